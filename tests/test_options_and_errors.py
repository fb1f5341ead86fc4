"""Solver options in their own namespace, checked before any work; every user error typed and clear."""

import importlib
import os
import textwrap

import numpy as np
import pytest

import cvxcontact as cc
import cvxcontact.geometry.mesh as mesh_mod
from cvxcontact.apps.cli import main
from cvxcontact.io.scenefile import SceneFileError, load_scene

from conftest import two_blocks

solve_mod = importlib.import_module("cvxcontact.solve")     # the module, not the function cc.solve


@pytest.fixture(scope="module")
def small():
    return two_blocks((6, 3), (5, 3))


@pytest.fixture
def no_assembly(monkeypatch):
    """Fail loudly if a bad parameter gets as far as assembly."""
    def boom(*a, **k):
        raise AssertionError("assembly started before the parameters were checked")
    from cvxcontact.fem import space
    monkeypatch.setattr(space, "assemble_matrices", boom)


# ------------------------------------------------------------------------------ solver options

@pytest.mark.parametrize("options,words", [
    ({"tol": 1e-3}, "use the tol argument"),
    ({"solver": "OSQP"}, "use the solver argument"),
    ({"condition": "sigma1"}, "use the condition argument"),
    ({"scale": False}, "scale argument of ContactSolver"),
    ({"warm_start": False}, "warm_start argument of ContactSolver"),
    ({"verbose": True}, "use the verbose argument"),
    ({"max_iters": 5}, "did you mean ['max_iter'"),
    ({"tol_gap": 1e-9}, "unknown Clarabel option 'tol_gap'"),
    ({"max_iter": 10.5}, "'max_iter' must be an integer"),
    ({"max_iter": True}, "'max_iter' must be an integer"),
    ({"equilibrate_enable": 1}, "'equilibrate_enable' must be true or false"),
    ({"direct_solve_method": 3}, "'direct_solve_method' must be a string"),
    ({"tol_feas": -1e-8}, "'tol_feas' must be > 0"),
    ({"tol_gap_rel": 0}, "'tol_gap_rel' must be > 0"),
    ({"tol_feas": float("nan")}, "'tol_feas' must be finite"),
    ({"time_limit": float("inf")}, "'time_limit' must be finite"),
    ({"time_limit": 0.0}, "'time_limit' must be > 0"),
    ({"max_iter": 0}, "'max_iter' must be an integer from 1"),
    ({"max_iter": 2**40}, "'max_iter' must be an integer from 1"),
    ({"max_threads": -1}, "'max_threads' must be an integer from 0"),
    ({"max_iter": [1]}, "must be a bool, int, float or str"),
    ({1: 2}, "names must be non-empty strings"),
    ("max_iter=3", "solver_options must be a dict"),
])
def test_bad_solver_options_refused_before_assembly(small, no_assembly, options, words):
    with pytest.raises(cc.SolverError) as info:
        cc.solve(small, solver_options=options)
    assert words in str(info.value)
    with pytest.raises(cc.SolverError):
        cc.ContactSolver(small, method="condensed", solver_options=options)


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")
def test_solver_options_reach_the_solver_and_are_not_mutated(small):
    options = {"max_iter": 1, "time_limit": 100}            # int accepted for a float setting
    with pytest.raises(cc.SolverError, match="status"):    # one iteration cannot reach optimality
        cc.solve(small, polish=False, solver_options=options)
    assert options == {"max_iter": 1, "time_limit": 100}
    sol = cc.solve(small, solver_options={"max_iter": 50, "time_limit": 100.0, "equilibrate_enable": True})
    assert sol.ok


def test_solver_refusing_a_value_gives_solver_error(small):
    with pytest.raises(cc.SolverError, match="direct_solve_method"):
        cc.solve(small, solver_options={"direct_solve_method": "no-such-method"})


def test_other_solvers_get_generic_checks(small):
    import cvxpy

    if "OSQP" not in cvxpy.installed_solvers():
        pytest.skip("OSQP is not installed")
    with pytest.raises(cc.SolverError, match="use the tol argument"):
        cc.solve(small, solver="OSQP", solver_options={"tol": 1.0})
    with pytest.raises(cc.SolverError, match="OSQP"):
        cc.solve(small, solver="OSQP", solver_options={"no_such_osqp_option": 1})


# ------------------------------------------------------------------------------ simple parameters

