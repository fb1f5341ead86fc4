"""Routes for the P2 "everywhere" condition (docs/formulation.md §8, §16): a second-order cone per merged
segment (a copositive 3x3 condition per triangle in 3D), alone (full or condensed program), or next to a
normal-compliance law in one program (§10, "P2"). Interior point with the conic tolerances, then an exact
finish: accumulated cuts on the interface compliance (certified), or on the sparse mixed system where no
compliance exists, or Newton at the contact structure (§18: tangency points, cones next to a compliance law)."""

from __future__ import annotations

import time

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..contact.bernstein import bernstein_max, point_rows
from .compliance import newton, program_penetration
from .condensed import InterfaceModel, InterfaceSystem, quasi_definite_rhs
from .bulkcuts import finish_cuts_bulk
from .cuts import (SEED_SPREAD, accumulate_cuts, dual_cone_point, energy_bound, interface_cuts, nnls_warm,
                   nodal_slack, point_duals, point_read_back, seed_forces, seed_points, segment_scales)
from .finish import Declined, Stop, coefficient_rounding, independent_active_set, row_reach, slack_terms
from .tangency import tangency_newton
from .conic import ConicInterfaceModel, bernstein_constraints, bernstein_duals
from .full import ContactModel, limit_reaction, mixed_kkt
from .mixedcuts import finish_cuts_compliance
from .interface import condensation, held_cone, program_fields, release_held, split
from .mixed import mixed_system, tangent_blocks
from .program import conic_options, timed_program
from .result import Finish, RawResult, Route
from .start import cone_seeds

__all__ = ["full", "condensed", "mixed", "mixed_full", "mixed_condensed", "conic_mix_model", "cone_program",
           "cone_forces", "mixed_program", "mixed_forces"]


def cone_width(problem) -> int:
    """Bernstein coefficients per element of the problem's cones: 3 (segments, 2D), 6 (triangles, 3D)."""
    return problem.lines.cone[1].shape[1]


def _mixed_width(problem) -> int:
    """Bernstein coefficients per element of the cones beside a compliance law: 3 (2D), 6 (3D)."""
    return problem.lines.mixed_bernstein[1].shape[1]


def cone_nodal_force(problem, beta):
    """r = B^T beta: the nodal contact force on X_h of the conic condition (scaled)."""
    return problem.lines.cone[0].T @ beta.ravel()


def held_beta(problem, beta):
    """beta with the cone rows no unknown moves at their least admissible value (§8, "Held nodes")."""
    return held_cone(beta, problem.lines.cone[0].tocsr(), problem.held_rows, problem.gap, cone_width(problem))


def cone_program(problem) -> ContactModel:
    """The full program of the P2 "everywhere" cones (the term :class:`~cvxcontact.discrete.terms.EverywhereCones`;
    :mod:`cvxcontact.backends.conic`, docs/formulation.md §8)."""
    return ContactModel(list(problem.blocks), problem.E, problem.g, bernstein=problem.lines.cone[0],
                        translations=list(problem.translations), width=cone_width(problem))


def cone_forces(problem, model, u, taus) -> tuple:
    """(y, None, beta) of the solved :func:`cone_program`: the Bernstein duals beta (the held elements' at their
    least admissible value) and the nodal force y = B^T beta on X_h (E = I; beside a nodal pair with friction, on
    E's rows, :meth:`~cvxcontact.contact.quadratic.QuadraticStack.row_cone`); scaled."""
    B, w = problem.lines.cone[0], cone_width(problem)
    beta = held_cone(bernstein_duals(model.cone, model.row, w), B, problem.held_rows, problem.g, w)
    return B.T @ beta.ravel(), None, beta


def mixed_program(problem):
    """The full program of cones beside a normal-compliance law (the term
    :class:`~cvxcontact.discrete.terms.ConesBesideCompliance`; :func:`conic_mix_model`)."""
    return conic_mix_model(list(problem.blocks), problem.E, problem.g, problem.scaled_law, problem.weights,
                           mixed_bernstein_rows(problem), translations=list(problem.translations),
                           width=_mixed_width(problem))


def mixed_forces(problem, model, u, taus) -> tuple:
    """(y, z, beta) of the solved :func:`mixed_program`: the limit reactions and the cones' nodal force
    z = (multipliers of the linear rows) + B^T beta, the row forces y = w p(r) + z, the Bernstein duals beta
    (held rows and elements at their least admissible value); scaled."""
    law, g, held = problem.scaled_law, problem.g, problem.held_rows
    B = mixed_bernstein_rows(problem)
    z = release_held(0.0, limit_reaction(model.contact, model.limit_rows, len(g)), held)[1]
    w = _mixed_width(problem)
    beta = held_cone(bernstein_duals(model.cone, model.row, w), B, held, g + law.cone_shift, w)
    z = z + B.T @ beta.ravel()
    return problem.weights * law.pressure(program_penetration(problem, u, taus)) + z, z, beta


def full(problem, cache, settings, timings) -> RawResult:
    """The full model with the conic condition (:mod:`cvxcontact.backends.conic`)."""
    t0 = time.perf_counter()
    model = problem.term.program(problem)
    timings["model"] = time.perf_counter() - t0
    iterations = timed_program(model.problem, settings, timings,
                               conic_options(settings.solver, settings.options, quadratic=problem.quadratic))
    beta = held_beta(problem, bernstein_duals(model.cone, model.row, cone_width(problem)))
    raw = RawResult(u=[v.value for v in model.u], phi=[v.value if v is not None else None for v in model.phi],
                    y=cone_nodal_force(problem, beta), beta=beta, program=model.problem, iterations=iterations,
                    taus=[np.asarray(t.value, dtype=float).ravel() for t in model.t], method="full")
    if not problem.quadratic:
        if settings.polish:
            finish_bulk(problem, timings, raw)
        if not raw.polished:
            raw.route = Route.INTERIOR_POINT_NONLINEAR_ENERGY
    elif condensable(problem):
        if settings.polish:
            finish_cuts(problem, cache, settings, timings, raw)
        certify(problem, cache, settings, timings, raw)
    elif settings.polish:
        finish_cuts_mixed(problem, timings, raw)
    return raw


