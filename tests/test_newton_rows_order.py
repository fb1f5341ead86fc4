"""The fast route's Newton steps (cvxcontact.backends.nonlinear) on contact rows whose sparse arrays come with
unsorted column indices, as P2 nodal rows between non-matching meshes do: each step solves the system of the rows
it was given, whatever the caller does to G's arrays afterwards (scipy's ``abs(G)`` sorts them in place), and a
Hencky block that never yields answers as the linear material solved by the linear routes (an independent
reference) and as the full route. Before, the steps solved rows scrambled by that sort and stopped on their own
solve's residual: a wrong answer labelled NEWTON_DIRECT (equilibrium 0.11)."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import rel, two_blocks

import cvxcontact as cc
from cvxcontact.backends.factor import pardiso_available
from cvxcontact.backends.nonlinear import TangentSolver

pytestmark = pytest.mark.numerics

NEVER = cc.materials.hencky(E=70e9, nu=0.3, sigma_y=1e15, h=0.1)     # a yield stress no strain here reaches
LINEAR = cc.materials.isotropic(E=70e9, nu=0.3)
SAME = 1e-10        # both exact answers of one linear problem: measured <= 5.1e-14 (u, phi, pressure)


def unsorted_rows(n):
    """Three contact rows on n unknowns, each with its columns in decreasing order (not canonical)."""
    cols = [np.array([n - 1, 3, 0]), np.array([n - 2, n - 3, 5, 1]), np.array([7, 2])]
    data = [np.array([0.5, -1.0, 0.25]), np.array([1.0, 0.75, -0.5, 0.125]), np.array([-0.3, 1.0])]
    indptr = np.concatenate([[0], np.cumsum([len(c) for c in cols])])
    G = sp.csr_matrix((np.concatenate(data), np.concatenate(cols), indptr), shape=(3, n))
    G.has_sorted_indices = False
    return G


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_the_tangent_solver_solves_the_rows_it_was_given_after_the_caller_sorts_them(factorization):
    """The system [[K, G_L^T], [G_L, 0]] for the rows as given, after the caller sorted G's arrays in place (as
    ``abs(G)`` does): the dense solve of the same system to rounding. Measured 2.3e-16 (SuperLU), 3.4e-16
    (PARDISO); before: 0.74, the couplings' values permuted within their rows."""
    if factorization == "pardiso" and not pardiso_available():
        pytest.skip("PARDISO (mkl) not installed")
    n = 12
    rng = np.random.default_rng(5)
    lap = sp.diags([-np.ones(n - 1), 3 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    K = (lap + sp.diags(rng.random(n))).tocsr()
    G = unsorted_rows(n)
    dense_G = G.toarray()
    solver = TangentSolver(sp.csr_matrix(abs(K) > 0, dtype=float), G, factorization)
    G.sort_indices()                                   # the caller's in-place sort, after the solver was built
    assert np.array_equal(G.toarray(), dense_G)        # the same matrix, its arrays permuted
    at = np.array([True, False, True])
    b = rng.normal(size=n + int(at.sum()))
    GL = dense_G[at]
    A = np.block([[K.toarray(), GL.T], [GL, np.zeros((len(GL), len(GL)))]])
    s = solver(K, b, at)
    assert s is not None
    assert rel(s, np.linalg.solve(A, b)) <= 1e-12, rel(s, np.linalg.solve(A, b))


def solved(scene, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        return cc.solve(scene, estimate=False, **kw)


def assert_same(sol, ref, tol=SAME):
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) <= tol, rel(a, b)
    for a, b in zip(sol.phi, ref.phi):
        if b is not None:
            assert rel(a, b) <= tol, rel(a, b)
    assert rel(sol.contact.pressure, ref.contact.pressure) <= tol
    assert np.array_equal(sol.contact.active, ref.contact.active)


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
@pytest.mark.parametrize("upper", ["piezoelectric", "elastic"])
def test_a_block_that_never_yields_on_p2_rows_of_non_matching_meshes_is_the_linear_answer(condition, upper):
    """P2 nodal rows between non-matching meshes (16 x 8 and 11 x 6 cells), the lower block Hencky with a yield
    stress no strain reaches, so that its (26) is the linear material's: ``auto`` takes the fast route and answers
    directly, checked (sol.ok), as the linear material solved by the linear routes (the condensed route's
    active-set finish, an independent code path) and as the full route, to rounding."""
    mat1 = cc.materials.PZT5A if upper == "piezoelectric" else cc.materials.isotropic(E=200e9, nu=0.3)
    kw = {"degree": 2, "condition": condition}
    fast = solved(two_blocks(mat1=mat1, mat2=NEVER), **kw)
    assert fast.info.route == cc.Route.NEWTON_DIRECT and fast.ok, (fast.info.route, fast.residuals())
    linear = solved(two_blocks(mat1=mat1, mat2=LINEAR), **kw)
    assert linear.info.method != "newton" and linear.ok
    full = solved(two_blocks(mat1=mat1, mat2=NEVER), method="full", **kw)
    assert full.ok
    assert fast.contact.active.sum() > 0
    assert_same(fast, linear)
    assert_same(full, linear)
