"""Solve a scene, read lambda_h back from the duals, and check the mixed formulation.

Read-back (shared/math.md §4): with y >= 0 the dual of E [u_nu] <= E g,

    M lambda_h = E^T y        (lambda_h in X_h on the merged mesh, Pa; lambda = -sigma_nu)

Checks (§5), all relative and dimensionless, reported by :meth:`Solution.residuals`:

    equilibrium      || A [u; phi] + [J^T M lambda_h; 0] - [f; q] || / max(|| [f; q] ||, || A [u; phi] ||)  (26)
    feasibility      max(E [u_nu] - E g)^+ / max|u|
    complementarity  sum_a |y_a (E [u_nu] - E g)_a| / (F max|u|)                       (27)
    cone             sum_a max(-y_a, 0) / F          (the multiplier lies in Lambda_h)

in scaled units, where F = max(sum_a |y_a|, 1) is the force scale (the scaled loads
total O(1)) and max|u| the displacement scale.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .assembly import assemble_loads, assemble_matrices
from .contact import lumped_lengths
from .condense import condense, quasi_definite, quasi_definite_rhs
from .finish import lcp_start, row_scales, signs_hold, solve_lcp
from .errors import ResidualWarning, SceneError, SolverError
from .fingerprint import geometry_fingerprint
from .model import Block, Compliance, ContactModel, InterfaceModel, Units, units
from .scene import Scene

__all__ = ["solve", "ContactSolver", "Solution", "ContactResult", "DEFAULT_TOL", "METHODS"]

DEFAULT_TOL = 1e-6
"""Default tolerance of the mixed-formulation checks."""

_CLARABEL = dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10, tol_ktratio=1e-8)


@dataclass
class ContactResult:
    """Contact quantities on the merged mesh of Gamma_3 (sorted abscissae ``x``, m).

    ``lam`` is lambda_h (Pa), ``jump`` is [u_h nu] (m), ``force`` the equivalent nodal
    force E^T y (N/m), ``constrained`` marks the nodes where non-penetration is imposed
    and ``active`` those among them that carry a positive force; ``line`` is the
    ordinate of Gamma_3 (m), ``gap`` the initial gap g at the nodes (m).
    """

    x: np.ndarray
    lam: np.ndarray
    jump: np.ndarray
    force: np.ndarray
    constrained: np.ndarray
    active: np.ndarray
    line: float = 0.0
    gap: np.ndarray | None = None

    @property
    def pressure(self) -> np.ndarray:
        """Nodal force divided by the lumped length of each node (Pa)."""
        return self.force / lumped_lengths(self.x)


@dataclass
class Solution:
    """Result of :func:`solve`. Displacements in m, potentials in V, lambda in Pa.

    ``energy`` is the reduced coupled energy Pi(u_h) of shared/math.md §2 in J/m (per
    unit thickness; with driven electrodes, up to the constant of the lifting).
    ``problem`` holds the interior-point values; with ``polished`` the arrays here
    are the exact finish. ``path`` says how the answer was reached: "interior point",
    "interior point + exact finish" or, for a re-solve of a :class:`ContactSolver`,
    "active-set warm start" (then ``problem`` is None: no convex program was needed,
    and the answer passed the same sign and residual checks).
    """

    scene: Scene
    condition: str
    u: list
    phi: list
    contact: ContactResult
    status: str
    problem: cp.Problem
    tol: float
    polished: bool = False
    energy: float = float("nan")
    method: str = "full"
    path: str = ""
    timings: dict = field(default_factory=dict)
    _checks: dict = field(default_factory=dict, repr=False)

    def residuals(self) -> dict:
        """Relative residuals of the mixed formulation (26)-(27): see the module docstring."""
        return dict(self._checks)

    @property
    def ok(self) -> bool:
        """True if the solver reported optimal and every check is below ``tol``."""
        return self.status == cp.OPTIMAL and all(v <= self.tol for v in self._checks.values())

    def traction(self, k):
        """Contact pressure as felt by body ``k`` (0 or 1): (x, p) on its own trace nodes.

        The merged nodal forces are moved to the nodes of body k's trace (the transpose
        of the trace interpolation: exact work equivalence) and divided by the lumped
        lengths there. A non-oscillating view of lambda, in Pa, on that body's mesh.
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k not in (0, 1):
            raise SceneError(f"traction(k): k must be 0 or 1 (the body), got {k!r}")
        itf = self.scene.interface
        x = itf.traces[k].x
        return x.copy(), (itf.interpolation(k).T @ self.contact.force) / lumped_lengths(x)

    def report(self) -> str:
        """A short human-readable account of the solve and its checks."""
        finish = "exact finish" if self.polished else "interior-point answer"
        lines = [f"condition {self.condition}, solver status {self.status}, {finish}, "
                 f"{int(self.contact.active.sum())} of {int(self.contact.constrained.sum())} "
                 f"constrained nodes active"]
        lines += [f"  {k:16s} {v:.2e}  {'ok' if v <= self.tol else 'FAILED'}" for k, v in self._checks.items()]
        return "\n".join(lines)


