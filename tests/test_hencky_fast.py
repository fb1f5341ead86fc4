"""The fast route of a non-quadratic bulk energy (issue 31 item 2, :mod:`cvxcontact.backends.nonlinear`, method
"newton"): Newton on the nonlinear mixed system (26) with the contact active set from the elastic predictor, no
interior point. Checked against the full route (the interior point + its Newton finish, the
reference) to rounding, the closed form of uniaxial strain, a dense Newton (tests/references.py),
and (26)-(27) by the read-back; its fallback to the full route when the steps do not settle. Tolerances: the
finish's rounding or 100x the measured values (beside them)."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from conftest import rel, two_blocks
from hencky_scenes import (
    EXACT,
    NU,
    SIGMA_Y,
    E,
    H,
    indented,
    pressed_block,
    uniaxial_stress,
)
from references import dense_newton

import cvxcontact as cc
from cvxcontact.backends import choose, describe, nonlinear
from cvxcontact.backends.factor import pardiso_available
from cvxcontact.backends.mixed import mixed_system
from cvxcontact.backends.result import Finish
from cvxcontact.discrete import build_problem
from cvxcontact.fem.space import space
from cvxcontact.physics.materials import deviator

pytestmark = pytest.mark.numerics

HENCKY = cc.materials.hencky(E, NU, SIGMA_Y, H)
SAME = 1e-11        # fast against full: both exact finishes of (26); measured <= 5.7e-14 (forces of a pair),
#                     7.1e-15 (u)


def both(scene, **kw):
    """(fast, full): cc.solve by method "auto" (asserted to be the fast route, finished exactly, sol.ok) and by the
    full route (interior point + Newton finish)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("error", cc.ResidualWarning)
        fast = cc.solve(scene, estimate=False, **kw)
        full = cc.solve(scene, estimate=False, method="full", **kw)
    assert fast.info.method == "newton" and fast.info.requested == "auto", fast.info
    assert fast.info.route == cc.Route.NEWTON_DIRECT and fast.info.finish == Finish.NEWTON_BULK
    assert fast.ok and fast.polished and fast.residuals()["equilibrium"] < EXACT, fast.report()
    assert full.info.method == "full" and full.info.finish == Finish.NEWTON_BULK and full.ok
    return fast, full


def same(fast, full, tol=SAME):
    for a, b in zip(fast.u, full.u):
        assert rel(a, b) < tol
    assert rel(fast.contact.lam, full.contact.lam) < tol


def test_auto_takes_the_fast_route_for_a_non_quadratic_energy_with_signorini_rows():
    problem = build_problem(two_blocks(mat2=HENCKY), space(1), "gamma3", cc.Signorini())
    assert choose("auto", describe(problem)) == "newton"
    linear = build_problem(two_blocks(), space(1), "gamma3", cc.Signorini())
    assert choose("auto", describe(linear)) == "condensed"
    with pytest.raises(cc.SolverError, match="method 'newton' does not accept"):     # a quadratic energy
        cc.solve(two_blocks(), method="newton")
    cones = build_problem(two_blocks(mat2=HENCKY), space(2), "gamma3", cc.Signorini())
    assert choose("auto", describe(cones)) == "full"          # the P2 cones beside Hencky: the full route's


@pytest.mark.parametrize("strain", [-2e-3, -1e-2])    # below yield (at -3.7e-3), above it
def test_uniaxial_strain_follows_the_closed_form(strain):
    fast, full = both(pressed_block(HENCKY, strain))
    expected = -uniaxial_stress(strain)
    assert rel(fast.contact.lam, np.full_like(fast.contact.lam, expected)) < 1e-12     # measured <= 2.2e-15
    assert abs(fast.obstacles[0].force[1] - expected) < 1e-12 * abs(expected)
    same(fast, full)                                            # measured 2.2e-16 (u), 2.2e-15 (forces)


