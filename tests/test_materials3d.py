"""3D material tensors: the built-ins' 6mm tensors, their plane-strain reduction (the 2D matrices), the Bond
rotation against an index-notation rotation of the 4th-order tensor, and the refusals."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.errors import MaterialError
from cvxcontact.physics.materials import EPS0, bond_matrix

MATERIALS = [cc.materials.PZT4, cc.materials.PZT5A, cc.materials.PZT5H, cc.materials.BaTiO3]
TABLE = {  # docs/materials.md §1: c11 c12 c13 c33 c44 (GPa), e31 e33 e15 (C/m^2), eps11 eps33 (eps0)
    "PZT-4": (139, 77.8, 74.3, 115, 25.6, -5.2, 15.1, 12.7, 730, 635),
    "PZT-5A": (121, 75.4, 75.2, 111, 21.1, -5.4, 15.8, 12.3, 916, 830),
    "PZT-5H": (126, 79.5, 84.1, 117, 23.0, -6.5, 23.3, 17.0, 1700, 1470),
    "BaTiO3": (150, 66, 66, 146, 44, -4.35, 17.5, 11.4, 1115, 1260),
}
VOIGT = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]


def generic_rotation(seed=3):
    """A rotation about no coordinate axis (QR of a random matrix, det +1)."""
    Q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(r))
    return Q if np.linalg.det(Q) > 0 else -Q


def full_c(c):
    """The 4th-order tensor c_ijkl of a Voigt 6x6 matrix (engineering shear: c_IJ = c_ijkl)."""
    t = np.zeros((3, 3, 3, 3))
    for I, (i, j) in enumerate(VOIGT):
        for J, (k, l) in enumerate(VOIGT):
            for a, b in {(i, j), (j, i)}:
                for p, q in {(k, l), (l, k)}:
                    t[a, b, p, q] = c[I, J]
    return t


def full_e(e):
    t = np.zeros((3, 3, 3))
    for J, (k, l) in enumerate(VOIGT):
        t[:, k, l] = t[:, l, k] = e[:, J]
    return t


def voigt_c(t):
    return np.array([[t[i, j, k, l] for (k, l) in VOIGT] for (i, j) in VOIGT])


def voigt_e(t):
    return np.array([[t[m, k, l] for (k, l) in VOIGT] for m in range(3)])


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


@pytest.mark.parametrize("mat", MATERIALS, ids=lambda m: m.name)
def test_built_in_tensors_are_the_table_and_the_2d_matrices_their_reduction(mat):
    c11, c12, c13, c33, c44, e31, e33, e15, k11, k33 = TABLE[mat.name]
    G = 1e9
    c = np.array([[c11, c12, c13, 0, 0, 0], [c12, c11, c13, 0, 0, 0], [c13, c13, c33, 0, 0, 0],
                  [0, 0, 0, c44, 0, 0], [0, 0, 0, 0, c44, 0], [0, 0, 0, 0, 0, (c11 - c12) / 2]]) * G
    e = np.array([[0, 0, 0, 0, e15, 0], [0, 0, 0, e15, 0, 0], [e31, e31, e33, 0, 0, 0]])
    assert rel(mat.c3, c) <= 1e-15                                  # measured 0 (c66: rounding of (c11-c12)/2)
    assert np.array_equal(mat.e3, e) and np.array_equal(mat.kappa3, np.diag([k11, k11, k33]) * EPS0)
    # the 2D matrices are exactly the (xx, zz, xz) / (x, z) rows and columns, i.e. the former 2D formulas
    assert np.array_equal(mat.c, np.array([[c11, c13, 0], [c13, c33, 0], [0, 0, c44]]) * G)
    assert np.array_equal(mat.e, np.array([[0, 0, e15], [e31, e33, 0]], dtype=float))
    assert np.array_equal(mat.kappa, np.diag([k11, k33]) * EPS0)
    assert np.array_equal(mat.c, mat.c3[np.ix_([0, 2, 4], [0, 2, 4])])
    assert np.array_equal(mat.e, mat.e3[np.ix_([0, 2], [0, 2, 4])])
    assert mat.tensors(2)[0] is mat.c and mat.tensors(3)[1] is mat.e3
    # the out-of-plane row of the plane reduction: sigma_22 = c12 exx + c13 ezz - e31 Ez
    a, c22, b = mat.out_of_plane
    assert np.array_equal(a, np.array([c12, c13, 0]) * G) and c22 == c11 * G and np.array_equal(b, [0, e31])


def test_isotropic_tensor_and_its_plane_strain_reduction():
    E, nu = 70e9, 0.3
    m = cc.materials.isotropic(E, nu)
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    assert np.array_equal(m.c, [[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    # uniaxial stress from the 6x6: sigma = c eps with eps = (1, -nu, -nu, 0, 0, 0) / E gives (1, 0, 0, 0, 0, 0)
    s = m.c3 @ (np.array([1, -nu, -nu, 0, 0, 0]) / E)
    assert np.abs(s - [1, 0, 0, 0, 0, 0]).max() <= 1e-15             # measured 1.1e-16
    R = generic_rotation()
    assert rel(m.rotated(R).c3, m.c3) <= 1e-14                       # isotropic: unchanged (measured 4e-16)


@pytest.mark.parametrize("mat", [cc.materials.PZT5A, cc.materials.BaTiO3], ids=lambda m: m.name)
def test_rotation_about_the_poling_axis_leaves_6mm_unchanged(mat):
    for t in (0.3, 1.1, -2.5):
        R = np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])
        r = mat.rotated(R)
        assert rel(r.c3, mat.c3) <= 1e-14                            # measured <= 4e-16
        assert rel(r.e3, mat.e3) <= 1e-14 and rel(r.kappa3, mat.kappa3) <= 1e-14


def test_rotation_then_its_inverse_is_the_identity():
    R = generic_rotation()
    m = cc.materials.PZT5H
    back = m.rotated(R).rotated(R.T)
    assert rel(back.c3, m.c3) <= 1e-14 and rel(back.e3, m.e3) <= 1e-14 and rel(back.kappa3, m.kappa3) <= 1e-14
    assert np.abs(back.rotation - np.eye(3)).max() <= 1e-15 * 10


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_bond_rotation_equals_the_index_notation_rotation(seed):
    """c'_ijkl = R_ip R_jq R_kr R_ls c_pqrs, e'_kij = R_kp R_iq R_jr e_pqr, kappa' = R kappa R^T (einsum on the
    full tensors, independent of the Bond matrix)."""
    R = generic_rotation(seed)
    m = cc.materials.PZT5A.rotated(generic_rotation(seed + 10))      # a general (triclinic-looking) material
    r = m.rotated(R)
    c = voigt_c(np.einsum("ip,jq,kr,ls,pqrs->ijkl", R, R, R, R, full_c(m.c3)))
    e = voigt_e(np.einsum("kp,iq,jr,pqr->kij", R, R, R, full_e(m.e3)))
    assert rel(r.c3, c) <= 1e-14 and rel(r.e3, e) <= 1e-14           # measured ~3e-16
    assert rel(r.kappa3, R @ m.kappa3 @ R.T) <= 1e-15
    # the poling axis follows R's last column: e'^T maps E along R e_z as e^T maps E along e_z
    assert rel(r.e3.T @ R[:, 2], bond_matrix(R) @ m.e3.T @ np.array([0, 0, 1.0])) <= 1e-14
    # the plane matrices of a 3D-rotated material are the reduction of its tensors
    assert np.array_equal(r.c, r.c3[np.ix_([0, 2, 4], [0, 2, 4])])


def test_plane_rotation_turns_the_3d_tensors_about_the_out_of_plane_axis():
    """rotated(angle) (2D) keeps its plane matrices and turns the 3D tensors about the crystal's x2 (3D y):
    their reduction equals the 2D result to rounding."""
    m = cc.materials.PZT5A
    for t in (0.4, np.pi / 2, -1.3):
        r = m.rotated(t)
        assert rel(r.c3[np.ix_([0, 2, 4], [0, 2, 4])], r.c) <= 1e-14          # measured ~2e-16
        assert rel(r.e3[np.ix_([0, 2], [0, 2, 4])], r.e) <= 1e-14
        assert rel(r.kappa3[np.ix_([0, 2], [0, 2])], r.kappa) <= 1e-14
        a, c22, b = r.out_of_plane
        assert rel(r.c3[1, [0, 2, 4]], a) <= 1e-14 and abs(r.c3[1, 1] - c22) <= 1e-14 * c22
    i = cc.materials.isotropic(1e9, 0.25).rotated(0.8)
    assert rel(i.c3, cc.materials.isotropic(1e9, 0.25).c3) <= 1e-14


def test_from_matrices_takes_3d_shapes():
    m = cc.materials.PZT4
    r = cc.materials.Piezoelectric.from_matrices(m.c3, m.e3, m.kappa3, name="copy")
    assert np.array_equal(r.c, m.c) and np.array_equal(r.e, m.e) and np.array_equal(r.c3, m.c3)
    el = cc.materials.Elastic(cc.materials.isotropic(2e9, 0.2).c3)
    assert el.tensors(3)[0].shape == (6, 6) and el.c.shape == (3, 3)
    with pytest.raises(MaterialError, match="shape"):
        cc.materials.Piezoelectric.from_matrices(m.c3, m.e, m.kappa3)
    with pytest.raises(MaterialError, match="not positive definite"):
        cc.materials.Elastic(-np.eye(6))


def test_refusals():
    m = cc.materials.PZT5A
    with pytest.raises(MaterialError, match="proper rotation"):
        m.rotated(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(MaterialError, match="proper rotation"):
        m.rotated(np.eye(3) * 1.01)
    with pytest.raises(MaterialError, match="3x3 rotation matrix"):
        m.rotated(np.eye(2))
    plane = cc.materials.Piezoelectric(c11=1e11, c13=7e10, c33=1e11, c44=2e10, e31=-5, e33=15, e15=12,
                                       eps11=1e-8, eps33=1e-8)
    assert plane.c3 is None
    with pytest.raises(MaterialError, match="no 3D constants.*c12"):
        plane.tensors(3)
    with pytest.raises(MaterialError, match="plane-stress"):
        m.plane_stress().tensors(3)
    with pytest.raises(MaterialError, match="no 3D constants"):
        plane.rotated(np.eye(3))
    with pytest.raises(MaterialError, match="dim 2 or 3"):
        m.tensors(4)
