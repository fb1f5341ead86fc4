"""cc.Model: the contact program in SI units with user terms, against independent dense solves."""

import warnings

import cvxpy as cp
import numpy as np
import pytest
import scipy.linalg as sla

import cvxcontact as cc
from cvxcontact.fem.assembly import assemble
from conftest import rel, two_blocks

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run



def _split(x, sizes):
    """Per-body (u, phi) pieces of a stacked free-dof vector, ``sizes`` = [(n_u, n_phi), ...]."""
    parts, p = [], 0
    for nu, npf in sizes:
        parts.append((x[p:p + nu], x[p + nu:p + nu + npf] if npf else None))
        p += nu + npf
    return parts

def _dense_bodies(scene):
    """Per body: assembled SI system, dense free-dof blocks, jump rows on the free dofs."""
    itf = scene.interface
    out = []
    for k, body in enumerate(scene.bodies):
        s = assemble(body)
        uf = s.u_free
        J = itf.jump(k, len(body.mesh.points)).toarray()[:, uf]
        d = dict(s=s, J=J, Kuu=s.Kuu[uf][:, uf].toarray(), f=s.f[uf], c0=np.abs(body.material.c).max())
        if s.piezoelectric:
            pf = s.phi_free
            d.update(Kup=s.Kup[uf][:, pf].toarray(), Kpp=s.Kpp[pf][:, pf].toarray(), q=s.q[pf],
                     e0=np.abs(s.Kpp.diagonal()).max())
        out.append(d)
    return out


def _nodal(scene, bodies, x_per_body):
    us, phis = [], []
    for body, d, (xu, xp) in zip(scene.bodies, bodies, x_per_body):
        n = len(body.mesh.points)
        u = np.zeros(2 * n)
        u[d["s"].u_free] = xu
        us.append(u.reshape(-1, 2))
        if xp is None:
            phis.append(None)
        else:
            p = d["s"].phi_fixed.copy()
            p[d["s"].phi_free] += xp
            phis.append(p)
    return us, phis


def dense_mixed_with_row(scene, active, body, dof, value):
    """The nonsymmetric mixed system (26), dense and in SI, with the contact closed on ``active``
    (merged nodes) and one extra row u_dof = value (m) on the free u dofs of ``body`` held as an
    equality, its multiplier acting on that dof's momentum row. Rows and columns equilibrated by
    the material constants. Returns nodal u, phi per body and the merged nodal contact force."""
    bodies = _dense_bodies(scene)
    A_blocks, D, rhs, J, sizes = [], [], [], [], []
    for d in bodies:
        nu = len(d["f"])
        if "Kpp" in d:
            npf = len(d["q"])
            A_blocks.append(np.block([[d["Kuu"], d["Kup"]], [-d["Kup"].T, d["Kpp"]]]))
            D.append(np.concatenate([np.full(nu, d["c0"] ** -0.5), np.full(npf, d["e0"] ** -0.5)]))
            rhs.append(np.concatenate([d["f"], d["q"]]))
            J.append(np.hstack([d["J"], np.zeros((len(d["J"]), npf))]))
        else:
            npf = 0
            A_blocks.append(d["Kuu"])
            D.append(np.full(nu, d["c0"] ** -0.5))
            rhs.append(d["f"])
            J.append(d["J"])
        sizes.append((nu, npf))
    A, D, J = sla.block_diag(*A_blocks), np.concatenate(D), np.hstack(J)
    n = A.shape[0]
    start = sum(a + b for a, b in sizes[:body])
    pos = int(np.flatnonzero(bodies[body]["s"].u_free == dof)[0])
    R = np.zeros((1, n))
    R[0, start + pos] = 1.0
    act = np.flatnonzero(active)
    G = np.vstack([J[act], R])
    m = len(G)
    K = np.block([[D[:, None] * A * D[None, :], D[:, None] * G.T], [G * D[None, :], np.zeros((m, m))]])
    z = np.linalg.solve(K, np.concatenate([D * np.concatenate(rhs), np.zeros(len(act)), [value]]))
    x = D * z[:n]
    parts = _split(x, sizes)
    us, phis = _nodal(scene, bodies, parts)
    force = np.zeros(scene.interface.size)
    force[act] = z[n:n + len(act)]
    return us, phis, force


