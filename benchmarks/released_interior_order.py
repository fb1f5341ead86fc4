"""The interior factorisation a body re-makes after its factors were freed (cvxcontact.backends.released.Released),
without PARDISO (SuperLU): on the body's own elimination order (now) against SciPy's default order (COLAMD with
partial pivoting, before), on ``two_boxes(n, "gamma3", elastic=False)`` (tests/scenes3d.py, piezoelectric).
Prints per body the first factorisation's nonzeros, the re-made one's on the kept order and its CPU seconds,
and COLAMD's nonzeros and CPU seconds on the same S_II (measured in the same run, one thread).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/released_interior_order.py 14
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes

import scipy.sparse as sp
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends import budget, factor


def main(n: int) -> None:
    factor._LIB, factor._LIB_ERROR = None, "PARDISO left out by this benchmark"
    splu, made = factor.spla.splu, []

    def recording(A, *args, **kwargs):
        t0 = time.process_time()
        lu = splu(A, *args, **kwargs)
        made.append((A.shape[0], int(lu.nnz), time.process_time() - t0))
        return lu

    factor.spla.splu = recording
    budget.RELEASE = True
    solver = cc.ContactSolver(two_boxes(n, "gamma3", False))
    sol = solver.solve()
    print(f"two_boxes({n}) piezo, released {sol.info.released}, factorization {sol.info.factorization}, ok {sol.ok}")
    print("| body dofs | first nnz | re-made nnz (kept order) | CPU s | COLAMD nnz | CPU s |")
    print("|---|---|---|---|---|---|")
    for c in solver.cache.condensation.bodies:
        f = c.factor
        first = next(m for m in made if m[0] == f.n)
        again = next(m for m in made if m[0] == len(f.interior))
        U = f._S_II
        t0 = time.process_time()
        colamd = splu((U + U.T - sp.diags(U.diagonal())).tocsc())
        t = time.process_time() - t0
        print(f"| {f.n} | {first[1]:,} | {again[1]:,} | {again[2]:.3f} | {colamd.nnz:,} | {t:.3f} |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 14)
