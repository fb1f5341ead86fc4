"""Contact pairs (issue 10 items 1-4): any number of bodies, any straight orientation, partial
overlap, rigid obstacles; each checked against something independent of the package's contact
operators (a rotated scene, a dense active-set solve of (26) built here with numpy, a limit case,
closed-form obstacle distances)."""

import numpy as np
import pytest

import cvxcontact as cc

from conftest import rel, two_blocks
from pair_scenes import ALU, STEEL, block_on, elastic_punch
from reference_problems import active_set_solve, merged_rows, per_body, stiffness


def rotation(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def rotated_mesh(m, R):
    return cc.Mesh(m.points @ R.T, m.triangles, {t: m.boundary(t) for t in m.tags})


def rotated_two_blocks(theta):
    """The elastic two-block scene of conftest (isotropic materials: invariant under rotation) turned by
    theta about the origin, with its loads turned too."""
    base = two_blocks(n1=(7, 3), n2=(5, 3), mat1=STEEL, mat2=ALU)
    R = rotation(theta)
    b1, b2 = base.bodies
    r1 = cc.Body(rotated_mesh(b1.mesh, R), STEEL, clamped=["top"], contact="bottom",
                 body_force=R @ np.array([0.0, -2e9]), traction={"right": R @ np.array([0.0, 3e8])})
    r2 = cc.Body(rotated_mesh(b2.mesh, R), ALU, clamped=["bottom"], contact="top")
    return base, cc.Scene(r1, r2)


@pytest.mark.parametrize("degrees", [30.0, 90.0, -135.0])
def test_rotated_two_block_scene_gives_the_rotated_solution(degrees):
    base, turned = rotated_two_blocks(np.radians(degrees))
    R = rotation(np.radians(degrees))
    ref, sol = cc.solve(base), cc.solve(turned)
    assert ref.ok and sol.ok
    for k in range(2):
        assert rel(sol.u[k], ref.u[k] @ R.T) < 1e-9
    # the contact line: same nodes (turned), same pressures, whatever the order along the tangent
    c0, c1 = ref.contact, sol.contact
    back = c1.points @ R                                     # turned back to the reference frame
    order = np.argsort(back[:, 0])
    assert np.abs(back[order] - np.column_stack([c0.x, np.full(len(c0.x), c0.line)])).max() < 1e-12
    assert rel(c1.lam[order], c0.lam) < 1e-9 and rel(c1.force[order], c0.force) < 1e-9
    assert np.array_equal(c1.active[order], c0.active) and c0.active.any() and not c0.active.all()
    assert abs(sol.energy - ref.energy) <= 1e-9 * abs(ref.energy)
    assert np.allclose(c1.normal, R @ np.array([0.0, -1.0]), atol=1e-12)


# ---- an independent dense solve of (26) on the overlap: test-built contact rows, active-set steps ------

def dense_reference(bodies, pairs, condition, gaps):
    """Elastic bodies only. pairs: (ka, part_a, kb, part_b); gaps[i](s) the gap of pair i (m).
    Returns per-body SI displacements and per-pair (merged abscissae, nodal forces E^T y in N/m)."""
    systems, off, K, f = stiffness(bodies)
    G, g, where = [], [], []
    for i, (ka, pa, kb, pb) in enumerate(pairs):
        xs, rows, inside = merged_rows(bodies, systems, off, ka, pa, kb, pb)
        keep = {"gamma3": np.ones(len(xs), bool),
                "sigma1": np.isin(xs, np.round(inside[0], 12)),
                "sigma2": np.isin(xs, np.round(inside[1], 12))}[condition]
        G.append(rows[keep])
        g.append(gaps[i](xs)[keep])
        where.append((xs, np.flatnonzero(keep)))
    u, y = active_set_solve(K, f, np.vstack(G), np.concatenate(g))
    forces, pos = [], 0
    for xs, keep in where:
        fr = np.zeros(len(xs))
        fr[keep] = y[pos:pos + len(keep)]
        pos += len(keep)
        forces.append((xs, fr))
    return per_body(systems, bodies, off, u), forces


@pytest.mark.parametrize("condition", ["gamma3", "sigma1", "sigma2"])
def test_partial_overlap_against_a_dense_solve_of_the_mixed_system(condition):
    scene, gap = elastic_punch()
    us, forces = dense_reference(scene.bodies, [(0, "bottom", 1, "top")], condition, [gap])
    xs, fr = forces[0]
    for method in ("full", "condensed"):
        sol = cc.solve(scene, condition=condition, method=method)
        assert sol.ok, sol.report()
        c = sol.contact
        assert c.x[0] == pytest.approx(0.3, abs=1e-15) and c.x[-1] == pytest.approx(0.7, abs=1e-15)
        assert np.abs(c.x - xs).max() < 1e-12                       # the merged mesh of the overlap
        for k in range(2):
            assert rel(sol.u[k], us[k]) < 1e-8
        assert rel(c.force, fr) < 1e-8
        assert c.active.any()                                       # a real contact zone ...
        assert condition == "sigma2" or not c.active[c.constrained].all()    # ... with open edges (3 nodes in sigma2)
    # the per-pair condition overrides the solve's
    assert rel(cc.solve(elastic_punch(condition)[0], condition="gamma3").contact.force, fr) < 1e-8


def test_three_body_stack_against_a_dense_solve():
    top = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(0.3, 0.5), nx=4, ny=2), STEEL, clamped="top", contact="bottom",
                  body_force=(0.0, -5e9), name="top")
    mid = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.3), nx=6, ny=2), ALU, clamped="left", contact="top",
                  name="middle")
    bot = cc.Body(cc.rectangle(x=(0.1, 0.9), y=(-0.3, 0.0), nx=5, ny=2), STEEL, clamped="bottom", contact="top",
                  name="bottom")
    gaps = [lambda s: -1e-4 + 0 * s, lambda s: 2e-5 + 0 * s]
    scene = cc.Scene(top, mid, bot, contacts=[cc.Contact(top, "bottom", mid, "top", gap=gaps[0]),
                                              cc.Contact(mid, "bottom", bot, "top", gap=gaps[1])])
    us, forces = dense_reference(scene.bodies, [(0, "bottom", 1, "top"), (1, "bottom", 2, "top")], "gamma3", gaps)
    for method in ("full", "condensed"):
        sol = cc.solve(scene, method=method)
        assert sol.ok, sol.report()
        assert len(sol.contacts) == 2 and sol.contact is sol.contacts[0]
        for k in range(3):
            assert rel(sol.u[k], us[k]) < 1e-8
        for c, (xs, fr) in zip(sol.contacts, forces):
            assert np.abs(c.x - xs).max() < 1e-12 and rel(c.force, fr) < 1e-8
            assert c.active.any()


