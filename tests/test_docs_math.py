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
CHECKS = DOCS / "checks.md"
MATH_PAGES = [FORMULATION, MODEL, CHECKS]
# Characters that only a formula uses: a transpose, an inverse or negative power, a norm, an integral, a sum, an
# equivalence, a semidefinite order, a gradient, a root. Written as Unicode in prose they are a plain-text formula.
FORMULA_CHARACTERS = "ᵀ⁻‖∫Σ⇔⪰∇√"
# The symbols of the model: in a section typeset through, a Greek letter (or the body index ℓ) outside $...$ is a
# plain-text symbol.
GREEK = "αβγδεηκλμνξπρστφχψωΓΔΛΠΣΦΨΩℓ"


def displays(path: Path) -> list[str]:
    """The $$ ... $$ blocks of a page (each delimiter on a line of its own)."""
    return re.findall(r"^\$\$\n(.*?)^\$\$$", path.read_text(encoding="utf-8"), re.S | re.M)


def prose(text: str) -> str:
    """The running text of a page: without fenced code, $$ displays, inline code and inline $...$ math."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    text = re.sub(r"^\$\$\n.*?^\$\$$", "", text, flags=re.S | re.M)
    text = re.sub(r"`[^`\n]*`", "", text)
    return re.sub(r"\$[^$\n]+\$", "", text)


def plain_text_displays(text: str) -> list[str]:
    """Lines that display an equation in plain text: indented by two or more spaces outside a list (an indented
    code block, or a two-space "display" that Markdown joins to the paragraph), outside fences and $$ blocks.
    Indented lines that continue a list item (its wrapped text, a table inside it) are prose."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    text = re.sub(r"^\$\$\n.*?^\$\$$", "", text, flags=re.S | re.M)
    found, in_list = [], False
    for line in text.splitlines():
        if re.match(r"\s*([-*]|\d+\.) ", line):
            in_list = True
        elif line.strip() and not line.startswith(" "):
            in_list = False
        elif line.startswith("  ") and line.strip() and not in_list:
            found.append(line)
    return found


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
    assert len(blocks) >= 55, len(blocks)                # measured: 62 (§1-§19)
    tags = set(re.findall(r"\\tag\{([^}]*)\}", "".join(blocks)))
    assert {"1-2", "7", "19", "26", "27", "34", "35"} <= tags, tags
    by_number = sections(FORMULATION)
    assert set(by_number) == {str(n) for n in range(1, 20)}, sorted(by_number)
    for n in ("1", "2", "3", "4", "6", "7", "8", "10", "11", "12", "13", "15", "16", "17", "18", "19"):
        assert "$$" in by_number[n], f"§{n} has no displayed equation"
    for n, text in by_number.items():
        shown = plain_text_displays(text)
        assert not shown, f"§{n} still displays an equation in plain text: {shown[0]!r}"
    assert "y^{\\top} s = 0" in by_number["7"]          # the LCP of the exact finish
    assert "(2 w_s,\\ p_0 - p_2) \\bigr\\rVert \\le p_0 + p_2" in by_number["8"]   # the cone of P2 "gamma3"
    assert "\\tag{7}" in by_number["10"] and "\\tag{19}" in by_number["10"]     # normal compliance, its energy
    assert "$h^{1/2+\\eta/2}$" in by_number["9"]         # the theorems' rates
    assert "\\tag{34}" in by_number["13"] and "\\tag{34}" in by_number["16"]   # K_h(Gamma_3): vertices; copositivity
    assert "\\tag{35}" in by_number["15"]               # K_h(Sigma_h^l) at the P2 nodes
    assert "P_t \\succeq 0" in by_number["16"]


@pytest.mark.parametrize("page", [FORMULATION, CHECKS], ids=lambda p: p.name)
def test_no_formula_is_left_in_plain_text(page):
    """How the test decides that no plain-text equation is left: (i) no line displays one (indented outside a
    list, see ``plain_text_displays``); (ii) no character that only a formula uses (a transpose, a norm, a sum,
    an integral, ...) stands in the running text outside $...$ and code."""
    text = page.read_text(encoding="utf-8")
    assert not plain_text_displays(text), plain_text_displays(text)[0]
    running = prose(text)
    for line in running.splitlines():
        used = [c for c in FORMULA_CHARACTERS if c in line]
        assert not used, f"{page.name}: {used} outside math in {line.strip()!r}"


