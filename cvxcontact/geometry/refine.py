"""Refinement of triangle and tetrahedron meshes: uniform (red; a tetrahedron into 8), the nested meshes of a
reference solution, and local (:func:`refine_marked`: newest-vertex bisection of triangles, longest-edge
bisection of tetrahedra (:func:`bisect_tets`), both with conforming closure; :func:`refine_times`: a number of
bisections per cell), the meshes of adaptive refinement; :func:`refine_local`, the local refinement of every mesh
an adaptive loop takes (these bisections, or a tensor grid's strips halved: :mod:`cvxcontact.geometry.grid`).

Uniform refinement:
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

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError
from .grid import face_lines, refine_grid, tensor_grid
from .mesh import Mesh
from .tetmesh import TetMesh

__all__ = ["bisect_tets", "circle", "label_longest", "local_refusal", "refine_local", "refine_marked", "refine_times",
           "refine_together", "refine_uniform", "start_local"]


BISECTED = frozenset({"triangle", "tetra"})
"""The cells (``mesh.cell``) :func:`refine_marked` bisects."""


GRID_HALVINGS = 1
"""The most halvings of a tensor grid's interval in one call of :func:`refine_local`: a strip halved k times
multiplies every cell along it by 2^k, so more bisections asked of a cell wait for the next step."""


def local_refusal(mesh, curved: bool = False) -> str:
    """Why :func:`refine_local` cannot refine ``mesh`` ("" if it can): triangles and tetrahedra are bisected,
    quadrilaterals and hexahedra refined as a tensor grid (:func:`~cvxcontact.geometry.grid.refine_grid`) if
    they are one; ``curved``: new boundary nodes are to go back on a curve (triangles only)."""
    if mesh.cell in BISECTED:
        return ""
    if tensor_grid(mesh) is None:
        return (f"its {mesh.cell} cells are not a tensor grid (nodes the product of sorted coordinate lists, cells "
                "the grid's cells), the only quadrilateral or hexahedral mesh refined locally without hanging "
                "nodes: mesh the body with triangles or tetrahedra (cell='triangle' or 'tetra'), or as a grid "
                "(cc.rectangle, cc.graded_block, cc.box with cell='quad' or 'hex')")
    if curved:
        return ("curves= puts new boundary nodes back on a curve on triangles only; a tensor grid's new nodes "
                "are on its grid lines: remove curves= (or mesh the curved body with triangles)")
    return ""


def start_local(mesh):
    """``mesh`` as the first mesh of :func:`refine_local`: a triangle mesh relabelled so that each triangle's
    refinement edge is its longest (:func:`label_longest`), others as they are."""
    return label_longest(mesh) if isinstance(mesh, Mesh) else mesh


def refine_local(mesh, times: ArrayLike, curves: Mapping[str, Curve] | None = None,
                 lines: tuple | None = None) -> tuple:
    """(fine mesh, parent): ``mesh`` refined where ``times`` (an int per cell: the bisections it asks, each
    halving its area or volume) says. Triangles and tetrahedra: :func:`refine_times` (``curves`` as there). A
    tensor grid of quadrilaterals or hexahedra (:func:`local_refusal` says which are): every grid interval
    through cell T halved ceil(times[T] / dim) times (:func:`~cvxcontact.geometry.grid.refine_grid`; one
    halving along every axis divides the cell's size by 2^dim, dim bisections), and as often as it takes to hold
    ``lines`` (per axis, a partner's face lines: :func:`~cvxcontact.geometry.grid.face_lines`), ``curves``
    refused."""
    if mesh.cell in BISECTED:
        return refine_times(mesh, times, curves)
    why = local_refusal(mesh, bool(curves))
    if why:
        raise MeshError(f"refine_local: {why}")
    times = np.asarray(times)
    if times.shape != (len(mesh.cells),) or not np.issubdtype(times.dtype, np.integer) or (times < 0).any():
        raise MeshError(f"refine_local: times must be non-negative integers, one per cell ({len(mesh.cells)}), "
                        f"got dtype {times.dtype} and shape {times.shape}")
    return refine_grid(mesh, np.minimum(-(-times // mesh.dim), GRID_HALVINGS), lines)

def refine_together(meshes: Sequence, times: Sequence[ArrayLike], faces: Sequence[tuple],
                    curves: Sequence[Mapping[str, Curve] | None] | None = None) -> list:
    """The meshes ``meshes`` each refined by :func:`refine_local` (``times[k]``, ``curves[k]``), the tensor grids
    among them keeping their contact faces meshed alike: ``faces``, pairs ((k, part_k), (l, part_l)) of faces of
    meshes k and l that are meshed alike (the same grid on the contact plane) and must stay so. Each grid interval
    across such a face is cut as often as its partner's is (the partner's lines, :func:`~cvxcontact.geometry.grid.
    face_lines`), repeated until no mesh changes (a chain of faces passes a line along)."""
    curves = [None] * len(meshes) if curves is None else list(curves)
    fine = [refine_local(m, t, c)[0] for m, t, c in zip(meshes, times, curves)]
    grids = [m.cell not in BISECTED for m in meshes]
    faces = [f for f in faces if grids[f[0][0]] and grids[f[1][0]]]
    for _ in range(len(meshes)):
        if not faces:
            break
        lines = [[[] for _ in range(m.dim)] for m in meshes]
        for (k, pk), (l, pl) in faces:
            for (a, _), (b, pb) in (((k, pk), (l, pl)), ((l, pl), (k, pk))):
                for d, line in enumerate(face_lines(fine[b], pb)):
                    lines[a][d].append(line)
        again = [refine_local(m, t, c, tuple(np.concatenate(x) if x else np.zeros(0) for x in ln))[0]
                 if g else f for m, t, c, ln, g, f in zip(meshes, times, curves, lines, grids, fine)]
        same = all(len(a.points) == len(b.points) for a, b in zip(again, fine))
        fine = again
        if same:
            break
    return fine


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


# --------------------------------------------------------------------------- local refinement: bisection

Curve = Callable[[np.ndarray], np.ndarray]
"""The closest-point map of a curved boundary part: (k, 2) points near it (m) -> (k, 2) points on it (m)."""


def label_longest(mesh: Mesh) -> Mesh:
    """The same mesh with each triangle's vertices rotated so that its longest edge is (v0, v1): the initial
    refinement edges of :func:`refine_marked` (Mitchell's newest-vertex bisection starts from the longest
    edges). The triangles keep their order and orientation; tags and cells are unchanged."""
    if not isinstance(mesh, Mesh):
        raise MeshError(f"label_longest takes a 2D cc.Mesh, got {type(mesh).__name__}")
    p, tri = mesh.points, mesh.triangles
    length = np.stack([np.linalg.norm(p[tri[:, (i + 1) % 3]] - p[tri[:, i]], axis=1) for i in range(3)], axis=1)
    first = np.argmax(length, axis=1)                                   # edge (v_i, v_i+1) is the longest
    rotated = tri[np.arange(len(tri))[:, None], (first[:, None] + np.arange(3)) % 3]
    return Mesh(p, rotated, {t: mesh.boundary(t) for t in mesh.tags})


def refine_marked(mesh: Mesh | TetMesh, marked: ArrayLike, curves: Mapping[str, Curve] | None = None
                  ) -> tuple[Mesh | TetMesh, np.ndarray]:
    """(fine mesh, parent): ``mesh`` with the ``marked`` triangles bisected by newest-vertex bisection
    (Mitchell 1991; Binev, Dahmen & DeVore 2004) and as many others as conformity needs; a
    :class:`~cvxcontact.geometry.tetmesh.TetMesh`'s marked tetrahedra by longest-edge bisection
    (:func:`bisect_tets`, where ``curves`` is refused).

    The refinement edge of triangle (v0, v1, v2) is (v0, v1) (:func:`label_longest` sets it on a new mesh;
    the meshes this returns keep the convention, so they can be refined again). A bisected triangle
    (a, b, c) with midpoint m of (a, b) becomes (c, a, m) and (b, c, m): the new vertex is opposite each
    child's refinement edge. The closure marks the refinement edge of every triangle with a marked edge
    until none is added, so every marked edge is bisected in both its triangles (no hanging node); a
    triangle is cut into 2, 3 or 4. Every triangle is similar to one of finitely many per initial triangle,
    whatever the number of steps: the smallest angle is bounded below (shape regular).

    Parameters
    ----------
    mesh : Mesh
        Triangles labelled as above.
    marked : (m,) bool or int array_like
        The triangles to refine (a mask or indices).
    curves : dict tag -> callable, optional
        For curved boundary parts: the closest-point map of the part's curve, (k, 2) -> (k, 2) (m). A new
        node on a tagged edge of such a part is put back on the curve; elsewhere new nodes are the edges'
        midpoints (a curved part the mesh is not told about stays the polygon it was).

    Returns
    -------
    Mesh, (m_fine,) int array
        The fine mesh (the coarse vertices keep their indices, the midpoints follow in the order of the
        sorted edges) and ``parent``, the coarse triangle of each fine one: a per-cell tag (material,
        region) ``tag`` of the coarse mesh is ``tag[parent]`` on the fine one. Boundary tags are carried to
        the halves of their edges.

    Raises
    ------
    MeshError
        For a mask of the wrong length, an index out of range, a tag in ``curves`` the mesh does not have,
        a curve map that does not return finite (k, 2) points, or a projected node that folds a triangle.
    """
    if isinstance(mesh, TetMesh):
        if curves:
            raise MeshError(f"refine_marked: curved boundary parts ({sorted(curves)}) are put back on their curve "
                            "in 2D only; a tetrahedral mesh's new boundary nodes stay on the flat faces: remove "
                            "curves= (or refine the curved 3D body with your mesher)")
        return bisect_tets(mesh, marked)
    if not isinstance(mesh, Mesh):
        raise MeshError(f"refine_marked takes a cc.Mesh (2D) or cc.TetMesh (3D), got {type(mesh).__name__}")
    p, tri = mesh.points, mesh.triangles
    m, nv = len(tri), len(p)
    cells = _marked_cells(marked, m)
    curves = dict(curves or {})
    for tag, curve in curves.items():
        if tag not in mesh.tags or not callable(curve):
            raise MeshError(f"refine_marked: curves must map boundary tags of the mesh ({sorted(mesh.tags)}) to "
                            f"closest-point maps (k, 2) -> (k, 2), got {tag!r}: {type(curve).__name__}")
    # the edges of every triangle: column 0 is the refinement edge (v0, v1), then (v1, v2), (v2, v0)
    ends = np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1)          # (m, 3, 2)
    keys = np.minimum(ends[..., 0], ends[..., 1]) * nv + np.maximum(ends[..., 0], ends[..., 1])
    unique, edge = np.unique(keys.ravel(), return_inverse=True)
    edge = edge.reshape(m, 3)
    split = np.zeros(len(unique), dtype=bool)
    split[edge[cells, 0]] = True
    while True:                                         # closure: a triangle with a split edge splits its own
        need = split[edge].any(axis=1) & ~split[edge[:, 0]]
        if not need.any():
            break
        split[edge[need, 0]] = True
    which = np.flatnonzero(split)
    mid = np.full(len(unique), -1, dtype=np.int64)
    mid[which] = nv + np.arange(len(which))
    a, b = unique[which] // nv, unique[which] % nv
    new = 0.5 * (p[a] + p[b])
    for tag, curve in curves.items():
        e = mesh.boundary(tag)
        at = np.searchsorted(unique, np.minimum(e[:, 0], e[:, 1]) * nv + np.maximum(e[:, 0], e[:, 1]))
        on = mid[at[split[at]]] - nv
        if len(on):
            new[on] = _on_curve(curve, new[on], tag)
    points = np.concatenate([p, new])

    def midpoint(u, v):
        return mid[np.searchsorted(unique, np.minimum(u, v) * nv + np.maximum(u, v))]

    n = len(points)
    wide = (unique // nv) * n + unique % nv                 # the same keys on all n nodes (still sorted)
    cur, parent = tri, np.arange(m)
    for _ in range(2):                                  # a marked edge of a child is an edge of its parent
        mm = np.full(len(cur), -1, dtype=np.int64)
        k = np.minimum(cur[:, 0], cur[:, 1]) * n + np.maximum(cur[:, 0], cur[:, 1])
        pos = np.minimum(np.searchsorted(wide, k), len(wide) - 1)
        known = wide[pos] == k
        mm[known] = mid[pos[known]]
        cut = mm >= 0
        if not cut.any():
            break
        x, y, z, w = cur[cut, 0], cur[cut, 1], cur[cut, 2], mm[cut]
        children = np.stack([np.column_stack([z, x, w]), np.column_stack([y, z, w])], axis=1).reshape(-1, 3)
        cur = np.concatenate([cur[~cut], children])
        parent = np.concatenate([parent[~cut], np.repeat(parent[cut], 2)])
    order = np.argsort(parent, kind="stable")           # the children of a triangle together, in parent order
    cur, parent = cur[order], parent[order]
    tags = {}
    for tag in mesh.tags:
        e = mesh.boundary(tag)
        w = midpoint(e[:, 0], e[:, 1])
        whole = e[w < 0]
        half = np.flatnonzero(w >= 0)
        tags[tag] = np.concatenate([whole, np.column_stack([e[half, 0], w[half]]),
                                    np.column_stack([w[half], e[half, 1]])])
    return Mesh(points, cur, tags), parent


def refine_times(mesh: Mesh | TetMesh, times: ArrayLike, curves: Mapping[str, Curve] | None = None
                 ) -> tuple[Mesh | TetMesh, np.ndarray]:
    """(fine mesh, parent): ``mesh`` with each cell bisected ``times[T]`` times (an int per cell; 0: only as
    conformity asks) by repeated :func:`refine_marked` (``curves`` as there): a child of T whose
    bisections so far (log2 of T's area or volume over its own, rounded: a child whose new boundary node went
    back on a curve is close to, not exactly, half its parent) fall short of ``times[T]`` is marked again.
    ``parent``: the cell of ``mesh`` each fine cell lies in (the maps of the rounds composed)."""
    times = np.asarray(times)
    if times.shape != (len(mesh.cells),) or not np.issubdtype(times.dtype, np.integer) or (times < 0).any():
        raise MeshError(f"refine_times: times must be non-negative integers, one per cell ({len(mesh.cells)}), "
                        f"got dtype {times.dtype} and shape {times.shape}")
    size0 = _sizes(mesh)
    parent = np.arange(len(mesh.cells))
    left = times.astype(np.int64)
    while (left > 0).any():
        mesh, up = refine_marked(mesh, left > 0, curves)
        parent = parent[up]
        done = np.rint(np.log2(size0[parent] / _sizes(mesh))).astype(np.int64)
        left = times[parent] - done
    return mesh, parent


def _sizes(mesh) -> np.ndarray:
    """Areas (triangles) or volumes (tetrahedra) of ``mesh``'s cells."""
    return mesh.volumes if isinstance(mesh, TetMesh) else mesh.areas


def _marked_cells(marked, m, cell="triangle"):
    """Indices of the marked cells (triangles or tetrahedra) from a mask (m,) or an index array (typed errors)."""
    marked = np.asarray(marked)
    if marked.dtype == bool:
        if marked.shape != (m,):
            raise MeshError(f"refine_marked: a mask needs one entry per {cell} ({m}), got shape {marked.shape}")
        return np.flatnonzero(marked)
    if marked.size == 0:
        return np.zeros(0, dtype=np.int64)
    if not np.issubdtype(marked.dtype, np.integer) or marked.ndim != 1:
        raise MeshError(f"refine_marked: marked must be a boolean mask (m,) or {cell} indices, got dtype "
                        f"{marked.dtype} and shape {marked.shape}")
    if marked.min() < 0 or marked.max() >= m:
        raise MeshError(f"refine_marked: {cell} indices must lie in 0..{m - 1}, got {marked.min()}..{marked.max()}")
    return np.unique(marked)


def _on_curve(curve, points, tag):
    """The curve's closest points to ``points``, checked."""
    out = np.asarray(curve(points.copy()), dtype=float)
    if out.shape != points.shape or not np.isfinite(out).all():
        raise MeshError(f"refine_marked: the curve of part {tag!r} must map (k, 2) points to finite (k, 2) points "
                        f"on it (m), got shape {out.shape}")
    return out


def circle(center: Sequence[float], radius: float) -> Curve:
    """The closest-point map of the circle of ``radius`` (m) around ``center`` (m): a :data:`Curve` for
    :func:`refine_marked` (e.g. the ``"arc"`` of :func:`~cvxcontact.geometry.generators.half_disk`)."""
    c = np.asarray(center, dtype=float)
    r = float(radius)
    if c.shape != (2,) or not np.isfinite(c).all() or not (np.isfinite(r) and r > 0):
        raise MeshError(f"circle: center must be (x, y) and radius a positive number (m), got {center!r}, {radius!r}")

    def closest(points):
        d = points - c
        return c + r * d / np.linalg.norm(d, axis=1)[:, None]

    return closest


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


# --------------------------------------------------------------------------- local refinement of tetrahedra

MAX_BISECTION_ROUNDS = 1000
"""Rounds of :func:`bisect_tets` before it gives up (each round bisects every non-conforming tetrahedron once;
the meshes of the tests close in at most 30)."""


def _edge_order(points, lo, hi):
    """(k,) float squared lengths and (k,) int keys of the edges (lo, hi), lo < hi: the total order of
    :func:`bisect_tets` is by length, then by key (the sorted vertex numbers). The length is computed from the
    sorted pair, so every cell holding an edge sees the same float (no rounding enters the comparison)."""
    d = points[hi] - points[lo]
    return (d * d).sum(axis=1), (lo.astype(np.int64) << 32) | hi


def _longest(points, cells, pairs):
    """(k,) position in ``pairs`` of each cell's longest edge (the total order of :func:`_edge_order`), with the
    (k,) keys of the edges."""
    a, b = cells[:, pairs[:, 0]], cells[:, pairs[:, 1]]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    length, key = _edge_order(points, lo.ravel(), hi.ravel())
    length, key = length.reshape(lo.shape), key.reshape(lo.shape)
    tie = np.where(length == length.max(axis=1)[:, None], key, -1)
    return np.argmax(tie, axis=1), key


def _split(cells, pairs, longest, mid_of):
    """The two halves of every cell bisected at its edge ``pairs[longest]``: the cell with the edge's second
    vertex, then with its first, replaced by the midpoint ``mid_of`` (k,) (orientation kept: a vertex moves
    along an edge of its own cell)."""
    r = np.arange(len(cells))
    first, second = cells.copy(), cells.copy()
    first[r, pairs[longest, 1]] = mid_of
    second[r, pairs[longest, 0]] = mid_of
    return first, second


_PAIRS_TET = np.array(_TET_EDGES)
_PAIRS_TRI = np.array([[0, 1], [1, 2], [2, 0]])


def bisect_tets(mesh: TetMesh, marked: ArrayLike) -> tuple[TetMesh, np.ndarray]:
    """(fine mesh, parent): ``mesh`` with the ``marked`` tetrahedra bisected at their longest edge and as many
    others as conformity needs (Rivara's longest-edge bisection, Rivara & Levin 1992).

    Each round bisects every tetrahedron to be refined at its longest edge, the midpoint shared by all
    tetrahedra bisecting that edge; the next round refines every tetrahedron with a node on one of its
    edges, until none has (no hanging node). Edges are ordered by their length and, on equal lengths, by
    their sorted vertex numbers (a strict total order that every cell holding an edge sees alike: the
    lengths are compared as computed, never rounded), so the choice is deterministic and shared by
    neighbours; a face is therefore always split at its own longest edge, and a tagged boundary face
    splits as its tetrahedron does (the tags are carried to the halves).

    Why this scheme: it needs no labelling of the initial mesh (the newest-vertex schemes of Maubach and of
    Arnold, Mukherjee & Pouly need one, which a general mesh admits only after work) and its closure ends.
    Termination (Rivara's argument): a tetrahedron bisected to remove a hanging node on edge e splits its
    longest edge, e or an edge after e in the order, so every chain of closure bisections rises in the order
    (a cap of :data:`MAX_BISECTION_ROUNDS` rounds turns a failure into an error). Shape regularity: no proof
    is known for longest-edge bisection of tetrahedra (the newest-vertex schemes have one); measured, the
    smallest dihedral angle of a jittered box and of a cylinder stays above half its initial value through
    six rounds of refining at a corner and random rounds after (0.69 to 1.0 of it, tests/test_refine_tets.py).
    New nodes are the edges' midpoints: a curved surface stays the faceted one.

    Parameters
    ----------
    mesh : TetMesh
    marked : (m,) bool or int array_like
        The tetrahedra to refine (a mask or indices).

    Returns
    -------
    TetMesh, (m_fine,) int array
        The fine mesh (the coarse vertices keep their indices, the midpoints follow in the order they are
        made) and ``parent``, the coarse tetrahedron of each fine one, the children of a tetrahedron together
        in the coarse order: a per-cell tag of the coarse mesh is ``tag[parent]`` on the fine one.

    Raises
    ------
    MeshError
        For a mask of the wrong length or an index out of range.
    """
    if not isinstance(mesh, TetMesh):
        raise MeshError(f"bisect_tets takes a cc.TetMesh, got {type(mesh).__name__}")
    tets, parent = np.array(mesh.tets), np.arange(len(mesh.tets))
    todo = np.zeros(len(tets), dtype=bool)
    todo[_marked_cells(marked, len(tets), "tetrahedron")] = True
    points = [np.array(mesh.points)]
    n = len(mesh.points)
    split_keys, split_mids = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)   # sorted by key
    for _ in range(MAX_BISECTION_ROUNDS):
        if not todo.any():
            break
        p = np.concatenate(points)
        cut = tets[todo]
        longest, key = _longest(p, cut, _PAIRS_TET)
        edge_key = key[np.arange(len(cut)), longest]
        new = np.setdiff1d(edge_key, split_keys)                         # sorted, unique
        lo, hi = new >> 32, new & 0xFFFFFFFF
        points.append(0.5 * (p[lo] + p[hi]))
        order = np.argsort(np.concatenate([split_keys, new]), kind="stable")
        split_keys = np.concatenate([split_keys, new])[order]
        split_mids = np.concatenate([split_mids, n + np.arange(len(new))])[order]
        n += len(new)
        first, second = _split(cut, _PAIRS_TET, longest, split_mids[np.searchsorted(split_keys, edge_key)])
        tets = np.concatenate([tets[~todo], first, second])
        parent = np.concatenate([parent[~todo], parent[todo], parent[todo]])
        todo = _has_split_edge(tets, _PAIRS_TET, split_keys)
    else:
        raise MeshError(f"bisect_tets: the conforming closure did not end within {MAX_BISECTION_ROUNDS} rounds; "
                        "this is a bug: please report the mesh and the marked cells")
    p = np.concatenate(points)
    order = np.argsort(parent, kind="stable")
    tags = {}
    for tag in mesh.tags:
        faces = np.array(mesh.boundary(tag))
        while True:                                      # a face splits at its longest edge (docstring)
            todo = _has_split_edge(faces, _PAIRS_TRI, split_keys)
            if not todo.any():
                break
            longest, key = _longest(p, faces[todo], _PAIRS_TRI)
            mid_of = split_mids[np.searchsorted(split_keys, key[np.arange(len(longest)), longest])]
            faces = np.concatenate([faces[~todo], *_split(faces[todo], _PAIRS_TRI, longest, mid_of)])
        tags[tag] = faces
    return TetMesh(p, tets[order], tags), parent[order]


def _has_split_edge(cells, pairs, split_keys):
    """(k,) True where a cell has an edge in the sorted ``split_keys`` (a node at its midpoint)."""
    if not len(split_keys):
        return np.zeros(len(cells), dtype=bool)
    a, b = cells[:, pairs[:, 0]], cells[:, pairs[:, 1]]
    key = (np.minimum(a, b).astype(np.int64) << 32) | np.maximum(a, b)
    pos = np.minimum(np.searchsorted(split_keys, key), len(split_keys) - 1)
    return (split_keys[pos] == key).any(axis=1)
