"""The convex solution against independent computations: the mixed system, closed forms, symmetry."""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from conftest import rel, two_blocks
from reference_problems import bonded_patch
from references import direct_mixed_solve

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


# polish=False (the interior point, the same on clarabel 0.10.0 and 0.11.1, cvxpy 1.7.5 and 1.9.3, with and without
# oneMKL, 1 or 2 threads): u, phi measured <= 6.5e-9 (full), 3.7e-8 (condensed); force and lambda_h <= 1.9e-6 (full),
# 5.1e-6 (condensed), all for gamma3
@pytest.mark.parametrize("method,polish,tol_u,tol_lam", [("full", False, 1e-7, 1e-5), ("full", True, 1e-11, 1e-10),
                                                         ("condensed", False, 1e-6, 1e-4),
                                                         ("condensed", True, 1e-11, 1e-10)])
@pytest.mark.parametrize("condition", cc.CONDITIONS)
def test_convex_solution_matches_direct_mixed_solve(scene, condition, method, polish, tol_u, tol_lam):
    """Interior-point answer (polish=False) and exact finish against a dense solve of (26),
    for the full model and for the condensed (interface-only) model."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = cc.solve(scene, condition, method=method, polish=polish)
    assert sol.polished == polish
    us, phis, lam, force, jump = direct_mixed_solve(scene, sol)
    err = max([rel(sol.u[k], us[k]) for k in range(2)] + [rel(sol.contact.force, force)])
    # ok means correct: an answer off by more than its tolerance is flagged and warned about
    assert err <= sol.tol or (not sol.ok and any(w.category is cc.ResidualWarning for w in caught)), (err, sol.ok)
    # the active set from the convex solve is a valid one for the mixed system:
    constrained = sol.contact.constrained
    assert (force[sol.contact.active] > 0).all()
    assert jump[constrained].max() <= 1e-12 * np.abs(np.concatenate(us)).max()
    for k in range(2):
        assert rel(sol.u[k], us[k]) < tol_u
        if phis[k] is not None:
            assert rel(sol.phi[k], phis[k]) < tol_u
    assert rel(sol.contact.force, force) < tol_lam
    assert rel(sol.contact.lam, lam) < tol_lam


@pytest.mark.parametrize("condition", cc.CONDITIONS)
def test_residual_report_below_tolerance(solutions, condition):
    sol = solutions[condition]
    res = sol.residuals()
    assert set(res) >= {"equilibrium", "feasibility", "complementarity", "cone"}
    # complementarity is sqrt(y |slack| / (Y U)) (docs/checks.md): at rounding (product ~ a few eps) it
    # reads ~1e-8, so it gets 1e-7 (product < 1e-14); the other three are linear and get 1e-8
    assert all(v < (1e-7 if k == "complementarity" else 1e-8) for k, v in res.items()), res
    assert sol.ok and sol.status == "optimal"
    assert sol.contact.active.sum() > 0 and (~sol.contact.active[sol.contact.constrained]).sum() > 0


def test_solution_shapes_and_units(scene, solutions):
    sol = solutions["gamma3"]
    b1, b2 = scene.bodies
    assert sol.u[0].shape == (len(b1.mesh.points), 2) and sol.u[1].shape == (len(b2.mesh.points), 2)
    assert sol.phi[0].shape == (len(b1.mesh.points),) and sol.phi[1] is None
    x = sol.contact.x
    assert np.all(np.diff(x) > 0) and x[0] == 0.0 and x[-1] == 1.0
    assert len(x) == 16 + 11 + 1 - 1  # 17 + 12 nodes, endpoints shared
    # clamped and grounded parts hold exactly
    top = b1.mesh.boundary_nodes(["top"])
    assert np.all(sol.u[0][top] == 0) and np.all(sol.phi[0][top] == 0)
    # lambda = -sigma_nu > 0 in compression: total force balances part of the downward load
    assert sol.contact.force.sum() > 0
    assert isinstance(sol.problem, __import__("cvxpy").Problem)


def test_condensed_interface_stiffness_is_the_dense_schur_complement(scene):
    """Sigma read from the trailing block of the factors equals S_GG - S_GI S_II^{-1} S_IG (dense)."""
    from cvxcontact.fem.assembly import assemble
    from cvxcontact.backends.condensed import condense, quasi_definite
    from cvxcontact.discrete import Block, units

    systems = [assemble(b) for b in scene.bodies]
    un = units(scene, systems)
    for k, (s, body) in enumerate(zip(systems, scene.bodies)):
        block = Block.scaled(s, scene.interface.jump(k, len(body.mesh.points)), un)
        c = condense(block, s, body.mesh)
        S = quasi_definite(block)[0].toarray()
        g = c.gamma
        i = np.setdiff1d(np.arange(len(S)), g)
        schur = S[np.ix_(g, g)] - S[np.ix_(g, i)] @ np.linalg.solve(S[np.ix_(i, i)], S[np.ix_(i, g)])
        assert rel(c.stiffness, schur) < 1e-12
        assert np.linalg.eigvalsh(c.stiffness).min() > 0           # SPD
        assert len(g) == len(scene.interface.traces[k].x)          # one normal dof per free trace node


def test_contact_solver_reuses_factorisations_for_new_loads():
    """Re-solving with other loads (same geometry) equals a fresh solve; other geometry is refused."""
    base = two_blocks()
    solver = cc.ContactSolver(base, "gamma3", method="condensed")
    first = solver.solve()
    assert "factorization" in first.timings
    b1, b2 = base.bodies
    loaded = cc.Scene(cc.Body(b1.mesh, b1.material, clamped=b1.clamped, grounded=b1.grounded, contact=b1.contact,
                              body_force=(1e8, -3e9), surface_charge={"right": 0.02}), b2)
    again = solver.solve(loaded)
    assert "factorization" not in again.timings and again.ok and again.path == "active-set warm start"
    assert again.problem is None and first.path == "interior point + exact finish"
    fresh = cc.solve(loaded, "gamma3")
    for k in range(2):
        assert rel(again.u[k], fresh.u[k]) < 1e-11
    assert rel(again.contact.lam, fresh.contact.lam) < 1e-9
    with pytest.raises(cc.SceneError, match="only loads may change"):
        solver.solve(two_blocks(n1=(8, 4)))


def test_dual_of_gauss_law_is_minus_phi(scene):
    """math.md §2: the dual of Kpp phi - Kup^T u = q equals -phi (scaled units)."""
    sol = cc.solve(scene, "gamma3", method="full")                # the full model has the variable phi1
    gauss = sol.problem.constraints[0]
    phi_var = [v for v in sol.problem.variables() if v.name() == "phi1"][0]
    assert rel(-gauss.dual_value, phi_var.value) < 1e-7


def test_user_can_add_constraint_and_resolve(scene):
    """The cvxpy.Problem is reachable and can be extended."""
    import cvxpy as cp

    sol = cc.solve(scene, "gamma3", method="full")
    u1 = [v for v in sol.problem.variables() if v.name() == "u1"][0]
    extra = cp.Problem(sol.problem.objective, sol.problem.constraints + [u1 <= 0])
    extra.solve(solver="CLARABEL")
    assert extra.status == "optimal" and extra.value >= sol.problem.value - 1e-9 * abs(sol.problem.value)


def test_coupling_is_real_surface_charge_closes_contact():
    """Loaded only by charge on the contact face, the piezo block moves; q2 < 0 pushes it down."""
    m1 = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=4)
    m2 = cc.rectangle(x=(0, 1), y=(-0.5, 0), nx=6, ny=3)
    soft = cc.materials.isotropic(E=10e9, nu=0.3)
    out = {}
    for q2 in (-0.05, 0.05):
        b1 = cc.Body(m1, cc.materials.PZT5A, clamped="top", grounded="top", contact="bottom",
                     surface_charge={"bottom": q2})
        b2 = cc.Body(m2, soft, clamped="bottom", contact="top")
        out[q2] = cc.solve(cc.Scene(b1, b2))
    push, pull = out[-0.05], out[0.05]
    assert np.abs(push.u[0]).max() > 1e-6  # a charge alone deforms the body (about 1e-5 m here)
    assert push.contact.active.sum() >= 5  # closes (at the foundation's nodes; the piezo face bulges between)
    assert push.contact.force.sum() > 0 and push.u[1][:, 1].min() < 0
    assert pull.contact.active.sum() == 0 and pull.contact.jump.max() < -1e-7  # lifts off
    assert np.abs(pull.u[1]).max() == pytest.approx(0.0, abs=1e-12)


def test_purely_elastic_scene_gives_the_elastic_answer():
    """A piezo material with e = 0 reproduces the elastic solution and a zero potential."""
    iso = cc.materials.isotropic(E=100e9, nu=0.25)
    fake = cc.materials.Piezoelectric.from_matrices(iso.c, np.zeros((2, 3)), np.eye(2) * 1e-8)
    ref = cc.solve(two_blocks(mat1=iso))
    piezo = cc.solve(two_blocks(mat1=fake, surface_charge={}))
    assert rel(piezo.u[0], ref.u[0]) < 1e-8 and rel(piezo.u[1], ref.u[1]) < 1e-8
    assert np.abs(piezo.phi[0]).max() == 0.0 or np.abs(piezo.phi[0]).max() < 1e-12
    assert rel(piezo.contact.lam, ref.contact.lam) < 1e-7


def test_mirror_symmetric_scene_gives_mirror_symmetric_solution():
    m1 = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=16, ny=6)
    m2 = cc.rectangle(x=(0, 1), y=(-0.5, 0), nx=10, ny=4)
    b1 = cc.Body(m1, cc.materials.PZT4, clamped=["top"], grounded=["top"], contact="bottom",
                 body_force=lambda x, y: (0 * x, -2e9 * (1 + np.cos(2 * np.pi * (x - 0.5)))),
                 surface_charge={"left": -0.03, "right": -0.03})
    b2 = cc.Body(m2, cc.materials.isotropic(E=60e9, nu=0.3), clamped=["bottom"], contact="top")
    scene = cc.Scene(b1, b2)
    for condition in cc.CONDITIONS:
        sol = cc.solve(scene, condition)
        for k, body in enumerate(scene.bodies):
            p = body.mesh.points
            mirror = _mirror_index(p)
            u = sol.u[k]
            assert rel(u[mirror, 0], -u[:, 0]) < 1e-7 and rel(u[mirror, 1], u[:, 1]) < 1e-7
            if sol.phi[k] is not None:
                assert rel(sol.phi[k][mirror], sol.phi[k]) < 1e-7
        assert rel(sol.contact.lam[::-1], sol.contact.lam) < 1e-6
        assert np.array_equal(sol.contact.active[::-1], sol.contact.active)


def _mirror_index(p):
    q = np.column_stack([1.0 - p[:, 0], p[:, 1]])
    key = lambda a: np.lexsort(np.round(a, 12).T[::-1])
    i, j = key(p), key(q)
    out = np.empty(len(p), dtype=int)
    out[j] = i
    assert np.allclose(p[out], q, atol=1e-12)
    return out


@pytest.mark.parametrize("voltage", [None, -2e4])
@pytest.mark.parametrize("condition,n1,n2", [("gamma3", 7, 5), ("gamma3", 6, 6), ("sigma1", 6, 6),
                                             ("sigma2", 6, 6), ("sigma1", 8, 4), ("sigma2", 4, 8)])
def test_bonded_uniform_compression_patch_is_exact(condition, n1, n2, voltage):
    """K_h(Gamma_3) passes the patch test on any meshes; K_h(Sigma_h^l) when mesh l's nodes contain the other's.
    Driven by surface charge or by an electrode voltage (phi = V lifted into the loads)."""
    scene, exact = bonded_patch(n1, n2, voltage=voltage)
    sol = cc.solve(scene, condition)
    p1, p2 = (b.mesh.points for b in scene.bodies)
    assert exact["lam"] > 0
    assert rel(sol.u[0], exact["u1"](p1)) < 1e-8 and rel(sol.u[1], exact["u2"](p2)) < 1e-8
    assert rel(sol.phi[0], exact["phi1"](p1)) < 1e-8
    assert np.all(sol.contact.active[sol.contact.constrained])
    assert rel(sol.contact.lam, np.full_like(sol.contact.lam, exact["lam"])) < 1e-7
    for k in range(2):                 # the pressure felt by each body is the same uniform value
        x, p = sol.traction(k)
        assert len(x) == len(scene.interface.traces[k].x) and rel(p, np.full_like(p, exact["lam"])) < 1e-7


def test_node_to_segment_fails_patch_test_on_non_nested_meshes():
    """Documented limitation: K_h(Sigma_h^1) with 7 vs 5 cells is not exact (the multiplier cannot
    represent a uniform pressure on the other trace); K_h(Gamma_3) on the same meshes is exact."""
    scene, exact = bonded_patch(7, 5)
    err = {c: rel(cc.solve(scene, c).u[1], exact["u2"](scene.bodies[1].mesh.points)) for c in ("gamma3", "sigma1")}
    assert err["gamma3"] < 1e-8 and err["sigma1"] > 1e-4


@pytest.mark.parametrize("factor", [1e-9, 1e-3, 1e4])
def test_linearity_in_load_magnitude_without_warnings(scene, solutions, factor):
    ref = solutions["gamma3"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = cc.solve(two_blocks(scale=factor), "gamma3")
    assert sol.ok
    for k in range(2):
        assert rel(sol.u[k] / factor, ref.u[k]) < 1e-8
    assert rel(sol.phi[0] / factor, ref.phi[0]) < 1e-8
    assert rel(sol.contact.lam / factor, ref.contact.lam) < 1e-7


@pytest.mark.skipif("OSQP" not in __import__("cvxpy").installed_solvers(), reason="OSQP not installed")
def test_other_cvxpy_solver_can_be_named(scene, solutions):
    sol = cc.solve(scene, "gamma3", solver="OSQP", tol=1e-3,
                   solver_options=dict(eps_abs=1e-10, eps_rel=1e-10, max_iter=200000))
    assert rel(sol.u[0], solutions["gamma3"].u[0]) < 1e-4
