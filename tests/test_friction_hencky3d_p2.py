"""A friction law beside a Hencky body under the 3D P2 cones ("gamma3" with degree=2 on tetrahedra; docs/refusals.md
row 36): the full program of the cones with the friction energy (the bulk cones' Clarabel settings), finished on the
nodes of X_h and at cut points (cvxcontact/backends/friction.py ``finish_on_nodes``), every round's friction finish
by damped sequential quadratic steps on the Hencky tangent (cvxcontact/backends/frictionsteps.py), each round accepted only by the exact
Bernstein maximum of every triangle's slack. Checked against the linear material's answer where the Hencky body never
yields, a yielded uniform layer's closed form with the Hencky stress computed here by hand, and the slack sampled on
every overlay triangle from the body's own P2 face functions. Tolerances: >= 100x the measured values (beside
them)."""

import warnings

import numpy as np
import pytest
from friction_scenes import (
    DIAGONAL3,
    FLOOR3D,
    NEVER_YIELDING,
    STUCK_LAWS,
    P,
    layer_key,
    never_yielding_key,
    positive_forces,
    sliding_layer3d,
    uniform_layer3d,
)
from friction_scenes import E as E3

import cvxcontact as cc
from cvxcontact.apps.studies.convergence_hencky import plastic_zone
from cvxcontact.backends.finish import Declined, Stop

pytestmark = [pytest.mark.numerics,       # the sphere's contact zone is spanned by 3 faces (a coarse mesh)
              pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]

P2 = {"condition": "gamma3", "degree": 2}
NEVER = NEVER_YIELDING                                               # no strain reaches its yield stress
E, NU, SIGMA_Y, H = 200e9, 0.3, 200e6, 0.1


def rel(a, b) -> float:
    return float(np.abs(np.asarray(a) - b).max() / np.abs(b).max())


def with_material(scene, material):
    """``scene`` (one body on the plane z = 0) with its body of ``material``, the same law on the same part."""
    body, law = scene.bodies[0].with_changes(material=material), scene.contacts[0].law
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=law)])


