"""A piezoelectric actuator driven only by an electrode voltage, pressing on an elastic foundation.
================================================================================================

The upper body (PZT-5H, 1 m x 0.25 m, poled along +y) is clamped along its top edge and
grounded along its bottom edge, which is also the contact face. A driven electrode
(phi = V) covers only the middle half of the top edge: a custom boundary tag, built
from the rectangle's top edges. No force is applied anywhere. With V < 0 the field
E = -grad(phi) points along the poling axis, the layer expands under the electrode
(converse piezoelectric effect, e33 > 0) and presses on the foundation (a polymer,
E = 3 GPa) below it.

Look at: the contact force grows exactly linearly with V (the problem is positively
homogeneous in the loads) and the active set does not change with V; the pressure
peaks under the electrode; reversing the voltage lifts the actuator off (no active node).

Run:  python examples/actuator.py [nx]
"""

import sys

import numpy as np

import cvxcontact as cc


def build(voltage, nx=24):
    grid = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.25), nx=nx, ny=max(2, nx // 4))
    top = grid.boundary("top")
    middle = np.abs(grid.points[top].mean(axis=1)[:, 0] - 0.5) <= 0.25 + 1e-12
    parts = {t: grid.boundary(t) for t in grid.tags} | {"electrode": top[middle]}
    actuator = cc.Mesh(grid.points, grid.triangles, parts)
    foundation = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=max(2, 2 * nx // 3), ny=max(2, nx // 3))
    b1 = cc.Body(actuator, cc.materials.PZT5H, clamped="top", grounded="bottom", potential={"electrode": voltage},
                 contact="bottom", name="actuator")
    b2 = cc.Body(foundation, cc.materials.isotropic(E=3e9, nu=0.35, name="polymer"), clamped="bottom",
                 contact="top", name="foundation")
    return cc.Scene(b1, b2)


def main(nx=24):
    rows = []
    for voltage in (-250.0, -500.0, -1000.0, 1000.0):
        sol = cc.solve(build(voltage, nx))
        c = sol.contact
        xa = c.x[c.active]
        zone = f"{len(xa)} active nodes in [{xa.min():.3f}, {xa.max():.3f}] m" if len(xa) else "none (lifted off)"
        rows.append((voltage, c.force.sum(), zone, sol))
        peak = c.x[np.argmax(c.pressure)] if len(xa) else float("nan")
        print(f"V = {voltage:+8.1f} V: contact force {c.force.sum():.6e} N/m, contact: {zone}, "
              f"peak pressure at x = {peak:.3f} m, max |u| {np.abs(sol.u[0]).max():.3e} m, checks ok: {sol.ok}")
    f = {v: force for v, force, _, _ in rows}
    print(f"force ratio F(-1000 V) / F(-250 V) = {f[-1000.0] / f[-250.0]:.12f} (linear: 4)")
    return rows


def figure(rows):
    """Left: the pressure felt by the foundation along the contact for each voltage; right: the contact
    force against the voltage (a straight line through zero until lift-off)."""
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import eng

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    for voltage, _, _, sol in rows:
        x, p = sol.traction(1)
        ax.plot(x, p, "o-", ms=2, lw=1, label=f"V = {voltage:+.0f} V")
    ax.set(xlabel="x1 along the contact", ylabel="pressure felt by the foundation", title="Contact pressure")
    ax.legend(fontsize=8)
    v = [r[0] for r in rows]
    ax2.plot(v, [r[1] for r in rows], "s", label="contact force (solved)")
    ax2.set(xlabel="electrode voltage V", ylabel="contact force", title="Force against voltage")
    for a, (xu, yu) in ((ax, ("m", "Pa")), (ax2, ("V", "N/m"))):
        a.xaxis.set_major_formatter(eng(xu))
        a.yaxis.set_major_formatter(eng(yu))
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 24))
    plt.show()
