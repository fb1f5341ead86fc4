"""The exact finish at tangency points (cvxcontact/backends/tangency.py, docs/formulation.md §18): a
force-controlled curved rigid obstacle touching a P2 face inside an element under "gamma3", 2D and 3D.

Independent references: the derivatives of an element's maximum against finite differences and its value
against dense sampling; the same program with the condition sampled at M points of every element, solved by
an interior point (CVXPY, Clarabel), converging to the finished answer as M grows; the interior point's answer
of the conic program itself."""

import warnings
from types import SimpleNamespace

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
import pytest

import cvxcontact as cc
from cvxcontact.backends import cones, tangency
from cvxcontact.backends.full import mixed_kkt
from cvxcontact.backends.result import Cache, Settings
from cvxcontact.backends.finish.declined import Declined, Stop
from cvxcontact.backends.tangency import element_maximum
from cvxcontact.contact.bernstein import SEGMENT, TRIANGLE, point_rows

from obstacle_scenes import circle

STEEL = cc.materials.isotropic(E=2.1e11, nu=0.3)


def _q(shape, b, L):
    return shape.basis(L if shape is TRIANGLE else L[:, 1]) @ b


@pytest.mark.parametrize("shape, I", [(SEGMENT, (0, 1)), (TRIANGLE, (0, 1, 2)), (TRIANGLE, (1, 2))])
def test_the_maximum_of_an_element_and_its_derivatives(shape, I):
    # m(Q) against dense sampling of the sub-simplex, its gradient (the point row at L*) and second derivative
    # -2 (dQ L*)^T M (dQ L*) against central differences of m along random directions
    rng = np.random.default_rng(3)
    k = 2 if shape is SEGMENT else 3
    pairs = [(0, 0), (0, 1), (1, 1)] if k == 2 else [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)]
    while True:                                   # a concave Q whose maximiser lies inside the sub-simplex
        X = rng.standard_normal((k, k))
        Q = -(X @ X.T) - 0.5 * np.eye(k) + 0.3
        b = np.array([Q[i, j] for i, j in pairs])                # the Bernstein coefficients of L^T Q L
        m, L, M = element_maximum(shape, b, I)
        if np.all(L[list(I)] > 0.05):
            break
    n = 400 if k == 2 else 200
    grid = np.linspace(0, 1, n + 1)
    if len(I) == 2:
        pts = np.zeros((n + 1, k))
        pts[:, I[0]], pts[:, I[1]] = 1 - grid, grid
    else:
        a, c = np.meshgrid(grid, grid)
        keep = a + c <= 1
        pts = np.column_stack([a[keep], c[keep], 1 - a[keep] - c[keep]])
    sampled = _q(shape, b, pts).max()
    assert sampled <= m + 1e-14 and m - sampled < 1e-4 * abs(m)        # measured 2e-6 relative (grid)
    assert np.all(L[list(I)] > 0) and abs(_q(shape, b, L[None, :])[0] - m) < 1e-14
    f = lambda bb: element_maximum(shape, bb, I)[0]
    for _ in range(3):
        db = rng.standard_normal(len(b))
        h = 1e-5
        d1 = (f(b + h * db) - f(b - h * db)) / (2 * h)
        assert abs(d1 - _q(shape, db, L[None, :])[0]) < 1e-8 * max(1, abs(d1))      # measured ~1e-11
        d2 = (f(b + h * db) - 2 * m + f(b - h * db)) / h ** 2
        dQL = np.array([sum(L[j] * db[shape.index(i, j)] for j in I) for i in I])
        exact = -2 * dQL @ M @ dQL
        assert exact >= 0 and abs(d2 - exact) < 1e-4 * max(1, abs(exact))         # measured ~1e-6


def _finished(scene):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", cc.ResolutionWarning)   # point contacts on coarse meshes, on purpose
        return cc.solve(scene, "gamma3", degree=2)


