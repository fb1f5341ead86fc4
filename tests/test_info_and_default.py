"""The default backend ("auto"), the typed SolveInfo, and the one definition of loads vs geometry."""

import dataclasses
import inspect
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import cvxcontact as cc
from conftest import rel, two_blocks
from cvxcontact.apps.sweep import Case, read_sweep, run_sweep
from cvxcontact.backends import BACKENDS, METHODS, ProblemDescription, choose
from cvxcontact.io.scenefile import load_scene
from cvxcontact.physics.fingerprint import geometry_fingerprint
from cvxcontact.physics.loads import GEOMETRY_FIELDS, LOAD_FIELDS, SCENE_LOAD_FIELDS
from cvxcontact.solution.info import Finish, Route, SolveInfo, Status
from references import direct_mixed_solve

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


# ------------------------------------------------------------------------------ default backend

def test_registry_auto_takes_the_first_accepting_backend_in_speed_order():
    assert METHODS[0] == "auto" and set(METHODS[1:]) == {b.name for b in BACKENDS} == {"full", "condensed", "sparse",
                                                                                      "amg", "newton"}
    assert [b.name for b in BACKENDS] == ["amg", "sparse", "condensed", "newton", "full"]   # speed order (sparse:
    assert choose("auto") == "condensed"                                          # long interfaces only, issue 13)
    assert choose("auto", ProblemDescription(user_terms=2)) == "full"              # user terms: only full
    assert choose("auto", ProblemDescription(quadratic_energy=False)) == "newton"     # Hencky: the Newton route
    assert choose("auto", ProblemDescription(quadratic_energy=False, dependent_rows=True)) == "full"
    assert choose("full", ProblemDescription(user_terms=1)) == "full"
    with pytest.raises(cc.SolverError, match="'condensed' does not accept"):
        choose("condensed", ProblemDescription(user_terms=1))
    with pytest.raises(cc.SolverError, match="method must be one of"):
        choose("fastest")


def test_defaults_are_auto_everywhere():
    for fn in (cc.solve, cc.ContactSolver.__init__):
        assert inspect.signature(fn).parameters["method"].default == "auto"
    spec = load_scene(EXAMPLES / "two_blocks.toml")                               # no method in the file
    assert spec.method == "auto"


