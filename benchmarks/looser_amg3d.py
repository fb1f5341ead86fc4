"""A/B in fresh processes: a 3D steel block pushed onto a whole floor and a strip raised 3e-6 m above it over
0.3 <= x < 0.7 (tests/reach_scenes.py ``strip`` and ``lowered``, as tests/test_sparse_parallel_rows.py, on an
n x n x nz box of [0, 1]^2 x [0, 0.5], P1 tetrahedra, "sigma1"), method="auto" at or above the AMG route's
threshold (``backends.AMG_UNKNOWNS``, 5e4 unknowns), two checkouts alternately: the route taken
(``sol.info.method``) and the CPU seconds of ``ContactSolver.solve`` (``time.process_time``; the assembly apart),
and the largest difference of u from the sparse route's answer (``method="sparse"``, the same process) over
max |u|. Before (main): the AMG route handed every such scene to the sparse route (two rows at one node have no
dof of their own); after: it keeps it, the looser row open.

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/looser_amg3d.py \\
        --base /tmp/looser-base --n 40 --nz 10 --pairs 3
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]


def one(tree: str, n: int, nz: int) -> dict:
    sys.path.insert(0, tree)
    sys.path.insert(0, str(HERE / "tests"))
    import cvxcontact as cc

    assert Path(cc.__file__).resolve().is_relative_to(Path(tree).resolve()), cc.__file__
    from hex_scenes import DELTA, SIDES, STEEL, H
    from reach_scenes import lowered, strip

    warnings.simplefilter("ignore", cc.ResolutionWarning)

    def scene():
        body = cc.Body(cc.box(nx=n, ny=n, nz=nz, z=(0.0, H)), STEEL, roller=SIDES,
                       displacement={"top": (None, None, -DELTA)}, contact="bottom")
        return cc.Scene(body, contacts=[cc.Contact(body, "bottom", o)
                                        for o in (strip(-1.0, 2.0), lowered(0.3, 0.7, 3, drop=-3e-6))])

    solver = cc.ContactSolver(scene(), "sigma1")
    c0 = time.process_time()
    sol = solver.solve()
    cpu = time.process_time() - c0
    ref = cc.solve(scene(), "sigma1", method="sparse")
    gap = max(np.abs(a - b).max() for a, b in zip(sol.u, ref.u)) / max(np.abs(b).max() for b in ref.u)
    return {"cpu": cpu, "method": sol.info.method, "route": str(sol.info.route), "ok": bool(sol.ok),
            "unknowns": int(sum(np.size(u) for u in sol.u)), "u_gap": float(gap)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="the other checkout (its cvxcontact is imported)")
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--nz", type=int, default=10)
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one(args.one[0], int(args.one[1]), int(args.one[2]))))
        return
    trees = {"before": str(Path(args.base).resolve()), "after": str(HERE)}
    runs = {k: [] for k in trees}
    for pair in range(args.pairs):
        for k in (list(trees) if pair % 2 == 0 else list(trees)[::-1]):
            out = subprocess.run([sys.executable, __file__, "--base", args.base, "--one", trees[k], str(args.n),
                                  str(args.nz)], capture_output=True, text=True, check=True, cwd="/tmp")
            runs[k].append(json.loads(out.stdout.strip().splitlines()[-1]))
            print(k, runs[k][-1], flush=True)
    for k in trees:
        cpu = [r["cpu"] for r in runs[k]]
        r = runs[k][0]
        print(f"| {k} | {r['unknowns']:,} | {r['method']} | {statistics.median(cpu):.2f} ({min(cpu):.2f}-"
              f"{max(cpu):.2f}) | {max(x['u_gap'] for x in runs[k]):.1e} | {r['ok']} |")


if __name__ == "__main__":
    main()
