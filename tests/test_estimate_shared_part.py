"""The contact terms of the estimate where several pairs hold one contact part (solution/contactestimate.py):
obstacles that together are one floor, each reaching part of the bottom, give the estimate of the single floor
(the same exact answer; every term 0 to rounding), in 2D and 3D, P1 and P2, frictionless and stuck by Tresca.

Before, each pair added int_F |sigma_h n|^2 over the whole part and its own lambda_h's terms, the cross terms
between the pairs' lambda_h (and t_h) missing: the 3D block pushed onto two strips split at x = 0.4 read 9.32
against a solution norm of 7.34 (P2; contact traction 86.9), 8.89 (P1; 79.0); the 2D P1 block on two lines 6.05
against 7.34 (there lambda_h also stopped at the last reaching node instead of its hat over the whole part, as the
law's weights read it); the 3D P2 layer stuck on the split floor 15.5 against 23.2, its friction cone 1.24 (each
pair's t_h, g_h a partial sum of the P2 basis, negative in places: the cone now reads the fields summed over the
part's pairs). A pair alone on its part is unchanged (the values on main, pinned below).
"""

import functools

import numpy as np
import pytest
from friction_scenes import FLOOR3D, P, sheared, uniform_layer, uniform_layer3d
from reach_scenes import (
    OBLIQUE,
    block2d,
    block3d,
    block_on_blocks2d,
    half,
    layer_on_strips_key,
    line,
    lowered,
    step,
    strip,
    tilted_plane,
)

import cvxcontact as cc
from cvxcontact.fem.simplex import simplex_rule
from cvxcontact.solution import contactestimate

pytestmark = [pytest.mark.numerics,
              pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning"),
              # Tresca layers stuck on obstacles that overlap (or both reach x = 0.5): the summed capacities are
              # not reached, the answer is the single floor's (tests/test_overlap.py: the warning itself)
              pytest.mark.filterwarnings("ignore::cvxcontact.OverlapWarning")]

ONE_2D = (line(-1.0, 2.0),)
SPLITS_2D = {"x = 1/3": (line(-1.0, 1 / 3), line(1 / 3, 2.0)),                  # 1/3 a vertex only the second reaches
             "x = 0.4": (line(-1.0, 0.4), line(0.4, 2.0)),                       # inside a segment
             "both at 0.5": (line(-1.0, 0.5, 1e-9), line(0.5, 2.0))}             # a vertex both reach
ONE_3D = (strip(-1.0, 2.0),)
SPLITS_3D = {"x = 0.4": (strip(-1.0, 0.4), strip(0.4, 2.0)),
             "oblique": (half(*OBLIQUE[1], True), half(*OBLIQUE[1], False))}
FRICTION_3D = {"floor": (FLOOR3D,), "x = 0.4": SPLITS_3D["x = 0.4"]}
OVERLAPS_2D = {"overlap 0.4 .. 0.6": (line(-1.0, 0.6), line(0.4, 2.0)),      # nodes 1/2 and 0.6.. both reach
               "overlap and floor": (line(-1.0, 0.7), line(0.3, 2.0), line(-1.0, 2.0))}   # one reaches all
OVERLAPS_3D = {"overlap 0.4 .. 0.6": (strip(-1.0, 0.6), strip(0.4, 2.0)),
               "overlap and floor": (strip(-1.0, 0.7), strip(0.3, 2.0), strip(-1.0, 2.0))}


def _estimate(kind, split, degree, shared=None):
    """The estimate of the scene ``kind`` on the obstacles ``split`` (None: the single one) with ``degree``; the P2
    layers on the strips and a floor read from conftest's ``shared`` when given (tests/test_sides.py reads them)."""
    if shared is not None and kind in ("layer3d", "coulomb3d") and split == "overlap and floor" and degree == 2:
        sol = shared(*layer_on_strips_key("coulomb" if kind == "coulomb3d" else "tresca"))
        assert sol.ok
        return sol.estimate
    return _solved_estimate(kind, split, degree)


