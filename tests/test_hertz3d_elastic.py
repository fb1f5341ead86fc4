"""A curved contact part against a planar one in 3D (node-to-face, contact/surface.py CurvedSurfaceInterface)
and the elastic Hertz study's coarsest level (cvxcontact/apps/studies/hertz3d_elastic.py): the rows against a
brute-force projection, a flat part read as curved against the overlay's sigma rows, pushing the punch's top
against the pair's gap, the force balance against the supports' reactions, Hertz's quantities within the
measured errors of the level, and the refusals."""

import numpy as np
import pytest

import cvxcontact as cc
import cvxcontact.physics.scene as scene_module
from cvxcontact.apps.studies import hertz3d_elastic as h
from cvxcontact.contact.surface import CurvedSurfaceInterface, SurfaceInterface
from cvxcontact.errors import SceneError, UnsupportedError
from cvxcontact.fem.assembly import assemble_matrices

from scenes3d import bumped_blocks, stacked_blocks

N = 8                                                     # the study's coarsest level


@pytest.fixture(scope="module")
def pressed():
    base = h.scene(N)
    solver = cc.ContactSolver(base, h.CONDITION, method="condensed")
    return h.press(solver, base)


def test_the_pair_of_the_study_is_node_to_face():
    itf = h.scene(4).interfaces[0]
    assert isinstance(itf, CurvedSurfaceInterface) and itf.curved == 1
    np.testing.assert_array_equal(itf.normal, [0.0, 0.0, 1.0])          # the block's outward normal (first)
    assert itf.size == 25                                                # every node of the punch's bottom


def test_rows_against_a_brute_force_projection():
    """Each punch node over the block's top: the face holding its projection found by testing every face
    (no search tree), its P1 weights, the gap z - 0; the jump operators and gaps built from them."""
    sc = h.scene(4, delta=1e-5)
    block, punch = sc.bodies
    itf = sc.interfaces[0]
    top = np.asarray(block.mesh.boundary("top"))
    P = block.mesh.points[top][:, :, :2]                                 # (f, 3, 2)
    nodes = np.unique(np.asarray(punch.mesh.boundary("bottom")))
    X = punch.mesh.points[nodes]
    n_b, n_p = len(block.mesh.points), len(punch.mesh.points)
    Jb, Jp = np.zeros((len(X), 3 * n_b)), np.zeros((len(X), 3 * n_p))
    for a, x in enumerate(X):
        for f, T in zip(top, P):
            M = np.column_stack([T[1] - T[0], T[2] - T[0]])
            l1, l2 = np.linalg.solve(M, x[:2] - T[0])
            L = np.array([1 - l1 - l2, l1, l2])
            if L.min() >= -1e-12:
                Jb[a, 3 * f + 2] = L                                     # u_block . (+z) at the projection
                break
        else:
            raise AssertionError("every node of the punch's bottom lies over the block's top")
        Jp[a, 3 * nodes[a] + 2] = -1.0                                   # u_punch . (-z) at the node
    order = np.lexsort(itf.points.T)                                     # rows in the order of the nodes
    ref = np.lexsort(X.T)
    np.testing.assert_allclose(itf.jump(0, n_b).toarray()[order], Jb[ref], rtol=0, atol=1e-12)
    np.testing.assert_allclose(itf.jump(1, n_p).toarray()[order], Jp[ref], rtol=0, atol=0)
    # the gap: the node's height over z = 0 plus the pair's gap -delta
    np.testing.assert_allclose(sc.gap_values()[order], X[ref, 2] - 1e-5, rtol=0, atol=1e-18)
    assert sc.gap_values().min() == pytest.approx(-1e-5, abs=1e-18)      # the pole touches z = 0


def _read_as_curved(monkeypatch, curved=1):
    """Scenes built while active read their pairs' second (``curved``) part as curved, though it is planar."""
    def forced(bodies, parts=None, obstacle=None):
        parts = tuple(b.contact for b in bodies) if parts is None else tuple(parts)
        if obstacle is not None:
            return SurfaceInterface(tuple(bodies), parts, obstacle=obstacle)
        return CurvedSurfaceInterface(tuple(bodies), parts, curved=curved)

    monkeypatch.setattr(scene_module, "pair_interface", forced)


