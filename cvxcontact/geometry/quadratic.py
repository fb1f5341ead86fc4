"""P2 node numbering on a P1 mesh (6-node triangles, 10-node tetrahedra): vertices first, then edge
midpoints.

Node ``i < n_vertices`` is vertex i of the mesh; node ``n_vertices + e`` is the midpoint of edge e
(edges numbered by sorted vertex pairs). The local order of a triangle is the gmsh triangle6 order
(v0, v1, v2, m01, m12, m20); of a tetrahedron the gmsh tetra10 order (v0, v1, v2, v3, m01, m12, m02,
m03, m23, m13) (VTK's tetra10 swaps the last two). Edges are straight, so midpoints are the arithmetic
means (m).
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshError, locked

__all__ = ["P2Nodes", "P2TetNodes", "Q2Nodes", "Q2HexNodes"]


class _MidpointNodes:
    """What the quadratic node sets share (module docstring): vertices first, then the edge midpoints numbered by
    sorted vertex pairs (``_keys``). A subclass sets ``mesh``, ``points``, ``n_vertices`` and ``_keys`` and
    answers ``cells`` and ``boundary(tag)``."""

    def __len__(self) -> int:
        return len(self.points)

    @property
    def node_components(self) -> np.ndarray:
        """(n,) the mesh component of each node (that of the cells it belongs to, as ``mesh.node_components``)."""
        comp = np.empty(len(self.points), dtype=self.mesh.node_components.dtype)
        cells = np.asarray(self.cells)
        comp[cells.ravel()] = np.repeat(self.mesh.components, cells.shape[1])
        return comp

    def midpoint(self, a, b) -> np.ndarray:
        """Node indices of the midpoints of the edges (a, b) (arrays of vertex indices)."""
        return _midpoint(self._keys, self.n_vertices, a, b)

    def boundary_nodes(self, tags) -> np.ndarray:
        """Sorted unique node indices (vertices and midpoints) on the parts named in ``tags`` (a name or names)."""
        parts = [self.boundary(t).ravel() for t in ([tags] if isinstance(tags, str) else tags)]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=int)


class _SegmentTraces(_MidpointNodes):
    """2D node sets (6-node triangles, 9-node quadrilaterals): boundary traces are 3-node segments."""

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 3) boundary edges carrying ``tag`` as (start, end, midpoint) node indices."""
        e = self.mesh.boundary(tag)
        return np.column_stack([e, self.midpoint(e[:, 0], e[:, 1])])


class P2Nodes(_SegmentTraces):
    """The P2 nodes of a :class:`~cvxcontact.geometry.mesh.Mesh` (module docstring).

    Attributes: ``mesh``, ``points`` (n, 2) m, ``triangles`` (m, 6) node indices of each element
    (read-only), ``n_vertices``.
    """

    def __init__(self, mesh) -> None:
        self.mesh = mesh
        tri = mesh.triangles
        nv = len(mesh.points)
        self._keys, mids, middles = _numbered_edges(mesh.points, tri, [[0, 1], [1, 2], [2, 0]])
        self.n_vertices = nv
        self.points = locked(np.concatenate([mesh.points, middles]))
        self.triangles = locked(np.column_stack([tri, mids]))

    @property
    def cells(self) -> np.ndarray:
        """(m, 6) the elements: ``triangles``."""
        return self.triangles



