"""The contact problem as an open convex program in physical units: :class:`Model`.

``cc.solve`` poses and solves the phi-form program of docs/formulation.md §2 (the paper's
(26)-(27) as a convex QP). :class:`Model` poses the same program and hands its unknowns to
the caller as CVXPY expressions in SI units, so that constraints and convex objective terms
can be added before solving:

    model = cc.Model(scene, condition="gamma3")
    U = model.u(1)                       # (n_nodes, 2) displacements, m (clamped dofs 0)
    P = model.phi(0)                     # (n_nodes,) potentials, V (electrodes included)
    model.add(U[k, 1] >= -1e-4)          # a user constraint, in metres
    model.add_objective(expr)            # a convex term in J/m (per unit thickness)
    sol = model.solve()

Internally the variables stay the scaled free dofs of
:class:`cvxcontact.backends.full.ContactModel` (x = [u_1; phi_1; u_2; ...; t_1; ...], dimensionless, t_i the
translation unknowns of force-controlled obstacles, docs/formulation.md §12):

    u_SI   = U (P_k u_k)                 P_k: (2n, n_free) selection, clamped dofs 0, U = units.displacement
    phi_SI = phi_D + Phi (Q_k phi_k)     phi_D: electrode potentials (V), Phi = units.potential

and user objective terms are divided by the energy unit W = units.force * units.displacement
(J/m). With user constraints C x + c0 <= 0 (multipliers z >= 0, CVXPY's sign convention:
Lagrangian + z^T (C x + c0)), the momentum rows of (26) become

    Kuu u + Kup phi + J^T E^T y + C_u^T z + Kup Kpp^{-1} C_phi^T z = f       (26) with user rows

(a row on phi acts through the coupling, phi = Kpp^{-1} (q + Kup^T u)), and the checks of
:mod:`cvxcontact.solution.checks` use this residual; each user constraint reports its own
feasibility and complementarity (27), normalised per row. With linear user terms only,
the exact finish solves that mixed system on the active set of all inequality rows
(contact and user) and corrects it by primal-dual active-set steps.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from dataclasses import replace

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..backends.cones import mixed_bernstein_rows
from ..backends.finish import Declined
from ..backends.program import conic_options, run_program
from ..backends.result import Cache, RawResult, Settings, declined_words
from ..backends.run import run
from ..contact.laws import ContactLaw, check_law, check_law_for
from ..discrete import build_problem
from ..errors import ResidualWarning, SceneError, UnsupportedError, user_stacklevel
from ..fem.space import space
from ..physics.scene import Body, Scene
from ..solution.checks import force_displacements, ipm_active, reach_forces
from ..solution.info import Route
from ..solution.readback import read_back
from ..solution.solution import Solution
from ..solve import DEFAULT_TOL
from .terms import balance, checks, finish, linearize, stacked

__all__ = ["Model"]

class Model:
    """The contact problem of ``scene`` as a CVXPY program in SI units, open to user terms.

    Every scene :func:`cvxcontact.solve` takes, posed as ``solve(..., method="full")`` poses it; exact finish
    without user terms or with linear ones, else the interior-point answer, checked. What is posed with P2, a
    compliance law and force-controlled obstacles, and what the finish does: docs/howto/extending.md,
    "What the model poses". Every parameter is checked before anything is assembled.

    Parameters
    ----------
    scene : Scene
        The bodies, supports, loads (SI units) and contact pairs.
    condition : {"gamma3", "sigma1", "sigma2"}
        The discrete contact condition, as in :func:`cvxcontact.solve`.
    solver : str
        A CVXPY solver name; Clarabel by default.
    tol : float
        Tolerance of the checks (dimensionless), user terms included.
    polish : bool
        Exact finish where the program allows it (default).
    verbose : bool
        Print the solver's progress.
    solver_options : dict, optional
        Options passed to ``cvxpy.Problem.solve``.
    law : Signorini or NormalCompliance, optional
        The normal contact law (stiffness in Pa/m^m); compliance adds its energy (docs/formulation.md §10).
    degree : {1, 2}
        P1 (default) or P2 elements; ``u(body)``, ``phi(body)`` then live on ``sol.points[k]``.

    Methods
    -------
    u(body), phi(body), jump(), translation(obstacle)
        CVXPY expressions of the unknowns in m and V (see the module docstring); ``offsets``: pair i's
        rows of ``jump()`` are ``offsets[i]:offsets[i + 1]``.
    add(item), add_objective(expr)
        User constraints (``==``, ``<=``, ``>=`` of the model's expressions, in SI) and convex
        objective terms (J/m). Items are kept; later solves include them.
    solve()
        Solve; returns a fresh :class:`~cvxcontact.Solution` with ``problem`` the program
        actually solved and the checks including the user terms.

    Raises
    ------
    SceneError
        ``scene`` is not a Scene, ``condition`` is unknown, a body index is unknown, or a
        user term is not built from this model's expressions or is not convex (DCP).
    SolverError
        A bad solver parameter or option, or the solver failed.
    """

    def __init__(self, scene, condition: str = "gamma3", solver: str = "CLARABEL", *, tol: float = DEFAULT_TOL,
                 polish: bool = True, verbose: bool = False, solver_options: Mapping[str, object] | None = None,
                 law: ContactLaw | None = None, degree: int = 1):
        from ..backends.options import check_solve_parameters, check_solver, check_solver_options

        if not isinstance(scene, Scene):
            raise SceneError(f"Model takes a Scene, got {type(scene).__name__}")
        self.law = check_law_for(scene, check_law(law))
        self.tol = check_solve_parameters(condition, "full", tol, polish=polish, verbose=verbose)
        self.solver = check_solver(solver)
        self.options = check_solver_options(solver_options, self.solver)
        discretisation = space(degree, scene.cell)
        self.scene, self.condition, self.polish, self.verbose = scene, condition, polish, verbose
        t0 = time.perf_counter()
        self.problem = p = build_problem(scene, discretisation, condition, self.law)
        self._nodes, self._itf = p.nodes, p.interface
        self.E, self.systems, self.units, self.blocks = p.E, list(p.systems), p.units, list(p.blocks)
        self._gap, self._g, self.rows, self.offsets = p.gap, p.g, p.rows, np.asarray(p.lines.offsets)
        self._obstacles, self._forced, self._translations = list(p.obstacles), p.forced, list(p.translations)
        self._weights, self._law = p.weights, p.scaled_law
        self._cone = p.lines.cone
        self._bernstein = self._cone[0] if self._cone is not None else None
        self._width = self._cone[1].shape[1] if self._cone is not None else 3     # 3: segments, 6: triangles
        self._limit = mixed_bernstein_rows(p)         # the cones beside a compliance law (§10), None without
        self._contact = p.term.program(p)             # the full program with the term's rows or cones
        self._setup = {"assembly": time.perf_counter() - t0}
        # x = [u_1; phi_1; u_2; ...]: each variable's offset in the stacked scaled unknowns
        self._vars, pos = [], 0
        for u, p in zip(self._contact.u, self._contact.phi):
            for v in (u, p):
                if v is not None:
                    self._vars.append((v, pos))
                    pos += v.size
        self._n_bodies = pos
        for t in self._contact.t:                     # then the obstacles' translations, as in mixed_kkt
            self._vars.append((t, pos))
            pos += t.size
        self._n = pos
        self._ids = {v.id for v, _ in self._vars}
        self._u_expr, self._phi_expr = {}, {}
        self.constraints: list[cp.Constraint] = []
        self._objective: list[cp.Expression] = []     # scaled (divided by the energy unit)

    # ---- the unknowns in SI -------------------------------------------------------------------
    def _index(self, body) -> int:
        bodies = self.scene.bodies
        if isinstance(body, Body):
            for k, b in enumerate(bodies):
                if b is body:
                    return k
            raise SceneError(f"body {body!r} is not a body of this model's scene")
        if isinstance(body, bool) or not isinstance(body, (int, np.integer)) or not 0 <= body < len(bodies):
            raise SceneError(f"body must be a body's index (0, 1, ...) or one of the scene's Body objects, "
                             f"got {body!r}")
        return int(body)

    def u(self, body, nodes=None) -> cp.Expression:
        """Nodal displacements of ``body``, m: a CVXPY expression, the clamped dofs (Gamma_1) the constant 0.

        Parameters
        ----------
        body : int or Body
            The body's index in ``scene.bodies``, or the Body.
        nodes : int or array of int, optional
            Those rows only, checked (a SceneError naming the valid range; plain indexing of the expression
            raises CVXPY's IndexError).

        Returns
        -------
        cvxpy.Expression
            (n_nodes, d) in m, d the scene's dimension; (d,) or (len(nodes), d) with ``nodes``.
        """
        k = self._index(body)
        if k not in self._u_expr:
            s = self.systems[k]
            d = self.problem.dim
            n = len(s.f) // d                                  # nodes (P2: vertices and midpoints)
            self._u_expr[k] = cp.reshape(s.u_fixed + self.units.displacement * (s.Tu @ self._contact.u[k]),
                                         (n, d), order="C")
        return self._rows(k, self._u_expr[k], nodes)

    def phi(self, body, nodes=None) -> cp.Expression | None:
        """Nodal potentials of ``body``, V: a CVXPY expression, the electrodes' potentials (Gamma_a) constants.

        Parameters
        ----------
        body : int or Body
            The body's index in ``scene.bodies``, or the Body.
        nodes : int or array of int, optional
            Those rows only, checked as in :meth:`u`.

        Returns
        -------
        cvxpy.Expression or None
            (n_nodes,) in V (or the rows of ``nodes``); None for an elastic body.
        """
        k = self._index(body)
        s = self.systems[k]
        if not s.piezoelectric:
            return None
        if k not in self._phi_expr:
            self._phi_expr[k] = s.phi_fixed + self.units.potential * (s.Tp @ self._contact.phi[k])
        return self._rows(k, self._phi_expr[k], nodes)

    def _rows(self, k, expr, which):
        """``expr`` (body k's nodal expression), or its rows ``which`` (a user's node selection, checked)."""
        return expr if which is None else expr[self._nodes_of(k, which)]

    def _nodes_of(self, k, nodes):
        """``nodes`` as checked node indices of body k (SceneError naming the body and the valid range)."""
        n = len(self.systems[k].f) // self.problem.dim
        idx = np.asarray(nodes)
        if idx.dtype.kind not in "iu" or idx.ndim > 1:
            raise SceneError(f"nodes of body {k} ({self.scene.bodies[k].name}) must be an integer node index or a "
                             f"1-D array of them, got {nodes!r}")
        bad = idx[(idx < 0) | (idx >= n)]
        if bad.size:
            raise SceneError(f"node {int(bad.ravel()[0])} of body {k} ({self.scene.bodies[k].name}) is out of range: "
                             f"the body has {n} nodes (0..{n - 1}; P2: vertices, then edge midpoints, as sol.points)")
        return int(idx) if idx.ndim == 0 else idx

    def jump(self) -> cp.Expression:
        """The normal jump [u_nu] of every contact pair at its nodes, stacked.

        Returns
        -------
        cvxpy.Expression
            In m; pair i's rows ``model.offsets[i]:offsets[i + 1]`` at the nodes ``sol.contacts[i].x``. Which
            nodes, and the rows against an obstacle: docs/howto/extending.md, "The model's expressions".
        """
        return self.units.displacement * (sum(b.jump @ u for b, u in zip(self.blocks, self._contact.u))
                                          + self.problem.prescribed_jump)

    def translation(self, obstacle: int) -> cp.Expression:
        """The rigid translation of ``scene.obstacles[obstacle]``: an unknown if the obstacle is force-controlled.

        Parameters
        ----------
        obstacle : int
            Index in ``scene.obstacles``.

        Returns
        -------
        cvxpy.Expression
            (d,) in m, d the scene's dimension: for a force-controlled obstacle an unknown (its force balance is
            part of the program), for a fixed one the constant 0.
        """
        if isinstance(obstacle, bool) or not isinstance(obstacle, (int, np.integer)) or \
                not 0 <= obstacle < len(self._obstacles):
            raise SceneError(f"obstacle must be an index into scene.obstacles (0..{len(self._obstacles) - 1}), "
                             f"got {obstacle!r}")
        o = self._obstacles[int(obstacle)]
        if o.force is None:
            return cp.Constant(np.zeros(self.scene.dim))
        t = self._contact.t[next(i for i, f in enumerate(self._forced) if f is o)]
        return self.units.displacement * (o.basis @ t)

    # ---- user terms ---------------------------------------------------------------------------
    def _own(self, expr, what):
        ids = {v.id for v in expr.variables()}
        if not ids:
            raise SceneError(f"{what} involves none of this model's unknowns; build it from model.u(), "
                             f"model.phi() or model.jump()")
        if not ids <= self._ids:
            names = sorted(v.name() for v in expr.variables() if v.id not in self._ids)
            raise SceneError(f"{what} involves variables that are not this model's ({names}); build it "
                             f"from model.u(), model.phi() or model.jump() of this Model")

    def add(self, item):
        """Add a user constraint, an objective term, or a list of them.

        Parameters
        ----------
        item : cvxpy.Constraint, cvxpy.Minimize, cvxpy.Maximize or list
            A constraint (``==``, ``<=``, ``>=``) of this model's expressions in SI units, or
            ``cp.Minimize(convex)`` / ``cp.Maximize(concave)`` in J/m (J in 3D); convex (DCP), else SceneError.

        Returns
        -------
        item
            As given: keep a constraint to read its ``dual_value`` after solving.
        """
        if isinstance(item, (cp.Minimize, cp.Maximize)):
            expr = item.args[0] if isinstance(item, cp.Minimize) else -item.args[0]
            self.add_objective(expr)
            return item
        if isinstance(item, (list, tuple)):
            for it in item:
                self.add(it)
            return item
        if not isinstance(item, (cp.constraints.Inequality, cp.constraints.Equality)):
            raise SceneError(f"model.add takes a constraint (==, <=, >=) or cp.Minimize/cp.Maximize of this "
                             f"model's expressions, got {type(item).__name__}")
        what = f"user constraint {len(self.constraints)} ({item})"
        self._own(item.expr, what)
        if not item.is_dcp():
            raise SceneError(f"{what} is not convex (DCP): an inequality needs a convex left side and a "
                             f"concave right side, an equality affine sides")
        self.constraints.append(item)
        return item

    def add_objective(self, expr) -> None:
        """Add a convex scalar term to the energy the program minimises.

        Parameters
        ----------
        expr : cvxpy.Expression
            Scalar, convex (DCP), of this model's unknowns; J/m in 2D (per unit thickness), J in 3D.
        """
        if not isinstance(expr, cp.Expression):
            raise SceneError(f"add_objective takes a CVXPY expression of this model's unknowns, "
                             f"got {type(expr).__name__}")
        what = f"user objective term {len(self._objective)}"
        if expr.size != 1:
            raise SceneError(f"{what} must be a scalar (J/m), got shape {expr.shape}")
        self._own(expr, what)
        if not expr.is_convex():
            raise SceneError(f"{what} is not convex (DCP); only convex terms can be minimised")
        self._objective.append(cp.reshape(expr, (), order="C") / (self.units.force * self.units.displacement))

    # ---- solve --------------------------------------------------------------------------------
    def _x(self):
        x = np.zeros(self._n)
        for v, pos in self._vars:
            x[pos:pos + v.size] = v.value
        return x

    def solve(self) -> Solution:
        """Solve the program with the user terms.

        Returns
        -------
        Solution
            A fresh Solution in SI whose checks include the user terms. Without them, the answer of
            ``cc.solve(..., method="full")``, with the same finish and read-back.
        """
        if not self.constraints and not self._objective:
            return self._solve_plain()
        if refusal := self.problem.term.refuses_user_terms:
            raise UnsupportedError(refusal)
        timings = dict(self._setup)
        self._setup = {}
        t0 = time.perf_counter()
        objective = sum(self._objective) if self._objective else None
        settings = Settings(solver=self.solver, options=self.options, verbose=self.verbose, polish=self.polish,
                            warm_start=False)
        out = self.problem.term.with_user_terms(self.problem, self._contact, self.constraints, objective, settings,
                                                timings, self._admits)
        if out is not None:                              # the term's own program beside the user terms
            return self._solve_by_term(*out, objective, timings)
        problem = self._contact.with_terms(self.constraints, objective)
        timings["model"] = time.perf_counter() - t0
        conic = self._bernstein is not None
        cone = conic or self._limit is not None                 # the conic tolerances (§8)
        run_program(problem, self.solver, self.verbose,
                    conic_options(self.solver, self.options, pairs=len(self.offsets) - 1) if cone else self.options)
        timings["compile"] = problem.compilation_time or 0.0
        timings["solve"] = problem.solver_stats.solve_time or 0.0
        blocks, E = self.blocks, self.E
        u = [v.value for v in self._contact.u]
        phi = [v.value if v is not None else None for v in self._contact.phi]
        taus = [np.asarray(t.value, dtype=float).ravel() for t in self._contact.t]   # force-controlled obstacles
        # the term's forces from the program's duals: the rows no unknown moves at their least admissible force,
        # as cc.solve sets it (docs/formulation.md §8, "Held nodes")
        y, z, beta = self.problem.term.program_forces(self.problem, self._contact, u, taus)
        held = self.problem.held_rows
        x = self._x()
        rows = []                                      # per user constraint: C, c0, z, equality
        for c in self.constraints:
            C, c0 = linearize(c.expr, x, self._vars)
            zc = np.asarray(c.dual_value, dtype=float).flatten(order="F")      # (not z: the limit reactions)
            rows.append((C, c0, zc, isinstance(c, cp.constraints.Equality), c.expr.is_affine()))
        grad, lin = np.zeros(self._n), True
        if objective is not None:
            Cobj, _ = linearize(objective, x, self._vars)
            grad = np.full(self._n, np.nan) if Cobj is None else Cobj.toarray().ravel()
            lin = objective.is_affine()
        linear = lin and all(r[4] for r in rows) and self._law is None   # no exact finish with compliance here
        finishable = linear and not conic and self.problem.quadratic       # nor with the conic condition, nor with
        #                                                   a non-quadratic bulk energy (its finish solves Kuu systems)
        moved = self.problem.moved_gap(taus)
        active = ipm_active([E @ (b.jump @ uk) for b, uk in zip(blocks, u)], E @ moved, y,
                            force_displacements(blocks, E, y), reach_forces(blocks, E, u, phi)) & ~held     # a held row would make the KKT singular
        polished, declined = False, None
        if self.polish and finishable:
            t0 = time.perf_counter()
            out = finish(self.problem, u, phi, y, rows, grad if objective is not None else None, active, x)
            timings["polish"] = time.perf_counter() - t0
            if isinstance(out, Declined):
                declined = out
            else:
                u, phi, y, zs, active, taus = out
                polished = True
                rows = [(C, c0, z, eq, aff) for (C, c0, _, eq, aff), z in zip(rows, zs)]
                x = stacked(u, phi, taus)
                self._set_values(u, phi, taus, zs)       # the model's expressions read the finished answer
        t0 = time.perf_counter()
        keep_z = self._law is not None and (self._limit is not None or self._law.limited.any())
        raw = RawResult(u=u, phi=phi, y=y, active=active, z=z if keep_z else None, beta=beta, taus=taus,
                        polished=polished, program=problem, method="full", declined=declined)
        sol = read_back(self.problem, raw, self.tol, timings, "full")
        sol._checks = checks(self.problem, sol._checks, u, phi, y, x, rows, grad)
        if self._forced and rows:        # user rows on a translation carry part of its prescribed force
            sol._checks["obstacle balance"] = balance(self.problem, y, rows, self._n_bodies)
        timings["read_back"] = time.perf_counter() - t0
        route = (Route.INTERIOR_POINT_FINISHED if polished else
                 Route.INTERIOR_POINT if linear or self._law is not None else Route.INTERIOR_POINT_NONLINEAR)
        stats = problem.solver_stats
        sol.info = replace(sol.info, method="full", requested="full", route=route, timings=timings,
                           iterations=int(stats.num_iters or 0) if stats is not None else 0)
        self._warn(sol, finishable, raw)
        return sol

    def _admits(self, raw) -> bool:
        """Whether the answer ``raw`` (scaled, finished without the user rows) satisfies every user constraint,
        each an inequality (then it answers the program with them, their multipliers 0: a convex program's KKT
        conditions); the model's variables are left at ``raw``'s values."""
        self._set_values(raw.u, raw.phi, raw.taus)
        return all(isinstance(c, cp.constraints.Inequality) and bool(np.all(np.asarray(c.expr.value) <= 0.0))
                   for c in self.constraints)

    def _solve_by_term(self, raw, force, objective, timings) -> Solution:
        """The Solution of the term's answer ``raw`` with the user terms (:meth:`ContactTerm.with_user_terms`;
        ``force``: the generalised force the term adds beyond E^T y, None: none): its read-back and the user
        terms' checks; a finished answer's user multipliers are 0 (it satisfies them, :meth:`_admits`)."""
        zs = [np.zeros(c.size) for c in self.constraints] if raw.polished else ()
        raw.y = self.problem.term.held_forces(self.problem, raw.y)     # the forces it reports, as cc.solve's run
        self._set_values(raw.u, raw.phi, raw.taus, zs)   # the model's expressions (and duals) read the answer
        x = self._x()
        rows = []
        for c in self.constraints:
            C, c0 = linearize(c.expr, x, self._vars)
            zc = np.asarray(c.dual_value, dtype=float).flatten(order="F")
            rows.append((C, c0, zc, isinstance(c, cp.constraints.Equality), c.expr.is_affine()))
        grad = np.zeros(self._n)
        if objective is not None:
            Cobj, _ = linearize(objective, x, self._vars)
            grad = np.full(self._n, np.nan) if Cobj is None else Cobj.toarray().ravel()
        t0 = time.perf_counter()
        sol = read_back(self.problem, raw, self.tol, timings, "full")
        sol._checks = checks(self.problem, sol._checks, raw.u, raw.phi, raw.y, x, rows,
                             grad if force is None else grad + force)
        if self._forced and rows:        # user rows on a translation carry part of its prescribed force (and the
            #                              term's force on it: a row of multiplier 1)
            extra = [] if force is None else [(sp.csr_matrix(force[None, :]), None, np.ones(1), False, True)]
            sol._checks["obstacle balance"] = balance(self.problem, raw.y, rows + extra, self._n_bodies)
        timings["read_back"] = time.perf_counter() - t0
        sol.info = replace(sol.info, timings=timings)
        # a finish that applies and declined (a friction term's decline keeps its interior point's answer silently,
        # as cc.solve: ``finishes``), else the checks
        self._warn(sol, self.problem.term.finish_declined(self.problem, raw, self.polish), raw)
        return sol

    def _warn(self, sol, finishable: bool, raw: RawResult) -> None:
        """A ResidualWarning when an exact finish that applies was declined (why: ``raw.declined``, what is kept:
        ``raw.kept``), or when the checks fail."""
        if self.polish and finishable and not sol.polished:
            warnings.warn(f"{declined_words(f'the user model of {self.scene!r}', self.condition, raw)}:\n"
                          f"{sol.report()}", ResidualWarning, stacklevel=user_stacklevel())
        elif not sol.ok:
            warnings.warn(f"the user model of {self.scene!r} ({self.condition}) fails its checks at "
                          f"tol={self.tol:g}:\n{sol.report()}", ResidualWarning, stacklevel=user_stacklevel())

    def _set_values(self, u, phi, taus, duals=()):
        """The model's variables (and the user constraints' duals) set to an answer, so that ``model.u(k).value``,
        ``model.jump().value`` and ``constraint.dual_value`` read it (scaled values in, SI expressions out)."""
        for var, val in [*zip(self._contact.u, u), *zip(self._contact.phi, phi), *zip(self._contact.t, taus)]:
            if var is not None and val is not None:
                var.value = np.asarray(val, dtype=float).reshape(var.shape)
        for c, z in zip(self.constraints, duals):
            c.dual_variables[0].value = np.asarray(z, dtype=float).reshape(c.dual_variables[0].shape, order="F")

    def _solve_plain(self) -> Solution:
        """No user terms: the full backend's route on the same :class:`~cvxcontact.discrete.DiscreteProblem`
        (``cc.solve(..., method="full")``); the model's variables take the answer's values."""
        timings = dict(self._setup)
        self._setup = {}
        settings = Settings(solver=self.solver, options=self.options, verbose=self.verbose, polish=self.polish,
                            warm_start=False)
        raw = run("full", self.problem, Cache(), settings, timings)
        t0 = time.perf_counter()
        sol = read_back(self.problem, raw, self.tol, timings, "full")
        timings["read_back"] = time.perf_counter() - t0
        sol.info = replace(sol.info, timings=timings)
        self._set_values(raw.u, raw.phi, raw.taus)
        # a finish that always runs (not term.finish_declined: cc.Model does not warn of the cones' declined cuts,
        # which cc.solve reports; tests/test_terms.py::test_model_warns_where_a_finish_that_always_runs_did_not)
        self._warn(sol, self.problem.term.always_finished, raw)
        return sol
