"""Solve a scene: the orchestration of the layers below (docs/architecture.md).

:class:`ContactSolver` assembles each body once (:mod:`cvxcontact.fem`), builds the scaled
discrete problem (:mod:`cvxcontact.discrete`), hands it to a backend
(:mod:`cvxcontact.backends`: the full CVXPY model or the condensed interface model), finishes
it exactly (:mod:`cvxcontact.backends.finish`) and reads the answer back with its checks
(:mod:`cvxcontact.solution`).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from dataclasses import replace

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from .backends import DEFAULT_METHOD, METHODS, ProblemDescription, choose
from .backends.conic import ConicInterfaceModel, bernstein_constraints, bernstein_duals, least_held_duals
from .backends.condensed import Compliance, InterfaceModel, condense, quasi_definite, quasi_definite_rhs
from .backends.finish import (lcp_start, row_scales, signs_hold, solve_compliance, solve_lcp,
                              solve_linear_compliance, solve_sparse_compliance)
from .backends.full import ContactModel, limit_reaction, mixed_kkt
from .contact.laws import ContactLaw, RowLaws, check_law, check_law_for, pair_laws
from .contact.quadratic import ConeRowLaws, bernstein_max, p2_pairs
from .discrete import Block, Units, units
from .errors import ResidualWarning, SceneError, SolverError, UnsupportedError
from .fem import p2
from .fem.assembly import assemble_loads, assemble_matrices
from .fem.kernel import check_determined, check_well_posed
from .geometry.quadratic import P2Nodes
from .physics.fingerprint import geometry_fingerprint
from .physics.scene import Scene
from .solution.checks import force_displacements, ipm_active
from .solution.info import Finish, Route, SolveInfo, Status
from .solution.solution import (ContactResult, Solution, obstacle_results, read_back, read_back_compliance,
                                read_back_conic_mix)

__all__ = ["solve", "ContactSolver", "Solution", "ContactResult", "SolveInfo", "Status", "Route", "DEFAULT_TOL",
           "METHODS", "DEFAULT_METHOD"]

DEFAULT_TOL = 1e-6
"""Default tolerance of the mixed-formulation checks."""

_CLARABEL = dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10, tol_ktratio=1e-8)
_CLARABEL_CONIC = dict(tol_gap_abs=1e-14, tol_gap_rel=1e-14, tol_feas=1e-10, tol_ktratio=1e-10, max_iter=400,
                       equilibrate_enable=False)
"""Clarabel settings of the conic (P2 "gamma3") condition, which has no exact finish (docs/formulation.md §8):
tight gap tolerances; feasibility 1e-10 (tighter stalls at about 1e-11 and ends "inaccurate"); no
equilibration, since the data are already non-dimensionalised (measured: it halves to eightfolds the
complementarity reached by the condensed SOCP on two_blocks 16x8 and 32x16)."""


_CLARABEL_CONIC_PAIRS = dict(max_step_fraction=0.95)
"""Added to :data:`_CLARABEL_CONIC` for the program of P2 cones with a normal-compliance law on several
pairs (docs/formulation.md §10, "P2"; one pair keeps :data:`_CLARABEL_CONIC`, on which its tests were
measured): steps of at most 0.95 of the way to the cone boundary (Clarabel's default 0.99). Measured on 22
solves of tests/test_p2_mixed_laws.py's scenes (both backends, single pairs, decoupled and interacting stacks,
exponent 1): with 0.99, 1 ended "inaccurate" (a compliant pair next to a conic one, condensed: the last step
left the stalled iterate, complementarity 3.5e-5; gap tolerances of 1e-13 did not help); with 0.95 all 22
end "optimal" with complementarity <= 1e-5. With exponent 2 (a power cone) the program still ends
"inaccurate" there (complementarity ~5e-6)."""


def conic_options(solver: str, options: Mapping[str, object]) -> dict:
    """Solver options of the conic condition: no exact finish applies, so Clarabel is run to tighter
    tolerances on the scaled data (:data:`_CLARABEL_CONIC`; the user's ``options`` still win)."""
    return {**(_CLARABEL_CONIC if solver == "CLARABEL" else {}), **options}


def solve(scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = DEFAULT_METHOD,
          tol: float = DEFAULT_TOL, polish: bool = True, verbose: bool = False,
          solver_options: Mapping[str, object] | None = None, law: ContactLaw | None = None,
          degree: int = 1, factorization: str = "auto") -> Solution:
    """Solve the frictionless contact problem of ``scene`` as a convex program.

    Parameters
    ----------
    scene : Scene
    condition : {"gamma3", "sigma1", "sigma2"}
        Non-penetration on K_h(Gamma_3) (every merged node) or K_h(Sigma_h^l) (nodes of mesh l).
    solver : str
        A CVXPY solver name; Clarabel by default (with tolerances tightened to 1e-10).
    method : {"auto", "sparse", "condensed", "full"}
        ``"auto"`` (default): the fastest backend that accepts the problem
        (:func:`cvxcontact.backends.choose`); for the package's own problems (quadratic
        energy, linear contact rows) that is ``"condensed"``, or ``"sparse"`` for a long interface with the
        Signorini law (more contact rows m than :data:`cvxcontact.backends.SPARSE_SLENDER` x sqrt(unknowns),
        or than :data:`cvxcontact.backends.SPARSE_ROWS`); a condensed answer that fails its checks falls
        back to ``"sparse"`` (``Route.SPARSE_FALLBACK``).
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
        tolerances: no exact finish), ``"sigma1"``/``"sigma2"`` the nodal condition at the P2 nodes
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
                         factorization=factorization).solve()


class ContactSolver:
    """A solver prepared for one geometry: meshes, materials, boundary parts and condition.

    ``solve()`` solves the scene it was built with; ``solve(other)`` solves a scene
    that differs only in its loads (body forces, tractions, charges, electrode
    potentials, the gap: :data:`cvxcontact.physics.loads.LOAD_FIELDS` and ``SCENE_LOAD_FIELDS``),
    reusing the assembled matrices and, with the condensed backend (what the default
    ``method="auto"`` runs), the factorisations and interface stiffnesses. With ``warm_start`` (default) a
    further load case starts from the previous exact active set and is finished by
    active-set steps on the interface (a few dense solves of the size of the active
    set), falling back to the interior-point solve if they do not settle; it then
    costs two triangular solves per body and little else. ``scale=False`` hands the
    raw SI matrices to the solver (for the stability study only: it shows what the
    non-dimensionalisation prevents). ``warm_start`` and ``scale`` are booleans. Other
    parameters as in :func:`solve` (``degree=2``: P2 elements; the conic "gamma3" condition is
    re-solved by the interior point each time, the nodal ones warm-start as above); all are
    checked before anything is assembled.
    """

    def __init__(self, scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = DEFAULT_METHOD,
                 tol: float = DEFAULT_TOL, polish: bool = True, warm_start: bool = True, scale: bool = True,
                 verbose: bool = False, solver_options: Mapping[str, object] | None = None,
                 law: ContactLaw | None = None, degree: int = 1, factorization: str = "auto"):
        from .backends.options import (check_factorization, check_solve_parameters, check_solver,
                                       check_solver_options)

        if not isinstance(scene, Scene):
            raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
        self.law = check_law_for(scene, check_law(law))   # the default of the pairs without their own law
        tol = check_solve_parameters(condition, method, tol, polish=polish, verbose=verbose,
                                     warm_start=warm_start, scale=scale)
        held = any(getattr(b, "held_by_contact", None) for b in scene.bodies)   # singular bodies: full backend
        solver = check_solver(solver)
        self.options = check_solver_options(solver_options, solver)
        check_factorization(factorization)
        self.factorization = factorization
        if isinstance(degree, bool) or degree not in (1, 2):
            raise SolverError(f"degree must be 1 (P1) or 2 (P2), got {degree!r}")
        self.degree, self.nodes, self.conic, self._p2, self._cone = degree, None, False, None, None
        self.conic_limit = False                 # P2: a compliance limit under gamma3, the cone at g + l
        self.interface = scene.stack                                   # P1: every pair's rows, stacked
        self.forced = [o for o in scene.obstacles if o.force is not None]     # force-controlled obstacles
        if degree == 2:
            self.nodes = [P2Nodes(b.mesh) for b in scene.bodies]
            pairs = p2_pairs(scene, self.nodes, condition, self.law)    # every pair, as Model poses them (§8)
            self.interface, self._p2, pair_conditions = pairs.interface, pairs.stack, list(pairs.conditions)
            # a compliance law on some pair with cones on others (Signorini "gamma3" pairs at g, limited compliant
            # "gamma3" pairs at g + l): one program, the compliance energy on the nodal rows plus the cones
            # (docs/formulation.md §10, "P2"); the nodal Signorini rows stay linear rows
            self._cone_pairs, self.conic_limit = pairs.cone_pairs, pairs.mixed
            self.conic = pairs.conic_only       # the cone on the gamma3 pairs, nodal rows as cones (§8)
            if self.conic:
                self.E = sp.identity(self._p2.size, format="csr")
                self._cone = self._p2.cone_rows(condition, pair_conditions)
            else:
                self.E = self._p2.evaluation(condition, pair_conditions)
        else:
            self.E = scene.stack.evaluation(condition, scene.conditions)
        self._structure = scene.structure()
        self.scene, self.condition, self.requested = scene, condition, method
        self.method = choose(method, ProblemDescription(
            held_by_contact=held, force_control=bool(self.forced), contact_rows=int(self.E.shape[0]),
            unknowns=sum(len(n.points if n is not None else b.mesh.points) * (3 if b.material.piezoelectric else 2)
                         for b, n in zip(scene.bodies, self.nodes or [None] * len(scene.bodies))),
            compliant=any(lw.compliant for lw in pair_laws(scene, self.law)), conic=self.conic))
        self.held = held
        self._fingerprints = [geometry_fingerprint(b) for b in scene.bodies]   # checked on every solve
        self.solver, self.tol, self.polish, self.verbose = solver, tol, polish, verbose
        t0 = time.perf_counter()
        self.matrices = ([assemble_matrices(b) for b in scene.bodies] if degree == 1 else
                         [p2.assemble_matrices(b, n) for b, n in zip(scene.bodies, self.nodes)])
        self.setup_time = {"assembly": time.perf_counter() - t0}
        self.warm_start, self.scale = warm_start, scale
        self._blocks = self._condensed = self._compliance = self._active = self._sparse = None
        self.rows = (_row_laws(scene, condition, self.law, held) if degree == 1    # each pair's law on its rows
                     else RowLaws(pair_laws(scene, self.law),
                                  np.diff(self._p2.row_offsets(condition, scene.conditions))))
        if self.conic_limit:               # P2: the cone pairs' rows take the cone, not nodal limit rows (§10)
            self.rows = ConeRowLaws(self.rows.laws, self.rows.counts, np.repeat(self._cone_pairs, self.rows.counts))
        self.compliant = self.rows.compliant
        if self.conic_limit and (self.forced or held):
            raise UnsupportedError("P2 elements (degree=2) with cones next to a normal-compliance law (the conic "
                                   "limit under 'gamma3', or Signorini 'gamma3' pairs beside a compliant pair: one "
                                   "program, docs/formulation.md §10) and a force-controlled obstacle or a body held "
                                   "by the contact only are not supported yet; use sigma conditions, or degree=1")
        self._weights = None                                                      # m, the law's quadrature
        if self.compliant:                                                        # P2: Simpson weights (§10)
            self._weights = (scene.stack.weights(condition, scene.conditions) if degree == 1
                             else self._p2.weights(condition, scene.conditions))
        self.path = ""

    def solve(self, scene=None) -> Solution:
        """Solve ``scene`` (default: the scene given at construction); see the class docstring."""
        scene = self._compatible(self.scene if scene is None else scene)
        timings = dict(self.setup_time)
        self.setup_time = {}
        t0 = time.perf_counter()
        if self.degree == 1:
            systems = [assemble_loads(b, m) for b, m in zip(scene.bodies, self.matrices)]
            gap = scene.gap_values()
        else:        # the P2 interpolant of the gap at the merged P2 nodes of every pair
            systems = [p2.assemble_loads(b, m, n) for b, m, n in zip(scene.bodies, self.matrices, self.nodes)]
            gap = np.concatenate([scene.pair_gap_values(i, np.array(itf.x))
                                  for i, itf in enumerate(self._p2.interfaces)])
        obstacles = scene.obstacles if self.degree == 1 else _p2_obstacles(scene, self._p2)
        # the rigid motions only the contact holds: determined by the loads and every pair together (or a SceneError)
        kernel = check_well_posed(scene.bodies, [s.f for s in systems], self.E, self.interface, obstacles, self.nodes)
        forced = [o for o in obstacles if o.force is not None]
        un = units(scene, systems, gap, forces=[o.force for o in forced]) if self.scale else Units(1.0, 1.0, 1.0, 1.0)
        gap = gap / un.displacement
        self._translations = [(self.E @ o.reduced_rows, (o.basis.T @ o.force) / un.force) for o in forced]
        self._taus = [np.zeros(o.basis.shape[1]) for o in forced]
        if self._blocks is None:
            self._blocks = [Block.scaled(s, self.interface.jump(k, len(s.f) // 2), un)
                            for k, s in enumerate(systems)]
        blocks = [blk.with_loads(s, un) for blk, s in zip(self._blocks, systems)]
        allowance = 0.0                  # how far a row may penetrate: 0 (Signorini), l (a compliance limit)
        if self.compliant:
            allowance = np.asarray(self.rows.penetration_limit, dtype=float)
            if hasattr(self.rows, "cone"):                        # the cone rows of the mixed program: g + shift
                allowance = np.where(self.rows.cone, self.rows.cone_shift, allowance)
            allowance = allowance / un.displacement
        self._held_rows = _held(self.E, blocks, self._translations)      # rows no unknown moves (§8)
        _check_reachable(scene, self.interface, self.E, self._held_rows, self.E @ gap + allowance, un)
        timings["loads"] = time.perf_counter() - t0
        run = {"full": self._full, "sparse": self._sparse_solve}.get(self.method, self._condensed_solve)
        if self.conic:
            run = self._conic_full if self.method == "full" else self._conic_condensed
        self.path, self.declined, self.finish_route, self.iterations = Route.INTERIOR_POINT, "", None, 0
        self._beta = None
        if self.compliant:
            u, phi, y, z, polished, problem = self._compliance_solve(blocks, self.E @ gap, un, timings)
            if z is not None and not self.conic_limit:     # (the conic mix releases its own held rows)
                y, z = _release_held(y, z, self._held_rows)
        else:
            u, phi, y, active, polished, problem = run(blocks, self.E @ gap, timings)
            if polished and not self.conic:     # a motion held only by rows open at the solution (fem/kernel.py)
                check_determined(kernel, active)
            y = self._held_forces(y, gap)
        if polished and self.path == Route.INTERIOR_POINT:
            self.path = Route.INTERIOR_POINT_FINISHED
        t0 = time.perf_counter()
        moved = gap - sum((o.reduced_rows @ tau for o, tau in zip(forced, self._taus)), np.zeros(len(gap)))
        if self.conic_limit:        # (force control and held bodies are refused with the conic limit)
            sol = read_back_conic_mix(scene, self.condition, blocks, systems, un, self.E, moved, u, phi, y, z,
                                      self._weights / un.length, self.rows, self.interface, self._cone_B, self._beta,
                                      problem, self.tol, timings, given=self.law, nodes=self.nodes)
        elif self.compliant:        # r = [u_nu] - g with the gap the force-controlled obstacles moved to
            sol = read_back_compliance(scene, self.condition, blocks, systems, un, self.E, moved, u, phi, y, z,
                                       self._weights / un.length, self.rows, polished, problem, self.tol, timings,
                                       given=self.law, interface=None if self.degree == 1 else self.interface,
                                       nodes=self.nodes, beta=self._beta)
        else:
            def read(u, phi, y, active, polished):
                return read_back(scene, self.condition, blocks, systems, un, self.E, moved, u, phi, y, active,
                                 polished, problem, self.tol, timings,
                                 interface=None if self.degree == 1 else self.interface, beta=self._beta,
                                 nodes=self.nodes, cone=self._cone)

            sol = read(u, phi, y, active, polished)
        method = self.method
        if (not sol.ok and polished and method == "condensed" and self.requested == "auto" and self.degree == 1
                and not self.compliant and not self.held and not forced):
            # the condensed answer is exact on its own interface matrices but fails the checks of (26)-(27):
            # an ill-conditioned interface (e.g. a slender layer, whose compliance W loses digits). The sparse
            # route solves the mixed system itself, from the condensed active set (1-2 steps): fall back.
            t1 = time.perf_counter()
            try:
                u, phi, y, active, polished, _ = self._sparse_solve(blocks, self.E @ gap, timings)
            except SolverError:
                pass
            else:
                other = read(u, phi, y, active, polished)
                if other.ok:
                    sol, method = other, "sparse"
                    self.path = Route.SPARSE_FALLBACK
                    self.method = "sparse"         # later load cases of this geometry: the sparse route
            timings["fallback"] = time.perf_counter() - t1
        if scene.obstacles:
            obstacle_results(sol, [tau * un.displacement for tau in self._taus], obstacles)
        timings["read_back"] = time.perf_counter() - t0
        sol.info = replace(sol.info, method=method, requested=self.requested, route=self.path,
                           iterations=self.iterations, timings=timings,
                           finish=Finish(self.finish_route) if polished and self.finish_route else None,
                           factorization=(self._sparse.factorization if method == "sparse" and self._sparse is not None
                                          else ",".join(dict.fromkeys(c.factorization for c in self._condensed or ()))))
        if self.polish and not polished and not self.conic and not self.conic_limit:
            warnings.warn(f"the exact finish of {scene!r} ({self.condition}) was declined ({self.declined}); "
                          f"the interior-point answer is kept (sol.polished is False):\n{sol.report()}",
                          ResidualWarning, stacklevel=3)
        elif not sol.ok:
            hint = ("\nThe conic P2 'gamma3' condition has no exact finish: its interior point stops where it "
                    "stops (complementarity 1e-7 to 1e-6 on simple scenes, up to 1e-4 with held bodies or stacks; "
                    "docs/formulation.md §8). Pass a tol above what the report shows to accept that answer, or use "
                    "'sigma1'/'sigma2' (nodal P2 conditions, finished exactly)." if self.conic or self.conic_limit
                    else "")
            warnings.warn(f"the solution of {scene!r} ({self.condition}) fails its checks at tol={self.tol:g}:\n"
                          f"{sol.report()}{hint}", ResidualWarning, stacklevel=3)
        return sol

    def _interface(self, blocks, timings):
        """Condensed bodies and the interface compliance W, built once per geometry."""
        if self._condensed is None:
            t0 = time.perf_counter()
            meshes = self.nodes or [body.mesh for body in self.scene.bodies]      # P2: the 6-node graph
            self._condensed = [condense(b, s, m, self.factorization)
                               for b, s, m in zip(blocks, self.matrices, meshes)]
            self._compliance = Compliance(self._condensed, self.E)
            timings["factorization"] = time.perf_counter() - t0
        return self._condensed, self._compliance

    def _lcp(self, blocks, g, timings):
        """(rhs, v0, d): per-body right-hand sides, unconstrained Gamma displacements, free slack."""
        condensed, compliance = self._interface(blocks, timings)
        t0 = time.perf_counter()
        rhs = [quasi_definite_rhs(b) for b in blocks]
        self._sweeps = [c.forward(F) for c, F in zip(condensed, rhs)]      # forward sweeps, kept for the back-
        v0 = [c.unconstrained(f) for c, f in zip(condensed, self._sweeps)]  # substitution (one backward sweep)
        d = compliance.free_slack(v0, g)
        timings["interface_load"] = time.perf_counter() - t0
        return rhs, v0, d

    def _finish(self, d, start, timings):
        """Exact LCP solution from the active set ``start``; None (and ``self.declined``) if none."""
        t0 = time.perf_counter()
        out = solve_lcp(self._compliance.W, d, start)
        timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
        if out is None:
            self.declined = "no active set satisfies the signs of the contact problem"
        else:
            self.finish_route = out[2]
        return out

    def _full(self, blocks, g, timings):
        t0 = time.perf_counter()
        tr = self._translations
        model = ContactModel(blocks, self.E, g, translations=tr)
        timings["model"] = time.perf_counter() - t0
        self.iterations = _run(model.problem, self.solver, self.verbose, self.options)
        timings["compile"] = model.problem.compilation_time or 0.0
        timings["solve"] = model.problem.solver_stats.solve_time or 0.0
        u = [v.value for v in model.u]
        phi = [v.value if v is not None else None for v in model.phi]
        y = np.asarray(model.contact.dual_value, dtype=float).ravel()
        self._taus = [np.asarray(t.value, dtype=float).ravel() for t in model.t]
        moved = g - sum((R @ tau for (R, _), tau in zip(tr, self._taus)), np.zeros(len(g)))   # the obstacles moved
        parts = [self.E @ (b.jump @ uk) for b, uk in zip(blocks, u)]
        slack = sum(parts) - moved
        active, polished = ipm_active(parts, moved, y, force_displacements(blocks, self.E, y)), False
        if self.polish and (self.held or tr):
            out = _sparse_finish(mixed_kkt(blocks, self.E, g, translations=tr), g,
                                 active & ~self._held_rows, timings)     # held rows: force 0 (§8)
            if out is None:
                self.declined = "the active-set steps on the sparse mixed system did not settle"
            else:
                (x, active), polished = out, True
                u, phi, y = x[:3]
                if tr:
                    self._taus = list(x[3])
                self.finish_route = "active set"
        elif self.polish:
            _, _, d = self._lcp(blocks, g, timings)
            W = self._compliance.W
            out = self._finish(d, lcp_start(W, d, y, slack), timings)
            if out is not None:
                t0 = time.perf_counter()
                exact = mixed_kkt(blocks, self.E, g)(out[1])      # the full model's own sparse solve
                timings["polish"] += time.perf_counter() - t0
                w, S = row_scales(W, d, out[0])
                if exact is not None and signs_hold(exact[1], exact[2], out[1], w, S):
                    (u, phi, y), active, polished = exact[0], out[1], True
                else:
                    self.declined = "the sparse mixed system on the finished active set is singular or breaks the signs"
        return u, phi, y, active, polished, model.problem

    def _condensed_solve(self, blocks, g, timings):
        condensed, compliance = self._interface(blocks, timings)
        rhs, v0, d = self._lcp(blocks, g, timings)
        warm = self.warm_start and self.polish and self._active is not None
        out = solve_lcp(compliance.W, d, self._active) if warm else None
        problem = None
        if out is not None:                                    # re-solve: the previous active set, corrected
            y, active, polished = out[0], out[1], True
            self.path, self.finish_route = Route.WARM_START, out[2]
        else:
            t0 = time.perf_counter()
            loads = [c.stiffness @ v for c, v in zip(condensed, v0)]
            model = InterfaceModel(condensed, loads, self.E, g)
            timings["model"] = time.perf_counter() - t0
            self.iterations = _run(model.problem, self.solver, self.verbose, self.options)
            timings["compile"] = model.problem.compilation_time or 0.0
            timings["solve"] = model.problem.solver_stats.solve_time or 0.0
            y = np.asarray(model.contact.dual_value, dtype=float).ravel()
            v = [var.value for var in model.v]
            parts = [self.E @ (c.jump @ vk) for c, vk in zip(condensed, v)]
            slack = sum(parts) - g
            active, polished, problem = ipm_active(parts, g, y, force_displacements(blocks, self.E, y)), False, model.problem
            if self.polish:
                out = self._finish(d, lcp_start(compliance.W, d, y, slack), timings)
                if out is not None:
                    y, active, polished = out[0], out[1], True
        if polished:
            self._active = active
        t0 = time.perf_counter()
        x = [c.back_substitute(f, self.E.T @ y) for c, f in zip(condensed, self._sweeps)]
        timings["back_substitution"] = time.perf_counter() - t0
        u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
        phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
        return u, phi, y, active, polished, problem

    def _sparse_solve(self, blocks, g, timings):
        """The sparse route (:mod:`cvxcontact.backends.sparse`): active-set steps on the sparse mixed system
        (26), from the bonded system (first solve) or the previous active set (re-solve); exact, no
        interior point (``polish`` does not apply). ``iterations`` counts the systems solved."""
        from .backends.sparse import SparseContact

        if self._sparse is None:
            self._sparse = SparseContact(blocks, self.E, factorization=self.factorization)
        sc, f0 = self._sparse, self._sparse.factor_time
        t0 = time.perf_counter()
        warm = self.warm_start and self._active is not None
        out = sc.solve(np.concatenate([quasi_definite_rhs(b) for b in blocks]), g, self._active if warm else None)
        if out is None and warm:                               # the previous set led nowhere: from bonded
            out = sc.solve(np.concatenate([quasi_definite_rhs(b) for b in blocks]), g)
            warm = False
        if sc.factor_time > f0:
            timings["factorization"] = timings.get("factorization", 0.0) + sc.factor_time - f0
        timings["active_set"] = time.perf_counter() - t0 - (sc.factor_time - f0)
        if out is None:
            raise SolverError("the active-set steps on the sparse mixed system did not settle (they cycled or met "
                              "a singular system); use method='condensed' or 'full'")
        u, phi, y, active, steps = out
        self._active, self.iterations = active, steps
        self.path = Route.WARM_START if warm else Route.SPARSE_ACTIVE_SET
        self.finish_route = "active set"
        return u, phi, y, active, True, None

    def _compliance_solve(self, blocks, g, un, timings):
        """Normal compliance on some or all pairs (docs/formulation.md §10): the convex program with the
        lumped compliance energy on the compliant rows and r <= l on the limited ones (Signorini rows:
        l = 0), full or condensed, then the exact finish :func:`solve_compliance` on the interface (or,
        if its steps do not settle and every compliant row is linear without a limit, the LCP of
        :func:`solve_linear_compliance`) and one back-substitution per body. Returns (u, phi, row forces
        y, limit reactions z or None if no row has a limit, polished, problem)."""
        if self.conic_limit:
            return self._conic_limit_solve(blocks, g, un, timings)
        if self.held or self._translations:
            return self._compliance_sparse(blocks, g, un, timings)
        law = self.rows.scaled(un.stress * un.load, un.displacement)
        w = self._weights / un.length
        problem, polished, z = None, False, None
        condensed = None
        if self.method == "condensed" or self.polish:
            condensed, compliance = self._interface(blocks, timings)
            rhs, v0, d = self._lcp(blocks, g, timings)
        out = None
        if self.method == "condensed" and self.warm_start and self.polish and self._active is not None:
            t0 = time.perf_counter()
            out = self._newton(compliance.W, d, w, law, *self._active)
            timings["polish"] = time.perf_counter() - t0
            if out is not None:
                self.path, self.finish_route = Route.WARM_START, out[3]
        if out is None:
            t0 = time.perf_counter()
            if self.method == "full":
                model = ContactModel(blocks, self.E, g, law=law, weights=w)
            else:
                loads = [c.stiffness @ v for c, v in zip(condensed, v0)]
                model = InterfaceModel(condensed, loads, self.E, g, law=law, weights=w)
            timings["model"] = time.perf_counter() - t0
            try:
                self.iterations = _run(model.problem, self.solver, self.verbose, self.options)
            except SolverError:
                if not self.polish:
                    raise
                model = None          # the finish converges globally from the free slack (§10)
        if out is None and model is None:
            t0 = time.perf_counter()
            out = self._newton(compliance.W, d, w, law)
            timings["polish"] = time.perf_counter() - t0
            if out is None:
                raise SolverError(f"{self.solver} failed on the normal-compliance program and the semismooth "
                                  "Newton finish did not settle")
            self.path, self.finish_route = Route.NEWTON_ONLY, out[3]
        elif out is None:
            timings["compile"] = model.problem.compilation_time or 0.0
            timings["solve"] = model.problem.solver_stats.solve_time or 0.0
            problem = model.problem
            u, phi, r = _program_fields(model, blocks, None if self.method == "full" else condensed, self.E, g)
            z = limit_reaction(model.contact, model.limit_rows, len(g))
            y = w * law.pressure(r) + z
            if self.polish:
                t0 = time.perf_counter()
                start = None
                if (law.limited & ~law.rows).any():        # Signorini rows: start from the IPM's active set
                    start = law.limited & (z * np.diag(compliance.W) + (r - law.penetration_limit) > 0)
                out = self._newton(compliance.W, d, w, law, r, start)
                timings["polish"] = time.perf_counter() - t0
                if out is None:
                    self.declined = "the semismooth Newton steps on the interface did not settle"
                else:
                    self.finish_route = out[3]
        if out is not None:
            y, z, polished = out[0], out[1], True
            self._active = (d - compliance.W @ y, out[2])     # the penetration r and the rows at their limit
        if condensed is not None and (polished or self.method == "condensed"):
            t0 = time.perf_counter()
            x = [c.back_substitute(f, self.E.T @ y) for c, f in zip(condensed, self._sweeps)]
            timings["back_substitution"] = time.perf_counter() - t0
            u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
            phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
        return u, phi, y, (z if law.limited.any() else None), polished, problem

    def _compliance_sparse(self, blocks, g, un, timings):
        """Normal compliance with a body held by the contact only or force-controlled obstacles (docs/
        formulation.md §10-§12): no body can be condensed alone (a singular stiffness) or the obstacles'
        translations tau couple every body they touch, so the full model (the energy with the compliance
        term, the limit rows, the unknowns tau with the work -F . tau) is solved by the interior point and
        finished exactly by Newton steps on the sparse mixed system with the law's rows
        (:func:`~cvxcontact.backends.finish.solve_sparse_compliance`). Sets ``self._taus`` (scaled).
        Returns (u, phi, row forces y, limit reactions z or None, polished, problem)."""
        law = self.rows.scaled(un.stress * un.load, un.displacement)
        w = self._weights / un.length
        tr = self._translations
        t0 = time.perf_counter()
        model = ContactModel(blocks, self.E, g, law=law, weights=w, translations=tr)
        timings["model"] = time.perf_counter() - t0
        self.iterations = _run(model.problem, self.solver, self.verbose, self.options)
        timings["compile"] = model.problem.compilation_time or 0.0
        timings["solve"] = model.problem.solver_stats.solve_time or 0.0
        u = [np.asarray(v.value, dtype=float) for v in model.u]
        phi = [np.asarray(v.value, dtype=float) if v is not None else None for v in model.phi]
        self._taus = [np.asarray(t.value, dtype=float).ravel() for t in model.t]
        z = limit_reaction(model.contact, model.limit_rows, len(g))
        r = (sum(self.E @ (b.jump @ uk) for b, uk in zip(blocks, u))
             + sum((R @ tau for (R, _), tau in zip(tr, self._taus)), np.zeros(len(g))) - g)
        y = w * law.pressure(r) + z
        polished = False
        if self.polish:
            t0 = time.perf_counter()
            parts = [quasi_definite(b) for b in blocks]
            widths = [R.shape[1] for R, _ in tr]
            A = sp.block_diag([S for S, _ in parts] + [sp.csr_matrix((sum(widths), sum(widths)))] * bool(widths),
                              format="csr")
            F = np.concatenate([Fk for _, Fk in parts] + [np.asarray(Fo, dtype=float) for _, Fo in tr])
            G = sp.hstack([sp.hstack([self.E @ b.jump, sp.csr_matrix((self.E.shape[0], S.shape[0] - b.Kuu.shape[0]))])
                           for b, (S, _) in zip(blocks, parts)] + [sp.csr_matrix(R) for R, _ in tr]).tocsr()
            x0 = np.concatenate([np.concatenate([uk, pk]) if pk is not None else uk for uk, pk in zip(u, phi)]
                                + self._taus)
            # the interior point's rows at their limit: reaction beats slack, each relative to its own scale
            Y = max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny)
            U = max(float(np.abs(r + g).max(initial=0.0)), float(np.abs(g).max(initial=0.0)), np.finfo(float).tiny)
            start = law.limited & (z / Y + (r - law.penetration_limit) / U > 0)
            out = solve_sparse_compliance(A, F, G, g, w, law, x0, start)
            timings["polish"] = time.perf_counter() - t0
            if out is None:
                self.declined = "the Newton steps on the sparse mixed system with the law's rows did not settle"
            else:
                x, y, z = out[0], out[1], out[2]
                polished, self.finish_route, pos = True, "semismooth Newton", 0
                u, phi = [], []
                for b, (S, _) in zip(blocks, parts):
                    nu, npf = b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]
                    u.append(x[pos:pos + nu])
                    phi.append(x[pos + nu:pos + nu + npf] if npf else None)
                    pos += nu + npf
                self._taus = list(np.split(x[pos:], np.cumsum(widths)[:-1])) if widths else []
        return u, phi, y, (z if law.limited.any() else None), polished, model.problem

    def _conic_limit_solve(self, blocks, g, un, timings):
        """P2 with a normal-compliance law on some pair and the "everywhere" cone of §8 on others (docs/
        formulation.md §10, "P2"): the Simpson-lumped compliance energy on the compliant pairs' nodal rows,
        the cone per merged segment of every cone pair (a Signorini "gamma3" pair at g, a limited compliant
        "gamma3" pair at g + l) and the linear rows r <= l of the nodal pairs with a limit (Signorini sigma
        pairs: l = 0) (:func:`conic_mix_model`), full or condensed; interior point with the conic tolerances,
        no exact finish. Returns (u, phi, row forces y = w p(r) + z, reactions z = (cone force B^T beta) +
        (multipliers of the linear rows), False, problem); beta in ``self._beta``, the cone's Bernstein map on
        the stacked nodes of X_h in ``self._cone_B``."""
        law = self.rows.scaled(un.stress * un.load, un.displacement)
        w = self._weights / un.length
        self._cone_B = self._p2.bernstein_of(self._cone_pairs)
        B = (self._cone_B[0] @ self.E.T).tocsr()          # on the rows: E is the identity on a cone pair's nodes
        t0 = time.perf_counter()
        if self.method == "full":
            model = conic_mix_model(blocks, self.E, g, law, w, B)
        else:
            condensed, _ = self._interface(blocks, timings)
            _, v0, _ = self._lcp(blocks, g, timings)
            loads = [c.stiffness @ v for c, v in zip(condensed, v0)]
            model = conic_mix_model(blocks, self.E, g, law, w, B, condensed=condensed, loads=loads)
        timings["model"] = time.perf_counter() - t0
        options = self._conic_options()
        if self.solver == "CLARABEL" and len(self._p2.interfaces) > 1:     # shorter steps (_CLARABEL_CONIC_PAIRS)
            options = {**options, **_CLARABEL_CONIC_PAIRS, **self.options}
        self.iterations = _run(model.problem, self.solver, self.verbose, options)
        timings["compile"] = model.problem.compilation_time or 0.0
        timings["solve"] = model.problem.solver_stats.solve_time or 0.0
        self._beta = bernstein_duals(model.cone, model.row)
        held = self._held_rows
        self._beta = _held_cone(self._beta, B, held, g + law.cone_shift)   # rows no unknown moves: least force
        z = B.T @ self._beta.ravel() + _release_held(0.0, limit_reaction(model.contact, model.limit_rows, len(g)),
                                                     held)[1]
        u, phi, r = _program_fields(model, blocks, None if self.method == "full" else condensed, self.E, g)
        y = w * law.pressure(r) + z
        if self.method != "full":
            # the interior dofs for the interior point's Gamma values v (one backward sweep each), as the full
            # model's u: r and the cone stay the program's. Back-substituting the force y instead carried the
            # power cone's error in y into r (complementarity ~4e-5 with m != 1, measured; here 6e-8)
            t0 = time.perf_counter()
            x = [c.factor.backward(f, v.value) for c, f, v in zip(condensed, self._sweeps, model.v)]
            timings["back_substitution"] = time.perf_counter() - t0
            u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
            phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
        if self.polish and not self.held and not law.cone.all() and not (law.cone & law.rows).any():
            u, phi, y, z = self._finish_nodal_rows(blocks, g, law, w, u, phi, y, z, r, timings)
        return u, phi, y, z, False, model.problem

    def _finish_nodal_rows(self, blocks, g, law, w, u, phi, y, z, r, timings):
        """The exact finish of the nodal rows of the cone/compliance program (docs/formulation.md §10, "P2"):
        with the cones' force y_C of the interior point held, the nodal rows R (compliance, their limits,
        Signorini sigma rows) solve r_R = d_R - W_RC y_C - W_RR y_R with their laws exactly
        (:func:`solve_compliance`, the finish of a nodal compliance scene), and every body's unknowns are
        back-substituted from the forces (one per body), as the conic condensed path does from the cone's
        duals. Only when every cone pair is a Signorini pair (y_C = B^T beta, the duals): the force of a
        compliant cone pair, w p(r) of the interior point's r, would carry its error into r (the comment in
        :meth:`_conic_limit_solve`). On pairs that share no body with a cone pair this is the exact answer
        of those pairs alone; elsewhere the cones' rows see the finished y_R, which the cone checks measure.
        Returns (u, phi, y, z); unchanged (and ``self.declined`` set) if the steps do not settle."""
        condensed, compliance = self._interface(blocks, timings)
        _, _, d = self._lcp(blocks, g, timings)
        t0 = time.perf_counter()
        R, C = np.flatnonzero(~law.cone), np.flatnonzero(law.cone)
        nodal = [not c for c in self._cone_pairs]
        rows = RowLaws([lw for lw, on in zip(law.laws, nodal) if on], [n for n, on in zip(law.counts, nodal) if on])
        W = compliance.W
        start = None
        if (rows.limited & ~rows.rows).any():             # Signorini rows: start from the IPM's active set
            start = rows.limited & (z[R] * np.diag(W)[R] + (r[R] - rows.penetration_limit) > 0)
        out = self._newton(W[np.ix_(R, R)], d[R] - W[np.ix_(R, C)] @ y[C], w[R], rows, r[R], start)
        timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
        if out is None:
            self.declined = "the semismooth Newton steps on the nodal rows did not settle"
            return u, phi, y, z
        self.finish_route = out[3]
        new_y, new_z = y.copy(), z.copy()
        new_y[R], new_z[R] = out[0], out[1]
        t0 = time.perf_counter()
        x = [c.back_substitute(f, self.E.T @ new_y) for c, f in zip(condensed, self._sweeps)]
        timings["back_substitution"] = timings.get("back_substitution", 0.0) + time.perf_counter() - t0
        u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
        phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
        return u, phi, new_y, new_z

    @staticmethod
    def _newton(W, d, w, law, r0=None, active=None):
        """:func:`solve_compliance` from (r0, active); if it does not settle and the compliant rows are all
        linear without a limit, the finite LCP of :func:`solve_linear_compliance`. None if neither does."""
        out = solve_compliance(W, d, w, law, r0=r0, active=active)
        if out is None and law.linear:
            out = solve_linear_compliance(W, d, w, law)
        return out

    def _conic_options(self):
        return conic_options(self.solver, self.options)

    def _conic_full(self, blocks, g, timings):
        """The full model with the P2 "everywhere" condition (:mod:`cvxcontact.backends.conic`)."""
        t0 = time.perf_counter()
        model = ContactModel(blocks, self.E, g, bernstein=self._cone[0], translations=self._translations)
        timings["model"] = time.perf_counter() - t0
        self.iterations = _run(model.problem, self.solver, self.verbose, self._conic_options())
        timings["compile"] = model.problem.compilation_time or 0.0
        timings["solve"] = model.problem.solver_stats.solve_time or 0.0
        self._taus = [np.asarray(t.value, dtype=float).ravel() for t in model.t]     # force-controlled obstacles
        self._beta = bernstein_duals(model.cone, model.row)
        u = [v.value for v in model.u]
        phi = [v.value if v is not None else None for v in model.phi]
        return u, phi, self._contact_force(), None, False, model.problem

    def _conic_condensed(self, blocks, g, timings):
        """The condensed interface SOCP with the P2 "everywhere" condition, then one back-substitution."""
        condensed, _ = self._interface(blocks, timings)
        t0 = time.perf_counter()
        rhs = [quasi_definite_rhs(b) for b in blocks]
        v0 = [c.solve(F)[c.gamma] for c, F in zip(condensed, rhs)]
        B = self._cone[0]
        free = (B @ (sum(c.jump @ v for c, v in zip(condensed, v0)) - g)).reshape(-1, 3)
        if (bernstein_max(free) <= 0.0).all():
            # [u_nu] <= g everywhere with no contact force (e.g. no load, or bodies apart): the unconstrained
            # solution is the solution, beta = 0 exactly; an interior point would stop at rounding around it
            # (measured: u = 5e-8 m under zero load, complementarity read 1.5)
            self._beta, self.iterations, self.path = np.zeros((B.shape[0] // 3, 3)), 0, Route.NO_CONTACT
            x = [c.solve(F) for c, F in zip(condensed, rhs)]
            u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
            phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
            timings["model"] = time.perf_counter() - t0
            return u, phi, np.zeros(B.shape[1]), None, True, None          # exact: polished
        loads = [c.stiffness @ v for c, v in zip(condensed, v0)]
        model = ConicInterfaceModel(condensed, loads, B, g)
        timings["model"] = time.perf_counter() - t0
        self.iterations = _run(model.problem, self.solver, self.verbose, self._conic_options())
        timings["compile"] = model.problem.compilation_time or 0.0
        timings["solve"] = model.problem.solver_stats.solve_time or 0.0
        self._beta = bernstein_duals(model.cone, model.row)
        r = self._contact_force()
        x = [c.solve(F - c.lift(r)) for c, F in zip(condensed, rhs)]
        u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
        phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
        return u, phi, r, None, False, model.problem

    def _held_forces(self, y, gap):
        """The contact forces with those of held rows (:func:`_held`: no unknown moves them, and the checks
        of ``_check_reachable`` leave them a gap >= 0) set to their least admissible value. Such a force acts
        on no unknown, so (26)-(27) do not determine it and the supports carry it: an interior point returns
        an arbitrary, typically huge one (measured: a clamped corner on a rigid floor with g = 0 got 8e8 N/m
        under a 1.4e7 N/m load, and inflated the checks' force scale 4e4 times). Nodal rows: y_a = 0. Conic
        rows: a Bernstein row b_j whose nodes are all held and whose value B g is 0 gets the least beta_j the
        dual cone allows (beta0 = beta1^2 / (4 beta2), both ends held: beta0 = beta2 = beta1 / 2, the
        midpoint row held: the whole segment 0). Equilibrium and complementarity are unchanged (the row
        moves no unknown; its value is 0); ``self._beta`` is updated. docs/formulation.md §8, docs/checks.md."""
        held = self._held_rows
        if not held.any():
            return y
        if self._beta is None:
            return np.where(held, 0.0, y)
        self._beta = _held_cone(self._beta, self._cone[0].tocsr(), held, gap)
        return self._contact_force()

    def _contact_force(self):
        """r = B^T beta: the nodal contact force on X_h of the conic condition (scaled)."""
        return self._cone[0].T @ self._beta.ravel()

    def accepts(self, scene) -> bool:
        """Whether ``scene`` differs from the prepared one in its loads only."""
        return (isinstance(scene, Scene) and len(scene.bodies) == len(self._fingerprints)
                and [geometry_fingerprint(b) for b in scene.bodies] == self._fingerprints
                and scene.structure() == self._structure)

    def _compatible(self, scene):
        if not isinstance(scene, Scene):
            raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
        if len(scene.bodies) != len(self._fingerprints):
            raise SceneError(f"the scene has {len(scene.bodies)} bodies, the prepared one {len(self._fingerprints)}; "
                             "only loads may change between solves of one ContactSolver")
        for k, (fp, b) in enumerate(zip(self._fingerprints, scene.bodies), start=1):
            if geometry_fingerprint(b) != fp:
                edited = any(b is a for a in self.scene.bodies)
                raise SceneError(
                    f"body {k} ({b.name}): " + ("its mesh, material or boundary parts were changed in place after "
                                                 "this ContactSolver was built" if edited else
                                                 "differs from the prepared scene in its mesh, material or boundary "
                                                 "parts") +
                    "; only loads may change between solves of one ContactSolver: build a new Scene and "
                    "ContactSolver for the new geometry")
        if scene.structure() != self._structure:
            raise SceneError("the scene's contact pairs (members, parts, conditions, overlaps) differ from the "
                             "prepared scene; only loads (and gaps) may change between solves of one ContactSolver: "
                             "build a new ContactSolver for the new geometry")
        return scene


def _without_limit(law: RowLaws) -> RowLaws:
    """The same rows with the compliance laws' penetration limits dropped (the limit posed as a cone)."""
    return RowLaws([replace(lw, penetration_limit=None) if lw.compliant else lw for lw in law.laws], law.counts)


def _add_limit_cone(model, jump, B, g, law) -> None:
    """Add to ``model`` (a full or condensed model of the compliance energy without the limit) the
    "everywhere" condition of docs/formulation.md §8 with the gap g + l, [u_h nu] - g_h <= l on every merged
    segment: ``model.cone``, ``model.row`` (their duals are the Bernstein duals beta), and ``model.problem``
    (and ``model.constraints`` for a full model) with them."""
    model.cone, model.row, _ = bernstein_constraints(jump, B, g + law.penetration_limit)
    if hasattr(model, "constraints"):
        model.constraints = model.constraints + [model.cone, model.row]
    model.problem = cp.Problem(model.problem.objective, list(model.problem.constraints) + [model.cone, model.row])


def conic_limit_model(blocks, E, g, law, weights, B) -> ContactModel:
    """The full model of a P2 compliance law with a penetration limit l under "gamma3" (scaled; docs/
    formulation.md §10, "P2"): the energy with the compliance term sum_a w_a Phi(r_a) on the merged P2 nodes
    (``E`` the identity on X_h, ``weights`` the Simpson weights) and, instead of the nodal rows r <= l, the
    second-order cone per merged segment of §8 with the gap ``g`` + l (``B`` the Bernstein map). The
    returned :class:`~cvxcontact.backends.full.ContactModel` has ``contact`` None and ``cone``, ``row`` set;
    :meth:`~cvxcontact.backends.full.ContactModel.with_terms` keeps the cone."""
    model = ContactModel(blocks, E, g, law=_without_limit(law), weights=weights)
    _add_limit_cone(model, sum((E @ b.jump) @ u for b, u in zip(blocks, model.u)), B, g, law)
    return model


def conic_mix_model(blocks, E, g, law, weights, B, condensed=None, loads=None):
    """The program of a P2 scene mixing cones and a normal-compliance law (scaled; docs/formulation.md §10,
    "P2"): the energy of every body (full model, or with ``condensed`` bodies and their ``loads`` the
    condensed interface model) plus sum_a w_a Phi_a(r_a) over the compliant rows, the linear rows
    r_a <= l_a of the nodal rows with a finite limit, and the second-order cone of §8 per merged segment of
    every cone pair with the gap g + ``law.cone_shift`` (``law`` a scaled
    :class:`~cvxcontact.contact.quadratic.ConeRowLaws`, ``B`` (3 S, rows) the cone pairs' Bernstein map on
    the rows of ``E``). The model's ``contact``/``limit_rows`` are the linear rows (or None), ``cone`` and
    ``row`` the cone's constraints (their duals the Bernstein duals beta)."""
    if condensed is None:
        model = ContactModel(blocks, E, g, law=law, weights=weights)
        jump = sum((E @ b.jump) @ u for b, u in zip(blocks, model.u))
    else:
        model = InterfaceModel(condensed, loads, E, g, law=law, weights=weights)
        jump = sum((E @ c.jump) @ v for c, v in zip(condensed, model.v))
    model.cone, model.row, _ = bernstein_constraints(jump, B, g + law.cone_shift)
    if hasattr(model, "constraints"):
        model.constraints = model.constraints + [model.cone, model.row]
    model.problem = cp.Problem(model.problem.objective, list(model.problem.constraints) + [model.cone, model.row])
    return model


def _p2_obstacles(scene, stack):
    """The scene's :class:`~cvxcontact.physics.pairs.ObstacleRows` with their rows at the stacked P2 nodes of
    ``stack`` (a :class:`~cvxcontact.contact.quadratic.QuadraticStack`): the sensitivities c(x) of each
    obstacle at its pairs' P2 nodes (vertices and midpoints), zero elsewhere; ``basis`` and ``force`` kept."""
    out = []
    for o in scene.obstacles:
        rows = np.zeros((stack.size, 2))
        for i in o.pairs:
            itf = stack.interfaces[i]
            rows[stack.offsets[i]:stack.offsets[i + 1]] = o.obstacle.sensitivity(itf.points, itf.normal)
        out.append(replace(o, rows=sp.csr_matrix(rows)))
    return out


def _row_laws(scene, condition, law, held=False) -> RowLaws:
    """Each pair's law (its own ``Contact.law`` or ``law``) on its rows of the stacked evaluation
    (:class:`~cvxcontact.contact.laws.RowLaws`). With a body held by the contact only (``held``) the
    compliance is solved on the full model and finished on the sparse mixed system
    (:meth:`ContactSolver._compliance_sparse`), since that body cannot be condensed alone."""
    laws = pair_laws(scene, law)
    offsets = scene.stack.row_offsets(condition, scene.conditions)
    rows = RowLaws(laws, np.diff(offsets))
    if rows.compliant:
        w = scene.stack.weights(condition, scene.conditions)
        for i, (a, b) in enumerate(zip(offsets[:-1], offsets[1:])):
            if rows.laws[i].compliant and not (w[a:b] > 0).all():
                raise SceneError(f"contacts[{i}] {scene.contacts[i]!r}: a normal-compliance law needs at least two "
                                 f"constrained nodes (it is integrated over their lumped lengths); under "
                                 f"{scene.conditions[i] or condition!r} the pair has {b - a}: use gamma3 or Signorini")
    return rows


def _sparse_finish(kkt, g, active, timings, max_iter=30):
    """Exact finish on the sparse mixed system (26) (``mixed_kkt``), for scenes whose bodies cannot be
    condensed alone (a body held by the contact only): primal-dual active-set steps from ``active``
    until y >= 0 on the active rows and the open rows' slack <= 0, each to SIGN_TOL of the problem's
    force and displacement scales. Returns ((u, phi, y), active) or None."""
    from .backends.finish import SIGN_TOL

    t0 = time.perf_counter()
    seen, out = set(), None
    for _ in range(max_iter):
        res = kkt(active)
        if res is None:
            break
        x, y, slack, _ = res
        ys = max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny)
        ds = max(float(np.abs(slack + g).max(initial=0.0)), float(np.abs(g).max(initial=0.0)),
                 np.finfo(float).tiny)
        if (y >= -SIGN_TOL * ys).all() and (slack[~active] <= SIGN_TOL * ds).all():
            out = (x, active)
            break
        new = y / ys + slack / ds > 0
        if new.tobytes() in seen or np.array_equal(new, active):
            break
        seen.add(new.tobytes())
        active = new
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    return out