METHODS = ("full", "condensed")


def solve(scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = "full",
          tol: float = DEFAULT_TOL, polish: bool = True, verbose: bool = False,
          solver_options: Mapping[str, object] | None = None) -> Solution:
    """Solve the frictionless contact problem of ``scene`` as a convex program.

    Parameters
    ----------
    scene : Scene
    condition : {"gamma3", "sigma1", "sigma2"}
        Non-penetration on K_h(Gamma_3) (every merged node) or K_h(Sigma_h^l) (nodes of mesh l).
    solver : str
        A CVXPY solver name; Clarabel by default (with tolerances tightened to 1e-10).
    method : {"full", "condensed"}
        ``"full"`` (the reference) poses the whole phi-form model in CVXPY, so that
        ``Solution.problem`` has the variables ``u1, phi1, u2, ...``. ``"condensed"``
        (fast, exact) factorises each body once, condenses it onto its contact dofs
        (:mod:`cvxcontact.condense`) and poses only the small interface QP in CVXPY.
    tol : float
        Tolerance of the mixed-formulation checks. A solution that fails them is
        returned with ``ok = False`` and a :class:`ResidualWarning`.
    polish : bool
        Exact finish (default): from the active set of the interior-point answer,
        solve the mixed system (26) with the contact closed there and correct the set
        by primal-dual active-set steps until y >= 0 and the open nodes stay feasible
        (:func:`cvxcontact.finish.solve_lcp`; ``Solution.polished``). If that fails the
        interior-point answer stands.
    verbose : bool
        Print the solver's progress.
    solver_options : dict, optional
        Options of the solver, passed to ``cvxpy.Problem.solve``: names to bool, int,
        float or str values (e.g. ``{"max_iter": 100}``). For Clarabel they are checked
        against ``clarabel.DefaultSettings()`` (names, types, ranges) before anything
        is assembled; cvxcontact's own parameters are not accepted here.

    Returns
    -------
    Solution

    Raises
    ------
    SceneError
        ``scene`` is not a Scene or ``condition`` is unknown.
    SolverError
        A bad parameter or solver option, or the solver failed.

    See Also
    --------
    ContactSolver : the same, prepared once for many load cases.
    """
    return ContactSolver(scene, condition, solver, method=method, tol=tol, polish=polish, verbose=verbose,
                         solver_options=solver_options).solve()


