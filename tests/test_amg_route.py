"""The AMG route for large 3D scenes (cvxcontact/backends/amg.py): active-set steps with AMG-preconditioned
Krylov solves, cross-checked against the sparse route's exact factorised steps; its place in the registry; a
SciPy-only install. No timing is asserted."""

import importlib.util
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import benchmark, fields_agree
from scenes3d import sphere_into_block, two_boxes

import cvxcontact as cc
import cvxcontact.backends as backends
from cvxcontact.apps.demo import two_blocks
from cvxcontact.backends.finish import Declined
from cvxcontact.backends import ProblemDescription, choose
from cvxcontact.backends.amg import own_dofs
from cvxcontact.backends.result import Route

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

@pytest.mark.parametrize("make, n", [(sphere_into_block, 12), (two_boxes, 6)], ids=["sphere", "pzt-on-aluminium"])
def test_amg_route_agrees_with_the_sparse_route(make, n):
    """The same active set and fields as the sparse route's factorised steps (Krylov solves to 1e-10):
    a rigid sphere into an elastic block (CG) and a PZT-5A box on an aluminium box (MINRES, potentials)."""
    pytest.importorskip("pyamg")
    scene = make(n)
    a = cc.solve(scene, method="amg")
    b = cc.solve(scene, method="sparse")
    assert a.ok and b.ok and a.info.method == "amg" and a.info.route == Route.KRYLOV_ACTIVE_SET
    assert a.info.factorization == "pyamg"
    assert 0 < np.sum(a.contact.active)
    fields_agree(a, b, 3e-8)                 # measured: sphere 8.4e-12, boxes 2.0e-10 (5 kernels; Krylov to 1e-10)
    assert a.residuals()["equilibrium"] < 1e-10                   # measured 3.4e-12, 7.6e-12


def test_amg_resolve_starts_from_the_previous_active_set():
    """A second solve through one ContactSolver reuses the hierarchy and starts from the exact active set:
    one step, the same answer."""
    pytest.importorskip("pyamg")
    solver = cc.ContactSolver(sphere_into_block(12), method="amg")
    first = solver.solve()
    again = solver.solve()
    assert first.ok and again.ok and again.info.route == Route.WARM_START and again.info.iterations == 1
    fields_agree(again, first, 1e-8)


def _elastic_boxes(press, n=8):
    """An aluminium box clamped on top, pushed down on an aluminium box (non-matching faces, "sigma1") by a body
    force and a traction ``press`` (N/m^2, along z) on its right face."""
    from cvxcontact.physics import materials

    al = materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=n // 2)
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=n - 2, ny=n - 2, nz=n // 2)
    top = cc.Body(upper, al, clamped=["top"], body_force=(0.0, 0.0, -2e9), traction={"right": (0.0, 0.0, press)})
    base = cc.Body(lower, al, clamped=["bottom"])
    return cc.Scene(top, base, contacts=[cc.Contact(top, "bottom", base, "top", condition="sigma1")])


def test_staged_solves_tighten_only_while_the_signs_hold(monkeypatch):
    """Each active set is solved to the stages STEP_RTOLS, then RTOL, in order, and left at the first stage whose
    signs fail: so the tolerances solved on one set are a prefix of that sequence, and only the last set reaches
    RTOL when it is the answer. Re-solving other loads through one solver (the reduced system of a set is kept
    between its stages, keyed by the loads) gives the sparse route's answer for each."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    calls, system = [], amg.KrylovContact._system

    def traced(self, active, F, g, x_start, rtol=amg.RTOL, verdict=None):
        calls.append((active.tobytes(), rtol))
        return system(self, active, F, g, x_start, rtol, verdict)

    monkeypatch.setattr(amg.KrylovContact, "_system", traced)
    ladder = amg.STEP_RTOLS + (amg.RTOL,)
    solver = cc.ContactSolver(_elastic_boxes(3e8), method="amg")
    for press in (3e8, -6e8):                     # the right face's traction: up, then down (other sets)
        calls.clear()
        a = solver.solve(_elastic_boxes(press))
        b = cc.solve(_elastic_boxes(press), method="sparse")
        assert a.ok and a.info.method == "amg"
        fields_agree(a, b, 1e-8)                            # measured 4.3e-11 .. 7.6e-11 (Krylov to 1e-10)
        runs, k = [], 0
        while k < len(calls):                               # consecutive calls on one set
            j = k
            while j < len(calls) and calls[j][0] == calls[k][0]:
                j += 1
            runs.append([r for _, r in calls[k:j]])
            k = j
        assert all(r == list(ladder[:len(r)]) for r in runs)
        assert runs[-1] == list(ladder) or runs[-1] == [amg.RTOL] * len(runs[-1])
    assert len(runs) >= 2                                   # measured 2 sets on the second load (4 on the first)


def test_gamma3_rows_are_refused_by_the_krylov_system():
    """Overlay rows share their dofs (no row has one of its own): the AMG route's system refuses them (the route
    then hands the problem to the sparse route) rather than eliminating the wrong dofs."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends.amg import KrylovContact

    problem = cc.ContactSolver(two_boxes(4, condition="gamma3")).problem
    with pytest.raises(cc.SolverError, match="no dof of its own"):
        KrylovContact(problem)


