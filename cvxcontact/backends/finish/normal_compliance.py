"""The exact finish of a normal compliance law (docs/formulation.md §7, §12): Newton on the interface
equation of the law, dense or on the sparse mixed system."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from .declined import CYCLE, MAX_ITER, STALL, Declined, Stop
from .lcp import SIGN_TOL, row_scales, solve_lcp


def rounding_floor(K, x, unsolved, sizes=None):
    """The residual of a Newton step's system below which no step can bring it, row by row (scaled units):

        floor_i = n_i eps max((|K| |x|)_i, sizes_i) + |unsolved_i|

    with K the step's matrix (the tangent), n_i the non-zeros of its row i, eps the unit round-off of doubles and
    ``unsolved`` the residual the step's own solve left in that row, where that is the rounding of the solve
    (:func:`solved_rounding`: a step not solved to rounding is no floor). The first term bounds the rounding of a
    row's residual evaluated at x (a sum of n_i terms of size (|K| |x|)_i, each at least as large as the row's
    stress terms; x itself is known to eps |x| only), which grows with the tangent's conditioning through |K| |x|
    (measured, circle into a Hencky block: max_i eps (|K| |x|)_i / S_i = 9.4e-11 at 26k unknowns, 3.4e-10 at 58k,
    6.5e-10 at 103k, S the row's scale; the steps stop at 1.6 to 7.8 eps (|K| |x|)_i, n_i ~ 18); docs/formulation.md
    §19, "Where the Newton steps stop"). ``sizes`` (optional, per row): the sizes of the terms the computed
    residual adds up where they are not the assembled |K| |x| (a non-quadratic energy sums its terms point by
    point, :meth:`~cvxcontact.discrete.energy.BulkEnergy.rounding`: a large rigid translation's strains cancel
    within each point, which the assembled entries of K do not show)."""
    import scipy.sparse as sps

    K = sps.csr_matrix(K)
    size = abs(K) @ np.abs(x)
    if sizes is not None:
        size = np.maximum(size, sizes)
    return np.diff(K.indptr) * np.finfo(float).eps * size + unsolved


SOLVED = 100.0
"""How many times the rounding of a step's own system, n_i eps (|K| |dx| + |G_L^T| |z_L| + |b|)_i, the residual its
solve left may count in the floor of :func:`rounding_floor` (:func:`solved_rounding`); a residual beyond it is
credited only up to it, so that the steps go on until (26) itself holds. Measured, the direct solves, refined
(PARDISO or SuperLU; the circle pressed into a Hencky block, P1 up to 320 x 120 cells, P2 128 x 48, fast and
full route; the tests of the Hencky routes and tests/test_newton_floor.py's chains): at most 5.1 times that
rounding; a singular system (the Hencky layer in an open gap of tests/test_wellposed.py, refused after the solve)
2.1e3; the rows scrambled under their step's solve (a P2 pair of non-matching meshes): 1e13 and more."""


def solved_rounding(K, GT, dx, z, b):
    """The residual a step's solve left in each row, |K dx + G_L^T z_L - b|_i, credited only up to :data:`SOLVED`
    times the rounding of that row of the step's system, n_i eps (|K| |dx| + |G_L^T| |z_L| + |b|)_i (n_i the
    non-zeros of K's row i): the ``unsolved`` of :func:`rounding_floor`. ``GT`` (n, m) the rows' transpose, ``z``
    (m,) the step's reactions (0 off L). Scaled units."""
    import scipy.sparse as sps

    K, GT = sps.csr_matrix(K), sps.csr_matrix(GT)
    left = np.abs(K @ dx + GT @ z - b)
    terms = abs(K) @ np.abs(dx) + abs(GT) @ np.abs(z) + np.abs(b)
    return np.minimum(left, SOLVED * np.diff(K.indptr) * np.finfo(float).eps * terms)


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

    Returns ``(y, z, at_limit, route)`` or a :class:`~cvxcontact.backends.finish.declined.Declined`: W singular
    on the rows (``Stop.SINGULAR``), a held row beyond its limit (``Stop.NO_SOLUTION``), or steps that do not
    settle with the signs holding to ``SIGN_TOL`` of each row's scale (:func:`row_scales`; ``Stop.CYCLE``,
    ``Stop.MAX_ITER``).
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
        return Declined(Stop.NO_SOLUTION, "a row no unknown moves is beyond its limit: no force can close it")
    if (d <= ell).all() and not np.any(w * law.pressure(d)):
        # nothing is pressed at zero force (e.g. no load): y = z = 0 is the solution, exactly; Newton steps
        # from an interior point would stop at rounding around it (1e-36), which no force scale can judge
        return np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), "semismooth Newton"
    keep = ~held
    H = np.zeros((n, n))
    try:                 # cho_factor raises LinAlgError where W is not positive definite (it issues no warning)
        H[np.ix_(keep, keep)] = sla.cho_solve(sla.cho_factor(W[np.ix_(keep, keep)]), np.eye(int(keep.sum())))
    except (np.linalg.LinAlgError, ValueError):
        return Declined(Stop.SINGULAR, "the interface compliance is singular on the rows")
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
                return Declined(Stop.SINGULAR, "a Newton step's system on the free rows is singular")
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
                rhs = (d - r - W @ (w * law.pressure(r)))[at]
                z[at] = sla.cho_solve(sla.cho_factor(W[np.ix_(at, at)]), rhs)
            except (np.linalg.LinAlgError, ValueError):
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
            return Declined(Stop.CYCLE, "the limit rows' active sets cycle")
    return Declined(Stop.MAX_ITER, "the semismooth Newton steps on the interface did not settle")


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
    :class:`~cvxcontact.contact.laws.RowLaws` (scaled). Returns ``(y, z, at_limit, route)`` or
    :func:`solve_lcp`'s :class:`~cvxcontact.backends.finish.declined.Declined`."""
    W = np.asarray(W, dtype=float)
    k = np.broadcast_to(np.asarray(law.stiffness, dtype=float), (len(d),))
    w = np.asarray(weights, dtype=float)
    on = k > 0
    keep = ~on | (w > 0)             # a compliance row of weight 0 (a P2 face vertex) carries no force: y = 0
    soft = np.zeros(len(d))
    soft[on & keep] = 1.0 / (w[on & keep] * k[on & keep])
    out = solve_lcp((W + np.diag(soft))[np.ix_(keep, keep)], d[keep])
    if isinstance(out, Declined):
        return out
    y, active, route = np.zeros(len(d)), np.zeros(len(d), dtype=bool), out[2]
    y[keep], active[keep] = out[0], out[1]
    z = np.where(on, 0.0, y)
    return y, z, active & ~on, route


