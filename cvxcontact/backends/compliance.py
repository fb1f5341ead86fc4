"""Routes for a normal-compliance law on some or all pairs (the paper's (7)/(19); docs/formulation.md §10):
the convex program with the compliance energy (full or condensed), finished exactly by semismooth Newton
steps on the interface, or, with a body held by the contact or force-controlled obstacles, on the sparse
mixed system with the law's rows; where rows with a condition r <= l depend on each other (3D "gamma3" on
non-matching faces, docs/formulation.md §13), Newton steps on the law around the finish of dependent rows
(:func:`dependent_newton`)."""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .condensed import InterfaceModel
from .finish import (SIGN_TOL, Declined, Stop, independent_active_set, rows_kkt, solve_compliance,
                     solve_linear_compliance, solve_sparse_compliance)
from .finish.normal_compliance import rounding_floor, solved_rounding
from .full import ContactModel, limit_reaction, solve_mixed
from .interface import condensation, program_fields, release_held
from .mixed import law_linearised, mixed_system, stacked, unstacked
from .program import timed_program
from .result import Finish, RawResult, Route, load_key
from .signorini import dependent_rows

__all__ = ["solve", "full", "condensed", "newton", "dependent_newton", "compliance_program", "compliance_forces",
           "program_penetration"]


def newton(W, d, w, law, r0=None, active=None):
    """:func:`solve_compliance` from (r0, active); if it does not settle and the compliant rows are all
    linear without a limit, the finite LCP of :func:`solve_linear_compliance`. ``(y, z, at_limit, route)``, or
    the :class:`~cvxcontact.backends.finish.declined.Declined` of the last that ran."""
    out = solve_compliance(W, d, w, law, r0=r0, active=active)
    if isinstance(out, Declined) and law.linear:
        out = solve_linear_compliance(W, d, w, law)
    return out


def compliance_program(problem) -> ContactModel:
    """The full program of a normal-compliance law on some rows (the term
    :class:`~cvxcontact.discrete.terms.ComplianceRows`): the bodies' energy plus the law's energy on the rows
    and the rows with a finite penetration limit (:func:`~cvxcontact.backends.full.law_rows`; scaled)."""
    return ContactModel(list(problem.blocks), problem.E, problem.g, law=problem.scaled_law, weights=problem.weights,
                        translations=list(problem.translations))


def program_penetration(problem, u, taus) -> np.ndarray:
    """r = E [u_nu] + R t - E g at the program's values ``u``, ``taus`` (scaled)."""
    E, g = problem.E, problem.g
    return (sum(E @ (b.jump @ uk) for b, uk in zip(problem.blocks, u)) - g
            + problem.row_translation(taus))


def compliance_forces(problem, model: ContactModel, u, taus) -> tuple:
    """(y, z, None) of the solved :func:`compliance_program`: the row forces y = w p(r) + z and the limit
    reactions z, those of the rows no unknown moves at 0 (docs/formulation.md §8, "Held nodes"); scaled."""
    z = release_held(0.0, limit_reaction(model.contact, model.limit_rows, len(problem.g)), problem.held_rows)[1]
    return problem.weights * problem.scaled_law.pressure(program_penetration(problem, u, taus)) + z, z, None


def full(problem, cache, settings, timings) -> RawResult:
    """:func:`solve` on the full program (the reference)."""
    return solve(problem, cache, settings, timings, method="full")


def condensed(problem, cache, settings, timings) -> RawResult:
    """:func:`solve` on the condensed interface program."""
    return solve(problem, cache, settings, timings, method="condensed")


def solve(problem, cache, settings, timings, method: str = "condensed") -> RawResult:
    """The compliance program of ``problem`` (method "full" or "condensed"), finished exactly; the route of
    :func:`sparse` for bodies held by the contact or force-controlled obstacles. ``raw.z``: the limit
    reactions (None if no row has a limit); ``cache.active``: (r, rows at their limit) for warm starts."""
    if problem.held or problem.translations:
        raw = sparse(problem, settings, timings)
    else:
        raw = _interface_route(problem, cache, settings, timings, method)
    if raw.z is not None:
        raw.y, raw.z = release_held(raw.y, raw.z, problem.held_rows)
    raw.method = method
    return raw


