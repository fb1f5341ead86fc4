"""P2 (degree=2): conic pairs next to normal-compliance pairs, and the conic compliance limit on several pairs
(issue 11; docs/formulation.md §10, "P2"). One program: the compliance energy on the compliant pairs' nodal rows,
the "everywhere" cone on the Signorini "gamma3" pairs (at g) and on the limited compliant "gamma3" pairs (at
g + l), nodal Signorini rows as linear rows.

Cross-checks, each independent of the mixed program:
* two pairs that share no body equal their single-pair solves (a compliance pair without a cone: its exact
  finish; a conic pair: the single-pair interior point);
* where the pairs interact (a stack of three blocks), the cone is the limit of dense nodal sampling of it (a
  relaxation from outside: energies below, tending to the conic one; fields converge), with the compliance
  pair's nodal law unchanged; a limit far beyond every penetration is no limit;
* the returned P2 jump sampled densely along every conic pair: no violation of its gap (g or g + l).
"""

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.contact.laws import RowLaws
from cvxcontact.contact.quadratic import p2_interpolation

from conftest import rel

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

A = 0.5
MAT = cc.materials.isotropic(E=1e9, nu=0.3)
GAPS = (lambda s: -2e-5 + 1e-2 * (s - 0.6) ** 2, lambda s: -3e-5 + 1e-2 * (s - 0.3) ** 2)
PLANE_GAP = lambda s: 5e-3 * (s - 0.45) ** 2 - 2e-5       # noqa: E731
K = 1e11                                                 # Pa/m: penetrations of ~1e-5 m next to Signorini's
TOL = 2e-5      # the checks' tol of the conic interior points here: complementarity measured 2.7e-7 .. 3.7e-6
                # (clarabel 0.10.0 and 0.11.1, cvxpy 1.7.5 and 1.9.3, with and without oneMKL, 1 or 2 threads)


def _blocks():
    top = cc.Body(cc.rectangle(x=(0, 1), y=(A, 2 * A), nx=4, ny=2), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -2e7), name="top")
    mid = cc.Body(cc.rectangle(x=(0, 1), y=(0, A), nx=3, ny=2), MAT, clamped=["left"], contact="bottom", name="mid")
    bot = cc.Body(cc.rectangle(x=(0, 1), y=(-A, 0), nx=5, ny=2), MAT, clamped=["bottom"], contact="top",
                  body_force=(0.0, 1e7), name="bottom")
    return top, mid, bot


def _decoupled(law, conditions):
    """Pair 0: top on mid (with ``law``); pair 1: a small block on a rigid plane (Signorini). No shared body."""
    top, mid, _ = _blocks()
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=GAPS[0], condition=conditions[0], law=law),
             cc.Contact(low, "bottom", plane, gap=PLANE_GAP, condition=conditions[1])]
    return cc.Scene(top, mid, low, contacts=pairs), [cc.Scene(top, mid, contacts=[pairs[0]]),
                                                      cc.Scene(low, contacts=[pairs[1]])]


def _penetration_rows(sol, i, condition):
    c = sol.contacts[i]
    return sol.interface.interfaces[i].evaluation(condition) @ (c.jump - c.gap)


def _sampled_penetration(sol, i, per_segment=200):
    """[u_h nu] - g_h of pair i sampled at ``per_segment`` + 1 points on each of its merged segments (m)."""
    c, itf = sol.contacts[i], sol.interface.interfaces[i]
    xv = np.asarray(itf.xv)
    pts = np.unique((xv[:-1, None] + np.diff(xv)[:, None] * np.linspace(0, 1, per_segment + 1)).ravel())
    return p2_interpolation(xv, pts) @ (c.jump - c.gap)


