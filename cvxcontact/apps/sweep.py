"""Reference-solution generator: many cases from one scene file, resumable after any interruption.

A sweep file (TOML) names a base scene file and the cases, as overrides of its keys::

    scene = "two_blocks.toml"              # relative to the sweep file
    method = "auto"                        # optional (default "auto"): see cvxcontact.solve
    conditions = ["gamma3", "sigma1"]      # optional (default: the scene file's condition)

    [grid]                                 # optional: the cartesian product of these values
    "body[0].body_force[1]" = [-1e9, -2e9]
    "body[0].mesh.rectangle.nx" = [8, 16]

    [[case]]                               # optional: explicit cases, each a table of overrides
    name = "heavy"
    "body[0].body_force" = [0.0, -5e9]

Every case (grid point x explicit case x condition) gets an id from a hash of its
overrides, and writes into OUT/cases: ``<id>.npz`` (arrays) then ``<id>.json``
(summary, written last: a case is done exactly when its JSON exists). Failures
go to OUT/failures/<id>.json with the reason and do not stop the sweep.
OUT/manifest.json lists every case and its state. All writes are atomic, so a
sweep killed at any moment (even kill -9) loses at most the cases in flight; a
rerun completes the missing ones and never touches a finished one.

Cases that differ only in loads (:data:`cvxcontact.physics.loads.LOAD_FIELDS` of a body,
``SCENE_LOAD_FIELDS`` of the scene: the gap) share a :class:`~cvxcontact.solve.ContactSolver`
inside a worker, so they reuse its factorisations.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import os
import re
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..contact.interface import CONDITIONS
from ..errors import CvxContactError
from ..io.output import atomic_write, summary
from ..io.scenefile import SceneFileError, read_toml, scene_from_data
from ..backends import DEFAULT_METHOD, METHODS
from ..physics.loads import LOAD_FIELDS, SCENE_LOAD_FIELDS

__all__ = ["Case", "SweepError", "load_sweep", "run_sweep", "SweepReport"]

_LOAD_KEYS = frozenset(LOAD_FIELDS + SCENE_LOAD_FIELDS)     # one definition: cvxcontact/physics/loads.py
_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]")


class SweepError(SceneFileError):
    """A sweep file is missing, malformed, or overrides a key that does not exist."""


@dataclass
class Case:
    """One case: overrides of the base scene data, and the contact condition."""

    id: str
    name: str
    overrides: dict
    condition: str

    @property
    def geometry(self) -> str:
        """Key of everything but the loads: cases with equal keys can share factorisations."""
        fixed = {k: v for k, v in self.overrides.items() if not _is_load(_path(k, ""))}
        return json.dumps([fixed, self.condition], sort_keys=True)


@dataclass
class Sweep:
    path: Path
    base: dict
    method: str
    cases: list = field(default_factory=list)


def _is_load(tokens) -> bool:
    """Whether a key path names a load: ``gap`` (SCENE_LOAD_FIELDS) or ``body[i].<LOAD_FIELDS>...``.

    A changed set of driven-electrode tags is geometry; ContactSolver.accepts catches it (a case
    whose fingerprint differs gets its own solver)."""
    if tokens[0] in SCENE_LOAD_FIELDS:
        return True
    return tokens[0] == "body" and len(tokens) >= 3 and isinstance(tokens[1], int) and tokens[2] in LOAD_FIELDS


def _path(key, where):
    tokens = [m.group(1) if m.group(1) is not None else int(m.group(2)) for m in _TOKEN.finditer(key)]
    if not tokens or "".join(f".{t}" if isinstance(t, str) else f"[{t}]" for t in tokens).lstrip(".") != key:
        raise SweepError(f"{where}: {key!r} is not a key path like 'body[0].mesh.rectangle.nx'")
    return tokens


def apply_overrides(data, overrides, where):
    """A deep copy of ``data`` with each dotted key path set to its value."""
    data = copy.deepcopy(data)
    for key, value in overrides.items():
        tokens = _path(key, where)
        node = data
        for i, t in enumerate(tokens[:-1]):
            nxt = tokens[i + 1]
            try:
                if isinstance(t, int):
                    node = node[t]
                else:
                    node = node.setdefault(t, [] if isinstance(nxt, int) else {})
            except (IndexError, KeyError, TypeError, AttributeError):
                raise SweepError(f"{where}: override {key!r}: {'.'.join(map(str, tokens[:i + 1]))} "
                                 "does not exist in the scene file") from None
        last = tokens[-1]
        try:
            node[last] = value
        except (IndexError, TypeError):
            raise SweepError(f"{where}: override {key!r}: cannot set {last!r} here") from None
    return data


def load_sweep(path) -> Sweep:
    """Read a sweep file and expand its cases (see the module docstring)."""
    path = Path(path)
    data = read_toml(path, "sweep file")
    unknown = sorted(set(data) - {"scene", "method", "conditions", "grid", "case"})
    if unknown:
        raise SweepError(f"{path}: unknown key(s) {unknown}; allowed: scene, method, conditions, grid, case")
    if not isinstance(data.get("scene"), str):
        raise SweepError(f"{path}: scene: expected the path of a scene file (string)")
    scene_path = path.parent / data["scene"]
    base = read_toml(scene_path)
    method = data.get("method", DEFAULT_METHOD)
    if method not in METHODS:
        raise SweepError(f"{path}: method: expected one of {list(METHODS)}, got {method!r}")
    conditions = data.get("conditions", [base.get("condition", "gamma3")])
    if not isinstance(conditions, list) or not conditions or any(c not in CONDITIONS for c in conditions):
        raise SweepError(f"{path}: conditions: expected a non-empty list from {list(CONDITIONS)}, got {conditions!r}")
    grid = data.get("grid", {})
    if not isinstance(grid, dict) or any(not isinstance(v, list) or not v for v in grid.values()):
        raise SweepError(f"{path}: grid: expected a table of non-empty lists of values")
    explicit = data.get("case", [{}])
    if not isinstance(explicit, list) or not all(isinstance(c, dict) for c in explicit):
        raise SweepError(f"{path}: case: expected [[case]] tables")
    sweep = Sweep(scene_path, base, method)
    keys = list(grid)
    for values in itertools.product(*(grid[k] for k in keys)):
        for k, extra in enumerate(explicit):
            extra = dict(extra)
            name = str(extra.pop("name", f"case{k}" if len(explicit) > 1 else ""))
            overrides = {**dict(zip(keys, values)), **extra}
            apply_overrides(base, overrides, f"{path}: grid/case")          # fail early on bad paths
            for condition in conditions:
                digest = hashlib.sha1(json.dumps([overrides, condition, method], sort_keys=True).encode()).hexdigest()
                sweep.cases.append(Case(digest[:12], name, overrides, condition))
    ids = [c.id for c in sweep.cases]
    if len(set(ids)) != len(ids):
        raise SweepError(f"{path}: two cases have the same overrides and condition")
    return sweep


# ---------------------------------------------------------------------------------- workers

_LOCAL = threading.local()   # per worker thread: {geometry key: ContactSolver}


def run_chunk(scene_path, base, method, cases, out, allow_outside=False):
    """Solve a list of cases in this process, writing each result; returns [(id, ok, message)].
    ``allow_outside``: accept mesh files outside the scene file's folder."""
    return [_run_case(Path(scene_path), base, method, case, Path(out), allow_outside) for case in cases]


