"""Scaling and the convex model (shared/math.md §2 and §6).

The mechanical part of the solution of (26)-(27) minimises the reduced coupled energy

    Pi(u) = 1/2 u^T Kuu u - f^T u + 1/2 w^T Kpp^{-1} w,     w = Kup^T u + q,

over K_h. It is posed sparsely in the "phi-form": per body

    minimise   1/2 u^T Kuu u + 1/2 phi^T Kpp phi - f^T u
    subject to Kpp phi - Kup^T u = q              (Gauss law (20), one per piezoelectric body)
               E [u_nu] <= E g                     (K_h(Gamma_3) or K_h(Sigma_h^l))

(no -q^T phi term: the constraint fixes phi). An elastic body has no phi and no
Gauss constraint. All blocks are non-dimensionalised (:class:`Units`) so that the
solver sees O(1) data whatever the SI magnitudes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cvxpy as cp
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

__all__ = ["Units", "Block", "ContactModel", "InterfaceModel", "Compliance", "units"]


@dataclass(frozen=True)
class Units:
    """Reference units: length L0 (m), stress c0 (Pa), permittivity eps0 (F/m), load scale s.

    Displacement U = L0 s, potential Phi = L0 sqrt(c0/eps0) s, energy W = c0 L0^2 s^2
    (J/m), nodal force W/U (N/m), nodal charge W/Phi (C/m). With these, Kuu/c0,
    Kpp/eps0, Kup/sqrt(c0 eps0) are O(1) and so is the scaled solution.
    """

    length: float
    stress: float
    permittivity: float
    load: float

    @property
    def displacement(self) -> float:
        return self.length * self.load

    @property
    def potential(self) -> float:
        return self.length * np.sqrt(self.stress / self.permittivity) * self.load

    @property
    def force(self) -> float:
        return self.stress * self.length * self.load

    @property
    def charge(self) -> float:
        return self.length * np.sqrt(self.stress * self.permittivity) * self.load


def units(scene, systems, gap=None) -> Units:
    """Choose :class:`Units` for a scene from its materials, size, loads and gap (m)."""
    mats = [b.material for b in scene.bodies]
    c0 = max(float(np.abs(m.c).max()) for m in mats)
    eps0 = max([float(np.linalg.eigvalsh(m.kappa).max()) for m in mats if m.piezoelectric] or [1.0])
    L0 = scene.length
    load = max(max(np.abs(s.f).sum() / (c0 * L0) for s in systems),
               max(np.abs(s.q).sum() / (L0 * np.sqrt(c0 * eps0)) if s.piezoelectric else 0.0 for s in systems),
               float(np.abs(gap).max()) / L0 if gap is not None and len(gap) else 0.0)
    return Units(L0, c0, eps0, load if load > 0 else 1.0)


@dataclass
class Block:
    """Scaled, Dirichlet-restricted blocks of one body (free dofs only, dimensionless)."""

    Kuu: sp.csr_matrix
    f: np.ndarray
    jump: sp.csr_matrix                 # [u_nu] at merged nodes from the free u dofs
    Kup: sp.csr_matrix | None = None
    Kpp: sp.csr_matrix | None = None
    q: np.ndarray | None = None

    @classmethod
    def scaled(cls, system, jump, un: Units) -> "Block":
        """The free-dof blocks of ``system`` in the units ``un``, with its loads."""
        uf = system.u_free
        blk = cls(Kuu=system.Kuu[uf][:, uf] / un.stress, f=None, jump=jump[:, uf].tocsr())
        if system.piezoelectric:
            pf = system.phi_free
            blk.Kup = system.Kup[uf][:, pf] / np.sqrt(un.stress * un.permittivity)
            blk.Kpp = system.Kpp[pf][:, pf] / un.permittivity
        return blk.with_loads(system, un)

    def with_loads(self, system, un: Units) -> "Block":
        """The same matrices with the loads of ``system`` scaled by ``un`` (the matrices do not depend on
        the load scale)."""
        q = system.q[system.phi_free] / un.charge if self.Kpp is not None else None
        return replace(self, f=system.f[system.u_free] / un.force, q=q)

    def energy(self, u, phi):
        """Scaled reduced energy 1/2 u^T Kuu u - f^T u + 1/2 phi^T Kpp phi (phi satisfying Gauss's law)."""
        e = 0.5 * u @ (self.Kuu @ u) - self.f @ u
        return e if phi is None else e + 0.5 * phi @ (self.Kpp @ phi)

    def internal(self, u, phi):
        """The operator of (26) applied to (u, phi): momentum rows, Gauss rows."""
        if self.Kpp is None:
            return self.Kuu @ u, np.zeros(0)
        return self.Kuu @ u + self.Kup @ phi, self.Kpp @ phi - self.Kup.T @ u

    def loads(self):
        """The right-hand side [f; q] of (26)."""
        return self.f, (self.q if self.q is not None else np.zeros(0))

    def magnitude(self, u, phi, contact_force):
        """Row scales of (26) for this body: |A| |x| + |F| + |J^T| |c|, the sizes of the terms each
        residual row balances (momentum rows, Gauss rows)."""
        cu = abs(self.jump).T @ np.abs(contact_force) + np.abs(self.f)
        au = abs(self.Kuu) @ np.abs(u) + cu
        if self.Kpp is None:
            return au, np.zeros(0)
        au = au + abs(self.Kup) @ np.abs(phi)
        return au, abs(self.Kpp) @ np.abs(phi) + abs(self.Kup).T @ np.abs(u) + np.abs(self.q)

    def residual(self, u, phi, contact_force):
        """Residual of (26) for this body: rows of the momentum and of the Gauss equations."""
        (a_u, a_p), (f, q) = self.internal(u, phi), self.loads()
        return a_u + self.jump.T @ contact_force - f, a_p - q


class ContactModel:
    """The CVXPY problem for given scaled blocks and constraint rows ``E``.

    Attributes: ``problem``, ``u`` and ``phi`` (variables per body, ``phi[k]`` None
    for an elastic body), ``gauss`` (equality constraints per body, or None) and
    ``contact`` (the inequality constraint E [u_nu] <= E g).
    """

    def __init__(self, blocks, E, gap_rows):
        self.blocks = blocks
        self.u = [cp.Variable(b.Kuu.shape[0], name=f"u{k + 1}") for k, b in enumerate(blocks)]
        self.phi = [cp.Variable(b.Kpp.shape[0], name=f"phi{k + 1}") if b.Kpp is not None else None
                    for k, b in enumerate(blocks)]
        energy, self.gauss = 0, []
        for b, u, phi in zip(blocks, self.u, self.phi):
            energy += 0.5 * cp.quad_form(u, cp.psd_wrap(b.Kuu)) - b.f @ u
            if phi is None:
                self.gauss.append(None)
                continue
            energy += 0.5 * cp.quad_form(phi, cp.psd_wrap(b.Kpp))
            self.gauss.append(b.Kpp @ phi - b.Kup.T @ u == b.q)
        jump = sum((E @ b.jump) @ u for b, u in zip(blocks, self.u))
        self.contact = jump <= gap_rows
        self.problem = cp.Problem(cp.Minimize(energy), [c for c in self.gauss if c is not None] + [self.contact])


class InterfaceModel:
    """The condensed contact problem in the Gamma dofs v_l of each body (:mod:`cvxcontact.condense`):

        minimise    sum_l 1/2 v_l^T Sigma_l v_l - g_l^T v_l
        subject to  E sum_l C_l v_l <= E g               (the same contact rows as the full model)

    Attributes: ``problem``, ``v`` (variables ``v1``, ``v2``) and ``contact``.
    """

    def __init__(self, bodies, loads, E, gap_rows):
        self.v = [cp.Variable(len(b.gamma), name=f"v{k + 1}") for k, b in enumerate(bodies)]
        energy = sum(0.5 * cp.quad_form(v, cp.psd_wrap(b.stiffness)) - g @ v
                     for b, v, g in zip(bodies, self.v, loads))
        self.contact = sum((E @ b.jump) @ v for b, v in zip(bodies, self.v)) <= gap_rows
        self.problem = cp.Problem(cp.Minimize(energy), [self.contact])


class Compliance:
    """Interface compliance of condensed bodies seen by the contact rows E (scaled units):

        R_l = E C_l,   B_l = Sigma_l^{-1} R_l^T,   W = sum_l R_l B_l   (SPD on the rows).

    With v0_l the unconstrained Gamma displacements and d = sum_l R_l v0_l - E g the
    slack at y = 0, a contact force y gives v_l = v0_l - B_l y and slack d - W y.
    Computed once per geometry; every load case reuses it.
    """

    def __init__(self, bodies, E):
        self.rows = [np.asarray((E @ b.jump)) for b in bodies]
        self.B = [sla.cho_solve(sla.cho_factor(b.stiffness), R.T) for b, R in zip(bodies, self.rows)]
        self.W = sum(R @ B for R, B in zip(self.rows, self.B))

    def free_slack(self, v0, gap_rows) -> np.ndarray:
        """d = sum_l R_l v0_l - E g: the slack of the contact rows with no contact force."""
        return sum(R @ v for R, v in zip(self.rows, v0)) - gap_rows

    def state(self, v0, y) -> list:
        """Gamma displacements v_l = v0_l - B_l y under contact forces y."""
        return [v0k - B @ y for v0k, B in zip(v0, self.B)]
