"""Curved rigid obstacles posed at the closest point (docs/formulation.md §12, issue 29 item 3): the rows
d . u <= g - c . t with g the signed distance from a node to the closest point q of the obstacle's surface,
d the unit direction from the node to q and c = -d, checked against brute force (dense sampling of the surface
and a local refinement by scipy), against an independent dense solve of the radial rows (tests/reference3d.py)
and under a rigid rotation of the whole scene."""

from fractions import Fraction

import numpy as np
import pytest
from scipy.optimize import minimize

import cvxcontact as cc
from conftest import rel
from reference3d import Dense, match
from scenes3d import rotation

RNG = np.random.default_rng(29)
UP = np.array([0.0, 0.0, 1.0])


def brute_closest(point, surface, params, bounds):
    """(distance, foot) of ``point`` to the parametrised surface ``surface(p)`` (p (k,) -> (3,) or (2,)):
    the best of the dense samples ``params`` (s, k), refined by scipy's L-BFGS-B within ``bounds``."""
    dist = np.linalg.norm(np.array([surface(p) for p in params]) - point, axis=1)
    best = params[int(np.argmin(dist))]
    res = minimize(lambda p: float(np.sum((surface(p) - point) ** 2)), best, method="L-BFGS-B", bounds=bounds,
                   options=dict(ftol=1e-30, gtol=1e-16, maxiter=500))
    q = surface(res.x)
    return float(np.linalg.norm(q - point)), q


def grid(*axes):
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


def check_rows(obstacle, x, nu, surface, params, bounds, normal_at, dir_tol):
    """The obstacle's rows at points x against brute force: |g| equals the brute-force distance (to 1e-9:
    the refinement's own precision, ~1e-12), the foot
    x + g d lies on the surface (brute force: its distance to the sampled-and-refined surface), d is (to ``dir_tol``) the
    surface's unit normal there (``normal_at(foot)``, the test's own formula) and c = -d."""
    g, d, c = obstacle.distance(x, nu), obstacle.direction(x, nu), obstacle.sensitivity(x, nu)
    assert np.isfinite(g).all()
    worst_g = worst_d = worst_q = 0.0
    for xi, gi, di in zip(x, g, d):
        dist, q = brute_closest(xi, surface, params, bounds)
        worst_g = max(worst_g, abs(abs(gi) - dist) / max(dist, 1e-300))
        foot = xi + gi * di
        n = normal_at(foot)                                         # the obstacle's outward normal at the foot
        worst_d = max(worst_d, np.linalg.norm(di + n))
        worst_q = max(worst_q, np.linalg.norm(q - foot))            # brute force's foot: to ~sqrt(eps) only
        assert np.sign(gi) == np.sign(np.dot(xi - foot, n))          # negative inside
    assert worst_q < 1e-6                                           # measured <= 8.6e-9
    np.testing.assert_allclose(c, -d, rtol=0, atol=0)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=0, atol=1e-15)
    assert worst_g < 1e-9 and worst_d < dir_tol          # measured <= 1.9e-12 (the cylinder: brute force's own)
    return worst_g, worst_d


def test_circle_rows_are_the_closest_point_by_brute_force():
    centre, R = np.array([0.3, 0.8]), 0.5
    disc = cc.Rigid.circle(centre, R)
    nu = np.array([0.0, 1.0])
    x = np.column_stack([RNG.uniform(-0.1, 0.7, 12), RNG.uniform(0.2, 0.45, 12)])   # below the disc, 2 inside
    x = np.vstack([x, [[0.3, 0.35], [0.35, 0.31]]])
    angle = np.linspace(-np.pi, 0, 4001)[:, None]
    g, _ = check_rows(disc, x, nu, lambda p: centre + R * np.array([np.cos(p[0]), np.sin(p[0])]), angle,
                      [(-np.pi, 0)], lambda q: (q - centre) / R, 1e-12)   # measured 1.3e-13, 1.1e-16
    # the closed form itself, by its definition: |x - c| - R = (|x - c|^2 - R^2) / (|x - c| + R), the numerator
    # exact in rationals (the subtraction |x - c| - R in floats is off by up to eps R: 4e-15 relative here)
    exact = [float(sum((Fraction(a) - Fraction(b)) ** 2 for a, b in zip(p, centre)) - Fraction(R) ** 2)
             / (np.linalg.norm(p - centre) + R) for p in x]
    # the numerator in doubled precision: the rounding of the last few operations, <= ~5 eps (measured 2.3e-16)
    np.testing.assert_allclose(disc.distance(x, nu), exact, rtol=2e-15, atol=0)


