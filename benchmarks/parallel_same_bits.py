"""Same bits after ``repeated_rows`` is read off ``ParallelRows`` (h-split, cvxcontact/backends/parallel.py): a
sha256 (16 hex digits) of u, every pair's lambda_h, force and active set, ok and the checks of each scene of
tests/test_parallel_obstacles.py (two coincident floors, a floor and a strip of it, a floor and a strip raised
3e-6 m over part; 2D P1/P2, 3D P1/P2 tetrahedra, Q1 hexahedra; methods "full", "condensed", "sparse", "amg", the
default call), a cc.Model with a user row on coincident floors (2D P1, 3D P1: full.mixed_kkt_rows), and two floors
apart by 0, 1e-18, 1e-15, 1e-10 m (2D P1, every route), with the package of the tree ``--tree`` (default: this one).

Run (one thread; the package of each tree, the scenes of this tree's tests/reach_scenes.py):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/parallel_same_bits.py --tree OLD > a
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/parallel_same_bits.py > b; diff a b
"""

import argparse
import sys
import warnings
from pathlib import Path

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--tree", default=str(Path(__file__).resolve().parent.parent), help="source tree of cvxcontact")
args = parser.parse_args()
sys.path[:0] = [args.tree, str(Path(__file__).resolve().parent.parent / "tests")]   # the package of --tree, the
# scenes of this tree (tests/reach_scenes.py: the same scenes whatever tree is measured)

import numpy as np
from harness import solution_digest
from reach_scenes import BODIES, block2d, floor, line, lowered
from reach_scenes import block as scene

import cvxcontact as cc

KINDS = {"coincident": lambda d: (floor(d), floor(d)),
         "coincident over part": lambda d: (floor(d), floor(d, 0.3, 0.7)),
         "raised over part": lambda d: (floor(d), lowered(0.3, 0.7, d, drop=-3e-6))}


def with_row(dim, cell, degree, obstacles):
    model = cc.Model(scene(obstacles, dim, cell), condition="sigma1", degree=degree)
    model.add(model.u(0)[0, 0] >= -1.0)
    return model.solve()


CASES = {}
for body, (dim, degree, cell) in BODIES.items():
    for kind, obstacles in KINDS.items():
        for method in ("full", "condensed", "sparse", "amg", "auto"):
            CASES[f"{body} {kind} {method}"] = (lambda o=obstacles, d=dim, c=cell, p=degree, m=method: cc.solve(
                scene(o(d), d, c), "sigma1", degree=p, **({} if m == "auto" else {"method": m})))
for body in ("2D P1", "3D P1"):
    dim, degree, cell = BODIES[body]
    CASES[f"{body} Model row coincident"] = lambda d=dim, c=cell, p=degree: with_row(d, c, p, (floor(d), floor(d)))
for apart in (0.0, 1e-18, 1e-15, 1e-10):
    for method in ("full", "condensed", "sparse", "amg"):
        CASES[f"2D P1 floors {apart:g} m apart {method}"] = (lambda a=apart, m=method: cc.solve(
            block2d((line(-1.0, 2.0), lowered(-1.0, 2.0, 2, drop=a))), "sigma1", method=m))

for name, make in CASES.items():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            sol = make()
            f = [c.force for c in sol.contacts]
            print(f"{name:42s} {solution_digest(sol)} ok={sol.ok} second pair's force {np.abs(f[1]).sum():.6e} N", flush=True)
        except Exception as exc:                     # noqa: BLE001  (said, and the next scene run)
            print(f"{name:42s} ERROR {type(exc).__name__}: {str(exc)[:200]}", flush=True)
