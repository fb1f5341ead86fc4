"""Benchmark: the effectivity (estimate / true error) of the error estimate with a friction law, on the sheared
block of :data:`cvxcontact.apps.studies.estimate.FRICTION_SCENES` (Tresca P1 and P2, Coulomb P1; levels 0, 1, 2 of
uniform refinement against a nested reference at level 4) and the sheared box in 3D (Tresca P1; levels 0, 1
against level 3), by the estimate study's loop (:func:`cvxcontact.apps.studies.estimate.against_reference`), with
the shares of the contact traction and of the friction terms in eta^2:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/friction_estimate.py \\
        [--riesz] [scene names]

``--riesz`` (2D only) reads t_h as the Riesz representer of the shear forces in X_h (M t_h = the forces, as
lambda_h is read) instead of the lumped shear the estimate uses (:mod:`cvxcontact.solution.slipestimate`).

Results: benchmarks/results/friction_estimate.md.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from cvxcontact.apps.studies.estimate import (
    FRICTION_SCENES,
    against_reference,
    measure_estimate,
)
from cvxcontact.solution import slipestimate

LEVELS = {2: ((0, 1, 2), 4), 3: ((0, 1), 3)}


def riesz(contact):
    """t_h with M t_h = the shear forces, M the P1 (P2) mass matrix of the 2D merged line; None without friction."""
    if contact.shear_force is None:
        return None
    x = np.asarray(contact.x, dtype=float)
    step = contact.degree
    h = np.diff(x[::step])
    local = (np.array([[2, 1], [1, 2]]) / 6.0 if step == 1
             else np.array([[4, 2, -1], [2, 16, 2], [-1, 2, 4]]) / 30.0)          # nodes in order along the line
    idx = np.arange(len(h))[:, None] * step + np.arange(step + 1)[None, :]
    rows = np.repeat(idx, step + 1, axis=1).ravel()
    cols = np.tile(idx, (1, step + 1)).ravel()
    vals = (h[:, None, None] * local[None]).ravel()
    M = sp.csc_matrix((vals, (rows, cols)), shape=(len(x), len(x)))
    return spla.spsolve(M, np.asarray(contact.shear_force, dtype=float))


def measure(sol, err, ref):
    columns, line = measure_estimate(sol, err, ref)
    p = sol.estimate.parts
    total = sum(p.values())
    columns.update(traction=p["contact traction"] / total,
                   friction=(p.get("friction cone", 0.0) + p.get("slip complementarity", 0.0)) / total)
    return columns, line


def main(args):
    if "--riesz" in args:
        lumped = slipestimate.friction_of

        def riesz_of(sol, i):
            f = lumped(sol, i)
            return None if f is None else replace(f, t=riesz(sol.contacts[i]))

        slipestimate.friction_of = riesz_of
        args = [a for a in args if a != "--riesz"]
    print("| scene | level | cells | estimate | true error | effectivity | contact traction share | "
          "friction terms share | cpu s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (build, options) in FRICTION_SCENES.items():
        if args and name not in args:
            continue
        start = time.process_time()
        levels, reference = LEVELS[build().dim]
        rows = against_reference(build, options, levels, reference, measure)
        cpu = time.process_time() - start
        for r in rows:
            print(f"| {name} | {r['level']} | {r['cells']} | {r['estimate']:.4g} | {r['true_error']:.4g} | "
                  f"{r['effectivity']:.3g} | {r['traction']:.3f} | {r['friction']:.2e} | {cpu:.0f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