def _program_fields(model, blocks, condensed, E, g):
    """(u, phi, r) of a solved program, r = E [u_nu] - g its rows' penetration (scaled): from the full model's
    fields, or (``condensed`` given) from the condensed model's Gamma values, u and phi then None (they come
    from a back-substitution)."""
    if condensed is not None:
        return None, None, sum(E @ (c.jump @ v.value) for c, v in zip(condensed, model.v)) - g
    u = [v.value for v in model.u]
    phi = [v.value if v is not None else None for v in model.phi]
    return u, phi, sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u)) - g


def _held(E, blocks, translations) -> np.ndarray:
    """Rows of ``E`` that no unknown moves: nodes the supports hold (clamped, or a prescribed displacement)
    on both sides of the contact, or against a fixed obstacle. Their slack is the constant -g."""
    reach = sum((abs(E @ b.jump) @ np.ones(b.jump.shape[1]) for b in blocks), np.zeros(E.shape[0]))
    for R, _ in translations:                                       # a force-controlled obstacle can move
        reach = reach + abs(R) @ np.ones(R.shape[1])
    return reach == 0


def _held_cone(beta, B, held, c):
    """beta with the entries of the Bernstein rows of ``B`` whose nodes are all ``held`` and whose value
    (at the cone's gap ``c``) is 0 lowered to the least the dual cone allows (:func:`least_held_duals`)."""
    if not np.any(held):
        return beta
    rows = (abs(B) @ (~held).astype(float) == 0) & (np.abs(B @ c) <= 1e-12 * max(np.abs(c).max(), 1e-300))
    return least_held_duals(beta, rows.reshape(-1, 3))


