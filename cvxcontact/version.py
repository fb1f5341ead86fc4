"""The version of the code that runs, and where it came from.

Versions follow the git tags (``v0.2.0``): setuptools-scm derives the version of a build from the tag
and the commits since, e.g. ``0.2.1.dev3+g1a2b3c4d5`` three commits after ``v0.2.0`` (``.d20260101`` is
appended when the tree had uncommitted changes). :func:`version` reads it in this order:

1. a git checkout of the package (a clone, an editable install): ``git describe`` now, in the same
   scheme, so the version follows every commit (the metadata of an editable install is frozen at
   install time);
2. an installed distribution whose files are the ones imported (a wheel or an sdist, no git needed):
   its metadata;
3. otherwise ``0+unknown``.

:func:`provenance` adds the commit, whether the tree was dirty, and the sha256 of the package's own
source files: the last changes whenever the code does, installed or not, tagged or not.
"""

from __future__ import annotations

import functools
import hashlib
import re
import subprocess
import time
from importlib import metadata
from pathlib import Path

__all__ = ["version", "provenance", "source_sha256", "UNKNOWN"]

UNKNOWN = "0+unknown"
PACKAGE = Path(__file__).resolve().parent
_TAG = re.compile(r"^v?(\d+(?:\.\d+)*)-(\d+)-g([0-9a-f]+)(-dirty)?$")


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


def from_describe(described: str, count: int | None = None, today: str | None = None) -> str:
    """The setuptools-scm version ("guess-next-dev" scheme, "node-and-date" local part, the commit cut to 9
    hex digits as setuptools-scm does) of the output of ``git describe --tags --long --dirty --abbrev=40
    --match 'v[0-9]*'``: ``v0.2.0-0-g<hash>`` -> ``0.2.0``; ``v0.2.0-3-g<hash>`` -> ``0.2.1.dev3+g<hash[:9]>``;
    a ``-dirty`` tree adds ``.d<YYYYMMDD>`` (``today``) and counts as one step past its tag. Without a tag
    (``described`` a bare hash): ``0.1.dev<count>+g<hash[:9]>``."""
    today = today or time.strftime("%Y%m%d", time.gmtime())
    m = _TAG.match(described)
    if m is None:
        dirty = described.endswith("-dirty")
        node = described.removesuffix("-dirty")[:9]
        return f"0.1.dev{count or 0}+g{node}" + (f".d{today}" if dirty else "")
    release, distance, node, dirty = m.group(1), int(m.group(2)), m.group(3)[:9], bool(m.group(4))
    if distance == 0 and not dirty:
        return release
    parts = [int(p) for p in release.split(".")]
    parts[-1] += 1
    return f"{'.'.join(map(str, parts))}.dev{distance}+g{node}" + (f".d{today}" if dirty else "")


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


@functools.lru_cache(maxsize=1)
def version() -> str:
    """The version of the imported code (see the module docstring)."""
    if _checkout():
        described = _git("describe", "--tags", "--long", "--dirty", "--abbrev=40", "--match", "v[0-9]*")
        if described is None:                                  # no tag reachable: a bare hash
            described = _git("describe", "--always", "--dirty", "--abbrev=40")
        if described:
            count = _git("rev-list", "--count", "HEAD")
            return from_describe(described, int(count) if count and count.isdigit() else None)
    return _installed() or UNKNOWN


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


@functools.lru_cache(maxsize=1)
def provenance() -> dict:
    """``version``; ``commit`` (full hash) and ``dirty`` (uncommitted changes to tracked files) when the code
    runs from a git checkout, else as recorded in the version (``+g<hash>``, ``.d<date>``), else None;
    ``source_sha256`` (:func:`source_sha256`)."""
    v = version()
    commit = dirty = None
    if _checkout():
        commit = _git("rev-parse", "HEAD")
        status = _git("status", "--porcelain", "--untracked-files=no")
        dirty = None if status is None else bool(status)
    else:
        m = re.search(r"\+g([0-9a-f]{7,40})(\.d\d{8})?", v)
        if m:
            commit, dirty = m.group(1), bool(m.group(2))
    return {"version": v, "commit": commit, "dirty": dirty, "source_sha256": source_sha256()}