def test_a_force_controlled_circle_touching_inside_a_segment_is_finished():
    # before: the cuts' round with one active point row was singular (the circle's sideways position is set by
    # the tangency), ok False with the interior point's answer
    sol = _finished(circle())
    assert sol.ok and sol.polished and sol.info.finish == "tangency Newton"
    r = sol.residuals()
    # feasibility against the circle's own distance |x - c| - R, whose evaluation rounds at eps R = 1.3e-16 m,
    # ~3e-14 of the element's scale (the interpolant's Bernstein coefficients, before, were exact: 0)
    assert r["equilibrium"] < 1e-14 and r["feasibility"] < 5e-12          # measured 5.9e-17, 3.5e-14
    assert r["complementarity"] < 1e-7 and r["obstacle balance"] < 1e-13   # measured 2.0e-8 (a square root), 4.5e-18
    F = sol.obstacles[0].force
    assert abs(F[0]) < 1e-14 * abs(F[1])                                   # measured 4.5e-18
    assert abs(sol.obstacles[0].translation[0]) > 1e-6                     # it moved sideways: 3.3e-5 m


def test_the_sampled_condition_converges_to_the_finished_answer():
    """The same program (u, the circle's translation) with "q <= 0" at M equally spaced points of every
    element, solved by an interior point at tight tolerance: its distance to the finished answer falls like
    1/M^2 (the gap between points) down to the interior point's accuracy."""
    # posed along the normal (distance="ray"), where the sequence below was measured; at the closest point the
    # sideways position converges as irregularly (tau_x 8.0, 3.2, 0.74, 0.47; u and tau_y as here)
    problem = cc.ContactSolver(circle("ray"), "gamma3", degree=2).problem
    raw = cones.full(problem, Cache(), Settings(), {})
    assert raw.finish == "tangency Newton"
    tr = list(problem.translations)
    kkt = mixed_kkt(problem.blocks, problem.E, problem.g, translations=tr)
    exact = kkt.stack((raw.u, raw.phi, None, raw.taus))
    A, F, G = kkt.matrix.tocsr(), kkt.rhs, kkt.rows.tocsr()
    B = problem.lines.cone[0]
    S = B.shape[0] // 3
    nu = len(raw.u[0])
    errors = []
    for M in (65, 129, 257, 513):
        seg, t = np.repeat(np.arange(S), M), np.tile(np.linspace(0, 1, M), S)
        P = point_rows(B, seg, t)
        x = cp.Variable(A.shape[0])
        # the circle's own gap at the points: the interpolant's plus its departure there (formulation §8)
        gp = P @ problem.g + problem.departure.at(seg, t)
        prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(x, cp.psd_wrap(A)) - F @ x), [(P @ G) @ x <= gp])
        prob.solve(solver="CLARABEL", tol_gap_abs=1e-13, tol_gap_rel=1e-13, tol_feas=1e-13)
        v = x.value
        errors.append([np.abs(v[:nu] - exact[:nu]).max() / np.abs(exact[:nu]).max(),     # u
                       *np.abs(v[nu:] - exact[nu:]) / np.abs(exact[nu:])])                # tau_x, tau_y
    errors = np.array(errors)
    # measured u 1.7e-5, 7.8e-6, 3.2e-6, 9.4e-7; tau_x 6.0, 2.5, 0.73, 0.15 (the sideways position is set
    # only to the spacing of the points around the tangency); tau_y 2.4e-5, 1.1e-5, 4.6e-6, 1.3e-6
    assert np.all(errors[1:] < 0.6 * errors[:-1]), errors
    assert errors[-1, 0] < 2e-6 and errors[-1, 1] < 0.3 and errors[-1, 2] < 3e-6, errors


def test_a_force_controlled_sphere_touching_inside_a_triangle_is_finished():
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=4, ny=4, nz=3)
    body = cc.Body(mesh, STEEL, clamped="bottom", contact="top", name="block")
    sphere = cc.Rigid.sphere((0.031, -0.017, 1.0), 1.0, force=(0, 0, -1e7))
    scene = cc.Scene(body, contacts=[cc.Contact(body, "top", sphere)])
    sol = _finished(scene)
    assert sol.ok and sol.polished and sol.info.finish == "tangency Newton"
    r = sol.residuals()
    # feasibility against the sphere's own distance (rounded at eps R), as for the circle
    assert r["equilibrium"] < 1e-14 and r["feasibility"] < 5e-12          # measured 7.4e-17, 2.4e-15
    assert r["complementarity"] < 1e-7 and r["obstacle balance"] < 1e-13   # measured 1.6e-9, 3.0e-18
    F = sol.obstacles[0].force
    assert np.abs(F[:2]).max() < 1e-14 * abs(F[2])                         # measured 2.9e-18
    t = sol.obstacles[0].translation
    assert np.abs(t[:2]).min() > 1e-5                                       # moved sideways: 1.8e-3, 6.1e-4 m
    # the interior point alone, a gross-error reference: it answers the interpolant's cones, whose slack read
    # against the sphere's own distance is positive (feasibility 1.4e-3, measured), so any tol accepts it
    ipm = cc.solve(scene, "gamma3", degree=2, polish=False, tol=1.0)
    scale = np.abs(sol.u[0]).max()
    assert np.abs(ipm.u[0] - sol.u[0]).max() < 1e-5 * scale                # measured 6.9e-8


