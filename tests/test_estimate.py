"""The error estimate (sol.estimate), its measured effectivity on nested meshes, and ResolutionWarning.

The effectivity bounds below are the measured ranges of `cvxcontact study estimate --quick` (levels 0 and 1
against a reference refined three times, the configuration run here) widened by 3 either way, as the
brief of issue 30 asks: a residual estimator's constants are unknown, so its effectivity is measured, and
these tests catch a change of the estimator or of the reference that moves it beyond that.
"""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import effectivity_falls_within

import cvxcontact as cc
from cvxcontact.apps.studies import estimate as study
from cvxcontact.fem import assembly, p2
from cvxcontact.geometry.quadratic import P2Nodes
from cvxcontact.geometry.refine import refine_uniform
from cvxcontact.solution.estimate import cell_energies

README = Path(__file__).resolve().parents[1] / "README.md"

# measured effectivity (estimate / true error), levels 0 and 1, reference at level 3 (2026-12-04; the circle
# re-measured after curved obstacles were posed at the closest point):
MEASURED = {
    "circle, P1": (3.48, 4.09),
    "two blocks (piezo), P1": (5.77, 5.99),
    "two blocks (piezo), P2": (8.37, 8.99),
    "stack, P2": (6.75, 7.91),
    # issue 30's further scenes (measured with this configuration, 2026-12-05):
    "Hertz cylinder, P1": (4.30, 4.52),
    "Hertz cylinder, P2": (6.36, 7.89),
    "punch, partial overlap, P1": (5.35, 6.81),
    "punch, partial overlap, P2": (7.96, 9.00),
    "PZT layer, floating electrode, P1": (3.49, 4.70),
    "PZT layer, floating electrode, P2": (7.61, 7.95),
}


@pytest.mark.parametrize("name", list(MEASURED))
def test_effectivity_within_the_measured_range_and_the_estimate_falls(name):
    # the circle's level 0 is under-resolved (ResolutionWarning); estimate ratios measured 0.39 .. 0.87
    effectivity_falls_within(*study.SCENES[name], MEASURED[name])


@pytest.mark.parametrize("degree", [1, 2])
def test_prolongation_is_exact_on_nested_meshes_and_the_energy_norm_is_the_stiffness(degree):
    """I reproduces a P1 (P2) function at the fine nodes (to rounding), and the cell energies sum to
    u^T Kuu u + phi^T Kpp phi of the assembled matrices (an independent assembly)."""
    scene = study.blocks_scene()
    fine, parents = study.refined(scene, 2)
    rng = np.random.default_rng(3)
    for bc, bf, par in zip(scene.bodies, fine.bodies, parents):
        pc = bc.mesh.points if degree == 1 else P2Nodes(bc.mesh).points
        pf = bf.mesh.points if degree == 1 else P2Nodes(bf.mesh).points
        a = rng.standard_normal(4)

        def field(p):
            return np.column_stack([a[0] + a[1] * p[:, 0] + a[2] * p[:, 1] + (degree - 1) * a[3] * p[:, 0] * p[:, 1],
                                    a[3] * p[:, 0] ** degree - a[0] * p[:, 1]])

        assert np.abs(study.prolong(field(pc), bc.mesh, bf.mesh, par, degree) - field(pf)).max() < 1e-13  # ~1e-15
        u = rng.standard_normal((len(pf), 2))
        system = assembly.assemble_matrices(bf) if degree == 1 else p2.assemble_matrices(bf, P2Nodes(bf.mesh))
        phi = rng.standard_normal(len(pf)) * 1e9 if system.Kpp is not None else None
        expected = u.ravel() @ (system.Kuu @ u.ravel()) + (0.0 if phi is None else phi @ (system.Kpp @ phi))
        assert abs(cell_energies(bf, u, phi, degree).sum() - expected) <= 1e-12 * expected    # measured 1e-16


def test_refinement_keeps_area_tags_and_nesting():
    mesh = cc.rectangle(x=(0.0, 2.0), y=(0.0, 1.0), nx=3, ny=2)
    fine, parent = refine_uniform(mesh, 2)
    assert len(fine.triangles) == 16 * len(mesh.triangles)
    assert np.isclose(fine.areas.sum(), 2.0, rtol=1e-14)
    assert np.allclose(np.bincount(parent, weights=fine.areas), mesh.areas, rtol=1e-13)
    for t in mesh.tags:
        assert len(fine.boundary(t)) == 4 * len(mesh.boundary(t))
        assert np.isclose(np.linalg.norm(np.diff(fine.points[fine.boundary(t)], axis=1), axis=2).sum(),
                          np.linalg.norm(np.diff(mesh.points[mesh.boundary(t)], axis=1), axis=2).sum())
    with pytest.raises(cc.MeshError, match="times"):
        refine_uniform(mesh, -1)


