"""Tetrahedral meshes: TetMesh validation, the box and cylinder generators, gmsh reading, P2 nodes."""

import itertools

import meshio
import numpy as np
import pytest
from meshes import bad_meshes, crossing_bars, curled_strip, ring_around_an_edge

import cvxcontact as cc
from cvxcontact.errors import FrozenError, MeshError
from cvxcontact.fem import p2 as p2_basis
from cvxcontact.geometry.quadratic import P2TetNodes
from cvxcontact.geometry.tetmesh import TetMesh


def enclosed_volume(points, faces):
    """Volume enclosed by outward faces (divergence theorem), independent of the tetrahedra."""
    p = points[faces] - points.mean(axis=0)
    return np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6


def face_set(faces):
    return {tuple(sorted(f)) for f in np.asarray(faces).tolist()}


# --------------------------------------------------------------------------- box

def test_box_volumes_areas_and_side_tags():
    m = cc.box(x=(-1, 2), y=(0, 0.5), z=(1, 1.25), nx=5, ny=3, nz=2)
    assert m.dim == 3 and cc.Mesh.dim == 2
    flat = cc.rectangle(nx=2, ny=1)
    assert flat.dim == 2 and flat.cells is flat.triangles
    assert m.cells is m.tets and m.tets.shape == (6 * 30, 4) and m.points.shape == (6 * 4 * 3, 3)
    assert (m.volumes > 0).all()
    assert m.volumes.sum() == pytest.approx(3 * 0.5 * 0.25, rel=1e-14)            # measured 1e-16
    assert enclosed_volume(m.points, m.boundary_faces) == pytest.approx(3 * 0.5 * 0.25, rel=1e-13)
    area = {"left": 0.125, "right": 0.125, "front": 0.75, "back": 0.75, "bottom": 1.5, "top": 1.5}
    axis = {"left": -1, "right": 1, "front": -2, "back": 2, "bottom": -3, "top": 3}
    for tag in area:
        assert m.face_areas(tag).sum() == pytest.approx(area[tag], rel=1e-13)
        want = np.zeros(3)
        want[abs(axis[tag]) - 1] = np.sign(axis[tag])
        np.testing.assert_allclose(m.outward_normals(tag), np.tile(want, (len(m.boundary(tag)), 1)), atol=1e-15)
        # the tagged faces lie on their plane, and the orientation of boundary() is the outward one
        c = m.points[m.boundary(tag)][..., abs(axis[tag]) - 1]
        assert np.ptp(c) == 0
    # the six sides are the whole boundary: 2 triangles per grid quad, counted independently
    assert len(m.boundary_faces) == 2 * 2 * (5 * 3 + 3 * 2 + 5 * 2)
    assert face_set(np.vstack([m.boundary(t) for t in area])) == face_set(m.boundary_faces)
    assert m.size == pytest.approx(np.sqrt(9 + 0.25 + 0.0625))
    np.testing.assert_array_equal(m.node_components, 0)
    assert "TetMesh(72 nodes, 180 tetrahedra" in repr(m)


def test_box_is_mirror_symmetric_with_even_counts():
    m = cc.box(x=(-1, 1), y=(-1, 1), z=(0, 1), nx=4, ny=2, nz=3)
    tets = {tuple(sorted(t)) for t in m.tets.tolist()}
    for axis in (0, 1):
        mirrored = m.points.copy()
        mirrored[:, axis] *= -1
        key = {tuple(np.round(p, 12)): i for i, p in enumerate(m.points)}
        image = np.array([key[tuple(np.round(p, 12))] for p in mirrored])       # node -> its mirror node
        assert {tuple(sorted(image[t])) for t in m.tets.tolist()} == tets


