"""Command line, scene files, output files and figures."""

import json
import shutil
import subprocess
from pathlib import Path

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.cli import main
from cvxcontact.apps.demo import two_blocks
from cvxcontact.io.output import atomic_write
from cvxcontact.io.scenefile import load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_demo_writes_vtu_png_and_summary(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--nx", "6", "-q"]) == 0
    for c in cc.CONDITIONS:
        for part in ("body1", "body2", "contact"):
            assert (tmp_path / f"{c}_{part}.vtu").stat().st_size > 0
        summary = json.loads((tmp_path / f"{c}.json").read_text())
        assert summary["status"] == "optimal" and summary["ok"] and summary["contact"]["active_nodes"] > 0
        assert summary["bodies"][0]["electric_unknowns"] and not summary["bodies"][1]["electric_unknowns"]
    for png in ("contact.png", "deformed_potential.png", "deformed_von_mises.png"):
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert capsys.readouterr().err == ""  # --quiet


def test_vtu_round_trip_holds_the_solution_with_units(tmp_path):
    scene = two_blocks(6)
    sol = cc.solve(scene)
    from cvxcontact.io.output import write_vtu

    write_vtu(sol, tmp_path)
    body = meshio.read(tmp_path / "solution_body1.vtu")
    assert np.allclose(body.point_data["displacement [m]"][:, :2], sol.u[0], rtol=1e-12, atol=0)
    assert np.allclose(body.point_data["electric potential [V]"], sol.phi[0], rtol=1e-12, atol=0)
    for name in ("stress [Pa]", "strain [-]", "von Mises stress [Pa]", "electric field [V/m]",
                 "electric displacement [C/m^2]"):
        assert name in body.cell_data
    elastic = meshio.read(tmp_path / "solution_body2.vtu")
    assert "electric potential [V]" not in elastic.point_data
    line = meshio.read(tmp_path / "solution_contact.vtu")
    assert np.allclose(line.point_data["lambda_h (diagnostic) [Pa]"], sol.contact.lam, rtol=1e-12, atol=0)


def test_fields_of_the_exact_patch_solution():
    """Uniform stress state: every element carries the closed-form stress and field."""
    from reference_problems import bonded_patch

    from cvxcontact.fem.fields import body_fields

    scene, exact = bonded_patch(5, 4, voltage=-1e4)
    sol = cc.solve(scene)
    f = body_fields(scene.bodies[0], sol.u[0], sol.phi[0])
    assert np.allclose(f.electric_field[:, 1], 1e4, rtol=1e-8) and np.allclose(f.electric_field[:, 0], 0, atol=1e-3)
    assert np.allclose(f.stress[:, 1], -exact["lam"], rtol=1e-7)            # sigma_yy = -lambda
    g = body_fields(scene.bodies[1], sol.u[1], None)
    assert np.allclose(g.stress[:, 1], -exact["lam"], rtol=1e-7) and g.electric_field is None


def test_scene_file_equals_api_scene(tmp_path):
    spec = load_scene(EXAMPLES / "two_blocks.toml")
    from_file = spec.solve()
    b1, b2 = spec.scene.bodies
    assert b1.piezoelectric and not b2.piezoelectric and spec.condition == "gamma3"
    api = cc.solve(two_blocks(16))
    assert np.array_equal(b1.mesh.points, two_blocks(16).bodies[0].mesh.points)
    assert np.allclose(from_file.u[0], api.u[0], rtol=0, atol=1e-14 * np.abs(api.u[0]).max())


def test_scene_file_gap_expression(tmp_path):
    """A parabolic gap in a scene file equals the same gap given to the API."""
    text = (EXAMPLES / "two_blocks.toml").read_text().replace(
        'condition = "gamma3"', 'condition = "gamma3"\ngap = "(x - 0.5)**2 / 2 - 1e-3"')
    path = tmp_path / "gap.toml"
    path.write_text(text)
    spec = load_scene(path)
    assert np.allclose(spec.scene.gap_values(), (spec.scene.interface.x - 0.5) ** 2 / 2 - 1e-3)
    b1, b2 = spec.scene.bodies
    api = cc.solve(cc.Scene(b1, b2, gap=lambda x: (x - 0.5) ** 2 / 2 - 1e-3))
    assert np.allclose(spec.solve().u[0], api.u[0], rtol=0, atol=1e-13 * np.abs(api.u[0]).max())
    assert np.allclose(api.contact.gap, (api.contact.x - 0.5) ** 2 / 2 - 1e-3)


def test_solve_command_all_conditions_and_info(tmp_path, capsys):
    scene = EXAMPLES / "gmsh_scene.toml"
    assert main(["solve", str(scene), "--out", str(tmp_path), "--condition", "all", "--no-plots"]) == 0
    out = capsys.readouterr()
    assert "results in" in out.out and "solving condition sigma2" in out.err  # progress on stderr
    assert sorted(p.name for p in tmp_path.glob("*.json")) == ["gamma3.json", "sigma1.json", "sigma2.json"]
    assert main(["info", str(scene)]) == 0
    info = capsys.readouterr().out
    assert "151 potential (electric unknowns)" in info and "no electric unknowns (elastic)" in info


def test_cli_errors_are_one_line_with_nonzero_exit(tmp_path, capsys):
    assert main(["solve", str(tmp_path / "missing.toml")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("cvxcontact: error:") and "does not exist" in err[-1]
    with pytest.raises(SystemExit) as exc:
        main(["frobnicate"])
    assert exc.value.code == 2


@pytest.mark.skipif(shutil.which("cvxcontact") is None, reason="console script not installed (pip install .)")
def test_console_script_is_installed(tmp_path):
    run = subprocess.run(["cvxcontact", "demo", "--out", str(tmp_path), "--nx", "4", "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "gamma3_body1.vtu").exists()


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    def broken(path):
        Path(path).write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError):
        atomic_write(tmp_path / "result.json", broken)
    assert list(tmp_path.iterdir()) == []


def test_plots_have_labels_and_colorbars():
    import matplotlib

    matplotlib.use("Agg")
    from cvxcontact.io.plot import plot_contact, plot_deformed

    sols = {c: cc.solve(two_blocks(6), c) for c in cc.CONDITIONS}
    fig = plot_deformed(sols["gamma3"], "potential")
    main_ax, cbar = fig.axes
    assert main_ax.get_xlabel() == "x1" and "x" in main_ax.get_title() and cbar.get_ylabel() == "electric potential"
    assert main_ax.xaxis.get_major_formatter().unit == "m" and cbar.yaxis.get_major_formatter().unit == "V"
    fig = plot_contact(sols)
    assert len(fig.axes) == 9 and all(ax.get_ylabel() and ax.yaxis.get_major_formatter().unit in ("Pa", "m")
                                      for ax in fig.axes)


def test_cli_prints_the_report_of_the_solution(tmp_path, capsys):
    """`cvxcontact solve` prints ``sol.report()`` itself (one source), and the report holds a line per contact pair
    (its total force, the nodes in contact, the active ones) and per electrode (its potential and charge): the
    stack of examples/stack.toml, two pairs and a floating electrode, against a solve of the same scene file."""
    scene = EXAMPLES / "stack.toml"
    assert main(["solve", str(scene), "--out", str(tmp_path), "--no-plots", "--condition", "gamma3"]) == 0
    printed = capsys.readouterr().out
    sol = load_scene(scene).solve("gamma3")
    report = sol.report()
    assert report in printed
    lines = report.splitlines()
    for i, c in enumerate(sol.contacts):
        (line,) = [ln for ln in lines if ln.startswith(f"  contact[{i}] ")]
        assert f"force {c.force.sum():.6g} N/m" in line and f"{int(c.active.sum())} of {int(c.constrained.sum())} " \
            "constrained nodes active" in line and f"of {len(c.x)} nodes" in line
    floating = [e for e in sol.electrodes if e.kind == "floating"]
    assert floating
    for e in sol.electrodes:
        name = sol.scene.bodies[e.body].name
        assert (f"  electrode {name}/{e.tag} ({e.kind}): potential {e.potential:.6g} V, charge {e.charge:.6g} C/m"
                in lines)


@pytest.mark.parametrize("mesh, counts", [
    ('{ rectangle = { x = [0.0, 1.0], y = [Y0, Y1], nx = 6, ny = 3, cell = "quad" } }',
     ("91 nodes, 18 quads (Q2)", "unknowns: 156 displacement")),         # 13 x 7 nodes, 13 clamped: 2 x 78
    ('{ box = { x = [0.0, 1.0], y = [0.0, 1.0], z = [Y0, Y1], nx = 2, ny = 2, nz = 1, cell = "hex" } }',
     ("75 nodes, 4 hexahedra (Q2)", "unknowns: 150 displacement")),      # 5 x 5 x 3 nodes, 25 clamped: 3 x 50
], ids=["quads", "hexahedra"])
def test_info_counts_the_unknowns_of_the_file_s_cells_and_degree(tmp_path, capsys, mesh, counts):
    """`cvxcontact info` on Q2 quadrilateral and hexahedral scene files (before: a traceback, the P1 simplex
    assembly): the nodes and unknowns of the file's degree on its cells, counted by hand."""
    bodies = "".join(f'''
[[body]]
name = "{name}"
material = {{ E = 200e9, nu = 0.3 }}
mesh = {mesh.replace("Y0", lo).replace("Y1", hi)}
contact = "{part}"
clamped = ["{held}"]
''' for name, lo, hi, part, held in (("upper", "0.5", "1.0", "bottom", "top"), ("lower", "0.0", "0.5", "top", "bottom")))
    path = tmp_path / "scene.toml"
    path.write_text('condition = "sigma1"\ndegree = 2\n' + bodies, encoding="utf-8")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert all(words in out for words in counts), out
