"""The Python snippets of the README and of the documentation pages run as written.

Each page's ```python blocks run in order in one namespace, which starts from the README's quickstart
(``cc``, ``scene``, ``sol``, ...): the pages continue from it where they say so. Blocks in other
languages (bash, toml, text) are not run, nor sketches written as ```{code-block} python (templates
with placeholder names). The gallery scripts run in tests/test_examples.py."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = sorted(p for p in (ROOT / "docs").rglob("*.md")
               if not {"_build", "auto_examples", "studies"} & set(p.relative_to(ROOT / "docs").parts))


def blocks(path):
    return re.findall(r"^```python\n(.*?)^```", path.read_text(encoding="utf-8"), re.S | re.M)


def run(path, ns):
    for i, code in enumerate(blocks(path)):
        exec(compile(code, f"{path.relative_to(ROOT)} [python block {i + 1}]", "exec"), ns)  # our own docs
    return ns


@pytest.fixture(scope="module")
def quickstart():
    return run(README, {})


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p)], ids=lambda p: str(p.relative_to(ROOT / "docs")))
def test_page_snippets_run(page, quickstart):
    run(page, dict(quickstart))
