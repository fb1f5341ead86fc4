"""The fast Hencky route's factorisations in single precision (:data:`cvxcontact.backends.nonlinear.SINGLE`,
:class:`~cvxcontact.backends.factor.PardisoSymmetric`'s ``single``), refined against the systems in double: the same
answer as double-precision factors and as the full route (interior point + Newton finish, the reference), one
analysis; a single factor that does not refine to its accuracy hands the steps to double precision; SuperLU stays in
double. Tolerances: 100x the measured values (beside them)."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from conftest import rel
from hencky_scenes import EXACT, NU, SIGMA_Y, E, H, indented

import cvxcontact as cc
from cvxcontact.backends import nonlinear
from cvxcontact.backends.factor import PardisoSymmetric, pardiso_available
from cvxcontact.backends.mixed import mixed_system

pytestmark = [pytest.mark.numerics,
              pytest.mark.skipif(not pardiso_available(), reason="single-precision factors are PARDISO's")]

HENCKY = cc.materials.hencky(E, NU, SIGMA_Y, H)
SCENES = {"P1": ({"nx": 48, "ny": 16}, {}), "P2": ({"nx": 16, "ny": 6}, {"degree": 2, "condition": "sigma1"})}


def fast(scene, **kw):
    """(solution, tangent solver) of the fast route (``method="auto"``, asserted "newton" and finished)."""
    solver = cc.ContactSolver(scene, estimate=False, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = solver.solve()
    assert sol.info.method == "newton" and sol.info.route == cc.Route.NEWTON_DIRECT, sol.info
    assert sol.ok and sol.residuals()["equilibrium"] < EXACT, sol.report()
    return sol, solver.cache.own["newton"]


def same(a, b, tol):
    for x, y in zip(a.u, b.u):
        assert rel(x, y) < tol
    assert rel(a.contact.lam, b.contact.lam) < tol


@pytest.mark.parametrize("case", sorted(SCENES))
def test_single_precision_factors_give_the_answer_of_double_ones_and_of_the_full_route(monkeypatch, case):
    """The steps factorised in single precision and refined in double end where steps factorised in double do
    (SINGLE = False), and both where the full route ends; the single run keeps its one analysis (no step fell back
    to double) and its factorisations are single-precision ones."""
    mesh, kw = SCENES[case]
    scene = indented(HENCKY, depth=5e-3, **mesh)
    single, tangent = fast(scene, **kw)
    assert tangent.single and not tangent.doubled and tangent.analyses == 1 and tangent._pardiso.single
    monkeypatch.setattr(nonlinear, "SINGLE", False)
    double, reference = fast(scene, **kw)
    assert not reference.single and not reference._pardiso.single
    same(single, double, 1e-11)         # measured 3.6e-16 (u), 6.4e-16 (forces) P1; 6.5e-16, 6.6e-16 P2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        full = cc.solve(scene, estimate=False, method="full", **kw)
    assert full.info.method == "full" and full.ok
    same(single, full, 1e-11)           # measured 3.6e-16 (u), 3.6e-16 (forces) P1; 7.8e-16, 3.6e-16 P2


def test_a_single_factor_that_does_not_refine_hands_the_steps_to_double_precision(monkeypatch):
    """With no refinement allowed on a single-precision factor (SINGLE_REFINE = 0) the first step whose answer is
    asked to rounding is factorised again in double (a second analysis), and so is every later one: the answer is
    that of double-precision factors throughout."""
    scene = indented(HENCKY, nx=48, ny=16, depth=5e-3)
    monkeypatch.setattr(nonlinear, "SINGLE_REFINE", 0)
    handed, tangent = fast(scene)
    assert tangent.doubled and not tangent.single and tangent.analyses == 2 and not tangent._pardiso.single
    monkeypatch.setattr(nonlinear, "SINGLE", False)
    double, reference = fast(scene)
    assert not reference.doubled and reference.analyses == 1
    same(handed, double, 1e-11)         # measured 0 (u and forces: the first step, asked to rounding, handed over)


def test_superlu_factors_stay_in_double_precision():
    _, tangent = fast(indented(HENCKY, nx=24, ny=8, depth=5e-3), factorization="superlu")
    assert tangent.kind == "superlu" and not tangent.single and tangent._pardiso is None


def test_a_single_precision_factor_solves_to_its_precision_and_refines_to_rounding():
    """PardisoSymmetric(single=True) on a step's system of the route (the elastic tangent with the closed rows):
    one solve within float32's reach of SuperLU's answer in double, and refined against the matrix in double to
    rounding in a few steps."""
    scene = indented(HENCKY, nx=48, ny=16, depth=5e-3)
    solver = cc.ContactSolver(scene, estimate=False)
    op, G, _ = mixed_system(solver.problem)
    closed = np.asarray(solver.problem.g) < 0
    tangent = nonlinear.TangentSolver(op.pattern(), G)
    K, _ = op.linearised(np.zeros(G.shape[1]))
    M = tangent.matrix(K, closed)
    b = M @ np.random.default_rng(0).standard_normal(M.shape[0])
    factor = PardisoSymmetric(M, single=True).factor(M)
    assert factor.single and factor.perturbed == 0
    z = factor.solve(b)
    assert z.dtype == np.float64
    reference = spla.spsolve(sp.csc_matrix(M), b)
    assert rel(z, reference) < 1e-3                             # measured 2.7e-6 (float32's 6e-8 and conditioning)
    history = []
    for _ in range(6):
        r = b - M @ z
        history.append(np.linalg.norm(r) / np.linalg.norm(b))
        z = z + factor.solve(r)
    assert history[0] < 1e-5 and min(history) < 1e-13           # measured 9.1e-8, 1.8e-13, 1.6e-16, ...
    assert rel(z, reference) < 1e-12                            # measured 5.5e-15


def test_a_single_factorisation_that_fails_hands_the_steps_to_double_precision(monkeypatch):
    """A single-precision numeric factorisation that PARDISO refuses (a SolverError, forced here on the first one)
    is done again in double, and the steps go on in double: the answer of double-precision factors."""
    scene = indented(HENCKY, nx=24, ny=8, depth=5e-3)
    factor = PardisoSymmetric.factor

    def refused(self, K):
        if self.single:
            raise cc.SolverError("refused (the test's)")
        return factor(self, K)

    monkeypatch.setattr(PardisoSymmetric, "factor", refused)
    handed, tangent = fast(scene)
    assert tangent.doubled and not tangent.single and tangent.analyses == 2
    monkeypatch.setattr(nonlinear, "SINGLE", False)
    double, _ = fast(scene)
    same(handed, double, 1e-11)         # measured 0 (u and forces: every step in double)
