"""Tresca and Coulomb friction in 3D (P1 tetrahedra, one second-order cone ||[u_t]_a||_2 per contact row).

A steel box (1 m cube, 3 x 3 x 2 cells) pressed on a rigid plane z = 0 by p = 10 MPa on its top:
- sheared along a diagonal direction below what it can stick: the answer is the box tied tangentially;
- pushed along a diagonal direction by a prescribed (s cos t, s sin t) on its left face (nu = 0): frictionless it
  translates rigidly, u = (s cos t, s sin t, -p z / E) (a closed form); with a small threshold g (or mu) every
  node slides along t and the friction force is -g A (cos t, sin t) (-mu p A (cos t, sin t)): an isotropic cone
  (a polygonal or componentwise one would push back along (1, 1));
- in partial slip the answer does not depend on the orientation of the frame: the scene rotated about the normal
  gives the rotated answer;
- a load beyond the capacity along the diagonal (each component below it, the norm above) is refused naming the
  diagonal translation;
- a pair on a much stiffer box matches the rigid plane;
- a box whose left side is held along x (the support fixes one tangential direction at the nodes where it meets
  the contact): stuck, the box tied tangentially; pushed along y (nu = 0), every node slides and its friction
  force is g w_a along the slip, the held nodes' x component 0; in partial slip the interior point's answer;
- a pair whose faces do not match (3 x 3 cells on 4 x 4), nodal rows ("sigma1") and overlay rows ("gamma3",
  linearly dependent): the same answer posed from either side (sigma1 and sigma2 swapped; "gamma3" stuck), the
  interior point's answer, a pushed box sliding with its whole capacity g A, Coulomb finished to its own law;
- a layer (its top moved by (s cos t, s sin t, -d)) in partial slip against an independent reference written
  here: the same nodal Tresca law as its dual, min 1/2 R^T W R + q^T R over R_n >= 0, |R_t| <= g w_a (W the
  condensed contact compliance, w_a the nodes' lumped areas computed here from the faces), solved by an
  accelerated projected gradient (FISTA with restart).
"""

import numpy as np
import pytest
from friction_box_scenes import (
    BOX,
    DIAGONAL,
    FLOOR,
    E,
    P,
    apart,
    held_side,
    non_matching,
    pair,
    pushed,
    sheared,
    steel,
)
from friction_scenes import tresca_reference

import cvxcontact as cc


@pytest.mark.numerics
def test_a_box_that_sticks_is_the_box_tied_tangentially():
    q = 0.2 * P * DIAGONAL
    tied = cc.solve(sheared(q, None, tied=True), estimate=False)
    big = cc.solve(sheared(q, cc.Tresca(1e9)))            # far above any shear: stuck, the tied answer
    assert tied.ok and big.ok
    scale = np.abs(tied.u[0]).max()
    assert np.abs(big.u[0] - tied.u[0]).max() < 1e-9 * scale                       # measured 7.2e-13
    largest = np.linalg.norm(big.contact.shear, axis=1).max()                       # the tied |sigma_t|: 2.43e7 Pa
    sol = cc.solve(sheared(q, cc.Tresca(1.01 * largest)))
    assert sol.ok and sol.contact.slip.shape == (16, 2)
    assert np.abs(sol.u[0] - tied.u[0]).max() < 1e-9 * scale                       # measured 1.0e-12
    assert np.allclose(sol.contact.shear_force.sum(axis=0), -q, rtol=1e-12)        # measured 4.1e-15
    below = cc.solve(sheared(q, cc.Tresca(0.8 * largest)))
    assert below.ok and np.linalg.norm(below.contact.slip, axis=1).max() > 1e-3 * scale   # measured 2.7e-2


