"""A normal-compliance law with P2 (10-node) tetrahedra (docs/formulation.md §15, "Normal compliance"): the law at
the points of a 6-point degree-4 rule of positive weights on the constrained triangles, springs in series to
rounding (m = 1, 2; matching and non-matching faces), a vertex pushed into the obstacle resisted as the quadrature
energy says, P1 on refined meshes converging to the P2 answer, k -> infinity tending to the "everywhere"
Signorini answer, and the penetration limit at the quadrature points.

Cross-checks, none taken from the code under test: the closed form of a layer in uniaxial strain pressed through
the law (the layer and the law are springs in series: u_z = -(p/k)^(1/m) - p z / c33), exact integrals of
monomials on a triangle, the tabulated rule, a dense Newton minimisation of the quadrature energy built in the
test, a P1 sequence on refined meshes, Signorini solves (another route), the Newton finish against the LCP finish.
"""

import contextlib
import warnings
from math import factorial

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.errors import ResidualWarning
from cvxcontact.contact.quadratic3d import P2_FACE_RULE, P2_TRIANGLE_MASS, p2_shape, p2_weights

from scenes3d import P, SIDES, STEEL, bumped_gap, layer_on_plane, stacked_blocks, uniaxial_modulus

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

C33 = uniaxial_modulus()


def series_error(sol, k, m=1.0, shift=(0.0, 0.0)) -> float:
    """max |u - u_exact| / (p / c33) over every node: u_z = -p z / c33 - shift[body], u_x = u_y = 0."""
    out = 0.0
    for u, x, s in zip(sol.u, sol.points, shift):
        out = max(out, float(np.abs(u[:, 2] + P * x[:, 2] / C33 + s).max()), float(np.abs(u[:, :2]).max()))
    return out / (P / C33)


# ---------------------------------------------------------------------------------------------------------
# the quadrature

def test_the_p2_weights_integrate_quadratics_exactly_and_are_the_mass_row_sums():
    """On a random triangle, sum_a w_a f(x_a) = int f for every monomial of degree <= 2 (exact integrals
    int L^a = 2 A a! / (|a| + 2)! in barycentric coordinates); the weights are the row sums of the P2 mass
    matrix (0 at the vertices, A/3 at the midpoints), never negative."""
    rng = np.random.default_rng(3)
    V = rng.random((3, 2))
    (a, b), (c, d) = V[1] - V[0], V[2] - V[0]
    A = 0.5 * abs(a * d - b * c)
    cells = np.arange(6)[None]
    w = p2_weights(cells, np.array([A]), 6)
    np.testing.assert_allclose(w, A * P2_TRIANGLE_MASS.sum(axis=1), rtol=0, atol=1e-16)   # measured 0
    assert (w >= 0).all() and (w[:3] == 0).all()
    nodes_L = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [.5, .5, 0], [0, .5, .5], [.5, 0, .5]])
    for a in [(0, 0, 0), (1, 0, 0), (0, 0, 1), (2, 0, 0), (1, 1, 0), (0, 1, 1), (0, 0, 2)]:
        exact = 2 * A * np.prod([factorial(i) for i in a]) / factorial(sum(a) + 2)
        assert abs(w @ np.prod(nodes_L ** np.array(a), axis=1) - exact) < 1e-15        # measured <= 1.4e-17
    # a cubic is not integrated exactly (the rule's degree is 2)
    assert abs(w @ nodes_L[:, 0] ** 3 - 2 * A * 6 / factorial(5)) > 1e-3 * A
    # the P2 shape functions sum to one: the weights sum to the area
    assert abs(p2_shape(nodes_L).sum(axis=1) - 1).max() < 1e-15 and abs(w.sum() - A) < 1e-16


# ---------------------------------------------------------------------------------------------------------
# springs in series (rounding)

