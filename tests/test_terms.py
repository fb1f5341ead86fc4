"""The contact term of a discrete problem (cvxcontact.discrete.terms): one object per law answers what the
backends, the read-back and the solve used to ask of the problem's flags (issue 31, "Seams").

The answers are checked against the flag expressions they replaced (written out here from the problem's own
flags, not from the term classes) on a problem of every kind, P1 and P2, 2D and 3D; and the state a solution
hands on to a warm start is computed only when it is read.
"""

import re
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import ClassVar

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.backends import Backend, describe, register, unregister
from cvxcontact.backends.full import ContactModel
from cvxcontact.backends.run import kind
from cvxcontact.backends.signorini import dependent_rows
from cvxcontact.discrete.terms import TERMS, ContactTerm, SignoriniRows, register_term, unregister_term
from cvxcontact.errors import SolverError
from cvxcontact.solution.readback import READ_BACKS

from conftest import two_blocks
from scenes3d import layer_on_plane

MAT = cc.materials.isotropic(E=1e9, nu=0.3)
FLOOR = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def _flags_kind(p) -> str:
    """The kind as backends/run.kind computed it from the flags before the term (the same precedence)."""
    if p.friction:
        return "conic_friction" if p.conic else "friction"
    if p.mixed:
        return "mixed"
    if p.conic:
        return "conic"
    return "compliance" if p.compliant else "signorini"


def _mixed_scene():
    """A compliance pair (gamma3) between two blocks beside a Signorini gamma3 block on a plane: P2 cones next to
    a compliance law (test_p2_mixed_laws' decoupled scene)."""
    top = cc.Body(cc.rectangle(x=(0, 1), y=(0.5, 1.0), nx=4, ny=2), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -2e7), name="top")
    mid = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=3, ny=2), MAT, clamped=["left"], contact="bottom", name="mid")
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=lambda s: -2e-5 + 1e-2 * (s - 0.6) ** 2, condition="gamma3",
                        law=cc.NormalCompliance(stiffness=1e11)),
             cc.Contact(low, "bottom", plane, gap=lambda s: 5e-3 * (s - 0.45) ** 2 - 2e-5, condition="gamma3")]
    return cc.Scene(top, mid, low, contacts=pairs)


def _tresca_scene():
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2)
    b = cc.Body(m, MAT, contact="bottom", traction={"top": (1e5, -1e7)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=cc.Tresca(1e7))])


def _small():
    return two_blocks(n1=(4, 2), n2=(3, 2))


CASES = {                                   # name: (scene, ContactSolver keywords, the kind expected)
    "signorini P1": (_small, dict(condition="gamma3"), "signorini"),
    "signorini P2 sigma1": (_small, dict(condition="sigma1", degree=2), "signorini"),
    "signorini 3D": (layer_on_plane, dict(condition="gamma3"), "signorini"),
    "compliance P1": (_small, dict(condition="gamma3", law=cc.NormalCompliance(stiffness=1e13)), "compliance"),
    "conic P2": (_small, dict(condition="gamma3", degree=2), "conic"),
    "mixed P2": (_mixed_scene, dict(degree=2), "mixed"),
    "friction P1": (_tresca_scene, dict(condition="gamma3"), "friction"),
    "friction P2 cones": (_tresca_scene, {"condition": "gamma3", "degree": 2}, "conic_friction"),
}


@pytest.fixture(scope="module", params=list(CASES))
def case(request):
    scene, keywords, expected = CASES[request.param]
    return cc.ContactSolver(scene(), estimate=False, **keywords).problem, expected


def test_every_kind_has_its_term_and_its_read_back(case):
    p, expected = case
    assert isinstance(p.term, ContactTerm)
    assert p.term.kind == _flags_kind(p) == expected == kind(p)
    assert p.term.dim == p.dim
    assert p.term.kind in READ_BACKS
    assert {t.kind for t in TERMS} == set(cc.backends.KINDS) == set(READ_BACKS)


