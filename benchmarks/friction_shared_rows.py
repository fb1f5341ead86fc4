"""Benchmark: the friction finish's independent subset of rows that may depend on each other, chosen group by group
of rows linked by common unknowns (``backends.finish.friction._kept``) against one column-pivoted QR of every
closed and stuck row (``_basis`` of all of them, the choice before). The rows are those the finish meets on a 3D
floor and wall sharing an edge (tests/friction_scenes.cornered3d, P1 tetrahedra, n x n x 2 cells, Tresca with a
threshold scaled as 1/n^2): the first row set of each solve is captured and both choices are timed on it:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests python \
        benchmarks/friction_shared_rows.py

Results: benchmarks/results/friction_shared_rows.md (CPU seconds of one choice; whether the two choose the same
rows; CPU seconds of the whole ``cc.solve``).
"""

from __future__ import annotations

import time

import numpy as np
from friction_scenes import P, cornered3d

import cvxcontact as cc
import cvxcontact.backends.finish.friction as finish


def main():
    print("| n | closed and stuck rows | groups | by group: cpu s | one QR: cpu s | same rows | solve: cpu s |")
    print("|---|---|---|---|---|---|---|")
    kept = finish._kept
    for n in (12, 24, 36, 48):
        seen = []

        def spy(M, weight, seen=seen):
            if not seen:
                seen.append((M.copy(), weight.copy()))
            return kept(M, weight)

        finish._kept = spy
        try:
            t = time.process_time()
            sol = cc.solve(cornered3d(cc.Tresca(0.3 * P * (3 / n) ** 2), n=n)[1])
            solve = time.process_time() - t
        finally:
            finish._kept = kept
        assert sol.ok and seen
        M, weight = seen[0]
        t = time.process_time()
        grouped = kept(M, weight)
        by_group = time.process_time() - t
        t = time.process_time()
        whole = finish._basis(M, weight)
        one = time.process_time() - t
        groups = len(finish._linked(M))
        print(f"| {n} | {M.shape[0]} | {groups} | {by_group:.3f} | {one:.2f} | {np.array_equal(grouped, whole)} | "
              f"{solve:.1f} |")


if __name__ == "__main__":
    main()
