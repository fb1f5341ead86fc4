"""Benchmark: :class:`~cvxcontact.backends.finish.CholeskySystem` (W_PP of the dependent-rows finish, 3D
"gamma3" on the condensed route) when keys leave at once: t deletions by rank-one updates of the factor
(``_update``) against a fresh Cholesky factorisation (``refactor``), on a random symmetric positive definite
matrix of r keys, in CPU seconds (``time.process_time``), one thread. The rule of ``CholeskySystem.solve``
refactorises where more than 2 + r // 1000 keys leave.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_cholesky_leaves.py
"""
from __future__ import annotations

import time

import numpy as np

from cvxcontact.backends.finish import CholeskySystem


def main(sizes=(1000, 3000), leaves=(1, 3, 5, 10, 100)):
    rng = np.random.default_rng(0)
    print("| keys r | leaving | deletions (CPU s) | fresh factor (CPU s) | rule |")
    print("|---|---|---|---|---|")
    for r in sizes:
        X = rng.normal(size=(r, r))
        M = X @ X.T + r * np.eye(r)

        def entries(a, b, M=M):
            return M[np.ix_(a // 2, b // 2)]

        for t in leaves:
            keys = 2 * np.arange(r)
            fewer = np.delete(keys, rng.choice(r, t, replace=False))
            system = CholeskySystem(entries)
            system.refactor(keys)
            t0 = time.process_time()
            system._update(fewer)
            updated = time.process_time() - t0
            t0 = time.process_time()
            system.refactor(fewer)
            fresh = time.process_time() - t0
            rule = "fresh" if t > 2 + r // 1000 else "update"
            print(f"| {r} | {t} | {updated:.3f} | {fresh:.3f} | {rule} |")


if __name__ == "__main__":
    main()
