"""cc.adapt's budget in unknowns (``max_unknowns``), its warning when ``tol`` is not reached, and the defaults
per dimension and degree (cvxcontact.adapt.LOOPS)."""

import warnings

import numpy as np
import pytest
from obstacle_scenes import indented_block

import cvxcontact as cc
from cvxcontact.adapt import LOOPS, unknowns
from cvxcontact.apps.studies import estimate as study


def quietly(*args, **kwargs):
    """cc.adapt with the coarse meshes' ResolutionWarnings and the P2 circle's declined finish (its ResidualWarning:
    the cuts stop short of rounding there, docs/accuracy.md) silenced: what is tested here is the loop's count."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("ignore", cc.ResidualWarning)
        return cc.adapt(*args, **kwargs)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("build", [indented_block, study.blocks_scene], ids=["elastic", "piezoelectric pair"])
def test_the_unknowns_of_a_refined_mesh_are_counted_before_its_solve(build, degree):
    """unknowns(bodies, degree), from the meshes alone, is the solve's count (u and phi of every body) on every
    step's mesh: elastic (2 per node) and a piezoelectric body on an elastic one (3 and 2), P1 and P2."""
    result = quietly(build(), degree=degree, max_steps=2, keep=True)
    assert len(result.solutions) == 3
    for step, sol in zip(result.history, result.solutions):
        counted = sum(u.size + (0 if p is None else p.size) for u, p in zip(sol.u, sol.phi))
        assert unknowns(sol.scene.bodies, degree) == counted == step.unknowns


def test_max_unknowns_stops_before_the_mesh_that_would_pass_it():
    """The loop without a budget reaches steps 0..3; a budget between step 2's and step 3's unknowns stops on step 2
    with the same meshes (the stop is by the count, not by a different path), and says why."""
    free = quietly(indented_block(), max_steps=3)
    counts = [s.unknowns for s in free.history]
    assert counts == sorted(counts) and counts[2] < counts[3]
    budget = (counts[2] + counts[3]) // 2
    capped = quietly(indented_block(), max_steps=3, max_unknowns=budget)
    assert capped.stopped == "max_unknowns"
    assert [s.unknowns for s in capped.history] == counts[:3]
    assert capped.history[-1].marked == 0 and capped.solution.ok
    exactly = quietly(indented_block(), max_steps=3, max_unknowns=counts[3])    # at the budget: allowed
    assert exactly.stopped == "max_steps" and exactly.history[-1].unknowns == counts[3]


def test_an_unreached_tol_warns_with_the_best_estimate():
    """tol = 1e-6 is far below what 150 unknowns reach (measured: the relative estimate 1.44 at 106 unknowns): a
    ResolutionWarning naming the stop, the last and the lowest estimate; tol reached: no such warning."""
    with pytest.warns(cc.ResolutionWarning, match=r"above tol = 1e-06: stopped by max_unknowns.*lowest") as caught:
        first = cc.adapt(indented_block(), max_steps=40, tol=1e-6, max_unknowns=150)
    assert first.stopped == "max_unknowns"
    lowest = min(s.relative for s in first.history)
    assert any(f"{lowest:.3g} at step" in str(w.message) for w in caught)
    loose = 10 * first.history[0].relative
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)       # the coarse mesh's own, not the loop's
        warnings.filterwarnings("error", message="adapt:", category=cc.ResolutionWarning)
        reached = cc.adapt(indented_block(), tol=loose)
    assert reached.stopped == "tol" and len(reached.history) == 1


