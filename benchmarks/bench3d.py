"""Benchmark: the default 3D ``cc.solve`` (P1 tetrahedra) against two solves of the bonded scene.

Scenes (tests/scenes3d.py, P1, the contact condition ``--condition``, default "sigma1"):

* ``two_boxes(n)``: a PZT-5A box [0, 1] x [0, 1] x [0, 0.5] m (n x n x n/2 cells, clamped and grounded on
  top, body force 2e9 N/m^3 downwards, traction 3e8 N/m^2 along z on its right face, surface charge
  -0.05 C/m^2 on its left face) on an aluminium box [0, 1] x [0, 1] x [-0.5, 0] m (about 0.7 n cells a
  side, clamped at the bottom): non-matching faces on z = 0, the 3D analogue of ``demo.two_blocks``.
  ``--elastic`` makes the upper box aluminium too (no potentials).
* ``sphere`` (``sphere_into_block(n)``): an aluminium block [-1, 1]^2 x [-1, 0] m (n x n x n/2 cells, clamped at the bottom)
  pressed 0.02 m deep by a fixed rigid sphere of radius 2 m (``cc.Rigid.sphere``): a Hertz contact whose
  zone (radius about 0.2 m) is a small part of the rows (one per top node).

A size is a count of unknowns N (>= 1e3), turned into n (two_boxes N ~ 2.8 n^3 with potentials, 2.2 n^3
without; sphere N ~ 1.65 n^3), or n itself (< 1e3). Each part of each case runs in a fresh subprocess,
so that its peak memory (``resource.getrusage`` maxrss) is its own (benchmarks/harness.py: the subprocesses,
medians, CSV and Markdown, and the bonded yardsticks).

Parts of one case:

* ``default``: ``cc.ContactSolver(scene).solve()`` as ``cc.solve`` runs it (``method="auto"``), from the
  Scene to the checked Solution; ``default_s`` excludes assembly (``assembly_s``, ``sol.timings``); the
  other ``sol.timings`` stages, the route, the number of systems solved (``steps``), factorisations and
  column solves of the sparse route, and the solution's residuals of (26)-(27) (docs/checks.md).
* ``bonded`` (the yardsticks): the same scaled blocks with every contact row closed, [u_nu] = g at every
  row (the rows' own E), i.e. the mixed system K = [[S, G^T], [G, 0]] of the free dofs and the rows,
  assembled once (excluded), then solved from scratch:
  - ``pardiso_s``: Intel oneMKL PARDISO, real symmetric indefinite with weighted matching
    (:class:`cvxcontact.backends.factor.PardisoSymmetric`: analysis + factorisation + solve);
  - ``amg_s``: smoothed-aggregation AMG (pyamg, ``pip install pyamg``) with the rigid-body modes of each
    body as near-null space, preconditioned CG to a relative residual 1e-10 (GMRES with the AMG route's block
    upper-triangular preconditioner, a V-cycle for u and one for phi, for a piezoelectric body) on the bonded
    system with its constraints eliminated exactly (each row solved for its own dof, the dof of largest
    coefficient, which no other row touches: sigma1 and rigid obstacles; not gamma3), setup + solve.
    Its answer is checked against PARDISO's (``amg_vs_pardiso``, max |a - b| / max |b| of x).
  ``bonded_s`` is the faster of the two. ``solver_build_cpu_s`` (default part) and
  ``bonded_solver_build_cpu_s`` (bonded part; one key for both let the bonded part's overwrite the default's in
  the merged row): the CPU seconds of the ContactSolver's construction (the assembly; after a first small one
  for the imports). Not in either
  yardstick's seconds: the bonded system's assembly (``bonded_build_s``, CPU ``bonded_build_cpu_s``) and the
  AMG yardstick's elimination (``amg_reduce_s``, CPU ``amg_reduce_cpu_s``).

Run (one thread per process: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 python benchmarks/bench3d.py --sizes 1e5 5e5 1e6 \
        [--scenes two_boxes sphere] [--runs 1] [--csv benchmarks/results/bench3d.csv] [--md FILE]

Printed and written: one row per case with both parts, ``default_s / bonded_s`` (and to each yardstick),
peak memory of each part, and growth exponents (least-squares slope of log time against log N) per scene.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes
sys.path.insert(0, str(Path(__file__).resolve().parent))              # harness

from harness import (StageTimes, amg_bonded, bonded_system, cell, growth, load, markdown_table,  # noqa: E402
                     median_row, pardiso_symmetric, peak_gb, rel, residual, run_part, side_cells, unknowns,
                     write_csv)

SCENES = ("two_boxes", "sphere")


def cells(scene: str, size: float, elastic: bool) -> int:
    """n for a size: n itself below 1e3, else a count of unknowns (module docstring), even."""
    return side_cells(size, {"two_boxes": 2.2 if elastic else 2.8, "sphere": 1.65}[scene])


def make(scene, n, condition, elastic):
    """The scene ``scene`` (tests/scenes3d.py: ``two_boxes`` or ``sphere_into_block``) at n cells a side."""
    from scenes3d import sphere_into_block, two_boxes

    return two_boxes(n, condition, elastic) if scene == "two_boxes" else sphere_into_block(n)


# ------------------------------------------------------------------------------------------------ default

def cpu_stages() -> StageTimes:
    """Inclusive CPU timers (harness.StageTimes) on the AMG route's stages and the read-back (``--cpu-stages``:
    the solve's stage split in CPU seconds, ``sol.timings`` being wall seconds); the route's CG / GMRES calls
    inside the active-set steps are its Krylov solves, V-cycles and products included."""
    import importlib

    import scipy.sparse.linalg as spla

    from cvxcontact.backends import amg

    solve_module = importlib.import_module("cvxcontact.solve")      # the module (cc.solve is the function)

    st = StageTimes()
    kc = amg.KrylovContact
    for name, label in (("__init__", "KrylovContact built (S stacked, own dofs)"),
                        ("solve", "active-set steps (KrylovContact.solve)"),
                        ("_system", "  one set's solve (_system)"),
                        ("_reduced", "    the set's operator (_reduced)"),
                        ("_diagonal_blocks", "    K's diagonal blocks for the set-up"),
                        ("_hierarchy", "    hierarchy set-up (pyamg)"),
                        ("_precondition", "    the set's preconditioner")):
        st.wrap(kc, name, label)
    st.wrap(spla, "cg", "    Krylov solves (CG)")
    st.wrap(amg, "gmres", "    Krylov solves (GMRES)")
    st.wrap(solve_module.ContactSolver, "_read", "read-back, checks, estimate")
    return st


def default_part(scene, n, condition, elastic, runs, stages=False):
    import cvxcontact as cc

    cc.solve(make(scene, 4, condition, elastic))                        # imports, first-call set-up
    st = cpu_stages() if stages else None
    rows = []
    for _ in range(runs):
        sc = make(scene, n, condition, elastic)
        t0, c0 = time.perf_counter(), time.process_time()
        solver = cc.ContactSolver(sc)
        t_asm, c_asm = time.perf_counter() - t0, time.process_time() - c0
        sol = solver.solve()
        total, cpu = time.perf_counter() - t0, time.process_time() - c0
        tm = {k: float(v) for k, v in dict(sol.timings).items()}
        sparse = solver.cache.sparse
        rows.append(dict(default_total_s=total, assembly_s=tm.get("assembly", 0.0),
                         default_s=total - tm.get("assembly", 0.0), default_cpu_s=cpu - c_asm,
                         solver_build_s=t_asm, solver_build_cpu_s=c_asm,
                         **{f"t_{k}": v for k, v in tm.items() if k != "assembly"},
                         method=sol.info.method, route=str(sol.info.route), steps=sol.info.iterations,
                         factorization=sol.info.factorization or "-", ok=bool(sol.ok),
                         factorizations=getattr(sparse, "factorizations", -1),
                         column_solves=getattr(sparse, "column_solves", -1),
                         krylov_iterations=getattr(solver.cache.amg, "iterations", -1),
                         hierarchies=getattr(solver.cache.amg, "setups", -1),
                         active_rows=int(np.sum(solver.cache.active)) if solver.cache.active is not None else -1,
                         **{f"res_{k}": float(v) for k, v in sol.residuals().items()}))
        N, m = unknowns(solver.problem), int(solver.problem.E.shape[0])
        del solver, sol
    if st is not None:       # summed over the runs: per run
        rows[0]["cpu_stages"] = {label: [calls / runs, inc / runs] for label, (calls, inc, _) in st.acc.items()}
    out = median_row(rows)
    out.update(unknowns=N, contact_rows=m, default_peak_gb=peak_gb())
    return out


# ------------------------------------------------------------------------------------------------ bonded

def bonded_part(scene, n, condition, elastic, runs, pardiso=True):
    """Both yardsticks on the bonded system, AMG first (its peak memory is then its own), PARDISO if ``pardiso``."""
    import cvxcontact as cc

    cc.solve(make(scene, 4, condition, elastic))                        # imports, first-call set-up
    sc = make(scene, n, condition, elastic)
    c0 = time.process_time()
    solver = cc.ContactSolver(sc)
    build_cpu = time.process_time() - c0
    problem = solver.problem
    t0, c0 = time.perf_counter(), time.process_time()
    K, rhs, A, G, sizes = bonded_system(problem)
    nan = float("nan")
    out = dict(kkt_size=int(K.shape[0]), bonded_build_s=time.perf_counter() - t0,
               bonded_solver_build_cpu_s=build_cpu,
               bonded_build_cpu_s=time.process_time() - c0, amg_s=nan, amg_cpu_s=nan,
               amg_iterations=-1, amg_reduce_s=nan, amg_reduce_cpu_s=nan, amg_vs_pardiso=nan, amg_residual=nan, pardiso_s=nan,
               pardiso_cpu_s=nan)
    x = None
    try:
        import pyamg  # noqa: F401
        res = [amg_bonded(problem, A, G, rhs, sizes) for _ in range(runs)]
        if all(r is not None for r in res):
            x = res[-1][1]
            out.update(amg_s=statistics.median(r[0] for r in res), amg_cpu_s=statistics.median(r[5] for r in res),
                       amg_iterations=res[-1][2], amg_reduce_s=res[-1][3], amg_residual=res[-1][4],
                       amg_reduce_cpu_s=res[-1][6])
    except ImportError:
        pass
    out["amg_peak_gb"] = peak_gb()
    if pardiso:
        ts = [pardiso_symmetric(K, rhs) for _ in range(runs)]
        z = ts[-1][1]
        out.update(pardiso_s=statistics.median(t[0] for t in ts), pardiso_cpu_s=statistics.median(t[3] for t in ts),
                   pardiso_perturbed=int(ts[-1][2]),
                   pardiso_residual=residual(K, z, rhs))
        if x is not None:
            out["amg_vs_pardiso"] = rel(x, z[:A.shape[0]])
    out["bonded_peak_gb"] = peak_gb()
    return out


def case(scene, size, condition, elastic, runs, parts, pardiso_up_to=float("inf"), stages=False):
    n = cells(scene, size, elastic)
    row = dict(scene=scene, n=n, condition=condition, elastic=elastic or scene == "sphere", load=load())
    a = dict(scene=scene, n=n, condition=condition, elastic=elastic, runs=runs)
    if "default" in parts:
        row.update(run_part(__file__, dict(a, part="default", stages=stages)))
    if "bonded" in parts:
        row.update(run_part(__file__, dict(a, part="bonded", pardiso=bool(size <= pardiso_up_to))))
    nan = float("nan")
    yard = [row.get(k, nan) for k in ("pardiso_s", "amg_s")]
    row["bonded_s"] = min((y for y in yard if y == y), default=nan)
    d = row.get("default_s", nan)
    row["ratio_bonded"] = d / row["bonded_s"]
    row["ratio_pardiso"] = d / row.get("pardiso_s", nan)
    row["ratio_amg"] = d / row.get("amg_s", nan)
    cpu = [row.get(k, nan) for k in ("pardiso_cpu_s", "amg_cpu_s")]
    row["ratio_bonded_cpu"] = row.get("default_cpu_s", nan) / min((c for c in cpu if c == c), default=nan)
    return row


def growth_lines(rows):
    """One line of growth exponents per scene (two sizes or more)."""
    keys = ("default_s", "default_cpu_s", "pardiso_s", "amg_s", "amg_cpu_s", "default_peak_gb")
    fits = {name: growth([r for r in rows if r["scene"] == name], keys) for name in sorted({r["scene"] for r in rows})}
    return [f"growth {name}: {text}" for name, text in fits.items() if text is not None]


def summary(r) -> str:
    g = lambda k, f="{:.2f}": cell(r, k, f)  # noqa: E731
    return (f"{r['scene']} n={r['n']}: {g('unknowns', '{:,}')} unknowns, {g('contact_rows', '{}')} rows "
            f"[{r.get('method', '-')}/{r.get('factorization', '-')}, {r.get('route', '-')}, {g('steps', '{}')} "
            f"steps, {g('factorizations', '{}')} factorisations, {g('column_solves', '{}')} column solves, "
            f"{g('krylov_iterations', '{}')} Krylov iterations] "
            f"default {g('default_s')} s, CPU {g('default_cpu_s')} s (+ assembly {g('assembly_s')}; factorisation "
            f"{g('t_factorization')}, AMG setup {g('t_amg_setup')}, active set {g('t_active_set')}) ok={r.get('ok', '-')} "
            f"compl {g('res_complementarity', '{:.1e}')} | PARDISO {g('pardiso_s')} s (CPU {g('pardiso_cpu_s')}), AMG-CG "
            f"{g('amg_s')} s (CPU {g('amg_cpu_s')}) "
            f"({g('amg_iterations', '{}')} it., vs PARDISO {g('amg_vs_pardiso', '{:.1e}')}) | default/bonded "
            f"{g('ratio_bonded')} (/PARDISO {g('ratio_pardiso')}, /AMG {g('ratio_amg')}) | peak default "
            f"{g('default_peak_gb')} GB, bonded {g('bonded_peak_gb')} GB | load {r['load']}")


def markdown(rows) -> str:
    head = ["scene", "unknowns", "contact rows", "route", "steps (Krylov it.)", "default [s] (CPU)", "assembly [s]",
            "PARDISO bonded [s] (CPU)", "AMG-CG bonded [s] (CPU, it.)", "default / faster bonded: wall (CPU)",
            "/ PARDISO", "/ AMG", "peak default [GB]", "peak AMG / PARDISO [GB]", "ok", "load"]
    f = cell
    return markdown_table(head, [[r["scene"], f(r, "unknowns", "{:,}"), f(r, "contact_rows", "{}"),
                         f"{r.get('method', '-')}/{r.get('factorization', '-')}",
                         f"{f(r, 'steps', '{}')} ({f(r, 'krylov_iterations', '{}')})",
                         f"{f(r, 'default_s')} ({f(r, 'default_cpu_s')})", f(r, "assembly_s"),
                         f"{f(r, 'pardiso_s')} ({f(r, 'pardiso_cpu_s')})",
                         f"{f(r, 'amg_s')} ({f(r, 'amg_cpu_s')}, {f(r, 'amg_iterations', '{}')})",
                         f"**{f(r, 'ratio_bonded')}** ({f(r, 'ratio_bonded_cpu')})", f(r, "ratio_pardiso"),
                         f(r, "ratio_amg"), f(r, "default_peak_gb"), f"{f(r, 'amg_peak_gb')} / {f(r, 'bonded_peak_gb')}",
                         str(r.get("ok", "-")), r["load"]] for r in rows])


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="*", default=[1e5, 5e5])
    p.add_argument("--scenes", nargs="*", default=list(SCENES), choices=SCENES)
    p.add_argument("--condition", default="sigma1", choices=("sigma1", "sigma2", "gamma3"))
    p.add_argument("--elastic", action="store_true", help="two_boxes: an aluminium upper box (no potentials)")
    p.add_argument("--parts", nargs="*", default=["default", "bonded"], choices=("default", "bonded"))
    p.add_argument("--runs", type=int, default=1)
    p.add_argument("--pardiso-up-to", type=float, default=float("inf"),
                   help="the PARDISO yardstick only for sizes up to this (it grows like N^2)")
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "bench3d.csv"))
    p.add_argument("--md", help="also write the table as Markdown to this file")
    p.add_argument("--append", action="store_true", help="append to the CSV instead of replacing it")
    p.add_argument("--cpu-stages", action="store_true",
                   help="the default solve's stages in CPU seconds (printed; the CSV's cpu_stages column)")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        if a["part"] == "default":
            print(json.dumps(default_part(a["scene"], a["n"], a["condition"], a["elastic"], a["runs"],
                                          a.get("stages", False))))
        else:
            print(json.dumps(bonded_part(a["scene"], a["n"], a["condition"], a["elastic"], a["runs"], a["pardiso"])))
        return
    rows = []
    for scene in args.scenes:
        for size in args.sizes:
            r = case(scene, size, args.condition, args.elastic, args.runs, args.parts, args.pardiso_up_to,
                     args.cpu_stages)
            rows.append(r)
            print(summary(r), flush=True)
            for label, (calls, inc) in r.get("cpu_stages", {}).items():
                print(f"    CPU {label:44s} calls {calls:6.1f}  inclusive {inc:9.2f} s", flush=True)
    for line in growth_lines(rows):
        print(line)
    print("wrote", write_csv(args.csv, rows, append=args.append))
    if args.md:
        Path(args.md).write_text(markdown(rows) + "\n")
        print("wrote", args.md)


if __name__ == "__main__":
    main()