def test_box_patch_is_a_union_of_faces_with_the_exact_area():
    m = cc.box(x=(0, 1), y=(0, 2), z=(0, 0.5), nx=7, ny=5, nz=4,
               patches={"punch": ("top", (0.3, 0.8), (0.25, 1.1)), "pad": ("left", (0.5, 1.5), (0.1, 0.4)),
                        "strip": ("front", (0.0, 1.0), (0.0, 0.2))})
    assert m.face_areas("punch").sum() == pytest.approx(0.5 * 0.85, rel=1e-13)
    assert m.face_areas("pad").sum() == pytest.approx(1.0 * 0.3, rel=1e-13)
    assert m.face_areas("strip").sum() == pytest.approx(1.0 * 0.2, rel=1e-13)
    # every top face is inside the rectangle or outside it: centroids sort them, nothing straddles
    top = m.points[m.boundary("top")]
    inside = (top[..., 0] >= 0.3).all(1) & (top[..., 0] <= 0.8).all(1) & (top[..., 1] >= 0.25).all(1) \
        & (top[..., 1] <= 1.1).all(1)
    outside = (top[..., 0] <= 0.3).all(1) | (top[..., 0] >= 0.8).all(1) | (top[..., 1] <= 0.25).all(1) \
        | (top[..., 1] >= 1.1).all(1)
    assert (inside | outside).all()
    assert face_set(m.boundary("punch")) == face_set(m.boundary("top")[inside])
    assert face_set(m.boundary("punch")) <= face_set(m.boundary("top"))              # a face carries two tags
    assert m.volumes.sum() == pytest.approx(1.0, rel=1e-13)


def test_box_patch_on_a_uniform_grid_keeps_it_uniform():
    m = cc.box(nx=8, ny=8, nz=2, patches={"p": ("top", (0.25, 0.75), (0.25, 0.75))})
    np.testing.assert_allclose(np.unique(m.points[:, 0]), np.linspace(0, 1, 9), atol=1e-15)


def test_box_grading_shrinks_cells_towards_the_point():
    point = (0.5, 0.5, 1.0)
    m = cc.box(nx=10, ny=10, nz=8, grade=(point, 20.0), patches={"c": ("top", (0.4, 0.6), (0.4, 0.6))})
    x = np.unique(m.points[:, 0])
    z = np.unique(m.points[:, 2])
    assert 0.5 in x and 1.0 in z and 0.4 in x and 0.6 in x
    hx, hz = np.diff(x), np.diff(z)
    half = hx[x[1:] <= 0.5]
    assert (np.diff(half) < 0).all() and (np.diff(hz) < 0).all()        # shrinking towards x = 0.5 and z = 1
    assert hz.max() / hz.min() == pytest.approx(20.0, rel=1e-6)       # the bisection's target: measured 1e-12
    for n in (3, 8, 33):                                                 # geometric: consecutive ratios equal
        hz = np.diff(np.unique(cc.box(nx=2, ny=2, nz=n, grade=(point, 20.0)).points[:, 2]))
        q = hz[:-1] / hz[1:]
        assert np.ptp(q) < 1e-9 * q.mean() and hz[0] / hz[-1] == pytest.approx(20.0, rel=1e-6)  # 5e-14, 2e-12
    assert m.volumes.sum() == pytest.approx(1.0, rel=1e-13)
    assert m.face_areas("c").sum() == pytest.approx(0.04, rel=1e-12)


def test_box_bad_arguments():
    with pytest.raises(MeshError, match="nz must be a positive integer"):
        cc.box(nz=0)
    with pytest.raises(MeshError, match="x must be a finite interval"):
        cc.box(x=(1, 0))
    with pytest.raises(MeshError, match="face must be one of"):
        cc.box(patches={"p": ("roof", (0, 1), (0, 1))})
    with pytest.raises(MeshError, match="the y range"):
        cc.box(patches={"p": ("top", (0, 1), (0.5, 2))})
    with pytest.raises(MeshError, match="must be a new tag"):
        cc.box(patches={"top": ("top", (0, 1), (0, 1))})
    with pytest.raises(MeshError, match="nx = 2 cells cannot put grid lines"):
        cc.box(nx=2, patches={"p": ("top", (0.2, 0.4), (0, 1))})
    with pytest.raises(MeshError, match="outside the box"):
        cc.box(grade=((0.5, 0.5, 2.0), 4))
    with pytest.raises(MeshError, match="ratio >= 1"):
        cc.box(grade=((0.5, 0.5, 1.0), 0.5))
    with pytest.raises(MeshError, match="cells is more than the limit"):
        cc.box(nx=1000, ny=1000, nz=1000)


# --------------------------------------------------------------------------- cylinder

