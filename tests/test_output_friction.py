"""The friction fields in the output files: a friction pair's contact VTU carries the slip, the shear and the shear
force as vectors in global coordinates and as their components along the pair's tangent (2D) or frame (3D), and the
threshold; the JSON summary a ``friction`` entry; a frictionless pair writes none of them. Read back from the files
(meshio, json) and compared with ``sol.contact``'s arrays."""

import json

import meshio
import numpy as np
import pytest
from friction_scenes import (
    DIAGONAL3,
    P,
    box,
    dragged_disk,
    pushed,
    sliding_layer3d,
    uniform_pair3d,
)

import cvxcontact as cc
from cvxcontact.io.output import write_all

pytestmark = pytest.mark.numerics

FIELDS = {"slip": "slip {}[m]", "shear": "shear {}[Pa]", "shear_force": "shear force {}[N]"}
"""The point data of a 3D friction pair (2D: ``[N/m]`` for the shear force): vector ``name.format("")``,
components ``name.format("t1 ")``, ..."""
FRICTIONLESS = {"active [-]", "constrained [-]", "displacement [m]", "displacement body 1 [m]", "gap [m]",
                "lambda_h (diagnostic) [Pa]", "nodal pressure [Pa]", "normal jump [m]", "penetration [-]",
                "pressure on body 1 [Pa]"}
"""The point data of a one-body frictionless contact VTU (without the nodal force, whose unit depends on d)."""


def _read(sol, tmp_path):
    write_all(sol, tmp_path, "s")
    return meshio.read(tmp_path / "s_contact.vtu"), json.loads((tmp_path / "s.json").read_text())


def _components_match(mesh, c, fields):
    """Every component array in the file is the ContactResult's array, bit for bit."""
    for key, name in fields.items():
        parts = np.asarray(getattr(c, key), dtype=float).reshape(len(c.x), -1)
        for j in range(parts.shape[1]):
            np.testing.assert_array_equal(mesh.point_data[name.format(f"t{j + 1} ")], parts[:, j])


@pytest.fixture(scope="module")
def sliding():
    """A layer slid by 1e-4 m along DIAGONAL3 over the plane z = 0 under Tresca's g = 0.1 p: every node slips."""
    sol = cc.solve(sliding_layer3d(0.1 * P))
    assert sol.ok
    return sol


def test_3d_tresca_fields_read_back_exactly_and_point_along_the_slide(sliding, tmp_path):
    """On the plane z = 0 the frame is (x, y) (canonical_frame), so the global vectors are the frame components
    with z = 0, exactly; the slip points along DIAGONAL3, the shear against it at |sigma_t| = g."""
    c = sliding.contact
    mesh, js = _read(sliding, tmp_path)
    _components_match(mesh, c, FIELDS)
    for key, name in FIELDS.items():
        v = mesh.point_data[name.format("")]
        assert v.shape == (len(c.x), 3)
        np.testing.assert_array_equal(v[:, :2], getattr(c, key))
        np.testing.assert_array_equal(v[:, 2], 0.0)
    np.testing.assert_array_equal(mesh.point_data["slip threshold [Pa]"], np.full(len(c.x), c.threshold))
    slip, shear = mesh.point_data["slip [m]"], mesh.point_data["shear [Pa]"]
    direction = np.append(DIAGONAL3, 0.0)
    along = slip / np.linalg.norm(slip, axis=1, keepdims=True)
    assert np.abs(along - direction).max() < 1e-6            # measured 3e-16 (slides along the diagonal)
    against = shear / np.linalg.norm(shear, axis=1, keepdims=True)
    assert np.abs(against + direction).max() < 1e-6          # measured 2e-16 (the shear opposes the slip)
    f = js["contact"]["friction"]
    assert f["threshold_Pa"] == {"min": 0.1 * P, "max": 0.1 * P}
    assert f["max_slip_m"] == pytest.approx(np.linalg.norm(c.slip, axis=1).max(), rel=1e-14)
    assert f["max_shear_Pa"] == pytest.approx(np.linalg.norm(c.shear, axis=1).max(), rel=1e-14)
    np.testing.assert_allclose(f["total_shear_force_N"], np.append(c.shear_force.sum(axis=0), 0.0), rtol=1e-14)
    # the friction forces of the slid unit square sum to g (N: the area is 1 m^2), against the slide
    np.testing.assert_allclose(f["total_shear_force_N"], -0.1 * P * direction, rtol=1e-6, atol=1e-6 * P)


