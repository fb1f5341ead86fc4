"""Coulomb's capacities under the P2 cones, checked by this module's own code: the non-negative nodal forces of
:func:`cvxcontact.contact.bernstein.positive_force` on P2 triangles (the 3D faces) from positive measures written
here with the P2 Lagrange functions of the triangle, under any numbering of the nodes; the answers' friction
forces against the capacities those forces allow (a cones' pair beside a nodal pair in 2D, a box on a sphere
under "gamma3" in 3D): the total friction force of a pair at most mu times its normal force, none at a node whose
nodal normal force is negative, and the reported threshold non-negative and at least the rows' shear."""

import warnings

import numpy as np
import pytest
from friction_scenes import L, P, rolled_stack, steel

import cvxcontact as cc
from cvxcontact.contact.bernstein import positive_force


def _p2_square(n):
    """(cells (S, 6), nodes (N, 2)): the unit square in 2 n^2 P2 triangles, each cell (v0, v1, v2, m01, m12, m20),
    the nodes of a (2n + 1)^2 grid."""
    k = 2 * n + 1
    idx = np.arange(k * k).reshape(k, k)
    cells = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = idx[2 * i, 2 * j], idx[2 * i, 2 * j + 2], idx[2 * i + 2, 2 * j + 2], idx[2 * i + 2, 2 * j]
            ab, bc, cd, da = idx[2 * i, 2 * j + 1], idx[2 * i + 1, 2 * j + 2], idx[2 * i + 2, 2 * j + 1], \
                idx[2 * i + 1, 2 * j]
            mid = idx[2 * i + 1, 2 * j + 1]
            cells += [[a, b, c, ab, bc, mid], [a, c, d, mid, cd, da]]
    return np.array(cells)


def _lagrange_p2(lam):
    """(6,) the P2 Lagrange functions of a triangle (v0, v1, v2, m01, m12, m20) at the barycentric point ``lam``."""
    l0, l1, l2 = lam
    return np.array([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0])


@pytest.mark.parametrize("seed", range(6))
def test_on_p2_triangles_point_forces_give_non_negative_forces_kept_under_any_numbering(seed):
    """Point forces at random points of P2 triangles (near vertices too, where the vertex functions are most
    negative): p >= 0, sum p = sum r, p <= max(r, 0) node by node (forces are only taken), p = 0 where r < 0, and
    the same p, permuted, for a permuted numbering of the nodes (measured: 0 failures of 2000 such draws)."""
    rng = np.random.default_rng(seed)
    cells = _p2_square(3)
    r = np.zeros(cells.max() + 1)
    for s in rng.integers(0, len(cells), 6):
        lam = rng.dirichlet((1.0, 1.0, 1.0)) if rng.random() < 0.5 else rng.dirichlet((0.2, 0.2, 0.2))
        r[cells[s]] += rng.uniform(0.1, 1.0) * _lagrange_p2(lam)
    assert r.min() < 0                                   # the case at stake: a negative nodal force
    p = positive_force(cells, r)
    assert p.min() >= -1e-15 * r.max()
    assert abs(p.sum() - r.sum()) <= 1e-14 * np.abs(r).sum()
    assert (p <= np.maximum(r, 0.0) + 1e-15 * r.max()).all()
    assert np.abs(p[r < 0]).max() <= 1e-15 * r.max()
    perm = rng.permutation(len(r))
    inverse = np.argsort(perm)
    assert np.abs(positive_force(inverse[cells], r[perm]) - p[perm]).max() <= 1e-14 * r.max()


def test_a_negative_node_with_no_positive_force_in_reach_keeps_it_and_the_sum():
    """No positive measure gives it, but the function must not lose force silently: where no positive force is in
    a negative node's reach, every force is kept (sum kept); Coulomb's thresholds then read it as no pressure."""
    cells = np.array([[0, 1, 2], [2, 3, 4]])
    r = np.array([-1.0, -2.0, -1.0, 0.0, 0.0])
    assert np.array_equal(positive_force(cells, r), r)


