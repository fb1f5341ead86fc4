"""The reference-solution generator: results, failures, manifest, resumption after kill -9, Dask."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.io.scenefile import load_scene
from cvxcontact.apps.sweep import SweepError, read_sweep, run_sweep

from sweep_files import write_sweep


def test_sweep_results_equal_direct_solves_and_failures_are_recorded(tmp_path):
    path = write_sweep(tmp_path, {"body[0].body_force[1]": [-1e9, -3e9], "body[1].material.nu": [0.3, 0.7]},
                       'conditions = ["gamma3", "sigma2"]')
    out = tmp_path / "out"
    report = run_sweep(path, out, workers=2, skip_invalid=True)
    assert report.total == 8 and report.done == 4 and len(report.failed) == 4       # nu = 0.7 is invalid
    assert all("nu < 0.5" in why for why in report.failed.values())
    manifest = json.loads((out / "manifest.json").read_text())
    assert sorted(c["state"] for c in manifest["cases"]) == ["done"] * 4 + ["failed"] * 4
    spec = load_scene(tmp_path / "scene.toml")
    for case in manifest["cases"]:
        if case["state"] != "done":
            continue
        info = json.loads((out / case["result"]).read_text())
        assert info["ok"] and info["condition"] == case["condition"]
        assert info["threads"]["OPENBLAS_NUM_THREADS"] == str(max(1, (os.cpu_count() or 1) // 2))   # per worker
        arrays = np.load(out / "cases" / f"{case['id']}.npz", allow_pickle=False)
        b1, b2 = spec.scene.bodies
        scene = cc.Scene(cc.Body(b1.mesh, b1.material, clamped=b1.clamped, grounded=b1.grounded, contact=b1.contact,
                                 body_force=(0.0, case["overrides"]["body[0].body_force[1]"]),
                                 traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05}), b2)
        ref = cc.solve(scene, case["condition"])
        assert np.abs(arrays["u1"] - ref.u[0]).max() <= 1e-10 * np.abs(ref.u[0]).max()
        assert np.abs(arrays["lam"] - ref.contact.lam).max() <= 1e-8 * np.abs(ref.contact.lam).max()
    again = run_sweep(path, out, workers=1, skip_invalid=True)
    assert again.skipped == 4 and len(again.failed) == 4                           # nothing re-run


def test_load_only_cases_reuse_the_factorisation(tmp_path):
    path = write_sweep(tmp_path, {"body[0].body_force[1]": [-1e9, -2e9, -3e9]})
    out = tmp_path / "out"
    run_sweep(path, out, workers=1)
    paths = sorted(json.loads(p.read_text())["path"] for p in (out / "cases").glob("*.json"))
    assert paths.count("active-set warm start") == 2


def test_bad_sweep_files(tmp_path):
    with pytest.raises(SweepError, match="does not exist"):
        read_sweep(write_sweep(tmp_path, {"body[5].mesh": [1]}))
    with pytest.raises(SweepError, match="not a key path"):
        read_sweep(write_sweep(tmp_path, {"body..x": [1]}))
    with pytest.raises(SweepError, match="conditions"):
        read_sweep(write_sweep(tmp_path, {"body[0].body_force[1]": [1]}, 'conditions = ["gamma9"]'))
    with pytest.raises(cc.CvxContactError, match="sweep file does not exist"):
        read_sweep(tmp_path / "none.toml")


def test_sweep_killed_with_sigkill_resumes_without_loss(tmp_path):
    # the full model (a CVXPY compile per case) keeps each case long enough to be caught mid-sweep
    path = write_sweep(tmp_path, {"body[0].body_force[1]": [-1e9 * k for k in range(1, 9)],
                                  "body[0].mesh.rectangle.nx": [8, 10]}, method="full")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "cvxcontact.apps.cli", "sweep", str(path), "--out", str(out), "--workers", "1", "-q"]
    proc = subprocess.Popen(cmd, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and len(list((out / "cases").glob("*.json"))) < 3:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    first = {p.name: p.read_bytes() for p in (out / "cases").glob("*.json")}
    assert 3 <= len(first) < 16, "the sweep should have been interrupted part-way"
    for name, data in first.items():
        json.loads(data)                                                          # complete, valid JSON
        np.load(out / "cases" / name.replace(".json", ".npz"), allow_pickle=False)["u1"]
    rerun = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    files = {p.name: p.read_bytes() for p in (out / "cases").glob("*.json")}
    assert len(files) == 16
    assert all(files[name] == data for name, data in first.items())              # finished cases untouched
    assert not list((out / "cases").glob(".*"))                                   # no temporaries left
    manifest = json.loads((out / "manifest.json").read_text())
    assert all(c["state"] == "done" for c in manifest["cases"])


def test_sweep_on_a_local_dask_cluster(tmp_path):
    distributed = pytest.importorskip("distributed")
    path = write_sweep(tmp_path, {"body[0].body_force[1]": [-1e9, -2e9]}, 'conditions = ["gamma3", "sigma1"]')
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as lc:
        with distributed.Client(lc) as client:
            report = run_sweep(path, tmp_path / "out", scheduler=client)
    assert report.done == 4 and not report.failed
