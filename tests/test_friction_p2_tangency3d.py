"""Tresca friction with P2 tetrahedra under "gamma3" finished at the exact tangency points in 3D
(:func:`cvxcontact.backends.frictiontangency.tangency_polish`): a rigid sphere pressed into a clamped P2 block
(tests/scenes3d.py ``sphere_into_block``: 4 x 4 x 2 cells, 5 mm deep), whose contact zone ends inside the top's
triangles, touching each at one isolated point. The cuts alone stop at 1e-9 of the displacements' violation, their
fields 2.1e-6 from the finished ones (benchmarks/results/friction_p2_tangency3d.md). Checked against what does not
share the finish: the frictionless cones' exact answer (the tangency Newton, another route) as the threshold tends
to 0, and the posed condition sampled on every top face from the nodal displacements and the sphere itself. (The
large-threshold limit is not the tied block here: against the sphere the slip rows lie in its tangent planes; the
boxes' tied limit is tests/test_friction_p2_lifting3d.py's.)"""

import numpy as np
import pytest
from friction_scenes import finished_p2
from scenes3d import _simplex_grid, sphere_into_block

import cvxcontact as cc

P2 = {"condition": "gamma3", "degree": 2}
N, DEPTH, RADIUS = 4, 0.005, 2.0
CENTRE = np.array([0.0, 0.0, RADIUS - DEPTH])


def _apart(u, v) -> float:
    return float(np.abs(u - v).max() / np.abs(v).max())


@pytest.fixture(scope="module")
def free():
    sol = cc.solve(sphere_into_block(N, depth=DEPTH), **P2)
    assert sol.polished and sol.info.finish == cc.Finish.TANGENCY_NEWTON
    return sol


@pytest.fixture(scope="module")
def sliding():
    return finished_p2(sphere_into_block(N, depth=DEPTH, law=cc.Tresca(1e6)))