def test_bad_budgets_are_refused():
    scene = indented_block()
    for bad in (0, -5, 2.5, True, "50k"):
        with pytest.raises(cc.SceneError, match="max_unknowns must be an integer >= 1"):
            cc.adapt(scene, max_unknowns=bad)
    with pytest.raises(cc.SceneError, match=r"first mesh already has 54 unknowns, more than max_unknowns = 53"):
        cc.adapt(scene, max_unknowns=53)           # 8 x 2 cells: 27 nodes, 2 each (checked below)
    assert len(scene.bodies[0].mesh.points) == 27
    with pytest.raises(cc.SceneError, match="exact_steps must be True, False or None"):
        cc.adapt(scene, exact_steps=1)
    with pytest.raises(cc.SceneError, match="rate"):
        cc.adapt(scene, rate=0.0)
    with pytest.raises(cc.SolverError, match="degree must be 1"):
        cc.adapt(scene, degree=3)


def test_the_defaults_are_the_table_of_the_dimension_and_degree():
    """theta, rate and exact_steps left None are LOOPS[dim, degree]'s: the same history as passing them; rate =
    inf is one bisection per marked cell (mark_bulk)."""
    assert LOOPS[2, 2].theta == 0.9 and LOOPS[2, 2].rate == 1.0 and LOOPS[2, 2].exact_steps is False
    assert LOOPS[2, 1].theta == 0.5 and np.isinf(LOOPS[2, 1].rate) and LOOPS[2, 1].exact_steps is True
    for degree in (1, 2):
        loop = LOOPS[2, degree]
        given = quietly(indented_block(), degree=degree, max_steps=2, theta=loop.theta, rate=loop.rate,
                        exact_steps=loop.exact_steps)
        default = quietly(indented_block(), degree=degree, max_steps=2)
        assert [(s.cells, s.unknowns, s.marked) for s in default.history] == \
            [(s.cells, s.unknowns, s.marked) for s in given.history]
    p2_old = quietly(indented_block(), degree=2, max_steps=2, theta=0.9, rate=np.inf, exact_steps=False)
    assert [s.cells for s in p2_old.history] != [s.cells for s in default.history]   # rate 1 bisects more


def test_the_history_reads_the_peak_pressure_and_its_change():
    """AdaptStep.peak is the largest pressure of the step's solution (sol.traction), peak_change the relative change
    from the step before (NaN on step 0); on the indented block the peak moves as nodes enter the zone (measured:
    changes of 1e-2 to 4e-1 over the first steps)."""
    result = quietly(indented_block(), max_steps=3, keep=True)
    peaks = [float(sol.traction(0)[1].max()) for sol in result.solutions]
    assert [s.peak for s in result.history] == peaks and min(peaks) > 0
    assert np.isnan(result.history[0].peak_change)
    for before, now, step in zip(peaks, peaks[1:], result.history[1:]):
        assert step.peak_change == pytest.approx(abs(now - before) / now, rel=1e-12)


def test_a_tol_reached_by_the_interior_point_alone_warns(monkeypatch):
    """With exact_steps=False the stop reads the interior point's estimate; the mesh it stops on is then solved
    exactly, and if that answer's estimate is above tol the loop says so (found by review). A target that reads
    the interior point's answers below tol and the exact one above it (a planted target: the two estimates differ
    at solver accuracy on real scenes) makes the case; a target below tol on both raises no such warning."""
    import importlib

    adapt_module = importlib.import_module("cvxcontact.adapt")      # the module (cc.adapt is the function)

    energy = adapt_module.TARGETS["energy"]

    def planted(sol):
        indicators = energy(sol)[0]
        return indicators, (0.5 if sol.polished else 1e-3)

    monkeypatch.setitem(adapt_module.TARGETS, "energy", planted)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        warnings.simplefilter("ignore", cc.ResidualWarning)
        warnings.filterwarnings("error", message="adapt: the interior point", category=cc.ResolutionWarning)
        with pytest.raises(cc.ResolutionWarning, match="its exact answer's reads 0.5"):
            cc.adapt(indented_block(), degree=2, tol=0.01, exact_steps=False)
        monkeypatch.setitem(adapt_module.TARGETS, "energy", lambda sol: (energy(sol)[0], 1e-3))
        result = cc.adapt(indented_block(), degree=2, tol=0.01, exact_steps=False)
    assert result.stopped == "tol" and result.solution.polished
