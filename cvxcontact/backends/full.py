"""The full model: the phi-form convex program of every body in CVXPY (docs/formulation.md §2).

    minimise   sum_bodies 1/2 u^T Kuu u + 1/2 phi^T Kpp phi - f^T u
    subject to Kpp phi - Kup^T u = q              (Gauss law (20), one per piezoelectric body)
               E [u_nu] <= E g                     (K_h(Gamma_3) or K_h(Sigma_h^l))

(no -q^T phi term: the constraint fixes phi). An elastic body has no phi and no
Gauss constraint. The reference backend: it accepts every problem the package poses,
and :func:`mixed_kkt` solves its mixed system (26) on a given active set (the exact finish).
"""

from __future__ import annotations

import functools

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla  # noqa: F401  (tests reach scipy.sparse.linalg as full.spla)
from scipy.linalg import null_space

from ..errors import SolverError
from .condensed import quasi_definite
from .factor import (
    DENSE_FILL,
    PardisoSymmetric,
    diagonal_stored,
    pardiso_available,
    structurally_nonsingular,
)
from .factor import lu as dense_or_sparse_lu
from .parallel import closed_once, normalised_gaps, repeated_rows

__all__ = [
    "ContactModel",
    "compliance_energy",
    "law_rows",
    "limit_reaction",
    "mixed_kkt",
    "signorini_forces",
    "signorini_program",
    "solve_mixed",
]



PARDISO_MIN = 5000
"""The smallest mixed system :func:`solve_mixed` (``factorization="auto"``) gives to PARDISO: below it SuperLU is
fast and the answers stay those of the one factorisation they always had (both are backward stable, 2e-16 after
refinement, but on an ill-conditioned small system they differ by up to 1e-13, measured on the 2D layer held by
the contact, which its finish's checks can see)."""


def symmetric_lu(K):
    """PARDISO's factorisation of the square sparse symmetric ``K`` (a mixed system (26): real symmetric
    indefinite, its own nested-dissection order, scaling and weighted matching,
    :class:`~cvxcontact.backends.factor.PardisoSymmetric`), with ``solve(b)`` and ``release()``; None where it does
    not apply and the caller's SuperLU (:func:`~cvxcontact.backends.factor.lu`) decides: PARDISO not installed, K
    nearly dense (:data:`~cvxcontact.backends.factor.DENSE_FILL`) or not symmetric (to 1e-12 of its largest
    entry: K's upper triangle is factorised), or a pivot PARDISO
    perturbed (K singular or nearly so; the answer would be that of a nearby matrix). The caller refines
    against K and checks the residual."""
    n = K.shape[0]
    if n == 0 or K.nnz > DENSE_FILL * n * n or not pardiso_available():
        return None
    K = sp.csc_matrix(K)
    if abs(K - K.T).max() > 1e-12 * abs(K).max():        # symmetric to rounding: PARDISO reads the upper part
        return None
    Kd = diagonal_stored(K.tocoo(), sp.csc_matrix)
    try:
        factor = PardisoSymmetric(Kd).factor(Kd)
    except SolverError:
        return None
    if factor.perturbed:
        factor.release()
        return None
    return factor


def solve_mixed(K, b, residual: float | None = 1e-8, factorization: str = "superlu"):
    """x with K x = b for a sparse mixed (KKT) matrix K: SuperLU (minimum degree on K^T + K) and two steps of
    iterative refinement (bodies of very different stiffness share one LU). None if K is singular, x is not
    finite, or (``residual`` not None) max|K x - b| exceeds ``residual`` times max|b|: the system does not
    determine the unknowns (e.g. an active set that leaves multipliers free). A structurally singular K (more
    active rows than the unknowns they touch, as on a 3D overlay whose rows outnumber the jump's dofs) is None
    before any factorisation (:func:`~cvxcontact.backends.factor.structurally_nonsingular`): SuperLU 1.17's panel
    updates call BLAS with illegal sizes on such matrices and can corrupt memory (measured: segmentation faults
    in later factorisations).

    ``factorization="auto"`` (with ``residual`` set, K of order :data:`PARDISO_MIN` or more): PARDISO first where
    it applies (:func:`symmetric_lu`: a symmetric K, no perturbed pivot), refined the
    same way; an answer that misses the residual falls back to SuperLU, which then decides (measured on issue
    30's punch, 23,938 rows: 0.13 s a factorisation instead of SuperLU's 1 s)."""
    try:
        structurally_nonsingular(K)     # before PARDISO too
    except RuntimeError:
        return None
    if factorization == "auto" and residual is not None and K.shape[0] >= PARDISO_MIN:
        x = _refined(symmetric_lu(K), K, b, residual)
        if x is not None:
            return x
    try:
        lu = dense_or_sparse_lu(sp.csc_matrix(K), permc_spec="MMD_AT_PLUS_A")   # dense: the condensed (26)
    except RuntimeError:
        return None
    x = _refined(lu, K, b, residual)
    return x


