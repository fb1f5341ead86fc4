"""Friction next to a normal-compliance pair, and friction next to a force-controlled obstacle (docs/howto/friction.md,
"Next to a compliance law", "Next to a force-controlled obstacle"; scenes in tests/friction_scenes.py).

Independent references:
- a compliance pair and a stuck sheared layer in series: springs in series and the stuck shear in closed form
  (nu = 0, uniform state: P1 and P2 reproduce it);
- Tresca's g = 0 beside a compliance law is the frictionless mixed answer (Signorini and compliance pairs);
- the compliance law and Tresca's law read off the answer by this module's own code (penetration from u, the
  pressure k r; the shear force against g w_a and the slip's direction);
- a force-controlled plane: the obstacle's translation found, the plane then prescribed at that position: the same u
  and the same force (an invariance).
"""

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import captured
from friction_scenes import (
    DIAGONAL3,
    FLOOR3D,
    E,
    H,
    L,
    P,
    compliant_series,
    compliant_series3d,
    compliant_series3d_exact,
    compliant_series_exact,
    friction_held_layers,
    lidded,
    steel,
    walled,
)

import cvxcontact as cc
from cvxcontact.geometry.quadratic import P2Nodes, P2TetNodes
from cvxcontact.solution.readback import read_back

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

K = 1e13
"""The compliance stiffness (Pa/m): a penetration p / K = 1 um under p = 10 MPa, beside the layers' 25 um."""


def rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def solved(scene, **kw):
    """The solution of ``scene``, a ResidualWarning an error (a declined finish, failed checks)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        return cc.solve(scene, **kw)


@pytest.mark.parametrize("dim, degree, cell, coulomb", [(2, 1, None, False), (2, 1, None, True), (2, 2, None, False),
                                                          (3, 1, "tetra", False), (3, 1, "tetra", True),
                                                          (3, 1, "hex", False), (3, 2, "tetra", False),
                                                          (3, 2, "tetra", True)])
def test_compliance_pair_and_stuck_layer_in_series_closed_form(dim, degree, cell, coulomb):
    """Two layers under (tau, -p), stuck together by Tresca (g = p / 2 > tau; or Coulomb, mu = 1/2), the lower one
    on the floor under the compliance law: u = (tau y' / G, -p / k - p y' / E), y' the height above the floor, in
    both layers."""
    tau = 0.1 * P
    law = cc.Coulomb(0.5) if coulomb else None
    if dim == 2:
        scene, exact = compliant_series(tau, K, g=0.5 * P, law=law), compliant_series_exact
    else:
        scene, exact = compliant_series3d(tau, K, g=0.5 * P, cell=cell, law=law), compliant_series3d_exact
    kw = {"degree": 2, "condition": "sigma1"} if degree == 2 else {}
    sol = solved(scene, **kw)
    assert sol.ok and sol.polished and sol.info.declined is None
    for i, body in enumerate(scene.bodies):
        points = body.mesh.points if degree == 1 else (P2Nodes if dim == 2 else P2TetNodes)(body.mesh).points
        # measured: 3.2e-15 / 5.0e-15 (2D P1), 1.5e-14 (2D P2), 6.0e-16 (3D tetra; Coulomb 8.2e-16), 8.7e-16 (hex),
        # 9.5e-15 (P2 tetrahedra: the law's rows at quadrature points of its faces; Coulomb 1.1e-14)
        assert rel(sol.u[i], exact(points, tau, K)) < 1e-11
    floor = sol.contacts[1]                                   # the compliance pair: lambda = k r = p everywhere
    assert rel(floor.lam, np.full(len(floor.lam), P)) < 1e-11   # measured at most 1.5e-14
    assert np.all(floor.active)


def test_tresca_to_zero_beside_compliance_is_the_frictionless_mixed_answer():
    """walled: Tresca(g) on the floor, the compliance law on the wall. g = 0 is the frictionless answer (Signorini
    floor beside the compliant wall, the term ComplianceRows' own route); a small g departs from it by O(g)."""
    law = cc.NormalCompliance(K)
    ref = solved(walled(cc.Signorini(), law))
    zero = solved(walled(cc.Tresca(0.0), law))
    assert ref.ok and zero.ok and zero.polished
    assert rel(zero.u[0], ref.u[0]) < 1e-12                   # measured 6.7e-16
    assert rel(zero.contacts[1].lam, ref.contacts[1].lam) < 1e-12
    gaps = [rel(solved(walled(cc.Tresca(g), law)).u[0], ref.u[0]) for g in (1e2, 1e3)]
    assert 0 < gaps[0] < gaps[1] < 1e-2                       # measured 1.7e-5, 1.7e-4 (g / p = 1e-5, 1e-4)
    assert 5 < gaps[1] / gaps[0] < 20                         # linear in g (measured ratio 10.000)


def test_the_laws_read_off_by_own_code():
    """walled with Coulomb on the floor and a compliance law on the wall: at the wall p = k [u_x - 0]_+ from the
    displacement (this module's penetration), 0 where open; on the floor |shear force| <= mu lambda w (to rounding)
    and, where it slips, the force anti-parallel to the slip at that bound."""
    mu = 0.2
    scene = walled(cc.Coulomb(mu), cc.NormalCompliance(K))
    sol = solved(scene)
    assert sol.ok and sol.polished
    body = scene.bodies[0]
    wall = sol.contacts[1]
    pts = body.mesh.points
    ux = np.array([sol.u[0][np.argmin(np.linalg.norm(pts - x, axis=1)), 0] for x in wall.points])
    penetration = np.maximum(ux - 0.0, 0.0)                    # the wall at x = L, the part's nodes at x = L
    assert penetration.max() > 0
    assert rel(wall.lam, K * penetration) < 1e-12              # measured 2.0e-16 (the lumped nodal law)
    floor = sol.contacts[0]
    capacity = mu * floor.force                                # mu lambda w_a: mu times the nodal normal force
    shear = np.abs(floor.shear_force)
    assert np.all(shear <= capacity + 1e-12 * capacity.max())  # measured: max(shear - capacity) = 0.0
    slipping = np.abs(floor.slip) > 1e-6 * np.abs(sol.u[0]).max()
    assert slipping.any()
    assert rel(shear[slipping], capacity[slipping]) < 1e-12    # measured 5.8e-17 (2 of the 9 rows slip)
    assert np.all(np.sign(floor.shear_force[slipping]) == -np.sign(floor.slip[slipping]))


@pytest.mark.parametrize("law, lid_law, kw", [
    (cc.Tresca(0.2 * P), None, {}),
    (cc.Coulomb(0.3), None, {}),
    (cc.Coulomb(0.3), cc.Tresca(0.1 * P), {}),
    (cc.Coulomb(0.3), cc.NormalCompliance(K), {}),
    (cc.Coulomb(0.3), None, {"degree": 2, "condition": "sigma1"}),
])
def test_force_controlled_plane_beside_friction_is_the_prescribed_one(law, lid_law, kw):
    """lidded: the plane on top under the force (0, -p) N/m, friction on the floor (and on the lid): its
    translation found, then the plane prescribed there: the same displacement, and its force the prescribed one."""
    forced = solved(lidded(law, lid_law=lid_law), **kw)
    assert forced.ok and forced.polished and forced.info.declined is None
    t = forced.obstacles[1].translation
    assert t[0] == 0.0 and t[1] < 0
    fixed = solved(lidded(law, force=None, at=H + t[1], lid_law=lid_law), **kw)
    assert fixed.ok and fixed.polished
    assert rel(forced.u[0], fixed.u[0]) < 1e-9                # measured 6e-14 .. 1.2e-12
    assert rel(fixed.obstacles[1].force, [0.0, -P]) < 1e-9    # measured 1e-15 .. 9e-13
    assert rel(forced.obstacles[1].force, [0.0, -P]) < 1e-12
    assert forced.residuals()["obstacle balance"] < 1e-12


def test_force_controlled_plane_beside_friction_3d():
    """The 3D counterpart: a unit cube on the floor z = 0 with Coulomb, sheared on its right face, pressed by a
    force-controlled plane on its top; prescribed at the translation found, the same answer."""

    def scene(force=-P, at=1.0):
        body = cc.Body(cc.box(nx=2, ny=2, nz=2), steel(), contact="bottom",
                       traction={"right": (0.0, 0.05 * P * DIAGONAL3[0], 0.05 * P * DIAGONAL3[1])})
        lid = cc.Rigid.plane(point=(0.0, 0.0, at), normal=(0.0, 0.0, -1.0),
                             force=None if force is None else (0.0, 0.0, force))
        return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=cc.Coulomb(0.3)),
                                        cc.Contact(body, "top", lid)])

    forced = solved(scene())
    assert forced.ok and forced.polished
    t = forced.obstacles[1].translation
    fixed = solved(scene(force=None, at=1.0 + t[2]))
    assert fixed.ok and fixed.polished
    assert rel(forced.u[0], fixed.u[0]) < 1e-9
    assert rel(fixed.obstacles[1].force, [0.0, 0.0, -P]) < 1e-9


