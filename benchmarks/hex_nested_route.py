"""Benchmark: Q1 hexahedra, "gamma3" between nested faces (n x n faces on n/2 x n/2) on the route the space picks
(the rows marked independent, ``ContactLines.independent``: the nodal rows' route) against the same rows finished as
possibly dependent (the route of "gamma3" overlay rows, the mark switched off here), and the finer side's nodal
rows ("sigma1"), which are the same rows; and "gamma3" on aligned crossing grids (3n/4 x 3n/4 on n/2 x n/2: the
pieces' corners, rows that do depend on each other). A lower block clamped on its bottom, an upper one pushed down
by 6 um at its top (held in its plane), an affine gap 1 to 12 um (part of the faces open):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests python benchmarks/hex_nested_route.py

Results: benchmarks/results/hex_nested_route.md (CPU seconds of ``cc.solve``; the largest difference of the
displacements from the first column's, relative to the largest displacement).
"""

from __future__ import annotations

import time

import numpy as np
from hex_scenes import block, pair

import cvxcontact as cc
import cvxcontact.fem.space as space_module

GAP = lambda s1, s2: 1e-6 + 8e-6 * s1 + 3e-6 * s2


def solve(scene, condition, independent=True):
    """(solution, CPU s) of ``scene`` under ``condition``; ``independent=False`` withholds the space's mark."""
    marked = space_module.independent_rows
    if not independent:
        space_module.independent_rows = lambda *args: False
    try:
        t = time.process_time()
        sol = cc.solve(scene, condition)
        return sol, time.process_time() - t
    finally:
        space_module.independent_rows = marked


def main():
    print("| faces (lower on upper) | rows | gamma3, marked: cpu s | as dependent: cpu s | sigma1: cpu s | "
          "max diff | finishes |")
    print("|---|---|---|---|---|---|---|")
    for n in (16, 32, 64):
        scene = pair(block(n, (0.0, 0.5)), block(n // 2, (0.5, 1.0)), gap=GAP, rollers=False, push=6e-6)
        runs = [solve(scene, "gamma3"), solve(scene, "gamma3", independent=False), solve(scene, "sigma1")]
        scale = max(np.abs(u).max() for u in runs[0][0].u)
        diff = max(np.abs(s.u[k] - runs[0][0].u[k]).max() for s, _ in runs[1:] for k in (0, 1)) / scale
        assert all(s.ok for s, _ in runs)
        print(f"| {n} x {n} on {n // 2} x {n // 2} | {(n + 1) ** 2} | "
              f"{runs[0][1]:.1f} | {runs[1][1]:.1f} | {runs[2][1]:.1f} | {diff:.1e} | "
              f"{', '.join(s.info.finish for s, _ in runs)} |")
    print()
    print("| faces (lower on upper) | gamma3 (pieces' corners): cpu s | finish |")
    print("|---|---|---|")
    for n in (16, 32, 64):
        m = 3 * n // 4
        scene = pair(block(m, (0.0, 0.5)), block(n // 2, (0.5, 1.0)), gap=GAP, rollers=False, push=6e-6)
        sol, cpu = solve(scene, "gamma3")
        assert sol.ok
        print(f"| {m} x {m} on {n // 2} x {n // 2} | {cpu:.1f} | {sol.info.finish} |")


if __name__ == "__main__":
    main()