from scenes import SCENES  # noqa: E402

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

NEWTON = {"force-controlled circle", "three blocks, P2 compliance next to a cone", "layer held, P2 conic limit"}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_every_canonical_scene_under_p2_gamma3_is_finished_at_the_default_tol(name):
    """Every canonical scene (tests/scenes.py) under degree=2, "gamma3" (a pair's own condition or law kept),
    at the default tol without warning, with an exact finish. Three needed Newton at the contact structure: a
    force-controlled circle, cones next to a compliance law (before: the interior point, ok only at tol 2e-5,
    or not at all). There the finished answer is compared with the interior point's of the same program (not
    the reference: it bounds a gross error); the references are the other tests of this module and
    tests/test_p2_mixed_laws.py (dense sampling), tests/test_p2_model_compliance.py (a closed form)."""
    build, kw = SCENES[name]
    kw = {**{k: v for k, v in kw.items() if k != "tol"}, "condition": "gamma3", "degree": 2}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", cc.ResolutionWarning)   # the finish is checked here, not the resolution
        sol = cc.solve(build(), **kw)
    assert sol.ok and sol.polished, sol.report()
    if name not in NEWTON:
        return
    assert sol.info.finish == "tangency Newton"
    r = sol.residuals()
    # the circle's feasibility is against its own distance, rounded at eps R (~3e-14 of the element's scale)
    feasible = 5e-12 if name == "force-controlled circle" else 1e-14
    assert r["equilibrium"] < 1e-14 and r["feasibility"] < feasible       # measured <= 8.3e-16; 3.5e-14, 6.7e-17
    assert r["complementarity"] < 1e-7 and r.get("law", 0.0) < 1e-12        # measured <= 2.0e-8, 9.0e-14
    ipm = cc.solve(build(), **kw, polish=False, tol=1.0)
    scale = max(np.abs(u).max() for u in sol.u)
    assert max(np.abs(a - b).max() for a, b in zip(sol.u, ipm.u)) < 1e-7 * scale   # measured 2.0e-9, 6.8e-11, 5.8e-15


def test_the_cuts_end_with_the_last_solved_round_when_a_round_is_singular():
    # new points nearly on old ones make a round's rows nearly parallel and its system singular (a free sphere's
    # patch on P2 triangles at round 11, violation 3.0e-11 after round 10): the last solved round is the answer
    # if its violation is below LAST_GOOD_TOL, else the cuts decline
    from cvxcontact.backends.cuts import LAST_GOOD_TOL, accumulate_cuts

    B = sp.csr_matrix(np.eye(3))                     # one segment, q's coefficients are the "nodal" values
    calls = []

    def solve(P, fail_at, q):
        calls.append(P.shape[0])
        if len(calls) == fail_at:
            return None
        slack = np.array(q)
        return np.zeros(P.shape[0]), slack, np.ones(3), len(calls), np.zeros(P.shape[0], dtype=bool)

    # Bernstein coefficients (-1, 1 + v, -1): q(1/2) = v / 2 is its maximum, the violation (scale 1)
    for q, expected in (((-1.0, 1.0 + 0.2 * LAST_GOOD_TOL, -1.0), 1), ((-1.0, 1.2, -1.0), None)):
        calls.clear()
        out = accumulate_cuts(B, lambda P, delta: solve(P, 2, q), np.array([0, 0, 0]), np.array([0.0, 0.5, 1.0]),
                              tol=1e-15)
        if expected is None:
            assert isinstance(out, str) and "no exact solution" in out
        else:
            assert isinstance(out, dict) and out["state"] == expected and out["violation"] <= LAST_GOOD_TOL


