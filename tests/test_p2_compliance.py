"""Normal compliance with P2 elements (issue 11 item 4, P2): closed form, the Signorini limit, full = condensed.

The closed-form reference is independent of the package (as in tests/test_compliance.py): two elastic
blocks with nu = 0, clamped at their far ends and pressed together by an interference delta (gap
g = -delta), are two 1D springs in series. With H_l the heights and E_l the moduli (plane strain with
nu = 0: c22 = E) the contact pressure is uniform, lambda = (delta - r) / C with C = H1/E1 + H2/E2, and
the law lambda = k r^m gives the scalar equation r + C k r^m = delta, solved here by brentq. u_y is
linear in y in each body and u_x = 0, which P2 reproduces at every P2 node (vertices and midpoints).
With P2 the law sits on the P2 contact nodes of the condition's rows with Simpson weights
(docs/formulation.md §10).
"""

import numpy as np
import pytest

import cvxcontact as cc

from conftest import rel, two_blocks
from reference_problems import C, DELTA, E1, E2, H1, H2, closed_form, field_error, pressed

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


@pytest.fixture(scope="module")
def scene_pressed():
    return pressed()


@pytest.mark.parametrize("method", ["condensed", "full"])
@pytest.mark.parametrize("m,k", [(1, 1e11), (2, 1e16)])
def test_p2_two_blocks_closed_form(scene_pressed, method, m, k):
    """gamma3 on non-matching meshes: the law at every P2 node of the merged mesh, Simpson weights. The finish
    refines r on the interface equation itself (not through W^-1, which lost cond(W) eps: 1.6e-10 on the stiff
    m = 2 law before, 1.017e-10 of the force on an AVX-512 CPU). Measured under the Haswell, Sandybridge,
    Nehalem and Prescott OpenBLAS kernels, both methods: lambda <= 5.4e-15, jump <= 2.9e-15, fields <= 1.4e-15,
    the force sum <= 1.3e-15, residuals <= 2.3e-15; bounds 1e-12 (>= 180x)."""
    r, lam = closed_form(k, m)
    tol = 1e-12
    assert 0.2 < r / DELTA < 0.8                                     # both springs and the law matter
    law = cc.NormalCompliance(stiffness=k, exponent=m)
    sol = cc.solve(scene_pressed, "gamma3", law=law, method=method, degree=2)
    assert sol.ok and sol.polished and sol.method == method and sol.degree == 2
    x = sol.contact.x
    assert len(x) == 2 * 12 - 1                                      # 12 merged vertices (8 + 6 - 2), midpoints
    assert rel(sol.contact.lam, np.full(len(x), lam)) < tol
    assert rel(sol.contact.jump - sol.contact.gap, np.full(len(x), r)) < tol
    assert rel(sol.contact.pressure, np.full(len(x), lam)) < tol    # force / Simpson weights
    assert field_error(sol, lam) < 1e-12
    assert abs(sol.contact.force.sum() / lam - 1.0) < 1e-12         # lambda times the length of Gamma_3
    assert set(sol.residuals()) == {"equilibrium", "law"} and max(sol.residuals().values()) < 1e-12
    assert sol.contact.law == law
    # the energy: the springs' strain energy plus k r^(m+1)/(m+1) over the unit length of Gamma_3
    assert abs(sol.energy / (0.5 * lam ** 2 * C + k * r ** (m + 1) / (m + 1)) - 1) < 1e-9


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_p2_sigma_rows_closed_form_on_matching_meshes(condition):
    """sigma_l: the law on the P2 nodes of body l's trace. On matching meshes (4 : 4 cells) the rows are
    the merged P2 nodes and the closed form holds at every node; both backends agree."""
    scene = pressed(n1=(4, 2), n2=(4, 2))
    k, m = 1e11, 1
    r, lam = closed_form(k, m)
    sols = [cc.solve(scene, condition, law=cc.NormalCompliance(stiffness=k, exponent=m), method=meth, degree=2)
            for meth in ("condensed", "full")]
    for sol in sols:
        assert sol.ok and sol.polished
        assert rel(sol.contact.lam, np.full(len(sol.contact.x), lam)) < 1e-10
        assert field_error(sol, lam) < 1e-10
    assert rel(sols[0].u[0], sols[1].u[0]) < 1e-10


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_p2_sigma_rows_on_non_matching_meshes(scene_pressed, condition):
    """sigma_l on non-matching meshes (7 : 5): lambda = p(r) at body l's P2 trace nodes (r from the returned
    displacements, independently of the read-back), extended to X_h as the P2 function of those nodes, the
    Simpson weights summing to the length of Gamma_3; the other body receives that force through its own
    trace interpolation, which Simpson on mesh l does not integrate exactly: not the closed form, but close."""
    k, m = 1e11, 1
    r, lam = closed_form(k, m)
    sol = cc.solve(scene_pressed, condition, law=cc.NormalCompliance(stiffness=k, exponent=m), degree=2)
    assert sol.ok and sol.polished and max(sol.residuals().values()) < 1e-9
    itf = sol.interface
    xl = np.asarray(itf.sigma_x[int(condition[-1]) - 1])
    w = itf.weights(condition)
    assert len(w) == len(xl) and (w > 0).all() and abs(w.sum() - 1.0) < 1e-14
    h = np.diff(xl[0::2])                                             # Simpson: h/6 at vertices, 2h/3 at midpoints
    assert np.allclose(w[1::2], 2 * h / 3, rtol=1e-14) and np.isclose(w[0], h[0] / 6, rtol=1e-14)
    # r at the trace nodes: the merged P2 jump (exact, quadratic on each merged segment) evaluated there
    from cvxcontact.contact.quadratic import p2_interpolation
    P = p2_interpolation(np.asarray(itf.xv), xl)
    r_nodes = P @ (sol.contact.jump - sol.contact.gap)
    lam_nodes = k * np.maximum(r_nodes, 0.0)
    assert rel(p2_interpolation(xl[0::2], xl) @ lam_nodes, lam_nodes) < 1e-15     # the sampling is exact
    assert rel(p2_interpolation(xl[0::2], np.asarray(itf.x)) @ lam_nodes, sol.contact.lam) < 1e-9
    assert abs((w * lam_nodes).sum() / sol.contact.force.sum() - 1) < 1e-10      # E^T (w lambda)
    assert rel(sol.contact.lam, np.full(len(sol.contact.x), lam)) < 0.1           # measured 2.8e-3 / 2.7e-2


