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

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import nnls

__all__ = ["solve_lcp", "lcp_start", "row_scales", "signs_hold", "reach_displacements", "reach_forces", "row_compliance",
           "force_scale", "FORCE_FLOOR", "solve_compliance", "solve_linear_compliance",
           "solve_sparse_compliance", "SIGN_TOL"]

SIGN_TOL = 1e-10
"""Relative tolerance of the sign tests of the finish (rounding is ~1e-15 of the row scales)."""


def row_scales(W, d, y):
    """Per-row compliance w (floored at 1e-14 of its max) and per-row displacement scale S_a =
    |d_a| + (|W| |y|)_a, the sizes of the terms of the slack s_a = d_a - (W y)_a (floored likewise)."""
    tiny = np.finfo(float).tiny
    w = np.diag(W).copy()
    w = np.maximum(w, 1e-14 * max(float(w.max(initial=0.0)), tiny))
    S = np.abs(d) + np.abs(W) @ np.abs(y)
    return w, np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), tiny))


def lcp_start(W, d, y, slack):
    """Active set of an approximate answer (e.g. an interior point's): rows where the force,
    turned into a displacement by the row's compliance, beats the open gap: y w + s > 0."""
    w, _ = row_scales(W, d, y)
    return y * w + slack > 0


def _closed(W, d, active):
    """y with W_AA y_A = d_A, zero elsewhere; None if W_AA is singular."""
    y = np.zeros(len(d))
    if active.any():
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", sla.LinAlgWarning)
                c = sla.cho_factor(W[np.ix_(active, active)])
                y[active] = sla.cho_solve(c, d[active])
        except (np.linalg.LinAlgError, ValueError, sla.LinAlgWarning):
            return None
    return y


def signs_hold(y, slack, active, w, S):
    """Whether y >= 0 (as displacements y w) and the open rows' slack <= 0, each to SIGN_TOL times
    the row's own scale S_a: a row cannot hide behind a larger one."""
    return bool(np.isfinite(y).all() and np.isfinite(slack).all() and (y * w >= -SIGN_TOL * S).all()
                and (slack[~active] <= SIGN_TOL * S[~active]).all())


def _signs_hold(W, d, y, active):
    w, S = row_scales(W, d, y)
    return signs_hold(y, d - W @ y, active, w, S)


def active_set_steps(step, start, max_iter: int, key=lambda active: active.tobytes()):
    """The primal-dual active-set iteration every exact finish shares (the semismooth Newton method for the
    complementarity function min(y, -s) = 0): ``step(active)`` solves the system with the rows of ``active``
    closed and returns ``(state, new)``, ``new`` the next active set or None when the signs hold (``state``
    is then the answer), or returns None for a singular system. ``key(active)``: a hashable form of an
    active set (default its bytes; a tuple of masks needs its own). Returns ``(state, active, steps)``, or
    the reason it stopped ("singular", "cycle", "max_iter") as a string."""
    seen, active = set(), start
    for n in range(1, max_iter + 1):
        out = step(active)
        if out is None:
            return "singular"
        state, new = out
        if new is None:
            return state, active, n
        k = key(new)
        if k == key(active) or k in seen:
            return "cycle"
        seen.add(k)
        active = new
    return "max_iter"


STOPPED = {"singular": "the mixed system on the active set is singular", "cycle": "the active-set steps cycle",
           "max_iter": "the active-set steps did not settle"}
"""Why :func:`active_set_steps` stopped, in words."""


def _pdas(W, d, active, max_iter):
    w, _ = row_scales(W, d, np.zeros(len(d)))

    def step(active):
        y = _closed(W, d, active)
        if y is None:
            return None
        return y, (None if _signs_hold(W, d, y, active) else y * w + (d - W @ y) > 0)

    out = active_set_steps(step, active, max_iter)
    return None if isinstance(out, str) else out[:2]


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


def solve_lcp(W, d, active=None, max_iter=30):
    """Solve the LCP of the module docstring exactly.

    Parameters
    ----------
    W : (m, m) ndarray, symmetric positive (semi-)definite compliance (scaled units)
    d : (m,) ndarray, slack at y = 0 (scaled displacement)
    active : (m,) bool ndarray, optional
        Starting active set (default: rows with d > 0, the penetrating ones).

    Returns
    -------
    (y, active, route) with route "active set" or "active set after NNLS", or None if
    no set satisfying the signs was found (W singular on the contact rows in a way
    that leaves the forces undetermined and the NNLS support too).
    """
    W = np.asarray(W, dtype=float)
    d = np.asarray(d, dtype=float)
    if len(d) == 0:
        return np.zeros(0), np.zeros(0, dtype=bool), "active set"
    held = np.diag(W) <= 0.0           # rows no unknown moves (W PSD: a zero diagonal is a zero row): y_a = 0
    if held.any():                     # if their constant slack d_a holds; (26) does not determine their force
        if (d[held] > 0).any():
            return None
        keep = ~held
        out = solve_lcp(W[np.ix_(keep, keep)], d[keep], None if active is None else np.asarray(active)[keep],
                        max_iter)
        if out is None:
            return None
        y, act = np.zeros(len(d)), np.zeros(len(d), dtype=bool)
        y[keep], act[keep] = out[0], out[1]
        return y, act, out[2]
    # symmetric equilibration (y = D z, W -> D W D, d -> D d, D = diag(W)^{-1/2}): same signs, same
    # active sets, unit diagonal; the rows of a stiff and a soft body then share one scale
    D = 1.0 / np.sqrt(row_scales(W, d, np.zeros(len(d)))[0])
    out = _solve_equilibrated(D[:, None] * W * D[None, :], D * d, active, max_iter)
    return None if out is None else (D * out[0], out[1], out[2])


