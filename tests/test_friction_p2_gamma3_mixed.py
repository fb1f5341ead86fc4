"""Friction (cc.Tresca, cc.Coulomb) with P2 elements under "gamma3" beside a pair under a nodal condition
(docs/refusals.md row 32; docs/howto/friction.md, "P2 under 'gamma3'"): the cones of every element of the "gamma3"
pairs and the nodal pair's rows as degenerate cones, all on the rows of E (the nodes of X_h on the cones' pairs,
the nodal pair's own rows), a friction row at each of them with its own weight (Simpson's of the merged P2 line;
of the nodal pair's trace), one program, finished exactly.

Checked against references the code under test does not make: closed forms (a stuck uniform stack of three
blocks, 2D and 3D, exact in P2), the frictionless answer of the same scene (cc.solve without a law: a vanishing
threshold departs from it linearly), one body made of the three blocks (a threshold that holds every row: the
stack bonded), independent answers of bodies that do not touch each other, and the friction law and the cones'
feasibility read off the answer's fields by this module's own code (Simpson's weights, the slip from the nodal
displacements, the P2 trace sampled on every segment). Sliding stacks (:func:`friction_scenes.dragged_stack`: one
pair slides on every row, the other holds; the cones' pair or the nodal pair, a rigid floor as the second pair,
a piezoelectric middle block, 3D): the shear through both pairs fixed by the middle block's equilibrium, the law
on each pair's own rows (a nodal pair's rows the P2 basis of X_h at that body's nodes, built here), the pairs
listed either way round.
"""

import contextlib
import warnings

import numpy as np
import pytest
from friction_scenes import (
    DIAGONAL3,
    E,
    H,
    L,
    P,
    dragged_stack,
    dragged_stack3d,
    pair2d,
    rolled_stack,
    rolled_union,
    steel,
    uniform_pair3d,
    uniform_stack,
    uniform_stack3d,
)
from reference_problems import simpson

import cvxcontact as cc

LAGRANGE = (lambda t: 2 * (t - 0.5) * (t - 1), lambda t: -4 * t * (t - 1), lambda t: 2 * t * (t - 0.5))
MIXED = [(("gamma3", "sigma1"), (4, 3, 3)), (("sigma1", "gamma3"), (3, 3, 5))]
"""The conditions of the upper and lower pair with the blocks' cells across: the cones' pair on non-matching lines,
the nodal pair on matching ones (on non-matching lines the nodal rows' point forces are not the consistent loads
of the other body's trace, and no P2 field is exactly the uniform state: 2 % off it, measured, with or without
the cones)."""


@contextlib.contextmanager
def _strict():
    """A ResidualWarning (a declined finish) as an error: every answer here must be finished."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        yield


def _line(sol, k, y):
    """Body ``k``'s nodes on the line y (sorted by x: vertex, midpoint, vertex, ...) and their displacements."""
    x, u = sol.points[k], sol.u[k]
    on = np.flatnonzero(np.abs(x[:, 1] - y) < 1e-12)
    on = on[np.argsort(x[on, 0])]
    return x[on], u[on]


def _simpson(x):
    """Simpson's weights of the P2 line through the sorted nodes ``x`` (vertex, midpoint, vertex, ...; (n, 2))."""
    return simpson(np.asarray(x)[0::2, 0])