@pytest.mark.numerics
def test_pushed_along_a_diagonal_it_translates_and_slides_against_the_push():
    exact = np.column_stack([np.full(len(BOX.points), 1e-4 * DIAGONAL[0]),
                             np.full(len(BOX.points), 1e-4 * DIAGONAL[1]), -P * BOX.points[:, 2] / E])
    zero = cc.solve(pushed(cc.Tresca(0.0)))
    assert zero.ok and np.abs(zero.u[0] - exact).max() < 1e-9 * 1e-4                 # measured 7.0e-13 (x 1e-4)
    errors = []
    for g in (1e2, 1e3):
        sol = cc.solve(pushed(cc.Tresca(g)))
        assert sol.ok
        c = sol.contact
        slip = np.linalg.norm(c.slip, axis=1)
        assert (slip > 0.5e-4).all()                                                  # every node slides
        assert np.abs(c.slip / slip[:, None] - DIAGONAL).max() < 1e-2                 # along t: 4.1e-6, 4.1e-5
        force = c.shear_force.sum(axis=0)
        assert np.abs(force / g + DIAGONAL).max() < 1e-2                              # measured 1e-6, 1e-5 (x A=1)
        errors.append(np.abs(sol.u[0] - exact).max())
    assert errors[1] / errors[0] == pytest.approx(10.0, rel=0.1)                     # linear in g: 9.99
    for mu in (1e-5, 1e-4):
        sol = cc.solve(pushed(cc.Coulomb(mu)))
        assert sol.ok
        assert np.abs(sol.contact.shear_force.sum(axis=0) / (mu * P) + DIAGONAL).max() < 2e-3   # 1.5e-6, 1.4e-5


@pytest.mark.numerics
def test_the_answer_turns_with_the_scene_about_the_normal():
    q = 0.2 * P * DIAGONAL
    g = 0.3 * P                                            # partial slip: 15 of 16 nodes slip
    sol = cc.solve(sheared(q, cc.Tresca(g)))
    phi = 0.3
    R = np.array([[np.cos(phi), -np.sin(phi), 0.0], [np.sin(phi), np.cos(phi), 0.0], [0.0, 0.0, 1.0]])
    turned = cc.solve(sheared(R[:2, :2] @ q, cc.Tresca(g), mesh=BOX.with_points(BOX.points @ R.T)))
    assert sol.ok and turned.ok
    slip = np.linalg.norm(sol.contact.slip, axis=1)
    assert (slip > 1e-3 * slip.max()).sum() >= 12
    assert np.abs(turned.u[0] - sol.u[0] @ R.T).max() < 1e-6 * np.abs(sol.u[0]).max()   # measured 4.3e-9
    for c in (sol.contact, turned.contact):                # the shear is 2-vectors in the cone |sigma_t| <= g
        assert (np.linalg.norm(c.shear, axis=1) <= g * (1 + 1e-9)).all()


def test_a_diagonal_load_beyond_the_capacity_is_refused_naming_the_diagonal():
    g = 0.25 * P                                           # each component 0.8 g: the norm 1.13 g > g
    with pytest.raises(cc.SceneError, match=r"translation along \(0\.7071, 0\.7071, 0\).*4e\+06 N.*capacity "
                                            r"3\.53553e\+06 N \(threshold times contact area\)"):
        cc.solve(sheared((0.8 * g, 0.8 * g), cc.Tresca(g)))
    assert cc.solve(sheared((0.75 * g, 0.0), cc.Tresca(g))).ok          # within the capacity: solved
    with pytest.raises(cc.SceneError, match=r"translation along \(0\.7071, 0\.7071, 0\).*friction coefficient"):
        cc.solve(sheared((0.3 * P, 0.3 * P), cc.Coulomb(0.4)))       # |q| = 0.42 P > 0.4 P


