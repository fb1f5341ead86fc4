"""The sparse route's arrays built without a sort (cvxcontact/backends/pattern.py, coarse.bordered_upper) and
PardisoSymmetric's reading of them (backends/factor.py): the same arrays, entry for entry and bit for bit, as the
assemblies they replaced (a COO assembly converted to CSC; scipy's bmat, triu and the diagonal stored), so every
factorisation, solve and answer downstream is the one it was. Exact arrays (values copied, none computed), so not
marked ``numerics`` (except the one PARDISO solve checked by its residual)."""

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.apps.demo import thin_layer, two_blocks
from cvxcontact.backends import factor as factor_module
from cvxcontact.backends.coarse import bordered_upper, coarse_rows, row_graph
from cvxcontact.backends.condensed import quasi_definite
from cvxcontact.backends.pattern import block_diagonal
from cvxcontact.backends.sparse import SparseContact
from cvxcontact.errors import SolverError


@pytest.fixture(scope="module", params=["thin_layer(200)", "two_blocks(8)"])
def route(request):
    """A route on an elastic thin layer (348 merged nodes) and on two blocks, one piezoelectric (Kpp, the -Kpp
    block of S: a body with two kinds of dofs), with their bodies' quasi-definite blocks."""
    scene = thin_layer(200) if request.param == "thin_layer(200)" else two_blocks(8)
    problem = cc.ContactSolver(scene, method="sparse").problem
    blocks = list(problem.blocks)
    return SparseContact(blocks, problem.E), [quasi_definite(b)[0] for b in blocks]


