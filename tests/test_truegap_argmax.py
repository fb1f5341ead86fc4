"""The maximum of the true slack s = q_h - delta over each P2 element against a curved rigid obstacle
(cvxcontact/contact/truegap.py, GapDeparture.argmax; docs/formulation.md §8, §16, §18): every start of the
search converges (Newton on s, stopped by rounding, not by a count of steps), and the maximum agrees with an
independent one: dense sampling of s, then a brute-force local grid zoomed around each sampled local maximum (s
itself only, no derivative). 2D: the circle of the tangency tests on P2 segments; 3D: a sphere on the P2
triangles of a box's top face. The Hertz 3D study's real slack: tests/test_hertz3d.py."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.truegap import simplex_grid

from obstacle_scenes import circle

ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def sphere_departure():
    """The scaled departure of a sphere (R = 0.5 m) over a box's top face pressed 1e-3 m in (P2 triangles)."""
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=4, ny=4, nz=2)
    body = cc.Body(mesh, ALU, clamped="bottom", contact="top")
    ball = cc.Rigid.sphere((0, 0, 0.5 - 1e-3), 0.5)
    return cc.ContactSolver(cc.Scene(body, contacts=[cc.Contact(body, "top", ball)]), "gamma3", degree=2) \
        .problem.departure


def slack(dep, b, el, L):
    """s (k,) at the full barycentric points L (k, c) of the elements el (k,), from its definition."""
    point = L[:, 1] if dep.width == 3 else L
    return (dep.shape.basis(point) * b[el]).sum(axis=1) - dep.at(el, point)


def reference(dep, b, m, n=6, steps=3000):
    """(S,) the maximum of s on each curved element: a dense grid of m intervals, then from every local maximum
    of it a local grid of (2n + 1)^(c-1) points of spacing h clipped to the element, recentred on its best
    point, h divided by 4 where that stays within n/2 of the centre (else followed along a ridge), down to
    1e-14."""
    on = np.flatnonzero(dep.curved)
    seg = dep.width == 3
    I = np.arange(m + 1)[:, None] if seg else np.rint(simplex_grid(m)[:, :2] * m).astype(int)   # grid coordinates
    full = lambda z: np.column_stack([1 - z[:, 0], z[:, 0]]) if seg else np.column_stack([z, 1 - z.sum(axis=1)])
    s = slack(dep, b, np.repeat(on, len(I)), np.tile(full(I / m), (len(on), 1))).reshape(len(on), -1)
    index = {tuple(p): k for k, p in enumerate(I)}
    moves = [(1,), (-1,)] if seg else [(1, 0), (-1, 0), (0, 1), (0, -1), (1, -1), (-1, 1)]
    nb = np.array([[index.get(tuple(p + np.array(d)), -1) for d in moves] for p in I])
    peak = (s[:, :, None] >= np.where(nb >= 0, s[:, np.maximum(nb, 0)], -np.inf)).all(axis=2)
    which, j = np.nonzero(peak)
    z, val, h = I[j] / m, s[which, j], np.full(len(j), 1.0 / m)
    offsets = (np.arange(-n, n + 1)[:, None] if seg else
               np.stack(np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1), indexing="ij"), -1).reshape(-1, 2))
    live = np.arange(len(j))
    for _ in range(steps):
        Z = np.clip(z[live, None, :] + h[live, None, None] * offsets[None], 0.0, 1.0)
        if not seg:
            over = Z.sum(axis=2) > 1
            Z[over] /= Z.sum(axis=2)[over][:, None]
        sv = slack(dep, b, np.repeat(on[which[live]], len(offsets)),
                   np.clip(full(Z.reshape(-1, Z.shape[2])), 0.0, None)).reshape(len(live), -1)
        k = np.argmax(sv, axis=1)
        r = np.arange(len(live))
        far = np.abs(Z[r, k] - z[live]).max(axis=1) > n / 2 * h[live]
        up = sv[r, k] > val[live]
        z[live[up]], val[live[up]] = Z[r, k][up], sv[r, k][up]
        h[live[~(up & far)]] /= 4
        live = live[h[live] > 1e-14]
        if not len(live):
            break
    assert not len(live)
    out = np.full(len(dep.curved), -np.inf)
    np.maximum.at(out, on[which], val)
    return out[on]


def check(dep, b, m, tol):
    """argmax against the reference: every start converged; (the largest difference, the slack's scale)."""
    best, point, (el, L, v, stop) = dep._argmax(b)
    on = np.flatnonzero(dep.curved)
    assert len(el) >= len(on) and np.all(stop == 0), np.bincount(stop)     # Newton converged at every start
    assert np.all(np.isin(on, el))
    # the point returned gives the value returned
    np.testing.assert_array_equal(slack(dep, b, on, dep._full(point[on])), best[on])
    scale = np.abs(b[on]).max(axis=1) + abs(dep.scale) * np.abs(dep.nodal[on]).max(axis=1)
    diff = np.abs(best[on] - reference(dep, b, m)) / scale
    assert diff.max() <= tol, diff.max()
    return diff.max()


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
        check(dep, b, 512, 1e-11)                    # measured 2.5e-14, 5.3e-14, 2.1e-14


@pytest.mark.numerics
def test_argmax_on_triangles_against_dense_sampling():
    dep = sphere_departure()
    for b in perturbations(dep, 2):
        check(dep, b, 60, 2e-13)                     # measured 4.8e-16, 9.0e-16, 1.1e-15
