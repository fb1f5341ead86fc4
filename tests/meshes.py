"""Mesh builders shared by the tests, as plain arrays (no package mesh class): structured and random planar
triangulations and their rotations, (points, triangles) (tests/test_overlay.py, tests/test_surface.py); the unit
tetrahedron, tetrahedra reordered to positive volumes, self-intersecting or non-manifold tetrahedral meshes
and the table of meshes the tetrahedral mesh must refuse with the message it must give, (points, tets, boundaries,
message) (tests/test_tetmesh.py, tests/test_tetmesh_checks.py). A fixtures module: the test modules do not
import each other.
"""

import numpy as np
from scipy.spatial import Delaunay

import cvxcontact as cc


def grid(nx, ny, x=(0.0, 1.0), y=(0.0, 1.0), flip=False):
    """A structured triangulation of a rectangle (each cell split along one diagonal)."""
    X, Y = np.meshgrid(np.linspace(*x, nx + 1), np.linspace(*y, ny + 1))
    pts = np.column_stack([X.ravel(), Y.ravel()])
    i = (np.arange(nx)[None, :] + (nx + 1) * np.arange(ny)[:, None]).ravel()
    if flip:
        tri = np.concatenate([np.column_stack([i, i + 1, i + nx + 1]),
                              np.column_stack([i + 1, i + nx + 2, i + nx + 1])])
    else:
        tri = np.concatenate([np.column_stack([i, i + 1, i + nx + 2]), np.column_stack([i, i + nx + 2, i + nx + 1])])
    return pts, tri


def random_mesh(n, rng, x=(0.0, 1.0), y=(0.0, 1.0)):
    """A Delaunay triangulation of the rectangle's corners, points on its sides and random inner points."""
    side = rng.uniform(0.05, 0.95, (4, 3))
    border = np.concatenate([np.column_stack([side[0], np.zeros(3)]), np.column_stack([side[1], np.ones(3)]),
                             np.column_stack([np.zeros(3), side[2]]), np.column_stack([np.ones(3), side[3]]),
                             [[0, 0], [1, 0], [0, 1], [1, 1]]])
    unit = np.concatenate([border, rng.uniform(0.05, 0.95, (n, 2))])
    pts = np.column_stack([x[0] + (x[1] - x[0]) * unit[:, 0], y[0] + (y[1] - y[0]) * unit[:, 1]])
    return pts, Delaunay(pts).simplices


def rotated(mesh, theta, centre=(0.5, 0.5)):
    """The planar mesh (points, triangles) rotated by ``theta`` (rad) about ``centre``."""
    c, s = np.cos(theta), np.sin(theta)
    R = np.array([[c, -s], [s, c]])
    return (mesh[0] - centre) @ R.T + centre, mesh[1]


UNIT = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)


def ring_around_an_edge(turns):
    """Tetrahedra (a, b, p_i, p_i+1) around the edge a = (0,0,0), b = (0,0,1), turning ``turns`` times."""
    k = 6 * turns
    t = 2 * np.pi * np.arange(k) / 6
    r = 1 + np.arange(k) // 6
    ring = np.column_stack([r * np.cos(t), r * np.sin(t), np.full(k, 0.5)])
    points = np.vstack([[0, 0, 0], [0, 0, 1], ring])
    i = np.arange(k)
    return points, np.column_stack([np.zeros(k, int), np.ones(k, int), 2 + i, 2 + (i + 1) % k])


def positive(points, tets):
    """The tetrahedra, each reordered to a positive volume."""
    t = np.array(tets)
    p = np.asarray(points)[t]
    vol = np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))
    return np.where((vol < 0)[:, None], t[:, [1, 0, 2, 3]], t)


def crossing_bars():
    """Two bars crossing like a plus sign, no node of either inside the other."""
    a = cc.box(x=(-2, 2), y=(-0.5, 0.5), z=(0, 1), nx=1, ny=1, nz=1)
    b = cc.box(x=(-0.5, 0.5), y=(-2, 2), z=(0.2, 0.8), nx=1, ny=1, nz=1)
    return np.vstack([a.points, b.points]), np.vstack([a.tets, b.tets + 8])


def curled_strip(turn):
    """A strip of 12 cells curled through ``turn`` radians around the z axis: it overlaps its own start
    when turn > 2 pi (one piece, one boundary surface)."""
    m = cc.box(x=(0, 1), y=(0, 0.3), z=(0, 0.2), nx=12, ny=1, nz=1)
    x, y, z = m.points.T
    return np.column_stack([(1 + y) * np.cos(turn * x), (1 + y) * np.sin(turn * x), z]), m.tets


