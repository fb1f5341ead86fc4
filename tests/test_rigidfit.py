"""The rigid fit of a body's free unknowns (cvxcontact/fem/rigidfit.py) against rigid modes written here by hand:
per piece, the deformation it answers is orthogonal to every rigid motion of the piece on its free unknowns, and
what it takes out is one of them (so a rigid motion added to the displacement leaves the deformation unchanged).
The measured values are the largest over seeds 0..19, 2D and 3D."""

import numpy as np
import pytest
import scipy.sparse as sp

from cvxcontact.fem.rigidfit import rigid_fit

pytestmark = pytest.mark.numerics


def _modes(x):
    """(dim n, m) the rigid motions of points x (n, dim), node-major: translations, then rotations (2D: about z;
    3D: about each axis), written independently of the package's rigid_field."""
    n, dim = x.shape
    cols = []
    for i in range(dim):
        t = np.zeros((n, dim))
        t[:, i] = 1.0
        cols.append(t.ravel())
    if dim == 2:
        cols.append(np.column_stack([-x[:, 1], x[:, 0]]).ravel())
    else:
        for w in np.eye(3):
            cols.append(np.cross(w, x).ravel())
    return np.column_stack(cols)


def _prolongation(rng, n, dim):
    """Tu (dim n, k) with orthonormal columns: most nodes free, some held (their dofs dropped), some on a roller
    along a random direction (one column, a unit vector over the node's dofs) -- the supports' prolongation."""
    cols = []
    for node in range(n):
        kind = rng.choice(3, p=[0.7, 0.15, 0.15])
        if kind == 0:                                              # free
            cols += [np.eye(dim * n)[:, dim * node + i] for i in range(dim)]
        elif kind == 1:                                            # a roller: one direction free
            v = np.zeros(dim * n)
            d = rng.standard_normal(dim)
            v[dim * node:dim * node + dim] = d / np.linalg.norm(d)
            cols.append(v)
    return sp.csr_matrix(np.column_stack(cols))


@pytest.mark.parametrize("dim", [2, 3])
def test_the_rigid_fit_takes_out_exactly_the_rigid_motions_of_each_piece(dim):
    rng = np.random.default_rng(7 + dim)
    n = 40
    x = rng.uniform(-3.0, 5.0, (n, dim))
    components = np.repeat([0, 1], [25, 15])
    Tu = _prolongation(rng, n, dim)
    assert np.allclose((Tu.T @ Tu).toarray(), np.eye(Tu.shape[1]))
    fit = rigid_fit(x, components, Tu)
    z = rng.standard_normal(Tu.shape[1])
    d = fit.deformation(z)
    free_owner = np.repeat(components, dim)[Tu.tocsc().indices[Tu.tocsc().indptr[:-1]]]
    for c in (0, 1):
        on = np.repeat(components == c, dim)
        M = np.asarray(Tu.T @ (on[:, None] * _modes(x)))[free_owner == c]   # the piece's motions, its free unknowns
        assert np.abs(M.T @ d[free_owner == c]).max() < 1e-12 * np.abs(M).sum(axis=0).max()   # measured <= 6.3e-16
        taken = (z - d)[free_owner == c]
        coef = np.linalg.lstsq(M, taken, rcond=None)[0]
        assert np.abs(M @ coef - taken).max() < 1e-12 * np.abs(z).max()    # measured <= 1.1e-15
    r = Tu.T @ sum((np.repeat(components == c, dim) * (_modes(x) @ rng.standard_normal(_modes(x).shape[1])))
                   for c in (0, 1))                                           # each piece moved rigidly on its own
    moved = fit.deformation(z + 100.0 * r)
    assert np.abs(moved - d).max() < 1e-10 * np.abs(d).max()                  # measured <= 6.7e-13
    assert np.abs(fit.deformation(r)).max() < 1e-12 * np.abs(r).max()        # measured <= 1.7e-15


def test_a_piece_the_supports_hold_keeps_only_the_motions_left_on_its_free_unknowns():
    """A 2D piece with one free unknown: one motion (along it) is fitted, so its deformation is 0; a piece whose
    every unknown is held has no piece in the fit."""
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [5.0, 5.0]])
    components = np.array([0, 0, 0, 1])
    Tu = sp.csr_matrix(np.eye(8)[:, [2]])                                    # node 1 along x; node 3 held
    fit = rigid_fit(x, components, Tu)
    assert len(fit.pieces) == 1 and fit.pieces[0][1].shape == (1, 1)
    assert np.all(fit.deformation(np.array([3.0])) == 0.0)
