"""The warnings of a solve name the caller's line (file and line number), whichever entry point it called:
cvxcontact.solve, ContactSolver.solve, ContactSolver.solve_many (its first load case alone, then batched),
Model.solve (without user terms, with a user row, with a user row beside a friction term) and cc.adapt (its own
warnings and those of its solves): each reaches the warning through a different depth of the package's calls
(cvxcontact.errors.user_stacklevel). Before, FixedPointWarning and NonUniqueWarning named a line of
cvxcontact/solve.py or cvxcontact/model/__init__.py from every entry point."""

import ast
import re
import sys
import warnings
from pathlib import Path

import pytest
from conftest import two_blocks
from friction_scenes import P, sheared
from obstacle_scenes import half_model

import cvxcontact as cc
from cvxcontact.backends import condensed
from cvxcontact.errors import SolverError, reissue


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


# ------------------------------------------------------------------ every warning class from every entry point

def _with_row(model):
    """``model`` with a user row that never binds (its solve takes the user terms' route)."""
    model.add(model.u(0)[:, 1] >= -1.0)
    return model


# name -> a call of one entry point on a scene builder and keywords, written on ONE line: the warnings must name it
ENTRIES = {
    "cc.solve": lambda scene, kw: cc.solve(scene(), **kw),
    "ContactSolver.solve": lambda scene, kw: cc.ContactSolver(scene(), **kw).solve(),
    "ContactSolver.solve_many": lambda scene, kw: cc.ContactSolver(scene(), **kw).solve_many([scene(), scene()]),
    "Model.solve": lambda scene, kw: cc.Model(scene(), **kw).solve(),
    "Model.solve, a user row": lambda scene, kw: _with_row(cc.Model(scene(), **kw)).solve(),
    "cc.adapt": lambda scene, kw: cc.adapt(scene(), max_steps=0, **kw),
}
SOLVERS = ["cc.solve", "ContactSolver.solve", "ContactSolver.solve_many"]


def _unsettled():
    """Coulomb's fixed point stopped after one iterate, unfinished: a FixedPointWarning and a ResidualWarning
    (measured; tests/test_coulomb.py on the same block at 8 x 4)."""
    return sheared(0.35 * P, cc.Coulomb(0.4, max_iterations=1), nx=4, ny=2)


def _one_node():
    """A force-controlled circle touching one node of the block under it: its sideways translation is not
    determined, a NonUniqueWarning (tests/test_wellposed.py)."""
    return half_model(force=(0.0, -1e7), center_x=0.5, roller=())


# name -> (scene builder, keywords, the warning classes raised, the entry points that raise them)
CASES = {
    "unsettled fixed point": (_unsettled, {"polish": False}, (cc.FixedPointWarning, cc.ResidualWarning),
                              list(ENTRIES)),
    "unsettled fixed point, P2 cones": (_unsettled, {"polish": False, "degree": 2}, (cc.FixedPointWarning,),
                                        ["cc.solve", "Model.solve", "Model.solve, a user row"]),
    "obstacle on one node": (_one_node, {"condition": "sigma1"}, (cc.NonUniqueWarning,),
                             [*SOLVERS, "Model.solve", "cc.adapt"]),
    "checks failed": (_coarse, {"tol": 1e-17}, (cc.ResidualWarning,), [*SOLVERS, "Model.solve",
                                                                        "Model.solve, a user row"]),
    "coarse contact zone": (_coarse, {}, (cc.ResolutionWarning,), [*SOLVERS, "cc.adapt"]),
    "adapt above its tol": (_coarse, {"tol": 1e-9}, (cc.ResolutionWarning,), ["cc.adapt"]),
}


@pytest.mark.parametrize("case,entry", [(c, e) for c, (*_, entries) in CASES.items() for e in entries])
def test_every_warning_names_the_calling_line_from_every_entry_point(case, entry):
    scene, kw, categories, _ = CASES[case]
    call = ENTRIES[entry]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call(scene, kw)
    line = call.__code__.co_firstlineno                     # the one line of the entry point's call
    for category in categories:
        assert _where(caught, category) == {(__file__, line)}, category.__name__


