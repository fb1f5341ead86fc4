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
stacked unknowns, unique). The sparse steps are skipped above ``--sparse-max-rows`` (they take minutes).
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


def finish_case(lower, upper, runs, sparse_max_rows):
    solver = cc.ContactSolver(stacked_blocks(lower, upper), "gamma3", method="full", polish=False)
    p = solver.problem
    t0 = time.perf_counter()
    raw = signorini.full(p, Cache(), solver.settings, {})
    ipm = time.perf_counter() - t0
    free = ~p.held_rows
    kkt = mixed_kkt(p.blocks, p.E, p.g, translations=list(p.translations))
    y0, start = np.where(free, raw.y, 0.0), raw.active & free
    row = dict(size=f"{lower[0]}x{lower[1]}/{upper[0]}x{upper[1]}", rows=p.E.shape[0], unknowns=p.unknowns, ipm_s=ipm)
    t_f, out_f = timed(lambda: independent_active_set(kkt, p.g, y0, start, factored=True), runs)
    assert not isinstance(out_f, str), out_f
    row.update(factored_s=t_f, steps_f=out_f[2], active=int(out_f[1].sum()))
    if p.E.shape[0] <= sparse_max_rows:
        t_s, out_s = timed(lambda: independent_active_set(kkt, p.g, y0, start, factored=False), runs)
        assert not isinstance(out_s, str), out_s
        xs, xf = kkt.stack(out_s[0]), kkt.stack(out_f[0])
        row.update(sparse_s=t_s, steps_s=out_s[2], ratio=t_s / t_f, diff=np.abs(xf - xs).max() / np.abs(xs).max())
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
    ap.add_argument("--sparse-max-rows", type=int, default=800)
    ap.add_argument("--condensed", action="store_true")
    args = ap.parse_args(argv)
    print("size          rows  unknowns  steps(s/f)  ipm_s   sparse_s  factored_s  sparse/factored  max|dx|/|x|")
    for text in args.sizes:
        r = finish_case(*parse_size(text), args.runs, args.sparse_max_rows)
        sparse = f"{r['sparse_s']:8.3f}" if "sparse_s" in r else "       -"
        ratio = f"{r['ratio']:15.1f}" if "ratio" in r else "              -"
        diff = f"{r['diff']:.1e}" if "diff" in r else "-"
        steps = f"{r.get('steps_s', '-')}/{r['steps_f']}"
        print(f"{r['size']:12s} {r['rows']:5d} {r['unknowns']:9d}  {steps:>10s} {r['ipm_s']:6.2f}  {sparse}  "
              f"{r['factored_s']:10.3f}  {ratio}  {diff}", flush=True)
    if args.condensed:
        print("\nsqueezed (both bodies held by supports): the condensed route's finish against the full route's")
        print("size          condensed polish_s  full polish_s  max|du|/|u|  ok")
        for text in args.sizes:
            r = condensed_case(*parse_size(text))
            print(f"{r['size']:12s} {r['condensed_polish_s']:18.3f} {r['full_polish_s']:14.3f}  "
                  f"{r['diff']:.1e}      {r['ok']}", flush=True)


if __name__ == "__main__":
    main()
