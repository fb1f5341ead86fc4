"""The overlay of two planar triangulations (pure geometry: arrays in, arrays out).

Two P1 traces on a planar contact surface are affine on every cell A_i ∩ B_j of the overlay of their
triangulations (docs/formulation.md, "Contact surfaces in 3D"), so the jump [u_nu] is affine there and
"[u_nu] <= g everywhere" holds exactly when it holds at the overlay's vertices: the nodes of both meshes
inside the overlap and the crossings of their edges.

:func:`overlay` builds it in the common plane's 2D frame: candidate pairs of triangles by a k-d tree on the
centroids (never all pairs), each pair's convex intersection by Sutherland-Hodgman clipping (a point within
``eps`` of a clipping line counts as on it: no crossing is made there), vertices merged within ``eps`` (so a
node shared by both meshes, or lying on the other mesh's edge, is one vertex), each cell fanned into
triangles, slivers below ``tol h^2`` dropped. ``eps = tol h`` with h the shortest edge of the two meshes.

The lumped area of each vertex (the quadrature of a contact law on the vertices: friction capacities, compliance)
is not the row sum of the fan's mass matrix: the fan starts at whichever vertex the clipping listed first, which
depends on the mesh clipped and so on the side a pair is posed from. It is :func:`_centroid_shares`, which depends
on the cells alone (their vertex sets), is positive, sums to each cell's area and is exact for affine functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..errors import SceneError

__all__ = ["Overlay", "overlay", "OVERLAY_TOL", "locate", "barycentric", "LOCATE_TOL"]

OVERLAY_TOL = 1e-9
"""Default tolerance of :func:`overlay`, relative to the shortest edge h of the two triangulations."""


@dataclass(frozen=True)
class Overlay:
    """The overlay of triangulations a and b of one plane (coordinates in m, read-only arrays).

    ``vertices`` (v, 2): the nodes of a inside the overlap first (in a's order), then b's not shared with
    a, then the edge crossings; ``triangles`` (c, 3): the cells fanned into triangles (counter-clockwise);
    ``cell_a``, ``cell_b`` (c,): the triangle of a and of b containing each; ``Ia`` (v, na), ``Ib`` (v, nb):
    the P1 hats of each mesh at the vertices (a unit row at a mesh's own node, barycentric weights in the
    containing triangle elsewhere); ``node_a`` (na,), ``node_b`` (nb,): each node's vertex (-1 outside the
    overlap); ``mass`` (v, v): the P1 mass matrix of ``triangles`` (m^2, exact for products of functions
    affine on each triangle); ``lumped`` (v,): the area attributed to each vertex (m^2; :func:`_centroid_shares`
    of the cells: positive, independent of the order of the two triangulations, exact for functions affine on
    each cell); ``area`` (m^2): the cells' area, the sum of ``lumped``; ``h`` the shortest edge (m);
    ``eps`` = tol h (m).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    cell_a: np.ndarray
    cell_b: np.ndarray
    Ia: sp.csr_matrix
    Ib: sp.csr_matrix
    node_a: np.ndarray
    node_b: np.ndarray
    mass: sp.csr_matrix
    lumped: np.ndarray
    area: float
    h: float
    eps: float

    @property
    def size(self) -> int:
        """Number of vertices."""
        return len(self.vertices)


