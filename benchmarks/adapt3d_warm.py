"""Benchmark: cc.adapt in 3D warm-started against cold, on benchmarks/adapt3d_hertz.py's scene (the Hertz 3D
quarter block from a uniform 4 x 4 x 4 grid, P1, theta 0.5) up to ``--cells`` tetrahedra.

Warm (the default): each step after the first starts its active set from the previous step's contact forces
(cvxcontact.backends.start: the nodal forces at the overlay's vertices, interpolated onto the new rows'
positions). Cold: ``warm_start=False`` (each step from the route's own start: an interior point on the
condensed route; on the sparse and AMG routes the rows the obstacle already closes, g <= 0). Per step: unknowns,
the route, its iterations (``sol.info.iterations``: the interior point's on the condensed route cold, else the
active-set steps), the rows of the first active set cold (sparse and AMG routes) and warm against the rows the
answer closes, the CPU seconds of the step (solve, estimate, marking, bisection) and the largest difference of u
and of the contact forces between the two answers (relative to their largest entry). Both runs in one process,
one thread:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/adapt3d_warm.py

The numbers of a run are in docs/accuracy.md ("Adaptive refinement in 3D").
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d
from cvxcontact.backends.signorini import cheap_start
from cvxcontact.backends.start import start_active


def relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(np.asarray(b)).max(), 1e-300))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=150_000, help="most tetrahedra")
    ap.add_argument("--method", default="auto", help="the backend of every solve (auto: AMG from 50,000 unknowns)")
    args = ap.parse_args()
    print(f"cvxcontact {cc.__version__} from {cc.__file__}")
    base = hertz3d.scene(4, ratio=1.0)
    runs = {}
    for warm in (False, True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cc.ResolutionWarning)
            runs[warm] = cc.adapt(base, theta=0.5, max_steps=60, max_cells=args.cells, keep=True, warm_start=warm,
                                method=args.method)
    cold, warm = runs[False], runs[True]
    print("\n| step | unknowns | route cold / warm | iterations cold / warm | first rows cold / warm / closed "
          "| CPU s cold / warm | u | forces |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|")
    previous = [None] + list(warm.solutions[:-1])
    for hc, hw, sc, sw, before in zip(cold.history, warm.history, cold.solutions, warm.solutions, previous):
        du = max(relative(a, b) for a, b in zip(sw.u, sc.u))
        dy = relative(sw.contact.force, sc.contact.force)
        problem = cc.ContactSolver(sw.scene, method=args.method).problem      # assembled, not solved
        first = cheap_start(problem)
        guess = "-" if before is None else int(start_active(problem, before.state).sum())
        print(f"| {hc.step} | {hc.unknowns} | {sc.info.route} / {sw.info.route} | {sc.info.iterations} / "
              f"{sw.info.iterations} | {'-' if first is None else int(first.sum())} / {guess} / "
              f"{int(sw.contact.active.sum())} | {hc.cpu_s:.2f} / {hw.cpu_s:.2f} | {du:.1e} | {dy:.1e} |")
    total = [sum(s.cpu_s for s in r.history) for r in (cold, warm)]
    steps = [sum(s.info.iterations for s in r.solutions[1:]) for r in (cold, warm)]
    print(f"\nall steps: CPU {total[0]:.1f} s cold, {total[1]:.1f} s warm ({total[1] / total[0]:.2f}); iterations "
          f"(interior point's or active-set steps) after the first solve {steps[0]} cold, {steps[1]} warm")


if __name__ == "__main__":
    main()
