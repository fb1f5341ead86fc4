"""3D scene files: box and cylinder meshes, 3-component loads and expressions of (x, y, z), 3D obstacles,
typed errors naming the file and the key; `cvxcontact solve` and `info` on a 3D scene."""

from pathlib import Path

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.cli import main
from cvxcontact.fem.assembly import assemble
from cvxcontact.io.scenefile import SceneFileError, load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

BLOCK = """
[[body]]
name = "block"
material = { E = 70e9, nu = 0.33 }
mesh = { box = { x = [0.0, 0.02], y = [0.0, 0.01], z = [0.0, 0.005], nx = 4, ny = 2, nz = 2 } }
clamped = ["bottom"]
"""


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_punch3d_file_equals_the_api_scene():
    """examples/punch3d.toml and the same scene built in Python give the same solution (both exact finishes), and
    the solve takes well under the example's budget."""
    spec = load_scene(EXAMPLES / "punch3d.toml")
    punch = cc.Body(cc.box(x=(0.005, 0.015), y=(0.005, 0.015), z=(0.005, 0.008), nx=3, ny=3, nz=2),
                    cc.materials.PZT5A, name="punch", displacement={"top": (0.0, 0.0, -1e-6)}, grounded=["bottom"],
                    floating={"top": 0.0})
    block = cc.Body(cc.box(x=(0, 0.02), y=(0, 0.02), z=(0, 0.005), nx=6, ny=6, nz=2,
                           patches={"footprint": ("top", (0.005, 0.015), (0.005, 0.015))}),
                    cc.materials.isotropic(70e9, 0.33), name="block", clamped=["bottom"],
                    body_force=(0.0, 0.0, -2700 * 9.81))
    api = cc.solve(cc.Scene(punch, block, contacts=[cc.Contact(punch, "bottom", block, "footprint")]), "gamma3")
    sol = spec.solve()
    assert sol.ok and sol.polished and api.polished
    for a, b in zip(sol.u, api.u):
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()                  # measured 0
    assert sol.electrodes[1].potential == pytest.approx(api.electrodes[1].potential, rel=1e-12)
    assert sol.electrodes[1].potential < -100                                   # the press reads as a voltage
    assert sol.contact.force.sum() > 0


def test_loads_are_expressions_of_x_y_z_with_three_components(tmp_path):
    """Body force, traction and surface charge given as expressions of (x, y, z) assemble to the same load
    vectors as the API's callables."""
    text = BLOCK.replace('material = { E = 70e9, nu = 0.33 }', 'material = "PZT-5A"') + """
grounded = ["bottom"]
contact = "top"
body_force = ["1e6 * x", "-2e6 * y * z / 0.005", 3e4]
traction = { right = ["1e5 * (1 + z / 0.005)", 0.0, "2e5 * y"] }
surface_charge = { top = "1e-3 * x * y / 0.0002" }
volume_charge = "z"
[[obstacle]]
name = "floor"
plane = { point = [0.0, 0.0, 0.006], normal = [0.0, 0.0, -1.0] }
[[contact]]
a = "block"
part_a = "top"
b = "floor"
"""
    body = load_scene(write(tmp_path, text)).scene.bodies[0]
    api = cc.Body(body.mesh, cc.materials.PZT5A, name="block", clamped=["bottom"], grounded=["bottom"],
                  body_force=lambda x, y, z: (1e6 * x, -2e6 * y * z / 0.005, 3e4 + 0 * x),
                  traction={"right": lambda x, y, z: (1e5 * (1 + z / 0.005), 0 * x, 2e5 * y)},
                  surface_charge={"top": lambda x, y, z: 1e-3 * x * y / 0.0002}, volume_charge=lambda x, y, z: z)
    a, b = assemble(body), assemble(api)
    assert np.abs(b.f).max() > 0 and np.abs(b.q).max() > 0
    assert np.array_equal(a.f, b.f) and np.array_equal(a.q, b.q)