def test_a_free_sphere_on_a_p2_patch_is_finished():
    """The sphere of tests/scenes3d.py (force control in x, y, z) pressing a patch of P2 triangles, against the
    same sphere guided along z (x, y held): the load is symmetric, so the guide takes nothing sideways and the
    free sphere does not move sideways; both answers are the same. The contact is at 8 interior tangency points
    and on 4 edges (4 more edge maxima touch with no force: their rows depend on the others'). Finished by the
    cuts on the mixed system, then Newton at the tangency points from the cuts' answer (the cuts alone stop at
    a violation ~1e-11, the fields then 1e-6 off in energy norm; before the true slack's maximum was searched
    from every local maximum of its grid, the cuts missed an interior maximum 1e-5 above zero and the guided
    sphere's sideways reaction was 1.6e-9 of its load under Haswell kernels, 2e-5 under Nehalem). Measured
    under the Haswell, Sandybridge, Nehalem and Prescott kernel sets (the largest beside each bound)."""
    from scenes3d import STEEL as steel, sphere_on_block

    free = _finished(sphere_on_block(n=(4, 4, 2)))
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=4, ny=4, nz=2)
    body = cc.Body(mesh, steel, clamped="bottom", contact="top", name="block")
    ball = cc.Rigid.sphere((0, 0, 1.0), 1.0, force=(0, 0, -2e9), guided=(0, 0, 1))
    guided = _finished(cc.Scene(body, contacts=[cc.Contact(body, "top", ball)]))
    assert free.ok and free.polished and guided.ok and guided.polished
    assert free.info.finish == guided.info.finish == "tangency Newton"
    for sol in (free, guided):
        assert sol.residuals()["feasibility"] < 1e-12                     # measured <= 6.5e-15
    assert free.residuals()["obstacle balance"] < 1e-11                   # measured <= 6.4e-14
    # the guide's reaction: the guided sphere's sideways contact resultant, from its nodal forces along the rows
    c = guided.contacts[0]
    rows = cc.Rigid.sphere((0, 0, 1.0), 1.0).sensitivity(np.asarray(c.points), np.array([0.0, 0.0, 1.0]))
    side = (np.asarray(c.force)[:, None] * rows).sum(axis=0)
    assert np.abs(side[:2]).max() < 1e-11 * abs(side[2])                   # measured <= 5.1e-14 (of 2e9 N)
    t = free.obstacles[0].translation
    assert np.abs(t[:2]).max() < 1e-11 * abs(t[2])                         # measured <= 3.0e-14 of 5.3e-2 m
    assert np.abs(free.u[0] - guided.u[0]).max() < 1e-11 * np.abs(guided.u[0]).max()   # measured <= 1.3e-14


def _sampled_q(sol, per_segment, center, radius, y=0.5):
    """max of the true slack s = [u_nu]_h - g over ``per_segment`` + 1 points of every P2 segment of the first
    pair (a top face at height ``y``, m), and where it is reached (m): the nodal jump plus the obstacle's
    translation term (jump - reported gap + the circle's own distance at the nodes) by Lagrange interpolation on
    each segment's (start, mid, end) (not the Bernstein code), minus the distance |x - center| - radius of the
    circle (closest point, its reference position) in closed form at the points."""
    c = sol.contacts[0]
    x = np.asarray(c.x)
    x = x[:, 0] if x.ndim == 2 else x
    o = np.argsort(x)
    xs = x[o]
    dist = lambda s: np.hypot(s - center[0], y - center[1]) - radius          # noqa: E731
    q = (np.asarray(c.jump) - np.asarray(c.gap))[o] + dist(xs)               # [u_nu] + c . t at the nodes
    a, mid, b = q[0:-1:2], q[1::2], q[2::2]
    t = np.linspace(0, 1, per_segment + 1)[:, None]
    where = xs[0:-1:2] + t * (xs[2::2] - xs[0:-1:2])
    vals = a * (1 - t) * (1 - 2 * t) + b * t * (2 * t - 1) + mid * 4 * t * (1 - t) - dist(where)
    k = np.unravel_index(np.argmax(vals), vals.shape)
    return vals[k], where[k]


