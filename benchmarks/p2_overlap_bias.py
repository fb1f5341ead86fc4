"""Study: the bias of the 2D P2 rows' weights under "sigma1" where the overlap's end cuts a segment of the trace
(docs/formulation.md §10, "P2"; docs/refusals.md row 4). An upper block on [0, 1] (n cells, h = 1/n) over a lower one
on [lo, 1], lo = h + t h/2: the overlap begins t half-pieces past the upper trace's vertex h. The relative errors of
sum_i w_i f(x_i) against the exact integral over the overlap, for f = 1 + 2 x (the force of a tilted interference)
and f = x (1 + 2 x) (its moment), and the centre of pressure's error (m); the node outside moves its share half a
segment inward (closed form h^2 (1 - t)^2 / 8 times f's slope: tests/test_p2_overlap_tilt.py), so the errors fall
like h^2. No solve: the weights alone (a soft law's solve presses exactly these, to the springs' 1e-7).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/p2_overlap_bias.py

Results: benchmarks/results/p2_overlap_bias.md.
"""

from __future__ import annotations

import numpy as np

import cvxcontact as cc
from cvxcontact.contact.quadratic import quadratic_interface
from cvxcontact.geometry.quadratic import P2Nodes

MAT = cc.materials.isotropic(E=1e9, nu=0.0)


def weights(n, lo):
    """The rows' abscissae and weights under "sigma1" of the upper block (n cells on [0, 1]) over [lo, 1]."""
    b1 = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=n, ny=1), MAT, clamped=["top"], contact="bottom")
    b2 = cc.Body(cc.rectangle(x=(lo, 1), y=(-0.5, 0), nx=max(1, n // 2 + 1), ny=1), MAT, clamped=["bottom"],
                 contact="top")
    scene = cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=-1e-5)])
    itf = quadratic_interface(scene, [P2Nodes(b.mesh) for b in scene.bodies])
    return np.asarray(itf.sigma_x[0]), itf.weights("sigma1")


def main():
    print(f"{'t':>4s} {'n':>4s} {'force':>10s} {'moment':>10s} {'centre (m)':>11s} {'rate F':>6s} {'rate M':>6s}")
    for t in (0.3, 0.75, 1.5):
        prev = None
        for n in (4, 8, 16, 32, 64, 128):
            h = 1.0 / n
            lo = h + t * h / 2
            x, w = weights(n, lo)
            force = (1 - lo) + (1 - lo ** 2)
            moment = (1 - lo ** 2) / 2 + 2 * (1 - lo ** 3) / 3
            ef = w @ (1 + 2 * x) / force - 1
            em = w @ (x * (1 + 2 * x)) / moment - 1
            ec = w @ (x * (1 + 2 * x)) / (w @ (1 + 2 * x)) - moment / force
            rates = (f"{np.log2(prev[0] / ef):6.2f} {np.log2(prev[1] / em):6.2f}" if prev else f"{'':6s} {'':6s}")
            print(f"{t:4.2f} {n:4d} {ef:10.3e} {em:10.3e} {ec:11.3e} {rates}")
            prev = (ef, em)


if __name__ == "__main__":
    main()
