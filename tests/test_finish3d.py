"""The exact finish of linearly dependent contact rows (3D "gamma3": one row per overlay vertex, more rows than
the jump's degrees of freedom; docs/formulation.md §13, "The exact finish").

Checked independently: on small random problems against the enumeration of every active set (the minimiser
is unique, the forces are not), on the patch test against the closed-form uniaxial solution, and on every
3D canonical scene with dependent rows by the singular values of every matrix the finish factorises. The
factored steps (one factorisation of the bodies, the system on the rows updated row by row) against the
steps that solve the sparse mixed system each time, and the condensed route's finish against the full
route's and a closed form.
"""

import itertools
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.backends import finish, full, signorini
from cvxcontact.backends.finish import UpdatedSystem, independent_active_set

from references import dense_kkt, enumerated
from scenes3d import P, SIDES, STEEL, bumped_blocks, bumped_gap, piezo_pair, punch_on_pad, rotation, stacked_blocks, \
    three_blocks, two_boxes, uniaxial_modulus

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def _dependent_rows(rng, dependent, n=6):
    """(A, base, C): an SPD A (n x n), three random rows ``base`` and the non-negative combinations C (dependent
    x 3, some entries 0, one 0.7 a row) that make the dependent rows C @ base."""
    B = rng.normal(size=(n, n))
    A = B @ B.T + n * np.eye(n)
    base = rng.normal(size=(3, n))
    C = rng.uniform(0.1, 1.0, size=(dependent, 3)) * (rng.uniform(size=(dependent, 3)) < 0.7)
    C[np.arange(dependent), rng.integers(0, 3, dependent)] = 0.7
    return A, base, C


