"""The exact finish of the 3D P2 cones where the contact runs along lines across the triangles (ridges), with the
touching points beside them: Newton on the KKT system of q = -(w_h)^2 on the ridge triangles, w_h linear on each
(one unknown per vertex), and of m(Q) = 0 on the triangles and edges that touch at isolated points.

On a P2 triangle the slack q = [u_nu] - g is one quadratic, q(L) = L^T Q L (docs/formulation.md §16). Where the
contact zone of a flat face pressed and sheared on a plane ends in a curve (a box lifting at a corner), each touching
triangle's q reaches 0 along a whole line across it: q <= 0 vanishing on a line is minus the square of a linear
function, q = -(v . L)^2 (Q = -v v^T, rank 1), neither an isolated tangency point (Q negative definite on the
triangle's plane: :mod:`cvxcontact.backends.tangency`) nor an edge (q = L_k (linear), Q of rank 2). Measured on the
sheared box of tests/friction_box_scenes.py at the cuts' answer: Q's second eigenvalue at most 1.5e-4 of the first
on every touching triangle (tests/test_friction_p2_ridges3d.py). Neighbouring ridges restrict to the same square on
their common edge, so the triangles' v are, up to sign, the vertex values of a P1 function w_h on the touching set
(its sign may turn around a triangle that is no ridge: the relations of the signs are read per edge,
:func:`_ridge_start`), and the P2 interpolant of -(w_h)^2 is -(w_h)^2 itself. The condition is then one row per P2
node a of the ridge triangles,

    r_a(x) + (P w)_a^2 = 0        (P: w's values at the nodes, a midpoint's (w_a ± w_b) / 2),

with the unknowns w beside x: Newton on the Lagrangian E(x) + lam^T (r(x) + (P w)^2), whose Hessian in w is
2 P^T diag(lam) P and whose stationarity in w, P^T (lam * P w) = 0, holds the forces lam to where w_h vanishes.

Where touching points and ridges mix (the held-side box, the box under most other shears and thresholds: 1 to 3
touching triangles no ridge, their form's second eigenvalue 5e-2 .. 0.35 of the first), such a triangle touches at
an isolated point of an edge or of its inside, and there the condition is the tangency finish's row m(Q) = 0 (the
maximum of q over that sub-simplex, smooth where q is strictly concave on it; its gradient the point row at the
maximiser, its second derivative the curvature term mu_c H_c in the Hessian: :func:`~cvxcontact.backends.tangency.
element_maximum`), posed in the same Newton system. A touching point on an edge whose P2 nodes are all the ridges' (a
triangle beside a ridge touching at the ridge's zero crossing on their common edge) has no row of its own: q there
is -(w_h)^2 already, and that row would depend on the ridges'. A triangle may touch at two points (on two edges).

The contact set is the zero line of w_h and the points; the nodal forces lam are the answer's exactly where they are
those of a non-negative measure on the lines (point forces y >= 0 along each triangle's zero segment fitted to lam
by non-negative least squares, :data:`MEASURE_ROUNDING`) and the points' forces mu are non-negative (one that is
not leaves the structure, as does a point whose q stops being strictly concave, and Newton runs again). Accepted
where the steps reach rounding with every row met, q <= 0 holds on every triangle (its exact Bernstein maximum),
each maximiser lies inside its sub-simplex and the fit holds; the answer is then the point forces (a cut's
read-back). Else a :class:`~cvxcontact.backends.finish.declined.Declined` saying why."""

from __future__ import annotations

import numpy as np
import scipy.optimize as so
import scipy.sparse as sp

from ..contact.bernstein import bernstein_argmax, element
from .cuts import point_duals, point_read_back, point_rows
from .factor import lu as dense_or_sparse_lu
from .finish.declined import Declined, Stop
from .tangency import element_maximum, node_rows

__all__ = ["ridge_newton"]