def test_a_circle_touching_just_beside_a_vertex_is_a_tangency():
    """A large circle (R = 3 m, F = 2 kN/m) centred 1e-3 of an element beside a vertex: the interior point's
    Bernstein duals put the point force at L = (3.7e-4, 0.99963) on one segment and (0.99919, 8.1e-4) on the
    next. With a coordinate below 1e-3 read as a vertex row the start was a single vertex row, whose Newton
    system is singular (the obstacle's two balance rows see one force): declined, ok False. The tangency at
    L = 0.999 is the answer: checked by sampling q at 4001 points of every segment."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), cc.materials.isotropic(E=7e10, nu=0.33),
                    clamped="bottom", contact="top", name="block")
    R, cx = 3.0, (13 - 1e-3) / 24
    circle = cc.Rigid.circle((cx, 0.5 + R - 1e-4), R, force=(0.0, -2e3))
    sol = _finished(cc.Scene(block, contacts=[cc.Contact(block, "top", circle)]))
    assert sol.ok and sol.polished and sol.info.finish == "tangency Newton"
    F = sol.obstacles[0].force
    assert abs(F[0]) < 1e-14 * abs(F[1])                                   # measured 5e-19
    q, x = _sampled_q(sol, 4000, (cx, 0.5 + R - 1e-4), R)
    # q touches 0 between the samples: -(half the spacing)^2 / (2 R) <= max <= 0 (the gap's curvature 1/R)
    scale = np.abs(sol.u[0]).max()                                          # 6.9e-8 m
    assert -(0.5 / 24 / 4000) ** 2 / (2 * R) - 1e-15 * scale <= q <= 1e-15 * scale, q
    assert abs(x - cx) < 2 / 24 / 4000                                # at the circle's foot, 1e-3 h from the vertex


@pytest.mark.numerics
@pytest.mark.parametrize("n", [24, 32])
def test_a_large_circle_pressed_into_p2_triangles_is_finished(n):
    """A steel block 1 x 0.5 m, clamped below, pressed 1 mm by a fixed circle of R = 10 m (examples/quad_elements.py
    under "gamma3"). Before: three points next to a seed on one segment carried forces, so the segment's cut
    (its row in their span, its true gap's constant not) was skipped by the NNLS as rounding and added again
    for 40 rounds: declined at n = 24 (violation 1.9e-8), and at n = 32 ok False (complementarity 1.4e-6).
    Checked by sampling the true slack at 4001 points of every segment against the circle in closed form."""
    R, depth = 10.0, 1e-3
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n, ny=n // 2), cc.materials.isotropic(E=2e11, nu=0.3),
                    clamped="bottom", contact="top")
    center = (0.5, 0.5 + R - depth)
    sol = _finished(cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle(center, R))]))
    assert sol.ok and sol.polished and sol.info.finish is not None   # n = 24 "accumulated cuts", 32 "tangency Newton"
    q, _ = _sampled_q(sol, 4000, center, R)
    # touching: -(half the spacing)^2 / (2 R) <= max q <= 100 eps R (the rounding of the circle's distance)
    assert -(0.5 / n / 4000) ** 2 / (2 * R) <= q <= 100 * np.finfo(float).eps * R, q   # measured 5.4e-19, 2.1e-15 m
    r = sol.residuals()
    assert r["complementarity"] < 1e-6                  # measured 4.2e-8, 1.4e-8 (the default tol's check: 1e-6)


def test_nnls_exchanges_a_dependent_column_whose_slack_is_no_rounding():
    """min 1/2 |A y - b|^2 - c.y over y >= 0 with column 2 = column 0 + column 1 and c_2 > c_0 + c_1: from the
    passive set {0, 1} column 2 lies in their span but its slack w_2 = 0.5 is no rounding. Before, it was skipped
    as dependent and (1, 1, 0) returned; the answer is the QP's (CVXPY, Clarabel)."""
    from cvxcontact.backends.cuts import nnls_warm

    A, b, c = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]), np.array([1.0, 1.0]), np.array([0.0, 0.0, 0.5])
    y, _ = nnls_warm(A, b, np.array([1.0, 1.0, 0.0]), lambda y: np.ones(3), c)
    x = cp.Variable(3, nonneg=True)
    cp.Problem(cp.Minimize(0.5 * cp.sum_squares(A @ x - b) - c @ x)).solve(solver="CLARABEL")
    assert np.abs(y - x.value).max() < 1e-6, (y, x.value)          # the QP's own accuracy (~1e-8)
    w = A.T @ (b - A @ y) + c                                      # KKT: w <= 0, w = 0 where y > 0
    assert w.max() < 1e-14 and np.abs(w[y > 0]).max() < 1e-14


