"""The bulk energy as a term (issue 31): the Hencky material (docs/materials.md), posed by the full backend only and
finished exactly by Newton on the nonlinear mixed system (26) with the contact active set
(:func:`cvxcontact.backends.signorini.newton_finish`), checked against the closed form of uniaxial strain, the linear
material in its limits, the interior point, a dense Newton (tests/references.py), and the equilibrium of (26) with the
nonlinear internal forces. Tolerances are 100x the measured values (or the finish's rounding)."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from conftest import rel, two_blocks
from hencky_scenes import EXACT, NU, SIGMA_Y, E, H, indented, pressed_block, uniaxial_stress
from cvxcontact.backends import choose, describe
from cvxcontact.backends.finish import Declined, solve_sparse_compliance
from cvxcontact.backends.mixed import mixed_system
from cvxcontact.backends.result import Finish
from cvxcontact.contact.laws import RowLaws, Signorini
from cvxcontact.discrete import build_problem
from cvxcontact.fem.space import space
from cvxcontact.physics.materials import deviator
from references import dense_newton

TOL = 1e-3          # the checks of an unfinished interior point: measured <= 5e-6 (complementarity),
#                     1.4e-6 (equilibrium)


def checked(scene, **kw):
    """cc.solve by the full route (the reference; ``auto`` takes the fast one, tests/test_hencky_fast.py), finished by
    Newton on (26): sol.ok at the default tol, the route and finish of that finish."""
    kw.setdefault("method", "full")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(scene, estimate=False, **kw)
    assert sol.ok and sol.polished and sol.status == "optimal", sol.report()
    assert sol.info.route == cc.Route.INTERIOR_POINT_FINISHED and sol.info.finish == Finish.NEWTON_BULK
    assert sol.residuals()["equilibrium"] < EXACT, sol.residuals()
    return sol


def interior_point(scene):
    """The full program's answer unfinished (polish=False): checked at TOL (Clarabel may end
    "optimal_inaccurate" on these SOCPs, then sol.ok is False)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = cc.solve(scene, tol=TOL, estimate=False, polish=False, method="full")
    assert sol.info.route == cc.Route.INTERIOR_POINT_NONLINEAR_ENERGY and not sol.polished
    assert max(sol.residuals().values()) < TOL, sol.residuals()
    return sol


def test_the_deviator_and_the_stress_are_those_of_the_tensors():
    """|P eps| is the Frobenius norm of the deviatoric tensor (plane strain: eps_zz = 0 kept in the deviator);
    the stress is the gradient of the density (central differences) and the tangent that of the stress."""
    mat, rng = cc.materials.hencky(E, NU, SIGMA_Y, H), np.random.default_rng(3)
    for dim, idx in ((2, [[0, 2, None], [2, 1, None], [None, None, None]]),
                     (3, [[0, 5, 4], [5, 1, 3], [4, 3, 2]])):
        P, t = deviator(dim)
        eps = rng.normal(size=3 if dim == 2 else 6) * 4e-3                   # beyond yield (s_y = 1.5e-3)
        T = np.array([[0.0 if i is None else eps[i] * (1 if r == c else 0.5) for c, i in enumerate(row)]
                      for r, row in enumerate(idx)])
        assert abs(np.linalg.norm(T - np.trace(T) / 3 * np.eye(3)) - np.linalg.norm(P @ eps)) < 1e-15
        step = 1e-9
        grad = [(mat.density(eps + step * e, dim) - mat.density(eps - step * e, dim)) / (2 * step)
                for e in np.eye(len(eps))]
        assert rel(mat.stress(eps, dim), grad) < 1e-6                        # measured 3e-11 to 8e-11
        hess = [(mat.stress(eps + step * e, dim) - mat.stress(eps - step * e, dim)) / (2 * step)
                for e in np.eye(len(eps))]
        assert rel(mat.tangent(eps, dim), np.array(hess).T) < 1e-5           # measured below 1e-7


@pytest.mark.parametrize("strain", [-2e-3, -1e-2])    # below yield (at -3.7e-3), above it
def test_uniaxial_strain_follows_the_closed_form(strain):
    sol = checked(pressed_block(cc.materials.hencky(E, NU, SIGMA_Y, H), strain))
    assert sol.info.method == "full"
    expected = -uniaxial_stress(strain)
    assert rel(sol.contact.lam, np.full_like(sol.contact.lam, expected)) < 1e-12     # measured 6.3e-16, 6.5e-16
    assert abs(sol.obstacles[0].force[1] - expected) < 1e-12 * abs(expected)        # measured 1.6e-16
    ip = interior_point(pressed_block(cc.materials.hencky(E, NU, SIGMA_Y, H), strain))
    assert rel(ip.contact.lam, sol.contact.lam) < 1e-3                              # measured 2.5e-6, 1.0e-5


