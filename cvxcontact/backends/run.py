"""One normalised call per backend: :func:`run` picks the route of a backend for the kind of contact term a
problem poses and returns one :class:`~cvxcontact.backends.result.RawResult`.

The kinds (``problem.term.kind``, :mod:`cvxcontact.discrete.terms`; :func:`kind`): ``"signorini"`` (nodal
rows, P1 or P2), ``"compliance"`` (a normal-compliance law on some pair, nodal rows), ``"conic"`` (the P2
"everywhere" cones, §8), ``"mixed"`` (cones next to a compliance law, §10 "P2") and ``"friction"`` (Signorini rows
and a friction law's cones on the slip, docs/howto/friction.md). Each backend of
:data:`cvxcontact.backends.BACKENDS` names the function that solves each kind (``Backend.routes``:
:data:`cvxcontact.backends.KINDS`); :func:`route` finds it.
"""

from __future__ import annotations

import importlib
import logging

from ..errors import SolverError
from ..fem.kernel import check_determined
from . import backend
from .finish.declined import Declined, rows_to_check
from .result import RawResult

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
    filling ``cache``. Each decision is its owner's: the term's first active-set guess from another mesh's state
    (``term.start``), the rows whose hold on the bodies is checked (``term.determining_rows``, and what a
    finish's :class:`~cvxcontact.backends.finish.declined.Declined` says of them:
    :func:`~cvxcontact.backends.finish.declined.rows_to_check`) and the forces it reports (``term.held_forces``:
    Signorini rows no unknown moves at their least admissible value, docs/formulation.md §8, "Held nodes").
    After an exact finish, a kernel motion that only rows open at the solution would hold is refused
    (:func:`~cvxcontact.fem.kernel.check_determined`); so is one that the rows carrying the forces leave free
    where a finish found its system singular (``Stop.SINGULAR_FORCES``). A registered backend's plain-string
    reason for a decline becomes a typed one (:meth:`Declined.of`)."""
    term = problem.term
    solver = route(method, term.kind)
    cache = cache.matching(problem.lines.key())
    term.start(problem, cache)
    raw = solver(problem, cache, settings, timings)
    raw.declined = Declined.of(raw.declined)
    log.info("%s (%s): backend %r, %s.%s: route %s%s, %d iterations%s", type(term).__name__, problem.condition,
             method, (getattr(solver, "__module__", None) or "").rsplit(".", 1)[-1],
             getattr(solver, "__name__", type(solver).__name__), raw.route,
             f", finish {raw.finish}" if raw.finish else "", raw.iterations,
             f"; exact finish declined: {raw.declined}" if raw.declined else "")
    rows = rows_to_check(raw.declined, term.determining_rows(problem, raw), raw.polished)
    if rows is not None:
        check_determined(problem.kernel, rows)   # a motion only rows open at the solution would hold (a finish
        # whose rows carrying forces cannot hold a body: is it the problem that leaves the body free?)
    raw.y = term.held_forces(problem, raw.y)
    if not raw.factorization and cache.condensation is not None:
        raw.factorization = cache.condensation.factorization
    if cache.condensation is not None:
        raw.released = raw.released or cache.condensation.released
    return raw