@pytest.mark.numerics
def test_a_pair_on_a_much_stiffer_box_tends_to_the_rigid_plane():
    """The pair's departure from the rigid plane is the partner's compliance: linear in it (stiffer by 1e3 and
    1e4), for Tresca and Coulomb. Exact finishes, judged at the default tolerance: the interior point's own
    stick-slip was 6.7e-7 ... 1.1e-5 for the Coulomb answers; after the finish the largest checks of these six
    solves are stick-slip 2.2e-9 (the square root of a product at rounding), slip direction 1.4e-9, equilibrium
    2.0e-15 (Haswell and Prescott kernels): 450x below the default tolerance."""
    q = 0.2 * P * DIAGONAL
    departures = {}
    for law in (cc.Tresca(0.3 * P), cc.Coulomb(0.4)):
        rigid = cc.solve(sheared(q, law))
        assert rigid.ok and rigid.info.finish == cc.Finish.FRICTION_NEWTON
        for stiffer in (1e3, 1e4):
            sol = cc.solve(pair(law, stiffer, q))
            assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON
            assert np.allclose(sol.contact.shear_force.sum(axis=0), -q, rtol=1e-12)  # measured 5.3e-16 ... 5.0e-15
            departures[stiffer] = np.abs(sol.u[0] - rigid.u[0]).max() / np.abs(rigid.u[0]).max()
        # measured 2.2e-3 / 2.2e-4 (Tresca), 2.4e-3 / 2.4e-4 (Coulomb); ratios 9.99992, 9.99984
        assert departures[1e3] / departures[1e4] == pytest.approx(10.0, rel=1e-2)


@pytest.mark.numerics
def test_a_side_held_along_one_tangent_is_finished_stuck_sliding_and_in_partial_slip():
    """The rows where the held side meets the contact have one slip component no unknown moves; before the finish
    took them the stuck ones made its system singular (declined: the interior point's answer was kept)."""
    tied = cc.solve(held_side(None, tied=True), estimate=False)
    big = cc.solve(held_side(cc.Tresca(1e9)))                # stuck everywhere: the tied answer
    assert tied.ok and big.ok and big.info.finish == cc.Finish.FRICTION_NEWTON and big.info.declined is None
    scale = np.abs(tied.u[0]).max()
    assert np.abs(big.u[0] - tied.u[0]).max() < 1e-9 * scale                       # measured 9.2e-16
    edge = np.abs(big.contact.points[:, 0]) < 1e-12                                  # where the held side meets it
    assert edge.sum() == 4 and (big.contact.shear_force[edge, 0] == 0).all()        # acting on nothing: 0
    for g in (1e2, 1e3):                                     # pushed along y: every node slides
        sol = cc.solve(held_side(cc.Tresca(g), q=0.0, nu=0.0, push=1e-4))
        assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON
        c = sol.contact
        slip = np.linalg.norm(c.slip, axis=1)
        assert slip.min() > 0.5 * slip.max()                                         # measured 0.99999
        assert np.linalg.norm(c.shear_force, axis=1).sum() == pytest.approx(g * 1.0, rel=1e-12)   # measured 0
        assert (c.shear_force[edge, 0] == 0).all() and (c.shear_force[:, 1] < 0).all()
    largest = np.linalg.norm(big.contact.shear, axis=1).max()
    scene = held_side(cc.Tresca(0.8 * largest))
    sol, ipm = cc.solve(scene), cc.solve(scene, polish=False)
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON
    slip = np.linalg.norm(sol.contact.slip, axis=1)
    assert 1 <= (slip > 1e-3 * slip.max()).sum() <= len(slip) - 2                   # partial slip: 2 of 16
    assert np.abs(ipm.u[0] - sol.u[0]).max() < 1e-6 * np.abs(sol.u[0]).max()        # measured 5.4e-9
    shear = np.abs(sol.contact.shear_force).max()
    assert np.abs(ipm.contact.shear_force - sol.contact.shear_force).max() < 5e-6 * shear   # measured 3.4e-8
    assert max(sol.residuals()[k] for k in ("stick-slip", "slip direction")) < 1e-7     # measured 1.5e-9


