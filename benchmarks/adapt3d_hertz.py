"""Benchmark: adaptive against uniform refinement in 3D (P1) on the Hertz 3D quarter scene: the error of the total
force against unknowns and CPU seconds.

The scene is the Hertz 3D study's (cvxcontact/apps/studies/hertz3d.py: a rigid sphere, R = 20 mm, at Hertz's
approach for a = 1 mm, on the quarter block [0, 10 a]^2 x [-10 a, 0], its contact patch [0, 2 a]^2), started
from a uniform 4 x 4 x 4 grid (``hertz3d.scene(4, ratio=1)``: cells 2.5 a wide, the contact zone inside one).
Uniform: the start refined 0..``--levels`` times into eight. Adaptive: ``cc.adapt`` (theta 0.5, longest-edge
bisection) up to ``--cells`` tetrahedra. Reference: the study's hand-graded grid of ``--reference`` cells per edge
(graded 10:1 towards the contact point; also printed: its distance to the grid of 3/4 the cells per edge, a
measure of its own error). The read-out is the total force on the sphere (N, four quarters,
``hertz3d.total_force``): the estimate does not see it. Times: CPU seconds (``time.process_time``); adaptive:
the sum over the steps up to that mesh (solve, estimate, marking, bisection); uniform: its solve only (the mesh
given). Run single-threaded for the work alone:

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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=70_000, help="adaptive: most tetrahedra")
    ap.add_argument("--levels", type=int, default=2, help="uniform: refinements of the start")
    ap.add_argument("--reference", type=int, default=32, help="cells per edge of the graded reference")
    args = ap.parse_args()
    print(f"cvxcontact {cc.__version__} from {cc.__file__}")
    ref, ref_s = solve(hertz3d.scene(args.reference))
    coarser, _ = solve(hertz3d.scene(args.reference * 3 // 4))
    F = hertz3d.total_force(ref)
    print(f"reference: graded {args.reference}^3, {ref.u[0].size} unknowns, F = {F:.2f} N ({ref_s:.1f} s); "
          f"graded {args.reference * 3 // 4}^3: {hertz3d.total_force(coarser) / F - 1:+.2%}")
    base = hertz3d.scene(4, ratio=1.0)
    rows = []
    for level in range(args.levels + 1):
        mesh = refine_uniform(base.bodies[0].mesh, level)[0]
        sol, s = solve(base.with_bodies(base.bodies[0].with_changes(mesh=mesh)))
        rows.append(("uniform", level, len(mesh.tets), sol.u[0].size, sol.estimate.absolute,
                     hertz3d.total_force(sol) / F - 1, s))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        result = cc.adapt(base, theta=0.5, max_steps=60, max_cells=args.cells, keep=True)
    cpu = np.cumsum([s.cpu_s for s in result.history])
    for step, sol, s in zip(result.history, result.solutions, cpu):
        rows.append(("adaptive", step.step, step.cells, step.unknowns, step.estimate,
                     hertz3d.total_force(sol) / F - 1, s))
    print("| refinement | level/step | cells | unknowns | estimate (sqrt(J)) | F_h / F_ref - 1 | CPU s |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for kind, k, cells, unknowns, est, err, s in rows:
        print(f"| {kind} | {k} | {cells} | {unknowns} | {est:.4g} | {err:+.2%} | {s:.2f} |")


if __name__ == "__main__":
    main()
