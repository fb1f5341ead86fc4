"""The parts of a re-solve this tree changed, timed against another tree's code in one process on the same inputs.

Scene: ``apps.demo.two_blocks(nx)`` (as benchmarks/resolve_stages.py: the first solve, then four load cases, the
traction x 1, 1.05, 1.1, 1.15). Captured during the load cases: the exact finish's arguments (W, d, start). Then,
alternating ``--repeats`` times, process CPU seconds of: the four finishes (``solve_lcp``) with the other tree's
module and with this one's (a kept factor carried from case to case, as the compliance keeps it; the first case's
started cold, as after a first solve whose finish closed another set); ``abs_product`` on each body's Kuu, Kup,
Kpp, Kup^T; the resolution check's cell owners of each side's contact part (all cells, against those kept at the
part). The answers of the two sides are compared (identical or max |a - b| / max |b|).

Run:  PYTHONPATH=<this tree> python benchmarks/resolve_parts.py 560 --other /path/holding/old/cvxcontact
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

import cvxcontact as cc
from cvxcontact.apps import demo
from cvxcontact.backends import signorini
from cvxcontact.backends.finish import lcp
from cvxcontact.discrete import energy
from cvxcontact.solution import resolution

SCALE = 0.37


def _load(root, name):
    """The module ``name`` of the package under ``root`` (the other tree), loaded beside this tree's package."""
    path = Path(root, *name.split(".")).with_suffix(".py")
    spec = importlib.util.spec_from_file_location(name + "_other", path)
    module = importlib.util.module_from_spec(spec)
    module.__package__ = name.rpartition(".")[0]
    sys.modules[spec.name] = module                   # (its dataclasses look their module up)
    spec.loader.exec_module(module)
    return module


def _cpu(f, repeats):
    best = []
    for _ in range(repeats):
        t = time.process_time()
        f()
        best.append(time.process_time() - t)
    return best


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("nx", type=int)
    p.add_argument("--other", required=True, help="a directory holding the other tree's cvxcontact/")
    p.add_argument("--repeats", type=int, default=7)
    args = p.parse_args()
    old_lcp = _load(args.other, "cvxcontact.backends.finish.lcp")
    old_energy = _load(args.other, "cvxcontact.discrete.energy")
    old_resolution = _load(args.other, "cvxcontact.solution.resolution")
    print(cc.__file__, "against", args.other)
    scene = demo.two_blocks(args.nx)
    solver = cc.ContactSolver(scene)
    solver.solve()
    captured = []
    real = signorini.solve_lcp

    def capture(W, d, start, **k):
        captured.append((W, np.array(d), np.array(start)))
        return real(W, d, start, **k)

    signorini.solve_lcp = capture
    for case in range(4):
        t = 1.0 + 0.05 * case
        solver.solve(scene.with_loads(0, body_force=(0.0, -2e9 * SCALE), traction={"right": (0.0, 3e8 * SCALE * t)},
                                      surface_charge={"left": -0.05 * SCALE}))
    signorini.solve_lcp = real

    def finishes_old():
        return [old_lcp.solve_lcp(W, d, s) for W, d, s in captured]

    def finishes_new():
        kept = lcp.LastFactor()
        return [lcp.solve_lcp(W, d, s, kept=kept) for W, d, s in captured]

    a, b = finishes_old(), finishes_new()
    same = all(np.array_equal(x[0], y[0]) and np.array_equal(x[1], y[1]) and x[2] == y[2] for x, y in zip(a, b))
    print(f"finish: {len(captured)} load cases, rows {len(captured[0][1])}, closed {[int(x[1].sum()) for x in b]}, "
          f"answers {'identical' if same else 'DIFFERENT'}")
    blocks = solver.problem.blocks
    rng = np.random.default_rng(0)
    mats = [(K, rng.standard_normal(K.shape[1])) for blk in blocks
            for K in (blk.Kuu, blk.Kup, blk.Kpp, None if blk.Kup is None else blk.Kup.T) if K is not None]
    same = all(np.array_equal(old_energy.abs_product(K, z), energy.abs_product(K, z)) for K, z in mats)
    print(f"abs_product: {len(mats)} matrices, {sum(K.nnz for K, _ in mats)} entries, "
          f"answers {'identical' if same else 'DIFFERENT'}")
    sides = []
    for pair in solver.scene.contacts:
        for body, part in [(pair.body_a, pair.part_a)] + ([] if pair.rigid else [(pair.other, pair.part_b)]):
            mesh = getattr(body.mesh, "split", body.mesh)
            sides.append((mesh, mesh.boundary(part), part))
    same = all(np.array_equal(old_resolution._owners(m.cells, f), resolution._owners(m.cells, f, m.cells_at(t)))
               for m, f, t in sides)
    print(f"owners: {len(sides)} contact parts, answers {'identical' if same else 'DIFFERENT'}")
    work = {
        "finish (4 load cases)": (finishes_old, finishes_new),
        "abs_product (all matrices)": (lambda: [old_energy.abs_product(K, z) for K, z in mats],
                                       lambda: [energy.abs_product(K, z) for K, z in mats]),
        "cell owners (all parts)": (lambda: [old_resolution._owners(m.cells, f) for m, f, _ in sides],
                                    lambda: [resolution._owners(m.cells, f, m.cells_at(t)) for m, f, t in sides]),
    }
    for name, (old, new) in work.items():
        to, tn = [], []
        for _ in range(args.repeats):                 # alternating, one call each
            to += _cpu(old, 1)
            tn += _cpu(new, 1)
        mo, mn = float(np.median(to)), float(np.median(tn))
        print(f"{name}: other {1e3 * mo:.1f} ms, this {1e3 * mn:.1f} ms CPU (medians of {args.repeats}; "
              f"ratio {mn / mo:.2f}, min {1e3 * min(to):.1f} -> {1e3 * min(tn):.1f})")


if __name__ == "__main__":
    main()
