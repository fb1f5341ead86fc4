"""A friction law beside a Hencky body (docs/refusals.md row 36, supported on nodal rows): the friction finish by
sequential quadratic steps on the nonlinear (26) (cvxcontact/backends/frictionsteps.py ``sequential``), checked against
a yielding uniform layer's closed form, the frictionless Hencky answer of the Newton route as the threshold
vanishes, the friction law read off the answer, and the interior point's answer."""

import warnings

import numpy as np
import pytest
from friction_scenes import sheared_hencky as sheared_block

import cvxcontact as cc

E, NU, SIGMA_Y, H = 200e9, 0.3, 200e6, 0.1
FLOOR = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def hencky_stress(e_yy, gamma):
    """The Hencky stress (sigma_xx, sigma_yy, sigma_xy) of the plane strain eps_xx = 0, eps_yy = e_yy, 2 eps_xy =
    gamma, from the density W = K/2 (tr eps)^2 + mu psi(|dev eps|) (docs/materials.md) by hand: sigma = K tr(eps) I
    + mu psi'(s) dev(eps) / s, psi'(s) = 2 h s + 2 (1 - h) min(s, s_y), s_y = sigma_y / (sqrt(6) mu)."""
    mu, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    s_y = SIGMA_Y / (np.sqrt(6.0) * mu)
    dev = np.array([-e_yy / 3, 2 * e_yy / 3, -e_yy / 3])          # xx, yy, zz (eps_zz = 0)
    s = np.sqrt(dev @ dev + 2 * (gamma / 2) ** 2)
    k = mu * (2 * H * s + 2 * (1 - H) * min(s, s_y)) / s
    assert s > 1.5 * s_y                                            # the state has yielded
    return K * e_yy + k * dev[0], K * e_yy + k * dev[1], k * gamma / 2


def yielded_layer(law_of_shear, e_yy=-1e-3, gamma=3e-3, nx=4, ny=2):
    """The layer 1 m x 0.5 m on the floor under the tractions of the uniform yielded state u = (gamma y, e_yy y)
    (top (s_xy, s_yy), sides -+(s_xx, s_xy)), its contact under ``law_of_shear(s_xy)``; (scene, exact u(points))
    with exact(points) the state's displacement at the given points."""
    sxx, syy, sxy = hencky_stress(e_yy, gamma)
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny)
    b = cc.Body(m, cc.materials.hencky(E=E, nu=NU, sigma_y=SIGMA_Y, h=H), contact="bottom",
                traction={"top": (sxy, syy), "left": (-sxx, -sxy), "right": (sxx, sxy)})
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law_of_shear(sxy))])
    return scene, lambda points: np.column_stack([gamma * points[:, 1], e_yy * points[:, 1]])


def rel(a, b):
    return float(np.abs(np.asarray(a) - b).max() / np.abs(b).max())


@pytest.mark.numerics
@pytest.mark.parametrize("condition, degree", [("sigma1", 1), ("sigma2", 2)])
@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_a_yielded_layer_stuck_on_the_floor_is_the_uniform_hencky_state(law, condition, degree):
    """The layer's uniform yielded state (|dev eps| = 2.1 s_y) with the Hencky stress computed by hand: stuck under
    a threshold three times its shear (Coulomb: mu = 3 |s_xy| / |s_yy|), the displacement is the uniform state's
    (exact in P1 and P2; measured 1e-16 relative), its tangential forces below their capacities."""
    def law_of(sxy):
        _, syy, _ = hencky_stress(-1e-3, 3e-3)
        return cc.Tresca(3 * abs(sxy)) if law == "tresca" else cc.Coulomb(3 * abs(sxy) / abs(syy))

    scene, exact = yielded_layer(law_of)
    sol = cc.solve(scene, condition, degree=degree)
    assert sol.ok and sol.polished
    assert rel(sol.u[0], exact(sol.points[0])) <= 1e-9
    c = sol.contact
    assert (np.abs(c.shear_force) < 0.5 * c.threshold * c.slip_measure).all()     # a third of the capacity


CIRCLE = cc.Rigid.circle((0.47, 0.5 + 3.0 - 5e-3), 3.0)


def indented(law=None):
    """A Hencky block 1 m x 0.5 m clamped at its base (it yields under the circle) indented by
    :data:`CIRCLE` (its contact ends inside P2 elements: the cut points and the tangency points), under ``law``."""
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=16, ny=4)
    b = cc.Body(m, cc.materials.hencky(E=E, nu=NU, sigma_y=SIGMA_Y, h=H), clamped="bottom", contact="top")
    return cc.Scene(b, contacts=[cc.Contact(b, "top", CIRCLE, **({} if law is None else {"law": law}))])