class ContactSolver:
    """A solver prepared for one geometry: meshes, materials, boundary parts and condition.

    ``solve()`` solves the scene it was built with; ``solve(other)`` solves a scene
    that differs only in its loads (body forces, tractions, charges, electrode
    potentials), reusing the assembled matrices and, with ``method="condensed"``,
    the factorisations and interface stiffnesses. With ``warm_start`` (default) a
    further load case starts from the previous exact active set and is finished by
    active-set steps on the interface (a few dense solves of the size of the active
    set), falling back to the interior-point solve if they do not settle; it then
    costs two triangular solves per body and little else. ``scale=False`` hands the
    raw SI matrices to the solver (for the stability study only: it shows what the
    non-dimensionalisation prevents). ``warm_start`` and ``scale`` are booleans. Other
    parameters as in :func:`solve`; all are checked before anything is assembled.
    """

    def __init__(self, scene, condition: str = "gamma3", solver: str = "CLARABEL", *, method: str = "full",
                 tol: float = DEFAULT_TOL, polish: bool = True, warm_start: bool = True, scale: bool = True,
                 verbose: bool = False, solver_options: Mapping[str, object] | None = None):
        from .options import check_solve_parameters, check_solver, check_solver_options

        if not isinstance(scene, Scene):
            raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
        tol = check_solve_parameters(condition, method, tol, polish=polish, verbose=verbose,
                                     warm_start=warm_start, scale=scale)
        solver = check_solver(solver)
        self.options = check_solver_options(solver_options, solver)
        self.E = scene.interface.evaluation(condition)
        self.scene, self.condition, self.method = scene, condition, method
        self._fingerprints = [geometry_fingerprint(b) for b in scene.bodies]   # checked on every solve
        self.solver, self.tol, self.polish, self.verbose = solver, tol, polish, verbose
        t0 = time.perf_counter()
        self.matrices = [assemble_matrices(b) for b in scene.bodies]
        self.setup_time = {"assembly": time.perf_counter() - t0}
        self.warm_start, self.scale = warm_start, scale
        self._blocks = self._condensed = self._compliance = self._active = None
        self.path = ""

    def solve(self, scene=None) -> Solution:
        """Solve ``scene`` (default: the scene given at construction); see the class docstring."""
        scene = self._compatible(self.scene if scene is None else scene)
        timings = dict(self.setup_time)
        self.setup_time = {}
        t0 = time.perf_counter()
        systems = [assemble_loads(b, m) for b, m in zip(scene.bodies, self.matrices)]
        gap = scene.gap_values()
        un = units(scene, systems, gap) if self.scale else Units(1.0, 1.0, 1.0, 1.0)
        gap = gap / un.displacement
        if self._blocks is None:
            self._blocks = [Block.scaled(s, scene.interface.jump(k, len(b.mesh.points)), un)
                            for k, (s, b) in enumerate(zip(systems, scene.bodies))]
        blocks = [blk.with_loads(s, un) for blk, s in zip(self._blocks, systems)]
        timings["loads"] = time.perf_counter() - t0
        run = self._full if self.method == "full" else self._condensed_solve
        self.path, self.declined = "interior point", ""
        u, phi, y, active, polished, problem = run(blocks, self.E @ gap, timings)
        if polished and self.path == "interior point":
            self.path = "interior point + exact finish"
        t0 = time.perf_counter()
        sol = _read_back(scene, self.condition, blocks, systems, un, self.E, gap, u, phi, y, active, polished,
                         problem, self.tol, timings)
        sol.method, sol.path = self.method, self.path
        timings["read_back"] = time.perf_counter() - t0
        if self.polish and not polished:
            warnings.warn(f"the exact finish of {scene!r} ({self.condition}) was declined ({self.declined}); "
                          f"the interior-point answer is kept (sol.polished is False):\n{sol.report()}",
                          ResidualWarning, stacklevel=3)
        elif not sol.ok:
            warnings.warn(f"the solution of {scene!r} ({self.condition}) fails its checks at tol={self.tol:g}:\n"
                          f"{sol.report()}", ResidualWarning, stacklevel=3)
        return sol

    def _interface(self, blocks, timings):
        """Condensed bodies and the interface compliance W, built once per geometry."""
        if self._condensed is None:
            t0 = time.perf_counter()
            self._condensed = [condense(b, s, body.mesh) for b, s, body in
                               zip(blocks, self.matrices, self.scene.bodies)]
            self._compliance = Compliance(self._condensed, self.E)
            timings["factorization"] = time.perf_counter() - t0
        return self._condensed, self._compliance

    def _lcp(self, blocks, g, timings):
        """(rhs, v0, d): per-body right-hand sides, unconstrained Gamma displacements, free slack."""
        condensed, compliance = self._interface(blocks, timings)
        t0 = time.perf_counter()
        rhs = [quasi_definite_rhs(b) for b in blocks]
        x0 = [c.solve(F) for c, F in zip(condensed, rhs)]
        v0 = [x[c.gamma] for c, x in zip(condensed, x0)]
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
        return out

    def _full(self, blocks, g, timings):
        t0 = time.perf_counter()
        model = ContactModel(blocks, self.E, g)
        timings["model"] = time.perf_counter() - t0
        _run(model.problem, self.solver, self.verbose, self.options)
        timings["compile"] = model.problem.compilation_time or 0.0
        timings["solve"] = model.problem.solver_stats.solve_time or 0.0
        u = [v.value for v in model.u]
        phi = [v.value if v is not None else None for v in model.phi]
        y = np.asarray(model.contact.dual_value, dtype=float).ravel()
        parts = [self.E @ (b.jump @ uk) for b, uk in zip(blocks, u)]
        slack = sum(parts) - g
        active, polished = _ipm_active(parts, g, y), False
        if self.polish:
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
            self.path = "active-set warm start"
        else:
            t0 = time.perf_counter()
            loads = [c.stiffness @ v for c, v in zip(condensed, v0)]
            model = InterfaceModel(condensed, loads, self.E, g)
            timings["model"] = time.perf_counter() - t0
            _run(model.problem, self.solver, self.verbose, self.options)
            timings["compile"] = model.problem.compilation_time or 0.0
            timings["solve"] = model.problem.solver_stats.solve_time or 0.0
            y = np.asarray(model.contact.dual_value, dtype=float).ravel()
            v = [var.value for var in model.v]
            parts = [self.E @ (c.jump @ vk) for c, vk in zip(condensed, v)]
            slack = sum(parts) - g
            active, polished, problem = _ipm_active(parts, g, y), False, model.problem
            if self.polish:
                out = self._finish(d, lcp_start(compliance.W, d, y, slack), timings)
                if out is not None:
                    y, active, polished = out[0], out[1], True
        if polished:
            self._active = active
        t0 = time.perf_counter()
        x = [c.solve(F - c.lift(self.E.T @ y)) for c, F in zip(condensed, rhs)]
        timings["back_substitution"] = time.perf_counter() - t0
        u = [xk[:c.n_u] for c, xk in zip(condensed, x)]
        phi = [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)]
        return u, phi, y, active, polished, problem

    def accepts(self, scene) -> bool:
        """Whether ``scene`` differs from the prepared one in its loads only."""
        return isinstance(scene, Scene) and [geometry_fingerprint(b) for b in scene.bodies] == self._fingerprints

    def _compatible(self, scene):
        if not isinstance(scene, Scene):
            raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
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
        return scene


