"""Defective meshes are refused: overlaps and folds, near-duplicate nodes, loose components, in-place edits."""

from pathlib import Path

import numpy as np
import pytest

import cvxcontact as cc

MESHES = Path(__file__).resolve().parents[1] / "examples" / "meshes"


def _square(x0, y0, side, n):
    """Nodes and counter-clockwise triangles of an n x n square grid (built here, not by cc.rectangle)."""
    t = np.linspace(0.0, side, n + 1)
    X, Y = np.meshgrid(x0 + t, y0 + t)
    node = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    sw, se, nw, ne = node[:-1, :-1].ravel(), node[:-1, 1:].ravel(), node[1:, :-1].ravel(), node[1:, 1:].ravel()
    tris = np.concatenate([np.column_stack([sw, se, ne]), np.column_stack([sw, ne, nw])])
    return np.column_stack([X.ravel(), Y.ravel()]), tris, node


def _union(*parts):
    points, tris, off = [], [], 0
    for p, t in parts:
        points.append(p)
        tris.append(t + off)
        off += len(p)
    return np.concatenate(points), np.concatenate(tris)


# ------------------------------------------------------------------------------------ valid meshes pass

@pytest.mark.parametrize("diagonal", ["right", "left", "alternate"])
def test_package_meshes_pass(diagonal):
    m = cc.rectangle(x=(0, 2), y=(0, 1), nx=7, ny=4, diagonal=diagonal)
    assert m.areas.sum() == pytest.approx(2.0) and m.components.max() == 0


@pytest.mark.parametrize("name", ["lower.msh", "upper_hole.msh"])
def test_gmsh_meshes_pass(name):
    m = cc.read_mesh(MESHES / name)
    again = cc.read_mesh(MESHES / name, region="body")
    assert np.array_equal(m.triangles, again.triangles) and m.components.max() == 0


def test_separate_and_nested_pieces_without_overlap_pass():
    """An island inside a hole of a frame: three loops, one layer everywhere."""
    p, t, node = _square(0, 0, 3, 3)
    frame = np.delete(t, [4, 13], axis=0)              # remove the centre cell: a hole [1, 2]^2
    island, ti, _ = _square(1.25, 1.25, 0.5, 2)
    m = cc.Mesh(*_union((p, frame), (island, ti)))
    assert m.areas.sum() == pytest.approx(9 - 1 + 0.25)
    assert np.bincount(m.components).tolist() == [16, 8]


# ------------------------------------------------------------------------------------ overlaps and folds

def test_extra_overlapping_triangle_on_existing_nodes():
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=4)
    p = m.points
    corners = [int(np.argmin(np.hypot(*(p - c).T))) for c in ([0.25, 0.125], [0.75, 0.125], [0.5, 0.375])]
    a, b, c = p[corners]
    assert (b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0] > 0                   # same orientation as the mesh
    with pytest.raises(cc.MeshError, match="overlap"):
        cc.Mesh(p, np.vstack([m.triangles, corners]))


@pytest.mark.parametrize("perm", [[1, 2, 0], [2, 0, 1]])
def test_triangle_duplicated_with_permuted_nodes(perm):
    p = [[0, 0], [1, 0], [0, 1]]
    with pytest.raises(cc.MeshError, match="overlap"):
        cc.Mesh(p, [[0, 1, 2], np.array([0, 1, 2])[perm]])


def test_fan_wrapping_twice_around_a_node():
    """Seven triangles around one node, each turning 4 pi / 7: the angles sum to 4 pi."""
    phi = 4 * np.pi * np.arange(7) / 7
    p = np.vstack([[0, 0], np.column_stack([np.cos(phi), np.sin(phi)])])
    t = [[0, 1 + k, 1 + (k + 1) % 7] for k in range(7)]
    with pytest.raises(cc.MeshError, match=r"overlap at interior node 0.*720\.0 deg"):
        cc.Mesh(p, t)


def test_two_squares_overlapping_without_shared_nodes():
    with pytest.raises(cc.MeshError, match="boundary edges .* cross"):
        cc.Mesh(*_union(_square(0, 0, 1, 2)[:2], _square(0.6, 0.3, 1, 2)[:2]))


def test_square_nested_inside_another():
    with pytest.raises(cc.MeshError, match="inside 1 other layer"):
        cc.Mesh(*_union(_square(0, 0, 1, 2)[:2], _square(0.2, 0.15, 0.2, 1)[:2]))


@pytest.mark.parametrize("h", [1e-12, 1e-9, 1.0, 1e6])
def test_checks_decide_alike_at_any_length_scale(h):
    """The 2D checks are relative to the mesh: a square grid of side h passes, two overlapping squares and
    a nested one are refused, and a third coordinate varying by 1e-6 of the size is refused (it was
    accepted below 1 m: the planar check had an absolute floor of 1e-12 m), 1e-14 of it accepted."""
    p, t, _ = _square(0, 0, h, 3)
    assert cc.Mesh(p, t).areas.sum() == pytest.approx(h * h, rel=1e-13)
    assert cc.rectangle(x=(0, h), y=(0, h), nx=3, ny=3).areas.sum() == pytest.approx(h * h, rel=1e-13)
    with pytest.raises(cc.MeshError, match="boundary edges .* cross"):
        cc.Mesh(*_union(_square(0, 0, h, 2)[:2], _square(0.6 * h, 0.3 * h, h, 2)[:2]))
    with pytest.raises(cc.MeshError, match="inside 1 other layer"):
        cc.Mesh(*_union(_square(0, 0, h, 2)[:2], _square(0.2 * h, 0.15 * h, 0.2 * h, 1)[:2]))
    z = np.zeros(len(p))
    z[4] = 1e-6 * h
    with pytest.raises(cc.MeshError, match="varying third coordinate"):
        cc.Mesh(np.column_stack([p, z]), t)
    z[4] = 1e-14 * h
    assert cc.Mesh(np.column_stack([p, z]), t).areas.sum() == pytest.approx(h * h, rel=1e-13)


