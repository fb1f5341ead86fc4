"""Contact pairs and rigid obstacles: what a :class:`~cvxcontact.physics.scene.Scene` puts in contact.

A :class:`Contact` names two straight boundary parts that touch: one of a body and one of another
body or of a :class:`Rigid` obstacle. Each pair is the paper's contact problem on its own segment
(docs/formulation.md §3-4): non-penetration [u_nu] <= g with

    [u_nu] = u^a . nu^a + u^b . nu^b        (each body's outward unit normal; nu^b = -nu^a)

on the overlap of the two parts. A rigid obstacle is analytic (no mesh, no unknowns): u^b = 0 and
g(x) is the distance (m) from the body's node x to the obstacle along nu^a, plus the pair's gap;
the linearised condition u^a . nu^a <= g(x) holds at every node of the body's part that can
reach the obstacle along nu^a (small displacements, like the rest of the model).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..contact.interface import CONDITIONS, canonical_tangent
from ..contact.laws import ContactLaw, check_law
from ..errors import SceneError, UnsupportedError

__all__ = ["Contact", "Rigid"]


def _point(value, label) -> np.ndarray:
    try:
        p = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{label}: expected two real numbers (m), got {value!r}") from None
    if p.shape != (2,) or not np.isfinite(p).all() or isinstance(value, (str, bytes)):
        raise SceneError(f"{label}: expected two finite real numbers, got {value!r}")
    p.setflags(write=False)
    return p


def _no_force(force, kind):
    if force is not None:
        raise UnsupportedError(f"Rigid.{kind}(force=...): force control (the obstacle's translation as an "
                               "unknown with a prescribed resultant) is not implemented in this version; "
                               "prescribe the obstacle's position instead (displacement control)")


class Rigid:
    """A rigid obstacle: analytic, fixed in space (no mesh, no unknowns). Build with
    :meth:`plane`, :meth:`circle` or :meth:`profile`.

    ``distance(points, normal)`` gives, for nodes ``points`` (n, 2) of a straight part with unit
    outward normal ``normal``, the distance (m) along ``normal`` to the obstacle's surface:
    negative for a node already inside the obstacle (an interference), ``+inf`` where the ray
    misses it (the node is then left free).
    """

    def __init__(self, kind: str, distance: Callable[[np.ndarray, np.ndarray], np.ndarray], describe: str):
        self.kind, self._distance, self._describe = kind, distance, describe

    def __repr__(self):
        return f"Rigid.{self._describe}"

    def distance(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Distance (m) from each of ``points`` (n, 2) along the unit ``normal`` to the surface."""
        points = np.array(points, dtype=float)
        points.setflags(write=False)
        return self._distance(points, np.asarray(normal, dtype=float))

    @classmethod
    def plane(cls, point: Sequence[float], normal: Sequence[float], *, force: Sequence[float] | None = None) -> "Rigid":
        """The half-plane {z : (z - point) . n <= 0}; ``normal`` n points out of the obstacle,
        towards the body (normalised here). The body's part must face it: nu^a . n < 0."""
        _no_force(force, "plane")
        p = _point(point, "Rigid.plane: point")
        n = _point(normal, "Rigid.plane: normal")
        if np.linalg.norm(n) == 0:
            raise SceneError("Rigid.plane: normal must not be zero")
        n = n / np.linalg.norm(n)

        def distance(x, nu):
            c = float(nu @ n)
            if c >= -1e-12:
                raise SceneError(f"Rigid.plane through ({p[0]:.6g}, {p[1]:.6g}) m with normal ({n[0]:.6g}, "
                                 f"{n[1]:.6g}) does not face the contact part, whose outward normal is "
                                 f"({nu[0]:.6g}, {nu[1]:.6g}); the plane's normal must point towards the body")
            return ((x - p) @ n) / (-c)

        return cls("plane", distance, f"plane(point=({p[0]:.6g}, {p[1]:.6g}), normal=({n[0]:.6g}, {n[1]:.6g}))")

    @classmethod
    def circle(cls, center: Sequence[float], radius: float, *, force: Sequence[float] | None = None) -> "Rigid":
        """The disc of ``radius`` (m) around ``center`` (m): a cylinder in plane strain. Nodes whose
        normal ray misses the disc are left free."""
        _no_force(force, "circle")
        c = _point(center, "Rigid.circle: center")
        if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)) \
                or not np.isfinite(radius) or radius <= 0:
            raise SceneError(f"Rigid.circle: radius must be a positive finite number (m), got {radius!r}")
        R = float(radius)

        def distance(x, nu):
            w = x - c
            b = w @ nu
            disc = b * b - (np.einsum("ij,ij->i", w, w) - R * R)
            root = np.sqrt(np.maximum(disc, 0.0))
            hit = (disc >= 0) & (-b + root > 0)          # the ray enters the disc ahead or the node is inside
            return np.where(hit, -b - root, np.inf)

        return cls("circle", distance, f"circle(center=({c[0]:.6g}, {c[1]:.6g}), radius={R:.6g})")

    @classmethod
    def profile(cls, f: Callable[[np.ndarray], ArrayLike], origin: Sequence[float] = (0.0, 0.0), *,
                force: Sequence[float] | None = None) -> "Rigid":
        """An obstacle whose surface lies at distance ``f(s)`` (m) from the contact part along its
        outward normal, with s = (x - origin) . t (m) the tangential coordinate (t the pair's tangent,
        :func:`cvxcontact.contact.interface.canonical_tangent`: positive x1 component). ``f`` is a
        vectorised function returning finite values, or ``+inf`` where there is no obstacle."""
        _no_force(force, "profile")
        if not callable(f):
            raise SceneError(f"Rigid.profile: f must be a callable f(s) of the tangential coordinate (m), "
                             f"got {type(f).__name__}")
        o = _point(origin, "Rigid.profile: origin")

        def distance(x, nu):
            s = (x - o) @ canonical_tangent(nu)
            s.setflags(write=False)
            try:
                d = np.array(f(s))
            except Exception as exc:
                raise SceneError(f"Rigid.profile: calling f failed: {exc}") from exc
            if d.dtype.kind not in "iuf":
                raise SceneError(f"Rigid.profile: f returned values of type {d.dtype}, expected real numbers")
            try:
                d = np.broadcast_to(d.astype(float), s.shape).copy()
            except ValueError:
                raise SceneError(f"Rigid.profile: f returned shape {d.shape}, expected {s.shape}") from None
            if np.isnan(d).any() or (d == -np.inf).any():
                raise SceneError("Rigid.profile: f returned NaN or -inf; use +inf where there is no obstacle")
            return d

        name = getattr(f, "__name__", type(f).__name__)
        return cls("profile", distance, f"profile({name}, origin=({o[0]:.6g}, {o[1]:.6g}))")