@pytest.mark.parametrize("m, k", [(1.0, 1e12), (2.0, 1e12 / 5e-6)], ids=["m=1", "m=2"])
@pytest.mark.parametrize("condition", ["sigma1", "gamma3"])
def test_a_layer_pressed_on_a_rigid_plane_through_the_law_is_springs_in_series(condition, m, k):
    """The layer (rollers on its sides) pressed by p onto the plane z = 0 through p(r) = k r^m: uniform stress
    -p, the layer shifted down by the law's penetration r = (p/k)^(1/m) (1e-6 m, 2.2e-6 m)."""
    law = cc.NormalCompliance(stiffness=k, exponent=m)
    sol = cc.solve(layer_on_plane(n=(2, 2, 1)), condition, degree=2, law=law)
    r = (P / k) ** (1 / m)
    assert sol.ok and sol.polished and sol.degree == 2
    assert series_error(sol, k, m, shift=(r,)) < 1e-12                            # measured <= 1.6e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-12                          # measured <= 5.6e-15
    assert np.abs(sol.traction(0)[1] / P - 1).max() < 1e-12                       # measured 2.9e-15
    np.testing.assert_allclose(sol.obstacles[0].force, [0, 0, P], rtol=0, atol=1e-12 * P)   # measured 1.4e-15 P


def squeezed_blocks(lower, upper, delta=1e-5):
    """Two blocks (0, 1)^2 x (0, 0.5) and (0, 1)^2 x (0.5, 1) m held by rollers on every face but their common
    one, z = 0.5, where they interfere by ``delta`` (m; gap -delta), with ``lower``/``upper`` cells across it:
    uniaxial strain, p = delta / (1/k + 1/c33) for p(r) = k r (the law and the two half-metre blocks in series)."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=1)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=1)
    b1 = cc.Body(low, STEEL, roller=SIDES + ["bottom"], contact="top", name="lower")
    b2 = cc.Body(up, STEEL, roller=SIDES + ["top"], contact="bottom", name="upper")
    return cc.Scene(b1, b2, gap=-delta)


CASES = [(((2, 2), (3, 3)), "gamma3"), (((3, 3), (3, 3)), "sigma1"), (((2, 2), (4, 4)), "sigma2"),
         (((4, 4), (2, 2)), "sigma1")]
CASE_IDS = ["non-matching, gamma3", "matching, sigma1", "fine upper, sigma2", "fine lower, sigma1"]


@pytest.mark.parametrize("method", ["condensed", "full"])
@pytest.mark.parametrize("counts, condition", CASES, ids=CASE_IDS)
def test_two_squeezed_blocks_and_the_law_are_springs_in_series(counts, condition, method):
    """Exact on non-matching faces under gamma3 (each trace basis function is quadratic on every overlay
    triangle, which the quadrature integrates exactly) and under the nodal rows of the finer (or either
    matching) side: lambda = p, u_z = -p z / c33 below, p (1 - z) / c33 above; the interface route (both
    bodies held by their rollers) with its Newton finish."""
    k, delta = 1e12, 1e-5
    sol = cc.solve(squeezed_blocks(*counts, delta), condition, degree=2, method=method,
                   law=cc.NormalCompliance(stiffness=k))
    p = delta / (1 / k + 1 / C33)
    assert sol.ok and sol.polished and sol.method == method
    assert np.abs(sol.contact.lam / p - 1).max() < 1e-12                         # measured <= 2.8e-14
    (u1, u2), (x1, x2) = sol.u, sol.points
    scale = p / C33
    assert np.abs(u1[:, 2] + p * x1[:, 2] / C33).max() < 1e-12 * scale          # measured <= 2.1e-15
    assert np.abs(u2[:, 2] - p * (1 - x2[:, 2]) / C33).max() < 1e-12 * scale    # measured <= 2.0e-15
    assert max(np.abs(u1[:, :2]).max(), np.abs(u2[:, :2]).max()) < 1e-12 * scale  # measured <= 3.5e-16
    assert abs(sol.contact.force.sum() / p - 1) < 1e-13                          # area 1 m^2; measured <= 4.1e-15


@pytest.mark.parametrize("counts, condition", CASES, ids=CASE_IDS)
def test_a_stiffening_law_between_squeezed_blocks_is_springs_in_series(counts, condition):
    """The patch test with p = k r^2 at the quadrature points (matching and non-matching faces): the interference
    splits into the law's r and the blocks' p / c33, delta = r + k r^2 / c33 (closed form r = (sqrt(1 + 4 k delta
    / c33) - 1) c33 / (2 k)); lambda = p at every node, u the uniaxial fields."""
    k, delta = 1e12 / 5e-6, 1e-5
    sol = cc.solve(squeezed_blocks(*counts, delta), condition, degree=2, law=cc.NormalCompliance(stiffness=k, exponent=2))
    r = (np.sqrt(1 + 4 * k * delta / C33) - 1) * C33 / (2 * k)
    p = k * r ** 2
    assert sol.ok and sol.polished
    assert np.abs(sol.contact.lam / p - 1).max() < 1e-12                              # measured <= 1.1e-14
    (u1, u2), (x1, x2) = sol.u, sol.points
    assert np.abs(u1[:, 2] + p * x1[:, 2] / C33).max() < 1e-12 * p / C33              # measured <= 1.5e-15
    assert np.abs(u2[:, 2] - p * (1 - x2[:, 2]) / C33).max() < 1e-12 * p / C33        # measured <= 1.6e-15


@pytest.mark.parametrize("counts, condition", CASES[:3], ids=CASE_IDS[:3])
def test_a_block_held_by_the_law_on_another_is_springs_in_series(counts, condition):
    """The upper block held along z by the contact only (rollers on its sides), pressed by p: the lower in
    uniaxial strain, the upper shifted down by r = p/k more (the sparse route and its Newton finish)."""
    k = 1e12
    sol = cc.solve(stacked_blocks(*counts, nz=1), condition, degree=2, law=cc.NormalCompliance(stiffness=k))
    assert sol.ok and sol.polished
    assert series_error(sol, k, shift=(0.0, P / k)) < 1e-12                     # measured <= 3.5e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-12                         # measured <= 1.2e-14
    assert abs(sol.contact.force.sum() / P - 1) < 1e-13                          # measured <= 1.3e-15
    for body in (0, 1):
        assert np.abs(sol.traction(body)[1] / P - 1).max() < 1e-12               # measured <= 9.1e-15


def test_the_coarser_sides_rows_on_non_matching_faces_are_not_exact():
    """As for Signorini (docs/formulation.md §15): the coarser side's rows do not see the finer side's kinks,
    the patch test fails (the exact tests above can fail)."""
    sol = cc.solve(stacked_blocks((2, 2), (3, 3), nz=1), "sigma1", degree=2, law=cc.NormalCompliance(stiffness=1e12))
    assert sol.ok and series_error(sol, 1e12, shift=(0.0, P / 1e12)) > 1e-2       # measured 0.21


# ---------------------------------------------------------------------------------------------------------
# P1 on refined meshes, k -> infinity

def bumped_pair(n=1, load=2e7):
    """Two blocks meeting at z = 0.5 with the gap 0.2 r^2 mm, the lower clamped, the upper (rollers on two
    sides, held along z by the contact) pressed by ``load`` on its top; 4n x 4n and 5n x 3n cells across."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=4 * n, ny=4 * n, nz=n)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=5 * n, ny=3 * n, nz=n)
    b1 = cc.Body(low, STEEL, clamped="bottom", contact="top", name="lower")
    b2 = cc.Body(up, STEEL, roller=["left", "front"], contact="bottom", name="upper", traction={"top": (0, 0, -load)})
    return cc.Scene(b1, b2, gap=bumped_gap)


