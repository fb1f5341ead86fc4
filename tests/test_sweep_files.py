"""Sweep files mean what they say: [grid] and [[case]], key paths and tags checked up front,
case ids from the resolved content, exit codes as in the README."""

import json
import re
import shutil
from pathlib import Path

import pytest

from cvxcontact.apps import cli
from cvxcontact.apps.sweep import SweepError, read_sweep, run_sweep
from cvxcontact.apps.sweep import spec as sweep_spec
from cvxcontact.io.scenefile import read_toml

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def small_scene(folder, text=None):
    text = text or (EXAMPLES / "two_blocks.toml").read_text()
    (folder / "scene.toml").write_text(text.replace("nx = 16, ny = 8", "nx = 8, ny = 4")
                                       .replace("nx = 11, ny = 6", "nx = 6, ny = 3"))


def sweep_file(folder, body):
    path = folder / "sweep.toml"
    path.write_text('scene = "scene.toml"\nmethod = "condensed"\n' + body)
    return path


def readme_sweep_block():
    section = (ROOT / "docs" / "reference" / "sweeps.md").read_text(encoding="utf-8")
    return re.search(r"```toml\n(.*?)```", section, re.S).group(1)


@pytest.mark.parametrize("source", ["readme", "example"])
def test_grid_plus_case_runs_every_grid_point_and_the_extra_case(tmp_path, source):
    text = readme_sweep_block() if source == "readme" else (EXAMPLES / "sweep.toml").read_text()
    shutil.copy(EXAMPLES / "two_blocks.toml", tmp_path / "two_blocks.toml")
    (tmp_path / "sweep.toml").write_text(text)
    data = read_toml(tmp_path / "sweep.toml")
    sweep = read_sweep(tmp_path / "sweep.toml")
    base = read_toml(EXAMPLES / "two_blocks.toml")
    grid = data["grid"]
    n_grid = 1
    for values in grid.values():
        n_grid *= len(values)
    conditions = data["conditions"]
    assert len(sweep.cases) == (n_grid + len(data["case"])) * len(conditions)
    heavy = [c for c in sweep.cases if c.name == "heavy"]
    assert len(heavy) == len(conditions)
    # the extra case is the base scene with its own overrides only
    assert heavy[0].data["body"][0]["body_force"] == [0.0, -5e9]
    assert heavy[0].data["body"][0]["mesh"] == base["body"][0]["mesh"]
    # the grid points are all there, each once per condition, with the grid's values
    points = {(c.data["body"][0]["body_force"][1], c.data["body"][0]["mesh"]["rectangle"]["nx"], c.condition)
              for c in sweep.cases if c.name != "heavy"}
    bf, nx = grid["body[0].body_force[1]"], grid["body[0].mesh.rectangle.nx"]
    assert points == {(f, n, cond) for f in bf for n in nx for cond in conditions}
    assert len({c.id for c in sweep.cases}) == len(sweep.cases)


def test_case_tables_alone_and_no_tables(tmp_path):
    small_scene(tmp_path)
    sweep = read_sweep(sweep_file(tmp_path, '[[case]]\nname = "a"\n"gap" = 0.0\n'
                                            '[[case]]\nname = "b"\n"gap" = -1e-6\n'))
    assert [c.name for c in sweep.cases] == ["a", "b"]                 # no base case added
    assert [c.data["gap"] for c in sweep.cases] == [0.0, -1e-6]
    assert [c.name for c in read_sweep(sweep_file(tmp_path, "")).cases] == ["base"]
    with pytest.raises(SweepError, match="same case"):
        read_sweep(sweep_file(tmp_path, '[grid]\n"gap" = [0.0]\n[[case]]\nname = "again"\n"gap" = 0.0\n'))
    with pytest.raises(SweepError, match="used twice"):
        read_sweep(sweep_file(tmp_path, '[[case]]\nname = "a"\n[[case]]\nname = "a"\n"gap" = 1e-9\n'))


@pytest.mark.parametrize("key, value, words", [
    ("body[0].material.E", 1e9, ["body[0].material", "not a table", "'E'"]),          # material is a name
    ("body[2].mesh", 1, ["body has 2 entries", "[2]"]),
    ("body[0].body_force[1].x", 1, ["body[0].body_force[1]", "'x'"]),
    ("body.x", 1, ["body is a list", "'x'"]),
])
def test_bad_override_paths_name_the_key(tmp_path, key, value, words):
    small_scene(tmp_path)
    with pytest.raises(SweepError) as err:
        read_sweep(sweep_file(tmp_path, f'[grid]\n"{key}" = [{value}]\n'))
    assert all(w in str(err.value) for w in words), str(err.value)
    assert key in str(err.value)


@pytest.mark.parametrize("key, value, word", [
    ("body[0].body_forc", "[0.0, 1.0]", "body_forc"),            # a misspelt key
    ("body[0].clamped", '"topp"', "topp"),                       # a misspelt tag
])
def test_invalid_cases_are_refused_up_front_with_the_key(tmp_path, key, value, word):
    small_scene(tmp_path)
    path = sweep_file(tmp_path, f'[grid]\n"{key}" = [{value}]\n"gap" = [0.0, -1e-6]\n')
    with pytest.raises(SweepError) as err:
        run_sweep(path, tmp_path / "out", workers=1)
    assert word in str(err.value) and "--skip-invalid" in str(err.value)
    assert not (tmp_path / "out").exists()                       # refused before anything is written
    code = cli.main(["sweep", str(path), "--out", str(tmp_path / "out"), "-q"])
    assert code == 1                                             # bad input: 1, never 3