def solve_strict(scene):
    """``cc.solve(scene, "gamma3", degree=2)`` with a ResidualWarning (a declined finish) an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        return cc.solve(scene, **P2)


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_a_stuck_layer_that_never_yields_is_the_linear_answer(law, shared):
    """The uniform sheared layer (tests/friction_scenes.py, stuck) of a Hencky body whose yield stress no strain
    reaches: the linear material's answer under the same cones and law (measured 1.1e-15 Tresca, 1.0e-15 Coulomb)
    and the linear closed form, finished on the nodes."""
    tau = 0.2 * P
    scene = uniform_layer3d(tau, STUCK_LAWS[law](tau))
    with warnings.catch_warnings():                 # Tresca's linear answer: LAYERS3D["stuck"], solved once a run
        warnings.simplefilter("error", cc.ResidualWarning)
        linear = shared(*layer_key("stuck")) if law == "tresca" else cc.solve(scene, **P2)
    sol = shared(*never_yielding_key(law))          # solve_strict(with_material(scene, NEVER)), read by test_refusals
    assert linear.ok and linear.polished and sol.ok and sol.polished, sol.info.declined
    assert sol.info.finish == cc.Finish.FRICTION_NEWTON and plastic_zone(sol, body=0)["yielded"] == 0
    assert rel(sol.u[0], linear.u[0]) <= 1e-9
    z, q = sol.points[0][:, 2], tau * DIAGONAL3
    assert rel(sol.u[0], np.column_stack([2 * q[0] * z / E3, 2 * q[1] * z / E3, -P * z / E3])) <= 1e-9


def test_a_sliding_layer_that_never_yields_is_the_linear_answer_at_cut_points(shared):
    """The layer whose top is moved past the onset slides (every node of X_h slips); the nodal relaxation leaves a
    vertex's triangles' cones and a round of cut points closes them (tests/test_friction_p2_gamma3.py): the Hencky
    body that never yields gives the linear material's answer (measured 2.3e-14), the friction force g A along
    the diagonal."""
    g = 1e5
    scene = sliding_layer3d(g)
    with warnings.catch_warnings():                 # the linear answer: LAYERS3D["sliding"], solved once a run
        warnings.simplefilter("error", cc.ResidualWarning)
        linear = shared(*layer_key("sliding"))
    sol = solve_strict(with_material(scene, NEVER))
    assert linear.ok and sol.ok and sol.polished, sol.info.declined
    assert rel(sol.u[0], linear.u[0]) <= 1e-9
    assert (np.linalg.norm(sol.contact.slip, axis=1) > 0).all()
    assert np.linalg.norm(sol.contact.shear_force.sum(axis=0) + g * DIAGONAL3) <= 1e-6 * g


def hencky_stress(e_zz, gamma):
    """The Hencky stress (sigma_xx, sigma_yy, sigma_zz, sigma_xz, sigma_yz) of the strain eps_zz = e_zz, 2 eps_xz =
    gamma_x, 2 eps_yz = gamma_y (the rest 0), from the density W = K/2 (tr eps)^2 + mu psi(|dev eps|)
    (docs/materials.md) by hand: sigma = K tr(eps) I + mu psi'(s) dev(eps) / s, psi'(s) = 2 h s + 2 (1 - h)
    min(s, s_y), s_y = sigma_y / (sqrt(6) mu)."""
    mu, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    s_y = SIGMA_Y / (np.sqrt(6.0) * mu)
    dev = np.array([-e_zz / 3, -e_zz / 3, 2 * e_zz / 3])          # xx, yy, zz
    s = np.sqrt(dev @ dev + 2 * (gamma[0] / 2) ** 2 + 2 * (gamma[1] / 2) ** 2)
    k = mu * (2 * H * s + 2 * (1 - H) * min(s, s_y)) / s
    assert s > 1.5 * s_y                                            # the state has yielded
    return K * e_zz + k * dev[0], K * e_zz + k * dev[1], K * e_zz + k * dev[2], k * gamma[0] / 2, k * gamma[1] / 2


def yielded_layer(law_of, e_zz=-1e-3, shear=3e-3):
    """The unit layer (2 x 2 x 1 cells of tetrahedra) on the plane z = 0 under the tractions of the uniform yielded
    state u = (gamma_x z, gamma_y z, e_zz z), gamma = ``shear`` along :data:`DIAGONAL3` (top (s_xz, s_yz, s_zz),
    sides -+ the stress's row), its contact under ``law_of(|(s_xz, s_yz)|, |s_zz|)``; (scene, exact u(points))."""
    gamma = shear * DIAGONAL3
    sxx, syy, szz, sxz, syz = hencky_stress(e_zz, gamma)
    body = cc.Body(cc.box(nx=2, ny=2, nz=1), cc.materials.hencky(E=E, nu=NU, sigma_y=SIGMA_Y, h=H), contact="bottom",
                   traction={"top": (sxz, syz, szz), "left": (-sxx, 0.0, -sxz), "right": (sxx, 0.0, sxz),
                             "front": (0.0, -syy, -syz), "back": (0.0, syy, syz)})
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=law_of(np.hypot(sxz, syz), abs(szz)))])
    return scene, lambda points: np.column_stack([gamma[0] * points[:, 2], gamma[1] * points[:, 2],
                                                  e_zz * points[:, 2]])


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_a_yielded_layer_stuck_on_the_plane_is_the_uniform_hencky_state(law):
    """The layer's uniform yielded state (|dev eps| = 2.1 s_y: every quadrature point yields) with the Hencky stress
    computed by hand, stuck under three times its shear (Tresca's threshold 3 |tau|, Coulomb's mu = 3 |tau| / |s_zz|):
    the displacement is the uniform state's, exact in P2 (measured 3.7e-14 Tresca, 7.4e-14 Coulomb), every
    quadrature point yielded, the tangential forces within half their capacities (measured: Tresca 0.44, the
    consistent P2 forces of the uniform shear, 0 at the vertices, against the red refinement's lumped capacities;
    Coulomb 1/3 at the midpoints against the capacities mu p_a the finish used, the vertices' forces and capacities
    both rounding, <= 3.7e-15 of the largest capacity)."""
    def law_of(tau, p):
        return cc.Tresca(3 * tau) if law == "tresca" else cc.Coulomb(3 * tau / p)

    scene, exact = yielded_layer(law_of)
    sol = solve_strict(scene)
    assert sol.ok and sol.polished, sol.info.declined
    zone = plastic_zone(sol, body=0)
    assert zone["yielded"] == zone["points"], zone
    assert rel(sol.u[0], exact(sol.points[0])) <= 1e-9
    c = sol.contact
    capacity = c.threshold * c.slip_measure
    assert (np.linalg.norm(c.shear_force, axis=1) <= 0.5 * capacity + 1e-12 * capacity.max()).all()


