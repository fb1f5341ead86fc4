"""lambda_h read once per side (cvxcontact/solution/sides.py): where several pairs hold one contact part, the
forces they put on it are summed and lambda_h read once on the union of their supports.

A box pushed onto two boxes split at x = 0.4 under "gamma3": the rows at the overlay's nodes outnumber the jump's
unknowns, and the upper box's force at a node whose functions cross the cut is split between the two pairs as the
solver leaves it (its force over the consistent load of the pair's overlap: up to 45 times), while the lower
boxes' forces and the upper box's summed over the pairs are the consistent loads of the uniform pressure (measured
<= 4e-15 apart). Each pair's own Riesz representer read that split: lambda_h from -5.2 p to 93.5 p (P1), -12.6 p
to 16.3 p (P2).
Read once, every pair reads the closed-form pressure.
"""

import numpy as np
import pytest
from friction_scenes import DIAGONAL3, P, uniform_layer3d
from hex_scenes import DELTA, M_S, H
from reach_scenes import (
    block2d,
    block3d,
    box_on_boxes,
    layer_on_strips_key,
    line,
    lowered,
    strip,
)

import cvxcontact as cc
from cvxcontact.contact.interface import row_frames
from cvxcontact.solution.sides import side_multiplier
from cvxcontact.solution.slipestimate import nodal_vectors

pytestmark = [pytest.mark.numerics, pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]


@pytest.mark.parametrize("degree", [1, 2])
def test_box_on_two_boxes_reads_the_uniform_pressure(degree):
    """Uniaxial strain through two steel layers of height H: p = c_33 DELTA / (2 H) everywhere (closed form)."""
    sol = cc.solve(box_on_boxes(), "gamma3", degree=degree)
    p = M_S * DELTA / (2 * H)
    # measured max |lambda / p - 1| <= 5.9e-13 (P1), 1.4e-10 (P2: TraceRiesz's iterations), 5 kernel sets
    assert max(np.abs(c.lam / p - 1).max() for c in sol.contacts) <= {1: 1e-10, 2: 1e-7}[degree]
    est = sol.estimate
    # measured |contact traction| <= 2.2e-16 of norm^2 26.9, 5 kernel sets (before: 172 in P1, 10.4 in P2)
    assert abs(est.parts["contact traction"]) <= 1e-12 * est.norm ** 2


def _consistent(points, faces, p):
    """(n,) int p phi_a over the P1 simplices ``faces`` (segments or triangles) of ``points`` (n, d - 1) for the
    pressure p linear (nodal values ``p``), by hand: a segment of length h gives h (2 p_a + p_b) / 6 to a, a
    triangle of area A gives A (2 p_a + p_b + p_c) / 12."""
    f = np.zeros(len(points))
    for cell in faces:
        x = points[cell]
        size = x[1, 0] - x[0, 0] if len(cell) == 2 else 0.5 * abs(np.linalg.det(x[1:] - x[0]))
        k = len(cell)
        for a in range(k):
            f[cell[a]] += size * (p[cell].sum() + p[cell[a]]) / ((k + 1) * k)
    return f


