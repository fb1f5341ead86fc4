"""PARDISO's fill-reducing orders on the sparse route's mixed system: nested dissection against minimum degree.

For each scene, the route's system K with every row closed (``SparseContact.matrix``, the values the route's analysis
is made on after the coarse start) is analysed and factorised once by ``PardisoSymmetric`` with iparm[1] = 2
(nested dissection, METIS) and 0 (minimum degree, AMD). Printed: process CPU seconds of the analysis and of
one numeric factorisation, the factor's Mflop and its fill (``PardisoSymmetric.fill``: factor nonzeros over K's
upper-triangle entries), the perturbed pivots, and the interface's slenderness m / n^(2/3) (the route tries minimum
degree above 1, ``sparse.SLENDER_FACE``, and keeps it at a fill of at most ``sparse.SLENDER_FILL``).

Run (one thread):  OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/longif_orderings.py \\
                       thin1000 thin3000 blocks64 blocks300 boxes6 boxes12 boxes18 boxes24
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the 3D boxes

SCENES = {"thin": "demo.thin_layer", "blocks": "demo.two_blocks", "boxes": "scenes3d.two_boxes"}


def main(names):
    warnings.simplefilter("ignore")
    import scenes3d  # noqa: F401  (the 3D scenes, by name)

    import cvxcontact as cc
    from cvxcontact.apps import demo  # noqa: F401  (the 2D scenes, by name)
    from cvxcontact.backends.factor import PardisoSymmetric
    from cvxcontact.backends.sparse import SparseContact

    for name in names:
        kind = name.rstrip("0123456789")
        scene = eval(SCENES[kind])(int(name[len(kind):]))
        p = cc.ContactSolver(scene).problem
        sc = SparseContact(list(p.blocks), p.E, factorization="pardiso")
        K = sc.matrix(np.ones(sc.m, dtype=bool))
        head = f"{name}: n {sc.n}, m {sc.m}, m/sqrt(n) {sc.m / np.sqrt(sc.n):.2f}, m/n^(2/3) {sc.m / sc.n ** (2 / 3):.2f}"
        row = [head]
        for ordering in (2, 0):
            ps = PardisoSymmetric(K, ordering=ordering)
            t0 = time.process_time()
            ps.analyse(K)
            t1 = time.process_time()
            ps.factor(K)
            t2 = time.process_time()
            row.append(f"order {ordering}: analysis {t1 - t0:.3f} s, factorisation {t2 - t1:.3f} s, "
                       f"{ps.cost[0]:.0f} Mflop, fill {ps.fill:.2f}, perturbed {ps.perturbed}")
            ps.release()
        print(" | ".join(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["thin1000", "thin3000", "blocks64", "boxes12"])
