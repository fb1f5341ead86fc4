"""A warning of a solve is shown once per place under Python's "default" action, as any warning issued at that
line is, when a user solves in a loop: ``for load in loads: cc.solve(scene)``. Python keeps what the "default"
action showed in the module's ``__warningregistry__`` and empties every registry at any change of the filters
(``warnings.catch_warnings`` enter and exit); the package entered one inside every solve (running CVXPY, the
dense LU's and the finishes' factorisations), so the same NonUniqueWarning and ResolutionWarning were shown at
every iteration (3 solves from one line: 3 of each, in a plain script and under ``simplefilter("default")``).
The solve now leaves the filters alone; a caller's own filters and records work as before."""

import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import cvxpy as cp
import numpy as np
import pytest
import scipy.linalg as sla
from obstacle_scenes import half_model

import cvxcontact as cc
from cvxcontact.backends.factor import DenseLU, dense_lu
from cvxcontact.backends.program import CLARABEL, run_program
from cvxcontact.errors import SolverError

TESTS = Path(__file__).resolve().parent


def _one_node():
    """A force-controlled circle touching one node of the block under it: a NonUniqueWarning and a
    ResolutionWarning (tests/test_warning_location.py, measured)."""
    return half_model(force=(0.0, -1e7), center_x=0.5, roller=())


def _count(caught, category):
    return sum(issubclass(w.category, category) for w in caught)


def _solve():
    return cc.solve(_one_node(), condition="sigma1")


def test_a_loop_from_one_line_shows_each_warning_once_under_default():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        for _ in range(3):
            cc.solve(_one_node(), condition="sigma1")
    assert [_count(caught, c) for c in (cc.NonUniqueWarning, cc.ResolutionWarning)] == [1, 1]


def test_different_lines_show_it_once_each_and_always_shows_every_one():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        for _ in range(2):
            cc.solve(_one_node(), condition="sigma1")
            cc.solve(_one_node(), condition="sigma1")
    assert _count(caught, cc.NonUniqueWarning) == 2
    assert len({w.lineno for w in caught if issubclass(w.category, cc.NonUniqueWarning)}) == 2
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(3):
            cc.solve(_one_node(), condition="sigma1")
    assert [_count(caught, c) for c in (cc.NonUniqueWarning, cc.ResolutionWarning)] == [3, 3]


def test_a_callers_record_and_error_filters_still_apply():
    with warnings.catch_warnings(record=True) as caught:      # the caller's record sees the package's warnings
        warnings.simplefilter("always")
        _solve()
    assert _count(caught, cc.NonUniqueWarning) == 1
    with warnings.catch_warnings():
        warnings.filterwarnings("error", category=cc.NonUniqueWarning)
        with pytest.raises(cc.NonUniqueWarning):
            _solve()
    with warnings.catch_warnings(record=True) as caught:      # and its "ignore"
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", category=cc.NonUniqueWarning)
        _solve()
    assert _count(caught, cc.NonUniqueWarning) == 0 and _count(caught, cc.ResolutionWarning) == 1


def test_the_solve_leaves_the_filters_alone(monkeypatch):
    """What the above rests on, counted where it happens: no change of the filters (``warnings._filters_mutated``,
    which ``catch_warnings``, ``filterwarnings`` and ``simplefilter`` call) during a solve that warns (a dense LU,
    the rows' finish, Clarabel) nor one that does not (two blocks, the LCP finish)."""
    from conftest import two_blocks
    calls = []
    mutated = warnings._filters_mutated
    monkeypatch.setattr(warnings, "_filters_mutated", lambda: calls.append(1) or mutated())
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        _solve()                          # once per process: imports, the PARDISO library's look-up
        calls.clear()
        _solve()
        cc.solve(two_blocks(n1=(3, 2), n2=(2, 2), traction={"right": (0.0, 3e8)}))
        cc.solve(two_blocks(n1=(3, 2), n2=(2, 2), traction={"right": (0.0, 3e8)}), method="full")
        assert calls == []


SCRIPT = """
import sys
sys.path.insert(0, {tests!r})
from obstacle_scenes import half_model
import cvxcontact as cc

def scene():
    return half_model(force=(0.0, -1e7), center_x=0.5, roller=())

for _ in range(3):
    cc.solve(scene(), condition="sigma1")
{more}
"""


@pytest.mark.parametrize("more, shown", [("", 1), ("cc.solve(scene(), condition='sigma1')", 2)])
def test_a_plain_script_under_python_s_default_filters(tmp_path, more, shown):
    """As a user's script runs: ``python script.py``, Python's own default filters (no -W, no PYTHONWARNINGS)."""
    script = tmp_path / "user_loop.py"
    script.write_text(textwrap.dedent(SCRIPT.format(tests=str(TESTS), more=more)))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=600,
                         check=False)
    assert run.returncode == 0, run.stderr
    assert [run.stderr.count(f"{c}:") for c in ("NonUniqueWarning", "ResolutionWarning")] == [shown, shown], \
        run.stderr