@pytest.mark.parametrize("n_r", [1, 2, 4])
def test_cylinder_volume_is_the_polygon_prism_and_converges(n_r):
    r, h, n_theta = 0.3, 0.1, 6 * n_r
    m = cc.cylinder(r, h, n_r=n_r, n_z=2, center=(1, -1, 0.5))
    polygon = 0.5 * n_theta * r ** 2 * np.sin(2 * np.pi / n_theta)          # inscribed polygon, closed form
    assert m.volumes.sum() == pytest.approx(polygon * h, rel=1e-13)
    assert m.face_areas("top").sum() == pytest.approx(polygon, rel=1e-13)
    assert m.face_areas("side").sum() == pytest.approx(n_theta * 2 * r * np.sin(np.pi / n_theta) * h, rel=1e-13)
    assert abs(m.volumes.sum() / (np.pi * r ** 2 * h) - 1) < 0.2 / n_r ** 2    # measured 0.173, 0.045, 0.011
    assert m.points[:, 2].min() == 0.5 and m.points[:, 2].max() == pytest.approx(0.6)
    np.testing.assert_allclose(m.outward_normals("top"), [[0, 0, 1]] * len(m.boundary("top")), atol=1e-15)
    np.testing.assert_allclose(m.outward_normals("bottom"), [[0, 0, -1]] * len(m.boundary("bottom")), atol=1e-15)
    side = m.outward_normals("side")
    radial = m.points[m.boundary("side")].mean(axis=1)[:, :2] - [1, -1]
    assert np.abs(side[:, 2]).max() < 1e-15 and (np.einsum("ij,ij->i", side[:, :2], radial) > 0).all()
    assert face_set(np.vstack([m.boundary(t) for t in m.tags])) == face_set(m.boundary_faces)


def test_cylinder_bad_arguments():
    with pytest.raises(MeshError, match="radius must be a positive number"):
        cc.cylinder(0.0, 1.0)
    with pytest.raises(MeshError, match="multiple of n_r"):
        cc.cylinder(1.0, 1.0, n_r=2, n_theta=7)


# --------------------------------------------------------------------------- TetMesh

def test_tetmesh_is_immutable_and_with_points_scales():
    m = cc.box(nx=2, ny=2, nz=1)
    for a in (m.points, m.tets, m.boundary("top"), m.volumes, m.boundary_faces):
        with pytest.raises(ValueError):
            a[0] = 0
    with pytest.raises(FrozenError, match="with_points"):
        m.points = m.points
    s = m.with_points(1e-3 * m.points)
    assert s.volumes.sum() == pytest.approx(1e-9, rel=1e-13)
    assert s.tags == m.tags and face_set(s.boundary("top")) == face_set(m.boundary("top"))
    with pytest.raises(MeshError, match=r"shape \(18, 3\)"):
        m.with_points(m.points[:, :2])
    np.testing.assert_array_equal(m.boundary_nodes(["top", "bottom"]), np.arange(18))
    np.testing.assert_array_equal(m.boundary_nodes("top"), np.unique(m.boundary("top")))
    with pytest.raises(MeshError, match="unknown boundary tag 'roof'"):
        m.boundary("roof")


def test_negative_mesh_is_reoriented_and_tags_are_oriented_outwards():
    m = cc.box(nx=2, ny=1, nz=1)
    flipped = TetMesh(m.points, m.tets[:, [1, 0, 2, 3]], {"top": m.boundary("top")[:, ::-1]})
    assert (flipped.volumes > 0).all()
    np.testing.assert_allclose(flipped.outward_normals("top"), [[0, 0, 1]] * 4, atol=1e-15)


def test_two_pieces_and_a_cavity_are_accepted():
    a = cc.box(nx=1, ny=1, nz=1)
    b = cc.box(x=(2, 3), nx=1, ny=1, nz=1)
    m = TetMesh(np.vstack([a.points, b.points]), np.vstack([a.tets, b.tets + len(a.points)]))
    np.testing.assert_array_equal(m.components, [0] * 6 + [1] * 6)
    hollow = cc.box(x=(-3, 3), y=(-3, 3), z=(-3, 3), nx=3, ny=3, nz=3)       # remove the middle cell
    centre = hollow.points[hollow.tets].mean(axis=1)
    keep = np.abs(centre).max(axis=1) > 1
    core = cc.box(x=(-0.5, 0.5), y=(-0.5, 0.5), z=(-0.5, 0.5), nx=1, ny=1, nz=1)
    shell = TetMesh(hollow.points, hollow.tets[keep])
    assert enclosed_volume(shell.points, shell.boundary_faces) == pytest.approx(216 - 8)
    nested = TetMesh(np.vstack([hollow.points, core.points]),
                     np.vstack([hollow.tets[keep], core.tets + len(hollow.points)]))
    assert nested.volumes.sum() == pytest.approx(216 - 8 + 1)


@pytest.mark.parametrize("points, tets, boundaries, message", bad_meshes(),
                         ids=[b[-1][:30] for b in bad_meshes()])
