"""2D P2 obstacles on one part, a run's first vertex inside another run (docs/accuracy.md, "Several pairs on one
part"): the 6 x 2 block on a floor x >= 0.3 (its run of vertices from x = 1/3) and an obstacle at the floor up to
x = 0.3, then falling away by 1e-5 per m (its run up to x = 1/2), the scene of
tests/test_sides.py::test_p2_runs_one_closed_one_open.

Each pair's lambda_h is a function of its own X_h, the continuous P2 line of its run (0 beyond it). The segment
[1/6, 1/3] is the obstacle's alone, so whatever the split of the part's lambda_h (the one floor's, uniform p) between
the pairs, the obstacle's function is p on that segment and, being continuous, p at x = 1/3, where the obstacle is
open by 3.3e-7 m: the complementarity of that pair alone charges it (the estimate reads the side's once, 0;
tests/test_side_gap_2d.py). These tests check that with
references that do not go through the read-back: a dense solve of the mixed system (26) with rows built here from
the obstacles' distances, P2 mass matrices built here, and the closed form of the complementarity integral. The
term is a property of the pairs' spaces (the obstacle's own representer of its own forces is not 0 there either),
and it falls as the floor's first vertex x_f nears 0.3 and h falls: at most p 1e-5 h^2 (0.146, 0.0652, 5.7e-4 at
nx = 6, 12, 96 against norm^2 53.8; what the estimate read pair by pair, before it read the side once).
"""

import numpy as np
import pytest
import scipy.sparse as sp
from hex_scenes import DELTA, M_S, H
from reach_scenes import block2d, line, lowered
from references import line_complementarity

import cvxcontact as cc
from cvxcontact.fem import p2
from cvxcontact.geometry.quadratic import P2Nodes

pytestmark = [pytest.mark.numerics, pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]

P_UNIFORM = M_S * DELTA / H
"""The pressure of the block on one floor (Pa): uniaxial strain, c_33 DELTA / H (closed form)."""


def _scenes():
    return (block2d((line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3))),     # pair 0 the floor, 1 the obstacle
            block2d((line(-1.0, 2.0),)))                                     # one floor: the same answer


DISTANCES = ([lambda x: np.where(x >= 0.3, 0.0, np.inf),                                  # the floor x >= 0.3
              lambda x: np.where(x < 0.6, 1e-5 * np.maximum(0.0, x - 0.3), np.inf)],      # the obstacle
             [lambda x: np.zeros_like(x)])                                                # the one floor
"""Per scene of :func:`_scenes`, each obstacle's distance below the bottom (m) at abscissae x, from its
description (tests/reach_scenes.py), for the dense reference."""


@pytest.fixture(scope="module")
def solved():
    two = _scenes()[0]
    sol = cc.solve(two, "sigma1", degree=2)
    assert sol.ok
    return two, sol


def _mass(x):
    """The P2 mass matrix (m) of the line with interleaved nodes ``x`` (vertex, midpoint, vertex, ...), by hand."""
    n = len(x)
    M = np.zeros((n, n))
    local = np.array([[4.0, 2.0, -1.0], [2.0, 16.0, 2.0], [-1.0, 2.0, 4.0]]) / 30.0
    for a in range(0, n - 2, 2):
        M[a:a + 3, a:a + 3] += (x[a + 2] - x[a]) * local
    return M


def _dense(scene, distances):
    """The mixed system (26) of the P2 block against each obstacle of ``scene``, dense, rows built here: each
    obstacle's row at every P2 node of the bottom between its first and last vertex that reach it (finite
    distance), -u_y <= d(x); closed on the rows the exact answer closes, found by trying (every node whose
    distance is 0 closed, the rest open), then certified. Returns per pair (abscissae, forces N) and u."""
    body = scene.bodies[0]
    nodes = P2Nodes(body.mesh)
    s = p2.assemble(body, nodes)
    pts = np.asarray(nodes.points)
    bottom = np.flatnonzero(np.abs(pts[:, 1]) < 1e-12)
    bottom = bottom[np.argsort(pts[bottom, 0])]
    Tu = sp.csr_matrix(s.Tu)
    rows, gaps, pair_of = [], [], []
    for i, distance in enumerate(distances):
        d = distance(pts[bottom, 0])
        vert = bottom < body.mesh.points.shape[0]
        reach = np.flatnonzero(vert & np.isfinite(d))
        at = bottom[reach[0]:reach[-1] + 1] if len(reach) else bottom[:0]
        for node in at:
            rows.append(-Tu[2 * node + 1].toarray().ravel())
            gaps.append(float(distance(pts[node, 0])) + s.u_fixed[2 * node + 1])
            pair_of.append((i, node))
    G, g = np.array(rows), np.array(gaps)
    K = (Tu.T @ s.Kuu @ Tu).toarray()
    b = s.reduced_loads()[0]
    closed = np.array([abs(gv - s.u_fixed[2 * nd + 1]) < 1e-15 for gv, (_, nd) in zip(g, pair_of)])
    Ga = G[closed]
    n, m = K.shape[0], int(closed.sum())
    scale = np.abs(K).max()
    A = np.block([[K / scale, Ga.T], [Ga, np.zeros((m, m))]])
    z = np.linalg.solve(A, np.concatenate([b / scale, g[closed]]))
    y = np.zeros(len(g))
    y[closed] = z[n:] * scale
    u = Tu @ z[:n] + s.u_fixed
    # certified: every row feasible, the forces non-negative, the momentum rows balanced
    assert (G @ z[:n] - g).max() <= 1e-12 * DELTA                       # measured 0 (closed) and -3.3e-7 (open)
    assert y.min() >= 0.0
    assert np.abs(K @ z[:n] + G.T @ y - b).max() <= 1e-9 * np.abs(b).max()
    out = []
    for i in range(len(distances)):
        mine = [k for k, (j, _) in enumerate(pair_of) if j == i]
        out.append((pts[[pair_of[k][1] for k in mine], 0], y[mine]))
    return out, u.reshape(-1, 2)


