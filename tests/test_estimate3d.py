"""The error estimate in 3D (tetrahedra, P1 and P2), its measured effectivity on nested tetrahedral meshes, the
uniform tetrahedral refinement, and the estimate carried by the report and the VTU files (2D and 3D).

The effectivity bounds are the measured values of `cvxcontact study estimate` for the 3D scenes (levels 0 and 1
against a reference refined three times: every tetrahedron into 8^3) widened by 3 either way, as in
tests/test_estimate.py.
"""

import copy
import warnings

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import estimate as study
from cvxcontact.fem import assembly, p2
from cvxcontact.fem.fields import body_fields
from cvxcontact.geometry.quadratic import P2TetNodes
from cvxcontact.geometry.refine import refine_uniform
from cvxcontact.io.output import write_vtu
from cvxcontact.solution.estimate import estimate

ALU = cc.materials.isotropic(E=70e9, nu=0.3)

# measured effectivity (estimate / true error), levels 0 and 1, reference at level 3 (2026-12-04)
MEASURED = {
    "sphere (3D), P1": (5.05, 5.32),
    "two boxes (3D piezo), P1": (10.0, 11.7),
}


def _plane_compression(degree):
    """A block on rollers pressed uniformly by a rigid plane: u_h is affine, the exact solution."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    block = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=3, ny=2, nz=2), mat,
                    roller=["bottom", "left", "right", "front", "back"], contact="top")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0, 0, 0.5 - 1e-4), (0, 0, -1.0)))])
    return cc.solve(scene, degree=degree)


@pytest.mark.parametrize("degree", [1, 2])
def test_the_3d_estimate_is_zero_for_a_solution_that_is_exact(degree):
    """Every residual of an exact (affine) solution vanishes; the complementarity enters eta^2 unsquared, so its
    rounding shows as a relative eta of about 1e-8 (measured 7.8e-9 (P1), 6.8e-9 (P2))."""
    sol = _plane_compression(degree)
    assert sol.ok and sol.estimate.relative < 1e-6
    assert sol.estimate.unit == "sqrt(J)" and "sqrt(J)" in sol.report()


@pytest.mark.parametrize("degree", [1, 2])
def test_a_side_held_in_two_of_three_components_counts_only_the_third(degree):
    """A side held in x and y, free in z (``displacement={"left": (0, 0, None)}``): its support reactions
    sigma_xx, sigma_yx are not residuals. Uniaxial strain with nu = 0.3 (sigma_xx = lambda eps_zz != 0 there),
    so u_h is exact and eta vanishes only if those two components, and only they, are left out (it raised an
    IndexError before: k facets broadcast against 2 components). Measured relative eta 0.0 (P1, P2); keeping x wrongly gives 0.42."""
    mat = cc.materials.isotropic(E=70e9, nu=0.3)
    block = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=3, ny=2, nz=2), mat,
                    roller=["bottom", "right", "front", "back"], displacement={"left": (0.0, 0.0, None)},
                    contact="top")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0, 0, 0.5 - 1e-4), (0, 0, -1.0)))])
    sol = cc.solve(scene, degree=degree)
    assert sol.ok and sol.estimate.relative < 1e-6


@pytest.mark.parametrize("degree", [1, 2])
def test_3d_fields_norm_and_indicators(degree):
    """The estimate's norm is the energy u^T Kuu u of an independent assembly, its indicators one per
    tetrahedron summing (in squares) to eta^2 and to the parts."""
    scene = study.sphere_scene()
    sol = cc.solve(scene, degree=degree)
    est = sol.estimate
    (body,) = scene.bodies
    assert len(est.indicators[0]) == len(body.mesh.tets) and est.kind == "residual" and not est.guaranteed
    assert np.isclose(np.sqrt((est.indicators[0] ** 2).sum()), est.absolute, rtol=1e-12)
    assert np.isclose(sum(est.parts.values()), est.absolute ** 2, rtol=1e-12)
    K = (assembly.assemble_matrices(body) if degree == 1 else p2.assemble_matrices(body, P2TetNodes(body.mesh))).Kuu
    u = sol.u[0].ravel()
    assert np.isclose(est.norm, np.sqrt(u @ (K @ u)), rtol=1e-10)
    assert est.parts["contact traction"] > 0 and est.parts["jump"] > 0


def test_the_3d_jump_term_is_the_face_by_face_sum():
    """For P1 the stress is constant per tetrahedron: the jump part is sum over interior faces of
    h_F |F| |(sigma_a - sigma_b) n|^2 / (2 mu), computed here face by face from the stresses of fem.fields (an
    independent evaluation) for a random displacement."""
    sol = copy.copy(cc.solve(study.sphere_scene(), estimate=False))
    scene = sol.scene
    mesh = scene.bodies[0].mesh
    rng = np.random.default_rng(5)
    sol.u = [rng.standard_normal(mesh.points.shape) * 1e-3]
    est, _ = estimate(sol)
    s = body_fields(scene.bodies[0], sol.u[0], None).stress                # (m, 6) xx, yy, zz, yz, xz, xy
    S = s[:, [0, 5, 4, 5, 1, 3, 4, 3, 2]].reshape(-1, 3, 3)
    faces = {}
    for t, tet in enumerate(mesh.tets):
        for i in range(4):
            faces.setdefault(tuple(sorted(np.delete(tet, i))), []).append(t)
    total = 0.0
    for f, cells in faces.items():
        if len(cells) == 2:
            p = mesh.points[list(f)]
            normal = np.cross(p[1] - p[0], p[2] - p[0])
            area = 0.5 * np.linalg.norm(normal)
            h = max(np.linalg.norm(p[a] - p[b]) for a, b in ((0, 1), (1, 2), (0, 2)))
            jump = (S[cells[0]] - S[cells[1]]) @ (normal / (2 * area))
            total += h * area * jump @ jump
    mu = 70e9 / (2 * 1.33)                                                # study.ALU: E = 70 GPa, nu = 0.33
    assert est.parts["jump"] == pytest.approx(total / (2 * mu), rel=1e-10)      # measured 2e-16


def test_tetrahedral_refinement_is_nested_and_keeps_tags():
    mesh = cc.box(x=(0.0, 1.0), y=(0.0, 2.0), z=(0.0, 0.5), nx=2, ny=3, nz=1)
    fine, parent = refine_uniform(mesh, 2)
    assert len(fine.tets) == 64 * len(mesh.tets) and (fine.volumes > 0).all()
    assert np.allclose(np.bincount(parent, weights=fine.volumes), mesh.volumes, rtol=1e-13)
    # every child lies in its parent: its vertices' barycentric coordinates there are in [0, 1]
    P = mesh.points[mesh.tets[parent]]
    T = (P[:, 1:] - P[:, :1]).transpose(0, 2, 1)
    lam = np.linalg.solve(T[:, None], (fine.points[fine.tets] - P[:, None, 0])[..., None])[..., 0]
    assert lam.min() > -1e-12 and lam.sum(axis=2).max() < 1 + 1e-12
    for t in mesh.tags:
        assert len(fine.boundary(t)) == 16 * len(mesh.boundary(t))
        assert np.isclose(fine.face_areas(t).sum(), mesh.face_areas(t).sum(), rtol=1e-13)
    with pytest.raises(cc.MeshError, match="times"):
        refine_uniform(mesh, -1)


@pytest.mark.parametrize("degree", [1, 2])
def test_3d_prolongation_is_exact_on_nested_meshes(degree):
    scene = study.boxes_scene()
    fine, parents = study.refined(scene, 1)
    rng = np.random.default_rng(2)
    a = rng.standard_normal(5)
    for bc, bf, par in zip(scene.bodies, fine.bodies, parents):
        pc = bc.mesh.points if degree == 1 else P2TetNodes(bc.mesh).points
        pf = bf.mesh.points if degree == 1 else P2TetNodes(bf.mesh).points

        def field(p):
            x, y, z = p.T
            return a[0] + a[1] * x + a[2] * y + a[3] * z + (degree - 1) * a[4] * x * z

        assert np.abs(study.prolong(field(pc), bc.mesh, bf.mesh, par, degree) - field(pf)).max() < 1e-13  # ~1e-15


@pytest.mark.parametrize("name", list(study.SCENES3D))
def test_3d_effectivity_within_the_measured_range_and_the_estimate_falls(name):
    build, options = study.SCENES3D[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        rows = study.effectivity(build, options, study.LEVELS3D, study.REFERENCE3D)
    lo, hi = MEASURED[name]
    for r in rows:
        assert r["ok"]
        assert lo / 3 <= r["effectivity"] <= hi * 3, r
    assert rows[1]["estimate"] < rows[0]["estimate"]
    assert rows[1]["true_error"] < rows[0]["true_error"]


@pytest.mark.parametrize("dim, degree", [(2, 1), (2, 2), (3, 1), (3, 2)])
def test_the_vtu_files_carry_the_error_indicators(tmp_path, dim, degree):
    scene = study.blocks_scene() if dim == 2 else study.boxes_scene()
    sol = cc.solve(scene, degree=degree)
    paths = write_vtu(sol, tmp_path)
    for k in range(len(scene.bodies)):
        (path,) = [p for p in paths if p.name == f"solution_body{k + 1}.vtu"]
        data = meshio.read(path).cell_data["error_indicator"][0]
        assert np.array_equal(data, sol.estimate.indicators[k])
    off = cc.solve(scene, degree=degree, estimate=False)
    (path,) = [p for p in write_vtu(off, tmp_path / "off") if p.name == "solution_body1.vtu"]
    assert "error_indicator" not in meshio.read(path).cell_data


def test_the_3d_json_summary_carries_the_estimate():
    from cvxcontact.io.output import summary

    sol = cc.solve(study.sphere_scene())
    s = summary(sol)["estimate"]
    assert s["relative"] == sol.estimate.relative and s["absolute_sqrt_J"] == sol.estimate.absolute
    assert s["energy_norm_sqrt_J"] == sol.estimate.norm and s["guaranteed"] is False and s["kind"] == "residual"
