"""Benchmark: piezoelectric 3D scenes on the AMG route (``method="amg"``) against the sparse (direct) route and
the bonded yardsticks.

Scene: ``two_boxes(n)`` (tests/scenes3d.py) with potentials, a PZT-5A box (clamped and grounded on top, body force,
traction, surface charge) on an aluminium box, non-matching faces, "sigma1" (benchmarks/bench3d.py). A size
is a count of unknowns (about 2.8 n^3) or n itself (< 1e3).

Parts of one size, each in a fresh subprocess (its peak memory its own), one thread:

* ``amg``: ``cc.ContactSolver(scene, method="amg").solve()`` (assembly, in the constructor, excluded): wall and
  CPU seconds, active-set steps, Krylov iterations of all its solves, the solution's checks (``ok``).
* ``sparse``: the same with ``method="sparse"`` (PARDISO factorisations of the mixed system; up to
  ``--sparse-up-to`` unknowns), and the largest difference of the two answers (max |a - b| / max |b| of u, phi,
  contact force) when both ran (``--compare``: the sparse part then saves its answer for the amg part).
* ``bonded``: the bonded system (every contact row closed) as the route's first system, solved three ways:
  - ``triangular``: the route's own solve (:meth:`cvxcontact.backends.amg.KrylovContact._system`): GMRES with
    the block upper-triangular AMG preconditioner, hierarchy set-up included, to a relative residual 1e-10;
  - ``diagonal``: MINRES with the block-diagonal AMG preconditioner (the AMG route's previous solve,
    ``harness.amg_bonded``), tightened until the true residual is 1e-10;
  - PARDISO (``harness.pardiso_symmetric``: analysis + factorisation + solve), up to ``--pardiso-up-to``.
  Iteration counts do not depend on the machine's load; times do.

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 python benchmarks/bench_piezo_amg.py --sizes 2e4 1e5 3e5 \
        [--sparse-up-to 1.5e5] [--pardiso-up-to 1.5e5] [--csv benchmarks/results/bench_piezo_amg.csv]

Printed: one line per size with the ratios amg / sparse, amg / PARDISO bonded, amg / AMG bonded (the
triangular solve) and the iteration counts; growth exponents (least squares of log time on log N).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scene
sys.path.insert(0, str(Path(__file__).resolve().parent))              # harness

from harness import (amg_bonded, bonded_system, cell, growth, load, pardiso_symmetric, peak_gb, rel,  # noqa: E402
                     run_part, side_cells, unknowns, write_csv)


def scene(n):
    """The PZT-5A box on an aluminium box, "sigma1" (tests/scenes3d.py ``two_boxes``)."""
    from scenes3d import two_boxes

    return two_boxes(n, "sigma1", elastic=False)


def answer(sol) -> np.ndarray:
    return np.concatenate([np.ravel(u) for u in sol.u] + [np.ravel(p) for p in sol.phi if p is not None]
                          + [np.ravel(sol.contact.force)])


def route_part(n, method, save=None, against=None):
    import cvxcontact as cc

    cc.solve(scene(4), method=method)                                   # imports, first-call set-up
    solver = cc.ContactSolver(scene(n), method=method)
    t0, c0 = time.perf_counter(), time.process_time()
    sol = solver.solve()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    tm = {k: float(v) for k, v in dict(sol.timings).items()}
    out = {f"{method}_s": wall, f"{method}_cpu_s": cpu, "assembly_s": tm.get("assembly", 0.0),    # (not in solve())
           f"{method}_steps": int(sol.info.iterations), f"{method}_ok": bool(sol.ok),
           f"{method}_route": sol.info.method,
           "unknowns": unknowns(solver.problem), "contact_rows": int(solver.problem.E.shape[0]),
           f"{method}_peak_gb": peak_gb()}
    if method == "amg":
        out.update(amg_krylov=int(solver.cache.amg.iterations), amg_setup_s=tm.get("amg_setup", 0.0))
    x = answer(sol)
    if save:
        np.save(save, x)
    if against and Path(against).exists():
        ref = np.load(against)
        out["amg_vs_sparse"] = rel(x, ref)
    return out


def bonded_part(n, pardiso=True):
    import cvxcontact as cc
    from cvxcontact.backends import amg
    from cvxcontact.backends.condensed import quasi_definite

    problem = cc.ContactSolver(scene(n)).problem
    out = {}
    # the route's own first system, every row closed: hierarchy + GMRES (block upper-triangular)
    t0, c0 = time.perf_counter(), time.process_time()
    kc = amg.KrylovContact(problem)
    F = np.concatenate([F for _, F in (quasi_definite(b) for b in problem.blocks)])
    x, _ = kc._system(kc.dof >= 0, F, np.asarray(problem.g, dtype=float), None, amg.RTOL)
    out.update(triangular_s=time.perf_counter() - t0, triangular_cpu_s=time.process_time() - c0,
               triangular_it=kc.iterations, triangular_setup_s=kc.setup_time)
    del kc
    K, rhs, A, G, sizes = bonded_system(problem)
    res = amg_bonded(problem, A, G, rhs, sizes, preconditioner="diagonal")     # MINRES, block-diagonal
    if res is not None:
        out.update(diagonal_s=res[0], diagonal_cpu_s=res[5], diagonal_it=res[2])
        out["triangular_vs_diagonal"] = rel(x, res[1])
    if pardiso:
        t, z, perturbed, c = pardiso_symmetric(K, rhs)
        out.update(pardiso_s=t, pardiso_cpu_s=c, pardiso_perturbed=int(perturbed))
        out["triangular_vs_pardiso"] = rel(x, z[:A.shape[0]])
    out["bonded_peak_gb"] = peak_gb()
    return out


def case(size, sparse_up_to, pardiso_up_to, tmp):
    n = side_cells(size, 2.8)
    row = dict(n=n, load=load())
    ref = str(Path(tmp) / f"sparse_{n}.npy")
    if size <= sparse_up_to:
        row.update(run_part(__file__, dict(part="route", n=n, method="sparse", save=ref)))
    row.update(run_part(__file__, dict(part="route", n=n, method="amg", against=ref)))
    row.update(run_part(__file__, dict(part="bonded", n=n, pardiso=bool(size <= pardiso_up_to))))
    nan = float("nan")
    for key, den in (("amg_over_sparse", "sparse_s"), ("amg_over_pardiso", "pardiso_s"),
                     ("amg_over_triangular", "triangular_s"), ("sparse_over_pardiso", "sparse_s")):
        num = "sparse_s" if key.startswith("sparse") else "amg_s"
        den = "pardiso_s" if key == "sparse_over_pardiso" else den
        row[key] = row.get(num, nan) / row.get(den, nan)
    row["amg_over_sparse_cpu"] = row.get("amg_cpu_s", nan) / row.get("sparse_cpu_s", nan)
    return row


def summary(r) -> str:
    g = lambda k, f="{:.2f}": cell(r, k, f)  # noqa: E731
    return (f"n={r['n']}: {g('unknowns', '{:,}')} unknowns, {g('contact_rows', '{}')} rows | amg {g('amg_s')} s "
            f"(CPU {g('amg_cpu_s')}; {g('amg_steps', '{}')} steps, {g('amg_krylov', '{}')} GMRES it., setup "
            f"{g('amg_setup_s')}) ok={r.get('amg_ok', '-')} | sparse {g('sparse_s')} s (CPU {g('sparse_cpu_s')}; "
            f"{g('sparse_steps', '{}')} steps) | amg/sparse {g('amg_over_sparse')} (CPU {g('amg_over_sparse_cpu')}), "
            f"answers {g('amg_vs_sparse', '{:.1e}')} | bonded: triangular {g('triangular_s')} s "
            f"({g('triangular_it', '{}')} it.), diagonal MINRES {g('diagonal_s')} s ({g('diagonal_it', '{}')} it.), "
            f"PARDISO {g('pardiso_s')} s | amg/PARDISO bonded {g('amg_over_pardiso')}, amg/AMG bonded "
            f"{g('amg_over_triangular')}, sparse/PARDISO bonded {g('sparse_over_pardiso')} | peak amg "
            f"{g('amg_peak_gb')} GB, sparse {g('sparse_peak_gb')} GB | load {r['load']}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="*", default=[2e4, 1e5, 3e5])
    p.add_argument("--sparse-up-to", type=float, default=1.5e5, help="the sparse route only up to this size")
    p.add_argument("--pardiso-up-to", type=float, default=1.5e5, help="the PARDISO yardstick only up to this size")
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "bench_piezo_amg.csv"))
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        if a["part"] == "route":
            print(json.dumps(route_part(a["n"], a["method"], a.get("save"), a.get("against"))))
        else:
            print(json.dumps(bonded_part(a["n"], a["pardiso"])))
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size in args.sizes:
            rows.append(case(size, args.sparse_up_to, args.pardiso_up_to, tmp))
            print(summary(rows[-1]), flush=True)
    fits = growth(rows, ("amg_s", "amg_cpu_s", "sparse_s", "pardiso_s", "triangular_s", "diagonal_s", "amg_peak_gb"))
    print("" if fits is None else "growth: " + fits)
    print("wrote", write_csv(args.csv, rows))


if __name__ == "__main__":
    main()