def test_bad_meshes_are_refused_naming_the_element(points, tets, boundaries, message):
    with pytest.raises(MeshError, match=message):
        TetMesh(points, tets, boundaries)


def test_ring_around_an_edge_turning_once_is_a_mesh():
    """The crafted wrap above is a bad mesh only because it turns twice."""
    m = TetMesh(*ring_around_an_edge(1))
    assert m.volumes.sum() == pytest.approx(enclosed_volume(m.points, m.boundary_faces))


def test_curled_strip_short_of_a_full_turn_is_a_mesh():
    """The crafted overlap above is a bad mesh only because it turns more than once (a gap of 0.2 rad)."""
    m = TetMesh(*curled_strip(2 * np.pi - 0.2))
    assert m.volumes.sum() == pytest.approx(enclosed_volume(m.points, m.boundary_faces))


@pytest.mark.parametrize("a, b, meet", [
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.2, 0.2, -1], [0.2, 0.2, 1], [1, 1, 1]], True),     # pierces
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.6, 0.6, -1], [0.6, 0.6, 1], [1, 1, 1]], False),    # passes by the edge
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.2, 0.2, 0], [2, 0.2, 0], [0.2, 2, 0]], True),      # coplanar overlap
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.6, 0.6, 0], [2, 0.6, 0], [0.6, 2, 0]], False),     # coplanar apart
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.5, 0.5, 0], [2, 0.5, 0], [0.5, 2, 0]], True),      # touching
    ([[0.2, 0.2, -1], [0.2, 0.2, 1], [0.2, 0.2, 1]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], True),  # a segment through
    ([[0.6, 0.6, -1], [0.6, 0.6, 1], [0.6, 0.6, 1]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], False),  # a segment by
    ([[0.1, 0.1, 0], [0.3, 0.1, 0], [0.3, 0.1, 0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], True),  # in the plane, inside
])
def test_separating_axes_of_two_triangles(a, b, meet):
    """The face-face test of the self-intersection check, against cases decided by hand."""
    from cvxcontact.geometry.tetmesh import _meet
    assert _meet(np.array([a], float), np.array([b], float), np.array([1e-9]))[0] == meet
    assert _meet(np.array([b], float), np.array([a], float), np.array([1e-9]))[0] == meet


SCALES = [1e-12, 1e-9, 1e6]     # lengths in m; 1e-9 and 1e-12 were refused as "cuts through itself" (issue 29)


@pytest.mark.parametrize("h", SCALES)
def test_a_box_builds_at_any_length_scale(h):
    """The same grid at edge h: the same tetrahedra, faces and tags as at 1 m, the volume h^3 times."""
    unit = cc.box(x=(0, 1), y=(0, 2), z=(0, 1), nx=3, ny=4, nz=2)
    m = cc.box(x=(0, h), y=(0, 2 * h), z=(0, h), nx=3, ny=4, nz=2)
    np.testing.assert_array_equal(m.tets, unit.tets)
    assert face_set(m.boundary_faces) == face_set(unit.boundary_faces) and m.tags == unit.tags
    assert m.volumes.sum() == pytest.approx(2 * h ** 3, rel=1e-13)              # measured ~1e-16
    assert enclosed_volume(m.points, m.boundary_faces) == pytest.approx(2 * h ** 3, rel=1e-13)
    assert unit.with_points(h * unit.points).volumes.sum() == pytest.approx(2 * h ** 3, rel=1e-13)
    c = cc.cylinder(radius=h, height=2 * h, n_r=2, n_z=2)
    assert c.volumes.sum() == pytest.approx(h ** 3 * cc.cylinder(radius=1, height=2, n_r=2, n_z=2).volumes.sum(),
                                            rel=1e-12)


@pytest.mark.parametrize("h", SCALES)
def test_a_surface_cutting_through_itself_is_refused_at_any_length_scale(h):
    """The crafted self-intersections above, scaled: still refused; the strip short of a turn still a mesh."""
    for points, tets in (crossing_bars(), curled_strip(2.2 * np.pi)):
        with pytest.raises(MeshError,
                           match="boundary faces .* meet near .* the boundary surface cuts through itself"):
            TetMesh(h * points, tets)
    points, tets = curled_strip(2 * np.pi - 0.2)
    assert TetMesh(h * points, tets).volumes.sum() == pytest.approx(h ** 3 * TetMesh(points, tets).volumes.sum(),
                                                                     rel=1e-12)


