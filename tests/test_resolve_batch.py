"""Several load cases through a prepared ContactSolver at once (ContactSolver.solve_many): the forward sweeps of
each body batched as the columns of one right-hand side (Condensation.prepare), and the backward sweeps of the
fields held until every load case of the batch is finished (Condensation.defer, flush). The oracles: the same load
cases solved one at a time by ContactSolver.solve (the batched sweep sums in another order: the same answers to
rounding), a fresh solver's answer for a load case outside the batch, and the number and width of the sweeps."""

import importlib

import numpy as np
import pytest
from conftest import rel, two_blocks

import cvxcontact as cc
from cvxcontact.backends import budget
from cvxcontact.backends.factor import pardiso_available
from cvxcontact.errors import SceneError

pytestmark = pytest.mark.numerics

solve_module = importlib.import_module("cvxcontact.solve")     # (cvxcontact.solve is also the function)

FACTORIZATIONS = ["superlu", pytest.param("pardiso", marks=pytest.mark.skipif(not pardiso_available(),
                                                                               reason="oneMKL PARDISO absent"))]


def _cases(count, start=0):
    """Load cases of conftest.two_blocks: the upper block's traction differs in each (the lower block unloaded)."""
    return [two_blocks(scale=0.37, traction={"right": (0.0, 1.1e8 * (1 + (start + i) / 10))}) for i in range(count)]


def _fields(sol):
    return np.concatenate([np.ravel(x) for x in sol.u] + [np.ravel(x) for x in sol.phi if x is not None])


def _sweeps(solver, name="forward"):
    """Wrap each body's factor.forward (or backward) to record the columns of every sweep (per body, a list; False
    for a single vector)."""
    seen = []
    for c in solver.cache.condensation.bodies:
        calls, sweep = [], getattr(c.factor, name)

        def counted(*args, calls=calls, sweep=sweep):
            rhs = args[-1]                                       # forward(F), backward(fwd, v)
            calls.append(np.ndim(rhs) == 2 and np.shape(rhs)[1])
            return sweep(*args)
        setattr(c.factor, name, counted)
        seen.append(calls)
    return seen


@pytest.fixture(scope="module", params=FACTORIZATIONS)
def batched(request):
    """A solver's first solve, then four load cases one at a time by a second solver and batched by the first."""
    one, many = (cc.ContactSolver(two_blocks(), method="condensed", factorization=request.param) for _ in range(2))
    one.solve()
    many.solve()
    sweeps = _sweeps(many), _sweeps(many, "backward")
    scenes = _cases(4)
    return request.param, many, [one.solve(s) for s in scenes], many.solve_many(scenes), sweeps


def test_solve_many_answers_as_solve_one_at_a_time(batched):
    """u, phi, the contact forces, the checks and the estimate of each load case as solve()'s, relative, worst
    over the default kernels and OPENBLAS_CORETYPE Haswell, Nehalem, Prescott, Sandybridge (measured: superlu
    u, phi 1.6e-15, forces 3.4e-13, estimate 5.4e-15, indicators 4.1e-13 (identical under the default kernels
    and Sandybridge); pardiso 3.6e-15, 1.0e-12, 1.6e-14, 1.2e-12 (Nehalem): the interface finish carries the
    sweeps' rounding into the forces; asserted to 1e-12, 1e-9, 1e-11, 1e-9)."""
    _, _, one, many, _ = batched
    for a, b in zip(many, one):
        assert a.ok and b.ok
        assert rel(_fields(a), _fields(b)) < 1e-12
        assert rel(a.contact.force, b.contact.force) < 1e-9
        assert abs(a.estimate.absolute - b.estimate.absolute) < 1e-11 * b.estimate.absolute
        assert all(rel(x, y) < 1e-9 for x, y in zip(a.estimate.indicators, b.estimate.indicators))
        assert set(a.residuals()) == set(b.residuals())
    assert rel(_fields(many[0]), _fields(many[1])) > 1e-3                    # (the load cases differ)