def condensable(problem) -> bool:
    """Whether the exact finish and the certificate of the cones apply: every body held by its supports (a
    body held by the contact only has no interface compliance) and no force-controlled obstacle (its
    translation has no stiffness). Elsewhere the answer is the interior point's, checked."""
    return not problem.held and not problem.translations


def condensed(problem, cache, settings, timings) -> RawResult:
    """The condensed interface SOCP with the conic condition, then one back-substitution per body. Force-controlled
    obstacles: :func:`~cvxcontact.backends.forced.cones` (bodies held by their supports)."""
    if problem.translations:
        from .forced import cones as forced

        return forced(problem, cache, settings, timings)
    reduction = condensation(problem, cache, settings, timings)
    cond = reduction.bodies
    t0 = time.perf_counter()
    # one forward sweep per body (the condensation's: the finish's load case reads the same), kept for the
    # back-substitution (a body whose factors were freed re-makes its interior factorisation for each sweep:
    # cvxcontact.backends.budget); v0 = Sigma^-1 r needs no backward sweep
    sweeps = [reduction.forward(k, quasi_definite_rhs(b)) for k, b in enumerate(problem.blocks)]
    v0 = [c.unconstrained(f) for c, f in zip(cond, sweeps)]
    B = problem.lines.cone[0]
    w = cone_width(problem)
    free = (B @ (sum(c.jump @ v for c, v in zip(cond, v0)) - problem.g)).reshape(-1, w)
    departure = problem.departure              # a curved obstacle: its own gap, not the interpolant's
    if ((bernstein_max(free) if departure is None else departure.argmax(free)[0]) <= 0.0).all():
        # [u_nu] <= g everywhere with no contact force (e.g. no load, or bodies apart): the unconstrained
        # solution is the solution, beta = 0 exactly; an interior point would stop at rounding around it
        # (measured: u = 5e-8 m under zero load, complementarity read 1.5)
        u, phi = split(cond, [c.factor.backward(f, v) for c, f, v in zip(cond, sweeps, v0)], problem.blocks)
        timings["model"] = time.perf_counter() - t0
        return RawResult(u=u, phi=phi, y=np.zeros(B.shape[1]), beta=np.zeros((B.shape[0] // w, w)),
                         polished=True, route=Route.NO_CONTACT, method="condensed",
                         pairing=None if departure is None else np.zeros(B.shape[0] // w))
    timings["model"] = time.perf_counter() - t0
    if cache.start is not None and settings.warm_start and settings.polish and cone_width(problem) == 3:
        # a state from another mesh (cvxcontact.backends.start): the cuts from its point forces, no program
        raw = RawResult(u=[], phi=[], y=np.zeros(B.shape[1]), route=Route.WARM_START, method="condensed")
        finish_cuts(problem, cache, settings, timings, raw, seeds=cone_seeds(problem, cache.start))
        if raw.polished:
            certify(problem, cache, settings, timings, raw)
            return raw
    t0 = time.perf_counter()
    model = ConicInterfaceModel(cond, [c.stiffness @ v for c, v in zip(cond, v0)], B, problem.g, w)
    timings["model"] = timings.get("model", 0.0) + time.perf_counter() - t0
    iterations = timed_program(model.problem, settings, timings, conic_options(settings.solver, settings.options))
    beta = held_beta(problem, bernstein_duals(model.cone, model.row, w))
    r = cone_nodal_force(problem, beta)
    u, phi = split(cond, [c.back_substitute(f, r) for c, f in zip(cond, sweeps)], problem.blocks)
    raw = RawResult(u=u, phi=phi, y=r, beta=beta, program=model.problem, iterations=iterations,
                    method="condensed")
    if settings.polish:
        finish_cuts(problem, cache, settings, timings, raw)
    certify(problem, cache, settings, timings, raw)
    return raw


def certify(problem, cache, settings, timings, raw) -> None:
    """``raw.certificate``: the energy-norm error bound of the answer's Bernstein duals
    (:func:`~cvxcontact.backends.cuts.energy_bound`; an interior point's duals first moved into the dual cone
    and the fields re-derived from them by one back-substitution, so that the fields are the bound's primal
    point). Only for :func:`condensable` problems; against a curved obstacle's own gap only for the finish's
    point forces (``raw.pairing``: an interior point's duals are those of the interpolant's cones)."""
    if raw.certificate is not None:              # certified by the finish (:func:`_tangency_on_compliance`)
        return
    t0 = time.perf_counter()
    reduction = condensation(problem, cache, settings, timings)
    _, _, d = reduction.apply(problem, timings)
    B = problem.lines.cone[0]
    if not raw.polished:
        raw.beta = dual_cone_point(raw.beta)
        raw.y = cone_nodal_force(problem, raw.beta)
        raw.u, raw.phi = reduction.invert(problem, raw.y, timings)
    departure = problem.departure
    if departure is not None and raw.pairing is None:
        return      # duals of the interpolant's cones: no point forces to pair with the true slack, no bound
    raw.certificate = energy_bound(reduction.W, d, B, raw.beta, problem.held_rows, factors=reduction.psd_factors,
                                   departure=departure, pairing=raw.pairing)[0]
    timings["certificate"] = time.perf_counter() - t0


def finish_cuts(problem, cache, settings, timings, raw, seeds=None) -> None:
    """The exact finish of the cones by accumulated cuts on the interface compliance
    (:func:`~cvxcontact.backends.cuts.interface_cuts`), seeded with the interior point's tangency points and
    forces, or with ``seeds`` (element, t, y0) (:func:`~cvxcontact.backends.start.cone_seeds`: a warm start from
    another mesh); the fields by one back-substitution per body from the nodal force r = P^T y. Updates ``raw``
    (u, phi, y, beta, active: the nodes read by the closed point rows, points, finish) or sets ``raw.declined``."""
    reduction = condensation(problem, cache, settings, timings)
    _, _, d = reduction.apply(problem, timings)
    B = problem.lines.cone[0]
    if seeds is None:
        segment, t = seed_points(B, raw.beta, width=cone_width(problem), around=SEED_SPREAD)
        y0 = seed_forces(segment, t, raw.beta)
    else:
        segment, t, y0 = seeds
    out = interface_cuts(reduction.W, d, problem.g, B, segment, t, timings, y0=y0,
                         width=cone_width(problem), factors=reduction.psd_factors, departure=problem.departure)
    if isinstance(out, Declined):
        raw.declined = out
        return
    r = out["state"]
    raw.u, raw.phi = reduction.invert(problem, r, timings)
    _, active = point_read_back(B, out["segment"], out["t"], out["y"], out["active"])
    raw.y, raw.beta, raw.active, raw.pairing = r, out["beta"], active, out["pairing"]
    raw.points = (out["segment"], out["t"], out["y"])
    raw.polished, raw.finish, raw.declined = True, Finish.ACCUMULATED_CUTS, None
    _tangency_on_compliance(problem, reduction, d, timings, raw, B, out)


def _gamma_values(bodies, u, phi) -> list:
    """Each body's Gamma values v (its contact dofs, :class:`~cvxcontact.backends.condensed.CondensedBody`)."""
    return [np.concatenate([uk] + ([pk] if pk is not None else []))[c.gamma] for c, uk, pk in zip(bodies, u, phi)]


def _tangency_on_compliance(problem, reduction, d, timings, raw, B, cuts) -> None:
    """Newton at the tangency points (:func:`~cvxcontact.backends.tangency.tangency_newton`) after the cuts on the
    interface compliance, as on the mixed route (:func:`_tangency_after_cuts`), on the mixed system (26)
    condensed onto the Gamma dofs (:class:`~cvxcontact.backends.condensed.InterfaceSystem`: the same equations,
    exactly reduced): the cuts' fields are exact only to the square root of their violation, Newton's to
    rounding. Its Gamma values v_N are kept, the fields back-substituted from them (one backward sweep per body),
    the force the admissible one (y >= 0 at points) with the smallest KKT residual for v_N (its balance and its
    complementarity): Newton's multipliers, the cuts', or the non-negative least squares at both sets of points.
    The certificate by the triangle inequality,
    ||v_N - u*|| <= bound(cuts) + ||v_N - v_cuts||_Sigma (the cuts' bound,
    :func:`~cvxcontact.backends.cuts.energy_bound`, is for their fields; both fields are back-substitutions from
    their Gamma values, so the Sigma norm is the energy norm of their difference). Where Newton declines, or
    its answer does not balance the system to :data:`NEWTON_BALANCE_TOL`, the cuts' answer stays
    (:func:`certify` then bounds it). Updates ``raw``."""
    t0 = time.perf_counter()
    bodies = reduction.bodies
    v_cuts = _gamma_values(bodies, raw.u, raw.phi)
    loads = [c.stiffness @ c.unconstrained(f) for c, f in zip(bodies, reduction.sweeps)]
    system = InterfaceSystem(bodies, loads, problem.E)
    out = tangency_newton(system, B, problem.g, raw.beta, system.stack(v_cuts), held=problem.held_rows,
                          tol=MIXED_CUT_TOL, departure=problem.departure,
                          points=(cuts["segment"], cuts["t"], cuts["y"]), max_rounds=NEWTON_ROUNDS)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        return
    x = out["x"]
    A, G, F = system.matrix, system.rows, system.rhs
    load = F - A @ x                                 # what the contact force must balance: G^T r = F - A x

    def balance(r):
        return np.abs(G.T @ r - load).max(initial=0.0) / max(
            (abs(A) @ np.abs(x) + np.abs(F) + abs(G).T @ np.abs(r)).max(initial=0.0), np.finfo(float).tiny)

    # admissible forces (y >= 0 at points: beta in the dual cone) for Newton's x, the one with the smallest KKT
    # residual kept (the larger of the balance and the complementarity products y_p q_p / (Y U_p)): Newton's
    # multipliers, which balance x only to its residual's floor (the rows at the tangency points of nearly flat
    # segments move with x's rounding: 1.3e-11 and 7.9e-10 on the quickstart at 8x4 and 16x8); the cuts' (they
    # balance the cuts' fields, ||x - x_cuts|| away: 2.7e-10, 3.5e-10); the non-negative least squares at
    # Newton's and the cuts' points together (3e-16, but a force may sit where q(x) < 0), and at those of them
    # where q(x) is 0 to Newton's tolerance (complementary, balance 1e-15 ... 3e-14)
    U = segment_scales(B, abs(G) @ np.abs(x) + np.abs(problem.g), cone_width(problem))
    slack = G @ x - problem.g
    departure = problem.departure

    def q(seg, t, P):
        """The slack at the points (a curved obstacle's: less its gap's departure there)."""
        return P @ slack - (0.0 if departure is None else departure.at(seg, t))

    def least_squares(seg, t, start):
        P = point_rows(B, seg, t)
        M = (G.T @ P.T).toarray()
        fit = nnls_warm(M, load, start,                         # each column's scale: the sizes of its terms
                        lambda y: np.abs(M).T @ (np.abs(load) + np.abs(M) @ y) + np.finfo(float).tiny)
        return seg, t, (start if fit is None else fit[0]), P    # (declined: its start, Newton's forces)

    seg_u, t_u = np.concatenate([out["segment"], cuts["segment"]]), np.concatenate([out["t"], cuts["t"]])
    start = np.r_[out["y"], np.zeros(len(cuts["t"]))]
    touching = q(seg_u, t_u, point_rows(B, seg_u, t_u)) >= -MIXED_CUT_TOL * U[seg_u]
    candidates = [(out["segment"], out["t"], out["y"], point_rows(B, out["segment"], out["t"])),
                  (cuts["segment"], cuts["t"], cuts["y"], point_rows(B, cuts["segment"], cuts["t"])),
                  least_squares(seg_u, t_u, start),
                  least_squares(seg_u[touching], t_u[touching], start[touching])]

    def kkt_residual(c):
        seg, t, y, P = c
        products, scale = np.abs(y * q(seg, t, P)), max(float(y.max(initial=0.0)), np.finfo(float).tiny) * U[seg]
        # a segment of zero scale (every term of its slack exactly 0: a block resting exactly on a floor) has
        # q = 0 there: its products 0, not 0/0 = NaN (which max() would pass over, hiding the others); a
        # positive product over a zero scale (a curved obstacle's departure) inf
        products = np.divide(products, scale, out=np.where(products > 0, np.inf, 0.0), where=scale > 0)
        return max(balance(P.T @ y), float(products.max(initial=0.0)))

    seg, t, y, P = _closed_only(min(candidates, key=kkt_residual), B, cone_width(problem), G, x, problem.g, departure,
                                least_squares, kkt_residual)
    r = P.T @ y
    bound = energy_bound(reduction.W, d, B, raw.beta, problem.held_rows, factors=reduction.psd_factors,
                         departure=problem.departure, pairing=raw.pairing)[0]
    if not (balance(r) <= NEWTON_BALANCE_TOL and np.isfinite(bound)):
        return
    v = system.split(x)
    raw.u, raw.phi = reduction.invert_gamma(problem, v, timings)
    S = B.shape[0] // cone_width(problem)
    raw.y, raw.beta, raw.points = r, point_duals(S, seg, t, y), (seg, t, y)
    _, raw.active = point_read_back(B, seg, t, y, y > 0)
    raw.pairing = None if problem.departure is None else problem.departure.pairing(S, seg, t, y)
    raw.finish = Finish.TANGENCY_NEWTON
    apart = sum(float((vk - wk) @ (c.stiffness @ (vk - wk))) for c, vk, wk in zip(bodies, v, v_cuts))
    raw.certificate = bound + np.sqrt(max(apart, 0.0))


def _closed_only(chosen, B, width: int, G, x, g, departure, least_squares, kkt_residual):
    """The point forces ``chosen`` (seg, t, y, P) with none left on an element whose slack is open: the least
    squares at the points of Newton and the cuts together may put forces of 2e-16 .. 7e-6 of the largest on
    elements where q(x) is open everywhere, by 1e-11 .. 1 of the scale (the quickstart at 8x4 .. 24x12,
    docs/checks.md), which the complementarity check reads as a gap. An element is open where its maximum of q
    (``B``'s Bernstein coefficients, ``width`` per element; the true slack against a curved obstacle,
    ``departure``) is below minus the rounding of its coefficients in an exact answer
    (:func:`~cvxcontact.backends.finish.coefficient_rounding` of the slack's terms |G| |x| + |g|). Then of
    ``chosen`` without those forces and the non-negative least squares at its other points, the one with the
    smaller KKT residual. On the elements that touch, a force at a point open beyond its rounding is zeroed where
    the KKT residual stays within :data:`ZEROED_BALANCE`, else kept: refitting without the forces of the cuts'
    points beside a tangency splits them among nearly dependent rows as the rounding falls (the pressure then
    moved by 2.4e-10 under a renumbering of the nodes, tests/test_permuted.py). Unchanged where no force sits on
    an open point."""
    seg, t, y, P = chosen
    b = (B @ (G @ x - g)).reshape(-1, width)
    T, n = slack_terms([G], [x], g)
    rounding = coefficient_rounding(B, T, n).reshape(-1, width).max(axis=1)
    top = bernstein_max(b) if departure is None else departure.argmax(b)[0]
    if departure is not None:
        rounding = rounding + np.finfo(float).eps * np.abs(top - bernstein_max(b))
    kept = top[seg] >= -rounding[seg]
    if (y[~kept] > 0).any():
        chosen = min([(seg[kept], t[kept], y[kept], P[kept]), least_squares(seg[kept], t[kept], y[kept])],
                     key=kkt_residual)
        seg, t, y, P = chosen
    # on the elements that touch: a force at a point open beyond its rounding, zeroed where the balance allows
    size = coefficient_rounding(P, T, n)
    qp = P @ (G @ x - g) - (0.0 if departure is None else departure.at(seg, t))
    far = (y > 0) & (qp < -size)
    if far.any():
        zeroed = (seg, t, np.where(far, 0.0, y), P)
        if kkt_residual(zeroed) <= max(kkt_residual(chosen), ZEROED_BALANCE):
            return zeroed
    return chosen


ZEROED_BALANCE = 1e-15
"""The KKT residual up to which forces at points open beyond rounding on elements that touch are zeroed
(:func:`_closed_only`; a few eps: rounding, not a share of the balance): 1.4e-16 .. 2.1e-16 of the largest force on
the quickstart at 12x6 under the Haswell kernels (PARDISO) and Nehalem (SuperLU) goes (zeroed, its KKT residual
stays at its 8.9e-17 .. 1.1e-16); the forces the quickstart at 8x4 .. 24x12 carries at the cuts' points beside its
tangencies stay (zeroed, its balance read 1.4e-10 .. 1.6e-7: they are part of the answer's balance, not rounding),
and so do those of 1.4e-11 .. 4.4e-10 of the largest on tests/conftest.py's two_blocks((8, 4), (5, 3)) (zeroed:
8.8e-13 .. 2.9e-11 against 2.4e-16 .. 1.2e-14 kept, under the five kernel sets with and without PARDISO; at 1e-12,
Nehalem's SuperLU answer zeroed them at 8.8e-13, equilibrium 9.4e-14 instead of 3e-16, and its pressure moved by
4.8e-11 against the others', tests/test_permuted.py). Kept, such forces read in the complementarity check: on
two_blocks((9, 5), (6, 3)) and ((7, 4), (5, 3)) 1.1e-9 .. 6.3e-9 (0 at 1e-12, which zeroed them at a KKT residual
of 4.6e-15 .. 5.5e-13 and moved their pressure under a renumbering by up to 2.2e-11, now 4.7e-14)."""

NEWTON_ROUNDS = 4
"""Outer rounds of the tangency Newton after the cuts on the interface compliance (its contact structure)."""

NEWTON_BALANCE_TOL = 1e-8
"""The largest residual of the condensed system (26) (the force kept against Newton's x, relative to the terms'
sizes) at which Newton's answer replaces the cuts': a Newton that stopped on a small step far from balance is
not taken (measured: the force kept reads equilibrium 3.5e-16, 2.7e-16, 3.2e-14 on the quickstart at 8x4, 16x8,
20x10)."""


FACTORED = True
"""Whether the rounds of :func:`finish_cuts_mixed` take the factored steps first (one factorisation of the bodies a
round, :class:`~cvxcontact.backends.finish.FactoredRows`) or only the unfactored ones (one sparse LU a step)."""

MIXED_CUT_TOL = 1e-11
"""The cuts' stopping violation on the mixed system: above the tolerance 1e-12 to which each round's active-set
solve closes its rows (measured: with the cuts' own 1e-15 the violation stalls at 1.1e-12 and every round adds
points at the same places)."""


def finish_cuts_mixed(problem, timings, raw, blocks=None, energy=None, keep: dict | None = None) -> None:
    """The exact finish of the cones by accumulated cuts where the interface compliance does not exist (a body
    held by the contact only, a force-controlled obstacle): each round's nodal problem at the cut points is
    solved on the sparse mixed system (26) with the obstacles' translations
    (:func:`~cvxcontact.backends.finish.independent_active_set`: the point rows outnumber the nodes, so they
    depend on each other; the rows carrying the forces stay independent), warm started from the last round,
    on the factored steps (one factorisation of the bodies a round; the unfactored ones, a sparse LU a step,
    where they decline: :data:`FACTORED`). A node's scale counts its neighbours' displacements
    (:func:`~cvxcontact.backends.finish.row_reach`), as the steps' rows do.
    Updates ``raw`` (u, phi, y, beta, taus, active, finish) or sets ``raw.declined``. No certificate: the bound
    needs the compliance; the checks state what holds. ``blocks``: the bodies' blocks (default the problem's;
    :func:`~cvxcontact.backends.forced.gamma_blocks`: condensed onto their Gamma dofs, ``raw.u`` then their
    Gamma values; :func:`~cvxcontact.backends.mixed.tangent_blocks`: a non-quadratic energy's Newton model).
    ``energy``: the Newton at the tangency points after the cuts on the nonlinear (26) of this
    :class:`~cvxcontact.backends.mixed.MixedEnergy` (:func:`finish_bulk`). ``keep``: updated with the cuts'
    answer (segment, t, y: their points and forces) where they reach it."""
    B, cells = problem.lines.cone
    width = cells.shape[1]
    blocks, E, g = problem.blocks if blocks is None else blocks, problem.E, problem.g
    tr = list(problem.translations)
    jumps = [E @ b.jump for b in blocks]
    held = problem.held_rows
    prev = {"y": seed_forces(*seed_points(B, raw.beta, width=width), raw.beta)}
    t0 = time.perf_counter()
    nodes = mixed_kkt(blocks, E, g, translations=tr)
    reach = row_reach(nodes.matrix, nodes.rows)       # each node's scale counts its neighbours' displacements

    def solve(P, delta):
        P = sp.csr_matrix(P)
        gp = P @ g + delta                            # the true gap at the points (delta: 0 on a quadratic gap)
        kkt = mixed_kkt(blocks, P @ E, gp, translations=[(P @ R, F) for R, F in tr])
        y0 = np.zeros(P.shape[0])
        y0[:len(prev["y"])] = prev["y"]
        out = independent_active_set(kkt, gp, y0, y0 > 0, factored=FACTORED, purify=False)
        if isinstance(out, Declined) and FACTORED:         # the factored steps declined: one sparse LU a step
            prev["declined"] = prev.get("declined", 0) + 1
            out = independent_active_set(kkt, gp, y0, y0 > 0, factored=False, purify=False)
        if isinstance(out, Declined):
            prev["why"] = out
            return None
        x, active = out[0], out[1]
        prev["y"] = y = x[2]
        taus = list(x[3]) if tr else []
        parts = [J @ uk for J, uk in zip(jumps, x[0])]
        jump = sum(parts) + problem.row_translation(taus)               # the obstacles moved
        slack, scale = nodal_slack(jump - g, reach @ np.abs(kkt.stack(x)) + np.abs(g), g, held)
        return y, slack, scale, (x, taus), active

    segment, t = seed_points(B, raw.beta, width=width)
    departure = problem.departure
    out = accumulate_cuts(B, solve, segment, t, width=width, tol=MIXED_CUT_TOL, departure=departure)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        why = f"{out} ({prev['why']})" if "why" in prev else str(out)
        if not _finish_tangency(problem, timings, raw, blocks, energy):
            # the decline that stands is the tangency step's (its stop and its rows, on the contact rows; the
            # cuts' rounds' systems are on the cut points), in words that name the cuts' reason first
            raw.declined = raw.declined.within(f"{why}; Newton at the tangency points")
        return
    if keep is not None:
        keep.update(out)
    x, taus = out["state"]
    raw.u, raw.phi = x[0], x[1]
    if tr:
        raw.taus = taus
    raw.y, raw.active = point_read_back(B, out["segment"], out["t"], out["y"], out["active"])
    raw.beta, raw.polished, raw.finish = out["beta"], True, Finish.ACCUMULATED_CUTS
    raw.pairing = out["pairing"]
    _tangency_after_cuts(problem, timings, raw, B, out, blocks, energy)


_FIELDS = ("u", "phi", "y", "beta", "active", "taus", "pairing", "points", "polished", "finish", "declined")
"""What :func:`finish_bulk` puts back where its finish declines (the interior point's answer)."""


def finish_bulk(problem, timings, raw) -> None:
    """The exact finish of the cones beside a non-quadratic bulk energy (a Hencky body; docs/formulation.md §19),
    from the interior point's answer in ``raw``. The cuts and the tangency Newton of a linear material solve
    systems of Kuu; here the energy's tangent takes its place: the accumulated cuts (:func:`finish_cuts_mixed`) on
    the Newton model of the energy at the interior point (:func:`~cvxcontact.backends.mixed.tangent_blocks`),
    whose point forces give the contact structure, then Newton at the tangency points on the nonlinear (26) itself
    (:func:`_newton_finish` with the bodies' :class:`~cvxcontact.backends.mixed.MixedEnergy`: the energy's gradient
    and its tangent at every step, the cones' structure fixed within a round and corrected between rounds), whose
    answer is the nonlinear problem's to rounding. Where the cuts decline, Newton from the interior point's
    structure (:func:`_finish_tangency`). Only Newton's answer is taken: where it declines, ``raw`` keeps the
    interior point's answer with the reason (the cuts' answer is the model's, not the problem's). Updates ``raw``."""
    kept = {k: getattr(raw, k) for k in _FIELDS}
    energy = mixed_system(problem)[0]
    cuts: dict = {}
    finish_cuts_mixed(problem, timings, raw, blocks=tangent_blocks(problem.blocks, raw.u), energy=energy, keep=cuts)
    if raw.finish == Finish.TANGENCY_NEWTON and raw.declined is None:
        return
    why = raw.declined or Declined(Stop.STALL, "Newton at the tangency points on the nonlinear (26) after the cuts "
                                   "on the energy's tangent did not settle")
    if not cuts:                                      # the cuts on the tangent declined: from the interior point
        for k, v in kept.items():
            setattr(raw, k, v)
    # the cuts on the nonlinear (26) itself (3D: the triangles), from the tangent's cuts (their fields and points)
    if finish_cuts_bulk(problem, timings, raw, seeds=(cuts["segment"], cuts["t"], cuts["y"]) if cuts else None):
        return
    why = Declined(why.stop, f"{why}; the accumulated cuts on the nonlinear (26): {raw.declined}", why.rows)
    for k, v in kept.items():
        setattr(raw, k, v)
    raw.declined = why


def _newton_finish(problem, timings, raw, B, blocks=None, **kw):
    """:func:`~cvxcontact.backends.tangency.tangency_newton` on the problem's sparse mixed system (26) from
    ``raw`` (the interior point's fields, translations and Bernstein duals ``raw.beta`` on the rows of ``B``);
    writes the fields, translations, beta and active rows back and marks ``raw`` finished. Returns its dict,
    or its reason (a :class:`~cvxcontact.backends.finish.declined.Declined`) leaving ``raw`` as it was. ``blocks``: as
    in :func:`finish_cuts_mixed`."""
    t0 = time.perf_counter()
    tr = list(problem.translations)
    kkt = mixed_kkt(problem.blocks if blocks is None else blocks, problem.E, problem.g, translations=tr)
    x0 = kkt.stack((raw.u, raw.phi, None, raw.taus if tr else ()))
    out = tangency_newton(kkt, B, problem.g, raw.beta, x0, held=problem.held_rows, tol=MIXED_CUT_TOL, **kw)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        return out
    (u, phi, _, *taus), *_ = kkt.fields(np.zeros(len(problem.g), dtype=bool), out["x"])
    raw.u, raw.phi = u, phi
    if tr:
        raw.taus = list(taus[0])
    raw.beta, raw.active, raw.pairing = out["beta"], out["active"], out["pairing"]
    raw.polished, raw.finish = True, Finish.TANGENCY_NEWTON
    return out


def _tangency_after_cuts(problem, timings, raw, B, cuts, blocks=None, energy=None) -> None:
    """Newton at the tangency points (:func:`_newton_finish`) from the accumulated cuts' answer ``cuts`` (its
    point forces the structure, its fields the start): the cuts close in on a tangency point only linearly
    (the violation shrinks ~4x a round, the fields' error as its square root: measured 1e-6 of the energy norm
    at a violation of 1e-11, a sphere pressed into P2 triangles, the answer then depending on the BLAS kernels),
    Newton reaches rounding in two or three steps. Where it declines, the cuts' answer stays (its violation is
    what the checks report). Updates ``raw`` (fields, beta, active, pairing, y: the nodal force, finish)."""
    out = _newton_finish(problem, timings, raw, B, blocks, departure=problem.departure,
                         points=(cuts["segment"], cuts["t"], cuts["y"]), energy=energy)
    if not isinstance(out, Declined):
        raw.y = out["nodal"]


def _finish_tangency(problem, timings, raw, blocks=None, energy=None) -> bool:
    """Where the cuts decline (a round's mixed system singular: a force-controlled curved obstacle touching
    inside an element), Newton at the tangency points from the interior point's answer (:func:`_newton_finish`).
    Updates ``raw`` and returns True, or sets ``raw.declined`` to its reason."""
    out = _newton_finish(problem, timings, raw, problem.lines.cone[0], blocks, departure=problem.departure,
                         energy=energy)
    if isinstance(out, Declined):
        raw.declined = out
        return False
    raw.y = out["nodal"]
    return True


def conic_mix_model(blocks, E, g, law, weights, B, condensed=None, loads=None, translations=None, width: int = 3):
    """The program of a P2 scene mixing cones and a normal-compliance law (scaled; docs/formulation.md §10,
    "P2"): the energy of every body (full model, or with ``condensed`` bodies and their ``loads`` the
    condensed interface model) plus sum_a w_a Phi_a(r_a) over the compliant rows, the linear rows
    r_a <= l_a of the nodal rows with a finite limit, and the second-order cone of §8 per merged segment of
    every cone pair with the gap g + ``law.cone_shift`` (``law`` a scaled
    :class:`~cvxcontact.contact.quadratic.ConeRowLaws`, ``B`` (3 S, rows) the cone pairs' Bernstein map on
    the rows of ``E``). The model's ``contact``/``limit_rows`` are the linear rows (or None), ``cone`` and
    ``row`` the cone's constraints (their duals the Bernstein duals beta). ``translations``: as in
    :class:`~cvxcontact.backends.full.ContactModel` (full model only): the rows and the cones see R t.
    ``width``: Bernstein coefficients per element, 3 (segments, 2D) or 6 (triangles, 3D: the copositive condition
    of §16 per triangle, B then (6 S, rows))."""
    if condensed is None:
        model = ContactModel(blocks, E, g, law=law, weights=weights, translations=translations)
        jump = model.jump
    else:
        model = InterfaceModel(condensed, loads, E, g, law=law, weights=weights)
        jump = sum((E @ c.jump) @ v for c, v in zip(condensed, model.v))
    model.cone, model.row, _ = bernstein_constraints(jump, B, g + law.cone_shift, width)
    if hasattr(model, "constraints"):
        model.constraints = model.constraints + [model.cone, model.row]
    model.problem = cp.Problem(model.problem.objective, list(model.problem.constraints) + [model.cone, model.row])
    return model


def mixed_bernstein_rows(problem):
    """The cone pairs' Bernstein map on the rows of E: on the cone rows (``rows.cone``, where E is the identity on
    a cone pair's nodes; a limited compliant pair of P2 tetrahedra also has its law's quadrature rows, off the
    cone); None where no cones sit beside a compliance law."""
    if problem.lines.mixed_bernstein is None:
        return None
    on = sp.diags(np.asarray(problem.rows.cone, dtype=float))
    return (problem.lines.mixed_bernstein[0] @ problem.E.T @ on).tocsr()


def mixed_full(problem, cache, settings, timings) -> RawResult:
    """:func:`mixed` on the full program."""
    return mixed(problem, cache, settings, timings, method="full")


def mixed_condensed(problem, cache, settings, timings) -> RawResult:
    """:func:`mixed` on the condensed interface program."""
    return mixed(problem, cache, settings, timings, method="condensed")


def mixed(problem, cache, settings, timings, method: str = "condensed") -> RawResult:
    """P2 with a normal-compliance law on some pair and the "everywhere" cone of §8 on others (docs/
    formulation.md §10, "P2"): the Simpson-lumped compliance energy on the compliant pairs' nodal rows,
    the cone per merged segment of every cone pair (a Signorini "gamma3" pair at g, a limited compliant
    "gamma3" pair at g + l) and the linear rows r <= l of the nodal pairs with a limit (Signorini sigma
    pairs: l = 0) (:func:`conic_mix_model`), full or condensed; interior point with the conic tolerances,
    finished by Newton at the contact structure (:func:`_finish_mixed`, §18), where that is singular (3D: P2
    tetrahedra's triangles, 6 coefficients each, a face in full contact) by accumulated cuts with the law's rows
    (:func:`~cvxcontact.backends.mixedcuts.finish_cuts_compliance`). ``raw.y`` = w p(r) + z,
    ``raw.z`` = (cone force B^T beta) + (multipliers of the linear rows), ``raw.beta`` the Bernstein duals."""
    law, w, E, g = problem.scaled_law, problem.weights, problem.E, problem.g
    B = mixed_bernstein_rows(problem)
    t0 = time.perf_counter()
    cond = None
    if method == "full":
        model = problem.term.program(problem)          # mixed_program
    else:
        reduction = condensation(problem, cache, settings, timings)
        cond = reduction.bodies
        _, loads, _ = reduction.apply(problem, timings)
        model = conic_mix_model(list(problem.blocks), E, g, law, w, B, condensed=cond, loads=loads,
                                width=_mixed_width(problem))
    timings["model"] = time.perf_counter() - t0
    pairs = len(problem.lines.offsets) - 1
    iterations = timed_program(model.problem, settings, timings,
                               conic_options(settings.solver, settings.options, pairs=pairs))
    held = problem.held_rows
    width = _mixed_width(problem)
    beta = held_cone(bernstein_duals(model.cone, model.row, width), B, held, g + law.cone_shift, width)  # least
    z = B.T @ beta.ravel() + release_held(0.0, limit_reaction(model.contact, model.limit_rows, len(g)), held)[1]
    u, phi, r = program_fields(model, problem, cond)
    taus = [np.asarray(t.value, dtype=float).ravel() for t in getattr(model, "t", [])]
    r = r + problem.row_translation(taus)                     # the obstacles moved
    y = w * law.pressure(r) + z
    if cond is not None:
        # the interior dofs for the interior point's Gamma values v (one backward sweep each), as the full
        # model's u: r and the cone stay the program's. Back-substituting the force y instead carried the
        # power cone's error in y into r (complementarity ~4e-5 with m != 1, measured; here 6e-8)
        u, phi = reduction.invert_gamma(problem, [v.value for v in model.v], timings)
    raw = RawResult(u=u, phi=phi, y=y, z=z, beta=beta, taus=taus, program=model.problem, iterations=iterations,
                    method=method)
    if settings.polish and not _finish_mixed(problem, timings, raw, B):
        why = raw.declined
        raw.declined = None
        if finish_cuts_compliance(problem, timings, raw, B):     # a singular tangency step: the cuts (3D)
            return raw
        if why and raw.declined and raw.declined.stop is not Stop.NOT_POSED:
            why = Declined(why.stop, f"{why}; the accumulated cuts: {raw.declined}", why.rows)
        raw.declined = None
        if (not problem.held and not problem.translations and not law.cone.all()
                and not (law.cone & law.rows).any()):
            _finish_nodal_rows(problem, cache, settings, timings, raw, r)
        elif why:
            raw.declined = why
    return raw


def _finish_mixed(problem, timings, raw, B) -> bool:
    """The exact finish of a cone/compliance program (docs/formulation.md §18): Newton on its KKT system at a
    fixed contact structure (vertex rows and tangency points of the cones, the compliant rows in penetration,
    the active limit rows) on the sparse mixed system, from the interior point's answer (:func:`_newton_finish`).
    Updates ``raw`` and returns True, or sets ``raw.declined`` and returns False."""
    law, g = problem.scaled_law, problem.g
    scale = float(np.abs(raw.y).max(initial=0.0))
    start = raw.z - B.T @ raw.beta.ravel() > 1e-6 * max(scale, np.finfo(float).tiny)    # limit rows carrying force
    out = _newton_finish(problem, timings, raw, B, cone_gap=g + law.cone_shift, law=law, weights=problem.weights,
                         limit=law.penetration_limit, limit_start=start, force_scale=scale)
    if isinstance(out, Declined):
        raw.declined = out.within("Newton at the contact structure")
        return False
    raw.z = out["nodal"] + out["z"]
    raw.y = out["pressure"] + raw.z
    return True


def _finish_nodal_rows(problem, cache, settings, timings, raw, r):
    """The exact finish of the nodal rows of the cone/compliance program (docs/formulation.md §10, "P2"):
    with the cones' force y_C of the interior point held, the nodal rows R (compliance, their limits,
    Signorini sigma rows) solve r_R = d_R - W_RC y_C - W_RR y_R with their laws exactly
    (:func:`~cvxcontact.backends.compliance.newton`), and every body's unknowns are back-substituted from the
    forces (one per body). Only when every cone pair is a Signorini pair (y_C = B^T beta, the duals): the force
    of a compliant cone pair, w p(r) of the interior point's r, would carry its error into r. On pairs that
    share no body with a cone pair this is the exact answer of those pairs alone; elsewhere the cones' rows
    see the finished y_R, which the cone checks measure. Updates ``raw`` (u, phi, y, z, finish) in place, or
    sets ``raw.declined`` if the steps do not settle."""
    law, w = problem.scaled_law, problem.weights
    reduction = condensation(problem, cache, settings, timings)
    compliance = reduction.compliance
    _, _, d = reduction.apply(problem, timings)
    t0 = time.perf_counter()
    y, z = raw.y, raw.z
    R, C = np.flatnonzero(~law.cone), np.flatnonzero(law.cone)
    rows = law.off_cone()
    W = compliance.W
    start = None
    if (rows.limited & ~rows.rows).any():             # Signorini rows: start from the IPM's active set
        start = rows.limited & (z[R] * np.diag(W)[R] + (r[R] - rows.penetration_limit) > 0)
    out = newton(W[np.ix_(R, R)], d[R] - W[np.ix_(R, C)] @ y[C], w[R], rows, r[R], start)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = out.within("the nodal rows beside the cones")
        return
    raw.finish = out[3]
    new_y, new_z = y.copy(), z.copy()
    new_y[R], new_z[R] = out[0], out[1]
    raw.u, raw.phi = reduction.invert(problem, new_y, timings)
    raw.y, raw.z = new_y, new_z