LIMIT = 1e-6
CASES = {   # pair 0's law and condition, pair 1's condition; which pairs are conic (interior point, ~1e-6)
    "compliance next to a conic pair": (cc.NormalCompliance(stiffness=K), ("gamma3", "gamma3"), (False, True)),
    "conic limit next to a nodal pair": (cc.NormalCompliance(stiffness=K, penetration_limit=LIMIT),
                                         ("gamma3", "sigma1"), (True, False)),
    "conic limit next to a conic pair": (cc.NormalCompliance(stiffness=1e12, penetration_limit=LIMIT),
                                         ("gamma3", "gamma3"), (True, True)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_pairs_sharing_no_body_equal_their_single_pair_solves(case):
    """Each pair of the stacked solve equals its own single-pair solve, body by body and in lambda_h, on both
    backends: a pair without a cone to its exact finish (1e-10; measured 4e-16 .. 7e-13), a conic pair to the
    accuracy of the single pair's answer (its cuts stop at a violation 1e-15, which fixes u to ~1e-8, certified
    ~6e-8; 1e-6 in u, measured <= 1.7e-8; 1e-5 in lambda_h, measured <= 4.7e-8; the stacked solve is finished by
    Newton at the contact structure, formulation §18). The limit binds where there is one.
    lambda_h of a pair without a cone: 1e-9, measured 1.2e-11 .. 9.9e-11 here and 1.5e-10 on another machine
    (its compliance finish stops at 1e-13 of the interface equation, which M^-1 and the law amplify)."""
    law, conditions, conic = CASES[case]
    scene, singles = _decoupled(law, conditions)
    refs = [cc.solve(sc, "sigma2", degree=2, method="full", tol=TOL) for sc in singles]
    # every single pair finishes exactly, a conic limit (cones next to a compliance law) too (formulation §18)
    assert all(r.ok and r.polished for r in refs)
    for method in ("full", "condensed"):
        sol = cc.solve(scene, "sigma2", degree=2, method=method, tol=TOL)
        assert sol.ok and len(sol.contacts) == 2 and sol.polished, sol.report()
        assert {"law", "feasibility", "complementarity", "cone"} <= set(sol.residuals())
        for u, r, c in zip(sol.u, [refs[0].u[0], refs[0].u[1], refs[1].u[0]], [conic[0], conic[0], conic[1]]):
            assert rel(u, r) < (1e-6 if c else 1e-10)     # measured <= 1.7e-8 (cone), 7.3e-13 (no cone)
        for c, r, on in zip(sol.contacts, refs, conic):
            assert np.array_equal(c.x, r.contact.x)
            assert rel(c.lam, r.contact.lam) < (1e-5 if on else 1e-9)   # measured <= 4.7e-8, 2.6e-13 (docstring)
            assert rel(c.jump, r.contact.jump) < (1e-6 if on else 1e-10)  # measured <= 3.7e-8, 1.1e-12
        assert sol.contacts[0].law == law and not getattr(sol.contacts[1].law, "compliant", False)
        assert rel(sol.obstacles[0].force, refs[1].obstacles[0].force) < (1e-5 if conic[1] else 1e-10)  # 6.7e-9, 1.7e-14
        if law.penetration_limit is not None:             # the cone at g + l holds the compliant pair
            # measured 2.7e-5 and 8.3e-5 of LIMIT below it on every configuration: the sampling (200 points per
            # segment) misses the maximum between samples (2e-9 of LIMIT with 20000), not the interior point
            assert abs(_sampled_penetration(sol, 0).max() - LIMIT) < 1e-3 * LIMIT


def _interacting(law0=None, law1=None, conditions=("gamma3", "gamma3")):
    top, mid, bot = _blocks()
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=GAPS[0], condition=conditions[0], law=law0),
             cc.Contact(mid, "bottom", bot, "top", gap=GAPS[1], condition=conditions[1], law=law1)]
    return cc.Scene(top, mid, bot, contacts=pairs)


def _sampled(scene, per_segment, condition1):
    """The stack with pair 0's cone replaced by the nodal condition at ``per_segment`` points per merged
    segment (a linear relaxation of it, solved with the exact compliance finish), pair 1 as it is."""
    solver = cc.ContactSolver(scene, "gamma3", degree=2)
    problem = solver.problem
    first, second = problem.interface.interfaces
    xv = np.asarray(first.xv)
    t = np.linspace(0, 1, per_segment + 1)[:-1]
    pts = np.append((xv[:-1, None] + np.diff(xv)[:, None] * t).ravel(), xv[-1])
    E1 = second.evaluation(condition1)
    # no cone left: the nodal compliance program and its finish (weights on Signorini rows are unused)
    solver.problem = problem.with_rows(sp.block_diag([p2_interpolation(xv, pts), E1], format="csr"),
                                       RowLaws(problem.rows.laws, [len(pts), E1.shape[0]]),
                                       np.concatenate([np.ones(len(pts)), second.weights(condition1)]))
    sol = solver.solve()
    assert sol.polished and sol.ok, sol.report()
    return sol


