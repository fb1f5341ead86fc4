"""Effectivity of the error estimate (docs/accuracy.md): estimate / true error on nested meshes.

For each scene and level l = 0, 1, 2 the scene's meshes are refined l times uniformly
(:func:`cvxcontact.geometry.refine.refine_uniform`: every triangle into four, straight midpoints, so the
meshes are nested) and solved; the reference is the same scene refined ``REFERENCE`` times (two levels
above the finest tested). The true error of level l is measured in the reference's energy norm,

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

from ...fem.p2 import shape_functions
from ...geometry.mesh import rectangle
from ...geometry.quadratic import P2Nodes
from ...geometry.refine import refine_uniform
from ...physics import materials
from ...physics.pairs import Contact, Rigid
from ...physics.scene import Body, Scene
from ...solution.estimate import cell_energies
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


def stack_scene():
    """Three elastic blocks, two pairs with parabolic gaps ("three blocks, P2 nodal stack" of tests/scenes.py)."""
    a, mat = 0.5, materials.isotropic(E=1e9, nu=0.3)
    top = Body(rectangle(x=(0, 1), y=(a, 2 * a), nx=4, ny=2), mat, clamped=["top"], contact="bottom",
               body_force=(0.0, -2e7), name="top")
    mid = Body(rectangle(x=(0, 1), y=(0, a), nx=3, ny=2), mat, clamped=["left"], contact="bottom", name="mid")
    bot = Body(rectangle(x=(0, 1), y=(-a, 0), nx=5, ny=2), mat, clamped=["bottom"], contact="top",
               body_force=(0.0, 1e7), name="bottom")
    pairs = [Contact(top, "bottom", mid, "top", gap=lambda s: -2e-5 + 1e-2 * (s - 0.6) ** 2, condition="sigma1"),
             Contact(mid, "bottom", bot, "top", gap=lambda s: -3e-5 + 1e-2 * (s - 0.3) ** 2, condition="sigma2")]
    return Scene(top, mid, bot, contacts=pairs)


SCENES = {
    "circle, P1": (circle_scene, dict(condition="gamma3")),
    "two blocks (piezo), P1": (blocks_scene, dict(condition="gamma3")),
    "two blocks (piezo), P2": (blocks_scene, dict(condition="sigma1", degree=2)),
    "stack, P2": (stack_scene, dict(condition="sigma1", degree=2)),
}
"""name -> (scene builder, solve keywords)."""


def refined(scene: Scene, times: int) -> tuple[Scene, list]:
    """(the scene with every body's mesh refined ``times`` times uniformly, each body's parent map)."""
    if times == 0:
        return scene, [np.arange(len(b.mesh.triangles)) for b in scene.bodies]
    meshes = [refine_uniform(b.mesh, times) for b in scene.bodies]
    bodies = [b.with_changes(mesh=m) for b, (m, _) in zip(scene.bodies, meshes)]
    return scene.with_bodies(*bodies), [p for _, p in meshes]


def prolong(values, coarse_mesh, fine_mesh, parent, degree: int) -> np.ndarray:
    """The coarse P1 (P2) nodal ``values`` (n_c, ...) evaluated at the fine mesh's P1 (P2) nodes: each fine
    cell's nodes in its coarse ``parent`` triangle (barycentric coordinates from the points), exact on nested
    meshes."""
    values = np.asarray(values, dtype=float)
    if degree == 1:
        fine_el, fine_pts, coarse_el = fine_mesh.triangles, fine_mesh.points, coarse_mesh.triangles
    else:
        fn, cn = P2Nodes(fine_mesh), P2Nodes(coarse_mesh)
        fine_el, fine_pts, coarse_el = fn.triangles, fn.points, cn.triangles
    P = coarse_mesh.points[coarse_mesh.triangles[parent]]                     # (m_f, 3, 2)
    T = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)               # (m_f, 2, 2)
    X = fine_pts[fine_el] - P[:, None, 0]                                      # (m_f, k, 2)
    lam = np.linalg.solve(T[:, None], X[..., None])[..., 0]                    # (m_f, k, 2)
    L = np.concatenate([1.0 - lam.sum(axis=2, keepdims=True), lam], axis=2)    # (m_f, k, 3)
    N = L if degree == 1 else shape_functions(L)                               # (m_f, k, k_c)
    coarse = values[coarse_el[parent]]                                         # (m_f, k_c, ...)
    out = np.zeros((len(fine_pts),) + values.shape[1:])
    out[fine_el.ravel()] = np.einsum("mkc,mc...->mk...", N, coarse).reshape((-1,) + values.shape[1:])
    return out


def true_error(sol, reference, parents) -> float:
    """|||(I u_h - u_ref, I phi_h - phi_ref)||| (sqrt(J/m)) in the reference's energy norm (module docstring);
    ``parents[k]``: the coarse triangle of each of the reference's triangles of body k."""
    total = 0.0
    for k, (bc, bf) in enumerate(zip(sol.scene.bodies, reference.scene.bodies)):
        eu = reference.u[k] - prolong(sol.u[k], bc.mesh, bf.mesh, parents[k], sol.degree)
        ep = None
        if sol.phi[k] is not None:
            ep = reference.phi[k] - prolong(sol.phi[k], bc.mesh, bf.mesh, parents[k], sol.degree)
        total += float(cell_energies(bf, eu, ep, sol.degree).sum())
    return float(np.sqrt(total))