def test_p1_on_refined_meshes_tends_to_the_p2_answer():
    """The energy of the P1 answers on 1x and 2x refined meshes approaches the P2 one on the coarse mesh
    (gamma3, k = 1e12 Pa/m: a contact zone inside the faces), the distance shrinking like h^2 (measured
    115.6, 33.0 J: ratio 3.5), the energies decreasing with refinement and P2 the lowest."""
    law = cc.NormalCompliance(stiffness=1e12)
    p2 = cc.solve(bumped_pair(1), "gamma3", degree=2, law=law)
    p1 = [cc.solve(bumped_pair(n), "gamma3", degree=1, law=law) for n in (1, 2)]
    assert p2.ok and p2.polished and all(s.ok and s.polished for s in p1)
    d = [s.energy - p2.energy for s in p1]
    assert d[0] > d[1] > 0 and d[0] / d[1] > 2.5                                  # measured 115.6, 33.0 J
    assert d[1] < 0.02 * abs(p2.energy)                                           # measured 9e-3
    assert abs(p1[1].contact.lam.max() / p2.contact.lam.max() - 1) < 0.02         # measured 2.7e-3


H, DELTA = 0.5, 1e-5


def dent(x, y):
    """A gap of -DELTA plus a shallow bowl (m): a rigid plane pressed into the whole top face, unevenly."""
    return 0.2 * DELTA * ((np.asarray(x) - .4) ** 2 + (np.asarray(y) - .55) ** 2) - DELTA