def _refined(lu, K, b, residual):
    """x = lu^-1 b with two steps of iterative refinement against K; None if ``lu`` is None, x is not finite or
    (``residual`` not None) its residual is above ``residual`` max|b|. Releases ``lu`` if it can."""
    if lu is None:
        return None
    x = lu.solve(b)
    for _ in range(2):
        x += lu.solve(b - K @ x)
    if hasattr(lu, "release"):
        lu.release()
    if not np.isfinite(x).all():
        return None
    if residual is not None and np.abs(K @ x - b).max() > residual * max(np.abs(b).max(), np.finfo(float).tiny):
        return None
    return x

def compliance_energy(jump_rows, gap_rows, weights, law):
    """The normal-compliance energy sum_a w_a k_a/(m_a+1) (r_a)_+^(m_a+1), r = E [u_nu] - E g (a CVXPY expression).

    ``law`` is a :class:`~cvxcontact.contact.laws.NormalCompliance` or a per-row
    :class:`~cvxcontact.contact.laws.RowLaws` in the units of ``jump_rows`` (scaled), ``weights`` the lumped
    lengths of the constrained nodes (docs/formulation.md §10): the trapezoidal rule for
    integral_Gamma3 Phi([u_nu] - g) over the compliant rows (Signorini rows, k = 0, get no term). m = 1
    gives a QP (``square(pos(r))``); other m a power cone (one term per distinct exponent).
    """
    n = jump_rows.shape[0]
    k = np.broadcast_to(np.asarray(law.stiffness, dtype=float), (n,))
    m_rows = np.broadcast_to(np.asarray(law.exponent, dtype=float), (n,))
    w = np.asarray(weights, dtype=float)
    energy = 0
    for m in (float(v) for v in np.unique(m_rows[k > 0])):
        on = (m_rows == m) & (k > 0)
        idx = np.flatnonzero(on)
        every = len(idx) == n
        r = cp.pos(jump_rows - gap_rows) if every else cp.pos(jump_rows[idx] - gap_rows[idx])
        term = cp.square(r) if m == 1 else cp.power(r, m + 1.0)
        if every and np.ptp(k) == 0:                  # one law on every row (the form of a single pair)
            energy += k[0] / (m + 1.0) * cp.sum(cp.multiply(w, term))
        else:
            energy += cp.sum(cp.multiply(w[idx] * k[idx] / (m + 1.0), term))
    return energy


def law_rows(jump_rows, gap_rows, weights, law):
    """(energy term, limit constraint or None, its row indices) of the contact rows under ``law``.

    ``law`` None or Signorini: no term, E [u_nu] <= E g on every row. A normal-compliance law or a
    per-row :class:`~cvxcontact.contact.laws.RowLaws` (scaled): :func:`compliance_energy` and
    E [u_nu] <= E g + l on the rows with a finite limit l (Signorini rows: l = 0)."""
    n = jump_rows.shape[0]
    if law is None or not law.compliant:
        return 0, jump_rows <= gap_rows, np.arange(n)
    limit = law.penetration_limit
    limit = np.full(n, np.inf) if limit is None else np.broadcast_to(np.asarray(limit, dtype=float), (n,))
    idx = np.flatnonzero(np.isfinite(limit))
    if len(idx) == 0:
        constraint = None
    elif len(idx) == n:
        constraint = jump_rows <= gap_rows + (limit[0] if np.ptp(limit) == 0 else limit)
    else:
        constraint = jump_rows[idx] <= gap_rows[idx] + limit[idx]
    return compliance_energy(jump_rows, gap_rows, weights, law), constraint, idx


