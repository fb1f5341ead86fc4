"""2D obstacles sharing one contact part: the estimate reads their complementarity and penetration once on the side
(solution/contactestimate.py, ``_side_line_terms``; docs/accuracy.md, "Several pairs on one part"), as 3D does:
lambda_h the pairs' functions summed, g - [u_h nu] at each node of the trace the least over the pairs reaching it.

Each scene has an independent twin of the same discrete answer, one obstacle under the part (the one floor; the
floor with a strip raised 3e-6 m as one obstacle), whose estimate the shared scene must read. Read pair by pair it
charged the discrete space's forced split of the side's lambda_h on an open pair's gap: the kink scene 0.146 (P2)
and 0.0499 (P1) of norm^2 53.8 at 6 cells; the raised strip 4.49 of 69.7 (P2, plus penetration 5.9e-3: the floor's
P2 interpolant of its gap dipping below 0 beside the strip) and 0.274 of 73.4 (P1), its estimate 78.5 % against the
one raised floor's 74.2 %. Those pair-by-pair integrals are recomputed here by hand
(:func:`references.line_complementarity`) to show the scenes tell the two reads apart.
"""

import numpy as np
import pytest
from reach_scenes import block2d, block_on_blocks2d, line, lowered, raised
from references import line_complementarity

import cvxcontact as cc
from cvxcontact.solution import contactestimate

pytestmark = [pytest.mark.numerics, pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]

KINK = ((line(0.3, 2.0), lowered(-1.0, 0.6, 2, kink=0.3)), (line(-1.0, 2.0),))
"""A floor x >= 0.3 and an obstacle at the floor up to x = 0.3, falling away by 1e-5 per m beyond (its run up to
x = 1/2); the one floor (tests/test_p2_run_vertex.py)."""
RAISED = ((line(-1.0, 2.0), lowered(0.3, 0.7, 2, drop=-3e-6)), (raised(0.3, 0.7, 2),))
"""A floor and the strip 0.3 <= x < 0.7 raised 3e-6 m above it; the one raised floor (tests/reach_scenes.raised)."""


def _pair(scene, degree, nx=6, cell="triangle"):
    """(the shared scene's solution, the one obstacle's): the same discrete answer, checked."""
    two, one = (cc.solve(block2d(s, nx=nx, cell=cell), "sigma1", degree=degree) for s in scene)
    assert two.ok and one.ok
    scale = float(np.abs(one.u[0]).max())
    # measured <= 1.1e-14 relative (kink nx = 96), <= 8.1e-31 elsewhere (5 kernel sets)
    assert np.abs(two.u[0] - one.u[0]).max() <= 1e-11 * scale
    return two, one


def _pair_by_pair(sol, degree):
    """The complementarity of each pair read alone, its own lambda_h on its own run (the old read), by hand."""
    return [line_complementarity(np.asarray(c.x), c.lam, np.asarray(c.gap) - np.asarray(c.jump), degree)
            for c in sol.contacts]


@pytest.mark.parametrize("degree, nx", [(1, 6), (1, 12), (1, 96), (2, 6), (2, 12), (2, 96)])
def test_kink_reads_the_one_floor(degree, nx):
    """Every term of the estimate 0 to rounding, as on the one floor; read pair by pair the obstacle's open gap
    charged the forced split (P2: the closed form of tests/test_p2_run_vertex.py)."""
    two, one = _pair(KINK, degree, nx)
    scale = one.estimate.norm ** 2                                      # 53.85
    # measured every part <= 1.0e-25 of norm^2 (nx = 96), <= 1.4e-28 (nx = 6, 12); complementarity <= 5.5e-32,
    # penetration <= 2.4e-61 of it, P1 and P2 (5 kernel sets)
    for est in (two.estimate, one.estimate):
        assert max(abs(v) for v in est.parts.values()) <= 1e-12 * scale, est.parts
    # the old read: measured P1 0.0499, 0.0249, 1.95e-4; P2 0.146, 0.0652, 5.72e-4 (nx = 6, 12, 96; 5 kernel sets)
    assert max(_pair_by_pair(two, degree)) >= 1e-8 * scale