@pytest.mark.parametrize("build", [stacked_blocks, bumped_blocks], ids=["uniform pressure", "bumped gap"])
def test_a_flat_part_read_as_curved_reproduces_the_overlay_sigma_rows(build, monkeypatch):
    """On coplanar non-matching faces (5x5 on 7x3, 4x4 on 5x3) the node-to-face rows at the upper body's
    nodes are the overlay's "sigma2" rows: the same solution to rounding (two independent constructions:
    polygon clipping of the faces against a point location of the nodes)."""
    overlay = build()
    assert isinstance(overlay.interfaces[0], SurfaceInterface)
    ref = cc.solve(overlay, "sigma2")
    _read_as_curved(monkeypatch)
    curved = build()
    assert isinstance(curved.interfaces[0], CurvedSurfaceInterface)
    sol = cc.solve(curved, "sigma2")
    assert ref.ok and sol.ok
    scale = max(float(np.abs(u).max()) for u in ref.u)
    for u, v in zip(sol.u, ref.u):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-9 * scale)     # measured 7e-16 and 0 of the scale
    # the row forces at the same nodes (the overlay's sigma2 vertices are the upper body's nodes)
    rc, rr = sol.contact, ref.contact
    on = rr.constrained
    a, b = np.lexsort(rc.points.T), np.lexsort(rr.points[on].T)
    np.testing.assert_allclose(rc.points[a], rr.points[on][b], rtol=0, atol=1e-12)
    F = float(np.abs(rr.force).sum())
    np.testing.assert_allclose(rc.force[a], rr.force[on][b], rtol=0, atol=1e-9 * F)   # measured 9e-17 and 0 of F
    with pytest.raises(UnsupportedError, match=r"upper 'bottom' \(curved\) against lower 'top'.*use 'sigma2'"):
        cc.solve(curved, "gamma3")


def test_pushing_the_top_is_the_pairs_gap():
    """The study's load: the top held and the gap -delta, against the top pushed down by delta (a prescribed
    displacement, another geometry): the same forces, the punch's displacement shifted by -delta e_z."""
    delta = 4e-5
    a = cc.solve(h.scene(4, delta=delta), h.CONDITION)
    b = cc.solve(h.scene(4, pushed=delta), h.CONDITION)
    assert a.ok and b.ok and a.contact.active.sum() >= 1
    F = float(a.contact.force.sum())
    np.testing.assert_allclose(b.contact.force, a.contact.force, rtol=0, atol=1e-9 * F)   # measured 3e-15 of F
    np.testing.assert_allclose(b.u[0], a.u[0], rtol=0, atol=1e-9 * delta)                # measured 3e-15 delta
    np.testing.assert_allclose(b.u[1], a.u[1] - [0.0, 0.0, delta], rtol=0, atol=1e-9 * delta)   # measured 1e-14 delta


def test_body_order_does_not_matter():
    """The punch as the first body (its nodes: "sigma1", the pair's normal -z): the same solution."""
    sc = h.scene(4, delta=4e-5)
    block, punch = sc.bodies
    swapped = cc.Scene(punch, block, contacts=[cc.Contact(punch, "bottom", block, "top", gap=-4e-5)])
    itf = swapped.interfaces[0]
    assert itf.curved == 0 and itf.normal[2] == -1.0
    a, b = cc.solve(sc, "sigma2"), cc.solve(swapped, "sigma1")
    np.testing.assert_allclose(b.u[0], a.u[1], rtol=0, atol=1e-12 * float(np.abs(a.u[1]).max()))
    np.testing.assert_allclose(b.u[1], a.u[0], rtol=0, atol=1e-12 * float(np.abs(a.u[1]).max()))


def test_force_balance_is_exact(pressed):
    """The total force is F to the secant's tolerance; the rows carry it to the block's clamped bottom and the
    punch's held top: their reactions K u (no other load) sum to it, and the active nodes touch."""
    sol, delta, resolves = pressed
    assert sol.ok and sol.polished and resolves <= 8                     # measured 4 solves
    c = sol.contact
    assert (c.force >= 0).all()
    assert abs(4 * c.force.sum() - h.FORCE) <= 1e-10 * h.FORCE
    block, punch = sol.scene.bodies
    for k, (body, part) in enumerate([(block, "bottom"), (punch, "top")]):
        reaction = (assemble_matrices(body).Kuu @ sol.u[k].ravel()).reshape(-1, 3)
        held = body.mesh.boundary_nodes([part])
        sign = 1.0 if k == 0 else -1.0              # the clamp pushes the block up, the top's support the punch down
        assert 4 * reaction[held, 2].sum() == pytest.approx(sign * h.FORCE, rel=1e-9)     # measured 1e-14
    np.testing.assert_allclose(c.jump[c.active], c.gap[c.active], rtol=0,
                               atol=1e-9 * h.hertz(h.FORCE)[2])          # measured 1.4e-20 m
    assert (c.jump <= c.gap + 1e-12 * h.hertz(h.FORCE)[2]).all()


