"""The overlay of two planar triangulations (contact/overlay.py), checked against a brute-force overlay built
here independently: every pair of triangles intersected as the convex hull (scipy) of the corners of each inside
the other and their edge crossings, integrated by a rule exact for quadratics."""

import numpy as np
import pytest
from meshes import grid, random_mesh, rotated
from scipy.spatial import ConvexHull

from cvxcontact.contact.overlay import overlay
from cvxcontact.errors import SceneError


def inside(P, tri_pts, eps=1e-12):
    """Points P (n, 2) in the closed triangle tri_pts (3, 2)."""
    a, b, c = tri_pts
    T = np.column_stack([b - a, c - a])
    lam = np.linalg.solve(T, (P - a).T).T
    return (lam >= -eps).all(axis=1) & (lam.sum(axis=1) <= 1 + eps)


def convex_intersection(P, Q):
    """The intersection polygon of two convex polygons (counter-clockwise hull points), or None (brute force:
    corners of each inside the other and every crossing of their edges, then scipy's ConvexHull)."""
    def contains(poly, pts):
        e = np.roll(poly, -1, axis=0) - poly
        w = pts[:, None, :] - poly[None]
        cross = e[None, :, 0] * w[..., 1] - e[None, :, 1] * w[..., 0]
        return (cross >= -1e-13).all(axis=1)

    pts = [P[contains(Q, P)], Q[contains(P, Q)]]
    for i in range(len(P)):
        p0, p1 = P[i], P[(i + 1) % len(P)]
        for j in range(len(Q)):
            q0, q1 = Q[j], Q[(j + 1) % len(Q)]
            A = np.column_stack([p1 - p0, q0 - q1])
            if abs(np.linalg.det(A)) < 1e-15:
                continue
            s, t = np.linalg.solve(A, q0 - p0)
            if -1e-13 <= s <= 1 + 1e-13 and -1e-13 <= t <= 1 + 1e-13:
                pts.append((p0 + s * (p1 - p0))[None])
    pts = np.concatenate(pts)
    if len(pts) < 3:
        return None
    try:
        hull = ConvexHull(pts)
    except Exception:          # collinear: no area
        return None
    if hull.volume < 1e-14:
        return None
    return pts[hull.vertices]


def hats_on(mesh, t, X):
    """Barycentric weights (k, 3) of points X in triangle t of mesh."""
    a, b, c = mesh[0][mesh[1][t]]
    lam = np.linalg.solve(np.column_stack([b - a, c - a]), (X - a).T).T
    return np.column_stack([1 - lam.sum(axis=1), lam])


def brute_force(ma, mb):
    """Independent overlay integrals: area, and int psi^a_i psi^b_j, int psi^a_i psi^a_k, int psi^b_j psi^b_l
    over the overlap (edge-midpoint rule on a fan of each pair's intersection: exact for quadratics)."""
    na, nb = len(ma[0]), len(mb[0])
    Cab, Caa, Cbb = np.zeros((na, nb)), np.zeros((na, na)), np.zeros((nb, nb))
    area = 0.0
    for i, ta in enumerate(ma[1]):
        for j, tb in enumerate(mb[1]):
            poly = convex_intersection(ma[0][ta], mb[0][tb])
            if poly is None:
                continue
            for k in range(1, len(poly) - 1):
                tri = poly[[0, k, k + 1]]
                d1, d2 = tri[1] - tri[0], tri[2] - tri[0]
                A = 0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0])
                area += A
                mids = (tri + np.roll(tri, -1, axis=0)) / 2
                wa, wb = hats_on(ma, i, mids), hats_on(mb, j, mids)
                Cab[np.ix_(ta, tb)] += A / 3 * wa.T @ wb
                Caa[np.ix_(ta, ta)] += A / 3 * wa.T @ wa
                Cbb[np.ix_(tb, tb)] += A / 3 * wb.T @ wb
    return area, Cab, Caa, Cbb


def polygon_area(P):
    return 0.5 * abs(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - P[:, 1] * np.roll(P[:, 0], -1)))


def boundary_polygon(mesh):
    return mesh[0][ConvexHull(mesh[0]).vertices]


