"""Factored rows of the mixed system (26): the rows carrying the forces kept independent, updated one row at a time
(docs/formulation.md §13)."""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..factor import lu as dense_or_sparse_lu
from .forces import inverse_diagonal

log = logging.getLogger(__name__)

SINGULAR_PIVOT = 1e-13
"""A factor of the interface systems (:class:`UpdatedSystem`'s R, :class:`CholeskySystem`'s U^T U) whose smallest
pivot is not above this fraction of its largest is numerically singular."""

DEPENDENT_PIVOT = 1e-10
"""A row whose component outside the span of the rows carrying forces is below this (unit rows) is dependent
on them (:func:`independent_active_set`): 3D overlay rows at vertices a distance ~1e-9 h apart are merged."""

def independent_columns(M, tol=DEPENDENT_PIVOT, factors: bool = False):
    """Indices of a maximal set of linearly independent columns of the dense ``M`` (unit columns), by a
    column-pivoted QR, in the order of the pivots. ``factors``: also its R and pivots, (chosen, R, piv) with
    M[:, piv] = Q R (Q itself is not formed). ``M`` is overwritten (LAPACK works in it: no copy of it)."""
    if M.shape[1] == 0:
        none = np.zeros(0, dtype=int)
        return (none, np.zeros((0, 0)), none) if factors else none
    R, piv = sla.qr(np.asfortranarray(M), mode="r", pivoting=True, overwrite_a=True, check_finite=False)
    diag = np.abs(np.diag(R))
    chosen = piv[:int(np.sum(diag > tol))]
    return (chosen, R, piv) if factors else chosen


GROUP_ROWS = 256
"""Rows in a group of :func:`independent_rows` (a group's rows are neighbours: they share unknowns)."""


def independent_rows(U, tol=DEPENDENT_PIVOT, group: int | None = None):
    """(chosen, R, piv) of :func:`independent_columns` on ``U``^T for the sparse rows ``U`` (k x n, each scaled by its
    weight), choosing among fewer columns: the rows are cut into groups of about ``group`` neighbours (reverse
    Cuthill-McKee on the rows sharing unknowns; None: :data:`GROUP_ROWS`), each group's dense block (its rows on
    the unknowns they touch) keeps its own independent rows by a column-pivoted QR, and the global QR runs on the
    rows kept. A row a
    group drops is a combination of rows the group keeps (U_j = U_K c), so the span is the same and the kept
    rows' maximal independent subset is one of all rows. The overlay rows of "gamma3" that carry force are
    about 1.8 times the unknowns they touch, most of the dependent ones a few faces apart: the global QR,
    O(n^2 k) for k rows on n unknowns, runs on about 0.65 of them (two boxes, n = 40: 2,481 of 3,836 rows
    kept on 2,168 unknowns, rank 2,042; CPU 1.7 s against 3.9 s for all rows at once). R is p x k (p = |chosen|), R = Q^T U^T[:, piv] as the QR's would be:
    a dropped row's column is R's on the group's kept rows times its c."""
    U = sp.csr_matrix(U)
    k = U.shape[0]
    group = GROUP_ROWS if group is None else group
    if k <= 2 * group:
        return independent_columns(U.T.toarray(), tol, factors=True)
    pattern = abs(U) @ abs(U).T
    order = csgraph.reverse_cuthill_mckee(sp.csr_matrix(pattern), symmetric_mode=True)
    kept, drops = [], []                              # drops: (dropped rows, group's kept rows, c)
    for g0 in range(0, k, group):
        rows = order[g0:g0 + group]
        block = U[rows]
        block = block[:, np.flatnonzero(np.diff(block.tocsc().indptr))].toarray().T
        chosen, R, piv = independent_columns(block, tol, factors=True)
        p = len(chosen)
        kept.append(rows[chosen])
        if p < len(rows):
            c = (sla.solve_triangular(R[:p, :p], R[:p, p:], check_finite=False) if p
                 else np.zeros((0, len(rows) - p)))
            drops.append((rows[piv[p:]], rows[chosen], c))
    kept = np.concatenate(kept)
    cols = U[kept]
    cols = cols[:, np.flatnonzero(np.diff(cols.tocsc().indptr))].toarray().T
    local, Rk, pivk = independent_columns(cols, tol, factors=True)
    p = len(local)
    R = np.empty((p, k))
    R[:, :len(kept)] = Rk[:p]
    piv = np.concatenate([kept[pivk], np.setdiff1d(np.arange(k), kept)])
    where = np.empty(k, dtype=int)
    where[piv] = np.arange(k)
    for rows, base, c in drops:                       # U_j = U_base c: Q^T U_j = R[:, base] c
        R[:, where[rows]] = R[:, where[base]] @ c
    return kept[local], R, piv


