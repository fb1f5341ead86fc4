"""A normal-compliance law against obstacles that reach a tetrahedral contact part or a 2D P1 contact line only in
part (contact/quadratic3d.QuadraticSurface._partial_weights, contact/surface.SurfaceInterface.weights,
contact/interface.Interface.weights): every node of X_h
carries the law, the faces an obstacle reaches only in part weighed by the lumped rule of the law's integral (Phi 0
at a node the obstacle misses).

The scene of tests/test_hex_partial_reach.py on tetrahedra: a steel block on [0, 1]^2 x [0, H] (3 x 3 x 1 cells of
six tetrahedra, rollers on its sides) pushed down by DELTA onto two flat obstacles in the plane z = 0, one under
x < 0.4 and one under x >= 0.4 (+inf distance elsewhere), so that the middle column of faces (1/3 < x < 2/3) is
reached by each only in part (P1: its vertices x = 1/3 by one, x = 2/3 by the other; P2: x = 1/3 by one, x = 1/2,
2/3 by the other). Together the obstacles are one plane: the closed form of uniaxial strain p = k DELTA / (1 + k H
/ c33). Each node's load under a unit pressure (E^T w) is written here by hand: P1 its hat's integral over the
face, (number of triangles at it) A / 3; P2 its P2 function's integral, 0 at a vertex, A / 3 at an edge midpoint
per triangle of the edge (A = 1/18 m^2 the triangles' area), so each obstacle's loads sum to 1/2, 1/2 (P1) and
7/18, 11/18 (P2, as on Q2 hexahedra). Before, P2 nodes on no face whose six nodes all reach an obstacle lay on no
quadrature point (the 7 midpoints at x = 1/2 penetrated for free: the block 0.195 DELTA off the closed form, its
total force 0.70 P) and P1 rows on such faces weighed the part's mass restricted to the reaching nodes (0.034
DELTA off, 0.915 P); both cases of the closed form failed.

A vertex on no wholly reached face (an obstacle under x < 0.05: only the nodes at x = 0 reach it) takes its red
hat's A/12 from each face, the midpoints next to it A/24 less than A/3 (so A/4 between two such vertices): the
pair's weights sum to the red refinement's 1/12 m^2 (on the strip 0 < x < 1/6 the red hats of the nodes at x = 0
sum to 1 - 6 x), before it had no weight at all.

In 2D (a P1 block of 3 x 1 cells, plane strain, on the same two obstacles) each obstacle's rows were the run of
the vertices that reach it, weighed by that run's own mesh: the segment 1/3 < x < 2/3 between the runs weighed
nothing (0.10 DELTA off the closed form, 0.72 P). Now each row weighs its hat over the whole trace (1/6, 1/3,
1/3, 1/6 m). (2D P2 lines still miss that segment: its midpoint is a row of neither pair, docs/formulation.md §10,
tests/test_p2_line_reach_hole.py.)
"""

import numpy as np
import pytest
from hex_scenes import DELTA, SIDES, STEEL, H
from reach_scenes import OBLIQUE, half, p2_loads
from reach_scenes import line as _line
from reach_scenes import strip as _strip
from reach_scenes import triangles_at as _triangles_at

import cvxcontact as cc
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics

K = 2e11                                   # Pa/m
EDGE = 0.4                                 # where one obstacle ends and the other begins (m)
C33 = float(STEEL.tensors(3)[0][2, 2])
P = K * DELTA / (1.0 + K * H / C33)
A = 1.0 / 18                               # the faces' triangles (m^2)


def _scene(strips=((-1.0, EDGE), (EDGE, 2.0))):
    body = cc.Body(cc.box(nx=3, ny=3, nz=1, z=(0.0, H)), STEEL, roller=SIDES,
                   displacement={"top": (None, None, -DELTA)}, contact="bottom")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", _strip(*s)) for s in strips])


def _loads(points, degree):
    """The nodes' loads (m^2) under a unit pressure, by hand (module docstring)."""
    if degree == 1:
        return np.array([_triangles_at(x, y) * A / 3 for x, y in points[:, :2]])
    return p2_loads(points)


