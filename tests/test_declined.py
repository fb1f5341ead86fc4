"""Why an exact finish declined is a typed result (cvxcontact.backends.finish.declined; issue 31, "Seams"): every
finish declines with a ``Declined`` (never a reason string or None), the well-posedness check after a solve reads
the rows a decline names (``rows_to_check``), and the reason reaches the user in ``sol.info.declined`` and the first
line of ``sol.report()``."""

import copy
import pickle
import warnings
from dataclasses import replace

import numpy as np
import pytest

import cvxcontact as cc
from conftest import two_blocks
from cvxcontact.backends import Backend, register, unregister
from cvxcontact.backends.cuts import accumulate_cuts
from cvxcontact.backends.finish import Declined, Stop, solve_compliance, solve_lcp, solve_linear_compliance
from cvxcontact.backends.finish.declined import rows_to_check
from cvxcontact.backends.signorini import full as full_route
from cvxcontact.contact.laws import NormalCompliance, RowLaws, Signorini
from cvxcontact.solution.info import SolveInfo


def test_a_reason_becomes_a_typed_decline():
    assert Declined.of(None) is None and Declined.of("") is None
    given = Declined.of("my backend's reason")
    assert isinstance(given, Declined) and given.stop is Stop.GIVEN and given == "my backend's reason"
    assert given.phrase == "my backend's reason"                      # a backend's own words are its phrase
    typed = Declined(Stop.CYCLE, "the steps on rows 3 and 4 cycle")
    assert Declined.of(typed) is typed and typed.phrase == Stop.CYCLE.value
    rows = np.array([True, False])
    inner = Declined(Stop.SINGULAR_FORCES, "singular", rows)
    outer = inner.within("Newton at the contact structure")
    assert outer == "Newton at the contact structure: singular" and outer.stop is Stop.SINGULAR_FORCES
    assert outer.rows is rows
    with pytest.raises(TypeError, match="must be a Declined or a string"):
        Declined.of(3)
    for copied in (pickle.loads(pickle.dumps(outer)), copy.deepcopy(outer)):      # its stop and rows too
        assert copied == outer and copied.stop is Stop.SINGULAR_FORCES and np.array_equal(copied.rows, rows)


def test_declines_with_the_same_words_and_different_stops_differ():
    """Equality reads the stop (and the rows) as well as the words; a plain string compares by the words (messages
    and ``info.declined == "..."``); ``in`` reads the words; equal objects hash alike, and a set keeps two declines
    that differ in their stop alone."""
    words = "the finish stopped"
    a, b = Declined(Stop.CYCLE, words), Declined(Stop.MAX_ITER, words)
    assert a != b and (a == b) is False and b != a
    assert a == Declined(Stop.CYCLE, words) and (a != Declined(Stop.CYCLE, words)) is False
    assert a == words and words == a and (a != words) is False and b == words       # str behaviour
    assert "stopped" in a and str(a) == words and f"{a}" == words
    assert a != Declined(Stop.CYCLE, "other words") and a != 3
    rows = np.array([True, False])
    r1, r2 = Declined(Stop.SINGULAR_FORCES, rows=rows), Declined(Stop.SINGULAR_FORCES, rows=~rows)
    assert r1 != r2 and r1 == Declined(Stop.SINGULAR_FORCES, rows=rows.copy())
    assert r1 != Declined(Stop.SINGULAR_FORCES)                                     # rows named or not
    assert hash(a) == hash(Declined(Stop.CYCLE, words)) == hash(words)
    assert len({a, b, Declined(Stop.CYCLE, words)}) == 2
    assert a.within("here") != b.within("here") and a.within("here") == "here: " + words


def test_the_rows_the_check_reads_after_a_decline():
    """A finished answer: the route's rows; an unfinished one: none, unless its finish found the system of the
    rows carrying the forces singular (then the rows it names, else the route's)."""
    rows, named = np.array([True, False, True]), np.array([False, True, False])
    assert rows_to_check(None, rows, True) is rows and rows_to_check(None, rows, False) is None
    assert rows_to_check(Declined(Stop.MAX_ITER), rows, False) is None
    assert rows_to_check(Declined(Stop.MAX_ITER), rows, True) is rows
    assert rows_to_check(Declined(Stop.SINGULAR_FORCES, rows=named), rows, False) is named
    assert rows_to_check(Declined(Stop.SINGULAR_FORCES), rows, False) is rows
    assert rows_to_check(Declined(Stop.SINGULAR_FORCES), None, False) is None


def test_solve_info_holds_the_decline_typed():
    info = SolveInfo(status="optimal", method="mine", route="interior point", declined="my reason")
    assert info.declined.stop is Stop.GIVEN and info.declined == "my reason"
    assert SolveInfo(status="optimal", method="full", route="interior point").declined is None
    with pytest.raises(cc.SolverError, match="must be a Declined or a string"):
        SolveInfo(status="optimal", method="full", route="interior point", declined=1.5)


