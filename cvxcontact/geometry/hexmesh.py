"""Hexahedral meshes with named boundary parts (the cells of the 3D Q1 and Q2 spaces).

A :class:`HexMesh` is an array of points (metres), an array of hexahedra (8 corners in the VTK_HEXAHEDRON /
gmsh order: the bottom face 0-1-2-3 counter-clockwise seen from above, then the top face 4-5-6-7 above it)
and a dictionary of tagged boundary faces, each a quadrilateral of 4 corners. As :class:`~cvxcontact.geometry.
quadmesh.QuadMesh` rests on the triangle :class:`~cvxcontact.geometry.mesh.Mesh` its cells split into, a
HexMesh rests on a :class:`~cvxcontact.geometry.tetmesh.TetMesh` (:attr:`HexMesh.split`): every cell cut into
12 tetrahedra from its centre to the two triangles of each face, the face cut along the diagonal through its
corner of lexicographically smallest (x, y, z) (a rule of the coordinates alone, so that neighbouring cells,
and the matching faces of two bodies, cut a shared face the same way). The split is validated as any
tetrahedral mesh (no overlap, no fold, tags on the boundary, components), so the checks, the boundary
surface and the connected components live in one place (``TetMesh``); the hexahedral mesh adds what is its own
(a positive Jacobian of the trilinear map at every corner, the quadrilateral faces, the cells' volumes). The
3D contact surfaces are the split's triangles (:attr:`triangulation`): the vertices of a face are its
corners.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from ..errors import FrozenMap, MeshError, locked
from .base import CellMesh, cell_corners
from .meshchecks import checked_renumbering, one_orientation
from .tetmesh import TetMesh, as_points3

__all__ = ["HexMesh", "HEX_FACES", "HEX_EDGES", "CORNERS", "read_hexes"]

CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)
"""The reference corners of a hexahedron in [-1, 1]^3 (VTK_HEXAHEDRON / gmsh order)."""

HEX_FACES = np.array([[0, 4, 7, 3], [1, 2, 6, 5], [0, 1, 5, 4], [3, 7, 6, 2], [0, 3, 2, 1], [4, 5, 6, 7]])
"""Local corners of the six faces (x = -1, +1, y = -1, +1, z = -1, +1), each in order around it with the
right-hand normal pointing out of the cell (the order of the VTK_TRIQUADRATIC_HEXAHEDRON face nodes)."""

HEX_EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4],
                      [0, 4], [1, 5], [2, 6], [3, 7]])
"""Local corners of the twelve edges, in the VTK_QUADRATIC/TRIQUADRATIC_HEXAHEDRON order of the edge nodes."""


class HexMesh(CellMesh):
    """A conforming mesh of hexahedra of one body in (x, y, z) space.

    Parameters
    ----------
    points : (n, 3) array_like of float
        Node coordinates in metres.
    hexes : (m, 8) array_like of int
        Corner indices of each cell (module docstring). A mesh whose cells are all mirrored (left-handed) is
        reoriented; the trilinear map of each cell must have a positive Jacobian at its eight corners.
    boundaries : dict of str to (k, 4) array_like of int, optional
        Named boundary parts, each a list of boundary faces (4 corners in order around the face, either
        direction; stored oriented outwards).

    Raises
    ------
    MeshError
        On badly shaped arrays, a cell with a non-positive corner Jacobian, mixed orientations, a tagged face
        that is not a boundary face, and everything :class:`~cvxcontact.geometry.tetmesh.TetMesh` refuses of the
        tetrahedra the cells split into.
    """

    dim = 3
    """Spatial dimension."""
    cell = "hex"
    """The cell type (the key of the spaces, :func:`cvxcontact.fem.space.space`)."""

    def __init__(self, points: ArrayLike, hexes: ArrayLike, boundaries: Mapping[str, ArrayLike] | None = None) -> None:
        points = as_points3(points)
        h = _orient(points, cell_corners(hexes, 8, "hexes", len(points)))
        faces = h[:, HEX_FACES].reshape(-1, 4)                                 # (6 m, 4) outward
        keys = np.sort(faces, axis=1)
        uniq, first, count = np.unique(keys, axis=0, return_index=True, return_counts=True)
        if (count > 2).any():
            k = int(np.argmax(count > 2))
            raise MeshError(f"face {uniq[k].tolist()} is shared by {int(count[k])} hexahedra (at most two)")
        owned = np.sort(first[count == 1])
        bfaces = faces[owned]
        if boundaries is not None and not isinstance(boundaries, Mapping):
            raise MeshError(f"boundaries must be a dict mapping tags to (k, 4) arrays of face corners, "
                            f"got {type(boundaries).__name__}")
        tags = {str(t): _tagged(str(t), f, bfaces, len(points)) for t, f in (boundaries or {}).items()}
        rank = np.empty(len(points), dtype=np.int64)
        rank[np.lexsort(points.T[::-1])] = np.arange(len(points))            # lexicographic (x, y, z)
        centres = points[h].mean(axis=1)
        tets = _split_cells(faces, rank, len(points) + np.repeat(np.arange(len(h)), 6))
        split = TetMesh(np.concatenate([points, centres]), tets,
                        {t: _triangles(f, rank) for t, f in tags.items()})
        self._set(_points=split.points[:len(points)], _hexes=locked(h, np.int64), split=split,
                  _boundary_faces=locked(bfaces, np.int64), boundary_cells=locked(owned // 6, np.int64),
                  _tags=FrozenMap({t: locked(f, np.int64) for t, f in tags.items()}, "HexMesh boundaries",
                                  "build a new HexMesh"))

    def _frozen_hint(self, name: str) -> str:
        return "build a new HexMesh (mesh.with_points(points) moves or scales it)"

    def __repr__(self) -> str:
        return f"HexMesh({len(self.points)} nodes, {len(self.hexes)} hexahedra, tags={list(self.tags)})"

    split: TetMesh
    """The 12 tetrahedra of each cell (module docstring; cell c: tetrahedra 12 c .. 12 c + 11), on the points
    followed by the cells' centres: the mesh the checks ran on and whose boundary triangles are the contact
    surfaces' (:attr:`triangulation`)."""

    boundary_cells: np.ndarray
    """(k,) the cell that owns each of :attr:`boundary_faces` (read-only)."""

    @property
    def triangulation(self) -> TetMesh:
        """The tetrahedral mesh whose boundary triangles stand for the faces on a contact surface (the split:
        each face's two triangles on its four corners)."""
        return self.split

    @property
    def points(self) -> np.ndarray:
        """(n, 3) node coordinates in metres (read-only)."""
        return self._points

    @property
    def hexes(self) -> np.ndarray:
        """(m, 8) corner indices of the cells (read-only)."""
        return self._hexes

    @property
    def cells(self) -> np.ndarray:
        """(m, 8) the elements: :attr:`hexes`."""
        return self._hexes

    @property
    def boundary_faces(self) -> np.ndarray:
        """(k, 4) every face on the boundary, oriented outwards (read-only)."""
        return self._boundary_faces

    @cached_property
    def volumes(self) -> np.ndarray:
        """(m,) cell volumes in m^3 (the integral of det J by the 2 x 2 x 2 Gauss rule, exact for the trilinear
        map)."""
        t = 1.0 / np.sqrt(3.0)
        X = self.points[self.hexes]
        vol = sum(_jacobian(X, np.array([a, b, c]) * t)[1] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1))
        return locked(vol, float)

    @property
    def node_components(self) -> np.ndarray:
        """(n,) connected-component label of each node (as :attr:`TetMesh.node_components`)."""
        return self.split.node_components[:len(self.points)]

    @cached_property
    def components(self) -> np.ndarray:
        """(m,) connected-component label of each cell."""
        return locked(self.split.components[::12], np.int64)

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 4) faces carrying ``tag``, corners in order around each with the right-hand normal outward
        (read-only)."""
        try:
            return self._tags[tag]
        except KeyError:
            raise MeshError(f"unknown boundary tag {tag!r}; this mesh has {sorted(self._tags)}") from None

    def outward_normals(self, tag: str) -> np.ndarray:
        """(k, 3) unit outward normals of the faces carrying ``tag`` (at each face's centre: the cross product of
        its diagonals)."""
        n = _diagonal_cross(self.points, self.boundary(tag))
        return n / np.linalg.norm(n, axis=1)[:, None]

    def face_areas(self, tag: str) -> np.ndarray:
        """(k,) areas of the faces carrying ``tag`` (m^2; the bilinear faces, 3 x 3 Gauss, exact when planar)."""
        X = self.points[self.boundary(tag)]                                    # (k, 4, 3)
        t, w = np.polynomial.legendre.leggauss(3)
        area = np.zeros(len(X))
        for a, wa in zip(t, w):
            for b, wb in zip(t, w):
                dxi = np.array([[-(1 - b), -(1 - a)], [1 - b, -(1 + a)], [1 + b, 1 + a], [-(1 + b), 1 - a]]) / 4
                J = np.einsum("kid,ia->kad", X, dxi)
                area += wa * wb * np.linalg.norm(np.cross(J[:, 0], J[:, 1]), axis=1)
        return area

    def node_areas(self, tag: str) -> np.ndarray:
        """(n,) the area (m^2) of the faces carrying ``tag`` attributed to each node: the integral of its bilinear
        (Q1) hat over them (2 x 2 Gauss, exact on parallelograms; a quarter of such a face to each corner), zero
        off the part. Positive on the part's nodes (the hats are non-negative on a convex face): the lumped
        areas of a contact law and of the pressure read-back."""
        faces = self.boundary(tag)
        X = self.points[faces]                                                 # (k, 4, 3)
        out = np.zeros(len(self.points))
        t = np.array([-1.0, 1.0]) / np.sqrt(3.0)
        for a in t:
            for b in t:
                N = np.array([(1 - a) * (1 - b), (1 + a) * (1 - b), (1 + a) * (1 + b), (1 - a) * (1 + b)]) / 4
                dxi = np.array([[-(1 - b), -(1 - a)], [1 - b, -(1 + a)], [1 + b, 1 + a], [-(1 + b), 1 - a]]) / 4
                J = np.einsum("kid,ia->kad", X, dxi)
                da = np.linalg.norm(np.cross(J[:, 0], J[:, 1]), axis=1)
                out += np.bincount(faces.T.ravel(), weights=(N[:, None] * da[None]).ravel(), minlength=len(out))
        return out

    def with_points(self, points: ArrayLike) -> HexMesh:
        """A new validated mesh with the same cells and tags on new node coordinates (metres)."""
        p = np.asarray(points)
        if p.shape != self.points.shape:
            raise MeshError(f"with_points needs an array of shape {self.points.shape} (one (x, y, z) per node, "
                            f"metres), got shape {p.shape}")
        return HexMesh(p, self.hexes, {t: self.boundary(t) for t in self.tags})

    def renumbered(self, order: ArrayLike) -> HexMesh:
        """The same mesh with node i of the new mesh node ``order[i]`` of this one (as :meth:`TetMesh.renumbered
        <cvxcontact.geometry.tetmesh.TetMesh.renumbered>`)."""
        order, new = checked_renumbering(order, len(self.points))
        return HexMesh(self.points[order], new[self.hexes], {t: new[self.boundary(t)] for t in self.tags})


def _jacobian(X, xi):
    """(J (m, 3, 3) dx_d/dxi_a as [m, a, d], det J (m,)) of the trilinear map of the cells with corners X (m, 8, 3)
    at the reference point ``xi`` (3,)."""
    f = 1 + CORNERS * np.asarray(xi, dtype=float)                                  # (8, 3)
    dN = np.stack([CORNERS[:, a] * f[:, (a + 1) % 3] * f[:, (a + 2) % 3] for a in range(3)]) / 8   # (3, 8)
    J = np.einsum("mid,ai->mad", X, dN)
    return J, np.linalg.det(J)


def _orient(points, hexes):
    """``hexes`` right-handed (a mesh mirrored throughout has its bottom and top swapped); MeshError on a corner
    with a non-positive Jacobian of the trilinear map or on mixed orientations."""
    X = points[hexes]
    e = X[:, HEX_EDGES[:, 1]] - X[:, HEX_EDGES[:, 0]]
    scale = (np.linalg.norm(e, axis=2).max(axis=1)) ** 3
    det = np.stack([_jacobian(X, c)[1] for c in CORNERS], axis=1) * 8 / scale[:, None]
    flat = np.abs(det) <= 1e-12
    if flat.any():
        k = int(np.argmax(flat.any(axis=1)))
        raise MeshError(f"hexahedron {k} (nodes {hexes[k].tolist()}) is degenerate at a corner (a flat corner); "
                        "expected cells with three independent edges at every corner")
    positive = det > 0
    mixed = positive.any(axis=1) & ~positive.all(axis=1)
    if mixed.any():
        k = int(np.argmax(mixed))
        raise MeshError(f"hexahedron {k} (nodes {hexes[k].tolist()}) is inverted at some corners (its trilinear "
                        "map folds over; or its corners are not in the VTK order: bottom face 0-1-2-3 around it, "
                        "then the top face 4-5-6-7 above it)")
    return one_orientation(hexes, positive.all(axis=1), [4, 5, 6, 7, 0, 1, 2, 3], ("hexahedra", "cell(s)", "cell"))


def _diagonal_cut(faces, rank):
    """(k, 2, 3) the two triangles of each quadrilateral face (k, 4) (corners in order around it; the
    triangles in the same direction), cut along the diagonal through the corner of lowest ``rank``."""
    low = np.argmin(rank[faces], axis=1) % 2 == 0                       # the diagonal (0, 2), else (1, 3)
    a = np.stack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]], axis=1)
    b = np.stack([faces[:, [1, 2, 3]], faces[:, [1, 3, 0]]], axis=1)
    return np.where(low[:, None, None], a, b)


def _split_cells(faces, rank, centre):
    """(12 m, 4) positive tetrahedra: each outward face triangle (reversed) with its cell's centre node."""
    tri = _diagonal_cut(faces, rank)                                    # (6 m, 2, 3) outward
    apex = np.repeat(centre, 2)[:, None]
    return np.concatenate([tri.reshape(-1, 3)[:, [0, 2, 1]], apex], axis=1)


