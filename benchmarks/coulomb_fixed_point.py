"""Benchmark: how Coulomb friction's fixed point converges (docs/howto/friction.md, "Coulomb").

A steel layer (1 m x 0.5 m, 6 x 3 cells, P1) on a rigid plane, its top moved by (s, -d), d = 10 um, under
``cc.Coulomb(mu)``: per (nu, mu, s / (mu d)) the fixed point's iterations (``sol.info.fixed_point``, the
relative change of the capacities at each), the median ratio of successive changes (the contraction per
iteration), the last change, ``ok``, the worst Coulomb check and whether the FixedPointWarning was raised; then
the wall-clock ratio of a Coulomb solve to a Tresca solve of the same block (the 8 x 4 block of
docs/howto/friction.md sheared by 3.5 MPa, mu = 0.4, g = 4 MPa; twice, within one run):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/coulomb_fixed_point.py
"""

from __future__ import annotations

import warnings

import numpy as np

import cvxcontact as cc

CASES = [(0.3, 0.1, 0.6), (0.3, 0.3, 0.6), (0.45, 0.3, 0.6), (0.0, 4.0, 0.6), (0.0, 8.0, 0.3)]


def layer(nu: float, mu: float, share: float) -> cc.Scene:
    """The layer of the module docstring, its top moved by (share mu d, -d)."""
    d = 1e-5
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=6, ny=3)
    b = cc.Body(m, cc.materials.isotropic(E=200e9, nu=nu), contact="bottom", displacement={"top": (share * mu * d, -d)})
    floor = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", floor, law=cc.Coulomb(mu))])


def main() -> None:
    print("nu    mu    s/(mu d)  iterations  contraction  last change  ok     worst check            warned")
    for nu, mu, share in CASES:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = cc.solve(layer(nu, mu, share), tol=1e-5)
        changes = np.array(sol.info.fixed_point)
        ratio = float(np.median(changes[1:] / changes[:-1])) if len(changes) > 1 else 0.0
        checks = {k: v for k, v in sol.residuals().items() if k in ("friction cone", "stick-slip", "slip direction")}
        worst = max(checks, key=checks.get)
        warned = any(issubclass(w.category, cc.FixedPointWarning) for w in caught)
        print(f"{nu:<5} {mu:<5} {share:<9} {len(changes):<11} {ratio:<12.2g} {changes[-1]:<12.2g} {sol.ok!s:<6} "
              f"{worst} {checks[worst]:.2g}   {warned}")


def timing() -> None:
    """The ratio of a Coulomb solve's wall-clock time to a Tresca solve's (module docstring)."""
    import time

    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    floor = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))

    def seconds(law):
        b = cc.Body(m, cc.materials.isotropic(E=200e9, nu=0.3), contact="bottom", traction={"top": (3.5e6, -1e7)})
        t0 = time.perf_counter()
        sol = cc.solve(cc.Scene(b, contacts=[cc.Contact(b, "bottom", floor, law=law)]), estimate=False)
        return time.perf_counter() - t0, sol

    for rep in range(2):
        tresca, _ = seconds(cc.Tresca(4e6))
        coulomb, sol = seconds(cc.Coulomb(0.4))
        print(f"run {rep}: Coulomb / Tresca wall clock {coulomb / tresca:.2f} ({len(sol.info.fixed_point)} fixed-point "
              f"iterations after the stuck start; Tresca {tresca:.2f} s)")


if __name__ == "__main__":
    main()
    timing()
