"""Rigid obstacles in 3D: plane, sphere, cylinder and height field distances and sensitivities against
closed forms, invariances and finite differences; force-control balance; typed refusals."""

from types import SimpleNamespace

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.errors import SceneError
from cvxcontact.physics.pairs import obstacle_rows

UP = np.array([0.0, 0.0, 1.0])


def grid(half=0.8, n=9, z=0.0):
    """Points of a square of the plane z (a body's top face)."""
    s = np.linspace(-half, half, n)
    X, Y = np.meshgrid(s, s)
    return np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])


def rotation():
    """A generic rotation (not about a coordinate axis)."""
    q, _ = np.linalg.qr(np.array([[0.3, -1.2, 0.5], [0.9, 0.4, -0.7], [0.2, 0.8, 1.1]]))
    return q * np.sign(np.linalg.det(q))


def test_sphere_distance_is_the_ray_sphere_closed_form():
    R, gap = 1.0, 0.01
    ball = cc.Rigid.sphere((0.1, -0.2, R + gap), R, distance="ray")
    x = grid()
    d = ball.distance(x, UP)
    r2 = (x[:, 0] - 0.1) ** 2 + (x[:, 1] + 0.2) ** 2
    want = np.where(r2 < R ** 2, R + gap - np.sqrt(np.maximum(R ** 2 - r2, 0)), np.inf)
    assert np.isinf(want).any() and np.isfinite(want).any()
    np.testing.assert_allclose(d, want, rtol=0, atol=1e-15)                 # measured 2e-16
    assert ball.dim == 3 and ball.kind == "sphere"
    inside = ball.distance([[0.1, -0.2, 0.5 + gap]], UP)                     # interference: back to the surface
    assert inside[0] == pytest.approx(-0.5)


@pytest.mark.parametrize("make", [
    lambda: cc.Rigid.plane((0.0, 0.0, 0.2), (0.3, -0.1, -1.0)),
    lambda: cc.Rigid.sphere((0.2, 0.1, 1.3), 1.2),
    lambda: cc.Rigid.cylinder((0.0, 0.0, 1.1), (1.0, 0.4, 0.1), 1.0),
], ids=["plane", "sphere", "cylinder"])
def test_distance_is_invariant_under_a_rotation_and_a_translation(make):
    """d(Qx + b, Q nu) of the obstacle turned by Q and moved by b equals d(x, nu): an independent check of
    the geometry of every ray (tilted normal included)."""
    obstacle = make()
    Q, b = rotation(), np.array([0.3, -2.0, 0.7])
    nu = np.array([0.2, -0.1, 1.0]) / np.linalg.norm([0.2, -0.1, 1.0])
    x = grid(0.5, 7)
    d = obstacle.distance(x, nu)
    kind = obstacle.kind
    if kind == "plane":
        turned = cc.Rigid.plane(Q @ [0.0, 0.0, 0.2] + b, Q @ [0.3, -0.1, -1.0])
    elif kind == "sphere":
        turned = cc.Rigid.sphere(Q @ [0.2, 0.1, 1.3] + b, 1.2)
    else:
        turned = cc.Rigid.cylinder(Q @ [0.0, 0.0, 1.1] + b, Q @ [1.0, 0.4, 0.1], 1.0)
    d2 = turned.distance(x @ Q.T + b, Q @ nu)
    assert np.isfinite(d).sum() >= 10
    np.testing.assert_array_equal(np.isinf(d), np.isinf(d2))
    np.testing.assert_allclose(d2[np.isfinite(d)], d[np.isfinite(d)], rtol=1e-12, atol=1e-14)  # measured 5e-15 rel., 3e-16 abs.
    # and the hit points (along nu for the plane's ray, to the closest point of a curved obstacle) lie on the
    # surface (the defining equation, by a formula of its own)
    q = x + np.where(np.isfinite(d), d, 0)[:, None] * obstacle.direction(x, nu)
    hit = np.isfinite(d)
    if kind == "sphere":
        res = np.linalg.norm(q - [0.2, 0.1, 1.3], axis=1) - 1.2
    elif kind == "cylinder":
        a = np.array([1.0, 0.4, 0.1]) / np.linalg.norm([1.0, 0.4, 0.1])
        w = q - [0, 0, 1.1]
        res = np.linalg.norm(w - np.outer(w @ a, a), axis=1) - 1.0
    else:
        res = (q - [0, 0, 0.2]) @ np.array([0.3, -0.1, -1.0])
    assert np.abs(res[hit]).max() < 1e-13                                   # measured 2e-16