def test_h_one_and_a_huge_yield_stress_are_the_linear_material():
    """h = 1 (no softening) and sigma_y -> inf (1e15 Pa) (never yields) give psi(s) = s^2: the linear isotropic
    material, to rounding after the Newton finish, on the pressed block and on a circle pressed into a clamped block
    (whose answer the linear material's condensed route and LCP finish give independently); a finite sigma_y that
    the strain passes does not."""
    lin = cc.solve(pressed_block(cc.materials.isotropic(E, NU), -1e-2), estimate=False)
    for mat in (cc.materials.hencky(E, NU, SIGMA_Y, 1.0), cc.materials.hencky(E, NU, 1e15, H)):
        sol = checked(pressed_block(mat, -1e-2))
        assert rel(sol.contact.lam, lin.contact.lam) < 1e-12, mat     # measured 6.3e-16, 8.9e-16
    circle = cc.solve(indented(cc.materials.isotropic(E, NU)), estimate=False)
    sol = checked(indented(cc.materials.hencky(E, NU, SIGMA_Y, 1.0)))
    assert circle.info.method == "condensed" and sol.info.iterations > 0
    assert rel(sol.u[0], circle.u[0]) < 1e-12                          # measured 5.8e-16
    assert rel(sol.contact.lam, circle.contact.lam) < 1e-12            # measured 1.1e-15
    soft = checked(pressed_block(cc.materials.hencky(E, NU, SIGMA_Y, H), -1e-2))
    assert rel(soft.contact.lam, lin.contact.lam) > 0.1           # the closed forms: 1 - 7.392/9.423 = 0.2155


def test_the_energy_object_answers_and_the_fast_routes_refuse():
    scene = two_blocks(mat2=cc.materials.hencky(E, NU, SIGMA_Y, H))
    problem = build_problem(scene, space(1), "gamma3", cc.Signorini())
    assert not problem.quadratic and not describe(problem).quadratic_energy
    assert choose("auto", describe(problem)) == "newton"          # the fast route (tests/test_hencky_fast.py)
    for method in ("condensed", "sparse", "amg"):
        with pytest.raises(cc.SolverError, match=f"method '{method}' does not accept"):
            cc.solve(scene, method=method)
    with pytest.raises(cc.SolverError, match="method 'full' does not accept"):    # its compliance finish is on Kuu
        cc.solve(scene, law=cc.NormalCompliance(stiffness=1e12, exponent=1.0), method="full")
    # the energy's gradient and Hessian against central differences of its value (scaled, random point)
    bulk, rng = problem.blocks[1].bulk, np.random.default_rng(0)
    z = rng.normal(size=bulk.A.shape[1]) * 50 / problem.units.load * 1e-6 * problem.units.length
    dz = rng.normal(size=z.size) * 1e-6 * np.abs(z).max()
    difference = bulk.value(z + dz) - bulk.value(z - dz)
    assert abs(difference - 2 * bulk.gradient(z) @ dz) < 1e-6 * abs(bulk.gradient(z) @ dz)
    assert rel(bulk.gradient(z + dz) - bulk.gradient(z - dz), 2 * bulk.hessian(z) @ dz) < 1e-5


def test_a_hencky_block_under_a_circle_is_the_newton_answer():
    """A rigid circle pressed into a Hencky block: the finished answer is the interior point's (to its accuracy), the
    answer of a dense Newton written here (to rounding), yields under the circle, and the Newton steps of the finish
    from the rest state converge quadratically (each residual below C times the square of the one before, once
    below 1e-2)."""
    mat = cc.materials.hencky(E, NU, SIGMA_Y, H)
    scene = indented(mat, nx=24, ny=8, depth=5e-3)
    sol, ip = checked(scene), interior_point(scene)
    assert rel(ip.u[0], sol.u[0]) < 3e-3 and rel(ip.contact.lam, sol.contact.lam) < 3e-3    # measured 2.0e-5, 1.0e-5
    problem = build_problem(scene, space(1), "gamma3", cc.Signorini())
    bulk, block, un = problem.blocks[0].bulk, problem.blocks[0], problem.units
    G = (problem.E @ block.jump).toarray()
    z, y, active = dense_newton(bulk, block.f, G, problem.g)
    x = sol.u[0].ravel() @ problem.systems[0].Tu / un.displacement
    assert rel(x, z) < 1e-12                                    # measured 1.4e-16
    assert active.sum() >= 3 and (y[active] > 0).all()
    s = np.linalg.norm(bulk.strains(z) @ deviator(2)[0].T, axis=1)
    assert (s > mat.s_y).sum() >= 10                            # measured 67 of 384 points yielded
    # the finish's own steps from the rest state (the sparse route's start): quadratic convergence
    op, Gs, _ = mixed_system(problem)
    out = solve_sparse_compliance(op, Gs, problem.g, np.zeros(len(problem.g)),
                                  RowLaws.uniform(Signorini(), len(problem.g)), np.zeros(Gs.shape[1]), problem.g < 0)
    assert not isinstance(out, Declined), out
    assert rel(out[0], z) < 1e-10 and (out[3] == active).all()
    history = np.array(out[5])
    print("relative residuals of (26) per Newton step:", " ".join(f"{h:.1e}" for h in history))
    # measured: 6.5e-01 1.0 1.0 1.0 1.3e-01 5.8e-03 4.1e-06 4.3e-12 5.8e-14 | 9.7e-01 2.3e-01 3.6e-02 1.1e-03
    # 5.8e-07 5.2e-13 1.1e-13 (| an active-set change; one 1.1e-13 more before the steps stopped at their own floor):
    # r_k+1 / r_k^2 <= 1.5 (a linear rate rho would need rho < 150 r_k, 1e-4 at these r_k, to pass)
    pairs = [(a, b) for a, b in zip(history, history[1:]) if 1e-11 < a < 1e-2 and b > 1e-13]
    assert len(pairs) >= 3 and all(b <= 150 * a ** 2 for a, b in pairs), history


