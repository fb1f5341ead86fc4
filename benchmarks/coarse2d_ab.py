"""The coarse rows on a slender 2D layer: main's ``coarse_rows`` (the pattern of C^4 by three products) against
this tree's (backends/coarse.coarse_rows: the density counted on sampled rows, then the power as (C^2)^2),
interleaved in one process on thin_layer(n)'s rows' graph; prints the medians and least of ``pairs`` rounds
(process CPU ms) and asserts the same rows.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/coarse2d_ab.py 3000 41
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import coarse_rows_by_c4

import cvxcontact as cc
from cvxcontact.apps import demo
from cvxcontact.backends import coarse

warnings.simplefilter("ignore")
n, pairs = int(sys.argv[1]), int(sys.argv[2])

p = cc.ContactSolver(demo.thin_layer(n)).problem
C = coarse.row_graph(sp.hstack([p.E @ b.jump for b in p.blocks]).tocsr())
free = np.ones(C.shape[0], dtype=bool)
t = {"main": [], "this": []}
for r in range(pairs):
    for side in (("main", "this") if r % 2 == 0 else ("this", "main")):
        rows = coarse_rows_by_c4 if side == "main" else coarse.coarse_rows
        t0 = time.process_time()
        rows(C, free)
        t[side].append(time.process_time() - t0)
assert np.array_equal(coarse_rows_by_c4(C, free), coarse.coarse_rows(C, free))
print(f"thin_layer({n}), {C.shape[0]} rows: coarse_rows median ms",
      {k: round(1e3 * statistics.median(v), 2) for k, v in t.items()},
      "least", {k: round(1e3 * min(v), 2) for k, v in t.items()}, "; the same rows: True")
