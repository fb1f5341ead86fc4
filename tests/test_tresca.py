"""Tresca friction (cc.Tresca, 2D P1, the full program): closed forms, limits and refusals.

A block (1 m x 0.5 m, steel) pressed on a rigid plane by p = 10 MPa on its top:
- sheared by q below what the contact can stick: the same answer as the block tied tangentially (g above the
  tied contact's largest shear traction: the tied answer satisfies every Tresca condition, so it is the answer);
- sheared beyond the capacity g L: no equilibrium, refused naming the sliding motion;
- pushed sideways by a prescribed u_x = s on its left face (nu = 0): frictionless, it translates rigidly
  (u = (s, -p y / E), a closed form); with a small threshold g every contact node slides, the friction force is
  the capacity -g L exactly, and the departure from the rigid translation is linear in g.
"""

import numpy as np
import pytest
from friction_scenes import E, H, L, P, pair2d, pushed, steel
from friction_scenes import sheared as _sheared

import cvxcontact as cc


def sheared(q, g, **options):
    """:func:`friction_scenes.sheared` with Tresca's threshold ``g`` (Pa)."""
    return _sheared(q, None if g is None else cc.Tresca(g), **options)


def test_a_block_that_sticks_is_the_block_tied_tangentially():
    q = 0.2 * P
    tied = cc.solve(sheared(q, None, tied=True))
    sol = cc.solve(sheared(q, 1e7))      # the tied answer's largest |sigma_t|: 9.46e6 Pa (corner) < g
    assert tied.ok and sol.ok
    assert sol.path == cc.Route.INTERIOR_POINT_FINISHED and sol.info.finish == cc.Finish.FRICTION_NEWTON
    scale = np.abs(tied.u[0]).max()
    assert np.abs(sol.u[0] - tied.u[0]).max() < 1e-13 * scale               # measured 1.0e-15 (IPM alone 2.0e-13)
    c = sol.contact
    assert np.abs(c.slip).max() < 1e-10 * scale                               # stuck: measured 2.0e-13
    assert c.shear_force.sum() == pytest.approx(-q * L, rel=1e-12)           # the floor holds the load; 3.3e-15
    assert np.abs(c.shear).max() < 1e7


def test_partial_slip_stays_in_the_friction_cone_and_slides_against_the_slip():
    g = 1e6
    sol = cc.solve(sheared(0.9 * g, g))
    assert sol.ok
    c = sol.contact
    assert c.shear_force.sum() == pytest.approx(-0.9 * g * L, rel=1e-11)     # equilibrium: measured 2.4e-14
    assert (np.abs(c.shear) <= g * (1 + 1e-13)).all()                         # friction cone: 2.2e-16 over
    slipping = np.abs(c.slip) > 1e-3 * np.abs(c.slip).max()
    assert slipping.sum() >= 7                                                # measured: 8 of 9 nodes slip
    assert np.abs(np.abs(c.shear[slipping]) - g).max() < 1e-13 * g            # |sigma_t| = g there: 2.2e-16
    assert (c.shear[slipping] * c.slip[slipping] < 0).all()                   # anti-parallel


def test_a_tangential_load_beyond_the_capacity_is_refused_naming_the_motion():
    with pytest.raises(cc.SceneError, match=r"slides body 'body 1' along translation x.*1\.1e\+06 N/m.*capacity "
                                            r"1e\+06 N/m"):
        cc.solve(sheared(1.1e6, 1e6))


def test_zero_threshold_is_frictionless_and_the_rigid_translation():
    m, frictionless = pushed(None)
    _, zero = pushed(cc.Tresca(0.0))
    exact = np.column_stack([np.full(len(m.points), 1e-4), -P * m.points[:, 1] / E])
    sols = [cc.solve(frictionless), cc.solve(zero)]
    for sol in sols:
        assert sol.ok
        assert np.abs(sol.u[0] - exact).max() < 1e-9 * 1e-4                   # measured 1.1e-14, 3.4e-13 (x 1e-4)
    assert np.abs(sols[1].contact.shear_force).max() < 1e-6 * P * L           # measured 3.2e-8 * P L


