"""A sweep's inputs and code are what its results say: the sweep file's scene confined to its folder, the
version (tests/test_version.py) and the case id following the source code, the commit in the provenance; the
library's log (routes, fallbacks, timings) and no output of its own."""

import logging
import os
import shutil
import subprocess
from pathlib import Path

import pytest

import cvxcontact as cc
from cvxcontact import version as cv
from cvxcontact.apps import cli
from cvxcontact.apps.sweep import SweepError, read_sweep, run_sweep
from cvxcontact.apps.sweep import spec as sweep_spec

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def small_scene(path):
    text = (EXAMPLES / "two_blocks.toml").read_text()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text.replace("nx = 16, ny = 8", "nx = 8, ny = 4").replace("nx = 11, ny = 6", "nx = 6, ny = 3"))


def sweep_file(folder, scene):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "sweep.toml").write_text(f'scene = "{scene}"\nmethod = "condensed"\n')
    return folder / "sweep.toml"


@pytest.mark.parametrize("where", ["parent", "absolute", "symlink"])
def test_the_scene_of_a_sweep_file_is_confined_to_its_folder(tmp_path, where, capsys):
    small_scene(tmp_path / "elsewhere" / "scene.toml")
    if where == "parent":
        name = "../elsewhere/scene.toml"
    elif where == "absolute":
        name = str(tmp_path / "elsewhere" / "scene.toml")
    else:
        (tmp_path / "sweep").mkdir()
        os.symlink(tmp_path / "elsewhere" / "scene.toml", tmp_path / "sweep" / "scene.toml")
        name = "scene.toml"
    path = sweep_file(tmp_path / "sweep", name)
    with pytest.raises(SweepError, match="outside the sweep file's folder|relative to the sweep file's folder") as err:
        read_sweep(path)
    assert "--allow-outside-mesh" in str(err.value)
    out = tmp_path / "out"
    assert cli.main(["sweep", str(path), "--out", str(out), "-q"]) == 1
    assert "scene:" in capsys.readouterr().err and not out.exists()           # refused before anything is written
    assert len(read_sweep(path, allow_outside=True).cases) == 1               # the same opt-out as mesh paths
    assert cli.main(["sweep", str(path), "--out", str(out), "-q", "--allow-outside-mesh", "--workers", "1"]) == 0


def test_a_scene_in_a_subfolder_is_inside(tmp_path):
    small_scene(tmp_path / "scenes" / "scene.toml")
    path = sweep_file(tmp_path, "scenes/scene.toml")
    assert len(read_sweep(path).cases) == 1
    with pytest.raises(SweepError, match="allow_outside must be True or False"):
        read_sweep(path, allow_outside="yes")


def test_version_and_provenance_of_this_checkout():
    p = cv.provenance()
    assert cc.__version__ == p["version"] != cv.UNKNOWN
    assert len(p["source_sha256"]) == 64
    if cv._checkout():                                  # a git checkout (the suite's usual case)
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout
        assert p["commit"] == head.strip() and isinstance(p["dirty"], bool)
    v = sweep_spec.versions()
    assert v["cvxcontact"] == p["version"] and v["cvxcontact_commit"] == p["commit"]


def test_the_case_id_follows_the_source_code(tmp_path, monkeypatch):
    small_scene(tmp_path / "scene.toml")
    path = sweep_file(tmp_path, "scene.toml")
    first = read_sweep(path).cases[0].id
    real = sweep_spec.versions()
    monkeypatch.setattr(sweep_spec, "versions", lambda: {**real, "cvxcontact_source_sha256": "0" * 64})
    assert read_sweep(path).cases[0].id != first       # same version string, other code: another case
    monkeypatch.setattr(sweep_spec, "versions", lambda: {**real, "cvxcontact_commit": "f" * 40, "cvxcontact_dirty": True})
    assert read_sweep(path).cases[0].id == first       # the commit alone is provenance, not identity


def test_source_hash_changes_with_a_source_file(tmp_path, monkeypatch):
    cv.source_sha256.cache_clear()                      # the files as they are now (cached once per process)
    original = cv.source_sha256()
    copy = tmp_path / "cvxcontact"
    shutil.copytree(cv.PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(cv, "PACKAGE", copy)
    cv.source_sha256.cache_clear()
    try:
        same = cv.source_sha256()                       # an identical copy elsewhere: the same hash
        with open(copy / "solve.py", "a") as f:
            f.write("\n# a comment\n")
        cv.source_sha256.cache_clear()
        other = cv.source_sha256()                      # one changed file: another hash
    finally:
        cv.source_sha256.cache_clear()
    assert same == original != other


def test_results_record_the_code(tmp_path):
    small_scene(tmp_path / "scene.toml")
    path = sweep_file(tmp_path, "scene.toml")
    run_sweep(path, tmp_path / "out", workers=1)
    record = cc.load_sweep(tmp_path / "out").record(read_sweep(path).cases[0].id)
    p = cv.provenance()
    assert record["versions"]["cvxcontact"] == p["version"]
    assert record["versions"]["cvxcontact_commit"] == p["commit"]
    assert record["versions"]["cvxcontact_source_sha256"] == p["source_sha256"]


def test_the_library_logs_routes_and_timings_and_prints_nothing(caplog, capsys):
    from cvxcontact.apps.demo import two_blocks

    with caplog.at_level(logging.DEBUG, logger="cvxcontact"):
        cc.solve(two_blocks(8), "gamma3")
    assert capsys.readouterr() == ("", "")
    messages = {r.name: [] for r in caplog.records}
    for r in caplog.records:
        messages[r.name].append((r.levelno, r.getMessage()))
    assert (logging.INFO, "method 'auto': backend 'condensed' (2 bodies, condition gamma3)") in messages["cvxcontact.solve"]
    assert any(level == logging.INFO and "backend 'condensed'" in m and "route" in m
               for level, m in messages["cvxcontact.backends.run"])
    assert any(level == logging.DEBUG and m.startswith("stage timings (s): assembly") for level, m in messages["cvxcontact.solve"])


def test_cli_verbose_shows_the_log(tmp_path, capsys):
    small_scene(tmp_path / "scene.toml")
    logger = logging.getLogger("cvxcontact")
    handlers, level = list(logger.handlers), logger.level
    try:
        assert cli.main(["-v", "solve", str(tmp_path / "scene.toml"), "--out", str(tmp_path / "o"), "--no-plots",
                         "-q"]) == 0
    finally:
        logger.handlers[:], logger.level = handlers, level
    err = capsys.readouterr().err
    assert "[cvxcontact.solve] INFO method" in err and "DEBUG" not in err


def test_a_worker_running_other_code_refuses_the_case(tmp_path, monkeypatch):
    from cvxcontact.apps.sweep import worker

    small_scene(tmp_path / "scene.toml")
    sweep = read_sweep(sweep_file(tmp_path, "scene.toml"))
    real = sweep_spec.versions()
    monkeypatch.setattr(worker, "versions", lambda: {**real, "cvxcontact_source_sha256": "0" * 64})
    from cvxcontact.apps.sweep.store import prepare_out

    out = prepare_out(tmp_path / "out")
    case_id, state, message = worker.solve_case(sweep.cases[0].as_task(), sweep.scene_path, "condensed", out)
    assert state == "failed" and "other cvxcontact code" in message
