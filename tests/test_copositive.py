"""The copositive "everywhere" condition of P2 tetrahedra (docs/formulation.md §16): q = [u_nu] - g_h <= 0 on
every triangle of X_h, posed as -Q = P + N (P a 3x3 positive semidefinite matrix, N >= 0 off the diagonal),
finished by accumulated cuts and certified.

Checked against things the code under test does not compute: dense sampling of quadratics, the feasibility of
the copositive constraints against the sign of a sampled maximum, a closed-form quadratic displacement field
(uniaxial strain under a body force), the jump evaluated on each body's own faces at sample points, and the
interior point's distance to the finished answer against its certified bound.
"""

import warnings

import cvxpy as cp
import numpy as np
import pytest
from scenes3d import (
    SIDES,
    STEEL,
    bumped_gap,
    pressed_blocks,
    pressed_key,
    uniaxial_modulus,
)

import cvxcontact as cc
from cvxcontact.backends.conic import copositive_constraints
from cvxcontact.contact.bernstein import SEGMENT, TRIANGLE, bernstein_argmax
from cvxcontact.contact.quadratic3d import locate, p2_shape
from cvxcontact.fem.space import space
from cvxcontact.geometry.quadratic import P2TetNodes

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def simplex_grid(n) -> np.ndarray:
    """Barycentric points of the triangle with spacing 1/n ((n+1)(n+2)/2, 3)."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    m = i + j <= n
    return np.column_stack([i[m], j[m], n - i[m] - j[m]]) / n


# --- the triangle's quadratic -------------------------------------------------------------------------------

def test_the_maximum_on_a_triangle_is_exact_against_dense_sampling():
    b = np.random.default_rng(3).standard_normal((300, 6))
    q, L = TRIANGLE.argmax(b)
    assert np.abs((TRIANGLE.basis(L) * b).sum(axis=1) - q).max() < 1e-14          # measured 2.2e-16
    assert (L >= 0).all() and np.allclose(L.sum(axis=1), 1.0)
    for n, loose in ((100, 5e-4), (800, 1e-5)):                                    # the samples converge to it
        sampled = (TRIANGLE.basis(simplex_grid(n)) @ b.T).max(axis=0)
        assert (sampled <= q + 1e-14).all()                                       # never above it (measured 0)
        assert (q - sampled).max() < loose                                        # measured 1.2e-4, 2.3e-6
    # on an edge (the third vertex far below) it is the segment's maximum
    edge = np.column_stack([b[:, 0], b[:, 1], np.full(300, -1e3), b[:, 3], np.full(300, -1e3), np.full(300, -1e3)])
    assert np.allclose(TRIANGLE.argmax(edge)[0], SEGMENT.argmax(b[:, [0, 3, 1]])[0], rtol=0, atol=1e-14)
    assert np.allclose(bernstein_argmax(b[:, :3])[0], SEGMENT.argmax(b[:, :3])[0])


def test_the_bernstein_coefficients_of_nodal_values():
    b = np.random.default_rng(4).standard_normal((50, 6))
    nodal = TRIANGLE.basis(TRIANGLE.nodes) @ b.T                  # the quadratic at the six P2 nodes
    assert np.abs(TRIANGLE.to_bernstein @ nodal - b.T).max() < 1e-14
    L = simplex_grid(7)                                           # and the Lagrange form agrees with Bernstein
    assert np.abs(p2_shape(L) @ nodal - TRIANGLE.basis(L) @ b.T).max() < 1e-13


def test_a_point_force_is_on_the_dual_cone_and_its_tangency_point_is_read_back():
    rng = np.random.default_rng(5)
    L = rng.dirichlet(np.ones(3), 40)
    y = rng.uniform(0.5, 2.0, 40)
    beta = y[:, None] * TRIANGLE.basis(L)                          # Z = y L L^T: completely positive
    assert np.allclose(beta.sum(axis=1), y)
    assert TRIANGLE.dual_cone_violation(beta).max() < 1e-15       # measured 1.2e-16
    assert np.abs(TRIANGLE.tangency(beta) - L).max() < 1e-10      # measured 2.2e-16
    outside = rng.standard_normal((40, 6))
    inside = TRIANGLE.dual_cone_point(outside)
    assert TRIANGLE.dual_cone_violation(outside).max() > 0.1
    assert TRIANGLE.dual_cone_violation(inside).max() < 1e-14 * np.abs(outside).max()     # measured 1.0e-16
    assert np.abs(TRIANGLE.dual_cone_point(beta) - beta).max() < 1e-14            # a cone point stays (8.9e-16)


@pytest.mark.parametrize("seed", range(4))
def test_the_copositive_constraints_are_feasible_exactly_when_the_quadratic_is_non_positive(seed):
    # one triangle at a time, its quadratic shifted to a sampled maximum of +-0.05: the program -Q = P + N must
    # be feasible iff q <= 0 on the triangle (the order of the coefficients in the PSD matrix matters here)
    rng = np.random.default_rng(seed)
    samples = TRIANGLE.basis(simplex_grid(200))
    for _ in range(4):
        b = rng.standard_normal(6)
        top = (samples @ b).max()
        for margin, feasible in ((-0.05, True), (0.05, False)):
            shifted = b - (top - margin) * np.array([1, 1, 1, 1, 1, 1.0])     # q - c: every coefficient - c
            eq, row, _ = copositive_constraints(cp.Constant(shifted), 1)
            prob = cp.Problem(cp.Minimize(0), [eq, row])
            prob.solve(solver="CLARABEL")
            assert (prob.status == cp.OPTIMAL) == feasible, (seed, margin, prob.status)


# --- scenes ------------------------------------------------------------------------------------------------


def solve(scene, condition="gamma3", **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")                    # no solver warning on these scenes; the resolution
        warnings.simplefilter("ignore", cc.ResolutionWarning)   # check says what it should: a bowl-shaped zone
        return cc.solve(scene, condition, degree=2, **kw)       # of 3 faces on these 2 x 2 x 2 test meshes


def shared_pressed(shared):
    """:func:`solve` of ``pressed_blocks()`` (its warnings errors but the ResolutionWarning), solved once in a run
    (conftest's ``shared``, :func:`scenes3d.pressed_key`: the same answer read by several modules)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        return shared(*pressed_key())


def sampled_penetration(scene, sol, n=12):
    """max over sample points of every overlay triangle of ([u_nu] - g) / (d scale), the jump evaluated from
    each body's own P2 face functions at the point (not through X_h) and the scene's gap function itself (a
    quadratic: its P2 interpolant on a triangle is itself)."""
    itf = space(2, "tetra").contact(scene, "sigma1", cc.Signorini()).interface
    ov = itf.linear.overlay
    V = np.asarray(ov.vertices)
    L = simplex_grid(n)
    x = np.einsum("pk,tkd->tpd", L, V[np.asarray(ov.triangles)]).reshape(-1, 2)     # in-plane points
    jump = np.zeros(len(x))
    for k, trace in enumerate(itf.traces):
        tri, bary = locate(x, np.asarray(trace.x), np.asarray(trace.faces)[:, :3])
        assert (tri >= 0).all()
        face = np.asarray(trace.nodes)[np.asarray(trace.faces)[tri]]                  # body node indices (p, 6)
        u = np.einsum("pk,pkd->pd", p2_shape(bary), sol.u[k][face])
        jump += u @ np.asarray(trace.unit_normal)
    points = itf.offset * np.asarray(itf.normal) + x @ np.asarray(itf.frame)
    g = bumped_gap(points[:, 0], points[:, 1])
    return float((jump - g).max()) / 2e-5


def test_pressed_blocks_hold_everywhere_where_the_nodal_conditions_penetrate(shared):
    scene = pressed_blocks()
    sol = shared_pressed(shared)
    assert sol.ok and sol.info.status == "optimal"
    r = sol.residuals()
    assert r["equilibrium"] < 1e-12 and r["feasibility"] < 1e-12 and r["cone"] < 1e-12   # 1.1e-16, 1.3e-15, 1e-17
    assert r["complementarity"] < 1e-6 and r["energy error"] < 1e-6                  # 3.7e-8, 1.6e-8
    assert sampled_penetration(scene, sol) < 1e-10                                    # measured -4.8e-5 (max)
    nodal = [sampled_penetration(scene, solve(scene, c)) for c in ("sigma1", "sigma2")]
    assert min(nodal) > 1e-2, nodal           # measured 0.14, 0.20: the nodal answers penetrate between nodes
    assert sol.contact.force.sum() > 0


def energy_norms(scene, fields):
    """sqrt(sum_k v_k^T Kuu_k v_k) (SI, Kuu on all dofs from an assembly of its own) of each list of per-body
    displacement fields v_k (n_k, 3): differences of two answers, or an answer minus its prescribed part."""
    Kuu = [space(2, "tetra").assemble_matrices(b).Kuu for b in scene.bodies]
    return [np.sqrt(sum(float(v.ravel() @ (K @ v.ravel())) for K, v in zip(Kuu, f))) for f in fields]


def free_part(scene, u):
    """u - u_D of each body (the energy norm of the answer the certified bound is relative to)."""
    return [uk - space(2, "tetra").assemble_matrices(b).u_fixed.reshape(uk.shape) for b, uk in zip(scene.bodies, u)]


def test_full_and_condensed_routes_and_the_certified_bound():
    # every answer is within its certified bound of the exact one (relative energy norm), so any two are within
    # the sum of their bounds of each other: a check of the bound that needs no exact solution
    scene = pressed_blocks()
    cond, full = solve(scene, method="condensed"), solve(scene, method="full")
    with warnings.catch_warnings():
        # the interior point's answer, unfinished: where it stops depends on the machine's arithmetic (its
        # complementarity 4.4e-6 under OPENBLAS_CORETYPE=Sandybridge on an AVX-512 CPU, above the default tol: a
        # ResidualWarning); what is checked here is its certified bound, not where it stopped
        warnings.simplefilter("ignore", cc.ResidualWarning)
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        raw = cc.solve(scene, "gamma3", degree=2, method="condensed", polish=False)
    bound = {k: s.residuals()["energy error"] for k, s in (("cond", cond), ("full", full), ("raw", raw))}
    # measured 1.6e-8, 1.6e-8 and 3.9e-7 (raw; 1.8e-6 under Sandybridge on an AVX-512 CPU)
    assert bound["cond"] < 1e-7 and bound["full"] < 1e-7 and bound["raw"] < 2e-4
    d_routes, d_raw, norm = energy_norms(scene, [[a - b for a, b in zip(cond.u, full.u)],
                                                 [a - b for a, b in zip(raw.u, cond.u)], free_part(scene, cond.u)])
    assert d_routes / norm <= 1.01 * (bound["cond"] + bound["full"])          # measured 2.4e-9 against 3.2e-8
    assert d_raw / norm <= 1.01 * (bound["cond"] + bound["raw"])              # measured 2.7e-9 against 4.0e-7


def test_a_quadratic_patch_is_reproduced_exactly():
    # uniaxial strain under a body force b: u = (0, 0, w(z)), w quadratic in each block, the contact pressure
    # p = M (d - g0) uniform (the body force cancels): P2 holds w exactly, the copositive condition with
    # non-matching faces gives it to rounding and lambda_h = p at every node of X_h
    M, d, g0, b = uniaxial_modulus(), 2e-5, 1e-6, -4e6
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=3, ny=3, nz=1)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=4, ny=2, nz=1)
    b1 = cc.Body(low, STEEL, roller=SIDES + ["bottom"], contact="top", body_force=(0, 0, b), name="lower")
    b2 = cc.Body(up, STEEL, roller=SIDES, displacement={"top": (None, None, -d)}, contact="bottom",
                 body_force=(0, 0, b), name="upper")
    sol = solve(cc.Scene(b1, b2, gap=g0))
    p = M * (d - g0)                  # sigma_zz(z) = -p - b (z - 1/2) in both blocks

    def w_lower(z):                   # w(0) = 0, w' = sigma / M
        return (-p * z - b * (z ** 2 / 2 - z / 2)) / M

    def w_upper(z):                   # w(1) = -d
        return -d - (-p * (1 - z) - b * (0.125 - (z - 0.5) ** 2 / 2)) / M

    for k, (mesh, w) in enumerate(((low, w_lower), (up, w_upper))):
        z = P2TetNodes(mesh).points[:, 2]
        exact = np.zeros_like(sol.u[k])
        exact[:, 2] = w(z)
        assert np.abs(sol.u[k] - exact).max() < 1e-9 * d, (k, np.abs(sol.u[k] - exact).max() / d)
    assert np.abs(sol.contact.lam - p).max() < 1e-9 * p, np.abs(sol.contact.lam - p).max() / p


