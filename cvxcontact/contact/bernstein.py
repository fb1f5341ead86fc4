"""Quadratics in Bernstein-Bezier form on a segment (2D contact lines) and on a triangle (3D contact surfaces).

docs/formulation.md §8 (segments) and §16 (triangles). A quadratic q on an element is written over the
barycentric coordinates L >= 0, sum(L) = 1, as q(L) = L^T Q L with Q symmetric; its Bernstein coefficients b are

    segment   (b0, b1, b2)                     q(t) = b0 (1-t)^2 + 2 b1 t (1-t) + b2 t^2,   L = (1-t, t)
    triangle  (b00, b11, b22, b01, b12, b20)   q(L) = sum_i b_ii L_i^2 + 2 sum_{i<j} b_ij L_i L_j

(the triangle's order follows the triangle6 nodes v0, v1, v2, m01, m12, m20). From the values at the P2 nodes:
b_ii = q(v_i), b_ij = 2 q(m_ij) - (q(v_i) + q(v_j)) / 2. The condition "q <= 0 on the element" is "-Q
copositive", which for 2 x 2 and 3 x 3 matrices is exactly "-Q = P + N, P positive semidefinite, N >= 0
entrywise with zero diagonal" (Diananda): a second-order cone per segment, a 3 x 3 semidefinite cone and three
non-negative scalars per triangle. Its dual cone is the completely positive cone, for these sizes the doubly
non-negative one: the Bernstein duals beta of an element (same order as b) with Z = (beta_ii; beta_ij / 2)
positive semidefinite and entrywise non-negative; beta . b = <Z, Q> is the element's complementarity and
r = B^T beta the nodal force. A point force y at L* has Z = y L* L*^T, i.e. beta = y basis(L*), on the
boundary of the dual cone.

:data:`SEGMENT` and :data:`TRIANGLE` are the two element shapes; :func:`element` picks one by the number of
coefficients (3 or 6). Points on an element are t (k,) on segments, L (k, 3) on triangles.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["Segment", "Triangle", "SEGMENT", "TRIANGLE", "element", "bernstein_map", "bernstein_max",
           "bernstein_argmax", "bernstein_basis", "point_rows", "positive_force"]


def bernstein_map(cells, size: int) -> sp.csr_matrix:
    """(w S, size): the map from nodal values of a continuous P2 space (``size`` nodes) to the Bernstein
    coefficients of each of its elements ``cells`` (S, w): (S, 3) segments (end, midpoint, end) or (S, 6)
    triangles (triangle6 order); rows: element 0's coefficients, then element 1's, ..."""
    cells = np.asarray(cells, dtype=np.int64)
    S, w = cells.shape
    T = element(w).to_bernstein
    rows = np.repeat(np.arange(w * S), w)
    cols = np.repeat(cells, w, axis=0).ravel()
    M = sp.csr_matrix((np.tile(T.ravel(), S), (rows, cols)), shape=(w * S, size))
    M.eliminate_zeros()
    return M


def bernstein_max(b) -> np.ndarray:
    """Exact maximum over each element of the quadratic of Bernstein coefficients ``b`` (k, 3) or (k, 6)."""
    return bernstein_argmax(b)[0]


def bernstein_argmax(b) -> tuple[np.ndarray, np.ndarray]:
    """(q_max, point) per row of ``b`` ((k, 3) segments, (k, 6) triangles): the exact maximum of the quadratic
    over its element and a point where it is reached (t (k,) or L (k, 3))."""
    b = np.asarray(b, dtype=float)
    return element(b.shape[1]).argmax(b)


def bernstein_basis(points) -> np.ndarray:
    """The Bernstein basis at ``points``: t (k,) -> (k, 3), L (k, 3) -> (k, 6)."""
    points = np.asarray(points, dtype=float)
    return (SEGMENT if points.ndim == 1 else TRIANGLE).basis(points)


def point_rows(B, elements, points) -> sp.csr_matrix:
    """(k, n): the rows evaluating q at ``points`` (t (k,) or L (k, 3)) of the ``elements`` (k,), from the
    Bernstein map ``B`` (w S, n) (w = 3 or 6 coefficients per element): row p is basis(point_p)^T B_s, the P2
    Lagrange basis of element s at that point (a degenerate element of one repeated nodal row e gives e itself).
    The condition "q <= 0 at these points" is linear."""
    elements = np.asarray(elements, dtype=int)
    phi = bernstein_basis(points)
    k, w = len(elements), phi.shape[1]
    cols = w * elements[:, None] + np.arange(w)
    Phi = sp.csr_matrix((phi.ravel(), (np.repeat(np.arange(k), w), cols.ravel())), shape=(k, B.shape[0]))
    P = (Phi @ sp.csr_matrix(B)).tocsr()
    P.eliminate_zeros()
    return P


SPREADS = 8
"""Rounds of :func:`positive_force` at most (each one ring of elements further; one suffices where a negative
nodal force's neighbours carry more than it, as beside a contact that ends inside an element)."""


def positive_force(cells, r) -> np.ndarray:
    """(n,) the nodal force ``r`` (n,) on the nodes of X_h made non-negative with its sums kept, locally: Coulomb's
    pressure under the cones (docs/howto/friction.md, "Coulomb under the cones").

    Under the cones the normal force is non-negative as a measure on each element (its Bernstein duals lie in the
    dual cone), but its nodal force r_a = int phi_a d nu, against the P2 Lagrange functions phi_a, is negative at a
    node beside a force between nodes (phi_a < 0 there: a contact that ends inside an element). Each negative
    r_a is taken from the positive forces of its patch N(a), the nodes of the elements ``cells`` (S, w) that hold
    a, in proportion to them: p_b = r_b - r_b^+ sum_{a: r_a < 0, b in N(a)} |r_a| / sum_{c in N(a)} r_c^+, p_a = 0;
    repeated where that leaves a node negative (the next ring), at most :data:`SPREADS` times. So p >= 0,
    sum p = sum r, the sums over every patch of a negative node and its neighbours kept, and p = r, bit for bit, at
    every node no negative node's patch holds (r >= 0 on the elements around it: nodal forces, a pressure that
    covers its elements). A function of r alone: one answer for every representation of the same force (the
    Bernstein duals, the point forces). A negative node with no positive one in reach keeps its force."""
    cells = np.asarray(cells, dtype=np.int64)
    p = np.array(r, dtype=float)
    S, w = cells.shape
    C = sp.csr_matrix((np.ones(cells.size), (np.repeat(np.arange(S), w), cells.ravel())), shape=(S, len(p)))
    A = (C.T @ C).tocsr()
    A.data[:] = 1.0                                      # a and b share an element (a in its own patch)
    for _ in range(SPREADS):
        negative = p < 0
        if not negative.any():
            break
        plus = np.maximum(p, 0.0)
        mass = A @ plus                                  # the positive force of each node's patch
        spread = negative & (mass > 0)
        if not spread.any():
            break
        share = np.divide(-p, mass, out=np.zeros(len(p)), where=spread)
        p = np.where(spread, 0.0, p - plus * (A @ share))
    return p


class Segment:
    """The quadratic on a segment [0, 1] (module docstring)."""

    width, name = 3, "segment"
    off = [1]
    """The coefficients that mix the vertices (the cross terms)."""
    nodes = np.array([0.0, 0.5, 1.0])
    """The P2 nodes: both ends and the midpoint."""
    to_bernstein = np.array([[1.0, 0.0, 0.0], [-0.5, 2.0, -0.5], [0.0, 0.0, 1.0]])
    """(q0, q_mid, q1) -> (b0, b1, b2)."""

    @staticmethod
    def basis(t) -> np.ndarray:
        """(k, 3): ((1-t)^2, 2 t (1-t), t^2) at the points ``t`` of [0, 1]."""
        t = np.asarray(t, dtype=float)
        return np.column_stack([(1 - t) ** 2, 2 * t * (1 - t), t ** 2])

    def argmax(self, b) -> tuple[np.ndarray, np.ndarray]:
        """(q_max, t_max): the larger end value, or the value at the vertex t* = (b0 - b1) / (b0 - 2 b1 + b2) of
        a concave q whose vertex lies inside (0, 1), evaluated in the Bernstein form itself (non-negative
        weights summing to one: no cancellation)."""
        b = np.asarray(b, dtype=float)
        b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
        q = np.maximum(b0, b2)
        t = np.where(b2 > b0, 1.0, 0.0)
        a = b0 - 2 * b1 + b2
        with np.errstate(divide="ignore", invalid="ignore"):
            ts = np.where(a < 0, (b0 - b1) / a, -1.0)
        inner = (ts > 0) & (ts < 1)
        tv = np.where(inner, ts, 0.0)
        qv = (self.basis(tv) * b).sum(axis=1)
        better = inner & (qv > q)
        return np.where(better, qv, q), np.where(better, tv, t)

    @staticmethod
    def index(i: int, j: int) -> int:
        """The position of Q_ij in the coefficient vector (b0, b1, b2) (q = L^T Q L, L = (1 - t, t))."""
        return 2 * i if i == j else 1

    @staticmethod
    def gram(b) -> np.ndarray:
        """(S, 2, 2): Q = [[b0, b1], [b1, b2]] with q = L^T Q L, L = (1 - t, t), from the coefficients ``b``
        (S, 3)."""
        b = np.asarray(b, dtype=float)
        return np.stack([np.stack([b[:, 0], b[:, 1]], -1), np.stack([b[:, 1], b[:, 2]], -1)], -2)

    @staticmethod
    def dual_gram(beta) -> np.ndarray:
        """(S, 2, 2): Z = [[beta0, beta1 / 2], [beta1 / 2, beta2]] of the Bernstein duals ``beta`` (S, 3)
        (beta . b = <Z, Q>)."""
        Z = Segment.gram(beta)
        Z[:, [0, 1], [1, 0]] /= 2
        return Z

    @staticmethod
    def dual_cone_violation(beta) -> np.ndarray:
        """(S,): how far each row of ``beta`` lies outside the dual cone beta0, beta2 >= 0, beta1 >= 0,
        beta1 <= 2 sqrt(beta0 beta2) (the largest of the four violations)."""
        b0, b1, b2 = beta[:, 0], beta[:, 1], beta[:, 2]
        return np.maximum.reduce([np.maximum(-b0, 0), np.maximum(-b2, 0), np.maximum(-b1, 0),
                                  np.maximum(b1 - 2 * np.sqrt(np.maximum(b0, 0) * np.maximum(b2, 0)), 0)])

    @staticmethod
    def dual_cone_point(beta) -> np.ndarray:
        """``beta`` moved into the dual cone (each entry clipped; beta1 lowered to 2 sqrt(beta0 beta2))."""
        beta = np.maximum(np.asarray(beta, dtype=float), 0.0)
        beta[:, 1] = np.minimum(beta[:, 1], 2 * np.sqrt(beta[:, 0] * beta[:, 2]))
        return beta

    @staticmethod
    def tangency(beta) -> np.ndarray:
        """t* (S,): the Bernstein duals ``beta`` (S, 3) read as one point force at t* = sqrt(beta2) /
        (sqrt(beta0) + sqrt(beta2)) (exact when beta is on the cone's boundary, beta1^2 = 4 beta0 beta2)."""
        r0, r2 = np.sqrt(np.maximum(beta[:, 0], 0)), np.sqrt(np.maximum(beta[:, 2], 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            ts = r2 / (r0 + r2)
        return np.nan_to_num(ts)

    @staticmethod
    def near_nodes(t, tol: float) -> np.ndarray:
        """(k,) bool: the points ``t`` within ``tol`` of a P2 node."""
        return (np.abs(np.asarray(t)[:, None] - Segment.nodes[None, :]) <= tol).any(axis=1)

    @staticmethod
    def vertex_shares(beta) -> np.ndarray:
        """(S, 2): the Bernstein duals as forces at the two ends: beta0 + beta1 / 2 and beta2 + beta1 / 2
        (the row sums of Z)."""
        return np.column_stack([beta[:, 0] + beta[:, 1] / 2, beta[:, 2] + beta[:, 1] / 2])

    vertices = np.array([0.0, 1.0])
    """The element's vertices as points."""


class Triangle:
    """The quadratic on a triangle over its barycentric coordinates (module docstring)."""

    width, name = 6, "triangle"
    off = [3, 4, 5]
    """The coefficients that mix the vertices (the cross terms)."""
    nodes = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]])
    """The P2 nodes (triangle6 order: v0, v1, v2, m01, m12, m20) as barycentric coordinates."""
    to_bernstein = np.array([[1.0, 0, 0, 0, 0, 0], [0, 1.0, 0, 0, 0, 0], [0, 0, 1.0, 0, 0, 0],
                             [-0.5, -0.5, 0, 2.0, 0, 0], [0, -0.5, -0.5, 0, 2.0, 0], [-0.5, 0, -0.5, 0, 0, 2.0]])
    """Values at the triangle6 nodes -> (b00, b11, b22, b01, b12, b20)."""
    edges = ((0, 1, 3), (1, 2, 4), (2, 0, 5))
    """(i, j, coefficient of ij) of the three edges."""
    vertices = np.eye(3)

    @staticmethod
    def basis(L) -> np.ndarray:
        """(k, 6): (L0^2, L1^2, L2^2, 2 L0 L1, 2 L1 L2, 2 L2 L0) at barycentric ``L`` (k, 3)."""
        L = np.asarray(L, dtype=float).reshape(-1, 3)
        return np.column_stack([L ** 2, 2 * L[:, 0] * L[:, 1], 2 * L[:, 1] * L[:, 2], 2 * L[:, 2] * L[:, 0]])

    @staticmethod
    def index(i: int, j: int) -> int:
        """The position of Q_ij in the coefficient vector (b00, b11, b22, b01, b12, b20)."""
        if i == j:
            return i
        return next(c for a, b, c in Triangle.edges if {a, b} == {i, j})

    @staticmethod
    def gram(b) -> np.ndarray:
        """(S, 3, 3): Q with q = L^T Q L from the coefficients ``b`` (S, 6) (Q_ii = b_ii, Q_ij = b_ij). Of
        Bernstein duals beta, the Gram matrix Z with beta . b = <Z, Q> is gram(beta) with its off-diagonal
        halved (:meth:`dual_gram`)."""
        b = np.asarray(b, dtype=float)
        Q = np.empty((len(b), 3, 3))
        Q[:, [0, 1, 2], [0, 1, 2]] = b[:, :3]
        for i, j, c in Triangle.edges:
            Q[:, i, j] = Q[:, j, i] = b[:, c]
        return Q

    @staticmethod
    def dual_gram(beta) -> np.ndarray:
        """(S, 3, 3): Z = (beta_ii; beta_ij / 2) of the Bernstein duals ``beta`` (S, 6)."""
        Z = Triangle.gram(beta)
        off = ~np.eye(3, dtype=bool)
        Z[:, off] /= 2
        return Z

    @staticmethod
    def from_dual_gram(Z) -> np.ndarray:
        """beta (S, 6) of the Gram matrices ``Z`` (S, 3, 3) (the inverse of :meth:`dual_gram`)."""
        return np.column_stack([Z[:, 0, 0], Z[:, 1, 1], Z[:, 2, 2], 2 * Z[:, 0, 1], 2 * Z[:, 1, 2], 2 * Z[:, 2, 0]])

    def argmax(self, b) -> tuple[np.ndarray, np.ndarray]:
        """(q_max, L_max): the exact maximum over the triangle, the largest of its values at the three edges'
        maxima (:meth:`Segment.argmax`, vertices included) and at the stationary point of q on the plane
        sum(L) = 1 where it lies inside (L proportional to adj(Q) 1: no division by det Q). A stationary point
        that is not a maximum is a point of the triangle, so never above the maximum: taking the largest
        candidate is exact. Every value is evaluated in the Bernstein form (non-negative weights)."""
        b = np.asarray(b, dtype=float)
        S = len(b)
        best = np.full(S, -np.inf)
        point = np.zeros((S, 3))
        for i, j, c in self.edges:
            q, t = SEGMENT.argmax(b[:, [i, c, j]])
            better = q > best
            L = np.zeros((S, 3))
            L[:, i], L[:, j] = 1 - t, t
            best, point = np.where(better, q, best), np.where(better[:, None], L, point)
        Q = self.gram(b)
        adj = np.stack([np.cross(Q[:, 1], Q[:, 2]), np.cross(Q[:, 2], Q[:, 0]), np.cross(Q[:, 0], Q[:, 1])], axis=1)
        x = adj.sum(axis=2)                                     # adj(Q) 1 (Q symmetric: adj symmetric)
        s = x.sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            L = x / s[:, None]
        inner = (s != 0) & np.all(np.isfinite(L), axis=1) & np.all(L > 0, axis=1)
        L = np.where(inner[:, None], L, 1.0 / 3)
        qv = (self.basis(L) * b).sum(axis=1)
        better = inner & (qv > best)
        return np.where(better, qv, best), np.where(better[:, None], L, point)

    def dual_cone_violation(self, beta) -> np.ndarray:
        """(S,): how far each row of ``beta`` lies outside the dual cone: the largest of -lambda_min(Z) and the
        negative parts of Z's entries (Z = :meth:`dual_gram`)."""
        Z = self.dual_gram(beta)
        neg = np.maximum(-Z, 0).reshape(len(Z), -1).max(axis=1, initial=0.0)
        return np.maximum(np.maximum(-np.linalg.eigvalsh(Z)[:, 0], 0.0), neg)

    def dual_cone_point(self, beta) -> np.ndarray:
        """``beta`` moved into the dual cone: Z's negative eigenvalues dropped, then every negative
        off-diagonal entry z_ij raised to 0 by adding |z_ij| (e_i + e_j)(e_i + e_j)^T (positive semidefinite:
        Z stays so; the diagonal grows)."""
        Z = self.dual_gram(beta)
        w, V = np.linalg.eigh(Z)
        Z = np.einsum("sij,sj,skj->sik", V, np.maximum(w, 0.0), V)
        for i, j, _ in self.edges:
            lift = np.maximum(-Z[:, i, j], 0.0)
            Z[:, i, j] += lift
            Z[:, j, i] += lift
            Z[:, i, i] += lift
            Z[:, j, j] += lift
        return self.from_dual_gram(Z)

    def tangency(self, beta) -> np.ndarray:
        """L* (S, 3): the Bernstein duals ``beta`` (S, 6) read as one point force at Z's leading eigenvector
        scaled to sum 1 (exact when Z = y L* L*^T)."""
        _, V = np.linalg.eigh(self.dual_gram(beta))
        v = np.abs(V[:, :, -1])
        s = v.sum(axis=1)
        return np.where(s[:, None] > 0, v / np.where(s > 0, s, 1.0)[:, None], 1.0 / 3)

    @staticmethod
    def near_nodes(L, tol: float) -> np.ndarray:
        """(k,) bool: the points ``L`` (k, 3) within ``tol`` (max norm) of a P2 node."""
        return (np.abs(np.asarray(L)[:, None, :] - Triangle.nodes[None]).max(axis=2) <= tol).any(axis=1)

    def vertex_shares(self, beta) -> np.ndarray:
        """(S, 3): the Bernstein duals as forces at the vertices: the row sums of Z (summing to sum(Z))."""
        return self.dual_gram(beta).sum(axis=2)


SEGMENT = Segment()
TRIANGLE = Triangle()


def element(width: int):
    """The element shape with ``width`` Bernstein coefficients: 3 (segment) or 6 (triangle)."""
    try:
        return {3: SEGMENT, 6: TRIANGLE}[int(width)]
    except KeyError:
        raise ValueError(f"Bernstein coefficients per element must be 3 (segment) or 6 (triangle), got {width}") from None