def test_the_batch_sweeps_each_loaded_body_once(batched):
    """Forward: the upper block's four loads in one sweep of four columns and no other; the lower block, unloaded
    in every load case, reuses its last sweep (none made). Backward: each body's four fields in one sweep of four
    columns (the contact forces differ in each load case). The batches' times are in the first load case's
    stages. Each answer is finite (no field left unfilled)."""
    _, _, _, many, (forward, backward) = batched
    assert forward == [[4], []] and backward == [[4], [4]]
    for key in ("batched_sweeps", "batched_backward"):
        assert key in many[0].info.timings and key not in many[1].info.timings
    assert all(np.isfinite(_fields(sol)).all() for sol in many)


@pytest.mark.parametrize("factorization", FACTORIZATIONS)
def test_a_load_case_outside_the_batch_is_swept_afresh(factorization):
    """After solve_many, a load case that was not in it takes no batched sweep (one single sweep) and answers as a
    fresh solver's solve (measured: identical, 0.0, both adapters; asserted to 1e-12)."""
    solver = cc.ContactSolver(two_blocks(), method="condensed", factorization=factorization)
    solver.solve()
    solver.solve_many(_cases(3))
    sweeps = _sweeps(solver)
    other = _cases(1, start=7)[0]
    again = solver.solve(other)
    fresh = cc.ContactSolver(other, method="condensed", factorization=factorization).solve()
    assert sweeps[0] == [False]                                             # one single forward sweep
    assert rel(_fields(again), _fields(fresh)) < 1e-12 and rel(again.contact.force, fresh.contact.force) < 1e-12


def test_solve_many_before_any_solve_and_with_released_factors(monkeypatch):
    """solve_many as the first call (the first load case builds the condensation, the rest are batched) and with
    every body's factors freed (a released body sweeps one load at a time): the answers of solve() one at a time
    under the same release (measured: u 9.1e-16, forces 2.0e-13 relative, worst over the five kernel sets, the
    first case; released: identical; asserted to 1e-12 and 1e-9)."""
    scenes = _cases(3)

    def answers(batch):
        solver = cc.ContactSolver(scenes[0], method="condensed", factorization="superlu")
        out = solver.solve_many(scenes) if batch else [solver.solve(s) for s in scenes]
        return solver, out

    checked = [(answers(True)[1], answers(False)[1])]
    monkeypatch.setattr(budget, "RELEASE", True)
    released, got = answers(True)
    assert released.cache.condensation.released
    checked.append((got, answers(False)[1]))
    for many, one in checked:
        for a, b in zip(many, one):
            assert rel(_fields(a), _fields(b)) < 1e-12 and rel(a.contact.force, b.contact.force) < 1e-9


def test_solve_many_checks_every_scene_before_solving():
    """A scene of another geometry among the load cases: SceneError before any of them is solved (the solver's
    problem is still the first solve's)."""
    solver = cc.ContactSolver(two_blocks(), method="condensed", factorization="superlu")
    solver.solve()
    problem = solver.problem
    with pytest.raises(SceneError):
        solver.solve_many([*_cases(2), two_blocks(n1=(12, 6))])
    assert solver.problem is problem


@pytest.mark.parametrize("options, force_bound", [({"law": cc.NormalCompliance(stiffness=1e13)}, 1e-9),
                                                  ({"degree": 2, "condition": "sigma1"}, 1e-9),
                                                  ({"degree": 2}, 1e-6)],
                         ids=["compliance", "P2 sigma1", "P2 cones"])
def test_the_other_condensed_routes_batch_their_forward_sweeps_and_answer_as_solve(options, force_bound):
    """A normal-compliance law, P2 nodal rows and the P2 cones ("gamma3": the cones' route, which reads the fields
    before it returns, so its backward sweeps are not held): solve_many answers as solve() one at a time
    ("superlu"; measured, worst over the five kernel sets: u 1.0e-15, 9.7e-16, 1.9e-15; forces 9.9e-15, 5.1e-15
    and 1.3e-9 (the cones' interior point and finish, Nehalem); identical under the default kernels and
    Sandybridge; asserted to 1e-12 and 1e-9, 1e-9, 1e-6) and the upper block's three loads are swept in one forward
    sweep."""
    options = {"condition": "gamma3", **options}
    one, many = (cc.ContactSolver(two_blocks(), method="condensed", factorization="superlu", **options)
                 for _ in range(2))
    one.solve()
    many.solve()
    sweeps = _sweeps(many)
    scenes = _cases(3)
    expected, got = [one.solve(s) for s in scenes], many.solve_many(scenes)
    assert sweeps[0] == [3]
    for a, b in zip(got, expected):
        assert a.ok and b.ok
        assert rel(_fields(a), _fields(b)) < 1e-12 and rel(a.contact.force, b.contact.force) < force_bound


