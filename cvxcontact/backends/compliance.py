"""Routes for a normal-compliance law on some or all pairs (the paper's (7)/(19); docs/formulation.md §10):
the convex program with the compliance energy (full or condensed), finished exactly by semismooth Newton
steps on the interface, or, with a body held by the contact or force-controlled obstacles, on the sparse
mixed system with the law's rows."""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .condensed import InterfaceModel, quasi_definite
from .finish import solve_compliance, solve_linear_compliance, solve_sparse_compliance
from .full import ContactModel, limit_reaction
from .interface import condensation, program_fields, release_held
from .program import timed_program
from .result import RawResult, Route

__all__ = ["solve", "full", "condensed", "newton"]


def newton(W, d, w, law, r0=None, active=None):
    """:func:`solve_compliance` from (r0, active); if it does not settle and the compliant rows are all
    linear without a limit, the finite LCP of :func:`solve_linear_compliance`. None if neither does."""
    out = solve_compliance(W, d, w, law, r0=r0, active=active)
    if out is None and law.linear:
        out = solve_linear_compliance(W, d, w, law)
    return out


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
    cond = None
    if method == "condensed" or settings.polish:
        reduction = condensation(problem, cache, settings, timings)
        cond, compliance = reduction.bodies, reduction.compliance
        _, loads, d = reduction.apply(problem, timings)
    out = None
    if method == "condensed" and settings.warm_start and settings.polish and cache.active is not None:
        t0 = time.perf_counter()
        out = newton(compliance.W, d, w, law, *cache.active)
        timings["polish"] = time.perf_counter() - t0
        if out is not None:
            raw.route, raw.finish = Route.WARM_START, out[3]
    model = None
    if out is None:
        t0 = time.perf_counter()
        if method == "full":
            model = ContactModel(list(problem.blocks), E, g, law=law, weights=w)
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
            if out is None:
                raise SolverError(f"{settings.solver} failed on the normal-compliance program and the semismooth "
                                  "Newton finish did not settle")
            raw.route, raw.finish = Route.NEWTON_ONLY, out[3]
        else:
            raw.program = model.problem
            raw.u, raw.phi, r = program_fields(model, problem, None if method == "full" else cond)
            raw.z = limit_reaction(model.contact, model.limit_rows, len(g))
            raw.y = w * law.pressure(r) + raw.z
            if settings.polish:
                t0 = time.perf_counter()
                start = None
                if (law.limited & ~law.rows).any():        # Signorini rows: start from the IPM's active set
                    start = law.limited & (raw.z * np.diag(compliance.W) + (r - law.penetration_limit) > 0)
                out = newton(compliance.W, d, w, law, r, start)
                timings["polish"] = time.perf_counter() - t0
                if out is None:
                    raw.declined = "the semismooth Newton steps on the interface did not settle"
                else:
                    raw.finish = out[3]
    if out is not None:
        raw.y, raw.z, raw.polished = out[0], out[1], True
        cache.active = (d - compliance.W @ raw.y, out[2])     # the penetration r and the rows at their limit
    if cond is not None and (raw.polished or method == "condensed"):
        raw.u, raw.phi = reduction.invert(problem, raw.y, timings)
    if not law.limited.any():
        raw.z = None
    return raw


def sparse(problem, settings, timings) -> RawResult:
    """Normal compliance with a body held by the contact only or force-controlled obstacles (docs/
    formulation.md §10-§12): no body can be condensed alone (a singular stiffness) or the obstacles'
    translations tau couple every body they touch, so the full model (the energy with the compliance
    term, the limit rows, the unknowns tau with the work -F . tau) is solved by the interior point and
    finished exactly by Newton steps on the sparse mixed system with the law's rows
    (:func:`~cvxcontact.backends.finish.solve_sparse_compliance`)."""
    law, w, E, g, blocks = problem.scaled_law, problem.weights, problem.E, problem.g, list(problem.blocks)
    tr = list(problem.translations)
    t0 = time.perf_counter()
    model = ContactModel(blocks, E, g, law=law, weights=w, translations=tr)
    timings["model"] = time.perf_counter() - t0
    raw = RawResult(u=None, phi=None, y=None, program=model.problem)
    raw.iterations = timed_program(model.problem, settings, timings)
    u = [np.asarray(v.value, dtype=float) for v in model.u]
    phi = [np.asarray(v.value, dtype=float) if v is not None else None for v in model.phi]
    taus = [np.asarray(t.value, dtype=float).ravel() for t in model.t]
    z = limit_reaction(model.contact, model.limit_rows, len(g))
    r = (sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u))
         + sum((R @ tau for (R, _), tau in zip(tr, taus)), np.zeros(len(g))) - g)
    y = w * law.pressure(r) + z
    if settings.polish:
        t0 = time.perf_counter()
        parts = [quasi_definite(b) for b in blocks]
        widths = [R.shape[1] for R, _ in tr]
        A = sp.block_diag([S for S, _ in parts] + [sp.csr_matrix((sum(widths), sum(widths)))] * bool(widths),
                          format="csr")
        F = np.concatenate([Fk for _, Fk in parts] + [np.asarray(Fo, dtype=float) for _, Fo in tr])
        G = sp.hstack([sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], S.shape[0] - b.Kuu.shape[0]))])
                       for b, (S, _) in zip(blocks, parts)] + [sp.csr_matrix(R) for R, _ in tr]).tocsr()
        x0 = np.concatenate([np.concatenate([uk, pk]) if pk is not None else uk for uk, pk in zip(u, phi)] + taus)
        # the interior point's rows at their limit: reaction beats slack, each relative to its own scale
        Y = max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny)
        U = max(float(np.abs(r + g).max(initial=0.0)), float(np.abs(g).max(initial=0.0)), np.finfo(float).tiny)
        start = law.limited & (z / Y + (r - law.penetration_limit) / U > 0)
        out = solve_sparse_compliance(A, F, G, g, w, law, x0, start)
        timings["polish"] = time.perf_counter() - t0
        if out is None:
            raw.declined = "the Newton steps on the sparse mixed system with the law's rows did not settle"
        else:
            x, y, z = out[0], out[1], out[2]
            raw.polished, raw.finish, pos = True, "semismooth Newton", 0
            u, phi = [], []
            for b, (S, _) in zip(blocks, parts):
                nu, npf = b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]
                u.append(x[pos:pos + nu])
                phi.append(x[pos + nu:pos + nu + npf] if npf else None)
                pos += nu + npf
            taus = list(np.split(x[pos:], np.cumsum(widths)[:-1])) if widths else []
    raw.u, raw.phi, raw.y, raw.taus = u, phi, y, taus
    raw.z = z if law.limited.any() else None
    return raw
