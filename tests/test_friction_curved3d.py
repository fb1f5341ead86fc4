"""Friction on a curved 3D contact part against a planar one (node-to-face, contact/surface.py
CurvedSurfaceInterface.tangential_jump) and against a curved rigid obstacle (a sphere pressed into a block).

References independent of the code under test: the slip rows against a brute-force projection (every face
tested); a flat part read as curved against the overlay's "sigma2" rows (another construction); a cap of large
radius tending linearly to the planar pair; Tresca's g -> 0 against the frictionless answer; a huge g against a
dense solve of the stuck (tied) mixed system on the answer's contact set, whose signs certify it; the law read
off the answer with capacities from the mesh's face areas; the mirror symmetry of a centred cap.
Scenes: tests/friction_scenes.py (capped_pair), tests/scenes3d.py (sphere_into_block)."""

import numpy as np
import pytest
from friction_scenes import capped_pair, projected_gradient_tresca
from scenes3d import sphere_into_block

import cvxcontact as cc
import cvxcontact.physics.scene as scene_module
from cvxcontact.contact.surface import CurvedSurfaceInterface, SurfaceInterface
from cvxcontact.errors import UnsupportedError

pytestmark = pytest.mark.numerics

S = 1e-4                                        # m, the upper block's top moved along x
LAWS = {"tresca": cc.Tresca(threshold=8e6), "coulomb": cc.Coulomb(coefficient=0.15)}


def _scale(sol) -> float:
    return max(float(np.abs(u).max()) for u in sol.u)


def _difference(sol, ref) -> float:
    """The largest displacement difference over the reference's largest displacement."""
    return max(float(np.abs(u - v).max()) for u, v in zip(sol.u, ref.u)) / _scale(ref)


def _brute_force_rows(scene):
    """(N (m, 3 n0 + 3 n1), T (2, m, 3 n0 + 3 n1), gap (m,), points (m, 3)): the rows of the pair of
    :func:`capped_pair` (lower planar top z = 0, upper curved bottom) built by testing every face of the lower
    top for each upper bottom node: [u_nu] = u_lower(X) . e_z - u_upper(x) . e_z, the slip along (x, y)
    u_lower(X) - u_upper(x) (the lower block is the first body), the gap x . e_z."""
    lower, upper = scene.bodies
    n0, n1 = len(lower.mesh.points), len(upper.mesh.points)
    top = np.asarray(lower.mesh.boundary("top"))
    corners = np.asarray(lower.mesh.points)[top][:, :, :2]
    nodes = np.unique(np.asarray(upper.mesh.triangulation.boundary("bottom")))
    X = np.asarray(upper.mesh.points)[nodes]
    rows = np.zeros((3, len(X), 3 * (n0 + n1)))                  # components x, y, z of u_lower(X) - u_upper(x)
    for a, x in enumerate(X):
        for f, T in zip(top, corners):
            lam = np.linalg.solve(np.column_stack([T[1] - T[0], T[2] - T[0]]), x[:2] - T[0])
            L = np.array([1.0 - lam.sum(), lam[0], lam[1]])
            if L.min() >= -1e-12:
                break
        else:
            raise AssertionError("every node of the upper bottom lies over the lower top")
        for j in range(3):
            rows[j, a, 3 * f + j] = L
            rows[j, a, 3 * n0 + 3 * nodes[a] + j] = -1.0
    return rows[2], rows[:2], X[:, 2].copy(), X


def _read_as_curved(monkeypatch):
    """Scenes built while active read the pair's second part (the upper block's bottom) as curved."""
    def forced(bodies, parts=None, obstacle=None):
        parts = tuple(b.contact for b in bodies) if parts is None else tuple(parts)
        return CurvedSurfaceInterface(tuple(bodies), parts, curved=1)

    monkeypatch.setattr(scene_module, "pair_interface", forced)