@pytest.mark.parametrize("h", SCALES)
def test_separating_axes_decide_alike_at_any_length_scale(h):
    """The hand-decided face pairs of test_separating_axes_of_two_triangles, scaled by h (tol too)."""
    from cvxcontact.geometry.tetmesh import _meet

    cases = test_separating_axes_of_two_triangles.pytestmark[0].args[1]
    a = h * np.array([c[0] for c in cases], float)
    b = h * np.array([c[1] for c in cases], float)
    tol = np.full(len(cases), 1e-9 * h)
    assert _meet(a, b, tol).tolist() == _meet(b, a, tol).tolist() == [c[2] for c in cases]


def test_interior_face_of_a_box_is_not_a_boundary_face():
    m = cc.box(nx=2, ny=2, nz=2)
    inner = [[13, 14, 4]]                                       # the centre node 13 is interior
    assert 13 not in m.boundary_faces
    with pytest.raises(MeshError):
        TetMesh(m.points, m.tets, {"x": inner})


# --------------------------------------------------------------------------- reading

def write_msh(path, m, names, order=1, bend=0.0):
    """A gmsh file of the TetMesh m (tags named ``names`` -> physical ids), optionally tetra10."""
    points, tets = m.points, m.tets
    cells = [("tetra", tets)]
    field = {"body": np.array([1, 3])}
    tri_cells, tri_ids = [], []
    for k, tag in enumerate(names):
        tri_cells.append(m.boundary(tag))
        tri_ids.append(np.full(len(m.boundary(tag)), 10 + k))
        field[tag] = np.array([10 + k, 2])
    tri = np.vstack(tri_cells)
    if order == 2:
        p2 = P2TetNodes(m)
        points = p2.points.copy()
        points[m.points.shape[0]:, 2] += bend
        cells = [("tetra10", p2.tets10)]
        tri = np.vstack([p2.boundary(t) for t in names])
    cells.append(("triangle6" if order == 2 else "triangle", tri))
    mesh = meshio.Mesh(points, cells, cell_data={"gmsh:physical": [np.ones(len(tets), int), np.concatenate(tri_ids)],
                                                 "gmsh:geometrical": [np.ones(len(tets), int),
                                                                      np.concatenate(tri_ids)]},
                       field_data=field)
    meshio.write(path, mesh, file_format="gmsh22", binary=False)


@pytest.mark.parametrize("order", [1, 2])
def test_read_mesh_round_trip(tmp_path, order):
    m = cc.box(x=(0, 2), nx=4, ny=2, nz=1, patches={"punch": ("top", (0.5, 1.5), (0, 0.5))})
    path = tmp_path / "block.msh"
    write_msh(path, m, ["bottom", "punch"], order=order)
    r = cc.read_mesh(path)
    assert isinstance(r, TetMesh) and r.tags == ("bottom", "punch")
    np.testing.assert_array_equal(r.points, m.points)              # the vertices come first: same numbering
    assert {tuple(sorted(t)) for t in r.tets.tolist()} == {tuple(sorted(t)) for t in m.tets.tolist()}
    for tag in r.tags:
        assert face_set(r.boundary(tag)) == face_set(m.boundary(tag))
        np.testing.assert_allclose(r.outward_normals(tag), m.outward_normals(tag), atol=1e-15)


def test_read_mesh_refuses_curved_tetra10(tmp_path):
    m = cc.box(nx=1, ny=1, nz=1)
    path = tmp_path / "curved.msh"
    write_msh(path, m, ["top"], order=2, bend=0.01)
    with pytest.raises(MeshError, match="curved edge"):
        cc.read_mesh(path)


def test_read_mesh_region_selects_a_volume(tmp_path):
    a = cc.box(nx=1, ny=1, nz=1)
    b = cc.box(z=(1, 2), nx=1, ny=1, nz=1)
    points = np.vstack([a.points, b.points])
    mesh = meshio.Mesh(points, [("tetra", a.tets), ("tetra", b.tets + 8),
                                ("triangle", a.boundary("bottom")), ("triangle", b.boundary("top") + 8)],
                       cell_data={"gmsh:physical": [np.full(6, 1), np.full(6, 2), np.full(2, 11), np.full(2, 12)],
                                  "gmsh:geometrical": [np.full(6, 1), np.full(6, 2), np.full(2, 11),
                                                       np.full(2, 12)]},
                       field_data={"lower": np.array([1, 3]), "upper": np.array([2, 3]),
                                   "floor": np.array([11, 2]), "lid": np.array([12, 2])})
    path = tmp_path / "two.msh"
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    up = cc.read_mesh(path, region="upper")
    assert up.tags == ("lid",) and up.volumes.sum() == pytest.approx(1.0)
    assert up.points[:, 2].min() == 1.0
    with pytest.raises(MeshError, match="no physical volume 'middle'; it has \\['lower', 'upper'\\]"):
        cc.read_mesh(path, region="middle")


