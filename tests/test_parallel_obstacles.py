"""Every route on obstacles whose rows repeat at a node (cvxcontact/backends/parallel.py): two coincident floors
(equal rows, equal gaps: the split of a node's force between the pairs is not unique, its sum is), a floor and a
strip of it (coincident over part of the part) and a floor with a strip raised 3e-6 m above it over part
(equal rows, different gaps: the floor's row there is implied), under the block pushed by DELTA (tests/
reach_scenes.py), 2D P1/P2, 3D P1/P2 tetrahedra and Q1 hexahedra, over method "full" (the reference backend),
"condensed", "sparse", "amg" and the default call. Before, method="full" read ok=False on every scene with
coincident rows but 2D P2 coincident floors and the 2D P1 floor and strip (its exact finish closed both equal rows
of a node: (26) singular; the interior point kept, its complementarity 1.9e-5 to 1.1e-4, 1e-4 of |u| away on 3D
P2).

Checked against an independent reference: the same block on ONE obstacle of the tightest gaps (the floor, or
:func:`reach_scenes.raised`), a problem of the same feasible set without repeated rows: u, the pairs' forces summed
at each node, and lambda_h summed over the pairs of the side (read once per side, cvxcontact/solution/sides.py)."""

import numpy as np
import pytest
import scipy.sparse as sp
from reach_scenes import BODIES, block3d, floor, lowered, raised
from reach_scenes import block as scene

import cvxcontact as cc
from cvxcontact.backends.parallel import (
    closed_once,
    looser_rows,
    normalised_gaps,
    repeated_rows,
)

pytestmark = [pytest.mark.numerics,    # re-run under every OpenBLAS kernel set by .ci/run
              pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]   # a 3 x 3 box's faces

UP = 3e-6
"""m: the strip's height above the floor."""

KINDS = {
    "coincident": (lambda d: (floor(d), floor(d)), lambda d: floor(d)),
    "coincident over part": (lambda d: (floor(d), floor(d, 0.3, 0.7)), lambda d: floor(d)),
    "raised over part": (lambda d: (floor(d), lowered(0.3, 0.7, d, drop=-UP)), lambda d: raised(0.3, 0.7, d, UP)),
}
"""kind: (the obstacles, the one obstacle of the tightest gaps), each of the dimension."""

METHODS = ("full", "condensed", "sparse", "amg", "auto")


@pytest.fixture(scope="module")
def references():
    """(body, kind) -> the block on the one obstacle of the tightest gaps, method "full"."""
    out = {}

    def get(body, kind):
        if (body, kind) not in out:
            dim, degree, cell = BODIES[body]
            out[body, kind] = cc.solve(scene((KINDS[kind][1](dim),), dim, cell), "sigma1", degree=degree,
                                       method="full")
        return out[body, kind]

    return get


