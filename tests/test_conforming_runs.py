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


def _p2_reproduced(cells, points, nodes):
    """Nodal forces of point forces (segment, t, y) on the P2 segments ``cells`` (t from cells[s, 0])."""
    f = np.zeros(nodes)
    for s, t, y in points:
        np.add.at(f, cells[s], y * lagrange(t))
    return f


@pytest.mark.parametrize("closed", [False, True])
def test_conforming_runs_are_reproduced_by_nonnegative_point_forces(closed):
    """An accepted run's point forces are >= 0 and reproduce its nodal forces (a certificate that the Bernstein
    duals lie in the cone, independent of the cone algebra). A loop's start vertex was counted twice (its whole
    force given to the first segment and again to the last): {0: 1.295, 1: -0.755, 2: 5.067, 3: 0.862} on two
    segments was accepted although no split of the vertex forces is admissible (Clarabel: infeasible)."""
    rng = np.random.default_rng(3)
    accepted = 0
    for trial in range(400):
        n = int(rng.integers(2, 5))
        nv = n if closed else n + 1
        cells = np.array([[s, nv + s, (s + 1) % nv] for s in range(n)])
        f = rng.normal(0.0, 1.0, nv + n)
        f[nv:] = 3 * np.abs(f[nv:])
        if trial == 0 and closed:
            cells, f = np.array([[0, 2, 1], [1, 3, 0]]), np.array([1.295, -0.755, 5.067, 0.862])
        points, covered = _conforming(cells, dict(enumerate(f.tolist())), 1e-12)
        if not covered:
            continue
        accepted += 1
        assert all(y >= 0 for _, _, y in points)
        assert np.allclose(_p2_reproduced(cells, points, len(f)), f, rtol=0, atol=1e-9 * np.abs(f).max())
    assert accepted > 20                  # the check ran on accepted runs (measured: 67 paths, 90 loops of 400)


def test_conforming_runs_through_a_vertex_of_three_segments_are_not_read():
    """Three full-contact segments at one vertex (0): a walk took its force once inside a run and again as the
    start of the next run. The far vertices carry -0.2, each midpoint 2: each segment's cone asks for
    beta0 >= 1 / (16 (-0.2 + 1/2)) = 5/6, i.e. a share >= 1/3 of vertex 0's force, so 0.7 at vertex 0 (< 1) has
    no admissible split, yet the runs were accepted (0.7 >= 2/3 for the run of two segments, and 0.7 again for
    the third). Such runs are not read as measures (the vertex rows keep the sign test); the chain of two
    segments alone (needs 2/3) is still read, and reproduced by point forces >= 0."""
    cells = np.array([[0, 4, 1], [0, 5, 2], [0, 6, 3]])
    f = {0: 0.7, 1: -0.2, 2: -0.2, 3: -0.2, 4: 2.0, 5: 2.0, 6: 2.0}
    points, covered = _conforming(cells, f, 1e-12)
    assert not covered and not points
    chain = {k: v for k, v in f.items() if k not in (3, 6)}
    points, covered = _conforming(cells[:2], chain, 1e-12)
    assert covered == {0, 1, 2, 4, 5}
    nodal = _p2_reproduced(cells[:2], points, 7)
    assert all(y >= 0 for _, _, y in points) and np.allclose(nodal[[0, 1, 2, 4, 5]], [0.7, -0.2, -0.2, 2, 2])
