"""Claims of the documentation that are not run as snippets, re-measured here."""

import io
import posixpath
import re
import subprocess
from contextlib import redirect_stderr
from pathlib import Path, PurePosixPath
from urllib.parse import unquote

import pytest

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks
from cvxcontact.backends import METHODS

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_checks_after_an_exact_finish_read_rounding_and_its_root():
    """docs/checks.md: after the exact finish equilibrium, feasibility and cone are at rounding level
    (<= 1e-13), complementarity (the slack's rounding taken off) 0 (the root of rounding before, 4.6e-9 … 5.8e-9)."""
    for condition in cc.CONDITIONS:
        sol = cc.solve(two_blocks(16), condition)
        r = sol.residuals()
        assert sol.polished and max(r["equilibrium"], r["feasibility"], r["cone"]) <= 1e-13, r   # measured <= 5e-16
        assert r["complementarity"] <= 1e-12, r                                                   # measured 0.0


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


def _checkout_paths():
    """The files of a plain checkout (git's tracked files, so that build products such as docs/auto_examples/ do
    not count) and their folders, as paths relative to the repository."""
    root = EXAMPLES.parent
    try:
        out = subprocess.run(["git", "-C", str(root), "ls-files"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the files of a plain checkout are unknown")
    files = {PurePosixPath(f) for f in out.splitlines()}
    return files | {d for f in files for d in f.parents}


def _markdown_links(text):
    """The link and image targets of a Markdown page as CommonMark (MyST's parser) reads them: code spans, fenced
    and indented code blocks and escaped brackets hold none."""
    from markdown_it import MarkdownIt

    def walk(tokens):
        for t in tokens:
            if t.type == "link_open":
                yield t.attrGet("href")
            elif t.type == "image":
                yield t.attrGet("src")
            yield from walk(t.children or ())

    return list(walk(MarkdownIt("commonmark").parse(text)))


def test_markdown_links_point_at_files_of_a_plain_checkout():
    """Every relative link of docs/**/*.md and README.md names a file or folder of a plain checkout (resolved from
    the page's folder, as GitHub follows it): no link to a build product (auto_examples/*.rst, *.html)."""
    pytest.importorskip("markdown_it")
    root = EXAMPLES.parent
    present = _checkout_paths()
    pages = sorted((root / "docs").rglob("*.md")) + [root / "README.md"]
    pages = [p for p in pages if PurePosixPath(p.relative_to(root).as_posix()) in present]
    dead, count = [], 0
    for page in pages:
        for href in _markdown_links(page.read_text(encoding="utf-8")):
            target = unquote(href.split("#", 1)[0])
            if not target or re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):      # an anchor, http(s), mailto
                continue
            count += 1
            where = PurePosixPath(posixpath.normpath(posixpath.join(page.parent.relative_to(root).as_posix(), target)))
            if where not in present:
                dead.append(f"{page.relative_to(root)}: {href}")
    assert count > 100, count               # the pages' relative links were read (measured: 127)
    assert not dead, "links to files a plain checkout lacks:\n" + "\n".join(dead)
