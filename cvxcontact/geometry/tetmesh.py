"""P1 tetrahedral meshes with named boundary faces.

A :class:`TetMesh` is an array of points (metres), an array of positively oriented
tetrahedra and a dictionary of tagged boundary faces. It is validated once, when built,
and its arrays are read-only copies, so every later stage can trust it (use
:meth:`TetMesh.with_points` to move or scale a mesh). It mirrors the 2D
:class:`~cvxcontact.geometry.mesh.Mesh`: ``cells`` are the elements, ``boundary(tag)`` the
tagged faces, oriented so that ``(p1 - p0) x (p2 - p0)`` points out of the body.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import FrozenMap, MeshError, locked
from .base import CellMesh
from .facets import facet_keys
from .meshchecks import check_nodes, checked_renumbering, one_orientation

__all__ = ["TetMesh"]

DEGENERATE_TOL = 1e-12
"""A tetrahedron whose volume is at most this times the cube of its longest edge is degenerate."""

ANGLE_TOL = 1e-6
"""Tolerance (radians) of the dihedral angle sums around edges (see :func:`_check_fans`)."""

MAX_NODES = 2_097_151
"""Most nodes a TetMesh holds (face keys are n^3 < 2^63)."""

OUTWARD_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
"""Local vertices of the faces of a positive tetrahedron, face i opposite vertex i, each oriented
so that (p1 - p0) x (p2 - p0) points out of it."""

EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [2, 3], [1, 3]])
"""Local vertices of the six edges of a tetrahedron, in the gmsh tetra10 order of the edge nodes
(the order of :class:`~cvxcontact.geometry.quadratic.P2TetNodes` and of the P2 basis)."""

OTHER = np.array([[2, 3], [0, 3], [1, 3], [1, 2], [0, 1], [0, 2]])
"""The two local vertices off each edge of EDGES: the edge lies on the faces opposite them."""

CHUNK = 1 << 14
"""Tetrahedra per block of the per-element geometry of the checks (bounds their temporary arrays)."""


class TetMesh(CellMesh):
    """A conforming P1 tetrahedral mesh of one body in (x, y, z) space.

    Parameters
    ----------
    points : (n, 3) array_like of float
        Node coordinates in metres.
    tets : (m, 4) array_like of int
        Node indices of each tetrahedron. A mesh whose tetrahedra are all negatively oriented
        is reoriented; a mesh with mixed orientation is folded and rejected.
    boundaries : dict of str to (k, 3) array_like of int, optional
        Named boundary parts, each a list of boundary faces (node index triples, any order;
        they are stored oriented outwards). A face may belong to several parts.

    The mesh is immutable like :class:`~cvxcontact.geometry.mesh.Mesh` (read-only arrays,
    :class:`~cvxcontact.errors.FrozenError` on assignment; :meth:`with_points` builds a moved copy).

    Raises
    ------
    MeshError
        On non-finite or badly shaped arrays, indices out of range, duplicate or unused nodes,
        degenerate tetrahedra, mixed orientation, a face shared by more than two tetrahedra,
        tetrahedra that overlap or fold over one another (checked locally at every face, edge
        and node, between separate pieces of the body, and on the boundary surface, which must
        not cut through itself; see :func:`_check_embedding`), or a tagged face that is not on
        the boundary.
    """

    dim = 3
    """Spatial dimension (a 2D :class:`~cvxcontact.geometry.mesh.Mesh` has 2)."""
    cell = "tetra"
    """The cell type (the key of the spaces, :func:`cvxcontact.fem.space.space`)."""

    def __init__(self, points: ArrayLike, tets: ArrayLike,
                 boundaries: Mapping[str, ArrayLike] | None = None) -> None:
        points = as_points3(points)
        tets = _as_tets(tets, len(points))
        check_nodes(points, tets, "tetrahedron")
        tets = _orient(points, tets)
        self._set(_points=locked(points, float), _tets=locked(tets, np.int64))
        keys, faces = _check_embedding(self._points, self._tets)
        self._set(_boundary_keys=locked(keys, np.int64), _boundary_faces=locked(faces, np.int64))
        if boundaries is not None and not isinstance(boundaries, Mapping):
            raise MeshError(f"boundaries must be a dict mapping tags to (k, 3) arrays of node triples, "
                            f"got {type(boundaries).__name__}")
        self._set(_tags=FrozenMap({str(tag): locked(self._orient_faces(str(tag), tagged), np.int64)
                                   for tag, tagged in (boundaries or {}).items()},
                                  "TetMesh boundaries", "build a new TetMesh"))

    def _frozen_hint(self, name: str) -> str:
        return ("build a new TetMesh (mesh.with_points(points) moves or scales it; "
                "cc.TetMesh(points, tets, boundaries))")

    def __repr__(self) -> str:
        return f"TetMesh({len(self.points)} nodes, {len(self.tets)} tetrahedra, tags={list(self._tags)})"

    @property
    def points(self) -> np.ndarray:
        """(n, 3) node coordinates in metres (read-only)."""
        return self._points

    @property
    def triangulation(self) -> TetMesh:
        """The tetrahedral mesh whose boundary triangles are the contact surfaces' faces: itself (a
        :class:`~cvxcontact.geometry.hexmesh.HexMesh` answers its split)."""
        return self

    @property
    def tets(self) -> np.ndarray:
        """(m, 4) node indices of the positively oriented tetrahedra (read-only)."""
        return self._tets

    @property
    def cells(self) -> np.ndarray:
        """(m, 4) the elements: :attr:`tets` (the name shared with the 2D mesh's triangles)."""
        return self._tets

    def with_points(self, points: ArrayLike) -> TetMesh:
        """A new validated mesh with the same tetrahedra and tags on new node coordinates (metres)."""
        p = np.asarray(points)
        if p.shape != self.points.shape:
            raise MeshError(f"with_points needs an array of shape {self.points.shape} (one (x, y, z) per node, "
                            f"metres), got shape {p.shape}")
        return TetMesh(p, self.tets, {t: self.boundary(t) for t in self.tags})

    def renumbered(self, order: ArrayLike) -> TetMesh:
        """The same mesh with its nodes numbered in a new order: node i of the new mesh is node ``order[i]``
        of this one.

        ``order`` is a permutation of 0..n-1 (n nodes). The points are ``self.points[order]``, the
        tets and every tagged part keep their order with their node indices renumbered, so a nodal
        field ``f`` of this mesh is ``f[order]`` on the new one (and ``g[np.argsort(order)]`` takes a field
        ``g`` of the new mesh back). The body, its parts and its cells are unchanged: only the numbering,
        and with it the order of the unknowns, differs.

        Raises
        ------
        MeshError
            If ``order`` is not a permutation of the node indices.
        """
        order, new = checked_renumbering(order, len(self.points))
        return TetMesh(self.points[order], new[self.tets], {t: new[self.boundary(t)] for t in self.tags})

    @cached_property
    def volumes(self) -> np.ndarray:
        """(m,) tetrahedron volumes in m^3 (read-only)."""
        return locked(_signed_volumes(self.points, self.tets), float)

    @cached_property
    def node_components(self) -> np.ndarray:
        """(n,) connected-component label of each node (read-only), numbered 0, 1, ... in the order
        of their lowest node index; two nodes are connected when a chain of edges joins them."""
        e = self.tets[:, EDGES.ravel()].reshape(-1, 2)
        n = len(self.points)
        _, labels = connected_components(coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)),
                                          directed=False)
        _, first = np.unique(labels, return_index=True)
        rank = np.empty(len(first), dtype=np.int64)
        rank[np.argsort(first)] = np.arange(len(first))
        return locked(rank[labels], np.int64)

    @cached_property
    def components(self) -> np.ndarray:
        """(m,) connected-component label of each tetrahedron (read-only), as :attr:`node_components`."""
        return locked(self.node_components[self.tets[:, 0]], np.int64)

    @property
    def boundary_faces(self) -> np.ndarray:
        """(k, 3) every face on the boundary, oriented outwards (read-only)."""
        return self._boundary_faces

    @cached_property
    def boundary_cells(self) -> np.ndarray:
        """(k,) the tetrahedron that owns each of :attr:`boundary_faces` (read-only)."""
        keys = facet_keys(np.sort(self.tets[:, OUTWARD_FACES].reshape(-1, 3), axis=1), len(self.points))
        order = np.argsort(keys, kind="stable")
        where = np.searchsorted(keys[order], facet_keys(np.sort(self._boundary_faces, axis=1), len(self.points)))
        return locked(order[where] // 4, np.int64)

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 3) faces carrying ``tag``, oriented so that (p1 - p0) x (p2 - p0) points out (read-only)."""
        try:
            return self._tags[tag]
        except KeyError:
            raise MeshError(f"unknown boundary tag {tag!r}; this mesh has {sorted(self._tags)}") from None

    def outward_normals(self, tag: str) -> np.ndarray:
        """(k, 3) unit outward normals of the faces carrying ``tag``."""
        n = _face_cross(self.points, self.boundary(tag))
        return n / np.linalg.norm(n, axis=1)[:, None]

    def face_areas(self, tag: str) -> np.ndarray:
        """(k,) areas of the faces carrying ``tag``, in m^2."""
        return 0.5 * np.linalg.norm(_face_cross(self.points, self.boundary(tag)), axis=1)

    def node_areas(self, tag: str) -> np.ndarray:
        """(n,) the area (m^2) of the faces carrying ``tag`` attributed to each node (a third of each face's),
        zero off the part."""
        return np.bincount(self.boundary(tag).ravel(), weights=np.repeat(self.face_areas(tag) / 3.0, 3),
                           minlength=len(self.points))

    def _orient_faces(self, tag, faces):
        faces = np.asarray(faces)
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.shape[0] == 0:
            raise MeshError(f"boundary part {tag!r} must be a non-empty (k, 3) array of node triples, "
                            f"got shape {faces.shape}")
        if not np.issubdtype(faces.dtype, np.integer):
            raise MeshError(f"boundary part {tag!r} must hold integer node indices")
        n = len(self.points)
        if faces.min() < 0 or faces.max() >= n:
            raise MeshError(f"boundary part {tag!r} refers to nodes outside 0..{n - 1}")
        keys = facet_keys(np.sort(faces, axis=1), n)
        where = np.minimum(np.searchsorted(self._boundary_keys, keys), len(self._boundary_keys) - 1)
        bad = self._boundary_keys[where] != keys
        if bad.any():
            raise MeshError(f"boundary part {tag!r}: {int(bad.sum())} face(s) are not on the boundary of the "
                            f"mesh, e.g. nodes {faces[bad][0].tolist()}")
        return self._boundary_faces[where]


# --------------------------------------------------------------------------- validation helpers

def as_points3(points):
    """The (n, 3) float array of a 3D mesh's ``points`` (m), checked: n >= 4, at most MAX_NODES, finite (a
    MeshError naming what is wrong otherwise)."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 4:
        raise MeshError(f"points must be an (n, 3) array with n >= 4, got shape {p.shape}")
    if len(p) > MAX_NODES:
        raise MeshError(f"{len(p)} nodes is more than a TetMesh holds ({MAX_NODES}); use a coarser mesh")
    if not np.isfinite(p).all():
        k = int(np.argmax(~np.isfinite(p).all(axis=1)))
        raise MeshError(f"points contain NaN or infinite coordinates, e.g. node {k}: {p[k].tolist()}")
    return np.ascontiguousarray(p)


