"""The P2 "everywhere" condition certified (docs/formulation.md §8 "The exact finish", docs/checks.md "The
certified bound"): the exact finish by accumulated cuts, the rigorous energy-norm bound, and the independent
check by the nodal condition sampled at M equally spaced points of every merged segment."""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks as quickstart
from cvxcontact.backends import cones, signorini
from cvxcontact.backends.cuts import energy_bound, point_duals
from cvxcontact.backends.interface import condensation
from cvxcontact.backends.result import Cache, Settings
from cvxcontact.contact.quadratic import bernstein_argmax, point_rows

from conftest import p2_trace_jump, two_blocks

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def _problem(scene):
    return cc.ContactSolver(scene, "gamma3", degree=2).problem


def _energy_norm(problem, a, b):
    """||a - b||_K of two answers (RawResults) in the scaled units, K the reduced stiffness: both answers solve
    the Gauss rows (back-substitutions), so e_phi = Kpp^-1 Kup^T e_u and e_u^T K e_u = e_u^T Kuu e_u +
    e_phi^T Kpp e_phi (docs/formulation.md §2)."""
    out = 0.0
    for blk, ua, pa, ub, pb in zip(problem.blocks, a.u, a.phi, b.u, b.phi):
        e = ua - ub
        out += float(e @ (blk.Kuu @ e))
        if pa is not None:
            f = pa - pb
            out += float(f @ (blk.Kpp @ f))
    return np.sqrt(out)


def _norm(problem, a):
    return np.sqrt(sum(float(u @ (b.Kuu @ u)) + (float(p @ (b.Kpp @ p)) if p is not None else 0.0)
                       for b, u, p in zip(problem.blocks, a.u, a.phi)))


def _sampled(problem, M):
    """The nodal problem at M equally spaced points of every merged segment (ends included; a node shared by
    two segments once), solved by the exact nodal route: (raw, segment, t)."""
    B = problem.lines.cone[0]
    S = B.shape[0] // 3
    seg = np.repeat(np.arange(S), M)
    t = np.tile(np.linspace(0.0, 1.0, M), S)
    keep = np.r_[True, ~((t[1:] == 0.0) & (t[:-1] == 1.0))]          # (s, 1) and (s + 1, 0): one node
    seg, t = seg[keep], t[keep]
    raw = signorini.condensed(problem.with_rows(point_rows(B, seg, t)), Cache(), Settings(), {})
    assert raw.polished
    return raw, seg, t


