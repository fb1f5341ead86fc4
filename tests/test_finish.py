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
