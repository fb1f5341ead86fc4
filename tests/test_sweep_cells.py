"""Sweeps over scenes of quadrilaterals, tetrahedra and hexahedra: the case arrays name the cells, equal direct
solves, and export to XDMF (the bodies with their cells, the contact rows: a polyline in 2D, vertices in 3D)."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.sweep import run_sweep
from cvxcontact.io.scenefile import load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _box_scene(cell):
    """examples/punch3d.toml with smaller boxes of ``cell`` ("tetra" or "hex": Q1), under "sigma1"."""
    text = (EXAMPLES / "punch3d.toml").read_text()
    text = text.replace('condition = "gamma3"', 'condition = "sigma1"')
    text = text.replace("nx = 3, ny = 3, nz = 2 }", f'nx = 2, ny = 2, nz = 1, cell = "{cell}" }}')
    text = text.replace("nx = 6, ny = 6, nz = 2, patches", f'nx = 4, ny = 4, nz = 1, cell = "{cell}", patches')
    assert text.count(f'cell = "{cell}"') == 2
    return text, "body[1].body_force[2]", [-2.0e4, -8.0e4]


def _hex_scene():
    return (*_box_scene("hex"), "hexahedra", "hexahedron")


def _tetra_scene():
    return (*_box_scene("tetra"), "tetrahedra", "tetra")


def _quad_scene():
    """examples/two_blocks.toml with both rectangles of Q1 quadrilaterals, smaller."""
    text = (EXAMPLES / "two_blocks.toml").read_text()
    text = text.replace("nx = 16, ny = 8", 'nx = 8, ny = 4, cell = "quad"')
    text = text.replace("nx = 11, ny = 6", 'nx = 6, ny = 3, cell = "quad"')
    assert text.count('cell = "quad"') == 2
    return text, "body[0].body_force[1]", [-1e9, -3e9], "quads", "quad"


def _with_force(text, key, value):
    """The scene file ``text`` with the body force component ``key`` ("body[i].body_force[j]") set to ``value``."""
    i, j = (int(n) for n in re.findall(r"\[(\d+)\]", key))
    bodies = text.split("[[body]]")
    old = re.search(r"^body_force = (.*?)(\s+#.*)?$", bodies[i + 1], re.MULTILINE)
    force = [0.0] * (3 if "box" in text else 2)
    force[j] = value
    bodies[i + 1] = bodies[i + 1].replace(old.group(0), f"body_force = {json.dumps(force)}")
    return "[[body]]".join(bodies)


@pytest.mark.parametrize("build", [_quad_scene, _tetra_scene, _hex_scene], ids=["quad", "tetra", "hex"])
def test_a_sweep_over_quadrilaterals_or_hexahedra_equals_direct_solves(tmp_path, build):
    text, key, values, cells, meshio_cell = build()
    (tmp_path / "scene.toml").write_text(text)
    (tmp_path / "sweep.toml").write_text(f'scene = "scene.toml"\n[grid]\n"{key}" = {json.dumps(values)}\n')
    out = tmp_path / "out"
    report = run_sweep(tmp_path / "sweep.toml", out, workers=1)
    assert report.done == len(values) and not report.failed
    results = cc.load_sweep(out)
    for case in json.loads((out / "manifest.json").read_text())["cases"]:
        value = case["overrides"][key]
        arrays = results.arrays(case["id"])
        spec = load_scene(tmp_path / "scene.toml")
        for k, body in enumerate(spec.scene.bodies, start=1):
            assert np.array_equal(arrays[f"{cells}{k}"], body.mesh.cells)       # the cells under their own name
        # the same case solved directly: the scene file with the override written into it
        direct = tmp_path / f"direct_{case['id']}.toml"
        direct.write_text(_with_force(text, key, value))
        ref_spec = load_scene(direct)
        ref = cc.solve(ref_spec.scene, ref_spec.condition or "gamma3")
        assert ref.ok
        for k, u in enumerate(ref.u, start=1):
            assert np.abs(arrays[f"u{k}"] - u).max() <= 1e-10 * np.abs(u).max()
    pytest.importorskip("h5py", reason="the XDMF export is the optional extra cvxcontact[export] (h5py)")
    import meshio

    case = results.ids[0]
    results.export(tmp_path / "xdmf", ids=[case])
    a = results.arrays(case)
    body = meshio.read(tmp_path / "xdmf" / f"{case}_body1.xdmf")
    assert np.array_equal(body.cells_dict[meshio_cell], a[f"{cells}1"])
    assert np.array_equal(body.point_data["displacement [m]"], a["u1"][:len(a["points1"])])
    contact = meshio.read(tmp_path / "xdmf" / f"{case}_contact1.xdmf")            # the rows, each once
    assert np.array_equal(contact.point_data["lambda_h [Pa]"], a["lam"])
    rows = contact.cells_dict["line"].ravel() if "line" in contact.cells_dict else contact.cells_dict["vertex"].ravel()
    assert set(rows.tolist()) == set(range(len(a["lam"])))
