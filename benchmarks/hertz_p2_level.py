"""Benchmark: one P2 row of the Hertz study (cvxcontact/apps/studies/hertz.py: the cylinder on the block, "gamma3",
the condensed route, the accumulated cuts' finish) in several source trees, in one run.

For each source tree (``--trees REV ...``: git revisions, each extracted into a temporary directory; ``.``: this
working tree) a child process, single-threaded, solves ``hertz.scene(n)`` as the study does (``solve_quietly(...,
"gamma3", method="condensed", degree=2)``) under a CPU-time limit (``--limit`` seconds; a tree over it is reported
as stopped) and prints the row's columns: the load, the half-width, the peak pressure, the active nodes, ok, and the
CPU seconds (``time.process_time``: the machine is shared, wall times measure the neighbours too). The parent prints
the table and, between successive trees that finished, the largest difference of the displacements (all bodies)
and of the contact forces, each over its largest entry.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/hertz_p2_level.py --n 256 \\
        --trees 2a29188 319c009 .

Results: benchmarks/results/hertz_p2_level.md.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, signal, sys, time, warnings
import numpy as np
import cvxcontact as cc
from cvxcontact.apps.studies import hertz
from cvxcontact.apps.studies.common import solve_quietly

n, limit, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
warnings.simplefilter("ignore")


class Stop(Exception):
    pass


def stop(*_):
    raise Stop()


signal.signal(signal.SIGVTALRM, stop)
scene = hertz.scene(n)
signal.setitimer(signal.ITIMER_VIRTUAL, limit)
t = time.process_time()
try:
    sol = solve_quietly(scene, "gamma3", method="condensed", degree=2)
except Stop:
    json.dump({"file": cc.__file__, "cpu": time.process_time() - t, "stopped": True}, open(out + ".json", "w"))
    sys.exit(0)
cpu = time.process_time() - t
signal.setitimer(signal.ITIMER_VIRTUAL, 0)
c = sol.contact
np.savez(out + ".npz", force=np.asarray(c.force, dtype=float), u=np.concatenate([np.ravel(u) for u in sol.u]))
json.dump({"file": cc.__file__, "cpu": cpu, "stopped": False, "load": float(c.force.sum()),
           "a_h": float(hertz.half_width(c)), "p0_h": float(sol.traction(0)[1].max()),
           "active": int(c.active.sum()), "ok": bool(sol.ok), "finish": getattr(sol.info, "finish", None)},
          open(out + ".json", "w"))
"""


def tree(rev: str, tmp: Path) -> Path:
    """The source tree of ``rev`` (``.``: this working tree), extracted into ``tmp``."""
    if rev == ".":
        return ROOT
    dest = tmp / rev
    dest.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=256)
    parser.add_argument("--trees", nargs="+", default=["."])
    parser.add_argument("--limit", type=float, default=120.0, help="CPU seconds a tree may take")
    args = parser.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    rows, forces = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for rev in args.trees:
            src = tree(rev, tmp)
            out = str(tmp / f"out-{rev.replace('.', 'here')}")
            subprocess.run([sys.executable, "-c", CHILD, str(args.n), str(args.limit), out], check=True,
                           env=dict(env, PYTHONPATH=str(src)), cwd=tmp)
            with open(out + ".json") as fh:
                r = json.load(fh)
            assert r["file"].startswith(str(src)), (r["file"], src)
            rows.append((rev, r))
            if not r["stopped"]:
                forces[rev] = dict(np.load(out + ".npz"))
    print(f"| tree | CPU s | load N/m | a_h m | p0_h Pa | active nodes | ok | finish |   (P2, n = {args.n})")
    print("|---|---|---|---|---|---|---|---|")
    for rev, r in rows:
        if r["stopped"]:
            print(f"| {rev} | > {r['cpu']:.0f} (stopped) | | | | | | |")
        else:
            print(f"| {rev} | {r['cpu']:.2f} | {r['load']:.4e} | {r['a_h']:.5f} | {r['p0_h']:.4e} | {r['active']} "
                  f"| {r['ok']} | {r['finish']} |")
    done = list(forces)
    for a, b in itertools.pairwise(done):
        for name in ("u", "force"):
            fa, fb = forces[a][name], forces[b][name]
            if fa.shape == fb.shape:
                diff = np.abs(fa - fb).max() / np.abs(fb).max()
                print(f"largest difference of {name} over its largest entry, {a} vs {b}: {diff:.1e}")


if __name__ == "__main__":
    main()