def test_cylinder_mesh_graded_box_patches_and_3d_obstacles_equal_the_api(tmp_path):
    """A graded box with a patch, a cylinder, and the four 3D obstacles read from a file equal the API's
    (same nodes, tags; same distances along a normal at sample points; the force kept)."""
    text = """
[[body]]
name = "disc"
material = "PZT-5A"
mesh = { cylinder = { radius = 0.01, height = 0.002, n_r = 3, n_z = 1 } }
grounded = ["bottom"]
displacement = { side = [0.0, 0.0, "free"] }
[[body]]
name = "slab"
material = { E = 70e9, nu = 0.33 }
mesh = { box = { x = [-0.01, 0.01], y = [-0.01, 0.01], z = [-0.004, 0.0], nx = 4, ny = 4, nz = 2, patches = { pad = ["top", [-0.005, 0.005], [-0.005, 0.005]] }, grade = { point = [0.0, 0.0, 0.0], ratio = 3.0 } } }
clamped = ["bottom"]
[[obstacle]]
name = "ball"
sphere = { center = [0.0, 0.0, 0.02], radius = 0.017 }
force = [0.0, 0.0, -10.0]
[[obstacle]]
name = "roll"
cylinder = { point = [0.0, 0.0, 0.05], axis = [1.0, 0.0, 0.0], radius = 0.047 }
[[obstacle]]
name = "dome"
height_field = { f = "(x**2 + y**2) / (2 * 0.05)", origin = [0.0, 0.0, 0.0035] }
[[obstacle]]
name = "wall"
plane = { point = [0.0, 0.0, 0.0031], normal = [0.0, 0.0, -1.0] }
[[contact]]
a = "disc"
part_a = "top"
b = "ball"
[[contact]]
a = "slab"
part_a = "pad"
b = "disc"
part_b = "bottom"
"""
    spec = load_scene(write(tmp_path, text))
    disc, slab = spec.scene.bodies
    mesh = cc.cylinder(radius=0.01, height=0.002, n_r=3, n_z=1)
    graded = cc.box(x=(-0.01, 0.01), y=(-0.01, 0.01), z=(-0.004, 0), nx=4, ny=4, nz=2,
                    patches={"pad": ("top", (-0.005, 0.005), (-0.005, 0.005))}, grade=((0, 0, 0), 3.0))
    assert np.array_equal(disc.mesh.points, mesh.points) and np.array_equal(disc.mesh.tets, mesh.tets)
    assert np.array_equal(slab.mesh.points, graded.points) and np.array_equal(slab.mesh.boundary("pad"),
                                                                              graded.boundary("pad"))
    from cvxcontact.io.scenefile import _Context

    ctx = _Context(tmp_path / "scene.toml")
    import tomllib

    obstacles = {o["name"]: ctx.obstacle(o, o["name"]) for o in tomllib.loads(text)["obstacle"]}
    api = {"ball": cc.Rigid.sphere((0, 0, 0.02), 0.017, force=(0, 0, -10.0)),
           "roll": cc.Rigid.cylinder((0, 0, 0.05), (1, 0, 0), 0.047),
           "dome": cc.Rigid.height_field(lambda x, y: (x ** 2 + y ** 2) / (2 * 0.05), origin=(0, 0, 0.0035)),
           "wall": cc.Rigid.plane((0, 0, 0.0031), (0, 0, -1))}
    pts = disc.mesh.points[disc.mesh.boundary_nodes("top")]
    up = np.array([0.0, 0.0, 1.0])
    for name, rigid in api.items():
        d_file, d_api = obstacles[name].distance(pts, up), rigid.distance(pts, up)
        assert np.isfinite(d_api).any() and np.array_equal(np.isfinite(d_file), np.isfinite(d_api))
        ok = np.isfinite(d_api)
        assert np.abs(d_file[ok] - d_api[ok]).max() <= 1e-15
    assert np.array_equal(obstacles["ball"].force, [0, 0, -10.0])


@pytest.mark.parametrize("edit,words", [
    (lambda t: t + 'body_force = [0.0, -1e4]\n', ["body[0].body_force", "a list of 3 components"]),
    (lambda t: t + 'displacement = { top = [0.0, 1e-6] }\n', ["body[0].displacement.top", "[ux, uy, uz]"]),
    (lambda t: t + 'rotation = 0.5\n', ["body[0].rotation", "3x3 rotation matrix"]),
    (lambda t: t + 'rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]\n', ["body[0].rotation"]),
    (lambda t: t + 'plane = "stress"\n', ["body[0].plane", "2D bodies only"]),
    (lambda t: t + 'traction = { top = [0.0, 0.0, "w * 2"] }\n', ["body[0].traction.top[2]", "unknown name 'w'",
                                                                   "x, y, z"]),
    (lambda t: t.replace("nz = 2", "nz = 2, nw = 3"), ["body[0].mesh.box", "unknown key(s) ['nw']"]),
    (lambda t: t.replace("nz = 2", "nz = 2, grade = { point = [0.0, 0.0, 0.0] }"), ["body[0].mesh.box.grade",
                                                                                   "ratio"]),
    (lambda t: t.replace("nz = 2", "nz = 0"), ["body[0].mesh", "nz"]),
    (lambda t: t.replace('{ box = { x = [0.0, 0.02], y = [0.0, 0.01], z = [0.0, 0.005], nx = 4, ny = 2, nz = 2 } }',
                         '{ cylinder = { height = 0.01 } }'), ["body[0].mesh.cylinder", "missing key 'radius'"]),
])
def test_bad_3d_keys_are_typed_errors_naming_file_and_key(tmp_path, edit, words):
    text = edit(BLOCK.rstrip("\n") + "\n") + """
[[obstacle]]
name = "floor"
plane = { point = [0.0, 0.0, 0.006], normal = [0.0, 0.0, -1.0] }
[[contact]]
a = "block"
part_a = "top"
b = "floor"
"""
    path = write(tmp_path, text)
    with pytest.raises(SceneFileError) as err:
        load_scene(path)
    message = str(err.value)
    assert str(path) in message
    for w in words:
        assert w in message, message


