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

import functools
from typing import Callable

import numpy as np

from .bernstein import bernstein_argmax, element

__all__ = ["GapDeparture", "CURVED_TOL", "simplex_grid"]

CURVED_TOL = 1e-13
"""An element is curved where |delta| at its sample points exceeds this fraction of its gap's size (the
largest |g| at its nodes and its diameter): below it, delta is the rounding of the gap's evaluation."""

GRID = {3: 64, 6: 12}
"""Intervals of the first sampling of an element (segments: 65 points; triangles: 91)."""

NEWTON_STEPS = 100
"""Safety bound on the Newton steps of one start (:meth:`GapDeparture.argmax`; measured on the Hertz 3D quarter,
n = 8, 197 calls: at most 23, median 7 per call); a start still improving after it is handed to the pattern search.
Newton stops on its own where its step's predicted gain is below the rounding of s (:meth:`GapDeparture._newton`)."""
LINE_SEARCH = 0.5 ** np.arange(12)
"""The fractions of a Newton step tried at once (the best that improves s is taken)."""
ZOOM_ROUNDS = 400
"""Largest number of steps of the fallback pattern search (without the gap's derivatives, or where Newton stalls
at a point that is no maximum): it moves to the best of its neighbours at distance h where one is better, else
shrinks h by :data:`ZOOM`."""
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
        d, grad, hess = self._departure_derivatives(np.array([element]), L[None, :])
        return float(d[0]), grad[0], hess[0]

    def _departure_derivatives(self, elements, L) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(delta (k,), grad (k, c), hess (k, c, c)) (scaled) at the full barycentric points ``L`` (k, c) of the
        curved ``elements`` (k,) (:meth:`curvature`)."""
        if self._derivatives is None:
            raise ValueError("GapDeparture.curvature: built without the gap's derivatives")
        Q = self.shape.gram(self.nodal[elements] @ self.shape.to_bernstein.T)          # g_h = L^T Q L
        g, grad, hess = self._derivatives(elements, L[:, 1] if self.width == 3 else L)
        QL = (Q * L[:, None, :]).sum(axis=2)
        return ((g - (QL * L).sum(axis=1)) * self.scale, (grad - 2 * QL) * self.scale, (hess - 2 * Q) * self.scale)

    def argmax(self, b) -> tuple[np.ndarray, np.ndarray]:
        """(s_max, point) per element: the maximum over the element of s = q_h - delta, q_h the quadratic of
        Bernstein coefficients ``b`` (S, w) (scaled), and a point where it is reached. Straight elements: the
        quadratic's exact maximum; curved ones: a grid (:data:`GRID`), then from every local maximum of the grid
        (each sample at least its neighbours') a safeguarded Newton ascent to the maximum it climbs
        (:meth:`_newton`), the best of them (s is smooth: its value then to rounding at an interior maximum, and
        exact at a vertex). Every local maximum, not the best sample's alone: where the body conforms to the
        obstacle, s has several maxima of nearly equal height in one element, and the best sample need not be
        next to the highest (measured: a sphere pressed into P2 triangles, the best sample at an edge's maximum
        -2.3e-6 below zero, the interior one 9.7e-6 above it, of the slack's scale; the cuts stopped with the true
        slack violated by 1e-5 and an answer that depended on the BLAS kernels). Each start climbs until no step
        improves s by more than its rounding: a search stopped by a count of steps would underestimate the
        maximum (measured, a pattern search capped at 400 steps on the Hertz 3D quarter, n = 8: starts still
        climbing a ridge, the maximum 4.5e-8 of the slack's scale returned as 1.5e-8). Without the gap's
        derivatives the starts climb by a pattern search (:data:`ZOOM_ROUNDS`)."""
        return self._argmax(b)[:2]

    def _argmax(self, b):
        """:meth:`argmax`, and per start (element, final point, s there, how it stopped: 0 Newton converged,
        1 the pattern search's step below rounding, 2 the pattern search's :data:`ZOOM_ROUNDS`)."""
        b = np.asarray(b, dtype=float)
        best, point = bernstein_argmax(b)
        on = np.flatnonzero(self.curved)
        if not len(on):
            return best, point, None
        seg = self.width == 3
        pts = self._grid(self.shape)
        s = self._slack(b, np.repeat(on, len(pts)), np.tile(self._full(pts), (len(on), 1))).reshape(len(on), -1)
        nb = self._neighbours(self.width)
        peak = (s[:, :, None] >= np.where(nb[None] >= 0, s[:, np.maximum(nb, 0)], -np.inf)).all(axis=2)
        which, j = np.nonzero(peak)                        # the starts: (element, sample) of every local maximum
        el = on[which]
        L, v = self._full(pts[j]), s[which, j]
        if self._derivatives is not None:
            L, v, stop = self._newton(b, el, L, v)
        else:
            stop = np.ones(len(el), dtype=int)
        climb = np.flatnonzero(stop)                       # no derivatives, or Newton stalled at no maximum
        if len(climb):
            L[climb], v[climb], capped = self._pattern(b, el[climb], L[climb], v[climb])
            stop[climb] = 1 + capped
        # per element the best start (the first of equal ones: independent of the order of the arithmetic)
        order = np.lexsort((-v, which))
        first = order[np.r_[True, which[order][1:] != which[order][:-1]]]
        x, vb = (L[first, 1] if seg else L[first]), v[first]
        # the quadratic's own maximiser, checked against s itself (delta moves the maximum off it)
        q0 = self._slack(b, on, self._full(point[on]))
        keep = vb >= q0
        best, point = best.copy(), point.copy()
        best[on] = np.where(keep, vb, q0)
        point[on] = np.where(keep if seg else keep[:, None], x, point[on])
        return best, point, (el, L, v, stop)

    def _full(self, points) -> np.ndarray:
        """(k, c): the full barycentric coordinates of ``points`` (t (k,) on segments, L (k, 3) on triangles)."""
        points = np.asarray(points, dtype=float)
        return np.column_stack([1 - points, points]) if self.width == 3 else points

    def _slack(self, b, el, L) -> np.ndarray:
        """s = q_h - delta (k,) at the full barycentric points ``L`` (k, c) of the curved elements ``el`` (k,)."""
        point = L[:, 1] if self.width == 3 else L
        return (self.shape.basis(point) * b[el]).sum(axis=1) - self.at(el, point)

    def _newton(self, b, el, L, v):
        """(L, s, stop) of a safeguarded Newton ascent of s from the points ``L`` (k, c) of the curved elements
        ``el`` (k,) where s is ``v`` (k,): stop 0 where it converged, 1 where it stalled at a point that is no
        maximum (or ran out of :data:`NEWTON_STEPS`).

        Each step solves the Newton system of s (gradient 2 Q_b L - grad delta, Hessian 2 Q_b - hess delta, Q_b
        the Gram matrix of ``b``, :meth:`_departure_derivatives`) on the face of the simplex the point is on:
        the free coordinates are L_i > 0 and the zero ones whose derivative exceeds the largest coordinate's
        (moving weight there increases s); the step moves weight from the largest coordinate to the other free
        ones. Where the reduced Hessian is not negative definite it is shifted to be (an ascent direction); the
        step is cut to at most 1/2 and to the simplex, and the best of the fractions :data:`LINE_SEARCH` of it
        that improves s is taken. A start has converged where the predicted gain g . y / 2 of a step of the
        unshifted (concave) system is below the rounding of s (then s there is its maximum to rounding: 16 eps of
        its terms' size, or, where no fraction improves s, the scatter of s over the shortest fractions, the
        rounding of the gap's own evaluation, e.g. eps R of a user's distance that subtracts a radius R), or where
        the step is below the rounding of the point; it has stalled where no fraction improves s before that."""
        eps = np.finfo(float).eps
        L, v = L.copy(), v.copy()
        k, c = L.shape
        stop = np.ones(k, dtype=int)
        rounding = 16 * eps * (np.abs(b[el]).max(axis=1) + abs(self.scale) * np.abs(self.nodal[el]).max(axis=1))
        others = np.array([[1, 0], [0, 0]]) if c == 2 else np.array([[1, 2], [0, 2], [0, 1]])
        live = np.arange(k)
        for _ in range(NEWTON_STEPS):
            n = len(live)
            r = np.arange(n)
            X = L[live]
            Q = self.shape.gram(b[el[live]])
            _, gd, hd = self._departure_derivatives(el[live], X)
            G = 2 * (Q * X[:, None, :]).sum(axis=2) - gd                 # ds/dL (n, c)
            H = 2 * Q - hd
            p = np.argmax(X, axis=1)                                     # the pivot: the largest coordinate
            o = others[p]                                                # (n, 2) the other coordinates
            real = np.ones((n, 2), dtype=bool) if c == 3 else np.column_stack([np.ones(n, bool), np.zeros(n, bool)])
            go = np.take_along_axis(G, o, axis=1) - G[r, p][:, None]     # derivative along e_o - e_p
            Xo = np.take_along_axis(X, o, axis=1)
            free = real & ((Xo > 0) | (go > 0))
            Hpp = H[r, p, p]
            Hop = H[r[:, None], o, p[:, None]]
            Hoo = H[r[:, None, None], o[:, :, None], o[:, None, :]]
            Hr = Hoo - Hop[:, :, None] - Hop[:, None, :] + Hpp[:, None, None]   # the Hessian along e_o - e_p
            y, gain, concave = self._newton_step(go, Hr, free)
            back = free & (Xo <= 0) & (y < 0)                            # a released coordinate the step lowers
            if back.any():
                y, gain, concave = self._newton_step(go, Hr, free & ~back)
            d = np.zeros_like(X)
            np.put_along_axis(d, o[:, :c - 1], y[:, :c - 1], axis=1)
            d[r, p] -= y.sum(axis=1)
            d *= np.minimum(1.0, 0.5 / np.maximum(np.abs(d).max(axis=1), np.finfo(float).tiny))[:, None]
            cand = np.clip(X[:, None, :] + LINE_SEARCH[None, :, None] * d[:, None, :], 0.0, None)
            cand /= cand.sum(axis=2, keepdims=True)
            sc = self._slack(b, np.repeat(el[live], len(LINE_SEARCH)), cand.reshape(-1, c)).reshape(n, -1)
            a = np.argmax(sc, axis=1)                                    # the first of equal best fractions
            moved = (sc[r, a] > v[live]) & (np.abs(cand[r, a] - X).max(axis=1) > 0)
            L[live[moved]] = cand[r, a][moved]
            v[live[moved]] = sc[r, a][moved]
            # the scatter of s over the shortest fractions (whose predicted change is below gain / 32): the
            # rounding of the gap's own evaluation (e.g. a user's distance |x - c| - R, to rounding of R, not of g)
            scatter = np.abs(sc[:, LINE_SEARCH <= 1 / 64] - v[live][:, None]).max(axis=1)
            done = concave & (gain <= np.where(moved, rounding[live], np.maximum(rounding[live], scatter))) \
                | (np.abs(d).max(axis=1) <= 4 * eps)
            stop[live[done]] = 0
            live = live[moved & ~done]
            if not len(live):
                break
        return L, v, stop

    @staticmethod
    def _newton_step(g, H, free):
        """(y (n, 2), predicted gain g . y / 2 (n,), concave (n,)): the ascent step y = -H^-1 g on the ``free`` (n, 2)
        components of the reduced gradient ``g`` (n, 2) and Hessian ``H`` (n, 2, 2), H shifted to negative
        definite where it is not (concave False there); closed form (2 x 2)."""
        g = np.where(free, g, 0.0)
        both = free[:, 0] & free[:, 1]
        o = np.where(both, H[:, 0, 1], 0.0)
        size = np.maximum(np.where(free, np.abs(H[:, [0, 1], [0, 1]]), 0.0).max(axis=1) + np.abs(o), 1e-150)
        a = np.where(free[:, 0], H[:, 0, 0], -size)                    # a fixed component: a neutral -size
        d = np.where(free[:, 1], H[:, 1, 1], -size)
        top = (a + d) / 2 + np.hypot((a - d) / 2, o)                   # the largest eigenvalue
        concave = top < 0
        shift = np.where(concave, 0.0, top + 1e-3 * size)
        a, d = a - shift, d - shift
        det = a * d - o * o
        y = np.column_stack([-(d * g[:, 0] - o * g[:, 1]), -(a * g[:, 1] - o * g[:, 0])]) / det[:, None]
        y = np.where(free, y, 0.0)
        return y, (g * y).sum(axis=1) / 2, concave

    def _pattern(self, b, el, L, v):
        """(L, s, capped): the pattern search from the points ``L`` (k, c) of the curved elements ``el`` where s
        is ``v``: each step moves to the best of the neighbours L + h (e_i - e_j) (and h / 2) where one is
        better, else shrinks h by :data:`ZOOM`; it stops where h is below :data:`ZOOM_STEP` or after
        :data:`ZOOM_ROUNDS` steps (capped True)."""
        L, v = L.copy(), v.copy()
        c = L.shape[1]
        d = np.array([[-1, 1], [1, -1]], dtype=float) if c == 2 else \
            np.array([[1, -1, 0], [-1, 1, 0], [0, 1, -1], [0, -1, 1], [1, 0, -1], [-1, 0, 1]], dtype=float)
        steps = np.concatenate([d, 0.5 * d])
        h = np.full(len(el), 1.0 / GRID[self.width])
        live = np.arange(len(el))
        for _ in range(ZOOM_ROUNDS):
            r = np.arange(len(live))
            cand = np.clip(L[live, None, :] + h[live, None, None] * steps[None], 0.0, None)
            cand /= cand.sum(axis=2, keepdims=True)
            sc = self._slack(b, np.repeat(el[live], len(steps)), cand.reshape(-1, c)).reshape(len(live), -1)
            a = np.argmax(sc, axis=1)
            up = sc[r, a] > v[live]
            L[live[up]] = cand[r, a][up]
            v[live[up]] = sc[r, a][up]
            h[live[~up]] *= ZOOM
            live = live[h[live] > ZOOM_STEP]
            if not len(live):
                break
        return L, v, h > ZOOM_STEP

    @staticmethod
    @functools.cache
    def _neighbours(width: int) -> np.ndarray:
        """(k, 6): the indices of each sample's neighbours on the grid of :meth:`_grid` of the elements of
        ``width`` coefficients (-1: none): t +- 1/m on segments, L + (e_i - e_j) / m on triangles."""
        m = GRID[width]
        if width == 3:
            i = np.arange(m + 1)
            nb = np.column_stack([i - 1, i + 1])
            nb = np.where((nb >= 0) & (nb <= m), nb, -1)
        else:
            P = np.rint(simplex_grid(m) * m).astype(int)
            index = {tuple(p): n for n, p in enumerate(P)}
            d = [(1, -1, 0), (-1, 1, 0), (0, 1, -1), (0, -1, 1), (1, 0, -1), (-1, 0, 1)]
            nb = np.array([[index.get(tuple(p + np.array(e)), -1) for e in d] for p in P])
        nb.flags.writeable = False
        return nb

    def pairing(self, S: int, elements, points, y) -> np.ndarray:
        """(S,): sum over the point forces ``y`` of each element of y_p delta(x_p) (scaled): what the pairing of
        the point forces with the true slack adds to beta . b (docs/formulation.md §8: sum_p y_p s(x_p) =
        beta . b - this)."""
        out = np.zeros(S)
        np.add.at(out, np.asarray(elements, dtype=int), np.asarray(y, dtype=float) * self.at(elements, points))
        return out
