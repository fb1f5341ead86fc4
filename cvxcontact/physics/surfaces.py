"""The analytic surfaces of the rigid obstacles (:class:`~cvxcontact.physics.pairs.Rigid`) and their geometry.

Each surface, at its place, answers the two questions a :class:`~cvxcontact.physics.posings.Posing` asks of it
(docs/formulation.md §12): the distance along a body's normal (a ray cast, +inf where the ray misses) with the
sensitivity c = n_o / (-nu . n_o), and the signed distance to the closest surface point with the obstacle's
outward normal n_o there; each also gives both distances' derivatives along a contact part in closed form
(the tangency Newton of P2 "gamma3" uses them). The surfaces: the half-plane / half-space, the disk / ball, the
cylinder, and the graphs (a 3D height field z = f(x, y), a 2D profile over the part's line), whose closest
point is found by Newton's method on the foot condition.
"""

from __future__ import annotations

import numpy as np

from ..contact.interface import canonical_tangent
from ..errors import SceneError


def fmt(v) -> str:
    """The vector ``v`` as "(x, y[, z])", each component to 6 significant digits (the obstacles' and pairs'
    messages and descriptions)."""
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"

def _surface_values(label, f, args) -> np.ndarray:
    """``f(*args)`` of a user's obstacle surface (a profile's distance, a height field's height), checked: real
    values of the arguments' shape (broadcast), no NaN or -inf (+inf: no obstacle there); a copy, floats."""
    shape = args[0].shape
    try:
        v = np.array(f(*args))
    except Exception as exc:
        raise SceneError(f"{label}: calling f failed: {exc}") from exc
    if v.dtype.kind not in "iuf":
        raise SceneError(f"{label}: f returned values of type {v.dtype}, expected real numbers")
    try:
        v = np.broadcast_to(v.astype(float), shape).copy()
    except ValueError:
        raise SceneError(f"{label}: f returned shape {v.shape}, expected {shape}") from None
    if np.isnan(v).any() or (v == -np.inf).any():
        raise SceneError(f"{label}: f returned NaN or -inf; use +inf where there is no obstacle")
    return v


class _Surface:
    """An analytic obstacle surface at its place: ``ray(x, nu)`` the distance along nu (m, +inf where the ray
    misses), ``outward(q)`` the obstacle's outward unit normals at surface points q, ``closest(x, nu)`` (g, n_o):
    the signed distance (m) to the closest surface point and n_o there (g = +inf where there is none)."""

    describe, suffix = "", ""

    def ray_sensitivity(self):
        return _ray_sensitivity(self.ray, self.outward)

    def closest_hessian(self, x, nu):
        """(g, n_o, H): :meth:`closest` and the Hessian (n, d, d) (1/m) of the signed distance at ``x``."""
        raise NotImplementedError

    def ray_derivatives(self, x, nu):
        """(g, grad, hess) of :meth:`ray` at ``x`` (:func:`_implicit_ray`)."""
        raise NotImplementedError


class Plane(_Surface):
    """The half-plane (half-space) {z : (z - p) . n <= 0} (``n`` its unit normal, out of the obstacle)."""

    def __init__(self, p, n):
        self.p, self.n = p, n
        self.describe = f"plane(point={fmt(p)}, normal={fmt(n)})"

    def _facing(self, nu):
        c = float(nu @ self.n)
        if c >= -1e-12:
            raise SceneError(f"Rigid.plane through {fmt(self.p)} m with normal {fmt(self.n)} does not face the "
                             f"contact part, whose outward normal is {fmt(nu)}; the plane's normal must point "
                             "towards the body")
        return -c

    def ray(self, x, nu):
        return ((x - self.p) @ self.n) / self._facing(nu)

    def ray_sensitivity(self):
        return lambda x, nu: np.tile(self.n / self._facing(nu), (len(x), 1))

    def outward(self, q):
        return np.tile(self.n, (len(q), 1))

    def closest(self, x, nu):
        self._facing(nu)
        return (x - self.p) @ self.n, self.outward(x)

    def closest_hessian(self, x, nu):
        return *self.closest(x, nu), np.zeros((len(x), len(nu), len(nu)))

    def ray_derivatives(self, x, nu):
        return _implicit_ray(self.ray(x, nu), self.outward(x), np.zeros((len(x), len(nu), len(nu))), nu)


