"""The guaranteed error bound for pairs of deformable bodies (cvxcontact.error_bound; docs/accuracy.md, "Pairs
of deformable bodies").

Checked independently of the code under test: a closed form (two blocks squeezed uniformly, matching and
non-matching meshes on Gamma_3: the exact solution lies in the P1 space, the bound is rounding); the bound
against the true error on nested fine references (the estimate study's prolongation and energy norm); the
two stresses sampled directly along Gamma_3 at points the construction never used (equal and opposite
tractions, normal, compressive); the admissible displacement sampled against a curved gap; the refusals.
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import bound as study
from cvxcontact.solution import bound

pytestmark = pytest.mark.numerics   # equilibrated stresses on divided meshes, sparse saddle-point solves

PAIRS = ["punch, partial overlap (pair), P1", "Hertz cylinder (pair), P1", "stack of three (two pairs), P1",
         "two blocks (piezo pair), P1", "PZT layer, floating electrode, punch (pair), P1"]

# measured effectivity (bound / true error) at levels 0, 1, 2 against a reference at level 3: (smallest, largest)
# (with the lumped pressure p, before p minimised the bound: punch 2.45-3.45, Hertz 1.85-2.78, stack 1.55-1.81,
# two blocks 1.58-2.29, PZT layer 1.40-1.61)
MEASURED = {"punch, partial overlap (pair), P1": (1.25, 1.75), "Hertz cylinder (pair), P1": (1.81, 2.38),
            "stack of three (two pairs), P1": (1.30, 1.41), "two blocks (piezo pair), P1": (1.31, 1.58),
            "PZT layer, floating electrode, punch (pair), P1": (1.27, 1.56)}
# issue 30's claim for 2D P1: effectivity in [1, 3]; the punch (where the lumped pressure read 3.35-3.45) is held
# to it (measured at most 1.75); the others to 3 times their measured largest
CLAIM = {"punch, partial overlap (pair), P1": 3.0}


def squeezed(nx_lower: int, piezo: bool = False):
    """Two blocks 1 m x 0.5 m, rollers on their sides and the lower one's bottom, the upper one's top pushed
    down 0.1 mm: uniaxial strain in each, the same stress sigma_yy, uniform contact pressure. The lower block's
    mesh has ``nx_lower`` columns (4: matching the upper block's; 3: non-matching)."""
    mat = cc.materials.isotropic(E=70e9, nu=0.3)
    upper_mat = cc.materials.PZT5A if piezo else cc.materials.isotropic(E=200e9, nu=0.25)
    electric = dict(grounded=["top"]) if piezo else {}
    upper = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2), upper_mat, roller=["left", "right"],
                    displacement={"top": (None, -1e-4)}, contact="bottom", name="upper", **electric)
    lower = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=nx_lower, ny=2), mat,
                    roller=["left", "right", "bottom"], contact="top", name="lower")
    return cc.Scene(upper, lower)


@pytest.mark.parametrize("nx_lower", [4, 3], ids=["matching", "non-matching"])
@pytest.mark.parametrize("piezo", [False, True], ids=["elastic", "piezo"])
def test_the_bound_of_an_exact_pair_solution_is_rounding(nx_lower, piezo):
    """Two blocks squeezed: u is affine in each block (the P1 answer is exact), the pressure uniform, so the
    bound is 0 up to rounding, on matching and on non-matching meshes (the reconstruction divides the lower
    block's contact cells at the upper block's nodes and vice versa). The piezoelectric upper block (poled along
    y, grounded on top, its bottom uncharged: D_y = 0) stays uniform too (E_x = 0)."""
    sol = cc.solve(squeezed(nx_lower, piezo), estimate="equilibrated", condition="gamma3")
    est = sol.estimate
    assert est.guaranteed and est.kind == "equilibrated" and len(est.indicators) == 2
    # measured: relative 2.0e-8, 1.7e-8 (elastic matching, non-matching), 1.7e-8, 1.7e-8 (piezo): the
    # unsquared complementarity's rounding (|||u_h||| = 37 and 34)
    assert est.relative < 1e-6
    # measured 1.3e-25 .. 3.6e-24 J/m (the pressure found by least squares: rounding of a squared system; with
    # the lumped pressure 6e-28 .. 1.5e-25) against |||u_h|||^2 = 1.1e3 .. 1.4e3
    assert est.parts["stress"] <= 1e-20 * est.norm ** 2
    assert est.parts["electric"] <= 1e-20 * est.norm ** 2          # measured 1.4e-28 J/m
    assert est.parts["correction"] <= 1e-12 * est.norm              # measured 7e-15 .. 1.8e-14 sqrt(J/m)


