"""The 3D P2 copositive cones ("gamma3" on 10-node tetrahedra, docs/formulation.md §16) beside a non-quadratic bulk
energy (a Hencky body, docs/materials.md §8; issue 31, docs/refusals.md row 35, once refused): the full CVXPY
program, finished by accumulated cuts on the nonlinear (26) (:mod:`cvxcontact.backends.bulkcuts`: the nodal problem
at the cut points solved by sequential quadratic steps on the Hencky tangent, the cuts accepted by the exact
Bernstein maximum of every triangle's slack). Checked against (26)-(27) with the nonlinear stress (the read-back),
the condition sampled on every overlay triangle from each body's own P2 face functions (not through X_h nor the
Bernstein form), the interior point of the CVXPY program, the elastic limit (a yield stress never reached: the
linear material's answer, the condensed route's), and the nodal condition, which penetrates between its nodes; a pair
of blocks held by their supports and a force-controlled sphere too. Small meshes (2 x 2 x 1 to 3 x 3 x 2 cells): the
full route is slow in 3D. Tolerances: >= 100x the measured values (beside them)."""

import warnings

import numpy as np
import pytest
from conftest import rel
from scenes3d import (
    NU,
    STEEL,
    E,
    bumped_blocks,
    bumped_gap,
    pressed_blocks,
    pressed_key,
    pzt_on_block,
    sampled_penetration,
    sphere_on_block,
    three_blocks,
)

import cvxcontact as cc
from cvxcontact.apps.studies.convergence_hencky import plastic_zone
from cvxcontact.backends.result import Finish, Route
from cvxcontact.errors import ResidualWarning
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics

YIELDING = cc.materials.hencky(E=E, nu=NU, sigma_y=8e6, h=0.1)     # yields under the contact zone (41 of 192 points)
NEVER = cc.materials.hencky(E=E, nu=NU, sigma_y=1e15, h=0.1)       # no strain reaches its yield stress


def blocks(material):
    """:func:`scenes3d.bumped_blocks` with a lower block of ``material``, 2 x 2 x 1 cells below, 3 x 2 x 1 above
    (non-matching faces; the upper block held by the contact, the finish on the sparse mixed system)."""
    return bumped_blocks((2, 2), (3, 2), material=material, nz=1)


def penetration(sol, material, scene=blocks) -> float:
    """The largest sampled [u_nu] - g on 496 points of every overlay triangle of ``scene(material)``, over the
    largest displacement."""
    over = sampled_penetration(scene(material), sol, bumped_gap, n=30)
    return float(over.max() / max(np.abs(u).max() for u in sol.u))


