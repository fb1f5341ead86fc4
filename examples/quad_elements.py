"""Quadrilaterals: Q1 and Q2 against P1 and P2 on one contact scene.
=================================================================

A steel block 1 m x 0.5 m, clamped at its bottom, is indented by a rigid circle of radius 10 m pressed 1 mm into
its top. The block is meshed with triangles (``cc.rectangle(...)``) and with quadrilaterals
(``cc.rectangle(..., cell="quad")``) on the same n by n/2 grid, and solved at ``degree=1`` (P1, Q1: linear and
bilinear) and ``degree=2`` (P2, Q2: quadratic and biquadratic) (docs/tutorials/quadrilaterals.md,
docs/howto/quadrilaterals.md).

Look at: the total contact force of the four elements, against a fine P2 reference (n = REFERENCE): from n = 16
on every element is within 5 % of it and within 0.5 % at n = 32, and at n = 32 Q2 and P2 agree with each other to
about 0.1 %. The errors do not fall steadily: the ends of the contact zone (where the
pressure drops like a square root) cross the nodes as n grows, which limits the linear and quadratic elements
alike; on a smooth solution the quadratic ones gain (docs/howto/quadrilaterals.md). Every answer is solved with
the nodal condition "sigma1" (the obstacle's rows at the body's trace nodes), finished exactly for P2 and Q2.

Run:  python examples/quad_elements.py [n ...]
"""

import sys

import numpy as np

import cvxcontact as cc

RADIUS, DEPTH = 10.0, 1e-3                          # m
ELEMENTS = {"P1": ("triangle", 1), "Q1": ("quad", 1), "P2": ("triangle", 2), "Q2": ("quad", 2)}
REFERENCE = 48                                       # the reference: P2 on REFERENCE by REFERENCE/2 cells


def build(n=8, cell="triangle"):
    """The block on n by n/2 cells of the given shape, the circle pressed DEPTH into its top at x = 0.5."""
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n, ny=max(1, n // 2), cell=cell)
    b = cc.Body(m, cc.materials.isotropic(E=200e9, nu=0.3), clamped=["bottom"], contact="top")
    circle = cc.Rigid.circle(center=(0.5, 0.5 + RADIUS - DEPTH), radius=RADIUS)
    return cc.Scene(b, contacts=[cc.Contact(b, "top", circle)])


def force(n, element):
    """(total contact force (N/m), unknowns (displacement components), solution) of ``element`` on n cells."""
    cell, degree = ELEMENTS[element]
    sol = cc.solve(build(n, cell), "sigma1", degree=degree)   # nodal: the exact finish for P2 and Q2
    assert sol.ok, sol.report()
    return sol.contact.force.sum(), sol.u[0].size, sol


def main(sizes=(16, 32), reference=REFERENCE):
    """{element: [(n, unknowns, force), ...]} and the reference force under "reference"."""
    F_ref = force(reference, "P2")[0]
    print(f"reference: P2 on {reference} x {reference // 2} cells, F = {F_ref / 1e6:.6f} MN/m")
    print(f"{'element':>7s} {'n':>4s} {'unknowns':>9s} {'F [MN/m]':>11s} {'|F - F_ref| / F_ref':>20s}")
    results = {"reference": F_ref}
    for element in ELEMENTS:
        results[element] = []
        for n in sizes:
            F, dofs, _ = force(n, element)
            results[element].append((n, dofs, F))
            print(f"{element:>7s} {n:4d} {dofs:9d} {F / 1e6:11.6f} {abs(F - F_ref) / F_ref:20.2e}")
    return results


def figure(results):
    """The relative force error of each element against its number of unknowns."""
    import matplotlib.pyplot as plt

    F_ref = results["reference"]
    fig, ax = plt.subplots(figsize=(6.5, 4), layout="constrained")
    for element, marker in zip(ELEMENTS, "os^v"):
        rows = np.array(results[element])
        ax.loglog(rows[:, 1], np.abs(rows[:, 2] - F_ref) / F_ref, marker + "-", mfc="none", label=element)
    ax.set(xlabel="unknowns (displacement components)", ylabel="|F - F_ref| / F_ref",
           title="Contact force of a pressed circle: triangles and quadrilaterals")
    ax.legend()
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(tuple(int(n) for n in sys.argv[1:]) or (16, 32)))
    plt.show()