def test_cylinder_closed_form_and_rays_along_its_axis():
    R, h = 0.5, 0.02
    roller = cc.Rigid.cylinder((0.0, 3.0, R + h), (0.0, 1.0, 0.0), R, distance="ray")
    x = grid()
    want = np.where(np.abs(x[:, 0]) < R, R + h - np.sqrt(np.maximum(R ** 2 - x[:, 0] ** 2, 0)), np.inf)
    np.testing.assert_allclose(roller.distance(x, UP), want, atol=1e-15)
    assert np.isinf(roller.distance(x, np.array([0.0, 1.0, 0.0]))).all()     # along the axis: never met
    assert roller.dim == 3 and "cylinder(point=(0, 3, 0.52), axis=(0, 1, 0), radius=0.5, distance='ray')" \
        in repr(roller)


def test_height_field_closed_form_and_against_a_plane():
    R, g = 2.0, 0.01
    para = cc.Rigid.height_field(lambda x, y: (x ** 2 + y ** 2) / (2 * R), origin=(0.1, 0.0, g), distance="ray")
    x = grid(z=-0.05)
    np.testing.assert_allclose(para.distance(x, UP), ((x[:, 0] - 0.1) ** 2 + x[:, 1] ** 2) / (2 * R) + g + 0.05,
                               atol=1e-15)
    # a linear height field is a half-space: compare with Rigid.plane under a tilted normal (Newton's path)
    a, b = 0.2, -0.1
    field = cc.Rigid.height_field(lambda x, y: a * x + b * y, origin=(0.0, 0.0, 0.3), distance="ray")
    plane = cc.Rigid.plane((0.0, 0.0, 0.3), (a, b, -1.0))
    nu = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    np.testing.assert_allclose(field.distance(x, nu), plane.distance(x, nu), rtol=1e-12)  # measured 2e-16
    np.testing.assert_allclose(field.sensitivity(x, nu), plane.sensitivity(x, nu), rtol=1e-7)  # measured 3e-11
    # curved and tilted: the hit points lie on the graph
    d = para.distance(x, nu)
    q = x + d[:, None] * nu
    assert np.abs(q[:, 2] - ((q[:, 0] - 0.1) ** 2 + q[:, 1] ** 2) / (2 * R) - g).max() < 1e-12   # measured 5e-17
    # where f is +inf there is no obstacle
    hole = cc.Rigid.height_field(lambda x, y: np.where(x > 0, np.inf, 0.1))
    d = hole.distance(x, UP)
    assert np.isinf(d[x[:, 0] > 0]).all() and np.isfinite(d[x[:, 0] <= 0]).all()


@pytest.mark.parametrize("obstacle", [
    cc.Rigid.plane((0.0, 0.0, 0.2), (0.3, -0.1, -1.0)),
    cc.Rigid.sphere((0.2, 0.1, 1.3), 1.2),
    cc.Rigid.cylinder((0.0, 0.0, 1.1), (1.0, 0.4, 0.1), 1.0),
    cc.Rigid.height_field(lambda x, y: (x ** 2 + 2 * y ** 2) / 3, origin=(0.1, 0.0, 0.05)),
], ids=["plane", "sphere", "cylinder", "height_field"])
@pytest.mark.parametrize("tilted", [False, True])
def test_sensitivity_is_the_derivative_of_the_distance_under_a_translation(obstacle, tilted):
    """c(x) . t = d(x) - d_t(x) to first order, d_t the distance to the obstacle moved by t (3d.md §2)."""
    nu = np.array([0.2, -0.1, 1.0]) / np.linalg.norm([0.2, -0.1, 1.0]) if tilted else UP
    x = grid(0.4, 5)
    c = obstacle.sensitivity(x, nu)
    assert c.shape == (len(x), 3) and np.isfinite(obstacle.distance(x, nu)).all()
    eps = 1e-6
    fd = np.column_stack([(obstacle.moved(by=-eps * e).distance(x, nu) - obstacle.moved(by=eps * e).distance(x, nu))
                          / (2 * eps) for e in np.eye(3)])
    np.testing.assert_allclose(c, fd, atol=1e-6)                            # measured 2e-10 at most
    if obstacle.kind == "plane":                                            # the ray: moving along -nu is 1:1
        np.testing.assert_allclose(np.einsum("ij,j->i", c, nu), -1.0, atol=1e-12)  # measured 2e-16
    else:                                                                   # closest point: the unit normal there
        np.testing.assert_allclose(np.linalg.norm(c, axis=1), 1.0, atol=1e-12)


