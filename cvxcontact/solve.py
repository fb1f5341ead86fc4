"""Solve a scene: the orchestration of the layers below (docs/architecture.md).

:class:`ContactSolver` assembles each body once (:mod:`cvxcontact.fem`), builds the scaled
discrete problem (:mod:`cvxcontact.discrete`), hands it to a backend
(:mod:`cvxcontact.backends`: the full CVXPY model or the condensed interface model), finishes
it exactly (:mod:`cvxcontact.backends.finish`) and reads the answer back with its checks
(:mod:`cvxcontact.solution`).
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace

from .backends import DEFAULT_METHOD, METHODS, backend, choose, describe
from .backends.result import Cache, Settings, declined_words
from .backends.run import run
from .backends.start import ContactState, deferred_state
from .contact.laws import ContactLaw, check_law, check_law_for
from .discrete import DiscreteProblem, build_problem
from .errors import ResidualWarning, ResolutionWarning, SceneError, SolverError, UnsupportedError, user_stacklevel
from .fem.space import space
from .physics.scene import Scene
from .solution.bound import check_covered as check_bound_covered
from .solution.bound import error_bound
from .solution.estimate import estimate as estimate_error
from .solution.info import Route, SolveInfo, Status
from .solution.readback import read_back
from .solution.resolution import rowless, unheld, unresolved
from .solution.solution import ContactResult, Solution

__all__ = ["solve", "ContactSolver", "Solution", "ContactResult", "SolveInfo", "Status", "Route", "DEFAULT_TOL",
           "METHODS", "DEFAULT_METHOD"]

log = logging.getLogger(__name__)

DEFAULT_TOL = 1e-6
"""Default tolerance of the mixed-formulation checks."""

BATCH = 8
"""The load cases whose sweeps :meth:`ContactSolver.solve_many` batches at a time (kept until the batch is read
back: each load and its forward sweep, 16 bytes per unknown and load case; the backward sweep forms three arrays of 8
bytes per unknown and load case at once). two_blocks(560)'s upper block, 471,240 unknowns under PARDISO: a forward
sweep of 1, 2, 4, 8 loads in 66, 51, 25, 18 ms of CPU per load, a backward one in 50, 41, 22, 14
(``benchmarks/resolve_batch_ab.py``)."""

ESTIMATES = {"residual": estimate_error,
             "equilibrated": lambda sol, cache=None, fingerprints=None: (error_bound(sol), "")}
"""The error estimates ``solve(..., estimate=...)`` computes, by name: (the estimate, why there is none) of a
solution (``cache``: what a ContactSolver keeps of its geometry between load cases, under the bodies'
``fingerprints``); ``True`` is "residual"."""


def solve(scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = DEFAULT_METHOD,
          tol: float = DEFAULT_TOL, polish: bool = True, verbose: bool = False,
          solver_options: Mapping[str, object] | None = None, law: ContactLaw | None = None,
          degree: int = 1, factorization: str = "auto", estimate: bool | str = True) -> Solution:
    """Solve the frictionless contact problem of ``scene`` as a convex program.

    Each option in full: docs/reference/solve-options.md.

    Parameters
    ----------
    scene : Scene
        The bodies, their supports and loads (SI units), and the contact pairs.
    condition : {"gamma3", "sigma1", "sigma2"}
        Non-penetration on K_h(Gamma_3) (34), at every merged node, or K_h(Sigma_h^l) (35), at the nodes of
        mesh l.
    solver : str
        A CVXPY solver name; Clarabel by default (tolerances tightened to 1e-10).
    method : {"auto", "amg", "sparse", "condensed", "newton", "full"}
        The backend; "auto" (default): the fastest that accepts the problem. ``Solution.info.method`` names it.
    tol : float
        Tolerance of the checks of (26)-(27) (dimensionless). Failing them: ``ok = False`` and a
        :class:`ResidualWarning`.
    polish : bool
        Exact finish of the interior-point answer (default; ``Solution.polished``).
    verbose : bool
        Print the solver's progress.
    solver_options : dict, optional
        Options passed to ``cvxpy.Problem.solve`` (e.g. ``{"max_iter": 100}``); Clarabel's are checked
        against ``clarabel.DefaultSettings()`` before anything is assembled.
    law : Signorini or NormalCompliance, optional
        The normal contact law: Signorini (8) by default, or normal compliance (7)/(19), stiffness in
        Pa/m^m.
    degree : {1, 2}
        P1 (default) or P2 (6-node) elements for u and phi; with 2, "gamma3" holds on the whole of every
        merged segment (a cone per segment).
    factorization : {"auto", "superlu", "pardiso"}
        The sparse factorisation of each body; "auto": PARDISO if installed, else SuperLU.
    estimate : bool or {"residual", "equilibrated"}
        ``Solution.estimate`` and the resolution check (default; True = "residual"); "equilibrated": the
        guaranteed bound of :func:`cvxcontact.error_bound` (2D P1, elastic or piezoelectric bodies on rigid
        obstacles and in pairs); False: neither (docs/reference/solve-options.md).

    Returns
    -------
    Solution

    Raises
    ------
    SceneError
        ``scene`` is not a Scene or ``condition`` is unknown.
    SolverError
        A bad parameter or solver option, or the solver failed.
    UnsupportedError
        A combination not implemented yet (e.g. force-controlled obstacles with a normal-compliance law).

    See Also
    --------
    ContactSolver : the same, prepared once for many load cases.
    """
    return ContactSolver(scene, condition, solver, method=method, tol=tol, polish=polish, verbose=verbose,
                         solver_options=solver_options, law=law, degree=degree,
                         factorization=factorization, estimate=estimate).solve()


class ContactSolver:
    """A solver prepared for one geometry (meshes, materials, parts, condition), re-solved for other loads.

    ``solve()`` solves the scene it was built with, ``solve(other)`` a scene that differs only in its loads
    (forces, charges, potentials, gaps, the obstacles' positions and forces), reusing the assembly and the
    factorisations. What is reused, the warm start and ``scale``: docs/reference/solve-options.md,
    "Re-solving: ContactSolver". Every parameter is checked before anything is assembled.

    Parameters
    ----------
    scene : Scene
        The geometry and the first load case (SI units).
    condition : {"gamma3", "sigma1", "sigma2"}
        The discrete contact condition, as in :func:`solve`.
    solver : str
        A CVXPY solver name, as in :func:`solve`.
    method : {"auto", "amg", "sparse", "condensed", "newton", "full"}
        The backend, as in :func:`solve`.
    tol : float
        Tolerance of the checks (dimensionless), as in :func:`solve`.
    polish : bool
        Exact finish of the interior-point answer (default).
    warm_start : bool
        Start a further load case from the previous exact active set (default; nodal conditions).
    scale : bool
        Solve in scaled units (default); False hands the SI matrices to the solver (stability study only).
    verbose : bool
        Print the solver's progress.
    solver_options : dict, optional
        Options passed to ``cvxpy.Problem.solve``, as in :func:`solve`.
    law : Signorini or NormalCompliance, optional
        The normal contact law, as in :func:`solve` (stiffness in Pa/m^m).
    degree : {1, 2}
        P1 (default) or P2 elements.
    factorization : {"auto", "superlu", "pardiso"}
        The sparse factorisation of each body.
    estimate : bool
        The a posteriori error estimate and the resolution check of each solve (default).
    start : Solution, optional
        A solution of the same scene on another mesh: the first solve starts from its contact forces
        (``Solution.state``) instead of an interior point; the answer is the exact finish's as without it
        (docs/reference/solve-options.md, "start").

    Attributes
    ----------
    problem : DiscreteProblem
        The prepared problem (:class:`~cvxcontact.discrete.DiscreteProblem`).
    cache : object
        What the backend keeps between solves.
    """

    def __init__(self, scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = DEFAULT_METHOD,
                 tol: float = DEFAULT_TOL, polish: bool = True, warm_start: bool = True, scale: bool = True,
                 verbose: bool = False, solver_options: Mapping[str, object] | None = None,
                 law: ContactLaw | None = None, degree: int = 1, factorization: str = "auto",
                 estimate: bool | str = True, start: Solution | None = None):
        from .backends.options import (check_factorization, check_solve_parameters, check_solver,
                                       check_solver_options)

        if not isinstance(scene, Scene):
            raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
        self.law = check_law_for(scene, check_law(law))   # the default of the pairs without their own law
        self.tol = check_solve_parameters(condition, method, tol, polish=polish, verbose=verbose,
                                          warm_start=warm_start, scale=scale)
        solver = check_solver(solver)
        self.settings = Settings(solver=solver, options=check_solver_options(solver_options, solver),
                                 verbose=verbose, polish=polish, warm_start=warm_start,
                                 factorization=factorization)
        check_factorization(factorization)
        kind = "residual" if estimate is True else estimate
        if estimate is not False and (not isinstance(kind, str) or kind not in ESTIMATES):
            raise SolverError(f"estimate must be True or False (compute the residual error estimate or not) or one "
                              f"of {sorted(ESTIMATES)}, got {estimate!r}")
        discretisation = space(degree, scene.cell)
        if estimate is not False and not discretisation.estimates:
            if estimate is not True:                          # asked by name: refused before anything is solved
                raise UnsupportedError(f"the {kind} error estimate on {scene.cell} cells is not available yet: use "
                                       "estimate=False, or triangles (cc.rectangle(..., cell='triangle'))")
            estimate = False                                  # the default: said in estimate_reason
        if kind == "equilibrated" and estimate is not False:
            check_bound_covered(scene, degree, self.law, condition)   # refused before anything is solved
        self.estimate = ESTIMATES[kind] if estimate is not False else None
        self._unestimated = not discretisation.estimates
        t0 = time.perf_counter()
        self.problem: DiscreteProblem = build_problem(scene, discretisation, condition, self.law, scale=scale)
        self._given = scene                 # what solve() without a scene solves
        self._setup = {"assembly": time.perf_counter() - t0}
        self.requested = method
        self.method = choose(method, describe(self.problem))
        log.info("method %r: backend %r (%d bodies, condition %s)", method, self.method,
                 len(self.problem.scene.bodies), self.problem.condition)
        self._cache = Cache()
        self._cache.start = _start_state(start, scene)
        self._geometry: dict = {}           # what the estimate reads from each body's geometry (its load cases reuse it)

    # the prepared problem, as attributes of the solver (read-only views)
    scene = property(lambda self: self.problem.scene, doc="The scene of the last solve.")
    condition = property(lambda self: self.problem.condition, doc="The contact condition.")
    degree = property(lambda self: self.problem.space.degree, doc="The element degree (1: P1, 2: P2).")
    solver = property(lambda self: self.settings.solver, doc="The CVXPY solver name.")
    polish = property(lambda self: self.settings.polish, doc="Whether the exact finish runs.")
    factorization = property(lambda self: self.settings.factorization, doc="The factorisation adapter asked for.")

    def solve(self, scene=None) -> Solution:
        """Solve ``scene`` (default: the scene given at construction); see the class docstring."""
        t0 = time.perf_counter()
        problem = self.problem.with_loads(self._given if scene is None else scene)
        return self._solve(problem, time.perf_counter() - t0)

    def solve_many(self, scenes: Sequence[Scene]) -> list[Solution]:
        """Solve each of ``scenes`` (load cases of the prepared geometry, each as :meth:`solve` would, in order),
        the sweeps of up to :data:`BATCH` of them at a time batched on the condensed routes: per body one forward
        sweep of their loads as the columns of one right-hand side
        (:meth:`~cvxcontact.backends.interface.Condensation.prepare`) and, where the route finishes exactly on
        the interface, one backward sweep of their fields (:meth:`~cvxcontact.backends.interface.Condensation.
        defer`), its factors read once for all (timed as ``batched_sweeps`` and ``batched_backward`` in the
        stage timings of the first of them; the forward sweep is made when the first route asks for it, inside
        that load case's ``interface_load``: a route that sweeps nothing, e.g. the sparse route a fallback moved
        the solver to, makes none). The answers are :meth:`solve`'s to rounding (a batched sweep sums in
        another order), checked and estimated as :meth:`solve`'s. Every scene is checked against the prepared
        geometry before anything is solved (SceneError, naming what differs; one too if ``scenes`` is a Scene or
        not a sequence of them)."""
        if isinstance(scenes, Scene) or not isinstance(scenes, Iterable):
            raise SceneError(f"solve_many takes a sequence of Scenes (the load cases), got {type(scenes).__name__}; "
                             "one load case: solve(scene) or solve_many([scene])")
        scenes = list(scenes)
        for scene in scenes:
            if not self.problem.accepts(scene):
                self.problem.with_loads(scene)          # the SceneError naming what differs
        out: list = []
        while len(out) < len(scenes):                   # the problems of one batch at a time (each holds its loads)
            t0 = time.perf_counter()
            chunk = [self.problem.with_loads(s) for s in scenes[len(out):len(out) + BATCH]]
            each = (time.perf_counter() - t0) / len(chunk)
            while chunk and not self._cache.prepare(chunk):    # nothing kept (yet, or ever on this route): one
                out.append(self._solve(chunk.pop(0), each))    # alone, its problem derived once
            if chunk:
                out.extend(self._solve_batch(chunk, each))
        return out

    def _solve_batch(self, problems, loads: float) -> list[Solution]:
        """The load cases ``problems`` (their forward sweeps prepared), their backward sweeps held until every
        route has run, then read back in order; after a fallback (the answer failing its checks moved the solver
        to another backend) the rest are solved one at a time, as :meth:`solve` would."""
        condensation, method, runs = self._cache.condensation, self.method, []
        condensation.defer()
        try:
            for problem in problems:
                runs.append((problem, *self._run(problem, loads)))
        finally:
            spent = condensation.flush()
        runs[0][2]["batched_sweeps"] = condensation.swept        # (within the interface_load of the route that
        runs[0][2]["batched_backward"] = spent                   # asked first: the first load case's)
        for _, raw, _ in runs:                          # the fields the flush made (Held lists): plain lists
            raw.u, raw.phi = list(raw.u), list(raw.phi)
        out = []
        for problem, raw, timings in runs:
            if self.method != method:
                out.append(self._solve(problem, loads))
                continue
            self.problem = problem
            out.append(self._read(problem, raw, timings))
        return out

    def _solve(self, problem, loads: float) -> Solution:
        """Solve the load case ``problem`` (:meth:`DiscreteProblem.with_loads` of the prepared one, which took
        ``loads`` seconds)."""
        return self._read(problem, *self._run(problem, loads))

    def _run(self, problem, loads: float):
        """The route's answer on the load case ``problem`` (made the solver's problem) and its stage timings, the
        set-up's since the last solve and ``loads`` seconds of deriving it included."""
        timings, self._setup = dict(self._setup), {}
        self.problem = problem
        timings["loads"] = loads
        return run(self.method, problem, self._cache, self.settings, timings), timings

    def _read(self, problem, raw, timings) -> Solution:
        """The checked, estimated :class:`Solution` of the route's answer ``raw`` on ``problem``."""
        t0 = time.perf_counter()
        self._cache.start = None                                    # a start serves the first solve only
        sol = read_back(problem, raw, self.tol, timings, self.requested)
        sol.defer_state(deferred_state(problem, raw))          # computed when a later solve starts from it
        fallback = None if sol.ok else self._fallback_of(raw)
        if fallback is not None:
            sol = self._fallback(fallback, problem, sol, timings)
        timings["read_back"] = time.perf_counter() - t0 - timings.get("fallback", 0.0)
        unestimated = problem.term.unestimated if self.estimate else ""     # the term's reason, if any
        if unestimated:
            sol.estimate_reason = f"not computed: {unestimated}"
        elif self.estimate:
            t0 = time.perf_counter()
            sol.estimate, sol.estimate_reason = self.estimate(sol, cache=self._geometry,
                                                              fingerprints=problem.fingerprints)
            timings["estimate"] = time.perf_counter() - t0
        elif self._unestimated:
            sol.estimate_reason = (f"not computed: the error estimates do not cover {problem.scene.cell} cells yet "
                                   "(use triangles or tetrahedra for an estimate)")
        else:
            sol.estimate_reason = "not computed (estimate=False)"
        sol.info = replace(sol.info, timings=timings)
        log.debug("stage timings (s): %s", ", ".join(f"{k} {v:.4g}" for k, v in timings.items()))
        self._warn(sol, raw)
        for message in rowless(sol) + unheld(sol):
            warnings.warn(message, ResolutionWarning, stacklevel=user_stacklevel())
        if self.estimate and not unestimated:
            for message in unresolved(sol):
                warnings.warn(message, ResolutionWarning, stacklevel=user_stacklevel())
        return sol

    def _fallback_of(self, raw):
        """The :class:`~cvxcontact.backends.Fallback` of the backend that ran (``auto`` only): an exact answer that
        fails its checks is retried by the backend the entry names if that accepts the problem, else None."""
        fallback = backend(self.method).fallback
        if fallback is None or not raw.polished or self.requested != DEFAULT_METHOD:
            return None
        p = describe(self.problem)
        return fallback if fallback.when(p) and backend(fallback.method).solves(p) else None

    def _fallback(self, fallback, problem, sol, timings):
        """The first answer is exact on its own matrices but fails the checks of (26)-(27) (the condensed route:
        an ill-conditioned interface, e.g. a slender layer, whose compliance W loses digits). The fallback
        backend solves the problem again (the sparse route: 1-2 steps from the condensed active set); it is
        kept for later load cases of this geometry if its answer passes."""
        t1, stages = time.perf_counter(), {}            # its stages are inside "fallback", not added twice
        failed = (f"the {self.method} answer fails its checks ("
                  + ", ".join(f"{k} {v:.2g}" for k, v in sol.residuals().items() if v > self.tol) + ")")
        log.info("%s; falling back to %r", failed, fallback.method)
        try:
            raw = run(fallback.method, problem, self._cache, self.settings, stages)
        except SolverError as exc:
            log.info("the %s fallback failed (%s); the %s answer is kept", fallback.method, exc, self.method)
            timings["fallback"] = time.perf_counter() - t1
            return sol
        other = read_back(problem, raw, self.tol, timings, self.requested)
        other.defer_state(deferred_state(problem, raw))
        timings["fallback"] = time.perf_counter() - t1
        if not other.ok:
            log.info("the %s fallback fails its checks too; the %s answer is kept", fallback.method, self.method)
            return sol
        log.info("the %s fallback passes its checks; later load cases of this geometry use it", fallback.method)
        self.method = fallback.method
        other.info = replace(other.info, route=fallback.route,
                             handed_over="; ".join(r for r in (failed, other.info.handed_over) if r))
        return other

    def _warn(self, sol, raw) -> None:
        p, term = self.problem, self.problem.term
        if term.finish_declined(p, raw, self.settings.polish):
            warnings.warn(f"{declined_words(repr(p.scene), p.condition, raw)}:\n{sol.report()}", ResidualWarning,
                          stacklevel=user_stacklevel())
        elif not sol.ok:
            hint = "" if raw.polished else term.unfinished_hint      # the term's words on its unfinished answer
            warnings.warn(f"the solution of {p.scene!r} ({p.condition}) fails its checks at tol={self.tol:g}:\n"
                          f"{sol.report()}{hint}", ResidualWarning, stacklevel=user_stacklevel())

    @property
    def cache(self) -> Cache:
        """What the backend keeps between solves of this geometry (condensed bodies, W, the sparse factor)."""
        return self._cache

    def accepts(self, scene) -> bool:
        """Whether ``scene`` differs from the prepared one in its loads only."""
        return self.problem.accepts(scene)


def _start_state(start, scene) -> ContactState | None:
    """The :class:`~cvxcontact.backends.start.ContactState` of ``start`` (a Solution or None), checked against
    ``scene`` (typed errors)."""
    if start is None:
        return None
    if not isinstance(start, Solution):
        raise SolverError(f"start must be a Solution of the same scene on another mesh (or None), got "
                          f"{type(start).__name__}")
    if start.scene.dim != scene.dim or len(start.scene.contacts) != len(scene.contacts):
        raise SolverError(f"start: the solution's scene ({start.scene.dim}D, {len(start.scene.contacts)} contact "
                          f"pairs) is not this scene on another mesh ({scene.dim}D, {len(scene.contacts)} pairs)")
    return start.state
