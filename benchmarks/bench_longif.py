"""Benchmark: the sparse route on the long interface against one bonded PARDISO solve, before and after (issue 33).

Scene: ``demo.thin_layer(n)`` (a thin PZT layer on a crowned substrate, non-matching traces: 5,101 merged contact
nodes at n = 3000, a saw-tooth of open rows inside the contact zone). For each side (this checkout's working tree,
and with ``--baseline REV`` the package at the git revision REV, extracted by ``git archive`` into a temporary
directory) and each size, a fresh subprocess of this interpreter imports the package from its own tree (checked),
builds the problem once and then measures, in process CPU seconds (``time.process_time``; run it with one thread,
``--threads 1``, the default):

* ``route_cpu``: the sparse route from the scaled problem to the exact answer, i.e.
  ``SparseContact(blocks, E).solve(F, g, start)`` from the route's start (the bonded system, or above
  ``sparse.COARSE_ROWS`` rows where the side has it ``SparseContact.coarse_start``; the bonded start if the steps
  from it lead nowhere, as the route does) (the pattern, PARDISO's analysis, the start, the active-set steps, every
  factorisation and solve); median of ``--repeats``. Its systems solved, factorisations and capacitance
  column solves are reported;
* ``solve_cpu``: ``cc.ContactSolver(scene).solve()`` (``method="auto"``: the sparse route here), from the Scene to
  the checked Solution, minus its assembly (``sol.timings["assembly"]``); median of ``--repeats``;
* ``bonded_cpu``, the yardstick: the bonded mixed system (every merged node glued, [u_nu] = 0: the same blocks,
  benchmarks/harness.bonded_kkt) solved once from scratch by MKL PARDISO through ``pypardiso`` (real symmetric
  indefinite, analysis + factorisation + solve); median of ``--repeats``.

Ratios ``route_cpu / bonded_cpu`` and ``solve_cpu / bonded_cpu`` are taken within one process, so that the load of
a shared machine touches both alike. The answers of the two sides must agree: max |a - b| / max |b| of the stacked
displacements and of the row forces (the forces of a slender layer carry its conditioning, about 1e-10).

Run:  python benchmarks/bench_longif.py --sizes 1000 3000 5000 --baseline b2ba6a9 --repeats 3 \\
          --report benchmarks/results/bench_longif.md
"""

from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def one(root: str, n: int, repeats: int, out: str) -> dict:
    """The measurements of one side at one size (module docstring), in this process; answers saved to ``out``."""
    sys.path.insert(0, root)
    sys.path.insert(0, str(HERE))
    import warnings

    warnings.simplefilter("ignore")
    import cvxcontact as cc
    from cvxcontact.apps import demo
    from cvxcontact.backends import sparse as sparse_module
    from cvxcontact.backends.condensed import quasi_definite_rhs
    from cvxcontact.backends.sparse import SparseContact

    if not Path(cc.__file__).resolve().is_relative_to(Path(root).resolve()):
        raise RuntimeError(f"imported {cc.__file__}, not from {root}")
    from harness import bonded_kkt

    cc.solve(demo.thin_layer(8))                                # imports, first-call set-up
    solver = cc.ContactSolver(demo.thin_layer(n))
    p = solver.problem
    blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    route, counts = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        sc = SparseContact(blocks, E, factorization="auto")
        start = None                                    # the route's start (backends/signorini.sparse)
        if hasattr(sc, "coarse_start") and len(g) >= getattr(sparse_module, "COARSE_ROWS", np.inf):
            start = sc.coarse_start(F, g)
        answer = sc.solve(F, g, start)
        answer = sc.solve(F, g) if answer is None else answer
        u, phi, y, active, steps = answer
        route.append(time.process_time() - t0)
        counts = {"systems": steps, "factorizations": sc.factorizations, "column_solves": sc.column_solves,
                  "closed": int(active.sum()), "rows": len(active), "factorization": sc.factorization}
    np.savez(out, x=np.concatenate(u + [q for q in phi if q is not None]), y=y)
    whole, ok = [], True
    for _ in range(repeats):
        scene = demo.thin_layer(n)
        t0 = time.process_time()
        sol = cc.ContactSolver(scene).solve()
        whole.append(time.process_time() - t0 - sol.timings["assembly"])
        ok = ok and bool(sol.ok)
    import pypardiso
    import scipy.sparse as sps

    K, rhs, _, _, _ = bonded_kkt(blocks, [b.jump for b in blocks])
    M = sps.triu(K, format="csr")
    M.sort_indices()
    bonded = []
    for _ in range(repeats):
        ps = pypardiso.PyPardisoSolver(mtype=-2)
        t0 = time.process_time()
        ps.solve(M, rhs)
        bonded.append(time.process_time() - t0)
        ps.free_memory(everything=True)
    r, s, b = statistics.median(route), statistics.median(whole), statistics.median(bonded)
    return dict(n=n, unknowns=int(K.shape[0]), route_cpu=r, solve_cpu=s, bonded_cpu=b, route_ratio=r / b,
                solve_ratio=s / b, ok=ok, method=sol.info.method, **counts)


def side(root: str, n: int, repeats: int, out: str, threads: int) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads),
               OPENBLAS_NUM_THREADS=str(threads))
    arg = json.dumps({"root": root, "n": n, "repeats": repeats, "out": out})
    res = subprocess.run([sys.executable, __file__, "--one", arg], env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=int, nargs="+", default=[1000, 3000])
    p.add_argument("--baseline", help="git revision to time against the working tree")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--report", help="also write the result as Markdown to this file")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        print(json.dumps(one(a["root"], a["n"], a["repeats"], a["out"])))
        return
    repo = HERE.parent
    with tempfile.TemporaryDirectory() as tmp:
        sides = [("after", str(repo))]
        if args.baseline:
            data = subprocess.run(["git", "-C", str(repo), "archive", args.baseline, "cvxcontact"],
                                  capture_output=True, check=True).stdout
            with tarfile.open(fileobj=io.BytesIO(data)) as tar:
                tar.extractall(Path(tmp) / "before", filter="data")
            sides.insert(0, ("before", str(Path(tmp) / "before")))
        rows = []
        for n in args.sizes:
            res = {name: side(root, n, args.repeats, str(Path(tmp) / f"{name}{n}.npz"), args.threads)
                   for name, root in sides}
            if args.baseline:
                a, b = np.load(Path(tmp) / f"after{n}.npz"), np.load(Path(tmp) / f"before{n}.npz")
                res["after"]["agree_x"], res["after"]["agree_y"] = rel(a["x"], b["x"]), rel(a["y"], b["y"])
            for name, r in res.items():
                r["side"] = name
                rows.append(r)
                print(json.dumps(r), flush=True)
    keys = ["side", "n", "unknowns", "rows", "closed", "systems", "factorizations", "column_solves", "route_cpu",
            "solve_cpu", "bonded_cpu", "route_ratio", "solve_ratio", "ok", "agree_x", "agree_y"]
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[k]:.3g}" if isinstance(r.get(k), float) else str(r.get(k, "-"))
                                       for k in keys) + " |")
    table = "\n".join(lines)
    print(table)
    if args.report:
        cmd = "python benchmarks/bench_longif.py " + " ".join(sys.argv[1:])
        Path(args.report).write_text(f"# The long interface: sparse route against one bonded PARDISO solve\n\n"
                                     f"Command (one thread, CPU seconds, medians of {args.repeats}):\n\n"
                                     f"    {cmd}\n\n{table}\n")


if __name__ == "__main__":
    main()