def test_p2_compliance_tends_to_p2_signorini():
    """The nodal P2 condition (sigma1) on the quickstart-like piezoelectric scene (partial contact):
    ||u_k - u_S||_inf / ||u_S||_inf decreases with k like 1/k for m = 1 (the penetration lambda / k)."""
    scene = two_blocks(n1=(6, 3), n2=(4, 2))
    ref = cc.solve(scene, "sigma1", degree=2)
    assert ref.ok and ref.polished
    umax = max(np.abs(u).max() for u in ref.u)
    ks = (1e15, 1e16, 1e17)
    errs = []
    for k in ks:
        sol = cc.solve(scene, "sigma1", law=cc.NormalCompliance(stiffness=k), degree=2)
        assert sol.ok and sol.polished
        errs.append(max(np.abs(a - b).max() for a, b in zip(sol.u, ref.u)) / umax)
    assert errs[0] > errs[1] > errs[2]
    rate = np.log(errs[1] / errs[2]) / np.log(ks[2] / ks[1])
    assert 0.9 < rate < 1.1, (errs, rate)


@pytest.mark.parametrize("condition", ["gamma3", "sigma1", "sigma2"])
def test_p2_compliance_full_equals_condensed(condition):
    """The piezoelectric scene with a nonlinear law (m = 1.5): the full model and the condensed interface
    program give the same fields, potentials and lambda; a ContactSolver re-solve (warm start) agrees."""
    scene = two_blocks(n1=(6, 3), n2=(4, 2))
    law = cc.NormalCompliance(stiffness=1e13, exponent=1.5)
    a = cc.solve(scene, condition, law=law, method="condensed", degree=2)
    b = cc.solve(scene, condition, law=law, method="full", degree=2)
    assert a.ok and b.ok and a.phi[0] is not None and a.contact.active.any() and not a.contact.active.all()
    assert max(a.residuals().values()) < 1e-9 and max(b.residuals().values()) < 1e-9
    assert rel(a.u[0], b.u[0]) < 1e-9 and rel(a.u[1], b.u[1]) < 1e-9 and rel(a.phi[0], b.phi[0]) < 1e-9
    assert rel(a.contact.lam, b.contact.lam) < 1e-8
    solver = cc.ContactSolver(scene, condition, law=law, degree=2)
    solver.solve()
    c = solver.solve()
    assert c.path == cc.Route.WARM_START and rel(c.u[0], a.u[0]) < 1e-9


