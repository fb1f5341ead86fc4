"""Exploration (not in the package): the augmented Lagrangian's certified answer (explore_gamma3_alm.py,
``--retries 0``) against the reference face of explore_gamma3_outer.run (the condensed route's closed rows P solved
by PARDISO on the mixed system), with the reference's residual through 10 refinement steps (not 2), its perturbed
pivots, and the certified answer's stationarity residual |A x - F + G^T z|_inf / |F|_inf (z >= 0 its NNLS forces).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_alm_reference.py 32
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import explore_gamma3_alm as alm_mod
import explore_gamma3_outer as outer_mod
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.factor import PardisoSymmetric


def main(n: int) -> None:
    s = cc.ContactSolver(two_boxes(n, "gamma3", True))
    sol = s.solve()
    P = np.flatnonzero(s.cache.active)
    A, F, G, g = outer_mod.mixed_data(s.problem)
    unit, cj = s.problem.units.displacement, np.asarray(sol.contact.jump)
    del s, sol
    closed = np.zeros(G.shape[0], bool)
    closed[P] = True
    K = outer_mod.Mixed(A, G).matrix(closed)
    ps = PardisoSymmetric(K)
    ps.factor(K)
    rhs = np.concatenate([F, np.where(closed, g, 0.0)])
    z = ps.solve(rhs)
    hist = []
    for k in range(10):
        z += ps.solve(rhs - K @ z)
        if k == 1:
            x2 = z[:A.shape[0]].copy()
        hist.append(np.abs(rhs - K @ z).max() / np.abs(rhs).max())
    xref = z[:A.shape[0]]
    print("reference residual per refinement step", [f"{h:.1e}" for h in hist], "perturbed pivots", ps.perturbed)
    print("reference after 2 steps against 10", np.abs(x2 - xref).max() / np.abs(xref).max(), flush=True)
    x, zz, k, ok, _ = alm_mod.alm(A, F, G, g, 300, log=lambda r: None, retries=0)
    print("certified", ok, "solves", k,
          "stationarity", np.abs(A @ x - F + G.T @ zz).max() / np.abs(F).max(),
          "u against the reference (10 steps)", np.abs(x - xref).max() / np.abs(xref).max(),
          "(2 steps)", np.abs(x - x2).max() / np.abs(x2).max(),
          "jump against the condensed route", np.abs(G @ x * unit - cj).max() / np.abs(cj).max(), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 16)