@pytest.mark.parametrize("entry", [*SOLVERS, "cc.adapt"])
def test_the_pardiso_fallback_names_the_calling_line(entry, monkeypatch):
    """PARDISO refusing a body's matrix (made to refuse here: it accepts these; chosen by "auto" here, as where
    pypardiso is installed) falls back to SuperLU with a warning naming the caller's line."""
    real = condensed.factorize

    def refusing(S, gamma, kind, *args, **kw):
        if kind == "pardiso":
            raise SolverError("refused (a test)")
        return real(S, gamma, kind, *args, **kw)

    monkeypatch.setattr(condensed, "factorize", refusing)
    monkeypatch.setattr(condensed, "resolve", lambda factorization: "pardiso")
    call = ENTRIES[entry]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call(_coarse, {"method": "condensed", "factorization": "auto"})
    fallback = {(w.filename, w.lineno) for w in caught if "PARDISO refused" in str(w.message)}
    assert fallback == {(__file__, call.__code__.co_firstlineno)}


def _fixed_levels(source):
    """Line numbers of the ``warnings.warn`` calls in ``source`` whose ``stacklevel`` is not ``user_stacklevel()``
    (a fixed level, or none: the package's own line), of the ``warnings.warn_explicit`` calls outside
    ``errors.reissue`` (a place and module of their own), and of the imports that would hide a call from this check
    (``from warnings import warn``, ``import warnings as w``)."""
    tree = ast.parse(source)
    skip = {id(n) for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) and f.name == "reissue"
            for n in ast.walk(f)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "warnings" \
                or isinstance(node, ast.Import) and any(a.name == "warnings" and a.asname for a in node.names):
            out.append(node.lineno)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and id(node) not in skip \
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "warnings":
            level = next((k.value for k in node.keywords if k.arg == "stacklevel"), None)
            if node.func.attr == "warn_explicit" or node.func.attr == "warn" and not (
                    isinstance(level, ast.Call) and getattr(level.func, "id", None) == "user_stacklevel"):
                out.append(node.lineno)
    return sorted(out)


def test_every_warning_of_the_package_takes_the_user_stacklevel():
    """No ``warnings.warn`` in the package names a fixed frame: a fixed level names the user's line from one entry
    point and a line of the package from another (the cases above)."""
    root = Path(cc.__file__).parent
    fixed = {str(p.relative_to(root)): lines for p in sorted(root.rglob("*.py"))
             if (lines := _fixed_levels(p.read_text()))}
    assert fixed == {}


def test_the_stacklevel_check_sees_a_fixed_level():
    assert _fixed_levels("import warnings\nwarnings.warn('x', UserWarning, stacklevel=2)\nwarnings.warn('y')\n"
                         "warnings.warn('z', stacklevel=user_stacklevel())\n"
                         "warnings.warn_explicit('w', UserWarning, 'f.py', 1)\n"
                         "def reissue(c):\n    warnings.warn_explicit('v', UserWarning, 'f.py', 1)\n"
                         "from warnings import warn\nimport warnings as w\n") == [2, 3, 5, 8, 9]


@pytest.mark.parametrize("entry", [*SOLVERS, "cc.adapt"])
def test_a_filter_by_the_callers_module_applies_from_every_entry_point(entry):
    """A caller's ``filterwarnings(module=...)`` matches the module of the line the warning names, from every entry
    point; cc.adapt re-issues its solves' warnings (recorded) and once gave them the module "/path/to/file" (the
    file's name: ``warn_explicit`` without ``module``), which no filter by the caller's module matched."""
    call, module = ENTRIES[entry], re.escape(__name__) + "$"
    for action, other, shown in (("ignore", module, 0), ("ignore", "elsewhere$", 1), ("error", module, "raised")):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            warnings.filterwarnings(action, category=cc.ResolutionWarning, module=other)
            if shown == "raised":
                with pytest.raises(cc.ResolutionWarning):
                    call(_coarse, {})
                continue
            call(_coarse, {})
        assert len(_where(caught, cc.ResolutionWarning)) == shown, (action, other)