def test_default_solve_is_condensed_and_matches_an_independent_dense_solve(scene):
    """The default answer against a dense LU of (26) on its active set (references.direct_mixed_solve)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = cc.solve(scene)
    assert sol.info.method == sol.method == "condensed" and sol.info.requested == "auto"
    assert sol.ok and sol.polished and sol.contact.active.sum() > 0
    u, phi, lam, _, _ = direct_mixed_solve(scene, sol)
    for k in range(2):
        assert rel(sol.u[k], u[k]) < 1e-10
    assert rel(sol.phi[0], phi[0]) < 1e-10
    assert rel(sol.contact.lam, lam) < 1e-8
    full = cc.solve(scene, method="full")
    assert full.info.method == "full" and full.info.requested == "full"
    assert {v.name() for v in full.problem.variables()} >= {"u1", "phi1", "u2"}


# ------------------------------------------------------------------------------ SolveInfo

def test_solve_info_is_typed_frozen_and_backs_the_old_attributes(scene):
    solver = cc.ContactSolver(scene, "gamma3")
    first = solver.solve()
    info = first.info
    assert isinstance(info, SolveInfo)
    assert info.status is Status.OPTIMAL and first.status == "optimal" == __import__("cvxpy").OPTIMAL
    assert info.route is Route.INTERIOR_POINT_FINISHED and first.path == "interior point + exact finish"
    assert info.finish in (Finish.ACTIVE_SET, Finish.ACTIVE_SET_AFTER_NNLS)
    assert info.iterations == first.problem.solver_stats.num_iters > 0
    assert info.polished is first.polished is True
    assert first.timings is info.timings and {"assembly", "factorization", "solve", "read_back"} <= set(info.timings)
    assert all(isinstance(v, float) and v >= 0 for v in info.timings.values())
    assert info.factorizations == 1
    with pytest.raises(dataclasses.FrozenInstanceError):
        info.method = "full"
    with pytest.raises(TypeError):
        info.timings["solve"] = 0.0                                               # read-only mapping
    with pytest.raises(AttributeError):
        first.status = "optimal"                                                  # a view of info
    assert json.loads(json.dumps({"s": first.status, "r": first.path})) == {"s": "optimal",
                                                                           "r": "interior point + exact finish"}
    again = solver.solve(two_blocks(scale=1.5))                                   # same geometry, other loads
    assert again.info.route is Route.WARM_START and again.info.iterations == 0 and again.problem is None
    assert again.info.factorizations == 0 and again.info.finish is not None and again.info.polished


def test_solve_info_rejects_unknown_statuses_and_keeps_a_backend_s_own_route_label():
    with pytest.raises(ValueError):
        SolveInfo(status="infeasible", method="full", route=Route.INTERIOR_POINT)
    info = SolveInfo(status=Status.OPTIMAL, method="mine", route="somehow")       # a registered backend's label
    assert info.route == "somehow" and not isinstance(info.route, Route)        # (tests/test_registry.py)
    with pytest.raises(cc.SolverError, match="route label"):
        SolveInfo(status=Status.OPTIMAL, method="full", route=None)


# ------------------------------------------------------------------------------ loads vs geometry

def _body(**kw):
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=6, ny=3)
    args = dict(clamped="top", contact="bottom", grounded=["left"], potential={"top": 10.0})
    args.update(kw)
    return cc.Body(args.pop("mesh", m), args.pop("material", cc.materials.PZT5A), **args)


def test_every_body_parameter_is_classified_as_load_or_geometry():
    params = set(inspect.signature(cc.Body.__init__).parameters) - {"self", "name"}
    assert params == set(LOAD_FIELDS) | set(GEOMETRY_FIELDS) and not set(LOAD_FIELDS) & set(GEOMETRY_FIELDS)
    fields = set(inspect.signature(cc.Scene.__init__).parameters) - {"self", "bodies", "contacts"}
    assert fields == set(SCENE_LOAD_FIELDS)


def test_fingerprint_excludes_exactly_the_loads():
    ref = geometry_fingerprint(_body())
    loads = dict(body_force=(1.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"right": -0.05},
                 volume_charge=1e-3, potential={"top": -250.0}, floating={"bottom": 1e-3})   # *values*
    assert set(loads) == set(LOAD_FIELDS)
    for key, value in loads.items():
        if key == "floating":     # a floating electrode apart from the driven one: its charge is a load
            base = dict(potential={}, grounded=["top"])
            assert (geometry_fingerprint(_body(floating={"bottom": 0.0}, **base))
                    == geometry_fingerprint(_body(**{key: value}, **base))
                    != geometry_fingerprint(_body(**base))), key
            continue
        assert geometry_fingerprint(_body(**{key: value})) == ref, key
    geometry = dict(mesh=cc.rectangle(x=(0, 1), y=(0, 0.5), nx=7, ny=3), material=cc.materials.PZT4,
                    clamped=["top", "right"], grounded=["left", "right"], contact="top", roller=["right"],
                    displacement={"right": (None, 0.0)})
    for key, value in geometry.items():
        kw = {key: value}
        if key == "contact":
            kw.update(clamped="bottom", potential={"bottom": 10.0})
        assert geometry_fingerprint(_body(**kw)) != ref, key
    assert set(geometry) == set(GEOMETRY_FIELDS)
    assert geometry_fingerprint(_body(potential={"right": 10.0})) != ref           # potential *tags*


def test_sweep_case_keys_follow_the_load_definition():
    def geo(overrides):
        return Case("x", "", overrides, "gamma3").geometry

    base = geo({})
    for key in ("gap", "body[0].body_force[1]", "body[1].traction.right", "body[0].surface_charge.left",
                "body[0].volume_charge", "body[0].potential.top"):
        assert geo({key: 1.0}) == base, key
    for key in ("body[0].mesh.rectangle.nx", "body[1].material.nu", "body[0].clamped", "condition"):
        assert geo({key: 1.0}) != base, key


def test_gap_only_sweep_shares_one_contact_solver(tmp_path):
    """Five gaps, one worker: one factorisation, four warm starts; each case equals a fresh full solve."""
    (tmp_path / "scene.toml").write_text((EXAMPLES / "two_blocks.toml").read_text()
                                         .replace("nx = 16, ny = 8", "nx = 8, ny = 4")
                                         .replace("nx = 11, ny = 6", "nx = 6, ny = 3"))
    gaps = [0.0, 2e-6, 5e-6, -1e-6, 1e-5]
    (tmp_path / "sweep.toml").write_text(f'scene = "scene.toml"\n[grid]\ngap = {json.dumps(gaps)}\n')
    sweep = read_sweep(tmp_path / "sweep.toml")
    assert sweep.method == "auto" and len({c.geometry for c in sweep.cases}) == 1
    report = run_sweep(tmp_path / "sweep.toml", tmp_path / "out", workers=1)
    assert report.done == 5 and not report.failed
    infos = {c.id: json.loads((tmp_path / "out" / "cases" / f"{c.id}.json").read_text()) for c in sweep.cases}
    assert sum("factorization" in i["timings_s"] for i in infos.values()) == 1
    assert sorted(i["path"] for i in infos.values()).count("active-set warm start") == 4
    spec = load_scene(tmp_path / "scene.toml")
    b1, b2 = spec.scene.bodies
    for c in sweep.cases:
        arrays = np.load(tmp_path / "out" / "cases" / f"{c.id}.npz", allow_pickle=False)
        ref = cc.solve(cc.Scene(b1, b2, gap=c.overrides["gap"]), method="full")
        assert rel(arrays["u1"], ref.u[0]) < 1e-9 and rel(arrays["lam"], ref.contact.lam) < 1e-7, c.overrides