def limit_reaction(constraint, rows, n):
    """The multipliers z >= 0 of the limit rows (:func:`law_rows`) scattered on all ``n`` rows (0 elsewhere)."""
    z = np.zeros(n)
    if constraint is not None:
        z[rows] = np.asarray(constraint.dual_value, dtype=float).ravel()
    return z


class ContactModel:
    """The CVXPY problem for given scaled blocks and constraint rows ``E``.

    Attributes: ``problem``, ``u`` and ``phi`` (variables per body, ``phi[k]`` None
    for an elastic body), ``gauss`` (equality constraints per body, or None) and
    ``contact`` (the inequality constraint E [u_nu] <= E g).

    With a normal-compliance ``law`` (scaled, :class:`~cvxcontact.contact.laws.NormalCompliance`, or a
    per-row :class:`~cvxcontact.contact.laws.RowLaws` mixing Signorini and compliance rows) and the
    lumped lengths ``weights`` of the constrained nodes, the energy gets :func:`compliance_energy` and
    ``contact`` becomes E [u_nu] <= E g + l on the rows ``limit_rows`` with a finite limit l (Signorini
    rows: l = 0), or None if there is none (:func:`law_rows`, :func:`limit_reaction`).

    ``translations``: per force-controlled obstacle (R, F), R (rows of E, k) the rows' sensitivities to
    its translation unknowns tau and F (k,) the prescribed force on them (scaled): a variable ``t[i]``,
    the energy gets -F . tau and the rows become E [u_nu] + R tau <= E g (docs/formulation.md §12).

    ``bernstein``: the P2 "everywhere" condition (docs/formulation.md §8, §16) instead of the rows: ``B``
    (``width`` S, n; 3 coefficients per segment, 6 per triangle), with E the identity on the nodes
    of X_h and ``gap_rows`` the gap there; ``contact`` is then None and the attributes ``cone`` and ``row``
    hold the constraints of :func:`~cvxcontact.backends.conic.bernstein_constraints` (their duals give the
    Bernstein duals beta, :func:`~cvxcontact.backends.conic.bernstein_duals`).
    """

    def __init__(self, blocks, E, gap_rows, law=None, weights=None, translations=None, bernstein=None, width=3):
        self.blocks = blocks
        self.u = [cp.Variable(b.Kuu.shape[0], name=f"u{k + 1}") for k, b in enumerate(blocks)]
        self.phi = [cp.Variable(b.Kpp.shape[0], name=f"phi{k + 1}") if b.Kpp is not None else None
                    for k, b in enumerate(blocks)]
        energy, self.gauss = 0, []
        for b, u, phi in zip(blocks, self.u, self.phi):
            if u.size:                       # (a body every node of which is clamped or prescribed has none)
                energy += b.bulk.expression(u) - b.f @ u
            if phi is None:
                self.gauss.append(None)
                continue
            energy += 0.5 * cp.quad_form(phi, cp.psd_wrap(b.Kpp))
            self.gauss.append(b.Kpp @ phi - b.Kup.T @ u == b.q)
        jump = sum((E @ b.jump) @ u for b, u in zip(blocks, self.u))
        self.t = []
        for k, (R, F) in enumerate(translations or ()):      # force-controlled obstacles (formulation.md §12)
            t = cp.Variable(R.shape[1], name=f"t{k + 1}")
            self.t.append(t)
            energy -= F @ t
            jump = jump + R @ t
        self.jump = jump                     # the rows' [u_nu] (+ R t), scaled
        self.cone = self.row = None
        if bernstein is not None:
            from .conic import bernstein_constraints

            self.contact, self.limit_rows = None, None
            self.cone, self.row, _ = bernstein_constraints(jump, bernstein, gap_rows, width)
            contact = [self.cone, self.row]
        else:
            term, self.contact, self.limit_rows = law_rows(jump, gap_rows, weights, law)
            energy += term
            contact = [self.contact] if self.contact is not None else []
        self.energy = energy
        self.constraints = [c for c in self.gauss if c is not None] + contact
        self.problem = cp.Problem(cp.Minimize(energy), self.constraints)

    def with_terms(self, constraints=(), objective=None) -> cp.Problem:
        """A new problem: this model's energy plus ``objective`` (a convex scalar expression of the
        scaled variables, dimensionless) subject to its constraints plus ``constraints`` (the hook
        of :class:`cvxcontact.Model`). ``self.problem`` is left as it is."""
        energy = self.energy if objective is None else self.energy + objective
        return cp.Problem(cp.Minimize(energy), self.constraints + list(constraints))


