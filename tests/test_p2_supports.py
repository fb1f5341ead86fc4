"""P2 elements (degree=2) with every support type (issue 11): rollers, prescribed displacements, floating
electrodes, bodies held by the contact only, built by the prolongation u = T_u z + u_D, phi = T_p z + phi_D
on the P2 nodes (vertices and edge midpoints). Cross-checks: a symmetric scene against its half model with
a symmetry roller; a column in uniaxial strain (rollers, a prescribed displacement and a body force: u_y
quadratic) reproduced at every P2 node to rounding by the "everywhere" condition and not by P1; the
piezoelectric column with a floating electrode against its closed form, and a floating electrode against
the driven one at its potential; a layer held by the contact only in exact uniaxial strain, the held
motion's balance check on the P2 nodes, a pulling load refused.
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem.assembly import prolongation
from cvxcontact.geometry.quadratic import P2Nodes

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

PZT = cc.materials.PZT5A
ALU = cc.materials.isotropic(E=70e9, nu=0.3)
H1, H2, DELTA, RHO_G = 0.4, 0.3, 1e-4, 2e8       # layer heights (m), top displacement (m), body force (N/m^3)


def _match(full, half):
    """Index j (len(half),) of each point of ``half`` in ``full`` (the same point to 1e-12 m)."""
    d = np.abs(full[None, :, :] - half[:, None, :]).sum(axis=2)
    assert d.min(axis=1).max() < 1e-12
    return d.argmin(axis=1)


# ---------------------------------------------------------------- the prolongation on the P2 nodes

def test_p2_prolongation_holds_rollers_and_displacements_at_the_midpoints():
    """A roller on the hypotenuse of a triangle and a prescribed displacement on part of a leg: every P2
    node of the slope (vertices and midpoints) keeps one column along the slope, every P2 node of the part
    has u_D = the prescribed value and no column; the other nodes keep two columns and u_D = 0."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5], [0.25, 0.25]])
    tri = np.array([[0, 3, 6], [3, 4, 6], [3, 1, 4], [6, 4, 5], [5, 4, 2], [0, 6, 5]])
    mesh = cc.Mesh(pts, tri, {"bottom": [[0, 3], [3, 1]], "slope": [[1, 4], [4, 2]], "left": [[2, 5]],
                              "corner": [[5, 0]]})
    b = cc.Body(mesh, ALU, displacement={"left": (2e-4, -2e-4)}, roller=["slope"], contact="bottom")
    nodes = P2Nodes(mesh)
    Tu, u_fixed, _, _ = prolongation(b, nodes)
    slope, left = nodes.boundary_nodes(["slope"]), nodes.boundary_nodes(["left"])
    assert len(slope) == 5 and len(left) == 3 and (slope >= nodes.n_vertices).sum() == 2
    n = np.array([1.0, 1.0]) / np.sqrt(2.0)
    ncol = np.diff(Tu.tocsr().indptr).reshape(-1, 2)
    for i in np.setdiff1d(slope, left):           # the corner (0, 1): the displacement (along the slope) holds it
        cols = Tu[2 * i:2 * i + 2].toarray()
        assert np.linalg.matrix_rank(cols) == 1 and np.abs(n @ cols).max() < 1e-15
    assert not ncol[left].any()
    assert np.abs(u_fixed.reshape(-1, 2)[left] - [2e-4, -2e-4]).max() <= 1e-19       # least squares at the corner
    others = np.setdiff1d(np.arange(len(nodes)), np.concatenate([slope, left]))
    assert (ncol[others] == 1).all() and not u_fixed.reshape(-1, 2)[others].any()
    assert np.abs((Tu.T @ Tu - np.eye(Tu.shape[1]))).max() < 1e-15        # orthonormal columns


# ---------------------------------------------------------------- rollers: the half model of a symmetric scene

