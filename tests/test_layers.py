"""Imports flow one way through the layers of the package (docs/architecture.md)."""

import ast
from pathlib import Path

import pytest

import cvxcontact

LAYERS = ["errors", "version", "geometry", "contact", "physics", "fem", "discrete", "backends", "solution", "solve",
          "model", "goal", "adapt", "io", "apps"]
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


TESTS = Path(__file__).resolve().parent


def imported_tests(source):
    """The test modules (``test_*``) and test functions that ``source`` imports, anywhere in the file: ``import``
    and ``from ... import``, absolute, package-qualified (``tests.test_x``) or relative, module-level or nested, and
    ``importlib.import_module("test_x")``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""] + [a.name for a in node.names]
        elif (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)
              and getattr(node.func, "attr", getattr(node.func, "id", None)) == "import_module"):
            names = [node.args[0].value]
        else:
            continue
        found += [n for n in names if any(part.startswith("test_") for part in n.split("."))]
    return found


def test_no_test_module_imports_another():
    """What tests and benchmarks share (scenes, meshes, reference solvers, constants) lives in fixtures modules
    (tests/scenes.py, tests/references.py, tests/meshes.py, ...), never in a test module: no file of tests/,
    benchmarks/ or examples/ imports a test module or a test function, so each test module runs, moves or goes alone
    and pytest collects every test once."""
    files = [p for d in ("tests", "benchmarks", "examples") for p in sorted((TESTS.parent / d).rglob("*.py"))]
    bad = {str(p.relative_to(TESTS.parent)): found for p in files if (found := imported_tests(p.read_text()))}
    assert not bad, f"{bad}: move what another module needs into a fixtures module (docs/architecture.md)"


def test_the_test_import_check_sees_every_form():
    """Module-level and nested, plain, aliased, package-qualified and relative imports of a test module, and a test
    function imported by name, are all caught; fixtures modules and names that merely contain "test" are not."""
    assert imported_tests("from test_solve import direct_mixed_solve\n") == ["test_solve"]
    assert imported_tests("def f():\n    from test_refusals import DELTA3\n") == ["test_refusals"]
    assert imported_tests("import test_friction3d as t3\n") == ["test_friction3d"]
    assert imported_tests("from tests.test_pairs import block_on\n") == ["tests.test_pairs"]
    assert imported_tests("from . import test_overlay\n") == ["test_overlay"]
    assert imported_tests("from .test_sweep import write_sweep\n") == ["test_sweep"]
    assert imported_tests("from scenes import test_like\n") == ["test_like"]
    assert imported_tests("import importlib\nm = importlib.import_module('test_tetmesh')\n") == ["test_tetmesh"]
    assert imported_tests("from references import dense_kkt\nimport pytest\nfrom testing import x\n") == []
