"""The 3D Hertz study's coarsest level (cvxcontact/apps/studies/hertz3d.py): a rigid sphere on a quarter block
under force control, the force balance exact, Hertz's radius, peak pressure and approach within the measured
errors of that level, and force control by the obstacle's translation unknown against the approach found by
re-solves of a fixed sphere (another backend)."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d as h
from cvxcontact.errors import SceneError

N = 8                                                     # the study's coarsest level


@pytest.fixture(scope="module")
def guided():
    """Force control: the sphere free to move along z under F / 4 on the quarter."""
    return cc.solve(h.scene(N, force=h.FORCE))


def test_force_control_balances_the_force_exactly(guided):
    sol = guided
    assert sol.ok and sol.polished, sol.report()
    y = sol.contact.force
    assert (y >= 0).all() and sol.contact.active.sum() >= 4
    # the quarter's contact forces carry F / 4: the balance is a row of the exact finish
    assert abs(4 * y.sum() - h.FORCE) <= 1e-12 * h.FORCE                 # measured 2e-16
    ob = sol.obstacles[0]
    np.testing.assert_allclose(ob.force, [0.0, 0.0, -h.FORCE / 4], rtol=0, atol=1e-12 * h.FORCE)
    assert ob.translation[0] == 0 and ob.translation[1] == 0 and ob.translation[2] < 0
    # the gap is read back to the moved sphere (0 at the axis before it moved), and every active node
    # touches it: its displacement closes that gap exactly
    c = sol.contact
    r = np.hypot(c.points[:, 0], c.points[:, 1])
    assert c.gap[np.argmin(r)] == pytest.approx(ob.translation[2], rel=1e-12)
    np.testing.assert_allclose(c.jump[c.active], c.gap[c.active], rtol=0,
                               atol=1e-9 * h.hertz(h.FORCE)[2])          # measured 7e-21 m


def test_hertz_quantities_at_the_coarsest_level(guided):
    row = h.measure(guided, -guided.obstacles[0].translation[2])
    assert row["F_N"] == pytest.approx(h.FORCE, rel=1e-12)
    # errors of the P1 level n = 8 (4 cells across the contact patch [0, 2a]); measured beside each bound
    assert abs(row["a_rel_error"]) < 0.15                                # measured +0.075 (h / 2 = 0.28 a)
    assert row["a_h_min_m"] < h.A_REF < row["a_h_max_m"]                 # measured 0.97 a .. 1.37 a
    assert abs(row["p0_rel_error"]) < 0.25                               # measured -0.176
    assert abs(row["cell_force_rel_error"]) < 0.15                       # measured +0.069
    # the clamped finite block is stiffer than the half-space: a shorter approach, by about Boussinesq's
    # displacement at the clamped depth (0.073 of delta) plus the mesh's stiffness
    assert -0.2 < row["delta_rel_error"] < -0.05                         # measured -0.113


def test_force_control_agrees_with_pressing_a_fixed_sphere(guided):
    """The study's route: a fixed sphere moved by secant steps until the force is F, on the condensed
    backend; the same approach and contact forces as the translation unknown on the full backend."""
    base = h.scene(N, delta=0.0)
    solver = cc.ContactSolver(base, "gamma3", method="condensed")
    sol, delta, resolves = h.press(solver, base)
    assert sol.ok and resolves <= 8                                      # measured 3 re-solves
    assert abs(4 * sol.contact.force.sum() - h.FORCE) <= 1e-10 * h.FORCE
    t = -guided.obstacles[0].translation[2]
    assert delta == pytest.approx(t, rel=1e-9)                           # measured 1e-14
    np.testing.assert_array_equal(sol.contact.active, guided.contact.active)
    np.testing.assert_allclose(sol.contact.force, guided.contact.force, rtol=0,
                               atol=1e-9 * h.FORCE)                      # measured 4e-11 N


def test_an_unguided_sphere_on_the_quarter_is_refused():
    """The scene cannot know the symmetry: a free sphere's x and y translations are undetermined."""
    body = h.block(4)
    sphere = cc.Rigid.sphere((0.0, 0.0, h.R), h.R, force=(0.0, 0.0, -h.FORCE / 4))
    with pytest.raises(SceneError, match="nothing determines the translation"):
        cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "zone", sphere)]))


def test_hat_loads_integrate_an_affine_pressure_exactly(guided):
    """The Hertz nodal forces of the axis cell come from hat_loads: exact for affine pressures, where the
    trace's P1 mass matrix gives the same integrals independently."""
    trace = guided.scene.interfaces[0].traces[0]
    M = trace.mass()
    x, y = trace.points[:, 0], trace.points[:, 1]
    got = h.hat_loads(trace, lambda X, Y: 3e9 * (1 + X / h.A_REF - 2 * Y / h.A_REF))
    want = M @ (3e9 * (1 + x / h.A_REF - 2 * y / h.A_REF))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())   # measured 3e-16
