"""P1 triangle meshes with named boundary parts.

A :class:`Mesh` is an array of points (metres), an array of counter-clockwise
triangles and a dictionary of tagged boundary edges. It is validated once, when
built, so every later stage can trust it.
"""

from __future__ import annotations

import contextlib
import io
from functools import cached_property
from pathlib import Path

import numpy as np

from ..errors import MeshError

__all__ = ["Mesh", "rectangle", "read_mesh"]


class Mesh:
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

    Raises
    ------
    MeshError
        On non-finite or badly shaped arrays, indices out of range, duplicate
        or unused nodes, inverted or degenerate triangles, or a tagged edge
        that is not an edge on the boundary of the triangulation.
    """

    def __init__(self, points, triangles, boundaries=None):
        self.points = _as_points(points)
        self.triangles = _as_triangles(triangles, len(self.points))
        _check_nodes(self.points, self.triangles)
        self.triangles = _orient(self.points, self.triangles)
        self._boundary_keys, self._boundary_edges = _boundary_edges(self.triangles, len(self.points))
        self._tags = {}
        for tag, edges in (boundaries or {}).items():
            self._tags[str(tag)] = self._orient_edges(str(tag), edges)

    def __repr__(self):
        return (f"Mesh({len(self.points)} nodes, {len(self.triangles)} triangles, "
                f"tags={list(self._tags)})")

    @property
    def tags(self) -> tuple[str, ...]:
        """Names of the tagged boundary parts."""
        return tuple(self._tags)

    @cached_property
    def areas(self) -> np.ndarray:
        """(m,) triangle areas in m^2."""
        areas = _signed_areas(self.points, self.triangles)
        areas.setflags(write=False)
        return areas

    @property
    def size(self) -> float:
        """Length of the bounding-box diagonal, in metres."""
        return float(np.linalg.norm(np.ptp(self.points, axis=0)))

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 2) edges carrying ``tag``, oriented as in their triangle (domain on the left)."""
        try:
            return self._tags[tag]
        except KeyError:
            raise MeshError(f"unknown boundary tag {tag!r}; this mesh has {sorted(self._tags)}") from None

    def boundary_nodes(self, tags) -> np.ndarray:
        """Sorted unique node indices on the union of the parts named in ``tags``."""
        edges = [self.boundary(t) for t in tags]
        return np.unique(np.concatenate(edges)) if edges else np.zeros(0, dtype=int)

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


# --------------------------------------------------------------------------- validation helpers

def _as_points(points):
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] not in (2, 3) or len(p) < 3:
        raise MeshError(f"points must be an (n, 2) array with n >= 3, got shape {p.shape}")
    if p.shape[1] == 3:
        if np.ptp(p[:, 2]) > 1e-12 * max(np.ptp(p[:, :2]), 1.0):
            raise MeshError("points have a varying third coordinate; cvxcontact meshes are planar (x, y)")
        p = p[:, :2]
    if not np.isfinite(p).all():
        raise MeshError("points contain NaN or infinite coordinates")
    return np.ascontiguousarray(p)


def _as_triangles(triangles, n):
    t = np.asarray(triangles)
    if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0:
        raise MeshError(f"triangles must be a non-empty (m, 3) array, got shape {t.shape}")
    if not np.issubdtype(t.dtype, np.integer):
        raise MeshError("triangles must hold integer node indices")
    if t.min() < 0 or t.max() >= n:
        raise MeshError(f"triangles refer to nodes outside 0..{n - 1}")
    return np.ascontiguousarray(t, dtype=np.int64)


def _check_nodes(points, triangles):
    used = np.zeros(len(points), dtype=bool)
    used[triangles.ravel()] = True
    if not used.all():
        raise MeshError(f"{int((~used).sum())} node(s) belong to no triangle, e.g. node {int(np.argmin(used))}")
    scale = max(float(np.ptp(points, axis=0).max()), np.finfo(float).tiny)
    order = np.lexsort(points.T[::-1])
    gap = np.abs(np.diff(points[order], axis=0)).max(axis=1)
    dup = gap <= 1e-12 * scale
    if dup.any():
        i = int(np.argmax(dup))
        raise MeshError(f"duplicate nodes {int(order[i])} and {int(order[i + 1])} at "
                        f"{points[order[i]].tolist()}")


def _signed_areas(points, triangles):
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _orient(points, triangles):
    area = _signed_areas(points, triangles)
    scale = float(np.ptp(points, axis=0).max()) ** 2
    tiny = np.abs(area) <= 1e-14 * scale
    if tiny.any():
        raise MeshError(f"{int(tiny.sum())} degenerate (zero-area) triangle(s), e.g. triangle "
                        f"{int(np.argmax(tiny))}: nodes {triangles[np.argmax(tiny)].tolist()}")
    negative = area < 0
    if negative.all():
        return triangles[:, [0, 2, 1]]
    if negative.any():
        k = int(np.argmax(negative) if negative.sum() <= len(area) / 2 else np.argmin(negative))
        raise MeshError(f"inverted triangles: {int(min(negative.sum(), (~negative).sum()))} triangle(s) are "
                        f"oriented against the rest (the mesh folds over), e.g. triangle {k}: "
                        f"nodes {triangles[k].tolist()}")
    return triangles