@pytest.mark.numerics
@pytest.mark.parametrize("conditions, nx", [(("gamma3", "sigma1"), (4, 3, 3)), (("sigma1", "gamma3"), (3, 3, 5))])
@pytest.mark.parametrize("mu", [0.01, 0.05])
def test_a_sliding_stack_of_a_cones_pair_and_a_nodal_pair_keeps_coulombs_bounds(conditions, nx, mu):
    """The rolled stack of tests/friction_scenes.py (Poisson's expansion slides it), Coulomb on a "gamma3" pair
    beside a nodal pair, non-matching lines: each pair's total friction force at most mu times its normal force
    p L (the top block's load, carried through both pairs; measured at most 0.967 of it), the reported threshold
    >= 0 and at least the rows' shear |row_shear| (measured at most 7.7e-13 of the largest threshold above it),
    the fixed point settled (its last change measured at most 7.4e-12)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = cc.solve(rolled_stack(cc.Coulomb(mu), conditions, nx=nx), degree=2)
    assert sol.ok and sol.polished, sol.info.declined
    assert sol.info.fixed_point[-1] <= 1e-9
    for c in sol.contacts:
        assert np.abs(c.shear_force).sum() <= mu * P * L * (1 + 1e-9)
        assert c.threshold.min() >= 0.0
        assert (np.abs(c.row_shear) - c.threshold).max() <= 1e-10 * c.threshold.max()


def _dragged_box(once, mu):
    """A P2 box (3 x 3 x 1 cells) pressed and dragged on a rigid sphere under "gamma3" with Coulomb's ``mu``,
    solved once per module (``once``: the two tests below read the mu = 0.2 answer)."""
    def make():
        b = cc.Body(cc.box(x=(-0.5, 0.5), y=(-0.5, 0.5), z=(0.0, 0.5), nx=3, ny=3, nz=1), steel(), contact="bottom",
                    displacement={"top": (2e-5, 1e-5, -1e-4)})
        ball = cc.Rigid.sphere(center=(0.0, 0.0, -2.0), radius=2.0)
        return cc.solve(cc.Scene(b, contacts=[cc.Contact(b, "bottom", ball, law=cc.Coulomb(mu),
                                                         condition="gamma3")]), degree=2)

    return once(("dragged box", mu), make)


@pytest.mark.numerics
@pytest.mark.parametrize("mu", [0.2, 0.5])
def test_3d_a_box_dragged_on_a_sphere_takes_friction_only_where_the_cones_nodal_force_is_positive(once, mu):
    """A P2 box pressed and dragged on a rigid sphere under "gamma3" (the contact ends inside faces: negative nodal
    forces beside it): at every node |f_a| <= mu max(r_a, 0), r the nodal normal force (``force``; Coulomb's
    capacities only take force from positive nodes; measured at most 0.994 of it, 0 where r_a < 0), so the total
    friction is at most mu sum r; the threshold >= 0."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = _dragged_box(once, mu)
    assert sol.ok and sol.polished, sol.info.declined
    c = sol.contacts[0]
    assert c.force.min() < 0                             # the case at stake
    f = np.linalg.norm(c.shear_force, axis=1)
    assert (f <= mu * np.maximum(c.force, 0.0) + 1e-10 * mu * c.force.max()).all()
    assert f.sum() <= mu * c.force.sum() * (1 + 1e-10)
    assert c.threshold.min() >= 0.0


@pytest.mark.numerics
def test_3d_the_reported_threshold_is_positive_wherever_friction_acts_on_a_sphere(once):
    """The box of the test above (mu = 0.2): wherever the answer applies a friction force (|f_a| > 0, a capacity
    mu p_a > 0) the reported threshold must be > 0, and 0 where the capacity is 0 (r_a < 0); the shear read on the
    same areas never above it. Before (main too): nodes with |f_a| = 7.2e3 N (slipping) reported threshold 0 (mu
    max(lam, 0), lam < 0 there), nodes with r_a < 0 (|f_a| = 0) 1.2e7 Pa; now the capacities over the areas the
    shear is read on."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = _dragged_box(once, 0.2)
    c = sol.contacts[0]
    f = np.linalg.norm(c.shear_force, axis=1)
    acts = f > 1e-9 * f.max()
    assert (c.threshold[acts] > 0).all()
    assert (c.threshold[c.force < 0] == 0).all()
    over = np.linalg.norm(c.shear, axis=1) - c.threshold
    assert over.max() <= 1e-10 * c.threshold.max(), over.max() / c.threshold.max()  # 7.8e-14 (3 kernel sets)
