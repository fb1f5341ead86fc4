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
from collections.abc import Mapping
from dataclasses import replace

from .backends import DEFAULT_METHOD, METHODS, choose, describe
from .backends.result import Cache, Settings
from .backends.run import run
from .contact.laws import ContactLaw, check_law, check_law_for
from .discrete import DiscreteProblem, build_problem
from .errors import ResidualWarning, ResolutionWarning, SceneError, SolverError
from .fem.space import space
from .physics.scene import Scene
from .solution.estimate import estimate as estimate_error
from .solution.info import Route, SolveInfo, Status
from .solution.readback import read_back
from .solution.resolution import unresolved
from .solution.solution import ContactResult, Solution

__all__ = ["solve", "ContactSolver", "Solution", "ContactResult", "SolveInfo", "Status", "Route", "DEFAULT_TOL",
           "METHODS", "DEFAULT_METHOD"]

log = logging.getLogger(__name__)

DEFAULT_TOL = 1e-6
"""Default tolerance of the mixed-formulation checks."""

def solve(scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = DEFAULT_METHOD,
          tol: float = DEFAULT_TOL, polish: bool = True, verbose: bool = False,
          solver_options: Mapping[str, object] | None = None, law: ContactLaw | None = None,
          degree: int = 1, factorization: str = "auto", estimate: bool = True) -> Solution:
    """Solve the frictionless contact problem of ``scene`` as a convex program.

    Parameters
    ----------
    scene : Scene
    condition : {"gamma3", "sigma1", "sigma2"}
        Non-penetration on K_h(Gamma_3) (every merged node) or K_h(Sigma_h^l) (nodes of mesh l).
    solver : str
        A CVXPY solver name; Clarabel by default (with tolerances tightened to 1e-10).
    method : {"auto", "amg", "sparse", "condensed", "full"}
        ``"auto"`` (default): the fastest backend that accepts the problem
        (:func:`cvxcontact.backends.choose`); for the package's own problems (quadratic
        energy, linear contact rows) that is ``"condensed"``, or ``"sparse"`` for a long interface with the
        Signorini law (more contact rows m than :data:`cvxcontact.backends.SPARSE_SLENDER` x sqrt(unknowns),
        or than :data:`cvxcontact.backends.SPARSE_ROWS`); a condensed answer that fails its checks falls
        back to ``"sparse"`` (``Route.SPARSE_FALLBACK``); ``"amg"`` for a 3D scene of at least
        :data:`cvxcontact.backends.AMG_UNKNOWNS` unknowns when pyamg is installed (``cvxcontact[amg]``): the
        sparse route's steps with AMG-preconditioned Krylov solves (:mod:`cvxcontact.backends.amg`).
        ``"sparse"`` (:mod:`cvxcontact.backends.sparse`) runs exact active-set steps on the sparse mixed
        system (26) of every body, no dense interface matrix and no interior point. ``"full"`` (the reference)
        poses the whole phi-form model in CVXPY, so that ``Solution.problem`` has the
        variables ``u1, phi1, u2, ...``. ``"condensed"`` (fast, exact) factorises each body
        once, condenses it onto its contact dofs (:mod:`cvxcontact.backends.condensed`) and
        poses only the small interface QP in CVXPY. ``Solution.info.method`` names the
        backend used.
    tol : float
        Tolerance of the mixed-formulation checks. A solution that fails them is
        returned with ``ok = False`` and a :class:`ResidualWarning`.
    polish : bool
        Exact finish (default): from the active set of the interior-point answer,
        solve the mixed system (26) with the contact closed there and correct the set
        by primal-dual active-set steps until y >= 0 and the open nodes stay feasible
        (:func:`cvxcontact.backends.finish.solve_lcp`; ``Solution.polished``). If that fails the
        interior-point answer stands.
    verbose : bool
        Print the solver's progress.
    solver_options : dict, optional
        Options of the solver, passed to ``cvxpy.Problem.solve``: names to bool, int,
        float or str values (e.g. ``{"max_iter": 100}``). For Clarabel they are checked
        against ``clarabel.DefaultSettings()`` (names, types, ranges) before anything
        is assembled; cvxcontact's own parameters are not accepted here.
    law : Signorini or NormalCompliance, optional
        The normal contact law (:mod:`cvxcontact.contact.laws`; default Signorini, the paper's (8)).
        ``cc.NormalCompliance(stiffness=k, exponent=m)`` poses (7)/(19): the energy gets
        sum_a w_a k/(m+1) r_a+^(m+1) at the constrained nodes of ``condition`` (docs/formulation.md §10).
        With force-controlled obstacles or a body held by the contact only: the full model, finished by
        Newton steps on the sparse mixed system with the law's rows (§10).
    degree : {1, 2}
        1: P1 elements (default). 2: P2 (6-node) elements for u and phi built on the P1 mesh
        (docs/formulation.md §8); ``"gamma3"`` then means [u_h nu] <= g on the whole of every merged
        segment (a second-order cone per segment, solved by the interior point with tight
        tolerances, then finished exactly by accumulated cuts where the problem condenses), ``"sigma1"``/``"sigma2"`` the nodal condition at the P2 nodes
        of that body's trace (linear, with the exact finish). P2 takes every pair of the scene (two bodies
        in any orientation, partial overlap, or a body against a rigid obstacle, fixed or force
        controlled: every condition then constrains the body's P2 trace nodes, "gamma3" on every segment),
        each under its own condition (conic "gamma3" pairs next to sigma pairs: the nodal rows are posed
        as degenerate cones, and the whole solve is an interior point without the exact finish). A
        normal-compliance law with P2 sits on the P2 nodes of the condition's rows ("gamma3": every P2
        node of the merged mesh, no cone) with Simpson weights (docs/formulation.md §10); its penetration
        limit l is nodal under "sigma1"/"sigma2" and, under "gamma3", the "everywhere" cone
        [u_h nu] - g_h <= l on every merged segment (interior point, no exact finish). Compliance pairs next
        to conic pairs (Signorini "gamma3", or a conic limit) are one interior point, whose nodal rows are
        finished exactly with the cones' force held when no cone pair is compliant (§10, "P2").
    factorization : {"auto", "superlu", "pardiso"}
        How each body's matrix is factorised with its contact dofs as a Schur block
        (:mod:`cvxcontact.backends.factor`): "superlu" (SciPy), "pardiso" (Intel oneMKL PARDISO, the optional
        extra ``pip install "cvxcontact[pardiso]"``), "auto" (default) PARDISO if it is installed, else
        SuperLU. Same answer to rounding; ``Solution.info.factorization`` names the one used.
    estimate : bool
        Compute the a posteriori error estimate ``Solution.estimate`` (default; docs/accuracy.md: a residual
        estimator with contact terms, 2D P1 and P2) and check that the contact zone is resolved (a
        :class:`~cvxcontact.errors.ResolutionWarning` otherwise). False skips both.

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
    """A solver prepared for one geometry: meshes, materials, boundary parts and condition.

    ``solve()`` solves the scene it was built with; ``solve(other)`` solves a scene
    that differs only in its loads (body forces, tractions, charges, electrode
    potentials, the gaps: :data:`cvxcontact.physics.loads.LOAD_FIELDS` and ``SCENE_LOAD_FIELDS``; and the
    positions and prescribed forces of rigid obstacles) through ``problem.with_loads(other)``
    (:class:`~cvxcontact.discrete.DiscreteProblem`), reusing the assembled matrices and, with the condensed
    backend (what the default ``method="auto"`` runs), the factorisations and interface stiffnesses while the
    contact rows stay the same (a moved obstacle that reaches other nodes re-derives them and refactorises).
    ``problem`` is the prepared :class:`~cvxcontact.discrete.DiscreteProblem`, ``cache`` what the backend
    keeps between solves. With ``warm_start`` (default) a
    further load case starts from the previous exact active set and is finished by
    active-set steps on the interface (a few dense solves of the size of the active
    set), falling back to the interior-point solve if they do not settle; it then
    costs two triangular solves per body and little else. ``scale=False`` hands the
    raw SI matrices to the solver (for the stability study only: it shows what the
    non-dimensionalisation prevents). ``warm_start`` and ``scale`` are booleans. Other
    parameters as in :func:`solve` (``estimate``: the error estimate and the resolution check of each solve; ``degree=2``: P2 elements; the conic "gamma3" condition is
    re-solved by the interior point each time, the nodal ones warm-start as above); all are
    checked before anything is assembled.
    """

    def __init__(self, scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = DEFAULT_METHOD,
                 tol: float = DEFAULT_TOL, polish: bool = True, warm_start: bool = True, scale: bool = True,
                 verbose: bool = False, solver_options: Mapping[str, object] | None = None,
                 law: ContactLaw | None = None, degree: int = 1, factorization: str = "auto",
                 estimate: bool = True):
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
        if not isinstance(estimate, bool):
            raise SolverError(f"estimate must be True or False (compute the error estimate or not), got {estimate!r}")
        self.estimate = estimate
        discretisation = space(degree, scene.dim)
        t0 = time.perf_counter()
        self.problem: DiscreteProblem = build_problem(scene, discretisation, condition, self.law, scale=scale)
        self._given = scene                 # what solve() without a scene solves
        self._setup = {"assembly": time.perf_counter() - t0}
        self.requested = method
        self.method = choose(method, describe(self.problem))
        log.info("method %r: backend %r (%d bodies, condition %s)", method, self.method,
                 len(self.problem.scene.bodies), self.problem.condition)
        self._cache = Cache()

    # the prepared problem, as attributes of the solver (read-only views)
    scene = property(lambda self: self.problem.scene, doc="The scene of the last solve.")
    condition = property(lambda self: self.problem.condition, doc="The contact condition.")
    degree = property(lambda self: self.problem.space.degree, doc="The element degree (1: P1, 2: P2).")
    solver = property(lambda self: self.settings.solver, doc="The CVXPY solver name.")
    polish = property(lambda self: self.settings.polish, doc="Whether the exact finish runs.")
    factorization = property(lambda self: self.settings.factorization, doc="The factorisation adapter asked for.")

    def solve(self, scene=None) -> Solution:
        """Solve ``scene`` (default: the scene given at construction); see the class docstring."""
        timings, self._setup = dict(self._setup), {}
        t0 = time.perf_counter()
        self.problem = self.problem.with_loads(self._given if scene is None else scene)
        problem = self.problem
        timings["loads"] = time.perf_counter() - t0
        raw = run(self.method, problem, self._cache, self.settings, timings)
        t0 = time.perf_counter()
        sol = read_back(problem, raw, self.tol, timings, self.requested)
        if not sol.ok and self._falls_back(raw):
            sol = self._fallback(problem, sol, timings)
        timings["read_back"] = time.perf_counter() - t0 - timings.get("fallback", 0.0)
        if self.estimate:
            t0 = time.perf_counter()
            sol.estimate, sol.estimate_reason = estimate_error(sol)
            timings["estimate"] = time.perf_counter() - t0
        else:
            sol.estimate_reason = "not computed (estimate=False)"
        sol.info = replace(sol.info, timings=timings)
        log.debug("stage timings (s): %s", ", ".join(f"{k} {v:.4g}" for k, v in timings.items()))
        self._warn(sol, raw)
        if self.estimate:
            for message in unresolved(sol):
                warnings.warn(message, ResolutionWarning, stacklevel=3)
        return sol

    def _falls_back(self, raw) -> bool:
        """True if a condensed answer that fails its checks should be retried by the sparse route (``auto``)."""
        p = self.problem
        return (raw.polished and self.method == "condensed" and self.requested == "auto" and p.nodes is None
                and not p.compliant and not p.held and not p.forced)

    def _fallback(self, problem, sol, timings):
        """The condensed answer is exact on its own interface matrices but fails the checks of (26)-(27): an
        ill-conditioned interface (e.g. a slender layer, whose compliance W loses digits). The sparse route
        solves the mixed system itself (1-2 steps from the condensed active set); it is kept for later load
        cases of this geometry if its answer passes."""
        t1, stages = time.perf_counter(), {}            # its stages are inside "fallback", not added twice
        log.info("the condensed answer fails its checks (%s); falling back to the sparse route",
                 ", ".join(f"{k} {v:.2g}" for k, v in sol.residuals().items() if v > self.tol))
        try:
            raw = run("sparse", problem, self._cache, self.settings, stages)
        except SolverError as exc:
            log.info("the sparse fallback failed (%s); the condensed answer is kept", exc)
            timings["fallback"] = time.perf_counter() - t1
            return sol
        other = read_back(problem, raw, self.tol, timings, self.requested)
        timings["fallback"] = time.perf_counter() - t1
        if not other.ok:
            log.info("the sparse fallback fails its checks too; the condensed answer is kept")
            return sol
        log.info("the sparse fallback passes its checks; later load cases of this geometry use it")
        self.method = "sparse"
        other.info = replace(other.info, route=Route.SPARSE_FALLBACK)
        return other

    def _warn(self, sol, raw) -> None:
        p = self.problem
        if self.settings.polish and not raw.polished and not p.mixed and (raw.declined or not p.conic):
            warnings.warn(f"the exact finish of {p.scene!r} ({p.condition}) was declined ({raw.declined}); "
                          f"the interior-point answer is kept (sol.polished is False):\n{sol.report()}",
                          ResidualWarning, stacklevel=4)
        elif not sol.ok:
            hint = ("\nThis conic P2 'gamma3' answer is the interior point's (no exact finish: polish=False, cones "
                    "next to a compliance law, or a declined finish), which "
                    "stops where it stops (complementarity 1e-7 to 1e-6 on simple scenes, up to 1e-4 with held bodies "
                    "or stacks; docs/formulation.md §8). Pass a tol above what the report shows to accept that answer, "
                    "or use 'sigma1'/'sigma2' (nodal P2 conditions, finished exactly)."
                    if (p.conic or p.mixed) and not raw.polished else "")
            warnings.warn(f"the solution of {p.scene!r} ({p.condition}) fails its checks at tol={self.tol:g}:\n"
                          f"{sol.report()}{hint}", ResidualWarning, stacklevel=4)

    @property
    def cache(self) -> Cache:
        """What the backend keeps between solves of this geometry (condensed bodies, W, the sparse factor)."""
        return self._cache

    def accepts(self, scene) -> bool:
        """Whether ``scene`` differs from the prepared one in its loads only."""
        return self.problem.accepts(scene)