def test_a_small_threshold_slides_with_the_full_capacity_and_departs_linearly_in_g():
    m, _ = pushed(None)
    exact = np.column_stack([np.full(len(m.points), 1e-4), -P * m.points[:, 1] / E])
    errors = []
    for g in (1e2, 1e3):
        sol = cc.solve(pushed(cc.Tresca(g))[1])
        assert sol.ok
        c = sol.contact
        assert (c.slip > 0.5e-4).all()                                        # every node slides forward
        assert c.shear_force.sum() == pytest.approx(-g * L, rel=1e-13)        # measured 1.4e-16, 0 (IPM 1.6e-8)
        errors.append(np.abs(sol.u[0] - exact).max())
    assert errors[1] / errors[0] == pytest.approx(10.0, rel=1e-3)            # measured 10.00000


def test_a_pair_on_a_much_stiffer_block_sticks_like_the_block_on_the_rigid_plane():
    q = 0.2 * P
    top = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4)
    below = cc.rectangle(x=(0.0, L), y=(-H, 0.0), nx=8, ny=4)
    a = cc.Body(top, steel(), contact="bottom", traction={"top": (q, -P)}, name="top")
    b = cc.Body(below, steel(scale=1e6), contact="top", clamped="bottom", name="below")
    sol = cc.solve(cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=cc.Tresca(1e7))]))
    rigid = cc.solve(sheared(q, 1e7))
    assert sol.ok
    assert sol.contact.shear_force.sum() == pytest.approx(-q * L, rel=1e-9)
    scale = np.abs(rigid.u[0]).max()
    assert np.abs(sol.u[0] - rigid.u[0]).max() < 1e-3 * scale               # measured 1.8e-6 (the stiffness ratio 1e-6)


def test_friction_is_refused_where_it_is_not_posed():
    with pytest.raises(cc.SceneError, match="threshold"):
        cc.Tresca(-1.0)
    with pytest.raises(cc.SceneError, match="threshold"):
        cc.Tresca(float("nan"))
    scene = sheared(0.2 * P, 1e7)
    with pytest.raises(cc.SolverError, match="condensed"):
        cc.solve(scene, method="condensed")


def test_a_scene_file_names_the_law():
    from cvxcontact.io.scenefile import SceneFileError, _law

    assert _law({"tresca": {"threshold": 2e6}}, "scene.toml") == cc.Tresca(2e6)
    with pytest.raises(SceneFileError, match=r"law.tresca: expected keys threshold \(required\)"):
        _law({"tresca": {"g": 2e6}}, "scene.toml")
    with pytest.raises(SceneFileError, match="law.tresca: Tresca: threshold"):
        _law({"tresca": {"threshold": -1.0}}, "scene.toml")


P2 = {"degree": 2, "condition": "sigma1"}
"""P2 (6-node triangles) with nodal rows at the P2 nodes ('sigma1'; against the rigid plane every P2 node), their
weights Simpson's (all positive: no vertex slips for free). The default tolerance: the exact finish leaves the
checks at rounding (largest: stick-slip 1.2e-10, complementarity 6.1e-14; the interior point alone had its
normal complementarity at 1e-7 ... 2.7e-6)."""