def test_typeset_sections_write_every_symbol_as_mathematics():
    """The formulation (its preamble and §1-§19) and the whole of checks.md: no Greek symbol in the running
    text (headings keep plain text: they are the pages' anchors)."""
    by_number = sections(FORMULATION)
    assert len(by_number) == 19, sorted(by_number)
    pages = {f"formulation §{n}": text.split("\n", 1)[1]                    # without the heading's title
             for n, text in by_number.items()}
    pages["formulation preamble"] = FORMULATION.read_text(encoding="utf-8").split("\n## 1. ", 1)[0]
    pages["checks.md"] = CHECKS.read_text(encoding="utf-8")
    for name, text in pages.items():
        for line in prose(text).splitlines():
            if line.startswith("#"):
                continue
            used = [c for c in GREEK if c in line]
            assert not used, f"{name}: {used} outside math in {line.strip()!r}"
    assert len(displays(CHECKS)) >= 6, len(displays(CHECKS))     # measured: 7


# Every written page of docs/: not the build products (the gallery, the tutorials' executed copies) nor the studies'
# output (docs/studies/: tables a study writes, where a symbol is data).
GENERATED = {"_build", "auto_examples", "_generated", "studies"}
PAGES = sorted(p for p in DOCS.rglob("*.md") if not GENERATED & set(p.relative_to(DOCS).parts)) + [ROOT / "README.md"]


def plain_text_symbols(text: str) -> list[str]:
    """The lines of a page's running text (outside $...$, $$ blocks, code and headings, which keep plain text:
    they are the pages' anchors) that hold a Greek symbol or a character only a formula uses."""
    return [line.strip() for line in prose(text).splitlines()
            if not line.startswith("#") and any(c in line for c in FORMULA_CHARACTERS + GREEK)]


def test_the_page_list_is_every_written_page():
    names = {p.relative_to(DOCS).as_posix() for p in PAGES if p.is_relative_to(DOCS)}
    assert (ROOT / "README.md") in PAGES and {"materials.md", "architecture.md", "getting-started.md", "refusals.md", "meshes3d.md",
            "explanation/performance.md", "reference/cli.md", "results/studies.md", "tutorials/model.md",
            "howto/3d.md", "formulation.md", "checks.md", "accuracy.md"} <= names, sorted(names)
    assert len(PAGES) >= 40, len(PAGES)                  # measured: 45 pages and the README


def test_a_planted_symbol_is_found():
    """The check below sees a plain-text symbol in prose, a list item and a table cell, and none in code or math."""
    assert plain_text_symbols("The stress σ = c ε is linear.\n")
    assert plain_text_symbols("- read λ_h back\n")
    assert plain_text_symbols("| a | Kᵀ |\n")
    assert plain_text_symbols("## Headings keep σ\n\nthe load on Γ3\n")
    assert not plain_text_symbols("The stress $\\sigma = c\\, \\varepsilon$, `sigma1`, `lam_λ`.\n"
                                  "```python\nσ = 1  # λ\n```\n$$\n\\lambda_h\n$$\n## σ in a heading\n")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_pages_write_their_symbols_and_formulas_as_mathematics(page):
    """Every page: no plain-text display, no character only a formula uses and no Greek symbol in the running text
    outside $...$ and code (headings keep plain text); inline math on one line (GitHub reads $...$ within a
    line)."""
    text = page.read_text(encoding="utf-8")
    assert not plain_text_displays(text), plain_text_displays(text)[0]
    found = plain_text_symbols(text)
    assert not found, f"{page.name}: a symbol outside math in {found[0]!r}"
    unfenced = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    for line in re.sub(r"^\$\$\n.*?^\$\$$", "", unfenced, flags=re.S | re.M).splitlines():
        assert re.sub(r"`[^`]*`", "", line).count("$") % 2 == 0, f"{page.name}: inline math across lines: {line!r}"

def test_model_tutorial_writes_its_equations_as_mathematics():
    text = re.sub(r"^```.*?^```", "", MODEL.read_text(encoding="utf-8"), flags=re.S | re.M)   # the code run
    assert len(displays(MODEL)) >= 5, len(displays(MODEL))
    assert not re.search(r"^ {4}\S", text, re.M), "an indented code block (a plain-text equation?) in the model tutorial"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
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
    for line in re.sub(r"^```.*?^```", "", text, flags=re.S | re.M).splitlines():
        if "$$" in re.sub(r"`[^`]*`", "", line):                 # `$$...$$` in code is a name, not a delimiter
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