def _solve_equilibrated(W, d, active, max_iter):
    start = (d > 0) if active is None else np.asarray(active, dtype=bool)
    out = _pdas(W, d, start, max_iter)
    if out is not None:
        return out[0], out[1], "active set"
    A, b = _least_squares_form(W, d)
    y, _ = nnls(A, b, maxiter=50 * len(d))
    w, S = row_scales(W, d, y)
    support = y * w > SIGN_TOL * S
    out = _pdas(W, d, support, max_iter)
    if out is not None:
        return out[0], out[1], "active set after NNLS"
    if _signs_hold(W, d, y, support):
        return y, support, "NNLS"
    return None


def solve_compliance(W, d, weights, law, r0=None, max_iter=50, active=None):
    """Exact finish for a normal-compliance law (docs/formulation.md §10), on the interface compliance.

    In the constrained rows (scaled units) the penetration r, the compliance force w p(r) (w the lumped
    lengths ``weights``, p the scaled ``law``) and the penetration-limit reaction z satisfy

        r = d - W y,   y = w p(r) + z,   r <= l,  z >= 0,  z (r - l) = 0     (z = 0 without a limit l)

    which is the optimality system of the strictly convex problem

        min_r  psi(r) = 1/2 (r - d)^T W^{-1} (r - d) + sum_a w_a Phi(r_a)     subject to r <= l.

    Solved by a damped semismooth Newton method on the free rows (Armijo backtracking on psi; for m = 1
    p' is piecewise constant and the steps end in finitely many once the contact set is right) inside
    primal-dual active-set steps on the limit rows (active next where z_a + (r_a - l) / W_aa > 0).

    ``law`` may be one :class:`~cvxcontact.contact.laws.NormalCompliance` or a per-row
    :class:`~cvxcontact.contact.laws.RowLaws`: a Signorini row is k = 0 with l = 0, so its row of the
    system is the LCP y >= 0, r <= 0, y r = 0 (the complementarity function min(y, -r) = 0 of
    :func:`solve_lcp`, here in the active-set form of the limit rows), and mixed rows are solved together.
    ``active`` (bool, optional) is the starting set of rows at their limit (default: r0 >= l).

    Returns ``(y, z, at_limit, route)`` or None if W is singular on the rows or the steps do not settle
    with the signs holding to ``SIGN_TOL`` of each row's scale (:func:`row_scales`).
    """
    W = np.asarray(W, dtype=float)
    d = np.asarray(d, dtype=float)
    w = np.asarray(weights, dtype=float)
    n = len(d)
    if n == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool), "semismooth Newton"
    limit = law.penetration_limit
    ell = np.full(n, np.inf) if limit is None else np.broadcast_to(np.asarray(limit, dtype=float), (n,)).copy()
    # rows no unknown moves (a zero diagonal of the PSD W is a zero row): r_a = d_a whatever the forces, so
    # their law force is w_a p(d_a) and their limit reaction, which (26) would not determine, is 0
    held = np.diag(W) <= 0.0
    if (d[held] > ell[held]).any():
        return None
    if (d <= ell).all() and not np.any(w * law.pressure(d)):
        # nothing is pressed at zero force (e.g. no load): y = z = 0 is the solution, exactly; Newton steps
        # from an interior point would stop at rounding around it (1e-36), which no force scale can judge
        return np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), "semismooth Newton"
    keep = ~held
    H = np.zeros((n, n))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", sla.LinAlgWarning)
            H[np.ix_(keep, keep)] = sla.cho_solve(sla.cho_factor(W[np.ix_(keep, keep)]), np.eye(int(keep.sum())))
    except (np.linalg.LinAlgError, ValueError, sla.LinAlgWarning):
        return None
    H = 0.5 * (H + H.T)
    r = np.minimum(d if r0 is None else np.asarray(r0, dtype=float), ell)
    at = (r >= ell) & keep
    if active is not None:
        at = at | (np.asarray(active, dtype=bool) & np.isfinite(ell) & keep)
    r[at] = ell[at]
    r[held] = d[held]

    def psi(r):
        return 0.5 * (r - d) @ (H @ (r - d)) + float(w @ law.energy(r))

    def grad(r):
        return H @ (r - d) + w * law.pressure(r)

    seen = set()
    for _ in range(max_iter):
        free = ~at & keep
        r[at] = ell[at]
        for _ in range(max_iter):                       # damped Newton on the free rows
            g = grad(r)
            gF = np.where(free, g, 0.0)
            _, S = row_scales(W, d, w * law.pressure(r) + np.where(at, -g, 0.0))
            if not free.any() or (np.abs(W @ gF) <= 1e-3 * SIGN_TOL * (S + np.abs(r))).all():
                break                                    # the interface equation holds to rounding
            K = H[np.ix_(free, free)] + np.diag(w[free] * law.derivative(r)[free])
            try:
                step = sla.solve(K, -g[free], assume_a="pos")
            except (np.linalg.LinAlgError, ValueError):
                return None
            t, f0, slope, n0 = 1.0, psi(r), float(g[free] @ step), np.linalg.norm(g[free])
            while True:
                trial = r.copy()
                trial[free] += t * step
                # Armijo on psi; near the solution psi's decrease drowns in rounding, so a step that
                # reduces the gradient is accepted too
                if (psi(trial) <= f0 + 1e-4 * t * slope or np.linalg.norm(grad(trial)[free]) < n0
                        or t < 1e-12):
                    break
                t *= 0.5
            r = trial
        if free.any():   # refinement on the interface equation itself, r - d + W w p(r) = 0 on the free rows:
            r = _refined(W, d, w, law, r, free, at)   # H = W^-1 explicit loses cond(W) eps in r (1e-11 measured)
        g = grad(r)
        z = np.where(at, -g, 0.0)
        if at.any():     # the reactions from W_AA z_A = d_A - l_A - (W w p(r))_A by Cholesky: the explicit
            try:         # inverse H loses cond(W) eps in z, which the back-substituted fields would show
                with warnings.catch_warnings():
                    warnings.simplefilter("error", sla.LinAlgWarning)
                    rhs = (d - r - W @ (w * law.pressure(r)))[at]
                    z[at] = sla.cho_solve(sla.cho_factor(W[np.ix_(at, at)]), rhs)
            except (np.linalg.LinAlgError, ValueError, sla.LinAlgWarning):
                pass
        y = w * law.pressure(r) + z
        wr, S = row_scales(W, d, y)
        resid = r - d + W @ y                            # the interface equation, displacement units
        ok = (np.abs(resid) <= SIGN_TOL * (S + np.abs(r))).all()
        neg = at & (z * wr < -SIGN_TOL * S)
        over = ~at & keep & (r - ell > SIGN_TOL * S)
        if ok and not neg.any() and not over.any():
            return y, z, at, "semismooth Newton"
        at = _next_limit_set(at, neg, over, seen)
        if at is None:
            return None
    return None


