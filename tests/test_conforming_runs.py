"""The nodal forces of P2 segments in contact along their whole length, read as measures on the segments
(:func:`cvxcontact.backends.tangency._conforming`): checked against forces built from known point forces (the
quadratic Lagrange basis at t, independent of the Bernstein form), one segment and a run of two sharing a vertex,
and against forces no measure gives (a negative midpoint value, a vertex pull larger than the cone allows)."""

import numpy as np
import pytest

from cvxcontact.backends.tangency import _conforming

CELLS = np.array([[0, 1, 2], [2, 3, 4], [5, 6, 7]])    # (start, mid, end) rows; segment 2 apart from the run


def lagrange(t):
    """The nodal values (start, mid, end) of a unit point force at t on a P2 segment."""
    return np.array([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)])


def nodal(points):
    """Node -> force of point forces [(segment, t, y)] on :data:`CELLS`."""
    out: dict[int, float] = {}
    for s, t, y in points:
        for node, v in zip(CELLS[s], y * lagrange(t)):
            out[int(node)] = out.get(int(node), 0.0) + float(v)
    return out


@pytest.mark.parametrize("points", [
    [(0, 0.75, 1.0)],                                  # a negative start value (-0.125)
    [(0, 0.2, 2.0), (0, 0.9, 0.5)],
    [(0, 0.8, 1.0), (1, 0.1, 3.0)],                    # the shared vertex 2 split between the two segments
    [(0, 0.3, 1.0), (1, 0.8, 1.0)],                    # a negative force (-0.24) at the shared vertex
])
def test_forces_of_a_measure_are_read_back_as_point_forces(points):
    f = nodal(points)
    spread, covered = _conforming(CELLS[:2] if max(s for s, _, _ in points) else CELLS[:1], f, 1e-14)
    assert covered == set(f)
    assert all(y >= 0 and 0 <= t <= 1 for _, t, y in spread)
    back = nodal(spread)
    assert max(abs(back.get(k, 0.0) - v) for k, v in f.items()) <= 1e-13


@pytest.mark.parametrize("f", [
    {0: 0.2, 1: -0.1, 2: 0.2},                         # the midpoint pulls: beta1 < 0
    {0: -0.5, 1: 1.0, 2: 0.5},                         # the start pulls more than the cone allows (beta0 < 0)
    {0: -0.2, 1: 1.0, 2: -0.2},                        # beta1^2 > 4 beta0 beta2 (0.25 > 0.01)
])
def test_forces_outside_the_cone_are_not_covered(f):
    spread, covered = _conforming(CELLS[:1], f, 1e-14)
    assert spread == [] and covered == set()


def test_a_segment_without_rows_at_all_three_nodes_is_no_run():
    spread, covered = _conforming(CELLS, {0: 1.0, 2: 1.0, 5: 1.0, 6: 1.0}, 1e-14)
    assert spread == [] and covered == set()