@pytest.fixture(scope="module", params=[1, 2], ids=["P1", "P2"])
def solved(request):
    degree = request.param
    scene = _scene()
    law = cc.NormalCompliance(K)
    lines = space(degree, "tetra").contact(scene, "sigma1", law)
    return degree, lines, cc.solve(scene, "sigma1", degree=degree, law=law)


def test_every_node_on_a_partly_reached_face_carries_the_law_with_the_consistent_loads(solved):
    """Every node of X_h lies on a law row of positive weight; the loads of a unit pressure E^T w are the ones
    written here, each obstacle's summing to the area its nodes are given and both to the face's 1 m^2."""
    degree, lines, sol = solved
    w, E = np.asarray(lines.weights), lines.E
    assert (w > 0).all()
    assert (abs(E).T @ w).min() > 0                        # measured min 6.3e-3 (P2), 1.9e-2 (P1); before 0 (P2)
    points = np.concatenate([c.points for c in sol.contacts])
    assert len(points) == (3 * degree + 1) ** 2            # every node of the face a node of X_h, once
    load = E.T @ w
    assert np.abs(load - _loads(points, degree)).max() <= 1e-14          # measured 4.2e-17
    split = len(sol.contacts[0].force)
    reached = {1: (1 / 2, 1 / 2), 2: (7 / 18, 11 / 18)}[degree]
    assert abs(load[:split].sum() - reached[0]) <= 1e-13                 # measured 3.9e-16
    assert abs(load[split:].sum() - reached[1]) <= 1e-13                 # measured 4.4e-16


def test_a_block_pushed_onto_obstacles_that_reach_its_faces_in_part_is_the_closed_form(solved):
    """Uniaxial strain: u_z = -(DELTA - P H / c33) - P z / c33, no lateral u, every node's force P times its
    load, lambda = P, the total P times the face's area."""
    degree, _, sol = solved
    assert sol.ok
    for u, x in zip(sol.u, sol.points):
        assert np.abs(u[:, 2] + (DELTA - P * H / C33) + P * x[:, 2] / C33).max() <= 1e-10 * DELTA  # measured 1.9e-15
        assert np.abs(u[:, :2]).max() <= 1e-10 * DELTA                                              # measured 4.8e-16
    for c in sol.contacts:
        assert np.abs(c.force - P * _loads(c.points, degree)).max() <= 1e-10 * P / 27       # measured 8e-17 P
        assert np.abs(np.asarray(c.lam) - P).max() <= 1e-10 * P                  # measured 3.8e-15 P
    assert abs(sum(c.force.sum() for c in sol.contacts) - P) <= 1e-10 * P     # measured 1.1e-15 P


def test_the_friction_weights_share_a_partly_reached_face(solved):
    """The rows' areas (the friction capacities' w_a): each node's hat over the whole part (P2: of the red
    refinement), so each obstacle's sum is the integral of its nodes' hats: P1 1/3 + 1/6 = 1/2 each (the hats of
    the nodes at x = 1/3 fall linearly to 0 at x = 2/3); P2 1/3 + 1/12 = 5/12 and 1/3 + 1/6 + 1/12 = 7/12 (the red
    hats of the nodes at x = 1/3 fall to 0 at x = 1/2). Before, the mass restricted to the reaching nodes: 4/9,
    4/9 (P1) and 7/18, 5/9 (P2)."""
    degree, lines, _ = solved
    pairs = lines.interface.interfaces
    for pair, area in zip(pairs, {1: (1 / 2, 1 / 2), 2: (5 / 12, 7 / 12)}[degree]):
        w = np.asarray(pair.weights("sigma1"))
        assert (w > 0).all()
        assert abs(w.sum() - area) <= 1e-13                                  # measured 2.2e-16


