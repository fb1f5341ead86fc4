"""Adversarial scenes against an independent dense reference (tests/adversarial_reference.py).

The contract checked for every case: either the answer is right to the tolerance
(u per body relative to that body's max |u|, phi likewise, nodal contact forces E^T y
relative to the largest reference nodal force), or ``sol.ok`` is False and a
``cvxcontact.ResidualWarning`` was issued. A silent wrong answer fails the test.
A ``SolverError`` (loud refusal) is accepted for the solve families; traps accept the
refusals named in their docstrings.
"""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import cvxcontact as cc
from adversarial_reference import Reference, mixed_residual
from cvxcontact.io.scenefile import load_scene

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

TOL_U = 1e-6        # displacement / potential, relative to each body's own max
TOL_F = 1e-5        # nodal contact forces, relative to the largest reference nodal force
METHODS = ("full", "condensed")
STEEL = cc.materials.isotropic(E=200e9, nu=0.3)


# --------------------------------------------------------------------------- helpers

def run(scene, **kw):
    """Solve with every warning recorded; returns (sol, caught) or (exception, caught)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sol = cc.solve(scene, **kw)
        except cc.SolverError as exc:
            return exc, caught
    return sol, caught


def _rel(a, b, floor=0.0):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return np.inf
    return float(np.abs(a - b).max() / max(np.abs(b).max(), floor, np.finfo(float).tiny))


def errors(sol, ref):
    """(error in u and phi, error in the nodal forces) of ``sol`` against ``ref``."""
    umax = max(np.abs(u).max() for u in ref.u)
    eu = max(_rel(sol.u[k], ref.u[k], 1e-14 * umax) for k in range(2))
    for k in range(2):
        if ref.phi[k] is not None:
            eu = max(eu, _rel(sol.phi[k], ref.phi[k]) if sol.phi[k] is not None else np.inf)
    if sol.contact.x.shape != ref.x.shape or np.abs(sol.contact.x - ref.x).max() > 1e-9 * np.ptp(ref.x):
        return eu, np.inf
    return eu, _rel(sol.contact.force, ref.force)


def describe(sol, ref, caught, extra=""):
    if isinstance(sol, Exception):
        return f"{extra} raised {type(sol).__name__}: {sol}"
    eu, ef = errors(sol, ref)
    warned = any(issubclass(w.category, cc.ResidualWarning) for w in caught)
    return (f"{extra} err_u={eu:.3g} err_force={ef:.3g} ok={sol.ok} warned={warned} polished={sol.polished} "
            f"path={sol.path!r} status={sol.status!r} residuals={sol.residuals()} "
            f"active={int(sol.contact.active.sum())} vs reference {int(ref.active.sum())}")


def judge(sol, ref, caught, tol=(TOL_U, TOL_F)):
    """True if the answer is right to ``tol``, or it is flagged (ok False and a ResidualWarning),
    or the solver refused loudly (SolverError)."""
    if isinstance(sol, cc.SolverError):
        return True
    eu, ef = errors(sol, ref)
    if eu <= tol[0] and ef <= tol[1]:
        return True
    warned = any(issubclass(w.category, cc.ResidualWarning) for w in caught)
    return (not sol.ok) and warned


def check(sol, ref, caught, label):
    assert judge(sol, ref, caught), "silent wrong answer: " + describe(sol, ref, caught, label)


def gap_fn(x_nodes, values):
    """A gap callable g(x) equal to ``values`` at the merged nodes ``x_nodes`` (piecewise linear)."""
    xs, vs = np.array(x_nodes, dtype=float), np.array(values, dtype=float)
    return lambda x: np.interp(x, xs, vs)


def partial_gap(ref0, a, b, xc, width):
    """Gap = free jump - D (a - b ((x - xc)/width)^2): contact around xc only (D = max free jump)."""
    d0 = ref0.d0
    D = np.abs(d0).max()
    x = ref0.x
    return d0 - D * (a - b * ((x - xc) / width) ** 2)


# --------------------------------------------------------------------------- reference self-check

def test_reference_satisfies_the_mixed_system_and_matches_a_direct_solve():
    """The reference itself: LCP signs, residual of (26) with its own operators, and the same
    answer as the dense KKT solve of (26) in references.py on the reference's active set."""
    from references import direct_mixed_solve

    b1, b2, gap, condition = _random_scene(3)
    r = Reference((b1, b2), "gamma3")
    ref = r.solve(gap(r.x))
    assert 0 < ref.active.sum() < len(ref.active)
    assert max(ref.lcp.values()) < 1e-12, ref.lcp
    assert mixed_residual((b1, b2), ref) < 1e-11
    # direct_mixed_solve closes the active rows at zero gap: compare on the zero-gap scene
    r0 = Reference((b1, b2), "gamma3")
    ref0 = r0.solve(np.zeros(len(r0.x)))
    assert ref0.active.sum() > 0 and max(ref0.lcp.values()) < 1e-12
    us, phis, lam, force, jump = direct_mixed_solve(
        cc.Scene(b1, b2), SimpleNamespace(contact=SimpleNamespace(active=ref0.force > 0)))
    for k in range(2):
        assert _rel(us[k], ref0.u[k]) < 1e-10
        if phis[k] is not None:
            assert _rel(phis[k], ref0.phi[k]) < 1e-10
    assert _rel(force, ref0.force) < 1e-9


