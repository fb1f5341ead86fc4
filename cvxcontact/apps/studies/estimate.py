"""Effectivity of the error estimate (docs/accuracy.md): estimate / true error on nested meshes.

For each scene and level l = 0, 1, 2 the scene's meshes are refined l times uniformly
(:func:`cvxcontact.geometry.refine.refine_uniform`: every triangle into four, every tetrahedron into eight,
straight midpoints, so the meshes are nested) and solved; the reference is the same scene refined
``REFERENCE`` times (two levels above the finest tested). The 3D scenes (:data:`SCENES3D`) run levels 0, 1
against a reference at level 3, the sphere levels 0, 1, 2 against level 4 in the full run (:data:`FULL3D`: the
sizes two shared cores allow). The true error of level l is measured in the reference's energy norm,

    |||(I u_l - u_ref, I phi_l - phi_ref)|||^2 = sum over bodies and fine cells of
        int c eps(e_u) : eps(e_u) + kappa grad e_phi . grad e_phi,

I the exact prolongation of the level's P1 (P2) functions onto the fine mesh's P1 (P2) nodes (:func:`prolong`:
each fine node evaluated in the coarse triangle that contains it; nested meshes, so I is the identity on
functions). Effectivity = ``sol.estimate.absolute`` / true error. The reference's own estimate is reported
beside it (its error is what the true errors of the finest level are uncertain by).

``run(out, quick=False)`` writes estimate.csv and estimate.md; ``quick`` runs levels 0, 1 against a reference
at level 3 (the test suite's configuration, tests/test_estimate.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...contact.laws import Coulomb, Tresca
from ...fem.space import space
from ...geometry.generators3d import box
from ...geometry.mesh import rectangle
from ...geometry.refine import refine_uniform
from ...physics import materials
from ...physics.pairs import Contact, Rigid
from ...physics.scene import Body, Scene
from ...solution.estimate import cell_energies
from .adapt import coarse_scene as hertz_coarse_scene
from .common import Timer, markdown_table, solve_quietly, write_csv, write_text

LEVELS = (0, 1, 2)
REFERENCE = 4
ALU = materials.isotropic(E=70e9, nu=0.33)


def circle_scene():
    """A rigid circle (R = 0.6 m) pressed 3 mm into an aluminium block 1 m x 0.5 m (24 x 6 cells), off-centre:
    the Hertz-like canonical scene "fixed circle" of tests/scenes.py."""
    block = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", contact="top",
                 name="block")
    return Scene(block, contacts=[Contact(block, "top", Rigid.circle((0.47, 0.5 + 0.6 - 3e-3), 0.6))])


def blocks_scene():
    """A PZT-5A block on an aluminium-like block, non-matching meshes (8 x 4 over 5 x 3), body force, a
    traction and a surface charge: "two blocks" of tests/scenes.py."""
    m1 = rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4, diagonal="alternate")
    m2 = rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=5, ny=3, diagonal="alternate")
    b1 = Body(m1, materials.PZT5A, clamped=["top"], contact="bottom", body_force=(0.0, -2e9),
              traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05}, grounded=["top"])
    b2 = Body(m2, materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top")
    return Scene(b1, b2)


def stack_scene(conditions=("sigma1", "sigma2")):
    """Three elastic blocks, two pairs with parabolic gaps ("three blocks, P2 nodal stack" of tests/scenes.py), the
    pairs under ``conditions`` (top/middle, middle/bottom)."""
    a, mat = 0.5, materials.isotropic(E=1e9, nu=0.3)
    top = Body(rectangle(x=(0, 1), y=(a, 2 * a), nx=4, ny=2), mat, clamped=["top"], contact="bottom",
               body_force=(0.0, -2e7), name="top")
    mid = Body(rectangle(x=(0, 1), y=(0, a), nx=3, ny=2), mat, clamped=["left"], contact="bottom", name="mid")
    bot = Body(rectangle(x=(0, 1), y=(-a, 0), nx=5, ny=2), mat, clamped=["bottom"], contact="top",
               body_force=(0.0, 1e7), name="bottom")
    pairs = [Contact(top, "bottom", mid, "top", gap=lambda s: -2e-5 + 1e-2 * (s - 0.6) ** 2, condition=conditions[0]),
             Contact(mid, "bottom", bot, "top", gap=lambda s: -3e-5 + 1e-2 * (s - 0.3) ** 2, condition=conditions[1])]
    return Scene(top, mid, bot, contacts=pairs)


def hertz_scene():
    """The Hertz cylinder of the hertz and adapt studies (:func:`.adapt.coarse_scene`: a steel cylinder of radius
    R = 2 m as the upper block 4 m x 2 m with the gap x^2 / (2 R) - 10 mm on an aluminium block), on uniform grids
    of 16 x 8 cells over 13 x 6, non-matching: the contact zone (about 0.42 m wide) spans two cells at level 0."""
    return hertz_coarse_scene(16)


def punch_scene():
    """A steel punch 0.6 m x 0.2 m (6 x 2 cells) whose bottom overlaps only [0.6, 1] of the top of an aluminium
    block 1 m x 0.5 m (8 x 4 cells), its top pushed down by 0.1 mm: a partial overlap, the contact ending at the
    punch's corner (x = 0.6) on one side and at the block's (x = 1) on the other."""
    steel = materials.isotropic(E=200e9, nu=0.3, name="steel")
    block = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4), ALU, clamped="bottom", contact="top",
                 name="block")
    punch = Body(rectangle(x=(0.6, 1.2), y=(0.5, 0.7), nx=6, ny=2), steel, contact="bottom",
                 displacement={"top": (0.0, -1e-4)}, name="punch")
    return Scene(punch, block, contacts=[Contact(punch, "bottom", block, "top")])


def floating_scene():
    """A PZT-5A layer 1 m x 0.2 m (10 x 2 cells), clamped and grounded along its bottom, its top a floating
    electrode with no net charge, pressed by a steel punch 0.2 m x 0.1 m (2 x 2 cells) on its footprint
    [0.4, 0.6] by a displacement of 2 um: the open-circuit force sensor of examples/punch_sensor.py."""
    steel = materials.isotropic(E=200e9, nu=0.3, name="steel")
    layer = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.2), nx=10, ny=2, segments={"footprint": ("top", 0.4, 0.6)}),
                 materials.PZT5A, clamped=["bottom"], grounded=["bottom"], floating={"top": 0.0},
                 contact="footprint", name="layer")
    punch = Body(rectangle(x=(0.4, 0.6), y=(0.2, 0.3), nx=2, ny=2), steel, contact="bottom",
                 displacement={"top": (0.0, -2e-6)}, name="punch")
    return Scene(punch, layer, contacts=[Contact(punch, "bottom", layer, "footprint")])


def sphere_scene():
    """A rigid sphere (R = 0.5 m) pressed 20 mm into an aluminium block 1 m x 1 m x 0.5 m (4 x 4 x 2 cubes of
    six tetrahedra), off-centre, clamped at the bottom: a partial contact."""
    block = Body(box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=4, ny=4, nz=2), ALU, clamped="bottom",
                 contact="top", name="block")
    return Scene(block, contacts=[Contact(block, "top", Rigid.sphere((0.47, 0.5, 0.5 + 0.5 - 0.02), 0.5))])


def boxes_scene():
    """A PZT-5A box on an aluminium-like box, non-matching faces (3 x 3 x 2 over 2 x 2 x 1 cubes), a body force
    and a surface charge, the top clamped and grounded: the 3D counterpart of "two blocks"."""
    top = Body(box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=3, ny=3, nz=2), materials.PZT5A, clamped=["top"],
               contact="bottom", body_force=(0.0, 0.0, -2e9), surface_charge={"left": -0.05}, grounded=["top"],
               name="pzt")
    bottom = Body(box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=2, ny=2, nz=1),
                  materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top", name="base")
    return Scene(top, bottom)


def sheared_scene(law):
    """A steel block 1 m x 0.5 m (8 x 4 cells) on a rigid floor under the traction (2, -10) MPa on its top, held
    by the friction ``law`` alone (tests/friction_scenes.py's ``sheared``): Tresca with g = 3 MPa or Coulomb
    with mu = 0.3 stick on the left of the base and slip on the right, the stick-slip transition inside it."""
    steel = materials.isotropic(E=200e9, nu=0.3, name="steel")
    block = Body(rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4), steel, contact="bottom",
                 traction={"top": (2e6, -1e7)}, name="block")
    return Scene(block, contacts=[Contact(block, "bottom", Rigid.plane((0.0, 0.0), (0.0, 1.0)), law=law)])


def sheared_box_scene(law):
    """A steel 1 m cube (3 x 3 x 2 cubes of six tetrahedra) on a rigid floor under the traction (1, 0.5, -10) MPa
    on its top, held by the friction ``law`` alone (tests/friction_scenes.py's ``box``): with Tresca's g = 5 MPa
    about a quarter of its base sticks."""
    steel = materials.isotropic(E=200e9, nu=0.3, name="steel")
    block = Body(box(nx=3, ny=3, nz=2), steel, contact="bottom", traction={"top": (1e6, 5e5, -1e7)}, name="box")
    return Scene(block, contacts=[Contact(block, "bottom", Rigid.plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), law=law)])


FRICTION_SCENES = {
    "sheared block, Tresca, P1": (lambda: sheared_scene(Tresca(3e6)), {"condition": "gamma3"}),
    "sheared block, Tresca, P2": (lambda: sheared_scene(Tresca(3e6)), {"condition": "sigma1", "degree": 2}),
    "sheared block, Coulomb, P1": (lambda: sheared_scene(Coulomb(0.3)), {"condition": "gamma3"}),
    "sheared box (3D), Tresca, P1": (lambda: sheared_box_scene(Tresca(5e6)), {"condition": "gamma3"}),
}
"""name -> (scene builder, solve keywords) of the friction laws' effectivity (benchmarks/friction_estimate.py)."""

SCENES3D = {
    "sphere (3D), P1": (sphere_scene, dict(condition="gamma3")),
    "two boxes (3D piezo), P1": (boxes_scene, dict(condition="gamma3")),
}
"""name -> (scene builder, solve keywords) in 3D: levels 0, 1 against a reference at level 3 (8^3 = 512 times
the cells of level 0) in both the full and the quick run."""

LEVELS3D, REFERENCE3D = (0, 1), 3

FULL3D = {"sphere (3D), P1": ((0, 1, 2), 4)}
"""name -> (levels, reference level) of the 3D scenes that the full run takes further: the sphere's level-4
reference (786,432 tetrahedra) takes 100 s and 4.7 GB (measured); the two boxes' (540,672 tetrahedra, a direct
factorisation of the piezoelectric pair and its polish) more than two shared cores allow, so they stay at
levels 0, 1 against level 3."""

SCENES = {
    "circle, P1": (circle_scene, dict(condition="gamma3")),
    "two blocks (piezo), P1": (blocks_scene, dict(condition="gamma3")),
    "two blocks (piezo), P2": (blocks_scene, dict(condition="sigma1", degree=2)),
    "stack, P2": (stack_scene, dict(condition="sigma1", degree=2)),
    "Hertz cylinder, P1": (hertz_scene, dict(condition="gamma3")),
    "Hertz cylinder, P2": (hertz_scene, dict(condition="sigma1", degree=2)),
    "punch, partial overlap, P1": (punch_scene, dict(condition="gamma3")),
    "punch, partial overlap, P2": (punch_scene, dict(condition="sigma1", degree=2)),
    "PZT layer, floating electrode, P1": (floating_scene, dict(condition="gamma3")),
    "PZT layer, floating electrode, P2": (floating_scene, dict(condition="sigma1", degree=2)),
}
"""name -> (scene builder, solve keywords)."""


def refined(scene: Scene, times: int) -> tuple[Scene, list]:
    """(the scene with every body's mesh refined ``times`` times uniformly, each body's parent map)."""
    if times == 0:
        return scene, [np.arange(len(b.mesh.cells)) for b in scene.bodies]
    meshes = [refine_uniform(b.mesh, times) for b in scene.bodies]
    bodies = [b.with_changes(mesh=m) for b, (m, _) in zip(scene.bodies, meshes)]
    return scene.with_bodies(*bodies), [p for _, p in meshes]


def prolong(values, coarse_mesh, fine_mesh, parent, degree: int) -> np.ndarray:
    """The coarse P1 (P2) nodal ``values`` (n_c, ...) evaluated at the fine mesh's P1 (P2) nodes: each fine
    cell's nodes in its coarse ``parent`` cell (triangle or tetrahedron; barycentric coordinates from the
    points), exact on nested meshes."""
    values = np.asarray(values, dtype=float)
    element = space(degree, fine_mesh.cell)
    fn, cn = element.node_set(fine_mesh), element.node_set(coarse_mesh)
    fine_el, fine_pts, coarse_el = fn.cells, fn.points, cn.cells
    P = coarse_mesh.points[coarse_mesh.cells[parent]]                          # (m_f, d + 1, d)
    T = (P[:, 1:] - P[:, :1]).transpose(0, 2, 1)                                # (m_f, d, d)
    X = fine_pts[fine_el] - P[:, None, 0]                                      # (m_f, k, d)
    lam = np.linalg.solve(T[:, None], X[..., None])[..., 0]                    # (m_f, k, d)
    L = np.concatenate([1.0 - lam.sum(axis=2, keepdims=True), lam], axis=2)    # (m_f, k, d + 1)
    N = element.shape_values(L)                                                # (m_f, k, k_c)
    coarse = values[coarse_el[parent]]                                         # (m_f, k_c, ...)
    out = np.zeros((len(fine_pts),) + values.shape[1:])
    out[fine_el.ravel()] = np.einsum("mkc,mc...->mk...", N, coarse).reshape((-1,) + values.shape[1:])
    return out


def true_error(sol, reference, parents) -> float:
    """|||(I u_h - u_ref, I phi_h - phi_ref)||| (sqrt(J/m)) in the reference's energy norm (module docstring);
    ``parents[k]``: the coarse cell of each of the reference's cells of body k."""
    total = 0.0
    for k, (bc, bf) in enumerate(zip(sol.scene.bodies, reference.scene.bodies)):
        eu = reference.u[k] - prolong(sol.u[k], bc.mesh, bf.mesh, parents[k], sol.degree)
        ep = None
        if sol.phi[k] is not None:
            ep = reference.phi[k] - prolong(sol.phi[k], bc.mesh, bf.mesh, parents[k], sol.degree)
        total += float(cell_energies(bf, eu, ep, sol.degree).sum())
    return float(np.sqrt(total))


def against_reference(build, options, levels, reference, measure, progress=None) -> list[dict]:
    """Effectivity against a nested reference, the loop both the estimate and the bound studies run: the scene
    ``build()`` refined ``reference`` times is solved with ``options`` (the reference), then refined each of
    ``levels`` times and solved; per level, the true error (:func:`true_error`) is handed with the solution and
    the reference to ``measure(sol, true_error, ref) -> (columns: dict, progress text)``. One row per level:
    level, cells, then ``measure``'s columns."""
    base = build()
    ref_scene, _ = refined(base, reference)
    if progress:
        progress(f"  reference: {sum(len(b.mesh.cells) for b in ref_scene.bodies)} cells")
    ref = solve_quietly(ref_scene, **options)
    rows = []
    for level in levels:
        scene, _ = refined(base, level)
        sol = solve_quietly(scene, **options)
        parents = [np.repeat(np.arange(len(b.mesh.cells)), 2 ** (scene.dim * (reference - level)))
                   for b in scene.bodies]
        columns, line = measure(sol, true_error(sol, ref, parents), ref)
        rows.append(dict(level=level, cells=sum(len(b.mesh.cells) for b in scene.bodies), **columns))
        if progress:
            progress(f"  level {level}: {line}")
    return rows


def measure_estimate(sol, err: float, ref) -> tuple[dict, str]:
    """The residual estimate's columns of a level (:func:`against_reference`): unknowns, estimate (absolute,
    relative), true error, effectivity, the solve's and the estimate's seconds, the reference's own estimate."""
    est = sol.estimate
    t = sol.timings
    solve_s = sum(v for k, v in t.items() if k != "estimate")
    columns = dict(unknowns=sum(u.size + (0 if p is None else p.size) for u, p in zip(sol.u, sol.phi)),
                   ok=sol.ok, estimate=est.absolute, relative=est.relative, true_error=err,
                   true_relative=err / est.norm, effectivity=est.absolute / err,
                   reference_estimate=ref.estimate.absolute, solve_s=solve_s, estimate_s=t["estimate"],
                   cost=t["estimate"] / solve_s)
    return columns, f"estimate {est.absolute:.4g}, true error {err:.4g}, effectivity {est.absolute / err:.3g}"


def effectivity(build, options, levels=LEVELS, reference=REFERENCE, progress=None) -> list[dict]:
    """One row per level (:func:`against_reference`, :func:`measure_estimate`): cells, unknowns, estimate
    (absolute, relative), true error, effectivity, the solve's and the estimate's seconds; the reference's own
    estimate in every row."""
    return against_reference(build, options, levels, reference, measure_estimate, progress)


def run(out, quick: bool = False, progress=None) -> dict:
    """Write estimate.csv and estimate.md into ``out`` (module docstring); returns {scene: rows}."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    levels, reference = ((0, 1), 3) if quick else (LEVELS, REFERENCE)
    timer = Timer()
    results, table = {}, []
    runs = [(name, entry, levels, reference) for name, entry in SCENES.items()]
    runs += [(name, entry) + (FULL3D.get(name, (LEVELS3D, REFERENCE3D)) if not quick else (LEVELS3D, REFERENCE3D))
             for name, entry in SCENES3D.items()]
    for name, (build, options), lv, ref in runs:
        if progress:
            progress(f"estimate: {name}")
        rows = effectivity(build, options, lv, ref, progress)
        results[name] = rows
        table += [dict(scene=name, **r, reference_level=ref) for r in rows]
    write_csv(out / "estimate.csv", table)
    columns = ["scene", "level", "cells", "unknowns", "estimate", "true_error", "effectivity", "relative",
               "true_relative", "reference_level", "reference_estimate", "cost"]
    formats = dict(estimate=".4g", true_error=".4g", effectivity=".3g", relative=".3g", true_relative=".3g",
                   reference_estimate=".4g", cost=".2f")
    summary = [dict(scene=n, lo=min(r["effectivity"] for r in rows), hi=max(r["effectivity"] for r in rows))
               for n, rows in results.items()]
    text = (f"# Effectivity of the error estimate\n\nGenerated by `cvxcontact study estimate{' --quick' if quick else ''}`"
            f" ({timer():.0f} s). 2D: levels {', '.join(map(str, levels))} against a reference at level {reference}; "
            f"3D: levels {', '.join(map(str, LEVELS3D))} against a reference at level {REFERENCE3D}"
            + ("" if quick else "".join(f", {n}: levels {', '.join(map(str, lv))} against level {r}"
                                        for n, (lv, r) in FULL3D.items()))
            + " (`reference_level`; uniform "
            "refinement, nested meshes: every triangle into 4, every tetrahedron into 8). Estimate and true error in "
            "sqrt(J/m) in 2D, sqrt(J) in 3D (energy norm of the coupled problem); `relative`: the estimate over the "
            "solution's own energy norm; `cost`: the estimate's seconds over the solve's.\n\n"
            + markdown_table(table, columns, formats)
            + "\n\nEffectivity range per scene:\n\n"
            + markdown_table(summary, ["scene", "lo", "hi"], dict(lo=".3g", hi=".3g")))
    write_text(out / "estimate.md", text)
    return results


FORCE_SCENES = {"circle, P2": (circle_scene, dict(condition="sigma1", degree=2)),
                **{name: SCENES[name] for name in ("circle, P1", "Hertz cylinder, P1", "Hertz cylinder, P2",
                                                   "punch, partial overlap, P1", "punch, partial overlap, P2")}}
"""name -> (scene builder, solve keywords) of the force estimate's study (:func:`force_effectivity`)."""


def measure_force(sol, err: float, ref) -> tuple[dict, str]:
    """The force estimate's columns of a level (:func:`against_reference`; ``err``, the energy error, unused):
    F_h (N/m), the reference's F, the true error |F_h - F_ref|, the estimate eta_F
    (:func:`cvxcontact.goal.force_estimate`), its effectivity, and the dual's held fraction."""
    from ...goal import force_estimate

    est = force_estimate(sol)
    force, force_ref = float(sol.contacts[0].force.sum()), float(ref.contacts[0].force.sum())
    true = abs(force - force_ref)
    columns = dict(force=force, reference_force=force_ref, true_error=true, estimate=est.absolute,
                   effectivity=est.absolute / true if true > 0 else float("inf"), held=est.held,
                   energy_error=err, energy_estimate=sol.estimate.absolute)
    return columns, (f"F {force:.6g}, true error {true:.4g}, estimate {est.absolute:.4g}, effectivity "
                     f"{columns['effectivity']:.3g}, held {est.held:.2f}")


def force_effectivity(build, options, levels=LEVELS, reference=REFERENCE, progress=None) -> list[dict]:
    """One row per level (:func:`against_reference`, :func:`measure_force`): the total contact force's error
    estimate against a nested reference."""
    return against_reference(build, options, levels, reference, measure_force, progress)
