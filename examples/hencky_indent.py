"""Hencky plasticity: a rigid cylinder pressed into a yielding block.
==================================================================

A block 1 m x 0.5 m, clamped at its bottom, is indented by a rigid circle of radius 2 m pressed a depth d
into its top (displacement control). The block is an aluminium-like alloy,
``cc.materials.hencky(E=70 GPa, nu=0.3, sigma_y=200 MPa, h=0.1)``: the linear isotropic material until the von
Mises stress reaches sigma_y, then its shear stiffness scaled by h (docs/tutorials/hencky.md,
docs/materials.md). The same scene is solved with the linear material for comparison.

Look at: at the smallest depth no cell yields and the force is the linear material's; deeper, a plastic zone
grows under the circle (the cells whose deviatoric strain ``|dev eps|`` passes s_y = sigma_y / (sqrt(6) mu), where the
von Mises stress reaches sigma_y) and the force falls below the linear one. ``cc.solve`` takes Newton on the
nonlinear mixed system with the contact active set (``sol.info.finish``).

Run:  python examples/hencky_indent.py [nx]
"""

import sys

import numpy as np

import cvxcontact as cc
from cvxcontact.fem.fields import body_fields

E, NU, SIGMA_Y, H = 70e9, 0.3, 200e6, 0.1          # Pa, -, Pa, -
RADIUS = 2.0                                        # m
DEPTHS = (0.2e-3, 1e-3, 2e-3, 3e-3)                 # m
MU = E / (2 * (1 + NU))
S_Y = SIGMA_Y / (np.sqrt(6) * MU)                   # the deviatoric strain at yield (docs/tutorials/hencky.md)


def build(nx=16, depth=3e-3, material=None):
    """The block on nx by nx / 2 cells, graded towards the indent, (Hencky unless ``material``), the circle pressed ``depth`` (m) in."""
    material = material or cc.materials.hencky(E=E, nu=NU, sigma_y=SIGMA_Y, h=H)
    m = cc.graded_block(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=max(2, nx // 2), contact="top", beta=4.0,
                        gamma=2.0, center=0.5)            # cells shrink towards the circle's lowest point
    b = cc.Body(m, material, clamped=["bottom"], contact="top")
    circle = cc.Rigid.circle(center=(0.5, 0.5 + RADIUS - depth), radius=RADIUS)
    return cc.Scene(b, contacts=[cc.Contact(b, "top", circle)])


def deviatoric_strain(sol):
    """|dev eps| per cell (plane strain, eps_zz = 0; the Frobenius norm of the 3x3 deviator)."""
    exx, eyy, exy = body_fields(sol.scene.bodies[0], sol.u[0], None).strain.T     # tensor strains at the centres
    mean = (exx + eyy) / 3
    return np.sqrt((exx - mean) ** 2 + (eyy - mean) ** 2 + mean ** 2 + 2 * exy ** 2)


def main(nx=16):
    """For each depth of DEPTHS: (depth, Hencky force, linear force, plastic cells, Hencky solution)."""
    linear = cc.materials.isotropic(E=E, nu=NU)
    print(f"{'d [mm]':>7s} {'F Hencky [MN/m]':>16s} {'F linear [MN/m]':>16s} {'ratio':>7s} {'plastic cells':>14s}")
    rows = []
    for depth in DEPTHS:
        sol = cc.solve(build(nx, depth))
        lin = cc.solve(build(nx, depth, linear))
        assert sol.ok and lin.ok, sol.report()
        F, F_lin = sol.contact.force.sum(), lin.contact.force.sum()
        plastic = int((deviatoric_strain(sol) > S_Y).sum())
        rows.append((depth, F, F_lin, plastic, sol))
        print(f"{depth * 1e3:7.2f} {F / 1e6:16.6f} {F_lin / 1e6:16.6f} {F / F_lin:7.4f} {plastic:14d}")
    print(f"the finish: {sol.info.finish}")
    return rows


def figure(rows):
    """Left: force against depth, Hencky and linear. Right: the plastic zone at the deepest indentation."""
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), layout="constrained")
    depth, F, F_lin = (np.array([r[i] for r in rows]) for i in range(3))
    left.plot(depth * 1e3, F_lin / 1e6, "s--", label="linear material")
    left.plot(depth * 1e3, F / 1e6, "o-", label="Hencky")
    left.set(xlabel="depth d (mm)", ylabel="contact force (MN/m)", title="force against depth")
    left.legend()
    sol = rows[-1][-1]
    mesh = sol.scene.bodies[0].mesh
    tri = Triangulation(mesh.points[:, 0], mesh.points[:, 1], mesh.triangles)
    shade = right.tripcolor(tri, deviatoric_strain(sol) / S_Y, cmap="viridis")
    fig.colorbar(shade, ax=right, label="|dev eps| / s_y (> 1: plastic)")
    right.set(aspect="equal", xlabel="x (m)", ylabel="y (m)", title=f"plastic zone, d = {rows[-1][0] * 1e3:g} mm")
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 16))
    plt.show()
