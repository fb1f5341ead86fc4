"""The condensed route's exact finish where the rows carrying the forces pass the rows' own independence test
(DEPENDENT_PIVOT, on the unit rows) but W_PP = R_P Sigma^-1 R_P^T on them is singular to SINGULAR_PIVOT (its
conditioning the rows' squared: issue 33, "gamma3" at 1e6 unknowns declined its finish). Two boxes whose faces'
grids lie 3e-7 h apart (tests/scenes3d.py ``offset_boxes``): every overlay vertex has a partner that near.

The finish used to decline there (``sol.polished`` False, complementarity 5.4e-6 FAILED); it now
treats the rows W finds dependent as its steps treat dependent rows. Checked independently against the full
route (CVXPY's interior point on the whole problem, finished by an LCP on the whole W and one sparse LU of the
mixed system (26) on its active set)."""

import logging
import warnings

import numpy as np
import pytest
from scenes3d import offset_boxes

import cvxcontact as cc

pytestmark = pytest.mark.numerics      # which rows W finds dependent is rounding


@pytest.fixture(scope="module")
def solved():
    """(condensed solution, full solution, the finish's debug log) of offset_boxes(6, 3e-7)."""
    scene = offset_boxes(6, 3e-7)
    records = []
    handler = logging.Handler(logging.DEBUG)
    handler.emit = records.append
    log = logging.getLogger("cvxcontact.backends.finish.dependent")
    level = log.level
    log.setLevel(logging.DEBUG)
    log.addHandler(handler)
    try:
        condensed = cc.solve(scene)
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.errors.ResidualWarning)
        full = cc.solve(scene, method="full")
    return condensed, full, [r.getMessage() for r in records]


def test_the_scene_meets_a_singular_system_on_rows_that_pass_the_unit_test(solved):
    """The premise: the first passive set (the crossover's, independent by the rows' test) gives a W_PP
    singular to the cut, and a row that the rows' test lets join P does too (both were declines)."""
    messages = solved[2]
    assert messages[0].startswith("step 1:") and messages[0].endswith("move singular"), messages[:3]
    assert any("of P dependent on the others in the steps' metric" in m for m in messages)
    assert any(m.startswith("row ") and "pivoted in" in m for m in messages)


def test_the_default_route_finishes_exactly(solved):
    """Before: declined (polished False, ok False: complementarity 5.4e-6 here, 9.4e-5 at issue 33's 1e6)."""
    sol = solved[0]
    assert sol.info.method == "condensed"
    assert sol.polished and sol.info.declined is None
    assert sol.ok, sol.report()


def test_the_answer_is_the_full_routes(solved):
    """The displacements of both bodies and the total contact force against the full route's exact finish
    (an LCP on the whole W, one sparse LU of (26)): measured u 2.1e-15 .. 2.5e-15 and the force 0 .. 5.2e-16 under
    the default, Prescott and Sandybridge kernels (bounds 1e-10: the finishes are exact)."""
    condensed, full = solved[:2]
    assert full.polished and full.ok
    u = np.concatenate([np.ravel(x) for x in condensed.u])
    v = np.concatenate([np.ravel(x) for x in full.u])
    assert np.abs(u - v).max() <= 1e-10 * np.abs(v).max()
    fc, ff = (float(s.contacts[0].force.sum()) for s in (condensed, full))
    assert abs(fc - ff) <= 1e-10 * abs(ff)
