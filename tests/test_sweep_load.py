"""Reference solutions people can load: cc.load_sweep(folder) gives the table of cases and each case's
arrays with units; typed errors for what is not a (complete) result; the XDMF export when h5py is there."""

import json
import shutil
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.sweep import SweepResultsError, run_sweep
from cvxcontact.apps.sweep.spec import apply_overrides
from cvxcontact.contact.interface import lumped_lengths
from cvxcontact.io.scenefile import read_toml, scene_from_data

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    """The README's example sweep (examples/sweep.toml, 14 cases; about 2 s on one worker), run once."""
    folder = tmp_path_factory.mktemp("example")
    for name in ("sweep.toml", "two_blocks.toml"):
        shutil.copy(EXAMPLES / name, folder / name)
    report = run_sweep(folder / "sweep.toml", folder / "out", workers=1)
    assert report.done == report.total == 14
    return folder


def rows(table):
    return table if isinstance(table, list) else table.to_dict("records")


def test_the_readme_example_sweep_loads_into_a_table_in_one_call(example):
    r = cc.load_sweep(example / "out")
    table = rows(r.cases)
    sweep = tomllib.loads((example / "sweep.toml").read_text())
    grid, heavy = sweep["grid"], sweep["case"][0]
    assert len(table) == 14 and [t["id"] for t in table] == r.ids
    assert {t["state"] for t in table} == {"done"} and all(t["ok"] for t in table)
    assert sorted(t["condition"] for t in table) == sorted(sweep["conditions"] * 7)
    points = {(t["body[0].body_force[1]"], t["body[0].mesh.rectangle.nx"]) for t in table if t["name"] != "heavy"}
    assert points == {(f, n) for f in grid["body[0].body_force[1]"] for n in grid["body[0].mesh.rectangle.nx"]}
    for t in table:                                      # the [[case]] "heavy": its own list, flattened
        if t["name"] == "heavy":
            assert [t["body[0].body_force[0]"], t["body[0].body_force[1]"]] == heavy["body[0].body_force"]
    assert list(table[0])[:4] == ["id", "name", "condition", "state"]
    for t in table:                                      # the checks and timings of the case file
        assert t["check.equilibrium"] <= t["tolerance"] and t["check.complementarity"] <= t["tolerance"]
        assert t["seconds"] > 0 and t["time.loads"] >= 0 and t["attempts"] >= 1


def test_arrays_are_the_direct_solve_with_units(example):
    r = cc.load_sweep(example / "out")
    t = next(t for t in rows(r.cases) if t["name"] == "heavy" and t["condition"] == "sigma1")
    a = r.arrays(t["id"])
    sweep = tomllib.loads((example / "sweep.toml").read_text())
    data = apply_overrides(read_toml(example / "two_blocks.toml"), {"body[0].body_force": [0.0, -5e9]}, "test")
    ref = cc.solve(scene_from_data(data, example / "two_blocks.toml").scene, "sigma1", method=sweep["method"])
    scale = np.abs(ref.u[0]).max()
    assert np.abs(a["u1"] - ref.u[0]).max() <= 1e-10 * scale and np.abs(a["u2"] - ref.u[1]).max() <= 1e-10 * scale
    assert np.abs(a["phi1"] - ref.phi[0]).max() <= 1e-10 * np.abs(ref.phi[0]).max()
    assert np.abs(a["lam"] - ref.contact.lam).max() <= 1e-8 * np.abs(ref.contact.lam).max()
    assert a.units["u1"] == "m" and a.units["phi1"] == "V" and a.units["lam"] == "Pa" and a.units["force"] == "N/m"
    assert a.units["pressure1"] == a.units["pressure2"] == "Pa" and a.units["x"] == a.units["trace_s1"] == "m"
    assert set(a.units) == set(a)
    # the pressure felt by each body carries the whole contact force (partition of unity of the traces):
    # measured relative differences 1e-16
    total = a["force"].sum()
    for j in (1, 2):
        assert a[f"pressure{j}"] @ lumped_lengths(a[f"trace_s{j}"]) == pytest.approx(total, rel=1e-12)
    assert a["pressure1"].max() > 0
    with pytest.raises(ValueError):
        a["u1"][0, 0] = 1.0                              # read-only
    assert r.record(t["id"])["units"]["u1"] == "m"


def test_without_pandas_the_table_is_a_list_of_dicts(example, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)     # import pandas raises ImportError
    table = cc.load_sweep(example / "out").cases
    assert isinstance(table, list) and len(table) == 14 and all(len(t) == len(table[0]) for t in table)