def test_nnls_does_not_exchange_a_duplicate_column_on_the_dual_s_rounding():
    """Column 2 repeats column 0 with the same constant (a point row added twice: the P2 Hertz study at n = 256),
    and ``dual`` (the slack by another route) reads 1e-13 on the columns outside the passive set, rounding
    above EXCHANGE_TOL (1e-14) of their scale 1. The exchange's true gain c_2 - c_0 is 0: column 2 is left out
    as dependent. Before, columns 0 and 2 were exchanged back and forth until max_iter (None)."""
    from cvxcontact.backends.cuts import nnls_warm

    A, b, c = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), np.array([1.0, 1.0]), np.full(3, 0.1)
    calls = []

    def dual(y):
        calls.append(1)
        w = A.T @ (b - A @ y) + c
        return w + 1e-13 * (y == 0)

    out = nnls_warm(A, b, np.array([1.0, 1.0, 0.0]), lambda y: np.ones(3), c, dual=dual)
    assert out is not None
    y, passive = out
    # min 1/2 |A y - b|^2 - c.y: A y = b + (c_0, c_1) = (1.1, 1.1) (closed form), the split of 1.1 over the two
    # copies free; from the warm start all of it on column 0
    np.testing.assert_allclose(A @ y, [1.1, 1.1], rtol=1e-14)
    assert y[2] == 0.0 and list(passive) == [True, True, False]
    w = A.T @ (b - A @ y) + c                                      # KKT: w = 0 on every column (all in the span)
    assert np.abs(w).max() < 1e-14
    assert len(calls) <= 3                                         # measured 2 (max_iter 19 before)


def test_a_cone_that_carries_nothing_next_to_a_compliance_law_is_finished():
    """A layer held by the contact through compliance (m = 2) with a P2 conic limit at 3x the free
    penetration (the limit does not bind, non-matching 3 : 4 meshes): the cones' Bernstein duals are the
    interior point's noise (5e-16). Read relative to themselves they made every segment a contact (rows at
    every node), and Newton did not converge in 40 steps (ok False: "optimal_inaccurate"). Against the closed
    form: uniform stress -p, the law's penetration r = (p / k)^(1/m)."""
    from compliance_scenes import P, held_layer

    k, m = 1e16, 2.0
    r = (P / k) ** (1 / m)
    law = cc.NormalCompliance(stiffness=k, exponent=m, penetration_limit=3 * r)
    sol = _finished(held_layer(law, nx=3))
    assert sol.ok and sol.polished
    c = sol.contact
    assert np.abs(c.jump - c.gap - r).max() < 1e-12 * r          # measured 1.5e-14
    assert np.abs(c.lam - P).max() < 1e-12 * P                    # measured 3.1e-14


@pytest.mark.parametrize("shape", [SEGMENT, TRIANGLE])
def test_one_coefficient_map_per_element_shape(shape):
    """gram(b) is the Q of q = L^T Q L (against the Bernstein basis evaluated directly), index(i, j) its
    position in b, and dual_gram the Z with beta . b = <Z, Q> (the pairing the cones' duals use)."""
    rng = np.random.default_rng(3)
    b, beta = rng.normal(size=(5, shape.width)), rng.normal(size=(5, shape.width))
    k = 2 if shape.width == 3 else 3
    L = rng.dirichlet(np.ones(k), size=7)                             # barycentric points
    Q = shape.gram(b)
    q = np.einsum("pi,sij,pj->sp", L, Q, L)
    direct = b @ (shape.basis(L[:, 1]) if k == 2 else shape.basis(L)).T
    np.testing.assert_allclose(q, direct, rtol=0, atol=1e-13)
    for i in range(k):
        for j in range(k):
            np.testing.assert_array_equal(Q[:, i, j], b[:, shape.index(i, j)])
    np.testing.assert_allclose((shape.dual_gram(beta) * Q).sum(axis=(1, 2)), (beta * b).sum(axis=1), atol=1e-13)


