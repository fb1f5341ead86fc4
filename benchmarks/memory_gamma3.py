"""Benchmark: where the peak memory of the default 3D condition "gamma3" comes from, stage by stage (two elastic
boxes with non-matching faces, tests/scenes3d.py ``two_boxes(n, "gamma3", elastic=True)``, the condensed route),
in one fresh process per size.

A thread samples the resident memory (``/proc/self/statm``) every 20 ms; the stages of the solve are marked by
wrapping the package's functions (the bodies' factorisations with their Schur blocks, the interface compliance,
the load case's forward sweeps, the interface program's model, CVXPY's compilation and Clarabel, the exact finish,
the back-substitution), and each prints its CPU seconds, the resident MB after it and its own peak MB with the
package's innermost frames at that peak. The same thread is a watchdog: above ``--limit`` GB resident it ends the
process (exit code 3) before the machine runs short.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/memory_gamma3.py \\
        --sizes 1.5e5 3e5 [--checkout DIR] [--limit 16] [--trace] [--release free|keep|auto]

``--release``: the bodies' factorisations freed once their Sigma is taken (``free``; the stage "factors freed"
marks each), kept (``keep``) or as the memory budget decides (``auto``, the package's default;
:mod:`cvxcontact.backends.budget`); without it the package's default.
"""

from __future__ import annotations

import argparse
import functools
import json
import resource
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

HERE = Path(__file__).resolve().parent


RELEASE = {"free": True, "keep": False, "auto": None}


def one(size: float, checkout: str, limit_gb: float, trace: bool = False, release: str | None = None) -> None:
    sys.path[:0] = [str(HERE.parent / "tests"), str(HERE)]
    from bench3d import cells
    from harness import PeakSampler, resident_mb

    sys.path.insert(0, checkout)
    import cvxpy as cp
    from scenes3d import two_boxes

    import cvxcontact as cc
    from cvxcontact.backends import condensed, interface, signorini

    if release is not None:
        from cvxcontact.backends import budget
        budget.RELEASE = RELEASE[release]
    cc.solve(two_boxes(4, "gamma3", True))                           # imports, first-call set-up
    sampler = PeakSampler(limit_mb=1e3 * limit_gb, packages=("cvxcontact", "cvxpy"))
    clock = [time.process_time()]

    def report(name):
        cpu = time.process_time()
        line = {"stage": name, "cpu_s": round(cpu - clock[0], 2), "resident_mb": round(resident_mb()),
                "peak_mb": round(sampler.peak), "at_peak": " < ".join(sampler.where[::-1])}
        if trace:                          # the arrays and Python objects alive now and at their peak, MB
            now, top = tracemalloc.get_traced_memory()
            line.update(traced_mb=round(now / 1e6), traced_peak_mb=round(top / 1e6))
            tracemalloc.reset_peak()
        print(json.dumps(line), flush=True)
        clock[0] = time.process_time()
        sampler.reset()

    def marked(name, fn):
        @functools.wraps(fn)
        def wrapper(*a, **k):
            report(f"(before {name})")
            try:
                return fn(*a, **k)
            finally:
                report(name)
        return wrapper

    condensed.factorize = marked("factorisation with the Schur block", condensed.factorize)
    if hasattr(condensed, "Released"):
        condensed.Released = marked("factors freed (Sigma and the load's forward sweep kept)", condensed.Released)
    condensed.Compliance.__init__ = marked("compliance (Cholesky of each Sigma)", condensed.Compliance.__init__)
    interface.Condensation.apply = marked("load case (forward sweeps)", interface.Condensation.apply)
    condensed.InterfaceModel.__init__ = marked("interface model (CVXPY expressions)",
                                               condensed.InterfaceModel.__init__)
    cp.Problem.get_problem_data = marked("CVXPY compilation", cp.Problem.get_problem_data)
    cp.Problem.unpack_results = marked("CVXPY read-back", cp.Problem.unpack_results)
    signorini.timed_program = marked("interior point (compilation and Clarabel)", signorini.timed_program)
    signorini.interface_finish = marked("exact finish", signorini.interface_finish)
    interface.Condensation.invert = marked("back-substitution", interface.Condensation.invert)

    n = cells("two_boxes", size, True)
    if trace:
        tracemalloc.start()
    sampler.reset()
    scene = two_boxes(n, "gamma3", True)
    report("scene")
    solver = cc.ContactSolver(scene)
    report("ContactSolver build (assembly)")
    sol = solver.solve()
    report("checks and the rest")
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    N = int(solver.problem.unknowns)
    print(json.dumps({"checkout": cc.__file__, "n": n, "unknowns": N, "rows": int(solver.problem.E.shape[0]),
                      "ok": bool(sol.ok), "iterations": int(sol.info.iterations), "peak_gb": round(peak_kb / 2**20, 3),
                      "kb_per_unknown": round(peak_kb * 1.024 / N, 2)}), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="*", default=[1.5e5])
    p.add_argument("--checkout", default=str(HERE.parent))
    p.add_argument("--limit", type=float, default=16.0, help="GB resident at which the run is ended")
    p.add_argument("--trace", action="store_true", help="also tracemalloc's live and peak MB (NumPy arrays and "
                   "Python objects; slower)")
    p.add_argument("--release", choices=tuple(RELEASE), default=None,
                   help="the factors freed after Sigma, kept, or by the memory budget")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        one(float(args.one), args.checkout, args.limit, args.trace, args.release)
        return
    for size in args.sizes:
        cmd = [sys.executable, __file__, "--one", str(size), "--checkout", args.checkout, "--limit", str(args.limit)]
        cmd += ["--trace"] if args.trace else []
        cmd += ["--release", args.release] if args.release else []
        out = subprocess.run(cmd, capture_output=True, text=True, check=False)
        print(out.stdout.strip(), flush=True)
        if out.returncode:
            print(out.stderr[-3000:], flush=True)


if __name__ == "__main__":
    main()
