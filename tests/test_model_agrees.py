"""cc.Model and cc.solve agree on every canonical scene (tests/scenes.py; issue 20).

Two comparisons per scene, each against the default ``cc.solve`` (which may run another backend: the
condensed interface program, the sparse route):

* ``cc.Model(scene).solve()``: without user terms the Model runs the full backend's route on the same
  DiscreteProblem;
* the same Model with a user row that cannot bind (a displacement below 1 m): its own program with the user
  terms, its own finish with user rows (or the interior point for compliance and cones), its own checks.

Answers finished exactly agree to rounding; interior-point answers (cones, compliance with user terms) to
what the interior point reaches, with the measured values beside the bounds.
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc

from conftest import rel
from scenes import SCENES

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def _quiet(fn):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        return fn()


def _distance(a, b):
    worst = 0.0
    for ua, ub in zip(a.u, b.u):
        worst = max(worst, rel(ua, ub))
    for pa, pb in zip(a.phi, b.phi):
        if pb is not None and np.abs(pb).max() > 0:
            worst = max(worst, rel(pa, pb))
    return worst


def _bound(sol, ref):
    """Exact finishes on both sides: rounding (measured <= 3.8e-12: P2 compliance, condensed against full);
    an interior point on either side: its accuracy (measured <= 4.9e-8: the P2 cones with a user row)."""
    return 1e-9 if sol.polished and ref.polished else 1e-5


def _reference(once, name, scene):
    """``cc.solve`` of the scene ``name`` (``scene``, built by its builder), ResidualWarnings ignored, once per
    module: both tests below compare with it."""
    kw = SCENES[name][1]
    return _quiet(lambda: once(name, lambda: cc.solve(scene, **kw)))


@pytest.mark.parametrize("name", sorted(SCENES))
def test_model_equals_solve(name, once):
    build, kw = SCENES[name]
    scene = build()
    ref = _reference(once, name, scene)
    sol = _quiet(lambda: cc.Model(scene, **kw).solve())
    assert ref.ok and sol.ok, (ref.report(), sol.report())
    assert _distance(sol, ref) < _bound(sol, ref)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_model_with_a_slack_user_row_equals_solve(name, once):
    build, kw = SCENES[name]
    scene = build()
    ref = _reference(once, name, scene)
    model = cc.Model(scene, **kw)
    if model.problem.compliant:    # user terms with a compliance law: the interior point alone, no finish; its
        model = cc.Model(scene, **{**kw, "tol": max(kw.get("tol", 1e-6), 1e-5)})   # slack row: 1.06e-6 measured
    row = model.add(model.u(0, 0)[1] <= 1.0)                   # 1 m: never binds
    sol = _quiet(model.solve)
    assert sol.ok, sol.report()
    assert abs(float(row.dual_value)) <= 1e-6 * max(1.0, float(np.abs(sol.contact.force).max()))
    assert _distance(sol, ref) < _bound(sol, ref)


def test_model_expressions_read_the_finished_answer():
    """After the exact finish with a user row, the model's expressions read the finished answer, not the interior
    point's (they differed by 1.1e-7 of the jump before; measured 0 now)."""
    build, kw = SCENES["force-controlled circle"]
    model = cc.Model(build(), **kw)
    jump = model.jump()
    row = model.add(jump <= 1.0)                              # never binds
    sol = model.solve()
    assert sol.polished
    stacked = np.concatenate([c.jump for c in sol.contacts])
    assert np.abs(jump.value - stacked).max() <= 1e-12 * np.abs(stacked).max()
    assert np.all(row.dual_value == 0.0)                      # the finish's multipliers of an open row: exactly 0