def _as_tets(tets, n):
    t = np.asarray(tets)
    if t.ndim != 2 or t.shape[1] != 4 or len(t) == 0:
        raise MeshError(f"tets must be a non-empty (m, 4) array, got shape {t.shape}")
    if not np.issubdtype(t.dtype, np.integer):
        raise MeshError("tets must hold integer node indices")
    bad = (t < 0) | (t >= n)
    if bad.any():
        k = int(np.argmax(bad.any(axis=1)))
        raise MeshError(f"tetrahedron {k} (nodes {t[k].tolist()}) refers to nodes outside 0..{n - 1}")
    st = np.sort(t, axis=1)
    repeated = (st[:, 1:] == st[:, :-1]).any(axis=1)
    del st
    if repeated.any():
        k = int(np.argmax(repeated))
        raise MeshError(f"tetrahedron {k} repeats a node (nodes {t[k].tolist()}); expected four distinct nodes")
    return np.ascontiguousarray(t, dtype=np.int64)


def _signed_volumes(points, tets):
    a = points[tets[:, 0]]
    return np.einsum("ij,ij->i", points[tets[:, 1]] - a,
                     np.cross(points[tets[:, 2]] - a, points[tets[:, 3]] - a)) / 6.0


def _longest_edges(points, tets):
    """(m,) the longest edge of each tetrahedron (metres)."""
    edge = points[tets[:, EDGES[:, 1]]] - points[tets[:, EDGES[:, 0]]]                   # (m, 6, 3)
    return np.sqrt((edge ** 2).sum(axis=2).max(axis=1))


