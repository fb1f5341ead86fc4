"""Normal compliance per contact pair (issue 10 item 1 ``Contact(law=...)``, issue 11 item 4).

References independent of the package's contact code:

* a dense solve of the mixed system (26) built here with numpy for a stack of three elastic bodies,
  one pair under the linear law (m = 1: springs on the set r > 0, trapezoidal weights computed here)
  and one under Signorini (multipliers on the active set), with active-set steps on both row types;
* a nu = 0 block clamped at its top, pressed by an interference onto a rigid plane through a
  compliance law: the block and the law are springs in series, lambda = E (delta - r) / H and
  lambda = k r^m, a scalar equation solved here by bisection.
"""

import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

import cvxcontact as cc
from cvxcontact.io.scenefile import SceneFileError, scene_from_data

from conftest import rel
from reference_problems import assert_complementary, merged_rows, next_active, per_body, sign_scales, stiffness

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

STEEL = cc.materials.isotropic(E=200e9, nu=0.3)
ALU = cc.materials.isotropic(E=70e9, nu=0.33)
K1 = 1e12          # Pa/m, the compliance of the upper pair of the stack
GAPS = (lambda s: -1e-4 + 2e-3 * (s - 0.5) ** 2,      # m: a curved interference (the edges stay open)
        lambda s: 2e-5 + 0.0 * s)                      # an initial gap


def stack(law_top=None, law_bottom=None):
    """Three elastic bodies: a punch on a plate (pair 0) that rests on a base (pair 1)."""
    top = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(0.3, 0.5), nx=4, ny=2), STEEL, clamped="top", contact="bottom",
                  body_force=(0.0, -5e8), name="top")
    mid = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.3), nx=6, ny=2), ALU, clamped="left", contact="top",
                  name="middle")
    bot = cc.Body(cc.rectangle(x=(0.1, 0.9), y=(-0.3, 0.0), nx=5, ny=2), STEEL, clamped="bottom", contact="top",
                  name="bottom")
    return cc.Scene(top, mid, bot, contacts=[
        cc.Contact(top, "bottom", mid, "top", gap=GAPS[0], law=law_top),
        cc.Contact(mid, "bottom", bot, "top", gap=GAPS[1], law=law_bottom)])


def dense_mixed(bodies, k, m=1):
    """The stack's (26) in SI, dense: pair 0 under lambda = k r_+^m (nodal, trapezoidal weights), pair 1
    under Signorini. Active-set steps on the Signorini rows (y > 0 / slack > 0), each solving the
    equilibrium with the springs by Newton's method (semismooth for m = 1: p' = k on r > 0, 0 else).
    Returns per-body displacements, pair 0's (x, lambda) and pair 1's (x, nodal force E^T y)."""
    systems, off, K, f = stiffness(bodies)
    n = off[-1]
    xc, Gc, _ = merged_rows(bodies, systems, off, 0, "bottom", 1, "top")
    xs, Gs, _ = merged_rows(bodies, systems, off, 1, "bottom", 2, "top")
    gc, gs = GAPS[0](xc), GAPS[1](xs)
    w = _lumped(xc)
    c = np.abs(K).max()
    on_s, u, ys = np.ones(len(xs), bool), np.zeros(n), np.zeros(0)
    for _ in range(60):
        na = int(on_s.sum())
        ys = np.zeros(na)
        for _ in range(100):                               # Newton on [u; y_S] for this Signorini set
            r = Gc @ u - gc
            res = np.concatenate([K @ u + Gc.T @ (w * k * np.maximum(r, 0.0) ** m) + Gs[on_s].T @ ys - f,
                                  Gs[on_s] @ u - gs[on_s]])
            tangent = K + Gc.T @ np.diag(w * k * m * np.where(r > 0, np.maximum(r, 0.0) ** (m - 1), 0.0)) @ Gc
            A = np.block([[tangent / c, Gs[on_s].T], [Gs[on_s], np.zeros((na, na))]])
            step = np.linalg.solve(A, -np.concatenate([res[:n] / c, res[n:]]))
            u, ys = u + step[:n], ys + step[n:] * c
            if np.abs(step[:n]).max() <= 1e-14 * np.abs(u).max():
                break
        else:
            raise AssertionError("the reference Newton steps did not settle")
        y = np.zeros(len(xs))
        y[on_s] = ys
        slack, scales = Gs @ u - gs, sign_scales(y, gs, Gs @ u)
        new_s = next_active(on_s, y, slack, scales)
        if np.array_equal(new_s, on_s):
            break
        on_s = new_s
    else:
        raise AssertionError("the reference active-set steps did not settle")
    assert_complementary(y, slack, scales)
    return per_body(systems, bodies, off, u), (xc, k * np.maximum(Gc @ u - gc, 0.0) ** m), (xs, y)


