"""The fast adaptive loop (issue 30): h-prediction marking (cvxcontact.adapt.mark_bisections), several bisections of
a cell in one step (cvxcontact.geometry.refine.refine_times) and intermediate steps left at the interior point's
answer (cc.adapt(..., exact_steps=False)), the returned answer still exact and checked."""

import itertools
import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.adapt import mark_bisections, mark_bulk
from cvxcontact.apps.studies.adapt import coarse_scene
from cvxcontact.geometry.refine import label_longest, refine_marked, refine_times


def edge_counts(triangles):
    """{sorted node pair: number of triangles holding it}."""
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(e, axis=0, return_counts=True)
    return {tuple(k): c for k, c in zip(keys.tolist(), counts)}


def test_mark_bisections_is_the_fewest_that_reach_the_unmarked_level():
    """On random indicators (many draws): the cells marked are Dorfler's set (mark_bulk); each marked cell's k is the
    fewest bisections whose predicted indicator eta_T 2^(-k rate / dim) is at or below the largest unmarked one
    (k - 1 is not enough), unless clipped to 1 or ``most``; unmarked cells 0."""
    rng = np.random.default_rng(3)
    for trial in range(200):
        eta = [rng.lognormal(0, 2.5, rng.integers(2, 30)) for _ in range(rng.integers(1, 4))]
        theta, rate, dim, most = rng.uniform(0.1, 0.95), rng.uniform(0.5, 3), int(rng.integers(2, 4)), 6
        k = mark_bisections(eta, theta, rate, dim, most)
        bulk = mark_bulk(eta, theta)
        free = max(e[~m].max() for e, m in zip(eta, bulk) if (~m).any())
        for e, m, ki in zip(eta, bulk, k):
            np.testing.assert_array_equal(ki > 0, m)
            for x, n in zip(e[m], ki[m]):
                after, before = x * 2.0 ** (-n * rate / dim), x * 2.0 ** (-(n - 1) * rate / dim)
                assert 1 <= n <= most
                assert after <= free * (1 + 1e-9) or n == most
                assert n == 1 or before > free * (1 - 1e-9)


def test_mark_bisections_all_marked_and_refusals():
    """Everything marked (theta = 1): no unmarked level to reach, one bisection each; bad rate or most refused."""
    k = mark_bisections([np.array([1.0, 2.0, 4.0])], 1.0, rate=2.0)
    np.testing.assert_array_equal(k[0], [1, 1, 1])
    for bad in (0.0, -1.0, True, "2"):
        with pytest.raises(cc.SceneError, match="rate"):
            mark_bisections([np.ones(3)], 0.5, rate=bad)
    with pytest.raises(cc.SceneError, match="most"):
        mark_bisections([np.ones(3)], 0.5, rate=1.0, most=0)


def test_refine_times_bisects_each_cell_as_asked_and_stays_conforming():
    """Random bisection counts 0..4 on a labelled rectangle: the fine mesh is conforming (every edge in one or two
    triangles, those in one exactly the tagged boundary, same length per tag), the coarse vertices keep their
    indices, the parent map is nested (each fine triangle's centroid inside its parent, the children's areas
    summing to the parent's), and every child of a cell asked k times has at most 2^-k of its area (children of
    cells asked 0 times split only as conformity asks)."""
    mesh = label_longest(cc.rectangle(nx=5, ny=4, diagonal="alternate"))
    rng = np.random.default_rng(5)
    times = rng.integers(0, 5, len(mesh.triangles)) * (rng.random(len(mesh.triangles)) < 0.3)
    fine, parent = refine_times(mesh, times)
    counts = edge_counts(fine.triangles)
    tagged = {tuple(sorted(e)) for t in fine.tags for e in fine.boundary(t).tolist()}
    assert {k for k, c in counts.items() if c == 1} == tagged and set(counts.values()) <= {1, 2}
    for t in mesh.tags:
        length = [np.linalg.norm(np.diff(m.points[m.boundary(t)], axis=1), axis=2).sum() for m in (mesh, fine)]
        assert length[1] == pytest.approx(length[0], rel=1e-12)
    np.testing.assert_array_equal(fine.points[:len(mesh.points)], mesh.points)
    np.testing.assert_allclose(np.bincount(parent, weights=fine.areas, minlength=len(mesh.triangles)), mesh.areas,
                               rtol=1e-12)                               # rounding, as refine_marked's test
    centroid = fine.points[fine.triangles].mean(axis=1)
    corners = mesh.points[mesh.triangles[parent]]                        # barycentric coordinates >= 0
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    det = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    lam1 = ((centroid - a)[:, 0] * (c - a)[:, 1] - (centroid - a)[:, 1] * (c - a)[:, 0]) / det
    lam2 = ((b - a)[:, 0] * (centroid - a)[:, 1] - (b - a)[:, 1] * (centroid - a)[:, 0]) / det
    assert min(lam1.min(), lam2.min(), (1 - lam1 - lam2).min()) > 0
    assert (fine.areas <= mesh.areas[parent] * 2.0 ** -times[parent] * (1 + 1e-12)).all()
    assert times.max() == 4 and (fine.areas < mesh.areas[parent]).sum() > 0
    # the same counts by hand: bisect the cells still short of their count, one refine_marked round at a time
    hand, up = mesh, np.arange(len(mesh.triangles))
    for _ in range(times.max()):
        short = times[up] - np.rint(np.log2(mesh.areas[up] / hand.areas)).astype(int) > 0
        if not short.any():
            break
        hand, step = refine_marked(hand, short)
        up = up[step]
    assert len(hand.triangles) == len(fine.triangles)
    np.testing.assert_allclose(np.sort(hand.areas), np.sort(fine.areas), rtol=1e-12)


