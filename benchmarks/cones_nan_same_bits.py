"""Same bits after the tangency finish's KKT residual reads a zero segment scale as 0 (0/0) or inf, not NaN
(h-conesnan, cvxcontact/backends/cones.py ``kkt_residual``): a sha256 (16 hex digits) of u, every pair's lambda_h,
force and active set, ok and the checks of 2D/3D P2 "gamma3" scenes on the default route, and how many
RuntimeWarnings cvxcontact/backends/cones.py raised on each, with the package of the tree ``--tree`` (default:
this one). The scenes with a warning before the fix are those whose contact rests exactly on a floor (every
term of the slack 0: tests/reach_scenes.py's block on ``line(-1, 2)``, ``strip(-1, 2)``).

Run (one thread; each tree's tests/ fixtures are read), interleaved:
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/cones_nan_same_bits.py --tree OLD > a
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/cones_nan_same_bits.py > b
    diff <(cut -c1-42 a) <(cut -c1-42 b)
"""

import argparse
import sys
import warnings
from pathlib import Path

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--tree", default=str(Path(__file__).resolve().parent.parent), help="source tree of cvxcontact")
parser.add_argument("scenes", nargs="*", help="names of SCENES (default: all)")
args = parser.parse_args()
sys.path[:0] = [args.tree, str(Path(args.tree) / "tests")]

from compliance_scenes import held_layer, pressed_block
from conftest import two_blocks
from harness import solution_digest
from obstacle_scenes import circle, indented_block, indenter_scene, punch_scene
from pair_scenes import block_on, elastic_punch
from reach_scenes import (
    block2d,
    block3d,
    block_on_blocks2d,
    kinked,
    line,
    lowered,
    raised,
    step,
    strip,
)
from stack_scenes import three_blocks

import cvxcontact as cc


def stack():
    bodies, pairs, _ = three_blocks(("gamma3", "gamma3"))
    return cc.Scene(*bodies, contacts=pairs)


SCENES = {
    "block2d line": lambda: block2d([line(-1.0, 2.0)]),
    "block2d line nx3": lambda: block2d([line(-1.0, 2.0)], nx=3),
    "block2d line nx8": lambda: block2d([line(-1.0, 2.0)], nx=8),
    "block2d line nx12": lambda: block2d([line(-1.0, 2.0)], nx=12),
    "block2d line quad": lambda: block2d([line(-1.0, 2.0)], cell="quad"),
    "block2d line part": lambda: block2d([line(-1.0, 0.4)]),
    "block2d line 0.3-2": lambda: block2d([line(0.3, 2.0)]),
    "block2d line+lowered": lambda: block2d([line(-1.0, 2.0), lowered(0.3, 0.7, 2)]),
    "3D block strip": lambda: block3d([strip(-1.0, 2.0)]),
    "3D strip+lowered": lambda: block3d([strip(-1.0, 2.0), lowered(0.3, 0.7, 3)]),
    "two blocks 8x4/5x3": lambda: two_blocks((8, 4), (5, 3)),
    "two blocks 16x8/11x6": lambda: two_blocks(),
    "two blocks 4x2/3x2": lambda: two_blocks((4, 2), (3, 2)),
    "two blocks 12x6/7x4": lambda: two_blocks((12, 6), (7, 4)),
    "punch 0.5-1e-5": lambda: punch_scene(0.5 - 1e-5)(),
    "punch force": lambda: punch_scene(0.5)(force=(0.0, -1e6)),
    "indenter fixed": lambda: indenter_scene(0.5 + 0.6 - 3e-3),
    "circle closest": lambda: circle(),
    "indented block": lambda: indented_block(),
    "block2d lowered": lambda: block2d([lowered(0.3, 0.7, 2)]),
    "block2d kinked": lambda: block2d([kinked(2)]),
    "block2d step": lambda: block2d([step(0.4, 2)]),
    "block on blocks": lambda: block_on_blocks2d(),
    "elastic punch": lambda: elastic_punch("gamma3")[0],
    "block on foundation": lambda: block_on(None, E_found=7e9),
    "held layer": lambda: held_layer(None),
    "pressed block": lambda: pressed_block(2e7),
    "three blocks gamma3": stack,
    "block2d two lines": lambda: block2d([line(-1.0, 0.7), line(0.3, 2.0)]),
    "block2d three lines": lambda: block2d([line(-1.0, 0.7), line(0.3, 2.0), line(-1.0, 2.0)]),
    "block2d coincident": lambda: block2d([line(-1.0, 2.0), line(-1.0, 2.0)]),
    "block2d line+raised": lambda: block2d([line(-1.0, 2.0), lowered(0.3, 0.7, 2, drop=-3e-6)]),
    "block2d raised": lambda: block2d([raised(0.3, 0.7, 2)]),
    "block2d line+kink": lambda: block2d([line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3)]),
    "block2d kinked x2": lambda: block2d([kinked(2), kinked(2)]),
    "block2d kinked shift": lambda: block2d([kinked(2), kinked(2, shift=1e-7)]),
    "block2d lowered 0-2": lambda: block2d([lowered(-1.0, 2.0, 2, drop=1e-7)]),
}

for name in args.scenes or list(SCENES):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = cc.solve(SCENES[name](), condition="gamma3", degree=2)
    nans = sum(issubclass(w.category, RuntimeWarning) and w.filename.endswith("cones.py") for w in caught)
    print(f"{name:24s} {solution_digest(sol)} cones.py RuntimeWarnings={nans} | {sol.info.finish}", flush=True)
