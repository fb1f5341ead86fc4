"""Benchmark: a further load case through a prepared ContactSolver against its first solve, before and after.

Scene: ``apps.demo.two_blocks(nx)`` (P1, PZT-5A on aluminium, non-matching meshes; 6.3e5 unknowns at nx = 560).
One timed case, in a fresh subprocess of the same interpreter and environment per side and pair, with the package
imported from that side's tree (checked): an untimed ``cc.solve(two_blocks(4))`` (imports, first-call set-up),
then

* first: ``solver = cc.ContactSolver(scene); solver.solve()``, from the Scene to the checked Solution (assembly
  and the error estimate included, as ``cc.solve`` runs them);
* re-solve: ``other = scene.with_loads(0, ...)`` (the upper block's body force, traction and surface charge x
  0.37: a new Scene of the same geometry) and ``solver.solve(other)``, the new Scene's construction included;
* reference: ``cc.solve(other)`` from scratch (untimed): the re-solve's u, phi and contact forces must agree with
  it to ``--agree`` (1e-9 relative, max |a - b| / max |b|), else the run says DIFFERENT and exits with status 1.

Reported per side: the re-solve's share of the first solve (wall and process CPU time, medians over the pairs),
its stages (``sol.timings``), the before/after ratio of the re-solve's CPU time (median of the per-pair ratios),
and the agreement of each side's re-solve with its from-scratch reference and of the after-side's answers with the
before-side's. The baseline is a git revision (its ``cvxcontact/`` extracted by ``git archive``) or a directory
holding ``cvxcontact/``, as in benchmarks/bench_default.py (whose helpers it uses). Pairs alternate the order
(before-after, then after-before).

Run:  python benchmarks/bench_resolve.py --baseline main --sizes 560 --repeats 5 --threads 1 \\
          --report benchmarks/results/resolve.md
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import shlex
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parent))              # harness, bench_default

from bench_default import THREAD_VARS, _describe, _git, _ratio_stats, materialise
from harness import markdown_table, peak_gb, rel, run_part, write_report

SCALE = 0.37
"""The further load case: the upper block's loads times this."""


def resolve_part(root, nx, out):
    """One timed first solve and re-solve with the package imported from ``root`` (module docstring)."""
    sys.path.insert(0, root)
    import cvxcontact as cc
    from cvxcontact.apps import demo

    where = Path(cc.__file__).resolve().parent
    if where != Path(root).resolve() / "cvxcontact":
        raise RuntimeError(f"cvxcontact imported from {where}, not from {root}")
    cc.solve(demo.two_blocks(4))                                       # imports, first-call set-up
    scene = demo.two_blocks(nx)
    t0, c0 = time.perf_counter(), time.process_time()
    solver = cc.ContactSolver(scene)
    first = solver.solve()
    t_first, c_first = time.perf_counter() - t0, time.process_time() - c0
    s = SCALE
    t0, c0 = time.perf_counter(), time.process_time()
    other = scene.with_loads(0, body_force=(0.0, -2e9 * s), traction={"right": (0.0, 3e8 * s)},
                             surface_charge={"left": -0.05 * s})
    t_scene = time.perf_counter() - t0
    again = solver.solve(other)
    t_again, c_again = time.perf_counter() - t0, time.process_time() - c0
    direct = cc.solve(other)

    def fields(sol):
        return {"u": np.concatenate([np.ravel(x) for x in sol.u]),
                    "phi": np.concatenate([np.ravel(x) for x in sol.phi if x is not None]),
                    "force": np.concatenate([np.ravel(c.force) for c in sol.contacts])}

    a, d = fields(again), fields(direct)
    np.savez(out, **a)
    return {"first_s": t_first, "first_cpu": c_first, "resolve_s": t_again, "resolve_cpu": c_again,
            "scene_s": t_scene, "share": t_again / t_first, "share_cpu": c_again / c_first,
            "timings": {k: float(v) for k, v in dict(again.timings).items()},
            "first_timings": {k: float(v) for k, v in dict(first.timings).items()},
            "direct": {k: rel(a[k], d[k]) for k in a},
            "estimate": rel(again.estimate.absolute, direct.estimate.absolute),
            "ok": bool(first.ok and again.ok and direct.ok), "route": str(again.info.route),
            "dofs": int(a["u"].size + a["phi"].size), "peak_gb": peak_gb(), "package": str(where)}