TURN = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""A quarter turn about x: (x, y, z) -> (x, -z, y); the plane z = 0 becomes y = 0, whose canonical frame is (x, -z)."""


def turned_sliding_layer3d(g, s=1e-4, n=2):
    """:func:`~friction_scenes.sliding_layer3d` turned by :data:`TURN` (mesh, tractions, the lid's motion, the
    plane): the same solution turned, its slip along TURN (DIAGONAL3, 0) = (cos 0.5, 0, sin 0.5)."""
    mesh = cc.box(nx=n, ny=n, nz=1)
    tags = {**{t: mesh.boundary(t) for t in mesh.tags}, "lid": mesh.boundary("top")}
    mesh = cc.TetMesh(mesh.points @ TURN.T, mesh.tets, tags)
    q = g * DIAGONAL3
    sides = {"left": (0.0, 0.0, -q[0]), "right": (0.0, 0.0, q[0]), "front": (0.0, 0.0, -q[1]),
             "back": (0.0, 0.0, q[1]), "top": (0.0, 0.0, -P)}
    d = s * DIAGONAL3
    body = cc.Body(mesh, cc.materials.isotropic(200e9, 0.0), contact="bottom",
                   traction={k: tuple(TURN @ v) for k, v in sides.items()}, displacement={"lid": (d[0], None, d[1])})
    floor = cc.Rigid.plane(point=(0.0, 0.0, 0.0), normal=tuple(TURN @ [0.0, 0.0, 1.0]))
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", floor, law=cc.Tresca(g))])


def test_3d_vectors_are_the_frame_components_turned_into_global_axes(sliding, tmp_path):
    """The sliding layer turned a quarter about x: the frame is (x, -z), so the file's vectors are TURN times the
    unturned layer's (its slip along TURN (DIAGONAL3, 0), not the components padded with 0), orthogonal to the
    normal, as long as their components; the components are the ContactResult's, bit for bit."""
    sol = cc.solve(turned_sliding_layer3d(0.1 * P))
    assert sol.ok
    c = sol.contact
    mesh, js = _read(sol, tmp_path)
    _components_match(mesh, c, FIELDS)
    frame, normal = np.asarray(js["contact"]["frame"]), np.asarray(js["contact"]["normal"])
    np.testing.assert_array_equal(frame, [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    direction = TURN @ np.append(DIAGONAL3, 0.0)
    for key, name in FIELDS.items():
        parts, v = np.asarray(getattr(c, key)), mesh.point_data[name.format("")]
        scale = np.abs(parts).max()
        assert np.abs(v @ normal).max() <= 1e-14 * scale                   # measured 0 (exact: axis-aligned)
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), np.linalg.norm(parts, axis=1), rtol=1e-14)
        unit = v / np.linalg.norm(v, axis=1, keepdims=True)
        sign = 1.0 if key == "slip" else -1.0                               # the shear opposes the slip
        assert np.abs(unit - sign * direction).max() < 1e-6                 # measured 6e-16
        unturned = np.asarray(getattr(sliding.contact, key))
        turned = np.append(unturned, np.zeros((len(unturned), 1)), axis=1) @ TURN.T     # uniform: any node order
        assert np.abs(v - turned).max() <= 1e-6 * scale                     # measured 6e-16 of the scale


def test_3d_pair_of_two_bodies_writes_its_fields(tmp_path):
    """Two stuck layers, the pair posed from the lower one: the fields of a deformable pair are written too (the
    components bit for bit, the vectors in the plane of the frame (x, y) with z = 0)."""
    sol = cc.solve(uniform_pair3d(0.01 * P, cc.Tresca(0.1 * P), swap=True))
    assert sol.ok
    c = sol.contact
    mesh, js = _read(sol, tmp_path)
    _components_match(mesh, c, FIELDS)
    for key, name in FIELDS.items():
        np.testing.assert_array_equal(mesh.point_data[name.format("")][:, :2], getattr(c, key))
        np.testing.assert_array_equal(mesh.point_data[name.format("")][:, 2], 0.0)
    np.testing.assert_array_equal(mesh.point_data["slip threshold [Pa]"], np.full(len(c.x), 0.1 * P))
    assert "friction" in js["contact"]


