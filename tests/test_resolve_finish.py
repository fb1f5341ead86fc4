"""The exact finish's factor of the last closed set, kept between load cases (backends.finish.lcp.LastFactor, on
the interface compliance): reused only for the same W and the same closed rows, and the answer is that of a finish
without it. The oracles: solve_lcp without the kept factor (a fresh factorisation of every step), a direct solve of
the same scene, and the LCP's own conditions."""

import numpy as np
import pytest
import scipy.linalg as sla
from conftest import rel, two_blocks

import cvxcontact as cc
from cvxcontact.backends.finish import lcp
from cvxcontact.backends.finish.lcp import LastFactor, solve_lcp

pytestmark = pytest.mark.numerics

ALU = cc.materials.isotropic(E=70e9, nu=0.3)


def _spd(m, seed, editable=False):
    A = np.random.default_rng(seed).standard_normal((m, m))
    W = A @ A.T / m + 0.05 * np.eye(m)
    W.flags.writeable = editable                   # a kept factor is for a read-only W only (as Compliance.W)
    return W


def _counting(monkeypatch):
    """Count the finish's Cholesky factorisations."""
    calls = []
    real = sla.cho_factor

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(lcp.sla, "cho_factor", counted)
    return calls


def test_a_kept_factor_gives_the_answers_of_fresh_ones_and_is_reused_only_for_its_own_w_and_rows(monkeypatch):
    """A sequence of slacks d on one W, each started from the last answer's set, with a kept factor and without:
    the same y, sets and routes bit for bit, and each y solves the LCP (y >= 0, d - W y <= 0, complementary). The
    same d again closes on the kept set: no factorisation. Another W with the same rows closed (other entries, even
    the same entries in another array) does not read the kept factor: its answer is its own fresh one."""
    m = 40
    W = _spd(m, 1)
    rng = np.random.default_rng(2)
    kept, active = LastFactor(), None
    calls = _counting(monkeypatch)
    for _ in range(5):
        d = rng.standard_normal(m)
        with_kept = solve_lcp(W, d, active, kept=kept)
        fresh = solve_lcp(W, d, active)
        assert np.array_equal(with_kept[0], fresh[0]) and np.array_equal(with_kept[1], fresh[1])
        assert with_kept[2] == fresh[2]
        y, s = with_kept[0], d - W @ with_kept[0]
        assert y.min() >= 0.0 and s.max() <= 1e-12 * np.abs(d).max()
        assert np.abs(y * s).max() <= 1e-12 * np.abs(d).max() * np.abs(y).max()
        assert 0 < with_kept[1].sum() < m                                    # some rows closed, some open
        active = with_kept[1]
    calls.clear()
    again = solve_lcp(W, d, active, kept=kept)
    assert len(calls) == 0 and np.array_equal(again[0], with_kept[0])      # the kept factor, the same answer
    other = W + 0.3 * np.eye(m)                                            # the same rows, other entries
    other.flags.writeable = False
    mine, its_own = solve_lcp(other, d, active, kept=kept), solve_lcp(other, d, active)
    assert np.array_equal(mine[0], its_own[0]) and rel(mine[0], again[0]) > 1e-3
    calls.clear()
    copy = np.array(other)                                                 # the same entries, another array
    copy.flags.writeable = False
    assert np.array_equal(solve_lcp(copy, d, mine[1], kept=kept)[0], its_own[0]) and len(calls) == 1


def _block_under_circle(x, depth=3e-3, R=0.6):
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", contact="top",
                    name="block", body_force=(0.0, -1e8))
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((x, 0.5 + R - depth), R))])


def _fields(sol):
    return np.concatenate([np.ravel(x) for x in sol.u] + [np.ravel(x) for x in sol.phi if x is not None])


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")         # a coarse top: not the point here
def test_load_cases_with_the_kept_factor_answer_as_direct_solves(monkeypatch):
    """Through one ContactSolver: other loads, another surface charge on the electrode side, the same load case
    twice (its finish then factorises nothing: the kept factor of its closed rows), back to the first loads; and an
    obstacle moved along a block and back. Each answers as cc.solve of its scene (measured: identical; asserted to
    1e-12 relative), its estimate too."""
    solver = cc.ContactSolver(two_blocks(), method="condensed")
    solver.solve()
    calls = _counting(monkeypatch)
    scenes = [two_blocks(scale=0.37, traction={"right": (0.0, -1e8)}),
              two_blocks(scale=0.37, traction={"right": (0.0, -1e8)}, surface_charge={"left": 0.08}),
              two_blocks(scale=0.37, traction={"right": (0.0, -1e8)}, surface_charge={"left": 0.08}),
              two_blocks()]
    counts = []
    for scene in scenes:
        calls.clear()
        again = solver.solve(scene)
        counts.append(len(calls))
        direct = cc.solve(scene, method="condensed")
        assert again.ok and direct.ok
        assert rel(_fields(again), _fields(direct)) < 1e-12
        assert rel(again.contact.force, direct.contact.force) < 1e-12
        assert abs(again.estimate.absolute - direct.estimate.absolute) <= 1e-12 * direct.estimate.absolute
    assert counts[2] == 0 and counts[1] > 0                       # the repeated case reused the kept factor
    assert solver.cache.condensation.compliance.last_factor.factor is not None
    mover = cc.ContactSolver(_block_under_circle(0.5), method="condensed")
    mover.solve()
    for x in (0.61, 0.5, 0.5):
        scene = _block_under_circle(x)
        again, direct = mover.solve(scene), cc.solve(scene, method="condensed")
        assert again.ok and direct.ok
        assert rel(_fields(again), _fields(direct)) < 1e-12
        assert rel(again.contact.force, direct.contact.force) < 1e-12


