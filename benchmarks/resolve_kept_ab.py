"""Re-solves through a prepared ContactSolver with what this pass keeps per problem (|K|'s values for the checks'
row scales, the estimate's facet operators) and without it (the code as at the base commit), interleaved in ONE
process.

"before": ``Block.abs_values`` keeping nothing (np.abs of the matrix's values formed on every product, as
abs_product did) and the estimate's ``_facet_terms`` of the base commit (the rows taken and subtracted,
np.bincount; read from git, the optional fourth argument). "after": the working tree. Scene:
``apps.demo.two_blocks(nx)`` (as benchmarks/bench_resolve.py). The first solve once, then ``rounds`` rounds, each
with one load case solved alone by each side and ``cases`` load cases through ``solve_many`` by each side (order
alternating; the upper block's loads x 0.37 and its traction x 1 + i / 1000, i distinct over the run, so that no
side reuses a sweep of the other). Prints the medians of the process CPU seconds per load case, their ratios and
shares of the first solve, the answers' agreement (u, the checks, the estimate: max |a - b| / max |b|; the same
code paths give 0.0) and the kept bytes.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_kept_ab.py 560 5 8
"""

import resource
import statistics
import subprocess
import sys
import time
import types
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import load_cases as new_load_cases
from harness import two_blocks_solver

from cvxcontact.discrete import blocks as blocks_module
from cvxcontact.solution import estimate as est

BASE = "1f844ec7"
ROOT = Path(__file__).resolve().parents[1]


def base_facet_terms(base):
    """``_facet_terms`` of ``base``'s cvxcontact/solution/estimate.py, run in a module of its own (its imports
    absolute) on today's Geometry (which still holds the rows ``at0``, ``at1`` and ``c0``, ``c1``, ``ii`` it
    reads)."""
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{base}:cvxcontact/solution/estimate.py"],
                            capture_output=True, text=True, check=True).stdout
    for old, new in (("from ..", "from cvxcontact."), ("from . import", "from cvxcontact.solution import"),
                     ("from .", "from cvxcontact.solution.")):
        source = source.replace(old, new)
    module = sys.modules["estimate_base"] = types.ModuleType("estimate_base")      # (its dataclasses look it up)
    exec(compile(source, f"{base}:estimate.py", "exec"), module.__dict__)    # noqa: S102 (this repository's own code)
    return module._facet_terms


def abs_values_unkept(self, name):
    """Block.abs_values forming |M|'s values anew on every call (what abs_product did inside its blocks)."""
    source = self.Kup if name == "KupT" else getattr(self, name)
    if name == "jump":
        M = abs(source).T
        return M, M.data
    M = source.T if name == "KupT" else source
    return M, np.abs(M.data)


def main():
    warnings.simplefilter("ignore")
    nx, rounds, cases = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    base = sys.argv[4] if len(sys.argv) > 4 else BASE
    after = {"abs_values": blocks_module.Block.abs_values, "facet": est._facet_terms}
    before = {"abs_values": abs_values_unkept, "facet": base_facet_terms(base)}

    def use(side):
        parts = before if side == "before" else after
        blocks_module.Block.abs_values = parts["abs_values"]
        est._facet_terms = parts["facet"]

    scene, solver, first = two_blocks_solver(nx)
    load_cases = new_load_cases(scene)

    t = {(mode, side): [] for mode in ("solve", "solve_many") for side in ("before", "after")}
    for r in range(rounds):
        for side in (("before", "after") if r % 2 == 0 else ("after", "before")):
            use(side)
            one = load_cases(1)[0]
            c0 = time.process_time()
            solver.solve(one)
            t["solve", side].append(time.process_time() - c0)
            many = load_cases(cases)
            c0 = time.process_time()
            solver.solve_many(many)
            t["solve_many", side].append((time.process_time() - c0) / cases)
    med = {k: statistics.median(v) for k, v in t.items()}
    print(f"two_blocks({nx}): first solve {first:.2f} CPU s; {rounds} rounds, base {base}")
    for mode in ("solve", "solve_many"):
        b, a = med[mode, "before"], med[mode, "after"]
        print(f"  {mode:10s} a load case before {b:.3f}, after {a:.3f} CPU s (ratio {a / b:.3f}); share of the "
              f"first solve {100 * b / first:.2f} % -> {100 * a / first:.2f} %")
    scenes = load_cases(cases)
    answers = {}
    for side in ("before", "after"):
        use(side)
        answers[side] = [solver.solve(scenes[0])] + solver.solve_many(scenes)
    use("after")

    def rel(p, q):
        p, q = np.concatenate([np.ravel(v) for v in p]), np.concatenate([np.ravel(v) for v in q])
        return float(np.abs(p - q).max() / max(np.abs(q).max(), 1e-300))

    worst = {"u": 0.0, "checks": 0.0, "estimate": 0.0, "indicators": 0.0}
    for x, y in zip(answers["after"], answers["before"]):
        worst["u"] = max(worst["u"], rel(x.u, y.u))
        rx, ry = x.residuals(), y.residuals()
        worst["checks"] = max(worst["checks"], max(abs(rx[k] - ry[k]) / max(abs(ry[k]), 1e-300) for k in ry))
        worst["estimate"] = max(worst["estimate"], abs(x.estimate.absolute - y.estimate.absolute)
                                / y.estimate.absolute)
        worst["indicators"] = max(worst["indicators"], rel(x.estimate.indicators, y.estimate.indicators))
    print("  after vs before, worst over the load cases (solve and solve_many): "
          + ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
          + f"; ok {all(s.ok for v in answers.values() for s in v)}")
    kept = sum(v[2].nbytes for b in solver.problem.blocks for k, v in b.absolute.items()
               if k != "KupT" and v[2] is not None)                # (None: a matrix asked once, none kept)
    faces = sum(J.data.nbytes + J.indices.nbytes + J.indptr.nbytes for g in solver._geometry.values()
                for J in [j for j, _ in g.faces.jumps] + list(g.faces.owners))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    print(f"  kept: |K|'s values {kept / 1e6:.1f} MB (Kuu, Kup, Kpp, |jump| of both bodies); the estimate's facet "
          f"operators {faces / 1e6:.1f} MB; peak RSS {peak:.2f} GB")


if __name__ == "__main__":
    main()
