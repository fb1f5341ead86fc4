"""Force-controlled rigid obstacles (issue 10 item 4; docs/formulation.md §12).

The obstacle's translation t is an unknown with a prescribed resultant F. Cross-checks: the
displacement-controlled obstacle with the same resultant (its contact force read back, then applied
as a force), a closed form (uniaxial strain under a force-controlled plane), the obstacle's force
balance against the nodal contact forces, and the refusals before any solve.
"""

import numpy as np
import pytest
from obstacle_scenes import ALU, indenter_scene, punch_scene

import cvxcontact as cc

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def test_force_controlled_flat_punch_equals_the_displacement_controlled_one():
    depth = 1e-4
    disp = cc.solve(punch_scene(0.5 - depth)())
    F = disp.obstacles[0].force
    assert disp.ok and F[1] < 0 and F[0] == 0.0 and np.all(disp.obstacles[0].translation == 0.0)
    assert abs(-F[1] - disp.contact.force.sum()) <= 1e-12 * -F[1]        # c = n = (0, -1) at every node
    force = cc.solve(punch_scene(0.5)(force=F))
    assert force.ok and force.polished and force.method == "condensed"   # the translation borders the interface
    assert rel(force.u[0], disp.u[0]) < 1e-8
    assert rel(force.contact.lam, disp.contact.lam) < 1e-8
    assert rel(force.obstacles[0].translation, [0.0, -depth]) < 1e-8
    assert force.residuals()["obstacle balance"] < 1e-12
    # the balance, independently of the check: sum of the nodal contact forces along the normal
    assert abs(force.contact.force.sum() + F[1]) <= 1e-10 * abs(F[1])
    assert np.allclose(force.obstacles[0].prescribed, F, rtol=0, atol=0)
    # the total energy includes the work of the prescribed force: -F . t
    assert abs(force.energy - (disp.energy - F @ force.obstacles[0].translation)) <= 1e-8 * abs(force.energy)


def test_force_controlled_circle_indenter_equals_the_displacement_controlled_one():
    R, depth = 0.6, 3e-3
    # posed along the block's normal (distance="ray"): there the rows of the circle moved down by t equal the
    # force-controlled rows g - c . t exactly; the closest-point rows (the default) are their linearisation in t
    disp = cc.solve(indenter_scene(0.5 + R - depth, R, distance="ray"))
    F = disp.obstacles[0].force
    assert disp.ok and int(disp.contact.active.sum()) >= 2 and abs(F[0]) > 1e-4 * abs(F[1])   # off-centre
    force = cc.solve(indenter_scene(0.5 + R, R, force=F, distance="ray"))
    assert force.ok and force.polished
    assert rel(force.u[0], disp.u[0]) < 1e-8
    assert rel(force.contact.lam, disp.contact.lam) < 1e-8
    assert np.abs(force.obstacles[0].translation - [0.0, -depth]).max() < 1e-8 * depth
    assert force.residuals()["obstacle balance"] < 1e-12
    assert rel(force.obstacles[0].force, F) < 1e-12


def test_uniaxial_strain_under_a_force_controlled_plane_closed_form():
    """Block H x W clamped at its bottom, rollers on both sides, a rigid plane pressed on its whole top
    by F = -p W: exact uniaxial strain, the plane moves by t = -p H / M, M = E (1-nu)/((1+nu)(1-2nu))
    (P1 exact)."""
    E, nu, H, W, p = 70e9, 0.33, 0.5, 1.0, 2e7
    block = cc.Body(cc.rectangle(x=(0.0, W), y=(0.0, H), nx=4, ny=3), ALU, clamped="bottom",
                    roller=["left", "right"], contact="top", name="block")

    def scene(force):
        return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, H), (0.0, -1.0),
                                                                                    force=(0.0, -force)))])

    solver = cc.ContactSolver(scene(p * W))
    sol = solver.solve()
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    t = sol.obstacles[0].translation
    assert sol.ok and abs(t[1] + p * H / M) < 1e-9 * p * H / M and t[0] == 0.0
    assert np.abs(sol.contact.pressure - p).max() < 1e-9 * p
    twice = solver.solve(scene(2 * p * W))            # a re-solve with a new force (a load): linear
    assert abs(twice.obstacles[0].translation[1] - 2 * t[1]) < 1e-9 * abs(t[1])


