"""The scene: bodies (physics/body.py) and the contact pairs between them or against rigid obstacles
(physics/pairs.py), checked together; the interface of each pair.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..contact.interface import Interface, Stack
from ..errors import Frozen, FrozenTuple, MeshError, SceneError
from .body import Body, Load, real_scalar
from .obstacles import obstacle_rows
from .pairs import Contact, Rigid

__all__ = ["Body", "Scene"]


def mesh_dim(body) -> int:
    """2 for a triangle mesh, 3 for a tetrahedral one."""
    return int(getattr(body.mesh, "dim", 2))


def pair_interface(bodies, parts=None, obstacle=None):
    """The contact geometry of one pair: a straight line in 2D (:class:`~cvxcontact.contact.interface.Interface`),
    a planar surface in 3D (:class:`~cvxcontact.contact.surface.SurfaceInterface`), or in 3D a curved part of one
    body against a planar part of the other (:class:`~cvxcontact.contact.surface.CurvedSurfaceInterface`)."""
    parts = tuple(b.contact for b in bodies) if parts is None else tuple(parts)
    if mesh_dim(bodies[0]) == 3:
        from ..contact.surface import CurvedSurfaceInterface, SurfaceInterface, is_planar
        if obstacle is None and len(bodies) == 2:
            tol = 1e-9 * max(b.mesh.size for b in bodies)
            flat = [is_planar(b, p, tol) for b, p in zip(bodies, parts)]
            if flat.count(False) == 1:
                return CurvedSurfaceInterface(tuple(bodies), parts, curved=flat.index(False))
        return SurfaceInterface(tuple(bodies), parts, obstacle=obstacle)
    return Interface(tuple(bodies), parts, obstacle=obstacle)


def _refuse_unheld(scene):
    """SceneError for a rigid motion of a body that no support holds and that no contact part of the body
    resists in either direction (u . nu = 0 along each of its parts: a motion tangential to them): whatever
    the partners and the loads, nothing determines it. What the contact resists in one direction only is
    decided with the loads, on the assembled problem (:func:`cvxcontact.fem.kernel.check_well_posed`). A pair with a
    friction law of its own (``Contact(..., law=cc.Tresca(g))``) resists every motion that moves its part, up to
    its capacity, which is decided with the loads too."""
    for b in scene.bodies:
        if not b.held_by_contact:
            continue
        if any(getattr(c.law, "friction", None) is not None for c in scene.contacts if b in (c.body_a, c.other)):
            continue
        parts = list(dict.fromkeys([c.part_a for c in scene.contacts if c.body_a is b]
                                   + [c.part_b for c in scene.contacts if c.other is b]))
        unheld = b.free_motions(contact=parts)
        if unheld:
            raise SceneError(f"{b.name}: nothing holds the rigid motion(s) {unheld}: add a clamped, roller or "
                             f"displacement support that stops it (contact is unilateral and holds only along "
                             f"the normal of the contact part(s) {parts}), or give one of its pairs a friction "
                             f"law of its own (Contact(..., law=cc.Tresca(g)); in a scene file the [[contact]]'s "
                             f"law: a solve's law= comes after the scene is built)")


class Scene(Frozen):
    """Bodies in frictionless contact: the paper's two bodies, or any bodies and contact pairs.

    ``Scene(body1, body2)`` is the paper's scene (the order is l = 1, 2: ``sigma1`` / ``sigma2``);
    ``Scene(*bodies, contacts=[...])`` any number of bodies and pairs, against bodies or rigid obstacles.
    The contact geometry is validated here; what a scene checks and keeps: docs/howto/pairs.md,
    "What a scene checks and keeps".

    Parameters
    ----------
    *bodies : Body
        The bodies; every body takes part in at least one pair.
    contacts : list of Contact, optional
        The contact pairs; None: the pair of the two bodies' ``contact`` parts.
    gap : float or callable g(s), m
        Initial normal gap of that pair (s the tangential coordinate, m); g < 0 is an interference.

    Attributes
    ----------
    bodies : tuple of Body
        The bodies, in order.
    contacts : tuple of Contact
        The pairs (the implicit one included).
    interfaces : tuple of Interface
        One validated contact geometry per pair (merged nodes, normals, rows).

    Notes
    -----
    A scene is immutable; :meth:`with_bodies`, :meth:`with_loads`, :meth:`with_gap` and
    :meth:`with_obstacles` make changed ones.
    """

    def __init__(self, *bodies: Body, contacts: Sequence[Contact] | None = None,
                 gap: float | Callable[[np.ndarray], ArrayLike] = 0.0) -> None:
        for k, b in enumerate(bodies, start=1):
            if not isinstance(b, Body):
                raise SceneError(f"Scene takes Body objects; argument {k} is {type(b).__name__}")
        for k, b in enumerate(bodies, start=1):
            b._label(k)
        dims = [mesh_dim(b) for b in bodies]
        if len(set(dims)) > 1:
            raise SceneError(f"the bodies of a scene share one dimension; got {', '.join(f'{b.name}: {d}D' for b, d in zip(bodies, dims))}")
        cells = [b.mesh.cell for b in bodies]
        if len(set(cells)) > 1:       # one space per scene (fem/space.py): triangles and quadrilaterals not mixed yet
            raise SceneError(f"the bodies of a scene share one cell type; got {', '.join(f'{b.name}: {c}' for b, c in zip(bodies, cells))}: "
                             "mesh every body with the same cells (e.g. cc.rectangle(..., cell='quad') for all)")
        self._set(bodies=self._tuple("bodies", bodies), _given_gap=gap)
        if contacts is None:
            if len(bodies) != 2:
                raise SceneError(f"Scene without contacts= takes exactly two bodies (each body's contact= part "
                                 f"touches the other's), got {len(bodies)}; for other scenes pass "
                                 "contacts=[cc.Contact(...), ...]")
            if bodies[0] is bodies[1]:
                raise SceneError("Scene needs two distinct bodies")
            for b in bodies:
                if b.contact is None:
                    raise SceneError(f"{b.name}: Scene(body1, body2) pairs the bodies' contact= parts and this body "
                                     "has none: give Body(..., contact=\"tag\"), or pass the pairs with "
                                     "Scene(..., contacts=[cc.Contact(...)])")
            pairs = (Contact(bodies[0], bodies[0].contact, bodies[1], bodies[1].contact),)
            self._set(_legacy=True, contacts=self._tuple("contacts", pairs))
        else:
            self._set(_legacy=False, contacts=self._tuple("contacts", self._check_contacts(contacts, gap)))
        members, interfaces = [], []
        for i, c in enumerate(self.contacts):
            a = self._index(c.body_a)
            b = None if c.rigid else self._index(c.other)
            members.append((a, b))
            try:
                if c.rigid:
                    itf = pair_interface((c.body_a,), (c.part_a,), obstacle=c.other)
                elif self._legacy:
                    itf = pair_interface(self.bodies)
                else:
                    itf = pair_interface((c.body_a, c.other), (c.part_a, c.part_b))
            except MeshError as exc:
                raise SceneError(str(exc)) from exc
            except SceneError as exc:
                if self._legacy:
                    raise
                raise SceneError(f"contacts[{i}] {c!r}: {exc}") from exc
            interfaces.append(itf)
        self._set(interfaces=self._tuple("interfaces", interfaces), interface=interfaces[0],
                  stack=Stack(interfaces, members), conditions=self._tuple("conditions", (c.condition for c in
                                                                                         self.contacts)),
                  gap=Load(gap if not callable(gap) else (lambda x, y, g=gap: g(x)), "scene: gap", 1))
        _refuse_unheld(self)
        self.gap_values()                                    # check it now: finite, right shape
        self._set(obstacles=self._tuple("obstacles", obstacle_rows(self)))   # force control checked here

    # ------------------------------------------------------------------ immutability and variants

    def _frozen_hint(self, name: str) -> str:
        hints = {"bodies": "build a new scene with scene.with_bodies(*bodies) (one body per body, in order)",
                 "gap": "build a new scene with scene.with_gap(g)",
                 "obstacles": "build a new scene with scene.with_obstacles(*obstacles) (e.g. rigid.moved(by=...))"}
        return hints.get(name, "build a new Scene (scene.with_bodies, with_loads, with_gap, with_obstacles make the "
                               "usual changes)")

    def _tuple(self, field, items):
        return FrozenTuple(items, f"Scene.{field}", self._frozen_hint(field))

    def _rebuilt(self, bodies, contacts, gap) -> "Scene":
        return Scene(*bodies, gap=gap) if self._legacy else Scene(*bodies, contacts=contacts)

    def with_bodies(self, *bodies: Body) -> "Scene":
        """A new scene with the same pairs (parts, gaps, conditions, laws, obstacles) on other bodies: one per
        body of this scene, in its order (e.g. ``body.with_loads(...)``; bodies with the same geometry keep a
        prepared ContactSolver valid)."""
        if len(bodies) != len(self.bodies):
            raise SceneError(f"with_bodies takes one body per body of the scene ({len(self.bodies)}, in order), "
                             f"got {len(bodies)}")
        for k, b in enumerate(bodies, start=1):
            if not isinstance(b, Body):
                raise SceneError(f"with_bodies takes Body objects; argument {k} is {type(b).__name__}")
        swap = {id(old): new for old, new in zip(self.bodies, bodies)}
        contacts = [c.with_changes(body_a=swap[id(c.body_a)], other=c.other if c.rigid else swap[id(c.other)])
                    for c in self.contacts]
        return self._rebuilt(bodies, contacts, self._given_gap)

    def with_loads(self, body: int | Body, **loads) -> "Scene":
        """A new scene in which ``body`` (its index in ``bodies`` or the Body itself) has other loads:
        ``scene.with_loads(0, body_force=(0.0, -2e9))`` is ``scene.with_bodies(b0.with_loads(...), b1, ...)``
        (units and fields: :meth:`Body.with_loads`)."""
        k = body if isinstance(body, (int, np.integer)) and not isinstance(body, bool) else None
        if k is None:
            k = self._index(body) if isinstance(body, Body) else None
        if k is None or not 0 <= k < len(self.bodies):
            raise SceneError(f"with_loads: body must be a Body of the scene or its index 0..{len(self.bodies) - 1}, "
                             f"got {body!r}")
        return self.with_bodies(*(b.with_loads(**loads) if i == k else b for i, b in enumerate(self.bodies)))

    def with_gap(self, gap: float | Callable[[np.ndarray], ArrayLike], pair: int | None = None) -> "Scene":
        """A new scene with another initial gap g (m; a number or a vectorised callable g(s) of the tangential
        coordinate s, m): the scene's gap for ``Scene(body1, body2)``, pair ``pair``'s gap (an index into
        ``contacts``; optional when there is one pair) for a scene with ``contacts=``."""
        if self._legacy:
            if pair not in (None, 0):
                raise SceneError(f"with_gap: this scene has one pair (pair 0), got pair={pair!r}")
            return Scene(*self.bodies, gap=gap)
        if pair is None and len(self.contacts) == 1:
            pair = 0
        if isinstance(pair, bool) or not isinstance(pair, (int, np.integer)) or not 0 <= pair < len(self.contacts):
            raise SceneError(f"with_gap: name the pair whose gap changes, pair = 0..{len(self.contacts) - 1} (the "
                             f"index into scene.contacts), got pair={pair!r}")
        contacts = [c.with_changes(gap=gap) if i == pair else c for i, c in enumerate(self.contacts)]
        return Scene(*self.bodies, contacts=contacts)

    def with_obstacles(self, *obstacles: Rigid) -> "Scene":
        """A new scene with other rigid obstacles: one per entry of ``obstacles`` (the scene's distinct
        obstacles, in that order), each taking the place of the old one in every pair against it, e.g.
        ``scene.with_obstacles(scene.obstacles[0].obstacle.moved(by=(0.11, 0.0)))``
        (:meth:`Rigid.moved`, :meth:`Rigid.with_force`)."""
        old = [o.obstacle for o in self.obstacles]
        if len(obstacles) != len(old):
            raise SceneError(f"with_obstacles takes one obstacle per rigid obstacle of the scene ({len(old)}: "
                             f"{old!r}, in order), got {len(obstacles)}")
        for k, o in enumerate(obstacles, start=1):
            if not isinstance(o, Rigid):
                raise SceneError(f"with_obstacles takes Rigid obstacles; argument {k} is {type(o).__name__}")
        swap = {id(a): b for a, b in zip(old, obstacles)}
        contacts = [c.with_changes(other=swap[id(c.other)]) if c.rigid else c for c in self.contacts]
        return Scene(*self.bodies, contacts=contacts)

    def _index(self, body) -> int:
        for k, b in enumerate(self.bodies):
            if b is body:
                return k
        same = " (another Body object of the same name)" if any(b.name == body.name for b in self.bodies) else ""
        raise SceneError(f"contact pair names {body.name}{same}, which is not one of the scene's bodies "
                         f"{[b.name for b in self.bodies]}: pass the Body objects given to Scene")

    def _check_contacts(self, contacts, gap):
        if isinstance(contacts, Contact) or not isinstance(contacts, (list, tuple)):
            raise SceneError(f"contacts must be a list of cc.Contact, got {type(contacts).__name__}")
        if not contacts:
            raise SceneError("contacts is empty; a scene needs at least one contact pair")
        for i, c in enumerate(contacts):
            if not isinstance(c, Contact):
                raise SceneError(f"contacts[{i}] must be a cc.Contact, got {type(c).__name__}")
        if callable(gap) or (real_scalar(gap) and gap != 0):
            raise SceneError("with contacts=, give each Contact its own gap (Contact(..., gap=g)); "
                             "Scene(gap=) is for the two-body scene without contacts")
        seen = set()
        for k, b in enumerate(self.bodies):
            if any(b is a for a in self.bodies[:k]):
                raise SceneError(f"{b.name} is given twice to Scene")
        for i, c in enumerate(contacts):
            self._index(c.body_a)
            if not c.rigid:
                self._index(c.other)
            key = frozenset([(id(c.body_a), c.part_a), (id(c.other), c.part_b)])
            if key in seen:
                raise SceneError(f"contacts[{i}] {c!r} repeats an earlier pair")
            seen.add(key)
        used = {id(c.body_a) for c in contacts} | {id(c.other) for c in contacts}
        for b in self.bodies:
            if id(b) not in used:
                raise SceneError(f"{b.name} takes part in no contact pair; remove it or add a Contact for it")
        return tuple(contacts)

    def pair_gap_values(self, i: int, s: np.ndarray | None = None) -> np.ndarray:
        """The gap g (m) at the merged nodes of pair ``i``: the pair's gap plus, for a rigid
        obstacle, the distance to it along the body's normal. ``s``: other points of the pair's line
        instead, given by their tangential coordinate (m; e.g. the P2 nodes of the merged mesh; with a rigid
        obstacle, points of the body's straight part between its nodes that reach it)."""
        itf = self.interfaces[i]
        load = self.gap if self._legacy else self.contacts[i].gap
        if getattr(itf, "dim", 2) == 3:
            return self._surface_gap(i, itf, s)
        if s is not None:
            s = np.asarray(s, dtype=float)
            g = np.array(load(s, np.full_like(s, itf.y)), dtype=float)
            if itf.rigid:
                points = itf.points[0] + np.outer(s - itf.x[0], itf.tangent)
                g = g + np.asarray(itf.obstacle.distance(points, itf.normal), dtype=float)
                bad = np.flatnonzero(~np.isfinite(g))
                if len(bad):
                    x, y = points[bad[0]]
                    raise SceneError(f"contact pair {i}: the rigid obstacle is not under the point ({x:.6g}, {y:.6g}) m "
                                     f"of the contact line (distance {g[bad[0]]}), which lies between nodes that reach "
                                     "it (e.g. a P2 edge midpoint over a hole of the profile): the gap there is "
                                     "needed; refine the mesh there, or give the profile a finite value")
            return g
        g = np.array(load(itf.x, np.full_like(itf.x, itf.y)), dtype=float)
        return g + itf.obstacle_gap() if itf.rigid else g

    def pair_gap_derivatives(self, i: int, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(g (k,), grad (k, m), hess (k, m, m)): :meth:`pair_gap_values` of rigid pair ``i`` at the points ``s``
        of its line or plane (tangential coordinates (k,) in 2D, in-plane (k, 2) in 3D, m) and its derivatives in
        those coordinates (m = 1 or 2): the obstacle's distance in closed form (:meth:`~cvxcontact.physics.pairs.
        Rigid.distance_derivatives`), the pair's own gap g(s) by central differences (none taken for a
        constant one). The curvature of the true gap along a P2 face (docs/formulation.md §8, §18)."""
        itf = self.interfaces[i]
        three = getattr(itf, "dim", 2) == 3
        s = np.asarray(s, dtype=float)
        S = s if three else s[:, None]
        if three:
            frame = np.asarray(itf.frame, dtype=float)                        # (2, 3) in-plane axes
            points = itf.offset * itf.normal + S @ frame
            given = self._given_gap if self._legacy else self.contacts[i]._given_gap
            f = Load(given, f"contacts[{i}]: gap g(s1, s2)", 1)
            load = lambda S: np.array(f(S[:, 0], S[:, 1]), dtype=float)       # noqa: E731
        else:
            frame = np.asarray(itf.tangent, dtype=float)[None, :]
            points = itf.points[0] + np.outer(S[:, 0] - itf.x[0], itf.tangent)
            f = self.gap if self._legacy else self.contacts[i].gap
            load = lambda S: np.array(f(S[:, 0], np.full(len(S), itf.y)), dtype=float)    # noqa: E731
        g, grad, hess = itf.obstacle.distance_derivatives(points, np.asarray(itf.normal, dtype=float))
        grad, hess = grad @ frame.T, np.einsum("ai,nij,bj->nab", frame, hess, frame)
        if not callable(f.value):                  # a constant gap: no derivatives, no differences to take
            return g + float(f.value), grad, hess
        m = S.shape[1]
        # the step from the pair's own extent (m), not the points': each point's derivatives then do not depend on
        # the others given (one point at the origin gave h = 0)
        span = np.asarray(itf.x, dtype=float)
        h = 1e-4 * max(float(np.ptp(span)), float(np.abs(span).max(initial=0.0)), np.finfo(float).tiny)
        g0 = load(S)
        E = np.eye(m) * h
        for a in range(m):
            grad[:, a] += (load(S + E[a]) - load(S - E[a])) / (2 * h)
            hess[:, a, a] += (load(S + E[a]) + load(S - E[a]) - 2 * g0) / h ** 2
            for b in range(a):
                c = (load(S + E[a] + E[b]) - load(S + E[a] - E[b]) - load(S - E[a] + E[b])
                     + load(S - E[a] - E[b])) / (4 * h * h)
                hess[:, a, b] += c
                hess[:, b, a] += c
        return g + g0, grad, hess

    def _surface_gap(self, i, itf, s):
        """3D: the gap (m) at the overlay vertices of pair ``i`` (or at in-plane points ``s`` (k, 2), m): the
        pair's gap g(s1, s2) of the in-plane coordinates (s1, s2) of the pair's frame, plus the distance to a
        rigid obstacle along the body's normal, or from a curved part's nodes to the plane of its partner."""
        given = self._given_gap if self._legacy else self.contacts[i]._given_gap
        load = Load(given, f"contacts[{i}]: gap g(s1, s2)", 1)
        s = itf.x if s is None else np.asarray(s, dtype=float)
        g = np.array(load(s[:, 0], s[:, 1]), dtype=float)
        if s is itf.x:                               # the distance to an obstacle, or from a curved part's nodes
            g = g + itf.obstacle_gap()               # to the plane (0 between two planar parts)
        elif itf.rigid:                              # other in-plane points: their distance to the obstacle
            points = itf.offset * itf.normal + s @ itf.frame
            g = g + np.asarray(itf.obstacle.distance(points, itf.normal), dtype=float)
        return g

    def gap_values(self) -> np.ndarray:
        """The gap g (m) at the stacked merged nodes of every pair (``stack``)."""
        return np.concatenate([self.pair_gap_values(i) for i in range(len(self.interfaces))])

    def structure(self) -> tuple:
        """What a prepared solver depends on beyond the bodies: each pair's members, parts, condition,
        merged-node count, own law and whether its obstacle is force controlled (the gaps, obstacle
        positions and prescribed forces are loads)."""
        return tuple((m, c.part_a, c.part_b, c.condition, itf.size, c.other.kind if c.rigid else None,
                      getattr(c, "law", None), c.rigid and c.other.force is not None)
                     for m, c, itf in zip(self.stack.members, self.contacts, self.interfaces))

    def __repr__(self):
        if self._legacy:
            return f"Scene({self.bodies[0]!r}, {self.bodies[1]!r})"
        return f"Scene({', '.join(repr(b) for b in self.bodies)}, contacts={list(self.contacts)!r})"

    @property
    def dim(self) -> int:
        """2 (triangle meshes, plane strain or stress) or 3 (tetrahedral meshes)."""
        return mesh_dim(self.bodies[0])

    @property
    def cell(self) -> str:
        """The cell type of the bodies' meshes ("triangle", "quad", "tetra"; the key of the spaces with the
        degree, :func:`cvxcontact.fem.space.space`)."""
        return self.bodies[0].mesh.cell

    @property
    def length(self) -> float:
        """Reference length L0 (m): the bounding-box diagonal of the whole scene."""
        low = np.min([b.mesh.bounds[0] for b in self.bodies], axis=0)
        high = np.max([b.mesh.bounds[1] for b in self.bodies], axis=0)
        return float(np.linalg.norm(high - low))