def pressed_block(law=None, gap=dent, n=2):
    """A block (0, 1)^2 x (0, H) m clamped at its bottom, rollers on its sides, its top against the rigid plane
    z = H with the gap ``gap`` (m) under ``law`` (the interface route: the block is held by its supports)."""
    mesh = cc.box(x=(0, 1), y=(0, 1), z=(0, H), nx=n, ny=n, nz=1)
    body = cc.Body(mesh, STEEL, clamped="bottom", roller=SIDES, contact="top", name="block")
    obstacle = cc.Rigid.plane((0, 0, H), (0, 0, -1))
    return cc.Scene(body, contacts=[cc.Contact(body, "top", obstacle, gap=gap, law=law)])


def test_a_stiffening_law_tends_to_the_everywhere_signorini_answer():
    """A rigid plane pressed into the whole face (full contact): as k grows from 1e6 to 1e12 c33/H the answer
    tends to the Signorini "gamma3" one (r = 0 on the whole face) at rate 1/k, under either condition (against an
    obstacle both integrate the law over the same faces): measured 1.04e-6, 1.04e-7, 1.04e-8, 1.04e-10, 1.04e-12
    of max|u|, rates 1.0000 per decade (1.00007 from 1e10 to 1e12, where the error is rounding). It does not tend to the Signorini "sigma1" answer, which lifts a vertex
    off the plane (a consistent P2 vertex force would be negative there: 5.1e-2 of max|u| apart; the vertex rows
    of weight 0 of the nodal quadrature let the old law find neither). Exact finish and ``ok`` throughout, no
    warning: the law's check is scaled by its own term w p'(r) U (docs/checks.md; scaled by the force alone it
    read 5.0e-6 at 1e10, ``ok`` False), the pressure read from the finish's force; equilibrium and law measured
    <= 1.3e-16 and <= 3.1e-16 from 1e6 to 1e14."""
    gamma3 = cc.solve(pressed_block(), "gamma3", degree=2)
    sigma1 = cc.solve(pressed_block(), "sigma1", degree=2)
    assert gamma3.ok and sigma1.ok
    r = gamma3.contact.jump - gamma3.contact.gap
    assert np.abs(r).max() < 1e-12 * DELTA                                              # measured 6.8e-21 m
    scale = float(np.abs(gamma3.u[0]).max())

    def err(sol):
        return float(np.abs(sol.u[0] - gamma3.u[0]).max()) / scale

    assert err(sigma1) > 1e-2                                                           # measured 5.1e-2
    kappas = np.array([1e6, 1e7, 1e8, 1e10, 1e12])
    for condition in ("gamma3", "sigma1"):
        errors = []
        for kappa in kappas:
            with warnings.catch_warnings():
                warnings.simplefilter("error", ResidualWarning)
                sol = cc.solve(pressed_block(cc.NormalCompliance(stiffness=kappa * C33 / H)), condition, degree=2)
            assert sol.polished and sol.ok
            res = sol.residuals()
            assert res["equilibrium"] < 1e-13 and res["law"] < 1e-13       # measured <= 1.3e-16, <= 3.1e-16
            errors.append(err(sol))
        errors = np.array(errors)
        assert errors[0] < 1e-4 and errors[-1] < 1e-10                  # measured 1.04e-6 (1e6), 1.04e-12 (1e12)
        rates = np.log10(errors[:-1] / errors[1:]) / np.log10(kappas[1:] / kappas[:-1])
        assert (np.abs(rates[:3] - 1) < 2e-4).all()                                     # measured |rate - 1| <= 1.2e-6
        assert abs(rates[3] - 1) < 1e-2                          # 1e10 -> 1e12, the error at rounding: measured 6.5e-5


def corner_gap(x, y):
    """A plane that reaches below the face only near the corner (1, 1): gap -DELTA at that vertex, >= DELTA/4 at
    every other P2 node of the 2 x 2 face (m)."""
    return 5 * DELTA * (2 - np.asarray(x) - np.asarray(y)) - DELTA


