"""Tetrahedral mesh generators: a box (with named patches of its faces and optional grading) and a
cylinder (a disc when flat). Each returns a validated :class:`~cvxcontact.geometry.tetmesh.TetMesh`
(metres) with tagged boundary faces, so that blocks, punches, discs and Hertz scenes need no mesher.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from itertools import permutations

import numpy as np

from ..errors import MeshError
from .mesh import positive_count, as_interval, physical_memory
from .hexmesh import HEX_FACES, HexMesh
from .tetmesh import OUTWARD_FACES, TetMesh

__all__ = ["box", "cylinder"]

SIDES = {"left": (0, 0), "right": (0, 1), "front": (1, 0), "back": (1, 1), "bottom": (2, 0), "top": (2, 1)}
"""Face tag -> (axis, end): "left"/"right" at x0/x1, "front"/"back" at y0/y1, "bottom"/"top" at z0/z1."""

MAX_CELLS_3D = 10**7
"""Most hexahedra or prisms (six or three tetrahedra each) :func:`box` and :func:`cylinder` build, whatever the machine."""

BYTES_PER_NODE_3D = 16_000
"""Memory of a 3D solve per mesh node (bytes): an estimate, not a measurement (a piezoelectric P1 node
carries 4 unknowns; 4 kB per unknown is a quarter of the 16 GB per 1e6 unknowns that the 3D solver aims
at), so the guard refuses only meshes that cannot be solved on this machine by a wide margin."""


def box(x: Sequence[float] = (0.0, 1.0), y: Sequence[float] = (0.0, 1.0), z: Sequence[float] = (0.0, 1.0),
        nx: int = 4, ny: int = 4, nz: int = 4, patches: Mapping[str, tuple] | None = None,
        grade: tuple | None = None, cell: str = "tetra") -> TetMesh | HexMesh:
    """Structured tetrahedral mesh of the box ``x[0]..x[1]`` by ``y[0]..y[1]`` by ``z[0]..z[1]`` (metres).

    Each of the ``nx`` by ``ny`` by ``nz`` hexahedral cells is cut into six tetrahedra around one of its
    diagonals (Kuhn's subdivision), mirrored from cell to cell so that the faces match and the mesh is
    mirror-symmetric about the box's mid-planes when the counts are even. Faces are tagged "left"/"right"
    (x0/x1), "front"/"back" (y0/y1), "bottom"/"top" (z0/z1).

    ``patches`` names rectangles of a face as extra tags (the face keeps its own):
    ``{"punch": ("top", (a0, a1), (b0, b1))}`` with (a, b) the face's in-plane coordinates in axis order
    ((x, y) on "bottom"/"top", (x, z) on "front"/"back", (y, z) on "left"/"right"), metres. Grid lines are
    placed on the patch's edges, so the patch is exactly a union of faces (its area is exact).

    ``grade=(point, ratio)`` shrinks the cells geometrically towards ``point`` (x, y, z) of the box (e.g. the
    centre of the contact face): along each axis the cell sizes grow in geometric progression with the
    distance from the point's coordinate, the largest ``ratio`` (>= 1) times the smallest (on the axis's
    grid without patch edges; patch edges take lines, which shifts the others); ``ratio`` may be one
    number or one per axis. A grid line passes through the point. The counts nx, ny, nz are kept: the cells are distributed over the sub-intervals
    between patch edges and the point in proportion to their share of the grading density.

    ``cell="hex"`` returns the grid's hexahedra uncut as a :class:`~cvxcontact.geometry.hexmesh.HexMesh` (Q1, Q2
    with ``degree=2``): the same points, the same tags on the quadrilateral faces.
    """
    if cell not in ("tetra", "hex"):
        raise MeshError(f"box: cell must be 'tetra' (tetrahedra) or 'hex' (hexahedra), got {cell!r}")
    bounds = [as_interval(v, k) for v, k in ((x, "x"), (y, "y"), (z, "z"))]
    counts = [positive_count(v, k) for v, k in ((nx, "nx"), (ny, "ny"), (nz, "nz"))]
    _check_size(counts[0] * counts[1] * counts[2], int(np.prod([n + 1 for n in counts])))
    specs = _patch_specs(patches, bounds)
    point, ratios = _grade(grade, bounds)
    breaks: list[list[float]] = [[], [], []]
    for _, axis_ranges in specs.values():
        for axis, (a, b) in axis_ranges:
            breaks[axis] += [a, b]
    axes = [_axis(lo, hi, n, breaks[k], None if point is None else point[k], ratios[k], "xyz"[k])
            for k, ((lo, hi), n) in enumerate(zip(bounds, counts))]
    shape = [n + 1 for n in counts]
    K, J, I = np.meshgrid(*(np.arange(s) for s in shape[::-1]), indexing="ij")
    I, J, K = I.ravel(), J.ravel(), K.ravel()
    points = np.column_stack([axes[0][I], axes[1][J], axes[2][K]])
    index = np.column_stack([I, J, K])                                        # grid index of each node
    if cell == "hex":
        cells = _grid_cells(*counts)[:, [0, 1, 3, 2, 4, 5, 7, 6]]             # VTK order of the corners
        faces = cells[:, HEX_FACES].reshape(-1, 4)
    else:
        cells = _kuhn_tets(*counts)
        faces = cells[:, OUTWARD_FACES].reshape(-1, 3)
    boundaries = {}
    for tag, (axis, end) in SIDES.items():
        on = (index[:, axis] == end * counts[axis])[faces].all(axis=1)     # by node: no (faces, 3) index copy
        boundaries[tag] = faces[on]
    for name, (side, axis_ranges) in specs.items():
        f = boundaries[side]
        inside = np.ones(len(f), dtype=bool)
        for axis, (a, b) in axis_ranges:
            c = points[f, axis]
            inside &= (c >= a).all(axis=1) & (c <= b).all(axis=1)          # grid lines hold a, b exactly
        boundaries[name] = f[inside]
    return (HexMesh if cell == "hex" else TetMesh)(points, cells, boundaries)


def _kuhn_tets(nx, ny, nz):
    """(6 nx ny nz, 4) positive tetrahedra of the grid nodes i + (nx+1)(j + (ny+1)k): Kuhn's six per cell
    (paths from corner 000 to 111), reflected along the axes where the cell index is odd."""
    bits = np.array([[b & 1, (b >> 1) & 1, (b >> 2) & 1] for b in range(8)])   # corner b -> (bx, by, bz)
    paths = []
    for perm in permutations(range(3)):
        corner = np.zeros(3, dtype=int)
        path = [0]
        for axis in perm:
            corner[axis] = 1
            path.append(int(corner @ [1, 2, 4]))
        paths.append(path)
    paths = np.array(paths)                                                    # (6, 4) corner ids
    templates = np.empty((8, 6, 4), dtype=np.int64)
    for mask in range(8):
        flip = bits[mask]
        corners = ((bits[paths] ^ flip) @ [1, 2, 4])                           # (6, 4) reflected corners
        xyz = bits[corners].astype(float)
        vol = np.einsum("ij,ij->i", xyz[:, 1] - xyz[:, 0], np.cross(xyz[:, 2] - xyz[:, 0], xyz[:, 3] - xyz[:, 0]))
        templates[mask] = np.where((vol < 0)[:, None], corners[:, [0, 2, 1, 3]], corners)
    ck, cj, ci = (a.ravel() for a in np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij"))
    mask = (ci % 2) + 2 * (cj % 2) + 4 * (ck % 2)
    return np.take_along_axis(_grid_cells(nx, ny, nz)[:, None, :], templates[mask], axis=2).reshape(-1, 4)


def _grid_cells(nx, ny, nz):
    """(nx ny nz, 8) the corner nodes of the grid's cells, corner b = bx + 2 by + 4 bz (x fastest, cells too)."""
    ck, cj, ci = (a.ravel() for a in np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij"))
    node = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)                   # noqa: E731
    return np.stack([node(ci + (b & 1), cj + ((b >> 1) & 1), ck + ((b >> 2) & 1)) for b in range(8)], axis=1)


