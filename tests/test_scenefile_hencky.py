"""A Hencky material in scene files (issue 31: the nonlinear A through scene files, the CLI and sweeps): the file's
table {E, nu, yield_stress, hardening} is cc.materials.hencky, solved as the same scene built in Python."""

import json
import subprocess
import sys

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.sweep import run_sweep
from cvxcontact.io.scenefile import SceneFileError, load_scene

E, NU, SIGMA_Y, H, P = 70e9, 0.3, 2e8, 0.1, 6e8

SCENE = f"""
condition = "sigma1"

[[body]]
name = "block"
material = {{ E = {E}, nu = {NU}, yield_stress = {SIGMA_Y}, hardening = {H} }}
mesh = {{ rectangle = {{ x = [0.0, 1.0], y = [0.0, 0.5], nx = 8, ny = 4 }} }}
roller = ["left"]
traction = {{ top = [0.0, {-P}] }}

[[obstacle]]
name = "floor"
plane = {{ point = [0.0, 0.0], normal = [0.0, 1.0] }}

[[contact]]
a = "block"
part_a = "bottom"
b = "floor"
"""


def python_scene(sigma_y=SIGMA_Y, material=None):
    """The scene of SCENE built in Python (its own construction: no scene file read); ``material`` instead of the
    Hencky one if given."""
    material = cc.materials.hencky(E, NU, sigma_y, H) if material is None else material
    block = cc.Body(cc.rectangle((0.0, 1.0), (0.0, 0.5), 8, 4), material, name="block", roller=["left"],
                    traction={"top": (0.0, -P)})
    return cc.Scene(block, contacts=[cc.Contact(block, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)))])


def test_a_hencky_table_in_a_scene_file_is_the_hencky_material(tmp_path):
    path = tmp_path / "hencky.toml"
    path.write_text(SCENE)
    spec = load_scene(path)
    mat = spec.scene.bodies[0].material
    assert isinstance(mat, cc.materials.Hencky) and (mat.sigma_y, mat.h, mat.E, mat.nu) == (SIGMA_Y, H, E, NU)
    sol, ref = cc.solve(spec.scene, spec.condition), cc.solve(python_scene(), "sigma1")
    assert sol.ok and ref.ok
    assert np.abs(sol.u[0] - ref.u[0]).max() <= 1e-12 * np.abs(ref.u[0]).max()
    # the load yields the block (else the test would not tell Hencky from linear): the linear answer differs
    lin = cc.solve(python_scene(material=cc.materials.isotropic(E, NU)), "sigma1")
    assert np.abs(lin.u[0] - ref.u[0]).max() > 1e-3 * np.abs(ref.u[0]).max()


def test_the_cli_solves_a_hencky_scene_file(tmp_path):
    path = tmp_path / "hencky.toml"
    path.write_text(SCENE)
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "cvxcontact", "solve", str(path), "--out", str(out)],
                         check=False, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert list(out.iterdir())                                        # its files written


def test_a_sweep_over_the_yield_stress_equals_direct_solves(tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE)
    values = [1.5e8, 3e8]
    (tmp_path / "sweep.toml").write_text(f'scene = "scene.toml"\n[grid]\n"body[0].material.yield_stress" = '
                                         f'{json.dumps(values)}\n')
    report = run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1)
    assert report.done == 2 and not report.failed
    results = cc.load_sweep(tmp_path / "out")
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    answers = {}
    for case in manifest["cases"]:
        sigma_y = case["overrides"]["body[0].material.yield_stress"]
        ref = cc.solve(python_scene(sigma_y), "sigma1")
        u = results.arrays(case["id"])["u1"]
        assert np.abs(u - ref.u[0]).max() <= 1e-10 * np.abs(ref.u[0]).max()
        answers[sigma_y] = u
    assert np.abs(answers[1.5e8] - answers[3e8]).max() > 1e-3 * np.abs(answers[3e8]).max()   # the constant acts


@pytest.mark.parametrize("table, words", [
    ("{ E = 70e9, nu = 0.3, yield_stress = 2e8 }", "missing hardening"),
    ("{ E = 70e9, yield_stress = 2e8, hardening = 0.1 }", "missing nu"),
    ("{ E = 70e9, nu = 0.3, yield_stress = 2e8, hardening = 0.0 }", "0 < h <= 1"),
    ("{ E = 70e9, nu = 0.3, yield_stress = -1.0, hardening = 0.1 }", "sigma_y > 0"),
    ("{ E = 70e9, nu = 0.3, yield_stress = 2e8, hardening = 0.1, c11 = 1.0 }", "unknown key"),
])
def test_a_bad_hencky_table_names_what_is_wrong(tmp_path, table, words):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE.replace(f"{{ E = {E}, nu = {NU}, yield_stress = {SIGMA_Y}, hardening = {H} }}", table))
    with pytest.raises(SceneFileError, match="material") as info:
        load_scene(path)
    assert words in str(info.value) and "bad.toml" in str(info.value)


def test_a_hencky_body_in_plane_stress_is_refused_naming_plane_strain(tmp_path):
    path = tmp_path / "stress.toml"
    path.write_text(SCENE.replace('roller = ["left"]', 'roller = ["left"]\nplane = "stress"'))
    with pytest.raises(SceneFileError, match="plane strain"):
        load_scene(path)
