"""The version of the code that runs, and where it came from.

The version is one number in one place: ``project.version`` in ``pyproject.toml`` (equal to
CITATION.cff's ``version`` and to CHANGELOG.md's newest release; tests/test_version.py checks it). No
git tags are needed: a clone without tags, an archive of the files, a wheel and an editable install all
name the same version. :func:`version` reads it

1. from the installed distribution's metadata when its files are the ones imported (a wheel or an
   sdist installed with pip);
2. else from the ``pyproject.toml`` beside the package (a source checkout, an editable install, whose
   metadata is frozen at install time, or a copy of the files);
3. else ``0+unknown``.

Between two commits of one version, :func:`provenance` tells the code apart: the commit and whether the
tree was dirty (from git in a checkout; in an installed wheel, as recorded at build time by setup.py in
``cvxcontact/_build.json``), and the sha256 of the package's own source files, which changes whenever the
code does, installed or not.
"""

from __future__ import annotations

import functools
import hashlib
import json
import subprocess
import tomllib
from importlib import metadata
from pathlib import Path

__all__ = ["version", "provenance", "source_sha256", "UNKNOWN"]

UNKNOWN = "0+unknown"
PACKAGE = Path(__file__).resolve().parent
BUILD_RECORD = "_build.json"         # {"commit": ..., "dirty": ...} written into a wheel by setup.py


def _git(*args: str) -> str | None:
    """Output of ``git -C <package folder> args``, or None (no git, not a checkout, an error)."""
    try:
        run = subprocess.run(["git", "-C", str(PACKAGE), *args], capture_output=True, text=True, timeout=10,
                             check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return run.stdout.strip() if run.returncode == 0 else None


@functools.lru_cache(maxsize=1)
def _checkout() -> bool:
    """True if the package imported is the ``cvxcontact/`` folder of a git work tree (not a copy that
    merely sits inside some other repository, e.g. a virtual environment kept in a project's tree)."""
    top = _git("rev-parse", "--show-toplevel")
    return top is not None and (Path(top) / "cvxcontact" / "__init__.py").resolve() == PACKAGE / "__init__.py"


def _installed() -> str | None:
    """The metadata version of the installed distribution, if its files are the ones imported."""
    try:
        dist = metadata.distribution("cvxcontact")
    except metadata.PackageNotFoundError:
        return None
    try:
        if Path(dist.locate_file("cvxcontact/__init__.py")).resolve() != PACKAGE / "__init__.py":
            return None
    except (OSError, TypeError, NotImplementedError):
        return None
    return dist.version


def from_pyproject(path: Path) -> str | None:
    """``project.version`` of the pyproject.toml at ``path`` if it is cvxcontact's and states its version,
    else None (no such file, unreadable, another project's, a dynamic version)."""
    try:
        project = tomllib.loads(path.read_text(encoding="utf-8")).get("project")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    if not isinstance(project, dict) or project.get("name") != "cvxcontact":
        return None
    found = project.get("version")
    return found if isinstance(found, str) and found else None


@functools.lru_cache(maxsize=1)
def version() -> str:
    """The version of the imported code (see the module docstring)."""
    return _installed() or from_pyproject(PACKAGE.parent / "pyproject.toml") or UNKNOWN


@functools.lru_cache(maxsize=1)
def source_sha256() -> str:
    """sha256 over the package's Python source files (their paths relative to the package and their bytes)."""
    h = hashlib.sha256()
    for path in sorted(PACKAGE.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        h.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0")
        h.update(path.read_bytes() + b"\0")
    return h.hexdigest()


def _built_from() -> tuple[str | None, bool | None]:
    """(commit, dirty) recorded in an installed wheel at build time, else (None, None)."""
    try:
        record = json.loads((PACKAGE / BUILD_RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None, None
    commit, dirty = (record.get("commit"), record.get("dirty")) if isinstance(record, dict) else (None, None)
    return (commit if isinstance(commit, str) else None), (dirty if isinstance(dirty, bool) else None)


@functools.lru_cache(maxsize=1)
def provenance() -> dict:
    """``version`` (:func:`version`); ``commit`` (full hash) and ``dirty`` (uncommitted changes to tracked
    files) from git when the code runs from a checkout, else as recorded when its wheel was built, else
    None; ``source_sha256`` (:func:`source_sha256`)."""
    if _checkout():
        commit = _git("rev-parse", "HEAD")
        status = _git("status", "--porcelain", "--untracked-files=no")
        dirty = None if status is None else bool(status)
    else:
        commit, dirty = _built_from()
    return {"version": version(), "commit": commit, "dirty": dirty, "source_sha256": source_sha256()}