def _orient(points, tets):
    """Refuse degenerate tetrahedra (volume <= DEGENERATE_TOL x longest edge^3) and mixed orientation;
    reorient a mesh that is negative throughout."""
    vol = np.concatenate([_signed_volumes(points, tets[s:s + CHUNK]) for s in range(0, len(tets), CHUNK)])
    longest = np.concatenate([_longest_edges(points, tets[s:s + CHUNK]) for s in range(0, len(tets), CHUNK)])
    tiny = np.abs(vol) <= DEGENERATE_TOL * longest ** 3
    if tiny.any():
        k = int(np.argmax(tiny))
        raise MeshError(f"{int(tiny.sum())} degenerate (flat) tetrahedra, e.g. tetrahedron {k}: nodes "
                        f"{tets[k].tolist()}, volume {vol[k]:.3g} m^3 for a longest edge of {longest[k]:.3g} m")
    return one_orientation(tets, vol > 0, [0, 2, 1, 3], ("tetrahedra", "tetrahedra", "tetrahedron"))


def _face_cross(points, faces):
    p0 = points[faces[:, 0]]
    return np.cross(points[faces[:, 1]] - p0, points[faces[:, 2]] - p0)


def _parity(t):
    """(k,) parity (0 even, 1 odd) of the permutation that sorts each row of the (k, 3) array t."""
    return ((t[:, 0] > t[:, 1]).astype(int) + (t[:, 0] > t[:, 2]) + (t[:, 1] > t[:, 2])) % 2


