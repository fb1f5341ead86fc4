"""Normal compliance with P2 in cc.Model, and the conic penetration limit under "gamma3" (issue 11, item 4).

References, independent of the code under test: the springs-in-series closed form of two nu = 0 blocks
pressed by an interference (tests/reference_problems.closed_form, with and without a penetration limit),
cc.solve(degree=2) for the same law (cc.Model poses its own program), the P2 Signorini "everywhere" problem
with the gap shifted by the limit (the limit of the law as k -> 0), and a dense sampling of each body's own P2
trace (tests/test_p2._sample_jump: 4001 points, independent of the merged mesh and of the Bernstein form).
"""

import numpy as np
import pytest

import cvxcontact as cc

from conftest import p2_trace_jump, rel, two_blocks
from reference_problems import closed_form, field_error, pressed

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

XS = np.linspace(0.0, 1.0, 4001)


@pytest.fixture(scope="module")
def scene_pressed():
    return pressed()


@pytest.fixture(scope="module")
def small():
    return two_blocks(n1=(8, 4), n2=(5, 3))


def _uniform(sol, value):
    return np.full(len(sol.contact.x), value)


# ------------------------------------------------------------------ (a) cc.Model(degree=2) with compliance

@pytest.mark.parametrize("m,k", [(1, 1e11), (2, 1e16)])
def test_model_p2_compliance_closed_form(scene_pressed, m, k):
    """cc.Model(degree=2) under gamma3 on non-matching meshes (7 : 5): the law at every merged P2 node with
    Simpson weights, finished exactly. Measured: lambda to 1.1e-11 (m = 1) / 1.1e-10 (m = 2), the fields at
    every P2 node to 7e-13 / 1.2e-11 of delta."""
    r, lam = closed_form(k, m)
    law = cc.NormalCompliance(stiffness=k, exponent=m)
    sol = cc.Model(scene_pressed, "gamma3", law=law, degree=2).solve()
    assert sol.ok and sol.polished and sol.degree == 2 and sol.contact.law == law
    assert rel(sol.contact.lam, _uniform(sol, lam)) < 3e-10
    assert rel(sol.contact.jump - sol.contact.gap, _uniform(sol, r)) < 3e-10
    assert field_error(sol, lam) < 1e-10
    assert abs(sol.contact.force.sum() / lam - 1.0) < 1e-10            # lambda times the length of Gamma_3
    assert set(sol.residuals()) == {"equilibrium", "law"} and max(sol.residuals().values()) < 1e-9


@pytest.mark.parametrize("condition", ["gamma3", "sigma1", "sigma2"])
def test_model_p2_compliance_equals_solve(condition):
    """The piezoelectric scene (partial contact), m = 1.5: cc.Model(degree=2) and cc.solve(degree=2) give the
    same fields, potentials and lambda (measured 3e-13 and below)."""
    scene = two_blocks(n1=(6, 3), n2=(4, 2))
    law = cc.NormalCompliance(stiffness=1e13, exponent=1.5)
    a = cc.Model(scene, condition, law=law, degree=2).solve()
    b = cc.solve(scene, condition, law=law, degree=2)
    assert a.ok and a.polished and a.contact.active.any() and not a.contact.active.all()
    assert max(a.residuals().values()) < 1e-9
    assert rel(a.u[0], b.u[0]) < 1e-9 and rel(a.u[1], b.u[1]) < 1e-9 and rel(a.phi[0], b.phi[0]) < 1e-9
    assert rel(a.contact.lam, b.contact.lam) < 1e-9 and rel(a.contact.force, b.contact.force) < 1e-9


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_model_p2_compliance_nodal_limit_equals_solve(condition):
    """A limit under sigma_l is nodal (linear rows): cc.Model and cc.solve agree, the limit binds at some
    row and holds at all of them."""
    scene = two_blocks(n1=(6, 3), n2=(4, 2))
    free = cc.solve(scene, condition, law=cc.NormalCompliance(stiffness=1e13, exponent=1.5), degree=2)
    limit = 0.5 * float((free.contact.jump - free.contact.gap).max())
    law = cc.NormalCompliance(stiffness=1e13, exponent=1.5, penetration_limit=limit)
    a = cc.Model(scene, condition, law=law, degree=2).solve()
    b = cc.solve(scene, condition, law=law, degree=2)
    assert a.ok and a.polished and {"feasibility", "complementarity", "cone"} <= set(a.residuals())
    assert rel(a.u[0], b.u[0]) < 1e-9 and rel(a.contact.lam, b.contact.lam) < 1e-9
    itf = a.interface
    rows = itf.evaluation(condition) @ (a.contact.jump - a.contact.gap)
    assert rows.max() <= limit * (1 + 1e-9) and rows.max() > limit * (1 - 1e-9)


