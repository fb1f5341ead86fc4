"""Exploration: the structure of P1 "gamma3" rows between two 3D elastic boxes, as an AMG route for them would meet
it (issue 33 item 1; docs/explanation/gamma3-amg.md). Two elastic boxes (tests/scenes3d.py
``two_boxes(n, "gamma3", elastic=True)``), solved on the default route; then, on the rows R = E [J_1, J_2] (the
jump map on each body's free dofs, restricted to the columns the rows touch, the Gamma dofs) and on the answer's
closed rows P (``solver.cache.active``):

* m, the Gamma dofs d, rank R (every row), the touching rows (|[u_nu] - g| at most 1e-8 of its largest over the
  rows) and their rank, |P| and rank R_P (column-pivoted QR of R^T, cut 1e-10 of the first pivot): how many rows
  an independent set per step keeps;
* with ``--facets`` (small n: one LP per row): the rows that are facets of {v : R v <= g} (HiGHS: max R_a v / |R_a|
  over the other rows and R_a v <= g_a + |R_a| reaches g_a + |R_a|, a point where row a alone fails), against d:
  rows each with a dof of their own are independent, at most d, so they cut at most d facets;
* of an independent subset B of P (the QR's first rank R_P pivots), the rows with a dof of their own in B (a
  dof no other row of B touches: what the AMG route's exact elimination needs, ``backends.amg.own_dofs``), and
  whether ``own_dofs`` accepts B as a whole;
* the elimination of B through a square block instead: the columns S of B's QR (R_B^T's pivots, one per row),
  X = R_BS^-1 R_BM (SuperLU), its fill (entries above 1e-14 of the largest) against R_B's, and the condition of
  R_BS (2-norm, dense): x_S = R_BS^-1 (g_B - R_BM x_M) is the exact elimination, x = T x_M + x_0 with T's
  rows X on S; the fill says whether T^T S T stays a sparse matrix AMG can take.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_rows.py --n 16 24 40
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_rows.py \
        --n 4 8 12 16 --facets
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.amg import own_dofs


def rank_pivots(M, cut: float = 1e-10):
    """(rank, pivots) of the rows of M (dense) by column-pivoted QR of M^T, cut ``cut`` of the first pivot."""
    _, Rq, piv = sla.qr(M.T, mode="economic", pivoting=True)
    d = np.abs(np.diag(Rq))
    r = int(np.sum(d > cut * d[0])) if d.size else 0
    return r, piv[:r]


def facets(R, g) -> int:
    """The rows of {v : R v <= g} (R dense) that are facets: one LP per row (HiGHS), the row's height above its
    bound over the others, its own bound raised by 1 (rows normalised); a facet reaches 1, an implied row 0."""
    from scipy.optimize import linprog

    norm = np.linalg.norm(R, axis=1)
    A, b = R / norm[:, None], np.asarray(g, dtype=float) / norm
    count = 0
    for a in range(len(A)):
        ub = b.copy()
        ub[a] += 1.0
        res = linprog(-A[a], A_ub=A, b_ub=ub, bounds=(None, None), method="highs")
        count += res.status == 0 and -res.fun - b[a] > 0.5
    return count


def explore(n: int, with_facets: bool = False) -> dict:
    solver = cc.ContactSolver(two_boxes(n, "gamma3", True))
    t0 = time.process_time()
    sol = solver.solve()
    t_solve = time.process_time() - t0
    p = solver.problem
    R = sp.hstack([sp.csr_matrix(p.E @ b.jump) for b in p.blocks]).tocsc()
    cols = np.flatnonzero(np.diff(R.indptr))
    R = sp.csr_matrix(R[:, cols])
    R.data[np.abs(R.data) < 1e-12 * np.abs(R.data).max()] = 0.0
    R.eliminate_zeros()
    m, d = R.shape
    active = np.flatnonzero(solver.cache.active)
    c = sol.contact                                  # one entry per row: [u_nu] and g at its overlay vertex (m)
    slack = np.abs(np.asarray(c.jump) - np.asarray(c.gap))
    touching = np.flatnonzero(slack <= 1e-8 * slack.max())
    rank_T, _ = rank_pivots(R[touching].toarray())
    Rd = R.toarray()
    rank_all, _ = rank_pivots(Rd)
    rank_P, piv = rank_pivots(Rd[active])
    B = active[piv]
    RB = R[B]
    used = np.bincount(RB.indices, minlength=d)
    rows = np.repeat(np.arange(len(B)), np.diff(RB.indptr))
    with_own = np.zeros(len(B), dtype=bool)
    with_own[rows[used[RB.indices] == 1]] = True
    accepted = own_dofs(RB) is not None
    # the exact elimination through a square block of B's columns
    _, _, cpiv = sla.qr(RB.toarray(), mode="economic", pivoting=True)
    S, M = np.sort(cpiv[:len(B)]), np.setdiff1d(np.arange(d), cpiv[:len(B)])
    RBS, RBM = sp.csc_matrix(RB[:, S]), RB[:, M].toarray()
    lu = spla.splu(RBS)
    X = lu.solve(RBM)
    fill = int(np.sum(np.abs(X) > 1e-14 * np.abs(X).max()))
    cond = float(np.linalg.cond(RBS.toarray()))
    n_facets = facets(Rd, p.g) if with_facets else -1
    return {"n": n, "N": int(p.unknowns), "m": m, "d": d, "rank": rank_all, "P": len(active), "rank_P": rank_P,
            "T": len(touching), "rank_T": rank_T, "own": int(with_own.sum()), "accepted": accepted,
            "nnz_RB": int(RB.nnz), "fill_X": fill, "cols_S": len(S), "cond_RBS": cond, "facets": n_facets,
            "solve_cpu": t_solve,
            "ok": bool(sol.ok)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[16, 24])
    ap.add_argument("--facets", action="store_true", help="also the rows that are facets (one LP per row)")
    args = ap.parse_args()
    head = ("| n | unknowns | rows m | Gamma dofs d | rank R | touching rows | their rank | closed rows P | rank R_P "
            "| rows of B with an own dof "
            "| own_dofs(B) | nnz R_B | nnz R_BS^-1 R_BM | cond R_BS | facets (LP) | solve CPU s | ok |")
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for n in args.n:
        r = explore(n, args.facets)
        fc = f"{r['facets']:,}" if r["facets"] >= 0 else "-"
        print(f"| {r['n']} | {r['N']:,} | {r['m']:,} | {r['d']:,} | {r['rank']:,} | {r['T']:,} | {r['rank_T']:,} | "
              f"{r['P']:,} | {r['rank_P']:,} | "
              f"{r['own']:,} | {'accepted' if r['accepted'] else 'refused'} | {r['nnz_RB']:,} | {r['fill_X']:,} | "
              f"{r['cond_RBS']:.1e} | {fc} | {r['solve_cpu']:.1f} | "
              f"{r['ok']} |", flush=True)


if __name__ == "__main__":
    main()
