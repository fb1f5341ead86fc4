"""One read-back: a backend's :class:`~cvxcontact.backends.result.RawResult` on a
:class:`~cvxcontact.discrete.DiscreteProblem` -> a :class:`~cvxcontact.solution.Solution` in SI, with lambda_h
and the checks of (26)-(27) (docs/checks.md)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from types import MappingProxyType

from .friction import read_back_friction
from .info import Route
from .solution import Solution, obstacle_results, read_back_compliance, read_back_conic_mix, read_back_nodal

__all__ = ["read_back", "READ_BACKS"]


def _read_back_tresca(problem, raw, tol: float, timings) -> Solution:
    """Nodal Signorini rows (:func:`~cvxcontact.solution.solution.read_back_nodal`) completed with the friction
    law's slip, shear force and checks (:func:`~cvxcontact.solution.friction.read_back_friction`)."""
    sol = read_back_nodal(problem, raw, tol, timings)
    read_back_friction(problem, raw, sol)
    return sol


READ_BACKS: Mapping[str, Callable] = MappingProxyType({
    "signorini": read_back_nodal, "conic": read_back_nodal, "compliance": read_back_compliance,
    "mixed": read_back_conic_mix, "friction": _read_back_tresca})
"""The read-back of each kind of contact term (``problem.term.kind``, :mod:`cvxcontact.discrete.terms`):
``(problem, raw, tol, timings) -> Solution``, lambda_h and the checks that apply to the term's law."""


def read_back(problem, raw, tol: float, timings: dict, requested: str = "") -> Solution:
    """The Solution of ``raw`` on ``problem`` (scaled -> SI), checked at ``tol``; ``timings`` and ``requested``
    (the ``method=`` asked for) go into its SolveInfo."""
    scene, un = problem.scene, problem.units
    sol = READ_BACKS[problem.term.kind](problem, raw, tol, timings)
    if scene.obstacles:
        obstacle_results(sol, [tau * un.displacement for tau in raw.taus], problem.obstacles)
    route = raw.route
    if raw.polished and route == Route.INTERIOR_POINT:
        route = Route.INTERIOR_POINT_FINISHED
    sol.info = replace(sol.info, method=raw.method, requested=requested or raw.method, route=route,
                       iterations=raw.iterations, timings=timings,
                       finish=raw.finish if raw.polished and raw.finish else None,
                       factorization=raw.factorization, fixed_point=raw.fixed_point or ())
    return sol
