"""Stacks of three blocks (two contact pairs), shared by tests/test_p2_stack.py, tests/test_model_stack.py,
tests/test_refusals.py, tests/test_finish3d.py and the canonical set of tests/scenes.py: the 2D P2 stack with its
dense reference built from each body's own quadratic edges (:func:`dense_stack`), and the 3D stack of blocks
pressed together by an interference at each pair (uniaxial strain, :func:`three_blocks_3d`). A fixtures module:
the test modules do not import each other.
"""

import numpy as np
from scenes3d import SIDES, STEEL

import cvxcontact as cc
from cvxcontact.fem import p2
from cvxcontact.geometry.quadratic import P2Nodes

A, YOUNG = 0.5, 1e9
MAT = cc.materials.isotropic(E=YOUNG, nu=0.3)
DELTA3 = 1e-5       # m


def three_blocks(conditions=("sigma1", "sigma2")):
    """Three blocks of width 1 m and height A (top: clamped on its top, pulled down by its weight; middle: clamped
    on its left side; bottom: clamped at its base, pushed up), 4 : 3 : 5 edges on the contact lines, two pairs
    with the parabolic gaps ``gaps`` (m) and the ``conditions``: (bodies, pairs, gaps)."""
    top = cc.Body(cc.rectangle(x=(0, 1), y=(A, 2 * A), nx=4, ny=2), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -2e7), name="top")
    mid = cc.Body(cc.rectangle(x=(0, 1), y=(0, A), nx=3, ny=2), MAT, clamped=["left"], contact="bottom", name="mid")
    bot = cc.Body(cc.rectangle(x=(0, 1), y=(-A, 0), nx=5, ny=2), MAT, clamped=["bottom"], contact="top",
                  body_force=(0.0, 1e7), name="bottom")
    gaps = (lambda s: -2e-5 + 1e-2 * (s - 0.6) ** 2, lambda s: -3e-5 + 1e-2 * (s - 0.3) ** 2)
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=gaps[0], condition=conditions[0]),
             cc.Contact(mid, "bottom", bot, "top", gap=gaps[1], condition=conditions[1])]
    return (top, mid, bot), pairs, gaps


def _trace_rows(body, part, nodes, xs):
    """(len(xs), 2 n): the x2 displacement of ``body`` at abscissae xs of its horizontal ``part``, from its
    P2 edges (start, end, mid) found here by coordinates."""
    e = nodes.boundary(part)
    pts = nodes.points
    G = np.zeros((len(xs), 2 * len(pts)))
    for i, x in enumerate(xs):
        xa, xb = pts[e[:, 0], 0], pts[e[:, 1], 0]
        j = np.flatnonzero((np.minimum(xa, xb) <= x + 1e-12) & (x <= np.maximum(xa, xb) + 1e-12))[0]
        t = (x - xa[j]) / (xb[j] - xa[j])
        for node, w in zip(e[j], ((1 - t) * (1 - 2 * t), t * (2 * t - 1), 4 * t * (1 - t))):
            G[i, 2 * node + 1] += w
    return G


def part_abscissae(nodes, part):
    """The sorted distinct abscissae (m) of the P2 nodes ``nodes`` on the horizontal ``part``."""
    return np.unique(np.round(nodes.points[np.unique(nodes.boundary(part)), 0], 12))


def dense_stack(bodies, gaps):
    """The dense reference of the stack of :func:`three_blocks` with the gaps ``gaps``, built from each body's
    own P2 edges: (systems, off, K, f, rows, gs, xs) with each body's P2 system, the offsets of its free dofs,
    K and f on every free dof and, per pair, the contact rows of [u_nu] = u^upper . (0, -1) + u^lower . (0, 1)
    at the constrained body's own P2 trace nodes xs and the gaps gs there."""
    nodes = [P2Nodes(b.mesh) for b in bodies]
    systems = [p2.assemble(b, n) for b, n in zip(bodies, nodes)]
    off = np.concatenate([[0], np.cumsum([len(s.u_free) for s in systems])])
    K, f = np.zeros((off[-1], off[-1])), np.zeros(off[-1])
    for s, a, b in zip(systems, off[:-1], off[1:]):
        K[a:b, a:b] = s.Kuu[s.u_free][:, s.u_free].toarray()
        f[a:b] = s.f[s.u_free]
    rows, gs, xs_all = [], [], []
    for (ka, pa, kb, pb, kc, pc), gap in zip(((0, "bottom", 1, "top", 0, "bottom"),
                                             (1, "bottom", 2, "top", 2, "top")), gaps):
        xs = part_abscissae(nodes[kc], pc)
        G = np.zeros((len(xs), off[-1]))
        G[:, off[ka]:off[ka + 1]] -= _trace_rows(bodies[ka], pa, nodes[ka], xs)[:, systems[ka].u_free]
        G[:, off[kb]:off[kb + 1]] += _trace_rows(bodies[kb], pb, nodes[kb], xs)[:, systems[kb].u_free]
        rows.append(G)
        gs.append(gap(xs))
        xs_all.append(xs)
    return systems, off, K, f, rows, gs, xs_all


def three_blocks_3d(conditions, laws):
    """Three blocks of height 1/3 m on (0, 1)^2 (rollers on their sides, the lowest on its base, the top one on
    its top: every body held by its supports), non-matching faces, pressed together by an interference
    ``DELTA3`` at each pair: uniaxial strain."""
    zs = (0.0, 1 / 3, 2 / 3, 1.0)
    counts = ((2, 2), (3, 3), (2, 3))
    extra = (["bottom"], [], ["top"])
    bodies = [cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(zs[k], zs[k + 1]), nx=c[0], ny=c[1], nz=1), STEEL,
                      roller=SIDES + e, name=f"block {k}") for k, (c, e) in enumerate(zip(counts, extra))]
    pairs = [cc.Contact(bodies[k], "top", bodies[k + 1], "bottom", condition=c, law=lw, gap=-DELTA3)
             for k, (c, lw) in enumerate(zip(conditions, laws))]
    return cc.Scene(*bodies, contacts=pairs)
