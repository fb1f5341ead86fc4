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

In 3D (an obstacle built from 3-vectors: :meth:`Rigid.plane`, :meth:`Rigid.sphere`,
:meth:`Rigid.cylinder`, :meth:`Rigid.height_field`) the same holds with points, normals, translations
and the force (N) in R^3; ``Rigid.dim`` says which.

A guided obstacle (``guided=`` unit, orthogonal axes G, rows of a (k, d) array) translates along those
axes only, t = G^T tau, as on a linear guide; its other translations are held at zero (a symmetry plane of a
half or quarter model does this: the scene cannot know it). Only the guided part of c(x) then enters the
condition, c(x) G^T G, and the prescribed force must lie along the axes: the guide takes the contact
resultant's other components.
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


_WORDS = {2: "two", 3: "three"}


def _point(value, label, dims=(2,)) -> np.ndarray:
    """A read-only vector of one of the lengths ``dims`` (2 in the plane, 3 in space)."""
    want = " or ".join(_WORDS[d] for d in dims)
    try:
        p = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{label}: expected {want} real numbers (m), got {value!r}") from None
    if p.ndim != 1 or len(p) not in dims or not np.isfinite(p).all() or isinstance(value, (str, bytes)):
        raise SceneError(f"{label}: expected {want} finite real numbers, got {value!r}")
    p.setflags(write=False)
    return p


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


def _fmt(v) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"


def _direction(v) -> np.ndarray:
    """The unit vector of v with components below 1e-12 of it set to 0 (rounding, not a direction)."""
    v = np.asarray(v, dtype=float) / np.linalg.norm(v)
    return np.where(np.abs(v) < 1e-12, 0.0, v)


def _force(force, kind, dim=2) -> np.ndarray | None:
    """The prescribed resultant of a force-controlled obstacle (N/m in 2D, N in 3D), or None (fixed)."""
    if force is None:
        return None
    F = _point(force, f"Rigid.{kind}: force", (dim,))
    if not np.linalg.norm(F) > 0:
        unit = "N/m" if dim == 2 else "N"
        raise SceneError(f"Rigid.{kind}(force={_fmt(F)}): a zero force holds the obstacle nowhere (its position is "
                         f"undetermined); give a non-zero force ({unit}) pressing it onto the bodies, or no force "
                         "(a fixed obstacle)")
    return F


def _guide(guided, kind, dim) -> np.ndarray | None:
    """The guided axes (k, dim) of an obstacle (read-only; 1 <= k <= dim unit, orthogonal rows), or None."""
    if guided is None:
        return None
    want = (f"one unit axis ({_WORDS[dim]} real numbers) or a list of 1 to {dim} orthogonal unit axes, e.g. "
            f"guided={'(0, 0, 1)' if dim == 3 else '(0, 1)'}")
    try:
        G = np.array(guided, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"Rigid.{kind}: guided: expected {want}, got {guided!r}") from None
    if isinstance(guided, (str, bytes)) or G.ndim not in (1, 2) or G.shape[-1] != dim or G.size == 0 \
            or not np.isfinite(G).all():
        raise SceneError(f"Rigid.{kind}: guided: expected {want} for a {dim}D obstacle, got {guided!r}")
    G = np.atleast_2d(G)
    if len(G) > dim:
        raise SceneError(f"Rigid.{kind}: guided: {len(G)} axes in {dim}D; give 1 to {dim} orthogonal unit axes")
    for i, g in enumerate(G):
        if abs(np.linalg.norm(g) - 1) > 1e-9:
            raise SceneError(f"Rigid.{kind}: guided axis {i} {_fmt(g)} has length {np.linalg.norm(g):.6g}; give "
                             "unit axes (e.g. (0, 0, 1)), the directions along which the obstacle may translate")
    for i in range(len(G)):
        for j in range(i + 1, len(G)):
            if abs(G[i] @ G[j]) > 1e-9:
                raise SceneError(f"Rigid.{kind}: guided axes {i} {_fmt(G[i])} and {j} {_fmt(G[j])} are not "
                                 f"orthogonal (dot product {G[i] @ G[j]:.6g}); give orthogonal unit axes")
    G.setflags(write=False)
    return G


