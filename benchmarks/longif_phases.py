"""PARDISO's phases in the sparse route on thin_layer(n), counted and timed (process CPU s), beside the rest.

Runs the route as benchmarks/longif_twod_ab.py times it (``SparseContact(...)``, ``coarse_start`` above
``COARSE_ROWS`` rows, ``solve``) ``reps`` times with a spy on PARDISO's calls (the coarse start's partial
factorisation, ``PardisoFactorization``, and the route's handle, ``PardisoSymmetric``), and one bonded PARDISO solve
per round; prints, for the last round, each call (phase, right-hand sides, CPU s) and, per round, the totals by kind.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_phases.py 3000 3
"""

import collections
import statistics
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import thin_layer_route

from cvxcontact.backends import factor as fm
from cvxcontact.backends import sparse as sm

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
blocks, E, g, F, bonded = thin_layer_route(n)
calls = []
inner = fm.PardisoFactorization._call


def spy(self, phase, b, x, nrhs=1):
    t0 = time.process_time()
    out = inner(self, phase, b, x, nrhs)
    calls.append((type(self).__name__, phase, nrhs, time.process_time() - t0))
    return out


fm.PardisoFactorization._call = fm.PardisoSymmetric._call = spy
rounds = []
for r in range(reps):
    calls.clear()
    t0 = time.process_time()
    sc = sm.SparseContact(blocks, E, factorization="auto")
    st = sc.coarse_start(F, g) if len(g) >= sm.COARSE_ROWS else None
    out = sc.solve(F, g, st)
    total = time.process_time() - t0
    yard = bonded()
    kinds = collections.defaultdict(lambda: [0, 0.0])
    for who, phase, nrhs, t in calls:
        key = f"{'coarse' if who == 'PardisoFactorization' else 'route'} {phase}"
        kinds[key][0] += 1
        kinds[key][1] += t
    pard = sum(t for *_, t in calls)
    rounds.append((total, yard, pard))
    print(f"round {r}: route {total:.3f} s, PARDISO {pard:.3f}, the rest {total - pard:.3f}, bonded {yard:.3f}, "
          f"ratio {total / yard:.2f}; factorizations {sc.factorizations}, columns {sc.column_solves}, "
          f"systems {out[-1]}")
    print("   ", {k: (c, round(t, 3)) for k, (c, t) in sorted(kinds.items())})
print("calls of the last round:", [(w[0], p, k, round(t, 4)) for w, p, k, t in calls])
med = [statistics.median(v) for v in zip(*rounds)]
print(f"medians: route {med[0]:.3f}, bonded {med[1]:.3f}, PARDISO {med[2]:.3f}, ratio {med[0] / med[1]:.2f}")
