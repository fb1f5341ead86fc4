"""Exact finish of the P2 "everywhere" condition by accumulated cuts (docs/formulation.md §8, "The exact finish").

The condition q_s(t) = [u_h nu](t) - g_h(t) <= 0 for t in [0, 1] on every merged segment s is semi-infinite but
each q_s is one quadratic. At a finite set of points (s_p, t_p) it is a set of linear rows
(:func:`~cvxcontact.contact.quadratic.point_rows`), and the contact problem with those rows is the nodal problem
of §7 (an LCP on the interface compliance), solved exactly at every round (:func:`interface_cuts`). The finish

1. starts from the P2 nodes of every segment (t = 0, 1/2, 1) and, if given, the interior point's tangency
   points t* = sqrt(beta2) / (sqrt(beta0) + sqrt(beta2)) of the segments that carry a force;
2. solves the nodal problem at the points exactly;
3. computes on every segment the exact maximiser of q (:func:`~cvxcontact.contact.quadratic.bernstein_argmax`);
   where q_max exceeds ``CUT_TOL`` times the segment's displacement scale, that maximiser becomes a new point
   (a cut: no point is ever removed), and goes back to 2; otherwise it stops.

Every answer is a KKT point of the conic program up to the stopping violation: the point forces y_p >= 0 give
Bernstein duals beta_s = sum_p y_p (1 - t_p)^2, 2 t_p (1 - t_p), t_p^2), a sum of points of the dual cone (on its
boundary, beta1^2 = 4 beta0 beta2), so beta lies in the dual cone exactly; r = B^T beta is the nodal force on X_h,
and beta_s . b_s = sum_p y_p q_s(t_p) = 0 to rounding (complementarity of the rows). Where the forces in X_h are
not unique (the discrete inf-sup condition fails, formulation.md §9; and the point rows outnumber the nodes)
the displacements still are: the finish never asks for unique forces (each round is a non-negative least
squares whose passive rows stay independent, :func:`nnls_warm`).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
import scipy.linalg.blas as blas
import scipy.sparse as sp

from ..contact.bernstein import bernstein_argmax, bernstein_basis, element, point_rows
from .finish.declined import Declined, Stop

__all__ = ["CUT_TOL", "SEED_SPREAD", "nnls_warm", "seed_forces", "seed_points", "point_duals", "point_read_back",
           "accumulate_cuts", "interface_cuts", "segment_scales"]

CUT_TOL = 1e-15
"""Relative violation (of each segment's displacement scale) below which no cut is added: rounding."""

STALL_TOL = 1e-12
"""A violation below this that no longer halves from one round to the next, :data:`STALL_ROUNDS` rounds in a
row, is rounding too (the finish stops)."""

STALL_ROUNDS = 2
"""Rounds in a row without halving the violation before a stall is rounding: one such round also happens while
the cuts still converge (the worst segment changes; measured with the points next to the seeds: stopped at
9e-14 and 3.8e-13, certified 3.7e-7 and 1.2e-6 instead of 4e-8 and 5e-8 on the quickstart at 35x17 and 70x35
cells of P2)."""

LAST_GOOD_TOL = 1e-9
"""A round whose system is singular (new points nearly on old ones: nearly parallel rows) is solved again with
its worst new point alone; if that is singular too, the cuts end with the last solved round if its violation is
below this (of the displacement scale); the checks report what it is (measured: a free sphere's patch on P2
triangles, singular at round 11 after 3.0e-11; against the sphere's own distance, singular at round 9 after
1.5e-10, then the worst point alone went on to 7.4e-12 in three more rounds)."""


def unique_rows(P) -> np.ndarray:
    """Indices of the first occurrence of every distinct row of the sparse ``P`` (rows with at most 3 entries,
    identical floats: the same node reached from two segments)."""
    P = sp.csr_matrix(P)
    P.sort_indices()
    k = P.shape[0]
    width = int(np.diff(P.indptr).max(initial=0))
    cols = np.full((k, max(width, 1)), -1.0)
    vals = np.zeros((k, max(width, 1)))
    for j in range(width):
        has = np.diff(P.indptr) > j
        at = P.indptr[:-1][has] + j
        cols[has, j] = P.indices[at]
        vals[has, j] = P.data[at]
    _, first = np.unique(np.hstack([cols, vals]), axis=0, return_index=True)
    return np.sort(first)


SEED_SPREAD = (1e-4, 1e-3, 1e-2)
"""Distances (in t) on either side of a segment's tangency seed of further starting points (:func:`seed_points`)."""


def seed_points(B, beta=None, force_floor: float = 1e-6, width: int = 3, around=()):
    """(element, point) of the starting points: the P2 nodes of every element of ``B`` (``width`` S, n; segments
    or triangles, :mod:`cvxcontact.contact.bernstein`) once each, plus, with the interior point's Bernstein duals
    ``beta`` (S, width), the tangency point of every element whose force sum(beta_s) exceeds ``force_floor`` of
    the largest and whose cross terms put it off the nodes; on segments, with ``around`` (e.g.
    :data:`SEED_SPREAD`), the points at those distances on either side of each such seed (inside (0, 1)).

    Why ``around``: the interior point's tangency point is close to the exact one t* (measured: within 1e-4 to
    1e-3), but the cuts close in on t* only by halving the interval between two loaded points per round (q, one
    quadratic, vanishes at both and peaks midway): from a node, about 11 rounds to rounding on the README
    scene. Points near the seed start that interval small."""
    el = element(width)
    S = B.shape[0] // width
    k = len(el.nodes)
    seg = np.repeat(np.arange(S), k)
    t = np.tile(el.nodes, (S,) + (1,) * (el.nodes.ndim - 1))
    if beta is not None and S:
        beta = np.maximum(np.asarray(beta, dtype=float), 0.0)
        total = beta.sum(axis=1)
        big = total > force_floor * max(float(total.max(initial=0.0)), np.finfo(float).tiny)
        ts = el.tangency(beta)
        inner = big & (beta[:, el.off].max(axis=1) > force_floor * total) & ~el.near_nodes(ts, 1e-3)
        seg = np.concatenate([seg, np.flatnonzero(inner)])
        t = np.concatenate([t, ts[inner]])
        if width == 3 and len(around):          # after the seeds: seed_forces loads each segment's first one
            offsets = np.concatenate([-np.asarray(around, dtype=float), np.asarray(around, dtype=float)])
            near = (ts[inner][:, None] + offsets[None, :]).ravel()
            at = np.repeat(np.flatnonzero(inner), len(offsets))
            ok = (near > 0) & (near < 1)
            seg = np.concatenate([seg, at[ok]])
            t = np.concatenate([t, near[ok]])
    keep = unique_rows(point_rows(B, seg, t))
    return seg[keep], t[keep]


def seed_forces(segment, t, beta) -> np.ndarray:
    """A warm start of the point forces from an interior point's Bernstein duals ``beta`` (S, w): the whole force
    sum(beta_s) of an element at its first point off the P2 nodes (its tangency seed, :func:`seed_points`),
    else the row sums of its Gram matrix at its vertices (a shared vertex is one point: it takes the share of
    the element it was kept for). Only a start: the first round corrects it."""
    beta = np.maximum(np.asarray(beta, dtype=float), 0.0)
    el = element(beta.shape[1])
    y = np.zeros(len(t))
    inner = np.flatnonzero(~el.near_nodes(t, 0.0))
    has = np.zeros(len(beta), dtype=bool)
    first = np.full(len(beta), -1)
    first[segment[inner[::-1]]] = inner[::-1]
    has[first >= 0] = True
    y[first[has]] = beta[has].sum(axis=1)
    shares = el.vertex_shares(beta)
    for i, vertex in enumerate(el.vertices):
        at_vertex = np.abs(np.asarray(t, dtype=float).reshape(len(t), -1) - np.reshape(vertex, (1, -1))).max(axis=1) == 0
        at = np.flatnonzero(at_vertex & ~has[segment])
        y[at] += shares[segment[at], i]
    return y


def point_duals(S: int, segment, t, y) -> np.ndarray:
    """beta (S, w): the Bernstein duals of point forces ``y`` at (``segment``, ``t``) (module docstring)."""
    phi = bernstein_basis(t)
    beta = np.zeros((S, phi.shape[1]))
    np.add.at(beta, np.asarray(segment, dtype=int), phi * np.asarray(y, dtype=float)[:, None])
    return beta


def point_read_back(B, segment, t, y, carrying) -> tuple[np.ndarray, np.ndarray]:
    """(r, active): the nodal force r = P^T y on X_h of point forces ``y`` at (``segment``, ``t``) of the
    Bernstein map ``B``, and the nodes read by the point rows that carry a force (``carrying``, bool per
    point): the read-back of every finish that answers with point forces."""
    P = point_rows(B, segment, t)
    active = np.zeros(B.shape[1], dtype=bool)
    active[np.unique(P[np.flatnonzero(carrying)].indices)] = True
    return P.T @ np.asarray(y, dtype=float), active


def segment_scales(B, U, width: int = 3) -> np.ndarray:
    """Per element of ``B`` (``width`` S, n), the largest node scale ``U`` among the nodes its rows read."""
    B = sp.csr_matrix(B)
    counts = np.diff(B.indptr)
    node = np.zeros(B.shape[0])
    has = counts > 0                                     # the row maxima of U over each row's stored columns
    node[has] = np.maximum.reduceat(np.asarray(U, dtype=float)[B.indices], B.indptr[:-1][has])
    return node.reshape(-1, width).max(axis=1)


def nodal_slack(slack, size, g, held=None) -> tuple[np.ndarray, np.ndarray]:
    """(slack, scale) of a round's nodal rows as ``solve`` of :func:`accumulate_cuts` returns them: ``size``
    (each row's reach of the displacements plus |g|) floored at 1e-9 of the largest; a row of ``held`` (a
    support's, :attr:`~cvxcontact.discrete.DiscreteProblem.held_rows`) scaled by |g| alone and its slack counted
    only where it penetrates."""
    g = np.abs(g)
    if held is not None:
        size, slack = np.where(held, g, size), np.where(held, np.minimum(slack, 0.0), slack)
    return slack, np.maximum(size, 1e-9 * size.max(initial=0.0) + np.finfo(float).tiny)


def accumulate_cuts(B, solve, segment, t, max_rounds: int = 40, tol: float = CUT_TOL, width: int = 3,
                    departure=None, accept: float | None = None):
    """The loop of the module docstring (stopping at ``tol``, or at ``STALL_TOL`` once the violation no longer
    halves per round). ``solve(P, delta)`` solves the nodal problem with the rows ``P`` (k, n), each point's
    slack P q - delta (``delta`` (k,): the true gap's departure from its interpolant at the points,
    ``departure`` a :class:`~cvxcontact.contact.truegap.GapDeparture`; zero without one) (warm started from
    its previous call: the points of a round are those of the last plus the new ones, appended) and returns
    ``(y, slack, scale, state, active)`` (the point forces, q at the nodes of X_h, each node's displacement
    scale, anything the caller keeps, the rows that carry the forces) or None.
    The new cut on an element is the maximiser of its true slack q_h - delta (``departure.argmax``; the
    quadratic's exact one without a departure). Returns a dict (state, y, segment, t, beta, pairing: the
    point forces' sum y_p delta_p per element, rounds, violation, active) or the reason it stopped (a
    :class:`~cvxcontact.backends.finish.declined.Declined`). ``accept``: after ``max_rounds``, the last round is
    returned if its violation is at most this (a ``tol`` below the rounding floor of the rounds' solves, where the
    violation neither reaches it nor stalls below :data:`STALL_TOL`); None: the rounds decline."""
    S = B.shape[0] // width
    maximum = bernstein_argmax if departure is None else departure.argmax
    offsets = (lambda e, p: np.zeros(len(e))) if departure is None else departure.at
    B = sp.csr_matrix(B)
    segment, t = np.asarray(segment, dtype=int), np.asarray(t, dtype=float)
    last, stalled, good, good_rel = np.inf, 0, None, None    # good_rel: the last good round's violations
    built = {"segment": segment[:0], "t": t[:0], "P": point_rows(B, segment[:0], t[:0])}

    def rows(segment, t):
        """point_rows(B, segment, t), the rows of the points kept from the last call not built again (a round's
        points are the last round's plus new ones, or a prefix of them plus one)."""
        k = min(len(segment), len(built["segment"]))
        moved = (t[:k] != built["t"][:k]).reshape(k, -1).any(axis=1) if k else np.zeros(0, dtype=bool)  # t or (k, 3)
        same = np.flatnonzero((segment[:k] != built["segment"][:k]) | moved)
        k = int(same[0]) if len(same) else k
        P = sp.vstack([built["P"][:k], point_rows(B, segment[k:], t[k:])], format="csr")
        built.update(segment=segment, t=t, P=P)
        return P

    for rounds in range(1, max_rounds + 1):
        out = solve(rows(segment, t), offsets(segment, t))
        if out is None and good is not None and len(segment) > len(good["segment"]) + 1:
            # the new points together made the round singular: the worst one alone
            k = len(good["segment"])
            keep = k + int(np.argmax(good_rel[segment[k:]]))
            segment, t = np.concatenate([segment[:k], segment[keep:keep + 1]]), np.concatenate([t[:k], t[keep:keep + 1]])
            out = solve(rows(segment, t), offsets(segment, t))
        if out is None:
            if good is not None and good["violation"] <= LAST_GOOD_TOL:
                return good                  # nearly parallel new rows made the round singular
            return Declined(Stop.NO_SOLUTION, "the nodal problem at the cut points has no exact solution")
        y, slack, scale, state, active = out
        qmax, tmax = maximum((B @ slack).reshape(-1, width))
        Us = segment_scales(B, scale, width)
        rel = np.maximum(qmax, 0.0) / Us
        worst = float(rel.max(initial=0.0))
        stalled = stalled + 1 if worst <= STALL_TOL and worst > 0.5 * last else 0
        good = dict(state=state, y=y, segment=segment, t=t, beta=point_duals(S, segment, t, y), rounds=rounds,
                    violation=worst, active=active,
                    pairing=np.zeros(S) if departure is None else departure.pairing(S, segment, t, y))
        if worst <= tol or stalled >= STALL_ROUNDS:
            return good
        last, good_rel = worst, rel
        new = np.flatnonzero(rel > tol)
        segment = np.concatenate([segment, new])
        t = np.concatenate([t, tmax[new]])
    if accept is not None and good is not None and good["violation"] <= accept:
        return good
    return Declined(Stop.MAX_ITER, f"the cuts did not reach rounding in {max_rounds} rounds (violation {worst:.1e})")


def nnls_warm(A, b, y0, scale, c=None, tol: float = 1e-15, max_iter: int | None = None, dual=None,
              carry: dict | None = None):
    """Lawson-Hanson non-negative least squares min 1/2 ||A y - b||^2 - c^T y over y >= 0 (``c`` (k,), default 0:
    the plain NNLS) from the warm start ``y0`` (>= 0; its support is the first passive set), with the QR factors
    of the passive columns updated column by column (``scipy.linalg.qr_insert``/``qr_delete``: O(n^2) per change
    instead of a new factorisation). The dual w = A^T (b - A y) + c is the slack of the point rows
    (:func:`interface_cuts`); it stops when w_j <= ``tol`` * ``scale(y)``_j on every column outside the passive
    set. The least squares on the passive set P closes its rows, A_P^T A_P z = A_P^T b + c_P, i.e.
    R z = Q^T b + R^-T c_P. The passive columns stay linearly independent (a column enters only with w_j > 0;
    one that rounding alone made positive while it lies in their span, a vanishing new pivot of R, is left
    out; one in their span, A_j = A_P z, whose slack there c_j - c_P . z (from the constants, not the rounding
    of ``dual``) exceeds :data:`EXCHANGE_TOL` of its scale, a constant no combination of theirs gives, replaces
    one of them, :func:`_exchange`), which is what the point rows need: more points than
    nodes, the forces not unique, the slack unique. ``dual(y)``: the same w computed another way (e.g. cheaper than A^T (A y)).
    ``carry`` (a dict): the passive columns and their QR factors at the return, kept there; a later call whose
    ``A`` has the same first columns (more columns appended: the next round of cuts) and whose warm start is
    this answer starts from them instead of factoring its passive columns again.
    Returns (y, passive) or None."""
    n, k = A.shape
    c = np.zeros(k) if c is None else np.asarray(c, dtype=float)
    y = np.maximum(np.asarray(y0, dtype=float), 0.0)
    support = np.flatnonzero(y > 0)
    if (carry and carry["columns"] <= k and carry["Q"].shape[0] == n and len(carry["passive"]) == len(support)
            and np.array_equal(np.sort(carry["passive"]), support)):
        passive, Q, R = list(carry["passive"]), carry["Q"].copy(order="F"), carry["R"].copy(order="F")
    else:
        passive = support
        if len(passive):    # a warm start's columns may depend on each other (more of them than A has rows)
            _, Rp, piv = sla.qr(A[:, passive] * (y[passive] / y[passive].max()), mode="economic", pivoting=True)
            d = np.abs(np.diag(Rp))
            passive = np.sort(passive[piv[:int(np.sum(d > 1e-12 * d.max(initial=0.0)))]])
        passive = list(passive)
        y[~np.isin(np.arange(k), passive)] = 0.0
        Q, R = sla.qr(A[:, passive]) if passive else (np.eye(n), np.zeros((n, 0)))
    max_iter = 3 * k + 10 if max_iter is None else max_iter

    has_c = bool(c.any())
    trsv = blas.get_blas_funcs("trsv", (A,))

    def least_squares():
        p = len(passive)
        z = np.zeros(k)
        if p:       # one contiguous copy of R's leading block, BLAS triangular solves on it (no LAPACK wrapper)
            Rp = np.asfortranarray(R[:p, :p])
            rhs = Q[:, :p].T @ b
            if has_c:
                rhs = rhs + trsv(Rp, c[passive], trans=1)
            z[passive] = trsv(Rp, rhs)
        return z

    def settle(y):
        """The inner loop: from the feasible y to the least-squares point of the passive set, dropping the
        columns that reach 0 on the way. Returns the new y, or None if it does not settle."""
        nonlocal Q, R
        for _ in range(len(passive) + 1):
            z = least_squares()
            zp = z[passive]
            if (zp > 0).all():
                return z
            yp = y[passive]
            neg = zp <= 0
            step = yp[neg] - zp[neg]            # >= 0 (y >= 0 feasible, z <= 0 there); 0 only where y = z = 0:
            alpha = float(np.min(np.divide(yp[neg], step, out=np.zeros_like(step), where=step > 0)))   # a 0 step
            y = y + alpha * (z - y)
            drop = [i for i, col in enumerate(passive) if y[col] <= 0 or (neg[i] and yp[i] / (yp[i] - zp[i]) <= alpha)]
            for i in reversed(drop):
                Q, R = sla.qr_delete(Q, R, i, which="col", overwrite_qr=True, check_finite=False)
                y[passive[i]] = 0.0
                del passive[i]
        return None

    def done(y):
        if carry is not None:
            carry.update(passive=list(passive), Q=Q, R=R, columns=k)
        return y, np.isin(np.arange(k), passive)

    if passive:                               # the warm start's own least-squares point
        y = settle(y)
        if y is None:
            return None
    S, fresh = scale(y), True
    dependent = np.zeros(k, dtype=bool)
    for _ in range(max_iter):
        w = A.T @ (b - A @ y) + c if dual is None else dual(y)
        out = np.ones(k, dtype=bool)
        out[passive] = False
        cand = np.flatnonzero(out & (w > tol * S))
        if not len(cand):
            if fresh:
                return done(y)
            S, fresh = scale(y), True                 # the scale of the start, refreshed before stopping
            continue
        fresh = False
        cand = cand[~dependent[cand]]
        if not len(cand):
            return done(y)
        p = len(passive)
        cand = cand[np.argsort(-(w[cand] / S[cand]), kind="stable")]      # the largest w_j / S_j first
        # no room (p >= n): every candidate lies in the passive span
        first = len(cand) if p >= n else _first_independent(Q[:, p:], A, cand)
        if first and has_c and w[cand[0]] > EXCHANGE_TOL * S[cand[0]]:
            # the best column lies in the passive span (A_j = A_P z); at the passive least-squares point its
            # slack is w_j = c_j - c_P . z, read from the constants alone (the w of ``dual`` carries the
            # rounding of its own route: a duplicate point row, z = e_k and c_j = c_k, showed w_j = 2.4e-14
            # of its scale on both copies, exchanged back and forth 2400 times). A true gain means the constant
            # differs from the passive ones' combination (a true gap's departure): it replaces one of them
            j = int(cand[0])
            z = _span_coefficients(Q, R, A, len(passive), j)
            if c[j] - c[passive] @ z > EXCHANGE_TOL * S[j]:
                y = _exchange(passive, y, j, z)
                if y is None:
                    return None
                Q, R = sla.qr(A[:, passive])
                y = settle(y)
                if y is None:
                    return None
                continue
        dependent[cand[:first]] = True                # in the span of the passive columns: rounding made w_j > 0
        if first == len(cand):
            continue
        j = int(cand[first])
        Q, R = sla.qr_insert(Q, R, A[:, j].copy(), p, which="col", overwrite_qru=True, check_finite=False)
        if abs(R[p, p]) <= DEPENDENT_TOL * np.linalg.norm(A[:, j]):      # the same test, after the update
            Q, R = sla.qr_delete(Q, R, p, which="col", overwrite_qr=True, check_finite=False)
            dependent[j] = True
            continue
        passive.append(j)
        y = settle(y)
        if y is None:
            return None
        if j not in passive:      # dropped at once: its w_j > 0 was rounding of a column the passive ones
            dependent[j] = True   # nearly span (else it cycles: measured 1370 times on one column)
    return None


DEPENDENT_TOL = 1e-12
"""A column whose part orthogonal to the passive columns is below this fraction of its norm lies in their span
(:func:`nnls_warm`)."""


EXCHANGE_TOL = 1e-2 * STALL_TOL
"""A column in the span of the passive ones whose slack exceeds this fraction of its scale is no rounding: it is
exchanged for a passive column (:func:`nnls_warm`, with a constant ``c``)."""


def _span_coefficients(Q, R, A, p: int, j: int) -> np.ndarray:
    """z with ``A_P z = A_j`` for column ``j`` of ``A`` in the span of the ``p`` passive columns A_P of
    :func:`nnls_warm` (``Q R`` their factors)."""
    return sla.solve_triangular(R[:p, :p], Q[:, :p].T @ A[:, j])


def _exchange(passive: list, y, j: int, z):
    """One exchange step of :func:`nnls_warm` for a column ``j`` in the span of the passive columns
    (``A_P z = A_j``, :func:`_span_coefficients`): along ``y_j += theta``, ``y_P -= theta z`` the residual A y
    does not change and the objective falls by ``theta w_j``; ``theta`` is the largest step keeping ``y >= 0``,
    and the passive column that reaches 0 leaves (``passive`` updated in place; ``j`` appended). None if no
    passive force falls (the point rows have no solution)."""
    p = len(passive)
    yp = y[passive]
    falls = z > 0
    if not falls.any():
        return None
    ratio = np.full(p, np.inf)
    ratio[falls] = yp[falls] / z[falls]
    leave = int(np.argmin(ratio))
    theta = ratio[leave]
    y = y.copy()
    y[passive] = np.maximum(yp - theta * z, 0.0)
    y[passive[leave]] = 0.0
    y[j] = theta
    del passive[leave]
    passive.append(j)
    return y


def _first_independent(Q_out, A, cand) -> int:
    """The position in ``cand`` of the first column of ``A`` with a part outside the passive span (``Q_out``: the
    orthonormal complement of the passive columns, the trailing columns of their full Q) above
    :data:`DEPENDENT_TOL` of its norm; ``len(cand)`` if none. That part's norm is the new pivot |R_pp| that
    inserting the column would give: the test of the insert, on blocks of 1, 8, 64, ... candidates at once
    (O(n (n - p)) a candidate instead of an insert and a delete, O(n^2) each; measured on adaptive P2 meshes:
    20-40 such columns tested per inserted one)."""
    start, size = 0, 1
    while start < len(cand):
        block = cand[start:start + size]
        cols = A[:, block]
        part = np.linalg.norm(Q_out.T @ cols, axis=0)
        ok = np.flatnonzero(part > DEPENDENT_TOL * np.linalg.norm(cols, axis=0))
        if len(ok):
            return start + int(ok[0])
        start, size = start + size, 8 * size
    return len(cand)


def interface_cuts(W, d, g, B, segment, t, timings, max_rounds: int = 40, y0=None, width: int = 3, factors=None,
                   departure=None):
    """:func:`accumulate_cuts` on the interface compliance: ``W`` (n, n) on the nodes of X_h, ``d`` the slack
    there at zero force, ``g`` the gap (scaled). The node scale is |d| + |g| + |W| |r| (the sizes of the
    terms of the slack q = d - W r), floored at 1e-9 of its largest. The state is r = P^T y.

    Each round solves the point rows' LCP y >= 0, P (d - W P^T y) <= 0, complementary, as the equivalent
    non-negative least squares min ||(P L)^T y - L^-1 d|| (W = L L^T, once) by :func:`nnls_warm`, from the
    previous round's forces (the new points at 0; round 1 from ``y0``, e.g. :func:`seed_forces`). Nodes no
    unknown moves (a zero row and column of W: held on
    both sides, or against a fixed obstacle) keep their constant slack d_h = -g_h: they are left out of the
    factor, a point row reading one gets the constant c = P_h d_h (the ``c`` of :func:`nnls_warm`), and a point
    row reading only such nodes carries no force (its slack, a constant, holds: ``_check_reachable``).
    ``departure``: the true gap's (:func:`accumulate_cuts`); its value at a point is one more constant."""
    t0 = time.perf_counter()
    absW = np.abs(W)
    base = np.abs(d) + np.abs(g)
    keep = np.diag(W) > 0
    factor = psd_factor(W, keep, factors)
    L = np.zeros((len(d), factor.F.shape[1]))
    L[keep] = factor.F                                                          # W = L L^T
    Ld = factor.coordinates(d[keep])
    # the part of d outside the range of W (a gap that is no jump of the traces, nodes held on one side): a
    # constant of every slack, like the held nodes' (else the least squares closes the wrong rows)
    d_out = np.zeros(len(d))
    d_out[keep] = d[keep] - factor.F @ Ld
    held = ~keep
    prev = {} if y0 is None else {"y": np.asarray(y0, dtype=float)}
    carry = {}                  # the passive columns' QR factors from one round to the next (nnls_warm)

    def node_scale(r):
        U = base + absW @ np.abs(r)
        return np.maximum(U, 1e-9 * U.max(initial=0.0) + np.finfo(float).tiny)

    def solve(P, delta):
        moving = np.asarray(abs(P[:, keep]).sum(axis=1)).ravel() > 0
        A = np.asarray((P @ L).T)[:, moving]
        absP = abs(P)
        y0 = np.zeros(P.shape[0])
        if "y" in prev:
            y0[:len(prev["y"])] = prev["y"]
        c = (P[:, held] @ d[held] + P[:, keep] @ d_out[keep] - delta)[moving]
        PT = P.T.tocsr()
        out = nnls_warm(A, Ld, y0[moving], lambda ym: (absP @ node_scale(_expand(PT, ym, moving)))[moving], c,
                        dual=lambda ym: (P @ (d - W @ _expand(PT, ym, moving)) - delta)[moving],  # O(n^2), not O(nk)
                        carry=carry)
        if out is None:
            return None
        y = np.zeros(P.shape[0])
        y[moving] = out[0]
        active = np.zeros(P.shape[0], dtype=bool)
        active[moving] = out[1]
        prev["y"] = y
        r = PT @ y
        return y, d - W @ r, node_scale(r), r, active

    out = accumulate_cuts(B, solve, segment, t, max_rounds, width=width, departure=departure)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    return out


PSD_RANK_TOL = 1e-12
"""Eigenvalues of the interface compliance below this fraction of its largest are its null space (the nodes of
X_h outnumber the jump's dofs: the overlay of a 3D surface)."""


class PsdFactor:
    """A factor W = F F^T of a positive semidefinite ``W`` (n, n), computed once: Cholesky where W is definite
    (the nodes of X_h at most the jump's dofs: 2D); else its eigenvectors with eigenvalues above
    :data:`PSD_RANK_TOL` of the largest, scaled by their square roots (n, rank): the forces on dependent rows
    are then not unique, the slack is."""

    def __init__(self, W):
        W = np.asarray(W, dtype=float)
        try:
            self.F, self.cholesky = sla.cholesky(W, lower=True), True
        except np.linalg.LinAlgError:
            w, V = np.linalg.eigh(W)
            big = w > PSD_RANK_TOL * max(float(w.max(initial=0.0)), np.finfo(float).tiny)
            self.V, self.w, self.cholesky = V[:, big], w[big], False
            self.F = self.V * np.sqrt(self.w)

    def coordinates(self, d) -> np.ndarray:
        """c with F c = d (``d`` in the range of W): F^-1 d, or F^+ d."""
        if self.cholesky:
            return sla.solve_triangular(self.F, d, lower=True)
        return (self.V.T @ d) / np.sqrt(self.w)

    def solve(self, h) -> np.ndarray:
        """z with W z = h (the least-norm solution where W is singular)."""
        if self.cholesky:
            return sla.cho_solve((self.F, True), h)
        return self.V @ ((self.V.T @ h) / self.w)


def psd_factor(W, keep, cache=None) -> PsdFactor:
    """The :class:`PsdFactor` of W restricted to the nodes ``keep``, from ``cache`` (a dict, e.g. kept by the
    reduction of the problem: the same W serves the cuts and the certificate) when it has it."""
    key = np.asarray(keep, dtype=bool).tobytes()
    if cache is not None and key in cache:
        return cache[key]
    out = PsdFactor(W[np.ix_(keep, keep)])
    if cache is not None:
        cache[key] = out
    return out


def _expand(PT, ym, moving):
    """r = P^T y from the forces ``ym`` of the ``moving`` point rows (``PT`` = P^T)."""
    y = np.zeros(PT.shape[1])
    y[moving] = ym
    return PT @ y


def dual_cone_point(beta) -> np.ndarray:
    """beta (S, w) moved into the dual cone (segments: each entry clipped, beta1 lowered to 2 sqrt(beta0 beta2);
    triangles: :meth:`~cvxcontact.contact.bernstein.Triangle.dual_cone_point`): an interior point's duals lie
    in it only to its tolerance."""
    beta = np.asarray(beta, dtype=float)
    return element(beta.shape[1]).dual_cone_point(beta)


def energy_bound(W, d, B, beta, held=None, max_doublings: int = 20, factors=None, departure=None, pairing=None):
    """A rigorous bound (scaled energy norm) on ||v - u*||, v the answer of the Bernstein duals ``beta`` and u*
    the exact solution of the conic problem, on the interface compliance (docs/checks.md, "The certified bound").

    The dual point beta (in the dual cone: :func:`dual_cone_point`) has the primal point v(beta) = Sigma^-1
    (f - J^T r), r = B^T beta: q = d - W r at the nodes of X_h (the back-substitution, so the residual of (26)
    is that of one solve). v is made exactly feasible by a uniform push apart, q' = q - tau h with h = 1 on the
    nodes some unknown moves (h = J delta, delta = Sigma^-1 J^T W^-1 h, ||delta||^2 = h^T W^-1 h; on a segment
    whose nodes all move, q drops by tau everywhere), tau the largest violation max_s max_t q_s(t)^+ (doubled
    until every segment holds, for segments next to a held node). The duality gap of (v', beta) is

        gap = -beta . B q' + 1/2 tau^2 h^T W^-1 h      (J(v') - D(beta) >= 1/2 ||v' - u*||^2)

    so ||v - u*|| <= tau sqrt(h^T W^-1 h) + sqrt(2 gap). Returns (bound, tau, gap), or (inf, tau, nan) if no
    push makes v feasible (a violated segment whose nodes no unknown moves).

    Against a curved obstacle's true gap (``departure``, :class:`~cvxcontact.contact.truegap.GapDeparture`) the
    slack is q - delta: tau and the feasibility of v' are its maxima, and the dual point is the point forces
    whose Bernstein duals are ``beta``, their pairing with the slack beta . b' - ``pairing`` (S,) (the forces'
    sum y_p delta_p per element, :func:`accumulate_cuts`): the same bound for the semi-infinite problem."""
    B = sp.csr_matrix(B)
    held = np.zeros(len(d), dtype=bool) if held is None else np.asarray(held, dtype=bool)
    r = B.T @ np.asarray(beta, dtype=float).ravel()
    q = d - W @ r
    width = np.asarray(beta).shape[1]
    maximum = bernstein_argmax if departure is None else departure.argmax
    offset = 0.0 if pairing is None else float(np.sum(pairing))
    qmax, _ = maximum((B @ q).reshape(-1, width))
    tau = float(np.maximum(qmax, 0.0).max(initial=0.0))
    keep = ~held
    h = keep.astype(float)
    hw = 0.0
    if tau > 0:
        # the push delta = Sigma^-1 J^T z, z = W^+ h: J delta = W z (= h where h lies in the range of W, as
        # with a definite W; else its projection, whose feasibility the loop below checks), ||delta||^2 = h . z
        z = np.zeros(len(d))
        z[keep] = psd_factor(W, keep, factors).solve(h[keep])
        h = W @ z
        hw = float(z @ h)
    for _ in range(max_doublings):
        b = (B @ (q - tau * h)).reshape(-1, width)
        if (maximum(b)[0] <= 0).all():
            gap = max(float(-(np.asarray(beta).ravel() @ b.ravel()) + offset) + 0.5 * tau ** 2 * hw, 0.0)
            return tau * np.sqrt(hw) + np.sqrt(2 * gap), tau, gap
        tau *= 2
    return np.inf, tau, np.nan
