"""The base every mesh shares (:class:`~cvxcontact.geometry.mesh.Mesh`, :class:`~cvxcontact.geometry.quadmesh.
QuadMesh`, :class:`~cvxcontact.geometry.tetmesh.TetMesh`, :class:`~cvxcontact.geometry.hexmesh.HexMesh`).

A mesh is immutable (:class:`~cvxcontact.errors.Frozen`) and answers its ``dim`` (2 or 3), its ``cell`` (the key
of the spaces with the degree: "triangle", "quad", "tetra", "hex"), ``points`` (n, dim) m, ``cells`` (m, k),
``tags`` and ``boundary(tag)`` (the tagged edges or faces), ``components``/``node_components``, ``with_points``
and ``renumbered``; what is written once for all of them lives here.
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import cached_property

import numpy as np

from ..errors import Frozen, MeshError, locked

__all__ = ["CellMesh", "cell_corners"]


class CellMesh(Frozen):
    """What every mesh shares (module docstring): the node sets of its boundary parts and its size."""

    dim: int
    cell: str

    @property
    def tags(self) -> tuple[str, ...]:
        """Names of the tagged boundary parts."""
        return tuple(self._tags)

    @cached_property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lowest, highest) (dim,) m: the corners of the bounding box (computed once: the points are read-only)."""
        low, high = self.points.min(axis=0), self.points.max(axis=0)
        return locked(low), locked(high)

    @property
    def size(self) -> float:
        """Length of the bounding-box diagonal, in metres."""
        low, high = self.bounds
        return float(np.linalg.norm(high - low))

    def boundary_nodes(self, tags: Iterable[str] | str) -> np.ndarray:
        """Sorted unique node indices on the union of the parts named in ``tags`` (a name or names)."""
        parts = [self.boundary(t) for t in ([tags] if isinstance(tags, str) else tags)]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.int64)

    def cells_at(self, tag: str) -> np.ndarray:
        """Sorted indices of the cells with a node on the boundary part ``tag`` (formed once per part and kept:
        the mesh is immutable)."""
        kept = self.__dict__.setdefault("_cells_at", {})
        if tag not in kept:
            touched = np.zeros(len(self.points), dtype=bool)
            touched[self.boundary_nodes(tag)] = True
            kept[tag] = locked(np.flatnonzero(touched[self.cells].any(axis=1)))
        return kept[tag]

    def node_set(self, nodes=None):
        """The node set a body's unknowns live on: ``nodes`` (another node set of this mesh with ``points``,
        ``cells``, ``boundary_nodes`` and ``node_components``, e.g. its P2 nodes), else the mesh itself (its
        vertices)."""
        return self if nodes is None else nodes


def cell_corners(cells, corners: int, name: str, n: int) -> np.ndarray:
    """``cells`` as a contiguous int64 (m, ``corners``) array of node indices below ``n``; MeshError naming the
    array (``name``) where it is empty, of another shape, not integer or refers to a node that does not exist."""
    c = np.asarray(cells)
    if c.ndim != 2 or c.shape[1] != corners or len(c) == 0:
        raise MeshError(f"{name} must be a non-empty (m, {corners}) array of corner indices, got shape {c.shape}")
    if not np.issubdtype(c.dtype, np.integer):
        raise MeshError(f"{name} must hold integer node indices")
    if c.min() < 0 or c.max() >= n:
        raise MeshError(f"{name} refer to nodes outside 0..{n - 1}")
    return np.ascontiguousarray(c, dtype=np.int64)
