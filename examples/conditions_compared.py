"""The three contact conditions on strongly non-matching meshes.
=============================================================

The upper PZT-5A block has ``n`` cells on the contact line, the lower aluminium block
``n // 6 + 1``: about six upper nodes per lower segment, and the two node sets are
not nested. Non-penetration is imposed

* ``gamma3``: everywhere on Gamma_3, i.e. at every node of the merged mesh (K_h(Gamma_3)),
* ``sigma1``: at the nodes of the fine upper mesh (K_h(Sigma_h^1)),
* ``sigma2``: at the nodes of the coarse lower mesh (K_h(Sigma_h^2)).

Look at: ``gamma3`` and ``sigma1`` give nearly the same contact force; ``sigma2``
constrains only the few coarse nodes, so the fine upper trace penetrates the coarse
one between them (the largest jump is positive) and less force is transmitted. The
oscillation of lambda_h on the merged mesh (total variation relative to the
smoothest of the three) differs strongly between the conditions.

Run:  python examples/conditions_compared.py [n] [OUTDIR]   (OUTDIR: writes contact.png)
"""

import sys

import numpy as np

import cvxcontact as cc


def build(n=48):
    upper = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n, ny=max(2, n // 4))
    lower = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=n // 6 + 1, ny=max(2, n // 12))
    b1 = cc.Body(upper, cc.materials.PZT5A, clamped="top", grounded="top", contact="bottom",
                 body_force=lambda x, y: (0 * x, -3e9 * np.exp(-((x - 0.4) / 0.2) ** 2)),
                 surface_charge={"left": -0.03})
    b2 = cc.Body(lower, cc.materials.isotropic(E=70e9, nu=0.33), clamped="bottom", contact="top")
    return cc.Scene(b1, b2)


def main(n=48, out=None):
    scene = build(n)
    sols = {c: cc.solve(scene, c) for c in cc.CONDITIONS}
    tv = {c: np.abs(np.diff(s.contact.lam)).sum() for c, s in sols.items()}
    ref = min(tv.values())
    print(f"{'condition':10s} {'active':>7s} {'force [N/m]':>14s} {'TV(lambda)/min':>15s} {'max jump [m]':>13s}")
    for c, s in sols.items():
        k = s.contact
        print(f"{c:10s} {int(k.active.sum()):7d} {k.force.sum():14.6e} {tv[c] / ref:15.3f} {k.jump.max():13.3e}")
    if out:
        import matplotlib

        matplotlib.use("Agg")
        from pathlib import Path

        from cvxcontact.io.plot import plot_contact

        Path(out).mkdir(parents=True, exist_ok=True)
        plot_contact(sols).savefig(Path(out) / "contact.png", dpi=120)
        print("wrote", Path(out) / "contact.png")
    return sols


def figure(sols):
    """The contact along Gamma_3 for the three conditions (cvxcontact.io.plot.plot_contact)."""
    from cvxcontact.io.plot import plot_contact

    return plot_contact(sols)


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 48, sys.argv[2] if len(sys.argv) > 2 else None))
    plt.show()