def test_a_hencky_block_in_contact_is_in_equilibrium_with_its_nonlinear_forces():
    """two_blocks with the lower block Hencky: the finished answer satisfies (26) with the nonlinear internal forces
    to rounding; yielded points exist (the nonlinear branch is exercised) and the answer differs from the linear
    one."""
    mat = cc.materials.hencky(E, NU, 1e8, H)
    sol = checked(two_blocks(mat2=mat, scale=4.0))
    lin = cc.solve(two_blocks(scale=4.0), estimate=False)
    assert sol.info.method == "full" and lin.info.method == "condensed"
    problem = build_problem(two_blocks(mat2=mat, scale=4.0), space(1), "gamma3", cc.Signorini())
    bulk = problem.blocks[1].bulk
    z = sol.u[1].ravel() @ problem.systems[1].Tu / problem.units.displacement    # free dofs of body 2, scaled
    s = np.linalg.norm(bulk.strains(z) @ deviator(2)[0].T, axis=1)
    assert (s > mat.s_y).any() and rel(sol.u[1], lin.u[1]) > 1e-3


def test_a_user_model_of_a_hencky_body_is_not_finished_as_a_linear_one():
    """cc.Model with a user row on a Hencky body: the exact finish solves linear systems of Kuu, so it is not
    run (a linear finish there moved u by 3.5e-6 and read equilibrium 3.6e-2); the interior-point answer
    passes the checks with the nonlinear forces and equals cc.solve's (the user row does not bind)."""
    scene = pressed_block(cc.materials.hencky(E, NU, SIGMA_Y, H), -1e-2)
    ref = checked(scene)
    model = cc.Model(scene, tol=TOL)
    model.add(model.u(0)[:, 0] <= 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = model.solve()
    assert not sol.polished
    # measured (Haswell, Nehalem): equilibrium 1.7e-7, complementarity 1.7e-5 (user row 4.8e-6), u 3.9e-6 apart
    assert max(sol.residuals().values()) < 2e-3, sol.residuals()
    assert rel(sol.u[0], ref.u[0]) < 1e-3


def sphere_pressed(material):
    """A block (0, 1)^2 x (0, 0.5) m (3 x 3 x 2 cells) clamped at its bottom, a rigid sphere pressed into its top."""
    body = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=3, ny=3, nz=2), material, clamped=["bottom"])
    return cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere((0.5, 0.5, 2.5 - 1e-3), 2.0))])


@pytest.mark.numerics
@pytest.mark.parametrize("case", ["P1", "P2", "3D P1"])
def test_the_tangent_is_the_product_of_the_strain_map_and_the_moduli(case):
    """StrainEnergy.hessian (assembled point by point onto its fixed pattern) equals A^T diag(w C) A formed here by
    sparse products from the strain map A and the material's tangent C at a strained state where some points yield
    and some do not; its pattern is that of |A|^T |A| (the points' couplings)."""
    scene = {"P1": lambda: indented(cc.materials.hencky(E, NU, SIGMA_Y, H), nx=10, ny=4),
             "P2": lambda: indented(cc.materials.hencky(E, NU, SIGMA_Y, H), nx=6, ny=2),
             "3D P1": lambda: sphere_pressed(cc.materials.hencky(E, NU, SIGMA_Y, H))}[case]()
    fem = space(2) if case == "P2" else space(1, "tetra") if case == "3D P1" else space(1)
    problem = build_problem(scene, fem, "sigma1" if case == "P2" else "gamma3", cc.Signorini())
    bulk = problem.blocks[0].bulk
    z = np.random.default_rng(5).normal(size=bulk.A.shape[1])
    z *= 1e-2 / np.abs(bulk.strains(z)).max()                            # strains up to 1e-2 (s_y = 3e-3)
    s = np.linalg.norm(bulk.strains(z) @ deviator(bulk.dim)[0].T, axis=1)
    assert (s > bulk.material.s_y).any() and (s < bulk.material.s_y).any()
    C = bulk.material.tangent(bulk.strains(z), bulk.dim) * bulk.w[:, None, None]
    D = sp.block_diag(list(C), format="csr")
    expected = (bulk.A.T @ D @ bulk.A).toarray()
    H_ = bulk.hessian(z)
    assert rel(H_.toarray(), expected) < 1e-13                           # measured <= 5.3e-16
    coupled = (abs(bulk.A).T @ sp.block_diag([np.ones_like(c) for c in C]) @ abs(bulk.A)).toarray() > 0
    assert np.array_equal(bulk.pattern().toarray() > 0, coupled)
    assert np.array_equal(H_.indptr, bulk.pattern().indptr) and np.array_equal(H_.indices, bulk.pattern().indices)