def test_with_pandas_the_table_is_a_data_frame(example):
    pandas = pytest.importorskip("pandas", reason="pandas is optional (cvxcontact[tables])")
    table = cc.load_sweep(example / "out").cases
    assert isinstance(table, pandas.DataFrame) and table.shape[0] == 14
    assert table.groupby("condition").size().to_dict() == {"gamma3": 7, "sigma1": 7}


def test_bad_folders_and_cases_are_typed_errors(example, tmp_path):
    with pytest.raises(SweepResultsError, match="is not a folder"):
        cc.load_sweep(tmp_path / "nowhere")
    with pytest.raises(SweepResultsError, match="no manifest.json"):
        cc.load_sweep(tmp_path)
    (tmp_path / "manifest.json").write_text('{"cases": [{"name": 1}]}')
    with pytest.raises(SweepResultsError, match="unreadable manifest.json"):
        cc.load_sweep(tmp_path)
    with pytest.raises(SweepResultsError, match="expected the path"):
        cc.load_sweep(3)
    out = tmp_path / "copy"
    shutil.copytree(example / "out", out)
    r = cc.load_sweep(out)
    with pytest.raises(SweepResultsError, match="is not a case of the sweep"):
        r.arrays("0123456789abcdef")
    first, second, third = r.ids[:3]
    npz = out / "cases" / f"{first}.npz"
    npz.write_bytes(npz.read_bytes()[:100])              # half-written
    with pytest.raises(SweepResultsError, match="incomplete or altered"):
        r.arrays(first)
    (out / "cases" / f"{second}.json").unlink()          # not computed (yet)
    with pytest.raises(SweepResultsError, match=r"has no result \(pending\)"):
        cc.load_sweep(out).arrays(second)
    assert rows(cc.load_sweep(out).cases)[1]["state"] == "pending"
    (out / "cases" / f"{third}.json").write_text("{")   # a torn record: the table says corrupt, no crash
    assert rows(cc.load_sweep(out).cases)[2]["state"] == "corrupt"
    with pytest.raises(SweepResultsError, match="is damaged: it is not valid JSON.*run the sweep again"):
        cc.load_sweep(out).arrays(third)


@pytest.mark.parametrize("field, wrong", [("residuals", [1e-12, 1e-13]), ("timings_s", 3.5), ("versions", "0.3.0"),
                                          ("attempts", 2)])
def test_a_record_with_a_field_of_the_wrong_type_is_a_damaged_case(example, tmp_path, field, wrong):
    """Valid JSON, the wrong type in one field: the table lists it as corrupt naming the file and the field,
    the other cases read as before; its record and arrays are a typed error; a rerun of the sweep redoes it."""
    from cvxcontact.apps.sweep.store import case_state

    out = tmp_path / "out"
    shutil.copytree(example / "out", out)
    r = cc.load_sweep(out)
    bad, good = r.ids[0], r.ids[1]
    before = rows(r.cases)
    path = out / "cases" / f"{bad}.json"
    record = json.loads(path.read_text())
    assert field in record                              # a field the writer does write
    record[field] = wrong
    path.write_text(json.dumps(record))
    r = cc.load_sweep(out)
    table = rows(r.cases)
    assert table[0]["state"] == "corrupt" and str(path) in table[0]["error"] and repr(field) in table[0]["error"]
    assert [t["state"] for t in table[1:]] == ["done"] * (len(table) - 1)
    assert {k: v for k, v in table[1].items() if k in before[1]} == before[1]   # the others: as before
    for read in (r.record, r.arrays):
        with pytest.raises(SweepResultsError, match=rf"{bad}.json'? is damaged: its field '{field}' is .* not a "
                                                    r".*run the sweep again") as err:
            read(bad)
        assert isinstance(err.value, cc.SweepResultsError) and isinstance(err.value, cc.CvxContactError)
    assert r.record(good)["case"] == good and r.arrays(good)["u1"].shape[1] == 2
    assert case_state(out, bad) == ("corrupt", None)    # what `cvxcontact sweep` redoes on its next run


