"""Supports (roller, prescribed displacement), floating electrodes and the rigid-motion check.

Closed forms: a layer on a frictionless rigid foundation (a roller) between side rollers, pressed
through a plate under displacement control, is in exact uniaxial strain (P1 reproduces it to
rounding); with a piezoelectric layer and an open-circuit floating electrode the layer's modulus
is the stiffened c33 + e33^2/eps33 and the potential is linear. A symmetric scene equals its half
model with a symmetry roller.
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.errors import SceneError

PZT = cc.materials.PZT5A
ALU = cc.materials.isotropic(E=70e9, nu=0.3)
H1, H2, DELTA = 0.4, 0.3, 1e-4


def _column(material, charge=None, n=(4, 4)):
    """Lower layer (material) on a roller foundation with side rollers, contact on top; an aluminium plate
    on it with side rollers and its top moved down by DELTA. ``charge``: floating top electrode (C/m)."""
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=n[0], ny=n[1])
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=n[0] + 1, ny=n[1] - 1)
    electric = {} if charge is None else dict(grounded=["bottom"], floating={"top": charge})
    b1 = cc.Body(low, material, roller=["bottom", "left", "right"], contact="top", **electric)
    b2 = cc.Body(top, ALU, roller=["left", "right"], displacement={"top": (None, -DELTA)}, contact="bottom")
    return cc.Scene(b1, b2)


def _series(c1):
    """Uniaxial strain of two layers in series (moduli c1, c22 of ALU): the common stress (Pa)."""
    return -DELTA / (H1 / c1 + H2 / ALU.c[1, 1])


@pytest.mark.parametrize("method", ["condensed", "full"])
def test_layer_on_roller_foundation_is_in_exact_uniaxial_strain(method):
    sol = cc.solve(_column(ALU), method=method)
    sigma = _series(ALU.c[1, 1])
    assert sol.ok and sol.polished
    p = sol.scene.bodies[0].mesh.points
    u = sol.u[0]
    assert np.abs(u[:, 0]).max() <= 1e-12 * DELTA                                  # no lateral motion
    assert np.abs(u[:, 1] - sigma / ALU.c[1, 1] * (p[:, 1] + H1)).max() <= 1e-9 * DELTA   # linear, P1 exact
    q = sol.scene.bodies[1].mesh.points
    assert np.abs(sol.u[1][:, 1] - (sigma / ALU.c[1, 1] * (q[:, 1] - H2) - DELTA)).max() <= 1e-9 * DELTA
    assert abs(sol.contact.force.sum() + sigma * 1.0) <= 1e-9 * abs(sigma)        # contact force = load
    assert sol.contact.active.all()


@pytest.mark.parametrize("charge", [0.0, 2e-3])
def test_piezo_layer_with_floating_electrode_closed_form(charge):
    """D_y = -Q / w in the layer (the electrode's charge is -D.nu); sigma = c33 eps - e33 E_y with
    E_y = (D_y - e33 eps) / eps33; for Q = 0 the modulus is c33 + e33^2 / eps33."""
    c33, e33, k33 = PZT.c[1, 1], PZT.e[1, 1], PZT.kappa[1, 1]
    c2 = ALU.c[1, 1]
    D = -charge / 1.0
    # unknowns (eps1, eps2): c33 eps1 - e33 (D - e33 eps1)/k33 = c2 eps2 ; eps1 H1 + eps2 H2 = -DELTA
    A = np.array([[c33 + e33 ** 2 / k33, -c2], [H1, H2]])
    eps1, eps2 = np.linalg.solve(A, [e33 * D / k33, -DELTA])
    E = (D - e33 * eps1) / k33
    sol = cc.solve(_column(PZT, charge=charge))
    assert sol.ok and sol.polished
    p = sol.scene.bodies[0].mesh.points
    scale = abs(E) * H1
    assert np.abs(sol.u[0][:, 1] - eps1 * (p[:, 1] + H1)).max() <= 1e-9 * DELTA
    assert np.abs(sol.phi[0] - (-E) * (p[:, 1] + H1)).max() <= 1e-9 * scale     # linear potential, phi(bottom) = 0
    if charge == 0.0:
        assert eps1 == pytest.approx(_series(c33 + e33 ** 2 / k33) / (c33 + e33 ** 2 / k33), rel=1e-12)
    force = c2 * eps2 * 1.0
    assert abs(sol.contact.force.sum() + force) <= 1e-9 * abs(force)
    top = [e for e in sol.electrodes if e.tag == "top"][0]
    ground = [e for e in sol.electrodes if e.tag == "bottom"][0]
    assert top.kind == "floating" and ground.kind == "grounded"
    assert top.potential == pytest.approx(-E * H1, rel=1e-9)
    assert abs(top.charge - charge) <= 1e-9 * max(abs(charge), abs(e33 * eps1))
    assert abs(ground.charge + charge) <= 1e-9 * max(abs(charge), abs(e33 * eps1))   # Gauss: charges sum to 0


def _blocks(x0, nx1, nx2, **roller):
    m1 = cc.rectangle(x=(x0, 1.0), y=(0.0, 0.5), nx=nx1, ny=4)
    m2 = cc.rectangle(x=(x0, 1.0), y=(-0.5, 0.0), nx=nx2, ny=3)
    b1 = cc.Body(m1, PZT, clamped=["top"], grounded=["top"], contact="bottom", body_force=(0.0, -2e9),
                 roller=roller.get("upper", []))
    b2 = cc.Body(m2, ALU, clamped=["bottom"], contact="top", roller=roller.get("lower", []))
    return cc.Scene(b1, b2)


def test_symmetric_scene_equals_its_half_model_with_a_roller():
    full = cc.solve(_blocks(0.0, 8, 4))          # even nx: the "alternate" meshes are mirror-symmetric
    half = cc.solve(_blocks(0.5, 4, 2, upper=["left"], lower=["left"]))
    assert full.ok and half.ok
    for k in range(2):
        pf, ph = full.scene.bodies[k].mesh.points, half.scene.bodies[k].mesh.points
        # node i of the half mesh is node j of the full mesh at the same point
        d = np.abs(pf[None, :, :] - ph[:, None, :]).sum(axis=2)
        j = d.argmin(axis=1)
        assert d.min(axis=1).max() < 1e-12
        uf = full.u[k]
        assert np.abs(uf[j] - half.u[k]).max() <= 1e-8 * np.abs(uf).max(), k
        if k == 0:
            assert np.abs(full.phi[0][j] - half.phi[0]).max() <= 1e-8 * np.abs(full.phi[0]).max()
    assert half.contact.force.sum() == pytest.approx(0.5 * full.contact.force.sum(), rel=1e-8)


def test_roller_on_a_tilted_straight_part_keeps_the_normal_component_zero():
    """A roller on the hypotenuse of a right triangle: u . n = 0 there, the tangent free."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5], [0.25, 0.25]])
    tri = np.array([[0, 3, 6], [3, 4, 6], [3, 1, 4], [6, 4, 5], [5, 4, 2], [0, 6, 5]])
    mesh = cc.Mesh(pts, tri, {"bottom": [[0, 3], [3, 1]], "slope": [[1, 4], [4, 2]], "left": [[2, 5], [5, 0]]})
    from cvxcontact.fem.assembly import prolongation
    b = cc.Body(mesh, ALU, clamped=["left"], roller=["slope"], contact="bottom")
    Tu, u_fixed, _, _ = prolongation(b)
    n = np.array([1.0, 1.0]) / np.sqrt(2.0)
    for i in (4,):                                         # the slope's middle node: one column, along the slope
        cols = Tu[2 * i:2 * i + 2].toarray()
        assert np.linalg.matrix_rank(cols) == 1 and np.abs(n @ cols).max() < 1e-15
    assert not u_fixed.any()


# ---- refusals -----------------------------------------------------------------------------------

def _rect():
    return cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=3, ny=2)


