"""Same bits where pairs share a contact part (h-tidy4, contact/sides.py; its review r-tidy4): a sha256 (16 hex
digits) of u, every pair's lambda_h, [u_nu], forces, active set and t_h, the checks, the energy, the estimate (its
parts and indicators) and every warning (category, text, line) of each scene below, with the package of the tree
``--tree`` (default: this one). Run it on two trees and compare the outputs line by line: a refactor of how pairs
are grouped by side must print the same lines.

Scenes: obstacles on strips and lines overlapping on one part (2D/3D, P1/P2/Q1/Q2, Tresca, Coulomb, compliance
beside Signorini, open at a node, untouched), boxes on and under two or three boxes, a body pair and obstacles on
one part, 2D blocks on two blocks posed from either side (P1/P2, piezoelectric), two bodies each on overlapping
lines with their pairs interleaved, stacks of three bodies (2D/3D), ``with_loads``, ``cc.Model``, ``cc.adapt``,
Body objects shared by two scenes in another order, a prepared ``ContactSolver`` re-solved.

Run (one thread; each tree's tests/ fixtures are read):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/sides_same_bits.py --tree OLD > a
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/sides_same_bits.py > b; diff a b
"""

import argparse
import hashlib
import sys
import warnings
from itertools import pairwise
from pathlib import Path

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--tree", default=str(Path(__file__).resolve().parent.parent), help="source tree of cvxcontact")
parser.add_argument("only", nargs="?", default="", help="run the scenes whose name contains this")
args = parser.parse_args()
sys.path[:0] = [args.tree, str(Path(args.tree) / "tests")]

import numpy as np
from conftest import two_blocks
from friction_scenes import (
    FLOOR,
    P,
    dragged_stack,
    pushed,
    steel,
    uniform_layer,
    uniform_layer3d,
    uniform_stack,
    uniform_stack3d,
)
from reach_scenes import block2d, block3d, box_on_boxes, line, lowered, strip
from scenes3d import pzt_on_block
from stack_scenes import three_blocks_3d

import cvxcontact as cc

G = 2 * P
L2 = (line(-1.0, 0.7), line(0.3, 2.0), line(-1.0, 2.0))
S3 = (strip(-1.0, 0.7), strip(0.3, 2.0), strip(-1.0, 2.0))
PZT = cc.materials.PZT5A


def compliance_beside():
    body = block2d((line(-1.0, 0.7),)).bodies[0]
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", line(-1.0, 0.7)),
                                    cc.Contact(body, "bottom", line(0.3, 2.0), law=cc.NormalCompliance(1e12))])


def boxes_under_box():
    """box_on_boxes with each pair posed from the lower box: the upper box's bottom each pair's second side."""
    s = box_on_boxes()
    return cc.Scene(*s.bodies, contacts=[cc.Contact(c.other, c.part_b, c.body_a, c.part_a) for c in s.contacts])


def obstacle_beside_body():
    """The 3 x 3 x 1 box on a lower box under x < 0.4 and a strip x >= 0.4: a two-body pair and an obstacle on
    one part."""
    s = box_on_boxes()
    top, low = s.bodies[0], s.bodies[1]
    return cc.Scene(top, low, contacts=[cc.Contact(top, "bottom", low, "top"), cc.Contact(top, "bottom",
                                                                                          strip(0.4, 2.0))])


def blocks2d(flip=False, law=None, extra=(), lows=(0.4,), mat=None):
    """A 2D block [0,1]x[0,0.5] pressed down (body force) onto lower blocks split at ``lows``, each clamped at its
    base; ``flip``: each pair posed from the lower block; ``extra``: obstacles on the upper block's bottom too."""
    top = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=5, ny=2), mat or steel(), clamped="top",
                  contact="bottom", body_force=(0.0, -2e9), traction={"right": (0.0, 1e8)}, name="upper",
                  **({"grounded": ["top"], "surface_charge": {"left": -0.05}} if mat is not None else {}))
    edges = (0.0, *lows, 1.0)
    lower = [cc.Body(cc.rectangle(x=(a, b), y=(-0.5, 0.0), nx=max(1, round(7 * (b - a))), ny=2), steel(),
                     clamped="bottom", contact="top", name=f"lower {i}") for i, (a, b) in enumerate(pairwise(edges))]
    pairs = [cc.Contact(lo, "top", top, "bottom", gap=-1e-5, law=law) if flip else
             cc.Contact(top, "bottom", lo, "top", gap=-1e-5, law=law) for lo in lower]
    pairs += [cc.Contact(top, "bottom", o, law=cc.Tresca(G) if law is None else law, gap=-1e-5) for o in extra]
    return cc.Scene(top, *lower, contacts=pairs)


