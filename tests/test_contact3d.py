"""3D contact through the public API (cc.solve, cc.ContactSolver, cc.Model on tetrahedral scenes): exact patch
tests against closed forms, every condition against an independent dense solve of the mixed system (26)
(tests/reference3d.py), the jump sampled densely on the contact faces, invariance under a generic rotation,
the plane-strain limit of an extruded scene, force control, several pairs and a punch on a patch.

The scenes are those of tests/scenes3d.py. Under "gamma3" on non-matching faces the overlay rows outnumber
the jump's dofs (dependent rows); their exact finish keeps the rows carrying the forces independent
(tests/test_finish3d.py).
"""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.backends import full
from cvxcontact.errors import SceneError

from reference3d import Dense, barycentric, face, match, plane_frame
from scenes3d import (P, PAD, bumped_blocks, bumped_gap, extruded_pair, floating_potential, layer_on_plane,
                      piezo_pair, punch_on_pad, pzt_layer_on_plane, rotation, section_pair, sphere_on_block,
                      SCENES3D, stacked_blocks, stiffened_modulus, three_blocks, tilted_gap, uniaxial_modulus)

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def solve(scene, condition):
    """cc.solve, asserting that an answer whose checks fail is flagged by a ResidualWarning (and that a
    passing one is not)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = cc.solve(scene, condition)
    warned = any(issubclass(w.category, cc.ResidualWarning) for w in caught)
    assert warned != sol.ok
    return sol


def shared(once, make, condition):
    """:func:`solve` of the scene ``make()`` under ``condition``, solved once per module (conftest's ``once``: the
    canonical scenes are read by several tests here; the warnings raised again at each call)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = once((make, condition), lambda: cc.solve(make(), condition))
    warned = any(issubclass(w.category, cc.ResidualWarning) for w in caught)
    assert warned != sol.ok
    return sol


def rel(a, b) -> float:
    """max |a - b| / max |b| over lists of arrays."""
    return max(float(np.abs(x - y).max()) for x, y in zip(a, b)) / max(float(np.abs(y).max()) for y in b)


def uniaxial_error(sol, modulus=None) -> float:
    """Largest |u_z + p z / c33| over every body's nodes, relative to p / c33 (the top's sag per metre), and
    the largest in-plane displacement, also relative."""
    c = uniaxial_modulus() if modulus is None else modulus
    uz = max(float(np.abs(u[:, 2] + P * x[:, 2] / c).max()) for u, x in zip(sol.u, sol.points))
    uxy = max(float(np.abs(u[:, :2]).max()) for u in sol.u)
    return max(uz, uxy) / (P / c)


# ---------------------------------------------------------------------------------------------------------
# exact patch tests (P1, rounding)

@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
def test_layer_on_a_rigid_plane_is_in_uniaxial_strain(condition, once):
    """Rollers on four sides, uniform pressure on top, a rigid plane below: u_z = -p z / c33, u_x = u_y = 0,
    the plane's reaction = p A, the pressure felt = p at every node."""
    sol = shared(once, layer_on_plane, condition)
    assert sol.ok and sol.polished
    assert uniaxial_error(sol) < 1e-13                                          # measured 4.8e-16
    reaction = sol.obstacles[0].force
    assert reaction.shape == (3,) and sol.obstacles[0].translation.shape == (3,)
    np.testing.assert_allclose(reaction, [0, 0, P * 1.0], rtol=0, atol=1e-12 * P)   # measured 0
    assert sol.contact.points.shape == (16, 3) and np.abs(sol.contact.points[:, 2]).max() == 0
    x, p = sol.traction(0)
    assert x.shape == (16, 2) and np.abs(p / P - 1).max() < 1e-13            # measured 6.7e-16


def test_pzt_layer_with_an_open_circuit_electrode_is_stiffened():
    """PZT-5A poled along z, grounded base on the rigid plane, zero-charge floating top electrode: D_z = 0,
    so the layer's uniaxial modulus is c33 + e33^2/eps33 and the electrode floats at e33 S3 H / eps33."""
    sol = cc.solve(pzt_layer_on_plane(), "gamma3")
    assert sol.ok and sol.polished
    pzt = cc.materials.PZT5A
    cD = stiffened_modulus(pzt)
    assert uniaxial_error(sol, cD) < 1e-13                                      # measured 3.7e-16
    assert uniaxial_error(sol, pzt.c3[2, 2]) > 0.1                              # c33 alone: measured 0.117 off
    top = next(e for e in sol.electrodes if e.kind == "floating")
    V = floating_potential(pzt)
    assert abs(top.potential / V - 1) < 1e-13                                   # measured 5e-16 (V = -7415 V)
    z = sol.points[0][:, 2]
    assert np.abs(sol.phi[0] - V * z / 0.5).max() < 1e-13 * abs(V)             # linear in z; measured 4.9e-16
    assert abs(top.charge) < 1e-12 * abs(V) * pzt.kappa3[2, 2]                  # open circuit; measured 2e-20 C


