"""How much a ContactSolver keeps between load cases as an obstacle moves: the entries and bytes of its problem's
``DiscreteProblem.shared`` store and the memory traced by ``tracemalloc``, every quarter of the run.

Scene: a block (1 m x 0.5 m, nx x nx/4 cells, clamped at its base, a body force) under a rigid circle (radius
0.6 m, 3 mm deep) moved in ``steps`` equal steps from x = 0.3 to 0.7 m: each position reads other contact rows.
Run (the package from a tree):  PYTHONPATH=<tree> python benchmarks/resolve_store.py 96 200
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
import warnings

import numpy as np
import scipy.sparse as sp

import cvxcontact as cc


def _bytes(obj, seen) -> int:
    """The bytes of the arrays, sparse matrices and byte strings reachable from ``obj`` (each counted once)."""
    if id(obj) in seen:
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return obj.nbytes if obj.base is None else 0
    if isinstance(obj, bytes):
        return len(obj)
    if sp.issparse(obj):
        return sum(_bytes(getattr(obj, a), seen) for a in ("data", "indices", "indptr") if hasattr(obj, a))
    if isinstance(obj, dict):
        return sum(_bytes(k, seen) + _bytes(v, seen) for k, v in obj.items())
    if isinstance(obj, (list, tuple)):
        return sum(_bytes(v, seen) for v in obj)
    return _bytes(vars(obj), seen) if hasattr(obj, "__dict__") else 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("nx", type=int)
    p.add_argument("steps", type=int)
    args = p.parse_args()
    warnings.simplefilter("ignore", cc.ResolutionWarning)
    mesh = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=args.nx, ny=max(args.nx // 4, 1))
    block = cc.Body(mesh, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", contact="top", name="block",
                    body_force=(0.0, -1e8))

    def scene(x, R=0.6, depth=3e-3):
        return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((x, 0.5 + R - depth), R))])

    solver = cc.ContactSolver(scene(0.3), method="condensed", estimate=False)
    solver.solve()
    tracemalloc.start()
    t0 = time.process_time()
    for i, x in enumerate(np.linspace(0.3, 0.7, args.steps)):
        solver.solve(scene(float(x)))
        if (i + 1) % max(args.steps // 4, 1) == 0:
            store = getattr(solver.problem, "_shared", {})
            print(f"step {i + 1}: {len(store)} entries, {_bytes(store, set()) / 1e6:.2f} MB kept, "
                  f"{tracemalloc.get_traced_memory()[0] / 1e6:.1f} MB traced, {time.process_time() - t0:.1f} CPU s",
                  flush=True)


if __name__ == "__main__":
    main()
