"""Sweeps under faults: a changed scene, corrupt files, interrupts (SIGINT, SIGTERM, kill -9) with no
orphan workers, a killed worker, two runs on one folder, a full disk, an unwritable output folder."""

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps import cli
from cvxcontact.apps.sweep import SweepLockedError, SweepOutputError, read_sweep, run_sweep
from cvxcontact.apps.sweep import store
from cvxcontact.io.scenefile import load_scene
from sweep_files import write_sweep as setup

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def results(out):
    return {p.name: p.read_bytes() for p in (out / "cases").glob("*.json")}


def test_changed_scene_is_recomputed_and_old_results_kept_aside(tmp_path):
    path = setup(tmp_path, {"gap": [0.0, -2e-6]})
    out = tmp_path / "out"
    lines = []
    first = run_sweep(path, out, workers=1)
    assert first.done == 2
    old = results(out)
    scene = tmp_path / "scene.toml"
    scene.write_text(scene.read_text().replace("E = 70e9", "E = 200e9"))          # the lower body stiffens
    again = run_sweep(path, out, workers=1, progress=lines.append)
    assert again.skipped == 0 and again.done == 2 and again.superseded == 2       # nothing reported as done
    assert any("moved to" in line and "superseded" in line for line in lines)
    kept = {p.name for p in Path(again.superseded_to, "cases").glob("*.json")}
    assert kept == set(old)                                                         # old results kept aside
    assert not set(old) & set(results(out))
    spec = load_scene(scene)
    b1, b2 = spec.scene.bodies
    for case in read_sweep(path).cases:
        info = json.loads((out / "cases" / f"{case.id}.json").read_text())
        assert info["scene"]["body"][1]["material"]["E"] == 200e9
        assert set(info["versions"]) >= {"cvxcontact", "cvxpy", "clarabel", "numpy", "scipy"}
        assert info["machine"]["platform"] and info["provenance"]["materials"][1]["c"][2][2] == pytest.approx(
            200e9 / (2 * 1.3))                                                      # shear modulus mu = E / 2(1 + nu)
        ref = cc.solve(cc.Scene(b1, b2, gap=case.data["gap"]), method="full")
        u1 = np.load(out / "cases" / f"{case.id}.npz")["u1"]
        assert np.abs(u1 - ref.u[0]).max() <= 1e-9 * np.abs(ref.u[0]).max()


