"""The fields read back per cell (cvxcontact.fem.fields.body_fields) of an affine displacement and potential are
their closed forms on every element: P1/P2 triangles and tetrahedra, Q1/Q2 quadrilaterals and hexahedra, on
distorted meshes (each space holds the affine fields exactly, whatever the cells' shapes). The oracle: eps =
sym(A), E = -g, sigma = c eps - e^T E and D = e eps + kappa E formed here from the material's matrices."""

import numpy as np
import pytest
from conftest import rel

import cvxcontact as cc
from cvxcontact.fem.fields import body_fields
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

VOIGT = {2: ((0, 0), (1, 1), (0, 1)), 3: ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))}


def distorted(mesh, seed):
    """``mesh`` with its interior vertices moved at random by up to a fifth of a cell (no cell inverted)."""
    p = np.array(mesh.points)
    lo, hi = p.min(axis=0), p.max(axis=0)
    inner = np.all((p > lo + 1e-9) & (p < hi - 1e-9), axis=1)
    h = (hi - lo).min() / 4
    p[inner] += np.random.default_rng(seed).uniform(-0.2 * h / 2, 0.2 * h / 2, size=(inner.sum(), p.shape[1]))
    return mesh.with_points(p)


MESHES = {
    "triangle": lambda: cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2),
    "quad": lambda: cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2, cell="quad"),
    "tetra": lambda: cc.box(z=(0.0, 0.5), nx=4, ny=4, nz=2),
    "hex": lambda: cc.box(z=(0.0, 0.5), nx=4, ny=4, nz=2, cell="hex"),
}


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("cell", list(MESHES))
def test_the_fields_of_affine_u_and_phi_are_their_closed_forms(cell, degree):
    mesh = distorted(MESHES[cell](), seed=3)
    dim = mesh.points.shape[1]
    body = cc.Body(mesh, cc.materials.PZT5A, clamped=["bottom"], grounded=["bottom"])
    nodes = space(degree, mesh.cell).nodes(body)
    x = mesh.node_set(nodes).points
    rng = np.random.default_rng(7)
    A, c0 = 1e-4 * rng.standard_normal((dim, dim)), 1e-4 * rng.standard_normal(dim)   # u = A x + c0 (m)
    g = 1e4 * rng.standard_normal(dim)                                          # phi = g . x (V)
    f = body_fields(body, x @ A.T + c0, x @ g, nodes)

    eng = np.array([A[i, j] + A[j, i] if i != j else A[i, i] for i, j in VOIGT[dim]])   # Voigt, engineering shears
    c, e, kappa = body.material.tensors(dim)
    E = -g
    sigma = c @ eng - e.T @ E
    D = e @ eng + kappa @ E
    tensor_shear = eng * np.array([1.0 if i == j else 0.5 for i, j in VOIGT[dim]])
    m = len(f.strain)
    # measured (all eight cases): strain <= 5.4e-15, stress <= 4.0e-15, E <= 1.9e-15, D <= 1.0e-14 (P2 tetrahedra)
    assert rel(f.strain, np.broadcast_to(tensor_shear, (m, len(eng)))) < 2e-12
    in_plane = f.stress[:, [0, 1, 3]] if dim == 2 else f.stress           # 2D: (sxx, syy, szz, sxy)
    assert rel(in_plane, np.broadcast_to(sigma, in_plane.shape)) < 2e-12
    assert rel(f.electric_field, np.broadcast_to(E, (m, dim))) < 2e-12
    assert rel(f.electric_displacement, np.broadcast_to(D, (m, dim))) < 2e-12