def _run_case(scene_path, base, method, case, out, allow_outside=False):
    import warnings

    from ..errors import ResidualWarning
    from ..solve import ContactSolver

    try:
        spec = scene_from_data(apply_overrides(base, case.overrides, f"case {case.id}"), scene_path,
                               allow_outside=allow_outside)
        key = (str(scene_path), method, case.geometry)
        cache = _LOCAL.__dict__.setdefault("solvers", {})
        solver = cache.get(key)
        if solver is not None and not solver.accepts(spec.scene):
            solver = None
        settings = {**spec.settings, "method": method}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResidualWarning)     # recorded in the summary ("ok": false)
            if solver is None:
                cache.clear()                                     # keep one geometry's factors in memory
                solver = cache[key] = ContactSolver(spec.scene, case.condition, **settings)
                sol = solver.solve()
            else:
                sol = solver.solve(spec.scene)
        arrays = {"x": sol.contact.x, "lam": sol.contact.lam, "jump": sol.contact.jump, "force": sol.contact.force,
                  "active": sol.contact.active}
        for k, (u, phi) in enumerate(zip(sol.u, sol.phi), start=1):
            arrays[f"u{k}"] = u
            if phi is not None:
                arrays[f"phi{k}"] = phi
        atomic_write(out / "cases" / f"{case.id}.npz", lambda p: np.savez_compressed(p, **arrays))
        info = {"case": case.id, "name": case.name, "overrides": case.overrides, "path": sol.path,
                **summary(sol)}
        text = json.dumps(info, indent=2)
        atomic_write(out / "cases" / f"{case.id}.json", lambda p: Path(p).write_text(text + "\n"))
        return case.id, True, "" if sol.ok else "checks failed"
    except Exception as exc:  # recorded per case; the sweep goes on
        reason = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
        text = json.dumps({"case": case.id, "name": case.name, "overrides": case.overrides,
                           "condition": case.condition, "error": reason}, indent=2)
        atomic_write(out / "failures" / f"{case.id}.json", lambda p: Path(p).write_text(text + "\n"))
        return case.id, False, reason


# ---------------------------------------------------------------------------------- driver

@dataclass
class SweepReport:
    total: int
    done: int
    failed: dict
    skipped: int
    seconds: float


