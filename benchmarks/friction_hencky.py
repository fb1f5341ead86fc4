"""Benchmark: a friction law beside a yielding Hencky body (the sheared block of tests/test_friction_hencky.py,
2D 8 x 4 cells, 3D 2 x 2 x 2 cells, sigma_y = p = 1e8 Pa) under every nodal condition and element the sequential
finish serves: the answer's checks, its finish, and the CPU seconds of the solve, under the route's Clarabel settings
beside a Hencky body and under the conic ones it used before (``equilibrate_enable=False``, the user's options
winning):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:benchmarks python benchmarks/friction_hencky.py

Results: benchmarks/results/friction_hencky.md.
"""

from __future__ import annotations

from harness import solve_cpu

import cvxcontact as cc

E, NU, H, P = 200e9, 0.3, 0.1, 1e8
FLOOR2 = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
FLOOR3 = cc.Rigid.plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))


def block(law, cell, dim):
    """The Hencky block on the floor under (p / 2, -p) (3D: (0.4 p, 0.2 p, -p)) on its top, ``law`` on its base."""
    material = cc.materials.hencky(E=E, nu=NU, sigma_y=P, h=H)
    if dim == 2:
        m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4, cell=cell)
        b = cc.Body(m, material, contact="bottom", traction={"top": (0.5 * P, -P)})
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR2, law=law)])
    m = cc.box(nx=2, ny=2, nz=2, cell=cell)
    b = cc.Body(m, material, contact="bottom", traction={"top": (0.4 * P, 0.2 * P, -P)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR3, law=law)])


CASES = [(f"{dim}D {el} {cond}", cell, dim, cond, deg)
         for dim, el, cell, cond, deg in [(2, "P1", "triangle", "gamma3", 1), (2, "P2", "triangle", "sigma1", 2),
                                          (2, "P2", "triangle", "sigma2", 2), (2, "Q1", "quad", "sigma1", 1),
                                          (2, "Q2", "quad", "sigma2", 2), (2, "Q1", "quad", "gamma3", 1),
                                          (3, "P1", "tetra", "sigma1", 1), (3, "P1", "tetra", "gamma3", 1),
                                          (3, "P2", "tetra", "sigma1", 2), (3, "P2", "tetra", "sigma2", 2),
                                          (3, "Q1", "hex", "sigma1", 1)]]


def main():
    print("| law | case | settings | ok | finished | cpu s |\n|---|---|---|---|---|---|")
    for law_name, law in (("Tresca 0.6 p", lambda: cc.Tresca(0.6 * P)), ("Coulomb 0.6", lambda: cc.Coulomb(0.6))):
        for name, cell, dim, cond, deg in CASES:
            for settings, options in (("route's", None), ("conic (before)", {"equilibrate_enable": False})):
                try:
                    sol, cpu = solve_cpu(block(law(), cell, dim), cond, degree=deg, solver_options=options)
                    ok, finished = sol.ok, sol.polished
                except cc.SolverError as exc:
                    ok, finished, cpu = f"SolverError ({str(exc)[:20]}...)", "-", float("nan")
                print(f"| {law_name} | {name} | {settings} | {ok} | {finished} | {cpu:.2f} |", flush=True)


if __name__ == "__main__":
    main()
