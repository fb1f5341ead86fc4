"""conftest's ``once``: a module's shared answers (one solve read by several tests) warn again at every call under
the caller's filters, are made once per key, and a test that changes one is caught (:func:`conftest._fingerprint`).
No solve here: stand-in answers with the shapes of a Solution (lists of read-only arrays, dataclass fields)."""

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import _fingerprint

import cvxcontact as cc


def _warns(calls):
    """A stand-in solve that records its call and raises a ResidualWarning (a declined finish)."""
    def make():
        calls.append(1)
        warnings.warn("declined: a stand-in", cc.ResidualWarning)
        return 42
    return make


def test_a_shared_answer_warns_again_at_every_call_under_the_callers_filters(once):
    calls = []
    with pytest.warns(cc.ResidualWarning, match="stand-in"):
        assert once(("warns", 1), _warns(calls)) == 42
    with pytest.warns(cc.ResidualWarning, match="stand-in"):            # the second call: no solve, the warning
        assert once(("warns", 1), _warns(calls)) == 42
    with warnings.catch_warnings():                                     # a test asserting no warning still fails
        warnings.simplefilter("error")
        with pytest.raises(cc.ResidualWarning, match="stand-in"):
            once(("warns", 1), _warns(calls))
    with warnings.catch_warnings(record=True) as caught:                # ignored where the caller ignores it
        warnings.simplefilter("ignore", cc.ResidualWarning)
        assert once(("warns", 1), _warns(calls)) == 42
    assert caught == [] and calls == [1]


def test_a_first_call_under_an_error_filter_still_makes_the_answer_once(once):
    """The first call under "error" (pyproject's filter for ResidualWarning) raises at the caller, not inside the
    solve: the answer is kept, and the next caller that ignores the warning reads it without a second solve."""
    calls = []
    with pytest.raises(cc.ResidualWarning):
        once(("warns", 2), _warns(calls))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        assert once(("warns", 2), _warns(calls)) == 42
    assert calls == [1]


def test_other_keys_make_other_answers(once):
    assert once(("key", 1), lambda: 1) == 1 and once(("key", 2), lambda: 2) == 2 and once(("key", 1), lambda: 3) == 1


@dataclasses.dataclass
class _Answer:
    u: list
    energy: float
    contact: dict
    problem: object = None


def _answer():
    u = [np.arange(6.0).reshape(3, 2), np.ones((2, 2))]
    for a in u:
        a.setflags(write=False)
    return _Answer(u=u, energy=1.5, contact={"force": np.zeros(3)})


@pytest.mark.parametrize("change", ["replace an array", "append", "set a field", "edit a dict", "edit in place",
                                    "nan"])
def test_a_changed_answer_changes_its_fingerprint(change):
    a = _answer()
    made = _fingerprint(a)
    assert _fingerprint(_answer()) == made                              # an equal answer: the same fingerprint
    if change == "replace an array":
        a.u[0] = a.u[0] - 1.0
    elif change == "append":
        a.u.append(np.zeros(1))
    elif change == "set a field":
        a.energy = 2.5
    elif change == "edit a dict":
        a.contact["slip"] = np.zeros(3)
    elif change == "edit in place":
        a.contact["force"][1] = 1e-300
    else:
        a.energy = float("nan")
    assert _fingerprint(a) != made


def test_the_fingerprint_leaves_out_the_problem():
    a = _answer()
    made = _fingerprint(a)
    a.problem = object()
    assert _fingerprint(a) == made


def _block():
    """A real :class:`~cvxcontact.discrete.blocks.Block` (3 unknowns, one jump row) as a shared answer holds one."""
    import scipy.sparse as sp

    from cvxcontact.discrete.blocks import Block

    K = sp.csr_matrix(np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 2.0]]))
    return Block(Kuu=K, f=np.array([0.0, 1.0, -1.0]), jump=sp.csr_matrix(np.array([[0.0, 0.0, 1.0]])))


def test_a_blocks_memos_read_by_a_second_check_leave_its_fingerprint():
    """A check read again with other displacements (tests/test_check_rounding_cones.py on the shared sphere) updates
    a Block's memos: its last product K z (``products``) and, from the second |K| |z| on, |K|'s values (``absolute``);
    the answer is the same (both are keyed by the matrix itself and z's numbers), its fingerprint too. A change of
    the Block's own data still changes it."""
    a = _block()
    a._times("Kuu", np.ones(3))
    a._abs_times("Kuu", np.ones(3))                         # the first |K| |z|: as a solve's checks leave it
    made = _fingerprint(a)
    for z in (np.arange(3.0), -np.ones(3)):                 # the second and third: |K|'s values formed and kept
        a._times("Kuu", z)
        a._abs_times("Kuu", z)
    assert a.absolute["Kuu"][2] is not None and _fingerprint(a) == made
    a.f = a.f + 1.0
    assert _fingerprint(a) != made