def test_a_segment_flat_to_rounding_has_no_maximum_rather_than_a_singular_system(monkeypatch):
    """Coefficients at rounding along a whole segment (a pair's slack 0 to rounding: found on the P2 stack of
    test_p2_pairs under OpenBLAS's Prescott kernels, where the bordered system was exactly singular and its
    LinAlgError escaped the solve): no maximum (None), never an exception or a non-finite point, whatever the
    kernels; where a solve does fail (forced here), None too."""
    b = np.array([-2.77555756e-16, -3.74700271e-16, -4.71844785e-16])       # the coefficients found there
    out = element_maximum(SEGMENT, b, (0, 1))
    assert out is None or (np.isfinite(out[0]) and np.isfinite(out[1]).all() and np.isfinite(out[2]).all())

    def singular(*args, **kwargs):
        raise np.linalg.LinAlgError("Singular matrix")

    concave = np.array([0.0, 1.0, 0.0])                                        # q = 2 t (1 - t): max 1/2 at 1/2
    m, L, _ = element_maximum(SEGMENT, concave, (0, 1))
    assert m == pytest.approx(0.5, abs=1e-15) and L[:2] == pytest.approx([0.5, 0.5], abs=1e-15)
    monkeypatch.setattr(np.linalg, "solve", singular)
    assert element_maximum(SEGMENT, concave, (0, 1)) is None


def _one_segment():
    """Three springs A = diag(2, 3, 4) N/m under F = (3, 1, 1) N, each moving one node of one P2 segment (rows
    G = I, gaps g = (0.5, 1, 1) m, its Bernstein map the segment's own): by hand, node 0 closes (x_0 = 0.5,
    force y = F_0 - 2 x_0 = 2), the others stay open (x = F / A: 1/3, 1/4, Bernstein coefficients of x - g
    0, -23/24, -3/4, all <= 0)."""
    kkt = SimpleNamespace(rows=sp.identity(3, format="csr"), matrix=sp.diags([2.0, 3.0, 4.0]).tocsr(),
                          rhs=np.array([3.0, 1.0, 1.0]))
    return kkt, sp.csr_matrix(SEGMENT.to_bernstein), np.array([0.5, 1.0, 1.0]), np.array([[2.0, 0.0, 0.0]])


def test_newton_takes_no_rounding_step_for_convergence_off_balance(monkeypatch):
    """The acceptance reads the residual (tangency.ACCEPT_TOL), not the step. With the true solves Newton ends at
    the answer by hand; with a Newton system whose solve gives a step at rounding (as a system singular to
    rounding did: the force-controlled P2 punch condensed, under the Sandybridge kernels) from a start off
    balance (residual 1 N of the 3 N load), it declines (Stop.STALL) where it took that step for convergence."""
    kkt, B, g, beta = _one_segment()
    out = tangency.tangency_newton(kkt, B, g, beta, np.array([0.4, 0.3, 0.2]))
    assert not isinstance(out, Declined)
    assert np.abs(out["x"] - [0.5, 1 / 3, 1 / 4]).max() < 1e-15 and out["y"] == pytest.approx([2.0], rel=1e-15)

    class Rounding:
        def __init__(self, K):
            self.n = K.shape[0]

        def solve(self, b):
            return np.full(self.n, 1e-17)

    monkeypatch.setattr(tangency, "dense_or_sparse_lu", Rounding)
    out = tangency.tangency_newton(kkt, B, g, beta, np.array([0.5, 0.5, 0.5]))
    assert isinstance(out, Declined) and out.stop is Stop.STALL, out


def test_a_segment_flat_to_the_finish_tolerance_is_a_whole_contact():
    """Coefficients at rounding of their terms (5.6e-17 against terms of 3.9: the force-controlled P2 punch
    condensed, under the Sandybridge kernels) give no maximum at the finish's tolerance of those terms, so the
    segment is in contact as a whole (vertex rows), not a tangency whose curvature 1/rounding makes the Newton
    system singular to rounding; a true curvature well above it still has its maximum."""
    rounding = np.array([0.0, 5.55111512e-17, 0.0])
    assert element_maximum(SEGMENT, rounding, (0, 1)) is not None          # negative definite by its signs alone
    assert element_maximum(SEGMENT, rounding, (0, 1), flat=1e-11 * 3.9) is None
    m, L, _ = element_maximum(SEGMENT, np.array([0.0, 1e-9, 0.0]), (0, 1), flat=1e-11 * 3.9)
    assert m == pytest.approx(5e-10, rel=1e-12) and L[:2] == pytest.approx([0.5, 0.5], abs=1e-15)