def _largest_sample(values, samples=401):
    """The largest value of the P2 interpolant of nodal ``values`` (vertex, midpoint, vertex, ...) over every
    segment, sampled at ``samples`` points each."""
    t = np.linspace(0.0, 1.0, samples)
    return max(float(max(sum(f(t) * values[2 * s + k] for k, f in enumerate(LAGRANGE))))
               for s in range((len(values) - 1) // 2))


@pytest.mark.numerics
@pytest.mark.parametrize("cell", ["triangle", "quad"])
@pytest.mark.parametrize("law", [cc.Tresca(2 * P), cc.Coulomb(0.5)], ids=["tresca", "coulomb"])
@pytest.mark.parametrize("conditions, nx", MIXED, ids=["cones-above", "cones-below"])
def test_a_stuck_stack_of_three_blocks_is_the_closed_form(conditions, nx, law, cell):
    """Three blocks in the uniform state (sigma_yy = -p, sigma_xy = tau = 0.2 p), one pair under "gamma3", the other
    under "sigma1", the threshold (2 p, or 0.5 p) above the shear: every row stuck, u = (tau (y + 2H) / G, -p (y +
    2H) / E) in every block, exact in P2 and Q2 (measured at most 7.9e-14 of the largest displacement), finished."""
    tau = 0.2 * P
    with _strict():
        sol = cc.solve(uniform_stack(tau, law, conditions, nx, cell), degree=2)
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    scale = 1.5 * P / E
    for x, u in zip(sol.points, sol.u):
        y = x[:, 1] + 2 * H
        assert np.abs(u - np.column_stack([2 * tau * y / E, -P * y / E])).max() <= 1e-10 * scale
    for c in sol.contacts:                   # the whole shear tau L through each pair, against the first body
        assert abs(c.shear_force.sum() / (-tau * L) - 1) <= 1e-10                 # measured at most 4.3e-14


@pytest.mark.numerics
@pytest.mark.parametrize("conditions, n", [(("gamma3", "sigma1"), (2, 3, 3)), (("sigma1", "gamma3"), (3, 3, 2))],
                         ids=["cones-above", "cones-below"])
def test_3d_a_stuck_stack_of_three_boxes_is_the_closed_form_and_coulomb_beside_two_body_cones_is_refused(
        conditions, n):
    """The 3D stack (tetrahedra; the cones' pair on non-matching faces, the nodal pair on matching ones) with Tresca
    above the shear: u = (tau_x (z + 2) / G, tau_y (z + 2) / G, -p (z + 2) / E) (measured 3.2e-14, 5.3e-14),
    finished. Coulomb there stays refused, naming why: the cones' nodal force on non-matching faces between two
    bodies is not unique (tests/test_friction_p2_gamma3.py)."""
    tau = 0.2 * P
    with _strict():
        sol = cc.solve(uniform_stack3d(tau, cc.Tresca(2 * P), conditions, n), degree=2)
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    for x, u in zip(sol.points, sol.u):
        z = x[:, 2] + 2.0
        exact = np.column_stack([2 * tau * DIAGONAL3[0] * z / E, 2 * tau * DIAGONAL3[1] * z / E, -P * z / E])
        assert np.abs(u - exact).max() <= 1e-10 * 3 * P / E
    with pytest.raises(cc.UnsupportedError, match="between two bodies is not available"):
        cc.solve(uniform_stack3d(tau, cc.Coulomb(0.5), conditions, n), degree=2)


@pytest.mark.numerics
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_a_vanishing_threshold_departs_from_the_frictionless_answer_linearly(conditions):
    """The rolled stack (Poisson's expansion slides the upper blocks over the clamped one) with Tresca's g = 1e-6 p
    and 1e-5 p: every moving row slips, so the answer is the frictionless one (cc.solve without a law, the cones
    beside the nodal rows, finished) plus g times a fixed correction: the departures are in the ratio 10 (measured
    9.99999999, departures 1.6e-6 and 1.6e-5 of the displacements)."""
    scene = rolled_stack(None, conditions, nx=(4, 3, 3))
    with _strict():
        free = cc.solve(scene, degree=2)
        assert free.ok and free.polished
        scale = max(np.abs(u).max() for u in free.u)
        departures = []
        for g in (1e-6 * P, 1e-5 * P):
            sol = cc.solve(rolled_stack(cc.Tresca(g), conditions, nx=(4, 3, 3)), degree=2)
            assert sol.ok and sol.polished, sol.info.declined
            departures.append(max(np.abs(a - b).max() for a, b in zip(sol.u, free.u)) / scale)
    assert 1e-7 <= departures[0] <= 1e-5                              # measured 1.6e-6: friction acts
    assert departures[1] / departures[0] == pytest.approx(10.0, rel=1e-6)


def _union():
    """The rolled stack's three blocks as the one body they make (:func:`friction_scenes.rolled_union`), solved."""
    return cc.solve(rolled_union(), degree=2)


def _dragged(once, laws, conditions, cell="triangle"):
    """The dragged stack (:func:`friction_scenes.dragged_stack`, its pairs in their order) solved under the P2 cones
    with a ResidualWarning an error, once per module (several tests read it)."""
    with _strict():
        return once(("dragged", laws, conditions, cell),
                    lambda: cc.solve(dragged_stack(laws, conditions, cell=cell), degree=2))


def _assert_is_the_union(sol, union):
    """Every body's nodal displacements of ``sol`` are ``union``'s (the one body the stack makes) at the same points
    (to 1e-10 of its largest)."""
    at = {tuple(np.round(p, 9)): i for i, p in enumerate(union.points[0])}
    U = union.u[0]
    for x, u in zip(sol.points, sol.u):
        assert np.abs(u - U[[at[tuple(np.round(p, 9))] for p in x]]).max() <= 1e-10 * np.abs(U).max()


@pytest.mark.numerics
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_a_threshold_that_holds_every_row_gives_the_bonded_stack(conditions, once):
    """The rolled stack on matching lines with g = 100 p: every row stuck and closed, so the three blocks are the one
    body they make (:func:`friction_scenes.rolled_union`, solved without any contact between its parts): the same
    nodal displacements at every node (measured 7.4e-15 and 9.3e-15 of the largest)."""
    with _strict():
        sol = cc.solve(rolled_stack(cc.Tresca(100 * P), conditions), degree=2)
        union = once("union", _union)
    assert sol.ok and sol.polished and union.ok
    _assert_is_the_union(sol, union)


@pytest.mark.numerics
@pytest.mark.parametrize("g", [0.01 * P, 0.03 * P], ids=["slipping", "partial"])
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_the_friction_law_and_the_cones_feasibility_read_off_the_fields(conditions, g):
    """The rolled stack on matching lines (every node of X_h a node of both sides), Tresca's g = 0.01 p (every row
    but the held corner slips) and 0.03 p (partial slip on the lower pair). From the nodal displacements alone: the
    slip u_1x - u_2x at each node of the two lines (the read-back's to rounding); the capacity g times Simpson's
    weight of the line; |f_a| <= c_a, f_a = -c_a sign(s_a) where it slips, no slip where |f_a| < c_a (measured
    at most 2.2e-16 of c); the cones' pair's P2 slack u_2y - u_1y sampled on every segment nowhere above the
    rounding of the displacements (measured 0: closed along the whole line)."""
    with _strict():
        sol = cc.solve(rolled_stack(cc.Tresca(g), conditions), degree=2)
    assert sol.ok and sol.polished, sol.info.declined
    scale = max(np.abs(u).max() for u in sol.u)
    slipping = 0
    for i, (y, cond) in enumerate(zip((0.0, -H), conditions)):
        x1, u1 = _line(sol, i, y)                                  # the upper body of the pair (its first)
        x2, u2 = _line(sol, i + 1, y)
        assert np.array_equal(x1, x2)                              # matching lines
        c = sol.contacts[i]
        order = np.argsort(c.x) if c.x.ndim == 1 else np.argsort(c.x[:, 0])
        slip = u1[:, 0] - u2[:, 0]
        sign = np.sign(c.slip[order] @ slip) or 1.0               # the pair's tangent along +x or -x
        assert np.abs(sign * c.slip[order] - slip).max() <= 1e-12 * scale
        f = sign * c.shear_force[order]                             # on the upper body, along +x
        cap = g * _simpson(x1)
        assert (np.abs(f) <= cap * (1 + 1e-10)).all()
        moves = np.abs(slip) > 1e-8 * scale
        slipping += moves.sum()
        assert np.abs(f[moves] + cap[moves] * np.sign(slip[moves])).max(initial=0.0) <= 1e-10 * cap.max()
        inside = np.abs(f) < cap * (1 - 1e-6)
        assert np.abs(slip[inside]).max(initial=0.0) <= 1e-10 * scale
        if cond == "gamma3":
            assert _largest_sample(u2[:, 1] - u1[:, 1]) <= 1e-12 * scale
    assert slipping >= 4                                            # measured 16 (g = 0.01 p) and 4


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Tresca(1e6), cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
def test_a_block_on_a_disk_under_the_cones_beside_a_nodal_pair_has_the_answers_alone(law):
    """A clamped block pressed into a disk under "gamma3" (its contact ends inside elements: cut points) beside the
    sheared two-body pair of tests/friction_scenes.py under "sigma1" (non-matching lines, rows at the upper block's
    nodes, each reading three nodes of X_h), far apart, friction on both: each body has the answer it has alone
    (measured at most 1.3e-13 of its displacements, the disk's block), all finished."""
    pair = pair2d(law, q=0.01 * P)
    m = cc.rectangle(x=(3.5, 4.5), y=(0.0, 0.5), nx=8, ny=4)
    block = cc.Body(m, steel(), contact="bottom", clamped="top", name="on disk")
    disk = cc.Contact(block, "bottom", cc.Rigid.circle(center=(4.0, -1.0), radius=1.0 + 1e-4), law=law,
                      condition="gamma3")
    both = cc.Scene(*pair.bodies, block, contacts=[*pair.contacts, disk])
    with _strict(), warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = cc.solve(both, degree=2)
        alone = [cc.solve(pair, degree=2), cc.solve(cc.Scene(block, contacts=[disk]), degree=2)]
    assert sol.ok and sol.polished and all(s.polished for s in alone), sol.info.declined
    for u, ref in zip(sol.u, [alone[0].u[0], alone[0].u[1], alone[1].u[0]]):
        assert np.abs(u - ref).max() <= 1e-10 * np.abs(ref).max()


@pytest.mark.numerics
def test_3d_coulomb_on_a_nodal_pair_beside_cones_against_a_plane_has_the_answers_alone():
    """Coulomb between two 3D bodies is refused under the cones only where their pair is under "gamma3" (its nodal
    forces not unique on non-matching faces); a two-body pair under "sigma1" (the stuck layers of
    :func:`friction_scenes.uniform_pair3d`, 2 x 2 x 1 cells each: vertices and midpoints inside the face and on its
    edges; its rows' forces its own, each the sum of its degenerate element's duals) beside a box on a plane under
    "gamma3", Coulomb on both, apart: each has the answer it has alone (measured at most 6.1e-13 of the
    displacements, the box's: the fixed points' tolerance 1e-12), finished. (3 x 3 x 1 layers, the same kinds of
    rows, ran too: 8.4 CPU s more a kernel set for the same claim; benchmarks/results/ci_time.md, 2026-12-07.)"""
    scene = uniform_pair3d(0.2 * P, cc.Coulomb(0.5), n=2)
    upper, lower = scene.bodies
    floor = cc.Rigid.plane(point=(0.0, 0.0, -4.0), normal=(0.0, 0.0, 1.0))
    aside = cc.Body(cc.box(x=(2, 3), y=(0, 1), z=(-4, -3), nx=1, ny=1, nz=1), steel(), contact="bottom",
                    traction={"top": (0.1 * P, 0.0, -P)},
                    displacement={"front": (None, 0.0, None), "left": (None, 0.0, None)}, name="aside")
    first = scene.contacts[0]
    pairs = [cc.Contact(upper, "bottom", lower, "top", law=first.law, condition="sigma1"),
             cc.Contact(aside, "bottom", floor, law=cc.Coulomb(0.5), condition="gamma3")]
    with _strict():
        sol = cc.solve(cc.Scene(upper, lower, aside, contacts=pairs), degree=2)
        alone = [cc.solve(cc.Scene(upper, lower, contacts=pairs[:1]), degree=2),
                 cc.solve(cc.Scene(aside, contacts=pairs[1:]), degree=2)]
    assert sol.ok and sol.polished and all(s.polished for s in alone), sol.info.declined
    for u, ref in zip(sol.u, [alone[0].u[0], alone[0].u[1], alone[1].u[0]]):
        assert np.abs(u - ref).max() <= 1e-10 * np.abs(ref).max()


def _evaluation(X, points):
    """The P2 Lagrange basis of the line through the sorted nodes ``X`` (vertex, midpoint, vertex, ...) at the
    abscissae ``points``: a nodal pair's rows (the value of X_h's function at that body's P2 nodes)."""
    M = np.zeros((len(points), len(X)))
    for a, p in enumerate(points):
        s = min(max(int(np.searchsorted(X[::2], p, side="right")) - 1, 0), (len(X) - 1) // 2 - 1)
        t = (p - X[2 * s]) / (X[2 * s + 2] - X[2 * s])
        M[a, 2 * s: 2 * s + 3] = [f(t) for f in LAGRANGE]
    return M


def _law_on_rows(sol, contact, law, condition, line, first):
    """The friction law and the cones' feasibility of one pair, on its own rows, by this module's code: the rows
    (X_h's nodes under "gamma3"; under a nodal condition the first body's P2 nodes on the line, read through
    :func:`_evaluation`), their forces (E^T y = the pair's nodal forces on X_h, solved for y), their slips (E times
    the slip on X_h), capacities g times Simpson's weights of the rows' line or mu times the rows' normal forces.
    Returns (largest |f_a| - c_a, largest |f_a + c_a sign(s_a)| where it slips, largest slip where |f_a| < c_a,
    largest sampled slack of the cones), the first two over the largest capacity, the others over the largest
    displacement, and the share of the rows with a capacity that slip."""
    U = max(np.abs(u).max() for u in sol.u)
    o = np.argsort(contact.x)
    X = contact.x[o]
    if condition == "gamma3":
        rows, weights = np.eye(len(X)), _simpson(np.column_stack([X, 0 * X]))
    else:
        x = sol.points[first]
        at = np.sort(x[np.abs(x[:, 1] - line) < 1e-12, 0])
        rows, weights = _evaluation(X, at), _simpson(np.column_stack([at, 0 * at]))
    normal = np.linalg.lstsq(rows.T, contact.force[o], rcond=None)[0]
    shear = np.linalg.lstsq(rows.T, contact.shear_force[o], rcond=None)[0]
    assert np.abs(rows.T @ shear - contact.shear_force[o]).max() <= 1e-12 * np.abs(shear).max()
    slip = rows @ contact.slip[o]
    cap = law.threshold * weights if isinstance(law, cc.Tresca) else law.coefficient * normal
    held = cap > 1e-9 * cap.max()                          # a row with no normal force (opened) slides freely
    moves = np.abs(slip) > 1e-9 * U
    slack = 0.0
    if condition == "gamma3":
        slack = _largest_sample(contact.jump[o] - contact.gap[o]) / U
    return ((np.abs(shear) - cap).max() / cap.max(),
            np.abs(shear + cap * np.sign(slip))[moves].max(initial=0.0) / cap.max(),
            np.abs(slip[held & (np.abs(shear) < cap * (1 - 1e-6))]).max(initial=0.0) / U, slack,
            (moves & held).sum() / held.sum())


SLIDES = [((cc.Tresca(0.01 * P), cc.Tresca(10 * P)), 0), ((cc.Tresca(10 * P), cc.Tresca(0.01 * P)), 1),
          ((cc.Coulomb(0.01), cc.Coulomb(5.0)), 0), ((cc.Coulomb(5.0), cc.Coulomb(0.01)), 1)]
"""The laws of :func:`friction_scenes.dragged_stack`'s pairs and the pair that slides on every row (g = 0.01 p,
mu = 0.01), the other holding (g = 10 p, mu = 5); the shear through both is 0.01 p L."""


@pytest.mark.numerics
@pytest.mark.parametrize("laws, slides", SLIDES, ids=["tresca-upper-slides", "tresca-lower-slides",
                                                      "coulomb-upper-slides", "coulomb-lower-slides"])
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
@pytest.mark.parametrize("cell", ["triangle", "quad"])
def test_a_dragged_stack_slides_on_one_pair_and_sticks_on_the_other(conditions, laws, slides, cell, once):
    """The dragged stack on non-matching lines (P2 triangles, Q2 quadrilaterals): the top block slides over the
    middle one and that one sticks to the clamped block, or both slide together over it, on the cones' pair or on
    the nodal pair. The middle block's
    equilibrium and the sliding pair's law fix the shear through each pair: 0.01 p L (Tresca: g L, every row at
    its capacity; Coulomb: mu p L), the normal force p L (measured at most 3.2e-13 off). On each pair's own rows
    (:func:`_law_on_rows`): |f_a| <= c_a (measured at most 6.5e-16 of the largest c over), f_a = -c_a sign(s_a)
    where it slips (6.5e-16), no slip where |f_a| < c_a (1.6e-16 of the displacements), the cones' slack
    sampled on every segment nowhere above 0 (2.1e-16 of the displacements); every row of the sliding pair
    slips, none of the holding pair's under Tresca (under Coulomb a row of it with a small normal force may slip
    at its capacity mu r_a: measured, one midpoint of X_h at 2 % of the largest r beside the rigid floor)."""
    sol = _dragged(once, laws, conditions, cell)
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    for i, (c, law, cond, line) in enumerate(zip(sol.contacts, laws, conditions, (0.0, -H))):
        assert abs(c.shear_force.sum() / (-0.01 * P * L) - 1) <= 1e-10
        assert abs(c.force.sum() / (P * L) - 1) <= 1e-10
        over, direction, stuck, slack, moving = _law_on_rows(sol, c, law, cond, line, first=i)
        assert over <= 1e-13 and direction <= 1e-13 and stuck <= 1e-13 and slack <= 1e-13
        assert moving == 1.0 if i == slides else (moving == 0.0 or isinstance(law, cc.Coulomb))


@pytest.mark.numerics
@pytest.mark.parametrize("laws", [SLIDES[0][0], (cc.Coulomb(0.3), cc.Tresca(0.05 * P)),
                                  (cc.Tresca(0.05 * P), cc.Coulomb(0.3))], ids=["tresca", "coulomb-tresca",
                                                                                "tresca-coulomb"])
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0], ("gamma3", "sigma2")],
                         ids=["cones-above", "cones-below", "cones-above-sigma2"])
