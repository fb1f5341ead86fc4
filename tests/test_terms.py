"""The contact term of a discrete problem (cvxcontact.discrete.terms): one object per law answers what the
backends, the read-back and the solve used to ask of the problem's flags (issue 31, "Seams").

The answers are checked against the flag expressions they replaced (written out here from the problem's own
flags, not from the term classes) on a problem of every kind, P1 and P2, 2D and 3D; and the state a solution
hands on to a warm start is computed only when it is read.
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.backends import describe
from cvxcontact.backends.run import kind
from cvxcontact.backends.signorini import dependent_rows
from cvxcontact.discrete.terms import TERMS, ContactTerm, SignoriniRows
from cvxcontact.solution.readback import READ_BACKS

from conftest import two_blocks
from scenes3d import layer_on_plane

MAT = cc.materials.isotropic(E=1e9, nu=0.3)
FLOOR = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def _flags_kind(p) -> str:
    """The kind as backends/run.kind computed it from the flags before the term (the same precedence)."""
    if p.friction:
        return "friction"
    if p.mixed:
        return "mixed"
    if p.conic:
        return "conic"
    return "compliance" if p.compliant else "signorini"


def _mixed_scene():
    """A compliance pair (gamma3) between two blocks beside a Signorini gamma3 block on a plane: P2 cones next to
    a compliance law (test_p2_mixed_laws' decoupled scene)."""
    top = cc.Body(cc.rectangle(x=(0, 1), y=(0.5, 1.0), nx=4, ny=2), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -2e7), name="top")
    mid = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=3, ny=2), MAT, clamped=["left"], contact="bottom", name="mid")
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=lambda s: -2e-5 + 1e-2 * (s - 0.6) ** 2, condition="gamma3",
                        law=cc.NormalCompliance(stiffness=1e11)),
             cc.Contact(low, "bottom", plane, gap=lambda s: 5e-3 * (s - 0.45) ** 2 - 2e-5, condition="gamma3")]
    return cc.Scene(top, mid, low, contacts=pairs)


def _tresca_scene():
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2)
    b = cc.Body(m, MAT, contact="bottom", traction={"top": (1e5, -1e7)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=cc.Tresca(1e7))])


def _small():
    return two_blocks(n1=(4, 2), n2=(3, 2))


CASES = {                                   # name: (scene, ContactSolver keywords, the kind expected)
    "signorini P1": (_small, dict(condition="gamma3"), "signorini"),
    "signorini P2 sigma1": (_small, dict(condition="sigma1", degree=2), "signorini"),
    "signorini 3D": (layer_on_plane, dict(condition="gamma3"), "signorini"),
    "compliance P1": (_small, dict(condition="gamma3", law=cc.NormalCompliance(stiffness=1e13)), "compliance"),
    "conic P2": (_small, dict(condition="gamma3", degree=2), "conic"),
    "mixed P2": (_mixed_scene, dict(degree=2), "mixed"),
    "friction P1": (_tresca_scene, dict(condition="gamma3"), "friction"),
}


@pytest.fixture(scope="module", params=list(CASES))
def case(request):
    scene, keywords, expected = CASES[request.param]
    return cc.ContactSolver(scene(), estimate=False, **keywords).problem, expected


def test_every_kind_has_its_term_and_its_read_back(case):
    p, expected = case
    assert isinstance(p.term, ContactTerm)
    assert p.term.kind == _flags_kind(p) == expected == kind(p)
    assert p.term.dim == p.dim
    assert p.term.kind in READ_BACKS
    assert {t.kind for t in TERMS} == set(cc.backends.KINDS) == set(READ_BACKS)


def test_the_term_answers_as_the_flag_branches_it_replaces(case):
    """Each question the solve asks, against the expression of the problem's flags it replaced (run.py, solve.py,
    backends/__init__.py, backends/start.py, model/__init__.py before the term)."""
    p, _ = case
    t, k = p.term, _flags_kind(p)
    assert t.takes_active_start == (k == "signorini")                # run.py: the warm start (2D and 3D since issue 30)
    assert t.zeroes_held_forces == (k == "signorini")                              # run.py: held rows' forces
    assert t.active_from_forces == (k == "compliance")                             # run.py: determinacy check
    assert t.hands_on_state == (k == "signorini" or (k == "conic" and p.dim == 2))  # start.py (the cones: 2D)
    assert t.finishes == (not p.mixed and not p.friction)                          # solve.py: declined finish
    assert t.always_finished == (not (p.conic or p.mixed or p.friction))           # solve.py, Model._warn
    assert t.cones == (p.conic or p.mixed)                                         # solve.py's hint
    assert t.estimated == t.takes_user_terms == (not p.friction)                   # solve.py, Model.solve
    d = describe(p)                                                                # backends/__init__.describe
    assert (d.compliant, d.conic, d.friction) == (p.compliant, p.conic or p.mixed, p.friction)
    assert d.dependent_rows == (bool(dependent_rows(p)) and not p.conic)


def test_the_term_follows_the_rows_it_is_posed_on():
    """A re-solve keeps the term; the conic condition posed at sampled nodal rows (with_rows) is Signorini rows."""
    p = cc.ContactSolver(_small(), condition="gamma3", degree=2, estimate=False).problem
    assert p.term.kind == "conic"
    assert p.with_loads(two_blocks(n1=(4, 2), n2=(3, 2), scale=0.5)).term == p.term
    sampled = p.with_rows(p.lines.cone[0][::3])                  # each element's first endpoint
    assert sampled.term == SignoriniRows(2) and not sampled.conic and sampled.term.zeroes_held_forces


def test_the_state_is_computed_when_first_read(monkeypatch):
    """A solve no longer computes its ContactState; reading ``sol.state`` does, once, and it is the solution's
    own nodal forces at the merged nodes' positions (the read-back's arrays, another path from the raw forces)."""
    import cvxcontact.backends.start as start

    calls = []
    real = start.point_loads
    monkeypatch.setattr(start, "point_loads", lambda *a: calls.append(1) or real(*a))
    sol = cc.solve(_small(), "gamma3", estimate=False)
    assert sol.ok and sol.polished and calls == []
    state = sol.state
    assert len(calls) == 1
    assert sol.state is state and len(calls) == 1                                  # once
    x = np.concatenate([c.x for c in sol.contacts])
    force = np.concatenate([c.force for c in sol.contacts])
    assert np.array_equal(state.s, x) and np.array_equal(state.pair, np.zeros(len(x), dtype=int))
    assert np.allclose(state.force, np.maximum(force, 0.0), rtol=1e-12, atol=0.0)   # E^T y in N/m both ways
    assert state.force.max() > 0


def test_no_state_where_none_applies(monkeypatch):
    """A compliance law hands on no state (nothing is deferred, nothing computed); a set state stands."""
    import cvxcontact.backends.start as start

    calls = []
    monkeypatch.setattr(start, "point_loads", lambda *a: calls.append(1))
    sol = cc.solve(_small(), "gamma3", law=cc.NormalCompliance(stiffness=1e13), estimate=False)
    assert sol.state is None and calls == []
    sol.state = "given"
    assert sol.state == "given"