def _release_held(y, z, held):
    """(y, z) with the limit reactions z of the ``held`` rows (:func:`_held`) set to 0 and the row forces y
    lowered by them: a reaction on a row no unknown moves acts on nothing, so (26)-(27) do not determine it,
    and an interior point reports an arbitrary, typically huge one (docs/formulation.md §8, "Held nodes")."""
    z = np.asarray(z, dtype=float)
    return y - np.where(held, z, 0.0), np.where(held, 0.0, z)


def _check_reachable(scene, interface, E, held, g, un):
    """Refuse, before any solve, a contact row that no unknown can move but whose gap is negative: a node
    the supports hold (clamped, or a prescribed displacement) that an obstacle or a partner already
    penetrates. The program would only be 'infeasible'; this names the pair and the point instead."""
    bad = np.flatnonzero(held & (g < 0))
    if not len(bad):
        return
    a = int(bad[0])
    node = int(E[a].indices[np.argmax(np.abs(E[a].data))])         # the merged node the row evaluates
    offsets = getattr(interface, "offsets", np.array([0, interface.size]))
    pair = int(np.searchsorted(offsets, node, side="right") - 1)
    points = interface.interfaces[pair].points if hasattr(interface, "interfaces") else interface.points
    x, y = np.asarray(points)[node - offsets[pair]]
    raise SceneError(f"contact pair {pair}: {len(bad)} constrained node(s) cannot move along the contact normal "
                     f"(held by clamped or prescribed-displacement supports) but start in penetration, e.g. at "
                     f"({x:.6g}, {y:.6g}) m where the gap (plus the law's penetration limit, if any) is "
                     f"{g[a] * un.displacement:.3g} m: the contact condition cannot hold there; free that node, or "
                     "move the obstacle or the gap so that it is >= 0")


def _run(problem, solver, verbose, options):
    given = sorted(options)
    if solver == "CLARABEL":
        options = {**_CLARABEL, **options}
    try:
        with warnings.catch_warnings():     # the status is recorded in SolveInfo and the checks say what holds
            warnings.filterwarnings("ignore", message="Solution may be inaccurate", category=UserWarning)
            problem.solve(solver=solver, verbose=verbose, **options)
    except cp.error.SolverError as exc:
        raise SolverError(f"{solver} failed: {exc}") from exc
    except Exception as exc:  # e.g. an option the solver refuses: TypeError, ValueError, OverflowError
        raise SolverError(f"{solver} refused the problem or the solver options {given}: "
                          f"{type(exc).__name__}: {exc}") from exc
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{solver} ended with status {problem.status!r}; no solution to read back")
    return int(getattr(problem.solver_stats, "num_iters", None) or 0)
