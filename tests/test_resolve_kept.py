"""What a re-solve reuses from the load case before it: a body's forward sweep when its scaled load is unchanged
(Condensation.apply), the residual's products in the energy (Block._times), a body's fingerprint; and the
estimate's strains formed without the strain matrices (fem.assembly.voigt_strains). The oracles: a direct solve of
the same scene, the direct formulas, a fresh hash, the strain matrices, and an affine field's exact strain."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import rel, two_blocks

import cvxcontact as cc
from cvxcontact.discrete import build_problem
from cvxcontact.discrete.energy import Quadratic
from cvxcontact.fem.assembly import gradients, strain_matrix, voigt_strains
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics


def _fields(sol):
    return np.concatenate([np.ravel(x) for x in sol.u] + [np.ravel(x) for x in sol.phi if x is not None])


def test_a_body_whose_loads_stay_reuses_its_forward_sweep_and_answers_as_a_direct_solve():
    """The lower block carries no load: its scaled load is the same in every load case and its forward sweep is
    reused (the same object); the upper block's loads change and its sweep is new, unless the load case is the one
    before times 2 (the units follow the loads: the scaled loads are the same numbers, exactly). Each load case,
    and a return to the first loads, answers as cc.solve of its scene (measured: identical; asserted to 1e-12
    relative)."""
    solver = cc.ContactSolver(two_blocks(), method="condensed")
    first = solver.solve()
    reduction = solver.cache.condensation
    assert reduction is not None
    upper, lower = reduction.sweeps
    scenes = [two_blocks(scale=0.37, traction={"right": (0.0, -1e8)}), two_blocks(scale=0.5), two_blocks()]
    for scene, new in zip(scenes, (True, True, False)):
        again, direct = solver.solve(scene), cc.solve(scene, method="condensed")
        assert again.ok and direct.ok
        assert reduction.sweeps[1] is lower and (reduction.sweeps[0] is not upper) == new
        upper = reduction.sweeps[0]
        assert rel(_fields(again), _fields(direct)) < 1e-12
        assert rel(again.contact.force, direct.contact.force) < 1e-12
    assert rel(_fields(again), _fields(first)) < 1e-12               # back to the first loads
    assert rel(_fields(solver.solve(scenes[0])), _fields(first)) > 1e-2      # (the loads matter)


def test_the_same_load_case_twice_reuses_both_sweeps():
    solver = cc.ContactSolver(two_blocks(), method="condensed")
    other = two_blocks(scale=0.37)
    once = solver.solve(other)
    sweeps = list(solver.cache.condensation.sweeps)
    twice = solver.solve(other)
    assert all(a is b for a, b in zip(solver.cache.condensation.sweeps, sweeps))
    assert np.array_equal(_fields(once), _fields(twice))


def test_the_energy_reads_the_residual_products_only_for_the_same_fields():
    """Block.energy after Block.residual of the same (u, phi) reuses Kuu u and Kpp phi (bit for bit the direct
    formula's numbers); other fields, the same array edited in place, or another matrix are formed anew."""
    problem = build_problem(two_blocks(), space(1, "triangle"), "gamma3", cc.Signorini())
    b = problem.blocks[0]
    rng = np.random.default_rng(5)
    u, phi = rng.standard_normal(b.Kuu.shape[0]), rng.standard_normal(b.Kpp.shape[0])
    c = rng.standard_normal(b.jump.shape[0])

    def direct(blk, u, phi):
        return 0.5 * float(u @ (blk.Kuu @ u)) - blk.f @ u + 0.5 * phi @ (blk.Kpp @ phi)

    r = b.residual(u, phi, c)
    assert np.array_equal(r[0], b.Kuu @ u + b.Kup @ phi + b.jump.T @ c - b.f)
    assert b.energy(u, phi) == direct(b, u, phi)
    product = b.products[("product", "Kuu")][2]
    assert not product.flags.writeable and b.energy(u, phi) == direct(b, u, phi)
    assert b.products[("product", "Kuu")][2] is product                       # read, not formed again
    u[:7] += 1.0                                                               # the same array, other numbers
    assert b.energy(u, phi) == direct(b, u, phi)
    v = rng.standard_normal(b.Kuu.shape[0])
    assert b.energy(v, phi) == direct(b, v, phi)
    K2 = (2.0 * b.Kuu).tocsr()
    doubled = replace(b, Kuu=K2, bulk=Quadratic(K2))                         # (shares the products' dict)
    assert doubled.products is b.products and doubled.energy(v, phi) == direct(doubled, v, phi)
    assert problem.with_loads(two_blocks(scale=0.5)).blocks[0].products == {}


@pytest.mark.parametrize("dim, k", [(2, 3), (2, 6), (3, 4), (3, 10)])
def test_voigt_strains_are_the_strain_matrices_products(dim, k):
    """Random gradients and displacements: the strain matrices' products, up to summation order (measured: 2D
    identical, 3D 7e-16 relative; asserted 1e-13)."""
    rng = np.random.default_rng(dim * 10 + k)
    grad = rng.standard_normal((500, dim, k))
    ue = rng.standard_normal((500, dim * k))
    want = np.einsum("mij,mj->mi", strain_matrix(grad), ue)
    assert rel(voigt_strains(grad, ue), want) < 1e-13


@pytest.mark.parametrize("dim", [2, 3])
def test_voigt_strains_of_an_affine_field_are_exact(dim):
    """u = A x + b on a mesh's P1 cells: eps = (A_ii; A_ij + A_ji) in every cell (measured: 2e-16 relative)."""
    mesh = cc.rectangle(nx=7, ny=5) if dim == 2 else cc.box(nx=3, ny=3, nz=2)
    A = np.arange(1.0, 1.0 + dim * dim).reshape(dim, dim) / 7.0
    u = mesh.points @ A.T + 0.3
    _, grad = gradients(mesh.points, mesh.cells)
    ue = u[mesh.cells].reshape(len(mesh.cells), -1)
    pairs = {2: ((0, 0), (1, 1), (0, 1)), 3: ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))}[dim]
    exact = np.array([A[i, j] + (A[j, i] if i != j else 0.0) for i, j in pairs])
    assert rel(voigt_strains(grad, ue), np.broadcast_to(exact, (len(mesh.cells), len(exact)))) < 1e-12


def test_a_body_keeps_its_fingerprint_and_a_load_case_of_it_starts_with_it():
    """The fingerprint is hashed once per body (the arrays are read-only for good) and is the hash of its arrays
    (computed here afresh: _digest); a with_loads body starts with it, a with_changes body of another mesh, of
    another material or with other supports hashes its own."""
    from cvxcontact.physics.fingerprint import KEPT, _digest, geometry_fingerprint

    body = two_blocks().bodies[0]
    assert KEPT not in body.__dict__
    fp = geometry_fingerprint(body)
    assert body.__dict__[KEPT] == fp == _digest(body)
    loaded = body.with_loads(body_force=(1e8, -1e9))
    assert loaded.__dict__[KEPT] == fp == _digest(loaded)
    for other in (body.with_changes(mesh=cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=10, ny=4)),
                  body.with_changes(material=cc.materials.PZT4),
                  body.with_changes(clamped=["top", "left"])):
        assert KEPT not in other.__dict__ and geometry_fingerprint(other) == _digest(other) != fp