def test_the_term_answers_as_the_flag_branches_it_replaces(case):
    """Each question the solve asks, against the expression of the problem's flags it replaced (run.py, solve.py,
    backends/__init__.py, backends/start.py, model/__init__.py before the term)."""
    p, _ = case
    t, k = p.term, _flags_kind(p)
    assert t.takes_active_start == (k == "signorini")                # run.py: the warm start (2D and 3D since issue 30)
    assert t.zeroes_held_forces == (k == "signorini")                              # run.py: held rows' forces
    assert t.active_from_forces == (k == "compliance")                             # run.py: determinacy check
    assert t.hands_on_state == (k == "signorini" or (k == "conic" and p.dim == 2))  # start.py (the cones: 2D)
    for polished, y in ((True, np.ones(2)), (False, np.ones(2)), (True, None)):      # start.py's _hands_on
        raw = SimpleNamespace(polished=polished, y=y)
        assert t.hands_on(raw) == (t.hands_on_state and polished and y is not None)
    assert t.finishes == (not p.mixed and (not p.friction or p.conic))            # solve.py: declined finish
    assert t.always_finished == (not (p.conic or p.mixed or p.friction))           # solve.py, Model._warn
    assert t.cones == (p.conic or p.mixed)                                         # solve.py's hint
    assert t.estimated                                                             # solve.py, Model.solve
    assert t.takes_user_terms                 # cc.Model: every term (friction: its beside_user_terms)
    d = describe(p)                                                                # backends/__init__.describe
    assert (d.compliant, d.conic, d.friction) == (p.compliant, p.conic or p.mixed, p.friction)
    assert d.dependent_rows == (bool(dependent_rows(p)) and not p.conic)


def test_the_term_follows_the_rows_it_is_posed_on():
    """A re-solve keeps the term; the conic condition posed at sampled nodal rows (with_rows) is Signorini rows."""
    p = cc.ContactSolver(_small(), condition="gamma3", degree=2, estimate=False).problem
    assert p.term.kind == "conic"
    assert p.with_loads(two_blocks(n1=(4, 2), n2=(3, 2), scale=0.5)).term == p.term
    sampled = p.with_rows(p.lines.cone[0][::3])                  # each element's first endpoint
    assert sampled.term == SignoriniRows(2) and not sampled.conic and sampled.term.zeroes_held_forces


def test_the_state_is_computed_when_first_read(monkeypatch):
    """A solve no longer computes its ContactState; reading ``sol.state`` does, once, and it is the solution's
    own nodal forces at the merged nodes' positions (the read-back's arrays, another path from the raw forces)."""
    import cvxcontact.backends.start as start

    calls = []
    real = start.point_loads
    monkeypatch.setattr(start, "point_loads", lambda *a: calls.append(1) or real(*a))
    sol = cc.solve(_small(), "gamma3", estimate=False)
    assert sol.ok and sol.polished and calls == []
    state = sol.state
    assert len(calls) == 1
    assert sol.state is state and len(calls) == 1                                  # once
    x = np.concatenate([c.x for c in sol.contacts])
    force = np.concatenate([c.force for c in sol.contacts])
    assert np.array_equal(state.s, x) and np.array_equal(state.pair, np.zeros(len(x), dtype=int))
    assert np.allclose(state.force, np.maximum(force, 0.0), rtol=1e-12, atol=0.0)   # E^T y in N/m both ways
    assert state.force.max() > 0


def test_no_state_where_none_applies(monkeypatch):
    """A compliance law hands on no state (nothing is deferred, nothing computed); a set state stands."""
    import cvxcontact.backends.start as start

    calls = []
    monkeypatch.setattr(start, "point_loads", lambda *a: calls.append(1))
    sol = cc.solve(_small(), "gamma3", law=cc.NormalCompliance(stiffness=1e13), estimate=False)
    assert sol.state is None and calls == []
    sol.state = "given"
    assert sol.state == "given"


# ---- a term from outside the package (issue 31 item 1: a new law adds one term class and its functions) --------



PROGRAMS = []


def _toy_program(problem):
    """Signorini's rows E [u_nu] <= E g in the full program, written here from the public ContactModel (the
    term's own program, not SignoriniRows' name); counts its calls."""
    PROGRAMS.append(problem)
    return ContactModel(list(problem.blocks), problem.E, problem.g, translations=list(problem.translations))


@dataclass(frozen=True)
class ToyRows(SignoriniRows):
    """A toy law posed like Signorini's rows under another kind: its own program function, SignoriniRows' forces
    and read-back; its problems solved by a backend registered with a route for its kind."""

    kind: ClassVar[str] = "toy"
    programs: ClassVar = _toy_program                 # a plain function (not bound to the term)

    @staticmethod
    def poses(lines) -> bool:
        return not (lines.conic or lines.mixed or lines.rows.compliant or lines.rows.friction)