def _refined(W, d, w, law, r, free, at, steps=3):
    """``r`` refined by Newton steps on the interface equation r - d + W (w p(r) + z) = 0 of
    :func:`solve_compliance` with the residual computed with W itself (not its inverse): the unknowns are r on
    the ``free`` rows and the reactions z on the rows ``at`` their limit (r = l there). The inner Newton on psi
    (through H = W^-1) reaches cond(W) eps (1e-11 ... 2e-10 measured); these steps reach rounding of the
    equation's terms. A step is kept only if it reduces the residual; the caller solves z afterwards."""
    F, A = np.flatnonzero(free), np.flatnonzero(at)
    if not len(F):
        return r
    rows = np.concatenate([F, A])

    def residual(r, zA):
        y = w * law.pressure(r)
        y[A] += zA
        return (r - d + W @ y)[rows]

    zA = np.zeros(len(A))
    if len(A):
        try:
            zA = sla.solve(W[np.ix_(A, A)], (d - r - W @ (w * law.pressure(r)))[A], assume_a="pos")
        except (np.linalg.LinAlgError, ValueError):
            return r
    res = residual(r, zA)
    for _ in range(steps):
        J = np.zeros((len(rows), len(rows)))
        J[:, :len(F)] = W[np.ix_(rows, F)] * (w * law.derivative(r))[F][None, :]
        J[:len(F), :len(F)] += np.eye(len(F))
        J[:, len(F):] = W[np.ix_(rows, A)]
        try:
            delta = sla.solve(J, -res)
        except (np.linalg.LinAlgError, ValueError):
            return r
        trial = r.copy()
        trial[F] += delta[:len(F)]
        new = residual(trial, zA + delta[len(F):])
        if not np.isfinite(new).all() or np.linalg.norm(new) >= np.linalg.norm(res):
            return r
        r, zA, res = trial, zA + delta[len(F):], new
    return r


def _next_limit_set(at, neg, over, seen):
    """The next set of rows at their limit in the active-set steps of the compliance finishes: ``at`` without
    the rows whose reaction is negative (``neg``) and with those beyond their limit (``over``); None if that
    set was visited before (``seen``, updated): the steps cycle."""
    new = (at & ~neg) | over
    key = new.tobytes()
    if key in seen:
        return None
    seen.add(key)
    return new


def solve_linear_compliance(W, d, weights, law):
    """Exact finish for rows whose compliance laws are all linear (m = 1) without a limit, mixed with
    Signorini rows, as one LCP (docs/formulation.md §10): on a compliance row y_a = w_a k_a (r_a)_+ is
    y_a >= 0, s_a = r_a - y_a / (w_a k_a) <= 0, y_a s_a = 0 with r = d - W y, i.e. the LCP of
    :func:`solve_lcp` with W + diag(1 / (w_a k_a)) on those rows; Signorini rows keep W; a compliance row of
    weight 0 carries no force and leaves the LCP. Finite (NNLS
    fallback) where the Newton steps of :func:`solve_compliance` might cycle. ``law`` a
    :class:`~cvxcontact.contact.laws.RowLaws` (scaled). Returns ``(y, z, at_limit, route)`` or None."""
    W = np.asarray(W, dtype=float)
    k = np.broadcast_to(np.asarray(law.stiffness, dtype=float), (len(d),))
    w = np.asarray(weights, dtype=float)
    on = k > 0
    keep = ~on | (w > 0)             # a compliance row of weight 0 (a P2 face vertex) carries no force: y = 0
    soft = np.zeros(len(d))
    soft[on & keep] = 1.0 / (w[on & keep] * k[on & keep])
    out = solve_lcp((W + np.diag(soft))[np.ix_(keep, keep)], d[keep])
    if out is None:
        return None
    y, active, route = np.zeros(len(d)), np.zeros(len(d), dtype=bool), out[2]
    y[keep], active[keep] = out[0], out[1]
    z = np.where(on, 0.0, y)
    return y, z, active & ~on, route


