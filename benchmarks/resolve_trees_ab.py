"""Re-solves of two trees of the package (an old and a new commit), interleaved in fresh processes.

Scene: ``apps.demo.two_blocks(nx)`` (as benchmarks/bench_resolve.py). Each process imports the package from one
tree (PYTHONPATH), makes the first solve (``harness.two_blocks_solver``: process CPU s from the Scene to the checked
Solution), one untimed re-solve, then ``rounds`` rounds of one load case alone (``solve``) and ``cases`` load cases
through ``solve_many`` (the upper block's loads x 0.37, its traction x 1 + i / 1000, i distinct over the run: no
load case repeats another's sweep), and saves the last load cases' answers (u, phi, contact forces, the checks, the
estimate's total, parts and indicators). ``pairs`` pairs of processes, old and new alternating (which goes first
alternates too). Printed: per process the first solve and the medians over its rounds of the process CPU s per load
case, and their shares of that process's first solve; over the pairs the medians and ranges; and the new answers
against the old: "identical" or the largest |a - b| / max |b|.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_trees_ab.py \\
        /tmp/base-tree . 560 5 8 --pairs 5
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def child(nx, rounds, cases, save):
    """One process: the first solve and the rounds of load cases (module docstring); a JSON line of its times."""
    sys.path.insert(0, str(HERE))
    warnings.simplefilter("ignore")
    from harness import load_cases as new_load_cases
    from harness import two_blocks_solver

    import cvxcontact as cc

    scene, solver, first = two_blocks_solver(nx)
    load_cases = new_load_cases(scene)

    solver.solve(load_cases(1)[0])
    single, many = [], []
    for _ in range(rounds):
        one = load_cases(1)[0]
        c0 = time.process_time()
        last = solver.solve(one)
        single.append(time.process_time() - c0)
        batch = load_cases(cases)
        c0 = time.process_time()
        out = solver.solve_many(batch)
        many.append((time.process_time() - c0) / cases)
    answers = {}
    for name, sol in (("solve", last), ("solve_many", out[-1])):
        e, r = sol.estimate, sol.residuals()
        answers.update({f"{name} u": np.concatenate([np.ravel(x) for x in sol.u]),
                        f"{name} phi": np.concatenate([np.ravel(x) for x in sol.phi if x is not None]),
                        f"{name} force": np.concatenate([np.ravel(c.force) for c in sol.contacts]),
                        f"{name} checks": np.array([r[k] for k in sorted(r)]),
                        f"{name} estimate": np.array([e.absolute, e.norm] + [e.parts[k] for k in sorted(e.parts)]),
                        f"{name} indicators": np.concatenate(e.indicators)})
    np.savez(save, **answers)
    print(json.dumps({"file": cc.__file__, "first": first, "solve": statistics.median(single),
                      "solve_many": statistics.median(many), "ok": bool(last.ok and all(s.ok for s in out))}))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("nx", type=int)
    p.add_argument("rounds", type=int)
    p.add_argument("cases", type=int)
    p.add_argument("--pairs", type=int, default=5)
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        return child(args.nx, args.rounds, args.cases, args.child)
    rows = {"old": [], "new": []}
    saved = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.pairs):
            for side in (("old", "new") if i % 2 == 0 else ("new", "old")):
                tree = Path(getattr(args, side)).resolve()
                save = f"{tmp}/{side}.npz"
                env = dict(os.environ, PYTHONPATH=str(tree))
                out = subprocess.run([sys.executable, __file__, str(tree), str(tree), str(args.nx), str(args.rounds),
                                      str(args.cases), "--child", save], env=env, capture_output=True, text=True,
                                     check=True)
                row = json.loads(out.stdout.strip().splitlines()[-1])
                rows[side].append(row)
                print(f"pair {i} {side}: first {row['first']:.2f} s, solve {row['solve']:.3f} s "
                      f"({100 * row['solve'] / row['first']:.2f} %), solve_many {row['solve_many']:.3f} s a case "
                      f"({100 * row['solve_many'] / row['first']:.2f} %), ok {row['ok']} [{row['file']}]", flush=True)
                saved[side] = dict(np.load(save))
    for side in ("old", "new"):
        r = rows[side]
        parts = []
        for mode in ("solve", "solve_many"):
            t = [x[mode] for x in r]
            share = [100 * x[mode] / x["first"] for x in r]
            parts.append(f"{mode} {statistics.median(t):.3f} s ({min(t):.3f}-{max(t):.3f}), share "
                         f"{statistics.median(share):.2f} % ({min(share):.2f}-{max(share):.2f})")
        first = [x["first"] for x in r]
        print(f"{side}: first solve {statistics.median(first):.2f} s ({min(first):.2f}-{max(first):.2f}); "
              + "; ".join(parts))
    for mode in ("solve", "solve_many"):
        ratio = [n[mode] / o[mode] for o, n in zip(rows["old"], rows["new"])]
        print(f"{mode}: new / old per pair {statistics.median(ratio):.3f} ({min(ratio):.3f}-{max(ratio):.3f})")
    print("new vs old answers (the last pair's last load cases): " + ", ".join(
        f"{k} " + ("identical" if np.array_equal(a, saved["old"][k]) else
                   f"{np.abs(a - saved['old'][k]).max() / max(np.abs(saved['old'][k]).max(), 1e-300):.1e}")
        for k, a in saved["new"].items()))


if __name__ == "__main__":
    main()
