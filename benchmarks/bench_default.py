"""Benchmark: the default ``cc.solve`` against one sparse direct solve of the bonded scene (issue 13).

Scenes are the canonical ones of :mod:`cvxcontact.apps.demo`: ``two_blocks(nx)`` (PZT-5A on aluminium,
non-matching meshes, P1 at ``nx`` and P2 at ``nx // 2``, i.e. about equal unknowns) and, if present,
``thin_layer(n)`` (a thin PZT layer on a substrate: thousands of merged contact nodes). Each case and
each part runs in a fresh subprocess, so that its peak memory (RSS) is its own; times are medians of
``--runs`` runs.

Parts of one case:

* ``default``: ``ContactSolver(scene, degree=d).solve()`` as ``cc.solve`` runs it (``method="auto"``),
  the first solve from the Scene to the checked Solution. ``default_s`` excludes assembly (reported as
  ``assembly_s``); ``resolve_share`` = a further load case through the same ContactSolver (the scene's
  loads x 0.37) / the first solve including assembly. Accuracy: the solution's own residuals of (26) and
  complementarity (27) (docs/checks.md).
* ``bonded`` (the yardstick): the same scaled blocks with the two bodies glued on Gamma_3, i.e. the
  mixed system (26) with [u_nu] = 0 held at every merged node, assembled once (excluded) and solved
  once from scratch (analysis + factorisation + solve) by
  - MKL PARDISO through ``pypardiso`` (``pip install ".[bench]"``), real symmetric indefinite (mtype -2,
    upper triangle) and real unsymmetric (mtype 11, pypardiso's default); the faster is ``pardiso_s``;
  - SciPy SuperLU (MMD on A^T + A, threshold pivoting 0.1), up to ``--superlu-up-to`` unknowns (it
    grows as N^1.5 and takes minutes above 1e6).
  The interpolation weights of coincident merged nodes (below 1e-12 of the largest) are dropped from
  the constraint rows first, so that the KKT pattern is the geometric one.

Run:  python benchmarks/bench_default.py [--sizes 70 140 280 560 1120] [--runs 3] [--p2] [--thin 1000 5000]
                                         [--csv FILE]
Print and CSV (``benchmarks/results/default.csv``): one row per case with both parts, the ratios
``default_s / pardiso_s`` and ``default_s / superlu_s``, and growth exponents over the sizes.
"""

from __future__ import annotations

import argparse
import csv
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout


def make_scene(name, n, scale=1.0):
    """The canonical scene ``name`` at size ``n`` with its loads x ``scale`` (thin_layer: pressure and voltage)."""
    from cvxcontact.apps import demo

    if name == "thin_layer":
        return demo.thin_layer(n, pressure=1e6 * scale, voltage=100.0 * scale)
    return getattr(demo, name)(n, scale=scale)


def peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def default_part(name, n, degree, runs, factorization="auto"):
    """The default solve, its re-solve share, accuracy and peak memory (module docstring)."""
    import cvxcontact as cc

    cc.solve(make_scene(name, 4), degree=degree, factorization=factorization)   # imports, first-call set-up
    rows = []
    for _ in range(runs):
        sc = make_scene(name, n)
        t0 = time.perf_counter()
        solver = cc.ContactSolver(sc, degree=degree, factorization=factorization)
        sol = solver.solve()
        total = time.perf_counter() - t0
        other = make_scene(name, n, scale=0.37)
        t0 = time.perf_counter()
        again = solver.solve(other)
        t_again = time.perf_counter() - t0
        tm = sol.timings
        rows.append(dict(default_total_s=total, assembly_s=tm["assembly"], default_s=total - tm["assembly"],
                         factorization_s=tm.get("factorization", 0.0),
                         interface_s=tm.get("model", 0.0) + tm.get("compile", 0.0) + tm.get("solve", 0.0)
                         + tm.get("polish", 0.0),
                         back_substitution_s=tm.get("back_substitution", 0.0), read_back_s=tm.get("read_back", 0.0),
                         resolve_s=t_again, resolve_share=t_again / total,
                         method=sol.info.method, route=str(sol.info.route), iterations=sol.info.iterations,
                         factorization=sol.info.factorization or "-", ok=bool(sol.ok),
                         resolve_ok=bool(again.ok), resolve_route=str(again.info.route),
                         **{f"res_{k}": float(v) for k, v in sol.residuals().items()}))
        unknowns = sum(b.Kuu.shape[0] + (b.Kpp.shape[0] if b.Kpp is not None else 0) for b in solver.problem.blocks)
        merged = solver.problem.E.shape[0]
        del solver, sol, again
    out = _median(rows)
    out.update(unknowns=unknowns, contact_rows=merged, default_peak_gb=peak_gb())
    return out


