"""Friction (cc.Tresca, cc.Coulomb) with P2 elements under "gamma3" (2D; 3D tetrahedra at the end): the cones of every
element for the normal condition, a friction row at every node of X_h (its capacity g times the Simpson weight of the
merged P2 line, in 3D the red refinement's lumped area;
Coulomb's mu r_a from the cones' nodal force r = B^T beta), finished exactly where the contact closes at nodes
(docs/howto/friction.md, "P2 under 'gamma3'"; docs/refusals.md row 32), and where it ends inside an element by
normal rows added at the slack's maxima (cut points, Tresca).

Closed forms on the block of tests/friction_scenes.py (1 m x 0.5 m on a rigid floor): the uniformly sheared layer
sticks with u = (tau y / G, -p y / E) (nu = 0, G = E / 2), exact in P2; the block pushed by u_x = s on its left face
slides with the friction force g L (Tresca) or mu p L (Coulomb). Where every node of the face touches, the cones and
the nodal rows at the nodes of X_h are one condition: the same answer as "sigma1" against the rigid floor (every P2
node). A contact that ends inside an element (a block on a disk) departs from the frictionless cones linearly in g.
"""

import warnings

import numpy as np
import pytest
from friction_scenes import (
    DIAGONAL3,
    E,
    L,
    P,
    _side_shear,
    layer_key,
    pair2d_key,
    pushed,
    sheared,
    steel,
    uniform_layer,
    uniform_layer3d,
)

import cvxcontact as cc
from cvxcontact.backends.friction import UNFINISHED_CONES

P2 = {"condition": "gamma3", "degree": 2}


@pytest.mark.numerics
def test_a_uniform_layer_sticks_with_the_closed_form_and_its_shear_read_back():
    """Stuck (g = 10 tau): u = (2 tau y / E, -p y / E) exactly in P2, the shear traction tau at every node of X_h,
    the floor holding the shear tau L; finished on the nodes (the checks at rounding)."""
    tau = 0.2 * P
    sol = cc.solve(uniform_layer(tau, cc.Tresca(10 * tau)), **P2)
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    y = sol.points[0][:, 1]
    exact = np.column_stack([2 * tau * y / E, -P * y / E])
    assert np.abs(sol.u[0] - exact).max() <= 1e-10 * np.abs(exact).max()          # measured 4.5e-15
    c = sol.contact
    assert np.abs(np.abs(c.shear) / tau - 1).max() <= 1e-10                       # the read-back's sigma_t = tau
    assert abs(c.shear_force.sum() / (-tau * L) - 1) <= 1e-10                     # measured 1.0e-14
    assert np.abs(c.slip).max() <= 1e-10 * np.abs(exact).max()                    # stuck
    r = sol.residuals()
    assert max(r["complementarity"], r["stick-slip"], r["friction cone"]) <= 1e-10   # measured 4.3e-15, 0, 0
    assert r["cone"] == 0.0 and r["feasibility"] <= 1e-12                          # the duals are point evaluations


@pytest.mark.numerics
@pytest.mark.parametrize("law, force", [(cc.Tresca(1e2), 1e2 * L), (cc.Tresca(1e3), 1e3 * L),
                                        (cc.Coulomb(1e-5), 1e-5 * P * L)])
def test_a_block_pushed_against_a_held_side_slides_with_the_whole_capacity(law, force):
    """u_x = s = 1e-4 m on the left face: every node of X_h slides along x and the floor's friction force is the
    capacity, g L (Tresca) or mu p L (Coulomb: its fixed point converges, in 4 iterations measured)."""
    _, scene = pushed(law)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                       # no ResidualWarning, no FixedPointWarning
        sol = cc.solve(scene, **P2)
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    c = sol.contact
    assert (c.slip > 0.5e-4).all()                                                  # measured >= 9.99e-5 m
    assert abs(c.shear_force.sum() / (-force) - 1) <= 1e-10                         # measured 1.6e-14 (Coulomb)
    threshold = np.broadcast_to(c.threshold, c.shear.shape)
    assert np.abs(np.abs(c.shear) - threshold).max() <= 1e-10 * threshold.max()    # sliding: |sigma_t| = g
    if law.friction.pressure_dependent:
        changes = sol.info.fixed_point
        assert 1 <= len(changes) <= 10 and changes[-1] <= 1e-8                      # measured 4: 0.65 ... 9.4e-15


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Tresca(1e9), cc.Tresca(3e6), cc.Coulomb(0.5), cc.Coulomb(0.25)],
                         ids=["stuck", "partial", "coulomb-stuck", "coulomb-slides"])
