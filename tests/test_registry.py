"""The public backend registry (issue 31): register() validates an entry and plugs it in everywhere a method
name is read; the fallback policy is the entry's; a backend's own route and finish labels reach SolveInfo."""

import warnings
from dataclasses import replace

import numpy as np
import pytest

import cvxcontact as cc
from conftest import rel, two_blocks
from cvxcontact import backends
from cvxcontact.backends import BACKENDS, METHODS, Backend, Fallback, register, unregister
from cvxcontact.backends.options import check_solve_parameters
from cvxcontact.backends.signorini import full as full_route
from cvxcontact.solution.info import SolveInfo


@pytest.fixture
def registry():
    """Registers through the public call and leaves the registry as it found it."""
    before = [b.name for b in BACKENDS]
    yield register
    for name in [b.name for b in BACKENDS if b.name not in before]:
        unregister(name)
    assert [b.name for b in BACKENDS] == before


def _signorini_only(p):
    return not (p.compliant or p.conic)


@pytest.mark.parametrize("entry, what", [
    ("full", "register takes a cvxcontact.backends.Backend"),
    (Backend("my backend", _signorini_only, routes={"signorini": full_route}), "must be an identifier"),
    (Backend("auto", _signorini_only, routes={"signorini": full_route}), "already registered or reserved"),
    (Backend("full", _signorini_only, routes={"signorini": full_route}), "already registered or reserved"),
    (Backend("condensed", _signorini_only, routes={"signorini": full_route}), "or pass replace=True"),
    (Backend("mine", True, routes={"signorini": full_route}), "accepts must be a function"),
    (Backend("mine", _signorini_only, prefers="large", routes={"signorini": full_route}), "prefers must be a function"),
    (Backend("mine", _signorini_only), "routes must map at least one kind"),
    (Backend("mine", _signorini_only, routes={"frictional": full_route}), "unknown kind 'frictional'"),
    (Backend("mine", _signorini_only, routes={"signorini": "signorini.full"}), "a function or 'module:function'"),
    (Backend("mine", _signorini_only, routes={"signorini": full_route}, fallback=Fallback("quick", "x")),
     "fallback must be a Fallback"),
])
def test_register_names_what_is_wrong(registry, entry, what):
    with pytest.raises(cc.SolverError, match=what):
        registry(entry)
    with pytest.raises(cc.SolverError, match="must name another registered backend"):
        registry(Backend("mine", _signorini_only, routes={"signorini": full_route}), before="fastest")
    assert "mine" not in METHODS


def test_unregister_keeps_the_reference_and_the_fallbacks():
    with pytest.raises(cc.SolverError, match="reference"):
        unregister("full")
    with pytest.raises(cc.SolverError, match=r"\['condensed'\] fall back to it"):
        unregister("sparse")
    with pytest.raises(cc.SolverError, match="method must be one of"):
        unregister("nothing")


def test_a_registered_name_is_a_method_everywhere_and_auto_walks_it_where_placed(registry):
    """METHODS is a live view: the parameter checks, the scene files' and sweeps' validation read the registry."""
    registry(Backend("mine", _signorini_only, routes={"signorini": "cvxcontact.backends.signorini:full"}))
    assert METHODS[-1] == "mine" and BACKENDS[-1].name == "mine" and "mine" in METHODS
    assert check_solve_parameters("gamma3", "mine", 1e-6) == 1e-6
    assert backends.choose("auto") == "condensed"                       # last: after "full", never auto
    registry(Backend("mine", _signorini_only, routes={"signorini": full_route}), before="condensed", replace=True)
    assert [b.name for b in BACKENDS] == ["amg", "sparse", "mine", "condensed", "newton", "full"]
    assert backends.choose("auto") == "mine"
    assert backends.choose("auto", backends.ProblemDescription(compliant=True)) == "condensed"
    unregister("mine")
    with pytest.raises(cc.SolverError, match="method must be one of"):
        check_solve_parameters("gamma3", "mine", 1e-6)