def test_the_package_answers_the_dense_mixed_system(solved):
    """The package's u and each pair's row forces are the dense solve's of (26), to rounding; the forces summed at
    each node are the one floor's (its own dense solve): the same discrete answer."""
    scene, sol = solved
    pairs, u = _dense(scene, DISTANCES[0])
    (one,), u_one = _dense(_scenes()[1], DISTANCES[1])
    scale = np.abs(u).max()
    # measured <= 8.5e-16 relative (5 kernel sets)
    assert np.abs(sol.u[0] - u).max() <= 1e-12 * scale
    assert np.abs(u_one - u).max() <= 1e-12 * scale                     # measured 0
    top = max(np.abs(f).max() for _, f in pairs)
    for c, (x, f) in zip(sol.contacts, pairs):
        assert np.allclose(np.asarray(c.points)[:, 0], x, rtol=0, atol=1e-12)
        assert np.abs(np.asarray(c.force) - f).max() <= 1e-12 * top     # measured <= 1.2e-15 (5 kernel sets)
    summed = {}
    for x, f in pairs:
        for xi, fi in zip(np.round(x, 9), f):
            summed[xi] = summed.get(xi, 0.0) + fi
    x1, f1 = one
    # measured <= 3.9e-16 (5 kernel sets)
    assert np.abs(np.array([summed[xi] for xi in np.round(x1, 9)]) - f1).max() <= 1e-12 * top


def test_the_obstacles_function_is_forced_at_the_floors_first_vertex(solved):
    """The part's lambda_h (the Riesz representer of the dense forces summed, on the union P2 line, by a mass matrix
    built here) is the one floor's uniform p. Any split into the pairs' functions (each continuous P2 on its run, 0
    beyond it) gives the obstacle the whole of it on [0, 1/3], the segments no other run holds, hence p at x = 1/3
    where it is open; the package's split does that and leaves the obstacle 0 at its open nodes beyond. The
    obstacle's own representer of its own dense forces (0 at its open nodes) is not 0 at x = 1/3 either (-0.35 p):
    no reading of the pair's space gives it 0 there."""
    scene, sol = solved
    pairs, _ = _dense(scene, DISTANCES[0])
    (xf, ff), (xo, fo) = pairs
    both = np.concatenate([xf, xo])
    keys, first, at_key = np.unique(np.round(both, 9), return_index=True, return_inverse=True)
    x = both[first]                                                     # the union's P2 nodes (the run 0 .. 1)
    f = np.bincount(at_key, weights=np.concatenate([ff, fo]), minlength=len(keys))
    lam_union = np.linalg.solve(_mass(x), f)
    # measured max |lambda_U / p - 1| <= 2.7e-15 (5 kernel sets)
    assert np.abs(lam_union / P_UNIFORM - 1).max() <= 1e-12
    obstacle = sol.contacts[1]
    xo_pkg = np.asarray(obstacle.points)[:, 0]
    alone = xo_pkg <= 1 / 3 + 1e-12                                     # [0, 1/3]: the obstacle's run alone
    # measured <= 1.3e-15 relative (5 kernel sets)
    assert np.abs(obstacle.lam[alone] / P_UNIFORM - 1).max() <= 1e-12
    opened = np.asarray(obstacle.gap) - np.asarray(obstacle.jump) > 1e-3 * DELTA
    assert list(xo_pkg[opened].round(4)) == [0.3333, 0.4167, 0.5]
    assert np.abs(obstacle.lam[opened & ~alone]).max() <= 1e-12 * P_UNIFORM          # measured 0
    own = np.linalg.solve(_mass(xo), fo) / P_UNIFORM
    at = np.argmin(np.abs(xo - 1 / 3))
    assert fo[at] == 0.0                                                 # the dense force there: open
    # measured at 1/3, 5/12, 1/2: -3/14 p, 1/28 p, -1/14 p to 1.4e-16 (5 kernel sets); its forces are
    # p h / 6 (1, 4, 2, 4, 0, 0, 0), h = 1/6: the consistent loads of p, x = 1/3's left to the floor
    assert np.abs(own[at:] - [-3 / 14, 1 / 28, -1 / 14]).max() <= 1e-12