# ------------------------------------------------------------------ the calls that replaced the filters

def _least_squares():
    """A small constrained least-squares program: Clarabel ends it "optimal" at its defaults, "optimal_inaccurate"
    at max_iter 5 to 9 and "user_limit" at 1 to 4 under gap and feasibility tolerances of 1e-14 (measured)."""
    rng = np.random.default_rng(0)
    A, b = rng.standard_normal((30, 10)), rng.standard_normal(30)
    x = cp.Variable(10)
    constraints = [x >= -0.1, cp.sum(x) == 1]
    return cp.Problem(cp.Minimize(cp.sum_squares(A @ x - b)), constraints), x, constraints


@pytest.mark.parametrize("options", [{}, {"max_iter": 6, "tol_gap_abs": 1e-14, "tol_gap_rel": 1e-14,
                                          "tol_feas": 1e-14}])
def test_run_program_answers_as_cvxpy_s_own_solve_without_its_inaccurate_warning(monkeypatch, options):
    """run_program runs CVXPY's steps itself (no filter change unless the status is one CVXPY warns of): the
    same status, value, primal and dual bits as ``problem.solve`` with the same options (the package's
    :data:`CLARABEL` tolerances, the given options winning); CVXPY's "Solution may
    be inaccurate" still silenced ("optimal_inaccurate" here), the filters untouched on an "optimal" solve."""
    reference, x0, c0 = _least_squares()
    with warnings.catch_warnings(record=True) as theirs:
        warnings.simplefilter("always")
        reference.solve(solver="CLARABEL", **{**CLARABEL, **options})     # run_program's: the options win
    ours, x1, c1 = _least_squares()
    calls = []
    mutated = warnings._filters_mutated
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        monkeypatch.setattr(warnings, "_filters_mutated", lambda: calls.append(1) or mutated())
        iterations = run_program(ours, "CLARABEL", False, options)
        monkeypatch.undo()
    assert ours.status == reference.status == ("optimal_inaccurate" if options else "optimal")
    assert [str(w.message)[:26] for w in theirs] == ["Solution may be inaccurate"] * bool(options)
    assert caught == []
    assert (len(calls) > 0) == bool(options)
    assert ours.value == reference.value and np.array_equal(x1.value, x0.value)
    assert all(np.array_equal(a.dual_value, b.dual_value) for a, b in zip(c1, c0))
    assert iterations == reference.solver_stats.num_iters


def test_run_program_still_refuses_a_program_stopped_at_its_limit():
    problem, _, _ = _least_squares()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(SolverError, match="user_limit"):
            run_program(problem, "CLARABEL", False, {"max_iter": 2, "tol_gap_abs": 1e-14, "tol_gap_rel": 1e-14,
                                                     "tol_feas": 1e-14})
    assert caught == []


def test_dense_lu_is_lu_factor_and_raises_where_it_warned():
    """dense_lu: scipy.linalg.lu_factor's bits; an exactly singular matrix raises LinAlgError (DenseLU's
    RuntimeError) and issues no LinAlgWarning, which lu_factor issues there."""
    a = np.random.default_rng(1).standard_normal((7, 7))
    lu, piv = dense_lu(a)
    ref_lu, ref_piv = sla.lu_factor(a)
    assert np.array_equal(lu, ref_lu) and np.array_equal(piv, ref_piv)
    singular = a.copy()
    singular[:, 3] = 0.0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sla.lu_factor(singular)
        assert [w.category for w in caught] == [sla.LinAlgWarning]
        caught.clear()
        with pytest.raises(np.linalg.LinAlgError, match="exactly zero"):
            dense_lu(singular)
        with pytest.raises(RuntimeError, match="singular"):
            DenseLU(__import__("scipy.sparse").sparse.csc_matrix(singular))
        with pytest.raises(ValueError):
            dense_lu(np.full((2, 2), np.nan))
    assert caught == []


def test_run_program_s_other_paths_keep_problem_solve_s_behaviour(capsys):
    """A verbose solve runs ``problem.solve`` (CVXPY's log printed; the same bits); a parameter without a value
    is refused as ``problem.solve`` refuses it (its ParameterError, named in the SolverError)."""
    reference, x0, _ = _least_squares()
    reference.solve(solver="CLARABEL", **CLARABEL)
    verbose, x1, _ = _least_squares()
    run_program(verbose, "CLARABEL", True, {})
    assert "CVXPY" in capsys.readouterr().out and np.array_equal(x1.value, x0.value)
    scale = cp.Parameter(nonneg=True)
    problem, _, constraints = _least_squares()
    unset = cp.Problem(cp.Minimize(scale * problem.objective.args[0]), constraints)
    with pytest.raises(SolverError, match="ParameterError"):
        run_program(unset, "CLARABEL", False, {})