def test_refine_times_tetrahedra_and_refusals():
    """Tetrahedra: volumes sum per parent and each child of a cell asked k times has at most 2^-k its volume; a
    count array of the wrong shape, type or sign is refused with a MeshError naming times."""
    mesh = cc.box(nx=2, ny=2, nz=2)
    times = np.zeros(len(mesh.tets), dtype=int)
    times[[0, 7]] = [3, 2]
    fine, parent = refine_times(mesh, times)
    np.testing.assert_allclose(np.bincount(parent, weights=fine.volumes, minlength=len(mesh.tets)), mesh.volumes,
                               rtol=1e-12)
    assert (fine.volumes <= mesh.volumes[parent] * 2.0 ** -times[parent] * (1 + 1e-12)).all()
    for bad in (np.zeros(3, dtype=int), -np.ones(len(mesh.tets), dtype=int), np.ones(len(mesh.tets))):
        with pytest.raises(cc.MeshError, match="times"):
            refine_times(mesh, bad)


@pytest.mark.numerics   # interior points and exact finishes of P2 "gamma3" on every kernel set
def test_fast_loop_answer_is_exact_and_checked():
    """The study's P2 loop (theta 0.9, rate 1, intermediate steps at the interior point's answer) on Hertz's
    cylinder: the meshes conform, the estimate falls at every step, the intermediate answers are not polished,
    the returned one is (polished, ok) and equals the exact solve of the same scene by the other route, the full
    model (relative difference of u measured 3.4e-9, asserted < 1e-6: both exact finishes, the cuts stop at
    rounding); a stop by tol (read on an interior point's estimate) hands back the exact answer too; the
    intermediate answers' ResidualWarnings are not raised."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("error", cc.ResidualWarning)     # the intermediate answers' failed checks: dropped
        result = cc.adapt(coarse_scene(), theta=0.9, rate=1.0, exact_steps=False, max_steps=2, keep=True,
                          degree=2, method="condensed")
        fresh = cc.ContactSolver(result.scene, degree=2, method="full").solve()
        by_tol = cc.adapt(coarse_scene(), theta=0.9, rate=1.0, exact_steps=False, tol=0.4, degree=2,
                          method="condensed")
    h = result.history
    assert result.stopped == "max_steps" and len(h) == 3
    assert all(b.estimate < a.estimate for a, b in itertools.pairwise(h))
    assert all(b.cells > 2 * a.cells for a, b in itertools.pairwise(h))          # several bisections per marked cell
    assert [s.polished for s in result.solutions] == [False, False, True]
    sol = result.solution
    assert sol.polished and sol.ok and h[-1].ok
    for body in result.scene.bodies:
        counts = edge_counts(body.mesh.triangles)
        assert set(counts.values()) <= {1, 2}
    assert fresh.polished and fresh.ok
    diff = max(np.abs(a - b).max() for a, b in zip(sol.u, fresh.u)) / max(np.abs(a).max() for a in fresh.u)
    assert diff < 1e-6
    assert by_tol.stopped == "tol" and by_tol.solution.polished and by_tol.solution.ok


def test_fast_loop_refusals():
    scene = coarse_scene()
    with pytest.raises(cc.SceneError, match="exact_steps"):
        cc.adapt(scene, exact_steps=1)
    with pytest.raises(cc.SceneError, match="rate"):
        cc.adapt(scene, rate=-1.0)
    with pytest.raises(cc.SceneError, match="most"):
        cc.adapt(scene, rate=1.0, most=0)
