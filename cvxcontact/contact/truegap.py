"""The gap of a curved rigid obstacle on the elements of the P2 "everywhere" condition (docs/formulation.md §8,
"Rigid obstacles", and §16).

The cones hold q_h = [u_h nu] - g_h <= 0, g_h the P2 interpolant of the gap at the nodes of X_h. Against a
curved obstacle the gap g(x) (the pair's gap plus the obstacle's distance) is no quadratic, and g_h dips below
it between the nodes (a sphere touching one node: g_h < 0 beside it, a phantom penetration). The condition the
package answers is the one against the obstacle itself,

    s(x) = [u_h nu](x) - g(x) = q_h(x) - delta(x) <= 0   at every point x of every element,

with delta = g - g_h the departure of the gap from its interpolant: semi-infinite, and convex in u (one
half-space per x). :class:`GapDeparture` is delta on the elements of the cones (zero on the elements where the
gap is quadratic: between two bodies, against a plane) and the exact maximum of s over each element
(:meth:`GapDeparture.argmax`), which the accumulated cuts, the checks and the certificate use in place of the
quadratic's maximum (:func:`~cvxcontact.contact.bernstein.bernstein_argmax`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .bernstein import bernstein_argmax, element

__all__ = ["GapDeparture", "CURVED_TOL", "simplex_grid"]

CURVED_TOL = 1e-13
"""An element is curved where |delta| at its sample points exceeds this fraction of its gap's size (the
largest |g| at its nodes and its diameter): below it, delta is the rounding of the gap's evaluation."""

GRID = {3: 64, 6: 12}
"""Intervals of the first sampling of an element (segments: 65 points; triangles: 91)."""

ZOOM_ROUNDS = 400
"""Largest number of steps of the local search from each local maximum of the grid (a pattern search: it moves
to the best of its neighbours at distance h where one is better, else shrinks h by :data:`ZOOM`)."""
ZOOM = 0.5
ZOOM_STEP = 1e-14
"""The pattern search stops where its step h (in barycentric coordinates) is below this: rounding of the point."""


def simplex_grid(m: int) -> np.ndarray:
    """(k, 3): the barycentric points (i, j, m - i - j) / m of a triangle."""
    i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
    keep = i + j <= m
    i, j = i[keep], j[keep]
    return np.column_stack([i, j, m - i - j]) / m