def test_a_deformed_pair_is_not_rounding():
    """The same squeeze with a body force in the lower block (a non-affine answer): the bound is far from 0, so
    the rounding above is not a bound that always vanishes."""
    scene = squeezed(3)
    lower = scene.bodies[1].with_changes(body_force=(3e9, -1e9))
    sol = cc.solve(scene.with_bodies(scene.bodies[0], lower), estimate="equilibrated", condition="gamma3")
    assert sol.estimate.relative > 1e-3                              # measured 0.33


@pytest.mark.parametrize("name", PAIRS)
def test_the_pair_bound_is_above_the_true_error(name):
    """Levels 0, 1 and 2 against a reference refined three times: the bound exceeds the true error (the
    piezoelectric scenes in the coupled energy norm). |||u - u_h||| >= |||u_ref - I u_h||| for nested spaces (up
    to the contact's complementarity), so effectivity >= 1 with no margin; above, the measured largest times 3.
    The bound falls under refinement."""
    build, options = study.SCENES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        rows = study.effectivity(build, options, levels=(0, 1, 2), reference=3)
    for r in rows:
        assert r["ok"]
        assert r["effectivity"] >= 1.0, r
        assert r["effectivity"] <= CLAIM.get(name, MEASURED[name][1] * 3), r
        assert r["equilibrium"] <= 1e-9                              # measured <= 1.1e-13
    assert rows[2]["bound"] < rows[0]["bound"]


def test_the_pressure_minimises_the_bound(monkeypatch):
    """The punch at level 0: the bound at the pressure the construction chose is no larger than at the solution's
    lumped pressure (the earlier choice) nor at 12 random admissible perturbations of it (p + delta >= 0 on the
    merged nodes, steps of 1 % and 10 % of its largest value), each with its stresses equilibrated anew: a
    sampled check of the joint minimum over (tau, p), independent of the least-squares solver that found it."""
    scene = study.SCENES["punch, partial overlap (pair), P1"][0]()
    sol = cc.solve(scene, condition="gamma3", estimate=False)
    chosen = {}
    find = bound._pressure

    def record(systems, c, lumped, zone):
        chosen.update(p=find(systems, c, lumped, zone), lumped=lumped)
        return chosen["p"]

    monkeypatch.setattr(bound, "_pressure", record)
    best = bound.error_bound(sol).absolute
    p, lumped = chosen["p"], chosen["lumped"]
    assert (p >= 0).all() and p.max() > 0

    def at(q):
        monkeypatch.setattr(bound, "_pressure", lambda *args: q)
        return bound.error_bound(sol).absolute

    assert at(lumped) > 2.0 * best                               # measured 24.23 against 8.751
    rng = np.random.default_rng(30)
    for k in range(12):                                          # steps of 1 % and 10 % of the largest p
        trial = np.maximum(p + (0.1 if k % 2 else 0.01) * p.max() * rng.standard_normal(len(p)), 0.0)
        # measured: 1.1e-4 .. 8.6e-4 relative above (1 % steps), 1.3e-2 .. 0.14 (10 %); rounding 1e-14
        assert at(trial) >= best * (1 - 1e-9)


def _traction(mesh, tau, point, normal):
    """tau n at ``point`` on a boundary edge of ``mesh`` (the reconstruction mesh; tau (3m, 3, 3) per
    sub-triangle (v_s, v_s+1, barycentre)), found from the coordinates alone: the sub-triangle whose edge
    v_s -> v_s+1 (the cell's boundary edge) contains the point."""
    p, tri = mesh.points, mesh.triangles
    a, b = p[tri], p[np.roll(tri, -1, axis=1)]                               # (m, 3, 2) edge s: a -> b
    ab = b - a
    t = np.einsum("msd,msd->ms", point - a, ab) / np.einsum("msd,msd->ms", ab, ab)
    off = np.abs((point - a)[..., 0] * ab[..., 1] - (point - a)[..., 1] * ab[..., 0]) / np.linalg.norm(ab, axis=2)
    hit = np.argwhere((off < 1e-12) & (t > 1e-9) & (t < 1 - 1e-9))
    assert len(hit) == 1, (point, hit)
    c, s = hit[0]
    T = (1 - t[c, s]) * tau[3 * c + s, 0] + t[c, s] * tau[3 * c + s, 1]
    return np.array([T[0] * normal[0] + T[2] * normal[1], T[2] * normal[0] + T[1] * normal[1]])


