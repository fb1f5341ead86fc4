"""What a contact term holds and declares beyond its program (cvxcontact.discrete.terms, cvxcontact.discrete.slip;
docs/architecture.md "A new contact law"): a friction law's data lives on its term (``term.data``, a
:class:`~cvxcontact.discrete.slip.Slip`), not on the problem or the blocks; the friction finish's normal rows are
the term's (``term.normal_rows``); the law's linearisation is one function (``backends.mixed.law_linearised``)."""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp
from friction_scenes import P, lidded, walled

import cvxcontact as cc
from cvxcontact.backends.frictionrows import LawRows, NormalRows
from cvxcontact.backends.mixed import LawEnergy, law_linearised, mixed_system
from cvxcontact.discrete.blocks import Block
from cvxcontact.discrete.slip import Slip


@pytest.fixture(scope="module")
def problems():
    """The problems (not solved) of a frictionless scene, Coulomb under a force-controlled lid, and Tresca beside a
    compliance wall."""
    build = lambda scene: cc.ContactSolver(scene, estimate=False).problem
    return {"signorini": build(walled(cc.Signorini())), "coulomb": build(lidded(cc.Coulomb(0.3))),
            "beside": build(walled(cc.Tresca(0.1 * P), cc.NormalCompliance(1e13)))}


