"""Exploration: where the sparse route for P1 "gamma3" between two 3D bodies spends, and what other starts and
continuations of its regularised stage cost (issue 33 item 1). Two elastic boxes (tests/scenes3d.py
``two_boxes(n, "gamma3", elastic=True)``); every variant runs the two stages of
:func:`cvxcontact.backends.signorini._sparse_dependent` on the sparse mixed system itself (the regularised problem
by damped semismooth Newton, :meth:`~cvxcontact.backends.sparse.SparseContact.regularised`, then Lawson-Hanson,
:meth:`~cvxcontact.backends.sparse.SparseContact.independent`) and reports the counts (deterministic: sparse
systems, numeric factorisations, Lawson-Hanson steps) and its time over the first variant's in the same run.

    OMP_NUM_THREADS=1 python benchmarks/explore_gamma3_sparse.py --n 16 [--variants shipped alm-1e-2x4 ...]

A variant is a start (the bonded system, no row, or the penetrating rows of the nodal solution on the rows at
the upper face's vertices: independent, the "sigma1"-like problem) and a list of levels (relative compliance
delta, outer iterations): one outer iteration is the regularised problem at delta; more are augmented-Lagrangian
iterations at the same delta (the rows' gaps shifted by delta w y, y the last forces: the factor is kept).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact

SHIPPED = ((1e-2, 1), (1e-4, 1), (1e-6, 1))
VARIANTS = {                            # name -> (start, levels, cap of the capacitance form (None: measured))
    "shipped": ("bonded", SHIPPED, None),
    "no-row-start": ("none", SHIPPED, None),
    "nodal-start": ("nodal", SHIPPED, None),
    "levels-1e-4,1e-6": ("bonded", ((1e-4, 1), (1e-6, 1)), None),
    "levels-1e-2..1e-6-by-10": ("bonded", ((1e-2, 1), (1e-3, 1), (1e-4, 1), (1e-5, 1), (1e-6, 1)), None),
    "levels-1e-1..1e-6-by-10": ("bonded", ((1e-1, 1), (1e-2, 1), (1e-3, 1), (1e-4, 1), (1e-5, 1), (1e-6, 1)), None),
    "levels-1e-2,1e-6": ("bonded", ((1e-2, 1), (1e-6, 1)), None),
    "level-1e-6": ("bonded", ((1e-6, 1),), None),
    "level-1e-2": ("bonded", ((1e-2, 1),), None),
    "alm-1e-2x4": ("bonded", ((1e-2, 4),), None),
    "alm-1e-2x8": ("bonded", ((1e-2, 8),), None),
    "alm-1e-3x3": ("bonded", ((1e-3, 3),), None),
    "alm-1e-2x3,1e-4,1e-6": ("bonded", ((1e-2, 3), (1e-4, 1), (1e-6, 1)), None),
    "cap-24": ("bonded", SHIPPED, 24),
    "cap-160": ("bonded", SHIPPED, 160),
    "cap-500": ("bonded", SHIPPED, 500),
    "nodal-then-LH": ("nodal", (), None),
}


def nodal_rows(problem) -> np.ndarray:
    """The rows at the upper face's vertices: rows that touch a single free dof of one body (the vertex's normal
    displacement, a flat face), one per dof, for the body with more of them (independent: each its own dof)."""
    best = np.zeros(0, dtype=int)
    for b in problem.blocks:
        R = sp.csr_matrix(problem.E @ b.jump)
        R.eliminate_zeros()
        one = np.flatnonzero(np.diff(R.indptr) == 1)
        _, first = np.unique(R.indices[R.indptr[one]], return_index=True)
        best = max(best, one[first], key=len)
    return best


def run(problem, start: str, levels, cap) -> dict:
    E, g, blocks = problem.E, np.asarray(problem.g, dtype=float), list(problem.blocks)
    m = E.shape[0]
    rhs = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    t0 = time.perf_counter()
    exact = SparseContact(blocks, E, factorization="auto", cap=cap)
    soft = SparseContact(blocks, E, factorization="auto", soft=1e-6 * exact.w, cap=cap)
    y, active, systems, factorisations = np.zeros(m), np.ones(m, dtype=bool), 0, 0
    if start == "none":
        active = np.zeros(m, dtype=bool)
    elif start == "nodal":
        rows = nodal_rows(problem)
        nodal = SparseContact(blocks, E[rows], factorization="auto")
        u, phi, yn, on, steps = nodal.solve(rhs, g[rows])
        x = np.concatenate([np.concatenate([uk] + ([pk] if pk is not None else [])) for uk, pk in zip(u, phi)])
        active = exact.G @ x - g > 0
        y[rows], systems, factorisations = yn, steps, nodal.factorizations
        if not levels:                  # Lawson-Hanson from the nodal forces directly
            active[rows] |= on
    for delta, outer in levels:
        soft.set_soft(delta * exact.w)
        for k in range(outer):
            out = soft.regularised(rhs, g - soft.soft * y if k else g, active)
            y, active, systems = out[0], out[1], systems + out[2]
    if soft.perm is not None:
        exact.perm = soft.perm
    out = exact.independent(rhs, g, y, active)
    if isinstance(out, str):
        raise SystemExit(f"the Lawson-Hanson finish stopped: {out}")
    return {"seconds": time.perf_counter() - t0, "systems": systems,
            "factorisations": factorisations + soft.factorizations + exact.factorizations, "lh": out[4],
            "passive": int(out[3].sum()), "u": np.concatenate(out[0]),
            "cap": "not measured" if soft.cap is None else soft.cap}    # (the default: None until a block of >= 16)


def columns(problem, counts) -> None:
    """One numeric factorisation of the mixed matrix (no row closed, the bodies' factor) against solves of
    ``counts`` columns with it (a Schur complement of k active rows needs k columns), seconds in one run."""
    sc = SparseContact(list(problem.blocks), problem.E, factorization="auto")
    sc._refactor(np.zeros(sc.m, dtype=bool))                 # the ordering (and the solver's analysis)
    t0 = time.perf_counter()
    sc._refactor(np.zeros(sc.m, dtype=bool))
    fact = time.perf_counter() - t0
    factor = sc.base[1]
    cols = np.random.default_rng(0).random((sc.n + sc.m, max(counts)))
    print(f"one numeric factorisation ({sc.factorization}): {fact:.3f} s")
    for k in counts:
        t0 = time.perf_counter()
        factor.solve(cols[:, :k] if k > 1 else cols[:, 0])
        dt = time.perf_counter() - t0
        print(f"{k} columns: {dt:.3f} s ({dt / fact:.1f} factorisations)")
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS))
    ap.add_argument("--columns", type=int, nargs="*", default=[],
                    help="also time one numeric factorisation of the mixed matrix against solves of this many columns")
    args = ap.parse_args()
    solver = cc.ContactSolver(two_boxes(args.n, "gamma3", elastic=True), "gamma3", method="sparse", estimate=False)
    problem = solver.problem
    print(f"n = {args.n}: {problem.unknowns} unknowns, {problem.E.shape[0]} rows\n")
    if args.columns:
        columns(problem, args.columns)
    print("| variant | cap | regularised systems | factorisations | Lawson-Hanson steps | time / first | "
          "max abs du / max abs u |")
    print("|---|---|---|---|---|---|---|")
    first = None
    for name in args.variants:
        start, levels, cap = VARIANTS[name]
        r = run(problem, start, levels, cap)
        first = first or r
        du = float(np.abs(r["u"] - first["u"]).max() / np.abs(first["u"]).max())
        print(f"| {name} | {r['cap']} | {r['systems']} | {r['factorisations']} | {r['lh']} | {r['seconds'] / first['seconds']:.2f} | "
              f"{du:.1e} |", flush=True)


if __name__ == "__main__":
    main()
