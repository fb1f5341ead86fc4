"""Rows of two obstacles at one node (cvxcontact/backends/parallel.py looser_rows, ParallelRows; signorini.py _hand_over; the AMG
route, cvxcontact/backends/amg.py, own_dofs): a whole floor and a
strip raised 3e-6 m above it over 0.3 <= x < 0.7 (tests/reach_scenes.lowered with a negative drop) under the block
pushed by DELTA. Both rows of a node under the strip are the same row of G with gaps 3e-6 apart: closed together,
K(A) of the sparse route is singular, and its steps met a singular system from every start (the 3D P2 default call,
which takes the sparse route, raised SolverError; method="sparse" did in 2D P1/P2 and 3D P1 too). The looser row
now stays open, on the sparse and the AMG route; the answers are checked against the condensed and full routes
(interior point + exact finish, a different algorithm on the same discrete problem). looser_rows against its
definition on random rows: tests/test_looser_rows.py."""

import numpy as np
import pytest
import scipy.sparse as sp
from reach_scenes import block2d, block3d, kinked, line, lowered, strip

import cvxcontact as cc
from cvxcontact.backends.factor import pardiso_available
from cvxcontact.backends.parallel import ParallelRows, looser_rows
from cvxcontact.backends.sparse import SparseContact

pytestmark = [pytest.mark.numerics,    # re-run under every OpenBLAS kernel set by .ci/run
              pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]   # a 3 x 3 box's faces

UP = 3e-6
"""m: the strip's height above the floor."""


def raised_3d():
    return block3d((strip(-1, 2), lowered(0.3, 0.7, 3, drop=-UP)))


def raised_2d():
    return block2d((line(-1, 2), lowered(0.3, 0.7, 2, drop=-UP)))


def u_gap(a, b) -> float:
    """max |u_a - u_b| over max |u_b| (every body)."""
    return max(np.abs(x - y).max() for x, y in zip(a.u, b.u)) / max(np.abs(y).max() for y in b.u)


def test_looser_rows_keeps_the_tightest_of_each_parallel_group():
    """By hand: rows 0, 1, 4 parallel (1 = 2 x 0, 4 = 0), normalised gaps 1, 0.75, 0.75: row 1 kept (the tightest,
    of the tie with 4 the first), 0 and 4 implied; row 2 (anti-parallel to 0) and row 3 (other unknowns) kept, the
    empty row 5 (a held row) not matched; rows 6, 7 differ by 1e-6 in a direction: not parallel."""
    G = sp.csr_matrix(np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 1.0],
                                [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 1e-6], [0.0, 1.0, 0.0]]))
    g = np.array([1.0, 1.5, -5.0, 1.0, 0.75, 0.0, 0.0, 1.0])
    assert looser_rows(G, g).tolist() == [True, False, False, False, True, False, False, False]
    # equal rows of equal gaps: the first kept
    assert looser_rows(sp.csr_matrix(np.ones((3, 2))), np.zeros(3)).tolist() == [False, True, True]


def test_the_parallel_groups_are_found_once_per_geometry(monkeypatch):
    """The sparse route keeps ParallelRows for the geometry (``cache.own``): two solves on one ContactSolver, one
    grouping; the second a warm start from the first's set, the same answer."""
    built, init = [], ParallelRows.__init__

    def counted(self, *args, **kwargs):
        built.append(1)
        init(self, *args, **kwargs)

    monkeypatch.setattr(ParallelRows, "__init__", counted)
    solver = cc.ContactSolver(raised_3d(), "sigma1", degree=2, method="sparse")
    first, again = solver.solve(), solver.solve()
    assert first.ok and again.ok and again.info.route == cc.Route.WARM_START and len(built) == 1
    assert u_gap(again, first) < 1e-13


