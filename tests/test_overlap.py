"""Given friction thresholds of obstacles that overlap on one contact part (cvxcontact/discrete/overlap.py): an
OverlapWarning when the problem is derived, once per problem, naming the pairs, the part, the nodes and their
weights; none where the obstacles only meet, for Coulomb (its capacity mu y_a is shared with the normal forces) or
without friction; and the discrete problem does solve with the summed capacity g1 + g2 (two coincident floors of g
resist a sliding block by 2 g L, as one floor of 2 g)."""

import warnings

import numpy as np
import pytest
from friction_scenes import FLOOR, FLOOR3D, L, P, pushed, uniform_layer, uniform_layer3d
from reach_scenes import block2d, line, lowered, strip

import cvxcontact as cc

G = 2 * P
THREE_2D = (line(-1.0, 0.7), line(0.3, 2.0), line(-1.0, 2.0))
THREE_3D = (strip(-1.0, 0.7), strip(0.3, 2.0), strip(-1.0, 2.0))
TWO_FLOORS = (FLOOR, cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0)))
"""Two coincident floors (two obstacles: a scene refuses one pair given twice)."""


def overlap_warnings(make):
    """The OverlapWarnings (messages) recorded while ``make()`` runs, and what it returned."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = make()
    return [str(w.message) for w in caught if issubclass(w.category, cc.OverlapWarning)], out


def test_tresca_strips_and_floor_warn_once_naming_pairs_part_nodes_and_area_2d():
    """Strips x < 0.7, x >= 0.3 and a whole floor under the 4 x 2 layer (nodes at x = 0, 0.25, ..., 1): every
    bottom node is reached by two or three of them (the floor and a strip; all three at x = 0.5), weights 1 m
    summed (the bottom's length), the largest capacity 3 g."""
    scene = uniform_layer(0.2 * P, cc.Tresca(G), obstacles=THREE_2D)
    found, solver = overlap_warnings(lambda: cc.ContactSolver(scene, "sigma1"))
    assert len(found) == 1
    m = found[0]
    assert "contact part 'bottom'" in m and all(f"contacts[{i}]" in m for i in range(3))
    assert "reach 5 of its nodes" in m and "summing to 1 m)" in m
    assert f"{3 * G:.6g} Pa" in m and f"{G:.6g} Pa of one pair" in m
    assert "split them" in m
    # the same problem re-solved for another load: derived again with the same rows, not warned again
    again, _ = overlap_warnings(lambda: solver.problem.with_loads(uniform_layer(0.1 * P, cc.Tresca(G),
                                                                                obstacles=THREE_2D)))
    assert again == []


def test_the_warning_names_the_users_line():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cc.ContactSolver(uniform_layer(0.2 * P, cc.Tresca(G), obstacles=THREE_2D), "sigma1")
    assert [w.filename for w in caught if issubclass(w.category, cc.OverlapWarning)] == [__file__]


def test_tresca_strips_and_floor_warn_3d():
    """The 3 x 3 x 1 box on the strips and the floor: every bottom node (16) reached by two or more, their
    weights summing to the bottom's area, 1 m^2."""
    found, _ = overlap_warnings(lambda: cc.ContactSolver(uniform_layer3d(0.2 * P, cc.Tresca(G), n=3,
                                                                         obstacles=THREE_3D), "sigma1"))
    assert len(found) == 1
    assert "reach 16 of its nodes" in found[0] and "summing to 1 m^2)" in found[0]
    assert f"{3 * G:.6g} Pa" in found[0]


@pytest.mark.parametrize("dim", [2, 3])
def test_obstacles_split_at_a_line_do_not_warn(dim):
    """Strips x < 0.4 and x >= 0.4 (no bottom node at x = 0.4 in 3D; at x = 0.4 in 2D, the 5 x 2 layer, reached
    by the second only): each node reached by one pair, no capacity added."""
    if dim == 2:
        scene = uniform_layer(0.2 * P, cc.Tresca(G), nx=5, obstacles=(line(-1.0, 0.4), line(0.4, 2.0)))
    else:
        scene = uniform_layer3d(0.2 * P, cc.Tresca(G), n=3, obstacles=(strip(-1.0, 0.4), strip(0.4, 2.0)))
    found, _ = overlap_warnings(lambda: cc.ContactSolver(scene, "sigma1"))
    assert found == []


def test_a_single_shared_end_node_counts():
    """Lines x <= 0.4 and x >= 0.4 both reach the node x = 0.4 of the 5 x 2 layer: each row there weighs the
    node's whole hat (0.2 m: the law's weights over the whole part), so the capacity on it is 2 g w: warned, one
    node, 0.2 m."""
    meet = (line(-1.0, 0.4, tol=1e-9), line(0.4, 2.0, tol=1e-9))
    scene = uniform_layer(0.2 * P, cc.Tresca(G), nx=5, obstacles=meet)
    found, _ = overlap_warnings(lambda: cc.ContactSolver(scene, "sigma1"))
    assert len(found) == 1 and "reach 1 of its nodes" in found[0] and "summing to 0.2 m)" in found[0]


def test_the_warning_says_where():
    """The message lists the overlapped nodes (body node 2 of the 5 x 2 layer: x = 0.4 on the bottom, numbered
    row by row) and the box of their coordinates."""
    meet = (line(-1.0, 0.4, tol=1e-9), line(0.4, 2.0, tol=1e-9))
    found, _ = overlap_warnings(lambda: cc.ContactSolver(uniform_layer(0.2 * P, cc.Tresca(G), nx=5, obstacles=meet),
                                                         "sigma1"))
    assert "nodes 2, in the box from (0.4, 0) to (0.4, 0) m" in found[0]


def test_p2_runs_ending_at_one_vertex_do_not_warn():
    """2D P2: each run's row at its end vertex weighs Simpson's h/6 on its own segment only (0.2 / 6 m on the 5 x 2
    layer), together the vertex's h/3 under one floor: no capacity added there, no warning (a false alarm before:
    warned as on P1, whose rows there weigh the whole hat each; tests/test_overlap.py's sliding blocks: P1 9/8 g L,
    P2 g L)."""
    meet = (line(-1.0, 0.4, tol=1e-9), line(0.4, 2.0, tol=1e-9))
    found, _ = overlap_warnings(lambda: cc.ContactSolver(uniform_layer(0.2 * P, cc.Tresca(G), nx=5, obstacles=meet),
                                                         "sigma1", degree=2))
    assert found == []


def test_p2_runs_overlapping_by_a_segment_warn():
    """2D P2 runs x <= 0.5 and x >= 0.25 on the 4 x 2 layer (h = 0.25 m) share the segment [0.25, 0.5]: at its
    midpoint both rows weigh 2 h / 3, the capacity 2 g; at its vertices the one run's h / 3 and the other's end h / 6
    (1.5 g). Three nodes, their weights under one floor h / 3 + 2 h / 3 + h / 3 = 1/3 m, up to 2 g."""
    runs = (line(-1.0, 0.5, tol=1e-9), line(0.25, 2.0, tol=1e-9))
    found, _ = overlap_warnings(lambda: cc.ContactSolver(uniform_layer(0.2 * P, cc.Tresca(G), obstacles=runs),
                                                         "sigma1", degree=2))
    assert len(found) == 1
    assert "reach 3 of its nodes" in found[0] and f"summing to {1 / 3:.6g} m)" in found[0]
    assert f"up to {2 * G:.6g} Pa" in found[0]


def test_coulomb_frictionless_and_a_single_floor_do_not_warn():
    for make in (lambda: uniform_layer(0.2 * P, cc.Coulomb(0.5), obstacles=THREE_2D),
                 lambda: uniform_layer3d(0.2 * P, cc.Coulomb(0.5), n=3, obstacles=THREE_3D),
                 lambda: block2d(THREE_2D),
                 lambda: uniform_layer(0.2 * P, cc.Tresca(G), obstacles=(FLOOR,)),
                 lambda: uniform_layer3d(0.2 * P, cc.Tresca(G), n=3, obstacles=(FLOOR3D,))):
        found, _ = overlap_warnings(lambda make=make: cc.ContactSolver(make(), "sigma1"))
        assert found == []


def test_one_tresca_pair_beside_a_coulomb_pair_does_not_warn():
    """A given threshold adds only to another given threshold: Tresca on the floor, Coulomb on a strip."""
    m, _ = pushed(None)
    body = cc.Body(m, cc.materials.isotropic(E=200e9, nu=0.0), contact="bottom", traction={"top": (0.0, -P)},
                   displacement={"left": (1e-4, None)})
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR, law=cc.Tresca(1e3)),
                                     cc.Contact(body, "bottom", line(-1.0, 0.7), law=cc.Coulomb(1e-4))])
    found, _ = overlap_warnings(lambda: cc.ContactSolver(scene, "sigma1"))
    assert found == []