def _patch_specs(patches, bounds):
    """name -> (side, [(axis, (a, b)), (axis, (a, b))]) of the ``patches`` argument of :func:`box`."""
    if patches is None:
        return {}
    if not isinstance(patches, Mapping):
        raise MeshError(f"box: patches must map new tag names to (face, (a0, a1), (b0, b1)) in m, e.g. "
                        f"patches={{\"punch\": (\"top\", (0.25, 0.75), (0.25, 0.75))}}, got {patches!r}")
    specs = {}
    for name, spec in patches.items():
        if not isinstance(name, str) or name in SIDES:
            raise MeshError(f"box: patch name {name!r} must be a new tag (a string other than {sorted(SIDES)})")
        try:
            side, ra, rb = spec
            ranges = [tuple(float(v) for v in r) for r in (ra, rb)]
            if any(len(r) != 2 for r in ranges):
                raise ValueError
        except (TypeError, ValueError):
            raise MeshError(f"box: patches[{name!r}] must be (face, (a0, a1), (b0, b1)), got {spec!r}") from None
        if side not in SIDES:
            raise MeshError(f"box: patches[{name!r}]: face must be one of {sorted(SIDES)}, got {side!r}")
        axes = [k for k in range(3) if k != SIDES[side][0]]
        for axis, (a, b) in zip(axes, ranges):
            lo, hi = bounds[axis]
            if not (np.isfinite(a) and np.isfinite(b) and lo <= a < b <= hi):
                raise MeshError(f"box: patches[{name!r}]: the {'xyz'[axis]} range {(a, b)} must be increasing "
                                f"and inside the face ({lo:g} .. {hi:g} m)")
        specs[name] = (side, list(zip(axes, ranges)))
    return specs