def _interface_route(problem, cache, settings, timings, method) -> RawResult:
    law, w, E, g = problem.scaled_law, problem.weights, problem.E, problem.g
    raw = RawResult(u=None, phi=None, y=None)
    cond, key = None, load_key(problem)
    if method == "condensed" or settings.polish:
        reduction = condensation(problem, cache, settings, timings)
        cond, compliance = reduction.bodies, reduction.compliance
        _, loads, d = reduction.apply(problem, timings)
    out = None
    # W is singular on dependent rows: no Newton on W (a linear law without a limit has the LCP of `newton`)
    dependent = settings.polish and (_dependent(problem, law) or (problem.lines.dependent and not law.linear))
    if method == "condensed" and settings.warm_start and settings.polish and cache.active is not None \
            and not dependent:
        t0 = time.perf_counter()
        answered = cache.own.get("compliance answer")          # this load's answer: its bits (Newton from it
        if answered is not None and answered[0] == key:        # would move it by its rounding)
            out = tuple(np.array(a) if isinstance(a, np.ndarray) else a for a in answered[1])
        else:                                                  # another load: from the previous answer
            out = newton(compliance.W, d, w, law, *cache.active)
        timings["polish"] = time.perf_counter() - t0
        if isinstance(out, Declined):
            out = None                                     # the program instead, from the start
        else:
            raw.route, raw.finish = Route.WARM_START, out[3]
    model = None
    if out is None:
        t0 = time.perf_counter()
        if method == "full":
            model = problem.term.program(problem)     # its rows and energy (compliance_program)
        else:
            model = InterfaceModel(cond, loads, E, g, law=law, weights=w)
        timings["model"] = time.perf_counter() - t0
        try:
            raw.iterations = timed_program(model.problem, settings, timings)
        except SolverError:
            if not settings.polish:
                raise
            model = None          # the finish converges globally from the free slack (§10)
        if model is None:
            t0 = time.perf_counter()
            out = newton(compliance.W, d, w, law)
            timings["polish"] = time.perf_counter() - t0
            if isinstance(out, Declined):
                raise SolverError(f"{settings.solver} failed on the normal-compliance program and the semismooth "
                                  f"Newton finish did not settle ({out})")
            raw.route, raw.finish = Route.NEWTON_ONLY, out[3]
        else:
            raw.program = model.problem
            raw.u, raw.phi, r = program_fields(model, problem, None if method == "full" else cond)
            raw.z = limit_reaction(model.contact, model.limit_rows, len(g))
            raw.y = w * law.pressure(r) + raw.z
            if dependent:
                if raw.u is None:                          # the condensed program's Gamma values, filled in
                    raw.u, raw.phi = reduction.invert_gamma(problem, [v.value for v in model.v], timings)
                return _dependent_finish(problem, raw, stacked(raw.u, raw.phi), raw.z, r, timings)
            if settings.polish:
                t0 = time.perf_counter()
                start = None
                if (law.limited & ~law.rows).any():        # Signorini rows: start from the IPM's active set
                    start = law.limited & (raw.z * np.diag(compliance.W) + (r - law.penetration_limit) > 0)
                out = newton(compliance.W, d, w, law, r, start)
                timings["polish"] = time.perf_counter() - t0
                if isinstance(out, Declined):
                    raw.declined, out = out, None
                else:
                    raw.finish = out[3]
    if out is not None:
        raw.y, raw.z, raw.polished = out[0], out[1], True
        cache.active = (d - compliance.W @ raw.y, out[2])     # the penetration r and the rows at their limit
        cache.own["compliance answer"] = (key, tuple(np.array(a) if isinstance(a, np.ndarray) else a for a in out))
    if cond is not None and (raw.polished or method == "condensed"):
        raw.u, raw.phi = reduction.invert(problem, raw.y, timings)
    if not law.limited.any():
        raw.z = None
    return raw


def linear_mixed_system(problem):
    """(A, F, G, widths) of the sparse mixed system (26) of ``problem`` (a linear material, scaled): A the
    bodies' quasi-definite blocks and a zero block for the obstacles' translations, F the loads
    (:func:`~cvxcontact.backends.mixed.mixed_system`)."""
    op, G, widths = mixed_system(problem)
    A, F = op.linearised(np.zeros(G.shape[1]))
    return A, F, G, widths


