"""Exploration (not shipped): the sparse route on thin_layer(n) with PARDISO's low-rank update of the factor.

PARDISO updates a factorisation for a few changed values of a matrix of the same pattern (iparm[38] = 1, 0-based;
the changed entries listed in ``perm``: perm[0] their count, then (row, column) pairs, 0-based, of the stored upper
triangle) only where its weighted matching is off (iparm[10] = iparm[12] = 0) and with iparm[23] = 10 (measured
here, thin_layer(3000): with the route's matching the update takes a numeric factorisation's time, as round two
found; without it and with iparm[23] = 10 a few percent of it). Without the matching, the contact rows' zero
pivots are perturbed (7,300-7,700 on thin_layer(3000)) and each solve needs refinement: backward error 4e-7, then
7.5e-13 and 3e-16 after one and two refinement steps.

This script monkeypatches the route (``SparseContact._analysed``: minimum degree, no matching, iparm[23] = 10;
``PardisoSymmetric.factor``: after the first factorisation of a handle, the update from the previous values, the
changed entries found by comparing them) and compares, interleaved in one process over ``reps`` rounds (process CPU
s, medians): "main" (the route as shipped), "lowrank" (the update, the route's own check and refinement to a
componentwise backward error of 1e-12) and "lowrank+1" (the same and one refinement step more after each system's
check, where the factor had perturbed pivots), and one bonded PARDISO solve (pypardiso, the yardstick). Prints the
counts (factorisations, columns, systems, attempts; updates and the entries each changed) and each variant's answer
against main's (the active set row for row; max |a - b| / max |b| of u and of the forces).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_longif_lowrank.py 3000 5
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import thin_layer_route

from cvxcontact.backends import factor as fm
from cvxcontact.backends import sparse as sm

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
blocks, E, g, F, bonded = thin_layer_route(n)
shipped = {"factor": fm.PardisoSymmetric.factor, "analysed": sm.SparseContact._analysed,
           "system": sm.SparseContact._system}
mode = {"name": "main"}
stats = {"updates": []}


def factor(self, K):
    if not getattr(self, "_low_rank", False):
        return shipped["factor"](self, K)
    old = self._a.copy() if getattr(self, "_factored", False) else None
    self._values(K, "factor")
    if old is None:
        self._call(22, None, None)
    else:
        pos = np.flatnonzero(old != self._a)                 # the changed entries of the upper triangle
        rows = np.repeat(np.arange(self.n, dtype=np.int32), np.diff(self._ia))[pos]
        perm = np.zeros(max(self.n, 1 + 2 * len(pos)), dtype=np.int32)
        perm[0] = len(pos)
        perm[1:1 + 2 * len(pos)] = np.column_stack([rows, self._ja[pos]]).ravel()
        kept, self._perm, self._iparm[38] = self._perm, perm, 1
        try:
            self._call(22, None, None)
        finally:
            self._perm, self._iparm[38] = kept, 0
        stats["updates"].append(len(pos))
    self._factored = True
    self.perturbed = int(self._iparm[13])
    return self


def analysed(self, K, active, own_analysis):
    if mode["name"] == "main" or own_analysis:
        return shipped["analysed"](self, K, active, own_analysis)
    moves = np.asarray(abs(self.G).sum(axis=1)).ravel() > 0
    handle = fm.PardisoSymmetric(K, ordering=0)
    handle._iparm[10] = handle._iparm[12] = 0                # no scaling, no weighted matching
    handle._iparm[23] = 10
    handle._low_rank = True
    return handle.analyse(self.matrix(moves) if self._bonded_analysis else K)


def system(self, active):
    z = shipped["system"](self, active)
    if z is None or mode["name"] != "lowrank+1" or self._pardiso is None or not self._pardiso.perturbed:
        return z
    b = np.concatenate([self.F, np.where(active, self._g, 0.0)])
    dz = self._solve_on(active, b - self.pattern.kept(active, self.soft) @ z)
    return z if dz is None else z + dz


fm.PardisoSymmetric.factor, sm.SparseContact._analysed, sm.SparseContact._system = factor, analysed, system
names = ("main", "lowrank", "lowrank+1")
t = {k: [] for k in (*names, "bonded")}
info, answers = {}, {}
for r in range(reps):
    for name in (names if r % 2 == 0 else names[::-1]):
        mode["name"] = name
        stats["updates"] = []
        t0 = time.process_time()
        sc = sm.SparseContact(blocks, E, factorization="auto")
        st = sc.coarse_start(F, g)
        out = sc.solve(F, g, st)
        t[name].append(time.process_time() - t0)
        info[name] = (sc.factorizations, sc.column_solves, out[-1], sc.attempts, list(stats["updates"]))
        answers[name] = (np.concatenate(out[0]), out[2], out[3])
    t["bonded"].append(bonded())
b = statistics.median(t["bonded"])
ua, ya, aa = answers["main"]
print(f"thin_layer({n}), {reps} rounds; bonded PARDISO solve {b:.3f} s")
for name in names:
    u, y, a = answers[name]
    f, c, s, att, upd = info[name]
    print(f"{name:10s} {statistics.median(t[name]):.3f} s (ratio {statistics.median(t[name]) / b:.2f}; "
          f"{[round(x, 2) for x in t[name]]}); factorizations {f}, columns {c}, systems {s}, attempts {att}, "
          f"updates (entries changed) {upd}; same set as main {bool(np.array_equal(a, aa))}, "
          f"u {np.abs(u - ua).max() / np.abs(ua).max():.1e}, y {np.abs(y - ya).max() / np.abs(ya).max():.1e}")