@pytest.mark.parametrize("kind", ["2d", "3d"])
def test_linear_pressure_read_from_any_split(kind):
    """The consistent loads of a linear pressure on the block's bottom, each node's force split between the pairs
    reaching it at random: read once on the union (the whole part, its consistent mass), the pairs' values summed
    are the pressure at every node, to rounding, as on the single floor (the same order: exact for P1)."""
    rng = np.random.default_rng(3)
    if kind == "2d":
        scene = block2d((line(-1.0, 0.7), line(0.3, 2.0), line(-1.0, 2.0)))
        x = scene.stack.interfaces[0].traces[0].x
        points, faces = x[:, None], np.column_stack([np.arange(len(x) - 1), np.arange(1, len(x))])
        p = 1.0 + 2.0 * x
    else:
        scene = block3d((strip(-1.0, 0.7), strip(0.3, 2.0), strip(-1.0, 2.0)))
        trace = scene.stack.interfaces[0].traces[0]
        points, faces = np.asarray(trace.x), np.asarray(trace.faces)
        p = 1.0 + 2.0 * points[:, 0] - 0.5 * points[:, 1]
    f = _consistent(points, faces, p)
    stack = scene.stack
    S = [itf.interpolation(0).toarray() for itf in stack.interfaces]       # (size_i, trace nodes) selections
    split = [rng.random(len(f)) * s.sum(axis=0) for s in S]
    total = sum(split)
    forces = np.concatenate([s @ (f * part / total) for s, part in zip(S, split)])
    lam = side_multiplier(stack, forces)
    summed = sum(s.T @ lam[a:b] for s, a, b in zip(S, stack.offsets[:-1], stack.offsets[1:]))
    # measured max |sum - p| <= 1.5e-16 (2D), 7.4e-16 (3D) of max p, 5 kernel sets
    assert np.abs(summed - p).max() <= 1e-12 * np.abs(p).max()
    single = stack.interfaces[2].multiplier(S[2] @ f)                    # the floor alone, all the forces
    assert np.abs(S[2].T @ single - p).max() <= 1e-12 * np.abs(p).max()  # measured <= 7.4e-16


def test_one_pair_per_side_unchanged():
    """Pairs alone on their sides (the block on one line; two separate parts) read their own multiplier, bit for
    bit (the same operations)."""
    scene = block2d((line(-1.0, 2.0),))
    stack = scene.stack
    r = np.random.default_rng(1).random(stack.size)
    assert np.array_equal(side_multiplier(stack, r), stack.multiplier(r))


def test_compliance_pair_beside_a_signorini_pair_reads_alone():
    """A Signorini line x < 0.7 and a compliant line x >= 0.3 under the block: the compliant pair's lambda_h is its
    law's, so its forces are not summed into the Signorini pair's side; the Signorini pair reads its own
    multiplier of its forces (to the rounding of the units' scaling)."""
    body_scene = block2d((line(-1.0, 0.7),))
    body = body_scene.bodies[0]
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", line(-1.0, 0.7)),
                                     cc.Contact(body, "bottom", line(0.3, 2.0), law=cc.NormalCompliance(1e12))])
    sol = cc.solve(scene, "sigma1")
    assert sol.ok
    itf = scene.stack.interfaces[0]
    own = itf.multiplier(np.asarray(sol.contacts[0].force, dtype=float))
    # measured <= 1.4e-16 relative, 5 kernel sets (its forces summed into the side: 0.47)
    assert np.abs(sol.contacts[0].lam - own).max() <= 1e-13 * np.abs(own).max()


SCENES = {2: (block2d, line), 3: (block3d, strip)}


@pytest.mark.parametrize("dim, degree", [(2, 1), (2, 2), (3, 1), (3, 2)])
def test_untouched_obstacle_beside_the_floor_reads_nothing(dim, degree):
    """A whole floor and an obstacle 3e-6 below it under x < 0.6, never touched (its forces 0): it reads lambda_h
    0, not a share of the floor's, and the estimate is the single floor's (every term 0). Shared by the number of
    pairs reaching each node it read p / 2 and the complementarity charged that on its open gap (4.04 2D P1, 3.81
    2D P2, 3.59 3D P1, 4.85 3D P2 against norm^2 53.8)."""
    block, floor = SCENES[dim]
    sol = cc.solve(block((floor(-1.0, 2.0), lowered(-1.0, 0.6, dim))), "sigma1", degree=degree)
    # measured 0 (5 kernel sets)
    assert np.abs(sol.contacts[1].lam).max() <= 1e-12 * np.abs(sol.contacts[0].lam).max()
    est = sol.estimate
    # measured |part| <= 1.8e-16 of norm^2 53.8 (5 kernel sets)
    assert max(abs(v) for v in est.parts.values()) <= 1e-12 * est.norm ** 2