def _settings_spy(monkeypatch):
    """The list that receives every Clarabel settings object CVXPY builds (as a dict of its fields), through
    ``parse_solver_opts``, which both a new solver and a warm (updated) one go through."""
    from cvxpy.reductions.solvers.conic_solvers.clarabel_conif import (
        CLARABEL as ClarabelInterface,
    )
    seen, parse = [], ClarabelInterface.parse_solver_opts

    def spy(verbose, opts, settings=None):
        out = parse(verbose, opts, settings)
        seen.append({k: repr(getattr(out, k)) for k in dir(out) if not k.startswith("_") and k != "default"})
        return out

    monkeypatch.setattr(ClarabelInterface, "parse_solver_opts", staticmethod(spy))
    return seen


@pytest.mark.parametrize("given", ["none", "conic", "conic pairs", "bulk cones", "user"])
def test_run_program_hands_clarabel_problem_solve_s_settings(monkeypatch, given):
    """Every solver option set the package passes (backends/program.py: CLARABEL under the options;
    conic_options' CLARABEL_CONIC, with CLARABEL_CONIC_PAIRS, CLARABEL_BULK_CONES; a user's options) reaches
    Clarabel as ``problem.solve(solver="CLARABEL", verbose=False, **options)`` sets it: every field of the
    settings object equal (verbose included), and the answer's bits and iterations."""
    from cvxcontact.backends.program import conic_options
    options = {"none": {}, "conic": conic_options("CLARABEL", {}), "conic pairs": conic_options("CLARABEL", {}, 2),
               "bulk cones": conic_options("CLARABEL", {}, quadratic=False),
               "user": {"max_iter": 60, "equilibrate_enable": False, "static_regularization_constant": 1e-7,
                        "direct_solve_method": "qdldl"}}[given]
    seen = _settings_spy(monkeypatch)
    reference, x0, c0 = _least_squares()
    reference.solve(solver="CLARABEL", verbose=False, **{**CLARABEL, **options})
    ours, x1, c1 = _least_squares()
    run_program(ours, "CLARABEL", False, options)
    assert len(seen) == 2 and seen[0] == seen[1]
    assert seen[1]["verbose"] == "False" and all(seen[1][k] == repr(v) for k, v in {**CLARABEL, **options}.items())
    assert ours.status == reference.status and np.array_equal(x1.value, x0.value)
    assert all(np.array_equal(a.dual_value, b.dual_value) for a, b in zip(c1, c0))
    assert ours.solver_stats.num_iters == reference.solver_stats.num_iters


def test_a_parameter_changed_between_run_programs_is_problem_solve_s_warm_re_solve(monkeypatch):
    """A parameterised program re-solved with a new parameter value (the friction capacities' fixed point,
    backends/friction.py): run_program takes CVXPY's fast path as ``problem.solve`` does (the cached
    parameterised program, the same Clarabel solver object updated in place, not a new one) and answers its
    bits at every value, iterations and duals included."""
    seen = _settings_spy(monkeypatch)
    answers, solvers = {}, {}
    for how in ("problem.solve", "run_program"):
        problem, x, constraints = _least_squares()
        weight = cp.Parameter(nonneg=True, value=1.0)
        problem = cp.Problem(cp.Minimize(problem.objective.args[0] + weight * cp.sum_squares(x)), constraints)
        out, ids = [], []
        for value in (1.0, 0.3, 2.5, 0.3):
            weight.value = value
            if how == "problem.solve":
                problem.solve(solver="CLARABEL", verbose=False, **CLARABEL)
            else:
                run_program(problem, "CLARABEL", False, {})
            ids.append(id(problem._solver_cache["CLARABEL"]))
            out.append((problem.status, problem.value, x.value.tobytes(),
                        tuple(np.asarray(c.dual_value).tobytes() for c in constraints),
                        problem.solver_stats.num_iters))
        assert problem._cache.param_prog is not None                       # the parameterised program kept
        answers[how], solvers[how] = out, ids
    assert answers["run_program"] == answers["problem.solve"]
    assert len(set(solvers["problem.solve"])) == len(set(solvers["run_program"])) == 1      # updated, not rebuilt
    assert len(seen) == 8 and all(s == seen[0] for s in seen)
    assert answers["run_program"][1][2] != answers["run_program"][0][2]    # the parameter changed the answer