def _triangles(quads, rank):
    return _diagonal_cut(quads, rank).reshape(-1, 3)


def _tagged(tag, faces, bfaces, n):
    """The boundary faces ``bfaces`` (outward) that ``faces`` (k, 4) name; MeshError if one is not there."""
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 4 or len(f) == 0:
        raise MeshError(f"boundary part {tag!r} must be a non-empty (k, 4) array of face corners, got shape {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise MeshError(f"boundary part {tag!r} must hold integer node indices")
    if f.min() < 0 or f.max() >= n:
        raise MeshError(f"boundary part {tag!r} refers to nodes outside 0..{n - 1}")
    keys = _rows(np.sort(bfaces, axis=1))        # one record per face, compared lexicographically (no base-n
    order = np.argsort(keys, kind="stable")       # key: n^4 overflows int64 from 55,109 nodes)
    keys = keys[order]
    want = _rows(np.sort(f, axis=1))
    pos = np.minimum(np.searchsorted(keys, want), len(keys) - 1)
    bad = keys[pos] != want
    if bad.any():
        raise MeshError(f"boundary part {tag!r}: {int(bad.sum())} face(s) are not on the boundary of the mesh, "
                        f"e.g. nodes {f[bad][0].tolist()}")
    return bfaces[order[pos]]


def _rows(a) -> np.ndarray:
    """(k,) the rows of the integer array ``a`` (k, c) as records of c int64 fields: NumPy sorts, searches and
    compares them lexicographically."""
    a = np.ascontiguousarray(a, dtype=np.int64)
    return a.view(np.dtype([(f"f{j}", np.int64) for j in range(a.shape[1])])).ravel()


def _diagonal_cross(points, faces):
    return np.cross(points[faces[:, 2]] - points[faces[:, 0]], points[faces[:, 3]] - points[faces[:, 1]])


def read_hexes(m, path, boundaries: Mapping[str, ArrayLike] | None = None, region: str | int | None = None) -> HexMesh:
    """The :class:`HexMesh` of a meshio mesh ``m`` read from ``path`` (called by
    :func:`~cvxcontact.geometry.mesh.read_mesh` for files holding hexahedra).

    Boundary parts are the quadrilateral cells (``quad``, ``quad9``), named by gmsh physical names (dimension 2) or,
    without names, by their physical number as a string; ``boundaries`` may add or override parts as corner
    quadruples in the file's numbering. Second-order ``hexahedron27`` files (meshio's order, converted from gmsh's
    by meshio) are read as their corner hexahedra: the Q2 space rebuilds the other 19 nodes as the means of the
    corners they stand on, so each must lie there (checked, 1e-9 of the cell's longest edge). Unused nodes are
    dropped; ``region`` (one physical volume of several) is not read for hexahedra.
    """
    kinds = {block.type for block in m.cells}
    if {"hexahedron", "hexahedron27"} <= kinds:
        raise MeshError(f"mesh file {str(path)!r} mixes hexahedron and hexahedron27 cells")
    other = kinds & {"tetra", "tetra10", "wedge", "pyramid", "hexahedron20", "triangle", "triangle6"}
    if other:
        raise MeshError(f"mesh file {str(path)!r} holds {sorted(other)} cells next to hexahedra; cvxcontact's "
                        "hexahedral meshes hold hexahedra (hexahedron, hexahedron27) with quadrilateral faces only")
    if region is not None:
        raise MeshError(f"mesh file {str(path)!r}: region= is not read for hexahedra yet; write one body per file")
    blocks = [b.data for b in m.cells if b.type in ("hexahedron", "hexahedron27")]
    points = np.asarray(m.points, dtype=float)
    if points.shape[1] != 3:
        raise MeshError(f"mesh file {str(path)!r} holds hexahedra with {points.shape[1]}D points; expected 3D")
    for data in blocks:
        if data.shape[1] == 27:
            X = points[data[:, :8]]                          # the order of Q2HexNodes: edges, faces, centre
            expected = np.concatenate([X, X[:, HEX_EDGES].mean(axis=2), X[:, HEX_FACES].mean(axis=2),
                                       X.mean(axis=1, keepdims=True)], axis=1)
            edge = np.linalg.norm(points[data[:, HEX_EDGES[:, 0]]] - points[data[:, HEX_EDGES[:, 1]]], axis=2)
            off = np.linalg.norm(points[data] - expected, axis=2).max(axis=1)
            bad = off > 1e-9 * edge.max(axis=1)
            if bad.any():
                k = int(np.argmax(bad))
                raise MeshError(f"mesh file {str(path)!r}: hexahedron27 cell {k} has a node off the mean of its "
                                "corners (a curved edge or face, or another node order); cvxcontact's Q2 hexahedra "
                                "are the images of the trilinear map")
    hexes = np.concatenate([b[:, :8] for b in blocks]).astype(np.int64)
    physical = m.cell_data.get("gmsh:physical")
    names = {int(v[0]): k for k, v in (m.field_data or {}).items() if len(v) > 1 and int(v[1]) == 2}
    parts: dict[str, list] = {}
    for k, block in enumerate(m.cells):
        if block.type not in ("quad", "quad9"):
            continue
        ids = physical[k] if physical is not None else np.zeros(len(block.data), dtype=int)
        for pid in np.unique(ids):
            parts.setdefault(names.get(int(pid), str(int(pid))), []).append(block.data[ids == pid, :4])
    faces = {tag: np.concatenate(v).astype(np.int64) for tag, v in parts.items()}
    faces.update({str(k): np.asarray(v) for k, v in (boundaries or {}).items()})
    used = np.unique(hexes)
    renumber = np.full(len(points), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    for tag, f in faces.items():
        if (renumber[f] < 0).any():
            raise MeshError(f"boundary part {tag!r} in {str(path)!r} uses nodes that belong to no hexahedron")
    return HexMesh(points[used], renumber[hexes], {t: renumber[f] for t, f in faces.items()})
