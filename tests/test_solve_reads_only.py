"""A solve reads its DiscreteProblem, never changes it: every array reachable from the problem holds the same bits
after one solve and after a second, and two cold solves of one problem give the same bits.

Found: the read-back's ``abs(block.jump)`` sorted a non-canonical jump operator in place during the first solve
(SciPy's ``sum_duplicates``), so a second solve read the same matrix with its entries in another order. The
problem's sparse matrices are now canonical and read-only from construction (:func:`cvxcontact.errors.frozen`).
"""

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from conftest import changed, digests
from cvxcontact.errors import frozen, frozen_pattern, locked
from friction_scenes import pair2d
from hencky_scenes import indented
from scenes import SCENES, two_blocks
from scenes3d import two_boxes

CASES = {
    "3D two boxes, gamma3 (a jump sorted in place before)": (lambda: two_boxes(4, "gamma3", True), {}),
    "2D two blocks, sigma1, sparse route": (lambda: two_blocks((8, 4), (5, 3)), dict(condition="sigma1",
                                                                                      method="sparse")),
    "2D P2 cones": SCENES["two blocks, P2 gamma3 (cones)"],
    "2D force-controlled circle": SCENES["force-controlled circle"],
    "2D P2 conic limit (two cold solves differed before)": SCENES["layer held, P2 conic limit"],
    "2D Coulomb pair (the slip's operators sorted in place before)": (lambda: pair2d(cc.Coulomb(0.3)), {}),
    "2D Hencky indented (its strain matrix A sorted in place before)": (
        lambda: indented(cc.materials.hencky(70e9, 0.3, 1e8, 0.1), nx=8, ny=3), {}),
}
@pytest.fixture(scope="module", params=list(CASES), ids=list(CASES))
def solved(request):
    """(problem, its digests before, after a first and after a second cold solve, the two answers)."""
    build, kw = CASES[request.param]
    solver = cc.ContactSolver(build(), warm_start=False, **kw)
    p = solver.problem
    d0 = digests(p)
    first = solver.solve()
    d1 = digests(p)
    second = solver.solve()
    return p, d0, d1, digests(p), first, second


def test_a_solve_changes_no_array_of_its_problem(solved):
    _, d0, d1, d2, _, _ = solved
    assert len(d0) > 50                              # the walk reaches the blocks, E, the gap, the rows... (78-184)
    assert any(".blocks[0].jump." in k for k in d0) and any(".lines.E." in k for k in d0)
    assert changed(d0, d1) == [], "the first solve changed these arrays of its problem"
    assert changed(d1, d2) == [], "the second solve changed these arrays of its problem"


def test_two_cold_solves_give_the_same_bits(solved):
    *_, first, second = solved
    one, two = digests(first), digests(second)
    assert len(one) > 10 and one.keys() == two.keys()
    for a, b in zip(first.u, second.u):
        assert np.array_equal(a, b)
    assert changed(one, two) == []


def test_the_problems_matrices_are_canonical_and_read_only(solved):
    p = solved[0]
    matrices = [m for b in p.blocks for m in (b.Kuu, b.jump, b.Kup, b.Kpp) if m is not None]
    matrices += [p.E] + [R for R, _ in p.translations]
    for m in matrices:
        rows = np.repeat(np.arange(len(m.indptr) - 1), np.diff(m.indptr))       # sorted, no duplicates, by hand
        assert np.all((np.diff(m.indices) > 0) | (np.diff(rows) > 0))
        for a in (m.data, m.indices, m.indptr):
            with pytest.raises(ValueError):
                a[:1] = a[:1]                        # an in-place change raises at once


def test_frozen_sums_duplicates_sorts_keeps_zeros_and_leaves_other_formats():
    A = sp.csr_matrix((np.array([1.0, 0.0, 2.0, 3.0]), np.array([2, 0, 2, 1]), np.array([0, 4, 4])), shape=(2, 3))
    dense = A.toarray()                              # [[0, 3, 3], [0, 0, 0]]: the two (0, 2) entries summed
    B = frozen(A)
    assert B is A and np.array_equal(B.toarray(), dense)
    assert B.indices.tolist() == [0, 1, 2] and B.data.tolist() == [0.0, 3.0, 3.0]   # the stored zero kept
    assert not B.data.flags.writeable and not B.indices.flags.writeable and not B.indptr.flags.writeable
    C = sp.coo_matrix(dense)
    assert frozen(C) is C and C.data.flags.writeable and frozen(None) is None


def test_frozen_pattern_locks_the_pattern_in_place_and_leaves_the_values():
    """The pattern-only contract (a strain energy's Hessians, which share H_0's pattern): indices and indptr
    read-only, the values writeable, nothing sorted or summed."""
    A = sp.csr_matrix((np.array([1.0, 2.0, 3.0]), np.array([2, 0, 2]), np.array([0, 3, 3])), shape=(2, 3))
    assert frozen_pattern(A) is A and A.indices.tolist() == [2, 0, 2] and A.data.tolist() == [1.0, 2.0, 3.0]
    for a in (A.indices, A.indptr):
        with pytest.raises(ValueError):
            a[:1] = a[:1]
    A.data[0] = 5.0
    assert A.toarray()[0].tolist() == [2.0, 0.0, 8.0]


def test_locked_is_a_read_only_copy_for_good_in_the_dtype_asked():
    """The dense contract: a copy (the caller's array untouched and still writeable), converted to ``dtype``, that
    no ``setflags(write=True)`` makes writeable again (an array owning its memory could be)."""
    mine = np.array([[1, 2], [3, 4]])
    a, b = locked(mine, float), locked([1.5, 2.5])
    assert a.dtype == np.float64 and a.shape == (2, 2) and a.tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert b.dtype == np.float64 and locked(3, float).shape == () and locked(mine).dtype == mine.dtype
    mine[0, 0] = 7
    assert a[0, 0] == 1.0 and mine.flags.writeable
    for x in (a, b):
        with pytest.raises(ValueError):
            x.setflags(write=True)
        with pytest.raises(ValueError):
            x[...] = 0


def test_with_rows_leaves_the_callers_matrix_alone():
    """with_rows freezes its own copy of E: the caller's matrix (unsorted, with duplicates) keeps its arrays' bits
    and stays writeable (before, sp.csr_matrix(E) viewed the caller's arrays and frozen sorted and summed them)."""
    p = cc.ContactSolver(two_blocks((8, 4), (5, 3)), condition="sigma1").problem
    m, n = 4, p.lines.E.shape[1]
    r = np.arange(m)[:, None]
    cols = np.hstack([n - 1 - r, r, n - 1 - r])          # row r: columns n-1-r, r, n-1-r (unsorted, a duplicate)
    E = sp.csr_matrix((np.arange(1.0, 3 * m + 1), cols.ravel(), np.arange(0, 3 * m + 1, 3)), shape=(m, n))
    dense, mine = E.toarray(), [a.copy() for a in (E.data, E.indices, E.indptr)]
    q = p.with_rows(E)
    assert np.array_equal(q.lines.E.toarray(), dense) and q.lines.E.nnz == 2 * m     # its own E: summed, sorted
    assert all(np.array_equal(a, b) for a, b in zip((E.data, E.indices, E.indptr), mine))
    assert E.data.flags.writeable and E.indices.flags.writeable
