"""Where a re-solve's CPU time goes, stage by stage, and its answers saved for a comparison between two trees.

Scene: ``apps.demo.two_blocks(nx)`` (as benchmarks/bench_resolve.py). One process: the first solve, then four load
cases (the upper block's loads x 0.37, its traction also x 1, 1.05, 1.1, 1.15: no load case repeats the one before,
whose forward sweeps a ContactSolver would reuse; each with its new Scene), each timed in CPU seconds per stage (the new Scene;
``DiscreteProblem.with_loads``: fingerprints, loads, units; the backend's ``run``: sweeps and finish; the read-back
with its checks; the error estimate; the resolution check). The last load case's u, phi, contact forces, estimate
(total, indicators, parts), checks and electrode charges are saved to ``--save`` (npz); with ``--reference`` (an npz
saved by another tree) each is compared: "identical" or its max |a - b| / max |b|.

Run (the package from a tree):  PYTHONPATH=<tree> python benchmarks/resolve_stages.py 560 --save /tmp/after.npz \\
    --reference /tmp/before.npz
"""

from __future__ import annotations

import argparse
import importlib
import time

import numpy as np

import cvxcontact as cc
from cvxcontact.apps import demo

SCALE = 0.37


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("nx", type=int)
    p.add_argument("--save", help="npz of the last load case's answers")
    p.add_argument("--reference", help="npz saved by another tree: compare")
    args = p.parse_args()
    module = importlib.import_module("cvxcontact.solve")
    spent: dict = {}

    def timed(owner, name, label):
        f = getattr(owner, name)

        def g(*a, **k):
            t = time.process_time()
            out = f(*a, **k)
            spent[label] = spent.get(label, 0.0) + time.process_time() - t
            return out
        setattr(owner, name, g)

    for name in ("run", "read_back", "unresolved"):
        timed(module, name, name)
    timed(module.DiscreteProblem, "with_loads", "with_loads")
    estimates = module.ESTIMATES
    residual = estimates["residual"]

    def estimate(*a, **k):
        t = time.process_time()
        out = residual(*a, **k)
        spent["estimate"] = spent.get("estimate", 0.0) + time.process_time() - t
        return out
    estimates["residual"] = estimate
    print(cc.__file__)
    cc.solve(demo.two_blocks(4))
    scene = demo.two_blocks(args.nx)
    t0 = time.process_time()
    solver = cc.ContactSolver(scene)
    first = solver.solve()
    c_first = time.process_time() - t0
    print(f"first solve {c_first:.3f} CPU s")
    s = SCALE
    for case in range(4):
        spent.clear()
        t = 1.0 + 0.05 * case            # the traction's share differs per case: no two load cases alike
        t0 = time.process_time()
        other = scene.with_loads(0, body_force=(0.0, -2e9 * s), traction={"right": (0.0, 3e8 * s * t)},
                                 surface_charge={"left": -0.05 * s})
        spent["scene"] = time.process_time() - t0
        again = solver.solve(other)
        total = time.process_time() - t0
        print(f"re-solve {total:.3f} CPU s ({100 * total / c_first:.2f} %): "
              + ", ".join(f"{k} {v:.4f}" for k, v in spent.items()))
    e = again.estimate
    arrays = {"u": np.concatenate([np.ravel(x) for x in again.u]),
              "phi": np.concatenate([np.ravel(x) for x in again.phi if x is not None]),
              "force": np.concatenate([np.ravel(c.force) for c in again.contacts]),
              "estimate": np.array([e.absolute, e.norm]), "indicators": np.concatenate(e.indicators),
              "parts": np.array([e.parts[k] for k in sorted(e.parts)]),
              "checks": np.array([again.residuals()[k] for k in sorted(again.residuals())]),
              "charges": np.array([x.charge for x in again.electrodes]),
              "first estimate": np.concatenate([[first.estimate.absolute], *first.estimate.indicators])}
    if args.save:
        np.savez(args.save, **arrays)
    if args.reference:
        ref = np.load(args.reference)
        for k, a in arrays.items():
            b = ref[k]
            print(f"  {k}: " + ("identical" if np.array_equal(a, b) else
                               f"{np.abs(a - b).max() / max(np.abs(b).max(), 1e-300):.2e} relative"))


if __name__ == "__main__":
    main()
