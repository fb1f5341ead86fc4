"""The sparse route's coarse start on a long interface: which rows are coarse, and the start their answer gives
(:meth:`cvxcontact.backends.sparse.SparseContact.coarse_start`, which solves the coarse rows' problem on its dense
Schur complement between the two).

The rows' graph: contact rows sharing a dof are neighbours (each its own). The coarse rows are a maximal
independent set of that graph to :data:`COARSE_HOPS` hops, taken greedily in row order (:func:`coarse_rows`); the
start closes every free row within as many hops of a closed coarse row, less the stiffer row of each nearly
dependent pair (:data:`NEAR_DEPENDENT`; :func:`spread`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["COARSE_HOPS", "DENSITY_SAMPLE", "NEAR_DEPENDENT", "SEARCH_WORK", "bordered_upper", "coarse_rows",
           "row_graph", "spread"]

COARSE_HOPS = 4
"""The coarse rows are a maximal independent set of the rows' graph to this many hops (rows sharing a dof are
neighbours); the start closes every row within as many hops of a closed coarse row."""

NEAR_DEPENDENT = 1e-2
"""Two rows whose Jacobi-scaled cosine exceeds 1 - this are nearly dependent (merged nodes of two traces close
together): the start closes at most one of them (the more compliant)."""

SEARCH_WORK = 1000.0
"""How :func:`coarse_rows` finds the balls of :data:`COARSE_HOPS` hops: from the pattern of C^4 = (C^2)^2, formed
once, where the square of C^2's mean row count (about the work per row of that product) is at most this; else by a
search from each coarse row. Forming the power costs about m b2^2 (b2: C^2's mean row count), the searches about
the rows m times a constant (each coarse row's search visits about its ball, the balls about cover the rows), so the
power is the cheaper on a sparse (slender) graph. Measured (one thread, process CPU, best of 5;
benchmarks/longif_coarse_rows.py, three runs): thin_layer(3000), 5,101 rows, b2^2 = 106: the power 3.3-6.5 ms
against 21-38 ms for the searches; tests/scenes3d.offset_boxes(28), 4,816 rows, b2^2 = 12,648: 131-162 ms against
16.5-19 ms. The two costs cross at b2^2 = 670 with thin_layer's constants (6.1 ns an entry, 4.1 us a row), 1,600
with the boxes' (2.2 ns, 3.4 us). C^2's mean row count is read on :data:`DENSITY_SAMPLE` rows evenly spread
(C^2 itself costs 14 ms on the boxes: about the searches' own cost)."""

DENSITY_SAMPLE = 128
"""The rows on which :func:`coarse_rows` counts C^2's mean row count (:data:`SEARCH_WORK`)."""


def row_graph(G) -> sp.csr_matrix:
    """(m, m) CSR pattern (ones) of the contact rows ``G`` (m x n, sparse) sharing a dof: ``a`` and ``b``
    neighbours where some dof couples to both (every row its own neighbour where it couples to any dof)."""
    B = abs(G).tocsr()
    B.data[:] = 1.0
    C = (B @ B.T).tocsr()
    C.data[:] = 1.0
    return C


def coarse_rows(C, free) -> np.ndarray:
    """The coarse rows (sorted indices): a maximal independent set of the free rows of the graph ``C``
    (:func:`row_graph`) to :data:`COARSE_HOPS` hops, greedy in row order: a free row not within COARSE_HOPS hops of
    an earlier coarse row is coarse. Each coarse row's ball (the rows within COARSE_HOPS hops) is read from the
    pattern of C ** COARSE_HOPS formed once, or found by its own search (:func:`_ball`), whichever costs less by
    the graph's density (:data:`SEARCH_WORK`); the same rows either way."""
    C = C.tocsr()
    sample = np.unique(np.linspace(0, C.shape[0] - 1, min(C.shape[0], DENSITY_SAMPLE)).astype(np.int64))
    P = None
    if ((C[sample] @ C).nnz / max(len(sample), 1)) ** 2 <= SEARCH_WORK:      # b2 on the sampled rows
        P = _power(C, COARSE_HOPS).tocsr()          # the pattern of C^4 = (C^2)^2 (entries >= 0: no cancellation)
    keep, blocked = np.zeros(C.shape[0], dtype=bool), ~np.asarray(free, dtype=bool)
    for a in range(C.shape[0]):
        if not blocked[a]:
            keep[a] = True
            blocked[_ball(C, a) if P is None else P.indices[P.indptr[a]:P.indptr[a + 1]]] = True
    return np.flatnonzero(keep)


def _power(B, k: int):
    """B ** k (sparse, k >= 1) by repeated squaring."""
    out = None
    while True:
        if k & 1:
            out = B if out is None else out @ B
        k >>= 1
        if not k:
            return out
        B = B @ B


def _ball(C, a) -> np.ndarray:
    """The rows within :data:`COARSE_HOPS` hops of row ``a`` of the graph ``C`` (CSR), by a search from it (the
    pattern of row ``a`` of C ** COARSE_HOPS: empty where the row has no neighbour, as there)."""
    ball = np.array([a])
    for _ in range(COARSE_HOPS):
        ball = np.unique(np.concatenate([ball[:0]] + [C.indices[C.indptr[b]:C.indptr[b + 1]] for b in ball]))
    return ball


def spread(C, closed, free, G, diagonal, w):
    """The start of the route's steps from the coarse rows ``closed`` (indices) the coarse problem closes: every
    free row within :data:`COARSE_HOPS` hops of one (graph ``C``, :func:`row_graph`), less, of each nearly dependent
    pair (Jacobi-scaled cosine of their rows ``G`` above 1 - :data:`NEAR_DEPENDENT`, ``diagonal`` the system's
    diagonal on the dofs; the most nearly dependent pairs first), the row of smaller compliance ``w``. (m,) bool,
    or None if it closes no row."""
    start = np.zeros(C.shape[0])
    start[closed] = 1.0
    for _ in range(COARSE_HOPS):                    # the rows within COARSE_HOPS hops of a closed coarse row
        start = (C @ start > 0).astype(float)
    start = free & (start > 0)
    Gs = G @ sp.diags(1.0 / np.sqrt(np.abs(diagonal)))
    P = (Gs @ Gs.T).tocoo()
    norm = np.sqrt(np.maximum(np.asarray(Gs.multiply(Gs).sum(axis=1)).ravel(), np.finfo(float).tiny))
    cos = P.data / (norm[P.row] * norm[P.col])
    near = np.flatnonzero((P.row < P.col) & (cos > 1.0 - NEAR_DEPENDENT))
    near = near[np.argsort(-cos[near], kind="stable")]          # the most nearly dependent pairs first
    for a, b in zip(P.row[near], P.col[near]):
        if start[a] and start[b]:
            start[a if w[a] < w[b] else b] = False
    return start if start.any() else None


def bordered_upper(A, Gc):
    """The upper triangle of M = [[A, Gc^T], [Gc, 0]] in CSR with every diagonal entry stored (the coarse rows' as
    zeros), indices sorted: what PARDISO reads of the coarse start's bordered matrix, the same arrays as
    ``factor.diagonal_stored(sp.triu(sp.bmat(...)), sp.csr_matrix)`` (tests/test_coarse_rows.py) without forming M,
    its COO copies and their sort (41 against 4 ms on thin_layer(3000), 106,257 + 526 rows). ``A``: (n, n) CSR
    with sorted indices, no duplicates and every diagonal entry stored (the route's block diagonal); ``Gc``: (c, n)
    sparse rows. None where A is not so (the caller forms M)."""
    A = sp.csr_matrix(A)
    n, c = A.shape[0], Gc.shape[0]
    if not A.has_canonical_format:
        return None
    rows = np.repeat(np.arange(n), np.diff(A.indptr))
    keep = np.flatnonzero(A.indices >= rows)
    ends = np.cumsum(np.bincount(rows[keep], minlength=n))     # the end of each row's upper entries in A's kept ones
    cols = A.indices[keep]
    starts = np.concatenate([[0], ends[:-1]])
    if np.any(ends == starts) or not np.array_equal(cols[np.minimum(starts, len(cols) - 1)], np.arange(n)):
        return None                                            # a diagonal entry not stored
    GT = sp.csr_matrix(Gc.T)
    GT.sum_duplicates()
    at = ends[np.repeat(np.arange(n), np.diff(GT.indptr))]   # row i: A's upper entries, then Gc^T's (cols >= n)
    data = np.concatenate([np.insert(A.data[keep], at, GT.data), np.zeros(c)])
    data[starts + GT.indptr[:n]] += 0.0         # each row's first upper entry, its diagonal, + 0.0 (a zero added)
    indices = np.concatenate([np.insert(cols, at, n + GT.indices), n + np.arange(c, dtype=cols.dtype)])
    indptr = np.concatenate([[0], ends + GT.indptr[1:], ends[-1] + GT.nnz + np.arange(1, c + 1)])
    return sp.csr_matrix((data, indices, indptr), shape=(n + c, n + c))
