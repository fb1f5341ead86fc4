"""Bodies (mesh + material + boundary parts + loads) and the two-body scene.

Boundary parts follow the paper: Gamma_1 ``clamped`` (u = 0), Gamma_2 ``traction``
(sigma nu = f2), Gamma_3 ``contact``, Gamma_a ``grounded`` (phi = 0) and, beyond the
paper, ``potential`` electrodes (phi = V), Gamma_b ``surface_charge`` (D nu = q2). Loads are constants or vectorised callables of
the coordinates in metres ((x, y) in 2D, (x, y, z) in 3D); they are checked for shape and finiteness where they are used.
A body's dimension is its mesh's (``mesh.dim``): 2 for a :class:`~cvxcontact.geometry.mesh.Mesh`, 3 for a
tetrahedral mesh; vectors (forces, tractions, displacements) have that many components.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..errors import Frozen, FrozenMap, FrozenTuple, MeshError, SceneError
from ..contact.interface import Interface, Stack
from ..geometry.base import CellMesh
from .materials import Elastic, Piezoelectric
from .loads import LOAD_FIELDS
from . import supports as _supports
from .pairs import Contact, Rigid, obstacle_rows

__all__ = ["Body", "Scene"]


class Body(Frozen):
    """One body of the scene: a mesh, a material, its supports, electrodes and loads (SI units).

    Parameters
    ----------
    mesh : Mesh, QuadMesh, TetMesh or HexMesh
        The body's mesh, 2D (plane strain, per unit thickness) or 3D.
    material : Piezoelectric or Elastic
        A 3D body needs the material's 3D tensors (``material.tensors(3)``).
    clamped : str or list of str
        Tags of Gamma_1, where u = 0. The supports together must hold every rigid motion the contact
        does not (:meth:`free_motions`).
    contact : str, optional
        Tag of Gamma_3 in ``Scene(body1, body2)``; with ``contacts=`` optional (docs/howto/pairs.md).
    grounded : str or list of str
        Tags of Gamma_a, where phi = 0 (piezoelectric bodies only).
    potential : dict tag -> float or callable, V
        Driven electrodes, phi = V; a piezoelectric body needs a grounded or driven electrode.
    body_force : sequence of d floats or callable f(x, y[, z]), N/m^3
        Volume force f0 (d = 2 or 3, the mesh's dimension); None: zero.
    traction : dict tag -> sequence of d floats or callable, N/m^2
        Surface traction f2 (sigma nu = f2).
    surface_charge : dict tag -> float or callable, C/m^2
        Surface charge q2 (D . nu = q2).
    volume_charge : float or callable, C/m^3
        Volume charge q0 (div D = q0).
    name : str, optional
        How messages and outputs name the body.
    roller : str or list of str
        Straight (planar in 3D) parts where u . n = 0: sliding supports, symmetry planes.
    displacement : dict tag -> (ux, uy) or (ux, uy, uz), m
        Prescribed displacement components; ``None`` leaves a component free.
    floating : dict tag -> float, C/m
        Floating electrodes: one unknown potential on the part, total charge Q (0: open circuit).

    Notes
    -----
    Supports and electrodes enter the unknowns through the prolongation of
    docs/formulation.md §11 (:func:`cvxcontact.fem.assembly.prolongation`).

    A body is immutable once built: its parts are tuples, its per-part loads read-only mappings, its
    arrays read-only, and assigning an attribute raises :class:`~cvxcontact.errors.FrozenError`. Other
    loads make a new body with :meth:`with_loads` (the same geometry: a ContactSolver re-solves it), any
    other change with :meth:`with_changes`; :meth:`Scene.with_bodies` puts it in a scene.
    """

    def __init__(self, mesh: CellMesh, material: Piezoelectric | Elastic, *, clamped: str | Sequence[str] = (),
                 contact: str | None = None, grounded: str | Sequence[str] = (),
                 potential: Mapping[str, float | Callable[..., ArrayLike]] | None = None,
                 body_force: Sequence[float] | Callable[..., ArrayLike] | None = None,
                 traction: Mapping[str, Sequence[float] | Callable[..., ArrayLike]] | None = None,
                 surface_charge: Mapping[str, float | Callable[..., ArrayLike]] | None = None,
                 volume_charge: float | Callable[..., ArrayLike] = 0.0, name: str | None = None,
                 roller: str | Sequence[str] = (),
                 displacement: Mapping[str, Sequence[float | None]] | None = None,
                 floating: Mapping[str, float] | None = None) -> None:
        if not isinstance(mesh, CellMesh):          # every mesh's base (geometry/base.py)
            raise SceneError(f"mesh must be a cvxcontact.Mesh, QuadMesh, TetMesh or HexMesh, got {type(mesh).__name__}")
        if not isinstance(material, (Piezoelectric, Elastic)):
            raise SceneError(f"material must be a Piezoelectric or Elastic material, got {type(material).__name__}")
        if name is not None and not isinstance(name, str):
            raise SceneError(f"name must be a string, got {name!r}")
        self._set(mesh=mesh, material=material, name=name or "body", _named=name is not None, dim=int(mesh.dim))
        if self.dim == 3:
            material.tensors(3)                 # a MaterialError naming why a material has no 3D constants
        dim = self.dim
        if contact is not None and not isinstance(contact, str):
            raise SceneError(f"{self.name}: contact must be one boundary tag (a string) or None, got {contact!r}")
        self._set(clamped=self._tags(clamped, "clamped"), grounded=self._tags(grounded, "grounded"),
                  contact=None if contact is None else self._tags(contact, "contact")[0],
                  roller=self._tags(roller, "roller"),
                  body_force=Load(np.zeros(dim) if body_force is None else body_force, f"{self.name}: body_force",
                                  dim, dim),
                  volume_charge=Load(volume_charge, f"{self.name}: volume_charge", 1, dim))
        self._set(
            traction=self._map("traction", {t: Load(v, f"{self.name}: traction[{t!r}]", dim, dim)
                                            for t, v in self._parts(traction, "traction").items()}),
            surface_charge=self._map("surface_charge", {t: Load(v, f"{self.name}: surface_charge[{t!r}]", 1, dim)
                                                        for t, v in self._parts(surface_charge,
                                                                                "surface_charge").items()}),
            potential=self._map("potential", {t: Load(v, f"{self.name}: potential[{t!r}]", 1, dim)
                                              for t, v in self._parts(potential, "potential").items()}),
            displacement=self._map("displacement", {t: _prescribed(v, f"{self.name}: displacement[{t!r}]", dim)
                                                    for t, v in self._parts(displacement, "displacement").items()}),
            floating=self._map("floating", {t: _charge(v, f"{self.name}: floating[{t!r}]")
                                            for t, v in self._parts(floating, "floating").items()}))
        self._check_parts()

    # ------------------------------------------------------------------ immutability and variants

    def _label(self, k: int) -> None:
        """An unnamed body is called "body k" after its place in the first scene it joins (messages only:
        the name is neither geometry nor load)."""
        if not self._named and self.name == "body":
            object.__setattr__(self, "name", f"body {k}")

    def _frozen_hint(self, name: str) -> str:
        if name in LOAD_FIELDS:
            return f"build a new Body with body.with_loads({name}=...) (and a new Scene with scene.with_bodies(...))"
        return (f"build a new Body with body.with_changes({name}=...) (and a new Scene with scene.with_bodies(...))")

    def _map(self, field, items):
        return FrozenMap(items, f"Body.{field}", self._frozen_hint(field))

    def _arguments(self) -> dict:
        """The constructor's keyword arguments that rebuild this body (loads as given: constants or callables)."""
        return dict(mesh=self.mesh, material=self.material, clamped=self.clamped, contact=self.contact,
                    grounded=self.grounded, potential={t: v.value for t, v in self.potential.items()},
                    body_force=self.body_force.value, traction={t: v.value for t, v in self.traction.items()},
                    surface_charge={t: v.value for t, v in self.surface_charge.items()},
                    volume_charge=self.volume_charge.value, name=self.name if self._named else None,
                    roller=self.roller, displacement=dict(self.displacement), floating=dict(self.floating))

    def with_changes(self, **fields) -> "Body":
        """A new body: this one with some constructor arguments replaced (``mesh``, ``material``, parts,
        loads, ``name``; as :class:`Body` takes them, units there), validated afresh. A change outside the
        loads (:data:`~cvxcontact.physics.loads.LOAD_FIELDS`) is a new geometry: a prepared ContactSolver
        refuses it. ``body.with_changes(mesh=finer, clamped=["top", "left"])``."""
        args = self._arguments()
        unknown = sorted(set(fields) - set(args))
        if unknown:
            raise SceneError(f"{self.name}: with_changes got unknown field(s) {unknown}; a Body takes {sorted(args)}")
        args.update(fields)
        return Body(args.pop("mesh"), args.pop("material"), **args)

    def with_loads(self, **loads) -> "Body":
        """A new body with the same geometry and other loads: any of ``body_force`` ((dim,) or f(x, y[, z]),
        N/m^3), ``traction`` (tag -> (dim,) or callable, N/m^2), ``surface_charge`` (tag -> C/m^2), ``volume_charge``
        (C/m^3), ``potential`` (tag -> V; the same driven electrodes) and ``floating`` (tag -> Q, C/m; the
        same floating electrodes), as :class:`Body` takes them; each given field replaces the body's whole
        field, the others are kept. The :data:`~cvxcontact.physics.loads.LOAD_FIELDS`: a ContactSolver
        prepared for this body re-solves the result (its geometry fingerprint is the same). For a new
        geometry use :meth:`with_changes`. ``body.with_loads(body_force=(0.0, -2e9), potential={"top": 50.0})``."""
        other = sorted(set(loads) - set(LOAD_FIELDS))
        if other:
            raise SceneError(f"{self.name}: with_loads takes the loads {list(LOAD_FIELDS)}, got {other}: "
                             "those are geometry (use body.with_changes(...) for a new geometry)")
        for field in ("potential", "floating"):
            if field in loads:
                given, held = loads[field], getattr(self, field)
                tags = sorted(given) if isinstance(given, Mapping) else None
                if tags != sorted(held):
                    raise SceneError(f"{self.name}: with_loads({field}=...) changes the values of the "
                                     f"{'driven' if field == 'potential' else 'floating'} electrodes "
                                     f"{sorted(held)} and must name exactly those (got {given!r}); which parts are "
                                     f"electrodes is geometry: use body.with_changes({field}=...)")
        return self.with_changes(**loads)

    def __repr__(self):
        return f"Body({self.name!r}, {self.mesh!r}, {self.material!r})"

    @property
    def piezoelectric(self) -> bool:
        """True if the body carries electric unknowns."""
        return self.material.piezoelectric

    def _tags(self, tags, role):
        if isinstance(tags, Mapping) or not (isinstance(tags, str) or isinstance(tags, Iterable)):
            raise SceneError(f"{self.name}: {role} must be a boundary tag or a sequence of tags (strings), "
                             f"got {tags!r}")
        tags = [tags] if isinstance(tags, str) else list(tags)
        for t in tags:
            if not isinstance(t, str) or t not in self.mesh.tags:
                raise SceneError(f"{self.name}: {role} names unknown boundary tag {t!r}; "
                                 f"the mesh has {sorted(self.mesh.tags)}")
        return FrozenTuple(tags, f"Body.{role}", self._frozen_hint(role))

    def _parts(self, loads, role):
        if loads is None:
            return {}
        if not isinstance(loads, Mapping):
            raise SceneError(f"{self.name}: {role} must be a dict mapping boundary tags to loads, got {loads!r}")
        self._tags(list(loads), role)
        return dict(loads)

    def _check_parts(self):
        mechanical = ([("clamped", t) for t in self.clamped] + [("traction", t) for t in self.traction]
                      + [("roller", t) for t in self.roller] + [("displacement", t) for t in self.displacement])
        if self.contact is not None:
            mechanical.append(("contact", self.contact))
        _disjoint(self, mechanical)
        self._set(_roller_normals=FrozenMap({t: _straight_normal(self, t) for t in self.roller}))
        # a clamped contact part is a fixed foundation, a prescribed displacement on it moves the contact line:
        # both enter the contact rows through the gap (discrete/problem.py, docs/formulation.md §11)
        reduced = _supports.node_supports(self)             # consistent at every node (or a SceneError)
        for a in reduced:
            a.setflags(write=False)
        self._set(_node_supports=reduced)                   # kept: the prolongation of the vertices reads it
        self._check_kinematics()
        if self.piezoelectric:
            if not (self.grounded or self.potential):
                raise SceneError(f"{self.name}: piezoelectric body without a grounded or driven electrode "
                                 "(Gamma_a is empty); its potential is undetermined")
            self._check_components([*self.grounded, *self.potential],
                                   "touches no grounded or driven electrode: its potential is undetermined")
            _disjoint(self, [("grounded", t) for t in self.grounded] + [("potential", t) for t in self.potential]
                      + [("surface_charge", t) for t in self.surface_charge]
                      + [("floating", t) for t in self.floating])
            fixed = self.mesh.boundary_nodes([*self.grounded, *self.potential])
            seen = np.zeros(0, dtype=int)
            for tag in self.floating:
                nodes = self.mesh.boundary_nodes([tag])
                if np.isin(nodes, fixed).any():
                    raise SceneError(f"{self.name}: floating electrode {tag!r} touches a grounded or driven "
                                     "electrode; its potential would not be free")
                if np.isin(nodes, seen).any():
                    raise SceneError(f"{self.name}: floating electrode {tag!r} touches another floating "
                                     "electrode; merge them into one part")
                seen = np.concatenate([seen, nodes])
        else:
            electric = (self.grounded or self.potential or self.surface_charge or self.floating
                        or self.volume_charge.nonzero)
            if electric:
                raise SceneError(f"{self.name}: elastic material {self.material.name!r} carries no electric "
                                 "unknowns; remove grounded / potential / floating / surface_charge / "
                                 "volume_charge")

    def supports(self, nodes=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The kinematic constraints of the supports (:func:`cvxcontact.physics.supports.supports`)."""
        return _supports.supports(self, nodes)

    def node_supports(self, nodes=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The supports reduced node by node (:func:`cvxcontact.physics.supports.node_supports`; read-only arrays,
        those of the mesh's vertices computed once)."""
        held = self.mesh.node_set(nodes)
        return self._node_supports if held is self.mesh else _supports.node_supports(self, held)

    def free_motions(self, contact: bool | Sequence[str] = True) -> list[str]:
        """The rigid motions nothing holds, as readable names (:func:`cvxcontact.physics.supports.free_motions`)."""
        return _supports.free_motions(self, contact)

    def motion_name(self, coefficients: ArrayLike) -> str:
        """A readable name of a combination of :meth:`held_modes` (:func:`cvxcontact.physics.supports.motion_name`)."""
        return _supports.motion_name(self, coefficients)

    def held_modes(self, nodes=None) -> np.ndarray:
        """(k, 2 n_nodes): the rigid motions no support holds, as nodal fields
        (:func:`cvxcontact.physics.supports.held_modes`)."""
        return _supports.held_modes(self, nodes)

    held_by_contact: tuple[str, ...]
    """The rigid motions no support holds, which the contact must hold (readable names, see
    :meth:`free_motions`; decided with the scene's pairs and loads, :mod:`cvxcontact.fem.kernel`); empty
    when the supports hold every rigid motion."""

    def _check_kinematics(self):
        # the rigid motions no support holds (see free_motions): the contact must hold them. Whether it does
        # depends on the scene's pairs and loads: refused by the Scene (a motion no contact part resists,
        # _refuse_unheld) or when the problem is built (cvxcontact.fem.kernel.check_well_posed)
        self._set(held_by_contact=FrozenTuple(self.free_motions(contact=False), "Body.held_by_contact",
                                              "it follows from the supports"))

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
        raise SceneError(f"{self.name}: mesh component {c} ({_supports.component_description(self.mesh, c)}) "
                         f"{problem}; expected every one of the {count} separate pieces of the mesh to touch one "
                         f"of {tags}")


def _straight_normal(body, tag):
    """The unit outward normal of a straight (2D) or planar (3D) boundary part; a SceneError if it is not."""
    normals = body.mesh.outward_normals(tag)
    n = normals.mean(axis=0)
    n = n / np.linalg.norm(n)
    dev = float(np.abs(normals - n).max())
    if dev > 1e-9:
        shape, piece, cells = ("straight", "straight pieces", "edge") if body.dim == 2 else ("planar", "planar pieces",
                                                                                             "face")
        raise SceneError(f"{body.name}: roller part {tag!r} is not {shape} (its {cells} normals differ by up to "
                         f"{dev:.3g}); a roller needs one normal direction (split the part into {piece})")
    n.setflags(write=False)
    return n


def _prescribed(value, label, dim=2):
    """(ux, uy[, uz]) with floats (m) or None (free), checked."""
    what = "a pair (ux, uy)" if dim == 2 else "a triple (ux, uy, uz)"
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != dim:
        raise SceneError(f"{label}: expected {what} of numbers (m) or None (free), got {value!r}")
    out = []
    for v in value:
        if v is None:
            out.append(None)
        elif _real_scalar(v) and np.isfinite(v):
            out.append(float(v))
        else:
            raise SceneError(f"{label}: expected {what} of finite numbers (m) or None, got {value!r}")
    if out == [None] * dim:
        raise SceneError(f"{label}: {'both' if dim == 2 else 'all'} components are None (free): nothing is "
                         "prescribed; remove the part")
    return tuple(out)


def _charge(value, label):
    """A floating electrode's total charge Q (C/m), checked."""
    if not _real_scalar(value) or not np.isfinite(value):
        raise SceneError(f"{label}: expected the total charge Q in C/m (a finite number, 0 = open circuit), "
                         f"got {value!r}")
    return float(value)


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
                             f"the normal of the contact part(s) {parts})")


def _disjoint(body, roles):
    seen = {}
    for role, tag in roles:
        if tag in seen:
            raise SceneError(f"{body.name}: boundary tag {tag!r} is both {seen[tag]} and {role}")
        seen[tag] = role


class Load(Frozen):
    """A constant or a vectorised callable of the coordinates ((x, y), or (x, y, z) for ``dim`` 3), evaluated
    and checked on demand.

    Constants must be real numbers (booleans and complex numbers are refused) and are kept as
    read-only arrays; a load is immutable. A callable receives read-only copies of the coordinates
    (m) and its result is copied, so no load can write into the meshes or the contact interface.
    """

    def __init__(self, value, label, ncomp, dim=2):
        self._set(label=label, ncomp=ncomp, dim=dim)
        if callable(value):
            self._set(value=value)
            return
        expected = "a number" if ncomp == 1 else f"a sequence of {ncomp} numbers"
        if not _real_numbers(value):
            raise SceneError(f"{label}: expected {expected} (real, not boolean or complex) or a callable "
                             f"f({'x, y' if dim == 2 else 'x, y, z'}), "
                             f"got {_kind(value)}")
        v = np.array(value, dtype=float)
        shape = () if ncomp == 1 else (ncomp,)
        if v.shape != shape:
            raise SceneError(f"{label}: expected {'a scalar' if ncomp == 1 else f'{ncomp} components'}, "
                             f"got shape {v.shape}")
        if not np.isfinite(v).all():
            raise SceneError(f"{label}: NaN or infinite value {v.tolist()}")
        v.setflags(write=False)
        self._set(value=v)

    def _frozen_hint(self, name: str) -> str:
        return "build a new Body with body.with_loads(...) (a new scene gap: scene.with_gap(...))"

    @property
    def nonzero(self) -> bool:
        return callable(self.value) or bool(np.any(self.value != 0))

    def __call__(self, *coords) -> np.ndarray:
        """Values at points (x, y) or (x, y, z) in metres: shape (k,) for scalars, (k, ncomp) for vectors."""
        coords = [_frozen(c) for c in coords]
        x = coords[0]
        v = self.value
        if not callable(v):
            return np.broadcast_to(v, x.shape + v.shape)
        try:
            out = v(*coords)
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
        p = np.concatenate([b.mesh.points for b in self.bodies])
        return float(np.linalg.norm(np.ptp(p, axis=0)))
