"""Local refinement of tetrahedra by longest-edge bisection (cvxcontact.geometry.refine.bisect_tets through
refine_marked): conformity checked from the faces, volumes, tags, parents, shape, bad input."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.geometry.refine import refine_marked


def jittered_box(n=3, seed=1, amount=0.08):
    """cc.box(n, n, n) of the unit cube with its interior nodes moved at random (no two edges of a cell alike)."""
    mesh = cc.box(nx=n, ny=n, nz=n)
    p = mesh.points.copy()
    inner = (p > 1e-9).all(axis=1) & (p < 1 - 1e-9).all(axis=1)
    p[inner] += amount * (np.random.default_rng(seed).random((inner.sum(), 3)) - 0.5)
    return mesh.with_points(p)


def face_counts(tets):
    """(faces, counts): every face of the tetrahedra as a sorted node triple with the number of cells holding it."""
    f = np.sort(tets[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1)
    return np.unique(f, axis=0, return_counts=True)


def triangle_areas(points, faces):
    p = points[faces]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def min_dihedral(points, tets):
    """Smallest interior dihedral angle (degrees), from the faces' normals (independent of tetmesh's own)."""
    p = points[tets]
    normals = []
    for opposite in range(4):                                  # the normal of the face opposite each vertex,
        f = [k for k in range(4) if k != opposite]             # pointing towards that vertex
        n = np.cross(p[:, f[1]] - p[:, f[0]], p[:, f[2]] - p[:, f[0]])
        n *= np.sign(((p[:, opposite] - p[:, f[0]]) * n).sum(axis=1))[:, None]
        normals.append(n / np.linalg.norm(n, axis=1)[:, None])
    cos = [-(normals[i] * normals[j]).sum(axis=1) for i in range(4) for j in range(i + 1, 4)]
    return np.degrees(np.arccos(np.clip(np.max(cos, axis=0), -1, 1))).min()


def random_rounds(mesh, rounds, fraction, seed):
    rng = np.random.default_rng(seed)
    for _ in range(rounds):
        fine, parent = refine_marked(mesh, rng.random(len(mesh.tets)) < fraction)
        yield mesh, fine, parent
        mesh = fine


SHIFTED = cc.box(x=(0.1, 1.1), y=(0.3, 1.3), z=(-0.7, 0.3), nx=2, ny=2, nz=2)
"""Equal edges whose computed lengths differ in the last bits (3 squared lengths, 8 floats; the unit box's: 3):
the order must still be shared by every cell holding an edge."""


@pytest.mark.parametrize("mesh", [cc.box(nx=2, ny=2, nz=2), SHIFTED, jittered_box()],
                         ids=["kuhn box", "shifted kuhn box", "jittered box"])
def test_conforming_volumes_tags_and_parents(mesh):
    """Every round, checked from the tetrahedra alone: each face lies in one or two cells, the faces in one
    cover exactly the cube's surface (area 6: a hanging node would leave inner faces with one cell) and are
    exactly the tagged faces; each coarse cell's volume is its children's sum, every child lies inside its
    parent and has 1/2^k of its volume (bisections halve); each tag's area is kept; the coarse nodes keep
    their place and number."""
    for coarse, fine, parent in random_rounds(mesh, 5, 0.15, seed=1):
        assert len(fine.tets) > len(coarse.tets)
        faces, counts = face_counts(fine.tets)
        assert set(counts.tolist()) == {1, 2}
        outer = faces[counts == 1]
        assert triangle_areas(fine.points, outer).sum() == pytest.approx(6.0, rel=1e-12)   # measured 1.5e-16
        tagged = np.unique(np.sort(np.concatenate([fine.boundary(t) for t in fine.tags]), axis=1), axis=0)
        assert np.array_equal(tagged, outer)
        children = np.bincount(parent, weights=fine.volumes, minlength=len(coarse.tets))
        np.testing.assert_allclose(children, coarse.volumes, rtol=1e-12)                  # measured <= 1.1e-15
        halvings = np.log2(coarse.volumes[parent] / fine.volumes)
        np.testing.assert_allclose(halvings, np.rint(halvings), atol=1e-9)                 # measured 2.7e-15
        assert np.all(np.diff(parent) >= 0)                      # children together, in the coarse order
        corners = coarse.points[coarse.tets[parent]]             # (m, 4, 3) the parent of each fine cell
        T = np.transpose(corners[:, 1:] - corners[:, :1], (0, 2, 1))
        for k in range(4):
            lam = np.linalg.solve(T, (fine.points[fine.tets[:, k]] - corners[:, 0])[..., None])[..., 0]
            lam = np.column_stack([1 - lam.sum(axis=1), lam])
            assert lam.min() > -1e-12                                                      # measured -1.0e-15
        for t in coarse.tags:
            assert fine.face_areas(t).sum() == pytest.approx(coarse.face_areas(t).sum(), rel=1e-12)
        assert np.array_equal(fine.points[:len(coarse.points)], coarse.points)


def test_only_what_conformity_needs():
    """Marking nothing changes nothing; marking one cell refines a neighbourhood of it, not the mesh."""
    mesh = jittered_box()
    same, parent = refine_marked(mesh, np.zeros(len(mesh.tets), bool))
    assert np.array_equal(same.tets, mesh.tets) and np.array_equal(parent, np.arange(len(mesh.tets)))
    fine, parent = refine_marked(mesh, [0])
    touched = np.flatnonzero(np.bincount(parent) >= 2)
    assert 0 in touched
    assert len(touched) < len(mesh.tets) // 4                                 # measured: 6 of 162


def test_marking_everything_keeps_a_valid_mesh():
    """Every cell is bisected at least once, the mesh stays valid (TetMesh checks its embedding) and the faces
    stay conforming over three rounds; the smallest dihedral angle stays above half the initial one."""
    mesh = jittered_box()
    start = min_dihedral(mesh.points, mesh.tets)                              # measured 35.1 degrees
    for _ in range(3):
        fine, parent = refine_marked(mesh, np.ones(len(mesh.tets), bool))
        assert np.bincount(parent, minlength=len(mesh.tets)).min() >= 2
        assert set(face_counts(fine.tets)[1].tolist()) == {1, 2}
        mesh = fine
    assert fine.volumes.sum() == pytest.approx(1.0, rel=1e-12)
    assert min_dihedral(fine.points, fine.tets) > 0.5 * start                  # measured 30.5 degrees (0.87)


@pytest.mark.parametrize("mesh", [jittered_box(), cc.cylinder(1.0, 1.0, 3, 3)], ids=["jittered box", "cylinder"])
def test_corner_refinement_keeps_the_shape(mesh):
    """Six rounds of refining the cells at one corner node, then two of random marking: the cells at the corner
    shrink, no cell degenerates (volume over longest edge cubed bounded away from 0) and the smallest dihedral
    angle stays above half the initial mesh's (no proof for longest-edge bisection in 3D: this measures it)."""
    corner = int(np.argmin(mesh.points @ [1.0, 1e-3, 1e-6]))
    start = min_dihedral(mesh.points, mesh.tets)                 # measured: box 35.1, cylinder 36.6 degrees

    def corner_size(mesh):
        return np.ptp(mesh.points[mesh.tets[(mesh.tets == corner).any(axis=1)]], axis=1).max()

    first = corner_size(mesh)
    for _ in range(6):
        mesh, _ = refine_marked(mesh, (mesh.tets == corner).any(axis=1))
    assert corner_size(mesh) < 0.6 * first                      # measured: box 0.25, cylinder 0.29
    for _, mesh, _ in random_rounds(mesh, 2, 0.3, seed=2):
        pass
    p = mesh.points[mesh.tets]
    longest = np.linalg.norm(p[:, :, None] - p[:, None], axis=3).max(axis=(1, 2))
    assert (mesh.volumes / longest ** 3).min() > 1e-3                         # measured: box 0.023, cyl 0.011
    assert min_dihedral(mesh.points, mesh.tets) > 0.5 * start                  # measured: box 1.0, cyl 0.69


def test_bad_input():
    mesh = cc.box(nx=1, ny=1, nz=1)
    with pytest.raises(cc.MeshError, match="one entry per tetrahedron"):
        refine_marked(mesh, np.ones(3, bool))
    with pytest.raises(cc.MeshError, match="0..5"):
        refine_marked(mesh, [6])
    with pytest.raises(cc.MeshError, match="flat faces"):
        refine_marked(mesh, [0], {"top": lambda x: x})
