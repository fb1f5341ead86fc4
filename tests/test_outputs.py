"""Outputs a scientist can use: the pressure felt by each body, VTU/PVD files, figures, the CLI's first hour."""

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.interface import lumped_lengths

ROOT = Path(__file__).resolve().parents[1]


def interference(soft, nx=(7, 5), E=1e9, ratio=1e8, h=0.5, delta=1e-4):
    """Two nu = 0 blocks clamped at their far faces, pressed together by an interference ``delta`` (m).

    Body ``soft`` has Young's modulus E, the other E * ratio (nearly rigid). With nu = 0 the soft
    block is in uniaxial strain, so the exact contact pressure is E delta / h whatever its mesh:
    P1 reproduces it, and any error is of order 1/ratio."""
    mats = [cc.materials.isotropic(E=E * (1.0 if k == soft else ratio), nu=0.0) for k in range(2)]
    m1 = cc.rectangle(x=(0, 1), y=(0, h), nx=nx[0], ny=2)
    m2 = cc.rectangle(x=(0, 1), y=(-h, 0), nx=nx[1], ny=2)
    b1 = cc.Body(m1, mats[0], clamped=["top"], contact="bottom")
    b2 = cc.Body(m2, mats[1], clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, gap=-delta), E * delta / h


@pytest.mark.parametrize("condition,soft", [("sigma1", 0), ("sigma2", 1), ("gamma3", 0), ("gamma3", 1)])
def test_pressure_of_uniform_compression_is_exact_on_non_matching_meshes(condition, soft):
    """The nodal pressure divides each force by the lumped length of the mesh that carries it
    (mesh l for sigma_l). Dividing by the merged mesh's lengths (the former bias) is off by tens of %."""
    scene, p = interference(soft)
    sol = cc.solve(scene, condition)
    c = sol.contact
    x, felt = sol.traction(soft)
    assert sol.ok and np.abs(felt / p - 1).max() < 1e-6
    if condition != "gamma3":
        assert np.abs(c.pressure[c.constrained] / p - 1).max() < 1e-6
        assert np.all(c.pressure[~c.constrained] == 0)
        biased = c.force[c.constrained] / lumped_lengths(c.x)[c.constrained]      # the former definition
        assert np.abs(biased / p - 1).max() > 0.1


def test_first_pressure_shown_is_the_pressure_felt_by_each_body(tmp_path):
    """VTU and JSON lead with the pressure on each body's own trace nodes; lambda_h is named a diagnostic.
    On the demo scene (loads / 100) each body feels 1.7-2.9 MPa in the middle of the line, for all
    three conditions, while lambda_h is negative somewhere and peaks above 5 MPa."""
    from cvxcontact.apps.demo import DEMO_LOAD_SCALE, two_blocks
    from cvxcontact.io.output import summary, write_vtu

    scene = two_blocks(12, scale=DEMO_LOAD_SCALE)
    for condition in cc.CONDITIONS:
        sol = cc.solve(scene, condition)
        write_vtu(sol, tmp_path, condition)
        line = meshio.read(tmp_path / f"{condition}_contact.vtu")
        assert np.allclose(line.point_data["lambda_h (diagnostic) [Pa]"], sol.contact.lam, rtol=1e-12, atol=0)
        itf = scene.interface
        for k in range(2):
            x, p = sol.traction(k)
            mid = (x > 0.3) & (x < 0.7)
            assert np.all((p[mid] > 1.5e6) & (p[mid] < 3.0e6))
            own = meshio.read(tmp_path / f"{condition}_contact_body{k + 1}.vtu")
            assert np.array_equal(own.points[:, 0], x) and np.allclose(own.point_data[f"pressure on body {k + 1} [Pa]"], p)
            # the line warps with its body: its displacement is the body's own at the trace nodes
            nodes = itf.traces[k].nodes
            assert np.array_equal(own.point_data["displacement [m]"][:, :2], sol.u[k][nodes])
            side = line.point_data[f"displacement body {k + 1} [m]"][:, :2]
            assert np.allclose(side[itf.sigma[k]], sol.u[k][nodes], rtol=0, atol=1e-15)   # at its own nodes
        assert sol.contact.lam.max() > 5e6 and sol.contact.lam.min() < 0
        s = summary(sol)["contact"]
        assert list(s)[0] == "pressure_on_body_Pa" and "max_lambda_Pa" not in s
        for k, entry in enumerate(s["pressure_on_body_Pa"]):
            assert entry["max"] == pytest.approx(sol.traction(k)[1].max(), rel=1e-12)
            assert 1.5e6 < entry["mean"] < 3.0e6
        assert s["lambda_h_diagnostic_Pa"]["max"] == pytest.approx(sol.contact.lam.max(), rel=1e-12)
    body = meshio.read(tmp_path / "gamma3_body2.vtu")
    sol = cc.solve(scene, "gamma3")
    from cvxcontact.fem.fields import body_fields

    f = body_fields(scene.bodies[1], sol.u[1], None)
    for name, col in (("xx", 0), ("yy", 1), ("zz", 2), ("xy", 3)):
        assert np.allclose(body.cell_data[f"stress {name} [Pa]"][0], f.stress[:, col], rtol=1e-12, atol=0)
    assert np.allclose(body.cell_data["strain xy [-]"][0], f.strain[:, 2], rtol=1e-12, atol=0)


