"""The fields behind the estimate on quadrilaterals and hexahedra (cvxcontact/solution/tensorestimate.py), formed
from the reference gradients with one matrix product per rule point, against the element's own route
(``TensorElement.at_points``: the physical gradients and second derivatives of every shape function, the strain
matrices of fem/assembly.py) on warped piezoelectric cells; the facets' grouped evaluation against the point by
point one; the closed-form Jacobian inverses against LAPACK."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem.assembly import strain_matrix
from cvxcontact.fem.quad import inverse
from cvxcontact.solution import contactestimate as contact
from cvxcontact.solution.tensorestimate import TensorGeometry

pytestmark = pytest.mark.numerics


def _warped_body(cell, n=3, seed=0):
    """A PZT-5A rectangle or box of n cells a side, its interior nodes moved by up to 0.15 of a cell."""
    mesh = cc.rectangle(nx=n, ny=n, cell="quad") if cell == "quad" else cc.box(nx=n, ny=n, nz=n, cell="hex")
    p = mesh.points.copy()
    inner = np.setdiff1d(np.arange(len(p)), mesh.boundary_nodes(mesh.tags))
    p[inner] += np.random.default_rng(seed).uniform(-0.15, 0.15, (len(inner), p.shape[1])) / n
    return cc.Body(mesh.with_points(p), cc.materials.PZT5A, clamped=["left"], grounded=["left"])


def _state(g, seed=1):
    """Random nodal u (m) and phi (V) of the body's Q1/Q2 space, at the scales of a solution."""
    n = g.el.max() + 1
    rng = np.random.default_rng(seed)
    return rng.standard_normal((n, g.dim)) * 1e-5, rng.standard_normal(n) * 50.0


def _by_the_element(g, cells, xi, u, phi):
    """The fields as the element forms them (independent of the estimate's evaluation): strains through the strain
    matrices, div sigma and div D from the physical second derivatives of every shape function."""
    c, e, kappa = g.tensors
    x, G, det, inv_T, H = g.element.at_points(g.corners[cells], xi, second=True)
    k, dim = len(x), g.dim
    ue = u[g.el[cells]].reshape(k, -1)
    pe = phi[g.el[cells]]
    eps = np.einsum("msj,mj->ms", strain_matrix(G), ue)
    gphi = np.einsum("mdk,mk->md", G, pe)
    sigma = eps @ c.T + gphi @ e
    D = eps @ e.T - gphi @ kappa.T
    div, divD = np.zeros((k, dim)), np.zeros(k)
    for j in range(dim):
        Hj = H[:, :, j, :]
        deps = np.einsum("msj,mj->ms", strain_matrix(Hj), ue)
        dg = np.einsum("mdk,mk->md", Hj, pe)
        div += contact.voigt_tensor(deps @ c.T + dg @ e)[:, :, j]
        divD += (deps @ e.T - dg @ kappa.T)[:, j]
    return x, det, inv_T, eps, gphi, sigma, D, div, divD


@pytest.mark.parametrize("cell", ["quad", "hex"])
@pytest.mark.parametrize("degree", [1, 2])
def test_the_fields_are_the_elements_at_points_of_warped_piezoelectric_cells(cell, degree):
    """x, det J, J^-T, eps, grad phi, sigma, D, div sigma and div D at random points of every warped cell, one
    point per cell and one point shared by all (the rules' case), equal the element's route to rounding: each
    field against its own largest value (measured <= 2.0e-15, div D of Q1; bound 1e-12)."""
    body = _warped_body(cell)
    g = TensorGeometry(body, degree)
    u, phi = _state(g)
    m, dim = len(g.el), g.dim
    rng = np.random.default_rng(3)
    cells = np.arange(m)
    for xi in (rng.uniform(-1, 1, (m, dim)), np.broadcast_to(rng.uniform(-1, 1, dim), (m, dim))):
        new = g.fields(cells, xi, u, phi, second=True)
        ref = _by_the_element(g, cells, np.array(xi), u, phi)
        for name, a, b in zip(("x", "det", "inv_T", "eps", "gphi", "sigma", "D", "div", "divD"), new, ref):
            assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max(), name
        shared = g._fields_of(g._evaluate(g._corners_T, g._nodal(u, phi), g._basis(np.array(xi[:1]), True)))
        if np.ptp(xi, axis=0).max() == 0:                      # one point for all: the single matrix product
            for name, a, b in zip(("x", "det", "inv_T", "eps", "gphi", "sigma", "D", "div", "divD"), shared, ref):
                assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max(), name


@pytest.mark.parametrize("cell", ["quad", "hex"])
@pytest.mark.parametrize("degree", [1, 2])
def test_the_facets_grouped_evaluation_is_the_pointwise_one(cell, degree):
    """The facet terms' fields, evaluated per group of facets placed alike in their cells, equal the fields at
    each facet's own points (``fields``, one point per facet) in both its cells, and n da / dA is Nanson's
    det J J^-T N (N the reference face's unit normal) from the element's route: to rounding (measured <= 1.2e-15
    relative; bound 1e-12); and the two sides of an interior facet are at the same physical points."""
    body = _warped_body(cell)
    g = TensorGeometry(body, degree)
    u, phi = _state(g)
    W = g._nodal(u, phi)
    owners, pos0, pos1, _, _ = g.facets
    ii = np.flatnonzero(owners[:, 1] >= 0)
    Wq, _ = g.element.face_rule(g.n)
    corners = g.element.corners
    sides = ((owners[:, 0], pos0), (owners[ii, 1], pos1[ii]))
    for cells, pos in sides:
        assert len(np.unique(pos, axis=0)) > 1                 # several groups
        for q, (_, x, nda, eps, gphi, sigma, D) in enumerate(g._facet_points(cells, pos, W)):
            xi = Wq[q] @ corners[pos]
            ref = _by_the_element(g, cells, xi, u, phi)
            nanson = ref[1][:, None] * np.einsum("fij,fj->fi", ref[2], corners[pos].mean(axis=1))
            for a, b in ((x, ref[0]), (nda, nanson), (eps, ref[3]), (gphi, ref[4]), (sigma, ref[5]), (D, ref[6])):
                assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    x0 = [x[ii] for _, x, *_ in g._facet_points(*sides[0], W)]
    x1 = [x for _, x, *_ in g._facet_points(*sides[1], W)]
    assert max(np.abs(a - b).max() for a, b in zip(x0, x1)) <= 1e-12


@pytest.mark.parametrize("dim", [2, 3])
def test_the_closed_form_inverse_is_lapacks(dim):
    """det and inverse of random Jacobian-like matrices (condition numbers up to ~1e2) by the adjugate equal
    numpy's (LAPACK) to rounding (measured <= 6.2e-16 relative; bound 1e-12), and A A^-1 = I (measured 1.8e-16)."""
    rng = np.random.default_rng(4)
    A = np.eye(dim) + 0.4 * rng.standard_normal((500, dim, dim))
    A = A[np.abs(np.linalg.det(A)) > 0.05]
    det, inv = inverse(A)
    assert np.abs(det - np.linalg.det(A)).max() <= 1e-12 * np.abs(det).max()
    ref = np.linalg.inv(A)
    assert np.abs(inv - ref).max() <= 1e-12 * np.abs(ref).max()
    assert np.abs(A @ inv - np.eye(dim)).max() <= 1e-12 * np.abs(ref).max()
