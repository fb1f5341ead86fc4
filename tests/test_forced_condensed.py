"""Force-controlled obstacles on the condensed route (cvxcontact/backends/forced.py): the bodies condensed onto their
Gamma dofs once per geometry, the obstacles' translations bordering that small system, the full route's program and
exact finishes run on it. The reference is the full backend (the whole phi-form program, its finishes on the sparse
mixed system of every dof): the two solve the same equations, exactly reduced, so their answers agree to rounding
where the finish is exact (the independent active set, Newton at the tangency points), and to the cuts' accuracy
where both stop at the accumulated cuts."""

import warnings

import numpy as np
import pytest
from conftest import rel
from scenes import SCENES
from scenes3d import sphere_cones_key, sphere_on_block

import cvxcontact as cc
from cvxcontact import backends
from cvxcontact.apps.studies.adapt import punch_block
from cvxcontact.apps.studies.adapt import punch_scene as issue_punch
from cvxcontact.discrete import build_problem
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

TIGHT = 1e-11
"""Condensed against full where the finish is exact: measured at most 4.6e-14 (lambda, the circle under P2 sigma1
and the held layer under P1; u, lambda and the translation 1e-15 ... 3e-14 on every case below, 2026-12-05); the
P2 cones of the punch and the circle at most 7.8e-14 (the circle's translation) under the SkylakeX, Haswell,
Prescott, Sandybridge and Nehalem kernels and without oneMKL."""

CASES = {
    "punch, P1": (SCENES["force-controlled punch"][0], {"condition": "gamma3"}),
    "punch, P2 sigma1": (SCENES["force-controlled punch"][0], {"condition": "sigma1", "degree": 2}),
    "punch, P2 cones": (SCENES["force-controlled punch"][0], {"condition": "gamma3", "degree": 2}),
    "circle, P1": (SCENES["force-controlled circle"][0], {"condition": "gamma3"}),
    "circle, P2 sigma1": (SCENES["force-controlled circle"][0], {"condition": "sigma1", "degree": 2}),
    "circle, P2 cones": (SCENES["force-controlled circle"][0], {"condition": "gamma3", "degree": 2}),
    "issue-30 punch, P1": (lambda: issue_punch(punch_block(16, 8, 9, 8)), {"condition": "gamma3"}),
    "issue-30 punch, P2 cones": (lambda: issue_punch(punch_block(16, 8, 9, 8)), {"condition": "gamma3", "degree": 2}),
    "sphere, 3D P1": (lambda: sphere_on_block(), {"condition": "gamma3"}),
    "sphere, 3D P2 sigma1": (lambda: sphere_on_block(n=(4, 4, 2)), {"condition": "sigma1", "degree": 2}),
    "sphere, 3D P2 cones": (lambda: sphere_on_block(n=(4, 4, 2)), {"condition": "gamma3", "degree": 2}),
    "held layer, P1": (SCENES["layer held by the contact"][0], {"condition": "gamma3"}),
    "held layer, P2 sigma1": (SCENES["layer held by the contact"][0], {"condition": "sigma1", "degree": 2}),
    "held layer, P2 sigma2": (SCENES["layer held by the contact"][0], {"condition": "sigma2", "degree": 2}),
}
HELD = {name for name in CASES if name.startswith("held")}
"""Bodies held by the contact only (no obstacle): the layer's rigid motion in its singular Sigma."""

SPLIT = {"issue-30 punch, P2 cones": (2e-9, 1e-6), "sphere, 3D P2 cones": (TIGHT, 1e-9)}
"""(u and translation, lambda_h) bounds where Newton at the tangency points sets the split of the force between
nearly coincident points only to the system's conditioning (backends/tangency.py, RESIDUAL_STALL_TOL), so the
last digits follow the BLAS kernels. Measured (SkylakeX / Haswell / Prescott / Sandybridge / Nehalem kernels):
the issue-30 punch u 3.1e-13 / 1.9e-13 / 2.7e-13 / 2.2e-13 / 2.4e-13, translation 9.8e-13 / 1.6e-13 / 2.3e-13 /
5.9e-13 / 2.0e-12, lambda 4.4e-10 / 9.8e-11 / 1.4e-10 / 2.0e-10 / 7.6e-10; the sphere u 1.4e-14 / 1.2e-14 / 1.5e-14
/ 2.8e-15 / 8.7e-15, lambda 5.8e-12 / 8.2e-12 / 7.0e-12 / 5.4e-12 / 5.5e-12 (after the tangency finish's restart from
the point reading, 2026-12-06: u 1.3e-15 / 1.1e-15 / 7.5e-16 / 6.0e-16 / 8.1e-16, lambda 2.4e-12 / 7.9e-13 / 5.8e-13
/ 3.7e-13 / 1.5e-12). Without oneMKL (default / Sandybridge kernels): the issue-30 punch u 1.8e-12 / 4.4e-13,
translation 1.6e-11 / 1.2e-12, lambda 5.5e-9 / 3.2e-10; the sphere u 1.2e-14 / 3.6e-15, lambda 2.1e-12 / 1.0e-12."""