def _blocks(x0, nx1, nx2, roller=()):
    m1 = cc.rectangle(x=(x0, 1.0), y=(0.0, 0.5), nx=nx1, ny=3)
    m2 = cc.rectangle(x=(x0, 1.0), y=(-0.5, 0.0), nx=nx2, ny=2)
    b1 = cc.Body(m1, PZT, clamped=["top"], grounded=["top"], contact="bottom", body_force=(0.0, -2e9),
                 roller=list(roller))
    b2 = cc.Body(m2, ALU, clamped=["bottom"], contact="top", roller=list(roller))
    return cc.Scene(b1, b2)


@pytest.fixture(scope="module")
def symmetric():
    """The full scene (even nx: the "alternate" meshes are mirror-symmetric about x = 0.5) and its right
    half with a roller on the symmetry line."""
    return _blocks(0.0, 8, 4), _blocks(0.5, 4, 2, roller=["left"])


@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
def test_p2_symmetric_scene_equals_its_half_model_with_a_roller(symmetric, condition):
    full_scene, half_scene = symmetric
    tol = 1e-5 if condition == "gamma3" else 1e-6       # gamma3: complementarity measured 1.8e-7 .. 2.0e-7
    full = cc.solve(full_scene, condition, degree=2, tol=tol)
    half = cc.solve(half_scene, condition, degree=2, tol=tol)
    assert full.ok and half.ok and half.degree == 2
    for k in range(2):
        j = _match(full.points[k], half.points[k])
        assert np.abs(full.u[k][j] - half.u[k]).max() <= 1e-8 * np.abs(full.u[k]).max(), k
        on = np.flatnonzero(np.abs(half.points[k][:, 0] - 0.5) < 1e-12)       # the roller's P2 nodes
        assert (on >= half_scene.bodies[k].mesh.points.shape[0]).any()       # midpoints among them
        assert np.abs(half.u[k][on, 0]).max() <= 1e-14 * np.abs(full.u[k]).max()
        assert np.abs(full.u[k][j[on], 0]).max() <= 1e-8 * np.abs(full.u[k]).max()   # u_x = 0 there by symmetry
    j = _match(full.points[0], half.points[0])
    assert np.abs(full.phi[0][j] - half.phi[0]).max() <= 1e-8 * np.abs(full.phi[0]).max()
    assert half.contact.force.sum() == pytest.approx(0.5 * full.contact.force.sum(), rel=1e-8)


# ---------------------------------------------------------------- prescribed displacement: a quadratic patch test

def _column(n=(4, 3)):
    """A layer on a roller foundation between side rollers, an aluminium plate on it between side rollers,
    its top moved down by DELTA (a prescribed displacement); both under the body force (0, -RHO_G).
    Non-matching meshes on the contact line."""
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=n[0], ny=n[1])
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=n[0] - 1, ny=n[1] - 1)
    b1 = cc.Body(low, ALU, roller=["bottom", "left", "right"], contact="top", body_force=(0.0, -RHO_G))
    b2 = cc.Body(top, ALU, roller=["left", "right"], displacement={"top": (None, -DELTA)}, contact="bottom",
                 body_force=(0.0, -RHO_G))
    return cc.Scene(b1, b2)


C22 = ALU.c[1, 1]
# uniaxial strain: d sigma_yy / dy = RHO_G, sigma_yy = S + RHO_G y in both layers (S at the contact line),
# u_y(-H1) = 0, u_y continuous at y = 0 (closed contact), u_y(H2) = -DELTA
S = (-DELTA + RHO_G * (H1 ** 2 - H2 ** 2) / (2 * C22)) / ((H1 + H2) / C22)


def _exact(y):
    """u_y (m) of the column at height y (m): quadratic in y."""
    return (S * (y + H1) + RHO_G * (y ** 2 - H1 ** 2) / 2) / C22


def _column_error(sol):
    return max(max(np.abs(sol.u[k][:, 1] - _exact(sol.points[k][:, 1])).max(), np.abs(sol.u[k][:, 0]).max())
               for k in (0, 1)) / DELTA