@pytest.mark.numerics
@pytest.mark.parametrize("case", ["P1", "P2", "3D P1", "Q2"])
def test_the_initial_tangent_is_the_assembled_stiffness_and_the_points_sum(case):
    """The Hessian at zero strain, taken from the assembled stiffness (the block's T_u^T Kuu T_u, summed element by
    element by the stiffness assembly) and summed point by point (a StrainEnergy given no stiffness), both equal
    A^T diag(w C_0) A formed here by sparse products (C_0 the material's tangent at zero strain), on the pattern."""
    material = cc.materials.hencky(E, NU, SIGMA_Y, H)
    quad = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=5, ny=3, cell="quad"), material, clamped="bottom")
    scene = {"P1": lambda: indented(material, nx=10, ny=4), "P2": lambda: indented(material, nx=6, ny=2),
             "3D P1": lambda: sphere_pressed(material),
             "Q2": lambda: cc.Scene(quad, contacts=[cc.Contact(quad, "top", cc.Rigid.circle((0.47, 1.097), 0.6))])
             }[case]()
    fem = {"P1": space(1), "P2": space(2), "3D P1": space(1, "tetra"), "Q2": space(2, "quad")}[case]
    problem = build_problem(scene, fem, "gamma3" if case in ("P1", "3D P1") else "sigma1", cc.Signorini())
    block = problem.blocks[0]
    bulk, system = block.bulk, problem.systems[0]
    points = type(bulk)(system, problem.units)                            # no stiffness: summed point by point
    assert bulk._assembled() is not None and points._assembled() is None
    C0 = bulk.material.tangent(np.zeros((1, bulk.s)), bulk.dim)[0]
    expected = (bulk.A.T @ sp.block_diag([C0 * w for w in bulk.w], format="csr") @ bulk.A).toarray()
    zero = np.zeros(bulk.A.shape[1])
    for energy in (bulk, points):
        H0 = energy.hessian(zero)
        assert rel(H0.toarray(), expected) < 1e-13                        # measured <= 8.5e-16 (either way)
        assert np.array_equal(H0.indptr, energy.pattern().indptr) and np.array_equal(H0.indices,
                                                                                    energy.pattern().indices)


def test_a_prepared_solver_refuses_a_hencky_material_with_other_constants():
    """The yield stress and the hardening ratio are geometry, not loads: a ContactSolver prepared for one Hencky
    material refuses a scene whose body has the same tangent c but another sigma_y or h (it was accepted and
    solved with the prepared material's energy: u 25 % away from a direct solve of the new scene, measured), and
    accepts an equal material built afresh."""
    from cvxcontact.physics.fingerprint import geometry_fingerprint

    base = indented(cc.materials.hencky(E, NU, SIGMA_Y, H), nx=4, ny=2)
    solver = cc.ContactSolver(base, method="full", estimate=False)
    for other in (cc.materials.hencky(E, NU, 5 * SIGMA_Y, H), cc.materials.hencky(E, NU, SIGMA_Y, 0.5)):
        scene = indented(other, nx=4, ny=2)
        assert geometry_fingerprint(scene.bodies[0]) != geometry_fingerprint(base.bodies[0])
        with pytest.raises(cc.SceneError, match="material"):
            solver.solve(scene)
    twin = indented(cc.materials.hencky(E, NU, SIGMA_Y, H), nx=4, ny=2)
    assert geometry_fingerprint(twin.bodies[0]) == geometry_fingerprint(base.bodies[0])
    # a linear material's fingerprint reads c, e, kappa only, as before: the same c gives the same print
    lin = cc.Body(base.bodies[0].mesh, cc.materials.isotropic(E, NU), clamped="bottom", contact="top")
    assert geometry_fingerprint(lin) == geometry_fingerprint(lin.with_changes(material=cc.materials.isotropic(E, NU)))