def test_a_circle_pressed_into_a_yielding_block_is_the_dense_newton_answer():
    """The fast answer equals the full route's and a dense Newton's (tests/test_bulk_energy.py) to rounding, and the
    block yields under the circle (the nonlinear branch is exercised, with active-set changes inside Newton)."""
    scene = indented(HENCKY, nx=24, ny=8, depth=5e-3)
    fast, full = both(scene)
    same(fast, full)                                            # measured 2.0e-15 (u), 1.0e-15 (forces)
    problem = build_problem(scene, space(1), "gamma3", cc.Signorini())
    bulk, block, un = problem.blocks[0].bulk, problem.blocks[0], problem.units
    z, _, active = dense_newton(bulk, block.f, (problem.E @ block.jump).toarray(), problem.g)
    x = fast.u[0].ravel() @ problem.systems[0].Tu / un.displacement
    assert rel(x, z) < 1e-12                                    # measured 1.6e-15
    s = np.linalg.norm(bulk.strains(z) @ deviator(2)[0].T, axis=1)
    assert (s > HENCKY.s_y).sum() >= 10 and active.sum() >= 3
    assert fast.info.iterations > 2                             # Newton steps (systems solved)


def test_a_pair_with_a_hencky_body():
    fast, full = both(two_blocks(mat2=cc.materials.hencky(E, NU, 1e8, H), scale=4.0))
    same(fast, full)                                            # measured 7.1e-15 (u), 5.7e-14 (forces)


def test_p2_sigma1():
    fast, full = both(indented(HENCKY, nx=12, ny=4, depth=5e-3), degree=2, condition="sigma1")
    same(fast, full)                                            # measured 3.0e-15 (u), 4.1e-15 (forces)


def test_3d_p1_sigma1_between_two_boxes():
    """3D P1, "sigma1" between two non-matching boxes, the lower one Hencky and yielding under the load."""
    aluminium = cc.materials.isotropic(E=70e9, nu=0.3)
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=3, ny=3, nz=2)
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=2, ny=2, nz=1)
    b1 = cc.Body(upper, aluminium, clamped=["top"], body_force=(0.0, 0.0, -8e9), traction={"right": (0.0, 0.0, 1e9)})
    b2 = cc.Body(lower, cc.materials.hencky(E, NU, 1e8, H), clamped=["bottom"])
    scene = cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", condition="sigma1")])
    fast, full = both(scene)
    same(fast, full)                                            # measured 1.2e-15 (u), 2.0e-15 (forces)
    problem = build_problem(scene, space(1, "tetra"), "sigma1", cc.Signorini())
    bulk = problem.blocks[1].bulk
    z = fast.u[1].ravel() @ problem.systems[1].Tu / problem.units.displacement
    assert (np.linalg.norm(bulk.strains(z) @ deviator(3)[0].T, axis=1) > b2.material.s_y).any()   # 24 of 24


def test_3d_gamma3_between_bodies_is_left_to_the_full_route():
    """Rows that may be linearly dependent (3D "gamma3" between two bodies): the Newton steps close the active rows
    as they are; the fast route does not accept them and auto takes the full route."""
    aluminium = cc.materials.isotropic(E=70e9, nu=0.3)
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=3, ny=3, nz=1)
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=2, ny=2, nz=1)
    scene = cc.Scene(cc.Body(upper, aluminium, clamped=["top"], body_force=(0.0, 0.0, -2e9), contact="bottom"),
                     cc.Body(lower, HENCKY, clamped=["bottom"], contact="top"))
    problem = build_problem(scene, space(1, "tetra"), "gamma3", cc.Signorini())
    assert describe(problem).dependent_rows and choose("auto", describe(problem)) == "full"


