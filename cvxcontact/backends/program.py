"""Running a CVXPY program: the solver settings of the package and one normalised call (:func:`run_program`)."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Mapping

import cvxpy as cp

from ..errors import SolverError

__all__ = ["CLARABEL", "CLARABEL_BULK_CONES", "CLARABEL_CONIC", "CLARABEL_CONIC_PAIRS", "conic_options", "release",
           "run_program", "timed_program"]

CLARABEL = dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10, tol_ktratio=1e-8)
"""Clarabel's tolerances for the package's programs (their answers are finished exactly where a finish applies)."""

CLARABEL_CONIC = dict(tol_gap_abs=1e-14, tol_gap_rel=1e-14, tol_feas=1e-10, tol_ktratio=1e-10, max_iter=400,
                      equilibrate_enable=False)
"""Clarabel settings of the conic (P2 "gamma3") condition, which has no exact finish (docs/formulation.md §8):
tight gap tolerances; feasibility 1e-10 (tighter stalls at about 1e-11 and ends "inaccurate"); no
equilibration, since the data are already non-dimensionalised (measured: it halves to eightfolds the
complementarity reached by the condensed SOCP on two_blocks 16x8 and 32x16)."""

CLARABEL_BULK_CONES = {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-11, "tol_ktratio": 1e-10,
                       "max_iter": 400}
"""Clarabel settings of the P2 cones beside a non-quadratic bulk energy (a Hencky body; docs/formulation.md §19),
whose exact finish (:func:`~cvxcontact.backends.cones.finish_bulk`) starts from the interior point's answer.
Measured on 48 scenes (tests/test_p2_cones_hencky.py's pressed block, 3 to 12 cells across, sigma_y 2e5 Pa to
never reached; two Hencky blocks, 4 to 16 cells, two loads): the finish settles on the same 42 with these as with
:data:`CLARABEL`; on the 6 where it declines (the heavier load, the whole line in contact) the interior point's
answer stands, and passes the checks at the default tol on 5 of them with these, on 1 with :data:`CLARABEL`. With
:data:`CLARABEL_CONIC` (unequilibrated) the program ended "inaccurate" after 400 iterations (equilibrium 1e-2 of
the Hencky terms); tighter than these (1e-13, 1e-12), 1 of 24 ended "inaccurate"."""

CLARABEL_CONIC_PAIRS = dict(max_step_fraction=0.95)
"""Added to :data:`CLARABEL_CONIC` for the program of P2 cones with a normal-compliance law on several
pairs (docs/formulation.md §10, "P2"; one pair keeps :data:`CLARABEL_CONIC`, on which its tests were
measured): steps of at most 0.95 of the way to the cone boundary (Clarabel's default 0.99). Measured on 22
solves of tests/test_p2_mixed_laws.py's scenes (both backends, single pairs, decoupled and interacting stacks,
exponent 1): with 0.99, 1 ended "inaccurate" (a compliant pair next to a conic one, condensed: the last step
left the stalled iterate, complementarity 3.5e-5; gap tolerances of 1e-13 did not help); with 0.95 all 22
end "optimal" with complementarity <= 1e-5. With exponent 2 (a power cone) the program still ends
"inaccurate" there (complementarity ~5e-6)."""


def conic_options(solver: str, options: Mapping[str, object], pairs: int = 1, quadratic: bool = True) -> dict:
    """Solver options of the conic condition: no exact finish applies, so Clarabel is run to tighter
    tolerances on the scaled data (:data:`CLARABEL_CONIC`, with :data:`CLARABEL_CONIC_PAIRS` for a program of
    cones and compliance on several ``pairs``; :data:`CLARABEL_BULK_CONES` beside a non-quadratic bulk energy,
    ``quadratic`` False); the user's ``options`` still win."""
    if solver != "CLARABEL":
        return dict(options)
    if not quadratic:
        return {**CLARABEL_BULK_CONES, **options}
    return {**CLARABEL_CONIC, **(CLARABEL_CONIC_PAIRS if pairs > 1 else {}), **options}


STATUS_HINTS = {
    cp.UNBOUNDED: ": the energy decreases without bound along a motion nothing holds (a load or a user objective "
                  "(cc.Model.add_objective) slides a body or an obstacle past its friction capacity, or along a motion "
                  "no contact or support resists); hold the motion (a support, a user constraint) or reduce the "
                  "load or objective",
    cp.UNBOUNDED_INACCURATE: ": the energy seems to decrease without bound along a motion nothing holds (a load "
                             "or a user objective slides a body or an obstacle past its friction capacity, or along "
                             "a motion no contact or support resists); hold the motion or reduce the load",
}
"""What a program's status says of the scene, added to the :class:`~cvxcontact.errors.SolverError` that
:func:`run_program` raises."""