def test_sphere_and_cylinder_rows_are_the_closest_point_by_brute_force():
    centre, R = np.array([0.1, -0.2, 0.6]), 0.5
    ball = cc.Rigid.sphere(centre, R)
    x = np.column_stack([RNG.uniform(-0.3, 0.5, 10), RNG.uniform(-0.6, 0.2, 10), RNG.uniform(0.0, 0.12, 10)])
    ang = grid(np.linspace(0, np.pi, 121), np.linspace(-np.pi, np.pi, 241))
    on_sphere = lambda p: centre + R * np.array([np.sin(p[0]) * np.cos(p[1]), np.sin(p[0]) * np.sin(p[1]),  # noqa: E731
                                                  np.cos(p[0])])
    check_rows(ball, x, UP, on_sphere, ang, [(0, np.pi), (-2 * np.pi, 2 * np.pi)], lambda q: (q - centre) / R,
               1e-12)                                                      # measured 2.2e-14, 1.7e-16
    p0, axis = np.array([0.0, 0.2, 0.55]), np.array([1.0, 0.4, 0.1]) / np.linalg.norm([1.0, 0.4, 0.1])
    roller = cc.Rigid.cylinder(p0, axis, R)
    e1 = np.cross(axis, UP)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    on_cylinder = lambda p: p0 + p[0] * axis + R * (np.cos(p[1]) * e1 + np.sin(p[1]) * e2)  # noqa: E731

    def outward(q):
        w = q - p0 - ((q - p0) @ axis) * axis
        return w / np.linalg.norm(w)

    check_rows(roller, x, UP, on_cylinder, grid(np.linspace(-1.5, 1.5, 61), np.linspace(-np.pi, np.pi, 361)),
               [(-3, 3), (-2 * np.pi, 2 * np.pi)], outward, 1e-12)         # measured 1.9e-12, 3e-16


def test_height_field_and_profile_rows_are_the_projection_by_brute_force():
    """The Newton projections against brute force and against the surfaces' own analytic normals: the
    distance to ~1e-10 relative (the slopes are fourth-order differences of the user's f)."""
    a, b = 0.8, 0.5

    def f(x, y):
        return 0.05 + (x ** 2 / a + y ** 2 / b) / 2 + 0.02 * np.sin(3 * x) * np.cos(2 * y)

    def grad(x, y):
        return np.array([x / a + 0.06 * np.cos(3 * x) * np.cos(2 * y), y / b - 0.04 * np.sin(3 * x) * np.sin(2 * y)])

    origin = np.array([0.1, -0.1, 0.02])
    field = cc.Rigid.height_field(f, origin=origin)
    x = np.column_stack([RNG.uniform(-0.5, 0.6, 10), RNG.uniform(-0.6, 0.5, 10), RNG.uniform(-0.05, 0.05, 10)])

    def graph(p):
        return np.array([p[0], p[1], f(p[0] - origin[0], p[1] - origin[1]) + origin[2]])

    def outward(q):
        n = np.r_[grad(q[0] - origin[0], q[1] - origin[1]), -1.0]
        return n / np.linalg.norm(n)

    check_rows(field, x, UP, graph, grid(np.linspace(-1.2, 1.2, 241), np.linspace(-1.2, 1.2, 241)),
               [(-2, 2), (-2, 2)], outward, 1e-9)                          # measured 2.2e-15, 2.1e-13
    # a profile over a tilted contact line: the curve x0 + s t + F(s) nu, F(s) = 0.03 + s^2 / (2 * 0.4)
    nu = np.array([np.sin(0.3), np.cos(0.3)])
    t = np.array([nu[1], -nu[0]])                                    # canonical: positive x1 component
    origin2 = np.array([0.2, 0.1])
    prof = cc.Rigid.profile(lambda s: 0.03 + s ** 2 / 0.8 + 0.01 * np.sin(5 * s), origin=origin2)
    F = lambda s: 0.03 + s ** 2 / 0.8 + 0.01 * np.sin(5 * s)                  # noqa: E731
    dF = lambda s: s / 0.4 + 0.05 * np.cos(5 * s)                             # noqa: E731
    s = RNG.uniform(-0.5, 0.5, 12)
    pts = origin2 + np.outer(s, t)                                   # nodes on the part's line
    curve = lambda p: origin2 + p[0] * t + F(p[0]) * nu                       # noqa: E731

    def outward2(q):
        sq = (q - origin2) @ t
        n = dF(sq) * t - nu
        return n / np.linalg.norm(n)

    check_rows(prof, pts, nu, curve, np.linspace(-1.5, 1.5, 3001)[:, None], [(-2, 2)], outward2, 1e-9)
    # measured 6.4e-15, 4.4e-13


