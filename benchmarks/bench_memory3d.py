"""Benchmark: where the peak memory of a 3D solve comes from, stage by stage, in one fresh process per size.

Stages of ``two_boxes`` (benchmarks/bench3d.py, "sigma1"): the two ``cc.box`` meshes (the ``TetMesh`` checks),
the bodies, the Scene (the overlay of the contact faces), the ``ContactSolver`` build (assembly, scaling) and
its ``solve`` (AMG set-up, Krylov steps, read-back, checks, estimate). A thread samples the resident memory
(``/proc/self/statm``) every 20 ms and keeps the call stack of the main thread at the highest sample of each
stage, so each stage prints: CPU seconds, resident MB after it, its peak MB and the package's innermost frames
at that peak.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_memory3d.py \
        --sizes 3e5 [--checkout DIR] [--no-solve]

``--checkout``: import cvxcontact from another checkout (a before/after comparison). Prints one JSON line per
stage and a last line with the unknowns and the process's peak (``ru_maxrss``) in KB per unknown.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def one(size: float, checkout: str, solve: bool) -> None:
    sys.path[:0] = [str(HERE.parent / "tests"), str(HERE)]
    from bench3d import cells
    from harness import PeakSampler, resident_mb, unknowns

    sys.path.insert(0, checkout)
    from scenes3d import two_boxes

    import cvxcontact as cc

    cc.solve(two_boxes(4))                                           # imports, first-call set-up
    sampler = PeakSampler()
    n = cells("two_boxes", size, False)
    n2 = max(2, round(0.7 * n))
    state: dict = {}
    clock = [time.process_time()]

    def stage(name, make):
        sampler.reset()
        state[name] = make()
        time.sleep(3 * sampler.dt)
        cpu = time.process_time()
        print(json.dumps({"stage": name, "cpu_s": round(cpu - clock[0], 2), "resident_mb": round(resident_mb()),
                          "peak_mb": round(sampler.peak), "at_peak": " < ".join(sampler.where[::-1])}), flush=True)
        clock[0] = time.process_time()

    aluminium = cc.materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    stage("box upper", lambda: cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=max(1, n // 2)))
    stage("box lower", lambda: cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=n2, ny=n2,
                                      nz=max(1, (n2 + 1) // 2)))
    stage("bodies", lambda: (
        cc.Body(state["box upper"], cc.materials.PZT5A, clamped=["top"], grounded=["top"], name="PZT-5A box",
                body_force=(0.0, 0.0, -2e9), traction={"right": (0.0, 0.0, 3e8)}, surface_charge={"left": -0.05}),
        cc.Body(state["box lower"], aluminium, clamped=["bottom"], name="aluminium box")))
    b1, b2 = state["bodies"]
    stage("scene", lambda: cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", condition="sigma1")]))
    stage("ContactSolver build", lambda: cc.ContactSolver(state["scene"]))
    if solve:
        stage("solve", lambda: state["ContactSolver build"].solve())
    N = unknowns(state["ContactSolver build"].problem)
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"checkout": cc.__file__, "n": n, "unknowns": N, "ok": bool(state["solve"].ok) if solve else None,
                      "peak_gb": round(peak_kb / 1e6, 3), "kb_per_unknown": round(peak_kb / N, 2)}), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="*", default=[1e5])
    p.add_argument("--checkout", default=str(HERE.parent))
    p.add_argument("--no-solve", action="store_true")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        one(float(args.one), args.checkout, not args.no_solve)
        return
    for size in args.sizes:
        cmd = [sys.executable, __file__, "--one", str(size), "--checkout", args.checkout]
        out = subprocess.run(cmd + (["--no-solve"] if args.no_solve else []), capture_output=True, text=True,
                             check=True)
        print(out.stdout.strip(), flush=True)


if __name__ == "__main__":
    main()
