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

__all__ = ["COARSE_HOPS", "NEAR_DEPENDENT", "coarse_rows", "row_graph", "spread"]

COARSE_HOPS = 4
"""The coarse rows are a maximal independent set of the rows' graph to this many hops (rows sharing a dof are
neighbours); the start closes every row within as many hops of a closed coarse row."""

NEAR_DEPENDENT = 1e-2
"""Two rows whose Jacobi-scaled cosine exceeds 1 - this are nearly dependent (merged nodes of two traces close
together): the start closes at most one of them (the more compliant)."""


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
    an earlier coarse row is coarse. The balls are the rows of the pattern of C ** COARSE_HOPS (C holds every row
    as its own neighbour, its entries are ones: no cancellation; about 20 rows a ball on thin_layer(3000), 5,101
    rows), formed once. On a 3D interface the balls are about 20 times larger and the power costs more than the
    searches it replaces (tests/scenes3d.offset_boxes(28), 4,816 rows: 391 rows a ball, 23 MB, 0.145 s against
    0.015 s for a search per coarse row; thin_layer(3000): 0.008 s against 0.034 s)."""
    P = C
    for _ in range(COARSE_HOPS - 1):
        P = P @ C
    P = P.tocsr()
    ind, ptr = P.indices, P.indptr
    keep, blocked = np.zeros(C.shape[0], dtype=bool), ~np.asarray(free, dtype=bool)
    for a in range(C.shape[0]):
        if not blocked[a]:
            keep[a] = True
            blocked[ind[ptr[a]:ptr[a + 1]]] = True
    return np.flatnonzero(keep)


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