@pytest.fixture(scope="module")
def sliding():
    """The 8 x 4 block pushed by u_x = 1e-4 m across two coincident floors of Tresca g = 1e3 Pa each, and across
    one floor of 2 g (every node slides: the friction, 2e3 N/m, strains the block by 1e-8 << 1e-4)."""
    g = 1e3
    two = overlap_warnings(lambda: cc.solve(pushed(cc.Tresca(g), obstacles=TWO_FLOORS)[1], "sigma1"))
    one = cc.solve(pushed(cc.Tresca(2 * g))[1], "sigma1")
    return g, two, one


@pytest.mark.numerics
def test_two_coincident_tresca_floors_resist_by_the_summed_capacity(sliding):
    """Closed form: a sliding node's friction force is its capacity, so with two floors of g each the tangential
    forces of the two pairs at a node sum to 2 g w_a (w_a its lumped length, by hand: 1/8 m, 1/16 m at the ends)
    and to 2 g L over the bottom, against the push; the answer is the one floor's of 2 g (an invariance)."""
    g, (found, sol), one = sliding
    assert len(found) == 1 and "reach 9 of its nodes" in found[0]
    assert sol.ok and one.ok
    w = np.full(9, L / 8)
    w[[0, -1]] = L / 16
    for c in sol.contacts:
        assert (c.slip > 0.5e-4).all()                                   # every node slides forward
    x = [np.asarray(c.points)[:, 0] for c in sol.contacts]
    assert np.array_equal(x[0], x[1])
    t = sum(np.asarray(c.shear_force) for c in sol.contacts)
    # measured 5.7e-17 g L, the sum exact, the displacements 1.2e-15 of the push apart (5 kernel sets)
    assert np.abs(t + 2 * g * w).max() <= 1e-12 * g * L
    assert t.sum() == pytest.approx(-2 * g * L, rel=1e-12)                # not -g L: the capacities add
    assert np.abs(sol.u[0] - one.u[0]).max() <= 1e-12 * 1e-4              # the one floor of 2 g