@pytest.mark.numerics
def test_p2_a_block_that_sticks_is_the_block_tied_tangentially():
    q = 0.2 * P
    tied = cc.solve(sheared(q, None, tied=True), estimate=False, **P2)
    big = cc.solve(sheared(q, 1e9), **P2)                 # far above any shear: stuck
    assert tied.ok and big.ok
    scale = np.abs(tied.u[0]).max()
    assert np.abs(big.u[0] - tied.u[0]).max() < 1e-10 * scale                       # measured 4.5e-15
    largest = np.abs(big.contact.shear).max()                                       # 1.46e7 Pa
    sol = cc.solve(sheared(q, 1.01 * largest), **P2)
    assert sol.ok
    assert np.abs(sol.u[0] - tied.u[0]).max() < 1e-8 * scale                        # measured 2.1e-11
    assert sol.contact.shear_force.sum() == pytest.approx(-q * L, rel=1e-12)        # measured 1.0e-14
    below = cc.solve(sheared(q, 0.5 * largest), **P2)
    assert below.ok and np.abs(below.contact.slip).max() > 1e-3 * scale             # measured 3.3e-2


@pytest.mark.numerics
def test_p2_a_small_threshold_slides_with_the_full_capacity_and_departs_linearly():
    errors = []
    for g in (1e2, 1e3):
        sol = cc.solve(pushed(cc.Tresca(g))[1], **P2)
        assert sol.ok
        points = sol.points[0]
        exact = np.column_stack([np.full(len(points), 1e-4), -P * points[:, 1] / E])
        c = sol.contact
        assert (c.slip > 0.5e-4).all()                                                # every P2 node slides
        assert c.shear_force.sum() == pytest.approx(-g * L, rel=5e-6)                 # Simpson: 5.4e-8, 9.0e-10
        assert np.abs(np.abs(c.shear) - g).max() < 1e-4 * g                           # measured 5.0e-7, 2.9e-9
        errors.append(np.abs(sol.u[0] - exact).max())
    assert errors[1] / errors[0] == pytest.approx(10.0, rel=1e-3)                    # measured 10.000004
    sol = cc.solve(pushed(cc.Coulomb(1e-5))[1], **P2)
    assert sol.ok and sol.contact.shear_force.sum() == pytest.approx(-1e-5 * P * L, rel=5e-6)   # measured 5.4e-8


@pytest.mark.numerics
def test_p2_a_pair_tends_to_the_rigid_plane_linearly_in_the_partners_compliance():
    q = 0.2 * P
    rigid = cc.solve(sheared(q, 1e7), **P2)
    departures = []
    for stiffer in (1e3, 1e4):
        a = cc.Body(cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4), steel(), contact="bottom",
                    traction={"top": (q, -P)}, name="top")
        b = cc.Body(cc.rectangle(x=(0.0, L), y=(-H, 0.0), nx=8, ny=4), steel(scale=stiffer), contact="top",
                    clamped="bottom", name="below")
        sol = cc.solve(cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=cc.Tresca(1e7))]), **P2)
        assert sol.ok
        assert sol.contact.shear_force.sum() == pytest.approx(-q * L, rel=1e-12)    # measured 2.6e-15
        departures.append(np.abs(sol.u[0] - rigid.u[0]).max() / np.abs(rigid.u[0]).max())
    assert departures[0] / departures[1] == pytest.approx(10.0, rel=1e-2)           # 1.96e-3 / 1.96e-4