@pytest.mark.parametrize("dim, degree", [(2, 1), (3, 1), (3, 2)])
def test_obstacle_open_at_a_node_takes_no_share_of_it(dim, degree):
    """A floor under x >= 0.3 and an obstacle under x < 0.6 at the floor up to x = 0.3, then falling away: both
    reach the nodes 0.3 <= x < 0.6, where the floor is closed and the other open (by 3.3e-7 m and more; no node
    closed for both, so no dependent rows). There the open pair's lambda_h is 0 (the node's share goes to the
    floor), and the sum is the side's (contact traction 0, as on one floor). Shared by the number of pairs reaching
    each node it read p / 2 there (contact traction 0 too). 2D P2: :func:`test_p2_runs_one_closed_one_open`."""
    block, floor = SCENES[dim]
    sol = cc.solve(block((floor(0.3, 2.0), lowered(-1.0, 0.6, dim, kink=0.3))), "sigma1", degree=degree)
    c = sol.contacts[1]
    opened = np.asarray(c.gap) - np.asarray(c.jump) > 1e-3 * DELTA            # x >= 1/3: open by 3.3e-7 or more
    assert opened.any() and not opened.all()
    # measured 0 (5 kernel sets)
    assert np.abs(c.lam[opened]).max() <= 1e-12 * np.abs(sol.contacts[0].lam).max()
    est = sol.estimate
    # measured |contact traction| <= 1.2e-16 of norm^2 (5 kernel sets)
    assert abs(est.parts["contact traction"]) <= 1e-12 * est.norm ** 2


def test_p2_runs_one_closed_one_open():
    """2D P2, the scene of :func:`test_obstacle_open_at_a_node_takes_no_share_of_it`: the runs share by segments,
    and of the runs holding a node's segments those closed there take its share (``QuadraticInterface.shares``):
    the pairs' lambda_h summed is the one floor's (uniform, an independent problem of the same answer) and the open
    pair's lambda_h is 0 where it is open, but at the floor's run's first vertex x = 1/3: the floor's function
    cannot reach the segment left of it, so the other run keeps that node's value. Before (each pair's own
    multiplier where one was closed and one open at a node) the sum ran from 0.79 p to 2.2 p (p the floor's;
    each pair's -0.21 p to 2.4 p) and the contact traction was 0.034 of norm^2."""
    sol = cc.solve(block2d((line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3))), "sigma1", degree=2)
    one = cc.solve(block2d((line(-1.0, 2.0),)), "sigma1", degree=2)
    assert sol.ok and one.ok
    at = {tuple(np.round(p, 9)): i for i, p in enumerate(one.contacts[0].points)}
    total = np.zeros(len(at))
    for c in sol.contacts:
        np.add.at(total, [at[tuple(np.round(p, 9))] for p in c.points], c.lam)
    ref = np.abs(one.contacts[0].lam).max()
    # measured 0 (5 kernel sets)
    assert np.abs(total - one.contacts[0].lam).max() <= 1e-12 * ref
    c = sol.contacts[1]
    opened = (np.asarray(c.gap) - np.asarray(c.jump) > 1e-3 * DELTA) & (np.asarray(c.points)[:, 0] > 0.34)
    assert opened.any()
    # measured 0 (5 kernel sets)
    assert np.abs(c.lam[opened]).max() <= 1e-12 * ref
    est = sol.estimate
    # measured |contact traction| 1.8e-31 to 2.1e-31 of norm^2 (5 kernel sets)
    assert abs(est.parts["contact traction"]) <= 1e-12 * est.norm ** 2


@pytest.fixture(scope="module", params=["Tresca", "Coulomb"])
def layer_on_strips(request, shared):
    """The 3 x 3 x 1 P2 layer stuck under the uniform shear tau = 0.2 p (:func:`uniform_layer3d`) on strips
    x < 0.7, x >= 0.3 and a whole floor (three pairs on its bottom), under Tresca 2 p or Coulomb 0.5."""
    return shared(*layer_on_strips_key(request.param.lower()))      # test_estimate_shared_part reads it too


