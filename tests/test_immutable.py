"""Descriptions cannot go stale (issue 20, item 3), and the typed errors of bad descriptions (item 7).

A built Mesh, material, Body, Load, Contact, Rigid or Scene refuses every edit, at the edit, with a
FrozenError (a SceneError and an AttributeError) naming the attribute and the variant to build; the
variants (``with_*``, ``moved``) are checked against a scene built from scratch and, where one exists,
against a closed form.
"""

import copy
import pickle

import numpy as np
from scipy.optimize import minimize_scalar
import pytest

import cvxcontact as cc
from cvxcontact.apps.cli import main
from cvxcontact.errors import FrozenError
from cvxcontact.io.scenefile import SceneFileError, load_scene
from cvxcontact.physics.fingerprint import geometry_fingerprint

ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def two_blocks(gap=0.0, force=(0.0, -1e9)):
    """A PZT-5A block on an aluminium block, meeting at y = 0 (the two-body form)."""
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=6, ny=3)
    b1 = cc.Body(m1, cc.materials.PZT5A, clamped="top", grounded="top", contact="bottom", body_force=force,
                 traction={"right": (0.0, 2e8)}, name="piezo")
    b2 = cc.Body(m2, ALU, clamped="bottom", contact="top", name="base")
    return cc.Scene(b1, b2, gap=gap)