def overlay(uv_a, tri_a, uv_b, tri_b, tol: float = OVERLAY_TOL) -> Overlay:
    """The overlay of triangulation a (``uv_a`` (na, 2) m, ``tri_a`` (ta, 3)) and b, both in one plane's
    2D frame (either orientation). ``tol``: merging distance and on-line tolerance relative to the shortest
    edge h of both meshes; cells and fan triangles of area below ``tol h^2`` are dropped. An empty overlap
    gives an overlay with no vertex (the caller names the parts)."""
    uv_a, tri_a = _triangulation(uv_a, tri_a, "a")
    uv_b, tri_b = _triangulation(uv_b, tri_b, "b")
    if not (np.isfinite(tol) and 0 < tol < 1e-3):
        raise SceneError(f"overlay tolerance must be in (0, 1e-3) (relative to the shortest edge), got {tol!r}")
    h = min(_shortest_edge(uv_a, tri_a), _shortest_edge(uv_b, tri_b))
    eps, small = tol * h, tol * h * h
    A, B = uv_a[tri_a], uv_b[tri_b]                                # (t, 3, 2) counter-clockwise
    pa, pb = _candidates(A, B, eps)
    poly, count = _clip(A[pa], B[pb], eps)
    keep = (count >= 3) & (_polygon_area(poly) > small)
    poly, count, pa, pb = poly[keep], count[keep], pa[keep], pb[keep]

    # merge: the mesh nodes first, so a cluster holding a node takes its coordinates (a before b)
    K = poly.shape[1]
    valid = np.arange(K) < count[:, None]
    cloud = np.concatenate([uv_a, uv_b, poly[valid]])
    label = _clusters(cloud, eps)
    na, nb = len(uv_a), len(uv_b)
    for name, lab in (("a", label[:na]), ("b", label[na:na + nb])):
        if len(np.unique(lab)) < len(lab):
            raise SceneError(f"triangulation {name} has two nodes closer than {eps:.3g} m (tol x shortest edge)")
    ids = np.full(poly.shape[:2], -1)
    ids[valid] = label[na + nb:]
    ids, count = _drop_repeats(ids, count)
    rep = np.full(label.max() + 1, len(cloud))                     # each cluster's first point
    np.minimum.at(rep, label, np.arange(len(cloud)))
    coords = cloud[rep]
    share, cell_area = _centroid_shares(coords, ids, count)
    ok = (count >= 3) & (cell_area > small)
    ids, count, pa, pb, share, cell_area = ids[ok], count[ok], pa[ok], pb[ok], share[ok], cell_area[ok]

    tri, cell = _fan(ids, count)
    area = _triangle_area(coords[tri]) if len(tri) else np.zeros(0)
    good = area > small
    tri, cell, area = tri[good], cell[good], area[good]

    member = ids >= 0                                              # every cell's vertices, fan or not
    used = np.unique(ids[member])
    used = used[np.argsort(rep[used], kind="stable")]              # the vertices, in the cloud's order
    vid = np.full(len(rep), -1)
    vid[used] = np.arange(len(used))
    triangles = vid[tri]
    vertices = coords[used]
    node_a, node_b = vid[label[:na]], vid[label[na:na + nb]]
    cell_a, cell_b = pa[cell], pb[cell]
    at, of = vid[ids[member]], np.nonzero(member)[0]              # each cell vertex and its cell
    Ia = _hats(vertices, at, pa[of], node_a, uv_a, tri_a)
    Ib = _hats(vertices, at, pb[of], node_b, uv_b, tri_b)
    mass = _mass(triangles, area, len(vertices))
    lumped = np.zeros(len(vertices))
    np.add.at(lumped, at, share[member])
    return Overlay(vertices=_ro(vertices), triangles=_ro(triangles), cell_a=_ro(cell_a), cell_b=_ro(cell_b),
                   Ia=Ia, Ib=Ib, node_a=_ro(node_a), node_b=_ro(node_b), mass=mass, lumped=_ro(lumped),
                   area=float(cell_area.sum()), h=float(h), eps=float(eps))


def _ro(a) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