@pytest.mark.parametrize("kw,motion", [
    (dict(), r"\['translation x'\]"),                                       # contact (bottom) holds y and rotation
    (dict(roller=["top"]), r"\['translation x'\]"),
    (dict(displacement={"top": (None, 0.0)}), r"\['translation x'\]"),
])
def test_free_rigid_motion_is_a_typed_error_naming_it(kw, motion):
    """Refused by the Scene, which knows the body's contact parts (a Body alone does not: its pairs may use
    other parts): a motion no support holds and tangential to every contact part."""
    body = cc.Body(_rect(), ALU, contact="bottom", **kw)
    with pytest.raises(SceneError, match=r"nothing holds the rigid motion\(s\) " + motion):
        cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)))])


def test_rotation_left_free_is_named_with_its_centre():
    # a roller on the left side holds x and the rotations; the contact on the right side cannot hold y
    body = cc.Body(_rect(), ALU, roller=["left"], contact="right")
    with pytest.raises(SceneError, match=r"translation y.*|rotation about"):
        cc.Scene(body, contacts=[cc.Contact(body, "right", cc.Rigid.plane((1.0, 0.0), (-1.0, 0.0)))])


def test_bad_support_input_is_refused():
    with pytest.raises(SceneError, match=r"displacement\['top'\]: both components are None"):
        cc.Body(_rect(), ALU, clamped=["left"], displacement={"top": (None, None)}, contact="bottom")
    with pytest.raises(SceneError, match=r"displacement\['top'\]: expected a pair"):
        cc.Body(_rect(), ALU, clamped=["left"], displacement={"top": (0.0, "x")}, contact="bottom")
    with pytest.raises(SceneError, match=r"'top' is both clamped and roller"):
        cc.Body(_rect(), ALU, clamped=["top"], roller=["top"], contact="bottom")
    with pytest.raises(SceneError, match="incompatible displacements"):
        cc.Body(_rect(), ALU, displacement={"top": (1e-3, 0.0), "left": (0.0, 0.0)}, contact="bottom")
    # (a prescribed displacement touching the contact part moves the contact line: tests/test_refusals.py)
    m = _rect()
    bent = cc.Mesh(m.points, m.triangles, {"bend": np.vstack([m.boundary("bottom"), m.boundary("right")]),
                                           "top": m.boundary("top"), "left": m.boundary("left")})
    with pytest.raises(SceneError, match=r"roller part 'bend' is not straight"):
        cc.Body(bent, ALU, clamped=["left"], roller=["bend"], contact="top")
    with pytest.raises(SceneError, match=r"floating\['top'\]: expected the total charge"):
        cc.Body(_rect(), PZT, clamped=["left"], grounded=["bottom"], floating={"top": "1"}, contact="bottom")
    with pytest.raises(SceneError, match="floating electrode 'right' touches a grounded"):
        cc.Body(_rect(), PZT, clamped=["left"], grounded=["bottom"], floating={"right": 0.0}, contact="bottom")
    with pytest.raises(SceneError, match="carries no electric unknowns"):
        cc.Body(_rect(), ALU, clamped=["left"], floating={"top": 0.0}, contact="bottom")