def test_blocks_held_by_the_contact_are_finished_on_the_mixed_system():
    # the upper block has only rollers on its sides (held by the contact): no interface compliance, so the
    # cuts' rounds are solved on the sparse mixed system (26); the uniaxial patch is then exact
    from scenes3d import P, stacked_blocks

    scene = stacked_blocks((3, 3), (4, 2), nz=1)
    sol = solve(scene)
    assert sol.ok and sol.polished and sol.info.finish == "accumulated cuts"
    M = uniaxial_modulus()
    for k, body in enumerate(scene.bodies):
        z = P2TetNodes(body.mesh).points[:, 2]
        assert np.abs(sol.u[k][:, 2] + P * z / M).max() < 1e-12 * P / M       # measured 1.3e-14, 1.5e-14
    assert np.abs(sol.contact.lam - P).max() < 1e-9 * P                       # measured 1.3e-11


def test_the_condition_sampled_at_more_points_converges_to_the_copositive_answer(shared):
    # an independent program: the nodal condition at the points of a grid of spacing 1/m on every triangle of
    # X_h (linear rows, dependent; the exact finish of dependent rows), m = 2 (the P2 nodes), 4, 8, 16; its
    # answer is a relaxation that tends to the copositive one
    from cvxcontact.backends import signorini
    from cvxcontact.backends.cuts import unique_rows
    from cvxcontact.backends.result import Cache, Settings
    from cvxcontact.contact.bernstein import point_rows
    from cvxcontact.solve import ContactSolver

    scene = pressed_blocks()
    conic = shared_pressed(shared)
    problem = ContactSolver(scene, "gamma3", degree=2).problem
    B = problem.lines.cone[0]
    T = B.shape[0] // 6
    distance = []
    for m in (2, 4, 8, 16):
        L = simplex_grid(m)
        P = point_rows(B, np.repeat(np.arange(T), len(L)), np.tile(L, (T, 1)))
        raw = signorini.full(problem.with_rows(P[unique_rows(P)]), Cache(), Settings(), {})
        assert raw.polished
        u = [(s.u_fixed + s.Tu @ (uk * problem.units.displacement)).reshape(-1, 3)
             for s, uk in zip(problem.systems, raw.u)]
        d, n = energy_norms(scene, [[a - b for a, b in zip(u, conic.u)], free_part(scene, conic.u)])
        distance.append(d / n)
    rates = np.log2(np.array(distance[:-1]) / np.array(distance[1:]))
    assert (rates > 0.9).all() and distance[-1] < 1.5e-3, distance   # measured 1.0e-2, 5.1e-3, 2.2e-3, 9.0e-4


