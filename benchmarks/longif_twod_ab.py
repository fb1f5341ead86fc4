"""The sparse route on thin_layer(n): this tree's ``backends/sparse.py`` against a baseline revision's, interleaved.

In ONE process (so that a shared machine's load touches both alike), ``reps`` rounds (the two sides' order
alternating) of: the route from its start as benchmarks/longif_ab.py times it (``SparseContact(...)``, then
``coarse_start`` above ``COARSE_ROWS`` rows, then ``solve``) with the baseline's module and with this tree's, and one
bonded PARDISO solve (pypardiso, the yardstick of benchmarks/bench_longif.py). The baseline's module is
``git show REV:cvxcontact/backends/sparse.py`` loaded as a module of this tree's package (its relative imports
resolve to this tree's modules: a comparison of the changes made in that file and in modules only it imports).
Prints the medians (process CPU s), the numeric factorisations, the capacitance columns, the ratios to the bonded
solve, and the answers' agreement: the active sets compared row for row, max |a - b| / max |b| of the stacked
displacements and of the row forces.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_twod_ab.py 3000 7 73f4b4d
"""

import importlib.util
import statistics
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import thin_layer_rounds, thin_layer_route

from cvxcontact.backends import sparse as after

warnings.simplefilter("ignore")
n, reps, rev = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
source = subprocess.run(["git", "show", f"{rev}:cvxcontact/backends/sparse.py"], cwd=HERE.parent, check=True,
                        capture_output=True, text=True).stdout
path = Path(tempfile.mkdtemp()) / "_sparse_baseline.py"
path.write_text(source)
spec = importlib.util.spec_from_file_location("cvxcontact.backends._sparse_baseline", path)
before = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = before
spec.loader.exec_module(before)

t, _, counts, answers = thin_layer_rounds({"before": before, "after": after}, thin_layer_route(n), reps)
b = statistics.median(t["bonded"])
(ub, yb, ab), (ua, ya, aa) = answers["before"], answers["after"]
print(n, {k: round(statistics.median(v), 3) for k, v in t.items()})
print("factorizations, columns, systems:", {k: sorted(set(v)) for k, v in counts.items()})
print(f"ratio before {statistics.median(t['before']) / b:.2f}, after {statistics.median(t['after']) / b:.2f}")
print("same active set:", bool(np.array_equal(ab, aa)), int(ab.sum()), "closed;",
      f"u {np.abs(ua - ub).max() / np.abs(ub).max():.2e}, y {np.abs(ya - yb).max() / np.abs(yb).max():.2e}")