def test_stacked_blocks_on_non_matching_faces_transmit_a_uniform_pressure_under_gamma3(once):
    """5x5 on 7x3 cells, gamma3: the uniaxial solution and lambda_h = p on the whole overlay (the overlay
    condition passes the patch test; docs/formulation.md §13). Interior-point answer: margins measured."""
    sol = shared(once, stacked_blocks, "gamma3")
    c = sol.contact
    assert c.constrained.all() and len(c.x) == 193
    assert uniaxial_error(sol) < 1e-8                                           # measured 3.4e-10
    assert np.abs(c.lam / P - 1).max() < 1e-5                                   # measured 1.2e-7
    assert abs(c.force.sum() / P - 1) < 1e-8                                    # measured 8.4e-10 (A = 1 m^2)
    assert abs(c.measure.sum() - 1.0) < 1e-14                                   # the overlay's area
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] / P - 1).max() < 1e-7                  # measured 2.2e-9


def test_stacked_blocks_on_non_matching_faces_get_an_exact_finish(once):
    assert shared(once, stacked_blocks, "gamma3").ok


@pytest.mark.parametrize("counts, condition", [(((2, 2), (4, 4)), "sigma2"), (((4, 4), (2, 2)), "sigma1")],
                         ids=["fine upper", "fine lower"])
def test_nodal_conditions_on_nested_faces_with_the_finer_sides_nodes_are_exact(counts, condition):
    sol = cc.solve(stacked_blocks(*counts), condition)
    assert sol.ok and sol.polished
    assert uniaxial_error(sol) < 1e-13                                          # measured 1.9e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-13                        # measured 9.8e-15
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] / P - 1).max() < 1e-13                 # measured 3.0e-15


@pytest.mark.parametrize("counts, condition, low", [(((2, 2), (4, 4)), "sigma1", 0.5), ((), "sigma1", 0.05),
                                                    ((), "sigma2", 0.05)],
                         ids=["nested, coarse nodes", "5x5 on 7x3, sigma1", "5x5 on 7x3, sigma2"])
def test_nodal_conditions_fail_the_patch_test_on_general_faces(counts, condition, low):
    """Node-to-face conditions do not transmit a uniform pressure exactly (docs/formulation.md §13): u_z off
    by 12-14 % of the sag on 5x5-on-7x3 faces, 78 % with the coarser side's nodes on nested faces. (Each is
    the exact discrete solution: tests below check it against a dense solve.)"""
    sol = cc.solve(stacked_blocks(*counts), condition)
    assert sol.ok and sol.polished
    assert uniaxial_error(sol) > low          # measured 0.78 (nested, coarse nodes), 0.117 (sigma1), 0.137 (sigma2)
    assert abs(sol.contact.force.sum() / P - 1) < 1e-13                         # the resultant still balances


# ---------------------------------------------------------------------------------------------------------
# every condition against an independent dense solve of (26) on the returned active set

