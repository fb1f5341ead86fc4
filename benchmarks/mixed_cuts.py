"""The exact finish of the P2 "everywhere" cones on the sparse mixed system (26) (``finish_cuts_mixed``: a body held
by the contact only, a force-controlled obstacle), its rounds on the factored steps (one factorisation of the
bodies a round, the steps on the rows) against the unfactored ones (one sparse LU of (26) a step): wall time of
``cc.solve`` and of the finish ("polish"), medians of ``--reps`` runs in one process, the two modes interleaved,
single-threaded. Scenes: the canonical ones of tests/scenes.py and tests/scenes3d.py under ``degree=2,
condition="gamma3"`` that take this finish (the others are listed as not taking it), the turned piezoelectric pair,
and the Hertz sphere guided along z under force control (apps/studies/hertz3d.py) at n = 4, 6, 8.

    OMP_NUM_THREADS=1 python benchmarks/mixed_cuts.py [--reps 3] [--2d] [--3d] [--hertz 4 6 8]
        [--slow-before 8] [--out benchmarks/results/mixed_cuts.md]

The unfactored finish of the Hertz sphere at n = 8 did not end within 900 s: it is timed only at the levels
given to ``--slow-before``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))                      # this checkout
sys.path.insert(0, str(ROOT / "tests"))            # the canonical scenes

import numpy as np  # noqa: E402

import cvxcontact as cc  # noqa: E402
from cvxcontact.apps.studies import hertz3d  # noqa: E402
from cvxcontact.backends import cones  # noqa: E402

DUPLICATES = ("layer on a rigid plane, sigma1", "stacked blocks 5x5 on 7x3, sigma1")
"""3D canonical scenes that are another's under condition="gamma3" (only their condition differs)."""


def scenes(two: bool, three: bool, hertz: list[int]):
    """name -> (scene builder, keywords of cc.solve: the scene's own, its tol dropped, under P2 "gamma3")."""
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
    """(solution, wall s, finish s, rounds of the mixed finish)."""
    cones.FACTORED = factored
    rounds = []
    inner = cones.independent_active_set

    def counted(*a, **k):
        if k.get("factored", True) == factored:       # a round (not its unfactored second try)
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--2d", dest="two", action="store_true", help="the 2D scenes")
    ap.add_argument("--3d", dest="three", action="store_true", help="the 3D scenes")
    ap.add_argument("--hertz", type=int, nargs="*", default=None, help="Hertz levels n (default 4 6 8)")
    ap.add_argument("--slow-before", type=int, nargs="*", default=(4, 6),
                    help="Hertz levels at which the unfactored finish is timed too (default 4 6)")
    ap.add_argument("--out", type=Path, default=None, help="a Markdown table to write")
    args = ap.parse_args(argv)
    every = not (args.two or args.three or args.hertz is not None)
    hertz = [4, 6, 8] if args.hertz is None and every else (args.hertz or [])
    rows = []
    for name, (build, kw) in scenes(args.two or every, args.three or every, hertz).items():
        modes = (False, True)
        if name.startswith("Hertz") and int(name.split()[-1]) not in args.slow_before:
            modes = (True,)
        times = {m: [] for m in modes}
        sols = {}
        took = True
        for _ in range(args.reps):
            for m in modes:
                sol, wall, polish, rounds = run(build, kw, m)
                if not rounds:                      # the scene does not take the mixed-system finish
                    took = False
                    break
                times[m].append((wall, polish))
                sols[m] = (sol, rounds)
            if not took:
                break
        if not took:
            print(f"{name}: does not take the mixed-system finish", flush=True)
            rows.append(dict(scene=name, took=False))
            continue
        row = dict(scene=name, took=True)
        for m in modes:
            sol, rounds = sols[m]
            key = "factored" if m else "unfactored"
            row[key] = dict(wall=statistics.median(t[0] for t in times[m]),
                            polish=statistics.median(t[1] for t in times[m]), ok=sol.ok,
                            finish=str(sol.info.finish), rounds=rounds,
                            feasibility=sol.residuals().get("feasibility"))
        if len(modes) == 2:
            a = np.concatenate([np.ravel(u) for u in sols[False][0].u])
            b = np.concatenate([np.ravel(u) for u in sols[True][0].u])
            row["du"] = float(np.abs(a - b).max() / max(np.abs(a).max(), np.finfo(float).tiny))
        rows.append(row)
        print(line(row), flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        head = ["| scene | unfactored s (finish s) | factored s (finish s) | ratio (finish) | rounds | ok, finish | "
                "feasibility | max abs du / max abs u |", "|---|---|---|---|---|---|---|---|"]
        args.out.write_text("\n".join(head + [line(r) for r in rows if r["took"]]) + "\n\n" + "Not taking the "
                            "mixed-system finish: " + ", ".join(r["scene"] for r in rows if not r["took"]) + ".\n")
    return 0


def line(r) -> str:
    """One Markdown row."""
    if not r["took"]:
        return f"| {r['scene']} | — | — | — | — | — | — | — |"
    f, u = r["factored"], r.get("unfactored")
    before = f"{u['wall']:.2f} ({u['polish']:.2f})" if u else "—"
    ratio = f"{u['wall'] / f['wall']:.1f}x ({u['polish'] / max(f['polish'], 1e-9):.1f}x)" if u else "—"
    rounds = f"{u['rounds']} / {f['rounds']}" if u else f"{f['rounds']}"
    ok = f"{u['ok']} / {f['ok']}, {f['finish']}" if u else f"{f['ok']}, {f['finish']}"
    feas = " / ".join(f"{x['feasibility']:.1e}" if x and x["feasibility"] is not None else "—" for x in (u, f) if x)
    du = f"{r['du']:.1e}" if "du" in r else "—"
    return f"| {r['scene']} | {before} | {f['wall']:.2f} ({f['polish']:.2f}) | {ratio} | {rounds} | {ok} | {feas} | {du} |"


if __name__ == "__main__":
    sys.exit(main())
