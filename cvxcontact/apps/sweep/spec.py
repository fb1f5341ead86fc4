"""Sweep files: the cases they mean, each resolved, validated and identified by its content.

Combination rule: the sweep runs every point of ``[grid]`` (the cartesian product of its value
lists, each applied to the base scene) and, in addition, every ``[[case]]`` table (the base scene
with that table's overrides only; a ``[[case]]`` is not combined with the grid). Without ``[grid]``
and ``[[case]]`` the sweep is the base scene alone. Each of these runs under every condition of
``conditions``.

Every case is resolved (overrides applied) and validated as a scene up front, before anything is
solved; a case whose id (see :func:`case_id`) equals another's is refused, naming both.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import platform
import re
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from ...backends import DEFAULT_METHOD, METHODS
from ...contact.interface import CONDITIONS
from ...errors import CvxContactError
from ...io.scenefile import SceneFileError, read_toml, scene_from_data
from ...physics.loads import LOAD_FIELDS, SCENE_LOAD_FIELDS
from ...version import provenance

__all__ = ["Case", "Sweep", "SweepError", "read_sweep", "apply_overrides", "case_id", "versions", "machine"]

_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]")
_KEYS = ("scene", "method", "conditions", "grid", "case")


class SweepError(SceneFileError):
    """A sweep file is missing, malformed, overrides a key that does not exist, or names an invalid case."""


def versions() -> dict:
    """Versions of cvxcontact (with its commit, whether the tree was dirty, and the sha256 of its source:
    :func:`cvxcontact.version.provenance`) and of the libraries that decide its numbers."""
    code = provenance()
    out = {"cvxcontact": code["version"], "cvxcontact_commit": code["commit"], "cvxcontact_dirty": code["dirty"],
           "cvxcontact_source_sha256": code["source_sha256"]}
    for name in ("cvxpy", "clarabel", "numpy", "scipy", "meshio"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def machine() -> dict:
    """The machine a case ran on."""
    import os

    return {"platform": platform.platform(), "machine": platform.machine(), "node": platform.node(),
            "python": platform.python_version(), "cpus": os.cpu_count()}


@dataclass
class Case:
    """One case: the resolved scene data (base + overrides), its condition and its content id.

    ``provenance``: the sha256 of every mesh file the scene reads and the constants of its
    materials (c, e, kappa in Pa, C/m^2, F/m), as hashed into ``id``; ``code``: the cvxcontact version and
    source sha256 hashed into ``id`` (a worker running other code refuses the case)."""

    id: str
    name: str
    overrides: dict
    condition: str
    data: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)
    invalid: str = ""
    code: dict = field(default_factory=dict)

    @property
    def geometry(self) -> str:
        """Key of everything but the loads: cases with equal keys can share factorisations."""
        data = {k: v for k, v in self.data.items() if k not in SCENE_LOAD_FIELDS}
        bodies = []
        for b in data.get("body", []) if isinstance(data.get("body"), list) else []:
            if isinstance(b, dict):
                b = {k: (sorted(v) if k == "potential" and isinstance(v, dict) else v)
                     for k, v in b.items() if k not in LOAD_FIELDS or k == "potential"}
            bodies.append(b)
        data["body"] = bodies
        fixed = {k: v for k, v in self.overrides.items() if not _is_load(_path(k, "override"))}
        return canonical([data, fixed, self.condition, self.provenance.get("mesh_files")])

    def as_task(self) -> dict:
        """What a worker needs (plain data: it crosses process boundaries)."""
        return {"id": self.id, "name": self.name, "overrides": self.overrides, "condition": self.condition,
                "data": self.data, "provenance": self.provenance, "geometry": self.geometry, "code": self.code}


@dataclass
class Sweep:
    path: Path
    scene_path: Path
    base: dict
    method: str
    cases: list = field(default_factory=list)

    @property
    def invalid(self) -> list:
        return [c for c in self.cases if c.invalid]


def canonical(obj) -> str:
    """Canonical JSON (sorted keys, no spaces) of plain data."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))


