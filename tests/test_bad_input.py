"""The bad-input table: each bad scene file raises a typed cvxcontact error naming file and key.

Together with tests/test_errors.py (API) and tests/test_mesh_materials_assembly.py (meshes,
materials) this covers well over 25 distinct bad inputs; none returns a solution.
"""

import textwrap

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.io.expr import Expression, ExpressionError
from cvxcontact.io.scenefile import SceneFileError, load_scene

GOOD_UPPER = """
[[body]]
material = "PZT-5A"
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 4, ny = 2 } }
clamped = ["top"]
grounded = ["top"]
contact = "bottom"
body_force = [0.0, -1e9]
"""
LOWER_MESH = "{ rectangle = { x = [0.0, 1.0], y = [-0.5, 0.0], nx = 3, ny = 2 } }"
GOOD_LOWER = f"""
[[body]]
material = {{ E = 70e9, nu = 0.3 }}
mesh = {LOWER_MESH}
clamped = "bottom"
contact = "top"
"""


def scene_text(upper=GOOD_UPPER, lower=GOOD_LOWER, head=""):
    return textwrap.dedent(head) + upper + lower


def replace(text, old, new):
    assert old in text, old
    return text.replace(old, new)


BAD = [
    # (id, scene-file text, expected error class, words the message must contain)
    ("not TOML", "this is = = not toml", SceneFileError, "not a valid TOML"),
    ("unknown top key", scene_text(head="solvr = 1\n"), SceneFileError, "unknown key(s) ['solvr']"),
    ("one body", GOOD_UPPER, SceneFileError, "exactly two [[body]]"),
    ("unknown body key", scene_text(upper=GOOD_UPPER + 'colour = "red"\n'), SceneFileError, "body[0]: unknown key"),
    ("missing clamped", scene_text(upper=replace(GOOD_UPPER, 'clamped = ["top"]\n', "")), SceneFileError,
     "nothing holds the rigid motion(s) ['translation x']"),
    ("empty clamped", scene_text(upper=replace(GOOD_UPPER, 'clamped = ["top"]', "clamped = []")), SceneFileError,
     "nothing holds the rigid motion(s) ['translation x']"),
    ("unknown material", scene_text(upper=replace(GOOD_UPPER, "PZT-5A", "PZT-9")), SceneFileError,
     "body[0].material: expected a built-in material"),
    ("negative modulus", scene_text(lower=replace(GOOD_LOWER, "E = 70e9", "E = -70e9")), SceneFileError,
     "need E > 0"),
    ("non-PD piezo constants", scene_text(upper=replace(GOOD_UPPER, 'material = "PZT-5A"',
     "material = { c11 = 1e11, c13 = 2e11, c33 = 1e11, c44 = 2e10, e31 = -5.0, e33 = 15.0, e15 = 12.0, "
     "eps11 = 8e-9, eps33 = 7e-9 }")), SceneFileError, "not positive definite"),
    ("unknown constant", scene_text(upper=replace(GOOD_UPPER, 'material = "PZT-5A"',
     "material = { c11 = 1e11, d33 = 1.0 }")), SceneFileError, "unknown key(s) ['d33']"),
    ("unknown tag", scene_text(upper=replace(GOOD_UPPER, 'clamped = ["top"]', 'clamped = ["roof"]')),
     SceneFileError, "unknown boundary tag 'roof'"),
    ("piezo without electrode", scene_text(upper=replace(GOOD_UPPER, 'grounded = ["top"]\n', "")), SceneFileError,
     "without a grounded or driven electrode"),
    ("bodies do not overlap", scene_text(lower=replace(GOOD_LOWER, "x = [0.0, 1.0]", "x = [1.5, 2.5]")),
     SceneFileError, "do not overlap"),
    ("not collinear", scene_text(lower=replace(GOOD_LOWER, "y = [-0.5, 0.0]", "y = [-0.5, -0.1]")),
     SceneFileError, "not collinear"),
    ("NaN load", scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]", "[nan, -1e9]")), SceneFileError,
     "body_force: NaN"),
    ("infinite charge", scene_text(upper=GOOD_UPPER + "surface_charge = { left = inf }\n"), SceneFileError,
     "surface_charge['left']: NaN or infinite"),
    ("wrong vector length", scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]", "[0.0, -1e9, 0.0]")),
     SceneFileError, "body[0].body_force: expected a list of 2 components"),
    ("forbidden name", scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]", "[0.0, \"__import__('os')\"]")),
     SceneFileError, "function '__import__' is not allowed"),
    ("attribute access", scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]", '[0.0, "x.__class__"]')),
     SceneFileError, "Attribute"),
    ("expression syntax", scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]", '[0.0, "2 *"]')), SceneFileError,
     "body[0].body_force[1]: cannot parse"),
    ("boolean load", scene_text(upper=GOOD_UPPER + "volume_charge = true\n"), SceneFileError,
     "volume_charge: expected a number"),
    ("bad condition", scene_text(head='condition = "gamma4"\n'), SceneFileError, "condition: expected one of"),
    ("bad tolerance", scene_text(head="[solver]\ntol = -1\n"), SceneFileError,
     "solver.tol: expected a finite positive"),
    ("infinite tolerance", scene_text(head="[solver]\ntol = inf\n"), SceneFileError,
     "solver.tol: expected a finite positive"),
    ("option colliding with tol", scene_text(head="[solver]\noptions = { tol = 1e-3 }\n"), SceneFileError,
     "solver.options: solver option 'tol' is not a solver option; use the tol argument"),
    ("misspelt solver option", scene_text(head="[solver]\noptions = { max_iters = 3 }\n"), SceneFileError,
     "unknown Clarabel option 'max_iters'; did you mean"),
    ("mesh outside the folder", scene_text(lower=replace(GOOD_LOWER, LOWER_MESH, '{ file = "../lower.msh" }')),
     SceneFileError, "body[1].mesh.file: '../lower.msh' leads outside the scene file's folder"),
    ("missing mesh file", scene_text(lower=replace(GOOD_LOWER, LOWER_MESH, '{ file = "nowhere.msh" }')),
     SceneFileError, "nowhere.msh' does not exist"),
    ("bad rectangle", scene_text(lower=replace(GOOD_LOWER, "nx = 3", "nx = 0")), SceneFileError,
     "nx must be a positive integer"),
    ("bad mesh spec", scene_text(lower=replace(GOOD_LOWER, LOWER_MESH, '"lower.msh"')), SceneFileError,
     "body[1].mesh: expected a table"),
    ("tag both clamped and contact", scene_text(upper=replace(GOOD_UPPER, 'clamped = ["top"]',
                                                             'clamped = ["bottom"]')), SceneFileError,
     "'bottom' is both clamped and contact"),
    ("gap not finite", scene_text(head="gap = nan\n"), SceneFileError, "scene: gap: NaN"),
    ("gap with a forbidden name", scene_text(head='gap = "open(1)"\n'), SceneFileError, "gap: in 'open(1)'"),
    ("function given an output array", scene_text(head='gap = "0*exp(x, x)"\n'), SceneFileError,
     "gap: in '0*exp(x, x)': function 'exp' takes exactly 1 argument, got 2"),
    ("extra argument in a component", scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]",
                                                               '["0*sin(x, y)", "-2e9*(1+y)"]')),
     SceneFileError, "body_force[0]: in '0*sin(x, y)': function 'sin' takes exactly 1 argument"),
    ("elastic body with electrode", scene_text(lower=GOOD_LOWER + 'grounded = ["bottom"]\n'), SceneFileError,
     "carries no electric unknowns"),
]