def test_slip_rows_against_a_brute_force_projection():
    """The tangential rows of both sides, component-major along the planar part's frame (x, y), against the
    brute-force projection; the normal rows likewise (the shared interpolation)."""
    sc = capped_pair(None)
    itf = sc.interfaces[0]
    assert isinstance(itf, CurvedSurfaceInterface) and itf.curved == 1
    np.testing.assert_array_equal(itf.frame, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    n0, n1 = (len(b.mesh.points) for b in sc.bodies)
    N, T, gap, X = _brute_force_rows(sc)
    order, ref = np.lexsort(itf.points.T), np.lexsort(X.T)
    np.testing.assert_allclose(itf.points[order], X[ref], rtol=0, atol=0)
    full = [np.hstack([itf.tangential_jump(0, n0).toarray(), itf.tangential_jump(1, n1).toarray()])]
    m = itf.size
    for j in range(2):
        np.testing.assert_allclose(full[0][j * m:(j + 1) * m][order], T[j][ref], rtol=0, atol=1e-12)
    normal = np.hstack([itf.jump(0, n0).toarray(), itf.jump(1, n1).toarray()])
    np.testing.assert_allclose(normal[order], N[ref], rtol=0, atol=1e-12)
    np.testing.assert_allclose(itf.obstacle_gap()[order], gap[ref], rtol=0, atol=0)


def _capped(once, name, **kw):
    """``cc.solve(capped_pair(LAWS[name], s=S, **kw))`` once per module: several tests read the same answer."""
    return once(("capped", name, tuple(sorted(kw.items()))), lambda: cc.solve(capped_pair(LAWS[name], s=S, **kw)))


@pytest.mark.parametrize("name", LAWS)
def test_a_flat_part_read_as_curved_is_the_planar_pair(name, monkeypatch, once):
    """Flat faces (6 x 6 under 4 x 4, the upper part inside the lower one): the node-to-face rows with friction
    are the overlay's "sigma2" rows, capacities included (the upper hats' integrals over the overlap are its
    lumped areas): the same answer to rounding (two constructions: polygon clipping against point location)."""
    law = LAWS[name]
    ref = _capped(once, name, radius=None)
    assert isinstance(ref.scene.interfaces[0], SurfaceInterface)
    _read_as_curved(monkeypatch)
    sol = cc.solve(capped_pair(law, radius=None, s=S))
    assert isinstance(sol.scene.interfaces[0], CurvedSurfaceInterface)
    assert ref.ok and sol.ok
    assert _difference(sol, ref) <= 1e-12                   # measured 3.6e-16
    a, b = sol.contact, ref.contact
    on = b.constrained
    i, j = np.lexsort(a.points.T), np.lexsort(b.points[on].T)
    F = float(np.abs(b.shear_force).sum())
    np.testing.assert_allclose(a.shear_force[i], b.shear_force[on][j], rtol=0, atol=1e-10 * F)
    np.testing.assert_allclose(a.slip[i], b.slip[on][j], rtol=0, atol=1e-12 * S)


@pytest.mark.parametrize("name", LAWS)
def test_a_cap_of_large_radius_tends_to_the_planar_pair(name, once):
    """The upper bottom a spherical cap of radius R (its corners 0.25 / R m above the centre: 5e-7, 5e-8 m at
    R = 5e5, 5e6 against a 3e-4 m approach): read as curved, its answer tends to the flat pair's linearly in
    1 / R (measured differences 9.6e-4 / 9.5e-4 and 9.6e-5 / 9.5e-5 of the displacement scale, Tresca / Coulomb:
    ratio 0.1000000)."""
    law = LAWS[name]
    flat = _capped(once, name, radius=None)
    assert isinstance(flat.scene.interfaces[0], SurfaceInterface)
    diffs = []
    for R in (5e5, 5e6):
        sol = cc.solve(capped_pair(law, radius=R, s=S))
        assert isinstance(sol.scene.interfaces[0], CurvedSurfaceInterface) and sol.ok
        diffs.append(_difference(sol, flat))
    assert diffs[0] < 0.1                                    # measured 9.6e-4 (Tresca), 9.5e-4 (Coulomb)
    assert diffs[1] == pytest.approx(0.1 * diffs[0], rel=1e-3)   # measured ratio 0.1 to 2e-8


def test_tresca_without_threshold_is_frictionless():
    """Tresca's g = 0 is the frictionless curved pair (cc.solve without a law) to rounding, and g > 0 departs
    from it linearly (measured 3.44e-8 of the displacement scale per Pa of g at g = 1, 10, 100 Pa)."""
    free = cc.solve(capped_pair(None, s=S))
    zero = cc.solve(capped_pair(cc.Tresca(threshold=0.0), s=S))
    assert free.ok and zero.ok
    assert _difference(zero, free) <= 1e-12                 # measured 1.1e-15
    d1, d10 = (_difference(cc.solve(capped_pair(cc.Tresca(threshold=g), s=S)), free) for g in (1.0, 10.0))
    assert d1 < 1e-5                                        # measured 3.4e-8
    assert d10 == pytest.approx(10 * d1, rel=1e-3)         # measured 10 * (1 + 2e-9)


def _reduced_dense(scene):
    """(Tu, K, f, u_fixed) of both bodies, dense: the free unknowns' map, the reduced stiffness Tu^T K Tu, the
    reduced load and the prescribed displacements (P1 tetrahedra, assembled by the space alone)."""
    import scipy.linalg as sla

    from cvxcontact.fem.space import P1Tet

    systems = [P1Tet().assemble_loads(b, P1Tet().assemble_matrices(b)) for b in scene.bodies]
    Tu = sla.block_diag(*[s.Tu.toarray() for s in systems])
    K = Tu.T @ sla.block_diag(*[s.Kuu.toarray() for s in systems]) @ Tu
    return Tu, K, Tu.T @ np.concatenate([s.f for s in systems]), np.concatenate([s.u_fixed for s in systems])


def _stuck_reference(scene, active):
    """(u per body, normal forces at ``active``): the frictionless pair's rows on ``active`` held at their gap
    and every row's slip held at 0 (stuck: tied), solved densely (the mixed system of both bodies' reduced
    stiffness and the brute-force rows), independent of the package's contact code."""
    Tu, K, f, u_fixed = _reduced_dense(scene)
    N, T, gap, X = _brute_force_rows(scene)
    C = np.vstack([N[active], T[0], T[1]])
    h = np.concatenate([gap[active], np.zeros(2 * len(X))]) - C @ u_fixed
    CT = C @ Tu
    m = CT.shape[0]
    sol = np.linalg.solve(np.block([[K, CT.T], [CT, np.zeros((m, m))]]), np.concatenate([f, h]))
    u = Tu @ sol[:K.shape[0]] + u_fixed
    n0 = 3 * len(scene.bodies[0].mesh.points)
    return (u[:n0].reshape(-1, 3), u[n0:].reshape(-1, 3)), sol[K.shape[0]:K.shape[0] + int(np.sum(active))], N, \
        gap, X


def test_a_huge_threshold_is_the_stuck_pair():
    """Tresca's g = 1e13 Pa (capacities far above any force): every row sticks. On the answer's contact set the
    dense stuck reference gives the same displacements and normal forces; its own signs certify it (forces > 0
    on the contact set, the others open)."""
    sc = capped_pair(cc.Tresca(threshold=1e13), s=S)
    sol = cc.solve(sc)
    assert sol.ok
    c, itf = sol.contact, sc.interfaces[0]
    _, _, _, X = _brute_force_rows(sc)
    order, ref = np.lexsort(itf.points.T), np.lexsort(X.T)
    active = np.zeros(len(X), dtype=bool)
    active[ref] = c.active[order]
    assert 1 <= active.sum() < len(X)                       # measured 9 of 25
    u, y, N, gap, _ = _stuck_reference(sc, active)
    scale = _scale(sol)
    for mine, theirs in zip(sol.u, u):
        np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-9 * scale)   # measured 9e-16 of the scale
    forces = np.zeros(len(X))
    forces[active] = y
    np.testing.assert_allclose(c.force[order], forces[ref], rtol=0, atol=1e-9 * float(y.sum()))   # measured 3e-16
    assert (y > 0).all()                                                  # measured min / max 0.80
    opening = (gap - N @ np.concatenate([v.ravel() for v in u]))[~active]
    assert (opening > 0).all()                                            # measured min 5.1e-5 m
    assert float(np.linalg.norm(c.slip, axis=1).max()) <= 1e-12 * S      # measured 1e-20 m


