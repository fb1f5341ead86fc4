"""The coarse start on a 3D overlay with main's coarse rows (the pattern of C^4 by three products, whatever the
density) and with this tree's (backends/coarse.coarse_rows: the searches where C^2's rows are many), interleaved.

In ONE process, ``reps`` rounds (the two sides' order alternating) of ``SparseContact(...).coarse_start(F, g)`` on
tests/scenes3d.offset_boxes(n) (``factorization="auto"``), timed in process CPU s, and of ``coarse_rows`` alone;
prints the medians and whether the starts are the same rows.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/coarse3d_ab.py 28 5
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import scenes3d
from harness import coarse_rows_by_c4

import cvxcontact as cc
from cvxcontact.backends import coarse, sparse
from cvxcontact.backends.condensed import quasi_definite_rhs

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
shipped = coarse.coarse_rows

p = cc.ContactSolver(scenes3d.offset_boxes(n)).problem
blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
t = {"main": [], "this": []}
rows = {"main": [], "this": []}
starts = {}
for r in range(reps):
    for side in (("main", "this") if r % 2 == 0 else ("this", "main")):
        sparse.coarse_rows = coarse_rows_by_c4 if side == "main" else shipped
        sc = sparse.SparseContact(blocks, E, factorization="auto")
        C = coarse.row_graph(sc.G)
        t0 = time.process_time()
        sparse.coarse_rows(C, np.ones(sc.m, dtype=bool))
        rows[side].append(time.process_time() - t0)
        t0 = time.process_time()
        starts[side] = sc.coarse_start(F, g)
        t[side].append(time.process_time() - t0)
sparse.coarse_rows = shipped
print(f"offset_boxes({n}): {len(g)} rows; coarse_start median s",
      {k: round(statistics.median(v), 3) for k, v in t.items()},
      "; coarse_rows alone", {k: round(statistics.median(v), 4) for k, v in rows.items()},
      "; the same start:", bool(np.array_equal(starts["main"], starts["this"])))
