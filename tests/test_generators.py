"""Mesh generators: named sub-segments of rectangle sides, graded_block, half_disk."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.errors import MeshError


def test_rectangle_segments_tag_the_edges_between_the_given_coordinates():
    m = cc.rectangle(x=(0.0, 2.0), y=(0.0, 1.0), nx=8, ny=4,
                     segments={"footprint": ("top", 0.5, 1.5), "upper_left": ("left", 0.5, 1.0)})
    e = m.boundary("footprint")
    x = m.points[e, 0]
    assert len(e) == 4 and x.min() == 0.5 and x.max() == 1.5 and np.all(m.points[e, 1] == 1.0)
    u = m.boundary("upper_left")
    assert len(u) == 2 and np.all(m.points[u, 0] == 0.0) and m.points[u, 1].min() == 0.5
    assert len(m.boundary("top")) == 8                                        # the side keeps its tag
    with pytest.raises(MeshError, match=r"0.6 m is not a grid node of side 'top' \(nearest \[0.5, 0.75\]\)"):
        cc.rectangle(x=(0.0, 2.0), nx=8, segments={"f": ("top", 0.6, 1.5)})
    with pytest.raises(MeshError, match="must be a new tag"):
        cc.rectangle(segments={"top": ("top", 0.0, 0.5)})
    with pytest.raises(MeshError, match=r"expected \(side, start, end\)"):
        cc.rectangle(segments={"f": ("roof", 0.0, 0.5)})


def test_graded_block_without_grading_is_the_rectangle_and_keeps_its_area():
    a = cc.graded_block((0.0, 1.0), (0.0, 0.5), 6, 3)
    b = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=6, ny=3)
    assert np.abs(a.points - b.points).max() < 1e-15
    g = cc.graded_block((-1.0, 1.0), (0.0, 0.5), 8, 4, "bottom", beta=3.0, gamma=2.0)
    assert g.areas.sum() == pytest.approx(1.0, rel=1e-12)
    h = np.diff(np.unique(g.points[:, 0]))
    assert h[len(h) // 2] < h[0] / 3                                          # finer at the centre
    with pytest.raises(MeshError, match="center must lie inside"):
        cc.graded_block((0.0, 1.0), (0.0, 0.5), 4, 2, beta=1.0, center=2.0)


def test_studies_still_import_graded_block():
    from cvxcontact.apps.studies.common import graded_block
    assert graded_block is cc.graded_block


@pytest.mark.parametrize("side,normal", [("bottom", (0, 1)), ("top", (0, -1)), ("left", (1, 0)), ("right", (-1, 0))])
def test_half_disk_is_the_inscribed_half_polygon(side, normal):
    R, nt = 0.3, 10
    m = cc.half_disk(R, center=(1.0, 2.0), nr=3, nt=nt, side=side)
    assert m.areas.sum() == pytest.approx(0.5 * R ** 2 * nt * np.sin(np.pi / nt), rel=1e-12)
    assert np.abs(m.outward_normals("flat") - normal).max() < 1e-12
    arc = np.unique(m.boundary("arc"))
    assert np.abs(np.hypot(*(m.points[arc] - (1.0, 2.0)).T) - R).max() < 1e-12
    with pytest.raises(MeshError, match="radius must be a positive"):
        cc.half_disk(0.0)