def test_a_foot_point_that_does_not_settle_is_a_typed_error():
    """A staircase surface (no slope to follow): Newton's projection cannot settle; SceneError names the remedy."""
    kinked = cc.Rigid.height_field(lambda x, y: 0.1 + np.floor(1e3 * (x + 0.3 * y)) / 1e3)
    with pytest.raises(cc.SceneError, match=r"closest point.*not found to rounding.*distance='ray'"):
        kinked.distance(np.array([[0.0, 0.0, 0.0]]), UP)


def test_the_ray_posing_is_kept_by_name_and_unknown_names_are_refused():
    ray = cc.Rigid.sphere((0, 0, 1.1), 1.0, distance="ray")
    x = np.array([[0.3, 0.2, 0.0], [2.0, 0.0, 0.0]])
    d = ray.distance(x, UP)
    assert d[0] == pytest.approx(1.1 - np.sqrt(1 - 0.13), rel=1e-15) and np.isinf(d[1])
    np.testing.assert_array_equal(ray.direction(x, UP), np.tile(UP, (2, 1)))
    assert "distance='ray'" in repr(ray) and "distance='ray'" in repr(ray.moved(by=(0, 0, 1)).with_force((0, 0, -1)))
    with pytest.raises(cc.SceneError, match=r"distance must be one of \['closest', 'ray'\]"):
        cc.Rigid.circle((0, 0), 1.0, distance="vertical")


# ------------------------------------------------------------------------ the Hertz sphere on a quarter block

E, NU = 70e9, 0.3
R_BALL, DEPTH = 0.5, 1e-2


def quarter_block(Q=np.eye(3), n=(8, 8, 2)):
    """A quarter block (0, 0.25)^2 x (-0.25, 0) m (rollers on x = 0 and y = 0, base clamped) under a rigid sphere
    (R 0.5 m, centre on the z axis) pressed DEPTH into it: a/R ~ 0.14; the whole scene turned by Q."""
    mesh = cc.box(x=(0, 0.25), y=(0, 0.25), z=(-0.25, 0), nx=n[0], ny=n[1], nz=n[2])
    mesh = mesh.with_points(mesh.points @ Q.T)
    body = cc.Body(mesh, cc.materials.isotropic(E=E, nu=NU), clamped="bottom", roller=["left", "front"],
                   contact="top", name="block")
    centre = Q @ np.array([0.0, 0.0, R_BALL - DEPTH])
    return cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere(centre, R_BALL))]), centre