def test_the_pairs_listed_the_other_way_round_report_their_own_rows(conditions, laws, once):
    """The dragged stack with its pairs listed the other way round (the lower pair first: the nodal pair first where
    the cones are above): the same answer, and each entry of ``sol.contacts`` is its own pair's (the lines y = 0
    and y = -H, the pairs' forces, slips and pressures the same to rounding; measured at most 1.1e-12 of their
    largest, the displacements 1.1e-14), the order of ``sol.contacts`` the order of the scene's pairs."""
    ab = _dragged(once, laws, conditions)
    with _strict():
        ba = cc.solve(dragged_stack(laws, conditions, order=(1, 0)), degree=2)
    assert ab.polished and ba.polished
    scale = max(np.abs(u).max() for u in ab.u)
    assert max(np.abs(u - v).max() for u, v in zip(ab.u, ba.u)) <= 1e-10 * scale
    assert [c.line for c in ab.contacts] == [0.0, -H] and [c.line for c in ba.contacts] == [-H, 0.0]
    for c, d in zip(ab.contacts, ba.contacts[::-1]):
        assert np.array_equal(c.x, d.x)
        force = np.abs(c.force).max()
        for a, b, size in [(c.force, d.force, force), (c.shear_force, d.shear_force, force),
                           (c.slip, d.slip, scale), (c.pressure, d.pressure, np.abs(c.pressure).max())]:
            assert np.abs(a - b).max() <= 1e-9 * size


