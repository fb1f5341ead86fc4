"""Friction with P2 elements under "gamma3" where the contact ends inside an element (docs/howto/friction.md, "P2
under 'gamma3'"): the cut rounds' answer finished at the exact tangency points (Tresca), Coulomb by its fixed point
on Tresca's capacities mu r, r the nodal force of the cut points' (then the tangency points') forces.

Each scene below was declined before (the interior point's answer kept; benchmarks/friction_p2_declines.py and
benchmarks/results/friction_p2_declines.md hold the table): a block dragged over a disk (a 2D cut round's slipping
row turned its direction and the steps ended as settled, residual 0.04), Coulomb pressed into a disk and dragged
over it (no cut points for Coulomb), a free block tilted on a floor whose heel lifts inside an element (its cut
round's active set cycled between two nodes; Coulomb too), the pair of non-matching lines (its cut rounds' steps do
not settle: finished at the tangency points from the interior point's structure). Each is now finished, no ResidualWarning, and checked
against what does not share the finish: the frictionless cones' exact answer (the tangency Newton) as the
threshold or coefficient tends to 0 (linear in it, extrapolated to 0), the mirror image of the scene, and on a flat
floor the interior point of the full program at tight tolerances.
"""

import warnings

import numpy as np
import pytest
from friction_scenes import (
    P,
    declined_p2,
    dragged_disk,
    finished_p2,
    pair2d,
    pair2d_key,
    pressed_disk,
    tilted,
    tilted_key,
    walled_disk,
)

import cvxcontact as cc

P2 = {"condition": "gamma3", "degree": 2}
TIGHT = {"tol_gap_abs": 1e-15, "tol_gap_rel": 1e-15, "tol_feas": 1e-13, "tol_ktratio": 1e-12, "max_iter": 1000}



def _apart(u, v) -> float:
    return float(np.abs(u - v).max() / np.abs(v).max())


def _pair(law):
    """The block on a wider clamped block (non-matching lines) under (0.02 p, -p), both under "gamma3"."""
    return pair2d(law, 0.02 * P, condition="gamma3")


def _tilted7(law):
    """:func:`friction_scenes.tilted` with 7 cells along x (its heel lifts at a node)."""
    return tilted(law, 7)


SHARED = {(_pair, cc.Tresca(0.03 * P)): lambda shared: shared(*pair2d_key())[0],
          (_tilted7, cc.Coulomb(0.6)): lambda shared: shared(*tilted_key(cc.Coulomb(0.6), 7)),
          (tilted, cc.Coulomb(0.6)): lambda shared: shared(*tilted_key(cc.Coulomb(0.6), 8)),
          (tilted, cc.Tresca(0.6 * P)): lambda shared: shared(*tilted_key(cc.Tresca(0.6 * P), 8))}
"""The scenes of this module whose P2 answer other modules read too, by (builder, law): their answer from conftest's
``shared`` (pair2d_key: tests/test_friction_finish.py, test_friction_p2_gamma3.py; tilted_key:
test_friction_p2_gamma3_checks.py), the same solve (``cc.solve(scene(law), **P2_CONES)``) once a run."""


def _finished(once, shared, scene, law):
    """``finished_p2(scene(law))`` once per module (``scene`` a builder of this module's lists; once a run where
    :data:`SHARED` names it): several tests read the same answer."""
    made = SHARED.get((scene, law))
    return once(("finished", scene, law),
                lambda: finished_p2(scene(law), made=None if made is None else lambda: made(shared)))


def _solved(once, scene, law, **options):
    """``cc.solve(scene(law), condition="gamma3", degree=2, **options)`` once per module (its warnings raised again
    at each call: conftest's ``once``)."""
    return once(("solved", scene, law, tuple(sorted(options.items()))), lambda: cc.solve(scene(law), **P2, **options))


FLAT = [(_pair, cc.Tresca(0.03 * P)), (_pair, cc.Coulomb(0.3)), (_tilted7, cc.Coulomb(0.6)),
        (tilted, cc.Coulomb(0.6)), (tilted, cc.Tresca(0.6 * P))]
