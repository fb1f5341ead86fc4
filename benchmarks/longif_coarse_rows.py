"""The coarse rows' independent set (backends/coarse.coarse_rows) by its two ways of finding the balls of
COARSE_HOPS hops: the pattern of C^4 = (C^2)^2 formed once, or a search from each coarse row; and which one
``coarse_rows`` picks by the graph's density (coarse.SEARCH_WORK against C^2's mean row count squared).

For thin_layer(1000), (3000) (2D, slender) and tests/scenes3d.offset_boxes(16), (28) (3D overlays): the rows' graph
C, its mean row counts b1 (C), b2 (C^2), b4 (C^4), and the process CPU ms (best of 5) of C^2, of the power's way,
of the searches' way, of main's (C^4 by three products) and of ``coarse_rows`` as shipped (the same rows asserted).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_coarse_rows.py
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import scenes3d
from harness import coarse_rows_by_c4

import cvxcontact as cc
from cvxcontact.apps import demo
from cvxcontact.backends import coarse

warnings.simplefilter("ignore")


def best(f, *args, reps=5):
    times = []
    for _ in range(reps):
        t0 = time.process_time()
        out = f(*args)
        times.append(time.process_time() - t0)
    return 1e3 * min(times), out


def forced(C, work):
    old, coarse.SEARCH_WORK = coarse.SEARCH_WORK, work
    try:
        return coarse.coarse_rows(C, np.ones(C.shape[0], dtype=bool))
    finally:
        coarse.SEARCH_WORK = old


for name, make in [("thin_layer(1000)", lambda: demo.thin_layer(1000)),
                   ("thin_layer(3000)", lambda: demo.thin_layer(3000)),
                   ("offset_boxes(16)", lambda: scenes3d.offset_boxes(16)),
                   ("offset_boxes(28)", lambda: scenes3d.offset_boxes(28))]:
    p = cc.ContactSolver(make()).problem
    C = coarse.row_graph(sp.hstack([p.E @ b.jump for b in p.blocks]).tocsr())
    m = C.shape[0]
    t2, C2 = best(sp.csr_matrix.__matmul__, C, C)
    b2 = C2.nnz / m     # (all rows; coarse_rows counts DENSITY_SAMPLE of them)
    tp, rp = best(forced, C, np.inf)
    ts, rs = best(forced, C, 0.0)
    tc, rc = best(coarse.coarse_rows, C, np.ones(m, dtype=bool))
    tm, rm = best(coarse_rows_by_c4, C)
    assert np.array_equal(rp, rs) and np.array_equal(rp, rc) and np.array_equal(rp, rm)
    b4 = coarse._power(C2, 2).nnz / m
    print(f"{name}: rows {m}, b1 {C.nnz / m:.1f}, b2 {b2:.1f}, b4 {b4:.1f}, b2^2 {b2 * b2:.0f} "
          f"({'power' if b2 * b2 <= coarse.SEARCH_WORK else 'searches'}); coarse rows {len(rp)}; ms: C^2 {t2:.1f}, "
          f"power {tp:.1f}, searches {ts:.1f}, main (C^4 by 3 products) {tm:.1f}, shipped {tc:.1f}", flush=True)