def dense_phi_form_kkt(scene, active, extra_rows, extra_values, phi_penalty=0.0):
    """Independent of (26): the KKT system of the phi-form QP itself, dense and in SI,

        min 1/2 u'Kuu u + 1/2 phi'Kpp phi - f'u + a |phi_SI|^2   s.t.  Kpp phi - Kup'u = q,
            [u_nu] = 0 on ``active``,  R x = r (``extra_rows`` on x = [u_1; phi_1; u_2], SI free dofs)

    with the Gauss multipliers kept as unknowns (no elimination). ``phi_penalty`` a (J/m/V^2)
    acts on the full nodal potential phi_SI = phi_fixed + phi_free."""
    bodies = _dense_bodies(scene)
    H, c, J, B, b, sizes = [], [], [], [], [], []
    for d in bodies:
        nu = len(d["f"])
        if "Kpp" in d:
            npf = len(d["q"])
            Hp = d["Kpp"] + 2 * phi_penalty * np.eye(npf)
            H.append(sla.block_diag(d["Kuu"], Hp))
            c.append(np.concatenate([d["f"], -2 * phi_penalty * d["s"].phi_fixed[d["s"].phi_free]]))
            J.append(np.hstack([d["J"], np.zeros((len(d["J"]), npf))]))
            B.append(np.hstack([-d["Kup"].T, d["Kpp"]]))
            b.append(d["q"])
        else:
            npf = 0
            H.append(d["Kuu"])
            c.append(d["f"])
            J.append(d["J"])
            B.append(np.zeros((0, nu)))
            b.append(np.zeros(0))
        sizes.append((nu, npf))
    H, c, J, B = sla.block_diag(*H), np.concatenate(c), np.hstack(J), sla.block_diag(*B)
    n = H.shape[0]
    act = np.flatnonzero(active)
    Aeq = np.vstack([B, J[act], extra_rows])
    beq = np.concatenate([np.concatenate(b), np.zeros(len(act)), extra_values])
    # equilibrate: u columns by 1/sqrt(c0), phi columns by 1/sqrt(e0)
    D = np.concatenate([np.concatenate([np.full(nu, d["c0"] ** -0.5), np.full(npf, d.get("e0", 1.0) ** -0.5)])
                        for d, (nu, npf) in zip(bodies, sizes)])
    Rs = 1.0 / np.maximum(np.abs(Aeq * D[None, :]).max(axis=1), 1e-300)
    Ae = Rs[:, None] * Aeq * D[None, :]
    m = len(Ae)
    K = np.block([[D[:, None] * H * D[None, :], Ae.T], [Ae, np.zeros((m, m))]])
    z = np.linalg.solve(K, np.concatenate([D * c, Rs * beq]))
    x = D * z[:n]
    parts = _split(x, sizes)
    us, phis = _nodal(scene, bodies, parts)
    force = np.zeros(scene.interface.size)
    force[act] = Rs[len(B):len(B) + len(act)] * z[n + len(B):n + len(B) + len(act)]
    return us, phis, force


@pytest.fixture(scope="module")
def reference():
    scene = two_blocks()
    return scene, cc.solve(scene, "gamma3", method="full")


def _node(scene, x, y):
    pts = scene.bodies[0].mesh.points
    return int(np.argmin(np.hypot(pts[:, 0] - x, pts[:, 1] - y)))


def test_no_user_terms_equals_solve_full(reference):
    scene, ref = reference
    sol = cc.Model(scene, "gamma3").solve()
    assert sol.ok and sol.polished
    for k in range(2):
        assert rel(sol.u[k], ref.u[k]) <= 1e-12
    assert rel(sol.phi[0], ref.phi[0]) <= 1e-12 and sol.phi[1] is None
    assert rel(sol.contact.force, ref.contact.force) <= 1e-12
    assert rel(sol.contact.lam, ref.contact.lam) <= 1e-12
    assert np.array_equal(sol.contact.active, ref.contact.active)


