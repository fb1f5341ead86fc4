"""Inputs are data: no expression, load or later edit can change package state unnoticed.

Expected states are written out independently (``np.linspace`` grids, NumPy itself),
never read back from the code under test.
"""

import textwrap

import numpy as np
import pytest

import cvxcontact as cc
import cvxcontact.io.expr as expr
from cvxcontact.io.expr import Expression, ExpressionError
from cvxcontact.physics.fingerprint import geometry_fingerprint
from cvxcontact.physics.scene import Load
from cvxcontact.io.scenefile import load_scene

UNARY = ["sin", "cos", "tan", "arcsin", "arccos", "arctan", "sinh", "cosh", "tanh", "exp", "log", "log10", "sqrt",
         "abs", "heaviside"]
BINARY = ["arctan2", "minimum", "maximum"]


def small_scene(gap=0.0, **load):
    """Two 4 x 2 blocks on [0, 1] meeting at y = 0: merged contact nodes at linspace(0, 1, 5)."""
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=4, ny=2)
    load = {"body_force": (0.0, -1e9), **load}
    b1 = cc.Body(m1, cc.materials.isotropic(E=70e9, nu=0.3), clamped="top", contact="bottom", **load)
    b2 = cc.Body(m2, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", contact="top")
    return cc.Scene(b1, b2, gap=gap)


def assert_grid(mesh, y0, y1):
    """The mesh still holds the 5 x 3 grid of points of rectangle([0, 1] x [y0, y1], nx=4, ny=2)."""
    assert mesh.points.shape == (15, 2)
    assert np.array_equal(np.unique(mesh.points[:, 0]), np.linspace(0.0, 1.0, 5))
    assert np.array_equal(np.unique(mesh.points[:, 1]), np.linspace(y0, y1, 3))


# ------------------------------------------------------------------- the output-array traps

def test_output_array_traps_in_a_scene_file_are_refused(tmp_path):
    body = """
        [[body]]
        material = {{ E = 70e9, nu = 0.3 }}
        mesh = {{ rectangle = {{ x = [0.0, 1.0], y = [{y}], nx = 4, ny = 2 }} }}
        clamped = "{clamped}"
        contact = "{contact}"
        body_force = {force}
        """
    for head, force, name in [('gap = "0*exp(x, x)"', '[0.0, -1e9]', "exp"),
                              ("", '["0*sin(x, y)", "-2e9*(1+y)"]', "sin")]:
        text = head + textwrap.dedent(body.format(y="0.0, 0.5", clamped="top", contact="bottom", force=force)
                                      + body.format(y="-0.5, 0.0", clamped="bottom", contact="top", force="[0, 0]"))
        path = tmp_path / "trap.toml"
        path.write_text(text)
        with pytest.raises(cc.SceneError, match=f"function '{name}' takes exactly 1 argument, got 2"):
            load_scene(path)


@pytest.mark.parametrize("text", ["0*exp(x, x)", "0*sin(x, y)"])
def test_output_array_traps_are_refused_at_parse(text):
    with pytest.raises(cc.CvxContactError, match="takes exactly 1 argument"):
        Expression(text)


@pytest.mark.parametrize("attack", ["imul", "zero"])
def test_a_callable_gap_cannot_move_the_contact_nodes(attack):
    def gap(x):
        if attack == "imul":
            x *= 2
        else:
            x[:] = 0
        return 0.0 * x

    try:
        scene = small_scene(gap=gap)
    except cc.CvxContactError:
        scene = small_scene()                      # refused: the state of a fresh scene is checked below
    else:
        scene.gap_values()
        scene.gap_values()
    assert np.array_equal(scene.interface.x, np.linspace(0.0, 1.0, 5))
    assert_grid(scene.bodies[0].mesh, 0.0, 0.5)


def test_a_load_component_cannot_change_what_the_other_one_sees():
    x, y = np.linspace(0.0, 1.0, 5), np.linspace(-1.0, 0.0, 5)

    def force(x, y):
        y[:] = np.sin(x)                           # would make the second component see y = sin(x)
        return 0.0 * x, y

    try:
        out = Load(force, "body_force", 2)(x, y)
    except cc.CvxContactError:
        pass
    else:
        assert np.array_equal(out[:, 1], np.linspace(-1.0, 0.0, 5))
    assert np.array_equal(x, np.linspace(0.0, 1.0, 5)) and np.array_equal(y, np.linspace(-1.0, 0.0, 5))


def test_expression_never_writes_into_its_inputs():
    x, y = np.linspace(0.0, 1.0, 5), np.linspace(-1.0, 0.0, 5)
    out = Expression("where(x < 0.5, minimum(x, y), maximum(x, y)) + heaviside(x - 0.5)")(x, y)
    out[:] = 7.0
    assert np.array_equal(x, np.linspace(0.0, 1.0, 5)) and np.array_equal(y, np.linspace(-1.0, 0.0, 5))


# ------------------------------------------------------------------------------ arities

@pytest.mark.parametrize("name,args,want", [(f, a, 1) for f in UNARY for a in ("", "x, y")]
                         + [(f, a, 2) for f in BINARY for a in ("x", "x, y, x")]
                         + [("where", "x < 0", 3), ("where", "x < 0, x, y, x", 3)])
def test_every_function_takes_exactly_its_arity(name, args, want):
    with pytest.raises(ExpressionError, match=f"'{name}' takes exactly {want} argument"):
        Expression(f"{name}({args})")


@pytest.mark.parametrize("name", UNARY + BINARY + ["where"])
def test_every_function_with_its_arity_agrees_with_numpy(name):
    x, y = np.linspace(0.1, 0.9, 5), np.linspace(0.2, 0.6, 5)
    reference = {"abs": np.abs(x), "heaviside": np.heaviside(x, 0.5), "where": np.where(x < 0.5, x, y)}
    if name in BINARY:
        expected, text = getattr(np, name)(x, y), f"{name}(x, y)"
    elif name == "where":
        expected, text = reference["where"], "where(x < 0.5, x, y)"
    else:
        expected, text = reference[name] if name in reference else getattr(np, name)(x), f"{name}(x)"
    assert np.allclose(Expression(text)(x, y), expected, rtol=1e-14, atol=0)


# ------------------------------------------------------------------------- size limits

def test_990_unary_minus_signs_give_a_typed_error():
    with pytest.raises(ExpressionError, match="nested more than"):
        Expression("-" * 990 + "x")


@pytest.mark.parametrize("depth", [2000, 20000])
def test_deep_nesting_gives_a_typed_error_even_without_the_length_limit(monkeypatch, depth):
    monkeypatch.setattr(expr, "_MAX_LENGTH", 10 ** 6)        # reach the parser and the depth check
    with pytest.raises(ExpressionError, match="nested"):
        Expression("-" * depth + "x")


def test_too_many_terms_give_a_typed_error(monkeypatch):
    monkeypatch.setattr(expr, "_MAX_LENGTH", 10 ** 6)

    def balanced(levels):                                     # depth `levels`, 2**levels leaves
        return "x" if levels == 0 else f"minimum({balanced(levels - 1)}, {balanced(levels - 1)})"

    with pytest.raises(ExpressionError, match="terms"):
        Expression(balanced(12))


def test_reasonable_nesting_still_evaluates():
    x = np.linspace(0.0, 1.0, 5)
    assert np.array_equal(Expression("-" * 150 + "x")(x, x), x)
    assert np.allclose(Expression("+".join(["x"] * 150))(x, x), 150 * x)


def test_expression_error_is_a_typed_scene_error():
    assert issubclass(ExpressionError, cc.SceneError) and issubclass(ExpressionError, cc.CvxContactError)
    with pytest.raises(cc.CvxContactError):
        Expression("1" + "0" * 400)                           # an integer no float can hold


# ------------------------------------------------------------------- boolean / complex loads

@pytest.mark.parametrize("load,label", [
    (dict(body_force=(True, 0)), "body_force"),
    (dict(body_force=np.array([True, False])), "body_force"),
    (dict(body_force=(0.0, 1j)), "body_force"),
    (dict(traction={"right": (np.bool_(False), 0.0)}), "traction['right']"),
    (dict(traction={"right": np.array([0.0, 1.0 + 0j])}), "traction['right']"),
])
def test_boolean_and_complex_loads_are_refused(load, label):
    with pytest.raises(cc.SceneError, match=label.replace("[", r"\[")):
        small_scene(**load)


@pytest.mark.parametrize("gap", [True, 1j, np.bool_(False)])
def test_boolean_and_complex_gaps_are_refused(gap):
    with pytest.raises(cc.SceneError, match="scene: gap"):
        small_scene(gap=gap)


def test_volume_charge_must_be_real():
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=2, ny=1)
    for q in (1j, True):
        with pytest.raises(cc.SceneError, match="volume_charge"):
            cc.Body(m, cc.materials.PZT5A, clamped="top", grounded="top", contact="bottom", volume_charge=q)