@pytest.mark.parametrize("kw,words", [
    (dict(tol=float("inf")), "tol must be a finite positive number"),
    (dict(tol=float("nan")), "tol must be a finite positive number"),
    (dict(tol="1e-6"), "tol must be a finite positive number"),
    (dict(polish="no"), "polish must be True or False"),
    (dict(polish=1), "polish must be True or False"),
    (dict(verbose="yes"), "verbose must be True or False"),
])
def test_bad_solve_parameters_name_the_parameter(small, no_assembly, kw, words):
    with pytest.raises(cc.SolverError, match=words):
        cc.solve(small, **kw)


@pytest.mark.parametrize("kw,words", [
    (dict(warm_start="yes"), "warm_start must be True or False"),
    (dict(scale=0), "scale must be True or False"),
])
def test_bad_contact_solver_flags(small, no_assembly, kw, words):
    with pytest.raises(cc.SolverError, match=words):
        cc.ContactSolver(small, **kw)


# ------------------------------------------------------------------------------ mesh size

def test_rectangle_too_large_for_the_machine(monkeypatch):
    monkeypatch.setattr(mesh_mod, "physical_memory", lambda: 10**8)     # a 0.1 GB machine
    with pytest.raises(cc.MeshError) as info:
        cc.rectangle(nx=100, ny=100)
    msg = str(info.value)
    assert "nx*ny = 1e+04 cells" in msg and "nodes" in msg and "GB" in msg and "machine has 0.1 GB" in msg
    assert cc.rectangle(nx=4, ny=4).points.shape == (25, 2)


def test_absurd_rectangle_refused_without_memory_information(monkeypatch):
    def no_sysconf(name):
        raise ValueError(name)
    monkeypatch.setattr(os, "sysconf", no_sysconf)
    with pytest.raises(cc.MeshError, match=r"nx\*ny = 1e\+12 cells is more than the limit"):
        cc.rectangle(nx=10**12, ny=1)
    assert len(cc.rectangle(nx=3, ny=2).triangles) == 12                  # falls back gracefully


# ------------------------------------------------------------------------------ mesh files

@pytest.mark.parametrize("name,text", [
    ("format.msh", "$MeshFormat\nSECRET-CONTENT 0 8\n$EndMeshFormat\n"),
    ("nodes.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\nSECRET-CONTENT\n$EndNodes\n"),
    ("points.obj", "v SECRET-CONTENT 1 2\n"),
])
def test_read_mesh_does_not_echo_file_content(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(cc.MeshError) as info:
        cc.read_mesh(path)
    msg = str(info.value)
    assert "SECRET" not in msg and str(path) in msg and "ValueError" in msg


# ------------------------------------------------------------------------------ scene files

SCENE = """
[solver]
{solver}

[[body]]
material = "PZT-5A"
mesh = {{ rectangle = {{ x = [0.0, 1.0], y = [0.0, 0.5], nx = 4, ny = 2 }} }}
clamped = ["top"]
grounded = ["top"]
contact = "bottom"
body_force = [0.0, -1e9]

[[body]]
material = {{ E = 70e9, nu = 0.3 }}
mesh = {mesh}
clamped = "bottom"
contact = "top"
"""
RECT = "{ rectangle = { x = [0.0, 1.0], y = [-0.5, 0.0], nx = 3, ny = 2 } }"


def write_scene(folder, solver="", mesh=RECT):
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.toml"
    path.write_text(textwrap.dedent(SCENE.format(solver=solver, mesh=mesh)))
    return path


@pytest.mark.parametrize("solver,words", [
    ("tol = inf", "solver.tol: expected a finite positive number"),
    ("tol = nan", "solver.tol: expected a finite positive number"),
    ('name = "NOSUCH"', "solver.name: solver 'NOSUCH' is not available"),
    ("options = { tol = 1e-3 }", "solver.options: solver option 'tol' is not a solver option"),
    ("options = { condition = 'sigma1' }", "solver.options: solver option 'condition'"),
    ("options = { max_iters = 10 }", "solver.options: unknown Clarabel option 'max_iters'; did you mean ['max_iter'"),
    ("options = { max_iter = 1.5 }", "solver.options: Clarabel option 'max_iter' must be an integer"),
    ("options = { max_iter = -3 }", "solver.options: Clarabel option 'max_iter' must be an integer from 1"),
    ("options = { tol_feas = nan }", "solver.options: solver option 'tol_feas' must be finite"),
    ("options = { presolve_enable = 'no' }", "solver.options: Clarabel option 'presolve_enable' must be true"),
    ("options = { nested = { a = 1 } }", "must be a bool, int, float or str"),
])
def test_scene_file_solver_table(tmp_path, solver, words):
    path = write_scene(tmp_path, solver)
    with pytest.raises(SceneFileError) as info:
        load_scene(path)
    assert str(path) in str(info.value) and words in str(info.value)


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")
def test_scene_file_options_go_to_the_solver(tmp_path):
    spec = load_scene(write_scene(tmp_path, "options = { max_iter = 60, time_limit = 100 }"))
    assert spec.settings["solver_options"] == {"max_iter": 60, "time_limit": 100.0}
    assert "max_iter" not in spec.settings
    assert spec.solve().ok and cc.solve(spec.scene, **spec.settings).ok
    with pytest.raises(cc.SolverError, match="status"):
        spec.solve(polish=False, solver_options={"max_iter": 1})


def _mesh_file(path):
    import meshio

    m = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=3, ny=2)
    lines = np.concatenate([m.boundary(t) for t in ("bottom", "top")])
    tags = np.concatenate([np.full(len(m.boundary(t)), i + 1) for i, t in enumerate(("bottom", "top"))])
    meshio.write(path, meshio.Mesh(np.column_stack([m.points, 0 * m.points[:, 0]]),
                                   [("triangle", m.triangles), ("line", lines)],
                                   cell_data={"gmsh:physical": [np.zeros(len(m.triangles), int), tags],
                                              "gmsh:geometrical": [np.zeros(len(m.triangles), int), tags]},
                                   field_data={"bottom": np.array([1, 1]), "top": np.array([2, 1])}),
                 file_format="gmsh22", binary=False)


