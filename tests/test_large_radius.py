"""Curved obstacles of large radius keep their gap: |x - c| - R and the ray's root computed without the
cancellation of two nearly equal large numbers, checked against exact rational arithmetic (fractions)."""

from fractions import Fraction
from math import sqrt

import numpy as np
import pytest

import cvxcontact as cc

RADII = [1e5, 1e6, 1e7, 1e8, 1e9, 1e10]


def _exact_closest(x, c, R):
    """|x - c| - R (m) with |x - c|^2 - R^2 formed exactly in rationals (the quotient by |x - c| + R is
    well conditioned)."""
    q = sum((Fraction(a) - Fraction(b)) ** 2 for a, b in zip(x, c)) - Fraction(R) ** 2
    r = sqrt(float(q + Fraction(R) ** 2))
    return float(q) / (r + R)


def _exact_ray(x, nu, c, R):
    """The root t of |x + t nu - c| = R ahead of a node outside facing the obstacle (b = (x - c) . nu < 0):
    t = q / (-b + sqrt(b^2 - q)), q = |x - c|^2 - R^2 and b exact in rationals."""
    w = [Fraction(a) - Fraction(b) for a, b in zip(x, c)]
    q = sum(v * v for v in w) - Fraction(R) ** 2
    b = sum(v * Fraction(n) for v, n in zip(w, nu))
    assert b < 0
    return float(q) / (float(-b) + sqrt(float(b * b - q)))


def _points(dim, R, rng):
    """Nodes of a flat part (its outward normal -e_z) of width 2 m at heights 0 .. 1e-3 m above the top of the
    disc / ball of radius R whose top is near the origin; the centre not a round number."""
    c = np.zeros(dim)
    c[:-1] = rng.uniform(-0.3, 0.3, dim - 1)
    c[-1] = -R - 0.123456789
    x = np.zeros((40, dim))
    x[:, :-1] = rng.uniform(-1.0, 1.0, (40, dim - 1))
    x[:, -1] = rng.uniform(0.0, 1e-3, 40) - 0.123456789
    return c, x


@pytest.mark.parametrize("R", RADII)
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("posing", ["closest", "ray"])
def test_large_radius_gap_matches_exact_arithmetic(R, dim, posing):
    rng = np.random.default_rng(int(np.log10(R)) + 10 * dim)
    c, x = _points(dim, R, rng)
    nu = np.zeros(dim)
    nu[-1] = -1.0
    obstacle = (cc.Rigid.circle if dim == 2 else cc.Rigid.sphere)(tuple(c), R, distance=posing)
    g = obstacle.distance(x, nu)
    exact = np.array([_exact_closest(p, c, R) if posing == "closest" else _exact_ray(p, nu, c, R) for p in x])
    # the gap spans 0 .. 1e-3 m; measured error <= 2.2e-19 m (rounding of g; bound 5e-17 m, 230x)
    # where the subtraction |x - c| - R lost eps R: 1.5e-11 m at R = 1e5 .. 9.5e-7 m at R = 1e10
    assert np.abs(g - exact).max() <= 5e-17


@pytest.mark.parametrize("R", [1e6, 1e9])
def test_large_radius_cylinder_gap_matches_exact_arithmetic(R):
    """The cylinder along the y axis: its section is the disc of x and z."""
    rng = np.random.default_rng(7)
    c, x = _points(3, R, rng)
    nu = np.array([0.0, 0.0, -1.0])
    cyl = cc.Rigid.cylinder(tuple(c), (0.0, 1.0, 0.0), R)
    g = cyl.distance(x, nu)
    exact = np.array([_exact_closest(p[[0, 2]], c[[0, 2]], R) for p in x])
    assert np.abs(g - exact).max() <= 5e-17


ALU = cc.materials.isotropic(E=70e9, nu=0.3)
DEPTH = 2.0 ** -13          # m; R - DEPTH is exact for the integer radii below (a multiple of their ulp)


def _block_under(obstacle):
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=24, ny=6), ALU, clamped="bottom", contact="top")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", obstacle)])


@pytest.mark.numerics
def test_block_under_a_large_disc_tends_to_the_flat_answer_as_one_over_r():
    """A disc of radius R pressed DEPTH into a block departs from the flat punch by the curvature of its gap,
    s^2 / (2 R): the departure falls by 10 from one radius to the next, R = 1e5 .. 1e10 m (measured: ratios
    10 - 2.4e-5 .. 10 - 2e-8; the unfixed gap rounded away the curvature at R >= 1e8, a ratio of 2.6e4)."""
    flat = cc.solve(_block_under(cc.Rigid.plane((0.0, -DEPTH), (0.0, -1.0))), "gamma3")
    scale = np.abs(flat.u[0]).max()
    departures = []
    for R in RADII:
        sol = cc.solve(_block_under(cc.Rigid.circle((0.47, R - DEPTH), R)), "gamma3")
        assert sol.ok
        departures.append(np.abs(sol.u[0] - flat.u[0]).max() / scale)
    ratios = np.array(departures[:-1]) / np.array(departures[1:])
    assert np.abs(ratios - 10.0).max() <= 1e-2, ratios
    assert 5e-3 <= departures[0] <= 5e-2                     # 1.15e-2: about 0.53^2 / (2 R DEPTH) at R = 1e5
