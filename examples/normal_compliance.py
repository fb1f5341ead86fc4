"""Normal compliance (the paper's (7), (19)) on the quickstart scene, and its limit k -> infinity.
===============================================================================================

The PZT-5A block of the quickstart pressed onto the aluminium block, with the contact law
lambda = p(r) = k r_+^m (r = [u_nu] - g, the penetration) instead of Signorini. For the linear
(m = 1) and the quadratic (m = 2) law and growing stiffness k it prints the checks, the largest
penetration and the distance to the Signorini solution of the same scene::

    e_u = max |u_k - u_S| / max |u_S|  (both bodies),    e_lam = max |F_k - F_S| / max |F_S|

(F the nodal contact forces on the merged nodes, N/m), and the rate of e_u in k from the last
two stiffnesses. Expected: penetration ~ (lambda / k)^(1/m), so O(1/k) for m = 1 and O(k^(-1/2))
for m = 2. Look at: the penetration shrinks, the checks stay at rounding (exact finish), and
e_u follows the penetration.

Run:  python examples/normal_compliance.py [nx]
"""

import sys

import numpy as np

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks


def distance(sol, ref):
    """(e_u, e_lam) of the module docstring."""
    du = max(np.abs(a - b).max() for a, b in zip(sol.u, ref.u)) / max(np.abs(b).max() for b in ref.u)
    df = np.abs(sol.contact.force - ref.contact.force).max() / np.abs(ref.contact.force).max()
    return float(du), float(df)


def main(nx=16, stiffnesses=None):
    """Returns {m: [(k, e_u, e_lam, max penetration, solution)]} and prints the table and rates."""
    scene = two_blocks(nx)                # the quickstart scene (cvxcontact.apps.demo)
    ref = cc.solve(scene)
    print(f"Signorini: {ref.report().splitlines()[0]}")
    out = {}
    for m, ks in (stiffnesses or {1: [1e12, 1e13, 1e14, 1e15, 1e16], 2: [1e17, 1e19, 1e21, 1e23, 1e25]}).items():
        rows = []
        print(f"\nm = {m}:  k [Pa/m^{m}]   e_u        e_lam      max r [m]   worst check")
        for k in ks:
            sol = cc.solve(scene, law=cc.NormalCompliance(stiffness=k, exponent=m))
            e_u, e_lam = distance(sol, ref)
            pen = float((sol.contact.jump - sol.contact.gap).max())
            rows.append((k, e_u, e_lam, pen, sol))
            print(f"       {k:9.1e}   {e_u:.3e}  {e_lam:.3e}  {pen:.3e}   {max(sol.residuals().values()):.1e}"
                  f"{'' if sol.ok else '  FAILED'}")
        (k0, e0, *_), (k1, e1, *_) = rows[-2], rows[-1]
        print(f"  rate of e_u in k (last two): {np.log(e0 / e1) / np.log(k1 / k0):.3f}   (expected {1 / m:.3f})")
        out[m] = rows
    return out


def figure(out):
    """e_u and the largest penetration against the stiffness k, for each exponent m (log-log)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(out), figsize=(5 * len(out), 4), layout="constrained", squeeze=False)
    for ax, (m, rows) in zip(axes[0], out.items()):
        k = [r[0] for r in rows]
        ax.loglog(k, [r[1] for r in rows], "o-", label="e_u: distance to Signorini (relative)")
        ax.loglog(k, [r[3] for r in rows], "s--", label="largest penetration r [m]")
        ax.set(xlabel=f"stiffness k [Pa/m^{m}]", title=f"law p(r) = k r^{m}: rate 1/m = {1 / m:g} expected")
        ax.legend(fontsize=8)
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(int(sys.argv[1]) if len(sys.argv) > 1 else 16))
    plt.show()