def test_estimate_fields_report_and_opt_out():
    scene = study.blocks_scene()
    sol = cc.solve(scene)
    est = sol.estimate
    assert est.kind == "residual" and est.guaranteed is False
    assert [len(i) for i in est.indicators] == [len(b.mesh.triangles) for b in scene.bodies]
    assert np.isclose(np.sqrt(sum((i ** 2).sum() for i in est.indicators)), est.absolute, rtol=1e-12)
    assert np.isclose(sum(est.parts.values()), est.absolute ** 2, rtol=1e-12)
    assert est.relative == est.absolute / est.norm
    # the solution's own norm: the energy of (26) without contact, sum u^T Kuu u + phi^T Kpp phi, independently
    norm2 = 0.0
    for b, u, phi in zip(scene.bodies, sol.u, sol.phi):
        s = assembly.assemble_matrices(b)
        norm2 += u.ravel() @ (s.Kuu @ u.ravel()) + (0.0 if phi is None else phi @ (s.Kpp @ phi))
    assert np.isclose(est.norm, np.sqrt(norm2), rtol=1e-10)
    assert re.search(r"estimate +\d", sol.report())
    off = cc.solve(scene, estimate=False)
    assert off.estimate is None and "estimate=False" in off.estimate_reason and "estimate " in off.report()
    with pytest.raises(cc.SolverError, match="estimate"):
        cc.solve(scene, estimate="yes")


def test_the_estimate_is_zero_for_a_solution_that_is_exact():
    """A uniform compression of one block by a rigid plane (no body force, no traction): u_h is affine, the
    exact solution; every residual vanishes to rounding and so must the estimate."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2), mat, roller=["bottom", "left", "right"],
                    contact="top")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, 0.5 - 1e-4), (0.0, -1.0)))])
    sol = cc.solve(scene)
    # the terms vanish to rounding; the complementarity int lambda (g - [u_nu]) enters eta^2 unsquared, so its
    # rounding (4e-13 J/m against a squared norm of 1.4e3 J/m: 3e-16) shows as a relative eta of 1.7e-8 (measured)
    assert sol.ok and sol.estimate.relative ** 2 < 1e-12
    est = cc.solve(scene.with_obstacles(cc.Rigid.plane((0.0, 0.5 - 2e-4), (0.0, -1.0)))).estimate
    assert est.relative ** 2 < 1e-12                                  # twice the approach: the same


def test_a_coarse_circle_warns_and_a_finer_one_does_not():
    """The circle of the effectivity study: at 24 cells along the top the zone has 2 loaded nodes (3 faces),
    its contact force 12 % above the converged one (measured: 1.219e8 against 1.085e8 N/m four levels finer);
    refined once the zone has 6 faces and no warning."""
    coarse = study.circle_scene()
    with pytest.warns(cc.ResolutionWarning, match=r"block/top.*3 faces.*Refine the contact face"):
        cc.solve(coarse)
    fine, _ = study.refined(coarse, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResolutionWarning)
        sol = cc.solve(fine)
    assert sol.ok


def test_the_readme_examples_emit_no_resolution_warning():
    """The README's Python snippets (2D and 3D) run without a ResolutionWarning."""
    blocks = [b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "cc.solve" in b]
    assert blocks
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResolutionWarning)
        for code in blocks:
            exec(compile(code, str(README), "exec"), {})  # our own documentation, not user input


def test_the_json_summary_carries_the_estimate():
    from cvxcontact.io.output import summary

    sol = cc.solve(study.blocks_scene())
    s = summary(sol)["estimate"]
    assert s["relative"] == sol.estimate.relative and s["absolute_sqrt_J_per_m"] == sol.estimate.absolute
    assert s["guaranteed"] is False and s["kind"] == "residual"
    assert summary(cc.solve(study.blocks_scene(), estimate=False))["estimate"]["reason"].startswith("not computed")