@pytest.mark.numerics
@pytest.mark.parametrize("law, condition, degree", [
    (cc.Tresca(0.6e8), "sigma1", 1), (cc.Tresca(0.6e8), "sigma2", 2), (cc.Coulomb(0.6), "sigma1", 1),
    (cc.Coulomb(0.6), "sigma1", 2), (cc.Coulomb(0.6), "sigma2", 2)],
    ids=["tresca-sigma1", "tresca-sigma2", "coulomb-sigma1", "coulomb-p2-sigma1", "coulomb-p2-sigma2"])
def test_a_sheared_hencky_block_keeps_the_friction_law_where_it_slips(law, condition, degree):
    """The friction law read off the answer by hand: every nodal shear force within its capacity (threshold times
    the node's weight), and where a node slips (|slip| above 1e-9 of the displacements) the force is the capacity
    opposite to the slip (measured 1.1e-16 of the largest capacity; 6 of 9 nodes slip under Tresca P1). Some
    nodes stick, some slip: the test sees both branches. Coulomb on P2: Clarabel's first program (all stuck) ended
    InsufficientProgress (SolverError) under the conic settings (unequilibrated); the bulk cones' settings solve it."""
    sol = cc.solve(sheared_block(law), condition, degree=degree)
    assert sol.ok and sol.polished
    c = sol.contact
    capacity = c.threshold * c.slip_measure
    slipping = np.abs(c.slip) > 1e-9 * np.abs(sol.u[0]).max()
    assert 0 < slipping.sum() < len(slipping)
    assert (np.abs(c.shear_force) - capacity).max() <= 1e-12 * capacity.max()
    assert np.abs(c.shear_force + np.sign(c.slip) * capacity)[slipping].max() <= 1e-12 * capacity.max()


@pytest.mark.numerics
@pytest.mark.parametrize("condition, degree", [("sigma1", 1), ("sigma2", 2)])
def test_a_vanishing_threshold_is_the_frictionless_hencky_answer(condition, degree):
    """Tresca's threshold 1e-6 Pa (1e-14 of the stresses) beside a Hencky body indented by a rigid circle (it yields
    under the circle: strains about 1e-2 against the yield strain 1e-3) equals the frictionless answer of the Newton
    route to 1e-10 (measured 4.7e-15 P1, 4.9e-15 P2)."""
    tresca = cc.solve(indented(cc.Tresca(1e-6)), condition, degree=degree)
    plain = cc.solve(indented(), condition, degree=degree, method="newton")
    assert tresca.ok and tresca.polished and plain.ok
    assert rel(tresca.u[0], plain.u[0]) <= 1e-10


@pytest.mark.numerics
@pytest.mark.parametrize("law, condition, degree", [("tresca", "sigma1", 1), ("tresca", "sigma2", 2),
                                                     ("coulomb", "sigma1", 1)])
def test_friction_beside_a_hencky_box_that_never_yields_is_the_linear_answer_in_3d(law, condition, degree):
    """The uniform sheared 3D layer of tests/friction_scenes.py (stuck: u = (tau_x z / G, tau_y z / G, -p z / E),
    nu = 0) with a Hencky body whose yield stress no strain reaches: the linear closed form (measured 5.4e-16 P1,
    6.8e-16 P2, Coulomb 4.1e-16)."""
    from friction_scenes import DIAGONAL3, FLOOR3D, P, uniform_layer3d
    from friction_scenes import E as E3

    tau = 0.2 * P
    friction = cc.Tresca(10 * tau) if law == "tresca" else cc.Coulomb(1.0)
    layer = uniform_layer3d(tau, friction).bodies[0]
    b = layer.with_changes(material=cc.materials.hencky(E=E3, nu=0.0, sigma_y=1e15, h=0.1))
    sol = cc.solve(cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR3D, law=friction)]), condition, degree=degree)
    z, q = sol.points[0][:, 2], tau * DIAGONAL3
    assert sol.ok and sol.polished
    assert rel(sol.u[0], np.column_stack([2 * q[0] * z / E3, 2 * q[1] * z / E3, -P * z / E3])) <= 1e-9


