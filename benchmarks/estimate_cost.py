"""Benchmark: the error estimate's cost against the solve's on the small 3D scenes of the estimate study
(cvxcontact/apps/studies/estimate.py: a rigid sphere pressed into a block, two boxes with a PZT-5A one; P1 and
P2 tetrahedra, "gamma3"), refined uniformly 0, 1, 2 times (P2: 0, 1).

Per mesh: the solve without the estimate (``estimate=False``; the least of 3, P2 one) and
:func:`cvxcontact.solution.estimate.estimate` on its answer (the least of 7), CPU seconds (process time: on a
shared machine wall time measures the neighbours), and their ratio (issue 30 asks for <= 30 %). Run it
single-threaded from a checkout:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/estimate_cost.py
"""

from __future__ import annotations

import time
import warnings

import cvxcontact as cc
from cvxcontact.apps.studies.estimate import boxes_scene, refined, sphere_scene
from cvxcontact.solution.estimate import estimate

CASES = [("sphere P1", sphere_scene, dict(condition="gamma3"), (0, 1, 2)),
         ("two boxes P1", boxes_scene, dict(condition="gamma3"), (0, 1, 2)),
         ("sphere P2", sphere_scene, dict(condition="gamma3", degree=2), (0, 1)),
         ("two boxes P2", boxes_scene, dict(condition="gamma3", degree=2), (0, 1))]


def least(f, times: int) -> float:
    out = []
    for _ in range(times):
        t0 = time.process_time()
        f()
        out.append(time.process_time() - t0)
    return min(out)


def main() -> None:
    print(f"cvxcontact {cc.__version__} from {cc.__file__}\n")
    print("| scene | level | cells | solve (s) | estimate (s) | estimate / solve |\n|---|---|---|---|---|---|")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, build, options, levels in CASES:
            for level in levels:
                scene, _ = refined(build(), level)
                sol = cc.solve(scene, estimate=False, **options)
                solve_s = least(lambda: cc.solve(scene, estimate=False, **options), 1 if "P2" in name else 3)
                estimate_s = least(lambda: estimate(sol), 7)
                cells = sum(len(b.mesh.cells) for b in scene.bodies)
                print(f"| {name} | {level} | {cells} | {solve_s:.3f} | {estimate_s:.4f} | "
                      f"{100 * estimate_s / solve_s:.0f} % |", flush=True)


if __name__ == "__main__":
    main()
