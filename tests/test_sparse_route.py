"""The sparse route for long interfaces (issue 13, cvxcontact/backends/sparse.py): active-set steps on the
sparse mixed system (26), cross-checked against the condensed and full backends and a dense solve."""

import warnings

import numpy as np
import pytest
from conftest import fields_agree, rel
from references import direct_mixed_solve

import cvxcontact as cc
import cvxcontact.backends as backends
from cvxcontact.apps.demo import thin_layer, thin_layer_nodes
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.sparse import SparseContact
from cvxcontact.solution.info import Route

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


@pytest.fixture(scope="module")
def layer():
    return thin_layer(40)


@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
def test_sparse_agrees_with_condensed_and_full_on_two_blocks(scene, solutions, condition):
    sol = cc.solve(scene, condition, method="sparse")
    assert sol.ok and sol.info.method == "sparse" and sol.info.route == Route.SPARSE_ACTIVE_SET
    assert sol.info.iterations >= 1 and sol.polished
    fields_agree(sol, solutions[condition], 1e-10)                 # condensed (the default here)
    fields_agree(sol, cc.solve(scene, condition, method="full"), 1e-10)


def test_sparse_matches_a_dense_solve_of_the_mixed_system(scene):
    sol = cc.solve(scene, method="sparse")
    u, phi, lam, force, _ = direct_mixed_solve(scene, sol)    # dense LU of (26) on the active set, SI
    for k in range(2):
        assert rel(sol.u[k], u[k]) < 1e-10
    assert rel(sol.phi[0], phi[0]) < 1e-10
    assert rel(sol.contact.force, force) < 1e-10 and (force >= 0).all()


def test_thin_layer_scene_has_a_genuine_active_set_and_the_routes_agree(layer):
    assert layer.stack.size == thin_layer_nodes(40) == 40 + 29 - 1 + 1
    assert thin_layer_nodes(3000) >= 5000                           # the benchmark size of issue 13
    sol = cc.solve(layer, method="sparse")
    assert sol.ok and sol.info.method == "sparse"
    active = np.asarray(sol.contact.active)
    assert 0.2 * len(active) < active.sum() < 0.95 * len(active)  # neither empty nor full
    assert not active[0] and not active[-1]                        # open at the clamped ends (the crown)
    # both routes exact on the same active set; the slender layer's forces carry its conditioning: u measured
    # 2.4e-13 .. 5.0e-12, phi <= 6.2e-13, the force 6.2e-13 .. 1.7e-10 (Haswell, Sandybridge, Nehalem, Prescott
    # OpenBLAS kernels; the largest once each under Sandybridge and Prescott), so 1e-9 and 2e-8 (>= 160x, 115x)
    fields_agree(sol, cc.solve(layer, method="full"), 1e-9, force_tol=2e-8)
    # the condensed route too, its closed rows refined after its finish (Condensation.invert_closed; before, they
    # were met to ~1e-11 U_a only: ResidualWarning): measured u <= 3.8e-13, phi <= 5e-14, force <= 1.4e-12
    # (default, Prescott, Sandybridge)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        condensed = cc.solve(layer, method="condensed")
    assert condensed.ok
    fields_agree(sol, condensed, 1e-9, force_tol=2e-8)


def test_capacitance_steps_match_refactorised_steps(layer):
    """The capacitance (bordered) solves on a base factor give the same steps as a refactorisation at
    every step: cap=0 refactorises each step, a large cap reuses the first factor throughout."""
    solver = cc.ContactSolver(layer, method="sparse")
    solver.solve()
    blocks, E = list(solver.problem.blocks), solver.problem.E
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    g = np.asarray(solver.cache.sparse._g)
    every, reuse = SparseContact(blocks, E, cap=0), SparseContact(blocks, E, cap=10**6)
    a, b = every.solve(F, g), reuse.solve(F, g)
    assert reuse.factorizations == 1 and every.factorizations == a[4] > 1 and reuse.column_solves > 0
    assert np.array_equal(a[3], b[3]) and b[4] <= a[4]      # (near one factor the steps settle on its columns)
    assert rel(np.concatenate(a[0]), np.concatenate(b[0])) < 1e-10 and rel(a[2], b[2]) < 1e-10


def test_long_interface_steps_settle_on_the_base_columns_and_reach_the_full_answer():
    """thin_layer(200) (348 merged nodes, non-matching traces: a saw-tooth of open rows inside the contact zone,
    rows flipping a few at a time near the answer): the steps near a base factor settle on its capacitance
    columns (SparseContact._settle), then one exact solve checks the set. The same active set and answer as
    the full CVXPY model and as the plain steps (a refactorisation and an exact solve every step, cap=0)."""
    scene = thin_layer(200)
    solver = cc.ContactSolver(scene, method="sparse")
    sol = solver.solve()
    assert sol.ok and sol.info.route == Route.SPARSE_ACTIVE_SET
    # measured u 3.8e-14 / 4.0e-13, phi 5.7e-14, the force 3.3e-11 (its conditioning, as above): >= 250x, 600x
    fields_agree(sol, cc.solve(scene, method="full"), 1e-10, force_tol=2e-8)
    sc = solver.cache.sparse
    blocks, E = list(solver.problem.blocks), solver.problem.E
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    plain = SparseContact(blocks, E, cap=0, factorization=sol.info.factorization)
    u, _, y, active, _ = plain.solve(F, np.asarray(sc._g))
    settled = SparseContact(blocks, E, factorization=sol.info.factorization)
    u2, _, y2, active2, steps2 = settled.solve(F, np.asarray(sc._g))
    assert np.array_equal(active, sol.contact.active) and np.array_equal(active2, active)
    assert rel(np.concatenate(u), np.concatenate(u2)) < 1e-10 and rel(y, y2) < 2e-8
    # systems solved: measured 6-9 (they follow the measured cap) against 14 plain steps; factorisations 5-7
    assert max(steps2, sol.info.iterations) <= 16 and max(settled.factorizations, sc.factorizations) <= 14