def _grade(grade, bounds):
    """(point (3,) or None, ratios (3,)) of the ``grade`` argument of :func:`box`."""
    if grade is None:
        return None, np.ones(3)
    try:
        point, ratio = grade
        point = np.asarray(point, dtype=float)
        ratios = np.broadcast_to(np.asarray(ratio, dtype=float), (3,)).copy()
    except (TypeError, ValueError):
        raise MeshError(f"box: grade must be (point (x, y, z), ratio >= 1), got {grade!r}") from None
    if point.shape != (3,) or not np.isfinite(point).all() or not np.isfinite(ratios).all() or (ratios < 1).any():
        raise MeshError(f"box: grade must be (point (x, y, z), ratio >= 1), got {grade!r}")
    for k, (lo, hi) in enumerate(bounds):
        if not lo <= point[k] <= hi:
            raise MeshError(f"box: the grading point's {'xyz'[k]} = {point[k]:g} m is outside the box "
                            f"({lo:g} .. {hi:g} m)")
    return point, ratios


def _axis(lo, hi, n, breaks, p, ratio, name):
    """n + 1 increasing grid coordinates on [lo, hi] with a line at every break (and at p), spaced by the
    density 1 / (1 + c |x - p|) (cell sizes in geometric progression away from p), c chosen so that the
    grid with a line at p alone has cells from h to ``ratio`` h (uniform without p or with ratio 1)."""
    inner = sorted({float(b) for b in breaks + ([p] if p is not None else []) if lo < b < hi})
    ends = np.array([lo, *inner, hi])
    if n < len(ends) - 1:
        raise MeshError(f"box: n{name} = {n} cells cannot put grid lines at the {len(ends) - 2} patch edges"
                        f"{'' if p is None else ' and grading point'} inside {name} = {lo:g} .. {hi:g} m "
                        f"({inner}); use n{name} >= {len(ends) - 1}")
    if p is None or ratio == 1 or n == 1:
        return _graded(ends, n, lo, 0.0)
    lines = np.array([lo, p, hi]) if lo < p < hi else np.array([lo, hi])
    span = max(p - lo, hi - p)
    a, b = 0.0, 1e8                                    # c span: bisection on the cells' size ratio
    for _ in range(60):
        h = np.diff(_graded(lines, n, p, 0.5 * (a + b) / span))
        a, b = (0.5 * (a + b), b) if h.max() / h.min() < ratio else (a, 0.5 * (a + b))
    return _graded(ends, n, p, 0.5 * (a + b) / span)