def test_profile_punch_with_ends_has_the_normal_of_its_face():
    """A flat profile punch (+inf outside its face): the sensitivity at its end nodes is one-sided, -nu."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=10, ny=3), ALU, clamped="bottom", contact="top")
    face = cc.Rigid.profile(lambda s: np.where(np.abs(s - 0.5) <= 0.2 + 1e-9, -1e-4, np.inf))
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", face)])
    itf = scene.interfaces[0]
    assert np.allclose(face.sensitivity(itf.points, itf.normal), [0.0, -1.0], rtol=0, atol=1e-9)
    disp = cc.solve(scene)
    F = disp.obstacles[0].force
    forced = cc.Rigid.profile(lambda s: np.where(np.abs(s - 0.5) <= 0.2 + 1e-9, 0.0, np.inf), force=F)
    sol = cc.solve(cc.Scene(block, contacts=[cc.Contact(block, "top", forced)]))
    assert sol.ok and rel(sol.u[0], disp.u[0]) < 1e-7 and rel(sol.obstacles[0].translation, [0, -1e-4]) < 1e-7


@pytest.mark.parametrize("force,match", [
    ((0.0, 1e6), r"pulls the obstacle away.*free to move along \(0, 1\)"),
    ((1e6, -1e6), r"component 1e\+06 N/m along \(1, 0\).*free to slide along \(1, 0\)"),
    ((1e6, 0.0), r"free to slide along \(1, 0\)"),
])
def test_a_force_nothing_balances_is_refused_before_solving(force, match):
    with pytest.raises(cc.SceneError, match=match):
        punch_scene(0.5)(force=force)


def test_a_circle_pulled_away_is_refused():
    with pytest.raises(cc.SceneError, match="pulls the obstacle away"):
        indenter_scene(1.1, force=(0.0, 1e6))


def test_force_control_refusals_name_the_reason():
    scene = punch_scene(0.5)(force=(0.0, -1e6))
    law = cc.NormalCompliance(stiffness=1e12)
    with pytest.raises(cc.SolverError, match="force_control=True"):    # the condensed route: Signorini and cones
        cc.solve(scene, method="condensed", law=law)
    # a normal-compliance law with force control: cc.Model poses the problem cc.solve(method="full") solves
    ref, sol = cc.solve(scene, law=law, method="full"), cc.Model(scene, law=law).solve()
    assert ref.ok and sol.ok and sol.polished
    assert rel(sol.u[0], ref.u[0]) < 1e-12                                     # measured 0 (the same route)
    assert rel(sol.obstacles[0].translation, ref.obstacles[0].translation) < 1e-12
    # cc.Model takes force-controlled obstacles (P1 and P2): tests/test_model_stack.py
    with pytest.raises(cc.SceneError, match="zero force"):
        cc.Rigid.circle((0, 0), 1.0, force=(0, 0))
    with pytest.raises(cc.SceneError, match="force: expected two finite"):
        cc.Rigid.plane((0, 0), (0, 1), force=(1.0, float("nan")))


def test_force_control_with_a_per_pair_compliance_law_is_solved():
    """A compliance law given to the force-controlled pair itself (Contact(law=)) or to another pair of
    the scene is solved (full model, exact finish on the sparse mixed system), the obstacle balanced;
    the same scenes with a fixed obstacle solve too. (Was refused before issue 11's force-control item.)"""
    mesh = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=6, ny=3)
    block = cc.Body(mesh, ALU, clamped="bottom", contact="top", name="block")
    law = cc.NormalCompliance(stiffness=1e13)
    for own, other in ((law, None), (None, law)):
        def scene(**kw):
            return cc.Scene(block, contacts=[
                cc.Contact(block, "top", cc.Rigid.plane((0.0, 0.5), (0.0, -1.0), **kw), law=own),
                cc.Contact(block, "right", cc.Rigid.plane((1.0 + 1e-3, 0.0), (-1.0, 0.0)), law=other)])
        sol = cc.solve(scene(force=(0.0, -1e6)))
        assert sol.ok and sol.polished and sol.residuals()["obstacle balance"] < 1e-10
        assert sol.obstacles[0].translation[1] < 0.0
        assert cc.solve(scene()).ok


FORCE_FILE = """
[[body]]
name = "block"
material = { E = 70e9, nu = 0.33 }
mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 6, ny = 3 } }
clamped = "bottom"
roller = ["left", "right"]

[[obstacle]]
name = "press"
plane = { point = [0.0, 0.5], normal = [0.0, -1.0] }
force = [0.0, -2e7]

[[contact]]
a = "block"
part_a = "top"
b = "press"
"""


def test_scene_file_with_a_force_controlled_obstacle(tmp_path):
    from cvxcontact.io.scenefile import SceneFileError, load_scene

    (tmp_path / "f.toml").write_text(FORCE_FILE)
    sol = load_scene(tmp_path / "f.toml").solve()
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=6, ny=3), ALU, clamped="bottom",
                    roller=["left", "right"], contact="top")
    ref = cc.solve(cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, 0.5), (0.0, -1.0),
                                                                                        force=(0.0, -2e7)))]))
    assert sol.ok and rel(sol.u[0], ref.u[0]) < 1e-12
    assert rel(sol.obstacles[0].translation, ref.obstacles[0].translation) < 1e-12
    (tmp_path / "g.toml").write_text(FORCE_FILE.replace("force = [0.0, -2e7]", "force = [0.0, 2e7]"))
    with pytest.raises(SceneFileError, match="pulls the obstacle away"):
        load_scene(tmp_path / "g.toml")
    (tmp_path / "h.toml").write_text(FORCE_FILE.replace("force = [0.0, -2e7]", 'force = "up"'))
    with pytest.raises(SceneFileError, match=r"obstacle\[0\].*force"):
        load_scene(tmp_path / "h.toml")