def test_adapt_s_warnings_are_shown_once_per_place_under_the_default_action():
    """Under the "default" action a warning is shown once per text, category and line, as Python does for one
    issued there: cc.adapt re-issues each step's warnings after the step's ``catch_warnings``, which changes the
    filters' version and so emptied the registries, and every step and every call showed the same warning again
    (here, two calls of 3 steps: 6 NonUniqueWarnings and 2 ResolutionWarnings, as under "always"; now 1 and 1). The
    actions "module" and "once" de-duplicate likewise; a caller's new ``catch_warnings`` starts afresh, as Python's
    registries do."""
    def calls():
        for _ in range(2):
            cc.adapt(_one_node(), "sigma1", max_steps=2)

    def counts(caught):
        return [sum(issubclass(w.category, c) for w in caught) for c in (cc.NonUniqueWarning, cc.ResolutionWarning)]

    for action, expected in (("always", [6, 2]), ("default", [1, 1]), ("module", [1, 1]), ("once", [1, 1])):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter(action)
            calls()
        assert counts(caught) == expected, action
        assert {w.filename for w in caught} == {__file__}
    with warnings.catch_warnings(record=True) as caught:           # a new context: shown again, once
        warnings.simplefilter("default")
        calls()
    assert counts(caught) == [1, 1]


def test_reissue_names_the_module_of_a_line_off_the_stack(tmp_path, monkeypatch):
    """A recorded warning whose line is no longer running (a library's) is issued again under that file's
    imported module; a file no module holds keeps warn_explicit's own module, the file's path without ".py"."""
    (tmp_path / "rtidy3_library.py").write_text("import warnings\n\ndef f():\n    warnings.warn('from a library')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    library = __import__("rtidy3_library")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        library.f()
    (w,) = caught
    assert (w.filename, w.lineno) == (library.__file__, 4)
    for module, raised in (("rtidy3_library$", True), (re.escape(__name__) + "$", False)):
        with warnings.catch_warnings(record=True) as again:
            warnings.simplefilter("always")
            warnings.filterwarnings("error", module=module)
            if raised:
                with pytest.raises(UserWarning, match="from a library"):
                    reissue(caught)
            else:
                reissue(caught)
                assert [(x.filename, x.lineno) for x in again] == [(library.__file__, 4)]
    w.filename = str(tmp_path / "nowhere.py")
    with warnings.catch_warnings():
        warnings.filterwarnings("error", module=re.escape(str(tmp_path / "nowhere")) + "$")
        with pytest.raises(UserWarning, match="from a library"):
            reissue(caught)


def test_reissue_takes_a_plain_string_filter_as_python_does():
    """Python's built-in default filters hold a plain string, the module "__main__" of ``('default', None,
    DeprecationWarning, '__main__', 0)``, which Python matches by equality: the de-duplication's filter matching
    called ``.match`` on it and raised AttributeError for every recorded DeprecationWarning (a library's, inside a
    step of cc.adapt) in a plain script. Shown once per place as Python shows the same warning issued there."""
    def record():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            warnings.warn("an old call", DeprecationWarning)
        return caught

    for module, shown in ((__name__, 1), ("__main__", 0)):
        with warnings.catch_warnings(record=True) as seen:
            warnings.resetwarnings()
            warnings.filters[:] = [("default", None, DeprecationWarning, module, 0),
                                   ("ignore", None, DeprecationWarning, None, 0)]
            warnings._filters_mutated()
            for _ in range(3):
                reissue(record())
        assert [str(w.message) for w in seen] == ["an old call"] * shown, module


def test_reissue_shows_once_per_module_under_once_as_python_does(tmp_path, monkeypatch):
    """Under "once" CPython (its ``_warnings``, given a module's registry, as ``warnings.warn`` and ``reissue``
    give) shows a warning once per text and category in each module, not once in the process: the same words
    from two modules, issued twice each, are shown twice. The de-duplication kept one process-wide record for
    "once" and showed them once."""
    for name in ("rsmall_a", "rsmall_b"):
        (tmp_path / f"{name}.py").write_text("import warnings\n\ndef f():\n    warnings.warn('the same words')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    libraries = [__import__(n) for n in ("rsmall_a", "rsmall_b")] * 2

    def record(f):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            f()
        return caught

    counts = []
    for again in (False, True):
        with warnings.catch_warnings(record=True) as shown:
            warnings.simplefilter("once")
            for library in libraries:
                if again:
                    reissue(record(library.f))
                else:
                    library.f()
        counts.append(len(shown))
    assert counts == [2, 2]                 # Python's own, then reissue's