@pytest.mark.parametrize(("delta", "bound"), [(1e-2, 1e-10), (1e-4, 1e-8)])   # measured 6.6e-13, 6.7e-11
def test_capacitance_steps_with_compliant_rows_match_refactorised_steps(delta, bound):
    """The regularised stage of the "gamma3" route (dependent overlay rows between two 3D boxes, each closed row
    compliant by delta times its own compliance): the capacitance form on one base factor (the compliant rows'
    diagonal in its bordered system) takes the same Newton steps as a refactorisation at every step."""
    from scenes3d import two_boxes

    problem = cc.ContactSolver(two_boxes(6, "gamma3", elastic=True), "gamma3", method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    soft = delta * SparseContact(blocks, E).w
    every, reuse = SparseContact(blocks, E, cap=0, soft=soft), SparseContact(blocks, E, cap=10**6, soft=soft)
    bonded = np.ones(E.shape[0], dtype=bool)
    a, b = every.regularised(F, g, bonded), reuse.regularised(F, g, bonded)
    assert reuse.factorizations == 1 and every.factorizations == a[2] > 1 and reuse.column_solves > 0
    assert np.array_equal(a[1], b[1]) and a[2] == b[2]
    assert rel(b[0], a[0]) < bound


def test_auto_takes_the_sparse_route_above_the_threshold(monkeypatch, layer):
    assert cc.ContactSolver(layer).method == "condensed"             # 69 rows: below SPARSE_ROWS
    monkeypatch.setattr(backends, "SPARSE_ROWS", 50)
    sol = cc.solve(layer)
    assert sol.info.method == "sparse" and sol.info.requested == "auto" and sol.ok
    law = cc.NormalCompliance(stiffness=1e12)                       # compliance: left to condensed
    assert cc.ContactSolver(layer, law=law).method == "condensed"


def test_resolve_starts_from_the_previous_active_set(layer):
    solver = cc.ContactSolver(layer, method="sparse")
    first = solver.solve()
    assert first.info.route == Route.SPARSE_ACTIVE_SET and first.info.factorizations == 1
    other = thin_layer(40, pressure=1.1e6, voltage=50.0)
    again = solver.solve(other)
    assert again.ok and again.info.route == Route.WARM_START
    assert again.info.iterations < first.info.iterations
    fields_agree(again, cc.solve(other, method="full"), 1e-10)


def test_sparse_refuses_what_it_cannot_take(scene):
    with pytest.raises(cc.SolverError, match="'sparse' does not accept"):
        cc.solve(scene, method="sparse", law=cc.NormalCompliance(stiffness=1e12))
    with pytest.raises(cc.SolverError, match="'sparse' does not accept"):
        cc.solve(scene, method="sparse", degree=2)                  # the P2 conic condition
    with pytest.raises(cc.SceneError, match="n must be an int"):
        thin_layer(1)


@pytest.mark.parametrize("make", ["punch_gamma3", "punch_sigma2", "three_bodies", "circle"])
def test_sparse_agrees_with_condensed_on_pairs_and_obstacles(make):
    """Partial overlap with a prescribed approach, three bodies (two pairs), a rigid circle."""
    from pair_scenes import block_on, elastic_punch

    if make.startswith("punch"):
        scene = elastic_punch(condition=make.split("_")[1])[0]
    elif make == "circle":
        scene = block_on(cc.Rigid.circle((0.5, -0.3 - 1e-4), 0.3))
    else:
        steel, alu = cc.materials.isotropic(E=210e9, nu=0.3), cc.materials.isotropic(E=70e9, nu=0.33)
        top = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(0.3, 0.5), nx=4, ny=2), steel, clamped="top", contact="bottom",
                      body_force=(0.0, -5e9))
        mid = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.3), nx=6, ny=2), alu, clamped="left", contact="top")
        bot = cc.Body(cc.rectangle(x=(0.1, 0.9), y=(-0.3, 0.0), nx=5, ny=2), steel, clamped="bottom", contact="top")
        scene = cc.Scene(top, mid, bot, contacts=[cc.Contact(top, "bottom", mid, "top"),
                                                  cc.Contact(mid, "bottom", bot, "top")])
    sol, ref = cc.solve(scene, method="sparse"), cc.solve(scene, method="condensed")
    assert sol.ok and sol.info.method == "sparse" and 0 < np.sum(sol.contact.active)
    for ua, ub in zip(sol.u, ref.u):
        assert rel(ua, ub) < 1e-10
    assert rel(sol.contact.force, ref.contact.force) < 1e-10


def test_registry_prefers_sparse_for_long_interfaces_only():
    from cvxcontact.backends import SPARSE_ROWS, ProblemDescription, choose

    long = SPARSE_ROWS + 1
    assert choose("auto", ProblemDescription(contact_rows=SPARSE_ROWS)) == "condensed"
    assert choose("auto", ProblemDescription(contact_rows=long)) == "sparse"
    assert choose("auto", ProblemDescription(contact_rows=long, compliant=True)) == "condensed"
    assert choose("auto", ProblemDescription(contact_rows=long, conic=True)) == "condensed"
    # a body held by the contact only: the condensed route (backends/forced.py), never the sparse one
    assert choose("auto", ProblemDescription(contact_rows=long, held_by_contact=True)) == "condensed"
    assert choose("auto", ProblemDescription(contact_rows=long, held_by_contact=True, compliant=True,
                                             kind="compliance")) == "full"
    assert choose("sparse", ProblemDescription(contact_rows=3)) == "sparse"        # named: any size