@pytest.mark.parametrize("obstacle,words", [
    ('sphere = { center = [0.0, 0.0, 0.02] }', ["obstacle[0].sphere", "missing key 'radius'"]),
    ('sphere = { center = [0.0, 0.02], radius = 0.01 }', ["obstacle[0]", "Rigid.sphere"]),
    ('height_field = { f = "x + q", origin = [0.0, 0.0, 0.01] }', ["obstacle[0].height_field.f", "unknown name 'q'"]),
    ('cylinder = { point = [0.0, 0.0, 0.02], axis = [0.0, 0.0, 0.0], radius = 0.01 }', ["obstacle[0]", "axis"]),
    ('sphere = { center = [0.0, 0.0, 0.02], radius = 0.01 }\ncircle = { center = [0.0, 0.0], radius = 1.0 }',
     ["obstacle[0]", "exactly one of"]),
])
def test_bad_3d_obstacles_are_typed_errors(tmp_path, obstacle, words):
    text = BLOCK + f"""
[[obstacle]]
name = "tool"
{obstacle}
[[contact]]
a = "block"
part_a = "top"
b = "tool"
"""
    with pytest.raises(SceneFileError) as err:
        load_scene(write(tmp_path, text))
    for w in words:
        assert w in str(err.value), str(err.value)


def test_z_in_a_2d_file_and_mixed_dimensions_are_refused(tmp_path):
    two_d = """
[[body]]
material = { E = 70e9, nu = 0.3 }
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 2, ny = 1 } }
clamped = ["top"]
contact = "bottom"
body_force = [0.0, "z"]
[[body]]
material = { E = 70e9, nu = 0.3 }
mesh = { rectangle = { x = [0.0, 1.0], y = [-0.5, 0.0], nx = 2, ny = 1 } }
clamped = ["bottom"]
contact = "top"
"""
    with pytest.raises(SceneFileError, match=r"body\[0\].body_force\[1\].*unknown name 'z' \(z exists in 3D"):
        load_scene(write(tmp_path, two_d))
    mixed = two_d.replace('body_force = [0.0, "z"]\n', "").replace(
        '{ rectangle = { x = [0.0, 1.0], y = [-0.5, 0.0], nx = 2, ny = 1 } }',
        '{ box = { x = [0.0, 1.0], y = [0.0, 1.0], z = [-0.5, 0.0], nx = 1, ny = 1, nz = 1 } }')
    with pytest.raises(SceneFileError, match="share one dimension"):
        load_scene(write(tmp_path, mixed, "mixed.toml"))


def test_gap_of_a_3d_pair_is_an_expression_of_the_in_plane_coordinates(tmp_path):
    """contact.gap = "1e-6 * (1 + x / 0.02 + y / 0.01)": g(s1, s2) at the pair's nodes, (s1, s2) = (x, y) on a
    plane z = const."""
    text = BLOCK + """
contact = "top"
[[obstacle]]
name = "floor"
plane = { point = [0.0, 0.0, 0.005], normal = [0.0, 0.0, -1.0] }
[[contact]]
a = "block"
part_a = "top"
b = "floor"
gap = "1e-6 * (1 + x / 0.02 + y / 0.01)"
"""
    scene = load_scene(write(tmp_path, text)).scene
    s = scene.interfaces[0].x
    expected = 1e-6 * (1 + s[:, 0] / 0.02 + s[:, 1] / 0.01)
    assert np.abs(scene.pair_gap_values(0) - expected).max() <= 1e-18


def test_solve_and_info_commands_on_a_3d_scene(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["solve", str(EXAMPLES / "punch3d.toml"), "--out", str(out), "--no-plots"]) == 0
    printed = capsys.readouterr().out
    assert "exact finish" in printed and " N; pressure > 0 at " in printed and " C/m" not in printed
    assert "; 16 of 16 constrained nodes active" in printed
    names = sorted(p.name for p in out.iterdir())
    assert names == ["gamma3.json", "gamma3_body1.vtu", "gamma3_body2.vtu", "gamma3_contact.vtu",
                     "gamma3_contact_body1.vtu", "gamma3_contact_body2.vtu", "results.pvd"]
    assert main(["info", str(EXAMPLES / "punch3d.toml")]) == 0
    printed = capsys.readouterr().out
    assert "108 tetrahedra" in printed and "area 0.0001 m^2" in printed and "16 overlay nodes" in printed