@pytest.mark.parametrize("result", [lambda x: 0 * x + 1e9j, lambda x: x > 0.5])
def test_a_callable_load_returning_complex_or_boolean_values_is_refused(result):
    scene = small_scene(body_force=lambda x, y: (0.0 * x, result(x)))
    with pytest.raises(cc.SceneError, match="body_force"):
        cc.solve(scene)


# --------------------------------------------------------------- stale solver caches

def test_a_reused_solver_notices_an_edited_mesh():
    scene = small_scene()
    solver = cc.ContactSolver(scene)
    solver.solve()
    mesh = scene.bodies[0].mesh
    with pytest.raises(ValueError, match="read-only"):
        mesh.points[:, 1] *= 2.0                     # the edit itself is refused: the arrays are read-only
    with pytest.raises(cc.FrozenError, match=r"Body\.mesh.*with_changes\(mesh="):
        scene.bodies[0].mesh = mesh.with_points(mesh.points * [1.0, 2.0])     # and so is a new mesh
    with pytest.raises(ValueError):                  # nor can the array be made writeable again
        mesh.points.setflags(write=True)
    assert solver.accepts(scene)                     # (a moved copy is other geometry: the test below)


def test_a_reused_solver_notices_an_edited_material():
    scene = small_scene()
    solver = cc.ContactSolver(scene)
    with pytest.raises(ValueError, match="read-only"):
        scene.bodies[1].material.c[2, 2] *= 1.5      # the edit itself is refused
    with pytest.raises(cc.FrozenError, match=r"Elastic\.c"):
        scene.bodies[1].material.c = 1.5 * scene.bodies[1].material.c
    with pytest.raises(ValueError):                  # nor can the array be made writeable again
        scene.bodies[1].material.c.setflags(write=True)
    assert solver.accepts(scene)


def test_equal_geometry_built_twice_is_accepted_and_other_geometry_is_not():
    solver = cc.ContactSolver(small_scene())
    assert solver.accepts(small_scene(body_force=(1e8, -3e9), gap=-1e-6))
    other = small_scene()
    assert geometry_fingerprint(other.bodies[0]) == geometry_fingerprint(small_scene().bodies[0])
    mesh = other.bodies[0].mesh
    points = np.array(mesh.points)
    points[0, 0] += 1e-12                            # (the mesh's own memory cannot be written: a moved copy)
    moved = other.with_bodies(other.bodies[0].with_changes(mesh=mesh.with_points(points)), *other.bodies[1:])
    assert not solver.accepts(moved)