def same(a, b) -> bool:
    """The same dtype, shape and bytes."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_the_pattern_is_the_coo_assemblys(route):
    """K(A)'s pattern, values, kinds and rows (mixed_pattern) against the assembly it replaced: every entry listed
    in COO (S, the couplings G and G^T, the rows' diagonals -1) and sorted into CSC by SciPy."""
    sc, S = route
    A = sp.block_diag(S, format="coo")
    n, m, G = sc.n, sc.m, sc.G.tocoo()
    rows = np.concatenate([A.row, n + G.row, G.col, n + np.arange(m)])
    cols = np.concatenate([A.col, G.col, n + G.row, n + np.arange(m)])
    vals = np.concatenate([A.data, G.data, G.data, -np.ones(m)])
    kind = np.concatenate([np.zeros(A.nnz, np.int8), np.ones(2 * G.nnz, np.int8), np.full(m, 2, np.int8)])
    rid = np.concatenate([np.zeros(A.nnz, np.int64), G.row, G.row, np.arange(m)])
    order = sp.csc_matrix((np.arange(1, len(rows) + 1, dtype=float), (rows, cols)), shape=(n + m, n + m))
    assert order.nnz == len(rows)
    idx = order.data.astype(np.int64) - 1
    assert same(sc.pattern.indptr, order.indptr) and same(sc.pattern.indices, order.indices)
    assert same(sc.pattern.vals, vals[idx]) and same(sc.pattern.kind, kind[idx]) and same(sc.pattern.rid, rid[idx])
    B = A.tocsr()
    assert same(sc.A.data, B.data) and same(sc.A.indices, B.indices) and same(sc.A.indptr, B.indptr)
    K = sc.matrix(np.arange(m) % 3 > 0)                    # some rows open: their couplings stored as zeros
    assert K.nnz == len(rows) and K.has_sorted_indices


def test_block_diagonal_refuses_an_entry_stored_twice():
    S = sp.csc_matrix((np.ones(3), np.array([0, 0, 1]), np.array([0, 2, 3])), shape=(2, 2))    # (0, 0) twice
    with pytest.raises(SolverError, match="duplicate entries"):
        block_diagonal([sp.eye(2, format="csc"), S])
    assert same(block_diagonal([sp.eye(2), 2 * sp.eye(3)]).toarray(), np.diag([1.0, 1, 2, 2, 2]))


def test_the_coarse_start_reads_the_bordered_matrixs_upper_triangle(route):
    """coarse.bordered_upper against what PardisoFactorization made of M = [[A, Gc^T], [Gc, 0]] before: its upper
    triangle, every diagonal stored (the coarse rows' as zeros), sorted; None where A lacks a stored diagonal or
    is not canonical (the caller then forms M)."""
    sc, _ = route
    free = np.ones(sc.m, dtype=bool)
    idx = coarse_rows(row_graph(sc.G), free)
    Gc = sc.G[idx]
    M = sp.bmat([[sc.A, Gc.T], [Gc, None]], format="csr")
    ref = factor_module.diagonal_stored(sp.triu(sp.csr_matrix(M), format="coo"), sp.csr_matrix)
    U = bordered_upper(sc.A, Gc)
    assert same(U.data, ref.data) and same(U.indices, ref.indices) and same(U.indptr, ref.indptr)
    missing = sc.A.copy()
    missing.setdiag(0.0)
    missing.eliminate_zeros()
    assert bordered_upper(missing, Gc) is None
    unsorted = sp.csr_matrix((np.array([1.0, 2.0, 3.0]), np.array([1, 0, 1]), np.array([0, 2, 3])), shape=(2, 2))
    assert bordered_upper(unsorted, sp.csr_matrix((1, 2))) is None
    small = bordered_upper(sp.csr_matrix(np.array([[2.0, 1.0], [1.0, 3.0]])), sp.csr_matrix(np.array([[0.0, 4.0]])))
    assert np.array_equal(small.toarray(), [[2, 1, 0], [0, 3, 4], [0, 0, 0]]) and small.nnz == 5   # (2, 2) stored


needs_pardiso = pytest.mark.skipif(not factor_module.pardiso_available(), reason="Intel oneMKL not installed")


@needs_pardiso
def test_pardiso_reads_the_routes_matrices_as_before(route):
    """PardisoSymmetric's arrays (the upper part of K's CSC columns, read as CSR rows) against the masks and counts
    it used before; the route's read-only pattern kept by reference, a writeable one copied; a K of another pattern
    with as many entries refused, whichever way its pattern was kept."""
    sc, _ = route
    K = sc.matrix(np.ones(sc.m, dtype=bool))
    n = K.shape[0]
    col = np.repeat(np.arange(n), np.diff(K.indptr))
    upper = K.indices >= col
    ia = np.concatenate([[0], np.cumsum(np.bincount(col[upper], minlength=n))]).astype(np.int32)
    h = factor_module.PardisoSymmetric(K)
    assert same(h._ia, ia) and same(h._ja, K.indices[upper].astype(np.int32)) and same(h._a, K.data[upper])
    assert h._pattern[1] is sc.pattern.indices                      # the route's own, read-only
    K2 = sc.matrix(np.arange(sc.m) % 2 == 0)
    h._values(K2, "factor")
    assert same(h._a, K2.data[upper])
    copied = sp.csc_matrix((K.data.copy(), K.indices.copy(), K.indptr.copy()), shape=K.shape)
    h2 = factor_module.PardisoSymmetric(copied)
    assert h2._pattern[1] is not copied.indices
    other = K.copy()                                          # as many entries, one moved to another row
    j = int(np.flatnonzero(K.indices[K.indptr[1:] - 1] < n - 1)[0])     # a column whose last row is not the last
    other.indices[K.indptr[j + 1] - 1] += 1
    for handle in (h, h2):
        with pytest.raises(SolverError, match="pattern differs"):
            handle._values(other, "factor")
    missing = K.copy()
    missing.setdiag(0.0)
    missing.eliminate_zeros()
    with pytest.raises(SolverError, match="every diagonal entry"):
        factor_module.PardisoSymmetric(missing)
    for handle in (h, h2):
        handle.release()


def test_the_kept_matrices_are_the_new_ones(route):
    """MixedPattern.kept (K(A) and |K(A)| on buffers kept between systems, only the changed rows rewritten) against
    a new matrix for each of a sequence of sets: far apart, one row apart, the same, and after the compliances
    changed (rebuilt)."""
    sc, _ = route
    rng = np.random.default_rng(3)
    sets = [rng.random(sc.m) < 0.5 for _ in range(3)]
    sets.insert(2, sets[1].copy())
    sets[2][0] = ~sets[2][0]
    soft = np.zeros(sc.m)
    for k, active in enumerate(sets + [sets[-1], sets[0]]):
        if k == len(sets) + 1:
            soft = np.full(sc.m, 1e-6)
        for absolute in (False, True):
            kept = sc.pattern.kept(active, soft, absolute)
            assert same(kept.data, sc.pattern.matrix(active, soft, absolute).data)
            assert kept.indices is sc.pattern.indices


@needs_pardiso
def test_the_coarse_start_is_the_one_from_the_formed_matrix(monkeypatch):
    """SparseContact.coarse_start with PARDISO reading bordered_upper's arrays and with M formed (bordered_upper
    declined: the path before): the same coarse forces and the same start, bit for bit (thin_layer(200), 348 rows;
    the coarse problem on every 4-hop independent row)."""
    from cvxcontact.backends import sparse as sparse_module
    from cvxcontact.backends.condensed import quasi_definite_rhs

    problem = cc.ContactSolver(thin_layer(200), method="sparse").problem
    blocks, g = list(problem.blocks), np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    starts, forces, used, real = [], [], [], sparse_module.bordered_upper
    for declined in (False, True):
        def spy(A, Gc, declined=declined):
            used.append(declined)
            return None if declined else real(A, Gc)

        monkeypatch.setattr(sparse_module, "bordered_upper", spy)
        sc = SparseContact(blocks, problem.E, factorization="pardiso")
        forces.append(sc._coarse(F, g, np.ones(sc.m, dtype=bool))[2])
        starts.append(sc.coarse_start(F, g))
    assert same(forces[0], forces[1]) and (forces[0] > 0).any() and (forces[0] == 0).any()
    assert same(starts[0], starts[1]) and used == [False, False, True, True]


def test_a_rewrite_stopped_half_way_is_not_kept(route, monkeypatch):
    """An exception (an interrupt) between the couplings' and the diagonals' rewrite of MixedPattern.kept: the
    half-rewritten buffer is dropped, and the next call (here back to the set before) is the new matrix, not one
    with the other set's couplings and this set's diagonals (its check would then read a wrong |K(A)| silently)."""
    sc, _ = route
    pattern = sc.pattern
    before, after = np.arange(sc.m) % 2 == 0, np.arange(sc.m) % 3 == 0
    soft = np.zeros(sc.m)
    for absolute in (False, True):
        pattern.kept(before, soft, absolute)
        real = pattern._set

        def halfway(data, active, soft_, absolute_, couple, rows):
            data[couple] = np.where(active[pattern.rid[couple]], pattern.vals[couple], 0.0)    # couplings only
            raise KeyboardInterrupt

        monkeypatch.setattr(pattern, "_set", halfway)
        with pytest.raises(KeyboardInterrupt):
            pattern.kept(after, soft, absolute)
        monkeypatch.setattr(pattern, "_set", real)
        assert same(pattern.kept(before, soft, absolute).data, pattern.matrix(before, soft, absolute).data)
        assert same(pattern.kept(after, soft, absolute).data, pattern.matrix(after, soft, absolute).data)


@needs_pardiso
@pytest.mark.numerics
def test_pardiso_reads_an_equal_pattern_in_other_arrays(route):
    """A handle made on the route's read-only pattern (kept by reference) factorises a K(A) whose pattern is equal
    but in other arrays (compared entry by entry, not by identity): its solve is K(A)'s, by the residual against
    K(A) itself (an independent product), and the solve of the route's own K(A)."""
    sc, _ = route
    active = np.arange(sc.m) % 3 > 0
    K = sc.matrix(active)
    other = sp.csc_matrix((K.data.copy(), K.indices.copy(), K.indptr.copy()), shape=K.shape)
    assert other.indices is not sc.pattern.indices
    b = np.random.default_rng(5).standard_normal(K.shape[0])
    h = factor_module.PardisoSymmetric(sc.matrix(np.ones(sc.m, dtype=bool)))
    try:
        x = h.factor(other).solve(b)
        residual = np.abs(K @ x - b).max() / (abs(K) @ np.abs(x) + np.abs(b)).max()
        assert residual <= 1e-8     # measured 9.7e-17-2.7e-16 (thin_layer(200)), 1.1e-16 (two_blocks), 5 kernels
        again = h.factor(K).solve(b)
        assert np.abs(again - x).max() <= 1e-8 * np.abs(x).max()          # measured 0 (one thread)
    finally:
        h.release()