def _gap(x):
    """The obstacle's gap below the flat bottom (m) at abscissae x: 1e-5 (x - 0.3) beyond the kink."""
    return 1e-5 * np.maximum(0.0, np.asarray(x, dtype=float) - 0.3)


def _complementarity_closed_form(nx):
    """int lambda^+ (g - [u])^+ on the obstacle's segments either side of the floor's first vertex x_f (the first
    of k / nx >= 0.3), length h = 1 / nx, by the estimate's 3-point Gauss rule: lambda = p on the left one, p (1 -
    t)(1 - 2 t) on the right one (the P2 vertex function of x_f, t in [0, 1] along it), g - [u] the P2 interpolants
    of the obstacle's gaps at their nodes (the bottom flat at 0); everywhere else the obstacle closed or its
    lambda_h 0."""
    h = 1.0 / nx
    xf = np.ceil(0.3 * nx - 1e-9) / nx
    t = 0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    w = np.array([5.0, 8.0, 5.0]) / 18.0
    shape = np.column_stack([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)])       # P2 on [0, 1]
    left = shape @ _gap([xf - h, xf - h / 2, xf])
    right = shape @ _gap([xf, xf + h / 2, xf + h])
    return h * P_UNIFORM * float(w @ (np.maximum(left, 0.0) + np.maximum(shape[:, 0], 0.0) * np.maximum(right, 0.0)))


@pytest.mark.parametrize("nx", [6, 12, 96])
def test_the_complementarity_is_the_forced_split_on_the_open_gap(nx):
    """The obstacle's own complementarity (its lambda_h on its gap, pair by pair, by hand) is that integral in
    closed form: the forced p at x_f on the obstacle's open gap, on the two segments next to it. The estimate reads
    the side's once (lambda_h summed, the least gap), 0 as the one floor's; pair by pair it read the closed form.
    It falls with h and x_f - 0.3 <= h: at most p 1e-5 h^2 (nx = 6, 12: x_f = 1/3; nx = 96: x_f = 0.302). nx = 24 and 48 are left out: a midpoint of the
    obstacle's run lies in (0.3, x_f), where the floor's run does not reach, so the discrete answer is not the one
    floor's (it is not held there)."""
    sol = cc.solve(block2d((line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3)), nx=nx), "sigma1", degree=2)
    one = cc.solve(block2d((line(-1.0, 2.0),), nx=nx), "sigma1", degree=2)
    assert sol.ok and one.ok
    scale = float(np.abs(one.u[0]).max())
    # the one floor's answer: measured <= 8.1e-31, 8.1e-31, 1.1e-14 relative (nx = 6, 12, 96; 5 kernel sets)
    assert np.abs(sol.u[0] - one.u[0]).max() <= 1e-11 * scale
    obstacle = sol.contacts[1]
    x = np.asarray(obstacle.points)[:, 0]
    xf = np.ceil(0.3 * nx - 1e-9) / nx
    want = (x < xf + 1e-9).astype(float)                                 # p up to x_f, 0 beyond
    # measured <= 1.3e-15, 3.7e-15, 1.7e-13 relative (nx = 6, 12, 96; 5 kernel sets)
    assert np.abs(obstacle.lam / P_UNIFORM - want).max() <= 1e-10
    closed_form = _complementarity_closed_form(nx)
    assert 0 < closed_form <= P_UNIFORM * 1e-5 / nx ** 2
    own = line_complementarity(x, obstacle.lam, np.asarray(obstacle.gap) - np.asarray(obstacle.jump), 2)
    # measured 0.14641, 0.065157, 5.7190e-4 against norm^2 53.85 (2.72e-3, 1.21e-3, 1.06e-5), off the closed form
    # by <= 1.1e-15, 1.9e-15, 6.1e-14 of it (nx = 6, 12, 96; 5 kernel sets)
    assert abs(own - closed_form) <= 1e-11 * closed_form
    # the estimate reads it once on the side (tests/test_side_gap_2d.py), as the one floor: measured <= 4.6e-29 of
    # the closed form (5 kernel sets; before, pair by pair, the obstacle's own: the closed form)
    assert abs(sol.estimate.parts["complementarity"]) <= 1e-12 * closed_form
    assert abs(one.estimate.parts["complementarity"]) <= 1e-12 * closed_form       # measured <= 2.6e-30
