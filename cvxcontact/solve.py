"""Solve a scene, read lambda_h back from the duals, and check the mixed formulation.

Read-back (shared/math.md §4): with y >= 0 the dual of E [u_nu] <= E g,

    M lambda_h = E^T y        (lambda_h in X_h on the merged mesh, Pa; lambda = -sigma_nu)

Checks (§5), all relative and dimensionless, reported by :meth:`Solution.residuals`:

    equilibrium      || A [u; phi] + [J^T M lambda_h; 0] - [f; q] || / || [f; q] ||     (26)
    feasibility      max(E [u_nu] - E g)^+ / max|u|
    complementarity  sum_a |y_a (E [u_nu] - E g)_a| / (F max|u|)                       (27)
    cone             sum_a max(-y_a, 0) / F          (the multiplier lies in Lambda_h)

in scaled units, where F = max(sum_a |y_a|, 1) is the force scale (the scaled loads
total O(1)) and max|u| the displacement scale.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .assembly import assemble
from .errors import ResidualWarning, SceneError, SolverError
from .model import Block, ContactModel, units
from .scene import Scene

__all__ = ["solve", "Solution", "ContactResult", "DEFAULT_TOL"]

DEFAULT_TOL = 1e-6
"""Default tolerance of the mixed-formulation checks."""

_CLARABEL = dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10, tol_ktratio=1e-8)


@dataclass
class ContactResult:
    """Contact quantities on the merged mesh of Gamma_3 (sorted abscissae ``x``, m).

    ``lam`` is lambda_h (Pa), ``jump`` is [u_h nu] (m), ``force`` the equivalent nodal
    force E^T y (N/m), ``constrained`` marks the nodes where non-penetration is imposed
    and ``active`` those among them that carry a positive force; ``line`` is the
    ordinate of Gamma_3 (m).
    """

    x: np.ndarray
    lam: np.ndarray
    jump: np.ndarray
    force: np.ndarray
    constrained: np.ndarray
    active: np.ndarray
    line: float = 0.0

    @property
    def pressure(self) -> np.ndarray:
        """Nodal force divided by the lumped length of each node (Pa): a non-oscillating view of lambda."""
        h = np.diff(self.x)
        w = np.zeros_like(self.x)
        w[:-1] += h / 2
        w[1:] += h / 2
        return self.force / w


@dataclass
class Solution:
    """Result of :func:`solve`. Displacements in m, potentials in V, lambda in Pa.

    ``energy`` is the reduced coupled energy Pi(u_h) of shared/math.md §2 in J/m (per
    unit thickness; with driven electrodes, up to the constant of the lifting).
    ``problem`` holds the interior-point values; with ``polished`` the arrays here
    are the exact finish.
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
    timings: dict = field(default_factory=dict)
    _checks: dict = field(default_factory=dict, repr=False)

    def residuals(self) -> dict:
        """Relative residuals of the mixed formulation (26)-(27): see the module docstring."""
        return dict(self._checks)

    @property
    def ok(self) -> bool:
        """True if the solver reported optimal and every check is below ``tol``."""
        return self.status == cp.OPTIMAL and all(v <= self.tol for v in self._checks.values())

    def report(self) -> str:
        """A short human-readable account of the solve and its checks."""
        finish = "exact finish" if self.polished else "interior-point answer"
        lines = [f"condition {self.condition}, solver status {self.status}, {finish}, "
                 f"{int(self.contact.active.sum())} of {int(self.contact.constrained.sum())} "
                 f"constrained nodes active"]
        lines += [f"  {k:16s} {v:.2e}  {'ok' if v <= self.tol else 'FAILED'}" for k, v in self._checks.items()]
        return "\n".join(lines)


