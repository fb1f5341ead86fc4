"""Independent checks of the friction vectors in the contact VTU (cvxcontact.io.output): their signs and directions
against quantities computed here without the pair's frame: the balance of a block held by friction on a turned floor,
a pair posed from either body, and the tangential part of the displacement against curved rigid obstacles."""

import meshio
import numpy as np
import pytest
from friction_scenes import DIAGONAL3, P, dragged_disk, steel, uniform_pair3d

import cvxcontact as cc
from cvxcontact.io.output import friction_vectors, write_all

pytestmark = pytest.mark.numerics


def _contact_vtu(sol, tmp_path):
    write_all(sol, tmp_path, "s")
    return meshio.read(tmp_path / "s_contact.vtu")


def test_2d_shear_and_normal_forces_balance_the_load_on_a_turned_floor():
    """A free block on a floor turned by 0.4 rad, under a load (0.3 p, -p) turned with it and held by Coulomb's
    mu = 0.6 alone: the global shear forces plus the normal forces along the floor's normal carry the whole load,
    -(load) times 1 m (the tangent's sign is not taken from the pair)."""
    th = 0.4
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 1.0), nx=8, ny=8)
    m = cc.Mesh(m.points @ R.T, m.triangles, {t: m.boundary(t) for t in m.tags})
    load, normal = R @ np.array([0.3 * P, -P]), R @ np.array([0.0, 1.0])
    body = cc.Body(m, steel(), contact="bottom", traction={"top": tuple(load)})
    floor = cc.Rigid.plane(point=(0.0, 0.0), normal=tuple(normal))
    sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", floor, law=cc.Coulomb(0.6))]))
    assert sol.ok
    v = friction_vectors(sol)
    total = v["shear_force"].sum(axis=0) + sol.contact.force.sum() * normal
    assert np.linalg.norm(total + load) <= 1e-11 * np.linalg.norm(load)          # measured 1.2e-14 of it
    assert np.abs(v["shear"] @ normal).max() <= 1e-12 * np.abs(v["shear"]).max()  # measured 1e-16 of it


def test_3d_pair_posed_from_either_body_gives_opposite_vectors():
    """Two stuck layers under the tangential load 0.05 p along DIAGONAL3: the upper layer's shear forces sum to
    -0.05 p DIAGONAL3 (1 m^2); posed from the lower layer, every vector (on the other first body) is the opposite."""
    vectors = []
    for swap in (False, True):
        sol = cc.solve(uniform_pair3d(0.05 * P, cc.Tresca(0.1 * P), swap=swap))
        assert sol.ok
        order = np.lexsort(np.asarray(sol.contact.points).T[::-1])
        vectors.append({k: a[order] for k, a in friction_vectors(sol).items()})
    expected = -0.05 * P * np.array([*DIAGONAL3, 0.0])
    np.testing.assert_allclose(vectors[0]["shear_force"].sum(axis=0), expected, rtol=0, atol=1e-13 * P)  # 1.2e-16 P
    for key in ("shear", "shear_force"):
        scale = np.abs(vectors[0][key]).max()
        assert np.abs(vectors[0][key] + vectors[1][key]).max() <= 1e-12 * scale   # measured 8e-15 of it


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")   # coarse meshes: 2 faces span the zone
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("obstacle", ["disk", "sphere"])
def test_slip_against_a_curved_obstacle_is_the_tangential_part_of_the_displacement(tmp_path, obstacle, degree):
    """Against a rigid obstacle [u_t] is the first body's displacement less its part along the direction r to the
    obstacle's centre (computed here from the written points): the slip vector is (I - r r^T) u, sign included,
    and where it slips under Tresca the shear points against it."""
    if obstacle == "disk":
        centre = np.array([0.0, -1.0])
        sol = cc.solve(dragged_disk(cc.Tresca(0.1 * P)), degree=degree)
    else:
        centre = np.array([0.0, 0.0, 1.98])
        block = cc.box(x=(-1.0, 1.0), y=(-1.0, 1.0), z=(-1.0, 0.0), nx=4, ny=4, nz=2)
        body = cc.Body(block, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"])
        sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere(tuple(centre), 2.0),
                                                           law=cc.Tresca(1e8))]), degree=degree)
    assert sol.ok
    mesh = _contact_vtu(sol, tmp_path)
    d = len(centre)
    u, s = mesh.point_data["displacement [m]"][:, :d], mesh.point_data["slip [m]"][:, :d]
    sh = mesh.point_data["shear [Pa]"][:, :d]
    r = mesh.points[:, :d] - centre
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    scale = np.abs(s).max()
    assert scale > 1e-6                                                            # it slips (>= 4e-5 m)
    assert np.abs(s - (u - np.einsum("nd,nd->n", u, r)[:, None] * r)).max() <= 1e-13 * scale   # measured 5e-16 of it
    slipping = np.linalg.norm(s, axis=1) > 1e-3 * scale
    cos = np.einsum("nd,nd->n", sh, s)[slipping] / np.linalg.norm(sh[slipping], axis=1) / np.linalg.norm(
        s[slipping], axis=1)
    assert cos.max() <= -1 + 1e-6                                                  # measured -1 + 2e-16


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")   # the rowless pair is warned about
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("law", [cc.Tresca(1e5), cc.Coulomb(0.3)])
def test_a_friction_pair_without_rows_writes_finite_fields_and_no_friction_entry(tmp_path, law, degree):
    """Under 'sigma1' no node of the coarse upper block lies in the small block's overlap: the pair has no row, its
    ContactResult no slip; the files are written, every point array finite, without friction fields or entry."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    up = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=2, ny=2), mat, contact="bottom", clamped=["top"])
    low = cc.Body(cc.rectangle(x=(0.3, 0.45), y=(-0.5, 0), nx=1, ny=2), mat, clamped=["bottom"], contact="top")
    scene = cc.Scene(up, low, contacts=[cc.Contact(up, "bottom", low, "top", gap=-1e-5, law=law)])
    sol = cc.solve(scene, condition="sigma1", degree=degree)
    assert sol.ok and sol.contact.slip is None
    mesh = _contact_vtu(sol, tmp_path)
    assert all(np.isfinite(v).all() for v in mesh.point_data.values())
    assert not any("slip" in k or "shear" in k for k in mesh.point_data)
    assert friction_vectors(sol) == {}
