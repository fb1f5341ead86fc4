"""The exact finish of a friction law (cvxcontact.backends.finish.friction, docs/howto/friction.md "The exact
finish") on its own: independent nodes, each a point on springs pressed on a plane and pulled along it, whose
answers are closed forms (2D) or the root of one scalar equation (3D, anisotropic tangential springs: the slip
is not along the pull, the direction condition is genuinely nonlinear); and the decline that keeps the interior
point's answer."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import brentq

import cvxcontact as cc
from cvxcontact.backends.finish import Declined, Stop
from cvxcontact.backends.finish.friction import FrictionRows, solve_friction


def nodes(nc, seed=0, n=12):
    """n independent nodes, nc tangential components each: springs k_t (nc,) and k_n, a pull f (nc,) along the
    plane and a push p into it; half Tresca (capacity c0), half Coulomb (capacity mu y); (the system, the
    reference x, y, mu). Node i: unknowns (t_1..t_nc, n) at i (nc + 1); the row G x <= 0 is -u_n <= 0."""
    rng = np.random.default_rng(seed)
    kt = rng.uniform(0.5, 2.0, (n, nc))
    kn = rng.uniform(0.5, 2.0, n)
    p = rng.uniform(0.5, 2.0, n)
    f = rng.normal(size=(n, nc))
    coulomb = np.arange(n) % 2 == 1
    c0 = np.where(coulomb, 0.0, rng.uniform(0.2, 1.5, n))
    D = np.where(coulomb, rng.uniform(0.2, 1.0, n), 0.0)
    m = nc + 1
    T = sp.diags(np.column_stack([kt, kn]).ravel()).tocsr()
    b = np.column_stack([f, -p]).ravel()
    G = sp.csr_matrix((-np.ones(n), (np.arange(n), m * np.arange(n) + nc)), shape=(n, m * n))
    S = sp.csr_matrix((np.ones(n * nc), (np.arange(n * nc), (m * np.arange(n)[:, None] + np.arange(nc)).ravel())),
                      shape=(n * nc, m * n))
    fr = FrictionRows(S, np.zeros(n * nc), np.arange(n), c0, D, nc, np.ones(n, dtype=bool))
    # the reference: closed, y = p; stuck where |f| <= c, else x_t = (K_t + c / r)^-1 f with r = |x_t|
    y = p.copy()
    c = c0 + D * y
    xt, mu = np.zeros((n, nc)), f.copy()
    for i in np.flatnonzero(np.linalg.norm(f, axis=1) > c):
        def gap(r, i=i):
            return np.linalg.norm(f[i] / (kt[i] + c[i] / r)) - r
        top = np.linalg.norm(f[i]) / kt[i].min()                 # gap > 0 near 0 (|f| > c), <= 0 at top
        r = brentq(gap, 1e-12 * top, top, xtol=1e-300, rtol=4 * np.finfo(float).eps)
        xt[i] = f[i] / (kt[i] + c[i] / r)
        mu[i] = f[i] - kt[i] * xt[i]
    x = np.column_stack([xt, np.zeros(n)]).ravel()
    return (T, b, G, np.zeros(n), fr), (x, y, mu), (c, np.linalg.norm(f, axis=1))


def finished_at(system, start, answer):
    """:func:`solve_friction` on ``system`` from ``start`` (x0, y0, mu0), every row free: not declined, every row
    closed, and (x, y, mu) the closed form ``answer`` to 1e-12 of their sizes. Returns its x, mu and steps."""
    x, y, mu = answer
    out = solve_friction(*system, np.ones(len(y), dtype=bool), *start, (float(y.max()), float(np.abs(x).max())))
    assert not isinstance(out, Declined), out
    xf, yf, muf, closed, steps = out
    assert closed.all()
    assert np.abs(xf - x).max() < 1e-12 * np.abs(x).max()
    assert np.abs(yf - y).max() < 1e-12 * y.max()
    assert np.abs(muf - mu).max() < 1e-12 * np.abs(mu).max()
    return xf, muf, steps


@pytest.mark.numerics
@pytest.mark.parametrize("nc", [1, 2])
def test_the_finish_of_independent_nodes_is_their_closed_form(nc):
    system, (x, y, mu), (c, pull) = nodes(nc)
    slips = pull > c
    assert 3 <= slips.sum() <= len(c) - 3                       # both kinds: stuck and slipping nodes
    n = len(c)
    # from a rough start (nothing moved, no force) and from the answer itself, 1e-3 off
    for start in ((np.zeros_like(x), np.zeros(n), np.zeros((n, nc))),
                  (x * (1 + 1e-3), y * (1 - 1e-3), mu * (1 + 1e-3))):
        # measured at most 2.2e-16 (x), 0 (y), 3.5e-16 (mu) for nc = 1 and 2, both starts (Haswell, Prescott)
        xf, _, steps = finished_at(system, start, (x, y, mu))
        if nc == 1:
            assert steps <= 4                                   # linear once the set is right: measured 3
        if nc == 2:                                             # the slip is not along the pull (anisotropic)
            f = system[1].reshape(n, nc + 1)[:, :nc]
            turn = 1 - np.einsum("ij,ij->i", xf.reshape(n, 3)[:, :2], f) / (
                np.linalg.norm(xf.reshape(n, 3)[:, :2], axis=1) * np.linalg.norm(f, axis=1) + 1e-300)
            assert turn[slips].max() > 1e-3                        # measured 2.2e-2


def coupled_degenerate(nc, seed, n=12):
    """n nodes coupled by a dense spring matrix (rounding reaches every row), every row closed at its gap g_a and
    stuck at its prescribed slip s0_a (x = (-s0, -g) per node), half Tresca, half Coulomb; every other Coulomb
    row carries no force (y_a = 0, mu_a = 0: capacity 0, force and gap and slip all 0, strict complementarity
    fails), the others a force and half their capacity. The loads b = T x + G^T y + S^T mu. Returns (the system,
    (x, y, mu), the degenerate rows)."""
    rng = np.random.default_rng(seed)
    m = nc + 1
    A = rng.normal(size=(m * n, m * n))
    T = sp.csr_matrix(A @ A.T / (m * n) + np.eye(m * n))
    coulomb = np.arange(n) % 2 == 1
    zero = np.arange(n) % 4 == 1
    y = np.where(zero, 0.0, rng.uniform(0.5, 2.0, n))
    D = np.where(coulomb, rng.uniform(0.2, 1.0, n), 0.0)
    c0 = np.where(coulomb, 0.0, rng.uniform(0.5, 1.5, n))
    d = rng.normal(size=(n, nc))
    mu = 0.5 * (c0 + D * y)[:, None] * d / np.linalg.norm(d, axis=1)[:, None]
    s0, g = rng.normal(size=(n, nc)), rng.uniform(-1.0, 1.0, n)
    x = np.column_stack([-s0, -g]).ravel()
    G = sp.csr_matrix((-np.ones(n), (np.arange(n), m * np.arange(n) + nc)), shape=(n, m * n))
    S = sp.csr_matrix((np.ones(n * nc), (np.arange(n * nc), (m * np.arange(n)[:, None] + np.arange(nc)).ravel())),
                      shape=(n * nc, m * n))
    fr = FrictionRows(S, s0.ravel(), np.arange(n), c0, D, nc, np.ones(n, dtype=bool))
    return (T, T @ x + G.T @ y + S.T @ mu.ravel(), G, g, fr), (x, y, mu), zero


@pytest.mark.numerics
@pytest.mark.parametrize("nc", [1, 2])
def test_rows_without_force_gap_or_slip_settle(nc):
    """The rows of :func:`coupled_degenerate` that carry nothing satisfy either branch of their law; the steps
    reach rounding there and the signs choosing the branch are the rounding's. Before ties counted as closed and
    stuck (finish.friction.TIE) 7 of these 40 were declined (2D: the set cycled; 3D: the steps stalled)."""
    for seed in range(20):
        system, (x, y, mu), zero = coupled_degenerate(nc, seed)
        assert zero.sum() == 3
        start = (x * (1 + 1e-3), y * (1 - 1e-3) + 1e-3 * zero, mu * (1 + 1e-3))   # a degenerate row pushed open
        # measured at most 3.5e-16 (x, y) and 2.3e-15 (mu) over the seeds, nc = 1 and 2
        finished_at(system, start, (x, y, mu))


def test_steps_that_do_not_settle_are_declined_with_their_reason():
    system, (x, y, _), _ = nodes(2)
    n = len(y)
    out = solve_friction(*system, np.ones(n, dtype=bool), np.zeros_like(x), np.zeros(n), np.zeros((n, 2)),
                         (float(y.max()), float(np.abs(x).max())), max_steps=1)
    assert isinstance(out, Declined) and out.stop == Stop.MAX_ITER


def test_a_declined_finish_keeps_the_interior_point_answer(monkeypatch):
    from friction_scenes import sheared

    import cvxcontact.backends.finish.friction as finish

    scene = sheared(0.9e6, cc.Tresca(1e6))
    monkeypatch.setattr(finish, "MAX_STEPS", 0)                  # no step: the finish cannot settle
    kept = cc.solve(scene)
    assert kept.path == cc.Route.INTERIOR_POINT_FRICTION and not kept.polished and kept.info.finish is None
    assert kept.ok                                              # the interior point at its accuracy, as before
    assert kept.residuals()["stick-slip"] > 1e-9                # measured 9.5e-8: not the finish's rounding
    assert kept.info.declined.stop is Stop.MAX_ITER              # the reason, on the solution and its report
    assert f"exact finish declined: {Stop.MAX_ITER.value}" in kept.report()
    monkeypatch.undo()
    done = cc.solve(scene)
    assert done.polished and done.info.finish == cc.Finish.FRICTION_NEWTON
    assert done.info.declined is None and "declined" not in done.report()
    plain = cc.solve(scene, polish=False)
    assert plain.path == cc.Route.INTERIOR_POINT_FRICTION and not plain.polished and plain.info.declined is None
    scale = np.abs(done.u[0]).max()
    assert np.abs(plain.u[0] - done.u[0]).max() < 1e-8 * scale   # the same answer, at the IPM's accuracy: 5.4e-13


def one_component(s0, n=10, seed=1):
    """n independent 3D nodes (``nodes``' springs, Tresca) whose first tangential component no unknown moves (a
    support fixing that direction: S_a,1 = 0), its slip prescribed ``s0`` (n,); the second free. The answer by
    hand: the first unknown is a spring alone, x_1 = f_1 / k_1; where s0 = 0 the row is the 2D law on the second
    component (stuck if |f_2| <= c: x_2 = 0, mu = (0, f_2); else mu_2 = c sign f_2), where s0 != 0 it cannot
    stick: mu = c s / |s|, s = (s0, x_2), k_2 x_2 + c x_2 / |s| = f_2 (one scalar root)."""
    rng = np.random.default_rng(seed)
    kt, kn, p = rng.uniform(0.5, 2.0, (n, 2)), rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    f, c = rng.normal(size=(n, 2)), rng.uniform(0.2, 1.5, n)
    T = sp.diags(np.column_stack([kt, kn]).ravel()).tocsr()
    b = np.column_stack([f, -p]).ravel()
    G = sp.csr_matrix((-np.ones(n), (np.arange(n), 3 * np.arange(n) + 2)), shape=(n, 3 * n))
    S = sp.csr_matrix((np.ones(n), (2 * np.arange(n) + 1, 3 * np.arange(n) + 1)), shape=(2 * n, 3 * n))
    moved = np.column_stack([np.zeros(n, dtype=bool), np.ones(n, dtype=bool)])
    fr = FrictionRows(S, np.column_stack([s0, np.zeros(n)]).ravel(), np.arange(n), c, np.zeros(n), 2, moved)
    x2, mu = np.zeros(n), np.zeros((n, 2))
    for i in range(n):
        if s0[i] == 0:
            mu[i, 1] = np.clip(f[i, 1], -c[i], c[i])
            x2[i] = (f[i, 1] - mu[i, 1]) / kt[i, 1]
            continue
        def force(v, i=i):
            return kt[i, 1] * v + c[i] * v / np.hypot(s0[i], v) - f[i, 1]
        top = abs(f[i, 1]) / kt[i, 1] + 1.0
        x2[i] = brentq(force, -top, top, xtol=1e-300, rtol=4 * np.finfo(float).eps)
        mu[i] = c[i] * np.array([s0[i], x2[i]]) / np.hypot(s0[i], x2[i])
    x = np.column_stack([f[:, 0] / kt[:, 0], x2, np.zeros(n)]).ravel()
    return (T, b, G, np.zeros(n), fr), (x, p, mu), (c, f)


@pytest.mark.numerics
def test_a_row_with_one_tangential_component_fixed_is_finished_to_its_closed_form():
    n = 10
    for s0 in (np.zeros(n), np.where(np.arange(n) % 2 == 0, 0.0, np.linspace(-0.5, 0.5, n))):
        system, (x, y, mu), (c, f) = one_component(s0, n)
        sticks = (s0 == 0) & (np.abs(f[:, 1]) <= c)
        assert 2 <= sticks.sum() <= n - 2                            # stuck rows with a fixed component, and not
        for x0, y0, mu0 in ((np.zeros_like(x), np.zeros(n), np.zeros((n, 2))),
                            (x * (1 + 1e-3), y * (1 - 1e-3), mu + 0.1)):     # mu0 off in the fixed component too
            # measured at most 4.4e-16 (x), 0 (y), 2.2e-16 (mu), Haswell and Prescott
            _, muf, _ = finished_at(system, (x0, y0, mu0), (x, y, mu))
            assert (muf[sticks, 0] == 0).all()                      # the force acting on nothing: its least value


@pytest.mark.numerics
@pytest.mark.parametrize("nc", [1, 2])
def test_rows_each_posed_twice_are_finished_to_the_closed_form(nc):
    """``nodes`` with every normal and friction row posed twice (exactly dependent rows, as on a 3D "gamma3"
    overlay; Tresca's capacity shared between the copies, Coulomb's mu y_a on each): the same displacements, and
    forces whose copies add up to the closed form's; without ``dependent`` the step is singular."""
    (T, b, G, _, fr), (x, y, mu), _ = nodes(nc)
    n = len(y)
    twice = FrictionRows(sp.vstack([fr.S, fr.S]), np.zeros(2 * n * nc), np.arange(2 * n), np.tile(fr.c0 / 2, 2),
                         np.tile(fr.D, 2), nc, np.ones(2 * n, dtype=bool))
    system = (T, b, sp.vstack([G, G]).tocsr(), np.zeros(2 * n), twice)
    free, scales = np.ones(2 * n, dtype=bool), (float(y.max()), float(np.abs(x).max()))
    for x0, y0, mu0 in ((np.zeros_like(x), np.zeros(2 * n), np.zeros((2 * n, nc))),
                        (x * (1 + 1e-3), np.tile(y, 2) * (1 - 1e-3) / 2, np.tile(mu, (2, 1)) * (1 + 1e-3) / 2),
                        (x * (1 + 1e-3), np.concatenate([0.2 * y, 0.8 * y]), np.tile(mu, (2, 1)) / 2)):
        assert solve_friction(*system, free, x0, y0, mu0, scales).stop == Stop.SINGULAR
        out = solve_friction(*system, free, x0, y0, mu0, scales, dependent=True)
        assert not isinstance(out, Declined), out
        xf, yf, muf, closed, _ = out
        assert (closed[:n] | closed[n:]).all()                     # each node closed by one of its copies
        # measured at most 2.2e-16 (x), 1.2e-16 (y), 3.5e-16 (mu), nc = 1 and 2, the three starts (three kernels)
        assert np.abs(xf - x).max() < 1e-12 * np.abs(x).max()
        assert np.abs(yf[:n] + yf[n:] - y).max() < 1e-12 * y.max()
        assert np.abs(muf[:n] + muf[n:] - mu).max() < 1e-12 * np.abs(mu).max()
        cap = twice.capacity(yf)                                     # each copy within its own cone
        assert (np.linalg.norm(muf, axis=1) <= cap * (1 + 1e-12) + 1e-15).all() and (yf >= 0).all()


