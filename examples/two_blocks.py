"""Two blocks in partial contact: a PZT-5A block pressed onto an aluminium foundation.
===================================================================================

The upper block (PZT-5A, poled along +y) is clamped and grounded on its top edge,
pulled down by its weight-like body force, sheared by a traction on its right edge
and charged on its left edge. The lower block (aluminium) is clamped at its bottom.
The meshes do not match on the contact line y = 0 (16 vs 11 cells).

For each non-penetration condition (paper: K_h(Gamma_3), K_h(Sigma_h^1),
K_h(Sigma_h^2)) it prints the checks of the mixed formulation (26)-(27) and the
active contact set. Look at: the active sets differ slightly between the
conditions, and lambda_h on the merged mesh oscillates for sigma1/sigma2 while
the nodal forces stay non-negative.

Run:  python examples/two_blocks.py [nx]
"""

import sys

import numpy as np

import cvxcontact as cc


def build(nx=16):
    """The scene: upper mesh nx by nx/2 cells, lower mesh about 0.7 nx cells wide."""
    nx2 = max(2, round(0.7 * nx))
    upper = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=max(1, nx // 2))
    lower = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=nx2, ny=max(1, nx2 // 2))
    b1 = cc.Body(upper, cc.materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom",
                 body_force=(0.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05})
    b2 = cc.Body(lower, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2)


def main(nx=16):
    scene = build(nx)
    results = {}
    for condition in cc.CONDITIONS:
        sol = cc.solve(scene, condition=condition)
        results[condition] = sol
        c = sol.contact
        print(sol.report())
        xa = c.x[c.active]
        print(f"  active set: {len(xa)} nodes, x in [{xa.min():.4f}, {xa.max():.4f}] m" if len(xa) else
              "  active set: empty")
        print(f"  total contact force {c.force.sum():.6e} N/m, max |u| {np.abs(sol.u[0]).max():.6e} m, "
              f"max |phi| {np.abs(sol.phi[0]).max():.6e} V\n")
    return results


def figure(results):
    """The contact along Gamma_3 for the three conditions (cvxcontact.io.plot.plot_contact)."""
    from cvxcontact.io.plot import plot_contact

    return plot_contact(results)


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 16))
    plt.show()