# --------------------------------------------------------------------------- stiffness ratio

RATIOS = (1e0, 1e2, 1e4, 1e6, 1e8, 1e9)


def _ratio_scene(ratio):
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=12, ny=4)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=9, ny=4)
    b1 = cc.Body(m1, cc.materials.isotropic(E=200e9, nu=0.3), clamped=["top"], contact="bottom",
                 body_force=(0.0, -2e9))
    b2 = cc.Body(m2, cc.materials.isotropic(E=200e9 / ratio, nu=0.3), clamped=["bottom"], contact="top")
    return b1, b2


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("ratio", RATIOS, ids=lambda r: f"ratio{r:.0e}")
def test_stiffness_ratio(ratio, method):
    """A steel block (E1 = E2 * ratio) pressed by its weight onto a soft clamped foundation,
    parabolic gap: contact in the middle part of the line only."""
    bodies = _ratio_scene(ratio)
    r = Reference(bodies, "gamma3")
    gap = partial_gap(r, 0.3, 1.2, 0.5, 1.0)
    ref = r.solve(gap)
    assert 0 < ref.active.sum() < len(ref.active) and max(ref.lcp.values()) < 1e-10
    sol, caught = run(cc.Scene(*bodies, gap=gap_fn(r.x, gap)), condition="gamma3", method=method)
    check(sol, ref, caught, f"ratio={ratio:g} method={method}")


# --------------------------------------------------------------------------- seeded random scenes

SEEDS = tuple(range(20))


