"""The exact finish on rows that may be linearly dependent (docs/formulation.md §13): active sets kept independent,
Lawson-Hanson on the forces."""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .declined import MAX_ITER, SINGULAR_FORCES
from .rows import (
    DEPENDENT_PIVOT,
    CompliantRows,
    factored_rows,
    independent_rows,
    row_reach,
    row_scale,
)

log = logging.getLogger(__name__)


def _append_column(Q, R, col):
    """The economic QR factors (Q: n x (p+1), R: (p+1) x (p+1)) of [Q R, col] from those of Q R (n x p): only
    the columns held are stored and updated, O(n p) a column (not O(n^2) as with the full n x n Q). Classical
    Gram-Schmidt with one reorthogonalisation; R's new diagonal entry is the norm of col's component outside
    span(Q) (its test against DEPENDENT_PIVOT; a column in the span gives a rounding-sized entry and a
    meaningless last column of Q, which the caller deletes)."""
    n, p = Q.shape[0], R.shape[1]
    if p >= n:                                          # (square Q: no room for another independent column)
        return sla.qr_insert(Q, R, col, p, which="col", check_finite=False)
    Q, R = Q[:, :p], R[:p, :p]          # economic (a square Q left by a delete: R's rows below p are zero)
    r = Q.T @ col
    v = col - Q @ r
    r2 = Q.T @ v
    v -= Q @ r2
    r += r2
    rho = float(np.linalg.norm(v))
    Rn = np.zeros((p + 1, p + 1))
    Rn[:p, :p], Rn[:p, p], Rn[p, p] = R[:p, :p], r, rho
    return np.column_stack([Q, v / rho if rho > 0 else v]), Rn


def _delete_column(Q, R, i):
    """The economic QR factors of Q R without its column ``i``."""
    if R.shape[1] == 1:
        return Q[:, :0], R[:0, :0]
    return sla.qr_delete(Q, R, i, which="col", check_finite=False)


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
        return x, z, slack, row_scale(absG, kkt.stack(x), g)

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
        return state, z, G @ x - g, row_scale(absG, x, g)

    return lawson_hanson(G, y0, start, steps_from, verify, tol, max_iter, purify, g)


def independent_interface(compliance, v0, g, y0, start, tol: float = 1e-12, max_iter: int | None = None):
    """:func:`independent_active_set` on a condensed interface (:class:`CompliantRows`; ``v0`` the bodies'
    unconstrained Gamma displacements, ``g`` the rows' gaps). Returns (y, active, steps) or the reason it
    stopped."""
    return lawson_hanson(compliance.stacked, y0, start, lambda first: CompliantRows(compliance, v0, g), None, tol,
                         max_iter, g=np.asarray(g, dtype=float))