def test_the_friction_data_is_the_terms_and_only_a_friction_term_holds_it(problems):
    """The problem and the blocks hold no friction field; a friction term's data is its Slip, whose slip rows are
    kron(I_c, E) and whose per-body operators are the interface's tangential jump on the free unknowns (both built
    here from the lines and the systems), a frictionless term holds nothing."""
    fields = {f.name for f in dataclasses.fields(type(problems["coulomb"]))}
    assert not fields & {"prescribed_slip", "translation_slips"}
    assert "slip" not in {f.name for f in dataclasses.fields(Block)}
    assert problems["signorini"].term.data is None and problems["signorini"].term.kernel_capacity() is None
    for key in ("coulomb", "beside"):
        p = problems[key]
        data = p.term.data
        assert isinstance(data, Slip) and data.components == 1                     # 2D: one slip component
        assert abs(data.rows - p.E).max() == 0                                     # kron(I_1, E) = E
        for k, s in enumerate(p.systems):
            T = p.lines.interface.tangential_jump(k, len(s.f) // 2) @ s.Tu
            assert abs(data.operators[k] - T).max() == 0
    coulomb = problems["coulomb"].term.data
    assert len(coulomb.translations) == 1 and coulomb.translations[0].shape[1] >= 1   # the lid's translation slips
    assert not problems["beside"].term.data.translations


@pytest.mark.numerics
def test_tresca_capacities_are_the_threshold_times_the_rows_lengths(problems):
    """Tresca's capacities c_a = g w_a (scaled) on the floor's rows, 0 on the wall's (frictionless), whatever the
    normal forces: the threshold 0.1 p times the lumped lengths, which sum to the floor's length 1 m."""
    p = problems["beside"]
    data, un = p.term.data, p.units
    floor = p.rows.frictional
    for y in (np.zeros(len(p.g)), np.ones(len(p.g))):
        c = data.capacities(y) * un.force                                           # N/m
        assert np.all(c[~floor] == 0)
        assert c[floor].sum() == pytest.approx(0.1 * P * 1.0, rel=1e-12)            # measured 2.2e-16


def test_the_finish_normal_rows_are_declared_by_the_term(problems):
    """A friction term's finish takes the normal rows as they are; beside a compliance law the law's energy and the
    rows with a finite limit (the floor's, Signorini), the wall's rows' forces w p(r) from the energy."""
    p = problems["beside"]
    op, G, _ = mixed_system(p)
    rows = p.term.normal_rows(p, op, G, p.g)
    assert type(rows) is LawRows and isinstance(rows.energy, LawEnergy)
    assert np.array_equal(rows.limited, p.rows.frictional)                           # the floor: Signorini rows
    assert rows.G.shape[0] == int(p.rows.frictional.sum())
    plain = problems["coulomb"]
    op, G, _ = mixed_system(plain)
    kept = plain.term.normal_rows(plain, op, G, plain.g)
    assert type(kept) is NormalRows and kept.G is G and kept.energy is op


@pytest.mark.numerics
@pytest.mark.parametrize("exponent", [1.0, 2.0])
def test_the_law_linearisation_is_the_gradients_taylor_model(exponent):
    """law_linearised at x: K x' - b is the gradient of 1/2 x^T A x - F^T x + sum_a w_a Phi_a(G_a x - g_a) near x up
    to the law's own curvature, the gradient computed here from the law's pressure k r_+^m: at x + h d, where no row
    changes side, the two differ by G^T (w k (h G d)^2) on the penetrating rows for m = 2 and by nothing for m = 1
    (the law linear on each side), to rounding."""
    rng = np.random.default_rng(5)
    n, m = 7, 5
    M = rng.normal(size=(n, n))
    A = sp.csr_matrix(M @ M.T + n * np.eye(n))
    F, G, w = rng.normal(size=n), sp.csr_matrix(rng.normal(size=(m, n))), rng.uniform(0.5, 1.5, size=m)
    law = cc.contact.laws.RowLaws([cc.NormalCompliance(stiffness=3.0, exponent=exponent)], [m])
    x = rng.normal(size=n)
    g = G @ x - np.array([0.5, -0.7, 0.9, -1.1, 1.3])          # rows 0, 2, 4 penetrate by >= 0.5, the others open
    pressed = G @ x - g > 0

    def gradient(z):
        pen = np.maximum(G @ z - g, 0.0)
        return A @ z - F + G.T @ (w * 3.0 * pen ** exponent)

    K, b = law_linearised(A, A @ x - F, G, g, w, law, x)
    d = rng.normal(size=n)
    d /= np.abs(G @ d).max()
    scale = np.abs(gradient(x)).max() + np.abs(A @ x).max() + np.abs(F).max()
    for h in (1e-1, 1e-2):                                   # |h G d| <= 0.1 < 0.5: no row changes side
        curvature = G.T @ np.where(pressed, w * 3.0 * (h * (G @ d)) ** 2, 0.0) if exponent == 2.0 else 0.0
        error = gradient(x + h * d) - (K @ (x + h * d) - b) - curvature
        assert np.abs(error).max() < 1e-13 * scale            # measured <= 5.0e-16 of the scale


def test_a_combination_of_laws_from_outside_is_one_term_class_and_a_route():
    """A friction law beside a compliance law posed by a term registered from outside the package (its declarations
    those of terms.FrictionBesideCompliance: the laws it combines, its program, forces, read-back, data and the
    finish's normal rows) and solved by a backend registered with a route for its kind: the package's answer, bit
    for bit (the same functions run), and no package file edited: the combination is the term and the route."""
    from cvxcontact import backends
    from cvxcontact.discrete import terms

    @dataclasses.dataclass(frozen=True)
    class Outside(terms.TrescaFriction):
        parts = frozenset({"friction", "compliance"})
        kind = "outside_beside"
        compliant = True
        active_from_forces = True
        finishes = True
        programs = "cvxcontact.backends.compliance:compliance_program"
        forces = "cvxcontact.backends.compliance:compliance_forces"
        reads_back = "cvxcontact.solution.readback:read_back_compliance_friction"
        finish_rows = "cvxcontact.backends.frictionrows:LawRows"

    scene = walled(cc.Tresca(0.1 * P), cc.NormalCompliance(1e13))
    own = cc.solve(scene, estimate=False)
    terms.register_term(Outside)
    backends.register(backends.Backend("outside", accepts=lambda d: True,
                                       routes={"outside_beside": "cvxcontact.backends.friction:full"}), before="full")
    try:
        solver = cc.ContactSolver(scene, method="outside", estimate=False)
        assert type(solver.problem.term) is Outside and solver.method == "outside"
        sol = solver.solve()
    finally:
        backends.unregister("outside")
        terms.unregister_term(Outside)
    assert own.ok and own.polished and sol.ok and sol.polished
    for a, b in zip(own.u, sol.u):
        assert np.array_equal(a, b)
    assert all(np.array_equal(c.slip, d.slip) and np.array_equal(c.lam, d.lam)
               for c, d in zip(own.contacts, sol.contacts))