def _triangulation(uv, tri, name):
    """Float (n, 2) points and int (t, 3) triangles, each turned counter-clockwise; degenerate refused."""
    uv = np.asarray(uv, dtype=float)
    tri = np.asarray(tri)
    if uv.ndim != 2 or uv.shape[1] != 2 or not np.isfinite(uv).all():
        raise SceneError(f"triangulation {name}: points must be a finite (n, 2) array, got shape {uv.shape}")
    if tri.ndim != 2 or tri.shape[1] != 3 or len(tri) == 0 or not np.issubdtype(tri.dtype, np.integer) \
            or tri.min() < 0 or tri.max() >= len(uv):
        raise SceneError(f"triangulation {name}: triangles must be a non-empty (t, 3) integer array of point "
                         f"indices below {len(uv)}, got shape {tri.shape}")
    area = _triangle_area(uv[tri])
    scale = np.ptp(uv, axis=0).max() if len(uv) else 0.0
    bad = np.flatnonzero(np.abs(area) <= 1e-14 * scale * scale)
    if len(bad):
        raise SceneError(f"triangulation {name}: triangle {int(bad[0])} has zero area in the contact plane")
    tri = np.where((area < 0)[:, None], tri[:, [0, 2, 1]], tri)
    return uv, tri


def _triangle_area(P) -> np.ndarray:
    """Signed areas of triangles P (t, 3, 2)."""
    d1, d2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def _shortest_edge(uv, tri) -> float:
    P = uv[tri]
    return float(np.linalg.norm(P - P[:, [1, 2, 0]], axis=2).min())


def _candidates(A, B, eps):
    """Pairs (i, j) of triangles of a and b whose bounding boxes meet (within eps): a k-d tree on b's
    centroids queried within each a-triangle's radius plus the largest b-radius, then a box test."""
    ca, cb = A.mean(axis=1), B.mean(axis=1)
    ra = np.linalg.norm(A - ca[:, None], axis=2).max(axis=1)
    rb = np.linalg.norm(B - cb[:, None], axis=2).max(axis=1)
    near = cKDTree(cb).query_ball_point(ca, ra + rb.max() + 2 * eps)
    counts = np.fromiter(map(len, near), dtype=int, count=len(near))
    pa = np.repeat(np.arange(len(A)), counts)
    pb = np.concatenate([np.asarray(n, dtype=int) for n in near]) if counts.sum() else np.zeros(0, dtype=int)
    lo_a, hi_a, lo_b, hi_b = A.min(axis=1)[pa], A.max(axis=1)[pa], B.min(axis=1)[pb], B.max(axis=1)[pb]
    meet = ((lo_a <= hi_b + eps) & (lo_b <= hi_a + eps)).all(axis=1)
    return pa[meet], pb[meet]


def _clip(subject, clip, eps):
    """Sutherland-Hodgman: each convex polygon ``subject`` (P, 3, 2) clipped by the counter-clockwise
    triangle ``clip`` (P, 3, 2), all pairs at once. A vertex within eps of a clipping line is on it (kept,
    no crossing made). Returns the polygons (P, K, 2) (rows padded with their first vertex) and counts."""
    poly = subject.copy()
    count = np.full(len(poly), 3)
    for e in range(3):
        q0, q1 = clip[:, e], clip[:, (e + 1) % 3]
        edge = q1 - q0
        length = np.linalg.norm(edge, axis=1)
        K = poly.shape[1]
        idx = np.arange(K)[None, :]
        valid = idx < count[:, None]
        nxt = (idx + 1) % np.maximum(count, 1)[:, None]
        w = poly - q0[:, None]
        d = (edge[:, None, 0] * w[..., 1] - edge[:, None, 1] * w[..., 0]) / length[:, None]   # > 0 inside
        dn = np.take_along_axis(d, nxt, axis=1)
        pn = np.take_along_axis(poly, nxt[..., None], axis=1)
        crossing = valid & (((d > eps) & (dn < -eps)) | ((d < -eps) & (dn > eps)))
        t = np.where(crossing, d / np.where(crossing, d - dn, 1.0), 0.0)
        cut = poly + t[..., None] * (pn - poly)
        cand = np.stack([poly, cut], axis=2).reshape(len(poly), 2 * K, 2)
        keep = np.stack([valid & (d >= -eps), crossing], axis=2).reshape(len(poly), 2 * K)
        order = np.argsort(~keep, axis=1, kind="stable")
        count = keep.sum(axis=1)
        width = max(int(count.max(initial=0)), 1)
        poly = np.take_along_axis(cand, order[:, :width, None], axis=1)
    pad = np.arange(poly.shape[1])[None, :] >= count[:, None]
    poly = np.where(pad[..., None], poly[:, :1], poly)
    return poly, count