@pytest.mark.numerics
def test_a_2d_set_that_comes_back_is_pivoted_to_the_answer(shared):
    """The 2D pair of non-matching lines under the P2 cones with Tresca's friction: the finish's steps come back to
    an active set already solved, and the one-row pivots from the set just solved end them (module docstring of
    backends/finish/friction.py). The pivots run (spied) and the answer is finished, every check at rounding (was:
    a NameError out of ``cc.solve`` once the steps moved into their own function). The solve is shared with
    tests/test_friction_p2_gamma3.py (a ResidualWarning of it raised here again, an error)."""
    from friction_scenes import pair2d_key

    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol, calls = shared(*pair2d_key())
    assert calls
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    r = sol.residuals()
    assert r["friction cone"] <= 1e-10 and r["equilibrium"] <= 1e-10     # measured 0 and 7.3e-14


def test_a_set_met_again_reuses_its_factor_and_the_answer_is_the_same_bit_for_bit(monkeypatch):
    """The Jacobian's LU is kept by the blocks that vary with the active set (``_System.factor``): the same set
    gives the same factor object, a factor solves its own Jacobian (against a dense solve), the oldest factor
    leaves past ``KEPT_FACTORS``, and the finish's answer with no factor kept is the same bit for bit."""
    from cvxcontact.backends.factor import superlu
    from cvxcontact.backends.finish import friction as finish

    system, (x, y, mu), _ = nodes(1)
    T, b, G, g, fr = system
    scales = (float(y.max()), float(np.abs(x).max()))
    free = np.ones(len(y), dtype=bool)
    s = finish._System(T, b, G, g, fr, free, scales)
    w = np.concatenate([np.zeros_like(x), y, np.zeros(mu.size)])
    state = s.state(w)
    frozen = s.frozen(w, state)
    lu = s.factor(state, frozen)
    assert s.factor(state, frozen) is lu and len(s._factors) == 1
    rhs = s.step_rhs(w, state, frozen)
    J = s.jacobian(state, frozen)
    assert np.array_equal(lu.solve(rhs), superlu(J).solve(rhs))
    dense = np.linalg.solve(J.toarray(), rhs)
    assert np.abs(lu.solve(rhs) - dense).max() <= 1e-12 * np.abs(dense).max()     # measured 0
    monkeypatch.setattr(finish, "KEPT_FACTORS", 2)
    states = []
    for i in range(3):                                   # three sets: row i open
        closed = state[0].copy()
        closed[i] = False
        states.append((closed, *state[1:]))
        s.factor(states[-1], frozen)
    assert len(s._factors) == 2 and s.factor(states[2], frozen) is s.factor(states[2], frozen)
    start = (x + 0.3 * np.abs(x).max(), 0.5 * y, np.zeros_like(mu))
    kept = solve_friction(*system, free, *start, scales)
    monkeypatch.setattr(finish, "KEPT_FACTORS", 0)
    fresh = solve_friction(*system, free, *start, scales)
    assert not isinstance(kept, Declined) and kept[4] == fresh[4]
    for a, c in zip(kept[:4], fresh[:4]):
        assert np.array_equal(a, c)