def _graded(ends, n, p, c):
    """n + 1 grid coordinates from ends[0] to ends[-1] with a line at each of ``ends``, equidistributing
    the density 1 / (1 + c |x - p|) (cells spread over the sub-intervals by their share of it)."""
    hi = ends[-1]

    def F(x):                                      # cumulative density
        d = x - p
        return d if c == 0 else np.sign(d) * np.log1p(c * np.abs(d)) / c

    def F_inv(f):
        return p + (f if c == 0 else np.sign(f) * np.expm1(c * np.abs(f)) / c)

    mass = np.diff(F(ends))
    share = n * mass / mass.sum()
    cells = np.maximum(1, np.floor(share).astype(int))
    while cells.sum() < n:                         # largest remainder (loop over sub-intervals, not cells)
        cells[np.argmax(share - cells)] += 1
    while cells.sum() > n:
        cells[np.argmax(np.where(cells > 1, cells - share, -np.inf))] -= 1
    parts = [F_inv(np.linspace(F(a), F(b), k + 1))[:-1] for a, b, k in zip(ends[:-1], ends[1:], cells)]
    coords = np.concatenate(parts + [[hi]])
    coords[np.cumsum(np.r_[0, cells])] = ends      # the breaks exactly
    return coords


def cylinder(radius: float, height: float, n_r: int = 4, n_z: int = 4, n_theta: int | None = None,
             center: Sequence[float] = (0.0, 0.0, 0.0)) -> TetMesh:
    """A circular cylinder (a disc when flat) along z: radius ``radius``, from z = center_z to center_z +
    ``height`` (m), its axis through (center_x, center_y). Tags "bottom", "top", "side".

    The cross-section is a polygon of ``n_theta`` sides (default 6 n_r; a multiple of n_r, at least
    3 n_r) inscribed in the circle, cut into ``n_r`` rings of near-equilateral triangles (ring k has
    k n_theta / n_r segments, nodes on circles); its area converges to pi radius^2 as
    1 - sinc(2 pi / n_theta). It is extruded through ``n_z`` layers, each prism cut into three
    tetrahedra whose side diagonals start at the lower-numbered node (so neighbours match).
    """
    for key, v in (("radius", radius), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not np.isfinite(v) or v <= 0:
            raise MeshError(f"cylinder: {key} must be a positive number (m), got {v!r}")
    n_r, n_z = positive_count(n_r, "n_r"), positive_count(n_z, "n_z")
    n_theta = 6 * n_r if n_theta is None else positive_count(n_theta, "n_theta")
    if n_theta % n_r or n_theta < 3 * n_r:
        raise MeshError(f"cylinder: n_theta = {n_theta} must be a multiple of n_r = {n_r} and at least {3 * n_r}")
    try:
        cx, cy, cz = (float(c) for c in center)
    except (TypeError, ValueError):
        raise MeshError(f"cylinder: center must be three numbers (x, y, z) in m, got {center!r}") from None
    if not np.isfinite([cx, cy, cz]).all():
        raise MeshError(f"cylinder: center must be finite, got {center!r}")
    sectors = n_theta // n_r
    _check_size(n_z * sectors * n_r * n_r, (n_z + 1) * (1 + sectors * n_r * (n_r + 1) // 2))
    xy, triangles = _disc(radius, n_r, sectors)
    nv = len(xy)
    zs = cz + height * np.arange(n_z + 1) / n_z
    points = np.column_stack([np.tile(xy[:, 0] + cx, n_z + 1), np.tile(xy[:, 1] + cy, n_z + 1),
                              np.repeat(zs, nv)])
    v = np.sort(triangles, axis=1)                                             # v0 < v1 < v2 per prism
    layer = nv * np.arange(n_z)[:, None, None]
    lo, up = v[None] + layer, v[None] + layer + nv                             # (n_z, t, 3)
    tets = np.concatenate([
        np.stack([lo[..., 0], lo[..., 1], lo[..., 2], up[..., 2]], axis=-1),
        np.stack([lo[..., 0], lo[..., 1], up[..., 1], up[..., 2]], axis=-1),
        np.stack([lo[..., 0], up[..., 0], up[..., 1], up[..., 2]], axis=-1)], axis=1).reshape(-1, 4)
    a = points[tets[:, 0]]
    vol = np.einsum("ij,ij->i", points[tets[:, 1]] - a, np.cross(points[tets[:, 2]] - a, points[tets[:, 3]] - a))
    tets = np.where((vol < 0)[:, None], tets[:, [0, 2, 1, 3]], tets)
    faces = tets[:, OUTWARD_FACES].reshape(-1, 3)
    level = np.repeat(np.arange(n_z + 1), nv)[faces]
    rim = np.zeros(nv, dtype=bool)
    rim[-sectors * n_r:] = True
    boundaries = {"bottom": faces[(level == 0).all(axis=1)], "top": faces[(level == n_z).all(axis=1)],
                  "side": faces[rim[faces % nv].all(axis=1)]}
    return TetMesh(points, tets, boundaries)


def _disc(radius, n_r, sectors):
    """Nodes (centre, then ring by ring, ring k holding k * sectors nodes) and triangles of a disc."""
    xy = [np.zeros((1, 2))]
    first = [0]
    for k in range(1, n_r + 1):                                                # loop over rings
        t = 2 * np.pi * np.arange(k * sectors) / (k * sectors)
        first.append(first[-1] + len(xy[-1]))
        xy.append(radius * k / n_r * np.column_stack([np.cos(t), np.sin(t)]))
    tris = []
    for k in range(1, n_r + 1):
        s = np.arange(sectors)[:, None]
        j = np.arange(k)[None, :]
        outer = lambda q: first[k] + (s * k + q) % (k * sectors)               # noqa: E731
        inner = lambda q: first[k - 1] + ((s * (k - 1) + q) % max((k - 1) * sectors, 1))  # noqa: E731
        tris.append(np.stack([outer(j), outer(j + 1), inner(j)], axis=-1).reshape(-1, 3))
        if k > 1:
            j = np.arange(k - 1)[None, :]
            tris.append(np.stack([inner(j), outer(j + 1), inner(j + 1)], axis=-1).reshape(-1, 3))
    return np.vstack(xy), np.vstack(tris)


def _check_size(cells, nodes):
    """Refuse a mesh too large to build or to solve on this machine (before allocating); ``cells``
    counts hexahedra or prisms (six or three tetrahedra)."""
    if cells > MAX_CELLS_3D:
        raise MeshError(f"{cells:.3g} cells is more than the limit of {MAX_CELLS_3D:.0e} "
                        f"(~{nodes:.3g} nodes, ~{4 * nodes:.3g} unknowns); use fewer cells")
    have = physical_memory()
    need = nodes * BYTES_PER_NODE_3D
    if have and need > have:
        raise MeshError(f"{cells:.3g} cells, ~{nodes:.3g} nodes (~{4 * nodes:.3g} unknowns), need ~{need / 1e9:.3g} "
                        f"GB to solve, the machine has {have / 1e9:.3g} GB; use fewer cells")