def two_bodies_interleaved(law=None):
    """Two separate blocks, each on two overlapping Tresca lines, the pairs interleaved A, B, A, B: two
    overlapping sides in one problem, the candidates' order not the sides'."""
    def blk(x0, name):
        return cc.Body(cc.rectangle(x=(x0, x0 + 1.0), y=(0.0, 0.5), nx=4, ny=2), steel(nu=0.0), contact="bottom",
                       traction={"top": (0.2 * P, -P), "left": (0.0, -0.2 * P), "right": (0.0, 0.2 * P)}, name=name)
    a, b = blk(0.0, "A"), blk(3.0, "B")
    law = law or cc.Tresca(G)
    return cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", line(-1.0, 0.7), law=law),
                                    cc.Contact(b, "bottom", line(2.0, 3.7), law=law),
                                    cc.Contact(a, "bottom", line(0.3, 2.0), law=law),
                                    cc.Contact(b, "bottom", line(3.3, 5.0), law=law)])


def box_and_strips(law=None):
    """box_on_boxes' upper box on its first lower box (x < 0.4) and on two strips x >= 0.3 and x >= 0.6 (``law``):
    a two-body pair and obstacles on one part, the obstacles overlapping."""
    s = box_on_boxes()
    top, low = s.bodies[0], s.bodies[1]
    return cc.Scene(top, low, contacts=[cc.Contact(top, "bottom", strip(0.3, 2.0), law=law),
                                        cc.Contact(top, "bottom", low, "top"),
                                        cc.Contact(top, "bottom", strip(0.6, 2.0), law=law)])


def flipped(s):
    return cc.Scene(*s.bodies, contacts=[cc.Contact(c.other, c.part_b, c.body_a, c.part_a) for c in s.contacts])


def model(scene, condition, **kw):
    return cc.Model(scene, condition=condition, **kw).solve()


def reordered(s):
    """The same Body and Contact objects, both in reverse order (each body's index changes)."""
    return cc.Scene(*reversed(s.bodies), contacts=list(reversed(s.contacts)))


def both(make, **kw):
    s1 = make()
    cc.solve(s1, **kw)
    return cc.solve(reordered(s1), **kw)


def resolved(make, k, **loads):
    s = make()
    solver = cc.ContactSolver(s, "sigma1")
    solver.solve()
    return solver.solve(s.with_loads(k, **loads))