def test_unpivoted_factorisation_in_the_route_order_solves_the_bonded_system(layer):
    """ordering() puts each contact row after its dofs so that no pivoting is needed: the factor solves
    the bonded mixed system as SciPy's pivoting spsolve does."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.elimination import factorize, ordering

    solver = cc.ContactSolver(layer, method="sparse")
    solver.solve()
    sc = solver.cache.sparse
    K = sc.matrix(np.ones(sc.m, dtype=bool))
    perm = ordering(K, sc.n + np.arange(sc.m))
    assert sorted(perm) == list(range(K.shape[0]))
    pos = np.empty(len(perm), dtype=int)
    pos[perm] = np.arange(len(perm))
    Kc = K.tocsc()
    for a in range(sc.m):                       # each contact row after every dof it couples to
        j = sc.n + a
        assert pos[j] >= pos[Kc.indices[Kc.indptr[j]:Kc.indptr[j + 1]]].max()
    b = np.concatenate([sc.F, sc._g])
    assert rel(factorize(K, perm).solve(b), spla.spsolve(K, b)) < 1e-8


def test_auto_falls_back_to_the_sparse_route_when_the_condensed_answer_fails_its_checks(monkeypatch):
    """thin_layer: a slender layer clamped at its ends has an ill-conditioned interface compliance; the
    condensed answer without its closed rows refined (:meth:`Condensation.invert_closed` replaced by the plain
    back-substitution, as before the refinement) fails the checks of (26)-(27) (measured: 5e-6
    complementarity). method="auto" then re-solves the mixed system from the condensed active set, and
    says so in the route; an explicit method="condensed" keeps its answer and, if it fails, warns. With the
    refinement the condensed answer passes (auto keeps it)."""
    from cvxcontact.backends.interface import Condensation

    scene = thin_layer(50)
    ref = cc.solve(scene, method="full")
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        kept = cc.solve(scene)
    assert kept.ok and kept.info.method == "condensed" and kept.info.route != cc.Route.SPARSE_FALLBACK
    monkeypatch.setattr(Condensation, "invert_closed",
                        lambda self, problem, y, active, timings: (*self.invert(problem, y, timings), y))
    solver = cc.ContactSolver(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                    # no warning: the answer passes its checks
        warnings.simplefilter("ignore", cc.ResolutionWarning)   # coarse by design: the resolution check names it
        sol = solver.solve()
        again = solver.solve(thin_layer(50, pressure=0.5e6))
    assert sol.ok and sol.info.method == "sparse" and sol.info.route == cc.Route.SPARSE_FALLBACK
    assert sol.info.handed_over.startswith("the condensed answer fails its checks (complementarity")
    assert sol.report().splitlines()[1] == (f"  method           auto -> sparse, route: {cc.Route.SPARSE_FALLBACK} "
                                            f"(handed over: {sol.info.handed_over})")
    assert kept.report().splitlines()[1] == f"  method           auto -> condensed, route: {kept.info.route}"
    for a, b in zip(ref.u, sol.u):
        assert rel(b, a) < 1e-10
    assert again.ok and again.info.method == "sparse"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        explicit = cc.solve(scene, method="condensed")
    assert explicit.info.method == "condensed"
    assert explicit.ok or any(issubclass(w.category, cc.ResidualWarning) for w in caught)    # never silent


@pytest.mark.skipif(not __import__("cvxcontact.backends.factor", fromlist=["x"]).pardiso_available(),
                    reason="Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
def test_sparse_route_with_pardiso_matches_superlu_and_the_full_model():
    """The sparse route's factorisations through PARDISO (analysis once, numeric factorisations per step):
    the same active-set steps and the same answer as with SuperLU, and as the full CVXPY model."""
    scene = thin_layer(60)
    a = cc.ContactSolver(scene, method="sparse", factorization="pardiso")
    sol = a.solve()
    ref = cc.solve(scene, method="sparse", factorization="superlu")
    assert sol.ok and sol.info.factorization == "pardiso" and ref.info.factorization == "superlu"
    assert np.array_equal(sol.contact.active, ref.contact.active)     # (the step counts follow each one's cap)
    fields_agree(sol, ref, 1e-10)
    fields_agree(sol, cc.solve(scene, method="full"), 1e-9)
    again = a.solve(thin_layer(60, pressure=0.6e6))
    assert again.ok and again.info.route == Route.WARM_START
    fields_agree(again, cc.solve(thin_layer(60, pressure=0.6e6), method="full"), 1e-9)


@pytest.mark.skipif(not __import__("cvxcontact.backends.factor", fromlist=["x"]).pardiso_available(),
                    reason="Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
def test_resolve_on_an_object_left_by_another_start_reaches_the_fresh_answer():
    """The state a solve leaves on a SparseContact (the base factor, PARDISO's analysis, whose scaling and
    matching come from the values of the first matrix it factorised) does not decide a later solve: on
    thin_layer(200), a first solve from every other row closed leaves an analysis on which the bonded start's
    steps meet a system that fails its check (118-170 perturbed pivots; before the fresh retry the solve returned
    None); the retry from a fresh factorisation and analysis gives the fresh object's answer, which SuperLU (its
    ordering from the pattern alone) and the full model confirm."""
    scene = thin_layer(200)
    problem = cc.ContactSolver(scene, method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    half = np.arange(E.shape[0]) % 2 == 0
    fresh = SparseContact(blocks, E, cap=24, factorization="pardiso").solve(F, g)
    other = SparseContact(blocks, E, cap=24, factorization="superlu").solve(F, g)
    used = SparseContact(blocks, E, cap=24, factorization="pardiso")
    first = used.solve(F, g, active=half)                         # the same problem from another start
    again = used.solve(F, g)                                       # then from the bonded start, as a re-solve
    assert used.factorization == "pardiso" and first is not None and again is not None
    for out in (first, again, other):
        assert np.array_equal(out[3], fresh[3])
        # measured u <= 3.5e-14, y <= 1.4e-12 (Haswell, Prescott, Sandybridge kernels): 1e-11, 1e-9 >= 280x, 700x
        assert rel(np.concatenate(out[0]), np.concatenate(fresh[0])) < 1e-11 and rel(out[2], fresh[2]) < 1e-9
    full = cc.solve(scene, method="full")
    assert np.array_equal(np.asarray(full.contact.active), again[3])


def test_a_retry_from_a_fresh_factorisation_counts_the_systems_of_every_attempt(monkeypatch, layer):
    """SparseContact.solve retries from a fresh factorisation when its steps on the base a previous solve left stop
    (SparseContact._attempts); the count it reports is that of the systems solved exactly by all its attempts.
    Forced: the first attempt's steps are cut after one system (it ends MAX_ITER, as steps that stop do). The retry
    takes a fresh object's path (same cap; SuperLU, its ordering from the pattern alone), so the count is 1 + the
    fresh object's, and a spy on the exact solves counts the same; the answer is the fresh object's."""
    from cvxcontact.backends import sparse as module

    problem = cc.ContactSolver(layer, method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    free = ~problem.held_rows
    fresh = SparseContact(blocks, E, cap=24, factorization="superlu").solve(F, g, free)
    assert fresh is not None and fresh[4] >= 2                   # the bonded start is not the answer
    used = SparseContact(blocks, E, cap=24, factorization="superlu")
    assert used.solve(F, g, np.arange(E.shape[0]) % 2 == 0) is not None and used.attempts == 1   # leaves a base
    real, cuts, solved = module.active_set_steps, [], []

    def cut_first(step, start, max_iter):
        cuts.append(max_iter)
        return real(step, start, 1 if len(cuts) == 1 else max_iter)

    def counted(self, active, system=SparseContact._system):
        z = system(self, active)
        solved.append(z is not None)
        return z

    monkeypatch.setattr(module, "active_set_steps", cut_first)
    monkeypatch.setattr(SparseContact, "_system", counted)
    again = used.solve(F, g, free)
    assert again is not None and used.attempts == len(cuts) == 2
    assert again[4] == sum(solved) == 1 + fresh[4]
    assert np.array_equal(again[3], fresh[3])
    # measured 0 (the same path, the same factorisations); 1e-12 for any rounding of a refactorised base
    assert rel(np.concatenate(again[0]), np.concatenate(fresh[0])) < 1e-12 and rel(again[2], fresh[2]) < 1e-10


# ================================================================ rows against a side that does not move

def _floor_reference(body):
    """Dense primal-dual active-set solve of ``body`` (clamped somewhere) on a rigid floor at y = 0 with a zero
    gap, rows -u_y <= 0 at the bottom nodes that have a free u_y (tests/reference_problems.py): per-node (n, 2)."""
    from reference_problems import active_set_solve, per_body, stiffness

    systems, off, K, f = stiffness([body])
    s = systems[0]
    nodes = np.unique(body.mesh.boundary("bottom"))
    dof = np.flatnonzero(np.isin(s.u_free, 2 * nodes + 1))      # the bottom nodes' free u_y, among the free dofs
    G = np.zeros((len(dof), off[-1]))
    G[np.arange(len(dof)), dof] = -1.0
    u, _ = active_set_solve(K, f, G, np.zeros(len(dof)))
    return per_body(systems, [body], off, u)[0]


def test_sparse_route_with_held_rows_and_rows_closed_at_zero_gap_against_a_fixed_side():
    """A strip clamped at both ends pressed onto a rigid floor at zero distance: its clamped corners are rows no
    unknown moves, and every other row closes at g = 0 where the floor does not move (the row's only term is
    its own force). The sparse route started from the bonded system of every row (singular with a held row) and
    judged its solves by a componentwise backward error that is rounding over rounding on such a row: it raised
    'did not settle' (method='sparse' and 'auto', which picks it for this slender interface). Against a dense
    active-set solve: measured 1.9e-14 (nx = 60; the full route 1.7e-14)."""
    strip = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.02), nx=60, ny=2), cc.materials.isotropic(E=70e9, nu=0.3),
                    clamped=["left", "right"], traction={"top": (0.0, -1e6)}, name="strip")
    scene = cc.Scene(strip, contacts=[cc.Contact(strip, "bottom", cc.Rigid.plane((0, 0), (0, 1)))])
    ref = _floor_reference(strip)
    for method in ("sparse", "auto"):
        sol = cc.solve(scene, method=method)
        assert sol.ok and sol.info.method == "sparse", sol.report()
        assert rel(sol.u[0], ref) < 1e-9


@pytest.mark.parametrize("ny", [1, 3])
def test_sparse_route_against_a_clamped_foundation_at_zero_gap(ny):
    """An upper block pressed onto a clamped foundation (a fixed foundation, rows of the upper body only) with
    no gap: the rows close where the foundation does not move. ny = 1: every node of the foundation clamped
    (no unknown of its own). Equal to the upper block on a rigid floor, by a dense active-set solve (measured
    1.1e-15 (ny = 1), 1.9e-15 (ny = 3))."""
    alu = cc.materials.isotropic(E=70e9, nu=0.3)
    upper = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=3), alu, clamped=["top"], body_force=(0, -1e8),
                    name="upper")
    lower = cc.Body(cc.rectangle(x=(0, 1), y=(-0.1, 0), nx=8, ny=ny), alu, clamped=["top", "bottom"], name="lower")
    scene = cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top")])
    sol = cc.solve(scene, "sigma1", method="sparse")
    assert sol.ok, sol.report()
    assert rel(sol.u[0], _floor_reference(upper)) < 1e-11 and np.abs(sol.u[1]).max() == 0.0


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_coarse_start_reaches_the_answer_of_the_bonded_start(monkeypatch, factorization):
    """The coarse start of a long interface (SparseContact.coarse_start; the route takes it above COARSE_ROWS
    free rows, lowered here to thin_layer(200)'s 341): the coarse rows' forces from their dense Schur complement
    are those of the route's own steps on the coarse rows alone (the other rows left out by a far gap), and the
    steps from the start end on the same active set and answer as from the bonded start and as the full model."""
    import cvxcontact.backends.sparse as sparse_mod
    from cvxcontact.backends.factor import pardiso_available

    if factorization == "pardiso" and not pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    scene = thin_layer(200)
    bonded = cc.ContactSolver(scene, method="sparse", factorization=factorization)
    ref = bonded.solve()                                   # 348 rows < COARSE_ROWS: from the bonded start
    monkeypatch.setattr(sparse_mod, "COARSE_ROWS", 10)
    calls = []
    coarse_start = SparseContact.coarse_start

    def spy(self, *args):
        calls.append(coarse_start(self, *args))
        return calls[-1]

    monkeypatch.setattr(SparseContact, "coarse_start", spy)
    solver = cc.ContactSolver(scene, method="sparse", factorization=factorization)
    sol = solver.solve()
    assert len(calls) == 1 and calls[0] is not None
    start = calls[0]
    assert sol.ok and sol.info.route == Route.SPARSE_ACTIVE_SET
    assert not np.array_equal(start, ref.contact.active)          # a start, not the answer (measured: 96 rows off)
    # measured (SuperLU / PARDISO) u 2.4e-14 / 2.6e-12, phi 4.9e-15 / 2.1e-13, force 6.1e-13 / 3.3e-11 against
    # the bonded start; u 2.1e-13 / 2.7e-12, phi 7.1e-14 / 2.1e-13, force 1.2e-12 / 1.0e-11 against the full
    # model: >= 370x, 300x
    fields_agree(sol, ref, 1e-9, force_tol=1e-8)
    fields_agree(sol, cc.solve(scene, method="full"), 1e-9, force_tol=1e-8)
    # the coarse problem two ways: dense Schur complement + LCP, and the sparse steps with the other rows far
    blocks, E = list(solver.problem.blocks), solver.problem.E
    g = np.asarray(solver.problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    sc = SparseContact(blocks, E, factorization=factorization)
    _, idx, y_c = sc._coarse(F, g, np.ones(len(g), dtype=bool))
    assert 0 < len(idx) < len(g) and (y_c > 0).any() and (y_c == 0).any()
    keep = np.zeros(len(g), dtype=bool)
    keep[idx] = True
    far = np.where(keep, g, 1e3 * np.abs(g).max() + 1.0)
    _, _, y, active, _ = SparseContact(blocks, E, factorization=factorization).solve(F, far, keep)
    assert np.array_equal(active[idx], y_c > 0) and not active[~keep].any()
    assert rel(y[idx], y_c) < 1e-9                               # measured 2.9e-12 / 3.2e-12


def test_a_system_failing_its_check_twice_is_refactorised_after_a_fresh_analysis(monkeypatch, layer):
    """SparseContact._system: an answer that fails its check against K(A) is refactorised; failing again, the
    factorisation (and with PARDISO its analysis) is made afresh on K(A) itself, and the steps go on to the
    answer of an undisturbed solve. Here the first two answers of the first system are spoiled on purpose."""
    solver = cc.ContactSolver(layer, method="sparse")
    ref = solver.solve()
    blocks, E = list(solver.problem.blocks), solver.problem.E
    g = np.asarray(solver.problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    u0, _, y0, _, _ = SparseContact(blocks, E, factorization=ref.info.factorization).solve(F, g)    # undisturbed
    sc = SparseContact(blocks, E, factorization=ref.info.factorization)
    solve_on, refactor, spoiled, own = SparseContact._solve_on, SparseContact._refactor, [], []

    def spoil(self, active, b):
        z = solve_on(self, active, b)
        if len(spoiled) < 8:         # the first answer and its three refinements, twice over: all fail the check
            spoiled.append(1)
            return z + 1.0
        return z

    def spy(self, active, K=None, own_analysis=False):
        own.append(own_analysis)
        return refactor(self, active, K, own_analysis)

    monkeypatch.setattr(SparseContact, "_solve_on", spoil)
    monkeypatch.setattr(SparseContact, "_refactor", spy)
    u, _, y, active, _ = sc.solve(F, g)
    assert own[:3] == [False, False, True] and sc.attempts == 1
    assert np.array_equal(active, ref.contact.active)
    # measured 2.9e-14 / 7.0e-13 against the undisturbed solve (scaled units): >= 3000x, 14000x
    assert rel(np.concatenate(u), np.concatenate(u0)) < 1e-10 and rel(y, y0) < 1e-8


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_coarse_forces_solve_the_lcp_of_an_independently_built_coarse_compliance(factorization):
    """SparseContact._coarse: the coarse rows' compliance W_c = G_c S^{-1} G_c^T and slack q = G_c S^{-1} F - g_c,
    built here column by column from SciPy's LU of S (partial pivoting, its own order: not the route's Schur
    factorisation), and the forces y_c of the coarse LCP satisfy that LCP, y >= 0, s = q - W_c y <= 0, y s = 0,
    each row to its own scale S_a = |q_a| + (|W_c| |y|)_a (thin_layer(200), both factorisations)."""
    import scipy.sparse.linalg as spla

    import cvxcontact.backends.sparse as sparse_mod
    from cvxcontact.backends.factor import pardiso_available

    if factorization == "pardiso" and not pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    solver = cc.ContactSolver(thin_layer(200), method="sparse", factorization=factorization)
    p = solver.problem
    blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    sc = SparseContact(blocks, E, factorization=factorization)
    seen = {}
    solve_lcp = sparse_mod.solve_lcp

    def spy(W, q, active):
        seen["W"], seen["q"] = W.copy(), q.copy()
        return solve_lcp(W, q, active)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sparse_mod, "solve_lcp", spy)
        _, idx, y = sc._coarse(F, g, ~p.held_rows)
    Gc = sc.G[idx].toarray()
    lu = spla.splu(sc.A.tocsc())
    W, q = Gc @ lu.solve(Gc.T.copy()), Gc @ lu.solve(F) - g[idx]
    # measured 3.7e-10 (SuperLU) / 5.7e-10 (PARDISO) for W, 3.9e-10 / 6.0e-10 for q: >= 175x
    assert np.abs(seen["W"] - W).max() < 1e-7 * np.abs(W).max()
    assert np.abs(seen["q"] - q).max() < 1e-7 * np.abs(q).max()
    closed = y > 0
    assert 0 < closed.sum() < len(idx) and (y >= 0).all()        # measured 30 of 36 closed
    s = q - W @ y
    scale = np.abs(q) + np.abs(W) @ y
    # measured max s / S <= -2.5e-14, |s| / S on the closed rows <= 5.6e-14: >= 1700x (W, q differ by <= 6e-10)
    assert (s / scale).max() < 1e-10 and np.abs(s[closed] / scale[closed]).max() < 1e-10
    assert (s[~closed] < 0).all()                                 # the open coarse rows are strictly open


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_route_takes_the_coarse_start_where_the_other_starts_lead_nowhere(monkeypatch, factorization):
    """thin_layer(200) on a flat gap (crown 0: every merged node starts in contact, 295 of 341 rows closed at the
    answer), below COARSE_ROWS: the route goes on to the coarse start when the bonded start leads nowhere (the
    steps from it cycle here, measured with either factorisation), and ends on the full model's answer."""
    from cvxcontact.backends.factor import pardiso_available

    if factorization == "pardiso" and not pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    scene = thin_layer(200, crown=0.0)
    starts, coarse_start = [], SparseContact.coarse_start

    def spy(self, *args):
        starts.append(coarse_start(self, *args))
        return starts[-1]

    monkeypatch.setattr(SparseContact, "coarse_start", spy)
    sol = cc.solve(scene, method="sparse", factorization=factorization)
    assert sol.ok and sol.info.route == Route.SPARSE_ACTIVE_SET
    assert len(starts) <= 1                                       # measured 1 (the bonded start cycled)
    # measured (SuperLU / PARDISO) u 3.4e-14 / 3.2e-14, phi 4.0e-14 / 3.1e-14, force 1.2e-11 / 5.9e-12: >= 800x
    fields_agree(sol, cc.solve(scene, method="full"), 1e-10, force_tol=1e-8)