def test_auto_takes_the_amg_route_for_large_3d_scenes_only(monkeypatch):
    big = dict(dim=3, unknowns=backends.AMG_UNKNOWNS, contact_rows=10_000)
    monkeypatch.setattr(backends, "_amg_available", lambda: True)
    assert choose("auto", ProblemDescription(**big)) == "amg"
    assert choose("auto", ProblemDescription(**dict(big, unknowns=backends.AMG_UNKNOWNS - 1))) == "sparse"
    assert choose("auto", ProblemDescription(**dict(big, dim=2))) == "sparse"
    assert choose("auto", ProblemDescription(**dict(big, compliant=True))) == "condensed"
    assert choose("auto", ProblemDescription(**dict(big, piezoelectric=True))) == "amg"
    assert choose("auto", ProblemDescription(**dict(big, piezoelectric=True, unknowns=backends.AMG_UNKNOWNS - 1))) \
        == "sparse"
    monkeypatch.setattr(backends, "_amg_available", lambda: False)          # a SciPy-only install
    assert choose("auto", ProblemDescription(**big)) == "sparse"
    assert choose("auto", ProblemDescription(**dict(big, piezoelectric=True))) == "sparse"


def test_without_pyamg_the_amg_method_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyamg", None)                           # import pyamg -> ImportError
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a, _f=importlib.util.find_spec: None if name == "pyamg" else _f(name, *a))
    with pytest.raises(cc.SolverError, match=r'pip install "cvxcontact\[amg\]"'):
        cc.solve(sphere_into_block(6), method="amg")
    with pytest.raises(cc.SolverError, match=r'pip install "cvxcontact\[amg\]"'):
        cc.solve(_electrodes_scene(4), method="amg")                          # piezoelectric: the same refusal


def test_own_dofs():
    """Each row's own dof: of largest |coefficient| among the dofs no other row touches; None when a row has
    none (overlay rows) or when another row's own dof sits in a row (eliminating one would move the other)."""
    G = sp.csr_matrix(np.array([[1.0, -0.5, 0.0, 0.0], [0.0, -0.5, 2.0, 0.0], [0.0, 0.0, 0.0, 0.0]]))
    dof, coef = own_dofs(G)
    assert dof.tolist() == [0, 2, -1] and coef.tolist() == [1.0, 2.0, 0.0]
    assert own_dofs(sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 1.0]]))) is None
    assert own_dofs(sp.csr_matrix(np.array([[1.0, 0.5, 0.0], [0.0, 3.0, 0.0]]))) is None


def test_amg_does_not_take_2d_scenes():
    pytest.importorskip("pyamg")
    sol = cc.solve(two_blocks(6), method="amg")          # 2D: handed to the sparse route
    assert sol.ok and sol.info.method == "sparse"
    assert sol.info.handed_over.startswith("the AMG route cannot take it: method 'amg'")
    assert f"amg -> sparse, route: {Route.SPARSE_ACTIVE_SET} (handed over: the AMG" in sol.report()


def traced_steps(monkeypatch, amg) -> list:
    """The stop of each run of the AMG route's active-set steps, in order ("settled" or the Declined's name), filled
    as the route runs them (``amg.active_set_steps`` wrapped through ``monkeypatch``)."""
    seen, steps = [], amg.active_set_steps

    def traced(*args, **kwargs):
        out = steps(*args, **kwargs)
        seen.append(out.stop.name if isinstance(out, Declined) else "settled")
        return out

    monkeypatch.setattr(amg, "active_set_steps", traced)
    return seen


def wrong_when(monkeypatch, amg, seen, wrong) -> list:
    """The AMG route's Krylov solves whose tolerance ``wrong(rtol)`` picks return a wrong answer, the same whatever
    the set (x = 0, y = -1: every row's sign fails and the next set is always the same); the others solve as before
    (``amg.KrylovContact._system`` wrapped through ``monkeypatch``). Returns the (attempt, rtol) of each solve, filled
    as the route runs them, the attempt being the number of runs of the steps ``seen`` (:func:`traced_steps`) ended
    before it."""
    tolerances, system = [], amg.KrylovContact._system

    def maybe_wrong(self, active, F, g, x_start, rtol=amg.RTOL, verdict=None):
        tolerances.append((len(seen), rtol))
        if wrong(rtol):
            return np.zeros(self.n), -np.ones(self.m)
        return system(self, active, F, g, x_start, rtol, verdict)

    monkeypatch.setattr(amg.KrylovContact, "_system", maybe_wrong)
    return tolerances


def sparse_two_boxes(once):
    """The sparse route's answer on ``two_boxes(6)`` (the PZT-5A box on aluminium), the reference of the AMG retry
    tests: solved once per module (:func:`once`)."""
    return once(("sparse", "two_boxes", 6), lambda: cc.solve(two_boxes(6), method="sparse"))


def test_steps_that_cycle_on_loose_solves_are_retried_on_tight_ones(monkeypatch, once):
    """Set-picking (loose) solves that return a wrong answer, the same whatever the set (x = 0, y = -1: every
    row's sign fails and the next set is always the same), make the steps cycle on the PZT box on aluminium,
    and cycle again when retried on the tighter loose stages (``amg.RETRIES``); the route retries from the last
    set on tight solves and still returns the sparse route's answer, without handing over."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    seen = traced_steps(monkeypatch, amg)
    wrong_when(monkeypatch, amg, seen, lambda rtol: rtol != amg.RTOL)
    a = cc.solve(two_boxes(6), method="amg")
    assert seen == ["CYCLE", "CYCLE", "settled"] and a.info.method == "amg" and a.ok
    fields_agree(a, sparse_two_boxes(once), 1e-8)                        # measured 9.7e-11 (Krylov to 1e-10)


def test_steps_that_cycle_on_the_loosest_solves_are_retried_on_the_tighter_loose_stages(monkeypatch, once):
    """Wrong answers from the two loosest stages only (1e-1, 1e-2; x = 0, y = -1, whatever the set) make the
    steps cycle; the retry runs the tighter loose stages (1e-4, 1e-6, ``amg.RETRIES``) before RTOL, not RTOL alone,
    settles there, and returns the sparse route's answer without handing over."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    seen = traced_steps(monkeypatch, amg)
    tolerances = wrong_when(monkeypatch, amg, seen, lambda rtol: rtol > amg.STEP_RTOLS[2])
    a = cc.solve(two_boxes(6), method="amg")
    assert seen == ["CYCLE", "settled"] and a.info.method == "amg" and a.ok
    retry = [rtol for attempt, rtol in tolerances if attempt == 1]
    assert retry[0] == amg.STEP_RTOLS[2] and max(retry) <= amg.STEP_RTOLS[2] and amg.RTOL in retry
    fields_agree(a, sparse_two_boxes(once), 2e-8)                        # measured 1.3e-10 (5 kernels)


