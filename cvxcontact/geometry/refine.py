"""Uniform (red) refinement of a triangle mesh: the nested meshes of a reference solution.

Each triangle (v0, v1, v2) is split into four by its edge midpoints m01, m12, m20 (straight edges, the
arithmetic means: a curved boundary stays the polygon it was, so the fine mesh covers exactly the coarse
one and every coarse P1 or P2 function is a fine one):

    (v0, m01, m20), (m01, v1, m12), (m20, m12, v2), (m01, m12, m20)

Tagged boundary edges (a, b) become (a, m), (m, b). The coarse vertices keep their indices; the
midpoints follow, numbered by sorted vertex pairs.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshError
from .mesh import Mesh

__all__ = ["refine_uniform"]


def refine_uniform(mesh: Mesh, times: int = 1) -> tuple[Mesh, np.ndarray]:
    """(fine mesh, parent): ``mesh`` refined ``times`` times (module docstring); ``parent`` (m_fine,) the
    index of the coarse triangle that contains each fine one (the children of triangle j are
    4^times consecutive rows from 4^times j)."""
    if not isinstance(mesh, Mesh):
        raise MeshError(f"refine_uniform takes a 2D cc.Mesh, got {type(mesh).__name__}")
    if isinstance(times, bool) or not isinstance(times, (int, np.integer)) or times < 0:
        raise MeshError(f"refine_uniform: times must be an integer >= 0, got {times!r}")
    parent = np.arange(len(mesh.triangles))
    for _ in range(times):
        mesh, up = _refine_once(mesh)
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
