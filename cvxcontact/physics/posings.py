"""How a rigid obstacle's surface becomes contact rows: the posings behind the constructors' ``distance=``.

A :class:`Posing` turns an analytic surface (physics/surfaces.py) into the distance g(x, nu) (m), the
sensitivity c(x, nu) to the obstacle's translation and the row direction d(x, nu) of the rows
d . u <= g - c . t (docs/formulation.md §12): :class:`ClosestPoint` (``"closest"``, towards the closest point of
the surface) and :class:`Ray` (``"ray"``, along the part's normal), both in :data:`POSINGS`; and the distance's
derivatives along a contact part, in closed form, or by central differences for an obstacle given by its
distance only.
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError


class Posing:
    """How a rigid obstacle's surface becomes contact rows (the strategy behind the constructors' ``distance=``):
    ``pose(surface)`` gives (distance g(x, nu) (m), sensitivity c(x, nu), direction d(x, nu) or None) with which
    the row at a node x of a part with outward normal nu reads d . u <= g - c . t (t the obstacle's translation,
    m; ``direction`` None: d = nu). :data:`POSINGS` holds the two: ``"closest"`` and ``"ray"``."""

    name: str = ""

    def pose(self, surface):
        raise NotImplementedError

    def derivatives(self, surface):
        """``(x, nu) -> (g, grad, hess)``: the posed gap g (n,) (m) at points ``x`` (n, d) of a part with outward
        ``nu`` and its gradient (n, d) and Hessian (n, d, d) (1/m) along the part (:meth:`.Rigid.
        distance_derivatives`), in closed form from the surface's geometry."""
        raise NotImplementedError


class ClosestPoint(Posing):
    """The field's linearised non-penetration (docs/formulation.md §12, "Closest point"): g(x) the signed distance
    from x to the closest point q of the obstacle's surface (negative inside), d(x) = -n_o(q) the unit direction
    from x to q (n_o the obstacle's outward unit normal at q) and c(x) = n_o(q): a translation t of the obstacle
    moves its surface near q by n_o . t along n_o, so the condition reads -n_o . (u - t) <= g. A node whose
    closest point faces away from the part (n_o . nu >= 0: the obstacle lies behind it or beside it) is left
    free (g = +inf), as a ray that misses."""

    name = "closest"

    def pose(self, surface):
        memo = {}

        def closest(x, nu):                                  # the foot once per (points, normal)
            key = (x.tobytes(), x.shape, nu.tobytes())
            if memo.get("key") != key:
                g, n_o = surface.closest(x, nu)
                facing = n_o @ nu < -1e-12                  # the surface there faces the part; else: no contact
                memo["key"], memo["value"] = key, (np.where(facing, g, np.inf), n_o)
            return memo["value"]

        def distance(x, nu):
            return closest(x, nu)[0].copy()

        def direction(x, nu):
            g, n_o = closest(x, nu)
            return np.where(np.isfinite(g)[:, None], -n_o, nu)

        def sensitivity(x, nu):
            g, n_o = closest(x, nu)
            return np.where(np.isfinite(g)[:, None], n_o, 0.0)

        return distance, sensitivity, direction

    def derivatives(self, surface):
        """grad g = n_o (the signed distance's gradient: x - q = g n_o, the foot q stationary) and
        hess g = d n_o(q(x)) / dx, the shape operator at the foot seen from x (:meth:`._Surface.closest_hessian`:
        (I - n_o n_o^T) / |x - c| for a ball, the same across the axis for a cylinder, 0 for a plane, through the
        foot point's motion for a graph), both projected on the part's plane; g = +inf where the surface there
        does not face the part (as :meth:`pose`)."""

        def derivatives(x, nu):
            g, n_o, H = surface.closest_hessian(x, nu)
            g = np.where(n_o @ nu < -1e-12, g, np.inf)
            return _along_part(g, n_o, H, nu)

        return derivatives


