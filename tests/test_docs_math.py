"""The documentation's mathematics: typeset ($...$, $$...$$ with the paper's numbers), rendered by a MathJax
bundled into the site (no network), written in what both Sphinx and GitHub's Markdown view typeset; and the
notation table paper <-> code names things the code has. Cheap: reads the sources, builds no site."""

import ast
import inspect
import re
import tomllib
from pathlib import Path

import pytest

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FORMULATION = DOCS / "formulation.md"
MODEL = DOCS / "tutorials" / "model.md"
MATH_PAGES = [FORMULATION, MODEL]


def displays(path: Path) -> list[str]:
    """The $$ ... $$ blocks of a page (each delimiter on a line of its own)."""
    return re.findall(r"^\$\$\n(.*?)^\$\$$", path.read_text(encoding="utf-8"), re.S | re.M)


def sections(path: Path) -> dict[str, str]:
    """A page's ## sections by their number ("1", "2", ...)."""
    parts = re.split(r"^## (\d+)\. ", path.read_text(encoding="utf-8"), flags=re.M)
    return {parts[i]: parts[i + 1] for i in range(1, len(parts) - 1, 2)}


def test_conf_enables_dollar_math_and_a_local_mathjax():
    conf = ast.literal_eval                              # the settings are literals: read them without running conf.py
    tree = ast.parse((DOCS / "conf.py").read_text(encoding="utf-8"))
    settings = {t.id: conf(node.value) for node in tree.body if isinstance(node, ast.Assign)
                for t in node.targets if isinstance(t, ast.Name)
                and t.id in {"extensions", "myst_enable_extensions", "mathjax_path"}}
    assert "dollarmath" in settings["myst_enable_extensions"]
    assert {"sphinx.ext.mathjax", "sphinx-mathjax-offline"} <= set(settings["extensions"])
    path = settings["mathjax_path"]
    assert "//" not in path and not path.startswith("/"), path     # relative: the site's own _static copy, no CDN
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert any(req.startswith("sphinx-mathjax-offline") for req in extras["docs"]), extras["docs"]


def test_formulation_writes_its_central_equations_as_mathematics():
    blocks = displays(FORMULATION)
    assert len(blocks) >= 20, len(blocks)                # measured: 21 (20 in §1-§5 and §7, the rates' in §9)
    tags = set(re.findall(r"\\tag\{([^}]*)\}", "".join(blocks)))
    assert {"1-2", "26", "27", "34", "35"} <= tags, tags
    by_number = sections(FORMULATION)
    for n in ("1", "2", "3", "4", "5", "7"):
        text = by_number[n]
        assert "$$" in text, f"§{n} has no displayed equation"
        # the plain-text equations were indented code blocks: none is left in these sections
        code = re.findall(r"(?:^|\n\n)( {4}\S[^\n]*)", text)
        assert not code, f"§{n} still writes an equation as a code block: {code[0]!r}"
    assert "y^{\\top} s = 0" in by_number["7"]          # the LCP of the exact finish
    assert "$h^{1/2+\\eta/2}$" in by_number["9"]         # the theorems' rates


def test_model_tutorial_writes_its_equations_as_mathematics():
    text = MODEL.read_text(encoding="utf-8")
    assert len(displays(MODEL)) >= 5, len(displays(MODEL))
    assert not re.search(r"^ {4}\S", text, re.M), "an indented code block (a plain-text equation?) in the model tutorial"


@pytest.mark.parametrize("page", MATH_PAGES, ids=lambda p: p.name)
def test_math_is_written_for_sphinx_and_for_github(page):
    """What breaks a formula on one of the two renderers: Sphinx wraps a display holding ``\\\\`` in a split
    environment, where MathJax refuses ``\\tag`` (seen in the first build: "\\tag not allowed in split
    environment"), so tagged matrices separate rows with ``\\cr``; GitHub's Markdown eats the backslash of
    ``\\{`` in inline math (``\\lbrace`` is safe); a ``$$`` delimiter shares its line with nothing (GitHub and
    MyST both read it then)."""
    text = page.read_text(encoding="utf-8")
    for block in displays(page):
        assert not ("\\tag" in block and "\\\\" in block), f"{page.name}: \\tag in a display with \\\\:\n{block}"
    assert "\\{" not in text and "\\}" not in text, f"{page.name}: use \\lbrace, \\rbrace"
    for line in text.splitlines():
        if "$$" in line:
            assert line == "$$", f"{page.name}: $$ not on a line of its own: {line!r}"
    assert text.splitlines().count("$$") % 2 == 0, f"{page.name}: a $$ block left open"


def _notation_rows() -> list[list[str]]:
    text = MODEL.read_text(encoding="utf-8").split("## The paper's notation in the API", 1)[1]
    rows = [line for line in text.splitlines() if line.startswith("| ")][1:]     # without the header
    return [[c.strip() for c in re.split(r"(?<!\\)\|", row)[1:-1]] for row in rows]


def test_notation_table_names_what_the_code_has():
    """Every code name of the notation table (its last column) exists: constructor keywords in the signatures,
    conditions in cc.CONDITIONS, and the ``sol.``/``scene.``/``material.`` expressions evaluated on a solved
    scene (not None)."""
    rows = _notation_rows()
    assert len(rows) >= 20, len(rows)
    scene = two_blocks(nx=4)
    sol = cc.solve(scene)
    namespace = {"cc": cc, "sol": sol, "scene": scene, "material": cc.materials.PZT5A, "k": 0, "m": 1.0,
                 "l": 1}                                 # Python reads the identifier ℓ as l (NFKC)
    signatures = {"Body": inspect.signature(cc.Body), "Scene": inspect.signature(cc.Scene),
                  "solve": inspect.signature(cc.solve)}
    checked = 0
    for row in rows:
        assert len(row) == 4, row
        for name in re.findall(r"`([^`]+)`", row[3]):
            call = re.fullmatch(r"(Body|Scene)\((.*)\)", name)
            if call:
                for keyword in re.findall(r"(\w+)=", call[2]):
                    assert keyword in signatures[call[1]].parameters, (name, keyword)
            elif re.fullmatch(r'"\w+"', name):
                assert name.strip('"') in cc.CONDITIONS, name
            elif name.startswith("condition="):
                assert "condition" in signatures["solve"].parameters and name[11:-1] in cc.CONDITIONS, name
            elif name.startswith("law="):
                assert "law" in signatures["solve"].parameters
                eval(name[4:].replace("stiffness=k", "stiffness=1e12"), namespace)     # our own table
            else:
                value = eval(name, namespace)                                      # our own table
                assert value is not None, name
            checked += 1
    assert checked >= 25, checked                        # measured: 30 names
