"""Local refinement of tensor-product grids of quadrilaterals and hexahedra: the meshes of adaptive refinement
on Q1/Q2 cells without hanging nodes.

A mesh is a tensor grid when its nodes are the product of sorted coordinate lists x_0 < ... < x_nx,
y_0 < ... < y_ny (and z_0 < ... < z_nz in 3D) and its cells are the grid's cells, each the box
[x_i, x_i+1] x [y_j, y_j+1] (x [z_k, z_k+1]): what :func:`~cvxcontact.geometry.mesh.rectangle`,
:func:`~cvxcontact.geometry.generators.graded_block` and :func:`~cvxcontact.geometry.generators3d.box` make
with ``cell="quad"`` or ``"hex"`` (graded or not, with named segments and patches). :func:`tensor_grid`
detects it from the points and cells alone, whatever the nodes' numbering and the corner each cell is listed
from (a structured grid read from a gmsh file is one; an unstructured quadrilateral mesh, or a grid turned out
of the axes, is none).

:func:`refine_grid` bisects every column and row (every slab in 3D) of the grid that holds a marked cell: a
marked cell splits into 4 (8), and so does every cell sharing one of its columns or rows, which splits in two
(the price of conformity without hanging nodes: the whole strip through a marked cell is refined, so the
unknowns grow as the strips' lengths, not as the marked cells). The result is again a tensor grid, graded
towards the marked cells, conforming, covering exactly the same box; each boundary tag goes to the fine
facets inside its coarse facets, so lengths and areas of every tag are kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError
from .hexmesh import HEX_EDGES, HEX_FACES, HexMesh
from .quadmesh import EDGES, QuadMesh

__all__ = ["GRID_TOL", "Grid", "face_lines", "refine_grid", "tensor_grid"]

GRID_TOL = 1e-10
"""Coordinates of two nodes that differ by at most this times the mesh's size (its bounding-box diagonal) lie on
the same grid line (:func:`tensor_grid`)."""

_GRIDS = {
    QuadMesh: (np.array([[0, 0], [1, 0], [1, 1], [0, 1]]), EDGES, EDGES),
    HexMesh: (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]),
              HEX_FACES, HEX_EDGES),
}
"""Mesh type -> (the grid offsets of a cell's corners in the mesh's corner order, the local corners of its facets
(edges, faces) in order around each with the domain on the left / the normal outward, the local corners of its
edges)."""


@dataclass(frozen=True)
class Grid:
    """A tensor grid found in a mesh (:func:`tensor_grid`).

    ``axes``: the sorted coordinates of the grid lines along x, y (z), m; ``index``: (n, dim) the grid index of
    each node of the mesh; ``lower``: (m, dim) the grid index of each cell's lowest corner (cell c is the box
    of ``axes[d][lower[c, d]]`` to ``axes[d][lower[c, d] + 1]``)."""

    axes: tuple
    index: np.ndarray
    lower: np.ndarray


def tensor_grid(mesh) -> Grid | None:
    """The :class:`Grid` of ``mesh`` if it is a tensor grid of quadrilaterals or hexahedra (module docstring),
    else None.

    The grid lines along each axis are the node coordinates clustered within :data:`GRID_TOL` times the mesh's
    size, each line at the mean of its cluster (the very value its nodes share when they agree: a grid given
    exactly keeps its coordinates bit for bit, one given with rounding noise is straightened); the mesh is a grid
    when every product of grid lines is exactly one node and the cells are the grid's cells, one each, each
    cell's corners the corners of its box with its edges along the box's edges (the mesh's corner order up to a
    rotation of the cell: a cell listed from another corner is the same box)."""
    kind = _GRIDS.get(type(mesh))
    if kind is None:
        return None
    p, cells = mesh.points, mesh.cells
    tol = GRID_TOL * mesh.size
    axes, index = [], np.empty(p.shape, dtype=np.int64)
    for d in range(mesh.dim):
        order = np.argsort(p[:, d], kind="stable")
        v = p[order, d]
        line = np.concatenate([[0], np.cumsum(np.diff(v) > tol)])
        index[order, d] = line
        first = v[np.concatenate([[0], np.flatnonzero(np.diff(line)) + 1])]      # each line's lowest value
        spread = np.bincount(line, v - first[line]) / np.bincount(line)        # 0 where the values are equal
        axes.append(first + spread)                     # the mean, bit for bit the value that all nodes share
    shape = tuple(len(a) for a in axes)
    if len(p) != np.prod(shape) or len(cells) != np.prod([s - 1 for s in shape]):
        return None
    if len(np.unique(np.ravel_multi_index(index.T, shape))) != len(p):
        return None
    lower = index[cells].min(axis=1)                                             # (m, dim)
    offset = index[cells] - lower[:, None, :]                                    # (m, corners, dim)
    corner = offset @ (1 << np.arange(mesh.dim))                                 # which corner of its box
    if offset.max(initial=0) > 1 or not (np.sort(corner, axis=1) == np.arange(2 ** mesh.dim)).all():
        return None                                          # a cell that is not one grid box
    step = np.abs(offset[:, kind[2][:, 1]] - offset[:, kind[2][:, 0]]).sum(axis=2)
    if (step != 1).any():
        return None                                          # its corners not in order around the box
    cell_shape = tuple(s - 1 for s in shape)
    if len(np.unique(np.ravel_multi_index(lower.T, cell_shape))) != len(cells):
        return None
    return Grid(axes=tuple(axes), index=index, lower=lower)


def refine_grid(mesh: QuadMesh | HexMesh, times: ArrayLike,
                lines: tuple | None = None) -> tuple[QuadMesh | HexMesh, np.ndarray]:
    """(fine mesh, parent): the tensor grid ``mesh`` with every grid interval (column, row, slab) that holds a
    cell T cut into 2^times[T] equal pieces (the most any of its cells asks), so that T splits into at least
    2^(dim times[T]) cells (module docstring); with ``lines``, every interval also cut as often as it takes to
    hold each of them (a partner's face lines, :func:`face_lines`: two faces meshed alike stay alike).

    Parameters
    ----------
    mesh : QuadMesh or HexMesh
        A tensor grid (:func:`tensor_grid`).
    times : (m,) bool or int array_like
        Per cell, how often to halve it along every axis (0: only as its strips ask); a mask is one halving of
        the marked cells.
    lines : tuple of dim array_like, optional
        Per axis, coordinates (m) the fine grid must hold; those strictly inside an interval must be dyadic
        points of it (a + j (b - a) / 2^k: lines a halving of the same coarse interval makes), others are
        ignored.

    Returns
    -------
    QuadMesh or HexMesh, (m_fine,) int array
        The fine grid (nodes numbered x fastest, then y, then z; the grid lines of ``mesh`` kept, new ones at the
        midpoints of the intervals they cut; the same tags, each on the fine facets inside its coarse ones) and
        ``parent``, the coarse cell that contains each fine one: a per-cell tag of the coarse mesh is
        ``tag[parent]`` on the fine one.

    Raises
    ------
    MeshError
        For a mesh that is not a tensor grid of quadrilaterals or hexahedra (mesh it with triangles or
        tetrahedra to refine it locally, or as a grid), ``times`` that is not one non-negative integer (or
        boolean) per cell, or a line that no halving of its interval makes (the faces were not meshed alike).
    """
    grid = tensor_grid(mesh)
    if grid is None:
        raise MeshError(f"refine_grid refines tensor grids of quadrilaterals or hexahedra (nodes the product of "
                        f"sorted coordinate lists, cells the grid's cells), got {mesh!r}: mesh the body with "
                        "triangles or tetrahedra (bisected locally: refine_marked), or as a grid (cc.rectangle, "
                        "cc.graded_block, cc.box with cell='quad' or 'hex')")
    times = np.asarray(times)
    if times.dtype == bool:
        times = times.astype(np.int64)
    if times.shape != (len(mesh.cells),) or not np.issubdtype(times.dtype, np.integer) or (times < 0).any():
        raise MeshError(f"refine_grid: times must be non-negative integers or a boolean mask, one per cell "
                        f"({len(mesh.cells)}), got dtype {times.dtype} and shape {times.shape}")
    offsets, facets, _ = _GRIDS[type(mesh)]
    dim = mesh.dim
    axes, coarse, fine_of = [], [], []          # fine grid lines; per fine interval its coarse one; node maps
    for d, a in enumerate(grid.axes):
        cuts = np.zeros(len(a) - 1, dtype=np.int64)
        np.maximum.at(cuts, grid.lower[:, d], times)
        if lines is not None:
            cuts = np.maximum(cuts, _halvings(a, lines[d], GRID_TOL * mesh.size))
        pieces = 2 ** cuts
        start = np.concatenate([[0], np.cumsum(pieces)])                        # fine index of each coarse line
        parent = np.repeat(np.arange(len(a) - 1), pieces)
        t = (np.arange(start[-1]) - start[parent]) / pieces[parent]
        axes.append(np.concatenate([a[parent] + t * (a[parent + 1] - a[parent]), a[-1:]]))
        coarse.append(parent)
        fine_of.append(start)
    shape = tuple(len(a) for a in axes)
    cell_shape = tuple(s - 1 for s in shape)
    grids = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([g.ravel(order="F") for g in grids])              # x fastest
    lower = np.column_stack([g.ravel(order="F") for g in np.meshgrid(*(np.arange(s) for s in cell_shape),
                                                                     indexing="ij")])
    corners = lower[:, None, :] + offsets[None]                                 # (m_fine, corners, dim)
    cells = np.ravel_multi_index(tuple(np.moveaxis(corners, -1, 0)), shape, order="F")
    coarse_lower = np.column_stack([coarse[d][lower[:, d]] for d in range(dim)])
    coarse_id = np.full(tuple(len(a) - 1 for a in grid.axes), -1, dtype=np.int64)
    coarse_id[tuple(grid.lower.T)] = np.arange(len(mesh.cells))
    parent = coarse_id[tuple(coarse_lower.T)]
    # tags: a fine boundary facet carries the tags of the coarse facet it lies in (the same key)
    node_grid_shape = tuple(len(a) for a in grid.axes)
    faces = cells[:, facets].reshape(-1, facets.shape[1])                       # (m_fine * f, k) outward
    face_index = np.stack([np.column_stack(np.unravel_index(f, shape, order="F")) for f in faces.T], axis=1)
    normal, side = _normal_axis(face_index)
    limit = np.array(shape)[normal] - 1
    on = (side == 0) | (side == limit)
    faces, face_index, normal = faces[on], face_index[on], normal[on]
    low = face_index.min(axis=1)                                                # fine lowest corner
    up = np.empty_like(low)
    for d in range(dim):
        node_line = np.searchsorted(fine_of[d], low[:, d])                     # a coarse line where the face lies
        interval = coarse[d][np.minimum(low[:, d], len(coarse[d]) - 1)]
        up[:, d] = np.where(normal == d, node_line, interval)
    fine_keys = _facet_keys(normal, up, node_grid_shape)
    tags = {}
    for tag in mesh.tags:
        f = mesh.boundary(tag)
        idx = grid.index[f]                                                     # (k, corners, dim)
        n_ax, _ = _normal_axis(idx)
        keys = _facet_keys(n_ax, idx.min(axis=1), node_grid_shape)
        tags[tag] = faces[np.isin(fine_keys, keys)]
    return type(mesh)(points, cells, tags), parent


def face_lines(mesh: QuadMesh | HexMesh, part: str) -> tuple:
    """Per axis, the grid lines (m) of the tensor grid ``mesh`` across its boundary part ``part``: those within
    the part's extent along each axis the part spans, none along the axis it is flat in (its normal): what a
    partner's face must hold to be meshed alike (:func:`refine_grid`'s ``lines``)."""
    grid = tensor_grid(mesh)
    X = mesh.points[np.unique(mesh.boundary(part))]
    lo, hi, tol = X.min(axis=0), X.max(axis=0), GRID_TOL * mesh.size
    return tuple(a[(a >= l - tol) & (a <= h + tol)] if h - l > tol else a[:0]
                 for a, l, h in zip(grid.axes, lo, hi))


MAX_HALVINGS = 8
"""The most halvings of an interval :func:`refine_grid` makes to hold a line (2^-8 of the interval; a partner
refined alike is one step ahead at most, :data:`~cvxcontact.geometry.refine.GRID_HALVINGS` halvings)."""


def _halvings(a, lines, tol) -> np.ndarray:
    """(len(a) - 1,) per interval of the sorted grid lines ``a``, the halvings that make it hold every one of
    ``lines`` strictly inside it (0 for none); MeshError for a line no halving makes."""
    out = np.zeros(len(a) - 1, dtype=np.int64)
    c = np.asarray(lines, dtype=float).ravel()
    c = c[(c > a[0] + tol) & (c < a[-1] - tol)]
    near = np.abs(a[np.clip(np.searchsorted(a, c), 0, len(a) - 1)] - c) <= tol
    near |= np.abs(a[np.clip(np.searchsorted(a, c) - 1, 0, len(a) - 1)] - c) <= tol
    c = c[~near]                                                 # on a line already
    i = np.searchsorted(a, c) - 1
    t = (c - a[i]) / (a[i + 1] - a[i])
    k = np.full(len(c), -1)
    for n in range(MAX_HALVINGS, 0, -1):                         # the fewest halvings that make t
        made = np.abs(t * 2 ** n - np.round(t * 2 ** n)) * (a[i + 1] - a[i]) <= tol * 2 ** n
        k = np.where(made, n, k)
    if (k < 0).any():
        j = int(np.argmax(k < 0))
        raise MeshError(f"refine_grid: the line at {c[j]:.9g} m is no halving of the interval [{a[i[j]]:.9g}, "
                        f"{a[i[j] + 1]:.9g}] m: the faces are not meshed alike (the same grid on the contact plane)")
    np.maximum.at(out, i, k)
    return out


def _normal_axis(index):
    """(k,) the axis along which each facet's corners (grid indices (k, corners, dim)) share their index, and
    that index."""
    flat = (index == index[:, :1, :]).all(axis=1)                               # (k, dim)
    axis = np.argmax(flat, axis=1)
    return axis, index[np.arange(len(index)), 0, axis]


def _facet_keys(axis, low, shape):
    """(k,) int keys of the facets of a grid of node ``shape`` normal to ``axis`` with lowest corner ``low``."""
    return axis.astype(np.int64) * int(np.prod(shape)) + np.ravel_multi_index(tuple(low.T), shape)