@pytest.fixture(scope="module")
def p2_3d():
    """The reviewer's scene (3D P2 tetrahedra): the default call, and the condensed and full routes."""
    return {m: cc.solve(raised_3d(), "sigma1", degree=2, **({} if m == "auto" else {"method": m}))
            for m in ("auto", "condensed", "full")}


def test_default_call_on_two_obstacles_at_one_node_takes_the_sparse_route_and_agrees(p2_3d):
    """The default call settles on the sparse route (it raised SolverError before) and its answer is the other
    routes'. Measured u_gap over the five kernel sets (default, Haswell, Nehalem, Prescott, Sandybridge): 5.1e-16 to
    5.9e-16 against condensed, 2.5e-16 to 3.4e-16 against full: bound 1e-13."""
    sol = p2_3d["auto"]
    assert sol.ok and sol.info.method == "sparse" and sol.info.route == cc.Route.SPARSE_ACTIVE_SET
    for other in ("condensed", "full"):
        assert p2_3d[other].ok
        assert u_gap(sol, p2_3d[other]) < 1e-13
    p = cc.ContactSolver(raised_3d(), "sigma1", degree=2).problem       # the floor's rows under the strip
    assert np.count_nonzero(looser_rows(SparseContact(list(p.blocks), p.E).G, p.g)) > 0


@pytest.mark.parametrize("make, degree", [(raised_3d, 1), (raised_2d, 1), (raised_2d, 2)])
def test_sparse_route_on_two_obstacles_at_one_node_agrees_with_the_condensed_route(make, degree):
    """The 3D P1 and 2D P1/P2 analogues, method="sparse" (which raised SolverError before). Measured u_gap, the
    same under the five kernel sets: 3D P1 4.2e-17 to 5.3e-17, 2D P1 2.5e-16, 2D P2 6.8e-16: bound 1e-13."""
    sparse = cc.solve(make(), "sigma1", degree=degree, method="sparse")
    condensed = cc.solve(make(), "sigma1", degree=degree, method="condensed")
    assert sparse.ok and condensed.ok and sparse.info.route == cc.Route.SPARSE_ACTIVE_SET
    assert u_gap(sparse, condensed) < 1e-13


def test_sparse_route_hands_over_to_the_condensed_route_where_its_steps_do_not_settle(p2_3d, monkeypatch):
    """Without looser_rows the sparse steps meet a singular system from every start on this scene (as before the
    fix): the default call is then answered by the condensed route, the route recorded, no exception. Its answer
    is the condensed route's own (the same computation: measured u_gap 0.0)."""
    monkeypatch.setattr(ParallelRows, "looser", lambda self, g: np.zeros(self.m, dtype=bool))
    sol = cc.solve(raised_3d(), "sigma1", degree=2)
    assert sol.ok and sol.info.method == "condensed" and sol.info.route == cc.Route.SPARSE_HANDED_OVER
    assert u_gap(sol, p2_3d["condensed"]) < 1e-13
    reason = "the active-set steps on the sparse mixed system did not settle (they cycled or met a singular system)"
    assert sol.info.handed_over == reason               # the words of the log, on the solution and in its report
    assert sol.report().splitlines()[1] == (f"  method           auto -> condensed, route: "
                                            f"{cc.Route.SPARSE_HANDED_OVER} (handed over: {reason})")
    assert p2_3d["condensed"].info.handed_over == "" and "handed over" not in p2_3d["condensed"].report()


def test_a_handed_over_scene_solved_again_gives_its_first_bits(p2_3d, monkeypatch):
    """Same question, same bits (tests/test_same_bits.py) where the sparse route hands over: solved again on one
    ContactSolver, the scene is handed over again (before: the second solve's sparse steps started from the
    condensed answer's set, settled, and answered with the sparse route's bits, 5e-16 of |u| away) and gives the
    first solve's bits, a fresh solver's."""
    monkeypatch.setattr(ParallelRows, "looser", lambda self, g: np.zeros(self.m, dtype=bool))
    solver = cc.ContactSolver(raised_3d(), "sigma1", degree=2)
    first, again = solver.solve(), solver.solve()
    fresh = cc.ContactSolver(raised_3d(), "sigma1", degree=2).solve()
    for sol in (first, again, fresh):
        assert sol.info.method == "condensed" and sol.info.route == cc.Route.SPARSE_HANDED_OVER
    for sol in (again, fresh):
        assert all(np.array_equal(x, y) for x, y in zip(sol.u, first.u))
        assert all(np.array_equal(a.force, b.force) for a, b in zip(sol.contacts, first.contacts))