CASES = {
    "boxes under a box P1 gamma3": lambda: cc.solve(boxes_under_box(), "gamma3", degree=1),
    "boxes under a box P2 gamma3": lambda: cc.solve(boxes_under_box(), "gamma3", degree=2),
    "obstacle beside a body P1": lambda: cc.solve(obstacle_beside_body(), "gamma3", degree=1),
    "box on two boxes P1 gamma3": lambda: cc.solve(box_on_boxes(), "gamma3", degree=1),
    "box on two boxes P2 gamma3": lambda: cc.solve(box_on_boxes(), "gamma3", degree=2),
    "box on three boxes P1 gamma3": lambda: cc.solve(box_on_boxes(cuts=(0.3, 0.7)), "gamma3", degree=1),
    "2d block on 3 lines P1": lambda: cc.solve(block2d(L2), "sigma1", degree=1),
    "2d block on 3 lines P2": lambda: cc.solve(block2d(L2), "sigma1", degree=2),
    "3d block on 3 strips P1": lambda: cc.solve(block3d(S3), "sigma1", degree=1),
    "3d block on 3 strips P2": lambda: cc.solve(block3d(S3), "sigma1", degree=2),
    "3d hex block on 3 strips P1": lambda: cc.solve(block3d(S3, cell="hex"), "sigma1", degree=1),
    "2d floor + untouched P1": lambda: cc.solve(block2d((line(-1.0, 2.0), lowered(-1.0, 0.6, 2))), "sigma1", degree=1),
    "2d floor + untouched P2": lambda: cc.solve(block2d((line(-1.0, 2.0), lowered(-1.0, 0.6, 2))), "sigma1", degree=2),
    "3d floor + untouched P2": lambda: cc.solve(block3d((strip(-1.0, 2.0), lowered(-1.0, 0.6, 3))), "sigma1", degree=2),
    "2d open at a node P1": lambda: cc.solve(block2d((line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3))), "sigma1"),
    "3d open at a node P1": lambda: cc.solve(block3d((strip(0.3, 2.0), lowered(-1.0, 0.6, 3, kink=0.3))), "sigma1"),
    "3d open at a node P2": lambda: cc.solve(block3d((strip(0.3, 2.0), lowered(-1.0, 0.6, 3, kink=0.3))), "sigma1",
                                             degree=2),
    "2d Tresca layer on 3 lines": lambda: cc.solve(uniform_layer(0.2 * P, cc.Tresca(G), obstacles=L2), "sigma1"),
    "2d Coulomb layer on 3 lines": lambda: cc.solve(uniform_layer(0.2 * P, cc.Coulomb(0.5), obstacles=L2), "sigma1"),
    "2d Tresca two floors pushed": lambda: cc.solve(pushed(cc.Tresca(G), obstacles=(FLOOR, cc.Rigid.plane(
        point=(0.0, 0.0), normal=(0.0, 1.0))))[1], "sigma1"),
    "3d Tresca layer on 3 strips P1": lambda: cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(G), n=3, obstacles=S3),
                                                       "sigma1"),
    "3d Tresca layer on 3 strips P2": lambda: cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(G), n=3, obstacles=S3),
                                                       "sigma1", degree=2),
    "3d Coulomb layer on 3 strips P2": lambda: cc.solve(uniform_layer3d(0.2 * P, cc.Coulomb(0.5), n=3,
                                                                        obstacles=S3), "sigma1", degree=2),
    "3d Tresca strip open everywhere P2": lambda: cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(G), n=3, obstacles=(
        lowered(-1.0, 0.5, 3), strip(-1.0, 2.0))), "sigma1", degree=2),
    "compliance beside Signorini": lambda: cc.solve(compliance_beside(), "sigma1"),
    "3d stack P1": lambda: cc.solve(uniform_stack3d(0.05 * P, cc.Tresca(G)), "sigma1"),
    "2d Tresca layer on 3 lines P2": lambda: cc.solve(uniform_layer(0.2 * P, cc.Tresca(G), obstacles=L2), "sigma1",
                                                      degree=2),
    "3d hex Tresca layer on 3 strips P1": lambda: cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(G), n=3, cell="hex",
                                                                           obstacles=S3), "sigma1"),
    "3d hex block on 3 strips Q2": lambda: cc.solve(block3d(S3, cell="hex"), "sigma1", degree=2),
    "adapt 2d Tresca layer on 3 lines": lambda: cc.adapt(uniform_layer(0.2 * P, cc.Tresca(G), obstacles=L2),
                                                         "sigma1", max_steps=2).solution,
    "2d block on 2 blocks P1 gamma3": lambda: cc.solve(blocks2d(), "gamma3"),
    "2d block on 2 blocks P1 sigma1": lambda: cc.solve(blocks2d(), "sigma1"),
    "2d block on 3 blocks P2 sigma1": lambda: cc.solve(blocks2d(lows=(0.3, 0.7)), "sigma1", degree=2),
    "2d block on 2 blocks P2 sigma1": lambda: cc.solve(blocks2d(), "sigma1", degree=2),
    "2d blocks under a block P2 sigma2": lambda: cc.solve(blocks2d(flip=True), "sigma2", degree=2),
    "2d blocks under a block P1 sigma2": lambda: cc.solve(blocks2d(flip=True), "sigma2"),
    "2d blocks under a block P2 gamma3": lambda: cc.solve(blocks2d(flip=True), "gamma3", degree=2),
    "2d block on blocks Tresca P1": lambda: cc.solve(blocks2d(law=cc.Tresca(G)), "sigma1"),
    "2d body pair + 2 Tresca lines P1": lambda: cc.solve(blocks2d(lows=(0.4,), extra=(line(0.6, 2.0), line(0.5, 2.0))),
                                                         "sigma1"),
    "2d piezo block on 2 blocks P1": lambda: cc.solve(blocks2d(mat=PZT), "sigma1"),
    "2d piezo block on 2 blocks P2": lambda: cc.solve(blocks2d(mat=PZT, flip=True), "sigma2", degree=2),
    "2d piezo legacy two blocks P1": lambda: cc.solve(two_blocks((8, 4), (5, 3)), "sigma1"),
    "2d two sides interleaved Tresca P1": lambda: cc.solve(two_bodies_interleaved(), "sigma1"),
    "2d two sides interleaved Tresca P2": lambda: cc.solve(two_bodies_interleaved(), "sigma1", degree=2),
    "2d two sides interleaved with_loads": lambda: cc.solve(two_bodies_interleaved().with_loads(
        1, traction={"top": (0.1 * P, -P), "left": (0.0, -0.1 * P), "right": (0.0, 0.1 * P)}), "sigma1"),
    "2d uniform stack Tresca P1": lambda: cc.solve(uniform_stack(0.2 * P, cc.Tresca(G)), "sigma1"),
    "2d uniform stack Tresca P2": lambda: cc.solve(uniform_stack(0.2 * P, cc.Tresca(G)), "sigma1", degree=2),
    "2d dragged stack order 1,0": lambda: cc.solve(dragged_stack((cc.Tresca(0.1 * P), cc.Tresca(G)), order=(1, 0)),
                                                   "sigma1"),
    "2d dragged stack piezo middle": lambda: cc.solve(dragged_stack((cc.Tresca(0.1 * P), cc.Tresca(G)), middle={
        "material": PZT, "grounded": ["left"]}), "sigma1"),
    "model 2d block on 2 blocks": lambda: model(blocks2d(), "sigma1"),
    "model 2d two sides interleaved": lambda: model(two_bodies_interleaved(), "sigma1"),
    "model box on two boxes": lambda: model(box_on_boxes(), "gamma3"),
    "with_loads 2d block on 2 blocks": lambda: cc.solve(blocks2d().with_loads(0, body_force=(0.0, -3e9)), "sigma1"),
    "3d three blocks P2 sigma1": lambda: cc.solve(three_blocks_3d(("sigma1", "sigma2"), (None, None)), "sigma1",
                                                  degree=2),
    "3d pzt on block P1": lambda: cc.solve(pzt_on_block(cc.materials.isotropic(E=70e9, nu=0.3)), "sigma1"),
    "3d box on two boxes P1 sigma1": lambda: cc.solve(box_on_boxes(), "sigma1"),
    "3d box on two boxes flipped P1 sigma2": lambda: cc.solve(flipped(box_on_boxes()), "sigma2"),
    "3d box on two boxes P2 sigma1": lambda: cc.solve(box_on_boxes(), "sigma1", degree=2),
    "3d box on two boxes flipped P2 sigma2": lambda: cc.solve(flipped(box_on_boxes()), "sigma2", degree=2),
    "3d box on a box + 2 strips": lambda: cc.solve(box_and_strips(), "sigma1"),
    "3d box on a box + 2 Tresca strips P2": lambda: cc.solve(box_and_strips(cc.Tresca(G)), "sigma1", degree=2),
    "3d hex Tresca layer on 3 strips Q2": lambda: cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(G), n=2, cell="hex",
                                                                           obstacles=S3), "sigma1", degree=2),
    "adapt 2d block on 2 blocks": lambda: cc.adapt(blocks2d(), "sigma1", max_steps=2).solution,
    "adapt 2d two sides interleaved": lambda: cc.adapt(two_bodies_interleaved(), "sigma1", max_steps=2).solution,
    "shared bodies reordered 2d blocks": lambda: both(blocks2d, condition="sigma1"),
    "shared bodies reordered interleaved": lambda: both(two_bodies_interleaved, condition="sigma1"),
    "shared bodies reordered 3d box+strips": lambda: both(lambda: box_and_strips(cc.Tresca(G)), condition="sigma1"),
    "shared bodies reordered 3d boxes P2": lambda: both(box_on_boxes, condition="gamma3", degree=2),
    "resolved interleaved with_loads": lambda: resolved(two_bodies_interleaved, 1, traction={
        "top": (0.1 * P, -P), "left": (0.0, -0.1 * P), "right": (0.0, 0.1 * P)}),
    "resolved 2d blocks with_loads": lambda: resolved(blocks2d, 0, body_force=(0.0, -3e9)),
    "2d blocks Coulomb + lines": lambda: cc.solve(blocks2d(law=cc.Coulomb(0.3), extra=(line(0.6, 2.0),)), "sigma1"),
    "3d box + strips Coulomb P1": lambda: cc.solve(box_and_strips(cc.Coulomb(0.3)), "sigma1"),
    "3d box + strips Tresca P1": lambda: cc.solve(box_and_strips(cc.Tresca(G)), "sigma1"),
}
"""name -> a solution (builders above)."""