def dunavant():
    """The 6-point degree-4 rule on a triangle from its closed form (Strang and Fix; Dunavant 1985): barycentrics
    (6, 3) and weights (6,) summing to 1."""
    s10, root = np.sqrt(10.0), np.sqrt(38.0 - 44.0 * np.sqrt(0.4))
    a, b = (8.0 - s10 + root) / 18.0, (8.0 - s10 - root) / 18.0
    L = np.array([[1 - 2 * a, a, a], [a, 1 - 2 * a, a], [a, a, 1 - 2 * a],
                  [1 - 2 * b, b, b], [b, 1 - 2 * b, b], [b, b, 1 - 2 * b]])
    root_w = np.sqrt(213125.0 - 53320.0 * s10)
    return L, np.repeat([(620.0 + root_w) / 3720.0, (620.0 - root_w) / 3720.0], 3)


def triangle6(L):
    """(k, 6) the quadratic Lagrange functions of the triangle (v0, v1, v2, m01, m12, m20) at barycentrics L."""
    l0, l1, l2 = L.T
    return np.column_stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2,
                            4 * l2 * l0])


def test_the_face_rule_has_positive_weights_and_degree_four():
    """P2_FACE_RULE (tabulated to 15 decimals) against the rule's closed form and exact monomial integrals on a
    random triangle (int L^a = 2 A a! / (|a| + 2)!): exact to degree 4 up to its decimals, not to degree 5; its
    weights times the P2 functions at its points are the P2 basis integrals (the mass-matrix row sums: 0 at the
    vertices). Bounds from the 15 decimals: each constant within 5e-16 (plus rounding), so a monomial of degree
    <= 4 (|f| <= 1, |grad f| <= 4 in barycentrics) within 6 (5e-16 + 4 * 2 * 5e-16) < 3e-14 of its integral."""
    rng = np.random.default_rng(5)
    V = rng.random((3, 2))
    (a, b), (c, d) = V[1] - V[0], V[2] - V[0]
    A = 0.5 * abs(a * d - b * c)
    L, w = P2_FACE_RULE
    Lc, wc = dunavant()
    assert np.abs(L - Lc).max() < 1e-15 and np.abs(w - wc).max() < 1e-15     # the 15 decimals; measured 5.6e-16
    assert (w > 0).all() and abs(w.sum() - 1) < 1e-14 and (L > 0).all()               # measured 1.0e-15
    for total in range(5):
        for i in range(total + 1):
            for j in range(total + 1 - i):
                e = (i, j, total - i - j)
                exact = 2 * A * np.prod([factorial(t) for t in e]) / factorial(total + 2)
                assert abs(A * w @ np.prod(L ** np.array(e), axis=1) - exact) < 3e-14 * A   # measured <= 1.0e-15 A
    assert abs(A * w @ L[:, 0] ** 5 - 2 * A * factorial(5) / factorial(7)) > 1e-5 * A             # measured 2.5e-4 A
    np.testing.assert_allclose(w @ p2_shape(L), P2_TRIANGLE_MASS.sum(axis=1), rtol=0, atol=3e-14)  # measured 1e-15


