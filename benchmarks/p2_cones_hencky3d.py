"""Benchmark: the 3D P2 copositive cones ("gamma3" on 10-node tetrahedra) beside a Hencky body (the full route,
finished by the accumulated cuts on the nonlinear (26), cvxcontact/backends/bulkcuts.py) against the same scene with
the linear material of the same E, nu, and the nodal condition "sigma1" with the Hencky body.

The scene of tests/test_p2_cones_hencky3d.py (tests/scenes3d.py ``bumped_blocks``): two blocks on (0, 1)^2 meeting at
z = 0.5 across a bumped gap, the lower clamped at its base (Hencky: E 70 GPa, nu 0.3, sigma_y 8 MPa, h 0.1; or
linear), the upper (held by the contact and rollers on two sides) pushed by 2e7 Pa on a central square; n x n x nz
cells below, (n + 1) x n x nz above (non-matching), nz = max(1, n // 2). For each n: the CPU seconds of one solve by
``auto`` of (a) Hencky "gamma3" (interior point + the finish), (b) the same with ``polish=False`` (the interior point
alone: the difference is the finish's), (c) linear "gamma3" (the full route: the upper block is held by the contact),
(d) Hencky "sigma1"; the unknowns, the finish, the plastic zone, the relative distance of (a) from (b) in u.

CPU seconds by ``time.process_time`` (the two cores are shared: wall times are noisy). Run single-threaded:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/p2_cones_hencky3d.py

Results: benchmarks/results/p2_cones_hencky3d.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from harness import solve_cpu

import cvxcontact as cc
from cvxcontact.apps.studies.convergence_hencky import plastic_zone

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes
SIGMA_Y = 8e6                                                           # Pa, the lower block's yield stress


def scene(material, n):
    from scenes3d import bumped_blocks

    return bumped_blocks((n, n), (n + 1, n), material=material, nz=max(1, n // 2))


def timed(scene, condition, **kw):
    return solve_cpu(scene, condition, degree=2, estimate=False, **kw)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[2, 3, 4])
    args = parser.parse_args()
    from scenes3d import NU, STEEL, E

    hencky = cc.materials.hencky(E=E, nu=NU, sigma_y=SIGMA_Y, h=0.1)
    print("| n | unknowns | Hencky gamma3 (s) | its interior point (s) | linear gamma3 (s) | Hencky sigma1 (s) | "
          "finish | yielded | finish - interior point (u, rel) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.n:
        hen, t_hen = timed(scene(hencky, n), "gamma3")
        ipm, t_ipm = timed(scene(hencky, n), "gamma3", polish=False, tol=1.0)
        _, t_lin = timed(scene(STEEL, n), "gamma3")
        _, t_nod = timed(scene(hencky, n), "sigma1")
        dofs = sum(3 * len(p) for p in hen.points)
        zone = plastic_zone(hen, body=0)
        apart = max(float(np.abs(a - b).max() / np.abs(b).max()) for a, b in zip(ipm.u, hen.u))
        print(f"| {n} | {dofs} | {t_hen:.2f} | {t_ipm:.2f} | {t_lin:.2f} | {t_nod:.2f} | {hen.info.finish} | "
              f"{zone['yielded']} of {zone['points']} | {apart:.1e} |", flush=True)


if __name__ == "__main__":
    main()
