"""Effectivity of the guaranteed error bound (:func:`cvxcontact.error_bound`, docs/accuracy.md): bound / true
error on nested meshes, as :mod:`cvxcontact.apps.studies.estimate` measures the residual estimate (same
refinement, prolongation and energy norm; the reference ``REFERENCE`` levels up). A guaranteed bound reads
>= 1 up to the reference's own error (its residual estimate is reported beside it).

``run(out, quick=False)`` writes bound.csv and bound.md; ``quick`` runs levels 0, 1 against a reference at
level 3.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ...geometry.mesh import rectangle
from ...physics import materials
from ...physics.pairs import Contact, Rigid
from ...physics.scene import Body, Scene
from ...solution.bound import error_bound
from .common import Timer, markdown_table, write_csv, write_text
from .estimate import (ALU, LEVELS, REFERENCE, against_reference, blocks_scene, floating_scene, hertz_scene,
                       punch_scene)
from .estimate import stack_scene as estimate_stack_scene


def circle_scene(distance: str = "ray"):
    """The estimate study's circle (R = 0.6 m pressed 3 mm into an aluminium block 1 m x 0.5 m, 24 x 6 cells),
    its rows along the block's normal (``distance="ray"``: the bound needs one row direction per part)."""
    block = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", contact="top",
                 name="block")
    return Scene(block, contacts=[Contact(block, "top", Rigid.circle((0.47, 0.5 + 0.6 - 3e-3), 0.6, distance=distance))])


def crowned_scene():
    """An aluminium block 1 m x 0.5 m (12 x 6 cells) on a rigid plane, its bottom crowned (initial gap
    2e-3 (s - 0.5)^2 m), its top pushed down 0.1 mm, under a body force (0, -1e8) N/m^3 and a traction
    (2e6, 0) Pa on its right side: a contact zone of about 0.45 m."""
    block = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=12, ny=6), ALU, displacement={"top": (0.0, -1e-4)},
                 contact="bottom", body_force=(0.0, -1e8), traction={"right": (2e6, 0.0)}, name="block")
    return Scene(block, contacts=[Contact(block, "bottom", Rigid.plane((0.0, 0.0), (0.0, 1.0)),
                                          gap=lambda s: 2e-3 * (s - 0.5) ** 2)])


def floating_layer_scene():
    """A PZT-5A layer 1 m x 0.2 m (20 x 4 cells), clamped and grounded along its bottom, its top a floating
    electrode with no net charge, pressed by a rigid circle (R = 1 m, 1 mm deep, rows along the layer's normal):
    the estimate study's open-circuit sensor with the punch made rigid (the bound covers one body)."""
    layer = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.2), nx=20, ny=4), materials.PZT5A, clamped=["bottom"],
                 grounded=["bottom"], floating={"top": 0.0}, contact="top", name="layer")
    return Scene(layer, contacts=[Contact(layer, "top", Rigid.circle((0.5, 0.2 + 1.0 - 1e-3), 1.0, distance="ray"))])


def charged_block_scene():
    """A PZT-5A block 1 m x 0.5 m (12 x 6 cells) on a rigid plane, its bottom crowned (initial gap
    2e-3 (s - 0.5)^2 m), its top pushed down 0.1 mm and grounded, under a body force (0, -1e8) N/m^3, a volume
    charge 0.05 C/m^3, a surface charge -0.05 C/m^2 on its left side and a traction (2e6, 0) Pa on its right:
    the crowned block made piezoelectric, with the charges of the estimate study's two blocks."""
    block = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=12, ny=6), materials.PZT5A,
                 displacement={"top": (0.0, -1e-4)}, grounded=["top"], contact="bottom", body_force=(0.0, -1e8),
                 volume_charge=0.05, surface_charge={"left": -0.05}, traction={"right": (2e6, 0.0)}, name="block")
    return Scene(block, contacts=[Contact(block, "bottom", Rigid.plane((0.0, 0.0), (0.0, 1.0)),
                                          gap=lambda s: 2e-3 * (s - 0.5) ** 2)])


def stack_scene():
    """Three elastic blocks, two pairs with parabolic gaps, non-matching meshes (4 x 2 over 3 x 2 over 5 x 2): the
    estimate study's stack (:func:`.estimate.stack_scene`) with the bound's condition, gamma3, on both pairs."""
    return estimate_stack_scene(conditions=("gamma3", "gamma3"))


