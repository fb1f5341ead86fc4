"""Local refinement by newest-vertex bisection (cvxcontact.geometry.refine.refine_marked): conformity, areas,
shape regularity over many rounds, boundary and cell tags, curved parts, bad input."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.geometry.refine import circle, label_longest, refine_marked


def angles(mesh):
    """(m, 3) interior angles (degrees) of every triangle."""
    p = mesh.points[mesh.triangles]
    out = []
    for i in range(3):
        u, w = p[:, (i + 1) % 3] - p[:, i], p[:, (i + 2) % 3] - p[:, i]
        c = (u * w).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        out.append(np.degrees(np.arccos(np.clip(c, -1, 1))))
    return np.stack(out, axis=1)


def edge_counts(mesh):
    """{sorted node pair: number of triangles holding it}."""
    t = mesh.triangles
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(e, axis=0, return_counts=True)
    return {tuple(k): c for k, c in zip(keys.tolist(), counts)}


def random_rounds(mesh, rounds, fraction, seed, curves=None):
    """``rounds`` refinements of randomly marked cells; yields (coarse, fine, parent) of each."""
    rng = np.random.default_rng(seed)
    for _ in range(rounds):
        fine, parent = refine_marked(mesh, rng.random(len(mesh.triangles)) < fraction, curves)
        yield mesh, fine, parent
        mesh = fine


MESHES = {"rectangle": lambda: cc.rectangle(nx=4, ny=3, diagonal="alternate"),
          "half disk": lambda: cc.half_disk(1.0, nr=3, nt=6)}


@pytest.mark.parametrize("name", MESHES)
def test_conforming_areas_and_tags_over_ten_rounds(name):
    """Every round: each edge in one triangle (the boundary) lies in exactly the tagged boundary edges, every
    other in exactly two (no hanging node); each coarse triangle's area is its children's sum (straight
    midpoints: exact to rounding); each tag's edges cover the same length."""
    mesh = label_longest(MESHES[name]())
    total = mesh.areas.sum()
    for coarse, fine, parent in random_rounds(mesh, 10, 0.15, seed=1):
        assert len(fine.triangles) > len(coarse.triangles)
        counts = edge_counts(fine)
        tagged = {tuple(sorted(e)) for t in fine.tags for e in fine.boundary(t).tolist()}
        assert {k for k, c in counts.items() if c == 1} == tagged
        assert set(counts.values()) <= {1, 2}
        children = np.bincount(parent, weights=fine.areas, minlength=len(coarse.triangles))
        np.testing.assert_allclose(children, coarse.areas, rtol=1e-12)       # rounding: measured <= 4e-16
        for t in coarse.tags:
            length = [np.linalg.norm(np.diff(m.points[m.boundary(t)], axis=1), axis=2).sum() for m in (coarse, fine)]
            assert length[1] == pytest.approx(length[0], rel=1e-12)
    assert fine.areas.sum() == pytest.approx(total, rel=1e-12)


def test_right_isosceles_stay_right_isosceles():
    """From right isosceles triangles labelled at the hypotenuse, every bisection gives right isosceles
    triangles: all angles are 45 or 90 degrees after 10 rounds of random marking (a wrong refinement edge
    would give 26.6 / 63.4 degree triangles)."""
    mesh = label_longest(cc.rectangle(nx=4, ny=4, diagonal="right"))
    for _, fine, _ in random_rounds(mesh, 10, 0.1, seed=2):
        pass
    a = angles(fine)
    assert len(fine.triangles) > 200
    assert np.all(np.minimum(np.abs(a - 45), np.abs(a - 90)) < 1e-6)


def test_smallest_angle_bounded_over_ten_rounds():
    """Newest-vertex bisection gives finitely many similarity classes per initial triangle: after 10 rounds of
    random marking the smallest angle is no smaller than the smallest of four generations of refining every
    cell (the classes appear within them)."""
    mesh = label_longest(cc.half_disk(1.0, nr=3, nt=6))
    every, smallest = mesh, angles(mesh).min()
    for _ in range(4):
        every, _ = refine_marked(every, np.ones(len(every.triangles), bool))
        smallest = min(smallest, angles(every).min())
    for _, fine, _ in random_rounds(mesh, 10, 0.2, seed=3):
        pass
    assert len(fine.triangles) > 10 * len(mesh.triangles)
    assert angles(fine).min() >= smallest - 1e-9      # measured: equal to 1e-13 (23.79 degrees)


def test_cell_tags_follow_parents():
    """A per-cell region tag carried by ``parent`` agrees with the region each fine cell's centroid lies in
    (the coarse cells do not straddle x = 0.5)."""
    mesh = label_longest(cc.rectangle(nx=4, ny=2))
    region = (mesh.points[mesh.triangles].mean(axis=1)[:, 0] > 0.5).astype(int)
    for _, fine, parent in random_rounds(mesh, 6, 0.3, seed=4):
        region = region[parent]
        assert np.array_equal(region, (fine.points[fine.triangles].mean(axis=1)[:, 0] > 0.5).astype(int))


def test_curved_part_nodes_on_the_curve():
    """With the arc's circle given, every node of the refined arc lies on it; without, the new nodes are
    chord midpoints (inside the circle)."""
    mesh = label_longest(cc.half_disk(0.3, center=(1.0, 2.0), nr=2, nt=4))
    with_curve = without = mesh
    for _ in range(3):
        with_curve, _ = refine_marked(with_curve, np.ones(len(with_curve.triangles), bool),
                                      {"arc": circle((1.0, 2.0), 0.3)})
        without, _ = refine_marked(without, np.ones(len(without.triangles), bool))
    r = np.linalg.norm(with_curve.points[with_curve.boundary_nodes(["arc"])] - [1.0, 2.0], axis=1)
    np.testing.assert_allclose(r, 0.3, rtol=1e-14)
    r = np.linalg.norm(without.points[without.boundary_nodes(["arc"])] - [1.0, 2.0], axis=1)
    assert r.min() < 0.3 * (1 - 1e-3)
    assert with_curve.areas.sum() > without.areas.sum()


def test_labels_and_bad_input():
    mesh = cc.rectangle(nx=2, ny=2)
    labelled = label_longest(mesh)
    p = labelled.points[labelled.triangles]
    length = np.linalg.norm(p - np.roll(p, -1, axis=1), axis=2)           # edge i: (v_i, v_i+1)
    assert np.all(length[:, 0] >= length.max(axis=1))
    with pytest.raises(cc.MeshError, match="one entry per triangle"):
        refine_marked(labelled, np.ones(3, bool))
    with pytest.raises(cc.MeshError, match="0..7"):
        refine_marked(labelled, [8])
    with pytest.raises(cc.MeshError, match="boundary tags"):
        refine_marked(labelled, [0], {"arc": circle((0, 0), 1)})
    once, _ = refine_marked(labelled, np.ones(8, bool))        # the diagonals; next, the sides
    with pytest.raises(cc.MeshError, match="finite"):
        refine_marked(once, np.ones(16, bool), {"bottom": lambda x: np.full_like(x, np.nan)})
    fine, parent = refine_marked(labelled, np.zeros(8, bool))
    assert np.array_equal(fine.triangles, labelled.triangles) and np.array_equal(parent, np.arange(8))
