"""The exact finish of linearly dependent contact rows (3D "gamma3": one row per overlay vertex, more rows than
the jump's degrees of freedom; docs/formulation.md §13, "The exact finish").

Checked independently: on small random problems against the enumeration of every active set (the minimiser
is unique, the forces are not), on the patch test against the closed-form uniaxial solution, and on every
3D canonical scene with dependent rows by the singular values of every mixed matrix the finish factorises.
"""

import itertools
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.backends import full
from cvxcontact.backends.finish import independent_active_set

from scenes3d import P, bumped_blocks, piezo_pair, punch_on_pad, rotation, stacked_blocks, three_blocks, \
    uniaxial_modulus


def dense_kkt(A, F, G, g):
    """A mixed-system callable of the form :func:`cvxcontact.backends.full.mixed_kkt` returns, dense: one body
    with stiffness A (SPD), load F and contact rows G x <= g."""
    n = len(F)

    def kkt(active):
        Ga = G[active]
        K = np.block([[A, Ga.T], [Ga, np.zeros((len(Ga), len(Ga)))]])
        z = np.linalg.solve(K, np.concatenate([F, g[active]]))
        y = np.zeros(len(g))
        y[active] = z[n:]
        return ([z[:n]], [None], y), y, G @ z[:n] - g, np.abs(z[:n]).max()

    kkt.rows = sp.csr_matrix(G)
    kkt.stack = lambda x: x[0][0]
    return kkt


def enumerated(A, F, G, g):
    """The minimiser of 1/2 x^T A x - F^T x subject to G x <= g by trying every set of closed rows whose rows
    are independent: the one whose forces are >= 0 and every row feasible (independent of the finish)."""
    m = len(g)
    for k in range(m + 1):
        for rows in itertools.combinations(range(m), k):
            Ga = G[list(rows)]
            if k and np.linalg.matrix_rank(Ga) < k:
                continue
            K = np.block([[A, Ga.T], [Ga, np.zeros((k, k))]])
            z = np.linalg.solve(K, np.concatenate([F, g[list(rows)]]))
            x, y = z[:len(F)], z[len(F):]
            if (y >= -1e-12).all() and (G @ x - g <= 1e-12).all():
                return x
    raise AssertionError("no active set solves the problem")


@pytest.mark.parametrize("seed", range(6))
def test_dependent_rows_with_constant_slacks_against_every_active_set(seed):
    """Six unknowns, three independent rows that the load violates and five rows that are non-negative
    combinations of them, with gaps that make most dependent rows bind (a constant slack whatever x, as under
    a non-affine gap on an overlay): the finish reaches the minimiser (enumerated) from a start that closes
    the independent rows, so the dependent ones enter by simplex pivots (9 over the six seeds)."""
    rng = np.random.default_rng(seed)
    n = 6
    B = rng.normal(size=(n, n))
    A = B @ B.T + n * np.eye(n)
    base = rng.normal(size=(3, n))
    C = rng.uniform(0.1, 1.0, size=(5, 3)) * (rng.uniform(size=(5, 3)) < 0.7)
    C[np.arange(5), rng.integers(0, 3, 5)] = 0.7
    G = np.vstack([base, C @ base])
    x_free = rng.normal(size=n) * 3
    g = np.concatenate([base @ x_free - rng.uniform(0.5, 2.0, size=3), np.zeros(5)])
    g[3:] = C @ g[:3] - rng.uniform(-0.1, 0.5, size=5)         # dependent rows: constant slacks, most binding
    F = A @ x_free
    kkt = dense_kkt(A, F, G, g)
    start = np.arange(8) < 3
    out = independent_active_set(kkt, g, start.astype(float), start)
    assert not isinstance(out, str), out
    (u, _, y), active, steps = out
    x = u[0]
    ref = enumerated(A, F, G, g)
    assert np.abs(x - ref).max() < 1e-12 * np.abs(ref).max()               # measured 0 (the same closed rows)
    assert (y >= 0).all() and (y[~active] == 0).all()
    assert np.linalg.matrix_rank(G[active]) == active.sum()                # the force-carrying rows independent
    scale = np.abs(G) @ np.abs(x) + np.abs(g)
    assert (G @ x - g <= 1e-12 * scale).all()                               # measured <= 2.1e-16
    assert np.abs(A @ x + G.T @ y - F).max() < 1e-12 * np.abs(F).max()     # stationarity; measured 3.1e-16


def uniaxial_error(sol):
    """max |u_z + p z / c33| over both blocks, relative to the largest."""
    c33 = uniaxial_modulus()
    err = max(np.abs(sol.u[k][:, 2] + P * sol.points[k][:, 2] / c33).max() for k in range(2))
    return err / (P / c33)


def test_the_patch_test_on_non_matching_faces_holds_to_rounding():
    """The uniaxial solution is the discrete solution under gamma3 on any overlay (docs/formulation.md §13):
    the finished answer reproduces it to rounding (the interior point: 3.4e-10 in u, 1.2e-7 in lambda_h)."""
    sol = cc.solve(stacked_blocks(), "gamma3")
    assert sol.ok and sol.polished and sol.info.finish == "independent active set"
    assert uniaxial_error(sol) < 1e-13                                          # measured 3.5e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-10                        # measured 1.1e-12 (λ_h's solve)
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] / P - 1).max() < 1e-12                 # measured 2.1e-14
    r = sol.residuals()
    assert r["equilibrium"] < 1e-14 and r["feasibility"] < 1e-14             # measured 8.9e-17, 6.1e-16


SCENES = {"stacked 5x5 on 7x3": stacked_blocks, "bumped": bumped_blocks, "three blocks": three_blocks,
          "punch on a patch": punch_on_pad, "two PZT blocks": piezo_pair,
          "two PZT blocks turned": lambda: piezo_pair(rotation())}


@pytest.mark.parametrize("name", list(SCENES))
def test_no_singular_mixed_matrix_is_factorised(name, monkeypatch):
    """Every mixed matrix the finish solves (:func:`cvxcontact.backends.full.solve_mixed`, the one place it
    factorises) is non-singular: its smallest singular value is far from rounding relative to the largest
    (dense SVD of each; the turned pair's faces are tilted, so its dependent rows are dependent only
    numerically). The answer is exact (ok at the default tol, no ResidualWarning)."""
    seen = []
    solve_mixed = full.solve_mixed

    def recording(K, *args, **kwargs):
        s = np.linalg.svd(K.toarray(), compute_uv=False)
        seen.append(s[-1] / s[0])
        return solve_mixed(K, *args, **kwargs)

    monkeypatch.setattr(full, "solve_mixed", recording)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(SCENES[name](), "gamma3", method="full")
    assert sol.ok and sol.polished and sol.info.finish == "independent active set"
    assert seen and min(seen) > 1e-8                                            # measured >= 4.4e-4
