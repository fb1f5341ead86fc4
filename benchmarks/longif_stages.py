"""The sparse route on thin_layer(n) by stage: each stage's process CPU seconds, PARDISO's share and the rest.

Runs the route as the A/B scripts time it (``SparseContact(...)``, ``coarse_start`` above ``COARSE_ROWS`` rows,
``solve``) ``reps`` times, each listed function wrapped by a timer (process CPU, inclusive) that also sums the
PARDISO calls made inside it (the coarse start's ``PardisoFactorization._call``, the route's
``PardisoSymmetric._call``); prints, per route (the first round left out: first-call costs), each stage's calls,
inclusive time, PARDISO's time inside it and the rest (what is not PARDISO), largest rest first. The stages nest
(``SC.solve`` holds ``SC._system``, which holds ``SC._refactor``, ...): read a row's rest as that stage's own
Python, scipy.sparse and dense work, its callees' included.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_stages.py 3000 4
"""

import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import StageTimes, thin_layer_route

from cvxcontact.backends import factor as fm
from cvxcontact.backends import sparse as sm

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
blocks, E, g, F, bonded = thin_layer_route(n)
stages = StageTimes()
wrap = stages.wrap


wrap(fm.PardisoFactorization, "_call", "PARDISO, coarse start", pardiso=True)
wrap(fm.PardisoSymmetric, "_call", "PARDISO, route", pardiso=True)
for name in ("__init__", "coarse_start", "solve", "matrix", "_refactor", "_analysed", "_solve_on", "_settle",
             "_solve_columns", "_system"):
    wrap(sm.SparseContact, name, "SparseContact." + name)
for name in ("row_reach", "row_weights", "quasi_definite", "coarse_rows", "spread", "solve_lcp", "bordered_upper",
             "block_diagonal"):
    if hasattr(sm, name):
        wrap(sm, name, name)
for name in ("__init__", "_values", "factor", "solve"):
    wrap(fm.PardisoSymmetric, name, "PardisoSymmetric." + name)
wrap(fm.PardisoFactorization, "__init__", "PardisoFactorization.__init__")
wrap(fm.Factorization, "__init__", "Factorization.__init__ (Sigma's Cholesky)")
totals = []
for r in range(reps):
    if r == 1:
        stages.acc.clear()
    t0 = time.process_time()
    sc = sm.SparseContact(blocks, E, factorization="auto")
    st = sc.coarse_start(F, g) if len(g) >= sm.COARSE_ROWS else None
    sc.solve(F, g, st)
    totals.append(time.process_time() - t0)
print(f"thin_layer({n}): routes {[round(t, 3) for t in totals]} s; per route (rounds 2-{reps}), ms:")
print("\n".join(stages.lines(reps - 1, by_rest=True)))