def _same_geometry(a, b):
    """Whether two bodies share mesh, material and boundary parts (so that only loads differ)."""
    return geometry_fingerprint(a) == geometry_fingerprint(b)


def _check_solver(solver):
    if not isinstance(solver, str) or solver.upper() not in cp.installed_solvers():
        raise SolverError(f"solver {solver!r} is not available; installed CVXPY solvers: {cp.installed_solvers()}")


def _run(problem, solver, verbose, options):
    given = sorted(options)
    if solver == "CLARABEL":
        options = {**_CLARABEL, **options}
    try:
        problem.solve(solver=solver, verbose=verbose, **options)
    except cp.error.SolverError as exc:
        raise SolverError(f"{solver} failed: {exc}") from exc
    except Exception as exc:  # e.g. an option the solver refuses: TypeError, ValueError, OverflowError
        raise SolverError(f"{solver} refused the problem or the solver options {given}: "
                          f"{type(exc).__name__}: {exc}") from exc
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{solver} ended with status {problem.status!r}; no solution to read back")


def _read_back(scene, condition, blocks, systems, un, E, gap, u, phi, y, active, polished, problem, tol, timings):
    """Scaled (u, phi, y) -> a Solution in SI with lambda_h and the checks of (26)-(27)."""
    itf = scene.interface
    g = E @ gap
    Ety = E.T @ y
    lam = _solve_mass(itf.mass, Ety)                        # scaled; M lam = E^T y
    jump = sum(b.jump @ uk for b, uk in zip(blocks, u))
    checks = _checks(blocks, u, phi, itf.mass @ lam, E, g, y)
    energy = sum(b.energy(uk, pk) for b, uk, pk in zip(blocks, u, phi)) * un.force * un.displacement
    u_si, phi_si = [], []
    for s, b, uk, pk in zip(systems, scene.bodies, u, phi):
        full = np.zeros(2 * len(b.mesh.points))
        full[s.u_free] = uk * un.displacement
        u_si.append(full.reshape(-1, 2))
        if pk is None:
            phi_si.append(None)
            continue
        pot = s.phi_fixed.copy()
        pot[s.phi_free] += pk * un.potential
        phi_si.append(pot)
    constrained = np.zeros(itf.size, dtype=bool)
    constrained[E.indices] = True
    on = np.zeros(itf.size, dtype=bool)
    on[E.indices[active]] = True
    contact = ContactResult(x=itf.x.copy(), lam=lam * un.force, jump=jump * un.displacement, force=Ety * un.force,
                            constrained=constrained, active=on, line=itf.y, gap=gap * un.displacement)
    return Solution(scene=scene, condition=condition, u=u_si, phi=phi_si, contact=contact,
                    status=problem.status if problem is not None else cp.OPTIMAL, problem=problem, tol=tol,
                    polished=polished,
                    energy=float(energy), timings=timings, _checks=checks)


