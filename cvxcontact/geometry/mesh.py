"""P1 triangle meshes with named boundary parts.

A :class:`Mesh` is an array of points (metres), an array of counter-clockwise
triangles and a dictionary of tagged boundary edges. It is validated once, when
built, and its arrays are read-only copies, so every later stage can trust it
(use :meth:`Mesh.with_points` to move or scale a mesh).
"""

from __future__ import annotations

import contextlib
import io
import os
from collections.abc import Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import FrozenMap, MeshError, locked
from .base import CellMesh, cell_corners
from .meshchecks import (
    as_points,
    boundary_edges,
    check_embedding,
    check_nodes,
    checked_renumbering,
    edge_table,
    orient,
    signed_areas,
)

if TYPE_CHECKING:
    from .hexmesh import HexMesh
    from .quadmesh import QuadMesh
    from .tetmesh import TetMesh

__all__ = ["Mesh", "rectangle", "read_mesh"]


class Mesh(CellMesh):
    """A conforming P1 triangulation of one body in the (x1, x3) plane.

    Parameters
    ----------
    points : (n, 2) array_like of float
        Node coordinates in metres.
    triangles : (m, 3) array_like of int
        Node indices of each triangle. A mesh oriented clockwise throughout is
        reoriented; a mesh with mixed orientation is folded and rejected.
    boundaries : dict of str to (k, 2) array_like of int, optional
        Named boundary parts, each a list of boundary edges (node index pairs).

    Notes
    -----
    The mesh is immutable: it keeps read-only copies of its arrays (editing ``points``,
    ``triangles`` or a boundary part in place raises ``ValueError``) and assigning an attribute
    raises :class:`~cvxcontact.errors.FrozenError`; build a new mesh instead (:meth:`with_points`).

    Raises
    ------
    MeshError
        On non-finite or badly shaped arrays, indices out of range, duplicate
        or unused nodes, inverted or degenerate triangles, triangles that
        overlap or fold over one another (each point of the body must be
        covered once), or a tagged edge that is not an edge on the boundary of
        the triangulation.
    """

    dim = 2
    """Spatial dimension (a :class:`~cvxcontact.geometry.tetmesh.TetMesh` has 3)."""
    cell = "triangle"
    """The cell type (the key of the spaces, :func:`cvxcontact.fem.space.space`)."""

    def __init__(self, points: ArrayLike, triangles: ArrayLike,
                 boundaries: Mapping[str, ArrayLike] | None = None) -> None:
        points = as_points(points)
        triangles = cell_corners(triangles, 3, "triangles", len(points))
        check_nodes(points, triangles)
        triangles = orient(points, triangles)
        self._set(_points=locked(points, float), _triangles=locked(triangles, np.int64))
        table = edge_table(self._triangles, len(points))
        keys, edges = boundary_edges(self._triangles, len(points), table)
        check_embedding(self._points, self._triangles, edges, table)
        self._set(_boundary_keys=locked(keys, np.int64), _boundary_edges=locked(edges, np.int64))
        if boundaries is not None and not isinstance(boundaries, Mapping):
            raise MeshError(f"boundaries must be a dict mapping tags to (k, 2) arrays of node pairs, "
                            f"got {type(boundaries).__name__}")
        self._set(_tags=FrozenMap({str(tag): locked(self._orient_edges(str(tag), tagged), np.int64)
                                   for tag, tagged in (boundaries or {}).items()},
                                  "Mesh boundaries", "build a new Mesh"))

    def _frozen_hint(self, name: str) -> str:
        return "build a new Mesh (mesh.with_points(points) moves or scales it; cc.Mesh(points, triangles, boundaries))"

    def __repr__(self) -> str:
        return (f"Mesh({len(self.points)} nodes, {len(self.triangles)} triangles, "
                f"tags={list(self._tags)})")

    @property
    def points(self) -> np.ndarray:
        """(n, 2) node coordinates in metres (read-only)."""
        return self._points

    @property
    def triangles(self) -> np.ndarray:
        """(m, 3) node indices of the counter-clockwise triangles (read-only)."""
        return self._triangles

    @property
    def cells(self) -> np.ndarray:
        """(m, 3) the elements: :attr:`triangles` (the name shared with the 3D mesh's tetrahedra)."""
        return self._triangles

    def with_points(self, points: ArrayLike) -> Mesh:
        """A new validated mesh with the same triangles and tags on new node coordinates (metres).

        For scaling or moving a mesh, e.g. ``mesh.with_points(1e-3 * mesh.points)``.
        """
        p = np.asarray(points)
        if p.shape != self.points.shape:
            raise MeshError(f"with_points needs an array of shape {self.points.shape} (one (x, y) per node, "
                            f"metres), got shape {p.shape}")
        return Mesh(p, self.triangles, {t: self.boundary(t) for t in self.tags})

    def renumbered(self, order: ArrayLike) -> Mesh:
        """The same mesh with its nodes numbered in a new order: node i of the new mesh is node ``order[i]``
        of this one.

        ``order`` is a permutation of 0..n-1 (n nodes). The points are ``self.points[order]``, the
        triangles and every tagged part keep their order with their node indices renumbered, so a nodal
        field ``f`` of this mesh is ``f[order]`` on the new one (and ``g[np.argsort(order)]`` takes a field
        ``g`` of the new mesh back). The body, its parts and its cells are unchanged: only the numbering,
        and with it the order of the unknowns, differs.

        Raises
        ------
        MeshError
            If ``order`` is not a permutation of the node indices.
        """
        order, new = checked_renumbering(order, len(self.points))
        return Mesh(self.points[order], new[self.triangles], {t: new[self.boundary(t)] for t in self.tags})

    @cached_property
    def areas(self) -> np.ndarray:
        """(m,) triangle areas in m^2."""
        areas = signed_areas(self.points, self.triangles)
        return locked(areas)

    @cached_property
    def vertex_areas(self) -> np.ndarray:
        """(n,) m^2: a third of the area of each triangle at each of its vertices, summed (read-only): the
        consistent nodal load of a constant density per unit of it."""
        share = np.bincount(self.triangles.ravel(), weights=np.repeat(self.areas / 3.0, 3), minlength=len(self.points))
        return locked(share)

    @cached_property
    def node_components(self) -> np.ndarray:
        """(n,) connected-component label of each node (read-only).

        Two nodes are connected when a chain of triangle edges joins them (the
        embedding checks make node and edge adjacency agree). Components are
        numbered 0, 1, ... in the order of their lowest node index.
        """
        t = self.triangles
        n = len(self.points)
        graph = coo_matrix((np.ones(3 * len(t)), (t.ravel(), t[:, [1, 2, 0]].ravel())), shape=(n, n))
        _, labels = connected_components(graph, directed=False)
        _, first = np.unique(labels, return_index=True)
        rank = np.empty(len(first), dtype=np.int64)
        rank[np.argsort(first)] = np.arange(len(first))   # number by lowest node index
        return locked(rank[labels], np.int64)

    @cached_property
    def components(self) -> np.ndarray:
        """(m,) connected-component label of each triangle (read-only), as in :attr:`node_components`.

        ``components.max() + 1`` is the number of separate pieces of the body.
        """
        return locked(self.node_components[self.triangles[:, 0]], np.int64)

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 2) edges carrying ``tag``, oriented as in their triangle (domain on the left; read-only)."""
        try:
            return self._tags[tag]
        except KeyError:
            raise MeshError(f"unknown boundary tag {tag!r}; this mesh has {sorted(self._tags)}") from None

    def outward_normals(self, tag: str) -> np.ndarray:
        """(k, 2) unit outward normals of the edges carrying ``tag``."""
        edges = self.boundary(tag)
        t = self.points[edges[:, 1]] - self.points[edges[:, 0]]
        return np.column_stack([t[:, 1], -t[:, 0]]) / np.linalg.norm(t, axis=1)[:, None]

    def _orient_edges(self, tag, edges):
        edges = np.asarray(edges)
        if edges.ndim != 2 or edges.shape[1] != 2 or edges.shape[0] == 0:
            raise MeshError(f"boundary part {tag!r} must be a non-empty (k, 2) array of node pairs, "
                            f"got shape {edges.shape}")
        if not np.issubdtype(edges.dtype, np.integer):
            raise MeshError(f"boundary part {tag!r} must hold integer node indices")
        n = len(self.points)
        if edges.min() < 0 or edges.max() >= n:
            raise MeshError(f"boundary part {tag!r} refers to nodes outside 0..{n - 1}")
        keys = np.sort(edges, axis=1) @ np.array([n, 1])
        where = np.searchsorted(self._boundary_keys, keys)
        where = np.minimum(where, len(self._boundary_keys) - 1)
        bad = self._boundary_keys[where] != keys
        if bad.any():
            raise MeshError(f"boundary part {tag!r}: {int(bad.sum())} edge(s) are not on the boundary "
                            f"of the triangulation, e.g. nodes {edges[bad][0].tolist()}")
        return self._boundary_edges[where]


# --------------------------------------------------------------------------- generators and readers

def rectangle(x: Sequence[float] = (0.0, 1.0), y: Sequence[float] = (0.0, 1.0), nx: int = 8, ny: int = 8,
              diagonal: str = "alternate", segments: Mapping[str, tuple] | None = None,
              cell: str = "triangle") -> Mesh | QuadMesh:
    """Structured mesh of the rectangle ``x[0]..x[1]`` by ``y[0]..y[1]`` (metres).

    ``cell="quad"``: the ``nx`` by ``ny`` cells themselves, a
    :class:`~cvxcontact.geometry.quadmesh.QuadMesh` (``diagonal`` unused), the same boundary tags.
    ``cell="triangle"`` (default): each cell is cut into two triangles. ``diagonal`` is
    ``"right"`` (all cuts /), ``"left"`` (all cuts \\) or ``"alternate"`` (a chequer
    pattern, mirror-symmetric about the vertical centre line when ``nx`` is even).
    The boundary parts are tagged ``"left"``, ``"right"``, ``"bottom"``, ``"top"``.
    ``segments`` names sub-segments of the sides as extra tags (the sides keep theirs):
    ``{"footprint": ("top", 0.25, 0.75)}`` tags the edges of the top side between x = 0.25
    and 0.75 m (for "left"/"right", between two ordinates); both ends must be grid nodes.
    """
    (x0, x1), (y0, y1) = (as_interval(x, "x"), as_interval(y, "y"))
    nx, ny = positive_count(nx, "nx"), positive_count(ny, "ny")
    _check_size(nx, ny)
    if cell not in ("triangle", "quad"):
        raise MeshError(f"cell must be 'triangle' or 'quad', got {cell!r}")
    if diagonal not in ("right", "left", "alternate"):
        raise MeshError(f"diagonal must be 'right', 'left' or 'alternate', got {diagonal!r}")
    X, Y = np.meshgrid(np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1))
    points = np.column_stack([X.ravel(), Y.ravel()])
    node = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    sw, se, nw, ne = (node[:-1, :-1].ravel(), node[:-1, 1:].ravel(), node[1:, :-1].ravel(), node[1:, 1:].ravel())
    j, i = np.divmod(np.arange(nx * ny), nx)
    cut = {"right": np.ones(nx * ny, bool), "left": np.zeros(nx * ny, bool),
           "alternate": (i + j) % 2 == 0}[diagonal]
    slash = np.stack([np.column_stack([sw, se, ne]), np.column_stack([sw, ne, nw])], axis=1)
    backslash = np.stack([np.column_stack([sw, se, nw]), np.column_stack([se, ne, nw])], axis=1)
    triangles = np.where(cut[:, None, None], slash, backslash).reshape(-1, 3)
    boundaries = {
        "bottom": np.column_stack([node[0, :-1], node[0, 1:]]),
        "right": np.column_stack([node[:-1, -1], node[1:, -1]]),
        "top": np.column_stack([node[-1, 1:], node[-1, :-1]]),
        "left": np.column_stack([node[1:, 0], node[:-1, 0]]),
    }
    boundaries.update(segment_parts(segments, boundaries, points, "rectangle"))
    if cell == "quad":
        from .quadmesh import QuadMesh

        return QuadMesh(points, np.column_stack([sw, se, ne, nw]), boundaries)
    return Mesh(points, triangles, boundaries)


def segment_parts(segments, sides, points, where) -> dict:
    """The extra tags ``segments`` (name -> (side, start, end), m) of a structured generator: the edges of
    ``sides`` (the four side tags -> edges) between the two coordinates, on the node ``points``."""
    if segments is None:
        return {}
    if not isinstance(segments, Mapping):
        raise MeshError(f"{where}: segments must map new tag names to (side, start, end) in m, e.g. "
                        f"segments={{\"footprint\": (\"top\", 0.25, 0.75)}} (in a scene file: segments = "
                        f"{{ footprint = [\"top\", 0.25, 0.75] }}), got {segments!r}")
    return {name: _segment(name, spec, sides, points) for name, spec in segments.items()}


def _segment(name, spec, sides, points):
    """The edges of side ``spec[0]`` between the coordinates ``spec[1]`` and ``spec[2]`` (m)."""
    if not isinstance(name, str) or name in sides:
        raise MeshError(f"segments: the name {name!r} must be a new tag (a string other than {sorted(sides)})")
    try:
        side, a, b = spec
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        raise MeshError(f"segments[{name!r}]: expected (side, start, end) with side one of "
                        f"{sorted(sides)}, got {spec!r}") from None
    if side not in ("left", "right", "bottom", "top") or not (np.isfinite(a) and np.isfinite(b) and b > a):
        raise MeshError(f"segments[{name!r}]: expected (side, start, end) with side one of "
                        f"['bottom', 'left', 'right', 'top'] and start < end, got {spec!r}")
    edges = sides[side]
    axis = 0 if side in ("bottom", "top") else 1
    coord = points[edges, axis]                                   # (k, 2)
    grid = np.unique(coord)
    tol = 1e-9 * float(np.ptp(grid))
    for v in (a, b):
        if np.abs(grid - v).min() > tol:
            near = grid[np.argsort(np.abs(grid - v))[:2]]
            raise MeshError(f"segments[{name!r}]: {v:.9g} m is not a grid node of side {side!r} (nearest "
                            f"{sorted(near.tolist())}); choose nx, ny so that the ends fall on grid lines")
    inside = (coord.min(axis=1) >= a - tol) & (coord.max(axis=1) <= b + tol)
    return edges[inside]


def as_interval(v, name):
    """(start, end) (m) of the pair ``v``, checked finite with end > start (a MeshError naming ``name`` otherwise)."""
    try:
        a, b = (float(s) for s in v)
    except (TypeError, ValueError):
        raise MeshError(f"{name} must be a pair (start, end) of numbers, got {v!r}") from None
    if not (np.isfinite(a) and np.isfinite(b) and b > a):
        raise MeshError(f"{name} must be a finite interval with end > start, got {v!r}")
    return a, b


def positive_count(n, name):
    """``n`` as an int, checked to be a positive integer (a MeshError naming the argument ``name`` otherwise)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise MeshError(f"{name} must be a positive integer, got {n!r}")
    return int(n)