class Ray(Posing):
    """The distance along the body's normal (a ray cast): g(x) the distance from x along nu to the surface (+inf
    where the ray misses), d = nu and c(x) = n_o / (-nu . n_o), n_o the outward normal where the ray meets the
    surface. Exact for a plane the part faces squarely; for a curved obstacle it is the vertical-distance
    approximation (the obstacle's slope under the contact is neglected in the row direction), kept for comparison
    with results posed that way."""

    name = "ray"

    def pose(self, surface):
        return surface.ray, surface.ray_sensitivity(), None

    def derivatives(self, surface):
        """The ray's distance g(x) with the surface phi(y) = 0 at y = x + g nu: grad g = -grad phi / (grad phi .
        nu) and hess g = -J^T (hess phi) J / (grad phi . nu), J = I + nu grad g^T (:meth:`._Surface.
        ray_derivatives`), projected on the part's plane."""

        def derivatives(x, nu):
            return _along_part(*surface.ray_derivatives(x, nu), nu)

        return derivatives


POSINGS = {p.name: p for p in (ClosestPoint(), Ray())}
"""The posings of :class:`Posing` by the name a constructor's ``distance=`` takes."""


def named_posing(distance, kind) -> Posing:
    """The :class:`Posing` named ``distance`` (SceneError naming the choices otherwise)."""
    if isinstance(distance, Posing):
        return distance
    if not isinstance(distance, str) or distance not in POSINGS:
        raise SceneError(f"Rigid.{kind}: distance must be one of {sorted(POSINGS)} (how the rows measure the "
                         f"distance to the obstacle: 'closest', to the closest point of its surface, the default; "
                         f"'ray', along the body's normal), got {distance!r}")
    return POSINGS[distance]


def posed_surface(surface, posing, default):
    """(distance, sensitivity, direction, description, suffix) of ``surface`` posed by ``posing`` (the
    description names the posing where it is not the kind's ``default``)."""
    distance, sensitivity, direction = posing.pose(surface)
    describe = surface.describe if posing is default else surface.describe[:-1] + f", distance={posing.name!r})"
    return distance, sensitivity, direction, posing.derivatives(surface), describe, surface.suffix


def _along_part(g, grad, hess, nu):
    """(g, grad, hess) with the derivatives' components along the part's normal ``nu`` removed (P grad,
    P hess P, P = I - nu nu^T) and zero where g = +inf."""
    P = np.eye(len(nu)) - np.outer(nu, nu)
    live = np.isfinite(g)
    grad = np.where(live[:, None], grad @ P, 0.0)
    hess = np.where(live[:, None, None], np.einsum("ij,njk,kl->nil", P, hess, P), 0.0)
    return g, grad, hess


def central_derivatives(distance, points, normal):
    """(g, grad, hess) of an obstacle given by its ``distance`` only, by central differences along the part
    (step 1e-4 of the points' extent; second-order: what an analytic surface gives in closed form)."""
    d = len(normal)
    P = np.eye(d) - np.outer(normal, normal)
    E = np.linalg.svd(P)[0][:, :d - 1].T                     # an orthonormal basis of the part's plane
    h = 1e-4 * max(float(np.ptp(points)), float(np.abs(points).max(initial=0.0)), np.finfo(float).tiny)
    g = np.asarray(distance(points, normal), dtype=float)
    grad = np.zeros((len(points), d))
    hess = np.zeros((len(points), d, d))
    with np.errstate(invalid="ignore"):
        at = lambda v: np.asarray(distance(points + v, normal), dtype=float)      # noqa: E731
        for i, ei in enumerate(E):
            fp, fm = at(h * ei), at(-h * ei)
            grad += np.outer((fp - fm) / (2 * h), ei)
            hess += np.einsum("n,i,j->nij", (fp + fm - 2 * g) / h ** 2, ei, ei)
            for ej in E[:i]:
                c = (at(h * (ei + ej)) - at(h * (ei - ej)) - at(h * (ej - ei)) + at(-h * (ei + ej))) / (4 * h * h)
                hess += np.einsum("n,i,j->nij", c, ei, ej) + np.einsum("n,i,j->nij", c, ej, ei)
    live = np.isfinite(g) & np.isfinite(grad).all(axis=1) & np.isfinite(hess).all(axis=(1, 2))
    return g, np.where(live[:, None], grad, 0.0), np.where(live[:, None, None], hess, 0.0)
