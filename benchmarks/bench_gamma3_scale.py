"""Benchmark: the default 3D condition "gamma3" (P1, two elastic boxes with non-matching faces on z = 0,
tests/scenes3d.py ``two_boxes(n, "gamma3", elastic=True)``) on the default route (``method="auto"``: condensed,
interior point + exact finish of dependent rows), stage by stage, this checkout against another one (``--before``,
e.g. an export of an earlier commit: ``git archive <commit> | tar -x -C DIR``), in one run.

Each (size, checkout) is a fresh subprocess (one thread; its peak memory, ``ru_maxrss``, its own) that builds the
scene, solves it from the Scene to the checked Solution and prints: the CPU seconds of ContactSolver construction
(assembly) and of ``solve()`` (``time.process_time``), its stages in CPU seconds (the child replaces
``time.perf_counter`` by ``time.process_time`` before importing the package, so that ``sol.timings`` counts CPU:
the machine is shared): "factorization" (the bodies' factorisations with their Schur blocks and the interface
compliance), the interior point (the rest of the solve's CPU less every other stage: CVXPY's compilation and
Clarabel, whose own clock is wall time) and "polish" (the exact finish); the unknowns, rows, the final active rows, the steps (``sol.info.iterations``: the interior point's and the
finish's),
``sol.ok`` and the fields. The answers of the two checkouts are compared:
max |u_after - u_before| / max |u_before| over both bodies (the finish is exact: rounding).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_gamma3_scale.py \\
        --sizes 5e4 1.5e5 --before /tmp/before [--md FILE] [--limit 16] [--only after]

Each child runs under a watchdog that ends it above ``--limit`` GB resident (default 16).

``--release free|keep|auto`` (and ``--release-before`` for the other checkout, which must have
``cvxcontact.backends.budget``): the bodies' factorisations freed once their Sigma is taken and re-made for the
back-substitution, kept, or as the memory budget decides (the default of the package; without the option the
child leaves the package's default). Forced against kept on this checkout alone:

    python benchmarks/bench_gamma3_scale.py --sizes 1.5e5 --before . --release-before keep --release free --limit 8

``--bonded``: after each size's runs, one bonded solve of the same mesh in a fresh process (the project's
yardstick, ``bench3d.py``'s bonded part: PARDISO on the mixed system with every contact row closed; its CPU
seconds and peak), and the ratios of this checkout's solve to it, the solve alone and with the assembly.

``--amg``: after each size's runs, on the same mesh (the same unknowns; two_boxes with "sigma1" rows), two more
fresh processes of ``bench3d.py``: "sigma1" on its default route (the AMG active set) from the Scene to the checked
Solution, and the other yardstick, one bonded AMG-CG solve (``bench3d.py``'s ``amg_bonded``: smoothed-aggregation
CG to 1e-10 on the bonded system with the nodal rows eliminated; setup + solve, the bonded system's assembly and
the elimination left out, 0.42 + 0.21 CPU s beside 6.3 at 1.5e5: its JSON's ``bonded_build_cpu_s`` and
``amg_reduce_cpu_s``; it cannot take the "gamma3" rows, which share their dofs). Printed: each CPU second, each
peak, and the ratios of "gamma3" and "sigma1" to it, the solve alone and with the assembly on both sides (the
yardstick's: its ContactSolver's construction). One command for both ratios, this checkout alone:

    python benchmarks/bench_gamma3_scale.py --sizes 1.5e5 --only after --amg --limit 3

The "back-substitution s" column is the stage "back_substitution" (with the factors freed: the interior
factorisations re-made, one body at a time); "released" is ``sol.info.released``.

A size is a count of unknowns (n from ``bench3d.cells``: N ~ 2.2 n^3) or n itself (< 1e3).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench3d import cells
from harness import run_part

CHILD = """
import json, os, resource, sys, threading, time
def watchdog(limit):                           # ends the run above the limit (GB resident), before the machine does
    while True:
        with open("/proc/self/statm") as f:
            if int(f.read().split()[1]) * resource.getpagesize() > limit * 2**30:
                print(json.dumps(dict(killed=limit)), flush=True)
                os._exit(3)
        time.sleep(0.05)