def test_a_rerun_redoes_a_damaged_record(example, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(example / "out", out)
    bad = cc.load_sweep(out).ids[0]
    path = out / "cases" / f"{bad}.json"
    record = json.loads(path.read_text())
    path.write_text(json.dumps({**record, "residuals": "none"}))
    report = run_sweep(example / "sweep.toml", out, workers=1)
    assert report.done == report.total == 14
    assert rows(cc.load_sweep(out).cases)[0]["state"] == "done" and isinstance(cc.load_sweep(out).record(bad)["residuals"], dict)


def test_failed_cases_are_rows_with_their_error(tmp_path):
    text = (EXAMPLES / "two_blocks.toml").read_text().replace("nx = 16, ny = 8", "nx = 8, ny = 4")
    (tmp_path / "scene.toml").write_text(text.replace("nx = 11, ny = 6", "nx = 6, ny = 3"))
    (tmp_path / "sweep.toml").write_text('scene = "scene.toml"\nmethod = "condensed"\n'
                                         '[grid]\n"body[1].material.nu" = [0.3, 0.7]\n')
    run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1, skip_invalid=True)
    r = cc.load_sweep(tmp_path / "out")
    table = {t["body[1].material.nu"]: t for t in rows(r.cases)}
    assert table[0.3]["state"] == "done" and table[0.7]["state"] == "failed" and "nu" in table[0.7]["error"]
    with pytest.raises(SweepResultsError, match=r"has no result \(failed: invalid input.*--retry-failed"):
        r.arrays(table[0.7]["id"])


def test_units_of_records_written_before_units_were_stored(example, tmp_path):
    out = tmp_path / "old"
    shutil.copytree(example / "out", out)
    r = cc.load_sweep(out)
    path = out / "cases" / f"{r.ids[0]}.json"
    record = json.loads(path.read_text())
    del record["units"]
    path.write_text(json.dumps(record))
    a = cc.load_sweep(out).arrays(r.ids[0])
    assert a.units["u1"] == "m" and a.units["lam"] == "Pa" and a.units["triangles1"] == "1"


def test_xdmf_export_opens_with_the_arrays(example, tmp_path):
    pytest.importorskip("h5py", reason="the XDMF export is the optional extra cvxcontact[export] (h5py)")
    import meshio

    r = cc.load_sweep(example / "out")
    case = r.ids[0]
    paths = r.export(tmp_path / "xdmf", ids=[case])
    assert sorted(p.name for p in paths) == [f"{case}_body1.xdmf", f"{case}_body2.xdmf", f"{case}_contact1.xdmf"]
    a = r.arrays(case)
    body = meshio.read(tmp_path / "xdmf" / f"{case}_body1.xdmf")
    assert np.array_equal(body.points[:, :2], a["points1"]) and np.array_equal(body.cells_dict["triangle"], a["triangles1"])
    assert np.array_equal(body.point_data["displacement [m]"], a["u1"])
    assert np.array_equal(body.point_data["electric potential [V]"], a["phi1"])
    line = meshio.read(tmp_path / "xdmf" / f"{case}_contact1.xdmf")
    assert np.array_equal(line.point_data["lambda_h [Pa]"], a["lam"]) and len(line.cells_dict["line"]) == len(a["x"]) - 1


def test_xdmf_export_without_h5py_names_the_extra(example, tmp_path, monkeypatch):
    from cvxcontact.apps.sweep.export import ExportError

    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(ExportError, match=r"cvxcontact\[export\]"):
        cc.load_sweep(example / "out").export(tmp_path / "x")


def _direct(folder, scene_name, overrides, condition):
    """The case solved directly: the scene file with the case's overrides, through cc.solve."""
    data = apply_overrides(read_toml(folder / scene_name), overrides, "test")
    return cc.solve(scene_from_data(data, folder / scene_name).scene, condition)


def test_the_table_reads_each_floating_electrodes_potential(tmp_path):
    """The punch sensor (2D, examples/punch_sensor.toml: a floating electrode on the PZT substrate) swept over the
    punch's push: the column ``substrate.top_V`` of each case is the electrode's potential of a direct cc.solve of
    that case; the energy is labelled per metre (2D); a record without electrodes (an older sweep) still loads."""
    shutil.copy(EXAMPLES / "punch_sensor.toml", tmp_path / "punch_sensor.toml")
    (tmp_path / "sweep.toml").write_text('scene = "punch_sensor.toml"\nconditions = ["gamma3"]\n'
                                         '[grid]\n"body[0].displacement.top[1]" = [-1e-6, -2e-6]\n')
    run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1)
    r = cc.load_sweep(tmp_path / "out")
    table = rows(r.cases)
    assert len(table) == 2 and all(t["ok"] for t in table)
    for t in table:
        push = t["body[0].displacement.top[1]"]
        ref = _direct(tmp_path, "punch_sensor.toml", {"body[0].displacement.top[1]": push}, "gamma3")
        (volts,) = [e.potential for e in ref.electrodes if e.kind == "floating"]
        assert abs(volts) > 0 and t["substrate.top_V"] == pytest.approx(volts, rel=1e-9)   # measured: 0
        assert t["energy_J_per_m"] == pytest.approx(ref.energy, rel=1e-9) and "energy_J" not in t
    path = tmp_path / "out" / "cases" / f"{r.ids[0]}.json"
    record = json.loads(path.read_text())
    del record["electrodes"]
    path.write_text(json.dumps(record))
    old = {t["id"]: t for t in rows(cc.load_sweep(tmp_path / "out").cases)}
    assert old[r.ids[0]]["substrate.top_V"] is None and old[r.ids[1]]["substrate.top_V"] == table[1]["substrate.top_V"]