SCENES = {
    "circle (ray), P1": (circle_scene, dict(condition="gamma3")),
    "crowned block on a plane, P1": (crowned_scene, dict(condition="gamma3")),
    "PZT layer, floating electrode, rigid circle, P1": (floating_layer_scene, dict(condition="gamma3")),
    "PZT block, charges, crowned on a plane, P1": (charged_block_scene, dict(condition="gamma3")),
    "punch, partial overlap (pair), P1": (punch_scene, dict(condition="gamma3")),
    "Hertz cylinder (pair), P1": (hertz_scene, dict(condition="gamma3")),
    "stack of three (two pairs), P1": (stack_scene, dict(condition="gamma3")),
    "two blocks (piezo pair), P1": (blocks_scene, dict(condition="gamma3")),
    "PZT layer, floating electrode, punch (pair), P1": (floating_scene, dict(condition="gamma3")),
}
"""name -> (scene builder, solve keywords)."""


def measure_bound(sol, err: float, ref) -> tuple[dict, str]:
    """The bound's columns of a level (:func:`.estimate.against_reference`): the bound and its parts, the true
    error, effectivity (bound / true error), the residual estimate's effectivity beside it, the reference's
    residual estimate, the bound's cost over the solve's."""
    t0 = time.perf_counter()
    b = error_bound(sol)
    bound_s = time.perf_counter() - t0
    solve_s = sum(v for k, v in sol.timings.items() if k != "estimate")
    columns = dict(ok=sol.ok, bound=b.absolute, relative=b.relative, stress=np.sqrt(b.parts["stress"]),
                   electric=np.sqrt(b.parts["electric"]),
                   complementarity=np.sqrt(max(b.parts["complementarity"], 0.0)),
                   correction=b.parts["correction"], equilibrium=b.parts["equilibrium residual"],
                   true_error=err, effectivity=b.absolute / err, residual_effectivity=sol.estimate.absolute / err,
                   reference_estimate=ref.estimate.absolute, cost=bound_s / solve_s)
    return columns, f"bound {b.absolute:.4g}, true error {err:.4g}, effectivity {b.absolute / err:.3g}"


def effectivity(build, options, levels=LEVELS, reference=REFERENCE, progress=None) -> list[dict]:
    """One row per level (:func:`.estimate.against_reference`, :func:`measure_bound`)."""
    return against_reference(build, options, levels, reference, measure_bound, progress)


def run(out, quick: bool = False, progress=None) -> dict:
    """Write bound.csv and bound.md into ``out`` (module docstring); returns {scene: rows}."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    levels, reference = ((0, 1), 3) if quick else (LEVELS, REFERENCE)
    timer = Timer()
    results, table = {}, []
    for name, (build, options) in SCENES.items():
        if progress:
            progress(f"bound: {name}")
        results[name] = rows = effectivity(build, options, levels, reference, progress)
        table += [dict(scene=name, **r) for r in rows]
    write_csv(out / "bound.csv", table)
    columns = ["scene", "level", "cells", "bound", "true_error", "effectivity", "residual_effectivity", "stress",
               "electric", "complementarity", "correction", "equilibrium", "reference_estimate", "cost"]
    formats = dict(bound=".4g", true_error=".4g", effectivity=".3g", residual_effectivity=".3g", stress=".4g",
                   electric=".4g",
                   complementarity=".4g", correction=".4g", equilibrium=".1e", reference_estimate=".4g", cost=".2f")
    text = (f"# Effectivity of the guaranteed error bound\n\nGenerated by `cvxcontact study bound"
            f"{' --quick' if quick else ''}` ({timer():.0f} s). Levels {', '.join(map(str, levels))} against a "
            f"reference at level {reference} (uniform refinement, nested meshes). Bound and true error in sqrt(J/m) "
            "(the coupled energy norm of (u, phi) for the piezoelectric scenes); `stress`, `electric`, "
            "`complementarity`: the square roots of the bound's three terms (`electric` 0 on elastic bodies), "
            "`correction`: |||w||| of the feasible displacement; `equilibrium`: the relative residual of the "
            "stress's (and the electric displacement's) conditions; "
            "`residual_effectivity`: the residual estimate's, for comparison; `reference_estimate`: the reference's "
            "residual estimate (what the true errors are uncertain by); `cost`: the bound's seconds over the "
            "solve's.\n\n" + markdown_table(table, columns, formats))
    write_text(out / "bound.md", text)
    return results