def test_a_declined_finish_is_flagged(monkeypatch):
    """Where the friction finish beside a compliance law declines, the interior point's answer is kept with a
    ResidualWarning and info.declined (never a silent interior-point answer called finished)."""
    from cvxcontact.backends import friction
    from cvxcontact.backends.finish import Declined, Stop

    monkeypatch.setattr(friction, "_sequential", lambda *a, **k: Declined(Stop.STALL, "planted"))
    with pytest.warns(cc.ResidualWarning, match="declined"):
        sol = cc.solve(walled(cc.Tresca(1e5), cc.NormalCompliance(K)))
    assert not sol.polished and sol.info.declined is not None and "planted" in str(sol.info.declined)


def test_a_translation_held_by_the_compliance_law_alone_balances_to_rounding(monkeypatch):
    """walled(Tresca(0.1 p), the wall's law p = k r^2): the block's x-translation is held by the wall's law alone,
    117 m of it (scaled 104.7) beside a deformation of 0.28, so each row's size |K| |u| is the translation's. The
    sequential finish stopped on the rows' relative residual (1e-12) with the translation's balance at 4.5e-10; it
    now steps on until the held motions balance to rounding (frictionsteps.HELD_ROUNDING)."""
    from cvxcontact.solution.checks import rigid_balance

    sol, p, raw = captured(monkeypatch, walled(cc.Tresca(0.1 * P), cc.NormalCompliance(1e11, exponent=2.0)))
    assert sol.ok and sol.polished and sol.info.declined is None
    # the check's reading (the balance on the deformation, whose own rounding is that of subtracting the 104.7 of
    # translation): measured 3.4e-12 default, 2.5e-12 Prescott, 2.8e-12 Sandybridge; 4.5e-10 before
    assert sol.residuals()["equilibrium"] <= 3.4e-10
    data, blk, s, body = p.term.data, p.blocks[0], p.systems[0], p.scene.bodies[0]
    Tmu = data.rows.T @ np.asarray(raw.tangential, dtype=float)
    sizes = abs(data.rows).T @ np.tile(np.linalg.norm(raw.tangential.reshape(data.components, -1), axis=0),
                                       data.components)
    modes = (s.Tu.T @ body.held_modes(p.meshes[0]).T).T
    assert len(modes) == 3
    T = data.operators[0]
    # the balance of the residual the finish solves (on u itself): measured 2.5e-13 default, 5.9e-14 Prescott,
    # 7.6e-14 Sandybridge; 4.4e-10 before
    balance = rigid_balance(blk, modes, raw.u[0], raw.phi[0], p.E.T @ raw.y, (T.T @ Tmu, abs(T).T @ sizes),
                            prolongation=s.Tu, dim=2)
    assert balance <= 2.5e-11


