"""Benchmark: how far the friction finish under the 3D P2 cones stands from the exact answer (Tresca, "gamma3").

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests \\
        python benchmarks/friction_p2_tangency3d.py [sphere] [boxes] [held] [shears] [coulomb]

``sphere``: a rigid sphere pressed 5 mm into a clamped P2 block (tests/scenes3d.py ``sphere_into_block``, 4 x 4 x 2
cells, Tresca 1 MPa), touching each top triangle at isolated points: the cuts' answer alone (the tangency finish off)
at stops 1e-7 .. 1e-11 (``friction.CONE_ROUNDING``) against the answer finished at the tangency points
(``frictiontangency.tangency_polish``); then, as the threshold tends to 0, the distance of the finished answer and of
the cuts' alone to the frictionless cones' exact answer (the tangency Newton). ``boxes``: the 3D boxes lifting at a
corner (tests/friction_box_scenes.py), where the tangency Newton declines and the sheared box is finished on its
ridges (``ridges.ridge_newton``): at cuts' stops 1e-7 .. 1e-11 the answer finished from them and the cuts' alone
against the one at the package's stop. ``shears``: the box under other shears and thresholds, the held-side box and
Coulomb on the box sheared along a diagonal (where touching points and ridges mix): finished or not, and the cuts'
answer alone against the finished one. ``coulomb``: Coulomb on the box sheared along a diagonal finished from cuts
stopped at 1e-9 .. 1e-11 and on the mirrored mesh, against the answer at the package's stop. Distances: the largest
displacement difference over the largest displacement.
"""

from __future__ import annotations

import sys
import time
import warnings

import friction_box_scenes as fb
import friction_scenes as fs
import numpy as np
from scenes3d import sphere_into_block

import cvxcontact as cc
from cvxcontact.backends import friction, frictiontangency
from cvxcontact.backends.finish import Declined, Stop

P2 = {"condition": "gamma3", "degree": 2, "estimate": False}


def apart(a, b) -> float:
    return max(float(np.abs(u - v).max()) for u, v in zip(a.u, b.u)) / max(float(np.abs(v).max()) for v in b.u)


def solve(scene, tol=None, polish=True):
    """The P2 "gamma3" answer of ``scene`` with the cuts stopped at ``tol`` (default the package's), the tangency
    finish on or off; its CPU seconds as ``cpu``, whether the finish at the tangency points (or on the ridges)
    finished it as ``finished``."""
    kept, cut, seen = frictiontangency._polish, friction.CONE_ROUNDING, []
    if tol is not None:
        friction.CONE_ROUNDING = tol

    def spy(*args):                     # polish off: a decline, so the cuts' answer is kept (frictiontangency.kept)
        out = kept(*args) if polish else Declined(Stop.NOT_POSED, "the polish is off")
        seen.append(not isinstance(out, Declined))
        return out

    frictiontangency._polish = spy
    try:
        t0 = time.process_time()
        sol = cc.solve(scene, **P2)
        sol.cpu, sol.finished = time.process_time() - t0, (sum(seen), len(seen)) if len(seen) > 1 else any(seen)
        return sol
    finally:
        frictiontangency._polish, friction.CONE_ROUNDING = kept, cut