def test_corrupt_files_are_redone_and_a_corrupt_failure_does_not_crash(tmp_path):
    path = setup(tmp_path, {"gap": [0.0, -1e-6, -2e-6, -3e-6, -4e-6], "body[1].material.nu": [0.3, 0.7]})
    out = tmp_path / "out"
    first = run_sweep(path, out, workers=1, skip_invalid=True)
    assert first.done == 5 and len(first.failed) == 5                               # nu = 0.7 is invalid
    ids = sorted(p.stem for p in (out / "cases").glob("*.json"))
    cases = out / "cases"
    (cases / f"{ids[0]}.json").write_text((cases / f"{ids[0]}.json").read_text()[:100])   # truncated JSON
    (cases / f"{ids[1]}.json").write_text("")                                              # empty JSON
    (cases / f"{ids[2]}.npz").unlink()                                                     # missing npz
    data = (cases / f"{ids[3]}.npz").read_bytes()
    (cases / f"{ids[3]}.npz").write_bytes(data[: len(data) // 2])                          # truncated npz
    failure = sorted((out / "failures").glob("*.json"))[0]
    failure.write_text(failure.read_text()[:20])                                           # truncated failure
    untouched = (cases / f"{ids[4]}.json").read_bytes()
    lines = []
    again = run_sweep(path, out, workers=1, skip_invalid=True, progress=lines.append)
    assert again.redone == 5 and again.skipped == 1 and again.done == 5 and len(again.failed) == 5
    assert any("redone" in line for line in lines)
    assert (cases / f"{ids[4]}.json").read_bytes() == untouched
    for cid in ids:
        info = json.loads((cases / f"{cid}.json").read_text())
        assert store.sha256(cases / f"{cid}.npz") == info["files"]["npz_sha256"]
    assert json.loads(failure.read_text())["error"].startswith("invalid input")


def test_export_problem_writes_the_conic_data(tmp_path):
    import scipy.sparse as sp

    path = setup(tmp_path, {"gap": [0.0]})
    out = tmp_path / "out"
    assert run_sweep(path, out, workers=1, export_problem=True).done == 1
    (info,) = [json.loads(p.read_text()) for p in (out / "cases").glob("*.json")]
    f = np.load(out / "cases" / info["files"]["problem"])
    assert store.sha256(out / "cases" / info["files"]["problem"]) == info["files"]["problem_sha256"]
    P = sp.csc_matrix((f["P_data"], f["P_indices"], f["P_indptr"]), shape=tuple(f["P_shape"]))
    A = sp.csc_matrix((f["A_data"], f["A_indices"], f["A_indptr"]), shape=tuple(f["A_shape"]))
    assert P.shape[0] == P.shape[1] == A.shape[1] == len(f["q"]) and A.shape[0] == len(f["b"])
    assert int(f["cone_zero"]) + int(f["cone_nonneg"]) + int(np.sum(f["cone_soc"])) == A.shape[0]
    # an independent solve of the exported QP (Clarabel directly) reaches the optimum CVXPY found
    import clarabel

    cones = [clarabel.ZeroConeT(int(f["cone_zero"]))] if int(f["cone_zero"]) else []
    cones += ([clarabel.NonnegativeConeT(int(f["cone_nonneg"]))]
              + [clarabel.SecondOrderConeT(int(k)) for k in f["cone_soc"]])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    sol = clarabel.DefaultSolver(sp.triu(P).tocsc(), f["q"], A, f["b"], cones, settings).solve()
    assert str(sol.status) == "Solved"
    x = np.asarray(sol.x)
    assert sol.obj_val == pytest.approx(0.5 * x @ (P @ x) + f["q"] @ x, rel=1e-9)
    assert np.all(f["b"] - A @ x >= -1e-8 * (1 + np.abs(f["b"]).max()))


def test_full_disk_and_unwritable_output_give_one_line(tmp_path, monkeypatch, capsys):
    path = setup(tmp_path, {"gap": [0.0, -1e-6]})
    calls = {"n": 0}
    real = store.atomic_write

    def full(target, write):
        calls["n"] += 1
        if calls["n"] > 2:                                       # manifest and the first npz, then the disk is full
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(target, write)

    monkeypatch.setattr(store, "atomic_write", full)
    with pytest.raises(SweepOutputError, match="No space left on device"):
        run_sweep(path, tmp_path / "out", workers=1)
    calls["n"] = 0
    assert cli.main(["sweep", str(path), "--out", str(tmp_path / "out2"), "--workers", "1", "-q"]) == 1
    err = capsys.readouterr().err
    assert "No space left on device (ENOSPC)" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    monkeypatch.setattr(store, "atomic_write", real)
    run_sweep(path, tmp_path / "out", workers=1)                 # the lock was released
    # --out names a file
    (tmp_path / "file").write_text("x")
    assert cli.main(["sweep", str(path), "--out", str(tmp_path / "file"), "-q"]) == 1
    assert "names a file" in capsys.readouterr().err
    # a folder that cannot be created (read-only parent; simulated, since tests may run as root)

    def refuse(self, *a, **k):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))

    monkeypatch.setattr(Path, "mkdir", refuse)
    assert cli.main(["sweep", str(path), "--out", str(tmp_path / "ro" / "out"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "cannot create the output folder" in err and "Permission denied" in err and "Traceback" not in err


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_output_folder(tmp_path, capsys):
    path = setup(tmp_path, {"gap": [0.0]})
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert cli.main(["sweep", str(path), "--out", str(ro / "out"), "-q"]) == 1
        assert "Traceback" not in capsys.readouterr().err
    finally:
        ro.chmod(0o700)


def test_second_run_on_a_folder_is_refused(tmp_path):
    path = setup(tmp_path, {"gap": [0.0]})
    out = tmp_path / "out"
    out.mkdir()
    with store.FolderLock(out):
        with pytest.raises(SweepLockedError, match=f"in use by another sweep \\(pid {os.getpid()}\\)"):
            run_sweep(path, out, workers=1)
    assert run_sweep(path, out, workers=1).done == 1


@pytest.mark.skipif("fork" not in __import__("multiprocessing").get_all_start_methods(), reason="needs fork")
def test_a_killed_worker_is_a_failure_of_its_case(tmp_path, monkeypatch):
    from cvxcontact.apps.sweep import worker

    path = setup(tmp_path, {"gap": [-1e-6 * k for k in range(8)]})
    out = tmp_path / "out"
    real = worker.solve_case

    def oom(task, *args):                      # forked workers inherit this: one case's worker is SIGKILLed
        if abs(task["data"]["gap"] + 3e-6) < 1e-12:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(task, *args)

    monkeypatch.setattr(worker, "solve_case", oom)
    report = run_sweep(path, out, workers=2)
    assert report.total == 8 and len(report.failed) == 1 and report.done == 7
    ((cid, reason),) = report.failed.items()
    assert "SIGKILL" in reason
    assert json.loads((out / "failures" / f"{cid}.json").read_text())["scene"]["gap"] == pytest.approx(-3e-6)
    monkeypatch.setattr(worker, "solve_case", real)
    again = run_sweep(path, out, workers=2, retry_failed=True)
    assert again.done == 8 and not again.failed


def _children(pid):
    found = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(d))
    return found


def _ctrl_c_enabled():
    """In the child before its exec: SIGINT back to its default action. A suite run in the background of a
    non-interactive shell (``pytest &``) has SIGINT ignored, the child inherits that, and a Python started so
    never raises KeyboardInterrupt (a sweep started with ``nohup``/``&`` rightly ignores Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _alive(pid):
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL], ids=["SIGINT", "SIGTERM", "SIGKILL"])
def test_interrupted_pooled_sweep_stops_without_orphans(tmp_path, sig):
    # the full model of the example's scene: ~0.4 s a case, 48 cases on 2 workers. As soon as the first
    # result exists the whole process group is frozen (SIGSTOP), so the sweep is part-way by construction
    # however loaded the machine is; the second run and the signal come while it is frozen, then it goes on
    path = setup(tmp_path, {"gap": [-1e-6 * k for k in range(48)]}, method="full", small=False)
    (tmp_path / "other").mkdir()
    other = setup(tmp_path / "other", {"gap": [0.0]})             # another sweep file, on the same folder
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "cvxcontact.apps.cli", "sweep", str(path), "--out", str(out), "--workers", "2", "-q"]
    proc = subprocess.Popen(cmd, cwd=ROOT, start_new_session=True, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_ctrl_c_enabled)
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not list((out / "cases").glob("*.json")):
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGSTOP)                       # driver and workers frozen
        workers = _children(proc.pid)
        assert len(workers) == 2
        assert len(list((out / "cases").glob("*.json"))) < 48, "the sweep should be frozen part-way"
        if sig == signal.SIGINT:
            with pytest.raises(SweepLockedError, match=f"in use by another sweep \\(pid {proc.pid}\\)"):
                run_sweep(other, out, workers=1)                  # a second run on the folder is refused
            os.killpg(proc.pid, signal.SIGINT)                    # Ctrl-C reaches the whole process group
        else:
            os.kill(proc.pid, sig)
        os.killpg(proc.pid, signal.SIGCONT)                       # the pending signal is handled on resuming
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    deadline = time.time() + 10
    while time.time() < deadline and any(_alive(p) for p in workers):
        time.sleep(0.05)
    assert not any(_alive(p) for p in workers), "orphan workers"
    done = {p.stem for p in (out / "cases").glob("*.json")}
    time.sleep(0.5)
    assert {p.stem for p in (out / "cases").glob("*.json")} == done      # nobody writes any more
    assert len(done) < 48, "the sweep should have been stopped part-way"
    if sig != signal.SIGKILL:
        assert proc.returncode == 130 and "interrupted" in err and "Traceback" not in err
        manifest = json.loads((out / "manifest.json").read_text())
        assert {c["id"] for c in manifest["cases"] if c["state"] == "done"} == done
    # resuming after an interrupt: tests/test_sweep.py (kill -9)


CRASH_AT_RENAME = """
import os, signal, sys
import numpy as np
from cvxcontact.apps.sweep import store
real = os.replace
def replace(src, dst):                     # the process dies between writing the case JSON and its rename
    if str(dst).endswith(".json"):
        os.kill(os.getpid(), signal.SIGKILL)
    return real(src, dst)
os.replace = replace
store.write_case(sys.argv[1], "c0", {"u1": np.arange(3.0)}, {"case": "c0", "ok": True})
"""


def test_a_crash_between_write_and_rename_leaves_nothing_that_looks_like_a_result(tmp_path):
    out = store.prepare_out(tmp_path / "out")
    run = subprocess.run([sys.executable, "-c", CRASH_AT_RENAME, str(out)], cwd=ROOT, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == -signal.SIGKILL, run.stderr
    left = sorted(p.name for p in (out / "cases").iterdir())
    assert "c0.npz" in left and any(n.startswith(".c0.") for n in left)       # the npz, the JSON's temporary
    # what a reader of results lists (pathlib's glob matches names starting with a dot too): nothing
    assert list((out / "cases").glob("*.json")) == []
    assert list((out / "cases").glob("*.npz")) == [out / "cases" / "c0.npz"]
    assert store.case_state(out, "c0") == ("pending", None)                      # the case is redone on resume
    store.clean_temporaries(out)
    assert sorted(p.name for p in (out / "cases").iterdir()) == ["c0.npz"]


def test_case_files_are_fsynced_before_their_rename(tmp_path, monkeypatch):
    from cvxcontact.io import output

    events = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        st = os.fstat(fd)
        events.append(("fsync", "folder" if os.path.isdir(f"/proc/self/fd/{fd}") else st.st_ino))
        return real_fsync(fd)

    def replace(src, dst):
        events.append(("replace", os.stat(src).st_ino, Path(dst).name))
        return real_replace(src, dst)

    monkeypatch.setattr(output.os, "fsync", fsync)
    monkeypatch.setattr(output.os, "replace", replace)
    out = store.prepare_out(tmp_path / "out")
    store.write_case(out, "c0", {"u1": np.arange(3.0)}, {"case": "c0", "ok": True})
    renames = [e for e in events if e[0] == "replace"]
    assert [e[2] for e in renames] == ["c0.npz", "c0.json"]
    for _, inode, _ in renames:                  # each file: its data synced, renamed, then the folder synced
        k = events.index(("fsync", inode))
        assert events[k + 1][:2] == ("replace", inode) and events[k + 2] == ("fsync", "folder")
    assert store.case_state(out, "c0")[0] == "done"


def _is_python(pid) -> bool:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[0] == sys.executable.encode()
    except OSError:
        return False


def _session(sid, python=False):
    """Live (non-zombie) processes of session ``sid``; ``python``: only those running Python (the driver and
    its forked workers, not a short git call)."""
    found = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(stat[3]) == sid and stat[0] != "Z" and (not python or _is_python(d)):
                found.append(int(d))
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
@pytest.mark.parametrize("cases", [1, 3])
def test_ctrl_c_stops_the_workers_promptly_and_says_how_to_resume(tmp_path, cases):
    # cases of 1.9e4 unknowns (nx = 96); Ctrl-C (SIGINT to the process group) 0.1 s after the workers started,
    # i.e. while they build, assemble or factorise their case. A single case with --workers 2 runs in a worker process
    # too, so that Ctrl-C does not wait for a factorisation to return. The bound is generous (a loaded machine): the
    # time on large cases (1e5-1e6 unknowns) is measured by benchmarks/bench_sweep_interrupt.py
    text = (EXAMPLES / "two_blocks.toml").read_text().replace("nx = 16, ny = 8", "nx = 96, ny = 48")
    (tmp_path / "scene.toml").write_text(text.replace("nx = 11, ny = 6", "nx = 66, ny = 36"))
    gaps = ", ".join(f"{-1e-9 * k:g}" for k in range(cases))
    (tmp_path / "sweep.toml").write_text(f'scene = "scene.toml"\nmethod = "condensed"\n[grid]\n"gap" = [{gaps}]\n')
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "cvxcontact.apps.cli", "sweep", "sweep.toml", "--out", "out", "--workers", "2", "-q"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)}, start_new_session=True,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_ctrl_c_enabled)
    try:
        deadline = time.time() + 120
        def started():
            # counted after the first manifest: then the driver runs no more git calls, whose forks (before
            # their exec) would look like workers
            return (out / "manifest.json").exists() and len(_session(proc.pid, True)) >= 1 + min(cases, 2)

        while time.time() < deadline and proc.poll() is None and not started():
            time.sleep(0.01)
        assert proc.poll() is None and len(_session(proc.pid, True)) == 1 + min(cases, 2), "the workers did not start"
        time.sleep(0.1)
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        seconds = time.monotonic() - t0
        while time.monotonic() - t0 < 30 and _session(proc.pid):
            time.sleep(0.01)
        left = _session(proc.pid)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130 and not left, (proc.returncode, left)
    assert seconds < 20, seconds         # measured 0.9-1.0 s (load 7 on 2 cores); 0.6-1.8 s at 1e5-1e6 unknowns
    assert "Traceback" not in err
    hint = err.split("Resume with the same command: ", 1)[1].strip()
    assert hint == "cvxcontact sweep sweep.toml --out out --workers 2 -q"
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["states"]["pending"] >= 1 and f"{manifest['states']['pending']} pending" in err
    assert hint.split()[1:] == cmd[3:]                # the command as given; resumed here in this process:
    assert cli.main(["sweep", str(tmp_path / "sweep.toml"), "--out", str(out), "--workers", "1", "-q"]) == 0
    assert json.loads((out / "manifest.json").read_text())["states"]["done"] == cases