@pytest.mark.parametrize("law", [cc.Tresca(1e6), cc.Coulomb(0.3)])
def test_force_controlled_sphere_on_a_frictional_pair_is_the_translated_scene(law):
    """3D (docs/refusals.md row 52): a block clamped at its base pressed by a force-controlled sphere (force
    (1e4, 5e3, -1e5) N) with friction on that pair; its translation t slips the rows (the sphere's tangents are
    tilted). The scene translated by -t (the sphere fixed where it started, the base moved by -t) has the same
    relative motion: its u is u - t."""
    mesh = cc.box(nx=4, ny=4, nz=2)
    F = np.array([1e4, 5e3, -1e5])
    sphere = cc.Rigid.sphere(center=(0.5, 0.5, 1.5), radius=0.5, force=tuple(F))
    body = cc.Body(mesh, steel(), contact="top", clamped="bottom")
    forced = solved(cc.Scene(body, contacts=[cc.Contact(body, "top", sphere, law=law)]))
    assert forced.ok and forced.polished
    t = forced.obstacles[0].translation
    assert np.abs(t[:2]).min() > 0                            # measured (1.6e-7, 8.1e-8, -4.9e-7) (Tresca)
    moved = cc.Body(mesh, steel(), contact="top", displacement={"bottom": tuple(-t)})
    ref = solved(cc.Scene(moved, contacts=[cc.Contact(moved, "top", sphere.with_force(None), law=law)]))
    assert ref.ok and ref.polished
    assert rel(forced.u[0] - t, ref.u[0]) <= 1e-12            # measured 1.3e-15, 1.4e-15
    assert rel(forced.obstacles[0].force, F) <= 1e-13         # measured 2.9e-16, 0


def _series_exact(points, tau, r):
    """u of :func:`compliant_series` with the floor's penetration ``r`` (m): (tau y' / G, -r - p y' / E)."""
    y = np.asarray(points, dtype=float)[:, 1] + H
    return np.column_stack([tau * y / (E / 2), -r - P * y / E])


@pytest.mark.parametrize("coulomb", [False, True])
@pytest.mark.parametrize("floor_law, r", [
    (cc.NormalCompliance(P / 1e-12, exponent=2.0), 1e-6),                            # k r^2 = p: r = 1 um
    (cc.NormalCompliance(P / 1e-9, exponent=1.5), 1e-6),
    (cc.NormalCompliance(K, penetration_limit=0.5e-6), 0.5e-6),                      # p / k = 1 um beyond the limit
    (cc.NormalCompliance(K, penetration_limit=2e-6), 1e-6),                          # the limit not reached
    (cc.NormalCompliance(P / 1e-12, exponent=2.0, penetration_limit=0.5e-6), 0.5e-6),
])
def test_nonlinear_compliance_and_a_penetration_limit_beside_friction_closed_form(floor_law, r, coulomb):
    """The layers in series with a nonlinear law (m = 2, 1.5: r = (p / k)^(1/m)) or a penetration limit on the floor
    (r = min(l, (p / k)^(1/m)): Signorini at the limit) beside the stuck Tresca / Coulomb pair: u in closed form,
    lambda = p on the floor."""
    tau = 0.1 * P
    scene = compliant_series(tau, K, g=0.5 * P, law=cc.Coulomb(0.5) if coulomb else None, floor_law=floor_law)
    sol = solved(scene)
    assert sol.ok and sol.polished and sol.info.declined is None
    for i, body in enumerate(scene.bodies):
        assert rel(sol.u[i], _series_exact(body.mesh.points, tau, r)) < 1e-11     # measured at most 6.1e-15
    assert rel(sol.contacts[1].lam, np.full(len(sol.contacts[1].lam), P)) < 1e-11  # measured at most 8.8e-15


@pytest.mark.parametrize("law", [cc.Tresca(0.3 * P), cc.Coulomb(0.3)])
@pytest.mark.parametrize("wall_law", [cc.NormalCompliance(K), cc.NormalCompliance(1e11, exponent=2.0)])
def test_an_open_compliance_pair_beside_friction_is_the_open_frictionless_one(law, wall_law):
    """walled with the wall 1 mm away (never touched; the floor's friction holds the block): the compliance law's
    energy and its semismooth tangent at r < 0 are 0, so the answer is that with a frictionless (Signorini) wall."""
    ref = solved(walled(law, None, gap=1e-3))
    sol = solved(walled(law, wall_law, gap=1e-3))
    assert sol.ok and sol.polished and sol.info.declined is None
    assert rel(sol.u[0], ref.u[0]) < 1e-12                    # measured at most 1.1e-15
    assert np.all(sol.contacts[1].lam == 0.0) and np.all(ref.contacts[1].lam == 0.0)


