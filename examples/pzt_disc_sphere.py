"""A PZT-5A disc pressed by a rigid sphere: the open-circuit electrode as a force sensor (3D).
===========================================================================================

The disc (radius 5 mm, 2 mm thick, ``cc.cylinder``, poled along +z) stands on a rigid base: its bottom
face is clamped and carries the grounded electrode. Its top face carries a floating electrode with no net
charge (open circuit: one unknown potential V) and is the contact surface of a rigid sphere (R = 50 mm)
centred on the axis, under force control (``cc.Rigid.sphere(..., force=(0, 0, -F))``). One
``cc.ContactSolver`` re-solves the scene for a few forces (``scene.with_obstacles(sphere.with_force(...))``):
the geometry is prepared once.

Look at: V is negative under compression (the direct effect: D_z = 0 and T_3 < 0 give E_3 > 0) and nearly
proportional to F; V / F drifts a little as the contact zone grows, since the reading weighs the pressure
by a sensitivity that falls off from the axis. That weight has a meaning of its own (reciprocity): with
u2 the top face's displacement when a charge Q2 sits on the electrode and nothing presses, the
open-circuit potential under contact forces y_a at the nodes x_a is

    V = sum_a y_a d_a . u2(x_a) / Q2,

d_a the direction of the node's row (towards the sphere's closest point: radial, nearly vertical here),

exact for the discrete problem too (its matrix is symmetric). The example solves that second state (the
sphere lifted clear: no contact) and prints both sides, and the point-force limit F u2_z(0) / Q2.

Run:  python examples/pzt_disc_sphere.py [n_r]
"""

import sys

import numpy as np

import cvxcontact as cc

RADIUS, THICKNESS, R = 5e-3, 2e-3, 0.5                        # m
FORCES = (100.0, 200.0, 400.0, 800.0)                       # N, the whole sphere's


def build(n_r=8, force=FORCES[0], lift=0.0, charge=0.0):
    """The disc and the sphere touching its centre (raised by ``lift``, m), under ``force`` (N; None: fixed)."""
    mesh = cc.cylinder(radius=RADIUS, height=THICKNESS, n_r=n_r, n_z=3)
    disc = cc.Body(mesh, cc.materials.PZT5A, name="disc", clamped=["bottom"], grounded=["bottom"],
                   floating={"top": charge}, contact="top")
    sphere = cc.Rigid.sphere((0.0, 0.0, THICKNESS + R + lift), R,
                             force=None if force is None else (0.0, 0.0, -force))
    return cc.Scene(disc, contacts=[cc.Contact(disc, "top", sphere)])


def sensitivity(n_r=8, Q2=1e-9):
    """u2 / Q2 (n, 3): the nodes' displacement per unit electrode charge (m/C), nothing pressing (the sphere
    fixed 1 mm above the disc: no contact)."""
    sol = cc.solve(build(n_r, force=None, lift=1e-3, charge=Q2))
    assert sol.ok and not sol.contact.active.any(), sol.report()
    return sol.u[0] / Q2


def main(n_r=8, forces=FORCES):
    scene = build(n_r, forces[0])
    solver = cc.ContactSolver(scene)
    sphere = scene.obstacles[0].obstacle
    w = sensitivity(n_r)                                       # m/C at every node of the disc
    itf = scene.interfaces[0]
    nodes = itf.traces[0].nodes[itf.reach]                     # the disc's nodes of the contact rows
    along = np.einsum("ij,ij->i", sphere.direction(itf.points, itf.normal), w[nodes])   # d_a . u2(x_a) / Q2
    centre = np.argmin(np.linalg.norm(scene.bodies[0].mesh.points - [0.0, 0.0, THICKNESS], axis=1))
    print(f"{'F [N]':>7s} {'V [V]':>10s} {'V/F [mV/N]':>11s} {'reciprocity [V]':>16s} {'point force [V]':>16s} "
          f"{'active':>6s} {'outermost active node [mm]':>27s}")
    rows = []
    for F in forces:
        sol = solver.solve(scene.with_obstacles(sphere.with_force((0.0, 0.0, -F))))
        assert sol.ok, sol.report()
        V = next(e.potential for e in sol.electrodes if e.tag == "top")
        c = sol.contact
        reciprocal = float(c.force @ along)                    # sum_a y_a d_a . u2(x_a) / Q2
        point = F * w[centre, 2]
        r = np.hypot(c.points[c.active, 0], c.points[c.active, 1]).max()
        rows.append(dict(F=F, V=V, reciprocal=reciprocal, point=point, sol=sol))
        print(f"{F:7.1f} {V:10.4f} {1e3 * V / F:11.4f} {reciprocal:16.4f} {point:16.4f} {int(c.active.sum()):6d} "
              f"{1e3 * r:27.3f}")
    worst = max(abs(r["V"] - r["reciprocal"]) / abs(r["V"]) for r in rows)
    print(f"reciprocity: V = sum_a y_a d_a . u2(x_a) / Q2 to {worst:.1e} (relative); the point-force limit F u2_z(0) / Q2 "
          f"is {abs(rows[0]['point'] / rows[0]['V'] - 1):.1%} off at {forces[0]:g} N, "
          f"{abs(rows[-1]['point'] / rows[-1]['V'] - 1):.1%} at {forces[-1]:g} N")
    return rows


def figure(rows):
    """Left: the open-circuit potential against the force, with the point-force line; right: the pressure on
    the top face at the largest force (the contact zone, on the disc's nodes)."""
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    from cvxcontact.io.plot import eng

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
    F = np.array([r["F"] for r in rows])
    ax.plot(F, [r["V"] for r in rows], "o-", label="floating electrode, finite elements")
    ax.plot(F, [r["reciprocal"] for r in rows], "x", ms=9, label=r"reciprocity: $\sum_a y_a\,u_{2z}(x_a)/Q_2$")
    ax.plot(F, [r["point"] for r in rows], "--", color="0.4", label=r"point force: $F\,u_{2z}(0)/Q_2$")
    ax.set(xlabel="sphere force", ylabel="open-circuit potential",
           title="PZT-5A disc under a rigid sphere: the electrode reading")
    ax.xaxis.set_major_formatter(eng("N"))
    ax.yaxis.set_major_formatter(eng("V"))
    ax.legend(fontsize=8)
    sol = rows[-1]["sol"]
    itf = sol.scene.interfaces[0]
    trace = itf.traces[0]
    p = np.zeros(len(trace.nodes))
    p[itf.reach] = sol.contact.pressure
    tri = Triangulation(trace.points[:, 0], trace.points[:, 1], trace.faces)
    m = ax2.tripcolor(tri, p, shading="gouraud", cmap="viridis")
    ax2.triplot(tri, lw=0.2, color="w", alpha=0.4)
    ax2.set_aspect("equal")
    ax2.set(xlabel="x", ylabel="y", title=f"Contact pressure on the top face, F = {rows[-1]['F']:g} N")
    for axis in (ax2.xaxis, ax2.yaxis):
        axis.set_major_formatter(eng("m"))
    fig.colorbar(m, ax=ax2, format=eng("Pa"), label="pressure felt by the disc")
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 8))
    plt.show()
