"""The exact finish of the P2 "everywhere" condition at tangency points: Newton on the KKT system of the
condition written through each touching element's maximum (docs/formulation.md §18).

Where a curved rigid obstacle under force control touches a P2 face at one point inside an element (a disc or
sphere whose contact zone is smaller than an element), the obstacle's sideways position is set by the tangency:
the quadratic q of the jump minus the gap reaches 0 at a point L* with zero slope there. Point rows at fixed
points (the accumulated cuts, :mod:`cvxcontact.backends.cuts`) cannot express that: with one active point
row the obstacle's balance along the tangent asks for a force along the row's direction that the point row
does not have, and the round's mixed system is singular.

Here the condition on a touching element (or one of its edges, on triangles) is its maximum itself,

    m(Q) = max { L^T Q L : L >= 0 on the sub-simplex I, sum(L) = 1 } <= 0,

smooth where Q is negative definite on the sub-simplex's tangent plane (the maximiser L* inside): with the
bordered system Q L* = m 1, 1^T L* = 1, its gradient is dm = L*^T dQ L* (the point row at L*, envelope) and its
second derivative d2m = -2 (dQ L*)^T T (T^T Q T)^-1 T^T (dQ L*) >= 0 (T a basis of {1^T v = 0}). Vertex
contacts (and whole elements in contact) stay linear nodal rows. Newton on

    A x + G_v^T y + sum_c mu_c grad m_c = F,   G_v x = g_v,   m_c(x) = 0

with the Hessian A + sum_c mu_c H_c: the curvature terms mu_c H_c carry the stiffness that the obstacle's
tangential translation lacks. The active structure comes from the interior point's Bernstein duals and is
corrected in an outer loop (a negative multiplier leaves, a violated element enters, a maximiser leaving its
sub-simplex moves to the sub-face). Quadratic convergence: from the interior point's answer (~1e-8) two to
four steps reach rounding.

A run of P2 segments in contact along their whole length (a body that conforms to the other, a whole line in
contact) carries its force as a measure on each segment: its nodal forces are read through the dual cone, a shared
vertex's force split between its segments (:func:`_conforming`), not by their signs (a vertex of such a run may carry
a negative nodal force: read as a sign test, the structure dropped and re-added it round after round).

A node or limit row dropped for its negative force, re-added by a violation and dropped a second time: the
structures wander, and the outer loop declines there (:attr:`~cvxcontact.backends.finish.declined.Stop.CYCLE`)
instead of running its remaining rounds to the same decline (the P2 Hencky block of benchmarks/p2_cones_hencky.py
at nx = 48: declined in round 3, 5.5 s CPU, against all 10 rounds, the last to Newton's 40 steps, 14.4 s; the
scenes the tests finish drop no row twice).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contact.bernstein import bernstein_argmax, element
from .cuts import point_duals, point_read_back, segment_scales
from .factor import lu as dense_or_sparse_lu
from .finish.declined import Declined, Stop
from .finish.rows import row_scale

__all__ = ["node_rows", "tangency_newton"]

NEWTON_TOL = 1e-14
"""Relative size of a Newton step at which the iteration stops (the residuals are then at rounding)."""
STALL_TOL = 1e-10
"""Below this relative step, a step that no longer shrinks by 4 ends the iteration (rounding's floor)."""
RESIDUAL_STALL_TOL = 1e-12
"""Below this relative KKT residual, a residual that no longer shrinks by 4 ends the iteration: two tangency
points that nearly coincide (a curved obstacle touching on both sides of a vertex, where the P2 jump has a kink)
have nearly parallel rows, and the direction that splits their forces (and the obstacle's sideways position with
it) is then set only to the system's conditioning (measured: the steps stall at 7.7e-7 of the largest unknown,
the residual at 1e-13, the circle beside a vertex of tests/test_tangency.py)."""

ACCEPT_TOL = 1e-7
"""The largest relative KKT residual at which a step that stopped (:data:`NEWTON_TOL`, :data:`STALL_TOL`,
:data:`RESIDUAL_STALL_TOL`) is taken for convergence, each block over the sizes of the terms it adds up
(:func:`_residual`); above it the Newton declines (:attr:`~cvxcontact.backends.finish.declined.Stop.STALL`). A step
at rounding says nothing by itself: on a Newton system singular to rounding the unknowns' step is rounding while
the multipliers' step, and the residual, are O(1) (measured: the force-controlled P2 punch on the condensed
system, 10 unknowns, a tangency row of curvature 1/rounding: residual 0.11 of the load at a step of 5.5e-16 under
the Sandybridge kernels). The answers taken measure at most 3.8e-10 (a large circle pressed into P2 triangles,
where the steps stall at the system's conditioning) in tests/test_tangency.py, test_forced_condensed.py and
test_mixed_cuts_factored.py under the SkylakeX, Haswell, Prescott, Sandybridge and Nehalem kernels."""


DEPENDENT_TOL = 1e-6
"""A tangency row whose component outside the span of the rows before it (vertex rows, then the tangencies by
decreasing force; unit rows) is below this is dependent on them and leaves the system (its multiplier 0): two
tangencies of an element and its edge that both touch, one of them with no force, make the rows dependent
up to rounding and the multipliers free along that direction (measured: a sphere pressed into P2 triangles,
16 tangencies, smallest singular value 5e-9 of the largest; Newton's multipliers swung in sign and it did
not converge). Its own condition is then held by the others' (checked with every element's maximum)."""


def _dependent(C_fixed, rows, mu) -> list[int]:
    """Indices into ``rows`` (the tangency rows, sparse (1, n) each, multipliers ``mu``) of those dependent on
    the rows ``C_fixed`` and the tangencies of larger force (:data:`DEPENDENT_TOL`)."""
    if not rows:
        return []
    order = np.argsort(-np.asarray(mu, dtype=float), kind="stable")
    M = sp.vstack([C_fixed] + [rows[i] for i in order]).toarray()
    norms = np.linalg.norm(M, axis=1)
    M = M / np.where(norms > 0, norms, 1.0)[:, None]
    R = np.linalg.qr(M.T, mode="r")
    d = np.abs(np.diag(R))[C_fixed.shape[0]:]
    return [int(order[j]) for j in np.flatnonzero(d < DEPENDENT_TOL)]


def _sub_basis(m: int) -> np.ndarray:
    """(m, m-1): an orthonormal basis of {v in R^m : sum(v) = 0}."""
    V = np.linalg.qr(np.column_stack([np.ones(m), np.eye(m)[:, :m - 1]]))[0]
    return V[:, 1:]


class _Element:
    """The Bernstein coefficients of one element as affine functions of x: b = D x - d (D (w, n) sparse)."""

    def __init__(self, shape, D, d):
        self.shape, self.D, self.d = shape, sp.csr_matrix(D), np.asarray(d, dtype=float)

    def coefficients(self, x):
        return self.D @ x - self.d


def _residual(terms, G, force, C, lam, x, r1, r2, c0) -> float:
    """The relative KKT residual of the Newton system: the balance r1 = A x + G^T ``force`` + C^T ``lam`` - F over
    the sizes of its terms, ``terms`` + |G^T| |force| + |C^T| |lam| (``terms``: |A| |x| + |F|, or the sizes of the
    terms of a non-quadratic energy's gradient, :meth:`~cvxcontact.backends.mixed.MixedEnergy.magnitude`, in place
    of A x - F), and the rows' residual r2 = C x - c0 over
    |C| |x| + |c0| (:func:`~cvxcontact.backends.finish.rows.row_scale`), each block's largest over its largest
    scale (normwise: a row whose own terms are small still carries the rounding of the unknowns it reads).
    Scales that add the terms up do not vanish where their sum cancels (closed rows whose nodes move with the
    obstacle: |C x| and |c0| are then 0 to rounding, and the residual over them read 1.0 at rounding)."""
    tiny = np.finfo(float).tiny
    s1 = row_scale(abs(sp.hstack([G.T, C.T]).tocsr()), np.r_[force, lam], terms)
    s2 = row_scale(abs(C), x, c0) if C.shape[0] else np.ones(1)
    return max(float(np.abs(r1).max(initial=0.0)) / max(float(s1.max(initial=0.0)), tiny),
               float(np.abs(r2).max(initial=0.0)) / max(float(s2.max(initial=0.0)), tiny))


def element_maximum(shape, b, I, delta=None, start=None, flat: float = 0.0):
    """(m, L*, M): the maximum of q over the sub-simplex ``I`` of an element with coefficients ``b``, its
    maximiser (full barycentric), and M = T (T^T Q_II T)^-1 T^T (the second derivative's matrix, module
    docstring); None where Q_II is not negative definite on the tangent plane, or is so by the signs of
    eigenvalues at rounding only (coefficients that are 0 to rounding along a whole segment: the systems below
    are then singular or not finite under some BLAS kernels, found under OpenBLAS's Prescott ones).

    ``flat``: the size below which a curvature is rounding (the element's coefficients' terms times the
    finish's tolerance): q's Hessian on the tangent plane must be negative definite by more than that. A
    segment whose coefficients are rounding (a flat face pressed by a plane) is then flat, a contact of the
    whole sub-simplex, not a tangency whose curvature 1/rounding would make the Newton system singular to
    rounding (measured: coefficients 5.6e-17 against terms of 3.9, the force-controlled P2 punch condensed,
    under the Sandybridge kernels)."""
    try:
        out = _stationary(shape, b, I, delta, start, flat)
    except np.linalg.LinAlgError:
        return None
    if out is not None and not (np.isfinite(out[0]) and np.isfinite(out[1]).all() and np.isfinite(out[2]).all()):
        return None
    return out


def _stationary(shape, b, I, delta=None, start=None, flat: float = 0.0):
    """:func:`element_maximum` without its guard against singular systems.

    ``delta(L)`` (L (k,) a full barycentric point): a curved obstacle's departure of its gap from the P2
    interpolant and its gradient and Hessian in L (:meth:`~cvxcontact.contact.truegap.GapDeparture.curvature`,
    in closed form): then q = L^T Q L - delta(L), the maximiser by Newton on its stationarity on I (quadratic
    convergence) from ``start`` (the last maximiser; else the quadratic's own where it is concave, else I's
    centre), and the condition is that q's Hessian on the tangent plane, T^T Q T - T^T D2delta T / 2, is
    negative definite there (not the quadratic's alone: where the body conforms to the obstacle, L^T Q L is
    flat or convex and the obstacle's curvature makes the maximum)."""
    Q = shape.gram(np.asarray(b, dtype=float)[None, :])[0]
    k = len(Q)
    I = list(I)
    QI = Q[np.ix_(I, I)]
    T = _sub_basis(len(I))
    H = T.T @ QI @ T
    m = len(I)
    concave = not np.any(np.linalg.eigvalsh(H) >= -flat)
    if delta is None and not concave:
        return None
    L = np.zeros(k)
    if delta is not None and start is not None:
        L[I] = np.asarray(start, dtype=float)[I] / np.sum(np.asarray(start, dtype=float)[I])
    elif concave:
        bordered = np.block([[QI, -np.ones((m, 1))], [np.ones((1, m)), np.zeros((1, 1))]])
        sol = np.linalg.solve(bordered, np.r_[np.zeros(m), 1.0])
        L[I] = sol[:m]
        if delta is None:
            return sol[m], L, T @ np.linalg.solve(H, T.T)
    else:
        L[I] = 1.0 / m
    TT = np.zeros((k, m - 1))
    TT[I] = T
    last, back = np.inf, None
    for _ in range(60):
        _, gd, hd = delta(L)                                       # in L; along the tangent coordinates z:
        Hs = H - 0.5 * (TT.T @ hd @ TT)                            # half the Hessian of q on the plane
        if np.any(np.linalg.eigvalsh(Hs) >= -flat):
            if back is None or np.abs(back[1]).max(initial=0.0) <= 1e-15:
                return None
            # a step that overshot into where q is not concave (a Hessian whose quadratic part is 0 to the
            # interior point's accuracy: the step ~ 1/curvature of the departure alone): half of it
            back = (back[0], 0.5 * back[1])
            L = back[0] + TT @ back[1]
            continue
        grad = T.T @ (2 * QI @ L[I]) - TT.T @ gd                   # of q = L^T Q L - delta along T
        step = -np.linalg.solve(2 * Hs, grad)
        back = (L, step)
        L = L + TT @ step
        size = np.abs(step).max(initial=0.0)
        if size <= 1e-15 or (size <= 1e-8 and size >= 0.5 * last):   # rounding: no longer shrinking
            break
        last = size
    _, gd, hd = delta(L)
    Hs = H - 0.5 * (TT.T @ hd @ TT)
    if np.any(np.linalg.eigvalsh(Hs) >= -flat):
        return None
    q = float(L @ Q @ L - delta(L)[0])
    return q, L, T @ np.linalg.solve(Hs, T.T)


def node_rows(B, w: int) -> np.ndarray:
    """(S, w): the row read at each P2 node of every element of the Bernstein map ``B`` (w S, N) (the values at
    the nodes are inv(to_bernstein) B_s, unit rows); -1 where a node's value is not one row's."""
    shape = element(w)
    V = (sp.kron(sp.eye(B.shape[0] // w), np.linalg.inv(shape.to_bernstein)) @ B).tocsr()
    V.eliminate_zeros()
    V.data[np.abs(V.data) < 1e-12] = 0.0
    V.eliminate_zeros()
    counts = np.diff(V.indptr)
    cells = np.full(V.shape[0], -1)
    one = counts == 1
    cells[one] = V.indices[V.indptr[:-1][one]]
    return cells.reshape(-1, w)


def _conforming(cells, force: dict, tol: float):
    """The runs of P2 segments in contact along their whole length (rows at their three nodes, ``cells`` (S, 3))
    with the nodal forces ``force`` (node -> multiplier of its row) as point forces, and the nodes they cover.

    On a segment in full contact the condition's force is a measure on the segment, not one per node: its
    Bernstein duals beta = T^-T f of the nodal forces f = (f0, f_mid, f1) (T ``to_bernstein``: beta0 = f0 +
    f_mid / 4, beta1 = f_mid / 2, beta2 = f1 + f_mid / 4) must lie in the dual cone beta0, beta2 >= 0,
    beta1 >= 0, beta1^2 <= 4 beta0 beta2 (docs/formulation.md §8), and a vertex's force may be negative (a point
    force at t in (1/2, 1) reads (1 - t) (1 - 2 t) < 0 at the start vertex: a body that conforms along segments
    carries such forces, and a sign test on the vertex rows drops and re-adds them in turn). A vertex shared by
    two segments of a run splits its force between them: along the run, each segment takes at its far vertex the
    least force its cone asks for (f1 >= f_mid^2 / (16 beta0) - f_mid / 4, smaller as beta0 grows), the next
    segment the rest (a loop: the start vertex's whole force to the first segment, none to the last; sound, not
    the widest split; a vertex of three or more segments: no run through it). Returns (points, covered): point
    forces (segment, t, y >= 0) reproducing the nodal forces of every run whose forces lie in the cone (up to
    ``tol``), and the nodes of those runs."""
    # a degenerate element (one row at its three nodes: a nodal pair's row beside the cones) is that row alone,
    # no run: its force read at three nodes counted it twice (measured: the (26) of a Tresca pair under "sigma1"
    # beside the cones missed its balance by half that row's force)
    whole = [s for s in range(len(cells)) if min(cells[s]) >= 0 and len(set(cells[s].tolist())) == len(cells[s])
             and all(int(c) in force for c in cells[s])]
    ends: dict[int, list] = {}
    for s in whole:
        for c in (cells[s, 0], cells[s, 2]):
            ends.setdefault(int(c), []).append(s)
    branch = {v for v, ss in ends.items() if len(ss) > 2}     # a vertex of three segments: no run (sign test)
    if branch:
        whole = [s for s in whole if int(cells[s, 0]) not in branch and int(cells[s, 2]) not in branch]
        ends = {}
        for s in whole:
            for c in (cells[s, 0], cells[s, 2]):
                ends.setdefault(int(c), []).append(s)
    points, covered, seen = [], set(), set()
    starts = [v for v, ss in ends.items() if len(ss) == 1] + list(ends)      # path ends first (a loop: anywhere)
    for v0 in starts:
        if all(s in seen for s in ends[v0]):
            continue
        run, v = [], v0                                  # (segment, its node at the run's start) along the run
        while True:
            nxt = [s for s in ends[v] if s not in seen]
            if not nxt:
                break
            s = nxt[0]
            seen.add(s)
            run.append((s, v))
            v = int(cells[s, 2] if cells[s, 0] == v else cells[s, 0])
        closed = v == v0                                 # a loop: v0's force went to the first segment
        pts, p, ok = [], force[v0], True
        for i, (s, a) in enumerate(run):
            far = int(cells[s, 2] if cells[s, 0] == a else cells[s, 0])
            fm = force[int(cells[s, 1])]
            b0 = p + fm / 4
            if fm < -tol or b0 < -tol:
                ok = False
                break
            fm, b0 = max(fm, 0.0), max(b0, 0.0)
            need = fm * fm / (16 * b0) - fm / 4 if b0 > 0 else (0.0 if fm <= tol else np.inf)
            r = (0.0 if closed else force[far]) if i == len(run) - 1 else need
            if r < need - tol:
                ok = False
                break
            b2, b1 = max(r + fm / 4, 0.0), fm / 2
            b1 = min(b1, 2 * np.sqrt(b0 * b2))          # within ``tol`` of the cone: onto it
            if b1 > 0:                                   # Z = a e0 e0^T + c e1 e1^T + y L L^T, L = (1 - t, t)
                t = np.sqrt(b2) / (np.sqrt(b0) + np.sqrt(b2))
                y = b1 / (2 * t * (1 - t))
                b0, b2 = max(b0 - y * (1 - t) ** 2, 0.0), max(b2 - y * t * t, 0.0)
                pts.append((s, t if cells[s, 0] == a else 1 - t, y))
            pts += [(s, 0.0 if cells[s, 0] == a else 1.0, b0), (s, 1.0 if cells[s, 0] == a else 0.0, b2)]
            p = force[far] - r
        if ok:
            points += pts
            covered.update(int(c) for s, _ in run for c in cells[s])
    return points, covered


def tangency_newton(kkt, B, g, beta, x0, *, cone_gap=None, law=None, weights=None, limit=None, limit_start=None,
                    held=None, force_floor: float = 1e-6, force_scale: float = 0.0, tol: float = 1e-11,
                    max_steps: int = 40, max_rounds: int = 10, departure=None, points=None, energy=None,
                    spread: float = 1e-3):
    """The exact finish of the module docstring on the sparse mixed system ``kkt``
    (:func:`cvxcontact.backends.full.mixed_kkt` on the contact rows: ``kkt.rows`` G (N, n), ``kkt.matrix`` A,
    ``kkt.rhs`` F; r = G x - ``g``), the Bernstein map ``B`` (w S, N) of the cones on those rows (q <= 0 for
    q = B (G x - ``cone_gap``), default ``g``), from the interior point's Bernstein duals ``beta`` (S, w) and
    stacked unknowns ``x0`` (n,).

    Optionally the rest of a mixed program (docs/formulation.md §10, "P2"): the compliance energy
    sum_a w_a Phi_a(r_a) of a scaled ``law`` (:class:`~cvxcontact.contact.laws.RowLaws`) with ``weights`` on
    its compliant rows (semismooth: its Hessian w p'(r) G^T G where r > 0, re-read every step), and linear rows
    r_a <= ``limit``_a where the limit is finite (active at the start where ``limit_start``). ``held`` rows (no
    unknown moves them) carry no linear row (their law's force w p(r) is kept: it moves nothing).

    Returns a dict (x, segment, t, y: the cones' point forces, beta, z: the limit rows' multipliers (N,),
    active: rows carrying force, rounds, violation, nodal: the cones' force B^T beta on the rows) or the
    reason it stopped (a :class:`~cvxcontact.backends.finish.declined.Declined`). An element carries a force at the start where its Bernstein duals exceed
    ``force_floor`` of the largest force (theirs, or ``force_scale``: the largest of the rest).

    ``departure``: a curved obstacle's true gap on the cones' elements
    (:class:`~cvxcontact.contact.truegap.GapDeparture`, scaled): each element's maximum is then that of the true
    slack q_h - delta (:func:`element_maximum`), and the answer carries ``pairing`` (the point forces' sum y_p delta_p
    per element).

    ``points``: (segment, t, y) point forces to start from instead of the Bernstein duals' structure (the
    accumulated cuts' answer, :mod:`cvxcontact.backends.cuts`): every point carrying a force is a tangency on
    the sub-simplex of its nonzero coordinates (a vertex row at a vertex); the points of one sub-simplex are
    one tangency (the cuts close in on a tangency from both sides). Where one element holds several points
    (an interior and an edge tangency) its Bernstein duals read as a spread force; the points do not.

    ``energy``: a non-quadratic bulk energy (the paper's nonlinear A, e.g. Hencky; docs/formulation.md §19): the
    :class:`~cvxcontact.backends.mixed.MixedEnergy` of the bodies on the unknowns of ``kkt``, whose gradient
    replaces A x - F and whose tangent (its Hessian at the step's x) replaces A, so that the steps are Newton's on
    the nonlinear (26) with the cones' structure fixed (``kkt``'s matrix and loads are then not read).

    ``spread``: an element's Bernstein duals read as a spread force (its whole face in contact) where the second
    eigenvalue of their dual Gram exceeds this fraction of the first, else as a point force at L*. Where rounds
    from a start that read spread forces wander, they run again with every element read as a point force."""
    args = {"cone_gap": cone_gap, "law": law, "weights": weights, "limit": limit, "limit_start": limit_start,
            "held": held, "force_floor": force_floor, "force_scale": force_scale, "tol": tol, "max_steps": max_steps,
            "max_rounds": max_rounds, "departure": departure, "points": points, "energy": energy}
    G = sp.csr_matrix(kkt.rows)
    A, F = (None, None) if energy is not None else (sp.csr_matrix(kkt.matrix), np.asarray(kkt.rhs, dtype=float))
    B = sp.csr_matrix(B)
    N, n = G.shape
    g = np.asarray(g, dtype=float)
    cone_gap = g if cone_gap is None else np.asarray(cone_gap, dtype=float)
    held = np.zeros(N, dtype=bool) if held is None else np.asarray(held, dtype=bool)
    w = np.shape(beta)[1]
    shape = element(w)
    cells = node_rows(B, w)
    S = len(cells)
    k = 2 if w == 3 else 3
    corner = [0, 2] if w == 3 else [0, 1, 2]          # the cells' columns of the vertices
    D_all = (B @ G).tocsr()
    d_all = B @ cone_gap
    elem = lambda s: _Element(shape, D_all[w * s:w * s + w], d_all[w * s:w * s + w])
    compliant = np.zeros(N, dtype=bool) if law is None else np.asarray(law.rows, dtype=bool)   # held: G_a = 0
    lim = np.full(N, np.inf) if limit is None else np.where(held, np.inf, np.asarray(limit, dtype=float))
    limited = np.isfinite(lim)
    beta = np.maximum(np.asarray(beta, dtype=float), 0.0)
    total = beta.sum(axis=1)
    kk = np.zeros(N) if law is None else np.asarray(law.stiffness, dtype=float)
    mm = np.ones(N) if law is None else np.asarray(law.exponent, dtype=float)
    wt = np.zeros(N) if weights is None else np.asarray(weights, dtype=float)
    # the force scale: the cones' and ``force_scale`` (the rest of the program's: cones that carry nothing
    # next to a compliance law have Bernstein duals at the interior point's noise, ~1e-16, which relative to
    # themselves read as contact everywhere)
    fmax = max(float(total.max(initial=0.0)), float(force_scale))
    big = np.flatnonzero(total > force_floor * max(fmax, np.finfo(float).tiny))
    # the starting structure: a vertex row per node, a tangency constraint per (element, sub-simplex)
    vertices: dict[int, float] = {}
    tangencies: dict[tuple, tuple] = {}
    where: dict[tuple, np.ndarray] = {}             # each tangency's last maximiser (Newton's start on a curved gap)
    dependent: set[tuple] = set()                   # tangencies left out: their rows depend on the others'
    limits: dict[int, float] = {int(a): 0.0 for a in np.flatnonzero(limited & (False if limit_start is None
                                                                               else np.asarray(limit_start)))}
    Z = shape.dual_gram(beta[big])

    def whole(s, I):
        """The sub-simplex I of element s in contact: rows at its P2 nodes (q = 0 at all of them: q = 0 on it)."""
        cols = [corner[i] for i in I] + ([1] if w == 3 and len(I) == 2 else
                                         [c for i, j, c in getattr(shape, "edges", ()) if i in I and j in I])
        for node in cells[s, cols]:
            if node >= 0 and not held[node]:
                vertices.setdefault(int(node), 0.0)

    def add(s, I, force, L=None):
        nodes = tuple(sorted({int(cells[s, corner[i]]) for i in I}))
        if min(nodes) < 0:
            return
        if len(nodes) == 1:
            if not held[nodes[0]]:
                vertices[nodes[0]] = vertices.get(nodes[0], 0.0) + force
        elif any(v in vertices for v in nodes):
            # a strictly concave q cannot touch 0 inside I and at a vertex of I: the contact covers I
            whole(s, I)
        elif nodes in dependent:
            return
        elif nodes not in tangencies:
            tangencies[nodes] = (int(s), tuple(I), force)
            if L is not None:
                where[nodes] = np.where(np.isin(np.arange(len(L)), I), L, 0.0)
        else:                                     # the same tangency seen again (from the element beside an
            s0, I0, f0 = tangencies[nodes]        # edge, or a second point of the cuts): its forces add up
            tangencies[nodes] = (s0, I0, f0 + force)

    seeds = []
    if points is not None:                        # the cuts' points: each its own seed, the largest first
        seg_p, t_p, y_p = (np.asarray(a, dtype=float) for a in points)
        seg_p = seg_p.astype(int)
        L_p = t_p if w == 6 else np.column_stack([1 - t_p, t_p])
        on_p = np.flatnonzero(y_p > force_floor * max(float(y_p.max(initial=0.0)), np.finfo(float).tiny))
        for i in on_p[np.argsort(-y_p[on_p], kind="stable")]:
            add(int(seg_p[i]), tuple(int(j) for j in np.flatnonzero(L_p[i] > 1e-6)), float(y_p[i]), L_p[i])
        big, Z = big[:0], Z[:0]
    for s, Zs in zip(big, Z):
        ev, V = np.linalg.eigh(Zs)
        if ev[-2] > spread * ev[-1]:              # a spread force: in contact on the face its diagonal covers
            d = np.diag(Zs)
            whole(s, tuple(int(i) for i in np.flatnonzero(d > 1e-3 * d.max())))
        else:                                     # a point force: at L* (Z's leading eigenvector)
            seeds.append((s, np.abs(V[:, -1]) / np.abs(V[:, -1]).sum()))
    for s, L in seeds:
        # coordinates above 1e-6: a point read as a vertex that is a tangency beside it (1e-3 of the element
        # away) starts from one vertex row, singular under force control; a tangency that is a vertex contact
        # leaves its sub-simplex and moves to the vertex in the outer loop
        add(s, tuple(int(i) for i in np.flatnonzero(L > 1e-6)), float(total[s]), L)
    read_spread = len(seeds) < len(big)

    def wanders(message: str):
        """A cycle from a start that read spread forces: the rounds again from the other reading (every element a
        point force at L*). The reading is a threshold on the interior point's duals, which an inexact interior
        point (the last bits of the BLAS kernels) puts on the other side; the cycle is then the start's, not the
        problem's (the P2 sphere: whole faces at every node, the true contact at points inside the faces)."""
        if read_spread:
            return tangency_newton(kkt, B, g, beta, x0, **args, spread=np.inf)
        return Declined(Stop.CYCLE, message)

    x = np.asarray(x0, dtype=float).copy()
    dropped: set[tuple[bool, int]] = set()           # the vertex and limit rows dropped once (a negative force)
    for rounds in range(1, max_rounds + 1):
        while touching := [c for c in tangencies if any(v in vertices for v in c)]:
            for c in touching:                    # a vertex row added beside a tangency: the contact covers I
                s, I, _ = tangencies.pop(c)       # (a concave q touching 0 inside I and at its vertex: add())
                whole(s, I)
        vnodes = np.array(sorted(vertices), dtype=int)
        lrows = np.array(sorted(limits), dtype=int)
        tkeys = list(tangencies)
        Gv, gv = G[vnodes], cone_gap[vnodes]
        Gl, gl = G[lrows], g[lrows] + lim[lrows]
        lam_lin = np.r_[[vertices[v] for v in vnodes], [limits[a] for a in lrows]]
        mu = np.array([tangencies[c][2] for c in tkeys])
        why, pen, last, last_res, flat, drop = None, None, np.inf, np.inf, [], []
        for step_no in range(max_steps):
            rows, vals, hess = [], [], sp.csr_matrix((n, n))
            points = []
            flats = tol * segment_scales(B, abs(G) @ np.abs(x) + np.abs(g) + np.abs(cone_gap), w) if tkeys else None
            for c, m_c in zip(tkeys, mu):
                s, I, _ = tangencies[c]
                el = elem(s)
                out = element_maximum(shape, el.coefficients(x), I,
                               None if departure is None else (lambda L, s=s: departure.curvature(s, L)),
                               start=where.get(c), flat=flats[s])
                if out is None:              # q flat or convex along I: the contact covers I (next round)
                    flat.append((c, s, I))   # all of them at once: a conforming body flattens many segments
                    continue
                m, L, M = out
                where[c] = L
                phi = shape.basis(L[None, :] if w == 6 else L[None, 1])[0]
                J = sp.vstack([sum(L[j] * el.D[shape.index(i, j)] for j in I) for i in I]).tocsr()
                hess = hess + m_c * (-2.0) * (J.T @ sp.csr_matrix(M) @ J)
                rows.append(sp.csr_matrix(phi[None, :]) @ el.D)
                vals.append(m)
                points.append((s, L))
            if flat:
                break
            if step_no == 0:
                drop = _dependent(sp.vstack([Gv, Gl]), rows, mu)
                if drop:
                    break
            r = G @ x - g
            on = compliant & (r > 0)
            rp = np.where(on, r, 0.0)
            force = wt * kk * rp ** mm                                   # w p(r)
            stiff = np.where(on, wt * kk * mm * np.where(on, rp, 1.0) ** (mm - 1.0), 0.0)
            C = sp.vstack([Gv, Gl] + rows).tocsr() if len(vnodes) + len(lrows) + len(rows) else \
                sp.csr_matrix((0, n))
            lam = np.r_[lam_lin, mu]
            if energy is None:
                At, terms = A, abs(A) @ np.abs(x) + np.abs(F)
                r1 = A @ x + G.T @ force + C.T @ lam - F
            else:                                # Newton on the nonlinear (26): its gradient and tangent at x
                At, terms = energy.tangent(x), energy.magnitude(x)
                r1 = energy.gradient(x) + G.T @ force + C.T @ lam
            r2 = np.r_[Gv @ x - gv, Gl @ x - gl, np.array(vals)]
            K = sp.bmat([[At + hess + G.T @ sp.diags(stiff) @ G, C.T], [C, None]], format="csc") if C.shape[0] \
                else (At + hess + G.T @ sp.diags(stiff) @ G).tocsc()
            if C.shape[0] > n:   # a whole merged line in contact: K structurally singular (SuperLU crashed on it)
                why = Declined(Stop.SINGULAR, f"the Newton system is singular: {C.shape[0]} contact rows on {n} "
                                              "unknowns")
                break
            try:
                dz = dense_or_sparse_lu(K).solve(-np.r_[r1, r2])
            except RuntimeError:
                why = Declined(Stop.SINGULAR, "the Newton system is singular")
                break
            if not np.all(np.isfinite(dz)):
                why = Declined(Stop.SINGULAR, "the Newton system is singular")
                break
            # the residual before the step, relative to its terms' sizes
            res = _residual(terms, G, force, C, lam, x, r1, r2, np.r_[gv, gl, (C[C.shape[0] - len(rows):] @ x
                                                                             - np.array(vals, dtype=float))])
            x, lam = x + dz[:n], lam + dz[n:]
            lam_lin, mu = lam[:len(lam_lin)], lam[len(lam_lin):]
            step = np.abs(dz[:n]).max(initial=0.0) / max(np.abs(x).max(initial=0.0), 1e-300)
            # converged: a step at rounding, or a small one that no longer shrinks quadratically (the floor of
            # the system's conditioning, measured 1e-14 .. 1e-13 with k = 1e14 Pa/m^2, m = 2), or a residual at
            # its floor that no longer shrinks (:data:`RESIDUAL_STALL_TOL`)
            small = step <= NEWTON_TOL or (step <= STALL_TOL and step > 0.25 * last) or \
                (res <= RESIDUAL_STALL_TOL and res > 0.25 * last_res)
            last, last_res = step, res
            if small and pen is not None and np.array_equal(on, pen):
                if res > ACCEPT_TOL:
                    why = Declined(Stop.STALL, f"Newton at the tangency points stopped on a step of {step:.1e} "
                                               f"with its residual at {res:.1e} (above {ACCEPT_TOL:.0e})")
                break
            pen = on
        else:
            why = Declined(Stop.MAX_ITER, f"Newton did not converge in {max_steps} steps")
        if why:
            return why
        if flat:
            for c, s, I in flat:
                del tangencies[c]
                whole(s, I)
            continue
        if drop:
            for i in drop:
                dependent.add(tkeys[i])
                del tangencies[tkeys[i]]
            continue
        # the structure: signs of the multipliers, maximisers inside their sub-simplex, feasibility elsewhere
        y, zl = lam_lin[:len(vnodes)], lam_lin[len(vnodes):]
        fscale = max(np.abs(np.r_[lam_lin, mu, force]).max(initial=0.0), np.finfo(float).tiny)
        changed = False
        spread, runs = _conforming(cells, dict(zip(vnodes.tolist(), y)), 1e-12 * fscale) if w == 3 else ([], set())
        for table, keys, values in ((vertices, vnodes, y), (limits, lrows, zl)):
            for a, v in zip(keys, values):
                if v < -1e-12 * fscale and not (table is vertices and int(a) in runs):
                    if (table is vertices, int(a)) in dropped:   # dropped, re-added, and dropped again
                        return wanders(f"the tangency structure wanders: round {rounds} drops the "
                                       f"{'node' if table is vertices else 'limit'} row {int(a)} a second time")
                    dropped.add((table is vertices, int(a)))
                    del table[int(a)]
                    changed = True
                else:
                    table[int(a)] = float(v)
        for c, m_c, (s, L) in zip(tkeys, mu, points):
            I = tangencies[c][1]
            if m_c < -1e-12 * fscale:
                del tangencies[c]
                changed = True
            elif np.any(L[list(I)] <= 0):
                del tangencies[c]
                add(s, tuple(i for i in I if L[i] > 0), float(m_c), np.maximum(L, 0.0))
                changed = True
            else:
                tangencies[c] = (s, I, float(m_c))
        U = abs(G) @ np.abs(x) + np.abs(g) + np.abs(cone_gap)
        qmax, Lmax = (bernstein_argmax if departure is None else departure.argmax)((D_all @ x - d_all).reshape(-1, w))
        rel = np.maximum(qmax, 0.0) / np.maximum(segment_scales(B, U, w), np.finfo(float).tiny)
        for s in np.flatnonzero(rel > tol):
            Ls = Lmax[s] if w == 6 else np.array([1 - Lmax[s], Lmax[s]])
            add(s, tuple(int(i) for i in np.flatnonzero(Ls > 0)), 0.0, Ls)
            changed = True
        over = np.flatnonzero(limited & ((G @ x - g - lim) > tol * np.maximum(U, np.finfo(float).tiny)))
        for a in over:
            if int(a) not in limits:
                limits[int(a)] = 0.0
                changed = True
        if not changed:
            break
    else:
        return Declined(Stop.MAX_ITER, f"the tangency structure did not settle in {max_rounds} rounds")
    # the answer as point forces (the read-back of the cuts): a node's row at that node of an element holding it
    first = {}
    for s in range(S):
        for i in range(w):
            first.setdefault(int(cells[s, i]), (s, i))
    nodes = shape.nodes if w == 6 else np.column_stack([1 - shape.nodes, shape.nodes])
    seg, pts, yk = [], [], []
    for v, yv in zip(vnodes, y):
        if int(v) in runs:                        # a run in full contact: its forces as measures (_conforming)
            continue
        s, i = first[int(v)]
        seg.append(s), pts.append(nodes[i]), yk.append(yv)
    for s, ts, ys in spread:
        seg.append(s), pts.append(np.array([1 - ts, ts])), yk.append(ys)
    for m_c, (s, L) in zip(mu, points):
        seg.append(s), pts.append(L), yk.append(m_c)
    seg = np.array(seg, dtype=int)
    pts = np.array(pts).reshape(len(seg), k)
    t = pts if w == 6 else pts[:, 1]
    yk = np.maximum(np.array(yk, dtype=float), 0.0)
    z = np.zeros(N)
    z[lrows] = np.maximum(zl, 0.0)
    nodal, active = point_read_back(B, seg, t, yk, yk > 0)
    active |= (z > 0) | (force > 0)
    return {"x": x, "segment": seg, "t": t, "y": yk, "beta": point_duals(S, seg, t, yk), "z": z, "active": active,
            "rounds": rounds, "violation": float(rel.max(initial=0.0)), "nodal": nodal, "pressure": force,
            "pairing": None if departure is None else departure.pairing(S, seg, t, yk)}