# ---- scene files ----------------------------------------------------------------------------------

COLUMN_TOML = """
[[body]]
name = "layer"
material = "PZT-5A"
mesh = { rectangle = { x = [0.0, 1.0], y = [-0.4, 0.0], nx = 4, ny = 4 } }
roller = ["bottom", "left", "right"]
grounded = ["bottom"]
floating = { top = 0.002 }
contact = "top"

[[body]]
name = "plate"
material = { E = 70e9, nu = 0.3 }
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.3], nx = 5, ny = 3 } }
roller = ["left", "right"]
displacement = { top = ["free", -1e-4] }
contact = "bottom"
"""


def test_scene_file_supports_and_floating_electrode_match_the_api(tmp_path):
    from cvxcontact.io.scenefile import load_scene
    path = tmp_path / "column.toml"
    path.write_text(COLUMN_TOML)
    a = cc.solve(load_scene(path).scene)
    b = cc.solve(_column(PZT, charge=2e-3))
    assert np.abs(a.u[0] - b.u[0]).max() <= 1e-12 * DELTA and np.abs(a.phi[0] - b.phi[0]).max() <= 1e-9
    assert [(e.tag, e.kind) for e in a.electrodes] == [("bottom", "grounded"), ("top", "floating")]
    from cvxcontact.io.output import summary
    s = summary(a)["electrodes"]
    assert s[1]["kind"] == "floating" and s[1]["charge_C_per_m"] == pytest.approx(2e-3, rel=1e-9)


@pytest.mark.parametrize("edit,words", [
    (('roller = ["left", "right"]', 'roller = "left, right"'), "unknown boundary tag 'left, right'"),
    (('["free", -1e-4]', '[null, -1e-4]'), None),                     # not TOML: refused by the parser
    (('["free", -1e-4]', '["none", -1e-4]'), 'body[1].displacement.top: expected a list [ux, uy]'),
    (("floating = { top = 0.002 }", 'floating = { top = "open" }'), "body[0].floating.top: expected the total"),
    (('name = "layer"', 'name = "layer"\nrotation = "30deg"'), "body[0].rotation: expected an angle in radians"),
    (('name = "layer"', 'name = "layer"\nplane = "shell"'), 'body[0].plane: expected "strain" (default) or "stress"'),
    (('name = "plate"', 'name = "plate"\nplane = "stress"\nmaterial_ = 1'), "unknown key(s) ['material_']"),
])
def test_scene_file_support_keys_are_checked(tmp_path, edit, words):
    from cvxcontact.io.scenefile import SceneFileError, load_scene
    path = tmp_path / "bad.toml"
    assert edit[0] in COLUMN_TOML
    path.write_text(COLUMN_TOML.replace(edit[0], edit[1], 1))
    with pytest.raises(SceneFileError) as info:
        load_scene(path)
    if words:
        assert words in str(info.value)


