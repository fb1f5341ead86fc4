"""The exact finish of the P2 "everywhere" cones on the sparse mixed system (26) (``finish_cuts_mixed``: a body held
by the contact only, a force-controlled obstacle): its rounds on the factored steps (one factorisation of the
bodies a round, the steps on the rows) against the unfactored ones (one sparse LU of (26) a step), and against
another checkout (``--root``, e.g. the commit before the factored steps served this finish). Wall time of
``cc.solve`` and of the finish ("polish"): medians of ``--reps`` runs in one process, the modes interleaved;
run it single-threaded. Scenes: the canonical ones of tests/scenes.py and tests/scenes3d.py under ``degree=2,
condition="gamma3"`` (a scene's own law kept) that take this finish (the others are listed as not taking it), the
turned piezoelectric pair, and the Hertz sphere guided along z under force control (apps/studies/hertz3d.py).

    OMP_NUM_THREADS=1 python benchmarks/mixed_cuts.py [--root CHECKOUT] [--modes unfactored factored]
        [--reps 3] [--2d] [--3d] [--hertz 4 6 8] [--json runs.json]
    python benchmarks/mixed_cuts.py --table before.json after.json --out benchmarks/results/mixed_cuts.md

A checkout without the factored mode (``--root`` an older one) runs its own finish for either mode: give it
``--modes unfactored``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

DUPLICATES = ("layer on a rigid plane, sigma1", "stacked blocks 5x5 on 7x3, sigma1")
"""3D canonical scenes that are another's under condition="gamma3" (only their condition differs)."""


def scenes(two: bool, three: bool, hertz: list[int]):
    """name -> (scene builder, keywords of cc.solve: the scene's own, its tol dropped, under P2 "gamma3")."""
    from cvxcontact.apps.studies import hertz3d
    out = {}
    if two:
        from scenes import SCENES
        out |= {f"2D {k}": (b, kw) for k, (b, kw) in SCENES.items()}
    if three:
        from scenes3d import SCENES3D, piezo_pair, rotation
        out |= {f"3D {k}": (b, kw) for k, (b, kw) in SCENES3D.items() if k not in DUPLICATES}
        out["3D two PZT blocks, turned"] = (lambda: piezo_pair(rotation()), {})
    out |= {f"Hertz sphere guided, n = {n}": ((lambda n=n: hertz3d.scene(n, force=hertz3d.FORCE)), {})
            for n in hertz}
    return {k: (b, {**{a: v for a, v in kw.items() if a != "tol"}, "condition": "gamma3", "degree": 2})
            for k, (b, kw) in out.items()}


def run(build, kw, factored: bool):
    """(solution, wall s, finish s, rounds of the mixed-system finish: 0 if the scene does not take it)."""
    import cvxcontact as cc
    from cvxcontact.backends import cones
    cones.FACTORED = factored
    rounds = []
    inner = cones.independent_active_set

    def counted(*a, **k):
        rounds.append(1)
        return inner(*a, **k)

    cones.independent_active_set = counted
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            sol = cc.solve(build(), **kw)
            wall = time.perf_counter() - t0
    finally:
        cones.independent_active_set = inner
        cones.FACTORED = True
    return sol, wall, float(sol.info.timings.get("polish", 0.0)), len(rounds)