@pytest.fixture(scope="module")
def column():
    return _column()


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_p2_column_with_rollers_and_prescribed_displacement_is_exact(column, method):
    assert S < 0                                                          # compressed: the contact is closed
    # the conic interior point: complementarity measured 8.0e-7 (clarabel 0.10.0, 0.11.1), so tol=1e-5
    sol = cc.solve(column, "gamma3", degree=2, method=method, tol=1e-5)
    assert sol.ok and sol.method == method
    assert _column_error(sol) < 1e-9                                      # at every P2 node; measured 1.9e-11
    top = sol.points[1][:, 1] == H2
    assert np.abs(sol.u[1][top, 1] + DELTA).max() <= 1e-15               # u_D at the top's vertices and midpoints
    assert abs(sol.contact.force.sum() + S * 1.0) <= 1e-8 * abs(S)       # the contact carries sigma_yy(0); 2.6e-12
    assert np.abs(sol.contact.lam / -S - 1).max() < 2e-7                 # measured 3.6e-8


def test_p1_is_not_exact_on_the_column(column):
    p1 = cc.solve(column, "gamma3")
    assert p1.ok and _column_error(p1) > 1e-3               # the same scene: the quadratic u_y is not in P1


# ---------------------------------------------------------------- floating electrodes

def _piezo_column(charge, n=(4, 3)):
    """The column with a PZT-5A lower layer grounded at its bottom and a floating electrode (total charge
    ``charge``, C/m) on its top, no body force; matching meshes on the contact line."""
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=n[0], ny=n[1])
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=n[0], ny=n[1] - 1)
    b1 = cc.Body(low, PZT, roller=["bottom", "left", "right"], contact="top", grounded=["bottom"],
                 floating={"top": charge})
    b2 = cc.Body(top, ALU, roller=["left", "right"], displacement={"top": (None, -DELTA)}, contact="bottom")
    return cc.Scene(b1, b2)


@pytest.mark.parametrize("charge", [0.0, 2e-3])
@pytest.mark.parametrize("condition", ["sigma1", "gamma3"])
def test_p2_floating_electrode_closed_form(charge, condition):
    """Uniaxial strain with D_y = -Q / w: sigma = c33 eps - e33 E_y, E_y = (D_y - e33 eps) / eps33 (for
    Q = 0 the stiffened modulus c33 + e33^2 / eps33), u_y and phi linear: reproduced at every P2 node, the
    floating electrode's potential -E_y H1 and charge Q, the grounded one's -Q."""
    c33, e33, k33 = PZT.c[1, 1], PZT.e[1, 1], PZT.kappa[1, 1]
    D = -charge / 1.0
    eps1, eps2 = np.linalg.solve([[c33 + e33 ** 2 / k33, -C22], [H1, H2]], [e33 * D / k33, -DELTA])
    E = (D - e33 * eps1) / k33
    # the conic condition is interior-point accurate (its complementarity measured 5.4e-7 with the floating
    # electrode's charge, 3.9e-6 without, clarabel 0.10.0 and 0.11.1); the nodal one has the exact finish
    tol = 1e-6 if condition == "sigma1" else 2e-5          # 1e-6: the default
    sol = cc.solve(_piezo_column(charge), condition, degree=2, tol=tol)
    assert sol.ok
    p = sol.points[0]
    assert len(p) > sol.scene.bodies[0].mesh.points.shape[0]
    assert np.abs(sol.u[0][:, 1] - eps1 * (p[:, 1] + H1)).max() <= 1e-9 * DELTA
    assert np.abs(sol.phi[0] - (-E) * (p[:, 1] + H1)).max() <= 1e-9 * abs(E) * H1
    top = [e for e in sol.electrodes if e.tag == "top"][0]
    ground = [e for e in sol.electrodes if e.tag == "bottom"][0]
    assert top.kind == "floating" and top.potential == pytest.approx(-E * H1, rel=1e-9)
    on = sol.points[0][:, 1] == 0.0
    assert np.ptp(sol.phi[0][on]) <= 1e-12 * abs(E) * H1                # one potential, midpoints included
    ref = max(abs(charge), abs(e33 * eps1))
    assert abs(top.charge - charge) <= 1e-9 * ref and abs(ground.charge + charge) <= 1e-9 * ref
    assert abs(sol.contact.force.sum() + C22 * eps2) <= 1e-8 * abs(C22 * eps2)