def _sampled_slack(sol) -> np.ndarray:
    """(faces,) the largest of c(x) . u(x) - g(x) sampled on every top face: the P2 interpolant of the nodal rows'
    values c . u (c the unit direction from a node to the sphere's centre, the closest-point posing's) less the
    sphere's own distance |x - centre| - R at the point (not its interpolant); at 91 points of each face, then
    five times 625 points around the best one, 10 times closer each time (a tangency found to ~1e-5 of a face)."""
    mesh = cc.box(x=(-1.0, 1.0), y=(-1.0, 1.0), z=(-1.0, 0.0), nx=N, ny=N, nz=N // 2)
    pts = sol.points[0]
    at = {tuple(np.round(p, 9)): i for i, p in enumerate(pts)}
    tri = mesh.boundary("top")
    mids = np.array([[at[tuple(np.round(0.5 * (pts[a] + pts[b]), 9))] for a, b in zip(t, np.roll(t, -1))]
                     for t in tri])
    faces = np.column_stack([tri, mids])
    c = CENTRE - pts
    c /= np.linalg.norm(c, axis=1)[:, None]
    v = np.einsum("nd,nd->n", c, sol.u[0])

    def slack(L):                                                  # L (f, p, 3) -> (f, p)
        basis = np.concatenate([L * (2 * L - 1), 4 * L[..., [0]] * L[..., [1]], 4 * L[..., [1]] * L[..., [2]],
                                4 * L[..., [2]] * L[..., [0]]], axis=-1)
        x = np.einsum("fpk,fkd->fpd", L, pts[tri])
        return np.einsum("fpk,fk->fp", basis, v[faces]) - (np.linalg.norm(x - CENTRE, axis=2) - RADIUS)

    L = np.broadcast_to(_simplex_grid(12), (len(tri), 91, 3))
    step = 1.0 / 12
    for _ in range(6):
        s = slack(L)
        best = L[np.arange(len(tri)), np.argmax(s, axis=1)]
        if step < 1e-5:
            break
        step /= 10
        i, j = np.meshgrid(np.arange(-12, 13), np.arange(-12, 13), indexing="ij")
        d = step * np.column_stack([i.ravel(), j.ravel(), -(i + j).ravel()])
        L = np.clip(best[:, None, :] + d[None], 0.0, None)
        L = L / L.sum(axis=2, keepdims=True)
    return s.max(axis=1)


@pytest.mark.numerics
def test_as_the_threshold_vanishes_the_answer_is_the_frictionless_cones_exact_one(free):
    """The answer departs from the frictionless cones' (finished by the tangency Newton, another route) linearly in
    the threshold (measured ratio 9.999999 for x10), and its linear extrapolation to 0 is that answer (measured
    2.4e-15 .. 1.8e-14 of the displacements across kernel sets). The cuts' answer alone stood 2.1e-6 away at every
    small threshold (their stop, 1e-9, under a square root), which neither bound admits."""
    small, large = (finished_p2(sphere_into_block(N, depth=DEPTH, law=cc.Tresca(g))).u[0] for g in (1.0, 10.0))
    d1, d2 = _apart(small, free.u[0]), _apart(large, free.u[0])
    assert d1 <= 3e-7 and abs(d2 / d1 - 10) <= 0.01                  # measured d1 2.95e-9
    # measured 2.4e-15 (default kernels), 6.6e-15 (Prescott), 1.8e-14 (Sandybridge)
    assert _apart(small - (large - small) / 9, free.u[0]) <= 3e-12


@pytest.mark.numerics
def test_the_finished_answer_touches_the_sphere_and_never_enters_it(free, sliding):
    """The posed condition sampled on every top face (:func:`_sampled_slack`, from the nodal displacements and the
    sphere, not the Bernstein form nor the finish's maxima): nowhere above 0 beyond rounding, and 0 at the touching
    faces' tangency points to the sampling's resolution (largest: measured -6.6e-11 of the displacements with
    friction, -3.3e-13 without). The cuts alone leave it 1.3e-10 above 0 (their stop, 1e-9 of an element's
    scale), which the first bound does not admit."""
    for sol in (sliding, free):
        top = _sampled_slack(sol) / float(np.abs(sol.u[0]).max())
        assert -1e-8 <= top.max() <= 1e-12


@pytest.mark.numerics
def test_the_finished_answer_keeps_tresca_law_at_rounding(sliding):
    """Finished at the tangency points (the slack there exactly 0: feasibility measured 2.3e-17, the cuts' 7.8e-12),
    Tresca's law on every row (friction cone 1.0e-19, stick-slip and slip direction 1.0e-10 and 9.0e-11 as the
    cuts'), balanced (2.0e-16)."""
    r = sliding.residuals()
    assert r["feasibility"] <= 1e-14 and r["equilibrium"] <= 1e-13 and r["friction cone"] <= 1e-14
    assert r["stick-slip"] <= 1e-8 and r["slip direction"] <= 1e-8 and r["complementarity"] <= 1e-6


@pytest.mark.numerics
def test_coulomb_s_fixed_point_is_finished_at_the_tangency_points_too(free):
    """Coulomb's fixed point on Tresca's capacities mu r runs on the tangency points' answers: the slack at them
    exactly 0 (feasibility measured 2.9e-17; the cuts' 7e-12), and as the coefficient tends to 0 the answer departs
    from the frictionless cones' exact answer linearly (measured ratio 10.000004 for x10, d1 2.1e-8), its linear
    extrapolation to 0 that answer (measured 1.1e-14 .. 2.6e-14; with Tresca the cuts' answer alone stood 2.1e-6
    away)."""
    # the interior point's own fixed point cannot reach the default tolerance (1e-12): it ran all 50 iterates, 51
    # conic programs, 80 % of this module's time; capped (the finish's fixed point, capped too, needs 2 .. 3) the
    # finished answers are the same (d1 2.081e-8 either way) at a fifth of the cost
    small, large = (finished_p2(sphere_into_block(N, depth=DEPTH, law=cc.Coulomb(m, max_iterations=8)))
                    for m in (1e-6, 1e-5))
    assert max(small.residuals()["feasibility"], large.residuals()["feasibility"]) <= 1e-14
    d1, d2 = _apart(small.u[0], free.u[0]), _apart(large.u[0], free.u[0])
    assert d1 <= 3e-6 and abs(d2 / d1 - 10) <= 0.01
    assert _apart(small.u[0] - (large.u[0] - small.u[0]) / 9, free.u[0]) <= 1e-11


def test_a_slipping_row_whose_slip_vanishes_gives_a_non_finite_step_without_a_warning():
    """A slipping row's force c s/|s| (:class:`~cvxcontact.backends.mixed.SlidingEnergy`) is undefined where the
    Newton drives its slip to 0: its gradient and tangent are then not finite, so the Newton's factorisation
    refuses (a decline: the cuts' answer stands), and no RuntimeWarning escapes the solve (an error under
    ``-W error``); a slip just above 0 is a force of size c along it, with the tangent c/|s| across it."""
    import warnings

    import scipy.sparse as sp

    from cvxcontact.backends.factor import lu
    from cvxcontact.backends.mixed import SlidingEnergy

    class Spring:                                              # the bulk energy |x|^2 / 2
        linear = True

        def gradient(self, x):
            return x

        def tangent(self, x):
            return sp.identity(len(x), format="csr")

        def magnitude(self, x):
            return np.abs(x)

    energy = SlidingEnergy(Spring(), sp.eye(2, 3, format="csr"), np.zeros(2), np.array([2.0]), 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        x = np.zeros(3)
        assert not np.isfinite(energy.gradient(x)[:2]).any() and not np.isfinite(energy.magnitude(x)[:2]).any()
        with pytest.raises(RuntimeError):
            lu(energy.tangent(x).tocsc()).solve(np.ones(3))
        x = np.array([0.0, 1e-12, 5.0])
        assert np.allclose(energy.gradient(x), [0.0, 2.0 + 1e-12, 5.0], rtol=0, atol=1e-15)   # x + S^T (0, c)
        K = energy.tangent(x)                                          # I + S^T (c/|s|) diag(1, 0) S
        assert np.isclose(K[0, 0], 1.0 + 2e12, rtol=1e-15) and K[1, 1] == 1.0 and K[2, 2] == 1.0


@pytest.mark.numerics
def test_a_stuck_row_over_its_capacity_declines_from_either_start(monkeypatch):
    """The partition's test on the stuck rows is the capacities' rounding (friction.SLIP_ROUNDING, as 2D's), also
    where the slips are read from the interior point's answer at a coarser floor (friction.INTERIOR_SLIP, 1e-7):
    that floor sorts the rows, it does not widen the friction cone. On the sphere at a threshold that sticks most
    rows (1e8 Pa), the most loaded stuck row's capacity set 1e-8 below its force (a stuck row's capacity moves
    nothing in the Newton: the same answer) is over it, so both starts decline; at the true capacities both
    accept. (The 1e-7 floor as the cone's tolerance accepted it.)"""
    from cvxcontact.backends import friction, frictiontangency
    from cvxcontact.backends.finish import Declined

    seen = []
    polish = frictiontangency._polish

    def spy(problem, trial, capacity, *rest):
        seen.append((problem, trial, np.array(capacity, dtype=float)))
        return polish(problem, trial, capacity, *rest)

    monkeypatch.setattr(frictiontangency, "_polish", spy)
    finished_p2(sphere_into_block(N, depth=DEPTH, law=cc.Tresca(1e8)))
    problem, trial, capacity = seen[0]
    R = problem.E.shape[0]
    for floor in (friction.SLIP_ROUNDING, friction.INTERIOR_SLIP):
        done = friction._tangency_polish(problem, trial, {}, capacity, floor)
        assert not isinstance(done, Declined)
        force = np.linalg.norm(done.tangential.reshape(-1, R), axis=0)
        stuck = np.flatnonzero((force < (1 - 1e-6) * capacity) & problem.rows.frictional)
        a = stuck[np.argmax(force[stuck])]
        assert force[a] > 0.1 * capacity.max()                       # the excess below is 1e-9 of the largest
        lowered = capacity.copy()
        lowered[a] = force[a] / (1 + 1e-8)
        assert isinstance(friction._tangency_polish(problem, trial, {}, lowered, floor), Declined)
