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

__all__ = ["block_diagonal", "mixed_pattern"]


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
