"""Built-in scenes for the command line's ``demo`` and for quick experiments."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError

from ..physics import materials
from ..geometry.generators import graded_block
from ..geometry.mesh import rectangle
from ..physics.scene import Body, Scene

__all__ = ["two_blocks", "thin_layer", "thin_layer_nodes", "DEMO_LOAD_SCALE"]

DEMO_LOAD_SCALE = 0.01
"""Load factor of ``cvxcontact demo``: the quickstart's loads / 100, so that the PZT-5A block stays in
its linear range (contact pressure about 2.3 MPa, field at most 0.1 kV/mm; docs/materials.md §5)."""


def two_blocks(nx=16, scale: float = 1.0) -> Scene:
    """A PZT-5A block (1 m x 0.5 m, clamped and grounded on top, body force, shear traction and
    surface charge) on an aluminium block (clamped at the bottom); non-matching meshes on y = 0
    (``nx`` and about 0.7 ``nx`` cells). At ``nx=16`` this is the README quickstart scene.

    ``scale`` multiplies every load (body force 2e9 N/m^3, traction 3e8 N/m^2, surface charge
    -0.05 C/m^2 at ``scale=1``). The quickstart's loads give a contact pressure of about 228 MPa and
    fields of several kV/mm, far beyond the linear range of a poled ceramic; ``cvxcontact demo``
    uses ``scale=DEMO_LOAD_SCALE`` (0.01). With zero gap the solution is linear in ``scale``.
    """
    s = float(scale)
    nx2 = max(2, round(0.7 * nx))
    upper = rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=max(1, nx // 2))
    lower = rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=nx2, ny=max(1, (nx2 + 1) // 2))
    b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom", name="PZT-5A block",
              body_force=(0.0, -2e9 * s), traction={"right": (0.0, 3e8 * s)}, surface_charge={"left": -0.05 * s})
    b2 = Body(lower, materials.isotropic(E=70e9, nu=0.3, name="aluminium"), clamped=["bottom"], contact="top",
              name="aluminium block")
    return Scene(b1, b2)


def thin_layer(n: int = 200, *, layer_ny: int = 4, substrate_ny: int = 16, thickness: float = 0.02,
               depth: float = 0.1, pressure: float = 1e6, voltage: float = 100.0, crown: float = 2e-5) -> Scene:
    """The long-interface scene (issue 13): a thin PZT-5A layer pressed onto a crowned aluminium substrate.

    Layer: x in [0, 1] m, y in [0, ``thickness``] m (default 0.02 m), ``n`` x ``layer_ny`` cells,
    clamped at both ends (``left``, ``right``: u = 0), electroded on both faces: the bottom electrode
    (on the contact face) grounded, the top one driven at ``voltage`` (V; 100 V: 5 kV/m through
    0.02 m), a uniform pressure ``pressure`` (Pa, default 1 MPa) on the top face pushing it down.
    Substrate: aluminium (E = 70 GPa, nu = 0.3), x in [0, 1] m, y in [-``depth``, 0] m, clamped at the
    bottom, a graded mesh (:func:`~cvxcontact.geometry.generators.graded_block`, exponential grading
    towards the contact line) of ``int(0.7 n) + 1`` x ``substrate_ny`` cells: non-matching meshes on
    y = 0 whose nodes coincide at gcd(n, int(0.7 n) + 1) + 1 points (the ends only at n = 3000); the merged line has
    :func:`thin_layer_nodes` nodes (5,101 at n = 3000). The gap is a crown,
    g(x) = ``crown`` (2x - 1)^2 (m; 20 um at the ends, 0 in the middle): the pressed layer closes on the
    middle of the substrate and stays open near its clamped ends, a genuine active set (3,872 of 5,101
    merged nodes closed at n = 3000; neither empty nor full; inside the closed zone the non-matching
    traces leave about one merged node in five open, a saw-tooth pattern). Both bodies are supported on
    their own (no rigid motion left to the contact). Linear range (n = 400): |sigma| <= 19 MPa in the
    layer (bending at the clamps), contact pressure <= 3 MPa, field 0.005 kV/mm.

    Unknowns: 3 (n + 1)(layer_ny + 1) in the layer (u, phi) and about 2 (0.7 n)(substrate_ny + 1) in the
    substrate, plus one per merged node in the sparse mixed system: 37,158 at n = 1000 and 111,358 at
    n = 3000 (defaults). What it exercises: a contact line with thousands of merged nodes, where a dense
    interface matrix (m x m) is what costs: the sparse route (:mod:`cvxcontact.backends.sparse`).
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise SceneError(f"thin_layer: n must be an int >= 2, got {n!r}")
    n2 = int(0.7 * n) + 1
    layer = rectangle(x=(0.0, 1.0), y=(0.0, float(thickness)), nx=n, ny=layer_ny)
    substrate = graded_block(x=(0.0, 1.0), y=(-float(depth), 0.0), nx=n2, ny=substrate_ny, contact="top",
                             gamma=5.0)
    p = float(pressure)
    b1 = Body(layer, materials.PZT5A, clamped=["left", "right"], grounded=["bottom"], potential={"top": voltage},
              contact="bottom", traction={"top": (0.0, -p)}, name="PZT-5A layer")
    b2 = Body(substrate, materials.isotropic(E=70e9, nu=0.3, name="aluminium"), clamped=["bottom"], contact="top",
              name="aluminium substrate")
    c = float(crown)
    return Scene(b1, b2, gap=lambda x: c * (2.0 * np.asarray(x) - 1.0) ** 2)


def thin_layer_nodes(n: int) -> int:
    """The number of merged contact nodes of :func:`thin_layer` ``(n)`` (the two traces meet only at the ends)."""
    n2 = int(0.7 * n) + 1
    return (n + 1) + (n2 + 1) - (math.gcd(n, n2) + 1)
