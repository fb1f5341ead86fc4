"""Benchmark: friction with P2 elements under "gamma3" (the cones of every element, a friction row at every node of
X_h; docs/howto/friction.md, "P2 under 'gamma3'") against the nodal P2 friction under "sigma1", on the scenes of
tests/friction_scenes.py:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=.:tests \
        python benchmarks/friction_p2_gamma3.py

Per scene: the checks (equilibrium, complementarity, cone, friction cone, stick-slip) of the interior point
(``polish=False``) and of the answer (finished on the nodes, or why the finish was declined), the answer's relative
distance to the "sigma1" answer, the fixed point's iterations (Coulomb) and the CPU seconds of one "gamma3" and one
"sigma1" solve (process time, one thread; the estimate off).
"""

from __future__ import annotations

import time
import warnings

import friction_scenes as fs
import numpy as np

import cvxcontact as cc

KEYS = ("equilibrium", "complementarity", "cone", "friction cone", "stick-slip")


def timed(scene, **options):
    t0 = time.process_time()
    sol = cc.solve(scene, degree=2, estimate=False, **options)
    return sol, time.process_time() - t0


def row(name, scene, nodal_scene=None) -> None:
    """``nodal_scene``: the scene under "sigma1" where its pairs name their own condition (else ``scene``)."""
    ipm, _ = timed(scene, condition="gamma3", polish=False)
    cones, t_cones = timed(scene, condition="gamma3")
    nodal, t_nodal = timed(scene if nodal_scene is None else nodal_scene, condition="sigma1")

    def fmt(sol):
        return " ".join(f"{sol.residuals().get(k, 0.0):.1e}" for k in KEYS)

    du = max(np.abs(a - b).max() for a, b in zip(cones.u, nodal.u)) / max(np.abs(b).max() for b in nodal.u)
    state = "finished" if cones.polished else f"declined ({cones.info.declined.split('(')[-1].rstrip(')')})"
    print(f"{name:30s} ipm [{fmt(ipm)}] answer [{fmt(cones)}] {state}; vs sigma1 {du:.1e}; "
          f"fixed point {len(cones.info.fixed_point)}; CPU gamma3 {t_cones:.2f} s, sigma1 {t_nodal:.2f} s", flush=True)


def main() -> None:
    warnings.simplefilter("ignore")
    P = fs.P
    print("columns:", KEYS)
    row("2D stuck q=.2P g=1e9", fs.sheared(0.2 * P, cc.Tresca(1e9)))
    row("2D partial q=.2P g=3e6", fs.sheared(0.2 * P, cc.Tresca(3e6)))
    row("2D Coulomb partial mu=.25", fs.sheared(0.2 * P, cc.Coulomb(0.25)))
    row("2D pushed g=1e3", fs.pushed(cc.Tresca(1e3))[1])
    row("2D pushed Coulomb mu=1e-5", fs.pushed(cc.Coulomb(1e-5))[1])
    row("2D partial 32x16 g=3e6", fs.sheared(0.2 * P, cc.Tresca(3e6), nx=32, ny=16))
    row("2D pair q=.02P g=.03P", fs.pair2d(cc.Tresca(0.03 * P), 0.02 * P, condition="gamma3"),
        fs.pair2d(cc.Tresca(0.03 * P), 0.02 * P))
    body = cc.Body(cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=8, ny=4), fs.steel(), contact="bottom", clamped="top")
    disk = cc.Rigid.circle(center=(0.0, -1.0), radius=1.0 + 1e-4)              # pressed 1e-4 m into a disk
    row("2D disk g=1e4 (cut points)", cc.Scene(body, contacts=[cc.Contact(body, "bottom", disk, law=cc.Tresca(1e4))]))
    row("3D layer stuck", fs.uniform_layer3d(0.2 * P, cc.Tresca(2 * P)))
    row("3D pair stuck", fs.uniform_pair3d(0.2 * P, cc.Tresca(2 * P)))
    row("3D pair Coulomb mu=.5", fs.uniform_pair3d(0.2 * P, cc.Coulomb(0.5)))
    row("3D layer sliding g=1e5", fs.sliding_layer3d(1e5))
    row("3D box q=(.2,.1)P g=3e6", fs.box((0.2 * P, 0.1 * P), cc.Tresca(3e6)))
    print(f"CPU total {time.process_time():.1f} s")


if __name__ == "__main__":
    main()
