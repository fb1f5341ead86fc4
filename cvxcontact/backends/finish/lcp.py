"""Exact finish: the interface contact problem as a linear complementarity problem (LCP).

Condensed onto the contact rows (:class:`cvxcontact.backends.condensed.Compliance`;
docs/formulation.md §7), the discrete contact problem (26)-(27) is, in the constrained
rows a of E and scaled units,

    y >= 0,    s = d - W y <= 0,    y . s = 0                      (LCP)

with W = sum_l R_l Sigma_l^{-1} R_l^T the (symmetric positive semi-definite) interface
compliance, d the slack the contact would have with no contact force and y the nodal
contact forces. It is the optimality system of the strictly convex dual QP
min 1/2 y^T W y - d^T y over y >= 0, whose solution set is exact and finite to
enumerate. :func:`solve_lcp` finds it exactly:

1. primal-dual active-set steps (the semismooth Newton method for
   min(y, -s) = 0) from a starting set, with the complementarity function scaled
   *per row* by the row's own compliance w_a = W_aa: a row is active when
   y_a w_a + s_a > 0, both terms being displacements of that node. (A single global
   force scale, as in cvxcontact 0.1, cycles when the contact forces are small beside
   the loads, e.g. a stiff body on a soft foundation.)
2. if the steps cycle or stall, Lawson-Hanson non-negative least squares on the
   factor W = L L^T: min ||L^T y - L^{-1} d|| over y >= 0 has the same minimiser as
   the dual QP, and terminates in finitely many steps; its support is then refined by
   step 1.

Every returned answer satisfies the signs to rounding, measured per row:
y_a w_a >= -eps S_a and s_a <= eps S_a, with S_a = |d_a| + (|W| |y|)_a the size of
the terms of that row's slack (eps = SIGN_TOL).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from scipy.optimize import nnls

from .declined import CYCLE, MAX_ITER, SINGULAR, Declined, Stop

SIGN_TOL = 1e-10
"""Relative tolerance of the sign tests of the finish (rounding is ~1e-15 of the row scales)."""


def row_scales(W, d, y, absW=None):
    """Per-row compliance w (floored at 1e-14 of its max) and per-row displacement scale S_a =
    |d_a| + (|W| |y|)_a, the sizes of the terms of the slack s_a = d_a - (W y)_a (floored likewise).
    ``absW``: |W| if formed already (the active-set steps form it once)."""
    tiny = np.finfo(float).tiny
    w = np.diag(W).copy()
    w = np.maximum(w, 1e-14 * max(float(w.max(initial=0.0)), tiny))
    S = np.abs(d) + (np.abs(W) if absW is None else absW) @ np.abs(y)
    return w, np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), tiny))


def lcp_start(W, d, y, slack):
    """Active set of an approximate answer (e.g. an interior point's): rows where the force,
    turned into a displacement by the row's compliance, beats the open gap: y w + s > 0."""
    w, _ = row_scales(W, d, y)
    return y * w + slack > 0


def _closed(W, d, active, kept=None):
    """y with W_AA y_A = d_A, zero elsewhere; None if W_AA is singular. ``kept``: a :class:`LastFactor` of W."""
    y = np.zeros(len(d))
    if active.any():
        at = np.flatnonzero(active)
        try:              # (cho_factor raises LinAlgError where W_AA is not positive definite; no filter needed)
            c = None if kept is None else kept.get(active)
            if c is None:     # W_AA by two takes (W[np.ix_(A, A)]'s entries, C order: a third of its time)
                c = sla.cho_factor(W.take(at, axis=0).take(at, axis=1), overwrite_a=True)
                if kept is not None:
                    kept.put(active, c)
            y[active] = sla.cho_solve(c, d[active])
        except (np.linalg.LinAlgError, ValueError):
            return None
    return y


def signs_hold(y, slack, active, w, S):
    """Whether y >= 0 (as displacements y w) and the open rows' slack <= 0, each to SIGN_TOL times
    the row's own scale S_a: a row cannot hide behind a larger one."""
    return bool(np.isfinite(y).all() and np.isfinite(slack).all() and (y * w >= -SIGN_TOL * S).all()
                and (slack[~active] <= SIGN_TOL * S[~active]).all())


def _signs_hold(W, d, y, active, absW=None, slack=None):
    w, S = row_scales(W, d, y, absW)
    return signs_hold(y, d - W @ y if slack is None else slack, active, w, S)


def active_set_steps(step, start, max_iter: int, key=lambda active: active.tobytes()):
    """The primal-dual active-set iteration every exact finish shares (the semismooth Newton method for the
    complementarity function min(y, -s) = 0): ``step(active)`` solves the system with the rows of ``active``
    closed and returns ``(state, new)``, ``new`` the next active set or None when the signs hold (``state``
    is then the answer), or returns None for a singular system. ``key(active)``: a hashable form of an
    active set (default its bytes; a tuple of masks needs its own). Returns ``(state, active, steps)``, or
    the reason it stopped, a :class:`~cvxcontact.backends.finish.declined.Declined` (SINGULAR, CYCLE,
    MAX_ITER)."""
    seen, active = set(), start
    for n in range(1, max_iter + 1):
        out = step(active)
        if out is None:
            return SINGULAR
        state, new = out
        if new is None:
            return state, active, n
        k = key(new)
        if k == key(active) or k in seen:
            return CYCLE
        seen.add(k)
        active = new
    return MAX_ITER


KEPT_ROWS = 2048
"""The most closed rows whose factor a :class:`LastFactor` keeps (32 MB): a larger set's is not kept between load
cases (a 3D interface of many thousand closed rows would otherwise hold a second matrix of W's size)."""


class LastFactor:
    """The Cholesky factor of W_AA of the last active set A the steps of :func:`solve_lcp` closed on one W (the
    equilibrated W of a kept compliance), for the next load case, whose first step starts from the set the last one
    ended with: the same matrix, the same factor (a deterministic factorisation of the same entries), not formed
    twice. Kept: 8 bytes per closed row squared, up to :data:`KEPT_ROWS` rows. ``owner``: the W it belongs to (the
    caller's; a factor is reused only while :func:`solve_lcp` is given that very array, read-only: not edited)."""

    def __init__(self):
        self.owner = self.active = self.factor = None

    def get(self, active):
        """The kept factor if it is of the rows ``active`` (bool per row), else None."""
        same = self.active is not None and np.array_equal(self.active, active)
        return self.factor if same else None

    def put(self, active, factor) -> None:
        """Keep ``factor`` of the rows ``active``, unless it has more than :data:`KEPT_ROWS` rows (then none)."""
        small = len(factor[0]) <= KEPT_ROWS
        self.active, self.factor = (np.array(active, dtype=bool), factor) if small else (None, None)


def _equilibration(W) -> np.ndarray:
    """D = diag(w)^{-1/2}, w the rows' compliances of :func:`row_scales` (W's diagonal, floored at 1e-14 of its
    max): :func:`solve_lcp` solves with D W D, unit diagonal."""
    w = np.diag(W).copy()
    return 1.0 / np.sqrt(np.maximum(w, 1e-14 * max(float(w.max(initial=0.0)), np.finfo(float).tiny)))


def closed_solve(W, r, active, kept: LastFactor | None = None) -> np.ndarray:
    """z with W_AA z_A = r_A on the closed rows A = ``active`` (bool per row), zero elsewhere: the force that
    closes a slack r left on them (scaled units). Solved as :func:`solve_lcp` solves, on the equilibrated
    D W D; ``kept``: the :class:`LastFactor` that :func:`solve_lcp` filled on this very ``W``, whose factor is
    reused if it is of the rows A (no second factorisation), else W_AA is factorised here. Where W_AA is singular
    (a row repeated: a node that two obstacles coinciding there both hold, each closed at the same slack) z_A is
    the least-norm solution of the equilibrated system (its eigenvalues above 1e-12 of the largest; the Cholesky
    factor fails there or not by the BLAS kernels' rounding). Raises :class:`numpy.linalg.LinAlgError` if W_AA is
    indefinite (an eigenvalue below -1e-10 of the largest: not a compliance)."""
    z = np.zeros(len(r))
    at = np.flatnonzero(active)
    if not len(at):
        return z
    D = _equilibration(W)[at]
    rhs = D * np.asarray(r, dtype=float)[at]
    c = kept.get(active) if kept is not None and kept.owner is W else None
    if c is None:
        try:
            c = sla.cho_factor(D[:, None] * W.take(at, axis=0).take(at, axis=1) * D[None, :], overwrite_a=True)
        except np.linalg.LinAlgError:
            lam, V = np.linalg.eigh(D[:, None] * W.take(at, axis=0).take(at, axis=1) * D[None, :])
            if lam[0] < -1e-10 * lam[-1]:
                raise
            keep = lam > 1e-12 * lam[-1]
            z[at] = D * (V[:, keep] @ ((V[:, keep].T @ rhs) / lam[keep]))
            return z
    z[at] = D * sla.cho_solve(c, rhs)
    return z


def _pdas(W, d, active, max_iter, kept=None, implied=None):
    """The active-set steps of :func:`solve_lcp` from ``active``, the rows ``implied`` (bool per row, optional)
    never closed: (y, active) or None."""
    w, _ = row_scales(W, d, np.zeros(len(d)))
    absW = np.abs(W)                                   # |W| for every step's row scales, formed once
    closable = np.ones(len(d), dtype=bool) if implied is None else ~implied

    def step(active):
        y = _closed(W, d, active, kept)
        if y is None:
            return None
        slack = d - W @ y
        return y, (None if _signs_hold(W, d, y, active, absW, slack) else (y * w + slack > 0) & closable)

    out = active_set_steps(step, active & closable, max_iter)
    return None if isinstance(out, Declined) else out[:2]


def _least_squares_form(W, d):
    """(A, b) with 1/2 y^T W y - d^T y = 1/2 ||A y - b||^2 + const: A = L^T, L b = d, W = L L^T
    (Cholesky; a symmetric eigen-factor and least squares if W is only semi-definite)."""
    try:
        L = sla.cholesky(W, lower=True)
        return L.T, sla.solve_triangular(L, d, lower=True)
    except np.linalg.LinAlgError:
        lam, V = np.linalg.eigh(W)
        L = V * np.sqrt(np.maximum(lam, 0.0))
        return L.T, sla.lstsq(L, d)[0]


def solve_lcp(W, d, active=None, max_iter=30, kept: LastFactor | None = None, implied=None):
    """Solve the LCP of the module docstring exactly.

    Parameters
    ----------
    W : (m, m) ndarray, symmetric positive (semi-)definite compliance (scaled units)
    d : (m,) ndarray, slack at y = 0 (scaled displacement)
    active : (m,) bool ndarray, optional
        Starting active set (default: rows with d > 0, the penetrating ones).
    kept : LastFactor, optional
        The factor of the last closed set on this very ``W`` (kept by the caller between load cases): reused if the
        steps close on that set again, and replaced by the last one they factorise (the same answer either way).
        Only for a read-only ``W`` that owns its entries (as :attr:`Compliance.W
        <cvxcontact.backends.condensed.Compliance.W>`): a W that can be edited in place keeps no factor.
    implied : (m,) bool ndarray, optional
        Rows never closed (their force 0): the rows a tighter parallel row implies
        (:meth:`Compliance.looser <cvxcontact.backends.condensed.Compliance.looser>`). W's row of such a row
        repeats the tighter one's, so closing both makes W_AA singular, and the gaps differing, d is then not in
        the range of W: the least-squares form of step 2 does not hold (it read a support whose closed rows were
        open by 0.015 to 0.14 (scaled) where d was 1e-5: a floor, a strip raised above part of it and a
        far floor 1 m below, 2D P1). Their slack is still checked for its sign.

    Returns
    -------
    (y, active, route) with route "active set" or "active set after NNLS", or a :class:`Declined`:
    ``Stop.SIGNS`` if no set satisfying the signs was found (W singular on the contact rows in a way that leaves
    the forces undetermined and the NNLS support too), ``Stop.NO_SOLUTION`` if a row no unknown moves
    penetrates.
    """
    W = np.asarray(W, dtype=float)
    d = np.asarray(d, dtype=float)
    if len(d) == 0:
        return np.zeros(0), np.zeros(0, dtype=bool), "active set"
    held = np.diag(W) <= 0.0           # rows no unknown moves (W PSD: a zero diagonal is a zero row): y_a = 0
    if held.any():                     # if their constant slack d_a holds; (26) does not determine their force
        if (d[held] > 0).any():
            return Declined(Stop.NO_SOLUTION, "a row no unknown moves penetrates: no force can close it")
        keep = ~held
        out = solve_lcp(W[np.ix_(keep, keep)], d[keep], None if active is None else np.asarray(active)[keep],
                        max_iter, implied=None if implied is None else np.asarray(implied, dtype=bool)[keep])
        if isinstance(out, Declined):
            return out
        y, act = np.zeros(len(d)), np.zeros(len(d), dtype=bool)
        y[keep], act[keep] = out[0], out[1]
        return y, act, out[2]
    # symmetric equilibration (y = D z, W -> D W D, d -> D d, D = diag(W)^{-1/2}): same signs, same
    # active sets, unit diagonal; the rows of a stiff and a soft body then share one scale
    D = _equilibration(W)
    editable = not (isinstance(W, np.ndarray) and W.flags.owndata) or W.flags.writeable
    if kept is not None and (editable or kept.owner is not W):    # another W, or one editable in place (its
        kept.owner, kept.active, kept.factor = (None if editable else W), None, None    # entries may have changed
        kept = None if editable else kept                          # under the kept factor): nothing kept applies
    implied = None if implied is None or not np.any(implied) else np.asarray(implied, dtype=bool)
    out = _solve_equilibrated(D[:, None] * W * D[None, :], D * d, active, max_iter, kept, implied)
    return out if isinstance(out, Declined) else (D * out[0], out[1], out[2])


def _solve_equilibrated(W, d, active, max_iter, kept=None, implied=None):
    start = (d > 0) if active is None else np.asarray(active, dtype=bool)
    out = _pdas(W, d, start, max_iter, kept, implied)
    if out is not None:
        return out[0], out[1], "active set"
    F = slice(None) if implied is None else ~implied            # the rows that may close
    A, b = _least_squares_form(W if implied is None else W[np.ix_(F, F)], d[F])
    y = np.zeros(len(d))
    y[F], _ = nnls(A, b, maxiter=50 * len(b))
    w, S = row_scales(W, d, y)
    support = y * w > SIGN_TOL * S
    out = _pdas(W, d, support, max_iter, kept, implied)
    if out is not None:
        return out[0], out[1], "active set after NNLS"
    slack = d - W @ y
    if _signs_hold(W, d, y, support, slack=slack) and (np.abs(slack[support]) <= SIGN_TOL * S[support]).all():
        return y, support, "NNLS"      # its closed rows closed too (a Lawson-Hanson answer on a singular W, rows
        # repeated, can leave them open or penetrated by 1e-2 of their scale: not an answer)
    return Declined(Stop.SIGNS, "no active set satisfies the signs of the contact problem")