def _random_scene(seed, zero_gap=False):
    """A realistic random scene: steel or PZT-5A on a foundation with E in [7e6, 7e11] (log-uniform),
    non-matching meshes, random loads, a random parabolic gap around the free deformation."""
    rng = np.random.default_rng(20240611 + seed)
    width = rng.uniform(0.5, 2.0)
    h1, h2 = rng.uniform(0.2, 0.6, size=2) * width
    nx1, nx2 = rng.choice(np.arange(6, 17), size=2, replace=False)
    ny1, ny2 = rng.integers(3, 6, size=2)
    diag = rng.choice(["alternate", "right", "left"], size=2)
    m1 = cc.rectangle(x=(0.0, width), y=(0.0, h1), nx=int(nx1), ny=int(ny1), diagonal=str(diag[0]))
    m2 = cc.rectangle(x=(0.0, width), y=(-h2, 0.0), nx=int(nx2), ny=int(ny2), diagonal=str(diag[1]))
    piezo = rng.random() < 0.5
    mat1 = cc.materials.PZT5A if piezo else STEEL
    E2 = 7.0 * 10 ** rng.uniform(6, 11)
    mat2 = cc.materials.isotropic(E=E2, nu=rng.uniform(0.2, 0.4))
    fy, fx = -rng.uniform(0.5, 3.0) * 1e9, rng.uniform(-0.5, 0.5) * 1e9
    a1, w1 = rng.uniform(-0.5, 0.5), rng.uniform(0.5, 3.0)
    load = dict(body_force=lambda x, y: (fx * (1 + a1 * y / h1) + 0 * x, fy * (1 + a1 * np.cos(w1 * x / width))),
                traction={str(rng.choice(["left", "right"])): (rng.uniform(-1, 1) * 1e8, rng.uniform(-1, 1) * 1e8)})
    if piezo:
        load["grounded"] = ["top"]
        load["surface_charge"] = {"left": rng.uniform(-0.05, 0.05),
                                  "right": (lambda x, y, c=rng.uniform(-0.05, 0.05): c * (1 + y / h1))}
        load["volume_charge"] = rng.uniform(-0.1, 0.1)
    b1 = cc.Body(m1, mat1, clamped=["top"], contact="bottom", **load)
    b2 = cc.Body(m2, mat2, clamped=["bottom"], contact="top",
                 traction={"right": (rng.uniform(-1, 1) * 1e6, 0.0)})
    condition = str(rng.choice(cc.CONDITIONS))
    a, b, xc = rng.uniform(0.1, 0.6), rng.uniform(1.0, 6.0), rng.uniform(0.2, 0.8) * width
    if zero_gap:
        return b1, b2, None, condition
    r = Reference((b1, b2), condition)
    if np.abs(r.d0).max() == 0 or r.d0.max() <= 0:       # pushed away: flip the vertical loads
        raise AssertionError("random scene without a tendency to contact; change the generator")
    gap = partial_gap(r, a, b, xc, width)
    return b1, b2, gap_fn(r.x, gap), condition


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("seed", SEEDS)
def test_random_scene(seed, method):
    b1, b2, gap, condition = _random_scene(seed)
    r = Reference((b1, b2), condition)
    ref = r.solve(gap(r.x))
    assert ref.active.sum() > 0 and max(ref.lcp.values()) < 1e-10, ref.lcp
    sol, caught = run(cc.Scene(b1, b2, gap=gap), condition=condition, method=method)
    check(sol, ref, caught, f"seed={seed} condition={condition} method={method} "
                            f"E2={b2.material.c[0, 0]:.2g} piezo={b1.piezoelectric}")


# --------------------------------------------------------------------------- near-grazing contact