def _tresca_reference(scene, g):
    """(u per body, R (m, 3): t1, t2 force on the lower block and the normal force per node, in the brute-force
    rows' order, points): the nodal Tresca law of threshold ``g`` (Pa) on the pair of :func:`capped_pair` solved
    independently of the package's contact code: both bodies' reduced stiffness, the brute-force rows (groups
    slip t1, slip t2, -[u_nu] >= -gap), capacities g times a third of each curved face's area, the dual QP by
    :func:`projected_gradient_tresca` (FISTA: accurate to about the square root of rounding)."""
    Tu, K, f, u_fixed = _reduced_dense(scene)
    N, T, gap, X = _brute_force_rows(scene)
    D = np.empty((3 * len(X), N.shape[1]))
    D[0::3], D[1::3], D[2::3] = T[0], T[1], -N
    DT = D @ Tu
    q = DT @ np.linalg.solve(K, f) + D @ u_fixed
    q[2::3] += gap
    R = projected_gradient_tresca(DT @ np.linalg.solve(K, DT.T), q, g * _face_shares(scene.bodies[1], X))
    u = Tu @ np.linalg.solve(K, f + DT.T @ R) + u_fixed
    n0 = 3 * len(scene.bodies[0].mesh.points)
    return (u[:n0].reshape(-1, 3), u[n0:].reshape(-1, 3)), R.reshape(-1, 3), X