SPHERE = np.array([0.0, 0.0, 1.98])
"""The centre of the rigid sphere (radius 2 m) pressed 0.02 m into the block's top z = 0."""


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")   # a coarse block: 2 faces span the zone
@pytest.mark.parametrize("degree", [1, 2])
def test_3d_vectors_against_a_sphere_lie_in_each_nodes_own_tangent_plane(tmp_path, degree):
    """A block (4 x 4 x 2 cells, clamped at its base) indented by a rigid sphere under Tresca's g: each node's rows
    measure along the frame turned into its own tangent plane (row_frames), so the file's vectors are orthogonal to
    the direction to the sphere's centre (computed here from the node and the centre), as long as their components;
    the components are the ContactResult's, bit for bit."""
    block = cc.box(x=(-1.0, 1.0), y=(-1.0, 1.0), z=(-1.0, 0.0), nx=4, ny=4, nz=2)
    body = cc.Body(block, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"])
    scene = cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.sphere(tuple(SPHERE), 2.0),
                                                law=cc.Tresca(1e8))])
    sol = cc.solve(scene, degree=degree)
    assert sol.ok
    c = sol.contact
    mesh, _ = _read(sol, tmp_path)
    _components_match(mesh, c, FIELDS)
    radial = c.points - SPHERE
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert np.abs(np.asarray(c.slip)).max() > 1e-3               # it slips (measured 1.7e-3 m, both degrees)
    for key, name in FIELDS.items():
        parts, v = np.asarray(getattr(c, key)), mesh.point_data[name.format("")]
        scale = np.abs(parts).max()
        assert np.abs(np.einsum("nd,nd->n", v, radial)).max() <= 1e-13 * scale      # measured 1.2e-16 of it
        assert np.abs(np.linalg.norm(v, axis=1) - np.linalg.norm(parts, axis=1)).max() <= 1e-13 * scale  # 3e-16


def test_2d_tresca_fields_read_back_along_the_tangent(tmp_path):
    """A pushed block sliding along x on the floor: components ``... t1`` are the ContactResult's, the vectors
    are them times the tangent (1, 0), padded with z = 0; the force unit is N/m."""
    _, scene = pushed(cc.Tresca(0.1 * P))
    sol = cc.solve(scene)
    assert sol.ok
    c = sol.contact
    mesh, js = _read(sol, tmp_path)
    fields = {**FIELDS, "shear_force": "shear force {}[N/m]"}
    _components_match(mesh, c, fields)
    for key, name in fields.items():
        v = mesh.point_data[name.format("")]
        np.testing.assert_array_equal(v, np.column_stack([getattr(c, key), np.zeros((len(c.x), 2))]))
    assert "slip t2 [m]" not in mesh.point_data
    assert js["contact"]["friction"]["total_shear_force_N_per_m"] == pytest.approx(
        [float(c.shear_force.sum()), 0.0], rel=1e-14, abs=0.0)


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")   # 2 faces span the zone
def test_2d_vectors_against_a_disk_lie_along_each_nodes_own_tangent(tmp_path):
    """The block dragged over a rigid disk (centre (0, -1) m) under Tresca's g: each node's row measures along the
    tangent turned to its own direction (row_tangents), so the file's vectors are orthogonal to the direction to
    the disk's centre (computed here), as long as their component."""
    sol = cc.solve(dragged_disk(cc.Tresca(0.1 * P)))
    assert sol.ok
    c = sol.contact
    mesh, _ = _read(sol, tmp_path)
    _components_match(mesh, c, {**FIELDS, "shear_force": "shear force {}[N/m]"})
    radial = c.points - [0.0, -1.0]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert np.abs(c.slip).max() > 1e-6                            # it slips (measured 4.8e-5 m)
    for key, name in {**FIELDS, "shear_force": "shear force {}[N/m]"}.items():
        parts, v = np.asarray(getattr(c, key)), mesh.point_data[name.format("")]
        scale = np.abs(parts).max()
        assert np.abs(np.einsum("nd,nd->n", v[:, :2], radial)).max() <= 1e-13 * scale   # measured 6e-17 of it
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), np.abs(parts), rtol=1e-14)


def test_3d_coulomb_threshold_is_written_per_node(tmp_path):
    """A pushed box under Coulomb's mu = 0.3: the threshold mu p varies over the nodes; the file holds
    ``sol.contact.threshold`` node by node and the summary its range."""
    sol = cc.solve(box((0.05 * P, 0.0), cc.Coulomb(0.3), push=(1e-5, 0.0)))
    assert sol.ok
    c = sol.contact
    mesh, js = _read(sol, tmp_path)
    g = np.asarray(c.threshold)
    assert g.shape == (len(c.x),) and g.max() > g.min()
    np.testing.assert_array_equal(mesh.point_data["slip threshold [Pa]"], g)
    assert js["contact"]["friction"]["threshold_Pa"] == {"min": float(g.min()), "max": float(g.max())}
    _components_match(mesh, c, FIELDS)


@pytest.mark.parametrize("dim", [2, 3])
def test_frictionless_output_has_no_friction_fields(tmp_path, dim):
    """A frictionless pair's contact VTU holds the frictionless fields only; its summary no ``friction`` key."""
    if dim == 2:
        _, scene = pushed(None)
    else:
        body = cc.Body(cc.box(nx=2, ny=2, nz=1), cc.materials.isotropic(70e9, 0.3), traction={"top": (0, 0, -1e6)},
                       roller=["left", "right", "front", "back"])
        scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])
    mesh, js = _read(cc.solve(scene), tmp_path)
    assert set(mesh.point_data) - {"nodal force [N]", "nodal force [N/m]"} == FRICTIONLESS
    assert "friction" not in js["contact"]