class Ball(_Surface):
    """The disc (2D) or ball (3D) of radius ``R`` (m) around ``c`` (m)."""

    def __init__(self, c, R, kind):
        self.c, self.R = c, R
        self.describe = f"{kind}(center={fmt(c)}, radius={R:.6g})"

    def ray(self, x, nu):
        w, lo = _two_sum(x, -self.c)
        return _quadratic_hit(np.ones(len(w)), w @ nu, _power(w, lo, self.R))

    def outward(self, q):
        return (q - self.c) / self.R

    def closest(self, x, nu):
        w, lo = _two_sum(x, -self.c)
        r = np.linalg.norm(w, axis=1)
        centre = r == 0                                     # at the centre: straight out along -nu
        n_o = np.where(centre[:, None], -nu, w / np.where(centre, 1.0, r)[:, None])
        return _power(w, lo, self.R) / (r + self.R), n_o   # |w| - R without cancellation

    def closest_hessian(self, x, nu):
        g, n_o = self.closest(x, nu)
        r = g + self.R                                      # (I - n_o n_o^T) / r: the sphere through x
        with np.errstate(divide="ignore"):
            H = (np.eye(len(nu))[None] - n_o[:, :, None] * n_o[:, None, :]) / r[:, None, None]
        return g, n_o, H

    def ray_derivatives(self, x, nu):
        g = self.ray(x, nu)                                 # phi(y) = |y - c|^2 / 2 - R^2 / 2
        y = x - self.c + np.where(np.isfinite(g), g, 0.0)[:, None] * nu
        return _implicit_ray(g, y, np.broadcast_to(np.eye(len(nu)), (len(x), len(nu), len(nu))), nu)


class Cylinder(_Surface):
    """The solid cylinder of radius ``R`` (m) around the line through ``p`` along the unit ``axis``."""

    def __init__(self, p, axis, R):
        self.p, self.axis, self.R = p, axis, R
        self.describe = f"cylinder(point={fmt(p)}, axis={fmt(axis)}, radius={R:.6g})"

    def across(self, v):                                    # the components normal to the axis
        return v - np.multiply.outer(v @ self.axis, self.axis)

    def ray(self, x, nu):
        hi, lo = _two_sum(x, -self.p)
        w, lo, v = self.across(hi), self.across(lo), self.across(nu)
        a = np.full(len(w), float(v @ v))
        a = np.where(a > 1e-24, a, 0.0)                     # a ray along the axis misses
        return _quadratic_hit(a, w @ v, _power(w, lo, self.R))

    def outward(self, q):
        return self.across(q - self.p) / self.R

    def closest(self, x, nu):
        hi, lo = _two_sum(x, -self.p)
        w, lo = self.across(hi), self.across(lo)
        r = np.linalg.norm(w, axis=1)
        v = -self.across(nu)                                # on the axis: out along -nu across the axis
        on_axis = r == 0
        n_o = w / np.where(on_axis, 1.0, r)[:, None]
        if on_axis.any():
            if np.linalg.norm(v) > 1e-12:
                n_o[on_axis] = v / np.linalg.norm(v)
            else:                                           # a part normal along the axis, on the axis: none
                return np.where(on_axis, np.inf, r - self.R), n_o
        return _power(w, lo, self.R) / (r + self.R), n_o   # |w| - R without cancellation

    def closest_hessian(self, x, nu):
        g, n_o = self.closest(x, nu)
        r = g + self.R                                      # (I - a a^T - n_o n_o^T) / r: the cylinder through x
        with np.errstate(divide="ignore"):
            H = (np.eye(3) - np.outer(self.axis, self.axis))[None] - n_o[:, :, None] * n_o[:, None, :]
            H = H / r[:, None, None]
        return g, n_o, H

    def ray_derivatives(self, x, nu):
        g = self.ray(x, nu)                                 # phi(y) = |y_across|^2 / 2 - R^2 / 2
        y = self.across(x - self.p + np.where(np.isfinite(g), g, 0.0)[:, None] * nu)
        A = np.eye(3) - np.outer(self.axis, self.axis)
        return _implicit_ray(g, y, np.broadcast_to(A, (len(x), 3, 3)), nu)


def _fd_scale(p, o):
    """A length (m) for the finite-difference steps of a graph's derivatives at parameters ``p`` (n, k)."""
    return max(float(np.ptp(p)) if p.size else 0.0, float(np.abs(p - o).max(initial=0.0)), 1e-300)