def case_id(data: dict, provenance: dict, condition: str, method: str, code) -> str:
    """The id of a case: sha256 (first 16 hex digits) of the resolved scene data, the contents of its
    mesh files, its material constants, the condition, the method, the degree (if the scene has one,
    it is in ``data``) and the code: ``code`` is the cvxcontact version and the sha256 of its source
    files (:func:`versions`), so results of other code never count as done."""
    text = canonical({"scene": data, "provenance": provenance, "condition": condition, "method": method,
                      "cvxcontact": code})
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _path(key, where):
    if not isinstance(key, str):
        raise SweepError(f"{where}: {key!r} is not a key path like 'body[0].mesh.rectangle.nx'")
    tokens = [m.group(1) if m.group(1) is not None else int(m.group(2)) for m in _TOKEN.finditer(key)]
    if not tokens or "".join(f".{t}" if isinstance(t, str) else f"[{t}]" for t in tokens).lstrip(".") != key:
        raise SweepError(f"{where}: {key!r} is not a key path like 'body[0].mesh.rectangle.nx'")
    return tokens


def _is_load(tokens) -> bool:
    """Whether a key path names a load: ``gap`` (SCENE_LOAD_FIELDS) or ``body[i].<LOAD_FIELDS>...``."""
    if tokens[0] in SCENE_LOAD_FIELDS:
        return True
    return tokens[0] == "body" and len(tokens) >= 3 and isinstance(tokens[1], int) and tokens[2] in LOAD_FIELDS


def _name(tokens):
    return "".join(f".{t}" if isinstance(t, str) else f"[{t}]" for t in tokens).lstrip(".")


def _describe(node):
    kind = "a list" if isinstance(node, list) else "a table" if isinstance(node, dict) else f"the value {node!r}"
    return kind


def apply_overrides(data, overrides, where):
    """A deep copy of ``data`` with each key path set to its value. A missing key of a table is
    created (the scene validation then names it if the scene file has no such key); indexing past
    the end of a list, a key on a list or anything on a plain value is refused, naming the key."""
    data = copy.deepcopy(data)
    for key, value in overrides.items():
        tokens = _path(key, where)
        node = data
        for i, t in enumerate(tokens):
            last = i == len(tokens) - 1
            here = _name(tokens[:i]) or "the scene"
            if isinstance(t, int):
                if not isinstance(node, list):
                    raise SweepError(f"{where}: override {key!r}: {here} is {_describe(node)}, not a list; "
                                     f"it has no entry [{t}]")
                if t >= len(node):
                    raise SweepError(f"{where}: override {key!r}: {here} has {len(node)} entries; [{t}] does not "
                                     "exist in the scene file")
            elif not isinstance(node, dict):
                raise SweepError(f"{where}: override {key!r}: {here} is {_describe(node)}, not a table; it has no "
                                 f"key {t!r}")
            if last:
                node[t] = value
            elif isinstance(t, int):
                node = node[t]
            else:
                node = node.setdefault(t, [] if isinstance(tokens[i + 1], int) else {})
    return data


def _provenance(spec, data, scene_path, allow_outside):
    """sha256 of each mesh file read and the constants of each material of a validated scene."""
    meshes = {}
    for k, b in enumerate(data.get("body", [])):
        mesh = b.get("mesh", {})
        if isinstance(mesh, dict) and isinstance(mesh.get("file"), str):
            path = scene_path.parent / mesh["file"]
            meshes[f"body[{k}].mesh.file"] = hashlib.sha256(path.read_bytes()).hexdigest()
    materials = []
    for b in spec.scene.bodies:
        m = b.material
        const = {"c": m.c.tolist()}
        if getattr(m, "piezoelectric", False):
            const.update(e=m.e.tolist(), kappa=m.kappa.tolist(), c12=m.c12)
        materials.append(const)
    return {"mesh_files": meshes, "materials": materials}


def resolve(data, scene_path, allow_outside=False):
    """Validate resolved scene ``data``; its provenance (mesh hashes, material constants)."""
    spec = scene_from_data(data, scene_path, allow_outside=allow_outside)
    return spec, _provenance(spec, data, scene_path, allow_outside)