def solve_sparse_compliance(A, F, G, g, weights, law, x0, active=None, max_iter=50):
    """Exact finish of a normal-compliance law on the sparse mixed system (26), for scenes that cannot be
    condensed body by body (a body held by the contact only, force-controlled obstacles; docs/formulation.md
    §10-§12). Scaled units.

    ``A`` (n, n) sparse symmetric: the bodies' quasi-definite blocks [[Kuu, Kup], [Kup^T, -Kpp]] and a zero
    block for the translations tau of force-controlled obstacles; ``F`` (n,) the loads [f; -q; F_obstacle];
    ``G`` (m, n) sparse the contact rows (E [u_nu] and R tau), ``g`` (m,) their gaps, so that r = G x - g is
    the penetration; ``weights`` w (m,) the rows' lumped lengths and ``law`` a per-row
    :class:`~cvxcontact.contact.laws.RowLaws` (Signorini rows: k = 0, l = 0). The system is

        A x + G^T y = F,   y = w p(r) + z,   r <= l,  z >= 0,  z (r - l) = 0   (z = 0 off the limited rows)

    the optimality system of the phi-form energy plus sum_a w_a Phi_a(r_a) subject to r <= l. Solved by
    Newton steps on the rows' law: with D = diag(w p'(r^k)) and L the rows held at their limit, each step
    solves the sparse system

        [[A + G^T D G, G_L^T], [G_L, 0]] [x; z_L] = [F - G^T (w p(r^k) - D (g + r^k)); g_L + l_L]

    (exact in one step for m = 1 once the penetrating rows are right: a semismooth Newton step), damped by
    backtracking on the energy 1/2 x^T A x - F^T x + sum_a w_a Phi_a(r_a) (the phi-form energy wherever
    the Gauss rows hold, which every step after the first keeps), inside primal-dual active-set steps on
    the limited rows (a row joins L where z_a > 0 is needed or r_a > l_a). ``x0`` the start (e.g. the interior
    point's answer), ``active`` (bool, m) the starting L (default r(x0) >= l on the limited rows).

    Returns ``(x, y, z, at_limit, steps)`` with the stationarity residual at rounding (each row's residual
    within 1e-3 ``SIGN_TOL`` of its scale |A| |x| + |G^T| |y| + |F|, or within ``SIGN_TOL`` once a full
    step no longer halves it) and the signs to ``SIGN_TOL``, or None if a
    system is singular (e.g. a held body whose rows all left the contact) or the steps do not settle.
    """
    import scipy.sparse as sps

    from .full import solve_mixed       # (full imports nothing from here)

    A, G = sps.csr_matrix(A), sps.csr_matrix(G)
    F, g, w = (np.asarray(a, dtype=float) for a in (F, g, weights))
    n, m = A.shape[0], G.shape[0]
    ell = np.asarray(law.penetration_limit, dtype=float)
    # a row no unknown moves (a zero row of G: a held node) keeps r = -g; its limit reaction, which (26) would
    # not determine and which would make the step matrix singular, is 0 (docs/formulation.md §8, "Held nodes")
    limited = np.isfinite(ell) & (np.diff(G.indptr) > 0)
    x = np.asarray(x0, dtype=float).copy()
    at = limited & ((G @ x - g) >= ell) if active is None else np.asarray(active, dtype=bool) & limited
    absA, absG = abs(A), abs(G)
    tiny = np.finfo(float).tiny

    def energy(x):
        r = G @ x - g
        return 0.5 * x @ (A @ x) - F @ x + float(w @ law.energy(r))

    def step(x, at):
        r = G @ x - g
        D = w * law.derivative(r)
        K = A + G.T @ sps.diags(D) @ G
        GL = G[at]
        M = sps.bmat([[K, GL.T], [GL, None]], format="csc") if at.any() else K.tocsc()
        b = F - G.T @ (w * law.pressure(r) - D * (g + r))
        b = np.concatenate([b, (g + ell)[at]]) if at.any() else b
        s = solve_mixed(M, b)
        if s is None:
            return None
        zL = np.zeros(m)
        zL[at] = s[n:]
        return s[:n], zL

    steps, seen, first = 0, set(), True
    for _ in range(max_iter):
        z, last = np.zeros(m), np.inf
        for _ in range(max_iter):                       # damped Newton with the limit rows L closed
            out = step(x, at)
            steps += 1
            if out is None:
                return None
            target, z = out
            dx = target - x
            t, f0 = 1.0, energy(x)
            if not first:
                while t > 1e-12 and energy(x + t * dx) > f0 + 1e-14 * max(abs(f0), tiny):
                    t *= 0.5
            first = False
            x = x + t * dx
            r = G @ x - g
            y = w * law.pressure(r) + z
            res = A @ x + G.T @ y - F
            S = absA @ np.abs(x) + absG.T @ np.abs(y) + np.abs(F)
            S = np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), tiny))
            ratio = float((np.abs(res) / S).max(initial=0.0))
            # converged: at rounding, or within SIGN_TOL and no longer improving (rounding of the steps)
            if t == 1.0 and (ratio <= 1e-3 * SIGN_TOL or (ratio <= SIGN_TOL and ratio >= 0.5 * last)):
                break
            last = ratio
            if np.abs(t * dx).max(initial=0.0) <= 1e-15 * max(np.abs(x).max(initial=0.0), tiny):
                return None                             # stalled above rounding
        else:
            return None
        r = G @ x - g
        y = w * law.pressure(r) + z
        scale = absG @ np.abs(x) + np.abs(g)
        scale = np.maximum(scale, 1e-14 * max(float(scale.max(initial=0.0)), tiny))
        Y = max(float(np.abs(y).max(initial=0.0)), tiny)
        neg = at & (z < -SIGN_TOL * Y)
        over = limited & ~at & (r - ell > SIGN_TOL * scale)
        if not neg.any() and not over.any():
            return x, y, z, at, steps
        at = _next_limit_set(at, neg, over, seen)
        if at is None:
            return None
    return None


def node_scales(parts, g, extra=None):
    """Slack E [u_nu] - g of the constrained rows, from each body's part E J_l u_l, and each row's
    displacement scale U_a: the sizes of both parts there plus the gap plus ``extra`` (the local
    displacement of the row's own force, :func:`force_displacements`), floored at 1e-9 of the largest."""
    U = sum(np.abs(p) for p in parts) + np.abs(g)
    if extra is not None:
        U = U + extra
    return sum(parts) - g, np.maximum(U, 1e-9 * U.max(initial=0.0) + np.finfo(float).tiny)


def force_displacements(blocks, E, y):
    """w_a |y_a|: the displacement the contact force y_a of row a produces through the diagonal of each
    body's stiffness, w_a = sum_l sum_j (E J_l)_aj^2 / (K_uu,l)_jj (scaled units). A node held at exactly
    [u_nu] = g by a rigid obstacle or a stuck partner has no other displacement scale (docs/checks.md)."""
    return row_compliance(blocks, E) * np.abs(y)


def row_compliance(blocks, E) -> np.ndarray:
    """w_a = sum_l sum_j (E J_l)_aj^2 / (K_uu,l)_jj: each row's compliance through the diagonal of each body's
    stiffness (scaled units; the unknowns with no stiffness diagonal do not count)."""
    w = np.zeros(E.shape[0])
    for b in blocks:
        R = (E @ b.jump).tocsr()
        w += np.asarray(R.multiply(R) @ _inverse_diagonal(b.Kuu)).ravel()
    return w