def mixed_kkt(blocks, E, g):
    """``kkt(active)`` for the exact finish of the full model: the sparse mixed system (26)

    [[A, G^T], [G, 0]] [x; y_A] = [F; g_A] with, per body, A = [[Kuu, Kup], [Kup^T, -Kpp]],
    F = [f; -q] (Gauss rows negated, which makes it symmetric) and G the active rows of E [u_nu].
    """
    parts = [quasi_definite(b) for b in blocks]
    A = sp.block_diag([S for S, _ in parts])
    rhs = np.concatenate([F for _, F in parts])
    sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(blocks, parts)]
    rows = [sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], n_phi))]) for b, (_, n_phi) in zip(blocks, sizes)]
    G_all = sp.hstack(rows).tocsr()

    def kkt(active):
        G = G_all[active]
        K = sp.bmat([[A, G.T], [G, None]], format="csc")
        b = np.concatenate([rhs, g[active]])
        try:
            lu = spla.splu(K, permc_spec="MMD_AT_PLUS_A")
        except RuntimeError:  # singular: the active set does not determine the multipliers
            return None
        z = lu.solve(b)
        for _ in range(2):    # iterative refinement: bodies of very different stiffness share one LU
            z += lu.solve(b - K @ z)
        n = A.shape[0]
        y = np.zeros(E.shape[0])
        y[active] = z[n:]
        u, phi, pos = [], [], 0
        for nu, npf in sizes:
            u.append(z[pos:pos + nu])
            phi.append(z[pos + nu:pos + nu + npf] if npf else None)
            pos += nu + npf
        slack = G_all @ z[:n] - g
        return (u, phi, y), y, slack, max(np.abs(uk).max(initial=0.0) for uk in u)

    return kkt


def _solve_mass(M, rhs):
    """Solve the tridiagonal P1 mass system M x = rhs."""
    ab = np.zeros((3, M.shape[0]))
    ab[0, 1:] = M.diagonal(1)
    ab[1] = M.diagonal()
    ab[2, :-1] = M.diagonal(-1)
    return sla.solve_banded((1, 1), ab, rhs)


def _node_scales(parts, g):
    """Slack E [u_nu] - g of the constrained rows, from each body's part E J_l u_l, and each row's
    displacement scale U_a: the sizes of both parts there plus the gap (floored at 1e-9 of the largest)."""
    U = sum(np.abs(p) for p in parts) + np.abs(g)
    return sum(parts) - g, np.maximum(U, 1e-9 * U.max(initial=0.0) + np.finfo(float).tiny)


def _ipm_active(parts, g, y):
    """Active rows of an interior-point answer: the force, relative to the largest contact force,
    beats the open gap relative to the row's displacement scale (free of units and load scale)."""
    slack, U = _node_scales(parts, g)
    return y / max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny) > np.abs(slack) / U


def _checks(blocks, u, phi, Mlam, E, g, y):
    """The relative residuals of the mixed formulation, in scaled units (module docstring).

    Each is normalised where nothing can hide: equilibrium per body by that body's own
    row scales |A||x| + |F| + |J^T||M lambda_h|; feasibility, complementarity and cone
    per constrained node by that node's displacement scale U_a (the sizes of both
    bodies' normal displacements there and of the gap) and by the largest contact
    force, never by the total load.
    """
    tiny = np.finfo(float).tiny
    equilibrium = 0.0
    for b, uk, pk in zip(blocks, u, phi):
        r = np.concatenate(b.residual(uk, pk, Mlam))
        m = np.concatenate(b.magnitude(uk, pk, Mlam))
        equilibrium = max(equilibrium, float(np.linalg.norm(r) / max(np.linalg.norm(m), tiny)))
    slack, U = _node_scales([E @ (b.jump @ uk) for b, uk in zip(blocks, u)], g)
    Y = max(float(np.abs(y).max(initial=0.0)), tiny)
    return {
        "equilibrium": equilibrium,
        "feasibility": float((np.maximum(slack, 0.0) / U).max(initial=0.0)),
        # the error this allows grows like the square root of the product (docs/checks.md): report that
        "complementarity": float(np.sqrt((np.abs(y * slack) / (Y * U)).max(initial=0.0))),
        "cone": float(np.maximum(-y, 0.0).max(initial=0.0) / Y),
    }
