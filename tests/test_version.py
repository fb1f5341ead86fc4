"""One version, written once (pyproject.toml's ``project.version``), named alike by CITATION.cff, CHANGELOG.md's
newest release, ``cvxcontact --version``, the installed metadata and ``cc.__version__``, with or without git
tags or git itself; the provenance keeps the commit and the source hash."""

import ast
import json
import re
import shutil
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

import cvxcontact as cc
from cvxcontact import version as cv
from cvxcontact.apps import cli

ROOT = Path(__file__).resolve().parents[1]


def source_version() -> str:
    """pyproject.toml's version, parsed here (not by the code under test)."""
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]


def test_pyproject_citation_and_changelog_name_one_version():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" not in pyproject["project"].get("dynamic", [])          # static: no git tags needed
    assert not any("setuptools-scm" in r or "setuptools_scm" in r for r in pyproject["build-system"]["requires"])
    assert "setuptools_scm" not in pyproject.get("tool", {})
    v = source_version()
    assert re.fullmatch(r"\d+\.\d+\.\d+", v)
    cff = re.search(r'^version: "([^"]+)"$', (ROOT / "CITATION.cff").read_text(encoding="utf-8"), re.M).group(1)
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    newest = re.search(r"^## \[(\d+\.\d+\.\d+)\] - (\d{4}-\d{2}-\d{2})$", changelog, re.M)
    assert v == cff == newest.group(1)
    date = re.search(r'^date-released: "([^"]+)"$', (ROOT / "CITATION.cff").read_text(encoding="utf-8"), re.M)
    assert date.group(1) == newest.group(2)                                   # the release's date, once more


def test_the_cli_the_package_and_the_source_agree(capsys):
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"cvxcontact {source_version()}" == f"cvxcontact {cc.__version__}"


def test_the_installed_metadata_agrees():
    """Where the imported package is the installed distribution (.ci/run's installs; a dev checkout imports
    its own files, and an editable install's metadata is frozen at install time, so there it is skipped)."""
    if cv._installed() is None:
        pytest.skip("the imported cvxcontact is not the installed distribution (a checkout on sys.path)")
    assert metadata.version("cvxcontact") == cc.__version__ == source_version()


def test_the_version_is_not_read_from_git():
    """The version code asks git for nothing but the commit and the dirty flag (no ``git describe``, whose
    answer depends on tags that a clone with --no-tags or an archive lacks)."""
    tree = ast.parse(Path(cv.__file__).read_text(encoding="utf-8"))
    strings = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    assert "describe" not in strings and "--tags" not in strings


def run_copy(where: Path, code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], cwd=where, env={"PYTHONPATH": str(where), "PATH": ""},
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_a_copy_without_git_names_the_version_and_the_source_hash(tmp_path):
    """The package and pyproject.toml copied where there is no .git (an archive of the files): the version is
    pyproject's, the commit unknown (None), the source hash the same as here."""
    shutil.copytree(cv.PACKAGE, tmp_path / "cvxcontact", ignore=shutil.ignore_patterns("__pycache__", "_build.json"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    got = json.loads(run_copy(tmp_path, "import json, cvxcontact, cvxcontact.version as v; "
                                        "print(json.dumps([cvxcontact.__file__, cvxcontact.__version__, v.provenance()]))"))
    where, version, provenance = got
    assert Path(where).resolve() == (tmp_path / "cvxcontact" / "__init__.py").resolve()
    assert version == provenance["version"] == source_version()
    assert provenance["commit"] is None and provenance["dirty"] is None
    assert provenance["source_sha256"] == cv.source_sha256()
    # without its pyproject.toml (and not installed there): unknown, never a made-up number
    (tmp_path / "pyproject.toml").unlink()
    assert run_copy(tmp_path, "import cvxcontact; print(cvxcontact.__version__)") == cv.UNKNOWN


def test_a_wheel_records_its_commit(tmp_path):
    """An installed copy (not a checkout) names the commit its wheel was built from (setup.py writes
    ``cvxcontact/_build.json``); a damaged record is ignored, not trusted."""
    shutil.copytree(cv.PACKAGE, tmp_path / "cvxcontact", ignore=shutil.ignore_patterns("__pycache__", "_build.json"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    commit = "0123456789abcdef0123456789abcdef01234567"
    code = "import json, cvxcontact.version as v; p = v.provenance(); print(json.dumps([p['commit'], p['dirty']]))"
    (tmp_path / "cvxcontact" / cv.BUILD_RECORD).write_text(json.dumps({"commit": commit, "dirty": False}))
    assert json.loads(run_copy(tmp_path, code)) == [commit, False]
    (tmp_path / "cvxcontact" / cv.BUILD_RECORD).write_text("{not json")
    assert json.loads(run_copy(tmp_path, code)) == [None, None]


def test_a_checkout_names_its_commit():
    p = cv.provenance()
    if not cv._checkout():
        pytest.skip("not a git checkout (an installed package)")
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout
    assert p["commit"] == head.strip() and isinstance(p["dirty"], bool) and p["version"] == source_version()


def test_setup_py_records_the_commit_of_the_checkout_it_builds(tmp_path):
    """setup.py's build hook, run on its own (no pip, no network, no package to build): it writes the commit
    of the checkout it sits in into the build folder, and nothing for an editable install."""
    if shutil.which("git") is None or not (ROOT / ".git").exists() or not (ROOT / "setup.py").exists():
        pytest.skip("not a git checkout of the sources")
    import importlib.util

    from setuptools.dist import Distribution

    spec = importlib.util.spec_from_file_location("cvxcontact_setup", ROOT / "setup.py")
    setup = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(setup)

    def build(target, editable=False):
        command = setup.BuildWithCommit(Distribution({"name": "cvxcontact", "packages": []}))
        command.initialize_options()
        command.build_lib, command.editable_mode = str(target), editable
        command.finalize_options()
        command.run()
        return target / "cvxcontact" / cv.BUILD_RECORD

    record = json.loads(build(tmp_path / "lib").read_text())
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout
    assert record["commit"] == head.strip() and isinstance(record["dirty"], bool)
    assert not build(tmp_path / "editable", editable=True).exists()
