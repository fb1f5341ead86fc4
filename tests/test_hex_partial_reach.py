"""A normal-compliance law against obstacles that reach a hexahedral contact face only in part (fem/q2faces.
SimpsonSurface.law_weights, fem/hexfaces.law_weights): every row carries the law with a positive weight, its node's
hat integrated over the body's part (the lumped rule of the law's integral, Phi 0 at a node the obstacle misses).

The scene: a steel block on [0, 1]^2 x [0, H] (3 x 3 x 1 cells, rollers on its sides) pushed down by DELTA onto two
flat obstacles in the plane z = 0, one under x < 0.4 and one under x >= 0.4 (+inf distance elsewhere: a node
there misses it), so that the middle column of faces (1/3 < x < 2/3) is reached by each obstacle only in part
(Q1: its corners x = 1/3 by one, x = 2/3 by the other; Q2: x = 1/3 by one, x = 1/2, 2/3 by the other). The two
obstacles reach complementary sets of nodes and together weigh the face once: the block is in uniaxial strain, the
closed form p = k r with r = DELTA - p H / c33, p = k DELTA / (1 + k H / c33), written here. Each row's force is p
times its node's hat integral written here (1D Simpson 1/18, 4/18, 2/18, ... on Q2; 1/6, 1/3 on Q1, squared), and
each obstacle's weights sum to its reached nodes' area (7/18 and 11/18 of the face on Q2, 1/2 each on Q1). Before,
a Q2 row on no face whose 9 nodes all reach an obstacle weighed 0: the 7 rows at x = 1/2 carried no law and
penetrated for free (the block 0.21 DELTA off the closed form; this module's Q2 cases failed, Q1's passed).
"""

import numpy as np
import pytest
from hex_scenes import DELTA, SIDES, STEEL, H
from reach_scenes import strip as _strip

import cvxcontact as cc
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics

K = 2e11                                   # Pa/m: the law's penetration 0.73 of DELTA
EDGE = 0.4                                 # where one obstacle ends and the other begins (m)
C33 = float(STEEL.tensors(3)[0][2, 2])
P = K * DELTA / (1.0 + K * H / C33)
# the 1D integrals of the nodes' hats on 3 faces 1/3 wide, by node index along the side (x = i / 3 or i / 6)
HATS = {1: np.array([1, 2, 2, 1]) / 6, 2: np.array([1, 4, 2, 4, 2, 4, 1]) / 18}


def _scene():
    body = cc.Body(cc.box(nx=3, ny=3, nz=1, z=(0.0, H), cell="hex"), STEEL, roller=SIDES,
                   displacement={"top": (None, None, -DELTA)}, contact="bottom")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", _strip(-1.0, EDGE)),
                                    cc.Contact(body, "bottom", _strip(EDGE, 2.0))])


@pytest.fixture(scope="module", params=[1, 2], ids=["Q1", "Q2"])
def solved(request):
    degree = request.param
    scene = _scene()
    law = cc.NormalCompliance(K)
    lines = space(degree, "hex").contact(scene, "sigma1", law)
    return degree, lines, cc.solve(scene, "sigma1", degree=degree, law=law)


def test_every_row_on_a_partly_reached_face_carries_the_law_with_its_hats_integral(solved):
    """The rows' weights: positive, each the hat integral written here at its node, each obstacle's summing to the
    area its nodes are given (Q2 7/18, 11/18; Q1 1/2, 1/2) and both to the face's 1 m^2."""
    degree, lines, sol = solved
    w = np.asarray(lines.weights)
    assert (w > 0).all()
    i = np.rint(np.concatenate([c.points[:, :2] for c in sol.contacts]) * 3 * degree).astype(int)
    assert len(w) == len(i) == (3 * degree + 1) ** 2                   # every node of the face a row, once
    assert np.abs(w - HATS[degree][i[:, 0]] * HATS[degree][i[:, 1]]).max() <= 1e-14   # measured 2.8e-17
    split = len(sol.contacts[0].force)
    reached = {1: (1 / 2, 1 / 2), 2: (7 / 18, 11 / 18)}[degree]
    assert abs(w[:split].sum() - reached[0]) <= 1e-13                 # measured 1.1e-16
    assert abs(w[split:].sum() - reached[1]) <= 1e-13                 # measured 2.2e-16
    assert abs(w.sum() - 1.0) <= 1e-13                                 # measured 4.4e-16


def test_a_block_pushed_onto_obstacles_that_reach_its_faces_in_part_is_the_closed_form(solved):
    """Uniaxial strain: u_z = -(DELTA - P H / c33) - P z / c33, no lateral u, every row's pressure P = k r, its force
    P times its hat integral, the total P times the face's area."""
    degree, _, sol = solved
    assert sol.ok
    for u, x in zip(sol.u, sol.points):
        assert np.abs(u[:, 2] + (DELTA - P * H / C33) + P * x[:, 2] / C33).max() <= 1e-10 * DELTA  # measured 1.5e-15
        assert np.abs(u[:, :2]).max() <= 1e-10 * DELTA                                              # measured 5.4e-16
    for c in sol.contacts:
        i = np.rint(c.points[:, :2] * 3 * degree).astype(int)
        assert np.abs(c.force - P * HATS[degree][i[:, 0]] * HATS[degree][i[:, 1]]).max() <= 1e-10 * P / 9  # 6.3e-16
        assert np.abs(np.asarray(c.lam) - P).max() <= 1e-10 * P                           # measured 1.6e-15 P
    assert abs(sum(c.force.sum() for c in sol.contacts) - P) <= 1e-10 * P           # measured 6.4e-16 P


def test_a_q2_block_on_a_sphere_posed_along_its_rays_feels_the_law_as_posed_towards_the_closest_points():
    """A Q2 block (2 x 2 faces, clamped on top) 20 um into a sphere of radius 0.3 m under its centre: posed along
    the faces' normal (``distance="ray"``) the rays of the face corners miss the sphere (+inf, no row), so that no
    face has all 9 nodes reaching it; posed towards the closest points every node reaches it. Only the centre node
    touches, where both distances are R - |x - c| alike: the law's forces and the displacements are the same. Before,
    the rows on no wholly reached face weighed 0: posed along the rays the block went through the sphere with no
    force (91 kN posed towards the closest points)."""
    body = cc.Body(cc.box(nx=2, ny=2, nz=1, z=(0.0, H), cell="hex"), STEEL, clamped=["top"], contact="bottom")
    sols = [cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.sphere(
        (0.5, 0.5, -0.3 + 2e-5), 0.3, distance=posing))]), "sigma1", degree=2, law=cc.NormalCompliance(K))
        for posing in ("ray", "closest")]
    assert all(s.ok for s in sols)
    ray, closest = sols
    assert len(ray.contacts[0].force) < len(closest.contacts[0].force) == 25       # the rays miss the corners
    total = closest.contacts[0].force.sum()
    assert total > 0
    assert abs(ray.contacts[0].force.sum() - total) <= 1e-10 * total               # measured <= 3.3e-16
    assert np.abs(ray.u[0] - closest.u[0]).max() <= 1e-10 * np.abs(closest.u[0]).max()   # measured <= 2.4e-16