def summed(ref, sol, field):
    """``field`` ("force" or "lam") of every pair of ``sol`` summed at each node of the reference's one pair
    (matched by position)."""
    at = {tuple(np.round(p, 9)): i for i, p in enumerate(ref.contacts[0].points)}
    total = np.zeros(len(at))
    for c in sol.contacts:
        idx = [at[tuple(np.round(p, 9))] for p in c.points]
        np.add.at(total, idx, getattr(c, field))
    return total


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.fixture(scope="module")
def solved():
    """(body, kind, method) -> the block on the kind's obstacles by that method ("auto": the default call)."""
    out = {}

    def get(body, kind, method):
        if (body, kind, method) not in out:
            dim, degree, cell = BODIES[body]
            out[body, kind, method] = cc.solve(scene(KINDS[kind][0](dim), dim, cell), "sigma1", degree=degree,
                                               **({} if method == "auto" else {"method": method}))
        return out[body, kind, method]

    return get


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("body", list(BODIES))
def test_every_route_answers_repeated_rows_as_one_obstacle_of_the_tightest_gaps(body, kind, method, references,
                                                                                solved):
    """ok; u, the pairs' forces summed at each node and lambda_h summed over the side's pairs those of the one
    obstacle of the tightest gaps (the same feasible set: the same discrete answer). Measured over the five kernel
    sets (default, Haswell, Nehalem, Prescott, Sandybridge), the worst (body, kind, method), relative to the max of
    the reference's: u 2.3e-15 to 4.9e-15 (bound 1e-12), forces 6.4e-15 to 1.3e-14 (bound 2e-12), lambda_h 3.9e-14
    to 8.4e-14 (bound 1e-11).

    On "raised over part" the floor is open under the strip, the strip closed, and the split is unique (the floor's
    rows under the strip are implied), so each pair's force and lambda_h are also asserted equal to method="full"'s
    (measured, five kernel sets, every kind "raised over part": 2.7e-15 to 3.7e-15 of the reference's max; bound
    1e-12). There 2D P2 read each pair's own multiplier before h-full2-rev (runs share by segments: one pair closed
    and one open at a node), whose sum was not the one obstacle's lambda_h (1.05 relative, twice its value at the
    strip's end vertices); now the closed runs take each node's share (``QuadraticInterface.shares``): 7.8e-16 to 1.2e-15 (five
    kernel sets, every route; within the bound above).

    The AMG route keeps the 3D scenes (the looser or repeated rows left open on their shared dof) and stops its Krylov
    steps at 1e-10: exact to that, not to rounding. Measured (3D P2, five kernel sets): u 7.0e-11 .. 7.8e-11, forces
    and lambda_h <= 4.7e-10 of the reference's max (3D P1, hexahedra: 2e-16); bounds 1e-8, 1e-7."""
    if method == "amg":
        pytest.importorskip("pyamg")
    u_tol, f_tol, lam_tol = (1e-8, 1e-7, 1e-7) if method == "amg" else (1e-12, 2e-12, 1e-11)
    sol, ref = solved(body, kind, method), references(body, kind)
    assert ref.ok and sol.ok
    assert rel(sol.u[0], ref.u[0]) < u_tol
    assert rel(summed(ref, sol, "force"), ref.contacts[0].force) < f_tol
    assert rel(summed(ref, sol, "lam"), ref.contacts[0].lam) < lam_tol
    if kind == "raised over part":
        full = solved(body, kind, "full")
        pair_tol = 1e-7 if method == "amg" else 1e-12
        for mine, theirs in zip(sol.contacts, full.contacts):
            assert np.abs(mine.force - theirs.force).max() <= pair_tol * np.abs(ref.contacts[0].force).max()
            assert np.abs(mine.lam - theirs.lam).max() <= pair_tol * np.abs(ref.contacts[0].lam).max()


def test_repeated_rows_by_hand():
    """Rows 0, 2, 4 equal up to a positive factor with equal normalised gaps (row 2 = 2 x row 0, gap 2 x 1): one
    class, its first row 0; row 1 parallel to 0 with a larger gap (implied: looser_rows, not a repeat); row 3 on
    other unknowns; the empty row 5 (a held row) matched with nothing. closed_once keeps the first ACTIVE row of a
    class (row 2 where 0 is open) and every row of no class."""
    G = sp.csr_matrix(np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 1.0],
                                [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    g = np.array([1.0, 1.5, 2.0, 1.0, 1.0, 0.0])
    first = repeated_rows(G, g)
    assert first.tolist() == [0, 1, 0, 3, 0, 5]
    assert looser_rows(G, g).tolist() == [False, True, True, False, True, False]
    assert closed_once(first, np.ones(6, dtype=bool)).tolist() == [True, True, False, True, False, True]
    assert closed_once(first, np.array([0, 1, 1, 1, 1, 0], dtype=bool)).tolist() == [False, True, True, True,
                                                                                     False, False]
    assert repeated_rows(G, g + np.array([0, 0, 0, 0, 1e-9, 0])).tolist() == [0, 1, 0, 3, 4, 5]   # 1e-9: not equal
    # an infinite gap repeats nothing, and sets no scale for the others' (1 and 1 + 1e-6: not equal)
    assert repeated_rows(sp.csr_matrix(np.ones((3, 1))), np.array([np.inf, 1.0, 1.0 + 1e-6])).tolist() == [0, 1, 2]


def test_closed_once_keeps_the_tightest_row_of_a_class():
    """A class's gaps agree only to PARALLEL_TOL of the largest normalised gap (here 1e3: rows 0 and 1, equal, of
    gaps 1 + 1e-10 and 1, are one class): of its active rows the tightest is closed (row 1), so the looser one
    left open is feasible (slack -1e-10), not the tighter one penetrated by 1e-10 (h-full2 kept the first, row
    0); of equal gaps the first, as before."""
    G = sp.csr_matrix(np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 0.0], [2.0, 0.0]]))
    g = np.array([1.0 + 1e-10, 1.0, 1e3, 4.0, 4.0])
    first = repeated_rows(G, g)
    assert first.tolist() == [0, 0, 2, 3, 3]
    assert closed_once(first, np.ones(5, dtype=bool), normalised_gaps(G, g)).tolist() == [False, True, True, True,
                                                                                          False]
    assert closed_once(first, np.array([1, 0, 1, 1, 1], dtype=bool), normalised_gaps(G, g)).tolist() == [
        True, False, True, True, False]                     # the looser row alone active: it is closed


