"""cc.Model takes every scene cc.solve takes (issue 11, the modelpairs brief): P2 with several pairs (nodal,
conic, mixed), rigid obstacles, and force-controlled obstacles (P1 and P2).

Cross-checks, each independent of the Model under test:
* cc.solve(..., method="full") on the same scene (the same program, posed by ContactSolver);
* a dense primal-dual active-set solve of (26) whose rows are built here from each body's own quadratic
  edges (test_p2_stack's reference), with the user row appended as one more inequality row;
* the closed form of uniaxial strain under a force-controlled plane (test_force_control).
"""

import warnings

import cvxpy as cp
import numpy as np
import pytest

import cvxcontact as cc

from conftest import rel
from reference_problems import active_set_solve
from obstacle_scenes import indenter_scene, punch_scene
from stack_scenes import MAT, YOUNG, dense_stack, three_blocks

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def _stack(conditions=("sigma1", "sigma2")):
    bodies, pairs, gaps = three_blocks(conditions)
    return cc.Scene(*bodies, contacts=pairs), gaps


def _strict(model):
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        return model.solve()


# ---------------------------------------------------------------- P2, several pairs

def test_p2_model_on_a_nodal_stack_is_the_full_solve_to_rounding():
    """Three blocks, two pairs (sigma1, sigma2): cc.Model(degree=2) finishes exactly like solve(method="full")
    and gives its answer to rounding, pair by pair; model.jump() is every pair's [u_nu] at its P2 nodes of X_h,
    stacked by model.offsets, and reads back each pair's sol.contacts[i].jump."""
    scene, _ = _stack()
    ref = cc.solve(scene, "gamma3", degree=2, method="full")
    model = cc.Model(scene, "gamma3", degree=2)
    sol = _strict(model)
    assert ref.ok and sol.ok and ref.polished and sol.polished, sol.report()
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) < 1e-12                                          # measured 0 (the same program)
    assert len(sol.contacts) == 2 and list(np.diff(model.offsets)) == [c.x.size for c in sol.contacts]
    for c, r in zip(sol.contacts, ref.contacts):
        assert np.array_equal(c.x, r.x) and np.array_equal(c.active, r.active)
        assert rel(c.lam, r.lam) < 1e-10 and c.active.any() and not c.active.all()
    assert abs(sol.energy - ref.energy) <= 1e-12 * abs(ref.energy)
    jump = model.jump().value                                            # the IPM's; sol is the finished one
    for i, c in enumerate(sol.contacts):
        part = jump[model.offsets[i]:model.offsets[i + 1]]
        assert part.shape == c.jump.shape and rel(part, c.jump) < 1e-6


@pytest.mark.parametrize("conditions", [("gamma3", "gamma3"), ("gamma3", "sigma2")])
def test_p2_model_on_a_conic_stack_is_the_full_solve(conditions):
    """The conic "everywhere" condition on one or both pairs of the stack (nodal rows as degenerate cones
    next to a conic pair): without user terms the same program and exact finish (accumulated cuts) as
    solve(method="full"), so the same answer, ok at the default tol."""
    scene, _ = _stack(conditions)
    ref = cc.solve(scene, degree=2, method="full")
    sol = cc.Model(scene, degree=2).solve()
    assert ref.ok and sol.ok and sol.polished, sol.report()
    assert sol.info.finish in ("accumulated cuts", "tangency Newton"), sol.report()
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) < 1e-7  # measured 0: the same program and IPM run
    for c, r in zip(sol.contacts, ref.contacts):
        assert np.array_equal(c.constrained, r.constrained) and rel(c.lam, r.lam) < 1e-5
    assert sol.residuals()["complementarity"] < 1e-5