@pytest.mark.numerics
def test_the_sequential_steps_past_their_cap_decline_flagged(monkeypatch):
    """One sequential quadratic step cannot see the same closed and stuck rows twice: the finish declines and the
    interior point's answer is kept, ``info.declined`` naming the steps. A friction term reports no decline by
    itself (discrete/terms.py ``TrescaFriction.finishes``): the kept answer is warned about (ResidualWarning) when it
    fails its checks, as under the unequilibrated conic settings (the interior point 3.2e-3 off; measured: the
    residual of the nonlinear (26) 4.5e-4 after one step); under the route's own settings it is the minimiser to
    2e-12 and passes them."""
    import cvxcontact.backends.frictionsteps as steps

    monkeypatch.setattr(steps, "SEQUENTIAL_STEPS", 1)
    with pytest.warns(cc.ResidualWarning):
        sol = cc.solve(sheared_block(cc.Tresca(0.6e8)), "sigma1", solver_options={"equilibrate_enable": False})
    assert not sol.ok and not sol.polished and "sequential quadratic steps" in str(sol.info.declined)
    sol = cc.solve(sheared_block(cc.Tresca(0.6e8)), "sigma1")
    assert sol.ok and not sol.polished and "sequential quadratic steps" in str(sol.info.declined)


def p1_hencky_energy(points, triangles, sigma_y):
    """An independent P1 plane-strain Hencky energy (docs/materials.md: W = K/2 (tr eps)^2 + mu psi(|dev eps|),
    psi(s) = s^2 up to s_y, then s_y^2 + 2 s_y (s - s_y) + h (s - s_y)^2) and its nodal gradient from the stress
    sigma = K tr(eps) I + mu psi'(s) dev(eps) / s, the strains constant per triangle: (energy(u), gradient(u)),
    u (n, 2) in m, J/m and N/m."""
    mu, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    s_y = sigma_y / (np.sqrt(6.0) * mu)
    p = points[triangles]
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    inv = np.stack([np.stack([d2[:, 1], -d2[:, 0]], -1), np.stack([-d1[:, 1], d1[:, 0]], -1)], 1) / det[:, None, None]
    grads = np.einsum("ak,tkj->taj", np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]), inv)   # dN_a / dx_j
    area = np.abs(det) / 2

    def state(u):
        du = np.einsum("tai,taj->tij", u[triangles], grads)
        eps = np.zeros((len(triangles), 3, 3))
        eps[:, :2, :2] = (du + du.transpose(0, 2, 1)) / 2
        tr = np.trace(eps, axis1=1, axis2=2)
        dev = eps - tr[:, None, None] / 3 * np.eye(3)
        s = np.sqrt((dev ** 2).sum(axis=(1, 2)))
        psi = np.where(s <= s_y, s ** 2, s_y ** 2 + 2 * s_y * (s - s_y) + H * (s - s_y) ** 2)
        dpsi = np.where(s <= s_y, 2 * s, 2 * s_y + 2 * H * (s - s_y))
        sigma = K * tr[:, None, None] * np.eye(3) + (mu * dpsi / np.where(s > 0, s, 1.0))[:, None, None] * dev
        return ((K / 2 * tr ** 2 + mu * psi) * area).sum(), sigma

    def gradient(u):
        f = np.zeros_like(u)
        np.add.at(f, triangles, area[:, None, None] * np.einsum("tij,taj->tai", state(u)[1][:, :2, :2], grads))
        return f

    return (lambda u: state(u)[0]), gradient


