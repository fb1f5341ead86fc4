"""Benchmark: a 3D pair whose faces do not match (tests/friction_box_scenes.py's ``non_matching``: 3 x 3 cells on
4 x 4, 75 overlay rows under "gamma3") solved posed from either body; the relative distance of the two answers'
displacements, finished and interior point (``polish=False``), for Tresca in partial slip, Tresca sliding (the
pushed box) and Coulomb:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests python benchmarks/friction_sides.py

Results: benchmarks/results/friction_sides.md.
"""

from __future__ import annotations

import time
import warnings

import friction_box_scenes as t3

import cvxcontact as cc

CASES = (("Tresca 0.25 p, partial slip", lambda: cc.Tresca(0.25 * t3.P), {}),
         ("Tresca 1e3 Pa, pushed: sliding", lambda: cc.Tresca(1e3), {"q": (0.0, 0.0), "nu": 0.0, "push": 1e-4}),
         ("Coulomb 0.3", lambda: cc.Coulomb(0.3), {}))


def main():
    print(f"{'case':32s} {'finished':>9s} {'interior':>9s} {'cpu s':>6s}")
    for name, law, kw in CASES:
        start = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            one, other = (cc.solve(t3.non_matching(law(), swap=s, **kw), condition="gamma3") for s in (False, True))
            ipm = [cc.solve(t3.non_matching(law(), swap=s, **kw), condition="gamma3", polish=False)
                   for s in (False, True)]
        print(f"{name:32s} {t3.apart(one, other):9.1e} {t3.apart(*ipm):9.1e} {time.process_time() - start:6.1f}")


if __name__ == "__main__":
    main()
