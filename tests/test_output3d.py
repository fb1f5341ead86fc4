"""3D output: tetra/tetra10 VTU with every field, the contact-surface VTU of each pair, the JSON summary in
3D units, the figures (contact pressure map, deformed boundary view)."""

import json

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.geometry.quadratic import P2TetNodes
from cvxcontact.io.output import body_mesh, contact_mesh, summary, write_all

P = 2e6                                    # Pa, the uniform pressure on the top faces
SIDES = ["left", "right", "front", "back"]
ALU = cc.materials.isotropic(70e9, 0.3)


@pytest.fixture(scope="module")
def layer():
    """An elastic layer on a rigid plane held by rollers on its four sides under a uniform pressure P: uniaxial
    strain, so the plane feels P everywhere (exact to rounding under the exact finish)."""
    body = cc.Body(cc.box(x=(0, 1e-2), y=(0, 1e-2), z=(0, 2e-3), nx=3, ny=4, nz=2), ALU, name="layer",
                   traction={"top": (0, 0, -P)}, roller=SIDES)
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])
    return cc.solve(scene)


@pytest.fixture(scope="module")
def stack():
    """A PZT-5A block (5 x 5 cells, grounded top) on an aluminium block (10 x 10 cells: nested faces), rollers on
    the sides, uniform pressure P on top; sigma2 (the finer side's nodes) passes the patch test exactly."""
    up = cc.Body(cc.box(x=(0, 1e-2), y=(0, 1e-2), z=(2e-3, 4e-3), nx=5, ny=5, nz=2), cc.materials.PZT5A,
                 name="upper", traction={"top": (0, 0, -P)}, roller=SIDES, grounded=["top"], contact="bottom")
    lo = cc.Body(cc.box(x=(0, 1e-2), y=(0, 1e-2), z=(0, 2e-3), nx=10, ny=10, nz=1), ALU, name="lower",
                 roller=SIDES + ["bottom"], contact="top")
    return cc.solve(cc.Scene(up, lo), "sigma2")


def _tri_areas(points, tri):
    p = points[tri]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def _lumped(points, tri):
    """A third of each triangle's area at each of its nodes (m^2), from the file's own triangles."""
    out = np.zeros(len(points))
    np.add.at(out, tri.ravel(), np.repeat(_tri_areas(points, tri) / 3, 3))
    return out


def _affine(points, A, b):
    return points @ A.T + b


@pytest.mark.parametrize("degree", [1, 2])
def test_tetra_vtu_of_an_affine_field_holds_its_closed_form_fields(tmp_path, degree):
    """u = A x + b, phi = -E0 . x on a PZT-5A box: every cell holds eps = sym(A) in VTK order (xx, yy, zz, xy, yz,
    xz), E = E0, sigma = c eps - e^T E0 and D = e eps + kappa E0 (Voigt products written out here); P2 as
    tetra10 cells whose mid-nodes sit on VTK's edges (01, 12, 20, 03, 13, 23). Read back from the file."""
    rng = np.random.default_rng(3)
    mesh = cc.box(x=(0, 2e-3), y=(0, 1e-3), z=(0, 1e-3), nx=2, ny=2, nz=1)
    body = cc.Body(mesh, cc.materials.PZT5A, clamped=["bottom"], grounded=["bottom"])
    A, b, E0 = 1e-4 * rng.standard_normal((3, 3)), 1e-6 * rng.standard_normal(3), 1e5 * rng.standard_normal(3)
    nodes = P2TetNodes(mesh) if degree == 2 else None
    pts = mesh.points if nodes is None else nodes.points
    u, phi = _affine(pts, A, b), -pts @ E0
    meshio.write(tmp_path / "b.vtu", body_mesh(body, u, phi, nodes))
    back = meshio.read(tmp_path / "b.vtu")
    kind, cells = back.cells[0].type, back.cells[0].data
    assert kind == ("tetra" if degree == 1 else "tetra10") and len(cells) == len(mesh.tets)
    assert np.array_equal(back.points, pts) and np.array_equal(back.point_data["displacement [m]"], u)
    assert np.array_equal(back.point_data["electric potential [V]"], phi)
    if degree == 2:
        X = back.points[cells]
        for mid, (i, j) in zip(range(4, 10), [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]):
            assert np.allclose(X[:, mid], 0.5 * (X[:, i] + X[:, j]), rtol=0, atol=1e-18)
    eps = 0.5 * (A + A.T)
    vtk = np.array([eps[0, 0], eps[1, 1], eps[2, 2], eps[0, 1], eps[1, 2], eps[0, 2]])
    voigt = np.array([eps[0, 0], eps[1, 1], eps[2, 2], 2 * eps[1, 2], 2 * eps[0, 2], 2 * eps[0, 1]])
    c, e, kappa = cc.materials.PZT5A.tensors(3)
    sigma = c @ voigt - e.T @ E0                                    # Voigt order xx, yy, zz, yz, xz, xy
    D = e @ voigt + kappa @ E0
    data = {k: v[0] for k, v in back.cell_data.items()}
    scale = np.abs(sigma).max()
    assert np.abs(data["strain [-]"] - vtk).max() <= 1e-12 * np.abs(vtk).max()        # measured ~1e-16
    assert np.abs(data["stress [Pa]"] - sigma[[0, 1, 2, 5, 3, 4]]).max() <= 1e-10 * scale   # measured ~1e-15
    for k, name in enumerate(["xx", "yy", "zz", "yz", "xz", "xy"]):
        assert np.abs(data[f"stress {name} [Pa]"] - sigma[k]).max() <= 1e-10 * scale
        assert np.abs(data[f"strain {name} [-]"] - (voigt[k] if k < 3 else voigt[k] / 2)).max() <= 1e-12 * np.abs(vtk).max()
    assert np.abs(data["electric field [V/m]"] - E0).max() <= 1e-10 * np.abs(E0).max()
    assert np.abs(data["electric displacement [C/m^2]"] - D).max() <= 1e-10 * np.abs(D).max()
    s = sigma
    vm = np.sqrt(0.5 * ((s[0] - s[1]) ** 2 + (s[1] - s[2]) ** 2 + (s[2] - s[0]) ** 2) + 3 * (s[3:] ** 2).sum())
    assert np.abs(data["von Mises stress [Pa]"] - vm).max() <= 1e-10 * scale


