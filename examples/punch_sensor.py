"""A steel punch pressed into a PZT-5A substrate, read as a force sensor.
======================================================================

The substrate (1 m x 0.2 m, poled along +y) is clamped and grounded along its bottom; its top
carries an electrode. The punch (0.2 m wide, steel) is centred on it and touches only the
footprint [0.4, 0.6] x {0.2} of the top side (a named sub-segment: no gmsh needed); its top
edge is pushed down by a prescribed displacement d (displacement control).

Two readings of the same top electrode:

* open circuit: a floating electrode with no net charge (Q = 0): its potential V is the reading;
* short circuit: the electrode grounded: the charge Q it collects (C/m) is the reading.

Look at: the punch force F (the contact force, N/m), V and Q are all proportional to d (the
problem is positively homogeneous: a flat punch with no gap keeps its active set), so V/F and
Q/F are constants of the sensor, printed in the last columns.

Run:  python examples/punch_sensor.py [nx]
The same scene as a file:  cvxcontact solve examples/punch_sensor.toml
"""

import sys

import cvxcontact as cc

STEEL = cc.materials.isotropic(E=200e9, nu=0.3, name="steel")


def build(d, nx=20, circuit="open"):
    """The scene for a punch displacement d (m); circuit "open" (floating electrode) or "short"."""
    substrate_mesh = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.2), nx=nx, ny=max(2, nx // 5),
                                  segments={"footprint": ("top", 0.4, 0.6)})
    electrode = dict(floating={"top": 0.0}) if circuit == "open" else dict(grounded=["bottom", "top"])
    substrate = cc.Body(substrate_mesh, cc.materials.PZT5A, name="substrate", clamped=["bottom"],
                        contact="footprint", **({"grounded": ["bottom"]} | electrode))
    punch_mesh = cc.rectangle(x=(0.4, 0.6), y=(0.2, 0.3), nx=max(2, nx // 4), ny=2)
    punch = cc.Body(punch_mesh, STEEL, name="punch", contact="bottom", displacement={"top": (0.0, -d)})
    return cc.Scene(punch, substrate, contacts=[cc.Contact(punch, "bottom", substrate, "footprint")])


def main(nx=20, displacements=(1e-6, 2e-6, 5e-6)):
    rows = []
    print(f"{'d [um]':>7s} {'F [kN/m]':>10s} {'V open [V]':>11s} {'Q short [uC/m]':>15s} "
          f"{'V/F [V m/N]':>12s} {'Q/F [C/N]':>11s}")
    for d in displacements:
        opened = cc.solve(build(d, nx, "open"))
        shorted = cc.solve(build(d, nx, "short"))
        assert opened.ok and shorted.ok, (opened.report(), shorted.report())
        force = opened.contact.force.sum()                     # N/m, compressive > 0
        V = next(e.potential for e in opened.electrodes if e.tag == "top")
        Q = next(e.charge for e in shorted.electrodes if e.tag == "top")
        rows.append((d, force, V, Q, shorted.contact.force.sum()))
        print(f"{d * 1e6:7.2f} {force / 1e3:10.3f} {V:11.4f} {Q * 1e6:15.6f} {V / force:12.5e} {Q / force:11.4e}")
    print("linear sensor: V/F and Q/F are the same on every row")
    return rows


def figure(rows):
    """The open-circuit potential and the short-circuit charge against the punch force: straight lines."""
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import eng

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    force = [r[1] for r in rows]
    ax.plot(force, [r[2] for r in rows], "o-")
    ax2.plot(force, [r[3] for r in rows], "s-", color="C1")
    ax.set(xlabel="punch force", ylabel="open-circuit potential", title="Open circuit: floating electrode")
    ax2.set(xlabel="punch force", ylabel="short-circuit charge", title="Short circuit: grounded electrode")
    for a, unit in ((ax, "V"), (ax2, "C/m")):
        a.xaxis.set_major_formatter(eng("N/m"))
        a.yaxis.set_major_formatter(eng(unit))
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 20))
    plt.show()
