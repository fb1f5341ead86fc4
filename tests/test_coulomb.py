"""Coulomb friction (cc.Coulomb, 2D P1, the full program by a fixed point on the Tresca thresholds).

- a block pressed on a rigid plane and sheared below what it can stick: the answer is the block tied
  tangentially (mu above the tied answer's largest |sigma_t| / p: the tied answer satisfies every Coulomb
  condition, so it is the answer);
- sheared beyond mu times its normal force: no equilibrium, refused naming the sliding motion;
- mu = 0 is frictionless; pushed sideways (nu = 0) with a small mu, every node slides and the friction force
  is mu times the normal force exactly;
- a sheared layer (its top moved by (s, -d)) in partial slip against an independent reference written here:
  the same discrete Coulomb law (nodal forces, |R_t| <= mu R_n) solved by a nonsmooth Gauss-Seidel on the
  condensed contact compliance (Delassus) matrix, each node's 2 x 2 local problem solved exactly by cases;
- a pair on a much stiffer block sticks like the block on the rigid plane;
- the law's refusals, the fixed point's warning at its iteration limit and the scene-file key.
"""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc

from friction_scenes import FLOOR, H, L, P, E, pushed, sheared, steel  # noqa: E402


@pytest.mark.numerics
def test_a_block_that_sticks_is_the_block_tied_tangentially():
    q = 0.2 * P
    tied = cc.solve(sheared(q, None, tied=True))
    # the tied answer's |sigma_t| / p, read through a Coulomb law with a large mu (stuck: the tied answer);
    # then mu just above that ratio keeps every node stuck, just below it lets the worst one slip
    big = cc.solve(sheared(q, cc.Coulomb(10.0)))
    assert tied.ok and big.ok
    assert np.abs(big.u[0] - tied.u[0]).max() < 1e-10 * np.abs(tied.u[0]).max()      # measured 4.0e-15
    cb = big.contact
    on = cb.pressure > 0
    ratio = (np.abs(cb.shear[on]) / cb.pressure[on]).max()                           # measured 0.724
    assert np.abs(cb.shear[~on]).max(initial=0.0) < 1e-6 * P                          # no force off contact
    sol = cc.solve(sheared(q, cc.Coulomb(1.01 * ratio)))
    assert sol.ok and sol.path == cc.Route.INTERIOR_POINT_FINISHED and sol.info.finish == cc.Finish.FRICTION_NEWTON
    scale = np.abs(tied.u[0]).max()
    assert np.abs(sol.u[0] - tied.u[0]).max() < 1e-9 * scale                         # measured 3.7e-12
    assert sol.contact.shear_force.sum() == pytest.approx(-q * L, rel=1e-12)         # the load; measured 2.9e-15
    # just below the ratio the tied answer violates the cone at its worst node: that node slips
    below = cc.solve(sheared(q, cc.Coulomb(0.9 * ratio)))
    assert below.ok
    assert np.abs(below.contact.slip).max() > 1e-4 * scale                          # measured 5.0e-3


def test_a_load_beyond_mu_times_the_normal_force_is_refused_naming_the_motion():
    with pytest.raises(cc.SceneError, match=r"slides body 'body 1' along translation x.*5e\+06 N/m.*capacity "
                                            r"3e\+06 N/m.*friction coefficient times the normal force"):
        cc.solve(sheared(0.5 * P, cc.Coulomb(0.3)))


