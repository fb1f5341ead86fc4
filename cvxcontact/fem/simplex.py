"""Quadrature on simplices and the consistent loads of a density integrated by it (any dimension, any
Lagrange element given by its shape functions in barycentric coordinates).

``simplex_rule(dim, degree)``: a rule exact for polynomials of total degree ``degree`` on a triangle
(dim 2) or a tetrahedron (dim 3), built as the conical (collapsed-coordinate) product of Gauss-Jacobi rules
(Stroud, *Approximate Calculation of Multiple Integrals*, 1971, §2.7): with n = ceil((degree + 1) / 2)
points per direction it is exact to degree 2 n - 1, all weights positive, all points inside. Returned as
barycentric coordinates (q, dim + 1) and weights (q,) summing to 1 (multiply by the element's measure).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import roots_jacobi

__all__ = ["simplex_rule", "element_load"]


def _gauss_jacobi01(n, alpha):
    """n-point rule on [0, 1] for the weight (1 - s)^alpha (exact to degree 2 n - 1)."""
    t, w = roots_jacobi(n, alpha, 0.0)
    return 0.5 * (1.0 + t), w / 2.0 ** (alpha + 1)


@lru_cache(maxsize=None)
def simplex_rule(dim: int, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """(L (q, dim + 1), w (q,)): barycentric points and weights (sum 1) exact to total degree ``degree``."""
    n = max(1, -(-(degree + 1) // 2))
    # x1 = s1, x2 = s2 (1 - s1), x3 = s3 (1 - s1)(1 - s2): Jacobian (1 - s1)^(dim - 1) (1 - s2)^(dim - 2)
    rules = [_gauss_jacobi01(n, dim - 1 - k) for k in range(dim)]
    grids = np.meshgrid(*[r[0] for r in rules], indexing="ij")
    weights = np.prod(np.meshgrid(*[r[1] for r in rules], indexing="ij"), axis=0).ravel()
    s = [g.ravel() for g in grids]
    x, scale = [], np.ones_like(s[0])
    for k in range(dim):
        x.append(s[k] * scale)
        scale = scale * (1.0 - s[k])
    x = np.column_stack(x)
    L = np.column_stack([1.0 - x.sum(axis=1), x])
    L.setflags(write=False)
    w = weights / weights.sum()
    w.setflags(write=False)
    return L, w


def element_load(points, vertices, nodes, measure, load, ncomp, rule, shape, n) -> np.ndarray:
    """(n, ncomp) consistent nodal load sum_e int_e f N_i of a density ``load`` (a Load, called with the
    coordinates) over simplices with vertex coordinates ``points[vertices]`` (m, dim + 1) and element node
    indices ``nodes`` (m, k), measures ``measure`` (m,), by ``rule`` (L, w) and ``shape`` (L (dim + 1,) ->
    (k,) shape functions)."""
    out = np.zeros((n, ncomp))
    p = points[vertices]                                              # (m, dim + 1, d)
    for L, w in zip(*rule):
        x = np.einsum("k,mkd->md", L, p)
        val = np.asarray(load(*x.T), dtype=float).reshape(len(p), ncomp) * (w * measure)[:, None]
        N = shape(L)
        out += _accumulate(nodes.T.ravel(), (N[:, None, None] * val[None]).reshape(-1, ncomp), n)
    return out


def _accumulate(index, values, n):
    return np.column_stack([np.bincount(index, weights=values[:, j], minlength=n) for j in range(values.shape[1])])