# --------------------------------------------------------------------------- P2 nodes

def test_p2_tet_nodes_are_the_edge_midpoints():
    m = cc.box(nx=2, ny=1, nz=2)
    p2 = P2TetNodes(m)
    n = len(m.points)
    edges = {tuple(sorted(e)) for t in m.tets.tolist() for e in itertools.combinations(t, 2)}
    assert len(p2) == n + len(edges) and p2.cells is p2.tets10 and p2.tets10.shape == (len(m.tets), 10)
    local = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)]                  # the documented gmsh tetra10 order
    assert [tuple(e) for e in p2_basis.EDGES[3]] == local                     # the P2 basis numbers them alike
    for k, (i, j) in enumerate(local):
        np.testing.assert_allclose(p2.points[p2.tets10[:, 4 + k]],
                                   0.5 * (m.points[m.tets[:, i]] + m.points[m.tets[:, j]]), atol=1e-15)
    f = p2.boundary("top")
    assert f.shape == (len(m.boundary("top")), 6)
    np.testing.assert_array_equal(f[:, :3], m.boundary("top"))
    for k, (i, j) in enumerate([(0, 1), (1, 2), (2, 0)]):
        np.testing.assert_allclose(p2.points[f[:, 3 + k]], 0.5 * (p2.points[f[:, i]] + p2.points[f[:, j]]))
    top = p2.boundary_nodes(["top"])
    assert np.allclose(p2.points[top, 2], 1.0) and len(top) == (2 * 2 + 1) * (2 * 1 + 1)
    with pytest.raises(MeshError, match="not an edge"):
        p2.midpoint([0], [n - 1])


# --------------------------------------------------------------------------- pieces, moved points

def _two_boxes():
    """Two separate unit boxes (the second at x in (2, 3)), the first one's bottom and top tagged."""
    a, b = cc.box(nx=1, ny=1, nz=1), cc.box(x=(2, 3), nx=1, ny=1, nz=1)
    return TetMesh(np.vstack([a.points, b.points]), np.vstack([a.tets, b.tets + len(a.points)]),
                   {"bottom": a.boundary("bottom"), "top": a.boundary("top")})


def test_a_piece_nothing_holds_or_no_electrode_reaches_is_refused_naming_it():
    """As in 2D: a mesh may have several pieces, but a body's piece held by nothing (its six rigid motions)
    or a piezoelectric piece no grounded or driven electrode touches is a SceneError naming the piece."""
    m = _two_boxes()
    alu = cc.materials.isotropic(E=70e9, nu=0.3)
    body = cc.Body(m, alu, clamped=["bottom"], contact="top")
    with pytest.raises(cc.SceneError, match=r"translation along x of mesh component 1 \(6 tetrahedra, centroid at "
                                            r"\(2.5, 0.5, 0.5\) m\)"):
        cc.Scene(body, contacts=[cc.Contact(body, "top", cc.Rigid.plane((0, 0, 1.5), (0, 0, -1)))])
    with pytest.raises(cc.SceneError, match=r"mesh component 1 \(6 tetrahedra.*no grounded or driven electrode"):
        cc.Body(m, cc.materials.PZT5A, clamped=["bottom"], grounded=["bottom"])


def test_with_points_refuses_what_the_constructor_refuses():
    m = cc.box(nx=2, ny=2, nz=2)
    close = m.points.copy()
    close[1] = close[0] + 1e-13
    with pytest.raises(MeshError, match="duplicate nodes 0 and 1"):
        m.with_points(close)
    folded = m.points.copy()
    folded[13] = [0.5, 0.5, 5.0]                               # the centre node pulled out through the top
    with pytest.raises(MeshError, match="inverted tetrahedra.*e.g. tetrahedron"):
        m.with_points(folded)
    mirrored = m.with_points(m.points * [1, 1, -1])            # every element reversed: reoriented, tags outward
    assert (mirrored.volumes > 0).all()
    np.testing.assert_allclose(mirrored.outward_normals("top"), [[0, 0, -1]] * len(m.boundary("top")), atol=1e-15)