def test_case_id_follows_the_resolved_content(tmp_path, monkeypatch):
    small_scene(tmp_path)
    path = sweep_file(tmp_path, '[grid]\n"gap" = [0.0, -1e-6]\n')
    ids = [c.id for c in read_sweep(path).cases]
    assert ids == [c.id for c in read_sweep(path).cases]         # deterministic
    text = (tmp_path / "scene.toml").read_text()
    assert "E = 70e9" in text
    (tmp_path / "scene.toml").write_text(text.replace("E = 70e9", "E = 200e9"))
    assert not set(ids) & {c.id for c in read_sweep(path).cases}        # a material constant
    (tmp_path / "scene.toml").write_text(text)
    monkeypatch.setattr(sweep_spec, "versions", lambda: {"cvxcontact": "9.9"})
    assert not set(ids) & {c.id for c in read_sweep(path).cases}        # the package version


def test_case_id_follows_mesh_file_contents(tmp_path):
    shutil.copy(EXAMPLES / "gmsh_scene.toml", tmp_path / "scene.toml")
    shutil.copytree(EXAMPLES / "meshes", tmp_path / "meshes")
    path = sweep_file(tmp_path, "")
    first = read_sweep(path).cases[0]
    assert set(first.provenance["mesh_files"]) == {"body[0].mesh.file", "body[1].mesh.file"}
    with open(tmp_path / "meshes" / "lower.msh", "a") as f:           # same mesh, other bytes
        f.write("\n")
    second = read_sweep(path).cases[0]
    assert second.id != first.id
    assert second.provenance["mesh_files"]["body[1].mesh.file"] != first.provenance["mesh_files"]["body[1].mesh.file"]


def test_exit_code_3_means_solved_but_checks_failed(tmp_path):
    text = (EXAMPLES / "two_blocks.toml").read_text()
    assert "tol = 1e-6" in text
    small_scene(tmp_path, text.replace("tol = 1e-6", "tol = 1e-300"))      # no solution can pass
    path = sweep_file(tmp_path, "")
    out = tmp_path / "out"
    assert cli.main(["sweep", str(path), "--out", str(out), "--workers", "1", "-q"]) == 3
    (record,) = [json.loads(p.read_text()) for p in (out / "cases").glob("*.json")]
    assert record["ok"] is False
    assert [a["attempt"] for a in record["attempts"]] == [1, 2, 3]            # the whole retry ladder
    assert record["attempts"][1]["solver_options"]["tol_feas"] == 1e-12        # tighter tolerances
    assert {record["attempts"][0]["backend"], record["attempts"][2]["backend"]} == {"condensed", "full"}
    manifest = json.loads((out / "manifest.json").read_text())
    assert [c["state"] for c in manifest["cases"]] == ["checks_failed"]


def test_retry_ladder_recovers_a_failed_solve(tmp_path):
    text = (EXAMPLES / "two_blocks.toml").read_text()
    assert "polish = true\n" in text
    small_scene(tmp_path, text.replace("polish = true\n", "polish = true\noptions = { max_iter = 3 }\n"))
    out = tmp_path / "out"
    assert cli.main(["sweep", str(sweep_file(tmp_path, "")), "--out", str(out), "--workers", "1", "-q"]) == 0
    (record,) = [json.loads(p.read_text()) for p in (out / "cases").glob("*.json")]
    first, second = record["attempts"]                      # 3 iterations are too few; the retry has 400
    assert "user_limit" in first["error"] and first["solver_options"]["max_iter"] == 3
    assert second["ok"] and second["solver_options"]["max_iter"] == 400 and record["kept_attempt"] == 2
    assert record["ok"] and record["residuals"] == second["residuals"]


def test_a_handed_over_route_says_why_in_the_record_and_the_table(tmp_path):
    """The AMG route hands a 2D scene to the sparse route (tests/test_amg_route.py): the case record, its attempt and
    the loaded table carry the reason (``SolveInfo.handed_over``); a route that hands nothing over records ""."""
    pytest.importorskip("pyamg")
    import cvxcontact as cc

    small_scene(tmp_path)
    (tmp_path / "amg.toml").write_text('scene = "scene.toml"\nmethod = "amg"\n')
    (tmp_path / "condensed.toml").write_text('scene = "scene.toml"\nmethod = "condensed"\n')
    for name in ("amg", "condensed"):
        assert cli.main(["sweep", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / name), "--workers", "1",
                         "-q"]) == 0
    (amg,) = [json.loads(p.read_text()) for p in (tmp_path / "amg" / "cases").glob("*.json")]
    (condensed,) = [json.loads(p.read_text()) for p in (tmp_path / "condensed" / "cases").glob("*.json")]
    assert amg["backend"] == "sparse" and amg["handed_over"].startswith("the AMG route cannot take it: method 'amg'")
    assert amg["attempts"][0]["handed_over"] == amg["handed_over"]
    assert condensed["backend"] == "condensed" and condensed["handed_over"] == ""
    assert condensed["attempts"][0]["handed_over"] == ""
    rows = cc.load_sweep(tmp_path / "amg").cases
    row = rows.iloc[0].to_dict() if hasattr(rows, "iloc") else rows[0]
    assert row["handed_over"] == amg["handed_over"] and row["backend"] == "sparse"