def test_model_takes_pairs():
    scene, gap = elastic_punch()
    model = cc.Model(scene)
    sol = model.solve()
    ref = cc.solve(scene, method="full")
    assert sol.ok and rel(sol.contact.force, ref.contact.force) < 1e-9
    assert model.jump().shape == (scene.stack.size,)


# ---- rigid obstacles --------------------------------------------------------------------------------


def test_rigid_plane_is_the_limit_of_a_stiff_clamped_foundation():
    rigid = cc.solve(block_on(cc.Rigid.plane((0.0, 0.0), (0.0, 1.0))))
    assert rigid.ok and rigid.contact.active.any()
    assert np.allclose(rigid.contact.gap, -1e-4, rtol=0, atol=1e-18)       # the plane passes through the part
    errs = []
    for E in (70e12, 70e14):
        stiff = cc.solve(block_on(None, E_found=E))
        assert stiff.ok
        errs.append(rel(stiff.u[0], rigid.u[0]))
    # the foundation's compliance goes like 1/E: 100 times stiffer, about 100 times closer
    assert errs[1] < 1e-4 and 30 < errs[0] / errs[1] < 300


def test_rigid_plane_turned_and_distance_along_the_normal():
    R = rotation(np.radians(30.0))
    block = cc.Body(rotated_mesh(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=6, ny=3), R), ALU, clamped="top",
                    contact="bottom", body_force=R @ np.array([0.0, -3e9]), name="block")
    plane = cc.Rigid.plane(R @ np.array([0.0, -2e-5]), R @ np.array([0.0, 1.0]))
    sol = cc.solve(cc.Scene(block, contacts=[cc.Contact(block, "bottom", plane)]))
    flat = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=6, ny=3), ALU, clamped="top", contact="bottom",
                   body_force=(0.0, -3e9), name="block")
    ref = cc.solve(cc.Scene(flat, contacts=[cc.Contact(flat, "bottom", cc.Rigid.plane((0.0, -2e-5), (0.0, 1.0)))]))
    assert sol.ok and ref.ok and rel(sol.u[0], ref.u[0] @ R.T) < 1e-9
    assert np.allclose(ref.contact.gap, 2e-5, rtol=1e-12, atol=0)
    # a plane met at 60 degrees: the distance along the part's normal is the offset / cos(60)
    tilted = cc.Rigid.plane((0.0, -2e-5), (np.sin(np.radians(60)), np.cos(np.radians(60))))
    sc = cc.Scene(flat, contacts=[cc.Contact(flat, "bottom", tilted)])
    x = sc.interface.x
    # (x - p) . n / (-nu . n) with nu = (0, -1): (x sin 60 + 2e-5 cos 60) / cos 60
    assert np.allclose(sc.gap_values(), 2e-5 + x * np.tan(np.radians(60)), rtol=1e-12, atol=0)