def solve_sparse_compliance(operator, G, g, weights, law, x0, active=None, max_iter=50, solve=None, early=None,
                            armijo=0.0, line=0, secant=0):
    """Exact finish of the contact rows' law on the sparse mixed system (26), for scenes that cannot be
    condensed body by body (a body held by the contact only, force-controlled obstacles; docs/formulation.md
    §10-§12) and for a non-quadratic bulk energy (the paper's nonlinear A, docs/materials.md "Hencky"), whose
    (26) is nonlinear in the displacements. Scaled units.

    ``operator`` (:class:`~cvxcontact.backends.mixed.MixedEnergy`) gives the residual of (26) without the
    contact forces, ``gradient(x)`` (A x - F for a linear material: A the bodies' quasi-definite blocks
    [[Kuu, Kup], [Kup^T, -Kpp]] and a zero block for the translations tau of force-controlled obstacles, F the
    loads [f; -q; F_obstacle]), its ``tangent(x)``, its ``value`` L(x) (the energy) and ``magnitude(x)``; ``G``
    (m, n) sparse the contact rows (E [u_nu] and R tau), ``g`` (m,) their gaps, so that r = G x - g is the
    penetration; ``weights`` w (m,) the rows' lumped lengths and ``law`` a per-row
    :class:`~cvxcontact.contact.laws.RowLaws` (Signorini rows: k = 0, l = 0; all of them for the Signorini
    problem). The system is

        grad L(x) + G^T y = 0,   y = w p(r) + z,   r <= l,  z >= 0,  z (r - l) = 0   (z = 0 off the limited rows)

    the optimality system of the energy L plus sum_a w_a Phi_a(r_a) subject to r <= l. Solved by Newton steps:
    with T the tangent at x^k, D = diag(w p'(r^k)) and L the rows held at their limit, each step solves the
    sparse system (the sparsity of the linear one)

        [[T + G^T D G, G_L^T], [G_L, 0]] [dx; z_L] = [-grad L(x^k) - G^T w p(r^k); l_L - r^k_L]

    (a semismooth Newton step: p' and a Hencky tangent jump where a row opens or a point yields; exact in one
    step for a linear material and m = 1 once the penetrating rows are right), damped by backtracking on the
    energy L(x) + sum_a w_a Phi_a(r_a) (strongly convex with a Lipschitz gradient on the rows L closed, which
    every step after the first of a set L keeps, as it keeps the Gauss rows: that first step is taken whole) plus
    the closed rows' term z_L . (r_L - l_L) with the step's reactions (the Lagrangian, of slope -dx . K dx along
    the step: a descent direction also where an inexact solve left r_L = l_L unmet, as a Krylov step does),
    inside primal-dual active-set steps on the limited rows (a row joins L where z_a > 0 is needed or
    r_a > l_a, leaves it where z_a < 0). ``x0`` the start (e.g. the interior point's answer), ``active`` (bool,
    m) the starting L (default r(x0) >= l on the limited rows). ``solve(K, b, at)``: the sparse solve of each step's
    system, given by its block K = T + G^T D G and the closed rows ``at`` (L) of G, [dx; z_L] or None if it is
    singular (default: :func:`~cvxcontact.backends.full.solve_mixed` on the matrix above; a ``solve`` with an
    attribute ``distance`` is told there the relative residual before the step, 0 at the first). ``early``: once a full
    step brings the relative residual below it, the signs of the limit rows are checked and a set they reject is
    left at once, without converging on it (None: only a converged set is checked; the last set is always
    converged, so the answer is the same, in fewer steps when the start's set is wrong); a set so reached twice
    turns it off (signs read before convergence can alternate between two sets). ``armijo``: the sufficient
    decrease c of the backtracking, L(x + t dx) <= L(x) + c t grad . dx (beside the rounding of L); 0: no
    increase only (enough from an interior point, near the answer). ``line``: the most regula falsi steps on the
    energy's slope along the step, phi'(t) = (grad L + G^T w p)(x + t dx) . dx, before the backtracking: where the
    full step overshoots the energy's minimum on its line (phi'(1) > :data:`LINE_SLOPE` |phi'(0)|; phi is convex,
    phi' increasing) t is moved to where |phi'(t)| <= LINE_SLOPE |phi'(0)|, the backtracking then starting from
    that t (0: from t = 1, halving only). ``secant``: the steps 2 to ``secant`` + 1 (after the start's) take the
    secant stiffness for T (``operator.tangent(x, secant=True)``; positive definite, so still a descent direction
    of the energy, which the backtracking globalises): from the elastic predictor, where the points that yield have
    their elastic strains, a Kacanov step spreads the plastic zone in one step where the tangent's overshoot is
    undone over several (0: Newton's tangent at every step). Each step solves for the correction dx (its
    right side the residual of (26) itself), so that the solve's error scales with the step, not with x.

    Returns ``(x, y, z, at_limit, steps, history)`` with the stationarity residual at rounding (after a full step,
    each row's residual within 1e-3 ``SIGN_TOL`` of its scale ``magnitude(x)`` + |G^T| |y| or within the step's
    :func:`rounding_floor`, which grows with the tangent's conditioning: no caller sets a floor) and the signs to
    ``SIGN_TOL``; ``history`` the largest relative residual after each step (the convergence to read). A full step
    that reaches that floor is taken whole (the energy's change drowns in its rounding there). Otherwise a
    :class:`~cvxcontact.backends.finish.declined.Declined`: ``SINGULAR_FORCES`` if a step's system is singular
    (``solve`` returned None: its factorisation's pivots or its backward error), its ``rows`` the closed rows
    and those whose law's stiffness enters K (e.g. a body held by the contact whose rows all left it: the
    caller's well-posedness check names it), ``CYCLE``, ``STALL`` or ``MAX_ITER`` if the steps do not settle.
    """
    import scipy.sparse as sps

    if solve is None:
        from ..full import solve_mixed  # (full imports nothing from here)

        def solve(K, b, at):
            GL = G[at]
            return solve_mixed(sps.bmat([[K, GL.T], [GL, None]], format="csc") if at.any() else K.tocsc(), b)

    G = sps.csr_matrix(G, copy=True)      # own canonical copy: abs(G) below would sort the caller's arrays in place
    G.sum_duplicates()
    g, w = (np.asarray(a, dtype=float) for a in (g, weights))
    m = G.shape[0]
    ell = np.asarray(law.penetration_limit, dtype=float)
    # a row no unknown moves (a zero row of G: a held node) keeps r = -g; its limit reaction, which (26) would
    # not determine and which would make the step matrix singular, is 0 (docs/formulation.md §8, "Held nodes")
    limited = np.isfinite(ell) & (np.diff(G.indptr) > 0)
    x = np.asarray(x0, dtype=float).copy()
    at = limited & ((G @ x - g) >= ell) if active is None else np.asarray(active, dtype=bool) & limited
    absG = abs(G)
    tiny = np.finfo(float).tiny
    rounding = getattr(operator, "rounding", lambda x: None)     # an operator's own sizes (optional)

    def energy(x):
        return operator.value(x) + float(w @ law.energy(G @ x - g))

    def force(x):
        """The gradient of :func:`energy` (the residual of (26) without the limit reactions)."""
        return operator.gradient(x) + G.T @ (w * law.pressure(G @ x - g))

    def step(x, at):
        """The Newton step (dx, z), its matrix K and the residual its solve left in the rows of x (the floor)."""
        r = G @ x - g
        D = w * law.derivative(r)
        T = operator.tangent(x, secant=True) if 0 < steps <= secant else operator.tangent(x)
        K = T + G.T @ sps.diags(D) @ G if D.any() else T      # (T itself: its sparsity, explicit zeros kept,
        #                                                      the same every step for the tangent solver)
        b = -(operator.gradient(x) + G.T @ (w * law.pressure(r)))     # the residual itself: a correction
        b = np.concatenate([b, (ell - r)[at]]) if at.any() else b
        if hasattr(solve, "distance"):          # how far from the answer: the last step's relative residual
            solve.distance = history[-1] if history else 0.0
        s = solve(K, b, at)
        if s is None:                 # singular (the solve's pivots or its backward error): the rows carrying
            return Declined(Stop.SINGULAR_FORCES, rows=at | (D > 0))   # forces leave a motion free
        dx, zL = s[:len(x)], np.zeros(m)
        zL[at] = s[len(x):]
        # the residual the solve left is rounding only where it solved to rounding; an inexact (Krylov) step's
        # forcing term is no floor: only the rows' own rounding then (the next steps bring it down). Even a solve
        # called exact is credited no more than the rounding of its own rows (:func:`solved_rounding`): a wrong
        # or loose solve's residual is no floor either (it once stopped the steps at 0.3, unconverged)
        unsolved = np.zeros(len(x))
        if getattr(solve, "exact", True):
            unsolved = solved_rounding(K, G.T, dx, zL, b[:len(x)])
        return dx, zL, K, unsolved

    def residual(x, z):
        """The residual of (26) at x with the reactions z, its rows' scales and the contact forces y."""
        y = w * law.pressure(G @ x - g) + z
        S = operator.magnitude(x) + absG.T @ np.abs(y)
        return operator.gradient(x) + G.T @ y, np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), tiny)), y

    steps, seen, left, history = 0, set(), set(), []
    for _ in range(max_iter):
        z, first, hasty = np.zeros(m), True, False
        for _ in range(max_iter):                       # damped Newton with the limit rows L closed
            out = step(x, at)
            steps += 1
            if isinstance(out, Declined):
                return out
            dx, z, K, unsolved = out
            # converged: after a full step each row's residual at the rounding of its own terms, or at the floor
            # of the step solved; such a step is taken whole (L's change drowns in its rounding there)
            trial = x + dx
            res, S, y = residual(trial, z)
            floor = rounding_floor(K, trial, unsolved, rounding(trial))
            settled = bool((np.abs(res) <= 1e-3 * SIGN_TOL * S + floor).all())
            t = 1.0
            if not first and not settled:
                # the merit: the Lagrangian with the step's reactions (the docstring); on the energy alone a step
                # restoring r_L = l_L after an inexact solve can rise against the reactions: the backtracking then
                # stalled (t ~ 1e-5 at every step, 40 x 12 indented block, GMRES on SuperLU's factors). Where
                # r_L = l_L holds the added term is rounding: the energy's test.
                GL, zL = G[at], z[at]
                c0, cz = float(zL @ (GL @ x - g[at] - ell[at])), float(zL @ (GL @ dx))    # the term, its slope
                f0 = energy(x) + c0
                slope = 0.0 if not (armijo or line) else min(float(force(x) @ dx) + cz, 0.0)
                if line and slope < 0.0:
                    t = _line_minimum(lambda t, x=x, dx=dx, cz=cz: float(force(x + t * dx) @ dx) + cz, slope, line)
                slope = slope if armijo else 0.0
                while t > 1e-12 and (energy(x + t * dx) + c0 + t * cz
                                     > f0 + armijo * t * slope + 1e-14 * max(abs(f0), tiny)):
                    t *= 0.5
                if t < 1.0:
                    trial = x + t * dx
                    res, S, y = residual(trial, z)
            first = False
            x = trial
            ratio = float((np.abs(res) / S).max(initial=0.0))
            history.append(ratio)
            if settled:
                break
            if early is not None and t == 1.0 and ratio <= early and _rejected(G, g, x, y, z, at, limited, ell):
                hasty = True                            # this set is wrong: leave it now (the outer check below)
                break
            if np.abs(t * dx).max(initial=0.0) <= 1e-15 * max(np.abs(x).max(initial=0.0), tiny):
                return STALL
        else:
            return MAX_ITER
        r = G @ x - g
        y = w * law.pressure(r) + z
        neg, over = _signs(G, g, x, y, z, at, limited, ell)
        if not neg.any() and not over.any():
            return x, y, z, at, steps, history
        if hasty:           # signs read before convergence: a set left so before is not left so again (they can
            new = (at & ~neg) | over            # alternate between two sets); from there every set is converged
            if new.tobytes() in left:
                early = None
            else:
                left.add(new.tobytes())
                at = new
            continue
        at = _next_limit_set(at, neg, over, seen)
        if at is None:
            return CYCLE
    return MAX_ITER