def test_hertz_quantities_at_the_coarsest_level(pressed):
    sol, delta, _ = pressed
    row = h.measure(sol, delta)
    assert row["F_N"] == pytest.approx(h.FORCE, rel=1e-10)
    # errors of the P1 level n = 8 (about 2 cells across the contact radius); measured beside each bound
    assert abs(row["a_rel_error"]) < 0.1                                 # measured -0.035
    assert row["a_h_min_m"] < h.A_REF < row["a_h_max_m"]                 # measured 0.72 a .. 1.06 a
    assert -0.25 < row["p0_rel_error"] < -0.1                            # measured -0.179
    # the block feels the punch's pressure on the axis (both sides' nodes lie over the axis)
    assert row["p_block_Pa"] == pytest.approx(row["p0_h_Pa"], rel=1e-3)  # measured 6e-5
    assert abs(row["cell_force_rel_error"]) < 0.25                       # measured -0.163
    # finite bodies are stiffer than half-spaces: a shorter approach, by about the far fields of both
    # (Boussinesq at depth L: 0.073 of delta) plus the coarse mesh's stiffness
    assert -0.2 < row["delta_rel_error"] < -0.05                         # measured -0.108


def test_refusals():
    sc = h.scene(4)
    with pytest.raises(UnsupportedError, match=r"punch 'bottom' \(curved\).*'gamma3' is not available"):
        cc.solve(_no_condition(sc), "gamma3")
    with pytest.raises(UnsupportedError, match="P2 .* not available: use degree=1"):
        cc.solve(sc, h.CONDITION, degree=2)
    block, punch = sc.bodies
    # a curved part turned away from the plane: the punch's top is planar; the block's "left" is planar too,
    # so pair the punch's curved bottom with the block's bottom (facing down, the same side as the punch)
    with pytest.raises(SceneError, match="does not face the planar part"):
        cc.Scene(block, punch, contacts=[cc.Contact(block, "bottom", punch, "bottom")])
    # no node over the planar part: a block far to the side
    far = block.with_changes(mesh=block.mesh.with_points(block.mesh.points + [1.0, 0.0, 0.0]))
    with pytest.raises(SceneError, match="no node of the curved part lies over the planar part"):
        cc.Scene(far, punch, contacts=[cc.Contact(far, "top", punch, "bottom")])
    # two curved parts: not a node-to-face pair
    other = h.bodies(4)[1]
    with pytest.raises(SceneError, match="not planar"):
        cc.Scene(other, punch, contacts=[cc.Contact(other, "bottom", punch, "bottom")])


def _no_condition(sc):
    block, punch = sc.bodies
    return cc.Scene(block, punch, contacts=[cc.Contact(block, "top", punch, "bottom")])


def test_a_punch_held_by_the_contact_alone_carries_its_load():
    """No support on the punch's top, a traction on it: the contact (the curved rows) holds the punch along z,
    and the row forces balance the traction's resultant; a stiff normal-compliance law on the same rows comes
    close to Signorini's force."""
    block, punch = h.bodies(4)
    loaded = punch.with_changes(displacement={}, traction={"top": (0.0, 0.0, -1e7)})
    sc = cc.Scene(block, loaded, contacts=[cc.Contact(block, "top", loaded, "bottom", condition="sigma2")])
    sol = cc.solve(sc)
    assert sol.ok
    L = h.SIZE * h.A_REF
    assert sol.contact.force.sum() == pytest.approx(1e7 * L * L, rel=1e-10)     # measured 2e-13
    pressed = h.scene(4, delta=4e-5)
    hard = cc.solve(pressed, "sigma2", law=cc.NormalCompliance(stiffness=1e16, exponent=1.0))
    exact = cc.solve(pressed, "sigma2")
    assert hard.ok and exact.ok
    # a penetration of about p / k = 1e-7 m against delta = 4e-5 m: the force 0.27 % lower
    assert hard.contact.force.sum() == pytest.approx(exact.contact.force.sum(), rel=1e-2)   # measured -2.7e-3
    assert hard.contact.force.sum() < exact.contact.force.sum()


def test_p1_errors_shrink_with_h(pressed):
    """Level n = 16 against n = 8: the peak pressure, the axis cell's force and the approach approach Hertz
    (the radius, read from active/open edges, is within h/2 at both: -0.035 / -0.006). Measured at n = 8 / 16:
    p0 -0.179 / -0.101, cell force -0.163 / -0.096, delta -0.108 / -0.066 (docs/studies/hertz3d_elastic)."""
    sol, delta, _ = pressed
    coarse = h.measure(sol, delta)
    fine, fine_sol = h.solve_level(16)
    assert fine_sol.ok and fine["F_N"] == pytest.approx(h.FORCE, rel=1e-10)
    for key in ("p0_rel_error", "cell_force_rel_error", "delta_rel_error"):
        assert abs(fine[key]) < 0.7 * abs(coarse[key]), key                # measured ratios 0.56, 0.59, 0.61
    assert abs(fine["a_rel_error"]) < 0.05                                 # measured -0.006