def _check_embedding(points, tets):
    """The boundary faces (sorted keys, outward triples) of a mesh whose tetrahedra neither overlap nor fold.

    With every tetrahedron positive and non-degenerate (checked before), this checks that:

    (a) every face belongs to at most two tetrahedra, which lie on opposite sides of it;
    (b) the boundary is a closed surface without seams: each boundary edge lies on exactly two
        boundary faces (two parts touching along an edge put four there);
    (c) the tetrahedra at a node form one fan, connected through faces at that node (two parts
        touching at a single node form two);
    (d) the tetrahedra turn once around every edge: their dihedral angles sum to 2 pi at an interior
        edge and to less than 2 pi at a boundary edge (a fan that wraps k extra times adds 2 pi k).
        With (a)-(c) the tetrahedra around every interior node then cover a ball around it once (the
        link is a connected covering of the sphere); around a boundary node they form a cone over a
        disc of the sphere, which (d) cannot tell from a disc that spirals over itself;
    (e) separate boundary surfaces (pieces of the body, cavities) do not cross: the winding number of
        the other surfaces at a node of each is 0 for an outer surface and 1 for a cavity.

    (f) the boundary surface does not cut through itself: boundary faces with no common node do not
        meet, and of two faces with one common node, neither's opposite edge meets the other
        (:func:`_check_self_intersection`; faces sharing an edge are left to (b) and (d)).

    With (a)-(d) the mesh is one sheet near every interior point, so two tetrahedra can overlap only
    where the boundary surface cuts through itself (f) or one piece lies inside another (e). Note that
    the divergence theorem (the tetrahedra's volume equal to the volume the boundary encloses) adds
    nothing once (a) holds: the interior faces' fluxes cancel, so the two volumes agree for any mesh
    passing (a), overlapping pieces included. Cost: one sort of the 4m face keys for (a), linear in m for
    (c) (connected components; a node's fans counted from them) and (d) (the angles summed per edge by a
    sparse matrix), O(surfaces x boundary faces) for (e), O(k log k) for (f) on k boundary faces of similar
    sizes (a grid of buckets). The per-element geometry and the pairs of (f) go by blocks of CHUNK, the face
    table is int32: the peak is about 480 bytes per tetrahedron (benchmarks/bench_tetmesh.py).
    """
    n, m = len(points), len(tets)
    local = OUTWARD_FACES.astype(np.int8)                                     # face j opposite vertex j
    faces = tets.astype(np.int32)[:, local].reshape(-1, 3)                   # (4m, 3), row 4 t + j (n < 2^31)
    order_in_face = np.argsort(faces, axis=1).astype(np.int8)
    sorted_faces = np.take_along_axis(faces, order_in_face, axis=1)
    keys = np.concatenate([facet_keys(sorted_faces[s:s + 4 * CHUNK], n) for s in range(0, 4 * m, 4 * CHUNK)])
    del sorted_faces
    order = np.argsort(keys, kind="stable")
    skeys = keys[order]
    del keys
    start = np.flatnonzero(np.r_[True, skeys[1:] != skeys[:-1]])
    count = np.diff(np.r_[start, len(skeys)])
    if (count > 2).any():                                                                     # (a)
        r = int(order[start[np.argmax(count > 2)]])
        raise MeshError(f"face {faces[r].tolist()} is shared by {int(count[np.argmax(count > 2)])} tetrahedra "
                        f"(tetrahedron {r // 4} and others): the mesh is not a manifold; expected at most two")
    pair = start[count == 2]
    r1, r2 = order[pair], order[pair + 1]
    same = _parity(faces[r1]) == _parity(faces[r2])
    if same.any():
        k = int(np.argmax(same))
        raise MeshError(f"tetrahedra {int(r1[k] // 4)} and {int(r2[k] // 4)} (nodes {tets[r1[k] // 4].tolist()} "
                        f"and {tets[r2[k] // 4].tolist()}) lie on the same side of their common face "
                        f"{sorted(faces[r1[k]].tolist())}: they overlap; expected neighbours on opposite sides")
    once = start[count == 1]
    bkeys, bfaces = skeys[once], faces[order[once]].astype(np.int64)
    del faces, skeys, order, start, count, pair, same, once
    _check_boundary_edges(points, bfaces, n)                                                  # (b)
    # (c): incidences (node, tet) = 4 t + i, joined across each interior face at its three nodes; each
    # component (a fan) holds one node's incidences, so a node's fans are the components that name it
    a = (4 * (r1 // 4)).astype(np.int32)[:, None] + local[(r1 % 4)[:, None], order_in_face[r1]]
    b = (4 * (r2 // 4)).astype(np.int32)[:, None] + local[(r2 % 4)[:, None], order_in_face[r2]]
    del order_in_face, r1, r2
    graph = coo_matrix((np.ones(a.size), (a.ravel(), b.ravel())), shape=(4 * m, 4 * m)).tocsr()
    del a, b
    fans, label = connected_components(graph, directed=False)
    del graph
    fan_node = np.empty(fans, dtype=np.int64)
    fan_node[label] = tets.ravel()
    per_node = np.bincount(fan_node, minlength=n)
    if (per_node > 1).any():
        v = int(np.argmax(per_node > 1))
        raise MeshError(f"node {v} at {points[v].tolist()} joins {int(per_node[v])} separate fans of tetrahedra: "
                        "parts of the mesh touch at a single node; expected one fan around each node")
    _check_fans(points, tets, bfaces)                                                        # (d)
    _check_surfaces(points, bfaces)                                                          # (e)
    _check_self_intersection(points, bfaces)                                                 # (f)
    return bkeys, bfaces


def _check_boundary_edges(points, bfaces, n):
    """(b): each boundary edge on exactly two boundary faces."""
    e = np.sort(bfaces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    keys, count = np.unique(e[:, 0] * n + e[:, 1], return_counts=True)
    bad = count != 2
    if bad.any():
        k = int(np.argmax(bad))
        a, b = divmod(int(keys[k]), n)
        raise MeshError(f"boundary edge ({a}, {b}) at {points[a].tolist()} lies on {int(count[k])} boundary faces, "
                        "expected 2: parts of the mesh touch along an edge (or the boundary is not closed)")


def _dihedral_angles(points, tets):
    """(m, 6) interior dihedral angle of each positive tetrahedron at each edge of EDGES (radians).

    At the edge shared by the faces opposite vertices k and l, with outward face normals N_k, N_l
    (|N| twice the face's area): |N_k x N_l| = 6 V |e| and the angle is atan2(6 V |e|, -N_k . N_l)."""
    p = points[tets]                                                          # (m, 4, 3)
    side = p[:, OUTWARD_FACES]                                                # (m, 4, 3, 3)
    normal = np.cross(side[:, :, 1] - side[:, :, 0], side[:, :, 2] - side[:, :, 0])
    del side
    d = p[:, 1:] - p[:, :1]
    six_v = np.einsum("mk,mk->m", d[:, 0], np.cross(d[:, 1], d[:, 2]))
    e = p[:, EDGES[:, 1]] - p[:, EDGES[:, 0]]
    length = np.sqrt(np.einsum("mek,mek->me", e, e))
    dot = np.einsum("mek,mek->me", normal[:, OTHER[:, 0]], normal[:, OTHER[:, 1]])
    return np.arctan2(six_v[:, None] * length, -dot)


def _solid_angles(a, b, c):
    """Signed solid angle (steradians) of the triangles (a, b, c), vectors from the viewpoint
    (Van Oosterom and Strackee, 1983); positive when det(a, b, c) > 0."""
    la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
    num = np.einsum("...k,...k->...", a, np.cross(b, c))
    den = la * lb * lc + np.einsum("...k,...k->...", a, b) * lc + np.einsum("...k,...k->...", a, c) * lb \
        + np.einsum("...k,...k->...", b, c) * la
    return 2.0 * np.arctan2(num, den)


def _check_fans(points, tets, bfaces):
    """(d): the tetrahedra turn once around every edge (dihedral angle sums, _check_embedding).

    The angles are summed per edge by a sparse (n, n) matrix built from blocks of CHUNK tetrahedra
    (int32 node indices)."""
    n, m = len(points), len(tets)
    row = np.empty((m, 6), dtype=np.int32)
    col = np.empty((m, 6), dtype=np.int32)
    angle = np.empty((m, 6))
    for s in range(0, m, CHUNK):
        t = tets[s:s + CHUNK]
        a, b = t[:, EDGES[:, 0]], t[:, EDGES[:, 1]]
        row[s:s + CHUNK], col[s:s + CHUNK] = np.minimum(a, b), np.maximum(a, b)
        angle[s:s + CHUNK] = _dihedral_angles(points, t)
    total = coo_matrix((angle.ravel(), (row.ravel(), col.ravel())), shape=(n, n)).tocsr()   # sums per edge
    del row, col, angle
    total.sum_duplicates()                                                    # rows' columns ascending
    off = np.flatnonzero(np.abs(total.data - 2 * np.pi) > ANGLE_TOL)         # not one turn: bad unless boundary
    if not len(off):
        return
    keys = (np.searchsorted(total.indptr, off, side="right") - 1) * np.int64(n) + total.indices[off]
    be = np.sort(bfaces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    boundary_edge = np.isin(keys, be[:, 0] * np.int64(n) + be[:, 1])
    turns = total.data[off]
    bad = np.where(boundary_edge, turns > 2 * np.pi + ANGLE_TOL, True)
    if bad.any():
        k = int(np.argmax(bad))
        a, b = divmod(int(keys[k]), n)
        raise MeshError(f"the tetrahedra around {'boundary' if boundary_edge[k] else 'interior'} edge ({a}, {b}) "
                        f"at {points[a].tolist()} turn {turns[k] / (2 * np.pi):.3f} times around it, expected "
                        f"{'less than ' if boundary_edge[k] else ''}1: the mesh folds over itself there")


def _check_surfaces(points, bfaces):
    """(e): separate boundary surfaces do not cross (_check_embedding)."""
    n = len(points)
    e = bfaces[:, [0, 1, 1, 2]].reshape(-1, 2)
    _, node_surface = connected_components(coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)),
                                           directed=False)
    surface = node_surface[bfaces[:, 0]]
    surfaces, first = np.unique(surface, return_index=True)
    if len(surfaces) == 1:
        return
    centre = points.mean(axis=0)
    p = points[bfaces] - centre                                               # (k, 3, 3)
    volume = np.bincount(np.searchsorted(surfaces, surface),
                         weights=np.einsum("ik,ik->i", p[:, 0], np.cross(p[:, 1], p[:, 2])))
    cavity = volume < 0
    chunk = max(1, 2_000_000 // len(bfaces))
    for s in range(0, len(surfaces), chunk):
        q = points[bfaces[first[s:s + chunk], 0]][:, None, None, :]          # one node per surface
        omega = _solid_angles(*(points[bfaces][None, :, j] - q[:, :, 0] for j in range(3)))
        other = surfaces[s:s + chunk, None] != surface[None, :]
        wind = np.rint((omega * other).sum(axis=1) / (4 * np.pi)).astype(int)
        bad = wind != cavity[s:s + chunk]
        if bad.any():
            i = s + int(np.argmax(bad))
            v = int(bfaces[first[i], 0])
            raise MeshError(f"the boundary surface through node {v} at {points[v].tolist()} lies inside "
                            f"{int(wind[i - s])} other layer(s) of tetrahedra, expected {int(cavity[i])}: "
                            "separate parts of the mesh overlap")


def _check_self_intersection(points, bfaces):
    """(f): no two boundary faces meet except at their common nodes (_check_embedding).

    Candidate pairs share a bucket of a uniform grid (spacing: the median face size, doubled while the
    buckets would hold too many entries) and have overlapping bounding boxes; each pair is tested by
    separating axes, a gap below TOUCH_TOL times the pair's size counting as contact."""
    k = len(bfaces)
    tri = points[bfaces]                                                      # (k, 3, 3)
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    size = (hi - lo).max(axis=1)
    cell = max(float(np.median(size)), float(size.max()) / 1000.0)
    while True:
        first = np.floor((lo - lo.min(axis=0)) / cell).astype(np.int64)
        last = np.floor((hi - lo.min(axis=0)) / cell).astype(np.int64)
        span = last - first + 1
        count = span.prod(axis=1)
        if count.sum() <= 20 * k + 1_000_000:
            break
        cell *= 2.0
    face = np.repeat(np.arange(k), count)                                     # one entry per (face, bucket)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    sy, sz = span[face, 1], span[face, 2]
    ijk = first[face] + np.column_stack([local // (sy * sz), (local // sz) % sy, local % sz])
    dims = ijk.max(axis=0) + 1
    key = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    order = np.argsort(key, kind="stable")
    key, face = key[order], face[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    group = np.diff(np.r_[start, len(key)])
    rank = np.arange(len(key)) - np.repeat(start, group)                      # position in its bucket
    later = np.repeat(group, group) - rank - 1                                # partners after it
    a = np.repeat(np.arange(len(key)), later)
    b = a + 1 + (np.arange(later.sum()) - np.repeat(np.cumsum(later) - later, later))
    fa, fb = np.minimum(face[a], face[b]), np.maximum(face[a], face[b])
    pairs = np.sort(fa * np.int64(k) + fb)                                    # each pair once, by a sort (NumPy
    pairs = pairs[np.r_[True, pairs[1:] != pairs[:-1]]]                       # 2.4's hashing np.unique: 47x slower)
    fa, fb = pairs // k, pairs % k
    keep = (fa != fb) & (lo[fa] <= hi[fb]).all(axis=1) & (lo[fb] <= hi[fa]).all(axis=1)
    fa, fb = fa[keep], fb[keep]
    meet = np.concatenate([_faces_meet(bfaces, tri, size, fa[s:s + CHUNK], fb[s:s + CHUNK])
                           for s in range(0, len(fa), CHUNK)] or [np.zeros(0, dtype=bool)])
    if meet.any():
        i = int(np.argmax(meet))
        f, g = bfaces[fa[i]], bfaces[fb[i]]
        raise MeshError(f"boundary faces {f.tolist()} and {g.tolist()} meet near {points[f].mean(axis=0).tolist()} "
                        "away from their common nodes: the boundary surface cuts through itself (the mesh "
                        "overlaps itself or touches itself there)")


TOUCH_TOL = 1e-9
"""Two boundary faces closer than this times their size count as touching (:func:`_check_self_intersection`)."""


def _faces_meet(bfaces, tri, size, fa, fb):
    """(p,) True where boundary faces fa and fb (p,) meet away from their common nodes: faces with no common
    node anywhere, faces with one common node where either's opposite edge meets the other (faces sharing an
    edge: False, left to (b) and (d)); ``tri`` (k, 3, 3) their vertices, ``size`` (k,) their sizes."""
    shared = (bfaces[fa][:, :, None] == bfaces[fb][:, None, :])               # (p, 3, 3)
    common = shared.sum(axis=(1, 2))
    tol = TOUCH_TOL * np.maximum(size[fa], size[fb])
    meet = np.zeros(len(fa), dtype=bool)
    apart = common == 0
    meet[apart] = _meet(tri[fa[apart]], tri[fb[apart]], tol[apart])
    one = np.flatnonzero(common == 1)
    if len(one):                                                              # the edge opposite the common node
        ia = np.argmax(shared[one].any(axis=2), axis=1)
        ib = np.argmax(shared[one].any(axis=1), axis=1)
        opp = np.array([[1, 2, 2], [0, 2, 2], [0, 1, 1]])                     # a segment as a flat triangle
        r = np.arange(len(one))[:, None]
        edge_a = tri[fa[one]][r, opp[ia]]
        edge_b = tri[fb[one]][r, opp[ib]]
        meet[one] = _meet(edge_a, tri[fb[one]], tol[one]) | _meet(edge_b, tri[fa[one]], tol[one])
    return meet


def _meet(A, B, tol):
    """(p,) True where the convex sets of the (p, 3, 3) vertex triples A and B (triangles, or segments given
    as a triangle with a repeated vertex) are within ``tol`` (p,) of each other (:func:`_meet_block`, by
    blocks of CHUNK pairs)."""
    return np.concatenate([_meet_block(A[s:s + CHUNK], B[s:s + CHUNK], tol[s:s + CHUNK])
                           for s in range(0, len(A), CHUNK)] or [np.zeros(0, dtype=bool)])


def _meet_block(A, B, tol):
    """(p,) True where the convex sets of the (p, 3, 3) vertex triples A and B (triangles, or segments given
    as a triangle with a repeated vertex) are within ``tol`` (p,) of each other along every axis of the
    separating-axis test: the two normals, the cross products of each normal with its own edges, then with
    the other's edges (the coplanar cases) and the cross products of their edges, tried in that order on the pairs not yet
    separated. Each pair is first moved and scaled to unit size, so the test is the same at every length
    scale (a box of 1e-12 m as of 1 m). Axes are unit vectors built from unit edges; an edge shorter than
    1e-9 of its pair's size is no edge (a segment's repeated vertex), an axis from directions parallel to
    1e-9 is skipped (the others separate such pairs)."""
    origin = A[:, :1]
    scale = np.ptp(np.concatenate([A, B], axis=1), axis=1).max(axis=1)        # (p,) the pair's size
    scale = np.where(scale > 0, scale, 1.0)
    A, B = (A - origin) / scale[:, None, None], (B - origin) / scale[:, None, None]
    tol = tol / scale
    ea = _unit(A[:, [1, 2, 0]] - A)                                           # (p, 3, 3) unit edges, 0 if none
    eb = _unit(B[:, [1, 2, 0]] - B)
    na = _unit(np.cross(ea[:, 0], ea[:, 1]) + np.cross(ea[:, 1], ea[:, 2]))[:, None]   # 0 for a segment
    nb = _unit(np.cross(eb[:, 0], eb[:, 1]) + np.cross(eb[:, 1], eb[:, 2]))[:, None]
    if (A[:, 2] == A[:, 1]).all():          # segments: na = ea[1] = 0, ea[2] = -ea[0]; the axes left, once each
        stages = [lambda i: nb[i],
                  lambda i: np.cross(nb[i], eb[i]),
                  lambda i: np.cross(nb[i], ea[i][:, :1]),
                  lambda i: np.cross(ea[i][:, :1, None], eb[i][:, None, :]).reshape(-1, 3, 3)]
    else:
        stages = [lambda i: np.concatenate([na[i], nb[i]], axis=1),
                  lambda i: np.concatenate([np.cross(na[i], ea[i]), np.cross(nb[i], eb[i])], axis=1),
                  lambda i: np.concatenate([np.cross(na[i], eb[i]), np.cross(nb[i], ea[i])], axis=1),
                  lambda i: np.cross(ea[i][:, :, None], eb[i][:, None, :]).reshape(-1, 9, 3)]
    live = np.arange(len(A))
    for axes in stages:
        ax = _unit(axes(live))                                                # (q, a, 3)
        pa, pb = ax @ A[live].transpose(0, 2, 1), ax @ B[live].transpose(0, 2, 1)   # (q, a, 3) projections
        gap = np.maximum(np.minimum(np.minimum(pb[..., 0], pb[..., 1]), pb[..., 2])
                         - np.maximum(np.maximum(pa[..., 0], pa[..., 1]), pa[..., 2]),
                         np.minimum(np.minimum(pa[..., 0], pa[..., 1]), pa[..., 2])
                         - np.maximum(np.maximum(pb[..., 0], pb[..., 1]), pb[..., 2]))
        usable = (ax[..., 0] != 0) | (ax[..., 1] != 0) | (ax[..., 2] != 0)
        live = live[~((gap > tol[live, None]) & usable).any(axis=1)]
    out = np.zeros(len(A), dtype=bool)
    out[live] = True
    return out


def _unit(v):
    """v / |v| along the last axis, 0 where |v| <= 1e-9 (v dimensionless: unit-size pairs, unit vectors)."""
    n = np.sqrt(v[..., 0] ** 2 + v[..., 1] ** 2 + v[..., 2] ** 2)[..., None]
    return np.where(n > 1e-9, v / np.where(n > 0, n, 1.0), 0.0)


# --------------------------------------------------------------------------- reading

def read_tets(m, path, boundaries: Mapping[str, ArrayLike] | None = None,
              region: str | int | None = None) -> TetMesh:
    """The :class:`TetMesh` of a meshio mesh ``m`` read from ``path`` (called by
    :func:`~cvxcontact.geometry.mesh.read_mesh` for files holding tetrahedra).

    Boundary parts are the triangle cells, named by gmsh physical names (``field_data``, dimension 2)
    or, without names, by their physical number as a string; ``boundaries`` may add or override parts
    as node triples in the file's numbering. ``region`` selects the tetrahedra of one physical volume
    (by name or number); its parts are then the tagged triangles on that volume's boundary. Unused
    nodes are dropped. Second-order files (``tetra10``, ``triangle6``) are read as their corner
    tetrahedra and triangles: the P2 space rebuilds the edge midpoints, so every mid-node must lie at
    the midpoint of an edge of its cell (checked, 1e-9 of the edge length).
    """
    kinds = {block.type for block in m.cells}
    if {"tetra", "tetra10"} <= kinds:
        raise MeshError(f"mesh file {str(path)!r} mixes tetra and tetra10 cells")
    other = kinds & {"hexahedron", "wedge", "pyramid", "triangle7", "quad", "quad8", "quad9"}
    if other:
        raise MeshError(f"mesh file {str(path)!r} holds {sorted(other)} cells; cvxcontact's 3D meshes are "
                        "tetrahedra with triangle boundary faces")
    blocks = [k for k, b in enumerate(m.cells) if b.type in ("tetra", "tetra10")]
    for k in [k for k, b in enumerate(m.cells) if b.type in ("tetra10", "triangle6")]:
        _check_straight(m.points, m.cells[k].data, m.cells[k].type, path)
    tets = np.concatenate([m.cells[k].data[:, :4] for k in blocks]).astype(np.int64)
    physical = m.cell_data.get("gmsh:physical")
    if region is not None:
        volumes = {k: int(v[0]) for k, v in (m.field_data or {}).items() if len(v) > 1 and int(v[1]) == 3}
        ids = np.concatenate([physical[k] for k in blocks]) if physical is not None else None
        wanted = volumes.get(str(region), int(region) if str(region).isdigit() else None)
        if ids is None or wanted is None or not (ids == wanted).any():
            have = sorted(volumes) or (sorted({str(int(i)) for i in np.unique(ids)}) if ids is not None else [])
            raise MeshError(f"mesh file {str(path)!r} has no physical volume {region!r}; it has {have}")
        tets = tets[ids == wanted]
    names = {int(v[0]): k for k, v in (m.field_data or {}).items() if len(v) > 1 and int(v[1]) == 2}
    parts: dict[str, list] = {}
    for k, block in enumerate(m.cells):
        if block.type not in ("triangle", "triangle6"):
            continue
        ids = physical[k] if physical is not None else np.zeros(len(block.data), dtype=int)
        for pid in np.unique(ids):
            parts.setdefault(names.get(int(pid), str(int(pid))), []).append(block.data[ids == pid, :3])
    faces = {tag: np.concatenate(v).astype(np.int64) for tag, v in parts.items()}
    faces.update({str(k): np.asarray(v) for k, v in (boundaries or {}).items()})
    used = np.unique(tets)
    renumber = np.full(len(m.points), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    points = np.asarray(m.points, dtype=float)[used]
    if points.shape[1] != 3:
        raise MeshError(f"mesh file {str(path)!r} holds tetrahedra with {points.shape[1]}D points; expected 3D")
    if region is not None:                                    # keep the faces on this volume's boundary
        own = TetMesh(points, renumber[tets])
        for tag, f in list(faces.items()):
            inside = (renumber[f] >= 0).all(axis=1)
            k = facet_keys(np.sort(renumber[f[inside]], axis=1), len(used))
            keep = np.isin(k, own._boundary_keys)
            if keep.any():
                faces[tag] = f[inside][keep]
            else:
                del faces[tag]
    for tag, f in faces.items():
        if (renumber[f] < 0).any():
            raise MeshError(f"boundary part {tag!r} in {str(path)!r} uses nodes that belong to no tetrahedron")
    return TetMesh(points, renumber[tets], {t: renumber[f] for t, f in faces.items()})


def _check_straight(points, cells, kind, path):
    """Each mid-node of a tetra10 / triangle6 cell at the midpoint of one of its cell's edges."""
    nv = 4 if kind == "tetra10" else 3
    pairs = EDGES if nv == 4 else np.array([[0, 1], [1, 2], [0, 2]])
    mids = 0.5 * (points[cells[:, pairs[:, 0]]] + points[cells[:, pairs[:, 1]]])          # (k, e, 3)
    length = np.linalg.norm(points[cells[:, pairs[:, 0]]] - points[cells[:, pairs[:, 1]]], axis=2).min(axis=1)
    nodes = points[cells[:, nv:]]                                                          # (k, e, 3)
    off = np.linalg.norm(nodes[:, :, None, :] - mids[:, None, :, :], axis=3).min(axis=2).max(axis=1)
    if (off > 1e-9 * length).any():
        k = int(np.argmax(off > 1e-9 * length))
        raise MeshError(f"mesh file {str(path)!r}: {kind} cell {k} has a curved edge (a mid-node off the "
                        "midpoints of its edges); cvxcontact's P2 elements are straight-sided")
