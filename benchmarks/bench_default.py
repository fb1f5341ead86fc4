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
                                         [--csv FILE] [--merge]
Print and CSV (``benchmarks/results/default.csv``): one row per case with both parts, the ratios
``default_s / pardiso_s`` and ``default_s / superlu_s``, and growth exponents over the sizes. A size is
``two_blocks``' ``nx``, or (a value >= 1e4) a count of unknowns N, taken as nx = 10 round(sqrt(N / 2) / 10)
(the scene has about 2 nx^2 unknowns: 1.6e5 -> 280, 6.3e5 -> 560, 2.5e6 -> 1120).

Before and after (issue 20): ``--baseline REV`` times the default ``cc.solve(scene)`` of the package at the
git revision REV (or in a directory holding a ``cvxcontact/`` package) against this checkout's working tree,
in one run:

    python benchmarks/bench_default.py --baseline 92924ab --sizes 1.6e5 6.3e5 --repeats 21 9 --threads 1 \
        --report benchmarks/results/compare-92924ab.md

REV's ``cvxcontact/`` is extracted by ``git archive`` into a temporary directory (removed afterwards; the
repository is only read). Every timed solve runs in a fresh subprocess of the same interpreter and
environment (thread variables printed), which imports the package from its own tree (checked), solves
``two_blocks(4)`` once (imports, first-call set-up), builds the scene and times ``cc.solve(scene)``, from
the Scene to the checked Solution, assembly included. Per size the two sides alternate, pair i in the order
before-after for even i and after-before for odd i (so that a drift of the machine's load favours neither).
Reported: the median of each side; after/before as the median of the per-pair ratios with its
distribution-free interval (order statistics; about 95 % from 6 pairs on), their min and max, and the ratio
of the medians; the same without assembly (``sol.timings["assembly"]``) and for the process's CPU time
(less sensitive to other work on a shared machine); the route, factorisation (``sol.info.factorization``:
"pardiso" is MKL) and checks of each side; the versions of numpy, scipy, cvxpy, clarabel and mkl. The
answers must agree: max |a - b| / max |b| of u, phi and the contact force (every pair's ``force``) between
each after-solve and the first before-solve, beside the same between repeats of one side (the rounding level); above
``--agree`` (1e-9) the run says DIFFERENT and exits with status 1. ``--report FILE`` also writes the
result as Markdown (``benchmarks/results/compare-*.md``). ``--threads N`` sets OMP_NUM_THREADS,
MKL_NUM_THREADS and OPENBLAS_NUM_THREADS for both sides. On a machine shared with other work, one thread
per solve is the steadier instrument (a two-thread factorisation waits for its slower thread whenever
another process holds a core) and more pairs at 1.6e5 buy more than at 6.3e5: a solve costs about 4 s at
1.6e5 unknowns and 14 s at 6.3e5 (imports, warm-up and scene included; two cores), the command above
about 7 min. With identical code on both sides (benchmarks/results/compare-92924ab-validation.md, a load
average of 2-4 on two cores) after/before came out 0.95-1.02 with intervals as wide as 0.76-1.10 (21
pairs) and 0.72-1.30 (6 pairs): at such a load a change of a few per cent is below what one run resolves.
"""

from __future__ import annotations

import argparse
import compileall
import csv
import datetime
import io
import json
import math
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parent))              # harness

from harness import (bonded_kkt, growth, markdown_table, median_row, peak_gb, pypardiso_solve, rel,  # noqa: E402
                     residual, run_part, superlu_solve, unknowns, write_csv, write_report)


def make_scene(name, n, scale=1.0):
    """The canonical scene ``name`` at size ``n`` with its loads x ``scale`` (thin_layer: pressure and voltage)."""
    from cvxcontact.apps import demo

    if name == "thin_layer":
        return demo.thin_layer(n, pressure=1e6 * scale, voltage=100.0 * scale)
    return getattr(demo, name)(n, scale=scale)


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
                         compile_s=tm.get("model", 0.0) + tm.get("compile", 0.0), ipm_s=tm.get("solve", 0.0),
                         polish_s=tm.get("polish", 0.0), certificate_s=tm.get("certificate", 0.0),
                         finish=str(sol.info.finish),
                         resolve_s=t_again, resolve_share=t_again / total,
                         method=sol.info.method, route=str(sol.info.route), iterations=sol.info.iterations,
                         factorization=sol.info.factorization or "-", ok=bool(sol.ok),
                         resolve_ok=bool(again.ok), resolve_route=str(again.info.route),
                         **{f"res_{k}": float(v) for k, v in sol.residuals().items()}))
        N, merged = unknowns(solver.problem), solver.problem.E.shape[0]
        del solver, sol, again
    out = median_row(rows)
    out.update(unknowns=N, contact_rows=merged, default_peak_gb=peak_gb())
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


def bonded_part(name, n, degree, runs, superlu_up_to):
    """The bonded scene (module docstring): the two bodies glued, [u] = 0 at every merged node."""
    sc = make_scene(name, n)
    t0 = time.perf_counter()
    blocks = bonded_blocks(sc, degree)
    t_asm = time.perf_counter() - t0
    K, rhs, _, _, _ = bonded_kkt(blocks, [b.jump for b in blocks])
    out = dict(kkt_size=K.shape[0], bonded_assembly_s=t_asm)
    try:
        import pypardiso  # noqa: F401
        for mtype, key in ((-2, "pardiso_sym"), (11, "pardiso_unsym")):
            ts = [pypardiso_solve(K, rhs, mtype) for _ in range(runs)]
            out[f"{key}_s"] = statistics.median(t for t, _ in ts)
            out[f"{key}_residual"] = max(r for _, r in ts)
        out["pardiso_s"] = min(out["pardiso_sym_s"], out["pardiso_unsym_s"])
    except ImportError:
        out["pardiso_s"] = float("nan")
    out["pardiso_peak_gb"] = peak_gb()
    if K.shape[0] <= superlu_up_to:
        ts = [superlu_solve(K, rhs) for _ in range(max(1, min(runs, 2)))]
        out["superlu_s"] = statistics.median(t for t, _ in ts)
        out["superlu_residual"] = residual(K, ts[-1][1], rhs)
    else:
        out["superlu_s"] = float("nan")
    out["bonded_peak_gb"] = peak_gb()
    return out


# ---------------------------------------------------------------------------------------------------------
# Before and after: the default cc.solve of a baseline revision against the working tree (module docstring)

THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "KMP_BLOCKTIME")
PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel", "mkl", "meshio")


def size(text: str) -> int:
    """``two_blocks``' nx from ``text``: nx itself, or (>= 1e4) a count of unknowns N -> 10 round(sqrt(N/2)/10)."""
    value = float(text)
    if value != value or value < 2:
        raise argparse.ArgumentTypeError(f"a size is nx >= 2 or a count of unknowns >= 1e4, got {text!r}")
    if value < 1e4:
        return int(round(value))
    return max(10, 10 * round((value / 2) ** 0.5 / 10))


def _versions() -> dict:
    from importlib import metadata

    out = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "-"
    return out


def solve_part(root, name, n, degree, out):
    """One timed default solve with the package imported from ``root``; its fields saved to ``out`` (.npz)."""
    sys.path.insert(0, root)
    import cvxcontact as cc

    where = Path(cc.__file__).resolve().parent
    if where != Path(root).resolve() / "cvxcontact":
        raise RuntimeError(f"cvxcontact imported from {where}, not from {root}")
    cc.solve(make_scene(name, 4), degree=degree)                       # imports, first-call set-up
    t0 = time.perf_counter()
    sc = make_scene(name, n)
    t_scene = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    sol = cc.solve(sc, degree=degree)
    t_solve, cpu = time.perf_counter() - t0, time.process_time() - c0
    timings = {k: float(v) for k, v in dict(sol.timings).items()}
    u = np.concatenate([np.ravel(x) for x in sol.u])
    phi = np.concatenate([np.ravel(x) for x in sol.phi if x is not None] or [np.zeros(0)])
    force = np.concatenate([np.ravel(c.force) for c in sol.contacts])
    active = int(sum(int(np.sum(c.active)) for c in sol.contacts))
    np.savez(out, u=u, phi=phi, force=force)
    info = sol.info
    return dict(solve_s=t_solve, cpu_s=cpu, scene_s=t_scene, assembly_s=timings.get("assembly", float("nan")),
                timings=timings, dofs=int(u.size + phi.size), contact_nodes=int(force.size), active=active,
                method=str(getattr(info, "method", "-")), route=str(getattr(info, "route", "-")),
                iterations=getattr(info, "iterations", None),
                factorization=str(getattr(info, "factorization", None) or "-"), ok=bool(sol.ok),
                residuals={k: float(v) for k, v in sol.residuals().items()}, peak_gb=peak_gb(),
                package=str(where), versions=_versions(),
                threads={k: os.environ.get(k, "unset") for k in THREAD_VARS},
                cpus=len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count())


def _git(repo, *args) -> str:
    out = subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"git {' '.join(args)}: {out.stderr.strip()}")
    return out.stdout.strip()


def materialise(spec, repo, dest):
    """The baseline's root (a directory holding ``cvxcontact/``) and its label: ``spec`` as a directory, or the
    git revision ``spec``'s ``cvxcontact/`` extracted by ``git archive`` into ``dest``."""
    path = Path(spec)
    if (path / "cvxcontact" / "__init__.py").is_file():
        return path.resolve(), f"directory {path.resolve()}", None
    found = subprocess.run(["git", "-C", str(repo), "rev-parse", "--verify", "--quiet", f"{spec}^{{commit}}"],
                           capture_output=True, text=True)
    if found.returncode:
        raise SystemExit(f"--baseline {spec!r} is neither a git revision of {repo} nor a directory holding "
                         f"cvxcontact/")
    commit = found.stdout.strip()
    tar = subprocess.run(["git", "-C", str(repo), "archive", "--format=tar", commit, "cvxcontact"],
                         capture_output=True)
    if tar.returncode:
        raise SystemExit(f"git archive {commit}: {tar.stderr.decode().strip()}")
    root = Path(dest) / "baseline"
    root.mkdir()
    with tarfile.open(fileobj=io.BytesIO(tar.stdout)) as archive:
        archive.extractall(root, filter="data")
    return root, f"{_describe(repo, commit)}, extracted by git archive", commit


def _describe(repo, rev) -> str:
    """``rev`` as "hash (date) subject", the subject cut at 70 characters."""
    short, date, subject = _git(repo, "log", "-1", "--format=%h%n%cs%n%s", rev).split("\n", 2)
    return f"{short} ({date}) {subject[:70] + '...' if len(subject) > 70 else subject}"


def _differences(files_a, files_b):
    """Largest relative differences of u, phi, force between each file of ``files_b`` and the first of ``files_a``."""
    ref = np.load(files_a[0])
    out = {}
    for key in ("u", "phi", "force"):
        out[key] = max((rel(np.load(f)[key], ref[key]) for f in files_b), default=float("nan"))
    return out


def _ratio_stats(before, after):
    """after/before: the median of the per-pair ratios with its distribution-free interval (order statistics
    r_(k) <= median <= r_(n+1-k), the largest k whose coverage 1 - 2 P(Bin(n, 1/2) < k) is >= 95 %, else
    k = 1: min and max; the coverage is returned), their min and max, and the ratio of the medians."""
    a, b = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    pairs = np.sort(b / a)
    n = len(pairs)

    def coverage(k):
        return 1.0 - 2.0 * sum(math.comb(n, i) for i in range(k)) / 2.0 ** n

    k = 1
    while k + 1 <= (n + 1) // 2 and coverage(k + 1) >= 0.95:
        k += 1
    return dict(ratio=float(np.median(pairs)), lo=float(pairs[k - 1]), hi=float(pairs[n - k]),
                coverage=coverage(k), pair_min=float(pairs[0]), pair_max=float(pairs[-1]),
                of_medians=float(np.median(b) / np.median(a)))


def _spread(x) -> float:
    """Median absolute deviation / median (relative spread of one side's times)."""
    x = np.asarray(x)
    m = np.median(x)
    return float(np.median(np.abs(x - m)) / m)


def compare(args) -> int:
    """Time the baseline and the working tree interleaved; print (and with ``--report`` write) the result."""
    repo = Path(__file__).resolve().parents[1]
    sizes = args.sizes or [size("1.6e5"), size("6.3e5")]
    repeats = args.repeats if len(args.repeats) == len(sizes) else [args.repeats[0]] * len(sizes)
    if len(args.repeats) not in (1, len(sizes)) or min(repeats) < 1:
        raise SystemExit("--repeats: one count >= 1, or one per size")
    degrees = [1, 2] if args.p2 else [1]
    env = dict(os.environ)
    if args.threads:
        env.update({k: str(args.threads) for k in THREAD_VARS[:3]})
    command = "python benchmarks/bench_default.py " + shlex.join(sys.argv[1:])
    started = datetime.datetime.now().astimezone()
    load0 = os.getloadavg()
    bad = False
    with tempfile.TemporaryDirectory(prefix="cvxcontact-bench-") as tmp:
        base_root, base_label, base_commit = materialise(args.baseline, repo, tmp)
        dirty = bool(_git(repo, "status", "--porcelain", "--", "cvxcontact"))
        work_label = (f"working tree {repo}, HEAD {_describe(repo, 'HEAD')}"
                      + ("; cvxcontact/ has uncommitted changes" if dirty else ""))
        if base_commit:
            changed = _git(repo, "diff", "--name-only", base_commit, "--", "cvxcontact").splitlines()
            work_label += (f"; cvxcontact/ differs from the baseline in {len(changed)} files" if changed else
                           "; cvxcontact/ identical to the baseline")
        for root in (base_root, repo):                                  # byte-code before any timing
            compileall.compile_dir(str(Path(root) / "cvxcontact"), quiet=1)
        sides = {"before": base_root, "after": repo}
        lines = [f"# Default path before and after: `cc.solve(two_blocks(nx))`", "",
                 f"- command: `{command}`", f"- date: {started:%Y-%m-%d %H:%M %Z}",
                 f"- before: {base_label}", f"- after: {work_label}",
                 f"- machine: {platform.machine()}, {os.cpu_count()} cores shared with other work; "
                 f"load average at start {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}",
                 "- thread variables given to both sides: " + ", ".join(f"{k}={env.get(k, 'unset')}"
                                                                         for k in THREAD_VARS)]
        for line in lines[2:]:
            print(line.removeprefix("- "), flush=True)
        table = []
        first = True
        for nx, reps in zip(sizes, repeats):
            for degree in degrees:
                n = nx if degree == 1 else max(2, nx // 2)
                runs = {"before": [], "after": []}
                files = {"before": [], "after": []}
                for i in range(reps):
                    for side in (("before", "after") if i % 2 == 0 else ("after", "before")):
                        out = Path(tmp) / f"{side}-{n}-{degree}-{i}.npz"
                        r = run_part(__file__, dict(part="solve", root=str(sides[side]), name="two_blocks", n=n,
                                                    degree=degree, out=str(out)), env)
                        runs[side].append(r)
                        files[side].append(out)
                    print(f"  P{degree} nx={n} pair {i + 1}/{reps}: before {runs['before'][-1]['solve_s']:.2f} s, "
                          f"after {runs['after'][-1]['solve_s']:.2f} s", flush=True)
                if first:
                    env_lines = []
                    for side in ("before", "after"):
                        r = runs[side][0]
                        env_lines.append(f"- {side}: package {r['package']}; " + ", ".join(
                            f"{k} {v}" for k, v in r["versions"].items()) + "; in the solving process " + ", ".join(
                            f"{k}={v}" for k, v in r["threads"].items()) + f"; {r['cpus']} CPUs usable")
                    if runs["before"][0]["versions"] != runs["after"][0]["versions"]:
                        env_lines.append("- WARNING: the two sides report different versions")
                    lines += env_lines
                    for line in env_lines:
                        print(line.removeprefix("- "), flush=True)
                    first = False
                row = _summarise(n, degree, runs, files, args.agree)
                bad |= row["differ"]
                table.append(row)
                print(_row_text(row), flush=True)
        load1 = os.getloadavg()
    minutes = (datetime.datetime.now().astimezone() - started).total_seconds() / 60
    lines.append(f"- load average at end {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}; whole run {minutes:.1f} min")
    print(lines[-1].removeprefix("- "))
    lines += ["", _markdown(table), "", NOTES]
    if args.report:
        write_report(args.report, lines)
    if bad:
        print(f"DIFFERENT answers (above --agree {args.agree:g}): a time ratio compares different solutions")
    return 1 if bad else 0


NOTES = ("Times: wall-clock seconds of `cc.solve(scene)` (Scene to checked Solution, assembly included), each "
         "in a fresh subprocess after an untimed `cc.solve(two_blocks(4))`; *w/o assembly* subtracts "
         "`sol.timings['assembly']`; *CPU time* is the solving process's user + system time over the same "
         "call (all its threads; less sensitive than wall time to other work on a shared machine). "
         "after/before: the median of the per-pair ratios (pair i: the two solves run one after the other) "
         "[its distribution-free interval from order statistics] (that interval's coverage; 95 % needs 6 "
         "pairs, 5 give min-max at 94 %); the ratio of the two sides' medians beside it is more sensitive to a "
         "change of load during the run. Spread: median absolute deviation / median of each side. "
         "Agreement: max |after - before| / max |before| of u, phi and the contact force against the first "
         "before-solve; *rounding* is the same among the before-solves themselves.")


def _summarise(n, degree, runs, files, agree):
    before, after = runs["before"], runs["after"]
    t = {s: [r["solve_s"] for r in runs[s]] for s in runs}
    t_core = {s: [r["solve_s"] - r["assembly_s"] for r in runs[s]] for s in runs}
    t_cpu = {s: [r["cpu_s"] for r in runs[s]] for s in runs}
    diff = _differences(files["before"], files["after"])
    rounding = _differences(files["before"], files["before"][1:]) if len(files["before"]) > 1 else \
        dict(u=float("nan"), phi=float("nan"), force=float("nan"))
    same_route = {r["route"] for r in after} == {r["route"] for r in before}
    differ = bool(max(diff.values()) > agree) or before[0]["dofs"] != after[0]["dofs"]
    return dict(nx=n, degree=degree, dofs=after[0]["dofs"], contact_nodes=after[0]["contact_nodes"],
                repeats=len(before), before=statistics.median(t["before"]), after=statistics.median(t["after"]),
                spread_before=_spread(t["before"]), spread_after=_spread(t["after"]),
                total=_ratio_stats(t["before"], t["after"]),
                core=_ratio_stats(t_core["before"], t_core["after"]),
                core_before=statistics.median(t_core["before"]), core_after=statistics.median(t_core["after"]),
                cpu=_ratio_stats(t_cpu["before"], t_cpu["after"]),
                cpu_before=statistics.median(t_cpu["before"]), cpu_after=statistics.median(t_cpu["after"]),
                min_before=min(t["before"]), min_after=min(t["after"]),
                diff=diff, rounding=rounding, differ=differ, same_route=same_route,
                route_before=f"{before[0]['method']}/{before[0]['factorization']}, {before[0]['route']}",
                route_after=f"{after[0]['method']}/{after[0]['factorization']}, {after[0]['route']}",
                ok=all(r["ok"] for r in before + after), active=(before[0]["active"], after[0]["active"]),
                peak=(max(r["peak_gb"] for r in before), max(r["peak_gb"] for r in after)),
                times=t)


def _ci(x) -> str:
    return f"{x['ratio']:.3f} [{x['lo']:.3f}, {x['hi']:.3f}] ({100 * x['coverage']:.0f} %)"


def _row_text(r) -> str:
    tot = r["total"]
    return (f"P{r['degree']} nx={r['nx']}: {r['dofs']} dofs (u, phi at every node), {r['repeats']} pairs\n"
            f"    wall: before {r['before']:.3f} s (spread {100 * r['spread_before']:.1f} %), after {r['after']:.3f} s "
            f"(spread {100 * r['spread_after']:.1f} %); after/before {_ci(tot)}, pairs {tot['pair_min']:.3f}-"
            f"{tot['pair_max']:.3f}, ratio of the medians {tot['of_medians']:.3f}, minima {r['min_before']:.3f} -> "
            f"{r['min_after']:.3f} s\n"
            f"    without assembly {r['core_before']:.3f} -> {r['core_after']:.3f} s, {_ci(r['core'])}; CPU time "
            f"{r['cpu_before']:.3f} -> {r['cpu_after']:.3f} s, {_ci(r['cpu'])}\n"
            f"    answers: u {r['diff']['u']:.1e}, phi {r['diff']['phi']:.1e}, force {r['diff']['force']:.1e} "
            f"(rounding among before-solves: u {r['rounding']['u']:.1e}, force {r['rounding']['force']:.1e}) "
            f"{'DIFFERENT' if r['differ'] else 'agree'}; before [{r['route_before']}] after [{r['route_after']}]"
            f"{'' if r['same_route'] else ' ROUTE CHANGED'}, ok={r['ok']}, active nodes {r['active'][0]} / "
            f"{r['active'][1]}, peak {r['peak'][0]:.2f} / {r['peak'][1]:.2f} GB")


def _markdown(table) -> str:
    case = [f"two_blocks({r['nx']}) P{r['degree']}" for r in table]
    times = markdown_table(
        ["case", "dofs", "pairs", "before [s]", "after [s]", "**after/before** [interval] (coverage)",
         "pairs min-max", "ratio of the medians", "spread before / after", "minima [s]"],
        [[c, f"{r['dofs']:,}", str(r["repeats"]), f"{r['before']:.3f}", f"{r['after']:.3f}", f"**{_ci(r['total'])}**",
          f"{r['total']['pair_min']:.3f}-{r['total']['pair_max']:.3f}", f"{r['total']['of_medians']:.3f}",
          f"{100 * r['spread_before']:.1f} % / {100 * r['spread_after']:.1f} %",
          f"{r['min_before']:.3f} -> {r['min_after']:.3f}"] for c, r in zip(case, table)])
    parts = markdown_table(
        ["case", "without assembly: before -> after [s]", "after/before", "CPU time: before -> after [s]",
         "after/before", "peak before / after [GB]"],
        [[c, f"{r['core_before']:.3f} -> {r['core_after']:.3f}", _ci(r["core"]),
          f"{r['cpu_before']:.3f} -> {r['cpu_after']:.3f}", _ci(r["cpu"]), f"{r['peak'][0]:.2f} / {r['peak'][1]:.2f}"]
         for c, r in zip(case, table)])
    answers = markdown_table(
        ["case", "u", "phi", "force", "rounding (u, force)", "same answer", "route before / after", "ok",
         "active nodes"],
        [[c, f"{r['diff']['u']:.1e}", f"{r['diff']['phi']:.1e}", f"{r['diff']['force']:.1e}",
          f"{r['rounding']['u']:.1e}, {r['rounding']['force']:.1e}", "no" if r["differ"] else "yes",
          f"{r['route_before']} / {r['route_after']}", str(r["ok"]), f"{r['active'][0]} / {r['active'][1]}"]
         for c, r in zip(case, table)])
    order = "Wall times of each solve in run order (s): " + "; ".join(
        f"P{r['degree']} nx={r['nx']} before " + " ".join(f"{x:.2f}" for x in r["times"]["before"]) + ", after "
        + " ".join(f"{x:.2f}" for x in r["times"]["after"]) for r in table)
    return "\n".join([times, "", parts, "", answers, "", order])


def case(name, n, degree, runs, superlu_up_to):
    row = dict(scene=name, n=n, degree=degree)
    row.update(run_part(__file__, dict(part="default", name=name, n=n, degree=degree, runs=runs)))
    if row["factorization"] == "pardiso" and row["unknowns"] <= superlu_up_to:    # the default install's path
        alt = run_part(__file__, dict(part="default", name=name, n=n, degree=degree, runs=runs,
                                      factorization="superlu"))
        row.update({f"scipy_{k}": alt[k] for k in ("default_s", "resolve_share", "default_peak_gb", "ok",
                                                    "res_complementarity", "route")})
    row.update(run_part(__file__, dict(part="bonded", name=name, n=n, degree=degree, runs=runs,
                                       superlu_up_to=superlu_up_to)))
    nan = float("nan")
    row["ratio_pardiso"] = row["default_s"] / row["pardiso_s"] if row["pardiso_s"] == row["pardiso_s"] else nan
    row["ratio_superlu"] = row["default_s"] / row["superlu_s"] if row["superlu_s"] == row["superlu_s"] else nan
    return row


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=size, nargs="*", default=None,
                   help="two_blocks nx (P1), or unknowns (>= 1e4, e.g. 1.6e5); default 70 140 280 560, "
                        "with --baseline 1.6e5 6.3e5")
    p.add_argument("--p2", action="store_true", help="also P2 at nx // 2 (about equal unknowns)")
    p.add_argument("--thin", type=int, nargs="*", default=[], help="thin_layer sizes")
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--superlu-up-to", type=int, default=800_000, help="largest KKT size solved by SuperLU")
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "default.csv"))
    p.add_argument("--merge", action="store_true",
                   help="replace only this run's cases (scene, n, degree) in an existing --csv, keep its other rows")
    p.add_argument("--baseline", help="git revision (or directory holding cvxcontact/) to time against the "
                                      "working tree (module docstring, 'Before and after')")
    p.add_argument("--repeats", type=int, nargs="*", default=[9],
                   help="with --baseline: solves per side, one value or one per size")
    p.add_argument("--agree", type=float, default=1e-9,
                   help="with --baseline: largest relative difference of the answers taken as the same answer")
    p.add_argument("--threads", type=int, help="set OMP/MKL/OPENBLAS_NUM_THREADS for both sides")
    p.add_argument("--report", help="with --baseline: also write the result as Markdown to this file")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        if a["part"] == "default":
            print(json.dumps(default_part(a["name"], a["n"], a["degree"], a["runs"], a.get("factorization", "auto"))))
        elif a["part"] == "solve":
            print(json.dumps(solve_part(a["root"], a["name"], a["n"], a["degree"], a["out"])))
        else:
            print(json.dumps(bonded_part(a["name"], a["n"], a["degree"], a["runs"], a["superlu_up_to"])))
        return
    if args.baseline:
        sys.exit(compare(args))
    if args.sizes is None:
        args.sizes = [70, 140, 280, 560]
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
        fits = growth(sel, ("default_s", "pardiso_s", "superlu_s"))
        if fits is not None:
            print(f"growth {name} P{degree}: {fits}")
    if args.merge and Path(args.csv).exists():      # this run's cases replace theirs, the others are kept
        with open(args.csv, newline="") as fh:
            old = list(csv.DictReader(fh))
        ran = {(r["scene"], str(r["n"]), str(r["degree"])) for r in rows}
        kept = [r for r in old if (r["scene"], r["n"], r["degree"]) not in ran]
        order = {key: i for i, key in enumerate((r["scene"], str(r["degree"])) for r in old)}
        rows = sorted(kept + rows, key=lambda r: (order.get((r["scene"], str(r["degree"])), len(order)),
                                                  int(r["n"])))
    print("wrote", write_csv(args.csv, rows))


if __name__ == "__main__":
    main()
