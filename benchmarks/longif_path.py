"""The sparse route's path on thin_layer(n) from the coarse start: how far the start is from the answer, which
sets are refactorised and how many rows each changes, under variants of the coarse rows' hops and of the
capacitance form's least cap.

Runs the route as benchmarks/longif_pkg_ab.py times it (``SparseContact(...)``, ``coarse_start``, ``solve``) for each
variant (``--hops``: ``coarse.COARSE_HOPS``, the package's 4 by default; ``--cap-min``: ``sparse.CAP_MIN``, 16), the
variants alternating over ``--rounds`` rounds in one process with one bonded PARDISO solve (pypardiso, the yardstick)
per round. Prints per variant: the coarse rows, the start's rows off the answer, the refactorisations (closed rows,
rows changed from the previous base), the numeric factorisations, capacitance columns and systems, the medians of the
coarse start's and the whole route's process CPU s and the ratio to the bonded solve, and whether the answer (active
set, u, forces) is the first variant's bit for bit.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_path.py 5000 --hops 4 6 8
"""

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import thin_layer_route

from cvxcontact.backends import coarse
from cvxcontact.backends import sparse as sm

warnings.simplefilter("ignore")
p = argparse.ArgumentParser()
p.add_argument("n", type=int)
p.add_argument("--hops", type=int, nargs="+", default=[coarse.COARSE_HOPS])
p.add_argument("--cap-min", type=int, nargs="+", default=[sm.CAP_MIN])
p.add_argument("--rounds", type=int, default=2)
args = p.parse_args()
blocks, E, g, F, bonded = thin_layer_route(args.n)
variants = [(h, c) for h in args.hops for c in args.cap_min]
refactor, path = sm.SparseContact._refactor, []


def traced(self, active, K=None, own_analysis=False):
    prev = None if self.base is None else self.base[0]
    out = refactor(self, active, K, own_analysis)
    path.append((int(active.sum()), None if prev is None else int((prev != active).sum())))
    return out


sm.SparseContact._refactor = traced
times = {v: ([], []) for v in variants}
yard, seen, first = [], {}, None
for r in range(args.rounds):
    for v in (variants if r % 2 == 0 else variants[::-1]):
        coarse.COARSE_HOPS, sm.CAP_MIN = v
        path.clear()
        t0 = time.process_time()
        sc = sm.SparseContact(blocks, E, factorization="auto")
        st = sc.coarse_start(F, g)
        t1 = time.process_time()
        out = sc.solve(F, g, st)
        t2 = time.process_time()
        times[v][0].append(t1 - t0)
        times[v][1].append(t2 - t0)
        answer = (np.concatenate(out[0]), out[2], out[3])
        first = answer if first is None else first
        same = all(np.array_equal(a, b) for a, b in zip(answer, first))
        ncoarse = len(coarse.coarse_rows(coarse.row_graph(sc.G), np.ones(sc.m, dtype=bool)))
        seen[v] = (ncoarse, int((st != out[3]).sum()), list(path), sc.factorizations, sc.column_solves, out[-1],
                   same)
    yard.append(bonded())
b = statistics.median(yard)
print(f"thin_layer({args.n}): bonded PARDISO solve {b:.3f} s (median of {args.rounds})")
for v in variants:
    ncoarse, off, steps, fact, cols, systems, same = seen[v]
    tc, tr = (statistics.median(x) for x in times[v])
    print(f"hops {v[0]}, CAP_MIN {v[1]}: {ncoarse} coarse rows, start {off} rows off the answer; refactorised "
          f"(closed, changed) {steps}; factorizations {fact}, columns {cols}, systems {systems}; coarse start "
          f"{tc:.3f} s, route {tr:.3f} s, ratio {tr / b:.2f}; the first variant's answer bit for bit: {same}")
