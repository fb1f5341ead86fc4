"""The exact finish of the P2 "everywhere" cones on the sparse mixed system (26) (a body held by the contact only,
a force-controlled obstacle: ``finish_cuts_mixed``) on the factored steps, against the unfactored ones.

Every round of the cuts is solved both ways (one factorisation of the bodies and the steps on the rows, against
one sparse LU of (26) a step): the displacements agree to rounding (unique; the forces on the dependent point rows
are not) and each answer solves (26) on its closed rows, checked here from the matrices. Then the faults that
made the factored steps decline on point rows, each on a problem small enough to know the answer: a dependent
row whose slack is rounding (pivots that cycled), a node that does not move (its slack over its own scale is
rounding over rounding), a row nearly parallel to a closed one (dropped and taken again; its system on the
rows singular).
"""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d
from cvxcontact.backends import cones, finish

from scenes3d import layer_on_plane
from compliance_scenes import held_layer
from references import dense_kkt, enumerated
from obstacle_scenes import punch_scene

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

SCENES = {
    "2D layer held by the contact": lambda: held_layer(None),
    "2D force-controlled punch": lambda: punch_scene(0.5)(force=(0.0, -1e6)),
    "3D layer on a rigid plane": layer_on_plane,
    "3D Hertz sphere guided under force control, n = 4": lambda: hertz3d.scene(4, force=hertz3d.FORCE),
}


def solve(scene, factored=True):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        old = cones.FACTORED
        cones.FACTORED = factored
        try:
            return cc.solve(scene, "gamma3", degree=2)
        finally:
            cones.FACTORED = old


def residual_of_26(kkt, x, y, active, g):
    """max |A x + G^T y - F| over the size of its terms, and max |G_P x - g_P| over |G_P| |x| + |g_P|: (26) on
    the closed rows, from the matrices."""
    A, F, G = sp.csr_matrix(kkt.matrix), kkt.rhs, sp.csr_matrix(kkt.rows)
    r = A @ x + G.T @ y - F
    s = abs(A) @ np.abs(x) + abs(G).T @ np.abs(y) + np.abs(F)
    c = (G @ x - g)[active]
    # the scale of a closed row's slack: its terms, plus the displacement the elastic forces at its unknowns give
    # them through their own stiffness (a P2 face vertex on a rigid plane does not move: its slack is rounding of
    # its neighbours' displacements; |G| |x| alone read 1.0 there under the Nehalem OpenBLAS kernels)
    diag = A.diagonal()
    reach = abs(A) @ np.abs(x) * np.where(diag > 0, 1.0 / np.where(diag > 0, diag, 1.0), 0.0)
    sc = (abs(G) @ (np.abs(x) + reach) + np.abs(g))[active]
    return float(np.max(np.abs(r) / np.maximum(s, 1e-300))), float(np.max(np.abs(c) / np.maximum(sc, 1e-300),
                                                                       initial=0.0))


@pytest.mark.parametrize("name", list(SCENES))
def test_every_round_factored_and_unfactored_agree(name, monkeypatch):
    """Both ways on every round of the cuts (the factored answer carries the cuts on): neither declines, the
    displacements agree (to rounding, or where a row's slack lies within the steps' stopping tolerance, 1e-12 of
    its scale, and one way closes it, the other not, to that) and each answer solves (26) on its closed rows."""
    rounds = []
    inner = finish.independent_active_set

    def both(kkt, g, y0, start, **kw):
        kw.pop("factored")
        slow = inner(kkt, g, y0, start, factored=False, **kw)
        fast = inner(kkt, g, y0, start, factored=True, **kw)
        assert not isinstance(fast, str) and not isinstance(slow, str), (fast, slow)
        xs = [kkt.stack(o[0]) for o in (slow, fast)]
        rounds.append(np.abs(xs[1] - xs[0]).max() / np.abs(xs[0]).max())
        for o, x in zip((slow, fast), xs):
            eq, closed = residual_of_26(kkt, x, o[0][2], o[1], g)
            assert eq < 1e-12 and closed < 1e-12         # measured <= 4.1e-15 and 1.6e-15
            assert (o[0][2] >= 0).all() and not o[0][2][~o[1]].any()
        return fast

    monkeypatch.setattr(cones, "independent_active_set", both)
    sol = solve(SCENES[name]())
    # the rounds ran; after them Newton at the tangency points from the cuts' answer finishes where it settles
    # (the 2D layer held by the contact, the 2D punch: "tangency Newton")
    assert sol.ok and sol.info.finish in ("accumulated cuts", "tangency Newton") and rounds
    assert max(rounds) < 1e-9                           # measured 1.1e-14, 3.8e-15, 0, 7.9e-12 (Hertz)


