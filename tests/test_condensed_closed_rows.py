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

SWEEP_BOUNDS = {"pardiso": 2e-12, "superlu": 2e-7}
"""u and phi of Condensation.invert_closed against the refinement as it was (the correction solved by S^{-1}), per
factorisation of the bodies, thin_layer(40) re-solved at 1.3 MPa. Measured under the default, Haswell, Nehalem,
Prescott and Sandybridge kernels: PARDISO u 2.9e-16 .. 5.8e-16, phi 6.8e-15 .. 1.07e-14; SuperLU u 3.5e-10 ..
1.20e-9, phi 1.2e-11 .. 3.1e-11 (Sigma's rounding on the layer, which the backward sweep reads; default kernels:
against the sparse route 1.46e-9 now, 2.40e-9 before, equilibrium 3.0e-10 now, 5.0e-10 before): >= 160x."""


@pytest.mark.parametrize("factorization", FACTORIZATIONS)
def test_invert_closed_sweeps_each_body_once_and_keeps_the_answer_of_the_solve_of_the_correction(
        monkeypatch, layer, factorization):
    """Condensation.invert_closed takes the closed rows' slack from the Gamma values of the fields and applies the
    correction -Sigma^{-1} J^T E^T dy to them before the one backward sweep per body (its right-hand side lies on
    the Gamma dofs: its forward sweep is itself). Against the refinement as it was (the fields' backward sweep,
    then S^{-1} of the correction by a forward and a backward sweep per body), on the same inputs, in a re-solve of
    thin_layer(40): the same forces bit for bit (the same slack, the same dy), u and phi within SWEEP_BOUNDS, the
    closed rows met as before (feasibility < 1e-14), the fields within TOLERANCES of the sparse route; one backward
    sweep per body and no forward sweep inside it (before: two backward, one forward)."""
    from cvxcontact.backends import interface as im

    solver = cc.ContactSolver(layer, method="condensed", factorization=factorization)
    solver.solve()
    new, seen = im.Condensation.invert_closed, []

    def reference(self, problem, y, active):
        E, g = problem.E, problem.g
        x = [c.back_substitute(f, E.T @ y) for c, f in zip(self.bodies, self.sweeps)]
        slack = sum(R @ xk[c.gamma] for R, xk, c in zip(self.compliance.rows, x, self.bodies)) - g
        dy = closed_solve(self.compliance.W, slack, np.asarray(active, dtype=bool), self.compliance.last_factor)
        x = [xk - c.solve(c.lift(E.T @ dy)) for xk, c in zip(x, self.bodies)]
        return (*im.split(self.bodies, x, problem.blocks), y + dy)

    def spy(self, problem, y, active, timings):
        calls = []
        for c in self.bodies:
            for name in ("forward", "backward"):
                orig = getattr(c.factor, name)
                monkeypatch.setattr(c.factor, name, lambda *a, orig=orig, name=name: calls.append(name) or orig(*a))
        out = new(self, problem, y, active, timings)
        for c in self.bodies:
            monkeypatch.delattr(c.factor, "forward")
            monkeypatch.delattr(c.factor, "backward")
        seen.append((out, reference(self, problem, y, active), calls, len(self.bodies)))
        return out

    monkeypatch.setattr(im.Condensation, "invert_closed", spy)
    again = solver.solve(thin_layer(40, pressure=1.3e6))            # the same geometry, another load case
    assert again.ok and again.polished and again.residuals()["feasibility"] < 1e-14 and len(seen) == 1
    (u, phi, y), (u0, phi0, y0), calls, bodies = seen[0]
    assert np.array_equal(y, y0) and y.any()
    bound = SWEEP_BOUNDS[factorization]
    assert rel(np.concatenate(u), np.concatenate(u0)) < bound
    phis = [np.concatenate([p for p in f if p is not None]) for f in (phi, phi0)]
    assert rel(*phis) < bound
    tol, force_tol = TOLERANCES[factorization]                     # and against the sparse route, as above
    fields_agree(again, cc.solve(thin_layer(40, pressure=1.3e6), method="sparse"), tol, force_tol=force_tol)
    assert calls.count("backward") == bodies and "forward" not in calls