def _solve(scene, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        return cc.solve(scene, **kw)


@pytest.mark.parametrize("name", list(CASES))
def test_condensed_equals_full_on_force_controlled_scenes(name, shared):
    build, kw = CASES[name]
    scene = build()
    fast = _solve(scene, method="condensed", **kw)
    # the sphere's full answer, solved once a run (tests/test_check_rounding_cones.py reads it too)
    ref = shared(*sphere_cones_key())[0] if name == "sphere, 3D P2 cones" else _solve(scene, method="full", **kw)
    assert fast.ok and ref.ok and fast.polished and ref.polished
    assert fast.info.method == "condensed" and fast.info.factorization        # one factorisation per body, kept
    assert fast.info.route == ref.info.route == cc.backends.result.Route.INTERIOR_POINT_FINISHED
    assert fast.info.finish == ref.info.finish
    fields, lam = SPLIT.get(name, (TIGHT, TIGHT))
    assert max(rel(a, b) for a, b in zip(fast.u, ref.u)) < fields
    assert rel(fast.contact.lam, ref.contact.lam) < lam
    if name in HELD:
        return
    assert rel(fast.obstacles[0].translation, ref.obstacles[0].translation) < fields
    # the obstacle's balance, independently of the check: the prescribed force against the contact resultant
    F = np.asarray(fast.obstacles[0].prescribed, dtype=float)
    assert rel(fast.obstacles[0].force, F) < 1e-9                               # measured <= 3e-14


def test_auto_chooses_the_condensed_route_for_force_control_and_the_full_one_for_a_compliance_law():
    """The registry decides (backends/__init__.py, FORCED_KINDS, HELD_KINDS): Signorini rows and the P2 cones under
    force control go to "condensed"; a compliance law under force control stays with "full", so do the P2 cones
    on a body held by the contact only; "sparse" refuses force control."""
    scene = SCENES["force-controlled punch"][0]()
    for kw in ({"condition": "gamma3"}, {"condition": "gamma3", "degree": 2}):
        problem = build_problem(scene, space(kw.get("degree", 1), "triangle"), kw["condition"], cc.Signorini())
        description = backends.describe(problem)
        assert description.force_control and backends.choose("auto", description) == "condensed"
        with pytest.raises(cc.SolverError, match="force_control=True"):
            backends.choose("sparse", description)
    build, kw = SCENES["force-controlled punch, compliance"]
    problem = build_problem(build(), space(1, "triangle"), kw["condition"], cc.NormalCompliance(stiffness=1e12))
    assert backends.choose("auto", backends.describe(problem)) == "full"
    sol = _solve(scene, condition="gamma3")
    assert sol.info.method == "condensed" and sol.info.requested == "auto"
    held = SCENES["layer held by the contact"][0]()
    for kw, method in (({"condition": "gamma3"}, "condensed"), ({"condition": "sigma1", "degree": 2}, "condensed"),
                       ({"condition": "gamma3", "degree": 2}, "full")):
        problem = build_problem(held, space(kw.get("degree", 1), "triangle"), kw["condition"], cc.Signorini())
        assert problem.held and backends.choose("auto", backends.describe(problem)) == method


def test_a_force_controlled_re_solve_reuses_the_factorisation():
    """A ContactSolver re-solve with another force: the condensation is kept (no new factorisation), the
    answer equals a fresh full solve of the new scene."""
    build = SCENES["force-controlled circle"][0]
    scene = build()
    solver = cc.ContactSolver(scene, condition="gamma3", method="condensed")
    first = solver.solve()
    obstacle = scene.obstacles[0].obstacle
    twice = scene.with_obstacles(obstacle.with_force(2 * np.asarray(obstacle.force, dtype=float)))
    again, ref = solver.solve(twice), _solve(twice, condition="gamma3", method="full")
    assert first.ok and again.ok and "factorization" not in again.info.timings
    assert rel(again.u[0], ref.u[0]) < TIGHT and rel(again.contact.lam, ref.contact.lam) < TIGHT


def test_dense_lu_solves_as_superlu_and_refuses_a_singular_matrix():
    """backends.factor.lu: a nearly dense matrix goes to LAPACK (DenseLU), a sparse one to SuperLU; both solve a
    random nonsingular system to rounding (checked by its residual), an exactly singular one raises RuntimeError
    as SuperLU does (the callers' "singular" branch)."""
    import scipy.sparse as sp

    from cvxcontact.backends.factor import DENSE_FILL, DenseLU, lu

    rng = np.random.default_rng(3)
    n = 60
    dense = sp.csc_matrix(rng.standard_normal((n, n)) + n * np.eye(n))
    sparse = sp.csc_matrix(sp.diags([rng.uniform(1, 2, n), np.full(n - 1, 0.3), np.full(n - 1, 0.3)], [0, 1, -1]))
    assert dense.nnz > DENSE_FILL * n * n > sparse.nnz
    b = rng.standard_normal(n)
    for K, kind in ((dense, DenseLU), (sparse, type(lu(sparse)))):
        f = lu(K)
        assert isinstance(f, kind) and not isinstance(lu(sparse), DenseLU)
        x = f.solve(b)
        assert np.abs(K @ x - b).max() <= 1e-12 * (abs(K) @ np.abs(x) + np.abs(b)).max()
    singular = dense.toarray()
    singular[:, 0] = 0.0
    with pytest.raises(RuntimeError):
        lu(sp.csc_matrix(singular))