@pytest.fixture
def toy():
    """ToyRows and a backend "toy" whose route for it is the package's Signorini full route, registered for one
    test and removed after it."""
    register_term(ToyRows)
    register(Backend("toy", lambda p: True, "a toy law's backend",
                     routes={"toy": "cvxcontact.backends.signorini:full"}))
    PROGRAMS.clear()
    try:
        yield
    finally:
        unregister("toy")
        unregister_term(ToyRows)


def test_a_term_from_outside_solves(toy):
    """The toy term is the problem's, its program is the one the full route solves, and the answer is the Signorini
    answer of the package's own term (computed after the toy is removed), exactly: the same rows, program and
    finish; its checks of (26)-(27) pass."""
    scene = _small()
    solver = cc.ContactSolver(scene, estimate=False)                 # method="auto"
    assert type(solver.problem.term) is ToyRows and solver.method == "toy"       # the only backend with its route
    assert "toy" in cc.backends.KINDS and "toy" in READ_BACKS
    sol = solver.solve()
    assert len(PROGRAMS) == 1 and PROGRAMS[0] is solver.problem                  # its own program, called once
    assert sol.ok and sol.polished
    with pytest.raises(SolverError, match="does not accept"):                    # no route for the toy kind
        cc.ContactSolver(scene, method="condensed", estimate=False)
    model = cc.Model(scene)                                                      # Model asks the term too
    assert len(PROGRAMS) == 2
    model.add(model.jump() <= 1.0)                                               # a user row that never binds
    with_row = model.solve()
    assert with_row.ok and with_row.polished
    unregister("toy")
    unregister_term(ToyRows)
    try:
        plain = cc.solve(scene, method="full", estimate=False)           # SignoriniRows, the same route
        assert type(cc.ContactSolver(scene, estimate=False).problem.term) is SignoriniRows
        for mine, theirs in zip(sol.u, plain.u):
            assert np.array_equal(mine, theirs)                              # measured: identical to the bit
        for mine, theirs in zip(sol.contacts, plain.contacts):
            assert np.array_equal(mine.force, theirs.force)
        for mine, theirs in zip(with_row.u, plain.u):                    # Model's own finish with the user row
            assert np.allclose(mine, theirs, rtol=0.0, atol=1e-10 * np.abs(theirs).max())   # measured 3e-16
    finally:
        register_term(ToyRows)                                               # for the fixture's removal
        register(Backend("toy", lambda p: True, routes={"toy": "cvxcontact.backends.signorini:full"}))


def test_a_term_from_outside_is_checked():
    """register_term refuses what is not a term (typed errors naming what is missing), a second registration, and
    unregister_term the package's own terms."""
    with pytest.raises(SolverError, match="class"):
        register_term(ToyRows(2))
    with pytest.raises(SolverError, match="kind must be an identifier"):
        register_term(type("NoKind", (), {"poses": staticmethod(lambda lines: True)}))
    with pytest.raises(SolverError, match="missing"):
        register_term(type("Bare", (), {"kind": "bare", "poses": staticmethod(lambda lines: True),
                                        "__init__": lambda self, dim: None}))
    with pytest.raises(SolverError, match="not a registered term from outside"):
        unregister_term(SignoriniRows)
    register_term(ToyRows)
    try:
        with pytest.raises(SolverError, match="already registered"):
            register_term(ToyRows)
    finally:
        unregister_term(ToyRows)
    assert ToyRows not in TERMS and "toy" not in cc.backends.KINDS


# ---- the seam stays closed: the term is asked for flags only where docs/architecture.md counts them -------------


FLAG_ASKS = re.compile(r"term\.(kind|compliant|cones|tangential|finishes|always_finished|estimated|takes_user_terms|"
                       r"zeroes_held_forces|active_from_forces|rows_may_depend|hands_on_state|takes_active_start)\b")
KIND_TABLES = re.compile(r"\[ *(problem\.)?term\.kind *\]|READ_BACKS\[")
"""A table looked up by the term's kind (the read-back's before the methods)."""


def _asks(pattern, files):
    return [f"{path}:{i}" for path, text in files.items() if path.split("/")[0] != "discrete"
            for i, line in enumerate(text.splitlines(), 1) if pattern.search(line)]


def test_the_term_is_asked_for_flags_only_where_counted():
    """Outside discrete/, the term's flags and kind are read on 8 lines, issue 31's limit (docs/architecture.md, "A
    new contact law": 21 before its methods, 17 before run.py's decisions and the refusals' words moved into the
    term, 9 before start.py's decision did) and no table is looked up by its kind; a planted lookup is found."""
    root = Path(cc.__file__).parent
    files = {p.relative_to(root).as_posix(): p.read_text() for p in sorted(root.rglob("*.py"))}
    asks = _asks(FLAG_ASKS, files)
    assert len(asks) <= 8, asks
    assert _asks(KIND_TABLES, files) == []
    planted = {"solution/x.py": "sol = READ_BACKS[problem.term.kind](problem)\n", "discrete/y.py": "term.kind\n"}
    assert _asks(KIND_TABLES, planted) == ["solution/x.py:1"] and _asks(FLAG_ASKS, planted) == ["solution/x.py:1"]


