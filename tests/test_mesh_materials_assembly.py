"""Meshes, materials and P1 assembly against closed forms (independent of the solver)."""

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem.assembly import assemble
from cvxcontact.physics.materials import EPS0


# ----------------------------------------------------------------------------------------- meshes

def test_rectangle_sizes_tags_and_area():
    m = cc.rectangle(x=(0.0, 2.0), y=(-1.0, 0.5), nx=5, ny=3)
    assert m.points.shape == (24, 2) and m.triangles.shape == (30, 3)
    assert m.areas.sum() == pytest.approx(3.0, rel=1e-14) and (m.areas > 0).all()
    assert set(m.tags) == {"left", "right", "bottom", "top"}
    assert m.boundary("right").shape == (3, 2)
    assert np.allclose(m.points[m.boundary_nodes(["bottom"]), 1], -1.0)
    assert np.allclose(m.outward_normals("top"), [0, 1]) and np.allclose(m.outward_normals("left"), [-1, 0])


@pytest.mark.parametrize("diagonal", ["right", "left", "alternate"])
def test_rectangle_diagonals_cover_the_domain(diagonal):
    m = cc.rectangle(nx=4, ny=4, diagonal=diagonal)
    assert m.areas.sum() == pytest.approx(1.0) and np.allclose(m.areas, 1 / 32)


def test_clockwise_mesh_is_reoriented_and_folded_mesh_rejected():
    p = [[0, 0], [1, 0], [1, 1], [0, 1]]
    m = cc.Mesh(p, [[0, 2, 1], [0, 3, 2]])        # clockwise throughout: a convention, accepted
    assert (m.areas > 0).all()
    with pytest.raises(cc.MeshError, match="inverted"):
        cc.Mesh(p, [[0, 1, 2], [0, 3, 2]])         # one of each orientation: folded


@pytest.mark.parametrize("points,triangles,match", [
    ([[0, 0], [1, 0], [2, 0]], [[0, 1, 2]], "degenerate"),
    ([[0, 0], [1, 0], [0, 1], [0, 1]], [[0, 1, 2], [1, 3, 0]], "duplicate nodes"),
    ([[0, 0], [1, 0], [0, 1], [5, 5]], [[0, 1, 2]], "belong to no triangle"),
    ([[0, 0], [1, 0], [0, np.nan]], [[0, 1, 2]], "NaN"),
    ([[0, 0], [1, 0], [0, 1]], [[0, 1, 3]], "outside"),
    ([[0, 0], [1, 0], [0, 1]], [[0.0, 1.0, 2.0]], "integer"),
    ([[0, 0], [1, 0]], [[0, 1, 1]], r"\(n, 2\)"),
])
def test_bad_meshes_raise_mesh_error(points, triangles, match):
    with pytest.raises(cc.MeshError, match=match):
        cc.Mesh(points, triangles)


def test_tags_must_be_boundary_edges_and_known():
    p = [[0, 0], [1, 0], [1, 1], [0, 1]]
    with pytest.raises(cc.MeshError, match="not on the boundary"):
        cc.Mesh(p, [[0, 1, 2], [0, 2, 3]], {"diag": [[0, 2]]})
    with pytest.raises(cc.MeshError, match="unknown boundary tag 'nope'"):
        cc.rectangle().boundary("nope")


def test_read_mesh_gmsh_with_physical_names(tmp_path):
    src = cc.rectangle(x=(0, 1), y=(0, 1), nx=3, ny=2)
    lines = np.concatenate([src.boundary("bottom"), src.boundary("top")])
    ids = np.array([1] * 3 + [2] * 3)
    pts3 = np.column_stack([src.points, np.zeros(len(src.points))])
    pts3 = np.vstack([pts3, [[9.0, 9.0, 0.0]]])    # a geometry point used by no triangle: dropped
    mesh = meshio.Mesh(pts3, [("line", lines), ("triangle", src.triangles)],
                       cell_data={"gmsh:physical": [ids, np.full(len(src.triangles), 3)],
                                  "gmsh:geometrical": [ids, np.full(len(src.triangles), 3)]},
                       field_data={"floor": np.array([1, 1]), "roof": np.array([2, 1]), "body": np.array([3, 2])})
    path = tmp_path / "block.msh"
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    m = cc.read_mesh(path)
    assert set(m.tags) == {"floor", "roof"} and len(m.points) == len(src.points)
    assert np.allclose(m.points[m.boundary_nodes(["roof"]), 1], 1.0)
    assert m.areas.sum() == pytest.approx(1.0)


