"""Benchmark: where the exact finish of friction with P2 elements under "gamma3" is declined, and why (the scenes of
tests/friction_scenes.py, tests/friction_box_scenes.py, tests/test_friction_p2_gamma3.py and the sheared Hencky block
of tests/test_friction_hencky.py, fs.sheared_hencky):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests \
        python benchmarks/friction_p2_declines.py

One row per scene: its mesh, its law, whether the finish was declined and the words of the decline, the largest
violation of the checks (equilibrium, complementarity, cone, friction cone, stick-slip) and the CPU seconds of the
solve (process time, one thread; the estimate off).
"""

from __future__ import annotations

import sys
import time
import warnings

import friction_box_scenes as fb
import friction_scenes as fs

import cvxcontact as cc

KEYS = ("equilibrium", "complementarity", "cone", "friction cone", "stick-slip")


P = fs.P
SCENES = {
    "2D sheared stuck": ("8x4", "Tresca 1e9", lambda: fs.sheared(0.2 * P, cc.Tresca(1e9))),
    "2D sheared partial": ("8x4", "Tresca 3e6", lambda: fs.sheared(0.2 * P, cc.Tresca(3e6))),
    "2D sheared partial C": ("8x4", "Coulomb .25", lambda: fs.sheared(0.2 * P, cc.Coulomb(0.25))),
    "2D pushed": ("8x4", "Tresca 1e3", lambda: fs.pushed(cc.Tresca(1e3))[1]),
    "2D pushed C": ("8x4", "Coulomb 1e-5", lambda: fs.pushed(cc.Coulomb(1e-5))[1]),
    "2D patch": ("8x4", "Tresca 1e6", lambda: fs.patch(cc.Tresca(1e6))),
    "2D patch C": ("8x4", "Coulomb .3", lambda: fs.patch(cc.Coulomb(0.3))),
    "2D walled": ("8x4", "Tresca 1e6", lambda: fs.walled(cc.Tresca(1e6))),
    "2D pair2d": ("7x3/9x3", "Tresca .03P", lambda: fs.pair2d(cc.Tresca(0.03 * P), 0.02 * P, condition="gamma3")),
    "2D pair2d C": ("7x3/9x3", "Coulomb .3", lambda: fs.pair2d(cc.Coulomb(0.3), 0.02 * P, condition="gamma3")),
    "2D disk g=1e3": ("8x4", "Tresca 1e3", lambda: fs.pressed_disk(cc.Tresca(1e3))),
    "2D disk g=1e6": ("8x4", "Tresca 1e6", lambda: fs.pressed_disk(cc.Tresca(1e6))),
    "2D disk g=1e8": ("8x4", "Tresca 1e8", lambda: fs.pressed_disk(cc.Tresca(1e8))),
    "2D disk 16x8": ("16x8", "Tresca 1e6", lambda: fs.pressed_disk(cc.Tresca(1e6), nx=16, ny=8)),
    "2D disk C": ("8x4", "Coulomb .3", lambda: fs.pressed_disk(cc.Coulomb(0.3))),
    "2D disk C 16x8": ("16x8", "Coulomb .3", lambda: fs.pressed_disk(cc.Coulomb(0.3), nx=16, ny=8)),
    "2D dragged": ("8x4", "Tresca 1e6", lambda: fs.dragged_disk(cc.Tresca(1e6))),
    "2D dragged C": ("8x4", "Coulomb .3", lambda: fs.dragged_disk(cc.Coulomb(0.3))),
    "2D tilted 7": ("7x8", "Tresca .6P", lambda: fs.tilted(cc.Tresca(0.6 * P), 7)),
    "2D tilted 8": ("8x8", "Tresca .6P", lambda: fs.tilted(cc.Tresca(0.6 * P), 8)),
    "2D tilted 7 C": ("7x8", "Coulomb .6", lambda: fs.tilted(cc.Coulomb(0.6), 7)),
    "2D tilted 8 C": ("8x8", "Coulomb .6", lambda: fs.tilted(cc.Coulomb(0.6), 8)),
    "2D Hencky sheared": ("8x4", "Tresca 6e7", lambda: fs.sheared_hencky(cc.Tresca(0.6e8))),
    "3D layer stuck": ("2x2x1", "Tresca 2P", lambda: fs.uniform_layer3d(0.2 * P, cc.Tresca(2 * P))),
    "3D layer sliding": ("2x2x1", "Tresca 1e5", lambda: fs.sliding_layer3d(1e5)),
    "3D pair stuck": ("2x2x1", "Tresca 2P", lambda: fs.uniform_pair3d(0.2 * P, cc.Tresca(2 * P))),
    "3D box sheared": ("3x3x2", "Tresca 3e6", lambda: fs.box((0.2 * P, 0.1 * P), cc.Tresca(3e6))),
    "3D box sheared C": ("3x3x2", "Coulomb .3", lambda: fb.sheared(0.2 * P * fb.DIAGONAL, cc.Coulomb(0.3))),
    "3D box pushed": ("3x3x2", "Tresca 1e5", lambda: fb.pushed(cc.Tresca(1e5))),
    "3D box held side": ("3x3x2", "Tresca 3e6", lambda: fb.held_side(cc.Tresca(3e6))),
    "3D box non-matching": ("3x3x2/4x4x2", "Tresca 3e6", lambda: fb.non_matching(cc.Tresca(3e6))),
}


def main(names) -> None:
    warnings.simplefilter("ignore")
    print("| scene | mesh | law | declined | reason | worst check | CPU s |\n|---|---|---|---|---|---|---|", flush=True)
    for name, (mesh, law, make) in SCENES.items():
        if names and not any(n in name for n in names):
            continue
        t0 = time.process_time()
        try:
            sol = cc.solve(make(), condition="gamma3", degree=2, estimate=False)
        except cc.errors.CvxContactError as e:              # a refusal
            print(f"| {name} | {mesh} | {law} | refused | {type(e).__name__}: {str(e)[:80]} | | |", flush=True)
            continue
        cpu = time.process_time() - t0
        r = sol.residuals()
        worst = max(r.get(k, 0.0) for k in KEYS)
        why = "" if sol.polished else sol.info.declined.split("(", 1)[-1].rstrip(")")
        print(f"| {name} | {mesh} | {law} | {'no' if sol.polished else 'yes'} | {why} | {worst:.1e} | {cpu:.2f} |",
              flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