def test_a_factor_of_more_rows_than_kept_rows_is_not_kept(monkeypatch):
    """Above KEPT_ROWS closed rows the factor is dropped (its memory), and the answers stay those of fresh
    factorisations."""
    monkeypatch.setattr(lcp, "KEPT_ROWS", 5)
    m = 30
    W, d = _spd(m, 3), np.random.default_rng(4).standard_normal(m)
    kept = LastFactor()
    out = solve_lcp(W, d, kept=kept)
    assert out[1].sum() > 5 and kept.factor is None and kept.active is None
    assert np.array_equal(out[0], solve_lcp(W, d)[0])


def test_3d_load_cases_answer_as_direct_solves():
    """bumped_blocks (3D P1, a contact zone with an edge inside the faces) through one ContactSolver: the load x 0.5,
    x 0.5 again, x 1.3; each answers as cc.solve of its scene (asserted to 1e-12 relative). (Its rows may be
    dependent: its finish is the independent-rows one, which keeps no factor.)"""
    from scenes3d import bumped_blocks

    solver = cc.ContactSolver(bumped_blocks(), condition="sigma1", method="condensed")
    solver.solve()
    for load in (1e7, 1e7, 2.6e7):
        scene = bumped_blocks(load=load)
        again, direct = solver.solve(scene), cc.solve(scene, condition="sigma1", method="condensed")
        assert again.ok and direct.ok
        assert rel(_fields(again), _fields(direct)) < 1e-12
        assert rel(again.contact.force, direct.contact.force) < 1e-12


def test_a_w_editable_in_place_keeps_no_factor_and_the_compliance_s_w_is_read_only():
    """A factor kept for a W that is then edited in place (the same array, other entries) would close the next
    load case on the old W_AA: its y would leave the closed rows' slack nonzero (measured before the guard: 5.7,
    the answer 3.0 off), yet pass the signs (they test the open rows' slack only). So a writeable W (or a view)
    keeps nothing, each step factorises afresh (the oracle: solve_lcp without a kept factor, and the closed rows'
    slack d - W y = 0); and the W the solver keeps, Compliance.W, refuses edits in place."""
    m = 30
    rng = np.random.default_rng(1)
    rng.standard_normal((m, m))                                            # _spd's draw: d is the next one
    W, d = _spd(m, 1, editable=True), rng.standard_normal(m)
    kept = LastFactor()
    first = solve_lcp(W, d, kept=kept)
    assert kept.factor is None and kept.owner is None                      # nothing kept for an editable W
    A = first[1]
    W[np.ix_(A, A)] += 0.2                                                 # edited in place: the same array
    again, fresh = solve_lcp(W, d, A, kept=kept), solve_lcp(W, d, A)
    assert np.array_equal(again[0], fresh[0]) and np.array_equal(again[1], fresh[1])
    s = d - W @ again[0]
    assert np.abs(s[again[1]]).max() <= 1e-12 * np.abs(d).max()            # closed rows closed (measured 4e-16)
    ro = _spd(m, 1)
    view = ro[:, :]                                                        # read-only, but a view of another array
    solve_lcp(view, d, kept=kept)
    assert kept.factor is None
    solver = cc.ContactSolver(two_blocks(), method="condensed")
    solver.solve()
    Wc = solver.cache.condensation.compliance.W
    assert solver.cache.condensation.compliance.last_factor.factor is not None
    with pytest.raises(ValueError):
        Wc[0, 0] += 1.0


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")
def test_3d_and_lift_off_load_cases_that_read_the_kept_factor_answer_as_direct_solves(monkeypatch):
    """Load cases that do read the kept factor (counted), through one ContactSolver: 3D P1 two_boxes under "sigma1"
    (independent rows: the LCP finish) and 2D two_blocks, each with its load x 0.5, the same again, reversed (the
    contact opens: no closed row), back and x 2. Each answers as cc.solve of its scene (measured: identical;
    asserted to 1e-12 relative), and the solver's W is bit for bit the one of its first solve."""
    from scenes3d import two_boxes

    reads, real = [], LastFactor.get

    def counted(self, active):
        c = real(self, active)
        reads.append(c is not None)
        return c

    monkeypatch.setattr(LastFactor, "get", counted)
    base = two_boxes(n=4, condition="sigma1")

    def boxes(s):
        return base.with_loads(0, body_force=(0.0, 0.0, -2e9 * s), traction={"right": (0.0, 0.0, 3e8 * s)},
                               surface_charge={"left": -0.05 * s})

    for make, kw in ((boxes, {"condition": "sigma1"}), (lambda s: two_blocks(scale=s), {})):
        solver = cc.ContactSolver(make(1.0), method="condensed", **kw)
        solver.solve()
        W = np.array(solver.cache.condensation.compliance.W)
        reads.clear()
        for s in (0.5, 0.5, -0.3, 1.0, 2.0):
            again, direct = solver.solve(make(s)), cc.solve(make(s), method="condensed", **kw)
            assert again.ok and direct.ok
            assert rel(_fields(again), _fields(direct)) < 1e-12
            assert rel(again.contact.force, direct.contact.force) < 1e-12 or not direct.contact.active.any()
            assert np.array_equal(again.contact.active, direct.contact.active)
        assert any(reads)                                                  # the kept factor was read
        assert solver.cache.condensation.compliance.W.tobytes() == W.tobytes()
