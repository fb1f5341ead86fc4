"""Benchmark: the checks of friction answers before (``polish=False``, the interior point) and after the exact
finish (docs/howto/friction.md, "The exact finish"), on the 2D scenes of tests/friction_scenes.py and the 3D
scenes of tests/test_friction3d.py, with the closed forms there (the block that sticks against the tied block,
the block that slides against its friction force -g L):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 OPENBLAS_CORETYPE=Haswell \
        PYTHONPATH=.:tests python benchmarks/friction_finish.py

(and ``OPENBLAS_CORETYPE=Prescott``). Columns: equilibrium, complementarity, friction cone, stick-slip, slip
direction; then whether the finish was accepted and its relative distance to the interior point's answer.
"""

from __future__ import annotations

import warnings

import friction_scenes as fs
import numpy as np
import test_friction3d as t3

import cvxcontact as cc

KEYS = ("equilibrium", "complementarity", "friction cone", "stick-slip", "slip direction")


def row(name, scene, tol=1e-6):
    """Solve ``scene`` without and with the finish; print their checks; the finished Solution."""
    a = cc.solve(scene, polish=False, tol=tol, estimate=False)
    b = cc.solve(scene, tol=tol, estimate=False)

    def fmt(sol):
        return " ".join(f"{sol._checks[k]:.1e}" for k in KEYS)

    du = np.abs(a.u[0] - b.u[0]).max() / np.abs(b.u[0]).max()
    print(f"{name:28s} before [{fmt(a)}]  after [{fmt(b)}] {b.info.finish is not None} |du|/|u| {du:.1e}", flush=True)
    return b


def main() -> None:
    warnings.simplefilter("ignore")
    P, L = fs.P, fs.L
    print("columns:", KEYS)
    s = row("2D T stick q=.2P g=1e7", fs.sheared(0.2 * P, cc.Tresca(1e7)))
    tied = cc.solve(fs.sheared(0.2 * P, None, tied=True))
    print("   vs tied:", np.abs(s.u[0] - tied.u[0]).max() / np.abs(tied.u[0]).max())
    s = row("2D T partial q=.9g g=1e6", fs.sheared(0.9e6, cc.Tresca(1e6)))
    print("   shear sum + q L:", abs(s.contact.shear_force.sum() + 0.9e6 * L) / (0.9e6 * L),
          " max |shear|/g - 1 on slip:", np.abs(np.abs(s.contact.shear[np.abs(s.contact.slip) > 0]) / 1e6 - 1).max())
    for g in (1e2, 1e3):
        s = row(f"2D T pushed g={g:g}", fs.pushed(cc.Tresca(g))[1])
        print("   shear sum + g L:", abs(s.contact.shear_force.sum() + g * L) / (g * L))
    s = row("2D C stick mu=0.8", fs.sheared(0.2 * P, cc.Coulomb(0.8)))
    print("   vs tied:", np.abs(s.u[0] - tied.u[0]).max() / np.abs(tied.u[0]).max())
    s = row("2D C partial q=.35P mu=.4", fs.sheared(0.35 * P, cc.Coulomb(0.4)))
    for mu in (1e-5, 1e-4):
        s = row(f"2D C pushed mu={mu:g}", fs.pushed(cc.Coulomb(mu))[1])
        print("   shear sum + mu P L:", abs(s.contact.shear_force.sum() + mu * P * L) / (mu * P * L))
    q = 0.2 * P * t3.DIAGONAL
    s = row("3D T stick g=1e9", t3.sheared(q, cc.Tresca(1e9)))
    s = row("3D T partial g=.3P", t3.sheared(q, cc.Tresca(0.3 * P)))
    for g in (1e2, 1e3):
        s = row(f"3D T pushed g={g:g}", t3.pushed(cc.Tresca(g)))
        f = s.contact.shear_force.sum(axis=0)
        print("   |force/g + t|:", np.abs(f / g + t3.DIAGONAL).max())
    for mu in (1e-5, 1e-4):
        s = row(f"3D C pushed mu={mu:g}", t3.pushed(cc.Coulomb(mu)))
        print("   |force/(mu P) + t|:", np.abs(s.contact.shear_force.sum(axis=0) / (mu * P) + t3.DIAGONAL).max())
    for law in (cc.Tresca(0.3 * P), cc.Coulomb(0.4)):
        s = row(f"3D rigid {law.name}", t3.sheared(q, law), tol=1e-3)
        for stiffer in (1e3, 1e4):
            s = row(f"3D pair {law.name} {stiffer:g}", t3.pair(law, stiffer, q), tol=1e-3)
            print("   shear sum + q:", np.abs(s.contact.shear_force.sum(axis=0) + q).max() / np.abs(q).max())


if __name__ == "__main__":
    main()
