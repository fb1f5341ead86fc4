"""The sparse route's steps on tests/scenes3d.offset_boxes(n) from one start, in a process of its own: ``bonded``
(every free row closed) or ``coarse`` (``SparseContact.coarse_start`` first, its CPU included). The package takes
neither here (the "gamma3" rows may be dependent: ``signorini._sparse_dependent``); this measures whether the coarse
start would pay on this scene. Prints the start's rows and CPU, then the closed rows, systems, numeric
factorisations, process CPU s and peak RSS (None: the steps led nowhere).

Run (one thread; the bonded start's factorisations are about 90 CPU s each at n = 28):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/coarse3d_route.py 28 coarse
"""

import resource
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import scenes3d

import cvxcontact as cc
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact

warnings.simplefilter("ignore")
n, start = int(sys.argv[1]), sys.argv[2]
p = cc.ContactSolver(scenes3d.offset_boxes(n), method="sparse").problem
blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
F, free = np.concatenate([quasi_definite_rhs(b) for b in blocks]), ~p.held_rows
sc = SparseContact(blocks, E, factorization="auto")
t0 = time.process_time()
first = sc.coarse_start(F, g, free) if start == "coarse" else free
print("start", start, "rows", None if first is None else int(first.sum()), "start_cpu",
      round(time.process_time() - t0, 2), flush=True)
out = None if first is None else sc.solve(F, g, first)
print("closed", None if out is None else int(out[3].sum()), "systems", None if out is None else out[4],
      "factorizations", sc.factorizations, "cpu", round(time.process_time() - t0, 2),
      "peakMB", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024, flush=True)