threading.Thread(target=watchdog, args=({limit},), daemon=True).start()
time.perf_counter = time.process_time          # sol.timings in this process's CPU seconds (one thread)
sys.path.insert(0, {root!r}); sys.path.insert(0, {tests!r})
import numpy as np
import cvxcontact as cc
from scenes3d import two_boxes
if {release!r} is not None:
    import cvxcontact.backends.budget as budget
    budget.RELEASE = {release!r}
cc.solve(two_boxes(4, "gamma3", True))                       # imports, first-call set-up
scene = two_boxes({n}, "gamma3", True)
c0 = time.process_time()
solver = cc.ContactSolver(scene)
c1 = time.process_time()
sol = solver.solve()
c2 = time.process_time()
np.savez({out!r}, *[np.asarray(u) for u in sol.u])
print(json.dumps(dict(code=cc.__file__, N=int(solver.problem.unknowns), m=int(solver.problem.E.shape[0]),
                      assembly_cpu=c1 - c0, solve_cpu=c2 - c1, ok=bool(sol.ok), route=str(sol.info.route),
                      active=-1 if solver.cache.active is None else int(np.sum(solver.cache.active)),
                      iterations=int(sol.info.iterations), polished=bool(getattr(sol, "polished", True)),
                      released=bool(getattr(sol.info, "released", False)),
                      timings={{k: float(v) for k, v in dict(sol.timings).items()}},
                      peak_gb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20)))
