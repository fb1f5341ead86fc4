"""The sparse route on thin_layer(n): this tree's package against a baseline revision's WHOLE package, interleaved.

As benchmarks/longif_twod_ab.py, but the baseline is the revision's whole ``cvxcontact`` package (``git archive``
into a temporary directory as the package ``cvxcontact_base``; the route's modules import one another relatively),
so changes in ``backends/factor.py`` and ``backends/coarse.py`` are compared too, not only ``backends/sparse.py``.
In ONE process, ``reps`` rounds (the two sides' order alternating) of: the route from its start as the A/B scripts
time it (``SparseContact(...)``, ``coarse_start`` above ``COARSE_ROWS`` rows, ``solve``) with each package, and one
bonded PARDISO solve (pypardiso, the yardstick). A spy on each package's PARDISO calls splits each side's process
CPU seconds into PARDISO's and the rest's. Prints the medians, the ratios to the bonded solve, the counts, and the
answers' agreement (active sets row for row; max |a - b| / max |b| of the displacements and of the row forces).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_pkg_ab.py 3000 7 1f844ec7
"""

import importlib
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import thin_layer_rounds, thin_layer_route

from cvxcontact.backends import factor as factor_after
from cvxcontact.backends import sparse as after

warnings.simplefilter("ignore")
n, reps, rev = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
tmp = Path(tempfile.mkdtemp())
archive = subprocess.run(["git", "archive", rev, "cvxcontact"], cwd=HERE.parent, check=True,
                         capture_output=True).stdout
subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
(tmp / "cvxcontact").rename(tmp / "cvxcontact_base")
sys.path.insert(0, str(tmp))
before = importlib.import_module("cvxcontact_base.backends.sparse")
factor_before = importlib.import_module("cvxcontact_base.backends.factor")

pardiso = {"now": 0.0}


def spied(inner):
    def spy(self, *args):
        t0 = time.process_time()
        try:
            return inner(self, *args)
        finally:
            pardiso["now"] += time.process_time() - t0
    return spy


for fm in (factor_before, factor_after):
    fm.PardisoFactorization._call = fm.PardisoSymmetric._call = spied(fm.PardisoFactorization._call)

t, rest, counts, answers = thin_layer_rounds({"before": before, "after": after}, thin_layer_route(n), reps,
                                            pardiso=lambda: pardiso["now"])
b = statistics.median(t["bonded"])
(ub, yb, ab), (ua, ya, aa) = answers["before"], answers["after"]
print(n, {k: round(statistics.median(v), 3) for k, v in t.items()}, "rest (not PARDISO):",
      {k: round(statistics.median(v), 3) for k, v in rest.items()})
print("factorizations, columns, systems:", {k: sorted(set(v)) for k, v in counts.items()})
print(f"ratio before {statistics.median(t['before']) / b:.2f}, after {statistics.median(t['after']) / b:.2f}")
print("same active set:", bool(np.array_equal(ab, aa)), int(ab.sum()), "closed;",
      f"u {np.abs(ua - ub).max() / np.abs(ub).max():.2e}, y {np.abs(ya - yb).max() / np.abs(yb).max():.2e}",
      "bit for bit:", bool(np.array_equal(ua, ub) and np.array_equal(ya, yb)))