def _grazing_scene(delta):
    """PZT-5A on aluminium, partial contact; the open node next to the contact zone is moved to touch
    (delta = 0), to be open by delta, or to penetrate by -delta (delta relative to max free jump)."""
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=12, ny=4)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=9, ny=3)
    b1 = cc.Body(m1, cc.materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom",
                 body_force=(0.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05})
    b2 = cc.Body(m2, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top")
    r = Reference((b1, b2), "gamma3")
    gap = partial_gap(r, 0.3, 2.0, 0.45, 1.0)
    base = r.solve(gap)
    open_ = np.flatnonzero(~base.active)
    j = open_[np.argmin(np.abs(base.slack[open_]))]            # the open node closest to touching
    assert base.slack[j] < 0
    gap = gap.copy()
    gap[j] += base.slack[j] - delta * np.abs(r.d0).max()      # new slack at j: delta * D (>0: penetrates)
    ref = r.solve(gap)
    return (b1, b2), gap_fn(r.x, gap), ref, j


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("polish", (True, False), ids=("polish", "no-polish"))
@pytest.mark.parametrize("delta", (0.0, 1e-9, -1e-9), ids=("touch", "penetrate1e-9", "open1e-9"))
def test_near_grazing(delta, polish, method):
    """An open node next to the contact zone brought to touch with (almost) zero force; with and
    without the exact finish."""
    bodies, gap, ref, j = _grazing_scene(delta)
    assert max(ref.lcp.values()) < 1e-10
    # the grazing node carries (almost) no force: within 1e-6 of the largest nodal force
    assert ref.force[j] <= 1e-6 * ref.force.max()
    sol, caught = run(cc.Scene(*bodies, gap=gap), condition="gamma3", method=method, polish=polish)
    check(sol, ref, caught, f"delta={delta:g} polish={polish} method={method} node={j}")


# ------------------------------------------------------------------------ traps: expressions with an output argument

_FILE = """
condition = "gamma3"
gap = {gap}
[[body]]
material = "PZT-5A"
mesh = {{ rectangle = {{ x = [0.0, 1.0], y = [0.0, 0.5], nx = 8, ny = 4 }} }}
clamped = ["top"]
grounded = ["top"]
contact = "bottom"
body_force = {force}
traction = {{ right = [0.0, 3e8] }}
[[body]]
material = {{ E = 70e9, nu = 0.3 }}
mesh = {{ rectangle = {{ x = [0.0, 1.0], y = [-0.5, 0.0], nx = 6, ny = 3 }} }}
clamped = ["bottom"]
contact = "top"
"""

TRAPS = {
    "gap-exp-out": ('"0*exp(x, x)"', '[0.0, -2e9]', (0.0, -2e9)),
    "force-sin-out": ('0.0', '["0*sin(x, y)", "-2e9*(1+y)"]', lambda x, y: (0.0 * x, -2e9 * (1 + y))),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("trap", sorted(TRAPS))
def test_expression_with_output_argument(trap, method, tmp_path):
    """Either refused (CvxContactError, at load or solve), or the answer is right and the merged
    abscissae and the mesh points are unchanged."""
    gap, force, python_force = TRAPS[trap]
    path = tmp_path / "scene.toml"
    path.write_text(_FILE.format(gap=gap, force=force))
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=6, ny=3)
    bodies = (cc.Body(m1, cc.materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom",
                      body_force=python_force, traction={"right": (0.0, 3e8)}),
              cc.Body(m2, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top"))
    r = Reference(bodies, "gamma3")
    ref = r.solve(np.zeros(len(r.x)))
    try:
        scene = load_scene(path).scene
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = cc.solve(scene, condition="gamma3", method=method)
    except cc.CvxContactError:
        return                                                   # refused: fine
    state = []
    if not np.array_equal(scene.interface.x, r.x) and np.abs(scene.interface.x - r.x).max() > 1e-12:
        state.append(f"merged abscissae changed: max |dx| = {np.abs(scene.interface.x - r.x).max():.3g}")
    for k, (mine, theirs) in enumerate(zip((m1, m2), (b.mesh for b in scene.bodies))):
        if not np.array_equal(mine.points, theirs.points):
            state.append(f"mesh {k + 1} points changed")
    eu, ef = errors(sol, ref)
    assert not state and eu <= TOL_U and ef <= TOL_F, (
        f"trap {trap}: accepted, " + "; ".join(state) + " " + describe(sol, ref, caught))


# --------------------------------------------------------------------------- traps: meshes

def _overlapping_mesh():
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    node = lambda i, j: j * 9 + i                                      # noqa: E731
    extra = np.array([[node(2, 1), node(4, 1), node(3, 3)]])           # covers cells already meshed
    return cc.Mesh(m.points, np.vstack([m.triangles, extra]), {t: m.boundary(t) for t in m.tags})


def _two_component_mesh():
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    island = cc.rectangle(x=(0.3, 0.5), y=(0.7, 0.9), nx=2, ny=2)
    points = np.vstack([m.points, island.points])
    triangles = np.vstack([m.triangles, island.triangles + len(m.points)])
    return cc.Mesh(points, triangles, {t: m.boundary(t) for t in m.tags})


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("trap", ("overlapping-triangle", "unclamped-component"))
def test_mesh_trap(trap, method):
    """A mesh with an extra triangle over meshed cells, or with a second component that no clamp
    holds: a CvxContactError, or ok False with a ResidualWarning."""
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=6, ny=3)
    try:
        m1 = _overlapping_mesh() if trap == "overlapping-triangle" else _two_component_mesh()
        b1 = cc.Body(m1, STEEL, clamped=["top"], contact="bottom", body_force=(0.0, -2e9))
        b2 = cc.Body(m2, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = cc.solve(cc.Scene(b1, b2), condition="gamma3", method=method)
    except cc.CvxContactError:
        return
    warned = any(issubclass(w.category, cc.ResidualWarning) for w in caught)
    assert not sol.ok and warned, (f"{trap} accepted silently: ok={sol.ok} warned={warned} "
                                   f"residuals={sol.residuals()} path={sol.path!r}")


# --------------------------------------------------------------------------- traps: mutation

def _fresh(bodies, loads=None):
    """Bodies rebuilt on copies of the meshes as they are now (the geometry the user sees)."""
    out = []
    for b, kw in zip(bodies, loads or ({}, {})):
        m = b.mesh
        mesh = cc.Mesh(m.points.copy(), m.triangles.copy(), {t: m.boundary(t).copy() for t in m.tags})
        args = dict(clamped=b.clamped, contact=b.contact, grounded=b.grounded,
                    body_force=b.body_force.value, volume_charge=b.volume_charge.value,
                    traction={t: v.value for t, v in b.traction.items()},
                    surface_charge={t: v.value for t, v in b.surface_charge.items()},
                    potential={t: v.value for t, v in b.potential.items()})
        args.update(kw)
        out.append(cc.Body(mesh, b.material, **args))
    return tuple(out)


def _mutation_bodies():
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=10, ny=4)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=7, ny=3)
    b1 = cc.Body(m1, cc.materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom",
                 body_force=(0.0, -2e9), traction={"right": (0.0, 4e8)})
    b2 = cc.Body(m2, cc.materials.isotropic(E=70e9, nu=0.3), clamped=["bottom"], contact="top")
    return b1, b2


@pytest.mark.parametrize("method", METHODS)
def test_points_scaled_in_place_after_a_solve(method):
    """``mesh.points *= 1e-3`` on both meshes after a solve: the mutation raises, the next solve
    raises a CvxContactError, or the next solve is right for the scaled geometry."""
    bodies = _mutation_bodies()
    scene = cc.Scene(*bodies)
    first, caught = run(scene, condition="gamma3", method=method)
    try:
        for b in bodies:
            b.mesh.points *= 1e-3
    except Exception:
        return                                                   # mutation refused: fine
    r = Reference(_fresh(bodies), "gamma3")
    ref = r.solve(np.zeros(len(r.x)))
    try:
        sol, caught = run(scene, condition="gamma3", method=method)
    except cc.CvxContactError:
        return
    if isinstance(sol, Exception):
        return
    eu, ef = errors(sol, ref)
    assert eu <= TOL_U and ef <= TOL_F, "stale geometry after points *= 1e-3: " + describe(sol, ref, caught)


@pytest.mark.parametrize("method", METHODS)
def test_contact_solver_reused_after_editing_a_shared_mesh(method):
    """A ContactSolver prepared on a scene, the foundation's shared mesh stretched in depth, a new
    load case on the same mesh objects: a refusal (the edit or the solve raises) or the right answer."""
    b1, b2 = _mutation_bodies()
    solver = cc.ContactSolver(cc.Scene(b1, b2), "gamma3", method=method)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        solver.solve()
    try:
        b2.mesh.points[:, 1] *= 2.0                       # the foundation is now twice as deep
    except Exception:
        return
    try:
        c1 = cc.Body(b1.mesh, b1.material, clamped=b1.clamped, grounded=b1.grounded, contact=b1.contact,
                     body_force=(3e8, -3e9), traction={"right": (0.0, 4e8)})
        c2 = cc.Body(b2.mesh, b2.material, clamped=b2.clamped, contact=b2.contact)
        scene = cc.Scene(c1, c2)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = solver.solve(scene)
    except cc.CvxContactError:
        return
    ref_bodies = _fresh((c1, c2))
    r = Reference(ref_bodies, "gamma3")
    ref = r.solve(np.zeros(len(r.x)))
    check(sol, ref, caught, f"ContactSolver reuse after a mesh edit, method={method}")