def _graph_derivatives(F, p, h):
    """(grad (n, k), hess (n, k, k)) of the graph function ``F`` ((n, k) -> (n,), m) at ``p`` by fourth-order
    central differences of step ``h`` (m; one-sided second-order slopes where a central stencil leaves the
    graph, i.e. meets +inf; the Hessian NaN there)."""
    n, k = p.shape
    f0 = F(p)
    grad = np.empty((n, k))
    hess = np.full((n, k, k), np.nan)
    E = np.eye(k) * h
    with np.errstate(invalid="ignore"):
        for i in range(k):
            fp, fm, fp2, fm2 = F(p + E[i]), F(p - E[i]), F(p + 2 * E[i]), F(p - 2 * E[i])
            central = (8 * (fp - fm) - (fp2 - fm2)) / (12 * h)
            forward = (-3 * f0 + 4 * fp - fp2) / (2 * h)
            backward = (3 * f0 - 4 * fm + fm2) / (2 * h)
            grad[:, i] = np.where(np.isfinite(central), central, np.where(np.isfinite(forward), forward, backward))
            hess[:, i, i] = (16 * (fp + fm) - (fp2 + fm2) - 30 * f0) / (12 * h * h)
            for j in range(i):
                hess[:, i, j] = hess[:, j, i] = (F(p + E[i] + E[j]) - F(p + E[i] - E[j]) - F(p - E[i] + E[j])
                                                 + F(p - E[i] - E[j])) / (4 * h * h)
    return grad, hess


FOOT_TOL = 1e-12
"""Relative size (of the scene's length) of a Newton step on a graph's foot point at which it has converged."""


def _graph_foot(F, p0, z, origin, label):
    """The foot point of each point (p0, z) on the graph w = F(p) (p in R^k, k = 1 or 2; +inf: no obstacle):
    p* minimising phi(p) = |p - p0|^2 / 2 + (F(p) - z)^2 / 2 by Newton's method from p0, safeguarded (the
    Gauss-Newton matrix where the Hessian is not positive definite, halved steps until phi does not grow).
    Returns (p*, F(p*), grad F(p*), hess F(p*)); rows with F(p0) = +inf (no obstacle above the point) are +inf.
    SceneError naming ``label`` if it does not settle in 100 steps."""
    n, k = p0.shape
    p = p0.copy()
    Fp = F(p)
    live = np.isfinite(Fp)
    scale = max(_fd_scale(p0[live], origin), float(np.abs(Fp[live] - z[live]).max(initial=0.0)))
    h = 1e-3 * scale

    def phi(q, Fq, zz, q0):
        return 0.5 * (np.einsum("ij,ij->i", q - q0, q - q0) + (Fq - zz) ** 2)

    todo = live.copy()
    for _ in range(100):
        idx = np.flatnonzero(todo)
        if len(idx) == 0:
            break
        q, Fq, zz, q0 = p[idx], Fp[idx], z[idx], p0[idx]
        G, H = _graph_derivatives(F, q, h)
        r = Fq - zz
        grad = (q - q0) + r[:, None] * G
        A = np.eye(k) + G[:, :, None] * G[:, None, :]
        full = A + r[:, None, None] * H
        pd = np.isfinite(full).all(axis=(1, 2)) & (np.linalg.eigvalsh(np.where(np.isfinite(full), full, 1.0))
                                                   .min(axis=1) > 1e-12)
        A = np.where(pd[:, None, None], full, A)
        step = -np.linalg.solve(A, grad[:, :, None])[:, :, 0]
        base = phi(q, Fq, zz, q0)
        a = np.ones(len(idx))
        for _ in range(60):                                 # halve until phi does not grow (off the graph: grows)
            trial = q + a[:, None] * step
            Ft = F(trial)
            with np.errstate(invalid="ignore"):
                bad = ~(phi(trial, Ft, zz, q0) <= base * (1 + 1e-12) + 1e-300)
            if not bad.any():
                break
            a = np.where(bad, 0.5 * a, a)
        p[idx], Fp[idx] = trial, Ft
        settled = (np.linalg.norm(step, axis=1) <= FOOT_TOL * scale) & ~bad   # the full Newton step, taken
        todo[idx] = ~settled
    else:
        worst = int(np.flatnonzero(todo)[0])
        raise SceneError(f"{label}: the closest point of the surface to the point with parameters {fmt(p0[worst])} "
                         "was not found to rounding in 100 Newton steps (the surface is not smooth there, or the "
                         "point is far from it compared with its curvature radius); use a smoother f, or "
                         "distance='ray'")
    G = np.full((n, k), np.nan)
    H = np.full((n, k, k), np.nan)
    if live.any():
        G[live], H[live] = _graph_derivatives(F, p[live], h)
    return p, np.where(live, Fp, np.inf), G, H


