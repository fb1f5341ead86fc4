"""The coarse rows of the sparse route's start (cvxcontact/backends/coarse.py): the greedy independent set of the
balls of COARSE_HOPS hops on the contact rows' graph, found from the pattern of C^4 or by searches from each coarse
row, the same rows either way. Patterns only (no floating-point result), so not marked ``numerics``."""

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.apps.demo import thin_layer
from cvxcontact.backends import coarse as coarse_module
from cvxcontact.backends.coarse import COARSE_HOPS, coarse_rows, row_graph
from cvxcontact.backends.sparse import SparseContact


@pytest.fixture(scope="module")
def layer200():
    """thin_layer(200)'s scaled blocks and rows (348 merged nodes)."""
    problem = cc.ContactSolver(thin_layer(200), method="sparse").problem
    return list(problem.blocks), problem.E


@pytest.mark.parametrize("work", [None, 0.0, np.inf])
def test_coarse_rows_are_the_greedy_independent_set_of_the_balls_of_four_hops(monkeypatch, layer200, work):
    """backends/coarse.coarse_rows reads the balls of COARSE_HOPS hops from the pattern of C^4 or finds each by a
    search from its coarse row, by the graph's density (coarse.SEARCH_WORK: None the default, 0 the searches, inf
    the power); either way the same rows as the greedy maximal independent set in row order with every ball found
    by its own breadth-first search on the rows' graph (rows sharing a dof), some rows not free (never coarse, but
    still in the graph)."""
    if work is not None:
        monkeypatch.setattr(coarse_module, "SEARCH_WORK", work)
    blocks, E = layer200
    sc = SparseContact(blocks, E)
    C = row_graph(sc.G)
    free = np.ones(sc.m, dtype=bool)
    free[::7] = False
    B = (abs(sc.G) @ abs(sc.G).T).tocsr()                 # rows sharing a dof (an independent product)
    neighbours = [B.indices[B.indptr[a]:B.indptr[a + 1]] for a in range(sc.m)]
    keep, blocked = [], ~free
    for a in range(sc.m):
        if blocked[a]:
            continue
        keep.append(a)
        ball, frontier = {a}, {a}
        for _ in range(COARSE_HOPS):
            frontier = {b for r in frontier for b in neighbours[r]} - ball
            ball |= frontier
        blocked[list(ball)] = True
    idx = coarse_rows(C, free)
    assert np.array_equal(idx, keep) and 0 < len(idx) < free.sum() and free[idx].all()


def test_coarse_rows_choose_the_power_on_a_slender_graph_and_the_searches_on_a_3d_one(monkeypatch, layer200):
    """coarse.coarse_rows forms the power of the rows' graph where its 2-hop balls are small (thin_layer(200): C^2's
    mean row count squared 102 on the 128 sampled rows, 103 on all, against SEARCH_WORK = 1000) and searches from
    each coarse row where they are large (tests/scenes3d.offset_boxes(6), a 3D overlay: 6,883 sampled, 6,832 on
    all; forming C^4 there cost 8x the searches at 4,816 rows, benchmarks/longif_coarse_rows.py); on the 3D graph
    the rows are the power's too."""
    from scenes3d import offset_boxes

    formed = []
    power = coarse_module._power
    monkeypatch.setattr(coarse_module, "_power", lambda B, k: formed.append(k) or power(B, k))
    blocks, E = layer200
    coarse_rows(row_graph(SparseContact(blocks, E).G), np.ones(E.shape[0], dtype=bool))
    assert formed == [COARSE_HOPS]
    problem = cc.ContactSolver(offset_boxes(6)).problem
    G = sp.hstack([problem.E @ b.jump for b in problem.blocks]).tocsr()
    C = row_graph(G)
    free = np.ones(C.shape[0], dtype=bool)
    free[::5] = False
    searched = coarse_rows(C, free)
    near = (abs(G) @ abs(G).T).toarray() > 0                # rows sharing a dof, dense (240 rows): an independent
    reach = near                                            # reference, the rows within COARSE_HOPS hops
    for _ in range(COARSE_HOPS - 1):
        reach = (reach.astype(float) @ near.astype(float)) > 0
    keep, blocked = [], ~free
    for a in range(len(free)):
        if not blocked[a]:
            keep.append(a)
            blocked |= reach[a]
    assert np.array_equal(searched, keep)                   # 3 coarse rows of 240
    assert formed == [COARSE_HOPS]                      # no power formed for the 3D graph
    monkeypatch.setattr(coarse_module, "SEARCH_WORK", np.inf)
    assert np.array_equal(searched, coarse_rows(C, free)) and formed == [COARSE_HOPS] * 2
    assert 0 < len(searched) < free.sum() and free[searched].all()


@pytest.mark.parametrize("work", [0.0, np.inf])
def test_coarse_rows_of_a_graph_with_rows_that_couple_to_no_dof_either_way(monkeypatch, work):
    """A contact row coupling to no dof is an empty row of the rows' graph (not even its own neighbour): coarse
    where free, blocking no other row, by the searches (SEARCH_WORK = 0) as by the power (inf). A chain of 12 rows,
    row r on dofs r and r + 1, rows 3 and 7 on none, row 0 not free: the pieces {0, 1, 2}, {4, 5, 6}, {8, ..., 11}
    (each within 4 hops of its first row) and the two lone rows give, greedy in row order, 1, 3, 4, 7, 8 (by hand)."""
    monkeypatch.setattr(coarse_module, "SEARCH_WORK", work)
    r = np.array([a for a in range(12) if a not in (3, 7)])
    G = sp.csr_matrix((np.ones(2 * len(r)), (np.repeat(r, 2), np.stack([r, r + 1], axis=1).ravel())), shape=(12, 13))
    free = np.ones(12, dtype=bool)
    free[0] = False
    assert np.array_equal(coarse_rows(row_graph(G), free), [1, 3, 4, 7, 8])


@pytest.mark.parametrize("hops", [1, 2, 3, 5])
def test_coarse_rows_by_either_way_at_other_radii(monkeypatch, hops):
    """The balls' radius is coarse.COARSE_HOPS whatever its value (rounds of tuning tried 2, 3, 5): by the power
    (SEARCH_WORK = inf) and by the searches (0) the greedy set in row order with the balls of ``hops`` hops; on a
    chain of 12 rows, row r on dofs r and r + 1 (rows a and b within ``hops`` hops where |a - b| <= hops), by hand
    every (hops + 1)-th row."""
    monkeypatch.setattr(coarse_module, "COARSE_HOPS", hops)
    r = np.arange(12)
    G = sp.csr_matrix((np.ones(24), (np.repeat(r, 2), np.stack([r, r + 1], axis=1).ravel())), shape=(12, 13))
    for work in (np.inf, 0.0):
        monkeypatch.setattr(coarse_module, "SEARCH_WORK", work)
        assert np.array_equal(coarse_rows(row_graph(G), np.ones(12, dtype=bool)), np.arange(0, 12, hops + 1))