def test_moved_with_force_and_repr():
    ball = cc.Rigid.sphere((0.0, 0.0, 1.0), 1.0)
    up = ball.moved(by=(0.0, 0.0, 0.25))
    x = grid()
    d0, d1 = ball.distance(x, UP), up.distance(x, UP)
    np.testing.assert_allclose(d0, np.linalg.norm(x - [0, 0, 1], axis=1) - 1, atol=1e-15)   # closest point
    np.testing.assert_allclose(d1, np.linalg.norm(x - [0, 0, 1.25], axis=1) - 1, atol=1e-15)
    np.testing.assert_array_equal(up.position, [0, 0, 1.25])
    assert np.array_equal(ball.moved(to=(1.0, 2.0, 3.0)).position, [1, 2, 3])
    pressed = ball.with_force((0.0, 0.0, -5.0))
    np.testing.assert_array_equal(pressed.force, [0, 0, -5])
    assert repr(pressed) == "Rigid.sphere(center=(0, 0, 1), radius=1, force=(0, 0, -5))"
    assert repr(up) == "Rigid.sphere(center=(0, 0, 1.25), radius=1)"
    assert cc.Rigid.plane((0, 0), (0, 1)).dim == 2 and cc.Rigid.plane((0, 0, 0), (0, 0, 1)).dim == 3
    assert repr(cc.Rigid.plane((0, 0), (0, 2))) == "Rigid.plane(point=(0, 0), normal=(0, 1))"


@pytest.mark.parametrize("build, words", [
    (lambda: cc.Rigid.sphere((0, 0, 1), 0.0), "radius must be a positive finite number"),
    (lambda: cc.Rigid.sphere((0, 0, 1), -1.0), "radius must be a positive finite number"),
    (lambda: cc.Rigid.cylinder((0, 0, 1), (0, 1, 0), float("nan")), "radius must be a positive finite number"),
    (lambda: cc.Rigid.sphere((0, 1), 1.0), "center: expected three finite real numbers"),
    (lambda: cc.Rigid.sphere((0, np.nan, 1), 1.0), "center: expected three finite real numbers"),
    (lambda: cc.Rigid.plane((0, 0, 0), (0, 0, 0)), "normal must not be zero"),
    (lambda: cc.Rigid.plane((0, 0, 0), (0, 1)), "normal: expected three finite real numbers"),
    (lambda: cc.Rigid.plane((0, 0, 0, 0), (0, 1, 0, 0)), "point: expected two or three finite real numbers"),
    (lambda: cc.Rigid.cylinder((0, 0, 1), (0, 0, 0), 1.0), "axis must not be zero"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0, force=(0, -1)), "force: expected three finite real numbers"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0, force=(0, 0, 0)), r"force=\(0, 0, 0\)\): a zero force"),
    (lambda: cc.Rigid.plane((0, 0), (0, 1), force=(0, 1, 0)), "force: expected two finite real numbers"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0).moved(by=(0, 1)), "by: expected three finite real numbers"),
    (lambda: cc.Rigid.height_field("z = x"), "f must be a callable"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0).distance(grid()[:, :2], UP), r"expected points \(n, 3\)"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0).distance(grid(), [0, 0, 2]), "must be a unit vector"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0).distance(np.full((2, 3), np.nan), UP), "must be finite"),
    (lambda: cc.Rigid.plane((0, 0, 1), (0, 0, 1)).distance(grid(), UP), "does not face the contact part"),
    (lambda: cc.Rigid.height_field(lambda x, y: x).distance(grid(), -UP), "the part must face up"),
    (lambda: cc.Rigid.height_field(lambda x, y: np.nan * x).distance(grid(), UP), "f returned NaN"),
    (lambda: cc.Rigid.height_field(lambda x, y: x[:2]).distance(grid(), UP), "f returned shape"),
])
def test_bad_input_is_refused_typed(build, words):
    with pytest.raises(SceneError, match=words):
        build()


def fake_scene(obstacle, points, normal):
    """The fields obstacle_rows reads: one pair of ``obstacle`` against a planar part (points, normal)."""
    itf = SimpleNamespace(points=points, normal=normal)
    pair = SimpleNamespace(rigid=True, other=obstacle)
    return SimpleNamespace(stack=SimpleNamespace(size=len(points), offsets=[0, len(points)]),
                           contacts=[pair], interfaces=[itf])