def test_layer_on_a_plane_files_hold_the_uniaxial_strain_solution(layer, tmp_path):
    """Body VTU: tetra cells, u (n, 3) as solved, sigma_zz = -P in every cell. Contact-surface VTU: the layer's
    faces that reach the plane, covering its whole bottom (1e-4 m^2), pressure P at every node, the nodal
    forces summing to P x area (in N); the JSON says N, J and C, not per metre."""
    sol = layer
    assert sol.ok and sol.polished
    paths = write_all(sol, tmp_path, "c")
    names = sorted(p.name for p in paths)
    assert names == ["c.json", "c_body1.vtu", "c_contact.vtu", "c_contact_body1.vtu"]
    body = meshio.read(tmp_path / "c_body1.vtu")
    assert body.cells[0].type == "tetra" and np.array_equal(body.cells[0].data, sol.scene.bodies[0].mesh.tets)
    assert np.array_equal(body.point_data["displacement [m]"], sol.u[0])
    assert np.abs(body.cell_data["stress zz [Pa]"][0] + P).max() <= 1e-9 * P            # measured 2e-15
    surf = meshio.read(tmp_path / "c_contact.vtu")
    tri = surf.cells[0].data
    assert surf.cells[0].type == "triangle"
    assert abs(_tri_areas(surf.points, tri).sum() - 1e-4) <= 1e-15                      # measured 0
    assert np.allclose(surf.points[:, 2], 0.0, atol=0)
    d = surf.point_data
    assert np.abs(d["pressure on body 1 [Pa]"] / P - 1).max() <= 1e-9                   # measured 1e-15
    assert np.abs(d["nodal pressure [Pa]"] / P - 1).max() <= 1e-9
    assert abs(d["nodal force [N]"].sum() / (P * 1e-4) - 1) <= 1e-12
    assert np.all(d["active [-]"] == 1) and np.all(d["penetration [-]"] == 0)
    assert np.abs(d["normal jump [m]"] - d["gap [m]"]).max() <= 1e-9 * np.abs(sol.u[0]).max()  # in contact
    own = meshio.read(tmp_path / "c_contact_body1.vtu")
    np.testing.assert_allclose(_lumped(own.points, own.cells[0].data) * own.point_data["pressure on body 1 [Pa]"],
                               np.full(len(own.points), P) * _lumped(own.points, own.cells[0].data), rtol=1e-9)
    s = json.loads((tmp_path / "c.json").read_text())
    assert s["dimension"] == 3 and "energy_J" in s and "energy_J_per_m" not in s
    assert s["contact"]["total_force_N"] == pytest.approx(P * 1e-4, rel=1e-12)
    (o,) = s["obstacles"]
    assert o["translation_m"] == [0.0, 0.0, 0.0]
    assert o["contact_force_N"] == pytest.approx([0.0, 0.0, P * 1e-4], rel=1e-12, abs=1e-12 * P * 1e-4)
    assert np.allclose(sol.obstacles[0].force, [0, 0, P * 1e-4], rtol=1e-12, atol=1e-12 * P * 1e-4)
    assert s["bodies"][0]["tetrahedra"] == len(sol.scene.bodies[0].mesh.tets)


