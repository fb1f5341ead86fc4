"""The checks of a mesh's nodes, cells and boundary, shared by the meshes of every cell.

:class:`~cvxcontact.geometry.mesh.Mesh` validates a triangulation with them once, when built (duplicate nodes,
orientation, the boundary edges, the embedding: angles, crossings, layers); the quadrilateral, tetrahedral and
hexahedral meshes use the node checks, the renumbering and the read-only copies.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..errors import MeshError

DUPLICATE_TOL = 1e-8
"""Two nodes closer than this times the longest edge at either node are duplicates."""

CELLS = 1 << 16
"""Cells per block of the edge lengths of :func:`check_nodes` (their temporaries, about 500 bytes per
tetrahedron at once, were the peak of building a large tetrahedral mesh)."""


# --------------------------------------------------------------------------- validation helpers

def as_points(points):
    """The (n, 2) float array of a planar mesh's ``points`` (m; a constant third coordinate dropped), checked:
    n >= 3, finite (a MeshError naming what is wrong otherwise)."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] not in (2, 3) or len(p) < 3:
        raise MeshError(f"points must be an (n, 2) array with n >= 3, got shape {p.shape}")
    if p.shape[1] == 3:
        if np.ptp(p[:, 2]) > 1e-12 * np.ptp(p[:, :2]):               # relative: the same at every scale
            raise MeshError("points have a varying third coordinate; cvxcontact meshes are planar (x, y)")
        p = p[:, :2]
    if not np.isfinite(p).all():
        raise MeshError("points contain NaN or infinite coordinates")
    return np.ascontiguousarray(p)


