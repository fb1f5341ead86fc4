"""Quadrilateral Lagrange elements Q1 (4 nodes) and Q2 (9 nodes) on the bilinear map of each cell (SI units).

Reference cell [-1, 1]^2, nodes in the gmsh quad / quad9 order (VTK_QUAD, VTK_BIQUADRATIC_QUAD): the corners
(-1, -1), (1, -1), (1, 1), (-1, 1), then (Q2) the side midpoints (0, -1), (1, 0), (0, 1), (-1, 0) and the centre
(0, 0). The shape functions are tensor products of the 1D Lagrange polynomials on {-1, 1} (Q1) or {-1, 0, 1}
(Q2). The geometry is the bilinear map x(xi) = sum_i X_i N1_i(xi) of the cell's corners X_i for both (Q2 is
subparametric: its edge and centre nodes are the images of the reference ones, straight sides), with Jacobian
J = dx/dxi; the physical gradients are J^-T grad_xi N and the measure det J dxi.

Why the 9-node Q2 and not the 8-node serendipity element: the bilinear map of a non-parallelogram cell keeps
every polynomial of total degree 2 in x inside the mapped 9-node space (it is Q2 in xi, and a quadratic in x of
a bilinear x(xi) is of degree at most 2 in each of xi, eta), while the mapped serendipity space loses some of
them, and with them the O(h^2) energy-norm rate, on distorted cells (Arnold, Boffi & Falk, Math. Comp. 71,
2002); its trace on a side is the same 3-node quadratic as a P2 triangle's (the contact lines need no change);
its centre node couples only to its own cell, so a condensation can eliminate it element by element.

Quadrature: Gauss-Legendre n x n, n = degree + 1 (2 x 2 for Q1, 3 x 3 for Q2): exact for the stiffness on
parallelograms and for the consistent loads of affine (Q1) or quadratic (Q2) densities on parallelograms, and
exact for the patch tests on any convex cell (the integrand of a(u, v) with a polynomial u in the space times
det J is a polynomial of degree at most 2 n - 1 in each variable).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .assembly import BodySystem, accumulate, lifted

__all__ = ["Q1_ELEMENT", "Q2_ELEMENT", "QuadElement", "TensorElement", "gauss_cube", "gauss_square", "inverse"]


def _lagrange_1d(nodes, t):
    """(values (..., p), derivatives (..., p)) of the 1D Lagrange polynomials on ``nodes`` (p,) at ``t`` (...)."""
    t = np.asarray(t, dtype=float)[..., None]
    nodes = np.asarray(nodes, dtype=float)
    p = len(nodes)
    value = np.ones(t.shape[:-1] + (p,))
    slope = np.zeros(t.shape[:-1] + (p,))
    for i in range(p):
        others = [j for j in range(p) if j != i]
        den = np.prod([nodes[i] - nodes[j] for j in others])
        factors = [t[..., 0] - nodes[j] for j in others]
        value[..., i] = np.prod(factors, axis=0) / den
        slope[..., i] = sum(np.prod([f for m, f in enumerate(factors) if m != k], axis=0)
                            for k in range(len(others))) / den
    return value, slope


def _lagrange_curvature(nodes, t):
    """(..., p): the second derivatives of the 1D Lagrange polynomials on ``nodes`` (p,) at ``t`` (...): the sum
    over ordered pairs a != b of the products of the other factors (0 for p = 2, constant for p = 3)."""
    t = np.asarray(t, dtype=float)
    nodes = np.asarray(nodes, dtype=float)
    p = len(nodes)
    out = np.zeros(t.shape + (p,))
    for i in range(p):
        others = [j for j in range(p) if j != i]
        den = np.prod([nodes[i] - nodes[j] for j in others])
        for a in others:
            for b in others:
                if a != b:
                    out[..., i] += np.prod([t - nodes[c] for c in others if c not in (a, b)], axis=0) / den
    return out


def gauss_square(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(xi (n^2, 2), w (n^2,)): the n x n Gauss-Legendre rule on [-1, 1]^2 (weights summing to 4), exact for
    polynomials of degree 2 n - 1 in each variable."""
    return gauss_cube(n, 2)


