"""cc.Model's user terms beside a friction law (docs/refusals.md row 37; the friction terms' ``beside_user_terms``,
cvxcontact/backends/frictionuser.py): the friction program with the user rows, finished by the friction finish
where the user rows do not bind its answer, else the interior point's answer (declined, checked).

References, none of them the code under test: the closed forms of the stuck uniform layers (on the floor, on a
compliant layer, in a P2 "gamma3" stack) and a block whose slip the user rows pin (the frictionless scene with the
contact edges held along x: cc.solve's Signorini route).
"""

import warnings

import numpy as np
import pytest
from friction_scenes import (
    P,
    compliant_series,
    compliant_series_exact,
    sheared,
    uniform_layer,
    uniform_stack,
)

import cvxcontact as cc

pytestmark = pytest.mark.numerics

G = 100e9           # E / 2: the shear modulus of friction_scenes' steel with nu = 0
E = 200e9
H = 0.5
TAU, K = 0.1 * P, 1e12


def rel(a, b):
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(np.asarray(b)))


def _solved(scene, constraint, **kwargs):
    """cc.Model of ``scene`` with ``constraint(model, scene)`` added, solved (warnings recorded: returned)."""
    model = cc.Model(scene, **kwargs)
    model.add(constraint(model, scene))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = model.solve()
    return model, sol, [str(w.message) for w in caught]


def _never_binds(model, scene):
    return model.u(scene.bodies[0])[:, 1] >= -1.0          # every node stays above y = -1 m


@pytest.mark.parametrize("law", [cc.Tresca(0.5 * P), cc.Coulomb(0.5)], ids=["tresca", "coulomb"])
def test_a_stuck_layer_with_a_user_constraint_that_never_binds_is_the_closed_form_finished(law):
    """P1, nodal rows: u = (tau y / G, -p y / E); the friction finish's answer satisfies the user row, so it is kept
    (polished; the user multiplier 0). Measured: 4.9e-16 (Tresca), 5.5e-16 (Coulomb), default, Prescott and
    Sandybridge kernels."""
    scene = uniform_layer(TAU, law)
    model, sol, caught = _solved(scene, _never_binds, condition="sigma1")
    y = sol.points[0][:, 1]
    exact = np.column_stack([TAU * y / G, -P * y / E])
    assert type(model.problem.term).__name__ == "TrescaFriction" and not caught
    assert sol.ok and sol.polished and sol.info.declined is None
    assert rel(sol.u[0], exact) <= 1e-12
    assert np.all(model.constraints[0].dual_value == 0.0)


def test_a_user_pin_of_the_slip_is_the_tied_block():
    """The bottom nodes held at u_x = 0 by user equalities: the friction no longer acts (the slip is 0), the answer
    is the frictionless block whose contact edges are held along x (cc.solve, Signorini rows and a support). The
    finish takes no user rows: declined, the interior point's answer, checked. Measured: at most 2.4e-14
    (Tresca), 1.8e-13 (Coulomb: its fixed point on the capacities) under the three kernels."""
    tied = cc.solve(sheared(0.35 * P, None, tied=True), "sigma1", method="full")
    for law in (cc.Tresca(0.5 * P), cc.Coulomb(0.5)):
        scene = sheared(0.35 * P, law)
        bottom = np.unique(scene.bodies[0].mesh.boundary("bottom"))

        def pinned(m, s, bottom=bottom):
            return m.u(s.bodies[0], bottom)[:, 0] == 0.0

        _, sol, caught = _solved(scene, pinned, condition="sigma1")
        assert sol.ok and not sol.polished and "binds" in sol.info.declined and not caught
        assert rel(sol.u[0], tied.u[0]) <= 1e-8


def test_beside_a_compliance_law_a_stuck_pair_is_the_closed_form():
    """Two layers, friction between them, the lower on a compliant floor (k): stuck, u = (tau y' / G, -p / k
    - p y' / E), y' = y + H; a user row that never binds leaves the finished answer (the friction finish on the
    energy with the law's term). Measured: 6.8e-15 (three kernels)."""
    scene = compliant_series(TAU, K, g=0.5 * P)
    model, sol, caught = _solved(scene, _never_binds, condition="sigma1")
    assert type(model.problem.term).__name__ == "FrictionBesideCompliance" and not caught
    assert sol.ok and sol.polished
    for x, u in zip(sol.points, sol.u):
        assert rel(u, compliant_series_exact(x, TAU, K)) <= 1e-12


def test_under_the_p2_cones_a_stuck_stack_is_the_closed_form():
    """Three P2 blocks, the upper pair under "gamma3" (the cones with a friction row at every node of X_h) on
    non-matching lines, the lower under "sigma1" on matching ones, stuck: u = (tau y' / G, -p y' / E), y' = y + 2H,
    exact in P2; a user row that never binds leaves the finished answer. Measured: at most 5.6e-14 (three
    kernels)."""
    scene = uniform_stack(TAU, cc.Tresca(0.5 * P), nx=(4, 3, 3))    # the nodal pair on matching lines: exact
    model, sol, _ = _solved(scene, _never_binds, condition="gamma3", degree=2)
    assert type(model.problem.term).__name__ == "ConesWithFriction"
    assert sol.ok and sol.polished
    for x, u in zip(sol.points, sol.u):                   # the P2 nodes: vertices and midpoints
        y = x[:, 1] + 2 * H
        assert rel(u, np.column_stack([TAU * y / G, -P * y / E])) <= 1e-10


