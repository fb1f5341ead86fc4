"""A/B of PARDISO's reproducible mode (CNR, iparm[33] = the thread count, sequential METIS): the same work timed
in fresh processes on two checkouts, interleaved pair by pair, CPU (time.process_time) and wall seconds.

Cases (``--case``): ``phases:<n>`` demo.thin_layer(n)'s K(A) (A: 60 % of the rows some unknown moves, at
random) as the sparse route factorises it (PardisoSymmetric in minimum degree, analysed on the bonded values): the
analysis, 3 numeric factorisations, 20 single right-hand-side solves, 3 solves of 32 columns; ``layer:<n>`` the sparse route on demo.thin_layer(n) with PARDISO (SparseContact.solve from
its default start: analysis, factorisations of K(A), solves); ``box:<n>`` tests/scenes3d.two_boxes(n, elastic=True)'s
bonded mixed system (PardisoSymmetric: analysis, factorisation, one solve) and each body condensed on its contact
dofs (factorize(S, gamma, "pardiso"): Sigma, one forward/backward sweep). The thread count is MKL_NUM_THREADS
(``--threads``), which the adapters read. Example (the numbers of CHANGELOG's entry)::

    git archive main | tar -x -C /tmp/cnr-base
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 /work/venv/bin/python benchmarks/pardiso_cnr_ab.py \\
        --a /tmp/cnr-base --b . --case layer:1500 --threads 2 --pairs 4
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def one(case: str) -> dict:
    kind, n = case.split(":")
    n = int(n)
    sys.path.insert(0, str(Path(os.environ["PYTHONPATH"].split(os.pathsep)[0]) / "tests"))
    import cvxcontact as cc
    from cvxcontact.backends import factor
    from cvxcontact.backends.condensed import (
        contact_dofs,
        quasi_definite,
        quasi_definite_rhs,
    )

    assert factor._load() is not None
    out = {"file": cc.__file__}
    if kind == "phases":
        from cvxcontact.apps.demo import thin_layer
        from cvxcontact.backends.sparse import SparseContact

        problem = cc.ContactSolver(thin_layer(n), method="sparse").problem
        sc = SparseContact(list(problem.blocks), problem.E)
        rng = np.random.default_rng(0)
        moves = np.asarray(abs(sc.G).sum(axis=1)).ravel() > 0
        K0, K = sc.matrix(moves), sc.matrix(moves & (rng.random(sc.m) < 0.6))
        b, B = rng.standard_normal(K.shape[0]), rng.standard_normal((K.shape[0], 32))
        marks = [(time.process_time(), time.perf_counter())]
        h = factor.PardisoSymmetric(K, ordering=0).analyse(K0)
        marks.append((time.process_time(), time.perf_counter()))
        for _ in range(3):
            h.factor(K)
        marks.append((time.process_time(), time.perf_counter()))
        for _ in range(20):
            h.solve(b)
        marks.append((time.process_time(), time.perf_counter()))
        for _ in range(3):
            h.solve(B)
        marks.append((time.process_time(), time.perf_counter()))
        h.release()
        for i, name in enumerate(("analysis", "factor3", "solve20", "block3x32")):
            out["cpu_" + name] = marks[i + 1][0] - marks[i][0]
            out["wall_" + name] = marks[i + 1][1] - marks[i][1]
        out.update(cpu=marks[-1][0] - marks[0][0], wall=marks[-1][1] - marks[0][1], unknowns=K.shape[0])
        return out
    if kind == "layer":
        from cvxcontact.apps.demo import thin_layer
        from cvxcontact.backends.sparse import SparseContact

        problem = cc.ContactSolver(thin_layer(n), method="sparse").problem
        blocks = list(problem.blocks)
        F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
        g = np.asarray(problem.g, dtype=float)
        c0, t0 = time.process_time(), time.perf_counter()
        sc = SparseContact(blocks, problem.E, factorization="pardiso")
        res = sc.solve(F, g)
        out.update(cpu=time.process_time() - c0, wall=time.perf_counter() - t0, unknowns=sc.n + sc.m,
                   active=int(np.sum(res[3])), factorizations=sc.factorizations)
        return out
    from scenes3d import two_boxes

    problem = cc.ContactSolver(two_boxes(n, elastic=True), method="sparse").problem
    blocks = list(problem.blocks)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from harness import bonded_system

    K, rhs = bonded_system(problem)[:2]
    K = K.tocsc()
    K.sort_indices()
    c0, t0 = time.process_time(), time.perf_counter()
    h = factor.PardisoSymmetric(K).factor(K)
    h.solve(rhs)
    h.release()
    c1, t1 = time.process_time(), time.perf_counter()
    for b in blocks:
        S, _ = quasi_definite(b)
        f = factor.factorize(S, contact_dofs(b), "pardiso")
        f.backward(f.forward(quasi_definite_rhs(b)), np.zeros(len(f.gamma)))
        f.release()
    c2, t2 = time.process_time(), time.perf_counter()
    out.update(cpu=c1 - c0, wall=t1 - t0, cpu_bodies=c2 - c1, wall_bodies=t2 - t1, unknowns=K.shape[0])
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--one")
    ap.add_argument("--a")
    ap.add_argument("--b")
    ap.add_argument("--case", default="layer:1500")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--pairs", type=int, default=4)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one(args.one)), flush=True)
        return
    rows = {"A": [], "B": []}
    for i in range(args.pairs):
        for tag, tree in (("A", args.a), ("B", args.b)) if i % 2 == 0 else (("B", args.b), ("A", args.a)):
            env = dict(os.environ, PYTHONPATH=str(Path(tree).resolve()), MKL_NUM_THREADS=str(args.threads))
            out = subprocess.run([sys.executable, __file__, "--one", args.case], capture_output=True, text=True, check=False,
                                 env=env)
            if out.returncode:
                raise RuntimeError(out.stderr[-3000:])
            r = json.loads(out.stdout.strip().splitlines()[-1])
            rows[tag].append(r)
            print(tag, json.dumps(r), flush=True)
    for key in rows["A"][0]:
        if key in ("file", "unknowns", "active", "factorizations"):
            continue
        a, b = (np.array([r[key] for r in rows[t]]) for t in "AB")
        print(f"{args.case} threads={args.threads} {key}: A median {np.median(a):.3f} [{a.min():.3f}, {a.max():.3f}]"
              f"  B median {np.median(b):.3f} [{b.min():.3f}, {b.max():.3f}]  B/A {np.median(b) / np.median(a):.3f}"
              f"  pairwise B/A {np.median(b / a):.3f}", flush=True)


if __name__ == "__main__":
    main()
