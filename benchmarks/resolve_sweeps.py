"""What one sweep of each body's factors costs, against the size of those factors (a re-solve's floor).

Scene: ``apps.demo.two_blocks(nx)`` solved once by a ContactSolver (PARDISO where available). Per body: its
factorisation's class, order, contact dofs, PARDISO's memory report (``Factorization.memory``; iparm[14]-[16], KB:
the analysis' peak, the permanent and the numerical factor), then ``repeats`` times the process CPU ms of one forward
sweep and one backward sweep of a random right-hand side (``factor.forward``, ``factor.backward``), of the same with
two columns, and of one whole solve (phase 33). The sweeps read the numerical factor once each: ms against MB gives
the bandwidth they run at.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_sweeps.py 560 3
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import two_blocks_solver


def ms(f, *args):
    """(f(*args), its process CPU ms)."""
    c0 = time.process_time()
    out = f(*args)
    return out, 1e3 * (time.process_time() - c0)


def main():
    warnings.simplefilter("ignore")
    nx, repeats = int(sys.argv[1]), int(sys.argv[2])
    _, solver, first = two_blocks_solver(nx)
    print(f"two_blocks({nx}): first solve {first:.2f} CPU s")
    for k, c in enumerate(solver._cache.condensation.bodies):
        f = c.factor
        ip = getattr(f, "_iparm", None)
        report = "" if ip is None else f", iparm[14:17] {list(map(int, ip[14:17]))} KB"
        print(f"body {k}: {type(f).__name__}, order {f.n}, {len(f.gamma)} contact dofs, memory "
              f"{f.memory / 1e6:.0f} MB{report}")
        rng = np.random.default_rng(k)
        rhs, two = rng.standard_normal(f.n), rng.standard_normal((f.n, 2))
        for _ in range(repeats):
            fw, t1 = ms(f.forward, rhs)
            _, t2 = ms(f.backward, fw, fw.reduced)
            fw2, t3 = ms(f.forward, two)
            _, t4 = ms(f.backward, fw2, fw2.reduced)
            line = f"  forward {t1:.1f} ms, backward {t2:.1f} ms; two columns {t3:.1f} + {t4:.1f} ms"
            if ip is not None:
                b, x = np.array(rhs, order="F"), np.zeros(f.n)
                _, t5 = ms(f._call, 33, b, x, 1)
                line += f"; phase 33 {t5:.1f} ms"
            print(line)


if __name__ == "__main__":
    main()
