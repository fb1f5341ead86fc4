"""The output folder of a sweep: its lock, case files (verified on resume), failures, the manifest.

Layout of ``OUT``::

    .lock                      held (flock) by the running sweep, with its pid
    manifest.json              every case, its state and provenance
    cases/<id>.npz             arrays (u, phi, contact results, pressures, meshes; ARRAY_UNITS), written first
    cases/<id>.problem.npz     the conic problem data (with --export-problem)
    cases/<id>.json            summary, checks, attempts, provenance, units and the sha256 of the npz files;
                               written last, so a case is done exactly when its JSON is complete
                               and the files it names have the recorded checksums
    failures/<id>.json         why a case has no result
    superseded/<UTC time>/     results of an earlier input (a changed scene, mesh, material,
                               version, or a case no longer in the sweep), kept aside

Every file is written whole or not at all (:func:`atomic_write`): into a temporary
``.<name>.<random>.tmp`` in the same folder, fsynced, renamed over the final name, the folder
fsynced. A temporary never ends in ``.json`` or ``.npz``, so a listing of results
(``glob("*.json")``, which in :mod:`pathlib` also matches names starting with a dot) cannot pick
up a half-written one; a run killed mid-write leaves only such temporaries, which the next run
removes (under the lock) before it verifies what is there.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import shutil
import time
from pathlib import Path

from ...errors import CvxContactError
from ...io.output import atomic_write as _atomic_write

__all__ = ["SweepOutputError", "SweepLockedError", "FolderLock", "prepare_out", "write_json", "write_case",
           "case_state", "record_fault", "RECORD_FIELDS", "sha256", "ARRAY_UNITS", "array_unit", "FORCE_UNITS",
           "arrays_dim"]

CASES, FAILURES, SUPERSEDED = "cases", "failures", "superseded"


class SweepOutputError(CvxContactError, OSError):
    """The output folder cannot be created or written (a file in the way, no permission, disk full)."""


class SweepLockedError(CvxContactError, RuntimeError):
    """Another sweep is running on the same output folder."""


def output_error(path, exc: OSError) -> SweepOutputError:
    """A one-line, typed description of a failed write of ``path``."""
    name = errno.errorcode.get(exc.errno, "") if exc.errno else ""
    why = exc.strerror or str(exc) or type(exc).__name__
    return SweepOutputError(f"cannot write {str(path)!r}: {why}{f' ({name})' if name else ''}")


def atomic_write(path, write) -> Path:
    """``write(tmp)`` then rename to ``path``, durably (see the module docstring); ``write`` gets a
    path ending in ``.tmp``, so it must not infer the format from the extension."""
    return _atomic_write(path, write, durable=True)


def write_json(path, obj) -> Path:
    """Atomic JSON write; an OSError becomes a :class:`SweepOutputError`."""
    text = json.dumps(obj, indent=2) + "\n"
    try:
        return atomic_write(path, lambda p: Path(p).write_text(text))
    except OSError as exc:
        raise output_error(path, exc) from None


def write_npz(path, arrays) -> str:
    """Atomic npz write; returns the sha256 of the file written."""
    import numpy as np

    digest = {}

    def write(p):
        with open(p, "wb") as f:            # a file object: numpy would append ".npz" to a ".tmp" path
            np.savez_compressed(f, **arrays)
        digest["h"] = sha256(p)

    try:
        atomic_write(path, write)
    except OSError as exc:
        raise output_error(path, exc) from None
    return digest["h"]


def sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


ARRAY_UNITS = (                  # (pattern of a case array's name, its unit), the first match counts
    (r"u\d+", "m"), (r"phi\d+", "V"), (r"points\d+", "m"), (r"triangles\d+", "1"), (r"quads\d+", "1"), (r"tetrahedra\d+", "1"),
    (r"hexahedra\d+", "1"),
    (r"(contact\d+_)?(x|trace_s\d+|line_points|jump|gap|slip)", "m"),
    (r"(contact\d+_)?(lam|pressure\d+|shear|threshold)", "Pa"),
    (r"(contact\d+_)?(force|shear_force)", "N/m"), (r"(contact\d+_)?(active|constrained)", "1"),
)
"""Units of the arrays of ``cases/<id>.npz``: ``u<k>`` displacement of body k (nodes, 2) and ``phi<k>``
its electric potential; ``points<k>``/``triangles<k>`` its mesh (triangles: node indices; ``quads<k>`` for quadrilaterals, ``tetrahedra<k>`` or ``hexahedra<k>`` in 3D); contact pair 1
(pair p >= 2: the same names prefixed ``contact<p>_``): ``x`` the tangential coordinate s of the merged
nodes, ``line_points`` their coordinates, ``lam`` lambda_h (a diagnostic), ``jump`` [u_h nu], ``gap``,
``force`` the nodal forces, ``active``/``constrained`` (booleans), ``pressure<j>`` the pressure felt by
body j on its own trace nodes at ``trace_s<j>``; under a friction law ``slip`` [u_t], ``shear_force`` the
tangential nodal forces on the first body, ``shear`` its tangential traction and ``threshold`` the slip threshold g
(ContactResult's fields). "1": dimensionless (indices, flags). The nodal forces' "N/m" (per metre of depth, plane
strain) is "N" in 3D (:data:`FORCE_UNITS`)."""

FORCE_UNITS = {2: "N/m", 3: "N"}
"""The unit of a nodal force (``force``, ``shear_force``) by the scene's dimension: N/m in 2D, N in 3D."""


def array_unit(name: str, dim: int = 2) -> str | None:
    """The unit of the case array ``name`` of a scene of dimension ``dim`` (:data:`ARRAY_UNITS`,
    :data:`FORCE_UNITS`), None if unknown."""
    unit = next((unit for pattern, unit in ARRAY_UNITS if re.fullmatch(pattern, name)), None)
    return FORCE_UNITS[dim] if unit == FORCE_UNITS[2] else unit


def arrays_dim(arrays) -> int:
    """The dimension of the scene whose case arrays are ``arrays`` (its first body's ``points1``: (n, dim))."""
    return int(arrays["points1"].shape[1]) if "points1" in arrays else 2


def write_case(out, case_id, arrays, info, problem=None) -> None:
    """Write a finished case: its npz file(s) first, then the JSON naming them with checksums and the
    units of the arrays (``units``)."""
    cases = Path(out) / CASES
    files = {"npz": f"{case_id}.npz", "npz_sha256": write_npz(cases / f"{case_id}.npz", arrays)}
    if problem is not None:
        files["problem"] = f"{case_id}.problem.npz"
        files["problem_sha256"] = write_npz(cases / files["problem"], problem)
    dim = arrays_dim(arrays)
    write_json(cases / f"{case_id}.json", {**info, "units": {k: array_unit(k, dim) for k in arrays}, "files": files})


def _read_json(path):
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


RECORD_FIELDS = {"files": dict, "residuals": dict, "timings_s": dict, "versions": dict, "units": dict,
                 "attempts": list}     # the fields of a case record read as a table or a list (absent or null: none)
_JSON = {dict: "a table (JSON object)", list: "a list (JSON array)"}


def record_fault(info, case_id) -> str | None:
    """What makes ``info`` (a case's JSON record, None if it did not parse) unusable as the record of
    ``case_id``, or None if nothing does: not parsed, another case's, or a field of :data:`RECORD_FIELDS` of
    the wrong JSON type."""
    if not isinstance(info, dict):
        return "it is not a JSON object (a torn or damaged file)" if info is not None else \
            "it is not valid JSON (a torn or damaged file)"
    if info.get("case") != case_id:
        return f"it names case {info.get('case')!r}, not {case_id!r}"
    for field, kind in RECORD_FIELDS.items():
        value = info.get(field)
        if value is not None and not isinstance(value, kind):
            return f"its field {field!r} is {type(value).__name__} {json.dumps(value)[:40]}, not {_JSON[kind]}"
    return None


def case_state(out, case_id) -> tuple[str, dict | None]:
    """("done" | "checks_failed" | "failed" | "pending" | "corrupt", the record or None).

    A result counts only if its JSON parses, names this case, has its fields of the right types
    (:func:`record_fault`), and every file it names exists with the recorded sha256; a failure record
    only if it parses and names this case."""
    out = Path(out)
    path = out / CASES / f"{case_id}.json"
    if path.exists():
        info = _read_json(path)
        files = info.get("files") if record_fault(info, case_id) is None else None
        good = isinstance(files, dict) and "npz" in files
        if good:
            for key in ("npz", "problem"):
                if key in files:
                    f = out / CASES / str(files[key])
                    good = good and f.is_file() and sha256(f) == files.get(f"{key}_sha256")
        if good:
            return ("done" if info.get("ok") else "checks_failed"), info
        return "corrupt", None
    path = out / FAILURES / f"{case_id}.json"
    if path.exists():
        info = _read_json(path)
        if isinstance(info, dict) and info.get("case") == case_id and isinstance(info.get("error"), str):
            return "failed", info
        return "corrupt", None
    return "pending", None


def remove_case(out, case_id) -> None:
    """Remove every file of a case (before it is redone)."""
    out = Path(out)
    for p in (out / CASES / f"{case_id}.json", out / CASES / f"{case_id}.npz",
              out / CASES / f"{case_id}.problem.npz", out / FAILURES / f"{case_id}.json"):
        p.unlink(missing_ok=True)


def supersede(out, keep_ids) -> tuple[int, Path | None]:
    """Move the results and failures of cases not in ``keep_ids`` to ``OUT/superseded/<UTC time>/``."""
    out = Path(out)
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    target, moved = out / SUPERSEDED / stamp, set()
    for sub in (CASES, FAILURES):
        for p in sorted((out / sub).glob("*")):
            if p.name.startswith(".") or not p.is_file():
                continue
            cid = p.name.split(".", 1)[0]
            if cid in keep_ids:
                continue
            try:
                (target / sub).mkdir(parents=True, exist_ok=True)
                shutil.move(str(p), str(target / sub / p.name))
            except OSError as exc:
                raise output_error(target / sub / p.name, exc) from None
            moved.add(cid)
    return len(moved), (target if moved else None)


def prepare_out(out) -> Path:
    """Create ``OUT``, ``OUT/cases`` and ``OUT/failures``; a typed error if impossible."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise SweepOutputError(f"--out {str(out)!r} names a file, not a folder; give a folder for the results")
    for sub in (out, out / CASES, out / FAILURES):
        try:
            sub.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SweepOutputError(f"cannot create the output folder {str(sub)!r}: "
                                   f"{exc.strerror or exc}") from None
        if not os.access(sub, os.W_OK | os.X_OK):
            raise SweepOutputError(f"the output folder {str(sub)!r} is not writable")
    return out


def clean_temporaries(out) -> None:
    """Remove the temporaries of an interrupted run (only ever called under the folder's lock)."""
    for sub, pattern in ((CASES, ".*"), (FAILURES, ".*"), (".", ".manifest.*")):
        for stale in (Path(out) / sub).glob(pattern):
            if stale.is_file():
                stale.unlink(missing_ok=True)


class FolderLock:
    """An exclusive lock on a sweep's output folder: ``OUT/.lock`` held with ``fcntl.flock``
    (released by the kernel when the process dies, kill -9 included), holding the pid. Without
    fcntl (Windows) the file is created with O_EXCL and a stale one (dead pid) is taken over."""

    def __init__(self, out):
        self.path = Path(out) / ".lock"
        self.fd = None

    def __enter__(self):
        try:
            import fcntl
        except ImportError:                                    # pragma: no cover - not on POSIX
            fcntl = None
        try:
            if fcntl is not None:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    os.close(fd)
                    raise SweepLockedError(self._busy()) from None
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode())
            else:                                              # pragma: no cover
                fd = self._exclusive()
        except OSError as exc:
            raise SweepOutputError(f"cannot lock the output folder ({str(self.path)!r}): "
                                   f"{exc.strerror or exc}") from None
        self.fd = fd
        return self

    def _busy(self):
        try:
            pid = self.path.read_text().strip() or "?"
        except OSError:
            pid = "?"
        return (f"the output folder {str(self.path.parent)!r} is in use by another sweep (pid {pid}); "
                "wait for it to finish or stop it, or choose another --out")

    def _exclusive(self):                                      # pragma: no cover - Windows fallback
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
                os.write(fd, f"{os.getpid()}\n".encode())
                return fd
            except FileExistsError:
                try:
                    pid = int(self.path.read_text().strip())
                    os.kill(pid, 0)
                except (ValueError, OSError):
                    self.path.unlink(missing_ok=True)          # its owner is gone
                    continue
                raise SweepLockedError(self._busy()) from None
        raise SweepLockedError(self._busy())

    def __exit__(self, *exc):
        if self.fd is not None:
            try:
                import fcntl

                fcntl.flock(self.fd, fcntl.LOCK_UN)
            except ImportError:                                # pragma: no cover
                self.path.unlink(missing_ok=True)
            os.close(self.fd)
            self.fd = None
        return False
