"""A normal-compliance law with P2 (10-node) tetrahedra under "sigma1"/"sigma2" where the overlap's edge cuts faces of
the constrained body (docs/formulation.md §15, "Normal compliance"; docs/refusals.md row 31): the 6-point rule on its
faces wholly in the overlap, and on a cut face the rows themselves weighted by the red refinement's hats integrated
over the overlap (a node outside giving its share to the nearest node inside).

Cross-checks, none taken from the code under test: the overlap's area and first moment in closed form, the soft law's
uniform state (r = the interference, so the total force is k delta times the area and lambda = k delta), the same pair
posed from the other body (an invariance), and the 1/k rate of the law's answer as k grows.
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem.space import P2Tet

from scenes3d import SIDES, STEEL
from scenes3d import sampled_penetration as sampled_jump_excess

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

DELTA = 1e-5       # m, the interference


def punch(edge=0.5, swap=False, law=None):
    """A punch (0, edge) x (0, 1) x (0.5, 1) on a block (0, 1)^2 x (0, 0.5) of 3 x 3 cells (the overlap's edge
    x = ``edge`` crosses the block's faces unless it is a multiple of 1/3), both held by rollers, interfering by
    DELTA; the block is the pair's first body (its nodes "sigma1") or, ``swap``, its second ("sigma2")."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=3, ny=3, nz=1)
    up = cc.box(x=(0, edge), y=(0, 1), z=(.5, 1), nx=2, ny=2, nz=1)
    block = cc.Body(low, STEEL, roller=SIDES + ["bottom"], contact="top", name="block")
    top = cc.Body(up, STEEL, roller=SIDES + ["top"], contact="bottom", name="punch")
    pair = cc.Contact(top, "bottom", block, "top", law=law, gap=-DELTA) if swap else \
        cc.Contact(block, "top", top, "bottom", law=law, gap=-DELTA)
    return cc.Scene(block, top, contacts=[pair])


def corner(law=None):
    """A block (0, 1)^2 of 2 x 2 cells on a block of 4 x 4 cells shifted by (1/8, 1/8) m: the overlap [1/8, 1]^2
    cuts the upper block's faces along both axes, across its red refinement (whose lines are 1/4 m apart)."""
    lower = cc.box(nx=4, ny=4, nz=1)
    below = cc.Body(lower.with_points(lower.points + [0.125, 0.125, -1.0]), STEEL, roller=SIDES + ["bottom"],
                    contact="top", name="below")
    above = cc.Body(cc.box(nx=2, ny=2, nz=1), STEEL, roller=SIDES + ["top"], contact="bottom", name="above")
    return cc.Scene(above, below, contacts=[cc.Contact(above, "bottom", below, "top", law=law, gap=-DELTA)])


# the overlap's area (m^2) and its first moments int x, int y (m^3), closed forms
CASES = {"edge on the refined faces": (lambda law: punch(0.5, law=law), 0.5, (0.125, 0.25)),
         "edge across them": (lambda law: punch(0.45, law=law), 0.45, (0.45 ** 2 / 2, 0.225)),
         "corner across them": (corner, 0.875 ** 2, ((1 - 0.125 ** 2) / 2 * 0.875,) * 2)}


@pytest.mark.parametrize("name", list(CASES))
def test_the_rule_on_cut_faces_is_positive_and_integrates_a_constant_over_the_overlap(name):
    """The law's quadrature under "sigma1": positive weights, rows Q that reproduce a constant (the P2 functions and
    the rows themselves), weights summing to the overlap's area; where the overlap's edge follows the refined faces'
    edges (x = 0.5 on 1/6 m sub-triangles) the first moment of the overlap is exact too."""
    build, area, moments = CASES[name]
    law = cc.NormalCompliance(stiffness=1e9)
    itf = P2Tet().contact(build(law), "sigma1", law).interface
    Q, w = itf.quadrature("sigma1")
    t, rows = itf.traces[0], itf.sigma_rows(0)
    assert (w > 0).all() and Q.shape == (len(w), len(rows))
    assert np.abs(Q @ np.ones(len(rows)) - 1).max() < 1e-13                  # measured 0
    assert abs(w.sum() / area - 1) < 1e-13                                   # measured <= 7.8e-16
    first = w @ (Q @ t.x[rows])
    if name == "edge on the refined faces":
        np.testing.assert_allclose(first, moments, rtol=1e-13)               # measured 6.7e-16
    else:                      # the nearest node's share: not exact for a linear function (the strip it moves)
        assert np.abs(first / moments - 1).max() > 1e-3                      # measured 6.7e-2 (x), 1.6e-2


@pytest.mark.parametrize("name", list(CASES))
def test_a_soft_law_on_cut_faces_presses_the_interference_over_the_overlap(name):
    """A law so soft (k = 1e4 Pa/m) that the bodies barely deform (k L / c33 ~ 1e-7): r = DELTA on the overlap, so
    the total force is k DELTA times its area and lambda = k DELTA at every node of X_h, whatever the faces' cuts
    (measured <= 1.9e-7 and 2.2e-7, the bodies' deformation)."""
    build, area, _ = CASES[name]
    k = 1e4
    sol = cc.solve(build(cc.NormalCompliance(stiffness=k)), "sigma1", degree=2)
    assert sol.ok
    assert abs(sol.contact.force.sum() / (k * DELTA * area) - 1) < 1e-4
    assert np.abs(sol.contact.lam / (k * DELTA) - 1).max() < 1e-4


@pytest.mark.parametrize("edge", [0.5, 0.45])
def test_the_block_s_nodes_give_the_same_answer_as_sigma1_or_sigma2(edge):
    """The same pair posed from the block ("sigma1") or from the punch with the block second ("sigma2"): the same
    rows, the same answer (measured 3.7e-16, 6.8e-16 of max |u|)."""
    law = cc.NormalCompliance(stiffness=1e12)
    here = cc.solve(punch(edge, law=law), "sigma1", degree=2)
    there = cc.solve(punch(edge, swap=True, law=law), "sigma2", degree=2)
    assert here.ok and there.ok
    scale = np.abs(here.u[1]).max()
    assert max(np.abs(here.u[i] - there.u[i]).max() for i in (0, 1)) < 1e-10 * scale


def test_a_stiffening_law_on_cut_faces_converges_at_rate_one_over_k():
    """k -> infinity: the answer tends to the Signorini condition on the law's rows at rate 1/k, the differences of
    successive decades shrinking tenfold (measured 1.9e-3, 1.9e-4 of max |u|, ratio 9.95, for k = 1e14 ... 1e16 Pa/m;
    c33 / L = 1.9e11 Pa/m).
    That limit is near the nodal Signorini "sigma1" answer, not equal to it: the whole faces' 6-point rule holds
    r <= 0 at its points, not at the nodes (measured 3.9e-3 of max |u|; §15)."""
    u = [cc.solve(punch(0.5, law=cc.NormalCompliance(stiffness=k)), "sigma1", degree=2).u for k in (1e14, 1e15, 1e16)]
    scale = max(np.abs(x).max() for x in u[-1])
    d = [max(np.abs(u[j][i] - u[j + 1][i]).max() for i in (0, 1)) / scale for j in (0, 1)]
    assert abs(d[0] / d[1] - 10) < 1.0                                       # measured 9.95


# ---------------------------------------------------------------------------------------------------------
# the copositive cones of a Signorini "gamma3" pair beside a compliance pair (docs/refusals.md row 29)

def bumped_stack(k):
    """Three blocks of height 1/3 m on (0, 1)^2 (rollers on their sides, the lowest on its base, the top one on its
    top; the middle one held by its two pairs), non-matching faces: below a Signorini "gamma3" pair whose gap
    opens away from the centre (-10 um there, +10 um at the corners: partial contact), above a "gamma3" pair of
    the law p = k r interfering by 10 um."""
    zs = (0.0, 1 / 3, 2 / 3, 1.0)
    extra = (["bottom"], [], ["top"])
    bodies = [cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(zs[i], zs[i + 1]), nx=c[0], ny=c[1], nz=1), STEEL,
                      roller=SIDES + e, name=f"block {i}")
              for i, (c, e) in enumerate(zip(((2, 2), (3, 3), (2, 3)), extra))]
    pairs = [cc.Contact(bodies[0], "top", bodies[1], "bottom", condition="gamma3", gap=bump),
             cc.Contact(bodies[1], "top", bodies[2], "bottom", condition="gamma3", gap=-DELTA,
                        law=cc.NormalCompliance(stiffness=k))]
    return cc.Scene(*bodies, contacts=pairs)


