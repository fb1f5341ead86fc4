"""Benchmark: P1 "gamma3" between two 3D elastic boxes (tests/scenes3d.py ``two_boxes(n, "gamma3", elastic=True)``),
the condensed route (interior point + finish on W) against the sparse route (regularised Newton stage + Lawson-Hanson
on the sparse mixed system), each in a fresh subprocess (its peak memory, ``resource.getrusage`` maxrss, its own),
one run of each at every size; times from ContactSolver construction (assembly) to the checked Solution.

    OMP_NUM_THREADS=1 python benchmarks/bench_gamma3_sparse.py --n 8 12 16 [--md benchmarks/results/bench_gamma3_sparse.md]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import json, resource, sys, time
sys.path.insert(0, {root!r}); sys.path.insert(0, {tests!r})
import cvxcontact as cc
from scenes3d import two_boxes
t0 = time.perf_counter()
s = cc.ContactSolver(two_boxes({n}, "gamma3", elastic=True), "gamma3", method={method!r}, estimate=False)
sol = s.solve()
t = time.perf_counter() - t0
print(json.dumps(dict(N=s.problem.unknowns, m=int(s.problem.E.shape[0]), seconds=t, ok=bool(sol.ok),
                      systems=sol.info.iterations, maxrss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3)))
"""


def run(n: int, method: str) -> dict:
    code = CHILD.format(root=str(ROOT), tests=str(ROOT / "tests"), n=n, method=method)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[8, 12, 16])
    ap.add_argument("--md", type=Path, default=None)
    args = ap.parse_args()
    lines = ["| n | unknowns N | rows m | condensed s | sparse s | sparse / condensed | condensed KB/N | sparse KB/N | "
             "sparse systems | ok |", "|---|---|---|---|---|---|---|---|---|---|"]
    for n in args.n:
        c, s = run(n, "condensed"), run(n, "sparse")
        lines.append(f"| {n} | {c['N']} | {c['m']} | {c['seconds']:.2f} | {s['seconds']:.2f} | "
                     f"{s['seconds'] / c['seconds']:.2f} | {1e3 * c['maxrss_mb'] / c['N']:.0f} | "
                     f"{1e3 * s['maxrss_mb'] / s['N']:.0f} | {s['systems']} | {c['ok'] and s['ok']} |")
        print(lines[-1], flush=True)
    if args.md:
        args.md.write_text("# gamma3 between two elastic boxes: condensed vs sparse route (one run each)\n\n"
                           "`OMP_NUM_THREADS=1 python benchmarks/bench_gamma3_sparse.py --n "
                           + " ".join(map(str, args.n)) + "` on the shared 2-core machine; peak memory is the "
                           "whole process's maxrss (Python and the imports included, ~150 MB).\n\n"
                           + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