def test_nnls_from_a_warm_start_with_more_columns_than_rows():
    # the cuts' least squares warm started with more positive forces than the factor has rows (a singular
    # compliance: rank below the number of points) against SciPy's own NNLS: the same residual
    from scipy.optimize import nnls

    from cvxcontact.backends.cuts import nnls_warm

    rng = np.random.default_rng(7)
    A, b = rng.standard_normal((4, 9)), rng.standard_normal(4)
    y, passive = nnls_warm(A, b, np.ones(9), lambda y: np.ones(9))
    ref, _ = nnls(A, b)
    assert (y >= 0).all() and passive.sum() <= 4
    assert abs(np.linalg.norm(A @ y - b) - np.linalg.norm(A @ ref - b)) < 1e-12     # measured 0 to 1e-16


def test_a_block_pressed_by_a_fixed_sphere_is_finished():
    # the copositive condition on the block's P2 faces that reach the sphere (g_h: the P2 interpolant of the
    # distance); its cuts' least squares once cycled on one column (added and dropped at once) until max_iter
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=10, ny=10, nz=5)
    body = cc.Body(mesh, STEEL, clamped="bottom", contact="top", name="block")
    scene = cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere((0, 0, 1.0 - 2e-3), 1.0))])
    sol = solve(scene)
    assert sol.ok and sol.polished and sol.info.finish in ("accumulated cuts", "tangency Newton")
    r = sol.residuals()
    assert r["feasibility"] < 1e-12 and r["energy error"] < 1e-5          # measured 0, 2.6e-7