def _graph_hessian(g, G, H, E, U):
    """(n_o, hess g): the outward normal and the Hessian (n, d, d) (1/m) of the signed distance g (n,) to the
    graph S(p) = p E + F(p) U (E (k, d) orthonormal rows, U (d,) the unit up direction, the obstacle the solid
    above) at points whose foot has slopes ``G`` = grad F (n, k) and curvature ``H`` = hess F (n, k, k).

    With x - S(p*) = g n_o, n_o = (G E - U) / w, w = sqrt(1 + |G|^2), the foot's condition (x - S) . S_i = 0
    moves it by dp/dx = A^-1 S_p^T, A = I + G G^T + g H / w, S_p^T = E + G U^T; grad g = n_o and
    hess g = dn_o/dp dp/dx with dn_o/dp = (I - n_o n_o^T) E^T H / w."""
    k = E.shape[0]
    w = np.sqrt(1 + np.einsum("ni,ni->n", G, G))
    n_o = (G @ E - U) / w[:, None]
    A = np.eye(k)[None] + G[:, :, None] * G[:, None, :] + g[:, None, None] * H / w[:, None, None]
    Sp = E[None] + G[:, :, None] * U[None, None, :]                                    # (n, k, d)
    dn = np.einsum("nij,jk,nkl->nil", np.eye(len(U))[None] - n_o[:, :, None] * n_o[:, None, :], E.T, H) \
        / w[:, None, None]                                                              # (n, d, k)
    return n_o, dn @ np.linalg.solve(A, Sp)


class HeightField(_Surface):
    """The solid above z = f(x - o_x, y - o_y) + o_z (m)."""

    def __init__(self, f, o):
        self.f, self.o = f, o
        name = getattr(f, "__name__", type(f).__name__)
        self.describe = f"height_field({name}, origin={fmt(o)})"

    def surface(self, xy):
        X, Y = xy[:, 0] - self.o[0], xy[:, 1] - self.o[1]
        X.setflags(write=False)
        Y.setflags(write=False)
        return _surface_values("Rigid.height_field", self.f, (X, Y)) + self.o[2]

    def slopes(self, xy):
        o = self.o
        h = 1e-6 * max(float(np.ptp(xy)), float(np.abs(xy - o[:2]).max(initial=0.0)), np.finfo(float).tiny)
        out = np.empty_like(xy)
        for k in range(2):
            step = np.zeros(2)
            step[k] = h
            with np.errstate(invalid="ignore"):
                out[:, k] = (self.surface(xy + step) - self.surface(xy - step)) / (2 * h)
        return out

    def _up(self, nu):
        if nu[2] <= 1e-12:
            raise SceneError(f"Rigid.height_field(origin={fmt(self.o)}) lies above its surface, so it does not "
                             f"face a contact part whose outward normal is {fmt(nu)}: the part must face up "
                             "(nu_z > 0)")

    def ray(self, x, nu):
        self._up(nu)
        surface, slopes = self.surface, self.slopes
        d = (surface(x[:, :2]) - x[:, 2]) / nu[2]           # exact for a vertical normal
        if abs(nu[2] - 1) > 1e-15:
            for _ in range(50):                            # Newton on phi(d) = z + d nu_z - f(x + d nu)
                live = np.isfinite(d)
                q = x[live] + d[live, None] * nu
                phi = q[:, 2] - surface(q[:, :2])
                dphi = nu[2] - slopes(q[:, :2]) @ nu[:2]
                step = np.where(np.isfinite(phi) & (np.abs(dphi) > 1e-12), phi / np.where(dphi != 0, dphi, 1), np.inf)
                d[live] = np.where(np.isfinite(step), d[live] - step, np.inf)   # no root on this ray: a miss
                if (np.abs(step[np.isfinite(step)]) <= 1e-12 * (1 + np.abs(d[live][np.isfinite(step)]))).all():
                    break
            else:
                raise SceneError(f"Rigid.height_field(origin={fmt(self.o)}): Newton's method did not find where "
                                 f"the normal {fmt(nu)} meets the surface in 50 steps; use a smoother f or a part "
                                 "facing straight up")
        return d

    def outward(self, q):                                  # out of the solid above: down the graph's normal
        g = self.slopes(q[:, :2])
        n = np.column_stack([g, -np.ones(len(q))])
        return n / np.linalg.norm(n, axis=1)[:, None]

    def closest(self, x, nu):
        return self.closest_hessian(x, nu)[:2]

    def closest_hessian(self, x, nu):
        self._up(nu)
        p, Fp, G, H = _graph_foot(self.surface, x[:, :2].copy(), x[:, 2], self.o[:2], repr_of(self))
        live = np.isfinite(Fp)
        r = np.where(live, Fp - x[:, 2], 0.0)
        dist = np.sqrt(np.einsum("ij,ij->i", p - x[:, :2], p - x[:, :2]) + r * r)
        g = np.where(live, np.sign(r) * dist, np.inf)
        n_o, hess = _graph_hessian(np.where(live, g, 0.0), np.where(live[:, None], G, 0.0),
                                   np.where(live[:, None, None], H, 0.0), np.eye(3)[:2], np.eye(3)[2])
        return g, n_o, hess

    def ray_derivatives(self, x, nu):
        g = self.ray(x, nu)                                 # phi(y) = f(y_x, y_y) - y_z (the solid above)
        live = np.isfinite(g)
        y = x + np.where(live, g, 0.0)[:, None] * nu
        G = np.zeros((len(x), 2))
        H2 = np.zeros((len(x), 2, 2))
        if live.any():
            G[live], H2[live] = _graph_derivatives(self.surface, y[live, :2],
                                                   1e-3 * _fd_scale(y[live, :2], self.o[:2]))
        hess = np.zeros((len(x), 3, 3))
        hess[:, :2, :2] = H2
        return _implicit_ray(g, np.column_stack([G, -np.ones(len(x))]), hess, nu)


