"""Uniform (red) refinement of a triangle or tetrahedron mesh: the nested meshes of a reference solution.

Each triangle (v0, v1, v2) is split into four by its edge midpoints m01, m12, m20 (straight edges, the
arithmetic means: a curved boundary stays the polygon it was, so the fine mesh covers exactly the coarse
one and every coarse P1 or P2 function is a fine one):

    (v0, m01, m20), (m01, v1, m12), (m20, m12, v2), (m01, m12, m20)

Tagged boundary edges (a, b) become (a, m), (m, b). The coarse vertices keep their indices; the
midpoints follow, numbered by sorted vertex pairs.

A tetrahedron (v0, v1, v2, v3) is split into eight by its edge midpoints m_ij (Bey, "Tetrahedral grid
refinement", Computing 55, 1995): the four corner tetrahedra (v_i and the midpoints of its three edges) and
the inner octahedron cut into four along its shortest diagonal (m01-m23, m02-m13 or m03-m12), each child
oriented positively. Tagged boundary faces split into four as the triangles above.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshError
from .mesh import Mesh
from .tetmesh import TetMesh

__all__ = ["refine_uniform"]


def refine_uniform(mesh: Mesh | TetMesh, times: int = 1) -> tuple[Mesh | TetMesh, np.ndarray]:
    """(fine mesh, parent): ``mesh`` refined ``times`` times (module docstring); ``parent`` (m_fine,) the
    index of the coarse cell that contains each fine one (the children of cell j are c^times consecutive
    rows from c^times j, c = 4 for triangles, 8 for tetrahedra)."""
    if not isinstance(mesh, (Mesh, TetMesh)):
        raise MeshError(f"refine_uniform takes a cc.Mesh (2D) or cc.TetMesh (3D), got {type(mesh).__name__}")
    if isinstance(times, bool) or not isinstance(times, (int, np.integer)) or times < 0:
        raise MeshError(f"refine_uniform: times must be an integer >= 0, got {times!r}")
    parent = np.arange(len(mesh.cells))
    once = _refine_tets if isinstance(mesh, TetMesh) else _refine_once
    for _ in range(times):
        mesh, up = once(mesh)
        parent = parent[up]
    return mesh, parent


def _refine_once(mesh: Mesh) -> tuple[Mesh, np.ndarray]:
    p, tri = mesh.points, mesh.triangles
    nv = len(p)
    pairs = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1), axis=2)   # (m, 3, 2)
    keys = pairs[..., 0].astype(np.int64) * nv + pairs[..., 1]
    unique, inverse = np.unique(keys.ravel(), return_inverse=True)
    mid = nv + inverse.reshape(-1, 3)                                    # m01, m12, m20
    edges = np.column_stack([unique // nv, unique % nv])
    points = np.concatenate([p, 0.5 * (p[edges[:, 0]] + p[edges[:, 1]])])
    v0, v1, v2 = tri.T
    m01, m12, m20 = mid.T
    fine = np.stack([np.column_stack(c) for c in ((v0, m01, m20), (m01, v1, m12), (m20, m12, v2),
                                                   (m01, m12, m20))], axis=1).reshape(-1, 3)
    tags = {}
    for tag in mesh.tags:
        e = mesh.boundary(tag)
        m = nv + np.searchsorted(unique, np.minimum(e[:, 0], e[:, 1]).astype(np.int64) * nv + np.maximum(e[:, 0], e[:, 1]))
        tags[tag] = np.concatenate([np.column_stack([e[:, 0], m]), np.column_stack([m, e[:, 1]])])
    return Mesh(points, fine, tags), np.repeat(np.arange(len(tri)), 4)


_TET_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def _refine_tets(mesh: TetMesh) -> tuple[TetMesh, np.ndarray]:
    p, tets = mesh.points, mesh.tets
    nv = len(p)
    pairs = np.sort(tets[:, _TET_EDGES], axis=2)                                      # (m, 6, 2)
    keys = pairs[..., 0].astype(np.int64) * nv + pairs[..., 1]
    unique, inverse = np.unique(keys.ravel(), return_inverse=True)
    mid = nv + inverse.reshape(-1, 6)
    edges = np.column_stack([unique // nv, unique % nv])
    points = np.concatenate([p, 0.5 * (p[edges[:, 0]] + p[edges[:, 1]])])
    v0, v1, v2, v3 = tets.T
    m01, m02, m03, m12, m13, m23 = mid.T
    corners = [(v0, m01, m02, m03), (m01, v1, m12, m13), (m02, m12, v2, m23), (m03, m13, m23, v3)]
    # the octahedron (m01, m02, m03, m12, m13, m23) around each diagonal (a, b): its four other vertices
    # form the cycle (c0, c1, c2, c3), and the children are (a, b, c_i, c_i+1)
    diagonals = [((m01, m23), (m02, m12, m13, m03)), ((m02, m13), (m01, m12, m23, m03)),
                 ((m03, m12), (m01, m02, m23, m13))]
    length = np.stack([np.linalg.norm(points[a] - points[b], axis=1) for (a, b), _ in diagonals], axis=1)
    choice = np.argmin(length, axis=1)
    inner = np.zeros((len(tets), 4, 4), dtype=np.int64)
    for j, ((a, b), cycle) in enumerate(diagonals):
        at = choice == j
        for i in range(4):
            inner[at, i] = np.column_stack([a, b, cycle[i], cycle[(i + 1) % 4]])[at]
    fine = np.concatenate([np.stack([np.column_stack(c) for c in corners], axis=1), inner], axis=1).reshape(-1, 4)
    a = points[fine[:, 0]]
    volume = np.einsum("ij,ij->i", points[fine[:, 1]] - a, np.cross(points[fine[:, 2]] - a, points[fine[:, 3]] - a))
    fine[volume < 0] = fine[volume < 0][:, [0, 2, 1, 3]]                             # every child positive
    tags = {}
    for tag in mesh.tags:
        f = mesh.boundary(tag)
        m = [nv + np.searchsorted(unique, np.minimum(f[:, i], f[:, j]).astype(np.int64) * nv + np.maximum(f[:, i], f[:, j]))
             for i, j in ((0, 1), (1, 2), (2, 0))]
        tags[tag] = np.concatenate([np.column_stack(c) for c in ((f[:, 0], m[0], m[2]), (m[0], f[:, 1], m[1]),
                                                                 (m[2], m[1], f[:, 2]), (m[0], m[1], m[2]))])
    return TetMesh(points, fine, tags), np.repeat(np.arange(len(tets)), 8)
