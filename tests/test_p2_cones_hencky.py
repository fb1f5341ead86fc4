"""The P2 "everywhere" condition ("gamma3", the conic condition of docs/formulation.md §8) beside a non-quadratic bulk
energy (a Hencky body, docs/materials.md §8; issue 31, docs/refusals.md row 35): the full CVXPY program (the cones
beside the energy's cones per quadrature point), finished exactly by Newton at the tangency points on the nonlinear
(26) (:func:`cvxcontact.backends.cones.finish_bulk`). Checked against (26)-(27) with the nonlinear stress (the
read-back), the condition sampled densely on each body's own P2 trace (independent of the merged mesh and the
Bernstein form), the interior point of the CVXPY program, and the nodal condition's answer (the Newton route), which
penetrates between its nodes. The limit case (a yield stress never reached equals the linear answer) is row 35's
test in tests/test_refusals.py. Tolerances: rounding or >= 100x the measured values (beside them)."""

import warnings

import numpy as np
import pytest
from conftest import p2_trace_jump, rel

import cvxcontact as cc
from cvxcontact.apps.studies.convergence_hencky import plastic_zone
from cvxcontact.backends.result import Finish, Route
from cvxcontact.errors import ResidualWarning

pytestmark = pytest.mark.numerics

E, NU = 70e9, 0.3
H = 0.5                                               # block heights (m)
ALU = cc.materials.isotropic(E=E, nu=NU)
HENCKY = cc.materials.hencky(E=E, nu=NU, sigma_y=2e6, h=0.1)    # yields under the contact zone
GAP = lambda s: -2e-6 + 2e-3 * (s - 0.4) ** 2         # a parabolic gap: contact on an interior zone
XS = np.linspace(0.0, 1.0, 4001)                      # the sampled abscissae of the contact line


def pressed(material, nx=6, ny=2):
    """A block [0, 1] x [0, H] clamped at its top, pressed down by its weight (1e8 N/m^3) onto a block
    [0, 1] x [-H, 0] of ``material`` (``nx`` cells across, ``ny`` through; the upper block nx + 1: non-matching)
    clamped at its base, across the gap :data:`GAP`."""
    upper = cc.Body(cc.rectangle(x=(0, 1), y=(0, H), nx=nx + 1, ny=ny), ALU, clamped=["top"], contact="bottom",
                    body_force=(0.0, -1e8), name="upper")
    lower = cc.Body(cc.rectangle(x=(0, 1), y=(-H, 0), nx=nx, ny=ny), material, clamped=["bottom"], contact="top",
                    name="lower")
    return cc.Scene(upper, lower, gap=GAP)




def sampled_jump(sol, xs=XS):
    """[u_nu] at ``xs`` from each body's own P2 trace (:func:`conftest.p2_trace_jump`)."""
    return p2_trace_jump(sol, xs)


def excess(sol):
    """The largest sampled [u_nu] - g over the largest |[u_nu]| (> 0: penetration between the sampled points)."""
    jump = sampled_jump(sol)
    return float((jump - GAP(XS)).max() / np.abs(jump).max())


@pytest.fixture(scope="module")
def yielding():
    return cc.solve(pressed(HENCKY), "gamma3", degree=2)


@pytest.mark.parametrize("nx", [3, 6, 12])
def test_a_yielding_block_under_the_cones_is_finished_exactly_and_balances_26_27(nx, yielding):
    """Every level: the full route (no other takes the cones beside a Hencky body), finished by Newton at the tangency
    points; the block yields under the contact zone only; (26)-(27) with the nonlinear stress at rounding (the
    read-back: measured equilibrium <= 1.1e-13, feasibility <= 1.2e-16, cone <= 1.2e-16, the Newton steps stopping
    once a step is at rounding; complementarity, read on the Bernstein duals as for a linear material (4.3e-8
    there), <= 1.4e-8)."""
    sol = yielding if nx == 6 else cc.solve(pressed(HENCKY, nx), "gamma3", degree=2)      # nx = 6: the fixture's
    assert sol.info.method == "full" and sol.info.requested == "auto"
    assert sol.polished and sol.info.finish == Finish.TANGENCY_NEWTON, sol.report()
    zone = plastic_zone(sol, body=1)
    assert 0 < zone["yielded"] < zone["points"], zone
    res = sol.residuals()
    assert sol.ok and res["equilibrium"] < 1e-11 and res["feasibility"] < 1e-13 and res["cone"] < 1e-13, res
    assert res["complementarity"] < 1e-6, res
    touching = sol.in_contact()        # the contact zone (at nx = 3 it touches inside segments: no node closes)
    assert touching.any() and not touching.all()


def test_the_condition_holds_between_the_nodes_where_the_nodal_one_penetrates(yielding):
    """[u_nu] <= g sampled at 4001 points of the line on each body's own P2 trace (measured max -1.2e-10 of the
    largest jump: no penetration anywhere, the contact touching between the samples); the nodal condition "sigma1"
    with the same Hencky body (the Newton route) penetrates between its nodes (measured 1.9e-2), and its answer is
    another one (measured 3.2e-2 apart)."""
    assert excess(yielding) <= 1e-12
    nodal = cc.solve(pressed(HENCKY), "sigma1", degree=2)
    assert nodal.ok and nodal.info.method == "newton"
    assert excess(nodal) > 1e-3 and rel(nodal.u[1], yielding.u[1]) > 1e-3


def test_the_yielding_answer_is_not_the_linear_one(yielding):
    """The nonlinear branch is exercised: the answer differs from the linear material's (measured 0.77 in the lower
    block's displacements, 0.44 in lambda_h), on a contact zone as wide or wider (measured 13 nodes of 25 each; no
    node closes to tol in either: both touch inside segments)."""
    linear = cc.solve(pressed(ALU), "gamma3", degree=2)
    assert linear.ok and rel(yielding.u[1], linear.u[1]) > 0.1 and rel(yielding.contact.lam, linear.contact.lam) > 0.1
    assert yielding.in_contact().sum() >= linear.in_contact().sum()


