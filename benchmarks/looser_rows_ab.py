"""A/B in fresh processes: ``backends.signorini.looser_rows`` of two checkouts (e.g. main, the loop over rows, and
this one, vectorised) on synthetic nodal contact rows, and this checkout's split of it, the groups once per
geometry (``ParallelRows(G)``) and their order per load case (``.looser(g)``, what a sparse or AMG solve pays).

Rows: ``m`` nodal rows of a 3D scene, row a on the three u dofs of its own node (a random unit normal, weights
0.5-2), a floor; a strip over a fifth of the nodes repeats their rows bit for bit (two obstacles at one node),
with gaps 3e-6 above the floor's; so m = 1.2 N for N nodes. Per size, ``--pairs`` pairs, the two checkouts
alternately (the order swapped every pair), each timing a fresh process: CPU seconds (``time.process_time``)
of one call, the answers compared (the same bools).

``--rows chained``: three obstacles at every node whose rows are chained within the tolerance (:func:`chained`).

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/looser_rows_ab.py \\
        --base /tmp/looser-base --sizes 1e4 1e5 1e6 --pairs 3
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

HERE = Path(__file__).resolve().parents[1]


def rows(m: int, seed: int = 0):
    """(G, g): about ``m`` rows, a floor on N = m / 1.2 nodes and a strip on a fifth of them (module docstring)."""
    rng = np.random.default_rng(seed)
    N = round(m / 1.2)
    normal = rng.standard_normal((N, 3))
    normal *= rng.uniform(0.5, 2.0, (N, 1)) / np.linalg.norm(normal, axis=1, keepdims=True)
    strip = np.sort(rng.choice(N, m - N, replace=False))
    nodes = np.concatenate([np.arange(N), strip])
    G = sp.csr_matrix((normal[nodes].ravel(), (np.repeat(np.arange(len(nodes)), 3),
                                               (3 * nodes[:, None] + np.arange(3)).ravel())),
                      shape=(len(nodes), 3 * N))
    g = np.concatenate([rng.uniform(0.0, 1e-5, N), np.zeros(len(strip))])
    g[N:] = g[strip] + 3e-6
    return G, g


def chained(m: int, seed: int = 0):
    """(G, g): about ``m`` rows, three obstacles at each of N = m / 3 nodes, the second's and third's unit rows
    0.6 and 1.2 PARALLEL_TOL (1e-12) from the first's in one entry: every node a chained cluster (the first and
    third not within tol), the worst case of :meth:`ParallelRows.looser` (ordered row by row); random gaps."""
    rng = np.random.default_rng(seed)
    N = m // 3
    normal = rng.standard_normal((N, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    vals = np.vstack([normal, normal + [0.6e-12, 0, 0], normal + [1.2e-12, 0, 0]])
    nodes = np.tile(np.arange(N), 3)
    G = sp.csr_matrix((vals.ravel(), (np.repeat(np.arange(3 * N), 3), (3 * nodes[:, None] + np.arange(3)).ravel())),
                      shape=(3 * N, 3 * N))
    return G, rng.uniform(0.0, 1e-5, 3 * N)


def one(tree: str, m: int, kind: str = "strip") -> dict:
    """The CPU seconds of ``looser_rows`` of the checkout ``tree`` (and, where it has them, of ParallelRows and of
    its .looser) on :func:`rows` ``(m)``, and a digest of the answer."""
    sys.path.insert(0, tree)
    from cvxcontact.backends import signorini

    assert Path(signorini.__file__).resolve().is_relative_to(Path(tree).resolve()), signorini.__file__
    G, g = rows(m) if kind == "strip" else chained(m)
    c0 = time.process_time()
    out = signorini.looser_rows(G, g)
    res = {"call": time.process_time() - c0, "looser": int(out.sum()),
           "digest": hashlib.sha256(out.tobytes()).hexdigest()[:12]}
    if hasattr(signorini, "ParallelRows"):
        c0 = time.process_time()
        groups = signorini.ParallelRows(G)
        res["groups"] = time.process_time() - c0
        c0 = time.process_time()
        again = groups.looser(g)
        res["order"] = time.process_time() - c0
        assert np.array_equal(again, out)
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="the other checkout (its cvxcontact is imported)")
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e4, 1e5, 1e6])
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--rows", choices=("strip", "chained"), default="strip",
                    help="a floor and a strip (default) or three obstacles chained within tol at every node")
    ap.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one(args.one[0], int(float(args.one[1])), args.rows)))
        return
    trees = {"before": str(Path(args.base).resolve()), "after": str(HERE)}
    print("| rows | before: looser_rows CPU s | after: looser_rows | after: ParallelRows (once per geometry) | "
          "after: .looser(g) (per solve) | same answer |")
    print("|---|---|---|---|---|---|")
    for size in args.sizes:
        m = int(size)
        runs = {k: [] for k in trees}
        for pair in range(args.pairs):
            for k in (list(trees) if pair % 2 == 0 else list(trees)[::-1]):
                out = subprocess.run([sys.executable, __file__, "--base", args.base, "--rows", args.rows, "--one", trees[k],
                                      str(m)],
                                     capture_output=True, text=True, check=True, cwd="/tmp")
                runs[k].append(json.loads(out.stdout.strip().splitlines()[-1]))

        def cell(k, key, runs=runs):
            v = [r[key] for r in runs[k]]
            return f"{statistics.median(v):.4f} ({min(v):.4f}-{max(v):.4f})"

        same = len({r["digest"] for k in trees for r in runs[k]}) == 1
        print(f"| {m:,} | {cell('before', 'call')} | {cell('after', 'call')} | {cell('after', 'groups')} | "
              f"{cell('after', 'order')} | {same} ({runs['after'][0]['looser']:,} looser) |", flush=True)


if __name__ == "__main__":
    main()