@pytest.mark.parametrize("degree, drop", [(1, -UP), (2, -UP), (1, 0.0), (2, 0.0)])
def test_amg_route_keeps_two_obstacles_at_one_node(degree, drop):
    """method="amg" on the 3D block on a floor and a strip raised by UP (or coincident with the floor, drop 0): the
    AMG route takes it (it handed such scenes to the sparse route before: two rows at one node had no dof of their
    own), the looser row open, and agrees with the sparse and condensed routes to its Krylov tolerance (1e-10).
    Where the gaps are equal the whole force goes on one pair, the floor (the first), as on the sparse route: the
    strip's forces are 0, and lambda_h on the side is the sparse route's. Measured over the five kernel sets, u_gap
    against sparse and condensed: P1 9.5e-17 to 2.1e-16 (raised), <= 6.8e-30 (coincident); P2 7.8e-11 (raised),
    7.0e-11 (coincident): bound 1e-8; forces and lambda_h against sparse (over their largest): P1 <= 1.5e-16, P2
    <= 4.7e-10: bound 1e-7."""
    pytest.importorskip("pyamg")
    def scene():
        return block3d((strip(-1, 2), lowered(0.3, 0.7, 3, drop=drop)))

    amg = cc.solve(scene(), "sigma1", degree=degree, method="amg")
    sparse = cc.solve(scene(), "sigma1", degree=degree, method="sparse")
    condensed = cc.solve(scene(), "sigma1", degree=degree, method="condensed")
    assert amg.ok and amg.info.method == "amg" and amg.info.route == cc.Route.KRYLOV_ACTIVE_SET
    assert sparse.ok and condensed.ok and sparse.info.method == "sparse"
    assert u_gap(amg, sparse) < 1e-8 and u_gap(amg, condensed) < 1e-8
    for field in ("force", "lam"):
        scale = max(np.abs(getattr(c, field)).max() for c in sparse.contacts)
        assert max(np.abs(getattr(a, field) - getattr(b, field)).max()
                   for a, b in zip(amg.contacts, sparse.contacts)) < 1e-7 * scale
    if drop == 0.0:
        assert not np.any(amg.contacts[1].force) and not np.any(sparse.contacts[1].force)


def test_a_hand_over_keeps_the_sparse_route_s_factorisation_time(monkeypatch):
    """The handed-over solve's ``timings["factorization"]`` counts the sparse route's factorisations too (before:
    the condensed route's set-up overwrote them). Each sparse factorisation is made to count 1000 s here."""
    refactor = SparseContact._refactor

    def slow(self, *args, **kwargs):
        out = refactor(self, *args, **kwargs)
        self.factor_time += 1000.0
        return out

    monkeypatch.setattr(SparseContact, "_refactor", slow)
    monkeypatch.setattr(ParallelRows, "looser", lambda self, g: np.zeros(self.m, dtype=bool))
    sol = cc.solve(raised_3d(), "sigma1", degree=2)
    assert sol.info.route == cc.Route.SPARSE_HANDED_OVER
    assert sol.info.timings["factorization"] >= 1000.0