def test_the_hertz_sphere_equals_an_independent_dense_solve_of_the_radial_rows():
    """The package's answer against tests/reference3d.py's dense mixed system, whose rows are rebuilt here from
    the block's top nodes with the radial direction (centre - x)/|centre - x| and g = |x - centre| - R: solved on
    the package's active set and certified (every row feasible, non-negative forces); u and the sphere's force
    agree to 1e-9. The ray posing's answer differs by far more (the model, not rounding)."""
    scene, centre = quarter_block()
    sol = cc.solve(scene, "gamma3")
    assert sol.ok
    ref = Dense(scene, "gamma3", obstacles={0: ("sphere", centre, R_BALL)})
    c = sol.contacts[0]
    on = np.flatnonzero(c.constrained)
    j = match(ref.points(0), c.points[on], 1e-9)
    active = c.active[on][j]
    assert 3 <= active.sum() < len(active)                                     # measured 8 of 81
    ans = ref.solve_on(active)
    penetration, unbalanced, y = ref.certify(ans, active)
    assert penetration < 1e-12 and unbalanced < 1e-12                          # measured 1e-16, 3.1e-15
    assert rel(sol.u, ans.u) < 1e-9                                            # measured 8.7e-16
    w = ref.points(0)[active] - centre
    F_ref = y @ (w / np.linalg.norm(w, axis=1)[:, None])                       # sum y n_o: on the sphere
    F = sol.obstacles[0].force
    assert np.abs(F - F_ref).max() < 1e-9 * np.abs(F_ref).max()                # measured 2.2e-15
    ray = cc.solve(scene.with_obstacles(cc.Rigid.sphere(centre, R_BALL, distance="ray")), "gamma3")
    assert abs(ray.obstacles[0].force[2] / F[2] - 1) > 1e-4                    # measured 3.5e-3


def test_the_hertz_sphere_on_a_rotated_block_gives_the_same_force():
    """The same scene turned rigidly by a generic rotation (block, rollers, sphere): the force turns with it and
    the displacements too, to 1e-10 (closest-point rows are geometric: no preferred axis)."""
    scene, _ = quarter_block()
    Q = rotation()
    turned, _ = quarter_block(Q)
    a, b = cc.solve(scene, "gamma3"), cc.solve(turned, "gamma3")
    assert a.ok and b.ok
    Fa, Fb = a.obstacles[0].force, b.obstacles[0].force
    assert np.linalg.norm(Q @ Fa - Fb) < 1e-10 * np.linalg.norm(Fa)            # measured 3.3e-15
    assert rel(b.u[0], a.u[0] @ Q.T) < 1e-10                                   # measured 5.5e-15


def test_a_scene_file_names_the_posing():
    """An [[obstacle]] table takes distance = "closest" | "ray" (the constructor's), and refuses another name."""
    from cvxcontact.io.scenefile import SceneFileError, scene_from_data

    data = {"body": [{"name": "b", "material": "PZT5A", "clamped": ["bottom"], "grounded": ["bottom"],
                      "contact": "top", "mesh": {"rectangle": {"x": [0, 1], "y": [0, 0.5], "nx": 4, "ny": 2}}}],
            "obstacle": [{"name": "disc", "circle": {"center": [0.5, 1.1], "radius": 0.6, "distance": "ray"}}],
            "contact": [{"a": "b", "part_a": "top", "b": "disc"}]}
    ray = scene_from_data(data, "posed.toml").scene.obstacles[0].obstacle
    assert repr(ray) == repr(cc.Rigid.circle((0.5, 1.1), 0.6, distance="ray"))
    del data["obstacle"][0]["circle"]["distance"]
    closest = scene_from_data(data, "posed.toml").scene.obstacles[0].obstacle
    assert repr(closest) == repr(cc.Rigid.circle((0.5, 1.1), 0.6))
    data["obstacle"][0]["circle"]["distance"] = "vertical"
    with pytest.raises(SceneFileError, match=r"posed.toml: obstacle\[0\].*distance must be one of"):
        scene_from_data(data, "posed.toml")
