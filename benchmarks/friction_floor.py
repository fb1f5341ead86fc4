"""Benchmark: the cost of the friction checks' force floor (``friction_scale``: each body's deformation, its rigid fit
taken out, docs/howto/friction.md "What is checked") beside the solve it belongs to, on the pushed block of
tests/friction_scenes.py refined to about ``--unknowns`` displacement unknowns (2D P1, Tresca, sliding):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests \
        python benchmarks/friction_floor.py [--unknowns 100000] [--dim 2]

CPU seconds (``time.process_time``, one thread) of: the whole ``cc.solve``; the rigid fits' set-up
(``DiscreteProblem.rigid_fits``, once per problem); one ``friction_scale`` call with the fits built (a solve calls it
twice: the finish and the read-back); the floor of |K| |u| it replaced (the same reaches on ``u`` itself). The
share is (set-up + 2 calls) / solve. Results: benchmarks/results/friction_floor.md.
"""

from __future__ import annotations

import argparse
import importlib
import time
import warnings

import friction_scenes as fs
import numpy as np

import cvxcontact as cc
from cvxcontact.backends.finish.forces import (
    FORCE_FLOOR,
    friction_scale,
    reach_forces,
    slip_reach,
)
from cvxcontact.solution.readback import read_back


def scene(unknowns: int, dim: int):
    """The block of :func:`friction_scenes.pushed` (2D) or its 3D twin, a cube pushed along x on its left face,
    with about ``unknowns`` displacement unknowns, Tresca g = 1e3 Pa (every row slides)."""
    if dim == 2:
        ny = max(2, round(np.sqrt(unknowns / 4)))
        m = cc.rectangle(x=(0.0, fs.L), y=(0.0, fs.H), nx=2 * ny, ny=ny)
        b = cc.Body(m, fs.steel(nu=0.0), contact="bottom", traction={"top": (0.0, -fs.P)},
                    displacement={"left": (1e-4, None)})
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", fs.FLOOR, law=cc.Tresca(1e3))])
    n = max(2, round((unknowns / 3) ** (1 / 3)))
    b = cc.Body(cc.box(nx=n, ny=n, nz=n), fs.steel(nu=0.0), contact="bottom", traction={"top": (0.0, 0.0, -fs.P)},
                displacement={"left": (1e-4, None, None)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", fs.FLOOR3D, law=cc.Tresca(1e3))])


def timed(f, repeat=3):
    """(the smallest CPU seconds of ``repeat`` calls of f, its value)."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.process_time()
        out = f()
        best = min(best, time.process_time() - t0)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--unknowns", type=int, default=100_000)
    parser.add_argument("--dim", type=int, default=2)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    seen = {}

    def spy(problem, raw, *a, **k):
        seen.update(problem=problem, raw=raw)
        return read_back(problem, raw, *a, **k)

    importlib.import_module("cvxcontact.solve").read_back = spy
    sc = scene(args.unknowns, args.dim)
    t0 = time.process_time()
    sol = cc.solve(sc, estimate=False)
    solve = time.process_time() - t0
    problem, raw = seen["problem"], seen["raw"]
    zero = np.zeros(problem.E.shape[0])

    def setup():
        problem.__dict__.pop("rigid_fits", None)
        return problem.rigid_fits

    fits, _ = timed(setup)
    call, C = timed(lambda: friction_scale(problem, raw.u, raw.phi, zero, zero))
    old, C_old = timed(lambda: FORCE_FLOOR * max(reach_forces(problem.blocks, problem.E, raw.u, raw.phi).max(),
                                                 slip_reach(problem.blocks, problem.term.data, raw.u, raw.phi).max()))
    n = sum(len(u) for u in raw.u)
    print(f"dim {args.dim}: {n} free unknowns, {problem.E.shape[0]} rows, ok {sol.ok}, finish {sol.info.finish}")
    print(f"solve {solve:.2f} s CPU; rigid fits set-up {fits * 1e3:.1f} ms; friction_scale {call * 1e3:.1f} ms "
          f"(floor {C:.3e}); the |K| |u| floor {old * 1e3:.1f} ms (floor {C_old:.3e})")
    print(f"share of the solve: (set-up + 2 calls) / solve = {(fits + 2 * call) / solve:.2%}; "
          f"added over the |K| |u| floor: {(fits + 2 * (call - old)) / solve:.2%}")


if __name__ == "__main__":
    main()
