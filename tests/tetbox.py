"""A minimal tetrahedral box for the 3D body and assembly tests (the 6-tetrahedra split of each hexahedron,
Kuhn's triangulation, conforming across cells), with the face tags of ``cc.box``: left/right (x), front/back (y),
bottom/top (z). Also its 10-node (P2) node set. Test scaffolding only; the package's TetMesh replaces it."""

from functools import cached_property

import numpy as np

# Kuhn's split of the unit cube: one tetrahedron per permutation (path 000 -> 111 along the axes)
_PERMS = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
TET10_EDGES = np.array([(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)])


class TetBox:
    dim = 3

    def __init__(self, points, tets, boundaries):
        p = np.array(points, dtype=float)
        t = np.array(tets, dtype=np.int64)
        e = p[t[:, 1:]] - p[t[:, :1]]
        det = np.einsum("ij,ij->i", e[:, 0], np.cross(e[:, 1], e[:, 2]))
        t[det < 0] = t[det < 0][:, [1, 0, 2, 3]]                      # positively oriented
        self.points, self.tets = p, t
        self._tags = {k: self._orient(np.asarray(v)) for k, v in boundaries.items()}
        for a in (self.points, self.tets):
            a.setflags(write=False)

    def _orient(self, faces):
        """Faces with (p1 - p0) x (p2 - p0) pointing out of the tetrahedron that owns them."""
        faces = np.array(faces, dtype=np.int64)
        key = {tuple(sorted(f)): i for i, f in enumerate(faces)}
        for tet in self.tets:
            for drop in range(4):
                f = tuple(sorted(np.delete(tet, drop)))
                if f in key:
                    i = key[f]
                    a, b, c = self.points[faces[i]]
                    if np.dot(np.cross(b - a, c - a), a - self.points[tet[drop]]) < 0:
                        faces[i] = faces[i][[0, 2, 1]]
        faces.setflags(write=False)
        return faces

    cells = property(lambda self: self.tets)
    tags = property(lambda self: tuple(self._tags))

    @cached_property
    def volumes(self):
        e = self.points[self.tets[:, 1:]] - self.points[self.tets[:, :1]]
        return np.einsum("ij,ij->i", e[:, 0], np.cross(e[:, 1], e[:, 2])) / 6.0

    @property
    def size(self):
        return float(np.ptp(self.points, axis=0).max())

    def boundary(self, tag):
        return self._tags[tag]

    def boundary_nodes(self, tags):
        parts = [self._tags[t].ravel() for t in tags]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=int)

    def _cross(self, tag):
        a, b, c = (self.points[self._tags[tag][:, k]] for k in range(3))
        return np.cross(b - a, c - a)

    def outward_normals(self, tag):
        n = self._cross(tag)
        return n / np.linalg.norm(n, axis=1)[:, None]

    def face_areas(self, tag):
        return 0.5 * np.linalg.norm(self._cross(tag), axis=1)

    node_components = cached_property(lambda self: np.zeros(len(self.points), dtype=int))
    components = cached_property(lambda self: np.zeros(len(self.tets), dtype=int))

    def moved(self, f):
        """The same box with points f(points) (an affine map with positive determinant keeps orientation)."""
        return TetBox(f(self.points), self.tets, {k: self._tags[k] for k in self._tags})


def box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 1.0), nx=2, ny=2, nz=2):
    xs, ys, zs = (np.linspace(a, b, n + 1) for (a, b), n in ((x, nx), (y, ny), (z, nz)))
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    index = np.arange(len(points)).reshape(nx + 1, ny + 1, nz + 1)
    I, J, K = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
    tets = []
    for perm in _PERMS:
        c = np.zeros((len(I), 3), dtype=int)
        nodes = [index[I, J, K]]
        for axis in perm:
            c[:, axis] += 1
            nodes.append(index[I + c[:, 0], J + c[:, 1], K + c[:, 2]])
        tets.append(np.column_stack(nodes))
    tets = np.concatenate(tets)
    faces = {}
    for name, axis, side in (("left", 0, 0), ("right", 0, 1), ("front", 1, 0), ("back", 1, 1),
                             ("bottom", 2, 0), ("top", 2, 1)):
        on = np.isclose(points[:, axis], (x, y, z)[axis][side])
        found = []
        for drop in range(4):
            f = np.delete(tets, drop, axis=1)
            found.append(f[on[f].all(axis=1)])
        faces[name] = np.concatenate(found)
    return TetBox(points, tets, faces)


class TetNodes:
    """10-node tetrahedra on a TetBox: vertices, then edge midpoints; local order (v0..v3, then the edges
    TET10_EDGES)."""

    def __init__(self, mesh):
        self.mesh = mesh
        nv = len(mesh.points)
        pairs = np.sort(mesh.tets[:, TET10_EDGES], axis=2)                  # (m, 6, 2)
        keys = pairs[..., 0] * nv + pairs[..., 1]
        self._keys, inverse = np.unique(keys.ravel(), return_inverse=True)
        edges = np.column_stack([self._keys // nv, self._keys % nv])
        self.n_vertices = nv
        self.points = np.concatenate([mesh.points, 0.5 * (mesh.points[edges[:, 0]] + mesh.points[edges[:, 1]])])
        self.tets10 = np.column_stack([mesh.tets, nv + inverse.reshape(-1, 6)])

    cells = property(lambda self: self.tets10)

    def __len__(self):
        return len(self.points)

    def midpoint(self, a, b):
        key = np.minimum(a, b) * self.n_vertices + np.maximum(a, b)
        return self.n_vertices + np.searchsorted(self._keys, key)

    def boundary(self, tag):
        f = self.mesh.boundary(tag)
        return np.column_stack([f, self.midpoint(f[:, 0], f[:, 1]), self.midpoint(f[:, 1], f[:, 2]),
                                self.midpoint(f[:, 2], f[:, 0])])

    def boundary_nodes(self, tags):
        parts = [self.boundary(t).ravel() for t in tags]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=int)