def test_more_load_cases_than_a_batch_go_in_batches(monkeypatch):
    """BATCH = 2 and five load cases: the upper block's forward sweeps in batches of two, the fifth alone (a single
    sweep); the answers as solve()'s ("superlu"; measured, worst over the five kernel sets: u 2.1e-15, forces
    6.7e-13 (Prescott); identical under the default kernels and Sandybridge; asserted to 1e-12 and 1e-9)."""
    monkeypatch.setattr(solve_module, "BATCH", 2)
    one, many = (cc.ContactSolver(two_blocks(), method="condensed", factorization="superlu") for _ in range(2))
    one.solve()
    many.solve()
    sweeps = _sweeps(many)
    scenes = _cases(5)
    expected, got = [one.solve(s) for s in scenes], many.solve_many(scenes)
    assert sweeps[0] == [2, 2, False]
    for a, b in zip(got, expected):
        assert rel(_fields(a), _fields(b)) < 1e-12 and rel(a.contact.force, b.contact.force) < 1e-9


@pytest.mark.parametrize("factorization", FACTORIZATIONS)
def test_after_solve_many_its_load_cases_are_swept_afresh(factorization):
    """The batch's sweeps end with it: solve() of one of its load cases (not the last) afterwards makes its own single
    forward sweep, and answers bit for bit as a solver that took the same load cases one at a time; the sweep kept
    after the batch holds its own column, not a view of the batch's whole right-hand side (before: the batched sweep
    was reused, PARDISO's rounding then differing from the single sweep's, and all the batch's columns were held)."""
    scenes = _cases(3)
    batched, alone = (cc.ContactSolver(two_blocks(), method="condensed", factorization=factorization)
                      for _ in range(2))
    batched.solve()
    alone.solve()
    batched.solve_many(scenes)
    for s in scenes:
        alone.solve(s)
    kept = batched.cache.condensation._loaded[0][1].state               # the upper block's last sweep
    assert kept.base is None or kept.base.size == kept.size
    sweeps = _sweeps(batched)
    a, b = batched.solve(scenes[0]), alone.solve(scenes[0])
    assert sweeps[0] == [False]                                             # one single forward sweep
    assert np.array_equal(_fields(a), _fields(b)) and np.array_equal(a.contact.force, b.contact.force)


@pytest.mark.parametrize("given", [None, 3, "scene"], ids=["None", "a number", "a Scene"])
def test_solve_many_takes_a_sequence_of_scenes(given):
    """A Scene itself, or no sequence at all: SceneError naming what was given and what to pass (before: a bare
    TypeError, "'Scene' object is not iterable"); the solver is still usable."""
    solver = cc.ContactSolver(two_blocks(), method="condensed", factorization="superlu")
    with pytest.raises(SceneError, match="sequence of Scenes.*solve_many\\(\\[scene\\]\\)"):
        solver.solve_many(two_blocks() if given == "scene" else given)
    assert solver.solve_many([]) == [] and solver.solve_many(_cases(1))[0].ok


@pytest.mark.parametrize("method, first", [("sparse", True), ("condensed", False)],
                         ids=["a route keeping no condensation", "solve_many as the first call"])
def test_solve_many_derives_each_load_case_once(monkeypatch, method, first):
    """Each load case's problem is derived once (DiscreteProblem.with_loads), whether the route keeps a
    condensation or not (before: on a route keeping none, the sparse one here, every load case solved alone
    re-derived the rest of its batch: 36 derivations for 8 load cases; 15 when solve_many built the condensation)."""
    from cvxcontact.discrete import DiscreteProblem

    solver = cc.ContactSolver(two_blocks(), method=method, factorization="superlu")
    if first:
        solver.solve()
    derived, with_loads = [], DiscreteProblem.with_loads
    monkeypatch.setattr(DiscreteProblem, "with_loads", lambda self, scene: derived.append(scene) or
                        with_loads(self, scene))
    scenes = _cases(8)
    got = solver.solve_many(scenes)
    assert len(derived) == 8 and all(sol.ok for sol in got)