@pytest.mark.numerics
def test_the_finished_tresca_answer_is_the_minimiser_by_an_independent_assembly():
    """The sheared Hencky block under Tresca (P1, "sigma1") checked by an energy and stress written here: the
    energy W summed over the triangles, minus the top load's work, plus g w_a |u_x| over the floor nodes (w_a the
    lumped edge lengths). Its optimality conditions by hand: the gradient vanishes off the floor (measured 4.6e-14
    of the nodal load), the floor reactions press (>= 0) and vanish where the node lifts, the shear reaction within
    g w_a and equal to it against the slip (1.5e-15 of the capacity); no feasible perturbation (u_y >= 0 kept on the
    floor nodes in contact, sizes 1e-6..1e-2 of the displacement) lowers the energy (smallest rise measured 0.24
    J/m); and the interior point's answer, unfinished, is within 1e-6 of it (measured 2e-12; 3.2e-3 under the
    unequilibrated conic settings) with an energy not below it beyond rounding."""
    P, g = 1e8, 0.6e8
    scene = sheared_block(cc.Tresca(g))
    mesh = scene.bodies[0].mesh
    sol = cc.solve(scene, "sigma1")
    ipm = cc.solve(scene, "sigma1", polish=False)
    assert sol.ok and sol.polished
    assert np.allclose(sol.points[0], mesh.points)
    energy_bulk, gradient_bulk = p1_hencky_energy(mesh.points, mesh.triangles, P)
    x, y = mesh.points[:, 0], mesh.points[:, 1]
    floor, top = np.flatnonzero(y == 0.0), np.flatnonzero(y == 0.5)
    floor, top = floor[np.argsort(x[floor])], top[np.argsort(x[top])]

    def lumped(nodes):
        w, half = np.zeros(len(nodes)), np.diff(x[nodes]) / 2
        w[:-1] += half
        w[1:] += half
        return w

    w_floor, load = lumped(floor), lumped(top)[:, None] * np.array([0.5 * P, -P])

    def energy(u):
        return energy_bulk(u) - (load * u[top]).sum() + g * (w_floor * np.abs(u[floor, 0])).sum()

    u = np.asarray(sol.u[0])
    f = gradient_bulk(u)
    f[top] -= load
    scale, U = np.abs(load).max(), np.abs(u).max()
    off_floor = np.setdiff1d(np.arange(len(u)), floor)
    assert np.abs(f[off_floor]).max() <= 1e-10 * scale
    reaction, lift = f[floor], u[floor]
    assert reaction[:, 1].min() >= -1e-10 * scale and lift[:, 1].min() >= -1e-12 * U
    assert np.abs(reaction[:, 1] * lift[:, 1]).max() <= 1e-10 * scale * U
    capacity = g * w_floor
    slipping = np.abs(lift[:, 0]) > 1e-9 * U
    assert 0 < slipping.sum() < len(slipping)
    assert (np.abs(reaction[:, 0]) - capacity).max() <= 1e-12 * capacity.max()
    assert np.abs(reaction[:, 0] + capacity * np.sign(lift[:, 0]))[slipping].max() <= 1e-12 * capacity.max()
    rng = np.random.default_rng(7)
    closed = lift[:, 1] <= 1e-12 * U
    e0 = energy(u)
    for size in 10.0 ** rng.uniform(-6, -2, size=100):
        d = rng.standard_normal(u.shape) * size * U
        d[floor[closed], 1] = np.abs(d[floor[closed], 1])
        assert energy(u + d) > e0
    u_ipm = np.asarray(ipm.u[0])
    assert np.abs(u_ipm - u).max() <= 1e-6 * U
    assert energy(u_ipm) >= e0 - 1e-12 * abs(e0)


# the 2D P2 cones ("gamma3", degree=2): the cones' friction finish on the nodes and cut points by the sequential
# quadratic steps, then Newton at the tangency points on the nonlinear (26) (backends/friction.py
# ``_tangency_polish`` with the energy's gradient and tangent)

@pytest.mark.numerics
@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_a_yielded_layer_stuck_under_the_p2_cones_is_the_uniform_hencky_state(law):
    """The layer's uniform yielded state (|dev eps| = 2.1 s_y, the Hencky stress by hand) stuck on the floor under
    "gamma3" with degree=2: the displacement is the uniform state's (measured 5.8e-13 Tresca, 3.0e-15 Coulomb),
    its tangential forces below their capacities."""
    def law_of(sxy):
        _, syy, _ = hencky_stress(-1e-3, 3e-3)
        return cc.Tresca(3 * abs(sxy)) if law == "tresca" else cc.Coulomb(3 * abs(sxy) / abs(syy))

    scene, exact = yielded_layer(law_of)
    sol = cc.solve(scene, "gamma3", degree=2)
    assert sol.ok and sol.polished
    assert rel(sol.u[0], exact(sol.points[0])) <= 1e-9
    c = sol.contact
    assert (np.abs(c.shear_force) < 0.5 * c.threshold * c.slip_measure).all()


@pytest.mark.numerics
def test_a_vanishing_threshold_under_the_p2_cones_is_the_frictionless_hencky_answer():
    """Tresca's threshold 1e-6 Pa (1e-14 of the stresses) beside the Hencky block indented by the circle (it yields
    under it), under "gamma3" with degree=2, equals the frictionless P2 cones' answer beside the Hencky body
    (cones.finish_bulk: Newton at the tangency points on the nonlinear (26); tests/test_p2_cones_hencky.py) to
    1e-10 (measured 3.1e-15; Coulomb mu = 1e-14: 2.4e-14, 50 s CPU, not run here). The contact ends inside
    elements: the cut rounds decline there and the answer is the Newton at the tangency points on the nonlinear (26)
    (before it, the interior point's answer kept flagged: 1.4e-2 of the displacements away)."""
    sol = cc.solve(indented(cc.Tresca(1e-6)), "gamma3", degree=2)
    plain = cc.solve(indented(), "gamma3", degree=2)
    assert sol.ok and sol.polished and plain.ok and plain.polished
    assert rel(sol.u[0], plain.u[0]) <= 1e-10