def bad_meshes():
    """(points, tets, boundaries, message): meshes :class:`cvxcontact.geometry.tetmesh.TetMesh` must refuse, each
    with a regular expression its message must match."""
    sq = cc.box(nx=2, ny=2, nz=2)
    flip = sq.tets.copy()
    flip[5] = flip[5, [1, 0, 2, 3]]
    above = np.vstack([UNIT, [0.2, 0.2, 2.0], [0.3, 0.2, -1.0]])
    edge_pair = np.vstack([UNIT, [[0.5, -1, -1], [0.2, -1, -0.5]]])
    a, b = cc.box(nx=1, ny=1, nz=1), cc.box(x=(0.5, 1.5), y=(0.5, 1.5), z=(0.5, 1.5), nx=1, ny=1, nz=1)
    return [
        (UNIT[:, :2], [[0, 1, 2, 3]], None, r"points must be an \(n, 3\) array"),
        (np.vstack([UNIT[:3], [np.nan, 0, 1]]), [[0, 1, 2, 3]], None, "NaN or infinite coordinates, e.g. node 3"),
        (UNIT, [[0, 1, 2]], None, r"tets must be a non-empty \(m, 4\) array"),
        (UNIT, [[0, 1, 2, 4]], None, r"tetrahedron 0 \(nodes \[0, 1, 2, 4\]\) refers to nodes outside 0..3"),
        (UNIT, [[0, 1, 2, 2]], None, "tetrahedron 0 repeats a node"),
        (UNIT, [[0.0, 1, 2, 3]], None, "integer node indices"),
        (np.vstack([UNIT, [5, 5, 5]]), [[0, 1, 2, 3]], None, "1 node.s. belong to no tetrahedron, e.g. node 4"),
        (np.vstack([UNIT, [1e-12, 0, 0]]), [[0, 1, 2, 3], [4, 2, 1, 3]], None, "duplicate nodes 0 and 4"),
        (np.vstack([UNIT[:3], [0.5, 0.5, 1e-14]]), [[0, 1, 2, 3]], None, "degenerate .flat. tetrahedra, e.g. "
                                                                         "tetrahedron 0"),
        (sq.points, flip, None, "oriented against the rest .* e.g. tetrahedron 5"),
        (np.vstack([UNIT, [0.3, 0.3, 2.0], [0.2, 0.2, -1.0]]), [[0, 1, 2, 3], [0, 1, 2, 4], [0, 2, 1, 5]], None,
         "is shared by 3 tetrahedra"),
        (above[:5], [[0, 1, 2, 3], [0, 1, 2, 4]], None, "tetrahedra 0 and 1 .* lie on the same side of their "
                                                        r"common face \[0, 1, 2\]"),
        (edge_pair, positive(edge_pair, [[0, 1, 2, 3], [0, 1, 4, 5]]), None,
         r"boundary edge \(0, 1\) .* lies on 4 boundary faces"),
        (np.vstack([UNIT, -UNIT[1:]]), positive(np.vstack([UNIT, -UNIT[1:]]), [[0, 1, 2, 3], [0, 4, 5, 6]]), None,
         "node 0 .* joins 2 separate fans"),
        (*ring_around_an_edge(2), None, r"interior edge \(0, 1\) .* turn 2.000 times around it"),
        (np.vstack([a.points, b.points]), np.vstack([a.tets, b.tets + 8]), None, "lies inside 1 other layer"),
        (*crossing_bars(), None, "boundary faces .* meet near .* the boundary surface cuts through itself"),
        (*curled_strip(2.2 * np.pi), None, "boundary faces .* meet near .* the boundary surface cuts through itself"),
        (UNIT, [[0, 1, 2, 3]], {"x": [[0, 1, 4]]}, "boundary part 'x' refers to nodes outside"),
        (UNIT, [[0, 1, 2, 3]], {"x": [[0, 1]]}, r"non-empty \(k, 3\) array"),
        (sq.points, sq.tets, {"inner": [[13, 14, 4]]}, "boundary part 'inner': 1 face.s. are not on the boundary"),
        (UNIT, [[0, 1, 2, 3]], [[0, 1, 2]], "boundaries must be a dict"),
    ]
