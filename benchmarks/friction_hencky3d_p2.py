"""Benchmark: a friction law beside a Hencky body under the 3D P2 cones ("gamma3", degree=2 on tetrahedra;
docs/refusals.md row 36): a block (3 x 3 x 1 cells) clamped at its base, indented 1 mm by a rigid sphere (radius 1 m)
off the centre of its top (the contact ends inside elements: cut points), and the sheared block of
benchmarks/friction_hencky.py (2 x 2 x 2 cells, sigma_y = p); the linear material, a Hencky one that never yields
and one that yields, the friction finish's sequential quadratic steps damped (the route) and undamped (every step
in full, as before): whether the answer is finished, its relative distance to the linear answer, and the CPU
seconds of the solve:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:benchmarks python benchmarks/friction_hencky3d_p2.py

Results: benchmarks/results/friction_hencky3d_p2.md.
"""

from __future__ import annotations

from unittest import mock

import numpy as np
from harness import solve_cpu

import cvxcontact as cc
from cvxcontact.backends import frictionsteps

E, NU, H, P = 200e9, 0.3, 0.1, 1e8
FLOOR = cc.Rigid.plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
MATERIALS = {"linear": cc.materials.isotropic(E=E, nu=NU),
             "never yields": cc.materials.hencky(E=E, nu=NU, sigma_y=1e15, h=H),
             "yields (200 MPa)": cc.materials.hencky(E=E, nu=NU, sigma_y=2e8, h=H)}


def indented(law, material):
    """The block indented by the sphere, ``law`` on its top."""
    body = cc.Body(cc.box(nx=3, ny=3, nz=1), material, clamped="bottom", contact="top")
    ball = cc.Rigid.sphere((0.47, 0.52, 2.0 - 1e-3), 1.0, distance="ray")
    return cc.Scene(body, contacts=[cc.Contact(body, "top", ball, law=law)])


def sheared(law, material):
    """The block of benchmarks/friction_hencky.py under (0.4 p, 0.2 p, -p) on its top, ``law`` on its base."""
    body = cc.Body(cc.box(nx=2, ny=2, nz=2), material, contact="bottom", traction={"top": (0.4 * P, 0.2 * P, -P)})
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR, law=law)])


SCENES = [("sphere, Tresca 1e-6 Pa", indented, lambda: cc.Tresca(1e-6)),
          ("sphere, Tresca 300 MPa", indented, lambda: cc.Tresca(3e8)),
          ("sphere, Coulomb 0.3", indented, lambda: cc.Coulomb(0.3)),
          ("sheared block, Tresca 0.6 p", sheared, lambda: cc.Tresca(0.6 * P)),
          ("sheared block, Coulomb 0.6", sheared, lambda: cc.Coulomb(0.6))]


def main():
    print("| scene | material | steps | ok | finished | from the linear answer | cpu s |\n|---|---|---|---|---|---|---|")
    for name, scene, law in SCENES:
        linear = None
        for material, m in MATERIALS.items():
            for steps in ("damped", "undamped") if material != "linear" else ("-",):
                with mock.patch.object(frictionsteps, "_damping", lambda *a: 1.0) if steps == "undamped" \
                        else mock.patch.object(frictionsteps, "ARMIJO", frictionsteps.ARMIJO):
                    sol, cpu = solve_cpu(scene(law(), m), "gamma3", degree=2)
                linear = sol if linear is None else linear
                apart = float(np.abs(sol.u[0] - linear.u[0]).max() / np.abs(linear.u[0]).max())
                print(f"| {name} | {material} | {steps} | {sol.ok} | {sol.polished} | {apart:.1e} | {cpu:.2f} |",
                      flush=True)


if __name__ == "__main__":
    main()