@pytest.mark.parametrize("conditions", [("sigma1", "sigma1"), ("gamma3", "sigma1"), ("gamma3", "gamma3")])
def test_p2_model_with_a_body_on_a_rigid_plane_next_to_a_pair(conditions):
    """A two-body pair and a body on a rigid plane in one scene: Model == solve(method="full") body by body,
    pair by pair, and the plane's reaction (sol.obstacles) is the same."""
    (top, mid, _), _, gaps = three_blocks()
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=gaps[0], condition=conditions[0]),
             cc.Contact(low, "bottom", plane, gap=lambda s: 5e-3 * (s - 0.45) ** 2 - 2e-5, condition=conditions[1])]
    scene = cc.Scene(top, mid, low, contacts=pairs)
    conic = "gamma3" in conditions
    # conic: both the same program and the same exact finish (accumulated cuts), ok at the default tol
    tol, bound = 1e-6, (1e-7 if conic else 1e-12)
    ref = cc.solve(scene, degree=2, method="full", tol=tol)
    sol = cc.Model(scene, degree=2, tol=tol).solve()
    assert ref.ok and sol.ok and sol.polished, sol.report()
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) < bound
    for c, r in zip(sol.contacts, ref.contacts):
        assert rel(c.lam, r.lam) < (1e-5 if conic else 1e-10)
    assert rel(sol.obstacles[0].force, ref.obstacles[0].force) < (1e-5 if conic else 1e-10)


def test_p2_model_user_row_that_binds_on_a_stack_against_a_dense_reference():
    """A user bound on the middle block's displacement, u_y >= half its value without it, at its right
    corner: the row binds (positive multiplier), the exact finish closes it, and the answer equals the dense
    active-set solve of (26) with that row appended (rows built here from each body's own P2 edges), with
    the same multiplier (N/m)."""
    scene, gaps = _stack()
    bodies = scene.bodies
    free = cc.solve(scene, degree=2)
    j = int(np.argmin(np.linalg.norm(free.points[1] - [1.0, 0.0], axis=1)))
    v0 = free.u[1][j, 1]
    assert v0 < -1e-6
    bound = 0.5 * v0
    model = cc.Model(scene, degree=2)
    con = model.add(model.u(1)[j, 1] >= bound)
    sol = _strict(model)
    assert sol.ok and sol.polished and float(con.dual_value) > 0, sol.report()
    res = sol.residuals()
    assert res["user[0] feasibility"] < 1e-9 and res["user[0] complementarity"] < 1e-9
    assert abs(sol.u[1][j, 1] - bound) <= 1e-12 * abs(bound)
    # the dense reference: every free dof, the contact rows from the bodies' own edges, the user row -u_y <= -bound
    systems, off, K, f, rows, gs, _ = dense_stack(bodies, gaps)
    user = np.zeros((1, off[-1]))
    user[0, off[1] + int(np.flatnonzero(systems[1].u_free == 2 * j + 1)[0])] = -1.0
    u, y = active_set_solve(K, f, np.vstack(rows + [user]), np.concatenate(gs + [[-bound]]))
    for k, (s, a, b) in enumerate(zip(systems, off[:-1], off[1:])):
        assert rel(sol.u[k].ravel()[s.u_free], u[a:b]) < 1e-10            # measured 3e-15
    assert y[-1] > 0
    # the interior point's multiplier of the row (CVXPY's dual_value; the finish does not rewrite it) in N/m:
    # the row is in m, the program's energy in units of force x displacement (J/m)
    W = model.units.force * model.units.displacement
    assert abs(float(con.dual_value) * W - y[-1]) < 1e-6 * y[-1]             # measured 6e-8