@pytest.mark.parametrize("name", ["punch, partial overlap (pair), P1", "two blocks (piezo pair), P1"])
def test_the_two_stresses_carry_equal_and_opposite_tractions(name):
    """Non-matching meshes: at points of Gamma_3 strictly inside the overlap (not nodes of either mesh), the
    tractions of the two equilibrated stresses, each read from its own mesh's sub-triangles, are equal and
    opposite, normal to the line and compressive; on the punch, the block's top outside the overlap is free.
    The divergence: div tau + f = 0 on every sub-triangle of both reconstruction meshes."""
    build, _ = study.SCENES[name]
    scene = build()
    sol = cc.solve(scene, condition="gamma3", estimate=False)
    taus = [bound.equilibrated_stress(sol, k)[0] for k in range(2)]
    meshes = [bound.reconstruction_mesh(sol, k)[0] for k in range(2)]
    scale = max(np.abs(t).max() for t in taus)
    itf = scene.interfaces[0]
    n_a = np.asarray(itf.normal)
    xs = np.linspace(itf.x[0], itf.x[-1], 158)[1:-1]       # 157 intervals: no node of either mesh
    points = itf.points[0] + np.outer(xs - itf.x[0], itf.tangent)
    ta = np.array([_traction(meshes[0], taus[0], q, n_a) for q in points])
    tb = np.array([_traction(meshes[1], taus[1], q, -n_a) for q in points])
    assert np.abs(ta + tb).max() <= 1e-9 * scale               # measured 7e-15 (punch), 1.4e-14 (blocks) relative
    normal = ta @ n_a
    assert np.abs(ta @ np.asarray(itf.tangent)).max() <= 1e-9 * scale          # measured 6.5e-15, 5.8e-16
    # measured: normal traction in [-0.43, -3.8e-4] (punch), [-0.33, 2.8e-15] (blocks) of the stress scale
    assert (normal <= 1e-9 * scale).all() and normal.min() < -1e-3 * scale
    for k, body in enumerate(scene.bodies):
        f = np.asarray(body.body_force.value, dtype=float)
        mesh, tau = meshes[k], taus[k]
        verts = mesh.points[mesh.triangles]
        bc = verts.mean(axis=1)
        allv = np.concatenate([np.stack([verts[:, s], verts[:, (s + 1) % 3], bc], axis=1) for s in range(3)])
        order = np.arange(len(allv)).reshape(3, -1).T.ravel()          # sub-triangle 3 c + s
        v = allv[order]
        d = np.roll(v, -1, axis=1) - np.roll(v, 1, axis=1)
        area2 = d[:, 0, 0] * d[:, 1, 1] - d[:, 0, 1] * d[:, 1, 0]
        gL = np.stack([d[:, :, 1], -d[:, :, 0]], axis=2) / area2[:, None, None]
        div = np.column_stack([(tau[:, :, 0] * gL[:, :, 0] + tau[:, :, 2] * gL[:, :, 1]).sum(axis=1),
                               (tau[:, :, 2] * gL[:, :, 0] + tau[:, :, 1] * gL[:, :, 1]).sum(axis=1)])
        assert np.abs(div + f).max() <= 1e-9 * scale                  # measured 1e-14 relative
    if name.startswith("punch"):                                       # the block's top left of the punch: free
        block = meshes[1]
        free = np.array([[x, 0.5] for x in np.linspace(0.03, 0.57, 10)])
        tf = np.array([_traction(block, taus[1], q, np.array([0.0, 1.0])) for q in free])
        assert np.abs(tf).max() <= 1e-9 * scale