def test_a_term_s_old_flags_without_their_reasons_are_refused_at_registration():
    """``estimated`` and ``takes_user_terms`` follow from the reasons ``unestimated`` and ``refuses_user_terms``
    (the solve and cc.Model read the reasons): a term from outside that sets a flag False as the protocol had it
    (a boolean), without the reason, would get an estimate that does not count its forces, or user rows beside
    it, silently. register_term refuses it, naming the reason to give; with the reason it is accepted."""
    @dataclass(frozen=True)
    class Unestimated(ToyRows):
        kind: ClassVar[str] = "unestimated_toy"
        estimated: ClassVar[bool] = False

    @dataclass(frozen=True)
    class NoUserRows(ToyRows):
        kind: ClassVar[str] = "no_user_rows_toy"
        takes_user_terms: ClassVar[bool] = False

    for term, reason in ((Unestimated, "unestimated"), (NoUserRows, "refuses_user_terms")):
        with pytest.raises(SolverError, match=reason):
            register_term(term)
        assert term not in TERMS

    @dataclass(frozen=True)
    class Said(ToyRows):
        kind: ClassVar[str] = "said_toy"
        unestimated: ClassVar[str] = "the estimates do not count this toy's forces"

    register_term(Said)
    try:
        assert not Said(2).estimated
    finally:
        unregister_term(Said)


def test_the_flags_say_what_held_forces_and_determining_rows_do():
    """``zeroes_held_forces`` and ``active_from_forces`` are what the two methods read: a subclass that turns one
    off is not overridden by a method of its parent (a flag set beside a method that ignored it was silent)."""
    import dataclasses

    from cvxcontact.discrete.terms import ComplianceRows, SignoriniRows

    problem = SimpleNamespace(held_rows=np.array([True, False, False]))
    y = np.array([2.0, 3.0, 0.0])
    assert np.array_equal(SignoriniRows(2).held_forces(problem, y), [0.0, 3.0, 0.0])
    keeps = dataclasses.make_dataclass("Keeps", [], bases=(SignoriniRows,), frozen=True)
    keeps.zeroes_held_forces = False
    assert np.array_equal(keeps(2).held_forces(problem, y), y)
    raw = SimpleNamespace(active=None, y=y)
    assert np.array_equal(ComplianceRows(2).determining_rows(problem, raw), [True, True, False])
    plain = dataclasses.make_dataclass("Plain", [], bases=(ComplianceRows,), frozen=True)
    plain.active_from_forces = False
    assert plain(2).determining_rows(problem, raw) is None