@pytest.mark.parametrize("conditions", [("gamma3", "sigma1"), ("sigma1", "sigma2")])
def test_p2_model_with_a_per_pair_compliance_law_on_a_stack(conditions):
    """The top pair under its own normal-compliance law (nodal rows at every P2 node of X_h under gamma3,
    Simpson weights, docs/formulation.md §10) next to a Signorini pair: Model == solve(method="full"), both
    finished exactly; the conic condition on a Signorini pair next to it is solved by solve (interior point)
    and refused by Model, typed."""
    (top, mid, bot), pairs, gaps = three_blocks(conditions)
    law = cc.NormalCompliance(stiffness=1e11, exponent=1)
    pairs[0] = cc.Contact(top, "bottom", mid, "top", gap=gaps[0], condition=conditions[0], law=law)
    scene = cc.Scene(top, mid, bot, contacts=pairs)
    ref = cc.solve(scene, degree=2, method="full")
    sol = _strict(cc.Model(scene, degree=2))
    assert ref.ok and sol.ok and ref.polished and sol.polished, sol.report()
    # two compliance finishes, each stopping at 1e-13 of its interface equation (backends/finish.py) from its
    # own interior point: measured u 0 .. 2.4e-13, lambda_h 1.5e-14 .. 1.8e-11 (clarabel 0.10.0, 0.11.1)
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) < 1e-11
    for c, r in zip(sol.contacts, ref.contacts):
        assert rel(c.lam, r.lam) < 1e-9 and c.active.any()
    pairs[1] = cc.Contact(mid, "bottom", bot, "top", gap=gaps[1], condition="gamma3")
    conic = cc.Scene(top, mid, bot, contacts=pairs)
    # one program in solve (tests/test_p2_mixed_laws.py): complementarity measured 2.4e-6 .. 3.1e-6, so tol=2e-5
    assert cc.solve(conic, degree=2, tol=2e-5).ok
    ref = cc.solve(conic, degree=2, tol=2e-5, method="full")
    sol = cc.Model(conic, degree=2, tol=2e-5).solve()       # the same program, the same read-back
    assert sol.ok
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) < 1e-12                            # measured 0


# ---------------------------------------------------------------- force-controlled obstacles (P1, P2)

def _punch_force(depth=1e-4):
    """test_force_control's flat punch: the resultant F (N/m) of the displacement-controlled punch at
    ``depth``, and the scene with the punch force-controlled by F (it must sink by ``depth``)."""
    disp = cc.solve(punch_scene(0.5 - depth)())
    return disp, punch_scene(0.5)(force=disp.obstacles[0].force)


@pytest.mark.parametrize("case", ["punch P1", "indenter P1", "punch P2 sigma1", "punch P2 gamma3"])
def test_model_with_a_force_controlled_obstacle_is_the_full_solve(case):
    """The obstacle's translation is an unknown of cc.Model with its force balance (docs/formulation.md §12):
    the same program as solve(method="full"), finished the same way (the sparse mixed system with the
    translations; P2 gamma3: the interior point), so the same answer, translation and energy (which includes
    -F . t); the obstacle balance holds and the obstacle sinks by the depth of the displacement-controlled
    scene whose resultant was prescribed."""
    depth, degree, condition = 1e-4, 1, "gamma3"
    if case == "indenter P1":
        R, depth = 0.6, 3e-3
        # posed along the normal (distance="ray"): moving the circle down by t is then exactly g - c . t, so the
        # force-controlled answer is the displacement-controlled one (closest point: to first order in t)
        disp = cc.solve(indenter_scene(0.5 + R - depth, R, distance="ray"))
        scene = indenter_scene(0.5 + R, R, force=disp.obstacles[0].force, distance="ray")
    else:
        disp, scene = _punch_force(depth)
        if "P2" in case:
            degree, condition = 2, case.split()[-1]
    conic = degree == 2 and condition == "gamma3"
    tol, bound = (1e-5, 1e-7) if conic else (1e-6, 1e-12)
    ref = cc.solve(scene, condition, degree=degree, method="full", tol=tol)
    model = cc.Model(scene, condition, degree=degree, tol=tol)
    sol = model.solve() if conic else _strict(model)
    assert sol.ok and ref.ok and sol.polished and ref.polished, sol.report()    # conic: the cuts on (26)
    assert rel(sol.u[0], ref.u[0]) < bound and rel(sol.contact.lam, ref.contact.lam) < 10 * bound   # measured 0
    t, tr = sol.obstacles[0].translation, ref.obstacles[0].translation
    assert np.abs(t - tr).max() < bound * depth and abs(sol.energy - ref.energy) < bound * abs(ref.energy)
    assert sol.residuals()["obstacle balance"] < 1e-9                   # measured 0 (P2 gamma3: 8e-15)
    if degree == 1:                                                       # P1: the displacement-controlled answer
        assert np.abs(t - [0.0, -depth]).max() < 1e-8 * depth and rel(sol.u[0], disp.u[0]) < 1e-8
    assert np.abs(model.translation(0).value - t).max() < 1e-5 * depth    # the IPM's t, in m (measured 1.4e-6)