@pytest.fixture(scope="module")
def reference():
    return dense_mixed(stack().bodies, K1)


def _check_against(sol, reference):
    us, (xc, lam), (xs, y) = reference
    assert sol.ok, sol.report()
    for k in range(3):
        assert rel(sol.u[k], us[k]) < 1e-8
    c0, c1 = sol.contacts
    assert np.abs(c0.x - xc).max() < 1e-12 and np.abs(c1.x - xs).max() < 1e-12
    assert rel(c0.lam, lam) < 1e-8                       # lambda = p(r) on the compliance pair
    assert rel(c0.force, lam * _lumped(xc)) < 1e-8
    assert rel(c1.force, y) < 1e-8                        # the Signorini multiplier's nodal force


def _lumped(x):
    h = np.diff(x)
    return np.concatenate([h / 2, [0.0]]) + np.concatenate([[0.0], h / 2])


@pytest.mark.parametrize("method", ["condensed", "full"])
def test_compliance_pair_and_signorini_pair_against_a_dense_solve(reference, method):
    law = cc.NormalCompliance(stiffness=K1)
    sol = cc.solve(stack(law_top=law), method=method)
    _check_against(sol, reference)
    assert sol.polished and sol.method == method
    c0, c1 = sol.contacts
    assert c0.law == law and c1.law == cc.Signorini()
    _, (_, lam), (_, y) = reference
    assert 0 < (lam > 0).sum() < len(lam) and 0 < (y > 0).sum() < len(y)   # both contact sets matter
    assert set(sol.residuals()) == {"equilibrium", "law", "feasibility", "complementarity", "cone"}
    res = sol.residuals()
    assert max(res["equilibrium"], res["law"], res["feasibility"], res["cone"]) < 1e-10
    assert res["complementarity"] < 1e-6           # a square root (docs/checks.md): 4e-8 to 6e-8 measured
    assert c1.penetration.sum() == 0 and c0.penetration.any()              # only the springs penetrate


def test_quadratic_compliance_pair_and_signorini_pair_against_a_dense_solve():
    """m = 2 on the top pair (Newton in the reference too), Signorini below: the nonlinear rows and the
    LCP rows solved together by the finish."""
    k2 = 1e17
    reference = dense_mixed(stack().bodies, k2, m=2)
    _, (_, lam), _ = reference
    assert 0 < (lam > 0).sum() < len(lam)
    for method in ("condensed", "full"):
        sol = cc.solve(stack(law_top=cc.NormalCompliance(stiffness=k2, exponent=2)), method=method)
        _check_against(sol, reference)
        assert sol.polished and sol.info.finish == "semismooth Newton"


def test_linear_lcp_finish_agrees_with_the_newton_finish():
    """The two exact finishes of mixed rows (formulation.md §10) on the stack's interface compliance W
    (scaled): the Newton / active-set steps and the LCP with W + diag(1 / (w k)) give the same forces,
    for a spring stiffness comparable to the bodies' and a slack with open and pressed rows."""
    from cvxcontact.backends.finish import solve_compliance, solve_linear_compliance
    from cvxcontact.contact.laws import RowLaws

    solver = cc.ContactSolver(stack(law_top=cc.NormalCompliance(stiffness=K1)))
    solver.solve()
    W, w = solver.cache.condensation.W, solver.problem.weights
    counts = solver.problem.rows.counts
    k = 1.0 / (w[:counts[0]].mean() * np.diag(W)[:counts[0]].mean())
    rows = RowLaws([cc.NormalCompliance(stiffness=k), cc.Signorini()], counts)
    d = np.linspace(-0.5, 1.0, len(W))
    a = solve_compliance(W, d, w, rows)
    b = solve_linear_compliance(W, d, w, rows)
    assert a is not None and b is not None
    assert rel(a[0], b[0]) < 1e-9 and (a[0] > 0).any() and (a[0] == 0).any()
    assert np.array_equal(a[2], b[2])                      # the same Signorini rows at their limit
    r = d - W @ a[0]                                       # the laws hold on the answer
    on = rows.rows
    assert np.abs(a[0][on] - w[on] * k * np.maximum(r[on], 0)).max() < 1e-9 * a[0].max()
    assert r[~on].max() < 1e-12 and np.abs(a[0][~on] * r[~on]).max() < 1e-12 * a[0].max()


