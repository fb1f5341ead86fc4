"""Issue 30's "done when" on its own scene: a rigid cylinder (R = 50 mm) pressed with 1 kN/m into an aluminium block
200 x 100 mm, plane strain, P2 "gamma3", half model (x >= 0, roller on x = 0, the cylinder guided along y and
loaded with half the force). Hertz for a rigid cylinder on an elastic half-plane: a = sqrt(4 F R (1 - nu^2) / (pi E)),
p0 = 2 F / (pi a) (28.5 um, 22.36 MPa; checked below).

- cc.adapt from a uniform 8 x 8 half block reaches the peak pressure within 3 % and the half-width within 5 % with at
  most 5e4 unknowns (tol 0.005 is not reached there: the warning says so).
- The issue's hand-graded meshes: the "+402 %" one (beta 12, gamma 3, nx 40) raises a ResolutionWarning, the
  "+0.5 %" one (beta 9, gamma 8, nx 80, ny 40) none.
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies.adapt import (
    PUNCH,
    punch_block,
    punch_measures,
    punch_scene,
)

# Not marked numerics: the two solves below take about 2 minutes of CPU, so they run once in the whole suite and
# not again under every OpenBLAS kernel set (the CI budget); the adapt loop's numerics are covered under every
# kernel set by tests/test_adapt*.py's smaller scenes.

R, F, E, NU = PUNCH["radius"], PUNCH["force"], PUNCH["E"], PUNCH["nu"]   # the study's fixture, issue 30's numbers


def hertz():
    """(a, p0): the half-width (m) and peak pressure (Pa) of a rigid cylinder on an elastic half-plane, plane
    strain (computed here, not by the study)."""
    a = np.sqrt(4 * F * R * (1 - NU ** 2) / (np.pi * E))
    return a, 2 * F / (np.pi * a)


def peak_and_half_width(sol):
    """(p0_h, a_h) as the study reads them (punch_measures: the largest nodal pressure; the half-width as the Hertz
    study's half_width, the mid-point between the outermost closed node and the next open one, from x = 0)."""
    m = punch_measures(sol)
    return m["p0"], m["a"]


def test_hertz_gives_the_issues_numbers():
    a, p0 = hertz()
    assert (R, F, E, NU, PUNCH["width"], PUNCH["height"]) == (0.05, 1e3, 70e9, 0.33, 0.1, 0.1)
    assert a == pytest.approx(28.5e-6, abs=0.05e-6) and p0 == pytest.approx(22.36e6, abs=0.005e6)


def test_the_issues_meshes_have_the_issues_cells():
    """The contact corner cell of each hand-graded mesh has the issue's size (width x height)."""
    for (beta, gamma, nx, ny), (w, h) in {(12, 3, 40, 40): (0.37e-6, 408e-6), (9, 3, 80, 40): (2.8e-6, 408e-6),
                                          (9, 8, 80, 40): (2.8e-6, 7.4e-6)}.items():
        p = punch_block(nx, ny, beta, gamma).points
        xs, ys = np.unique(p[:, 0]), np.unique(p[:, 1])
        assert xs[1] == pytest.approx(w, rel=0.02) and -ys[-2] == pytest.approx(h, rel=0.02)


def test_adapt_from_a_uniform_8_by_8_half_block_reaches_hertz():
    """The issue's call with the issue's budget; the defaults (cvxcontact.adapt.LOOPS, 2D P2: theta 0.9, rate 1,
    the last mesh finished exactly) and max_steps = 10 stop it first. Measured (2026-12-04): 11 solves, 23,980
    unknowns, peak pressure -3.0e-5 and half-width +2.5e-2 off Hertz, the relative estimate 0.11 (tol 0.005
    would need about 20x the unknowns at P2's N^-1: the warning says so); about 25 s CPU, single-threaded. The old
    defaults (theta 0.5, one bisection, every step exact) stopped after 10 steps at 730 unknowns, -96 % and
    +2644 %."""
    with pytest.warns(cc.ResolutionWarning, match=r"above tol = 0.005: stopped by max_steps"):
        result = cc.adapt(punch_scene(punch_block()), tol=0.005, condition="gamma3", degree=2, max_unknowns=50_000)
    sol, (a, p0) = result.solution, hertz()
    assert result.stopped == "max_steps" and sol.ok and sol.polished
    assert max(s.unknowns for s in result.history) <= 50_000
    assert 2 * sol.contact.force.sum() == pytest.approx(F, rel=1e-6)    # force control: the load carried
    p0_h, a_h = peak_and_half_width(sol)
    assert abs(p0_h / p0 - 1) <= 0.03                                    # the issue's target; measured -3.0e-5
    assert abs(a_h / a - 1) <= 0.05                                      # the issue's target; measured +2.5e-2


def _resolution_warnings(mesh):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = cc.solve(punch_scene(mesh), degree=2)
    return sol, [str(w.message) for w in caught if w.category is cc.ResolutionWarning]


def test_the_issues_402_percent_mesh_warns_and_its_half_percent_mesh_does_not():
    """The issue's "+402 %" mesh (cells 0.37 x 408 um at the contact): a ResolutionWarning (measured today: aspect
    ratio up to 630 on the zone's cells, the peak pressure +167 % off Hertz, the issue's +402 % was measured before
    the solver's later fixes); its "+0.5 %" mesh (2.8 x 7.4 um): none, and the peak within 3 % (measured +0.46 %)."""
    sol, messages = _resolution_warnings(punch_block(40, 40, beta=12, gamma=3))
    assert sol.ok and messages and all("block/top" in m for m in messages), messages
    assert peak_and_half_width(sol)[0] / hertz()[1] - 1 > 0.5            # the warning is due: measured +1.67
    sol, messages = _resolution_warnings(punch_block(80, 40, beta=9, gamma=8))
    assert sol.ok and messages == []
    assert abs(peak_and_half_width(sol)[0] / hertz()[1] - 1) <= 0.03      # measured +4.6e-3
