"""One read-back: a backend's :class:`~cvxcontact.backends.result.RawResult` on a
:class:`~cvxcontact.discrete.DiscreteProblem` -> a :class:`~cvxcontact.solution.Solution` in SI, with lambda_h
and the checks of (26)-(27) (docs/checks.md)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import replace

import numpy as np

from ..discrete.terms import TERMS, named
from .friction import obstacle_friction, read_back_friction
from .info import Route
from .nodal import read_back_compliance, read_back_cones, read_back_nodal
from .solution import Solution, obstacle_results

__all__ = ["read_back", "read_back_tresca", "read_back_compliance_friction", "read_back_conic_friction", "READ_BACKS"]


def read_back_tresca(problem, raw, tol: float, timings) -> Solution:
    """Nodal Signorini rows (:func:`~cvxcontact.solution.nodal.read_back_nodal`) completed with the friction
    law's slip, shear force and checks (:func:`~cvxcontact.solution.friction.read_back_friction`)."""
    sol = read_back_nodal(problem, raw, tol, timings)
    read_back_friction(problem, raw, sol)
    return sol


def read_back_compliance_friction(problem, raw, tol: float, timings) -> Solution:
    """A friction law beside a normal-compliance law (the term
    :class:`~cvxcontact.discrete.terms.FrictionBesideCompliance`): the compliance read-back
    (:func:`~cvxcontact.solution.nodal.read_back_compliance`: lambda = p(r) + z / w on the compliant rows, the
    Signorini rows' multipliers, the checks of both laws) completed with the friction law's slip, shear force and
    checks (:func:`~cvxcontact.solution.friction.read_back_friction`). ``raw.z``, the reactions of the rows with a
    finite limit (the Signorini rows', the frictional rows among them), is y - w p(r) there where the route left
    it unset (the interior point's answer)."""
    if raw.z is None:
        law, E, w = problem.scaled_law, problem.E, problem.weights
        r = sum(E @ (b.jump @ uk) for b, uk in zip(problem.blocks, raw.u)) - E @ problem.moved_gap(raw.taus)
        raw = replace(raw, z=np.where(law.limited, raw.y - w * law.pressure(r), 0.0))
    sol = read_back_compliance(problem, raw, tol, timings)
    read_back_friction(problem, raw, sol)
    return sol


def read_back_conic_friction(problem, raw, tol: float, timings) -> Solution:
    """The P2 "gamma3" cones (:func:`~cvxcontact.solution.nodal.read_back_cones`: lambda_h from r = B^T beta, the
    conic checks) completed with the friction law's slip, shear force and checks at the nodes of X_h
    (:func:`~cvxcontact.solution.friction.read_back_friction`, the capacities at the pressures of r)."""
    sol = read_back_cones(problem, raw, tol, timings)
    read_back_friction(problem, raw, sol)
    return sol


class _ReadBacks(Mapping):
    """The read-back each term names, by kind (read-only, always current)."""

    def _terms(self) -> dict:
        return {t.kind: t for t in reversed(tuple(TERMS))}       # the first term of a kind names it

    def __getitem__(self, kind: str) -> Callable:
        return named(self._terms()[kind].reads_back)

    def __iter__(self) -> Iterator[str]:
        return iter(self._terms())

    def __len__(self) -> int:
        return len(self._terms())


READ_BACKS: Mapping[str, Callable] = _ReadBacks()
"""Compatibility view: the read-back of each kind of contact term, ``(problem, raw, tol, timings) -> Solution``,
as the term names it (``problem.term.read_back``, :mod:`cvxcontact.discrete.terms`)."""


def read_back(problem, raw, tol: float, timings: dict, requested: str = "") -> Solution:
    """The Solution of ``raw`` on ``problem`` (scaled -> SI), checked at ``tol``; ``timings`` and ``requested``
    (the ``method=`` asked for) go into its SolveInfo."""
    scene, un = problem.scene, problem.units
    sol = problem.term.read_back(problem, raw, tol, timings)
    if scene.obstacles:
        obstacle_results(sol, [tau * un.displacement for tau in raw.taus], problem.obstacles,
                         obstacle_friction(problem, raw))
    route = raw.route
    if raw.polished and route == Route.INTERIOR_POINT:
        route = Route.INTERIOR_POINT_FINISHED
    sol.info = replace(sol.info, method=raw.method, requested=requested or raw.method, route=route,
                       iterations=raw.iterations, timings=timings,
                       finish=raw.finish if raw.polished and raw.finish else None,
                       factorization=raw.factorization, fixed_point=raw.fixed_point or (), released=raw.released,
                       declined=None if raw.polished else raw.declined,
                       kept=raw.kept if raw.declined is not None and not raw.polished else "",
                       handed_over=raw.handed_over)
    return sol