def test_rigid_circle_and_profile():
    R = 0.3
    ray = block_on(cc.Rigid.circle((0.5, -R - 1e-4), R, distance="ray"))
    x = ray.interface.x
    assert x.min() > 0.5 - R and x.max() < 0.5 + R and len(x) >= 2      # only nodes that reach the disc
    exact = 1e-4 + R - np.sqrt(R ** 2 - (x - 0.5) ** 2) - 1e-4           # the Contact's gap -1e-4 added
    assert np.abs(ray.gap_values() - exact).max() < 1e-15
    # the default: the distance to the closest point, at every node of the part
    scene = block_on(cc.Rigid.circle((0.5, -R - 1e-4), R))
    x = scene.interface.x
    assert len(x) == len(scene.interface.traces[0].x)
    exact = np.hypot(x - 0.5, R + 1e-4) - R - 1e-4
    assert np.abs(scene.gap_values() - exact).max() < 1e-15
    sol = cc.solve(scene)
    assert sol.ok and sol.contact.active.any()
    f = lambda s: np.where(np.abs(s - 0.5) < R,                                           # noqa: E731
                           1e-4 + R - np.sqrt(np.maximum(R ** 2 - (s - 0.5) ** 2, 0)), np.inf)
    prof = cc.solve(block_on(cc.Rigid.profile(f)))
    # the profile is the disc's arc where it is finite (its foot points are the disc's closest points there); the
    # circle's other nodes are inactive
    assert prof.ok and rel(prof.u[0], sol.u[0]) < 1e-9
    assert abs(prof.contact.force.sum() / sol.contact.force.sum() - 1) < 1e-9


# ---- legacy meaning and typed errors --------------------------------------------------------------------

def test_two_body_scene_equals_its_contact_pair():
    legacy = two_blocks(n1=(6, 3), n2=(5, 3))
    b1, b2 = legacy.bodies
    pair = cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top")])
    a, b = cc.solve(legacy), cc.solve(pair)
    assert rel(a.u[0], b.u[0]) == 0.0 and rel(a.contact.lam, b.contact.lam) == 0.0
    # with the bodies given the other way round, sigma1 of the pair is the lower body
    swapped = cc.Scene(b2, b1, contacts=[cc.Contact(b2, "top", b1, "bottom", condition="sigma2")])
    s1 = cc.solve(legacy, condition="sigma1")
    assert rel(cc.solve(swapped).u[1], s1.u[0]) < 1e-9