TOUCHING = 1e-6
"""A triangle touches where its slack's exact maximum at the start is at least minus this times the largest reach of
the rows (|G| |x| + |g|). Measured at the cuts' answer of the sheared box: 16 triangles at -8.7e-12 .. +5.8e-9 (one
of them, touching at an isolated point beside a vertex, no ridge: no row of its own is posed there), the 2 lifted
at -6.2e-5; on the held-side box all 18 at +4.6e-9 .. +1.7e-8."""

MEASURE_ROUNDING = 1e-9
"""The largest residual of the non-negative fit of the nodal forces by point forces on the zero lines, relative to
the forces (measured 1.7e-16 on the sheared box; 0.15 where a touching triangle was left out of the set)."""

RANKS = (1e-2, 3e-4)
"""A touching triangle is a ridge where the second largest eigenvalue of its form Q (in magnitude) is at most this
times the largest, the first value tried first (measured at the cuts' answers: at most 1.5e-4 on the sheared box's
ridges, tests/test_friction_p2_ridges3d.py; the triangles that touch at isolated points 5.1e-2 .. 2.8e-1 on the
held-side box). The cuts' answer reads some in between (the box sheared by (0.2, -0.1) p: one at 4.2e-4 that
touches at points, finished only with it read so, the second value)."""

SIGN_WEIGHT = 1e-6
"""An edge's relation of its vertices' signs (from its midpoint's slack) that breaks its triangle's own signs flips
only where the product of their depths |w_a| |w_b| is at most this fraction of the largest (one of them is then 0 to
the start's rounding and either sign holds); above it the finish declines."""

SAMPLES = 41
"""Point forces per triangle's zero segment in the fit (equally spaced, ends included)."""

EDGES = ((0, 1, 3), (1, 2, 4), (2, 0, 5))


def _point_rows(points, D, d, z, shape):
    """The tangency rows of the point contacts ``points`` ((s, I) each) at ``z`` (:func:`~cvxcontact.backends.
    tangency.element_maximum`, docs/formulation.md §18): (C, m, H, where) the rows' gradients (sparse), their values
    m(Q), the second derivatives' matrices (-2 J^T M J per row, the multipliers' weights not applied) and the
    maximisers; or the index of the first point whose sub-simplex's slack is not strictly concave there."""
    rows, vals, hess, where = [], [], [], []
    for c, (s, I) in enumerate(points):
        Ds = D[6 * s:6 * s + 6]
        out = element_maximum(shape, Ds @ z - d[6 * s:6 * s + 6], I)
        if out is None:
            return c
        m, L, M = out
        J = sp.vstack([sum(L[j] * Ds[shape.index(i, j)] for j in I) for i in I]).tocsr()
        rows.append(sp.csr_matrix(shape.basis(L[None, :])) @ Ds)
        vals.append(m)
        hess.append(-2.0 * (J.T @ sp.csr_matrix(M) @ J))
        where.append(L)
    C = sp.vstack(rows).tocsr() if rows else sp.csr_matrix((0, D.shape[1]))
    return C, np.array(vals, dtype=float), hess, where


def _touching_points(cells, b, candidates, covered, reach) -> dict:
    """The point contacts of the touching triangles ``candidates`` that are no ridges (coefficients ``b`` (S, 6)):
    (vertex nodes) -> (s, I) for every edge and interior I of theirs where the slack is strictly concave with its
    maximum inside I and at least ``-reach`` (a triangle may touch at two points, on two of its edges), one per
    sub-simplex (an edge shared by two triangles once). A sub-simplex whose P2 nodes are all on the ridges
    (``covered``) needs no row of its own: there q = -(w_h)^2 already (a triangle beside a ridge touches on their
    common edge at the ridge's zero crossing; a row there depends on the ridge's)."""
    shape, points = element(6), {}
    for s in candidates:
        for I in ((0, 1), (1, 2), (0, 2), (0, 1, 2)):
            own = [cells[s, i] for i in I] + [cells[s, c] for i, j, c in EDGES if i in I and j in I]
            if {int(v) for v in own} <= covered:
                continue
            out = element_maximum(shape, b[s], I)
            if out is not None and out[0] >= -reach and (out[1][list(I)] > 1e-6).all():
                points.setdefault(tuple(sorted(int(cells[s, i]) for i in I)), (int(s), I))
    return points


