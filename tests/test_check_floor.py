"""The frictionless checks' force floor (cvxcontact.solution.checks.checks: Y floored at FORCE_FLOOR of the
elastic forces at the contact rows) reads each body's deformation, its rigid fit taken out: a block held on its
left face and slid along x above a floor it never reaches has the same floor after 0.1 mm and 0.1 m, and a wrong
answer (a negative force on one open row) reads the same cone violation at both. With |K| |u| the floor grew with
the slide (55 N and 2.7e4 N, measured) and the same wrong force read 1e-3 and 8.8e-8 (below tol, ok).
"""

import dataclasses

import numpy as np
import pytest
from conftest import captured

import cvxcontact as cc
from cvxcontact.backends.finish.forces import FORCE_FLOOR, reach_forces
from cvxcontact.solution.readback import read_back

pytestmark = pytest.mark.numerics


def _held_open(s, p=1e6):
    """A steel block 1 m x 0.5 m held by (u_x, u_y) = (s, 0) on its left face, pressed by p on its top, 1 mm above
    a rigid floor it never reaches (frictionless): the same deformation whatever s, carried s further."""
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    b = cc.Body(m, cc.materials.isotropic(E=200e9, nu=0.3), contact="bottom", traction={"top": (0.0, -p)},
                displacement={"left": (s, 0.0)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0.0, -1e-3), (0.0, 1.0)))])




def test_the_check_floor_does_not_grow_with_a_slide_and_a_wrong_force_reads_the_same(monkeypatch):
    floors, cones, force = [], [], None
    for s in (1e-4, 1e-1):
        sol, problem, raw = captured(monkeypatch, _held_open(s))
        assert sol.ok and sol.polished and not np.any(raw.y)                  # open: exactly no force
        f = problem.units.force
        floors.append(FORCE_FLOOR * f * reach_forces(problem.blocks, problem.E, raw.u, raw.phi,
                                                     problem.rigid_fits).max())      # N (per m)
        force = force or 1e-3 * floors[0]                                     # 1e-3 of the floor at 0.1 mm
        y = np.array(raw.y, dtype=float)
        y[len(y) // 2] = -force / f
        bad = read_back(problem, dataclasses.replace(raw, y=y), sol.tol, {})
        assert not bad.ok
        cones.append(bad.residuals()["cone"])
    assert floors[0] > 0 and abs(floors[1] - floors[0]) < 1e-6 * floors[0]   # measured 1.2e-11 relative
    assert cones[0] == pytest.approx(1e-3, rel=1e-6)                          # by construction of the force
    assert cones[1] == pytest.approx(cones[0], rel=1e-6)                      # measured 1.2e-11 relative (8.8e-8)



@pytest.mark.parametrize("law", [cc.Coulomb(0.3), cc.Tresca(0.0)], ids=["Coulomb", "Tresca-0"])
def test_a_strain_free_body_lifted_off_a_friction_floor_is_finished_exactly_and_reads_ok(law):
    """A steel block moved rigidly by its supports alone ((u_x, u_y) = (0.1 mm, 10 um) on its left face, no load)
    off a rigid floor with friction: the answer is that rigid motion and no force. Its deformation is rounding
    (eps |u|), so the finish's force scale read from it alone was 1e-21 (scaled), the interior point's noise on
    the open rows (1e-8 of the whole displacement's forces) read as forces and the finish declined (Coulomb:
    complementarity 1.0, not ok; main finished it, ok). The finish reads the whole displacement, as ipm_active;
    and its open rows, whose Coulomb capacity is 0, carry no tangential force (their steps left 1e-30, which the
    checks read against the deformation's floor, itself rounding there: stick-slip 2.8e-5, not ok).
    Measured: u within 1.3e-18 m of the rigid motion, no normal force, every check 0 (8e-10 with 1e-30)."""
    s = (1e-4, 1e-5)
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    b = cc.Body(m, cc.materials.isotropic(E=200e9, nu=0.3), contact="bottom", displacement={"left": s})
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)), law=law)])
    sol = cc.solve(scene)
    assert sol.polished and sol.ok
    assert np.abs(sol.u[0] - np.array(s)).max() <= 1e-9 * s[1]            # measured 1.3e-18 m
    assert np.abs(sol.contacts[0].pressure).max(initial=0.0) == 0.0          # open: no force
    residuals = sol.residuals()
    assert max(residuals.values()) < 1e-2 * sol.tol                          # measured 5.2e-17 (equilibrium)