def bump(x, y):
    return -DELTA + 4 * DELTA * ((np.asarray(x) - .5) ** 2 + (np.asarray(y) - .5) ** 2)


def sampled_penetration(scene, sol, pair=0, n=12):
    """max over the points of spacing 1/n of every overlay triangle of pair ``pair`` of [u_nu] - g (m), the jump
    from each body's own P2 face functions and :func:`bump` itself (:func:`scenes3d.sampled_penetration`)."""
    return float(sampled_jump_excess(scene, sol, bump, pair, n).max())


def test_signorini_cones_beside_a_compliance_pair_hold_everywhere_and_are_finished():
    """The program of both (the copositive cones of the Signorini pair, the law's energy on the other pair's
    quadrature points), finished exactly by accumulated cuts (the tangency steps are singular where a face is in
    full contact): the jump sampled on 91 points of every overlay triangle of the Signorini pair never exceeds
    its gap and touches it (max of [u_nu] - g measured -1.4e-10 DELTA: the cuts stop at 1e-11 of each element's
    scale), and the middle block's two pairs carry the same force (it is held by them alone; measured 6e-16)."""
    k = 1e12
    scene = bumped_stack(k)
    sol = cc.solve(scene, degree=2)
    assert sol.ok and sol.polished and sol.info.finish == "accumulated cuts"
    r = sol.residuals()
    assert r["equilibrium"] < 1e-12 and r["cone"] < 1e-12                 # measured 2.4e-16, 1.2e-16
    assert r["feasibility"] < 1e-9 and r["complementarity"] < 1e-6        # measured 8.5e-12, 1.3e-8
    assert -1e-7 * DELTA < sampled_penetration(scene, sol) < 1e-8 * DELTA
    forces = [c.force.sum() for c in sol.contacts]
    assert abs(forces[0] / forces[1] - 1) < 1e-12
    assert 0 < sol.contacts[0].active.sum() < sol.contacts[0].active.size
    model = cc.Model(scene, degree=2).solve()                 # the Model poses the same program (measured 0)
    assert model.ok and max(np.abs(a - b).max() for a, b in zip(model.u, sol.u)) <= 1e-12 * DELTA


