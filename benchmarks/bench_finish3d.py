"""Benchmark: the exact finish of dependent 3D "gamma3" rows, factored steps against sparse steps.

Scene: two stacked blocks with non-matching contact faces (tests/scenes3d.py ``stacked_blocks``: rollers on
the sides and under the lower block, a uniform pressure on the upper block's top, the upper block held by
the contact only), ``lower`` x ``lower`` cells on ``upper`` cells across the faces, nz = 2; the overlay rows
outnumber the jump's degrees of freedom. For each size the interior point runs once (``method="full"``
without polish) and gives the start; then, from that same start,
:func:`cvxcontact.backends.finish.independent_active_set`

* ``sparse``: every step a sparse LU of the mixed system (26) (``factored=False``), and
* ``factored``: one factorisation of the regularised bodies, the system on the rows updated row by row,
  and one exact solve of (26) where the steps stop (the default),

each timed ``--runs`` times (median printed), the answers compared (max |x_f - x_s| / max |x_s|, x the
stacked unknowns, unique). The sparse steps are skipped above ``--sparse-max-rows`` (minutes: at 1,513 rows SciPy's structural-rank
test before the sparse LU alone ran over 200 s on the crossover's mixed matrix, whose LU took 0.27 s).
With ``--condensed`` the same sizes with the upper block also held on its top and an interference of
1e-5 m between the faces (``squeezed``) are solved by ``method="condensed"`` (the finish on the interface
compliance, :func:`cvxcontact.backends.finish.independent_interface`) and ``"full"``: the finish times
(``sol.timings["polish"]``) and the agreement of u.

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONPATH=. python benchmarks/bench_finish3d.py \\
        [--sizes 5x5/7x3 10x10/12x8 15x15/18x12] [--runs 3] [--sparse-max-rows 800] [--condensed]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import cvxcontact as cc  # noqa: E402
from cvxcontact.backends import signorini  # noqa: E402
from cvxcontact.backends.finish import independent_active_set  # noqa: E402
from cvxcontact.backends.full import mixed_kkt  # noqa: E402
from cvxcontact.backends.result import Cache  # noqa: E402
from scenes3d import SIDES, STEEL, stacked_blocks  # noqa: E402


def parse_size(text):
    lower, upper = text.split("/")
    return tuple(int(v) for v in lower.split("x")), tuple(int(v) for v in upper.split("x"))


def squeezed(lower, upper, overlap=1e-5):
    """The stacked blocks with the upper one held by rollers on its top and an interference ``overlap`` (m)."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=2)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=2)
    b1 = cc.Body(low, STEEL, roller=SIDES + ["bottom"], contact="top", name="lower")
    b2 = cc.Body(up, STEEL, roller=SIDES + ["top"], contact="bottom", name="upper")
    return cc.Scene(b1, b2, gap=-overlap)


def timed(run, runs):
    times, out = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


VARIANTS = {"sparse": dict(factored=False, purify=False), "sparse+crossover": dict(factored=False, purify=True),
            "factored": dict(factored=True, purify=False), "factored+crossover": dict(factored=True, purify=True)}
"""The finishes timed: steps solving the sparse mixed system or factored steps, each from the first independent
rows of the start (the finish before the crossover) or from the crossover of the start's forces (the default:
factored+crossover). "sparse" is the finish as it was before the factored steps."""


def finish_case(lower, upper, runs, limits):
    solver = cc.ContactSolver(stacked_blocks(lower, upper), "gamma3", method="full", polish=False)
    p = solver.problem
    t0 = time.perf_counter()
    raw = signorini.full(p, Cache(), solver.settings, {})
    ipm = time.perf_counter() - t0
    free = ~p.held_rows
    kkt = mixed_kkt(p.blocks, p.E, p.g, translations=list(p.translations))
    y0, start = np.where(free, raw.y, 0.0), raw.active & free
    row = dict(size=f"{lower[0]}x{lower[1]}/{upper[0]}x{upper[1]}", rows=p.E.shape[0], unknowns=p.unknowns,
               ipm_s=ipm, results={})
    xs = {}
    for name, kw in VARIANTS.items():
        if p.E.shape[0] > limits.get(name, np.inf):
            continue
        t, out = timed(lambda: independent_active_set(kkt, p.g, y0, start, **kw), runs)
        assert not isinstance(out, str), (name, out)
        row["results"][name] = (t, out[2])
        xs[name] = kkt.stack(out[0])
    ref = xs["factored+crossover"]
    row["diff"] = max((np.abs(x - ref).max() / np.abs(ref).max() for x in xs.values()), default=0.0)
    return row


def condensed_case(lower, upper):
    sols = {m: cc.solve(squeezed(lower, upper), "gamma3", method=m) for m in ("condensed", "full")}
    c, f = sols["condensed"], sols["full"]
    scale = max(np.abs(u).max() for u in f.u)
    return dict(size=f"{lower[0]}x{lower[1]}/{upper[0]}x{upper[1]}", ok=c.ok and f.ok,
                finish=c.info.finish, condensed_polish_s=c.info.timings.get("polish", float("nan")),
                full_polish_s=f.info.timings.get("polish", float("nan")),
                diff=max(np.abs(a - b).max() for a, b in zip(c.u, f.u)) / scale)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["5x5/7x3", "10x10/12x8", "15x15/18x12"])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--sparse-max-rows", type=int, default=800, help="rows above which 'sparse' is skipped")
    ap.add_argument("--factored-max-rows", type=int, default=1600,
                    help="rows above which 'factored' (no crossover) is skipped")
    ap.add_argument("--condensed", action="store_true")
    args = ap.parse_args(argv)
    limits = {"sparse": args.sparse_max_rows, "sparse+crossover": args.sparse_max_rows,
              "factored": args.factored_max_rows}
    print("median of", args.runs, "runs, seconds (steps); ratio = sparse / factored+crossover; "
          "dx = max |x - x_default| / max |x_default| over the variants")
    print(f"{'size':12s} {'rows':>5s} {'unknowns':>8s} {'ipm':>6s} " + " ".join(f"{k:>18s}" for k in VARIANTS)
          + f" {'ratio':>7s} {'dx':>8s}")
    for text in args.sizes:
        r = finish_case(*parse_size(text), args.runs, limits)
        cells = [f"{r['results'][k][0]:10.3f} ({r['results'][k][1]:4d})" if k in r["results"] else f"{'-':>18s}"
                 for k in VARIANTS]
        ratio = (f"{r['results']['sparse'][0] / r['results']['factored+crossover'][0]:7.1f}"
                 if "sparse" in r["results"] else f"{'-':>7s}")
        print(f"{r['size']:12s} {r['rows']:5d} {r['unknowns']:8d} {r['ipm_s']:6.2f} " + " ".join(cells)
              + f" {ratio} {r['diff']:8.1e}", flush=True)
    if args.condensed:
        print("\nsqueezed (both bodies held by supports): the condensed route's finish against the full route's")
        print("size          condensed polish_s  full polish_s  max|du|/|u|  ok")
        for text in args.sizes:
            r = condensed_case(*parse_size(text))
            print(f"{r['size']:12s} {r['condensed_polish_s']:18.3f} {r['full_polish_s']:14.3f}  "
                  f"{r['diff']:.1e}      {r['ok']}", flush=True)


if __name__ == "__main__":
    main()