def digest(sol, caught):
    h = hashlib.sha256()
    add = lambda a: h.update(np.ascontiguousarray(np.asarray(a, dtype=float)).tobytes())
    for u in sol.u:
        add(u)
    for c in sol.contacts:
        for name in ("lam", "jump", "force", "active", "shear_multiplier"):
            v = getattr(c, name, None)
            if v is not None:
                add(v)
    h.update(repr(sorted(sol.residuals().items())).encode())
    h.update(repr((sol.ok, sol.energy)).encode())
    est = sol.estimate
    if est is not None:
        h.update(repr((est.absolute, est.norm, sorted(est.parts.items()), est.guaranteed)).encode())
        for e in est.indicators:
            add(e)
    else:
        h.update(str(sol.estimate_reason).encode())
    w = [(x.category.__name__, str(x.message), x.filename.rsplit("/", 1)[-1], x.lineno) for x in caught]
    h.update(repr(w).encode())
    return h.hexdigest()[:16], len(w), sorted({n for n, *_ in w}), w


for name, make in CASES.items():
    if args.only not in name:
        continue
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = make()
        d, n, cats, _ = digest(sol, caught)
        est = sol.estimate
        print(f"{name:40s} {d} ok={sol.ok} est={f'{est.absolute:.6g}' if est else None} warnings={n} {cats}",
              flush=True)
    except Exception as exc:                     # noqa: BLE001  (said, and the next scene run)
        print(f"{name:40s} ERROR {type(exc).__name__}: {str(exc)[:200]}", flush=True)