def test_model_p2_compliance_with_a_user_row(small):
    """A user row on top of the P2 law: interior-point answer (no exact finish with user rows), checked with
    the user row's own checks; it binds and changes the answer. Clarabel at the default 1e-10 reaches a user
    complementarity of 1.1e-5 here (P1: 7e-6), so the gap tolerances are tightened (then 2.7e-8)."""
    law = cc.NormalCompliance(stiffness=1e12)
    base = cc.Model(small, "gamma3", law=law, degree=2).solve()
    tight = dict(tol_gap_abs=1e-14, tol_gap_rel=1e-14, tol_ktratio=1e-10, max_iter=400)
    model = cc.Model(small, "gamma3", law=law, degree=2, solver_options=tight)
    tip = int(np.argmax(np.abs(base.u[0][:, 1])))                   # the node of body 1 that moves most
    bound = 0.5 * float(base.u[0][tip, 1])
    model.add(model.u(0)[tip, 1] >= bound if bound < 0 else model.u(0)[tip, 1] <= bound)
    sol = model.solve()
    assert sol.ok and not sol.polished and "user[0] feasibility" in sol.residuals()
    assert abs(sol.u[0][tip, 1] - bound) < 1e-6 * abs(bound)
    assert rel(sol.u[0], base.u[0]) > 1e-3


# ------------------------------------------------------------------ (b) the conic penetration limit

@pytest.mark.parametrize("how", ["full", "condensed", "model"])
@pytest.mark.parametrize("m,k", [(1, 1e11), (2, 1e14)])
def test_p2_conic_limit_closed_form(scene_pressed, how, m, k):
    """gamma3 with a limit at 0.3 of the free penetration: the limit binds on the whole line, r = l and
    lambda = (delta - l) / C (p(l) from the law, the rest from the cone's multiplier, M^-1 B^T beta), finished
    exactly (docs/formulation.md §18)."""
    r, _ = closed_form(k, m)
    rl, lam = closed_form(k, m, limit=0.3 * r)
    assert rl == 0.3 * r
    law = cc.NormalCompliance(stiffness=k, exponent=m, penetration_limit=rl)
    if how == "model":
        sol = cc.Model(scene_pressed, "gamma3", law=law, degree=2).solve()
    else:
        sol = cc.solve(scene_pressed, "gamma3", law=law, degree=2, method=how)
    assert sol.ok and sol.polished and sol.info.finish == "tangency Newton" and sol.degree == 2   # §18
    assert sol.method == ("full" if how == "model" else how)
    assert set(sol.residuals()) == {"equilibrium", "law", "feasibility", "complementarity", "cone"}
    # the exact finish (formulation §18); the interior point alone measured 7.3e-9 .. 2.2e-8, 1.2e-13, 1.6e-12
    assert rel(sol.contact.lam, _uniform(sol, lam)) < 5e-9          # measured 5.8e-11 .. 6.3e-10
    assert rel(sol.contact.jump - sol.contact.gap, _uniform(sol, rl)) < 1e-13          # measured <= 8.5e-16
    assert field_error(sol, lam) < 1e-12                                               # measured <= 2.7e-14
    assert abs(sol.contact.force.sum() / lam - 1.0) < 1e-7                             # measured <= 2.0e-9


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_p2_conic_limit_far_away_is_no_limit(small, method):
    """A limit of 1 m never binds: the answer is the law without a limit (exact finish) to the interior
    point's accuracy (measured u 3e-11, lambda 8e-10), and the cone carries no force."""
    k = 1e12
    free = cc.solve(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=k), method=method)
    sol = cc.solve(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=k, penetration_limit=1.0),
                   method=method)
    assert free.ok and sol.ok and "cone" in sol.residuals()      # complementarity measured 4.8e-9 .. 1.1e-8
    assert rel(sol.u[0], free.u[0]) < 1e-8 and rel(sol.u[1], free.u[1]) < 1e-8      # measured <= 2.8e-11, 6.5e-11
    assert rel(sol.contact.lam, free.contact.lam) < 1e-7                               # measured <= 7.5e-10


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_p2_conic_limit_holds_everywhere(small, method):
    """The limit at half the free penetration: sampled densely along the line (4001 points of each body's
    own P2 trace), [u_nu] - g <= l everywhere to rounding and = l somewhere (measured: max within 3e-12 of
    l); the nodal limit at one body's P2 nodes (sigma1, sigma2) exceeds it between them (by 12 % / 68 %)."""
    k = 1e12
    free = cc.solve(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=k))
    limit = 0.5 * float((free.contact.jump - free.contact.gap).max())
    law = cc.NormalCompliance(stiffness=k, penetration_limit=limit)
    # the conic limit is an interior-point answer: complementarity measured 2.9e-7 .. 1.22e-6 (clarabel 0.10.0 and
    # 0.11.1, with and without oneMKL, 1 or 2 threads), so a tol of 1e-5 (docs/formulation.md §8)
    sol = cc.solve(small, "gamma3", degree=2, law=law, method=method, tol=1e-5)
    assert sol.ok
    excess = (p2_trace_jump(sol, XS) - small.gap(XS, 0 * XS)).max() / limit - 1
    assert -1e-6 < excess < 1e-9                                                       # measured -1.7e-12
    assert (sol.contact.lam > 0).any() and np.isfinite(sol.contact.lam).all()
    for condition in ("sigma1", "sigma2"):
        nodal = cc.solve(small, condition, degree=2, law=law)
        assert nodal.ok
        assert (p2_trace_jump(nodal, XS) - small.gap(XS, 0 * XS)).max() / limit - 1 > 1e-2