def sparse(problem, settings, timings) -> RawResult:
    """Normal compliance with a body held by the contact only or force-controlled obstacles (docs/
    formulation.md §10-§12): no body can be condensed alone (a singular stiffness) or the obstacles'
    translations tau couple every body they touch, so the full model (the energy with the compliance
    term, the limit rows, the unknowns tau with the work -F . tau) is solved by the interior point and
    finished exactly by Newton steps on the sparse mixed system with the law's rows
    (:func:`~cvxcontact.backends.finish.solve_sparse_compliance`; :func:`dependent_newton` where the rows
    with a condition r <= l can depend on each other)."""
    law, w, E, g, blocks = problem.scaled_law, problem.weights, problem.E, problem.g, list(problem.blocks)
    t0 = time.perf_counter()
    model = problem.term.program(problem)              # the compliance law's rows (compliance_program)
    timings["model"] = time.perf_counter() - t0
    raw = RawResult(u=None, phi=None, y=None, program=model.problem)
    raw.iterations = timed_program(model.problem, settings, timings)
    u = [np.asarray(v.value, dtype=float) for v in model.u]
    phi = [np.asarray(v.value, dtype=float) if v is not None else None for v in model.phi]
    taus = [np.asarray(t.value, dtype=float).ravel() for t in model.t]
    z = limit_reaction(model.contact, model.limit_rows, len(g))
    r = (sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u))
         + problem.row_translation(taus) - g)
    y = w * law.pressure(r) + z
    raw.u, raw.phi, raw.y, raw.taus = u, phi, y, taus
    if settings.polish:
        if _dependent(problem, law):
            _dependent_finish(problem, raw, stacked(u, phi, taus), z, r, timings)
        else:
            t0 = time.perf_counter()
            op, G, widths = mixed_system(problem)
            out = solve_sparse_compliance(op, G, g, w, law, stacked(u, phi, taus), _limit_start(law, y, z, r, g))
            timings["polish"] = time.perf_counter() - t0
            if isinstance(out, Declined):
                raw.declined = Declined(out.stop, "the Newton steps on the sparse mixed system with the law's rows "
                                        f"did not settle: {out}", out.rows)   # a singular step's rows: run's check
            else:
                raw.polished, raw.finish = True, Finish.SEMISMOOTH_NEWTON
                raw.u, raw.phi, raw.taus = unstacked(problem, out[0], widths)
                raw.y, raw.z = out[1], out[2]
    raw.z = (raw.z if raw.polished else z) if law.limited.any() else None
    return raw


def _limit_start(law, y, z, r, g):
    """The interior point's rows at their limit: reaction beats slack, each relative to its own scale."""
    Y = max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny)
    U = max(float(np.abs(r + g).max(initial=0.0)), float(np.abs(g).max(initial=0.0)), np.finfo(float).tiny)
    return law.limited & (z / Y + (r - law.penetration_limit) / U > 0)


def _dependent(problem, law) -> bool:
    """Whether the finish must keep the rows with a condition r <= l independent: rows that can depend on
    each other (:func:`~cvxcontact.backends.signorini.dependent_rows`) and some row with a finite limit (rows
    of a compliance law alone carry no multiplier: their dependence does not matter)."""
    return bool(law.limited.any()) and dependent_rows(problem)


def _dependent_finish(problem, raw, x0, z0, r0, timings):
    """:func:`dependent_newton` on the sparse mixed system of ``problem`` from the interior point's unknowns
    ``x0``, limit reactions ``z0`` and penetration ``r0``; fills ``raw`` (fields, y, z, finish) or its
    ``declined``."""
    t0 = time.perf_counter()
    law, g = problem.scaled_law, problem.g
    A, F, G, widths = linear_mixed_system(problem)
    free = ~problem.held_rows
    z0 = np.where(free, z0, 0.0)
    start = _limit_start(law, problem.weights * law.pressure(r0) + z0, z0, r0, g) & free
    out = dependent_newton(A, F, G, g, problem.weights, law, x0, z0, start)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = out
        return raw
    x, raw.y, raw.z = out[:3]
    raw.u, raw.phi, raw.taus = unstacked(problem, x, widths)
    raw.polished, raw.finish = True, Finish.NEWTON_INDEPENDENT
    return raw