@pytest.mark.parametrize("condition1", ["gamma3", "sigma2"])
def test_interacting_conic_and_compliance_pairs_are_the_limit_of_dense_nodal_sampling(condition1):
    """A conic Signorini pair (top on mid) pressing through the middle block onto a compliance pair (mid on
    bottom, nodal law): sampling pair 0's condition at 3, 12, 48 points per merged segment relaxes the cone from
    outside (energies below the conic one) and tends to it; the fields converge to the conic answer, and the
    compliance pair carries its law at its nodes."""
    scene = _interacting(law1=cc.NormalCompliance(stiffness=K), conditions=("gamma3", condition1))
    conic = {m: cc.solve(scene, "gamma3", degree=2, method=m, tol=TOL) for m in ("full", "condensed")}
    assert all(s.ok and s.polished for s in conic.values()), conic["full"].report()
    assert rel(conic["condensed"].u[1], conic["full"].u[1]) < 1e-6                  # measured <= 1.2e-11
    ref = conic["full"]
    gaps, errors = [], []
    for per_segment in (3, 12, 48):
        sampled = _sampled(scene, per_segment, condition1)
        gaps.append(ref.energy - sampled.energy)
        errors.append(max(rel(u, r) for u, r in zip(sampled.u, ref.u)))
        assert gaps[-1] > -1e-9 * abs(ref.energy)
    assert gaps[2] < gaps[1] < gaps[0] and gaps[2] < 1e-4 * abs(ref.energy)
    assert errors[2] < errors[0] and errors[2] < 1e-3              # measured 2.0e-4 (gamma3), 6.9e-5 (sigma2)
    c = ref.contacts[1]                          # the compliance pair: lambda = p(r) at its nodes
    itf = ref.interface.interfaces[1]
    r = itf.evaluation(condition1) @ (c.jump - c.gap)
    lam = itf.evaluation(condition1) @ c.lam
    assert r.max() > 0 and np.abs(lam - K * np.maximum(r, 0)).max() < 1e-6 * lam.max()


def test_a_limit_beyond_every_penetration_is_no_limit():
    """A compliant pair under "gamma3" with a limit 1 m (far beyond any penetration: the cone at g + l never
    binds) next to a conic Signorini pair, sharing the middle block, equals the same pair without a limit
    (nodal rows, finished exactly with the cone's force held) to the interior point's accuracy."""
    law = cc.NormalCompliance(stiffness=K)
    free = cc.solve(_interacting(law1=law), "gamma3", degree=2, tol=TOL)
    far = cc.solve(_interacting(law1=cc.NormalCompliance(stiffness=K, penetration_limit=1.0)), "gamma3", degree=2,
                   tol=TOL)
    assert free.ok and far.ok, far.report()
    assert max(rel(u, r) for u, r in zip(far.u, free.u)) < 1e-6                     # measured <= 2.1e-11
    for c, r in zip(far.contacts, free.contacts):
        assert rel(c.lam, r.lam) < 1e-5                                                # measured <= 9.3e-10
    assert _penetration_rows(free, 1, "gamma3").max() > 0


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_dense_sampling_of_every_conic_pair_shows_no_violation(method):
    """Two conic pairs sharing the middle block, a Signorini one (gap g) and a compliant one with a limit (gap
    g + l, which binds): the returned P2 jump minus the P2 gap, sampled at 200 points per merged segment, stays
    below 0 resp. l to rounding (1e-9 of the largest jump), and reaches it (the contact is real)."""
    law = cc.NormalCompliance(stiffness=K, penetration_limit=LIMIT)
    sol = cc.solve(_interacting(law1=law), "gamma3", degree=2, method=method, tol=TOL)
    assert sol.ok, sol.report()
    t = np.linspace(0, 1, 201)
    for c, itf, bound in zip(sol.contacts, sol.interface.interfaces, (0.0, LIMIT)):
        xv = np.asarray(itf.xv)
        pts = np.unique((xv[:-1, None] + np.diff(xv)[:, None] * t).ravel())
        q = p2_interpolation(xv, pts) @ (c.jump - c.gap)
        scale = np.abs(c.jump).max()
        assert q.max() - bound < 1e-9 * scale          # measured -1.4e-10, -7.9e-10 of scale (never above)
        assert q.max() - bound > -1e-6 * scale