@pytest.mark.parametrize("where", ["parent", "absolute", "symlink"])
def test_mesh_paths_confined_to_the_scene_folder(tmp_path, where):
    _mesh_file(tmp_path / "lower.msh")
    folder = tmp_path / "scene"
    folder.mkdir()
    ref = {"parent": "../lower.msh", "absolute": str(tmp_path / "lower.msh"), "symlink": "link.msh"}[where]
    if where == "symlink":
        (folder / "link.msh").symlink_to(tmp_path / "lower.msh")
    path = write_scene(folder, mesh=f"{{ file = {ref!r} }}")
    with pytest.raises(SceneFileError) as info:
        load_scene(path)
    assert str(path) in str(info.value) and "body[1].mesh.file" in str(info.value)
    assert "allow_outside" in str(info.value)
    spec = load_scene(path, allow_outside=True)
    assert len(spec.scene.bodies[1].mesh.triangles) == 12
    assert main(["info", str(path), "-q"]) == 1
    assert main(["info", str(path), "-q", "--allow-outside-mesh"]) == 0


def test_mesh_file_inside_the_folder_still_loads(tmp_path):
    (tmp_path / "meshes").mkdir()
    _mesh_file(tmp_path / "meshes" / "lower.msh")
    spec = load_scene(write_scene(tmp_path, mesh='{ file = "meshes/../meshes/lower.msh" }'))
    assert len(spec.scene.bodies[1].mesh.triangles) == 12
    with pytest.raises(SceneFileError, match="allow_outside must be True or False"):
        load_scene(write_scene(tmp_path), allow_outside="yes")


# ------------------------------------------------------------------------------ results

def test_traction_and_plot_errors_are_typed(solutions):
    sol = solutions["gamma3"]
    for k in (2, -1, 1.0, "1", True):
        with pytest.raises(cc.CvxContactError, match="k must be 0 or 1"):
            sol.traction(k)
    assert len(sol.traction(1)[0]) == len(sol.scene.interface.traces[1].x)
    from cvxcontact.io.plot import plot_deformed

    with pytest.raises(cc.CvxContactError, match=r"field must be one of \['potential', 'von_mises'\]"):
        plot_deformed(sol, "displacement")
    with pytest.raises(cc.CvxContactError, match="magnify must be"):
        plot_deformed(sol, magnify="big")


def test_sweep_and_cli_accept_the_opt_out(tmp_path):
    from cvxcontact.apps.cli import _parser
    from cvxcontact.apps.sweep import run_sweep

    _mesh_file(tmp_path / "lower.msh")
    write_scene(tmp_path / "scene", mesh='{ file = "../lower.msh" }')
    sweep = tmp_path / "scene" / "sweep.toml"
    sweep.write_text('scene = "scene.toml"\n')
    with pytest.raises(cc.CvxContactError, match="leads outside the scene file's folder"):
        run_sweep(sweep, tmp_path / "out1", workers=1)                 # refused up front (issue 12)
    allowed = run_sweep(sweep, tmp_path / "out2", workers=1, allow_outside=True)
    assert allowed.done == allowed.total == 1 and not allowed.failed
    for argv in (["solve", "s.toml"], ["info", "s.toml"], ["sweep", "w.toml", "--out", "o"]):
        assert _parser().parse_args(argv + ["--allow-outside-mesh"]).allow_outside_mesh
        assert not _parser().parse_args(argv).allow_outside_mesh
