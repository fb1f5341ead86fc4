"""Every tutorial page has a figure and executed output when the site is built, and a downloadable notebook
that is the page as it stands (docs/_ext/tutorial_cells.py, which the Sphinx build runs on each page)."""

import importlib.util
import json
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = ROOT / "docs" / "tutorials"
_spec = importlib.util.spec_from_file_location("tutorial_cells", ROOT / "docs" / "_ext" / "tutorial_cells.py")
cells = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cells)
PAGES = cells.pages()


def test_every_tutorial_page_is_listed():
    listed = {p.name for p in PAGES}
    present = {p.name for p in TUTORIALS.glob("*.md")} - {"index.md"}
    assert listed == present and len(listed) >= 5, (listed, present)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.stem)
def test_tutorial_runs_with_output_and_a_figure(page, tmp_path):
    """What the build inserts into the page: the blocks' printed output and at least one figure, the figure
    files written (non-empty PNGs) and linked from the page."""
    text, figures = cells.run(page, figures=tmp_path)
    assert figures, f"{page.name}: no figure drawn by its code"
    for path in figures:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000, path
        assert f"]({os.path.relpath(path, page.parent)})" in text, path
    assert re.search(r"^```text\n\S", text, re.M), f"{page.name}: no printed output"
    assert text.startswith(page.read_text(encoding="utf-8").split("```python", 1)[0]), "the page's text changed"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.stem)
def test_tutorial_links_its_notebook_and_the_notebook_is_the_page(page):
    pytest.importorskip("jupytext")
    name = f"notebooks/{page.stem}.ipynb"
    assert f"]({name})" in page.read_text(encoding="utf-8"), f"{page.name} does not link {name}"
    committed = TUTORIALS / name
    assert committed.exists(), f"{committed} missing: run python docs/_ext/tutorial_cells.py"
    assert json.loads(committed.read_text(encoding="utf-8")) == json.loads(cells.notebook(page)), \
        f"{committed.name} is out of date with {page.name}: run python docs/_ext/tutorial_cells.py"
    book = json.loads(committed.read_text(encoding="utf-8"))
    code = ["".join(c["source"]) for c in book["cells"] if c["cell_type"] == "code"]
    # the notebook runs as the page does: the README's quickstart first, then the page's blocks in order
    assert code[0].strip() == cells.quickstart().strip()
    assert [c.strip() for c in code[1:]] == [b.strip() for b in cells.BLOCK.findall(page.read_text(encoding="utf-8"))]


def test_solve_docstring_is_short_and_links_its_options_page():
    """numpydoc, one short entry per parameter (at most 3 lines); the long explanations live in
    docs/reference/solve-options.md, one section per option that needs one."""
    import inspect

    import cvxcontact as cc

    doc = inspect.getdoc(cc.solve)
    assert "docs/reference/solve-options.md" in doc
    params = doc.split("Parameters\n----------\n", 1)[1].split("\n\nReturns", 1)[0]
    entries = re.split(r"\n(?=\w+ : )", params)
    names = [e.split(" : ", 1)[0] for e in entries]
    assert names == list(inspect.signature(cc.solve).parameters), names
    for entry in entries:
        assert len(entry.splitlines()) <= 4, entry          # the "name : type" line and at most 3 lines
    page = (ROOT / "docs" / "reference" / "solve-options.md").read_text(encoding="utf-8")
    for option in ("method", "polish", "law", "degree", "factorization", "estimate"):
        assert f"## `{option}`" in page, option


def test_learning_path_runs_through_every_tutorial_and_ends_with_the_accuracy():
    """The path ends with the accuracy of an answer; after it come only the extensions (a nonlinear material,
    quadrilaterals, friction), each a tutorial (issue 32)."""
    text = (ROOT / "docs" / "index.md").read_text(encoding="utf-8").split("## A learning path", 1)[1]
    steps = re.findall(r"^\d+\. \[[^]]+\]\(([^)]+)\)", text, re.M)
    assert "accuracy.md" in steps, steps
    after = steps[steps.index("accuracy.md") + 1:]
    assert all(s.startswith("tutorials/") for s in after), steps
    assert {"tutorials/hencky.md", "tutorials/quadrilaterals.md", "tutorials/friction.md"} <= set(after), steps
    assert [int(n) for n in re.findall(r"^(\d+)\. \[", text, re.M)] == list(range(1, len(steps) + 1)), steps
    tutorials = [s for s in steps if s.startswith("tutorials/")]
    assert tutorials == [f"tutorials/{p.name}" for p in PAGES], tutorials   # in the tutorials' own order
    assert all((ROOT / "docs" / s).exists() for s in steps), steps