def purified(U, norms, y0, cand, chosen, factors=None, block: int = 64):
    """(P, y): the independent rows ``cand[chosen]`` exchanged, row by row, so that the start's forces y0 on the
    rows ``cand`` (>= 0; ``U`` their unit rows, dense) become forces y >= 0 on P alone with the same resultant
    G^T y (an LP crossover: each other row j is written G_j = sum_i c_i G_i over P and its force moved onto P,
    y_P + t c; where a force of P would turn negative first, that row leaves P and j enters). From the
    interior point's forces this starts the iteration near its end, instead of opening the rows of a basis
    whose forces are negative one by one (stacked blocks, 685 rows: 1 step instead of 173).

    The coefficients c of every row with a force over the first P (a simplex tableau) come from one triangular
    solve with many right-hand sides: on the R of the column-pivoted QR that chose P (``factors`` = (R, piv,
    scale) of :func:`~cvxcontact.backends.finish.rows.independent_columns` on U^T diag(scale)), or else of a QR of
    U_P^T. An exchange changes the basis by an elementary matrix E = I - w e_i^T; their product is kept as
    I + X S (S the rows of the exchanged positions), so that a row's tableau column is c0 + X c0[S], applied to
    ``block`` rows at a time (each exchange also updates the rest of its block): O(p q) for the q rows instead of
    a QR update and a solve per row."""
    m = len(norms)
    y = np.zeros(m)
    y[cand] = y0[cand]
    if not len(chosen):
        return [], np.zeros(m)
    chosen = np.asarray(chosen, dtype=int)
    p = len(chosen)
    rest = np.setdiff1d(np.arange(len(cand)), chosen)
    rest = rest[y[cand[rest]] > 0]                       # (a row with no force moves nothing)
    if factors is None:
        Q, R = sla.qr(U[chosen].T, mode="economic")
        T = sla.solve_triangular(R, Q.T @ U[rest].T, check_finite=False)
    else:
        R, piv, scale = factors                          # U^T diag(scale) [:, piv] = Q R, piv[:p] = chosen
        at = np.empty(len(piv), dtype=int)
        at[piv] = np.arange(len(piv))
        T = sla.solve_triangular(R[:p, :p], R[:p, at[rest]], check_finite=False)
        T *= scale[chosen][:, None] / scale[rest][None, :]
    basis = cand[chosen].copy()                          # the row at each position of the basis
    seq = list(range(p))                                 # the positions in the order rows joined P
    X, S = np.zeros((p, 8)), []                          # the exchanges so far: I + X[:, :len(S)] (.)[S]
    for b0 in range(0, len(rest), block):
        Tb = T[:, b0:b0 + block].copy()
        if S:
            Tb += X[:, :len(S)] @ T[S, b0:b0 + block]
        for jj in range(Tb.shape[1]):
            j = cand[rest[b0 + jj]]
            a = Tb[:, jj]
            c = a * norms[j] / norms[basis]
            yP = y[basis]
            neg = c < 0
            limit = np.full(p, np.inf)
            limit[neg] = yP[neg] / -c[neg]
            order = np.asarray(seq)
            i = int(order[np.argmin(limit[order])])
            if limit[i] >= y[j]:                         # all of y_j moves onto P
                y[basis] = np.maximum(yP + y[j] * c, 0.0)
                y[j] = 0.0
                continue
            t = limit[i]                                 # row i of P reaches 0 first: it leaves, j enters
            y[basis] = np.maximum(yP + t * c, 0.0)
            y[j] -= t
            y[basis[i]] = 0.0
            w = a.copy()
            w[i] -= 1.0
            w /= a[i]
            Tb[:, jj + 1:] -= np.outer(w, Tb[i, jj + 1:])
            n = len(S)
            X[:, :n] -= np.outer(w, X[i, :n])
            if i in S:
                X[:, S.index(i)] -= w
            else:
                if n == X.shape[1]:
                    X = np.hstack([X, np.zeros_like(X)])
                X[:, n] = -w
                S.append(i)
            basis[i] = j
            seq.remove(i)
            seq.append(i)
    passive = [int(basis[i]) for i in seq]
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
    rounding (a node that does not move: its own scale is rounding too), and it is passed over.

    A step may measure dependence in its own metric (:class:`~cvxcontact.backends.finish.rows.CompliantRows`: W's,
    whose conditioning is the rows' squared, so that rows independent by the unit rows' test can give a system
    singular to its cut): ``step.dependent(passive)`` (the positions of P's rows dependent on the others and their
    coefficients) and ``step.coefficients(passive, j)`` (row j's on P). Where its system on P is singular, the rows
    it finds dependent leave P, their forces moved onto the rest; where the row that just joined P made it
    singular, that row is pivoted in as a dependent row (passed over if no force of P can give way). A row found
    so a third time declines (SINGULAR_FORCES), as does a singular system of a step without them."""
    G = sp.csr_matrix(G)
    m = G.shape[0]
    touched = np.flatnonzero(np.diff(G.tocsc().indptr))
    norms = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())
    held = norms == 0                                   # rows no unknown moves: force 0 (docs §8)
    unit = (sp.diags(1.0 / np.where(held, 1.0, norms)) @ G)[:, touched].tocsr()
    y0 = np.where(held, 0.0, np.maximum(np.asarray(y0, dtype=float), 0.0))
    cand = np.flatnonzero(np.asarray(start, dtype=bool) & ~held)
    weight = np.maximum(y0[cand], 1e-300)                  # the pivots prefer the rows with the larger forces
    U = unit[cand]                                         # the start's unit rows on the unknowns they touch
    U = U[:, np.flatnonzero(np.diff(U.tocsc().indptr))]    # (their span lives there)
    scale = weight / weight.max(initial=1.0)
    chosen, Rp, piv = independent_rows(sp.diags(scale) @ U)
    first = cand[chosen]
    passive, y = purified(U, norms, y0, cand, chosen, (Rp, piv, scale)) if purify else (list(first), np.where(
        np.isin(np.arange(m), first), y0, 0.0))
    step = steps_from(np.asarray(passive, dtype=int))
    if step is None:
        return SINGULAR_FORCES
    Q = R = None              # the QR of P's unit rows, formed when a row first penetrates (often never: the
    # crossover's P is the answer's)

    def factors():
        nonlocal Q, R
        if Q is None:
            Q, R = (sla.qr(unit[passive].toarray().T, mode="economic", overwrite_a=True)  # P's columns only,
                    if passive                                          # factorised in place (no copy)
                    else (np.zeros((len(touched), 0)), np.zeros((0, 0))))

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
            factors()
            col = unit[j].toarray().ravel()
            if p < len(touched):
                Q, R = _append_column(Q, R, col)
                if abs(R[p, p]) > DEPENDENT_PIVOT:
                    return "add", int(j), col
                Q, R = _delete_column(Q, R, p)
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
        factors()
        p = len(passive) - 1
        Q, R = _delete_column(Q, R, p)
        del passive[p]
        col = unit[j].toarray().ravel()
        c = sla.solve_triangular(R[:p, :p], (Q[:, :p].T @ col), check_finite=False) * norms[j] / norms[passive]
        if not (c > 1e-12 * np.abs(c).max(initial=0.0)).any():
            return None
        return "swap", int(j), col, c

    def pivot(y, j, col, c):
        """The simplex pivot of the row j dependent on P (G_j = sum c_i G_i): y_j = t, y_P - t c, t as large
        as the forces of P stay >= 0; the row of P whose force reaches 0 leaves P, j joins it. The new y."""
        nonlocal Q, R
        pos = c > 1e-12 * np.abs(c).max(initial=0.0)
        t = y[passive][pos] / c[pos]
        i = int(np.flatnonzero(pos)[np.argmin(t)])
        y = y.copy()
        y[passive] = y[passive] - t.min() * c
        y[j] = t.min()
        y[passive[i]] = 0.0
        Q, R = _delete_column(Q, R, i)
        del passive[i]
        Q, R = _append_column(Q, R, col)
        passive.append(j)
        settled.clear()
        return y

    dropped = {}                                        # rows found dependent in the steps' metric: how often
    unproven = set()                                    # rows passed over in the steps' metric
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
        log.debug("step %d: |P| %d, move %s", steps, len(passive), "singular" if res is None else move[0])
        if res is None and entered is not None and hasattr(step, "coefficients"):
            j, entered = entered, None                  # the row that joined P makes the system singular: it
            factors()                                   # is dependent on P in the steps' own metric (W's), and
            Q, R = _delete_column(Q, R, len(passive) - 1)   # is pivoted in as the steps pivot a dependent row
            del passive[-1]
            dropped[j] = dropped.get(j, 0) + 1
            if dropped[j] > 2:                          # (the same row again and again: the pivots cycle)
                return SINGULAR_FORCES
            c = step.coefficients(passive, j)
            if c is None or not (c > 1e-12 * np.abs(c).max(initial=0.0)).any():
                dependent.add(j)                        # (no force of P can give way: passed over, and checked
                unproven.add(j)                         # at the stop: dependent only to W's cut, not infeasible)
            else:
                y = pivot(y, j, unit[j].toarray().ravel(), c)
            log.debug("row %d dependent on P in the steps' metric: %s", j, "passed over" if j in dependent else
                      "pivoted in")
            continue
        if res is None and hasattr(step, "dependent"):
            out = step.dependent(passive)               # P (the crossover's, or a pivot's) singular in the
            if out is None:                             # steps' metric: its dependent rows leave P, their
                log.debug("singular on the passive rows %s", passive)   # forces carried by the others
                return SINGULAR_FORCES
            drop, C = out
            at = np.asarray(passive, dtype=int)
            keep = np.setdiff1d(np.arange(len(at)), drop)
            for row in at[drop]:
                dropped[row] = dropped.get(row, 0) + 1
            if max(dropped.values()) > 2:               # (the same rows dropped again and again: no progress)
                return SINGULAR_FORCES
            moved = np.maximum(y[at[keep]] + C @ y[at[drop]], 0.0)
            y[at[drop]] = 0.0
            y[at[keep]] = moved
            for i in sorted(drop, reverse=True):
                if Q is not None:
                    Q, R = _delete_column(Q, R, int(i))
                del passive[int(i)]
            settled.clear()
            log.debug("%d rows of P dependent on the others in the steps' metric: left P", len(drop))
            entered = None
            continue
        if res is None:
            log.debug("singular on the passive rows %s", passive)
            return SINGULAR_FORCES
        entered = None
        if move[0] == "back":
            continue
        state, z, _, _ = res
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
                if Q is not None:
                    Q, R = _delete_column(Q, R, i)
                y[passive[i]] = 0.0
                del passive[i]
            settled.clear()
            continue
        if move[0] != "swap":                           # (a swap keeps the forces of P before j joined)
            y = z
        if move[0] == "stop":                           # 3. every row feasible
            at = np.asarray(sorted(unproven), dtype=int)
            if (res[2][at] > tol * res[3][at]).any():   # a row passed over in W's metric penetrates: its
                log.debug("rows passed over in the steps' metric penetrate")   # remainder is not rounding
                return SINGULAR_FORCES
            return state, mask, steps
        if move[0] == "add":                            # 2. the worst row: independent, it joins P
            passive.append(move[1])
            entered = move[1]
            continue
        _, j, col, c = move                             # or dependent: a pivot (a swap likewise)
        y = pivot(y, j, col, c)
    return MAX_ITER


def rows_kkt(K, b, GL, c, solve):
    """``kkt(active)`` of :func:`independent_active_set` for the mixed system [[K, G_A^T], [G_A, 0]] [x; y_A] =
    [b; c_A] (K sparse, the rows GL x <= c), each system solved by ``solve(M, rhs)`` (the solution, or None where
    the system is singular): the state is (x, y)."""
    n = K.shape[0]

    def fields(active, s):
        y = np.zeros(GL.shape[0])
        y[active] = s[n:]
        x = s[:n]
        return (x, y), y, GL @ x - c, float(np.abs(x).max(initial=0.0))

    def kkt(active):
        Ga = GL[active]
        M = sp.bmat([[K, Ga.T], [Ga, None]], format="csc") if Ga.shape[0] else sp.csc_matrix(K)
        s = solve(M, np.concatenate([b, c[active]]))
        return None if s is None else fields(active, s)

    kkt.rows, kkt.matrix, kkt.rhs, kkt.fields = GL, K, b, fields
    kkt.stack = lambda state: state[0]
    return kkt