def _inverse_diagonal(K) -> np.ndarray:
    """1 / K_jj where the diagonal is positive, 0 elsewhere (an unknown no stiffness holds)."""
    d = K.diagonal()
    return np.where(d > 0, 1.0 / np.where(d > 0, d, 1.0), 0.0)


def _elastic_forces(blocks, u, phi):
    """Per body (block, |Kuu| |u| + |Kup| |phi|): the sizes of the elastic forces at its unknowns (scaled)."""
    for k, (b, uk) in enumerate(zip(blocks, u)):
        f = abs(b.Kuu) @ np.abs(uk)
        pk = None if phi is None else phi[k]
        if pk is not None and getattr(b, "Kup", None) is not None:
            f = f + abs(b.Kup) @ np.abs(pk)
        yield b, f


def reach_displacements(blocks, E, u, phi=None):
    """The displacement each row's unknowns would have from the elastic forces of their neighbours alone:
    sum_l |E J_l| D_l^{-1} (|Kuu_l| |u_l| + |Kup_l| |phi_l|), D_l the positive diagonal of Kuu_l (scaled units;
    the check-side twin of :func:`row_reach`). The rounding of a node's displacement is relative to it: a node
    that does not move (a P2 face vertex on a rigid plane under a uniform pressure) has a slack of rounding and
    no displacement of its own, and its neighbours' displacements are the scale of that rounding."""
    return sum((abs(E @ b.jump) @ (_inverse_diagonal(b.Kuu) * f) for b, f in _elastic_forces(blocks, u, phi)),
               np.zeros(E.shape[0]))


def reach_forces(blocks, E, u, phi=None):
    """The size of the elastic forces at each row's unknowns, sum_l |E J_l| (|Kuu_l| |u_l| + |Kup_l| |phi_l|)
    (scaled forces): the force scale of a contact row that carries no force (an open contact, or forces of
    interior-point noise), below which a contact force is not read as a force (:data:`FORCE_FLOOR`)."""
    return sum((abs(E @ b.jump) @ f for b, f in _elastic_forces(blocks, u, phi)), np.zeros(E.shape[0]))


FORCE_FLOOR = 1e-6
"""The largest contact force Y is floored at this fraction of the largest elastic force at the contact rows
(:func:`reach_forces`) where it normalises the forces (the active rows of an interior point, the
complementarity and cone checks): with the contact open, an interior point's forces are noise (1e-8 of
that scale, measured) and must not read as a contact (docs/checks.md)."""


def force_scale(y, reach=None) -> float:
    """Y = max(max |y|, FORCE_FLOOR max ``reach``) (:func:`reach_forces`), at least the smallest float."""
    Y = float(np.abs(y).max(initial=0.0))
    if reach is not None:
        Y = max(Y, FORCE_FLOOR * float(np.max(reach, initial=0.0)))
    return max(Y, np.finfo(float).tiny)


def ipm_active(parts, g, y, extra=None, reach=None):
    """Active rows of an interior-point answer: the force, relative to the largest contact force
    (:func:`force_scale`, floored by ``reach``, :func:`reach_forces`), beats the open gap relative to the
    row's displacement scale (free of units and load scale; ``extra`` as in :func:`node_scales`, e.g.
    :func:`force_displacements`)."""
    slack, U = node_scales(parts, g, extra)
    return y / force_scale(y, reach) > np.abs(slack) / U


DEPENDENT_PIVOT = 1e-10
"""A row whose component outside the span of the rows carrying forces is below this (unit rows) is dependent
on them (:func:`independent_active_set`): 3D overlay rows at vertices a distance ~1e-9 h apart are merged."""


def _independent(M, tol=DEPENDENT_PIVOT) -> np.ndarray:
    """Indices of a maximal set of linearly independent columns of the dense ``M`` (unit columns), by a
    column-pivoted QR, in the order of the pivots."""
    if M.shape[1] == 0:
        return np.zeros(0, dtype=int)
    _, R, piv = sla.qr(M, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    return piv[:int(np.sum(diag > tol))]


def _row_scale(absG, x, g):
    """S_j = (|G| |x|)_j + |g_j|, the displacement scale of each row's slack G_j x - g_j (floored at 1e-14 of
    the largest). With ``absG`` :func:`row_reach` the scale also counts the row's nodes' neighbours."""
    S = absG @ np.abs(x) + np.abs(g)
    return np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), np.finfo(float).tiny))