def bonded_blocks(sc, degree):
    """The scaled free-dof blocks of ``sc`` as the solver builds them, and the bonded constraint rows."""
    from cvxcontact.contact.quadratic import quadratic_interface
    from cvxcontact.discrete import Block, units
    from cvxcontact.fem import p2
    from cvxcontact.fem.assembly import assemble
    from cvxcontact.geometry.quadratic import P2Nodes

    if degree == 1:
        systems = [assemble(b) for b in sc.bodies]
        interface = sc.stack
    else:
        nodes = [P2Nodes(b.mesh) for b in sc.bodies]
        systems = [p2.assemble(b, nd) for b, nd in zip(sc.bodies, nodes)]
        interface = quadratic_interface(sc, nodes)
    un = units(sc, systems)
    return [Block.scaled(s, interface.jump(k, len(s.f) // 2), un) for k, s in enumerate(systems)]


def bonded_kkt(blocks):
    """K = [[A, G^T], [G, 0]] and its right-hand side: the bonded scene (module docstring)."""
    import scipy.sparse as sp

    from cvxcontact.backends.condensed import quasi_definite

    parts = [quasi_definite(b) for b in blocks]
    jumps = []
    for b, (S, _) in zip(blocks, parts):
        J = b.jump.tocsr(copy=True)
        J.data[np.abs(J.data) < 1e-12 * np.abs(J.data).max()] = 0.0
        J.eliminate_zeros()
        jumps.append(sp.hstack([J, sp.csr_matrix((J.shape[0], S.shape[0] - J.shape[1]))]))
    G = sp.hstack(jumps).tocsr()
    keep = np.diff(G.indptr) > 0
    G = G[keep]
    A = sp.block_diag([S for S, _ in parts])
    K = sp.bmat([[A, G.T], [G, None]], format="csr")
    rhs = np.concatenate([F for _, F in parts] + [np.zeros(G.shape[0])])
    return K, rhs


def _pardiso(K, rhs, mtype):
    import pypardiso
    import scipy.sparse as sp

    solver = pypardiso.PyPardisoSolver(mtype=mtype)
    if mtype == -2:                       # upper triangle, every diagonal entry stored (zeros included)
        U = sp.triu(K, format="coo")
        n = K.shape[0]
        diag = np.arange(n)
        rows, cols = np.concatenate([U.row, diag]), np.concatenate([U.col, diag])
        vals = np.concatenate([U.data, np.zeros(n)])
        M = sp.csr_matrix((vals, (rows, cols)), shape=K.shape)
        M.sum_duplicates()
        M.sort_indices()
    else:
        M = K
    t0 = time.perf_counter()
    z = solver.solve(M, rhs)
    t = time.perf_counter() - t0
    solver.free_memory(everything=True)
    return t, float(np.linalg.norm(K @ z - rhs) / np.linalg.norm(rhs))


def bonded_part(name, n, degree, runs, superlu_up_to):
    import scipy.sparse.linalg as spla

    sc = make_scene(name, n)
    t0 = time.perf_counter()
    blocks = bonded_blocks(sc, degree)
    t_asm = time.perf_counter() - t0
    K, rhs = bonded_kkt(blocks)
    out = dict(kkt_size=K.shape[0], bonded_assembly_s=t_asm)
    try:
        import pypardiso  # noqa: F401
        for mtype, key in ((-2, "pardiso_sym"), (11, "pardiso_unsym")):
            ts = [_pardiso(K, rhs, mtype) for _ in range(runs)]
            out[f"{key}_s"] = statistics.median(t for t, _ in ts)
            out[f"{key}_residual"] = max(r for _, r in ts)
        out["pardiso_s"] = min(out["pardiso_sym_s"], out["pardiso_unsym_s"])
    except ImportError:
        out["pardiso_s"] = float("nan")
    out["pardiso_peak_gb"] = peak_gb()
    if K.shape[0] <= superlu_up_to:
        ts = []
        for _ in range(max(1, min(runs, 2))):
            t0 = time.perf_counter()
            lu = spla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                           options=dict(SymmetricMode=True))
            z = lu.solve(rhs)
            ts.append(time.perf_counter() - t0)
            del lu
        out["superlu_s"] = statistics.median(ts)
        out["superlu_residual"] = float(np.linalg.norm(K @ z - rhs) / np.linalg.norm(rhs))
    else:
        out["superlu_s"] = float("nan")
    out["bonded_peak_gb"] = peak_gb()
    return out


def _median(rows):
    out = {}
    for key, value in rows[0].items():
        vals = [r[key] for r in rows]
        out[key] = statistics.median(vals) if isinstance(value, float) else value
    return out


def _run(args):
    out = subprocess.run([sys.executable, __file__, "--one", json.dumps(args)], capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(f"{args}: exit {out.returncode}\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def case(name, n, degree, runs, superlu_up_to):
    row = dict(scene=name, n=n, degree=degree)
    row.update(_run(dict(part="default", name=name, n=n, degree=degree, runs=runs)))
    if row["factorization"] == "pardiso" and row["unknowns"] <= superlu_up_to:    # the default install's path
        alt = _run(dict(part="default", name=name, n=n, degree=degree, runs=runs, factorization="superlu"))
        row.update({f"scipy_{k}": alt[k] for k in ("default_s", "resolve_share", "default_peak_gb", "ok",
                                                    "res_complementarity", "route")})
    row.update(_run(dict(part="bonded", name=name, n=n, degree=degree, runs=runs, superlu_up_to=superlu_up_to)))
    nan = float("nan")
    row["ratio_pardiso"] = row["default_s"] / row["pardiso_s"] if row["pardiso_s"] == row["pardiso_s"] else nan
    row["ratio_superlu"] = row["default_s"] / row["superlu_s"] if row["superlu_s"] == row["superlu_s"] else nan
    return row


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=int, nargs="*", default=[70, 140, 280, 560], help="two_blocks nx (P1); 560: 6.3e5 unknowns, 1120: 2.5e6")
    p.add_argument("--p2", action="store_true", help="also P2 at nx // 2 (about equal unknowns)")
    p.add_argument("--thin", type=int, nargs="*", default=[], help="thin_layer sizes")
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--superlu-up-to", type=int, default=800_000, help="largest KKT size solved by SuperLU")
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "default.csv"))
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        if a["part"] == "default":
            print(json.dumps(default_part(a["name"], a["n"], a["degree"], a["runs"], a.get("factorization", "auto"))))
        else:
            print(json.dumps(bonded_part(a["name"], a["n"], a["degree"], a["runs"], a["superlu_up_to"])))
        return
    cases = [("two_blocks", nx, 1) for nx in args.sizes]
    cases += [("two_blocks", max(2, nx // 2), 2) for nx in args.sizes if args.p2]
    cases += [("thin_layer", n, 1) for n in args.thin]
    rows = []
    for name, n, degree in cases:
        r = case(name, n, degree, args.runs if n < 400 or name != "two_blocks" else 1, args.superlu_up_to)
        rows.append(r)
        print(f"{name} n={n} P{degree}: {r['unknowns']} unknowns, {r['contact_rows']} contact rows "
              f"[{r['method']}/{r['factorization']}, {r['route']}] default {r['default_s']:.2f} s "
              f"(+ assembly {r['assembly_s']:.2f}; factorisation {r['factorization_s']:.2f}, interface "
              f"{r['interface_s']:.2f}, back-substitution {r['back_substitution_s']:.2f}, read-back "
              f"{r['read_back_s']:.2f})  PARDISO {r['pardiso_s']:.3f} s  SuperLU {r['superlu_s']:.2f} s  "
              f"default/PARDISO {r['ratio_pardiso']:.2f}  default/SuperLU {r['ratio_superlu']:.2f}  "
              f"re-solve {100 * r['resolve_share']:.1f} % [{r['resolve_route']}]  eq {r['res_equilibrium']:.1e} "
              f"compl {r['res_complementarity']:.1e} ok={r['ok']}  peak default {r['default_peak_gb']:.2f} GB, "
              f"bonded {r['bonded_peak_gb']:.2f} GB"
              + (f"  | SciPy-only default {r['scipy_default_s']:.2f} s (/PARDISO {r['scipy_default_s'] / r['pardiso_s']:.2f}, "
                 f"/SuperLU {r['scipy_default_s'] / r['superlu_s']:.2f}), re-solve {100 * r['scipy_resolve_share']:.1f} %, "
                 f"peak {r['scipy_default_peak_gb']:.2f} GB, ok={r['scipy_ok']}" if "scipy_default_s" in r else ""),
              flush=True)
    for name, degree in sorted({(r["scene"], r["degree"]) for r in rows}):
        sel = [r for r in rows if r["scene"] == name and r["degree"] == degree]
        if len(sel) >= 2:
            n = np.log([r["unknowns"] for r in sel])
            fits = {k: np.polyfit(n, np.log([r[k] for r in sel]), 1)[0]
                    for k in ("default_s", "pardiso_s", "superlu_s") if all(r[k] == r[k] for r in sel)}
            print(f"growth {name} P{degree}: " + ", ".join(f"{k} N^{v:.2f}" for k, v in fits.items()))
    Path(args.csv).parent.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(args.csv, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    print("wrote", args.csv)


if __name__ == "__main__":
    main()