@pytest.mark.numerics
def test_two_coincident_coulomb_floors_share_the_capacity():
    """Coulomb's capacity mu y_a is each pair's share of the node's normal force times mu: two coincident floors
    of mu resist a sliding block by mu p L (as one floor), not 2 mu p L; no warning."""
    mu = 1e-4
    found, sol = overlap_warnings(lambda: cc.solve(pushed(cc.Coulomb(mu), obstacles=TWO_FLOORS)[1], "sigma1"))
    assert found == [] and sol.ok
    total = sum(np.asarray(c.shear_force).sum() for c in sol.contacts)
    assert total == pytest.approx(-mu * P * L, rel=1e-12)                 # measured 3.4e-15 (5 kernel sets)


@pytest.mark.numerics
def test_a_tresca_floor_never_touched_still_adds_its_capacity():
    """A floor 3e-6 m below the one the block slides on reaches every node (its distance is finite) and is never
    touched (lambda 0), yet its Tresca capacity g L resists the slide as well (Tresca's does not ask for contact):
    the warning names it, each pair's friction is -g L."""
    g = 1e3
    found, sol = overlap_warnings(lambda: cc.solve(pushed(cc.Tresca(g), obstacles=(FLOOR, lowered(-1.0, 2.0, 2)))[1],
                                                   "sigma1"))
    assert len(found) == 1 and "reach 9 of its nodes" in found[0]
    assert sol.ok
    top, low = sol.contacts
    assert np.abs(low.lam).max() == 0.0 and top.lam.max() > 0.9 * P                     # measured 0, 1.0008 p
    for c in (top, low):                                                                # measured exact
        assert np.asarray(c.shear_force).sum() == pytest.approx(-g * L, rel=1e-12)