@pytest.mark.parametrize("law", [cc.Coulomb(0.3), cc.Tresca(0.3 * P)])
def test_force_controlled_lid_the_friction_capacity_in_closed_form(law):
    """lidded: the lid presses with p L, so the floor holds at most 0.3 p L along x (Coulomb: mu p L; Tresca: g L).
    At 0.99 of it the block is held (the floor's shear forces sum to -q H); at 1.01 a SceneError names the
    capacity 3e+06 N/m, never an answer."""
    capacity = 0.3 * P * L
    sol = solved(lidded(law, q=0.99 * capacity / H))
    assert sol.ok and sol.polished
    assert abs(sol.contacts[0].shear_force.sum() + 0.99 * capacity) < 1e-11 * capacity   # measured 1.0e-14, 1.3e-14
    with pytest.raises(cc.SceneError, match="exceeds the friction capacity 3e\\+06 N/m"):
        cc.solve(lidded(law, q=1.01 * capacity / H))


def test_a_tangential_force_on_a_forced_plane_is_refused_with_friction_too():
    """A plane pressed with a force not along its normal: its tangential translation is its guide's (docs/howto/
    friction.md), so even with friction on its pair the tangential part is refused by name (docs/refusals.md row
    21), never balanced silently; along its normal the same scene is taken, the obstacle balanced."""
    a = np.deg2rad(10.0)
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    mesh = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4)
    mesh = mesh.with_points(mesh.points @ R.T)
    normal = R @ [0.0, -1.0]

    def scene(force):
        body = cc.Body(mesh, steel(), contact="top", clamped="bottom")
        lid = cc.Rigid.plane(point=tuple(R @ [0.0, H]), normal=tuple(normal), force=tuple(force))
        return cc.Scene(body, contacts=[cc.Contact(body, "top", lid, law=cc.Coulomb(0.3))])

    with pytest.raises(cc.SceneError, match="cannot balance"):
        cc.solve(scene((0.0, -P)))                            # 0.17 p along the plane: within mu p, still refused
    sol = solved(scene(P * normal))
    assert sol.ok and sol.polished
    assert rel(sol.obstacles[0].force, P * normal) < 1e-12     # measured 1.9e-16
    assert sol.residuals()["obstacle balance"] < 1e-12         # measured 1.9e-16


def test_an_outside_backend_without_the_route_refuses_and_auto_takes_full():
    """A backend registered with no "compliance_friction" route: method=its name is a SolverError naming the kind
    and the fix; method="auto" solves with "full"."""
    from cvxcontact import backends

    entry = backends.Backend("outside", accepts=lambda d: True,
                             routes={"signorini": "cvxcontact.backends.full:full",
                                     "friction": "cvxcontact.backends.friction:full"})
    backends.register(entry, before="full")
    try:
        scene = walled(cc.Tresca(1e5), cc.NormalCompliance(K))
        with pytest.raises(cc.SolverError, match="compliance_friction.*method='auto' or 'full'"):
            cc.solve(scene, method="outside")
        sol = solved(scene)
        assert sol.ok and sol.info.method == "full"
    finally:
        backends.unregister("outside")


