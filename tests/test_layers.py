"""Imports flow one way through the layers of the package (docs/architecture.md)."""

import ast
from pathlib import Path

import pytest

import cvxcontact

LAYERS = ["errors", "version", "geometry", "contact", "physics", "fem", "discrete", "backends", "solution", "solve", "model", "goal", "adapt", "io",
          "apps"]
ROOT = Path(cvxcontact.__file__).parent
MODULES = sorted(p for p in ROOT.rglob("*.py") if p not in (ROOT / "__init__.py", ROOT / "__main__.py"))


def imported(source, own):
    """Package-relative dotted names (as lists) of the cvxcontact modules that ``source`` imports,
    anywhere in the file; ``own`` is the importing module's package-relative path parts."""
    package = list(own[:-1])
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                mod = package[: len(package) - node.level + 1] + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "cvxcontact":
                mod = node.module.split(".")[1:]
            else:
                continue
            yield from ([mod] if node.module else [mod + [a.name] for a in node.names])
        elif isinstance(node, ast.Import):
            yield from (a.name.split(".")[1:] for a in node.names if a.name.startswith("cvxcontact."))


def upward(source, own):
    """The imports of ``source`` that go against the layer order."""
    return [t for t in imported(source, own) if t[0] not in LAYERS or LAYERS.index(t[0]) > LAYERS.index(own[0])]


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_go_one_way(path):
    own = path.relative_to(ROOT).with_suffix("").parts
    assert own[0] in LAYERS, f"{path}: not in a layer; add it to one of {LAYERS}"
    bad = upward(path.read_text(), own)
    assert not bad, f"{'.'.join(own)} imports {['.'.join(t) for t in bad]}: imports must flow {' -> '.join(LAYERS)}"


def test_the_check_sees_upward_imports():
    """Relative and absolute, module-level and nested imports against the order are all caught."""
    own = ("geometry", "mesh")
    assert upward("from ..errors import MeshError\nfrom . import other\n", own) == []
    assert upward("from ..solve import solve\n", own) == [["solve"]]
    assert upward("def f():\n    from cvxcontact.apps.cli import main\n", own) == [["apps", "cli"]]
    assert upward("from .. import physics\n", own) == [["physics"]]


def prints(source):
    """Line numbers of the calls of the built-in print in ``source``."""
    return [node.lineno for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print"]


@pytest.mark.parametrize("path", [p for p in MODULES if p.relative_to(ROOT).parts[0] != "apps"],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_the_library_does_not_print(path):
    """Below the command line and the studies (apps/), the package speaks through return values, warnings,
    errors, ``progress=`` callbacks and logging, never print (a debug print of the tangency Newton's rounds once
    reached main)."""
    assert prints(path.read_text()) == []


def test_the_print_check_sees_a_print():
    assert prints("def f(x):\n    print('DBG', x)\n    return x\n") == [2]
    assert prints("def f(out):\n    out.print(1)\n") == []
