"""Where one re-solve's CPU time goes, split by stage, from a cProfile (process CPU timer) of several load cases.

Scene: ``apps.demo.two_blocks(nx)`` (as benchmarks/bench_resolve.py). The first solve, two load cases unprofiled,
then ``cases`` load cases profiled (the upper block's loads x 0.37, its traction x 1 + i / 100: no two alike).
Printed per load case (CPU ms, cumulative times of the functions named; cProfile's overhead included): the new
Scene (``Scene.with_loads``), the problem's loads (``DiscreteProblem.with_loads``), the forward sweeps
(``Condensation.apply``), the interface finish (``signorini.finish``), the fields (``Condensation.invert_closed``:
the closed rows' refinement and the backward sweeps), the read-back (``read_back``) and within it the checks
(``checks``), the error estimate (``estimate``), the resolution check (``unresolved``), and the whole
``ContactSolver.solve``; then the PARDISO/SuperLU calls alone (``factor``'s sweeps) and the share of the first
solve.

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_profile.py 560 4
"""

import cProfile
import pstats
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import two_blocks_solver

STAGES = [("new Scene", "physics/scene.py", "with_loads"), ("problem's loads", "discrete/problem.py", "with_loads"),
          ("forward sweeps", "backends/interface.py", "apply"),
          ("interface finish", "backends/signorini.py", "finish"),
          ("fields (refinement, backward sweeps)", "backends/interface.py", "invert_closed"),
          ("read-back", "solution/readback.py", "read_back"), ("  of which checks", "solution/checks.py", "checks"),
          ("error estimate", "solution/estimate.py", "estimate"), ("resolution check", "solution/resolution.py",
                                                                   "unresolved"),
          ("sweeps alone (factor.forward, backward)", "backends/factor.py", ("forward", "backward")),
          ("whole ContactSolver.solve", "cvxcontact/solve.py", "solve")]


def main():
    warnings.simplefilter("ignore")
    nx, cases = int(sys.argv[1]), int(sys.argv[2])
    scene, solver, first = two_blocks_solver(nx)

    def case(r, s=0.37):
        return scene.with_loads(0, body_force=(0.0, -2e9 * s), traction={"right": (0.0, 3e8 * s * (1 + r / 100))},
                                surface_charge={"left": -0.05 * s})

    for r in range(2):
        solver.solve(case(r))
    profile = cProfile.Profile(time.process_time)
    c0 = time.process_time()
    profile.enable()
    for r in range(2, 2 + cases):
        solver.solve(case(r))
    profile.disable()
    whole = (time.process_time() - c0) / cases
    stats = pstats.Stats(profile).stats
    print(f"two_blocks({nx}): first solve {first:.2f} CPU s; re-solve {1e3 * whole:.0f} CPU ms under cProfile "
          f"({100 * whole / first:.2f} % of the first solve); per load case:")
    for label, path, names in STAGES:
        names = (names,) if isinstance(names, str) else names
        ms = 1e3 * sum(v[3] for (file, _, name), v in stats.items() if file.endswith(path) and name in names) / cases
        print(f"  {label:42s} {ms:7.1f} ms  ({100 * ms / (1e3 * whole):4.1f} %)")


if __name__ == "__main__":
    main()
