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
    """Force control: the sphere guided along z (Rigid.sphere(..., guided=(0, 0, 1))) under F / 4 on the quarter,
    posed along the vertical (``distance="ray"``: the rows are vertical, so the nodal forces' plain sum is the
    load, and the translation enters the gap exactly; at the closest point it enters to first order in t / R,
    the study's posing: test_closest_point_rows_balance_the_vertical_resultant_...)."""
    return cc.solve(h.scene(N, force=h.FORCE, distance="ray"))


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


def test_closest_point_rows_balance_the_vertical_resultant_not_the_sum_of_the_nodal_forces():
    """The sphere posed at the closest point (the rows along the radius): the balance holds for the obstacle's
    resultant sum_a n_o y_a (total_force), exactly; the nodal forces' plain sum is larger (they lean outwards),
    by sum y (1 - cos theta) over sum y cos theta at most, theta the angle off the axis; the study's ray posing
    (:data:`h.DISTANCE`) gives a longer approach, the closest point's rows being stiffer off the axis."""
    sol = cc.solve(h.scene(N, force=h.FORCE, distance="closest"))
    assert sol.ok and sol.polished, sol.report()
    assert abs(h.total_force(sol) - h.FORCE) <= 1e-12 * h.FORCE              # measured 1.8e-16
    excess = 4 * sol.contact.force.sum() / h.FORCE - 1
    theta = np.arcsin(2 * np.sqrt(2) * h.A_REF / h.R)     # the patch [0, 2a]^2 sees the sphere within theta
    assert 0 < excess <= 1 / np.cos(theta) - 1                                 # measured 4.5e-4 (bound 1.0e-2)
    ray = cc.solve(h.scene(N, force=h.FORCE, distance="ray"))
    t, t_ray = -sol.obstacles[0].translation[2], -ray.obstacles[0].translation[2]
    assert 0 < 1 - t / t_ray < 0.4                                             # measured 3.8e-3


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
    base = h.scene(N, delta=0.0, distance="ray")                          # as the guided fixture
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
    """The scene cannot know the symmetry: a free sphere's x and y translations are undetermined (the
    guided sphere of the other tests is the way to pose it)."""
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


@pytest.fixture(scope="module")
def p2_levels():
    """The study's coarsest level in P1 and P2 (press: the condensed backend), rows and the P2 solution."""
    p1, _ = h.solve_level(N)
    p2, sol = h.solve_level(N, degree=2)
    return p1, p2, sol


def test_p2_hertz_quantities_at_the_coarsest_level(p2_levels):
    p1, p2, sol = p2_levels
    assert sol.ok and sol.degree == 2 and p2["ok"]
    assert p2["F_N"] == pytest.approx(h.FORCE, rel=1e-10)
    assert p2["contact_nodes"] == 81                                     # the 9 x 9 P2 nodes of the patch
    # errors of the P2 level n = 8, measured beside each bound
    assert abs(p2["a_rel_error"]) < 0.1                                  # measured +0.051 (h / 4 = 0.14 a)
    assert p2["a_h_min_m"] < h.A_REF < p2["a_h_max_m"]                   # measured 0.84 a .. 1.14 a
    assert abs(p2["p0_rel_error"]) < 0.12                                # measured -0.063
    assert abs(p2["cell_force_rel_error"]) < 0.03                        # measured -0.005
    assert -0.1 < p2["delta_rel_error"] < -0.03                          # measured -0.054 (Boussinesq: -0.073)
    # what P2 gains on the same grid: the peak pressure, the axis cell's force, the approach
    assert abs(p2["p0_rel_error"]) < 0.5 * abs(p1["p0_rel_error"])       # measured 0.063 against 0.176
    assert abs(p2["cell_force_rel_error"]) < 0.5 * abs(p1["cell_force_rel_error"])   # 0.005 against 0.069
    assert abs(p2["delta_rel_error"]) < abs(p1["delta_rel_error"])       # 0.054 against 0.113


def test_p2_felt_pressure_carries_the_force(p2_levels):
    """The P2 peak pressure is read from the felt pressure (a Riesz representer on the block's P2 faces): its
    integral over the patch is the sum of the nodal forces (which lean outwards with the sphere's normal: a little
    more than the quarter's force, whose vertical resultant is F / 4), and it is positive at the axis, where
    Hertz's is largest."""
    _, p2, sol = p2_levels
    trace = sol.interface.traces[0]
    _, p = sol.traction(0)
    total = float(np.ones(len(p)) @ (trace.mass @ p))
    assert total == pytest.approx(sol.contact.force.sum(), rel=1e-9)    # measured 1e-16
    assert h.total_force(sol) == pytest.approx(h.FORCE, rel=1e-9)
    assert 0 < total / (h.FORCE / 4) - 1 < 1e-2                         # measured 5.0e-4
    assert p2["p0_h_Pa"] > 0.8 * p2["p0_Pa"]


