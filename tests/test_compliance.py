"""Normal compliance (issue 11 item 4, P1): closed forms, the Signorini limit, piezoelectric scenes, errors.

The reference for the closed form is independent of the package: two elastic blocks with nu = 0,
clamped at their far ends and pressed together by an interference delta (gap g = -delta), are two
1D springs in series. With H_l the heights and E_l the moduli (plane strain with nu = 0: c22 = E),
the contact pressure is uniform, lambda = (delta - r) / C with C = H1/E1 + H2/E2, and the law
lambda = k r^m gives the scalar equation r + C k r^m = delta, solved here by bisection (brentq).
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.io.scenefile import SceneFileError, scene_from_data

from conftest import rel, two_blocks
from reference_problems import C, DELTA, E1, E2, H1, H2, closed_form, pressed

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

@pytest.fixture(scope="module")
def scene_pressed():
    return pressed()


@pytest.mark.parametrize("method", ["condensed", "full"])
@pytest.mark.parametrize("m,k,limit", [(1, 1e12, None), (2, 1e17, None), (1, 1e12, 4e-6), (2.5, 1e21, None)])
def test_two_blocks_closed_form(scene_pressed, method, m, k, limit):
    r, lam = closed_form(k, m, limit)
    if limit is not None:
        assert closed_form(k, m)[0] > 2 * limit          # the limit is really active
    sol = cc.solve(scene_pressed, law=cc.NormalCompliance(stiffness=k, exponent=m, penetration_limit=limit),
                   method=method)
    assert sol.ok and sol.polished and sol.method == method
    assert rel(sol.contact.lam, np.full(len(sol.contact.x), lam)) < 1e-10
    assert rel(sol.contact.jump - sol.contact.gap, np.full(len(sol.contact.x), r)) < 1e-9
    # the fields: u_y linear in y in each body, u_x = 0
    for k_, (body, top) in enumerate(zip(scene_pressed.bodies, (H1, -H2))):
        y = body.mesh.points[:, 1]
        uy = (lam * H1 / E1) * (1 - y / H1) if k_ == 0 else -(lam * H2 / E2) * (1 + y / H2)
        assert np.abs(sol.u[k_][:, 1] - uy).max() < 1e-10 * DELTA
        assert np.abs(sol.u[k_][:, 0]).max() < 1e-10 * DELTA
    # total force = lambda times the length of Gamma_3
    assert abs(sol.contact.force.sum() / lam - 1.0) < 1e-10
    keys = {"equilibrium", "law"} | ({"feasibility", "complementarity", "cone"} if limit else set())
    assert set(sol.residuals()) == keys
    assert sol.law == cc.NormalCompliance(stiffness=k, exponent=m, penetration_limit=limit)


def test_energy_includes_the_compliance_term(scene_pressed):
    """Pi(u) + sum w Phi(r) at the solution equals its closed form: the strain energy of the springs
    (lambda^2 C / 2 per unit length) plus k r^(m+1)/(m+1) over the unit length of Gamma_3."""
    k, m = 1e12, 1
    r, lam = closed_form(k, m)
    sol = cc.solve(scene_pressed, law=cc.NormalCompliance(stiffness=k, exponent=m))
    assert abs(sol.energy / (0.5 * lam ** 2 * C + k * r ** (m + 1) / (m + 1)) - 1) < 1e-9


def test_tends_to_signorini_at_rate_one_over_k():
    """Quickstart-like piezoelectric scene (partial contact): ||u_k - u_S|| = O(1/k) for m = 1 and
    O(k^(-1/2)) for m = 2, measured between the last two stiffnesses (the asymptotic range: the
    nodes with a small Signorini force enter it last; measured 0.54, 0.89, 0.99 per decade for m = 1
    from k = 1e14 on)."""
    scene = two_blocks(n1=(10, 5), n2=(7, 4))
    ref = cc.solve(scene)
    umax = max(np.abs(u).max() for u in ref.u)
    rates = {}
    for m, ks in ((1, (1e15, 1e16, 1e17)), (2, (1e21, 1e23, 1e25))):
        errs = []
        for k in ks:
            sol = cc.solve(scene, law=cc.NormalCompliance(stiffness=k, exponent=m))
            assert sol.ok
            errs.append(max(np.abs(a - b).max() for a, b in zip(sol.u, ref.u)) / umax)
        assert errs[0] > errs[1] > errs[2]
        rates[m] = np.log(errs[1] / errs[2]) / np.log(ks[2] / ks[1])
    assert 0.95 < rates[1] < 1.05, rates
    assert 0.46 < rates[2] < 0.54, rates


@pytest.mark.parametrize("condition", ["gamma3", "sigma1", "sigma2"])
def test_piezoelectric_scene_passes_its_checks(condition):
    """The quickstart-like scene (PZT-5A on aluminium): both backends and cc.Model agree and pass their
    checks; with a user row, cc.Model's interior-point answer agrees to its accuracy."""
    scene = two_blocks(n1=(8, 4), n2=(6, 3))
    law = cc.NormalCompliance(stiffness=1e13, exponent=1.5)
    a = cc.solve(scene, condition, law=law, method="condensed")
    b = cc.solve(scene, condition, law=law, method="full")
    assert a.ok and b.ok and a.phi[0] is not None
    assert max(a.residuals().values()) < 1e-9
    assert rel(a.u[0], b.u[0]) < 1e-9 and rel(a.phi[0], b.phi[0]) < 1e-9 and rel(a.contact.lam, b.contact.lam) < 1e-8
    model = cc.Model(scene, condition, law=law)
    c = model.solve()                                      # no user terms: exact finish
    assert c.ok and c.polished and rel(c.u[0], a.u[0]) < 1e-9 and rel(c.contact.lam, a.contact.lam) < 1e-8
    model.add(model.u(0)[0, 0] <= 1.0)                     # a user row: the interior-point answer, checked
    with warnings.catch_warnings():      # (ok at tol 1e-6 is the interior point's stopping point: asserted below)
        warnings.simplefilter("ignore", cc.ResidualWarning)
        c = model.solve()
    # measured: u 3.8e-10 .. 8.0e-10; equilibrium 1.2e-10 .. 2.1e-10; the user row's complementarity 4.1e-7 .. 6.0e-7
    assert not c.polished and rel(c.u[0], a.u[0]) < 1e-4 and c.residuals()["equilibrium"] < 1e-4
    assert max(c.residuals().values()) < 1e-5
    # lambda = p(r) at the constrained nodes, read back from the returned displacements
    pen = (a.contact.jump - a.contact.gap)[a.contact.constrained]
    if condition == "gamma3":
        assert rel(a.contact.lam, law.pressure(pen)) < 1e-12


