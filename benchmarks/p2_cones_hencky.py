"""Benchmark: P2 "gamma3" (the cones) beside a Hencky body (cvxcontact/backends/cones.py ``finish_bulk``) against the
same scene with the linear material of the same E, nu, and the nodal condition "sigma1" with the Hencky body.

The scene of tests/test_p2_cones_hencky.py: an aluminium block [0, 1] x [0, 0.5] m pressed by its weight (1e8 N/m^3)
onto a block [0, 1] x [-0.5, 0] m across a parabolic gap, the lower block Hencky (E 70 GPa, nu 0.3, sigma_y 2 MPa,
h 0.1: about three quarters of it yields) or linear; ``nx`` cells across the lower block (nx + 1 the upper), ny =
nx / 3. For each nx: the CPU seconds of one solve by ``auto`` of (a) Hencky "gamma3" (the full route: interior point
+ the finish), (b) the same with ``polish=False`` (the interior point alone: the difference is the finish's), (c)
linear "gamma3" (the condensed route), (d) Hencky "sigma1" (the Newton route, no interior point); the unknowns, the
route's finish and the plastic zone.

CPU seconds by ``time.process_time`` (the two cores are shared: wall times are noisy). Run single-threaded:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/p2_cones_hencky.py

Results: benchmarks/results/p2_cones_hencky.md.
"""

from __future__ import annotations

import argparse

from harness import solve_cpu

import cvxcontact as cc
from cvxcontact.apps.studies.convergence_hencky import plastic_zone

E, NU, H = 70e9, 0.3, 0.5
ALU = cc.materials.isotropic(E=E, nu=NU)
HENCKY = cc.materials.hencky(E=E, nu=NU, sigma_y=2e6, h=0.1)


def gap(s):
    return -2e-6 + 2e-3 * (s - 0.4) ** 2


def pressed(material, nx):
    ny = max(2, nx // 3)
    upper = cc.Body(cc.rectangle(x=(0, 1), y=(0, H), nx=nx + 1, ny=ny), ALU, clamped=["top"], contact="bottom",
                    body_force=(0.0, -1e8), name="upper")
    lower = cc.Body(cc.rectangle(x=(0, 1), y=(-H, 0), nx=nx, ny=ny), material, clamped=["bottom"], contact="top",
                    name="lower")
    return cc.Scene(upper, lower, gap=gap)


def timed(scene, condition, **kw):
    return solve_cpu(scene, condition, degree=2, estimate=False, **kw)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nx", type=int, nargs="+", default=[12, 24, 48, 96])
    args = parser.parse_args()
    print("| nx | unknowns | Hencky gamma3 (s) | its interior point (s) | linear gamma3 (s) | Hencky sigma1 (s) | "
          "finish | yielded |")
    print("|---|---|---|---|---|---|---|---|")
    for nx in args.nx:
        hen, t_hen = timed(pressed(HENCKY, nx), "gamma3")
        _, t_ipm = timed(pressed(HENCKY, nx), "gamma3", polish=False, tol=1.0)
        _, t_lin = timed(pressed(ALU, nx), "gamma3")
        _, t_nod = timed(pressed(HENCKY, nx), "sigma1")
        dofs = sum(2 * len(p) for p in hen.points)
        zone = plastic_zone(hen, body=1)
        print(f"| {nx} | {dofs} | {t_hen:.2f} | {t_ipm:.2f} | {t_lin:.2f} | {t_nod:.2f} | {hen.info.finish} | "
              f"{zone['yielded']} of {zone['points']} |", flush=True)


if __name__ == "__main__":
    main()