def test_p2_contact_solver_resolves_a_new_floating_charge():
    """The floating charge is a load: a prepared P2 ContactSolver re-solves the column with another Q (warm
    start) to the same answer as a fresh solve, the new Q on the electrode."""
    solver = cc.ContactSolver(_piezo_column(0.0), "sigma1", degree=2)
    assert solver.solve().ok
    again = solver.solve(_piezo_column(2e-3))
    fresh = cc.solve(_piezo_column(2e-3), "sigma1", degree=2)
    assert again.ok and again.path == cc.Route.WARM_START
    assert np.abs(again.u[0] - fresh.u[0]).max() <= 1e-12 * np.abs(fresh.u[0]).max()
    assert np.abs(again.phi[0] - fresh.phi[0]).max() <= 1e-12 * np.abs(fresh.phi[0]).max()
    top = [e for e in again.electrodes if e.tag == "top"][0]
    assert abs(top.charge - 2e-3) <= 1e-12


def _electrode_blocks(left):
    """Two blocks, the upper one PZT-5A clamped at its top, pressed by its weight, grounded on its right
    side, a surface charge on its top and on its left side the electrode ``left`` (dict: floating= or
    potential=)."""
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=3)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=3, ny=2)
    b1 = cc.Body(m1, PZT, clamped=["top"], grounded=["right"], contact="bottom", body_force=(0.0, -2e9),
                 surface_charge={"top": 0.05}, **left)
    b2 = cc.Body(m2, ALU, clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2)


@pytest.mark.parametrize("charge", [0.0, -3e-3])
def test_p2_floating_electrode_equals_the_driven_one_at_its_potential(charge):
    """A floating electrode (charge Q) in a 2-D field; the potential V it takes, imposed as a driven
    electrode, gives the same fields (u, phi at every P2 node) and a reaction charge equal to Q."""
    floating = cc.solve(_electrode_blocks(dict(floating={"left": charge})), "sigma1", degree=2)
    assert floating.ok
    V = [e for e in floating.electrodes if e.tag == "left"][0].potential
    on = P2Nodes(floating.scene.bodies[0].mesh).boundary_nodes(["left"])
    assert np.ptp(floating.phi[0][on]) <= 1e-12 * abs(V) and abs(V) > 0
    driven = cc.solve(_electrode_blocks(dict(potential={"left": V})), "sigma1", degree=2)
    assert driven.ok
    for k in (0, 1):
        assert np.abs(driven.u[k] - floating.u[k]).max() <= 1e-9 * np.abs(floating.u[k]).max()
    assert np.abs(driven.phi[0] - floating.phi[0]).max() <= 1e-9 * np.abs(floating.phi[0]).max()
    reaction = [e for e in driven.electrodes if e.tag == "left"][0].charge
    scale = max(abs(e.charge) for e in driven.electrodes)
    assert abs(reaction - charge) <= 1e-9 * scale and scale > 1e-3


# ---------------------------------------------------------------- bodies held by the contact only

P = 2e7                                        # pressure on the resting layer (Pa)


def _resting(p, nx=3, load=None):
    """A layer between side rollers, pressed by a pressure p (Pa) on its top (or by the traction ``load``),
    resting on a foundation clamped at its bottom, also between side rollers: only the contact holds the
    layer vertically. ``nx``: the layer's cells along the contact line (the foundation has 4)."""
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=4, ny=3)
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=nx, ny=2)
    b1 = cc.Body(top, ALU, roller=["left", "right"], contact="bottom", traction={"top": load or (0.0, -p)})
    b2 = cc.Body(low, ALU, clamped=["bottom"], roller=["left", "right"], contact="top")
    return cc.Scene(b1, b2)


