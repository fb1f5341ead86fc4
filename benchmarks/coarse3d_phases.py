"""The coarse start's partial factorisation on a 3D scene by PARDISO phase, with other settings, and (``--bonded``)
the route's bonded system's factorisation for scale.

Builds the coarse start's bordered matrix M = [[A, G_c^T], [G_c, 0]] (``coarse.bordered_upper``, the coarse rows of
``coarse.coarse_rows`` on every row) of tests/scenes3d.offset_boxes(n) or two_boxes(n) and runs PARDISO on it with
``PardisoFactorization``'s arrays and iparm, phase 11 (analysis) then 22 (numeric), timed apart in process CPU s:
as shipped (Schur block = the coarse rows, iparm[35] = 1), with no Schur block (iparm[35] = 0), iparm[35] = 2,
minimum degree asked (iparm[1] = 0), scaling and weighted matching (iparm[10] = iparm[12] = 1); prints each one's
factor size and the largest difference of its W_c from the shipped one. ``--bonded``: also the analysis and the
numeric factorisation of the route's bonded system K (every row closed, ``PardisoSymmetric`` as the route makes it;
87 CPU s on offset_boxes(28)).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 python benchmarks/coarse3d_phases.py offset 28 [--bonded]
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import scenes3d

import cvxcontact as cc
from cvxcontact.backends import factor as fm
from cvxcontact.backends import sparse as sm
from cvxcontact.backends.coarse import bordered_upper, coarse_rows, row_graph

warnings.simplefilter("ignore")
scene, n = sys.argv[1], int(sys.argv[2])
p = cc.ContactSolver(scenes3d.offset_boxes(n) if scene == "offset" else scenes3d.two_boxes(n)).problem
sc = sm.SparseContact(list(p.blocks), p.E, factorization="auto")
idx = coarse_rows(row_graph(sc.G), np.ones(sc.m, dtype=bool))
U, gamma = bordered_upper(sc.A, sc.G[idx]), sc.n + np.arange(len(idx))
print(f"{scene}({n}): n = {sc.n}, m = {sc.m}, coarse rows c = {len(idx)}, M's upper entries {U.nnz}", flush=True)
SHIPPED = {0: 1, 1: 3, 7: 0, 9: 13, 10: 0, 12: 0, 17: 0, 26: 0, 34: 1, 35: 1}     # PardisoFactorization's iparm


def run(label, **changed):
    obj = fm.PardisoFactorization.__new__(fm.PardisoFactorization)
    obj._a, obj._ia, obj._ja = np.ascontiguousarray(U.data), U.indptr.astype(np.int32), U.indices.astype(np.int32)
    fm._open(obj, fm._load(), U.shape[0], None)
    obj._perm[gamma] = 1
    for k, v in {**SHIPPED, **{int(k[1:]): v for k, v in changed.items()}}.items():
        obj._iparm[k] = v
    schur = np.zeros((len(gamma), len(gamma)))
    t0 = time.process_time()
    obj._call(11, None, schur)
    t1 = time.process_time()
    obj._call(22, None, schur)
    t2 = time.process_time()
    ip = obj._iparm
    print(f"{label:34s} analysis {t1 - t0:6.3f} s  numeric {t2 - t1:6.3f} s  perturbed {int(ip[13])}  "
          f"factor {int(ip[16]) / 1024:6.0f} MB", flush=True)
    obj._finalizer()
    return schur


W = run("shipped (Schur iparm[35] = 1, ND)")
run("no Schur block (iparm[35] = 0)", i35=0)
for label, kw in (("iparm[35] = 2", {"i35": 2}), ("minimum degree asked (iparm[1] = 0)", {"i1": 0}),
                  ("scaling and matching", {"i10": 1, "i12": 1})):
    print(f"{'':34s} W_c's largest difference from shipped: {np.abs(run(label, **kw) - W).max():.1e}")
if "--bonded" in sys.argv:
    K = sc.matrix(np.ones(sc.m, dtype=bool))
    ps = fm.PardisoSymmetric(K)
    t0 = time.process_time()
    ps.analyse(K)
    t1 = time.process_time()
    ps.factor(K)
    print(f"the route's bonded K ({K.shape[0]} unknowns): analysis {t1 - t0:.3f} s, numeric "
          f"{time.process_time() - t1:.3f} s, (Mflop, factor nonzeros) {ps.cost}")
    ps.release()
