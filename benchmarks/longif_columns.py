"""What a step of the sparse route costs on thin_layer(n): one numeric factorisation of K(A) against a block of k
capacitance columns solved in ONE PARDISO call (multiple right-hand sides), and the coarse start's partial
factorisation split into PARDISO's analysis and numeric phases.

The route (``SparseContact(...)``, ``coarse_start``, ``solve``, as benchmarks/longif_pkg_ab.py times it) is run once
for its answer's set A and its PARDISO handle; then, ``reps`` rounds, in one process: a numeric factorisation of
K(A) on the route's handle (phase 22, its analysis kept), and blocks of k = 1, 2, 4, 8, 16, 32, 64 capacitance
columns of the route's own kind (k added rows: a force -G_a^T on x each, F-ordered as ``_solve_columns`` builds them)
solved in one call (phase 33, k right-hand sides). Prints the medians (process CPU s), each block's cost per column
and how many columns of that block size cost one factorisation (the break-even of the capacitance form's reach).
Then the coarse start's partial factorisation (``PardisoFactorization`` with the coarse rows as its Schur block,
phase 12) split into phase 11 (analysis) and phase 22 (numeric, with the dense Schur block), and one bonded
PARDISO solve (pypardiso, the yardstick), per round.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_columns.py 5000 5
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import thin_layer_route

from cvxcontact.backends import coarse
from cvxcontact.backends import factor as fm
from cvxcontact.backends import sparse as sm

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
KS = (1, 2, 4, 8, 16, 32, 64)
blocks, E, g, F, bonded = thin_layer_route(n)
sc = sm.SparseContact(blocks, E, factorization="auto")
st = sc.coarse_start(F, g)
out = sc.solve(F, g, st)
active, handle = out[3], sc._pardiso
K = sc.matrix(active)
N, rows = K.shape[0], np.flatnonzero(active)
rng = np.random.default_rng(0)


def columns(k):
    cols = np.zeros((N, k), order="F")
    for j, a in enumerate(rng.choice(rows, k, replace=False)):
        row = sc.G.getrow(a)
        cols[row.indices, j] = -row.data
    return cols


# the coarse start's partial factorisation, phase 12 split into 11 and 22 (the same calls PARDISO makes in 12)
C = coarse.row_graph(sc.G)
idx = coarse.coarse_rows(C, np.ones(sc.m, dtype=bool))
U = coarse.bordered_upper(sc.A, sc.G[idx])
inner, split = fm.PardisoFactorization._call, []


def two_phases(self, phase, b, x, nrhs=1):
    if phase != 12:
        return inner(self, phase, b, x, nrhs)
    t0 = time.process_time()
    inner(self, 11, b, x, nrhs)
    t1 = time.process_time()
    inner(self, 22, b, x, nrhs)
    split.append((t1 - t0, time.process_time() - t1))


t = {"factor": [], "bonded": [], "schur 11": [], "schur 22": []} | {k: [] for k in KS}
for r in range(reps):
    t0 = time.process_time()
    handle.factor(K)
    t["factor"].append(time.process_time() - t0)
    for k in (KS if r % 2 == 0 else KS[::-1]):
        B = columns(k)
        t0 = time.process_time()
        handle.solve(B)
        t[k].append(time.process_time() - t0)
    fm.PardisoFactorization._call = two_phases
    fac = fm.PardisoFactorization(U, sc.n + np.arange(len(idx)), upper=True)
    fac.free()
    fm.PardisoFactorization._call = inner
    t["schur 11"].append(split[-1][0])
    t["schur 22"].append(split[-1][1])
    t["bonded"].append(bonded())
med = {k: statistics.median(v) for k, v in t.items()}
print(f"thin_layer({n}): {N} unknowns, {sc.m} rows, {int(active.sum())} closed; factor {handle.cost[0]:.0f} Mflop, "
      f"{handle.cost[1]:.3g} entries; {len(idx)} coarse rows; medians of {reps} rounds, process CPU s")
print(f"numeric factorisation {med['factor']:.4f}; bonded PARDISO solve {med['bonded']:.4f}")
for k in KS:
    print(f"  block of {k:3d} columns {med[k]:.4f} s, {med[k] / k:.4f} s a column, "
          f"{med['factor'] / (med[k] / k):.1f} such columns = one factorisation")
print(f"coarse partial factorisation: analysis (phase 11) {med['schur 11']:.4f}, numeric with the Schur block "
      f"(phase 22) {med['schur 22']:.4f}")
