"""The teaching examples run (at a small size) and print what their docstrings promise."""

import runpy
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name):
    return runpy.run_path(str(EXAMPLES / name))


def draws(name, result):
    """The example's figure (the gallery shows it) is drawn from its result: axes with data on them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = load(name)["figure"](result)
    try:
        assert fig.axes and all(ax.lines or ax.collections for ax in fig.axes if ax.get_label() != "<colorbar>")
    finally:
        plt.close(fig)


def test_two_blocks_example(capsys):
    results = load("two_blocks.py")["main"](8)
    draws("two_blocks.py", results)
    out = capsys.readouterr().out
    for condition in ("gamma3", "sigma1", "sigma2"):
        assert f"condition {condition}" in out
    assert out.count("active set:") == 3 and "FAILED" not in out
    totals = np.array([r.contact.force.sum() for r in results.values()])
    assert np.ptp(totals) < 0.05 * totals.mean()


def test_actuator_example_is_linear_in_voltage_and_lifts_off(capsys):
    rows = load("actuator.py")["main"](8)
    draws("actuator.py", rows)
    force = {v: f for v, f, _, _ in rows}
    assert abs(force[-1000.0] / force[-250.0] - 4.0) < 1e-9
    assert force[1000.0] == 0.0 and all(sol.ok for *_, sol in rows)
    assert "lifted off" in capsys.readouterr().out


def test_gmsh_example_reads_shipped_meshes(tmp_path, capsys):
    sol = load("gmsh_mesh.py")["main"](str(tmp_path))
    draws("gmsh_mesh.py", sol)
    assert sol.ok and (tmp_path / "gmsh_body1.vtu").exists()
    assert "tags ['bottom', 'hole', 'sides', 'top']" in capsys.readouterr().out


def test_conditions_compared_example(tmp_path):
    sols = load("conditions_compared.py")["main"](18, str(tmp_path))
    draws("conditions_compared.py", sols)
    assert (tmp_path / "contact.png").exists()
    g, s1, s2 = (sols[c] for c in ("gamma3", "sigma1", "sigma2"))
    assert abs(g.contact.force.sum() - s1.contact.force.sum()) < 0.01 * g.contact.force.sum()
    assert s2.contact.jump.max() > 0 >= g.contact.jump[g.contact.constrained].max() - 1e-15


def test_shipped_sweep_example_runs(tmp_path):
    from cvxcontact.apps.sweep import run_sweep

    report = run_sweep(EXAMPLES / "sweep.toml", tmp_path, workers=2)
    assert report.total == 14 and report.done == 14 and not report.failed      # 6 grid points + "heavy", x 2 conditions


def test_normal_compliance_example(capsys):
    out = load("normal_compliance.py")["main"](8, {1: [1e16, 1e17], 2: [1e23, 1e25]})
    draws("normal_compliance.py", out)
    text = capsys.readouterr().out
    assert "FAILED" not in text and text.count("rate of e_u in k") == 2
    for m, rows in out.items():
        (k0, e0, _, r0, _), (k1, e1, _, r1, _) = rows
        assert e1 < e0 and r1 < r0 and all(row[-1].ok for row in rows)
        # penetration ~ (lambda/k)^(1/m): its rate in k is 1/m
        assert abs(np.log(r0 / r1) / np.log(k1 / k0) - 1 / m) < 0.05


def test_wall_actuator_example_matches_uniaxial_closed_form(capsys):
    rows = load("wall_actuator.py")["main"](2)
    draws("wall_actuator.py", rows)
    mat = __import__("cvxcontact").materials.PZT5H
    for voltage, t, _, sol in rows:       # t = -(p H + e33 V) / c33, computed here from the material's constants
        exact = -(1e5 / 0.2 * 0.5 + mat.e[1, 1] * voltage) / mat.c[1, 1]
        assert sol.ok and abs(t - exact) < 1e-9 * abs(exact)
        assert abs(-sol.obstacles[0].force[1] - 1e5) < 1e-10 * 1e5
    assert "affine in V" in capsys.readouterr().out


def test_punch_sensor_example_reads_force_linearly(capsys):
    rows = load("punch_sensor.py")["main"](10, (1e-6, 3e-6))
    draws("punch_sensor.py", rows)
    (_d0, f0, v0, q0, g0), (_d1, f1, v1, q1, g1) = rows
    assert f0 > 0 and v0 != 0 and q0 != 0
    # positively homogeneous: 3x the displacement gives 3x force, potential, charge (same active set)
    for a, b in ((f0, f1), (v0, v1), (q0, q1), (g0, g1)):
        assert abs(b / a - 3.0) < 1e-8
    assert "linear sensor" in capsys.readouterr().out


def test_hertz_half_example_against_the_closed_form(capsys):
    rows = load("hertz_half.py")["main"]((16, 32))
    draws("hertz_half.py", rows)
    errors = []
    for nx, P, a_h, a, h, p0_h, p0 in rows:
        assert abs(a_h - a) <= h / 2 + 1e-12            # the resolution limit of the half-width
        errors.append(abs(p0_h / p0 - 1))
    assert errors[1] < errors[0] < 0.1 and errors[1] < 0.05
    assert "p0 [MPa]" in capsys.readouterr().out


def test_stack_example_matches_uniaxial_strain(capsys):
    sol, rows, phi = load("stack.py")["main"](6)
    draws("stack.py", (sol, rows, phi))
    assert sol.ok and len(sol.contacts) == 2 and all(c.active.all() for c in sol.contacts)
    for name, short, exact in rows:
        assert abs(short - exact) < 1e-6 * exact, name
    (floating,) = [e for e in sol.electrodes if e.kind == "floating"]
    assert floating.potential == pytest.approx(phi, rel=1e-8)
    assert "closed form of the floating electrode" in capsys.readouterr().out


def test_pzt_disc_sphere_example_reads_the_force_by_reciprocity(capsys):
    rows = load("pzt_disc_sphere.py")["main"](8, (100.0, 400.0))
    draws("pzt_disc_sphere.py", rows)
    for r in rows:
        assert r["sol"].ok and r["V"] < 0                        # compression: a negative open-circuit potential
        # reciprocity with the charged, unpressed disc: exact for the discrete problem
        assert abs(r["V"] - r["reciprocal"]) <= 1e-10 * abs(r["V"])   # measured 3e-15
        assert abs(r["point"] / r["V"] - 1) < 0.03                    # the point-force limit; measured 0.011, 0.013
    # nearly linear: V / F drifts by the sensitivity's fall-off across the growing contact zone
    s0, s1 = (r["V"] / r["F"] for r in rows)
    assert 0 < 1 - s1 / s0 < 0.01                                     # measured 0.0021
    assert "reciprocity" in capsys.readouterr().out


@pytest.mark.numerics
def test_friction_block_example_between_sliding_and_tied(capsys):
    results = load("friction_block.py")["main"](8)
    draws("friction_block.py", results)
    S, P = 1e-5, 1e7
    tied = results["tied"]
    assert tied.ok and tied.contact.slip is None                       # the tied block: no friction law at all
    slipping = {}
    for (name, g), sol in ((k, v) for k, v in results.items() if k != "tied"):
        c = sol.contact
        assert sol.ok and sol.polished and sol.info.finish is not None
        # |sigma_t| <= g sampled at the nodes (Coulomb: mu times the pressure), relative to the threshold
        cap = g if name == "tresca" else (g / P) * c.pressure
        assert (np.abs(c.shear) <= cap * (1 + 1e-9) + 1e-9 * g).all()   # measured max |sigma_t| / cap - 1: 2e-16
        slipping[name, g] = int((np.abs(c.slip) > 1e-9 * S).sum())
        if g == 0.5e6:      # every node slides: the full capacity, -g L (Tresca) or -mu times the normal force
            capacity = -g * 1.0 if name == "tresca" else -(g / P) * c.force.sum()
            assert slipping[name, g] == len(c.x)
            assert abs(c.shear_force.sum() / capacity - 1) < 1e-9      # measured 0 and 2.2e-16
        if g == 24e6:       # stuck: the tied block, computed without friction
            assert np.abs(sol.u[0] - tied.u[0]).max() < 1e-12 * S      # measured 2.0e-15 S
    for name in ("tresca", "coulomb"):      # the slip zone shrinks as the threshold grows (to the pushed corner)
        assert slipping[name, 0.5e6] > slipping[name, 3e6] > slipping[name, 24e6] == 1
    assert "friction / capacity" in capsys.readouterr().out


@pytest.mark.numerics
def test_hencky_indent_example_is_linear_below_yield_and_softer_above(capsys):
    ns = load("hencky_indent.py")
    rows = ns["main"](12)
    draws("hencky_indent.py", rows)
    for depth, F, F_lin, plastic, sol in rows:
        assert sol.ok and sol.polished and F > 0
        if plastic == 0:        # no cell past yield: psi(s) = s^2 everywhere, the linear material's answer
            assert abs(F / F_lin - 1) < 1e-9                              # measured 1e-15
        else:                   # a plastic zone: the softened shear stiffness carries less force at the same depth
            assert F < F_lin
    plastic = [r[3] for r in rows]
    assert plastic[0] == 0 and plastic[-1] > 0 and plastic == sorted(plastic)
    # the plastic zone lies under the circle: its cells' centres within 0.4 m of the indent point (0.5, 0.5) (the
    # block is 1 m x 0.5 m), centred on x = 0.5 (the graded mesh mirrors about it); measured 0.30 m and 1e-16
    sol = rows[-1][-1]
    mesh = sol.scene.bodies[0].mesh
    centres = mesh.points[mesh.triangles].mean(axis=1)
    yielded = centres[ns["deviatoric_strain"](sol) > ns["S_Y"]]
    assert np.hypot(yielded[:, 0] - 0.5, yielded[:, 1] - 0.5).max() < 0.4 and abs(yielded[:, 0].mean() - 0.5) < 1e-3
    assert "plastic cells" in capsys.readouterr().out


@pytest.mark.numerics
def test_quad_elements_example_agrees_on_the_contact_force(capsys):
    results = load("quad_elements.py")["main"]((16, 32), 48)
    draws("quad_elements.py", results)
    F_ref = results["reference"]
    finest = {element: rows[-1] for element, rows in results.items() if element != "reference"}
    assert finest["P1"][1] == finest["Q1"][1] and finest["P2"][1] == finest["Q2"][1]   # the same grid's nodes
    for element, (n, dofs, F) in finest.items():
        assert n == 32 and abs(F - F_ref) < 0.05 * F_ref, element          # measured <= 4.5e-3 F_ref (P1)
    # P2 and Q2 agree well inside the discretisation difference (P2 from n = 16 to 32: measured 1.7e-2 F_ref)
    assert abs(finest["P2"][2] - finest["Q2"][2]) < 0.015 * F_ref              # measured 1.3e-3 F_ref
    assert "|F - F_ref| / F_ref" in capsys.readouterr().out


@pytest.mark.numerics
def test_hex_elements_example_orders_the_elements_on_the_contact_force(capsys):
    """Hexahedra and tetrahedra on a pressed sphere (examples/hex_elements.py): on each grid the quadratic elements
    are nearer the fine P2 reference than the linear ones (measured at n = 8: Q2 7.7e-3, P2 3.8e-4 against P1
    2.9e-2, Q1 5.7e-2 of F_ref), every element within 0.2 F_ref at n = 4 (measured <= 0.15, Q1)."""
    results = load("hex_elements.py")["main"]((4, 8), 12)
    draws("hex_elements.py", results)
    F_ref = results["reference"]
    for i, n in enumerate((4, 8)):
        err = {element: abs(rows[i][2] - F_ref) / F_ref for element, rows in results.items() if element != "reference"}
        assert results["P1"][i][1] == results["Q1"][i][1] and results["P2"][i][1] == results["Q2"][i][1]
        assert max(err["P2"], err["Q2"]) < min(err["P1"], err["Q1"]) and max(err.values()) < 0.2, (n, err)
    assert "|F - F_ref| / F_ref" in capsys.readouterr().out
