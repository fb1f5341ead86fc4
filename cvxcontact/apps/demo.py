"""Built-in scenes for the command line's ``demo`` and for quick experiments."""

from __future__ import annotations

from ..physics import materials
from ..geometry.mesh import rectangle
from ..physics.scene import Body, Scene

__all__ = ["two_blocks", "DEMO_LOAD_SCALE"]

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