def test_the_retries_follow_a_changed_step_rtols(monkeypatch, once):
    """``amg.RETRIES`` is read through ``amg.STEP_RTOLS`` when the steps run (it copied STEP_RTOLS at import
    before, so a changed STEP_RTOLS left the retries on the old stages): by default the stages of each attempt are
    STEP_RTOLS, STEP_RTOLS[2:], () as before; with STEP_RTOLS = (1e-2, 1e-5) and wrong answers from the stage
    1e-2 (x = 0, y = -1) the steps cycle and the retry runs the new stage 1e-5 (at or below 1e-4), then RTOL, and
    settles on the sparse route's answer."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    assert [amg.loose_stages(c) for c in amg.RETRIES] == [amg.STEP_RTOLS, amg.STEP_RTOLS[2:], ()]
    monkeypatch.setattr(amg, "STEP_RTOLS", (1e-2, 1e-5))
    seen = traced_steps(monkeypatch, amg)
    tolerances = wrong_when(monkeypatch, amg, seen, lambda rtol: rtol > 1e-4)
    a = cc.solve(two_boxes(6), method="amg")
    assert seen == ["CYCLE", "settled"] and a.info.method == "amg" and a.ok
    assert {rtol for attempt, rtol in tolerances if attempt == 0} <= {1e-2, 1e-5, amg.RTOL}
    retry = [rtol for attempt, rtol in tolerances if attempt == 1]
    assert retry[0] == 1e-5 and set(retry) == {1e-5, amg.RTOL}, retry
    fields_agree(a, sparse_two_boxes(once), 1e-8)              # measured u 6.7e-11, phi 5.7e-11, force 3.0e-11


def test_steps_that_cycle_on_every_retry_hand_over_to_the_sparse_route(monkeypatch, caplog, once):
    """Wrong answers at every tolerance, RTOL included (x = 0, y = -1, whatever the set), make the steps cycle on
    the first attempt and on each retry of ``amg.RETRIES``: the retries are bounded (one attempt each, then the
    cold start's), the route hands the problem to the sparse route, says why in the log, and the answer is the
    sparse route's own."""
    import logging

    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    seen = traced_steps(monkeypatch, amg)
    wrong_when(monkeypatch, amg, seen, lambda rtol: True)
    with caplog.at_level(logging.INFO, logger="cvxcontact"):
        a = cc.solve(two_boxes(6), method="amg")
    assert seen == ["CYCLE"] * len(amg.RETRIES) and a.ok and a.info.method == "sparse"
    assert any("AMG route" in r.getMessage() and "cycle" in r.getMessage() for r in caplog.records)
    fields_agree(a, sparse_two_boxes(once), 1e-12)                       # measured 0 (the same factorised steps)
    assert a.info.handed_over.startswith("the AMG route's steps stopped: ") and "cycle" in a.info.handed_over
    assert a.report().splitlines()[1] == (f"  method           amg -> sparse, route: {Route.SPARSE_ACTIVE_SET} "
                                          f"(handed over: {a.info.handed_over})")


def test_steps_that_cycle_by_themselves_settle_on_the_tighter_loose_stages(monkeypatch):
    """Two aluminium boxes (``_elastic_boxes(1e9, 14)``, CG) whose own loose steps cycle (no answer altered: a set's
    1e-2 solve points to a set whose 1e-4 solve points back; on all five kernel sets): the retry from the last set
    runs the stages 1e-4, 1e-6 before RTOL, settles without a second cycle, and its answer is the sparse route's
    (the same active set, u and the contact force)."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    seen, tolerances, system = traced_steps(monkeypatch, amg), [], amg.KrylovContact._system

    def logged(self, active, F, g, x_start, rtol=amg.RTOL, verdict=None):
        tolerances.append((len(seen), rtol))
        return system(self, active, F, g, x_start, rtol, verdict)

    monkeypatch.setattr(amg.KrylovContact, "_system", logged)
    a = cc.solve(_elastic_boxes(1e9, 14), method="amg")
    assert seen == ["CYCLE", "settled"], "the scene no longer cycles: pick one that does to test the retry"
    retry = [rtol for attempt, rtol in tolerances if attempt == 1]
    assert retry[0] == amg.STEP_RTOLS[2] and retry[-1] == amg.RTOL and a.ok and a.info.method == "amg"
    fields_agree(a, cc.solve(_elastic_boxes(1e9, 14), method="sparse"), 2e-8)  # measured 1.5e-10 (5 kernels)


def _electrodes_scene(n=6):
    """A PZT-5A box pressed on an aluminium box (non-matching faces), driven at 200 V on its right face, a
    floating electrode with a charge on its left face, no grounded one."""
    from cvxcontact.physics import materials

    al = materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=max(1, n // 2))
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=n - 1, ny=n - 1, nz=max(1, n // 2))
    pzt = cc.Body(upper, materials.PZT5A, clamped=["top"], potential={"right": 200.0}, floating={"left": 1e-3},
                  name="PZT", body_force=(0.0, 0.0, -2e9), traction={"front": (0.0, 0.0, 3e8)})
    base = cc.Body(lower, al, clamped=["bottom"], name="aluminium")
    return cc.Scene(pzt, base, contacts=[cc.Contact(pzt, "bottom", base, "top", condition="sigma1")])


def test_amg_route_keeps_driven_and_floating_electrodes():
    """Driven and floating electrodes on the piezoelectric body (GMRES, block-triangular preconditioner): the
    sparse route's active set, fields, electrode potentials and charges."""
    pytest.importorskip("pyamg")
    scene = _electrodes_scene()
    a = cc.solve(scene, method="amg")
    b = cc.solve(scene, method="sparse")
    assert a.ok and b.ok and a.info.method == "amg" and a.info.route == Route.KRYLOV_ACTIVE_SET
    assert 0 < np.sum(a.contact.active) < len(a.contact.active)                  # measured 42 of 213
    fields_agree(a, b, 3e-8)                 # measured 2.5e-10 (5 kernels; 1.5e-10 before the 1e-6 stage)
    assert [(e.tag, e.kind) for e in a.electrodes] == [("right", "driven"), ("left", "floating")]
    # the route's answer is a Krylov solve to a relative residual of 1e-10 (amg.RTOL), which a floating
    # electrode's potential sees through the conditioning: measured 8.9e-11 and 2.0e-9 in two runs (the
    # hierarchy-rebuild rule depends on CPU time, so the iterations differ between runs)
    for ea, eb in zip(a.electrodes, b.electrodes):
        assert abs(ea.potential - eb.potential) < 1e-7 * abs(eb.potential)      # measured 0; 8.9e-11, 2.0e-9
        assert abs(ea.charge - eb.charge) < 1e-7 * abs(eb.charge)               # measured 1.1e-10; 8.5e-11, 4.6e-11
    assert a.residuals()["equilibrium"] < 1e-10                                   # measured 2.4e-12


def test_gmres_reaches_the_true_residual():
    """The route's GMRES against a dense solve, on a nonsymmetric system with a Jacobi preconditioner: the
    true residual below rtol with and without restarts, no iteration from the answer itself."""
    from cvxcontact.backends.amg import gmres

    rng = np.random.default_rng(3)
    n = 120
    K = sp.csr_matrix(np.diag(rng.uniform(1.0, 50.0, n)) + rng.normal(0.0, 0.5, (n, n)))
    b = rng.normal(size=n)
    x_ref = np.linalg.solve(K.toarray(), b)
    M = sp.diags(1.0 / K.diagonal())
    for restart in (120, 7):
        its = []
        x = gmres(K, b, np.zeros(n), M, 1e-10, restart=restart, callback=lambda: its.append(1))
        assert np.linalg.norm(b - K @ x) <= 1e-10 * np.linalg.norm(b)
        assert np.abs(x - x_ref).max() < 1e-8 * np.abs(x_ref).max()         # measured 6.6e-11, 4.6e-10
        assert 0 < len(its) < 300                                           # measured 26, 61
    its = []
    assert np.array_equal(gmres(K, b, x_ref, M, 1e-6, callback=lambda: its.append(1)), x_ref) and its == []


def test_block_triangular_preconditioner_with_exact_blocks():
    """With the V-cycles replaced by exact solves the route's preconditioner is P^-1, P = [[A, B], [0, -C]]:
    the eigenvalues of K P^-1 are real, in [1, 1 + rho^2], rho^2 the largest eigenvalue of B^T A^-1 B against
    C computed on its own (dense), on a bonded PZT-5A box on aluminium."""
    pytest.importorskip("pyamg")
    import scipy.linalg as sla

    from cvxcontact.backends.amg import KrylovContact

    kc = KrylovContact(cc.ContactSolver(two_boxes(4)).problem)
    seen, precondition = {}, kc._precondition

    def capture(K=None):
        seen["K"] = K
        return precondition(K)

    kc._precondition = capture
    kc._system(kc.dof >= 0, np.ones(kc.n), np.zeros(kc.m), None)             # every row closed
    K = seen["K"].tocsr()
    u, p = kc.u_idx, kc.p_idx
    A, B, C = K[u][:, u].toarray(), K[u][:, p].toarray(), -K[p][:, p].toarray()

    def exact(M):                          # a one-level hierarchy: its coarse solve is exact
        inv = np.linalg.inv(M)
        return SimpleNamespace(levels=[SimpleNamespace(A=M)], coarse_solver=lambda M, b: inv @ b)

    kc.ml_u, kc.ml_p = exact(A), exact(C)
    P_inv = kc._precondition(seen["K"])                          # the set's operator (amg.Reduced)
    KP = K.toarray() @ (P_inv @ np.eye(kc.n))
    ev = np.linalg.eigvals(KP)
    rho2 = sla.eigh(B.T @ np.linalg.solve(A, B), C, eigvals_only=True).max()
    assert 0.5 < rho2 < 1.0                                                       # measured 0.62 (PZT-5A)
    assert np.abs(ev.imag).max() < 1e-8
    assert ev.real.min() > 1 - 1e-8 and ev.real.max() < 1 + rho2 + 1e-8         # measured [1 - 7e-15, 1 + rho2 + 2e-16]


def test_one_hierarchy_per_geometry():
    """The hierarchy is built once, on the first set, and reused by every later set and re-solve (the contact
    dofs corrected per set): the same answer as the sparse route (PZT-5A box on aluminium, several sets)."""
    pytest.importorskip("pyamg")
    scene = two_boxes(8)
    solver = cc.ContactSolver(scene, method="amg")
    a = solver.solve()
    assert a.ok and a.info.method == "amg" and a.info.iterations >= 3                 # measured 4 sets
    assert solver.cache.amg.setups == 1
    fields_agree(a, cc.solve(scene, method="sparse"), 1e-8)                           # measured 7.4e-11 (u)
    again = solver.solve()
    assert again.ok and solver.cache.amg.setups == 1
    fields_agree(again, a, 1e-8)


def test_two_solves_are_bit_identical_and_leave_the_random_stream_alone():
    """pyamg starts its spectral-radius estimates from NumPy's global random stream: the set-up runs seeded (and
    restores the stream), so two fresh solves of one scene give the same bits and a caller's draws are unchanged
    (unseeded, two solves in one process differed by about 5e-13 relative)."""
    pytest.importorskip("pyamg")
    scene = two_boxes(6)
    np.random.seed(7)
    expected = np.random.rand(3)
    np.random.seed(7)
    a = cc.solve(scene, method="amg")
    b = cc.solve(scene, method="amg")
    assert np.array_equal(np.random.rand(3), expected)
    assert a.ok and b.ok and a.info.method == b.info.method == "amg"
    for ua, ub in zip(a.u, b.u):
        assert np.array_equal(ua, ub)


def test_contact_dof_correction():
    """The V-cycle of a hierarchy built on one set, corrected on the contact dofs for another set's system
    (KrylovContact._corrected), is a symmetric positive definite operator (CG's preconditioner), and exact when
    the V-cycle is: two elastic boxes, hierarchy on every row closed, system of every other row closed,
    operators formed densely column by column."""
    pytest.importorskip("pyamg")

    from cvxcontact.backends.amg import KrylovContact

    kc = KrylovContact(cc.ContactSolver(two_boxes(4, elastic=True)).problem)
    movable = kc.dof >= 0
    F, g = np.ones(kc.n), np.zeros(kc.m)
    kc._system(movable, F, g, None)                                                # the hierarchy: all closed
    other = movable & (np.arange(kc.m) % 2 == 0)
    R = kc._reduced(np.flatnonzero(other), F, g)[2]                               # the set's operator
    K = R.tocsr()
    assert K.shape == (kc.n, kc.n) and len(kc.p_idx) == 0
    P = np.column_stack([kc._corrected(R)(e) for e in np.eye(kc.n)])
    assert np.abs(P - P.T).max() <= 1e-10 * np.abs(P).max()                      # measured 2.9e-16 (relative)
    assert np.linalg.eigvalsh(0.5 * (P + P.T)).min() > 0

    inv = np.linalg.inv(K.toarray())
    kc.ml_u = SimpleNamespace(levels=[SimpleNamespace(A=K)], coarse_solver=lambda K, b: inv @ b)   # exact, one level
    P = np.column_stack([kc._corrected(R)(e) for e in np.eye(kc.n)])
    assert np.abs(P @ K.toarray() - np.eye(kc.n)).max() < 1e-8                    # measured 2.5e-15


def test_piezo_benchmark_bonded_part():
    """benchmarks/bench_piezo_amg.py's bonded part on a small PZT-5A box on aluminium: the route's block-
    triangular GMRES needs fewer iterations than block-diagonal MINRES, and both answers agree with PARDISO's
    (when Intel oneMKL loads)."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends.factor import pardiso_available

    out = benchmark("bench_piezo_amg").bonded_part(6, pardiso=pardiso_available())
    assert out["triangular_it"] < out["diagonal_it"]                             # measured 23 < 43
    assert out["triangular_vs_diagonal"] < 1e-8                                  # measured 2.8e-10
    if pardiso_available():
        assert out["triangular_vs_pardiso"] < 1e-8                              # measured 1.5e-10


def test_amg_resolve_after_a_load_change_agrees_with_the_sparse_route():
    """A ContactSolver's re-solve under other loads (S dropped after the first solve and stacked again, the
    hierarchy and the previous active set kept) gives the sparse route's answer for those loads, and going back
    to the first loads gives the first answer."""
    pytest.importorskip("pyamg")
    push, pull = _elastic_boxes(1e9, n=6), _elastic_boxes(-3e9, n=6)
    solver = cc.ContactSolver(push, method="amg")
    first = solver.solve()
    other = solver.solve(pull)
    back = solver.solve(push)
    assert first.ok and other.ok and back.ok and other.info.method == back.info.method == "amg"
    assert solver.cache.amg.setups == 1
    fields_agree(other, cc.solve(pull, method="sparse"), 1e-8)              # measured 3.5e-11 (u)
    fields_agree(back, first, 1e-8)                                          # measured 1.3e-10


def test_reduced_operator_is_the_formed_congruence():
    """A set's K = T^T S T + D applied unformed (``amg.Reduced``: the steps' Krylov operator) against the
    product formed by scipy from the same T and S, D = S's diagonal magnitudes at the eliminated dofs: its
    products (dense, every column), its contact rows, its coupling block and ``tocsr``; S stacked without the
    entries stored as 0.0 equals block_diag of the quasi-definite blocks with its zeros eliminated, arrays and
    all. A PZT-5A box on an aluminium box, every other row closed."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg
    from cvxcontact.backends.condensed import quasi_definite

    kc = amg.KrylovContact(cc.ContactSolver(two_boxes(4)).problem)
    plain = sp.block_diag([quasi_definite(b)[0] for b in kc._blocks], format="csr")
    plain.eliminate_zeros()
    S = kc._stacked()
    assert all(np.array_equal(a, b) for a, b in ((S.data, plain.data), (S.indices, plain.indices),
                                                 (S.indptr, plain.indptr)))
    assert amg.stacked(kc._blocks).nnz > S.nnz                  # the assembled blocks do store zeros
    rows = np.flatnonzero(kc.dof >= 0)[::2]
    T, _, K, _ = kc._reduced(rows, np.ones(kc.n), np.zeros(kc.m))
    slaves = kc.dof[rows]
    D = sp.csr_matrix((np.abs(plain.diagonal())[slaves], (slaves, slaves)), shape=(kc.n, kc.n))
    whole = (T.T @ plain @ T + D).toarray()
    scale = np.abs(whole).max()
    assert isinstance(K, amg.Reduced) and np.abs(K @ np.eye(kc.n) - whole).max() <= 1e-14 * scale   # measured 7.2e-18
    assert np.abs(K.tocsr().toarray() - whole).max() <= 1e-14 * scale                              # measured 2.9e-17
    idx = kc.u_idx[kc.interface]
    assert np.abs(K.rows(idx).toarray() - whole[idx]).max() <= 1e-14 * scale                       # measured 2.9e-17
    assert np.abs(K.coupling(kc.u_idx, kc.p_idx).toarray() - whole[np.ix_(kc.u_idx, kc.p_idx)]).max() \
        <= 1e-14 * scale                                                                           # measured 0
    others = np.setdiff1d(np.arange(kc.n), slaves)
    assert np.all(np.diag(whole)[slaves] > 0) and np.all(whole[np.ix_(slaves, others)] == 0)   # decoupled