@pytest.mark.parametrize("name", ["layer on a rigid plane, gamma3", "PZT-5A layer, floating electrode",
                                  "punch on a patch"])
def test_canonical_scenes_held_by_the_contact_are_finished(name):
    # canonical 3D scenes (tests/scenes3d.py) whose bodies the contact holds, under P2 "gamma3": the cuts on
    # the mixed system, then Newton at the tangency points from their answer (the punch's patch touches at
    # points; the layers' whole faces in contact on triangles settle there since the flat tangencies become
    # whole faces in one round: before, one a round, the rounds ran out and the cuts' answer stayed); the
    # layers' uniaxial patch (closed form in scenes3d) is then exact
    from scenes3d import SCENES3D

    build, kw = SCENES3D[name]
    sol = solve(build(), kw["condition"])
    assert sol.ok and sol.polished and sol.info.finish == "tangency Newton", sol.report()
    assert sol.residuals()["complementarity"] < 1e-7                       # measured 0 ... 2.5e-8


def test_the_pressure_of_a_3d_p2_solution_is_lambda_h(shared):
    # (it raised a broadcast error: the 1D P2 lumping applied to in-plane points)
    sol = shared_pressed(shared)
    assert np.array_equal(sol.contact.pressure, sol.contact.lam)
    assert sol.contact.pressure.shape == (len(sol.contact.x),)
