"""Bodies (mesh + material + boundary parts + loads) and the two-body scene.

Boundary parts follow the paper: Gamma_1 ``clamped`` (u = 0), Gamma_2 ``traction``
(sigma nu = f2), Gamma_3 ``contact``, Gamma_a ``grounded`` (phi = 0) and, beyond the
paper, ``potential`` electrodes (phi = V), Gamma_b ``surface_charge`` (D nu = q2). Loads are constants or vectorised callables of
(x, y) in metres; they are checked for shape and finiteness where they are used.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError, SceneError
from ..contact.interface import Interface, Stack
from ..geometry.mesh import Mesh
from .materials import Elastic, Piezoelectric
from .pairs import Contact

__all__ = ["Body", "Scene"]


class Body:
    """One body of the scene.

    Parameters
    ----------
    mesh : Mesh
    material : Piezoelectric or Elastic
    clamped : str or list of str
        Tags of Gamma_1, where u = 0. Must not be empty: a body free to move rigidly
        has a singular stiffness.
    grounded : str or list of str
        Tags of Gamma_a, where phi = 0 (piezoelectric bodies only).
    potential : dict tag -> float or callable, V
        Driven electrodes, phi = V (part of Gamma_a). A piezoelectric body needs
        at least one grounded or driven electrode.
    contact : str
        Tag of Gamma_3, a straight segment parallel to the x1-axis.
    body_force : (2,) or callable f(x, y) -> (fx, fy), N/m^3
    traction : dict tag -> (2,) or callable, N/m^2 (surface traction f2, eq. sigma nu = f2)
    surface_charge : dict tag -> float or callable, C/m^2 (q2 in D nu = q2)
    volume_charge : float or callable, C/m^3 (q0 in div D = q0)
    name : str, optional
    """

    def __init__(self, mesh: Mesh, material: Piezoelectric | Elastic, *, clamped: str | Sequence[str],
                 contact: str, grounded: str | Sequence[str] = (),
                 potential: Mapping[str, float | Callable[..., ArrayLike]] | None = None,
                 body_force: Sequence[float] | Callable[..., ArrayLike] = (0.0, 0.0),
                 traction: Mapping[str, Sequence[float] | Callable[..., ArrayLike]] | None = None,
                 surface_charge: Mapping[str, float | Callable[..., ArrayLike]] | None = None,
                 volume_charge: float | Callable[..., ArrayLike] = 0.0, name: str | None = None) -> None:
        if not isinstance(mesh, Mesh):
            raise SceneError(f"mesh must be a cvxcontact.Mesh, got {type(mesh).__name__}")
        if not isinstance(material, (Piezoelectric, Elastic)):
            raise SceneError(f"material must be a Piezoelectric or Elastic material, got {type(material).__name__}")
        self.mesh, self.material = mesh, material
        self.name = name or "body"
        self.clamped = self._tags(clamped, "clamped")
        self.grounded = self._tags(grounded, "grounded")
        if not isinstance(contact, str):
            raise SceneError(f"{self.name}: contact must be one boundary tag (a string), got {contact!r}")
        self.contact = self._tags(contact, "contact")[0]
        self.body_force = Load(body_force, f"{self.name}: body_force", 2)
        self.traction = {t: Load(v, f"{self.name}: traction[{t!r}]", 2)
                         for t, v in self._parts(traction, "traction").items()}
        self.surface_charge = {t: Load(v, f"{self.name}: surface_charge[{t!r}]", 1)
                               for t, v in self._parts(surface_charge, "surface_charge").items()}
        self.volume_charge = Load(volume_charge, f"{self.name}: volume_charge", 1)
        self.potential = {t: Load(v, f"{self.name}: potential[{t!r}]", 1)
                          for t, v in self._parts(potential, "potential").items()}
        self._check_parts()

    def __repr__(self):
        return f"Body({self.name!r}, {self.mesh!r}, {self.material!r})"

    @property
    def piezoelectric(self) -> bool:
        """True if the body carries electric unknowns."""
        return self.material.piezoelectric

    def _tags(self, tags, role):
        tags = [tags] if isinstance(tags, str) else list(tags)
        for t in tags:
            if not isinstance(t, str) or t not in self.mesh.tags:
                raise SceneError(f"{self.name}: {role} names unknown boundary tag {t!r}; "
                                 f"the mesh has {sorted(self.mesh.tags)}")
        return tags

    def _parts(self, loads, role):
        if loads is None:
            return {}
        if not isinstance(loads, Mapping):
            raise SceneError(f"{self.name}: {role} must be a dict mapping boundary tags to loads, got {loads!r}")
        self._tags(list(loads), role)
        return dict(loads)

    def _check_parts(self):
        mechanical = [("clamped", t) for t in self.clamped] + [("traction", t) for t in self.traction]
        mechanical.append(("contact", self.contact))
        _disjoint(self, mechanical)
        if not self.clamped:
            raise SceneError(f"{self.name}: no clamped boundary (Gamma_1 is empty); the body could move "
                             "rigidly and its stiffness is singular")
        self._check_components(self.clamped, "touches no clamped part: nothing holds it (contact is "
                               "unilateral) and its position is undetermined")
        contact_nodes = self.mesh.boundary_nodes([self.contact])
        if np.isin(contact_nodes, self.mesh.boundary_nodes(self.clamped)).all():
            raise SceneError(f"{self.name}: every node of the contact part {self.contact!r} is clamped; "
                             "the body cannot take part in the contact")
        if self.piezoelectric:
            if not (self.grounded or self.potential):
                raise SceneError(f"{self.name}: piezoelectric body without a grounded or driven electrode "
                                 "(Gamma_a is empty); its potential is undetermined")
            self._check_components(self.grounded + list(self.potential),
                                   "touches no grounded or driven electrode: its potential is undetermined")
            _disjoint(self, [("grounded", t) for t in self.grounded] + [("potential", t) for t in self.potential]
                      + [("surface_charge", t) for t in self.surface_charge])
        else:
            electric = self.grounded or self.potential or self.surface_charge or self.volume_charge.nonzero
            if electric:
                raise SceneError(f"{self.name}: elastic material {self.material.name!r} carries no electric "
                                 "unknowns; remove grounded / potential / surface_charge / volume_charge")

    def _check_components(self, tags, problem):
        """Every connected piece of the mesh (``Mesh.components``) has an edge on one of ``tags``."""
        mesh = self.mesh
        count = int(mesh.components.max()) + 1
        if count == 1:
            return
        touched = np.zeros(count, dtype=bool)
        touched[mesh.node_components[mesh.boundary_nodes(tags)]] = True
        if touched.all():
            return
        c = int(np.argmin(touched))
        inside = mesh.components == c
        area = mesh.areas[inside]
        centroid = (mesh.points[mesh.triangles[inside]].mean(axis=1) * area[:, None]).sum(axis=0) / area.sum()
        raise SceneError(f"{self.name}: mesh component {c} ({int(inside.sum())} triangles, centroid at "
                         f"({centroid[0]:.4g}, {centroid[1]:.4g}) m) {problem}; expected every one of the "
                         f"{count} separate pieces of the mesh to touch one of {tags}")


def _disjoint(body, roles):
    seen = {}
    for role, tag in roles:
        if tag in seen:
            raise SceneError(f"{body.name}: boundary tag {tag!r} is both {seen[tag]} and {role}")
        seen[tag] = role


class Load:
    """A constant or a vectorised callable of (x, y), evaluated and checked on demand.

    Constants must be real numbers (booleans and complex numbers are refused). A
    callable receives read-only copies of the coordinates (m) and its result is
    copied, so no load can write into the meshes or the contact interface.
    """

    def __init__(self, value, label, ncomp):
        self.label, self.ncomp = label, ncomp
        if callable(value):
            self.value = value
            return
        expected = "a number" if ncomp == 1 else f"a sequence of {ncomp} numbers"
        if not _real_numbers(value):
            raise SceneError(f"{label}: expected {expected} (real, not boolean or complex) or a callable f(x, y), "
                             f"got {_kind(value)}")
        v = np.array(value, dtype=float)
        shape = () if ncomp == 1 else (ncomp,)
        if v.shape != shape:
            raise SceneError(f"{label}: expected {'a scalar' if ncomp == 1 else f'{ncomp} components'}, "
                             f"got shape {v.shape}")
        if not np.isfinite(v).all():
            raise SceneError(f"{label}: NaN or infinite value {v.tolist()}")
        v.setflags(write=False)
        self.value = v

    @property
    def nonzero(self) -> bool:
        return callable(self.value) or bool(np.any(self.value != 0))

    def __call__(self, x, y) -> np.ndarray:
        """Values at points (x, y) in metres: shape (k,) for scalars, (k, 2) for vectors."""
        x, y = _frozen(x), _frozen(y)
        v = self.value
        if not callable(v):
            return np.broadcast_to(v, x.shape + v.shape)
        try:
            out = v(x, y)
            comps = [np.array(c) for c in ([out] if self.ncomp == 1 else out)]   # copies, never views
        except Exception as exc:
            raise SceneError(f"{self.label}: calling the load function failed: {exc}") from exc
        if len(comps) != self.ncomp:
            raise SceneError(f"{self.label}: the load function returned {len(comps)} components, "
                             f"expected {self.ncomp}")
        bad = [c.dtype for c in comps if c.dtype.kind not in "iuf"]
        if bad:
            raise SceneError(f"{self.label}: the load function returned values of type {bad[0]}, "
                             "expected real numbers (not boolean, complex or objects)")
        try:
            out = comps[0].astype(float) if self.ncomp == 1 else np.stack(
                [np.broadcast_to(c.astype(float), x.shape) for c in comps], axis=-1)
        except ValueError:
            raise SceneError(f"{self.label}: the load function returned components of shapes "
                             f"{[c.shape for c in comps]}, expected {x.shape} each") from None
        want = x.shape + (() if self.ncomp == 1 else (self.ncomp,))
        try:
            out = np.broadcast_to(out, want)
        except ValueError:
            raise SceneError(f"{self.label}: the load function returned shape {out.shape}, "
                             f"expected {want}") from None
        if not np.isfinite(out).all():
            raise SceneError(f"{self.label}: the load function returned NaN or infinite values")
        return out


def _real_numbers(value) -> bool:
    """Whether ``value`` is a real number, or a flat sequence or an array of real numbers."""
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "iuf"
    if isinstance(value, (list, tuple)):
        return all(_real_scalar(v) for v in value)
    return _real_scalar(value)


def _real_scalar(v) -> bool:
    if isinstance(v, np.ndarray):
        return v.ndim == 0 and v.dtype.kind in "iuf"
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _kind(value) -> str:
    """A short description of a rejected load value, without echoing large contents."""
    if isinstance(value, np.ndarray):
        return f"an array of dtype {value.dtype}"
    if isinstance(value, (list, tuple)):
        return f"a {type(value).__name__} holding {', '.join(sorted({type(v).__name__ for v in value}))}"
    return f"a value of type {type(value).__name__}"


def _frozen(a):
    """A read-only float copy of ``a``."""
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


class Scene:
    """Bodies in frictionless contact along straight segments.

    ``Scene(body1, body2)``: the paper's scene, two bodies touching along each body's ``contact``
    part; the body order defines l = 1, 2 of the paper (``sigma1`` / ``sigma2``). ``gap`` is the
    initial normal gap g (m) between the bodies, a number or a vectorised callable g(s) of the
    tangential coordinate (the abscissa x1 for a line parallel to the x1-axis): the condition reads
    [u_nu] <= g (interpolated in X_h, i.e. at the merged nodes). g = 0 is the paper's problem; g < 0
    is an initial interference (a prescribed approach), used for Hertz-type tests.

    ``Scene(*bodies, contacts=[Contact(...), ...])``: any number of bodies and contact pairs
    (:class:`~cvxcontact.physics.pairs.Contact`), each pair against another body or a rigid obstacle,
    with its own gap and, optionally, its own condition; the bodies' ``contact`` tags are then not
    used. Every body must take part in at least one pair.

    The contact geometry (lines, normals, overlaps, merged nodes) is validated here: ``interfaces``
    (one :class:`~cvxcontact.contact.interface.Interface` per pair), ``interface`` (the first),
    ``stack`` (all pairs' rows stacked, what the solvers use).
    """

    def __init__(self, *bodies: Body, contacts: Sequence[Contact] | None = None,
                 gap: float | Callable[[np.ndarray], ArrayLike] = 0.0) -> None:
        for k, b in enumerate(bodies, start=1):
            if not isinstance(b, Body):
                raise SceneError(f"Scene takes Body objects; argument {k} is {type(b).__name__}")
        for k, b in enumerate(bodies, start=1):
            if b.name == "body":
                b.name = f"body {k}"
        self.bodies = tuple(bodies)
        if contacts is None:
            if len(bodies) != 2:
                raise SceneError(f"Scene without contacts= takes exactly two bodies (each body's contact= part "
                                 f"touches the other's), got {len(bodies)}; for other scenes pass "
                                 "contacts=[cc.Contact(...), ...]")
            if bodies[0] is bodies[1]:
                raise SceneError("Scene needs two distinct bodies")
            self._legacy = True
            self.contacts = (Contact(bodies[0], bodies[0].contact, bodies[1], bodies[1].contact),)
        else:
            self._legacy = False
            self.contacts = self._check_contacts(contacts, gap)
        members, interfaces = [], []
        for i, c in enumerate(self.contacts):
            a = self._index(c.body_a)
            b = None if c.rigid else self._index(c.other)
            members.append((a, b))
            try:
                if c.rigid:
                    itf = Interface((c.body_a,), (c.part_a,), obstacle=c.other)
                elif self._legacy:
                    itf = Interface(self.bodies)
                else:
                    itf = Interface((c.body_a, c.other), (c.part_a, c.part_b))
            except MeshError as exc:
                raise SceneError(str(exc)) from exc
            except SceneError as exc:
                if self._legacy:
                    raise
                raise SceneError(f"contacts[{i}] {c!r}: {exc}") from exc
            interfaces.append(itf)
        self.interfaces = tuple(interfaces)
        self.interface = self.interfaces[0]
        self.stack = Stack(self.interfaces, members)
        self.conditions = tuple(c.condition for c in self.contacts)
        self.gap = Load(gap if not callable(gap) else (lambda x, y, g=gap: g(x)), "scene: gap", 1)
        self.gap_values()                                    # check it now: finite, right shape

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
        if callable(gap) or (_real_scalar(gap) and gap != 0):
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
        obstacle, the distance to it along the body's normal. ``s``: other points of a two-body pair's
        line instead, given by their tangential coordinate (m; e.g. the P2 nodes of the merged mesh)."""
        itf = self.interfaces[i]
        load = self.gap if self._legacy else self.contacts[i].gap
        if s is not None:
            if itf.rigid:
                raise SceneError("pair_gap_values(i, s): points other than the merged nodes are for a pair of "
                                 "two bodies, not against a rigid obstacle")
            s = np.asarray(s, dtype=float)
            return np.array(load(s, np.full_like(s, itf.y)), dtype=float)
        g = np.array(load(itf.x, np.full_like(itf.x, itf.y)), dtype=float)
        return g + itf.obstacle_gap() if itf.rigid else g

    def gap_values(self) -> np.ndarray:
        """The gap g (m) at the stacked merged nodes of every pair (``stack``)."""
        return np.concatenate([self.pair_gap_values(i) for i in range(len(self.interfaces))])

    def structure(self) -> tuple:
        """What a prepared solver depends on beyond the bodies: each pair's members, parts, condition
        and merged-node count (the gaps and obstacle positions are loads)."""
        return tuple((m, c.part_a, c.part_b, c.condition, itf.size, c.other.kind if c.rigid else None)
                     for m, c, itf in zip(self.stack.members, self.contacts, self.interfaces))

    def __repr__(self):
        if self._legacy:
            return f"Scene({self.bodies[0]!r}, {self.bodies[1]!r})"
        return f"Scene({', '.join(repr(b) for b in self.bodies)}, contacts={list(self.contacts)!r})"

    @property
    def length(self) -> float:
        """Reference length L0 (m): the bounding-box diagonal of the whole scene."""
        p = np.concatenate([b.mesh.points for b in self.bodies])
        return float(np.linalg.norm(np.ptp(p, axis=0)))