@pytest.mark.numerics
@pytest.mark.parametrize("floor", ["sigma1", "gamma3"])
@pytest.mark.parametrize("laws, slides", SLIDES, ids=["tresca-upper-slides", "tresca-lower-slides",
                                                      "coulomb-upper-slides", "coulomb-lower-slides"])
def test_a_rigid_floor_as_the_second_pair_under_either_condition(laws, slides, floor):
    """The dragged stack's two upper blocks on a rigid floor (y = -H) instead of the clamped block: the cones between
    the blocks, the floor's pair under "sigma1" (a nodal pair against an obstacle: the middle block's P2 nodes)
    or "gamma3", listed after or before the blocks' pair. The shear through both pairs is 0.01 p L (measured
    at most 2.8e-13 off), and the law holds on each pair's rows (:func:`_law_on_rows`; measured at most 3.3e-16)."""
    scene = dragged_stack(laws, ("gamma3", floor))
    top, mid = scene.bodies[:2]
    below = cc.Rigid.plane(point=(0.0, -H), normal=(0.0, 1.0))
    pairs = [scene.contacts[0], cc.Contact(mid, "bottom", below, law=laws[1], condition=floor)]
    for order in ((0, 1), (1, 0)):
        with _strict():
            sol = cc.solve(cc.Scene(top, mid, contacts=[pairs[i] for i in order]), degree=2)
        assert sol.ok and sol.polished, sol.info.declined
        contacts = sol.contacts if order == (0, 1) else sol.contacts[::-1]
        for i, (c, law, cond, line) in enumerate(zip(contacts, laws, ("gamma3", floor), (0.0, -H))):
            assert abs(c.shear_force.sum() / (-0.01 * P * L) - 1) <= 1e-10
            over, direction, stuck, slack, moving = _law_on_rows(sol, c, law, cond, line, first=i)
            assert over <= 1e-13 and direction <= 1e-13 and stuck <= 1e-13 and slack <= 1e-13
            assert moving == 1.0 if i == slides else (moving == 0.0 or isinstance(law, cc.Coulomb))