def test_the_maximiser_backtracks_a_newton_step_that_overshoots_into_the_convex_part():
    """A conforming face: the quadratic part of q is 0 (Q = 0, the interior point's x on the P2 sphere under the
    Sandybridge kernels had it 0 to 1e-12), so q = -delta(L) alone, here a bump A exp(-u^2 / 2), u = (t - c) / s:
    concave only for |u| < 1. Newton from the centre t = 1/2 (u = 0.9) steps to u = 0.9 + 0.9 / (0.81 - 1) = -3.8,
    where q is convex; halving that step lands at u = -0.28 and Newton converges to the closed-form maximum
    (t = c, q = A). Without the backtracking the face read as flat (None), a whole contact, and the rounds cycled."""
    A, c, s = 2.0, 0.41, 0.1

    def delta(L):
        u = (L[1] - c) / s
        f = A * np.exp(-0.5 * u * u)
        return -f, np.array([0.0, u / s * f]), np.diag([0.0, (1 - u * u) / s ** 2 * f])

    m, L, M = element_maximum(SEGMENT, np.zeros(3), (0, 1), delta=delta)
    assert L[:2] == pytest.approx([1 - c, c], abs=1e-12) and m == pytest.approx(A, rel=1e-14)
    assert np.isfinite(M).all()


@pytest.mark.numerics
def test_a_nodal_pair_beside_the_cones_carries_its_force_once():
    """A free block (1 m x 0.5 m, 8 x 4 P2 cells) under (0, -p) on its top and 0.3 p on its left face, on a rigid
    disk of radius 10 m under "gamma3" (the contact ends inside elements), its right face's upper half against a
    frictionless wall under "sigma1" (a nodal pair beside the cones: each of its rows one degenerate element of
    the Bernstein map, the same row at its three nodes). The answer balances the load, summed here from the
    pairs' nodal forces along their own normals: the wall takes 0.3 p H less the disk's x-component, the disk
    p L (measured 3.5e-14 and 6.2e-14). Before, the tangency finish read each wall row's force at three nodes
    (a run of one element) and reported the wall's force twice (2.99e6 N/m against 1.49e6: ok False, warned).
    The interior point of the full program at tight tolerances, which shares nothing with the finish, has the
    same wall force (measured 3.6e-7) and displacements (1.3e-5: its own resolution)."""
    P, L, H = 1e7, 1.0, 0.5
    centre = np.array([L / 2, -10.0])
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4, segments={"side": ("right", H / 2, H)})
    b = cc.Body(m, STEEL, contact="bottom", traction={"top": (0.0, -P), "left": (0.3 * P, 0.0)})
    scene = cc.Scene(b, contacts=[
        cc.Contact(b, "bottom", cc.Rigid.circle(center=tuple(centre), radius=10.0)),
        cc.Contact(b, "side", cc.Rigid.plane(point=(L, 0.0), normal=(-1.0, 0.0)), condition="sigma1")])
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(scene, degree=2)
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.TANGENCY_NEWTON, sol.info.declined

    def balance(s):
        floor, wall = s.contacts
        n = floor.points - centre
        f = floor.force @ (n / np.linalg.norm(n, axis=1)[:, None])     # the disk's force on the block
        return wall.force.sum(), (0.3 * P * H + f[0] - wall.force.sum()) / (0.3 * P * H), (f[1] - P * L) / (P * L)

    wall, bx, by = balance(sol)
    assert abs(bx) <= 1e-11 and abs(by) <= 1e-11
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ipm = cc.solve(scene, degree=2, method="full", polish=False,
                       solver_options={"tol_gap_abs": 1e-15, "tol_gap_rel": 1e-15, "tol_feas": 1e-13,
                                       "tol_ktratio": 1e-12, "max_iter": 1000})
    assert abs(balance(ipm)[0] / wall - 1) <= 1e-5
    assert max(np.abs(a - c).max() / np.abs(c).max() for a, c in zip(sol.u, ipm.u)) <= 1e-3