def test_force_control_in_3d_balances_or_names_the_free_translation():
    top = grid(0.4, 5)
    rows = obstacle_rows(fake_scene(cc.Rigid.sphere((0, 0, 1.01), 1.0, force=(0.0, 0.0, -3.0)), top, UP))[0]
    assert rows.rows.shape == (25, 3) and rows.basis.shape == (3, 3)       # a sphere's translations all count
    plane = obstacle_rows(fake_scene(cc.Rigid.plane((0, 0, 0.1), (0, 0, -1), force=(0.0, 0.0, -3.0)), top, UP))[0]
    np.testing.assert_allclose(plane.basis, [[0], [0], [-1]], atol=1e-15)  # only the normal translation
    with pytest.raises(SceneError, match=r"component 1 N along \(1, 0, 0\).*free to slide along \(1, 0, 0\)"):
        obstacle_rows(fake_scene(cc.Rigid.plane((0, 0, 0.1), (0, 0, -1), force=(1.0, 0.0, -3.0)), top, UP))
    roller = cc.Rigid.cylinder((0, 0, 1.01), (0, 1, 0), 1.0, force=(0.0, 2.0, -3.0))
    with pytest.raises(SceneError, match=r"component 2 N along \(0, 1, 0\).*free to slide along \(0, 1, 0\)"):
        obstacle_rows(fake_scene(roller, top, UP))
    assert obstacle_rows(fake_scene(roller.with_force((0.5, 0.0, -3.0)), top, UP))[0].basis.shape == (3, 2)
    with pytest.raises(SceneError, match=r"pulls the obstacle away.*free to move along \(0, 0, 1\)"):
        obstacle_rows(fake_scene(cc.Rigid.sphere((0, 0, 1.01), 1.0, force=(0.0, 0.0, 3.0)), top, UP))


