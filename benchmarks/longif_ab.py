"""The sparse route on thin_layer(n) with PARDISO analysed in nested dissection against minimum degree, interleaved.

In ONE process (so that a shared machine's load touches every variant alike), ``reps`` rounds of: the route from its
start (``SparseContact(...).solve`` after ``coarse_start`` above ``COARSE_ROWS`` rows, as benchmarks/bench_longif.py
times it) with ``sparse.SLENDER_FACE`` set out of reach (nested dissection: the route before the fifth round) and as
shipped (minimum degree), and one bonded PARDISO solve (pypardiso, the yardstick of bench_longif.py). Prints the
medians (process CPU s) and the ratios to the bonded solve.

Run (one thread):  OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_ab.py 3000 7
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import thin_layer_route

from cvxcontact.backends import sparse as sm
from cvxcontact.backends.sparse import SparseContact

warnings.simplefilter("ignore")
n, reps = int(sys.argv[1]), int(sys.argv[2])
blocks, E, g, F, bonded = thin_layer_route(n)
t = {"nd": [], "md": [], "bonded": []}
for r in range(reps):
    for mode in ("nd", "md", "bonded"):
        if mode == "bonded":
            t[mode].append(bonded())
            continue
        sm.SLENDER_FACE = 2 / 3 if mode == "md" else np.inf
        t0 = time.process_time()
        sc = SparseContact(blocks, E, factorization="auto")
        st = sc.coarse_start(F, g) if len(g) >= sm.COARSE_ROWS else None
        sc.solve(F, g, st)
        t[mode].append(time.process_time() - t0)
b = statistics.median(t["bonded"])
nd, md = statistics.median(t["nd"]) / b, statistics.median(t["md"]) / b
print(n, {k: round(statistics.median(v), 3) for k, v in t.items()},
      f"ratio nested dissection {nd:.2f}, minimum degree {md:.2f}")