@pytest.mark.numerics
def test_zero_coefficient_is_frictionless_and_a_small_one_slides_with_mu_times_the_normal_force():
    m, _ = pushed(None)
    exact = np.column_stack([np.full(len(m.points), 1e-4), -P * m.points[:, 1] / E])   # rigid translation
    zero = cc.solve(pushed(cc.Coulomb(0.0))[1])
    assert zero.ok
    assert np.abs(zero.u[0] - exact).max() < 1e-10 * 1e-4                            # measured 3.4e-13
    assert np.abs(zero.contact.shear_force).max() < 1e-12 * P * L                     # measured 4.3e-16
    errors = []
    for mu in (1e-5, 1e-4):
        sol = cc.solve(pushed(cc.Coulomb(mu))[1])
        assert sol.ok
        c = sol.contact
        assert (c.slip > 0.5e-4).all()                                                # every node slides forward
        assert c.shear_force.sum() == pytest.approx(-mu * P * L, rel=1e-12)           # measured 4.3e-15, 3.0e-15
        on = c.pressure > 0                                                           # |sigma_t| = mu p everywhere
        assert np.abs(np.abs(c.shear[on]) - mu * c.pressure[on]).max() < 1e-5 * mu * P    # measured 5.5e-8
        errors.append(np.abs(sol.u[0] - exact).max())
    assert errors[1] / errors[0] == pytest.approx(10.0, rel=5e-3)                    # linear in mu; measured 10.0005