def _public_callables():
    import cvxcontact as cc

    rigid = {f"Rigid.{n}": getattr(cc.Rigid, n)
             for n in ("plane", "circle", "profile", "sphere", "cylinder", "height_field")}
    solution = {f"Solution.{n}": getattr(cc.Solution, n) for n in ("traction", "in_contact", "contact_fraction")}
    model = {f"Model.{n}": getattr(cc.Model, n) for n in ("u", "phi", "translation", "add", "add_objective")}
    return {"solve": cc.solve, "ContactSolver": cc.ContactSolver, "Model": cc.Model, "Scene": cc.Scene,
            "Body": cc.Body, "Contact": cc.Contact, "Rigid": cc.Rigid, "adapt": cc.adapt, "force_estimate": cc.force_estimate, **rigid, **solution,
            **model}


def _section(doc: str, title: str) -> list[str]:
    """The entries of a numpydoc section ("Parameters", "Attributes"): one string per ``name : type`` line
    and its indented description."""
    body = doc.split(f"{title}\n{'-' * len(title)}\n", 1)[1]
    body = re.split(r"\n\n(?=\w[\w ]*\n-+\n)", body, maxsplit=1)[0]     # up to the next section
    return re.split(r"\n(?=\*{0,2}\w+ : )", body.strip("\n"))


@pytest.mark.parametrize("name", list(_public_callables()))
def test_public_callables_have_numpydoc_parameters_naming_every_parameter(name):
    """numpydoc: a "Parameters" section whose entries are the signature's parameters in order, each with a
    type (units in the type or the text where the quantity has one) and at most 3 lines of text; the long
    explanations live on the docs pages the docstring names, and those pages and sections exist."""
    import inspect

    obj = _public_callables()[name]
    doc = inspect.getdoc(obj)
    assert "Parameters\n----------\n" in doc, f"{name}: no numpydoc Parameters section"
    entries = _section(doc, "Parameters")
    names = [e.split(" : ", 1)[0].lstrip("*") for e in entries]
    assert names == [p for p in inspect.signature(obj).parameters if p != "self"], (name, names)
    for entry in entries:
        head = entry.splitlines()[0]
        assert head.split(" : ", 1)[1].strip(), f"{name}: {head!r} has no type"
        assert len(entry.splitlines()) <= 4, f"{name}: a long entry, move it to a docs page:\n{entry}"
    summary = doc.split("\n\n", 1)[0]
    assert len(summary.splitlines()) == 1, f"{name}: the summary is one line: {summary!r}"
    intro = doc.split("Parameters\n----------\n", 1)[0]
    assert len(intro.splitlines()) <= 8, f"{name}: {len(intro.splitlines())} lines before Parameters"
    for page, heading in re.findall(r'(docs/[\w/.-]+\.md),\s+"([^"]+)"', doc):
        text = (ROOT / page).read_text(encoding="utf-8")
        headings = {re.sub(r"[`]", "", h).strip() for h in re.findall(r"^#+ (.*)$", text, re.M)}
        assert heading in headings, f"{name} names {page}, {heading!r}: no such heading"
    for page in re.findall(r"(docs/[\w/.-]+\.md)", doc):
        assert (ROOT / page).exists(), f"{name} names {page}, which does not exist"


@pytest.mark.parametrize("name", ["residuals", "report", "traction", "in_contact", "contact_fraction"])
def test_solution_methods_have_numpydoc_returns(name):
    """numpydoc: a one-line summary, a "Returns" section whose entries name a type and hold at most 3 lines of
    text (units in the text); the docs pages and headings the docstring names exist."""
    import inspect

    import cvxcontact as cc

    doc = inspect.getdoc(getattr(cc.Solution, name))
    assert len(doc.split("\n\n", 1)[0].splitlines()) == 1, f"{name}: the summary is one line"
    assert "Returns\n-------\n" in doc, f"{name}: no numpydoc Returns section"
    entries = re.split(r"\n(?=\S)", doc.split("Returns\n-------\n", 1)[1].strip("\n"))
    for entry in entries:
        assert len(entry.splitlines()) <= 4, f"{name}: a long entry, move it to a docs page:\n{entry}"
    for page, heading in re.findall(r'(docs/[\w/.-]+\.md),\s+"([^"]+)"', doc):
        headings = {re.sub(r"[`$]", "", h).strip()
                    for h in re.findall(r"^#+ (.*)$", (ROOT / page).read_text(encoding="utf-8"), re.M)}
        assert heading in headings, f"Solution.{name} names {page}, {heading!r}: no such heading"


def test_solution_documents_its_main_attributes():
    """The Solution's docstring lists its main attributes (numpydoc "Attributes", short entries with units),
    and every name listed is an attribute of a solved Solution."""
    import inspect

    import cvxcontact as cc
    from cvxcontact.apps.demo import two_blocks

    doc = inspect.getdoc(cc.Solution)
    entries = _section(doc, "Attributes")
    names = [e.split(" : ", 1)[0] for e in entries]
    assert {"u", "phi", "contact", "energy", "ok", "tol", "info", "electrodes", "obstacles"} <= set(names), names
    for entry in entries:
        assert len(entry.splitlines()) <= 4, entry
    sol = cc.solve(two_blocks(nx=4))
    for attribute in names:
        assert hasattr(sol, attribute), attribute
    assert len(doc.split("Attributes\n----------\n", 1)[0].splitlines()) <= 8