# ------------------------------------------------------------------------------------ near-duplicate nodes

@pytest.mark.parametrize("dx", [1e-13, 1e-10])
def test_near_duplicates_not_adjacent_in_a_sorted_order(dx):
    """Two halves of a block with their own nodes on x = 0.5: pairs sit 1e-13..1e-10 m apart, and nodes
    of the same half lie between them in a lexicographic order."""
    left, tl, _ = _square(0.0, 0.0, 0.5, 2)
    right, tr, _ = _square(0.5 + dx, 0.0, 0.5, 2)
    with pytest.raises(cc.MeshError, match="duplicate nodes"):
        cc.Mesh(*_union((left, tl), (right, tr)))


def test_small_but_distinct_elements_pass():
    p, t, _ = _square(0.0, 0.0, 1e-9, 2)                  # 0.5 nm cells: small, not duplicates
    assert cc.Mesh(p, t).areas.sum() == pytest.approx(1e-18)


# ------------------------------------------------------------------------------------ components

def _two_pieces():
    p1, t1, n1 = _square(0.0, 0.0, 1.0, 4)
    p2, t2, n2 = _square(2.0, 0.0, 0.5, 2)
    p, t = _union((p1, t1), (p2, t2))
    off = len(p1)
    strip = lambda row: np.column_stack([row[:-1], row[1:]])
    tags = {"top": np.vstack([strip(n1[-1])[:, ::-1], strip(n2[-1])[:, ::-1] + off]),
            "ground": strip(n1[-1])[:, ::-1], "bottom": strip(n1[0]), "top2": strip(n2[-1])[:, ::-1] + off}
    return cc.Mesh(p, t, tags)


def test_components_label_triangles_and_nodes():
    m = _two_pieces()
    assert np.bincount(m.components).tolist() == [32, 8]
    assert np.bincount(m.node_components).tolist() == [25, 9]
    assert (m.points[m.node_components == 1, 0] >= 2.0).all()


def test_unclamped_component_is_refused():
    m = _two_pieces()
    steel = cc.materials.isotropic(E=200e9, nu=0.3)
    body = cc.Body(m, steel, clamped=["ground"], contact="bottom")   # refused by the scene, which knows its pairs
    with pytest.raises(cc.SceneError, match=r"component 1 \(8 triangles, centroid at \(2.25, 0.25\) m\).*clamped"):
        cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)))])
    cc.Body(m, steel, clamped=["top"], contact="bottom")    # both pieces held: accepted


def test_piezo_component_without_electrode_is_refused():
    m = _two_pieces()
    with pytest.raises(cc.SceneError, match=r"component 1 \(8 triangles.*electrode"):
        cc.Body(m, cc.materials.PZT4, clamped=["top"], grounded=["ground"], contact="bottom")
    cc.Body(m, cc.materials.PZT4, clamped=["top"], grounded=["ground"], potential={"top2": 5.0}, contact="bottom")


# ------------------------------------------------------------------------------------ immutability

def test_mesh_arrays_are_read_only_copies():
    p, t, node = _square(0.0, 0.0, 1.0, 2)
    bottom = np.column_stack([node[0, :-1], node[0, 1:]])
    m = cc.Mesh(p, t, {"bottom": bottom})
    area = m.areas.sum()
    with pytest.raises(ValueError):
        m.points *= 2
    with pytest.raises(ValueError):
        m.triangles[0, 0] = 5
    with pytest.raises(ValueError):
        m.boundary("bottom")[0, 0] = 5
    p *= 2                                                   # the caller's arrays stay theirs
    t[:] = 0
    bottom[:] = 0
    assert m.areas.sum() == area and m.points.max() == 1.0 and m.triangles.max() == 8
    assert m.boundary("bottom").max() == 2


def test_with_points_builds_a_new_validated_mesh():
    m = cc.rectangle(x=(0, 1), y=(0, 1), nx=3, ny=2)
    A = np.array([[-2.0, 0.5], [0.0, 3.0]])                # a mirror: the triangles get reoriented
    moved = m.with_points(m.points @ A.T + [1.0, -4.0])
    assert moved is not m and np.array_equal(m.points, cc.rectangle(x=(0, 1), y=(0, 1), nx=3, ny=2).points)
    assert np.allclose(moved.areas, abs(np.linalg.det(A)) / (3 * 2 * 2))
    assert np.allclose(moved.outward_normals("top"), [0, 1])  # still outward after the mirror
    assert set(moved.tags) == set(m.tags)
    with pytest.raises(cc.MeshError, match=r"shape \(12, 2\)"):
        m.with_points(m.points[:-1])
    folded = m.points.copy()
    folded[np.argmin(np.hypot(*(folded - [1 / 3, 0.5]).T))] = [5.0, 0.5]   # an interior node pulled outside
    with pytest.raises(cc.MeshError, match="inverted|overlap"):
        m.with_points(folded)
