"""Reading a sweep's results back: ``r = cc.load_sweep(folder)``.

``r.cases`` is the table of cases (one row per case of the manifest: its id, name, condition, state, its
overrides as flattened columns, the checks, timings, how it was solved and its readings: energy, floating
electrodes' potentials, obstacles' forces and translations, :func:`readings`); ``r.arrays(id)`` the arrays
of one case with their units; ``r.export(folder)`` writes the fields as XDMF + HDF5 for ParaView. The
folder is only read: loading while a sweep runs on it is safe (every file is written whole, the manifest
last), and shows the cases finished so far.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np

from ...errors import SweepResultsError
from .store import CASES, FAILURES, array_unit, arrays_dim, case_state, record_fault

__all__ = ["load_sweep", "SweepResults", "CaseArrays", "SweepResultsError", "flatten", "readings"]


def flatten(value, key: str = "") -> dict:
    """Nested lists and tables as ``{key path: number or string}``: ``{"f": [0, -5e9]}`` ->
    ``{"f[0]": 0, "f[1]": -5e9}``, ``{"m": {"nx": 8}}`` -> ``{"m.nx": 8}`` (the sweep file's key syntax)."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            out.update(flatten(v, f"{key}.{k}" if key else str(k)))
        return out
    if isinstance(value, list):
        out = {}
        for i, v in enumerate(value):
            out.update(flatten(v, f"{key}[{i}]"))
        return out
    return {key: value}


class CaseArrays(Mapping):
    """The arrays of one case (read-only NumPy arrays by name) and ``units`` ({name: unit}, SI; "1" for
    indices and flags; see :data:`cvxcontact.apps.sweep.store.ARRAY_UNITS`), ``record`` the case's JSON."""

    def __init__(self, arrays: dict, units: dict, record: dict):
        self._arrays, self.units, self.record = arrays, units, record

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._arrays[name]
        except KeyError:
            raise KeyError(f"case {self.record.get('case')} has no array {name!r}; it has "
                           f"{sorted(self._arrays)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __repr__(self) -> str:
        return f"CaseArrays({self.record.get('case')}: " + ", ".join(
            f"{k} {tuple(v.shape)} [{self.units.get(k)}]" for k, v in self._arrays.items()) + ")"


def _read_json(path: Path):
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def readings(record: dict) -> dict:
    """The physical readings of a case record as table columns, each named with its unit:

    * the energy: ``energy_J_per_m`` in 2D (per unit thickness), ``energy_J`` in 3D (the record's key);
    * each floating electrode's potential: ``<body>.<part>_V`` (the body's name, the electrode's boundary part);
    * each rigid obstacle k (1-based, the scene's order): ``obstacle<k>.translation_m[i]`` and its contact
      force ``obstacle<k>.contact_force_N_per_m[i]`` (2D) or ``obstacle<k>.contact_force_N[i]`` (3D);
    * the error estimate's relative value ``estimate_rel`` (:attr:`Solution.estimate`, docs/accuracy.md; None
      when the case has none).

    Records of older sweeps (a missing or ill-typed entry) give the columns they have."""
    out = {k: record[k] for k in ("energy_J_per_m", "energy_J") if k in record}
    estimate = record.get("estimate")
    out["estimate_rel"] = estimate.get("relative") if isinstance(estimate, dict) else None
    electrodes = record.get("electrodes")
    for e in electrodes if isinstance(electrodes, list) else ():
        if isinstance(e, dict) and e.get("kind") == "floating" and "potential_V" in e:
            body = e.get("body_name") or f"body {e.get('body')}"
            out[f"{body}.{e.get('tag')}_V"] = e["potential_V"]
    obstacles = record.get("obstacles")
    for k, o in enumerate(obstacles if isinstance(obstacles, list) else (), start=1):
        if isinstance(o, dict):
            out.update(flatten({key: o[key] for key in ("translation_m", "contact_force_N_per_m", "contact_force_N")
                                if isinstance(o.get(key), list)}, f"obstacle{k}"))
    return out


def _row(case: dict, record: dict | None, failure: dict | None, state: str) -> dict:
    row = {"id": case["id"], "name": case.get("name"), "condition": case.get("condition"), "state": state}
    row.update(flatten(case.get("overrides") or {}))
    if record is not None:
        row.update({"ok": record.get("ok"), "status": record.get("status"), "polished": record.get("polished"),
                    "route": record.get("route"), "backend": record.get("backend"),
                    "handed_over": record.get("handed_over"),
                    "iterations": record.get("iterations"), "attempts": len(record.get("attempts") or []),
                    "kept_attempt": record.get("kept_attempt"), "tolerance": record.get("tolerance"),
                    "seconds": record.get("seconds")})
        row.update(readings(record))
        row.update({f"check.{k}": v for k, v in (record.get("residuals") or {}).items()})
        row.update({f"time.{k}": v for k, v in (record.get("timings_s") or {}).items()})
        row["cvxcontact"] = (record.get("versions") or {}).get("cvxcontact")
    if failure is not None:
        row["error"] = failure.get("error")
    return row


def _table(rows: list[dict], overrides: list[str]):
    """A pandas DataFrame of ``rows`` when pandas is installed, else the list itself (one dict per case,
    every dict with every column; None where a case has no value). Columns: id, name, condition, state,
    the ``overrides`` columns, then the rest in order of appearance."""
    columns = list(dict.fromkeys(["id", "name", "condition", "state", *overrides, *(k for r in rows for k in r)]))
    rows = [{k: r.get(k) for k in columns} for r in rows]
    try:
        import pandas
    except ImportError:
        return rows
    return pandas.DataFrame(rows, columns=columns)


class SweepResults:
    """The results of a sweep folder (see the module docstring). ``folder``; ``manifest`` (the parsed
    ``manifest.json``); ``ids`` the case ids in the sweep file's order; ``cases`` the table."""

    def __init__(self, folder: Path, manifest: dict, rows: list[dict]):
        self.folder, self.manifest, self._rows = folder, manifest, rows
        self.ids = [r["id"] for r in rows]
        overrides = dict.fromkeys(k for c in manifest["cases"] for k in flatten(c.get("overrides") or {}))
        self.cases = _table(rows, list(overrides))

    def __repr__(self) -> str:
        states = {}
        for r in self._rows:
            states[r["state"]] = states.get(r["state"], 0) + 1
        return f"SweepResults({str(self.folder)!r}: {len(self.ids)} cases, " + \
            ", ".join(f"{n} {s}" for s, n in states.items()) + ")"

    def _known(self, case_id) -> str:
        if not isinstance(case_id, str) or case_id not in self.ids:
            raise SweepResultsError(f"{case_id!r} is not a case of the sweep in {str(self.folder)!r}; its cases "
                                    f"are {self.ids[:4]}{' ...' if len(self.ids) > 4 else ''} (r.ids, r.cases)")
        return case_id

    def record(self, case_id: str) -> dict:
        """The JSON record of a case with a result (summary, checks, attempts, provenance, units)."""
        return self._load(case_id)[1]

    def arrays(self, case_id: str) -> CaseArrays:
        """The arrays of a case with a result (verified against the checksums its record names)."""
        data, record = self._load(case_id)
        units = dict(record.get("units") or {})
        units.update({k: array_unit(k, arrays_dim(data)) for k in data if not units.get(k)})   # records before units
        return CaseArrays(data, units, record)

    def _load(self, case_id):
        case_id = self._known(case_id)
        state, record = case_state(self.folder, case_id)
        if state in ("pending", "failed"):
            why = ""
            if state == "failed":
                why = f": {(_read_json(self.folder / FAILURES / f'{case_id}.json') or {}).get('error')}"
            raise SweepResultsError(f"case {case_id} has no result ({state}{why}); run the sweep (again) to "
                                    "compute it" + (" with --retry-failed" if state == "failed" else ""))
        if state == "corrupt":
            path = self.folder / CASES / f"{case_id}.json"
            fault = record_fault(_read_json(path), case_id) if path.exists() else None
            if fault is not None:
                raise SweepResultsError(f"case {case_id}: its record {str(path)!r} is damaged: {fault}; run the "
                                        "sweep again (`cvxcontact sweep SWEEP.toml --out FOLDER`) to redo it")
            raise SweepResultsError(f"case {case_id}: its files in {str(self.folder / CASES)!r} are incomplete or "
                                    "altered (a half-written or damaged result); run the sweep again to redo it")
        try:
            with np.load(self.folder / CASES / record["files"]["npz"], allow_pickle=False) as f:
                data = {k: f[k] for k in f.files}
        except (OSError, ValueError) as exc:                     # changed between the checksum and the read
            raise SweepResultsError(f"case {case_id}: cannot read its arrays: {exc}; run the sweep again") from None
        for v in data.values():
            v.flags.writeable = False
        return data, record

    def export(self, target=None, ids=None) -> list[Path]:
        """Write the fields of the cases with a result (or of ``ids``) as XDMF + HDF5 files (through meshio;
        needs h5py: ``pip install "cvxcontact[export]"``) into ``target`` (default ``<folder>/xdmf``):
        ``<id>_body<k>.xdmf`` (point data ``displacement [m]``, ``electric potential [V]``) and
        ``<id>_contact<p>.xdmf`` (the merged line of pair p: ``lambda_h [Pa]``, ``normal jump [m]``, ``gap [m]``,
        ``nodal force [N/m]``, ``active``). ParaView opens them (Xdmf3 reader). Returns the XDMF paths."""
        from .export import export_xdmf

        ids = [r["id"] for r in self._rows if r["state"] in ("done", "checks_failed")] if ids is None else \
            [self._known(i) for i in ids]
        target = Path(target) if target is not None else self.folder / "xdmf"
        return export_xdmf(self, ids, target)


def load_sweep(folder) -> SweepResults:
    """The results of the sweep whose output folder is ``folder`` (the ``--out`` of ``cvxcontact sweep``):
    ``r.cases`` (a pandas DataFrame when pandas is installed, else a list of dicts), ``r.arrays(id)``,
    ``r.record(id)``, ``r.export()``; see :mod:`cvxcontact.apps.sweep.load`.

    A case whose record is damaged (not valid JSON, another case's, a field of the wrong type) is a row in state
    ``corrupt`` with an ``error`` naming the file and the field; the other cases read as usual.

    Raises :class:`SweepResultsError` if ``folder`` is not a sweep's output folder (no readable
    ``manifest.json``)."""
    if not isinstance(folder, (str, Path)) or not str(folder):
        raise SweepResultsError(f"load_sweep(folder): expected the path of a sweep's output folder, got {folder!r}")
    folder = Path(folder)
    if not folder.is_dir():
        raise SweepResultsError(f"{str(folder)!r} is not a folder; give the output folder of a sweep "
                                "(the --out of `cvxcontact sweep SWEEP.toml --out FOLDER`)")
    manifest = _read_json(folder / "manifest.json")
    cases = manifest.get("cases") if isinstance(manifest, dict) else None
    if not isinstance(cases, list) or not all(isinstance(c, dict) and isinstance(c.get("id"), str) for c in cases):
        what = "has no manifest.json" if not (folder / "manifest.json").exists() else "has an unreadable manifest.json"
        raise SweepResultsError(f"{str(folder)!r} is not a sweep's output folder: it {what} (written by "
                                "`cvxcontact sweep SWEEP.toml --out FOLDER`)")
    rows = []
    for c in cases:
        path = folder / CASES / f"{c['id']}.json"
        record = _read_json(path)
        failure = _read_json(folder / FAILURES / f"{c['id']}.json")
        failure = failure if isinstance(failure, dict) and failure.get("case") == c["id"] else None
        fault = record_fault(record, c["id"]) if path.exists() else None
        if fault is not None:               # listed, not read: r.record / r.arrays raise, a rerun redoes it
            record, failure = None, {"error": f"{str(path)!r} is damaged: {fault}; run the sweep again to redo it"}
            state = "corrupt"
        elif record is not None:
            state = "done" if record.get("ok") else "checks_failed"
        else:
            state = "failed" if failure is not None else "pending"
        rows.append(_row(c, record, failure, state))
    return SweepResults(folder, manifest, rows)