PLANE = {0: ("plane", (0, 0, 0), (0, 0, 1))}
DENSE = {
    "layer on a plane, gamma3": (layer_on_plane, "gamma3", dict(obstacles=PLANE), True),
    "layer on a plane, sigma1": (layer_on_plane, "sigma1", dict(obstacles=PLANE), True),
    "PZT layer, floating electrode": (pzt_layer_on_plane, "gamma3", dict(obstacles=PLANE), True),
    "stacked 5x5 on 7x3, gamma3": (stacked_blocks, "gamma3", {}, True),
    "stacked 5x5 on 7x3, sigma1": (stacked_blocks, "sigma1", {}, True),
    "stacked 5x5 on 7x3, sigma2": (stacked_blocks, "sigma2", {}, True),
    "bumped, gamma3": (bumped_blocks, "gamma3", dict(gaps={0: lambda x: bumped_gap(x[:, 0], x[:, 1])}), True),
    "bumped, sigma1": (bumped_blocks, "sigma1", dict(gaps={0: lambda x: bumped_gap(x[:, 0], x[:, 1])}), True),
    "bumped, sigma2": (bumped_blocks, "sigma2", dict(gaps={0: lambda x: bumped_gap(x[:, 0], x[:, 1])}), True),
    "force-controlled sphere": (sphere_on_block, "gamma3", dict(obstacles={0: ("sphere", (0, 0, 1.0), 1.0)}), True),
    "three blocks, gamma3": (three_blocks, "gamma3", {}, True),
    "three blocks, sigma2 and sigma1": (lambda: three_blocks(conditions=("sigma2", "sigma1")), "gamma3", {}, True),
    "punch on a patch": (punch_on_pad, "gamma3", {}, True),
    "two PZT blocks, sigma1": (piezo_pair, "sigma1", {}, True),
    "two PZT blocks, gamma3": (piezo_pair, "gamma3", {}, True),
}


@pytest.mark.parametrize("name", list(DENSE))
def test_every_condition_against_a_dense_solve_of_the_mixed_system(name, once):
    """The reference rebuilds the contact rows by brute force (tests/reference3d.py), checks that they sit at
    the package's constrained points, solves (26) densely with the package's active rows as equalities and
    certifies it (every row feasible, non-negative forces on the active rows). Displacements, potentials and
    translations then agree: to rounding for an exact finish, to the interior point's accuracy otherwise."""
    make, condition, shapes, finished = DENSE[name]
    scene = make()
    sol = shared(once, make, condition)                  # the answer of an equal scene (made by the same builder)
    ref = Dense(scene, condition, **shapes)
    active = []
    for i, c in enumerate(sol.contacts):
        on = np.flatnonzero(c.constrained)
        j = match(ref.points(i), c.points[on], 1e-9)                           # the same rows, one to one
        active.append(c.active[on][j])
    active = np.concatenate(active)
    ans = ref.solve_on(active)
    penetration, unbalanced, _ = ref.certify(ans, active)
    assert penetration < 1e-12 and unbalanced < 1e-12                           # measured <= 1.6e-15, 4.2e-15
    assert sol.polished or not finished
    bound = 1e-12 if sol.polished else 1e-6       # measured <= 2.4e-14 finished; 3.4e-10 to 1.4e-8 otherwise
    assert rel(sol.u, ans.u) < bound
    phis = [(a, b) for a, b in zip(sol.phi, ans.phi) if b is not None]
    if phis:
        assert rel(*zip(*phis)) < bound                                         # measured <= 1.1e-15 / 2e-8
    if len(ans.t):
        taus = np.concatenate([o.translation for o in sol.obstacles if o.prescribed is not None])
        assert np.abs(taus - ans.t).max() < bound * np.abs(ans.t).max()         # measured 1e-16 relative


# ---------------------------------------------------------------------------------------------------------
# the jump sampled densely on the contact faces

def sampled_excess(sol, scene, gap, k=12):
    """[u_nu] - g at the points of a barycentric grid (k per edge) of every face triangle of the first
    body's part that lie in the second's faces, [u_nu] interpolated in each body's own face triangle (brute
    force), g = gap(s1, s2); (excess, number of points)."""
    pair = scene.contacts[0]
    fa, fb = face(scene, 0, pair.part_a), face(scene, 1, pair.part_b)
    T = plane_frame(fa.normal)
    Xa, Xb = fa.points @ T.T, fb.points @ T.T
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1))
    keep = i + j <= k
    L = np.column_stack([i[keep], j[keep]]) / k
    s = np.einsum("qv,tvd->tqd", np.column_stack([1 - L.sum(axis=1), L]), Xa[fa.tri]).reshape(-1, 2)
    Pb = barycentric(s, Xb, fb.tri)
    inside = Pb.sum(axis=1) > 0.5
    s, Pb = s[inside], Pb[inside]
    jump = barycentric(s, Xa, fa.tri) @ (sol.u[0][fa.nodes] @ fa.normal) + Pb @ (sol.u[1][fb.nodes] @ fb.normal)
    return jump - gap(s[:, 0], s[:, 1]), len(s)


