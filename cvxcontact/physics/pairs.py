"""Contact pairs and rigid obstacles: what a :class:`~cvxcontact.physics.scene.Scene` puts in contact.

A :class:`Contact` names two straight boundary parts that touch: one of a body and one of another
body or of a :class:`Rigid` obstacle. Each pair is the paper's contact problem on its own segment
(docs/formulation.md §3-4): non-penetration [u_nu] <= g with

    [u_nu] = u^a . nu^a + u^b . nu^b        (each body's outward unit normal; nu^b = -nu^a)

on the overlap of the two parts. A rigid obstacle is analytic (no mesh): u^b = 0 and
g(x) is the distance (m) from the body's node x to the obstacle along nu^a, plus the pair's gap;
the linearised condition u^a . nu^a <= g(x) holds at every node of the body's part that can
reach the obstacle along nu^a (small displacements, like the rest of the model).

Force control (``force=(fx, fy)``, N/m; docs/formulation.md §12): the obstacle's translation t (m) is
an unknown with that prescribed resultant; the condition becomes u^a . nu^a <= g(x) - c(x) . t with
c = n / (-nu^a . n) (:meth:`Rigid.sensitivity`) and :func:`obstacle_rows` checks, before solving,
that compressive contact can balance the force.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from ..contact.interface import CONDITIONS, canonical_tangent
from ..contact.laws import ContactLaw, check_law
from ..errors import Frozen, SceneError

__all__ = ["Contact", "Rigid", "ObstacleRows", "obstacle_rows"]


def _point(value, label) -> np.ndarray:
    try:
        p = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{label}: expected two real numbers (m), got {value!r}") from None
    if p.shape != (2,) or not np.isfinite(p).all() or isinstance(value, (str, bytes)):
        raise SceneError(f"{label}: expected two finite real numbers, got {value!r}")
    p.setflags(write=False)
    return p


def _force(force, kind) -> np.ndarray | None:
    """The prescribed resultant of a force-controlled obstacle (N/m), or None (fixed obstacle)."""
    if force is None:
        return None
    F = _point(force, f"Rigid.{kind}: force")
    if not np.linalg.norm(F) > 0:
        raise SceneError(f"Rigid.{kind}(force=(0, 0)): a zero force holds the obstacle nowhere (its position is "
                         "undetermined); give a non-zero force (N/m) pressing it onto the bodies, or no force "
                         "(a fixed obstacle)")
    return F


class Rigid(Frozen):
    """A rigid obstacle: analytic (no mesh), fixed in space or, with ``force=(fx, fy)`` (N/m), free to
    translate under that prescribed resultant (force control, docs/formulation.md §12). Build with
    :meth:`plane`, :meth:`circle` or :meth:`profile`; ``Rigid(kind, distance, describe)`` takes any
    distance function (its sensitivity, if not given, by central differences).

    ``distance(points, normal)`` gives, for nodes ``points`` (n, 2) of a straight part with unit
    outward normal ``normal``, the distance (m) along ``normal`` to the obstacle's surface:
    negative for a node already inside the obstacle (an interference), ``+inf`` where the ray
    misses it (the node is then left free).

    An obstacle is immutable (assigning an attribute raises :class:`~cvxcontact.errors.FrozenError`).
    Its position and prescribed force are loads of a re-solve: :meth:`moved` gives the obstacle
    translated, :meth:`with_force` the same obstacle under another force, and
    :meth:`cvxcontact.Scene.with_obstacles` swaps them into a scene.
    """

    def __init__(self, kind: str, distance: Callable[[np.ndarray, np.ndarray], np.ndarray], describe: str,
                 sensitivity: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 force: Sequence[float] | None = None):
        if not callable(distance) or (sensitivity is not None and not callable(sensitivity)):
            raise SceneError(f"Rigid({kind!r}): distance (and sensitivity, if given) must be callables f(points, "
                             "normal)")

        def shape(p):                                        # the obstacle as given, translated by p (m)
            moved = bool(np.any(p != 0))
            dist = (lambda x, nu: distance(x - p, nu)) if moved else distance
            sens = sensitivity if sensitivity is None or not moved else (lambda x, nu: sensitivity(x - p, nu))
            return dist, sens, str(describe), (f".moved(to=({p[0]:.6g}, {p[1]:.6g}))" if moved else "")

        self._build(str(kind), shape, np.zeros(2), _force(force, str(kind)))

    def _build(self, kind, shape, position, force):
        """Set the fields: ``shape(position)`` gives (distance, sensitivity or None, description,
        suffix of the description) of the obstacle with its reference point at ``position`` (m)."""
        position = _point(position, f"Rigid.{kind}: position")
        distance, sensitivity, describe, suffix = shape(position)
        if force is not None:
            describe = describe[:-1] + f", force=({force[0]:.6g}, {force[1]:.6g}))"
        self._set(kind=kind, force=force, position=position, _shape=shape, _distance=distance,
                  _sensitivity=sensitivity, _describe=describe + suffix)

    @classmethod
    def _made(cls, kind, shape, position, force) -> "Rigid":
        out = object.__new__(cls)
        out._build(kind, shape, position, force)
        return out

    force: np.ndarray | None
    """The prescribed resultant (fx, fy) (N/m, read-only) of a force-controlled obstacle, or None (fixed)."""
    position: np.ndarray
    """(2,) m, read-only: the obstacle's reference point, the plane's ``point``, the circle's ``center``, the
    profile's ``origin`` (moved with it); (0, 0) for ``Rigid(kind, distance, describe)`` as given."""

    def _frozen_hint(self, name: str) -> str:
        if name == "force":
            return ("build the obstacle under another force with rigid.with_force((fx, fy)) (N/m; None: fixed) "
                    "and put it in the scene with scene.with_obstacles(...)")
        return ("build a moved obstacle with rigid.moved(by=(dx, dy)) or rigid.moved(to=(x, y)) (m), or a new one "
                "with Rigid.plane / circle / profile, and put it in the scene with scene.with_obstacles(...)")

    def moved(self, by: Sequence[float] | None = None, *, to: Sequence[float] | None = None) -> "Rigid":
        """The same obstacle (shape and prescribed force) translated by ``by`` = (dx, dy) (m), or with its
        reference point (:attr:`position`) at ``to`` = (x, y) (m); exactly one of the two. A profile moves with
        its origin along the contact line and, along the line's normal, by the normal component of the
        translation (its distances grow by ``by . nu``)."""
        if (by is None) == (to is None):
            raise SceneError(f"{self!r}.moved: give exactly one of by=(dx, dy) (a translation, m) or to=(x, y) "
                             "(the new reference point, m)")
        target = _point(to, "Rigid.moved: to") if by is None else self.position + _point(by, "Rigid.moved: by")
        return self._made(self.kind, self._shape, target, self.force)

    def with_force(self, force: Sequence[float] | None) -> "Rigid":
        """The same obstacle at the same place under the prescribed resultant ``force`` = (fx, fy) (N/m,
        pressing it onto the bodies), or fixed in space with ``force=None``."""
        return self._made(self.kind, self._shape, self.position, _force(force, self.kind))

    def __repr__(self):
        return f"Rigid.{self._describe}"

    def sensitivity(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """(n, 2): c(x) = n_o / (-nu . n_o) at each of ``points`` (dimensionless), n_o the obstacle's
        outward unit normal where the ray from x along ``normal`` nu meets it: a translation t (m) of
        the obstacle shortens the distance along nu by c(x) . t to first order (docs/formulation.md §12).
        Rows of nodes that miss the obstacle are 0."""
        points = np.array(points, dtype=float)
        points.setflags(write=False)
        normal = np.asarray(normal, dtype=float)
        if self._sensitivity is not None:
            return self._sensitivity(points, normal)
        # an obstacle given by its distance only: c = grad d by central differences (d_t(x) = d(x - t))
        h = 1e-7 * max(float(np.ptp(points)), float(np.abs(points).max(initial=0.0)), np.finfo(float).tiny)
        out = np.zeros_like(points)
        for k in range(2):
            step = np.zeros(2)
            step[k] = h
            with np.errstate(invalid="ignore"):
                out[:, k] = (self.distance(points + step, normal) - self.distance(points - step, normal)) / (2 * h)
        return np.where(np.isfinite(out), out, 0.0)

    def distance(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Distance (m) from each of ``points`` (n, 2) along the unit ``normal`` to the surface."""
        points = np.array(points, dtype=float)
        points.setflags(write=False)
        return self._distance(points, np.asarray(normal, dtype=float))

    @classmethod
    def plane(cls, point: Sequence[float], normal: Sequence[float], *, force: Sequence[float] | None = None) -> "Rigid":
        """The half-plane {z : (z - point) . n <= 0}; ``normal`` n points out of the obstacle,
        towards the body (normalised here). The body's part must face it: nu^a . n < 0. ``force``
        (N/m): force control; only its component along n, pressing the plane onto the body, can be
        balanced (frictionless), and only the translation along n is an unknown."""
        F = _force(force, "plane")
        p = _point(point, "Rigid.plane: point")
        n = _point(normal, "Rigid.plane: normal")
        if np.linalg.norm(n) == 0:
            raise SceneError("Rigid.plane: normal must not be zero")
        n = n / np.linalg.norm(n)
        n.setflags(write=False)
        return cls._made("plane", lambda p: _plane(p, n), p, F)

    @classmethod
    def circle(cls, center: Sequence[float], radius: float, *, force: Sequence[float] | None = None) -> "Rigid":
        """The disc of ``radius`` (m) around ``center`` (m): a cylinder in plane strain. Nodes whose
        normal ray misses the disc are left free. ``force`` (N/m): force control (an indenter under a
        prescribed load)."""
        F = _force(force, "circle")
        c = _point(center, "Rigid.circle: center")
        if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)) \
                or not np.isfinite(radius) or radius <= 0:
            raise SceneError(f"Rigid.circle: radius must be a positive finite number (m), got {radius!r}")
        R = float(radius)
        return cls._made("circle", lambda c: _circle(c, R), c, F)

    @classmethod
    def profile(cls, f: Callable[[np.ndarray], ArrayLike], origin: Sequence[float] = (0.0, 0.0), *,
                force: Sequence[float] | None = None) -> "Rigid":
        """An obstacle whose surface lies at distance ``f(s)`` (m) from the contact part along its
        outward normal, with s = (x - origin) . t (m) the tangential coordinate (t the pair's tangent,
        :func:`cvxcontact.contact.interface.canonical_tangent`: positive x1 component). ``f`` is a
        vectorised function returning finite values, or ``+inf`` where there is no obstacle. ``force``
        (N/m): force control; the sensitivity uses f'(s) by central differences."""
        F = _force(force, "profile")
        if not callable(f):
            raise SceneError(f"Rigid.profile: f must be a callable f(s) of the tangential coordinate (m), "
                             f"got {type(f).__name__}")
        o = _point(origin, "Rigid.profile: origin")
        return cls._made("profile", lambda q: _profile(f, o, q), o, F)


def _plane(p, n):
    """The half-plane {z : (z - p) . n <= 0} (``n`` its unit normal, out of the obstacle): (distance,
    sensitivity, description, suffix) as :meth:`Rigid._build` takes them."""

    def distance(x, nu):
        c = float(nu @ n)
        if c >= -1e-12:
            raise SceneError(f"Rigid.plane through ({p[0]:.6g}, {p[1]:.6g}) m with normal ({n[0]:.6g}, "
                             f"{n[1]:.6g}) does not face the contact part, whose outward normal is "
                             f"({nu[0]:.6g}, {nu[1]:.6g}); the plane's normal must point towards the body")
        return ((x - p) @ n) / (-c)

    def sensitivity(x, nu):
        return np.tile(n / (-float(nu @ n)), (len(x), 1))

    return distance, sensitivity, f"plane(point=({p[0]:.6g}, {p[1]:.6g}), normal=({n[0]:.6g}, {n[1]:.6g}))", ""


def _circle(c, R):
    """The disc of radius ``R`` (m) around ``c`` (m), as :func:`_plane`."""

    def distance(x, nu):
        w = x - c
        b = w @ nu
        disc = b * b - (np.einsum("ij,ij->i", w, w) - R * R)
        root = np.sqrt(np.maximum(disc, 0.0))
        hit = (disc >= 0) & (-b + root > 0)          # the ray enters the disc ahead or the node is inside
        return np.where(hit, -b - root, np.inf)

    def sensitivity(x, nu):
        d = distance(x, nu)
        hit = np.isfinite(d)
        q = x + np.where(hit, d, 0.0)[:, None] * nu                 # where the ray meets the circle
        n_o = (q - c) / R                                            # the disc's outward normal there
        den = -(n_o @ nu)
        ok = hit & (den > 1e-12)
        return np.where(ok[:, None], n_o / np.where(ok, den, 1.0)[:, None], 0.0)

    return distance, sensitivity, f"circle(center=({c[0]:.6g}, {c[1]:.6g}), radius={R:.6g})", ""


def _profile(f, o, q):
    """The profile ``f`` built with origin ``o`` and moved so that its origin is at ``q`` (m), as
    :func:`_plane`: s = (x - q) . t, and the distance f(s) grows by (q - o) . nu (the translation's normal
    component; a profile's distances are measured from the contact part)."""
    lift = q - o

    def distance(x, nu):
        s = (x - q) @ canonical_tangent(nu)
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
        return d + float(lift @ nu)

    def sensitivity(x, nu):
        t = canonical_tangent(nu)
        s = (x - q) @ t
        h = 1e-6 * max(float(np.ptp(s)), float(np.abs(s).max(initial=0.0)), np.finfo(float).tiny)
        d0, dp, dm = distance(x, nu), distance(x + h * t, nu), distance(x - h * t, nu)
        with np.errstate(invalid="ignore"):              # f'(s): central, one-sided at an end of f
            fp = np.where(np.isfinite(dp) & np.isfinite(dm), (dp - dm) / (2 * h),
                          np.where(np.isfinite(dp), (dp - d0) / h, (d0 - dm) / h))
        ok = np.isfinite(fp) & np.isfinite(d0)
        return np.where(ok[:, None], np.outer(np.where(ok, fp, 0.0), t) - nu, 0.0)

    name = getattr(f, "__name__", type(f).__name__)
    moved = f".moved(to=({q[0]:.6g}, {q[1]:.6g}))" if np.any(lift != 0) else ""
    return distance, sensitivity, f"profile({name}, origin=({o[0]:.6g}, {o[1]:.6g}))", moved


class Contact(Frozen):
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

    Notes
    -----
    A pair is immutable (assigning an attribute raises :class:`~cvxcontact.errors.FrozenError`); a scene
    with other gaps, obstacles or bodies is built by :meth:`cvxcontact.Scene.with_gap`,
    :meth:`~cvxcontact.Scene.with_obstacles` or :meth:`~cvxcontact.Scene.with_bodies`.
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
        part_a = self._part(body_a, part_a, "part_a")
        if isinstance(other, Rigid):
            if part_b is not None:
                raise SceneError(f"Contact: a rigid obstacle has no boundary parts; drop part_b={part_b!r}")
        else:
            part_b = self._part(other, part_b, "part_b")
        self._set(body_a=body_a, part_a=part_a, other=other, part_b=part_b, condition=condition, law=law,
                  _given_gap=gap)
        self._set(gap=Load(gap if not callable(gap) else (lambda x, y, g=gap: g(x)), f"{self}: gap", 1))

    def _frozen_hint(self, name: str) -> str:
        return ("build a new pair with contact.with_changes(...) or Contact(...), or a changed scene with "
                "scene.with_gap(g, pair=i), scene.with_obstacles(...) or scene.with_bodies(...)")

    def with_changes(self, **changes) -> "Contact":
        """A new pair: this one with some constructor arguments replaced (``body_a``, ``part_a``, ``other``,
        ``part_b``, ``condition``, ``gap`` (m), ``law``), validated afresh. A scene takes it through
        ``Scene(*bodies, contacts=[...])``; :meth:`cvxcontact.Scene.with_gap`, ``with_obstacles`` and
        ``with_bodies`` do the usual changes on a whole scene."""
        args = dict(body_a=self.body_a, part_a=self.part_a, other=self.other, part_b=self.part_b,
                    condition=self.condition, gap=self._given_gap, law=self.law)
        unknown = sorted(set(changes) - set(args))
        if unknown:
            raise SceneError(f"{self!r}: with_changes got unknown field(s) {unknown}; a Contact takes {sorted(args)}")
        args.update(changes)
        return Contact(args.pop("body_a"), args.pop("part_a"), args.pop("other"), args.pop("part_b"), **args)

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
        if part in body.traction:
            raise SceneError(f"Contact: {role} {part!r} of {body.name} is also a traction part: where it touches, "
                             "its stress vector is the contact pressure along the normal (no shear, frictionless), "
                             "so a prescribed traction there over-determines it (Gamma_2 and Gamma_3 are disjoint); "
                             "load another part, or split the part into a loaded and a contact segment")
        return part

    def __repr__(self):
        other = repr(self.other) if self.rigid else f"{self.other.name!r}, {self.part_b!r}"
        return f"Contact({self.body_a.name!r}, {self.part_a!r}, {other})"


@dataclass(frozen=True)
class ObstacleRows:
    """One rigid obstacle of a scene and how its translation t (m) enters the stacked contact rows.

    ``pairs`` are the indices (in ``scene.contacts``) of its pairs; ``rows`` (stack size, 2) the
    sensitivities c(x) of :meth:`Rigid.sensitivity` at the stacked merged nodes (0 on other pairs'
    rows): with t the condition at a node reads u . nu <= g(x) - c(x) . t (docs/formulation.md §12).
    ``force`` is the prescribed resultant (N/m) or None; for a force-controlled obstacle ``basis``
    (2, k) spans the translations the contact can see (k = 1 when every c(x) is parallel, e.g. a
    plane: its tangential translation changes nothing and is not an unknown; k = 2 otherwise), and
    the unknowns are t = basis @ tau.
    """

    obstacle: Rigid
    pairs: tuple
    rows: sp.csr_matrix
    force: np.ndarray | None
    basis: np.ndarray

    @property
    def reduced_rows(self) -> sp.csr_matrix:
        """(stack size, k): the rows on the unknowns tau (``rows @ basis``)."""
        return sp.csr_matrix(self.rows @ self.basis)


def obstacle_rows(scene) -> tuple[ObstacleRows, ...]:
    """The :class:`ObstacleRows` of every distinct rigid obstacle of ``scene`` (an obstacle shared by
    several pairs moves as one). For a force-controlled obstacle the prescribed force F must be
    balanced by compressive contact forces y >= 0 at its nodes, F = sum_a y_a c_a (the stationarity of
    the energy in t): SceneError, naming the free direction, if F lies outside the cone of the c_a
    (a force pulling the obstacle away from every body, or a plane's tangential force component,
    which frictionless contact cannot balance)."""
    from scipy.optimize import nnls

    stack = scene.stack
    out, seen = [], {}
    for i, (c, itf) in enumerate(zip(scene.contacts, scene.interfaces)):
        if c.rigid:
            seen.setdefault(id(c.other), (c.other, []))[1].append(i)
    for obstacle, pairs in seen.values():
        rows = np.zeros((stack.size, 2))
        for i in pairs:
            itf = scene.interfaces[i]
            rows[stack.offsets[i]:stack.offsets[i + 1]] = obstacle.sensitivity(itf.points, itf.normal)
        F = obstacle.force
        basis = np.eye(2)
        if F is not None:
            label = f"{obstacle!r} (pairs {pairs})"
            scale = float(np.linalg.norm(rows, axis=1).max(initial=0.0))
            _, sv, Vt = np.linalg.svd(rows, full_matrices=False)
            if not scale > 0:
                raise SceneError(f"{label}: no node of its pairs sees the obstacle move (its distance is finite at "
                                 "isolated nodes only), so no contact force can balance the prescribed force: give "
                                 "the obstacle a shape that faces the part around the nodes it reaches, or no force "
                                 "(a fixed obstacle)")
            if sv[1] <= 1e-9 * sv[0]:                       # every c(x) parallel: one direction only
                b = Vt[0] * np.sign(rows @ Vt[0])[np.argmax(np.abs(rows @ Vt[0]))]
                basis = b[:, None]
                side = np.array([-b[1], b[0]]) + 0.0
                b = b + 0.0
                if abs(F @ side) > 1e-9 * np.linalg.norm(F):
                    raise SceneError(
                        f"{label}: the force ({F[0]:.6g}, {F[1]:.6g}) N/m has a component {F @ side:.6g} N/m along "
                        f"({side[0]:.6g}, {side[1]:.6g}), which frictionless contact cannot balance: the obstacle "
                        f"is free to slide along ({side[0]:.6g}, {side[1]:.6g}); give a force along its normal "
                        f"({b[0]:.6g}, {b[1]:.6g}) only")
            y, res = nnls(rows.T / scale, F)
            if res > 1e-9 * np.linalg.norm(F):
                r = F - rows.T @ y / scale
                r = r / np.linalg.norm(r)
                raise SceneError(
                    f"{label}: the force ({F[0]:.6g}, {F[1]:.6g}) N/m pulls the obstacle away from the bodies "
                    f"(compressive contact forces cannot balance it): the obstacle is free to move along "
                    f"({r[0]:.6g}, {r[1]:.6g}); give a force pressing it onto the bodies")
        basis = np.array(basis)
        basis.setflags(write=False)
        out.append(ObstacleRows(obstacle, tuple(pairs), sp.csr_matrix(rows), F, basis))
    return tuple(out)
