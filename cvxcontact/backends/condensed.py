"""Exact static condensation of each body onto its contact unknowns (the fast path).

Contact touches only the normal displacements of the trace nodes on Gamma_3 (the
"Gamma dofs", O(sqrt(n)) of them). Per body, with the symmetric quasi-definite form
of (26) on the free dofs (scaled units)

    S = [[Kuu, Kup], [Kup^T, -Kpp]],     F = [f; -q],

S is factorised once with the Gamma dofs as its Schur block (:mod:`cvxcontact.backends.factor`: SciPy's
SuperLU on a minimum-degree order with the Gamma dofs last, reading the trailing block of its factors, or
Intel oneMKL PARDISO's Schur-complement option), which gives

    Sigma = S_GG - S_GI S_II^{-1} S_IG        (interface stiffness, SPD)

so the whole body reduces exactly to  1/2 v^T Sigma v - g^T v  in the Gamma dofs v,
with g = Sigma v0 and v0 the Gamma part of S^{-1} F. The contact problem becomes a
small dense QP in (v_1, v_2); the body fields follow from one back-substitution
x = S^{-1} (F - J^T E^T y).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import cvxpy as cp
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError, user_stacklevel
from .factor import Factorization, Forward, factorize, resolve
from .finish.lcp import LastFactor
from .parallel import ParallelRows
from .released import Released

__all__ = ["CondensedBody", "Compliance", "InterfaceModel", "InterfaceSystem", "condense", "contact_dofs", "node_order",
           "quasi_definite", "quasi_definite_rhs"]

def node_order(mesh) -> np.ndarray:
    """A fill-reducing elimination order of the mesh nodes (SuperLU's minimum degree on A + A^T).

    Computed on the scalar node graph (a graph Laplacian plus identity), which is
    several times cheaper to factorise than the body's coupled system. ``mesh`` may be any object
    with ``points`` and element rows ``cells`` (triangles or tetrahedra, P1 or P2 nodes).
    """
    tri = mesh.cells.astype(np.int32)
    n, k = len(mesh.points), tri.shape[1]
    rows, cols = np.repeat(tri, k, axis=1).ravel(), np.tile(tri, (1, k)).ravel()
    A = sp.csc_matrix((-np.ones(len(rows)), (rows, cols)), shape=(n, n))
    A.data[:] = -1.0
    A = (A + sp.diags(1.0 - np.asarray(A.sum(axis=0)).ravel())).tocsc()
    lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    return np.argsort(lu.perm_c)


@dataclass
class CondensedBody:
    """One body's factorisation and its interface stiffness (scaled units).

    ``factor`` is the :class:`~cvxcontact.backends.factor.Factorization` of S (``factor.name``: "superlu" or
    "pardiso"); ``gamma`` indexes the Gamma dofs in the body's free-dof vector x = [u; phi];
    ``stiffness`` is Sigma, ``jump`` the (n_merged, m) map from v to [u_nu] (sparse CSR: a merged node reads the
    few Gamma dofs of its faces, so that the interface rows E J are O(rows) numbers, not rows x Gamma dofs).
    """

    factor: Factorization
    n_u: int
    gamma: np.ndarray
    stiffness: np.ndarray
    jump: np.ndarray

    @property
    def factorization(self) -> str:
        """The adapter that factorised S ("superlu" or "pardiso")."""
        return self.factor.name


    @property
    def perm(self):
        """SuperLU's elimination order of the dofs (None for another adapter)."""
        return getattr(self.factor, "perm", None)

    def solve(self, rhs):
        """x = S^{-1} rhs, in the body's free-dof order."""
        return self.factor.solve(rhs)

    def forward(self, rhs) -> Forward:
        """The forward sweep of ``rhs`` = F (one per load case): ``.reduced`` r = F_G - S_GI S_II^{-1} F_I,
        which is the interface load g = Sigma v0."""
        return self.factor.forward(rhs)

    def unconstrained(self, fwd: Forward) -> np.ndarray:
        """v0 = Sigma^{-1} r: the Gamma part of S^{-1} F (no contact force)."""
        return self.factor.schur_solve(fwd.reduced)

    def gamma_values(self, fwd: Forward, contact_force) -> np.ndarray:
        """v = Sigma^{-1} (r - J^T contact_force): the Gamma part of S^{-1} (F - J^T contact_force), from the
        forward sweep of F (J^T only touches the Gamma dofs)."""
        return self.factor.schur_solve(fwd.reduced - self.jump.T @ contact_force)

    def back_substitute(self, fwd: Forward, contact_force) -> np.ndarray:
        """x = S^{-1} (F - J^T contact_force) from the forward sweep of F: its :meth:`gamma_values`, then one
        backward sweep."""
        return self.factor.backward(fwd, self.gamma_values(fwd, contact_force))

    def lift(self, contact_force):
        """J^T contact_force as a vector over the free dofs (nonzero on the Gamma dofs only)."""
        out = np.zeros(self.factor.n)
        out[self.gamma] = self.jump.T @ contact_force
        return out


def quasi_definite(block):
    """S = [[Kuu, Kup], [Kup^T, -Kpp]] and F = [f; -q] of a scaled :class:`~cvxcontact.discrete.Block`."""
    if block.Kpp is None:
        return block.Kuu.tocsc(), block.f
    S = sp.bmat([[block.Kuu, block.Kup], [block.Kup.T, -block.Kpp]], format="csc")
    return S, quasi_definite_rhs(block)


def quasi_definite_rhs(block):
    """F = [f; -q] (the Gauss rows negated, as in :func:`quasi_definite`)."""
    return block.f if block.Kpp is None else np.concatenate([block.f, -block.q])


def contact_dofs(block) -> np.ndarray:
    """The Gamma dofs of a body's scaled ``block``: the columns of its jump map touching [u_nu] (sorted)."""
    return np.flatnonzero(np.diff(block.jump.tocsc().indptr))


def condense(block, system, mesh, factorization: str = "auto", threads: int | None = None,
             held: bool = False, budget=None) -> CondensedBody:
    """Factorise one body with its Gamma dofs as the Schur block and extract Sigma (module docstring).

    ``factorization``: one of :data:`~cvxcontact.backends.factor.FACTORIZATIONS` ("auto": PARDISO if Intel
    oneMKL loads, else SuperLU); ``threads``: MKL threads for PARDISO (default: the environment's, else all
    cores). With "auto", a PARDISO factorisation that perturbs pivots or fails falls back to SuperLU with a
    warning; an explicit "pardiso" raises :class:`SolverError` instead.

    ``held``: the body has rigid motions only the contact holds (S singular; the contact rows see them, so
    S_II, the Gamma dofs fixed, is not). S + D is factorised instead, D = diag(|S_jj|) on the Gamma dofs: its
    II and IG blocks are S's, so the forward sweep's reduced load r = F_G - S_GI S_II^-1 F_I and the backward
    sweep x_I = S_II^-1 (F_I - S_IG v) are S's, and ``stiffness`` is Sigma = Schur(S + D) - D, singular along the
    rigid motions (only :mod:`cvxcontact.backends.forced` reads such a body: ``unconstrained`` and
    ``back_substitute`` solve with S + D).

    ``budget``: a :class:`~cvxcontact.backends.budget.Budget`; where it says so, the factors are freed once Sigma
    and the forward sweep of the body's load are taken (``factor`` is then a
    :class:`~cvxcontact.backends.released.Released`, which re-makes S_II's factorisation for each later sweep).
    """
    S, F = quasi_definite(block)
    n_u = block.Kuu.shape[0]
    gamma = contact_dofs(block)
    shift = np.zeros(len(gamma))
    if held:
        shift = np.abs(S.diagonal()[gamma])
        S = (S + sp.csc_matrix((shift, (gamma, gamma)), shape=S.shape)).tocsc()
    kind = resolve(factorization)
    factor = None
    if kind == "pardiso" and 0 < len(gamma) < S.shape[0]:
        try:
            factor = factorize(S, gamma, "pardiso", threads=threads)
        except SolverError as exc:
            if factorization == "pardiso":
                raise
            warnings.warn(f"PARDISO refused a body's matrix ({exc}); falling back to SuperLU",
                          stacklevel=user_stacklevel())
    if factor is None:
        factor = factorize(S, gamma, "superlu", order=_superlu_order(S, gamma, n_u, system, mesh))
    if budget is not None and budget.release(factor.memory, possible=0 < len(gamma) < S.shape[0]):
        factor = Released(factor, S, F)
    stiffness = factor.schur                        # (shared, read only: no second m x m copy)
    if held:
        stiffness = factor.schur.copy()
        stiffness[np.diag_indices(len(gamma))] -= shift
    return CondensedBody(factor=factor, n_u=n_u, gamma=gamma, stiffness=stiffness,
                         jump=sp.csr_matrix(block.jump[:, gamma]))


def _superlu_order(S, gamma, n_u, system, mesh):
    """SuperLU's elimination order: the minimum-degree node order (the displacement components and phi of a node together), a
    floating electrode's potentials late, the Gamma dofs last in their sorted order."""
    d = len(system.f) // len(mesh.points)                                   # displacement components per node
    node = np.concatenate([system.u_free // d, system.phi_free if system.piezoelectric else []]).astype(int)
    kind = np.concatenate([system.u_free % d, np.full(S.shape[0] - n_u, d)])
    rank = np.empty(len(mesh.points), dtype=np.int64)
    rank[node_order(mesh)] = np.arange(len(mesh.points))
    key = (d + 1) * rank[node] + kind
    if system.piezoelectric and system.floating.any():                      # a floating electrode couples a
        fl = n_u + np.flatnonzero(system.floating)                          # whole part: eliminate it late
        key[fl] = key.max() + 1 + np.arange(len(fl))
    key[gamma] = key.max(initial=-1) + 1 + np.arange(len(gamma))            # Gamma dofs last, in x order
    return np.argsort(key, kind="stable")


class InterfaceModel:
    """The condensed contact problem in the Gamma dofs v_l of each body (:mod:`cvxcontact.backends.condensed`):

        minimise    sum_l 1/2 v_l^T Sigma_l v_l - g_l^T v_l
        subject to  E sum_l C_l v_l <= E g               (the same contact rows as the full model)

    Attributes: ``problem``, ``v`` (variables ``v1``, ``v2``) and ``contact``. With a normal-compliance
    ``law`` (scaled) the energy gets the lumped compliance energy of the rows
    (:func:`cvxcontact.backends.full.compliance_energy`, ``weights`` the lumped lengths) and ``contact``
    is the penetration limit E [u_nu] <= E g + l on the rows ``limit_rows`` with a finite limit (per-row
    laws, :class:`~cvxcontact.contact.laws.RowLaws`: Signorini rows l = 0), or None.
    """

    def __init__(self, bodies, loads, E, gap_rows, law=None, weights=None):
        self.v = [cp.Variable(len(b.gamma), name=f"v{k + 1}") for k, b in enumerate(bodies)]
        # a body whose contact dofs its supports all hold (a roller on the pair's part) has none: no term
        energy = sum(0.5 * cp.quad_form(v, cp.psd_wrap(b.stiffness)) - g @ v
                     for b, v, g in zip(bodies, self.v, loads) if len(b.gamma))
        jump = sum((E @ b.jump) @ v for b, v in zip(bodies, self.v))
        from .full import law_rows

        term, self.contact, self.limit_rows = law_rows(jump, gap_rows, weights, law)
        energy += term
        self.problem = cp.Problem(cp.Minimize(energy), [self.contact] if self.contact is not None else [])


def _sigma_cholesky(body):
    """``scipy.linalg.cho_factor``'s factors of a body's ``stiffness`` Sigma: its factorisation's own where Sigma
    is that factorisation's Schur complement (no second m x m copy), else computed."""
    factor = getattr(body, "factor", None)
    if factor is not None and body.stiffness is factor.schur and factor.cholesky is not None:
        return factor.cholesky
    return sla.cho_factor(body.stiffness)


class Compliance:
    """Interface compliance of condensed bodies seen by the contact rows E (scaled units):

        R_l = E C_l,   B_l = Sigma_l^{-1} R_l^T,   W = sum_l R_l B_l   (SPD on the rows),

    R_l sparse (``rows``; a row touches the few Gamma dofs of its overlay vertex's faces), B_l and W dense.

    With v0_l the unconstrained Gamma displacements and d = sum_l R_l v0_l - E g the
    slack at y = 0, a contact force y gives v_l = v0_l - B_l y and slack d - W y.
    Built once per geometry (the Cholesky factors of every Sigma_l); ``B`` and ``W`` are formed on their first
    use and kept, so that every load case reuses them. A finish that needs W on a few rows only (the dependent
    rows of 3D "gamma3", :class:`~cvxcontact.backends.finish.rows.CompliantRows`) reads the block of the rows it
    asks for instead (:meth:`keep`, kept for every load case): m^2 n_Gamma flops and m^2 doubles saved, m the
    rows (1.4e5 unknowns: 8,353 rows, about 9 CPU s and 0.56 GB).
    """

    def __init__(self, bodies, E):
        self.rows = [sp.csr_matrix(E @ b.jump) for b in bodies]
        self._factors = [_sigma_cholesky(b) for b in bodies]
        self._B = self._W = self._stacked = self._parallel = None
        m = E.shape[0]
        self.where = np.full(m, -1)          # each row's position in the kept block, -1 if not kept (:meth:`keep`)
        self.count = 0
        self.kept_B = np.zeros((sum(R.shape[1] for R in self.rows), min(m, 64)))   # B's columns of the kept rows
        self.kept_W = np.zeros((min(m, 64), min(m, 64)))                          # W on the kept rows
        self.last_factor = LastFactor()      # the exact finish's last factor of W on its closed rows (solve_lcp)

    @property
    def B(self) -> list:
        """Per body, Sigma_l^{-1} R_l^T (n_Gamma,l x m), formed on first use."""
        if self._B is None:
            self._B = [sla.cho_solve(f, R.T.toarray()) for f, R in zip(self._factors, self.rows)]
        return self._B

    @property
    def W(self) -> np.ndarray:
        """W = sum_l R_l B_l (m x m), formed on first use; read-only (a factor of it is kept between load cases)."""
        if self._W is None:
            self._W = sum(np.asarray(R @ B) for R, B in zip(self.rows, self.B))
            self._W.flags.writeable = False      # read-only: the exact finish keeps a factor of it (LastFactor)
        return self._W

    @property
    def stacked(self) -> sp.csr_matrix:
        """R = [R_1, R_2, ...] (m x n_Gamma, every body's Gamma dofs in order; sparse), formed on first use."""
        if self._stacked is None:
            self._stacked = sp.hstack(self.rows, format="csr")
        return self._stacked

    @property
    def parallel(self) -> ParallelRows:
        """The parallel groups of the rows of :attr:`stacked` (the rows of several obstacles at one node with one
        normal), found on first use and kept for the geometry: the exact finish leaves open the rows a tighter
        parallel row implies (:meth:`ParallelRows.looser <cvxcontact.backends.parallel.ParallelRows.looser>`)."""
        if self._parallel is None:
            self._parallel = ParallelRows(self.stacked)
        return self._parallel

    def columns(self, rows) -> np.ndarray:
        """The columns ``rows`` of every body's B_l, stacked: Sigma^{-1} R_rows^T over all Gamma dofs (the
        bodies in order), so that W[a, rows] = R_a @ columns(rows) with R = :attr:`stacked`."""
        rows = np.asarray(rows, dtype=int)
        if self._B is not None:
            return np.vstack([B[:, rows] for B in self._B])
        return np.vstack([sla.cho_solve(f, R[rows].T.toarray()) for f, R in zip(self._factors, self.rows)])

    def keep(self, rows) -> np.ndarray:
        """The positions of ``rows`` in the kept block: ``kept_B[:, pos]`` are their columns of B (stacked) and
        ``kept_W[pos][:, pos]`` is W on them. The rows not kept yet are added (their columns of B and their
        entries of W against every kept row); the block stays for the later load cases of the geometry."""
        rows = np.asarray(rows, dtype=int)
        new = np.unique(rows[self.where[rows] < 0])
        if len(new):
            c, k = self.count, len(new)
            if c + k > self.kept_B.shape[1]:       # room for an eighth more (not double: cap^2 doubles)
                cap = min(len(self.where), c + k + max(64, (c + k) // 8))
                B, W = np.zeros((self.kept_B.shape[0], cap)), np.zeros((cap, cap))
                B[:, :c], W[:c, :c] = self.kept_B[:, :c], self.kept_W[:c, :c]
                self.kept_B, self.kept_W = B, W
            R = self.stacked
            self.kept_B[:, c:c + k] = self.columns(new)
            old = np.flatnonzero(self.where >= 0)
            old = old[np.argsort(self.where[old])]                       # the kept rows, at positions 0..c-1
            self.kept_W[c:c + k, :c + k] = R[new] @ self.kept_B[:, :c + k]
            self.kept_W[:c, c:c + k] = R[old] @ self.kept_B[:, c:c + k]
            self.where[new] = c + np.arange(k)
            self.count = c + k
        return self.where[rows]

    def free_slack(self, v0, gap_rows) -> np.ndarray:
        """d = sum_l R_l v0_l - E g: the slack of the contact rows with no contact force."""
        return sum(R @ v for R, v in zip(self.rows, v0)) - gap_rows


class InterfaceSystem:
    """The mixed system (26) condensed exactly onto the Gamma dofs (module docstring), in the form the tangency
    Newton reads (:func:`~cvxcontact.backends.tangency.tangency_newton`): unknowns x = [v_1; v_2; ...], ``matrix``
    A = diag(Sigma_l), ``rhs`` F = (Sigma_l v0_l) (the interface loads), ``rows`` G = [E J_1, E J_2, ...] the
    contact rows (r = G x - g). Its answer x is every body's Gamma values (:meth:`split`); the bodies' fields
    follow by one backward sweep each. Dense blocks (Gamma dofs: O(sqrt(n)) in 2D), stored sparse."""

    def __init__(self, bodies, loads, E):
        self.sizes = [len(b.gamma) for b in bodies]
        self.matrix = sp.block_diag([sp.csr_matrix(b.stiffness) for b in bodies], format="csr")
        self.rhs = np.concatenate([np.asarray(f, dtype=float) for f in loads])
        self.rows = sp.hstack([sp.csr_matrix(E @ b.jump) for b in bodies], format="csr")

    def stack(self, v) -> np.ndarray:
        """x from each body's Gamma values ``v``."""
        return np.concatenate([np.asarray(vk, dtype=float) for vk in v])

    def split(self, x) -> list:
        """Each body's Gamma values from x."""
        return np.split(np.asarray(x, dtype=float), np.cumsum(self.sizes)[:-1])