def _guided_force(F, G, kind):
    """SceneError if the prescribed force ``F`` has a component along a translation the guide ``G`` holds."""
    if F is None or G is None:
        return
    held = F - G.T @ (G @ F)
    if np.linalg.norm(held) > 1e-9 * np.linalg.norm(F):
        unit = "N/m" if len(F) == 2 else "N"
        axes = ", ".join(_fmt(g) for g in G)
        raise SceneError(f"Rigid.{kind}(force={_fmt(F)}, guided={axes}): the force has a component "
                         f"{np.linalg.norm(held):.6g} {unit} along {_fmt(_direction(held))}, a direction the guide "
                         f"holds (the obstacle translates along {axes} only); give a force along the guided axes")


class Rigid(Frozen):
    """A rigid obstacle: analytic (no mesh), fixed in space or force controlled.

    Build with :meth:`plane`, :meth:`circle` or :meth:`profile` in 2D, :meth:`plane`, :meth:`sphere`,
    :meth:`cylinder` or :meth:`height_field` in 3D; the constructor itself takes any distance function.
    Posing, force control and guides: docs/howto/obstacles.md; the rows: docs/formulation.md §12.

    Parameters
    ----------
    kind : str
        A short name of the shape (messages, figures).
    distance : callable, m
        ``distance(points, normal)``: for nodes (n, dim) of a part with unit outward normal, the distance along it
        to the surface (n,); negative inside the obstacle, ``+inf`` where the ray misses it (node left free).
    describe : str
        How messages name the obstacle.
    sensitivity : callable, optional
        ``sensitivity(points, normal)`` (n, dim): the distance's gradient c in the obstacle's translation
        (dimensionless); central differences if None.
    force : sequence of float, optional
        Prescribed resultant, N/m (N in 3D): force control, the translation an unknown; None: fixed.
    dim : {2, 3}
        The dimension of the scene.
    guided : axis or list of axes, optional
        Unit axes of the only translations allowed under force control (a linear guide).

    Notes
    -----
    An obstacle is immutable (assigning an attribute raises :class:`~cvxcontact.errors.FrozenError`).
    Its position and prescribed force are loads of a re-solve: :meth:`moved` gives the obstacle
    translated, :meth:`with_force` the same obstacle under another force, and
    :meth:`cvxcontact.Scene.with_obstacles` swaps them into a scene.
    """

    def __init__(self, kind: str, distance: Callable[[np.ndarray, np.ndarray], np.ndarray], describe: str,
                 sensitivity: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 force: Sequence[float] | None = None, *, dim: int = 2, guided: ArrayLike | None = None):
        if not callable(distance) or (sensitivity is not None and not callable(sensitivity)):
            raise SceneError(f"Rigid({kind!r}): distance (and sensitivity, if given) must be callables f(points, "
                             "normal)")
        if isinstance(dim, bool) or dim not in (2, 3):
            raise SceneError(f"Rigid({kind!r}): dim must be 2 or 3, got {dim!r}")

        def shape(p):                                        # the obstacle as given, translated by p (m)
            moved = bool(np.any(p != 0))
            dist = (lambda x, nu: distance(x - p, nu)) if moved else distance
            sens = sensitivity if sensitivity is None or not moved else (lambda x, nu: sensitivity(x - p, nu))
            return dist, sens, None, None, str(describe), (f".moved(to={_fmt(p)})" if moved else "")

        self._build(str(kind), shape, np.zeros(dim), _force(force, str(kind), dim), _guide(guided, str(kind), dim))

    def _build(self, kind, shape, position, force, guided=None):
        """Set the fields: ``shape(position)`` gives (distance, sensitivity or None, row direction or None (the
        part's normal), the distance's derivatives or None (:meth:`Posing.derivatives`), description, suffix of
        the description) of the obstacle with its reference point at ``position`` (m); the
        obstacle's dimension is the length of ``position``; ``guided`` the checked axes (k, dim) or None."""
        position = _point(position, f"Rigid.{kind}: position", (2, 3))
        _guided_force(force, guided, kind)
        distance, sensitivity, direction, derivatives, describe, suffix = shape(position)
        if force is not None:
            describe = describe[:-1] + f", force={_fmt(force)})"
        if guided is not None:
            describe = describe[:-1] + ", guided=" + (_fmt(guided[0]) if len(guided) == 1 else
                                                      "(" + ", ".join(_fmt(g) for g in guided) + ")") + ")"
        self._set(kind=kind, force=force, guided=guided, position=position, dim=len(position), _shape=shape,
                  _distance=distance, _sensitivity=sensitivity, _direction=direction, _derivatives=derivatives,
                  _describe=describe + suffix)

    @classmethod
    def _made(cls, kind, shape, position, force, guided=None) -> "Rigid":
        out = object.__new__(cls)
        out._build(kind, shape, position, force, guided)
        return out

    force: np.ndarray | None
    """The prescribed resultant (fx, fy) (N/m; (fx, fy, fz) N in 3D, read-only) of a force-controlled
    obstacle, or None (fixed)."""
    position: np.ndarray
    """The position (d components, m; read-only): the obstacle's reference point, the plane's ``point``, the circle's or sphere's
    ``center``, the cylinder's ``point``, the profile's or height field's ``origin`` (moved with it); zero
    for ``Rigid(kind, distance, describe)`` as given."""
    dim: int
    """2 (an obstacle of the (x1, x3) plane) or 3 (of space), the length of its points and force."""
    guided: np.ndarray | None
    """The axes (k, dim) (unit, orthogonal rows; read-only) along which a force-controlled obstacle translates,
    its other translations held; None: free to translate in every direction the contact sees."""

    def _frozen_hint(self, name: str) -> str:
        if name == "guided":
            return ("build the obstacle again with its constructor's guided=... (e.g. Rigid.sphere(center, radius, "
                    "force=..., guided=(0, 0, 1))) and put it in the scene with scene.with_obstacles(...)")
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
        d = (self.dim,)
        target = _point(to, "Rigid.moved: to", d) if by is None else self.position + _point(by, "Rigid.moved: by", d)
        return self._made(self.kind, self._shape, target, self.force, self.guided)

    def with_force(self, force: Sequence[float] | None) -> "Rigid":
        """The same obstacle at the same place (and on the same guide) under the prescribed resultant ``force``
        = (fx, fy) (N/m, pressing it onto the bodies), or fixed in space with ``force=None``."""
        return self._made(self.kind, self._shape, self.position, _force(force, self.kind, self.dim), self.guided)

    def __repr__(self):
        return f"Rigid.{self._describe}"

    def sensitivity(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """(n, dim): c(x) at each of ``points`` (dimensionless): a translation t (m) of the obstacle shortens
        the gap g(x) by c(x) . t to first order (docs/formulation.md §12): c = n_o, the obstacle's outward unit
        normal at the closest point of its surface (``distance="closest"``), or c = n_o / (-nu . n_o) with n_o
        where the ray from x along ``normal`` nu meets it (``distance="ray"``, a plane). Rows of nodes that miss
        the obstacle are 0. A guided obstacle under force control: the components along
        its axes G only, c G^T G (its translations t = G^T tau see no other)."""
        c = self._full_sensitivity(points, normal)
        if self.guided is not None and self.force is not None:
            c = c @ (self.guided.T @ self.guided)
        return c

    def _full_sensitivity(self, points, normal):
        points, normal = self._check(points, normal)
        if self._sensitivity is not None:
            return self._sensitivity(points, normal)
        # an obstacle given by its distance only: c = grad d by central differences (d_t(x) = d(x - t))
        h = 1e-7 * max(float(np.ptp(points)), float(np.abs(points).max(initial=0.0)), np.finfo(float).tiny)
        out = np.zeros_like(points)
        for k in range(self.dim):
            step = np.zeros(self.dim)
            step[k] = h
            with np.errstate(invalid="ignore"):
                out[:, k] = (self.distance(points + step, normal) - self.distance(points - step, normal)) / (2 * h)
        return np.where(np.isfinite(out), out, 0.0)

    def distance(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """The gap g (m) from each of ``points`` (n, dim) of a part with unit outward ``normal`` (dim,) to the
        surface: to its closest point (a curved obstacle's default, ``distance="closest"``), or along ``normal``
        (``distance="ray"``, a plane, an obstacle given by its distance function); negative inside the obstacle,
        +inf where there is none (the node is left free)."""
        points, normal = self._check(points, normal)
        return self._distance(points, normal)

    def distance_derivatives(self, points: np.ndarray, normal: np.ndarray) \
            -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(g (n,), grad (n, dim), hess (n, dim, dim)): the gap :meth:`distance` (m) at ``points`` of a part with
        unit outward ``normal`` and its gradient (dimensionless) and Hessian (1/m) along the part's plane (line in
        2D): the derivatives of g(x + v) in v . ``normal`` = 0, their components along the normal zero. In closed
        form for the constructors' obstacles under either posing (:meth:`Posing.derivatives`); by central
        differences of :meth:`distance` for ``Rigid(kind, distance, describe)``. Points where g = +inf (no
        obstacle) have zero derivatives."""
        points, normal = self._check(points, normal)
        if self._derivatives is not None:
            return self._derivatives(points, normal)
        return _central_derivatives(self._distance, points, normal)

    def direction(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """(n, dim): the unit direction d(x) along which the row at each of ``points`` measures the body's
        displacement, d . u <= g - c . t: towards the closest point of a curved obstacle's surface (``distance=
        "closest"``, the default), or the part's outward ``normal`` itself (``distance="ray"``, a plane, an
        obstacle given by its distance function)."""
        points, normal = self._check(points, normal)
        if self._direction is None:
            return np.tile(normal, (len(points), 1))
        return self._direction(points, normal)

    def _check(self, points, normal):
        """Read-only float copies of ``points`` (n, dim) and ``normal`` (dim,) (unit), or SceneError."""
        points = np.array(points, dtype=float)
        normal = np.array(normal, dtype=float)
        if points.ndim != 2 or points.shape[1] != self.dim or normal.shape != (self.dim,):
            raise SceneError(f"{self!r}: expected points (n, {self.dim}) and a normal ({self.dim},) (m), got "
                             f"shapes {points.shape} and {normal.shape}")
        if not (np.isfinite(points).all() and np.isfinite(normal).all()):
            raise SceneError(f"{self!r}: points and normal must be finite (no NaN or inf)")
        if abs(np.linalg.norm(normal) - 1) > 1e-9:
            raise SceneError(f"{self!r}: the normal {_fmt(normal)} must be a unit vector")
        points.setflags(write=False)
        normal.setflags(write=False)
        return points, normal

    @classmethod
    def plane(cls, point: Sequence[float], normal: Sequence[float], *, force: Sequence[float] | None = None,
              guided: ArrayLike | None = None, distance: str = "ray") -> "Rigid":
        """The half-plane (half-space in 3D) {z : (z - point) . n <= 0} (docs/howto/obstacles.md).

        Parameters
        ----------
        point : sequence of 2 or 3 floats, m
            A point of the boundary line (plane).
        normal : sequence of 2 or 3 floats
            Its normal n, out of the obstacle towards the body (normalised here); the part must face it.
        force : sequence of float, optional
            Prescribed resultant along n, N/m (N in 3D): force control, the translation an unknown; None: fixed.
        guided : axis or list of axes, optional
            Unit axes of the only translations allowed under force control (a linear guide).
        distance : {"closest", "ray"}
            Posing: rows towards the closest point, or along the part's normal ("ray" the default).

        Returns
        -------
        Rigid
        """
        p = _point(point, "Rigid.plane: point", (2, 3))
        n = _point(normal, "Rigid.plane: normal", (len(p),))
        F = _force(force, "plane", len(p))
        if np.linalg.norm(n) == 0:
            raise SceneError("Rigid.plane: normal must not be zero")
        n = n / np.linalg.norm(n)
        n.setflags(write=False)
        posing = _posing(distance, "plane")
        return cls._made("plane", lambda p: _posed(_Plane(p, n), posing, POSINGS["ray"]), p, F,
                         _guide(guided, "plane", len(p)))

    @classmethod
    def sphere(cls, center: Sequence[float], radius: float, *, force: Sequence[float] | None = None,
               guided: ArrayLike | None = None, distance: str = "closest") -> "Rigid":
        """The ball of ``radius`` around ``center``: a spherical indenter (docs/howto/obstacles.md).

        Parameters
        ----------
        center : sequence of 3 floats, m
            The centre (x, y, z).
        radius : float, m
            The radius R; the gap at a node x is |x - center| - R.
        force : sequence of float, optional
            Prescribed resultant (fx, fy, fz), N: force control, the translation an unknown; None: fixed.
        guided : axis or list of axes, optional
            Unit axes of the only translations allowed under force control (a linear guide).
        distance : {"closest", "ray"}
            Posing: rows towards the closest point, or along the part's normal ("closest" the default).

        Returns
        -------
        Rigid
        """
        c = _point(center, "Rigid.sphere: center", (3,))
        F = _force(force, "sphere", 3)
        R = _radius(radius, "sphere")
        posing = _posing(distance, "sphere")
        return cls._made("sphere", lambda c: _posed(_Ball(c, R, "sphere"), posing, POSINGS["closest"]), c, F,
                         _guide(guided, "sphere", 3))

    @classmethod
    def cylinder(cls, point: Sequence[float], axis: Sequence[float], radius: float, *,
                 force: Sequence[float] | None = None, guided: ArrayLike | None = None,
                 distance: str = "closest") -> "Rigid":
        """The infinite solid circular cylinder around a line: a roller in 3D (docs/howto/obstacles.md).

        Parameters
        ----------
        point : sequence of 3 floats, m
            A point of the axis.
        axis : sequence of 3 floats
            The axis' direction (normalised here).
        radius : float, m
            The radius R; the gap at a node is its distance from the axis minus R.
        force : sequence of float, optional
            Prescribed resultant (fx, fy, fz), N, none along the axis: force control; None: fixed.
        guided : axis or list of axes, optional
            Unit axes of the only translations allowed under force control (a linear guide).
        distance : {"closest", "ray"}
            Posing: rows towards the closest point, or along the part's normal ("closest" the default).

        Returns
        -------
        Rigid
        """
        p = _point(point, "Rigid.cylinder: point", (3,))
        a = _point(axis, "Rigid.cylinder: axis", (3,))
        F = _force(force, "cylinder", 3)
        R = _radius(radius, "cylinder")
        if np.linalg.norm(a) == 0:
            raise SceneError("Rigid.cylinder: axis must not be zero")
        a = a / np.linalg.norm(a)
        a.setflags(write=False)
        posing = _posing(distance, "cylinder")
        return cls._made("cylinder", lambda p: _posed(_Cylinder(p, a, R), posing, POSINGS["closest"]), p, F,
                         _guide(guided, "cylinder", 3))

    @classmethod
    def height_field(cls, f: Callable[[np.ndarray, np.ndarray], ArrayLike], origin: Sequence[float] = (0.0, 0.0, 0.0),
                     *, force: Sequence[float] | None = None, guided: ArrayLike | None = None,
                     distance: str = "closest") -> "Rigid":
        """The solid above the surface z = f(x - ox, y - oy) + oz: an indenter pressing down on a body below.

        Parameters
        ----------
        f : callable f(x, y) -> array, m
            Vectorised height of the underside over the origin; ``+inf`` where there is no obstacle.
        origin : sequence of 3 floats, m
            (ox, oy, oz); moving the obstacle moves it.
        force : sequence of float, optional
            Prescribed resultant (fx, fy, fz), N: force control, the translation an unknown; None: fixed.
        guided : axis or list of axes, optional
            Unit axes of the only translations allowed under force control (a linear guide).
        distance : {"closest", "ray"}
            Posing: rows towards the closest point, or along the part's normal ("closest" the default).

        Returns
        -------
        Rigid

        Notes
        -----
        The foot point and the ray's root: docs/howto/obstacles.md, "Each obstacle's surface".
        """
        if not callable(f):
            raise SceneError(f"Rigid.height_field: f must be a callable f(x, y) (m), got {type(f).__name__}")
        o = _point(origin, "Rigid.height_field: origin", (3,))
        F = _force(force, "height_field", 3)
        posing = _posing(distance, "height_field")
        return cls._made("height_field", lambda q: _posed(_HeightField(f, q), posing, POSINGS["closest"]), o, F,
                         _guide(guided, "height_field", 3))

    @classmethod
    def circle(cls, center: Sequence[float], radius: float, *, force: Sequence[float] | None = None,
               guided: ArrayLike | None = None, distance: str = "closest") -> "Rigid":
        """The disc of ``radius`` around ``center``: a cylinder in plane strain (docs/howto/obstacles.md).

        Parameters
        ----------
        center : sequence of 2 floats, m
            The centre.
        radius : float, m
            The radius R; the gap at a node x is |x - center| - R.
        force : sequence of float, optional
            Prescribed resultant (fx, fy), N/m: force control, the translation an unknown; None: fixed.
        guided : axis or list of axes, optional
            Unit axes of the only translations allowed under force control (a linear guide).
        distance : {"closest", "ray"}
            Posing: rows towards the closest point, or along the part's normal ("closest" the default).

        Returns
        -------
        Rigid
        """
        F = _force(force, "circle")
        c = _point(center, "Rigid.circle: center")
        if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)) \
                or not np.isfinite(radius) or radius <= 0:
            raise SceneError(f"Rigid.circle: radius must be a positive finite number (m), got {radius!r}")
        R = float(radius)
        posing = _posing(distance, "circle")
        return cls._made("circle", lambda c: _posed(_Ball(c, R, "circle"), posing, POSINGS["closest"]), c, F,
                         _guide(guided, "circle", 2))

    @classmethod
    def profile(cls, f: Callable[[np.ndarray], ArrayLike], origin: Sequence[float] = (0.0, 0.0), *,
                force: Sequence[float] | None = None, guided: ArrayLike | None = None,
                distance: str = "closest") -> "Rigid":
        """An obstacle whose surface lies at distance f(s) from the contact part along its outward normal.

        Parameters
        ----------
        f : callable f(s) -> array, m
            Vectorised distance at the tangential coordinate s = (x - origin) . t (m); ``+inf``: no obstacle.
        origin : sequence of 2 floats, m
            Where s = 0.
        force : sequence of float, optional
            Prescribed resultant (fx, fy), N/m: force control, the translation an unknown; None: fixed.
        guided : axis or list of axes, optional
            Unit axes of the only translations allowed under force control (a linear guide).
        distance : {"closest", "ray"}
            Posing: rows towards the closest point, or along the part's normal ("closest" the default).

        Returns
        -------
        Rigid

        Notes
        -----
        The tangent t and the foot point: docs/howto/obstacles.md, "Each obstacle's surface".
        """
        F = _force(force, "profile")
        if not callable(f):
            raise SceneError(f"Rigid.profile: f must be a callable f(s) of the tangential coordinate (m), "
                             f"got {type(f).__name__}")
        o = _point(origin, "Rigid.profile: origin")
        posing = _posing(distance, "profile")
        return cls._made("profile", lambda q: _posed(_Profile(f, o, q), posing, POSINGS["closest"]), o, F,
                         _guide(guided, "profile", 2))


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
        ``nu`` and its gradient (n, d) and Hessian (n, d, d) (1/m) along the part (:meth:`Rigid.
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
        hess g = d n_o(q(x)) / dx, the shape operator at the foot seen from x (:meth:`_Surface.closest_hessian`:
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
        nu) and hess g = -J^T (hess phi) J / (grad phi . nu), J = I + nu grad g^T (:meth:`_Surface.
        ray_derivatives`), projected on the part's plane."""

        def derivatives(x, nu):
            return _along_part(*surface.ray_derivatives(x, nu), nu)

        return derivatives