@functools.cache
def _solved_estimate(kind, split, degree):
    if kind == "block2d":
        scene = block2d(ONE_2D if split is None else {**SPLITS_2D, **OVERLAPS_2D}[split])
    elif kind == "block3d":
        scene = block3d(ONE_3D if split is None else {**SPLITS_3D, **OVERLAPS_3D}[split])
    elif kind == "hexlayer":
        scene = uniform_layer3d(0.2 * P, cc.Tresca(2 * P), n=3, cell="hex", obstacles=FRICTION_3D[split or "floor"])
    elif kind == "layer2d":
        obstacles = (line(-1.0, 2.0),) if split is None else SPLITS_2D[split]
        scene = uniform_layer(0.2 * P, cc.Tresca(2 * P), obstacles=obstacles)
    else:                                                    # "layer3d" (Tresca), "coulomb3d"
        law = cc.Coulomb(0.5) if kind == "coulomb3d" else cc.Tresca(2 * P)
        scene = uniform_layer3d(0.2 * P, law, n=3, obstacles={**FRICTION_3D, **OVERLAPS_3D}[split or "floor"])
    sol = cc.solve(scene, "sigma1", degree=degree)
    assert sol.ok
    return sol.estimate


def _same_as_one(kind, split, degree, shared=None):
    """Every part of the split scene's estimate and of the single obstacle's is 0 to rounding, the norms equal."""
    one, two = _estimate(kind, None, degree), _estimate(kind, split, degree, shared)
    assert two.norm == pytest.approx(one.norm, rel=1e-12)         # measured <= 1.3e-15 relative, 5 kernel sets
    scale = one.norm ** 2
    for name in one.parts:
        # measured |part| <= 2.9e-16 scale under the 5 kernel sets (contact traction: the squares' cancellation)
        assert abs(two.parts[name]) <= 1e-12 * scale, (name, two.parts[name], scale)
        assert abs(one.parts[name]) <= 1e-12 * scale, (name, one.parts[name], scale)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("split", list(SPLITS_3D))
def test_block3d_on_split_floor(split, degree):
    _same_as_one("block3d", split, degree)


@pytest.mark.parametrize("split", ["x = 1/3", "x = 0.4", "both at 0.5"])
def test_block2d_p1_on_split_floor(split):
    _same_as_one("block2d", split, 1)


@pytest.mark.parametrize("kind", ["block2d", "block3d"])
def test_p1_overlapping_obstacles(kind):
    """Two obstacles that both reach the nodes of a band of the part (P1): the solver's split of those nodes'
    forces between the two rows is arbitrary, but lambda_h is read once from the forces summed (both pairs read
    r / w before, the same linear map), so the sum is the single floor's whatever the split; the cross terms there
    integrate hats both pairs carry (before: contact traction 33.2 in 2D, 79.0 in 3D, norm^2 53.8)."""
    _same_as_one(kind, "overlap 0.4 .. 0.6", 1)


@pytest.mark.parametrize("kind, degree", [("block2d", 1), ("block3d", 1), ("block3d", 2)])
def test_overlapping_obstacles_and_a_floor(kind, degree):
    """Lines (strips) x < 0.7, x >= 0.3 and a whole floor under the block: the union of their reach is the whole
    part, read once by its consistent mass from the forces summed (each pair reading its nodes' values over the
    number of pairs reaching them). Before each pair read its own split of the nodes' forces (the floor by M^-1 r,
    the others by r / w): contact traction 7.96 in 2D P1, 2.90 in 3D P1, 0.549 in 3D P2 (norm^2 53.8)."""
    _same_as_one(kind, "overlap and floor", degree)


