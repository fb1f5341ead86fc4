"""The assembly into the nodal pattern (fem/assembly.py ``assemble_points``, ``NodePattern``) against a dense
element-by-element assembly written here: for every element and stiffness point the textbook B^T c B, B^T e^T G
and G^T kappa G, with B built here from the Voigt definition of the strains, summed into dense matrices by dof.
P1 and P2, triangles and tetrahedra, elastic and piezoelectric, on distorted meshes (no entry is zero by a
symmetry of the grid), in mesh order, in shuffled element order and in passes of a few elements."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem import assembly, p2
from cvxcontact.geometry.quadratic import P2Nodes, P2TetNodes

pytestmark = pytest.mark.numerics

# the largest relative difference measured is 5.4e-16 (P2 tetrahedra, piezoelectric); 1e-13 is 190x that
RTOL = 1e-13


def _voigt_B(G):
    """(s, dim k) strain matrix of one element's gradients G (dim, k): rows xx, yy[, zz], then the engineering
    shears (2D: 2xy; 3D: 2yz, 2xz, 2xy); dofs node-major (dim a + p)."""
    dim, k = G.shape
    pairs = [(0, 0), (1, 1), (0, 1)] if dim == 2 else [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    B = np.zeros((len(pairs), dim * k))
    for r, (i, j) in enumerate(pairs):
        for a in range(k):
            B[r, dim * a + i] += G[j, a]
            if i != j:
                B[r, dim * a + j] += G[i, a]
    return B


def _dense(body, cells, n, points):
    """Dense Kuu, Kup, Kpp of ``points`` [(G (m, dim, k), w (m,))] on ``cells`` (m, k), element by element."""
    dim = body.dim
    c, e, kappa = body.material.tensors(dim)
    Kuu, Kup, Kpp = np.zeros((dim * n, dim * n)), np.zeros((dim * n, n)), np.zeros((n, n))
    for el, nodes in enumerate(cells):
        dofs = (dim * nodes[:, None] + np.arange(dim)).ravel()
        for G, w in points:
            g, B = G[el], _voigt_B(G[el])
            Kuu[np.ix_(dofs, dofs)] += w[el] * B.T @ c @ B
            if e is not None:
                Kup[np.ix_(dofs, nodes)] += w[el] * B.T @ e.T @ g
                Kpp[np.ix_(nodes, nodes)] += w[el] * g.T @ kappa @ g
    return Kuu, Kup, Kpp


def _distorted(mesh, seed=0):
    """The mesh with every node moved by up to 0.03 m along each axis (a tenth of its smallest cell)."""
    rng = np.random.default_rng(seed)
    return mesh.with_points(mesh.points + 0.03 * rng.uniform(-1, 1, mesh.points.shape))


def _body(dim, piezo):
    if dim == 2:
        mesh = _distorted(cc.rectangle(nx=3, ny=2))
    else:
        mesh = _distorted(cc.box(nx=2, ny=2, nz=1))
    material = cc.materials.PZT5A if piezo else cc.materials.isotropic(E=70e9, nu=0.3)
    electric = {"grounded": ["bottom"]} if piezo else {}
    return cc.Body(mesh, material, clamped=["bottom"], **electric)


def _case(dim, degree, piezo):
    body = _body(dim, piezo)
    if degree == 1:
        area, grad = assembly.gradients(body.mesh.points, body.mesh.cells)
        return body, body.mesh.cells, len(body.mesh.points), [(grad, area)], None
    nodes = P2Nodes(body.mesh) if dim == 2 else P2TetNodes(body.mesh)
    return body, nodes.cells, len(nodes), p2.stiffness_points(body), nodes


def _compare(system, ref):
    for name, M, R in zip(("Kuu", "Kup", "Kpp"), (system.Kuu, system.Kup, system.Kpp), ref):
        if M is None:
            continue
        assert M.shape == R.shape, name
        assert np.abs(M.toarray() - R).max() <= RTOL * np.abs(R).max(), name


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("piezo", [False, True])
def test_pattern_assembly_equals_dense_elementwise(dim, degree, piezo):
    body, cells, n, points, nodes = _case(dim, degree, piezo)
    ref = _dense(body, cells, n, points)
    _compare(assembly.assemble_points(body, cells, n, points, nodes), ref)
    if degree == 1:                                       # the public entry point takes the same path
        _compare(assembly.assemble_matrices(body), ref)
    else:
        _compare(p2.assemble_matrices(body, nodes), ref)


@pytest.mark.parametrize("degree", [1, 2])
def test_shuffled_elements_and_small_passes(degree, monkeypatch):
    """Elements in random order (positions of a pass spread over the whole pattern) and passes of 3 elements
    (P2 tetrahedra: ENTRIES_PER_PASS // 100) give the dense matrices too."""
    body, cells, n, points, nodes = _case(3, degree, True)
    ref = _dense(body, cells, n, points)
    order = np.random.default_rng(1).permutation(len(cells))
    monkeypatch.setattr(assembly, "ENTRIES_PER_PASS", 3 * cells.shape[1] ** 2)
    shuffled = [(G[order], w[order]) for G, w in points]
    _compare(assembly.assemble_points(body, cells[order], n, shuffled, nodes), ref)


def test_node_pattern_positions():
    """Each element node pair's position holds that pair: its column is the second node and its row (from the
    row pointers) the first; the pattern has each pair once, sorted within rows, and no other pair."""
    mesh = cc.box(nx=2, ny=3, nz=2)
    cells, n = mesh.cells, len(mesh.points)
    pattern = assembly.NodePattern(cells, n)
    row = np.searchsorted(pattern.indptr, pattern.pos, side="right") - 1
    assert np.array_equal(row, np.broadcast_to(cells[:, :, None], pattern.pos.shape))
    assert np.array_equal(pattern.indices[pattern.pos], np.broadcast_to(cells[:, None, :], pattern.pos.shape))
    pairs = {(int(a), int(b)) for el in cells for a in el for b in el}
    assert pattern.nnz == len(pairs)
    assert np.all(np.unique(pattern.pos) == np.arange(pattern.nnz))
    for i in range(n):
        assert np.all(np.diff(pattern.indices[pattern.indptr[i]:pattern.indptr[i + 1]]) > 0)
