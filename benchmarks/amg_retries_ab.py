"""A/B in one process: the AMG route's retry of steps that cycle on loose solves, on the tighter loose stages first
(``amg.RETRIES`` = (1.0, 1e-4, 0.0): the stages STEP_RTOLS, STEP_RTOLS[2:], (), :func:`amg.loose_stages`) against
tight solves at once ((1.0, 0.0): STEP_RTOLS, (), before).

Scene: ``two_boxes`` (tests/scenes3d.py, PZT-5A on aluminium, "sigma1"), sizes as counts of unknowns as in
benchmarks/bench3d.py (1.5e5: n = 38; 4e5: n = 52, 366,062 unknowns, where the loose steps cycle). Per size,
``--pairs`` pairs of solves, the two codes alternately (the order swapped every pair), a fresh ``ContactSolver``
each (the assembly apart): CPU seconds of ``solve`` (``time.process_time``), sets, Krylov iterations, and the
largest relative difference of u from the pair's other answer.

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/amg_retries_ab.py \\
        --sizes 1.5e5 4e5 --pairs 2
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench3d import cells


def main() -> None:
    from scenes3d import two_boxes

    import cvxcontact as cc
    from cvxcontact.backends import amg

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1.5e5, 4e5])
    ap.add_argument("--pairs", type=int, default=2)
    args = ap.parse_args()
    codes = {"before": (1.0, 0.0), "after": amg.RETRIES}        # ceilings of the loose stages (amg.loose_stages)
    cc.solve(two_boxes(4), method="amg")                                  # imports, first-call set-up
    for size in args.sizes:
        n = cells("two_boxes", size, False)
        cpu = {k: [] for k in codes}
        for pair in range(args.pairs):
            u = {}
            for code in (list(codes) if pair % 2 == 0 else list(codes)[::-1]):
                amg.RETRIES = codes[code]
                solver = cc.ContactSolver(two_boxes(n, "sigma1"), method="amg")
                c0 = time.process_time()
                sol = solver.solve()
                cpu[code].append(time.process_time() - c0)
                u[code] = np.concatenate([np.ravel(x) for x in sol.u])
                kc = solver.cache.amg
                print(f"n={n} ({kc.n:,} unknowns) pair {pair} {code}: {cpu[code][-1]:.2f} CPU s, "
                      f"{sol.info.iterations} sets, {kc.iterations} Krylov iterations, "
                      f"{int(solver.cache.active.sum())} rows closed, ok {sol.ok}", flush=True)
                del solver, sol
            d = np.linalg.norm(u["after"] - u["before"]) / np.linalg.norm(u["before"])
            print(f"  u after vs before: {d:.1e} relative", flush=True)
        print(f"n={n}: medians before {np.median(cpu['before']):.2f}, after {np.median(cpu['after']):.2f} CPU s")
    amg.RETRIES = codes["after"]


if __name__ == "__main__":
    main()