def run_program(problem: cp.Problem, solver: str, verbose: bool, options: Mapping[str, object]) -> int:
    """Solve ``problem`` with ``solver`` (Clarabel: :data:`CLARABEL` under the given ``options``); the number of
    iterations. SolverError if the solver fails, refuses an option, or ends without a solution."""
    given = sorted(options)
    if solver == "CLARABEL":
        options = {**CLARABEL, **options}
    try:
        _solve(problem, solver, verbose, options)
    except cp.error.SolverError as exc:
        raise SolverError(f"{solver} failed: {exc}") from exc
    except Exception as exc:  # e.g. an option the solver refuses: TypeError, ValueError, OverflowError
        raise SolverError(f"{solver} refused the problem or the solver options {given}: "
                          f"{type(exc).__name__}: {exc}") from exc
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{solver} ended with status {problem.status!r}; no solution to read back"
                          + STATUS_HINTS.get(problem.status, ""))
    return int(getattr(problem.solver_stats, "num_iters", None) or 0)


_SOLVE_KEYWORDS = ("solver_verbose", "solver_path", "bibtex", "nlp")
"""Keywords of CVXPY's ``Problem.solve`` not in :data:`~cvxcontact.backends.options.RESERVED` (which refuses the
others): :func:`_solve` passes them to ``problem.solve``."""


def _solve(problem: cp.Problem, solver: str, verbose: bool, options: Mapping[str, object]) -> None:
    """``problem.solve(solver=solver, verbose=verbose, **options)`` without CVXPY's warning "Solution may be
    inaccurate" (the status is recorded in SolveInfo and the checks say what holds), and without changing the
    warning filters where the solver ends with a status CVXPY does not warn of: CVXPY's documented steps of a
    solve (``get_problem_data``, the chain's ``solve_via_data``, ``unpack_results``), the status read from the
    chain's inverse before ``unpack_results`` issues the warning, which a ``catch_warnings`` then silences.

    Any change of the filters (``catch_warnings`` enter and exit) empties every module's record of the warnings
    the "default" action showed once per place, and a user's loop of solves showed the package's warnings at
    every solve (tests/test_warning_once.py). A verbose solve (CVXPY's own log), an option ``problem.solve``
    reads itself (:data:`_SOLVE_KEYWORDS`, for solvers whose options are not checked) or a parameter without a
    value (CVXPY's ParameterError) runs ``problem.solve`` as before."""
    if verbose or any(k in options for k in _SOLVE_KEYWORDS) or any(p.value is None for p in problem.parameters()):
        with _inaccurate_unsaid():
            problem.solve(solver=solver, verbose=verbose, **options)
        return
    data, chain, inverse = problem.get_problem_data(solver, solver_opts=dict(options))
    raw = chain.solve_via_data(problem, data, True, False, dict(options))     # warm_start: problem.solve's default
    if chain.invert(raw, inverse).status not in cp.settings.INACCURATE:
        problem.unpack_results(raw, chain, inverse)
        return
    with _inaccurate_unsaid():
        problem.unpack_results(raw, chain, inverse)


@contextlib.contextmanager
def _inaccurate_unsaid():
    """CVXPY's "Solution may be inaccurate" not shown (a change of the warning filters: only where it is issued)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Solution may be inaccurate", category=UserWarning)
        yield


def timed_program(problem: cp.Problem, settings, timings: dict, options: Mapping[str, object] | None = None) -> int:
    """:func:`run_program` with ``settings`` (a :class:`~cvxcontact.backends.result.Settings`; ``options``
    instead of its own if given), recording the compile and solve times in ``timings``."""
    iterations = run_program(problem, settings.solver, settings.verbose,
                             settings.options if options is None else options)
    timings["compile"] = problem.compilation_time or 0.0
    timings["solve"] = problem.solver_stats.solve_time or 0.0
    return iterations


def release(problem: cp.Problem) -> None:
    """Free what CVXPY keeps of a solved ``problem`` for a later solve of the same problem: its compiled data
    and the solver object (Clarabel's, with its KKT factors) held for warm starts. The values, the duals and
    the status stay. For a program solved once whose answer a finish takes over: the condensed "gamma3"
    interface program of two 3D bodies kept these through the finish (305,562 unknowns, the dense Sigma blocks
    of 4,178 contact dofs: about 1 GB; benchmarks/results/bench_gamma3_scale.md)."""
    cache = getattr(problem, "_cache", None)
    if cache is not None and hasattr(cache, "invalidate"):
        cache.invalidate()
    if isinstance(getattr(problem, "_solver_cache", None), dict):
        problem._solver_cache = {}