@pytest.mark.parametrize("split", ["both at 0.5", "overlap and floor"])
def test_p2_lines_sharing_nodes(split):
    """2D P2 lines that both reach a vertex (0.5), or x < 0.7, x >= 0.3 and a whole floor: each pair's function
    lives on its own run, read once on the union run and shared so that the runs holding a segment sum to the
    side's lambda_h there (``QuadraticInterface.shares``). Before each pair solved M lambda = r on its run from the
    solver's split of the shared nodes' forces: contact traction 2.47 and 1.84 against norm^2 53.8 (default
    kernels; 0 under Nehalem for "both at 0.5", where the split is even)."""
    _same_as_one("block2d", split, 2)


def test_p2_overlapping_strips():
    """3D P2 strips x < 0.6, x >= 0.4: each read its own split by the partial mass of its reach (contact traction
    4.59 against norm^2 53.8 before); read once on the union, the single floor's."""
    _same_as_one("block3d", "overlap 0.4 .. 0.6", 2)


@pytest.mark.parametrize("degree", [1, 2])
def test_cross_terms_only_where_pairs_meet(degree, monkeypatch):
    """Four strips x < 0.2, 0.2 .. 0.5, 0.5 .. 0.8, >= 0.8 under the 3 x 3 x 1 box each reach one column of its
    bottom's vertices (x = 0, 1/3, 2/3, 1), so each pair's elements are the 6 or 12 triangles that touch that
    column; neighbours share the 6 triangles between their columns, the other three couples none. The cross terms
    read both functions at the q = 9 points of the degree-4 rule on the shared triangles only: 3 x 2 x 6 q = 324
    points (before: on all the larger pair's points of all 6 couples, 132 q = 1188; 1.5 s against 0.20 s on
    48 x 48 x 2 under 12 strips, 0.20 s before the cross terms). The estimate stays the floor's, 0."""
    reads = []
    traction = contactestimate._PairSide.traction

    def counted(self, face, Lf, normals):
        reads.append(len(face))
        return traction(self, face, Lf, normals)

    monkeypatch.setattr(contactestimate._PairSide, "traction", counted)
    cuts = [(-1.0, 0.2), (0.2, 0.5), (0.5, 0.8), (0.8, 2.0)]
    est = cc.solve(block3d(tuple(strip(*c) for c in cuts)), "sigma1", degree=degree).estimate
    assert sum(reads) == 3 * 2 * 6 * len(simplex_rule(2, 4)[1])
    # measured |part| <= 1.4e-16 of the squared norm (contact traction -2.9e-15, -7.4e-15; norm^2 53.8)
    assert max(abs(v) for v in est.parts.values()) <= 1e-12 * est.norm ** 2