def test_two_body_surface_vtu_has_both_sides_and_the_overlay(stack, tmp_path):
    """Nested faces (5 x 5 on 10 x 10): the overlay's triangles tile the overlap (1e-4 m^2), each body feels P on
    its own faces, lambda_h = P on the overlay, the forces sum to P x area; every array equals the solution's."""
    sol = stack
    assert sol.ok and sol.polished
    write_all(sol, tmp_path, "s")
    surf = meshio.read(tmp_path / "s_contact.vtu")
    c, ov = sol.contact, sol.scene.interfaces[0].overlay
    assert np.array_equal(surf.points, c.points) and c.points.shape == (len(c.x), 3)
    assert abs(_tri_areas(surf.points, surf.cells[0].data).sum() / 1e-4 - 1) <= 1e-12
    d = surf.point_data
    for k in (1, 2):
        assert np.abs(d[f"pressure on body {k} [Pa]"] / P - 1).max() <= 1e-8          # measured 4e-14
        own = meshio.read(tmp_path / f"s_contact_body{k}.vtu")
        t = sol.scene.interfaces[0].traces[k - 1]
        assert np.array_equal(own.cells[0].data, t.faces) and np.array_equal(own.points, t.points)
        assert np.array_equal(own.point_data["displacement [m]"], sol.u[k - 1][t.nodes])
        vertex = (ov.node_a, ov.node_b)[k - 1]               # each trace node's overlay vertex (-1: outside)
        inside = vertex >= 0
        assert inside.all()                                   # same footprint: every node lies in the overlap
        assert np.array_equal(d[f"displacement body {k} [m]"][vertex], sol.u[k - 1][t.nodes])
    assert np.abs(d["lambda_h (diagnostic) [Pa]"] / P - 1).max() <= 1e-8                # measured 5e-14
    assert abs(d["nodal force [N]"].sum() / (P * 1e-4) - 1) <= 1e-12
    assert np.array_equal(d["normal jump [m]"], c.jump) and np.array_equal(d["active [-]"], c.active)
    s = summary(sol)
    (e,) = s["electrodes"]
    assert "charge_C" in e and e["charge_C"] == sol.electrodes[0].charge


def test_contact_mesh_against_an_obstacle_lists_only_faces_that_reach_it():
    """A sphere posed along the normal (distance="ray") reaches only the nodes under it: the surface mesh's
    triangles are the faces of the body whose three nodes all reach the sphere, numbered as the nodes of X_h.
    (Posed at the closest point, the default, every node of the top face faces the sphere and reaches it.)"""
    body = cc.Body(cc.box(x=(-1e-2, 1e-2), y=(-1e-2, 1e-2), z=(-4e-3, 0), nx=8, ny=8, nz=1), ALU,
                   clamped=["bottom"])
    closest = cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere((0, 0, 6e-3 + 1e-6), 6e-3))])
    assert closest.interfaces[0].size == len(closest.interfaces[0].traces[0].nodes)
    ball = cc.Rigid.sphere((0, 0, 6e-3 + 1e-6), 6e-3, distance="ray")
    scene = cc.Scene(body, contacts=[cc.Contact(body, "top", ball)])
    itf = scene.interfaces[0]
    from cvxcontact.io.output import surface_cells

    tri = surface_cells(itf)
    r = np.hypot(*itf.points[:, :2].T)
    assert itf.size < len(itf.traces[0].nodes) and r.max() <= 6e-3 and len(tri) > 0   # nodes under the ball
    t = itf.traces[0]
    faces = t.faces[np.isin(t.faces, itf.reach).all(axis=1)]
    assert np.array_equal(np.sort(itf.reach[tri], axis=1), np.sort(faces, axis=1))


