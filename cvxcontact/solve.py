"""Solve a scene, read lambda_h back from the duals, and check the mixed formulation.

Read-back (shared/math.md §4): with y >= 0 the dual of E [u_nu] <= E g,

    M lambda_h = E^T y        (lambda_h in X_h on the merged mesh, Pa; lambda = -sigma_nu)

Checks (§5), all relative and dimensionless, reported by :meth:`Solution.residuals`:

    equilibrium      || A [u; phi] + [J^T M lambda_h; 0] - [f; q] || / || [f; q] ||     (26)
    feasibility      max(E [u_nu] - E g)^+ / max|u|
    complementarity  sum_a |y_a (E [u_nu] - E g)_a| / (sum_a |y_a| max|u|)             (27)
    cone             max(-y)^+ / max|y|              (the multiplier lies in Lambda_h)
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.linalg as sla

from .assembly import assemble
from .contact import CONDITIONS
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
    and ``active`` those among them that carry a positive force.
    """

    x: np.ndarray
    lam: np.ndarray
    jump: np.ndarray
    force: np.ndarray
    constrained: np.ndarray
    active: np.ndarray
    y: float = 0.0

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
    """Result of :func:`solve`. Displacements in m, potentials in V, lambda in Pa."""

    scene: Scene
    condition: str
    u: list
    phi: list
    contact: ContactResult
    status: str
    problem: cp.Problem
    tol: float
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
        lines = [f"condition {self.condition}, solver status {self.status}, "
                 f"{int(self.contact.active.sum())} of {int(self.contact.constrained.sum())} "
                 f"constrained nodes active"]
        lines += [f"  {k:16s} {v:.2e}  {'ok' if v <= self.tol else 'FAILED'}" for k, v in self._checks.items()]
        return "\n".join(lines)


def solve(scene, condition="gamma3", solver="CLARABEL", *, tol=DEFAULT_TOL, verbose=False, **solver_options):
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
    sol = _read_back(scene, condition, model, systems, un, E, gap, tol, timings)
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


def _read_back(scene, condition, model, systems, un, E, gap, tol, timings):
    blocks, itf = model.blocks, scene.interface
    uh = [v.value for v in model.u]
    ph = [v.value if v is not None else None for v in model.phi]
    y = np.asarray(model.contact.dual_value, dtype=float).ravel()
    Ety = E.T @ y
    lam = _solve_mass(itf.mass, Ety)                        # scaled; M lam = E^T y
    jump = sum(b.jump @ u for b, u in zip(blocks, uh))
    checks = _checks(blocks, uh, ph, itf.mass @ lam, E @ (jump - gap), y)

    u_si, phi_si = [], []
    for s, b, u, p in zip(systems, scene.bodies, uh, ph):
        full = np.zeros(2 * len(b.mesh.points))
        full[s.u_free] = u * un.displacement
        u_si.append(full.reshape(-1, 2))
        if p is None:
            phi_si.append(None)
            continue
        pot = np.zeros(len(b.mesh.points))
        pot[s.phi_free] = p * un.potential
        phi_si.append(pot)
    constrained = np.zeros(itf.size, dtype=bool)
    constrained[E.indices] = True
    force = Ety * un.force
    active = constrained & (Ety > 1e-6 * max(np.abs(Ety).max(), np.finfo(float).tiny))
    contact = ContactResult(x=itf.x.copy(), lam=lam * un.force, jump=jump * un.displacement, force=force,
                            constrained=constrained, active=active, y=itf.y)
    return Solution(scene=scene, condition=condition, u=u_si, phi=phi_si, contact=contact,
                    status=model.problem.status, problem=model.problem, tol=tol, timings=timings,
                    _checks=checks)


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
    ymass = np.abs(y).sum()
    tiny = np.finfo(float).tiny
    return {
        "equilibrium": float(np.linalg.norm(np.concatenate(res)) / max(norm, tiny)),
        "feasibility": float(max(slack.max(initial=0.0), 0.0) / max(umax, tiny)),
        "complementarity": float(np.abs(y * slack).sum() / max(ymass * umax, tiny)),
        "cone": float(max(-y.min(initial=0.0), 0.0) + 0.0 / max(np.abs(y).max(initial=0.0), tiny)),
    }