@pytest.mark.parametrize("nx", [8, 16, 24])
def test_quickstart_p2_gamma3_is_ok_at_the_default_tol_without_warning(nx):
    """The README's quickstart scene with `degree=2, "gamma3"`: the exact finish, ok at tol = 1e-6, no warning
    (before: a ResidualWarning and ok False at every size, the interior point's complementarity 1e-6)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = cc.solve(quickstart(nx), "gamma3", degree=2)
    assert sol.ok and sol.polished and sol.info.finish in ("accumulated cuts", "tangency Newton") and sol.status == "optimal"
    res = sol.residuals()
    # bounds >= 100x the largest measured under every kernel set, one thread (Haswell, Prescott: nx = 8, 16, 24);
    # the finish itself is told by `polished`, the finish's name and no warning above (the interior point's answer
    # warned, ok False)
    assert res["equilibrium"] < 1e-13                # measured 1.3e-16 ... 5.7e-16
    assert res["feasibility"] < 1e-13                # measured 6.2e-17 ... 1.8e-16
    assert res["complementarity"] < 1e-5             # measured 2.1e-8 ... 1.05e-7 (a square root of products ~1e-14)
    assert res["energy error"] < 1e-5                # measured 3.4e-8 ... 7.4e-8


@pytest.mark.parametrize("method", ["condensed", "full"])
def test_finished_jump_holds_everywhere_by_dense_sampling(method):
    """Sampled on each body's own P2 trace (not the merged mesh the finish works on), the finished jump stays
    below the gap everywhere to rounding; both backends give the same displacements."""
    scene = quickstart(16)
    sol = cc.solve(scene, "gamma3", degree=2, method=method)
    assert sol.ok and sol.polished
    xs = np.linspace(0.0, 1.0, 20001)
    jump = p2_trace_jump(sol, xs)
    scale = max(np.abs(u).max() for u in sol.u)
    assert jump.max() < 1e-13 * scale                 # measured 1.2e-16 scale (g = 0)
    other = cc.solve(scene, "gamma3", degree=2, method="condensed" if method == "full" else "full")
    for a, b in zip(sol.u, other.u):
        # the same finish from two interior points: the displacements are fixed to about the square root of the
        # cuts' stopping violation (each answer certified to ~5e-8 of ||u||_K, docs/checks.md); measured
        # 4.7e-12 .. 2.2e-10 of max|u| (oneMKL or not, one thread or two: 2.6e-10 apart on the same code)
        assert np.abs(a - b).max() < 1e-8 * scale


@pytest.mark.parametrize("scene", [lambda: two_blocks((8, 4), (5, 3)), lambda: quickstart(16)], ids=["small", "quickstart"])
def test_certified_bound_holds_and_is_not_loose(scene):
    """The bound sqrt(2 gap) of docs/checks.md against the true energy-norm error ||v - u*||_K, u* the exact
    finish (itself certified to ~5e-8 of ||u||_K), v (i) the interior point's answer, (ii) the nodal condition
    sampled at M = 3, 5, 9 points per segment (infeasible between its points: the bound pushes it apart first).
    The bound holds, and exceeds the true error by at most the factor written beside each case."""
    problem = _problem(scene())
    exact = cones.condensed(problem, Cache(), Settings(), {})
    norm = _norm(problem, exact)
    assert exact.polished and exact.certificate / norm < 3e-7              # measured 6.4e-8, 6.8e-8
    ipm = cones.condensed(problem, Cache(), Settings(polish=False), {})
    err = _energy_norm(problem, ipm, exact)
    assert ipm.certificate >= err - exact.certificate                     # holds
    assert ipm.certificate < 2e4 * err           # measured ratio 5.6e2 (small), 1.8e3 (quickstart): the square
    #                                              root of a gap at the interior point's complementarity
    reduction = condensation(problem, Cache(), Settings(), {})
    _, _, d = reduction.apply(problem, {})
    B = problem.lines.cone[0]
    for M in (3, 5, 9):
        raw, seg, t = _sampled(problem, M)
        beta = point_duals(B.shape[0] // 3, seg, t, raw.y)
        bound = energy_bound(reduction.W, d, B, beta, problem.held_rows)[0]
        err = _energy_norm(problem, raw, exact)
        assert bound >= err - exact.certificate                           # holds
        assert bound < 100 * err                                          # measured ratio 13 ... 19


def test_sampled_condition_converges_to_the_conic_answer():
    """The independent check: [u_nu] <= g at M equally spaced points of every merged segment (linear rows, the
    exact nodal finish: a different program) tends to the conic answer as M grows. The sampled energy stays
    below the conic one (a relaxation) and its deficit falls monotonically; the energy-norm distance falls
    about like 1/M (the violation between points ~ 1/M^2 is a product force x gap, whose square root is the
    error), not to rounding: a finite sample cannot find the tangency points. Numbers in docs/checks.md."""
    problem = _problem(quickstart(16))
    exact = cones.condensed(problem, Cache(), Settings(), {})
    norm = _norm(problem, exact)
    energy = sum(b.energy(u, p) for b, u, p in zip(problem.blocks, exact.u, exact.phi))
    errors, deficits = [], []
    for M in (3, 5, 9, 17, 33, 65):
        raw, _, _ = _sampled(problem, M)
        errors.append(_energy_norm(problem, raw, exact) / norm)
        deficits.append((energy - sum(b.energy(u, p) for b, u, p in zip(problem.blocks, raw.u, raw.phi))) / abs(energy))
    errors, deficits = np.array(errors), np.array(deficits)
    assert (deficits > -1e-12).all() and (deficits[1:] < deficits[:-1]).all()    # measured 6.0e-5 ... 5.6e-8
    assert (errors[1:] < errors[:-1]).all()                 # measured 3.3e-3, 1.9e-3, 6.5e-4, 2.2e-4, 1.6e-4, 5.1e-5
    assert errors[-1] < errors[0] / 30                      # measured / 64


def test_interior_point_alone_is_certified_by_the_bound_or_fails():
    """polish=False: the interior point's answer, its duals moved into the dual cone and its fields re-derived
    from them; `ok` is True only if the certified bound or the three contact checks pass at tol, and a
    ResidualWarning says so when they do not. Where the interior point stops depends on the BLAS kernels
    (measured alone, complementarity / energy error: Haswell 9.5e-7 / 7.6e-7 and Nehalem 1.36e-6 / 7.6e-7,
    `ok` True; Sandybridge 1.04e-6 / 1.04e-6 and Prescott 1.35e-6 / 1.05e-6, `ok` False and warned), so either
    outcome must be consistent."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", cc.errors.ResidualWarning)
        sol = cc.solve(quickstart(16), "gamma3", degree=2, polish=False, tol=1e-6)
    res = sol.residuals()
    assert not sol.polished and "energy error" in res
    certified = res["energy error"] <= 1e-6
    checked = all(res[k] <= 1e-6 for k in ("feasibility", "complementarity", "cone"))
    assert sol.ok == (res["equilibrium"] <= 1e-6 and (certified or checked))
    warned = any(issubclass(w.category, cc.errors.ResidualWarning) for w in caught)
    assert warned == (not sol.ok)