def _flips(keys, same, weight, bound):
    """The relations to flip so that every ridge's three relations have the product +1, all at once: the edges of
    weight at most ``bound`` (:data:`SIGN_WEIGHT` of the largest: a vertex where w is 0 to the start's rounding)
    are free, the others keep ``same``; each triangle (``keys``: its three edges) asks that the number of its
    free edges flipped be odd where its measured product is -1, even else, a linear system over GF(2) solved by
    elimination (the lightest relation of each triangle flipped in turn may undo a flip its neighbour needed:
    measured on the box sheared along a diagonal under Coulomb, three triangles around two vertices where w is 0).
    Returns the set of edges to flip, or None where no flips of free edges satisfy every triangle."""
    free = sorted({e for edges in keys for e in edges if weight[e] <= bound})
    col = {e: i for i, e in enumerate(free)}
    A = np.zeros((len(keys), len(free) + 1), dtype=bool)          # [coefficients | right-hand side] over GF(2)
    for k, edges in enumerate(keys):
        A[k, [col[e] for e in edges if e in col]] = True
        A[k, -1] = np.prod([same[e] for e in edges]) < 0
    pivots, row = [], 0
    for c in range(len(free)):
        hit = np.flatnonzero(A[row:, c])
        if row == len(A) or not len(hit):
            continue
        A[[row, row + hit[0]]] = A[[row + hit[0], row]]
        others = np.flatnonzero(A[:, c])
        A[others[others != row]] ^= A[row]
        pivots.append(c)
        row += 1
    if A[row:, -1].any():
        return None
    return {free[c] for k, c in enumerate(pivots) if A[k, -1]}