def solve(scene, condition="gamma3", solver="CLARABEL", *, tol=DEFAULT_TOL, polish=True, verbose=False,
          **solver_options):
    """Solve the frictionless contact problem of ``scene`` as a convex program.

    Parameters
    ----------
    scene : Scene
    condition : {"gamma3", "sigma1", "sigma2"}
        Non-penetration on K_h(Gamma_3) (every merged node) or K_h(Sigma_h^l) (nodes of mesh l).
    solver : str
        A CVXPY solver name; Clarabel by default (with tolerances tightened to 1e-10).
    tol : float
        Tolerance of the mixed-formulation checks. A solution that fails them is
        returned with ``ok = False`` and a :class:`ResidualWarning`.
    polish : bool
        Exact finish (default): take the active set of the interior-point answer,
        solve the mixed system (26) with the contact closed there by a sparse LU
        factorization, and keep that answer if y >= 0 and the open nodes stay
        feasible (``Solution.polished``). Otherwise the interior-point answer stands.
    verbose : bool
        Print the solver's progress.
    **solver_options
        Passed to ``cvxpy.Problem.solve``.

    Returns
    -------
    Solution

    Raises
    ------
    SceneError, SolverError
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
    E = scene.interface.evaluation(condition)
    if not (isinstance(tol, (int, float)) and tol > 0):
        raise SolverError(f"tol must be a positive number, got {tol!r}")
    timings = {}
    t0 = time.perf_counter()
    systems = [assemble(b) for b in scene.bodies]
    un = units(scene, systems)
    blocks = [Block.scaled(s, scene.interface.jump(k, len(b.mesh.points)), un)
              for k, (s, b) in enumerate(zip(systems, scene.bodies))]
    gap = np.zeros(scene.interface.size)
    timings["assembly"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    model = ContactModel(blocks, E, gap)
    timings["model"] = time.perf_counter() - t0
    _run(model.problem, solver, verbose, solver_options)
    timings["compile"] = model.problem.compilation_time or 0.0
    timings["solve"] = model.problem.solver_stats.solve_time or 0.0
    t0 = time.perf_counter()
    sol = _read_back(scene, condition, model, systems, un, E, gap, tol, polish, timings)
    timings["read_back"] = time.perf_counter() - t0
    if not sol.ok:
        warnings.warn(f"the solution of {scene!r} ({condition}) fails its checks at tol={tol:g}:\n"
                      f"{sol.report()}", ResidualWarning, stacklevel=2)
    return sol


def _run(problem, solver, verbose, options):
    if not isinstance(solver, str) or solver.upper() not in cp.installed_solvers():
        raise SolverError(f"solver {solver!r} is not available; installed CVXPY solvers: {cp.installed_solvers()}")
    solver = solver.upper()
    if solver == "CLARABEL":
        options = {**_CLARABEL, **options}
    try:
        problem.solve(solver=solver, verbose=verbose, **options)
    except cp.error.SolverError as exc:
        raise SolverError(f"{solver} failed: {exc}") from exc
    except TypeError as exc:
        raise SolverError(f"bad option for {solver}: {exc}") from exc
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{solver} ended with status {problem.status!r}; no solution to read back")


def _read_back(scene, condition, model, systems, un, E, gap, tol, polish, timings):
    blocks, itf = model.blocks, scene.interface
    u = [v.value for v in model.u]
    phi = [v.value if v is not None else None for v in model.phi]
    y = np.asarray(model.contact.dual_value, dtype=float).ravel()
    g = E @ gap
    active = _active_set(blocks, u, y, E, g)
    polished = False
    if polish:
        t0 = time.perf_counter()
        exact = finish(blocks, E, g, active)
        timings["polish"] = time.perf_counter() - t0
        if exact is not None:
            u, phi, y = exact
            polished = True
    Ety = E.T @ y
    lam = _solve_mass(itf.mass, Ety)                        # scaled; M lam = E^T y
    jump = sum(b.jump @ uk for b, uk in zip(blocks, u))
    checks = _checks(blocks, u, phi, itf.mass @ lam, E @ jump - g, y)
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
                            constrained=constrained, active=on, line=itf.y)
    return Solution(scene=scene, condition=condition, u=u_si, phi=phi_si, contact=contact,
                    status=model.problem.status, problem=model.problem, tol=tol, polished=polished,
                    energy=float(energy), timings=timings, _checks=checks)


def _active_set(blocks, u, y, E, g):
    """Constrained rows where the scaled force beats the scaled gap: y / F > |E[u_nu] - E g| / U.

    Loads are scaled to total O(1) (:func:`cvxcontact.model.units`), so F = max(sum|y|, 1);
    U is the largest displacement. The comparison is free of units and of mesh size.
    """
    slack = E @ sum(b.jump @ uk for b, uk in zip(blocks, u)) - g
    F = max(np.abs(y).sum(), 1.0)
    U = max(max(np.abs(uk).max(initial=0.0) for uk in u), np.finfo(float).tiny)
    return y / F > np.abs(slack) / U


def finish(blocks, E, g, active):
    """Exact finish: solve the mixed system (26) with the contact closed on ``active``.

    The system is [[A, G^T], [G, 0]] [x; y_A] = [F; g_A], per body
    A = [[Kuu, Kup], [Kup^T, -Kpp]], F = [f; -q] (Gauss rows negated, which makes
    it symmetric), G = the active rows of E [u_nu]. The result is accepted only if
    the signs hold: y_A >= 0 and the inactive rows stay feasible. Returns scaled
    (u, phi, y) or None.
    """
    mats, rhs, rows, sizes = [], [], [], []
    for b in blocks:
        G = (E[active] @ b.jump)
        if b.Kpp is None:
            mats.append(b.Kuu)
            rhs.append(b.f)
            rows.append(G)
            sizes.append((b.Kuu.shape[0], 0))
            continue
        mats.append(sp.bmat([[b.Kuu, b.Kup], [b.Kup.T, -b.Kpp]]))
        rhs.append(np.concatenate([b.f, -b.q]))
        rows.append(sp.hstack([G, sp.csr_matrix((G.shape[0], b.Kpp.shape[0]))]))
        sizes.append((b.Kuu.shape[0], b.Kpp.shape[0]))
    A, G = sp.block_diag(mats), sp.hstack(rows)
    K = sp.bmat([[A, G.T], [G, None]], format="csc")
    try:
        z = spla.splu(K, permc_spec="MMD_AT_PLUS_A").solve(np.concatenate(rhs + [g[active]]))
    except RuntimeError:  # singular: the active set does not determine the multipliers
        return None
    n = A.shape[0]
    y = np.zeros(E.shape[0])
    y[active] = z[n:]
    u, phi, pos = [], [], 0
    for nu, npf in sizes:
        u.append(z[pos:pos + nu])
        phi.append(z[pos + nu:pos + nu + npf] if npf else None)
        pos += nu + npf
    slack = E @ sum(b.jump @ uk for b, uk in zip(blocks, u)) - g
    scale_u = max(max(np.abs(uk).max(initial=0.0) for uk in u), np.finfo(float).tiny)
    if not np.isfinite(z).all() or (y < -1e-12 * max(np.abs(y).sum(), 1.0)).any() or slack[~active].max(initial=0.0) > 1e-12 * scale_u:
        return None
    return u, phi, y


def _solve_mass(M, rhs):
    """Solve the tridiagonal P1 mass system M x = rhs."""
    ab = np.zeros((3, M.shape[0]))
    ab[0, 1:] = M.diagonal(1)
    ab[1] = M.diagonal()
    ab[2, :-1] = M.diagonal(-1)
    return sla.solve_banded((1, 1), ab, rhs)


def _checks(blocks, u, phi, Mlam, slack, y):
    """The relative residuals of the mixed formulation, in scaled units (module docstring)."""
    res, rhs = [], []
    for b, uk, pk in zip(blocks, u, phi):
        res.extend(b.residual(uk, pk, Mlam))
        rhs.extend([b.f, b.q if b.q is not None else np.zeros(0)])
    norm = np.linalg.norm(np.concatenate(rhs))
    umax = max(float(np.abs(uk).max(initial=0.0)) for uk in u)
    force = max(np.abs(y).sum(), 1.0)       # scaled loads total O(1): see model.units
    tiny = np.finfo(float).tiny
    return {
        "equilibrium": float(np.linalg.norm(np.concatenate(res)) / max(norm, tiny)),
        "feasibility": float(max(slack.max(initial=0.0), 0.0) / max(umax, tiny)),
        "complementarity": float(np.abs(y * slack).sum() / max(force * umax, tiny)),
        "cone": float(np.maximum(-y, 0.0).sum() / force),
    }
