"""Benchmark helper: sha256 (first 16 hex digits) of the error estimate (absolute, norm, parts, indicators) of 35
scenes (16 3D, 19 2D), a before/after bit-for-bit check of a change that must not alter the estimate (h-estmem: the
contact terms' memory), and of 2D obstacle scenes (h-side2d: one pair per part unchanged; obstacles sharing a part, "shared",
their complementarity and penetration read once on the side). Run it with each checkout's package and tests and diff
the outputs:

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONPATH=<checkout> \
        python benchmarks/estimate_hashes.py <checkout> [name prefix, e.g. 2D] > hashes.txt
"""
import hashlib
import sys

sys.path[:0] = [sys.argv[1] + "/tests"]

import friction_scenes as fs
import hex_scenes as hx
import numpy as np
import reach_scenes as rs
import scenes3d as s3
from conftest import two_blocks

import cvxcontact as cc

TILTED = cc.Rigid("tilted line", lambda x, nu: np.asarray(x, float)[:, 1] + 4e-6 * np.asarray(x, float)[:, 0],
                  "the line y = -4e-6 x", sensitivity=lambda x, nu: np.tile([0.0, 1.0], (len(x), 1)), dim=2)


def h(e):
    m = hashlib.sha256()
    m.update(np.float64([e.absolute, e.norm]).tobytes())
    for k in sorted(e.parts):
        m.update(k.encode()); m.update(np.float64(e.parts[k]).tobytes())
    for a in e.indicators:
        m.update(np.ascontiguousarray(a, dtype=float).tobytes())
    return m.hexdigest()[:16]

cases = {
    "2D two blocks sigma1": (lambda: two_blocks((8, 4), (5, 3)), {"condition": "sigma1"}),
    "2D two blocks P2 gamma3": (lambda: two_blocks((8, 4), (5, 3)), {"condition": "gamma3", "degree": 2}),
    "3D two_boxes PZT sigma1": (lambda: s3.two_boxes(6, "sigma1"), {}),
    "3D two_boxes elastic sigma1": (lambda: s3.two_boxes(6, "sigma1", True), {}),
    "3D two_boxes elastic gamma3": (lambda: s3.two_boxes(5, "gamma3", True), {"condition": "gamma3"}),
    "3D bumped_blocks P2": (lambda: s3.bumped_blocks(), {"degree": 2}),
    "3D three_blocks gamma3": (lambda: s3.three_blocks(), {"condition": "gamma3"}),
    "3D pzt_on_block": (lambda: s3.pzt_on_block(s3.STEEL), {}),
    "3D sphere_on_block": (lambda: s3.sphere_on_block(), {}),
    "3D hex nested skewed": (lambda: hx.nested("skewed 4 on 2")[0], {}),
    "3D friction sliding tetra": (lambda: fs.LAYERS3D["sliding"](), {"condition": "gamma3"}),
    "3D friction sliding P2": (lambda: fs.LAYERS3D["sliding"](), {"condition": "gamma3", "degree": 2}),
    "3D friction slid_cube": (lambda: fs.slid_cube(3e-4), {}),
    "3D strips+floor tresca P2 shared": (lambda: fs.uniform_layer3d(0.2 * fs.P, cc.Tresca(2 * fs.P), n=3, obstacles=(rs.strip(-1.0, 0.7), rs.strip(0.3, 2.0), rs.strip(-1.0, 2.0))), {"condition": "sigma1", "degree": 2}),
    "3D strips+floor coulomb P1 shared": (lambda: fs.uniform_layer3d(0.2 * fs.P, cc.Coulomb(0.5), n=4, obstacles=(rs.strip(-1.0, 0.7), rs.strip(0.3, 2.0), rs.strip(-1.0, 2.0))), {"condition": "sigma1"}),
    "3D two_boxes elastic n=30 (multi-block)": (lambda: s3.two_boxes(30, "sigma1", True), {}),
    "3D two_boxes PZT n=24 (multi-block)": (lambda: s3.two_boxes(24, "sigma1"), {}),
    "3D two_boxes elastic P2 n=12": (lambda: s3.two_boxes(12, "sigma1", True), {"degree": 2}),
    "2D block one line P1": (lambda: rs.block2d((rs.line(-1.0, 2.0),)), {"condition": "sigma1"}),
    "2D block one line P2": (lambda: rs.block2d((rs.line(-1.0, 2.0),)), {"condition": "sigma1", "degree": 2}),
    "2D block raised floor P1": (lambda: rs.block2d((rs.raised(0.3, 0.7, 2),)), {"condition": "sigma1"}),
    "2D block raised floor P2": (lambda: rs.block2d((rs.raised(0.3, 0.7, 2),)), {"condition": "sigma1", "degree": 2}),
    "2D block tilted line P1": (lambda: rs.block2d((TILTED,)), {"condition": "sigma1"}),
    "2D block one strip P2": (lambda: rs.block2d((rs.line(-1.0, 0.4),)), {"condition": "sigma1", "degree": 2}),
    "2D layer tresca floor P1": (lambda: fs.uniform_layer(0.2 * fs.P, cc.Tresca(2 * fs.P)), {"condition": "sigma1"}),
    "2D sheared tresca P1": (lambda: fs.sheared(0.05 * fs.P, cc.Tresca(0.1 * fs.P)), {"condition": "sigma1"}),
    "2D block on two blocks P1": (lambda: rs.block_on_blocks2d(), {"condition": "sigma1"}),
    "2D block on two blocks P2": (lambda: rs.block_on_blocks2d(), {"condition": "sigma1", "degree": 2}),
    "2D shared kink P1": (lambda: rs.block2d((rs.line(0.3, 2.0), rs.lowered(-1.0, 0.6, 2, kink=0.3))), {"condition": "sigma1"}),
    "2D shared kink P2": (lambda: rs.block2d((rs.line(0.3, 2.0), rs.lowered(-1.0, 0.6, 2, kink=0.3))), {"condition": "sigma1", "degree": 2}),
    "2D shared raised strip P1": (lambda: rs.block2d((rs.line(-1.0, 2.0), rs.lowered(0.3, 0.7, 2, drop=-3e-6))), {"condition": "sigma1"}),
    "2D shared raised strip P2": (lambda: rs.block2d((rs.line(-1.0, 2.0), rs.lowered(0.3, 0.7, 2, drop=-3e-6))), {"condition": "sigma1", "degree": 2}),
    "2D shared split 0.4 P1": (lambda: rs.block2d((rs.line(-1.0, 0.4), rs.line(0.4, 2.0))), {"condition": "sigma1"}),
    "2D shared strips+floor P2": (lambda: rs.block2d((rs.line(-1.0, 0.7), rs.line(0.3, 2.0), rs.line(-1.0, 2.0))), {"condition": "sigma1", "degree": 2}),
    "2D shared layer tresca 0.4 P1": (lambda: fs.uniform_layer(0.2 * fs.P, cc.Tresca(2 * fs.P), obstacles=(rs.line(-1.0, 0.4), rs.line(0.4, 2.0))), {"condition": "sigma1"}),
}
only = sys.argv[2] if len(sys.argv) > 2 else ""         # e.g. "2D": the cases whose name starts with it
for name, (make, kw) in cases.items():
    if not name.startswith(only):
        continue
    sol = cc.solve(make(), **kw)
    e = sol.estimate
    print(f"{name:32s} {h(e)} abs={e.absolute!r} parts_ct={e.parts['contact traction']!r} "
          f"comp={e.parts.get('complementarity')!r} pen={e.parts.get('penetration')!r}", flush=True)
