"""The solution of a contact problem: read-back in SI and the checks of (26)-(27).

Read-back (docs/formulation.md §4): with y >= 0 the dual of E [u_nu] <= E g,

    M lambda_h = E^T y        (lambda_h in X_h on the merged mesh, Pa; lambda = -sigma_nu)

The checks are in :mod:`cvxcontact.solution.checks`; what they guarantee is derived in
docs/checks.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from ..contact.interface import lumped_lengths
from ..contact.quadratic import QuadraticInterface
from ..errors import SceneError
from ..physics.scene import Scene
from .checks import checks, conic_checks
from .info import Route, SolveInfo, Status

__all__ = ["Solution", "ContactResult", "read_back"]


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
    degree: int = 1

    @property
    def pressure(self) -> np.ndarray:
        """Nodal force divided by the lumped length of each node (Pa): the row sums of the mass matrix
        of X_h (P1: half of each adjacent segment; P2: h/6 per adjacent segment at a vertex, 2h/3 at a
        midpoint)."""
        return self.force / (lumped_lengths(self.x) if self.degree == 1 else _p2_lumped(self.x))


@dataclass
class Solution:
    """Result of :func:`solve`. Displacements in m, potentials in V, lambda in Pa.

    ``energy`` is the reduced coupled energy Pi(u_h) of docs/formulation.md §2 in J/m (per
    unit thickness; with driven electrodes, up to the constant of the lifting).
    ``problem`` holds the interior-point values; with ``polished`` the arrays here
    are the exact finish. ``path`` says how the answer was reached: "interior point",
    "interior point + exact finish" or, for a re-solve of a :class:`ContactSolver`,
    "active-set warm start" (then ``problem`` is None: no convex program was needed,
    and the answer passed the same sign and residual checks).

    ``info`` (:class:`~cvxcontact.solution.info.SolveInfo`, frozen) records how the solve
    went: status, backend used, route, iterations, timings (s), finish. ``status``,
    ``path``, ``method``, ``timings`` and ``polished`` are read-only views of it.
    """

    scene: Scene
    condition: str
    u: list
    phi: list
    contact: ContactResult
    problem: cp.Problem | None
    tol: float
    info: SolveInfo
    energy: float = float("nan")
    _checks: dict = field(default_factory=dict, repr=False)
    points: list = field(default_factory=list)
    """``points[k]``: coordinates (m) of body k's nodes in the order of ``u[k]`` and ``phi[k]`` (P1: the
    mesh points; P2: vertices first, then edge midpoints)."""
    degree: int = 1

    @property
    def status(self) -> Status:
        """Solver status (:class:`Status`; equal to the CVXPY status string)."""
        return self.info.status

    @property
    def polished(self) -> bool:
        """True if the arrays are the exact finish."""
        return self.info.polished

    @property
    def method(self) -> str:
        """The backend actually used ("full" or "condensed")."""
        return self.info.method

    @property
    def path(self) -> str:
        """The route taken (:class:`Route`; equal to the former strings)."""
        return self.info.route

    @property
    def timings(self):
        """Read-only mapping stage -> wall-clock seconds of this solve."""
        return self.info.timings

    def residuals(self) -> dict[str, float]:
        """Relative residuals of the mixed formulation (26)-(27): see the module docstring."""
        return dict(self._checks)

    @property
    def ok(self) -> bool:
        """True if the solver reported optimal and every check is below ``tol``."""
        return self.status == cp.OPTIMAL and all(v <= self.tol for v in self._checks.values())

    def traction(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Contact pressure as felt by body ``k`` (0 or 1): (x, p) on its own trace nodes.

        The merged nodal forces are moved to the nodes of body k's trace (the transpose
        of the trace interpolation: exact work equivalence) and divided by the lumped
        lengths there. A non-oscillating view of lambda, in Pa, on that body's mesh.
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k not in (0, 1):
            raise SceneError(f"traction(k): k must be 0 or 1 (the body), got {k!r}")
        if self.degree == 2:           # P2: body k's trace nodes (vertices and midpoints), P2 lumped lengths
            itf = QuadraticInterface(self.scene.bodies)
            x = itf.traces[k].x
            return x.copy(), (itf.interpolation(k).T @ self.contact.force) / _p2_lumped(x)
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


def read_back(scene, condition, blocks, systems, un, E, gap, u, phi, y, active, polished, problem, tol, timings,
              interface=None, beta=None, points=None):
    """Scaled (u, phi, y) -> a Solution in SI with lambda_h and the checks of (26)-(27).

    P2 (``interface`` a :class:`~cvxcontact.contact.quadratic.QuadraticInterface`): with the conic
    condition, ``beta`` (S, 3) are the Bernstein duals of each merged segment, ``y`` is the nodal force
    r = B^T beta and M lambda_h = r (docs/formulation.md §8); ``points`` the P2 node coordinates.
    """
    itf = scene.interface if interface is None else interface
    g = E @ gap
    Ety = E.T @ y
    if getattr(itf, "degree", 1) == 2:
        lam = spla.spsolve(itf.mass.tocsc(), Ety)           # scaled; M lam = r (P2 mass of X_h)
    else:
        lam = _solve_mass(itf.mass, Ety)                    # scaled; M lam = E^T y
    jump = sum(b.jump @ uk for b, uk in zip(blocks, u))
    if beta is not None:
        checks_ = conic_checks(blocks, u, phi, Ety, itf.bernstein(), gap, beta)
        S = itf.segments[beta.sum(axis=1) > 1e-6 * max(float(np.abs(beta).max(initial=0.0)), 1e-300)]
        active = np.zeros(itf.size, dtype=bool)
        active[S.ravel()] = True              # the nodes of segments that carry a force
    else:
        checks_ = checks(blocks, u, phi, itf.mass @ lam, E, g, y)
    energy = sum(b.energy(uk, pk) for b, uk, pk in zip(blocks, u, phi)) * un.force * un.displacement
    u_si, phi_si = [], []
    for s, b, uk, pk in zip(systems, scene.bodies, u, phi):
        full = np.zeros(len(s.f))
        full[s.u_free] = uk * un.displacement
        u_si.append(full.reshape(-1, 2))
        if pk is None:
            phi_si.append(None)
            continue
        pot = s.phi_fixed.copy()
        pot[s.phi_free] += pk * un.potential
        phi_si.append(pot)
    constrained = np.zeros(itf.size, dtype=bool)
    on = np.zeros(itf.size, dtype=bool)
    if getattr(itf, "degree", 1) == 2:      # P2: the merged nodes in the support of the constrained rows
        support = np.flatnonzero(np.asarray(abs(E).sum(axis=0)).ravel() > 0)
        constrained[support] = True
        if beta is not None:
            on = active
        else:
            on[np.flatnonzero(np.asarray(abs(E[np.flatnonzero(active)]).sum(axis=0)).ravel() > 0)] = True
    else:
        constrained[E.indices] = True
        on[E.indices[active]] = True
    contact = ContactResult(x=itf.x.copy(), lam=lam * un.force, jump=jump * un.displacement, force=Ety * un.force,
                            constrained=constrained, active=on, line=itf.y, gap=gap * un.displacement,
                            degree=getattr(itf, "degree", 1))
    for a in [*u_si, *(p for p in phi_si if p is not None), *(getattr(contact, f) for f in
              ("x", "lam", "jump", "force", "constrained", "active", "gap"))]:
        a.setflags(write=False)                 # results are data: read-only, never silently edited
    info = SolveInfo(status=problem.status if problem is not None else Status.OPTIMAL, method="",
                     route=Route.INTERIOR_POINT_FINISHED if polished else Route.INTERIOR_POINT,
                     polished=polished, timings=timings)              # provisional: the caller completes it
    pts = points if points is not None else [b.mesh.points for b in scene.bodies]
    return Solution(scene=scene, condition=condition, u=u_si, phi=phi_si, contact=contact, problem=problem,
                    tol=tol, info=info, energy=float(energy), _checks=checks_, points=list(pts),
                    degree=getattr(itf, "degree", 1))


def _p2_lumped(x):
    """Row sums of the P2 mass matrix of the 1D mesh with interleaved nodes x (vertex, midpoint, ...), m."""
    h = x[2::2] - x[:-1:2]
    w = np.zeros_like(x, dtype=float)
    w[:-1:2] += h / 6
    w[2::2] += h / 6
    w[1::2] = 2 * h / 3
    return w


def _solve_mass(M, rhs):
    """Solve the tridiagonal P1 mass system M x = rhs."""
    ab = np.zeros((3, M.shape[0]))
    ab[0, 1:] = M.diagonal(1)
    ab[1] = M.diagonal()
    ab[2, :-1] = M.diagonal(-1)
    return sla.solve_banded((1, 1), ab, rhs)
