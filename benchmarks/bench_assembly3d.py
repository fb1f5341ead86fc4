"""Benchmark: the 3D problem build (``cc.ContactSolver(scene)``: assembly of every body, contact lines, scaling) and
its peak memory, one fresh process per size (``resource.getrusage`` maxrss, so the peak is the build's own plus the
interpreter's), on the scenes of benchmarks/bench3d.py (sizes as there: a count of unknowns or n).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_assembly3d.py \
        --sizes 1e5 3e5 1e6 [--scene two_boxes] [--elastic] [--checkout DIR]

``--checkout``: import cvxcontact from another checkout (the before of a before/after comparison; the scenes
and this script stay this checkout's). Prints one JSON line per size: seconds of the build and of
``assemble_matrices`` of every body again (the matrices alone), each also in CPU seconds (``_cpu_s``: the
figure to compare on a loaded machine), peak GB and KB per unknown.
"""

from __future__ import annotations

import argparse
import importlib
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def one(scene: str, size: float, elastic: bool, checkout: str) -> dict:
    sys.path[:0] = [str(HERE.parent / "tests"), str(HERE)]
    from bench3d import cells, make  # (puts this checkout first on the path)
    from harness import unknowns

    sys.path.insert(0, checkout)                                    # the checkout measured
    cc = importlib.import_module("cvxcontact")
    assemble_matrices = importlib.import_module("cvxcontact.fem.assembly").assemble_matrices

    n = cells(scene, size, elastic)
    cc.solve(make(scene, 4, "sigma1", elastic))                      # imports, first-call set-up
    sc = make(scene, n, "sigma1", elastic)
    t0, c0 = time.perf_counter(), time.process_time()
    solver = cc.ContactSolver(sc)
    build, build_cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss       # KB on Linux
    t0, c0 = time.perf_counter(), time.process_time()
    for body in sc.bodies:
        assemble_matrices(body)
    matrices, matrices_cpu = time.perf_counter() - t0, time.process_time() - c0
    N = unknowns(solver.problem)
    return {"checkout": cc.__file__, "scene": scene, "n": n, "unknowns": N, "build_s": round(build, 2),
            "build_cpu_s": round(build_cpu, 2), "matrices_s": round(matrices, 2),
            "matrices_cpu_s": round(matrices_cpu, 2), "peak_gb": round(peak / 1e6, 3),
            "kb_per_unknown": round(peak / N, 2)}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="*", default=[1e5, 3e5])
    p.add_argument("--scene", default="two_boxes", choices=("two_boxes", "sphere"))
    p.add_argument("--elastic", action="store_true")
    p.add_argument("--checkout", default=str(HERE.parent))
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        print(json.dumps(one(args.scene, float(args.one), args.elastic, args.checkout)))
        return
    for size in args.sizes:
        cmd = [sys.executable, __file__, "--one", str(size), "--scene", args.scene, "--checkout", args.checkout]
        out = subprocess.run(cmd + (["--elastic"] if args.elastic else []), capture_output=True, text=True, check=True)
        print(out.stdout.strip().splitlines()[-1], flush=True)


if __name__ == "__main__":
    main()