def _block(x=(0.0, 1.0), y=(0.0, 0.5), **kw):
    args = dict(clamped="top", contact="bottom")
    args.update(kw)
    return cc.Body(cc.rectangle(x=x, y=y, nx=3, ny=2), ALU, **args)


@pytest.mark.parametrize("make,error,match", [
    (lambda: (lambda b: cc.Contact(b, "bottom", b, "top"))(_block()), cc.SceneError, "paired with itself"),
    (lambda: cc.Contact(_block(), "bottom", _block(y=(-0.5, 0), clamped="bottom", contact="top"), "top",
                        law="compliance"), cc.SceneError, "law must be"),
    (lambda: cc.Rigid.plane((0, 0), (0, 1), force=(0.0, 0.0)), cc.SceneError, "zero force"),
    (lambda: cc.Rigid.circle((0, 0), -1.0), cc.SceneError, "radius"),
    (lambda: cc.Contact(_block(), "roof", cc.Rigid.plane((0, 0), (0, 1))), cc.SceneError, "unknown boundary tag"),
    (lambda: cc.Contact(_block(), "bottom", cc.Rigid.plane((0, 0), (0, 1)), "top"), cc.SceneError,
     "no boundary parts"),
    (lambda: cc.Contact(_block(), "bottom", cc.Rigid.plane((0, 0), (0, 1)), condition="sigma3"), cc.SceneError,
     "condition"),
    (lambda: (lambda b: cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0, 0), (0, -1)))]))(_block()),
     cc.SceneError, "does not face"),
    (lambda: (lambda a, b: cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top")]))(
        _block(), _block(x=(1.5, 2.5), y=(-0.5, 0), clamped="bottom", contact="top")), cc.SceneError,
     "do not overlap"),
    (lambda: (lambda a, b: cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top")]))(
        _block(), _block(y=(-0.5, -0.1), clamped="bottom", contact="top")), cc.SceneError, "not collinear"),
    (lambda: (lambda a, b: cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "left")]))(
        _block(), _block(x=(1.0, 2.0), clamped="right", contact="left")), cc.SceneError, "do not face each other"),
    (lambda: (lambda a, b: cc.Scene(a, contacts=[cc.Contact(a, "bottom", b, "top")]))(
        _block(), _block(y=(-0.5, 0), clamped="bottom", contact="top")), cc.SceneError,
     "not one of the scene's bodies"),
    (lambda: (lambda a, b, c: cc.Scene(a, b, c, contacts=[cc.Contact(a, "bottom", b, "top")]))(
        _block(), _block(y=(-0.5, 0), clamped="bottom", contact="top"), _block(x=(3, 4))), cc.SceneError,
     "no contact pair"),
    (lambda: (lambda a, b: cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top")], gap=1e-3))(
        _block(), _block(y=(-0.5, 0), clamped="bottom", contact="top")), cc.SceneError, "its own gap"),
    (lambda: cc.Scene(_block()), cc.SceneError, "exactly two bodies"),
    (lambda: (lambda a: cc.Scene(a, contacts=[cc.Contact(a, "bottom", cc.Rigid.circle((5.0, 5.0), 0.1))]))(_block()),
     cc.SceneError, "cannot be reached"),
    (lambda: (lambda a: cc.Scene(a, contacts=[cc.Contact(a, "bottom", cc.Rigid.profile(lambda s: np.nan * s))]))(
        _block()), cc.SceneError, "NaN"),
])
def test_misuse_is_a_typed_error(make, error, match):
    with pytest.raises(error, match=match):
        make()


def test_non_straight_part_in_a_pair_names_the_pair():
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2)
    bent = cc.Mesh(m.points + np.column_stack([0 * m.points[:, 0], 0.1 * np.abs(m.points[:, 0] - 0.5)]),
                   m.triangles, {t: m.boundary(t) for t in m.tags})
    a = cc.Body(bent, ALU, clamped="top", contact="bottom")
    with pytest.raises(cc.SceneError, match=r"contacts\[0\].*not a straight segment"):
        cc.Scene(a, contacts=[cc.Contact(a, "bottom", cc.Rigid.plane((0, -1), (0, 1)))])