MAX_CELLS = 10**8
"""Largest ``nx * ny`` that :func:`rectangle` accepts, whatever the machine."""

BYTES_PER_NODE = 10_000
"""Memory of a solve per mesh node (bytes), piezoelectric body, condensed method: measured
peak 9.9 kB per node at 1e5 nodes (the full CVXPY model needs about twice as much)."""


def physical_memory():
    """The machine's physical memory in bytes, or None if the system does not say."""
    import os

    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def _check_size(nx, ny):
    """Refuse a rectangle too large to build or to solve on this machine (before allocating)."""
    cells, nodes = nx * ny, (nx + 1) * (ny + 1)
    need = nodes * BYTES_PER_NODE
    if cells > MAX_CELLS:
        raise MeshError(f"rectangle: nx*ny = {cells:.3g} cells is more than the limit of {MAX_CELLS:.0e} cells "
                        f"(~{nodes:.3g} nodes, ~{3 * nodes:.3g} unknowns)")
    have = physical_memory()
    if have and need > have:
        raise MeshError(f"rectangle: nx*ny = {cells:.3g} cells, ~{nodes:.3g} nodes (~{3 * nodes:.3g} unknowns), "
                        f"needs ~{need / 1e9:.3g} GB to solve, machine has {have / 1e9:.3g} GB; "
                        "use fewer cells")