def layer(s, d, law, nx=6, ny=3):
    """A layer on the rigid plane, its top moved by (s, -d)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    b = cc.Body(m, steel(), contact="bottom", displacement={"top": (s, -d)})
    return m, cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def gauss_seidel_coulomb(W, q, mu, sweeps=2000):
    """The discrete Coulomb law at n contact nodes, by nonsmooth Gauss-Seidel: u = W R + q (u, R: (t, n) per
    node, n the outward normal of the floor, u_n >= 0 the gap), R_n >= 0, R_n u_n = 0, |R_t| <= mu R_n, R_t = -mu
    R_n sign(u_t) where u_t != 0. Each node's local 2 x 2 problem is solved exactly (open, stuck, or sliding
    either way)."""
    n = len(q) // 2
    R = np.zeros(2 * n)
    for _ in range(sweeps):
        old = R.copy()
        for i in range(n):
            j = slice(2 * i, 2 * i + 2)
            Wii = W[j, j]
            qi = q[j] + W[j] @ R - Wii @ R[j]
            if qi[1] >= 0:
                R[j] = 0.0
                continue
            stuck = np.linalg.solve(Wii, -qi)
            if stuck[1] > 0 and abs(stuck[0]) <= mu * stuck[1]:
                R[j] = stuck
                continue
            for sign in (1.0, -1.0):            # sliding with u_t of this sign: R_t = -sign mu R_n, u_n = 0
                rn = -qi[1] / (Wii[1, 1] - sign * mu * Wii[1, 0])
                rt = -sign * mu * rn
                ut = Wii[0, 0] * rt + Wii[0, 1] * rn + qi[0]
                if rn > 0 and sign * ut >= 0:
                    R[j] = (rt, rn)
                    break
            else:
                raise AssertionError(f"no local solution at node {i}")
        if np.abs(R - old).max() <= 1e-15 * np.abs(R).max():
            break
    return R


@pytest.mark.numerics
def test_a_sheared_layer_in_partial_slip_matches_a_gauss_seidel_reference():
    from cvxcontact.fem.space import P1

    s, d, mu = 3e-6, 1e-5, 0.3
    m, scene = layer(s, d, cc.Coulomb(mu))
    sol = cc.solve(scene)               # the exact finish: stick-slip 3.3e-9 (the square root of a product at rounding)
    assert sol.ok and sol.info.finish == cc.Finish.FRICTION_NEWTON
    body = scene.bodies[0]
    system = P1().assemble_loads(body, P1().assemble_matrices(body))        # SI, the prescribed top lifted
    Tu, u_fixed = system.Tu, system.u_fixed
    Kzz = (Tu.T @ system.Kuu @ Tu).toarray()
    fz = Tu.T @ system.f
    bottom = np.flatnonzero(np.abs(m.points[:, 1]) < 1e-12)
    bottom = bottom[np.argsort(m.points[bottom, 0])]
    rows = np.ravel(np.column_stack([2 * bottom, 2 * bottom + 1]))            # (x, y) of every bottom node
    Pc = sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)), rows)), shape=(len(rows), Tu.shape[0]))
    PT = (Pc @ Tu).toarray()
    W = PT @ np.linalg.solve(Kzz, PT.T)                                       # m per N/m
    q = PT @ np.linalg.solve(Kzz, fz) + Pc @ u_fixed
    R = gauss_seidel_coulomb(W, q, mu)
    u_ref = Tu @ np.linalg.solve(Kzz, fz + PT.T @ R) + u_fixed
    ref = u_ref.reshape(-1, 2)
    slips = np.abs(ref[bottom, 0]) > 1e-3 * np.abs(ref[bottom, 0]).max()
    assert 2 <= slips.sum() <= len(bottom) - 2                               # partial slip: 3 of 7 nodes slip
    # the finish and the reference meet at rounding (the interior point alone: 6.6e-12, 1.2e-11, 2.6e-12)
    assert np.abs(sol.u[0] - ref).max() < 1e-13 * np.abs(ref).max()         # measured 6.5e-16 (Prescott 4.7e-16)
    c = sol.contact                                       # the tangential and normal nodal forces on the layer
    assert np.abs(c.shear_force - R[0::2]).max() < 2e-13 * np.abs(R).max()  # measured 1.1e-15 (Prescott 1.3e-15)
    assert np.abs(c.pressure * c.measure - R[1::2]).max() < 2e-13 * np.abs(R).max()  # measured 1.1e-15 (both)


@pytest.mark.numerics
def test_a_pair_on_a_much_stiffer_block_sticks_like_the_block_on_the_rigid_plane():
    q = 0.2 * P
    top = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4)
    below = cc.rectangle(x=(0.0, L), y=(-H, 0.0), nx=8, ny=4)
    a = cc.Body(top, steel(), contact="bottom", traction={"top": (q, -P)}, name="top")
    b = cc.Body(below, steel(scale=1e6), contact="top", clamped="bottom", name="below")
    sol = cc.solve(cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=cc.Coulomb(0.4))]))
    rigid = cc.solve(sheared(q, cc.Coulomb(0.4)))
    assert sol.ok and rigid.ok
    assert sol.contact.shear_force.sum() == pytest.approx(-q * L, rel=1e-7)   # measured 1.3e-9 (equilibrium 6e-10)
    scale = np.abs(rigid.u[0]).max()
    assert np.abs(sol.u[0] - rigid.u[0]).max() < 1e-3 * scale               # measured 1.8e-6 (the stiffness ratio 1e-6)


def test_the_fixed_point_warns_at_its_iteration_limit_and_its_checks_say_how_far():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = cc.solve(sheared(0.35 * P, cc.Coulomb(0.4, max_iterations=1)), polish=False)
    fixed = [w for w in caught if issubclass(w.category, cc.FixedPointWarning)]
    assert len(fixed) == 1 and "max_iterations" in str(fixed[0].message)
    assert not sol.ok and sol.residuals()["stick-slip"] > 1e-4        # one iterate from the stuck start: 1.3e-3
    assert len(sol.info.fixed_point) == 1
    # the exact finish from that iterate reaches Coulomb's law itself (its capacities mu y_a the answer's own):
    # no warning, and the same answer as the converged fixed point's finish
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.FixedPointWarning)
        short = cc.solve(sheared(0.35 * P, cc.Coulomb(0.4, max_iterations=1)))
    assert short.ok and short.info.finish == cc.Finish.FRICTION_NEWTON and len(short.info.fixed_point) == 1
    converged = cc.solve(sheared(0.35 * P, cc.Coulomb(0.4)))
    changes = converged.info.fixed_point                                # contracting, then at the tolerance
    assert converged.ok and 2 <= len(changes) < 50 and changes[-1] <= 1e-8
    scale = np.abs(converged.u[0]).max()
    assert np.abs(short.u[0] - converged.u[0]).max() < 1e-10 * scale           # measured 9.5e-16


def test_the_law_refuses_bad_parameters_and_scene_files_name_it():
    from cvxcontact.io.scenefile import SceneFileError, _law

    for bad in (-0.1, float("nan"), "0.3", True):
        with pytest.raises(cc.SceneError, match="Coulomb: coefficient"):
            cc.Coulomb(bad)
    with pytest.raises(cc.SceneError, match="tolerance"):
        cc.Coulomb(0.3, tolerance=0.0)
    with pytest.raises(cc.SceneError, match="max_iterations"):
        cc.Coulomb(0.3, max_iterations=0)
    assert _law({"coulomb": {"coefficient": 0.3}}, "scene.toml") == cc.Coulomb(0.3)
    with pytest.raises(SceneFileError, match="law.coulomb: expected keys coefficient"):
        _law({"coulomb": {"mu": 0.3}}, "scene.toml")
    with pytest.raises(SceneFileError, match="law.coulomb: Coulomb: coefficient"):
        _law({"coulomb": {"coefficient": -1.0}}, "scene.toml")


SCENE = """
[[body]]
name = "block"
material = { E = 200e9, nu = 0.3 }
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 8, ny = 4 } }
contact = "bottom"
traction = { top = [3.5e6, -1e7] }

