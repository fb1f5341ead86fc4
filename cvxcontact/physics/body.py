"""A body: mesh + material + boundary parts + loads, checked; and :class:`Load`, a checked constant or callable load.

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

from ..errors import Frozen, FrozenMap, FrozenTuple, SceneError, locked
from ..geometry.base import CellMesh
from . import supports as _supports
from .fingerprint import KEPT
from .loads import LOAD_FIELDS
from .materials import Elastic, Piezoelectric

__all__ = ["Body", "Load"]


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
        self._check_parts(self.__dict__.pop("_checked_like", None))     # set by _variant: a body of this geometry

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
        return self._variant(fields)

    def _variant(self, fields, geometry=None) -> Body:
        """:meth:`with_changes` of ``fields``; ``geometry``: a body whose checks of the geometry the new one
        shares (:meth:`with_loads`: itself)."""
        args = self._arguments()
        unknown = sorted(set(fields) - set(args))
        if unknown:
            raise SceneError(f"{self.name}: with_changes got unknown field(s) {unknown}; a Body takes {sorted(args)}")
        args.update(fields)
        body = Body.__new__(Body)
        if geometry is not None:
            object.__setattr__(body, "_checked_like", geometry)       # read (and dropped) by __init__
        body.__init__(args.pop("mesh"), args.pop("material"), **args)
        return body

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
        return self._variant(loads, geometry=self)          # what its geometry's checks decided is shared

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

    def _check_parts(self, geometry=None):
        """Check the parts; ``geometry``: a body of the same mesh, material, supports and electrodes
        (:meth:`with_loads`), whose checks of them this body shares (only the loads' parts are checked again)."""
        mechanical = ([("clamped", t) for t in self.clamped] + [("traction", t) for t in self.traction]
                      + [("roller", t) for t in self.roller] + [("displacement", t) for t in self.displacement])
        if self.contact is not None:
            mechanical.append(("contact", self.contact))
        _disjoint(self, mechanical)
        if geometry is not None:
            self._set(_roller_normals=geometry._roller_normals, _node_supports=geometry._node_supports,
                      held_by_contact=geometry.held_by_contact)
            if KEPT in geometry.__dict__:                       # the same geometry: its fingerprint, not hashed again
                self._set(**{KEPT: geometry.__dict__[KEPT]})
        else:
            self._set(_roller_normals=FrozenMap({t: _straight_normal(self, t) for t in self.roller}))
            # a clamped contact part is a fixed foundation, a prescribed displacement on it moves the contact line:
            # both enter the contact rows through the gap (discrete/problem.py, docs/formulation.md §11)
            reduced = tuple(locked(a) for a in _supports.node_supports(self))   # consistent at every node (or a
            # SceneError)
            self._set(_node_supports=reduced)                   # kept: the prolongation of the vertices reads it
            self._check_kinematics()
        if self.piezoelectric:
            if not (self.grounded or self.potential):
                raise SceneError(f"{self.name}: piezoelectric body without a grounded or driven electrode "
                                 "(Gamma_a is empty); its potential is undetermined")
            _disjoint(self, [("grounded", t) for t in self.grounded] + [("potential", t) for t in self.potential]
                      + [("surface_charge", t) for t in self.surface_charge]
                      + [("floating", t) for t in self.floating])
            if geometry is not None:
                return                                          # the electrodes are the same parts
            self._check_components([*self.grounded, *self.potential],
                                   "touches no grounded or driven electrode: its potential is undetermined")
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
    return locked(n)


def _prescribed(value, label, dim=2):
    """(ux, uy[, uz]) with floats (m) or None (free), checked."""
    what = "a pair (ux, uy)" if dim == 2 else "a triple (ux, uy, uz)"
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != dim:
        raise SceneError(f"{label}: expected {what} of numbers (m) or None (free), got {value!r}")
    out = []
    for v in value:
        if v is None:
            out.append(None)
        elif real_scalar(v) and np.isfinite(v):
            out.append(float(v))
        else:
            raise SceneError(f"{label}: expected {what} of finite numbers (m) or None, got {value!r}")
    if out == [None] * dim:
        raise SceneError(f"{label}: {'both' if dim == 2 else 'all'} components are None (free): nothing is "
                         "prescribed; remove the part")
    return tuple(out)


def _charge(value, label):
    """A floating electrode's total charge Q (C/m), checked."""
    if not real_scalar(value) or not np.isfinite(value):
        raise SceneError(f"{label}: expected the total charge Q in C/m (a finite number, 0 = open circuit), "
                         f"got {value!r}")
    return float(value)


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
        self._set(value=locked(v))                     # (writing cannot be turned back on)

    def _frozen_hint(self, name: str) -> str:
        return "build a new Body with body.with_loads(...) (a new scene gap: scene.with_gap(...))"

    @property
    def nonzero(self) -> bool:
        return callable(self.value) or bool(np.any(self.value != 0))

    @property
    def constant(self) -> bool:
        """True for a constant load (its ``value`` everywhere), False for a function of the coordinates."""
        return not callable(self.value)

    def __call__(self, *coords) -> np.ndarray:
        """Values at points (x, y) or (x, y, z) in metres: shape (k,) for scalars, (k, ncomp) for vectors."""
        coords = [locked(c, float) for c in coords]
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
        return all(real_scalar(v) for v in value)
    return real_scalar(value)


def real_scalar(v) -> bool:
    """Whether ``v`` is a real number (an int or float, a NumPy scalar or 0-d array of one; not a bool)."""
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