def _ridge_start(cells, touching, r):
    """(nodes, vid, P, w, sign) of the ridge triangles ``touching``: their P2 node rows, the vertex indices per
    triangle, P (w's values at the nodes: a vertex's own, a midpoint's (w_a + s w_b) / 2, s = ±1 the edge's relation
    of its vertices' signs), the start w = sqrt(-r) at the vertices and each triangle's s along :data:`EDGES`
    (k, 3); a Declined where a triangle's relations admit no signs of its own. An edge's s is read from its
    midpoint's slack (same signs: |mean| the larger); on each ridge
    the three relations' product is +1 (q = -(v . L)^2: s_ab = sign(v_a v_b)); where it is not, the relation
    of least weight |w_a| |w_b| flips if that is at most :data:`SIGN_WEIGHT` of the largest (a vertex where w is 0 to
    the start's rounding: either sign holds), each triangle in turn; where a flip undid one a neighbour needed, the
    free relations are solved for all at once (:func:`_flips`). The relations are per edge, not per vertex: around a
    triangle that is no ridge w may change its sign (measured on the box sheared by (0.2, 0.2) p: one such twist
    around a triangle bounded by three ridges), each ridge's square is still that of a linear function."""
    verts = np.unique(cells[touching, :3])
    nodes = np.unique(cells[touching])
    vid, nid = np.searchsorted(verts, cells[touching, :3]), np.searchsorted(nodes, cells[touching])
    depth = np.sqrt(np.maximum(-r[verts], 0.0))
    same, weight = {}, {}
    for k, s in enumerate(touching):
        for a, b, m in EDGES:
            key = tuple(sorted((int(vid[k, a]), int(vid[k, b]))))
            da, db, dm = depth[key[0]], depth[key[1]], -r[cells[s, m]]
            same[key] = 1.0 if abs(((da + db) / 2) ** 2 - dm) <= abs(((da - db) / 2) ** 2 - dm) else -1.0
            weight[key] = da * db
    heaviest = max(weight.values(), default=0.0)
    keys = [[tuple(sorted((int(vid[k, a]), int(vid[k, b])))) for a, b, _ in EDGES] for k in range(len(touching))]
    measured = dict(same)
    for edges in keys:                              # each triangle's lightest relation, in turn
        if np.prod([same[e] for e in edges]) < 0:
            light = min(edges, key=lambda e: weight[e])
            if weight[light] > SIGN_WEIGHT * heaviest:
                break
            same[light] = -same[light]
    if any(np.prod([same[e] for e in edges]) < 0 for edges in keys):     # one flip undid another's: all at once
        flips = _flips(keys, measured, weight, SIGN_WEIGHT * heaviest)
        if flips is None:
            return Declined(Stop.NOT_POSED, "a touching triangle's slack is no square of a linear function")
        same = {e: -v if e in flips else v for e, v in measured.items()}
    lo = np.array([[e[0] for e in edges] for edges in keys], dtype=int).reshape(-1, 3)
    hi = np.array([[e[1] for e in edges] for edges in keys], dtype=int).reshape(-1, 3)
    sign = np.array([[same[e] for e in edges] for edges in keys]).reshape(-1, 3)
    i_, j_, v_ = [nid[:, :3].ravel()], [vid.ravel()], [np.ones(vid.size)]
    for c, (_, _, m) in enumerate(EDGES):            # a midpoint: (w_lo + s w_hi) / 2, lo the lower vertex index
        i_ += [nid[:, m], nid[:, m]]
        j_ += [lo[:, c], hi[:, c]]
        v_ += [np.full(len(touching), 0.5), 0.5 * sign[:, c]]
    rows_, cols_, vals_ = np.concatenate(i_), np.concatenate(j_), np.concatenate(v_)
    _, first = np.unique(rows_ * len(verts) + cols_, return_index=True)      # an entry shared by triangles: once
    P = sp.csr_matrix((vals_[first], (rows_[first], cols_[first])), shape=(len(nodes), len(verts)))
    return nodes, vid, P, depth, sign


def _newton(energy, Gz, g, P, nodes, D, d, z, w, points, n, max_steps):
    """Newton on the ridges' rows (module docstring) and the point contacts' tangency rows m_c(z) = 0 (``points``,
    (s, I) each) from (``z``, ``w``): (z, w, lam, mu, where) (the ridges' node forces, the points' forces, their
    maximisers, their values), a Declined, or the index of a point whose slack left strict concavity on its
    sub-simplex."""
    shape, nz = element(6), len(z)
    Gr, gr = Gz[nodes], g[nodes]
    first = _point_rows(points, D, d, z, shape)
    if isinstance(first, int):
        return first
    lm = sp.linalg.lsqr(sp.vstack([Gr, first[0]]).T, -energy.gradient(z), atol=1e-15, btol=1e-15)[0]
    lam, mu = lm[:len(nodes)], lm[len(nodes):]
    last = np.inf
    for _ in range(max_steps):
        rows = _point_rows(points, D, d, z, shape)
        if isinstance(rows, int):
            return rows
        C, m, hess, _ = rows
        A = energy.tangent(z) + sum((mu_c * h for mu_c, h in zip(mu, hess)), sp.csr_matrix((nz, nz)))
        pw = P @ w
        rows_all = sp.vstack([Gr, C]).tocsr()
        Wc = sp.vstack([sp.diags(2 * pw) @ P, sp.csr_matrix((len(points), len(w)))]).tocsr()
        K = sp.bmat([[A, None, rows_all.T], [None, 2 * P.T @ sp.diags(lam) @ P, Wc.T], [rows_all, Wc, None]],
                    format="csc")
        rhs = -np.r_[energy.gradient(z) + rows_all.T @ np.r_[lam, mu], 2 * P.T @ (lam * pw), Gr @ z - gr + pw ** 2, m]
        try:
            dx = dense_or_sparse_lu(K).solve(rhs)
        except RuntimeError:
            return Declined(Stop.SINGULAR, "the Newton system on the ridges is singular")
        if not np.isfinite(dx).all():
            return Declined(Stop.SINGULAR, "the Newton system on the ridges is singular")
        dl = dx[nz + len(w):]
        z, w, lam, mu = z + dx[:nz], w + dx[nz:nz + len(w)], lam + dl[:len(nodes)], mu + dl[len(nodes):]
        step = np.abs(dx[:n]).max(initial=0.0) / max(np.abs(z[:n]).max(initial=0.0), np.finfo(float).tiny)
        if step <= 1e-14 or (step <= 1e-10 and step > 0.25 * last):
            break
        last = step
    else:
        return Declined(Stop.STALL, f"Newton on the ridges did not converge in {max_steps} steps")
    rows = _point_rows(points, D, d, z, shape)
    if isinstance(rows, int):
        return rows
    return z, w, lam, mu, rows[3], rows[1]