class Contact:
    """A contact pair: part ``part_a`` of ``body_a`` against part ``part_b`` of ``other`` (a Body)
    or against a :class:`Rigid` obstacle (then ``part_b`` is omitted).

    Parameters
    ----------
    body_a : Body
    part_a : str
        A straight boundary part of body_a (any direction).
    other : Body or Rigid
    part_b : str, optional
        A straight boundary part of ``other``, parallel to part_a with the opposite normal; None for a
        rigid obstacle.
    condition : {"gamma3", "sigma1", "sigma2"} or None
        K_h(Gamma_3) or K_h(Sigma_h^l) on this pair ("sigma1"/"sigma2": the nodes of body_a/other);
        None (default): the condition given to ``solve``.
    gap : float or callable g(s), m
        Initial normal gap g along the pair, s the tangential coordinate (m); added to the distance
        to a rigid obstacle.
    law : Signorini, NormalCompliance or None
        This pair's normal law (:mod:`cvxcontact.contact.laws`): ``cc.Signorini()`` (non-penetration)
        or ``cc.NormalCompliance(stiffness=k, exponent=m)`` (the paper's (7), docs/formulation.md §10);
        None (default): the law given to ``solve``/``Model`` (itself Signorini by default). A scene may
        mix the two, against bodies and rigid obstacles alike.
    """

    def __init__(self, body_a, part_a: str, other, part_b: str | None = None, *, condition: str | None = None,
                 gap: float | Callable[[np.ndarray], ArrayLike] = 0.0, law: ContactLaw | None = None) -> None:
        from .scene import Body, Load

        if not isinstance(body_a, Body):
            raise SceneError(f"Contact: body_a must be a Body, got {type(body_a).__name__}")
        if not isinstance(other, (Body, Rigid)):
            raise SceneError(f"Contact: other must be a Body or a Rigid obstacle, got {type(other).__name__}")
        if other is body_a:
            raise SceneError(f"Contact: {body_a.name} is paired with itself; a contact pair needs two bodies "
                             "(self-contact is not modelled)")
        if law is not None:
            law = check_law(law)
        if condition is not None and condition not in CONDITIONS:
            raise SceneError(f"Contact: condition must be one of {CONDITIONS} or None, got {condition!r}")
        self.body_a, self.other, self.condition, self.law = body_a, other, condition, law
        self.part_a = self._part(body_a, part_a, "part_a")
        if isinstance(other, Rigid):
            if part_b is not None:
                raise SceneError(f"Contact: a rigid obstacle has no boundary parts; drop part_b={part_b!r}")
            self.part_b = None
        else:
            self.part_b = self._part(other, part_b, "part_b")
        self.gap = Load(gap if not callable(gap) else (lambda x, y, g=gap: g(x)), f"{self}: gap", 1)

    @property
    def rigid(self) -> bool:
        """True if the second side is a rigid obstacle."""
        return isinstance(self.other, Rigid)

    @staticmethod
    def _part(body, part, role):
        if not isinstance(part, str):
            raise SceneError(f"Contact: {role} must be a boundary tag (a string) of {body.name}, got {part!r}")
        if part not in body.mesh.tags:
            raise SceneError(f"Contact: {role} names unknown boundary tag {part!r} of {body.name}; "
                             f"the mesh has {sorted(body.mesh.tags)}")
        for kind, tags in (("clamped", body.clamped), ("traction", list(body.traction))):
            if part in tags:
                raise SceneError(f"Contact: {role} {part!r} of {body.name} is also {kind}")
        return part

    def __repr__(self):
        other = repr(self.other) if self.rigid else f"{self.other.name!r}, {self.part_b!r}"
        return f"Contact({self.body_a.name!r}, {self.part_a!r}, {other})"
