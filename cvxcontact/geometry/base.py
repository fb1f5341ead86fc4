"""The base every mesh shares (:class:`~cvxcontact.geometry.mesh.Mesh`, :class:`~cvxcontact.geometry.quadmesh.
QuadMesh`, :class:`~cvxcontact.geometry.tetmesh.TetMesh`, :class:`~cvxcontact.geometry.hexmesh.HexMesh`).

A mesh is immutable (:class:`~cvxcontact.errors.Frozen`) and answers its ``dim`` (2 or 3), its ``cell`` (the key
of the spaces with the degree: "triangle", "quad", "tetra", "hex"), ``points`` (n, dim) m, ``cells`` (m, k),
``tags`` and ``boundary(tag)`` (the tagged edges or faces), ``components``/``node_components``, ``with_points``
and ``renumbered``; what is written once for all of them lives here.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..errors import Frozen

__all__ = ["CellMesh"]


class CellMesh(Frozen):
    """What every mesh shares (module docstring): the node sets of its boundary parts and its size."""

    dim: int
    cell: str

    @property
    def tags(self) -> tuple[str, ...]:
        """Names of the tagged boundary parts."""
        return tuple(self._tags)

    @property
    def size(self) -> float:
        """Length of the bounding-box diagonal, in metres."""
        return float(np.linalg.norm(np.ptp(self.points, axis=0)))

    def boundary_nodes(self, tags: Iterable[str] | str) -> np.ndarray:
        """Sorted unique node indices on the union of the parts named in ``tags`` (a name or names)."""
        parts = [self.boundary(t) for t in ([tags] if isinstance(tags, str) else tags)]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.int64)