def test_where_every_node_touches_the_cones_are_the_nodal_rows_of_sigma1(law):
    """The block sheared by q = 0.2 p on its top (partial slip at g = 3e6 Pa and mu = 0.25): every P2 node touches
    the floor, where the cones and the nodal rows at the nodes of X_h (sigma1 against the rigid floor: every P2
    node, the same Simpson weights) pose one condition: the same answer to rounding, both finished exactly."""
    scene = sheared(0.2 * P, law)
    cones, nodal = cc.solve(scene, **P2), cc.solve(scene, "sigma1", degree=2)
    assert cones.ok and nodal.ok
    assert cones.info.finish == nodal.info.finish == cc.Finish.FRICTION_NEWTON, cones.info.declined
    scale = np.abs(nodal.u[0]).max()
    assert np.abs(cones.u[0] - nodal.u[0]).max() <= 1e-10 * scale                  # measured 5.6e-15 (stuck)
    a, b = cones.contact, nodal.contact
    assert np.abs(a.shear_force - b.shear_force).max() <= 1e-10 * np.abs(b.shear_force).max()
    assert np.abs(a.force - b.force).max() <= 1e-10 * np.abs(b.force).max()
    assert abs(a.shear_force.sum() / (-0.2 * P * L) - 1) <= 1e-10                   # the floor holds q L; 5.3e-14
    # (measured: 10 of 17 nodes slip at g = 3e6 Pa, 12 at mu = 0.25, whose fixed point converges in 10 iterations)


@pytest.mark.numerics
def test_a_contact_ending_inside_an_element_is_finished_at_cut_points_and_tends_to_frictionless():
    """A clamped block pressed 1e-4 m into a disk: the contact ends inside elements (3 of 17 nodes carry a force), so
    the nodal relaxation leaves their cones and the finish adds a normal row at each maximum of the true slack (the
    disk's own gap) until none is above rounding. Tresca's answer departs from the frictionless one (the cones' own
    finish, Newton at the tangency points: an independent route) linearly in g (measured ratios 10.0003, 10.00003 for
    g x10, the departure 3.9e-5 of the displacements at g = 1e3 Pa); every check at rounding."""
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=8, ny=4)
    body = cc.Body(m, steel(), contact="bottom", clamped="top")
    disk = cc.Rigid.circle(center=(0.0, -1.0), radius=1.0 + 1e-4)
    free = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", disk)]), **P2)
    assert free.polished
    departures = []
    for g in (1e3, 1e4):
        with warnings.catch_warnings():
            warnings.simplefilter("error", cc.ResidualWarning)
            sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", disk, law=cc.Tresca(g))]), **P2)
        assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
        r = sol.residuals()
        assert r["feasibility"] <= 1e-9 and r["cone"] <= 1e-12 and r["complementarity"] <= 1e-7   # 8e-15, 0, 1.6e-9
        departures.append(np.abs(sol.u[0] - free.u[0]).max() / np.abs(free.u[0]).max())
    assert departures[0] <= 1e-3 and abs(departures[1] / departures[0] - 10) <= 0.1


@pytest.mark.numerics
def test_two_blocks_on_non_matching_lines_balance_finished_or_not(shared):
    """Two blocks (non-matching lines, the upper one narrower): the finish adds cut points where the contact ends
    inside an element; where its steps do not settle (measured: they cycle on the cut round) the Newton at the
    tangency points from the interior point's structure (measured: finished, tests/test_friction_p2_cuts.py), else
    the interior point's answer is kept with a ResidualWarning naming why. Either way the shear balances q L (the upper block has no
    other support along x) and the checks sit within the interior point's resolution."""
    q = 0.02 * P
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sol = shared(*pair2d_key())[0]      # pair2d(Tresca(0.03 p), q, "gamma3"), read by test_friction_finish too
    if not sol.polished:
        assert UNFINISHED_CONES in sol.info.declined
        assert any(UNFINISHED_CONES in str(w.message) for w in record if issubclass(w.category, cc.ResidualWarning))
    assert abs(sol.contact.shear_force.sum() / (-q * L) - 1) <= 1e-10                # measured 1.7e-13
    r = sol.residuals()
    assert r["equilibrium"] <= 1e-10 and r["friction cone"] <= 1e-10               # measured 6.3e-14, 3.4e-15
    assert r["complementarity"] <= 1e-5 and r["stick-slip"] <= 1e-5                 # measured 7.7e-8, 3.7e-8


