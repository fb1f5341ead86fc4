"""Benchmark: the peak memory of a large 3D solve line by line, and what stays held, in one fresh process.

The default solve of ``two_boxes`` (tests/scenes3d.py, PZT-5A on aluminium, "sigma1", P1: the scene of
benchmarks/bench3d.py; ``--elastic``: both boxes aluminium, as bench3d.py's ``--elastic``) from the meshes to the checked Solution. A thread samples the resident memory
(``/proc/self/statm``) every 10 ms and keeps, for each innermost package line on the main thread's stack, the
highest sample seen there: the lines where the peak sits. Each stage prints its CPU seconds, the resident MB
after it and its peak; the end prints the bytes of the arrays held by each part of the ContactSolver and the
Solution (``held``: numpy arrays and scipy sparse matrices reachable from it, each counted once) and the
resident MB after ``malloc_trim`` (what the heap holds freed but not returned).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench3d_memory.py \
        --size 1e6 [--elastic] [--checkout DIR] [--top 12]

``--checkout``: import cvxcontact from another checkout (a before/after comparison). KB per unknown are
``ru_maxrss`` (KiB) over the unknowns, with and without the interpreter-and-imports baseline (the resident
memory after a small solve, before the meshes).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import resource
import sys
import threading
import time
import traceback
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


class LinePeaks:
    """The highest resident memory (MB) seen at each innermost ``cvxcontact`` line of the main thread."""

    def __init__(self, dt: float = 0.01):
        from harness import resident_mb

        self.dt, self.resident, self.peaks = dt, resident_mb, {}
        self.main = threading.main_thread().ident
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        while True:
            r = self.resident()
            frame = sys._current_frames().get(self.main)
            stack = traceback.extract_stack(frame) if frame is not None else []
            ours = [f for f in stack if "cvxcontact" in f.filename]
            if ours:
                f = ours[-1]
                key = f"{Path(f.filename).parent.name}/{Path(f.filename).name}:{f.lineno} {f.name}"
                if r > self.peaks.get(key, 0.0):
                    self.peaks[key] = r
            time.sleep(self.dt)


def held(obj, seen=None) -> int:
    """Bytes of the numpy arrays (their own buffers) and scipy sparse matrices reachable from ``obj`` through
    attributes, dict values and sequences, each buffer counted once across calls sharing ``seen``."""
    import scipy.sparse as sp

    seen = set() if seen is None else seen
    total, todo = 0, [obj]
    while todo:
        o = todo.pop()
        if id(o) in seen or o is None or isinstance(o, (str, bytes, int, float, bool, type)):
            continue
        seen.add(id(o))
        if isinstance(o, np.ndarray):
            base = o
            while isinstance(base.base, np.ndarray):
                base = base.base
            if id(base) not in seen or base is o:
                seen.add(id(base))
                total += base.nbytes
            continue
        if sp.issparse(o):
            todo += [getattr(o, a) for a in ("data", "indices", "indptr", "row", "col") if hasattr(o, a)]
            continue
        if isinstance(o, dict):
            todo += list(o.values())
        elif isinstance(o, (list, tuple, set, frozenset)):
            todo += list(o)
        elif hasattr(o, "__dict__") and type(o).__module__.split(".")[0] in ("cvxcontact", "pyamg", "scipy",
                                                                              "functools"):
            todo += list(vars(o).values())
            if hasattr(o, "__closure__") and o.__closure__:
                todo += [c.cell_contents for c in o.__closure__]
        elif hasattr(o, "__slots__"):
            todo += [getattr(o, s) for s in o.__slots__ if hasattr(o, s)]
    return total


def one(size: float, checkout: str, top: int, save: str | None = None, elastic: bool = False) -> None:
    sys.path[:0] = [str(HERE.parent / "tests"), str(HERE)]
    from bench3d import cells
    from harness import resident_mb, unknowns

    sys.path.insert(0, checkout)
    from scenes3d import two_boxes

    import cvxcontact as cc

    cc.solve(two_boxes(4, "sigma1", elastic))                        # imports, first-call set-up
    base = resident_mb()
    lines = LinePeaks()
    n = cells("two_boxes", size, elastic)
    clock = [time.process_time()]

    def stage(name, make):
        value = make()
        time.sleep(0.05)
        print(json.dumps({"stage": name, "cpu_s": round(time.process_time() - clock[0], 2),
                          "resident_mb": round(resident_mb()),
                          "peak_so_far_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)}),
              flush=True)
        clock[0] = time.process_time()
        return value

    scene = stage("scene (meshes, bodies, overlay)", lambda: two_boxes(n, "sigma1", elastic))
    solver = stage("ContactSolver build", lambda: cc.ContactSolver(scene, "sigma1"))
    sol = stage("solve", lambda: solver.solve())
    N = unknowns(solver.problem)
    peak_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    seen: set = set()
    parts = {"scene": scene, "problem.matrices (unscaled)": solver.problem.matrices,
             "problem.systems": solver.problem.systems, "problem.blocks (scaled)": solver.problem.blocks,
             "problem (rest)": solver.problem, "cache.amg S": getattr(solver._cache.amg, "S", None),
             "cache.amg hierarchy u": getattr(solver._cache.amg, "ml_u", None),
             "cache.amg hierarchy phi": getattr(solver._cache.amg, "ml_p", None),
             "cache.amg (rest)": solver._cache.amg, "cache (rest)": solver._cache,
             "solution": sol, "solver (rest)": solver}
    sizes = {k: round(held(v, seen) / 1e6, 1) for k, v in parts.items()}
    resident = resident_mb()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    ranked = sorted(lines.peaks.items(), key=lambda kv: -kv[1])[:top]
    print(json.dumps({"held_mb": sizes, "resident_mb": round(resident), "resident_after_trim_mb":
                      round(resident_mb())}), flush=True)
    print(json.dumps({"peaks_mb": {k: round(v) for k, v in ranked}}, indent=0), flush=True)
    modules: dict = {}
    for k, v in lines.peaks.items():                                 # the highest line of each module
        mod = k.split(":")[0]
        if v > modules.get(mod, (0.0, ""))[0]:
            modules[mod] = (v, k.split(":", 1)[1])
    print(json.dumps({"module_peaks_mb": {f"{m} ({at})": round(v) for m, (v, at) in
                                          sorted(modules.items(), key=lambda kv: -kv[1][0])}}, indent=0), flush=True)
    print(json.dumps({"checkout": cc.__file__, "n": n, "unknowns": N, "ok": bool(sol.ok), "residuals": {k: float(v) for k, v in sol.residuals().items()},
                                            "base_mb": round(base), "peak_gib": round(peak_kib / 2**20, 3),
                      "kib_per_unknown": round(peak_kib / N, 2),
                      "kib_per_unknown_above_base": round((peak_kib - base * 1e6 / 1024) / N, 2)}), flush=True)
    if save:
        np.save(save, np.concatenate([np.ravel(a) for a in (*sol.u, *sol.phi) if a is not None]))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=float, default=1e5)
    p.add_argument("--checkout", default=str(HERE.parent))
    p.add_argument("--top", type=int, default=12)
    p.add_argument("--save", help="write u and phi of every body (a .npy file: a before/after comparison)")
    p.add_argument("--elastic", action="store_true", help="two_boxes: an aluminium upper box (no potentials)")
    args = p.parse_args()
    one(args.size, args.checkout, args.top, args.save, args.elastic)


if __name__ == "__main__":
    main()
