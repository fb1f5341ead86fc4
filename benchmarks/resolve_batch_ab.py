"""Load cases through a prepared ContactSolver one at a time (``solver.solve(scene)``) and batched
(``solver.solve_many(scenes)``: the forward and backward sweeps of every body batched, ``Condensation.prepare``,
``defer``, ``flush``), interleaved
in ONE process.

Scene: ``apps.demo.two_blocks(nx)`` (as benchmarks/bench_resolve.py). The first solve once, then ``rounds`` rounds,
each solving ``cases`` load cases one at a time and ``cases`` others batched (order alternating; the upper block's
loads x 0.37 and its traction x 1 + i / 1000 with i distinct over every load case of the run, so that no side reuses
a sweep of the other). Prints the medians over the rounds of the process CPU seconds per load case, their ratio and
share of the first solve; then the stages (``sol.info.timings``, wall s, medians over the last round's load cases;
the batch's sweeps under ``batched_sweeps`` and ``batched_backward``, spread over its cases);
then the answers of ``solve_many`` against
``solve`` on the same load cases (max |a - b| / max |b| of u, phi, the contact forces; the estimate's total and
indicators) and ``ok``. Also the multi-column sweep alone on the upper block: 1, 2, 4, 8 right-hand sides, CPU ms
per right-hand side (forward, backward; medians of 5).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_batch_ab.py 560 3 8
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import load_cases as new_load_cases
from harness import two_blocks_solver


def rel(p, q):
    p, q = np.concatenate([np.ravel(v) for v in p]), np.concatenate([np.ravel(v) for v in q])
    return float(np.abs(p - q).max() / max(np.abs(q).max(), 1e-300))


def main():
    warnings.simplefilter("ignore")
    nx, rounds, cases = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    scene, solver, first = two_blocks_solver(nx)
    new_cases = new_load_cases(scene)

    def load_cases():
        return new_cases(cases)

    t, stages = {"one": [], "many": []}, {}
    for r in range(rounds):
        for side in (("one", "many") if r % 2 == 0 else ("many", "one")):
            scenes = load_cases()
            c0 = time.process_time()
            sols = [solver.solve(s) for s in scenes] if side == "one" else solver.solve_many(scenes)
            t[side].append((time.process_time() - c0) / cases)
            stages[side] = [s.info.timings for s in sols]
    med = {k: statistics.median(v) for k, v in t.items()}
    print(f"two_blocks({nx}), {cases} load cases a round, {rounds} rounds: first solve {first:.2f} CPU s; per load "
          f"case one at a time {med['one']:.3f}, batched {med['many']:.3f} CPU s (ratio "
          f"{med['many'] / med['one']:.3f}); share of the first solve {100 * med['one'] / first:.2f} % -> "
          f"{100 * med['many'] / first:.2f} %")
    for side, ts in stages.items():
        keys = sorted({k for x in ts for k in x})
        spread = {k: statistics.median([x.get(k, 0.0) for x in ts]) for k in keys}
        for key in ("batched_sweeps", "batched_backward"):
            if key in keys:
                spread[key] = sum(x.get(key, 0.0) for x in ts) / len(ts)
        print(f"  stages {side} (wall s): " + ", ".join(f"{k} {v:.3f}" for k, v in spread.items()))
    scenes = load_cases()
    a = [solver.solve(s) for s in scenes]
    b = solver.solve_many(scenes)
    worst = {"u": 0.0, "phi": 0.0, "force": 0.0, "estimate": 0.0, "indicators": 0.0}
    for x, y in zip(b, a):
        worst["u"] = max(worst["u"], rel(x.u, y.u))
        worst["phi"] = max(worst["phi"], rel([p for p in x.phi if p is not None],
                                             [p for p in y.phi if p is not None]))
        worst["force"] = max(worst["force"], rel([c.force for c in x.contacts], [c.force for c in y.contacts]))
        worst["estimate"] = max(worst["estimate"],
                                abs(x.estimate.absolute - y.estimate.absolute) / y.estimate.absolute)
        worst["indicators"] = max(worst["indicators"], rel(x.estimate.indicators, y.estimate.indicators))
    print("solve_many vs solve, worst over the load cases: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
          + f"; ok {all(x.ok for x in a + b)}")
    factor = solver.cache.condensation.bodies[0].factor
    rng = np.random.default_rng(0)
    F = rng.standard_normal((factor.n, 8))
    for k in (1, 2, 4, 8):
        fw, bw = [], []
        for _ in range(5):
            c0 = time.process_time()
            fwd = factor.forward(F[:, 0] if k == 1 else F[:, :k])
            c1 = time.process_time()
            factor.backward(fwd, fwd.reduced)
            c2 = time.process_time()
            fw.append(c1 - c0)
            bw.append(c2 - c1)
        print(f"  upper block ({factor.n} unknowns, {type(factor).__name__}), {k} right-hand side(s): forward "
              f"{1e3 * statistics.median(fw) / k:.1f}, backward {1e3 * statistics.median(bw) / k:.1f} CPU ms each")


if __name__ == "__main__":
    main()
