"""Exploration (issue 33): how close the condensed "gamma3" finish comes to a singular W_PP, by size and geometry.

``--geometry N ...``: the closest two vertices of the overlay of two_boxes(n)'s contact faces, in units of the
upper box's h (no solve: the two faces of one-cell-thick boxes with the same grids). ``--solve N ...``: two_boxes(n,
"gamma3", elastic=True) solved by cc.solve with the finish's DEBUG log on: the smallest pivot ratio of every W_PP it
factorised (Cholesky or QR, |P|, the step), its steps by move, ``sol.ok``; ``--offset D ...``: tests/scenes3d.py
``offset_boxes(n, D)`` instead (grids D h apart). One thread:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python \\
        benchmarks/explore_gamma3_pivots.py --geometry 24 48 60 76 --solve 16 24 32 40 48 --offset 1e-6 3e-7
"""

from __future__ import annotations

import argparse
import io
import logging
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from scenes3d import offset_boxes, two_boxes

import cvxcontact as cc
from cvxcontact.contact.surface import SurfaceInterface


def closest_vertices(n: int) -> float:
    """The smallest distance between two vertices of the overlay of two_boxes(n)'s faces, over h = 1/n."""
    n2 = max(2, round(0.7 * n))
    al = cc.materials.isotropic(E=70e9, nu=0.3)
    up = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5 / n), nx=n, ny=n, nz=1), al, clamped=["top"])
    lo = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(-0.5 / n2, 0), nx=n2, ny=n2, nz=1), al, clamped=["bottom"])
    x = np.asarray(SurfaceInterface((up, lo), ("bottom", "top")).x)
    return float(cKDTree(x).query(x, k=2)[0][:, 1].min() * n)


def pivots(scene) -> dict:
    """Solve ``scene`` with the finish's DEBUG log captured: the smallest pivot ratio and where, the moves."""
    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    log = logging.getLogger("cvxcontact.backends.finish")
    level = log.level
    log.setLevel(logging.DEBUG)
    log.addHandler(handler)
    t = time.process_time()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cc.errors.ResidualWarning)
            sol = cc.solve(scene)
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    best, steps, moves = (np.inf, "", 0, 0), 0, {}
    for line in stream.getvalue().splitlines():
        m = re.search(r"(Cholesky|QR) on (\d+) keys: pivot ratio ([0-9.e+-]+)", line)
        if m and float(m.group(3)) < best[0]:
            best = (float(m.group(3)), m.group(1), int(m.group(2)), steps + 1)
        m = re.search(r"step (\d+): \|P\| \d+, move (\w+)", line)
        if m:
            steps = int(m.group(1))
            moves[m.group(2)] = moves.get(m.group(2), 0) + 1
    return {"ratio": best[0], "system": best[1], "keys": best[2], "at_step": best[3], "steps": steps,
            "moves": moves, "ok": bool(sol.ok), "polished": bool(sol.polished), "cpu": time.process_time() - t}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--geometry", type=int, nargs="*", default=[])
    ap.add_argument("--solve", type=int, nargs="*", default=[])
    ap.add_argument("--offset", type=float, nargs="*", default=[], help="offset_boxes at these offsets (h)")
    ap.add_argument("--offset-n", type=int, nargs="*", default=[8], help="the n of offset_boxes")
    args = ap.parse_args()
    for n in args.geometry:
        print(f"n = {n}: closest overlay vertices {closest_vertices(n):.4g} h", flush=True)
    for n in args.solve:
        print(f"two_boxes({n}):", pivots(two_boxes(n, "gamma3", True)), flush=True)
    for n in args.offset_n if args.offset else []:
        for d in args.offset:
            print(f"offset_boxes({n}, {d:g}):", pivots(offset_boxes(n, d)), flush=True)


if __name__ == "__main__":
    main()