def signorini_program(problem) -> ContactModel:
    """The full program of Signorini rows E [u_nu] + R t <= E g (the term
    :class:`~cvxcontact.discrete.terms.SignoriniRows`, and the normal rows of a friction law)."""
    return ContactModel(list(problem.blocks), problem.E, problem.g, translations=list(problem.translations))


def signorini_forces(problem, model: ContactModel, u, taus) -> tuple:
    """(y, None, None): the multipliers of the solved :func:`signorini_program`'s rows, those of the rows no
    unknown moves at 0, their least admissible value (docs/formulation.md §8, "Held nodes"); scaled."""
    return np.where(problem.held_rows, 0.0, np.asarray(model.contact.dual_value, dtype=float).ravel()), None, None


def _unseen(R, F, active, hold):
    """The rows holding a force-controlled obstacle's translations that the active rows do not see:
    (H, h) with H tau = h fixing tau along the null space V of R[active] at ``hold`` (V^T tau = V^T hold), or
    None if the prescribed force F has a component along V (no force of these rows balances it: the set
    cannot hold the obstacle). Empty (0, k) rows where R[active] has full column rank."""
    V = null_space(sp.csr_matrix(R)[active].toarray(), rcond=1e-9)
    F = np.asarray(F, dtype=float)
    if V.shape[1] and np.linalg.norm(V.T @ F) > 1e-9 * max(np.linalg.norm(F), np.finfo(float).tiny):
        return None
    return V.T, V.T @ np.asarray(hold, dtype=float)


def _closing_once(G_all, g):
    """``active -> the rows closed``: each class of repeated rows of G_all (coincident obstacles at a node) closed
    once (:func:`~cvxcontact.backends.parallel.closed_once`), its classes found at the first solve (many callers of
    :func:`mixed_kkt` read only ``kkt.matrix`` / ``kkt.rows``)."""
    repeats = functools.cache(lambda: (repeated_rows(G_all, g), normalised_gaps(G_all, g)))

    def once(active):
        first, gap = repeats()
        return closed_once(first, active, gap)

    return once


