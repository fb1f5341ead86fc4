"""Build hook (the metadata is in pyproject.toml): a wheel built from a git checkout records the commit it
was built from and whether the tree was dirty in ``cvxcontact/_build.json``, so that an installed copy's
provenance (:func:`cvxcontact.version.provenance`) still names its commit. Not written for an editable
install (the package is the checkout, which git answers for) nor without git (an sdist: None)."""

import json
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


def _git(*args):
    try:
        run = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return run.stdout.strip() if run.returncode == 0 else None


class BuildWithCommit(build_py):
    def run(self):
        super().run()
        top = _git("rev-parse", "--show-toplevel")
        if getattr(self, "editable_mode", False) or self.dry_run or top is None or Path(top).resolve() != ROOT:
            return
        status = _git("status", "--porcelain", "--untracked-files=no")
        record = {"commit": _git("rev-parse", "HEAD"), "dirty": None if status is None else bool(status)}
        target = Path(self.build_lib) / "cvxcontact" / "_build.json"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(json.dumps(record) + "\n", encoding="utf-8")


if __name__ == "__main__":         # as setuptools.build_meta runs it (tests/test_version.py imports it)
    setup(cmdclass={"build_py": BuildWithCommit})
