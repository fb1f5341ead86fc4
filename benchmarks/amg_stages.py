"""Where one solve of the AMG route goes, by stage, and what the final set's Krylov solve is made of.

Scene: ``two_boxes`` (tests/scenes3d.py, PZT-5A on aluminium, "sigma1"), ``--n`` cells a side (38: 148,524
unknowns, bench3d.py's 1.5e5). One ``ContactSolver.solve`` under ``cProfile`` with ``time.process_time`` (the
assembly, ``ContactSolver``'s construction, timed apart); each call of ``KrylovContact._system`` (one Krylov solve:
a set and a tolerance) logged with its closed rows, tolerance, Krylov iterations, relative start residual
||b - K r0|| / ||b||, CPU seconds and the settled stop's verdicts (count and CPU seconds). Then, with
``--final``, the final set's Krylov solve to ``RTOL`` from zero (on the route's hierarchy, built on the first
set, its V-cycle corrected on the contact dofs) and on a hierarchy built on the final set itself, from zero and
from the final set's own start (the previous set's answer) through the route's stages: what one hierarchy
across sets costs in iterations.

Run (one thread: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/amg_stages.py --n 38 --final

Printed: the CPU seconds of the assembly and the solve, the solve's stages (cumulative CPU seconds of the
profiled functions), the per-solve log, and with ``--final`` the iterations of the three final-set solves.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes

STAGES = {  # label: (file suffix, function name) of the profiled stage (cumulative CPU seconds)
    "route (active-set steps)": ("backends/amg.py", "solve"),
    "  Krylov solves (GMRES/CG)": ("backends/krylov.py", "gmres"),
    "    preconditioner applications": ("backends/amg.py", "apply"),
    "    products with the set's operator (Reduced)": ("backends/amg.py", "_matvec"),
    "  hierarchy set-up (pyamg)": ("backends/amg.py", "_hierarchy"),
    "  K formed for the set-up (congruence)": ("backends/amg.py", "tocsr"),
    "  the sets' preconditioners (contact-dof factor, Kup)": ("backends/amg.py", "_precondition"),
    "  the sets' operators (_reduced)": ("backends/amg.py", "_reduced"),
    "KrylovContact built (S stacked, own dofs)": ("backends/amg.py", "__init__"),
    "read-back, checks, estimate": ("cvxcontact/solve.py", "_read"),
    "  estimate": ("solution/estimate.py", "estimate"),
    "  read-back": ("solution/readback.py", "read_back"),
}


def main() -> None:
    from scenes3d import two_boxes

    import cvxcontact as cc
    from cvxcontact.backends import amg
    from cvxcontact.backends.condensed import quasi_definite_rhs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=38, help="cells a side (38: 148,524 unknowns)")
    ap.add_argument("--final", action="store_true", help="the final set's solves on the two hierarchies")
    args = ap.parse_args()

    log, starts, system = [], [], amg.KrylovContact._system

    def logged(self, active, F, g, x_start, rtol=amg.RTOL, verdict=None):
        rows = np.flatnonzero(active)
        _, _, K, b = self._reduced(rows, F, g)
        r0 = np.zeros(self.n) if x_start is None else np.array(x_start)
        r0[self.dof[rows]] = 0.0
        start = np.linalg.norm(b - K @ r0) / max(np.linalg.norm(b), np.finfo(float).tiny)
        starts.append((active.tobytes(), None if x_start is None else np.array(x_start)))
        asked = [0, 0.0]
        if verdict is not None:
            inner = verdict

            def verdict(x, y):
                c = time.process_time()
                out = inner(x, y)
                asked[0], asked[1] = asked[0] + 1, asked[1] + time.process_time() - c
                return out
        i0, c0 = self.iterations, time.process_time()
        out = system(self, active, F, g, x_start, rtol, verdict)
        log.append((int(active.sum()), rtol, self.iterations - i0, start, time.process_time() - c0, *asked))
        return out

    cc.solve(two_boxes(4), method="amg")                                  # imports, first-call set-up
    amg.KrylovContact._system = logged
    c0 = time.process_time()
    solver = cc.ContactSolver(two_boxes(args.n), method="amg")
    assembly = time.process_time() - c0
    prof = cProfile.Profile(time.process_time)
    c0 = time.process_time()
    prof.enable()
    sol = solver.solve()
    prof.disable()
    cpu = time.process_time() - c0
    amg.KrylovContact._system = system
    kc = solver.cache.amg
    print(f"two_boxes({args.n}): assembly {assembly:.2f} CPU s, solve {cpu:.2f} CPU s, ok {sol.ok}, "
          f"{sol.info.iterations} sets, {kc.iterations} Krylov iterations, {kc.setups} hierarchy set-up(s)")
    stats = pstats.Stats(prof).stats
    for label, (suffix, name) in STAGES.items():
        hits = [(v[3], v[1]) for (f, _, fn), v in stats.items() if f.endswith(suffix) and fn == name]
        cum, calls = max(hits, default=(0.0, 0))      # the outermost of the functions of that name there
        print(f"  {label:<56s} {cum:7.2f} CPU s ({calls} calls)")
    print("  per Krylov solve: closed rows / rtol: iterations, start residual, CPU s, verdicts (CPU s)")
    for rows, rtol, its, start, c, nv, cv in log:
        print(f"    {rows:6d} / {rtol:.0e}: {its:3d}, {start:.2e}, {c:6.2f}, {nv} ({cv:.3f})")
    if not args.final:
        return
    p = solver.problem
    final = solver.cache.active & (kc.dof >= 0)
    F, g = np.concatenate([quasi_definite_rhs(b) for b in p.blocks]), p.g
    warm = next(x for key, x in starts if key == final.tobytes())
    kc._stacked()

    def iterations(k, x, stages):
        i0 = k.iterations
        k._preconditioner = None
        for rtol in stages:
            x, _ = k._system(final, F, g, x, rtol)
        return k.iterations - i0

    stages = amg.STEP_RTOLS[1:] + (amg.RTOL,)
    print(f"  final set ({int(final.sum())} rows closed), Krylov iterations:")
    print(f"    the route's hierarchy, from zero to RTOL: {iterations(kc, None, (amg.RTOL,))}")
    own = amg.KrylovContact(p)
    print(f"    its own hierarchy, from zero to RTOL: {iterations(own, None, (amg.RTOL,))}")
    print(f"    from its start through {stages}: the route's hierarchy {iterations(kc, warm, stages)}, "
          f"its own {iterations(own, warm, stages)}")


if __name__ == "__main__":
    main()