def _polygon_area(poly):
    """Areas of polygons padded with their first vertex (shoelace)."""
    if poly.shape[1] == 0:
        return np.zeros(len(poly))
    q = np.roll(poly, -1, axis=1)
    return 0.5 * (poly[..., 0] * q[..., 1] - poly[..., 1] * q[..., 0]).sum(axis=1)


def _clusters(points, eps):
    """A label per point: points within eps of each other (transitively) share one."""
    pairs = cKDTree(points).query_pairs(eps, output_type="ndarray")
    n = len(points)
    graph = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _drop_repeats(ids, count):
    """Remove cyclically repeated consecutive vertex ids of each polygon (padding -1) and compact."""
    K = ids.shape[1]
    idx = np.arange(K)[None, :]
    valid = idx < count[:, None]
    prev = (idx - 1) % np.maximum(count, 1)[:, None]
    keep = valid & (ids != np.take_along_axis(ids, prev, axis=1))
    keep[count == 1, 0] = True
    order = np.argsort(~keep, axis=1, kind="stable")
    ids = np.take_along_axis(ids, order, axis=1)
    count = keep.sum(axis=1)
    ids[np.arange(K)[None, :] >= count[:, None]] = -1
    return ids, count


def _fan(ids, count):
    """The triangles (v0, v_i, v_i+1) of each polygon and the polygon of each."""
    tris, cells = [], []
    for i in range(1, ids.shape[1] - 1):            # at most a few fan positions, all polygons at once
        on = np.flatnonzero(count > i + 1)
        tris.append(np.column_stack([ids[on, 0], ids[on, i], ids[on, i + 1]]))
        cells.append(on)
    if not tris:
        return np.zeros((0, 3), dtype=int), np.zeros(0, dtype=int)
    return np.concatenate(tris), np.concatenate(cells)


def _centroid_shares(coords, ids, count):
    """The area of each convex cell (ids (P, K) of ``coords``, padded -1; counter-clockwise) attributed to its
    vertices, and the cells' areas (P,) (m^2). Cell i is cut into the triangles (c, v_k, v_k+1) about its vertex
    centroid c (areas A_k, each clipped at 0: a convex cell has none negative but for rounding); each triangle's
    area goes a third to each corner, c's third shared equally by the n vertices (the value at c of a function
    affine on the cell is their mean): w_k = (A_k-1 + A_k) / 3 + A / (3 n), A = sum A_k. The shares are positive,
    sum to A, integrate functions affine on the cell exactly, and depend on the vertex set alone (not on which
    vertex is listed first), unlike a fan from the first vertex."""
    K = ids.shape[1]
    idx = np.arange(K)[None, :]
    valid = idx < count[:, None]
    n = np.maximum(count, 1)[:, None]
    X = np.where(valid[..., None], coords[np.maximum(ids, 0)], 0.0)
    c = X.sum(axis=1) / n
    D = np.where(valid[..., None], X - c[:, None], 0.0)
    Dn = np.take_along_axis(D, ((idx + 1) % n)[..., None], axis=1)
    tri = np.where(valid, np.maximum(0.5 * (D[..., 0] * Dn[..., 1] - D[..., 1] * Dn[..., 0]), 0.0), 0.0)
    area = tri.sum(axis=1)
    prev = np.take_along_axis(tri, (idx - 1) % n, axis=1)
    share = np.where(valid, (prev + tri) / 3.0 + (area / (3.0 * n[:, 0]))[:, None], 0.0)
    return share, area


