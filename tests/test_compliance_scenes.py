"""Normal compliance with force-controlled obstacles and with bodies held by the contact only (issue 11
item 4; docs/formulation.md §10-§12): the full model, finished by Newton steps on the sparse mixed system
with the law's rows (``backends.finish.solve_sparse_compliance``).

Cross-checks, none taken from the code under test:

- a block pressed by a force-controlled rigid plane through a law p(r) = k r^m: uniaxial strain, the
  block and the law are springs in series (closed form of the plane's translation, the penetration, the
  pressure); k -> inf tends to the Signorini answer at rate 1/k;
- an off-centre circle indenter, force controlled with the force the fixed indenter reads back: the same
  answer as the fixed one (which the condensed backend and its own finish solve);
- a layer held by the contact only (rollers on its sides) pressed through the law onto a clamped block:
  uniform stress, the layer shifted by the law's penetration r = (p / k)^(1/m) (P1 and P2), and at a
  penetration limit l < r the limit holds with lambda = p.
"""

import numpy as np
import pytest
from compliance_scenes import ALU, H1, H2, H, M, P, W, held_layer, pressed_block

import cvxcontact as cc

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("m", [1.0, 2.0])
def test_force_controlled_plane_through_compliance_closed_form(degree, m):
    """Springs in series: the plane moves by t = -(p H / M + r), r = (p / k)^(1/m) the law's penetration
    (for m = 1: the compliance H / (M W) of the block plus 1 / (k W) of the law, times F = p W)."""
    k = 1e12 if m == 1 else 1e12 / 1e-4        # Pa/m^m: r = 2e-5 m (m = 1), 4.5e-5 m (m = 2)
    law = cc.NormalCompliance(stiffness=k, exponent=m)
    solver = cc.ContactSolver(pressed_block(P * W, law), degree=degree)
    sol = solver.solve()
    r = (P / k) ** (1.0 / m)
    t = sol.obstacles[0].translation
    assert sol.ok and sol.polished and sol.method == "full"
    assert t[0] == 0.0 and abs(t[1] + P * H / M + r) <= 1e-12 * (P * H / M + r)
    top = np.isclose(sol.points[0][:, 1], H)
    assert np.abs(sol.u[0][top, 1] - t[1] - r).max() <= 1e-10 * r            # penetration from u and t
    y = sol.points[0][:, 1]
    assert np.abs(sol.u[0][:, 1] + P * y / M).max() <= 1e-9 * P * H / M       # uniaxial strain in the block
    assert rel(sol.contact.pressure, np.full(len(sol.contact.x), P)) < 1e-9
    assert rel(sol.contact.lam, np.full(len(sol.contact.x), P)) < 1e-9
    assert abs(sol.contact.force.sum() - P * W) <= 1e-10 * P * W              # the plane's force balance
    assert sol.residuals()["obstacle balance"] < 1e-10
    assert sol.residuals()["law"] < 1e-10 and sol.residuals()["equilibrium"] < 1e-12
    if m == 1:      # a re-solve with twice the force (a load): the linear law, in full contact, is linear
        twice = solver.solve(pressed_block(2 * P * W, law))
        assert twice.ok and abs(twice.obstacles[0].translation[1] - 2 * t[1]) <= 1e-9 * abs(t[1])


def test_force_controlled_compliance_tends_to_signorini_at_rate_one_over_k():
    """k -> inf: the translation tends to the Signorini force-control answer -p H / M, error p / k."""
    sig = cc.solve(pressed_block(P * W))
    t0 = sig.obstacles[0].translation[1]
    assert sig.ok and abs(t0 + P * H / M) <= 1e-9 * P * H / M
    ks = np.array([1e12, 1e13, 1e14, 1e15])
    err = np.array([abs(cc.solve(pressed_block(P * W), law=cc.NormalCompliance(stiffness=k)).obstacles[0]
                        .translation[1] - t0) for k in ks])
    rates = -np.diff(np.log(err)) / np.diff(np.log(ks))
    assert np.all(np.abs(rates - 1.0) < 1e-3), rates
    assert rel(err, P / ks) < 1e-6


def indenter(center_y, law, **kw):
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", contact="top",
                    name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, center_y), 0.6, **kw),
                                                law=law)])