def test_a_force_controlled_sphere_on_a_frictional_pair_is_the_translated_scene():
    """3D: a block clamped at its base pressed by a force-controlled sphere (force (1e4, 5e3, -1e5) N), Tresca on
    that pair (its translation t slips the rows), a user row that never binds. The scene translated by -t (the
    sphere fixed where it started, the base moved by -t) has the same relative motion: u - t (cc.solve of it). The
    obstacle's balance with the user rows counts the friction's force on the translation (measured at most 2.5e-16
    under the three kernels; 0.86 without it); u measured at most 9.9e-16."""
    from friction_scenes import steel

    mesh = cc.box(nx=4, ny=4, nz=2)
    F = np.array([1e4, 5e3, -1e5])
    sphere = cc.Rigid.sphere(center=(0.5, 0.5, 1.5), radius=0.5, force=tuple(F))
    body = cc.Body(mesh, steel(), contact="top", clamped="bottom")
    scene = cc.Scene(body, contacts=[cc.Contact(body, "top", sphere, law=cc.Tresca(1e6))])
    _, sol, _ = _solved(scene, lambda m, s: m.u(s.bodies[0])[:, 2] >= -1.0, condition="sigma1")
    assert sol.ok and sol.polished and sol._checks["obstacle balance"] <= 1e-12
    t = sol.obstacles[0].translation
    moved = cc.Body(mesh, steel(), contact="top", displacement={"bottom": tuple(-t)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        ref = cc.solve(cc.Scene(moved, contacts=[cc.Contact(moved, "top", sphere.with_force(None),
                                                            law=cc.Tresca(1e6))]), "sigma1", method="full")
    assert ref.ok and ref.polished
    assert rel(sol.u[0] - t, ref.u[0]) <= 1e-12


def _shear_objective(scene, q):
    """cc.Model of ``scene`` ("sigma1") with the linear user objective -sum_i q w_i u_x(i) over its body's top nodes,
    w_i their lumped lengths (the P1 consistent load of a uniform shear traction q, Pa)."""
    body = scene.bodies[0]
    points, edges = body.mesh.points, body.mesh.boundary("top")
    w = np.zeros(len(points))
    np.add.at(w, edges.ravel(), np.repeat(np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1) / 2, 2))
    top = np.flatnonzero(w)
    model = cc.Model(scene, "sigma1")
    model.add_objective(-(q * w[top]) @ model.u(body, top)[:, 0])
    return model


@pytest.mark.parametrize("law", [cc.Tresca(0.5 * P), cc.Coulomb(0.5)], ids=["tresca", "coulomb"])
def test_a_user_objective_of_the_shear_traction_is_the_sheared_block(law):
    """A linear user objective -sum_i q w_i u_x(i) over the top nodes (w_i their lumped lengths: the P1 consistent
    load of a uniform traction q) on the block pressed without shear is the block sheared by the traction (q, -p)
    (cc.solve of that scene, finished). The friction finish takes no user gradient: declined, the interior point's
    answer, checked (the equilibrium with the objective's gradient and the friction's force). Measured: 3.2e-13
    (Tresca), 4.5e-14 (Coulomb), the same under the three kernels."""
    q = 0.35 * P
    ref = cc.solve(sheared(q, law), "sigma1", method="full")
    model = _shear_objective(sheared(0.0, law), q)
    sol = model.solve()
    assert ref.ok and ref.polished and sol.ok and not sol.polished and "objective" in sol.info.declined
    assert rel(sol.u[0], ref.u[0]) <= 1e-9


def test_coulomb_with_a_slip_the_user_rows_prescribe_is_the_dragged_block():
    """Coulomb with user equalities dragging the contact nodes by u_x = s (written per micrometre: the rows at the
    interior point's scale) is the block whose contact edges a support drags by s (cc.solve with Coulomb, finished;
    every row slides). Coulomb's start held the slip at 0 where it can stick, with the user rows: infeasible, a
    SolverError; the start is now posed without them. Measured 5.5e-15 (default, Prescott, Sandybridge)."""
    s = 1e-6
    ref = cc.solve(sheared(0.35 * P, cc.Coulomb(0.5), drag=s), "sigma1", method="full")
    scene = sheared(0.35 * P, cc.Coulomb(0.5))
    bottom = np.unique(scene.bodies[0].mesh.boundary("bottom"))
    _, sol, caught = _solved(scene, lambda m, sc: m.u(sc.bodies[0], bottom)[:, 0] / s == 1.0, condition="sigma1")
    assert ref.ok and ref.polished and sol.ok and not sol.polished and not caught
    assert rel(sol.u[0], ref.u[0]) <= 1e-10


@pytest.mark.parametrize("law", [cc.Tresca(0.2 * P), cc.Coulomb(0.2)], ids=["tresca", "coulomb"])
def test_a_user_objective_that_slides_the_block_past_its_capacity_names_the_cause(law):
    """The shear objective of the test above at 0.35 p against a capacity of 0.2 p: the energy decreases without
    bound along x (no equilibrium; the scene-time sliding check cannot see a user objective). The solver's status
    'unbounded' is raised as a SolverError that says what it means of the scene and what to do (it said only the
    status)."""
    model = _shear_objective(sheared(0.0, law), 0.35 * P)
    with pytest.raises(cc.SolverError, match="friction capacity"):
        model.solve()
