"""A three-layer stack: three bodies, two contact pairs, a floating electrode, no clamp but the base.
==================================================================================================

From the top: a PZT-5A layer (poled along +y) with a grounded bottom face and an open-circuit
floating electrode on its top face (Q = 0), an aluminium layer, a steel base clamped along
its bottom. Every side edge rolls (u_x = 0: a strip cut from a long stack) and a uniform
pressure p pushes on the top. The two upper layers are held by the contacts only: nothing
clamps them, the solve holds them exactly (no penalty).

The aluminium layer carries its own weight (rho g = 26.5 kN/m^3), so that the two pairs carry
different forces. (It is not needed for the solve: whether the contacts hold the layers is decided on
the assembled problem, every body and load together; a load-free layer squeezed between the others is
solved as well.)

The closed form (uniaxial strain): the upper pair carries F = p w (N/m), the lower one adds the
aluminium's weight, p w + rho g h w; layer i shortens by (p h_i + its weight's share) / M_i with M_i = E(1 - nu)/((1 + nu)(1 - 2 nu)) for the elastic layers and the
stiffened M = c33 + e33^2 / eps33 for the open-circuit piezoelectric layer, whose floating
electrode sits at phi = e33 eps_yy h / eps33 < 0 (D_y = 0 through the layer).

Look at: each pair's force equals the load, the shortenings and the electrode's potential
match the closed form to rounding, and both pairs are fully active.

Run:  python examples/stack.py [nx]
The same scene as a file:  cvxcontact solve examples/stack.toml
"""

import sys

import numpy as np

import cvxcontact as cc

P, W = 1e7, 1.0                                     # pressure on the top (Pa), width (m)
RHO_G = 2700.0 * 9.81                               # weight density of the aluminium (N/m^3)
LAYERS = (("piezo", cc.materials.PZT5A, 0.2, 0.3),     # name, material, y bottom, y top (m)
          ("aluminium", cc.materials.isotropic(E=70e9, nu=0.33, name="aluminium"), 0.1, 0.2),
          ("steel", cc.materials.isotropic(E=200e9, nu=0.3, name="steel"), 0.0, 0.1))


def build(nx=8):
    bodies = []
    for k, (name, material, y0, y1) in enumerate(LAYERS):
        mesh = cc.rectangle(x=(0.0, W), y=(y0, y1), nx=nx + 2 * k, ny=2)      # non-matching meshes
        kw = dict(roller=["left", "right"], contact="top" if name == "steel" else "bottom")
        if name == "piezo":
            kw.update(grounded=["bottom"], floating={"top": 0.0}, traction={"top": (0.0, -P)})
        if name == "steel":
            kw.update(clamped=["bottom"])
        if name == "aluminium":
            kw.update(body_force=(0.0, -RHO_G))        # its own weight (see the docstring)
        bodies.append(cc.Body(mesh, material, name=name, **kw))
    piezo, alu, steel = bodies
    contacts = [cc.Contact(piezo, "bottom", alu, "top"), cc.Contact(alu, "bottom", steel, "top")]
    return cc.Scene(*bodies, contacts=contacts)


def modulus(material):
    """Uniaxial-strain modulus (Pa): c33, stiffened by e33^2/eps33 for an open-circuit piezoelectric layer."""
    c33 = material.c[1, 1]
    return c33 + material.e[1, 1] ** 2 / material.kappa[1, 1] if material.piezoelectric else c33


def main(nx=8):
    scene = build(nx)
    sol = cc.solve(scene)
    print(sol.report())
    print(f"\n{'pair':28s} {'force [kN/m]':>13s} {'load [kN/m]':>11s} {'active':>8s}")
    for i, (pair, c) in enumerate(zip(scene.contacts, sol.contacts)):
        label = f"{pair.body_a.name}/{pair.part_a} on {pair.other.name}/{pair.part_b}"
        load = P * W + (RHO_G * 0.1 * W if i == 1 else 0.0)
        print(f"{label:28s} {c.force.sum() / 1e3:13.6f} {load / 1e3:11.6f} "
              f"{int(c.active.sum()):>3d} of {int(c.constrained.sum())}")
    print(f"\n{'layer':10s} {'shortening [nm]':>16s} {'closed form [nm]':>17s}")
    rows = []
    for body, u, (name, material, y0, y1) in zip(scene.bodies, sol.u, LAYERS):
        pts = body.mesh.points
        top, bottom = pts[:, 1] > y1 - 1e-12, pts[:, 1] < y0 + 1e-12
        short = u[bottom, 1].mean() - u[top, 1].mean()
        h = y1 - y0
        weight = {"aluminium": RHO_G * h * h / 2, "steel": RHO_G * 0.1 * h}.get(name, 0.0)
        exact = (P * h + weight) / modulus(material)
        rows.append((name, short, exact))
        print(f"{name:10s} {short * 1e9:16.6f} {exact * 1e9:17.6f}")
    piezo = scene.bodies[0].material
    eps = -P / modulus(piezo)
    exact_phi = piezo.e[1, 1] * eps * (LAYERS[0][3] - LAYERS[0][2]) / piezo.kappa[1, 1]
    for e in sol.electrodes:
        print(f"electrode {scene.bodies[e.body].name}/{e.tag} ({e.kind}): {e.potential:10.4f} V, "
              f"charge {e.charge:.3e} C/m")
    print(f"closed form of the floating electrode: {exact_phi:10.4f} V")
    return sol, rows, exact_phi


def figure(result):
    """The contact along both pairs (cvxcontact.io.plot.plot_contact): the jumps are at rounding level
    (every node closed) and are drawn as zero with their magnitude stated."""
    from cvxcontact.io.plot import plot_contact

    return plot_contact(result[0])


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 8))
    plt.show()
