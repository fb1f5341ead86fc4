"""TetMesh validation by blocks: the dihedral angles against an independent formula and a closed form, every
refusal of meshes.bad_meshes still firing when the blocks are a few tetrahedra (every block boundary
crossed), and the refusals whose path the blocked checks changed (a folded fan at a boundary edge, a node
joining three fans)."""

import numpy as np
import pytest
from meshes import UNIT, bad_meshes, positive, ring_around_an_edge

import cvxcontact as cc
from cvxcontact.errors import MeshError
from cvxcontact.geometry import tetmesh
from cvxcontact.geometry.tetmesh import EDGES, TetMesh, _dihedral_angles


def dihedral_by_edge_normals(points, tets):
    """(m, 6) dihedral angles from the normals of the two faces through each edge, each built from the edge
    and the vertex off it on that face (another route than the code's, which uses the four face normals)."""
    p = points[tets]
    other = np.array([[2, 3], [0, 3], [1, 3], [1, 2], [0, 1], [0, 2]])
    e = p[:, EDGES[:, 1]] - p[:, EDGES[:, 0]]
    n1 = np.cross(e, p[:, other[:, 0]] - p[:, EDGES[:, 0]])
    n2 = np.cross(e, p[:, other[:, 1]] - p[:, EDGES[:, 0]])
    return np.arctan2(np.linalg.norm(np.cross(n1, n2), axis=2), np.einsum("mek,mek->me", n1, n2))


@pytest.mark.numerics
def test_dihedral_angles_match_edge_normals_and_the_regular_tetrahedron():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(4000, 3))
    tets = positive(points, np.arange(4000).reshape(-1, 4))
    # measured 8.4e-15 rad (random tetrahedra, some nearly flat)
    np.testing.assert_allclose(_dihedral_angles(points, tets), dihedral_by_edge_normals(points, tets), rtol=0,
                               atol=1e-12)
    regular = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    np.testing.assert_allclose(_dihedral_angles(regular, positive(regular, [[0, 1, 2, 3]])), np.arccos(1 / 3),
                               rtol=0, atol=1e-14)             # measured 0


@pytest.mark.parametrize("points, tets, boundaries, message", bad_meshes(), ids=[b[-1][:30] for b in bad_meshes()])
def test_refusals_fire_alike_with_blocks_of_three_tetrahedra(monkeypatch, points, tets, boundaries, message):
    monkeypatch.setattr(tetmesh, "CHUNK", 3)
    with pytest.raises(MeshError, match=message):
        TetMesh(points, tets, boundaries)


def test_small_blocks_accept_a_box_and_find_its_boundary():
    """A box of 384 tetrahedra checked in blocks of 5: accepted, its boundary the 6 x 32 faces of its sides."""
    m = cc.box(nx=4, ny=4, nz=4)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(tetmesh, "CHUNK", 5)
        small = TetMesh(m.points, m.tets)
    assert len(small.boundary_faces) == 6 * 32
    np.testing.assert_array_equal(small.boundary_faces, m.boundary_faces)


def test_a_fan_folded_over_a_boundary_edge_is_refused():
    """The ring turning twice around edge (0, 1) less one tetrahedron: the edge is on the boundary and the
    tetrahedra turn 11/12 of two turns around it."""
    points, tets = ring_around_an_edge(2)
    with pytest.raises(MeshError, match=r"around boundary edge \(0, 1\) .* turn 1.833 times around it, expected "
                                        "less than 1"):
        TetMesh(points, tets[:-1])


def test_three_tetrahedra_touching_at_one_node_make_three_fans():
    """Three tetrahedra meeting only at the origin (octants +++, ---, and x > 0, y < 0): three fans at node 0."""
    third = np.array([[1, -1, 0.5], [1, -1.5, -0.5], [0.5, -2, 0]])
    points = np.vstack([UNIT, -UNIT[1:], third])
    tets = positive(points, [[0, 1, 2, 3], [0, 4, 5, 6], [0, 7, 8, 9]])
    with pytest.raises(MeshError, match=r"node 0 .* joins 3 separate fans"):
        TetMesh(points, tets)


def test_segments_decide_alike_given_either_way():
    """A segment (a, b) as the flat triangle (a, b, b) takes the segments' short list of axes; given as (a, a, b)
    it takes the general list: the two decide alike, on pairs that meet and pairs that do not."""
    from cvxcontact.geometry.tetmesh import _meet
    rng = np.random.default_rng(7)
    tri = rng.uniform(-1, 1, size=(3000, 3, 3))
    a, b = rng.uniform(-1.5, 1.5, size=(2, 3000, 3))
    tol = np.full(3000, 1e-9)
    short = _meet(np.stack([a, b, b], axis=1), tri, tol)
    general = _meet(np.stack([a, a, b], axis=1), tri, tol)
    np.testing.assert_array_equal(short, general)
    assert 0.02 < short.mean() < 0.98                                # both answers occur (measured 0.057)