def interior_point(material):
    """The full program's interior point, not finished (its status may read "optimal_inaccurate")."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        return cc.solve(blocks(material), "gamma3", degree=2, polish=False, tol=1e-3)


@pytest.fixture(scope="module")
def yielding():
    return cc.solve(blocks(YIELDING), "gamma3", degree=2)


@pytest.fixture(scope="module")
def linear():
    return cc.solve(blocks(STEEL), "gamma3", degree=2)


def test_a_yielding_block_under_the_copositive_cones_is_finished_and_balances_26_27(yielding):
    """The full route (auto), finished by the accumulated cuts on the nonlinear (26); the lower block yields under
    the contact zone only (measured 41 of 192 quadrature points); (26)-(27) with the nonlinear stress (measured
    equilibrium 6.2e-16, feasibility 4.8e-12, cone 1.5e-16, complementarity 1.8e-8, read on the point forces as
    for a linear material: 2.7e-8 in the elastic limit)."""
    sol = yielding
    assert sol.info.method == "full" and sol.info.requested == "auto" and sol.info.declined is None
    assert sol.polished and sol.info.finish == Finish.ACCUMULATED_CUTS, sol.report()
    zone = plastic_zone(sol, body=0)
    assert 0 < zone["yielded"] < zone["points"], zone
    res = sol.residuals()
    assert sol.ok and res["equilibrium"] < 1e-13 and res["feasibility"] < 1e-9 and res["cone"] < 1e-14, res
    assert res["complementarity"] < 1e-5, res
    assert sol.in_contact().any() and not sol.in_contact().all()


def test_the_condition_holds_on_every_triangle_where_the_nodal_one_penetrates(yielding):
    """[u_nu] <= g sampled on 496 points of every overlay triangle from each body's own P2 face functions
    (measured max -7.3e-9 of the largest displacement: no penetration anywhere); the nodal condition "sigma1" with
    the same Hencky block penetrates between its nodes (measured 7.4e-2) and its answer is another (3.2e-1)."""
    assert penetration(yielding, YIELDING) <= 1e-9
    nodal = cc.solve(blocks(YIELDING), "sigma1", degree=2)
    assert nodal.ok and penetration(nodal, YIELDING) > 1e-3 and rel(nodal.u[0], yielding.u[0]) > 1e-2


def test_the_yielding_answer_is_not_the_linear_one(yielding, linear):
    """The nonlinear branch is exercised: the lower block's displacements differ from the linear material's by
    0.11 (measured), lambda_h by 0.045; the contact zone is as wide or wider (measured 64 nodes against 63)."""
    assert linear.ok and rel(yielding.u[0], linear.u[0]) > 1e-2
    assert rel(yielding.contact.lam, linear.contact.lam) > 4e-3
    assert yielding.in_contact().sum() >= linear.in_contact().sum()


def test_the_interior_point_of_the_cvxpy_program_agrees_with_the_finish(yielding):
    """The reference: the full program's interior point (polish=False) within 1e-5 of the finished answer in u and
    3e-5 in lambda_h (measured 3.6e-8 and 1.7e-7: the interior point's own accuracy)."""
    ipm = interior_point(YIELDING)
    assert not ipm.polished and ipm.info.route == Route.INTERIOR_POINT_NONLINEAR_ENERGY
    assert all(rel(a, b) <= 1e-5 for a, b in zip(ipm.u, yielding.u))
    assert rel(ipm.contact.lam, yielding.contact.lam) <= 3e-5


def test_a_block_that_never_yields_gives_the_linear_answer(linear):
    """The elastic limit: a Hencky block whose yield stress no strain reaches has the linear material's energy, and
    its answer (the cuts on the nonlinear (26)) is the linear material's (the cuts on the linear (26)) within 2e-6
    in u and 1e-5 in lambda_h (measured 1.2e-8 and 6.2e-8: the linear finish stops at a cut violation of 1e-11 of
    the displacements, this one at 1e-13, at other points; the interior point is as far, 1.2e-8), on the same
    closed nodes; no penetration sampled (measured -4.3e-11)."""
    sol = cc.solve(blocks(NEVER), "gamma3", degree=2)
    assert sol.info.method == "full" and sol.polished and sol.info.finish == Finish.ACCUMULATED_CUTS
    assert plastic_zone(sol, body=0)["yielded"] == 0
    assert linear.ok and linear.polished and sol.ok
    assert all(rel(a, b) <= 2e-6 for a, b in zip(sol.u, linear.u))
    assert rel(sol.contact.lam, linear.contact.lam) <= 1e-5
    assert np.array_equal(sol.in_contact(), linear.in_contact())
    assert penetration(sol, NEVER) <= 1e-9


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")     # a zone of 3 faces on these coarse meshes
def test_blocks_held_by_their_supports_yield_and_never_yielding_give_the_linear_answer_to_rounding(shared):
    """Both blocks held by their supports (:func:`scenes3d.pressed_blocks`, the upper pushed down 20 um): the linear
    material's answer is the condensed route's, finished by Newton at the tangency points to rounding. A Hencky
    lower block that never yields gives it to rounding (measured 1.8e-15 in u, 1.0e-13 in lambda_h, the same
    closed nodes; its finish: the tangency Newton on the nonlinear (26)); one that yields (sigma_y = 1 MPa:
    measured 67 of 432 points) is finished by the cuts on the nonlinear (26) (measured equilibrium 4.1e-16,
    feasibility 5.2e-13, no penetration sampled: -7.5e-9 of the largest displacement) and is 0.12 from the linear
    answer. The linear answer is shared with tests/test_copositive.py (:func:`scenes3d.pressed_key`)."""
    linear = shared(*pressed_key())
    assert linear.ok and linear.info.method == "condensed" and linear.info.finish == Finish.TANGENCY_NEWTON
    never = cc.solve(pressed_blocks(material=NEVER), "gamma3", degree=2)
    assert never.info.method == "full" and never.polished and never.ok
    assert all(rel(a, b) <= 1e-12 for a, b in zip(never.u, linear.u))
    assert rel(never.contact.lam, linear.contact.lam) <= 1e-10
    assert np.array_equal(never.in_contact(), linear.in_contact())
    soft = cc.materials.hencky(E=E, nu=NU, sigma_y=1e6, h=0.1)
    sol = cc.solve(pressed_blocks(material=soft), "gamma3", degree=2)
    assert sol.polished and sol.info.finish == Finish.ACCUMULATED_CUTS and 0 < plastic_zone(sol, body=0)["yielded"]
    res = sol.residuals()
    assert sol.ok and res["equilibrium"] < 1e-13 and res["feasibility"] < 1e-8 and res["cone"] < 1e-14, res
    assert penetration(sol, soft, lambda m: pressed_blocks(material=m)) <= 1e-9
    assert rel(sol.u[0], linear.u[0]) > 1e-2


def test_a_force_controlled_sphere_on_a_hencky_block_is_finished_and_balanced():
    """A rigid sphere under a prescribed force (2e8 N) on a Hencky block (3 x 3 x 2 cells; the sphere's own gap, a
    translation unknown): finished by Newton at the tangency points on the nonlinear (26) (cones.finish_bulk's
    first finish, which settles here); the block yields under the sphere (sigma_y = 1 GPa: measured 55 of 864
    points); (26)-(27) and the obstacle's balance (measured equilibrium 1.6e-16, feasibility 8.9e-17, cone
    7.9e-17, obstacle balance 1.5e-16). A block that never yields gives the linear material's answer (the
    condensed route's) to rounding (measured 7.4e-16 in u, 3.4e-16 in lambda_h)."""
    linear = cc.solve(sphere_on_block(force=2e8, n=(3, 3, 2)), "gamma3", degree=2)
    assert linear.ok and linear.polished
    never = cc.solve(sphere_on_block(force=2e8, n=(3, 3, 2), material=NEVER), "gamma3", degree=2)
    assert never.info.method == "full" and never.polished and never.ok
    assert rel(never.u[0], linear.u[0]) <= 1e-12 and rel(never.contact.lam, linear.contact.lam) <= 1e-12
    hard = cc.materials.hencky(E=E, nu=NU, sigma_y=1e9, h=0.1)
    sol = cc.solve(sphere_on_block(force=2e8, n=(3, 3, 2), material=hard), "gamma3", degree=2)
    assert sol.polished and sol.info.finish == Finish.TANGENCY_NEWTON, sol.report()
    zone = plastic_zone(sol, body=0)
    assert 0 < zone["yielded"] < zone["points"], zone
    res = sol.residuals()
    assert sol.ok and res["equilibrium"] < 1e-13 and res["feasibility"] < 1e-13 and res["cone"] < 1e-14, res
    assert res["obstacle balance"] < 1e-13, res


def test_where_the_cuts_on_the_nonlinear_26_decline_the_interior_point_is_kept_and_flagged(yielding, monkeypatch):
    """No sequential quadratic step allowed (``BULK_STEPS`` = 0: every round declines): the answer is the interior
    point's, not polished, with a ResidualWarning and ``info.declined`` naming both finishes tried (the tangency
    Newton on the nonlinear (26) and the cuts on it); it is the finished answer's to the interior point's accuracy
    (measured 3.6e-8 in u)."""
    from cvxcontact.backends import bulkcuts

    monkeypatch.setattr(bulkcuts, "BULK_STEPS", 0)
    with pytest.warns(ResidualWarning, match="declined"):
        sol = cc.solve(blocks(YIELDING), "gamma3", degree=2)
    assert not sol.polished and sol.info.route == Route.INTERIOR_POINT_NONLINEAR_ENERGY
    assert "the accumulated cuts on the nonlinear (26)" in sol.info.declined, sol.info.declined
    assert "tangency" in sol.info.declined, sol.info.declined
    assert all(rel(a, b) <= 1e-5 for a, b in zip(sol.u, yielding.u))


def energy_and_residual(scene, u, body=0):
    """The bodies' energy of the displacements ``u`` (one array per body) (J: sum of the Hencky density W over the quadrature points of each Hencky
    body, the quadratic form of Kuu of a linear one, less the loads' work) and, for body ``body`` (a Hencky one),
    the largest free component of its internal force from the material's own stress formula less its loads,
    away from its contact face z = 0.5 and tangential on it, over the largest internal force component (the
    frictionless (26) of that body, not through the package's contact rows)."""
    total, worst = 0.0, None
    for k, b in enumerate(scene.bodies):
        el = space(2, b.mesh.cell)
        nodes = el.nodes(b)
        s = el.assemble_loads(b, el.assemble_matrices(b, nodes), nodes)
        x = np.asarray(u[k]).ravel()
        if s.strain is None:
            total += 0.5 * float(x @ (s.Kuu @ x)) - float(s.f @ x)
            continue
        eps = (s.strain @ x).reshape(len(s.weights), -1)
        total += float(s.weights @ b.material.density(eps, 3)) - float(s.f @ x)
        if k == body:
            force = s.strain.T @ (s.weights[:, None] * b.material.stress(eps, 3)).ravel()
            r = s.Tu.T @ (force - s.f)
            node, comp = s.u_free // 3, s.u_free % 3
            face = np.isclose(np.asarray(nodes.points)[node, 2], 0.5)
            worst = float(np.abs(r[~face | (comp < 2)]).max() / np.abs(force).max())
    return total, worst


def test_a_hencky_block_under_a_driven_piezoelectric_block_is_finished():
    """A PZT-5A block driven at 50 V pressed on a yielding Hencky block (measured 46 of 192 points): the cuts on
    the nonlinear (26) oscillate at a violation of 1.1e-12 (the rounds' active-set solves close their rows to
    1e-12) without reaching 1e-13 in 40 rounds nor stalling below 1e-12; the last round is accepted at the linear
    finish's 1e-11 (it declined before, leaving the interior point's answer: equilibrium 4.2e-9). Independent
    checks: no penetration sampled (measured -9.1e-12 of the largest displacement), the Hencky body's (26) off
    its contact face from the material's stress formula (measured 7.7e-16), the interior point within 1e-5 in u
    and phi (measured 6.9e-8, 7.0e-8)."""
    scene = pzt_on_block(YIELDING)
    sol = cc.solve(scene, "gamma3", degree=2)
    assert sol.info.method == "full" and sol.info.declined is None, sol.info.declined
    assert sol.polished and sol.info.finish == Finish.ACCUMULATED_CUTS and sol.ok, sol.report()
    assert 0 < plastic_zone(sol, body=0)["yielded"]
    res = sol.residuals()
    assert res["equilibrium"] < 1e-13 and res["feasibility"] < 1e-9, res
    assert penetration(sol, YIELDING, pzt_on_block) <= 1e-9
    assert energy_and_residual(scene, sol.u)[1] < 1e-13
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        ipm = cc.solve(scene, "gamma3", degree=2, polish=False, tol=1e-3)
    assert rel(ipm.u[0], sol.u[0]) <= 1e-5 and rel(ipm.phi[1], sol.phi[1]) <= 1e-5


def test_a_nearly_perfectly_plastic_block_yielding_everywhere_is_the_least_energy():
    """sigma_y = 1 kPa, h = 0.001: every quadrature point yields (192 of 192), the deviatoric stiffness 1000 times
    smaller; the cuts on the nonlinear (26) end at a violation of about 1.2e-12 (accepted at 1e-11; they declined
    before, leaving the interior point's answer: equilibrium 1.2e-4). The answer is the least energy (the
    material's density summed at the quadrature points): the interior point of the CVXPY program at tol 1e-8,
    feasible (sampled -6.3e-14), is higher by 1.1e-2 J, a relative 9.7e-8 (measured; 7.8e-3 J under the Prescott
    and Sandybridge kernels; asserted > 0: the energy's rounding is about 1e-9 J), and the energy rises along the
    segment toward it (measured 1.1e-4 J a tenth of the way, 7.9e-5 J under Prescott; a thousandth of the way is
    at rounding there, -1.8e-9 J); the (26) of the block from the material's
    stress formula off its contact face: measured 9.1e-13 (asserted 1e-10); sampled penetration 2.3e-12 of the
    largest displacement."""
    material = cc.materials.hencky(E=E, nu=NU, sigma_y=1e3, h=1e-3)
    scene = blocks(material)
    sol = cc.solve(scene, "gamma3", degree=2)
    assert sol.polished and sol.info.finish == Finish.ACCUMULATED_CUTS and sol.ok, sol.report()
    zone = plastic_zone(sol, body=0)
    assert zone["yielded"] == zone["points"], zone
    assert penetration(sol, material) <= 1e-9
    energy, residual = energy_and_residual(scene, sol.u)
    assert residual < 1e-10
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        ipm = cc.solve(scene, "gamma3", degree=2, polish=False, tol=1e-8)
    assert penetration(ipm, material) <= 1e-9
    assert energy_and_residual(scene, ipm.u)[0] > energy
    between = [a + 0.1 * (b - a) for a, b in zip(sol.u, ipm.u)]
    assert energy_and_residual(scene, between)[0] > energy


def test_a_hencky_block_between_two_pairs_yielding_everywhere_is_the_uniaxial_closed_form():
    """Three blocks stacked under rollers (:func:`scenes3d.three_blocks`: two pairs of non-matching faces), the
    middle one Hencky (sigma_y = 2 MPa, h = 0.1) yielding at every quadrature point under p = 10 MPa: uniaxial
    strain, eps_zz = -p / c33 in the steel blocks and, in the Hencky one, sigma_zz = (K + 4 h mu / 3) e
    - 2 sqrt(2/3) (1 - h) mu s_y = -p (|dev eps| = sqrt(2/3) |e| beyond s_y = sigma_y / (sqrt(6) mu)), by hand,
    not from the material's code: e = -1.42e-4 against -1.06e-4 linear. The finish (the cuts on the nonlinear
    (26)) is it within 1e-9 of the largest displacement (measured 2.2e-12)."""
    p, sigma_y, h = 1e7, 2e6, 0.1
    material = cc.materials.hencky(E=E, nu=NU, sigma_y=sigma_y, h=h)
    scene = three_blocks(p=p, middle=material)
    sol = cc.solve(scene, "gamma3", degree=2)
    assert sol.polished and sol.ok and sol.info.declined is None, sol.report()
    zone = plastic_zone(sol, body=1)
    assert zone["yielded"] == zone["points"], zone
    mu, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    c33 = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
    s_y = sigma_y / (np.sqrt(6.0) * mu)
    e = (-p + 2 * np.sqrt(2 / 3) * (1 - h) * mu * s_y) / (K + 4 * h * mu / 3)
    assert np.sqrt(2 / 3) * abs(e) > s_y and abs(e) > 1.3 * p / c33

    def uz(z):
        return np.where(z <= 1 / 3, -p * z / c33, np.where(z <= 2 / 3, -p / (3 * c33) + e * (z - 1 / 3),
                                                          -p / (3 * c33) + e / 3 - p * (z - 2 / 3) / c33))

    worst = 0.0
    for body, u in zip(scene.bodies, sol.u):
        z = np.asarray(space(2, body.mesh.cell).nodes(body).points)[:, 2]
        exact = np.zeros_like(u)
        exact[:, 2] = uz(z)
        worst = max(worst, float(np.abs(u - exact).max()))
    assert worst <= 1e-9 * max(float(np.abs(u).max()) for u in sol.u)