@pytest.mark.numerics
@pytest.mark.parametrize("module, degree, model_warns", [("signorini", 1, True), ("cones", 2, False)])
def test_model_warns_where_a_finish_that_always_runs_did_not(monkeypatch, module, degree, model_warns):
    """cc.Model's plain solve warns of a declined finish where the term's finish always runs (``always_finished``),
    not where ``term.finish_declined`` holds: on the P2 cones, whose cuts finish only what they can condense, a
    declined finish is reported by cc.solve and not by cc.Model (as before the term); on Signorini rows by both.
    The route's answer is relabelled declined (its fields are the finished ones, so the checks pass)."""
    import importlib
    import warnings

    from cvxcontact.backends.finish.declined import Declined, Stop
    from cvxcontact.errors import ResidualWarning

    routes = importlib.import_module(f"cvxcontact.backends.{module}")
    real = routes.full

    def declined(problem, cache, settings, timings):
        raw = real(problem, cache, settings, timings)
        assert raw.polished                                  # the scene's finish runs: relabel it
        raw.polished, raw.declined = False, Declined(Stop.MAX_ITER, "declined by a test")
        return raw

    monkeypatch.setattr(routes, "full", declined)
    scene = _small()
    with pytest.warns(ResidualWarning, match="declined by a test"):
        cc.solve(scene, "gamma3", degree=degree, method="full", estimate=False)
    model = cc.Model(scene, "gamma3", degree=degree)
    assert model.problem.term.finish_declined(model.problem, SimpleNamespace(polished=False, declined="yes"), True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = model.solve()
    warned = [w for w in caught if issubclass(w.category, ResidualWarning)]
    assert not sol.polished and sol.info.declined.stop is Stop.MAX_ITER
    assert len(warned) == int(model_warns), [str(w.message) for w in warned]
    assert all("declined by a test" in str(w.message) for w in warned)


# ---- combinations of laws: declared by the terms (``parts``), computed from the lines --------------------------


def _lines(cones=False, compliance=False, friction=False):
    """Contact lines as the parts read them (PARTS' tests: ``conic``/``mixed``, the rows' laws)."""
    rows = SimpleNamespace(compliant=compliance, friction=friction)
    return SimpleNamespace(conic=cones and not compliance, mixed=cones and compliance, rows=rows)


def test_each_combination_of_laws_is_posed_by_the_one_term_that_declares_it_or_refused_by_name():
    """The package's terms declare distinct combinations (their ``parts``); each of the 2^3 combinations of
    PARTS is posed by the term declaring it, whatever the order tried, and the one no term declares (the cones,
    a compliance law and friction together) is an UnsupportedError with its declared words (UNPOSED: what to do),
    met before anything else is built (cc.Model of such a scene); one without words names the combination and the
    declared ones (the registry without the cones' terms, for the call)."""
    import itertools

    from friction_scenes import P, compliant_series

    from cvxcontact.discrete import terms
    from cvxcontact.discrete.terms import PARTS, contact_term, parts_of
    from cvxcontact.errors import UnsupportedError

    own = [t for t in TERMS if t.__module__ == "cvxcontact.discrete.terms"]
    assert len({t.parts for t in own}) == len(own) and all(t.parts <= set(PARTS) for t in own)
    for on in itertools.product((False, True), repeat=3):
        lines = _lines(*on)
        parts = parts_of(lines)
        assert parts == {name for name, o in zip(("cones", "compliance", "friction"), on) if o}
        posing = [t for t in own if t.poses(lines)]
        if parts == {"cones", "compliance", "friction"}:
            assert posing == []
            with pytest.raises(UnsupportedError, match="not available beside a normal-compliance law"):
                contact_term(lines, 2)                          # its words declared (UNPOSED)
        else:
            assert len(posing) == 1 and posing[0].parts == parts
            assert type(contact_term(lines, 2)) is posing[0]
    with pytest.raises(UnsupportedError, match=r"poses cones \+ friction together \(the terms and the laws they "
                                               r"declare: .*friction \(friction\), .*signorini \(Signorini rows\)"):
        _refused_without(terms, "cones")
    scene = compliant_series(0.1 * P, 1e12, g=0.5 * P)   # friction under the P2 cones beside a compliant floor
    with pytest.raises(UnsupportedError, match="is not available beside a normal-compliance law: pose every pair"):
        cc.Model(scene, "gamma3", degree=2)


def _refused_without(terms, part):
    """contact_term of lines with the cones and friction, the terms declaring ``part`` set aside for the call."""
    kept = [t for t in terms._REGISTRY if part not in getattr(t, "parts", ())]
    saved = list(terms._REGISTRY)
    terms._REGISTRY[:] = kept
    try:
        return terms.contact_term(_lines(True, False, True), 2)
    finally:
        terms._REGISTRY[:] = saved


def test_friction_rows_that_do_not_match_the_cones_are_a_solver_error_not_the_compliance_refusal(monkeypatch):
    """discrete/slip.Slip.kernel_capacity's check that the friction rows, their weights and the cones' rows under the
    P2 "gamma3" cones are the same rows: no compliance law is on such lines (cones beside one are ``lines.mixed``,
    refused by the terms), so a mismatch is the space's fault, a SolverError counting them, not the compliance
    refusal's words (UNPOSED) it raised. The mismatch made by a test (one weight dropped)."""
    from friction_scenes import P, uniform_stack

    import cvxcontact.discrete.slip as slip_module
    from cvxcontact.errors import SolverError

    weights = slip_module.friction_weights
    monkeypatch.setattr(slip_module, "friction_weights", lambda *a: weights(*a)[:-1])
    with pytest.raises(SolverError, match=r"friction rows, \d+ weights and \d+ rows of the cones") as info:
        cc.Model(uniform_stack(0.1 * P, cc.Tresca(0.5 * P), nx=(4, 3, 3)), "gamma3", degree=2)
    assert "compliance" not in str(info.value) and not isinstance(info.value, cc.UnsupportedError)