# ---- scene files -----------------------------------------------------------------------------------------

PUNCH_FILE = """
condition = "gamma3"

[[body]]
name = "punch"
material = { E = 200e9, nu = 0.3 }
mesh = { rectangle = { x = [0.3, 0.7], y = [0.0, 0.2], nx = 5, ny = 2 } }
clamped = "top"
body_force = [0.0, -1e9]

[[body]]
name = "substrate"
material = { E = 70e9, nu = 0.33 }
mesh = { rectangle = { x = [0.0, 1.0], y = [-0.5, 0.0], nx = 8, ny = 4 } }
clamped = "bottom"

[[contact]]
a = "punch"
part_a = "bottom"
b = "substrate"
part_b = "top"
gap = "-2e-4 + 5e-3 * (x - 0.52)**2"
"""

RIGID_FILE = """
[[body]]
name = "block"
material = { E = 70e9, nu = 0.33 }
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.4], nx = 6, ny = 3 } }
clamped = "top"
body_force = [0.0, -3e9]
traction = { right = [2e8, 0.0] }

[[obstacle]]
name = "floor"
plane = { point = [0.0, 0.0], normal = [0.0, 1.0] }

[[contact]]
a = "block"
part_a = "bottom"
b = "floor"
gap = -1e-4
"""


def test_scene_files_with_contact_and_obstacle_tables(tmp_path):
    from cvxcontact.io.scenefile import load_scene

    (tmp_path / "punch.toml").write_text(PUNCH_FILE)
    (tmp_path / "rigid.toml").write_text(RIGID_FILE)
    punch = load_scene(tmp_path / "punch.toml").solve()
    api = cc.solve(elastic_punch()[0])
    assert rel(punch.u[0], api.u[0]) < 1e-12 and rel(punch.contact.force, api.contact.force) < 1e-12
    rigid = load_scene(tmp_path / "rigid.toml").solve()
    ref = cc.solve(block_on(cc.Rigid.plane((0.0, 0.0), (0.0, 1.0))))
    assert rel(rigid.u[0], ref.u[0]) < 1e-12


@pytest.mark.parametrize("edit,match", [
    (lambda t: t.replace('b = "substrate"', 'b = "base"'), r"contact\[0\]\.b: expected the name of a body"),
    (lambda t: t.replace('a = "punch"', 'a = "punch"\nlaw = "compliance"'), "law"),
    (lambda t: t.replace('condition = "gamma3"', 'condition = "gamma3"\ngap = 0.0'), "give each contact its own gap"),
    (lambda t: t.replace('part_b = "top"', 'part_b = "roof"'), "unknown boundary tag 'roof'"),
    (lambda t: t + '\n[[obstacle]]\nname = "wall"\nplane = { point = [0, 0], normal = [1, 0] }\n'
     'circle = { center = [0, 0], radius = 1.0 }\n', r"obstacle\[0\]: expected exactly one of plane, circle"),
    (lambda t: t + '\n[[obstacle]]\nname = "wall"\nplane = { point = [0, 0], normal = [0, 1] }\nforce = [0.0, 0.0]\n',
     r"obstacle\[0\]: .*zero force"),
    (lambda t: t.replace('gap = "-2e-4', 'gap = "__import__(1) -2e-4'), "not allowed"),
])
def test_scene_file_contact_errors(tmp_path, edit, match):
    from cvxcontact.io.scenefile import SceneFileError, load_scene

    (tmp_path / "s.toml").write_text(edit(PUNCH_FILE))
    with pytest.raises(SceneFileError, match=match):
        load_scene(tmp_path / "s.toml")


