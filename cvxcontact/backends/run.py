"""One normalised call per backend: :func:`run` picks the route of a backend for the kind of contact term a
problem poses and returns one :class:`~cvxcontact.backends.result.RawResult`.

The kinds (``problem.term.kind``, :mod:`cvxcontact.discrete.terms`; :func:`kind`): ``"signorini"`` (nodal
rows, P1 or P2), ``"compliance"`` (a normal-compliance law on some pair, nodal rows), ``"conic"`` (the P2 "everywhere" cones, §8), ``"mixed"`` (cones next to a compliance
law, §10 "P2") and ``"friction"`` (Signorini rows and a friction law's cones on the slip, docs/howto/friction.md). Each backend of :data:`cvxcontact.backends.BACKENDS` names the function that solves each kind
(``Backend.routes``: :data:`cvxcontact.backends.KINDS`); :func:`route` finds it.
"""

from __future__ import annotations

import importlib
import logging

import numpy as np

from ..errors import SolverError
from ..fem.kernel import check_determined
from .finish import Stop
from . import backend
from .result import RawResult
from .start import start_active

__all__ = ["route", "kind", "run"]

log = logging.getLogger(__name__)


def route(method: str, kind_: str):
    """The function of backend ``method`` (a name of :data:`cvxcontact.backends.BACKENDS`) for problems of
    ``kind_``; SolverError if that backend has none or its "module:function" does not import."""
    where = backend(method).routes.get(kind_)
    if where is None:
        raise SolverError(f"method {method!r} does not solve a {kind_} problem")
    if callable(where):
        return where
    module, name = where.split(":")
    try:
        return getattr(importlib.import_module(module, __package__), name)
    except (ImportError, AttributeError) as exc:
        raise SolverError(f"the {kind_} route {where!r} of backend {method!r} does not import ({exc}); register "
                          f"the function itself or an importable 'module:function'") from exc


def kind(problem) -> str:
    """The kind of contact term ``problem`` poses: ``problem.term.kind`` (:mod:`cvxcontact.discrete.terms`)."""
    return problem.term.kind


def run(method: str, problem, cache, settings, timings) -> RawResult:
    """Solve ``problem`` with the backend ``method`` (a name of :data:`cvxcontact.backends.BACKENDS`), reusing and
    filling ``cache``; the forces of rows no unknown moves at their least admissible value (docs/formulation.md
    §8, "Held nodes": (26)-(27) do not determine them). After an exact finish, a kernel motion that only rows
    open at the solution would hold is refused (:func:`~cvxcontact.fem.kernel.check_determined`; the active
    rows, or with a compliance law the rows that carry a force); so is one that the rows carrying the forces
    leave free where a finish found its system singular (``Stop.SINGULAR_FORCES``; the finish's rows if it
    names them, :attr:`~cvxcontact.backends.finish.declined.Declined.rows`)."""
    term = problem.term
    solver = route(method, term.kind)
    cache = cache.matching(problem.lines.key())
    if cache.start is not None and cache.active is None and term.takes_active_start:
        cache.active = start_active(problem, cache.start)     # a state from another mesh: the first guess
    raw = solver(problem, cache, settings, timings)
    log.info("%s problem (%s): backend %r, %s.%s: route %s%s, %d iterations%s", term.kind, problem.condition,
             method, (getattr(solver, "__module__", None) or "").rsplit(".", 1)[-1],
             getattr(solver, "__name__", type(solver).__name__), raw.route,
             f", finish {raw.finish}" if raw.finish else "", raw.iterations,
             f"; exact finish declined: {raw.declined}" if raw.declined else "")
    active = raw.active
    singular = getattr(raw.declined, "stop", None) is Stop.SINGULAR_FORCES
    if singular and raw.declined.rows is not None:
        active = raw.declined.rows          # the rows carrying the forces in the finish's singular system
    elif active is None and term.active_from_forces and raw.y is not None:   # the rows that carry a force
        y = np.asarray(raw.y, dtype=float)
        active = y > 1e-12 * max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny)
    if active is not None and (raw.polished or singular):
        check_determined(problem.kernel, active)    # a motion only rows open at the solution would hold (a
        # finish whose rows carrying forces cannot hold a body: is it the problem that leaves the body free?)
    if term.zeroes_held_forces:
        raw.y = np.where(problem.held_rows, 0.0, raw.y)
    if not raw.factorization and cache.condensation is not None:
        raw.factorization = cache.condensation.factorization
    return raw