@pytest.mark.numerics
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_a_piezoelectric_middle_block(conditions):
    """The dragged stack whose middle block is PZT-5A (grounded on its base): the top block slides over it (Tresca
    0.01 p) on the cones' or the nodal pair, the middle one held by the other (10 p): 0.01 p L through both pairs
    (measured at most 3.6e-14 off), the law on each pair's rows (measured at most 4.4e-16)."""
    laws = SLIDES[0][0]
    with _strict():
        sol = cc.solve(dragged_stack(laws, conditions, middle={"material": cc.materials.PZT5A,
                                                               "grounded": "bottom"}), degree=2)
    assert sol.ok and sol.polished, sol.info.declined
    for i, (c, law, cond, line) in enumerate(zip(sol.contacts, laws, conditions, (0.0, -H))):
        assert abs(c.shear_force.sum() / (-0.01 * P * L) - 1) <= 1e-10
        over, direction, stuck, slack, moving = _law_on_rows(sol, c, law, cond, line, first=i)
        assert over <= 1e-13 and direction <= 1e-13 and stuck <= 1e-13 and slack <= 1e-13
        assert moving == (1.0 if i == 0 else 0.0)


@pytest.mark.numerics
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_a_huge_threshold_gives_the_bonded_stack_without_overflow(conditions, once):
    """Tresca's g = 1e4 p on the rolled stack: the bonded union (as g = 100 p; measured 7.2e-15 of the largest
    displacement), and the finish's Newton steps divide no stuck row's capacity by its vanishing |z| (an overflow
    RuntimeWarning before)."""
    with _strict(), warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        sol = cc.solve(rolled_stack(cc.Tresca(1e4 * P), conditions), degree=2)
    union = once("union", _union)
    assert sol.ok and sol.polished and union.ok
    _assert_is_the_union(sol, union)