def test_the_interior_point_of_the_cvxpy_program_agrees_with_the_finish(yielding):
    """The reference: the full program's interior point (polish=False: the CVXPY answer as it stops, with the
    Clarabel settings of the cones beside a bulk energy, CLARABEL_BULK_CONES) within 1e-4 of the finished answer
    (measured 2.9e-8 in u, 1.3e-7 in lambda_h); it is the route's start, its structure the finish's."""
    with warnings.catch_warnings():      # its status may read "optimal_inaccurate" (Clarabel's own tolerances)
        warnings.simplefilter("ignore", ResidualWarning)
        ipm = cc.solve(pressed(HENCKY), "gamma3", degree=2, polish=False, tol=1e-3)
    assert not ipm.polished and ipm.info.route == Route.INTERIOR_POINT_NONLINEAR_ENERGY
    for a, b in zip(ipm.u, yielding.u):
        assert rel(a, b) <= 1e-4
    assert rel(ipm.contact.lam, yielding.contact.lam) <= 1e-4


def test_the_piezoelectric_study_scene_is_finished_exactly():
    """The Hencky convergence study's scene (PZT-5A on a Hencky block, docs/studies/convergence_hencky) under P2
    "gamma3" at n = 4 and 8: finished exactly (measured checks <= 1.4e-8, the complementarity), a plastic zone."""
    from cvxcontact.apps.studies import convergence, convergence_hencky

    for n in (4, 8):
        row, sol = convergence.level("smooth", 2, "gamma3", n, "auto", convergence_hencky.HENCKY)
        assert row["ok"] and sol.polished and sol.info.finish == Finish.TANGENCY_NEWTON and row["checks_max"] < 1e-6
        assert 0 < plastic_zone(sol)["yielded"]


def closed_run(sol) -> float:
    """The longest stretch of the line (m) on which the sampled [u_nu] equals g to 1e-9 of the largest jump."""
    closed = np.abs(sampled_jump(sol) - GAP(XS)) <= 1e-9 * np.abs(sampled_jump(sol)).max()
    runs = [len(r) for r in np.split(closed, np.flatnonzero(np.diff(closed)) + 1) if r[0]]
    return max(runs, default=1) * (XS[1] - XS[0])


def test_a_block_that_conforms_along_whole_segments_is_finished_exactly():
    """nx = 24, ny = 8 (the benchmark's scene, benchmarks/p2_cones_hencky.py): the yielding block conforms to the
    other along whole segments (measured: [u_nu] = g on a stretch of 0.083 m, two of its cells), whose nodal forces
    are measures on the segments with negative vertex values (read as a sign test, the structure cycled and the
    finish declined: tangency.py ``_conforming``). Finished by Newton at the tangency points; (26)-(27) with the
    nonlinear stress (measured equilibrium 6.5e-13, feasibility 1.2e-16, cone 6.3e-17, complementarity 1.4e-8);
    no penetration between the nodes (measured 3.8e-16 of the largest jump: rounding on the closed stretch); the
    interior point within 8.2e-9 in u and 3.0e-5 in lambda_h."""
    scene = lambda: pressed(HENCKY, 24, ny=8)
    sol = cc.solve(scene(), "gamma3", degree=2)
    assert sol.info.method == "full" and sol.polished and sol.info.finish == Finish.TANGENCY_NEWTON, sol.report()
    assert closed_run(sol) >= 1.5 / 24
    res = sol.residuals()
    assert sol.ok and res["equilibrium"] < 1e-10 and res["feasibility"] < 1e-13 and res["cone"] < 1e-13, res
    assert res["complementarity"] < 1.4e-6, res
    assert excess(sol) <= 1e-12
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        ipm = cc.solve(scene(), "gamma3", degree=2, polish=False, tol=1e-3)
    assert all(rel(a, b) <= 1e-6 for a, b in zip(ipm.u, sol.u))
    assert rel(ipm.contact.lam, sol.contact.lam) <= 3e-3


def test_a_wandering_tangency_structure_declines_once_a_row_is_dropped_a_second_time(monkeypatch):
    """nx = 48, ny = 16 (the benchmark's largest scene): the run of whole segments has forces outside the cone and
    the tangency Newton's structures wander (a node row dropped for its negative force, re-added by a violation,
    dropped again) without repeating exactly. The outer loop ran its 10 rounds, the last to Newton's 40 steps (14.4 s
    against 5.5 s, CPU, one run, benchmarks/results/p2_cones_hencky.md) for the same decline; it now declines in
    round 3, where a row is dropped a second time; the accumulated cuts on the nonlinear (26) then finish it
    (cvxcontact/backends/bulkcuts.py: 6.7 s CPU in all, measured)."""
    from cvxcontact.backends import cones
    from cvxcontact.backends.finish.declined import Declined, Stop

    seen = []
    newton = cones.tangency_newton

    def spy(*args, **kwargs):
        out = newton(*args, **kwargs)
        seen.append(out)
        return out

    monkeypatch.setattr(cones, "tangency_newton", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        sol = cc.solve(pressed(HENCKY, 48, ny=16), "gamma3", degree=2)
    wandered = [out for out in seen if isinstance(out, Declined) and out.stop is Stop.CYCLE]
    assert wandered and "a second time" in wandered[0], seen
    assert sol.polished and sol.info.declined is None and sol.ok, sol.info.declined
    res = sol.residuals()
    assert res["equilibrium"] < 1e-11 and res["feasibility"] < 1e-9, res   # measured 1.6e-14, 3.3e-12
