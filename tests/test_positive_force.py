"""Coulomb's normal force under the P2 cones (:func:`cvxcontact.contact.bernstein.positive_force`): the cones'
nodal force r = B^T beta made non-negative, each negative r_a taken from the positive forces of its patch (the
nodes of the elements holding it) in proportion to them, the sums kept (docs/howto/friction.md, "Coulomb under
the cones"). Checked against closed forms (a point force inside a segment, at a triangle's centroid), against
the nodes-by-nodes version of the tests (friction_scenes.positive_forces) and by its defining properties."""

import numpy as np
import pytest
from friction_scenes import positive_forces

from cvxcontact.contact.bernstein import bernstein_basis, bernstein_map, positive_force

LINE = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 6]])
"""Three P2 segments of a line (vertex, midpoint, vertex), nodes 0..6."""


def test_a_point_force_inside_a_segment_goes_to_the_nodes_whose_lagrange_function_is_positive_there():
    """A force y at t = 0.8 of the middle segment: r = y (phi_0, phi_m, phi_1)(0.8) = y (-0.12, 0.64, 0.48) on nodes
    2, 3, 4; node 2's -0.12 y is taken from nodes 3 and 4 in proportion 0.64 : 0.48, so p = y (4/7, 3/7) there."""
    y = 2.5
    beta = np.zeros((3, 3))
    beta[1] = y * bernstein_basis(np.array([0.8]))[0]
    r = bernstein_map(LINE, 7).T @ beta.ravel()
    assert np.allclose(r, y * np.array([0, 0, -0.12, 0.64, 0.48, 0, 0]), rtol=0, atol=1e-15)
    p = positive_force(LINE, r)
    assert np.abs(p - y * np.array([0, 0, 0, 4 / 7, 3 / 7, 0, 0])).max() <= 1e-15 * y


def test_a_point_force_at_a_triangles_centroid_goes_to_its_midpoints():
    """At the centroid the P2 vertex functions are -1/9, the midpoints' 4/9: the vertices' -1/3 y is taken from the
    midpoints, each left with y / 3."""
    tri = np.array([[0, 1, 2, 3, 4, 5]])
    beta = bernstein_basis(np.full((1, 3), 1 / 3))
    r = bernstein_map(tri, 6).T @ beta.ravel()
    assert np.allclose(r, [-1 / 9] * 3 + [4 / 9] * 3, rtol=0, atol=1e-15)
    assert np.abs(positive_force(tri, r) - [0, 0, 0, 1 / 3, 1 / 3, 1 / 3]).max() <= 1e-15


def test_non_negative_nodal_forces_are_kept_bit_for_bit():
    """Nodal forces (point forces at the nodes), a pressure covering its elements: p = r exactly."""
    r = np.random.default_rng(0).uniform(0.0, 1.0, 7)
    r[[0, 6]] = 0.0
    assert np.array_equal(positive_force(LINE, r), r)


@pytest.mark.parametrize("seed", range(10))
def test_point_forces_anywhere_give_non_negative_forces_with_their_sum_kept_and_nothing_moved_far(seed):
    """Point forces at random points of a 12-segment line (the cones' dual: positive measures): p >= 0, sum p =
    sum r to rounding, p = r at every node no negative node's patch holds, and p equal to the node-by-node version
    of the tests."""
    rng = np.random.default_rng(seed)
    S = 12
    cells = np.column_stack([2 * np.arange(S), 2 * np.arange(S) + 1, 2 * np.arange(S) + 2])
    beta = np.zeros((S, 3))
    for s, t, y in zip(rng.integers(0, S, 5), rng.uniform(0, 1, 5), rng.uniform(0.1, 1, 5)):
        beta[s] += y * bernstein_basis(np.array([t]))[0]
    r = bernstein_map(cells, 2 * S + 1).T @ beta.ravel()
    p = positive_force(cells, r)
    assert p.min() >= -1e-15 * r.max()
    assert abs(p.sum() - r.sum()) <= 1e-14 * np.abs(r).sum()
    near = np.zeros(len(r), dtype=bool)
    for cell in cells:
        if (r[cell] < 0).any():
            near[cell] = True
    grown = near.copy()                                  # the patches of the nodes of those elements (a 2nd round)
    for cell in cells:
        if near[cell].any():
            grown[cell] = True
    assert np.array_equal(p[~grown], r[~grown])
    assert np.abs(p - positive_forces(r, cells)).max() <= 1e-15 * r.max()