@pytest.mark.numerics
@pytest.mark.parametrize("slides", [0, 1], ids=["upper-slides", "lower-slides"])
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_3d_tresca_a_dragged_stack_slides_on_one_pair(conditions, slides):
    """The 3D dragged stack (tetrahedra, non-matching faces): Tresca 0.01 p on one pair, 10 p on the other. The
    middle box's equilibrium along x: the same shear force through both pairs (measured 3.3e-13 apart), at most
    g times the face's area; the normal force p through each (4.4e-15 off); where the cones' pair slides, every
    node of X_h at its capacity, so the sum of |f_a| is g times the area, 0.01 p (1.1e-16 off); every node of
    the sliding pair slips along +x."""
    g = (0.01 * P, 10 * P) if slides == 0 else (10 * P, 0.01 * P)
    with _strict():
        sol = cc.solve(dragged_stack3d(g, conditions), degree=2)
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    upper, lower = sol.contacts
    assert abs(upper.shear_force[:, 0].sum() / lower.shear_force[:, 0].sum() - 1) <= 1e-10
    assert abs(upper.shear_force[:, 0].sum() / (0.01 * P)) <= 1.0 + 1e-10
    for c in sol.contacts:
        assert abs(c.force.sum() / P - 1) <= 1e-10
    sliding = sol.contacts[slides]
    if conditions[slides] == "gamma3":
        assert abs(np.linalg.norm(sliding.shear_force, axis=1).sum() / (0.01 * P) - 1) <= 1e-10
    assert (sliding.slip[:, 0] > 0).all()