def test_tresca_against_a_dense_dual_reference():
    """Tresca g = 8 MPa, the upper block's top moved by 1e-4 m along x (10 rows slip): the package's answer against
    the dense dual reference (measured 2.0e-8 of the displacement scale, 6.3e-9 of the normal forces' sum, 7.6e-8
    of the shear forces' sum: the reference's own accuracy)."""
    g = 8e6
    sc = capped_pair(cc.Tresca(threshold=g), s=S)
    sol = cc.solve(sc)
    assert sol.ok
    u, R, X = _tresca_reference(sc, g)
    scale = _scale(sol)
    for mine, theirs in zip(sol.u, u):
        np.testing.assert_allclose(mine, theirs, rtol=0, atol=2e-6 * scale)
    c, itf = sol.contact, sc.interfaces[0]
    order, ref = np.lexsort(itf.points.T), np.lexsort(X.T)
    np.testing.assert_allclose(c.force[order], R[ref, 2], rtol=0, atol=1e-6 * float(R[:, 2].sum()))
    np.testing.assert_allclose(c.shear_force[order], R[ref, :2], rtol=0, atol=1e-5 * float(np.abs(R[:, :2]).sum()))


def _face_shares(body, X):
    """A third of the area of every face of ``body``'s "bottom" at each of the points ``X`` (its nodes), m^2."""
    mesh = body.mesh.triangulation
    faces = np.asarray(mesh.boundary("bottom"))
    P = np.asarray(mesh.points)[faces]
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    share = np.zeros(len(mesh.points))
    np.add.at(share, faces.ravel(), np.repeat(area / 3.0, 3))
    at = [int(np.flatnonzero((np.abs(np.asarray(mesh.points) - x) <= 1e-14).all(axis=1))[0]) for x in X]
    return share[at]


def _capacities(sol, law):
    """Each row's capacity (N) from the mesh: Tresca g times a third of the area of every face of the upper bottom
    at the row's node (the faces' true areas); Coulomb mu times the row's normal force."""
    c = sol.contact
    if isinstance(law, cc.Coulomb):
        return law.coefficient * c.force
    return law.threshold * _face_shares(sol.scene.bodies[1], sol.scene.interfaces[0].points)


@pytest.mark.parametrize("name", LAWS)
def test_the_law_read_off_the_answer(name, once):
    """|shear_a| <= capacity_a (1 + 1e-12) on every row; where a row slips the shear force on the first body is
    its capacity, against the slip; somewhere it slips, somewhere it sticks (measured: Tresca g = 8 MPa 10 rows
    slip, 15 stick, the open rows included; Coulomb mu = 0.15 7 of the 9 loaded rows slip)."""
    law = LAWS[name]
    sol = _capped(once, name)
    assert sol.ok
    c = sol.contact
    cap = _capacities(sol, law)
    shear = np.linalg.norm(c.shear_force, axis=1)
    slip = np.linalg.norm(c.slip, axis=1)
    assert (shear <= cap * (1 + 1e-12)).all()
    sliding = slip > 1e-9 * S
    carried = cap > 1e-9 * cap.max()
    assert (sliding & carried).any() and (~sliding & carried).any()
    turned = np.einsum("ij,ij->i", c.shear_force, c.slip) / np.maximum(shear * slip, np.finfo(float).tiny)
    assert (turned[sliding & carried] <= -1 + 1e-6).all()     # measured -1 + 2.2e-16
    np.testing.assert_allclose(shear[sliding], cap[sliding], rtol=1e-6, atol=1e-9 * cap.max())   # measured 3.5e-16
    assert max(float(v) for v in sol.residuals().values()) <= 1e-6              # measured 4.0e-9 (complementarity)


@pytest.mark.parametrize("name", LAWS)
def test_a_centred_cap_carries_no_net_shear(name):
    """No tangential load and a scene mirror-symmetric about x = 0.5 and y = 0.5: the net shear is zero and the
    rows' shear forces are the mirror images of each other (measured: net 1.9e-15, mirror images 1.4e-15 of the
    sum of |shear|)."""
    sol = cc.solve(capped_pair(LAWS[name], s=0.0))
    assert sol.ok
    c = sol.contact
    total = float(np.abs(c.shear_force).sum())
    assert total > 0
    assert np.abs(c.shear_force.sum(axis=0)).max() <= 1e-12 * total      # measured 1.9e-15
    pts = c.points[:, :2]
    for flip in ([-1.0, 1.0], [1.0, -1.0]):
        mirrored = 0.5 + (pts - 0.5) * flip
        j = [int(np.argmin(np.linalg.norm(pts - q, axis=1))) for q in mirrored]
        np.testing.assert_allclose(pts[j], mirrored, rtol=0, atol=1e-14)
        np.testing.assert_allclose(c.shear_force[j] * flip, c.shear_force, rtol=0, atol=1e-12 * total)


