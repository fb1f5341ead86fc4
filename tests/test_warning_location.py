"""The warnings of a solve name the caller's line (file and line number), whichever entry point it called:
cvxcontact.solve, ContactSolver.solve, ContactSolver.solve_many (its first load case alone, then batched): each
reaches the warning through a different depth of the package's calls (cvxcontact.errors.user_stacklevel)."""

import sys
import warnings

from conftest import two_blocks

import cvxcontact as cc


def _here():
    return sys._getframe(1).f_lineno


def _coarse(i=0):
    """A contact zone of too few cells (a ResolutionWarning, measured), the upper block's traction varied."""
    return two_blocks(n1=(3, 2), n2=(2, 2), traction={"right": (0.0, 3e8 * (1 + i / 10))})


def _where(caught, category):
    return {(w.filename, w.lineno) for w in caught if issubclass(w.category, category)}


def test_warnings_name_the_line_that_called_the_solve():
    options = {"method": "condensed", "factorization": "superlu"}
    solver = cc.ContactSolver(_coarse(), **options)
    fresh = cc.ContactSolver(_coarse(), **options)
    strict = cc.ContactSolver(_coarse(), tol=1e-17, **options)          # fails its checks: a ResidualWarning
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        calls = [(cc.solve(_coarse(), **options), _here()), (solver.solve(), _here()),
                 (solver.solve_many([_coarse(1), _coarse(2)]), _here()),
                 (fresh.solve_many([_coarse(1), _coarse(2)]), _here())]
        assert _where(caught, cc.ResolutionWarning) == {(__file__, line) for _, line in calls}
        caught.clear()
        _, line = strict.solve_many([_coarse(1), _coarse(2)]), _here()
        assert _where(caught, cc.ResidualWarning) == {(__file__, line)}