# ---------------------------------------------------------------------------------------------------------
# a penetration limit under "gamma3": the copositive cone at g + l beside the law's quadrature rows (row 30)

def limited_pair(ell, k=1e12):
    """A block of 2 x 2 cells on one of 3 x 3 (non-matching faces, rollers on the sides, the lower block's base and
    the upper's top), their gap the bump (-DELTA at the centre, +DELTA at the corners: partial contact), through the
    law p = k r with the limit r <= ``ell`` under "gamma3"."""
    low = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=3, ny=3, nz=1), STEEL, roller=SIDES + ["bottom"],
                  name="below")
    up = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0.5, 1), nx=2, ny=2, nz=1), STEEL, roller=SIDES + ["top"],
                 name="above")
    law = cc.NormalCompliance(stiffness=k, penetration_limit=ell)
    return cc.Scene(low, up, contacts=[cc.Contact(low, "top", up, "bottom", condition="gamma3", gap=bump, law=law)])


def test_a_penetration_limit_under_gamma3_holds_everywhere_and_touches():
    """The jump sampled on 91 points of every overlay triangle never exceeds g + l and comes within 1e-2 l of it
    (max of [u_nu] - g - l measured -5.5e-6 DELTA, l = DELTA / 10: the sample misses the touching point by that
    much); the full program and cc.Model give the same answer (measured 3.4e-16 DELTA), and so do the accumulated
    cuts when the tangency steps are declined (the cuts' point rows at g + l; measured 5.2e-11 DELTA and, at
    l = DELTA / 50, 2.6e-8 DELTA)."""
    from cvxcontact.backends import cones
    from cvxcontact.backends.finish import Declined, Stop

    for ell in (0.1 * DELTA, 0.02 * DELTA):
        scene = limited_pair(ell)
        sol = cc.solve(scene, degree=2)
        assert sol.ok and sol.polished
        r = sol.residuals()
        assert r["equilibrium"] < 1e-12 and r["cone"] < 1e-12 and r["feasibility"] < 1e-10   # <= 2.3e-16, 4.8e-13
        over = sampled_penetration(scene, sol) - ell
        assert -1e-2 * ell < over < 1e-9 * DELTA                 # -5.5e-6 DELTA (5.5e-5 l), -3.6e-5 DELTA (1.8e-3 l)
        assert 0 < sol.contact.active.sum() < sol.contact.active.size            # partial contact: 83 of 105
        if ell == 0.1 * DELTA:
            full = cc.solve(scene, degree=2, method="full")
            assert full.ok and max(np.abs(a - b).max() for a, b in zip(sol.u, full.u)) < 1e-10 * DELTA
            model = cc.Model(scene, degree=2).solve()                            # the same program (3.4e-16 DELTA)
            assert model.ok and max(np.abs(a - b).max() for a, b in zip(sol.u, model.u)) < 1e-10 * DELTA

        def declined(problem, timings, raw, B):
            raw.declined = Declined(Stop.NOT_POSED, "declined here: the cuts' turn")
            return False

        finish, cones._finish_mixed = cones._finish_mixed, declined
        try:
            cuts = cc.solve(scene, degree=2)
        finally:
            cones._finish_mixed = finish
        assert cuts.ok and cuts.info.finish == "accumulated cuts"
        assert max(np.abs(a - b).max() for a, b in zip(sol.u, cuts.u)) < 1e-5 * DELTA   # 5.2e-11, 2.6e-8 DELTA


def test_a_penetration_limit_under_gamma3_far_away_is_no_limit():
    """With l above the largest penetration of the law alone (0.11 DELTA at l = 0.3 DELTA) the answer is the law's
    without a limit (measured 4.7e-16 DELTA; lambda 3.5e-15)."""
    scene = limited_pair(0.3 * DELTA)
    free = cc.Scene(*scene.bodies, contacts=[cc.Contact(scene.bodies[0], "top", scene.bodies[1], "bottom",
                                                        condition="gamma3", gap=bump,
                                                        law=cc.NormalCompliance(stiffness=1e12))])
    a, b = cc.solve(scene, degree=2), cc.solve(free, degree=2)
    assert a.ok and b.ok
    assert max(np.abs(x - y).max() for x, y in zip(a.u, b.u)) < 1e-10 * DELTA
    assert np.abs(a.contact.lam - b.contact.lam).max() < 1e-8 * np.abs(b.contact.lam).max()