@pytest.mark.parametrize("name", LAWS)
def test_the_body_order_turns_the_slip_and_the_shear(name, once):
    """The pair posed from the curved body (its nodes "sigma1", the pair's normal -z): the same displacements and
    normal forces, the slip (u^a - u^b) and the shear force on the first body of the opposite sign (measured 0:
    the same operations)."""
    ref = _capped(once, name)
    sol = cc.solve(capped_pair(LAWS[name], s=S, swap=True))
    itf = sol.scene.interfaces[0]
    assert itf.curved == 0 and itf.normal[2] == -1.0 and sol.ok
    assert _difference(sol, ref) <= 1e-12
    a, b = sol.contact, ref.contact
    i, j = np.lexsort(a.points.T), np.lexsort(b.points.T)
    F = float(np.abs(b.shear_force).sum())
    assert F > 0
    np.testing.assert_allclose(a.shear_force[i], -b.shear_force[j], rtol=0, atol=1e-12 * F)
    np.testing.assert_allclose(a.slip[i], -b.slip[j], rtol=0, atol=1e-12 * S)
    np.testing.assert_allclose(a.force[i], b.force[j], rtol=0, atol=1e-12 * float(b.force.sum()))


@pytest.mark.parametrize("name", LAWS)
def test_the_answer_turns_with_the_scene(name, once):
    """The whole scene turned by a generic rotation Q (the plane's normal then along no axis, its frame
    canonical_frame's): the displacements are Q u, the slip and shear vectors (frame components mapped to 3D)
    Q times the unturned ones: the friction is isotropic and the frame a mere basis (measured 1.5e-13, 2e-13, 6e-14
    of the scales)."""
    from scenes3d import rotation

    Q = rotation()
    ref = _capped(once, name)
    sol = cc.solve(capped_pair(LAWS[name], s=S, turn=Q))
    itf = sol.scene.interfaces[0]
    assert isinstance(itf, CurvedSurfaceInterface) and sol.ok
    scale = _scale(ref)
    for u, v in zip(sol.u, ref.u):
        np.testing.assert_allclose(u, v @ Q.T, rtol=0, atol=1e-10 * scale)
    a, b = sol.contact, ref.contact
    back = a.points @ Q
    j = [int(np.argmin(np.linalg.norm(b.points - p, axis=1))) for p in back]
    np.testing.assert_allclose(b.points[j], back, rtol=0, atol=1e-12)
    frame, frame0 = itf.frame, ref.scene.interfaces[0].frame
    F = float(np.abs(b.shear_force).sum())
    np.testing.assert_allclose(a.shear_force @ frame, (b.shear_force @ frame0)[j] @ Q.T, rtol=0, atol=1e-10 * F)
    np.testing.assert_allclose(a.slip @ frame, (b.slip @ frame0)[j] @ Q.T, rtol=0, atol=1e-10 * S)


def test_friction_refused_on_a_pair_without_slip_rows(monkeypatch):
    """An interface lacking a tangential part (none of the package's now) is still refused by name."""
    from cvxcontact.contact import surface

    monkeypatch.delattr(surface.CurvedSurfaceInterface, "tangential_jump")
    with pytest.raises(UnsupportedError, match="CurvedSurfaceInterface.*tangential_jump"):
        cc.solve(capped_pair(LAWS["tresca"], s=S))


@pytest.mark.parametrize("law", [cc.Tresca(threshold=1e8), cc.Coulomb(coefficient=0.3)], ids=["tresca", "coulomb"])
def test_a_rigid_sphere_into_a_block(law):
    """A rigid sphere of radius 0.3 m pressed 0.02 m into the aluminium block (6 x 6 x 3 cells) with friction:
    finished exactly (the friction rows' Newton), every check at rounding (measured: at most 6.5e-10, Tresca's
    stick-slip, a square root of rounding products; Coulomb 0 but equilibrium 3.7e-17)."""
    sol = cc.solve(sphere_into_block(6, radius=0.3, depth=0.02, law=law))
    assert sol.ok and sol.polished
    checks = {k: float(v) for k, v in sol.residuals().items()}
    assert {"friction cone", "stick-slip", "slip direction"} <= set(checks)
    assert max(checks.values()) <= 1e-7, checks              # measured 6.5e-10
    c = sol.contact
    assert c.active.sum() >= 1 and np.linalg.norm(c.shear_force, axis=1).max() > 0