def test_expressions_are_si(reference):
    """Values of model.u/phi/jump at the interior-point answer are the SI fields of its solution."""
    scene, _ = reference
    model = cc.Model(scene, "gamma3", polish=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = model.solve()
    for k in range(2):
        assert rel(model.u(k).value, sol.u[k]) < 1e-12
    assert rel(model.phi(0).value, sol.phi[0]) < 1e-12 and model.phi(1) is None
    assert rel(model.jump().value, sol.contact.jump) < 1e-12
    top = scene.bodies[0].mesh.boundary_nodes(["top"])
    assert np.all(model.u(scene.bodies[0]).value[top] == 0) and np.all(model.phi(0).value[top] == 0)


def test_user_bound_on_a_displacement_matches_dense_mixed_solve(reference):
    """The done-when test: u_y of a node of body 1 (PZT-5A) >= half its unconstrained value (m)."""
    scene, ref = reference
    k = _node(scene, 0.75, 0.25)
    v0 = ref.u[0][k, 1]
    assert v0 < -1e-5                               # the bound cuts into the unconstrained answer
    bound = 0.5 * v0
    model = cc.Model(scene, "gamma3")
    con = model.add(model.u(0)[k, 1] >= bound)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = model.solve()
    assert sol.ok and sol.polished and sol.path == "interior point + exact finish"
    assert con in sol.problem.constraints and con.dual_value > 0
    assert sol.u[0][k, 1] >= bound - 1e-12 * abs(bound)
    res = sol.residuals()
    assert {"user[0] feasibility", "user[0] complementarity"} <= set(res)
    assert all(v <= 1e-7 for v in res.values()), res
    us, phis, force = dense_mixed_with_row(scene, sol.contact.active, 0, 2 * k + 1, bound)
    for b in range(2):
        assert rel(sol.u[b], us[b]) < 1e-7
    assert rel(sol.phi[0], phis[0]) < 1e-7
    assert rel(sol.contact.force, force) < 1e-7
    assert (force[sol.contact.active] > 0).all()
    # the bound changed the answer: it is not the unconstrained one
    assert rel(sol.u[0], ref.u[0]) > 1e-3
    # the interior-point answer of the same problem agrees with the dense reference too
    ipm = model.u(0).value
    assert rel(ipm, us[0]) < 1e-5


def test_user_bound_on_a_potential_matches_the_phi_form_kkt(reference):
    """A bound on a nodal potential (V) acts on the momentum through the coupling (w-rows of the
    finish); reference: the dense KKT of the phi-form QP, Gauss multipliers kept."""
    scene, ref = reference
    k = _node(scene, 0.0, 0.25)
    p0 = ref.phi[0][k]
    assert abs(p0) > 0
    bound = 0.5 * p0
    model = cc.Model(scene, "gamma3")
    P = model.phi(0)
    model.add(P[k] <= bound if p0 > 0 else P[k] >= bound)        # halfway towards 0: binding
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = model.solve()
    assert sol.ok and sol.polished
    assert abs(sol.phi[0][k] - bound) <= 1e-10 * abs(bound)
    s = assemble(scene.bodies[0])
    n_u0 = len(s.u_free)
    n = n_u0 + len(s.phi_free) + len(assemble(scene.bodies[1]).u_free)
    R = np.zeros((1, n))
    R[0, n_u0 + int(np.flatnonzero(s.phi_free == k)[0])] = 1.0
    us, phis, force = dense_phi_form_kkt(scene, sol.contact.active, R, np.array([bound - s.phi_fixed[k]]))
    for b in range(2):
        assert rel(sol.u[b], us[b]) < 1e-7
    assert rel(sol.phi[0], phis[0]) < 1e-7
    assert rel(sol.contact.force, force) < 1e-7


def test_quadratic_objective_term_is_honest(reference):
    """A penalty on phi (J/m): no exact finish; the checks include its gradient and are either
    below tol (and then the answer matches the dense KKT with the penalty) or flagged with a warning."""
    scene, ref = reference
    energy_scale = abs(ref.energy)
    a = 0.5 * energy_scale / float(np.sum(ref.phi[0] ** 2))      # J/m/V^2: changes the answer visibly
    model = cc.Model(scene, "gamma3")
    model.add(cp.Minimize(a * cp.sum_squares(model.phi(0))))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = model.solve()
    assert not sol.polished and "no exact finish" in sol.path
    warned = any(w.category is cc.ResidualWarning for w in caught)
    assert sol.ok != warned
    us, phis, force = dense_phi_form_kkt(scene, sol.contact.active, np.zeros((0, sum(
        len(s.u_free) + (len(s.phi_free) if s.piezoelectric else 0) for s in map(assemble, scene.bodies)))),
        np.zeros(0), phi_penalty=a)
    err = max(rel(sol.u[0], us[0]), rel(sol.u[1], us[1]), rel(sol.phi[0], phis[0]))
    assert rel(sol.phi[0], ref.phi[0]) > 1e-2                     # the penalty mattered
    assert err < 1e-5, err
    if sol.ok:
        assert all(v <= sol.tol for v in sol.residuals().values())


def test_equilibrium_check_sees_a_missing_user_multiplier(reference):
    """The check can fail: dropping the user constraint's multiplier from the residual of (26)
    makes the equilibrium residual large (the bound carries a real force)."""
    scene, ref = reference
    k = _node(scene, 0.75, 0.25)
    model = cc.Model(scene, "gamma3")
    model.add(model.u(0)[k, 1] >= 0.5 * ref.u[0][k, 1])
    sol = model.solve()
    good = sol.residuals()["equilibrium"]
    x = model._x()
    from cvxcontact.model.terms import checks, linearize

    C, c0 = linearize(model.constraints[0].expr, x, model._vars)
    lying = checks(model.problem, {}, [v.value for v in model._contact.u],
                          [v.value if v is not None else None for v in model._contact.phi],
                          np.asarray(model._contact.contact.dual_value).ravel(), x,
                          [(C, c0, np.zeros(1), False, True)], np.zeros(model._n))
    assert good < 1e-10 and lying["equilibrium"] > 1e-4


def test_resolve_is_fresh(reference):
    scene, ref = reference
    k = _node(scene, 0.75, 0.25)
    model = cc.Model(scene, "gamma3")
    first = model.solve()
    u_first = first.u[0].copy()
    model.add(model.u(0)[k, 1] >= 0.5 * ref.u[0][k, 1])
    second = model.solve()
    assert np.array_equal(first.u[0], u_first) and second is not first
    assert len(first.problem.constraints) + 1 == len(second.problem.constraints)
    assert "user[0] feasibility" in second.residuals() and "user[0] feasibility" not in first.residuals()
    assert rel(second.u[0], first.u[0]) > 1e-3


def test_bad_inputs_raise_typed_errors(reference):
    scene, _ = reference
    model = cc.Model(scene, "gamma3")
    other = cc.Model(two_blocks(), "gamma3")
    for body in (2, -1, True, "upper", 0.0, other.scene.bodies[0]):
        with pytest.raises(cc.SceneError, match="body"):
            model.u(body)
        with pytest.raises(cc.SceneError, match="body"):
            model.phi(body)
    with pytest.raises(cc.SceneError, match="not this model's"):
        model.add(cp.Variable(2) >= 0)
    with pytest.raises(cc.SceneError, match="not this model's"):
        model.add(other.u(0)[3, 1] >= 0)
    with pytest.raises(cc.SceneError, match="none of this model's unknowns"):
        model.add(cp.Constant(1.0) >= 0)
    with pytest.raises(cc.SceneError, match="not convex"):
        model.add(cp.square(model.u(0)[3, 1]) >= 1e-8)
    with pytest.raises(cc.SceneError, match="scalar"):
        model.add_objective(model.u(0)[:, 1])
    with pytest.raises(cc.SceneError, match="not convex"):
        model.add(cp.Minimize(-cp.sum_squares(model.u(0))))
    with pytest.raises(cc.SceneError, match="constraint"):
        model.add("u >= 0")
    with pytest.raises(cc.SceneError):
        cc.Model("not a scene")
    with pytest.raises(cc.SolverError):
        cc.Model(scene, solver_options={"max_itr": 3})
    assert model.constraints == []                   # nothing half-added


def test_a_user_model_whose_finish_does_not_settle_keeps_the_interior_point_and_says_why(monkeypatch):
    """The finish of a model with user rows declines with a typed reason (cvxcontact.backends.finish.Declined)
    when its active-set steps do not settle: the interior point's answer is kept, with a ResidualWarning naming
    the steps. It returned a plain string, which the model unpacked as an answer (ValueError)."""
    from cvxcontact.backends.finish import MAX_ITER, Stop
    from cvxcontact.model import terms

    monkeypatch.setattr(terms, "active_set_steps", lambda *args, **kwargs: MAX_ITER)
    body = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2), cc.materials.isotropic(E=200e9, nu=0.3),
                   contact="bottom", traction={"top": (0.0, -1e7)}, displacement={"left": (0.0, None)})
    model = cc.Model(cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)))]),
                     "sigma1")
    model.add(model.u(0)[:, 1] >= -1.0)                                   # a user row that never binds
    with pytest.warns(cc.ResidualWarning, match=f"did not settle in {terms.MAX_STEPS} steps.*; the interior-point "
                                                r"answer is kept \(sol.polished is False\)"):
        sol = model.solve()
    assert not sol.polished and sol.info.declined.stop is Stop.MAX_ITER