LINE_SLOPE = 0.1
"""The slope along a Newton step, relative to its start's, at which :func:`solve_sparse_compliance`'s ``line``
search stops: |phi'(t)| <= LINE_SLOPE |phi'(0)| (a full step within it is kept whole: near the answer, where
Newton's steps are full, phi'(1) is of the order of the step's square)."""


def _line_minimum(slope, start, steps) -> float:
    """The step length t in (0, 1] along a Newton step: 1 if the slope of the convex phi there, ``slope(1)``, is
    at most :data:`LINE_SLOPE` |phi'(0)| (``start`` < 0), else the regula falsi (Illinois) estimate of phi's minimum
    in (0, 1) after at most ``steps`` slopes, stopped once |phi'(t)| <= LINE_SLOPE |phi'(0)|."""
    lo, hi, dlo, dhi = 0.0, 1.0, start, slope(1.0)
    if not np.isfinite(dhi):
        return 1.0                      # (the backtracking halves from there)
    if dhi <= LINE_SLOPE * abs(start):
        return 1.0
    t, side = 1.0, 0
    for _ in range(steps):
        t = lo - dlo * (hi - lo) / (dhi - dlo)
        dt = slope(t)
        if not np.isfinite(dt) or abs(dt) <= LINE_SLOPE * abs(start):
            break
        if dt < 0.0:
            lo, dlo = t, dt
            if side < 0:
                dhi *= 0.5              # Illinois: the end kept twice counts half
            side = -1
        else:
            hi, dhi = t, dt
            if side > 0:
                dlo *= 0.5
            side = 1
    return t


def _signs(G, g, x, y, z, at, limited, ell):
    """(neg, over) of the Newton steps of :func:`solve_sparse_compliance`: the rows of L whose reaction is negative
    and the limited rows off L beyond their limit, each to ``SIGN_TOL`` of its scale."""
    tiny = np.finfo(float).tiny
    scale = abs(G) @ np.abs(x) + np.abs(g)
    scale = np.maximum(scale, 1e-14 * max(float(scale.max(initial=0.0)), tiny))
    Y = max(float(np.abs(y).max(initial=0.0)), tiny)
    return at & (z < -SIGN_TOL * Y), limited & ~at & (G @ x - g - ell > SIGN_TOL * scale)


def _rejected(G, g, x, y, z, at, limited, ell) -> bool:
    """Whether the signs of :func:`_signs` reject the set ``at`` at ``x``."""
    neg, over = _signs(G, g, x, y, z, at, limited, ell)
    return bool(neg.any() or over.any())