@pytest.mark.parametrize("name", ["2D layer held by the contact", "2D force-controlled punch"])
def test_the_whole_finish_is_the_same_either_way(name):
    """The cuts on the factored steps and on the unfactored ones end at the same displacements to rounding (the
    same rounds: the answers of a round agree to rounding)."""
    slow, fast = solve(SCENES[name](), factored=False), solve(SCENES[name](), factored=True)
    assert slow.ok and fast.ok
    a, b = (np.concatenate([np.ravel(u) for u in s.u]) for s in (slow, fast))
    assert np.abs(a - b).max() < 1e-11 * np.abs(a).max()      # measured 1.2e-14, 3.6e-15


def test_a_dependent_row_whose_slack_is_rounding_is_passed_over():
    """Row 2 repeats row 0 (G_2 = G_0, g = 0): closed row 0 fixes its slack at 0 whatever x, and the slack the
    step reads there is rounding of the size of the row's own scale (a node that does not move). With the gaps
    the iteration computes that constant slack, 0, and stops at once; without them it pivots row 2 in for row 0
    and back, for ever (the cycle of the factored steps on a layer pressed on a plane)."""
    G = sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0]]))
    g = np.zeros(3)

    def step(mask, passive):
        z = np.zeros(3)
        z[passive] = 1.0
        slack = np.where(mask, 0.0, 1e-30)              # rounding on the open row ...
        return None, z, slack, np.full(3, 1e-30)         # ... over a scale of rounding

    start = np.array([True, True, False])
    out = finish.lawson_hanson(G, np.ones(3), start, lambda first: step, purify=False, g=g, max_iter=20)
    assert not isinstance(out, str) and list(np.flatnonzero(out[1])) == [0, 1] and out[2] == 1
    assert (finish.lawson_hanson(G, np.ones(3), start, lambda first: step, purify=False, max_iter=20)
            is finish.MAX_ITER)


def test_a_node_that_does_not_move_is_scaled_by_its_neighbours():
    """row_reach: S_j = |G_j| |x| + |g_j| + |G_j| diag(A)^-1 |A| |x| on the unknowns with stiffness, against the
    sum written out by hand on a chain of springs whose contact node (unknown 1) does not move."""
    A = np.array([[2.0, -1.0, 0.0, 0.0], [-1.0, 2.0, -1.0, 0.0], [0.0, -1.0, 2.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    G = np.array([[0.0, 1.0, 0.0, 0.5]])                 # node 1 and a stiffness-free translation (unknown 3)
    x = np.array([0.3, 0.0, -0.2, 0.1])
    g = np.array([0.05])
    S = finish.row_scale(finish.row_reach(sp.csr_matrix(A), sp.csr_matrix(G)), x, g)
    by_hand = (1.0 * 0.0 + 0.5 * 0.1) + 0.05 + 1.0 * (1.0 * 0.3 + 2.0 * 0.0 + 1.0 * 0.2) / 2.0
    assert S[0] == pytest.approx(by_hand, rel=1e-15)
    assert finish.row_scale(abs(sp.csr_matrix(G)), x, g)[0] == pytest.approx(0.5 * 0.1 + 0.05, rel=1e-15)


def test_a_row_nearly_parallel_to_a_closed_one_is_swapped_in():
    """Row 3 = row 0 + 1e-9 e_5, both pressed: the answer closes row 3 and opens row 0 (their slacks differ by
    1e-9 x_5). Joining P, row 3's own force comes out negative (rounding of a nearly singular system: 1.2e10
    against -1.2e10), and dropping it again cycled; it is swapped in for row 0 instead. The factored system on
    both rows is singular (its Schur complement squares their conditioning), so that step is the sparse LU of
    (26). Both ways end at the minimiser found by trying every active set."""
    rng = np.random.default_rng(0)
    n = 8
    M = rng.standard_normal((n, n))
    A = M @ M.T + n * np.eye(n)
    F = np.ones(n)
    G = np.vstack([np.eye(n)[:3], np.eye(n)[0] + 1e-9 * np.eye(n)[5]])
    g = np.zeros(4)
    kkt = dense_kkt(A, F, G, g)
    rows = finish.factored_rows(A, F, G, g, np.arange(4))
    assert rows is not None and rows(np.ones(4, dtype=bool), [0, 1, 2, 3]) is None
    reference = enumerated(A, F, G, g)
    for factored in (False, True):
        out = finish.independent_active_set(kkt, g, np.ones(4), np.ones(4, dtype=bool), factored=factored,
                                            purify=False)
        assert not isinstance(out, str)
        assert list(np.flatnonzero(out[1])) == [1, 2, 3]
        x = out[0][0][0]
        assert np.abs(x - reference).max() < 1e-12 * np.abs(reference).max()     # measured 0 (the same set)