def indenter(center=(0.47, 1.1), radius=0.6, force=None):
    """A block clamped at its bottom under a rigid circle (contacts= form; the block has no contact=)."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", name="block")
    circle = cc.Rigid.circle(center, radius, force=force)
    return cc.Scene(block, contacts=[cc.Contact(block, "top", circle)])


# ------------------------------------------------------------------ every edit is refused, typed

def edits():
    """(label, edit, the attribute named, the variant named) for every kind of description."""
    scene = two_blocks()
    b1, b2 = scene.bodies
    ind = indenter(force=(0.0, -1e6))
    rigid = ind.contacts[0].other
    mesh = b1.mesh
    return [
        ("body.mesh = other", lambda: setattr(b1, "mesh", b2.mesh), "Body.mesh", "with_changes(mesh="),
        ("del body.material", lambda: delattr(b1, "material"), "Body.material", "with_changes(material="),
        ("body.body_force = F", lambda: setattr(b1, "body_force", (0.0, 1.0)), "Body.body_force",
         "with_loads(body_force="),
        ("body.contact = tag", lambda: setattr(b1, "contact", "top"), "Body.contact", "with_changes(contact="),
        ("body.name = s", lambda: setattr(b1, "name", "x"), "Body.name", "with_changes(name="),
        ("body.roller.append", lambda: b1.roller.append("left"), "Body.roller (a tuple)", "with_changes(roller="),
        ("body.clamped.extend", lambda: b1.clamped.extend(["left"]), "Body.clamped (a tuple)",
         "with_changes(clamped="),
        ("body.grounded[0] = tag", lambda: b1.grounded.__setitem__(0, "left"), "Body.grounded[0]",
         "with_changes(grounded="),
        ("body.traction[tag] = f", lambda: b1.traction.__setitem__("left", (1.0, 0.0)), "Body.traction['left']",
         "with_loads(traction="),
        ("body.traction.update", lambda: b1.traction.update(left=(1.0, 0.0)), "Body.traction (a read-only mapping)",
         "with_loads(traction="),
        ("body.potential.pop", lambda: b1.potential.pop("top"), "Body.potential", "with_loads(potential="),
        ("del body.displacement[tag]", lambda: b1.displacement.__delitem__("top"), "Body.displacement['top']",
         "with_changes(displacement="),
        ("body.floating.setdefault", lambda: b1.floating.setdefault("left", 0.0), "Body.floating",
         "with_loads(floating="),
        ("body.held_by_contact.append", lambda: b1.held_by_contact.append("x"), "Body.held_by_contact", "supports"),
        ("load.value = v", lambda: setattr(b1.body_force, "value", 0.0), "Load.value", "with_loads"),
        ("rigid.force = F", lambda: setattr(rigid, "force", np.array([0.0, -2e6])), "Rigid.force", "with_force("),
        ("rigid.kind = s", lambda: setattr(rigid, "kind", "plane"), "Rigid.kind", "moved("),
        ("contact.gap = g", lambda: setattr(scene.contacts[0], "gap", 1e-3), "Contact.gap", "with_gap("),
        ("contact.other = rigid", lambda: setattr(ind.contacts[0], "other", rigid), "Contact.other",
         "with_obstacles("),
        ("scene.bodies[0] = b", lambda: scene.bodies.__setitem__(0, b2), "Scene.bodies[0]", "with_bodies("),
        ("scene.bodies = (...)", lambda: setattr(scene, "bodies", (b2, b1)), "Scene.bodies", "with_bodies("),
        ("scene.gap = g", lambda: setattr(scene, "gap", 1e-3), "Scene.gap", "with_gap("),
        ("scene.contacts.append", lambda: scene.contacts.append(scene.contacts[0]), "Scene.contacts (a tuple)",
         "Scene"),
        ("scene.obstacles.pop", lambda: ind.obstacles.pop(), "Scene.obstacles (a tuple)", "with_obstacles("),
        ("scene.stack = s", lambda: setattr(scene, "stack", None), "Scene.stack", "Scene"),
        ("mesh.points = p", lambda: setattr(mesh, "points", 2 * mesh.points), "Mesh.points", "with_points("),
        ("mesh.areas = a (a cached property)", lambda: setattr(mesh, "areas", 0 * mesh.areas), "Mesh.areas",
         "with_points("),
        ("material.c = c", lambda: setattr(ALU, "c", 2 * ALU.c), "Elastic.c", "with_changes(material="),
        ("PZT5A.name = s", lambda: setattr(cc.materials.PZT5A, "name", "x"), "Piezoelectric.name", "rotated"),
    ]


@pytest.mark.parametrize("label,edit,what,variant", edits(), ids=[e[0] for e in edits()])
def test_every_edit_of_a_built_description_is_refused_naming_what_to_build(label, edit, what, variant):
    with pytest.raises(FrozenError) as info:
        edit()
    err = info.value
    assert isinstance(err, cc.SceneError) and isinstance(err, AttributeError)
    assert what in str(err) and variant in str(err), str(err)


def test_the_refusal_keeps_hasattr_and_getattr_meaningful():
    b1, _ = two_blocks().bodies
    assert not hasattr(b1.roller, "append") and not hasattr(b1.traction, "update")
    assert getattr(b1, "no_such_field", 7) == 7 and getattr(b1.roller, "append", None) is None
    assert b1.roller == () and b1.clamped == ("top",) and dict(b1.traction) == {"right": b1.traction["right"]}
    assert issubclass(FrozenError, cc.CvxContactError) and cc.FrozenError is FrozenError


def test_a_refused_roller_leaves_a_body_that_solves():
    """The issue's ``body.roller.append("left")`` gave a KeyError at solve: the append itself is refused
    and the scene is unchanged."""
    scene = two_blocks()
    before = cc.solve(scene)
    with pytest.raises(FrozenError, match=r"Body\.roller"):
        scene.bodies[0].roller.append("left")
    after = cc.solve(scene)
    assert before.ok and after.ok and np.array_equal(before.u[0], after.u[0])


def test_arrays_of_descriptions_are_read_only():
    scene = two_blocks()
    b1 = scene.bodies[0]
    ind = indenter(force=(0.0, -1e6))
    arrays = {"mesh.points": b1.mesh.points, "mesh.triangles": b1.mesh.triangles,
              "mesh.boundary": b1.mesh.boundary("bottom"), "mesh.areas": b1.mesh.areas,
              "body_force": b1.body_force.value, "traction": b1.traction["right"].value,
              "material.c": b1.material.c, "material.e": b1.material.e,
              "material.out_of_plane": b1.material.out_of_plane[0],
              "rigid.force": ind.contacts[0].other.force, "rigid.position": ind.contacts[0].other.position,
              "interface.x": scene.interface.x, "obstacle basis": ind.obstacles[0].basis}
    for name, a in arrays.items():
        assert isinstance(a, np.ndarray) and not a.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            a[...] = 0


def test_a_frozen_body_copies_and_pickles_as_itself():
    b1, _ = two_blocks().bodies
    for twin in (copy.deepcopy(b1), pickle.loads(pickle.dumps(b1))):
        assert geometry_fingerprint(twin) == geometry_fingerprint(b1) and twin.roller == b1.roller
        with pytest.raises(FrozenError):
            twin.mesh = b1.mesh



@pytest.mark.parametrize("make", [lambda: cc.rectangle(x=(0, 1), y=(0, 1), nx=2, ny=2),
                                  lambda: cc.rectangle(x=(0, 1), y=(0, 1), nx=2, ny=2, cell="quad"),
                                  lambda: cc.box(x=(0, 1), y=(0, 1), z=(0, 1), nx=1, ny=1, nz=1)])
def test_a_mesh_stays_read_only_when_asked_to_be_writeable_and_when_unpickled(make):
    """A mesh's arrays cannot be made writeable again (``setflags(write=True)``; they owned their data, so it was
    allowed, and a triangle mesh stretched in place after one solve gave another scene's answer off by 0.50
    relative in u: the nodal shares of its body force, computed once, were the old mesh's), nor come back writeable
    from pickle or deepcopy."""
    mesh = make()
    for twin in (mesh, pickle.loads(pickle.dumps(mesh)), copy.deepcopy(mesh)):
        for a in (twin.points, twin.cells, *(twin.boundary(t) for t in twin.tags)):
            assert not a.flags.writeable
            _cannot_be_made_writeable(a)
        assert np.array_equal(twin.points, mesh.points) and twin.tags == mesh.tags
    once = [getattr(mesh, name) for name in ("areas", "vertex_areas", "volumes") if hasattr(type(mesh), name)]
    for a in (*once, *mesh.bounds):                                                       # computed once
        _cannot_be_made_writeable(a)


@pytest.mark.parametrize("make", [lambda: cc.rectangle(x=(0, 1), y=(0, 1), nx=3, ny=2),
                                  lambda: cc.rectangle(x=(0, 1), y=(0, 1), nx=3, ny=2, cell="quad"),
                                  lambda: cc.box(x=(0, 1), y=(0, 1), z=(0, 1), nx=2, ny=1, nz=1)])
def test_the_cells_a_mesh_keeps_at_a_part_stay_read_only_when_unpickled(make):
    """CellMesh.cells_at keeps its answer on the mesh (a dict in its instance dict); a pickled or deep-copied
    mesh brings it along read-only for good as its other arrays (it came back writeable: an edit of it would
    change every later search for the owners of that part's facets), and equal to the twin's own."""
    mesh = make()
    kept = mesh.cells_at("top")
    for twin in (pickle.loads(pickle.dumps(mesh)), copy.deepcopy(mesh)):
        again = twin.cells_at("top")
        assert np.array_equal(again, kept) and not again.flags.writeable
        _cannot_be_made_writeable(again)
        fresh = make().cells_at("top")                                     # formed by the twin's own mesh
        assert np.array_equal(again, fresh)


def _cannot_be_made_writeable(a):
    """Neither ``a`` nor the array it views (its ``base``) can be made writeable again."""
    for x in (a, a.base):
        if isinstance(x, np.ndarray):
            with pytest.raises(ValueError):
                x.setflags(write=True)



def test_a_load_cannot_be_made_writeable_behind_a_prepared_solver():
    """A load's values cannot be made writeable again: edited in place (``setflags(write=True)`` was allowed, the
    array owned its data), a prepared solver's ``solve()`` of the same Scene answered the old loads (measured: u
    unchanged, 0.0, after the body force was tripled) while ``cc.solve`` answered the new ones."""
    body = two_blocks().bodies[0]
    for twin in (body, pickle.loads(pickle.dumps(body)), copy.deepcopy(body)):      # (pickle: writeable before)
        for a in (twin.body_force.value, twin.traction["right"].value, twin.material.c, twin.mesh.points):
            assert not a.flags.writeable
            _cannot_be_made_writeable(a)


# ------------------------------------------------------------------ the variants

def test_body_with_loads_keeps_the_geometry_and_a_prepared_solver_resolves_it():
    scene = two_blocks()
    solver = cc.ContactSolver(scene)
    solver.solve()
    new = scene.with_loads(0, body_force=(3e8, -2e9), traction={"right": (0.0, 1e8)})
    b = new.bodies[0]
    assert geometry_fingerprint(b) == geometry_fingerprint(scene.bodies[0]) and solver.accepts(new)
    assert new.bodies[1] is scene.bodies[1] and new.contacts[0].body_a is b and b.name == "piezo"
    assert np.array_equal(b.body_force.value, [3e8, -2e9]) and scene.bodies[0].body_force.value[0] == 0.0
    fresh = cc.Scene(cc.Body(scene.bodies[0].mesh, cc.materials.PZT5A, clamped="top", grounded="top",
                             contact="bottom", body_force=(3e8, -2e9), traction={"right": (0.0, 1e8)}),
                     scene.bodies[1])
    resolved, direct = solver.solve(new), cc.solve(fresh)
    assert resolved.ok and direct.ok and direct.contact.active.any() and not direct.contact.active.all()
    assert rel(resolved.u[0], direct.u[0]) < 1e-10 and rel(resolved.contact.lam, direct.contact.lam) < 1e-10  # 0, 0


def test_solve_without_a_scene_solves_the_scene_given_at_construction():
    """``ContactSolver.solve()`` solves the scene the solver was built with, also after ``solve(other)``
    (it solved the last scene instead, with ok=True: u off by 35 % on this indenter pushed 1 mm deeper and
    back); ``solver.scene`` is the scene of the last solve. Measured 0 against fresh solves."""
    a = indenter(center=(0.47, 1.1 - 3e-3))
    b = a.with_obstacles(a.obstacles[0].obstacle.moved(by=(0.0, -1e-3)))
    solver = cc.ContactSolver(a)
    first, other, again = solver.solve(), solver.solve(b), solver.solve()
    fresh_a, fresh_b = cc.solve(a), cc.solve(b)
    assert rel(first.u[0], fresh_a.u[0]) < 1e-12 and rel(other.u[0], fresh_b.u[0]) < 1e-12
    assert rel(again.u[0], fresh_a.u[0]) < 1e-12 and rel(fresh_b.u[0], fresh_a.u[0]) > 0.1
    assert solver.scene is a


def test_with_loads_refuses_geometry_and_other_electrodes():
    b1 = two_blocks().bodies[0]
    with pytest.raises(cc.SceneError, match=r"with_loads takes the loads .*\['mesh'\].*with_changes"):
        b1.with_loads(mesh=b1.mesh)
    electrode = b1.with_changes(grounded=(), potential={"top": 0.0})
    assert electrode.with_loads(potential={"top": 100.0}).potential["top"].value == 100.0
    with pytest.raises(cc.SceneError, match=r"driven electrodes \['top'\].*with_changes\(potential="):
        electrode.with_loads(potential={"top": 1.0, "left": 2.0})
    with pytest.raises(cc.SceneError, match=r"unknown field\(s\) \['colour'\]"):
        b1.with_changes(colour="red")
    finer = b1.with_changes(mesh=cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=10, ny=4))
    assert geometry_fingerprint(finer) != geometry_fingerprint(b1) and finer.clamped == b1.clamped


def test_with_gap_equals_a_scene_built_with_that_gap():
    g = lambda s: -1e-5 * (1.0 - (s - 0.5) ** 2)                     # noqa: E731  an interference, m
    scene = two_blocks()
    new = scene.with_gap(g)
    assert new.bodies == scene.bodies and np.array_equal(new.gap_values(), two_blocks(gap=g).gap_values())
    assert cc.ContactSolver(scene).accepts(new)
    a, b = cc.solve(new), cc.solve(cc.Scene(*scene.bodies, gap=g))
    assert a.ok and np.array_equal(a.u[0], b.u[0])                     # the same scene: the same numbers
    pairs = indenter()
    moved = pairs.with_gap(2e-4)
    assert np.allclose(moved.gap_values() - pairs.gap_values(), 2e-4, rtol=0, atol=1e-15)
    two = cc.Scene(*pairs.bodies, contacts=[pairs.contacts[0], cc.Contact(pairs.bodies[0], "left",
                                                                         cc.Rigid.plane((-1e-3, 0), (1, 0)))])
    with pytest.raises(cc.SceneError, match=r"name the pair .*pair = 0\.\.1"):
        two.with_gap(1e-3)
    assert two.with_gap(1e-3, pair=1).contacts[0] is two.contacts[0]


def test_with_bodies_rebuilds_the_pairs_on_the_new_bodies():
    scene = indenter()
    block = scene.bodies[0].with_loads(body_force=(0.0, -1e5))
    new = scene.with_bodies(block)
    assert new.contacts[0].body_a is block and new.contacts[0].other is scene.contacts[0].other
    with pytest.raises(cc.SceneError, match=r"one body per body of the scene \(1"):
        scene.with_bodies(block, block)
    pair = scene.contacts[0].with_changes(gap=1e-4, condition="sigma1")
    assert pair.gap.value == 1e-4 and pair.condition == "sigma1" and pair.other is scene.contacts[0].other
    assert scene.contacts[0].gap.value == 0.0 and scene.contacts[0].condition is None
    with pytest.raises(cc.SceneError, match=r"unknown field\(s\) \['stiffness'\]"):
        scene.contacts[0].with_changes(stiffness=1.0)


def rigid_points():
    x = np.column_stack([np.linspace(0.1, 0.9, 9), np.full(9, 0.5)])
    return x, np.array([0.0, 1.0])


@pytest.mark.parametrize("make", [lambda: cc.Rigid.plane((0.2, 0.6), (0.3, -1.0)),
                                  lambda: cc.Rigid.circle((0.47, 1.1), 0.6),
                                  lambda: cc.Rigid.profile(lambda s: 1e-3 + 0.2 * (s - 0.5) ** 2, (0.1, 0.0)),
                                  lambda: cc.Rigid("custom", cc.Rigid.circle((0.47, 1.1), 0.6).distance, "custom()")],
                         ids=["plane", "circle", "profile", "custom"])
def test_moved_obstacle_distance_shortens_by_the_sensitivity(make):
    """Moving an obstacle by t shortens each distance by c(x) . t to first order (§12, the definition of
    the sensitivity): central differences of moved(by=+-h e_k), to O(h^2)."""
    rigid = make()
    x, nu = rigid_points()
    c = rigid.sensitivity(x, nu)
    h = 1e-6
    for k in range(2):
        step = np.zeros(2)
        step[k] = h
        fd = -(rigid.moved(by=step).distance(x, nu) - rigid.moved(by=-step).distance(x, nu)) / (2 * h)
        assert np.abs(fd - c[:, k]).max() < 1e-8                      # measured <= 5.7e-10 (custom), 8.2e-11 circle
    there = rigid.moved(to=rigid.position + (0.05, -0.02))
    assert np.array_equal(there.position, rigid.position + (0.05, -0.02))
    assert np.allclose(there.distance(x, nu), rigid.moved(by=(0.05, -0.02)).distance(x, nu), rtol=0, atol=1e-15)


def test_moved_plane_and_circle_equal_those_built_there_and_a_profile_follows_its_definition():
    x, nu = rigid_points()
    d = np.array([0.07, -0.03])
    pairs = [(cc.Rigid.circle((0.47, 1.1), 0.6).moved(by=d), cc.Rigid.circle((0.54, 1.07), 0.6)),
             (cc.Rigid.plane((0.2, 0.6), (0.3, -1.0)).moved(to=(0.27, 0.57)), cc.Rigid.plane((0.27, 0.57), (0.3, -1.0)))]
    for moved, built in pairs:
        assert repr(moved) == repr(built)
        assert np.allclose(moved.distance(x, nu), built.distance(x, nu), rtol=0, atol=1e-15)
    f = lambda s: 1e-3 + 0.2 * (s - 0.5) ** 2                           # noqa: E731
    s = (x - np.array([0.1, 0.0]) - d) @ np.array([1.0, 0.0])           # the tangent of a line with nu = +y
    ray = cc.Rigid.profile(f, (0.1, 0.0), distance="ray").moved(by=d)  # the definition: f(s) along nu, lifted
    assert np.allclose(ray.distance(x, nu), f(s) + d @ nu, rtol=0, atol=1e-15)
    prof = cc.Rigid.profile(f, (0.1, 0.0)).moved(by=d)                 # closest point: to that curve, sampled
    curve = np.linspace(-1.0, 2.0, 30001)
    near = []
    for si in s:                                  # the sampled nearest point, refined by a bounded 1D search
        r = lambda c: np.hypot(c - si, f(c) + d @ nu)                   # noqa: E731
        c0 = curve[np.argmin(r(curve))]
        near.append(minimize_scalar(r, bounds=(c0 - 1e-4, c0 + 1e-4), method="bounded",
                                    options={"xatol": 1e-12}).fun)
    assert np.allclose(prof.distance(x, nu), np.sign(f(s) + d @ nu) * np.array(near), rtol=0, atol=1e-12)  # 2.9e-16
    assert "moved(to=(0.17, -0.03))" in repr(prof)
    with pytest.raises(cc.SceneError, match="exactly one of by="):
        prof.moved(by=d, to=d)


def test_scene_with_a_moved_circle_equals_the_scene_built_with_it_there():
    scene = indenter()
    moved = scene.with_obstacles(scene.obstacles[0].obstacle.moved(to=(0.58, 1.09)))
    a, b = cc.solve(moved), cc.solve(indenter(center=(0.58, 1.09)))
    assert a.ok and b.ok and a.contact.active.sum() >= 2
    assert rel(a.u[0], b.u[0]) < 1e-12 and rel(a.contact.lam, b.contact.lam) < 1e-12   # measured 0, 0 (same data)
    with pytest.raises(cc.SceneError, match=r"one obstacle per rigid obstacle of the scene \(1"):
        scene.with_obstacles()


def test_with_force_meets_the_uniaxial_closed_form():
    """A block H x W clamped at its bottom, rollers on its sides, a force-controlled plane on its top:
    the plane moves by t = -p H / M, M = E (1-nu)/((1+nu)(1-2nu)) (P1 exact); the force changed with
    with_force + with_obstacles, and a displacement-controlled plane moved down by the same t."""
    E, nu, H, W = 70e9, 0.33, 0.5, 1.0
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    block = cc.Body(cc.rectangle(x=(0.0, W), y=(0.0, H), nx=4, ny=3), ALU, clamped="bottom", roller=["left", "right"],
                    name="block")
    plane = cc.Rigid.plane((0.0, H), (0.0, -1.0), force=(0.0, -1e7))
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", plane)])
    p = 3e7
    pressed = scene.with_obstacles(plane.with_force((0.0, -p * W)))
    sol = cc.solve(pressed)
    t = -p * H / M
    assert sol.ok and abs(sol.obstacles[0].translation[1] - t) < 1e-9 * abs(t)     # measured 0 relative
    fixed = cc.solve(scene.with_obstacles(plane.with_force(None).moved(by=(0.0, t))))
    assert fixed.ok and abs(fixed.contact.force.sum() - p * W) < 1e-9 * p * W     # measured 1.1e-13 relative
    assert rel(fixed.u[0], sol.u[0]) < 1e-9                                         # measured 1.1e-13
    assert repr(plane.with_force(None)) == "Rigid.plane(point=(0, 0.5), normal=(0, -1))"


# ------------------------------------------------------------------ Body(contact=) is optional with contacts=

def test_contact_tag_is_optional_with_contacts_and_changes_nothing_there():
    scene = indenter()
    assert scene.bodies[0].contact is None
    tagged = scene.with_bodies(scene.bodies[0].with_changes(contact="top"))
    a, b = cc.solve(scene), cc.solve(tagged)
    assert a.ok and np.array_equal(a.u[0], b.u[0])


def test_the_two_body_form_still_needs_contact():
    b1, b2 = two_blocks().bodies
    with pytest.raises(cc.SceneError, match=r"base: Scene\(body1, body2\) pairs the bodies' contact= parts"):
        cc.Scene(b1, b2.with_changes(contact=None))


def test_a_body_held_by_nothing_without_contact_is_a_typed_error():
    """Without contact= the Body cannot know which parts its pairs use: the Scene decides. A motion that no
    support holds and that is tangential to every pair part of the body is refused there; a pair on a part
    whose normal holds it is accepted (and the loads are judged on the assembled problem, fem/kernel.py)."""
    body = cc.Body(cc.rectangle(nx=2, ny=2), ALU, roller="bottom")
    assert body.held_by_contact == ("translation x",)
    with pytest.raises(cc.SceneError, match=r"nothing holds the rigid motion\(s\) \['translation x'\]"):
        cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.plane((0.0, 1.0), (0.0, -1.0)))])
    cc.Scene(body, contacts=[cc.Contact(body, "left", cc.Rigid.plane((0.0, 0.0), (1.0, 0.0)))])


# ------------------------------------------------------------------ typed errors of bad descriptions

@pytest.mark.parametrize("make", [lambda: cc.rectangle(segments="top"),
                                  lambda: cc.graded_block((0.0, 1.0), (0.0, 1.0), 4, 4, segments=["top", 0.25, 0.75])])
def test_segments_given_as_a_side_is_a_typed_error(make):
    with pytest.raises(cc.MeshError, match=r"segments must map new tag names.*\"footprint\": \(\"top\", 0.25, 0.75\)"):
        make()


BASE = """
[[body]]
name = "block"
material = { E = 70e9, nu = 0.3 }
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 4, ny = 2 } }
clamped = "top"
body_force = [0.0, -1e9]

