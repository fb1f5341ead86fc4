"""Benchmark: issue 30's adapt call, ``cc.adapt(scene, tol=0.005, condition="gamma3", degree=d,
max_unknowns=50_000)``, with ``cc.adapt``'s defaults (``cvxcontact.adapt.LOOPS``) and with the old ones (theta 0.5,
one bisection per marked cell, every step exact), P1 and P2, on the adapt study's Hertz cylinder (``coarse_scene``,
method "condensed") and on issue 30's punch (``punch_scene``: a rigid cylinder, force-controlled, on the uniform
8 x 8 half block). Per run: why it stopped, the solves, the unknowns of the last mesh, its relative estimate, the CPU
seconds of the whole call, the peak pressure's and the half-width's errors against Hertz (the study's ``measures``
and ``punch_measures``), ok and polished. The numbers are in docs/accuracy.md ("Defaults per degree").

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/adapt_defaults.py

(``--only punch`` or ``--only hertz``: one scene; the punch's P2 runs take about a minute each.)
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import cvxcontact as cc
from cvxcontact.apps.studies.adapt import (
    coarse_scene,
    measures,
    punch_measures,
    punch_scene,
)

SCENES = {"hertz": (coarse_scene, measures, {"method": "condensed"}), "punch": (punch_scene, punch_measures, {})}
OLD = {"theta": 0.5, "rate": math.inf, "exact_steps": True}


def run(name: str, degree: int, loop: dict) -> str:
    build, read, options = SCENES[name]
    clock = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        result = cc.adapt(build(), tol=0.005, condition="gamma3", degree=degree, max_unknowns=50_000, **loop,
                          **options)
    seconds = time.process_time() - clock
    m, last = read(result.solution), result.history[-1]
    return (f"| {name} | P{degree} | {'old' if loop else 'default'} | {result.stopped} | {len(result.history)} | "
            f"{last.unknowns} | {last.relative:.3g} | {seconds:.1f} | {m['p0_rel_error']:+.2e} | "
            f"{m['a_rel_error']:+.2e} | {result.solution.ok and result.solution.polished} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=sorted(SCENES))
    args = parser.parse_args()
    print(f"cvxcontact {cc.__version__} from {cc.__file__}")
    print("| scene | degree | loop | stopped | solves | unknowns | relative | CPU s | peak | half-width | exact |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in SCENES if args.only is None else [args.only]:
        for degree in (1, 2):
            for loop in ({}, OLD) if degree == 2 else ({},):     # P1's default is the old loop
                print(run(name, degree, loop), flush=True)


if __name__ == "__main__":
    main()
