"""What a re-solve reads in another layout or keeps per geometry since h-resolve3: the estimate's strains and
potential gradients from the shape gradients and the element dofs kept component-major
(fem.assembly.voigt_strain_rows, gradient_rows, estimate.Geometry.rows) and the held rows a load case of the same
contact rows shares with the one before (discrete.problem._derive). The oracles: voigt_strains (the einsum over
strided columns, the numbers before), the strain matrices' products, grad phi's einsum on the (m, q, d, k)
gradients, held_rows formed afresh, and the estimate without a kept Geometry."""

import numpy as np
import pytest
from conftest import rel, two_blocks

import cvxcontact as cc
from cvxcontact.discrete.problem import held_rows
from cvxcontact.fem.assembly import (
    gradient_rows,
    gradients,
    strain_matrix,
    voigt_strain_rows,
    voigt_strains,
)
from cvxcontact.fem.space import space
from cvxcontact.solution import estimate as est

pytestmark = pytest.mark.numerics

ALU = cc.materials.isotropic(E=70e9, nu=0.3, name="aluminium")


@pytest.mark.parametrize("dim, k", [(2, 3), (2, 6), (3, 4), (3, 10)])
def test_strain_rows_are_voigt_strains_bit_for_bit(dim, k):
    """Random gradients and displacements (P1 and P2 in 2D and 3D): the same numbers as voigt_strains (each sum in
    node order from the first product, as its einsum over strided columns sums: array_equal), and the strain
    matrices' products to rounding (measured: 2D identical, 3D 7e-16 relative; asserted 1e-13)."""
    rng = np.random.default_rng(dim * 10 + k)
    grad = rng.standard_normal((500, dim, k))
    ue = rng.standard_normal((500, dim * k))
    rows = voigt_strain_rows(np.ascontiguousarray(grad.transpose(1, 2, 0)),
                             np.ascontiguousarray(ue.reshape(500, k, dim).transpose(1, 2, 0)))
    assert np.array_equal(rows.T, voigt_strains(grad, ue))
    assert rel(rows.T, np.einsum("mij,mj->mi", strain_matrix(grad), ue)) < 1e-13


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_the_geometry_rows_are_its_gradients_and_dofs_read_only(dim, degree):
    """Geometry.rows: G transposed (q, d, k, m) and each node component's dof index (k d, m); read-only; the
    estimate's strains from them are voigt_strains' at each corner (array_equal) on a real mesh's cells."""
    mesh = cc.rectangle(nx=5, ny=3) if dim == 2 else cc.box(nx=2, ny=2, nz=2)
    body = cc.Body(mesh, ALU, clamped="bottom")
    g = est.Geometry(body, degree)
    G, dofs = g.rows
    m, k = g.el.shape
    assert np.array_equal(G, g.G.transpose(1, 2, 3, 0))
    assert np.array_equal(dofs.reshape(k, dim, m).transpose(2, 0, 1), dim * g.el[:, :, None] + np.arange(dim))
    assert not G.flags.writeable and not dofs.flags.writeable
    u = np.random.default_rng(dim + degree).standard_normal((int(g.el.max()) + 1, dim))
    ue = u[g.el].reshape(m, k * dim)
    want = np.stack([voigt_strains(g.G[:, i], ue) for i in range(g.G.shape[1])], axis=1)
    assert np.array_equal(est._strains(g, u), want)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_the_geometry_keeps_one_copy_of_the_gradients_and_grad_phi_is_the_einsum(dim, degree):
    """G (m, q, d, k) is corner_gradients' and a view of the component-major copy; for P1 (G then a view of the
    barycentric gradients) gradL is a view of it too: one copy of the gradients, read-only. The fields' grad phi
    (gradient_rows on the rows) is the einsum of G with the cells' potentials to rounding (measured: P1 identical,
    P2 1.2e-16 relative; asserted 1e-13), and its strains are those of _strains."""
    mesh = cc.rectangle(nx=5, ny=3) if dim == 2 else cc.box(nx=2, ny=2, nz=2)
    body = cc.Body(mesh, cc.materials.PZT5A, clamped="bottom", grounded="top")
    g = est.Geometry(body, degree)
    _, gradL = gradients(mesh.points, mesh.cells)
    el, G = space(degree, mesh.cell).corner_gradients(body, gradL)
    assert np.array_equal(g.G, G) and np.array_equal(g.gradL, gradL) and np.array_equal(g.el, el)
    assert np.shares_memory(g.G, g.rows[0]) and not g.G.flags.writeable
    assert np.shares_memory(g.gradL, g.rows[0]) == (degree == 1)
    rng = np.random.default_rng(dim * degree)
    n = int(el.max()) + 1
    u, phi = rng.standard_normal((n, dim)), rng.standard_normal(n)
    eps, gphi = est._fields(g, u, phi)[:2]
    assert rel(gphi, np.einsum("mvdj,mj->mvd", G, phi[el])) < 1e-13
    assert np.array_equal(eps, est._strains(g, u))
    grad = np.ascontiguousarray(G[:, 0].transpose(1, 2, 0))
    want = np.einsum("mdj,mj->md", G[:, 0], phi[el])
    assert rel(gradient_rows(grad, np.ascontiguousarray(phi[el].T)).T, want) < 1e-13