@pytest.mark.numerics
def test_p2_friction_under_the_conic_condition_beside_a_nodal_pair_is_each_pairs_answer_alone():
    """P2 friction under 'gamma3' beside a two-body pair under 'sigma1' (once refused, docs/refusals.md row 32; its
    rows fewer than its nodes of X_h: the cones sit on E's rows, tests/test_friction_p2_gamma3_mixed.py): a sheared
    block on a wider one (Tresca, non-matching lines) and a third block on the floor under the cones, apart: each
    pair's answer is the one it has alone (measured at most 5.7e-15 of the displacements), finished."""
    a = cc.Body(cc.rectangle(x=(0.0, L), y=(0.0, H), nx=4, ny=2), steel(), contact="bottom",
                traction={"top": (0.02 * P, -P)}, name="top")
    b = cc.Body(cc.rectangle(x=(-0.2, 1.2), y=(-H, 0.0), nx=5, ny=2), steel(), contact="top", clamped="bottom",
                name="below")
    c = cc.Body(cc.rectangle(x=(2.0, 3.0), y=(0.0, H), nx=2, ny=1), steel(), contact="bottom",
                traction={"top": (0.0, -P)}, displacement={"left": (0.0, None)}, name="aside")
    floor = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    pairs = [cc.Contact(a, "bottom", b, "top", law=cc.Tresca(1e7), condition="sigma1"),
             cc.Contact(c, "bottom", floor, condition="gamma3")]
    sol = cc.solve(cc.Scene(a, b, c, contacts=pairs), degree=2)
    alone = [cc.solve(cc.Scene(a, b, contacts=pairs[:1]), degree=2),
             cc.solve(cc.Scene(c, contacts=pairs[1:]), degree=2)]
    assert sol.ok and sol.polished and all(s.polished for s in alone), sol.info.declined
    for u, ref in zip(sol.u, [alone[0].u[0], alone[0].u[1], alone[1].u[0]]):
        assert np.abs(u - ref).max() <= 1e-10 * np.abs(ref).max()


@pytest.mark.numerics
def test_a_p2_pair_under_sigma1_in_partial_slip_is_finished():
    """A 2D P2 pair under "sigma1" (non-matching lines), sheared to partial slip: the friction finish settles (its
    damped steps; the full step to each new set, as 3D takes it, made the steps cycle: declined, the interior
    point's answer kept). Its tangential forces balance the top's shear q L (the upper block has no other support
    along x) to rounding, and the law's checks hold at rounding."""
    q = 0.02 * P
    sol = cc.solve(pair2d(cc.Tresca(0.03 * P), q), degree=2)
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    assert abs(sol.contact.shear_force.sum() + q * L) < 1e-10 * q * L                   # measured 3.8e-14
    r = sol.residuals()
    assert r["friction cone"] < 1e-12 and r["slip direction"] < 1e-12                    # measured 2.3e-16, 0


def _overhang(q, g):
    """A block (1 m x 0.5 m, 4 x 2 cells) under (q, -p) on its top, held by the contact only, over a clamped block on
    [0.1, 1] (3 x 2 cells), Tresca's g between them under "sigma1": the upper trace's first P2 node in the overlap
    is the midpoint 0.125, its rows begin inside a segment."""
    mat = cc.materials.isotropic(E=E, nu=0.0)
    upper = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2), mat, contact="bottom", traction={"top": (q, -P)})
    lower = cc.Body(cc.rectangle(x=(0.1, 1.0), y=(-0.5, 0), nx=3, ny=2), mat, clamped=["bottom"], contact="top")
    return cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", law=cc.Tresca(g),
                                                       condition="sigma1")])


@pytest.mark.numerics
def test_p2_friction_on_rows_beginning_inside_a_segment_has_the_overlaps_capacity():
    """Under "sigma1" the upper block's first P2 node in the overlap [0.1, 1] is a midpoint (docs/refusals.md row 4):
    the rows' weights are Simpson's on the segments inside and the red refinement's hats over the overlap on the
    segment it cuts, positive and summing to the overlap's length 0.9 m, so the capacity is g times it: a net shear
    2 % above it is refused naming 0.9 g, 2 % below it the block holds, the shear forces balancing q L (measured
    4.5e-14) with the friction conditions at rounding."""
    g = 1e6
    with pytest.raises(cc.SceneError, match=r"918000 N/m, exceeds the friction capacity 900000 N/m"):
        cc.solve(_overhang(1.02 * 0.9 * g, g), degree=2)
    q = 0.98 * 0.9 * g
    sol = cc.solve(_overhang(q, g), degree=2)
    assert sol.ok and sol.polished
    assert abs(sol.contact.shear_force.sum() + q * L) < 1e-11 * q * L
    r = sol.residuals()
    assert r["friction cone"] < 1e-12 and r["slip direction"] < 1e-12 and r["equilibrium"] < 1e-11
