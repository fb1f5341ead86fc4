"""Benchmark: force-controlled obstacles on the condensed route (cvxcontact/backends/forced.py) against the full
backend, on issue 30's punch (cvxcontact/apps/studies/adapt.py: a rigid cylinder, R = 50 mm, pressed with 1 kN/m
into an aluminium half block, P2 "gamma3", the cylinder force-controlled and guided along y).

1. One solve per route on the issue's hand-graded mesh (beta 9, gamma 8) of ``--nx`` x ``--ny`` cells (default
   100 x 50: 40,602 unknowns): CPU seconds of the whole solve, of the same solve with ``polish=False`` (no exact
   finish; the difference is the finish's CPU), the solver's timings (wall) of the interior point ("solve"),
   the exact finish ("polish") and the factorisation (condensed only), and the answers' largest differences
   (u, lambda_h, the translation).
2. The adapt call of tests/test_adapt_issue.py (``cc.adapt`` from the uniform 8 x 8 half block, tol 0.005,
   max_unknowns 50,000): its total CPU seconds with ``method="full"`` (the route it took before) and with the
   default (``auto``: now the condensed route), and the last step's solve.

CPU seconds by ``time.process_time`` (the two cores are shared: wall times are noisy). Run single-threaded:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/forced_finish.py

Results: benchmarks/results/forced_finish.md.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import cvxcontact as cc
from cvxcontact.apps.studies.adapt import punch_block, punch_scene


def rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def one_solve(nx: int, ny: int) -> None:
    scene = punch_scene(punch_block(nx, ny, 9.0, 8.0))
    sols = {}
    print(f"issue-30 punch, hand-graded {nx} x {ny}, P2 gamma3")
    print("| route | unknowns | CPU s | CPU s without the finish | finish CPU s | wall s: interior point, finish, "
          "factorisation | finish | ok |")
    print("|---|---|---|---|---|---|---|---|")
    for method in ("full", "condensed"):
        cpu = {}
        for polish in (False, True):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")      # (without the finish the checks fail: the interior point's)
                t = time.process_time()
                sol = cc.solve(scene, condition="gamma3", degree=2, method=method, polish=polish)
                cpu[polish] = time.process_time() - t
        sols[method] = sol
        tm = sol.info.timings
        n = sum(u.size for u in sol.u)
        print(f"| {method} | {n} | {cpu[True]:.2f} | {cpu[False]:.2f} | {cpu[True] - cpu[False]:.2f} | "
              f"{tm.get('solve', 0.0):.2f}, {tm.get('polish', 0.0):.2f}, {tm.get('factorization', 0.0):.2f} | "
              f"{sol.info.finish} | {sol.ok} |")
    a, b = sols["condensed"], sols["full"]
    print(f"\ncondensed against full: u {rel(a.u[0], b.u[0]):.1e}, lambda {rel(a.contact.lam, b.contact.lam):.1e}, "
          f"translation {rel(a.obstacles[0].translation, b.obstacles[0].translation):.1e}\n")


def adapt_call() -> None:
    print("tests/test_adapt_issue.py's adapt call")
    print("| method | CPU s | solves | last unknowns | last solve s (wall) | peak error | ok |")
    print("|---|---|---|---|---|---|---|")
    for method in ("full", "auto"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.process_time()
            result = cc.adapt(punch_scene(punch_block()), tol=0.005, condition="gamma3", degree=2,
                              max_unknowns=50_000, method=method)
            cpu = time.process_time() - t
        last = result.history[-1]
        F, E, nu, R = 1e3, 70e9, 0.33, 0.05
        a = np.sqrt(4 * F * R * (1 - nu ** 2) / (np.pi * E))
        p0 = 2 * F / (np.pi * a)
        print(f"| {method} ({result.solution.info.method}) | {cpu:.1f} | {len(result.history)} | {last.unknowns} | "
              f"{last.solve_s:.1f} | {last.peak / p0 - 1:+.1e} | {result.solution.ok} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nx", type=int, default=100)
    parser.add_argument("--ny", type=int, default=50)
    parser.add_argument("--skip-adapt", action="store_true")
    args = parser.parse_args()
    one_solve(args.nx, args.ny)
    if not args.skip_adapt:
        adapt_call()


if __name__ == "__main__":
    main()