def ridge_newton(energy, G, g, B, z0, n: int, tol: float, max_steps: int = 30, max_rounds: int = 4):
    """The finish of the module docstring: ``energy`` (a :class:`~cvxcontact.backends.mixed.MixedEnergy`, e.g. with
    the stick-slip partition's rows, on z = [x; extra], x the first ``n``), the contact rows ``G`` (N, n) with gap
    ``g`` (r = G x - g, scaled), the P2 triangles' Bernstein map ``B`` (6 S, N), from ``z0`` (the cuts' answer);
    ``tol`` the largest slack accepted, over the largest reach of the rows (|G| |x| + |g|). A point contact whose
    force comes out negative, or whose slack stops being strictly concave on its sub-simplex, leaves and Newton runs
    again from ``z0`` (at most ``max_rounds`` runs). The ridges are read off the start at each of :data:`RANKS` in
    turn, the first structure accepted the answer (each passes the exact tests of the module docstring). Returns a
    dict (z, segment, t, y: the point forces on the zero lines and at the points, beta, nodal: the forces on the rows,
    active, points: the number of point contacts) or the Declined that stopped it."""
    first = None
    for rank in RANKS:
        out = _ridge_newton(energy, G, g, B, z0, n, tol, max_steps, max_rounds, rank)
        if not isinstance(out, Declined):
            return out
        first = first or out
    return first


