"""Benchmark: the validation of a TetMesh (``cc.TetMesh(points, tets)``: the checks of
``_check_embedding`` and the orientation before them) on box meshes, one fresh process per size and checkout,
the checkouts alternated (so a before/after ratio is taken under the same load).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_tetmesh.py \\
        --nodes 1e4 3e4 1e5 3e5 [--before DIR] [--repeat 2]

``--before``: a checkout to compare with (its cvxcontact builds the same arrays). Prints one JSON line per size and
checkout: seconds of the build (the least of ``--repeat`` runs) and the peak of the memory it allocates (a second
build under ``tracemalloc``: every NumPy array counted; MB and bytes per node).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

HERE = Path(__file__).resolve().parent


def one(checkout: str, arrays: str) -> dict:
    sys.path.insert(0, checkout)
    import numpy as np

    import cvxcontact as cc
    data = np.load(arrays)
    points, tets = data["points"], data["tets"]
    cc.box(nx=1, ny=1, nz=1)                                                      # first call
    t0 = time.perf_counter()
    cc.TetMesh(points, tets)
    seconds = time.perf_counter() - t0
    tracemalloc.start()                                                           # a second build, traced
    cc.TetMesh(points, tets)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {"checkout": cc.__file__, "nodes": len(points), "tets": len(tets), "seconds": round(seconds, 3),
            "peak_mb": round(peak / 1e6, 1), "bytes_per_node": round(peak / len(points))}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--nodes", type=float, nargs="*", default=[1e4, 3e4, 1e5, 3e5])
    p.add_argument("--before", help="a checkout to compare with")
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        print(json.dumps(one(*args.one)))
        return
    sys.path.insert(0, str(HERE.parent))
    import numpy as np

    import cvxcontact as cc
    checkouts = [c for c in (args.before, str(HERE.parent)) if c]
    with tempfile.TemporaryDirectory() as tmp:
        for nodes in args.nodes:
            k = max(1, round(nodes ** (1 / 3)) - 1)                              # (k + 1)^3 nodes
            m = cc.box(nx=k, ny=k, nz=k)
            arrays = str(Path(tmp) / f"box{k}.npz")
            np.savez(arrays, points=m.points, tets=m.tets)
            del m
            runs: dict[str, list] = {c: [] for c in checkouts}
            for _ in range(args.repeat):
                for c in checkouts:
                    out = subprocess.run([sys.executable, __file__, "--one", c, arrays], capture_output=True,
                                         text=True, check=True)
                    runs[c].append(json.loads(out.stdout))
            for c in checkouts:
                best = min(runs[c], key=lambda r: r["seconds"])
                best["peak_mb"] = max(r["peak_mb"] for r in runs[c])
                best["bytes_per_node"] = max(r["bytes_per_node"] for r in runs[c])
                print(json.dumps(best), flush=True)


if __name__ == "__main__":
    main()
