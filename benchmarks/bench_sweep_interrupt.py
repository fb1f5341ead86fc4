"""How fast Ctrl-C stops a pooled sweep on large cases, and whether any process is left.

Runs ``cvxcontact sweep`` on the two-block scene scaled to NX cells along the contact line (cases differing
in their gap only) with 2 workers in a new session, waits until both workers have been inside their case
for DELAY seconds (by default half of the case's measured assembly + factorisation, so that they are
inside the factorisation), sends SIGINT to the whole process group (as a terminal's Ctrl-C does) and
measures the time until the command exits and until no process of the group is left.

    python benchmarks/bench_sweep_interrupt.py --nx 200 400 --repeat 2

Prints one line per run: unknowns per case, the delay, seconds to exit, seconds until no process is left,
the exit code and the last line of stderr (the resume hint).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scene_text(nx: int) -> str:
    text = (ROOT / "examples" / "two_blocks.toml").read_text()
    lower = max(2, round(nx * 11 / 16))
    return (text.replace("nx = 16, ny = 8", f"nx = {nx}, ny = {nx // 2}")
                .replace("nx = 11, ny = 6", f"nx = {lower}, ny = {max(2, round(lower * 6 / 11))}"))


def _is_python(pid) -> bool:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[0] == sys.executable.encode()
    except OSError:
        return False


def group(sid: int, python: bool = False) -> list[int]:
    """Live (non-zombie) processes of session ``sid``; ``python``: only those running Python (the driver and
    its forked workers, not a short git call)."""
    pids = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(stat[3]) == sid and stat[0] != "Z" and (not python or _is_python(d)):       # field 6 of stat: session id
                pids.append(int(d))
    return pids


def calibrate(folder: Path, nx: int) -> dict:
    """One case solved in this process: unknowns and stage timings (s)."""
    sys.path.insert(0, str(ROOT))
    import cvxcontact as cc
    from cvxcontact.io.scenefile import load_scene

    (folder / "scene.toml").write_text(scene_text(nx))
    spec = load_scene(folder / "scene.toml")
    t0 = time.perf_counter()
    solver = cc.ContactSolver(spec.scene, "gamma3", method="condensed")
    sol = solver.solve()
    unknowns = sum(u.size + (p.size if p is not None else 0) for u, p in zip(sol.u, sol.phi))
    return {"unknowns": unknowns, "timings": dict(sol.timings), "total": time.perf_counter() - t0}


def run(folder: Path, nx: int, delay: float, cases: int) -> dict:
    (folder / "scene.toml").write_text(scene_text(nx))
    gaps = ", ".join(f"{-1e-9 * k:g}" for k in range(cases))
    (folder / "sweep.toml").write_text(f'scene = "scene.toml"\nmethod = "condensed"\n[grid]\n"gap" = [{gaps}]\n')
    out = folder / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "cvxcontact.apps.cli", "sweep", str(folder / "sweep.toml"), "--out", str(out),
           "--workers", "2"]
    proc = subprocess.Popen(cmd, cwd=folder, env=env, start_new_session=True, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))   # as a terminal starts it
    started = None
    while proc.poll() is None:                                # the workers started
        if (out / "manifest.json").exists() and len(group(proc.pid, python=True)) >= 1 + min(2, cases):
            started = time.monotonic()
            break
        time.sleep(0.01)
    time.sleep(delay)
    t0 = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    exited = time.monotonic() - t0
    while group(proc.pid):
        time.sleep(0.01)
    gone = time.monotonic() - t0
    manifest = json.loads((out / "manifest.json").read_text()) if (out / "manifest.json").exists() else {}
    return {"exit_s": exited, "gone_s": gone, "code": proc.returncode, "workers_started": started is not None,
            "states": manifest.get("states"), "stderr": err.strip().splitlines()[-1] if err.strip() else ""}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--nx", type=int, nargs="+", default=[200])
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--cases", type=int, default=4, help="cases of the sweep (1: a single case, on one worker)")
    p.add_argument("--delay", type=float, default=None, help="seconds after the workers start (default: see above)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for nx in args.nx:
            cal = calibrate(Path(tmp), nx)
            t = cal["timings"]
            delay = args.delay if args.delay is not None else \
                1.0 + t.get("assembly", 0.0) + 0.5 * t.get("factorization", 0.0)   # +1 s: the worker's start
            print(f"nx {nx}: {cal['unknowns']} unknowns per case; assembly {t.get('assembly', 0):.2f} s, "
                  f"factorization {t.get('factorization', 0):.2f} s, case {cal['total']:.2f} s; SIGINT after "
                  f"{delay:.2f} s", flush=True)
            for k in range(args.repeat):
                folder = Path(tmp) / f"nx{nx}-{k}"
                folder.mkdir()
                r = run(folder, nx, delay, args.cases)
                print(f"  run {k}: exit after {r['exit_s']:.2f} s, no process left after {r['gone_s']:.2f} s, "
                      f"exit code {r['code']}, states {r['states']}; stderr: {r['stderr']}", flush=True)


if __name__ == "__main__":
    main()