@pytest.mark.parametrize("factored", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_dependent_rows_with_constant_slacks_against_every_active_set(seed, factored):
    """Six unknowns, three independent rows that the load violates and five rows that are non-negative
    combinations of them, with gaps that make most dependent rows bind (a constant slack whatever x, as under
    a non-affine gap on an overlay): the finish reaches the minimiser (enumerated) from a start that closes
    the independent rows, so the dependent ones enter by simplex pivots (9 over the six seeds)."""
    rng = np.random.default_rng(seed)
    A, base, C = _dependent_rows(rng, 5)
    n = len(A)
    G = np.vstack([base, C @ base])
    x_free = rng.normal(size=n) * 3
    g = np.concatenate([base @ x_free - rng.uniform(0.5, 2.0, size=3), np.zeros(5)])
    g[3:] = C @ g[:3] - rng.uniform(-0.1, 0.5, size=5)         # dependent rows: constant slacks, most binding
    F = A @ x_free
    kkt = dense_kkt(A, F, G, g)
    start = np.arange(8) < 3
    out = independent_active_set(kkt, g, start.astype(float), start, factored=factored)
    assert not isinstance(out, str), out
    (u, _, y), active, steps = out
    x = u[0]
    ref = enumerated(A, F, G, g)
    assert np.abs(x - ref).max() < 1e-12 * np.abs(ref).max()               # measured <= 6.9e-16
    assert (y >= 0).all() and (y[~active] == 0).all()
    assert np.linalg.matrix_rank(G[active]) == active.sum()                # the force-carrying rows independent
    scale = np.abs(G) @ np.abs(x) + np.abs(g)
    assert (G @ x - g <= 1e-12 * scale).all()                               # measured <= 2.1e-16
    assert np.abs(A @ x + G.T @ y - F).max() < 1e-12 * np.abs(F).max()     # stationarity; measured <= 8.1e-16


@pytest.mark.parametrize("seed", range(6))
def test_a_body_held_by_the_rows_only_from_a_start_closing_every_row(seed):
    """A stiffness with a two-dimensional kernel (a body only the rows hold), three independent rows carrying
    the load and five dependent rows with constant slacks; the start closes every row, so the first rows
    carrying forces (which regularise the factored steps) include rows that must leave, and the steps solve
    systems with open regularised rows. The factored steps and the sparse ones, each from the first
    independent rows or from the crossover of the start's forces, reach the enumerated minimiser."""
    rng = np.random.default_rng(100 + seed)
    n = 6
    B = rng.normal(size=(n, n - 2))
    A = B @ B.T                                                 # rank n - 2: a kernel the rows must hold
    base = rng.normal(size=(3, n))
    C = rng.uniform(0.1, 1.0, size=(5, 3)) * (rng.uniform(size=(5, 3)) < 0.7)
    C[np.arange(5), rng.integers(0, 3, 5)] = 0.7
    G = np.vstack([base, C @ base])
    x_star = rng.normal(size=n)
    F = A @ x_star + base.T @ rng.uniform(0.5, 2.0, size=3)    # forces >= 0 on the base rows: a minimiser
    g = np.concatenate([base @ x_star, np.zeros(5)])
    g[3:] = C @ g[:3] - rng.uniform(-0.1, 0.5, size=5)
    ref = enumerated(A, F, G, g)
    kkt = dense_kkt(A, F, G, g)
    start = np.ones(8, dtype=bool)
    for factored, purify in itertools.product((False, True), (False, True)):
        out = independent_active_set(kkt, g, start.astype(float), start, factored=factored, purify=purify)
        assert not isinstance(out, str), out
        (u, _, y), active, _ = out
        x = u[0]
        assert np.abs(x - ref).max() < 1e-10 * np.abs(ref).max()          # measured <= 1.2e-14
        assert (y >= 0).all() and np.linalg.matrix_rank(G[active]) == active.sum()
        assert np.abs(A @ x + G.T @ y - F).max() < 1e-12 * np.abs(F).max()  # measured <= 1.7e-15


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("pivoted", [False, True])
def test_the_crossover_keeps_the_resultant_on_independent_rows_with_forces_ge_0(seed, pivoted):
    """The start of the finish: the interior point's forces y0 >= 0 on 30 rows of rank 8 (with duplicated and
    scaled rows) moved onto an independent subset with the same resultant G^T y, checked by numpy: G^T y =
    G^T y0 to rounding, y >= 0, zero off the subset, the subset's rows independent. ``pivoted``: the tableau from
    the R of the weighted column-pivoted QR that chose the subset (as the finish runs it), else from a QR of
    the subset's rows."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(8, 12))
    C = rng.uniform(0, 1, size=(30, 8)) * (rng.uniform(size=(30, 8)) < 0.4)
    C[np.arange(30), rng.integers(0, 8, 30)] = 0.5                           # no zero row
    C[np.arange(8), np.arange(8)] = 1.0
    G = C @ base
    G[20:] = G[:10] * rng.uniform(0.5, 2.0, size=(10, 1))                    # parallel rows, other lengths
    y0 = rng.uniform(0, 1, size=30) * (rng.uniform(size=30) < 0.8)
    norms = np.linalg.norm(G, axis=1)
    U = G / norms[:, None]
    cand = np.flatnonzero(y0 > 0)
    scale = y0[cand] / y0[cand].max()
    chosen, R, piv = finish.independent_columns(U[cand].T * scale, factors=True)
    assert (chosen == finish.independent_columns(U[cand].T * scale)).all()
    passive, y = finish.purified(U[cand], norms, y0, cand, chosen, (R, piv, scale) if pivoted else None)
    assert len(passive) == np.linalg.matrix_rank(G[cand]) == np.linalg.matrix_rank(G[passive])
    assert (y >= 0).all() and (y[np.setdiff1d(np.arange(30), passive)] == 0).all()
    assert np.abs(G.T @ y - G.T @ y0).max() < 1e-13 * np.abs(G).T.dot(y0).max()   # measured <= 1.7e-16


@pytest.mark.parametrize("seed", range(3))
def test_the_start_chosen_group_by_group_spans_every_row_and_keeps_the_resultant(seed):
    """The independent start chosen by groups of neighbouring rows (8 a group: 60 groups) then one pivoted QR on
    the rows they keep: 480 local rows (each on 3 consecutive of 200 unknowns, a 1D chain; parallel copies and
    sums of neighbours, in random order, forces 0.01 to 1) against numpy: the chosen rows independent and as
    many as G's rank; every row the combination of the chosen ones that R gives (R[:p, :p]^-1 R[:p, j]), so
    the crossover on them keeps G^T y with y >= 0 off nothing but the chosen rows' successors."""
    rng = np.random.default_rng(seed)
    n = 200
    base = np.zeros((n - 2, n))
    for i in range(n - 2):
        base[i, i:i + 3] = rng.normal(size=3)
    G = np.vstack([base, base[rng.integers(0, n - 2, 150)] * rng.uniform(0.5, 2.0, size=(150, 1)),
                   base[:133] + base[1:134]])
    G = G[rng.permutation(len(G))]
    norms = np.linalg.norm(G, axis=1)
    U = G / norms[:, None]
    y0 = rng.uniform(0.01, 1, size=len(G))
    scale = y0 / y0.max()
    chosen, R, piv = finish.independent_rows(sp.csr_matrix(U * scale[:, None]), group=8)
    p = len(chosen)
    assert p == np.linalg.matrix_rank(G) == np.linalg.matrix_rank(G[chosen]) == n - 2
    assert p == len(finish.independent_columns(U.T * scale))                      # as many as all rows at once
    assert (piv[:p] == chosen).all() and sorted(piv) == list(range(len(G)))
    M = U.T * scale
    coef = np.linalg.solve(np.triu(R[:, :p]), R[:, p:])
    assert np.abs(M[:, chosen] @ coef - M[:, piv[p:]]).max() < 1e-10         # measured <= 5.4e-16
    cand = np.arange(len(G))
    passive, y = finish.purified(U, norms, y0, cand, chosen, (R, piv, scale))
    assert np.linalg.matrix_rank(G[passive]) == len(passive) == p
    assert (y >= 0).all() and (y[np.setdiff1d(cand, passive)] == 0).all()
    assert np.abs(G.T @ y - G.T @ y0).max() < 1e-12 * np.abs(G).T.dot(y0).max()   # measured <= 3.9e-16


@pytest.mark.parametrize("form", [np.asarray, sp.csr_matrix])
def test_the_compliant_rows_form_w_on_the_rows_that_carry_forces_as_the_dense_compliance(form):
    """``form``: the bodies' jump maps dense or sparse (CSR, as :func:`~cvxcontact.backends.condensed.condense`
    keeps them). :class:`~cvxcontact.backends.condensed.Compliance` forms W and B on first use and
    :class:`~cvxcontact.backends.finish.CompliantRows` only W's block on the rows that entered a passive set:
    two random SPD "bodies" (Sigma_l) and 40 dependent rows on their 12 + 9 dofs, against numpy's dense
    W = sum_l R_l Sigma_l^-1 R_l^T; each step's forces solve W_PP y_P = d_P and its slack is d - W y; another load
    case reuses the kept block."""
    from types import SimpleNamespace

    from cvxcontact.backends.condensed import Compliance
    from cvxcontact.backends.finish import CompliantRows

    rng = np.random.default_rng(3)
    bodies, sizes, m = [], (12, 9), 40
    for k in sizes:
        X = rng.normal(size=(k, k))
        J = rng.normal(size=(15, k))
        J[rng.random(J.shape) < 0.5] = 0.0                                        # sparse rows
        bodies.append(SimpleNamespace(stiffness=X @ X.T + k * np.eye(k), jump=form(J)))
    E = sp.random(m, 15, density=0.2, random_state=rng, format="csr") + sp.eye(m, 15, format="csr")
    comp = Compliance(bodies, E)
    R = [np.asarray((E @ b.jump).toarray() if sp.issparse(b.jump) else E @ b.jump) for b in bodies]
    W = sum(Rl @ np.linalg.solve(b.stiffness, Rl.T) for Rl, b in zip(R, bodies))
    assert comp._W is None and comp._B is None                                  # nothing formed yet
    cols = comp.columns([3, 7, 11])
    assert np.abs(np.hstack(R) @ cols - W[:, [3, 7, 11]]).max() < 1e-12 * np.abs(W).max()   # measured 1e-16
    v0 = [rng.normal(size=k) for k in sizes]
    g = rng.normal(size=m)
    rows = CompliantRows(comp, v0, g)
    d = np.hstack(R) @ np.concatenate(v0) - g
    for rows_p in ([0, 5, 9], [0, 5, 9, 14, 2], [9, 14, 30, 31], list(range(0, 21, 2))):
        y, _, slack, _ = rows(None, rows_p)
        assert np.abs(W[np.ix_(rows_p, rows_p)] @ y[rows_p] - d[rows_p]).max() < 1e-10 * np.abs(d).max()  # 1e-15
        assert (y[np.setdiff1d(np.arange(m), rows_p)] == 0).all()
        assert np.abs(slack - (d - W @ y)).max() < 1e-10 * np.abs(d).max()            # measured 1e-15
    kept = np.flatnonzero(comp.where >= 0)
    assert set(kept) == set(range(0, 21, 2)) | {5, 9, 14, 30, 31} and comp._W is None   # W never formed whole
    again = CompliantRows(comp, v0, 2 * g)                  # another load case: the kept block is reused
    y, _, slack, _ = again(None, [0, 5, 9])
    d2 = np.hstack(R) @ np.concatenate(v0) - 2 * g
    assert comp.count == len(kept) and np.abs(slack - (d2 - W @ y)).max() < 1e-10 * np.abs(d2).max()
    assert np.abs(comp.W - W).max() < 1e-12 * np.abs(W).max()                           # measured 1e-16


def test_the_updated_interface_system_solves_like_a_dense_solve():
    """:class:`UpdatedSystem` (QR updated key by key) on a symmetric indefinite matrix, along 60 random changes
    of its keys (1-3 keys in or out, now and then many): each answer against numpy's dense solve."""
    rng = np.random.default_rng(7)
    N = 40
    X = rng.normal(size=(N, N))
    Mfull = X + X.T + np.diag(rng.choice([-1.0, 1.0], N) * 8.0)

    def entries(a, b):
        return Mfull[np.ix_(a // 2, b // 2)]

    system = UpdatedSystem(entries)
    keys = 2 * rng.choice(N, 10, replace=False)
    worst = 0.0
    for k in range(60):
        if k % 20 == 19:
            keys = 2 * rng.choice(N, int(rng.integers(5, 30)), replace=False)
        else:
            out = rng.choice(len(keys), min(int(rng.integers(0, 3)), len(keys) - 1), replace=False)
            keys = np.delete(keys, out)
            fresh = np.setdiff1d(2 * np.arange(N), keys)
            keys = np.concatenate([keys, rng.choice(fresh, int(rng.integers(0, 3)), replace=False)])
            keys = rng.permutation(keys)
        b = rng.normal(size=len(keys))
        M = entries(keys, keys)
        w = system.solve(keys, b)
        ref = np.linalg.solve(M, b)
        worst = max(worst, np.abs(w - ref).max() / (np.linalg.cond(M) * np.abs(ref).max()))
    assert system.updates > 30 and system.factorisations >= 3
    assert worst < 1e-13                                                  # measured 1.8e-16


@pytest.mark.numerics
def test_the_cholesky_interface_system_solves_like_a_dense_solve():
    """:class:`CholeskySystem` (W_PP of :class:`~cvxcontact.backends.finish.CompliantRows`: Cholesky updated key by
    key) on a symmetric positive definite matrix with a spread of 1e6 in its eigenvalues, along 80 random changes
    of its keys (1-3 keys in or out, in any order, now and then many): each answer against numpy's dense solve;
    the deletions' rank-one updates keep U^T U the matrix on the keys."""
    from cvxcontact.backends.finish import CholeskySystem

    rng = np.random.default_rng(11)
    N = 50
    Q = np.linalg.qr(rng.normal(size=(N, N)))[0]
    Mfull = (Q * np.logspace(0, 6, N)) @ Q.T

    def entries(a, b):
        return Mfull[np.ix_(a // 2, b // 2)]

    system = CholeskySystem(entries)
    keys = 2 * rng.choice(N, 12, replace=False)
    worst = fit = 0.0
    for k in range(80):
        if k % 20 == 19:
            keys = 2 * rng.choice(N, int(rng.integers(5, 40)), replace=False)
        else:
            out = rng.choice(len(keys), min(int(rng.integers(0, 4)), len(keys) - 1), replace=False)
            keys = np.delete(keys, out)
            fresh = np.setdiff1d(2 * np.arange(N), keys)
            keys = rng.permutation(np.concatenate([keys, rng.choice(fresh, int(rng.integers(0, 3)), replace=False)]))
        b = rng.normal(size=len(keys))
        M = entries(keys, keys)
        w = system.solve(keys, b)
        ref = np.linalg.solve(M, b)
        worst = max(worst, np.abs(w - ref).max() / (np.linalg.cond(M) * np.abs(ref).max()))
        own = entries(system.keys, system.keys)
        fit = max(fit, np.abs(system.U.T @ system.U - own).max() / np.abs(own).max())
        assert np.allclose(np.tril(system.U, -1), 0.0)
    assert system.updates > 40 and system.factorisations >= 4 and system.qr.Q is None      # the QR never used
    assert worst < 1e-13                                                  # measured <= 4.2e-16
    assert fit < 1e-12                                                    # measured <= 4.4e-16


@pytest.mark.numerics
def test_the_cholesky_interface_system_falls_back_on_the_qr_where_not_positive_definite():
    """Keys on which the matrix is indefinite (a negative pivot) or singular (two equal rows): the QR of
    :class:`UpdatedSystem` answers (the same numbers as an UpdatedSystem of its own), None where it is singular;
    back on positive definite keys the Cholesky factor answers again."""
    from cvxcontact.backends.finish import CholeskySystem

    rng = np.random.default_rng(5)
    N = 20
    X = rng.normal(size=(N, N))
    Mfull = X @ X.T + N * np.eye(N)
    Mfull[3, 3] = -Mfull[3, 3]                        # indefinite on keys holding row 3
    Mfull[7], Mfull[:, 7] = Mfull[8], Mfull[:, 8]     # rows 7 and 8 equal: singular on keys holding both

    def entries(a, b):
        return Mfull[np.ix_(a // 2, b // 2)]

    chol, qr = CholeskySystem(entries), UpdatedSystem(entries)
    b = rng.normal(size=6)
    indefinite = 2 * np.array([0, 1, 2, 3, 4, 5])
    w = chol.solve(indefinite, b)
    assert chol.U is None and np.array_equal(w, qr.solve(indefinite, b))
    assert np.abs(entries(indefinite, indefinite) @ w - b).max() < 1e-12 * np.abs(b).max()   # measured 1.2e-16
    assert chol.solve(2 * np.array([0, 1, 2, 7, 8, 9]), b) is None
    definite = 2 * np.array([0, 1, 2, 4, 5, 6])
    w = chol.solve(definite, b)
    assert chol.U is not None
    assert np.abs(w - np.linalg.solve(entries(definite, definite), b)).max() < 1e-12 * np.abs(w).max()  # 1.3e-16


@pytest.mark.numerics
def test_the_cholesky_interface_system_refuses_what_the_qr_refuses():
    """Gram matrices of unit rows with one nearly dependent pair (1 - cos^2 = e2 swept across the singularity
    cut): :class:`CholeskySystem` answers None exactly where :class:`UpdatedSystem` (the QR) does and otherwise
    solves like a dense solve. A bare 1e-13 cut on the Cholesky pivots accepted one e2 of this sweep
    (condition 4e13) that the QR refuses."""
    from cvxcontact.backends.finish import CholeskySystem

    rng = np.random.default_rng(7)
    refused = accepted = 0
    for e2 in np.geomspace(2e-14, 2e-12, 41):
        A = rng.normal(size=(12, 36))
        A /= np.linalg.norm(A, axis=1)[:, None]
        v = rng.normal(size=36)
        v -= (v @ A[0]) * A[0]
        A[1] = np.sqrt(1.0 - e2) * A[0] + np.sqrt(e2) * v / np.linalg.norm(v)
        M = A @ A.T

        def entries(a, b, M=M):
            return M[np.ix_(a // 2, b // 2)]

        keys = 2 * rng.permutation(12)
        b = rng.normal(size=12)
        w, ref = CholeskySystem(entries).solve(keys, b), UpdatedSystem(entries).solve(keys, b)
        assert (w is None) == (ref is None), e2
        if w is None:
            refused += 1
            continue
        accepted += 1
        Mk = entries(keys, keys)
        dense = np.linalg.solve(Mk, b)
        assert np.abs(w - dense).max() < 1e-12 * np.linalg.cond(Mk) * np.abs(dense).max()  # measured 1.6e-16
    assert refused >= 3 and accepted >= 3                 # the sweep crosses the cut (measured 5 and 36)


@pytest.mark.numerics
def test_the_cholesky_interface_system_keeps_its_factor_along_hundreds_of_deletions():
    """200 keys out one at a time (a key in every fifth step) from 280 keys of a symmetric positive definite
    matrix with eigenvalues spread by 1e8, with no fresh factorisation: the rank-one updates keep U^T U the
    matrix on the keys and each answer a dense solve's, and U a fresh Cholesky factor's."""
    import scipy.linalg as sla

    from cvxcontact.backends.finish import CholeskySystem

    rng = np.random.default_rng(13)
    N = 300
    Q = np.linalg.qr(rng.normal(size=(N, N)))[0]
    Mfull = (Q * np.logspace(0, 8, N)) @ Q.T
    Mfull = (Mfull + Mfull.T) / 2

    def entries(a, b):
        return Mfull[np.ix_(a // 2, b // 2)]

    system = CholeskySystem(entries)
    keys = 2 * rng.permutation(N)[:280]
    system.solve(keys, np.ones(len(keys)))
    worst = fit = 0.0
    for k in range(200):
        keys = np.delete(keys, rng.integers(len(keys)))
        if k % 5 == 0:
            keys = np.append(keys, rng.choice(np.setdiff1d(2 * np.arange(N), keys)))
        b = rng.normal(size=len(keys))
        M = entries(keys, keys)
        w, ref = system.solve(keys, b), np.linalg.solve(M, b)
        worst = max(worst, np.abs(w - ref).max() / (np.linalg.cond(M) * np.abs(ref).max()))
        own = entries(system.keys, system.keys)
        fit = max(fit, np.abs(system.U.T @ system.U - own).max() / np.abs(own).max())
    fresh = sla.cholesky(entries(system.keys, system.keys))
    assert system.factorisations == 1 and system.updates >= 190                  # measured 199
    assert worst < 1e-13 and fit < 1e-12                          # measured <= 2.8e-17, 2.3e-15
    assert np.abs(system.U - fresh).max() < 1e-11 * np.abs(fresh).max()  # measured <= 1.1e-14


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
    assert uniaxial_error(sol) < 1e-13                                          # measured 4.4e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-10                        # measured 1.1e-12 (λ_h's solve)
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] / P - 1).max() < 1e-12                 # measured 2.4e-14
    r = sol.residuals()
    assert r["equilibrium"] < 1e-14 and r["feasibility"] < 1e-14             # measured 1.6e-16, 8.3e-16


SCENES = {"stacked 5x5 on 7x3": stacked_blocks, "bumped": bumped_blocks, "three blocks": three_blocks,
          "punch on a patch": punch_on_pad, "two PZT blocks": piezo_pair,
          "two PZT blocks turned": lambda: piezo_pair(rotation())}


@pytest.mark.parametrize("purify", [False, True])
@pytest.mark.parametrize("name", list(SCENES))
def test_no_singular_matrix_is_factorised(name, purify, monkeypatch):
    """Every matrix the finish factorises is non-singular: the regularised bodies K0 of the factored steps,
    every system on the rows they solve (:class:`UpdatedSystem`; non-singular exactly when the mixed system
    (26) on those rows is, K0 being so) and any sparse mixed system (:func:`cvxcontact.backends.full.solve_mixed`,
    the check's fallback): its smallest singular value is far from rounding relative to the largest (dense SVD
    of each; the turned pair's faces are tilted, so its dependent rows are dependent only numerically). The
    answer is exact (ok at the default tol, no ResidualWarning). With and without the crossover start (few
    steps, many)."""
    seen = {"K0": [], "rows": [], "mixed": []}
    solve_mixed, factored_rows, solve = full.solve_mixed, finish.factored_rows, UpdatedSystem.solve

    def rcond(K):
        s = np.linalg.svd(K, compute_uv=False)
        return s[-1] / s[0] if len(s) else 1.0

    def recording(K, *args, **kwargs):
        seen["mixed"].append(rcond(K.toarray()))
        return solve_mixed(K, *args, **kwargs)

    def recording_K0(*args):
        out = factored_rows(*args)
        seen["K0"].append(rcond(out.K0.toarray()))
        return out

    def recording_rows(self, keys, b):
        seen["rows"].append(rcond(self.entries(np.asarray(keys), np.asarray(keys))))
        return solve(self, keys, b)

    monkeypatch.setattr(full, "solve_mixed", recording)
    monkeypatch.setattr(finish.dependent, "factored_rows", recording_K0)   # where the finish calls it
    original = signorini.independent_active_set
    monkeypatch.setattr(signorini, "independent_active_set",
                        lambda *args, **kwargs: original(*args, purify=purify, **kwargs))
    monkeypatch.setattr(UpdatedSystem, "solve", recording_rows)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(SCENES[name](), "gamma3", method="full")
    assert sol.ok and sol.polished and sol.info.finish == "independent active set"
    assert len(seen["K0"]) == 1 and seen["rows"]
    assert min(min(v) for v in seen.values() if v) > 1e-8                 # measured >= 9.1e-5 (K0 >= 2.3e-3)


@pytest.mark.parametrize("name", list(SCENES))
def test_the_factored_steps_agree_with_the_sparse_steps(name, monkeypatch):
    """From the same interior point: the finish that factorises the sparse mixed system at every step from the
    first independent rows (the finish without the crossover), the factored steps from the same rows (many
    steps: 39 on the stacked blocks) and the default (factored, from the crossover: 1-2 steps) give the same
    displacements and potentials (unique; the forces on dependent rows are not) to rounding."""
    runs = []
    original = signorini.independent_active_set

    def all_three(kkt, g, y0, start, **kwargs):
        outs = [original(kkt, g, y0, start, factored=f, purify=c, **kwargs)
                for f, c in ((False, False), (True, False), (True, True))]
        runs.append([kkt.stack(o[0]) for o in outs])
        return outs[-1]

    monkeypatch.setattr(signorini, "independent_active_set", all_three)
    sol = cc.solve(SCENES[name](), "gamma3", method="full")
    assert sol.ok and sol.polished and len(runs) == 1
    sparse_x = runs[0][0]
    for x in runs[0][1:]:
        assert np.abs(x - sparse_x).max() < 1e-12 * np.abs(sparse_x).max()   # measured <= 4.0e-15


def squeezed_blocks(lower=(5, 5), upper=(7, 3), overlap=1e-5):
    """:func:`stacked_blocks` with the upper block held by rollers on its top too and an interference
    ``overlap`` (m) between the faces (gap -overlap): every body held by its supports (the condensed route
    applies) and the uniaxial solution u_z = -overlap z below, overlap (1 - z) above, pressure c33 overlap."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=2)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=2)
    b1 = cc.Body(low, STEEL, roller=SIDES + ["bottom"], contact="top", name="lower")
    b2 = cc.Body(up, STEEL, roller=SIDES + ["top"], contact="bottom", name="upper")
    return cc.Scene(b1, b2, gap=-overlap)


def test_the_condensed_route_finishes_dependent_rows_like_the_full_route():
    """Both bodies held by their supports: the condensed route finishes the dependent gamma3 rows on the
    interface compliance W (singular) and agrees with the full route to rounding; both reproduce the
    uniaxial solution, and a re-solve from the previous active set (warm start) is exact too."""
    overlap = 1e-5
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        cond = cc.solve(squeezed_blocks(overlap=overlap), "gamma3", method="condensed")
        ref = cc.solve(squeezed_blocks(overlap=overlap), "gamma3", method="full")
    for sol in (cond, ref):
        assert sol.ok and sol.polished and sol.info.finish == "independent active set"
        exact = [-overlap * sol.points[0][:, 2], overlap * (1 - sol.points[1][:, 2])]
        assert max(np.abs(sol.u[k][:, 2] - exact[k]).max() for k in (0, 1)) < 1e-13 * overlap  # measured <= 5.4e-15
        assert np.abs(sol.contact.lam / (uniaxial_modulus() * overlap) - 1).max() < 1e-10  # measured <= 1.6e-12
    scale = max(np.abs(ref.u[k]).max() for k in (0, 1))
    assert max(np.abs(cond.u[k] - ref.u[k]).max() for k in (0, 1)) < 1e-12 * scale      # measured 9.3e-15
    solver = cc.ContactSolver(squeezed_blocks(overlap=overlap), "gamma3", method="condensed")
    solver.solve()
    again = solver.solve(squeezed_blocks(overlap=2 * overlap))
    assert again.ok and again.info.route == "active-set warm start"
    assert np.abs(again.contact.lam / (uniaxial_modulus() * 2 * overlap) - 1).max() < 1e-10   # measured 6.5e-12


def test_the_condensed_route_frees_the_interface_program_before_the_finish(monkeypatch):
    """The interface program's compiled data and Clarabel's solver (its KKT factors, kept by CVXPY for a warm
    re-solve of the same problem) are dropped once the interior point's answer is read: the finish of dependent
    rows runs without them (the largest stage of memory at scale). The program keeps its status, values and
    duals, a later solve of it compiles again to the same answer, and the route's answer is the full route's."""
    seen = []

    def finish(*args, **kwargs):
        seen.append([(p._cache.param_prog, dict(p._solver_cache)) for p in programs])
        return interface_finish(*args, **kwargs)

    programs, release, interface_finish = [], signorini.release, signorini.interface_finish
    monkeypatch.setattr(signorini, "release", lambda p: (programs.append(p), release(p)))
    monkeypatch.setattr(signorini, "interface_finish", finish)
    scene = squeezed_blocks(overlap=1e-5)
    sol = cc.solve(scene, "gamma3", method="condensed")
    ref = cc.solve(squeezed_blocks(overlap=1e-5), "gamma3", method="full")
    assert sol.ok and sol.polished and len(programs) == 1
    assert seen == [[(None, {})]]                            # nothing compiled or factorised kept at the finish
    program = programs[0]
    values = [v.value.copy() for v in program.variables()]
    duals = np.asarray(program.constraints[0].dual_value).copy()
    assert program.status == "optimal" and duals.max() > 0
    program.solve(solver="CLARABEL")                         # compiles again
    assert all(np.abs(v.value - w).max() <= 1e-8 * np.abs(w).max() for v, w in zip(program.variables(), values))
    scale = max(np.abs(ref.u[k]).max() for k in (0, 1))
    assert max(np.abs(sol.u[k] - ref.u[k]).max() for k in (0, 1)) < 1e-12 * scale


def test_the_default_route_of_dependent_rows_between_supported_bodies_is_finished():
    # P1 "gamma3" between two 3D bodies held by their supports, non-matching faces: the rows depend on each
    # other. `auto` used to take the sparse route (long interface), which had no dependent-row finish, and
    # raised SolverError; `auto` takes the condensed one (faster there), the AMG route refuses such rows and the
    # sparse route finishes them (a regularised stage, then Lawson-Hanson on the mixed system)
    import cvxcontact as cc
    from cvxcontact.errors import SolverError
    from scenes3d import STEEL, bumped_gap

    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=3, ny=3, nz=2)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=4, ny=2, nz=2)
    scene = cc.Scene(cc.Body(low, STEEL, clamped="bottom", contact="top", name="lower"),
                     cc.Body(up, STEEL, displacement={"top": (0.0, 0.0, -2e-5)}, contact="bottom", name="upper"),
                     gap=bumped_gap)
    sol = cc.solve(scene, "gamma3")
    assert sol.info.method == "condensed" and sol.ok and sol.polished
    full = cc.solve(scene, "gamma3", method="full")
    assert max(np.abs(a - b).max() for a, b in zip(sol.u, full.u)) < 1e-12 * max(np.abs(u).max() for u in full.u)
    with pytest.raises(SolverError, match="does not accept"):
        cc.solve(scene, "gamma3", method="amg")          # no dependent-row finish with Krylov solves (yet)
    sparse = cc.solve(scene, "gamma3", method="sparse")  # the sparse route's own finish of dependent rows
    assert sparse.ok and sparse.info.finish == "independent active set"
    assert max(np.abs(a - b).max() for a, b in zip(sparse.u, full.u)) < 1e-12 * max(np.abs(u).max() for u in full.u)


def test_dependent_rows_next_to_a_compliance_pair_are_finished():
    """Three blocks on non-matching faces pressed together by an interference at each pair (supported by
    rollers), a Signorini "gamma3" pair next to a compliance pair p = k r, either way up: uniaxial strain with
    the law in series, 2 delta = 3 p (1/3 m) / c33 + p / k, lambda = p on both pairs. Finished by Newton on
    the law around the finish of dependent rows (the interior point alone: lambda to 9.7e-10, complementarity
    1.08e-6, not ok at the default tol)."""
    from stack_scenes import DELTA3, three_blocks_3d

    k = 1e12
    p = 2 * DELTA3 / (1 / uniaxial_modulus() + 1 / k)
    c33 = uniaxial_modulus()
    law = cc.NormalCompliance(stiffness=k)
    for laws in ((cc.Signorini(), law), (law, cc.Signorini())):
        scene = three_blocks_3d(("gamma3", "gamma3"), laws)
        with warnings.catch_warnings():
            warnings.simplefilter("error", cc.ResidualWarning)
            sol = cc.solve(scene)
        assert sol.polished and sol.ok and sol.info.finish == "semismooth Newton on independent active sets"
        for c in sol.contacts:
            assert np.abs(c.lam / p - 1).max() < 1e-9                          # measured <= 5.8e-14
        # u_z: -p z / c33 in the lowest block, then the jump of each pair: 0 (Signorini) or -p / k (penetration)
        jumps = [0.0 if not law.compliant else p / k for law in laws]
        for b in range(3):
            exact = -p * sol.points[b][:, 2] / c33 + DELTA3 * b - sum(jumps[:b])
            assert np.abs(sol.u[b][:, 2] - exact).max() < 1e-12 * DELTA3          # measured <= 1.1e-15
        r = sol.residuals()
        assert r["equilibrium"] < 1e-14 and r["law"] < 1e-14 and r["feasibility"] < 1e-14   # measured <= 7.4e-16
        assert r["complementarity"] < 1e-12          # the slack's rounding taken off: measured 0 (1.36e-8 before)


def compliance_problem(seed, exponent):
    """Six unknowns (A SPD), three independent Signorini rows the unconstrained minimiser x_free violates and
    three non-negative combinations of them with constant slacks (most binding, as in
    :func:`test_dependent_rows_with_constant_slacks_against_every_active_set`), and three rows of a compliance
    law k r_+^m with weights w, some penetrating at x_free."""
    rng = np.random.default_rng(200 + seed)
    A, base, C = _dependent_rows(rng, 3)
    n = len(A)
    soft = rng.normal(size=(3, n))
    G = np.vstack([base, C @ base, soft])
    x_free = rng.normal(size=n) * 3
    g = np.concatenate([base @ x_free - rng.uniform(0.5, 2.0, size=3), np.zeros(3),
                        soft @ x_free - rng.uniform(-1.0, 1.5, size=3)])
    g[3:6] = C @ g[:3] - rng.uniform(-0.1, 0.5, size=3)
    law = cc.contact.laws.RowLaws([cc.Signorini(), cc.NormalCompliance(stiffness=5.0, exponent=exponent)], [6, 3])
    w = rng.uniform(0.5, 1.5, size=9)
    return A, A @ x_free, G, g, w, law, x_free


def enumerated_compliance(A, F, G, g, w, k):
    """The minimiser of 1/2 x^T A x - F^T x + sum_a w_a k/2 (r_a)_+^2 (the compliance rows 6-8) subject to
    r_a <= 0 (the Signorini rows 0-5), r = G x - g, by trying every set of closed Signorini rows with
    independent rows and every set of penetrating compliance rows (the law linear on each): the one whose
    forces are >= 0, every Signorini row feasible and every compliance row on the side it was taken on."""
    S, Cr = np.arange(6), np.arange(6, 9)
    for ks in range(7):
        for closed in itertools.combinations(S, ks):
            Gs = G[list(closed)]
            if ks and np.linalg.matrix_rank(Gs) < ks:
                continue
            for kp in range(4):
                for pen in itertools.combinations(Cr, kp):
                    Gp, D = G[list(pen)], w[list(pen)] * k
                    K = np.block([[A + Gp.T @ (D[:, None] * Gp), Gs.T], [Gs, np.zeros((ks, ks))]])
                    z = np.linalg.solve(K, np.concatenate([F + Gp.T @ (D * g[list(pen)]), g[list(closed)]]))
                    x, y = z[:6], z[6:]
                    r = G @ x - g
                    inside = np.isin(Cr, pen)
                    if ((y >= -1e-12).all() and (r[S] <= 1e-12).all() and (r[Cr][inside] >= -1e-12).all()
                            and (r[Cr][~inside] <= 1e-12).all()):
                        return x
    raise AssertionError("no active set solves the problem")


@pytest.mark.parametrize("seed", range(6))
def test_dependent_rows_next_to_a_linear_law_against_every_active_set(seed):
    """Dependent Signorini rows next to compliance rows (m = 1), from the unconstrained minimiser with no row
    closed and from every row closed: :func:`~cvxcontact.backends.compliance.dependent_newton` reaches the
    minimiser found by enumerating every set of closed and penetrating rows, its forces >= 0 on independent
    rows, stationary and feasible to rounding."""
    from cvxcontact.backends.compliance import dependent_newton

    A, F, G, g, w, law, x_free = compliance_problem(seed, 1.0)
    ref = enumerated_compliance(A, F, G, g, w, 5.0)
    for start in (np.zeros(9, dtype=bool), law.limited.copy()):
        out = dependent_newton(sp.csr_matrix(A), F, sp.csr_matrix(G), g, w, law, x_free, np.zeros(9), start)
        assert not isinstance(out, str), out
        x, y, z, at = out[:4]
        assert np.abs(x - ref).max() < 1e-12 * np.abs(ref).max()            # measured <= 9.3e-16
        assert (z >= 0).all() and (z[~at] == 0).all() and np.linalg.matrix_rank(G[at]) == at.sum()
        assert np.abs(A @ x + G.T @ y - F).max() < 1e-12 * np.abs(F).max()  # measured <= 1.4e-15
        assert ((G @ x - g)[:6] <= 1e-12 * np.abs(g).max()).all()            # measured <= 4.5e-16


@pytest.mark.parametrize("seed", range(6))
def test_dependent_rows_next_to_a_quadratic_law_satisfy_the_optimality_system(seed):
    """The same with the law k r_+^2 (m = 2): the optimality system of the strictly convex problem, checked by
    numpy, certifies the unique minimiser: A x + G^T y = F with y = w k r_+^2 + z to rounding, z >= 0 on
    independent rows, every Signorini row feasible and the rows carrying z closed."""
    from cvxcontact.backends.compliance import dependent_newton

    A, F, G, g, w, law, x_free = compliance_problem(seed, 2.0)
    out = dependent_newton(sp.csr_matrix(A), F, sp.csr_matrix(G), g, w, law, x_free, np.zeros(9), np.zeros(9, bool))
    assert not isinstance(out, str), out
    x, y, z, at, newton_steps = out[:5]
    r = G @ x - g
    law_force = np.where(np.arange(9) >= 6, w * 5.0 * np.maximum(r, 0.0) ** 2, 0.0)
    assert np.abs(y - law_force - z).max() <= 1e-13 * np.abs(y).max()        # measured <= 6.2e-15
    assert np.abs(A @ x + G.T @ y - F).max() < 1e-12 * np.abs(F).max()      # measured <= 2.4e-15
    assert (z >= 0).all() and (z[6:] == 0).all() and np.linalg.matrix_rank(G[at]) == at.sum()
    assert (r[:6] <= 1e-12 * np.abs(g).max()).all()                          # measured <= 3.8e-16
    assert np.abs(r[at]).max(initial=0.0) <= 1e-12 * np.abs(g).max()         # measured <= 3.8e-16
    assert newton_steps <= 12                                                 # measured 4-6


def _three_block_u_error(sol, p, jumps):
    """max |u_z - exact| / DELTA3 over the three blocks of :func:`stack_scenes.three_blocks_3d`: -p z / c33
    in the lowest, each block above shifted by the interference DELTA3 less the penetrations ``jumps`` of the
    pairs below it."""
    from stack_scenes import DELTA3

    c33 = uniaxial_modulus()
    return max(np.abs(sol.u[b][:, 2] - (-p * sol.points[b][:, 2] / c33 + DELTA3 * b - sum(jumps[:b]))).max()
               for b in range(3)) / DELTA3


def test_dependent_rows_next_to_a_quadratic_compliance_pair_are_finished():
    """The three blocks with the law p = k r^2 (k = 1e16 Pa/m^2) on one pair, Signorini "gamma3" on the other,
    either way up: 2 delta = p (1 m) / c33 + (p / k)^(1/2), solved for p by brentq (independent of the
    package); lambda = p on both pairs, the fields to rounding, the checks at rounding."""
    from scipy.optimize import brentq

    from stack_scenes import DELTA3, three_blocks_3d

    k, c33 = 1e16, uniaxial_modulus()
    p = brentq(lambda p: p / c33 + np.sqrt(p / k) - 2 * DELTA3, 0.0, 2 * DELTA3 * c33, xtol=1e-14, rtol=1e-15)
    law = cc.NormalCompliance(stiffness=k, exponent=2)
    for laws in ((cc.Signorini(), law), (law, cc.Signorini())):
        sol = cc.solve(three_blocks_3d(("gamma3", "gamma3"), laws))
        assert sol.ok and sol.polished and sol.info.finish == "semismooth Newton on independent active sets"
        assert max(np.abs(c.lam / p - 1).max() for c in sol.contacts) < 1e-9             # measured <= 5.1e-14
        jumps = [np.sqrt(p / k) if lw.compliant else 0.0 for lw in laws]
        assert _three_block_u_error(sol, p, jumps) < 1e-12                                # measured <= 1.7e-15
        r = sol.residuals()
        assert max(r["equilibrium"], r["law"], r["feasibility"]) < 1e-14                  # measured <= 7.3e-16


@pytest.mark.parametrize("k, lam_tol", [(1e12, 2e-8), (1e10, 2e-6)])
def test_dependent_rows_next_to_a_soft_quadratic_compliance_pair_are_finished(k, lam_tol):
    """The three blocks of the test above with a soft law (k = 1e12, 1e10 Pa/m^2: nearly all the interference
    2 delta is the law's penetration, p ~ 400 Pa, 4 Pa): the Newton steps on the law around the dependent rows
    settle at the rounding of each row (its rounding floor; the rows of nodes that do not move in a component
    read 7e-12 of their floored scale at a residual of 1e-25, and the backtracking then halved the rounding step:
    declined, lambda 2 % off, u 1.7e-7 of delta). p by brentq as above; lambda's error grows as p / (c33 delta)
    falls (the elastic forces' rounding of the blocks' shift), u to rounding either way."""
    from scipy.optimize import brentq
    from stack_scenes import DELTA3, three_blocks_3d

    c33 = uniaxial_modulus()
    p = brentq(lambda p: p / c33 + np.sqrt(p / k) - 2 * DELTA3, 0.0, 2 * DELTA3 * c33, xtol=1e-14, rtol=1e-15)
    law = cc.NormalCompliance(stiffness=k, exponent=2)
    for laws in ((cc.Signorini(), law), (law, cc.Signorini())):
        sol = cc.solve(three_blocks_3d(("gamma3", "gamma3"), laws))
        assert sol.ok and sol.polished and sol.info.finish == "semismooth Newton on independent active sets"
        # measured <= 1.5e-10 (k = 1e12), <= 1.3e-8 (k = 1e10) under the default, Prescott and Sandybridge kernels
        assert max(np.abs(c.lam / p - 1).max() for c in sol.contacts) < lam_tol
        jumps = [np.sqrt(p / k) if lw.compliant else 0.0 for lw in laws]
        assert _three_block_u_error(sol, p, jumps) < 1e-12                                # measured <= 1.7e-15
        r = sol.residuals()
        assert max(r["equilibrium"], r["law"], r["feasibility"]) < 1e-8                   # measured <= 5.3e-11


def test_dependent_limit_rows_of_a_compliance_pair_are_finished():
    """The three blocks with a compliance law p = k r whose penetration limit l (half the free penetration)
    binds, on non-matching faces: the limit rows depend on each other. Next to a Signorini pair, r = l and
    p = c33 (2 delta - l) / (1 m); on both pairs, p = c33 (2 delta - 2 l) / (1 m). lambda = p(r) + z as a
    pressure (the Riesz representer of the limit reactions in X_h: unique though they are not; z / w was
    off by 3.2 on the squeezed blocks below) on every pair, the fields to rounding."""
    from stack_scenes import DELTA3, three_blocks_3d

    k, c33 = 1e12, uniaxial_modulus()
    ell = 0.5 * 2 * DELTA3 / (1 / c33 + 1 / k) / k
    law = cc.NormalCompliance(stiffness=k, penetration_limit=ell)
    for laws in ((cc.Signorini(), law), (law, law)):
        sol = cc.solve(three_blocks_3d(("gamma3", "gamma3"), laws))
        jumps = [ell if lw.compliant else 0.0 for lw in laws]
        p = c33 * (2 * DELTA3 - sum(jumps))
        assert sol.ok and sol.polished and sol.info.finish == "semismooth Newton on independent active sets"
        assert max(np.abs(c.lam / p - 1).max() for c in sol.contacts) < 1e-9             # measured <= 7.8e-14
        assert _three_block_u_error(sol, p, jumps) < 1e-12                                # measured <= 3.0e-15
        r = sol.residuals()
        assert max(r["equilibrium"], r["law"], r["feasibility"]) < 1e-14                  # measured <= 2.2e-15


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_dependent_limit_rows_between_supported_bodies_are_finished(method):
    """Both bodies held by their supports (the interface route: W is singular on the dependent rows, so the
    finish runs on the sparse mixed system from the program's fields): the squeezed blocks through p = k r
    with a binding limit l, r = l, p = c33 (overlap - l) / (1 m), u_z = -p z / c33 below and
    overlap - l - p z / c33 above."""
    k, c33, overlap = 1e12, uniaxial_modulus(), 1e-5
    ell = 0.5 * overlap / (1 + k / c33)
    p = c33 * (overlap - ell)
    law = cc.NormalCompliance(stiffness=k, penetration_limit=ell)
    sol = cc.solve(squeezed_blocks(overlap=overlap), "gamma3", law=law, method=method)
    assert sol.info.method == method and sol.ok and sol.polished
    assert sol.info.finish == "semismooth Newton on independent active sets"
    assert np.abs(sol.contact.lam / p - 1).max() < 1e-10                                  # measured <= 4.7e-12
    exact = [-p * sol.points[0][:, 2] / c33, overlap - ell - p * sol.points[1][:, 2] / c33]
    assert max(np.abs(sol.u[i][:, 2] - exact[i]).max() for i in (0, 1)) < 1e-12 * overlap  # measured <= 9.8e-15


def bumped_stack(k=1e12, load=2e7):
    """Three blocks of height 1/3 m on (0, 1)^2 (rollers on their sides, the lowest on its base), the top one
    pressed by ``load`` (Pa) on a central square of its top, the gap :func:`bumped_gap` at both pairs: a
    Signorini "gamma3" pair on non-matching faces (5x5 below 4x4: dependent rows) under a compliance pair
    p = k r on matching faces (4x4 on 4x4); the middle and top blocks held by the contact only. Contact
    zones with edges inside the faces."""
    zs = (0.0, 1 / 3, 2 / 3, 1.0)
    press = lambda x, y, z: np.where((np.abs(x - .5) < .3) & (np.abs(y - .5) < .3), -load, 0.0)  # noqa: E731
    bodies = []
    for i, c in enumerate(((5, 5), (4, 4), (4, 4))):
        extra = dict(traction={"top": lambda x, y, z: (0 * x, 0 * x, press(x, y, z))}) if i == 2 else {}
        bodies.append(cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(zs[i], zs[i + 1]), nx=c[0], ny=c[1], nz=1), STEEL,
                              roller=SIDES + (["bottom"] if i == 0 else []), name=f"block {i}", **extra))
    pairs = [cc.Contact(bodies[0], "top", bodies[1], "bottom", condition="gamma3", gap=bumped_gap),
             cc.Contact(bodies[1], "top", bodies[2], "bottom", condition="gamma3", gap=bumped_gap,
                        law=cc.NormalCompliance(stiffness=k))]
    return cc.Scene(*bodies, contacts=pairs)


def test_dependent_rows_next_to_a_compliance_pair_against_a_dense_solve():
    """:func:`bumped_stack` against the independent dense reference (tests/reference3d.py: rows rebuilt by
    brute force): on the returned active set (the Signorini pair's closed rows, the compliance pair's
    penetrating rows), the dense mixed system with the law's stiffness w k G_P^T G_P and load w k G_P^T g_P
    added (w the lumped areas of the matching faces' triangles, computed here) is solved densely and
    certified: every Signorini row feasible, forces >= 0 on its closed rows balancing the bodies (nnls), each
    compliance row on the side it was taken on; the package's u and lambda agree with it to rounding."""
    from scipy.optimize import nnls

    from reference3d import Dense, face, match

    k = 1e12
    scene = bumped_stack(k)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(scene)
    assert sol.ok and sol.polished and sol.info.finish == "semismooth Newton on independent active sets"
    gap = lambda x: bumped_gap(x[:, 0], x[:, 1])                                          # noqa: E731
    ref = Dense(scene, "gamma3", gaps={0: gap, 1: gap})
    m0 = ref.counts[0]
    active, rows = [], []
    for i, c in enumerate(sol.contacts):
        on = np.flatnonzero(c.constrained)
        j = match(ref.points(i), c.points[on], 1e-9)
        active.append(c.active[on][j])
        rows.append(on[j])
    closed, pen = active
    assert 0 < closed.sum() < len(closed) and 0 < pen.sum() < len(pen)      # zones inside the faces: 40/133, 21/25
    f = face(scene, 1, "top")                              # the matching faces: X_h is this face's P1 space
    X = f.points[f.tri]
    area = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
    lumped = np.zeros(len(f.points))
    np.add.at(lumped, f.tri.ravel(), np.repeat(area / 3, 3))
    w = lumped[match(ref.points(1), f.points, 1e-9)]
    G1, g1 = ref.G[m0:], ref.g[m0:]
    D = np.where(pen, w * k, 0.0)
    ref.K = ref.K + G1.T @ (D[:, None] * G1)
    ref.b = ref.b + G1.T @ (D * g1)
    stacked = np.concatenate([closed, np.zeros(len(pen), dtype=bool)])
    ans = ref.solve_on(stacked)
    slack = ref.G @ ans.x - ref.g
    scale = max(float(np.abs(ref.g).max()), float((np.abs(ref.G) @ np.abs(ans.x)).max()))
    assert slack[:m0].max() < 1e-12 * scale                                          # measured 2.6e-16
    need = ref.b - ref.K @ ans.x
    _, unbalanced = nnls(ref.G[:m0][closed].T, need, maxiter=5000)
    assert unbalanced < 1e-12 * np.linalg.norm(need)                                # measured 5.1e-15
    r1 = slack[m0:]
    assert (r1[pen] > 0).all() and (r1[~pen] <= 1e-12 * scale).all()
    err = max(np.abs(a - b).max() for a, b in zip(sol.u, ans.u)) / max(np.abs(b).max() for b in ans.u)
    assert err < 1e-12                                                               # measured 2.8e-15
    lam = k * np.maximum(r1, 0.0)
    assert np.abs(sol.contacts[1].lam[rows[1]] - lam).max() < 1e-10 * lam.max()    # measured 6.8e-15


@pytest.mark.parametrize("name", ["squeezed", "squeezed, turned", "two PZT-5A-on-aluminium boxes",
                                  "two elastic boxes"])
def test_the_sparse_route_finishes_dependent_rows_like_the_condensed_and_full_routes(name):
    """P1 "gamma3" between two 3D bodies held by their supports, non-matching faces: the sparse route (a
    regularised stage on the quasi-definite mixed system, then Lawson-Hanson on the exact one, no interior point)
    agrees with the condensed route (interior point + the finish on W) and the full route (interior point + the
    finish on (26) by sparse LU) to rounding; on the squeezed blocks both give the uniaxial solution (the patch
    test of a uniform pressure through non-matching faces), also after a rotation of the whole scene."""
    from scenes3d import rotation, two_boxes

    overlap = 1e-5
    turned = "turned" in name
    if name.startswith("squeezed"):
        scene = squeezed_blocks(overlap=overlap)
        if turned:
            R = rotation()
            b1, b2 = scene.bodies
            scene = cc.Scene(*(cc.Body(b.mesh.with_points(b.mesh.points @ R.T), STEEL, roller=rollers,
                                       contact=face, name=b.name) for b, rollers, face in
                               ((b1, SIDES + ["bottom"], "top"), (b2, SIDES + ["top"], "bottom"))), gap=-overlap)
    else:
        scene = two_boxes(6, "gamma3", elastic="elastic" in name)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sols = {m: cc.solve(scene, "gamma3", method=m) for m in ("sparse", "condensed", "full")}
    sparse = sols["sparse"]
    assert sparse.ok and sparse.polished and sparse.info.finish == "independent active set"
    assert sparse.info.method == "sparse"
    scale = max(np.abs(u).max() for u in sols["full"].u)
    for other in ("condensed", "full"):
        # measured <= 8.8e-15 of the largest displacement (squeezed; PZT boxes 6.8e-15, elastic boxes 2.6e-15)
        assert max(np.abs(a - b).max() for a, b in zip(sparse.u, sols[other].u)) < 1e-12 * scale
        if sparse.phi[0] is not None:
            pscale = max(np.abs(p).max() for p in sols[other].phi if p is not None)
            assert max(np.abs(a - b).max() for a, b in zip(sparse.phi, sols[other].phi) if a is not None) \
                < 1e-12 * pscale
    if name.startswith("squeezed") and not turned:
        exact = [-overlap * sparse.points[0][:, 2], overlap * (1 - sparse.points[1][:, 2])]
        assert max(np.abs(sparse.u[k][:, 2] - exact[k]).max() for k in (0, 1)) < 1e-13 * overlap  # measured 2.0e-15
        assert np.abs(sparse.contact.lam / (uniaxial_modulus() * overlap) - 1).max() < 1e-10      # measured 6.6e-13


def test_a_sparse_re_solve_of_dependent_rows_is_exact():
    """A ContactSolver on the sparse route re-solves dependent rows from its previous regularised set (warm
    start) and reaches the uniaxial solution of the doubled interference exactly."""
    overlap = 1e-5
    solver = cc.ContactSolver(squeezed_blocks(overlap=overlap), "gamma3", method="sparse")
    solver.solve()
    again = solver.solve(squeezed_blocks(overlap=2 * overlap))
    assert again.ok and again.info.route == "active-set warm start"
    assert np.abs(again.contact.lam / (uniaxial_modulus() * 2 * overlap) - 1).max() < 1e-10   # measured 6.6e-13


@pytest.mark.parametrize("warm_steps", [0, None])
def test_a_gamma3_resolve_after_a_load_change_is_the_fresh_solve(monkeypatch, warm_steps):
    """A re-solve of "gamma3" between two boxes (dependent overlay rows, condensed route) after the body force
    changes by 1 %, 10 % and 30 %: the same answer as a fresh ContactSolver's, and the checks hold, whether the
    warm start from the previous forces finishes (its steps capped at WARM_STEPS) or gives way to the interface
    program (WARM_STEPS = 0: route "interior point + exact finish")."""
    if warm_steps is not None:
        monkeypatch.setattr(signorini, "WARM_STEPS", warm_steps)
    scene = two_boxes(12, "gamma3", elastic=True)
    solver = cc.ContactSolver(scene)
    solver.solve()
    routes = set()
    for f in (2.02e9, 2.2e9, 2.6e9):
        changed = scene.with_loads(1, body_force=(0.0, 0.0, -f))
        sol, fresh = solver.solve(changed), cc.solve(changed)
        assert sol.ok and fresh.ok
        routes.add(sol.info.route)
        if warm_steps == 0:
            assert sol.info.route == fresh.info.route
        ref = np.concatenate([np.ravel(u) for u in fresh.u])
        got = np.concatenate([np.ravel(u) for u in sol.u])
        assert np.abs(got - ref).max() < 1e-10 * np.abs(ref).max()          # measured <= 1e-14
    if warm_steps is None:                    # both ways taken (measured: 2 changes past the cap, 1 warm)
        assert routes == {fresh.info.route, cc.Route.WARM_START}


def test_the_gamma3_finish_from_the_start_chosen_by_groups_is_the_one_from_all_rows_at_once(monkeypatch):
    """"gamma3" between two elastic boxes (dependent overlay rows, condensed route): the finish's independent
    start chosen by groups of 16 neighbouring rows (:func:`~cvxcontact.backends.finish.rows.independent_rows`,
    the path of large interfaces) and by one pivoted QR of all the start's rows (groups larger than the rows)
    give the same answer to rounding, both checked; the grouped path ran and dropped rows."""
    from cvxcontact.backends.finish import rows as rows_module

    scene = two_boxes(12, "gamma3", elastic=True)
    monkeypatch.setattr(rows_module, "GROUP_ROWS", 10**9)
    whole = cc.solve(scene)
    seen, chosen_by = [], rows_module.independent_columns

    def spy(M, *args, **kwargs):
        seen.append(M.shape[1])
        return chosen_by(M, *args, **kwargs)

    monkeypatch.setattr(rows_module, "GROUP_ROWS", 16)
    monkeypatch.setattr(rows_module, "independent_columns", spy)
    grouped = cc.solve(scene)
    assert whole.ok and grouped.ok
    assert len(seen) > 3 and seen[-1] < sum(seen[:-1])  # groups, then the global QR on the rows kept (264 of 287)
    ref = np.concatenate([np.ravel(u) for u in whole.u])
    got = np.concatenate([np.ravel(u) for u in grouped.u])
    assert np.abs(got - ref).max() < 1e-10 * np.abs(ref).max()              # measured 5.0e-15