def dependent_newton(A, F, G, g, weights, law, x0, z0, start, max_iter: int = 50):
    """Exact finish of rows with a condition r <= l (Signorini rows, l = 0; compliance rows with a penetration
    limit) that may depend on each other (3D "gamma3" overlay rows, docs/formulation.md §13) next to rows of
    a normal-compliance law (§10), on the sparse mixed system (26). Scaled units; ``A``, ``F``, ``G``, ``g``,
    ``weights`` w, ``law`` (a :class:`~cvxcontact.contact.laws.RowLaws`) as in
    :func:`~cvxcontact.backends.finish.solve_sparse_compliance`, whose system it solves:

        A x + G^T y = F,   y = w p(r) + z,   r = G x - g <= l,  z >= 0,  z (r - l) = 0.

    Why Newton outside and Lawson-Hanson inside: a compliance row carries no multiplier (its force w p(r) is a
    function of x), so its dependence on other rows never makes a system singular, while a multiplier z of
    dependent rows is not unique and every active-set step that closes them factorises a singular matrix.
    Linearising the law at x^k (r^k = G x^k - g, D = diag(w p'(r^k))) turns the compliance rows into a
    stiffness and a load on the bodies,

        [A + G^T D G] x + G_L^T z_L = F - G^T (w p(r^k) - D (g + r^k)),   G_L x <= g_L + l_L  (compl.),

    the Signorini problem (26)-(27) of the rows L with a finite limit, which
    :func:`~cvxcontact.backends.finish.independent_active_set` solves exactly whatever the dependence of its
    rows (its forces on independent rows; factored steps, warm-started from the previous step's rows and
    forces). That is one step of Newton's method on the law (a sequential QP with the exact Hessian of the
    energy 1/2 x^T A x - F^T x + sum_a w_a Phi_a(r_a), convex where the Gauss rows hold): both x^k and the
    step's answer satisfy G_L x <= g_L + l_L, so the damped step x^k + t (x^{k+1} - x^k) (backtracking on
    the energy, as in :func:`solve_sparse_compliance`; the first step from the interior point taken whole)
    stays admissible. For m = 1, p' is piecewise constant: once no compliance row changes sign the step's
    system is the problem's own, and the answer is exact (semismooth Newton, finite); for m > 1 the steps
    converge quadratically. Stops with t = 1 when the stationarity residual A x + G^T y - F is within 1e-3
    ``SIGN_TOL`` of each row's scale |A| |x| + |G^T| |y| + |F| or within the step's
    :func:`~cvxcontact.backends.finish.normal_compliance.rounding_floor` (such a full step is taken whole, not
    backtracked: its energy's change is rounding), or within ``SIGN_TOL`` once a step no longer halves it; the
    signs, feasibility (to 1e-12 of each row's scale) and complementarity (the rows carrying
    z closed) are the inner finish's.

    ``x0``, ``z0``, ``start``: the start (e.g. the interior point's unknowns, limit reactions and rows at their
    limit). Returns ``(x, y, z, at_limit, newton_steps, active_set_steps)`` or the reason it stopped (a
    :class:`~cvxcontact.backends.finish.declined.Declined`).
    """
    A, G = sp.csr_matrix(A), sp.csr_matrix(G)
    F, g, w = (np.asarray(a, dtype=float) for a in (F, g, weights))
    m = G.shape[0]
    ell = np.broadcast_to(np.asarray(law.penetration_limit, dtype=float), (m,))
    L = np.flatnonzero(np.isfinite(ell))
    GL, cL = G[L], g[L] + ell[L]
    zL = np.maximum(np.asarray(z0, dtype=float)[L], 0.0)
    active = np.asarray(start, dtype=bool)[L]
    absA, absG, tiny = abs(A), abs(G), np.finfo(float).tiny
    x = np.asarray(x0, dtype=float).copy()

    def energy(x):
        r = G @ x - g
        return 0.5 * x @ (A @ x) - F @ x + float(w @ law.energy(r))

    def residual(x, z):
        """The residual of (26) at x with the limit reactions z, its rows' scales and the rows' forces y."""
        y = w * law.pressure(G @ x - g) + z
        S = absA @ np.abs(x) + absG.T @ np.abs(y) + np.abs(F)
        return A @ x + G.T @ y - F, np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), tiny)), y

    inner, last = 0, np.inf
    for newton_steps in range(1, max_iter + 1):
        K, b = law_linearised(A, A @ x - F, G, g, w, law, x)      # one Newton step's model of the law at x
        out = independent_active_set(rows_kkt(K, b, GL, cL, solve_mixed), cL, zL, active)
        if isinstance(out, Declined):
            return out
        (target, zL), active, steps = out
        inner += steps
        dx, t = target - x, 1.0
        z = np.zeros(m)
        z[L] = zL
        res, S, y = residual(target, z)
        # settled: the full step's residual at the rounding of each row, or below the floor no step can pass
        # (the step's rounding_floor, as solve_sparse_compliance's): such a step is taken whole, its energy's
        # change drowns in its rounding (a row whose own terms are ~0 beside a moving block read 7e-12 of its
        # floored scale at residual 1e-25, and the backtracking halved the rounding step: declined, 1e12 m^-2)
        floor = rounding_floor(K, target, solved_rounding(K, GL.T, target, zL, b))
        settled = bool((np.abs(res) <= 1e-3 * SIGN_TOL * S + floor).all())
        if newton_steps > 1 and not settled:
            f0 = energy(x)
            while t > 1e-12 and energy(x + t * dx) > f0 + 1e-14 * max(abs(f0), tiny):
                t *= 0.5
        x = x + t * dx
        if t < 1.0:
            res, S, y = residual(x, z)
        ratio = float((np.abs(res) / S).max(initial=0.0))
        if t == 1.0 and (settled or ratio <= 1e-3 * SIGN_TOL or (ratio <= SIGN_TOL and ratio >= 0.5 * last)):
            at = np.zeros(m, dtype=bool)
            at[L] = active
            return x, y, z, at, newton_steps, inner
        last = ratio
        if np.abs(t * dx).max(initial=0.0) <= 1e-15 * max(np.abs(x).max(initial=0.0), tiny):
            return Declined(Stop.STALL, "the Newton steps on the law stalled above rounding")
    return Declined(Stop.MAX_ITER, "the Newton steps on the law did not settle")
