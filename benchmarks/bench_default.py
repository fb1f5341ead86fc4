"""Benchmark: the default ``cc.solve(scene)`` against one sparse direct solve of the bonded scene.

Scene: the two-block PZT-5A on PZT-4 scene of ``bench_contact.py`` (non-matching meshes, condition
gamma3). Each size runs in a fresh subprocess (its own peak memory), three times; the medians are
reported. Per run:

* ``default``: ``cc.solve(scene)`` from the Scene to the Solution, first solve (a new
  ContactSolver each run): assembly included (``default_total_s``), and without it
  (``default_s`` = total - ``sol.timings["assembly"]``);
* ``bonded`` (the yardstick): the two bodies glued on Gamma_3, i.e. the mixed system (26) with
  [u_nu] = 0 held at every merged node: one KKT matrix, one SciPy SuperLU factorisation and solve
  (MMD on A^T + A, threshold pivoting), from the scaled blocks (assembly excluded, reported once);
* ``separate`` (the lower floor): each body solved alone without contact (SuperLU, symmetric mode);
* ``pardiso``: the bonded KKT system with Intel MKL PARDISO through ``pypardiso``, if installed
  (``pip install ".[bench]"``).

Ratios: ``default_s / bonded_s`` (both without assembly) and ``default_total_s / (bonded_s +
assembly_s)``; accuracy: the solution's residuals of (26)-(27) and the bonded solve's relative
residual. The target is default <= 2 x bonded at ~1.5e5 unknowns.

Run:  python benchmarks/bench_default.py [--sizes 60 120 240] [--runs 3] [--csv FILE]
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

sys.path[:0] = [str(Path(__file__).resolve().parents[1]), str(Path(__file__).resolve().parent)]  # this checkout
from bench_contact import bonded_solve, removed_solve, scaled_blocks, scene  # noqa: E402


def pardiso_solve(blocks, jumps):
    """The bonded KKT system of :func:`bench_contact.bonded_solve`, solved by MKL PARDISO; None if absent."""
    try:
        import pypardiso
    except ImportError:
        return None
    import scipy.sparse as sp

    from cvxcontact.backends.condensed import quasi_definite

    t0 = time.perf_counter()
    parts = [quasi_definite(b) for b in blocks]
    A = sp.block_diag([S for S, _ in parts])
    G = sp.hstack([sp.hstack([J, sp.csr_matrix((J.shape[0], S.shape[0] - J.shape[1]))])
                   for J, (S, _) in zip(jumps, parts)])
    K = sp.bmat([[A, G.T], [G, None]], format="csr")
    rhs = np.concatenate([F for _, F in parts] + [np.zeros(G.shape[0])])
    z = pypardiso.spsolve(K, rhs)
    t = time.perf_counter() - t0
    return t, float(np.linalg.norm(K @ z - rhs) / np.linalg.norm(rhs))


def one_run(nx):
    import cvxcontact as cc

    sc = scene(nx)
    t0 = time.perf_counter()
    sol = cc.solve(sc)                                              # the default: method="auto"
    total = time.perf_counter() - t0
    t_asm_default = sol.timings["assembly"]

    blocks, t_asm = scaled_blocks(sc)
    t_bonded, bonded_res, n_kkt = bonded_solve(blocks, [b.jump for b in blocks])
    t_sep, sep_res = removed_solve(blocks)
    pardiso = pardiso_solve(blocks, [b.jump for b in blocks])
    n = sum(b.Kuu.shape[0] + (b.Kpp.shape[0] if b.Kpp is not None else 0) for b in blocks)
    res = sol.residuals()
    return dict(nx=nx, unknowns=n, kkt_size=n_kkt, merged_nodes=sc.interface.size, method=sol.info.method,
                route=str(sol.info.route), iterations=sol.info.iterations, ok=sol.ok,
                default_total_s=total, default_assembly_s=t_asm_default, default_s=total - t_asm_default,
                factorization_s=sol.timings.get("factorization", 0.0),
                model_compile_s=sol.timings.get("model", 0.0) + sol.timings.get("compile", 0.0),
                assembly_s=t_asm, bonded_s=t_bonded, bonded_residual=bonded_res, separate_s=t_sep,
                separate_residual=sep_res,
                pardiso_s=pardiso[0] if pardiso else float("nan"),
                pardiso_residual=pardiso[1] if pardiso else float("nan"),
                **{f"res_{k}": v for k, v in res.items()})


def one_size(nx, runs):
    rows = [one_run(nx) for _ in range(runs)]
    out = {}
    for key, value in rows[0].items():
        if isinstance(value, float):
            out[key] = statistics.median(r[key] for r in rows)
        else:
            out[key] = value
    out["runs"] = runs
    out["ratio"] = out["default_s"] / out["bonded_s"]
    out["ratio_with_assembly"] = out["default_total_s"] / (out["bonded_s"] + out["assembly_s"])
    out["ratio_to_separate"] = out["default_s"] / out["separate_s"]
    out["ratio_to_pardiso"] = out["default_s"] / out["pardiso_s"] if out["pardiso_s"] == out["pardiso_s"] else float("nan")
    out["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=int, nargs="+", default=[60, 120, 240])
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "default.csv"))
    p.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        print(json.dumps(one_size(args.one, args.runs)))
        return
    rows = []
    for nx in args.sizes:
        out = subprocess.run([sys.executable, __file__, "--one", str(nx), "--runs", str(args.runs)],
                             capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(r)
        print(f"nx={nx:4d} unknowns={r['unknowns']:7d} [{r['method']}, {r['iterations']} it] "
              f"default {r['default_s']:6.2f} s (+ assembly {r['default_assembly_s']:5.2f})  "
              f"bonded {r['bonded_s']:6.2f} s  separate {r['separate_s']:6.2f} s  "
              f"pardiso {r['pardiso_s']:6.2f} s  ratio {r['ratio']:4.2f} (with assembly "
              f"{r['ratio_with_assembly']:4.2f}, to separate {r['ratio_to_separate']:4.2f})  "
              f"eq {r['res_equilibrium']:.1e} compl {r['res_complementarity']:.1e} "
              f"bonded res {r['bonded_residual']:.1e}  peak {r['peak_rss_gb']:.2f} GB", flush=True)
    Path(args.csv).parent.mkdir(parents=True, exist_ok=True)
    with open(args.csv, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[-1]))
        w.writeheader()
        w.writerows(rows)
    print("wrote", args.csv)


if __name__ == "__main__":
    main()