def _summed_t_h(sol) -> np.ndarray:
    """(nodes, 3) the pairs' t_h (Pa, vectors) summed at each node of the bottom any of them reaches."""
    total: dict = {}
    for i, c in enumerate(sol.contacts):
        t = nodal_vectors(c.shear_multiplier, row_frames(sol._pair_line(i)))[:-1]
        for p, v in zip(np.round(c.points, 9), t):
            total[tuple(p)] = total.get(tuple(p), 0.0) + v
    return np.array(list(total.values()))


@pytest.mark.filterwarnings("ignore::cvxcontact.OverlapWarning")     # stuck: the summed Tresca capacity unused
def test_friction_t_h_read_once_per_side(layer_on_strips):
    """A friction law's t_h on 3D P2 faces is read once per side as lambda_h is: the pairs' t_h summed at each node
    of the bottom is the uniform shear -tau (the first body's sigma n, closed form). Each pair the representer of its
    own share of the tangential forces read up to 0.82 tau off it (contact traction 0.487 against norm^2 540)."""
    sol = layer_on_strips
    t = _summed_t_h(sol)
    assert len(t) == 49                                               # the bottom's P2 nodes, each reached
    tau = 0.2 * P * DIAGONAL3
    # measured <= 5.2e-14 tau (Tresca), 3.6e-14 (Coulomb), 5 kernel sets; before 0.82 tau
    assert np.abs(t[:, :2] + tau).max() <= 1e-11 * 0.2 * P


def test_friction_t_h_of_a_pair_alone_is_its_own():
    """A pair alone on its part reads its own representer of its tangential forces (bit for bit)."""
    sol = cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(2 * P), n=2), "sigma1", degree=2)
    c, itf = sol.contact, sol._pair_line(0)
    own = np.column_stack([itf.multiplier(col) for col in np.asarray(c.shear_force).T])
    assert np.array_equal(c.shear_multiplier, own)
    assert not c.shear_multiplier.flags.writeable                     # read-only, as the read-back's other fields


@pytest.mark.filterwarnings("ignore::cvxcontact.OverlapWarning")     # stuck: the summed Tresca capacity unused
@pytest.mark.parametrize("order", ["strip first", "floor first"])
def test_tresca_t_h_shared_with_a_pair_open_everywhere(order):
    """The P2 layer stuck under Tresca 2 p on the floor and a strip x < 0.5 3e-6 below it (never touched): Tresca's
    open rows hold tangential forces too (g w_a whatever the gap; listed first, the strip is left 1.0e6 N of the
    2.7e6 N), so the strip, closed nowhere, is not read alone: the pairs' t_h summed is the uniform shear -tau at
    every node, the single floor's estimate (0 to rounding). Read alone (its own representer on its reach) it left
    the pairs' t_h summed up to 0.80 tau off the shear, contact traction 0.450, the estimate 0.671 (strip first)."""
    pairs = (lowered(-1.0, 0.5, 3), strip(-1.0, 2.0))
    pairs = pairs if order == "strip first" else pairs[::-1]
    sol = cc.solve(uniform_layer3d(0.2 * P, cc.Tresca(2 * P), n=3, obstacles=pairs), "sigma1", degree=2)
    t = _summed_t_h(sol)
    assert len(t) == 49
    # measured <= 6.0e-14 tau, 5 kernel sets; before 0.80 tau (strip first)
    assert np.abs(t[:, :2] + 0.2 * P * DIAGONAL3).max() <= 1e-11 * 0.2 * P
    est = sol.estimate
    # measured |contact traction| <= 3.6e-17 of norm^2 (540), the estimate 0 (5 kernel sets)
    assert abs(est.parts["contact traction"]) <= 1e-12 * est.norm ** 2
    assert est.absolute <= 1e-9 * est.norm