def test_the_admissible_displacement_keeps_the_curved_gap_between_nodes():
    """Hertz (a parabolic gap between non-matching meshes): u_h penetrates between the merged nodes (the rows
    hold at the nodes only); v = u_h - w does not, sampled at 4001 points of Gamma_3: [v . nu] <= g."""
    scene = study.SCENES["Hertz cylinder (pair), P1"][0]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        sol = cc.solve(scene, condition="gamma3", estimate=False)
    itf = scene.interfaces[0]
    s = np.linspace(itf.x[0], itf.x[-1], 4001)
    g = scene.pair_gap_values(0, s)

    def jump(fields):
        total = np.zeros_like(s)
        for k, trace in enumerate(itf.traces):
            un = fields[k][trace.nodes] @ trace.unit_normal
            total += np.interp(s, trace.x, un)
        return total

    u_h = [np.asarray(u) for u in sol.u]
    v = [bound.equilibrated_stress(sol, k)[1][: len(u)] for k, u in enumerate(u_h)]   # original nodes first
    scale = np.abs(jump(u_h)).max()
    assert (jump(u_h) - g).max() > 1e-6 * scale                       # u_h penetrates: measured 3.7e-2 relative
    assert (jump(v) - g).max() <= 1e-12 * scale                       # measured -3.3e-6 relative


def test_pairs_outside_the_bound_are_refused_by_name():
    scene = study.SCENES["punch, partial overlap (pair), P1"][0]()
    with pytest.raises(cc.UnsupportedError, match="under condition 'sigma2'.*condition='gamma3'"):
        cc.solve(scene, estimate="equilibrated", condition="sigma2")
    with pytest.raises(cc.UnsupportedError, match="friction"):
        cc.solve(scene, estimate="equilibrated", condition="gamma3", law=cc.Tresca(1e6))
    with pytest.raises(cc.UnsupportedError, match="P2"):
        cc.solve(scene, estimate="equilibrated", condition="gamma3", degree=2)


def test_a_body_index_outside_the_scene_is_refused_by_name():
    """-1, 2, 1.0 and True are not indices of a pair's two bodies (-1 gave the last body, 2 an IndexError)."""
    sol = cc.solve(squeezed(3), condition="gamma3", estimate=False)
    for wrong in (-1, 2, 1.0, True):
        for call in (bound.equilibrated_stress, bound.reconstruction_mesh, bound.equilibrated_displacement):
            with pytest.raises(cc.SceneError, match="integer 0 to 1"):
                call(sol, wrong)
    assert len(bound.reconstruction_mesh(sol, 1)[1]) >= len(sol.scene.bodies[1].mesh.triangles)


def test_a_body_held_by_its_contacts_alone_keeps_its_bound():
    """A body on rollers pressed onto its support by its loads carries only a pressure that balances them; the
    minimising p (priced on the conditions' range) missed that balance and the bound raised SolverError (found
    by review). Alone on a plane the P1 answer is exact (a uniform traction): the bound is rounding (measured
    6.9e-16 relative); as the upper block of a pair it is a finite bound."""
    m = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4)
    block = cc.Body(m, cc.materials.isotropic(E=70e9, nu=0.3), roller=["left", "right"],
                    traction={"top": (0.0, -1e7)}, contact="bottom", name="block")
    plane = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    sol = cc.solve(cc.Scene(block, contacts=[cc.Contact(block, "bottom", plane)]), estimate="equilibrated")
    assert sol.ok and sol.estimate.guaranteed
    assert sol.estimate.relative <= 1e-12                      # measured 6.9e-16 (1.6e-14 against 23)
    upper = cc.Body(cc.rectangle(x=(0.3, 0.7), y=(0.0, 0.5), nx=4, ny=3), cc.materials.isotropic(E=200e9, nu=0.25),
                    roller=["left", "right"], traction={"top": (0.0, -1e7)}, body_force=(0.0, -5e7),
                    contact="bottom", name="upper")
    lower = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=5, ny=3), cc.materials.isotropic(E=70e9, nu=0.3),
                    roller=["left", "right", "bottom"], contact="top", name="lower")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        pair = cc.solve(cc.Scene(upper, lower), "gamma3", estimate="equilibrated")
    assert pair.ok and pair.estimate.guaranteed and np.isfinite(pair.estimate.absolute)
    assert pair.estimate.parts["equilibrium residual"] <= 1e-12        # measured 6.4e-15