class P2TetNodes(_MidpointNodes):
    """The P2 nodes of a :class:`~cvxcontact.geometry.tetmesh.TetMesh` (module docstring).

    Attributes: ``mesh``, ``points`` (n + e, 3) m, ``tets10`` (m, 10) node indices of each element in the
    gmsh tetra10 order (v0, v1, v2, v3, m01, m12, m02, m03, m23, m13; ``tetmesh.EDGES``; read-only),
    ``n_vertices``.
    """

    def __init__(self, mesh) -> None:
        from .tetmesh import EDGES

        self.mesh = mesh
        tets = mesh.tets
        nv = len(mesh.points)
        self._keys, mids, middles = _numbered_edges(mesh.points, tets, EDGES)
        self.n_vertices = nv
        self.points = locked(np.concatenate([mesh.points, middles]))
        self.tets10 = locked(np.column_stack([tets, mids]))

    @property
    def cells(self) -> np.ndarray:
        """(m, 10) the elements: :attr:`tets10`."""
        return self.tets10

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 6) boundary faces carrying ``tag`` as triangle6 P2 node indices (v0, v1, v2, m01, m12, m20),
        the vertices oriented as :meth:`TetMesh.boundary <cvxcontact.geometry.tetmesh.TetMesh.boundary>`
        (outward)."""
        f = self.mesh.boundary(tag)
        return np.column_stack([f] + [self.midpoint(f[:, i], f[:, j]) for i, j in ((0, 1), (1, 2), (2, 0))])



class Q2Nodes(_SegmentTraces):
    """The Q2 (9-node) nodes of a :class:`~cvxcontact.geometry.quadmesh.QuadMesh`: its vertices, then the
    midpoints of its edges (numbered by sorted vertex pairs), then the cells' centres (the mean of the
    corners: the image of the reference centre by the bilinear map, as the midpoints are of the edges' middles).

    Attributes: ``mesh``, ``points`` (n, 2) m, ``quads9`` (m, 9) node indices of each element in the gmsh
    quad9 / VTK_BIQUADRATIC_QUAD order (v0, v1, v2, v3, m01, m12, m23, m30, centre; read-only),
    ``n_vertices``. The boundary traces are those of :class:`P2Nodes`: (start, end, midpoint).
    """

    def __init__(self, mesh) -> None:
        from .quadmesh import EDGES

        self.mesh = mesh
        quads = mesh.quads
        nv = len(mesh.points)
        self._keys, mids, middles = _numbered_edges(mesh.points, quads, EDGES)
        self.n_vertices = nv
        self.points = locked(np.concatenate([mesh.points, middles, mesh.points[quads].mean(axis=1)]))
        self.quads9 = locked(np.column_stack([quads, mids, nv + len(middles) + np.arange(len(quads))]))

    @property
    def cells(self) -> np.ndarray:
        """(m, 9) the elements: ``quads9``."""
        return self.quads9



class Q2HexNodes(_MidpointNodes):
    """The Q2 (27-node) nodes of a :class:`~cvxcontact.geometry.hexmesh.HexMesh`: its vertices, the midpoints of
    its edges (numbered by sorted vertex pairs), the centres of its faces (numbered by sorted corner quadruples)
    and the cells' centres, each the mean of the corners it stands on (the image of the reference node by the
    trilinear map: straight edges, the faces' and cells' centres).

    Attributes: ``mesh``, ``points`` (n, 3) m, ``hexes27`` (m, 27) node indices of each element in the
    VTK_TRIQUADRATIC_HEXAHEDRON order (meshio's ``hexahedron27``): corners, edge midpoints in ``HEX_EDGES``
    order, face centres in ``HEX_FACES`` order (x = -1, +1, y = -1, +1, z = -1, +1), centre; ``n_vertices``.
    """

    def __init__(self, mesh) -> None:
        from .hexmesh import HEX_EDGES, HEX_FACES

        self.mesh = mesh
        hexes = mesh.hexes
        nv = len(mesh.points)
        self._keys, mids, middles = _numbered_edges(mesh.points, hexes, HEX_EDGES)
        faces = np.sort(hexes[:, HEX_FACES].reshape(-1, 4), axis=1)
        self._faces, inverse = np.unique(faces, axis=0, return_inverse=True)
        first = nv + len(middles)
        centres = mesh.points[self._faces].mean(axis=1)
        self.n_vertices = nv
        self.points = locked(np.concatenate([mesh.points, middles, centres, mesh.points[hexes].mean(axis=1)]))
        self.hexes27 = locked(np.column_stack([hexes, mids, first + inverse.reshape(len(hexes), 6),
                                                first + len(centres) + np.arange(len(hexes))]))

    @property
    def cells(self) -> np.ndarray:
        """(m, 27) the elements: ``hexes27``."""
        return self.hexes27

    def face_centre(self, faces) -> np.ndarray:
        """Node indices of the centres of the faces ``faces`` (k, 4) (corner indices, any order)."""
        f = np.sort(np.asarray(faces), axis=1)
        uniq, inverse = np.unique(np.concatenate([self._faces, f]), axis=0, return_inverse=True)
        if len(uniq) != len(self._faces):
            raise MeshError("face_centre(): corners that are not a face of the mesh")
        return self.n_vertices + len(self._keys) + inverse.ravel()[len(self._faces):]

    def boundary(self, tag: str) -> np.ndarray:
        """(k, 9) boundary faces carrying ``tag`` as quad9 node indices (corners as :meth:`HexMesh.boundary
        <cvxcontact.geometry.hexmesh.HexMesh.boundary>`, outward; the midpoints of sides 01, 12, 23, 30; the
        centre)."""
        f = self.mesh.boundary(tag)
        sides = [self.midpoint(f[:, i], f[:, (i + 1) % 4]) for i in range(4)]
        return np.column_stack([f] + sides + [self.face_centre(f)])


    @property
    def triangulation(self) -> _FaceTriangles6:
        """The P2 node set of the faces' triangles (:attr:`HexMesh.triangulation
        <cvxcontact.geometry.hexmesh.HexMesh.triangulation>`): ``boundary(tag)`` (2 k, 6) triangle6 nodes of the
        two triangles of each face, the face's centre on the diagonal (its midpoint when the face is a
        parallelogram: then the 9 nodes of a face are the 6 + 6 of its triangles)."""
        return _FaceTriangles6(self)


class _FaceTriangles6:
    """The 6-node triangles of the faces of a :class:`Q2HexNodes` (its ``triangulation``): ``points`` and
    ``boundary(tag)`` as :class:`P2TetNodes`', on the triangles of the hexahedral mesh's split in their order."""

    def __init__(self, nodes) -> None:
        self.nodes, self.points = nodes, nodes.points

    def boundary(self, tag: str) -> np.ndarray:
        """(2 k, 6) triangle6 node indices (v0, v1, v2, m01, m12, m20) of the triangles of the faces carrying
        ``tag`` (triangles 2 q and 2 q + 1 on face q of ``mesh.boundary(tag)``)."""
        mesh = self.nodes.mesh
        quads, tri = mesh.boundary(tag), np.asarray(mesh.triangulation.boundary(tag))
        quad = np.repeat(quads, 2, axis=0)                                   # the face of each triangle
        centre = np.repeat(self.nodes.face_centre(quads), 2)
        where = np.argmax(tri[:, :, None] == quad[:, None, :], axis=2)       # (2 k, 3) corner positions
        mids = []
        for i, j in ((0, 1), (1, 2), (2, 0)):
            diagonal = (where[:, i] - where[:, j]) % 2 == 0
            mids.append(_side_or_centre(self.nodes, tri[:, i], tri[:, j], diagonal, centre))
        return np.column_stack([tri] + mids)


def _side_or_centre(nodes, a, b, diagonal, centre):
    """The midpoints of the sides (a, b) of the faces, the face's ``centre`` where (a, b) is its ``diagonal``."""
    out = centre.copy()
    side = ~diagonal
    out[side] = nodes.midpoint(a[side], b[side])
    return out


def _numbered_edges(points, cells, local_edges):
    """(keys, mids, middles): the edges of ``cells`` (vertex pairs ``local_edges`` of each) numbered by sorted
    vertex pairs: ``keys`` (e,) int64 a * nv + b (a < b), ``mids`` (m, k) the node index nv + e of each cell's
    k edges, ``middles`` (e, d) m their midpoints."""
    nv = len(points)
    pairs = np.sort(np.asarray(cells)[:, local_edges], axis=2)                   # (m, k, 2)
    keys, inverse = np.unique(pairs[..., 0].astype(np.int64) * nv + pairs[..., 1], return_inverse=True)
    ends = np.column_stack([keys // nv, keys % nv])
    return keys, nv + inverse.reshape(len(pairs), -1), 0.5 * (points[ends[:, 0]] + points[ends[:, 1]])


def _midpoint(keys, nv, a, b):
    a, b = np.asarray(a), np.asarray(b)
    key = np.minimum(a, b).astype(np.int64) * nv + np.maximum(a, b)
    pos = np.searchsorted(keys, key)
    if (pos >= len(keys)).any() or (keys[np.minimum(pos, len(keys) - 1)] != key).any():
        raise MeshError("midpoint(): a vertex pair that is not an edge of the mesh")
    return nv + pos