def _tilted(lo, hi):
    """The line y = -4e-6 x under lo <= x < hi (2D; +inf off it): the 6 x 2 block pushed by 1e-5 touches it
    everywhere with a pressure that varies along x, an answer not exact in the discrete space."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return np.where((x[:, 0] >= lo) & (x[:, 0] < hi), x[:, 1] + 4e-6 * x[:, 0], np.inf)
    return cc.Rigid("tilted line", distance, f"the line y = -4e-6 x under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile([0.0, 1.0], (len(x), 1)), dim=2)


def _tilted_pair(one, two, degree=1):
    """The answers and estimates of ``one`` and ``two`` (scenes) under "sigma1": the discrete answers agree to
    rounding (the same rows, the same nodes), so should the contact tractions."""
    one, two = cc.solve(one, "sigma1", degree=degree), cc.solve(two, "sigma1", degree=degree)
    scale = max(np.abs(u).max() for u in one.u)
    assert max(np.abs(a - b).max() for a, b in zip(one.u, two.u)) <= 1e-12 * scale     # measured <= 9.4e-16
    return one.estimate, two.estimate


def test_block2d_p1_tilted_split_floor_reads_the_single_floor():
    """The split lines reach the part in part (before r / w, lumped) and the single line all of it (M^-1 r,
    consistent): read once on the union, the whole part, both read M^-1 r. Before contact traction 0.0763 split,
    0.1318 on the single line, estimate 0.838 against 0.870; now equal (measured 0 apart, 5 kernel sets)."""
    one, two = _tilted_pair(block2d((_tilted(-1.0, 2.0),)), block2d((_tilted(-1.0, 0.4), _tilted(0.4, 2.0))))
    assert two.parts["contact traction"] == pytest.approx(one.parts["contact traction"], rel=1e-9)
    assert two.absolute == pytest.approx(one.absolute, rel=1e-9)


TILTED_3D = {"x = 0.4": (tilted_plane(-1.0, 0.4), tilted_plane(0.4, 2.0)),
             "overlap and floor": (tilted_plane(-1.0, 0.7), tilted_plane(0.3, 2.0), tilted_plane(-1.0, 2.0))}


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("split", list(TILTED_3D))
def test_block3d_tilted_split_floor_reads_the_single_floor(split, degree):
    """The 3 x 3 x 1 box on the plane tilted in x and y, split at x = 0.4 (or strips x < 0.7, x >= 0.3 and the whole
    plane) or whole: the same contact traction (before P1 0.938 split against 2.655, P2 0.629 against 0.520) and
    the same estimate. The complementarity and the penetration of obstacles sharing the part are read on the side
    (the pairs' lambda_h summed against the nearest obstacle's g - [u_nu] on every face one of them holds); each
    pair's of its own functions on the faces a cut crosses read P2's complementarity 0.0378 split, 0.0405 with the
    overlap, against 0.0394 (penetration 1.44e-4, 3.24e-4 against 1.47e-4) of the estimate's square 2.82."""
    one, two = _tilted_pair(block3d((tilted_plane(-1.0, 2.0),)), block3d(TILTED_3D[split]), degree)
    # measured <= 2.0e-14 relative apart (contact traction), 5 kernel sets
    assert two.parts["contact traction"] == pytest.approx(one.parts["contact traction"], rel=1e-9)
    # measured <= 1.4e-15 relative apart (the estimate), <= 2.5e-16 of its square (complementarity), 5 kernel sets
    assert two.absolute == pytest.approx(one.absolute, rel=1e-9)
    for name in ("complementarity", "penetration"):
        assert abs(two.parts[name] - one.parts[name]) <= 1e-12 * one.absolute ** 2, name


STEPPED_3D = {"strip, lowered floor": (strip(-1.0, 0.5), lowered(-1.0, 2.0, 3)),
              "lowered floor, strip": (lowered(-1.0, 2.0, 3), strip(-1.0, 0.5))}


@pytest.mark.parametrize("cell", ["tetra", "hex"])
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("pairs", list(STEPPED_3D))
def test_block3d_on_overlapping_floors_at_two_heights_reads_the_step(pairs, degree, cell):
    """The box pushed by 1e-5 onto a strip x < 0.5 at z = 0 and a floor 3e-6 lower under the whole bottom (the
    strip's nodes reached by both, closed against the strip and open by 3e-6 against the floor beneath; each order)
    reads the estimate of the one obstacle that is their upper envelope (:func:`step`: the same nodes' gaps, the
    same answer): g - [u_nu] at a node the nearest obstacle's. Each pair's own functions read complementarity
    0.331 (P1), 0.333 (P2; penetration 3.2e-3) against 0 (P2: 5.28e-3, penetration 1.48e-6) of the estimate's
    square 11.4 (P1), 38.8 (P2); hexahedra 0.635 (Q1), 0.228 (Q2; penetration 3.5e-3) against 0 of 8.53, 23.8."""
    one, two = _tilted_pair(block3d((step(0.5, 3),), cell), block3d(STEPPED_3D[pairs], cell), degree)
    # measured <= 1.3e-15 relative apart (the estimate), every part <= 5.5e-16 of its square, 5 kernel sets
    assert two.absolute == pytest.approx(one.absolute, rel=1e-9)
    for name in ("contact traction", "complementarity", "penetration"):
        assert abs(two.parts[name] - one.parts[name]) <= 1e-12 * one.absolute ** 2, name


