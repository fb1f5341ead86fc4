"""The route of a friction law (Tresca, :class:`~cvxcontact.contact.laws.Tresca`): the full program with the
friction energy (docs/howto/friction.md).

    minimise   (the full program of :mod:`cvxcontact.backends.full`) + sum_a c_a |s_a|
    subject to s = E [u_t] + E [u_D t]           (the slip at the contact rows)
               E [u_nu] + R t <= E g              (Signorini rows)

with c_a = g_a w_a the friction capacity of row a (threshold g_a times its lumped length w_a, scaled). In 2D
|s_a| is an absolute value (a second-order cone of one component). The multiplier of the slip rows is the
tangential force of each row: with the momentum rows K u - f + J^T y + T^T mu = 0, ``mu`` lies in
[-c_a, c_a] and mu_a = c_a sign(s_a) where the row slips; the force on the first body along t is -mu_a.

No exact finish: the answer is the interior point's (Clarabel at the conic tolerances,
:data:`~cvxcontact.backends.program.CLARABEL_CONIC`), checked (:mod:`cvxcontact.solution.friction`).
"""

from __future__ import annotations

import time

import cvxpy as cp
import numpy as np

from .finish import force_displacements, ipm_active, reach_forces
from .full import ContactModel
from .program import conic_options, timed_program
from .result import RawResult, Route

__all__ = ["full", "friction_program"]


def friction_program(problem, model: ContactModel):
    """(the CVXPY problem, the slip equality constraint, its rows) of ``problem``'s friction term added to
    ``model`` (the full program of the normal rows): one slip variable per frictional row."""
    E, rows = problem.E, np.flatnonzero(problem.rows.frictional)
    capacity = (problem.thresholds * problem.row_lengths)[rows]
    slip_rows = E[rows]
    slip = sum((slip_rows @ b.slip) @ u for b, u in zip(problem.blocks, model.u) if u.size) \
        + slip_rows @ np.broadcast_to(np.asarray(problem.prescribed_slip, dtype=float), (E.shape[1],))
    s = cp.Variable(len(rows), name="slip")
    constraint = s == slip
    program = model.with_terms([constraint], objective=capacity @ cp.abs(s))
    return program, constraint, rows


def full(problem, cache, settings, timings) -> RawResult:
    """The full program with the friction energy (module docstring); the normal rows' forces ``y`` and the
    tangential row forces ``raw.tangential`` (scaled) from its duals, no exact finish."""
    t0 = time.perf_counter()
    E, g, blocks, tr = problem.E, problem.g, problem.blocks, list(problem.translations)
    model = ContactModel(blocks, E, g, translations=tr)
    program, constraint, rows = friction_program(problem, model)
    timings["model"] = time.perf_counter() - t0
    iterations = timed_program(program, settings, timings, conic_options(settings.solver, settings.options))
    u = [np.asarray(v.value, dtype=float).ravel() if v.size else np.zeros(0) for v in model.u]
    phi = [np.asarray(v.value, dtype=float).ravel() if v is not None else None for v in model.phi]
    y = np.asarray(model.contact.dual_value, dtype=float).ravel()
    mu = np.zeros(E.shape[0])
    mu[rows] = -np.asarray(constraint.dual_value, dtype=float).ravel()     # CVXPY: L = ... + nu^T (s - slip)
    raw = RawResult(u=u, phi=phi, y=y, program=program, taus=[np.asarray(t.value, dtype=float).ravel()
                                                                 for t in model.t],
                    method="full", iterations=iterations, route=Route.INTERIOR_POINT_FRICTION)
    moved = g - sum((R @ tau for (R, _), tau in zip(tr, raw.taus)), np.zeros(len(g)))
    parts = [E @ (b.jump @ uk) for b, uk in zip(blocks, u)]
    raw.active = ipm_active(parts, moved, y, force_displacements(blocks, E, y), reach_forces(blocks, E, u, phi))
    raw.tangential = mu
    return raw
