"""The weights of a law on the rows of a 2D P2 pair (QuadraticInterface.weights; docs/formulation.md §10, "P2";
docs/refusals.md row 4): positive, summing to the overlap's length for any overlap, Simpson's where the overlap
ends at vertices of the trace, the red refinement's hats where it cuts a segment (checked against hand values).

The references are built here from the meshes' abscissae (uniform cells of cc.rectangle), not from the package.
"""

import numpy as np
import pytest
from reference_problems import simpson

import cvxcontact as cc
from cvxcontact.contact.interface import shares_to_nearest
from cvxcontact.contact.quadratic import quadratic_interface
from cvxcontact.geometry.quadratic import P2Nodes

MAT = cc.materials.isotropic(E=1e9, nu=0.0)


def _pair(x1, n1, x2, n2):
    """The P2 interface of an upper block on ``x1`` (n1 cells) over a lower one on ``x2`` (n2 cells)."""
    b1 = cc.Body(cc.rectangle(x=x1, y=(0, 0.5), nx=n1, ny=1), MAT, clamped=["top"], contact="bottom")
    b2 = cc.Body(cc.rectangle(x=x2, y=(-0.5, 0), nx=n2, ny=1), MAT, clamped=["bottom"], contact="top")
    scene = cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=-1e-5)])
    return quadratic_interface(scene, [P2Nodes(b.mesh) for b in scene.bodies])



def test_random_overlaps_give_positive_weights_summing_to_the_overlap():
    """200 random pairs (cells, extents): under each condition every row's weight is positive and they sum to the
    overlap's length (measured: 3.3e-16 relative at most); "sigma<l>" has no row and no weight exactly when no
    P2 node of trace l lies in the overlap (the solve warns: tests/test_resolution.py)."""
    rng = np.random.default_rng(4)
    worst, refused = 0.0, 0
    for _ in range(200):
        a1, a2 = rng.uniform(0, 0.6, 2)
        b1, b2 = a1 + rng.uniform(0.2, 1.0), a2 + rng.uniform(0.2, 1.0)
        lo, hi = max(a1, a2), min(b1, b2)
        if hi - lo < 0.05:
            continue
        n1, n2 = rng.integers(1, 8, 2)
        itf = _pair((a1, b1), int(n1), (a2, b2), int(n2))
        nodes = [np.linspace(a1, b1, 2 * n1 + 1), np.linspace(a2, b2, 2 * n2 + 1)]
        for condition in ("sigma1", "sigma2", "gamma3"):
            if condition != "gamma3":
                x = nodes[int(condition[-1]) - 1]
                if not ((x >= lo - 1e-9) & (x <= hi + 1e-9)).any():
                    assert len(itf.weights(condition)) == itf.evaluation(condition).shape[0] == 0
                    refused += 1
                    continue
            w = itf.weights(condition)
            assert len(w) == itf.evaluation(condition).shape[0] and (w > 0).all()
            worst = max(worst, abs(w.sum() / (hi - lo) - 1))
    assert worst <= 1e-13 and refused > 0


@pytest.mark.parametrize("cells", [(4, 3), (4, 4), (6, 9), (5, 2)])
def test_an_overlap_ending_at_vertices_keeps_simpsons_weights(cells):
    """Both blocks on [0, 1] (and the lower one on [0.25, 0.75] under 4 upper cells): the rows under each condition
    form a P2 mesh and the weights are Simpson's on it, to rounding (the package's unchanged before; measured
    bit-identical)."""
    n1, n2 = cells
    itf = _pair((0, 1), n1, (0, 1), n2)
    for condition, n in (("sigma1", n1), ("sigma2", n2)):
        assert np.abs(itf.weights(condition) - simpson(np.linspace(0, 1, n + 1))).max() <= 1e-15
    assert np.abs(itf.weights("gamma3") - simpson(np.asarray(itf.xv))).max() <= 1e-15
    inner = _pair((0, 1), 4, (0.25, 0.75), n2)
    assert np.abs(inner.weights("sigma1") - simpson(np.array([0.25, 0.5, 0.75]))).max() <= 1e-15


def test_a_cut_segment_takes_the_red_hats_over_the_overlap():
    """The upper trace (4 cells of 0.25) over the overlap [0.1, 1] under "sigma1": its segment [0, 0.25] is cut.
    Split at its midpoint, the hats over [0.1, 0.25]: the node 0 (outside) gets 0.025 * 0.1 (its hat's mean 0.1 on
    [0.1, 0.125]) and gives it to 0.125, which gets 0.025 * 0.9 + 0.125 / 2; 0.25 gets 0.125 / 2 from the cut
    segment and Simpson's 0.25 / 6 from the next; Simpson's further on. The overlap [0.2, 1] (first row the vertex
    0.25) adds the cut segment's [0.2, 0.25] to 0.25: 0.05 + 0.25 / 6."""
    w = _pair((0, 1), 4, (0.1, 1), 3).weights("sigma1")
    expected = np.concatenate([[0.025 + 0.0625, 0.0625 + 0.25 / 6], simpson(np.array([0.25, 0.5, 0.75, 1.0]))[1:]])
    assert np.abs(w - expected).max() <= 1e-15
    w = _pair((0, 1), 4, (0.2, 1), 3).weights("sigma1")
    expected = simpson(np.array([0.25, 0.5, 0.75, 1.0]))
    expected[0] += 0.05
    assert np.abs(w - expected).max() <= 1e-15


def test_extend_on_a_cut_segment_is_the_trace_function():
    """``extend`` of the rows' values under "sigma1" on the overlap [0.1, 1]: a constant stays that constant, and the
    nodes of X_h that are rows (the upper trace's vertices 0.25, 0.5, 0.75, 1) take their row's value; the node 0.1
    of X_h reads the upper trace's P2 function on [0, 0.25] whose node 0 (outside) takes the value of 0.125."""
    itf = _pair((0, 1), 4, (0.1, 1), 3)
    rows = np.asarray(itf.sigma_x[0])
    assert np.abs(itf.extend("sigma1", np.full(len(rows), 2.5)) - 2.5).max() <= 1e-15
    values = np.sin(7 * rows)
    out = itf.extend("sigma1", values)
    x = np.asarray(itf.x)
    for r, v in zip(rows[1::2], values[1::2]):
        assert abs(out[np.argmin(np.abs(x - r))] - v) <= 1e-15
    t = 0.1 / 0.25                                                       # 0.1 on [0, 0.25]
    shape = [(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)]
    assert abs(out[0] - (shape[0] * values[0] + shape[1] * values[0] + shape[2] * values[1])) <= 1e-15


def test_shares_to_nearest_keeps_the_sum_and_gives_each_share_to_the_nearest_row():
    """The rule itself on points of the plane: the rows keep their shares, each other node's goes whole to its
    nearest row, the total is kept."""
    points = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.9, 0.1], [0.1, 0.8]])
    shares = np.array([1.0, 2.0, 3.0, 0.5, 0.25])
    w = shares_to_nearest(shares, [0, 1, 2], points)
    assert np.array_equal(w, [1.0, 2.5, 3.25]) and w.sum() == shares.sum()