def sphere() -> None:
    make = lambda law: sphere_into_block(4, depth=0.005, law=law)
    exact = solve(make(cc.Tresca(1e6)))
    print(f"sphere, Tresca 1e6: finished at the tangency points, CPU {exact.cpu:.1f} s\n")
    print("| cuts' stop | cuts' answer from the finished one | CPU s |\n|---|---|---|")
    for tol in (1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        cuts = solve(make(cc.Tresca(1e6)), tol, polish=False)
        print(f"| {tol:.0e} | {apart(cuts, exact):.2e} | {cuts.cpu:.1f} |", flush=True)
    free = solve(make(None))
    print(f"\nfrictionless: {free.info.finish}\n")
    print("| threshold g | finished from frictionless | cuts' alone from frictionless |\n|---|---|---|")
    for g in (1.0, 1e1, 1e2, 1e3, 1e4):
        print(f"| {g:.0e} | {apart(solve(make(cc.Tresca(g))), free):.3e} | "
              f"{apart(solve(make(cc.Tresca(g)), polish=False), free):.3e} |", flush=True)


def boxes() -> None:
    P = fs.P
    scenes = {"sheared": lambda: fs.box((0.2 * P, 0.1 * P), cc.Tresca(3e6)),
              "held side": lambda: fb.held_side(cc.Tresca(3e6)),
              "held side mirrored": lambda: fb.held_side(cc.Tresca(3e6), mesh=fb.mirrored_box(), q=-0.2 * P)}
    for name, make in scenes.items():
        ref = solve(make())
        print(f"\nbox {name}: at the package's stop (1e-9) finished at the tangency points or on the ridges: "
              f"{ref.finished}, CPU {ref.cpu:.1f} s\n")
        print("| cuts' stop | finished | its answer from the package's | cuts' alone from the package's | CPU s |\n"
              "|---|---|---|---|---|")
        for tol in (1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
            done, cuts = solve(make(), tol), solve(make(), tol, polish=False)
            print(f"| {tol:.0e} | {done.finished} | {apart(done, ref):.2e} | {apart(cuts, ref):.2e} | "
                  f"{done.cpu:.1f} |", flush=True)


def held() -> None:
    make = lambda: fb.held_side(cc.Tresca(3e6))
    ref = solve(make())
    print(f"held side at the package's stop: finished {ref.finished}, CPU {ref.cpu:.1f} s\n")
    print("| cuts' stop | finished | its answer from the package's | CPU s |\n|---|---|---|---|")
    for tol in (1e-7, 1e-8, 1e-10, 1e-11):
        done = solve(make(), tol)
        print(f"| {tol:.0e} | {done.finished} | {apart(done, ref):.2e} | {done.cpu:.1f} |", flush=True)


def shears() -> None:
    P = fs.P
    scenes = {f"box ({a}, {b}) p, Tresca {c / 1e6} MPa": (lambda a=a, b=b, c=c: fs.box((a * P, b * P), cc.Tresca(c)))
              for a, b, c in ((-0.2, 0.1, 3e6), (0.2, -0.1, 3e6), (0.2, 0.0, 3e6), (0.0, 0.2, 3e6), (0.2, 0.2, 3e6),
                              (0.2, 0.1, 2.5e6), (0.2, 0.1, 5e6))}
    scenes["held side, Tresca 3 MPa"] = lambda: fb.held_side(cc.Tresca(3e6))
    scenes["box sheared 0.2 p along a diagonal, Coulomb 0.3"] = \
        lambda: fb.sheared(0.2 * fb.P * fb.DIAGONAL, cc.Coulomb(0.3))
    print("| scene | finishes (one per polish) | cuts' alone from the answer | CPU s |\n|---|---|---|---|")
    for name, make in scenes.items():
        done, cuts = solve(make()), solve(make(), polish=False)
        print(f"| {name} | {done.finished} | {apart(cuts, done):.2e} | {done.cpu:.1f} |", flush=True)


def coulomb() -> None:
    def make(mesh=fb.BOX, sign=1.0):
        return fb.sheared(0.2 * fb.P * fb.DIAGONAL * [1.0, sign], cc.Coulomb(0.3), mesh=mesh)

    ref = solve(make())
    print(f"Coulomb 0.3, box sheared along a diagonal: finishes {ref.finished}, CPU {ref.cpu:.1f} s\n")
    print("| cuts' stop | finishes | its answer from the package's | cuts' alone from the package's | CPU s |\n"
          "|---|---|---|---|---|")
    for tol in (1e-9, 1e-10, 1e-11):
        done, cuts = solve(make(), tol), solve(make(), tol, polish=False)
        print(f"| {tol:.0e} | {done.finished} | {apart(done, ref):.2e} | {apart(cuts, ref):.2e} | {done.cpu:.1f} |",
              flush=True)
    mirrored = solve(make(fb.mirrored_box(), -1.0))
    at = {tuple(np.round(p, 9)): i for i, p in enumerate(mirrored.points[0])}
    image = np.array([at[tuple(np.round(p * [1.0, -1.0, 1.0] + [0.0, 1.0, 0.0], 9) + 0.0)] for p in ref.points[0]])
    off = np.abs(mirrored.u[0][image] * [1.0, -1.0, 1.0] - ref.u[0]).max() / np.abs(ref.u[0]).max()
    print(f"\nmirrored about y = 1/2 (shear (q_x, -q_y)): finishes {mirrored.finished}, from the first {off:.1e}")


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    which = sys.argv[1:] or ["sphere", "boxes"]
    for name in which:
        {"sphere": sphere, "boxes": boxes, "held": held, "shears": shears, "coulomb": coulomb}[name]()
