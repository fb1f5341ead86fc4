"""A guided rigid obstacle (``guided=`` axes: force control along them, the other translations held): on a
half or quarter model it gives the answer of the whole model, mirrored from it, with a free (unguided)
obstacle; the unguided obstacle on the symmetric part is refused; bad axes and forces are typed errors."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d as h
from cvxcontact.errors import FrozenError, SceneError
from cvxcontact.io.scenefile import SceneFileError, scene_from_data
from cvxcontact.physics.materials import isotropic

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def mirrored(mesh, axis, symmetry):
    """``mesh`` and its mirror image across the plane x_axis = 0 (a face of it), the nodes on the plane shared;
    the tags of ``symmetry`` (faces on that plane) dropped, every other tag kept on both halves."""
    P = np.asarray(mesh.points)
    n = len(P)
    on = P[:, axis] == 0
    Q = P.copy()
    Q[:, axis] *= -1
    image = np.where(on, np.arange(n), n + np.arange(n))           # a node's image (itself on the plane)
    keep = np.concatenate([np.ones(n, bool), ~on])
    index = np.cumsum(keep) - 1
    cells = np.asarray(mesh.cells)
    flipped = index[image[cells]]
    flipped[:, [0, 1]] = flipped[:, [1, 0]]                          # a mirror turns the orientation
    tags = {t: np.concatenate([np.asarray(mesh.boundary(t)), index[image[np.asarray(mesh.boundary(t))]]])
            for t in mesh.tags if t not in symmetry}
    return type(mesh)(np.concatenate([P, Q])[keep], np.concatenate([cells, flipped]), tags)


def node_forces(sol, points):
    """The contact force (N) of ``sol`` at each of ``points`` (its contact nodes, matched by coordinates)."""
    c = sol.contact
    key = {tuple(np.round(p, 15)): y for p, y in zip(c.points, c.force)}
    return np.array([key[tuple(np.round(p, 15))] for p in points])


def test_a_guided_sphere_on_a_quarter_is_the_whole_block_under_a_free_sphere():
    """Quarter model (symmetry rollers, the sphere guided along z under F / 4) against the whole block mirrored
    from it twice under a free sphere (force (0, 0, -F), every translation an unknown): the same approach, a
    quarter of the force, and at every contact node of the quarter the whole model's force times the share of
    the node's hat inside the quarter (1/4 on the axis, 1/2 on a symmetry plane)."""
    quarter = h.block(4)
    whole = cc.Body(mirrored(mirrored(quarter.mesh, 0, ("left",)), 1, ("front",)), quarter.material,
                    name="whole", clamped=["bottom"], contact="zone")
    guided = cc.Rigid.sphere((0.0, 0.0, h.R), h.R, force=(0.0, 0.0, -h.FORCE / 4), guided=(0, 0, 1))
    free = cc.Rigid.sphere((0.0, 0.0, h.R), h.R, force=(0.0, 0.0, -h.FORCE))
    q = cc.solve(cc.Scene(quarter, contacts=[cc.Contact(quarter, "zone", guided)]))
    w = cc.solve(cc.Scene(whole, contacts=[cc.Contact(whole, "zone", free)]))
    assert q.ok and w.ok, (q.report(), w.report())
    tq, tw = q.obstacles[0].translation, w.obstacles[0].translation
    assert tq[0] == 0 and tq[1] == 0                                    # held by the guide
    delta = -tw[2]
    assert abs(tw[0]) <= 1e-9 * delta and abs(tw[1]) <= 1e-9 * delta    # free, zero by symmetry: measured 7e-15
    assert tq[2] == pytest.approx(tw[2], rel=1e-9)                      # measured 7e-16
    assert 4 * q.contact.force.sum() == pytest.approx(w.contact.force.sum(), rel=1e-12)
    pts = q.contact.points
    share = np.where(pts[:, 0] == 0, 0.5, 1.0) * np.where(pts[:, 1] == 0, 0.5, 1.0)
    np.testing.assert_allclose(q.contact.force, share * node_forces(w, pts), rtol=0,
                               atol=1e-9 * h.FORCE)                     # measured 3e-13 N
    np.testing.assert_allclose(q.obstacles[0].force, [0.0, 0.0, -h.FORCE / 4], rtol=0, atol=1e-12 * h.FORCE)