def test_p2_conic_limit_tends_to_shifted_signorini(small):
    """As k -> 0 the law's force vanishes and only r <= l remains: the answer tends to the P2 Signorini
    "everywhere" answer with the gap g + l, like k (measured 2.5e-7, 2.5e-6 for k = 1e7, 1e8 Pa/m)."""
    k0 = 1e12
    free = cc.solve(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=k0))
    limit = 0.5 * float((free.contact.jump - free.contact.gap).max())
    ref = cc.solve(cc.Scene(*small.bodies, gap=limit), "gamma3", degree=2, tol=1e-5)   # compl. measured 1.4e-7
    assert ref.ok
    errs = []
    for k in (1e7, 1e8):      # interior points: complementarity measured 3.0e-7 .. 1.81e-6, hence tol=1e-5
        sol = cc.solve(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=k, penetration_limit=limit),
                       method="full", tol=1e-5)
        assert sol.ok
        errs.append(max(rel(a, b) for a, b in zip(sol.u, ref.u)))
    assert errs[0] < 1e-6                          # measured 2.5e-7: the law's force ~ k, not the interior point
    assert 0.8 < np.log10(errs[1] / errs[0]) < 1.2, errs                               # measured 1.00


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_p2_conic_limit_zero_is_p2_signorini(small, method):
    """l = 0: r <= 0 on every segment makes the law's nodal energy vanish, so the problem is P2 Signorini
    "everywhere" (cc.solve without a law, the package's other conic program): measured u 4e-10, lambda 1.6e-7,
    forces 9e-8 (two interior points)."""
    # two interior points, complementarity measured 5.7e-7 (ref), 2.8e-7 .. 6.0e-7 (sol; 1.01e-6 with clarabel 0.9.0)
    ref = cc.solve(small, "gamma3", degree=2, tol=1e-5)
    sol = cc.solve(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=1e12, penetration_limit=0.0),
                   method=method, tol=1e-5)
    assert ref.ok and sol.ok
    assert rel(sol.u[0], ref.u[0]) < 1e-8 and rel(sol.u[1], ref.u[1]) < 1e-8          # measured 4.2e-10, 1.1e-9
    assert rel(sol.contact.lam, ref.contact.lam) < 1e-6 and rel(sol.contact.force, ref.contact.force) < 1e-6
    # (measured lambda 1.5e-7 .. 1.65e-7, forces 8.9e-8 .. 9.5e-8)


def test_model_p2_conic_limit_with_a_user_row(small):
    """cc.Model keeps the conic limit under user terms: a user row that binds, and the limit still holds
    everywhere on the line (4001 samples, measured 1e-14 of l), with the user row's checks."""
    limit = 5e-5
    model = cc.Model(small, "gamma3", degree=2, law=cc.NormalCompliance(stiffness=1e12, penetration_limit=limit),
                     tol=1e-5)      # interior points: complementarity measured 6.1e-7 .. 6.5e-7, user row's <= 4.6e-7
    base = model.solve()
    tip = int(np.argmax(np.abs(base.u[0][:, 1])))
    bound = 0.5 * float(base.u[0][tip, 1])
    model.add(model.u(0)[tip, 1] >= bound if bound < 0 else model.u(0)[tip, 1] <= bound)
    sol = model.solve()
    assert base.ok and sol.ok and {"cone", "user[0] complementarity"} <= set(sol.residuals())
    assert abs(sol.u[0][tip, 1] / bound - 1) < 1e-9                                    # measured <= 3.5e-13
    for s in (base, sol):
        excess = (p2_trace_jump(s, XS) - small.gap(XS, 0 * XS)).max() / limit - 1
        assert -1e-6 < excess < 1e-9                                    # measured -2.8e-13 .. 1.1e-14
