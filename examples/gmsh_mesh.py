"""A gmsh-generated geometry read through meshio: a PZT-4 block with a hole on an elastic base.
============================================================================================

``examples/meshes/upper_hole.msh`` (a 1 m x 0.5 m block with a circular hole of radius
0.12 m) and ``examples/meshes/lower.msh`` (a 1 m x 0.4 m base) were made with gmsh; their
physical line names ("top", "bottom", "sides", "hole") become boundary tags. The two
unstructured meshes do not match on the contact line y = 0.

The block is clamped and grounded on top and carries a downward body force; the hole's
surface carries a negative charge, which couples into the mechanics.

Look at: the residual report, the contact pressure along the line (peak and where it
sits), and the stress around the hole in ParaView (``gmsh_body1.vtu``).

Run:  python examples/gmsh_mesh.py [OUTDIR]     (writes VTU files for ParaView into OUTDIR)
"""

import sys
from pathlib import Path

import numpy as np

import cvxcontact as cc

# the folder of this script (the documentation build runs it from there, without __file__)
MESHES = Path(globals().get("__file__", "gmsh_mesh.py")).resolve().parent / "meshes"


def build():
    upper, lower = cc.read_mesh(MESHES / "upper_hole.msh"), cc.read_mesh(MESHES / "lower.msh")
    b1 = cc.Body(upper, cc.materials.PZT4, clamped="top", grounded="top", contact="bottom",
                 body_force=(0.0, -5e8), surface_charge={"hole": -0.02}, name="PZT-4 block with hole")
    b2 = cc.Body(lower, cc.materials.isotropic(E=200e9, nu=0.3, name="steel"), clamped="bottom", contact="top",
                 name="steel base")
    return cc.Scene(b1, b2)


def main(out=None):
    scene = build()
    for b in scene.bodies:
        print(f"{b.name}: {len(b.mesh.points)} nodes, {len(b.mesh.triangles)} triangles, tags {sorted(b.mesh.tags)}")
    sol = cc.solve(scene, "gamma3")
    print(sol.report())
    c = sol.contact
    print(f"peak nodal pressure {c.pressure.max():.4e} Pa at x = {c.x[np.argmax(c.pressure)]:.3f} m; "
          f"total contact force {c.force.sum():.6e} N/m")
    if out:
        from cvxcontact.io.output import write_all

        for path in write_all(sol, out, stem="gmsh"):
            print("wrote", path)
    return sol


def figure(sol):
    """The deformed bodies coloured by the von Mises stress (cvxcontact.io.plot.plot_deformed)."""
    from cvxcontact.io.plot import plot_deformed

    return plot_deformed(sol, "von_mises")


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    figure(main(sys.argv[1] if len(sys.argv) > 1 else None))
    plt.show()