@pytest.mark.parametrize("cell", ["hex", "tetra"])
def test_3d_coulomb_sliding_beside_compliance_walls_laws_read_off_by_own_code(cell):
    """A unit box on the floor with Coulomb (mu = 0.2) under (0.3 p (cos 0.4, sin 0.4), -p) on its top, held by a
    linear compliance wall at x = 1 and a quadratic one (m = 2) at y = 1: most floor rows slip. Read off by this
    module's own code: the walls' lambda = k pen^m from u; on the floor |shear| <= mu y_a (hex: y_a = lambda w_a,
    w_a the bottom face's lumped areas computed here), at the bound and anti-parallel to the slip where it slips;
    the box's force balance (its loads against the contact forces)."""
    mu, th, kx, ky = 0.2, 0.4, 1e12, 1e17
    mesh = cc.box(nx=3, ny=3, nz=2, cell=cell)
    load = np.array([0.3 * P * np.cos(th), 0.3 * P * np.sin(th), -P])
    body = cc.Body(mesh, steel(), contact="bottom", traction={"top": tuple(load)})
    walls = [cc.Rigid.plane(point=(1.0, 0.0, 0.0), normal=(-1.0, 0.0, 0.0)),
             cc.Rigid.plane(point=(0.0, 1.0, 0.0), normal=(0.0, -1.0, 0.0))]
    sol = solved(cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=cc.Coulomb(mu)),
                                          cc.Contact(body, "right", walls[0], law=cc.NormalCompliance(kx)),
                                          cc.Contact(body, "back", walls[1], law=cc.NormalCompliance(ky, exponent=2.0))]))
    assert sol.ok and sol.polished and sol.info.declined is None
    pts, u = mesh.points, sol.u[0]

    def at(points):
        return np.array([np.argmin(np.linalg.norm(pts - x, axis=1)) for x in points])

    for c, j, k, m in [(sol.contacts[1], 0, kx, 1.0), (sol.contacts[2], 1, ky, 2.0)]:
        pen = np.maximum(u[at(c.points), j], 0.0)             # the walls at x = 1, y = 1: the part's own faces
        assert pen.max() > 0
        assert rel(c.lam, k * pen**m) < 1e-12                 # measured at most 3.5e-16
    floor = sol.contacts[0]
    y = floor.force
    if cell == "hex":                                         # lumped areas of the bottom quadrilaterals
        w = np.zeros(len(pts))
        for c in mesh.cells:
            on = c[np.abs(pts[c, 2]) < 1e-12]
            if len(on) == 4:
                w[on] += np.ptp(pts[on, 0]) * np.ptp(pts[on, 1]) / 4
        y = floor.lam * w[at(floor.points)]
        assert rel(y, floor.force) < 1e-12                    # measured 2.9e-16
    shear, slip = np.linalg.norm(floor.shear_force, axis=1), np.linalg.norm(floor.slip, axis=1)
    assert np.all(shear <= mu * y + 1e-12 * y.max())          # measured: max(shear - mu y) = 0.0
    slipping = slip > 1e-6 * np.abs(u).max()
    assert slipping.sum() >= len(slip) // 2                   # measured 15 of 16
    assert np.abs(shear - mu * y)[slipping].max() < 1e-12 * y.max()     # measured 5.4e-16 (hex), 3.6e-17 (tetra)
    cos = np.einsum("ij,ij->i", floor.shear_force[slipping], floor.slip[slipping]) / (shear * slip)[slipping]
    assert np.all(cos < -1 + 1e-9)                            # measured -1 + 2e-16
    resultant = np.array([*floor.shear_force.sum(axis=0), floor.force.sum()])
    resultant -= [sol.contacts[1].force.sum(), sol.contacts[2].force.sum(), 0.0]
    assert np.linalg.norm(load + resultant) < 1e-12 * np.linalg.norm(load)      # measured 1.2e-16, 4.2e-16


