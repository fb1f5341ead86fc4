"""Hexahedral Lagrange elements Q1 (8 nodes) and Q2 (27 nodes) on the trilinear map of each cell (SI units).

Reference cell [-1, 1]^3, nodes in the VTK_HEXAHEDRON / VTK_TRIQUADRATIC_HEXAHEDRON order (meshio's
``hexahedron`` / ``hexahedron27``; gmsh's hexahedron27 differs in its edge and face nodes and meshio converts):
the corners (:data:`~cvxcontact.geometry.hexmesh.CORNERS`), then (Q2) the midpoints of the twelve edges
(``HEX_EDGES``), the centres of the six faces (``HEX_FACES``: x = -1, +1, y = -1, +1, z = -1, +1) and the centre.
The shape functions are tensor products of the 1D Lagrange polynomials on {-1, 1} (Q1) or {-1, 0, 1} (Q2)
(:class:`~cvxcontact.fem.quad.TensorElement`, shared with the quadrilaterals). The geometry is the trilinear
map of the corners for both (Q2 subparametric: its edge, face and centre nodes are the images of the reference
ones); the physical gradients are J^-T grad_xi N and the measure det J dxi.

Why 27 nodes and not the 20-node serendipity hexahedron: as for the 9-node quadrilateral
(:mod:`cvxcontact.fem.quad`), the trilinear image of Q2 keeps every polynomial of total degree 2 in x, and with
it the O(h^2) energy-norm rate, on cells that are not parallelepipeds; the serendipity space loses some. Its
trace on a face is the 9-node biquadratic quadrilateral.

Quadrature: Gauss-Legendre n x n x n, n = degree + 1 (2 x 2 x 2 for Q1, 3 x 3 x 3 for Q2), full integration
(no hourglass modes: the six rigid motions are the only zero-energy modes); surface densities on the faces by
the n x n rule on each face's bilinear map, |dx/dxi x dx/deta| its area element.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .assembly import BodySystem, accumulate, lifted
from .quad import QuadElement, TensorElement

__all__ = ["HexElement", "HEX1_ELEMENT", "HEX2_ELEMENT", "face_hats", "face_points", "bilinear_rows",
           "reference_points"]


class HexElement(TensorElement):
    """A Lagrange element on the reference cube (module docstring): ``degree`` 1 (8 nodes) or 2 (27 nodes)."""

    def __init__(self, degree: int) -> None:
        super().__init__(degree, 3)

    def loads(self, body, matrices: BodySystem, nodes) -> BodySystem:
        """``matrices`` with the consistent loads of ``body`` (SI, N and C per node): volume densities by
        :attr:`rule`, surface densities on the tagged faces by the faces' rule (4 or 9 face nodes: the
        corners, ``nodes.boundary(tag)`` for Q2)."""
        mesh = body.mesh
        held = mesh if nodes is None else nodes
        cells, n = held.cells, len(held.points)
        f = self._volume(mesh, cells, body.body_force, 3, n)
        for tag, load in body.traction.items():
            f += self._faces(mesh, held.boundary(tag), load, 3, n)
        q = None
        if matrices.piezoelectric:
            q = self._volume(mesh, cells, body.volume_charge, 1, n)[:, 0]
            for tag, load in body.surface_charge.items():
                q -= self._faces(mesh, held.boundary(tag), load, 1, n)[:, 0]
        return lifted(body, matrices, f.ravel(), q, held)

    def _faces(self, mesh, faces, load, ncomp, n) -> np.ndarray:
        """(n, ncomp) consistent nodal load of a surface density on the faces ``faces`` (k, 4 or 9), corners
        first."""
        out = np.zeros((n, ncomp))
        if not load.nonzero:
            return out
        for x, N, da in face_points(mesh.points, faces, self.degree):
            val = np.asarray(load(*x.T), dtype=float).reshape(len(x), ncomp) * da[:, None]
            out += accumulate(faces.T.ravel(), (N[:, None, None] * val[None]).reshape(-1, ncomp), n)
        return out


def face_points(points, faces, degree):
    """Yield (x (k, 3) m, N (j,), da (k,) m^2) at the points of the (degree + 1)^2 Gauss rule of the faces
    ``faces`` (k, j) (j = 4 corners, or 9 quad9 nodes for degree 2; the geometry the bilinear map of the corners):
    the points, the face shape functions there, the weights times the area element |dx/dxi x dx/deta|."""
    face = QuadElement(degree)
    X = points[faces[:, :4]]                                                   # (k, 4, 3) the bilinear map
    for xi, w in zip(*face.rule):
        N1, dN1 = face.linear.shape_derivatives(xi)
        J = np.einsum("kid,ai->kad", X, dN1)
        yield np.einsum("i,kid->kd", N1, X), face.shape(xi), w * np.linalg.norm(np.cross(J[:, 0], J[:, 1]), axis=1)


def face_hats(points, faces, degree) -> np.ndarray:
    """(n,) the integral over the faces ``faces`` (k, j) of each of the ``points``' (n, 3) face shape functions
    (m^2; bilinear for degree 1, biquadratic for 2, by :func:`face_points`' rule: exact on parallelograms), zero
    off the faces: a node's share of the faces' area, the lumped quadrature of a face load."""
    faces = np.asarray(faces)
    hats = np.zeros(len(points))
    for _, N, da in face_points(np.asarray(points, dtype=float), faces, degree):
        hats += np.bincount(faces.ravel(), weights=(da[:, None] * N[None]).ravel(), minlength=len(hats))
    return hats


def reference_points(X, host, points) -> np.ndarray:
    """(v, 2): the reference coordinates in [-1, 1]^2 of ``points`` (v, 2) m, point i in the planar quadrilateral
    ``host[i]`` of corners ``X`` (k, 4, 2) m (in-plane, in order around each), by Newton's method on the bilinear
    map (quadratic convergence from the centre on a convex face; 30 steps, far more than enough). Unclipped: a
    point outside its face comes out outside [-1, 1]^2."""
    element = QuadElement(1)
    Xh = X[host]                                                                # (v, 4, 2)
    xi = np.zeros((len(points), 2))
    for _ in range(30):
        N, dN = element.shape_derivatives(xi)                                   # (v, 4), (v, 2, 4)
        residual = np.asarray(points) - np.einsum("vi,vid->vd", N, Xh)
        J = np.einsum("vai,vid->vda", dN, Xh)                                   # dx_d / dxi_a
        xi = xi + np.linalg.solve(J, residual[..., None])[..., 0]
    return xi


def bilinear_rows(X, corners, host, points, n):
    """(v, n) sparse: the bilinear (Q1) functions of planar quadrilaterals at ``points`` (v, 2) m, point i in face
    ``host[i]``; the faces' corners ``X`` (k, 4, 2) m (in-plane coordinates, in order around each) and their
    indices ``corners`` (k, 4) among the n columns; the reference points by :func:`reference_points`."""
    xi = reference_points(X, host, points)
    N = QuadElement(1).shape(np.clip(xi, -1.0, 1.0))
    return sp.csr_matrix((N.ravel(), (np.repeat(np.arange(len(points)), 4), corners[host].ravel())),
                         shape=(len(points), n))


HEX1_ELEMENT = HexElement(1)
"""The trilinear 8-node element."""
HEX2_ELEMENT = HexElement(2)
"""The triquadratic 27-node element."""
