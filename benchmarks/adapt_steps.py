"""Benchmark: where the time of one ``cc.adapt`` run goes, warm-started (default), cold (``warm_start=False``) and
fast (the adapt study's P2 loop: ``theta=0.9, rate=1.0, exact_steps=False``).

The scene is the adapt study's (cvxcontact/apps/studies/adapt.py: the Hertz cylinder on a block, uniform start
with 8 cells along the cylinder's trace), P2 "gamma3" (or ``--degree 1``), method "condensed", Dorfler theta 0.5
(cold, warm; fast: its own options), up to ``--cells`` triangles. Per run: the total, and the sum over the steps of each stage of ``sol.info.timings``
(assembly: the problem's construction; factorization: the bodies' condensation onto the interface; model,
compile, solve: the interior point's program; polish: the exact finish (cuts); certificate; read_back; estimate)
and of the marking, bisection and rebuilt scene (refine). CPU seconds (``time.process_time``, patched into the
package's clocks): on a machine shared with other work, wall time measures the neighbours. Run single-threaded
(``OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``): the dense interface operations are a few
hundred rows, where threads only wait on each other (measured: a 327 x 107 QR takes 16 ms on one thread, a
median 330 ms and up to 3.5 s with two threads on two loaded cores).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/adapt_steps.py --degree 2

(``PYTHONPATH=.`` from a checkout: the package it imports is printed first.)
"""

from __future__ import annotations

import argparse
import time
import warnings

time.perf_counter = time.process_time       # the package's stage clocks in CPU seconds (module docstring)

import cvxcontact  # noqa: E402
from cvxcontact.solve import ContactSolver  # noqa: E402
from cvxcontact.adapt import adapt  # noqa: E402
from cvxcontact.apps.studies.adapt import coarse_scene  # noqa: E402
from cvxcontact.errors import ResidualWarning, ResolutionWarning  # noqa: E402


RUNS = {"cold": {"theta": 0.5, "warm_start": False}, "warm": {"theta": 0.5},
        "fast": {"theta": 0.9, "rate": 1.0, "exact_steps": False}}
"""The runs compared: name -> the options of cc.adapt."""


def run(degree: int, cells: int, options: dict) -> tuple[float, dict, object]:
    """(CPU seconds, stage sums, the Adapted result) of one adapt run with ``options``."""
    timings = []
    solver = ContactSolver
    original = solver.solve

    def recorded(self, scene=None):
        sol = original(self, scene)
        timings.append(dict(sol.info.timings))
        return sol

    solver.solve = recorded
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResolutionWarning)
            warnings.simplefilter("ignore", ResidualWarning)
            t0 = time.process_time()
            result = adapt(coarse_scene(), "gamma3", max_steps=60, max_cells=cells, degree=degree,
                           method="condensed", **options)
            total = time.process_time() - t0
    finally:
        solver.solve = original
    stages = {}
    for t in timings:
        for k, v in t.items():
            stages[k] = stages.get(k, 0.0) + v
    stages["refine"] = sum(s.refine_s for s in result.history)
    return total, stages, result


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--degree", type=int, default=2)
    parser.add_argument("--cells", type=int, default=4200, help="max_cells of the run (all bodies)")
    args = parser.parse_args(argv)
    runs = {name: run(args.degree, args.cells, options) for name, options in RUNS.items()}
    keys = sorted({k for _, s, _ in runs.values() for k in s}, key=lambda k: -runs["cold"][1].get(k, 0.0))
    print(f"cvxcontact {cvxcontact.__version__} from {cvxcontact.__file__}")
    for name, (_, _, result) in runs.items():
        h = result.history
        print(f"P{args.degree} {name}: {len(h)} steps to {h[-1].unknowns} unknowns ({h[-1].cells} cells)")
    print("CPU seconds\n\n| stage | " + " | ".join(runs) + " |\n|---|" + "---|" * len(runs))
    for k in keys:
        print(f"| {k} | " + " | ".join(f"{r[1].get(k, 0.0):.2f}" for r in runs.values()) + " |")
    print("| **total** | " + " | ".join(f"**{r[0]:.2f}**" for r in runs.values()) + " |")


if __name__ == "__main__":
    main()
