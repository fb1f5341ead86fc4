"""Validation of the parameters of :func:`cvxcontact.solve` and of the solver options.

Everything here runs before any assembly or solve, so that a bad parameter costs
nothing and leaves nothing behind. Errors name the parameter (or option) and what
was expected: :class:`~cvxcontact.errors.SolverError`, or
:class:`~cvxcontact.errors.SceneError` for the contact condition.
"""

from __future__ import annotations

import difflib
import functools
import math
import numbers
from collections.abc import Mapping

from ..contact.interface import CONDITIONS
from ..errors import SceneError, SolverError
from . import METHODS

__all__ = ["check_solve_parameters", "check_solver", "check_solver_options", "check_factorization", "RESERVED"]

RESERVED = {
    "solver": "the solver argument", "verbose": "the verbose argument", "tol": "the tol argument",
    "polish": "the polish argument", "method": "the method argument", "condition": "the condition argument",
    "scale": "the scale argument of ContactSolver", "warm_start": "the warm_start argument of ContactSolver",
    "solver_options": "a flat table of options", "factorization": "the factorization argument", "gp": None, "qcp": None, "requires_grad": None,
    "enforce_dpp": None, "ignore_dpp": None, "canon_backend": None, "use_quad_obj": None,
}
"""Names that are not solver options: cvxcontact's own parameters, and CVXPY's ``Problem.solve`` keywords."""

_U32 = 2**32 - 1


@functools.cache
def _installed_solvers() -> tuple:
    """CVXPY's installed solvers, asked once per process (the query imports every solver interface: 30 ms, once
    per ContactSolver before; measured on the adapt study, 5 % of a P2 run)."""
    import cvxpy as cp

    return tuple(cp.installed_solvers())


def check_solver(solver) -> str:
    """The upper-case name of an installed CVXPY solver; :class:`SolverError` otherwise."""
    installed = list(_installed_solvers())
    if not isinstance(solver, str) or solver.upper() not in installed:
        raise SolverError(f"solver {solver!r} is not available; installed CVXPY solvers: {installed}")
    return solver.upper()


def check_factorization(factorization) -> str:
    """The factorisation adapter ``factorization`` will run (:mod:`cvxcontact.backends.factor`): "auto" gives
    "pardiso" if Intel oneMKL loads, else "superlu". :class:`SolverError` for an unknown name, or for
    "pardiso" when oneMKL is not installed (``pip install "cvxcontact[pardiso]"``)."""
    from .factor import FACTORIZATIONS, resolve

    if not isinstance(factorization, str) or factorization not in FACTORIZATIONS:
        raise SolverError(f"factorization must be one of {FACTORIZATIONS}, got {factorization!r}")
    return resolve(factorization)


def check_solve_parameters(condition, method, tol, **flags) -> float:
    """Check ``condition``, ``method``, ``tol`` (finite, > 0) and boolean ``flags`` (e.g. polish=True).

    Returns ``tol`` as a float.
    """
    if not isinstance(condition, str) or condition not in CONDITIONS:
        raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
    if not isinstance(method, str) or method not in METHODS:
        raise SolverError(f"method must be one of {METHODS}, got {method!r}")
    if not _real(tol) or not (math.isfinite(tol) and tol > 0):
        raise SolverError(f"tol must be a finite positive number (relative residual), got {tol!r}")
    for name, value in flags.items():
        if not isinstance(value, bool):
            raise SolverError(f"{name} must be True or False, got {value!r} ({type(value).__name__})")
    return float(tol)


def check_solver_options(options: Mapping[str, object] | None, solver: str = "CLARABEL") -> dict:
    """A validated copy of ``options`` for ``solver`` (an upper-case CVXPY solver name).

    Keys are strings; values bool, int, float or str, numbers finite. For Clarabel the
    names are those of ``clarabel.DefaultSettings()``, each value of the default's type
    (an int is accepted for a float), with tolerances > 0, ``max_iter`` >= 1,
    ``time_limit`` > 0 (s) and other counts in 0 .. 2**32 - 1. Other solvers check
    their own names at solve time.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise SolverError(f"solver_options must be a dict of option name -> value, got {type(options).__name__}")
    defaults = _clarabel_defaults() if solver == "CLARABEL" else None
    out = {}
    for key, value in options.items():
        if not isinstance(key, str) or not key:
            raise SolverError(f"solver option names must be non-empty strings, got {key!r}")
        if key in RESERVED:
            use = RESERVED[key]
            raise SolverError(f"solver option {key!r} is not a solver option"
                              + (f"; use {use}" if use else "; cvxcontact sets it itself"))
        if isinstance(value, bool) or isinstance(value, str):
            pass
        elif isinstance(value, numbers.Integral):
            value = int(value)
        elif isinstance(value, numbers.Real):
            value = float(value)
            if not math.isfinite(value):
                raise SolverError(f"solver option {key!r} must be finite, got {value!r}")
        else:
            raise SolverError(f"solver option {key!r} must be a bool, int, float or str, "
                              f"got {type(value).__name__}")
        if defaults is not None:
            value = _check_clarabel(key, value, defaults)
        out[key] = value
    return out


def _real(x):
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


def _clarabel_defaults():
    import clarabel

    s = clarabel.DefaultSettings()
    return {k: getattr(s, k) for k in dir(s)
            if not k.startswith("_") and isinstance(getattr(s, k), (bool, int, float, str))}


def _check_clarabel(key, value, defaults):
    if key not in defaults:
        close = difflib.get_close_matches(key, list(defaults), n=3, cutoff=0.6)
        hint = f"; did you mean {close}?" if close else f"; Clarabel's options: {sorted(defaults)}"
        raise SolverError(f"unknown Clarabel option {key!r}{hint}")
    default = defaults[key]
    kind = type(default)
    if kind is float and _real(value):
        value = float(value)
    elif type(value) is not kind:
        raise SolverError(f"Clarabel option {key!r} must be {_kind_name(kind)}, got {value!r} "
                          f"({type(value).__name__})")
    if "tol_" in key and not value > 0:
        raise SolverError(f"Clarabel option {key!r} must be > 0, got {value!r}")
    if key == "max_iter" and not 1 <= value <= _U32:
        raise SolverError(f"Clarabel option 'max_iter' must be an integer from 1 to {_U32}, got {value!r}")
    if key == "time_limit" and not value > 0:
        raise SolverError(f"Clarabel option 'time_limit' must be > 0 (seconds), got {value!r}")
    if kind is int and not 0 <= value <= _U32:
        raise SolverError(f"Clarabel option {key!r} must be an integer from 0 to {_U32}, got {value!r}")
    return value


def _kind_name(kind):
    return {bool: "true or false", int: "an integer", float: "a number", str: "a string"}[kind]
