"""The exact finish of the 3D P2 cones where the contact runs along lines across the triangles (ridges): Newton on the
KKT system of q = -(w_h)^2 on the touching triangles, w_h continuous and linear on each (one unknown per vertex).

On a P2 triangle the slack q = [u_nu] - g is one quadratic, q(L) = L^T Q L (docs/formulation.md §16). Where the
contact zone of a flat face pressed and sheared on a plane ends in a curve (a box lifting at a corner), each touching
triangle's q reaches 0 along a whole line across it: q <= 0 vanishing on a line is minus the square of a linear
function, q = -(v . L)^2 (Q = -v v^T, rank 1), neither an isolated tangency point (Q negative definite on the
triangle's plane: :mod:`cvxcontact.backends.tangency`) nor an edge (q = L_k (linear), Q of rank 2). Measured on the
sheared box of tests/friction_box_scenes.py at the cuts' answer: Q's second eigenvalue at most 1.5e-4 of the first
on every touching triangle (tests/test_friction_p2_ridges3d.py); on the held-side box and under other shears or
thresholds 1 to 3 touching triangles touch at isolated points instead, which this finish leaves out: it declines
there (CHANGELOG). Neighbouring ridges restrict to the same square on their common edge, so the triangles' v are,
up to sign, the vertex values of one continuous P1 function w_h on the touching set, and the P2 interpolant of
-(w_h)^2 is -(w_h)^2 itself. The condition is then one row per P2 node a of the touching triangles,

    r_a(x) + (P w)_a^2 = 0        (P: w's values at the nodes, a midpoint's the mean of its vertices'),

with the unknowns w beside x: Newton on the Lagrangian E(x) + lam^T (r(x) + (P w)^2), whose Hessian in w is
2 P^T diag(lam) P and whose stationarity in w, P^T (lam * P w) = 0, holds the forces lam to where w_h vanishes. The
contact set is the zero line of w_h; the nodal forces lam are the answer's exactly where they are those of a
non-negative measure on it: point forces y >= 0 along each triangle's zero segment fitted to lam by non-negative
least squares (:data:`MEASURE_ROUNDING`). Accepted where the steps reach rounding, q <= 0 holds on every triangle (its
exact Bernstein maximum) and the fit holds; the answer is then the point forces (a cut's read-back). Else a
:class:`~cvxcontact.backends.finish.declined.Declined` saying why."""

from __future__ import annotations

import numpy as np
import scipy.optimize as so
import scipy.sparse as sp

from ..contact.bernstein import bernstein_argmax, element
from .cuts import point_duals, point_read_back, point_rows
from .factor import lu as dense_or_sparse_lu
from .finish.declined import Declined, Stop
from .tangency import node_rows

__all__ = ["ridge_newton"]

TOUCHING = 1e-6
"""A triangle touches where its slack's exact maximum at the start is at least minus this times the largest reach of
the rows (|G| |x| + |g|). Measured at the cuts' answer of the sheared box: 16 triangles at -8.7e-12 .. +5.8e-9 (one
of them, touching at an isolated point beside a vertex, no ridge: :data:`RANK` leaves it out), the 2 lifted at
-6.2e-5."""

MEASURE_ROUNDING = 1e-9
"""The largest residual of the non-negative fit of the nodal forces by point forces on the zero lines, relative to
the forces (measured 1.7e-16 on the sheared box; 0.15 where a touching triangle was left out of the set)."""

RANK = 1e-2
"""A touching triangle is a ridge where the second largest eigenvalue of its form Q (in magnitude) is at most this
times the largest (measured at most 1.5e-4 on the sheared box's ridges, tests/test_friction_p2_ridges3d.py)."""

SIGN_WEIGHT = 1e-6
"""An edge's relation of its vertices' signs (from its midpoint's slack) is read only where the product of their
depths |w_a| |w_b| exceeds this fraction of the largest (else one of them is 0 to the start's rounding and either
sign holds)."""

SAMPLES = 41
"""Point forces per triangle's zero segment in the fit (equally spaced, ends included)."""

EDGES = ((0, 1, 3), (1, 2, 4), (2, 0, 5))


def _signs(pairs, count) -> np.ndarray | None:
    """±1 per vertex from ``pairs`` (i, j, same, weight): w_i w_j >= 0 where ``same``, the relations of larger
    ``weight`` first (a spanning forest, union-find with parity); None where a relation of weight above
    :data:`SIGN_WEIGHT` of the largest contradicts it (a vertex where w is 0 to rounding relates to none)."""
    parent, parity = list(range(count)), [0] * count

    def root(i):
        p = 0
        while parent[i] != i:
            p ^= parity[i]
            i = parent[i]
        return i, p

    heaviest = max((p[3] for p in pairs), default=0.0)
    for i, j, same, weight in sorted(pairs, key=lambda p: -p[3]):
        (ri, pi), (rj, pj) = root(i), root(j)
        flip = 0 if same else 1
        if ri != rj:
            parent[ri], parity[ri] = rj, pi ^ pj ^ flip
        elif (pi ^ pj) != flip and weight > SIGN_WEIGHT * heaviest:
            return None
    return np.array([1.0 - 2.0 * root(i)[1] for i in range(count)])