@pytest.mark.numerics
def test_a_pair_whose_faces_do_not_match_is_finished_exactly():
    """Nodal rows are independent; the overlay rows ("gamma3", one per overlay vertex: 75 rows on 2 x 25 jump
    nodes) are not, and their forces not unique: the finish keeps an independent subset per step (before it,
    its step was singular and the interior point's answer was kept). Posed from the other side, "sigma1" is
    "sigma2" and "gamma3" the same overlay in another order (another subset): the same answer at rounding, in
    partial slip too (the "gamma3" capacities g w_a are the overlay's lumped areas, shares of its cells; when they
    were the row sums of a fan's mass matrix, which depends on the vertex the clipping lists first, the two sides
    were 2.7e-4 apart)."""
    tresca = cc.Tresca(0.25 * P)
    for condition, other in (("sigma1", "sigma2"), ("gamma3", "gamma3")):
        sol = cc.solve(non_matching(tresca), condition=condition)
        assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON and sol.info.declined is None
        slip = np.linalg.norm(sol.contact.slip, axis=1)
        assert 1 <= (slip < 1e-3 * slip.max()).sum() <= len(slip) - 2               # partial slip: 8, 5 of 75
        assert np.allclose(sol.contact.shear_force.sum(axis=0), -0.2 * P * DIAGONAL, rtol=1e-12)   # 1.9e-14
        # the interior point's answer: measured 7.4e-10 (sigma1), 3.0e-10 (gamma3)
        assert apart(sol, cc.solve(non_matching(tresca), condition=condition, polish=False)) < 1e-6
        for stuck in (tresca, cc.Tresca(1e9)):
            here = sol if stuck is tresca else cc.solve(non_matching(stuck), condition=condition)
            there = cc.solve(non_matching(stuck, swap=True), condition=other)
            assert here.info.finish == there.info.finish == cc.Finish.FRICTION_NEWTON
            # measured 6.3e-15 (sigma1), 6.7e-15 (gamma3, partial slip), 9.2e-15 (gamma3, stuck)
            assert apart(here, there) < 1e-12
    for g in (1e2, 1e3):                                     # pushed: every overlay vertex slides, force g w_a
        sol = cc.solve(non_matching(cc.Tresca(g), q=(0.0, 0.0), nu=0.0, push=1e-4), condition="gamma3")
        assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON
        slip = np.linalg.norm(sol.contact.slip, axis=1)
        assert slip.min() > 0.5 * slip.max()                                         # measured 0.99987
        assert np.linalg.norm(sol.contact.shear_force, axis=1).sum() == pytest.approx(g * 1.0, rel=1e-12)  # 1.1e-16
        there = cc.solve(non_matching(cc.Tresca(g), q=(0.0, 0.0), nu=0.0, push=1e-4, swap=True), condition="gamma3")
        assert apart(sol, there) < 1e-12                                            # measured 1.4e-15 (g = 1e3)
    with pytest.warns(cc.FixedPointWarning):            # the forces on dependent rows wander: no fixed point
        ipm = cc.solve(non_matching(cc.Coulomb(0.3)), condition="gamma3", polish=False, tol=1.0)
    sol = cc.solve(non_matching(cc.Coulomb(0.3)), condition="gamma3")
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON
    assert ipm.residuals()["stick-slip"] > 1e-7            # the fixed point's iterate off its law: 3.9e-5, 7.2e-5
    # after the finish: measured at most 4.0e-9 (stick-slip; Haswell, Prescott), the default tolerance 1e-6
    assert max(sol.residuals()[k] for k in ("friction cone", "stick-slip", "slip direction")) < 1e-6
    assert apart(sol, ipm) < 1e-6                                                   # measured 3.8e-9
    # posed from the other side: its own law's answer too; not at rounding (the finish stops at its law's
    # residual, 4e-9, and the forces of the dependent rows, hence the capacities mu y_a, are not unique)
    there = cc.solve(non_matching(cc.Coulomb(0.3), swap=True), condition="gamma3")
    assert there.ok and there.info.finish == cc.Finish.FRICTION_NEWTON
    assert apart(sol, there) < 1e-6                                                 # measured 2.6e-9