def test_penetration_at_unconstrained_nodes_is_flagged():
    """sigma1 on meshes where body 2 is fine and stiff enough to bulge between body 1's nodes: some
    of body 2's nodes penetrate; they are flagged, the constrained ones are not."""
    import matplotlib

    matplotlib.use("Agg")
    from cvxcontact.io.plot import plot_contact

    m1 = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=3, ny=2)
    m2 = cc.rectangle(x=(0, 1), y=(-0.5, 0), nx=16, ny=4)
    b1 = cc.Body(m1, cc.materials.isotropic(E=200e9, nu=0.3), clamped=["top"], contact="bottom",
                 body_force=(0.0, -1e9))
    b2 = cc.Body(m2, cc.materials.isotropic(E=1e9, nu=0.3), clamped=["bottom"], contact="top")
    sol = cc.solve(cc.Scene(b1, b2), "sigma1")
    c = sol.contact
    pen = c.penetration
    assert not pen[c.constrained].any() and pen[~c.constrained].any()
    assert np.array_equal(pen, c.jump - c.gap > 1e-9 * np.abs(c.jump).max())
    fig = plot_contact(sol)
    flagged = [ln for ln in fig.axes[2].lines if ln.get_label() == "penetration at an unconstrained node"]
    assert len(flagged) == 1 and len(flagged[0].get_xdata()) == int(pen.sum())


def test_demo_writes_pvd_and_figures_for_every_condition(tmp_path, monkeypatch, capsys):
    from cvxcontact.apps.cli import main

    assert main(["demo", "--out", str(tmp_path), "--nx", "4", "-q"]) == 0
    tree = ET.parse(tmp_path / "results.pvd")
    listed = [d.get("file") for d in tree.iter("DataSet")]
    assert sorted(listed) == sorted(p.name for p in tmp_path.glob("*.vtu")) and len(listed) == 3 * 5
    assert {d.get("group") for d in tree.iter("DataSet")} == set(cc.CONDITIONS)
    keys = [(d.get("timestep"), d.get("part")) for d in tree.iter("DataSet")]
    assert len(set(keys)) == len(keys)                      # each file its own block of its time step
    import matplotlib

    matplotlib.use("Agg")
    from cvxcontact.apps.demo import two_blocks
    from cvxcontact.io.plot import plot_contact, plot_deformed_all

    sols = {c: cc.solve(two_blocks(4, scale=0.01), c) for c in cc.CONDITIONS}
    fig = plot_contact(sols)
    rows = [fig.axes[3 * i:3 * i + 3] for i in range(3)]              # row-major: one row per quantity
    for row in rows:
        assert len({ax.get_ylim() for ax in row}) == 1             # one y-scale per quantity
    # engineering prefixes on the ticks: pressures in Pa, the jump in m (at these loads MPa and µm)
    assert [ax.yaxis.get_major_formatter().unit for ax in (rows[0][0], rows[1][0], rows[2][0])] == ["Pa", "Pa", "m"]
    fig.canvas.draw()
    assert any("MPa" in t.get_text() for t in rows[0][0].get_yticklabels())
    assert any("µm" in t.get_text() for t in rows[2][0].get_yticklabels())
    assert all(ax.get_legend() is None for ax in fig.axes) and len(fig.legends) == 1   # legend off the data
    for ax, c in zip(rows[0], cc.CONDITIONS):                      # every condition drawn, both bodies
        assert ax.get_title().startswith(c) and len([ln for ln in ax.lines if "pressure on body" in ln.get_label()]) == 2
    fig = plot_deformed_all(sols, "potential")
    assert len(fig.axes) == 4 and fig.axes[-1].get_ylabel() == "electric potential"
    fig.canvas.draw()
    assert any("kV" in t.get_text() for t in fig.axes[-1].get_yticklabels())     # 23 kV at nx = 4
    assert [ax.get_title().split(":")[0] for ax in fig.axes[:3]] == list(cc.CONDITIONS)


def test_all_elastic_scene_has_no_potential_plot(tmp_path, monkeypatch):
    from cvxcontact.apps.cli import main

    (tmp_path / "scene.toml").write_text((ROOT / "examples" / "two_blocks.toml").read_text()
                                         .replace('material = "PZT-5A"', "material = { E = 70e9, nu = 0.3 }")
                                         .replace('grounded = ["top"]\n', "")
                                         .replace("surface_charge = { left = -0.05 }", ""))
    monkeypatch.chdir(tmp_path)
    assert main(["solve", "scene.toml", "-q"]) == 0
    out = tmp_path / "scene-out"                                  # default: in the current folder
    assert (out / "contact.png").exists() and (out / "deformed_von_mises.png").exists()
    assert not (out / "deformed_potential.png").exists()


