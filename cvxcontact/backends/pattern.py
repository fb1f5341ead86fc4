"""The sparse route's one pattern of K(A) for every active set (:class:`~cvxcontact.backends.sparse.SparseContact`).

    K(A) = [[S,     G^T P],
            [P G, -(I - P)]]        (S = diag_l S_l the bodies' quasi-definite blocks, G the m contact rows)

stored in CSC with every contact row's couplings and diagonal present whatever A (an open row's as explicit zeros).
Assembled column by column from the blocks' own CSC arrays and G's, each column's rows already in order (S's rows,
then the contact rows coupling to that dof; a contact row's dofs, then its diagonal), so that no sort of the whole
pattern is needed: the same arrays as a COO assembly converted to CSC (tests/test_sparse_pattern.py), 1.6e6 entries on
thin_layer(3000) without the sort's permutation and its gathers.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError

__all__ = ["MixedPattern", "block_diagonal", "mixed_pattern"]


def block_diagonal(blocks) -> sp.csc_matrix:
    """diag(blocks) in CSC (sorted indices), from the blocks' own CSC arrays; SolverError where a block stores an
    entry twice (a duplicate would make the route's pattern hold it twice)."""
    parts = []
    for S in blocks:
        S = sp.csc_matrix(S)
        if not S.has_canonical_format:
            nnz = S.nnz
            S = S.copy()
            S.sum_duplicates()
            if S.nnz != nnz:
                raise SolverError("duplicate entries in the sparse mixed system's pattern (a body's matrix storing "
                                  "an entry twice); use method='condensed' or 'full'")
        parts.append(S)
    rows, nnz = np.cumsum([0] + [S.shape[0] for S in parts]), np.cumsum([0] + [S.nnz for S in parts])
    indptr = np.concatenate([S.indptr[:-1] + o for S, o in zip(parts, nnz)] + [nnz[-1:]])
    indices = np.concatenate([S.indices + o for S, o in zip(parts, rows)])
    data = np.concatenate([S.data for S in parts]).astype(float, copy=False)
    A = sp.csc_matrix((data, indices, indptr), shape=(rows[-1], rows[-1]))
    A.has_canonical_format = True
    return A


def mixed_pattern(A, G):
    """The pattern of K(A) in CSC for the block diagonal ``A`` (n x n CSC, sorted indices, :func:`block_diagonal`)
    and the contact rows ``G`` (m x n CSR, canonical): ``(indptr, indices, vals, kind, rid)``, ``vals`` the entries
    of the bonded system with every row open on its diagonal (-1), ``kind`` 0 on S, 1 on a coupling, 2 on a contact
    row's diagonal, ``rid`` the contact row of a coupling or a diagonal (0 on S). Column j < n: A's column j, then
    the rows n + a of the contact rows a coupling to dof j; column n + a: row a's dofs, then its diagonal."""
    n, m = A.shape[0], G.shape[0]
    Gt = sp.csc_matrix(G)                                          # column j: the contact rows coupling to dof j
    at = np.repeat(A.indptr[1:], np.diff(Gt.indptr))               # after A's column j
    indices = [np.insert(A.indices, at, n + Gt.indices)]
    vals = [np.insert(A.data, at, Gt.data)]
    kind = [np.insert(np.zeros(A.nnz, np.int8), at, np.int8(1))]
    rid = [np.insert(np.zeros(A.nnz, np.int64), at, Gt.indices)]
    at = G.indptr[1:]                                              # after row a's dofs: its diagonal
    indices.append(np.insert(G.indices, at, n + np.arange(m)))
    vals.append(np.insert(G.data, at, -1.0))
    kind.append(np.insert(np.ones(G.nnz, np.int8), at, np.int8(2)))
    rid.append(np.insert(np.repeat(np.arange(m), np.diff(G.indptr)), at, np.arange(m)))
    index = np.int32 if 2 * (A.nnz + 2 * G.nnz + m) < np.iinfo(np.int32).max else np.int64     # as SciPy picks
    indptr = np.concatenate([A.indptr.astype(np.int64) + Gt.indptr,
                             A.nnz + G.nnz + G.indptr[1:] + np.arange(1, m + 1)])
    return indptr.astype(index), np.concatenate(indices).astype(index), np.concatenate(vals), np.concatenate(kind), \
        np.concatenate(rid)


class MixedPattern:
    """K(A)'s one pattern (:func:`mixed_pattern`) and its matrices for any active set: ``indptr``, ``indices``
    (read-only: every K(A) shares them), ``vals``, ``kind``, ``rid`` as there."""

    def __init__(self, A, G):
        self.n, self.m = A.shape[0], G.shape[0]
        self.indptr, self.indices, self.vals, self.kind, self.rid = mixed_pattern(A, G)
        self.indices.flags.writeable = self.indptr.flags.writeable = False
        self.abs = np.abs(self.vals)
        self.couple, self.diag = np.flatnonzero(self.kind == 1), np.flatnonzero(self.kind == 2)   # diag[a]: row a's
        order = np.argsort(self.rid[self.couple], kind="stable")
        self._by_row = self.couple[order], np.searchsorted(self.rid[self.couple][order], np.arange(self.m + 1))
        self._kept = {}                     # absolute -> [active, soft, K] of :meth:`kept`

    def _csc(self, data) -> sp.csc_matrix:
        N = self.n + self.m                 # without the constructor's check: canonical by construction
        K = sp.csc_matrix((N, N), dtype=float)
        K.data, K.indices, K.indptr = data, self.indices, self.indptr
        K.has_canonical_format = True
        return K

    def _set(self, data, active, soft, absolute, couple, rows):
        """The values of the couplings ``couple`` and of the diagonals of ``rows`` for the set ``active``."""
        vals = self.abs if absolute else self.vals
        data[couple] = np.where(active[self.rid[couple]], vals[couple], 0.0)
        soft = np.abs(soft) if absolute else -soft
        data[self.diag[rows]] = np.where(active[rows], soft[rows], 1.0 if absolute else -1.0)

    def matrix(self, active, soft, absolute: bool = False) -> sp.csc_matrix:
        """K(A) in CSC for the active set ``active`` (bool, m) and the closed rows' compliances ``soft`` (m), a new
        one; ``absolute``: |K(A)| (entrywise)."""
        data = (self.abs if absolute else self.vals).copy()
        self._set(data, active, soft, absolute, self.couple, slice(None))
        return self._csc(data)

    def kept(self, active, soft, absolute: bool = False) -> sp.csc_matrix:
        """:meth:`matrix` on a buffer kept between calls (one for K, one for |K|), only the couplings and diagonals
        of the rows whose state changed since the last call rewritten: the same values (the same expressions), no
        copy of the 1.6e6 entries per system on thin_layer(3000) (the two buffers stay held: 26 MB there). A matrix it
        returned before is this one, rewritten. The buffer is no one's while it is rewritten: an exception half-way
        (an interrupt) drops it, and the next call builds a new one (rather than trusting rows half rewritten)."""
        active = np.asarray(active, dtype=bool)
        state = self._kept.pop(absolute, None)
        if state is None or not np.array_equal(state[1], soft):
            state = None                    # (the old buffer freed before the new one is made)
            K = self.matrix(active, soft, absolute)
            self._kept[absolute] = [active.copy(), np.array(soft, dtype=float), K]
            return K
        last, _, K = state
        rows = np.flatnonzero(last != active)
        if len(rows):
            pos, ptr = self._by_row
            counts = ptr[rows + 1] - ptr[rows]
            couple = pos[np.repeat(ptr[rows] - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())]
            self._set(K.data, active, soft, absolute, couple, rows)
            last[:] = active
        self._kept[absolute] = state
        return K
