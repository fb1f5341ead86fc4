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

The obstacles' analytic surfaces are in physics/surfaces.py, the posings (``distance=``: closest point or ray)
in physics/posings.py, the rows of their translations in the stacked contact condition and the force balance
check (:class:`ObstacleRows`, :func:`obstacle_rows`) in physics/obstacles.py.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..contact.interface import CONDITIONS
from ..contact.laws import ContactLaw, check_law
from ..errors import Frozen, SceneError, locked
from .obstacles import ObstacleRows, obstacle_rows, unit_direction
from .posings import POSINGS, central_derivatives, named_posing, posed_surface
from .surfaces import Ball, Cylinder, HeightField, Plane, Profile, fmt

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
    return locked(p)



def _force(force, kind, dim=2) -> np.ndarray | None:
    """The prescribed resultant of a force-controlled obstacle (N/m in 2D, N in 3D), or None (fixed)."""
    if force is None:
        return None
    F = _point(force, f"Rigid.{kind}: force", (dim,))
    if not np.linalg.norm(F) > 0:
        unit = "N/m" if dim == 2 else "N"
        raise SceneError(f"Rigid.{kind}(force={fmt(F)}): a zero force holds the obstacle nowhere (its position is "
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
            raise SceneError(f"Rigid.{kind}: guided axis {i} {fmt(g)} has length {np.linalg.norm(g):.6g}; give "
                             "unit axes (e.g. (0, 0, 1)), the directions along which the obstacle may translate")
    for i in range(len(G)):
        for j in range(i + 1, len(G)):
            if abs(G[i] @ G[j]) > 1e-9:
                raise SceneError(f"Rigid.{kind}: guided axes {i} {fmt(G[i])} and {j} {fmt(G[j])} are not "
                                 f"orthogonal (dot product {G[i] @ G[j]:.6g}); give orthogonal unit axes")
    return locked(G)


def _guided_force(F, G, kind):
    """SceneError if the prescribed force ``F`` has a component along a translation the guide ``G`` holds."""
    if F is None or G is None:
        return
    held = F - G.T @ (G @ F)
    if np.linalg.norm(held) > 1e-9 * np.linalg.norm(F):
        unit = "N/m" if len(F) == 2 else "N"
        axes = ", ".join(fmt(g) for g in G)
        raise SceneError(f"Rigid.{kind}(force={fmt(F)}, guided={axes}): the force has a component "
                         f"{np.linalg.norm(held):.6g} {unit} along {fmt(unit_direction(held))}, a direction the "
                         f"guide holds (the obstacle translates along {axes} only); give a force along the guided "
                         "axes")


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
            return dist, sens, None, None, str(describe), (f".moved(to={fmt(p)})" if moved else "")

        self._build(str(kind), shape, np.zeros(dim), _force(force, str(kind), dim), _guide(guided, str(kind), dim))

    def _build(self, kind, shape, position, force, guided=None):
        """Set the fields: ``shape(position)`` gives (distance, sensitivity or None, row direction or None (the
        part's normal), the distance's derivatives or None (:meth:`.Posing.derivatives`), description, suffix of
        the description) of the obstacle with its reference point at ``position`` (m); the
        obstacle's dimension is the length of ``position``; ``guided`` the checked axes (k, dim) or None."""
        position = _point(position, f"Rigid.{kind}: position", (2, 3))
        _guided_force(force, guided, kind)
        distance, sensitivity, direction, derivatives, describe, suffix = shape(position)
        if force is not None:
            describe = describe[:-1] + f", force={fmt(force)})"
        if guided is not None:
            describe = describe[:-1] + ", guided=" + (fmt(guided[0]) if len(guided) == 1 else
                                                      "(" + ", ".join(fmt(g) for g in guided) + ")") + ")"
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
        form for the constructors' obstacles under either posing (:meth:`.Posing.derivatives`); by central
        differences of :meth:`distance` for ``Rigid(kind, distance, describe)``. Points where g = +inf (no
        obstacle) have zero derivatives."""
        points, normal = self._check(points, normal)
        if self._derivatives is not None:
            return self._derivatives(points, normal)
        return central_derivatives(self._distance, points, normal)

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
            raise SceneError(f"{self!r}: the normal {fmt(normal)} must be a unit vector")
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
        n = locked(n / np.linalg.norm(n))
        posing = named_posing(distance, "plane")
        return cls._made("plane", lambda p: posed_surface(Plane(p, n), posing, POSINGS["ray"]), p, F,
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
        posing = named_posing(distance, "sphere")
        return cls._made("sphere", lambda c: posed_surface(Ball(c, R, "sphere"), posing, POSINGS["closest"]), c, F,
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
        a = locked(a / np.linalg.norm(a))
        posing = named_posing(distance, "cylinder")
        return cls._made("cylinder", lambda p: posed_surface(Cylinder(p, a, R), posing, POSINGS["closest"]), p, F,
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
        posing = named_posing(distance, "height_field")
        return cls._made("height_field", lambda q: posed_surface(HeightField(f, q), posing, POSINGS["closest"]), o, F,
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
        posing = named_posing(distance, "circle")
        return cls._made("circle", lambda c: posed_surface(Ball(c, R, "circle"), posing, POSINGS["closest"]), c, F,
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
        posing = named_posing(distance, "profile")
        return cls._made("profile", lambda q: posed_surface(Profile(f, o, q), posing, POSINGS["closest"]), o, F,
                         _guide(guided, "profile", 2))


def _radius(radius, kind):
    if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)) \
            or not np.isfinite(radius) or radius <= 0:
        raise SceneError(f"Rigid.{kind}: radius must be a positive finite number (m), got {radius!r}")
    return float(radius)


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