def test_law_given_to_solve_applies_to_pairs_without_their_own(reference):
    """solve(law=NC) on a scene whose top pair has no law and whose bottom pair is Signorini equals the
    mixed reference; with both pairs unset, both take the solve's law (= both set explicitly)."""
    law = cc.NormalCompliance(stiffness=K1)
    sol = cc.solve(stack(law_bottom=cc.Signorini()), law=law)
    _check_against(sol, reference)
    assert sol.law == law and sol.contacts[1].law == cc.Signorini()
    both = cc.solve(stack(), law=law)
    explicit = cc.solve(stack(law_top=law, law_bottom=law))
    assert both.ok and [c.law for c in both.contacts] == [law, law]
    for k in range(3):
        assert rel(both.u[k], explicit.u[k]) < 1e-10
    assert rel(both.u[0], sol.u[0]) > 1e-3              # the bottom law changed the answer


def test_per_pair_law_overrides_the_solve_law(reference):
    """The top pair's own law wins over the (stiffer) law given to solve; the Signorini pair stays one."""
    own = cc.NormalCompliance(stiffness=K1)
    sol = cc.solve(stack(law_top=own, law_bottom=cc.Signorini()), law=cc.NormalCompliance(stiffness=1e15))
    _check_against(sol, reference)
    assert sol.contacts[0].law == own


def test_model_takes_per_pair_laws(reference):
    model = cc.Model(stack(law_top=cc.NormalCompliance(stiffness=K1)))
    sol = model.solve()
    assert sol.polished
    _check_against(sol, reference)


def test_resolve_of_a_mixed_scene_warm_starts():
    law = cc.NormalCompliance(stiffness=K1)
    solver = cc.ContactSolver(stack(law_top=law))
    first = solver.solve()
    again = solver.solve(stack(law_top=law))
    assert again.path == cc.Route.WARM_START and again.ok
    assert rel(again.u[1], first.u[1]) < 1e-10
    with pytest.raises(cc.SceneError, match="contact pairs"):
        solver.solve(stack(law_top=cc.NormalCompliance(stiffness=2 * K1)))      # a law is not a load


# ---- against a rigid plane: springs in series -------------------------------------------------------

E0, H0, DELTA = 70e9, 0.4, 1e-4


def on_plane(law=None):
    """A nu = 0 block [0, 1] x [0, H0], clamped at its top, its bottom DELTA inside a rigid plane."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, H0), nx=5, ny=3), cc.materials.isotropic(E=E0, nu=0.0),
                    clamped="top", contact="bottom", name="block")
    plane = cc.Rigid.plane((0.0, DELTA), (0.0, 1.0))
    return cc.Scene(block, contacts=[cc.Contact(block, "bottom", plane, law=law)])


@pytest.mark.parametrize("method", ["condensed", "full"])
@pytest.mark.parametrize("k,m", [(1e12, 1), (1e17, 2)])
def test_compliance_against_a_rigid_plane_closed_form(method, k, m):
    r = brentq(lambda r: r + H0 / E0 * k * r ** m - DELTA, 0.0, DELTA, xtol=1e-22, rtol=1e-15)
    lam = E0 * (DELTA - r) / H0
    assert 0.1 < r / DELTA < 0.9                          # the law and the block share the approach
    sol = cc.solve(on_plane(cc.NormalCompliance(stiffness=k, exponent=m)), method=method)
    assert sol.ok and sol.polished, sol.report()
    c = sol.contact
    assert rel(c.lam, np.full(len(c.x), lam)) < 1e-10
    assert rel(c.jump - c.gap, np.full(len(c.x), r)) < 1e-9
    y = sol.scene.bodies[0].mesh.points[:, 1]
    assert np.abs(sol.u[0][:, 1] - (DELTA - r) * (1 - y / H0)).max() < 1e-10 * DELTA
    assert np.abs(sol.u[0][:, 0]).max() < 1e-10 * DELTA
    assert abs(c.force.sum() / lam - 1.0) < 1e-10
    assert set(sol.residuals()) == {"equilibrium", "law"}


def test_rigid_plane_compliance_limit_and_signorini_limit():
    """With a penetration limit below the spring's penetration the limit holds and the pressure is the
    block's E (delta - l) / H; the Signorini law gives E delta / H."""
    ell = 1e-5
    sol = cc.solve(on_plane(), law=cc.NormalCompliance(stiffness=1e12, penetration_limit=ell))
    assert sol.ok and rel(sol.contact.lam, np.full(len(sol.contact.x), E0 * (DELTA - ell) / H0)) < 1e-10
    sig = cc.solve(on_plane())
    assert sig.ok and rel(sig.contact.lam, np.full(len(sig.contact.x), E0 * DELTA / H0)) < 1e-10