def checked_renumbering(order: ArrayLike, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(order, new) for ``renumbered``: ``order`` checked to be a permutation of 0..n-1 (else a MeshError naming
    the fix) and its inverse, new[old index] = new index."""
    order = np.asarray(order)
    if (order.shape != (n,) or not np.issubdtype(order.dtype, np.integer)
            or not np.array_equal(np.sort(order), np.arange(n))):
        raise MeshError(f"renumbered needs a permutation of 0..{n - 1} (one new place per node, integers), "
                        f"got an array of shape {order.shape} and dtype {order.dtype}; e.g. "
                        f"np.random.default_rng(0).permutation({n})")
    new = np.empty(n, dtype=np.int64)
    new[order] = np.arange(n)
    return order, new


def check_nodes(points, cells, what="triangle"):
    """Every node is used, and no two nodes are closer than DUPLICATE_TOL times the local element size.

    The local size h(v) of node v is its longest incident edge; nodes i, j are
    duplicates when |x_i - x_j| < DUPLICATE_TOL * max(h(i), h(j)), found with a
    k-d tree (nearest neighbour of every node, O(n log n)), whatever the node order.
    ``cells`` are simplices (triangles or tetrahedra, named ``what`` in the messages).
    """
    used = np.zeros(len(points), dtype=bool)
    used[cells.ravel()] = True
    if not used.all():
        raise MeshError(f"{int((~used).sum())} node(s) belong to no {what}, e.g. node {int(np.argmin(used))}")
    a, b = np.triu_indices(cells.shape[1], 1)                 # the cells' edges (a, b), by blocks of CELLS cells
    h = np.zeros(len(points))
    for s in range(0, len(cells), CELLS):
        ends = cells[s:s + CELLS, a], cells[s:s + CELLS, b]
        length = np.linalg.norm(points[ends[1]] - points[ends[0]], axis=2)
        for end in ends:
            np.maximum.at(h, end, length)
    dist, idx = cKDTree(points).query(points, k=2)
    own = np.arange(len(points))
    other = np.where(idx[:, 0] == own, idx[:, 1], idx[:, 0])
    near = dist[:, 1] < DUPLICATE_TOL * h
    if near.any():
        i = int(np.argmax(near))
        j = int(other[i])
        raise MeshError(f"duplicate nodes {min(i, j)} and {max(i, j)} at {points[i].tolist()}: "
                        f"{dist[i, 1]:.3g} m apart, expected at least {DUPLICATE_TOL:g} x the local "
                        f"element size ({h[i]:.3g} m)")


def signed_areas(points, triangles):
    """(m,) the signed areas (m^2) of the ``triangles`` (m, 3) of ``points``, positive counter-clockwise."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def orient(points, triangles):
    """The ``triangles`` oriented counter-clockwise (all reversed where all are clockwise; a MeshError where the
    orientations are mixed, :func:`one_orientation`, or a triangle is degenerate, zero area)."""
    area = signed_areas(points, triangles)
    scale = float(np.ptp(points, axis=0).max()) ** 2
    tiny = np.abs(area) <= 1e-14 * scale
    if tiny.any():
        raise MeshError(f"{int(tiny.sum())} degenerate (zero-area) triangle(s), e.g. triangle "
                        f"{int(np.argmax(tiny))}: nodes {triangles[np.argmax(tiny)].tolist()}")
    return one_orientation(triangles, area > 0, [0, 2, 1], ("triangles", "triangle(s)", "triangle"))


def one_orientation(cells, positive, flip, names):
    """``cells`` (m, k) oriented alike: as they are where every cell is ``positive`` (m,) bool, reordered by the
    columns ``flip`` where none is (a mesh reversed throughout); MeshError naming a cell of the smaller group (a
    reversed one at a tie) where both occur (the mesh folds over). ``names``: (the cells, their count's noun, one
    cell), e.g. ("triangles", "triangle(s)", "triangle")."""
    if positive.all():
        return cells
    if not positive.any():
        return cells[:, flip].copy()
    negative = ~positive
    kind, counted, one = names
    k = int(np.argmax(negative) if negative.sum() <= len(positive) / 2 else np.argmin(negative))
    raise MeshError(f"inverted {kind}: {int(min(negative.sum(), positive.sum()))} {counted} are oriented against "
                    f"the rest (the mesh folds over), e.g. {one} {k}: nodes {cells[k].tolist()}")


def edge_table(triangles, n):
    """Directed edges (3 per triangle, row 3 t + i), their sorted undirected keys, the sorting
    permutation, and the start and length of each run of equal keys."""
    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keys = np.minimum(edges[:, 0], edges[:, 1]) * n + np.maximum(edges[:, 0], edges[:, 1])
    order = np.argsort(keys, kind="stable")
    keys = keys[order]
    start = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    return edges, keys, order, start, np.diff(np.r_[start, len(keys)])


def boundary_edges(triangles, n, table=None):
    """Sorted keys and oriented node pairs of the edges that belong to exactly one triangle."""
    edges, keys, order, start, count = table if table is not None else edge_table(triangles, n)
    if (count > 2).any():
        k = int(order[start[np.argmax(count > 2)]])
        raise MeshError(f"an edge is shared by more than two triangles (nodes {edges[k].tolist()}, triangle "
                        f"{k // 3} and others): the mesh is not a manifold; expected at most two per edge")
    once = start[count == 1]
    return keys[once], edges[order[once]]


def check_embedding(points, triangles, boundary, table):
    """Refuse triangles that overlap or fold over one another.

    With every triangle counter-clockwise and non-degenerate and every edge in at
    most two triangles (checked before), the triangles tile a plane domain without
    overlap if and only if:

    (a) each interior edge is traversed in opposite directions by its two
        triangles, so they lie on either side of it;
    (b) each boundary node has exactly one incoming and one outgoing boundary
        edge, so the boundary is a set of vertex-disjoint closed loops and the
        triangles at a node form fans;
    (c) the triangle angles at an interior node sum to 2 pi, and at a boundary
        node to the interior angle from its outgoing to its incoming boundary
        edge; a fan that wraps k extra times adds 2 pi k, so (a)-(c) make the
        mesh one sheet near every node (an immersion);
    (d) boundary edges meet only where consecutive edges share a node (no
        crossing, touching or collinear overlap), so the boundary loops are
        disjoint simple polygons;
    (e) every boundary loop has exactly one layer of triangles on its left:
        the winding number of the other loops at a node of the loop is 0 for a
        counter-clockwise (outer) loop and 1 for a clockwise (hole) loop.

    For an immersion, the number of triangles covering a point off the boundary
    equals the sum of the winding numbers of the loops around it; it is constant
    between the loops and changes by one across each. A region covered twice
    would border a loop with a layer on its outer side, which (e) excludes, so
    each point is covered at most once. Cost: O(m log m), bucketed crossing tests
    (d), and O(loops x boundary edges) for (e).
    """
    n = len(points)
    edges, _, order, start, count = table
    forward = edges[:, 0] < edges[:, 1]
    pair = start[count == 2]
    same = forward[order[pair]] == forward[order[pair + 1]]                        # (a)
    if same.any():
        k = int(order[pair[np.argmax(same)]])
        raise MeshError(f"triangle {k // 3} (nodes {triangles[k // 3].tolist()}) overlaps its neighbour across "
                        f"edge {edges[k].tolist()}: both triangles lie on the same side of it; expected "
                        "neighbours on opposite sides")
    out_deg = np.bincount(boundary[:, 0], minlength=n)
    in_deg = np.bincount(boundary[:, 1], minlength=n)
    bad = (out_deg + in_deg > 0) & ((out_deg != 1) | (in_deg != 1))               # (b)
    if bad.any():
        v = int(np.argmax(bad))
        raise MeshError(f"boundary node {v} at {points[v].tolist()} has {int(out_deg[v] + in_deg[v])} boundary "
                        "edges, expected 2: triangles overlap or touch at a single node there")
    _check_angles(points, triangles, boundary)                                      # (c)
    _check_crossings(points, boundary)                                              # (d)
    _check_layers(points, boundary)                                                 # (e)


def _check_angles(points, triangles, boundary):
    n = len(points)
    x, y = points[:, 0][triangles], points[:, 1][triangles]         # (m, 3) corner coordinates
    total = np.zeros(n)
    for i in range(3):                                               # angle at corner i of each triangle
        j, k = (i + 1) % 3, (i + 2) % 3
        ux, uy, wx, wy = x[:, j] - x[:, i], y[:, j] - y[:, i], x[:, k] - x[:, i], y[:, k] - y[:, i]
        total += np.bincount(triangles[:, i], weights=np.arctan2(ux * wy - uy * wx, ux * wx + uy * wy),
                             minlength=n)
    expected = np.full(n, 2 * np.pi)
    v, w_node = boundary[:, 0], boundary[:, 1]
    u_node = np.empty(n, dtype=np.int64)
    u_node[boundary[:, 1]] = boundary[:, 0]                          # source of the incoming edge
    a, b = points[w_node] - points[v], points[u_node[v]] - points[v]
    expected[v] = np.mod(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1)), 2 * np.pi)
    bad = np.abs(total - expected) > np.pi                           # a mismatch is a multiple of 2 pi
    if bad.any():
        k = int(np.argmax(bad))
        where = "boundary" if np.isin(k, v) else "interior"
        raise MeshError(f"triangles overlap at {where} node {k} at {points[k].tolist()}: their angles there sum "
                        f"to {np.degrees(total[k]):.1f} deg, expected {np.degrees(expected[k]):.1f} deg")