def _zone_length(zone):
    return float(np.linalg.norm(zone[:, 1] - zone[:, 0], axis=1).sum())


def test_contact_zone_outlines_the_cells_in_contact(layer, stack):
    """Full contact: the zone's boundary is the perimeter of the contact face (4 cm for a 1 cm square), on both
    the rigid pair (the body's faces) and the two-body overlay. A sphere pressed into a block: a closed outline
    inside the circle where the undeformed surfaces intersect (plus one cell), away from the face's edge."""
    from cvxcontact.io.plot import contact_zone

    for sol in (layer, stack):
        zone = contact_zone(sol)
        assert zone.shape[1:] == (2, 2) and abs(_zone_length(zone) - 0.04) <= 1e-15
        ends, count = np.unique(zone.reshape(-1, 2), axis=0, return_counts=True)
        assert np.all(count == 2)                                     # a closed curve: each end shared by two
    R, delta, h = 5e-2, 5e-4, 2.5e-3
    body = cc.Body(cc.box(x=(-1e-2, 1e-2), y=(-1e-2, 1e-2), z=(-4e-3, 0), nx=8, ny=8, nz=2), ALU, clamped=["bottom"])
    ball = cc.Rigid.sphere((0, 0, R - delta), R)
    sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "top", ball)]))
    assert sol.ok and 0 < sol.contact.active.sum() < sol.contact.constrained.sum()
    # a rigid pair: the pressure at a node is its force over its area, positive where the force is
    assert np.array_equal(sol.in_contact(), sol.contact.active)
    assert 0 < sol.contact_fraction() < 1
    zone = contact_zone(sol)
    r = np.hypot(zone[..., 0], zone[..., 1])
    assert len(zone) >= 3 and r.max() <= np.sqrt(2 * R * delta) + h and r.max() < 1e-2
    _, count = np.unique(zone.reshape(-1, 2), axis=0, return_counts=True)
    assert np.all(count == 2)


def test_boundary_owners_are_the_tetrahedra_behind_each_face():
    """Each boundary face's owner has the face among its four, and its fourth vertex lies behind the face (inside:
    against the outward normal)."""
    from cvxcontact.io.plot import boundary_owners

    mesh = cc.cylinder(radius=1e-2, height=3e-3, n_r=3, n_z=2)
    owner = boundary_owners(mesh)
    faces = np.asarray(mesh.boundary_faces)
    tets = mesh.tets[owner]
    assert all(set(f) <= set(t) for f, t in zip(faces.tolist(), tets.tolist()))
    fourth = tets.sum(axis=1) - faces.sum(axis=1)
    p = mesh.points
    normal = np.cross(p[faces[:, 1]] - p[faces[:, 0]], p[faces[:, 2]] - p[faces[:, 0]])
    assert np.all(np.einsum("ij,ij->i", p[fourth] - p[faces[:, 0]], normal) < 0)