@pytest.mark.parametrize("law", [cc.Tresca(1e6), cc.Coulomb(0.5)])
@pytest.mark.parametrize("wall_law", [cc.NormalCompliance(1e11), cc.NormalCompliance(1e16, exponent=2.0)])
def test_force_controlled_disk_on_a_frictional_pair_beside_a_compliance_wall_is_the_translated_scene(law, wall_law):
    """Both at once: a block clamped at its base, pressed by a force-controlled disk (force (3e5, -1e6) N/m, within
    mu = 0.5 of its pair; friction there) towards a compliance wall (linear, quadratic) on its right face. The scene
    translated by -t (the disk fixed where it started, the base and the wall moved by -t) has the same relative
    motion: its u is u - t, the wall's pressures the same, the disk's force the prescribed one."""
    mesh = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=16, ny=4, segments={"side": ("right", H / 2, H)})
    F = np.array([3e5, -1e6])
    disk = cc.Rigid.circle(center=(0.5, H + 0.5), radius=0.5, force=tuple(F))
    wall = cc.Rigid.plane(point=(L, 0.0), normal=(-1.0, 0.0))
    body = cc.Body(mesh, steel(), contact="top", clamped="bottom")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)        # a contact zone of a few nodes under the disk
        forced = solved(cc.Scene(body, contacts=[cc.Contact(body, "top", disk, law=law),
                                                 cc.Contact(body, "side", wall, law=wall_law)]))
        t = forced.obstacles[0].translation
        moved = cc.Body(mesh, steel(), contact="top", displacement={"bottom": tuple(-t)})
        ref = solved(cc.Scene(moved, contacts=[cc.Contact(moved, "top", disk.with_force(None), law=law),
                                               cc.Contact(moved, "side", wall.moved(tuple(-t)), law=wall_law)]))
    assert forced.ok and forced.polished and ref.ok and ref.polished
    assert np.abs(t[0]) > 0 and np.abs(forced.contacts[0].slip).max() > 0    # measured t_x 3.0e-6 .. 3.7e-6
    assert rel(forced.u[0] - t, ref.u[0]) < 1e-10             # measured 2.9e-15 .. 2.3e-13
    assert rel(forced.contacts[1].lam, ref.contacts[1].lam) < 1e-8      # measured 2.7e-15 .. 1.3e-11
    assert rel(forced.obstacles[0].force, F) < 1e-13          # measured 0 .. 1.2e-16
    assert forced.residuals()["obstacle balance"] < 1e-13     # measured 0 .. 1.1e-16


def test_3d_force_controlled_sphere_on_a_free_box_the_floor_capacity_mu_n():
    """A free box on a Coulomb floor (mu = 0.3), pressed by a force-controlled sphere (Coulomb 0.5 on its pair)
    under F = (r N cos 0.3, r N sin 0.3, -N): the floor holds the box and the sphere for r = 0.299 < mu (the floor's
    shear forces sum to -F_t, the sphere's force is F); r = 0.31 > mu is a SceneError naming the friction capacity,
    never an answer."""
    def scene(r):
        F = 1e5 * np.array([r * np.cos(0.3), r * np.sin(0.3), -1.0])
        body = cc.Body(cc.box(nx=4, ny=4, nz=2), steel(), contact="bottom")
        sphere = cc.Rigid.sphere(center=(0.5, 0.5, 1.5), radius=0.5, force=tuple(F))
        return F, cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=cc.Coulomb(0.3)),
                                           cc.Contact(body, "top", sphere, law=cc.Coulomb(0.5))])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)        # the sphere's zone: a few nodes
        F, held = scene(0.299)
        sol = solved(held)
        assert sol.ok and sol.polished
        floor = sol.contacts[0]
        assert rel(floor.shear_force.sum(axis=0), -F[:2]) < 1e-11      # measured 5.3e-14
        assert rel(floor.force.sum(), -F[2]) < 1e-12                    # measured 1.0e-15
        assert rel(sol.obstacles[1].force, F) < 1e-12                   # measured 3.6e-17
        with pytest.raises(cc.SceneError, match="exceeds the friction capacity"):
            cc.solve(scene(0.31)[1])


@pytest.fixture(scope="module")
def held_layers():
    """The layers of :func:`friction_scenes.friction_held_layers` solved in m / Pa and in mm / MPa (Signorini) and in
    m / Pa (compliance): {(interface, units): (the solution, its problem, its raw answer)}."""
    out = {}
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        for interface, length, stress in [(cc.Signorini(), 1.0, 1.0), (cc.Signorini(), 1e-3, 1e6),
                                          (cc.NormalCompliance(K), 1.0, 1.0)]:
            key = (type(interface).__name__, length)
            out[key] = captured(mp, friction_held_layers(interface, length, stress))
    return out