@pytest.mark.numerics
@pytest.mark.parametrize("quarter, scale", [(1, 1.0), (2, 1e-3), (3, 1e3)], ids=["turned", "mm", "km"])
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_a_turned_and_scaled_dragged_stack_has_the_turned_and_scaled_answer(conditions, quarter, scale, once):
    """The dragged stack (Coulomb 0.3 on the upper pair, Tresca 0.05 p on the lower) turned by quarter turns (its
    pairs' tangents and normals along other axes, their orientation reversed) and its lengths scaled by 1e-3 or
    1e3 (the weights of the rows in other units): the displacements are the reference's turned and scaled
    (stresses unchanged: u scales with the lengths; measured at most 3.2e-14 of the largest)."""
    laws = (cc.Coulomb(0.3), cc.Tresca(0.05 * P))
    ref = _dragged(once, laws, conditions)
    with _strict():
        sol = cc.solve(dragged_stack(laws, conditions, quarter=quarter, scale=scale), degree=2)
    assert ref.polished and sol.polished, sol.info.declined
    R = np.linalg.matrix_power(np.array([[0.0, -1.0], [1.0, 0.0]]), quarter)
    U = max(np.abs(u).max() for u in ref.u)
    assert max(np.abs(u - scale * v @ R.T).max() for u, v in zip(sol.u, ref.u)) <= 1e-11 * scale * U


