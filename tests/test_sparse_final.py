"""The sparse route's last step and its pieces (cvxcontact/backends/sparse.py, backends/coarse.py): the set the
steps on the capacitance columns predict as the answer factorised for itself (SparseContact._last), K(A) and |K(A)|
on the pattern's own arrays, the coarse rows' independent set from the pattern of C^4."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
import cvxcontact.backends.sparse as sparse_mod
from cvxcontact.apps.demo import thin_layer
from cvxcontact.backends import coarse as coarse_module
from cvxcontact.backends import factor as factor_module
from cvxcontact.backends.coarse import COARSE_HOPS, coarse_rows, row_graph
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


@pytest.fixture(scope="module")
def layer200():
    """thin_layer(200)'s scaled blocks, rows, loads and gaps (348 merged nodes, a saw-tooth of open rows)."""
    problem = cc.ContactSolver(thin_layer(200), method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    return blocks, E, np.concatenate([quasi_definite_rhs(b) for b in blocks]), g


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_the_set_the_columns_predict_is_factorised_for_itself_and_gives_the_same_bits(monkeypatch, layer200,
                                                                                      factorization):
    """Under the timed cap the answer comes from a factor of K(A) for the final set A. Where the steps on the
    capacitance columns (SparseContact._settle) end on a set whose signs hold, that set is factorised as its own
    system (SparseContact._last) instead of being solved through the base by the capacitance form and then
    factorised again for the answer. Against the route with _last off, on one fake clock (the same caps, hence
    the same path): the prediction is taken, the same active set and the same bits of u, phi and y (the same
    factorisation of the same K(A), then the same solve and refinement), as many factorisations, and fewer systems
    solved through the base (measured on thin_layer(200): the capacitance solve of the final set and its
    refinement, 2 of 11 with SuperLU and PARDISO)."""
    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    blocks, E, F, g = layer200
    last, solve_on = SparseContact._last, SparseContact._solve_on
    runs = {}
    for mode in ("predicted", "off"):
        def clock(now=[0.0]):              # noqa: B006 (the clock's own time, one list per clock)
            now[0] += 1e-6                 # a factorisation takes as long as a solve: the cap at CAP_MIN
            return now[0]

        monkeypatch.setattr(sparse_mod, "time", SimpleNamespace(perf_counter=clock))
        taken, solves = [], []

        def spy_last(self, active, taken=taken, mode=mode):
            out = last(self, active) if mode == "predicted" else False
            taken.append(out)
            return out

        def spy_solve_on(self, active, b, solves=solves):
            solves.append(active.sum())
            return solve_on(self, active, b)

        monkeypatch.setattr(SparseContact, "_last", spy_last)
        monkeypatch.setattr(SparseContact, "_solve_on", spy_solve_on)
        sc = SparseContact(blocks, E, factorization=factorization)
        runs[mode] = (sc.solve(F, g), sc.factorizations, len(solves), sum(taken))
    (new, f_new, s_new, taken_new), (old, f_old, s_old, _) = runs["predicted"], runs["off"]
    assert taken_new == 1                                  # the prediction was taken (once)
    assert np.array_equal(new[3], old[3]) and new[3].any() and not new[3].all()
    assert np.array_equal(new[2], old[2])
    assert all(np.array_equal(p, q) for p, q in zip(new[0] + new[1], old[0] + old[1]) if p is not None)
    assert f_new == f_old and s_new < s_old


def test_k_and_its_absolute_values_on_the_patterns_own_arrays(layer200):
    """SparseContact.matrix: K(A) built on the pattern's index arrays (shared, read-only) is the matrix of the
    mixed system (26) assembled independently, [[S, G^T P], [P G, -(I - P)]] with P the active rows; |K(A)|
    (absolute=True) is its entrywise absolute value; neither shares its values with another K(A)."""
    blocks, E, _, _ = layer200
    sc = SparseContact(blocks, E)
    rng = np.random.default_rng(3)
    active = rng.random(sc.m) < 0.6
    K, absK = sc.matrix(active), sc.matrix(active, absolute=True)
    P = sp.diags(active.astype(float))
    ref = sp.bmat([[sc.A, sc.G.T @ P], [P @ sc.G, -sp.diags((~active).astype(float))]], format="csc")
    assert abs(K - ref).max() == 0.0 and abs(absK - abs(ref)).max() == 0.0
    assert K.indices is absK.indices and not K.indices.flags.writeable and not K.indptr.flags.writeable
    other = sc.matrix(~active)
    assert other.data is not K.data and abs(K - ref).max() == 0.0     # building another K(A) left K as it was


@pytest.mark.parametrize("work", [None, 0.0, np.inf])
def test_coarse_rows_are_the_greedy_independent_set_of_the_balls_of_four_hops(monkeypatch, layer200, work):
    """backends/coarse.coarse_rows reads the balls of COARSE_HOPS hops from the pattern of C^4 or finds each by a
    search from its coarse row, by the graph's density (coarse.SEARCH_WORK: None the default, 0 the searches, inf
    the power); either way the same rows as the greedy maximal independent set in row order with every ball found
    by its own breadth-first search on the rows' graph (rows sharing a dof), some rows not free (never coarse, but
    still in the graph)."""
    if work is not None:
        monkeypatch.setattr(coarse_module, "SEARCH_WORK", work)
    blocks, E, _, _ = layer200
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
    blocks, E, _, _ = layer200
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


WRONG_PREDICTION_BOUNDS = (1e-11, 1e-9)
"""(x = [u; phi], y) of the route whose every settled set is claimed as the answer, against an independent sparse
solve of K(A) z = [F; P g] on the final set A (scipy.sparse.linalg.spsolve of the mixed system (26) assembled with
scipy.sparse.bmat), max-norm relative, thin_layer(200), a first solve and a re-solve at 1.3 F. Measured under the
default, Haswell, Nehalem, Prescott and Sandybridge kernels, SuperLU and PARDISO: x 2.7e-14 .. 6.9e-14, y 1.8e-12 ..
5.4e-12 (a wrong set's answer differs by O(1)): >= 145x, 185x."""


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_a_wrong_prediction_is_only_a_new_base_and_the_answer_is_still_checked(monkeypatch, layer200, factorization):
    """SparseContact._last factorises the set the steps on the columns predict; where the prediction is wrong (the
    exact solve's signs do not hold) that factor is only the next base. Forced here: every set the settling steps
    return is claimed as the answer (most are not). The steps still end on the set the route ends on unforced,
    on its exact answer (an independent sparse solve of K(A) on that set), in a first solve and a re-solve from
    the state the first left."""
    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    import scipy.sparse.linalg as spla
    from conftest import rel

    blocks, E, F, g = layer200
    plain = SparseContact(blocks, E, factorization=factorization)
    expected = [plain.solve(F, g)[3], plain.solve(1.3 * F, g)[3]]
    settle, last, taken = SparseContact._settle, SparseContact._last, []

    def claimed(self, active, S, visited, max_iter=50):
        out = settle(self, active, S, visited, max_iter)
        self._predicted = out.tobytes()                 # claimed as the answer, signs holding or not
        return out

    def spy_last(self, active):
        out = last(self, active)
        taken.append(out)
        return out

    monkeypatch.setattr(SparseContact, "_settle", claimed)
    monkeypatch.setattr(SparseContact, "_last", spy_last)
    sc = SparseContact(blocks, E, factorization=factorization)
    for load, want in zip((F, 1.3 * F), expected):
        before = sum(taken)
        u, phi, y, active, _ = sc.solve(load, g)
        assert sum(taken) - before >= 3                  # predictions taken, all but at most one of them wrong
        assert np.array_equal(active, want) and active.any() and not active.all()
        P = sp.diags(active.astype(float))
        K = sp.bmat([[sc.A, sc.G.T @ P], [P @ sc.G, -sp.diags((~active).astype(float))]], format="csc")
        z = spla.spsolve(K, np.concatenate([load, np.where(active, g, 0.0)]))
        x = np.concatenate([np.concatenate([a for a in (uk, pk) if a is not None]) for uk, pk in zip(u, phi)])
        assert rel(x, z[:sc.n]) < WRONG_PREDICTION_BOUNDS[0]
        assert rel(y, z[sc.n:]) < WRONG_PREDICTION_BOUNDS[1]