@pytest.mark.parametrize("text,error,words", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_scene_files(tmp_path, text, error, words):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(error) as info:
        load_scene(path)
    assert words in str(info.value) and str(path) in str(info.value)
    assert isinstance(info.value, cc.CvxContactError)


def test_table_is_large_enough():
    assert len({b[0] for b in BAD}) == len(BAD) >= 25


def test_mesh_file_with_no_triangles(tmp_path):
    meshio.write(tmp_path / "lines.msh", meshio.Mesh(np.array([[0.0, 0, 0], [1, 0, 0]]),
                                                     [("line", np.array([[0, 1]]))]), file_format="gmsh22")
    path = tmp_path / "scene.toml"
    path.write_text(scene_text(lower=replace(GOOD_LOWER, LOWER_MESH, '{ file = "lines.msh" }')))
    with pytest.raises(SceneFileError, match="holds no triangles"):
        load_scene(path)


def test_load_expression_failing_at_solve_names_the_key(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(scene_text(upper=replace(GOOD_UPPER, "[0.0, -1e9]", '[0.0, "log(x - 0.5)"]')))
    spec = load_scene(path)
    with pytest.raises(cc.SceneError, match=r"body_force: .*scene\.toml: body\[0\]\.body_force\[1\]: "
                                            r"'log\(x - 0\.5\)' is nan at \(x, y\)"):   # names the file and key
        spec.solve()


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneFileError, match="does not exist"):
        load_scene(tmp_path / "nope.toml")


# ------------------------------------------------------------------------ restricted evaluator

@pytest.mark.parametrize("text,expected", [
    ("1 + 2 * x", lambda x, y: 1 + 2 * x),
    ("-2e9 * (1 + cos(pi * x))", lambda x, y: -2e9 * (1 + np.cos(np.pi * x))),
    ("where(x < 0.5, y ** 2, -y)", lambda x, y: np.where(x < 0.5, y ** 2, -y)),
    ("sqrt(x**2 + y**2) % 0.3", lambda x, y: np.sqrt(x ** 2 + y ** 2) % 0.3),
    ("maximum(0, 1 - abs(x - 0.5) / 0.2)", lambda x, y: np.maximum(0, 1 - np.abs(x - 0.5) / 0.2)),
    ("7", lambda x, y: 7 + 0 * x),
])
def test_expressions_evaluate_like_numpy(text, expected):
    x, y = np.linspace(0, 1, 7), np.linspace(-1, 0, 7)
    assert np.allclose(Expression(text)(x, y), expected(x, y))


@pytest.mark.parametrize("text", ["__import__('os').system('true')", "x.__class__", "open('f')", "[1, 2]",
                                  "lambda: 1", "x if y else 1", "'a'", "z + 1", "exp(x=1)", "(1).real",
                                  "x[0]", "True"])
def test_expressions_reject_everything_else(text):
    with pytest.raises(ExpressionError):
        Expression(text)
