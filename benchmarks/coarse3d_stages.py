"""The sparse route's coarse start on a 3D scene by stage: each stage's process CPU ms (inclusive), PARDISO's share.

``SparseContact(...).coarse_start(F, g)`` on tests/scenes3d.offset_boxes(n), two_boxes(n) or explore_coarse3d.py's
plate(n) (``factorization="auto"``) ``reps`` times (the first round left out: first-call costs), each listed
function wrapped by a timer (process CPU, inclusive) that also sums the PARDISO calls inside it
(``PardisoFactorization._call``). The stages nest (``coarse_start`` holds ``_coarse``, which holds ``row_graph``,
``coarse_rows``, ...): ``_coarse``'s own lines (G[idx], the forward solve's vectors) are its inclusive time less
its callees'.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/coarse3d_stages.py offset 28 4
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/coarse3d_stages.py two 24 4
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/coarse3d_stages.py plate 55 4
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import scenes3d
from harness import StageTimes

import cvxcontact as cc
from cvxcontact.backends import factor as fm
from cvxcontact.backends import sparse as sm
from cvxcontact.backends.condensed import quasi_definite_rhs

warnings.simplefilter("ignore")
scene, n, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
if scene == "plate":                            # benchmarks/explore_coarse3d.py's clamped plate on a block, sigma1
    from explore_coarse3d import plate

    p = cc.ContactSolver(plate(n), method="sparse").problem
else:
    p = cc.ContactSolver(scenes3d.offset_boxes(n) if scene == "offset" else scenes3d.two_boxes(n)).problem
blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
stages = StageTimes()
wrap = stages.wrap


wrap(fm.PardisoFactorization, "_call", "PARDISO (phases 12, 331)", pardiso=True)
wrap(fm, "_open", "factor._open")
wrap(fm, "_release", "factor._release")
for name in ("coarse_start", "_coarse"):
    wrap(sm.SparseContact, name, "SparseContact." + name)
for name in ("row_graph", "coarse_rows", "spread", "solve_lcp", "bordered_upper"):
    wrap(sm, name, name)
for name in ("__init__", "forward", "free"):
    wrap(fm.PardisoFactorization, name, "PardisoFactorization." + name)
wrap(fm.Factorization, "__init__", "Factorization.__init__ (W_c's Cholesky)")
totals, starts = [], []
for r in range(reps):
    if r == 1:
        stages.acc.clear()
    sc = sm.SparseContact(blocks, E, factorization="auto")
    t0 = time.process_time()
    starts.append(sc.coarse_start(F, g))
    totals.append(time.process_time() - t0)
st = starts[-1]
print(f"{scene}({n}): {len(g)} rows, n = {sc.n}; start {None if st is None else int(st.sum())} rows; "
      f"coarse_start {[round(t, 3) for t in totals]} s; per call (rounds 2-{reps}), ms:")
print("\n".join(stages.lines(reps - 1, by_rest=False)))