def test_steps_that_do_not_settle_fall_back_to_the_full_route(monkeypatch):
    """Newton steps that do not settle (forced here: the solve of each step declines) are never the answer: the
    full route's (interior point + Newton finish) is, route NEWTON_FELL_BACK."""
    scene = indented(HENCKY, nx=16, ny=6, depth=5e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        full = cc.solve(scene, estimate=False, method="full")
        monkeypatch.setattr(nonlinear.TangentSolver, "__call__", lambda self, K, b, at: None)
        sol = cc.solve(scene, estimate=False)
    assert sol.info.method == "full" and sol.info.route == cc.Route.NEWTON_FELL_BACK
    assert sol.ok and sol.polished and sol.info.finish == Finish.NEWTON_BULK
    assert rel(sol.u[0], full.u[0]) < SAME                      # the same computation: measured 1.7e-15


def test_a_contact_solver_re_solves_a_new_load():
    """A ContactSolver keeps the tangent solver's analysis and starts a re-solve from the previous answer: a second,
    deeper indentation is solved by the fast route again and equals a fresh full solve."""
    solver = cc.ContactSolver(indented(HENCKY, nx=16, ny=6, depth=3e-3), estimate=False)
    first = solver.solve()
    deeper = indented(HENCKY, nx=16, ny=6, depth=5e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        second = solver.solve(deeper)
        ref = cc.solve(deeper, estimate=False, method="full")
    assert first.info.method == second.info.method == "newton" and second.ok
    assert rel(second.u[0], ref.u[0]) < SAME and rel(second.contact.lam, ref.contact.lam) < SAME


def dense_compliance(bulk, f, G, g, w, law):
    """An independent solution of one body with the energy ``bulk`` and a normal-compliance law on the rows G z - g
    (no limit): min bulk(z) - f z + sum_a w_a Phi_a(G z - g) by damped Newton on dense matrices, until the step is
    at rounding. Near the answer the energy's decrease drowns in its rounding, so a step that reduces the gradient
    is taken too (else the halving can stop the steps at a step of rounding size short of the answer: 2.6e-12
    seen)."""
    z = np.zeros(G.shape[1])

    def energy(v):
        return bulk.value(v) - f @ v + float(w @ law.energy(G @ v - g))

    def gradient(v):
        return bulk.gradient(v) - f + G.T @ (w * law.pressure(G @ v - g))

    for _ in range(100):
        r = G @ z - g
        grad = gradient(z)
        hess = bulk.hessian(z).toarray() + G.T @ ((w * law.derivative(r))[:, None] * G)
        dz, t = np.linalg.solve(hess, -grad), 1.0
        while (t > 1e-10 and energy(z + t * dz) > energy(z)
               and np.linalg.norm(gradient(z + t * dz)) >= np.linalg.norm(grad)):
            t /= 2
        z = z + t * dz
        if np.abs(t * dz).max() <= 1e-15 * np.abs(z).max():
            return z
    raise AssertionError("the dense Newton steps did not settle")


@pytest.mark.parametrize("law", [cc.NormalCompliance(stiffness=1e13, exponent=1.0),
                                 cc.NormalCompliance(stiffness=1e15, exponent=2.0)], ids=["m=1", "m=2"])
def test_a_compliance_law_beside_a_hencky_body_is_the_dense_newton_answer(law):
    """A normal-compliance law with a Hencky block (no other route poses it: the full route's compliance finish
    solves systems of Kuu): the fast route's answer passes the checks and equals a dense Newton's on the same
    energy to rounding; the block yields and the law carries the load."""
    scene = indented(HENCKY, nx=24, ny=8, depth=5e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(scene, estimate=False, law=law)
    assert sol.info.method == "newton" and sol.info.route == cc.Route.NEWTON_DIRECT and sol.ok and sol.polished
    assert sol.residuals()["equilibrium"] < EXACT, sol.report()
    problem = build_problem(scene, space(1), "gamma3", law)
    bulk, block, un = problem.blocks[0].bulk, problem.blocks[0], problem.units
    G = (problem.E @ block.jump).toarray()
    z = dense_compliance(bulk, block.f, G, problem.g, problem.weights, problem.scaled_law)
    x = sol.u[0].ravel() @ problem.systems[0].Tu / un.displacement
    assert rel(x, z) < 1e-12                                    # measured 1.2e-15 (m = 1), 2.8e-15 (m = 2)
    assert (G @ z - problem.g > 0).sum() >= 3                    # rows pressed into the circle: 3
    s = np.linalg.norm(bulk.strains(z) @ deviator(2)[0].T, axis=1)
    assert (s > HENCKY.s_y).sum() >= 10


@pytest.mark.parametrize("cheap", [False, True], ids=["near the answer", "every step"])
def test_steps_solved_by_krylov_on_the_last_factor_give_the_answer_of_a_factorisation_each(monkeypatch, cheap):
    """The Newton steps' systems solved by GMRES on the last factorisation give the answer of one factorisation per
    step (KRYLOV = 0), with fewer factorisations: as in 2D (GMRES near the answer, inexact by FORCING far from it)
    and as where GMRES is cheap (3D: tried at every step, inexact by LOOSE; forced here by CHEAP = 0)."""
    scene = indented(HENCKY, nx=40, ny=12, depth=5e-3)
    answers = []
    for krylov in (nonlinear.KRYLOV, 0):
        monkeypatch.setattr(nonlinear, "KRYLOV", krylov)
        monkeypatch.setattr(nonlinear, "CHEAP", 0 if cheap else nonlinear.CHEAP)
        solver = cc.ContactSolver(scene, estimate=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cc.ResolutionWarning)
            sol = solver.solve()
        tangent = solver.cache.own["newton"]
        assert sol.ok and sol.info.route == cc.Route.NEWTON_DIRECT
        answers.append((sol, tangent.factorizations, tangent.iterations))
    (fast, factored, iterations), (reference, every, none) = answers
    # measured: 8 steps and 8 factorisations with KRYLOV = 0; near the answer 8 steps, 5 factorisations and 8 GMRES
    # iterations; every step (a budget of 2 here) 9 steps, 5 factorisations and 11 iterations
    assert iterations > 0 and factored < fast.info.iterations and none == 0 and every == reference.info.iterations
    same(fast, reference)                                       # measured <= 6.1e-15 (u), 6.7e-15 (forces)


def test_unrefined_far_steps_give_the_answer_of_steps_refined_to_rounding(monkeypatch):
    """Factorised steps far from the answer taken unrefined (ROUGH: inexact by FORCING, as a GMRES step, and then
    no floor for the stopping test) give the answer of every step refined to rounding (ROUGH = infinity), in as
    many steps: the last steps are still solved to rounding before the answer is accepted."""
    scene = indented(HENCKY, nx=64, ny=24, depth=5e-3)
    runs = []
    for rough in (nonlinear.ROUGH, np.inf):
        monkeypatch.setattr(nonlinear, "ROUGH", rough)
        solver = cc.ContactSolver(scene, estimate=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cc.ResolutionWarning)
            sol = solver.solve()
        assert sol.ok and sol.info.route == cc.Route.NEWTON_DIRECT
        assert sol.residuals()["equilibrium"] < EXACT, sol.report()
        runs.append((sol, solver.cache.own["newton"].unrefined))
    (fast, unrefined), (reference, none) = runs
    # measured: 13 steps both, 3 factorised ones taken unrefined (the others settled without a refinement)
    assert unrefined > 0 and none == 0
    assert fast.info.iterations <= reference.info.iterations + 1
    same(fast, reference)                                       # measured 1.7e-16 (u), 7.9e-16 (forces)


def test_gmres_on_an_earlier_factor_is_the_direct_solve(monkeypatch):
    """TangentSolver: a system whose tangent (yielded points) and closed rows (one opened, one closed) differ from
    the factorised one is solved by GMRES on that factor to the direct solve's rounding (forcing 0), without a new
    factorisation; checked against SuperLU on the system with only the closed rows (formed here)."""
    monkeypatch.setattr(nonlinear, "FORCING", 0.0)
    monkeypatch.setattr(nonlinear, "LOOSE", 0.0)
    scene = indented(HENCKY, nx=24, ny=8, depth=5e-3)
    solver = cc.ContactSolver(scene, estimate=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        solver.solve()
    x, closed, *_ = solver.cache.own["newton_answer"]      # (its load key and forces after them)
    problem = solver.problem
    op, G, _ = mixed_system(problem)
    tangent = nonlinear.TangentSolver(op.pattern(), G, krylov=80)          # a budget of 80 iterations
    g = np.asarray(problem.g)

    def system(state, at):
        K, load = op.linearised(state)
        return K, np.concatenate([load, g[at]])

    first = closed.copy()
    tangent(*system(np.zeros_like(x), first), first)            # the elastic tangent: factorised
    at = closed.copy()
    at[np.flatnonzero(closed)[0]] = False                       # a row opened and one closed since
    at[np.flatnonzero(~closed)[0]] = True
    K, b = system(x, at)
    s = tangent(K, b, at)
    assert tangent.factorizations == 1 and tangent.iterations > 0
    GL = G[at]
    reference = spla.spsolve(sp.bmat([[K, GL.T], [GL, None]], format="csc"), b)
    assert rel(s, reference) < 1e-12                            # measured 1.4e-15, 1.5e-15 (39 iterations)


@pytest.mark.parametrize("dim", [2, 3])
def test_the_secant_stiffness_gives_the_stress_and_bounds_the_tangent(dim):
    """Hencky's secant stiffness S (the Newton steps' start, nonlinear.SECANT): S(eps) eps is the stress (computed
    by its own formula), S is the tangent below yield and at least the tangent above it (S - C positive
    semi-definite), and positive definite."""
    rng = np.random.default_rng(3)
    s = 3 if dim == 2 else 6
    eps = rng.standard_normal((40, s)) * HENCKY.s_y * np.geomspace(0.05, 20.0, 40)[:, None]
    S, C = HENCKY.tangent(eps, dim, secant=True), HENCKY.tangent(eps, dim)
    sigma = HENCKY.stress(eps, dim)
    assert rel(np.einsum("qab,qb->qa", S, eps), sigma) < 1e-13                   # measured 1.2e-16 (2D), 2.1e-16 (3D)
    below = np.linalg.norm(eps @ deviator(dim)[0].T, axis=1) <= HENCKY.s_y
    assert below.any() and (~below).any()
    assert rel(S[below], C[below]) < 1e-13                                         # measured 1.9e-17, 4.0e-17
    gap = np.linalg.eigvalsh(S - C)                                               # Pa
    assert gap.min() > -1e-12 * E and gap[~below].max() > 1e-3 * E                 # measured -8.2e-6 Pa, 0.27 E
    assert np.linalg.eigvalsh(S).min() > 1e-3 * E                            # measured 0.048 E


def test_the_line_search_finds_the_minimum_on_the_step():
    """_line_minimum on convex phi: the minimum of a quadratic in one regula falsi step; 1 where the full step
    stops short of it or overshoots it only by LINE_SLOPE; a kinked slope (a point yielding on the way) within
    LINE_SLOPE of 0; 0 steps: 1 (halving only, the caller's backtracking)."""
    from cvxcontact.backends.finish.normal_compliance import LINE_SLOPE, _line_minimum

    def quadratic(m):
        return lambda t: 2.0 * (t - m)
    assert abs(_line_minimum(quadratic(0.3), -0.6, 4) - 0.3) < 1e-15
    assert _line_minimum(quadratic(1.7), -3.4, 4) == 1.0
    assert _line_minimum(quadratic(0.97), -1.94, 4) == 1.0                      # phi'(1) = 0.06 <= 0.1 x 1.94
    def kinked(t):                                               # increasing, zero at 0.6, phi'(1) = 0.2
        return 4.0 * t - 1.0 if t < 0.2 else 0.5 * (t - 0.2) - 0.2
    t = _line_minimum(kinked, -1.0, 8)
    assert 0.2 < t < 1.0 and abs(kinked(t)) <= LINE_SLOPE
    assert _line_minimum(quadratic(0.3), -0.6, 0) == 1.0


@pytest.mark.parametrize("size", [(24, 8), (64, 24)])
def test_the_line_search_and_secant_start_give_the_answer_of_plain_newton(monkeypatch, size):
    """The steps' line search on the slope (nonlinear.LINE) and the secant start (nonlinear.SECANT) reach the
    answer of plain Newton steps (both 0: the tangent at every step, backtracking by halving) and of the full route
    (the interior point and its finish), with no more factorisations than plain Newton on these scenes (measured:
    24 x 8 cells 8 steps and 6 factorisations against 11 and 8; 64 x 24 13 steps and 8 factorisations against 12
    and 10: the secant step once leaves the final contact set and comes back)."""
    scene = indented(HENCKY, nx=size[0], ny=size[1], depth=5e-3)
    assert nonlinear.LINE > 0 and nonlinear.SECANT > 0
    runs = []
    for line, secant in ((nonlinear.LINE, nonlinear.SECANT), (0, 0)):
        monkeypatch.setattr(nonlinear, "LINE", line)
        monkeypatch.setattr(nonlinear, "SECANT", secant)
        solver = cc.ContactSolver(scene, estimate=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cc.ResolutionWarning)
            sol = solver.solve()
        assert sol.ok and sol.info.route == cc.Route.NEWTON_DIRECT, sol.report()
        runs.append((sol, solver.cache.own["newton"].factorizations))
    (new, factored), (plain, plain_factored) = runs
    same(new, plain)                                            # measured 2.4e-16 (u), 24 x 8 and 64 x 24
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        full = cc.solve(scene, estimate=False, method="full")
    same(new, full)                                             # measured <= 2e-15 (u)
    assert factored <= plain_factored and new.info.iterations <= 2 * 13     # measured above


class Recorded(nonlinear.TangentSolver):
    """The route's TangentSolver, recording each step's system (K, b, closed rows) and answer."""

    def __call__(self, K, b, at):
        out = super().__call__(K, b, at)
        self.steps = getattr(self, "steps", []) + [(K.copy(), b.copy(), at.copy(), out)]
        return out


def test_the_secant_step_is_the_kacanov_step(monkeypatch):
    """The route's second step (nonlinear.SECANT, the default) takes the secant stiffness at the elastic predictor
    x_1: S(x_1) x_1 is the internal force there, so the step's K x_1 + b is the load f = -gradient(0) on every
    unknown (the Kacanov step: the load on the stiffness frozen at x_1; Signorini rows add nothing to K); the
    tangent at x_1 is not (the block yields there), and the answer is the full route's."""
    monkeypatch.setattr(nonlinear, "TangentSolver", Recorded)
    scene = indented(HENCKY, nx=24, ny=8, depth=5e-3)
    solver = cc.ContactSolver(scene, estimate=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = solver.solve()
        full = cc.solve(scene, estimate=False, method="full")
    assert sol.ok and sol.info.route == cc.Route.NEWTON_DIRECT and nonlinear.SECANT >= 1
    same(sol, full)                                             # measured <= 2.3e-16 (u), 8.8e-16 (forces)
    op, G, _ = mixed_system(solver.problem)
    steps = solver.cache.own["newton"].steps
    n = G.shape[1]
    x1 = steps[0][3][:n]                                        # the start's step from x_0 = 0, taken whole
    f = -op.gradient(np.zeros(n))                               # the loads (0 here: the circle presses)
    K2, b2 = steps[1][0], steps[1][1][:n]                       # b2 = f - F(x_1), F the internal forces
    scale = np.linalg.norm(K2 @ x1)
    assert np.linalg.norm(K2 @ x1 + b2 - f) < 1e-12 * scale     # measured 2.6e-15
    assert np.linalg.norm(op.tangent(x1) @ x1 + b2 - f) > 1e-2 * scale      # measured 0.30 (the tangent's softer)
    s = np.linalg.norm(solver.problem.blocks[0].bulk.strains(x1) @ deviator(2)[0].T, axis=1)
    assert (s > HENCKY.s_y).sum() >= 10                         # measured: 124 points past yield at x_1


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_krylov_steps_on_any_factorisation_settle_from_the_secant_start(monkeypatch, factorization):
    """GMRES at every step (CHEAP = 0, as in 3D) on SuperLU's or PARDISO's factors from the secant start settles
    without the interior point on a 40 x 12 indented block, at the full route's answer. Before the steps' merit was
    the closed rows' Lagrangian (solve_sparse_compliance) it did not: a Krylov step left r_L = l_L to 1e-10, the
    step restoring it raised the energy against the reactions, and the backtracking on the energy alone cut every
    step to t ~ 1e-5 until the step limit (route NEWTON_FELL_BACK)."""
    if factorization == "pardiso" and not pardiso_available():
        pytest.skip("PARDISO (oneMKL) is not installed")
    monkeypatch.setattr(nonlinear, "CHEAP", 0)
    scene = indented(HENCKY, nx=40, ny=12, depth=5e-3)
    solver = cc.ContactSolver(scene, estimate=False, factorization=factorization)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = solver.solve()
        full = cc.solve(scene, estimate=False, method="full")
    tangent = solver.cache.own["newton"]
    assert tangent.kind == factorization and tangent.iterations > 0 and nonlinear.SECANT >= 1
    assert sol.ok and sol.info.route == cc.Route.NEWTON_DIRECT, sol.info.route
    # measured: SuperLU 13 steps, 3 factorisations, 41 GMRES iterations; PARDISO 11 steps, 5 and 16
    assert tangent.factorizations < sol.info.iterations
    same(sol, full)                                             # measured <= 2.4e-15 (u), 1.8e-15 (forces)
