"""The sparse route in 3D (cvxcontact/backends/sparse.py, signorini.cheap_start) and the bonded yardsticks of
benchmarks/harness.py (benchmarks/bench3d.py), cross-checked against the condensed route and direct solves. No
timing is asserted."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from conftest import benchmark, fields_agree, rel
from scenes3d import sphere_into_block, two_boxes

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.signorini import cheap_start
from cvxcontact.backends.sparse import SparseContact

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

@pytest.fixture(scope="module")
def sphere():
    return sphere_into_block(12)


@pytest.fixture(scope="module")
def boxes():
    return two_boxes(4)


def test_cheap_start_closes_the_overlap_in_3d_only(sphere, boxes):
    """3D: the rows inside the sphere's initial overlap (g <= 0), a strict part of the rows; none where every row
    starts closed (two boxes, g = 0: the bonded start) and none in 2D."""
    p = cc.ContactSolver(sphere).problem
    start = cheap_start(p)
    assert start is not None and np.array_equal(start, ~p.held_rows & (p.g <= 0))
    assert 0 < start.sum() < len(start)
    assert cheap_start(cc.ContactSolver(boxes).problem) is None
    assert cheap_start(cc.ContactSolver(two_blocks(8)).problem) is None


def test_sparse_route_in_3d_agrees_with_the_condensed_route(sphere):
    """The sparse route (cheap start) and the condensed route (interior point + exact LCP finish) give the
    same fields and active set on the sphere pressed into a block (9 of 169 rows closed)."""
    a = cc.solve(sphere, method="sparse")
    b = cc.solve(sphere, method="condensed")
    assert a.ok and b.ok and a.info.method == "sparse"
    assert 0 < np.sum(a.contact.active) < len(a.contact.active)
    assert np.array_equal(a.contact.active, b.contact.active)
    assert rel(a.u[0], b.u[0]) < 1e-9                           # measured 7e-16
    assert rel(a.contact.force, b.contact.force) < 1e-9          # measured 1.3e-15


def test_cheap_start_and_bonded_start_reach_the_same_answer(sphere):
    """The same exact answer from both starts; the cheap one solves fewer systems (measured 1 against 4
    at this size; 2 against 6 at 22,500 unknowns)."""
    p = cc.ContactSolver(sphere).problem
    rhs = np.concatenate([quasi_definite_rhs(b) for b in p.blocks])
    runs = [SparseContact(list(p.blocks), p.E).solve(rhs, p.g, start) for start in (cheap_start(p), ~p.held_rows)]
    (u1, _, y1, a1, steps1), (u2, _, y2, a2, steps2) = runs
    assert np.array_equal(a1, a2)
    assert rel(u1[0], u2[0]) < 1e-12 and rel(y1, y2) < 1e-12    # measured 7e-16, 1.6e-15
    assert steps1 < steps2


@pytest.mark.parametrize("scene", ["sphere", "boxes"])
def test_bench_elimination_solves_the_bonded_system(scene, request):
    """The AMG yardstick's reduction (each contact row solved for its own dof) gives the bonded system's
    solution: against a direct solve of the whole KKT system."""
    b = benchmark("harness")
    p = cc.ContactSolver(request.getfixturevalue(scene)).problem
    K, rhs, A, G, _ = b.bonded_system(p)
    z = spla.spsolve(K.tocsc(), rhs)
    n = A.shape[0]
    T, x0, slaves = b.eliminate(G, rhs[n:], n)
    assert len(slaves) == G.shape[0] and T.shape == (n, n - G.shape[0])
    xr = spla.spsolve((T.T @ A @ T).tocsc(), T.T @ (rhs[:n] - A @ x0))
    assert rel(T @ xr + x0, z[:n]) < 1e-10                       # measured 1.6e-15, 1.1e-15
    assert np.abs(G @ (T @ xr + x0) - rhs[n:]).max() < 1e-12 * np.abs(z[:n]).max()   # measured 0, 5e-17


@pytest.mark.parametrize("scene", ["sphere", "boxes"])
def test_bench_amg_yardstick_runs_the_routes_v_cycle(scene, request, monkeypatch):
    """The bonded AMG yardstick (``harness.amg_bonded``: CG, and GMRES with the block upper-triangular
    preconditioner for the piezoelectric boxes) applies the route's ``amg.v_cycle``, not pyamg's
    ``aspreconditioner`` (the same cycle with two residual norms more: a yardstick about 7 % slower would flatter
    the route's ratios), and solves the bonded system: against a direct solve of the whole KKT system."""
    pyamg = pytest.importorskip("pyamg")

    def refused(self, cycle="V"):
        raise AssertionError("the yardstick applies pyamg's aspreconditioner")

    monkeypatch.setattr(pyamg.multilevel.MultilevelSolver, "aspreconditioner", refused)
    b = benchmark("harness")
    p = cc.ContactSolver(request.getfixturevalue(scene)).problem
    K, rhs, A, G, sizes = b.bonded_system(p)
    z = spla.spsolve(K.tocsc(), rhs)
    out = b.amg_bonded(p, A, G, rhs, sizes)
    assert out is not None and out[2] > 0
    assert rel(out[1], z[:A.shape[0]]) < 1e-6              # measured 1.9e-10, 1.3e-10 (5 kernels; Krylov to 1e-10)


def test_bench_amg_yardstick_is_seeded(boxes):
    """The bonded AMG yardstick's set-ups are seeded (pyamg's spectral-radius estimates start from random vectors):
    two runs from different global random states give the same bits (unseeded: 1.5e-12 relative apart on these
    boxes), and the caller's random stream is left as it was."""
    pytest.importorskip("pyamg")
    b = benchmark("harness")
    p = cc.ContactSolver(boxes).problem
    _, rhs, A, G, sizes = b.bonded_system(p)
    runs = []
    for seed in (1, 2):
        np.random.seed(seed)
        runs.append(b.amg_bonded(p, A, G, rhs, sizes))
        assert np.random.rand() == np.random.RandomState(seed).rand()         # the stream untouched
    assert runs[0][2] == runs[1][2] and np.array_equal(runs[0][1], runs[1][1])


def test_bench_elimination_refuses_rows_sharing_their_dofs():
    """gamma3-like rows (two rows on one dof, none of its own) cannot be eliminated: None, not a wrong system."""
    import scipy.sparse as sp

    G = sp.csr_matrix(np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0]]))
    assert benchmark("harness").eliminate(G, np.zeros(2), 3) is None


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_coarse_start_in_3d_reaches_the_answer_of_the_bonded_start_and_the_full_model(monkeypatch, factorization):
    """The route's coarse start (SparseContact.coarse_start, taken above COARSE_ROWS free rows where the obstacles
    close no row first: lowered here to the 49 rows of two PZT-5A / aluminium boxes, g = 0 everywhere) fires in
    3D too: its start (measured 42 rows) is not the answer (38), and the steps from it end on the active set and
    fields of the bonded start and of the full model (interior point + exact finish)."""
    import cvxcontact.backends.sparse as sparse_mod
    from cvxcontact.backends.factor import pardiso_available

    if factorization == "pardiso" and not pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    scene = two_boxes(6)
    bonded = cc.solve(scene, method="sparse", factorization=factorization)      # 49 rows < COARSE_ROWS
    starts, coarse_start = [], SparseContact.coarse_start

    def spy(self, *args):
        starts.append(coarse_start(self, *args))
        return starts[-1]

    monkeypatch.setattr(sparse_mod, "COARSE_ROWS", 10)
    monkeypatch.setattr(SparseContact, "coarse_start", spy)
    solver = cc.ContactSolver(scene, method="sparse", factorization=factorization)
    sol = solver.solve()
    assert len(starts) == 1 and starts[0] is not None and sol.ok
    assert 0 < starts[0].sum() < len(starts[0]) and not np.array_equal(starts[0], solver.cache.active)
    # measured (SuperLU, PARDISO) u <= 2.0e-15, phi <= 2.3e-15, force <= 4.9e-15 against the bonded start and the
    # full model: >= 2e4x
    fields_agree(sol, bonded, 1e-10)
    fields_agree(sol, cc.solve(scene, method="full"), 1e-10)