@pytest.mark.numerics
def test_the_overlay_rows_weights_do_not_depend_on_the_side_the_pair_is_posed_from():
    """The "gamma3" weights w_a (the Tresca capacities g w_a) of the non-matching pair: positive, summing to the
    overlap's area (1 m^2, the lower box's top covering the upper's bottom), the same at each overlay vertex
    from either side (matched by position)."""
    from scipy.spatial import cKDTree
    one, other = (non_matching(cc.Tresca(1.0), swap=swap).interfaces[0] for swap in (False, True))
    w, v = one.weights("gamma3"), other.weights("gamma3")
    assert (w > 0).all() and len(w) == len(v) == 75
    assert abs(w.sum() - 1.0) <= 1e-14 and abs(w.sum() - one.area) <= 1e-14            # measured 0, 0
    dist, at = cKDTree(other.points).query(one.points)
    assert dist.max() <= 1e-12 and len(np.unique(at)) == len(w)
    assert np.abs(v[at] - w).max() <= 1e-12 * w.max()                                  # measured 1.9e-16 relative


@pytest.mark.numerics
def test_a_sheared_layer_in_partial_slip_matches_a_projected_gradient_reference():
    from cvxcontact.fem.space import P1Tet

    s, d, g = 4e-6, 1e-5, 0.25 * P
    body = cc.Body(BOX, steel(), contact="bottom", displacement={"top": (s * DIAGONAL[0], s * DIAGONAL[1], -d)})
    sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR, law=cc.Tresca(g))]))
    assert sol.ok
    system = P1Tet().assemble_loads(body, P1Tet().assemble_matrices(body))     # SI, the prescribed top lifted
    Tu, u_fixed = system.Tu, system.u_fixed
    Kzz = (Tu.T @ system.Kuu @ Tu).toarray()
    fz = Tu.T @ system.f
    points, faces = BOX.points, np.asarray(BOX.boundary("bottom"))
    bottom = np.unique(faces)
    areas = 0.5 * np.linalg.norm(np.cross(points[faces[:, 1]] - points[faces[:, 0]],
                                          points[faces[:, 2]] - points[faces[:, 0]]), axis=1)
    lumped = np.zeros(len(points))
    np.add.at(lumped, faces.ravel(), np.repeat(areas / 3, 3))
    ref, R = tresca_reference(Tu, Kzz, fz, u_fixed, bottom, g * lumped[bottom])
    slip = np.linalg.norm(ref[bottom, :2], axis=1)
    assert 2 <= (slip > 1e-3 * slip.max()).sum() <= len(bottom) - 2             # partial slip: 4 of 16 nodes
    assert np.abs(sol.u[0] - ref).max() < 1e-5 * np.abs(ref).max()             # measured 5.9e-8
    c = sol.contact
    at = [int(np.argmin(np.linalg.norm(c.points - points[b], axis=1))) for b in bottom]
    assert np.abs(c.shear_force[at] - R[:, :2]).max() < 2e-5 * np.abs(R).max()  # measured 1.5e-7
    assert np.abs(c.force[at] - R[:, 2]).max() < 2e-5 * np.abs(R).max()        # measured 1.6e-7


def test_a_curved_part_with_friction_is_posed_with_p1_only():
    """A curved 3D part against a planar one takes a friction law with P1 tetrahedra (its slip rows:
    CurvedSurfaceInterface.tangential_jump, tests/test_friction_curved3d.py); P2 tetrahedra with a curved part are
    refused as without friction, naming degree=1."""
    from cvxcontact.apps.studies import hertz3d_elastic

    base = hertz3d_elastic.scene(2, delta=1e-3)
    pair = base.contacts[0]
    rubbing = cc.Contact(pair.body_a, pair.part_a, pair.other, pair.part_b, law=cc.Tresca(1e6),
                         condition=base.conditions[0])
    scene = cc.Scene(*base.bodies, contacts=[rubbing])
    sol = cc.solve(scene, condition="sigma2")
    assert sol.ok and {"friction cone", "stick-slip", "slip direction"} <= set(sol.residuals())
    with pytest.raises(cc.UnsupportedError, match="use degree=1"):
        cc.solve(scene, condition="sigma2", degree=2)