def _hats(vertices, at_vertex, cell, node, uv, tri):
    """(v, n) P1 hats of a mesh at the vertices: unit rows at its own nodes, else the barycentric weights
    of the vertex in the mesh's triangle ``cell`` containing one overlay cell at that vertex (``at_vertex``,
    ``cell``: each cell vertex and the mesh triangle of its cell)."""
    v, n = len(vertices), len(uv)
    own = node >= 0
    at = np.full(v, -1)
    at[node[own]] = np.flatnonzero(own)
    host = np.full(v, -1)
    host[at_vertex] = cell                                         # any containing mesh triangle will do
    other = np.flatnonzero(at < 0)
    P = uv[tri[host[other]]]                                       # (o, 3, 2)
    T = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)   # (o, 2, 2)
    l12 = np.linalg.solve(T, (vertices[other] - P[:, 0])[..., None])[..., 0] if len(other) else np.zeros((0, 2))
    bary = np.column_stack([1.0 - l12.sum(axis=1), l12])
    bary[np.abs(bary) < 1e-15] = 0.0                              # rounding of exact zeros
    rows = np.concatenate([np.flatnonzero(at >= 0), np.repeat(other, 3)])
    cols = np.concatenate([at[at >= 0], tri[host[other]].ravel()])
    vals = np.concatenate([np.ones(int((at >= 0).sum())), bary.ravel()])
    keep = vals != 0
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(v, n))


def _mass(triangles, area, v):
    """P1 mass matrix of the triangles with the given areas: area/12 (1 + delta_ij) per triangle."""
    local = (np.ones((3, 3)) + np.eye(3)) / 12.0
    rows = np.repeat(triangles, 3, axis=1).ravel()
    cols = np.tile(triangles, (1, 3)).ravel()
    vals = (area[:, None, None] * local[None]).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(v, v))


LOCATE_TOL = 1e-9
"""Barycentric tolerance of a point on a triangle's edge (relative) in :func:`locate`."""


def barycentric(x, P) -> np.ndarray:
    """(k, 3): the barycentric coordinates of the points ``x`` (k, 2) in the triangles ``P`` (k, 3, 2)."""
    T = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)
    l12 = np.linalg.solve(T, (x - P[:, 0])[..., None])[..., 0] if len(x) else np.zeros((0, 2))
    return np.column_stack([1.0 - l12.sum(axis=1), l12])


def locate(x, coords, triangles, tol: float = LOCATE_TOL) -> tuple[np.ndarray, np.ndarray]:
    """(triangle, barycentric): for each point ``x`` (k, 2) a triangle of (``coords``, ``triangles``) that
    contains it (barycentric coordinates >= -``tol``; -1 if none) and its barycentric coordinates there. Candidates
    by a k-d tree on the centroids (never all pairs)."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(coords, dtype=float)[np.asarray(triangles)]
    c = P.mean(axis=1)
    radius = float(np.linalg.norm(P - c[:, None], axis=2).max())
    near = cKDTree(c).query_ball_point(x, radius * (1 + 1e-9))
    counts = np.fromiter(map(len, near), dtype=int, count=len(near))
    point = np.repeat(np.arange(len(x)), counts)
    cand = np.concatenate([np.asarray(n, dtype=int) for n in near]) if counts.sum() else np.zeros(0, dtype=int)
    L = barycentric(x[point], P[cand])
    inside = L.min(axis=1) >= -tol
    point, cand, L = point[inside], cand[inside], L[inside]
    first = np.full(len(x), -1)
    at, index = np.unique(point, return_index=True)             # any containing triangle: the first listed
    first[at] = index
    found = first >= 0
    tri = np.full(len(x), -1)
    bary = np.zeros((len(x), 3))
    tri[found] = cand[first[found]]
    bary[found] = np.clip(L[first[found]], 0.0, None)
    bary[found] /= bary[found].sum(axis=1, keepdims=True)
    return tri, bary
