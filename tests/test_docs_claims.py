"""Claims of the documentation that are not run as snippets, re-measured here."""

import io
from contextlib import redirect_stderr
from pathlib import Path

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks
from cvxcontact.backends import METHODS

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_checks_after_an_exact_finish_read_rounding_and_its_root():
    """docs/checks.md: after the exact finish equilibrium, feasibility and cone are at rounding level
    (<= 1e-13), complementarity (a square root) at the root of rounding (1e-9 … 1e-7)."""
    for condition in cc.CONDITIONS:
        sol = cc.solve(two_blocks(16), condition)
        r = sol.residuals()
        assert sol.polished and max(r["equilibrium"], r["feasibility"], r["cone"]) <= 1e-13, r   # measured <= 5e-16
        assert r["complementarity"] <= 1e-7, r                                                    # measured 1.6e-8


def test_cli_progress_counts_the_active_nodes_of_every_pair(tmp_path):
    """`cvxcontact solve` on the stack (two pairs): the progress line counts the active nodes of both pairs,
    the number the report gives."""
    from cvxcontact.apps.cli import main
    from cvxcontact.io.scenefile import load_scene

    err = io.StringIO()
    with redirect_stderr(err):
        assert main(["solve", str(EXAMPLES / "stack.toml"), "--out", str(tmp_path / "out"), "--no-plots",
                     "--condition", "gamma3"]) == 0
    sol = load_scene(EXAMPLES / "stack.toml").solve("gamma3")
    total = sum(int(c.active.sum()) for c in sol.contacts)
    assert len(sol.contacts) == 2 and total > int(sol.contacts[0].active.sum())
    assert f"{total} active nodes (2 pairs)" in err.getvalue()


def test_solve_info_names_every_method():
    """SolveInfo's docstring names every backend ``method=`` accepts (cvxcontact.backends.METHODS), not a subset."""
    doc = cc.SolveInfo.__doc__
    assert all(f'"{m}"' in doc for m in METHODS), (METHODS, doc)