@pytest.mark.numerics
@pytest.mark.parametrize("order", [(0, 1), (1, 0)], ids=["blocks-first", "floor-first"])
def test_3d_coulomb_sliding_on_a_nodal_pair_beside_cones_against_a_plane(order, once):
    """3D Coulomb on the dragged stack's two upper boxes on a rigid plane: the boxes' pair under "sigma1" slides
    (mu = 0.01), the plane's under "gamma3" holds (mu = 5), listed either way round. The middle box's
    equilibrium: the same shear force along x through both pairs (measured 1.5e-14 apart), at most mu p (0.99966
    mu p measured: its rows' forces along the slips, nearly x), the normal force p through each (3e-15 off),
    every node of the sliding pair slipping along +x; the same displacements in either order. With the boxes'
    pair under "gamma3" instead it is refused in either order (its cones' nodal forces are not unique)."""
    plane = cc.Rigid.plane(point=(0.0, 0.0, -1.0), normal=(0.0, 0.0, 1.0))
    answers = []
    for conditions in [("sigma1", "gamma3"), ("gamma3", "sigma1")]:
        top, mid = dragged_stack3d((1.0, 1.0), conditions).bodies[:2]
        pairs = [cc.Contact(top, "bottom", mid, "top", law=cc.Coulomb(0.01), condition=conditions[0]),
                 cc.Contact(mid, "bottom", plane, law=cc.Coulomb(5.0), condition=conditions[1])]
        scenes = [cc.Scene(top, mid, contacts=[pairs[i] for i in o]) for o in (order, order[::-1])]
        if conditions[0] == "gamma3":
            with pytest.raises(cc.UnsupportedError, match="between two bodies is not available"):
                cc.solve(scenes[0], degree=2)
            continue
        with _strict():               # either order compared with the other (one solve each in the module)
            sol, ref = [once(("plane3d", conditions, o), lambda s=s: cc.solve(s, degree=2))
                        for s, o in zip(scenes, (order, order[::-1]))]
        assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
        boxes, floor = sol.contacts if order == (0, 1) else sol.contacts[::-1]
        fx = boxes.shear_force[:, 0].sum()
        assert abs(fx / floor.shear_force[:, 0].sum() - 1) <= 1e-10
        assert abs(fx) <= 0.01 * P * (1 + 1e-10)
        assert all(abs(c.force.sum() / P - 1) <= 1e-10 for c in sol.contacts)
        assert (boxes.slip[:, 0] > 0).all()
        answers.append((sol, ref))
    sol, ref = answers[0]
    scale = max(np.abs(u).max() for u in ref.u)
    assert max(np.abs(u - v).max() for u, v in zip(sol.u, ref.u)) <= 1e-10 * scale     # measured 1.6e-15..3.0e-15
