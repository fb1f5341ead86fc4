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
displacements, the P2 trace sampled on every segment).
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
    pair2d,
    rolled_stack,
    rolled_union,
    steel,
    uniform_pair3d,
    uniform_stack,
    uniform_stack3d,
)

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
    """Simpson's weights of the P2 line through the sorted nodes ``x`` (h/6, 2h/3, h/6 per segment)."""
    w = np.zeros(len(x))
    for s in range((len(x) - 1) // 2):
        h = x[2 * s + 2, 0] - x[2 * s, 0]
        w[2 * s: 2 * s + 3] += (h / 6, 2 * h / 3, h / 6)
    return w


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


@pytest.mark.numerics
@pytest.mark.parametrize("conditions", [MIXED[0][0], MIXED[1][0]], ids=["cones-above", "cones-below"])
def test_a_threshold_that_holds_every_row_gives_the_bonded_stack(conditions):
    """The rolled stack on matching lines with g = 100 p: every row stuck and closed, so the three blocks are the one
    body they make (:func:`friction_scenes.rolled_union`, solved without any contact between its parts): the same
    nodal displacements at every node (measured 7.4e-15 and 9.3e-15 of the largest)."""
    with _strict():
        sol = cc.solve(rolled_stack(cc.Tresca(100 * P), conditions), degree=2)
        union = cc.solve(rolled_union(), degree=2)
    assert sol.ok and sol.polished and union.ok
    at = {tuple(np.round(p, 9)): i for i, p in enumerate(union.points[0])}
    U = union.u[0]
    for x, u in zip(sol.points, sol.u):
        mine = U[[at[tuple(np.round(p, 9))] for p in x]]
        assert np.abs(u - mine).max() <= 1e-10 * np.abs(U).max()


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
@pytest.mark.parametrize("n", [2, 3])
def test_3d_coulomb_on_a_nodal_pair_beside_cones_against_a_plane_has_the_answers_alone(n):
    """Coulomb between two 3D bodies is refused under the cones only where their pair is under "gamma3" (its nodal
    forces not unique on non-matching faces); a two-body pair under "sigma1" (the stuck layers of
    :func:`friction_scenes.uniform_pair3d`, n x n x 1 cells each; its rows' forces its own, each the sum of its
    degenerate element's duals) beside a box on a plane under "gamma3", Coulomb on both, apart: each has the answer
    it has alone (measured at most 6.1e-13 of the displacements, the box's: the fixed points' tolerance 1e-12),
    finished."""
    scene = uniform_pair3d(0.2 * P, cc.Coulomb(0.5), n=n)
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