@pytest.mark.parametrize("key", [("Signorini", 1.0), ("NormalCompliance", 1.0)])
def test_an_unloaded_mode_held_by_friction_alone_is_not_flagged(held_layers, key):
    """Two layers (nu = 0) under p: the upper one (a roller on its left) on the lower one (frictionless: Signorini
    or compliance), the lower one on the floor with Tresca, which alone holds its x translation, unloaded. u is in
    closed form (0, -r - p y' / E), r the interface's penetration; the answer is then ok (no residual fails). The
    balance of that translation read its rounding against the forces along it, themselves rounding: 0.50
    (Signorini), 0.43 (compliance) before; against FORCE_FLOOR of the contact forces on the body now."""
    sol, _, _ = held_layers[key]
    top, low = (b.mesh for b in sol.scene.bodies)
    r = P / K if key[0] == "NormalCompliance" else 0.0
    for uk, pts, shift in [(sol.u[0], top.points, r), (sol.u[1], low.points, 0.0)]:
        exact = np.column_stack([0.0 * pts[:, 0], -shift - P * (pts[:, 1] + H) / E])
        assert rel(uk, exact) < 1e-11                         # measured 2.6e-15, 3.9e-15
    assert sol.ok, sol.residuals()
    assert sol.residuals()["equilibrium"] < 1e-9              # measured 1.0e-11 (Signorini), 7.0e-12


def _pushed_along_x(problem, raw, relative):
    """``raw`` with one floor row's tangential force (along x on the lower layer) raised by ``relative`` times the
    floor's total normal force: a force along the translation only friction holds, nothing else changed."""
    first = int(problem.rows.counts[0])                      # the rows of the interface, then those of the floor
    floor = slice(first, first + int(problem.rows.counts[1]))
    mu = np.array(raw.tangential, dtype=float)
    mu[first + int(problem.rows.counts[1]) // 2] += relative * float(np.sum(raw.y[floor]))
    return dataclasses.replace(raw, tangential=mu)


@pytest.mark.parametrize("relative", [1e-6, 1e-9])
def test_a_force_along_the_unloaded_mode_is_flagged(held_layers, relative):
    """The check is not blind along that translation: one floor row's friction force raised by 1e-6 or 1e-9 of the
    floor's normal force (the answer otherwise the same) unbalances it, and the answer reads not ok on equilibrium
    (the friction checks do not see it: the force stays far inside its cone, the row does not slip)."""
    sol, problem, raw = held_layers[("Signorini", 1.0)]
    bad = read_back(problem, _pushed_along_x(problem, raw, relative), sol.tol, {})
    assert not bad.ok
    assert bad.residuals()["equilibrium"] > 4 * sol.tol      # measured 0.50 (1e-6), 5.0e-4 (1e-9)
    for check in ("friction cone", "stick-slip", "slip direction"):
        assert bad.residuals()[check] < sol.tol


def test_the_balance_and_its_verdicts_do_not_depend_on_the_units(held_layers):
    """The same layers in mm / MPa and in m / Pa: the same answer (mm = 1e3 m), ok both, and the same read of the
    same fault (a force of 1e-9 of the floor's along the translation only friction holds): the checks are
    dimensionless."""
    (si, p_si, raw_si), (mm, p_mm, raw_mm) = held_layers[("Signorini", 1.0)], held_layers[("Signorini", 1e-3)]
    for a, b in zip(si.u, mm.u):
        assert rel(b * 1e-3, a) < 1e-11                       # measured 5.4e-16
    assert si.ok and mm.ok
    assert max(si.residuals()["equilibrium"], mm.residuals()["equilibrium"]) < 1e-9   # measured 1.0e-11, 6.6e-12
    bad = [read_back(p, _pushed_along_x(p, r, 1e-9), s.tol, {}).residuals()["equilibrium"]
           for s, p, r in [(si, p_si, raw_si), (mm, p_mm, raw_mm)]]
    # 5.0e-4 both; they differ by the rounding of the balance against the fault, eps |K| |u| / 1e-9 of the forces
    assert bad[1] == pytest.approx(bad[0], rel=1e-5)          # measured relative difference 7.0e-9
