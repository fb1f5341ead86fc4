"""Friction: a block pressed on a rigid floor and pushed sideways, Tresca against Coulomb.
=======================================================================================

A steel block 1 m x 0.5 m (Poisson's ratio 0) is pressed on a rigid plane by p = 10 MPa on its top and
pushed by a prescribed u_x = s = 10 um on its left face; the floor resists slip with Tresca friction
(``cc.Tresca(g)``, a threshold g in Pa) or Coulomb friction (``cc.Coulomb(mu)``, the threshold mu times the
contact pressure). Coulomb with mu = g / p is compared with Tresca at g.

Look at: with a small friction every node slides and the floor's friction force is the full capacity
(Tresca: -g L; Coulomb: -mu times the normal force); with a large one the block sticks and is the *tied* block
(u_x = 0 prescribed on the base edges, no friction law at all); in between the slip zone shrinks towards the
pushed corner. Each answer is finished exactly (``sol.info.finish``) and checked (``sol.ok``).
See docs/tutorials/friction.md and docs/howto/friction.md.

Run:  python examples/friction_block.py [nx]
"""

import sys

import numpy as np

import cvxcontact as cc

E, P, L, S = 200e9, 1e7, 1.0, 1e-5                  # Pa, Pa, m, m
THRESHOLDS = (0.5e6, 3e6, 24e6)                     # g, Pa: sliding, partly sticking, stuck
FLOOR = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def build(nx=8, law=None, tied=False):
    """The block on nx by nx/2 cells pushed by u_x = S, pressed by P; tied: u_x = 0 on the base edges
    (all but the pushed corner's), frictionless."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, 0.5), nx=nx, ny=max(1, nx // 2))
    held = {}
    if tied:
        bottom = m.boundary("bottom")
        corner = np.flatnonzero((m.points[:, 0] == 0.0) & (m.points[:, 1] == 0.0))[0]
        m = cc.Mesh(m.points, m.triangles, {**{t: m.boundary(t) for t in m.tags},
                                            "base": bottom[(bottom != corner).all(axis=1)]})
        held = {"base": (0.0, None)}
    b = cc.Body(m, cc.materials.isotropic(E=E, nu=0.0), contact="bottom", traction={"top": (0.0, -P)},
                displacement={"left": (S, None), **held})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def main(nx=8):
    """Solve Tresca and Coulomb (mu = g / P) at each threshold of THRESHOLDS, and the tied block.

    Returns {"tied": Solution, ("tresca" | "coulomb", g): Solution}."""
    results = {"tied": cc.solve(build(nx, tied=True))}
    tied = results["tied"].u[0]
    print(f"{'law':>8s} {'g [MPa]':>8s} {'ok':>5s} {'friction / capacity':>20s} {'|u - u_tied| / s':>17s} "
          f"{'slipping nodes':>15s}  finish")
    for g in THRESHOLDS:
        for name, law in (("tresca", cc.Tresca(g)), ("coulomb", cc.Coulomb(g / P))):
            sol = cc.solve(build(nx, law=law))
            results[name, g] = sol
            c = sol.contact
            capacity = -g * L if name == "tresca" else -(g / P) * c.force.sum()
            slipping = int((np.abs(c.slip) > 1e-9 * S).sum())
            print(f"{name:>8s} {g / 1e6:8.2f} {sol.ok!s:>5s} {c.shear_force.sum() / capacity:20.9f} "
                  f"{np.abs(sol.u[0] - tied).max() / S:17.1e} {slipping:8d} of {len(c.x):<3d}  {sol.info.finish}")
    return results


def figure(results):
    """The slip along the floor for each threshold, Tresca (lines) and Coulomb (markers)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    for g, colour in zip(THRESHOLDS, ("C0", "C1", "C2")):
        for name, style in (("tresca", "-"), ("coulomb", "o")):
            c = results[name, g].contact
            label = f"Tresca g = {g / 1e6:g} MPa" if name == "tresca" else f"Coulomb mu = {g / P:g}"
            ax.plot(c.x, c.slip * 1e6, style, color=colour, mfc="none", label=label)
    ax.set(xlabel="x on the floor (m)", ylabel="slip [u_t] (um)",
           title="A pushed block: sliding, partly sticking, stuck")
    ax.legend(fontsize="small")
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 8))
    plt.show()