@pytest.mark.parametrize("counts", [(), ((5, 3), (4, 4))], ids=["4x4 on 5x3", "5x3 on 4x4"])
def test_the_sampled_jump_never_exceeds_an_affine_gap_under_gamma3_but_does_between_nodes_under_sigma(counts):
    """With an affine gap (its interpolant on the overlay is itself) the jump, affine on each overlay cell,
    stays below the gap everywhere under gamma3; under the nodal conditions it exceeds it between nodes."""
    scene = bumped_blocks(*counts, gap=tilted_gap)
    excess, n = sampled_excess(solve(scene, "gamma3"), scene, tilted_gap)
    sol = cc.solve(scene, "sigma1")
    scale = max(float(np.abs(u).max()) for u in sol.u)                        # 1.8e-4 m
    assert n > 2500
    assert excess.max() < 1e-12 * scale                                         # measured -1.1e-13 / -2.4e-13
    nodal, _ = sampled_excess(sol, scene, tilted_gap)
    assert nodal.max() > 0.03 * scale                                           # measured 0.081 / 0.067
    assert sol.contact.penetration[sol.contact.constrained].sum() == 0         # at its own nodes it holds


def test_between_vertices_gamma3_holds_against_the_gaps_interpolant_only():
    """The rows take g at the overlay vertices: a convex gap a r^2 may be exceeded between them, by at most
    its interpolation error a sum_i lambda_i |x - v_i|^2 <= a diam^2 (diam: the longest face-triangle edge)."""
    scene = bumped_blocks()
    sol = solve(scene, "gamma3")
    excess, _ = sampled_excess(sol, scene, bumped_gap)
    a, diam = 2e-4, np.hypot(1 / 4, 1 / 4)
    assert 0 < excess.max() < a * diam ** 2                                     # measured 3.2e-6 < 2.5e-5 m
    assert (sol.contact.jump - sol.contact.gap).max() < 1e-12 * np.abs(sol.u[1]).max()   # at the vertices


# ---------------------------------------------------------------------------------------------------------
# invariances

def test_a_piezoelectric_pair_turned_by_a_generic_rotation_gives_the_turned_solution(once):
    """Points, materials (material.rotated(R)), tractions and planar supports turned by R (about no axis):
    u' = R u and the same potentials, to rounding (exact finish under sigma1)."""
    R = rotation()
    assert np.abs(np.diag(R)).max() < 0.9                                       # no coordinate axis kept; 0.83
    a, b = shared(once, piezo_pair, "sigma1"), cc.solve(piezo_pair(R), "sigma1")
    assert a.ok and b.ok and a.polished and b.polished
    assert rel(b.u, [u @ R.T for u in a.u]) < 1e-9                              # measured 2.1e-15
    assert rel(b.phi, a.phi) < 1e-9                                             # measured 2.3e-15
    assert np.abs(b.contact.normal - R @ a.contact.normal).max() < 1e-12


def test_the_turned_pair_under_gamma3_agrees_to_rounding(once):
    R = rotation()
    a, b = shared(once, piezo_pair, "gamma3"), solve(piezo_pair(R), "gamma3")
    assert a.ok and b.ok and rel(b.u, [u @ R.T for u in a.u]) < 1e-12         # measured 1.6e-15


def test_an_extruded_scene_with_rollers_on_front_and_back_converges_to_plane_strain():
    """A section (x, z) extruded along y with u_y = 0 on its front and back faces (ny = 1) against the 2D
    plane-strain scene of the same section (2D y = 3D z, docs/materials.md), both through cc.solve: the
    nodal displacements and potentials agree better on the finer mesh. Measured (max over both bodies,
    relative): u 0.028 at n = 8, 0.015 at n = 16; phi 0.025, 0.0079."""
    diffs = []
    for n in (8, 16):
        s2, s3 = cc.solve(section_pair(n), "gamma3"), cc.solve(extruded_pair(n), "gamma3")
        assert s2.ok and s3.ok
        du, dphi = 0.0, 0.0
        for k in range(2):
            p2, p3 = s2.points[k], s3.points[k]
            key = {(round(x, 12), round(y, 12)): i for i, (x, y) in enumerate(p2)}
            j = np.array([key[round(x, 12), round(z, 12)] for x, _, z in p3])
            assert np.abs(s3.u[k][:, 1]).max() == 0                             # plane strain
            du = max(du, np.abs(s3.u[k][:, [0, 2]] - s2.u[k][j]).max() / np.abs(s2.u[k]).max())
            dphi = max(dphi, np.abs(s3.phi[k] - s2.phi[k][j]).max() / np.abs(s2.phi[k]).max())
        diffs.append((du, dphi))
    (u8, p8), (u16, p16) = diffs
    assert u8 < 0.05 and p8 < 0.05                                              # measured 0.028, 0.025
    assert u16 < 0.7 * u8 and p16 < 0.5 * p8                                     # measured ratios 0.54, 0.32


