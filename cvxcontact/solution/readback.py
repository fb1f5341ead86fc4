"""One read-back: a backend's :class:`~cvxcontact.backends.result.RawResult` on a
:class:`~cvxcontact.discrete.DiscreteProblem` -> a :class:`~cvxcontact.solution.Solution` in SI, with lambda_h
and the checks of (26)-(27) (docs/checks.md)."""

from __future__ import annotations

from dataclasses import replace

from .friction import read_back_friction
from .info import Route
from .solution import Solution, obstacle_results, read_back_compliance, read_back_conic_mix, read_back_nodal

__all__ = ["read_back"]


def read_back(problem, raw, tol: float, timings: dict, requested: str = "") -> Solution:
    """The Solution of ``raw`` on ``problem`` (scaled -> SI), checked at ``tol``; ``timings`` and ``requested``
    (the ``method=`` asked for) go into its SolveInfo."""
    scene, un = problem.scene, problem.units
    if problem.mixed:
        sol = read_back_conic_mix(problem, raw, tol, timings)
    elif problem.compliant:
        sol = read_back_compliance(problem, raw, tol, timings)
    else:
        sol = read_back_nodal(problem, raw, tol, timings)
    if problem.friction:
        read_back_friction(problem, raw, sol)
    if scene.obstacles:
        obstacle_results(sol, [tau * un.displacement for tau in raw.taus], problem.obstacles)
    route = raw.route
    if raw.polished and route == Route.INTERIOR_POINT:
        route = Route.INTERIOR_POINT_FINISHED
    sol.info = replace(sol.info, method=raw.method, requested=requested or raw.method, route=route,
                       iterations=raw.iterations, timings=timings,
                       finish=raw.finish if raw.polished and raw.finish else None,
                       factorization=raw.factorization)
    return sol
