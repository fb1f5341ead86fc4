"""Benchmark: one V-cycle of the AMG route's hierarchies, ``cvxcontact.backends.amg.v_cycle`` against pyamg's
``aspreconditioner(cycle="V")`` (the same bits; pyamg's ``solve`` adds two residual norms of the finest level per
cycle, its stopping test), in one process on the hierarchies of one solve.

Scene: ``two_boxes`` (tests/scenes3d.py, PZT-5A on aluminium, "sigma1"), a size a count of unknowns as in
benchmarks/bench3d.py. The AMG route's solve runs once (``method="amg"``: the default at 1.5e5, the sparse route's
below about 1e5; its hierarchies: the displacement block node-blocked, the potential block scalar); then each
hierarchy's two operators are applied to one random vector ``--repeats`` times, alternately, CPU seconds
(``time.process_time``) per application, medians: the ratio is measured under one load.

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_amg_vcycle.py \
        --size 1.5e5 --repeats 21

Printed: per hierarchy, its levels, both medians [ms] and the saving; the solve's Krylov iterations (one
application of each hierarchy per iteration, plus one per non-kept GMRES update).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench3d import cells, make


def main() -> None:
    import cvxcontact as cc
    from cvxcontact.backends.amg import v_cycle

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=1.5e5)
    ap.add_argument("--repeats", type=int, default=21)
    args = ap.parse_args()
    n = cells("two_boxes", args.size, False)
    solver = cc.ContactSolver(make("two_boxes", n, "sigma1", False), method="amg")   # the default below ~1e5: sparse
    sol = solver.solve()
    kc = solver.cache.amg
    print(f"two_boxes n={n}: {kc.n:,} unknowns, {sol.info.iterations} steps, {kc.iterations} Krylov iterations, "
          f"ok={sol.ok}")
    rng = np.random.default_rng(0)
    for name, ml in (("u (BSR 3x3)", kc.ml_u), ("phi", kc.ml_p)):
        if ml is None:
            continue
        b = rng.standard_normal(ml.levels[0].A.shape[0])
        ops = {"v_cycle": v_cycle(ml), "aspreconditioner": ml.aspreconditioner(cycle="V")}
        assert np.array_equal(ops["v_cycle"] @ b, ops["aspreconditioner"] @ b)
        cpu = {k: [] for k in ops}
        for _ in range(args.repeats):
            for k, M in ops.items():
                c0 = time.process_time()
                M @ b
                cpu[k].append(time.process_time() - c0)
        med = {k: 1e3 * float(np.median(v)) for k, v in cpu.items()}
        cut = 100 * (1 - med["v_cycle"] / med["aspreconditioner"])
        print(f"{name}: {len(ml.levels)} levels, v_cycle {med['v_cycle']:.2f} ms, aspreconditioner "
              f"{med['aspreconditioner']:.2f} ms per application: {cut:.1f} % less (same bits)")


if __name__ == "__main__":
    main()