class Profile(_Surface):
    """The profile ``f`` built with origin ``o`` and moved so that its origin is at ``q`` (m): the surface lies at
    F(s) = f(s) + (q - o) . nu from the contact part along its outward normal nu, s = (x - q) . t (a profile's
    distances are measured from the contact part; the translation's normal component adds to them)."""

    def __init__(self, f, o, q):
        self.f, self.o, self.q = f, o, q
        self.lift = q - o
        name = getattr(f, "__name__", type(f).__name__)
        self.describe = f"profile({name}, origin=({o[0]:.6g}, {o[1]:.6g}))"
        self.suffix = f".moved(to=({q[0]:.6g}, {q[1]:.6g}))" if np.any(self.lift != 0) else ""

    def height(self, s, nu):
        s = np.array(s, dtype=float).reshape(-1)
        s.setflags(write=False)
        return _surface_values("Rigid.profile", self.f, (s,)) + float(self.lift @ nu)

    def ray(self, x, nu):
        return self.height((x - self.q) @ canonical_tangent(nu), nu)

    def ray_sensitivity(self):
        def sensitivity(x, nu):
            t = canonical_tangent(nu)
            s = (x - self.q) @ t
            h = 1e-6 * max(float(np.ptp(s)), float(np.abs(s).max(initial=0.0)), np.finfo(float).tiny)
            d0, dp, dm = self.ray(x, nu), self.ray(x + h * t, nu), self.ray(x - h * t, nu)
            with np.errstate(invalid="ignore"):              # f'(s): central, one-sided at an end of f
                fp = np.where(np.isfinite(dp) & np.isfinite(dm), (dp - dm) / (2 * h),
                              np.where(np.isfinite(dp), (dp - d0) / h, (d0 - dm) / h))
            ok = np.isfinite(fp) & np.isfinite(d0)
            return np.where(ok[:, None], np.outer(np.where(ok, fp, 0.0), t) - nu, 0.0)

        return sensitivity

    def closest(self, x, nu):
        return self.closest_hessian(x, nu)[:2]

    def closest_hessian(self, x, nu):
        t = canonical_tangent(nu)
        s0 = ((x - self.q) @ t)[:, None]
        F = lambda s: self.height(s[:, 0], nu)             # noqa: E731  (the graph over the part's line)
        s, Fs, G, H = _graph_foot(F, s0.copy(), np.zeros(len(x)), np.zeros(1), repr_of(self))
        live = np.isfinite(Fs)
        r = np.where(live, Fs, 0.0)
        dist = np.hypot(s[:, 0] - s0[:, 0], r)
        g = np.where(live, np.sign(r) * dist, np.inf)
        # the graph over the part's line: S(s) = s t + F(s) nu, its point at s0 (height 0)
        n_o, hess = _graph_hessian(np.where(live, g, 0.0), np.where(live[:, None], G, 0.0),
                                   np.where(live[:, None, None], H, 0.0), t[None, :], nu)
        return g, n_o, hess

    def ray_derivatives(self, x, nu):
        t = canonical_tangent(nu)                           # g = F(s), s = (x - q) . t
        g = self.ray(x, nu)
        live = np.isfinite(g)
        s = ((x - self.q) @ t)[:, None]
        G = np.zeros((len(x), 1))
        H = np.zeros((len(x), 1, 1))
        if live.any():
            G[live], H[live] = _graph_derivatives(lambda v: self.height(v[:, 0], nu), s[live],
                                                  1e-3 * _fd_scale(s[live], np.zeros(1)))
        return g, G[:, 0, None] * t, H[:, 0, 0, None, None] * np.outer(t, t)