# ---- scene files and typed errors -------------------------------------------------------------------

def _file(law):
    body = lambda name, y, clamp: {"name": name, "material": {"E": E0, "nu": 0.0}, "clamped": [clamp],  # noqa: E731
                                   "mesh": {"rectangle": {"x": [0.0, 1.0], "y": y, "nx": 4, "ny": 2}}}
    contact = {"a": "block", "part_a": "bottom", "b": "floor"}
    if law is not None:
        contact["law"] = law
    return {"body": [body("block", [0.0, H0], "top")],
            "obstacle": [{"name": "floor", "plane": {"point": [0.0, DELTA], "normal": [0.0, 1.0]}}],
            "contact": [contact]}


def test_scene_file_contact_law(tmp_path):
    spec = scene_from_data(_file({"normal_compliance": {"stiffness": 1e12}}), tmp_path / "s.toml")
    assert spec.scene.contacts[0].law == cc.NormalCompliance(stiffness=1e12)
    sol = spec.solve()
    r = DELTA / (1 + H0 / E0 * 1e12)
    assert sol.ok and rel(sol.contact.lam, np.full(len(sol.contact.x), 1e12 * r)) < 1e-10
    assert scene_from_data(_file(None), tmp_path / "s.toml").scene.contacts[0].law is None
    with pytest.raises(SceneFileError, match=r"contact\[0\]: law: expected"):
        scene_from_data(_file("coulomb"), tmp_path / "s.toml")
    with pytest.raises(SceneFileError, match=r"contact\[0\]: law.normal_compliance: .*stiffness"):
        scene_from_data(_file({"normal_compliance": {"stiffness": -1.0}}), tmp_path / "s.toml")


@pytest.mark.parametrize("law", ["compliance", 1e12, cc.NormalCompliance])
def test_bad_pair_law_is_a_scene_error(law):
    with pytest.raises(cc.SceneError, match="law must be"):
        stack(law_top=law)


def test_compliance_with_a_body_held_by_contact_only_is_solved():
    """A body that only the contact holds has a singular stiffness: the compliance is solved on the full
    model and finished on the sparse mixed system (was a typed refusal before issue 11's held-body item);
    uniform pressure p under a rigid plane: lambda = p, penetration p / k."""
    layer = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.2), nx=4, ny=2), ALU, roller=["left", "right"],
                    contact="bottom", traction={"top": (0.0, -1e6)}, name="layer")
    scene = cc.Scene(layer, contacts=[cc.Contact(layer, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)),
                                                 law=cc.NormalCompliance(stiffness=1e12))])
    assert layer.held_by_contact
    sol = cc.solve(scene)
    assert sol.ok and sol.polished and sol.method == "full"
    assert np.abs(sol.contact.lam - 1e6).max() <= 1e-9 * 1e6
    assert np.abs(sol.contact.jump - sol.contact.gap - 1e6 / 1e12).max() <= 1e-9 * 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        assert cc.solve(cc.Scene(layer, contacts=[cc.Contact(layer, "bottom",
                                                             cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)))])).ok


def test_compliance_pair_with_a_single_constrained_node_is_refused_typed():
    """sigma2 on a punch that covers one node of its substrate: the law's integral has no length there."""
    punch = cc.Body(cc.rectangle(x=(0.3, 0.5), y=(0.0, 0.2), nx=1, ny=1), STEEL, clamped="top", contact="bottom")
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=2, ny=2), STEEL, clamped="bottom", contact="top")
    scene = cc.Scene(punch, base, contacts=[cc.Contact(punch, "bottom", base, "top", gap=-1e-5, condition="sigma2",
                                                       law=cc.NormalCompliance(stiffness=1e12))])
    for make in (cc.solve, cc.Model):
        with pytest.raises(cc.SceneError, match="at least two constrained nodes"):
            make(scene)
