"""The maximum of the true slack s = q_h - delta over each P2 element against a curved rigid obstacle
(cvxcontact/contact/truegap.py, GapDeparture.argmax; docs/formulation.md §8, §16, §18): every start of the
search converges (Newton on s, stopped by rounding, not by a count of steps), and the maximum agrees with an
independent one: dense sampling of s, then a brute-force local grid zoomed around each sampled local maximum (s
itself only, no derivative). 2D: the circle of the tangency tests on P2 segments; 3D: a sphere on the P2
triangles of a box's top face. The Hertz 3D study's real slack: tests/test_hertz3d.py."""

import numpy as np
import pytest

import cvxcontact as cc

from obstacle_scenes import circle
from references import check_argmax

ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def sphere_departure():
    """The scaled departure of a sphere (R = 0.5 m) over a box's top face pressed 1e-3 m in (P2 triangles)."""
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=4, ny=4, nz=2)
    body = cc.Body(mesh, ALU, clamped="bottom", contact="top")
    ball = cc.Rigid.sphere((0, 0, 0.5 - 1e-3), 0.5)
    return cc.ContactSolver(cc.Scene(body, contacts=[cc.Contact(body, "top", ball)]), "gamma3", degree=2) \
        .problem.departure


def perturbations(dep, seed):
    """Bernstein coefficients b (S, w): 0 (the body follows the obstacle at the nodes: s = -delta, several
    maxima of nearly equal height per element), and b of random signs at the size of delta (maxima inside, on
    edges and at vertices)."""
    rng = np.random.default_rng(seed)
    S, w = dep.nodal.shape
    t = np.linspace(0, 1, 9)[1:-1]
    L = np.column_stack([t, t[::-1] / 2, 1 - t - t[::-1] / 2])                   # points inside a triangle
    size = np.abs(dep.at(np.repeat(np.arange(S), len(t)), np.tile(t, S) if w == 3 else np.tile(L, (S, 1)))).max()
    return [np.zeros((S, w)), size * rng.uniform(-1, 1, (S, w)), size * rng.uniform(-1, 1, (S, w)) - 0.5 * size]


@pytest.mark.numerics
def test_argmax_on_segments_against_dense_sampling():
    dep = cc.ContactSolver(circle(), "gamma3", degree=2).problem.departure
    # s rounds at eps R of the circle's distance |x - c| - R, ~3e-14 of the slack's scale: the dense maximum
    # lies above Newton's by that (the largest of many rounded samples)
    for b in perturbations(dep, 1):
        check_argmax(dep, b, 512, 1e-11)                    # measured 2.5e-14, 5.3e-14, 2.1e-14


@pytest.mark.numerics
def test_argmax_on_triangles_against_dense_sampling():
    dep = sphere_departure()
    for b in perturbations(dep, 2):
        check_argmax(dep, b, 60, 2e-13)                     # measured 4.8e-16, 9.0e-16, 1.1e-15
