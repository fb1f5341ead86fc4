"""Every canonical scene of the test suite (2D: tests/scenes.py, 3D: tests/scenes3d.py) under the P2 "everywhere"
condition (``degree=2, condition="gamma3"``; a pair's own condition or law kept), at the default tol: whether
the answer is ``ok``, which exact finish ran, its checks and the wall time. A table of what
docs/checks.md promises for the conic condition, measured; not a pass/fail test (the 3D scenes take minutes).

    python benchmarks/canonical_p2_gamma3.py [--2d] [--3d] [--out results/canonical_p2_gamma3.md]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))                      # this checkout
sys.path.insert(0, str(ROOT / "tests"))            # the canonical scenes
sys.path.insert(0, str(Path(__file__).resolve().parent))  # harness

from harness import write_report

import cvxcontact as cc


def rows(scenes, dim):
    for name, (build, kw) in scenes.items():
        kw = {**{k: v for k, v in kw.items() if k != "tol"}, "condition": "gamma3", "degree": 2}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            t0 = time.perf_counter()
            sol = cc.solve(build(), **kw)
            seconds = time.perf_counter() - t0
        r = sol.residuals()
        row = dict(dim=dim, scene=name, ok=sol.ok, finish=str(sol.info.finish or "none"), seconds=seconds,
                   warnings=len(caught), **{k: r.get(k) for k in ("equilibrium", "feasibility", "complementarity",
                                                                 "energy error")})
        print("  ".join(f"{v:.1e}" if isinstance(v, float) else str(v) for v in row.values()), flush=True)
        yield row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--2d", dest="two", action="store_true", help="the 2D scenes only")
    ap.add_argument("--3d", dest="three", action="store_true", help="the 3D scenes only")
    ap.add_argument("--out", type=Path, default=None, help="a Markdown table to write")
    args = ap.parse_args(argv)
    both = not (args.two or args.three)
    out = []
    if args.two or both:
        from scenes import SCENES
        out += list(rows(SCENES, 2))
    if args.three or both:
        from scenes3d import SCENES3D
        out += list(rows(SCENES3D, 3))
    if args.out:
        f = lambda v: "—" if v is None else f"{v:.1e}"
        lines = ["| dim | scene | ok | finish | equilibrium | feasibility | complementarity | energy error | s |",
                 "|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r['dim']}D | {r['scene']} | {r['ok']} | {r['finish']} | {f(r['equilibrium'])} | "
                  f"{f(r['feasibility'])} | {f(r['complementarity'])} | {f(r['energy error'])} | {r['seconds']:.1f} |"
                  for r in out]
        write_report(args.out, lines)
    return 0 if all(r["ok"] for r in out) else 1


if __name__ == "__main__":
    sys.exit(main())