def test_a_vertex_pushed_into_the_obstacle_is_resisted_as_the_quadrature_energy_says():
    """The plane reaches below the face only near one vertex (corner_gap): the law at the quadrature points
    resists it with a positive force (the nodal quadrature, weight 0 at vertices, gave u = 0 and no force), and
    the answer is the minimiser of the energy built here independently: the block's stiffness (package
    assembly, not under test), the tabulated 6-point rule on each top face, the quadratic Lagrange functions
    written out above at the rule's closed-form points, the gap evaluated there; minimised by semismooth Newton (dense). u agrees to
    1e-9 (measured 5.2e-15 of max|u|), and the vertex still penetrates, by less than DELTA (0.85 DELTA)."""
    from cvxcontact.fem.space import space

    k = C33 / H
    scene = pressed_block(cc.NormalCompliance(stiffness=k), gap=corner_gap)
    sol = cc.solve(scene, "sigma1", degree=2)
    assert sol.ok and sol.polished
    # the independent energy 1/2 u^T K u + sum_q w_q k/2 (u_z(x_q) - g(x_q))_+^2 on the free dofs
    body = scene.bodies[0]
    P2 = space(2, "tetra")
    nodes = P2.nodes(body)
    S = P2.assemble_matrices(body, nodes)
    T = S.Tu.toarray()
    K = T.T @ S.Kuu.toarray() @ T
    faces = nodes.boundary("top")
    x = nodes.points
    L, w = dunavant()
    N = triangle6(L)
    B = np.zeros((len(faces) * len(w), 3 * len(x)))
    gq, wq = [], []
    for f, face in enumerate(faces):
        (x0, y0), (x1, y1), (x2, y2) = x[face[:3], :2]
        area = 0.5 * abs((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0))
        xy = L @ x[face[:3], :2]
        B[f * len(w):(f + 1) * len(w), 3 * face + 2] = N                  # u_z: the top's outward normal is +z
        gq.append(corner_gap(xy[:, 0], xy[:, 1]))
        wq.append(area * w)
    gq, wq = np.concatenate(gq), np.concatenate(wq)
    G = B @ T
    z = np.zeros(K.shape[0])
    for _ in range(50):
        r = G @ z - gq
        on = r > 0
        step = np.linalg.solve(K + G[on].T @ (k * wq[on, None] * G[on]), K @ z + G.T @ (k * wq * np.maximum(r, 0)))
        z -= step
        if np.abs(step).max() <= 1e-15 * np.abs(z).max():
            break
    u = (T @ z).reshape(-1, 3)
    assert np.abs(u).max() > 0
    assert np.abs(sol.u[0] - u).max() < 1e-9 * np.abs(u).max()                        # measured 5.2e-15
    force = float(wq @ (k * np.maximum(G @ z - gq, 0)))
    assert force > 0 and abs(sol.obstacles[0].force[2] + force) < 1e-9 * force       # 11149 N; measured 2.8e-15
    corner = np.flatnonzero((np.abs(sol.contact.points - [1, 1, H]) < 1e-12).all(axis=1))
    penetration = (sol.contact.jump - sol.contact.gap)[corner]
    assert 0 < penetration[0] < DELTA                                                 # measured 0.85 DELTA


# ---------------------------------------------------------------------------------------------------------
# a penetration limit (at the quadrature points)

def test_a_binding_penetration_limit_holds_the_layer_at_the_limit_with_lambda_p():
    """A limit l = r/2 below the law's penetration r = p/k: the layer sits at u_z(0) = -l, the law carries
    p(l) and the limit's reaction the rest; lambda_h, the Riesz representer of the row forces w p(l) + z at the
    quadrature points, reads p at every node (vertices included) and the checks hold (the sparse route: the
    layer is held by the law; the limit rows, six per triangle, are finished as dependent rows)."""
    k = 1e12
    ell = 0.5 * P / k
    law = cc.NormalCompliance(stiffness=k, penetration_limit=ell)
    sol = cc.solve(layer_on_plane(n=(2, 2, 1)), "sigma1", degree=2, law=law)
    assert sol.ok and sol.polished
    assert series_error(sol, k, shift=(ell,)) < 1e-12                              # measured 8.3e-16
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-12                          # measured 4.4e-15
    np.testing.assert_allclose(sol.obstacles[0].force, [0, 0, P], rtol=0, atol=1e-12 * P)


@pytest.mark.parametrize("method", ["condensed", "full"])
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_a_binding_penetration_limit_between_squeezed_blocks(condition, method):
    """The squeezed blocks with l = r/2: the penetration is l, the blocks take the rest of the interference,
    p = (delta - l) c33 / 1 m, and lambda_h = p at every node (the interface route, active-set finish)."""
    k, delta = 1e12, 1e-5
    r = delta / (1 / k + 1 / C33) / k
    ell = 0.5 * r
    law = cc.NormalCompliance(stiffness=k, penetration_limit=ell)
    counts = ((4, 4), (2, 2)) if condition == "sigma1" else ((2, 2), (4, 4))       # the finer side's rows
    sol = cc.solve(squeezed_blocks(*counts, delta), condition, degree=2, law=law, method=method)
    p = (delta - ell) * C33
    assert sol.ok and sol.polished and sol.method == method
    assert np.abs(sol.contact.lam / p - 1).max() < 1e-12                         # measured <= 3.4e-14
    (u1, u2), (x1, x2) = sol.u, sol.points
    assert np.abs(u1[:, 2] + p * x1[:, 2] / C33).max() < 1e-12 * p / C33          # measured <= 1.2e-15
    assert np.abs(u2[:, 2] - p * (1 - x2[:, 2]) / C33).max() < 1e-12 * p / C33    # measured <= 1.2e-15