def row_scale(absG, x, g):
    """S_j = (|G| |x|)_j + |g_j|, the displacement scale of each row's slack G_j x - g_j (floored at 1e-14 of
    the largest). With ``absG`` :func:`row_reach` the scale also counts the row's nodes' neighbours."""
    S = absG @ np.abs(x) + np.abs(g)
    return np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), np.finfo(float).tiny))


def row_reach(A, G):
    """|G| + |G| diag(A)^{-1} |A| (sparse, m x n; only the unknowns with a positive stiffness diagonal count in
    the second term): with it, :func:`row_scale` gives S_j = (|G| |x|)_j + |g_j| plus the displacement that
    the elastic forces at row j's unknowns, (|A| |x|)_k, produce through their own stiffness A_kk. A node that
    does not move (held at the gap by a rigid plane, carrying no force: a P2 face vertex under a uniform
    pressure) has a slack of rounding and no displacement of its own, so that its slack over its own scale
    is rounding over rounding, of either sign; its neighbours' displacements are the scale of that rounding."""
    A, absG = sp.csr_matrix(A), abs(sp.csr_matrix(G))
    return (absG + absG @ sp.diags(inverse_diagonal(A)) @ abs(A)).tocsr()


class FactoredRows:
    """The mixed system (26) with the rows P closed, solved on the rows with one factorisation of the bodies.

    With A the bodies' quasi-definite blocks (singular for a body held by the contact only or a
    force-controlled obstacle), F the loads and G the rows, the anchor rows Q (independent, holding every
    body: the first rows carrying forces) regularise A once:

        K0 = A + G_Q^T D G_Q,   D = diag(rho_a),

    rho_a the largest diagonal stiffness of the unknowns row a touches over |G_a|^2 (K0 is quasi-definite,
    factorised once by SuperLU without pivoting in a symmetric minimum-degree order). For (26) on P with the
    right-hand side [f; c] (c the rows' values, c = g for the contact problem): on P the rows of Q are closed
    and the terms G_Q^T D (G_Q x - c_Q) added to both sides vanish; a row of Q open at P (Q' = Q \\ P) keeps
    its term as the unknown tau = -D (G_Q' x - c_Q'). With H = G K0^{-1} G^T, f~ = f + G_Q^T D c_Q and
    h = G K0^{-1} f~ - c, (26) on P is the system on the rows R = P + Q'

        [[H_PP,  H_PQ'          ], [[y_P ],   [[h_P ],
         [H_Q'P, H_Q'Q' - D^{-1}]]  [tau ]] =  [h_Q']],     x = K0^{-1} (f~ - G_R^T [y_P; tau])

    (block elimination of the mixed matrix with the factored K0). A column of H costs one solve with K0's
    factors, computed when its row first enters R and kept with K0^{-1} G_r^T (m + n doubles a row); the system
    on R is solved by :class:`UpdatedSystem` (O(|R|^2) a changed row); a step costs that and x from the kept
    columns, O(n |R|) (the rows' scales). :meth:`exact` solves (26) on P to rounding (iterative refinement on (26) itself).
    """

    def __init__(self, A, F, G, g, anchor, lu, K0, rho):
        self.A, self.F, self.G, self.g, self.anchor, self.lu, self.K0 = A, F, G, g, anchor, lu, K0
        self.absA, self.absG = abs(A), abs(G)
        self.reach = row_reach(A, G)
        self.rho = np.zeros(G.shape[0])
        self.rho[anchor] = rho
        self.Ft = F + G[anchor].T @ (rho * g[anchor])
        self.xF = self.solve(self.Ft)                       # K0^{-1} f~
        self.h = G @ self.xF - g
        m = G.shape[0]
        self.where = np.full(m, -1)
        self.cols = np.zeros((m, min(m, max(16, 2 * len(anchor)))))
        self.Z = np.zeros((A.shape[0], self.cols.shape[1]))   # K0^{-1} G_r^T of the rows with a column
        self.count = 0
        self.system = UpdatedSystem(self.entries)
        self.sizes = []                                   # (|P|, |Q'|) of each step
        self.fallbacks = 0                                # steps solved by the sparse LU of (26) instead

    def solve(self, b):
        """K0^{-1} b (one step of iterative refinement)."""
        x = self.lu.solve(b)
        return x + self.lu.solve(b - self.K0 @ x)

    def _columns(self, rows):
        new = rows[self.where[rows] < 0]
        if not len(new):
            return
        if self.count + len(new) > self.cols.shape[1]:
            grown = np.zeros((self.cols.shape[0], max(2 * self.cols.shape[1], self.count + len(new))))
            grown[:, :self.count] = self.cols[:, :self.count]
            self.cols = grown
            Z = np.zeros((self.Z.shape[0], grown.shape[1]))
            Z[:, :self.count] = self.Z[:, :self.count]
            self.Z = Z
        Z = self.lu.solve(self.G[new].T.toarray())     # (no refinement: the answers are refined on (26))
        self.cols[:, self.count:self.count + len(new)] = self.G @ Z
        self.Z[:, self.count:self.count + len(new)] = Z
        self.where[new] = self.count + np.arange(len(new))
        self.count += len(new)

    def entries(self, keys_a, keys_b):
        """The matrix of the system on the rows at keys a x b: H less 1/rho on the diagonal of the open anchor
        rows; a key is 2 row + 1 for an open anchor row, 2 row for a closed row."""
        ra, rb = keys_a // 2, keys_b // 2
        M = self.cols[np.ix_(ra, self.where[rb])]
        reg = np.where(keys_a % 2 == 1, 1.0 / np.where(self.rho[ra] > 0, self.rho[ra], 1.0), 0.0)
        return M - np.where(keys_a[:, None] == keys_b[None, :], reg[:, None], 0.0)

    def _rows(self, mask, passive):
        passive = np.asarray(passive, dtype=int)
        rows = np.concatenate([passive, self.anchor[~mask[self.anchor]]]).astype(int)
        self._columns(rows)
        open_anchor = np.arange(len(rows)) >= len(passive)
        return rows, 2 * rows + open_anchor, np.where(open_anchor, 1.0 / np.where(self.rho[rows] > 0,
                                                                                 self.rho[rows], 1.0), 0.0)

    def _interface(self, rows, keys, reg, rhs):
        """w on the rows R and C w, C the columns of H on R (:func:`refined_solve`); None if singular."""
        cols = self.cols[:, :self.count]
        spread = np.zeros(self.count)

        def product(w):                                   # (M w, C w) without gathering C
            spread[self.where[rows]] = w
            Cw = cols @ spread
            return Cw[rows] - reg * w, Cw

        return refined_solve(self.system, keys, rhs, product)

    def __call__(self, mask, passive):
        """(None, z, slack, S) of (26) with the rows ``passive`` closed (z their forces, 0 elsewhere), or None
        if the system on them is singular (they do not hold the bodies)."""
        rows, keys, reg = self._rows(mask, passive)
        out = self._interface(rows, keys, reg, self.h[rows]) if len(rows) else (np.zeros(0), np.zeros(len(self.h)))
        if out is None:
            return None
        w, Cw = out
        spread = np.zeros(self.count)
        spread[self.where[rows]] = w
        x = self.xF - self.Z[:, :self.count] @ spread       # K0^{-1} (f~ - G_R^T w), for the rows' scales only
        z = np.zeros(self.G.shape[0])
        z[passive] = w[:len(passive)]
        self.sizes.append((len(passive), len(rows) - len(passive)))
        return None, z, self.h - Cw, row_scale(self.reach, x, self.g)

    def exact(self, mask, passive, steps: int = 3):
        """(x, y) solving (26) on the rows ``passive`` with every residual within 1e-12 of its row's scale
        (componentwise backward error, after up to ``steps`` refinement steps on (26)), or None."""
        rows, keys, reg = self._rows(mask, passive)
        p = len(passive)
        GP = self.G[rows[:p]]
        x, y = np.zeros(self.A.shape[0]), np.zeros(p)
        f, c = self.F.copy(), np.zeros(self.G.shape[0])
        c[rows[:p]] = self.g[rows[:p]]
        for _ in range(steps + 1):
            ft = f + self.G[self.anchor].T @ (self.rho[self.anchor] * c[self.anchor])
            u = self.solve(ft)
            out = self._interface(rows, keys, reg, self.G[rows] @ u - c[rows]) if len(rows) else (np.zeros(0), 0)
            if out is None:
                return None
            w = out[0]
            x = x + self.solve(ft - self.G[rows].T @ w)
            y = y + w[:p]
            f = self.F - self.A @ x - GP.T @ y               # the residuals of (26) and their scales
            c = np.zeros(self.G.shape[0])
            c[rows[:p]] = self.g[rows[:p]] - GP @ x
            sf = self.absA @ np.abs(x) + abs(GP).T @ np.abs(y) + np.abs(self.F)
            sc = abs(GP) @ np.abs(x) + np.abs(self.g[rows[:p]])
            if (np.abs(f) <= 1e-12 * sf).all() and (np.abs(c[rows[:p]]) <= 1e-12 * sc).all():
                return x, y
        return None