def test_a_solvers_estimate_of_each_load_case_is_the_fresh_one():
    """Through a ContactSolver (its Geometry and rows kept): each load case's estimate, and a return to the first
    loads, is estimate() with nothing kept (the same numbers: ==); a solver of another mesh keeps its own."""
    solver = cc.ContactSolver(two_blocks(), method="condensed")
    for scene in (two_blocks(), two_blocks(scale=0.37, traction={"right": (0.0, -1e8)}), two_blocks()):
        sol = solver.solve(scene)
        fresh, _ = est.estimate(sol)
        assert sol.estimate.absolute == fresh.absolute and sol.estimate.parts == fresh.parts
        assert all(np.array_equal(a, b) for a, b in zip(sol.estimate.indicators, fresh.indicators))
    other = cc.ContactSolver(two_blocks(n1=(12, 6)), method="condensed").solve()
    fresh, _ = est.estimate(other)
    assert other.estimate.absolute == fresh.absolute


def _corner_scene(scale=1.0):
    """Two blocks both clamped at their left side, in contact along y = 0: the contact node at x = 0 is held on
    both sides (a held row); the upper block loaded by a body force (x ``scale``)."""
    upper = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4), ALU, clamped=["left"], contact="bottom",
                    body_force=(0.0, -2e9 * scale), name="upper")
    lower = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=6, ny=3), ALU, clamped=["left", "bottom"],
                    contact="top", name="lower")
    return cc.Scene(upper, lower)


def test_a_load_case_shares_the_held_rows_and_they_are_the_fresh_ones():
    """A load case of the same contact rows shares the held rows of the one before (the same read-only array) and
    they are held_rows formed afresh on its rows and blocks; a load case under a force-controlled obstacle forms
    its own (its translations move rows), also the fresh ones."""
    from obstacle_scenes import circle

    problem = cc.ContactSolver(_corner_scene()).problem
    assert problem.held_rows.any() and not problem.held_rows.all()
    again = problem.with_loads(_corner_scene(0.37))
    assert again.held_rows is problem.held_rows and not again.held_rows.flags.writeable
    assert np.array_equal(again.held_rows, held_rows(again.E, again.blocks, again.translations))
    scene = circle()
    forced = cc.ContactSolver(scene, degree=2).problem
    loaded = forced.with_loads(scene.with_loads(0, body_force=(0.0, -1e8)))
    assert loaded.translations and loaded.held_rows is not forced.held_rows
    assert np.array_equal(loaded.held_rows, held_rows(loaded.E, loaded.blocks, loaded.translations))
