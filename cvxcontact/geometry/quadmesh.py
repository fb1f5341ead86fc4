"""Quadrilateral meshes with named boundary parts (the cells of the Q1 and Q2 spaces).

A :class:`QuadMesh` is an array of points (metres), an array of counter-clockwise convex quadrilaterals
and a dictionary of tagged boundary edges. Its corners cut along one diagonal form a triangle
:class:`~cvxcontact.geometry.mesh.Mesh` (:attr:`QuadMesh.split`) that is validated as any triangle mesh
(nodes used once, no duplicates, no overlap or fold, tags on the boundary): both meshes have the same
points, boundary edges and pieces, so the checks, the boundary parts and the connected components live in
one place (``Mesh``) and the quadrilateral mesh adds only what is its own (convexity, areas, the cells).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError, locked
from .base import CellMesh, cell_corners
from .mesh import Mesh
from .meshchecks import as_points, checked_renumbering, one_orientation

__all__ = ["QuadMesh", "CONVEX_TOL"]

CONVEX_TOL = 1e-12
"""A corner whose triangle (previous, corner, next) has at most this times the square of the cell's
longest side as area is flat: the cell is degenerate or not strictly convex."""

EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
"""Local corners of the four sides of a quadrilateral, counter-clockwise (the order of the Q2 edge nodes:
gmsh quad9 / VTK_BIQUADRATIC_QUAD)."""


class QuadMesh(CellMesh):
    """A conforming mesh of convex quadrilaterals of one body in the (x1, x3) plane.

    Parameters
    ----------
    points : (n, 2) array_like of float
        Node coordinates in metres.
    quads : (m, 4) array_like of int
        Corner indices of each cell, in order around it. A mesh oriented clockwise throughout is
        reoriented; each cell must be strictly convex (its bilinear map is then one-to-one, with a
        positive Jacobian everywhere).
    boundaries : dict of str to (k, 2) array_like of int, optional
        Named boundary parts, each a list of boundary edges (node index pairs).

    Raises
    ------
    MeshError
        On badly shaped arrays, a degenerate, non-convex or inverted cell, mixed orientations, and everything
        :class:`~cvxcontact.geometry.mesh.Mesh` refuses of the triangles the cells split into.
    """

    dim = 2
    """Spatial dimension."""
    cell = "quad"
    """The cell type (the key of the spaces, :func:`cvxcontact.fem.space.space`)."""

    def __init__(self, points: ArrayLike, quads: ArrayLike, boundaries: Mapping[str, ArrayLike] | None = None) -> None:
        points = as_points(points)
        q = _orient(points, cell_corners(quads, 4, "quads", len(points)))
        split = Mesh(points, q[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3), boundaries)   # every Mesh check
        self._set(_points=split.points, _quads=locked(q, np.int64), split=split)

    def _frozen_hint(self, name: str) -> str:
        return "build a new QuadMesh (mesh.with_points(points) moves or scales it)"

    def __repr__(self) -> str:
        return f"QuadMesh({len(self.points)} nodes, {len(self.quads)} quadrilaterals, tags={list(self.tags)})"

    split: Mesh
    """The triangles of the cells cut along their diagonal (0, 2) (cell c: triangles 2 c and 2 c + 1): the
    mesh the checks ran on, and what a triangle plot draws."""

    @property
    def points(self) -> np.ndarray:
        """(n, 2) node coordinates in metres (read-only)."""
        return self._points

    @property
    def quads(self) -> np.ndarray:
        """(m, 4) corner indices of the counter-clockwise cells (read-only)."""
        return self._quads

    @property
    def cells(self) -> np.ndarray:
        """(m, 4) the elements: :attr:`quads`."""
        return self._quads

    @property
    def tags(self) -> tuple[str, ...]:
        """Names of the tagged boundary parts."""
        return self.split.tags

    @cached_property
    def areas(self) -> np.ndarray:
        """(m,) cell areas in m^2 (the two triangles of each cell)."""
        a = self.split.areas.reshape(-1, 2).sum(axis=1)
        return locked(a)

    @property
    def node_components(self) -> np.ndarray:
        """(n,) connected-component label of each node (as :attr:`Mesh.node_components`)."""
        return self.split.node_components

    @cached_property
    def components(self) -> np.ndarray:
        """(m,) connected-component label of each cell."""
        return locked(self.split.components[::2], np.int64)

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 2) edges carrying ``tag``, oriented as in their cell (domain on the left; read-only)."""
        return self.split.boundary(tag)

    def outward_normals(self, tag: str) -> np.ndarray:
        """(k, 2) unit outward normals of the edges carrying ``tag``."""
        return self.split.outward_normals(tag)

    def with_points(self, points: ArrayLike) -> QuadMesh:
        """A new validated mesh with the same cells and tags on new node coordinates (metres)."""
        p = np.asarray(points)
        if p.shape != self.points.shape:
            raise MeshError(f"with_points needs an array of shape {self.points.shape} (one (x, y) per node, "
                            f"metres), got shape {p.shape}")
        return QuadMesh(p, self.quads, {t: self.boundary(t) for t in self.tags})

    def renumbered(self, order: ArrayLike) -> QuadMesh:
        """The same mesh with node i of the new mesh node ``order[i]`` of this one (as :meth:`Mesh.renumbered`)."""
        order, new = checked_renumbering(order, len(self.points))
        return QuadMesh(self.points[order], new[self.quads], {t: new[self.boundary(t)] for t in self.tags})


def _orient(points, quads):
    """``quads`` counter-clockwise (a mesh clockwise throughout is reversed); MeshError on a degenerate or
    non-convex cell or on mixed orientations."""
    p = points[quads]                                            # (m, 4, 2)
    before, after = np.roll(p, 1, axis=1) - p, np.roll(p, -1, axis=1) - p
    corner = after[..., 0] * before[..., 1] - after[..., 1] * before[..., 0]     # 2 x area at each corner
    side = np.linalg.norm(after, axis=2).max(axis=1)
    flat = np.abs(corner) <= CONVEX_TOL * side[:, None] ** 2
    if flat.any():
        k = int(np.argmax(flat.any(axis=1)))
        raise MeshError(f"quadrilateral {k} (nodes {quads[k].tolist()}) is degenerate (a flat corner); expected "
                        "strictly convex cells")
    positive = corner > 0
    mixed = positive.any(axis=1) & ~positive.all(axis=1)
    if mixed.any():
        k = int(np.argmax(mixed))
        raise MeshError(f"quadrilateral {k} (nodes {quads[k].tolist()}) is not convex or its corners are not in "
                        "order around it; expected strictly convex cells with corners listed around the cell")
    return one_orientation(quads, positive.all(axis=1), [3, 2, 1, 0], ("quadrilaterals", "cell(s)", "cell"))