def half_scene(guided=(0.0, 1.0), force=-2e7, distance="closest"):
    """2D: a cylinder (a disc in plane strain) pressed on the top of the half block x >= 0 (roller on x = 0),
    posed by ``distance``."""
    mesh = cc.rectangle((0.0, 0.01), (-0.01, 0.0), nx=10, ny=6)
    body = cc.Body(mesh, isotropic(E=70e9, nu=0.3), name="half", clamped=["bottom"], roller=["left"],
                   contact="top")
    disc = cc.Rigid.circle((0.0, 0.02), 0.02, force=(0.0, force / 2), guided=guided, distance=distance)
    return body, cc.Scene(body, contacts=[cc.Contact(body, "top", disc)])


def test_a_guided_disc_on_a_half_block_is_the_whole_block_under_a_free_disc():
    half, scene = half_scene()
    whole = cc.Body(mirrored(half.mesh, 0, ("left",)), half.material, name="whole", clamped=["bottom"],
                    contact="top")
    free = cc.Rigid.circle((0.0, 0.02), 0.02, force=(0.0, -2e7))
    g = cc.solve(scene)
    w = cc.solve(cc.Scene(whole, contacts=[cc.Contact(whole, "top", free)]))
    assert g.ok and w.ok
    tg, tw = g.obstacles[0].translation, w.obstacles[0].translation
    assert tg[0] == 0 and abs(tw[0]) <= 1e-9 * abs(tw[1])               # measured 0 and 6e-15
    assert tg[1] == pytest.approx(tw[1], rel=1e-9)                      # measured 4e-16
    pts = g.contact.points
    share = np.where(pts[:, 0] == 0, 0.5, 1.0)
    np.testing.assert_allclose(g.contact.force, share * node_forces(w, pts), rtol=0,
                               atol=1e-9 * 2e7)                         # measured 4e-9 N/m


def test_the_unguided_disc_on_the_half_block_is_refused():
    with pytest.raises(SceneError, match="nothing determines the translation"):
        cc.solve(half_scene(guided=None)[1])


def test_a_plane_guided_along_its_normal_is_the_plane_under_force_control():
    """A plane's tangential translations are not unknowns anyway: guiding it along its normal changes nothing."""
    mesh = cc.box(x=(0, 1e-2), y=(0, 1e-2), z=(0, 5e-3), nx=2, ny=2, nz=2)
    body = cc.Body(mesh, isotropic(E=70e9, nu=0.3), name="layer", clamped=["bottom"], contact="top")
    plane = cc.Rigid.plane((0, 0, 5e-3), (0, 0, -1), force=(0, 0, -1e3))
    a = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", plane)]))
    b = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.plane(
        (0, 0, 5e-3), (0, 0, -1), force=(0, 0, -1e3), guided=(0, 0, 1)))]))
    assert a.ok and b.ok
    np.testing.assert_allclose(b.obstacles[0].translation, a.obstacles[0].translation, rtol=1e-12, atol=0)
    np.testing.assert_allclose(b.contact.force, a.contact.force, rtol=0, atol=1e-12 * 1e3)


def test_the_guide_restricts_the_sensitivity_and_survives_moves_and_new_forces():
    s = cc.Rigid.sphere((0.0, 0.0, 1.0), 1.0, force=(0.0, 0.0, -1.0), guided=(0, 0, 1))
    x = np.array([[0.3, 0.2, 0.0], [0.0, 0.5, 0.0]])
    nu = np.array([0.0, 0.0, 1.0])
    free = cc.Rigid.sphere((0.0, 0.0, 1.0), 1.0, force=(0.0, 0.0, -1.0)).sensitivity(x, nu)
    assert np.abs(free[:, :2]).max() > 0.1                              # a free sphere's c has x, y parts ...
    np.testing.assert_array_equal(s.sensitivity(x, nu), free * [0.0, 0.0, 1.0])   # ... the guided one not
    assert repr(s).endswith("guided=(0, 0, 1))")
    np.testing.assert_array_equal(s.moved(by=(0.0, 0.0, 0.1)).guided, [[0.0, 0.0, 1.0]])
    np.testing.assert_array_equal(s.with_force((0.0, 0.0, -2.0)).guided, [[0.0, 0.0, 1.0]])
    with pytest.raises(SceneError, match="a direction the guide holds"):
        s.with_force((1.0, 0.0, -2.0))
    with pytest.raises(FrozenError, match="guided="):
        s.guided = None
    two = cc.Rigid.cylinder((0, 0, 1), (1, 0, 0), 1.0, force=(0.0, 0.0, -1.0), guided=[(0, 1, 0), (0, 0, 1)])
    assert two.guided.shape == (2, 3) and not two.guided.flags.writeable