def _state(out, case):
    if (out / "cases" / f"{case.id}.json").exists():
        return "done"
    if (out / "failures" / f"{case.id}.json").exists():
        return "failed"
    return "pending"


def _write_manifest(out, sweep, states):
    text = json.dumps({"scene": str(sweep.path), "method": sweep.method, "cases": [
        {"id": c.id, "name": c.name, "condition": c.condition, "overrides": c.overrides, "state": states[c.id],
         "result": f"cases/{c.id}.json" if states[c.id] == "done" else None} for c in sweep.cases]}, indent=2)
    atomic_write(out / "manifest.json", lambda p: Path(p).write_text(text + "\n"))


def _chunks(cases, workers):
    """Cases grouped by geometry (so that factorisations are reused), split for the workers."""
    groups: dict = {}
    for c in cases:
        groups.setdefault(c.geometry, []).append(c)
    size = max(1, min(8, -(-len(cases) // (4 * max(workers, 1)))))
    return [g[i:i + size] for g in groups.values() for i in range(0, len(g), size)]


def run_sweep(path, out, workers=None, scheduler=None, retry_failed=False, progress=None,
              allow_outside: bool = False) -> SweepReport:
    """Run (or resume) the sweep of ``path`` into the folder ``out``.

    ``workers``: local processes (default: the number of cores; 1 runs in this
    process). ``scheduler``: address of a Dask distributed scheduler, or a
    ``distributed.Client``, to run there instead. ``progress``: a callable taking
    one line of text. ``allow_outside``: accept mesh files outside the scene file's
    folder (see :func:`cvxcontact.io.scenefile.load_scene`).
    """
    if not isinstance(allow_outside, bool):
        raise SweepError(f"allow_outside must be True or False, got {allow_outside!r}")
    sweep = load_sweep(path)
    out = Path(out)
    for sub in ("cases", "failures"):
        (out / sub).mkdir(parents=True, exist_ok=True)
        for stale in (out / sub).glob(".*"):                 # temporaries of an interrupted run
            stale.unlink(missing_ok=True)
    states = {c.id: _state(out, c) for c in sweep.cases}
    if retry_failed:
        for c in sweep.cases:
            if states[c.id] == "failed":
                (out / "failures" / f"{c.id}.json").unlink()
                states[c.id] = "pending"
    todo = [c for c in sweep.cases if states[c.id] == "pending"]
    _write_manifest(out, sweep, states)
    say = progress or (lambda line: None)
    total, t0, failed = len(sweep.cases), time.perf_counter(), {}
    done_before = sum(s == "done" for s in states.values())
    say(f"{total} cases: {done_before} already done, "
        f"{sum(s == 'failed' for s in states.values())} failed before, {len(todo)} to run")
    workers = workers or os.cpu_count() or 1
    chunks = _chunks(todo, workers)
    finished = 0
    for results in _execute(chunks, sweep, out, workers, scheduler, allow_outside):
        for case_id, ok, message in results:
            finished += 1
            states[case_id] = "done" if ok else "failed"
            if not ok:
                failed[case_id] = message
        _write_manifest(out, sweep, states)
        rate = (time.perf_counter() - t0) / max(finished, 1)
        say(f"{done_before + finished - len(failed)}/{total} done, {len(failed)} failed, "
            f"ETA {rate * (len(todo) - finished):.0f} s")
    for c in sweep.cases:
        if states[c.id] == "failed" and c.id not in failed:
            failed[c.id] = json.loads((out / "failures" / f"{c.id}.json").read_text())["error"]
    return SweepReport(total=total, done=sum(s == "done" for s in states.values()), failed=failed,
                       skipped=done_before, seconds=time.perf_counter() - t0)


def _execute(chunks, sweep, out, workers, scheduler, allow_outside=False):
    args = (str(sweep.path), sweep.base, sweep.method)
    if scheduler is not None:
        try:
            from distributed import Client, as_completed as dask_completed
        except ImportError:
            raise CvxContactError("a Dask scheduler was given but dask.distributed is not installed "
                                  "(pip install 'cvxcontact[dask]')") from None
        client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
        futures = [client.submit(run_chunk, *args, chunk, str(out), allow_outside, pure=False) for chunk in chunks]
        for fut in dask_completed(futures):
            yield fut.result()
        return
    if workers == 1 or len(chunks) <= 1:
        for chunk in chunks:
            yield run_chunk(*args, chunk, str(out), allow_outside)
        return
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(run_chunk, *args, chunk, str(out), allow_outside) for chunk in chunks]
        for fut in as_completed(futures):
            yield fut.result()


def main_progress(quiet):
    """A progress printer for the command line (stderr)."""
    if quiet:
        return None
    return lambda line: print(f"[sweep] {line}", file=sys.stderr, flush=True)