def test_a_named_refusal_is_typed_and_a_backend_that_solves_the_problem_lifts_it(registry, monkeypatch):
    """A problem no backend solves (a compliance law beside a non-quadratic energy on a body held by the contact
    only: the Newton route needs bodies held by their supports, the full route finishes the law on Kuu) named by
    a :data:`~cvxcontact.backends.REFUSALS` entry: ``choose`` raises it (UnsupportedError, not the generic
    SolverError) for ``auto`` and for a named backend; a backend registered with a route for it is then chosen,
    and a problem no refusal names keeps the generic SolverError. The P2 cones beside a non-quadratic energy,
    once refused in 3D (docs/refusals.md row 35), are the full route's in 2D and 3D."""
    cones = backends.ProblemDescription(quadratic_energy=False, conic=True, dim=3, degree=2, kind="conic")
    for dim in (2, 3):
        assert backends.choose("auto", replace(cones, dim=dim)) == "full" == backends.choose("full", cones)
    law = backends.ProblemDescription(quadratic_energy=False, compliant=True, held_by_contact=True,
                                      linear_contact=False, kind="compliance")
    monkeypatch.setattr(backends, "REFUSALS", (backends.Refusal(lambda p: p.compliant and not p.quadratic_energy,
                                                                "a law beside a Hencky body: use 'sigma1'"),))
    for method in ("auto", "full", "newton"):
        with pytest.raises(cc.UnsupportedError, match="a law beside a Hencky body: use 'sigma1'"):
            backends.choose(method, law)
    registry(Backend("mine", lambda p: p.compliant, routes={"compliance": full_route}), before="full")
    assert backends.choose("auto", law) == "mine"
    with pytest.raises(cc.SolverError, match="method 'full' does not accept") as info:
        backends.choose("full", law)                   # another backend solves it: the named one just refuses
    assert not isinstance(info.value, cc.UnsupportedError)
    unregister("mine")
    with pytest.raises(cc.SolverError, match="method 'condensed' does not accept") as info:
        backends.choose("condensed", backends.ProblemDescription(quadratic_energy=False))
    assert not isinstance(info.value, cc.UnsupportedError)


def test_a_route_that_does_not_import_is_a_typed_error_at_the_solve(registry):
    registry(Backend("mine", _signorini_only, routes={"signorini": "cvxcontact.backends.nowhere:full"}))
    with pytest.raises(cc.SolverError, match="'cvxcontact.backends.nowhere:full' of backend 'mine' does not import"):
        cc.solve(two_blocks(), method="mine")


def test_the_fallback_is_the_entry_s_policy(registry):
    """A backend whose finished answer is wrong (the full answer with its displacements scaled by 1.01) and whose
    entry names "full" as its fallback: ``auto`` retries with full, whose answer (it passes) is returned with the
    entry's route label and kept for the next load case; asked by name, the wrong answer stands and is flagged
    (never silent)."""
    def wrong(problem, cache, settings, timings):
        raw = full_route(problem, cache, settings, timings)
        raw.u, raw.method, raw.finish = [1.01 * u for u in raw.u], "wrong", "its own finish"
        return raw

    scene = two_blocks()
    ref = cc.solve(scene, method="full")
    registry(Backend("wrong", _signorini_only, routes={"signorini": wrong},
                     fallback=Fallback("full", "wrong, failed its checks -> full")), before="amg")
    solver = cc.ContactSolver(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                 # the fallback passes: no warning
        sol = solver.solve()
    assert sol.ok and sol.info.method == "full" and sol.info.route == "wrong, failed its checks -> full"
    assert rel(sol.u[0], ref.u[0]) < 1e-12 and solver.method == "full"
    with pytest.warns(cc.ResidualWarning, match="fails its checks"):
        named = cc.solve(scene, method="wrong")
    assert not named.ok and named.info.method == "wrong" and named.info.finish == "its own finish"
    assert rel(named.u[0], ref.u[0]) == pytest.approx(0.01, rel=1e-9)


def test_solve_info_keeps_known_labels_as_members_and_others_as_strings():
    info = SolveInfo(status="optimal", method="mine", route="interior point", finish="my finish")
    assert info.route is cc.Route.INTERIOR_POINT and info.finish == "my finish"
    with pytest.raises(cc.SolverError, match="route label"):
        SolveInfo(status="optimal", method="mine", route="")
    with pytest.raises(cc.SolverError, match="finish label"):
        SolveInfo(status="optimal", method="mine", route="interior point", finish=3)


def test_cache_empties_a_backend_s_own_entries_with_the_rest():
    cache = cc.ContactSolver(two_blocks()).cache.matching("rows A")
    cache.own["mine"] = np.ones(3)
    assert cache.matching("rows A").own["mine"].sum() == 3 and cache.matching("rows B").own == {}