def effectivity(build, options, levels=LEVELS, reference=REFERENCE, progress=None) -> list[dict]:
    """One row per level: cells, unknowns, estimate (absolute, relative), true error, effectivity, the solve's
    and the estimate's seconds; the reference's own estimate in every row."""
    base = build()
    ref_scene, _ = refined(base, reference)
    if progress:
        progress(f"  reference: {sum(len(b.mesh.triangles) for b in ref_scene.bodies)} cells")
    ref = solve_quietly(ref_scene, **options)
    rows = []
    for level in levels:
        scene, _ = refined(base, level)
        sol = solve_quietly(scene, **options)
        parents = [np.repeat(np.arange(len(b.mesh.triangles)), 4 ** (reference - level)) for b in scene.bodies]
        err = true_error(sol, ref, parents)
        est = sol.estimate
        t = sol.timings
        solve_s = sum(v for k, v in t.items() if k != "estimate")
        rows.append(dict(level=level, cells=sum(len(b.mesh.triangles) for b in scene.bodies),
                         unknowns=sum(u.size + (0 if p is None else p.size) for u, p in zip(sol.u, sol.phi)),
                         ok=sol.ok, estimate=est.absolute, relative=est.relative, true_error=err,
                         true_relative=err / est.norm, effectivity=est.absolute / err,
                         reference_estimate=ref.estimate.absolute, solve_s=solve_s, estimate_s=t["estimate"],
                         cost=t["estimate"] / solve_s))
        if progress:
            progress(f"  level {level}: estimate {est.absolute:.4g}, true error {err:.4g}, "
                     f"effectivity {est.absolute / err:.3g}")
    return rows


def run(out, quick: bool = False, progress=None) -> dict:
    """Write estimate.csv and estimate.md into ``out`` (module docstring); returns {scene: rows}."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    levels, reference = ((0, 1), 3) if quick else (LEVELS, REFERENCE)
    timer = Timer()
    results, table = {}, []
    for name, (build, options) in SCENES.items():
        if progress:
            progress(f"estimate: {name}")
        rows = effectivity(build, options, levels, reference, progress)
        results[name] = rows
        table += [dict(scene=name, **r) for r in rows]
    write_csv(out / "estimate.csv", table)
    columns = ["scene", "level", "cells", "unknowns", "estimate", "true_error", "effectivity", "relative",
               "true_relative", "reference_estimate", "cost"]
    formats = dict(estimate=".4g", true_error=".4g", effectivity=".3g", relative=".3g", true_relative=".3g",
                   reference_estimate=".4g", cost=".2f")
    summary = [dict(scene=n, lo=min(r["effectivity"] for r in rows), hi=max(r["effectivity"] for r in rows))
               for n, rows in results.items()]
    text = (f"# Effectivity of the error estimate\n\nGenerated by `cvxcontact study estimate{' --quick' if quick else ''}`"
            f" ({timer():.0f} s). Levels {', '.join(map(str, levels))} against a reference at level {reference} "
            "(uniform refinement, nested meshes). Estimate and true error in sqrt(J/m) (energy norm of the coupled "
            "problem); `relative`: the estimate over the solution's own energy norm; `cost`: the estimate's "
            "seconds over the solve's.\n\n"
            + markdown_table(table, columns, formats)
            + "\n\nEffectivity range per scene:\n\n"
            + markdown_table(summary, ["scene", "lo", "hi"], dict(lo=".3g", hi=".3g")))
    write_text(out / "estimate.md", text)
    return results
