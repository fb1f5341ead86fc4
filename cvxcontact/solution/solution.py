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

from ..contact.interface import lumped_lengths
from ..errors import SceneError
from ..physics.scene import Scene
from .checks import checks
from .info import Route, SolveInfo, Status

__all__ = ["Solution", "ContactResult", "Electrode", "read_back"]


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


@dataclass(frozen=True)
class Electrode:
    """One electrode of a piezoelectric body: grounded (phi = 0), driven (phi = V) or floating.

    ``body`` is the body's index in the scene, ``tag`` the boundary part, ``kind`` one of
    "grounded", "driven", "floating"; ``potential`` its potential (V; the mean over its nodes
    for a driven electrode whose potential varies along it) and ``charge`` its total charge
    (C/m): the reaction of the Gauss equation (20) summed over its nodes, i.e. -int D.nu ds
    (for a floating electrode, the prescribed Q). A node shared by two electrodes counts for
    the first in the order grounded, driven, floating.
    """

    body: int
    tag: str
    kind: str
    potential: float
    charge: float


def electrodes(scene, systems, u_si, phi_si) -> list[Electrode]:
    """The :class:`Electrode` results of every piezoelectric body (SI, see :class:`Electrode`)."""
    out = []
    for k, (b, s, u, phi) in enumerate(zip(scene.bodies, systems, u_si, phi_si)):
        if phi is None:
            continue
        r = s.Kpp @ (phi - s.phi_fixed) - s.Kup.T @ (u.ravel() - s.u_fixed) - s.q      # C/m per node
        taken = np.zeros(len(phi), dtype=bool)
        parts = ([(t, "grounded") for t in b.grounded] + [(t, "driven") for t in b.potential]
                 + [(t, "floating") for t in getattr(b, "floating", {})])
        for tag, kind in parts:
            nodes = b.mesh.boundary_nodes([tag])
            mine = nodes[~taken[nodes]]
            taken[nodes] = True
            out.append(Electrode(body=k, tag=tag, kind=kind, potential=float(phi[nodes].mean()),
                                 charge=float(r[mine].sum())))
    return out


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
    electrodes: list = field(default_factory=list)
    """:class:`Electrode` results (potential V, charge C/m) of every electrode of every body."""

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


def read_back(scene, condition, blocks, systems, un, E, gap, u, phi, y, active, polished, problem, tol, timings):
    """Scaled (u, phi, y) -> a Solution in SI with lambda_h and the checks of (26)-(27)."""
    itf = scene.interface
    g = E @ gap
    Ety = E.T @ y
    lam = _solve_mass(itf.mass, Ety)                        # scaled; M lam = E^T y
    jump = sum(b.jump @ uk for b, uk in zip(blocks, u))
    checks_ = checks(blocks, u, phi, itf.mass @ lam, E, g, y)
    energy = sum(b.energy(uk, pk) for b, uk, pk in zip(blocks, u, phi)) * un.force * un.displacement
    u_si, phi_si = [], []
    for s, b, uk, pk in zip(systems, scene.bodies, u, phi):
        full = s.u_fixed + s.Tu @ (uk * un.displacement)                  # u = T_u z + u_D
        u_si.append(full.reshape(-1, 2))
        if pk is None:
            phi_si.append(None)
            continue
        phi_si.append(s.phi_fixed + s.Tp @ (pk * un.potential))          # phi = T_p z + phi_D
    constrained = np.zeros(itf.size, dtype=bool)
    constrained[E.indices] = True
    on = np.zeros(itf.size, dtype=bool)
    on[E.indices[active]] = True
    contact = ContactResult(x=itf.x.copy(), lam=lam * un.force, jump=jump * un.displacement, force=Ety * un.force,
                            constrained=constrained, active=on, line=itf.y, gap=gap * un.displacement)
    for a in [*u_si, *(p for p in phi_si if p is not None), *(getattr(contact, f) for f in
              ("x", "lam", "jump", "force", "constrained", "active", "gap"))]:
        a.setflags(write=False)                 # results are data: read-only, never silently edited
    info = SolveInfo(status=problem.status if problem is not None else Status.OPTIMAL, method="",
                     route=Route.INTERIOR_POINT_FINISHED if polished else Route.INTERIOR_POINT,
                     polished=polished, timings=timings)              # provisional: the caller completes it
    return Solution(scene=scene, condition=condition, u=u_si, phi=phi_si, contact=contact, problem=problem,
                    tol=tol, info=info, energy=float(energy), _checks=checks_,
                    electrodes=electrodes(scene, systems, u_si, phi_si))


def _solve_mass(M, rhs):
    """Solve the tridiagonal P1 mass system M x = rhs."""
    ab = np.zeros((3, M.shape[0]))
    ab[0, 1:] = M.diagonal(1)
    ab[1] = M.diagonal()
    ab[2, :-1] = M.diagonal(-1)
    return sla.solve_banded((1, 1), ab, rhs)