def test_without_polish_the_answer_is_the_interior_points_and_says_so():
    """polish=False: the interior point's answer, checked (a check failing at tol would warn with the term's hint),
    its ``info.declined`` naming why it is not finished."""
    sol = cc.solve(uniform_layer(0.2 * P, cc.Tresca(2 * P)), polish=False, **P2)
    assert not sol.polished and UNFINISHED_CONES in sol.info.declined
    with pytest.warns(cc.ResidualWarning, match="or a finish that declined"):
        cc.solve(uniform_layer(0.2 * P, cc.Tresca(2 * P)), polish=False, tol=1e-14, **P2)


def _stuck_pair3d(tau, law, lower_n):
    """The two layers of :func:`friction_scenes.uniform_pair3d` (the upper 2 x 2 x 1 tetrahedra cells), the lower
    one ``lower_n`` x ``lower_n`` x 1 (3: non-matching faces)."""
    q = tau * DIAGONAL3
    a = cc.Body(cc.box(nx=2, ny=2, nz=1), steel(nu=0.0), contact="bottom",
                traction={"top": (q[0], q[1], -P), **_side_shear(q)}, name="upper")
    lower = cc.box(nx=lower_n, ny=lower_n, nz=1)
    b = cc.Body(lower.with_points(lower.points - [0.0, 0.0, 1.0]), steel(nu=0.0), contact="top", clamped="bottom",
                traction=_side_shear(q), name="lower")
    return cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=law)])


def _uniform3d(tau, z):
    """The stuck uniform layer's displacement (tau_x z / G, tau_y z / G, -p z / E), G = E / 2 (nu = 0)."""
    return np.column_stack([2 * tau * DIAGONAL3[0] * z / E, 2 * tau * DIAGONAL3[1] * z / E, -P * z / E])


@pytest.mark.numerics
def test_3d_a_uniform_layer_on_a_plane_sticks_with_the_closed_form_and_its_shear_read_back(shared):
    """P2 tetrahedra: the copositive cones of every face triangle, a friction row at every node of X_h (capacity g
    times the red refinement's lumped areas, positive at the vertices). Stuck: the closed form, exact in P2
    (measured 5.4e-15), the plane holding tau A along the diagonal (A = 1 m^2), the nodal forces those of "sigma1"."""
    tau = 0.2 * P                                   # the layer of LAYERS3D["stuck"], solved once a run
    sol = shared(*layer_key("stuck"))
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    exact = _uniform3d(tau, sol.points[0][:, 2])
    assert np.abs(sol.u[0] - exact).max() <= 1e-10 * np.abs(exact).max()
    c, nodal = sol.contact, cc.solve(uniform_layer3d(tau, cc.Tresca(10 * tau)), "sigma1", degree=2).contact
    assert np.abs(c.shear_force.sum(axis=0) / (-tau * DIAGONAL3) - 1).max() <= 1e-10
    # every P2 node touches: the nodal rows of "sigma1" (every P2 face node) are the same condition; the rows carry
    # the consistent forces of the uniform shear, 0 at a vertex and tau A/3 per face at an edge midpoint
    # (tests/test_friction3d_p2.py)
    assert np.abs(c.shear_force - nodal.shear_force).max() <= 1e-10 * np.abs(nodal.shear_force).max()
    assert np.abs(c.force - nodal.force).max() <= 1e-10 * np.abs(nodal.force).max()
    r = sol.residuals()
    assert max(r["complementarity"], r["stick-slip"], r["cone"]) <= 1e-10            # measured 0, 0, 0


@pytest.mark.numerics
@pytest.mark.parametrize("law, lower_n", [(cc.Tresca(2 * P), 2), (cc.Tresca(2 * P), 3)],
                         ids=["tresca", "tresca-non-matching"])
def test_3d_a_stuck_pair_of_layers_is_the_closed_form(law, lower_n):
    """Two layers (the lower one clamped at z = -1), matching and non-matching faces: stuck, u = the uniform state of
    z + 1 on the upper layer (measured 1.1e-14, 5.8e-15), finished on the nodes. (Coulomb between two 3D bodies
    under the P2 cones is refused: the test below.)"""
    tau = 0.2 * P
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(_stuck_pair3d(tau, law, lower_n), **P2)
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    exact = _uniform3d(tau, sol.points[0][:, 2] + 1.0)
    assert np.abs(sol.u[0] - exact).max() <= 1e-10 * np.abs(exact).max()