def test_an_obstacle_given_by_its_distance_only_gets_the_gradient_as_sensitivity():
    plane = cc.Rigid.plane((0.1, 0.5), (0.3, -1.0))
    generic = cc.Rigid("custom", plane.distance, "custom()")
    pts = np.array([[0.0, 0.4], [0.5, 0.3], [0.9, 0.2]])
    nu = np.array([0.0, 1.0])
    n = np.array([0.3, -1.0]) / np.hypot(0.3, 1.0)
    assert np.allclose(plane.sensitivity(pts, nu), n / (-(nu @ n)), rtol=0, atol=1e-15)
    assert np.allclose(generic.sensitivity(pts, nu), plane.sensitivity(pts, nu), rtol=0, atol=1e-6)


def test_summary_reports_the_obstacles():
    from cvxcontact.io.output import summary

    sol = cc.solve(punch_scene(0.5)(force=(0.0, -1e6)))
    out = summary(sol)["obstacles"]
    assert len(out) == 1 and out[0]["prescribed_force_N_per_m"] == [0.0, -1e6]
    assert out[0]["translation_m"][1] < 0 and abs(out[0]["contact_force_N_per_m"][1] + 1e6) < 1e-6


def test_one_obstacle_shared_by_two_bodies_moves_as_one():
    """A rigid plate pressed on two clamped blocks of different stiffness (two pairs, one obstacle):
    force control with the displacement-controlled resultant gives the same answer."""
    soft = cc.materials.isotropic(E=10e9, nu=0.3)

    def scene(top, **kw):
        a = cc.Body(cc.rectangle(x=(0.0, 0.4), y=(0.0, 0.5), nx=4, ny=3), ALU, clamped="bottom", contact="top",
                    name="a")
        b = cc.Body(cc.rectangle(x=(0.6, 1.0), y=(0.2, 0.5), nx=4, ny=2), soft, clamped="bottom", contact="top",
                    name="b")
        plate = cc.Rigid.plane((0.0, top), (0.0, -1.0), **kw)
        return cc.Scene(a, b, contacts=[cc.Contact(a, "top", plate), cc.Contact(b, "top", plate)])

    disp = cc.solve(scene(0.5 - 1e-4))
    assert disp.obstacles[0].pairs == (0, 1)
    F = disp.obstacles[0].force
    assert abs(-F[1] - disp.contacts[0].force.sum() - disp.contacts[1].force.sum()) <= 1e-12 * -F[1]
    assert disp.contacts[0].force.sum() > 2 * disp.contacts[1].force.sum() > 0      # the stiffer block carries more
    sol = cc.solve(scene(0.5, force=F))
    assert sol.ok and len(sol.obstacles) == 1
    assert rel(sol.u[0], disp.u[0]) < 1e-8 and rel(sol.u[1], disp.u[1]) < 1e-8
    assert rel(sol.obstacles[0].translation, [0.0, -1e-4]) < 1e-8


def test_figure_draws_a_force_controlled_obstacle_where_it_moved():
    """plot_deformed draws the bodies with magnified displacements; the force-controlled punch is drawn
    moved by the same magnification times its translation: its face stays on the block's top nodes
    under the footprint (they touch it), which a fixed drawing would not."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import plot_deformed

    sol = cc.solve(punch_scene(0.5, nx=10, ny=2)(force=(0.0, -1e8)))
    t = sol.obstacles[0].translation
    assert sol.ok and t[1] < 0
    k = 1e-2 / abs(t[1])
    fig = plot_deformed(sol, magnify=k)
    (line,) = [ln for ln in fig.axes[0].lines if ln.get_label().startswith("rigid obstacle")]
    y = np.asarray(line.get_ydata(), dtype=float)
    assert np.allclose(y, 0.5 + k * t[1], rtol=0, atol=1e-12)
    pts = sol.scene.bodies[0].mesh.points
    under = np.isclose(pts[:, 1], 0.5) & (pts[:, 0] > 0.3 + 1e-9) & (pts[:, 0] < 0.7 - 1e-9)
    top = pts[under, 1] + k * sol.u[0][:len(pts)][under, 1]
    assert np.allclose(top, y[0], rtol=0, atol=1e-9)      # the drawn face touches the drawn block
    plt.close(fig)