def test_point_rows_are_the_lagrange_basis_and_the_maximiser_is_exact():
    """point_rows evaluates the P2 function of a segment at t (its Lagrange basis); bernstein_argmax finds the
    maximum of every segment's quadratic against 10001 samples."""
    problem = _problem(two_blocks((8, 4), (5, 3)))
    B = problem.lines.cone[0]
    S, n = B.shape[0] // 3, B.shape[1]
    rng = np.random.default_rng(3)
    xi = rng.normal(size=n)
    t = np.linspace(0.0, 1.0, 10001)
    seg = np.repeat(np.arange(S), len(t))
    vals = (point_rows(B, seg, np.tile(t, S)) @ xi).reshape(S, -1)
    segs = problem.lines.cone[1]
    lagrange = np.column_stack([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)])
    assert np.abs(vals - xi[segs] @ lagrange.T).max() < 1e-13
    qmax, tmax = bernstein_argmax((B @ xi).reshape(-1, 3))
    assert np.all(qmax >= vals.max(axis=1) - 1e-14) and np.all(qmax - vals.max(axis=1) < 1e-7)
    assert np.abs((point_rows(B, np.arange(S), tmax) @ xi) - qmax).max() < 1e-13


def test_readme_p2_pairs_scene_is_ok_at_the_default_tol():
    """The README's P2 pairs snippet (a punch on a base clamped at its left side, the base on a rigid floor with a
    parabolic gap): the base's clamped corner on the floor is a node no unknown moves, with a gap, whose constant
    slack enters the point rows of its segment; finished on both backends, no warning at tol = 1e-6 (the README
    passed tol=1e-5 for the interior point)."""
    steel = cc.materials.isotropic(E=200e9, nu=0.3)
    punch = cc.Body(cc.rectangle(x=(0.3, 0.7), y=(0.0, 0.2), nx=4, ny=2), steel, clamped="top", contact="bottom",
                    body_force=(0.0, -1e9))
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=8, ny=4), steel, clamped="left", contact="top")
    floor = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    scene = cc.Scene(punch, base, contacts=[cc.Contact(punch, "bottom", base, "top"),
                                            cc.Contact(base, "bottom", floor, gap=lambda s: 1e-3 * (s - 0.6) ** 2)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sols = [cc.solve(scene, "gamma3", degree=2, method=m) for m in ("condensed", "full")]
    for sol in sols:
        assert sol.ok and sol.polished
        assert sol.residuals()["feasibility"] < 1e-13             # measured 4.1e-15, 5.0e-15
        assert sol.residuals()["energy error"] < 3e-7             # measured 8.0e-8, 8.4e-8
    force = [s.obstacles[0].force[1] for s in sols]
    assert abs(force[0] - force[1]) < 1e-9 * force[0]            # measured 9e-14


def test_block_resting_exactly_on_a_floor_finishes_without_a_nan():
    """A block pushed down by DELTA on rollers onto a floor at its bottom (y = 0): every slack of the contact is
    exactly 0 and so is every term of it (the Gamma values u_y = 0), so each segment's scale in the tangency
    finish's KKT residual is 0. Before: the complementarity products 0/0 = NaN ("invalid value encountered in
    divide", made an error here), which max() passed over. Independent check: the plane-strain closed form of
    the uniaxial strain DELTA/H, the resultant (lambda + 2 mu) DELTA / H per m of width."""
    from hex_scenes import DELTA, H
    from reach_scenes import block2d, line

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = cc.solve(block2d((line(-1.0, 2.0),)), "gamma3", degree=2)
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.TANGENCY_NEWTON, sol.report()
    E, nu = 200e9, 0.3                                         # hex_scenes.STEEL
    p = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) * DELTA / H   # Pa; the block is 1 m wide
    force = sol.obstacles[0].force
    # bounds >= 100x the largest measured under the five kernel sets, one thread
    assert abs(force[1] - p) < 1e-12 * p                       # measured 0 ... 5.2e-16 (relative)
    assert abs(force[0]) < 1e-12 * p                           # measured 0
    assert sol.residuals()["complementarity"] < 1e-12          # measured 0
