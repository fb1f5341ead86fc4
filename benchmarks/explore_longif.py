"""Exploration: starts of the sparse route's active-set steps on the long interface (issue 33 item 4).

Scene: ``demo.thin_layer(n)`` (5,101 merged contact nodes at n = 3000). Every variant ends with the route's own
steps (``SparseContact.solve``) to the exact answer, checked as always; the variants differ in the set they start
from, and report (one thread, process CPU seconds, construction of ``SparseContact`` included) the numeric
factorisations, the systems, the capacitance column solves, the CPU and its ratio to one bonded PARDISO solve in
the same process (benchmarks/harness.bonded_kkt, as benchmarks/bench_longif.py), and whether the final active set
is the plain route's.

* ``plain``: the shipped route from the bonded start (every row closed).
* ``reduced``: one row of each nearly dependent pair left out (the rows' Jacobi-scaled cosine, sum_j R_aj R_bj /
  Kuu_jj over the norms, above 1 - ``--eps``: merged nodes of the two traces close together; the less compliant
  row of the pair left out), the problem of the other rows solved to its answer, then the full problem from its
  active set.
* ``coarse``: a coarse subset of rows (a maximal independent set of the rows' graph to ``--hops`` hops: rows
  sharing a dof are neighbours) solved to its answer from the bonded start; then every row within ``--hops``
  hops of a closed coarse row closed, less one row of each nearly dependent pair (as in ``reduced``), and the
  full problem from there (on a declined run, the plain steps).
* ``schur``: the package's start above ``sparse.COARSE_ROWS`` rows, :meth:`SparseContact.coarse_start` (the same
  coarse rows, their problem solved on its dense Schur complement W_c = G_c S^{-1} G_c^T by one partial
  factorisation and the dense LCP, then the start as in ``coarse``, with the package's hops and eps: ``--hops``
  and ``--eps`` do not apply), then the full problem from there (on a declined run, the plain steps).
  ``coarse_cpu`` is the start's CPU.

A row is left out of a subproblem by a gap of 1e3 max|g| + 1 (scaled) on it: it never penetrates, so the steps
never close it. This is an exploration (the package does not ship these starts): see
benchmarks/results/bench_longif.md for what was measured and what remains.

Run:  OMP_NUM_THREADS=1 python benchmarks/explore_longif.py --n 3000 [--variants plain coarse reduced schur]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import cvxcontact as cc
from cvxcontact.apps import demo
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact


def pairs(sc: SparseContact, eps: float):
    """(a, b, cos) of the row pairs whose Jacobi-scaled cosine exceeds 1 - eps, most nearly dependent first."""
    Gs = sc.G @ sp.diags(1.0 / np.sqrt(np.abs(sc.A.diagonal())))
    C = (Gs @ Gs.T).tocoo()
    norm = np.sqrt(np.asarray(Gs.multiply(Gs).sum(axis=1)).ravel())
    cos = C.data / (norm[C.row] * norm[C.col])
    sel = (C.row < C.col) & (cos > 1.0 - eps)
    order = np.argsort(-cos[sel])
    return C.row[sel][order], C.col[sel][order]


def thin_out(sc: SparseContact, closed: np.ndarray, eps: float) -> np.ndarray:
    """``closed`` less the less compliant row of each nearly dependent pair of closed rows (greedy)."""
    closed = closed.copy()
    for a, b in zip(*pairs(sc, eps)):
        if closed[a] and closed[b]:
            closed[a if sc.w[a] < sc.w[b] else b] = False
    return closed


def row_graph(sc: SparseContact, hops: int) -> sp.csr_matrix:
    """The pattern of the rows' graph to ``hops`` hops (rows sharing a dof are neighbours)."""
    B = abs(sc.G).tocsr()
    B.data[:] = 1.0
    C = (B @ B.T).tocsr()
    C.data[:] = 1.0
    H = C.copy()
    for _ in range(hops - 1):
        H = (H @ C).tocsr()
        H.data[:] = 1.0
    return H


def coarse_rows(H: sp.csr_matrix) -> np.ndarray:
    """A maximal independent set of the graph ``H`` (greedy in row order)."""
    keep, blocked = np.zeros(H.shape[0], bool), np.zeros(H.shape[0], bool)
    for a in range(H.shape[0]):
        if not blocked[a]:
            keep[a] = True
            blocked[H.indices[H.indptr[a]:H.indptr[a + 1]]] = True
    return keep


def run(variant: str, blocks, E, F, g, eps: float, hops: int):
    sc = SparseContact(blocks, E, factorization="auto")
    systems, far = 0, 1e3 * float(np.abs(g).max()) + 1.0
    start, coarse_cpu = None, 0.0
    if variant == "reduced":
        keep = thin_out(sc, np.ones(sc.m, bool), eps)
        out = sc.solve(F, np.where(keep, g, far), active=keep)
        systems += out[4]
        start = out[3]
    elif variant == "coarse":
        H = row_graph(sc, hops)
        keep = coarse_rows(H)
        out = sc.solve(F, np.where(keep, g, far), active=keep)
        systems += out[4]
        start = thin_out(sc, (H @ out[3].astype(float)) > 0, eps)
    elif variant == "schur":                            # the package's start (its own hops and eps)
        t0 = time.process_time()
        start = sc.coarse_start(F, g)
        coarse_cpu = time.process_time() - t0
    out = sc.solve(F, g, active=start)
    declined = out is None
    if declined:
        out = sc.solve(F, g)
    return out[3], systems + out[4], sc.factorizations, sc.column_solves, coarse_cpu, declined


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--n", type=int, default=3000)
    p.add_argument("--variants", nargs="+", default=["plain", "coarse", "reduced"])
    p.add_argument("--eps", type=float, default=0.01)
    p.add_argument("--hops", type=int, default=4)
    args = p.parse_args()
    warnings.simplefilter("ignore")
    from harness import bonded_kkt

    solver = cc.ContactSolver(demo.thin_layer(args.n))
    pr = solver.problem
    blocks, E, g = list(pr.blocks), pr.E, np.asarray(pr.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    import pypardiso

    K, rhs, _, _, _ = bonded_kkt(blocks, [b.jump for b in blocks])
    M = sp.triu(K, format="csr")
    M.sort_indices()
    bonded = []
    for _ in range(3):
        ps = pypardiso.PyPardisoSolver(mtype=-2)
        t0 = time.process_time()
        ps.solve(M, rhs)
        bonded.append(time.process_time() - t0)
        ps.free_memory(everything=True)
    b = statistics.median(bonded)
    reference = None
    for v in args.variants:
        t0 = time.process_time()
        active, systems, fact, cols, coarse_cpu, declined = run(v, blocks, E, F, g, args.eps, args.hops)
        cpu = time.process_time() - t0
        reference = active if reference is None else reference
        row = {"n": args.n, "variant": v, "factorizations": fact, "systems": systems, "column_solves": cols,
               "cpu": round(cpu, 3), "coarse_cpu": round(coarse_cpu, 3), "declined": declined,
               "bonded_cpu": round(b, 3), "ratio": round(cpu / b, 2),
               "closed": int(active.sum()), "same_set": bool(np.array_equal(active, reference))}
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