@pytest.mark.parametrize("field", ["compliant", "friction", "force_control", "conic"])
def test_the_sparse_backend_takes_no_rows_looser_rows_would_be_wrong_on(field):
    """looser_rows holds for Signorini rows of fixed gaps only: a looser row penetrated under a compliance law
    carries a force, a row's force bounds its friction, a force-controlled obstacle's gaps g - R tau may change
    order with tau. The sparse and AMG routes, its callers, take none."""
    from cvxcontact.backends import ProblemDescription, backend

    assert backend("sparse").accepts(ProblemDescription())
    assert not backend("sparse").accepts(ProblemDescription(**{field: True}))
    assert not backend("amg").accepts(ProblemDescription(**{field: True}))


def test_above_sparse_rows_the_unsettled_steps_raise_a_typed_error_naming_the_fix(monkeypatch):
    """No hand-over above SPARSE_ROWS rows (the condensed route's dense m x m matrices): the SolverError names the
    routes to use (SPARSE_ROWS lowered below the scene's rows here)."""
    from cvxcontact import backends

    monkeypatch.setattr(ParallelRows, "looser", lambda self, g: np.zeros(self.m, dtype=bool))
    monkeypatch.setattr(backends, "SPARSE_ROWS", 10)
    with pytest.raises(cc.SolverError, match=r"did not settle.*use method='condensed' or 'full'"):
        cc.solve(raised_3d(), "sigma1", degree=2, method="sparse")


FACTORIZATIONS = ["superlu", pytest.param("pardiso", marks=pytest.mark.skipif(not pardiso_available(),
                                                                              reason="Intel oneMKL not installed"))]


@pytest.mark.parametrize("factorization", FACTORIZATIONS)
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("shift", [0.0, -1e-18])
def test_the_sparse_steps_never_close_a_looser_row(shift, degree, factorization):
    """Two obstacles at every node of the 3D block's bottom (reach_scenes.kinked: touched where x <= 0.3, found in
    two or three sets from the bonded start), the second's gaps equal to the first's (``shift`` 0) or 1e-18 m
    tighter. The steps' next set y w + s > 0 took in the looser rows, whose slack is their tight twin's (its
    rounding, > 0 half the time): K(A) singular. Before (the review of h-looser): with SuperLU the coincident
    scenes' steps stopped and were handed to the condensed route; with PARDISO (its perturbed pivots) they
    settled with the node's force split between the two pairs (coincident: 2.4e6 and 1.6e6 N on P1), and at 1e-18
    m 40 % of it on the floor's rows, which the tighter obstacle implies (their force is 0 at the answer), u 5.0e-14
    from the reference. Now every set stays within the rows that may close: the looser pair carries nothing (exact:
    its rows are never closed), and u and the forces summed over the pairs are those of the one obstacle of the
    tightest gaps, method "full" (an interior point and exact finish on a problem without repeated rows).
    Measured over the five kernel sets (default, Haswell, Nehalem, Prescott, Sandybridge; both factorisations, P1
    and P2): u 2.6e-17 to 1.0e-15, summed forces 3.7e-17 to 2.5e-15 of the reference's max; bounds 1e-12, 2e-12
    (the fault's u, 5.0e-14, passes them: the looser pair's zero force is what fails before)."""
    scene = block3d((kinked(3), kinked(3, shift=shift)))
    sol = cc.solve(scene, "sigma1", degree=degree, method="sparse", factorization=factorization)
    ref = cc.solve(block3d((kinked(3, shift=shift),)), "sigma1", degree=degree, method="full")
    assert ref.ok and sol.ok and sol.info.method == "sparse" and sol.info.route == cc.Route.SPARSE_ACTIVE_SET
    looser = 1 if shift == 0.0 else 0                  # equal gaps: the first pair kept (ties by index)
    assert not np.any(sol.contacts[looser].force)
    assert np.abs(sol.u[0] - ref.u[0]).max() < 1e-12 * np.abs(ref.u[0]).max()
    total = sol.contacts[0].force + sol.contacts[1].force
    assert np.abs(total - ref.contacts[0].force).max() < 2e-12 * np.abs(ref.contacts[0].force).max()