def test_polish_false_is_checked_honestly():
    scene = two_blocks(n1=(8, 4), n2=(6, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, law=cc.NormalCompliance(stiffness=1e13), polish=False, method="condensed")
    assert not sol.polished and sol.residuals()["law"] > 1e-12      # back-substitution moved u


def test_resolve_warm_starts_from_the_previous_penetration():
    scene = two_blocks(n1=(8, 4), n2=(6, 3))
    law = cc.NormalCompliance(stiffness=1e13)
    solver = cc.ContactSolver(scene, law=law)
    solver.solve()
    other = two_blocks(n1=(8, 4), n2=(6, 3), scale=1.3)
    warm = solver.solve(other)
    fresh = cc.solve(other, law=law)
    assert warm.path == cc.Route.WARM_START and warm.ok
    assert rel(warm.u[0], fresh.u[0]) < 1e-10


@pytest.mark.parametrize("kw,match", [
    (dict(stiffness=0.0), "stiffness.*> 0"),
    (dict(stiffness=-1e12), "stiffness.*> 0"),
    (dict(stiffness=float("nan")), "stiffness.*finite"),
    (dict(stiffness=float("inf")), "stiffness.*finite"),
    (dict(stiffness="1e12"), "stiffness.*real number"),
    (dict(stiffness=True), "stiffness.*real number"),
    (dict(stiffness=1e12, exponent=0.5), "exponent must be >= 1"),
    (dict(stiffness=1e12, exponent=float("nan")), "exponent.*finite"),
    (dict(stiffness=1e12, penetration_limit=-1e-6), "penetration_limit.*>= 0"),
    (dict(stiffness=1e12, penetration_limit=float("nan")), "penetration_limit.*finite"),
])
def test_bad_parameters_raise_typed_errors(kw, match):
    with pytest.raises(cc.SceneError, match=match):
        cc.NormalCompliance(**kw)


@pytest.mark.parametrize("law", ["normal_compliance", 1e12, cc.NormalCompliance])
def test_bad_law_arguments(scene_pressed, law):
    with pytest.raises(cc.SceneError, match="law must be"):
        cc.solve(scene_pressed, law=law)
    with pytest.raises(cc.SceneError, match="law must be"):
        cc.Model(scene_pressed, law=law)


def _data(law):
    body = lambda y, clamp, contact, E: {"material": {"E": E, "nu": 0.0}, "clamped": [clamp], "contact": contact,  # noqa: E731
                                         "mesh": {"rectangle": {"x": [0.0, 1.0], "y": y, "nx": 4, "ny": 2}}}
    data = {"gap": -DELTA, "body": [body([0.0, H1], "top", "bottom", E1), body([-H2, 0.0], "bottom", "top", E2)]}
    if law is not None:
        data["law"] = law
    return data


def test_scene_file_law(tmp_path):
    spec = scene_from_data(_data({"normal_compliance": {"stiffness": 1e12, "exponent": 2}}), tmp_path / "s.toml")
    assert spec.law == cc.NormalCompliance(stiffness=1e12, exponent=2)
    sol = spec.solve()
    r, lam = closed_form(1e12, 2)
    assert sol.ok and rel(sol.contact.lam, np.full(len(sol.contact.x), lam)) < 1e-10
    assert scene_from_data(_data(None), tmp_path / "s.toml").law == cc.Signorini()


@pytest.mark.parametrize("law,match", [
    ("coulomb", "law: expected"),
    ({"normal_compliance": {"exponent": 2}}, "stiffness \\(required\\)"),
    ({"normal_compliance": {"stiffness": 1e12, "kk": 1}}, "expected keys"),
    ({"normal_compliance": {"stiffness": -1.0}}, "law.normal_compliance: .*stiffness"),
])
def test_scene_file_bad_law(tmp_path, law, match):
    with pytest.raises(SceneFileError, match=match):
        scene_from_data(_data(law), tmp_path / "s.toml")


def _dense_compliance(scene, k):
    """Independent reference for the linear law (m = 1), gamma3: the mixed system (26) in SI, dense,

        Kuu u + Kup phi + J^T diag(w k) [J u - g]_A = f,    -Kup^T u + Kpp phi = q     (per body),

    with the trapezoidal weights w of the merged mesh, on the contact set A = {r > 0}, iterated until A
    is stable (the law is linear on each side of r = 0). Rows and columns equilibrated before the solve."""
    from cvxcontact.fem.assembly import assemble

    itf = scene.interface
    w = np.zeros(len(itf.x))
    h = np.diff(itf.x)
    w[:-1] += h / 2
    w[1:] += h / 2
    g = scene.gap_values()
    blocks, J, F, sizes = [], [], [], []
    for kb, b in enumerate(scene.bodies):
        s = assemble(b)
        uf = s.u_free
        A = s.Kuu[uf][:, uf].toarray()
        Jk = itf.jump(kb, len(b.mesh.points))[:, uf].toarray()
        if s.Kpp is not None:
            pf = s.phi_free
            Kup, Kpp = s.Kup[uf][:, pf].toarray(), s.Kpp[pf][:, pf].toarray()
            A = np.block([[A, Kup], [-Kup.T, Kpp]])
            Jk = np.hstack([Jk, np.zeros((len(itf.x), len(pf)))])
            F.append(np.concatenate([s.f[uf], s.q[pf]]))
        else:
            F.append(s.f[uf])
        blocks.append(A)
        J.append(Jk)
        sizes.append(len(uf))
    from scipy.linalg import block_diag

    K0, Jall, Fall = block_diag(*blocks), np.hstack(J), np.concatenate(F)
    active = np.ones(len(itf.x), dtype=bool)
    for _ in range(30):
        D = np.diag(w * k * active)
        K = K0 + Jall.T @ D @ Jall
        b = Fall + Jall.T @ D @ g
        sc = 1.0 / np.sqrt(np.abs(np.diag(K)))
        x = sc * np.linalg.solve(sc[:, None] * K * sc[None, :], sc * b)
        r = Jall @ x - g
        new = r > 0
        if np.array_equal(new, active):
            break
        active = new
    u1 = x[:sizes[0]]
    return u1, k * np.maximum(r, 0.0)


def test_piezoelectric_against_a_dense_solve_of_26():
    scene = two_blocks(n1=(8, 4), n2=(6, 3))
    k = 1e13
    u1, lam = _dense_compliance(scene, k)
    for method in ("condensed", "full"):
        sol = cc.solve(scene, law=cc.NormalCompliance(stiffness=k), method=method)
        free = cc.ContactSolver(scene).problem.matrices[0].u_free
        assert sol.ok and rel(sol.u[0].ravel()[free], u1) < 1e-9
        assert rel(sol.contact.lam, lam) < 1e-9
        assert 0 < (lam > 0).sum() < len(lam)         # partial contact: the set matters


@pytest.mark.parametrize("method", ["condensed", "full"])
def test_zero_penetration_limit_is_signorini(method):
    """l = 0: p vanishes on the admissible set r <= 0, so the problem is Signorini's (limit case)."""
    scene = two_blocks(n1=(8, 4), n2=(6, 3))
    ref = cc.solve(scene, method=method)
    sol = cc.solve(scene, law=cc.NormalCompliance(stiffness=1e13, exponent=2, penetration_limit=0.0), method=method)
    assert sol.ok and rel(sol.u[0], ref.u[0]) < 1e-9 and rel(sol.contact.force, ref.contact.force) < 1e-8


def test_cli_solves_a_scene_file_with_a_law(tmp_path):
    import json
    from pathlib import Path

    from cvxcontact.apps.cli import main

    text = (Path(__file__).resolve().parents[1] / "examples" / "two_blocks.toml").read_text()
    scene = tmp_path / "s.toml"
    scene.write_text('law = { normal_compliance = { stiffness = 1e13, exponent = 2 } }\n' + text)
    assert main(["solve", str(scene), "--out", str(tmp_path / "out"), "--no-plots", "--quiet"]) == 0
    summary = json.loads((tmp_path / "out" / "gamma3.json").read_text())
    assert summary["ok"] and set(summary["residuals"]) == {"equilibrium", "law"}
