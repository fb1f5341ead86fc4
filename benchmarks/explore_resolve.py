"""Exploration: re-solves on one ``SparseContact`` of the long interface (issue 33 item 4).

Two parts, on ``demo.thin_layer(n)``, one thread, process CPU seconds:

* ``forced``: a ``SparseContact`` (PARDISO) first solves the same loads from another start (``half``: every other
  row closed; ``open``: every row open), then from the bonded start as a re-solve does; reported: the systems
  of a fresh object's bonded solve, of the start's solve and of the re-solve (None: it stopped), PARDISO's
  perturbed pivots after each, and whether the re-solve's active set is the fresh one's.
* ``sweep``: the public API, ``ContactSolver(thin_layer(n))`` solved, then re-solved with the pressure and the
  voltage scaled by each of ``--scales``; reported per re-solve: the route, ``ok``, its CPU, the object's
  factorisations so far, whether the active set is that of a new ``ContactSolver`` on the same loads and the
  largest difference of u relative to it.

Run:  OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_resolve.py \\
          --part forced --n 200 1000
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import cvxcontact as cc
from cvxcontact.apps import demo
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact


def forced(n: int, cap: int):
    problem = cc.ContactSolver(demo.thin_layer(n), estimate=False).problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    m = E.shape[0]
    fresh = SparseContact(blocks, E, cap=cap, factorization="pardiso")
    ref = fresh.solve(F, g)
    for name, start in (("half", np.arange(m) % 2 == 0), ("open", np.zeros(m, dtype=bool))):
        sc = SparseContact(blocks, E, cap=cap, factorization="pardiso")
        t0 = time.process_time()
        a = sc.solve(F, g, active=start)
        pa = sc._pardiso.perturbed if sc._pardiso is not None else None
        t1 = time.process_time()
        b = sc.solve(F, g)
        t2 = time.process_time()
        print(json.dumps({"n": n, "cap": cap, "start": name, "fresh_systems": ref[4],
                          "start_systems": None if a is None else a[4], "perturbed_after_start": pa,
                          "resolve_systems": None if b is None else b[4],
                          "perturbed_after_resolve": sc._pardiso.perturbed if sc._pardiso is not None else None,
                          "same_set": None if b is None else bool(np.array_equal(b[3], ref[3])),
                          "cpu_start": round(t1 - t0, 3), "cpu_resolve": round(t2 - t1, 3)}), flush=True)


def sweep(n: int, scales):
    solver = cc.ContactSolver(demo.thin_layer(n), estimate=False)
    t0 = time.process_time()
    first = solver.solve()
    print(json.dumps({"n": n, "scale": "first", "route": str(first.info.route.value), "ok": first.ok,
                      "cpu": round(time.process_time() - t0, 3)}), flush=True)
    for s in scales:
        scene = demo.thin_layer(n, pressure=1e6 * s, voltage=100.0 * s)
        t0 = time.process_time()
        try:
            sol = solver.solve(scene)
        except cc.SolverError as exc:
            print(json.dumps({"n": n, "scale": s, "error": str(exc)}), flush=True)
            continue
        cpu = time.process_time() - t0
        other = cc.ContactSolver(scene, estimate=False)
        ref = other.solve()
        du = max(float(np.abs(a - b).max() / np.abs(b).max()) for a, b in zip(sol.u, ref.u))
        sc = solver.cache.sparse
        print(json.dumps({"n": n, "scale": s, "route": str(sol.info.route.value), "ok": sol.ok, "cpu": round(cpu, 3),
                          "factorizations": None if sc is None else sc.factorizations,
                          "same_set": bool(np.array_equal(solver.cache.active, other.cache.active)),
                          "du": du}), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--part", choices=["forced", "sweep"], default="forced")
    p.add_argument("--n", type=int, nargs="+", default=[200, 1000])
    p.add_argument("--cap", type=int, default=24)
    p.add_argument("--scales", type=float, nargs="+", default=[0.5, 1.0, 1.5, 2.0, 1.01])
    args = p.parse_args()
    warnings.simplefilter("ignore")
    print(json.dumps({"cvxcontact": cc.__file__}), flush=True)
    for n in args.n:
        if args.part == "forced":
            forced(n, args.cap)
        else:
            sweep(n, args.scales)


if __name__ == "__main__":
    main()