def pressed_block(law=None, sigma_y=2e7):
    """A Hencky block (2 x 2 x 1 cells of tetrahedra) on the plane z = 0 under rollers on its left and front sides,
    pressed by p (1 + x + y / 2) on its top: its whole base stays closed (the contact ends at no point inside an
    element) and it yields where the pressure is highest (sigma_y = 20 MPa: measured 36 of 192 points); ``law``
    on its base (None: frictionless)."""
    body = cc.Body(cc.box(nx=2, ny=2, nz=1), cc.materials.hencky(E=E, nu=NU, sigma_y=sigma_y, h=H), contact="bottom",
                   roller=["left", "front"],
                   traction={"top": lambda x, y, z: (0 * x, 0 * x, -P * (1 + x + 0.5 * y))})
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, **({} if law is None else {"law": law}))])


def test_a_vanishing_threshold_is_the_frictionless_hencky_answer_of_the_p2_cones():
    """Tresca's threshold 1e-6 Pa (1e-13 of the pressures) beside the partly yielding pressed block: the answer of
    the frictionless Hencky P2 cones (the full route's finish on the nonlinear (26), cvxcontact/backends/bulkcuts.py
    and the tangency Newton) to 1e-9 in u and lambda_h (measured 3.9e-14 and 1.8e-13), every base node slipping
    outwards under Poisson's expansion."""
    frictionless, sol = cc.solve(pressed_block(), **P2), solve_strict(pressed_block(cc.Tresca(1e-6)))
    assert frictionless.ok and frictionless.polished and sol.ok and sol.polished, sol.info.declined
    zone = plastic_zone(sol, body=0)
    assert 0 < zone["yielded"] < zone["points"], zone
    assert sol.in_contact().all()
    assert rel(sol.u[0], frictionless.u[0]) <= 1e-9
    assert rel(sol.contact.lam, frictionless.contact.lam) <= 1e-9


YIELDING = cc.materials.hencky(E=E, nu=NU, sigma_y=SIGMA_Y, h=H)
RADIUS, CENTRE = 1.0, (0.47, 0.52, 2.0 - 1e-3)


def indented_block(law=None, material=YIELDING):
    """A block (3 x 3 x 1 cells of tetrahedra) clamped at its base, indented 1 mm by a rigid sphere (radius 1 m, its
    gap the vertical ray's) off the centre of its top: the contact ends inside P2 elements (cut points), and a
    Hencky block yields under the sphere (measured 21 of 432 points); ``law`` on its top."""
    body = cc.Body(cc.box(nx=3, ny=3, nz=1), material, clamped="bottom", contact="top")
    ball = cc.Rigid.sphere(CENTRE, RADIUS, distance="ray")
    return cc.Scene(body, contacts=[cc.Contact(body, "top", ball, **({} if law is None else {"law": law}))])


def sampled_slack(sol, n=30):
    """u_z - g on the points of spacing 1/n of every top triangle (z = 1), u_z from the block's own P2 face
    functions (its nodes' displacements, the triangles' midpoints found by position), g the vertical distance to the
    sphere; over the largest displacement."""
    from scipy.spatial import cKDTree

    from cvxcontact.contact.quadratic3d import p2_shape

    mesh, points, u = cc.box(nx=3, ny=3, nz=1), np.asarray(sol.points[0]), np.asarray(sol.u[0])
    tri = np.asarray(mesh.boundary("top"))
    V = np.asarray(mesh.points)[tri]                                              # (t, 3, 3)
    mids = (V[:, [0, 1, 2]] + V[:, [1, 2, 0]]) / 2
    dist, node = cKDTree(points).query(np.concatenate([V, mids], axis=1).reshape(-1, 3))
    assert dist.max() < 1e-12
    nodes = node.reshape(-1, 6)
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    L = np.column_stack([i[keep], j[keep], n - i[keep] - j[keep]]) / n
    x = np.einsum("pk,tkd->tpd", L, V).reshape(-1, 3)
    uz = np.einsum("pk,tk->tp", p2_shape(L), u[nodes, 2]).ravel()
    r2 = (x[:, 0] - CENTRE[0]) ** 2 + (x[:, 1] - CENTRE[1]) ** 2
    gap = CENTRE[2] - np.sqrt(RADIUS ** 2 - r2) - x[:, 2]
    return float((uz - gap).max() / np.abs(u).max())


