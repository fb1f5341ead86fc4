"""Benchmark: the checks of friction answers before (``polish=False``, the interior point) and after the exact
finish (docs/howto/friction.md, "The exact finish"), on the 2D scenes of tests/friction_scenes.py and the 3D
scenes of tests/friction_box_scenes.py, with the closed forms of tests/test_friction3d.py (the block that sticks
against the tied block, the block that slides against its friction force -g L), the box held along one tangent on a
side, and the pair whose faces do not match (nodal "sigma1" and dependent overlay "gamma3" rows):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 OPENBLAS_CORETYPE=Haswell \
        PYTHONPATH=.:tests python benchmarks/friction_finish.py

(and ``OPENBLAS_CORETYPE=Prescott``); ``--large`` adds the "gamma3" pair on finer meshes (n x n on m x m cells:
its rows, the finish's steps and the wall seconds of the interior point and of the finish). Columns: equilibrium, complementarity, friction cone, stick-slip, slip
direction; then whether the finish was accepted (else why it was declined, ``info.declined``) and its relative
distance to the interior point's answer.
"""

from __future__ import annotations

import warnings

import friction_box_scenes as t3
import friction_scenes as fs
import numpy as np

import cvxcontact as cc

KEYS = ("equilibrium", "complementarity", "friction cone", "stick-slip", "slip direction")


def row(name, scene, tol=1e-6, **options):
    """Solve ``scene`` without and with the finish (``options``: cc.solve's, e.g. the condition); print their
    checks; the finished Solution."""
    a = cc.solve(scene, polish=False, tol=tol, estimate=False, **options)
    b = cc.solve(scene, tol=tol, estimate=False, **options)

    def fmt(sol):
        return " ".join(f"{sol._checks[k]:.1e}" for k in KEYS)

    du = max(np.abs(ua - ub).max() for ua, ub in zip(a.u, b.u)) / max(np.abs(ub).max() for ub in b.u)
    done = b.info.finish is not None
    print(f"{name:28s} before [{fmt(a)}]  after [{fmt(b)}] {done} |du|/|u| {du:.1e}"
          + ("" if done else f" (declined: {getattr(b.info, 'declined', '?')})"), flush=True)
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
    s = row("3D held side T stick g=1e9", t3.held_side(cc.Tresca(1e9)))
    tied = cc.solve(t3.held_side(None, tied=True), estimate=False)
    print("   vs tied:", np.abs(s.u[0] - tied.u[0]).max() / np.abs(tied.u[0]).max())
    largest = np.linalg.norm(s.contact.shear, axis=1).max()
    row("3D held side T partial", t3.held_side(cc.Tresca(0.8 * largest)))
    for condition in ("sigma1", "gamma3"):
        row(f"3D non-matching T {condition}", t3.non_matching(cc.Tresca(0.25 * P)), condition=condition)
    s = row("3D non-matching T gamma3 push", t3.non_matching(cc.Tresca(1e3), q=(0.0, 0.0), nu=0.0, push=1e-4),
            condition="gamma3")
    print("   sum |shear| / (g A) - 1:", np.linalg.norm(s.contact.shear_force, axis=1).sum() / 1e3 - 1)
    row("3D non-matching C gamma3", t3.non_matching(cc.Coulomb(0.3)), condition="gamma3")


def large() -> None:
    """The "gamma3" Tresca pair of tests/test_friction3d.py on finer meshes: rows, checks, seconds."""
    P, D = t3.P, t3.DIAGONAL
    for n, m in ((6, 8), (10, 13), (16, 21)):
        top, lower = cc.box(nx=n, ny=n, nz=2), cc.box(nx=m, ny=m, nz=2)
        a = cc.Body(top, t3.steel(), contact="bottom", traction={"top": (0.2 * P * D[0], 0.2 * P * D[1], -P)})
        b = cc.Body(lower.with_points(lower.points - [0.0, 0.0, 1.0]), t3.steel(), contact="top", clamped="bottom")
        scene = cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=cc.Tresca(0.25 * P))])
        sol = cc.solve(scene, condition="gamma3", estimate=False)
        worst = max(sol.residuals()[k] for k in KEYS)
        print(f"gamma3 {n}x{n} on {m}x{m}: {len(sol.contact.points)} rows, finish {sol.info.finish is not None}"
              f" {sol.info.declined}, worst check {worst:.1e}, interior point {sol.timings['solve']:.2f} s,"
              f" finish {sol.timings.get('polish', 0.0):.2f} s (wall)", flush=True)


if __name__ == "__main__":
    import sys

    main()
    if "--large" in sys.argv:
        large()
