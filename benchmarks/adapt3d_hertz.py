"""Benchmark: adaptive against uniform refinement in 3D (P1) on the Hertz 3D quarter scene: the error of the total
force against unknowns and CPU seconds.

The scene is the Hertz 3D study's (cvxcontact/apps/studies/hertz3d.py: a rigid sphere, R = 20 mm, at Hertz's
approach for a = 1 mm, on the quarter block [0, 10 a]^2 x [-10 a, 0], its contact patch [0, 2 a]^2), started
from a uniform 4 x 4 x 4 grid (``hertz3d.scene(4, ratio=1)``: cells 2.5 a wide, the contact zone inside one).
Uniform: the start refined 0..``--levels`` times into eight. Adaptive: ``cc.adapt`` (theta 0.5, longest-edge
bisection) up to ``--cells`` tetrahedra. The read-out is the total force on the sphere (N, four quarters,
``hertz3d.total_force``), which the estimate does not see. Reference: the adaptive run's last mesh (the finest
answer at hand); printed beside it, the study's hand-graded grid of ``--graded`` cells per edge (graded 10:1
towards the contact point) against the same reference, and the last adaptive steps' increments, a measure of
the reference's own error. Per accuracy level (1, 2, 5 %): the first mesh of each series from which every later
one stays within it. Times: CPU seconds (``time.process_time``); adaptive: the sum over the steps up to that
mesh (solve, estimate, marking, bisection); uniform: its solve only (the mesh given). Run single-threaded for
the work alone:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/adapt3d_hertz.py

The numbers of a run are in docs/accuracy.md ("Adaptive refinement in 3D").
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d
from cvxcontact.geometry.refine import refine_uniform


def solve(scene):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        t = time.process_time()
        sol = cc.solve(scene)
        return sol, time.process_time() - t


def reached(rows, level):
    """The first row from which every later row's |error| stays <= level, or None."""
    for k, row in enumerate(rows):
        if all(abs(r["error"]) <= level for r in rows[k:]):
            return row
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=250_000, help="adaptive: most tetrahedra (the reference's mesh)")
    ap.add_argument("--levels", type=int, default=3, help="uniform: refinements of the start")
    ap.add_argument("--graded", type=int, default=32, help="cells per edge of the hand-graded grid (0: none)")
    args = ap.parse_args()
    print(f"cvxcontact {cc.__version__} from {cc.__file__}")
    base = hertz3d.scene(4, ratio=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        result = cc.adapt(base, theta=0.5, max_steps=60, max_cells=args.cells, keep=True)
    forces = [hertz3d.total_force(sol) for sol in result.solutions]
    F = forces[-1]
    print(f"reference: the last adaptive mesh, {result.history[-1].unknowns} unknowns, F = {F:.2f} N; the last "
          f"steps moved it by {', '.join(f'{b / a - 1:+.2%}' for a, b in zip(forces[-4:], forces[-3:]))}")
    if args.graded:
        graded, s = solve(hertz3d.scene(args.graded))
        print(f"hand-graded {args.graded}^3 grid: {graded.u[0].size} unknowns, F = {hertz3d.total_force(graded):.2f} N "
              f"({hertz3d.total_force(graded) / F - 1:+.2%}), {s:.1f} s")
    series = {"adaptive": [], "uniform": []}
    for step, force, cpu in zip(result.history, forces, np.cumsum([s.cpu_s for s in result.history])):
        series["adaptive"].append(dict(k=step.step, cells=step.cells, unknowns=step.unknowns, estimate=step.estimate,
                                       error=force / F - 1, cpu=cpu))
    for level in range(args.levels + 1):
        mesh = refine_uniform(base.bodies[0].mesh, level)[0]
        sol, s = solve(base.with_bodies(base.bodies[0].with_changes(mesh=mesh)))
        series["uniform"].append(dict(k=level, cells=len(mesh.tets), unknowns=sol.u[0].size,
                                      estimate=sol.estimate.absolute, error=hertz3d.total_force(sol) / F - 1, cpu=s))
    print("\n| mesh | cells | unknowns | estimate (sqrt(J)) | F_h / F_ref - 1 | CPU s |")
    print("|---|---:|---:|---:|---:|---:|")
    for kind, rows in series.items():
        for r in rows:
            print(f"| {kind} {'step' if kind == 'adaptive' else 'level'} {r['k']} | {r['cells']} | {r['unknowns']} | "
                  f"{r['estimate']:.4g} | {r['error']:+.2%} | {r['cpu']:.2f} |")
    print("\n| force within | adaptive: step, unknowns, CPU s | uniform: level, unknowns, CPU s |")
    print("|---|---|---|")
    for level in (0.05, 0.02, 0.01):
        cells = [reached(rows, level) for rows in series.values()]
        print(f"| {level:.0%} | " + " | ".join("not reached" if r is None else
                                             f"{r['k']}, {r['unknowns']}, {r['cpu']:.2f}" for r in cells) + " |")


if __name__ == "__main__":
    main()