def coulomb_capacity(sol, mu):
    """Coulomb's capacities mu p_a at the contact's nodes of the indented block: p its nodal normal forces made
    non-negative by patches on the top's P2 triangles (friction_scenes.positive_forces; a negative share of a force
    between nodes taken from its neighbours)."""
    from scipy.spatial import cKDTree

    mesh, c = cc.box(nx=3, ny=3, nz=1), sol.contact
    V = np.asarray(mesh.points)[np.asarray(mesh.boundary("top"))]
    mids = (V[:, [0, 1, 2]] + V[:, [1, 2, 0]]) / 2
    dist, row = cKDTree(np.asarray(c.points)).query(np.concatenate([V, mids], axis=1).reshape(-1, 3))
    assert dist.max() < 1e-12
    return mu * positive_forces(c.force, row.reshape(-1, 6))


@pytest.fixture(scope="module")
def indented():
    return solve_strict(indented_block(cc.Tresca(1e-6)))


def indented_yielding(once, law):
    """The yielding indented block under ``law`` solved (:func:`solve_strict`) once per module: two tests read it."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        return once(("indented", law), lambda: cc.solve(indented_block(law), **P2))


def test_a_block_indented_by_a_sphere_is_finished_at_cut_points_and_never_penetrates(indented):
    """The indented Hencky block under Tresca's threshold 1e-6 Pa: the friction finish on the nodes and cut points
    through the damped sequential quadratic steps (the undamped ones cycled at a relative residual of 1 of the
    nonlinear (26)), accepted by the Bernstein maximum of every triangle's slack. Independent checks: the slack
    sampled on 496 points of every top triangle from the block's own P2 functions and the sphere itself (measured
    at most -1.4e-4 of the largest displacement: no penetration; the contact touches between the samples), and the frictionless Hencky answer within the cuts' accuracy
    (the 3D friction cuts stop at a violation 1e-9 of the displacements, their fields within about its square root;
    measured 8.6e-6 in u, as the linear material's 6.6e-6)."""
    sol = indented
    assert sol.ok and sol.polished, sol.info.declined
    zone = plastic_zone(sol, body=0)
    assert 0 < zone["yielded"] < zone["points"], zone
    assert sampled_slack(sol) <= 1e-9
    frictionless = cc.solve(indented_block(), **P2)
    assert frictionless.polished and rel(sol.u[0], frictionless.u[0]) <= 1e-3


def test_undamped_sequential_steps_on_the_indented_block_decline_flagged(monkeypatch):
    """Every step taken in full (the damping off): the steps cycle, the finish declines and the interior point's
    answer is kept, with a ResidualWarning and ``info.declined`` naming the sequential quadratic steps. (The 3D
    tangency Newton from the interior point's answer, tried where the cut rounds decline, finishes this scene
    otherwise: 1.1e-15 from the damped steps' answer, measured; turned off here, as it is what the steps'
    decline would fall back on.)"""
    from cvxcontact.backends import frictionsteps, frictiontangency

    monkeypatch.setattr(frictionsteps, "_damping", lambda *args: 1.0)
    monkeypatch.setattr(frictiontangency, "_polish", lambda *args: Declined(Stop.NOT_POSED, "turned off"))
    with pytest.warns(cc.ResidualWarning):
        sol = cc.solve(indented_block(cc.Tresca(1e-6)), **P2)
    assert not sol.polished and "sequential quadratic steps" in str(sol.info.declined), sol.info.declined


@pytest.mark.parametrize("law", [cc.Tresca(3e8), cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
def test_friction_under_a_sphere_keeps_its_law_and_never_yielding_is_the_linear_answer(law, once):
    """The indented block under a friction law that holds part of the contact (Tresca 300 MPa; Coulomb mu = 0.3, its
    fixed point on Tresca's capacities mu p at the cut points, p the nodal force made non-negative by patches: 3 of
    49 r_a < 0, the capacities up to 25 % of the largest off mu r_a+ beside them): a Hencky block that never yields gives the linear
    material's answer through the same cut rounds (measured 2.3e-15 Tresca, 2.9e-13 Coulomb); one that yields (0.19
    and 0.21 from the linear answer, measured) is finished with no sampled penetration (measured at most -2.0e-4
    and -1.7e-4 of the largest displacement) and its friction law read off by hand: every nodal shear force within
    its capacity, and where a node slips (above 1e-9 of the displacements) the capacity against the slip (measured
    8.4e-17 and 1.0e-15 of the largest capacity Tresca, 2 of 49 nodes slipping; Coulomb 1.6e-13 and 1.6e-13, 47 of
    49, its fixed point stops at 1e-12)."""
    linear = solve_strict(indented_block(law, material=cc.materials.isotropic(E=E, nu=NU)))
    never = solve_strict(indented_block(law, material=cc.materials.hencky(E=E, nu=NU, sigma_y=1e15, h=H)))
    assert linear.polished and never.ok and never.polished, never.info.declined
    assert rel(never.u[0], linear.u[0]) <= 1e-10
    sol = indented_yielding(once, law)
    assert sol.ok and sol.polished, sol.info.declined
    assert 0 < plastic_zone(sol, body=0)["yielded"] and rel(sol.u[0], linear.u[0]) > 1e-2
    assert sampled_slack(sol) <= 1e-9
    c = sol.contact
    # Tresca: g times the node's weight; Coulomb: mu p_a, p the cones' nodal normal force made non-negative
    capacity = c.threshold * c.slip_measure if isinstance(law, cc.Tresca) else coulomb_capacity(sol, 0.3)
    force = np.linalg.norm(c.shear_force, axis=1)
    slip = np.linalg.norm(c.slip, axis=1)
    slipping = slip > 1e-9 * np.abs(sol.u[0]).max()
    along = c.shear_force + capacity[:, None] * c.slip / np.where(slipping, slip, 1.0)[:, None]
    assert 0 < slipping.sum() < len(slipping)
    assert (force - capacity).max() <= 1e-10 * capacity.max()
    assert np.abs(along[slipping]).max() <= 1e-10 * capacity.max()


def beside_a_piezoelectric_layer(law, material=YIELDING):
    """The indented block of :func:`indented_block` (``material``, ``law`` on its top) and, apart from it, a PZT-5A
    layer (x in (5, 6); grounded base, floating top electrode, held by rollers on its sides) pressed by 10 MPa on the
    plane z = 0 under the same ``law``: two bodies that share no row, the layer's electric unknowns making the
    program's energy a saddle."""
    blk = indented_block(law, material=material)
    mesh = cc.box(x=(5, 6), y=(0, 1), z=(0, 0.5), nx=2, ny=2, nz=1)
    layer = cc.Body(mesh, cc.materials.PZT5A, roller=["left", "right", "front", "back"], contact="bottom",
                    traction={"top": (0, 0, -1e7)}, grounded="bottom", floating={"top": 0.0}, name="layer")
    return cc.Scene(blk.bodies[0], layer, contacts=[blk.contacts[0], cc.Contact(layer, "bottom", FLOOR3D, law=law)])


def test_a_piezoelectric_layer_beside_the_yielding_block_leaves_both_answers(indented):
    """The yielding indented block under Tresca's 1e-6 Pa beside a PZT-5A layer that shares no row with it: the
    damped steps also run with the layer's electric unknowns (after the first step every iterate satisfies the
    linear electric rows, where the enthalpy is the energy with the potential eliminated, convex in the
    displacements: the same objective); undamped there, the steps cycled and the finish declined (the interior
    point's answer 4.8e-2 off). Independent checks, the bodies being uncoupled: the block is the block's answer
    alone (measured 1.8e-15), the layer the layer's beside a linear block (measured 1.2e-15 in u, 5.9e-16 in phi)."""
    law = cc.Tresca(1e-6)
    sol = solve_strict(beside_a_piezoelectric_layer(law))
    alone = indented                                      # the block alone under the same law
    linear = solve_strict(beside_a_piezoelectric_layer(law, material=cc.materials.isotropic(E=E, nu=NU)))
    assert sol.ok and sol.polished and alone.polished and linear.polished, sol.info.declined
    assert 0 < plastic_zone(sol, body=0)["yielded"]
    assert rel(sol.u[0], alone.u[0]) <= 1e-10
    assert rel(sol.u[1], linear.u[1]) <= 1e-10 and rel(sol.phi[1], linear.phi[1]) <= 1e-10


def test_no_descent_above_the_tolerance_declines_flagged(monkeypatch):
    """The damping given no halving (the smallest step 1): the first damped step of the yielding indented block
    finds no descent at a residual far above 1e-12 (the full step raised the objective by 0.4 of it, measured), so
    the finish declines, the interior point's answer kept, flagged (``ResidualWarning``, ``info.declined`` naming
    the missing descent), never ``ok``. (The 3D tangency Newton from the interior point's answer, which finishes
    this scene otherwise, 1.1e-15 from the damped steps' answer, measured, turned off.)"""
    from cvxcontact.backends import frictionsteps, frictiontangency

    monkeypatch.setattr(frictionsteps, "SMALLEST_STEP", 1.0)
    monkeypatch.setattr(frictiontangency, "_polish", lambda *args: Declined(Stop.NOT_POSED, "turned off"))
    with pytest.warns(cc.ResidualWarning):
        sol = cc.solve(indented_block(cc.Tresca(1e-6)), **P2)
    assert not sol.ok and not sol.polished and "no descent" in str(sol.info.declined), sol.info.declined


def hencky_forces(sol):
    """(F, size) per node of the block (n, 3): F = the gradient of its Hencky energy by hand, sum_q w_q B_q^T
    sigma(eps_q), the stress sigma = dW/d eps of W = K/2 tr(eps)^2 + mu psi(|dev eps|) (:func:`hencky_stress`'s
    law, engineering shears), the strain rows B and weights w of the body's own assembly; size the largest
    sum_q w_q |B_q|^T |sigma_q| (the scale of its terms)."""
    from cvxcontact.fem.space import space

    b = sol.scene.bodies[0]
    element = space(sol.degree, b.mesh.cell)
    system = element.assemble_matrices(b, element.nodes(b))
    mu, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    s_y = SIGMA_Y / (np.sqrt(6.0) * mu)
    eps = (system.strain @ np.asarray(sol.u[0]).ravel()).reshape(len(system.weights), 6)
    tr = eps[:, :3].sum(axis=1)
    dev = eps[:, :3] - tr[:, None] / 3
    s = np.sqrt((dev ** 2).sum(axis=1) + 0.5 * (eps[:, 3:] ** 2).sum(axis=1))
    k = mu * (2 * H * s + 2 * (1 - H) * np.minimum(s, s_y)) / s
    sigma = np.column_stack([K * tr[:, None] + k[:, None] * dev, k[:, None] * eps[:, 3:] / 2]) * system.weights[:, None]
    size = abs(system.strain).T @ np.abs(sigma).ravel()
    return (system.strain.T @ sigma.ravel()).reshape(-1, 3), float(size.max())


@pytest.mark.parametrize("law", [cc.Tresca(3e8), cc.Coulomb(0.3)], ids=["tresca", "coulomb"])
def test_the_yielding_block_under_a_sphere_balances_a_stress_computed_by_hand(law, once):
    """The indented yielding block's equilibrium and friction law read off the Hencky stress computed here (not the
    package's energy): every node off the contact face and the clamped base balanced (measured 9.3e-16 Tresca,
    3.5e-16 Coulomb of the terms' size); on the top nodes F is the contact's force on the block: -F_z the reported
    normal force (measured 3.8e-16), F_t the reported friction force (1.4e-15 / 1.8e-15), within the capacity
    (1.7e-16 / 1.6e-13 above it at most, of the largest capacity; Coulomb's mu p, :func:`coulomb_capacity`) and
    against the slip where a node slips (1.3e-15 / 1.6e-13)."""
    from scipy.spatial import cKDTree

    sol = indented_yielding(once, law)
    assert sol.ok and sol.polished, sol.info.declined
    assert 0 < plastic_zone(sol, body=0)["yielded"]
    F, size = hencky_forces(sol)
    z = np.asarray(sol.points[0])[:, 2]
    inside = (z > 1e-12) & (z < 1 - 1e-12)
    assert np.abs(F[inside]).max() <= 1e-12 * size
    c = sol.contact
    dist, node = cKDTree(sol.points[0]).query(c.points)
    assert dist.max() < 1e-12 and len(node) == (~inside & (z > 0.5)).sum()
    r = -F[node]                                  # the block's force on the sphere
    assert np.abs(r[:, 2] - c.force).max() <= 1e-12 * np.abs(c.force).max()
    assert np.abs(r[:, :2] + c.shear_force).max() <= 1e-12 * np.abs(c.shear_force).max()
    capacity = c.threshold * c.slip_measure if isinstance(law, cc.Tresca) else coulomb_capacity(sol, 0.3)
    assert (np.linalg.norm(r[:, :2], axis=1) - capacity).max() <= 1e-10 * capacity.max()
    slip = np.linalg.norm(c.slip, axis=1)
    slipping = slip > 1e-9 * np.abs(sol.u[0]).max()
    assert slipping.any()
    along = r[:, :2] - capacity[:, None] * c.slip / np.where(slipping, slip, 1.0)[:, None]
    assert np.abs(along[slipping]).max() <= 1e-10 * capacity.max()
