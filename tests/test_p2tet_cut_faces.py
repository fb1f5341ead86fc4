"""The nodal weights of a 3D P2 (10-node tetrahedra) "sigma1"/"sigma2" pair on the faces the overlap's edge cuts
(QuadraticSurface._sigma_faces, _cut_weights; docs/formulation.md §15).

A face of the constrained body may cover part of the overlap with none of its P2 nodes in it (a corner of the
overlap inside the face): its share goes to the nearest node inside (``interface.shares_to_nearest``), as on a face
with some of its nodes inside. Before, such a face was skipped: the whole faces' areas and the cut weights summed to
less than the overlap (0.675 - 2.08e-4 for the upper block (0.25, 1.25) x (-0.1, 0.9) under "sigma1").

References built here: the overlap of two axis-aligned rectangles in closed form, the triangles' areas, the
total force of a normal-compliance law k delta A between two bodies too stiff to deform (closed form).
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem.space import P2Tet

DELTA, K, E_RIGID = 1e-5, 1e9, 1e18          # m, Pa/m, Pa


def _scene(upper, n1=(3, 2), n2=(2, 3), E=1e9, law=None):
    """A nu = 0 block ``upper`` x (0.5, 1) (n1 cells) on a block (0, 1)^2 x (0, 0.5) (n2 cells), clamped at their
    far faces, interfering by DELTA; both of Young's modulus E."""
    m = cc.materials.isotropic(E=E, nu=0.0)
    up = cc.box(x=upper[0], y=upper[1], z=(0.5, 1), nx=n1[0], ny=n1[1], nz=1)
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=n2[0], ny=n2[1], nz=1)
    b1 = cc.Body(up, m, contact="bottom", clamped=["top"])
    b2 = cc.Body(low, m, clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=-DELTA, law=law)])


def _overlap(upper) -> float:
    """The area (m^2) of upper[0] x upper[1] intersected with (0, 1)^2, in closed form."""
    (x0, x1), (y0, y1) = upper
    return max(min(x1, 1) - max(x0, 0), 0.0) * max(min(y1, 1) - max(y0, 0), 0.0)


def _areas(x, faces) -> np.ndarray:
    c = x[np.asarray(faces)[:, :3]]
    d1, d2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def _overlaps(n=12, seed=7):
    """Random overlaps (upper box, cells of each block) and corner slivers; in the first two (and random ones) a
    face of the constrained block covers part of the overlap with none of its P2 nodes inside it."""
    rng = np.random.default_rng(seed)
    out = [(((0.25, 1.25), (-0.1, 0.9)), (3, 2), (2, 3)),          # the case found: sigma1 short by 2.08e-4
           (((0.805, 1.805), (-0.834, 0.166)), (3, 3), (3, 3)),     # a corner sliver: both 1.2e-2 short
           (((-0.95, 0.04), (0.97, 1.97)), (2, 2), (3, 2)),
           (((0.3, 1.3), (-0.2, 0.8)), (3, 3), (4, 4))]
    while len(out) < n:
        (x0, y0), (w, h) = rng.uniform(-0.9, 0.9, 2), rng.uniform(0.3, 1.2, 2)
        upper = ((x0, x0 + w), (y0, y0 + h))
        if _overlap(upper) > 0.01:
            n1, n2 = (tuple(int(k) for k in rng.integers(1, 5, 2)) for _ in range(2))
            out.append((upper, n1, n2))
    return out


OVERLAPS = _overlaps()


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
@pytest.mark.parametrize("k", range(len(OVERLAPS)))
def test_the_whole_faces_and_the_cut_weights_sum_to_the_overlap(k, condition):
    """The areas of the constrained body's faces wholly in the overlap plus the nodal weights on the others sum to
    the overlap's area (closed form; measured 2.1e-16 relative at most; bound 1e-13), and so do the friction
    weights; the weights are non-negative. (The former rule, skipping faces with none of their nodes in the
    overlap, was short on 5 of these 24: 3.1e-4 relative on the first, 1.2e-2 on the sliver.)"""
    upper, n1, n2 = OVERLAPS[k]
    area = _overlap(upper)
    itf = P2Tet().contact(_scene(upper, n1, n2), condition, cc.Signorini()).interface
    l = int(condition[-1]) - 1
    whole, _ = itf._sigma_faces(condition)
    cut = itf._cut_weights(condition)
    assert cut.min() >= 0 and itf.weights(condition).min() >= 0
    assert abs(_areas(itf.traces[l].x, whole).sum() + cut.sum() - area) <= 1e-13 * area
    assert abs(itf.weights(condition).sum() - area) <= 1e-13 * area
    _, w = itf.quadrature(condition)
    assert abs(w.sum() - area) <= 1e-13 * area                           # the law's quadrature integrates 1


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
@pytest.mark.parametrize("k", [0, 1, 2])
def test_a_compliance_law_between_rigid_blocks_carries_k_delta_times_the_overlap(k, condition):
    """Two blocks 1e9 times stiffer than the law (E = 1e18 Pa, k = 1e9 Pa/m, h = 0.5 m) interfering by delta
    penetrate by delta up to k h / E = 5e-10 relative: the total contact force is k delta times the overlap's area
    (closed form; measured 9.3e-10 relative at most, the bodies' own O(k h / E); bound 1e-7 -- the former rule was
    3.1e-4 short on the first case and 1.2e-2 on the sliver)."""
    upper, n1, n2 = OVERLAPS[k]
    area = _overlap(upper)
    sol = cc.solve(_scene(upper, n1, n2, E=E_RIGID, law=cc.NormalCompliance(stiffness=K)), condition, degree=2)
    total = float(np.sum(sol.contact.force))
    assert sol.ok and abs(total / (K * DELTA * area) - 1) <= 1e-7