[[obstacle]]
name = "floor"
plane = { point = [0.0, 0.0], normal = [0.0, 1.0] }

[[contact]]
a = "block"
part_a = "bottom"
b = "floor"
law = { coulomb = { coefficient = 0.4 } }
"""


def test_a_scene_file_poses_coulomb_on_its_pair(tmp_path):
    from cvxcontact.io.scenefile import load_scene

    path = tmp_path / "block.toml"
    path.write_text(SCENE, encoding="utf-8")
    sol = load_scene(path).solve()
    assert sol.ok and sol.scene.contacts[0].law == cc.Coulomb(0.4)
    assert sol.contact.shear_force.sum() == pytest.approx(-3.5e6, rel=1e-9)          # the file's shear load
    direct = cc.solve(sheared(0.35 * P, cc.Coulomb(0.4)))                              # the same scene in code
    assert np.abs(sol.u[0] - direct.u[0]).max() < 1e-12 * np.abs(direct.u[0]).max()


@pytest.mark.numerics
def test_a_sweep_over_the_coefficient_stores_the_friction_read_back(tmp_path):
    """A sweep of the scene file above over the Coulomb coefficient: each case's arrays hold the friction read-back
    (slip, tangential forces, traction, threshold; with their units) equal to the direct solve's, and the stored
    tangential forces balance the file's shear load (3.5e6 N/m)."""
    import json

    from cvxcontact.apps.sweep import run_sweep

    (tmp_path / "block.toml").write_text(SCENE, encoding="utf-8")
    (tmp_path / "sweep.toml").write_text('scene = "block.toml"\nconditions = ["sigma1"]\n[grid]\n'
                                         '"contact[0].law.coulomb.coefficient" = [0.4, 0.6]\n', encoding="utf-8")
    report = run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1)
    assert report.done == 2 and not report.failed
    results = cc.load_sweep(tmp_path / "out")
    for case in json.loads((tmp_path / "out" / "manifest.json").read_text())["cases"]:
        mu = case["overrides"]["contact[0].law.coulomb.coefficient"]
        ref = cc.solve(sheared(0.35 * P, cc.Coulomb(mu)), "sigma1").contact
        arrays = results.arrays(case["id"])
        for name in ("slip", "shear_force", "shear", "threshold"):
            expected = np.asarray(getattr(ref, name))
            assert np.abs(arrays[name] - expected).max() <= 1e-10 * np.abs(expected).max(), name
        assert arrays["shear_force"].sum() == pytest.approx(-3.5e6, rel=1e-9)
        record = json.loads((tmp_path / "out" / "cases" / f"{case['id']}.json").read_text())
        assert record["units"]["slip"] == "m" and record["units"]["shear"] == "Pa"
