"""Benchmark: the friction estimate's read-back of t_h on 3D P2 faces (docs/accuracy.md, "Friction"): the Riesz
representer of the row forces (:meth:`cvxcontact.fem.trace.QuadraticTrace.friction_fields`) against the forces over
the rows' areas (the lumped read-back of 2D and 3D P1, :meth:`cvxcontact.fem.trace.LinearTrace.friction_fields`),
on the uniformly sheared layer stuck on a plane (tests/friction_scenes.py ``uniform_layer3d``: the exact solution),
the sliding layer (``sliding_layer3d``) and the sheared box in partial slip (``box``, Tresca g = 0.5 p,
shear 0.25 p; 3 x 3, 6 x 6 and 12 x 12 x 2 cells): the estimate's relative value and its parts over the norm
squared, and the estimate's CPU seconds:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests python benchmarks/friction_estimate_p2.py

Results: benchmarks/results/friction_estimate_p2.md.
"""

from __future__ import annotations

import time
from contextlib import contextmanager

import numpy as np
from friction_scenes import P, box, sliding_layer3d, uniform_layer3d

import cvxcontact as cc
from cvxcontact.fem import trace
from cvxcontact.solution.estimate import estimate

PARTS = ("element", "contact traction", "friction cone", "slip complementarity")


@contextmanager
def lumped():
    """The lumped read-back on P2 faces too (the estimate before the representer)."""
    keep = trace.QuadraticTrace.friction_fields
    trace.QuadraticTrace.friction_fields = trace.LinearTrace.friction_fields
    try:
        yield
    finally:
        trace.QuadraticTrace.friction_fields = keep


def row(name, sol):
    cells = []
    for reading in ("representer", "lumped"):
        if reading == "lumped":
            with lumped():
                t0 = time.process_time()
                est = estimate(sol)[0]
        else:
            t0 = time.process_time()
            est = estimate(sol)[0]
        seconds = time.process_time() - t0
        n2 = est.norm ** 2
        cells.append(f"{est.relative:.4g} | " + " | ".join(f"{est.parts.get(k, 0.0) / n2:.2e}" for k in PARTS)
                     + f" | {seconds:.3f}")
    print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def main():
    heads = " | ".join(["relative", *PARTS, "CPU s"])
    print(f"| scene | {heads} (representer) | {heads} (lumped) |")
    print("|---" * (1 + 2 * (len(PARTS) + 2)) + "|")
    for tau in (0.1, 0.2):
        sol = cc.solve(uniform_layer3d(tau * P, cc.Tresca(0.3 * P)), degree=2, condition="sigma1", estimate=False)
        row(f"stuck layer, tau = {tau} p", sol)
    for n in (2, 4):
        sol = cc.solve(sliding_layer3d(0.1 * P, n=n), degree=2, condition="sigma1", estimate=False)
        row(f"sliding layer, {n} x {n}", sol)
    q = 0.25 * P * np.array([np.cos(0.5), np.sin(0.5)])
    for n in (3, 6, 12):
        sol = cc.solve(box(q, cc.Tresca(0.5 * P), n=n), degree=2, condition="sigma1", estimate=False)
        row(f"box in partial slip, {n} x {n} x 2", sol)


if __name__ == "__main__":
    main()