def test_read_mesh_region_selects_one_body_of_a_two_body_file(tmp_path):
    """One gmsh file with two physical surfaces sharing the line y = 0: each region is one body."""
    upper, lower = cc.rectangle(x=(0, 1), y=(0, 1), nx=3, ny=2), cc.rectangle(x=(0, 1), y=(-1, 0), nx=3, ny=2)
    pts = np.vstack([upper.points, lower.points])
    off = len(upper.points)
    tris = np.vstack([upper.triangles, lower.triangles + off])
    lines = np.vstack([upper.boundary("top"), upper.boundary("bottom"), lower.boundary("bottom") + off])
    line_ids = np.array([1] * 3 + [2] * 3 + [3] * 3)
    tri_ids = np.array([10] * len(upper.triangles) + [20] * len(lower.triangles))
    mesh = meshio.Mesh(np.column_stack([pts, np.zeros(len(pts))]), [("line", lines), ("triangle", tris)],
                       cell_data={"gmsh:physical": [line_ids, tri_ids], "gmsh:geometrical": [line_ids, tri_ids]},
                       field_data={"roof": np.array([1, 1]), "joint": np.array([2, 1]), "floor": np.array([3, 1]),
                                   "piezo": np.array([10, 2]), "base": np.array([20, 2])})
    path = tmp_path / "two.msh"
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    top = cc.read_mesh(path, region="piezo")
    bottom = cc.read_mesh(path, region="base")
    assert set(top.tags) == {"roof", "joint"} and set(bottom.tags) == {"floor"}
    assert np.allclose(top.points, upper.points) and len(bottom.points) == len(lower.points)
    with pytest.raises(cc.MeshError, match="no physical surface 'lid'; it has \\['base', 'piezo'\\]"):
        cc.read_mesh(path, region="lid")


def test_read_mesh_errors(tmp_path):
    with pytest.raises(cc.MeshError, match="does not exist"):
        cc.read_mesh(tmp_path / "missing.msh")
    bad = tmp_path / "garbage.msh"
    bad.write_text("this is not a mesh")
    with pytest.raises(cc.MeshError, match="cannot read"):
        cc.read_mesh(bad)
    lines_only = tmp_path / "lines.vtu"
    meshio.write(lines_only, meshio.Mesh(np.array([[0.0, 0, 0], [1, 0, 0]]), [("line", np.array([[0, 1]]))]))
    with pytest.raises(cc.MeshError, match="no triangles"):
        cc.read_mesh(lines_only)


# ------------------------------------------------------------------------------------- materials

def test_pzt5a_plane_reduction():
    m = cc.materials.PZT5A
    assert m.c[0, 0] == 121e9 and m.c[0, 1] == 75.2e9 and m.c[1, 1] == 111e9 and m.c[2, 2] == 21.1e9
    assert m.e.tolist() == [[0, 0, 12.3], [-5.4, 15.8, 0]]
    assert m.kappa[0, 0] == pytest.approx(916 * EPS0) and m.kappa[1, 1] == pytest.approx(830 * EPS0)
    assert m.kappa[1, 1] == pytest.approx(7.349e-9, rel=1e-3)