def _check_crossings(points, boundary):
    """Boundary edges meet only at the node shared by consecutive edges (uniform-grid buckets)."""
    k = len(boundary)
    a, b = points[boundary[:, 0]], points[boundary[:, 1]]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    h = float(np.median(np.linalg.norm(b - a, axis=1)))
    origin = lo.min(axis=0)
    while True:                                      # cells of side h; coarser if long edges span too many
        i0 = np.floor((lo - origin) / h).astype(np.int64)
        i1 = np.floor((hi - origin) / h).astype(np.int64)
        span = i1 - i0 + 1
        cells = span[:, 0] * span[:, 1]
        if cells.sum() <= 4 * k + 64:
            break
        h *= 2.0
    owner = np.repeat(np.arange(k), cells)
    local = np.arange(len(owner)) - np.repeat(np.cumsum(cells) - cells, cells)
    cell = (i0[owner, 0] + local // span[owner, 1]) * (int(i1[:, 1].max()) + 1) + i0[owner, 1] + local % span[owner, 1]
    order = np.argsort(cell, kind="stable")
    cell, owner = cell[order], owner[order]
    pairs = [np.zeros((0, 2), dtype=np.int64)]
    for d in range(1, len(cell)):                    # all pairs within each bucket
        same = cell[d:] == cell[:-d]
        if not same.any():
            break
        pairs.append(np.column_stack([owner[:-d][same], owner[d:][same]]))
    pairs = np.concatenate(pairs)
    e, f = boundary[pairs[:, 0]], boundary[pairs[:, 1]]
    apart = (e[:, :, None] != f[:, None, :]).all(axis=(1, 2))        # consecutive edges share a node
    pairs, e, f = pairs[apart], e[apart], f[apart]
    if not len(pairs):
        return

    def side(p, q, r):
        return np.sign((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0]))

    p1, q1, p2, q2 = points[e[:, 0]], points[e[:, 1]], points[f[:, 0]], points[f[:, 1]]
    boxes = ((np.maximum(p1, q1) >= np.minimum(p2, q2)) & (np.maximum(p2, q2) >= np.minimum(p1, q1))).all(axis=1)
    meet = boxes & (side(p1, q1, p2) * side(p1, q1, q2) <= 0) & (side(p2, q2, p1) * side(p2, q2, q1) <= 0)
    if meet.any():
        i = int(np.argmax(meet))
        raise MeshError(f"boundary edges {e[i].tolist()} and {f[i].tolist()} cross or touch near "
                        f"{points[e[i, 0]].tolist()}: parts of the mesh overlap; expected boundary loops "
                        "that meet only at shared nodes of consecutive edges")