def test_hat_loads_on_p2_faces():
    """hat_loads on 6-node faces: the integrals of a uniform pressure against the P2 functions are the row sums
    of the P2 mass matrix (exact; a vertex's is zero), of an affine one close to them (the rule is exact for
    quadratics, the integrand cubic)."""
    base = h.scene(4, delta=0.0)
    sol, _, _ = h.press(cc.ContactSolver(base, "sigma1", method="condensed", degree=2), base)
    trace = sol.interface.traces[0]
    x, y = trace.points[:, 0], trace.points[:, 1]
    one = h.hat_loads(trace, lambda X, Y: np.ones_like(X))
    np.testing.assert_allclose(one, trace.mass @ np.ones(len(x)), rtol=0,
                               atol=1e-12 * np.abs(one).max())           # measured 3e-16
    f = lambda X, Y: 3e9 * (1 + X / h.A_REF - 2 * Y / h.A_REF)
    want = trace.mass @ f(x, y)                                          # P2 interpolates an affine f exactly
    np.testing.assert_allclose(h.hat_loads(trace, f), want, rtol=0,
                               atol=1e-4 * np.abs(want).max())           # measured 7e-6


def test_p2_force_control_by_the_guided_sphere_agrees_with_pressing():
    """P2 at n = 4 under the nodal condition: the guided sphere's translation unknown (full backend) against
    press (condensed)."""
    g = cc.solve(h.scene(4, force=h.FORCE, distance="ray"), "sigma1", degree=2)   # the translation exact in the
    assert g.ok and g.polished                                                     # gap (the guided fixture)
    base = h.scene(4, delta=0.0, distance="ray")
    sol, delta, _ = h.press(cc.ContactSolver(base, "sigma1", method="condensed", degree=2), base)
    assert -g.obstacles[0].translation[2] == pytest.approx(delta, rel=1e-9)   # measured 1e-15
    np.testing.assert_array_equal(sol.contact.active, g.contact.active)
    np.testing.assert_allclose(sol.contact.force, g.contact.force, rtol=0,
                               atol=1e-9 * h.FORCE)                      # measured 3e-11 N


# --- the contact radius of the P2 "gamma3" rows: the hull of the points where the gap closes ---------------------

def test_hull_radius_of_points_on_a_quarter_circle():
    """k + 1 points equally spaced on a quarter circle of radius s (and points inside it): the hull with the axis
    point is k triangles of area s^2 sin(pi / 2k) / 2 each, so the radius is s sqrt(2k sin(pi / 2k) / pi)."""
    s = 1.3e-3
    for k in (2, 5, 40):
        t = np.linspace(0.0, np.pi / 2, k + 1)
        ring = s * np.column_stack([np.cos(t), np.sin(t)])
        inner = 0.7 * s * np.random.default_rng(k).random((30, 2)) / np.sqrt(2)
        want = s * np.sqrt(2 * k * np.sin(np.pi / (2 * k)) / np.pi)
        assert h.hull_radius(np.concatenate([inner, ring])) == pytest.approx(want, rel=1e-12)
    assert h.hull_radius(ring[:1]) == 0.0                            # one point off the axis: no area
    assert h.hull_radius(np.zeros((0, 2))) == 0.0


def _p2_grid(m, size):
    """A triangle6 mesh of [0, size]^2 (m x m squares, two triangles each): (x (n, 2), cells (c, 6))."""
    from cvxcontact.contact.quadratic3d import p2_triangle_nodes

    g = np.linspace(0.0, size, m + 1)
    X, Y = np.meshgrid(g, g, indexing="ij")
    V = np.column_stack([X.ravel(), Y.ravel()])
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    v = (i * (m + 1) + j).ravel()
    tri = np.concatenate([np.c_[v, v + m + 1, v + m + 2], np.c_[v, v + m + 2, v + 1]])
    cells, edges = p2_triangle_nodes(tri, len(V))
    return np.concatenate([V, 0.5 * (V[edges[:, 0]] + V[edges[:, 1]])]), cells