RNG = np.random.default_rng(7)
CASES = {
    "random non-matching": (random_mesh(14, RNG), random_mesh(9, RNG)),
    "rotated": (grid(5, 4), rotated(grid(4, 6, x=(0.2, 0.8), y=(0.2, 0.8)), 0.37)),
    "rotated random, partial": (random_mesh(12, RNG),
                                rotated(random_mesh(10, RNG, x=(0.4, 1.5), y=(-0.3, 0.7)), 1.1)),
    "structured 5x5 on 7x3": (grid(5, 5), grid(7, 3, flip=True)),
    "nested": (grid(3, 3), grid(6, 6)),
    "matching": (grid(4, 3), grid(4, 3)),
    "punch (partial)": (grid(6, 6, x=(-1, 2), y=(-1, 2)), grid(3, 2, x=(0.1, 0.9), y=(0.25, 0.75))),
    "nodes on edges": (grid(4, 4), grid(2, 6, flip=True)),
    "offset partial": (grid(4, 4), grid(5, 3, x=(0.5, 1.7), y=(0.3, 1.3))),
}


@pytest.fixture(scope="module", params=list(CASES))
def case(request):
    ma, mb = CASES[request.param]
    return request.param, ma, mb, overlay(*ma, *mb), brute_force(ma, mb)


def test_cell_areas_sum_to_the_overlap_area(case):
    name, ma, mb, ov, (area, *_) = case
    exact = polygon_area(convex_intersection(boundary_polygon(ma), boundary_polygon(mb)))   # both convex
    assert abs(ov.area - exact) <= 1e-13 * exact                # measured <= 3.2e-16 relative
    assert abs(area - exact) <= 1e-12 * exact                   # the brute force agrees (measured <= 1e-15)
    d1 = ov.vertices[ov.triangles[:, 1]] - ov.vertices[ov.triangles[:, 0]]
    d2 = ov.vertices[ov.triangles[:, 2]] - ov.vertices[ov.triangles[:, 0]]
    assert (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] > 0).all()  # counter-clockwise, no degenerate triangle
    assert abs(ov.mass.sum() - exact) <= 1e-13 * exact


def test_every_overlay_triangle_lies_in_its_two_cells(case):
    name, ma, mb, ov, _ = case
    for mesh, cell in ((ma, ov.cell_a), (mb, ov.cell_b)):
        P = mesh[0][mesh[1][cell]]                                       # (c, 3, 2)
        T = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)
        for k in range(3):
            lam = np.linalg.solve(T, (ov.vertices[ov.triangles[:, k]] - P[:, 0])[..., None])[..., 0]
            bary = np.column_stack([1 - lam.sum(axis=1), lam])
            assert bary.min() >= -1e-12                               # measured >= -2.8e-15


def test_vertices_are_the_nodes_in_the_overlap_and_the_edge_crossings(case):
    """The vertex set against a brute-force one: both meshes' nodes inside the other's triangulation and every
    crossing of an edge of a with an edge of b, merged at 1e-9."""
    name, ma, mb, ov, _ = case
    pts = []
    for m, other in ((ma, mb), (mb, ma)):
        In = np.zeros(len(m[0]), dtype=bool)
        for t in other[1]:
            In |= inside(m[0], other[0][t])
        pts.append(m[0][In])
    ea = np.unique(np.sort(np.concatenate([ma[1][:, [0, 1]], ma[1][:, [1, 2]], ma[1][:, [2, 0]]]), axis=1), axis=0)
    eb = np.unique(np.sort(np.concatenate([mb[1][:, [0, 1]], mb[1][:, [1, 2]], mb[1][:, [2, 0]]]), axis=1), axis=0)
    p0, p1 = ma[0][ea[:, 0]][:, None], ma[0][ea[:, 1]][:, None]
    q0, q1 = mb[0][eb[:, 0]][None], mb[0][eb[:, 1]][None]
    r, s = p1 - p0, q1 - q0
    den = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    w = q0 - p0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * s[..., 1] - w[..., 1] * s[..., 0]) / den
        u = (w[..., 0] * r[..., 1] - w[..., 1] * r[..., 0]) / den
    hit = (np.abs(den) > 1e-14) & (t >= -1e-12) & (t <= 1 + 1e-12) & (u >= -1e-12) & (u <= 1 + 1e-12)
    pts.append((p0 + np.where(hit, t, 0.0)[..., None] * r)[hit])
    cloud = np.concatenate(pts)
    key = np.round(cloud / 1e-9).astype(np.int64)
    ref = cloud[np.unique(key, axis=0, return_index=True)[1]]
    assert len(ref) == ov.size
    dist = np.linalg.norm(ov.vertices[:, None] - ref[None], axis=2).min(axis=1)
    assert dist.max() <= 1e-12