[[obstacle]]
name = "floor"
plane = { point = [0.0, 0.0], normal = [0.0, 1.0] }

[[contact]]
a = "block"
part_a = "bottom"
b = "floor"
"""


@pytest.mark.parametrize("old,new,key,expected", [
    ('b = "floor"', 'b = ["floor"]', "contact[0].b", "a string"),
    ('b = "floor"', 'b = { name = "floor" }', "contact[0].b", "a string"),
    ('a = "block"', 'a = ["block"]', "contact[0].a", "a string"),
    ('part_a = "bottom"', 'part_a = ["bottom"]', "contact[0].part_a", "a string"),
    ('b = "floor"', 'b = "floor"\npart_b = ["top"]', "contact[0].part_b", "a string"),
    ('b = "floor"', 'b = "floor"\ncondition = ["gamma3"]', "contact[0].condition", "a string"),
    ('b = "floor"', 'b = "floor"\ngap = { value = 1 }', "contact[0].gap", "a number or an expression"),
    ('name = "floor"', 'name = ["floor"]', "obstacle[0].name", "a string"),
    ('name = "block"', 'name = ["block"]', "body[0].name", "a string"),
    ('clamped = "top"', 'clamped = "top"\ncontact = ["bottom"]', "body[0].contact", "a string"),
    ('clamped = "top"', 'clamped = { tag = "top" }', "body[0].clamped", "a tag or a list of tags"),
    ("nu = 0.3 }", 'nu = 0.3, name = ["alu"] }', "body[0].material.name", "a string"),
    ("E = 70e9", "E = { value = 70e9 }", "body[0].material", "must be a finite number"),
    ("ny = 2 }", 'ny = 2, segments = "top" }', "body[0].mesh", "segments must map new tag names"),
    ("normal = [0.0, 1.0] }", "normal = [0.0, 1.0] }\nforce = { y = 1e6 }", "obstacle[0]", "two real numbers"),
    ("plane = { point = [0.0, 0.0], normal = [0.0, 1.0] }", 'profile = { f = ["1e-3"] }', "obstacle[0].profile.f",
     "a number or an expression"),
    ('b = "floor"', 'b = "floor"\nlaw = { normal_compliance = { stiffness = { k = 1 } } }',
     "contact[0]: law.normal_compliance", "must be a real number"),
])
def test_scene_file_keys_of_the_wrong_type_are_typed_errors_from_the_cli(tmp_path, capsys, old, new, key, expected):
    assert old in BASE
    path = tmp_path / "bad.toml"
    path.write_text(BASE.replace(old, new, 1))
    with pytest.raises(SceneFileError) as info:
        load_scene(path)
    assert str(info.value).count(str(path)) == 1, str(info.value)                  # named once, no nesting
    assert key in str(info.value) and expected in str(info.value), str(info.value)
    assert main(["solve", str(path), "--out", str(tmp_path / "out"), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("cvxcontact: error: ") and key in err and "Traceback" not in err


def test_the_base_scene_file_solves(tmp_path):
    path = tmp_path / "good.toml"
    path.write_text(BASE)
    spec = load_scene(path)
    assert spec.scene.bodies[0].contact == "bottom"            # the first part of its pair (scene-file rule)
    assert spec.solve().ok


def test_rigid_obstacles_and_supports_stay_read_only_for_good():
    """An obstacle's position, force, guided axes, plane normal and cylinder axis, and a body's node supports, are
    read-only for good (errors.locked): ``setflags(write=True)`` raises instead of making them writeable again (they
    owned their data and could be unlocked: a description edited in place after a solve read it)."""
    import numpy as np

    arrays = [cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)).position, cc.Rigid.plane((0.0, 0.0), (0.0, 2.0)).position]
    plane3 = cc.Rigid.plane((0.0, 0.0, 0.0), (0.0, 0.0, 3.0), force=(0.0, 0.0, -1.0), guided=(0.0, 0.0, 1.0))
    arrays += [plane3.position, plane3.force, plane3.guided, cc.Rigid.sphere((0.0, 0.0, 1.0), 0.5).position]
    for a in arrays:
        assert isinstance(a, np.ndarray) and not a.flags.writeable
        with pytest.raises(ValueError):
            a.setflags(write=True)