def test_contact_points_of_a_synthetic_gap():
    """q_h = -c |x - x0|^2 is quadratic (in P2 exactly), <= 0 and zero at x0 alone: the contact points are x0
    (once per triangle that holds it), whatever the tolerance below the nearest node's value; q_h = -c (x - x0)^2
    closes along the line x = x0: points on that line only, and its nodes there."""
    x, cells = _p2_grid(6, 2e-3)
    x0 = np.array([0.77e-3, 0.41e-3])                                 # inside one triangle
    q = -1e3 * ((x - x0) ** 2).sum(axis=1)
    pts = h.contact_points(x, cells, q, tol=1e-3 * np.abs(q[q < 0]).min())
    assert len(pts) == 1
    np.testing.assert_allclose(pts[0], x0, rtol=0, atol=1e-12 * 2e-3)  # measured 0 (exact stationary point)
    line = -1e3 * (x[:, 0] - 1e-3) ** 2                                # x = 1e-3 is a grid line
    pts = h.contact_points(x, cells, line, tol=1e-15)
    assert len(pts) > 0
    np.testing.assert_allclose(pts[:, 0], 1e-3, rtol=0, atol=1e-15)
    assert pts[:, 1].min() == 0.0 and pts[:, 1].max() == 2e-3         # its nodes at both ends of the patch
    # the hull with the axis point: the triangle (0, 0), (1e-3, 0), (1e-3, 2e-3) of area 1e-6 m^2
    assert h.hull_radius(pts) == pytest.approx(np.sqrt(4e-6 / np.pi), rel=1e-12)


def test_moment_radius_of_hertz_forces():
    """Hertz's pressure of radius s integrated on the P2 functions of the quarter patch (hat_loads): the second
    moment of the forces gives back s (r^2 is quadratic, so sum f_i r_i^2 is the integral of r^2 p up to the
    quadrature of hat_loads); a uniform pressure on the whole patch [0, 2a]^2 gives its own moment instead."""
    x, cells = _p2_grid(8, 2 * h.A_REF)

    class Trace:                                                       # the protocol hat_loads reads
        points = np.column_stack([x, np.zeros(len(x))])
        faces = cells
        nodes = np.arange(len(x))

    for s in (0.6e-3, 1.1e-3):
        f = h.hat_loads(Trace, lambda X, Y: 2e9 * np.sqrt(np.maximum(1 - (X * X + Y * Y) / s ** 2, 0.0)), k=16)
        assert h.moment_radius(x, f) == pytest.approx(s, rel=3e-4)     # measured 3.1e-5, 1.3e-6
    one = h.hat_loads(Trace, lambda X, Y: np.ones_like(X))
    # a uniform square [0, 2a]^2: <r^2> = 2 (2a)^2 / 3, so sqrt(5/2 <r^2>) = 2a sqrt(5/3)
    assert h.moment_radius(x, one) == pytest.approx(2 * h.A_REF * np.sqrt(5 / 3), rel=1e-12)


@pytest.fixture(scope="module")
def gamma3_level():
    """The study's P2 "gamma3" row at the coarsest level (the copositive condition on every face of the patch),
    the sphere posed along the vertical (``distance="ray"``: its gap has the closed form the tests below sample;
    the closest point's P2 "gamma3" against a sampled true slack: tests/test_p2_gamma3_true_gap.py)."""
    return h.solve_level(N, degree=2, condition="gamma3", distance="ray")