@pytest.mark.numerics
@pytest.mark.parametrize("degree, extra", [(1, 1 / 8), (2, 0.0)])
def test_runs_ending_at_one_node_add_the_node_where_their_rows_weigh_its_whole_hat(degree, extra):
    """The 8 x 4 block pushed across two Tresca floors of g, x <= L/2 and x >= L/2 (both reaching the node x = L/2):
    every node slides, so the friction is the capacities summed, by hand: P1, each row there the whole hat h = L/8,
    g (L + h) = 9/8 g L and the warning; 2D P2, each run's end row its own h/6, g L and none."""
    g = 1e3
    meet = (line(-1.0, L / 2, tol=1e-9), line(L / 2, 2.0, tol=1e-9))
    found, sol = overlap_warnings(lambda: cc.solve(pushed(cc.Tresca(g), obstacles=meet)[1], "sigma1", degree=degree))
    assert sol.ok and len(found) == (extra > 0)
    assert min(np.asarray(c.slip).min() for c in sol.contacts) > 0.5e-4                  # measured 1e-4: sliding
    total = sum(np.asarray(c.shear_force).sum() for c in sol.contacts)
    assert total == pytest.approx(-g * L * (1 + extra), rel=1e-12)     # measured 0 (P1), 1.1e-16 (P2), 5 kernels


def test_adapt_warns_once_not_at_every_step():
    """cc.adapt solves the scene on each refined mesh, a new problem each time: the overlap (the same pairs on the
    same part) is said once, at the user's line (before: once per step, three for max_steps=2)."""
    scene = uniform_layer(0.2 * P, cc.Tresca(G), obstacles=THREE_2D)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = cc.adapt(scene, "sigma1", max_steps=2)
    assert len(out.history) == 3
    assert [w.filename for w in caught if issubclass(w.category, cc.OverlapWarning)] == [__file__]


@pytest.mark.parametrize("dim, degree, cell", [(2, 1, "triangle"), (2, 2, "triangle"), (3, 1, "tetra"),
                                               (3, 2, "tetra"), (3, 1, "hex"), (3, 2, "hex")])
def test_one_obstacles_weights_over_the_whole_part_sum_to_its_area(dim, degree, cell):
    """The reference a node's summed weights are compared with (overlap._whole_part: the pair's reaching copy of
    every trace node) is one obstacle's quadrature of the whole part: every node weighed, summing to the bottom's
    1 m (2D) or 1 m^2 (3D) (measured 0 and 2.2e-16 off)."""
    from cvxcontact.discrete.overlap import _whole_part
    if dim == 2:
        scene = uniform_layer(0.2 * P, cc.Tresca(G), nx=5, obstacles=(line(-1.0, 0.4), line(0.4, 2.0)))
    else:
        scene = uniform_layer3d(0.2 * P, cc.Tresca(G), n=2, cell=cell, obstacles=(strip(-1.0, 0.4), strip(0.4, 2.0)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        solver = cc.ContactSolver(scene, "sigma1", degree=degree)
    w = _whole_part(solver.problem.lines.interface.interfaces[0], "sigma1")
    assert (w > 0).all()
    assert w.sum() == pytest.approx(1.0, rel=1e-12)
