"""The complementarity check of an exact answer reads 0, not the square root of rounding, and a fault as before
(cvxcontact.solution.checks.complementarity: the slack's rounding, SLACK_ROUNDING U_a, taken off before the product).

An exact finish leaves each closed row's slack s_a = E [u_nu] - g at the rounding of the displacements there
(|s_a| <= 4.2 eps of sum_l |E J_l u_l|_a + |g_a|, measured below), and the product y_a |s_a| / (Y U_a) of a row
carrying the largest force is then eps: its square root read 1.35e-8 (offset_boxes(6, 3e-7), rows dependent to
rounding), 3.5e-9 (two_boxes(4, "sigma1"), no dependent rows) and 1.36e-8 (three blocks, a Signorini pair beside a
compliance pair) although the answers are exact. Now 0; a force on an open row and a slack opened by 1e-9 of a
body's displacement read the same as before (the square drops by at most SLACK_ROUNDING).
"""

import dataclasses
import importlib

import numpy as np
import pytest
from scenes3d import offset_boxes, two_boxes
from stack_scenes import three_blocks_3d

import cvxcontact as cc
from cvxcontact.backends.finish import (
    force_displacements,
    force_scale,
    node_scales,
    reach_displacements,
    reach_forces,
)
from cvxcontact.solution.checks import SLACK_ROUNDING
from cvxcontact.solution.readback import read_back

pytestmark = pytest.mark.numerics

EPS = np.finfo(float).eps
SCENES = {"offset 3e-7 h (dependent rows)": lambda: offset_boxes(6, 3e-7),
          "sigma1 (independent rows)": lambda: two_boxes(4, "sigma1")}


def _captured(scene):
    """(solution, problem, raw) of ``cc.solve(scene)`` (tests/conftest.py's ``captured``, for a module fixture)."""
    seen = {}

    def spy(problem, raw, *args, **kwargs):
        seen.update(problem=problem, raw=dataclasses.replace(raw))
        return read_back(problem, raw, *args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(importlib.import_module("cvxcontact.solve"), "read_back", spy)
        sol = cc.solve(scene)
    return sol, seen["problem"], seen["raw"]


@pytest.fixture(scope="module", params=list(SCENES))
def solved(request):
    return _captured(SCENES[request.param]())


def _slack(problem, raw):
    """(s, sum_l |E J_l u_l| + |g|) at the rows, recomputed from the answer's arrays (scaled)."""
    E, g = problem.E, problem.E @ problem.moved_gap(raw.taus)
    parts = [E @ (b.jump @ uk) for b, uk in zip(problem.blocks, raw.u)]
    return sum(parts) - g, sum(np.abs(p) for p in parts) + np.abs(g)


def _unfloored(problem, raw):
    """The complementarity check without the slack's rounding taken off (its definition before), from the
    answer's arrays: max_a sqrt(|y_a s_a| / (Y U_a)), U_a and Y the checks' own scales."""
    blocks, E, y = problem.blocks, problem.E, np.asarray(raw.y, dtype=float)
    local = force_displacements(blocks, E, y) + reach_displacements(blocks, E, raw.u, raw.phi)
    slack, U = node_scales([E @ (b.jump @ uk) for b, uk in zip(blocks, raw.u)], E @ problem.moved_gap(raw.taus),
                           local)
    Y = force_scale(y, reach_forces(blocks, E, raw.u, raw.phi, problem.rigid_fits))
    return float(np.sqrt((np.abs(y * slack) / (Y * U)).max()))


def _read(problem, raw, tol, **changes):
    return read_back(problem, dataclasses.replace(raw, **changes), tol, {}).residuals()["complementarity"]


def test_an_exact_answer_reads_no_complementarity_gap(solved):
    sol, problem, raw = solved
    assert sol.polished and sol.ok
    s, size = _slack(problem, raw)
    forced = np.asarray(raw.y) != 0
    # exact: measured <= 9.3e-16 (4.2 eps) and 1.0e-16 (under the default, Prescott and Sandybridge kernels)
    assert forced.any() and (np.abs(s) / size)[forced].max() < 1e-13
    assert _unfloored(problem, raw) > 1e-10                            # before: 1.35e-8, 3.5e-9 (the root of eps)
    assert sol.residuals()["complementarity"] < 1e-12                  # measured 0.0


def test_a_force_on_an_open_row_reads_as_before(solved):
    sol, problem, raw = solved
    y = np.array(raw.y, dtype=float)
    s, size = _slack(problem, raw)
    i = int(np.argmax(np.where(y != 0, -np.inf, -s / size)))           # the most open row
    assert s[i] < -1e-3 * size[i]
    y[i] = 1e-6 * np.abs(y).max()
    before, after = _unfloored(problem, dataclasses.replace(raw, y=y)), _read(problem, raw, sol.tol, y=y)
    assert before > 1e2 * sol.tol                                      # measured 5.0e-4, 4.5e-4
    assert after == pytest.approx(before, rel=1e-10)                   # measured 3e-14 relative


def test_a_slack_opened_on_closed_rows_reads_as_before(solved):
    """Body 0's displacement scaled by 1 + 1e-9: its closed rows open or penetrate by 1e-9 of its part there."""
    sol, problem, raw = solved
    u = [raw.u[0] * (1 + 1e-9)] + list(raw.u[1:])
    before, after = _unfloored(problem, dataclasses.replace(raw, u=u)), _read(problem, raw, sol.tol, u=u)
    assert before > 10 * sol.tol                                       # measured 1.25e-5, 1.18e-5
    # what the floor guarantees: the square drops by at most SLACK_ROUNDING (|y_a| <= Y; by that much where the row
    # carries Y: measured 1.4211e-14), never rises (1e-12: the rounding of the squares)
    assert before**2 * (1 - 1e-12) - SLACK_ROUNDING <= after**2 <= before**2 * (1 + 1e-12)
    assert after == pytest.approx(before, rel=1e-3)                    # measured 4.5e-5, 5.1e-5 relative


def test_a_signorini_pair_beside_a_compliance_pair_reads_no_complementarity_gap():
    """compliance_checks' complementarity on the Signorini rows (the limit reaction z): 1.36e-8 before."""
    sol = cc.solve(three_blocks_3d(("gamma3", "gamma3"), (cc.Signorini(), cc.NormalCompliance(stiffness=1e12))))
    assert sol.polished and sol.ok
    assert sol.residuals()["complementarity"] < 1e-12                  # measured 0.0
