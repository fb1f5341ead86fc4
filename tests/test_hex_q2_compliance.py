"""A normal-compliance law on Q2 (27-node) hexahedra (fem/q2faces.SimpsonSurface): the law on the nodal rows,
integrated by the biquadratic faces' own weights (tensor Simpson on a parallelogram: A/36, 4A/36, 16A/36).

Independent references: the series closed form of a column squeezed through the law (two blocks in uniaxial
strain and the law between them, linear and quadratic; a block on a rigid plane through the law), solved here by
hand; under a tilted gap (partial contact) the law read off the displacements at the faces' nodes by hand, the
rows' forces against Simpson's weights written here, and the total force against a direct Gauss quadrature of the
biquadratic trace of the penetration (Lagrange functions written here, no package code).
"""

import numpy as np
import pytest
from hex_scenes import (
    ALU,
    DELTA,
    M_A,
    M_S,
    PUSH,
    SIDES,
    SOFT,
    STEEL,
    TILTED,
    H,
    block,
    check_column,
    pair,
    series,
)

import cvxcontact as cc
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics

Q2 = space(2, "hex")



@pytest.mark.parametrize("m", [1, 2])
def test_a_column_squeezed_through_the_law_is_the_series_closed_form(m):
    """Steel under aluminium (2 x 2 matching Q2 faces), pushed together by DELTA through p = k r^m: the
    penetration is uniform, the displacements piecewise linear, every row reads p and the forces sum to p times
    the faces' area (1 m^2)."""
    scene = pair(block(2, (0.0, H)), block(2, (H, 2 * H)), materials=(STEEL, ALU))
    sol = cc.solve(scene, "sigma1", degree=2, law=cc.NormalCompliance(SOFT[m], exponent=m))
    assert sol.ok and sol.polished
    p, r = series(SOFT[m], m)
    assert 0.1 * DELTA < r < 0.9 * DELTA                                      # the law takes part in the answer
    check_column(sol, p, r)                     # measured: u <= 1.2e-15 DELTA, forces 1.4e-15 p, lam 2.9e-15 p


def test_a_penetration_limit_holds_the_column_at_the_limit():
    """The column of the closed form (k = 2e11 Pa/m) with a penetration limit l at half the free penetration,
    under the upper block's rows ("sigma2"): the rows stop at r = l, so p = (DELTA - l) / (H / M_steel + H / M_alu)
    at every row, the forces sum to p times 1 m^2 and the upper block is in uniaxial strain."""
    k, c = SOFT[1], H / M_S + H / M_A
    limit = 0.5 * series(k, 1, c)[1]
    p = (DELTA - limit) / c
    scene = pair(block(2, (0.0, H)), block(2, (H, 2 * H)), materials=(STEEL, ALU))
    sol = cc.solve(scene, "sigma2", degree=2, law=cc.NormalCompliance(k, penetration_limit=limit))
    assert sol.ok and sol.polished
    cr = sol.contacts[0]
    assert abs(cr.force.sum() - p) <= 1e-12 * p                                  # measured 1.2e-15 p
    assert np.abs(cr.lam - p).max() <= 1e-12 * p                                 # measured 2.0e-15 p
    z = sol.points[1][:, 2]
    assert np.abs(sol.u[1][:, 2] + p * H / M_S + limit + p * (z - H) / M_A).max() <= 1e-12 * DELTA   # 8.0e-16


def test_a_block_on_a_rigid_plane_through_the_law_is_the_closed_form():
    """A steel block (2 x 2 x 1 Q2 cells, clamped at its bottom) whose top meets a rigid plane DELTA below it
    through p = k r: uniaxial strain, r = DELTA / (1 + k H / M_steel), every row reads p = k r."""
    body = cc.Body(block(2, (0.0, H)), STEEL, roller=SIDES, clamped=["bottom"], contact="top", name="block")
    plane = cc.Rigid.plane((0.0, 0.0, H - DELTA), (0.0, 0.0, -1.0))
    k = SOFT[1]
    sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", plane)]), "sigma1", degree=2,
                   law=cc.NormalCompliance(k))
    p, _ = series(k, 1, H / M_S, H - (H - DELTA))       # the push as the plane holds it (1e-12 off DELTA)
    assert sol.ok and sol.polished
    assert np.abs(sol.u[0][:, 2] + p * sol.points[0][:, 2] / M_S).max() <= 1e-12 * DELTA   # measured 3.4e-16
    assert abs(sol.contacts[0].force.sum() - p) <= 1e-12 * p                                # measured 4.8e-16
    assert np.abs(sol.contacts[0].lam - p).max() <= 1e-12 * p                               # measured 6.4e-16


