"""The fast route of a Hencky body (method "newton", cvxcontact/backends/nonlinear.py) against one linear solve of
the same mesh and against the full route (interior point + Newton finish), as ratios within one run.

Scene: a rigid circle (radius 0.6 m) pressed 5 mm into a block 1 m x 0.5 m clamped at its bottom
(tests/hencky_scenes.py ``indented``), Hencky E = 70 GPa, nu = 0.3, sigma_y = 200 MPa, h = 0.1 (yields under
the circle); the linear solve: the same scene with the isotropic material of the same E, nu (the Hencky body's
initial tangent), by ``auto`` (the condensed route) and by the sparse route; P2 with the nodal condition "sigma1".

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_hencky.py [--quick|--large|--p2|--3d]

prints a Markdown table: seconds of ``ContactSolver.solve`` (the assembly excluded), wall and CPU (process time: on
a shared machine the wall time of one thread is stretched by the load, its CPU time much less); ratios to the
linear solves; "steps": the Newton steps; "factorisations": the numeric factorisations of the tangent solver, the
other steps solved by GMRES on the last factor ("GMRES": its iterations); "1 per step": the fast route with a
factorisation every step (``nonlinear.KRYLOV = 0``), CPU seconds.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import cvxcontact as cc
from cvxcontact.backends import nonlinear

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from hencky_scenes import NU, SIGMA_Y, E, H, indented

HENCKY = cc.materials.hencky(E, NU, SIGMA_Y, H)
LINEAR = cc.materials.isotropic(E, NU)


def sphere(material, n):
    """3D: a block (-1, 1)^2 x (-1, 0) m (n x n x n/2 cells, clamped at the bottom) pressed 0.02 m deep by a rigid
    sphere of radius 2 m (tests/scenes3d.py ``sphere_into_block`` with the given material)."""
    block = cc.box(x=(-1.0, 1.0), y=(-1.0, 1.0), z=(-1.0, 0.0), nx=n, ny=n, nz=max(1, n // 2))
    body = cc.Body(block, material, clamped=["bottom"])
    return cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere((0.0, 0.0, 2.0 - 0.02), 2.0))])


def timed(material, method, nx, ny, degree, krylov=None):
    """(wall s, CPU s, solution, unknowns, tangent solver or None) of one ``ContactSolver.solve``."""
    scene = sphere(material, nx) if ny == 0 else indented(material, nx=nx, ny=ny, depth=5e-3)
    solver = cc.ContactSolver(scene, method=method, estimate=False,
                              degree=degree, condition="sigma1" if degree == 2 else "gamma3")
    default, nonlinear.KRYLOV = nonlinear.KRYLOV, nonlinear.KRYLOV if krylov is None else krylov
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cc.ResolutionWarning)
            t0, c0 = time.perf_counter(), time.process_time()
            sol = solver.solve()
            seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        nonlinear.KRYLOV = default
    assert sol.ok, sol.report()
    print(f"  {method} {material.name} {nx} x {ny} P{degree}: {seconds:.2f} s ({cpu:.2f} s CPU), "
          f"{sol.info.iterations} iterations, stages {', '.join(f'{k} {v:.2f}' for k, v in sol.info.timings.items())}",
          file=sys.stderr, flush=True)
    return seconds, cpu, sol, solver.problem.unknowns, solver.cache.own.get("newton")


def main(quick=False):
    timed(HENCKY, "auto", 8, 4, 1)             # loads the libraries (PARDISO, CVXPY) outside the measurements
    timed(LINEAR, "auto", 8, 4, 1)
    cases = [(64, 24, 1, True), (160, 80, 1, False), (320, 160, 1, False), (160, 80, 2, False)]
    if quick:
        cases = [(64, 24, 1, True), (96, 48, 1, False)]
    elif "--large" in sys.argv:
        cases = cases[2:]
    elif "--p2" in sys.argv:
        cases = cases[3:]
    elif "--3d" in sys.argv:
        cases = [(24, 0, 1, False)]            # ny = 0: the 3D sphere (nx cells a side)
    print("| mesh | P | unknowns | linear auto (s) | linear sparse (s) | fast (s) | steps | factorisations | GMRES "
          "| fast / linear auto | fast / linear sparse | CPU: linear auto (s) | CPU: fast (s) | CPU: fast / linear auto "
          "| CPU: 1 per step (s) | full (s) | full / fast |")
    print("|---" * 17 + "|")
    for nx, ny, degree, with_full in cases:
        t_auto, c_auto, _, N, _ = timed(LINEAR, "auto", nx, ny, degree)
        t_sparse, _, _, _, _ = timed(LINEAR, "sparse", nx, ny, degree)
        t_fast, c_fast, fast, _, tangent = timed(HENCKY, "auto", nx, ny, degree)
        assert fast.info.method == "newton"
        _, c_each, _, _, _ = timed(HENCKY, "auto", nx, ny, degree, krylov=0)
        full = "- | -"
        if with_full:
            t_full, _, _, _, _ = timed(HENCKY, "full", nx, ny, degree)
            full = f"{t_full:.2f} | {t_full / t_fast:.1f}"
        print(f"| {f'3D sphere {nx}' if ny == 0 else f'{nx} x {ny}'} | {degree} | {N} | {t_auto:.2f} | {t_sparse:.2f} "
              f"| {t_fast:.2f} | {fast.info.iterations} | {tangent.factorizations} | {tangent.iterations} "
              f"| {t_fast / t_auto:.1f} | {t_fast / t_sparse:.1f} | {c_auto:.2f} | {c_fast:.2f} | {c_fast / c_auto:.1f} "
              f"| {c_each:.2f} | {full} |", flush=True)


if __name__ == "__main__":
    main("--quick" in sys.argv)
