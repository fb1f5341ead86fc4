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
import scipy.sparse.linalg as spla

from .backends.cones import conic_mix_model, mixed_bernstein_rows
from .backends.conic import bernstein_duals
from .backends.finish import SIGN_TOL
from .backends.full import ContactModel, limit_reaction, mixed_kkt
from .backends.interface import held_cone, release_held
from .backends.program import conic_options, run_program
from .backends.result import Cache, RawResult, Settings
from .backends.run import run
from .contact.laws import ContactLaw, check_law, check_law_for
from .discrete import build_problem
from .errors import ResidualWarning, SceneError
from .fem.space import space
from .physics.scene import Body, Scene
from .solution.checks import equilibrium_with, force_displacements, ipm_active, node_scales, row_checks, row_scales, rows_active
from .solution.info import Route
from .solution.readback import read_back
from .solution.solution import Solution
from .solve import DEFAULT_TOL

__all__ = ["Model"]

_MAX_STEPS = 20


def _stacked(u, phi, taus=()):
    """x = [u_1; phi_1; u_2; ...; tau_1; ...]: the scaled unknowns in the order of the model's variables."""
    return np.concatenate([a for uk, pk in zip(u, phi) for a in ((uk,) if pk is None else (uk, pk))] + list(taus))


class Model:
    """The contact problem of ``scene`` as a CVXPY program in SI units, open to user terms.

    Parameters as in :func:`cvxcontact.solve` (``method`` is always ``"full"``; ``law=`` a normal
    contact law: with ``cc.NormalCompliance`` the energy gets the lumped compliance term of
    docs/formulation.md §10; exact finish without user terms, else the interior-point answer, checked); all are
    checked before anything is assembled. ``degree=2``: P2 elements, the nodes of ``u(body)`` and
    ``phi(body)`` being ``sol.points[k]`` (vertices, then edge midpoints), and ``jump()`` at the P2 nodes
    of every pair's X_h, stacked; every scene :func:`cvxcontact.solve` takes with P2 (several pairs, rigid
    obstacles, each pair under its own condition and law), posed as ``solve(..., method="full")`` poses it:
    "gamma3" is the conic "everywhere" condition (docs/formulation.md §8: a second-order cone per merged
    segment, nodal pairs next to it as degenerate cones; interior-point answer with tight tolerances, no
    exact finish, checked like :func:`cvxcontact.solve`'s), "sigma1"/"sigma2" the nodal rows with the exact
    finish. A normal-compliance law with P2 sits on the P2 nodes of the
    condition's rows with Simpson weights, finished exactly without user terms (§10, "P2"); its penetration
    limit under "gamma3" is the cone of §8 at the gap g + l (interior point, checked like the cone).

    Rigid obstacles, fixed or force controlled, as in :func:`cvxcontact.solve`: a force-controlled obstacle's
    translation t is an unknown with its force balance (docs/formulation.md §12; ``translation(i)``), finished
    on the sparse mixed system with the translations; ``sol.obstacles`` as from :func:`cvxcontact.solve`.

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
        from .backends.options import check_solve_parameters, check_solver, check_solver_options

        if not isinstance(scene, Scene):
            raise SceneError(f"Model takes a Scene, got {type(scene).__name__}")
        self.law = check_law_for(scene, check_law(law))
        self.tol = check_solve_parameters(condition, "full", tol, polish=polish, verbose=verbose)
        self.solver = check_solver(solver)
        self.options = check_solver_options(solver_options, self.solver)
        discretisation = space(degree)
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
        self._limit = mixed_bernstein_rows(p) if p.mixed else None      # the cones of a mixed program (§10)
        if self._limit is not None:
            self._contact = conic_mix_model(self.blocks, self.E, self._g, self._law, self._weights, self._limit,
                                            translations=self._translations)
        else:
            self._contact = ContactModel(self.blocks, self.E, self._g, law=self._law, weights=self._weights,
                                         bernstein=self._bernstein, translations=self._translations)
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

    def u(self, body) -> cp.Expression:
        """Nodal displacements of ``body`` (index 0/1 or the Body), an (n_nodes, 2) expression in m;
        the clamped dofs (Gamma_1) are the constant 0."""
        k = self._index(body)
        if k not in self._u_expr:
            s = self.systems[k]
            n = len(s.f) // 2                                  # nodes (P2: vertices and midpoints)
            self._u_expr[k] = cp.reshape(s.u_fixed + self.units.displacement * (s.Tu @ self._contact.u[k]),
                                         (n, 2), order="C")
        return self._u_expr[k]

    def phi(self, body) -> cp.Expression | None:
        """Nodal potentials of ``body``, an (n_nodes,) expression in V with the electrode potentials
        (Gamma_a, grounded parts) as constants; None for an elastic body."""
        k = self._index(body)
        s = self.systems[k]
        if not s.piezoelectric:
            return None
        if k not in self._phi_expr:
            self._phi_expr[k] = s.phi_fixed + self.units.potential * (s.Tp @ self._contact.phi[k])
        return self._phi_expr[k]

    def jump(self) -> cp.Expression:
        """[u_nu] of every pair, stacked, m: pair i's rows are ``model.offsets[i]:offsets[i + 1]`` at the nodes
        ``sol.contacts[i].x``. P1: the merged nodes of each pair (``scene.stack``); P2: the P2 nodes of each
        pair's X_h (merged vertices and segment midpoints, interleaved). Against a rigid obstacle [u_nu] is
        the body's u . nu; the contact condition is [u_nu] <= gap, for a force-controlled obstacle
        [u_nu] + c . t <= gap with t its translation (:meth:`translation`, docs/formulation.md §12)."""
        return self.units.displacement * sum(b.jump @ u for b, u in zip(self.blocks, self._contact.u))

    def translation(self, obstacle: int) -> cp.Expression:
        """The rigid translation (2,) in m of ``scene.obstacles[obstacle]``: for a force-controlled obstacle an
        unknown (its force balance is part of the program), for a fixed one the constant 0."""
        if isinstance(obstacle, bool) or not isinstance(obstacle, (int, np.integer)) or \
                not 0 <= obstacle < len(self._obstacles):
            raise SceneError(f"obstacle must be an index into scene.obstacles (0..{len(self._obstacles) - 1}), "
                             f"got {obstacle!r}")
        o = self._obstacles[int(obstacle)]
        if o.force is None:
            return cp.Constant(np.zeros(2))
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
        """Add a user constraint (``==``, ``<=`` or ``>=`` of this model's expressions, SI units),
        an objective term (``cp.Minimize(convex)`` / ``cp.Maximize(concave)``, J/m), or a list of
        them. Returns ``item`` (keep a constraint to read its ``dual_value`` after solving)."""
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
        """Add a convex scalar objective term ``expr`` in J/m (per unit thickness) to the energy."""
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

    def _rows(self, expr, x):
        """(C, c0) with expr ~ C x + c0 at x (exact for an affine expr); C None if not differentiable."""
        grad = expr.grad
        m = expr.size
        if grad is None or any(grad.get(v) is None for v in expr.variables()):
            return None, None
        blocks = []
        for v, _ in self._vars:
            G = grad.get(v)
            blocks.append(sp.csr_matrix((m, v.size)) if G is None else sp.csr_matrix(G).T)
        C = sp.hstack(blocks).tocsr()
        return C, np.asarray(expr.value, dtype=float).flatten(order="F") - C @ x

    def solve(self) -> Solution:
        """Solve with the user terms; a fresh Solution in SI with checks that include them. Without user terms
        the program is the one ``cc.solve(..., method="full")`` solves, with the same finish and read-back."""
        if not self.constraints and not self._objective:
            return self._solve_plain()
        timings = dict(self._setup)
        self._setup = {}
        t0 = time.perf_counter()
        objective = sum(self._objective) if self._objective else None
        problem = self._contact.with_terms(self.constraints, objective)
        timings["model"] = time.perf_counter() - t0
        conic = self._bernstein is not None
        cone = conic or self._limit is not None                 # the conic tolerances (§8)
        run_program(problem, self.solver, self.verbose,
                    conic_options(self.solver, self.options, pairs=len(self.offsets) - 1) if cone else self.options)
        timings["compile"] = problem.compilation_time or 0.0
        timings["solve"] = problem.solver_stats.solve_time or 0.0
        blocks, E, g = self.blocks, self.E, self._g
        u = [v.value for v in self._contact.u]
        phi = [v.value if v is not None else None for v in self._contact.phi]
        taus = [np.asarray(t.value, dtype=float).ravel() for t in self._contact.t]   # force-controlled obstacles
        beta, z = None, None
        # rows no unknown moves: their force, which (26)-(27) do not determine, at its least admissible value,
        # as cc.solve sets it (docs/formulation.md §8, "Held nodes")
        held = self.problem.held_rows
        if self._law is not None:      # normal compliance: row forces w p(r) + limit reactions z (§10)
            r = (sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u)) - g
                 + sum((R @ tau for (R, _), tau in zip(self._translations, taus)), np.zeros(len(g))))
            z = release_held(0.0, limit_reaction(self._contact.contact, self._contact.limit_rows, len(g)), held)[1]
            if self._limit is not None:     # cones next to the law: their nodal force B^T beta joins z
                beta = held_cone(bernstein_duals(self._contact.cone, self._contact.row), self._limit, held,
                                 g + self._law.cone_shift)
                z = z + self._limit.T @ beta.ravel()
            y = self._weights * self._law.pressure(r) + z
        elif conic:    # the nodal force r = B^T beta on X_h (E = I)
            beta = held_cone(bernstein_duals(self._contact.cone, self._contact.row), self._bernstein, held, g)
            y = self._bernstein.T @ beta.ravel()
        else:
            y = np.where(held, 0.0, np.asarray(self._contact.contact.dual_value, dtype=float).ravel())
        x = self._x()
        rows = []                                      # per user constraint: C, c0, z, equality
        for c in self.constraints:
            C, c0 = self._rows(c.expr, x)
            zc = np.asarray(c.dual_value, dtype=float).flatten(order="F")      # (not z: the limit reactions)
            rows.append((C, c0, zc, isinstance(c, cp.constraints.Equality), c.expr.is_affine()))
        grad, lin = np.zeros(self._n), True
        if objective is not None:
            Cobj, _ = self._rows(objective, x)
            grad = np.full(self._n, np.nan) if Cobj is None else Cobj.toarray().ravel()
            lin = objective.is_affine()
        linear = lin and all(r[4] for r in rows) and self._law is None   # no exact finish with compliance here
        finishable = linear and not conic                                  # nor with the conic condition
        moved = self.problem.moved_gap(taus)
        active = ipm_active([E @ (b.jump @ uk) for b, uk in zip(blocks, u)], E @ moved, y,
                            force_displacements(blocks, E, y)) & ~held     # a held row would make the KKT singular
        polished, declined = False, ""
        if self.polish and finishable:
            t0 = time.perf_counter()
            out = self._finish(u, phi, y, rows, grad if objective is not None else None, active)
            timings["polish"] = time.perf_counter() - t0
            if isinstance(out, str):
                declined = out
            else:
                u, phi, y, zs, active, taus = out
                polished = True
                rows = [(C, c0, z, eq, aff) for (C, c0, _, eq, aff), z in zip(rows, zs)]
                x = _stacked(u, phi, taus)
        t0 = time.perf_counter()
        keep_z = self._law is not None and (self._limit is not None or self._law.limited.any())
        raw = RawResult(u=u, phi=phi, y=y, active=active, z=z if keep_z else None, beta=beta, taus=taus,
                        polished=polished, program=problem, method="full")
        sol = read_back(self.problem, raw, self.tol, timings, "full")
        sol._checks = self._checks(sol._checks, u, phi, y, x, rows, grad)
        if self._forced and rows:        # user rows on a translation carry part of its prescribed force
            sol._checks["obstacle balance"] = self._balance(y, rows)
        timings["read_back"] = time.perf_counter() - t0
        route = (Route.INTERIOR_POINT_FINISHED if polished else
                 Route.INTERIOR_POINT if linear or self._law is not None else Route.INTERIOR_POINT_NONLINEAR)
        stats = problem.solver_stats
        sol.info = replace(sol.info, method="full", requested="full", route=route, timings=timings,
                           iterations=int(stats.num_iters or 0) if stats is not None else 0)
        if self.polish and finishable and not polished:
            warnings.warn(f"the exact finish of the user model of {self.scene!r} ({self.condition}) was declined "
                          f"({declined}); the interior-point answer is kept (sol.polished is False):\n"
                          f"{sol.report()}", ResidualWarning, stacklevel=2)
        elif not sol.ok:
            warnings.warn(f"the user model of {self.scene!r} ({self.condition}) fails its checks at "
                          f"tol={self.tol:g}:\n{sol.report()}", ResidualWarning, stacklevel=2)
        return sol

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
        for var, val in [*zip(self._contact.u, raw.u), *zip(self._contact.phi, raw.phi), *zip(self._contact.t, raw.taus)]:
            if var is not None and val is not None:
                var.value = np.asarray(val, dtype=float).reshape(var.shape)
        if self.polish and not raw.polished and not self.problem.conic and not self.problem.mixed:
            warnings.warn(f"the exact finish of the user model of {self.scene!r} ({self.condition}) was declined "
                          f"({raw.declined}); the interior-point answer is kept (sol.polished is False):\n"
                          f"{sol.report()}", ResidualWarning, stacklevel=3)
        elif not sol.ok:
            warnings.warn(f"the user model of {self.scene!r} ({self.condition}) fails its checks at "
                          f"tol={self.tol:g}:\n{sol.report()}", ResidualWarning, stacklevel=3)
        return sol

    def _balance(self, y, rows) -> float:
        """The force balance of every force-controlled obstacle with the user rows' forces on its translation
        (scaled; docs/formulation.md §12): max |F - R^T y - C_t^T z| / |F| (with the obstacle's check of
        :func:`~cvxcontact.solution.solution.obstacle_results` when no user row touches t)."""
        worst, pos = 0.0, self._n_bodies
        for (R, F), t in zip(self._translations, self._contact.t):
            r = F - R.T @ y
            for C, _, z, _, _ in rows:
                r = r - (np.full(t.size, np.nan) if C is None else C[:, pos:pos + t.size].T @ z)
            worst = float(np.max([worst, np.linalg.norm(r) / np.linalg.norm(F)]))     # (nan propagates)
            pos += t.size
        return worst

    def _contact_norms(self):
        G = sp.hstack([self.E @ b.jump for b in self.blocks]).tocsr()
        n = np.sqrt(np.asarray(G.power(2).sum(axis=1)).ravel())
        return np.where(n > 0, n, 1.0)

    def _finish(self, u, phi, y, rows, load, active):
        """Exact finish with linear user rows: primal-dual active-set steps on the mixed system (26)
        with the contact rows and the user inequality rows (and, with force-controlled obstacles, their
        translations tau and force balances R^T y = F, docs/formulation.md §12); returns
        (u, phi, y, [z_i], active, taus) or the reason it was declined."""
        E, g, blocks, tr = self.E, self._g, self.blocks, self._translations
        m = [len(r[1]) for r in rows]
        if rows:
            C = sp.vstack([r[0] for r in rows]).tocsr()
            d = -np.concatenate([r[1] for r in rows])
            z = np.concatenate([r[2] for r in rows])
            eq = np.concatenate([np.full(k, r[3]) for k, r in zip(m, rows)])
        else:
            C, d, z, eq = sp.csr_matrix((0, self._n)), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool)
        if not rows and load is None:
            base = mixed_kkt(blocks, E, g, translations=tr or None)

            def kkt(ac, ar):
                out = base(ac)
                if out is None:
                    return None
                x = out[0] if tr else (*out[0], [])
                return (*x[:3], np.zeros(0), x[3]), out[2], np.zeros(0)
        else:
            rows_kkt = mixed_kkt(blocks, E, g, rows=C, bound=d, load=load, translations=tr or None)

            def kkt(ac, ar):
                out = rows_kkt(ac, ar)
                if out is None:
                    return None
                x = out[0] if tr else (*out[0], [])
                return x, out[1], out[2]
        nc = self._contact_norms()
        x = self._x()
        S, norms = row_scales(C, x, d)
        Z = max(float((y * nc).max(initial=0.0)), float((np.abs(z) * norms).max(initial=0.0)))
        ar = eq | rows_active(C @ x - d, S, z, norms, Z)
        ac = active.copy()
        seen = set()
        for _ in range(_MAX_STEPS):
            out = kkt(ac, ar)
            if out is None:
                return "the mixed system on the active set is singular"
            (uk, pk, yk, zk, tk), sc, sr = out
            xk = _stacked(uk, pk, tk)
            moved = g - sum((R @ t for (R, _), t in zip(tr, tk)), np.zeros(len(g)))
            _, U = node_scales([E @ (b.jump @ ui) for b, ui in zip(blocks, uk)], moved)
            S, _ = row_scales(C, xk, d)
            Z = max(float((yk * nc).max(initial=0.0)), float((np.abs(zk) * norms).max(initial=0.0)),
                    np.finfo(float).tiny)
            neg_c = ac & (yk * nc < -SIGN_TOL * Z)
            neg_r = ar & ~eq & (zk * norms < -SIGN_TOL * Z)
            bad_c = ~ac & (sc > SIGN_TOL * U)
            bad_r = ~ar & (sr > SIGN_TOL * S)
            if not (neg_c.any() or neg_r.any() or bad_c.any() or bad_r.any()):
                off = np.cumsum([0] + m)
                return uk, pk, yk, [zk[a:b] for a, b in zip(off[:-1], off[1:])], ac, list(tk)
            ac, ar = (ac & ~neg_c) | bad_c, (ar & ~neg_r) | bad_r
            key = ac.tobytes() + ar.tobytes()
            if key in seen:
                return "the active-set steps cycle"
            seen.add(key)
        return f"the active-set steps did not settle in {_MAX_STEPS} steps"

    def _checks(self, base, u, phi, y, x, rows, grad):
        """The checks of read_back with the user terms: equilibrium of (26) with the user forces,
        and feasibility/complementarity of each user constraint, normalised per row."""
        blocks, E = self.blocks, self.E
        t = grad.copy()
        tm = np.abs(grad)
        for C, c0, z, _, _ in rows:
            if C is None:
                t[:] = np.nan
                continue
            t += C.T @ z
            tm += abs(C).T @ np.abs(z)
        forces, pos = [], 0
        for b, uk, pk in zip(blocks, u, phi):
            nu, npf = len(uk), (0 if pk is None else len(pk))
            tu, mu = t[pos:pos + nu].copy(), tm[pos:pos + nu].copy()
            if npf and np.any(t[pos + nu:pos + nu + npf] != 0):
                w = spla.splu(b.Kpp.tocsc()).solve(t[pos + nu:pos + nu + npf])
                tu += b.Kup @ w
                mu += abs(b.Kup) @ np.abs(w)
            forces.append((tu, mu))
            pos += nu + npf
        out = dict(base)
        out["equilibrium"] = equilibrium_with(blocks, u, phi, E.T @ y, forces)
        nc = self._contact_norms()
        Z = float((np.abs(y) * nc).max(initial=0.0))     # (the conic nodal force r may change sign)
        for C, c0, z, _, _ in rows:
            if C is not None:
                Z = max(Z, float((np.abs(z) * row_scales(C, x, c0)[1]).max(initial=0.0)))
        for i, (C, c0, z, eq, _) in enumerate(rows):
            if C is None:
                out[f"user[{i}] feasibility"] = out[f"user[{i}] complementarity"] = float("nan")
                continue
            S, norms = row_scales(C, x, c0)
            feas, comp, cone = row_checks(C @ x + c0, S, z, norms, Z, equality=eq)
            out[f"user[{i}] feasibility"] = feas
            if not eq:
                out[f"user[{i}] complementarity"] = comp
                out[f"user[{i}] cone"] = cone
        return out