def measure(args) -> list[dict]:
    import numpy as np
    rows = []
    modes = {"unfactored": False, "factored": True}
    for name, (build, kw) in scenes(args.two, args.three, args.hertz).items():
        times = {m: [] for m in args.modes}
        last = {}
        for _ in range(args.reps):
            for m in args.modes:
                sol, wall, polish, calls = run(build, kw, modes[m])
                if not calls:
                    break
                times[m].append((wall, polish))
                last[m] = (sol, calls)
            if not last:
                break
        if not last:
            print(f"{name}: does not take the mixed-system finish", flush=True)
            rows.append(dict(scene=name, took=False))
            continue
        row = dict(scene=name, took=True, root=str(args.root))
        for m in args.modes:
            sol, calls = last[m]
            r = sol.residuals()
            row[m] = dict(wall=statistics.median(t[0] for t in times[m]), polish=statistics.median(t[1] for t in times[m]),
                          walls=[t[0] for t in times[m]], ok=bool(sol.ok), finish=str(sol.info.finish), calls=calls,
                          feasibility=r.get("feasibility"), u=[np.asarray(u).ravel().tolist() for u in sol.u])
            print(f"{name} [{m}]: {row[m]['wall']:.2f} s (finish {row[m]['polish']:.2f} s), ok {sol.ok}, "
                  f"{sol.info.finish}, {calls} calls, feasibility {row[m]['feasibility']}", flush=True)
        rows.append(row)
    return rows


def table(paths: list[Path]) -> str:
    """Markdown: the first file's unfactored run as "before", this checkout's runs after it."""
    import numpy as np
    runs = [json.loads(Path(p).read_text()) for p in paths]
    before = {r["scene"]: r for r in runs[0]}
    after = {r["scene"]: r for r in runs[-1]}
    head = ["| scene | before s (finish s) | unfactored s (finish s) | factored s (finish s) | before / factored "
            "(finish) | ok, finish | feasibility before / factored | max abs du / max abs u |",
            "|---|---|---|---|---|---|---|---|"]
    out = []
    f2 = lambda d: f"{d['wall']:.2f} ({d['polish']:.2f})" if d else "—"  # noqa: E731
    for name, a in after.items():
        if not a["took"]:
            continue
        b = before.get(name, {}).get("unfactored")
        u, f = a.get("unfactored"), a.get("factored")
        ratio = f"{b['wall'] / f['wall']:.1f}x ({b['polish'] / max(f['polish'], 1e-9):.1f}x)" if b and f else "—"
        ok = ", ".join(f"{d['ok']}" for d in (b, u, f) if d) + f", {f['finish'] if f else ''}"
        feas = " / ".join(f"{d['feasibility']:.1e}" if d and d["feasibility"] is not None else "—" for d in (b, f))
        du = "—"
        if b and f:
            x, y = (np.concatenate([np.asarray(v) for v in d["u"]]) for d in (b, f))
            du = f"{np.abs(x - y).max() / np.abs(x).max():.1e}"
        out.append(f"| {name} | {f2(b)} | {f2(u)} | {f2(f)} | {ratio} | {ok} | {feas} | {du} |")
    skipped = [r["scene"] for r in runs[-1] if not r["took"]]
    return "\n".join(head + out) + "\n\nNot taking the mixed-system finish: " + ", ".join(skipped) + ".\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=ROOT, help="the checkout to import cvxcontact from")
    ap.add_argument("--modes", nargs="+", default=["unfactored", "factored"], choices=["unfactored", "factored"])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--2d", dest="two", action="store_true", help="the 2D scenes")
    ap.add_argument("--3d", dest="three", action="store_true", help="the 3D scenes")
    ap.add_argument("--hertz", type=int, nargs="*", default=None, help="Hertz levels n (default 4 6 8)")
    ap.add_argument("--json", type=Path, default=None, help="write the runs here")
    ap.add_argument("--table", type=Path, nargs="+", default=None, help="JSON runs to tabulate (before first)")
    ap.add_argument("--out", type=Path, default=None, help="the Markdown table (with --table)")
    args = ap.parse_args(argv)
    if args.table:
        text = table(args.table)
        print(text)
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(text)
        return 0
    sys.path.insert(0, str(args.root.resolve()))
    sys.path.insert(0, str(args.root.resolve() / "tests"))
    every = not (args.two or args.three or args.hertz is not None)
    args.two, args.three = args.two or every, args.three or every
    args.hertz = [4, 6, 8] if args.hertz is None and every else (args.hertz or [])
    rows = measure(args)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