"""


RELEASE = {"free": True, "keep": False, "auto": None}


def run(root: Path, n: int, out: str, limit: float = 16.0, release: str | None = None) -> dict:
    code = CHILD.format(root=str(root), tests=str(ROOT / "tests"), n=n, out=out, limit=limit,
                        release=None if release is None else RELEASE[release])
    res = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True)
    if res.returncode:
        raise RuntimeError((res.stdout + res.stderr)[-3000:])
    return json.loads(res.stdout.strip().splitlines()[-1])


def amg_table(amg: list) -> list[str]:
    """The lines of the AMG yardstick's table: per size, one line per checkout's "gamma3" and one for "sigma1"
    (its default route; the same mesh, so the same unknowns), CPU seconds, against one bonded AMG-CG solve
    (setup + solve; with the assembly: plus each side's ContactSolver construction)."""
    head = ("| unknowns (before supports) | condition (code) | route | assembly CPU s | solve CPU s "
            "| bonded AMG-CG CPU s (it.) "
            "| yardstick's assembly CPU s | solve / AMG-CG | (assembly + solve) / (assembly + AMG-CG) "
            "| peak GB: run / AMG-CG | ok |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for n, s1, y, rs in amg:
        ya, yc = y["bonded_solver_build_cpu_s"], y["amg_cpu_s"]
        runs = [(f'"gamma3" ({name})', r["N"], r["route"], r["assembly_cpu"], r["solve_cpu"], r["peak_gb"], r["ok"])
                for name, r in rs.items()]
        runs.append(('"sigma1"', runs[0][1], s1["route"], s1["solver_build_cpu_s"], s1["default_cpu_s"],
                     s1["default_peak_gb"], s1["ok"]))
        for label, N, route, a, c, peak, ok in runs:
            out.append(f"| {N:,} | {label} | {route} | {a:.1f} | {c:.1f} | {yc:.1f} ({y['amg_iterations']}) | "
                       f"{ya:.1f} | {c / yc:.2f} | {(a + c) / (ya + yc):.2f} | {peak:.2f} / {y['amg_peak_gb']:.2f} "
                       f"| {ok} |")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[5e4])
    ap.add_argument("--before", type=Path, default=None,
                    help="the other checkout (its cvxcontact is imported); not needed with --only after")
    ap.add_argument("--md", type=Path, default=None, help="append the table to this file")
    ap.add_argument("--limit", type=float, default=16.0, help="GB resident at which a run is ended (watchdog)")
    ap.add_argument("--only", choices=("before", "after"), default=None,
                    help="run one checkout only (no du/u; e.g. a size too long for both)")
    ap.add_argument("--release", choices=tuple(RELEASE), default=None,
                    help="this checkout: the factors freed after Sigma, kept, or by the memory budget")
    ap.add_argument("--bonded", action="store_true",
                    help="also one bonded PARDISO solve of the same mesh (bench3d.py's yardstick), and the ratios")
    ap.add_argument("--amg", action="store_true",
                    help='also "sigma1" (AMG route) and one bonded AMG-CG solve of the same mesh, and the ratios')
    ap.add_argument("--release-before", choices=tuple(RELEASE), default=None, help="the same for --before")
    args = ap.parse_args()
    if args.before is None and args.only != "after":
        ap.error("--before is needed unless --only after")
    head = ("| unknowns | rows | active rows | code | released | steps | solve CPU s | factorisation s | interior point s "
            "| finish s | back-substitution s | assembly s | peak GB | after / before (CPU) | du/u | ok |")  # CPU s
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    bonded, amg = [], []
    print(lines[0], flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for size in args.sizes:
            n = cells("two_boxes", size, True)
            res = {}
            names = [args.only] if args.only else ["before", "after"]
            for name, root, release in (("before", args.before, args.release_before), ("after", ROOT, args.release)):
                if name in names:
                    res[name] = run(root.resolve(), n, os.path.join(tmp, f"{name}{n}.npz"), args.limit, release)
            du = float("nan")
            if len(res) == 2:
                ub = [np.load(os.path.join(tmp, f"before{n}.npz"))[k] for k in ("arr_0", "arr_1")]
                ua = [np.load(os.path.join(tmp, f"after{n}.npz"))[k] for k in ("arr_0", "arr_1")]
                du = max(np.abs(a - b).max() for a, b in zip(ua, ub)) / max(np.abs(b).max() for b in ub)
            for name in names:
                r = res[name]
                t = r["timings"]
                ratio = r["solve_cpu"] / res[names[0]]["solve_cpu"]
                ipm = r["solve_cpu"] - sum(v for k, v in t.items() if k not in ("compile", "solve", "assembly"))
                lines.append(f"| {r['N']:,} | {r['m']:,} | {r['active']:,} | {name} | {r.get('released', False)} | "
                             f"{r['iterations']} | {r['solve_cpu']:.1f} | "
                             f"{t['factorization']:.1f} | {ipm:.1f} | {t['polish']:.1f} | "
                             f"{t.get('back_substitution', 0.0):.1f} | {r['assembly_cpu']:.1f}"
                             + f" | {r['peak_gb']:.2f} | {ratio:.2f} | {du:.1e} | {r['ok']} |")
                print(lines[-1], flush=True)
            if args.bonded:
                part = {"scene": "two_boxes", "n": n, "condition": "gamma3", "elastic": True, "runs": 1,
                        "part": "bonded", "pardiso": True}
                b = run_part(ROOT / "benchmarks" / "bench3d.py", part)
                bonded.append((n, b, {name: res[name] for name in names}))
                print(json.dumps({"n": n, "bonded": b}), flush=True)
            if args.amg:
                base = {"scene": "two_boxes", "n": n, "condition": "sigma1", "elastic": True, "runs": 1}
                s1 = run_part(ROOT / "benchmarks" / "bench3d.py", dict(base, part="default"))
                y = run_part(ROOT / "benchmarks" / "bench3d.py", dict(base, part="bonded", pardiso=False))
                amg.append((n, s1, y, {name: res[name] for name in names}))
                print(json.dumps({"n": n, "sigma1": s1, "amg_bonded": y}), flush=True)
    if bonded:
        bh = ("| unknowns | code | assembly CPU s | solve CPU s | bonded PARDISO CPU s (wall) | solve / bonded (CPU) "
              "| (assembly + solve) / bonded | peak GB: default / bonded |")
        lines += ["", bh, "|" + "---|" * (bh.count("|") - 1)]
        for n, b, rs in bonded:
            for name, r in rs.items():
                lines.append(f"| {r['N']:,} | {name} | {r['assembly_cpu']:.1f} | {r['solve_cpu']:.1f} | "
                             f"{b['pardiso_cpu_s']:.1f} ({b['pardiso_s']:.1f}) | "
                             f"{r['solve_cpu'] / b['pardiso_cpu_s']:.2f} | "
                             f"{(r['assembly_cpu'] + r['solve_cpu']) / b['pardiso_cpu_s']:.2f} | "
                             f"{r['peak_gb']:.2f} / {b['bonded_peak_gb']:.2f} |")
        print("\n".join(lines[-len(bonded) * len(names) - 2:]), flush=True)
    if amg:
        lines += [""] + amg_table(amg)
        print("\n".join(lines[-len(amg) * (len(names) + 1) - 2:]), flush=True)
    print("load", " ".join(f"{x:.1f}" for x in os.getloadavg()))
    if args.md:
        with open(args.md, "a") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