def test_gmres_keeping_preconditioned_vectors_saves_the_update_application():
    """``gmres(keep=k)``: a cycle of at most k iterations applies the preconditioner once per iteration (not once
    more for the update), and gives the iterate of the plain update to rounding; a longer cycle still meets
    rtol. Nonsymmetric system, Jacobi preconditioner, against a dense solve."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.amg import gmres

    rng = np.random.default_rng(3)
    n = 120
    K = sp.csr_matrix(np.diag(rng.uniform(1.0, 50.0, n)) + rng.normal(0.0, 0.5, (n, n)))
    b = rng.normal(size=n)
    x_ref = np.linalg.solve(K.toarray(), b)
    d = 1.0 / K.diagonal()
    for rtol, keep in ((1e-2, 10), (1e-10, 10), (1e-10, 120)):
        out = {}
        for k in (0, keep):
            applied, its = [], []
            M = spla.LinearOperator((n, n), matvec=lambda r, tally=applied: tally.append(1) or d * r, dtype=float)
            out[k] = gmres(K, b, np.zeros(n), M, rtol, callback=lambda tally=its: tally.append(1), keep=k)
            assert np.linalg.norm(b - K @ out[k]) <= rtol * np.linalg.norm(b)
            assert len(applied) == len(its) + (0 if k >= len(its) else 1)      # one cycle (restart 100)
        assert 0 < len(its) <= 100                                          # measured 10, 26, 26
        assert np.abs(out[keep] - out[0]).max() <= 1e-12 * np.abs(x_ref).max()   # measured 5.1e-16 at most



def test_gmres_keeping_preconditioned_vectors_across_restarts():
    """``gmres(keep=k)`` over several restart cycles: each cycle keeps its own preconditioned vectors (not the
    first cycle's), so with ``restart`` <= k no cycle applies the preconditioner beyond its iterations, and the
    iterate is the plain update's to rounding; a ``keep`` below ``restart`` too. Nonsymmetric, diagonally
    dominant system, Jacobi preconditioner, against a dense solve."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.amg import gmres

    rng = np.random.default_rng(5)
    n = 60
    A = np.diag(rng.uniform(1.0, 3.0, n)) + rng.normal(0.0, 0.08, (n, n))
    K, b = sp.csr_matrix(A), rng.normal(size=n)
    x_ref = np.linalg.solve(A, b)
    d = 1.0 / np.diag(A)
    for restart, keep in ((4, 10), (12, 5)):
        out = {}
        for k in (0, keep):
            applied, its = [], []
            M = spla.LinearOperator((n, n), matvec=lambda r, tally=applied: tally.append(1) or d * r, dtype=float)
            out[k] = gmres(K, b, np.zeros(n), M, 1e-10, restart=restart, keep=k,
                           callback=lambda tally=its: tally.append(1))
            assert np.linalg.norm(b - K @ out[k]) <= 1e-10 * np.linalg.norm(b)
            assert len(its) > restart                                       # two cycles or more: measured 23, 22
            if k >= restart:
                assert len(applied) == len(its)                             # measured 23 (29 with keep=0)
        assert np.abs(out[keep] - out[0]).max() <= 1e-12 * np.abs(x_ref).max()   # measured 1.4e-16, 1.9e-16
        assert np.abs(out[keep] - x_ref).max() <= 1e-6 * np.abs(x_ref).max()     # measured 5.5e-11, 2.5e-11

class _Formed(sp.csr_matrix):
    """A set's K formed, read as the route read it before :class:`~cvxcontact.backends.amg.Reduced`."""

    def rows(self, idx):
        return self[idx]

    def coupling(self, u_idx, p_idx):
        return self[:, p_idx][u_idx].tocsr()


def test_unformed_steps_take_the_formed_matrix_steps():
    """The steps with each set's K applied unformed (``amg.Reduced``) take the sets, steps and Krylov iterations
    of the same route handed each set's K formed (``tocsr``, as before the operator), and give its answer to
    rounding: a PZT-5A box on an aluminium box with several sets (GMRES) and two elastic boxes (CG)."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    plain = amg.KrylovContact._reduced

    def formed(self, rows, F, g):
        T, x_fix, K, b = plain(self, rows, F, g)
        return T, x_fix, (_Formed(K.tocsr()) if isinstance(K, amg.Reduced) else K), b

    for scene in (two_boxes(6), _elastic_boxes(3e8)):
        unformed = cc.ContactSolver(scene, method="amg")
        a = unformed.solve()
        amg.KrylovContact._reduced = formed
        try:
            whole = cc.ContactSolver(scene, method="amg")
            b = whole.solve()
        finally:
            amg.KrylovContact._reduced = plain
        assert a.ok and b.ok and a.info.iterations == b.info.iterations >= 2          # measured 3 and 3 steps
        assert unformed.cache.amg.iterations == whole.cache.amg.iterations
        assert np.array_equal(a.contact.active, b.contact.active)
        for ua, ub in zip(a.u, b.u):
            assert np.abs(ua - ub).max() <= 1e-12 * np.abs(ub).max()                  # measured 1.4e-15, 8.2e-16


def test_loose_gmres_solves_of_the_route_apply_no_preconditioner_for_their_update(monkeypatch):
    """The route's loose GMRES solves (``STEP_RTOLS``) keep their preconditioned vectors (``LOOSE_KEEP``): one
    that stops within LOOSE_KEEP iterations applies the preconditioner once per iteration, the answer's solve
    (RTOL, keeping none) once more for its update. A PZT-5A box on an aluminium box (GMRES)."""
    pytest.importorskip("pyamg")
    import scipy.sparse.linalg as spla

    from cvxcontact.backends import amg

    plain, seen = amg.gmres, []

    def spy(K, b, x0, M, rtol, *args, **kw):
        applied, its = [], []
        counted = spla.LinearOperator(M.shape, matvec=lambda r: applied.append(1) or M @ r, dtype=float)
        callback = kw.pop("callback", None)
        x = plain(K, b, x0, counted, rtol, *args, callback=lambda: its.append(1) or callback and callback(), **kw)
        seen.append((rtol, len(its), len(applied)))
        return x

    monkeypatch.setattr(amg, "gmres", spy)
    assert cc.ContactSolver(two_boxes(4), method="amg").solve().ok
    loose = [(i, a) for rtol, i, a in seen if rtol > amg.RTOL and 0 < i <= amg.LOOSE_KEEP]
    tight = [(i, a) for rtol, i, a in seen if rtol == amg.RTOL and 0 < i <= amg.GMRES_RESTART]
    assert loose and tight                     # measured (iterations, applications): (2, 2) ... (4, 4); (11, 12)
    assert all(a == i for i, a in loose) and all(a == i + 1 for i, a in tight)


def test_gmres_stops_where_its_iterate_is_settled():
    """``gmres(settled=...)``: asked after each iteration k <= keep of the first cycle with the iterate x_k, a True
    answer returns x_k at once: the bits of the same solve stopped by ``maxiter=k`` (the same update), whatever its
    residual; never asked beyond ``keep``. Nonsymmetric system, Jacobi preconditioner."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.amg import gmres

    rng = np.random.default_rng(5)
    n = 80
    K = sp.csr_matrix(np.diag(rng.uniform(1.0, 50.0, n)) + rng.normal(0.0, 0.5, (n, n)))
    b = rng.normal(size=n)
    M = spla.LinearOperator((n, n), matvec=lambda r: r / K.diagonal(), dtype=float)
    for stop in (1, 3, 6):
        asked = []

        def settled(x, asked=asked, stop=stop):
            asked.append(np.array(x))
            return len(asked) == stop

        x = gmres(K, b, np.zeros(n), M, 1e-12, settled=settled, keep=8)
        assert len(asked) == stop and np.array_equal(x, asked[-1])
        assert np.array_equal(x, gmres(K, b, np.zeros(n), M, 1e-12, maxiter=stop, keep=8))
        assert np.linalg.norm(b - K @ x) > 1e-12 * np.linalg.norm(b)
    asked = []
    x = gmres(K, b, np.zeros(n), M, 1e-12, settled=lambda x: asked.append(1) and False, keep=4)
    assert len(asked) == 4 and np.linalg.norm(b - K @ x) <= 1e-12 * np.linalg.norm(b)


@pytest.mark.parametrize("make", [lambda: two_boxes(6), lambda: _elastic_boxes(1e9, n=12)],
                         ids=["pzt-on-aluminium-gmres", "aluminium-cg"])
def test_loose_solves_stop_once_two_iterates_agree_on_the_next_set(make, monkeypatch):
    """A loose solve (``STEP_RTOLS``) of a set whose signs fail stops at the first iteration whose iterate implies
    the same next set as the iterate before it (``SETTLE``), and the step moves to that set; a solve whose
    iterates never agree so meets its tolerance; the answer's solve (RTOL) never asks. The answer is the one
    found with the loose solves run to their tolerances, and the sparse route's."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    calls, system = [], amg.KrylovContact._system

    def traced(self, active, F, g, x_start, rtol=amg.RTOL, verdict=None):
        asked = []

        def told(x, y):
            asked.append(verdict(x, y))
            return asked[-1]
        out = system(self, active, F, g, x_start, rtol, told)
        calls.append((rtol, asked, None if out is None else verdict(*out)))
        return out

    monkeypatch.setattr(amg.KrylovContact, "_system", traced)
    scene = make()
    a = cc.solve(scene, method="amg")
    early = 0
    for rtol, asked, final in calls:
        same = [k for k in range(1, len(asked)) if asked[k] is not None and asked[k - 1] is not None
                and np.array_equal(asked[k], asked[k - 1])]
        if rtol == amg.RTOL:
            assert not asked
        elif same:                                              # stopped at the first agreement, and moved there
            assert same[0] == len(asked) - 1 and np.array_equal(final, asked[-1])
            early += 1
    assert early >= 1                                           # measured 1 (GMRES), 3 (CG)
    monkeypatch.setattr(amg, "SETTLE", False)
    b = cc.solve(scene, method="amg")
    assert a.ok and b.ok and a.info.method == b.info.method == "amg"
    assert np.array_equal(a.contact.active, b.contact.active)
    fields_agree(a, b, 3e-8)                                   # measured 1.1e-10, 9.3e-11 (Krylov to 1e-10)
    fields_agree(a, cc.solve(scene, method="sparse"), 5e-8)    # measured 1.5e-10, 3.2e-10 (5 kernels)


@pytest.mark.parametrize("make", [lambda: two_boxes(6), lambda: _elastic_boxes(1e9, n=16)],
                         ids=["pzt-on-aluminium-gmres", "aluminium-cg"])
def test_settled_stops_that_mispredict_the_next_set_still_give_the_checked_answer(make, monkeypatch):
    """The settled stop's mechanism, whatever the scene's iterates: a verdict that always names the same (wrong)
    next set makes every loose solve (GMRES and CG) that reaches its second iterate stop there (structural: the
    first two answers agree), the answer's solve (RTOL) never asks, and the steps, moved by those 2-iteration
    iterates' own signs, still end on the sparse route's set and answer through the route's own checks (a
    mispredicted set is left by the next step, or the steps cycle and are retried on tight solves), not handed
    over."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    calls, system = [], amg.KrylovContact._system

    def wrong(self, active, F, g, x_start, rtol=amg.RTOL, verdict=None):
        asked = []

        def told(x, y):
            asked.append(1)
            return np.zeros(self.m, dtype=bool)                 # the same next set at every iterate
        out = system(self, active, F, g, x_start, rtol, told)
        calls.append((rtol, len(asked)))
        return out

    monkeypatch.setattr(amg.KrylovContact, "_system", wrong)
    scene = make()
    a = cc.solve(scene, method="amg")
    assert all(n == 0 for rtol, n in calls if rtol == amg.RTOL)
    assert all(n <= 2 for rtol, n in calls if rtol > amg.RTOL)
    assert any(n == 2 for _, n in calls)                        # measured 3 stops (GMRES), 4 (CG; 5 kernels)
    assert a.ok and a.info.method == "amg"
    fields_agree(a, cc.solve(scene, method="sparse"), 3e-8)    # measured 1.6e-10, 1.4e-10 (5 kernels)