def test_fields_held_by_the_batch_refuse_to_be_read_before_they_are_made(monkeypatch):
    """A route that read its fields under Condensation.defer (before flush made them) fails at once (RuntimeError)
    instead of reading a placeholder (before: NaN arrays, on which every comparison is silently False); after the
    batch every answer's fields are plain lists of finite arrays, as solve()'s."""
    from cvxcontact.backends import signorini

    solver = cc.ContactSolver(two_blocks(), method="condensed", factorization="superlu")
    solver.solve()
    seen, route = [], signorini.condensed

    def reading(*args):
        raw = route(*args)
        try:
            seen.append(float(np.sum(raw.u[0])))
        except RuntimeError as exc:
            seen.append(type(exc))
        return raw

    monkeypatch.setattr(signorini, "condensed", reading)
    got = solver.solve_many(_cases(3))
    assert seen == [RuntimeError] * 3
    assert all(type(sol.u) is list and np.isfinite(_fields(sol)).all() for sol in got)


def test_after_a_fallback_to_a_route_without_sweeps_solve_many_makes_none():
    """The batch's forward sweeps are made when a route first asks for one: a solver moved to the sparse route
    (as a fallback moves it, ContactSolver._fallback) keeps its condensation but sweeps nothing on it, and answers
    as a fresh sparse solver (fields measured 2.4e-15 relative, 2.6e-15 under Nehalem; asserted to 1e-12)."""
    solver = cc.ContactSolver(two_blocks(), method="condensed")
    solver.solve()
    solver.method = "sparse"                                       # (what a passing fallback sets)
    forward, backward = _sweeps(solver), _sweeps(solver, "backward")
    scenes = _cases(3, start=20)
    many = solver.solve_many(scenes)
    assert forward == [[], []] and backward == [[], []]
    for sol, scene in zip(many, scenes):
        assert sol.ok
        assert rel(_fields(sol), _fields(cc.ContactSolver(scene, method="sparse").solve())) < 1e-12


@pytest.mark.parametrize("failing", [1, 2], ids=["before any sweep", "after the batch's sweep"])
def test_a_load_case_failing_mid_batch_leaves_nothing_pending(monkeypatch, failing):
    """A route raising on the ``failing``-th load case of a batch (the first: before its route asked for the
    batched sweep; the second: after): solve_many raises that error, the condensation keeps no pending load nor
    batched sweep, and the solver then answers the same load cases as a solver that never failed (one single
    sweep per new load; fields measured 0.0 apart, 1.2e-15 under Haswell, 5.9e-16 Nehalem; asserted to 1e-12)."""
    from cvxcontact.backends import signorini

    solver, alone = (cc.ContactSolver(two_blocks(), method="condensed", factorization="superlu") for _ in range(2))
    solver.solve()
    alone.solve()
    scenes, route, calls = _cases(3, start=30), signorini.condensed, []

    def failing_route(*args):
        calls.append(1)
        if len(calls) == failing:
            raise RuntimeError("a route failing mid-batch")
        return route(*args)

    monkeypatch.setattr(signorini, "condensed", failing_route)
    forward = _sweeps(solver)
    with pytest.raises(RuntimeError, match="mid-batch"):
        solver.solve_many(scenes)
    assert forward[0] == ([] if failing == 1 else [3])              # the batch swept when first asked, or never
    condensation = solver.cache.condensation
    assert condensation._pending == [[], []] and condensation._batched == [[], []]
    monkeypatch.setattr(signorini, "condensed", route)
    again = solver.solve(scenes[2])
    assert forward[0][-1] is False                                   # its own single sweep
    assert rel(_fields(again), _fields(alone.solve(scenes[2]))) < 1e-12
    for a, b in zip(solver.solve_many(scenes), [alone.solve(s) for s in scenes]):
        assert a.ok and rel(_fields(a), _fields(b)) < 1e-12