def test_a_limit_that_does_not_bind_changes_nothing():
    k = 1e12
    free = cc.solve(bumped_pair(1), "sigma1", degree=2, law=cc.NormalCompliance(stiffness=k))
    limited = cc.solve(bumped_pair(1), "sigma1", degree=2, law=cc.NormalCompliance(stiffness=k, penetration_limit=1.0))
    assert free.ok and limited.ok and limited.polished
    for a, b in zip(free.u, limited.u):
        assert np.abs(a - b).max() < 1e-12 * np.abs(b).max()                     # measured 0


# ---------------------------------------------------------------------------------------------------------
# rows of weight 0, the piezoelectric layer, cc.Model

def test_the_lcp_finish_leaves_rows_of_weight_zero_without_force():
    """solve_linear_compliance (the finite LCP fallback) on rows some of which have weight 0 (P2 face vertices):
    y = 0 there, and the same (y, r) as the Newton finish solve_compliance (another algorithm) on a random
    positive definite interface compliance with Signorini and compliance rows mixed."""
    from cvxcontact.backends.finish import solve_compliance, solve_linear_compliance
    from cvxcontact.contact.laws import RowLaws

    rng = np.random.default_rng(7)
    n = 12
    A = rng.standard_normal((n, n))
    W = A @ A.T / n + 0.5 * np.eye(n)
    d = rng.standard_normal(n)
    w = np.where(np.arange(n) % 3 == 0, 0.0, rng.random(n) + 0.5)        # every third row: weight 0
    law = RowLaws([cc.Signorini(), cc.NormalCompliance(stiffness=3.0)], [3, n - 3])
    lcp = solve_linear_compliance(W, d, w, law)
    newton = solve_compliance(W, d, w, law)
    assert lcp is not None and newton is not None
    y = lcp[0]
    r = d - W @ y
    assert np.all(y[3:][w[3:] == 0] == 0) and np.isfinite(y).all()
    assert r[9] > 0.01                     # a compliant row of weight 0 penetrates (measured 0.023) with y = 0
    assert np.abs(y - newton[0]).max() < 1e-12 * np.abs(y).max()                   # measured 2.7e-16
    compliant = (np.arange(n) >= 3) & (w > 0)
    assert np.abs(y[compliant] - w[compliant] * 3.0 * np.maximum(r[compliant], 0)).max() < 1e-12   # the law
    assert (y[:3] >= 0).all() and (r[:3] <= 1e-12).all() and np.abs(y[:3] * r[:3]).max() < 1e-12    # Signorini


def test_a_piezoelectric_layer_through_the_law_floats_at_its_closed_form_potential():
    """The PZT-5A layer (grounded base, open-circuit top) on the plane through p = k r: shifted by p/k, strained
    by the stiffened modulus c33 + e33^2/eps33, its top electrode at the closed-form potential."""
    from scenes3d import floating_potential, pzt_layer_on_plane, stiffened_modulus

    k = 1e12
    sol = cc.solve(pzt_layer_on_plane(n=(2, 2, 1)), "sigma1", degree=2, law=cc.NormalCompliance(stiffness=k))
    c = stiffened_modulus(cc.materials.PZT5A)
    u, x = sol.u[0], sol.points[0]
    assert sol.ok and sol.polished
    assert np.abs(u[:, 2] + P / k + P * x[:, 2] / c).max() < 1e-12 * P / c            # measured 1.3e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-12                              # measured 4.4e-15
    top = [e for e in sol.electrodes if e.kind == "floating"][0]
    assert abs(top.potential / floating_potential(cc.materials.PZT5A) - 1) < 1e-12   # measured 4.4e-16


def test_the_model_poses_the_same_law():
    """cc.Model(degree=2) of the squeezed blocks under gamma3 on non-matching faces: the closed form."""
    k, delta = 1e12, 1e-5
    sol = cc.Model(squeezed_blocks((2, 2), (3, 3), delta), "gamma3", degree=2,
                   law=cc.NormalCompliance(stiffness=k)).solve()
    p = delta / (1 / k + 1 / C33)
    assert sol.ok and np.abs(sol.contact.lam / p - 1).max() < 1e-12                   # measured 8.7e-15