def test_v_cycle_is_pyamgs_preconditioner_without_its_residual_norms(monkeypatch):
    """``amg.v_cycle`` gives the bits of pyamg's ``aspreconditioner(cycle="V")`` on the route's own hierarchies
    (the displacement block node-blocked, the potential block scalar; several levels each), and the route's steps
    with it take the same sets, Krylov iterations and answer, bit for bit (a PZT-5A box on aluminium). What it
    leaves out (pyamg's two residual norms of the finest level per cycle) is timed in benchmarks only."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    solver = cc.ContactSolver(two_boxes(8), method="amg")
    lean = solver.solve()
    kc = solver.cache.amg
    rng = np.random.default_rng(3)
    for ml in (kc.ml_u, kc.ml_p):
        assert len(ml.levels) >= 2                                       # measured 2 (u) and 2 (phi)
        for _ in range(3):
            b = rng.standard_normal(ml.levels[0].A.shape[0])
            assert np.array_equal(amg.v_cycle(ml) @ b, ml.aspreconditioner(cycle="V") @ b)
    # the route's hierarchies here have two levels, which never recurse: the same blocks with deeper and
    # one-level hierarchies (the cycle's recursion, pyamg's one-level branch), and a float32 right-hand side
    # (pyamg's solve casts it to the operator's dtype)
    import pyamg

    for A, coarse in ((kc.ml_u.levels[0].A, 5), (kc.ml_p.levels[0].A, 5), (kc.ml_p.levels[0].A, 10 ** 6)):
        ml = pyamg.smoothed_aggregation_solver(A, symmetry="symmetric", max_coarse=coarse)
        assert len(ml.levels) == (1 if coarse > A.shape[0] else 3) or len(ml.levels) > 3   # measured 3, 3, 1
        b = rng.standard_normal(A.shape[0])
        assert np.array_equal(amg.v_cycle(ml) @ b, ml.aspreconditioner(cycle="V") @ b)
        b32 = b.astype(np.float32)
        assert np.array_equal(amg.v_cycle(ml) @ b32, ml.aspreconditioner(cycle="V") @ b32)
    monkeypatch.setattr(amg, "v_cycle", lambda ml: ml.aspreconditioner(cycle="V"))
    plain_solver = cc.ContactSolver(two_boxes(8), method="amg")
    plain = plain_solver.solve()
    assert lean.ok and plain.ok and lean.info.iterations == plain.info.iterations >= 2      # measured 4
    assert kc.iterations == plain_solver.cache.amg.iterations
    assert np.array_equal(lean.contact.active, plain.contact.active)
    for a, b in zip(lean.u, plain.u):
        assert np.array_equal(a, b)
    for a, b in zip(lean.phi, plain.phi):
        assert (a is None and b is None) or np.array_equal(a, b)