@pytest.mark.parametrize("cell", ["triangle", "quad"])
@pytest.mark.parametrize("degree", [1, 2])
def test_raised_strip_reads_the_one_raised_floor(degree, cell):
    """The estimate, its parts and its indicators the one raised floor's: the floor, open by 3e-6 m under the
    strip, keeps the side's lambda_h at the strip's end vertices x = 1/3, 2/3, which read pair by pair charged
    (quadrilaterals, Q1 and Q2: 0.572 and 3.92 of norm^2 72.9, 69.4)."""
    two, one = _pair(RAISED, degree, cell=cell)
    e2, e1 = two.estimate, one.estimate
    scale = e1.norm ** 2                                                # 73.4 (P1), 69.7 (P2), 72.9, 69.4 (Q1, Q2)
    # measured <= 3.3e-16 apart (P1 3.664, 42.8 % of the norm; P2 6.197, 74.2 %; Q1 3.290, Q2 6.163; 5 kernel sets)
    assert e2.absolute == pytest.approx(e1.absolute, rel=1e-12)
    # measured every part <= 1.3e-16 of norm^2 apart; complementarity <= 1.0e-32, penetration <= 4.6e-63 of it
    # (5 kernel sets)
    for name in e1.parts:
        assert abs(e2.parts[name] - e1.parts[name]) <= 1e-12 * scale, name
    for name in ("complementarity", "penetration"):
        assert abs(e2.parts[name]) <= 1e-12 * scale, name
    top = max(np.abs(v).max() for v in e1.indicators)
    # measured <= 2.6e-16 of the largest indicator apart (5 kernel sets)
    assert max(np.abs(a - b).max() for a, b in zip(e2.indicators, e1.indicators)) <= 1e-12 * top
    floor, strip = _pair_by_pair(two, degree)
    # the old read: measured the floor's 0.274, 4.49, 0.572, 3.92 (P1, P2, Q1, Q2), the strip's 0 (closed)
    assert floor >= 1e-3 * scale and abs(strip) <= 1e-12 * scale


def test_a_part_held_by_one_pair_is_read_pair_by_pair(monkeypatch):
    """The side read serves the sides held by several Signorini pairs against obstacles only: one obstacle, or a
    block on two blocks (two-body pairs sharing its bottom), or obstacles under a compliance law sharing a part,
    never reach it (their estimates unchanged: benchmarks/estimate_hashes.py, 12 2D scenes bit for bit); the kink
    scene reaches it once."""
    calls = []
    real = contactestimate._side_line_terms
    monkeypatch.setattr(contactestimate, "_side_line_terms", lambda *a: calls.append(a[1]) or real(*a))
    body = block2d(KINK[0]).bodies[0]
    compliant = cc.Scene(body, contacts=[cc.Contact(body, "bottom", o, law=cc.NormalCompliance(stiffness=1e15))
                                         for o in KINK[0]])
    for scene, kw in [(block2d((line(-1.0, 2.0),)), {}), (block2d((line(-1.0, 0.4),)), {"degree": 2}),
                      (block_on_blocks2d(), {}), (compliant, {})]:
        assert np.isfinite(cc.solve(scene, "sigma1", **kw).estimate.absolute)
    assert calls == []
    assert np.isfinite(cc.solve(block2d(KINK[0]), "sigma1").estimate.absolute)
    assert len(calls) == 1 and sorted(calls[0]) == [0, 1]


@pytest.mark.filterwarnings("ignore::cvxcontact.OverlapWarning")   # Tresca's thresholds add where both reach
@pytest.mark.parametrize("law", [lambda: cc.Tresca(1e7), lambda: cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
@pytest.mark.parametrize("degree", [1, 2])
def test_kink_under_friction_reads_the_side_once(degree, law):
    """A friction law on the kink's pairs: the complementarity and penetration still read once on the side (not also
    pair by pair beside the friction terms, which stay per pair): 0 to rounding as on the one floor under that law,
    the friction cone and slip complementarity 0 as there (the block is not sheared)."""
    scenes = []
    for obstacles in KINK:
        body = block2d(obstacles).bodies[0]
        scenes.append(cc.Scene(body, contacts=[cc.Contact(body, "bottom", o, law=law()) for o in obstacles]))
    two, one = (cc.solve(s, "sigma1", degree=degree) for s in scenes)
    assert two.ok and one.ok
    # measured <= 4.2e-16 relative (P1, P2; 5 kernel sets)
    assert np.abs(two.u[0] - one.u[0]).max() <= 1e-11 * float(np.abs(one.u[0]).max())
    scale = one.estimate.norm ** 2                                      # 53.85
    # measured of norm^2: complementarity <= 7.4e-31, penetration <= 1.1e-61, friction cone 0, slip complementarity
    # <= 9.1e-31 (P1 all 0; 5 kernel sets); pair by pair (before) the complementarity read 0.0499 (P1), 0.146 (P2)
    for name in ("complementarity", "penetration", "friction cone", "slip complementarity"):
        assert abs(two.estimate.parts[name]) <= 1e-12 * scale, (name, two.estimate.parts[name])