# ---------------------------------------------------------------------------------------------------------
# force control, re-solves, cc.Model

def test_a_force_controlled_sphere_balances_its_force_and_its_translation_is_determined():
    F = 2e9
    sol = cc.solve(sphere_on_block(F), "gamma3")
    assert sol.ok and sol.polished
    o = sol.obstacles[0]
    np.testing.assert_allclose(o.force, [0, 0, -F], rtol=0, atol=1e-12 * F)     # measured 3e-8 N
    assert sol.residuals()["obstacle balance"] < 1e-12                         # measured 1.2e-16
    assert np.abs(o.translation[:2]).max() < 1e-12 * abs(o.translation[2])      # symmetric: no lateral drift
    assert o.translation[2] < 0 and sol.contact.active.sum() >= 5              # measured 9 nodes, -0.051 m
    resolver = cc.ContactSolver(sphere_on_block(F), "gamma3")
    resolver.solve()
    again = resolver.solve(sphere_on_block(1.5 * F))
    assert again.ok and again.obstacles[0].translation[2] < o.translation[2]
    np.testing.assert_allclose(again.obstacles[0].force, [0, 0, -1.5 * F], rtol=0, atol=1e-12 * F)


def test_a_tangential_force_on_a_rigid_plane_is_refused_naming_the_direction():
    mesh = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=2, ny=2, nz=1)
    body = cc.Body(mesh, cc.materials.isotropic(E=70e9, nu=0.3), roller=["left", "right", "front", "back"],
                   contact="bottom", traction={"top": (0, 0, -P)})
    plane = cc.Rigid.plane((0, 0, 0), (0, 0, 1), force=(0, 2e5, 1e6))
    with pytest.raises(SceneError, match=r"component 200000 N along \(0, 1, 0\).*free to slide along \(0, 1, 0\)"):
        cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", plane)]), "gamma3")


def test_model_and_contact_solver_agree_with_solve_in_3d():
    scene = stacked_blocks((2, 2), (4, 4))
    direct = cc.solve(scene, "sigma2")
    model = cc.Model(scene, "sigma2").solve()
    assert model.ok and rel(model.u, direct.u) < 1e-12                         # measured 0
    solver = cc.ContactSolver(scene, "sigma2")
    solver.solve()
    double = solver.solve(stacked_blocks((2, 2), (4, 4), p=2 * P))
    assert double.ok and rel(double.u, [2 * u for u in direct.u]) < 1e-12      # linear in the load; measured 0


# ---------------------------------------------------------------------------------------------------------
# several pairs, a punch on a patch

def test_a_stack_of_three_blocks_transmits_the_pressure_through_both_pairs(once):
    sol = shared(once, three_blocks, "gamma3")
    assert len(sol.contacts) == 2
    assert uniaxial_error(sol) < 1e-8                                           # measured 1.3e-11
    for c in sol.contacts:
        assert np.abs(c.lam / P - 1).max() < 1e-6                               # measured 2.2e-9
        assert abs(c.force.sum() / P - 1) < 1e-8                                # measured 4.1e-11


def test_a_punch_on_a_named_patch_overlapping_it_in_part():
    """The punch's face (0.5, 1.1) x (0.4, 0.9) meets the patch (0.25, 0.75)^2 on (0.5, 0.75) x (0.4, 0.75):
    the overlay covers exactly that rectangle and the contact carries the punch's load."""
    sol = cc.solve(punch_on_pad(load=5e7), "gamma3")
    assert sol.ok and sol.polished
    c = sol.contact
    assert PAD[0] == "top"
    assert abs(c.measure.sum() - 0.25 * 0.35) < 1e-15                           # measured 0
    lo, hi = c.points.min(axis=0), c.points.max(axis=0)
    np.testing.assert_allclose([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]], [.5, .75, .4, .75, .5, .5], atol=1e-15)
    assert abs(c.force.sum() / (5e7 * 0.6 * 0.5) - 1) < 1e-12                   # the punch's load; measured 0
    assert 0 < c.active.sum() < len(c.x)                                        # a contact zone inside the overlap