def _overhang(lo, hi, n1=4, n2=3):
    """The upper block (n1 cells on [0, 1]) over a lower one on [lo, hi] (n2 cells), interfering by DELTA."""
    m1 = cc.rectangle(x=(0, 1), y=(0, H1), nx=n1, ny=2)
    m2 = cc.rectangle(x=(lo, hi), y=(-H2, 0), nx=n2, ny=2)
    b1 = cc.Body(m1, cc.materials.isotropic(E=E1, nu=0.0), clamped=["top"], contact="bottom")
    b2 = cc.Body(m2, cc.materials.isotropic(E=E2, nu=0.0), clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=-DELTA)])


def test_p2_compliance_refusals_are_typed():
    """A nodal limit under sigma1 holds at its rows (the conic limit under gamma3: tests/test_p2_model_compliance.py).
    Sigma rows that begin inside a segment of that trace (the lower block on [0.1, 1]: the upper trace's first node
    in the overlap is the midpoint 0.125) are taken (docs/refusals.md row 4, tests/test_p2_overlap_weights.py); a
    sigma condition with no node of that trace in the overlap (the lower block on [0.3, 0.45], between the upper
    trace's nodes 0.25 and 0.5) gives the law no row, as Signorini's: a ResolutionWarning naming the case
    (tests/test_resolution.py)."""
    scene = pressed(n1=(4, 2), n2=(4, 2))
    sol = cc.solve(scene, "sigma1", degree=2, law=cc.NormalCompliance(stiffness=1e11, penetration_limit=1e-6))
    assert sol.ok and sol.polished and {"feasibility", "complementarity", "cone"} <= set(sol.residuals())
    assert np.abs(sol.contact.jump - sol.contact.gap).max() < 1e-6 * (1 + 1e-9)     # the limit holds
    law = cc.NormalCompliance(stiffness=1e11)
    partial = cc.solve(_overhang(0.1, 1.0), "sigma1", degree=2, law=law)
    assert partial.ok and max(partial.residuals().values()) < 1e-9
    with pytest.warns(cc.ResolutionWarning, match="under 'sigma1' the rows are the nodes of"):
        assert cc.solve(_overhang(0.3, 0.45, n1=2, n2=1), "sigma1", degree=2, law=law).ok
    assert cc.solve(_overhang(0.3, 0.45, n1=2, n2=1), "sigma2", degree=2, law=law).ok


def test_p2_compliance_on_rows_beginning_inside_a_segment_is_the_same_program_on_every_route():
    """The lower block on [0.1, 1] under "sigma1" (the upper trace's rows begin at the midpoint 0.125; weights: Simpson's
    inside, the red hats over the overlap on the cut segment): the condensed route, the full program and cc.Model pose
    the same law on the same rows (measured: u 1.8e-16, lambda 4.2e-16 apart; checks 1.3e-16)."""
    scene = _overhang(0.1, 1.0)
    law = cc.NormalCompliance(stiffness=1e12)
    a = cc.solve(scene, "sigma1", degree=2, law=law)
    b = cc.solve(scene, "sigma1", degree=2, law=law, method="full")
    c = cc.Model(scene, "sigma1", law=law, degree=2).solve()
    assert a.ok and b.ok and c.ok and a.contact.active.any()
    for other in (b, c):
        assert max(rel(x, y) for x, y in zip(a.u, other.u)) < 1e-12
        assert rel(a.contact.lam, other.contact.lam) < 1e-12
        assert max(other.residuals().values()) < 1e-12
