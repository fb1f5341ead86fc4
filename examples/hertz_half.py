"""Hertz half model: a rigid cylinder pressed into a block, only the right half meshed.
====================================================================================

The scene is symmetric about x = 0, so only x >= 0 is modelled: the block's left edge (on the
symmetry line) gets a roller (u_x = 0, u_y free), the cylinder is a rigid circle obstacle
(``cc.Rigid.circle``: analytic, no mesh) of radius R whose lowest point sits delta below the
block's top (a prescribed approach, displacement control). The block is clamped at its bottom.

The plane-strain Hertz solution of a rigid cylinder on an elastic half-space under the load
P (N/m) of the WHOLE contact (twice the half model's force) is::

    a = sqrt(4 P R / (pi E*)),   p0 = 2 P / (pi a),   E* = E / (1 - nu^2).

Look at: the half-width a_h (half-way between the last active node and the first open one, so
``|a_h - a| <= h/2``, h the cell where the contact ends) and the peak pressure p0_h felt by the block
come within a few per cent of Hertz (the block is finite, the mesh is P1). The pressure felt by
the block alternates from node to node against a rigid obstacle on this mesh (try plotting
``sol.traction(0)``), so p0_h is the mean over the two nodes nearest the axis.

Run:  python examples/hertz_half.py [nx ...]
The same scene as a file (nx = 32):  cvxcontact solve examples/hertz_half.toml
"""

import sys

import numpy as np

import cvxcontact as cc

E, NU = 70e9, 0.33
R, DELTA, WIDTH, DEPTH = 1.0, 2e-3, 0.5, 0.5        # m


def build(nx=40):
    # cells shrink towards the top and towards the symmetry line (the grading centre must lie
    # strictly inside the block: a micrometre from its left edge)
    mesh = cc.graded_block(x=(0.0, WIDTH), y=(-DEPTH, 0.0), nx=nx, ny=max(2, nx // 2), contact="top",
                           beta=3.0, gamma=2.0, center=1e-6)
    block = cc.Body(mesh,
                    cc.materials.isotropic(E=E, nu=NU, name="aluminium"), name="block",
                    clamped=["bottom"], roller=["left"], contact="top")
    cylinder = cc.Rigid.circle(center=(0.0, R - DELTA), radius=R)
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cylinder)])


def hertz(P):
    """Half-width a (m) and peak pressure p0 (Pa) of a rigid cylinder on a half-space under P (N/m)."""
    a = np.sqrt(4 * P * R / (np.pi * E / (1 - NU ** 2)))
    return a, 2 * P / (np.pi * a)


def measured(sol):
    """(P, a_h, p0_h, h): whole-contact load (N/m), half-width (m), peak pressure on the block (Pa; the
    mean over the first two nodes), size of the cell where the contact ends (m)."""
    c = sol.contact
    x, p = sol.traction(0)
    last = c.x[c.active].max()
    after = c.x[c.x > last + 1e-12]
    a_h = 0.5 * (last + after.min()) if len(after) else last
    p0_h = 0.5 * (p[0] + p[1])             # the two nodes nearest the axis: the nodal values alternate
    return 2 * c.force.sum(), a_h, p0_h, (after.min() - last if len(after) else float("nan"))


def main(sizes=(20, 40)):
    print(f"{'nx':>4s} {'P [MN/m]':>9s} {'a_h [mm]':>9s} {'a [mm]':>8s} {'h/2 [mm]':>9s} "
          f"{'p0_h [MPa]':>11s} {'p0 [MPa]':>9s}")
    rows = []
    for nx in sizes:
        sol = cc.solve(build(nx))
        assert sol.ok, sol.report()
        P, a_h, p0_h, h = measured(sol)
        a, p0 = hertz(P)
        rows.append((nx, P, a_h, a, h, p0_h, p0))
        print(f"{nx:4d} {P / 1e6:9.4f} {a_h * 1e3:9.3f} {a * 1e3:8.3f} {h / 2 * 1e3:9.3f} "
              f"{p0_h / 1e6:11.2f} {p0 / 1e6:9.2f}")
    return rows


def figure(rows, nx=None):
    """The pressure felt by the block on the finest mesh against the Hertz profile at the measured load."""
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import eng

    nx = nx or rows[-1][0]
    sol = cc.solve(build(nx))
    P, *_ = measured(sol)
    a, p0 = hertz(P)
    x, p = sol.traction(0)
    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    xs = np.linspace(0, a, 200)
    ax.plot(xs, p0 * np.sqrt(1 - (xs / a) ** 2), "k-", label="Hertz (measured load)")
    ax.plot(x, p, "o-", ms=3, lw=0.8, label=f"pressure felt by the block, nx = {nx}")
    ax.set(xlabel="x1 (distance from the symmetry line)", ylabel="contact pressure", xlim=(0, 3 * a),
           title="Rigid cylinder on a block: half model")
    ax.xaxis.set_major_formatter(eng("m"))
    ax.yaxis.set_major_formatter(eng("Pa"))
    ax.legend()
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(tuple(int(n) for n in sys.argv[1:]) or (20, 40)))
    plt.show()
