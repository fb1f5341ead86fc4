"""Benchmark: the exact finish of tests/test_adapt_issue.py's adapt call on issue 30's punch (a rigid cylinder pushed by
a force into an aluminium half block, P2 "gamma3", cvxcontact/apps/studies/adapt.py), on the "full" route, before
and after a change, in one run.

For each source tree (``--before REV``: that git revision, extracted into a temporary directory; and this working
tree) a child process, single-threaded, runs

1. the adapt call ``cc.adapt(punch_scene(punch_block()), tol=0.005, condition="gamma3", degree=2,
   max_unknowns=50_000)``: its CPU seconds, the last step's (its exact finish is nearly all of it);
2. one cold ``cc.solve(..., method="full")`` on the adapt call's last mesh (23,980 unknowns): CPU seconds, and
   the solver's wall timings of the interior point ("solve") and of the exact finish ("polish");

and saves u, lambda and the translation of both answers. The parent prints the table and the largest relative
differences between the trees' answers. CPU seconds by ``time.process_time`` (the machine is shared: wall times
measure the neighbours too).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/adapt_punch_finish.py --before 2af5595

Results: benchmarks/results/adapt_punch_finish.md.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time, warnings
import numpy as np
import cvxcontact as cc
from cvxcontact.apps.studies.adapt import punch_block, punch_scene

out = sys.argv[1]
warnings.simplefilter("ignore")
t = time.process_time()
result = cc.adapt(punch_scene(punch_block()), tol=0.005, condition="gamma3", degree=2, max_unknowns=50_000)
adapt_cpu = time.process_time() - t
t = time.process_time()
sol = cc.solve(result.scene, condition="gamma3", degree=2, method="full")
solve_cpu = time.process_time() - t
a = result.solution
np.savez(out + ".npz", u=sol.u[0], lam=sol.contact.lam, tr=sol.obstacles[0].translation,
         au=a.u[0], alam=a.contact.lam, atr=a.obstacles[0].translation)
json.dump({"file": cc.__file__, "adapt_cpu": adapt_cpu, "steps": len(result.history),
           "last_unknowns": result.history[-1].unknowns, "last_cpu": result.history[-1].cpu_s,
           "adapt_method": a.info.method, "solve_cpu": solve_cpu, "solve_wall": sol.info.timings.get("solve", 0.0),
           "polish_wall": sol.info.timings.get("polish", 0.0), "finish": sol.info.finish, "ok": bool(sol.ok and a.ok)},
          open(out + ".json", "w"))
"""


def run(tree: Path, out: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", MKL_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    subprocess.run([sys.executable, "-c", CHILD, out], env=env, cwd=tree, check=True)
    with open(out + ".json") as f:
        return json.load(f)


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", default="HEAD~1", help="git revision of the 'before' tree (default HEAD~1)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        before = Path(tmp) / "before"
        before.mkdir()
        archive = subprocess.run(["git", "archive", args.before, "cvxcontact"], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(before)], input=archive, check=True)
        rows = {"before": run(before, str(Path(tmp) / "before_out")), "after": run(ROOT, str(Path(tmp) / "after_out"))}
        answers = {k: np.load(str(Path(tmp) / f"{k}_out.npz")) for k in rows}
        rev = subprocess.run(["git", "rev-parse", "--short", args.before], cwd=ROOT, check=True,
                             capture_output=True, text=True).stdout.strip()
        print(f"before: {rev}; after: the working tree ({ROOT})\n")
        print("| tree | adapt CPU s | steps | last unknowns | last step CPU s | one solve CPU s | interior point s "
              "(wall) | finish s (wall) | finish | ok |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for k, r in rows.items():
            print(f"| {k} | {r['adapt_cpu']:.1f} | {r['steps']} | {r['last_unknowns']} | {r['last_cpu']:.1f} | "
                  f"{r['solve_cpu']:.1f} | {r['solve_wall']:.1f} | {r['polish_wall']:.1f} | {r['finish']} | "
                  f"{r['ok']} |")
        b, a = rows["before"], rows["after"]
        print(f"\nratios before/after: adapt {b['adapt_cpu'] / a['adapt_cpu']:.2f}, last step "
              f"{b['last_cpu'] / a['last_cpu']:.2f}, one solve {b['solve_cpu'] / a['solve_cpu']:.2f}")
        x, y = answers["after"], answers["before"]
        print(f"after against before, one solve: u {rel(x['u'], y['u']):.1e}, lambda {rel(x['lam'], y['lam']):.1e}, "
              f"translation {rel(x['tr'], y['tr']):.1e}; the adapt call's answer: u {rel(x['au'], y['au']):.1e}, "
              f"lambda {rel(x['alam'], y['alam']):.1e}, translation {rel(x['atr'], y['atr']):.1e}")


if __name__ == "__main__":
    main()
