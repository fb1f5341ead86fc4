"""Sphinx configuration of the cvxcontact documentation.

Build (warnings are errors):  python -m sphinx -W --keep-going -b html docs docs/_build/html
Needs ``pip install ".[docs]"`` (Sphinx, MyST-parser, sphinx-gallery, sphinx-mathjax-offline). The pages are
Markdown (MyST), their equations dollar math typeset by a MathJax bundled into the site (readable offline);
the gallery is ``examples/``, every script executed during the build, and so is the code of every tutorial
(``_ext/tutorial_cells.py``: its output and figures are inserted into the page); the API reference is read from
the docstrings (autodoc + napoleon, numpy style). Why these tools: docs/explanation/about-docs.md.
"""

import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS, EXAMPLES = ROOT / "docs", ROOT / "examples"
sys.path.insert(0, str(ROOT))            # the clone's package, also when it is not installed
sys.path.insert(0, str(DOCS / "_ext"))   # tutorial_cells: the tutorials run as the pages are built
os.environ.setdefault("MPLBACKEND", "Agg")

import cvxcontact  # noqa: E402
from sphinx.util import logging  # noqa: E402

_LOG = logging.getLogger(__name__)

project = "cvxcontact"
author = "the cvxcontact developers"
copyright = "the cvxcontact developers, BSD-3-Clause"
release = version = cvxcontact.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",            # MathJax 3.2.2 copied into _static/mathjax: the equations render offline
                                         # (it declares no parallel safety: a build with -j would warn)
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
    "tutorial_cells",                    # docs/_ext: each tutorial's code run, its output and figures inserted
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "tutorials/_generated", "Thumbs.db", ".DS_Store", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json", "auto_examples/*.md5"]

myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]   # $...$, $$...$$ \tag{26}: also GitHub's math
mathjax_path = "mathjax/tex-chtml.js"    # relative: the site's own _static copy (sphinx-mathjax-offline), no CDN
myst_heading_anchors = 3                 # [text](page.md#a-heading) links resolve

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_ivar = True                 # "Attributes": fields of the class, not a second object description
napoleon_custom_sections = [("Methods", "params_style")]   # listed in the class, documented as its members


def _escape_bars(app, what, name, obj, options, lines):
    """The docstrings write mathematics in plain text, where |x| is an absolute value or a norm, never a
    reStructuredText substitution: escape the bars outside ``literals`` and literal blocks."""
    literal_indent = None
    for i, line in enumerate(lines):
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and (not line.strip() or indent > literal_indent):
            continue
        literal_indent = None
        if "|" in line:
            parts = line.split("``")
            lines[i] = "``".join(p.replace("|", "\\|") if k % 2 == 0 else p for k, p in enumerate(parts))
        if line.rstrip().endswith("::"):
            literal_indent = indent


def _gallery_links(app, docname, source):
    """The pages link an example by its source file, ``[text](../../examples/NAME.py)``, and the gallery by its
    folder, ``../examples/`` (links GitHub follows, where the gallery is not built); on the site the same links go
    to the example's gallery page ``auto_examples/NAME`` (built from that file) and to the gallery's index."""
    page = (DOCS / docname).parent

    def to_gallery(match):
        target = (page / match[1]).resolve()
        if target == EXAMPLES:
            built = DOCS / "auto_examples" / "index.rst"
        elif target.parent == EXAMPLES and target.suffix == ".py":
            built = DOCS / "auto_examples" / f"{target.stem}.rst"
        else:
            return match[0]
        return f"]({os.path.relpath(built, page)})"

    source[0] = re.sub(r"\]\(([^()\s#]*examples/[^()\s#]*)\)", to_gallery, source[0])


def _check_site(app, exception):
    """What issue 32 asks of the built site, checked on it (a warning: an error under -W): every page with
    mathematics loads the MathJax copied into the site and no script from the network (readable offline), and
    every tutorial page shows a figure and links its notebook."""
    if exception is not None or app.builder.name != "html":
        return
    out = Path(app.outdir)
    for page in sorted(out.rglob("*.html")):
        if "_static" in page.relative_to(out).parts or "_modules" in page.relative_to(out).parts:
            continue
        html, name = page.read_text(encoding="utf-8"), page.relative_to(out).as_posix()
        scripts = re.findall(r'<script[^>]*\ssrc="([^"]*)"', html)
        remote = [s for s in scripts if re.match(r"([a-z]+:)?//", s)]
        if remote:
            _LOG.warning("%s loads scripts from the network: %s", name, remote)
        if 'class="math' in html:
            local = [s for s in scripts if s.split("?")[0].endswith("_static/" + mathjax_path)]
            if not local or not (page.parent / local[0].split("?")[0]).is_file():
                _LOG.warning("%s has mathematics but no local MathJax (%s)", name, mathjax_path)
        if name.startswith("tutorials/") and name != "tutorials/index.html":
            if "<img" not in html or not re.search(r'href="[^"]*\.ipynb"', html):
                _LOG.warning("%s: a tutorial page without a figure or without its notebook's link", name)


def _stale_timing_pages(app, config):
    """Remove the computation-times pages an earlier build wrote into the sources (they are no longer written:
    ``write_computation_times`` below; a checkout built before that would otherwise keep their remote scripts)."""
    for stale in (Path(app.srcdir) / "sg_execution_times.rst", Path(app.srcdir) / "auto_examples" / "sg_execution_times.rst"):
        stale.unlink(missing_ok=True)


def setup(app):
    app.connect("config-inited", _stale_timing_pages)
    app.connect("autodoc-process-docstring", _escape_bars)
    app.connect("source-read", _gallery_links)
    app.connect("build-finished", _check_site)

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py$",      # every example runs during the build
    "ignore_pattern": r"__init__\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
    "show_memory": False,
    "write_computation_times": False,    # its pages load jQuery and DataTables from CDNs: the site loads nothing remote
    "plot_gallery": "True",
}

html_theme = "alabaster"
html_title = f"cvxcontact {release}"
html_static_path = []