@pytest.mark.parametrize("m,limit", [(1.0, None), (1.5, None), (1.0, 1e-4)])
def test_force_controlled_indenter_through_compliance_equals_the_fixed_one(m, limit):
    """An off-centre circle pressed 3 mm through a law: the fixed indenter (condensed backend, interface
    finish) gives the force F; the force-controlled indenter under F (full model, sparse finish) must come
    to the same place: translation (0, -3 mm), same u and lambda, partial contact. With a penetration
    limit 1e-4 m (the largest penetration is 2.1e-4 m without it): a row held at the limit, a row below it."""
    R, depth = 0.6, 3e-3
    law = cc.NormalCompliance(stiffness=1e13 if m == 1 else 1e13 * 3e-3 ** -0.5, exponent=m,
                              penetration_limit=limit)
    # posed along the block's normal (distance="ray"): there the rows of the circle moved down by t equal the
    # force-controlled rows g - c . t exactly; the closest-point rows (the default) are their linearisation in t
    fixed = cc.solve(indenter(0.5 + R - depth, law, distance="ray"))
    if limit is not None:
        c = fixed.contact
        assert 1 <= int(np.sum(c.jump - c.gap > (1 - 1e-9) * limit)) < int(c.active.sum())
    F = fixed.obstacles[0].force
    assert fixed.ok and fixed.method == "condensed" and 2 <= int(fixed.contact.active.sum()) < len(fixed.contact.x)
    forced = cc.solve(indenter(0.5 + R, law, force=F, distance="ray"))
    assert forced.ok and forced.polished and forced.method == "full"
    assert np.abs(forced.obstacles[0].translation - [0.0, -depth]).max() < 1e-8 * depth
    assert rel(forced.u[0], fixed.u[0]) < 1e-7
    assert rel(forced.contact.lam, fixed.contact.lam) < 1e-7
    assert rel(forced.obstacles[0].force, F) < 1e-10 and forced.residuals()["obstacle balance"] < 1e-10


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("m,k", [(1.0, 1e12), (1.0, 1e14), (2.0, 1e16)])
def test_layer_held_by_the_contact_through_compliance_closed_form(degree, m, k):
    """Uniform stress sigma_yy = -p in both bodies; the foundation u_y = -p (y + H1) / M; the layer the same
    shifted down by the law's penetration r = (p / k)^(1/m): u_y = -p (y + H1) / M - r."""
    scene = held_layer(cc.NormalCompliance(stiffness=k, exponent=m))
    assert scene.bodies[0].held_by_contact == ("translation y",)
    sol = cc.solve(scene, degree=degree)
    r = (P / k) ** (1.0 / m)
    q1, q2 = sol.points
    scale = P * H1 / M + r
    assert sol.ok and sol.polished and sol.method == "full"
    assert np.abs(sol.u[1][:, 1] + P * (q2[:, 1] + H1) / M).max() <= 1e-11 * scale
    assert np.abs(sol.u[0][:, 1] + P * (q1[:, 1] + H1) / M + r).max() <= 1e-11 * scale
    assert max(np.abs(sol.u[0][:, 0]).max(), np.abs(sol.u[1][:, 0]).max()) <= 1e-11 * scale
    assert rel(sol.contact.lam, np.full(len(sol.contact.x), P)) < 1e-9
    assert abs(sol.contact.force.sum() - P * 1.0) <= 1e-9 * P                  # the layer's balance
    assert sol.residuals()["equilibrium"] < 1e-12 and sol.residuals()["law"] < 1e-10


@pytest.mark.parametrize("degree,nx,condition", [(1, 3, "gamma3"), (1, 4, "sigma2"), (2, 4, "sigma1")])
def test_layer_held_at_the_penetration_limit(degree, nx, condition):
    """A limit l below the law's penetration p / k: the layer stops at r = l, lambda = p (the limit's
    reaction carries p - k l). P2: nodal limit rows ("sigma1" on matching meshes; the conic limit under
    "gamma3" is refused with a held body, below)."""
    k, ell = 1e12, 5e-6                        # p / k = 2e-5 m > l
    sol = cc.solve(held_layer(cc.NormalCompliance(stiffness=k, penetration_limit=ell), nx=nx), degree=degree,
                   condition=condition)
    q1 = sol.points[0]
    assert sol.ok and sol.polished
    assert np.abs(sol.u[0][:, 1] + P * (q1[:, 1] + H1) / M + ell).max() <= 1e-9 * (P * H1 / M)
    assert rel(sol.contact.lam, np.full(len(sol.contact.x), P)) < 1e-9
    assert sol.residuals()["complementarity"] < 1e-6 and sol.residuals()["feasibility"] < 1e-9