def row_reach(A, G):
    """|G| + |G| diag(A)^{-1} |A| (sparse, m x n; only the unknowns with a positive stiffness diagonal count in
    the second term): with it, :func:`_row_scale` gives S_j = (|G| |x|)_j + |g_j| plus the displacement that
    the elastic forces at row j's unknowns, (|A| |x|)_k, produce through their own stiffness A_kk. A node that
    does not move (held at the gap by a rigid plane, carrying no force: a P2 face vertex under a uniform
    pressure) has a slack of rounding and no displacement of its own, so that its slack over its own scale
    is rounding over rounding, of either sign; its neighbours' displacements are the scale of that rounding."""
    A, absG = sp.csr_matrix(A), abs(sp.csr_matrix(G))
    return (absG + absG @ sp.diags(_inverse_diagonal(A)) @ abs(A)).tocsr()


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
    factors, computed when its row first enters R and kept (m doubles a row); the system on R is solved by
    :class:`UpdatedSystem` (O(|R|^2) a changed row); a step costs that and one solve with K0 for x (the rows'
    scales). :meth:`exact` solves (26) on P to rounding (iterative refinement on (26) itself).
    """

    def __init__(self, A, F, G, g, anchor, lu, K0, rho):
        self.A, self.F, self.G, self.g, self.anchor, self.lu, self.K0 = A, F, G, g, anchor, lu, K0
        self.absA, self.absG = abs(A), abs(G)
        self.reach = row_reach(A, G)
        self.rho = np.zeros(G.shape[0])
        self.rho[anchor] = rho
        self.Ft = F + G[anchor].T @ (rho * g[anchor])
        self.h = G @ self.solve(self.Ft) - g
        m = G.shape[0]
        self.where = np.full(m, -1)
        self.cols = np.zeros((m, min(m, max(16, 2 * len(anchor)))))
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
        Z = self.lu.solve(self.G[new].T.toarray())     # (no refinement: the answers are refined on (26))
        self.cols[:, self.count:self.count + len(new)] = self.G @ Z
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
        x = self.lu.solve(self.Ft - self.G[rows].T @ w)      # for the rows' scales only: no refinement
        z = np.zeros(self.G.shape[0])
        z[passive] = w[:len(passive)]
        self.sizes.append((len(passive), len(rows) - len(passive)))
        return None, z, self.h - Cw, _row_scale(self.reach, x, self.g)

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
        (a diagonal entry of R below 1e-13 of the largest)."""
        keys = np.asarray(keys, dtype=int)
        if not len(keys):
            return np.zeros(0)
        changes = len(np.setxor1d(keys, self.keys))
        if self.Q is None or changes > max(4, len(keys) // 8):
            self.refactor(keys)
        elif changes:
            self._update(keys)
        d = np.abs(np.diag(self.R))
        if not d.min() > 1e-13 * d.max():
            return None
        order = np.argsort(self.keys)
        where = order[np.searchsorted(self.keys[order], keys)]     # keys[i] = self.keys[where[i]]
        bk = np.zeros(len(keys))
        bk[where] = b
        return sla.solve_triangular(self.R, self.Q.T @ bk, check_finite=False)[where]


def factored_rows(A, F, G, g, anchor) -> FactoredRows | None:
    """:class:`FactoredRows` of the mixed system, or None if K0 is singular (the anchor rows do not hold every
    body): structurally (checked before SuperLU, which can corrupt memory on such matrices, see
    :func:`~cvxcontact.backends.full.solve_mixed`), by a zero pivot, or numerically (a solve of K0 z = K0 v
    misses v by more than 1e-6, v a fixed vector with components along any kernel)."""
    from scipy.sparse.csgraph import structural_rank

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
    if structural_rank(K0) < n:
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", spla.MatrixRankWarning)
            lu = spla.splu(K0, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options=dict(SymmetricMode=True))
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
    W_PP y_P = d_P (:class:`UpdatedSystem`, O(|P|^2) a changed row), with W = sum_l R_l Sigma_l^{-1} R_l^T the
    interface compliance and d the free slack (:class:`~cvxcontact.backends.condensed.Compliance`); the Gamma
    displacements v = v0 - B y give every row's slack R v - g and its scale (|R| |v|) + |g|, as the sparse
    mixed system's steps do."""

    def __init__(self, compliance, v0, g):
        self.W = compliance.W
        self.R = np.hstack(compliance.rows)
        self.B = np.vstack(compliance.B)
        self.v0 = np.concatenate(v0)
        self.g = np.asarray(g, dtype=float)
        self.d = self.R @ self.v0 - self.g
        self.absR = np.abs(self.R)
        self.system = UpdatedSystem(lambda a, b: self.W[np.ix_(a // 2, b // 2)])

    def __call__(self, mask, passive):
        P = np.asarray(passive, dtype=int)
        y = np.zeros(len(self.g))
        if len(P):
            WP = self.W[:, P]
            out = refined_solve(self.system, 2 * P, self.d[P], lambda w: (WP[P] @ w, None))
            if out is None:
                return None
            y[P] = out[0]
        v = self.v0 - self.B[:, P] @ y[P]
        return y, y.copy(), self.R @ v - self.g, _row_scale(self.absR, v, self.g)


def independent_active_set(kkt, g, y0, start, tol: float = 1e-12, max_iter: int | None = None,
                           factored: bool = True, purify: bool = True):
    """Exact finish on the sparse mixed system (26) for contact rows that are linearly dependent (3D overlay
    rows: more vertices than the jump's degrees of freedom, docs/formulation.md §13): Lawson-Hanson on the
    dual, whose passive rows (the rows carrying the forces) stay linearly independent, so that every mixed
    system solved is non-singular whatever the dependence of the rows, structural or numerical.

    ``kkt`` is :func:`~cvxcontact.backends.full.mixed_kkt` (its ``rows`` G, so that r = G x - g is the rows'
    penetration); ``y0`` the forces of an approximate answer (e.g. the interior point's) and ``start`` its
    active rows: the first passive set is a maximal independent subset of them (column-pivoted QR of the
    unit rows weighted by the forces). Each step closes the passive rows P (G_P x = g_P) and

    1. if a passive force is not positive, moves y towards the new forces as far as they stay >= 0 and
       opens the rows that reach 0 (the inner loop of Lawson-Hanson);
    2. else, if some other row penetrates (r_j > ``tol`` S_j, S_j its displacement scale: (|G| |x|)_j + |g_j|
       and its neighbours' displacements, :func:`row_reach`), takes the worst: independent of G_P it joins P;
       dependent (G_j = sum c_i G_i) it has the constant slack sum c_i g_i - g_j whatever x (a non-affine
       gap), and a simplex pivot moves the force along y_j = t, y_P = y_P - t c (x unchanged) until a passive
       row's force reaches 0, which leaves P (a constant slack of rounding: the next row is taken; a row whose
       own force comes out <= 0 on joining P, nearly parallel to some of P, is swapped in by the pivot);
    3. stops when none penetrates: y >= 0 on P, 0 elsewhere, every row feasible to ``tol`` of its scale and
       the passive rows closed, so complementary exactly.

    ``factored`` (and ``kkt`` carrying its ``matrix`` and ``rhs``): the steps are solved on the rows with
    one factorisation of the bodies (:class:`FactoredRows`), and the set where they stop is checked by
    ``kkt`` itself (one sparse LU of (26); its answer is returned, or the steps go on from it); a step whose
    system on the rows is singular (its conditioning is the rows' squared: nearly parallel point rows) is
    ``kkt`` too. Otherwise every step is ``kkt`` (one sparse LU each).

    Returns ((u, phi, y[, taus]), active, steps) with ``active`` the passive rows, or the reason it stopped.
    A passive set too small to hold a body (rigid motion free) makes its system singular: the reason then."""
    G = sp.csr_matrix(kkt.rows)
    g = np.asarray(g, dtype=float)
    A = getattr(kkt, "matrix", None)
    absG = abs(G) if A is None else row_reach(A, G)      # the rows' scales count their neighbours

    def exact(mask, passive):
        res = kkt(mask)
        if res is None:
            return None
        x, z, slack, _ = res
        return x, z, slack, _row_scale(absG, kkt.stack(x), g)

    if not factored or getattr(kkt, "matrix", None) is None:
        return lawson_hanson(G, y0, start, lambda first: exact, None, tol, max_iter, purify, g)
    built = []

    def steps_from(first):
        built.append(factored_rows(kkt.matrix, kkt.rhs, G, g, first))
        return exact if built[0] is None else step      # no anchor holds the bodies (e.g. a translation held
        # by ``hold`` rather than by a row): every step is the sparse LU of (26)

    def step(mask, passive):
        out = built[0](mask, passive)
        if out is None:             # the rows' system (squared conditioning) singular: the sparse LU of (26)
            built[0].fallbacks += 1
            return exact(mask, passive)
        return out

    def verify(mask, passive):
        if built[0] is None:                            # the steps were the sparse LU of (26) already
            return exact(mask, passive)
        out = built[0].exact(mask, passive)
        if out is None:                                 # not at rounding: the sparse LU of (26)
            return exact(mask, passive)
        x, yP = out
        z = np.zeros(len(g))
        z[np.asarray(passive, dtype=int)] = yP
        state = kkt.fields(mask, np.concatenate([x, z[mask]]))[0]
        return state, z, G @ x - g, _row_scale(absG, x, g)

    return lawson_hanson(G, y0, start, steps_from, verify, tol, max_iter, purify, g)


def independent_interface(compliance, v0, g, y0, start, tol: float = 1e-12, max_iter: int | None = None):
    """:func:`independent_active_set` on a condensed interface (:class:`CompliantRows`; ``v0`` the bodies'
    unconstrained Gamma displacements, ``g`` the rows' gaps). Returns (y, active, steps) or the reason it
    stopped."""
    rows = sp.csr_matrix(np.hstack(compliance.rows))
    return lawson_hanson(rows, y0, start, lambda first: CompliantRows(compliance, v0, g), None, tol, max_iter,
                         g=np.asarray(g, dtype=float))


SINGULAR = "the mixed system on the rows carrying the forces is singular"


def _purified(U, norms, y0, cand, chosen):
    """(P, y): the independent rows ``cand[chosen]`` exchanged, row by row, so that the start's forces y0 on the
    rows ``cand`` (>= 0; ``U`` their unit rows, dense) become forces y >= 0 on P alone with the same resultant
    G^T y (an LP crossover: each other row j is written G_j = sum_i c_i G_i over P and its force moved onto P,
    y_P + t c; where a force of P would turn negative first, that row leaves P and j enters). From the
    interior point's forces this starts the iteration near its end, instead of opening the rows of a basis
    whose forces are negative one by one (stacked blocks, 685 rows: 1 step instead of 173)."""
    m = len(norms)
    y = np.zeros(m)
    y[cand] = y0[cand]
    if not len(chosen):
        return [], np.zeros(m)
    basis = list(chosen)                                 # positions in cand
    Q, R = sla.qr(U[basis].T)
    p = len(basis)
    for k in np.setdiff1d(np.arange(len(cand)), chosen):
        j = cand[k]
        if y[j] <= 0:
            continue
        rows = cand[basis]
        c = sla.solve_triangular(R[:p, :p], Q[:, :p].T @ U[k], check_finite=False) * norms[j] / norms[rows]
        yP = y[rows]
        limit = np.where(c < 0, yP / np.where(c < 0, -c, 1.0), np.inf)
        i = int(np.argmin(limit))
        if limit[i] >= y[j]:                             # all of y_j moves onto P
            y[rows] = np.maximum(yP + y[j] * c, 0.0)
            y[j] = 0.0
            continue
        t = limit[i]                                     # row i of P reaches 0 first: it leaves, j enters
        y[rows] = np.maximum(yP + t * c, 0.0)
        y[j] -= t
        y[rows[i]] = 0.0
        Q, R = sla.qr_delete(Q, R, i, which="col", check_finite=False)
        del basis[i]
        Q, R = sla.qr_insert(Q, R, U[k], p - 1, which="col", check_finite=False)
        basis.append(int(k))
    passive = [int(r) for r in cand[basis]]
    out = np.zeros(m)
    out[passive] = y[passive]
    return passive, out


def lawson_hanson(G, y0, start, steps_from, verify=None, tol: float = 1e-12, max_iter: int | None = None,
                  purify: bool = True, g=None):
    """The iteration of :func:`independent_active_set` on the rows G (sparse, m x n) from the forces ``y0`` and
    active rows ``start``. ``steps_from(first)`` gives the step for the first passive set (None: singular):
    ``step(mask, passive)`` returns (state, z, slack, S) of (26) with the rows ``passive`` closed (z their
    forces, slack G x - g of every row, S its scale) or None if singular. ``verify`` (a step, optional)
    re-solves a set where the steps would stop; its values decide (and its state is returned). ``g`` (the
    rows' gaps, optional): a row dependent on the passive rows, G_j = sum c_i G_i, has the slack
    sum c_i g_i - g_j whatever x; where that is not above ``tol`` of its scale the row's computed slack is
    rounding (a node that does not move: its own scale is rounding too), and it is passed over."""
    G = sp.csr_matrix(G)
    m = G.shape[0]
    touched = np.flatnonzero(np.diff(G.tocsc().indptr))
    norms = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())
    held = norms == 0                                   # rows no unknown moves: force 0 (docs §8)
    unit = (sp.diags(1.0 / np.where(held, 1.0, norms)) @ G)[:, touched].tocsr()
    y0 = np.where(held, 0.0, np.maximum(np.asarray(y0, dtype=float), 0.0))
    cand = np.flatnonzero(np.asarray(start, dtype=bool) & ~held)
    weight = np.maximum(y0[cand], 1e-300)                  # the pivots prefer the rows with the larger forces
    U = unit[cand].toarray()                               # the start's unit rows, dense
    chosen = _independent(U.T * (weight / weight.max(initial=1.0))) if len(cand) else np.zeros(0, dtype=int)
    first = cand[chosen]
    passive, y = _purified(U, norms, y0, cand, chosen) if purify else (list(first), np.where(
        np.isin(np.arange(m), first), y0, 0.0))
    step = steps_from(np.asarray(passive, dtype=int))
    if step is None:
        return SINGULAR
    Q, R = sla.qr(unit[passive].toarray().T) if passive else (np.eye(len(touched)), np.zeros((len(touched), 0)))
    max_iter = 3 * m + 20 if max_iter is None else max_iter
    dependent = set()                                   # rows found infeasible: passed over from then on
    settled = set()                                     # dependent rows whose slack is rounding, while P grows

    def next_move(res):
        """What the worst penetrating row off P does: ("add", j) (independent of G_P), ("pivot", j, c)
        (dependent, G_j = sum c_i G_i, a positive constant slack) or ("stop",) when no row penetrates."""
        nonlocal Q, R
        _, _, slack, S = res
        worst = slack / S
        worst[passive] = -np.inf
        worst[held] = -np.inf
        off = list(dependent | settled)
        worst[off] = -np.inf
        p = len(passive)
        for j in np.flatnonzero(worst > tol)[np.argsort(-worst[worst > tol])]:
            col = unit[j].toarray().ravel()
            if p < len(touched):
                Q, R = sla.qr_insert(Q, R, col, p, which="col", check_finite=False)
                if abs(R[p, p]) > DEPENDENT_PIVOT:
                    return "add", int(j), col
                Q, R = sla.qr_delete(Q, R, p, which="col", check_finite=False)
            c = sla.solve_triangular(R[:p, :p], (Q[:, :p].T @ col), check_finite=False) * norms[j] / norms[passive]
            if g is not None:
                constant = float(c @ g[passive] - g[j])
                if constant <= tol * (S[j] + np.abs(c) @ np.abs(g[passive]) + abs(g[j])):
                    settled.add(int(j))
                    continue
            if not (c > 1e-12 * np.abs(c).max(initial=0.0)).any():
                dependent.add(int(j))                   # no passive force can give way: infeasible rows
                continue
            return "pivot", int(j), col, c
        return ("stop",)

    def exchange(j):
        """The pivot of the row j that just joined P (last in P, force 0) as if it depended on the others: its
        own new force came out <= 0, which for an independent row with r_j > 0 only rounding does (a row nearly
        parallel to some of P: G_j = sum c_i G_i + a remainder near DEPENDENT_PIVOT). None if no force of P can
        give way."""
        nonlocal Q, R
        p = len(passive) - 1
        Q, R = sla.qr_delete(Q, R, p, which="col", check_finite=False)
        del passive[p]
        col = unit[j].toarray().ravel()
        c = sla.solve_triangular(R[:p, :p], (Q[:, :p].T @ col), check_finite=False) * norms[j] / norms[passive]
        if not (c > 1e-12 * np.abs(c).max(initial=0.0)).any():
            return None
        return "swap", int(j), col, c

    entered = None                                      # the row that joined P at the last step
    for steps in range(1, max_iter + 1):
        mask = np.zeros(m, dtype=bool)
        mask[passive] = True
        res = step(mask, passive)
        verified = verify is None
        while res is not None:
            if not (res[1][passive] > 0).all():
                move = ("inner",)
                if entered is not None and res[1][entered] <= 0:
                    move = exchange(entered) or ("inner",)
                    if move[0] == "inner":              # it cannot enter: passed over, P as it was
                        dependent.add(entered)
                        move = ("back",)
            else:
                move = next_move(res)
            if move[0] != "stop" or verified:
                break
            res = verify(mask, passive)                 # where the steps would stop: the exact solve decides
            verified = True
        if res is None:
            return SINGULAR
        entered = None
        if move[0] == "back":
            continue
        state, z, slack, _ = res
        zp = z[passive]
        if move[0] == "inner":                          # 1. the inner loop
            yp = y[passive]
            neg = zp <= 0
            ratio = yp[neg] / (yp[neg] - zp[neg])
            alpha = float(np.min(ratio))
            y = y + alpha * (z - y)
            drop = [i for i, row in enumerate(passive) if y[row] <= 0] or \
                   [int(np.flatnonzero(neg)[np.argmin(ratio)])]
            for i in sorted(set(drop), reverse=True):
                Q, R = sla.qr_delete(Q, R, i, which="col", check_finite=False)
                y[passive[i]] = 0.0
                del passive[i]
            settled.clear()
            continue
        if move[0] != "swap":                           # (a swap keeps the forces of P before j joined)
            y = z
        if move[0] == "stop":                           # 3. every row feasible
            return state, mask, steps
        if move[0] == "add":                            # 2. the worst row: independent, it joins P
            passive.append(move[1])
            entered = move[1]
            continue
        _, j, col, c = move                             # or dependent: a pivot (a swap likewise)
        pos = c > 1e-12 * np.abs(c).max(initial=0.0)
        t = y[passive][pos] / c[pos]
        i = int(np.flatnonzero(pos)[np.argmin(t)])
        y[passive] = y[passive] - t.min() * c
        y[j] = t.min()
        y[passive[i]] = 0.0
        Q, R = sla.qr_delete(Q, R, i, which="col", check_finite=False)
        del passive[i]
        Q, R = sla.qr_insert(Q, R, col, len(passive), which="col", check_finite=False)
        passive.append(j)
        settled.clear()
    return "max_iter"
