"""The sparse route on thin_layer(n) without and with its final factor of K(A) (the answer clock-free), interleaved.

In ONE process, ``reps`` rounds (the two variants' order alternating) of: the route from its start as
benchmarks/longif_ab.py times it, with ``SparseContact._timed`` off (the answer from the capacitance form on the
base the steps ended on, as before) and on (as shipped), and one bonded PARDISO solve (pypardiso). Prints the
medians (process CPU s), the numeric factorisations and the ratios to the bonded solve.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_final_ab.py 3000 7
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import thin_layer_route

from cvxcontact.backends import sparse as sm
from cvxcontact.backends.sparse import SparseContact

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
blocks, E, g, F, bonded = thin_layer_route(n)
t = {"branch": [], "fix": [], "bonded": []}
nf = {"branch": [], "fix": []}
for r in range(reps):
    for mode in (("branch", "fix", "bonded") if r % 2 == 0 else ("fix", "branch", "bonded")):
        if mode == "bonded":
            t[mode].append(bonded())
            continue
        t0 = time.process_time()
        sc = SparseContact(blocks, E, factorization="auto")
        sc._timed = mode == "fix"
        st = sc.coarse_start(F, g) if len(g) >= sm.COARSE_ROWS else None
        sc.solve(F, g, st)
        t[mode].append(time.process_time() - t0)
        nf[mode].append(sc.factorizations)
b = statistics.median(t["bonded"])
without, with_ = statistics.median(t["branch"]) / b, statistics.median(t["fix"]) / b
print(n, {k: round(statistics.median(v), 3) for k, v in t.items()}, nf,
      f"ratio without the final factor {without:.2f}, with {with_:.2f}")