@pytest.mark.parametrize("body", ["2D P1", "3D P1"])
def test_model_with_a_user_row_on_coincident_floors(body):
    """cc.Model with a user row takes the exact solve of (26) with extra rows (full.mixed_kkt_rows), which closed
    both equal rows of a node as h-full2 left it: ok False ("the mixed system on the active set is singular",
    complementarity 2.3e-5 2D P1, 6.2e-5 3D P1). Now each class of repeated rows closed once there too: ok, and u
    and the summed forces those of the one floor under the same Model row. Measured over the five kernel sets:
    u and forces 0 from the reference's (the same bits; bounds 1e-12, 2e-12 of its max)."""
    dim, degree, cell = BODIES[body]
    sols = []
    for obstacles in ((floor(dim), floor(dim)), (floor(dim),)):
        model = cc.Model(scene(obstacles, dim, cell), condition="sigma1", degree=degree)
        model.add(model.u(0)[0, 0] >= -1.0)            # a user row (slack: 1 m), the rows' path of the finish
        sols.append(model.solve())
    sol, ref = sols
    assert ref.ok and sol.ok
    assert rel(sol.u[0], ref.u[0]) < 1e-12
    assert rel(summed(ref, sol, "force"), ref.contacts[0].force) < 2e-12


@pytest.mark.parametrize("body", ["3D P1", "3D Q1"])
def test_amg_warm_start_after_the_tighter_obstacle_swaps_stays_warm(body, monkeypatch):
    """One AMG ContactSolver whose strip moves from 3e-6 m above the floor to 3e-6 m below it, to it, 1e-9 m below
    it and back: each re-solve is one warm Krylov solve (``KrylovContact.solve`` called once, the route
    WARM_START) and answers as a fresh solver. Before, with the strip below (every row closed on the floor at
    gap 0) the reduced right-hand side was F's rounding (6.9e-18 against ||F|| = 0.10, P1; 8.8e-18, Q1), the warm
    Krylov solve could not meet 1e-10 of it and the route solved again cold (two calls, KRYLOV_ACTIVE_SET); now
    such a b is zero (``amg.rounding_floor``: 5.2e-16 and 7.6e-16 here) and its answer x_fix. u and the summed
    forces against the fresh solver's, relative to its max: the bounds of the AMG route above (1e-8, 1e-7);
    measured over the five kernel sets: 0 (the strip below, at, 1e-9 m below: the same bits) to 5.5e-16 (u), 0 to
    1.5e-16 (forces)."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    dim, degree, cell = BODIES[body]
    calls = []
    solve = amg.KrylovContact.solve
    monkeypatch.setattr(amg.KrylovContact, "solve", lambda self, *a, **k: calls.append(1) or solve(self, *a, **k))

    def made(drop):
        return scene((floor(dim), lowered(0.3, 0.7, dim, drop=drop)), dim, cell)
    solver = cc.ContactSolver(made(-UP), "sigma1", degree=degree, method="amg")
    assert solver.solve().ok
    for drop in (UP, 0.0, 1e-9, -UP):
        calls.clear()
        sol = solver.solve(made(drop))
        assert len(calls) == 1 and sol.info.route == cc.Route.WARM_START
        fresh = cc.solve(made(drop), "sigma1", degree=degree, method="amg")
        assert sol.ok and fresh.ok
        assert rel(sol.u[0], fresh.u[0]) < 1e-8
        assert rel(summed(fresh, sol, "force"), summed(fresh, fresh, "force")) < 1e-7


@pytest.fixture(scope="module")
def without_far_floor():
    """(body, up) -> (the block on the floor and the strip raised ``up`` over 0.3 <= x < 0.7, the block on the
    one obstacle :func:`reach_scenes.raised` of the same gaps), both method "full"."""
    out = {}

    def get(body, up):
        if (body, up) not in out:
            dim, degree, cell = BODIES[body]
            out[body, up] = tuple(cc.solve(scene(obstacles, dim, cell), "sigma1", degree=degree, method="full")
                                  for obstacles in ((floor(dim), lowered(0.3, 0.7, dim, drop=-up)),
                                                    (raised(0.3, 0.7, dim, up),)))
        return out[body, up]

    return get


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("far", [1.0, 1000.0])
@pytest.mark.parametrize("up", [UP, 1e-13])
@pytest.mark.parametrize("body", list(BODIES))
def test_a_far_floor_changes_nothing(body, up, far, method, without_far_floor):
    """A floor, a strip raised ``up`` above it over 0.3 <= x < 0.7 and a far floor ``far`` m below the first,
    never touched: the answer of the floor and the strip alone, the far floor's forces and lambda_h 0. The far
    floor's rows repeat the floor's at every node (equal rows, gaps ``far`` apart), as the strip's do over its part.

    Before (found by a review), methods "full" and "condensed" (and the default call on 2D P2) read ok False on
    every body wherever the far floor was 1000 m below, and with it 1 m below under a strip raised 1e-13 m (3D Q1
    "condensed" under the strip at 3e-6 m too; 2D P2, and 3D P2 on "full", also without it, the strip at
    1e-13 m): the exact finish on the interface (the LCP of
    cvxcontact/backends/finish/lcp.py) closed the floor's rows beside the strip's (W singular on the closed rows:
    the steps failed), and its NNLS fallback read a least-squares form that does not hold where d is not in the range of
    W, as two rows of different gaps make it (d's component along a far floor's repeated rows: its gap): the
    support it gave closed rows open by up to 0.14 (scaled) where d was 1e-5. Full kept the interior point
    (complementarity 0.28 to 0.60 against tol 1e-6, u 0.098 to 720 of its max from this test's reference);
    condensed closed that support (feasibility 0.32 to 0.46, or complementarity 0.25 to 0.57 in 3D; u 0.24 to 650
    off). Now the finish leaves the rows a tighter parallel row implies open, as the sparse and AMG routes do.

    References: the floor and the strip alone, and the one obstacle of the same gaps (:func:`reach_scenes.raised`,
    no repeated rows: an independent problem of the same answer), each method "full". Measured over the five
    kernel sets (default, Haswell, Nehalem, Prescott, Sandybridge), the worst case of the 100, relative to the
    reference's max: u 5.1e-16 to 7.6e-16 (bound 1e-12), each pair's force 1.4e-15 to 2.9e-15 and lambda_h 4.5e-15
    to 6.9e-15 (bound 1e-11), the far floor's force and lambda_h 0; the two references' u 2.5e-16 to 5.9e-16 apart
    (bound 1e-12). The AMG route stops its Krylov steps at 1e-10 (3D P2: u 7.8e-11, forces 2.5e-11, lambda_h
    9.0e-11, every kernel set; bounds 1e-8, 1e-7).

    lambda_h per pair: the pairs' shares of the side's lambda_h go to the pairs closed at each node
    (cvxcontact/solution/sides.py), closed read within tol of a scale that took the largest gap of any row: the far
    floor 1000 m below read the floor open by 3e-6 m under the strip closed (1e-6 x 1000 m), its share 5.2e6 Pa
    (half the strip's lambda_h) where the reference reads 0. Now each node's scale is the bodies' displacements and
    its own gap (cvxcontact/solution/nodal.py)."""
    if method == "amg":
        pytest.importorskip("pyamg")
    dim, degree, cell = BODIES[body]
    ref, one = without_far_floor(body, up)
    assert ref.ok and one.ok
    assert rel(ref.u[0], one.u[0]) < 1e-12
    sol = cc.solve(scene((floor(dim), lowered(0.3, 0.7, dim, drop=-up), lowered(-1.0, 2.0, dim, drop=far)), dim,
                         cell), "sigma1", degree=degree, **({} if method == "auto" else {"method": method}))
    u_tol, f_tol = (1e-8, 1e-7) if method == "amg" else (1e-12, 1e-11)
    assert sol.ok
    assert rel(sol.u[0], ref.u[0]) < u_tol
    f_max, lam_max = (max(np.abs(c.force).max() for c in ref.contacts), max(np.abs(c.lam).max() for c in ref.contacts))
    for mine, theirs in zip(sol.contacts, ref.contacts):         # the floor and the strip, pair by pair
        assert np.abs(mine.force - theirs.force).max() <= f_tol * f_max
        assert np.abs(mine.lam - theirs.lam).max() <= f_tol * lam_max
    far_pair = sol.contacts[2]
    assert np.abs(far_pair.force).max() <= f_tol * f_max and np.abs(far_pair.lam).max() <= f_tol * lam_max


@pytest.mark.parametrize("body", ["3D P1", "3D Q1"])
def test_amg_rounding_floor_drops_only_loads_at_rounding(body):
    """``amg.rounding_floor`` is a normwise backward error, not a test of exact zero: the box with every row closed
    on the floor at gap 0 (the strip 3e-6 m below it), plus a horizontal body force f, whose reduced right-hand side
    is f's alone (F's rounding apart). Its floor is ~75x above that rounding here, so a genuine load between them is
    dropped: f = 3e-8 N/m^3 (||b|| 0.38 of the floor, P1) gives u_x = 0 exactly (the answer x_fix) against the
    sparse route's 1.4e-20 m (P1; Q1 1.3e-20): u 1.3e-15 to 1.4e-15 of max |u| from the sparse route's over the
    five kernel sets (bound 1e-12). A load 12.6 times the floor (P1, f = 1e-6 N/m^3) is solved: u_x against the
    sparse route's, relative to its max, 1.2e-15 to 2.7e-15 over the five kernel sets (bound 1e-12); the same
    check with the floor inflated 13-fold fails (u_x = 0)."""
    pytest.importorskip("pyamg")
    dim, degree, cell = BODIES[body]
    faint, clear = 3e-8, 1e-6                       # N/m^3 (steel's weight: 7.7e4)

    def made(f):
        return block3d((floor(dim), lowered(0.3, 0.7, dim, drop=UP)), cell=cell, body_force=(f, 0.0, 0.0))
    out = {}
    for f in (faint, clear):
        sol = cc.solve(made(f), "sigma1", degree=degree, method="amg")
        ref = cc.solve(made(f), "sigma1", degree=degree, method="sparse")
        assert sol.ok and ref.ok and sol.info.method == "amg"
        out[f] = (sol.u[0], ref.u[0])
    u, ref = out[faint]
    assert np.abs(ref[:, 0]).max() > 0.0 and not u[:, 0].any()
    assert rel(u, ref) < 1e-12
    u, ref = out[clear]
    assert rel(u[:, 0], ref[:, 0]) < 1e-12