POSINGS = {p.name: p for p in (ClosestPoint(), Ray())}
"""The posings of :class:`Posing` by the name a constructor's ``distance=`` takes."""


def _posing(distance, kind) -> Posing:
    """The :class:`Posing` named ``distance`` (SceneError naming the choices otherwise)."""
    if isinstance(distance, Posing):
        return distance
    if not isinstance(distance, str) or distance not in POSINGS:
        raise SceneError(f"Rigid.{kind}: distance must be one of {sorted(POSINGS)} (how the rows measure the "
                         f"distance to the obstacle: 'closest', to the closest point of its surface, the default; "
                         f"'ray', along the body's normal), got {distance!r}")
    return POSINGS[distance]


def _posed(surface, posing, default):
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


def _implicit_ray(g, grad_phi, hess_phi, nu):
    """(g, grad g, hess g) of the ray distance g(x), x + g nu on the surface phi = 0, from phi's gradient (n, d)
    and Hessian (n, d, d) at the hit point (:meth:`Ray.derivatives`); zero derivatives where the ray misses or
    grazes."""
    a = grad_phi @ nu
    ok = np.isfinite(g) & (np.abs(a) > 1e-300)
    a = np.where(ok, a, 1.0)
    grad = -grad_phi / a[:, None]
    J = np.eye(len(nu))[None] + nu[None, :, None] * grad[:, None, :]
    hess = -np.einsum("nji,njk,nkl->nil", J, hess_phi, J) / a[:, None, None]
    return g, np.where(ok[:, None], grad, 0.0), np.where(ok[:, None, None], hess, 0.0)