def ridge_newton(energy, G, g, B, z0, n: int, tol: float, max_steps: int = 30):
    """The finish of the module docstring: ``energy`` (a :class:`~cvxcontact.backends.mixed.MixedEnergy`, e.g. with
    the stick-slip partition's rows, on z = [x; extra], x the first ``n``), the contact rows ``G`` (N, n) with gap
    ``g`` (r = G x - g, scaled), the P2 triangles' Bernstein map ``B`` (6 S, N), from ``z0`` (the cuts' answer);
    ``tol`` the largest slack accepted, over the largest reach of the rows (|G| |x| + |g|). Returns a dict (z,
    segment, t, y: the point forces on the zero lines, beta, nodal: the forces on the rows, active) or the Declined
    that stopped it."""
    B = sp.csr_matrix(B)
    cells = node_rows(B, 6)
    if (cells < 0).any():
        return Declined(Stop.NOT_POSED, "a triangle's P2 node is not one contact row")
    nz, N = len(z0), G.shape[0]
    Gz = sp.hstack([sp.csr_matrix(G), sp.csr_matrix((N, nz - n))]).tocsr()
    z = np.asarray(z0, dtype=float).copy()
    r = Gz @ z - g
    scale = max(float((abs(G) @ np.abs(z[:n]) + np.abs(g)).max(initial=0.0)), np.finfo(float).tiny)
    top, _ = bernstein_argmax((B @ r).reshape(-1, 6))
    Q = element(6).gram((B @ r).reshape(-1, 6))
    ev = np.sort(np.abs(np.linalg.eigvalsh(Q)), axis=1)           # ascending magnitudes
    ridge = ev[:, 1] <= RANK * ev[:, 2]
    touching = np.flatnonzero((top >= -TOUCHING * scale) & ridge)
    if not len(touching):
        return Declined(Stop.NOT_POSED, "no triangle touches")
    verts = np.unique(cells[touching, :3])
    nodes = np.unique(cells[touching])
    vid, nid = np.searchsorted(verts, cells[touching, :3]), np.searchsorted(nodes, cells[touching])
    # P: w's values at the nodes (a vertex's own, a midpoint's the mean of its edge's)
    i_, j_, v_ = [nid[:, :3].ravel()], [vid.ravel()], [np.ones(vid.size)]
    for a, b, m in EDGES:
        i_ += [nid[:, m], nid[:, m]]
        j_ += [vid[:, a], vid[:, b]]
        v_ += [np.full(len(touching), 0.5)] * 2
    rows_, cols_, vals_ = np.concatenate(i_), np.concatenate(j_), np.concatenate(v_)
    _, first = np.unique(rows_ * len(verts) + cols_, return_index=True)      # an entry shared by triangles: once
    P = sp.csr_matrix((vals_[first], (rows_[first], cols_[first])), shape=(len(nodes), len(verts)))
    # the start: |w| = sqrt(-r) at the vertices, signs from each edge's midpoint (same signs: |mean| the larger)
    depth = np.sqrt(np.maximum(-r[verts], 0.0))
    pairs = []
    for a, b, m in EDGES:
        da, db, dm = depth[vid[:, a]], depth[vid[:, b]], -r[cells[touching, m]]
        same = np.abs(((da + db) / 2) ** 2 - dm) <= np.abs(((da - db) / 2) ** 2 - dm)
        pairs += list(zip(vid[:, a].tolist(), vid[:, b].tolist(), same.tolist(), (da * db).tolist()))
    sign = _signs(pairs, len(verts))
    if sign is None:
        return Declined(Stop.NOT_POSED, "the touching triangles' slack is no square of one continuous function")
    w = sign * depth
    Gr, gr = Gz[nodes], g[nodes]
    lam = sp.linalg.lsqr(Gr.T, -energy.gradient(z), atol=1e-15, btol=1e-15)[0]
    last = np.inf
    for _ in range(max_steps):
        pw = P @ w
        K = sp.bmat([[energy.tangent(z), None, Gr.T], [None, 2 * P.T @ sp.diags(lam) @ P, (sp.diags(2 * pw) @ P).T],
                     [Gr, sp.diags(2 * pw) @ P, None]], format="csc")
        rhs = -np.r_[energy.gradient(z) + Gr.T @ lam, 2 * P.T @ (lam * pw), Gr @ z - gr + pw ** 2]
        try:
            d = dense_or_sparse_lu(K).solve(rhs)
        except RuntimeError:
            return Declined(Stop.SINGULAR, "the Newton system on the ridges is singular")
        if not np.isfinite(d).all():
            return Declined(Stop.SINGULAR, "the Newton system on the ridges is singular")
        z, w, lam = z + d[:nz], w + d[nz:nz + len(w)], lam + d[nz + len(w):]
        step = np.abs(d[:n]).max(initial=0.0) / max(np.abs(z[:n]).max(initial=0.0), np.finfo(float).tiny)
        if step <= 1e-14 or (step <= 1e-10 and step > 0.25 * last):
            break
        last = step
    else:
        return Declined(Stop.STALL, f"Newton on the ridges did not converge in {max_steps} steps")
    r = Gz @ z - g
    top, _ = bernstein_argmax((B @ r).reshape(-1, 6))
    if np.abs(r[nodes] + (P @ w) ** 2).max(initial=0.0) > tol * scale:
        return Declined(Stop.STALL, "Newton on the ridges stopped with its rows unmet")
    if (top > tol * scale).any():
        return Declined(Stop.SIGNS, f"the answer on the ridges leaves a triangle's cone by "
                                    f"{float(top.max()) / scale:.1e}")
    # the forces: non-negative point forces on each triangle's zero segment
    seg, pts = [], []
    wv = w[vid]
    for k, s in enumerate(touching):
        ends = [np.eye(3)[a] * (1 - t) + np.eye(3)[b] * t
                for a, b, _ in EDGES if wv[k, a] * wv[k, b] <= 0 and wv[k, a] != wv[k, b]
                for t in [wv[k, a] / (wv[k, a] - wv[k, b])]]
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
    seg, pts, y = seg[keep], pts[keep], y[keep]
    nodal, active = point_read_back(B, seg, pts, y, y > 0)
    return {"z": z, "segment": seg, "t": pts, "y": y, "beta": point_duals(len(cells), seg, pts, y), "nodal": nodal,
            "active": active}