def compare(args) -> int:
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ)
    if args.threads:
        env.update({k: str(args.threads) for k in THREAD_VARS[:3]})
    command = "python benchmarks/bench_resolve.py " + shlex.join(sys.argv[1:])
    started = datetime.datetime.now().astimezone()
    load0 = os.getloadavg()
    bad = False
    lines = []
    with tempfile.TemporaryDirectory(prefix="cvxcontact-resolve-") as tmp:
        base_root, base_label, _ = materialise(args.baseline, repo, tmp)
        dirty = bool(_git(repo, "status", "--porcelain", "--", "cvxcontact"))
        lines += ["# A further load case through a prepared ContactSolver: `two_blocks(nx)`, before and after", "",
                  f"- command: `{command}`", f"- date: {started:%Y-%m-%d %H:%M %Z}", f"- before: {base_label}",
                  f"- after: working tree, HEAD {_describe(repo, 'HEAD')}"
                  + ("; cvxcontact/ has uncommitted changes" if dirty else ""),
                  (f"- machine: {os.cpu_count()} cores shared with other work; load average at start "
                  f"{load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}"),
                  "- thread variables: " + ", ".join(f"{k}={env.get(k, 'unset')}" for k in THREAD_VARS)]
        for line in lines[2:]:
            print(line.removeprefix("- "), flush=True)
        table, stages = [], []
        for nx in args.sizes:
            runs = {"before": [], "after": []}
            files = {"before": [], "after": []}
            for i in range(args.repeats):
                for side in (("before", "after") if i % 2 == 0 else ("after", "before")):
                    out = Path(tmp) / f"{side}-{nx}-{i}.npz"
                    root = base_root if side == "before" else repo
                    part = {"part": "resolve", "root": str(root), "nx": nx, "out": str(out)}
                    runs[side].append(run_part(__file__, part, env))
                    files[side].append(out)
                b, a = runs["before"][-1], runs["after"][-1]
                print(f"  nx={nx} pair {i + 1}/{args.repeats}: re-solve share before {100 * b['share']:.1f} % "
                      f"(CPU {100 * b['share_cpu']:.1f} %), after {100 * a['share']:.1f} % "
                      f"(CPU {100 * a['share_cpu']:.1f} %)", flush=True)
            ref = np.load(files["before"][0])
            sides = {"u": 0.0, "phi": 0.0, "force": 0.0}
            for f in files["after"]:
                got = np.load(f)
                sides = {k: max(v, rel(got[k], ref[k])) for k, v in sides.items()}
            direct = max(max(r["direct"].values()) for r in runs["before"] + runs["after"])
            bad |= max(sides.values()) > args.agree or direct > args.agree
            cpu = _ratio_stats([r["resolve_cpu"] for r in runs["before"]], [r["resolve_cpu"] for r in runs["after"]])
            med = {s: {k: statistics.median(r[k] for r in runs[s]) for k in
                       ("first_s", "first_cpu", "resolve_s", "resolve_cpu", "scene_s", "share", "share_cpu")}
                   for s in runs}
            table.append([f"two_blocks({nx}) P1", f"{runs['after'][0]['dofs']:,}", str(args.repeats)]
                         + [f"{med[s]['first_s']:.2f} / {med[s]['first_cpu']:.2f}" for s in ("before", "after")]
                         + [f"{med[s]['resolve_s']:.3f} / {med[s]['resolve_cpu']:.3f}" for s in ("before", "after")]
                         + [(f"**{100 * med['before']['share_cpu']:.1f} % -> "
                             f"{100 * med['after']['share_cpu']:.1f} %** (wall {100 * med['before']['share']:.1f} % "
                             f"-> {100 * med['after']['share']:.1f} %)"),
                            f"{cpu['ratio']:.3f} [{cpu['lo']:.3f}, {cpu['hi']:.3f}]",
                            f"u {sides['u']:.1e}, phi {sides['phi']:.1e}, force {sides['force']:.1e}",
                            f"{direct:.1e}", str(all(r["ok"] for r in runs["before"] + runs["after"]))])
            for s in ("before", "after"):
                keys = sorted({k for r in runs[s] for k in r["timings"]})
                stages.append([f"two_blocks({nx}) {s}"] + [
                    f"{k} {statistics.median(r['timings'].get(k, 0.0) for r in runs[s]):.3f}" for k in keys]
                    + [f"scene {med[s]['scene_s']:.3f}"])
            print(table[-1], flush=True)
        load1 = os.getloadavg()
    minutes = (datetime.datetime.now().astimezone() - started).total_seconds() / 60
    lines.append(f"- load average at end {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}; "
                 f"whole run {minutes:.1f} min")
    lines += ["", markdown_table(
        ["case", "unknowns", "pairs", "first solve before: wall / CPU [s]", "after",
         "re-solve before: wall / CPU [s]", "after", "**re-solve / first solve** (CPU; wall)",
         "re-solve CPU after/before [interval]", "after vs before answers",
         "re-solve vs from-scratch (both sides)", "ok"], table), "",
        "Re-solve stages (medians, s): " + "; ".join(", ".join(r) for r in stages), "", NOTES]
    print("\n".join(lines[-4:]))
    if args.report:
        write_report(args.report, lines)
    if bad:
        print(f"DIFFERENT answers (above --agree {args.agree:g})")
    return 1 if bad else 0


NOTES = ("First solve: `cc.ContactSolver(scene).solve()` from the Scene to the checked Solution (assembly and the "
         "error estimate included). Re-solve: `scene.with_loads(0, ...)` (loads x 0.37) and `solver.solve(other)`, "
         "the new Scene's construction included. CPU: the solving process's user + system time (less sensitive "
         "than wall time to other work on a shared machine). Agreement: max |a - b| / max |b| of u, phi and the "
         "contact forces; from-scratch: `cc.solve(other)` in the same process.")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--baseline", default="main", help="git revision or directory holding cvxcontact/")
    p.add_argument("--sizes", type=int, nargs="*", default=[560], help="two_blocks nx (560: 6.3e5 unknowns)")
    p.add_argument("--repeats", type=int, default=5, help="pairs (before, after) per size")
    p.add_argument("--threads", type=int, help="set OMP/MKL/OPENBLAS_NUM_THREADS for both sides")
    p.add_argument("--agree", type=float, default=1e-9)
    p.add_argument("--report", help="also write the result as Markdown to this file")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        print(json.dumps(resolve_part(a["root"], a["nx"], a["out"])))
        return
    sys.exit(compare(args))


if __name__ == "__main__":
    main()