# P2 conic limit with a held body or force control (formerly refused): solved, against these scenes' closed
# forms, in tests/test_refusals.py::test_p2_conic_limit_with_a_held_body_or_force_control


@pytest.mark.parametrize("degree", [1, 2])
def test_piezoelectric_layer_held_through_compliance_closed_form(degree):
    """The held layer in PZT-5A, grounded at its bottom, an open-circuit floating electrode on top, on the
    law p = k r: strain -p / (c33 + e33^2/eps33) in the layer, the potential linear, the layer shifted down
    by r = p / k from the foundation's top -p H1 / M (the Gauss rows in the sparse finish)."""
    pzt, k = cc.materials.PZT5A, 1e12
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=4, ny=3)
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=3, ny=2)
    layer = cc.Body(top, pzt, roller=["left", "right"], contact="bottom", traction={"top": (0.0, -P)},
                    grounded=["bottom"], floating={"top": 0.0}, name="layer")
    base = cc.Body(low, ALU, clamped=["bottom"], roller=["left", "right"], contact="top", name="base")
    sol = cc.solve(cc.Scene(layer, base, contacts=[cc.Contact(layer, "bottom", base, "top",
                                                              law=cc.NormalCompliance(stiffness=k))]), degree=degree)
    c33, e33, k33 = pzt.c[1, 1], pzt.e[1, 1], pzt.kappa[1, 1]
    eps = -P / (c33 + e33 ** 2 / k33)
    y = sol.points[0][:, 1]
    assert sol.ok and sol.polished and sol.residuals()["equilibrium"] < 1e-12
    assert np.abs(sol.u[0][:, 1] - (-P * H1 / M - P / k + eps * y)).max() <= 1e-11 * (P * H1 / M)
    assert np.abs(sol.phi[0] - e33 * eps / k33 * y).max() <= 1e-10 * abs(e33 * eps / k33) * H2


@pytest.mark.parametrize("degree", [1, 2])
def test_compliance_limit_with_a_clamped_node_on_the_contact_line(degree):
    """A body clamped on its sides, pressed onto a rigid floor through a stiff linear law with a penetration
    limit: its clamped corners sit on the floor (g = 0) and no unknown moves their rows, whose W row is zero.
    The interface finish inverted W and declined ('did not settle', complementarity 1e-5 from the interior
    point); it now keeps those rows at r = d (force w p(d) = 0, no limit reaction). Checked: finished and ok;
    the limit binds (r = l on some rows, to rounding); with a limit 100 times larger, which does not bind, the
    answer equals the no-limit one (solved by the separate linear-law LCP) to rounding."""
    mat = cc.materials.isotropic(E=70e9, nu=0.33)

    def scene(lim):
        b = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.3), nx=6, ny=3), mat, clamped=["left", "right"],
                    contact="bottom", body_force=(0, -1e8))
        law = cc.NormalCompliance(stiffness=1e16, exponent=1, penetration_limit=lim)
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane(point=(0, 0), normal=(0, 1)), law=law)])

    free = cc.solve(scene(None), "sigma1", degree=degree, method="full")
    pen = float((free.contacts[0].jump - free.contacts[0].gap).max())       # the deepest penetration r (m)
    assert pen > 0
    limit = 0.5 * pen
    sol = cc.solve(scene(limit), "sigma1", degree=degree, method="full")
    assert sol.ok and sol.polished
    r = sol.contacts[0].jump - sol.contacts[0].gap
    assert abs(r.max() - limit) < 1e-9 * limit
    loose = cc.solve(scene(100 * pen), "sigma1", degree=degree, method="full")
    assert loose.ok and loose.polished
    assert np.abs(loose.u[0] - free.u[0]).max() < 1e-9 * np.abs(free.u[0]).max()