def refined_solve(system, keys, rhs, product):
    """(w, extra) with M w = rhs on ``keys`` by ``system`` (:class:`UpdatedSystem`) and one step of iterative
    refinement, ``product(w)`` giving (M w, extra); a fresh factorisation if the updated one misses
    (residual above 1e-10 of the sizes of the terms); None if M is singular."""
    for fresh in (False, True):
        if fresh:
            system.refactor()
        w = system.solve(keys, rhs)
        if w is None:
            continue
        w = w + system.solve(keys, rhs - product(w)[0])
        Mw, extra = product(w)
        size = np.abs(rhs) + np.abs(Mw)
        if np.isfinite(w).all() and np.abs(rhs - Mw).max(initial=0.0) <= 1e-10 * size.max(initial=0.0):
            return w, extra
    return None


class UpdatedSystem:
    """A dense square system on a changing set of keys (the rows of :class:`FactoredRows`), by a QR
    factorisation updated key by key (scipy.linalg.qr_insert/qr_delete: O(r^2) a key, r the size),
    refactorised when more than an eighth of the keys change (or on :meth:`refactor`). ``entries(a, b)``
    gives the matrix's block on the keys a x b."""

    def __init__(self, entries):
        self.entries = entries
        self.keys = np.zeros(0, dtype=int)
        self.Q = self.R = None
        self.factorisations = self.updates = 0

    def refactor(self, keys=None):
        """A fresh factorisation (of the matrix on ``keys``, default the present ones)."""
        self.keys = self.keys if keys is None else np.asarray(keys, dtype=int)
        self.Q, self.R = sla.qr(self.entries(self.keys, self.keys))
        self.factorisations += 1

    def _update(self, keys):
        keep = np.isin(self.keys, keys)
        for k in np.flatnonzero(~keep)[::-1]:
            self.Q, self.R = sla.qr_delete(self.Q, self.R, k, 1, which="row", check_finite=False)
            self.Q, self.R = sla.qr_delete(self.Q, self.R, k, 1, which="col", check_finite=False)
        self.keys = self.keys[keep]
        for key in keys[~np.isin(keys, self.keys)]:
            r = len(self.keys)
            both = np.append(self.keys, key)
            if r == 0:
                self.Q, self.R = sla.qr(self.entries(both, both))
            else:
                row = self.entries(np.array([key]), self.keys).ravel()
                self.Q, self.R = sla.qr_insert(self.Q, self.R, row, r, which="row", check_finite=False)
                col = self.entries(both, np.array([key])).ravel()
                self.Q, self.R = sla.qr_insert(self.Q, self.R, col, r, which="col", check_finite=False)
            self.keys = both
        self.updates += 1

    def solve(self, keys, b):
        """w with M w = b, M the matrix on ``keys`` (in their order), or None if M is numerically singular
        (a diagonal entry of R not above :data:`SINGULAR_PIVOT` of the largest)."""
        keys = np.asarray(keys, dtype=int)
        if not len(keys):
            return np.zeros(0)
        changes = len(np.setxor1d(keys, self.keys))
        if self.Q is None or changes > max(4, len(keys) // 8):
            self.refactor(keys)
        elif changes:
            self._update(keys)
        d = np.abs(np.diag(self.R))
        if log.isEnabledFor(logging.DEBUG):
            k = int(np.argmin(d))
            log.debug("QR on %d keys: pivot ratio %.3e (key %d at %d)", len(keys), d.min() / d.max(),
                      int(self.keys[k]), k)
        if not d.min() > SINGULAR_PIVOT * d.max():
            return None
        where, bk = self._placed(keys, b)
        return sla.solve_triangular(self.R, self.Q.T @ bk, check_finite=False)[where]

    def _placed(self, keys, b):
        """(where, b in the factor's order): keys[i] = self.keys[where[i]]."""
        order = np.argsort(self.keys)
        where = order[np.searchsorted(self.keys[order], keys)]
        bk = np.zeros(len(keys))
        bk[where] = b
        return where, bk


QR_MARGIN = 1e-10
"""Pivot ratio (smallest over largest squared diagonal entry of the Cholesky factor) below which
:meth:`CholeskySystem.solve` leaves the answer to the QR of :class:`UpdatedSystem` (keeping its Cholesky factor): the
two ratios are not the same number (R of M's QR is the Cholesky factor of M^2), and on nearly dependent unit rows
(cos > 1 - 1e-13) the Cholesky's measured up to 2x the QR's (115x on rows of scales spread by 1e4), so that a bare
1e-13 cut on the Cholesky accepted some W_PP the QR refuses as singular (condition 4e13): with this margin the QR's
test (:data:`SINGULAR_PIVOT`) decides. A decision margin: no row is dropped by it."""

CHOLESKY_RANK_CUT = 1e-10
"""The rank cut of the pivoted Cholesky factorisation (LAPACK dpstrf's ``tol``, times the largest diagonal entry)
by which :meth:`CompliantRows.dependent` drops rows of W_PP: a row whose pivot, its squared distance from the span
of the rows kept before it in the metric of W, is not above this fraction of the largest diagonal entry is
dependent on them and dropped (the steps' systems on the rows kept are then non-singular by :data:`SINGULAR_PIVOT`
with this margin). The value of :data:`QR_MARGIN`, another test: this one decides the rank and drops rows, that one
only which factorisation answers a solve."""


def _cholesky_delete(U, k):
    """The upper Cholesky factor of M without its row and column ``k`` from M's, U^T U = M (C order): the rows
    of U after k lose their column k, and the trailing block takes the rank-one update U22^T U22 + u u^T,
    u = U[k, k+1:], by Givens rotations row by row (O(r^2), contiguous rows)."""
    r = U.shape[0]
    keep = np.concatenate([np.arange(k), np.arange(k + 1, r)])
    x = U[k, k + 1:].copy()
    U = U[np.ix_(keep, keep)]
    for j in range(k, r - 1):
        i = j - k
        d = U[j, j]
        h = float(np.hypot(d, x[i]))
        c, s = h / d, x[i] / d
        U[j, j] = h
        row = U[j, j + 1:]
        row += s * x[i + 1:]
        row /= c
        x[i + 1:] *= c
        x[i + 1:] -= s * row
    return U


class CholeskySystem(UpdatedSystem):
    """:class:`UpdatedSystem` for a symmetric positive definite matrix (W on independent rows,
    :class:`CompliantRows`): M = U^T U by a Cholesky factorisation (r^3 / 3 flops against the QR's 4 r^3 / 3 and
    its r x r Q) updated key by key, a key out by a rank-one update of the trailing factor (:func:`_cholesky_delete`)
    and the keys in by one triangular solve and the Cholesky factorisation of their block's Schur complement.
    Where M is not numerically positive definite (a pivot not above :data:`SINGULAR_PIVOT` of the largest) the QR of
    :class:`UpdatedSystem` solves it (None if singular there too); so it does, keeping the Cholesky factor, for
    pivots within :data:`QR_MARGIN` of the largest, where the QR's singularity test decides.

    Measured on the default 3D "gamma3" at 305,562 unknowns (14,905 rows, 3,456 carrying force): the QR system
    took 11 of the finish's 34 CPU s (benchmarks/results/bench_gamma3_scale.md)."""

    def __init__(self, entries):
        super().__init__(entries)
        self.U = None
        self.qr = UpdatedSystem(entries)

    def refactor(self, keys=None):
        self.keys = self.keys if keys is None else np.asarray(keys, dtype=int)
        self.factorisations += 1
        try:
            self.U = sla.cholesky(self.entries(self.keys, self.keys), lower=False, check_finite=False)
        except np.linalg.LinAlgError:
            self.U = None
            if self.qr.Q is not None:                      # a fresh factorisation asked for: the QR's too
                self.qr.refactor(self.keys)

    def _update(self, keys):
        keep = np.isin(self.keys, keys)
        for k in np.flatnonzero(~keep)[::-1]:
            self.U = _cholesky_delete(self.U, int(k))
        self.keys = self.keys[keep]
        new = keys[~np.isin(keys, self.keys)]
        self.updates += 1
        if not len(new):
            return
        r, t = len(self.keys), len(new)
        C = sla.solve_triangular(self.U, self.entries(self.keys, new), trans="T", check_finite=False)
        try:
            U2 = sla.cholesky(self.entries(new, new) - C.T @ C, lower=False, check_finite=False)
        except np.linalg.LinAlgError:
            self.refactor(np.append(self.keys, new))
            return
        U = np.zeros((r + t, r + t))
        U[:r, :r], U[:r, r:], U[r:, r:] = self.U, C, U2
        self.U, self.keys = U, np.append(self.keys, new)

    def solve(self, keys, b):
        keys = np.asarray(keys, dtype=int)
        if not len(keys):
            return np.zeros(0)
        changes = len(np.setxor1d(keys, self.keys))
        leaves = len(self.keys) - np.isin(self.keys, keys).sum()    # a deletion costs about 1/4 of a fresh
        if self.U is None or changes > max(4, len(keys) // 8) or leaves > 2 + len(self.keys) // 1000:  # factor
            self.refactor(keys)                                           # at 3,000 keys (1/2 at 1,000)
        elif changes:
            self._update(keys)
        d = np.diag(self.U) ** 2 if self.U is not None else np.zeros(1)
        if log.isEnabledFor(logging.DEBUG):
            log.debug("Cholesky on %d keys: pivot ratio %.3e", len(keys), d.min() / d.max() if d.max() > 0 else 0.0)
        if not d.min() > SINGULAR_PIVOT * d.max():
            self.U = None                                  # (refactored at the next solve)
            return self.qr.solve(keys, b)
        if not d.min() > QR_MARGIN * d.max():             # near the QR's cut: the QR decides (and answers)
            return self.qr.solve(keys, b)
        where, bk = self._placed(keys, b)
        z = sla.solve_triangular(self.U, bk, trans="T", check_finite=False)
        return sla.solve_triangular(self.U, z, check_finite=False)[where]


def factored_rows(A, F, G, g, anchor) -> FactoredRows | None:
    """:class:`FactoredRows` of the mixed system, or None if K0 is singular (the anchor rows do not hold every
    body): structurally (:func:`~cvxcontact.backends.factor.lu` checks it before SuperLU, which goes wrong on such
    matrices), by a zero pivot, or numerically (a solve of K0 z = K0 v
    misses v by more than 1e-6, v a fixed vector with components along any kernel)."""
    A, G = sp.csr_matrix(A), sp.csr_matrix(G)
    anchor = np.asarray(anchor, dtype=int)
    GQ = G[anchor]
    touch = abs(GQ).tocsr()
    touch.data[:] = 1.0
    diag = np.abs(A.diagonal())
    big = np.asarray(touch.multiply(diag[None, :]).max(axis=1).todense()).ravel() if len(anchor) else np.zeros(0)
    big = np.where(big > 0, big, max(float(diag.max(initial=0.0)), np.finfo(float).tiny))
    rho = big / np.asarray(GQ.multiply(GQ).sum(axis=1)).ravel()
    K0 = (A + GQ.T @ sp.diags(rho) @ GQ).tocsc()
    n = K0.shape[0]
    try:                   # a zero pivot: RuntimeError (SuperLU's splu and the dense LU issue no warning)
        lu = dense_or_sparse_lu(K0, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                options={"SymmetricMode": True})
    except RuntimeError:
        return None
    v = np.cos(np.arange(n) * 0.7548776662466927) + 1.5          # fixed, no zero entry
    out = FactoredRows(A, np.asarray(F, dtype=float), G, np.asarray(g, dtype=float), anchor, lu, K0, rho)
    with np.errstate(all="ignore"):
        if not np.abs(out.solve(K0 @ v) - v).max() <= 1e-6 * np.abs(v).max():
            return None
    return out


class CompliantRows:
    """The steps of :func:`independent_active_set` on a condensed interface: the rows P closed are
    W_PP y_P = d_P (:class:`CholeskySystem`, O(|P|^2) a changed row), with W = sum_l R_l Sigma_l^{-1} R_l^T the
    interface compliance and d the free slack (:class:`~cvxcontact.backends.condensed.Compliance`); the Gamma
    displacements v = v0 - B y give every row's slack R v - g and its scale (|R| |v|) + |g|, as the sparse
    mixed system's steps do.

    Only the rows that have carried a force (the passive rows of some step, J) need W: their columns of B and
    the block W_JJ are formed as the rows first enter P and kept with the compliance
    (:meth:`~cvxcontact.backends.condensed.Compliance.keep`: O(n_Gamma (|J|^2 + n_Gamma |J|)) flops and
    |J|^2 + n_Gamma |J| doubles), never the whole m x m W of the interface (m the rows, several times |J| on
    non-matching faces: 1.4e5 unknowns, m = 8,353, |J| about 2,000)."""

    def __init__(self, compliance, v0, g):
        self.compliance = compliance
        self.R = compliance.stacked
        self.v0 = np.concatenate(v0)
        self.g = np.asarray(g, dtype=float)
        self.d = self.R @ self.v0 - self.g
        self.absR = abs(self.R)
        c = compliance
        self.system = CholeskySystem(lambda a, b: c.kept_W[np.ix_(c.where[a // 2], c.where[b // 2])])

    def __call__(self, mask, passive):
        P = np.asarray(passive, dtype=int)
        y = np.zeros(len(self.g))
        c = self.compliance
        spread = np.zeros(c.count)
        if len(P):
            cols = c.keep(P)
            spread = np.zeros(c.count)

            def product(w):                     # W_PP w from the kept block in place (no |P| x |P| copy)
                spread[:] = 0.0
                spread[cols] = w
                return (c.kept_W[:c.count, :c.count] @ spread)[cols], None

            out = refined_solve(self.system, 2 * P, self.d[P], product)
            if out is None:
                return None
            y[P] = out[0]
            spread[:] = 0.0
            spread[cols] = y[P]
        v = self.v0 - c.kept_B[:, :c.count] @ spread        # (no n_Gamma x |P| copy of B's columns)
        return y, y.copy(), self.R @ v - self.g, row_scale(self.absR, v, self.g)

    def coefficients(self, passive, j) -> np.ndarray | None:
        """c with W_PP c = W_Pj: the row j as the combination sum c_i R_i of the rows P nearest to it in the
        metric of W (R_j = sum c_i R_i + r, r W-orthogonal to the rows of P); None if W_PP is singular. Where the
        system on P + j is singular (r below the cut), :func:`~cvxcontact.backends.finish.dependent.lawson_hanson`
        treats j as its steps treat a dependent row, with these c."""
        P = np.asarray(passive, dtype=int)
        c = self.compliance
        cols = c.keep(np.append(P, int(j)))
        spread = np.zeros(c.count)

        def product(w):
            spread[:] = 0.0
            spread[cols[:-1]] = w
            return (c.kept_W[:c.count, :c.count] @ spread)[cols[:-1]], None

        out = refined_solve(self.system, 2 * P, c.kept_W[cols[:-1], cols[-1]], product) if len(P) else None
        return None if out is None else out[0]

    def dependent(self, passive):
        """(drop, C): the positions in ``passive`` of the rows that the pivoted Cholesky factorisation of W_PP
        (LAPACK dpstrf) finds dependent on the others, a pivot not above :data:`CHOLESKY_RANK_CUT` of the largest
        diagonal entry (the rows' squared distance from the span of the others, in the metric of W: the steps'
        systems on the rest are then non-singular by :data:`SINGULAR_PIVOT` with that margin), and C (kept x
        dropped), each dropped row's coefficients R_j = sum_i C_ij R_i + r on the kept rows (``keep`` = the
        other positions, in their order). None if none is. The steps' factors are freed first (W_PP is copied:
        |P|^2 doubles)."""
        P = np.asarray(passive, dtype=int)
        c = self.compliance
        cols = c.keep(P)
        self.system.U = None
        self.system.qr.Q = self.system.qr.R = None
        W = c.kept_W[np.ix_(cols, cols)].T              # (symmetric: its transpose, Fortran order, is factorised
        U, piv, rank, info = sla.lapack.dpstrf(W, tol=CHOLESKY_RANK_CUT * float(W.diagonal().max(initial=0.0)),
                                               lower=0, overwrite_a=1)   # in place: one |P|^2 copy in all)
        del W
        if info < 0 or rank >= len(P) or rank == 0:
            return None
        piv = piv - 1
        C = sla.solve_triangular(U[:rank, :rank], U[:rank, rank:], check_finite=False)
        order = np.argsort(piv[:rank])                  # the kept rows in their order in P
        return np.sort(piv[rank:]), C[order][:, np.argsort(piv[rank:])]
