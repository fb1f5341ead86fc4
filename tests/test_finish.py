"""The exact finish (cvxcontact.backends.finish.solve_lcp) against brute-force enumeration of active sets."""

import itertools

import numpy as np
import pytest

from cvxcontact.backends.finish import solve_lcp

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def brute_force_lcp(W, d):
    """The solution of y >= 0, d - W y <= 0, y.(d - W y) = 0 by trying every active set (small m)."""
    m = len(d)
    for bits in itertools.product([False, True], repeat=m):
        A = np.array(bits)
        y = np.zeros(m)
        if A.any():
            y[A] = np.linalg.solve(W[np.ix_(A, A)], d[A])
        s = d - W @ y
        scale = np.abs(d) + np.abs(W) @ np.abs(y)         # each row against its own terms
        if (y * np.diag(W) >= -1e-11 * scale).all() and (s[~A] <= 1e-11 * scale[~A]).all():
            return y
    raise AssertionError("no solution found by enumeration")


def spd(rng, m, spread):
    """A random SPD matrix whose rows live on scales spread over `spread` decades."""
    Q = rng.standard_normal((m, m))
    D = np.diag(10.0 ** rng.uniform(-spread, 0, m))
    return D @ (Q @ Q.T + m * np.eye(m)) @ D


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("spread", [0, 4, 9])
def test_lcp_matches_enumeration(seed, spread):
    rng = np.random.default_rng(seed)
    m = 8
    W = spd(rng, m, spread)
    d = W @ rng.standard_normal(m) * 10.0 ** rng.uniform(-6, 6)     # any scale of the data
    D = 1 / np.sqrt(np.diag(W))                 # compare forces as the displacements they cause
    y_ref = D * brute_force_lcp(D[:, None] * W * D, D * d)
    for start in (None, np.zeros(m, bool), np.ones(m, bool), rng.random(m) < 0.5):
        y, active, route = solve_lcp(W, d, start)
        assert np.abs((y - y_ref) / D).max() <= 1e-9 * max(np.abs(y_ref / D).max(), 1e-300), route
        assert np.array_equal(active, y_ref > 0) or np.abs(y[active ^ (y_ref > 0)]).max() <= 1e-9 * np.abs(y_ref).max()


def test_stiff_soft_rows_do_not_cycle():
    """Rows of a stiff and a soft body (compliances 1e9 apart) coupled: the per-row scaled
    active-set rule settles, where one global force scale cycles."""
    rng = np.random.default_rng(7)
    m = 10
    B = rng.standard_normal((m, 3 * m))
    W = B @ B.T * 1e-9 + np.diag(np.linspace(1, 2, m))     # soft diagonal, small coupling
    W = W / W.max()
    d = 17.0 + np.sin(np.arange(m))                         # large free slack, partial contact
    d[::3] = -30.0
    y, active, route = solve_lcp(W, d, np.zeros(m, bool))
    np.testing.assert_allclose(y, brute_force_lcp(W, d), rtol=1e-10, atol=0)


def _twinned(rng, spread):
    """(W, d, twin, y_ref): the LCP of a random SPD W0 (6 rows; d0 made from a chosen answer, rows 0, 2, 4 closed)
    with rows 0, 2, 4 repeated as rows 6, 7, 8 (times c > 0: parallel rows, as two obstacles at one node) of a
    looser gap (by c delta, delta > 0), so each twin is implied by its row; y_ref the enumerated answer of W0 alone
    (nonsingular: an independent reference)."""
    m0, twin = 6, np.array([0, 2, 4])
    W0 = spd(rng, m0, spread)
    y0 = np.where(rng.random(m0) < 0.5, 0.0, rng.uniform(0.5, 1.0, m0)) / np.diag(W0)    # an answer: y0 >= 0,
    y0[twin] = rng.uniform(0.5, 1.0, len(twin)) / np.diag(W0)[twin]    # the twinned rows closed,
    d0 = W0 @ y0 - (y0 == 0) * rng.uniform(0.1, 1.0, m0)               # the others open where y0 = 0
    c = 10.0 ** rng.uniform(-2, 2, len(twin))
    P = np.vstack([np.eye(m0), c[:, None] * np.eye(m0)[twin]])
    delta = rng.uniform(0.1, 1.0, len(twin)) * (np.abs(W0) @ y0)[twin]   # the twin's gap looser (> 0)
    d = np.concatenate([d0, c * (d0[twin] - delta)])
    return P @ W0 @ P.T, d, twin, brute_force_lcp(W0, d0)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("spread", [0, 4])
def test_implied_rows_stay_open_and_a_needed_row_is_never_left_open(seed, spread):
    """solve_lcp(implied=) (the rows a tighter parallel row implies, backends/parallel.py): with the twins marked,
    the answer is that of W0 alone (enumerated), the twins' forces 0 and their slack <= 0; with the tighter rows
    marked instead (rows that are needed: each closed in the answer), no answer may leave them penetrated: the
    finish declines (their slack is checked, as every open row's). Review of the merged finish (h-int25): a variant
    that removed the implied rows from the LCP (h-p2held's) never read their slack; given the tighter rows it
    answered with them penetrated in all 12 cases."""
    from cvxcontact.backends.finish import Declined

    W, d, twin, y_ref = _twinned(np.random.default_rng(seed), spread)
    m = len(d)
    implied = np.zeros(m, dtype=bool)
    implied[6:] = True
    for start in (None, np.ones(m, bool)):
        y, active, _ = solve_lcp(W, d, start, implied=implied)
        assert not active[implied].any() and (y[implied] == 0).all()
        D = 1 / np.sqrt(np.diag(W))[:6]
        # measured <= 4.0e-16 (default, Haswell, Nehalem, Prescott, Sandybridge)
        assert np.abs((y[:6] - y_ref) / D).max() <= 1e-9 * np.abs(y_ref / D).max()
        S = np.abs(d) + np.abs(W) @ np.abs(y)
        assert (d - W @ y <= 1e-10 * S).all()      # every row feasible, the twins too (measured <= 2.0e-16 S)
    needed = np.zeros(m, dtype=bool)
    needed[twin] = True                                             # the tighter rows, each closed at y_ref
    assert (y_ref[twin] > 0).all()
    for start in (None, np.ones(m, bool)):
        out = solve_lcp(W, d, start, implied=needed)
        assert isinstance(out, Declined), out