class GapDeparture:
    """delta(x) = g(x) - g_h(x) on the elements of the everywhere condition (module docstring).

    ``gap(elements, points)``: the true gap (m) at ``points`` (t (k,) on segments, L (k, 3) on triangles) of the
    cone's ``elements`` (k,), for the curved ones; ``nodal`` (S, w): the gap at each element's P2 nodes (m; its
    P2 interpolant is g_h); ``curved`` (S,) bool: the elements whose gap is not quadratic (the others have
    delta = 0 and the quadratic's exact maximum). ``derivatives(elements, points)``: (g (k,), grad (k, c),
    hess (k, c, c)), the true gap and its derivatives (m) in the full barycentric coordinates L of the element's
    c corners (L = (1 - t, t) on segments; their components along sum(L) = const are the meaningful ones), for
    :meth:`curvature`. :meth:`scaled` gives the same in another unit of length."""

    def __init__(self, gap: Callable, nodal, curved, scale: float = 1.0, derivatives: Callable | None = None):
        self._gap = gap
        self._derivatives = derivatives
        self.nodal = np.asarray(nodal, dtype=float)
        self.curved = np.asarray(curved, dtype=bool)
        self.width = self.nodal.shape[1]
        self.shape = element(self.width)
        self.scale = float(scale)

    @classmethod
    def build(cls, gap: Callable, nodal, candidates, derivatives: Callable | None = None) -> "GapDeparture | None":
        """The departure on the ``candidates`` (S,) bool elements (rigid obstacles' faces), each marked curved
        where delta at its first sample points is above rounding (:data:`CURVED_TOL`); None if none is."""
        nodal = np.asarray(nodal, dtype=float)
        shape = element(nodal.shape[1])
        on = np.flatnonzero(np.asarray(candidates, dtype=bool))
        curved = np.zeros(len(nodal), dtype=bool)
        if len(on):
            pts = cls._grid(shape)
            k = len(pts)
            el = np.repeat(on, k)
            P = np.tile(pts, (len(on),) + (1,) * (pts.ndim - 1))
            g = np.asarray(gap(el, P), dtype=float).reshape(len(on), k)
            gh = cls._interpolant(shape, nodal[on], pts)
            size = np.maximum(np.abs(nodal[on]).max(axis=1), np.abs(g).max(axis=1))
            curved[on] = (np.abs(g - gh).max(axis=1) > CURVED_TOL * np.maximum(size, np.finfo(float).tiny)) \
                | ~np.isfinite(g).all(axis=1)
        if not curved.any():
            return None
        return cls(gap, nodal, curved, derivatives=derivatives)

    def scaled(self, length: float) -> "GapDeparture":
        """The same departure in units of ``length`` (m): delta / length."""
        return GapDeparture(self._gap, self.nodal, self.curved, self.scale / float(length), self._derivatives)

    @staticmethod
    def _grid(shape) -> np.ndarray:
        m = GRID[shape.width]
        return np.linspace(0.0, 1.0, m + 1) if shape.width == 3 else simplex_grid(m)

    @staticmethod
    def _interpolant(shape, nodal, points) -> np.ndarray:
        """(S, k): the P2 interpolant of the ``nodal`` values (S, w) at ``points`` (k, ...) of every element."""
        phi = shape.basis(points)                               # (k, w) Bernstein basis
        b = nodal @ shape.to_bernstein.T                        # (S, w) Bernstein coefficients
        return b @ phi.T

    def at(self, elements, points) -> np.ndarray:
        """delta (scaled) at ``points`` of ``elements`` (0 on the straight ones)."""
        elements = np.asarray(elements, dtype=int)
        points = np.asarray(points, dtype=float)
        out = np.zeros(len(elements))
        on = np.flatnonzero(self.curved[elements]) if len(elements) else np.zeros(0, dtype=int)
        if len(on):
            e, p = elements[on], points[on]
            phi = self.shape.basis(p)
            gh = ((self.nodal[e] @ self.shape.to_bernstein.T) * phi).sum(axis=1)
            out[on] = (np.asarray(self._gap(e, p), dtype=float) - gh) * self.scale
        return out

    def curvature(self, element: int, L) -> tuple[float, np.ndarray, np.ndarray]:
        """(delta, grad, hess) (scaled) at the full barycentric point ``L`` (c,) of ``element``: delta = g - g_h
        and its gradient (c,) and Hessian (c, c) in L, g's from ``derivatives`` (closed form, docs/formulation.md
        §18) and g_h = L^T Q L's (2 Q L, 2 Q); zero on a straight element. Their components along the element
        (directions with sum 0) are its slope and curvature (the tangency Newton's)."""
        L = np.asarray(L, dtype=float)
        c = len(L)
        if not self.curved[element]:
            return 0.0, np.zeros(c), np.zeros((c, c))
        if self._derivatives is None:
            raise ValueError("GapDeparture.curvature: built without the gap's derivatives")
        Q = self.shape.gram((self.nodal[element] @ self.shape.to_bernstein.T)[None, :])[0]
        g, grad, hess = self._derivatives(np.array([element]), L[None, 1] if self.width == 3 else L[None, :])
        return ((float(g[0]) - L @ Q @ L) * self.scale, (grad[0] - 2 * Q @ L) * self.scale,
                (hess[0] - 2 * Q) * self.scale)

    def argmax(self, b) -> tuple[np.ndarray, np.ndarray]:
        """(s_max, point) per element: the maximum over the element of s = q_h - delta, q_h the quadratic of
        Bernstein coefficients ``b`` (S, w) (scaled), and a point where it is reached. Straight elements: the
        quadratic's exact maximum; curved ones: a grid (:data:`GRID`), then a shrinking local grid
        (:data:`ZOOM_ROUNDS`) around every local maximum of the grid (each sample at least its neighbours'),
        the best of them (s is smooth: its value then to rounding at an interior maximum, and exact at a
        vertex). Every local maximum, not the best sample's alone: where the body conforms to the obstacle, s
        has several maxima of nearly equal height in one element, and the best sample need not be next to the
        highest (measured: a sphere pressed into P2 triangles, the best sample at an edge's maximum -2.3e-6
        below zero, the interior one 9.7e-6 above it, of the slack's scale; the cuts stopped with the true
        slack violated by 1e-5 and an answer that depended on the BLAS kernels)."""
        b = np.asarray(b, dtype=float)
        best, point = bernstein_argmax(b)
        on = np.flatnonzero(self.curved)
        if not len(on):
            return best, point
        seg = self.width == 3
        pts = self._grid(self.shape)

        def value(el, P):                      # s at points P (n, k[, 3]) of the elements el (n,)
            flat = P.reshape(len(el) * P.shape[1], -1) if not seg else P.ravel()
            e = np.repeat(el, P.shape[1])
            q = (self.shape.basis(flat) * b[e]).sum(axis=1)
            return (q - self.at(e, flat)).reshape(len(el), P.shape[1])

        s = value(on, np.broadcast_to(pts[None], (len(on),) + pts.shape))
        nb = self._neighbours(self.shape)
        peak = (s[:, :, None] >= np.where(nb[None] >= 0, s[:, np.maximum(nb, 0)], -np.inf)).all(axis=2)
        which, j = np.nonzero(peak)                        # the starts: (element, sample) of every local maximum
        x = pts[j].copy()
        v = s[which, j]
        el = on[which]
        if seg:
            steps = np.array([-1.0, -0.5, 0.5, 1.0])
        else:
            d = np.array([[1, -1, 0], [-1, 1, 0], [0, 1, -1], [0, -1, 1], [1, 0, -1], [-1, 0, 1]], dtype=float)
            steps = np.concatenate([d, 0.5 * d])
        h = np.full(len(el), 1.0 / GRID[self.width])
        rows = np.arange(len(el))
        live = rows
        for _ in range(ZOOM_ROUNDS):
            if seg:
                cand = np.clip(x[live, None] + h[live, None] * steps[None, :], 0.0, 1.0)
            else:
                cand = np.clip(x[live, None, :] + h[live, None, None] * steps[None], 0.0, None)
                cand = cand / cand.sum(axis=2, keepdims=True)
            sc = value(el[live], cand)
            k = np.argmax(sc, axis=1)
            up = sc[np.arange(len(live)), k] > v[live]
            x[live[up]] = cand[np.arange(len(live)), k][up]
            v[live[up]] = sc[np.arange(len(live)), k][up]
            h[live[~up]] *= ZOOM                       # a pattern search: the step shrinks where none is better
            live = live[h[live] > ZOOM_STEP]
            if not len(live):
                break
        # per element the best start (the first of equal ones: independent of the order of the arithmetic)
        order = np.lexsort((-v, which))
        first = order[np.r_[True, which[order][1:] != which[order][:-1]]]
        x, v = x[first], v[first]
        # the quadratic's own maximiser, checked against s itself (delta moves the maximum off it)
        q0 = value(on, point[on][:, None] if seg else point[on][:, None, :])[:, 0]
        keep = v >= q0
        best, point = best.copy(), point.copy()
        best[on] = np.where(keep, v, q0)
        point[on] = np.where(keep if seg else keep[:, None], x, point[on])
        return best, point

    @staticmethod
    def _neighbours(shape) -> np.ndarray:
        """(k, 6): the indices of each sample's neighbours on the grid of :meth:`_grid` (-1: none): t +- 1/m on
        segments, L + (e_i - e_j) / m on triangles."""
        m = GRID[shape.width]
        if shape.width == 3:
            i = np.arange(m + 1)
            nb = np.column_stack([i - 1, i + 1])
            return np.where((nb >= 0) & (nb <= m), nb, -1)
        P = np.rint(simplex_grid(m) * m).astype(int)
        index = {tuple(p): n for n, p in enumerate(P)}
        d = [(1, -1, 0), (-1, 1, 0), (0, 1, -1), (0, -1, 1), (1, 0, -1), (-1, 0, 1)]
        return np.array([[index.get(tuple(p + np.array(e)), -1) for e in d] for p in P])

    def pairing(self, S: int, elements, points, y) -> np.ndarray:
        """(S,): sum over the point forces ``y`` of each element of y_p delta(x_p) (scaled): what the pairing of
        the point forces with the true slack adds to beta . b (docs/formulation.md §8: sum_p y_p s(x_p) =
        beta . b - this)."""
        out = np.zeros(S)
        np.add.at(out, np.asarray(elements, dtype=int), np.asarray(y, dtype=float) * self.at(elements, points))
        return out
