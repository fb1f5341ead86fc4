"""The 3D default solve on a SciPy-only install (no oneMKL, no pyamg: ``pip install cvxcontact``), against the
bonded yardstick SciPy has: one SuperLU factorisation and solve of the bonded mixed system (every contact row
closed; benchmarks/harness.py ``bonded_system``). Scenes and sizes as bench3d.py's; each part runs in this
process one after the other (ratios within one run; wall and CPU seconds).

    python benchmarks/bench3d_scipy.py --sizes 2e4 5e4 1e5 [--scenes two_boxes sphere] [--md out.md]

Run it in an environment without pyamg and mkl to measure what such an install does (the script says which
factorisation and route the default solve took).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench3d import cells, make
from harness import bonded_system, residual, unknowns, write_report


def superlu_bonded(problem):
    """SuperLU as the package's sparse route uses it (its fill-reducing quasi-definite order, no pivoting:
    ``cvxcontact.backends.elimination.ordering``), order + factorisation + solve of the bonded system."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.elimination import ordering
    from cvxcontact.backends.factor import SUPERLU_OPTIONS

    K, rhs, A, _, _ = bonded_system(problem)
    rows = np.arange(A.shape[0], K.shape[0])                               # the closed rows come last in K
    t0, c0 = time.perf_counter(), time.process_time()
    perm = ordering(K, rows)
    lu = spla.splu(K[perm][:, perm].tocsc(), **SUPERLU_OPTIONS)
    z = np.empty_like(rhs)
    z[perm] = lu.solve(rhs[perm])
    return time.perf_counter() - t0, time.process_time() - c0, residual(K, z, rhs)


def main(argv=None):
    from importlib.util import find_spec

    import cvxcontact as cc

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", type=float, default=[2e4, 5e4])
    ap.add_argument("--scenes", nargs="+", default=["two_boxes"], choices=["two_boxes", "sphere"])
    ap.add_argument("--md", type=Path, default=None)
    args = ap.parse_args(argv)
    extras = [m for m in ("pyamg", "mkl") if find_spec(m) is not None]
    print(f"optional packages present: {extras or 'none'}", flush=True)
    cc.solve(make("two_boxes", 4, "sigma1", True))                         # imports, first-call set-up
    lines = ["| scene | unknowns | default s (CPU) | route | SuperLU bonded s (CPU) | ratio | ok |",
             "|---|---|---|---|---|---|---|"]
    for scene in args.scenes:
        for size in args.sizes:
            n = cells(scene, size, True)
            sc = make(scene, n, "sigma1", True)
            t0, c0 = time.perf_counter(), time.process_time()
            solver = cc.ContactSolver(sc)
            sol = solver.solve()
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            asm = float(dict(sol.timings).get("assembly", 0.0))
            N = unknowns(solver.problem)
            ts, tc, res = superlu_bonded(solver.problem)
            route = f"{sol.info.method}, {sol.info.route}, {sol.info.factorization or '-'}"
            line = (f"| {scene} | {N:.2e} | {wall - asm:.1f} ({cpu:.1f}) | {route} | {ts:.1f} ({tc:.1f}) | "
                    f"{(wall - asm) / ts:.2f} | {sol.ok} |")
            print(line, f"(SuperLU residual {res:.1e})", flush=True)
            lines.append(line)
            del solver, sol
    if args.md:
        write_report(args.md, lines)


if __name__ == "__main__":
    main()
