"""The sparse route's last step and its pieces (cvxcontact/backends/sparse.py, backends/coarse.py): the set the
steps on the capacitance columns predict as the answer factorised for itself (SparseContact._last), K(A) and |K(A)|
on the pattern's own arrays (the coarse rows: tests/test_coarse_rows.py)."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
import cvxcontact.backends.sparse as sparse_mod
from cvxcontact.apps.demo import thin_layer
from cvxcontact.backends import factor as factor_module
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


CLOCK_COSTS = (0.0, 30.0, 1000.0)
"""A numeric factorisation's cost in single solves on the virtual clocks of
:func:`test_the_answer_does_not_depend_on_the_clock`: the timed cap at CAP_MIN, 496, CAP_MAX (thin_layer(200): 9, 7
and 2 systems solved in the first solve)."""


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_the_answer_does_not_depend_on_the_clock(monkeypatch, layer200, factorization):
    """The timed cap (SparseContact._over_cap) chooses between refactorising and the capacitance columns by the
    clock, so the sets the steps factorise and their count follow the machine's speed; the answer does not
    (SparseContact.solve takes it from a factor of K(A) for the final set A itself). Three virtual clocks
    (each perf_counter call advances 1, a numeric factorisation CLOCK_COSTS more): different paths (the systems
    solved differ), and the same bits of u, phi, y and the active set, in a first solve and in a re-solve at
    1.3 F from the state the first left. One MKL thread (PARDISO on several factorises one matrix to different
    bits run to run). Measured (benchmarks/results/sparse_clock_bits.md): thin_layer(200, 400, 800, 1500) and
    two_boxes(12), five clocks each, SuperLU and PARDISO: one hash per scene and factorisation. With _last and the
    final refactorisation of solve both off this test fails (thin_layer(400): 5 hashes over 7 clocks)."""
    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    import hashlib

    monkeypatch.setenv("MKL_NUM_THREADS", "1")
    blocks, E, F, g = layer200
    now, cost = [0.0], [0.0]

    def clock():
        now[0] += 1.0
        return now[0]

    def slow(call):
        def timed(*args, **kwargs):
            out = call(*args, **kwargs)
            now[0] += cost[0]
            return out
        return timed

    monkeypatch.setattr(sparse_mod, "time", SimpleNamespace(perf_counter=clock))
    monkeypatch.setattr(sparse_mod, "factorize", slow(sparse_mod.factorize))
    monkeypatch.setattr(factor_module.PardisoSymmetric, "factor", slow(factor_module.PardisoSymmetric.factor))
    hashes, systems = set(), set()
    for c in CLOCK_COSTS:
        cost[0] = c
        sc = SparseContact(blocks, E, factorization=factorization)
        h, counts = hashlib.sha256(), []
        for load in (F, 1.3 * F):
            u, phi, y, active, steps = sc.solve(load, g)
            counts.append(steps)
            for a in [*u, *(p for p in phi if p is not None), y, active]:
                h.update(np.ascontiguousarray(a).tobytes())
        assert active.any() and not active.all()
        hashes.add(h.hexdigest())
        systems.add(tuple(counts))
    assert len(systems) == len(CLOCK_COSTS)              # three paths (not one path three times)
    assert len(hashes) == 1                               # one answer