def test_the_finishes_that_declined_with_none_or_a_string_decline_typed():
    """The LCP, the compliance Newton and its LCP, and the cuts' loop: where they cannot answer, a Declined
    naming what stopped them (they returned None or a bare string before)."""
    W = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 0.0]])      # row 2: no unknown moves it
    d = np.array([1.0, -1.0, 0.5])                                          # ... and it penetrates
    out = solve_lcp(W, d)
    assert isinstance(out, Declined) and out.stop is Stop.NO_SOLUTION, out
    law = RowLaws.uniform(NormalCompliance(stiffness=1.0, penetration_limit=0.1), 3)
    out = solve_compliance(W, d, np.ones(3), law)
    assert isinstance(out, Declined) and out.stop is Stop.NO_SOLUTION, out
    out = solve_linear_compliance(W, d, np.ones(3), RowLaws.uniform(Signorini(), 3))
    assert isinstance(out, Declined) and out.stop is Stop.NO_SOLUTION, out
    B = np.eye(3)
    out = accumulate_cuts(B, lambda P, delta: None, np.array([0]), np.array([0.5]))       # every round singular
    assert isinstance(out, Declined) and out.stop is Stop.NO_SOLUTION, out
    # and where they can: the answer (a tuple), checked against the LCP's conditions
    y, active, _ = solve_lcp(W[:2, :2], d[:2])
    r = d[:2] - W[:2, :2] @ y
    assert (y >= 0).all() and (r <= 1e-15).all() and abs(y @ r) <= 1e-15 and active.tolist() == [True, False]


@pytest.mark.numerics
def test_a_declined_finish_reaches_info_and_report(monkeypatch):
    """The condensed route's LCP finish made to decline (its steps said to cycle): the solve warns, keeps the
    interior point's answer and says why in ``sol.info.declined`` and the report's first line; the warning and
    ``sol.info.kept`` name the interior-point answer as what is kept."""
    from cvxcontact.backends import signorini

    scene = two_blocks()
    monkeypatch.setattr(signorini, "solve_lcp",
                        lambda W, d, start=None, kept=None, implied=None: Declined(Stop.CYCLE, "cycled (a test)"))
    with pytest.warns(cc.ResidualWarning, match=r"was declined \(cycled \(a test\)\); the interior-point answer "
                                                r"is kept \(sol.polished is False\)"):
        sol = cc.solve(scene, method="condensed")
    assert not sol.polished and sol.info.route is cc.Route.INTERIOR_POINT and sol.info.kept == "interior-point answer"
    assert sol.info.declined.stop is Stop.CYCLE and sol.info.declined == "cycled (a test)"
    first = sol.report().splitlines()[0]
    assert first.endswith(f"interior-point answer (exact finish declined: {Stop.CYCLE.value})"), first
    monkeypatch.undo()
    exact = cc.solve(scene, method="condensed")
    assert exact.polished and exact.info.declined is None and "declined" not in exact.report()
    assert exact.info.kept == ""


@pytest.mark.numerics
def test_the_cones_mixed_finish_reports_one_decline(monkeypatch):
    """Where the cuts on the mixed system (26) decline and Newton at the tangency points declines after them
    (``cones.finish_cuts_mixed``, a layer held by the contact only, P2 "gamma3"), the decline that stands is the
    tangency step's whole (its stop and its rows, one decline: they were the cuts' stop beside the tangency's
    rows), in words naming the cuts' reason first."""
    from compliance_scenes import held_layer

    from cvxcontact.backends import cones

    marker = np.zeros(1, dtype=bool)                      # rows no check reads (the stop is not SINGULAR_FORCES)
    monkeypatch.setattr(cones, "accumulate_cuts", lambda *a, **k: Declined(Stop.NO_SOLUTION, "cuts (a test)"))
    monkeypatch.setattr(cones, "tangency_newton", lambda *a, **k: Declined(Stop.SINGULAR, "Newton (a test)", marker))
    with pytest.warns(cc.ResidualWarning, match="declined"):
        sol = cc.solve(held_layer(None), "gamma3", degree=2, method="full", estimate=False)
    declined = sol.info.declined
    assert not sol.polished and declined.stop is Stop.SINGULAR and declined.rows is marker
    assert declined == "cuts (a test); Newton at the tangency points: Newton (a test)"
    assert sol.report().splitlines()[0].endswith(f"(exact finish declined: {Stop.SINGULAR.value})")


def test_a_registered_backend_s_plain_reason_is_typed(registry_cleanup):
    """A backend from outside that declines in its own words (a plain string): typed as ``Stop.GIVEN``, its words
    the phrase the report shows."""
    def mine(problem, cache, settings, timings):
        raw = full_route(problem, cache, replace(settings, polish=False), timings)
        raw.declined = "my finish needs a bigger budget"
        return raw

    register(Backend("declining", lambda p: not (p.compliant or p.conic), routes={"signorini": mine}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(two_blocks(), method="declining")
    assert sol.info.declined.stop is Stop.GIVEN and sol.info.declined == "my finish needs a bigger budget"
    assert "(exact finish declined: my finish needs a bigger budget)" in sol.report().splitlines()[0]


@pytest.fixture
def registry_cleanup():
    yield
    unregister("declining")