def test_contact_solver_resolves_a_moved_obstacle_and_refuses_other_pairs():
    def scene(depth, part="bottom"):
        block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=6, ny=3), ALU, clamped="top", contact="bottom",
                        body_force=(0.0, -3e9), name="block")
        return cc.Scene(block, contacts=[cc.Contact(block, part, cc.Rigid.plane((0.0, -depth), (0.0, 1.0)))])

    solver = cc.ContactSolver(scene(1e-5))
    first = solver.solve()
    again = solver.solve(scene(-1e-4))                       # the obstacle moved: a gap, i.e. a load
    fresh = cc.solve(scene(-1e-4))
    assert first.ok and again.ok and rel(again.u[0], fresh.u[0]) < 1e-10
    assert not np.allclose(first.u[0], again.u[0])
    block = scene(0.0).bodies[0]
    with pytest.raises(cc.SceneError, match="contact pairs"):
        solver.solve(cc.Scene(block, contacts=[cc.Contact(block, "bottom", cc.Rigid.circle((0.5, -1.0), 1.0))]))


def test_staggered_overlap_and_traction_per_pair():
    """Overlap [0.35, 0.6]: each end comes from a different body and falls between the other's nodes."""
    a = cc.Body(cc.rectangle(x=(0.0, 0.6), y=(0.0, 0.3), nx=5, ny=2), STEEL, clamped="top", contact="bottom",
                body_force=(0.0, -1e9), name="left")
    b = cc.Body(cc.rectangle(x=(0.35, 1.0), y=(-0.3, 0.0), nx=6, ny=2), ALU, clamped="bottom", contact="top",
                name="right")
    gap = lambda s: -1e-4 + 2e-3 * (s - 0.45) ** 2                       # noqa: E731
    scene = cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", gap=gap)])
    us, forces = dense_reference(scene.bodies, [(0, "bottom", 1, "top")], "gamma3", [gap])
    sol = cc.solve(scene)
    c = sol.contact
    assert sol.ok and c.x[0] == 0.35 and c.x[-1] == pytest.approx(0.6, abs=1e-15)
    assert np.abs(c.x - forces[0][0]).max() < 1e-12 and rel(c.force, forces[0][1]) < 1e-8
    assert rel(sol.u[0], us[0]) < 1e-8 and rel(sol.u[1], us[1]) < 1e-8
    # each body's view of the pressure carries the same resultant (the work-equivalent transfer)
    for k in range(2):
        x, p = sol.traction(k, pair=0)
        w = np.zeros(len(x))
        w[:-1] += np.diff(x) / 2
        w[1:] += np.diff(x) / 2
        assert abs((p * w).sum() - c.force.sum()) <= 1e-12 * abs(c.force.sum())
    with pytest.raises(cc.SceneError, match="pair must be an index"):
        sol.traction(0, pair=1)


def test_two_punches_on_one_part_of_a_substrate():
    """Two pairs on the same part of one body (disjoint overlaps) against the dense reference."""
    p1 = cc.Body(cc.rectangle(x=(0.1, 0.4), y=(0.0, 0.2), nx=3, ny=2), STEEL, clamped="top", contact="bottom",
                 body_force=(0.0, -1e9), name="p1")
    p2 = cc.Body(cc.rectangle(x=(0.55, 0.9), y=(0.0, 0.2), nx=4, ny=2), STEEL, clamped="top", contact="bottom",
                 body_force=(0.0, -1e9), name="p2")
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.4, 0.0), nx=7, ny=3), ALU, clamped="bottom", contact="top",
                   name="substrate")
    gaps = [lambda s: -5e-5 + 1e-3 * (s - 0.2) ** 2, lambda s: -2e-5 + 2e-4 * (s - 0.55)]
    scene = cc.Scene(p1, p2, base, contacts=[cc.Contact(p1, "bottom", base, "top", gap=gaps[0]),
                                             cc.Contact(p2, "bottom", base, "top", gap=gaps[1])])
    us, forces = dense_reference(scene.bodies, [(0, "bottom", 2, "top"), (1, "bottom", 2, "top")], "gamma3", gaps)
    sol = cc.solve(scene)
    assert sol.ok and all(rel(sol.u[k], us[k]) < 1e-8 for k in range(3))
    for c, (xs, fr) in zip(sol.contacts, forces):       # (the reference rounds its abscissae to 1e-12)
        assert np.abs(c.x - xs).max() < 1e-11 and rel(c.force, fr) < 1e-8 and c.active.any()