@pytest.mark.parametrize("make, match", [
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0, force=(0, 0, -1), guided=(0, 0, 2)), "has length 2"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0, force=(0, 0, -1), guided=[(0, 0, 1), (0, 0.6, 0.8)]),
     "are not orthogonal"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0, force=(0.1, 0, -1), guided=(0, 0, 1)),
     r"component 0.1 N along \(1, 0, 0\), a direction the guide holds"),
    (lambda: cc.Rigid.sphere((0, 0, 1), 1.0, force=(0, 0, -1), guided=(0, 1)), "for a 3D obstacle"),
    (lambda: cc.Rigid.circle((0, 1), 1.0, force=(0, -1), guided=(0, 0, 1)), "for a 2D obstacle"),
    (lambda: cc.Rigid.circle((0, 1), 1.0, force=(0, -1), guided=[(1, 0), (0, 1), (1, 0)]), "3 axes in 2D"),
    (lambda: cc.Rigid.plane((0, 0), (0, 1), force=(0, -1), guided="z"), "one unit axis"),
    (lambda: cc.Rigid.plane((0, 0), (0, 1), force=(0, -1), guided=(np.nan, 1)), "one unit axis"),
])
def test_bad_guides_are_typed_errors(make, match):
    with pytest.raises(SceneError, match=match):
        make()


def test_a_guide_the_contact_cannot_see_is_refused():
    """A plane guided along a tangent: no translation it may make changes a distance."""
    mesh = cc.box(x=(0, 1e-2), y=(0, 1e-2), z=(0, 5e-3), nx=2, ny=2, nz=1)
    body = cc.Body(mesh, isotropic(E=70e9, nu=0.3), name="layer", clamped=["bottom"], contact="top")
    plane = cc.Rigid.plane((0, 0, 5e-3), (0, 0, -1), force=(1.0, 0, 0), guided=(1, 0, 0))
    with pytest.raises(SceneError, match="along its guided axes changes no distance"):
        cc.Scene(body, contacts=[cc.Contact(body, "top", plane)])


def test_scene_files_take_the_guide():
    data = {"condition": "gamma3",
            "body": [{"name": "half", "material": {"E": 70e9, "nu": 0.3},
                      "mesh": {"rectangle": {"x": [0.0, 0.01], "y": [-0.01, 0.0], "nx": 10, "ny": 6}},
                      "clamped": ["bottom"], "roller": ["left"], "contact": "top"}],
            "obstacle": [{"name": "disc", "circle": {"center": [0.0, 0.02], "radius": 0.02},
                          "force": [0.0, -1e7], "guided": [0.0, 1.0]}],
            "contact": [{"a": "half", "part_a": "top", "b": "disc"}]}
    scene = scene_from_data(data, "guided.toml").scene
    np.testing.assert_array_equal(scene.obstacles[0].obstacle.guided, [[0.0, 1.0]])
    sol = cc.solve(scene)
    assert sol.ok
    np.testing.assert_allclose(sol.obstacles[0].translation, cc.solve(half_scene()[1]).obstacles[0].translation,
                               rtol=1e-12, atol=0)
    data["obstacle"][0]["guided"] = [0.6, 0.6]
    with pytest.raises(SceneFileError, match=r"obstacle\[0\].*has length"):
        scene_from_data(data, "guided.toml")


def test_the_model_and_a_distance_only_obstacle_take_the_guide():
    """cc.Model poses the guided translation as cc.solve does; an obstacle given by its distance alone (its
    sensitivity by central differences) is guided the same way."""
    body, scene = half_scene()
    ref = cc.solve(scene)
    model = cc.Model(scene).solve()
    assert model.ok
    np.testing.assert_allclose(model.obstacles[0].translation, ref.obstacles[0].translation, rtol=1e-12,
                               atol=0)                                  # measured 0
    # an obstacle given by its distance alone is posed along the body's normal: the ray circle's twin
    disc = cc.Rigid.circle((0.0, 0.02), 0.02, distance="ray")
    by_distance = cc.Rigid("circle", disc.distance, "disc(distance only)", force=(0.0, -1e7), guided=(0, 1))
    sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", by_distance)]))
    assert sol.ok and sol.obstacles[0].translation[0] == 0
    ray = cc.solve(half_scene(distance="ray")[1])
    np.testing.assert_allclose(sol.obstacles[0].translation, ray.obstacles[0].translation,
                               rtol=1e-6, atol=0)                       # measured 1e-9 (differences)