def _central_derivatives(distance, points, normal):
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


class _Plane(_Surface):
    """The half-plane (half-space) {z : (z - p) . n <= 0} (``n`` its unit normal, out of the obstacle)."""

    def __init__(self, p, n):
        self.p, self.n = p, n
        self.describe = f"plane(point={_fmt(p)}, normal={_fmt(n)})"

    def _facing(self, nu):
        c = float(nu @ self.n)
        if c >= -1e-12:
            raise SceneError(f"Rigid.plane through {_fmt(self.p)} m with normal {_fmt(self.n)} does not face the "
                             f"contact part, whose outward normal is {_fmt(nu)}; the plane's normal must point "
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


class _Ball(_Surface):
    """The disc (2D) or ball (3D) of radius ``R`` (m) around ``c`` (m)."""

    def __init__(self, c, R, kind):
        self.c, self.R = c, R
        self.describe = f"{kind}(center={_fmt(c)}, radius={R:.6g})"

    def ray(self, x, nu):
        w = x - self.c
        return _quadratic_hit(np.ones(len(w)), w @ nu, np.einsum("ij,ij->i", w, w) - self.R * self.R)

    def outward(self, q):
        return (q - self.c) / self.R

    def closest(self, x, nu):
        w = x - self.c
        r = np.linalg.norm(w, axis=1)
        centre = r == 0                                     # at the centre: straight out along -nu
        n_o = np.where(centre[:, None], -nu, w / np.where(centre, 1.0, r)[:, None])
        return r - self.R, n_o

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


class _Cylinder(_Surface):
    """The solid cylinder of radius ``R`` (m) around the line through ``p`` along the unit ``axis``."""

    def __init__(self, p, axis, R):
        self.p, self.axis, self.R = p, axis, R
        self.describe = f"cylinder(point={_fmt(p)}, axis={_fmt(axis)}, radius={R:.6g})"

    def across(self, v):                                    # the components normal to the axis
        return v - np.multiply.outer(v @ self.axis, self.axis)

    def ray(self, x, nu):
        w, v = self.across(x - self.p), self.across(nu)
        a = np.full(len(w), float(v @ v))
        a = np.where(a > 1e-24, a, 0.0)                     # a ray along the axis misses
        return _quadratic_hit(a, w @ v, np.einsum("ij,ij->i", w, w) - self.R * self.R)

    def outward(self, q):
        return self.across(q - self.p) / self.R

    def closest(self, x, nu):
        w = self.across(x - self.p)
        r = np.linalg.norm(w, axis=1)
        v = -self.across(nu)                                # on the axis: out along -nu across the axis
        on_axis = r == 0
        n_o = w / np.where(on_axis, 1.0, r)[:, None]
        if on_axis.any():
            if np.linalg.norm(v) > 1e-12:
                n_o[on_axis] = v / np.linalg.norm(v)
            else:                                           # a part normal along the axis, on the axis: none
                r = np.where(on_axis, np.inf, r)
        return r - self.R, n_o

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
        raise SceneError(f"{label}: the closest point of the surface to the point with parameters {_fmt(p0[worst])} "
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


class _HeightField(_Surface):
    """The solid above z = f(x - o_x, y - o_y) + o_z (m)."""

    def __init__(self, f, o):
        self.f, self.o = f, o
        name = getattr(f, "__name__", type(f).__name__)
        self.describe = f"height_field({name}, origin={_fmt(o)})"

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
            raise SceneError(f"Rigid.height_field(origin={_fmt(self.o)}) lies above its surface, so it does not "
                             f"face a contact part whose outward normal is {_fmt(nu)}: the part must face up "
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
                raise SceneError(f"Rigid.height_field(origin={_fmt(self.o)}): Newton's method did not find where "
                                 f"the normal {_fmt(nu)} meets the surface in 50 steps; use a smoother f or a part "
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


class _Profile(_Surface):
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


def _radius(radius, kind):
    if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)) \
            or not np.isfinite(radius) or radius <= 0:
        raise SceneError(f"Rigid.{kind}: radius must be a positive finite number (m), got {radius!r}")
    return float(radius)


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
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(hit, (-b - root) / np.where(a > 0, a, 1.0), np.inf)


class Contact(Frozen):
    """A contact pair: a part of one body against a part of another body or against a rigid obstacle.

    Parameters
    ----------
    body_a : Body
        The first body of the pair (l = 1 of "sigma1").
    part_a : str
        A straight (planar in 3D) boundary part of body_a (any direction).
    other : Body or Rigid
        The second body, or a rigid obstacle.
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
        This pair's normal law: non-penetration (8) or normal compliance (7), stiffness in Pa/m^m
        (docs/formulation.md §10); None (default): the law given to ``solve``/``Model``.

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

    ``pairs`` are the indices (in ``scene.contacts``) of its pairs; ``rows`` (stack size, dim) the
    sensitivities c(x) of :meth:`Rigid.sensitivity` at the stacked merged nodes (0 on other pairs'
    rows): with t the condition at a node reads u . nu <= g(x) - c(x) . t (docs/formulation.md §12).
    ``force`` is the prescribed resultant (N/m; N in 3D) or None; for a force-controlled obstacle
    ``basis`` (dim, k) spans the translations the contact can see (k = 1 when every c(x) is parallel,
    e.g. a plane: its tangential translations change nothing and are not unknowns; k = 2 for a 3D
    cylinder, whose translations along its axis change nothing; k = dim otherwise; a guided obstacle's
    rows and basis lie along its axes), and the unknowns are t = basis @ tau.
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
        dim = obstacle.dim
        rows = np.zeros((stack.size, dim))
        for i in pairs:
            itf = scene.interfaces[i]
            rows[stack.offsets[i]:stack.offsets[i + 1]] = obstacle.sensitivity(itf.points, itf.normal)
        F = obstacle.force
        basis = np.eye(dim)
        if F is not None:
            label = f"{obstacle!r} (pairs {pairs})"
            scale = float(np.linalg.norm(rows, axis=1).max(initial=0.0))
            _, sv, Vt = np.linalg.svd(rows, full_matrices=False)
            if not scale > 0:
                if obstacle.guided is not None:
                    raise SceneError(f"{label}: a translation along its guided axes changes no distance to its "
                                     "pairs' nodes, so no contact force can balance the prescribed force: guide it "
                                     "along a direction that presses it onto the bodies (e.g. the contact's normal)")
                raise SceneError(f"{label}: no node of its pairs sees the obstacle move (its distance is finite at "
                                 "isolated nodes only), so no contact force can balance the prescribed force: give "
                                 "the obstacle a shape that faces the part around the nodes it reaches, or no force "
                                 "(a fixed obstacle)")
            unit = "N/m" if dim == 2 else "N"
            rank = int((sv > 1e-9 * sv[0]).sum())
            if rank < dim:                                  # translations the contact does not see
                basis = Vt[:rank].T * np.sign(rows @ Vt[:rank].T)[np.argmax(np.abs(rows @ Vt[:rank].T), axis=0),
                                                                    np.arange(rank)]
                off = F - basis @ (basis.T @ F)             # the force's part along the unseen translations
                if np.linalg.norm(off) > 1e-9 * np.linalg.norm(F):
                    side = _direction(off)
                    along = "its normal " + _fmt(basis[:, 0] + 0.0) if rank == 1 else \
                        "the directions " + ", ".join(_fmt(b + 0.0) for b in basis.T)
                    seen = int((np.abs(rows) > 0).any(axis=1).sum())
                    few = "" if obstacle.kind in ("plane", "cylinder") else (
                        f" (only {seen} node{'s' if seen != 1 else ''} of its pairs {'lie' if seen != 1 else 'lies'}"
                        f" within its reach, too few to hold it in {dim} directions: refine the mesh under it, "
                        f"cells well below its size, or guide it with guided=<the force's direction>)")
                    raise SceneError(
                        f"{label}: the force {_fmt(F)} {unit} has a component {np.linalg.norm(off):.6g} {unit} along "
                        f"{_fmt(side)}, which frictionless contact cannot balance: the obstacle is free to slide "
                        f"along {_fmt(side)}; give a force along {along} only{few}")
            y, res = nnls(rows.T / scale, F)
            if res > 1e-9 * np.linalg.norm(F):
                r = F - rows.T @ y / scale
                r = _direction(r)
                raise SceneError(
                    f"{label}: the force {_fmt(F)} {unit} pulls the obstacle away from the bodies "
                    f"(compressive contact forces cannot balance it): the obstacle is free to move along "
                    f"{_fmt(r)}; give a force pressing it onto the bodies")
        basis = np.array(basis)
        basis.setflags(write=False)
        out.append(ObstacleRows(obstacle, tuple(pairs), sp.csr_matrix(rows), F, basis))
    return tuple(out)