@pytest.mark.parametrize("degree, condition", [(1, "gamma3"), (2, "sigma1"), (2, "gamma3")])
def test_model_force_controlled_plane_closed_form(degree, condition):
    """test_p2_stack's closed form through cc.Model: a nu = 0 block clamped at its top pushed up by a rigid
    plane with the prescribed force F over its width 1 m, starting 1 mm below it: u = (0, F (H - y) / E)
    (linear in y: exact for P1 and P2), the plane moves by 1 mm + F H / E, lambda_h = F."""
    H, force = 0.5, 2e6
    body = cc.Body(cc.rectangle(x=(0, 1), y=(0, H), nx=5, ny=3), cc.materials.isotropic(E=YOUNG, nu=0.0),
                   clamped=["top"], contact="bottom")
    plane = cc.Rigid.plane(point=(0.0, -1e-3), normal=(0.0, 1.0), force=(0.0, force))
    sol = cc.Model(cc.Scene(body, contacts=[cc.Contact(body, "bottom", plane)]), condition, degree=degree,
                   tol=1e-5).solve()
    assert sol.ok, sol.report()
    want = np.column_stack([np.zeros(len(sol.points[0])), force / YOUNG * (H - sol.points[0][:, 1])])
    assert np.abs(sol.u[0] - want).max() < 1e-9 * force * H / YOUNG
    assert np.abs(sol.obstacles[0].translation - [0.0, 1e-3 + force * H / YOUNG]).max() < 1e-12
    assert np.abs(sol.contact.lam / force - 1).max() < 1e-9


@pytest.mark.parametrize("degree", [1, 2])
def test_user_bound_on_a_force_controlled_translation(degree):
    """A user row on the obstacle's translation (model.translation(0)): the punch, force-controlled by the
    resultant F of a 1e-4 m indentation, may sink by at most 5e-5 m. The row binds, the exact finish (mixed
    system with the translations and the user row) closes it, and the answer is the displacement-controlled
    punch at 5e-5 m; the user row carries the rest of F: its multiplier (N/m) is |F| minus that punch's
    reaction, and the obstacle balance counts it."""
    depth = 1e-4
    _, scene = _punch_force(depth)
    F = scene.obstacles[0].force
    ref = cc.solve(punch_scene(0.5 - depth / 2)(), "sigma1", degree=degree)
    model = cc.Model(scene, "sigma1", degree=degree)
    con = model.add(model.translation(0)[1] >= -depth / 2)
    sol = _strict(model)
    assert sol.ok and sol.polished and ref.ok, sol.report()
    assert rel(sol.u[0], ref.u[0]) < 1e-10 and rel(sol.contact.lam, ref.contact.lam) < 1e-10   # measured 1e-13
    assert np.abs(sol.obstacles[0].translation - [0.0, -depth / 2]).max() < 1e-12 * depth
    res = sol.residuals()
    # the user row is closed by the finish: its slack is rounding, and the check reports the square root of
    # the normalised product z |slack| (docs/checks.md), i.e. up to ~sqrt(eps) = 1.5e-8: measured 0 (Haswell,
    # Nehalem, Sandybridge, Prescott OpenBLAS kernels) and 8.2e-9 (SkylakeX, an AVX-512 CPU); bound 120x that
    assert res["obstacle balance"] < 1e-12 and res["user[0] complementarity"] < 1e-6
    W = model.units.force * model.units.displacement
    rest = -F[1] + ref.obstacles[0].force[1]
    assert rest > 0.1 * -F[1] and abs(float(con.dual_value) * W - rest) < 1e-6 * rest    # measured 2e-10


def test_translation_of_a_fixed_obstacle_and_bad_indices():
    """model.translation(i): the constant 0 for a fixed obstacle, a typed error naming the bad index."""
    model = cc.Model(punch_scene(0.5 - 1e-4)())
    assert isinstance(model.translation(0), cp.Constant) and np.all(model.translation(0).value == 0.0)
    for bad in (1, -1, True, "0"):
        with pytest.raises(cc.SceneError, match="obstacle must be an index into scene.obstacles"):
            model.translation(bad)


