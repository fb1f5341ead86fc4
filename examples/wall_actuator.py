"""A piezoelectric actuator pushing a rigid wall held by a prescribed force (force control).
=========================================================================================

A PZT-5H column (0.2 m wide, 0.5 m tall, poled along +y) is clamped and grounded along its
bottom edge and guided by rollers on its sides (u_x = 0 there: it can only stretch along its axis). Its top edge is a driven electrode (phi = V) and touches a rigid wall, the plane
y = 0.5 m, which is not fixed: a spring-less press holds it with the prescribed force
F = (0, -F0) (N/m, pushing the wall down onto the column). The wall's translation t is then an
unknown of the convex program (energy term -F . t; docs/formulation.md §12) and the solution
reports it in ``sol.obstacles[0].translation``.

With V < 0 the field E = -grad(phi) points along the poling axis and the column lengthens
(converse effect, e33 > 0): it lifts the wall against the press. With V > 0 it shortens and the
wall follows it down: under force control the contact never opens, its resultant is always F.

Look at: the wall's translation is affine in V (equal steps for equal voltage steps: the
problem is linear while the contact stays closed) and equals the closed form of uniaxial strain,
t = -(p H + e33 V) / c33 with p = F0 / W (sigma_yy = c33 eps_yy - e33 E_y = -p, E_y = -V / H; exact for
P1); the contact resultant equals F to rounding ("obstacle balance").

Run:  python examples/wall_actuator.py [nx]
"""

import sys

import numpy as np

import cvxcontact as cc

F0 = 1e5          # N/m, the press's force on the wall
H, W = 0.5, 0.2   # m, the column's height and width


def build(voltage, nx=4):
    column = cc.rectangle(x=(0.0, W), y=(0.0, H), nx=nx, ny=max(2, 2 * nx))
    body = cc.Body(column, cc.materials.PZT5H, clamped="bottom", roller=["left", "right"], grounded="bottom",
                   potential={"top": voltage}, contact="top", name="actuator")
    wall = cc.Rigid.plane(point=(0.0, H), normal=(0.0, -1.0), force=(0.0, -F0))   # normal towards the body
    return cc.Scene(body, contacts=[cc.Contact(body, "top", wall)])


def main(nx=4):
    rows = []
    mat = cc.materials.PZT5H
    c33, e33 = mat.c[1, 1], mat.e[1, 1]                     # plane strain, poling along y (Pa, C/m^2)
    for voltage in (0.0, -2000.0, -4000.0, -6000.0, 2000.0):
        sol = cc.solve(build(voltage, nx))
        wall = sol.obstacles[0]
        exact = -(F0 / W * H + e33 * voltage) / c33
        rows.append((voltage, wall.translation[1], exact, sol))
        print(f"V = {voltage:+7.1f} V: wall moves by {wall.translation[1] * 1e6:+9.5f} um (closed form "
              f"{exact * 1e6:+9.5f}), contact resultant {-wall.force[1]:.6e} N/m (press {F0:.1e}), "
              f"balance {sol.residuals()['obstacle balance']:.1e}, checks ok: {sol.ok}")
    t = {v: ty for v, ty, _, _ in rows}
    steps = np.diff([t[v] for v in (0.0, -2000.0, -4000.0, -6000.0)])
    print(f"wall lift per -2000 V: {', '.join(f'{s * 1e6:.6f}' for s in steps)} um (affine in V)")
    return rows


def figure(rows):
    """The wall's translation against the voltage: solved (markers) and the closed form (line)."""
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import eng

    rows = sorted(rows, key=lambda r: r[0])
    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    ax.plot([r[0] for r in rows], [r[2] for r in rows], "k-", label="closed form (uniaxial strain)")
    ax.plot([r[0] for r in rows], [r[1] for r in rows], "o", label="solved (force control)")
    ax.set(xlabel="electrode voltage V", ylabel="wall translation", title="Wall lifted by the column")
    ax.xaxis.set_major_formatter(eng("V"))
    ax.yaxis.set_major_formatter(eng("m"))
    ax.legend()
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 4))
    plt.show()
