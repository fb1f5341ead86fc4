"""The Signorini pressure read back (lambda_h) against obstacles that reach a P1 contact part only in part
(contact/interface.Interface.multiplier, contact/surface.SurfaceInterface.multiplier): each row's force over its
weight, the reaching node's hat integrated over the whole part (the law's weights, tests/test_partial_reach.py).

The scenes of tests/test_partial_reach.py without the compliance law: a steel block pushed down by DELTA onto two
flat obstacles, one under x < 0.4 and one under x >= 0.4 (2D: 3 x 1 cells; 3D: 3 x 3 x 1 cells of six
tetrahedra), together one rigid plane: uniaxial strain, the closed form p = c DELTA / H (c = lambda + 2 mu) at
every node. Before, lambda_h solved M lambda = r with the mass of the run of reaching nodes, which weighs the
segment (faces) between the runs nothing (short): in 2D it read 0 and 3 p on each run (16.15e6 Pa against
5.38e6), in 3D 0.795 ... 1.416 p. With one obstacle (x < 0.4) the forces are >= 0 and M lambda = r read a
negative pressure: 2D -0.98 p (-5.27e6 Pa) at x = 0, 3D -0.025 p.
"""

import functools

import numpy as np
import pytest
from hex_scenes import DELTA, SIDES, STEEL, H
from reach_scenes import line, strip, triangles_at

import cvxcontact as cc

pytestmark = pytest.mark.numerics

EDGE = 0.4                                  # where one obstacle ends and the other begins (m)
MATERIAL = cc.materials.isotropic(E=200e9, nu=0.3)
C = 200e9 * 0.7 / (1.3 * 0.4)          # lambda + 2 mu (Pa) of both materials (E = 200 GPa, nu = 0.3)
BOTH, ONE = ((-1.0, EDGE), (EDGE, 2.0)), ((-1.0, EDGE),)


def _scene(dim, strips):
    if dim == 2:
        body = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, H), nx=3, ny=1), MATERIAL, roller=["left", "right"],
                       displacement={"top": (None, -DELTA)}, contact="bottom")
        obstacle = line
    else:
        body = cc.Body(cc.box(nx=3, ny=3, nz=1, z=(0.0, H)), STEEL, roller=SIDES,
                       displacement={"top": (None, None, -DELTA)}, contact="bottom")
        obstacle = strip
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", obstacle(*s)) for s in strips])


def _hats(dim, points):
    """Each node's hat integrated over the whole part (m or m^2), by hand: 2D h/2 at an end, h inside (h = 1/3);
    3D (number of the faces' triangles at it) A / 3, A = 1/18."""
    x = np.asarray(points, dtype=float)
    if dim == 2:
        return np.where((np.abs(x[:, 0]) < 1e-12) | (np.abs(x[:, 0] - 1.0) < 1e-12), 1 / 6, 1 / 3)
    return np.array([triangles_at(a, b) / 54 for a, b in x[:, :2]])


@functools.cache
def _solved(dim, strips):
    sol = cc.solve(_scene(dim, strips), "sigma1", degree=1)
    assert sol.ok
    return sol


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strips", [BOTH, ONE], ids=["both", "one"])
def test_the_read_back_keeps_each_rows_force_by_its_whole_hat(dim, strips):
    """lambda_a w_a = r_a at every row (w_a by hand), so the total force is kept; lambda >= 0 where the forces are
    (one obstacle: before, 2D -5.27e6 Pa at x = 0 and 3D -0.025 p from forces >= 0)."""
    sol = _solved(dim, strips)
    for c in sol.contacts:
        force, lam = np.asarray(c.force), np.asarray(c.lam)
        assert (force >= 0).all()
        assert (lam >= 0).all()                         # measured min 0.74 p (one obstacle); -0.98 p before
        assert np.abs(lam * _hats(dim, c.points) - force).max() <= 1e-12 * np.abs(force).max()   # measured 1.5e-16
        assert abs((lam * _hats(dim, c.points)).sum() - force.sum()) <= 1e-12 * force.sum()     # measured 1.7e-16


@pytest.mark.parametrize("dim", [2, 3])
def test_a_uniform_push_reads_the_closed_form_at_every_row(dim):
    """Two obstacles together one rigid plane: lambda = c DELTA / H at every row of both (before 2D 0 and 3 p,
    3D 0.795 ... 1.416 p); the forces themselves p times the whole hats (they were right before)."""
    sol = _solved(dim, BOTH)
    p = C * DELTA / H
    for c in sol.contacts:
        assert np.abs(np.asarray(c.force) - p * _hats(dim, c.points)).max() <= 1e-9 * p / 54   # measured 4.3e-17 p
        assert np.abs(np.asarray(c.lam) - p).max() <= 1e-9 * p                               # measured 3.5e-16 p