FLAT_IDS = ["pair-tresca", "pair-coulomb", "tilted7-coulomb", "tilted-coulomb", "tilted-tresca"]


@pytest.mark.numerics
@pytest.mark.parametrize("scene, law", [(pressed_disk, cc.Coulomb(0.3)), (dragged_disk, cc.Tresca(1e6)),
                                        (dragged_disk, cc.Coulomb(0.3)), *FLAT],
                         ids=["pressed-coulomb", "dragged-tresca", "dragged-coulomb", *FLAT_IDS])
def test_a_contact_ending_inside_an_element_is_finished_with_friction(scene, law, once, shared):
    """Finished (was declined), every check at rounding: the slack at the tangency points exactly (feasibility,
    measured at most 7.9e-17), the friction cone and the stick-slip (Coulomb's capacities those of the answer's own
    forces: its fixed point converged; measured at most 5e-14 and 6.5e-8, the latter a square root)."""
    r = _finished(once, shared, scene, law).residuals()
    assert r["feasibility"] <= 1e-12 and r["cone"] <= 1e-12 and r["friction cone"] <= 1e-10
    assert r["stick-slip"] <= 1e-5 and r["complementarity"] <= 1e-6 and r["equilibrium"] <= 1e-10


@pytest.mark.numerics
@pytest.mark.parametrize("scene", [pressed_disk, dragged_disk], ids=["pressed", "dragged"])
@pytest.mark.parametrize("laws", [(cc.Tresca(1e-2), cc.Tresca(1e-1)), (cc.Coulomb(1e-9), cc.Coulomb(1e-8))],
                         ids=["tresca", "coulomb"])
def test_as_friction_vanishes_the_answer_is_the_frictionless_cones_exact_one(scene, laws, once):
    """The answer departs from the frictionless cones' (finished by the tangency Newton: another route) linearly in
    the threshold or the coefficient (measured ratios 9.99999, 9.9954, 9.99995, 10.00002 for x10), and its linear
    extrapolation to 0 is that answer (measured at most 2.5e-14 of the displacements). Before the finish at the
    tangency points the cuts' answer stood 9.4e-8 and 2.3e-6 away at every threshold (the cuts' stop, 1e-9, under
    a square root)."""
    free = _solved(once, scene, None)
    assert free.polished and free.info.finish == cc.Finish.TANGENCY_NEWTON
    small, large = (finished_p2(scene(law)).u[0] for law in laws)
    d1, d2 = _apart(small, free.u[0]), _apart(large, free.u[0])
    assert d1 <= 1e-7 and abs(d2 / d1 - 10) <= 0.01                  # measured d1 at most 1.4e-9
    assert _apart(small - (large - small) / 9, free.u[0]) <= 1e-10


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Tresca(1e6), cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
def test_the_block_pressed_into_a_disk_and_its_mirror_image_have_mirrored_answers(law, once, shared):
    """The scene on the mesh reflected about x = 0 (its triangles the mirror images of the first mesh's, another
    set of elements and cut points): u_x(-x, y) = -u_x(x, y), u_y(-x, y) = u_y(x, y) (measured 2.4e-15, 1.2e-14)."""
    a, b = _finished(once, shared, pressed_disk, law), finished_p2(pressed_disk(law, mirrored=True))
    at = {tuple(np.round(p, 12)): i for i, p in enumerate(b.points[0])}
    mirror = np.array([at[tuple(np.round(p * [-1.0, 1.0], 12) + 0.0)] for p in a.points[0]])
    assert _apart(b.u[0][mirror] * [-1.0, 1.0], a.u[0]) <= 1e-10


@pytest.mark.numerics
@pytest.mark.parametrize("scene, law", FLAT, ids=FLAT_IDS)
def test_on_flat_contact_the_answer_is_the_interior_point_at_tight_tolerances(scene, law, once, shared):
    """Between flat faces the interior point's program is the finish's (no gap departure): at tight tolerances its
    displacements are the finished ones (measured 4.0e-11, 1.5e-11 on the pair, 1.4e-10, 3.5e-14, 2.0e-14 on the
    tilted block), its own complementarity 5e-9. The pair and the tilted block at nx = 7 with Coulomb are finished
    at the tangency points from the interior point's structure (their cut rounds' steps do not settle)."""
    sol = _finished(once, shared, scene, law)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ipm = cc.solve(scene(law), polish=False, solver_options=TIGHT, **P2)
    assert not ipm.polished
    assert max(_apart(a, b) for a, b in zip(ipm.u, sol.u)) <= 1e-7