def mixed_kkt(blocks, E, g, rows=None, bound=None, load=None, translations=None, hold=None):
    """``kkt(active)`` for the exact finish of the full model: the sparse mixed system (26)

    [[A, G^T], [G, 0]] [x; y_A] = [F; g_A] with, per body, A = [[Kuu, Kup], [Kup^T, -Kpp]],
    F = [f; -q] (Gauss rows negated, which makes it symmetric) and G the active rows of E [u_nu].

    With extra linear rows ``rows`` C x <= ``bound`` d (sparse (m, n), x = [u_1; phi_1; u_2; ...]
    the scaled free dofs, as in :class:`ContactModel`) and a linear objective gradient ``load``
    (n,), see :func:`mixed_kkt_rows`: ``kkt(active, active_rows)`` then also returns their
    multipliers and slacks.

    With ``translations`` (as in :class:`ContactModel`) the unknowns tau of force-controlled obstacles
    join x with no stiffness: their rows are R^T y = F (the obstacle's force balance) and the contact
    rows gain R tau (docs/formulation.md §12); ``kkt(active)`` then returns (u, phi, y, taus). Where the
    active rows do not see every translation (a sphere touching at one node on its axis: its sideways
    translations change no active row) those components are not determined by (26) but are free within the
    interval the open rows allow; with ``hold`` (one array per obstacle, e.g. the interior point's
    translations) they are held there if the force has no component along them (else the set is singular:
    None); without, such a set is singular (the cones' finish then turns to the tangency points, §18).

    Rows that repeat each other (:func:`~cvxcontact.backends.parallel.repeated_rows`: coincident obstacles, the
    same row of E [u_nu] with the same gap) are one equation: of those ``active`` closes, the tightest (ties: the
    first) is closed and carries their force, the others get force 0 and its slack
    (:func:`~cvxcontact.backends.parallel.closed_once`; closed together, (26) would be singular: the split of the
    force between them is not determined, its sum is).
    """
    if rows is not None or load is not None:
        return mixed_kkt_rows(blocks, E, g, rows, bound, load, translations=translations)
    parts = [quasi_definite(b) for b in blocks]
    A = sp.block_diag([S for S, _ in parts])
    rhs = np.concatenate([F for _, F in parts])
    sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(blocks, parts)]
    rows = [sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], n_phi))]) for b, (_, n_phi) in zip(blocks, sizes)]
    G_all = sp.hstack(rows).tocsr()
    widths = [R.shape[1] for R, _ in translations or ()]
    if widths:
        A = sp.block_diag([A, sp.csr_matrix((sum(widths), sum(widths)))])
        rhs = np.concatenate([rhs, *(np.asarray(F, dtype=float) for _, F in translations)])
        G_all = sp.hstack([G_all, *(sp.csr_matrix(R) for R, _ in translations)]).tocsr()

    held = [] if hold is None else [np.asarray(h, dtype=float) for h in hold]
    once = _closing_once(G_all, g)

    def kkt(active):
        active = once(active)
        G, b = G_all[active], np.concatenate([rhs, g[active]])
        n, start = A.shape[0], A.shape[0] - sum(widths)
        for (R, F), w, h in zip(translations or (), widths, held):
            fix = _unseen(R, F, active, h)
            if fix is None:
                return None
            H, c = fix
            if len(H):
                G = sp.vstack([G, sp.hstack([sp.csr_matrix((len(H), start)), sp.csr_matrix(H),
                                             sp.csr_matrix((len(H), n - start - w))])]).tocsr()
                b = np.concatenate([b, c])
            start += w
        K = sp.bmat([[A, G.T], [G, None]], format="csc")
        z = solve_mixed(K, b, factorization="auto")  # None: numerically singular (e.g. a body held by the contact only, rows not active)
        return None if z is None else fields(active, z[:n + int(np.count_nonzero(active))])

    def fields(active, z):
        """kkt's answer from the solution z = [x; y_active] of (26) on ``active``."""
        n = A.shape[0]
        y = np.zeros(E.shape[0])
        y[active] = z[n:]
        u, phi, pos = [], [], 0
        for nu, npf in sizes:
            u.append(z[pos:pos + nu])
            phi.append(z[pos + nu:pos + nu + npf] if npf else None)
            pos += nu + npf
        slack = G_all @ z[:n] - g
        x = (u, phi, y)
        if widths:
            x = (u, phi, y, np.split(z[n - sum(widths):n], np.cumsum(widths)[:-1]))
        return x, y, slack, max(np.abs(uk).max(initial=0.0) for uk in u)

    kkt.rows = G_all          # the contact rows on the stacked unknowns [u_1; phi_1; ...; tau_1; ...]
    kkt.matrix, kkt.rhs, kkt.fields = A, rhs, fields      # for the factored steps of the finish
    kkt.stack = lambda x: np.concatenate([np.concatenate([uk] + ([pk] if pk is not None else []))
                                          for uk, pk in zip(x[0], x[1])] + list(x[3] if widths else []))
    return kkt