def test_the_table_reads_each_obstacles_force_and_translation(tmp_path):
    """The Hertz half model (a fixed rigid circle, examples/hertz_half.toml, coarsened): the columns
    ``obstacle1.contact_force_N_per_m[i]`` and ``obstacle1.translation_m[i]`` are sol.obstacles[0]'s of a direct
    cc.solve."""
    shutil.copy(EXAMPLES / "hertz_half.toml", tmp_path / "hertz_half.toml")
    grid = {"body[0].mesh.graded_block.nx": 8, "body[0].mesh.graded_block.ny": 4}
    (tmp_path / "sweep.toml").write_text('scene = "hertz_half.toml"\nconditions = ["gamma3"]\n[grid]\n'
                                         + "".join(f'"{k}" = [{v}]\n' for k, v in grid.items()))
    run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1)
    (t,) = rows(cc.load_sweep(tmp_path / "out").cases)
    ref = _direct(tmp_path, "hertz_half.toml", grid, "gamma3").obstacles[0]
    assert ref.force[1] < 0                                # the block pressed down by the cylinder
    for i in range(2):
        assert t[f"obstacle1.contact_force_N_per_m[{i}]"] == pytest.approx(ref.force[i], rel=1e-9, abs=1e-9 * abs(ref.force[1]))
        assert t[f"obstacle1.translation_m[{i}]"] == ref.translation[i] == 0.0        # a fixed obstacle
    direct = _direct(tmp_path, "hertz_half.toml", grid, "gamma3")
    assert t["estimate_rel"] > 0 and t["estimate_rel"] == pytest.approx(direct.estimate.relative, rel=1e-9)


def test_3d_energies_and_potentials_are_labelled_in_3d_units(tmp_path):
    """The 3D punch (examples/punch3d.toml: a floating top electrode on the PZT punch): energy in J, not J/m; the
    column ``punch.top_V`` is the direct solve's potential."""
    shutil.copy(EXAMPLES / "punch3d.toml", tmp_path / "punch3d.toml")
    (tmp_path / "sweep.toml").write_text('scene = "punch3d.toml"\nconditions = ["gamma3"]\n'
                                         '[grid]\n"body[0].displacement.top[2]" = [-1e-6]\n')
    run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1)
    (t,) = rows(cc.load_sweep(tmp_path / "out").cases)
    ref = _direct(tmp_path, "punch3d.toml", {"body[0].displacement.top[2]": -1e-6}, "gamma3")
    (volts,) = [e.potential for e in ref.electrodes if e.kind == "floating"]
    assert t["energy_J"] == pytest.approx(ref.energy, rel=1e-9) and "energy_J_per_m" not in t
    assert abs(volts) > 0 and t["punch.top_V"] == pytest.approx(volts, rel=1e-9)
    assert t["estimate_rel"] > 0 and t["estimate_rel"] == pytest.approx(ref.estimate.relative, rel=1e-9)
    results = cc.load_sweep(tmp_path / "out")
    (case,) = results.ids
    a = results.arrays(case)
    assert a["points1"].shape[1] == 3 and a.units["force"] == "N" and a.units["u1"] == "m"  # nodal forces: N in 3D
    assert results.record(case)["units"]["force"] == "N"


def test_nodal_force_units_follow_the_dimension():
    """The nodal forces of a case (``force``, ``shear_force``, any pair's) are per metre of depth in 2D, N in 3D;
    the other units do not change with the dimension."""
    from cvxcontact.apps.sweep.store import array_unit, arrays_dim

    for name in ("force", "shear_force", "contact2_force", "contact3_shear_force"):
        assert array_unit(name) == array_unit(name, 2) == "N/m" and array_unit(name, 3) == "N"
    for name, unit in (("shear", "Pa"), ("slip", "m"), ("threshold", "Pa"), ("lam", "Pa"), ("u1", "m")):
        assert array_unit(name, 2) == array_unit(name, 3) == unit
    assert arrays_dim({"points1": np.zeros((4, 3))}) == 3 and arrays_dim({"points1": np.zeros((4, 2))}) == 2
