"""A/B of the routes that now give a re-solved load its first bits (docs/explanation/known-behaviour.md, "Same
question, same bits"): the CPU seconds and Krylov iterations of the AMG route, and the CPU seconds of the Newton
(Hencky) route, on a first solve, the same load again and another load, with the package at ``--a`` and ``--b`` (two
source trees: e.g. an export of the commit before and the worktree). Each (tree, case) runs in its own subprocess,
in A, B, A, B order (``--runs`` rounds): the medians are printed per tree.

Cases: ``sphere`` (tests/scenes3d.py ``sphere_into_block(n)``, CG), ``boxes`` (``two_boxes(n)``, PZT-5A on aluminium,
GMRES), ``hencky`` (tests/hencky_scenes.py ``indented``, nx x ny cells, method "newton"); another load: body 0's
body force along -z (-y in 2D).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/same_bits_ab.py --a OLD --b NEW
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, sys, time, warnings
sys.path.insert(0, {tests!r})
warnings.simplefilter("ignore")
import numpy as np
import cvxcontact as cc
from scenes3d import sphere_into_block, two_boxes
from hencky_scenes import indented
case, n = {case!r}, {n!r}
if case == "hencky":
    scene, options, force = indented(cc.materials.hencky(70e9, 0.3, 1e8, 0.1), nx=n, ny=max(3, n // 3)), {{}}, 1e6
else:
    scene, options, force = (sphere_into_block(n), dict(method="amg"), 1e8) if case == "sphere" else \
        (two_boxes(n), dict(method="amg"), 3e9)
other = scene.with_loads(0, body_force=(0.0,) * (scene.dim - 1) + (-force,))
solver = cc.ContactSolver(scene, **options)
out = {{"where": cc.__file__}}
for name, s in (("first", None), ("same", None), ("other", other), ("back", scene)):
    kc = solver.cache.amg
    its = 0 if kc is None else kc.iterations
    t = time.process_time()
    sol = solver.solve(s)
    out[name + "_cpu_s"] = time.process_time() - t
    kc = solver.cache.amg
    out[name + "_krylov"] = None if kc is None else kc.iterations - its
    out[name + "_ok"] = bool(sol.ok)
out["unknowns"] = int(sum(len(u) for u in sol.u))
print(json.dumps(out))
"""


def run(tree: str, case: str, n: int) -> dict:
    env = dict(os.environ, PYTHONPATH=tree)
    code = CHILD.format(tests=str(ROOT / "tests"), case=case, n=n)
    done = subprocess.run([sys.executable, "-c", code], env=env, cwd="/", capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--a", required=True, help="source tree A (holding cvxcontact/)")
    p.add_argument("--b", default=str(ROOT), help="source tree B (default: this one)")
    p.add_argument("--cases", nargs="*", default=["sphere:20", "boxes:10", "hencky:16"])
    p.add_argument("--runs", type=int, default=3)
    args = p.parse_args()
    for spec in args.cases:
        case, n = spec.split(":")
        rows = {"A": [], "B": []}
        for _ in range(args.runs):
            for label, tree in (("A", args.a), ("B", args.b)):
                rows[label].append(run(tree, case, int(n)))
        for label in ("A", "B"):
            r = rows[label]
            assert all(str(Path(x["where"]).resolve()).startswith(str(Path(getattr(args, label.lower())).resolve()))
                       for x in r), "the subprocess imported another tree"
            cells = [f"{k} {statistics.median(x[k + '_cpu_s'] for x in r):.3f} s"
                     + (f" ({r[0][k + '_krylov']} its)" if r[0][k + "_krylov"] is not None else "")
                     for k in ("first", "same", "other", "back")]
            ok = all(x[k + "_ok"] for x in r for k in ("first", "same", "other", "back"))
            print(f"{case}({n}) {label}: {r[0]['unknowns']} unknowns, CPU medians of {len(r)}: " + ", ".join(cells)
                  + ("" if ok else "  (an answer failed its checks)"), flush=True)


if __name__ == "__main__":
    main()
