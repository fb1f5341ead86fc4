"""The condensed route meets its closed rows to rounding of the fields (Condensation.invert_closed: one step of
iterative refinement after the exact finish), on the scene where the slack d - W y of those rows cancels terms
about 9e3 times the rows' displacement scale: the thin layer pressed onto its substrate (thin_layer(40)), which
the route read "not ok" before (closed rows met to 1.6e-11 U_a, complementarity 2.1e-6)."""

import warnings

import numpy as np
import pytest
from conftest import fields_agree, rel

import cvxcontact as cc
from cvxcontact.apps.demo import thin_layer
from cvxcontact.backends.factor import pardiso_available
from cvxcontact.backends.finish import closed_solve, solve_lcp
from cvxcontact.backends.finish.lcp import LastFactor

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


@pytest.fixture(scope="module")
def layer():
    return thin_layer(40)


FACTORIZATIONS = ["superlu"] + (["pardiso"] if pardiso_available() else [])

TOLERANCES = {"pardiso": (1e-10, 1e-9), "superlu": (3e-7, 1e-8)}
"""(u and phi, force) bounds against the sparse and full routes per factorisation of the bodies. Measured under
SkylakeX, Haswell, Sandybridge, Nehalem and Prescott (thin_layer(40)): PARDISO u <= 3.8e-13, force <= 1.4e-12;
SuperLU u 9.4e-11 .. 1.73e-9, phi <= 4.7e-11, force <= 3.5e-11 (the refinement meets the closed rows; the layer's
interior keeps SuperLU's Schur complement's rounding): >= 170x each."""


@pytest.fixture(scope="module", params=FACTORIZATIONS)
def condensed(layer, request):
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)         # the answer must pass its own checks
        return cc.ContactSolver(layer, method="condensed", factorization=request.param).solve()


def test_condensed_thin_layer_is_ok_and_agrees_with_a_dense_solve_and_the_full_route(layer, condensed):
    assert condensed.ok and condensed.polished and condensed.info.method == "condensed"
    # the closed rows' slack over U_a, read by the checks (measured 5.0e-17 feasibility, 6.3e-9 complementarity,
    # the same as the full route's; before: 5.6e-12 and 2.1e-6)
    assert condensed.residuals()["feasibility"] < 1e-14
    # against the sparse route (active-set steps on the sparse mixed system (26): no condensation, no W) and the
    # full route (its finish solves (26) on the active set): the same active set, u, phi and force within
    # TOLERANCES (measured there; before the refinement, PARDISO: u 4.0e-11, force 3.3e-10 from its own new answer)
    tol, force_tol = TOLERANCES[condensed.info.factorization]
    fields_agree(condensed, cc.solve(layer, method="sparse"), tol, force_tol=force_tol)
    fields_agree(condensed, cc.solve(layer, method="full"), tol, force_tol=force_tol)

def test_closed_solve_matches_a_dense_solve_with_and_without_the_kept_factor():
    rng = np.random.default_rng(3)
    M = rng.standard_normal((12, 12))
    scale = np.logspace(0, 6, 12)                                  # rows of very different compliances
    W = scale[:, None] * (M @ M.T + 12 * np.eye(12)) * scale[None, :]
    W.flags.writeable = False                                      # as Compliance.W: a factor may be kept
    d = W @ np.where(np.arange(12) % 3 == 0, -1.0, 1.0) / scale ** 2
    kept = LastFactor()
    _, active, _ = solve_lcp(W, d, kept=kept)
    assert 0 < active.sum() < 12 and kept.get(active) is not None
    r = rng.standard_normal(12)
    at = np.flatnonzero(active)
    ref = np.zeros(12)
    ref[at] = np.linalg.solve(W[np.ix_(at, at)], r[at])
    for z in (closed_solve(W, r, active, kept), closed_solve(W, r, active)):
        assert rel(z, ref) < 1e-12 and not z[~active].any()
    assert not closed_solve(W, r, np.zeros(12, dtype=bool)).any()
    with pytest.raises(np.linalg.LinAlgError):
        closed_solve(np.array([[1.0, 2.0], [2.0, 1.0]]), np.ones(2), np.ones(2, dtype=bool))   # indefinite


def test_closed_solve_of_repeated_rows_is_the_least_norm_solution():
    """Two closed rows that repeat each other (a node two coinciding obstacles both hold): W_AA singular, positive
    semi-definite. A consistent slack is met (W z = r) and split evenly between the two (the least-norm solution of
    the equilibrated system), under every kernel set; the Cholesky factor failed there with a LinAlgError under
    OPENBLAS_CORETYPE=Haswell and Nehalem (tests/test_p2_line_reach_hole.py)."""
    rng = np.random.default_rng(5)
    B = rng.standard_normal((5, 8)) * np.logspace(0, 3, 5)[:, None]
    B = np.vstack([B[:1], B])                                      # row 0 repeated as row 1
    W = B @ B.T
    r = W @ rng.standard_normal(6)
    z = closed_solve(W, r, np.ones(6, dtype=bool))
    assert rel(W @ z, r) < 1e-12                                   # measured <= 1.6e-15 (five kernel sets)
    assert abs(z[0] - z[1]) <= 1e-11 * np.abs(z).max()            # measured <= 3.5e-14
    ref = np.linalg.solve(W[1:, 1:], r[1:])                        # the rows merged: unique, its row 0 the sum
    assert rel(np.concatenate([[z[0] + z[1]], z[2:]]), ref) < 1e-10                # measured <= 1.3e-13