def _lagrange(t):
    """(k, 3): the 1D quadratic Lagrange functions of the nodes -1, 0, 1 at ``t`` (k,)."""
    return np.stack([t * (t - 1) / 2, 1 - t ** 2, t * (t + 1) / 2], axis=1)


@pytest.fixture(scope="module")
def tilted():
    """Two steel blocks of 2 x 2 x 1 Q2 cells under the tilted gap of tests/hex_scenes.py (part of the faces
    open), pushed by PUSH, k = 1e11 Pa/m."""
    k = 1e11
    scene = pair(block(2, (0.0, H)), block(2, (H, 2 * H)), gap=TILTED, rollers=False, push=PUSH)
    return k, cc.solve(scene, "sigma1", degree=2, law=cc.NormalCompliance(k))


def test_the_law_reads_the_biquadratic_trace_at_the_nodes_with_simpsons_weights(tilted):
    """Under the tilted gap: at every node of the contact faces (a 5 x 5 grid of step 1/4), lambda = k (r)_+ with
    r = u_z(lower) - u_z(upper) - g read off the displacements by hand, the row's force is Simpson's weight
    s(x) s(y) times it (s = 1/12, 4/12, 2/12, 4/12, 1/12 along each axis: 1D Simpson on faces 1/2 wide), and the
    forces sum to k times the integral of the biquadratic trace of (r)_+ by 3 x 3 Gauss on each face (exact)."""
    k, sol = tilted
    assert sol.ok and sol.polished
    top = [np.flatnonzero(np.isclose(sol.points[i][:, 2], H)) for i in (0, 1)]
    grid = lambda pts: np.rint(pts[:, :2] * 4).astype(int)                     # (i, j) on the 5 x 5 grid
    uz = np.zeros((2, 5, 5))
    for i in (0, 1):
        ij = grid(sol.points[i][top[i]])
        uz[i, ij[:, 0], ij[:, 1]] = sol.u[i][top[i], 2]
    s = np.linspace(0.0, 1.0, 5)
    r = uz[0] - uz[1] - TILTED(s[:, None], s[None, :])
    p = k * np.maximum(r, 0.0)
    assert 0 < (r > 0).sum() < 25                                              # partial contact
    c = sol.contacts[0]
    ij = grid(c.points)
    simpson = np.array([1, 4, 2, 4, 1]) / 12
    scale = p.max()
    assert np.abs(c.lam - p[ij[:, 0], ij[:, 1]]).max() <= 1e-12 * scale        # measured <= 1.2e-15
    w = simpson[ij[:, 0]] * simpson[ij[:, 1]]
    assert np.abs(c.force - w * p[ij[:, 0], ij[:, 1]]).max() <= 1e-12 * scale * w.max()  # measured <= 5.7e-16
    g, gw = np.polynomial.legendre.leggauss(3)
    N = _lagrange(g)                                                           # (3 points, 3 nodes)
    total = 0.0
    for a in (0, 1):
        for b in (0, 1):
            nodal = p[2 * a:2 * a + 3, 2 * b:2 * b + 3]
            total += np.einsum("p,q,pi,qj,ij->", gw, gw, N, N, nodal) / 16          # Jacobian (1/4)^2
    assert abs(c.force.sum() - total) <= 1e-12 * total                          # measured <= 3.9e-16


def test_friction_beside_a_compliance_pair_is_the_series_closed_form():
    """Two unit boxes of 2 x 2 x 1 Q2 cells (tests/friction_scenes.compliant_series3d): the upper stuck on the lower
    under Tresca, the lower on a rigid plane through the law (k = 1e13 Pa/m): the friction capacities beside the
    law's Simpson-weighted rows; the closed form (springs in series, the stuck shear; Q2 reproduces it)."""
    from friction_scenes import P as P_FRICTION
    from friction_scenes import compliant_series3d, compliant_series3d_exact

    tau, k = 0.1 * P_FRICTION, 1e13
    scene = compliant_series3d(tau, k, g=0.5 * P_FRICTION, cell="hex")
    sol = cc.solve(scene, degree=2, condition="sigma1")
    assert sol.ok
    for i, body in enumerate(scene.bodies):
        exact = compliant_series3d_exact(Q2.node_set(body.mesh).points, tau, k)
        assert np.abs(sol.u[i] - exact).max() <= 1e-11 * np.abs(exact).max()       # measured <= 2.8e-14
