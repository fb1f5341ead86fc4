"""material.rotated(angle) and plane stress: identities, tensor invariance of the assembled operators,
a rotated scene giving the rotated solution, and the plane-stress closed forms."""

import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.fem.assembly import assemble_matrices

sys.path.insert(0, str(Path(__file__).parent))
from conftest import rel  # noqa: E402

PZT = cc.materials.PZT5A
ALU = cc.materials.isotropic(E=70e9, nu=0.3)


@pytest.mark.parametrize("angle", [0.0, 2 * np.pi, -4 * np.pi])
def test_rotation_by_whole_turns_is_the_identity(angle):
    for m in (PZT, ALU):
        r = m.rotated(angle)
        assert rel(r.c, m.c) <= 1e-14
        if m.piezoelectric:
            assert np.abs(r.e - m.e).max() <= 1e-14 * np.abs(m.e).max() and rel(r.kappa, m.kappa) <= 1e-14


def test_quarter_turn_points_the_poling_axis_along_minus_x():
    r = PZT.rotated(np.pi / 2)
    c11, c13, c33 = PZT.c[0, 0], PZT.c[0, 1], PZT.c[1, 1]
    e31, e33, e15 = PZT.e[1, 0], PZT.e[1, 1], PZT.e[0, 2]
    assert rel(r.c, [[c33, c13, 0], [c13, c11, 0], [0, 0, PZT.c[2, 2]]]) <= 1e-14
    assert np.abs(r.e - np.array([[-e33, -e31, 0], [0, 0, -e15]])).max() <= 1e-14 * e33
    assert rel(np.diag(r.kappa), np.diag(PZT.kappa)[::-1]) <= 1e-14


def test_rotated_mesh_and_material_give_the_rotated_operators():
    """K' = R K R^T (R turns each node's displacement), Kup' = R Kup, Kpp' = Kpp, for any angle."""
    t = np.deg2rad(30.0)
    Q = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=3, ny=2)
    mr = cc.Mesh(m.points @ Q.T, m.triangles, {k: m.boundary(k) for k in m.tags})
    a = assemble_matrices(cc.Body(m, PZT, clamped=["top"], grounded=["top"], contact="bottom"))
    b = assemble_matrices(cc.Body(mr, PZT.rotated(t), clamped=["top"], grounded=["top"], contact="bottom"))
    R = sp.block_diag([Q] * len(m.points))
    assert rel((R @ a.Kuu @ R.T).toarray(), b.Kuu.toarray()) <= 1e-13
    assert rel((R @ a.Kup).toarray(), b.Kup.toarray()) <= 1e-13
    assert rel(a.Kpp.toarray(), b.Kpp.toarray()) <= 1e-13


def test_scene_turned_half_a_turn_gives_the_turned_solution():
    """Both blocks, materials and loads turned by pi about the origin: u'(Rx) = R u(x), phi'(Rx) = phi(x)."""
    def scene(turn):
        sgn = -1.0 if turn else 1.0
        m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=6, ny=3)
        m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=5, ny=3)
        if turn:
            m1, m2 = (cc.Mesh(-m.points, m.triangles, {k: m.boundary(k) for k in m.tags}) for m in (m1, m2))
        p, a = (PZT.rotated(np.pi), ALU.rotated(np.pi)) if turn else (PZT, ALU)
        b1 = cc.Body(m1, p, clamped=["top"], grounded=["top"], contact="bottom", body_force=(0.0, -2e9 * sgn),
                     traction={"right": (0.0, 3e8 * sgn)}, surface_charge={"left": -0.05})
        b2 = cc.Body(m2, a, clamped=["bottom"], contact="top")
        return cc.Scene(b1, b2)

    s0, s1 = cc.solve(scene(False)), cc.solve(scene(True))
    assert s0.ok and s1.ok and s0.contact.active.any()
    for k in range(2):
        assert rel(s1.u[k], -s0.u[k]) <= 1e-9
    assert rel(s1.phi[0], s0.phi[0]) <= 1e-9
    assert rel(s1.contact.force[::-1], s0.contact.force) <= 1e-9


def test_plane_stress_isotropic_is_the_closed_form():
    E, nu = 70e9, 0.3
    c = ALU.plane_stress().c
    assert rel(c, E / (1 - nu ** 2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])) <= 1e-14
    assert ALU.plane == "strain" and ALU.plane_stress().plane == "stress"


def test_plane_stress_piezo_leaves_no_out_of_plane_stress():
    """From the 6mm constants (crystal x1, x2 = out of plane, x3 = poling): pick in-plane strains and field,
    choose eps22 with sigma22 = 0, and compare stress and D with the reduced matrices."""
    c11, c12, c13, c33 = 121e9, 75.4e9, 75.2e9, 111e9
    e31, e33, k33 = -5.4, 15.8, 830 * cc.materials.EPS0
    eps11, eps33, E3 = 1e-4, -2e-4, 3e5
    eps22 = -(c12 * eps11 + c13 * eps33 - e31 * E3) / c11           # sigma22 = 0
    s11 = c11 * eps11 + c12 * eps22 + c13 * eps33 - e31 * E3
    s33 = c13 * eps11 + c13 * eps22 + c33 * eps33 - e33 * E3
    D3 = e31 * eps11 + e31 * eps22 + e33 * eps33 + k33 * E3
    m = PZT.plane_stress()
    v, f = np.array([eps11, eps33, 0.0]), np.array([0.0, E3])
    assert rel(m.c @ v - m.e.T @ f, [s11, s33, 0.0]) <= 1e-12
    assert rel(m.e @ v + m.kappa @ f, [0.0, D3]) <= 1e-12
    with pytest.raises(cc.MaterialError, match="c12"):
        cc.materials.Piezoelectric.from_matrices(PZT.c, PZT.e, PZT.kappa).plane_stress()
