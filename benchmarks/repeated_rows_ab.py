"""A/B in fresh processes: ``backends.parallel.repeated_rows`` of two checkouts (e.g. main: its own grouping, a loop
over the rows; h-split: read off ``ParallelRows``) on the synthetic nodal rows of benchmarks/looser_rows_ab.py:
``--rows strip`` (a floor and a strip over a fifth of the nodes, its rows repeating the floor's bit for bit, its
gaps the floor's: coincident, a class of two at each such node) or ``--rows chained`` (three obstacles per node,
rows chained within the tolerance; random gaps). Per size, ``--pairs`` pairs, the two checkouts alternately (the
order swapped every pair), each a fresh process: CPU seconds (``time.process_time``) of one call (the grouping
included: mixed_kkt calls it once per geometry and gaps), and whether the answers are the same ints.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/repeated_rows_ab.py \\
        --base /tmp/split-base --sizes 1e4 1e5 --pairs 3
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def one(tree: str, m: int, kind: str) -> dict:
    sys.path[:0] = [tree, str(HERE / "benchmarks")]
    from looser_rows_ab import chained, rows

    from cvxcontact.backends.parallel import repeated_rows
    G, g = chained(m) if kind == "chained" else rows(m)
    if kind == "strip":
        N = round(m / 1.2)                              # the floor's rows first (looser_rows_ab.rows)
        g[N:] -= 3e-6                                   # the strip's gaps the floor's: coincident
    t0 = time.process_time()
    first = repeated_rows(G, g)
    return {"cpu": time.process_time() - t0, "digest": hashlib.sha256(first.tobytes()).hexdigest()[:16]}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--base", required=True)
    p.add_argument("--sizes", nargs="+", type=float, default=[1e4, 1e5])
    p.add_argument("--pairs", type=int, default=3)
    p.add_argument("--rows", choices=("strip", "chained"), default="strip")
    p.add_argument("--one", nargs=2)
    a = p.parse_args()
    if a.one:
        print(json.dumps(one(a.one[0], int(float(a.one[1])), a.rows)))
        return
    print(f"rows: {a.rows}")
    print("| rows | before: repeated_rows CPU s | after | same answer |")
    print("|---|---|---|---|")
    for m in a.sizes:
        times = {"base": [], "this": []}
        digests = set()
        for k in range(a.pairs):
            for name in (("base", "this") if k % 2 == 0 else ("this", "base")):
                tree = a.base if name == "base" else str(HERE)
                out = json.loads(subprocess.run([sys.executable, __file__, "--base", a.base, "--rows", a.rows,
                                                 "--one", tree, str(m)], capture_output=True, text=True,
                                                check=True).stdout)
                times[name].append(out["cpu"])
                digests.add(out["digest"])
        fmt = lambda t: f"{statistics.median(t):.3f} ({min(t):.3f}-{max(t):.3f})"
        print(f"| {int(m)} | {fmt(times['base'])} | {fmt(times['this'])} | {len(digests) == 1} |", flush=True)


if __name__ == "__main__":
    main()