def test_isotropic_plane_strain_lame_constants():
    m = cc.materials.isotropic(E=200e9, nu=0.25)
    lam, mu = 200e9 * 0.25 / (1.25 * 0.5), 200e9 / 2.5
    assert np.allclose(m.c, [[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    assert not m.piezoelectric and cc.materials.PZT4.piezoelectric


@pytest.mark.parametrize("make,match", [
    (lambda: cc.materials.isotropic(E=-1.0, nu=0.3), "E > 0"),
    (lambda: cc.materials.isotropic(E=1e9, nu=0.5), "nu < 0.5"),
    (lambda: cc.materials.Piezoelectric.from_matrices([[1, 2, 0], [0, 1, 0], [0, 0, 1]], np.zeros((2, 3)),
                                                      np.eye(2)), "not symmetric"),
    (lambda: cc.materials.Piezoelectric.from_matrices(np.eye(3), np.zeros((2, 3)), -np.eye(2)),
     "kappa is not positive definite"),
    (lambda: cc.materials.Piezoelectric(c11=1e11, c13=2e11, c33=1e11, c44=2e10, e31=-5, e33=15, e15=12,
                                        eps11=8e-9, eps33=7e-9), "not positive definite"),
    (lambda: cc.materials.Piezoelectric(c11=1e11, c13=5e10), "missing"),
    (lambda: cc.materials.Piezoelectric(c11=float("nan"), c13=5e10, c33=1e11, c44=2e10, e31=-5, e33=15, e15=12,
                                        eps11=8e-9, eps33=7e-9), "finite"),
    (lambda: cc.materials.Elastic(np.ones((2, 2))), "shape"),
])
def test_bad_materials_raise_material_error(make, match):
    with pytest.raises(cc.MaterialError, match=match):
        make()


# -------------------------------------------------------------------------------------- assembly

def _body(mat, **kw):
    m = cc.rectangle(x=(0.0, 2.0), y=(0.0, 1.0), nx=5, ny=3, diagonal="right")
    extra = {"grounded": ["top"]} if mat.piezoelectric else {}
    return cc.Body(m, mat, clamped=["left"], contact="bottom", **extra, **kw)


def test_stiffness_kernel_and_energy_of_affine_fields():
    mat = cc.materials.PZT5H
    s = assemble(_body(mat))
    p = _body(mat).mesh.points
    x, y = p[:, 0], p[:, 1]
    for r in ([1 + 0 * x, 0 * x], [0 * x, 1 + 0 * x], [-y, x]):     # rigid motions
        assert np.abs(s.Kuu @ np.column_stack(r).ravel()).max() < 1e-4  # vs entries ~1e11
    F = np.array([[1e-3, 2e-4], [-3e-4, 5e-4]])                        # u = F x
    u = (p @ F.T).ravel()
    eps = np.array([F[0, 0], F[1, 1], F[0, 1] + F[1, 0]])
    assert u @ s.Kuu @ u == pytest.approx(2.0 * eps @ mat.c @ eps, rel=1e-12)
    g = np.array([30.0, -70.0])                                        # phi = g . x
    phi = p @ g
    assert u @ s.Kup @ phi == pytest.approx(2.0 * (mat.e @ eps) @ g, rel=1e-12)
    assert phi @ s.Kpp @ phi == pytest.approx(2.0 * g @ mat.kappa @ g, rel=1e-12)


def test_consistent_loads_integrate_exactly():
    f = lambda x, y: (1e6 * (1 + x * y), -2e6 * x)                       # linear: midpoint rule exact
    t = lambda x, y: (0 * x, 5e5 * (1 + y))
    b = _body(cc.materials.PZT4, body_force=f, traction={"right": t}, volume_charge=lambda x, y: 3e-3 * y,
              surface_charge={"bottom": 2e-2})
    s = assemble(b)
    p = b.mesh.points
    fx, fy = s.f[0::2], s.f[1::2]
    # int over [0,2]x[0,1] of 1e6(1+xy) = 1e6 (2 + 1) ; of -2e6 x = -4e6 ; traction on x=2: int 5e5(1+y) = 7.5e5
    assert fx.sum() == pytest.approx(3e6, rel=1e-12)
    assert fy.sum() == pytest.approx(-4e6 + 7.5e5, rel=1e-12)
    assert fy @ p[:, 0] == pytest.approx(-2e6 * 8 / 3 + 2 * 7.5e5, rel=1e-12)  # first moment, exact for P1
    # q = (q0, psi) - (q2, psi)_Gamma_b: int 3e-3 y = 3e-3, surface charge on bottom (length 2): 4e-2
    assert s.q.sum() == pytest.approx(3e-3 - 4e-2, rel=1e-12)


def test_elastic_body_has_no_electric_unknowns():
    s = assemble(_body(cc.materials.isotropic(E=1e9, nu=0.2)))
    assert s.Kup is None and s.Kpp is None and s.phi_free is None
    clamped = _body(cc.materials.isotropic(E=1e9, nu=0.2)).mesh.boundary_nodes(["left"])
    assert len(s.u_free) == 2 * (24 - len(clamped))