@pytest.mark.numerics
@pytest.mark.parametrize("scene", [pressed_disk, dragged_disk], ids=["pressed", "dragged"])
def test_coulomb_s_fixed_point_that_does_not_settle_declines_and_says_so(scene, once):
    """Coulomb's fixed point on the cut points' capacities stopped at its ``max_iterations`` (2: measured relative
    change 2.1e-4 there, above the tolerance 1e-12) is no answer: the interior point's, not polished, its
    ``info.declined`` naming the fixed point, a ResidualWarning (and the interior point's FixedPointWarning)."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sol = _solved(once, scene, cc.Coulomb(0.3, max_iterations=2))
    assert not sol.polished and sol.info.finish is None
    assert "Coulomb's fixed point on the cut points' capacities" in sol.info.declined
    assert any(issubclass(w.category, cc.ResidualWarning) and "Coulomb's fixed point" in str(w.message)
               for w in record)


@pytest.mark.numerics
@pytest.mark.parametrize("scene", [pressed_disk, dragged_disk], ids=["pressed", "dragged"])
def test_info_fixed_point_is_the_fixed_point_that_produced_the_answer(scene, once, shared):
    """Coulomb under the P2 cones, finished by its fixed point at the cut points then at the tangency points:
    ``info.fixed_point`` lists that finish's changes (measured 9 iterates, the last 8.5e-14 pressed and 1.7e-13
    dragged, <= the law's tolerance 1e-12), not the interior point's fixed point (50 iterates, its limit, last
    change 1.0e-7 and 2.2e-6: what was reported before). Declined (its ``max_iterations`` 2), the answer is the
    interior point's and so is the fixed point reported: that of the interior point alone (``polish=False``)."""
    law = cc.Coulomb(0.3)
    sol = _finished(once, shared, scene, law)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                  # the interior point's answer fails its checks
        interior = cc.solve(scene(law), polish=False, **P2).info.fixed_point
    assert len(interior) == law.max_iterations and interior[-1] > law.tolerance   # it never settled
    changes = sol.info.fixed_point
    assert 1 <= len(changes) <= 2 * law.max_iterations and changes[-1] <= law.tolerance
    assert changes != interior
    short = cc.Coulomb(0.3, max_iterations=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        declined = _solved(once, scene, short)
        alone = cc.solve(scene(short), polish=False, **P2)
    assert not declined.polished and len(declined.info.fixed_point) == 2
    assert np.allclose(declined.info.fixed_point, alone.info.fixed_point, rtol=1e-6, atol=0)


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Tresca(1e6), cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
def test_a_declined_2d_polish_labels_the_cut_rounds_answer_declined_and_keeps_it(law, monkeypatch):
    """The block dragged over a disk (its contact ends inside elements) with the 2D Newton at the tangency points
    made to decline (``friction.tangency_newton`` said to stall): the cut rounds' answer stands, labelled as every
    declined finish is (:func:`friction_scenes.declined_p2`: not polished, no finish, the interior point's route,
    ``info.declined`` the polish's reason, a ResidualWarning and the report's first line saying the cut rounds'
    answer is kept); it read polished, finished by the friction Newton, with no warning before. The label alone
    changed: the arrays are bit for bit those of the answer unlabelled (``friction._kept`` passing the cuts' answer
    on, as before), and its checks sit at the cuts' stop."""
    from cvxcontact.backends import friction
    from cvxcontact.backends.finish import Declined, Stop

    monkeypatch.setattr(friction, "tangency_newton", lambda *args, **kwargs: Declined(Stop.STALL, "stalled (a test)"))
    sol = declined_p2(dragged_disk(law))
    assert sol.info.declined.stop is Stop.STALL
    assert "the friction cuts declined (stalled (a test))" in sol.info.declined, sol.info.declined
    assert sol.info.kept == "cut rounds' answer"
    assert sol.report().splitlines()[0].endswith("cut rounds' answer (exact finish declined: "
                                                 f"{Stop.STALL.value})")
    # measured (default, Haswell, Nehalem, Prescott, Sandybridge) Tresca 1.1e-11 .. 5.2e-10, Coulomb 2.5e-8 .. 1.5e-7
    assert max(sol.residuals().values()) <= 2e-5
    monkeypatch.setattr(friction, "_kept", lambda problem, cuts, done: cuts if isinstance(done, Declined) else done)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        unlabelled = cc.solve(dragged_disk(law), **P2)
    assert unlabelled.polished and unlabelled.info.declined is None
    assert all(np.array_equal(a, b) for a, b in zip(sol.u, unlabelled.u))
    assert all(np.array_equal(a.force, b.force) and np.array_equal(a.shear_force, b.shear_force)
               for a, b in zip(sol.contacts, unlabelled.contacts))


@pytest.mark.numerics
def test_coulomb_s_fixed_point_at_the_tangency_points_that_does_not_settle_labels_the_cut_rounds_answer(monkeypatch):
    """Coulomb on the block dragged over a disk with the fixed point at the tangency points made not to settle
    (each polish's forces scaled by 1 +- 1e-2 in turn: the capacities change by about 2e-2 at every iterate, never
    below the tolerance, while the cuts' fixed point before it converges as it does): the cut rounds' answer
    stands, labelled as every declined finish is (:func:`friction_scenes.declined_p2`; ``info.declined`` names the
    fixed point and the iterates it ran, its stop MAX_ITER); it read polished, finished by the friction Newton,
    with no warning before (and the interior point's FixedPointWarning after, naming an answer not kept). The
    arrays are bit for bit those of the answer unlabelled."""
    from cvxcontact.backends import friction
    from cvxcontact.backends.finish import Declined, Stop

    polish, calls = friction._tangency_polish, []

    def swinging(*args, **kwargs):
        done = polish(*args, **kwargs)
        if not isinstance(done, Declined):
            calls.append(len(calls))
            done.y = np.asarray(done.y, dtype=float) * (1.0 + 1e-2 * (-1) ** len(calls))
        return done

    monkeypatch.setattr(friction, "_tangency_polish", swinging)
    law = cc.Coulomb(0.3, max_iterations=6)     # the cuts' fixed point converges in 5 iterates, the interior's not
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sol = declined_p2(dragged_disk(law), {"degree": 2})
    assert len(calls) == 6                               # the polish finished every iterate; the fixed point ran out
    # no FixedPointWarning: the interior point's fixed point did not settle (5.7e-6 at its iterate 6), but its
    # words ("the answer is its iterate of smallest change") are not the kept cuts' answer's, whose own converged
    assert not [w for w in record if issubclass(w.category, cc.FixedPointWarning)]
    assert sol.info.declined.stop is Stop.MAX_ITER and "did not settle in 6 iterates" in sol.info.declined
    assert sol.info.kept == "cut rounds' answer"
    monkeypatch.setattr(friction, "_kept", lambda problem, cuts, done: cuts if isinstance(done, Declined) else done)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        unlabelled = cc.solve(dragged_disk(law), degree=2)
    assert unlabelled.polished and unlabelled.info.declined is None
    assert all(np.array_equal(a, b) for a, b in zip(sol.u, unlabelled.u))
    assert all(np.array_equal(a.force, b.force) and np.array_equal(a.shear_force, b.shear_force)
               for a, b in zip(sol.contacts, unlabelled.contacts))


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Tresca(1e6), cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
def test_the_block_dragged_over_a_disk_against_a_wall_reads_finished_or_declined(law):
    """:func:`friction_scenes.walled_disk`: where the 2D Newton at the tangency points declines (measured: Tresca
    under the default kernels, Coulomb under all but Sandybridge; its tangency structure unsettled in 10 rounds) the
    answer is the cut rounds', labelled declined (``info.declined`` the polish's reason, ``info.kept``, a
    ResidualWarning); where it finishes, polished with no warning and its slack at the tangency points at rounding
    (the cuts' answer is not: it read finished before). Either way the checks sit at the cuts' stop."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sol = cc.solve(walled_disk(law), degree=2)
    warned = [str(w.message) for w in record if issubclass(w.category, cc.ResidualWarning)]
    assert sol.polished == (sol.info.declined is None) and bool(warned) == (not sol.polished), warned
    # the interior point's Coulomb fixed point does not settle here (2.6e-6 at its 50th iterate): its warning, "the
    # answer is its iterate of smallest change", was raised beside the kept cut rounds' answer, not that iterate
    assert not [w for w in record if issubclass(w.category, cc.FixedPointWarning)]
    if not sol.polished:
        assert "not finished at the exact tangency points" in sol.info.declined, sol.info.declined
        assert sol.info.kept == "cut rounds' answer" and "the cut rounds' answer is kept" in warned[0]
    else:   # finished at the tangency points: the slack there exactly (measured at most 1.1e-17; the cuts' answer,
        assert sol.residuals()["feasibility"] <= 1e-13    # which read finished before, 7.4e-12 and 1.1e-11)
    # measured over the five kernel sets: declined 1.2e-10 (Tresca), 5.6e-8 (Coulomb), finished at most 8.8e-8
    assert max(sol.residuals().values()) <= 2e-5


@pytest.mark.numerics
def test_a_cycle_murty_s_rule_does_not_settle_declines_and_says_so(monkeypatch):
    """Where the 2D active set cycles and Murty's least-index rule does not settle (forced here; the tilted block
    at nx = 8 needs it, measured 3 calls), the finish declines with the cycle named and a ResidualWarning, the
    interior point's answer kept (never a step's point taken as settled)."""
    from cvxcontact.backends.finish import Stop
    from cvxcontact.backends.finish import friction as steps

    monkeypatch.setattr(steps, "_pivots", lambda *args, **kwargs: None)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sol = cc.solve(tilted(cc.Tresca(0.6 * P)), **P2)
    assert not sol.polished and sol.info.declined.stop is Stop.CYCLE, sol.info.declined
    assert any(issubclass(w.category, cc.ResidualWarning) and "cycle" in str(w.message) for w in record)


def _tresca_energy(sol, g: float) -> float:
    """The Tresca energy of an answer summed here (J/m): its bulk energy ``sol.energy`` (1/2 a(u, u) - f(u)) plus
    the friction dissipation sum_a g w_a |s_a| (w the rows' lumped lengths, s the slips)."""
    c = sol.contacts[0]
    return sol.energy + float(g * np.asarray(c.slip_measure) @ np.abs(np.asarray(c.slip)))


@pytest.mark.numerics
@pytest.mark.parametrize("nx, q, g", [(9, 0.3, 0.5), (11, 0.35, 0.6)], ids=["nx9", "nx11"])
def test_the_finished_tresca_energy_is_no_more_than_the_interior_point_s(nx, q, g):
    """The tilted block on meshes and loads not above (nx = 9, 11): the finished answer minimises the Tresca
    energy, so its energy is at most that of the interior point at tight tolerances, a feasible point of the same
    program (measured (J_finish - J_ipm) / |J| = -1.6e-14 and -1.0e-12), and its friction forces are at the
    capacity g w_a, against their slip, where it slips (measured 1.6e-16)."""
    law = cc.Tresca(g * P)
    sol = finished_p2(tilted(law, nx, q))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ipm = cc.solve(tilted(law, nx, q), polish=False, solver_options=TIGHT, **P2)
    a, b = _tresca_energy(sol, g * P), _tresca_energy(ipm, g * P)
    assert a - b <= 1e-10 * abs(b)
    c = sol.contacts[0]
    cap, t, s = g * P * np.asarray(c.slip_measure), np.asarray(c.shear_force), np.asarray(c.slip)
    slips = np.abs(s) > 1e-9 * np.abs(sol.u[0]).max()
    assert slips.any() and (~slips).any()
    assert np.abs(np.abs(t[slips]) - cap[slips]).max() <= 1e-12 * cap.max() and (t[slips] * s[slips] < 0).all()
    assert (np.abs(t[~slips]) <= cap[~slips] * (1 + 1e-12)).all()