def gauss_cube(n: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """(xi (n^dim, dim), w (n^dim,)): the tensor Gauss-Legendre rule of n points per axis on [-1, 1]^dim (weights
    summing to 2^dim), exact for polynomials of degree 2 n - 1 in each variable."""
    t, w = np.polynomial.legendre.leggauss(n)
    grids = np.meshgrid(*([t] * dim), indexing="ij")
    weights = np.meshgrid(*([w] * dim), indexing="ij")
    return np.column_stack([g.ravel() for g in grids]), np.prod([g.ravel() for g in weights], axis=0)


def inverse(A) -> tuple[np.ndarray, np.ndarray]:
    """(det A (m,), A^-1 (m, d, d)) of the matrices ``A`` (m, d, d), d = 2 or 3, by the adjugate over the
    determinant (closed forms, elementwise over m: the Jacobians of many cells at once, where a batched LAPACK call
    costs far more per matrix). Equal to ``np.linalg.det`` and ``np.linalg.inv`` up to rounding (a few ulps of
    the entries for the well-conditioned Jacobians of valid cells)."""
    A = np.asarray(A, dtype=float)
    if A.shape[-1] == 2:
        det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
        adj = np.stack([np.stack([A[:, 1, 1], -A[:, 0, 1]], -1), np.stack([-A[:, 1, 0], A[:, 0, 0]], -1)], 1)
    else:
        r0, r1, r2 = A[:, 0], A[:, 1], A[:, 2]
        adj = np.stack([_cross(r1, r2), _cross(r2, r0), _cross(r0, r1)], axis=2)  # columns: A^-1 = adj / det
        det = np.einsum("md,md->m", r0, adj[:, :, 0])
    return det, adj / det[:, None, None]


def _cross(a, b) -> np.ndarray:
    """(m, 3) the cross products of the rows of ``a`` and ``b`` (m, 3)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


@dataclass(frozen=True)
class TensorElement:
    """A Lagrange element on the reference cube [-1, 1]^dim (module docstring; 3D: :mod:`cvxcontact.fem.hex`):
    ``degree`` 1 (2^dim nodes) or 2 (3^dim nodes), on the multilinear map of each cell's corners."""

    degree: int
    dim: int = 2

    @cached_property
    def _subsets(self) -> list:
        """The corner subsets each reference node is the centre of: the corners, then (degree 2) the edges, the
        faces (3D) and the cell, in the VTK / gmsh order of the element's nodes."""
        if self.dim == 2:
            corners = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
            groups = [[[0, 1], [1, 2], [2, 3], [3, 0]], [[0, 1, 2, 3]]]
        else:
            from ..geometry.hexmesh import CORNERS, HEX_EDGES, HEX_FACES
            corners = CORNERS
            groups = [HEX_EDGES.tolist(), HEX_FACES.tolist(), [list(range(8))]]
        out = [[i] for i in range(len(corners))]
        return out + ([g for group in groups for g in group] if self.degree == 2 else []), corners

    @cached_property
    def reference(self) -> np.ndarray:
        """(k, dim) the reference nodes in element order."""
        subsets, corners = self._subsets
        return np.array([corners[s].mean(axis=0) for s in subsets])

    @cached_property
    def _index(self) -> np.ndarray:
        """(k, dim) each node's 1D node indices (into -1, [0,] 1 sorted) along each reference axis."""
        line = np.linspace(-1.0, 1.0, self.degree + 1)
        return np.searchsorted(line, self.reference)

    @property
    def rule(self) -> tuple[np.ndarray, np.ndarray]:
        """The (degree + 1)^dim Gauss rule of the stiffness and the loads."""
        return gauss_cube(self.degree + 1, self.dim)

    @cached_property
    def linear(self) -> TensorElement:
        """The element of degree 1 of the same dimension: the geometry's map."""
        return self if self.degree == 1 else TensorElement(1, self.dim)

    def shape(self, xi) -> np.ndarray:
        """(..., k) the shape functions at reference points ``xi`` (..., dim)."""
        return self.shape_derivatives(xi)[0]

    def shape_derivatives(self, xi) -> tuple[np.ndarray, np.ndarray]:
        """(N (..., k), dN/dxi (..., dim, k)) at reference points ``xi`` (..., dim)."""
        xi = np.asarray(xi, dtype=float)
        line = np.linspace(-1.0, 1.0, self.degree + 1)
        v, d = zip(*(_lagrange_1d(line, xi[..., a]) for a in range(self.dim)))
        f = [v[a][..., self._index[:, a]] for a in range(self.dim)]
        g = [d[a][..., self._index[:, a]] for a in range(self.dim)]
        N = np.prod(f, axis=0)
        dN = np.stack([np.prod([g[a] if b == a else f[b] for b in range(self.dim)], axis=0)
                       for a in range(self.dim)], axis=-2)
        return N, dN

    @property
    def corners(self) -> np.ndarray:
        """(2^dim, dim) the reference corners, in element order."""
        return self._subsets[1]

    @cached_property
    def faces(self) -> np.ndarray:
        """(2 dim, 2^(dim - 1)) the local corners of each face of the cell, in order around it (2D: the sides
        (0, 1), (1, 2), (2, 3), (3, 0); 3D: :data:`~cvxcontact.geometry.hexmesh.HEX_FACES`)."""
        if self.dim == 2:
            return np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
        from ..geometry.hexmesh import HEX_FACES
        return HEX_FACES

    def face_rule(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(W (q, 2^(dim - 1)), w (q,)): the n^(dim - 1) Gauss rule on the reference face [-1, 1]^(dim - 1), each
        point as the weights of the face's corners (in the order of :attr:`faces`) whose combination it is: a
        point of a cell's face is the same combination of the corners' reference coordinates."""
        t, w = np.polynomial.legendre.leggauss(n)
        if self.dim == 2:
            return np.column_stack([(1 - t) / 2, (1 + t) / 2]), w
        xi, w2 = gauss_square(n)
        return TensorElement(1, 2).shape(xi), w2

    def second_derivatives(self, xi) -> np.ndarray:
        """(..., dim, dim, k) the second derivatives d^2 N / dxi_a dxi_b at reference points ``xi`` (..., dim)."""
        xi = np.asarray(xi, dtype=float)
        line = np.linspace(-1.0, 1.0, self.degree + 1)
        v, d = zip(*(_lagrange_1d(line, xi[..., a]) for a in range(self.dim)))
        f = [v[a][..., self._index[:, a]] for a in range(self.dim)]
        g = [d[a][..., self._index[:, a]] for a in range(self.dim)]
        c = [_lagrange_curvature(line, xi[..., a])[..., self._index[:, a]] for a in range(self.dim)]
        out = np.empty(xi.shape[:-1] + (self.dim, self.dim, len(self._index)))
        for a in range(self.dim):
            for b in range(self.dim):
                out[..., a, b, :] = np.prod([(c[e] if a == b else g[e]) if e in (a, b) else f[e]
                                             for e in range(self.dim)], axis=0)
        return out

    def at_points(self, corners, xi, second: bool = False):
        """(x (m, dim) m, G (m, dim, k) 1/m, det J (m,), J^-T (m, dim, dim), H (m, dim, dim, k) 1/m^2 or None) at
        one reference point per cell, ``xi`` (m, dim), of the cells with corner coordinates ``corners``
        (m, 2^dim, dim): as :meth:`at`, and with ``second`` the physical second derivatives of the shape functions
        d^2 N / dx_p dx_q = J^-T (d^2 N / dxi^2 - sum_c dN / dx_c d^2 x_c / dxi^2) J^-1 (the map's own curvature
        taken out)."""
        N1, dN1 = self.linear.shape_derivatives(xi)                          # (m, 2^dim), (m, dim, 2^dim)
        J = np.einsum("mid,mai->mda", corners, dN1)
        inv_T = np.linalg.inv(J).transpose(0, 2, 1)
        _, dN = self.shape_derivatives(xi)
        G = inv_T @ dN
        H = None
        if second:
            curv = np.einsum("mabi,mic->mabc", self.linear.second_derivatives(xi), corners)
            T = self.second_derivatives(xi) - np.einsum("mabc,mck->mabk", curv, G)
            H = np.einsum("mpa,mabk,mqb->mpqk", inv_T, T, inv_T)
        return np.einsum("mi,mid->md", N1, corners), G, np.linalg.det(J), inv_T, H

    def locate(self, corners, x, xi) -> np.ndarray:
        """(m, dim) the reference coordinates of the points ``x`` (m, dim) m in the cells of corners ``corners``
        (m, 2^dim, dim), by Newton's method on the multilinear map from ``xi`` (m, dim) (a point of the cell
        near the answer; exact at once where the map is affine). Eight steps: quadratic convergence from a
        point of the cell on a convex cell, far more than enough."""
        xi = np.array(xi, dtype=float)
        for _ in range(8):
            N1, dN1 = self.linear.shape_derivatives(xi)
            inv = inverse(dN1 @ corners)[1]                                 # (J^T)^-1, J = dx / dxi
            xi = xi + ((x - (N1[:, None, :] @ corners)[:, 0])[:, None, :] @ inv)[:, 0]
        return xi

    def at(self, corners, xi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x (m, dim) m, G (m, dim, k) 1/m, det J (m,)) at the reference point ``xi`` (dim,) of the cells with
        corner coordinates ``corners`` (m, 2^dim, dim): the point, the physical shape gradients, the Jacobian."""
        N1, dN1 = self.linear.shape_derivatives(xi)                          # the multilinear map
        J = np.einsum("mid,ai->mda", corners, dN1)                          # (m, dim, dim): dx_d / dxi_a
        if self.dim == 2:
            det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
            inv_T = np.stack([np.stack([J[:, 1, 1], -J[:, 1, 0]], -1), np.stack([-J[:, 0, 1], J[:, 0, 0]], -1)], 1)
            inv_T = inv_T / det[:, None, None]                               # J^-T
        else:
            det, inv_T = np.linalg.det(J), np.linalg.inv(J).transpose(0, 2, 1)
        _, dN = self.shape_derivatives(xi)
        return np.einsum("i,mid->md", N1, corners), inv_T @ dN, det

    def points(self, mesh) -> list[tuple[np.ndarray, np.ndarray]]:
        """[(G (m, dim, k), w (m,) m^dim)] at the points of :attr:`rule` on every cell of ``mesh``: what
        :func:`~cvxcontact.fem.assembly.assemble_points` integrates."""
        corners = mesh.points[mesh.cells]
        out = []
        for xi, w in zip(*self.rule):
            _, G, det = self.at(corners, xi)
            out.append((G, w * det))
        return out

    def _volume(self, mesh, cells, load, ncomp, n) -> np.ndarray:
        """(n, ncomp) consistent nodal load of a volume density over the cells."""
        out = np.zeros((n, ncomp))
        if not load.nonzero:
            return out
        corners = mesh.points[mesh.cells]
        for xi, w in zip(*self.rule):
            x, _, det = self.at(corners, xi)
            val = np.asarray(load(*x.T), dtype=float).reshape(len(x), ncomp) * (w * det)[:, None]
            N = self.shape(xi)
            out += accumulate(cells.T.ravel(), (N[:, None, None] * val[None]).reshape(-1, ncomp), n)
        return out


class QuadElement(TensorElement):
    """A Lagrange element on the reference square (module docstring): ``degree`` 1 (4 nodes) or 2 (9 nodes)."""

    def __init__(self, degree: int) -> None:
        super().__init__(degree, 2)

    def loads(self, body, matrices: BodySystem, nodes) -> BodySystem:
        """``matrices`` with the consistent loads of ``body`` (SI): volume densities by :attr:`rule`, surface
        densities on the boundary edges by the segments' rules of the same trace as P1 (2 nodes) or P2 (3)."""
        from . import p2
        from .assembly import edge_load

        mesh = body.mesh
        held = mesh if nodes is None else nodes
        cells, n = held.cells, len(held.points)
        segment = (lambda tag, load, c: edge_load(mesh, mesh.boundary(tag), load, c)) if self.degree == 1 else \
            (lambda tag, load, c: p2.edge_load_p2(nodes, nodes.boundary(tag), load, c))

        def edges(tag, load, c):                                    # (n, c) whatever the segment rule returns
            return np.reshape(segment(tag, load, c), (n, c))
        f = self._volume(mesh, cells, body.body_force, 2, n)
        for tag, load in body.traction.items():
            f += edges(tag, load, 2)
        q = None
        if matrices.piezoelectric:
            q = self._volume(mesh, cells, body.volume_charge, 1, n)[:, 0]
            for tag, load in body.surface_charge.items():
                q -= edges(tag, load, 1)[:, 0]
        return lifted(body, matrices, f.ravel(), q, held)


Q1_ELEMENT = QuadElement(1)
"""The bilinear 4-node element."""
Q2_ELEMENT = QuadElement(2)
"""The biquadratic 9-node element."""