def test_scene_file_rotation_plane_stress_and_generated_meshes(tmp_path):
    from cvxcontact.io.scenefile import load_scene
    text = COLUMN_TOML.replace('name = "plate"', 'name = "plate"\nplane = "stress"\nrotation = 0.5', 1).replace(
        "{ rectangle = { x = [0.0, 1.0], y = [0.0, 0.3], nx = 5, ny = 3 } }",
        '{ graded_block = { x = [0.0, 1.0], y = [0.0, 0.3], nx = 5, ny = 3, contact = "bottom", gamma = 1.0 } }')
    path = tmp_path / "frames.toml"
    path.write_text(text)
    plate = load_scene(path).scene.bodies[1]
    E, nu = 70e9, 0.3
    assert plate.material.plane == "stress" and plate.material.angle == 0.5
    assert plate.material.c[0, 0] == pytest.approx(E / (1 - nu ** 2), rel=1e-12)     # isotropic: turned = same
    assert plate.mesh.points[:, 1].max() == pytest.approx(0.3)


# ---- bodies held by the contact only ------------------------------------------------------------

def _resting(p, material=ALU):
    """A layer between side rollers, pressed by a uniform pressure p (Pa) on its top, resting on a foundation
    clamped at its bottom, also between side rollers: nothing but the contact holds the layer vertically."""
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=4, ny=3)
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=3, ny=3)
    b1 = cc.Body(top, material, roller=["left", "right"], contact="bottom", traction={"top": (0.0, -p)})
    b2 = cc.Body(low, ALU, clamped=["bottom"], roller=["left", "right"], contact="top")
    return cc.Scene(b1, b2)


def test_layer_held_by_contact_only_is_solved_exactly():
    p = 2e7
    scene = _resting(p)
    assert scene.bodies[0].held_by_contact == ("translation y",)
    sol = cc.solve(scene)
    assert sol.method == "condensed" and sol.ok and sol.polished     # the layer's rigid motion kept (forced.py)
    assert abs(sol.contact.force.sum() - p * 1.0) <= 1e-9 * p                     # contact force = load
    c = ALU.c[1, 1]
    q1, q2 = (b.mesh.points for b in scene.bodies)
    assert np.abs(sol.u[1][:, 1] - (-p / c) * (q2[:, 1] + H1)).max() <= 1e-9 * p / c * H1
    assert np.abs(sol.u[0][:, 1] - (-p / c) * (q1[:, 1] + H1)).max() <= 1e-9 * p / c * H1
    assert np.abs(sol.u[0][:, 0]).max() <= 1e-9 * p / c * H1
    full = cc.solve(scene, method="full")                    # the whole mixed system: the same answer to rounding
    assert full.ok and max(np.abs(a - b).max() for a, b in zip(sol.u, full.u)) <= 1e-12 * p / c * H1


def test_load_pulling_a_body_off_its_support_is_a_typed_error():
    with pytest.raises(SceneError, match=r"the load pulls body 'body 1' off along translation y \(its net load "
                                         r"along it, 2e\+07 N/m"):
        cc.solve(_resting(-2e7))
    with pytest.raises(SceneError, match=r"nothing determines the translation y of body 'body 1': the load does no "
                                         "work along it"):
        cc.solve(_resting(0.0))


def test_piezo_layer_resting_under_pressure_with_open_circuit_electrode_is_stiffened():
    """The resting layer in PZT-5A, grounded at its bottom (the contact side), an open-circuit floating
    electrode on top: sigma_yy = -p, strain -p / (c33 + e33^2/eps33), potential linear."""
    p = 2e7
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=4, ny=3)
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=3, ny=3)
    b1 = cc.Body(top, PZT, roller=["left", "right"], contact="bottom", traction={"top": (0.0, -p)},
                 grounded=["bottom"], floating={"top": 0.0})
    b2 = cc.Body(low, ALU, clamped=["bottom"], roller=["left", "right"], contact="top")
    sol = cc.solve(cc.Scene(b1, b2))
    assert sol.ok and sol.polished
    c33, e33, k33 = PZT.c[1, 1], PZT.e[1, 1], PZT.kappa[1, 1]
    eps = -p / (c33 + e33 ** 2 / k33)
    base = -p / ALU.c[1, 1] * H1                                                   # the foundation's top
    y = b1.mesh.points[:, 1]
    assert np.abs(sol.u[0][:, 1] - (base + eps * y)).max() <= 1e-9 * abs(eps) * H2
    assert np.abs(sol.phi[0] - e33 * eps / k33 * y).max() <= 1e-9 * abs(e33 * eps / k33) * H2
    assert abs(sol.contact.force.sum() - p) <= 1e-9 * p
    top_e = [e for e in sol.electrodes if e.kind == "floating"][0]
    assert abs(top_e.charge) <= 1e-9 * abs(e33 * eps) and top_e.potential == pytest.approx(e33 * eps / k33 * H2,
                                                                                           rel=1e-9)