def test_node_maps(case):
    name, ma, mb, ov, _ = case
    for m, node in ((ma, ov.node_a), (mb, ov.node_b)):
        own = node >= 0
        assert np.abs(ov.vertices[node[own]] - m[0][own]).max() <= 1e-15 * 10
        assert len(np.unique(node[own])) == own.sum()
    if name == "matching":
        assert ov.size == len(ma[0]) and len(ov.triangles) == len(ma[1])
        assert np.array_equal(ov.node_a, ov.node_b)
    if name == "nested":                       # the fine mesh's triangles are the cells
        assert ov.size == len(mb[0]) and len(ov.triangles) == len(mb[1]) and (ov.node_b >= 0).all()


def test_interpolations_reproduce_affine_functions(case):
    name, ma, mb, ov, _ = case
    f = lambda p: 0.3 - 1.7 * p[:, 0] + 2.9 * p[:, 1]
    for m, I in ((ma, ov.Ia), (mb, ov.Ib)):
        assert np.abs(I @ f(m[0]) - f(ov.vertices)).max() <= 1e-12
        # measured <= 6.2e-15 (1.8e-13 over 300 random pairs)
        assert np.abs(I @ np.ones(len(m[0])) - 1).max() <= 1e-14


def test_mass_matrix_integrates_products_of_the_hats_exactly(case):
    name, ma, mb, ov, (area, Cab, Caa, Cbb) = case
    M = ov.mass
    scale = np.abs(Caa).max()
    assert np.abs(ov.Ia.T @ M @ ov.Ib - Cab).max() <= 1e-12 * scale   # measured <= 1.0e-15 relative
    assert np.abs(ov.Ia.T @ M @ ov.Ia - Caa).max() <= 1e-12 * scale
    assert np.abs(ov.Ib.T @ M @ ov.Ib - Cbb).max() <= 1e-12 * scale


def test_read_only_and_bad_input():
    ma, mb = grid(2, 2), grid(3, 3)
    ov = overlay(*ma, *mb)
    with pytest.raises(ValueError):
        ov.vertices[0, 0] = 1.0
    with pytest.raises(SceneError, match="zero area"):
        overlay(np.array([[0, 0], [1, 0], [2, 0.0]]), np.array([[0, 1, 2]]), *mb)
    with pytest.raises(SceneError, match=r"\(t, 3\) integer"):
        overlay(ma[0], ma[1].astype(float), *mb)
    with pytest.raises(SceneError, match="tolerance"):
        overlay(*ma, *mb, tol=0.1)
    far = overlay(*ma, mb[0] + 5.0, mb[1])
    assert far.size == 0 and far.area == 0.0 and (far.node_a < 0).all()


def test_nodes_within_tol_of_each_other_and_of_edges_are_one_vertex():
    """A mesh shifted by 1e-12 m (h = 0.25 m, eps = 2.5e-10) overlays as the matching one; the same mesh shifted
    by 1e-3 h does not merge."""
    ma = grid(4, 4)
    ov = overlay(*ma, ma[0] + 1e-12, ma[1])
    assert ov.size == len(ma[0]) and len(ov.triangles) == len(ma[1])
    assert abs(ov.area - 1.0) <= 1e-11
    shifted = overlay(*ma, ma[0] + np.array([2.5e-4, 0.0]), ma[1])
    assert shifted.size > len(ma[0])
    assert abs(shifted.area - (1 - 2.5e-4)) <= 1e-13


