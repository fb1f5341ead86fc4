"""Exploration: the sparse route's coarse start (``SparseContact.coarse_start``) on 3D interfaces.

Scenes (sigma1, the sparse route's non-dependent rows; no row starts closed, so no obstacle start applies):

* ``boxes``: ``tests/scenes3d.two_boxes(n)`` (a PZT-5A box on an aluminium box, g = 0 on every row);
* ``plate``: a steel plate (0, 1)^2 x (0, 0.02) m, ``n`` x ``n`` x 2 cells, clamped on its four sides, pressed
  by 1 MPa onto an aluminium block (0, 1)^2 x (-0.1, 0) m (``int(0.7 n) + 1`` cells a side, 3 through, clamped
  at its base) across the crowned gap g = 2e-5 ((2x - 1)^2 + (2y - 1)^2) + 1e-7 m (positive everywhere): the 3D
  analogue of ``demo.thin_layer``; ``--piezo``: a PZT-5A plate driven at 100 V on its top, grounded below.

For each scene, from a fresh ``SparseContact``: the steps from the bonded start (every row closed) and from the
coarse start (``coarse_start`` first, its CPU reported apart), each with its systems, numeric factorisations and
process CPU seconds, and whether both end on the same active set. A start that leads nowhere reports ``None``.

Run:  OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 python benchmarks/explore_coarse3d.py --scene plate --n 55
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "tests"))

import cvxcontact as cc
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact


def plate(n: int, piezo: bool = False) -> cc.Scene:
    """The plate on a block of the module docstring."""
    block = cc.box(x=(0, 1), y=(0, 1), z=(-0.1, 0), nx=int(0.7 * n) + 1, ny=int(0.7 * n) + 1, nz=3)
    sheet = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.02), nx=n, ny=n, nz=2)
    b1 = cc.Body(block, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", name="block")
    material = cc.materials.PZT5A if piezo else cc.materials.isotropic(E=210e9, nu=0.3)
    extra = {"potential": {"top": 100.0}, "grounded": ["bottom"]} if piezo else {}
    b2 = cc.Body(sheet, material, clamped=["left", "right", "front", "back"], traction={"top": (0.0, 0.0, -1e6)},
                 name="plate", **extra)

    def gap(x, y):
        return 2e-5 * ((2 * np.asarray(x) - 1) ** 2 + (2 * np.asarray(y) - 1) ** 2) + 1e-7

    return cc.Scene(b1, b2, contacts=[cc.Contact(b2, "bottom", b1, "top", gap=gap, condition="sigma1")])


def run(scene: cc.Scene, factorization: str) -> list[dict]:
    p = cc.ContactSolver(scene, method="sparse", factorization=factorization).problem
    blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    free = ~p.held_rows
    rows, finals = [], []
    for start in ("bonded", "coarse"):
        sc = SparseContact(blocks, E, factorization=factorization)
        t0 = time.process_time()
        first = sc.coarse_start(F, g, free) if start == "coarse" else free
        t_start = time.process_time() - t0
        out = None if first is None else sc.solve(F, g, first)
        finals.append(None if out is None else out[3])
        rows.append({"start": start, "rows": len(g), "start_rows": None if first is None else int(first.sum()),
                     "closed": None if out is None else int(out[3].sum()),
                     "systems": None if out is None else out[4], "factorizations": sc.factorizations,
                     "start_cpu": round(t_start, 2), "cpu": round(time.process_time() - t0, 2)})
    same = None if any(f is None for f in finals) else bool(np.array_equal(*finals))
    for r in rows:
        r["same_active_set"] = same
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=["boxes", "plate"], default="plate")
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--piezo", action="store_true", help="plate: a PZT-5A plate")
    ap.add_argument("--factorization", default="auto", choices=["auto", "pardiso", "superlu"])
    args = ap.parse_args(argv)
    if args.scene == "boxes":
        from scenes3d import two_boxes

        scene = two_boxes(args.n)
    else:
        scene = plate(args.n, args.piezo)
    for r in run(scene, args.factorization):
        print(" ".join(f"{k}={v}" for k, v in r.items()), flush=True)


if __name__ == "__main__":
    main()
