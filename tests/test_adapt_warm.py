"""The warm start of a solve from a solution on another mesh (``ContactSolver(..., start=sol)``,
cvxcontact/backends/start.py), as cc.adapt uses it: the contact state carried as point loads, mapped exactly onto
nested meshes, and the warm answer equal to the cold one to the finish's exactness."""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.adapt import mark_bulk
from cvxcontact.apps.studies.adapt import coarse_scene
from cvxcontact.backends.result import Route
from cvxcontact.backends.start import cone_seeds, start_active
from cvxcontact.geometry.refine import label_longest, refine_marked

pytestmark = pytest.mark.numerics   # warm-started finishes, P2 cuts (every kernel set)


def nested(degree):
    """The study's Hertz scene (16 cells along the cylinder), its solution, and the mesh Dorfler (theta = 0.5)
    and newest-vertex bisection make of it (each body refined on its own: the sides stay non-matching)."""
    scene = coarse_scene(16)
    scene = scene.with_bodies(*(b.with_changes(mesh=label_longest(b.mesh)) for b in scene.bodies))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        first = cc.ContactSolver(scene, degree=degree, method="condensed").solve()
    marks = mark_bulk(first.estimate.indicators, 0.5)
    fine = scene.with_bodies(*(b.with_changes(mesh=refine_marked(b.mesh, m)[0]) for b, m in zip(scene.bodies, marks)))
    return first, fine


def solve_both(degree):
    first, fine = nested(degree)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        cold = cc.ContactSolver(fine, degree=degree, method="condensed").solve()
        warm = cc.ContactSolver(fine, degree=degree, method="condensed", start=first).solve()
    return first, cold, warm


def relative_difference(a, b):
    return max(np.abs(x - y).max() for x, y in zip(a.u, b.u)) / max(np.abs(x).max() for x in a.u)


def test_state_carries_the_contact_force():
    """The state's point loads sum to the pair's total force (P1: the nodal forces; P2: the cut points' forces,
    whose P2 rows sum to 1 at every point) and sit inside the contact line."""
    for degree in (1, 2):
        first, _ = nested(degree)
        state, c = first.state, first.contact
        assert state.force.min() >= 0 and (state.pair == 0).all()
        assert state.force.sum() == pytest.approx(c.force.sum(), rel=1e-12)
        assert c.x.min() - 1e-12 <= state.s.min() and state.s.max() <= c.x.max() + 1e-12


def test_state_maps_exactly_onto_its_own_and_nested_meshes():
    """P1: the active guess on the solution's own rows is its active set (a linear interpolant through the nodes
    reproduces their values). P2: every loaded point mapped onto the refined mesh's elements (``cone_seeds``)
    is at the same position s (the refined contact line holds the coarse one's points; rounding: 1e-12 m on a
    4 m line) with the same force."""
    first, _ = nested(1)
    own = cc.ContactSolver(first.scene, degree=1, method="condensed").problem
    assert np.array_equal(start_active(own, first.state), first.contact.force > 0)
    first, fine = nested(2)
    problem = cc.ContactSolver(fine, degree=2, method="condensed").problem
    segment, t, y = cone_seeds(problem, first.state)
    cells, x = problem.lines.cone[1], np.asarray(problem.lines.interface.x)
    s = (1 - t) * x[cells[segment, 0]] + t * x[cells[segment, 2]]
    loaded = first.state.force > 0
    for s_old, f_old in zip(first.state.s[loaded], first.state.force[loaded]):
        at = np.flatnonzero(np.abs(s - s_old) <= 1e-12)
        assert len(at) == 1
        assert y[at[0]] * problem.units.force == pytest.approx(f_old, rel=1e-12)


def test_warm_p1_equals_cold():
    """P1 "gamma3" (nodal rows): the warm start's first active set, verified by the exact finish, is the cold
    answer's; the fields agree to rounding (measured: identical, difference 0.0)."""
    _, cold, warm = solve_both(1)
    assert warm.info.route == Route.WARM_START and cold.info.route != Route.WARM_START
    assert warm.ok and cold.ok
    assert np.array_equal(warm.contact.active, cold.contact.active)
    assert relative_difference(cold, warm) <= 1e-12


def test_warm_p2_equals_cold():
    """P2 "gamma3": the cuts from the coarse solution's point forces (no interior point) reach the cold answer
    to the finish's exactness: both certified (energy error relative 2.0e-7 warm, 2.1e-6 cold, checked by
    ``ok``), the nodal displacements within 2.1e-8 of the largest (asserted 3e-6), the same nodes in contact,
    the total force to 1.0e-9 (asserted 1e-7)."""
    _, cold, warm = solve_both(2)
    assert warm.info.route == Route.WARM_START and cold.info.route != Route.WARM_START
    assert warm.ok and cold.ok and warm.polished
    assert np.array_equal(warm.contact.active, cold.contact.active)
    assert relative_difference(cold, warm) <= 3e-6
    assert warm.contact.force.sum() == pytest.approx(cold.contact.force.sum(), rel=1e-7)


def test_adapt_warm_equals_cold():
    """cc.adapt's steps, warm (default) and cold (``warm_start=False``), mark the same cells and give the same
    estimates (P1: the same exact answers; measured identical, asserted to 1e-9; P2 measured 1.2e-7 apart)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warm = cc.adapt(coarse_scene(), method="condensed", theta=0.5, max_steps=6)
        cold = cc.adapt(coarse_scene(), method="condensed", theta=0.5, max_steps=6, warm_start=False)
    assert [s.cells for s in warm.history] == [s.cells for s in cold.history]
    assert np.allclose([s.estimate for s in warm.history], [s.estimate for s in cold.history], rtol=1e-9, atol=0)


def test_start_refused():
    first, fine = nested(1)
    with pytest.raises(cc.SolverError, match="start must be a Solution"):
        cc.ContactSolver(fine, method="condensed", start="coarse")
    with pytest.raises(cc.SceneError, match="remove start="):
        cc.adapt(fine, method="condensed", start=first)