@pytest.mark.skipif(not __import__("cvxcontact.backends.factor", fromlist=["x"]).pardiso_available(),
                    reason="Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
def test_pardiso_analysis_on_other_values_then_a_numeric_factorisation_solves_k_itself(layer):
    """PardisoSymmetric.analyse: the analysis (ordering, scaling and weighted matching) on one matrix's values with
    no factor of it, then a numeric factorisation of another matrix of the same pattern (the sparse route after
    coarse_start: analysed on the bonded values, every factor numeric): its solves are those of K itself, as
    SciPy's pivoting sparse LU solves it; a second analysis and a matrix of another pattern are refused."""
    import scipy.sparse as sps
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.factor import PardisoSymmetric

    solver = cc.ContactSolver(layer, method="sparse")
    solver.solve()
    sc = solver.cache.sparse
    half = np.arange(sc.m) % 2 == 0
    bonded, K = sc.matrix(np.ones(sc.m, dtype=bool)), sc.matrix(half)
    b = np.concatenate([sc.F, np.where(half, sc._g, 0.0)])
    ps = PardisoSymmetric(K).analyse(bonded)
    assert ps.cost is not None and ps.cost[1] > 0
    z = ps.factor(K).solve(b)
    scale = np.maximum(abs(K) @ np.abs(z) + np.abs(b), np.finfo(float).tiny)     # componentwise backward error
    # measured: backward error 3.3e-14, 7.1e-14 from SciPy's LU (Haswell, Prescott, Sandybridge kernels): >= 140x
    assert float((np.abs(b - K @ z) / scale).max()) < 1e-11
    assert rel(z, spla.spsolve(K.tocsc(), b)) < 1e-11
    with pytest.raises(cc.SolverError, match="already analysed"):
        ps.analyse(bonded)
    with pytest.raises(cc.SolverError, match="pattern differs"):
        PardisoSymmetric(K).analyse(sps.identity(K.shape[0], format="csc"))
    ps.release()


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_default_cap_is_measured_on_the_capacitance_forms_own_columns(layer, factorization):
    """SparseContact's default cap (cap=None, SparseContact._over_cap): a change of at most CAP_MIN rows is solved
    by the capacitance form and one of more than CAP_MAX refactorised, whatever the timings; the first block of at
    least CAP_MIN columns the capacitance form solves sets the cap within [CAP_MIN, CAP_MAX], with no column solved
    for the measurement alone (column_solves counts the rows asked). Those columns are the base matrix's inverse
    on the rows' unit vectors (SciPy's LU); the steps with this cap end on the full model's set and answer."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends import factor as factor_module
    from cvxcontact.backends.sparse import CAP_MAX, CAP_MIN

    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    problem = cc.ContactSolver(layer, method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    sc = SparseContact(blocks, E, factorization=factorization)
    bonded = np.ones(sc.m, dtype=bool)
    assert sc.m > CAP_MIN + 4 and sc._refactor(bonded)
    none = np.zeros(0, dtype=int)
    assert not sc._over_cap(np.arange(CAP_MIN), none) and sc._over_cap(np.arange(CAP_MAX + 1), none)
    assert sc.cap is None and sc.column_solves == 0                  # nothing solved to decide those
    drop = np.arange(0, sc.m, 2)[:CAP_MIN + 4]                       # CAP_MIN + 4 rows dropped from the base
    GZ, YZ = sc._capacitance_columns(drop, none)
    assert sc.column_solves == len(drop) and CAP_MIN <= sc.cap <= CAP_MAX
    rhs = np.zeros((sc.n + sc.m, len(drop)))
    rhs[sc.n + drop, np.arange(len(drop))] = 1.0                     # a gap correction on each dropped row
    Z = spla.splu(sc.matrix(bonded).tocsc()).solve(rhs)
    # measured 2.9e-10 .. 8.6e-10 (SuperLU unpivoted against SciPy's pivoting LU: the slender layer's conditioning),
    # 1.2e-13 .. 7.1e-12 (PARDISO), under the Haswell, Prescott and Sandybridge kernels: >= 116x
    assert rel(GZ, sc.G @ Z[:sc.n]) < 1e-7 and rel(YZ, Z[sc.n:]) < 1e-7
    active = SparseContact(blocks, E, factorization=factorization).solve(F, g)[3]
    sol, full = cc.solve(layer, method="sparse", factorization=factorization), cc.solve(layer, method="full")
    assert np.array_equal(active, np.asarray(full.contact.active)) and np.array_equal(active, sol.contact.active)
    fields_agree(sol, full, 1e-9, force_tol=2e-8)            # as in the test of this scene above (its conditioning)



@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_default_cap_under_a_clock_that_does_not_advance(monkeypatch, layer, factorization):
    """The default cap (cap=None) is read from timings (SparseContact._over_cap); a clock that does not advance
    between two readings (a coarse timer, a solve shorter than its resolution: every time read 0 here) must not
    stop the route (it divided by the first single solve's time: ZeroDivisionError). The cap stays within
    [CAP_MIN, CAP_MAX] and the answer does not depend on it: the full model's set, the plain steps' fields."""
    from types import SimpleNamespace

    import cvxcontact.backends.sparse as sparse_mod
    from cvxcontact.backends import factor as factor_module

    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    problem = cc.ContactSolver(layer, method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    plain = SparseContact(blocks, E, cap=0, factorization=factorization).solve(F, g)   # no timing read
    monkeypatch.setattr(sparse_mod, "time", SimpleNamespace(perf_counter=lambda: 0.0))
    sc = SparseContact(blocks, E, factorization=factorization)
    out = sc.solve(F, g)
    assert out is not None and plain is not None
    assert sc._t_solve == 0.0 and sc._t_fact == 0.0                  # the clock did not advance
    assert sc._over_cap(np.arange(sparse_mod.CAP_MIN), np.zeros(0, dtype=int)) is False
    assert sc.cap is None or sparse_mod.CAP_MIN <= sc.cap <= sparse_mod.CAP_MAX
    assert np.array_equal(out[3], plain[3])
    assert np.array_equal(out[3], np.asarray(cc.solve(layer, method="full").contact.active))
    # measured u 3.2e-14 .. 5.3e-14 (SuperLU), 1.2e-13 .. 2.4e-13 (PARDISO) between the two (the same set solved
    # exactly twice, scaled units) under the Haswell, Prescott and Sandybridge kernels: >= 400x
    assert max(rel(out[0][k], plain[0][k]) for k in range(2)) < 1e-10


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_bonded_analysis_then_other_load_cases_and_nearly_dependent_rows(monkeypatch, factorization):
    """The coarse start taken (COARSE_ROWS lowered), so that with PARDISO the analysis is made on the bonded values
    alone (PardisoSymmetric.analyse) and every later factor is numeric on other values: (1) three load cases on one
    ContactSolver (the analysis kept, a re-solve never analyses the same handle twice), each the full model's set
    and fields; (2) two blocks of nearly matching meshes (50 and 51 cells: merged nodes down to 3.9e-4 m, 2% of a
    cell, apart: nearly dependent rows, a nearly singular system wherever both close), the full model's as well."""
    from conftest import two_blocks

    import cvxcontact.backends.sparse as sparse_mod
    from cvxcontact.backends import factor as factor_module

    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    monkeypatch.setattr(sparse_mod, "COARSE_ROWS", 10)
    analyses = []
    if factorization == "pardiso":
        analyse = factor_module.PardisoSymmetric.analyse
        monkeypatch.setattr(factor_module.PardisoSymmetric, "analyse",
                            lambda self, K: analyses.append(1) or analyse(self, K))
    solver = cc.ContactSolver(thin_layer(40), method="sparse", factorization=factorization)
    for kw in ({}, {"pressure": 3e6, "crown": 1e-5}, {"pressure": 2e5, "voltage": -200.0, "crown": 4e-5}):
        scene = thin_layer(40, **kw)
        sol, full = solver.solve(scene), cc.solve(scene, method="full")
        assert sol.ok and np.array_equal(np.asarray(sol.contact.active), np.asarray(full.contact.active))
        # measured (SuperLU and PARDISO, the three cases, Haswell / Prescott / Sandybridge kernels) u <= 3.1e-12 /
        # 5.9e-12 / 4.7e-12, phi <= 1.5e-12, the force <= 6.2e-11 / 2.6e-10 / 2.3e-10: >= 169x, 115x
        fields_agree(sol, full, 1e-9, force_tol=3e-8)
    scene = two_blocks((50, 4), (51, 4))      # 101 rows, 8 pairs of Jacobi-scaled cosine > 0.99 (up to 0.9995)
    sol, full = cc.solve(scene, "gamma3", method="sparse", factorization=factorization), \
        cc.solve(scene, "gamma3", method="full")
    assert sol.ok and np.array_equal(np.asarray(sol.contact.active), np.asarray(full.contact.active))
    fields_agree(sol, full, 1e-10)        # measured u, phi 1.3e-14 .. 3.6e-14 (the three kernel sets): >= 2700x
    assert factorization == "superlu" or len(analyses) >= 2   # the bonded analysis was the one taken, both scenes


@pytest.mark.skipif(not __import__("cvxcontact.backends.factor", fromlist=["x"]).pardiso_available(),
                    reason="Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
def test_pardiso_refuses_another_pattern_with_the_same_count_of_entries(layer):
    """PardisoSymmetric reads every later K's values in the order of the pattern given at construction: a matrix
    with as many stored entries in another pattern (the bonded system symmetrically permuted) is refused by
    analyse and factor (SolverError), not factorised as another matrix (it was: the solve's residual 6e36)."""
    import scipy.sparse as sps

    from cvxcontact.backends.factor import PardisoSymmetric

    solver = cc.ContactSolver(layer, method="sparse")
    solver.solve()
    sc = solver.cache.sparse
    K = sc.matrix(np.ones(sc.m, dtype=bool))
    p = np.random.default_rng(0).permutation(K.shape[0])
    other = sps.csc_matrix(K[p][:, p])
    other.sort_indices()
    assert other.nnz == K.nnz and not np.array_equal(other.indices, K.indices)
    for call in ("analyse", "factor"):
        ps = PardisoSymmetric(K)
        with pytest.raises(cc.SolverError, match="pattern differs"):
            getattr(ps, call)(other)
        ps.release()
    ps = PardisoSymmetric(K).factor(K)                   # its own pattern, values changed: taken
    z = ps.factor(sc.matrix(np.arange(sc.m) % 3 == 0)).solve(np.ones(K.shape[0]))
    assert np.isfinite(z).all()
    ps.release()


@pytest.mark.skipif(not __import__("cvxcontact.backends.factor", fromlist=["x"]).pardiso_available(),
                    reason="Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
def test_a_slender_interface_is_analysed_in_minimum_degree_and_its_answer_is_the_other_orders(monkeypatch):
    """On a slender interface (thin_layer(400): 681 rows, 1.16 n^(2/3)) the route's PARDISO handle is analysed in
    minimum degree order (iparm[1] = 0) and kept (its fill below SLENDER_FILL); where the fill is over the bound
    (SLENDER_FILL lowered to 0) it is released and the analysis made in nested dissection (2). Both reach the
    active set and fields of SciPy's SuperLU on the route's own order (an independent factorisation); a bulky
    interface (two 3D boxes, 49 rows, 0.6 n^(2/3)) is analysed in nested dissection alone. A bad order is a typed
    error."""
    from scenes3d import two_boxes

    import cvxcontact.backends.factor as factor_mod
    import cvxcontact.backends.sparse as sparse_mod

    orders, Handle = [], factor_mod.PardisoSymmetric

    class Spy(Handle):
        def __init__(self, K, *args, **kwargs):
            super().__init__(K, *args, **kwargs)
            orders.append(int(self._iparm[1]))

    monkeypatch.setattr(factor_mod, "PardisoSymmetric", Spy)
    scene = thin_layer(400)
    ref = cc.solve(scene, method="sparse", factorization="superlu")
    amd = cc.solve(scene, method="sparse", factorization="pardiso")
    assert orders == [0] and amd.ok and ref.ok
    monkeypatch.setattr(sparse_mod, "SLENDER_FILL", 0.0)
    orders.clear()
    metis = cc.solve(scene, method="sparse", factorization="pardiso")
    assert orders == [0, 2] and metis.ok
    for sol in (amd, metis):
        assert np.array_equal(sol.contact.active, ref.contact.active)
        # measured (default, Prescott, Sandybridge kernels; every answer from a factor of K(A) itself): u and phi
        # 7.4e-14 to 6.0e-13, the forces 1.15e-11 to 1.96e-11 of the largest: >= 160x, 150x. (The 1.22e-9 measured
        # before was the timed cap's: SuperLU's answer from the capacitance form on another base, 6.6e-12 or 1.2e-9
        # from an independent pivoted LU of K(A) in two runs of one process.)
        fields_agree(sol, ref, 1e-10, force_tol=3e-9)
    orders.clear()
    assert cc.solve(two_boxes(6), method="sparse", factorization="pardiso").ok and set(orders) == {2}
    small = cc.ContactSolver(thin_layer(8)).problem
    sc = sparse_mod.SparseContact(list(small.blocks), small.E)
    K = sc.matrix(np.ones(sc.m, dtype=bool))
    for bad in (1, 3, True, "amd"):          # (3, parallel METIS: not reproducible)
        with pytest.raises(cc.SolverError, match="ordering must be one of"):
            Handle(K, ordering=bad)


@pytest.mark.parametrize("factorization", ["superlu", "pardiso"])
def test_the_answer_does_not_depend_on_the_clock_that_times_the_default_cap(monkeypatch, factorization):
    """The default cap (cap=None, SparseContact._over_cap) is read from the clock, so which sets are refactorised
    and which base the steps end on change from run to run; the answer must not: it is taken from a factor of
    K(A) for the final set A itself. Two fake clocks: one where a factorisation takes a million times a solve
    (the cap at CAP_MAX: thin_layer(200)'s steps settle on the first base's columns, 2 systems, 1 factorisation)
    and one where both take alike (the cap at CAP_MIN: 9 systems, 8 factorisations). Before the final factor the
    forces differed by 1.5e-12 to 5.5e-12 of the largest, the displacements 5.3e-14 to 6.4e-14 (SuperLU, PARDISO;
    default, Prescott, Sandybridge kernels; thin_layer(400) alike, the forces 6e-12 to 1.3e-11); now the same set
    and the same bits."""
    import sys
    from types import SimpleNamespace

    import cvxcontact.backends.sparse as sparse_mod
    from cvxcontact.backends import factor as factor_module

    if factorization == "pardiso" and not factor_module.pardiso_available():
        pytest.skip("Intel oneMKL PARDISO not installed (the 'pardiso' extra)")
    problem = cc.ContactSolver(thin_layer(200), method="sparse").problem
    blocks, E, g = list(problem.blocks), problem.E, np.asarray(problem.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    answers, caps = [], []
    for slow in (1.0, 1e-6):              # the seconds a factorisation takes on the fake clock (a solve 1e-6)
        def clock(slow=slow, now=[0.0]):   # noqa: B006 (the clock's own time, one list per clock)
            now[0] += slow if sys._getframe(1).f_code.co_name == "_refactor" else 1e-6
            return now[0]

        monkeypatch.setattr(sparse_mod, "time", SimpleNamespace(perf_counter=clock))
        sc = SparseContact(blocks, E, factorization=factorization)
        answers.append(sc.solve(F, g))
        caps.append(sc._over_cap(np.arange(sparse_mod.CAP_MIN + 4), np.zeros(0, dtype=int)))
    (u1, phi1, y1, a1, _), (u2, phi2, y2, a2, _) = answers
    assert caps == [False, True]          # the two clocks' caps differ (CAP_MAX against CAP_MIN)
    assert np.array_equal(a1, a2) and np.array_equal(y1, y2)
    assert all(np.array_equal(p, q) for p, q in zip(u1 + phi1, u2 + phi2) if p is not None)
