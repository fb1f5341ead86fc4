"""The discrete problem: Dirichlet-restricted, non-dimensionalised blocks of each body (docs/formulation.md).

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

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ..errors import frozen
from .energy import BulkEnergy, Quadratic, abs_product, bulk_energy

__all__ = ["Units", "Block", "units"]


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


def units(scene, systems, gap=None, forces=()) -> Units:
    """Choose :class:`Units` for a scene from its materials, size, loads, gap (m) and the prescribed
    forces (N/m) of force-controlled obstacles."""
    mats = [b.material for b in scene.bodies]
    c0 = max(float(np.abs(m.c).max()) for m in mats)
    eps0 = max([float(np.linalg.eigvalsh(m.kappa).max()) for m in mats if m.piezoelectric] or [1.0])
    L0 = scene.length
    load = max(max(np.abs(s.f).sum() / (c0 * L0) for s in systems),
               max((np.abs(s.q).sum() + np.abs(s.charge).sum()) / (L0 * np.sqrt(c0 * eps0)) if s.piezoelectric
                   else 0.0 for s in systems),
               float(np.abs(gap).max()) / L0 if gap is not None and len(gap) else 0.0,
               sum(float(np.abs(F).sum()) for F in forces) / (c0 * L0))
    return Units(L0, c0, eps0, load if load > 0 else 1.0)


def _selection(T):
    """The selected rows of a selection matrix T (one 1 per column, at most one per row), or None."""
    T = T.tocsc()
    if T.nnz != T.shape[1] or not np.all(np.diff(T.indptr) == 1) or not np.all(T.data == 1.0):
        return None
    rows = T.indices
    return rows if len(np.unique(rows)) == len(rows) else None


def _congruence(A, K, B):
    """A^T K B as CSR; a plain row/column selection when A and B are selections: no round-off, and the
    assembled sparsity pattern kept (a sparse product drops entries that cancel to zero, e.g. the x-y
    couplings of an orthotropic material; SuperLU's fill-reducing ordering on the thinned pattern was
    measured 4-15x slower on the benchmark scene, benchmarks/bench_default.py)."""
    ra, rb = _selection(A), _selection(B)
    if ra is not None and rb is not None:
        return K.tocsr()[ra][:, rb].tocsr()
    return (A.T @ K @ B).tocsr()


NONE_KEPT = "none kept"
"""The key of :attr:`Block.absolute` that says no |K| values are kept (:meth:`Block.keep_no_abs`)."""


@dataclass
class Block:
    """Scaled, Dirichlet-restricted blocks of one body (free dofs only, dimensionless)."""

    Kuu: sp.csr_matrix
    f: np.ndarray
    jump: sp.csr_matrix                 # [u_nu] at merged nodes from the free u dofs
    Kup: sp.csr_matrix | None = None
    Kpp: sp.csr_matrix | None = None
    q: np.ndarray | None = None
    bulk: BulkEnergy | None = None      # the mechanical energy (:mod:`cvxcontact.discrete.energy`; set by with_loads)
    products: dict = field(default_factory=dict, repr=False, compare=False)   # the last K z (:meth:`_times`)
    absolute: dict = field(default_factory=dict, repr=False, compare=False)   # |K|'s values (:meth:`abs_values`;
    # the entry NONE_KEPT: none kept from now on, :meth:`keep_no_abs`)

    def __post_init__(self):
        for name in ("Kuu", "jump", "Kup", "Kpp"):          # canonical and read-only: a solve cannot reorder them
            frozen(getattr(self, name))

    @classmethod
    def scaled(cls, system, jump, un: Units) -> "Block":
        """The reduced blocks of ``system`` in the units ``un``, with its loads: T_u^T Kuu T_u,
        T_u^T Kup T_p, T_p^T Kpp T_p and J T_u with the prolongations of
        :func:`cvxcontact.fem.assembly.prolongation` (formulation.md §11)."""
        Tu, Tp, Kup, Kpp = system.Tu, system.Tp, None, None
        if system.piezoelectric and Tp.shape[1]:              # every potential prescribed: no Gauss rows, the
            Kup = _congruence(Tu, system.Kup, Tp) / np.sqrt(un.stress * un.permittivity)   # potential's lift is
            Kpp = _congruence(Tp, system.Kpp, Tp) / un.permittivity                          # a load of f
        blk = cls(Kuu=_congruence(Tu, system.Kuu, Tu) / un.stress, f=None, jump=(jump @ Tu).tocsr(), Kup=Kup, Kpp=Kpp)
        return blk.with_loads(system, un)

    def with_loads(self, system, un: Units) -> "Block":
        """The same matrices with the loads of ``system`` scaled by ``un`` (the matrices do not depend on
        the load scale)."""
        fz, qz = system.reduced_loads()
        return replace(self, f=fz / un.force, q=qz / un.charge if self.Kpp is not None else None,
                       bulk=bulk_energy(system, un, self.Kuu), products={})

    def energy(self, u, phi):
        """Scaled reduced energy Pi(u) - f^T u + 1/2 phi^T Kpp phi (phi satisfying Gauss's law; Pi the bulk energy,
        1/2 u^T Kuu u for a linear material). Kuu u and Kpp phi: those of :meth:`internal` if it had the same
        (u, phi) (:meth:`_times`: the checks' residual and the energy of one answer form them once)."""
        e = (0.5 * float(u @ self._times("Kuu", u)) if self._linear else self.bulk.value(u)) - self.f @ u
        return e if phi is None else e + 0.5 * phi @ self._times("Kpp", phi)

    def internal(self, u, phi):
        """The operator of (26) applied to (u, phi): momentum rows (the bulk energy's gradient, Kuu u for a linear
        material: the internal forces of sigma = A(eps(u)) - E* E(phi)), Gauss rows."""
        Ku = self._times("Kuu", u) if self._linear else self.bulk.gradient(u)
        if self.Kpp is None:
            return Ku, np.zeros(0)
        return Ku + self.Kup @ phi, self._times("Kpp", phi) - self.Kup.T @ u

    @property
    def _linear(self) -> bool:
        """The bulk energy is 1/2 u^T Kuu u of this block's Kuu (its gradient the product Kuu u)."""
        return isinstance(self.bulk, Quadratic) and self.bulk.K is self.Kuu

    def _times(self, name, z) -> np.ndarray:
        """The product of the matrix ``name`` ("Kuu", "Kpp") with ``z`` (read-only): the last one of this block
        if ``z`` holds the same numbers (kept with a copy of z: 16 bytes per unknown), else formed and kept."""
        K, key = getattr(self, name), ("product", name)
        last = self.products.get(key)
        if last is not None and last[0] is K and np.array_equal(last[1], z):
            return last[2]
        out = K @ z
        out.setflags(write=False)
        self.products[key] = (K, np.array(z, dtype=float), out)
        return out

    def abs_values(self, name: str) -> tuple:
        """(M, |M|'s values): M the matrix ``name`` ("Kuu", "Kup", "Kpp"; "KupT": Kup^T, a CSC view of Kup's
        arrays; "jump": |jump|^T, the small matrix itself) and np.abs of its stored values (read-only), built when
        first asked and kept while the matrix is the same object. A load case's blocks share this store
        (:meth:`with_loads` keeps it: the same matrices), so |K| is formed once per problem, not per check: 8 bytes
        per stored entry of Kuu, Kup and Kpp (Kup^T reads Kup's), sharing K's index arrays. The checks ask it from
        their second product of a matrix on (:meth:`_abs_times`), unless the store keeps none (:meth:`keep_no_abs`:
        the body's factors freed, memory short)."""
        source = self.Kup if name == "KupT" else getattr(self, name)
        kept = self.absolute.get(name)
        if kept is None or kept[0] is not source or kept[1] is None:
            if name == "jump":
                M = abs(source).T                               # as abs(jump).T (the same numbers)
                values = M.data
            else:
                M = source.T if name == "KupT" else source
                values = self.abs_values("Kup")[1] if name == "KupT" else np.abs(source.data)
            values.setflags(write=False)
            kept = self.absolute[name] = (source, M, values)
        return kept[1], kept[2]

    def _abs_times(self, name: str, z) -> np.ndarray:
        """|M| |z| of the matrix ``name``: the first product of a matrix by :func:`abs_product` alone (its |values|
        formed block by block, none kept: a one-shot solve's checks peak no higher than without the store), the
        next on the values :meth:`abs_values` keeps (a re-solve; the same numbers either way)."""
        source = self.Kup if name == "KupT" else getattr(self, name)
        kept = self.absolute.get(name)
        if kept is not None and kept[0] is source:
            M, values = self.abs_values(name)
            return abs_product(M, z, values)
        if NONE_KEPT not in self.absolute:
            self.absolute[name] = (source, None, None)          # asked once: kept if asked again
        return abs_product(source.T if name == "KupT" else source, z)

    def keep_no_abs(self) -> None:
        """Drop |K|'s values kept for Kuu, Kup and Kpp (:meth:`abs_values`) and keep none from now on, for every load
        case of this problem (they share the store): each |K| |x| of the checks then forms them block by block, as
        a first product does (the same numbers). Where the condensed route freed this body's factors because memory
        was short (:mod:`cvxcontact.backends.budget`), the 8 bytes per stored entry a re-solve would keep are freed
        with them: a re-solve's peak is then not raised by the store, as a one-shot solve's is not."""
        self.absolute.clear()
        self.absolute[NONE_KEPT] = (None, None, None)

    def loads(self):
        """The right-hand side [f; q] of (26)."""
        return self.f, (self.q if self.q is not None else np.zeros(0))

    def magnitude(self, u, phi, contact_force):
        """Row scales of (26) for this body: |A| |x| + |F| + |J^T| |c|, the sizes of the terms each
        residual row balances (momentum rows, Gauss rows)."""
        cu = self.abs_values("jump")[0] @ np.abs(contact_force) + np.abs(self.f)
        au = (self._abs_times("Kuu", u) if self._linear else self.bulk.magnitude(u)) + cu
        if self.Kpp is None:
            return au, np.zeros(0)
        au = au + self._abs_times("Kup", phi)            # (|K|'s values kept: abs_values)
        return au, self._abs_times("Kpp", phi) + self._abs_times("KupT", u) + np.abs(self.q)

    def residual(self, u, phi, contact_force):
        """Residual of (26) for this body: rows of the momentum and of the Gauss equations."""
        (a_u, a_p), (f, q) = self.internal(u, phi), self.loads()
        return a_u + self.jump.T @ contact_force - f, a_p - q
