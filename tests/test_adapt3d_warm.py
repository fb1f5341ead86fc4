"""The warm start in 3D (cvxcontact/backends/start.py): a solution's contact state as the nodal forces at the
overlay's vertices (positions in the pair's plane axes), the next mesh's first active set by linear
interpolation over the old points' Delaunay triangles, and cc.adapt's 3D steps warm equal to cold (P1 on the
Hertz 3D quarter scene, P2 under the nodal "sigma1" condition)."""

import warnings
from itertools import pairwise

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d
from cvxcontact.apps.studies.estimate import boxes_scene, sphere_scene
from cvxcontact.backends.result import Route
from cvxcontact.backends.start import start_active

pytestmark = pytest.mark.numerics      # warm-started exact finishes (every kernel set)


def quietly(f, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        return f(*args, **kw)


def relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


def warm_and_cold(scene, steps, condition="gamma3", **options):
    """cc.adapt's solutions (warm-started, the default) and each step's mesh solved cold. Not a second adapt run
    with ``warm_start=False``: on a symmetric scene equal indicators are marked or not by rounding, and the two
    runs may refine mirror images of each other (measured on the Hertz quarter, sparse route, from step 3)."""
    warm = quietly(cc.adapt, scene, condition, theta=0.5, max_steps=steps, keep=True, **options)
    cold = [quietly(cc.ContactSolver(s.scene, condition, **options).solve) for s in warm.solutions]
    return warm.solutions, cold


@pytest.fixture(scope="module")
def hertz_run():
    """Nine adaptive steps on the Hertz 3D quarter scene (P1 "gamma3"), every solution kept."""
    return quietly(cc.adapt, hertz3d.scene(4, ratio=1.0), theta=0.5, max_steps=9, keep=True).solutions


def test_3d_state_carries_the_contact_force(hertz_run):
    """The state of a 3D solution (the ninth step's, 20 rows closed): one point per vertex of the overlay,
    (s1, s2) inside the contact surface's span, forces >= 0 summing to the nodal forces' total (rounding), which
    bounds the obstacle's resultant (the rows lie along the sphere's radii: |sum_a c_a y_a| <= sum_a y_a) and is
    within 5 % of it (measured: resultant / sum = 0.99982)."""
    sol = hertz_run[-1]
    state, c = sol.state, sol.contact
    assert state is not None and state.s.shape == (len(state.force), 2) and (state.pair == 0).all()
    assert state.force.min() >= 0 and (state.force > 0).sum() == c.active.sum()
    assert state.force.sum() == pytest.approx(c.force.sum(), rel=1e-12)
    assert (state.s.min(axis=0) >= c.x.min(axis=0) - 1e-12).all()
    assert (state.s.max(axis=0) <= c.x.max(axis=0) + 1e-12).all()
    resultant = np.linalg.norm(sol.obstacles[0].force)
    assert resultant <= state.force.sum() * (1 + 1e-12)
    assert resultant >= 0.95 * state.force.sum()


def test_3d_state_maps_onto_its_own_rows():
    """On the solution's own mesh the first active guess is its active set (the linear interpolant reproduces
    the forces at the points it interpolates): P1 "gamma3" and P2 "sigma1"."""
    for scene, degree, condition in ((hertz3d.scene(4, ratio=1.0), 1, "gamma3"), (sphere_scene(), 2, "sigma1")):
        solver = cc.ContactSolver(scene, condition, degree=degree)
        sol = quietly(solver.solve)
        assert np.array_equal(start_active(solver.problem, sol.state), sol.contact.force > 0)


def test_3d_state_guess_on_the_next_mesh_is_near_the_answer(hertz_run):
    """Carried to the next adaptive mesh, the guess is near the rows the finer answer closes: over the nine steps,
    rows guessed wrong (closed rows missed, open rows guessed closed) are at most a quarter of the closed rows
    (measured: 1 missed and 7 extra against 54 closed, the linear interpolant being positive on the old
    triangles that touch a loaded point)."""
    wrong = closed = 0
    for coarse, fine in pairwise(hertz_run):
        guess = start_active(cc.ContactSolver(fine.scene).problem, coarse.state)
        answer = fine.contact.force > 0
        wrong += int((guess != answer).sum())
        closed += int(answer.sum())
    assert closed > 0 and wrong <= closed / 4


# the difference warm against cold allowed, relative to the largest entry: direct solves (measured: u and forces
# identical on the condensed route, 1.8e-15 and 1.5e-15 on the sparse one); AMG: Krylov solves to RTOL 1e-10
# from different first iterates (measured 2.5e-11 and 1.2e-11)
ROUNDING = {"condensed": 1e-12, "sparse": 1e-12, "amg": 1e-8}


@pytest.mark.parametrize("method", sorted(ROUNDING))
def test_3d_adapt_warm_equals_cold_p1(method):
    """cc.adapt on the Hertz 3D quarter scene (P1 "gamma3"), five steps: every step after the first starts from
    the previous step's state and is accepted as a warm start (``Route.WARM_START``), and its answer is the cold
    solve's of the same mesh, the same active set, u and forces to rounding (:data:`ROUNDING`)."""
    if method == "amg":
        pytest.importorskip("pyamg")                    # the optional extra cvxcontact[amg]
    warm, cold = warm_and_cold(hertz3d.scene(4, ratio=1.0), 5, method=method)
    assert all(s.info.route == Route.WARM_START for s in warm[1:])
    assert all(s.info.route != Route.WARM_START for s in cold)
    for w, c in zip(warm, cold):
        assert w.ok and c.ok
        assert np.array_equal(w.contact.active, c.contact.active)
        assert max(relative(a, b) for a, b in zip(w.u, c.u)) <= ROUNDING[method]
        assert relative(w.contact.force, c.contact.force) <= ROUNDING[method]


def test_3d_adapt_warm_equals_cold_p2_sigma1():
    """P2 tetrahedra under the nodal "sigma1" condition on the estimate study's sphere scene, two steps: the
    warm steps start from the state and give the cold answers on the same meshes (measured identical; asserted
    to 1e-12)."""
    warm, cold = warm_and_cold(sphere_scene(), 2, condition="sigma1", degree=2)
    assert all(s.info.route == Route.WARM_START for s in warm[1:])
    assert all(s.info.route != Route.WARM_START for s in cold)
    for w, c in zip(warm, cold):
        assert w.ok and c.ok
        assert np.array_equal(w.contact.active, c.contact.active)
        assert max(relative(a, b) for a, b in zip(w.u, c.u)) <= 1e-12
        assert relative(w.contact.force, c.contact.force) <= 1e-12


def test_3d_adapt_warm_equals_cold_two_bodies():
    """Two non-matching boxes (PZT on aluminium, the whole overlay closed), two steps: on the first refined mesh
    the overlay's 31 rows act on the bodies through normal jumps of rank 16 and 9, so the row forces are not
    unique (warm and cold pick different ones, measured up to 1.5 times the largest apart, the same total); the
    answer is: u, the forces each body receives (J_k^T y) and the estimate equal to rounding (measured 1.8e-15,
    7.8e-16 and 2.2e-16 at most; asserted 1e-12)."""
    warm, cold = warm_and_cold(boxes_scene(), 2)
    assert all(s.info.route == Route.WARM_START for s in warm[1:])
    for w, c in zip(warm, cold):
        assert w.ok and c.ok
        assert max(relative(a, b) for a, b in zip(w.u, c.u)) <= 1e-12
        interface = cc.ContactSolver(w.scene).problem.lines.interface
        for k, body in enumerate(w.scene.bodies):
            J = interface.jump(k, len(body.mesh.points))
            assert relative(J.T @ w.contact.force, J.T @ c.contact.force) <= 1e-12
        assert w.contact.force.sum() == pytest.approx(c.contact.force.sum(), rel=1e-12)
        assert w.estimate.absolute == pytest.approx(c.estimate.absolute, rel=1e-12)