@pytest.mark.parametrize("split", ["x = 0.4", "both at 0.5"])
def test_layer2d_stuck_on_split_floor(split):
    _same_as_one("layer2d", split, 1)


@pytest.mark.parametrize("degree", [1, 2])
def test_layer3d_stuck_on_split_floor(degree):
    _same_as_one("layer3d", "x = 0.4", degree)
    assert _estimate("layer3d", "x = 0.4", degree).parts["friction cone"] == 0.0     # was 1.24 (P2)


@pytest.mark.parametrize("kind", ["layer3d", "coulomb3d"])
def test_layer3d_p2_stuck_on_strips_and_a_floor(kind, shared):
    """The P2 layer stuck (Tresca 2 p, Coulomb 0.5) on strips x < 0.7, x >= 0.3 and a whole floor: t_h read once
    per side as lambda_h (solution/sides.py), the single floor's estimate. Each pair the representer of its own
    share of the tangential forces: contact traction 0.487 (Tresca), 0.485 (Coulomb) against norm^2 540."""
    _same_as_one(kind, "overlap and floor", 2, shared)


@pytest.mark.parametrize("degree", [1, 2])
def test_hex_layer_stuck_on_split_floor(degree):
    """Hexahedra (Q1, Q2; :class:`~cvxcontact.solution.tensorestimate.TensorSides`): before 14.8 (Q1, contact
    traction 218), 15.5 (Q2, 240; friction cone 1.34) against a solution norm of 23.2."""
    _same_as_one("hexlayer", "x = 0.4", degree)


def test_one_pair_unchanged():
    """A pair alone on its part: the contact traction of main's estimate (2D P1 sheared block, Tresca; 3D P2 block
    on one strip reaching part of its bottom)."""
    e2 = cc.solve(sheared(0.05 * P, cc.Tresca(0.1 * P)), "sigma1").estimate
    assert e2.parts["contact traction"] == pytest.approx(0.7309772965747344, rel=1e-9)   # measured <= 4.4e-16 apart
    e3 = cc.solve(block3d((strip(-1.0, 0.4),)), "sigma1", degree=2).estimate
    assert e3.parts["contact traction"] == pytest.approx(44.008325187645696, rel=1e-9)  # measured 0 apart
    assert np.isfinite(e3.absolute)


@pytest.mark.parametrize("law, degree", [(None, 1), (None, 2), ("tresca", 1), ("coulomb", 1), ("tresca", 2)])
def test_block2d_on_two_blocks_reads_the_same_posed_from_either_side(law, degree):
    """A 2D block on two blocks (its bottom held by both pairs, contact/sides.held_sides), posed from the upper
    block under "sigma1" and from the lower ones under "sigma2": the same discrete problem, so the same answer and
    the same estimate, cell by cell (each side's traction summed over its pairs, a friction law's t_h read with
    the sign of the pair's slot). Measured (rel., the 5 kernel sets): u, lambda_h, indicators 0 (frictionless),
    <= 3.5e-15 (Tresca, Coulomb; P2 Tresca)."""
    made = {"tresca": lambda: cc.Tresca(2 * P), "coulomb": lambda: cc.Coulomb(0.3), None: lambda: None}[law]
    a = cc.solve(block_on_blocks2d(made()), "sigma1", degree=degree)
    b = cc.solve(block_on_blocks2d(made(), flip=True), "sigma2", degree=degree)
    for x, y in zip(a.u, b.u):
        assert np.abs(x - y).max() <= 1e-12 * np.abs(x).max()
    for x, y in zip(a.contacts, b.contacts):
        assert np.abs(x.lam - y.lam).max() <= 1e-12 * np.abs(x.lam).max()
    for x, y in zip(a.estimate.indicators, b.estimate.indicators):
        assert np.abs(x - y).max() <= 1e-12 * np.abs(x).max()
    assert b.estimate.parts["contact traction"] == pytest.approx(a.estimate.parts["contact traction"], rel=1e-12)
