"""The balance of the rigid motions only the contact holds, with friction (cvxcontact.solution.friction): a cube
slid along x on a rigid plane (Tresca) reads it balanced whether it slid 0.1 mm or 0.1 m, and a wrong answer
(a shear of 1e-6 of the load across the slide on one row, the body moved across the slide) still reads not ok.

Before, the balance summed the elastic forces K u of the whole displacement (their rounding grows with the
slide) and measured them against the components of the contact forces along each motion alone (the translation
across the slide sees only the rounding of the friction forces' direction): equilibrium 1e-4 at 0.1 mm, 2.4 at
0.1 m, on right answers whose momentum rows read 1e-17.
"""

import dataclasses

import numpy as np
import pytest
from conftest import captured
from friction_scenes import slid_cube

import cvxcontact as cc
from cvxcontact.solution.readback import read_back

pytestmark = pytest.mark.numerics




@pytest.mark.parametrize("s", [1e-4, 1e-1])
def test_a_slid_cube_reads_balanced_at_any_slide_and_a_wrong_answer_does_not(monkeypatch, s):
    sol, problem, raw = captured(monkeypatch, slid_cube(s))
    assert len(sol.scene.bodies[0].held_by_contact) == 3                    # y, z and a rotation: the contact holds them
    slip = np.asarray(sol.contact.slip)
    assert (slip[:, 0] > 0.5 * s).all()                                    # every node slides along x
    assert sol.ok
    assert sol.residuals()["equilibrium"] < 0.2 * sol.tol   # measured 6.8e-12, 1.2e-9 (was 1e-4, 2.4)
    # a shear of 1e-6 of the load across the slide on one row: the contact no longer balances translation along y
    rows = problem.term.data.rows.shape[0] // 2
    mu = np.array(raw.tangential, dtype=float)
    mu[rows + rows // 2] += 1e-6 * float(np.sum(raw.y))
    bad = read_back(problem, dataclasses.replace(raw, tangential=mu), sol.tol, {})
    assert not bad.ok and bad.residuals()["equilibrium"] > sol.tol        # measured 1.0e-5 both
    # the body moved across the slide by 1e-3 of its largest displacement: the slip turns off the friction force
    npts = len(problem.meshes[0].points)
    moved = [uk + problem.systems[0].Tu.T @ np.tile([0.0, 1e-3 * np.abs(uk).max(), 0.0], npts) for uk in raw.u]
    bad = read_back(problem, dataclasses.replace(raw, u=moved), sol.tol, {})
    assert not bad.ok and bad.residuals()["slip direction"] > 10 * sol.tol  # measured 1.6e-4 both


def test_a_q2_hexahedral_cube_slid_along_x_reads_balanced_and_agrees_with_the_unfinished_reference(monkeypatch):
    """Q2 hexahedra (2 x 2 x 2, "sigma1"), pressed by 10 MPa and pushed 0.1 mm along x, Tresca 100 Pa: read 1.1e-5
    (nz = 1) and 8.3e-4 (nz = 2) in equilibrium before, from the same balance across the slide (the translation
    along y). The answer was right: it agrees with the interior point's own answer of the `full` backend, not
    finished, and its friction forces sum to g A."""
    scene = slid_cube(1e-4, p=1e7, n=2, cell="hex")
    sol, problem, raw = captured(monkeypatch, scene, degree=2, condition="sigma1")
    assert sol.ok
    assert sol.residuals()["equilibrium"] < 0.01 * sol.tol                   # measured 6.3e-11 (was 8.3e-4)
    assert np.linalg.norm(sol.contact.shear_force, axis=1).sum() == pytest.approx(1e2, rel=1e-12)  # 2.2e-16
    ref = cc.solve(scene, degree=2, condition="sigma1", method="full", polish=False)
    assert ref.ok and not ref.polished
    assert np.abs(sol.u[0] - ref.u[0]).max() < 1e-5 * np.abs(sol.u[0]).max()  # measured 8.8e-8
    rows = problem.term.data.rows.shape[0] // 2
    mu = np.array(raw.tangential, dtype=float)
    mu[rows + rows // 2] += 1e-6 * float(np.sum(raw.y))
    bad = read_back(problem, dataclasses.replace(raw, tangential=mu), sol.tol, {})
    assert not bad.ok and bad.residuals()["equilibrium"] > sol.tol          # measured 9.5e-2


def test_a_cube_slid_by_its_own_size_is_finished_and_carries_the_same_deformation(monkeypatch):
    """The cube slid 1 m (its own size) against 0.1 m. Its deformation is 5.1e-9 m, 2e8 times smaller than the
    slide, and the units' load is the slide's: the contact forces are 1e-10 of the force unit, below the interior
    point's precision (its answer carried 0.17 N of the 1000 N load, every row open), and the friction finish's
    steps from it did not settle (cone 1.7, equilibrium 1: not ok). The finish starts again from every row closed
    and slipping where the first steps decline: it settles, and the answer is the 0.1 m one carried 0.9 m further.
    Its translation along y, which only the friction holds (a stiffness g / s = 100 N/m at s = 1 m against the
    rounding of the elastic forces, eps |K| |u|), differs by 2.9e-8 m (measured); the deformation by 1.4e-15 m.
    A tangential force 1 % above the capacity on one row reads the same cone violation at both (5.0e-4)."""
    sols, cones = {}, {}
    for s in (1e-1, 1.0):
        sol, problem, raw = captured(monkeypatch, slid_cube(s))
        assert sol.ok and sol.polished
        assert sol.residuals()["equilibrium"] < 0.2 * sol.tol                # measured 5.3e-9, 2.9e-8
        assert np.linalg.norm(sol.contact.shear_force, axis=1).sum() == pytest.approx(1e2, rel=1e-9)  # g A
        R = problem.E.shape[0]
        mu = np.array(raw.tangential, dtype=float).reshape(-1, R)
        a = R // 2
        mu[:, a] *= 1.01 * raw.capacity[a] / np.linalg.norm(mu[:, a])
        bad = read_back(problem, dataclasses.replace(raw, tangential=mu.ravel()), sol.tol, {})
        assert not bad.ok
        sols[s], cones[s] = sol.u[0], bad.residuals()["friction cone"]
    d = sols[1.0] - sols[1e-1] - [0.9, 0.0, 0.0]
    deformation = np.abs(sols[1e-1] - [0.1, 0.0, 0.0]).max()                 # 5.1e-9 m
    assert np.abs(d - d.mean(axis=0)).max() < 1e-4 * deformation             # measured 1.4e-15 m
    assert np.abs(d.mean(axis=0)).max() < 1e-5                               # measured 2.9e-8 m (y)
    assert cones[1e-1] > 1e-4 and cones[1.0] == pytest.approx(cones[1e-1], rel=1e-3)  # measured 5.0e-4 both