def _ridge_newton(energy, G, g, B, z0, n, tol, max_steps, max_rounds, rank):
    """:func:`ridge_newton` with the ridges read at ``rank`` (:data:`RANKS`)."""
    B = sp.csr_matrix(B)
    cells = node_rows(B, 6)
    if (cells < 0).any():
        return Declined(Stop.NOT_POSED, "a triangle's P2 node is not one contact row")
    nz, N = len(z0), G.shape[0]
    Gz = sp.hstack([sp.csr_matrix(G), sp.csr_matrix((N, nz - n))]).tocsr()
    z0 = np.asarray(z0, dtype=float)
    r = Gz @ z0 - g
    scale = max(float((abs(G) @ np.abs(z0[:n]) + np.abs(g)).max(initial=0.0)), np.finfo(float).tiny)
    top, _ = bernstein_argmax((B @ r).reshape(-1, 6))
    Q = element(6).gram((B @ r).reshape(-1, 6))
    ev = np.sort(np.abs(np.linalg.eigvalsh(Q)), axis=1)           # ascending magnitudes
    ridge = ev[:, 1] <= rank * ev[:, 2]
    near = top >= -TOUCHING * scale
    touching = np.flatnonzero(near & ridge)
    if not len(touching):
        return Declined(Stop.NOT_POSED, "no triangle touches along a line")
    start = _ridge_start(cells, touching, r)
    if isinstance(start, Declined):
        return start
    nodes, vid, P, w0, sign = start
    points = _touching_points(cells, (B @ r).reshape(-1, 6), np.flatnonzero(near & ~ridge), set(nodes.tolist()),
                              TOUCHING * scale)
    D, d = (B @ Gz).tocsr(), B @ g
    for _ in range(max_rounds):
        keys = list(points)
        out = _newton(energy, Gz, g, P, nodes, D, d, z0.copy(), w0.copy(), [points[k] for k in keys], n, max_steps)
        if isinstance(out, Declined):
            return out
        if isinstance(out, int):                # a point's slack no longer strictly concave: it leaves
            del points[keys[out]]
            continue
        z, w, lam, mu, where, m = out
        size = max(float(np.abs(np.r_[lam, mu]).max(initial=0.0)), np.finfo(float).tiny)
        negative = mu < -MEASURE_ROUNDING * size
        if not negative.any():
            break
        for k in [keys[i] for i in np.flatnonzero(negative)]:
            del points[k]
    else:
        return Declined(Stop.CYCLE, f"the point contacts beside the ridges did not settle in {max_rounds} runs")
    r = Gz @ z - g
    top, _ = bernstein_argmax((B @ r).reshape(-1, 6))
    if max(np.abs(r[nodes] + (P @ w) ** 2).max(initial=0.0), np.abs(m).max(initial=0.0)) > tol * scale:
        return Declined(Stop.STALL, "Newton on the ridges stopped with its rows unmet")
    if (top > tol * scale).any():
        return Declined(Stop.SIGNS, f"the answer on the ridges leaves a triangle's cone by "
                                    f"{float(top.max()) / scale:.1e}")
    spots = [(points[k][0], L) for k, L in zip(keys, where)]
    if any(np.any(L[list(points[k][1])] <= 0) for k, L in zip(keys, where)):
        return Declined(Stop.SIGNS, "a point contact's maximiser left its sub-simplex")
    # the forces: non-negative point forces on each triangle's zero segment
    seg, pts = [], []
    wv = w[vid]
    for k, s in enumerate(touching):                  # along edge ab: w_a (1 - t) + s w_b t (the triangle's signs)
        ends = [np.eye(3)[a] * (1 - t) + np.eye(3)[b] * t
                for c, (a, b, _) in enumerate(EDGES) for wa, wb in [(wv[k, a], sign[k, c] * wv[k, b])]
                if wa * wb <= 0 and wa != wb for t in [wa / (wa - wb)]]
        if len(ends) >= 2:                    # a line through a vertex finds it twice: the farthest two ends
            far = max(((i, j) for i in range(len(ends)) for j in range(i)),
                      key=lambda ij: float(np.abs(ends[ij[0]] - ends[ij[1]]).sum()))
            t = np.linspace(0.0, 1.0, SAMPLES)[:, None]
            pts.append((1 - t) * ends[far[0]] + t * ends[far[1]])
            seg.append(np.full(SAMPLES, s))
    f = np.zeros(N)
    f[nodes] = lam
    if not seg:
        return Declined(Stop.SIGNS, "no touching triangle holds a zero line")
    seg, pts = np.concatenate(seg), np.vstack(pts)
    A = point_rows(B, seg, pts).T.toarray()
    y, misfit = so.nnls(A, f, maxiter=50 * A.shape[1])
    size = max(float(np.linalg.norm(f)), np.finfo(float).tiny)
    if misfit > MEASURE_ROUNDING * size:
        return Declined(Stop.SIGNS, f"the forces on the ridges are no non-negative measure on their zero lines "
                                    f"(misfit {misfit / size:.1e})")
    keep = y > 0
    seg = np.r_[seg[keep], np.array([s for s, _ in spots], dtype=int)]
    pts = np.vstack([pts[keep]] + [L[None, :] for _, L in spots])
    y = np.r_[y[keep], np.maximum(mu, 0.0)]
    nodal, active = point_read_back(B, seg, pts, y, y > 0)
    return {"z": z, "segment": seg, "t": pts, "y": y, "beta": point_duals(len(cells), seg, pts, y), "nodal": nodal,
            "active": active, "points": len(spots)}
