"""Bodies held by the contact only, against rigid obstacles and deformable partners: closed forms,
and the rigid-motion balance check that a spurious rigid displacement cannot hide from."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.solution.checks import rigid_balance

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

E, NU = 200e9, 0.3
STEEL = cc.materials.isotropic(E=E, nu=NU)
LAME_P = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))       # lambda + 2 mu, plane strain (Pa)


def layer_on_floor(p=1e7, nx=5, ny=3, method="auto", condition="gamma3"):
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=nx, ny=ny)
    b = cc.Body(m, STEEL, roller=["left", "right"], contact="bottom", traction={"top": (0.0, -p)})
    floor = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", floor)])
    return m, cc.solve(scene, condition=condition, method=method)


@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
def test_layer_on_a_rigid_plane_held_by_rollers_is_in_exact_uniaxial_strain(condition):
    p = 1e7
    m, sol = layer_on_floor(p, condition=condition)
    assert sol.ok and sol.polished
    y = m.points[:, 1]
    exact_uy = -p / LAME_P * y                                   # u_y(0) = 0 on the floor, sigma_yy = -p
    scale = p / LAME_P * 0.4
    assert np.abs(sol.u[0][:, 1] - exact_uy).max() < 1e-9 * scale
    assert np.abs(sol.u[0][:, 0]).max() < 1e-9 * scale
    assert sol.contact.force.sum() == pytest.approx(p * 1.0, rel=1e-10)       # contact force = load (N/m)


def test_block_on_a_rigid_plane_under_its_own_weight_carries_its_weight():
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2)
    b = cc.Body(m, STEEL, roller=["left", "right"], contact="bottom", body_force=(0.0, -1e6))
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)))])
    for method in ("auto", "full"):
        sol = cc.solve(scene, method=method)
        assert sol.ok
        assert sol.contact.force.sum() == pytest.approx(1e6 * 0.5, rel=1e-10)
        assert np.abs(sol.u[0]).max() < 1e-5           # elastic sag only: micrometres, not a rigid drift


def test_rigid_balance_exposes_a_spurious_rigid_displacement():
    """The equilibrium row scales |A||x| grow with a spurious rigid translation x; the balance of the
    held motions does not: adding a translation to the exact answer and dropping the contact force
    must fail it, while the exact answer passes."""
    m, sol = layer_on_floor()
    scene = sol.scene
    from cvxcontact.discrete import Block, Units
    from cvxcontact.fem.assembly import assemble
    body = scene.bodies[0]
    system = assemble(body)
    blk = Block.scaled(system, scene.stack.jump(0, len(m.points)), Units(1.0, 1.0, 1.0, 1.0))     # SI
    modes = (system.Tu.T @ body.held_modes().T).T
    assert modes.shape[0] == 1                                    # translation y only (rollers hold x)
    z = system.Tu.T @ (sol.u[0].ravel() - system.u_fixed)
    Mlam = np.asarray(sol.contact.force)                          # M lambda_h = E^T y, N/m
    assert rigid_balance(blk, modes, z, None, Mlam, prolongation=system.Tu, dim=2) < 1e-10
    drift = system.Tu.T @ np.tile([0.0, 1.0], len(m.points)) * 1e9
    assert rigid_balance(blk, modes, z + drift, None, 0 * Mlam, prolongation=system.Tu, dim=2) > 0.1


def test_unloaded_scene_with_zero_gap_passes_its_checks():
    """No load and no gap: everything is zero and every check must read 0, not 0/0 = nan."""
    b1 = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2), STEEL, clamped="top", contact="bottom")
    b2 = cc.Body(cc.rectangle(x=(0, 1), y=(-0.5, 0), nx=3, ny=2), STEEL, clamped="bottom", contact="top")
    for method in ("full", "condensed"):
        sol = cc.solve(cc.Scene(b1, b2), method=method)
        assert all(v == 0.0 for v in sol.residuals().values()) and sol.ok
        assert np.abs(sol.u[0]).max() == 0.0


def test_a_clamped_node_in_penetration_is_a_typed_error_naming_the_point():
    """A node the supports hold that an obstacle already penetrates: refused before any solve with the
    pair and the point, never a solver's 'infeasible'."""
    b = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2), STEEL, clamped="left", contact="bottom")
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0.0, 1e-6), (0.0, 1.0)))])
    for method in ("full", "condensed"):
        with pytest.raises(cc.SceneError, match=r"contact pair 0: 1 constrained node.*\(0, 0\) m.*-1e-06 m"):
            cc.solve(scene, method=method)
    ok = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0.0, -1e-6), (0.0, 1.0)))])
    assert cc.solve(ok).ok                                         # the same node with a positive gap solves


def test_the_user_terms_checks_keep_the_balance_of_the_motions_only_the_contact_holds(monkeypatch):
    """cc.Model's checks with user terms (``cvxcontact.model.terms.checks``) recompute "equilibrium" with the user
    forces. They kept the row check alone and dropped the balance of the motions only the contact holds, which the
    read-back had: an answer moved rigidly along the held translation (1e9 times its displacement) with every contact
    force 1 % too large read balanced (its row scales |A| |x| grow with the drift). The right answer reads balanced,
    that one not."""
    from conftest import captured

    from cvxcontact.model.terms import checks
    from cvxcontact.solution.checks import equilibrium_with

    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=5, ny=3)
    b = cc.Body(m, STEEL, roller=["left", "right"], contact="bottom", traction={"top": (0.0, -1e7)})
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0)))])
    sol, problem, raw = captured(monkeypatch, scene)
    assert sol.ok and b.held_by_contact == ("translation y",)
    Tu, grad = problem.systems[0].Tu, np.zeros(len(raw.u[0]))          # no user rows, no objective's gradient
    right = checks(problem, {}, raw.u, raw.phi, raw.y, None, [], grad)["equilibrium"]
    assert right < 1e-10                                     # measured 4.8e-16 (Prescott, Sandybridge 1.0e-15)
    drifted = [raw.u[0] + Tu.T @ np.tile([0.0, 1.0], len(m.points)) * 1e9 * np.abs(raw.u[0]).max()]
    wrong = 1.01 * raw.y
    rows = equilibrium_with(problem.blocks, drifted, raw.phi, problem.E.T @ wrong, [(grad, grad)])
    assert rows < sol.tol                                                 # measured 4.6e-13: blind to it
    assert checks(problem, {}, drifted, raw.phi, wrong, None, [], grad)["equilibrium"] > sol.tol  # measured 5.0e-3
    #                                                                       (4.6e-13 before: the row check alone)
