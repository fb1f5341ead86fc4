"""What the estimate keeps of the facets once per geometry (estimate._Faces.jumps, .owners): the jumps of the fields
across the facets and the cells' sums of the facet terms as sparse operators, built with the body's Geometry and
read-only. The oracles: the rows of the fields taken and subtracted by plain indexing and np.bincount (the same
numbers), and the estimate without a kept Geometry (cache=None) for each of two geometries sharing one cache."""

import numpy as np
import pytest
from conftest import two_blocks

import cvxcontact as cc
from cvxcontact.solution import estimate as est


@pytest.mark.parametrize("degree", [1, 2])
def test_the_kept_jumps_and_incidences_are_the_indexed_differences_and_bincounts(degree):
    body = two_blocks(n1=(6, 3), n2=(5, 3)).bodies[0]
    g = est.Geometry(body, degree)
    f = g.faces
    m, q = len(g.el), g.G.shape[1]
    rng = np.random.default_rng(degree)
    values = rng.standard_normal((m, q, 3))
    stacked = np.concatenate([values.reshape(m * q, 3), np.zeros((1, 3))])     # a boundary facet's zero row
    direct = stacked[f.at0] - stacked[f.at1]
    assert np.array_equal(est._normal_jumps(values, f, f.normal, lambda J, n: J), direct)
    assert (f.at1 == m * q).any() and (f.at1 < m * q).any()                   # boundary and interior facets
    term = rng.random(len(f.c0))
    assert np.array_equal(f.owners[0] @ term + f.owners[1] @ term,
                          np.bincount(f.c0, term, m) + np.bincount(f.c1, term[f.ii], m))
    for J, _ in f.jumps:
        assert not J.data.flags.writeable and not J.indices.flags.writeable
    with pytest.raises(ValueError):
        f.owners[0].data[0] = 2.0


@pytest.mark.numerics
def test_a_cache_shared_by_two_geometries_reads_each_its_own_facets():
    """Two scenes of different meshes through one estimate cache, each estimate the same numbers as without the
    cache (built afresh), in either order; the cache holds a Geometry per body and geometry."""
    cache: dict = {}
    sols = [cc.solve(two_blocks(n1=n1), estimate=False) for n1 in ((16, 8), (12, 6))]
    for sol in sols + sols[::-1]:
        kept, _ = est.estimate(sol, cache=cache)
        fresh, _ = est.estimate(sol)
        assert kept.absolute == fresh.absolute and kept.parts == fresh.parts
        assert all(np.array_equal(a, b) for a, b in zip(kept.indicators, fresh.indicators))
    assert len(cache) == 3                                  # the lower block's mesh is the same in both scenes
    assert len({id(g.faces) for g in cache.values()}) == 3