def mixed_kkt_rows(blocks, E, g, C=None, d=None, load=None, translations=None):
    """``kkt(active, active_rows)``: (26) with extra linear rows C x <= d and a linear load term.

    Stationarity of the phi-form program with multipliers z >= 0 of C x <= d and an added
    objective c^T x (all scaled), the Gauss multiplier eliminated, reads per body

        Kuu u + Kup phi + Kup w + J^T E^T y + C_u^T z = f - c_u      (momentum rows of (26))
        Kup^T u - Kpp phi                              = -q          (Gauss rows of (26))
        Kpp w - C_phi^T z                              = c_phi       (w = Kpp^-1 (C_phi^T z + c_phi))

    (a row on phi acts on the momentum through the coupling: phi = Kpp^-1 (q + Kup^T u)). The
    active contact rows and active extra rows are closed (E [u_nu] = g, C x = d); the extra rows
    are normalised to unit norm inside the solve; contact rows that repeat each other are closed once, as in
    :func:`mixed_kkt`. Returns ((u, phi, y, z), slack, row_slack) or None if the system is singular.

    ``translations`` (as in :class:`ContactModel`): the unknowns tau of force-controlled obstacles join x
    after the bodies' dofs (x = [u_1; phi_1; ...; tau_1; ...], so C has columns for them), with no
    stiffness, the load F and the rows R^T y + C_tau^T z = F; the result is then ((u, phi, y, z, taus), ...).
    """
    parts = [quasi_definite(b) for b in blocks]
    A = sp.block_diag([S for S, _ in parts]).tocsr()
    F = np.concatenate([F for _, F in parts])
    n = A.shape[0]
    sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(blocks, parts)]
    G_all = sp.hstack([sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], n_phi))])
                       for b, (_, n_phi) in zip(blocks, sizes)]).tocsr()
    widths = [R.shape[1] for R, _ in translations or ()]
    n_bodies = n
    if widths:                               # obstacle translations: no stiffness, load F, rows R (§12)
        A = sp.block_diag([A, sp.csr_matrix((sum(widths), sum(widths)))]).tocsr()
        F = np.concatenate([F, *(np.asarray(Ft, dtype=float) for _, Ft in translations)])
        G_all = sp.hstack([G_all, *(sp.csr_matrix(R) for R, _ in translations)]).tocsr()
        n = A.shape[0]
    C = sp.csr_matrix((0, n)) if C is None else sp.csr_matrix(C)
    d = np.zeros(C.shape[0]) if d is None else np.asarray(d, dtype=float)
    c = np.zeros(n) if load is None else np.asarray(load, dtype=float)
    norms = np.sqrt(np.asarray(C.multiply(C).sum(axis=1)).ravel())
    norms = np.where(norms > 0, norms, 1.0)
    Cn, dn = sp.diags(1.0 / norms) @ C, d / norms
    # Lw: Kup blocks from w to the momentum rows; Rw: picks the phi entries of x; Mu: the u entries
    lr, lc, lv, rr, rc, kpp, mu, pos, nw = [], [], [], [], [], [], np.zeros(n), 0, 0
    for b, (nu, npf) in zip(blocks, sizes):
        mu[pos:pos + nu] = 1.0
        if npf:
            K = b.Kup.tocoo()
            lr.append(K.row + pos)
            lc.append(K.col + nw)
            lv.append(K.data)
            rr.append(np.arange(npf) + nw)
            rc.append(np.arange(npf) + pos + nu)
            kpp.append(b.Kpp)
            nw += npf
        pos += nu + npf
    mu[n_bodies:] = 1.0                      # a row on tau acts on its force balance directly
    cat = lambda a, dt=float: np.concatenate(a).astype(dt) if a else np.zeros(0, dtype=dt)
    Lw = sp.csr_matrix((cat(lv), (cat(lr, int), cat(lc, int))), shape=(n, nw))
    Rw = sp.csr_matrix((np.ones(nw), (cat(rr, int), cat(rc, int))), shape=(nw, n))
    Kw = sp.block_diag(kpp).tocsr() if kpp else sp.csr_matrix((0, 0))
    Mu = sp.diags(mu)

    once = _closing_once(G_all, g)

    def kkt(active, active_rows):
        active = once(active)
        Ga, Ca = G_all[active], Cn[active_rows]
        K = sp.bmat([[A, Lw, Ga.T, Mu @ Ca.T],
                     [None, Kw, None, -(Rw @ Ca.T)],
                     [Ga, None, None, None],
                     [Ca, None, None, None]], format="csc",
                    ) if nw else sp.bmat([[A, Ga.T, Mu @ Ca.T], [Ga, None, None], [Ca, None, None]], format="csc")
        rhs = np.concatenate([F - mu * c, Rw @ c, g[active], dn[active_rows]])
        if K.shape[0] != len(rhs):   # an empty block dropped by bmat
            return None
        zz = solve_mixed(K, rhs, residual=None)
        if zz is None:
            return None
        x = zz[:n]
        y = np.zeros(E.shape[0])
        y[active] = zz[n + nw:n + nw + int(active.sum())]
        z = np.zeros(C.shape[0])
        z[active_rows] = zz[n + nw + int(active.sum()):] / norms[active_rows]
        u, phi, p = [], [], 0
        for nu, npf in sizes:
            u.append(x[p:p + nu])
            phi.append(x[p + nu:p + nu + npf] if npf else None)
            p += nu + npf
        if widths:
            taus = np.split(x[n_bodies:], np.cumsum(widths)[:-1])
            return (u, phi, y, z, taus), G_all @ x - g, C @ x - d
        return (u, phi, y, z), G_all @ x - g, C @ x - d

    return kkt