def test_3d_figures_are_drawn_with_colour_bars_and_units(layer, stack):
    """The pressure map has one panel per side plus the opening, a shared pressure colour bar, the zone drawn;
    the deformed boundary view has a 3D axes with a colour bar; a 2D solution is refused by name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import plot_contact_map, plot_deformed_3d, plot_deformed_3d_all

    fig = plot_contact_map({"rigid": layer, "two bodies": stack})
    try:
        panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
        assert len(panels) == 5                                       # 1 + opening, 2 + opening
        assert all(ax.collections and ax.lines for ax in panels)
        labels = [ax.get_ylabel() for ax in fig.axes if ax.get_label() == "<colorbar>"]
        assert "contact pressure" in labels
        assert "s1 along t1 = (1, 0, 0)" in panels[0].get_xlabel()
    finally:
        plt.close(fig)
    for field in ("von_mises", "displacement", "potential"):
        fig = plot_deformed_3d(stack, field)
        try:
            ax3 = [ax for ax in fig.axes if getattr(ax, "name", "") == "3d"]
            assert len(ax3) == 1 and ax3[0].collections and len(fig.axes) == 2       # with its colour bar
        finally:
            plt.close(fig)
    fig = plot_deformed_3d_all({"a": layer, "b": layer}, "displacement")
    plt.close(fig)
    two_d = cc.Scene(cc.Body(cc.rectangle(x=(0, 1), y=(0, 1), nx=2, ny=2), ALU, clamped=["top"], contact="bottom"),
                     cc.Body(cc.rectangle(x=(0, 1), y=(-1, 0), nx=2, ny=2), ALU, clamped=["bottom"], contact="top"))
    with pytest.raises(cc.SceneError, match="draws 3D solutions"):
        plot_contact_map(cc.solve(two_d))


def test_2d_figure_functions_draw_3d_solutions_with_the_3d_figures(layer):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import plot_contact, plot_deformed, plot_deformed_all

    for fig in (plot_contact(layer), plot_deformed(layer), plot_deformed_all({"a": layer}, "displacement")):
        try:
            assert any(getattr(ax, "name", "") == "3d" for ax in fig.axes) or fig.get_suptitle().startswith(
                "Contact pressure in the plane")
        finally:
            plt.close(fig)


def test_p2_files_hold_tetra10_cells_and_both_sides_pressure(tmp_path):
    """P2 (degree=2) on nested faces (2 x 2 on 4 x 4 cells, sigma2: the finer side's nodes, exact): the body
    files are tetra10 with the solved displacement at every node; the contact-surface file has both sides'
    pressure, lambda_h and the jump; each side's own file is triangle6 with its felt pressure, P everywhere."""
    from scenes3d import P as p0, stacked_blocks

    sol = cc.solve(stacked_blocks((2, 2), (4, 4)), "sigma2", degree=2)
    assert sol.ok and sol.polished and sol.degree == 2
    write_all(sol, tmp_path, "q")
    for k in (1, 2):
        body = meshio.read(tmp_path / f"q_body{k}.vtu")
        assert body.cells[0].type == "tetra10" and len(body.cells[0].data) == len(sol.scene.bodies[k - 1].mesh.tets)
        assert np.array_equal(body.points, sol.points[k - 1])
        assert np.array_equal(body.point_data["displacement [m]"], sol.u[k - 1])
        assert np.abs(body.cell_data["stress zz [Pa]"][0] / p0 + 1).max() <= 1e-9          # measured 2.2e-14
        own = meshio.read(tmp_path / f"q_contact_body{k}.vtu")
        assert own.cells[0].type == "triangle6"
        assert np.abs(own.point_data[f"pressure on body {k} [Pa]"] / p0 - 1).max() <= 1e-9  # measured 4.3e-14
    d = meshio.read(tmp_path / "q_contact.vtu").point_data
    for name in ("pressure on body 1 [Pa]", "pressure on body 2 [Pa]", "lambda_h (diagnostic) [Pa]"):
        assert np.abs(d[name] / p0 - 1).max() <= 1e-9, name                               # measured 4.3e-14
    assert np.array_equal(d["normal jump [m]"], sol.contact.jump)


def test_full_contact_under_gamma3_on_non_matching_faces_is_the_whole_face():
    """Stacked blocks, 5 x 5 on 7 x 3 faces (non-matching), a uniform pressure P, "gamma3": the pressure felt by
    each body is P on its whole face, so the contact zone is the whole face: every overlay node in contact, the
    contact area fraction 1 in the report and the JSON, and the outline the face's perimeter (4 m) -- though
    the nodal forces sit on a third of the overlay's nodes (the rows are dependent; measured 65 of 193), which
    the report names as active."""
    from scenes3d import P as p0, stacked_blocks

    from cvxcontact.io.plot import contact_zone

    sol = cc.solve(stacked_blocks(), "gamma3")
    c = sol.contact
    assert sol.ok and sol.polished
    for k in (0, 1):                                                  # the independent fact: P on both faces
        assert np.abs(sol.traction(k)[1] / p0 - 1).max() <= 1e-9      # measured 4.7e-14
    assert c.active.sum() < c.constrained.sum() == len(c.x)           # forces on a subset of the overlay
    assert sol.in_contact().all() and sol.contact_fraction() == pytest.approx(1.0, abs=1e-12)   # measured 0
    zone = contact_zone(sol)
    assert abs(_zone_length(zone) - 4.0) <= 1e-12                    # the perimeter of the unit square face
    pair = summary(sol)["contact"]
    assert pair["contact_zone_nodes"] == len(c.x) and pair["contact_zone_fraction"] == pytest.approx(1.0, abs=1e-12)
    line = next(ln for ln in sol.report().splitlines() if ln.startswith("  contact[0]"))
    assert f"pressure > 0 at {len(c.x)} of {len(c.x)} nodes (100 % of the area)" in line
    assert f"{int(c.active.sum())} of {len(c.x)} constrained nodes active (in contact)" in line