def test_a_small_sphere_over_too_few_nodes_is_refused_naming_them_and_solves_on_a_finer_mesh():
    """A sphere (R = 0.2 m) off-centre on a block with cells of 0.25 m reaches 2 top nodes: their rows see
    two of its three translations, so the prescribed force cannot be balanced; the error names the count and
    the remedy. Cells of 0.125 m: it is held, and the row forces balance the force (stationarity in t)."""
    def scene(n, distance="ray"):
        mesh = cc.box(x=(-1, 1), y=(-1, 1), z=(-1, 0), nx=n, ny=n, nz=2)
        body = cc.Body(mesh, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", contact="top", name="b")
        ball = cc.Rigid.sphere((0.3, 0.1, 0.2), 0.2, force=(0, 0, -1e8), distance=distance)
        return cc.Scene(body, contacts=[cc.Contact(body, "top", ball)])

    with pytest.raises(SceneError, match=r"free to slide.*only 2 nodes of its pairs lie within its reach.*refine "
                                         r"the mesh under it.*guided="):
        scene(8)
    sol = cc.solve(scene(16))
    assert sol.ok
    np.testing.assert_allclose(sol.obstacles[0].force, [0, 0, -1e8], rtol=0, atol=1e-6 * 1e8)  # measured 4.7e-10 N
    # posed at the closest point every top node sees the sphere, its rows radial: on the coarse mesh it slides
    # sideways into the hollow of three nodes and is held there
    sol = cc.solve(scene(8, "closest"))
    assert sol.ok and sol.contact.active.sum() == 3
    np.testing.assert_allclose(sol.obstacles[0].force, [0, 0, -1e8], rtol=0, atol=1e-6 * 1e8)  # measured 4e-9 N


# --------------------------------------------------------------------------- cylinders and height fields solved

def _block_under(obstacle, n=8):
    """A block (-1, 1)^2 x (-1, 0) m, aluminium, clamped at its bottom, its top against ``obstacle``."""
    mesh = cc.box(x=(-1, 1), y=(-1, 1), z=(-1, 0), nx=n, ny=n, nz=2)
    body = cc.Body(mesh, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top")
    return cc.Scene(body, contacts=[cc.Contact(body, "top", obstacle)])


def test_a_force_controlled_cylinder_equals_the_fixed_one_whose_force_it_is_given():
    """A cylinder (axis y, R = 2 m) pressed 0.02 m into the block off the grid's lines: its reaction F, given
    back as a prescribed force to the cylinder at rest on the top, moves it by the same 0.02 m along z only
    (free along x as well, where the off-centre contact pushes it; nothing acts along its axis) and gives the same displacements, to rounding (both
    finished exactly)."""
    R, depth, x0 = 2.0, 0.02, 0.07
    # the ray posing: its distance along the vertical normal shifts by exactly the vertical translation, so the
    # linearised rows of the moved cylinder are those of the fixed one (closest point: to first order in depth)
    fixed = cc.solve(_block_under(cc.Rigid.cylinder((x0, 0.0, R - depth), (0, 1, 0), R, distance="ray")))
    assert fixed.ok and fixed.polished
    F = fixed.obstacles[0].force
    assert F[2] < 0 and abs(F[1]) == 0 and 10 < fixed.contact.active.sum() < 81     # measured 18 nodes
    pushed = cc.solve(_block_under(cc.Rigid.cylinder((x0, 0.0, R), (0, 1, 0), R, force=F, distance="ray")))
    assert pushed.ok and pushed.polished
    t = pushed.obstacles[0].translation
    assert abs(t[2] / -depth - 1) < 1e-12 and abs(t[0]) < 1e-12 * depth          # measured 2e-15, 3e-15
    assert np.abs(pushed.u[0] - fixed.u[0]).max() < 1e-12 * np.abs(fixed.u[0]).max()   # measured 1.1e-15
    np.testing.assert_array_equal(pushed.contact.active, fixed.contact.active)


@pytest.mark.parametrize("posing", ["closest", "ray"])
def test_a_height_field_plane_is_the_rigid_plane(posing):
    """z = a x + b y + c as a height field and as cc.Rigid.plane through (0, 0, c) with the downward normal
    (a, b, -1)/|.|, both posed the same way: the same answer, to rounding, reached through the two obstacles' own
    distances (the height field's closest point by its Newton projection)."""
    a, b, c = 0.01, -0.02, -1e-3
    field = cc.Rigid.height_field(lambda x, y: a * x + b * y, origin=(0.0, 0.0, c), distance=posing)
    normal = np.array([a, b, -1.0]) / np.linalg.norm([a, b, -1.0])
    one = cc.solve(_block_under(field, 6))
    two = cc.solve(_block_under(cc.Rigid.plane((0, 0, c), normal, distance=posing), 6))
    assert one.ok and two.ok and 0 < one.contact.active.sum() < len(one.contact.x)   # measured 21 of 49
    assert np.abs(one.u[0] - two.u[0]).max() < 1e-12 * np.abs(two.u[0]).max()      # measured 2.8e-16
    F = two.obstacles[0].force
    assert np.abs(one.obstacles[0].force - F).max() < 1e-12 * np.abs(F).max()      # measured 1.6e-13


@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_a_sphere_or_cylinder_on_one_node_or_line_is_finished_its_sideways_translation_held(shape):
    """A force-controlled sphere centred over a node (one active row, on its axis) or a cylinder over a line of
    nodes (the active rows under its lowest line): the sideways translation changes no active row, so the
    solution leaves it free within the interval the open rows allow. The field and the forces are unique: the
    solve finishes exactly (it declined before: complementarity 0.19 at 1e5 N on the sphere, ok False), warns
    naming the translation, and equals the fixed obstacle at the returned position (an independent solve
    without translation unknowns), whose reaction is the prescribed force."""
    mesh = cc.box(x=(-1, 1), y=(-1, 1), z=(-1, 0), nx=8, ny=8, nz=2)
    body = cc.Body(mesh, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", contact="top", name="block")
    ob = (cc.Rigid.sphere((0.0, 0.0, 2.0), 2.0, force=(0, 0, -1e6)) if shape == "sphere" else
          cc.Rigid.cylinder((0.0, 0.0, 2.0), (0, 1, 0), 2.0, force=(0, 0, -1e6)))
    scene = cc.Scene(body, contacts=[cc.Contact(body, "top", ob)])
    with pytest.warns(cc.NonUniqueWarning, match=r"translation x of obstacle 0"):
        sol = cc.solve(scene)
    assert sol.ok and sol.polished
    t = sol.obstacles[0].translation
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", cc.ResolutionWarning)   # coarse by design: the resolution check names it
        ref = cc.solve(scene.with_obstacles(ob.moved(by=tuple(t)).with_force(None)))
    assert np.abs(sol.u[0] - ref.u[0]).max() <= 1e-9 * np.abs(ref.u[0]).max()    # measured 9.4e-13, 3.4e-12
    np.testing.assert_allclose(ref.obstacles[0].force, [0, 0, -1e6], rtol=0, atol=1e-6 * 1e6)  # 2.2e-9, 6.7e-11 N
