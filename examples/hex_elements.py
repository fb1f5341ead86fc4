"""Hexahedra: Q1 and Q2 against P1 and P2 tetrahedra on one 3D contact scene.
============================================================================

A steel block 1 m x 1 m x 0.5 m, clamped at its bottom, is indented by a rigid sphere of radius 50 m pressed 1 mm
into the middle of its top. The block is meshed with tetrahedra (``cc.box(...)``) and with hexahedra
(``cc.box(..., cell="hex")``) on the same n by n by n/2 grid, and solved at ``degree=1`` (P1 tetrahedra, Q1
trilinear hexahedra) and ``degree=2`` (P2 10-node tetrahedra, Q2 27-node triquadratic hexahedra)
(docs/howto/quadrilaterals.md).

Look at: the total contact force of the four elements against a fine P2 reference (n = REFERENCE). The sphere
crosses the top on a circle of radius sqrt(2 R d) = 0.32 m, a few cells across: the linear elements are 11 to 15 %
off at n = 4 and 3 to 6 % at n = 8, the quadratic ones within 1.5 % at both, nearer the reference than the linear
ones on the same grid. P1 and Q1 (P2 and Q2) have the same nodes on the same grid. Every answer is solved with the
nodal condition "sigma1" (the obstacle's rows at the block's nodes), finished exactly.

Run:  python examples/hex_elements.py [n ...]
"""

import sys

import numpy as np

import cvxcontact as cc

RADIUS, DEPTH = 50.0, 1e-3                          # m
ELEMENTS = {"P1": ("tetra", 1), "Q1": ("hex", 1), "P2": ("tetra", 2), "Q2": ("hex", 2)}
REFERENCE = 12                                       # the reference: P2 on REFERENCE^2 x REFERENCE/2 cells


def build(n=4, cell="tetra"):
    """The block on n by n by n/2 cells of the given shape, the sphere pressed DEPTH into its top's centre."""
    m = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=max(1, n // 2), cell=cell)
    b = cc.Body(m, cc.materials.isotropic(E=200e9, nu=0.3), clamped=["bottom"], contact="top")
    sphere = cc.Rigid.sphere(center=(0.5, 0.5, 0.5 + RADIUS - DEPTH), radius=RADIUS)
    return cc.Scene(b, contacts=[cc.Contact(b, "top", sphere)])


def force(n, element):
    """(total contact force (N), unknowns (displacement components), solution) of ``element`` on n cells."""
    cell, degree = ELEMENTS[element]
    sol = cc.solve(build(n, cell), "sigma1", degree=degree)
    assert sol.ok, sol.report()
    return sol.contact.force.sum(), sol.u[0].size, sol


def main(sizes=(4, 8), reference=REFERENCE):
    """{element: [(n, unknowns, force), ...]} and the reference force under "reference"."""
    F_ref = force(reference, "P2")[0]
    print(f"reference: P2 on {reference} x {reference} x {reference // 2} cells, F = {F_ref / 1e6:.6f} MN")
    print(f"{'element':>7s} {'n':>4s} {'unknowns':>9s} {'F [MN]':>11s} {'|F - F_ref| / F_ref':>20s}")
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
           title="Contact force of a pressed sphere: tetrahedra and hexahedra")
    ax.legend()
    return fig


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(tuple(int(n) for n in sys.argv[1:]) or (4, 8)))
    plt.show()