def test_cli_conditions_match_the_package():
    from cvxcontact.apps import cli
    from cvxcontact.contact.interface import CONDITIONS

    assert cli.CONDITIONS == CONDITIONS


def test_help_and_version_are_fast_and_light(tmp_path):
    """``--help`` / ``--version`` import neither NumPy, SciPy nor CVXPY (python -X importtime);
    ``python -m cvxcontact`` is the command line. The commands run outside the checkout with the folder of
    the package this process imported first on the path, so they run the same code (an installed package
    reads its version from its metadata, a checkout from its pyproject.toml)."""
    import os

    env = {**os.environ, "PYTHONPATH": str(Path(cc.__file__).resolve().parents[1])}

    def run(*args):
        return subprocess.run([sys.executable, *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=60)

    for args in (["--help"], ["--version"], ["solve", "--help"]):
        out = run("-X", "importtime", "-m", "cvxcontact", *args)
        assert out.returncode == 0, out.stderr
        imported = {line.split("|")[-1].strip().split(".")[0] for line in out.stderr.splitlines() if "|" in line}
        assert "cvxcontact" in imported and not imported & {"numpy", "scipy", "cvxpy", "matplotlib", "meshio"}
    assert out.stdout.startswith("usage: cvxcontact solve")
    where = run("-c", "import cvxcontact; print(cvxcontact.__file__)").stdout.strip()
    assert Path(where).resolve() == Path(cc.__file__).resolve()
    assert run("-m", "cvxcontact", "--version").stdout.strip() == f"cvxcontact {cc.__version__}"


def test_license_and_citation_agree_with_pyproject():
    import tomllib

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert meta["license"] == "BSD-3-Clause" and "BSD 3-Clause License" in (ROOT / "LICENSE").read_text()
    cff = (ROOT / "CITATION.cff").read_text()
    assert "license: BSD-3-Clause" in cff                # the versions: tests/test_version.py
    assert 'title: "Mixed finite element approximation for a contact problem in electro-elasticity"' in cff
    assert "demo/" in (ROOT / ".gitignore").read_text().split()


def test_cli_reference_table_lists_every_command_and_option():
    import argparse
    import re

    from cvxcontact.apps.cli import _parser

    text = (ROOT / "docs" / "reference" / "cli.md").read_text(encoding="utf-8")
    section = text[:text.index("## Output files")]
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| `cvxcontact (\w+)[^\n]*", section, re.M)}
    parser = _parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) <= set(rows), set(sub.choices) - set(rows)
    for name, p in sub.choices.items():
        for action in p._actions:
            longest = max(action.option_strings, key=len, default=None)
            if longest and longest != "--help":
                assert longest in rows[name], f"docs/reference/cli.md: `cvxcontact {name}` row lacks {longest}"
    assert "--version" in section and "python -m cvxcontact" in section


def test_out_naming_a_file_is_one_line_before_any_solve(tmp_path, capsys):
    from cvxcontact.apps.cli import main

    (tmp_path / "afile").write_text("")
    assert main(["demo", "--out", str(tmp_path / "afile"), "--nx", "4"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("cvxcontact: error: --out") and "is a file, not a folder" in err[-1]
    assert not any("solving" in line for line in err)


def test_no_penetration_is_flagged_where_both_sides_move_together_at_zero_gap():
    """Two blocks between side rollers pressed together over their whole line at zero gap (every row closed),
    and a block pressed onto a foundation lifted rigidly by a prescribed displacement: [u_nu] - g is rounding
    of the displacements at every node (measured 1.5e-20 m and 1.1e-21 m against |u| = 7e-5 m and 5e-6 m). The
    mask took its tolerance from max |[u_nu]|, itself rounding: it flagged 1 and 5 of 9 nodes of exact answers."""
    alu = cc.materials.isotropic(E=70e9, nu=0.3)
    up = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=3), alu, clamped=["top"], roller=["left", "right"],
                 body_force=(0, -1e8), contact="bottom", name="upper")
    low = cc.Body(cc.rectangle(x=(0, 1), y=(-0.4, 0), nx=8, ny=3), alu, clamped=["bottom"],
                  roller=["left", "right"], contact="top", name="lower")
    lifted = low.with_changes(clamped=(), roller=(), contact=None,
                              displacement={t: (0.0, 5e-6) for t in ("top", "bottom", "left", "right")})
    free = up.with_changes(roller=(), body_force=(0.0, 0.0))
    moved = cc.Scene(free, lifted, contacts=[cc.Contact(free, "bottom", lifted, "top")])
    for scene in (cc.Scene(up, low), moved):
        for condition in ("gamma3", "sigma1"):
            c = cc.solve(scene, condition).contact
            assert c.active.all() and np.abs(c.jump - c.gap).max() < 1e-12 * c.scale
            assert not c.penetration.any()
    c = cc.solve(moved).contact
    assert abs(c.scale - 1e-5) <= 1e-16 and np.abs(c.jump).max() < 1e-15    # |u . nu| = lift, plus the lift
