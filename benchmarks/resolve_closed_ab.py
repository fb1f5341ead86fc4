"""A re-solve through a prepared ContactSolver with ``Condensation.invert_closed`` as before (the fields' backward
sweep, then a forward and a backward sweep of the closed rows' correction per body) and as now (one backward sweep
per body: the slack and the correction on the Gamma values), interleaved in ONE process.

Scene: ``apps.demo.two_blocks(nx)`` (as benchmarks/bench_resolve.py). The first solve once, then ``reps`` rounds of
a load case (the upper block's loads x 0.37 and its traction x 1 + round / 100: no two rounds alike, so neither side
reuses a forward sweep the other made) solved by each side in turn (order alternating), each with its new Scene;
process CPU seconds of ``solver.solve(other)``. Prints the medians, their ratio, the share of the first solve, and
the answers' agreement (max |a - b| / max |b| of u, phi, the contact forces) and the closed rows' slack over their
displacement scale on each side (what invert_closed refines).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_closed_ab.py 560 7
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import two_blocks_solver

from cvxcontact.backends import interface as im
from cvxcontact.backends.finish.lcp import closed_solve


def before(self, problem, y, active, timings):
    """invert_closed as at 73f4b4d (the fields' sweep, then S^{-1} of the correction: a forward and a backward
    sweep per body)."""
    E, g = problem.E, problem.g
    t0 = time.perf_counter()
    x = [c.back_substitute(f, E.T @ y) for c, f in zip(self.bodies, self.sweeps)]
    active = np.asarray(active, dtype=bool)
    if self.compliance is not None and active.any():
        slack = sum(R @ xk[c.gamma] for R, xk, c in zip(self.compliance.rows, x, self.bodies)) - g
        dy = closed_solve(self.compliance.W, slack, active, self.compliance.last_factor)
        y = y + dy
        x = [xk - c.solve(c.lift(E.T @ dy)) for xk, c in zip(x, self.bodies)]
    timings["back_substitution"] = timings.get("back_substitution", 0.0) + time.perf_counter() - t0
    return (*im.split(self.bodies, x, problem.blocks), y)


def main():
    warnings.simplefilter("ignore")
    nx, reps = int(sys.argv[1]), int(sys.argv[2])
    after = im.Condensation.invert_closed
    scene, solver, first = two_blocks_solver(nx)
    t, last = {"before": [], "after": []}, {}
    for r in range(reps):
        s = 0.37
        other = scene.with_loads(0, body_force=(0.0, -2e9 * s), traction={"right": (0.0, 3e8 * s * (1 + r / 100))},
                                 surface_charge={"left": -0.05 * s})
        for side in (("before", "after") if r % 2 == 0 else ("after", "before")):
            im.Condensation.invert_closed = before if side == "before" else after
            c0 = time.process_time()
            sol = solver.solve(other)
            t[side].append(time.process_time() - c0)
            last[side] = (r, sol)
    im.Condensation.invert_closed = after
    med = {k: statistics.median(v) for k, v in t.items()}
    print(f"two_blocks({nx}): first solve {first:.2f} s; re-solve before {med['before']:.3f}, after "
          f"{med['after']:.3f} s (ratio {med['after'] / med['before']:.3f}); share of the first solve "
          f"{100 * med['before'] / first:.2f} % -> {100 * med['after'] / first:.2f} %")
    (ra, a), (rb, b) = last["after"], last["before"]
    assert ra == rb

    def rel(p, q):
        p, q = np.concatenate([np.ravel(v) for v in p]), np.concatenate([np.ravel(v) for v in q])
        return float(np.abs(p - q).max() / np.abs(q).max())

    phi = [[p for p in s.phi if p is not None] for s in (a, b)]
    print(f"answers after vs before: u {rel(a.u, b.u):.1e}, phi {rel(*phi):.1e}, "
          f"force {rel([c.force for c in a.contacts], [c.force for c in b.contacts]):.1e}; ok {a.ok} {b.ok}")
    for side, sol in (("before", b), ("after", a)):
        print(side, "residuals", {k: f"{v:.1e}" for k, v in sol.residuals().items()})


if __name__ == "__main__":
    main()