@pytest.mark.numerics
def test_3d_a_sliding_layer_is_finished_at_cut_points_and_slides_with_g_times_the_area(shared):
    """The layer whose top is moved by s > g / G along the diagonal slides with the friction force g A along it (every
    node of X_h slips). The vertices' friction capacities (the red refinement's areas, A/12) are not the consistent P2
    forces of a uniform traction (0 there), so the nodal relaxation opens a vertex and leaves its triangles' cones
    (by 6.1e-6 of the displacements); one round of cut points closes them (measured: the force g A to 6.9e-9, the
    checks at most 1.5e-9)."""
    g = 1e5                                         # the layer of LAYERS3D["sliding"], solved once a run
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = shared(*layer_key("sliding"))
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    assert (np.linalg.norm(sol.contact.slip, axis=1) > 0).all()
    assert np.linalg.norm(sol.contact.shear_force.sum(axis=0) + g * DIAGONAL3) <= 1e-6 * g
    r = sol.residuals()
    assert r["feasibility"] <= 1e-9 and r["complementarity"] <= 1e-7 and r["cone"] <= 1e-12


@pytest.mark.numerics
def test_p2_friction_under_gamma3_beside_a_nodal_pair_in_3d_is_each_pairs_answer_alone():
    """A 3D pair under 'sigma1' (Tresca, non-matching faces) beside a 'gamma3' one (a box on a plane), apart: once
    refused (docs/refusals.md row 32; the 2D case: tests/test_tresca.py), each pair's answer is the one it has alone
    (measured at most 1.3e-14 of the displacements), finished (tests/test_friction_p2_gamma3_mixed.py)."""
    tau = 0.2 * P
    scene = _stuck_pair3d(tau, cc.Tresca(2 * P), 3)
    floor = cc.Rigid.plane(point=(0.0, 0.0, -3.0), normal=(0.0, 0.0, 1.0))
    aside = cc.Body(cc.box(x=(2, 3), y=(0, 1), z=(-3, -2), nx=1, ny=1, nz=1), steel(), contact="bottom",
                    traction={"top": (0.0, 0.0, -P)},
                    displacement={"left": (0.0, 0.0, None), "front": (0.0, 0.0, None)},
                    name="aside")
    upper, lower = scene.bodies
    pairs = [cc.Contact(upper, "bottom", lower, "top", law=cc.Tresca(2 * P), condition="sigma1"),
             cc.Contact(aside, "bottom", floor, condition="gamma3")]
    sol = cc.solve(cc.Scene(*scene.bodies, aside, contacts=pairs), **P2)
    alone = [cc.solve(cc.Scene(upper, lower, contacts=pairs[:1]), **P2),
             cc.solve(cc.Scene(aside, contacts=pairs[1:]), **P2)]
    assert sol.ok and sol.polished and all(s.polished for s in alone), sol.info.declined
    for u, ref in zip(sol.u, [alone[0].u[0], alone[0].u[1], alone[1].u[0]]):
        assert np.abs(u - ref).max() <= 1e-10 * np.abs(ref).max()


@pytest.mark.numerics
def test_a_body_above_a_curved_obstacle_is_finished_against_its_own_gap():
    """A clamped block under its weight above a disk (gap 1e-4 m, never closed): the finish on the nodes checks the
    slack against the disk's own gap (its departure from the P2 interpolant) and is kept; Tresca's threshold holds
    the face tangentially with no pressure, as under "sigma1" (the same answer, measured 2.5e-15)."""
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=8, ny=4)
    body = cc.Body(m, steel(), contact="bottom", clamped="top", body_force=(0.0, -1e5))
    disk = cc.Rigid.circle(center=(0.0, -1.0), radius=1.0 - 1e-4)
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", disk, law=cc.Tresca(1e6))])
    sol, nodal = cc.solve(scene, **P2), cc.solve(scene, "sigma1", degree=2)
    assert sol.ok and sol.polished, sol.info.declined
    assert np.abs(sol.u[0] - nodal.u[0]).max() <= 1e-10 * np.abs(nodal.u[0]).max()
    assert np.abs(sol.contact.force).max() == 0.0 and sol.residuals()["feasibility"] == 0.0


@pytest.mark.parametrize("lower_n", [2, 3], ids=["matching", "non-matching"])
def test_3d_coulomb_between_two_bodies_under_the_p2_cones_is_refused_naming_what_to_use(lower_n):
    """Coulomb's capacities mu r_a read the cones' nodal forces r on X_h, not unique on non-matching 3D faces (rank
    59 of 81 nodes: tests/test_friction_p2_gamma3_checks.py): refused between two bodies, naming Tresca under
    'gamma3', Coulomb under 'sigma1'/'sigma2' and degree=1; against a rigid obstacle it stays available."""
    with pytest.raises(cc.UnsupportedError) as info:
        cc.solve(_stuck_pair3d(0.2 * P, cc.Coulomb(0.5), lower_n), **P2)
    msg = str(info.value)
    assert "cc.Coulomb" in msg and "not unique" in msg, msg
    assert "cc.Tresca(g)" in msg and "'sigma1'" in msg and "'sigma2'" in msg and "degree=1" in msg, msg