@pytest.mark.parametrize("degree", [1, 2])
def test_piezoelectric_wall_actuator_through_the_model(degree):
    """examples/wall_actuator.py's PZT-5H column under a force-controlled wall at V = -4000 V: the wall moves
    by the closed form t = -(p H + e33 V) / c33 (uniaxial strain, exact for P1 and P2; measured 5e-15,
    2e-14). With a user bound t >= t/2 (x = [u; phi; t]: the translation after the potentials) the answer is
    the fixed wall at H + t/2 (u, phi, lambda_h), and the user row carries F0 minus that wall's reaction."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
    try:
        from wall_actuator import F0, H, W, build
    finally:
        sys.path.pop(0)
    mat = cc.materials.PZT5H
    voltage = -4000.0
    exact = -(F0 / W * H + mat.e[1, 1] * voltage) / mat.c[1, 1]
    scene = build(voltage)
    sol = _strict(cc.Model(scene, "sigma1", degree=degree))
    assert sol.ok and sol.polished and abs(sol.obstacles[0].translation[1] / exact - 1) < 1e-12
    model = cc.Model(scene, "sigma1", degree=degree)
    con = model.add(model.translation(0)[1] >= exact / 2)
    sol = _strict(model)
    body = scene.bodies[0]
    wall = cc.Rigid.plane(point=(0.0, H + exact / 2), normal=(0.0, -1.0))
    ref = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", wall)]), "sigma1", degree=degree)
    assert sol.ok and sol.polished and ref.ok, sol.report()
    assert rel(sol.u[0], ref.u[0]) < 1e-9 and rel(sol.phi[0], ref.phi[0]) < 1e-12     # measured 4e-11, 8e-15
    assert rel(sol.contact.lam, ref.contact.lam) < 1e-9                                # measured 2e-11
    rest = F0 + ref.obstacles[0].force[1]
    assert rest > 0.1 * F0 and sol.residuals()["obstacle balance"] < 1e-12
    W_ = model.units.force * model.units.displacement
    assert abs(float(con.dual_value) * W_ - rest) < 1e-6 * rest                        # measured 3e-8


@pytest.mark.parametrize("degree, condition", [(1, "sigma1"), (2, "sigma1"), (2, "gamma3")])
def test_one_force_controlled_plate_on_two_bodies_through_the_model(degree, condition):
    """test_force_control's plate shared by two blocks of different stiffness (two pairs, one translation):
    Model == solve(method="full") (measured identical), the plate's balance over both pairs' forces."""
    soft = cc.materials.isotropic(E=10e9, nu=0.3)
    alu = cc.materials.isotropic(E=70e9, nu=0.33)

    def scene(top, **kw):
        a = cc.Body(cc.rectangle(x=(0.0, 0.4), y=(0.0, 0.5), nx=4, ny=3), alu, clamped="bottom", contact="top")
        b = cc.Body(cc.rectangle(x=(0.6, 1.0), y=(0.2, 0.5), nx=4, ny=2), soft, clamped="bottom", contact="top")
        plate = cc.Rigid.plane((0.0, top), (0.0, -1.0), **kw)
        return cc.Scene(a, b, contacts=[cc.Contact(a, "top", plate), cc.Contact(b, "top", plate)])

    F = cc.solve(scene(0.5 - 1e-4)).obstacles[0].force
    forced = scene(0.5, force=F)
    ref = cc.solve(forced, condition, degree=degree, method="full", tol=1e-5)
    sol = cc.Model(forced, condition, degree=degree, tol=1e-5).solve()
    assert sol.ok and ref.ok and sol.polished == ref.polished, sol.report()
    for a, b in zip(sol.u, ref.u):
        assert rel(a, b) < 1e-9
    assert np.abs(sol.obstacles[0].translation - ref.obstacles[0].translation).max() < 1e-9 * 1e-4
    assert sol.residuals()["obstacle balance"] < 1e-12                  # measured 3e-14 (P2 gamma3)
    assert all(c.force.sum() > 0 for c in sol.contacts)