def scene_file(path: Path, name: str, allow_outside: bool) -> Path:
    """The base scene file ``name`` of the sweep file ``path``: relative to the sweep file's folder and
    confined to it (after resolving '..' and symbolic links), like mesh paths in scene files, unless
    ``allow_outside``."""
    if allow_outside:
        return path.parent / name
    if not name or Path(name).is_absolute():
        raise SweepError(f"{path}: scene: expected a path relative to the sweep file's folder, got {name!r} "
                         "(absolute paths need allow_outside=True / --allow-outside-mesh)")
    folder = path.parent.resolve()
    target = (folder / name).resolve()
    if not target.is_relative_to(folder):
        raise SweepError(f"{path}: scene: {name!r} leads outside the sweep file's folder {str(folder)!r} (after "
                         "resolving '..' and symbolic links); allow it with allow_outside=True / --allow-outside-mesh")
    return path.parent / name


def read_sweep(path, allow_outside: bool = False) -> Sweep:
    """Read a sweep file, expand, resolve and validate its cases (see the module docstring).

    A case whose scene is invalid (e.g. ``nu = 0.7``) gets ``invalid`` set to the reason; a bad
    key path, a duplicate case, or a malformed sweep file raises :class:`SweepError`."""
    if not isinstance(allow_outside, bool):
        raise SweepError(f"allow_outside must be True or False, got {allow_outside!r}")
    path = Path(path)
    data = read_toml(path, "sweep file")
    unknown = sorted(set(data) - set(_KEYS))
    if unknown:
        raise SweepError(f"{path}: unknown key(s) {unknown}; allowed: {', '.join(_KEYS)}")
    if not isinstance(data.get("scene"), str):
        raise SweepError(f"{path}: scene: expected the path of a scene file (string)")
    scene_path = scene_file(path, data["scene"], allow_outside)
    base = read_toml(scene_path)
    method = data.get("method", DEFAULT_METHOD)
    if method not in METHODS:
        raise SweepError(f"{path}: method: expected one of {list(METHODS)}, got {method!r}")
    conditions = data.get("conditions", [base.get("condition", "gamma3")])
    if not isinstance(conditions, list) or not conditions or any(c not in CONDITIONS for c in conditions):
        raise SweepError(f"{path}: conditions: expected a non-empty list from {list(CONDITIONS)}, got {conditions!r}")
    if len(set(conditions)) != len(conditions):
        raise SweepError(f"{path}: conditions: {conditions!r} names a condition twice")
    grid = data.get("grid", {})
    if not isinstance(grid, dict) or any(not isinstance(v, list) or not v for v in grid.values()):
        raise SweepError(f"{path}: grid: expected a table of non-empty lists of values")
    explicit = data.get("case", [])
    if not isinstance(explicit, list) or not all(isinstance(c, dict) for c in explicit):
        raise SweepError(f"{path}: case: expected [[case]] tables")
    for k in grid:
        _path(k, f"{path}: grid")
    entries = []                                       # (name, where, overrides)
    if grid or not explicit:
        keys = list(grid)
        for i, values in enumerate(itertools.product(*(grid[k] for k in keys))):
            entries.append((f"grid{i}" if keys else "base", f"{path}: grid", dict(zip(keys, values))))
    names = set()
    for k, extra in enumerate(explicit):
        extra = dict(extra)
        name = extra.pop("name", f"case{k}")
        if not isinstance(name, str) or not name:
            raise SweepError(f"{path}: case[{k}].name: expected a non-empty string, got {name!r}")
        if name in names:
            raise SweepError(f"{path}: case[{k}].name: {name!r} is used twice")
        names.add(name)
        entries.append((name, f"{path}: [[case]] {name!r}", extra))
    code = {k: v for k, v in versions().items() if k in ("cvxcontact", "cvxcontact_source_sha256")}
    sweep = Sweep(path, scene_path, base, method)
    seen: dict = {}
    for name, where, overrides in entries:
        resolved = apply_overrides(base, overrides, where)   # a bad key path refuses the sweep
        try:
            _, provenance = resolve(resolved, scene_path, allow_outside)
            invalid = ""
        except (CvxContactError, OSError) as exc:
            provenance, invalid = {}, " ".join(str(exc).split())
        for condition in conditions:
            cid = case_id(resolved, provenance, condition, method, code)
            if cid in seen:
                raise SweepError(f"{path}: cases {seen[cid]!r} and {name!r} are the same case (same resolved scene "
                                 f"and condition {condition!r}); remove one")
            seen[cid] = name
            sweep.cases.append(Case(cid, name, overrides, condition, resolved, provenance, invalid, code))
    return sweep
