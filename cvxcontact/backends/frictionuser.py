"""A friction law's program beside ``cc.Model``'s user terms (the friction terms' ``beside_user_terms``,
:class:`~cvxcontact.discrete.terms.TrescaFriction`; docs/howto/friction.md, docs/refusals.md row 37).

The program is the friction route's (:func:`~cvxcontact.backends.friction.friction_program`: the Signorini rows,
the slip's cones with the capacities c_a, Coulomb's fixed point on them) with the user constraints and the user
objective added, convex as each of them is; its interior point's answer is finished by the friction finish
(:func:`~cvxcontact.backends.friction.exact_finish`), which takes no user rows. The finished answer is kept where
the user rows do not bind it: every user constraint an inequality that the finished answer satisfies (``admits``).
Then it is the program's answer with them: the KKT conditions of the program without the user rows hold, each user
row is feasible and its multiplier 0 is admissible (complementarity holds), which are the KKT conditions of the
convex program with them. Elsewhere (a user objective, an equality, a constraint the finished answer breaks: a
binding one) the finish is declined (``info.declined`` says why) and the interior point's answer is kept, checked
(its user multipliers the program's duals).
"""

from __future__ import annotations

import copy
import warnings

import numpy as np

from ..errors import FixedPointWarning, user_stacklevel
from .finish import Declined, Stop
from .friction import (
    UNFINISHED_CONES,
    exact_finish,
    finish_on_nodes,
    interior_active,
    interior_answer,
    normal_cone_forces,
    normal_row_forces,
)
from .result import INTERIOR_POINT_KEPT

__all__ = ["beside_user_terms", "cones_beside_user_terms", "tangential_force"]

BINDS = "a user constraint binds, or is an equality, at the friction finish's answer (the finish takes no user rows)"
"""Why the friction finish's answer is not kept beside user constraints (:func:`beside_user_terms`)."""

OBJECTIVE = "a user objective beside a friction law (the friction finish takes no user terms' gradient)"
"""Why the friction finish does not run beside a user objective."""


def beside_user_terms(problem, model, constraints, objective, settings, timings, admits):
    """(raw, force): the friction program of ``problem`` on ``model`` (the term's program of nodal rows, whose
    variables the user ``constraints`` and the scaled ``objective`` are built on) with the user terms, solved with
    ``settings`` (module docstring), then finished by :func:`~cvxcontact.backends.friction.exact_finish` where
    ``admits(raw)`` holds for the finished answer; ``force`` the friction's generalised force on the stacked
    unknowns (:func:`tangential_force`). The terms :class:`~cvxcontact.discrete.terms.TrescaFriction` and
    :class:`~cvxcontact.discrete.terms.FrictionBesideCompliance`."""
    raw, unsettled = interior_answer(problem, settings, timings, normal_row_forces, model, tuple(constraints),
                                     objective)
    raw.active = interior_active(problem, raw)
    return _finished(problem, raw, unsettled, objective, settings, admits,
                     lambda r: exact_finish(problem, r, timings))


def cones_beside_user_terms(problem, model, constraints, objective, settings, timings, admits):
    """(raw, force) as :func:`beside_user_terms` on the P2 "gamma3" cones' program with a friction law (the term
    :class:`~cvxcontact.discrete.terms.ConesWithFriction`): its normal forces the cones' nodal force r = B^T beta,
    finished by :func:`~cvxcontact.backends.friction.finish_on_nodes`."""
    raw, unsettled = interior_answer(problem, settings, timings, normal_cone_forces, model, tuple(constraints),
                                     objective)
    if not settings.polish:
        raw.declined = Declined(Stop.NOT_POSED, UNFINISHED_CONES)
    return _finished(problem, raw, unsettled, objective, settings, admits,
                     lambda r: finish_on_nodes(problem, r, timings))


def _finished(problem, raw, unsettled, objective, settings, admits, finish):
    """(raw, force): the interior point's answer ``raw`` finished by ``finish(raw) -> raw`` where ``admits`` the
    finished answer (module docstring), else kept with its ``declined``; Coulomb's ``unsettled`` warned if no
    finish reached its law."""
    if settings.polish and objective is not None:
        raw.declined = Declined(Stop.NOT_POSED, OBJECTIVE)
    elif settings.polish:
        interior = copy.copy(raw)
        out = finish(raw)
        # a finish's own answer (finished, or a new one: the cuts' kept where the 3D polish declined,
        # frictiontangency.kept; a decline returns ``raw`` itself) is kept only where it admits the user rows
        if (out.polished or out is not raw) and not admits(out):
            out = interior
            out.declined = Declined(Stop.NOT_POSED, BINDS)
        raw = out
    if unsettled and not raw.polished and raw.kept == INTERIOR_POINT_KEPT:     # not the cuts' answer (its own
        warnings.warn(unsettled, FixedPointWarning, stacklevel=user_stacklevel())   # fixed point converged)
    return raw, tangential_force(problem, raw)


def tangential_force(problem, raw) -> np.ndarray:
    """The friction's generalised force on the stacked scaled unknowns [u_1; phi_1; u_2; ...; t_1; ...] of the
    answer ``raw`` (its tangential row forces ``raw.tangential``): T_k^T kron(I_c, E)^T mu on body k's
    displacements (the momentum rows' term, :mod:`cvxcontact.solution.friction`), 0 on the potentials, and
    (kron(I_c, E) S_o)^T mu on a force-controlled obstacle's translations, S_o the slip of its unit translations
    (the friction term's ``data.translations``: the term of its force balance)."""
    mu, data = np.asarray(raw.tangential, dtype=float), problem.term.data
    Tmu = data.rows.T @ mu
    parts = []
    for T, uk, pk in zip(data.operators, raw.u, raw.phi):
        parts.append(T.T @ Tmu if len(uk) else np.zeros(0))
        parts.append(np.zeros(0 if pk is None else len(pk)))
    moves = data.translations or tuple(np.zeros((len(Tmu), len(t))) for t in raw.taus)
    parts.extend(np.asarray(S).T @ Tmu for S in moves)
    return np.concatenate(parts)
