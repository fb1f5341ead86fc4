"""``ContactResult.active`` of the P2 "everywhere" cones is the closed-contact set of the displacement
(:func:`cvxcontact.solution.checks.closed_contact`), not the nodes of the segments whose Bernstein duals carry a
force: beta is not unique where runs of segments touch, q = [u_h nu] - g_h is.

Checked by two routes that give different beta (the interior point's answer and its exact finish: beta 18 ... 55 %
apart, the old rule's counts 5 against 9 nodes) and against the jump sampled from each body's own P2 trace."""

import numpy as np
import pytest
from conftest import p2_trace_jump

from cvxcontact.apps.studies.common import solve_quietly
from cvxcontact.apps.studies.convergence import scene
from cvxcontact.solution import nodal

CASES = [("smooth", 4), ("hertzian", 4), ("partial", 8), ("hertzian", 8)]


def solved(kind, n, **options):
    """(sol, beta, segments) of the convergence study's scene ``kind`` at ``n`` under P2 "gamma3"."""
    seen = {}
    read_back = nodal.read_back_cones

    def keep(problem, raw, tol, timings):
        seen.update(beta=np.array(raw.beta), segments=np.array(problem.lines.cone[1]))
        return read_back(problem, raw, tol, timings)

    nodal.read_back_cones = keep           # the term names its read-back by module path: looked up per call
    try:
        sol = solve_quietly(scene(kind, n, 3 * n // 4 + 1), "gamma3", degree=2, **options)
    finally:
        nodal.read_back_cones = read_back
    return sol, seen["beta"], seen["segments"]


def carrying(beta, segments, size):
    """The former rule: the nodes of the segments whose duals carry a force."""
    on = np.zeros(size, dtype=bool)
    on[segments[beta.sum(axis=1) > 1e-6 * np.abs(beta).max()].ravel()] = True
    return on


@pytest.mark.numerics
@pytest.mark.parametrize("kind,n", CASES)
def test_active_is_the_same_whichever_duals_the_route_returns(kind, n):
    finished, beta_f, segments = solved(kind, n)
    interior, beta_i, _ = solved(kind, n, polish=False)
    assert finished.info.polished and not interior.info.polished
    # the two routes' duals differ (measured 18 ... 55 % of the largest), so the nodes of the segments that
    # carry them may differ (the former rule: measured 5 / 9, 5 / 9, 21 / 25, 15 / 17 nodes)
    assert np.abs(beta_f - beta_i).max() > 1e-2 * np.abs(beta_f).max()
    size = len(finished.contact.x)
    assert (carrying(beta_f, segments, size) != carrying(beta_i, segments, size)).any()
    # the closed-contact set is one
    assert np.array_equal(finished.contact.active, interior.contact.active)
    assert finished.contact.active.any()


@pytest.mark.numerics
@pytest.mark.parametrize("kind,n", CASES)
def test_active_is_where_the_sampled_jump_meets_the_gap(kind, n):
    """q = [u_nu] - g at the merged nodes from each body's own P2 trace (not the merged mesh's rows), over the
    node's scale |u^1_nu| + |u^2_nu| + |g| (without the checks' force term: a smaller scale, a larger ratio):
    the active nodes close to below tol (measured <= 8.9e-7 of 1e-6 here), the others stay open by more than
    tol (measured >= 8.8e-6)."""
    sol, _, _ = solved(kind, n)
    c = sol.contact
    q = p2_trace_jump(sol, c.x) - c.gap
    size = sum(np.abs(p2_trace_jump_side(sol, k, c.x)) for k in (0, 1)) + np.abs(c.gap)
    ratio = -q / np.maximum(size, 1e-9 * size.max())
    assert ratio[c.active].max(initial=0.0) <= sol.tol
    assert ratio[~c.active].min() > sol.tol
    assert (ratio >= -1e-9).all()          # nowhere penetrates at the nodes (measured >= -1.5e-16)


def p2_trace_jump_side(sol, k, xs):
    """Body ``k``'s normal displacement at ``xs`` from its own P2 trace (the sign of the jump dropped)."""
    from cvxcontact.geometry.quadratic import P2Nodes

    body = sol.scene.bodies[k]
    nodes = P2Nodes(body.mesh)
    e = nodes.boundary(body.contact)
    xa, xb = nodes.points[e[:, 0], 0], nodes.points[e[:, 1], 0]
    lo, hi = np.minimum(xa, xb), np.maximum(xa, xb)
    j = np.array([np.flatnonzero((lo <= x + 1e-15) & (x <= hi + 1e-15))[0] for x in xs])
    t = (xs - xa[j]) / (xb[j] - xa[j])
    uy = sol.u[k][:, 1]
    return uy[e[j, 0]] * (1 - t) * (1 - 2 * t) + uy[e[j, 1]] * t * (2 * t - 1) + uy[e[j, 2]] * 4 * t * (1 - t)