@pytest.mark.parametrize("condition,nx", [("gamma3", 3), ("sigma1", 4), ("sigma2", 4)])
def test_p2_layer_held_by_contact_only_is_in_exact_uniaxial_strain(condition, nx):
    """sigma_yy = -P in both layers: u_y = -P / c22 (y + H1) at every P2 node of both bodies (the nodal
    conditions on matching meshes, the "everywhere" one on non-matching ones), u_x = 0, contact force P."""
    scene = _resting(P, nx)
    assert scene.bodies[0].held_by_contact == ("translation y",)
    sol = cc.solve(scene, condition, degree=2)
    # sigma1/sigma2: the condensed route (backends/forced.py); gamma3 (the cones): full (HELD_KINDS)
    assert sol.ok and sol.method == ("full" if condition == "gamma3" else "condensed") and sol.polished
    scale = P / C22 * H1
    for k in (0, 1):
        assert len(sol.points[k]) > len(scene.bodies[k].mesh.points)
        assert np.abs(sol.u[k][:, 1] + P / C22 * (sol.points[k][:, 1] + H1)).max() <= 1e-9 * scale
        assert np.abs(sol.u[k][:, 0]).max() <= 1e-9 * scale
    assert abs(sol.contact.force.sum() - P * 1.0) <= 1e-9 * P


def test_p2_held_modes_are_rigid_motions_on_the_p2_nodes():
    """The held motion on the P2 nodes: the rigid translation at every node (midpoints included), in the
    kernel of the P2 stiffness; the balance check built on it passes for the solved answer and exposes a
    spurious rigid displacement (as tests/test_held_by_contact.py does for P1)."""
    from cvxcontact.discrete import Block, Units
    from cvxcontact.fem import p2
    from cvxcontact.solution.checks import rigid_balance

    scene = _resting(P)
    body = scene.bodies[0]
    nodes = P2Nodes(body.mesh)
    modes = body.held_modes(nodes)
    assert modes.shape == (1, 2 * len(nodes))
    assert np.abs(modes.reshape(-1, 2) - modes[0, 1] * np.array([0.0, 1.0])).max() == 0.0 and modes[0, 1] != 0
    system = p2.assemble(body, nodes)
    assert np.abs(system.Kuu @ modes[0]).max() <= 1e-12 * abs(system.Kuu).max()
    solver = cc.ContactSolver(scene, "sigma1", degree=2)
    sol = solver.solve()
    blk = Block.scaled(system, solver.problem.interface.jump(0, len(nodes)), Units(1.0, 1.0, 1.0, 1.0))     # SI
    reduced = (system.Tu.T @ modes.T).T
    z = system.Tu.T @ (sol.u[0].ravel() - system.u_fixed)
    force = np.asarray(sol.contact.force)                     # M lambda_h on the merged P2 nodes, N/m
    assert len(force) == solver.problem.interface.size and abs(force.sum() - P) <= 1e-9 * P
    assert rigid_balance(blk, reduced, z, None, force, prolongation=system.Tu, dim=2) < 1e-10
    drift = system.Tu.T @ np.tile([0.0, 1.0], len(nodes)) * 1e9
    assert rigid_balance(blk, reduced, z + drift, None, 0 * force, prolongation=system.Tu, dim=2) > 0.1


@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
def test_p2_held_layer_under_a_varying_pressure_carries_its_load(condition):
    """A pressure growing along the layer (p(x) = P (0.2 + x)): the contact carries its resultant 0.7 P
    (N/m) whatever the condition; the answer passes its checks, the rigid balance included."""
    scene = _resting(P, load=lambda x, y: (0 * x, -P * (0.2 + x)))
    sol = cc.solve(scene, condition, degree=2)
    assert sol.ok and sol.method == ("full" if condition == "gamma3" else "condensed")      # HELD_KINDS
    assert abs(sol.contact.force.sum() - 0.7 * P) <= 1e-9 * P


def test_p2_load_pulling_a_held_body_off_its_support_is_a_typed_error():
    with pytest.raises(cc.SceneError, match=r"the load pulls body 'body 1' off along translation y"):
        cc.solve(_resting(-P), "gamma3", degree=2)
    with pytest.raises(cc.SceneError, match=r"nothing determines the translation y of body 'body 1'"):
        cc.solve(_resting(0.0), "gamma3", degree=2)
