"""Scene files (TOML): bodies, meshes, materials, boundary parts, loads, condition, solver.

A scene file is data. Loads are numbers or expressions in x and y read by the
restricted evaluator of :mod:`cvxcontact.io.expr`; nothing is executed. Every error
names the file, the key and what was expected. Format (all SI units)::

    condition = "gamma3"                      # or "sigma1", "sigma2" (optional)
    degree = 1                                # 1: P1 elements, 2: P2 (6-node) elements (optional)
    law = "signorini"                         # default; or normal compliance (7), docs/formulation.md §10:
                                              # { normal_compliance = { stiffness = 1e12, exponent = 1,
                                              #                         penetration_limit = 1e-5 } }  (Pa/m^m, -, m)
                                              # or friction (docs/howto/friction.md): { tresca = {
                                              # threshold = 1e6 } } (Pa), { coulomb = { coefficient = 0.3 } }
    gap = 0.0                                 # initial normal gap g(x) on Gamma_3, m (number or expression)

    [solver]                                  # optional
    name = "CLARABEL"                         # any installed CVXPY solver
    tol = 1e-6                                # tolerance of the mixed-formulation checks
    polish = true                             # exact finish
    method = "auto"                           # default: the fastest backend; or "full", "condensed"
    options = { max_iter = 100 }              # solver options (for Clarabel: names, types and
                                              # ranges of clarabel.DefaultSettings)

    [[body]]                                  # exactly two; the order defines l = 1, 2
    name = "actuator"
    material = "PZT-5A"                       # a built-in name, or a table: {E, nu}, Hencky plasticity
                                              # {E, nu, yield_stress, hardening} or
                                              # {c11, c13, c33, c44, e31, e33, e15, eps11, eps33[, c12]}
    mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 16, ny = 8 } }
                                              # or mesh = { file = "lower.msh" } (relative to this file,
                                              # inside its folder unless allow_outside=True),
                                              # with region = "name" for one surface of a multi-body file
    clamped = ["top"]
    grounded = ["top"]                        # piezoelectric bodies
    contact = "bottom"
    body_force = [0.0, "-2e9 * (1 + x)"]      # N/m^3; numbers or expressions in x, y
    traction = { right = [0.0, 3e8] }         # N/m^2
    surface_charge = { left = -0.05 }         # C/m^2
    potential = { }                           # V, driven electrodes
    volume_charge = 0.0                       # C/m^3
    roller = ["left"]                         # u.n = 0 on straight parts (sliding supports, symmetry)
    displacement = { right = ["free", -1e-4] }  # prescribed [ux, uy] in m, "free" = not prescribed
    floating = { side = 0.0 }                 # floating electrodes: total charge Q, C/m (0 = open circuit)
    rotation = 0.0                            # material turned counter-clockwise, radians (poling axis)
    plane = "strain"                          # or "stress"

Meshes may also be ``{ rectangle = {..., segments = { footprint = ["top", 0.25, 0.75] } } }`` (``cell = "quad"``:
quadrilaterals, Q1 and Q2 with ``degree``),
``{ graded_block = { x, y, nx, ny, contact, beta, gamma, center, cell } }`` or
``{ half_disk = { radius, center, nr, nt, side } }`` (tags "flat", "arc").

Contact pairs and rigid obstacles (any number of bodies; without ``[[contact]]`` tables the file
needs exactly two bodies touching along their ``contact`` parts)::

    [[obstacle]]                              # a rigid obstacle, analytic: one of plane, circle, profile
    name = "floor"
    plane = { point = [0.0, 0.0], normal = [0.0, 1.0] }     # normal out of the obstacle, towards the body
    # circle = { center = [0.5, -0.3], radius = 0.3 }
    # profile = { f = "1e-3 + (x - 0.5)**2", origin = [0.0, 0.0] }   # distance along the normal, m;
    #                                           x stands for the tangential coordinate s
    force = [0.0, 1e6]                        # optional, N/m, pressing it onto the body: force control (its
    #                                           translation is an unknown with this resultant; formulation.md §12)
    guided = [0.0, 1.0]                       # optional, with force: translate along this unit axis only (or a
    #                                           list of orthogonal unit axes), the rest held: a half model

    [[contact]]
    a = "punch"                               # a body's name
    part_a = "bottom"
    b = "substrate"                           # a body's or an obstacle's name
    part_b = "top"                            # omitted for an obstacle
    condition = "sigma1"                      # optional (default: the file's condition)
    gap = 0.0                                 # m, number or expression (x stands for s)
    law = { normal_compliance = { stiffness = 1e13 } }   # optional: this pair's law (as the top-level
                                              # law); default: the file's law

With ``[[contact]]`` tables a body's ``contact`` key is optional (its first part in a pair) and
the top-level ``gap`` is refused (each pair has its own).

3D scenes: a body whose mesh is tetrahedral or hexahedral (``box = {..., cell = "hex"}``: Q1, Q2 with ``degree``) is 3D (every body of a file has one dimension); its loads
have three components, expressions may use ``z``, ``displacement`` is [ux, uy, uz], ``rotation`` a 3x3
rotation matrix (no ``plane`` key), and a pair's gap is an expression of the in-plane coordinates x, y =
(s1, s2) of the pair's frame::

    mesh = { box = { x = [0, 0.02], y = [0, 0.02], z = [0, 0.005], nx = 6, ny = 6, nz = 2,
                     patches = { footprint = ["top", [0.005, 0.015], [0.005, 0.015]] },
                     grade = { point = [0.01, 0.01, 0.005], ratio = 4.0 } } }
    mesh = { cylinder = { radius = 0.01, height = 0.002, n_r = 4, n_z = 2, n_theta = 24, center = [0, 0, 0] } }
    mesh = { file = "part.msh" }              # gmsh tetra / tetra10, hexahedron / hexahedron27

    [[obstacle]]                              # 3D: one of plane (3-vectors), sphere, cylinder, height_field
    sphere = { center = [0.01, 0.01, 0.025], radius = 0.02 }
    # cylinder = { point = [0, 0.01, 0.03], axis = [1, 0, 0], radius = 0.025 }
    # height_field = { f = "(x**2 + y**2) / 0.1", origin = [0.01, 0.01, 0.005] }   # solid above z = f(x, y)
    force = [0.0, 0.0, -50.0]                 # N
    guided = [0.0, 0.0, 1.0]                  # optional: along z only (a quarter model's symmetry planes hold
    #                                           the sphere in x and y); or [[0, 1, 0], [0, 0, 1]] (two axes)
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..physics import materials as mats
from ..contact.interface import CONDITIONS
from ..errors import CvxContactError, SceneError
from .expr import VARIABLES, Expression, ExpressionError
from ..geometry.mesh import read_mesh, rectangle
from ..geometry.generators import graded_block, half_disk
from ..geometry.generators3d import box, cylinder
from ..backends.options import check_solver, check_solver_options
from ..physics.scene import Body, Scene
from ..physics.pairs import Contact, Rigid
from ..backends import METHODS

__all__ = ["SceneFile", "SceneFileError", "load_scene", "scene_from_data", "read_toml", "MATERIALS"]

MATERIALS = {"PZT4": mats.PZT4, "PZT5A": mats.PZT5A, "PZT5H": mats.PZT5H, "BATIO3": mats.BaTiO3}

_TOP = {"condition", "solver", "body", "gap", "law", "contact", "obstacle", "degree"}
_CONTACT = {"a", "part_a", "b", "part_b", "condition", "gap", "law"}
_OBSTACLE = {"name", "plane", "circle", "profile", "sphere", "cylinder", "height_field", "force", "guided"}
_OBSTACLE_KINDS = {"plane": {"point", "normal", "distance"}, "circle": {"center", "radius", "distance"},
                   "profile": {"f", "origin", "distance"}, "sphere": {"center", "radius", "distance"},
                   "cylinder": {"point", "axis", "radius", "distance"}, "height_field": {"f", "origin", "distance"}}
_OPTIONAL = {"origin", "distance"}     # distance: the posing, "closest" or "ray" (physics.posings.POSINGS)
_SOLVER = {"name", "tol", "polish", "method", "options"}
_HENCKY = {"yield_stress", "hardening"}
"""The keys that make a material table a Hencky material (with E, nu): :func:`~cvxcontact.materials.hencky`."""
_BODY = {"name", "material", "mesh", "clamped", "grounded", "contact", "body_force", "traction",
         "surface_charge", "potential", "volume_charge", "roller", "displacement", "floating", "rotation", "plane"}
_PIEZO = {"c11", "c12", "c13", "c33", "c44", "e31", "e33", "e15", "eps11", "eps33"}


_REQUIRED = object()
"""Marks a key that must be present (:meth:`_Context.string`)."""


class SceneFileError(SceneError):
    """A scene file is missing, not TOML, or has a key with a bad value."""


@dataclass
class SceneFile:
    """A scene read from a file, with the solve settings it asks for."""

    path: Path
    scene: Scene
    condition: str = "gamma3"
    solver: str = "CLARABEL"
    tol: float = 1e-6
    polish: bool = True
    method: str = "auto"
    options: dict = field(default_factory=dict)
    law: object = None
    degree: int = 1

    @property
    def settings(self) -> dict:
        """Keyword arguments of :func:`cvxcontact.solve` given by the file (condition excluded)."""
        return dict(solver=self.solver, tol=self.tol, polish=self.polish, method=self.method,
                    solver_options=dict(self.options), law=self.law, degree=self.degree)

    def solve(self, condition: str | None = None, *, solver: str | None = None, method: str | None = None,
              tol: float | None = None, polish: bool | None = None, verbose: bool = False,
              solver_options: dict | None = None, degree: int | None = None):
        """Solve with the file's settings; the arguments that are not None override them
        (``solver_options`` replaces the file's options). Parameters as in :func:`cvxcontact.solve`."""
        from ..solve import solve

        kw = self.settings
        given = dict(solver=solver, method=method, tol=tol, polish=polish, solver_options=solver_options,
                     degree=degree)
        kw.update({k: v for k, v in given.items() if v is not None})
        return solve(self.scene, condition or self.condition, verbose=verbose, **kw)


def read_toml(path, what="scene file") -> dict:
    """The data of a TOML file; :class:`SceneFileError` if missing or malformed."""
    path = Path(path)
    if not path.is_file():
        raise SceneFileError(f"{path}: {what} does not exist")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneFileError(f"{path}: not a valid TOML file: {exc}") from None


def load_scene(path: str | os.PathLike[str], allow_outside: bool = False) -> SceneFile:
    """Read and validate a scene file. Raises :class:`SceneFileError` naming file and key.

    Mesh files must lie in the scene file's folder or below it (after resolving ``..``
    and symbolic links), and be given by relative paths, unless ``allow_outside``.
    """
    return scene_from_data(read_toml(path), Path(path), allow_outside=allow_outside)


def scene_from_data(data, path, allow_outside: bool = False) -> SceneFile:
    """Validate scene-file ``data`` (a dict as read from TOML); ``path`` names it in errors and
    anchors relative mesh files (confined to its folder unless ``allow_outside``)."""
    if not isinstance(allow_outside, bool):
        raise SceneFileError(f"allow_outside must be True or False, got {allow_outside!r}")
    path = Path(path)
    ctx = _Context(path, allow_outside)
    ctx.keys(data, _TOP, "top level")
    condition = data.get("condition", "gamma3")
    if condition not in CONDITIONS:
        ctx.fail("condition", f"one of {list(CONDITIONS)}", condition)
    degree = data.get("degree", 1)
    if isinstance(degree, bool) or degree not in (1, 2):
        ctx.fail("degree", "1 (P1) or 2 (P2)", degree)
    solver = ctx.table(data.get("solver", {}), "solver")
    ctx.keys(solver, _SOLVER, "solver")
    name = solver.get("name", "CLARABEL")
    tol = solver.get("tol", 1e-6)
    polish = solver.get("polish", True)
    method = solver.get("method", "auto")
    options = ctx.table(solver.get("options", {}), "solver.options")
    if method not in METHODS:
        ctx.fail("solver.method", f"one of {list(METHODS)}", method)
    if not isinstance(name, str):
        ctx.fail("solver.name", "a CVXPY solver name (string)", name)
    try:
        name = check_solver(name)
    except CvxContactError as exc:
        raise SceneFileError(f"{path}: solver.name: {exc}") from None
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (math.isfinite(tol) and tol > 0):
        ctx.fail("solver.tol", "a finite positive number", tol)
    if not isinstance(polish, bool):
        ctx.fail("solver.polish", "true or false", polish)
    try:
        options = check_solver_options(options, name)
    except CvxContactError as exc:
        raise SceneFileError(f"{path}: solver.options: {exc}") from None
    bodies = data.get("body")
    if "contact" in data or "obstacle" in data:
        return SceneFile(path, _pairs_scene(ctx, data, bodies), condition, name, float(tol), polish, method,
                         options, degree=int(degree))
    if not isinstance(bodies, list) or len(bodies) != 2:
        ctx.fail("body", "exactly two [[body]] tables", f"{len(bodies) if isinstance(bodies, list) else 0}")
    built = [ctx.body(b, k) for k, b in enumerate(bodies)]
    gap = ctx.gap(data.get("gap", 0.0), "gap", built[0].dim)
    try:
        scene = Scene(*built, gap=gap)
    except CvxContactError as exc:
        raise SceneFileError(f"{path}: {exc}") from exc
    return SceneFile(path, scene, condition, name, float(tol), polish, method, options,
                     law=_law(data.get("law", "signorini"), path), degree=int(degree))


_LAW_KEYS = {"normal_compliance": ({"stiffness"}, ("stiffness", "exponent", "penetration_limit")),
             "tresca": ({"threshold"}, ("threshold",)),
             "coulomb": ({"coefficient"}, ("coefficient", "tolerance", "max_iterations"))}
"""A scene file's law tables: name -> (required keys, all keys), in the order the messages name them."""


def _law(value, path):
    """The contact law of a scene file: "signorini", { normal_compliance = { stiffness, exponent,
    penetration_limit } }, { tresca = { threshold } } or { coulomb = { coefficient, tolerance, max_iterations } }
    (:mod:`cvxcontact.contact.laws`)."""
    from ..contact.laws import LAWS, Coulomb, NormalCompliance, Signorini, Tresca

    if value == "signorini":
        return Signorini()
    if isinstance(value, dict) and len(value) == 1 and set(value) <= set(_LAW_KEYS):
        ((name, params),) = value.items()
        required, keys = _LAW_KEYS[name]
        if not isinstance(params, dict) or set(params) - set(keys) or required - set(params):
            expected = ", ".join(f"{k} (required)" if k in required else k for k in keys)
            got = sorted(params) if isinstance(params, dict) else repr(params)
            raise SceneFileError(f"{path}: law.{name}: expected keys {expected}; got {got}")
        law = {"normal_compliance": NormalCompliance, "tresca": Tresca, "coulomb": Coulomb}[name]
        try:
            return law(**params)
        except CvxContactError as exc:
            raise SceneFileError(f"{path}: law.{name}: {exc}") from None
    raise SceneFileError(f"{path}: law: expected \"signorini\" or {{ normal_compliance = {{ stiffness = ..., "
                         f"exponent = ... }} }} (laws: {sorted(LAWS)}), got {value!r}")


def _pairs_scene(ctx, data, bodies):
    """The scene of a file with [[contact]] (and [[obstacle]]) tables."""
    if not isinstance(bodies, list) or not bodies:
        ctx.fail("body", "at least one [[body]] table", f"{len(bodies) if isinstance(bodies, list) else 0}")
    if "gap" in data:
        raise SceneFileError(f"{ctx.path}: gap: with [[contact]] tables give each contact its own gap "
                             "(contact[i].gap)")
    contacts = data.get("contact")
    if not isinstance(contacts, list) or not contacts:
        ctx.fail("contact", "one or more [[contact]] tables", contacts)
    names = [ctx.string(b, "name", f"body[{k}]", f"body {k + 1}") if isinstance(b, dict) else None
             for k, b in enumerate(bodies)]
    if len(set(names)) != len(names):
        ctx.fail("body", "bodies with distinct names", names)
    obstacles = {}
    for i, o in enumerate(data.get("obstacle", []) if isinstance(data.get("obstacle", []), list) else [None]):
        where = f"obstacle[{i}]"
        o = ctx.table(o, where)
        ctx.keys(o, _OBSTACLE, where)
        oname = ctx.string(o, "name", where)
        if oname in names or oname in obstacles:
            ctx.fail(f"{where}.name", "a name (string) that no body or other obstacle has", oname)
        obstacles[oname] = ctx.obstacle(o, where)
    for i, c in enumerate(contacts):
        c = ctx.table(c, f"contact[{i}]")
        ctx.keys(c, _CONTACT, f"contact[{i}]")
        for key in ("a", "part_a", "b", "part_b", "condition"):          # boundary tags and names: strings
            ctx.string(c, key, f"contact[{i}]", None if key in ("part_b", "condition") else _REQUIRED)
        if c["a"] not in names:
            ctx.fail(f"contact[{i}].a", f"the name of a body {names}", c["a"])
        if c["b"] not in names and c["b"] not in obstacles:
            ctx.fail(f"contact[{i}].b", f"the name of a body {names} or of an obstacle {sorted(obstacles)}", c["b"])
    first_part = {}
    for c in contacts:
        first_part.setdefault(c["a"], c["part_a"])
        if c["b"] in names and "part_b" in c:
            first_part.setdefault(c["b"], c["part_b"])
    built = []
    for k, b in enumerate(bodies):
        if isinstance(b, dict) and "contact" not in b and names[k] in first_part:
            b = {**b, "contact": first_part[names[k]]}
        built.append(ctx.body(b, k, pairs=True))
    by_name = dict(zip(names, built))
    pairs = []
    for i, c in enumerate(contacts):
        where = f"contact[{i}]"
        condition = c.get("condition")
        if condition is not None and condition not in CONDITIONS:
            ctx.fail(f"{where}.condition", f"one of {list(CONDITIONS)}", condition)
        gap = ctx.gap(c.get("gap", 0.0), f"{where}.gap", by_name[c["a"]].dim)
        other = by_name.get(c["b"]) or obstacles[c["b"]]
        law = _law(c["law"], f"{ctx.path}: {where}") if "law" in c else None
        try:
            pairs.append(Contact(by_name[c["a"]], c["part_a"], other, c.get("part_b"), condition=condition,
                                 gap=gap, law=law))
        except CvxContactError as exc:
            raise SceneFileError(f"{ctx.path}: {where}: {exc}") from exc
    try:
        return Scene(*built, contacts=pairs)
    except CvxContactError as exc:
        raise SceneFileError(f"{ctx.path}: {exc}") from exc


class _Context:
    """Validation helpers that prefix every message with the file name."""

    def obstacle(self, o, where):
        kinds = [k for k in _OBSTACLE_KINDS if k in o]
        if len(kinds) != 1:
            raise SceneFileError(f"{self.path}: {where}: expected exactly one of {', '.join(_OBSTACLE_KINDS)} (2D: "
                                 f"plane, circle, profile; 3D: plane, sphere, cylinder, height_field), got "
                                 f"{kinds or 'none'}")
        kind = kinds[0]
        spec = self.table(o[kind], f"{where}.{kind}")
        allowed = _OBSTACLE_KINDS[kind]
        self.keys(spec, allowed, f"{where}.{kind}")
        for req in sorted(allowed - _OPTIONAL):
            if req not in spec:
                raise SceneFileError(f"{self.path}: {where}.{kind}: missing key {req!r}")
        force = o.get("force")
        guided = o.get("guided")
        posed = {"distance": spec["distance"]} if "distance" in spec else {}
        f = None
        if kind == "profile":
            f = self.load(spec["f"], f"{where}.profile.f", 1)
        elif kind == "height_field":
            f = self.load(spec["f"], f"{where}.height_field.f", 1)     # a function of (x, y), m
        try:
            if kind == "plane":
                return Rigid.plane(spec["point"], spec["normal"], force=force, guided=guided, **posed)
            if kind == "circle":
                return Rigid.circle(spec["center"], spec["radius"], force=force, guided=guided, **posed)
            if kind == "sphere":
                return Rigid.sphere(spec["center"], spec["radius"], force=force, guided=guided, **posed)
            if kind == "cylinder":
                return Rigid.cylinder(spec["point"], spec["axis"], spec["radius"], force=force, guided=guided, **posed)
            if kind == "height_field":
                fn = f if callable(f) else (lambda x, y, f=f: f + 0.0 * x)
                return Rigid.height_field(fn, spec.get("origin", (0.0, 0.0, 0.0)), force=force, guided=guided, **posed)
            fn = (lambda s, f=f: f(s, 0.0 * s)) if callable(f) else (lambda s, f=f: f + 0.0 * s)
            return Rigid.profile(fn, spec.get("origin", (0.0, 0.0)), force=force, guided=guided, **posed)
        except CvxContactError as exc:
            raise SceneFileError(f"{self.path}: {where}: {exc}") from exc

    def gap(self, value, key, dim):
        """A pair's gap (m): a number, or an expression of the position along the pair: in 2D of x (standing for
        the tangential coordinate s), in 3D of x, y (the in-plane coordinates (s1, s2) of the pair's frame)."""
        g = self.load(value, key, 1)
        if not callable(g):
            return g
        return g if dim == 3 else (lambda x, g=g: g(x, 0.0 * x))

    def __init__(self, path, allow_outside=False):
        self.path, self.allow_outside = path, allow_outside

    def string(self, table, key, where, default=None):
        """``table[key]``, which must be a string (a name, a boundary tag, a condition); ``default`` if the
        key is absent (``_REQUIRED``: a missing key is an error). SceneFileError naming the file and key."""
        if key not in table:
            if default is _REQUIRED:
                raise SceneFileError(f"{self.path}: {where}: missing key {key!r}")
            return default
        value = table[key]
        if not isinstance(value, str):
            self.fail(f"{where}.{key}", "a string", value)
        return value

    def fail(self, key, expected, got):
        raise SceneFileError(f"{self.path}: {key}: expected {expected}, got {got!r}")

    def keys(self, table, allowed, where):
        unknown = sorted(set(table) - allowed)
        if unknown:
            raise SceneFileError(f"{self.path}: {where}: unknown key(s) {unknown}; allowed: {sorted(allowed)}")

    def table(self, value, key):
        if not isinstance(value, dict):
            self.fail(key, "a table", value)
        return value

    def body(self, b, k, pairs=False):
        """The Body of table ``b`` (``body[k]``); its ``contact`` key is required unless the file has
        [[contact]] tables (``pairs``)."""
        where = f"body[{k}]"
        b = self.table(b, where)
        self.keys(b, _BODY, where)
        for req in ("material", "mesh") if pairs else ("material", "mesh", "contact"):
            if req not in b:
                raise SceneFileError(f"{self.path}: {where}: missing key {req!r}")
        name = self.string(b, "name", where, f"body {k + 1}")
        mesh = self.mesh(b["mesh"], f"{where}.mesh")
        dim = int(getattr(mesh, "dim", 2))                # the mesh decides: 2 (triangles) or 3 (tetrahedra)
        kw = dict(
            clamped=self.tags(b.get("clamped", []), f"{where}.clamped"),
            grounded=self.tags(b.get("grounded", []), f"{where}.grounded"),
            contact=self.string(b, "contact", where),
            body_force=self.load(b.get("body_force", [0.0] * dim), f"{where}.body_force", dim, dim),
            volume_charge=self.load(b.get("volume_charge", 0.0), f"{where}.volume_charge", 1, dim),
        )
        for key, n in (("traction", dim), ("surface_charge", 1), ("potential", 1)):
            parts = self.table(b.get(key, {}), f"{where}.{key}")
            kw[key] = {t: self.load(v, f"{where}.{key}.{t}", n, dim) for t, v in parts.items()}
        kw["roller"] = self.tags(b.get("roller", []), f"{where}.roller")
        kw["displacement"] = {t: self.prescribed(v, f"{where}.displacement.{t}", dim)
                              for t, v in self.table(b.get("displacement", {}), f"{where}.displacement").items()}
        floating = self.table(b.get("floating", {}), f"{where}.floating")
        for t, v in floating.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                self.fail(f"{where}.floating.{t}", "the total charge in C/m (a number; 0 = open circuit)", v)
        kw["floating"] = {t: float(v) for t, v in floating.items()}
        material = self.material(b["material"], f"{where}.material")
        material = self.frame(material, b, where, dim)
        try:
            return Body(mesh, material, name=str(name), **kw)
        except CvxContactError as exc:
            raise SceneFileError(f"{self.path}: {where}: {exc}") from exc

    def prescribed(self, value, key, dim=2):
        """[ux, uy] (3D: [ux, uy, uz]) in m, "free" for a free component."""
        if not isinstance(value, list) or len(value) != dim or not all(
                v == "free" or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in value):
            self.fail(key, f'a list [{", ".join("u" + c for c in "xyz"[:dim])}] of numbers (m) or "free"', value)
        return tuple(None if v == "free" else float(v) for v in value)

    def frame(self, material, b, where, dim=2):
        """The material turned by ``rotation`` (2D: radians, CCW; 3D: a 3x3 rotation matrix whose columns are
        the turned axes, the poling axis its last column) and, in 2D, reduced to ``plane`` = "stress"."""
        if dim == 3:
            if "plane" in b:
                raise SceneFileError(f"{self.path}: {where}.plane: plane strain or stress applies to 2D bodies only; "
                                     "this body's mesh is tetrahedral (3D): remove the key")
            if "rotation" not in b:
                return material
            R = b["rotation"]
            if not (isinstance(R, list) and len(R) == 3 and all(isinstance(r, list) and len(r) == 3 and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in r)
                    for r in R)):
                self.fail(f"{where}.rotation", "in 3D a 3x3 rotation matrix: three rows of three numbers, e.g. "
                          "[[1, 0, 0], [0, 0, -1], [0, 1, 0]]", R)
            try:
                return material.rotated([[float(v) for v in r] for r in R])
            except CvxContactError as exc:
                raise SceneFileError(f"{self.path}: {where}.rotation: {exc}") from exc
        try:
            if "rotation" in b:
                angle = b["rotation"]
                if isinstance(angle, bool) or not isinstance(angle, (int, float)) or not math.isfinite(angle):
                    self.fail(f"{where}.rotation", "an angle in radians (a finite number, counter-clockwise)", angle)
                material = material.rotated(float(angle))
            plane = b.get("plane", "strain")
            if plane not in ("strain", "stress"):
                self.fail(f"{where}.plane", '"strain" (default) or "stress"', plane)
            return material.plane_stress() if plane == "stress" else material
        except SceneFileError:
            raise
        except CvxContactError as exc:
            raise SceneFileError(f"{self.path}: {where}: {exc}") from exc

    def tags(self, value, key):
        value = [value] if isinstance(value, str) else value
        if not isinstance(value, list) or not all(isinstance(t, str) for t in value):
            self.fail(key, "a tag or a list of tags (strings)", value)
        return value

    def load(self, value, key, ncomp, dim=2):
        """A number, or an expression of the coordinates (x, y; x, y, z in 3D), or for ``ncomp`` > 1 a list of
        ``ncomp`` of them (a list of numbers, or a callable of the coordinates returning the components)."""
        variables = VARIABLES[dim]
        if ncomp > 1:
            if not isinstance(value, list) or len(value) != ncomp:
                self.fail(key, f"a list of {ncomp} components (numbers or expressions)", value)
            comps = [self.load(v, f"{key}[{i}]", 1, dim) for i, v in enumerate(value)]
            if all(isinstance(c, float) for c in comps):
                return comps
            fs = [c if callable(c) else (lambda *xs, c=c: c + 0.0 * xs[0]) for c in comps]
            return lambda *xs: tuple(f(*xs) for f in fs)
        if isinstance(value, bool):
            self.fail(key, f"a number or an expression in {', '.join(variables)}", value)
        if isinstance(value, (int, float)):
            return float(value)
        if isinstance(value, str):
            try:
                return Expression(value, where=f"{self.path}: {key}", variables=variables)
            except ExpressionError as exc:
                raise SceneFileError(f"{self.path}: {key}: {exc}") from None
        self.fail(key, f"a number or an expression in {', '.join(variables)}", value)

    def material(self, value, key):
        if isinstance(value, str):
            norm = value.upper().replace("-", "").replace("_", "").replace(" ", "")
            if norm not in MATERIALS:
                self.fail(key, f"a built-in material {sorted(MATERIALS)} or a table of constants", value)
            return MATERIALS[norm]
        table = self.table(value, key)
        name = self.string(table, "name", key)
        try:
            if set(table) <= {"E", "nu", "name"} and {"E", "nu"} <= set(table):
                return mats.isotropic(table["E"], table["nu"], name=name)
            if set(table) & _HENCKY:
                missing = sorted(({"E", "nu"} | _HENCKY) - set(table))
                if missing:
                    self.fail(key, "a Hencky material: a table {E, nu, yield_stress, hardening} (Pa, 1, Pa, 1; "
                              f"docs/materials.md), missing {', '.join(missing)}", value)
                self.keys(table, {"E", "nu", "name"} | _HENCKY, key)
                return mats.hencky(table["E"], table["nu"], table["yield_stress"], table["hardening"], name=name)
            self.keys(table, _PIEZO | {"name"}, key)
            return mats.Piezoelectric(**table)
        except CvxContactError as exc:
            raise SceneFileError(f"{self.path}: {key}: {exc}") from exc

    def mesh(self, value, key):
        table = self.table(value, key)
        try:
            if set(table) == {"rectangle"}:
                spec = self.table(table["rectangle"], f"{key}.rectangle")
                self.keys(spec, {"x", "y", "nx", "ny", "diagonal", "segments", "cell"}, f"{key}.rectangle")
                return rectangle(**spec)
            if set(table) == {"graded_block"}:
                spec = self.table(table["graded_block"], f"{key}.graded_block")
                self.keys(spec, {"x", "y", "nx", "ny", "contact", "beta", "gamma", "center", "segments", "cell"},
                          f"{key}.graded_block")
                return graded_block(**spec)
            if set(table) == {"half_disk"}:
                spec = self.table(table["half_disk"], f"{key}.half_disk")
                self.keys(spec, {"radius", "center", "nr", "nt", "side"}, f"{key}.half_disk")
                return half_disk(**spec)
            if set(table) == {"box"}:
                spec = dict(self.table(table["box"], f"{key}.box"))
                self.keys(spec, {"x", "y", "z", "nx", "ny", "nz", "patches", "grade", "cell"}, f"{key}.box")
                if "patches" in spec:
                    self.table(spec["patches"], f"{key}.box.patches")
                if "grade" in spec:
                    grade = self.table(spec["grade"], f"{key}.box.grade")
                    self.keys(grade, {"point", "ratio"}, f"{key}.box.grade")
                    if set(grade) != {"point", "ratio"}:
                        self.fail(f"{key}.box.grade", "{ point = [x, y, z] (m), ratio = r or [rx, ry, rz] }", grade)
                    spec["grade"] = (grade["point"], grade["ratio"])
                return box(**spec)
            if set(table) == {"cylinder"}:
                spec = self.table(table["cylinder"], f"{key}.cylinder")
                self.keys(spec, {"radius", "height", "n_r", "n_z", "n_theta", "center"}, f"{key}.cylinder")
                for req in ("radius", "height"):
                    if req not in spec:
                        raise SceneFileError(f"{self.path}: {key}.cylinder: missing key {req!r}")
                return cylinder(**spec)
            if set(table) <= {"file", "region"} and isinstance(table.get("file"), str):
                return read_mesh(self.mesh_path(table["file"], f"{key}.file"), region=table.get("region"))
        except CvxContactError as exc:
            raise SceneFileError(f"{self.path}: {key}: {exc}") from exc
        self.fail(key, "{ rectangle = {...} }, { graded_block = {...} }, { half_disk = {...} } (2D), { box = {...} }, "
                       "{ cylinder = {...} } (3D) or { file = \"mesh.msh\" [, region = \"name\"] }", value)

    def mesh_path(self, name, key):
        """The mesh file ``name`` relative to the scene file, confined to its folder unless allowed."""
        if self.allow_outside:
            return self.path.parent / name
        if not name or Path(name).is_absolute():
            raise SceneFileError(f"{self.path}: {key}: expected a path relative to the scene file's folder, got "
                                 f"{name!r} (absolute paths need allow_outside=True / --allow-outside-mesh)")
        folder = self.path.parent.resolve()
        target = (folder / name).resolve()
        if not target.is_relative_to(folder):
            raise SceneFileError(f"{self.path}: {key}: {name!r} leads outside the scene file's folder {str(folder)!r} "
                                 "(after resolving '..' and symbolic links); allow it with allow_outside=True / "
                                 "--allow-outside-mesh")
        return target