def _sheared_p2(once):
    """The block sheared until it yields at its corners, Tresca 0.6e8 Pa, under "gamma3" with degree=2, solved once
    per module (the two tests below read it; its warnings raised again at each call, under the caller's filters)."""
    return once("sheared p2", lambda: cc.solve(sheared_block(cc.Tresca(0.6e8)), "gamma3", degree=2))


@pytest.mark.numerics
def test_a_sheared_hencky_block_under_the_p2_cones_keeps_the_law_or_is_flagged(once):
    """The block sheared until it yields at its corners, Tresca 0.6 P, under "gamma3" with degree=2: the interior
    point stops at its iteration cap (optimal_inaccurate); the finish's active-set steps once cycled from it
    (declined, equilibrium 1.0e-1), and it is now finished (the next test). Whichever answer comes back, it is never
    reported ok while breaking the law: an ok answer keeps every nodal shear force within its capacity, else it is
    flagged (not polished, a reason)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = _sheared_p2(once)
    c = sol.contact
    capacity = c.threshold * c.slip_measure
    if sol.ok:
        assert sol.polished and (np.abs(c.shear_force) - capacity).max() <= 1e-12 * capacity.max()
    else:
        assert not sol.polished and sol.info.declined


def _bottom_p2(sol):
    """(x, u) of the block's bottom nodes (y = 0) sorted by x: the P2 trace's vertices and midpoints alternate."""
    pts, u = sol.points[0], sol.u[0]
    on = np.flatnonzero(np.abs(pts[:, 1]) <= 1e-12)
    order = on[np.argsort(pts[on, 0])]
    return pts[order, 0], u[order]


@pytest.mark.numerics
def test_the_sheared_hencky_block_under_the_p2_cones_is_finished_and_keeps_the_law(once):
    """The block of the test above, finished (no ResidualWarning, the friction Newton), checked by code of its own
    on the displacement read off the nodes: the normal displacement of the bottom sampled at 101 points of each P2
    segment (its quadratic through the segment's three nodes) never enters the floor beyond 1e-7 of the
    displacements (measured: every sample 3.5e-14 of them above it; the cut rounds stop at 1e-9, CONE_ROUNDING);
    the shear forces within their capacities, those of the nodes that slip (|u_x| above 1e-9 of the displacements;
    measured 13 of 17, the least 2.2e-3, the stuck ones 0) at the capacity against the slip (measured 0 of the
    largest capacity); the slip read back is u_x of the nodes; and the contact forces hold the load applied on the
    top (P, P / 2 per metre; measured 1.5e-16 relative). The same numbers under OPENBLAS_CORETYPE Haswell,
    Prescott and Sandybridge."""
    P = 1e8
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = _sheared_p2(once)                                       # Tresca 0.6 P
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON
    x, u = _bottom_p2(sol)
    U = float(np.abs(sol.u[0]).max())
    assert len(x) % 2 == 1 and np.allclose(x[1::2], 0.5 * (x[:-1:2] + x[2::2]), rtol=0, atol=1e-12)
    s = np.linspace(0.0, 1.0, 101)
    lagrange = np.column_stack([(1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)])      # nodes 0, 1/2, 1
    uy = np.column_stack([u[0:-1:2, 1], u[1::2, 1], u[2::2, 1]])                               # (segments, 3)
    assert (-(uy @ lagrange.T)).max() <= 1e-7 * U            # -u_y: the penetration of the floor y = 0
    c = sol.contact
    assert np.allclose(np.sort(c.x), x, rtol=0, atol=1e-12)
    slip = u[np.argsort(np.argsort(c.x)), 0]                 # u_x at the contact's own node order
    sign = np.sign(c.slip @ slip)
    assert np.abs(c.slip - sign * slip).max() <= 1e-12 * U
    capacity = c.threshold * c.slip_measure
    slipping = np.abs(slip) > 1e-9 * U
    assert 0 < slipping.sum() < len(slipping)
    assert (np.abs(c.shear_force) - capacity).max() <= 1e-12 * capacity.max()
    assert np.abs(c.shear_force + np.sign(c.slip) * capacity)[slipping].max() <= 1e-12 * capacity.max()
    assert abs(c.force.sum() - P) <= 1e-10 * P and abs(abs(c.shear_force.sum()) - 0.5 * P) <= 1e-10 * P