def repr_of(surface) -> str:
    return "Rigid." + surface.describe + surface.suffix


def _ray_sensitivity(distance, outward):
    """c(x) = n_o / (-nu . n_o) with n_o = ``outward(q)`` the obstacle's unit outward normal where the ray
    from x along nu meets it (q, from ``distance``); 0 where it misses or grazes."""

    def sensitivity(x, nu):
        d = distance(x, nu)
        hit = np.isfinite(d)
        n_o = outward(x + np.where(hit, d, 0.0)[:, None] * nu)
        den = -(n_o @ nu)
        ok = hit & (den > 1e-12)
        return np.where(ok[:, None], n_o / np.where(ok, den, 1.0)[:, None], 0.0)

    return sensitivity


def _quadratic_hit(a, b, c):
    """The first root d of a d^2 + 2 b d + c = 0 (a > 0) ahead of the node or behind it inside the
    obstacle (c < 0), +inf where the ray misses."""
    disc = b * b - a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    hit = (disc >= 0) & (-b + root > 0) & (a > 0)     # the ray enters ahead or the node is inside
    with np.errstate(divide="ignore", invalid="ignore"):   # c / (-b + root) = (-b - root) / a, no cancellation
        d = np.where(b <= 0, c / np.where(hit, -b + root, 1.0), (-b - root) / np.where(a > 0, a, 1.0))
        return np.where(hit, d, np.inf)


def _two_sum(a, b):
    """(s, e) with s = fl(a + b) and a + b = s + e exactly (Knuth's TwoSum, elementwise)."""
    s = a + b
    t = s - a
    return s, (a - (s - t)) + (b - t)


def _two_product(a, b):
    """(p, e) with p = fl(a b) and a b = p + e exactly (Dekker's TwoProduct, elementwise; |a|, |b| < 1e150)."""
    def split(v):
        t = 134217729.0 * v                                 # 2^27 + 1
        hi = t - (t - v)
        return hi, v - hi

    p = a * b
    (ah, al), (bh, bl) = split(a), split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _power(w, lo, R):
    """|w + lo|^2 - R^2 (m^2) for the vectors (n, d) w + lo = x - c held exactly as a float w and its rounding
    lo (:func:`_two_sum`): the squares summed in doubled precision (Ogita, Rump and Oishi's Sum2), so that a
    point near a sphere of large radius R keeps its gap |x - c| - R = (|x - c|^2 - R^2) / (|x - c| + R) to
    rounding of the gap, not of R (eps R: 2e-6 m at R = 1e10 m)."""
    s, small = _two_product(np.asarray(R, float), -np.asarray(R, float))
    s, small = np.full(len(w), float(s)), np.full(len(w), float(small))
    for k in range(w.shape[1]):
        p, e = _two_product(w[:, k], w[:, k])
        s, t = _two_sum(s, p)
        small = small + t + e
    return s + (small + np.einsum("ij,ij->i", 2 * w + lo, lo))


def _implicit_ray(g, grad_phi, hess_phi, nu):
    """(g, grad g, hess g) of the ray distance g(x), x + g nu on the surface phi = 0, from phi's gradient (n, d)
    and Hessian (n, d, d) at the hit point (:meth:`.Ray.derivatives`); zero derivatives where the ray misses or
    grazes."""
    a = grad_phi @ nu
    ok = np.isfinite(g) & (np.abs(a) > 1e-300)
    a = np.where(ok, a, 1.0)
    grad = -grad_phi / a[:, None]
    J = np.eye(len(nu))[None] + nu[None, :, None] * grad[:, None, :]
    hess = -np.einsum("nji,njk,nkl->nil", J, hess_phi, J) / a[:, None, None]
    return g, np.where(ok[:, None], grad, 0.0), np.where(ok[:, None, None], hess, 0.0)
