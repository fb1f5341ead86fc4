"""Two floors a few metres of rounding apart (2D P1, tests/reach_scenes.py): every route gives the whole force to
the tighter pair (the first on a tie) and 0 to the implied one, at every gap difference.

Before (benchmarks/results/parallel_split.md, h-split): the full and condensed routes' exact finish on the interface
(solve_lcp) had no classes of rows: with both rows of a node closed W_AA was singular, the NNLS fallback decided the
split node by node (1.79e6 to 1.85e6 N of 5.38e6 N on the second pair at 0, 1e-18 and 1e-15 m apart) and at 1e-10 m
apart no active set held the signs: the interior point kept, ok False. The sparse and AMG routes gave the second
pair 0. Now the interface finish leaves the rows a tighter (or equal, later) parallel row implies open
(``solve_lcp(implied=)``, ``Compliance.looser``), as the sparse and AMG routes do."""

import numpy as np
import pytest
from reach_scenes import block2d, line, lowered

import cvxcontact as cc

pytestmark = pytest.mark.numerics


@pytest.fixture(scope="module")
def one_floor():
    return cc.solve(block2d((line(-1.0, 2.0),)), "sigma1", method="full")


@pytest.mark.parametrize("method", ["full", "condensed", "sparse", "amg"])
@pytest.mark.parametrize("apart", [0.0, 1e-18, 1e-15, 1e-10])
def test_the_tighter_floor_carries_the_force_on_every_route(apart, method, one_floor):
    if method == "amg":
        pytest.importorskip("pyamg")
    sol = cc.solve(block2d((line(-1.0, 2.0), lowered(-1.0, 2.0, 2, drop=apart))), "sigma1", method=method)
    assert sol.ok
    tight, implied = sol.contacts
    ref = one_floor.contacts[0]
    scale = np.abs(ref.force).max()
    u_tol, f_tol = (1e-8, 1e-7) if method == "amg" else (1e-12, 1e-11)
    # measured over the five kernel sets (default, Haswell, Nehalem, Prescott, Sandybridge), every route, relative to
    # the one floor's max: the implied pair's force 0 exactly, the tighter pair's force 2.6e-16 and u 1.1e-16 from the
    # one floor's (the AMG route here too; its Krylov bounds kept as elsewhere)
    assert np.abs(implied.force).max() <= f_tol * scale
    assert np.abs(tight.force - ref.force).max() <= f_tol * scale
    assert np.abs(sol.u[0] - one_floor.u[0]).max() <= u_tol * np.abs(one_floor.u[0]).max()