def test_model_poses_supports_and_floating_electrodes_in_si():
    scene = _column(PZT, charge=2e-3)
    model = cc.Model(scene)
    ref, sol = cc.solve(scene), model.solve()
    assert sol.ok and np.abs(sol.u[0] - ref.u[0]).max() <= 1e-9 * DELTA
    assert np.abs(model.u(1).value - ref.u[1]).max() <= 1e-6 * DELTA          # u_D included, interior point
    resting = cc.Model(_resting(2e7)).solve()                # a body held by the contact: as cc.solve(full)
    full = cc.solve(_resting(2e7), method="full")
    assert resting.ok and np.abs(resting.u[0] - full.u[0]).max() <= 1e-12 * np.abs(full.u[0]).max()


@pytest.mark.parametrize("lift", [0.0, 5e-6])
@pytest.mark.parametrize("degree,condition", [(1, "gamma3"), (1, "sigma2"), (2, "sigma1")])
def test_a_foundation_with_no_unknown_of_its_own(lift, degree, condition):
    """A foundation one element thick whose every node is clamped (lift 0) or moved up by ``lift`` (a prescribed
    displacement of its top and bottom): a body without a free unknown (P1), a fixed foundation or a moved
    contact line. It equals the upper block on a rigid plane at y = lift on every route (before: a bare
    ValueError in the condensed body's ordering, CVXPY's 'Invalid dimensions for arguments to quad_form' on the
    full route). Measured <= 5.1e-15 (P1 and P2, every method)."""
    gap = lambda s: -2e-6 + 2e-3 * (s - 0.4) ** 2          # noqa: E731  partial contact
    upper = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=3), ALU, clamped=["top"], body_force=(0, -1e8),
                    name="upper")
    held = dict(clamped=["top", "bottom"]) if lift == 0 else dict(displacement={"top": (0.0, lift),
                                                                                "bottom": (0.0, lift)})
    lower = cc.Body(cc.rectangle(x=(0, 1), y=(-0.1, 0), nx=8, ny=1), ALU, name="lower", **held)
    scene = cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", gap=gap)])
    plane = cc.Scene(upper, contacts=[cc.Contact(upper, "bottom", cc.Rigid.plane((0, lift), (0, 1)), gap=gap)])
    ref = cc.solve(plane, "sigma1" if condition == "sigma1" else "gamma3", degree=degree)   # matching meshes
    assert ref.ok and ref.contact.active.any() and not ref.contact.active.all()
    for method in ("auto", "condensed", "full", "sparse"):
        sol = cc.solve(scene, condition, degree=degree, method=method)
        assert sol.ok, sol.report()
        assert np.abs(sol.u[0] - ref.u[0]).max() <= 1e-12 * np.abs(ref.u[0]).max()
        scale = max(lift, np.abs(ref.u[0]).max())           # (P2: the midpoints of interior edges are free)
        assert np.abs(sol.u[1] - [0.0, lift]).max() <= 1e-12 * scale


def test_prepared_solver_names_a_changed_prescribed_displacement():
    """A prescribed displacement is part of a prepared ContactSolver: a new value is refused with a message
    naming the body, the part, both values and what to do (not "mesh, material or boundary parts")."""
    scene = _column(ALU)
    solver = cc.ContactSolver(scene)
    b1, b2 = scene.bodies
    pushed = cc.Scene(b1, b2.with_changes(displacement={"top": (None, -2 * DELTA)}))
    with pytest.raises(SceneError) as err:
        solver.solve(pushed)
    text = str(err.value)
    assert "body 2" in text and "prescribed displacement" in text and "'top'" in text
    assert "(free, -0.0001)" in text and "(free, -0.0002)" in text
    assert "new ContactSolver" in text and "cc.solve" in text and "mesh, material" not in text
    # another part prescribed is a changed structure, told as before
    other = cc.Scene(b1, b2.with_changes(displacement={"top": (None, -DELTA)}, roller=["left"]))
    with pytest.raises(SceneError, match="mesh, material or boundary parts"):
        solver.solve(other)