# ---------------------------------------------------------------------------------------------------------
# the guard that keeps SuperLU away from dependent rows

def test_solve_mixed_declines_a_structurally_singular_kkt_without_factorising(monkeypatch):
    """More active rows than the unknowns they touch (as the rows of a 3D overlay): None before SuperLU,
    whose panel updates call BLAS with illegal sizes on such matrices."""
    A = sp.identity(3, format="csr")
    G = sp.csr_matrix(np.array([[1.0, 0, 0], [0.5, 0, 0], [0.2, 0, 0]]))       # 3 rows on one unknown
    K = sp.bmat([[A, G.T], [G, None]], format="csc")
    monkeypatch.setattr(full.spla, "splu", lambda *a, **k: pytest.fail("factorised a singular matrix"))
    assert full.solve_mixed(K, np.ones(6)) is None


@pytest.mark.parametrize("name", list(SCENES3D))
def test_model_agrees_with_solve_on_the_canonical_3d_scenes(name, once):
    """cc.Model (the open CVXPY program, no user terms) answers as cc.solve on every scene of
    tests/scenes3d.py, and flags the same way."""
    make, keywords = SCENES3D[name]
    direct = shared(once, make, keywords["condition"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        model = cc.Model(make(), keywords["condition"]).solve()
    assert model.ok == direct.ok and model.polished == direct.polished
    assert rel(model.u, direct.u) < (1e-12 if direct.polished else 1e-7)       # measured 0 (the same route)


# ---------------------------------------------------------------------------------------------------------
# electrodes: the charge read back in 3D (C, not C/m)

def _pzt_layer_with(**electrodes):
    """The PZT-5A layer of pzt_layer_on_plane (1 x 1 x 0.5 m, rollers on its sides, pressure P on top, the
    rigid plane below, grounded base) with the top electrode given by ``electrodes``."""
    mesh = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=2, ny=3, nz=2)
    body = cc.Body(mesh, cc.materials.PZT5A, roller=["left", "right", "front", "back"], contact="bottom",
                   grounded=["bottom"], traction={"top": (0, 0, -P)}, **electrodes)
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])


def test_driven_and_floating_electrodes_read_their_charge_back_in_coulombs():
    """Uniaxial strain along the poling axis z, a uniform field: sigma_zz = c33 S3 - e33 E3 = -P and
    D3 = e33 S3 + eps33 E3. Driven top at V (E3 = -V/H): the top electrode holds Q = -D3 A and the grounded
    base +D3 A (the charge is -D.nu over the electrode, A = 1 m^2). Floating top with charge Q: D3 = -Q/A
    fixes E3 = (-Q/A + e33 P/c33) / (eps33 + e33^2/c33) and the potential -E3 H."""
    pzt, H, A = cc.materials.PZT5A, 0.5, 1.0
    c33, e33, k33 = pzt.c3[2, 2], pzt.e3[2, 2], pzt.kappa3[2, 2]
    V = 100.0
    sol = cc.solve(_pzt_layer_with(potential={"top": V}), "gamma3")
    assert sol.ok and sol.polished
    E3 = -V / H
    D3 = e33 * (-P + e33 * E3) / c33 + k33 * E3
    kinds = {e.kind: e for e in sol.electrodes}
    assert kinds["driven"].potential == V
    assert abs(kinds["driven"].charge / (-D3 * A) - 1) < 1e-12                  # measured 3.3e-16 (Q = 1.4e-4 C)
    assert abs(kinds["grounded"].charge / (D3 * A) - 1) < 1e-12                 # measured 2.2e-16
    Q = 3e-3                                                                     # C
    sol = cc.solve(_pzt_layer_with(floating={"top": Q}), "gamma3")
    assert sol.ok and sol.polished
    E3 = (-Q / A + e33 * P / c33) / (k33 + e33 ** 2 / c33)
    kinds = {e.kind: e for e in sol.electrodes}
    assert abs(kinds["floating"].charge / Q - 1) < 1e-12                        # measured 2.2e-16
    assert abs(kinds["grounded"].charge / -Q - 1) < 1e-12                       # Gauss: the charges sum to 0
    assert abs(kinds["floating"].potential / (-E3 * H) - 1) < 1e-12             # measured 4.4e-16 (1.5e5 V)
    z = sol.points[0][:, 2]
    assert np.abs(sol.phi[0] + E3 * z).max() < 1e-12 * abs(E3 * H)             # linear in z; measured 4.9e-16