def read_mesh(path: str | os.PathLike[str], boundaries: Mapping[str, ArrayLike] | None = None,
              region: str | int | None = None) -> Mesh | TetMesh | HexMesh:
    """Read a triangle mesh with meshio (gmsh ``.msh``, VTU, XDMF, ...).

    A file holding tetrahedra (``tetra`` or ``tetra10``) is read as a 3D
    :class:`~cvxcontact.geometry.tetmesh.TetMesh` instead: its boundary parts are the
    triangle cells, named by their physical surface, and ``region`` selects a physical
    volume (:func:`cvxcontact.geometry.tetmesh.read_tets`).

    Boundary parts are the line cells, named by gmsh physical names (``field_data``)
    or, without names, by their physical number as a string. Unused nodes (geometry
    points) are dropped. ``boundaries`` may add or override parts as node pairs in
    the file's numbering. ``region`` selects the triangles of one physical surface
    (by name or number) of a file that holds several bodies; its boundary parts are
    the tagged lines on that surface's boundary.

    Second-order gmsh meshes (``triangle6`` with ``line3`` boundary lines) are read as
    their corner triangles: the P2 nodes of ``degree=2`` are rebuilt as the edge
    midpoints (:class:`cvxcontact.geometry.quadratic.P2Nodes`), so every edge must be
    straight with its mid-node at its midpoint (checked).

    Quadrilaterals (``quad``, or ``quad9`` read as their corners the same way, the centre node at the
    image of the cell's centre by its bilinear map) give a
    :class:`~cvxcontact.geometry.quadmesh.QuadMesh` (Q1, Q2 with ``degree=2``); hexahedra (``hexahedron``,
    ``hexahedron27`` with ``quad``/``quad9`` faces) a :class:`~cvxcontact.geometry.hexmesh.HexMesh`
    (:func:`cvxcontact.geometry.hexmesh.read_hexes`).

    Raises
    ------
    MeshError
        If the file is missing or unreadable, holds no triangles, holds other
        higher-order elements or curved second-order edges, mixes triangle and
        triangle6 cells, or ``region`` names no physical surface of the file.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise MeshError(f"mesh file {str(path)!r} does not exist")
    try:
        with contextlib.redirect_stdout(io.StringIO()):   # meshio prints to stdout on some formats
            m = meshio.read(path)
    except (Exception, SystemExit) as exc:  # meshio raises many types, and exits on unknown formats
        # the exception text may quote the file's content: name only its type
        raise MeshError(f"cannot read mesh file {str(path)!r} ({type(exc).__name__} in meshio); expected a "
                        "triangle mesh in a format meshio reads (gmsh .msh, .vtu, .xdmf, ...)") from None
    kinds = {block.type for block in m.cells}
    if kinds & {"tetra", "tetra10"}:
        from .tetmesh import read_tets

        return read_tets(m, path, boundaries, region)
    if kinds & {"hexahedron", "hexahedron27"}:
        from .hexmesh import read_hexes

        return read_hexes(m, path, boundaries, region)
    cell = "quad" if kinds & {"quad", "quad9"} else "triangle"
    higher = kinds & {"triangle7", "quad8", "hexahedron"} | (kinds & {"triangle", "triangle6"} if cell == "quad" else set())
    if higher:
        raise MeshError(f"mesh file {str(path)!r} holds {sorted(higher)} cells; cvxcontact reads triangles "
                        "(triangle, triangle6) or quadrilaterals (quad, quad9), one kind per file")
    for first, second in (("triangle", "triangle6"), ("quad", "quad9")):
        if second in kinds:
            if first in kinds:
                raise MeshError(f"mesh file {str(path)!r} mixes {first} and {second} cells")
            m = _corner_mesh(m, path)
    blocks = [k for k, b in enumerate(m.cells) if b.type == cell]
    if not blocks:
        raise MeshError(f"mesh file {str(path)!r} holds no triangles (cell types: {sorted(kinds)})")
    triangles = np.concatenate([m.cells[k].data for k in blocks])
    if region is not None:
        triangles = triangles[_region_mask(m, blocks, region, path)]
    parts = _line_parts(m)
    parts.update({str(k): np.asarray(v) for k, v in (boundaries or {}).items()})
    used = np.unique(triangles)
    renumber = np.full(len(m.points), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    if region is not None:                                    # keep the lines on this region's boundary
        corners = renumber[triangles]
        if cell == "quad":                                    # the same boundary as its cells cut in two
            corners = corners[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3)
        keys, _ = boundary_edges(corners, len(used))
        for tag, edges in list(parts.items()):
            inside = (renumber[edges] >= 0).all(axis=1)
            e = np.sort(renumber[edges[inside]], axis=1) @ np.array([len(used), 1])
            keep = np.isin(e, keys)
            parts[tag] = edges[inside][keep]
            if not keep.any():
                del parts[tag]
    for tag, edges in parts.items():
        if (renumber[edges] < 0).any():
            raise MeshError(f"boundary part {tag!r} in {str(path)!r} uses nodes that belong to no {cell}")
    tagged = {t: renumber[e] for t, e in parts.items()}
    if cell == "quad":
        from .quadmesh import QuadMesh

        return QuadMesh(m.points[used], renumber[triangles], tagged)
    return Mesh(m.points[used], renumber[triangles], tagged)


def _corner_mesh(m, path):
    """A second-order mesh as its corner triangles and end-point lines (same points, cell data kept);
    refuses curved edges (a mid-node off its edge's midpoint by more than 1e-9 of the edge length)."""
    import meshio

    cells = []
    for block in m.cells:
        d = block.data
        pairs = {"triangle6": [(0, 1, 3), (1, 2, 4), (2, 0, 5)], "line3": [(0, 1, 2)],
                 "quad9": [(0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7), (4, 6, 8)]}.get(block.type, [])
        for a, b, c in pairs:
            mid = 0.5 * (m.points[d[:, a], :2] + m.points[d[:, b], :2])
            length = np.linalg.norm(m.points[d[:, a], :2] - m.points[d[:, b], :2], axis=1)
            if (np.linalg.norm(m.points[d[:, c], :2] - mid, axis=1) > 1e-9 * length).any():
                raise MeshError(f"mesh file {str(path)!r}: a {block.type} cell has a curved edge (mid-node off "
                                "the midpoint, or a quad9's centre node off the middle of its side midpoints: the image of the centre "
                                "by the bilinear map); "
                                "cvxcontact's P2 and Q2 elements are straight-sided")
        kind = {"triangle6": "triangle", "line3": "line", "quad9": "quad"}.get(block.type, block.type)
        corners = {"triangle": 3, "line": 2, "quad": 4}.get(kind)
        cells.append(meshio.CellBlock(kind, d[:, :corners] if corners else d))
    return meshio.Mesh(m.points, cells, cell_data=m.cell_data, field_data=m.field_data)


def _region_mask(m, blocks, region, path):
    """Boolean mask over the concatenated triangles of the physical surface ``region``."""
    physical = m.cell_data.get("gmsh:physical")
    names = {k: int(v[0]) for k, v in (m.field_data or {}).items() if len(v) > 1 and int(v[1]) == 2}
    ids = np.concatenate([physical[k] for k in blocks]) if physical is not None else None
    wanted = names.get(str(region), int(region) if str(region).isdigit() else None)
    if ids is None or wanted is None or not (ids == wanted).any():
        available = sorted(names) or sorted({str(int(i)) for i in np.unique(ids)}) if ids is not None else []
        raise MeshError(f"mesh file {str(path)!r} has no physical surface {region!r}; it has {available}")
    return ids == wanted


def _line_parts(m):
    names = {int(v[0]): k for k, v in (m.field_data or {}).items() if len(v) > 1 and int(v[1]) == 1}
    physical = m.cell_data.get("gmsh:physical")
    parts: dict[str, list] = {}
    for k, block in enumerate(m.cells):
        if block.type != "line":
            continue
        ids = physical[k] if physical is not None else np.zeros(len(block.data), dtype=int)
        for pid in np.unique(ids):
            name = names.get(int(pid), str(int(pid)))
            parts.setdefault(name, []).append(block.data[ids == pid])
    return {k: np.concatenate(v) for k, v in parts.items()}
