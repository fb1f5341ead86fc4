"""Benchmark: the effectivity (estimate / true error) of the error estimate with a friction law, on the sheared
block of :data:`cvxcontact.apps.studies.estimate.FRICTION_SCENES` (Tresca P1 and P2, Coulomb P1): levels 0, 1, 2
of uniform refinement against a nested reference at level ``REFERENCE`` (the estimate study's loop,
:func:`cvxcontact.apps.studies.estimate.effectivity`), with the share of the friction terms in eta^2:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/friction_estimate.py

Results: benchmarks/results/friction_estimate.md.
"""

from __future__ import annotations

import sys
import time

from cvxcontact.apps.studies.estimate import (
    FRICTION_SCENES,
    against_reference,
    measure_estimate,
)

LEVELS, REFERENCE = (0, 1, 2), 4


def measure(sol, err, ref):
    columns, line = measure_estimate(sol, err, ref)
    p = sol.estimate.parts
    total = sum(p.values())
    columns.update(traction=p["contact traction"] / total,
                   friction=(p.get("friction cone", 0.0) + p.get("slip complementarity", 0.0)) / total)
    return columns, line


def main(names=None):
    print("| scene | level | cells | estimate | true error | effectivity | contact traction share | "
          "friction terms share | cpu s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (build, options) in FRICTION_SCENES.items():
        if names and name not in names:
            continue
        start = time.process_time()
        rows = against_reference(build, options, LEVELS, REFERENCE, measure)
        cpu = time.process_time() - start
        for r in rows:
            print(f"| {name} | {r['level']} | {r['cells']} | {r['estimate']:.4g} | {r['true_error']:.4g} | "
                  f"{r['effectivity']:.3g} | {r['traction']:.3f} | {r['friction']:.2e} | {cpu:.0f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