def test_a_p2_vertex_on_no_wholly_reached_face_takes_its_red_hat():
    """An obstacle under x < 0.05 reaches only the nodes at x = 0, every face it touches in part: the midpoints
    on x = 0 weigh A/4, the vertices A/12 per triangle at them, summing to 1/12 m^2 (module docstring)."""
    lines = space(2, "tetra").contact(_scene(((-1.0, 0.05),)), "sigma1", cc.NormalCompliance(K))
    x = np.asarray(lines.interface.points)                              # the one pair's nodes of X_h
    assert np.abs(x[:, 0]).max() == 0.0 and len(x) == 7               # the 4 vertices and 3 midpoints at x = 0
    load = lines.E.T @ np.asarray(lines.weights)
    i = np.rint(x[:, 1] * 6).astype(int)
    expected = np.where(i % 2 == 1, A / 4, [_triangles_at(0.0, y) * A / 12 for y in x[:, 1]])
    assert (expected > 0).all()
    assert np.abs(load - expected).max() <= 1e-14                            # measured 1.7e-18
    assert abs(load.sum() - 1 / 12) <= 1e-14                                 # measured 1.4e-17


def test_a_p1_line_pushed_onto_obstacles_that_reach_it_in_part_is_the_closed_form():
    """The 2D P1 block (module docstring): uniaxial plane strain, p = k DELTA / (1 + k H / c), c = lambda + 2 mu;
    the rows' forces p times their hats' integrals 1/6, 1/3 (m) written here."""
    material = cc.materials.isotropic(E=200e9, nu=0.3)
    c = 200e9 * 0.7 / (1.3 * 0.4)
    p = K * DELTA / (1.0 + K * H / c)
    body = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, H), nx=3, ny=1), material, roller=["left", "right"],
                   displacement={"top": (None, -DELTA)}, contact="bottom")
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", _line(*s)) for s in ((-1.0, EDGE), (EDGE, 2.0))])
    sol = cc.solve(scene, "sigma1", degree=1, law=cc.NormalCompliance(K))
    assert sol.ok
    u, x = sol.u[0], sol.points[0]
    assert np.abs(u[:, 1] + (DELTA - p * H / c) + p * x[:, 1] / c).max() <= 1e-10 * DELTA          # measured 3.4e-16
    assert np.abs(u[:, 0]).max() <= 1e-10 * DELTA                                                  # measured 3.4e-17
    for contact, hats in zip(sol.contacts, ([1 / 6, 1 / 3], [1 / 3, 1 / 6])):
        assert np.abs(contact.force - p * np.array(hats)).max() <= 1e-10 * p / 6                  # measured 1.2e-16 p
    assert abs(sum(contact.force.sum() for contact in sol.contacts) - p) <= 1e-10 * p           # measured 1.6e-16 p


def _oblique(line):
    body = cc.Body(cc.box(nx=3, ny=3, nz=1, z=(0.0, H)), STEEL, roller=SIDES,
                   displacement={"top": (None, None, -DELTA)}, contact="bottom")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", half(*line, below)) for below in (True, False)])


@pytest.mark.parametrize("line", OBLIQUE)
def test_p1_obstacles_that_split_the_part_along_an_oblique_line_are_the_closed_form(line):
    """P1: every row weighs its hat over the whole part, so two obstacles reaching complementary sets of nodes (any
    split, here along a line across the faces' diagonals) weigh every node by its whole hat: the uniform state is
    exact (before, the row sums of the restricted mass weighed the cut faces short)."""
    sol = cc.solve(_oblique(line), "sigma1", degree=1, law=cc.NormalCompliance(K))
    assert sol.ok
    for u, x in zip(sol.u, sol.points):
        assert np.abs(u[:, 2] + (DELTA - P * H / C33) + P * x[:, 2] / C33).max() <= 1e-10 * DELTA  # measured 5.1e-16
    assert abs(sum(c.force.sum() for c in sol.contacts) - P) <= 1e-10 * P                       # measured 3.3e-16 P


@pytest.mark.parametrize("line", OBLIQUE)
def test_p2_every_node_carries_the_law_when_the_part_is_split_along_an_oblique_line(line):
    """P2: an oblique split leaves reaching vertices on no wholly reached face (the red hat's A/12 rule): every node
    of X_h still lies on a law row of positive weight, the midpoints' weights positive after their A/24 give-up."""
    lines = space(2, "tetra").contact(_oblique(line), "sigma1", cc.NormalCompliance(K))
    w = np.asarray(lines.weights)
    assert (w > 0).all()
    assert (abs(lines.E).T @ w).min() > 0                   # measured min 4.6e-3 m^2 = A/12 (both); 0 before