def test_p2_gamma3_row_balances_the_force_and_closes_the_gap_at_points(gamma3_level):
    row, sol = gamma3_level
    assert sol.ok and sol.polished and row["condition"] == "gamma3", sol.report()
    # the force is reached to FORCE_RTOL_CONIC, and the felt pressure carries it
    assert abs(row["F_N"] / h.FORCE - 1) <= h.FORCE_RTOL_CONIC           # measured 5e-9
    _, p = sol.traction(0)
    trace = sol.interface.traces[0]
    assert float(np.ones(len(p)) @ (trace.mass @ p)) == pytest.approx(sol.contact.force.sum(), rel=1e-12)
    # the gap closes at points inside triangles: no node of the patch touches (q_h < 0 at every node,
    # measured at least 3.6e-5 of the approach below the sphere), so a node count cannot see the zone
    c = sol.contact
    q = c.jump - c.gap
    assert (q < -1e-6 * row["delta_h_m"]).all()
    # the contact points: the maxima of the slack against the sphere's own gap (the condition "gamma3" holds)
    pts = h.contact_points(c.x, sol.interface.cells, q, h.SUPPORT_TOL * np.abs(c.jump).max(), h.true_departure(sol))
    # measured: 14 faces whose true maximum is within 1e-9 of the approach (posed along the vertical); 13 while
    # the search from every local maximum was a pattern search capped at 400 steps (it stopped low on the flat
    # ridges of faces that conform to the sphere), 8 while it started from the best sample alone
    # (docs/formulation.md section 8)
    assert row["support_points"] == len(pts) == 14
    from cvxcontact.contact.overlay import locate
    from cvxcontact.contact.quadratic3d import p2_shape
    cells = np.asarray(sol.interface.cells)
    tri, _ = locate(pts, c.x, cells[:, :3])
    # sampled on every triangle: the true slack [u_nu]_h - g, the sphere's vertical distance (the study's "ray"
    # posing) in closed form, g(s) = R - delta - sqrt(R^2 - |s|^2) (top face z = 0, its axis at s = 0)
    delta = row["delta_h_m"]
    gap = lambda s: h.R - delta - np.sqrt(h.R ** 2 - (s ** 2).sum(axis=-1))    # noqa: E731
    x = np.asarray(c.x)
    assert np.abs(np.asarray(c.gap) - gap(x)).max() < 1e-15              # the nodal gap: measured 3.5e-18 m
    k = 12
    u, v = (g.ravel() for g in np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij"))
    L = np.column_stack([k - u - v, u, v])[u + v <= k] / k
    where = np.einsum("pv,tvd->ptd", L, x[cells[:, :3]])                 # (91, triangles, 2)
    samples = p2_shape(L) @ np.asarray(c.jump)[cells].T - gap(where)
    hold = np.zeros(len(cells), dtype=bool)
    hold[tri] = True
    assert hold.sum() == 14
    assert samples[:, hold].max() <= 1e-12 * delta                       # measured -1.9e-9 (samples miss the point)
    # the triangles without a contact point stay clear of the sphere: against the sphere itself the P2 face
    # cannot conform to it, it touches at 14 points (their faces' exact maxima within 1e-9 of the approach)
    assert samples[:, ~hold].max() < -5e-10 * delta                      # measured -3.0e-6


@pytest.fixture(scope="module")
def gamma3_closest_level():
    """The study's P2 "gamma3" row at the coarsest level as the study poses it (the closest point)."""
    return h.solve_level(N, degree=2, condition="gamma3")


def test_p2_gamma3_maxima_of_the_true_slack_converge(gamma3_closest_level):
    # the maxima of the slack against the sphere's own gap on the solution's faces (its contact points): the
    # search converged from every start (a pattern search capped at 400 steps stopped on the faces' long flat
    # ridges, the maxima low by up to 1.4e-11 of the slack's scale here, 5e-7 in the cuts' rounds), and agrees
    # with dense sampling and a local zoom (tests/test_truegap_argmax.py)
    from references import check_argmax
    from cvxcontact.contact.bernstein import TRIANGLE
    _, sol = gamma3_closest_level
    c = sol.contact
    b = (np.asarray(c.jump) - np.asarray(c.gap))[np.asarray(sol.interface.cells)] @ TRIANGLE.to_bernstein.T
    check_argmax(h.true_departure(sol), b, 48, 5e-11)   # measured 4.7e-13 (the zoom below Newton on the ridges)


def test_p2_gamma3_hertz_quantities_at_the_coarsest_level(gamma3_level, p2_levels):
    row, _ = gamma3_level
    p1, p2, _ = p2_levels
    # errors of the P2 gamma3 level n = 8, measured beside each bound
    assert row["a_rel_error"] == row["a_hull_rel_error"]
    # a hull of inner points (from inside: < 0); the 13 points where the P2 face touches the sphere itself (14
    # against the interpolant, -0.200)
    assert -0.45 < row["a_hull_rel_error"] < 0                           # measured -0.229 (-0.373 with 8 points)
    assert abs(row["a_moment_rel_error"]) < 0.02                         # measured -0.0007
    assert abs(row["p0_rel_error"]) < 0.15                               # measured -0.091
    assert abs(row["cell_force_rel_error"]) < 0.05                       # measured -0.015
    assert -0.1 < row["delta_rel_error"] < -0.03                         # measured -0.063
    # the hull estimator against the edge mid-points where both apply (nodal rows): within a mesh size near
    # the zone's edge (h at the axis, h_m; the grid is graded, coarser at r = a)
    for r in (p1, p2):
        assert abs(r["a_hull_m"] - r["a_h_m"]) < r["h_m"]               # measured 0.53 h (P1), 0.19 h (P2)


def test_p1_errors_shrink_with_h(guided):
    """Level n = 16 against n = 8 (h at the axis 0.42x): the radius, the peak pressure and the axis cell's
    force approach Hertz, and the approach approaches it down to the finite block's own compliance (Boussinesq
    at the clamped depth: -0.073). Measured at n = 8 / 16: a +0.075 / +0.034, p0 -0.176 / -0.106, cell force
    +0.069 / +0.029, delta -0.113 / -0.075 (docs/studies/hertz3d, the README table)."""
    coarse = h.measure(guided, -guided.obstacles[0].translation[2])
    fine, sol = h.solve_level(16)
    assert sol.ok and fine["F_N"] == pytest.approx(h.FORCE, rel=1e-10)
    for key in ("a_rel_error", "p0_rel_error", "cell_force_rel_error"):
        assert abs(fine[key]) < 0.7 * abs(coarse[key]), key                # measured ratios 0.46, 0.60, 0.42
    assert coarse["delta_rel_error"] < fine["delta_rel_error"] < -0.05     # measured -0.113 < -0.075
