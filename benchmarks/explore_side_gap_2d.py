"""Exploration: the 2D complementarity of obstacles sharing one part, read pair by pair (the package) or once on the
side (lambda_h summed over the pairs, g - [u_h nu] the least over the pairs at each node of the trace, as 3D's
``contactestimate._side_gap_terms``; the prototype of 2D's ``_side_line_terms``, which the package now reads: its
"pair by pair" column is then the side's), against one obstacle of the same answer.

Scenes (the 6 x 2 block of tests/reach_scenes.block2d under "sigma1", P1 and P2):

* ``kink``: a floor x >= 0.3 and an obstacle at the floor up to x = 0.3, falling away by 1e-5 per m beyond (its
  run ends at x = 1/2); the one obstacle: a floor under the whole part (tests/test_p2_run_vertex.py);
* ``tilted split x = 0.4``, ``tilted strips + floor``: the line y = -4e-6 x split (tests/test_estimate_shared_part);
* ``raised over part``: a floor and the strip 0.3 <= x < 0.7 raised 3e-6 above it; the one obstacle: the raised
  floor (tests/test_parallel_obstacles.py).

Then the refinement of ``kink`` (``--nx``): the complementarity pair by pair as the floor's first vertex x_f nears 0.3.

Run:  OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD:$PWD/tests \
      python benchmarks/explore_side_gap_2d.py [--nx 6 10 12 24 48 96 192]
Results: benchmarks/results/explore_side_gap_2d.md.
"""

import argparse
import warnings

import numpy as np
from reach_scenes import block2d, line, lowered, raised

import cvxcontact as cc
from cvxcontact.solution.contactestimate import _GAUSS3, _line_at


def tilted(lo, hi):
    """The line y = -4e-6 x under lo <= x < hi (+inf off it)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return np.where((x[:, 0] >= lo) & (x[:, 0] < hi), x[:, 1] + 4e-6 * x[:, 0], np.inf)
    return cc.Rigid("tilted line", distance, f"the line y = -4e-6 x under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile([0.0, 1.0], (len(x), 1)), dim=2)


def side_complementarity(sol) -> float:
    """int lambda^+ (g - [u])^+ over the union of the pairs' lines, lambda the pairs' functions summed, g - [u] the
    least over the pairs at each node, interpolated on the union line (P1 or P2), by the estimate's 3-point rule."""
    least = {}
    for c in sol.contacts:
        for xi, oi in zip(np.asarray(c.x, float), np.asarray(c.gap, float) - np.asarray(c.jump, float)):
            k = round(float(xi), 9)
            least[k] = (least[k][0], min(least[k][1], oi)) if k in least else (xi, oi)
    keys = sorted(least)
    x, gap = np.array([least[k][0] for k in keys]), np.array([least[k][1] for k in keys])
    trace = sol.contacts[0].trace
    v = trace.vertices(x)
    a, h = v[:-1], np.diff(v)
    lines = [sol._pair_line(i).support(c.lam) for i, c in enumerate(sol.contacts)]
    comp = np.zeros(len(a))
    for t, w in zip(*_GAUSS3):
        s = a + t * h
        lam = sum(_line_at(c, xl, lv, s) for c, (xl, lv) in zip(sol.contacts, lines))
        comp += w * np.maximum(lam, 0.0) * np.maximum(trace.values(x, gap, s), 0.0)
    return float((comp * h).sum())


SCENES = {
    "kink": ((line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3)), (line(-1.0, 2.0),)),
    "tilted split x = 0.4": ((tilted(-1.0, 0.4), tilted(0.4, 2.0)), (tilted(-1.0, 2.0),)),
    "tilted strips + floor": ((tilted(-1.0, 0.7), tilted(0.3, 2.0), tilted(-1.0, 2.0)), (tilted(-1.0, 2.0),)),
    "raised over part": ((line(-1.0, 2.0), lowered(0.3, 0.7, 2, drop=-3e-6)), (raised(0.3, 0.7, 2, 3e-6),)),
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nx", type=int, nargs="*", default=[6, 10, 12, 24, 48, 96, 192])
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    print("| scene | degree | norm^2 | eta^2 pairs | eta^2 one obstacle | complementarity: pair by pair | on the side "
          "| one obstacle |\n|---|---|---:|---:|---:|---:|---:|---:|")
    for name, (pairs, one) in SCENES.items():
        for degree in (1, 2):
            two, single = (cc.solve(block2d(s), "sigma1", degree=degree) for s in (pairs, one))
            e2, e1 = two.estimate, single.estimate
            print(f"| {name} | P{degree} | {e2.norm ** 2:.4g} | {sum(e2.parts.values()):.4g} | "
                  f"{sum(e1.parts.values()):.4g} | {e2.parts['complementarity']:.4g} | "
                  f"{side_complementarity(two):.3g} | {e1.parts['complementarity']:.3g} |", flush=True)
    print("\n| degree | nx | x_f | ok | the one floor's u | complementarity (of norm^2) | penetration "
          "| contact traction |\n|---|---:|---:|---|---:|---:|---:|---:|")
    pairs, one = SCENES["kink"]
    for degree in (1, 2):
        for nx in args.nx:
            two, single = (cc.solve(block2d(s, nx=nx), "sigma1", degree=degree) for s in (pairs, one))
            e = two.estimate
            du = np.abs(two.u[0] - single.u[0]).max() / np.abs(single.u[0]).max()
            xf = np.asarray(two.contacts[0].points)[0, 0]
            print(f"| P{degree} | {nx} | {xf:.5f} | {two.ok} | {du:.1e} | {e.parts['complementarity']:.4g} "
                  f"({e.parts['complementarity'] / e.norm ** 2:.3g}) | {e.parts['penetration']:.3g} | "
                  f"{e.parts['contact traction']:.2g} |", flush=True)


if __name__ == "__main__":
    main()
