"""The guaranteed error bound (cvxcontact.error_bound, solve(..., estimate="equilibrated"); docs/accuracy.md).

Checked independently of the code under test: the bound against the true error measured on nested fine
references (the estimate study's prolongation and energy norm); a closed form (a uniaxial block whose exact
solution lies in the P1 space: the bound is rounding); the equilibrium of the stress sampled directly (its
divergence and its normal traction across every edge at points the construction never used); the refusals.
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import bound as study
from cvxcontact.solution import bound


def uniaxial(approach=1e-4, nx=4, ny=2):
    mat = cc.materials.isotropic(E=70e9, nu=0.3)
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny), mat, roller=["bottom", "left", "right"],
                    contact="top")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, 0.5 - approach), (0.0, -1.0)))])


def test_the_bound_of_an_exact_solution_is_rounding():
    """Uniaxial compression by a rigid plane, rollers elsewhere: u is affine, u_h = u, so the bound is 0 up to
    rounding; its terms: the stress mismatch and the complementarity p (g - u_h . d) at active nodes."""
    sol = cc.solve(uniaxial(), estimate="equilibrated")
    est = sol.estimate
    assert est.kind == "equilibrated" and est.guaranteed is True
    # measured: relative 2.3e-8 (the unsquared complementarity's rounding, 7e-13 J/m against |||u_h|||^2 = 1.4e3)
    assert est.relative < 1e-6
    assert est.parts["stress"] <= 1e-20 * est.norm ** 2          # measured 3e-28 / 1.4e3
    assert est.parts["correction"] == 0.0                         # a plane: u_h is admissible between the nodes
    assert "guaranteed" in str(est) and "not guaranteed" not in str(est)


@pytest.mark.parametrize("name", list(study.SCENES))
def test_the_bound_is_above_the_true_error(name):
    """Levels 0 and 1 against a reference refined three times: the bound exceeds the true error (measured
    effectivity in the comment); a guaranteed bound reads >= 1 up to the reference's own error, which is
    smaller than the finest bound (the margin asserted below)."""
    build, options = study.SCENES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        rows = study.effectivity(build, options, levels=(0, 1), reference=3)
    for r in rows:
        assert r["ok"]
        # the true error is measured against a reference with its own error e_ref <= reference_bound; the
        # error to the continuous solution is >= true_error - e_ref, so the bound must exceed that
        assert r["bound"] >= r["true_error"] - r["reference_bound"] * 0, r
        assert r["effectivity"] >= 1.0, r
        assert r["effectivity"] <= study.MEASURED[name][1] * 3, r
    assert rows[1]["bound"] < rows[0]["bound"]


def test_the_stress_is_equilibrated_where_the_construction_did_not_look():
    """The equilibrated stress of the circle, level 0: div tau + f = 0 from its nodal values by an independent
    finite difference of the barycentric interpolant, and tau n continuous across every interior edge at
    the edge's quarter points (the construction imposes it at the ends; linearity carries it between)."""
    sol = cc.solve(study.circle_scene(), estimate=False)
    tau, info = bound.equilibrated_stress(sol)
    mesh = sol.scene.bodies[0].mesh
    _, _, verts = bound._split(mesh)                              # (3m, 3, 2) sub-triangle vertices
    scale = np.abs(tau).max()

    def value(sub, x):                                            # tau (Voigt) of sub-triangle ``sub`` at x
        P = verts[sub]
        T = np.column_stack([P[1] - P[0], P[2] - P[0]])
        lam = np.linalg.solve(T, x - P[0])
        L = np.array([1 - lam.sum(), *lam])
        return L @ tau[sub]

    rng = np.random.default_rng(0)
    for sub in rng.choice(len(verts), 20, replace=False):
        x0 = verts[sub].mean(axis=0)
        h = 1e-3 * np.linalg.norm(verts[sub][1] - verts[sub][0])
        d = [(value(sub, x0 + h * e) - value(sub, x0 - h * e)) / (2 * h) for e in np.eye(2)]
        div = np.array([d[0][0] + d[1][2], d[0][2] + d[1][1]])
        assert np.abs(div).max() * 0.5 <= 1e-6 * scale            # f = 0; measured ~1e-10 relative per metre
    for a, b, x in info["interior_edges_sample"]:
        na = info["normal"][a, b]
        ta, tb = value(a, x), value(b, x)
        tra = np.array([ta[0] * na[0] + ta[2] * na[1], ta[2] * na[0] + ta[1] * na[1]])
        trb = np.array([tb[0] * na[0] + tb[2] * na[1], tb[2] * na[0] + tb[1] * na[1]])
        assert np.abs(tra - trb).max() <= 1e-9 * scale             # measured ~1e-15


def test_uncovered_cases_are_refused_naming_what_is_covered():
    mesh3 = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=2, ny=2, nz=1)
    block3 = cc.Body(mesh3, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", contact="top")
    scene3 = cc.Scene(block3, contacts=[cc.Contact(block3, "top", cc.Rigid.plane((0.0, 0.0, 0.5 - 1e-4),
                                                                                 (0.0, 0.0, -1.0)))])
    with pytest.raises(cc.UnsupportedError, match="3D.*it covers 2D P1"):
        cc.solve(scene3, estimate="equilibrated")
    with pytest.raises(cc.UnsupportedError, match="P2.*it covers 2D P1"):
        cc.solve(uniaxial(), estimate="equilibrated", degree=2)
    with pytest.raises(cc.UnsupportedError, match="compliance"):
        cc.solve(uniaxial(), estimate="equilibrated", law=cc.NormalCompliance(1e12))
    with pytest.raises(cc.UnsupportedError, match="closest point.*distance='ray'"):
        cc.solve(study.circle_scene(distance="closest"), estimate="equilibrated")
    from cvxcontact.apps.studies import estimate as residual_study
    with pytest.raises(cc.UnsupportedError, match="pairs of deformable bodies"):
        cc.solve(residual_study.blocks_scene(), estimate="equilibrated")
    with pytest.raises(cc.UnsupportedError, match="P2"):                  # the function refuses a solved P2 too
        cc.error_bound(cc.solve(uniaxial(), degree=2, estimate=False))
    with pytest.raises(cc.SolverError, match="equilibrated"):
        cc.solve(uniaxial(), estimate="guaranteed")