def test_spatial_search_scales():
    """Many triangles: the candidate pairs stay near the number of overlay cells (a k-d tree, not all pairs)."""
    from cvxcontact.contact.overlay import _candidates
    ma, mb = grid(40, 40), rotated(grid(37, 41), 0.2)
    A, B = ma[0][ma[1]], mb[0][mb[1]]
    pa, _ = _candidates(A, B, 1e-12)
    assert len(pa) < 0.02 * len(A) * len(B)            # measured 0.25 % of all pairs
    ov = overlay(*ma, *mb)
    exact = polygon_area(convex_intersection(boundary_polygon(ma), boundary_polygon(mb)))
    assert abs(ov.area - exact) <= 1e-12 * exact


def test_lumped_areas_are_positive_sum_to_the_area_and_integrate_each_hat(case):
    """The vertices' lumped areas (a contact law's quadrature: friction capacities g w_a) are positive, sum to the
    overlap's area and integrate every hat of either mesh exactly (the hats are affine on each cell): against the
    brute force's integrals (the row sums of its exact products, the hats summing to 1 on the overlap)."""
    _, _, _, ov, (_, _, Caa, Cbb) = case
    w = np.asarray(ov.lumped)
    assert w.shape == (ov.size,) and (w > 0).all()
    assert abs(w.sum() - ov.area) <= 1e-14 * ov.area               # measured <= 2.8e-16 relative
    scale = w.max()
    assert np.abs(ov.Ia.T @ w - Caa.sum(axis=1)).max() <= 1e-12 * scale     # measured <= 2.9e-15 relative
    assert np.abs(ov.Ib.T @ w - Cbb.sum(axis=1)).max() <= 1e-12 * scale


def test_lumped_areas_do_not_depend_on_the_order_of_the_two_triangulations(case):
    """The overlay of b on a has the same vertices (in another order) and the same lumped area at each, to
    rounding: the areas are shares of the cells, not of a fan from whichever vertex the clipping listed first."""
    from scipy.spatial import cKDTree
    _, ma, mb, ov, _ = case
    other = overlay(*mb, *ma)
    assert other.size == ov.size
    dist, at = cKDTree(other.vertices).query(ov.vertices)
    assert dist.max() <= ov.eps and len(np.unique(at)) == ov.size
    w = np.asarray(ov.lumped)
    assert np.abs(np.asarray(other.lumped)[at] - w).max() <= 1e-12 * w.max()   # measured <= 5.7e-16 relative


def test_centroid_shares_depend_on_the_cell_alone():
    """A convex cell's shares do not depend on which vertex is listed first; a fan from the first vertex does
    (the side dependence they replace); a square's corners share its area equally."""
    from cvxcontact.contact.overlay import _centroid_shares, _fan, _mass, _triangle_area
    t = np.sort(np.random.default_rng(3).uniform(0, 2 * np.pi, 6))
    coords = np.column_stack([np.cos(t), 0.6 * np.sin(t)]) + [0.3, -0.2]              # convex, counter-clockwise
    ids = np.array([np.roll(np.arange(6), k) for k in range(6)])
    share, area = _centroid_shares(coords, ids, np.full(6, 6))
    per_vertex = np.zeros((6, 6))
    np.put_along_axis(per_vertex, ids, share, axis=1)
    assert (per_vertex > 0).all()
    assert np.abs(per_vertex - per_vertex[0]).max() <= 1e-13 * per_vertex.max()     # measured 1.9e-16 relative
    shoelace = 0.5 * np.sum(coords[:, 0] * np.roll(coords[:, 1], -1) - coords[:, 1] * np.roll(coords[:, 0], -1))
    assert np.allclose(area, shoelace, rtol=1e-13, atol=0)
    fans = []
    for k in range(2):
        tri, _ = _fan(ids[k:k + 1], np.array([6]))
        fans.append(np.asarray(_mass(tri, _triangle_area(coords[tri]), 6).sum(axis=1)).ravel())
    assert np.abs(fans[0] - fans[1]).max() > 1e-3 * fans[0].max()                    # the fan's lumping moves
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    s, a = _centroid_shares(square, np.array([[0, 1, 2, 3]]), np.array([4]))
    assert np.allclose(s, 0.5, rtol=1e-13) and np.isclose(a[0], 2.0, rtol=1e-13)