def _check_layers(points, boundary):
    """Each boundary loop has one layer of triangles on its left (see check_embedding, (e))."""
    n = len(points)
    graph = coo_matrix((np.ones(len(boundary)), (boundary[:, 0], boundary[:, 1])), shape=(n, n))
    _, node_loop = connected_components(graph, directed=False)
    loop = node_loop[boundary[:, 0]]
    loops, first = np.unique(loop, return_index=True)
    if len(loops) == 1:
        return                                       # one simple loop around counter-clockwise triangles
    a, b = points[boundary[:, 0]], points[boundary[:, 1]]
    area = np.bincount(np.searchsorted(loops, loop), weights=a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    hole = area < 0
    chunk = max(1, 2_000_000 // len(boundary))
    for s in range(0, len(loops), chunk):           # winding numbers of all edges at one node per loop
        q = a[first[s:s + chunk]][:, None, :]
        up = (a[None, :, 1] <= q[..., 1]) & (b[None, :, 1] > q[..., 1])
        down = (b[None, :, 1] <= q[..., 1]) & (a[None, :, 1] > q[..., 1])
        left = (b[None, :, 0] - a[None, :, 0]) * (q[..., 1] - a[None, :, 1]) \
            - (b[None, :, 1] - a[None, :, 1]) * (q[..., 0] - a[None, :, 0])
        other = loops[s:s + chunk, None] != loop[None, :]
        wind = ((up & (left > 0) & other).sum(axis=1) - (down & (left < 0) & other).sum(axis=1))
        bad = wind != hole[s:s + chunk]
        if bad.any():
            i = s + int(np.argmax(bad))
            v = int(boundary[first[i], 0])
            raise MeshError(f"the boundary loop through node {v} at {points[v].tolist()} lies inside "
                            f"{int(wind[i - s])} other layer(s) of triangles, expected {int(hole[i])}: "
                            "separate parts of the mesh overlap")