def _boundary_edges(triangles, n):
    """Sorted keys and oriented node pairs of the edges that belong to exactly one triangle."""
    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keys = np.sort(edges, axis=1) @ np.array([n, 1])
    uniq, first, count = np.unique(keys, return_index=True, return_counts=True)
    if (count > 2).any():
        raise MeshError("an edge is shared by more than two triangles: the mesh is not a manifold")
    once = count == 1
    return uniq[once], edges[first[once]]


# --------------------------------------------------------------------------- generators and readers

def rectangle(x=(0.0, 1.0), y=(0.0, 1.0), nx=8, ny=8, diagonal="alternate") -> Mesh:
    """Structured triangulation of the rectangle ``x[0]..x[1]`` by ``y[0]..y[1]`` (metres).

    Each of the ``nx`` by ``ny`` cells is cut into two triangles. ``diagonal`` is
    ``"right"`` (all cuts /), ``"left"`` (all cuts \\) or ``"alternate"`` (a chequer
    pattern, mirror-symmetric about the vertical centre line when ``nx`` is even).
    The boundary parts are tagged ``"left"``, ``"right"``, ``"bottom"``, ``"top"``.
    """
    (x0, x1), (y0, y1) = (_interval(x, "x"), _interval(y, "y"))
    nx, ny = _count(nx, "nx"), _count(ny, "ny")
    _check_size(nx, ny)
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
    return Mesh(points, triangles, boundaries)


def _interval(v, name):
    try:
        a, b = (float(s) for s in v)
    except (TypeError, ValueError):
        raise MeshError(f"{name} must be a pair (start, end) of numbers, got {v!r}") from None
    if not (np.isfinite(a) and np.isfinite(b) and b > a):
        raise MeshError(f"{name} must be a finite interval with end > start, got {v!r}")
    return a, b


def _count(n, name):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise MeshError(f"{name} must be a positive integer, got {n!r}")
    return int(n)


MAX_CELLS = 10**8
"""Largest ``nx * ny`` that :func:`rectangle` accepts, whatever the machine."""

BYTES_PER_NODE = 10_000
"""Memory of a solve per mesh node (bytes), piezoelectric body, condensed method: measured
peak 9.9 kB per node at 1e5 nodes (the full CVXPY model needs about twice as much)."""


def _physical_memory():
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
    have = _physical_memory()
    if have and need > have:
        raise MeshError(f"rectangle: nx*ny = {cells:.3g} cells, ~{nodes:.3g} nodes (~{3 * nodes:.3g} unknowns), "
                        f"needs ~{need / 1e9:.3g} GB to solve, machine has {have / 1e9:.3g} GB; "
                        "use fewer cells")


def read_mesh(path, boundaries=None, region=None) -> Mesh:
    """Read a triangle mesh with meshio (gmsh ``.msh``, VTU, XDMF, ...).

    Boundary parts are the line cells, named by gmsh physical names (``field_data``)
    or, without names, by their physical number as a string. Unused nodes (geometry
    points) are dropped. ``boundaries`` may add or override parts as node pairs in
    the file's numbering. ``region`` selects the triangles of one physical surface
    (by name or number) of a file that holds several bodies; its boundary parts are
    the tagged lines on that surface's boundary.

    Raises
    ------
    MeshError
        If the file is missing or unreadable, holds no linear triangles or holds
        higher-order elements, or ``region`` names no physical surface of the file.
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
    higher = kinds & {"triangle6", "triangle7", "quad", "quad8", "quad9", "tetra", "hexahedron"}
    if higher:
        raise MeshError(f"mesh file {str(path)!r} holds {sorted(higher)} cells; cvxcontact needs linear triangles")
    blocks = [k for k, b in enumerate(m.cells) if b.type == "triangle"]
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
        keys, _ = _boundary_edges(renumber[triangles], len(used))
        for tag, edges in list(parts.items()):
            inside = (renumber[edges] >= 0).all(axis=1)
            e = np.sort(renumber[edges[inside]], axis=1) @ np.array([len(used), 1])
            keep = np.isin(e, keys)
            parts[tag] = edges[inside][keep]
            if not keep.any():
                del parts[tag]
    for tag, edges in parts.items():
        if (renumber[edges] < 0).any():
            raise MeshError(f"boundary part {tag!r} in {str(path)!r} uses nodes that belong to no triangle")
    return Mesh(m.points[used], renumber[triangles], {t: renumber[e] for t, e in parts.items()})


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
