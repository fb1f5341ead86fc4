"""The 2D friction scenes shared by tests/test_tresca.py and tests/test_coulomb.py: a steel block 1 m x 0.5 m
on a rigid floor, pressed by p on its top (a fixtures module: the test modules do not import each other); the
awkward scenes of tests/test_friction_awkward.py (a contact that never closes, a pair whose rows all open, a
floor and a wall sharing a corner node, 2D and 3D) with exact and projected-gradient references; and
a uniformly sheared 3D layer (stuck, sliding, and on a second layer) and the independent reference of the 3D nodal Tresca law (tests/test_friction3d.py,
tests/test_friction3d_p2.py, tests/test_refusals.py).
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc

E, P, L, H = 200e9, 1e7, 1.0, 0.5
FLOOR = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def steel(nu=0.3, scale=1.0):
    return cc.materials.isotropic(E=E * scale, nu=nu)


def sheared(q, law, tied=False, nx=8, ny=4, drag=None):
    """The block under (q, -p) on its top, ``law`` on its contact; ``tied``: frictionless contact, u_x = 0 on the
    contact edges (the same edges under a second tag "base"); ``drag`` (m): ``law`` on the contact, u_x = drag on
    the contact edges (the tag "base": every row slides by it)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    if tied or drag is not None:
        m = cc.Mesh(m.points, m.triangles, {**{t: m.boundary(t) for t in m.tags}, "base": m.boundary("bottom")})
        b = cc.Body(m, steel(), contact="bottom", traction={"top": (q, -P)},
                    displacement={"base": (0.0 if tied else drag, None)})
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=None if tied else law)])
    b = cc.Body(m, steel(), contact="bottom", traction={"top": (q, -P)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def uniform_layer(tau, law, nx=4, ny=2, obstacles=(FLOOR,)):
    """The block (nu = 0) under (tau, -p) on its top and the complementary shear (0, -+tau) on its left and right
    faces: a uniform state (sigma_yy = -p, sigma_xy = tau), ``law`` against the floor (or against ``obstacles``
    that together are that floor, each reaching part of the bottom). Stuck: u = (tau y / G, -p y / E), G = E / 2
    (plane strain, nu = 0)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    b = cc.Body(m, steel(nu=0.0), contact="bottom",
                traction={"top": (tau, -P), "left": (0.0, -tau), "right": (0.0, tau)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", o, law=law) for o in obstacles])


def pushed(law, s=1e-4, obstacles=(FLOOR,)):
    """The nu = 0 block pushed by u_x = s on its left face, pressed by p: (its mesh, the scene); ``law`` against
    the floor (or against each of ``obstacles``, one pair each: two coincident floors overlap)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4)
    b = cc.Body(m, steel(nu=0.0), contact="bottom", traction={"top": (0.0, -P)}, displacement={"left": (s, None)})
    return m, cc.Scene(b, contacts=[cc.Contact(b, "bottom", o, law=law) for o in obstacles])


def patch(law, tied=False, nx=8, ny=4):
    """The block with its left face above y = H / 4 held along x (u_x = 0: not the corner, whose row would then
    carry an undetermined force), pressed by p on [0.25, 0.625] of its top: held without
    friction too (``law`` None or cc.Signorini()), its base slides outwards under Poisson's expansion.
    ``tied``: frictionless contact with u_x = 0 on the contact edges (the same edges under a second tag "base")."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny, segments={"load": ("top", 0.25, 0.625), "side": ("left", H / 4, H)})
    held = {"side": (0.0, None)}
    if tied:
        m = cc.Mesh(m.points, m.triangles, {**{t: m.boundary(t) for t in m.tags}, "base": m.boundary("bottom")})
        held["base"] = (0.0, None)
    b = cc.Body(m, steel(), contact="bottom", traction={"load": (0.0, -P)}, displacement=held)
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=None if tied else law)])


FLOOR3D = cc.Rigid.plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))


def box(q, law, tied=False, nu=0.3, push=None, n=3):
    """A steel 1 m cube (n x n x 2 cells) on a rigid floor under (q_x, q_y, -p) on its top, ``law`` on its
    contact (tests/test_friction3d.py's scenes); ``tied``: frictionless, u_x = u_y = 0 on the contact faces;
    ``push`` (s_x, s_y): its left face moved so along x, y (then held there without friction too)."""
    mesh = cc.box(nx=n, ny=n, nz=2)
    held = {} if push is None else {"left": (push[0], push[1], None)}
    if tied:
        mesh = cc.TetMesh(mesh.points, mesh.tets, {**{t: mesh.boundary(t) for t in mesh.tags},
                                                   "base": mesh.boundary("bottom")})
        held["base"] = (0.0, 0.0, None)
    b = cc.Body(mesh, steel(nu=nu), contact="bottom", traction={"top": (q[0], q[1], -P)}, displacement=held)
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR3D, law=None if tied else law)])


def slid_cube(s, p=1e3, g=1e2, n=3, cell="tetra"):
    """The 1 m cube (n x n x 2 cells ``cell``, nu = 0) pressed by p on its top and moved by u_x = s on its left
    face across the rigid plane z = 0, Tresca's ``g`` (g < p): past the onset every row slides along x, its
    friction forces summing to g (N: the area is 1 m^2), and a larger s carries the same deformation a rigid
    distance further; translation along y and rotation about x are held by the contact alone."""
    body = cc.Body(cc.box(nx=n, ny=n, nz=2, cell=cell), steel(nu=0.0), contact="bottom",
                   traction={"top": (0.0, 0.0, -p)},
                   displacement={"left": (s, None, None)})
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=cc.Tresca(g))])


DIAGONAL3 = np.array([np.cos(0.5), np.sin(0.5)])
"""The in-plane direction of the 3D scenes' shear (a diagonal of the frame (x, y))."""


def uniform_layer3d(tau, law, n=2, cell="tetra", obstacles=(FLOOR3D,)):
    """A unit box (n x n x 1 cells, nu = 0) under (tau_x, tau_y, -p) on its top along :data:`DIAGONAL3` and the
    complementary shear on its sides, so that the state is uniform (sigma_zz = -p, sigma_xz = tau_x, sigma_yz =
    tau_y), ``law`` against the rigid plane z = 0 (or against ``obstacles`` that together are that plane, each
    reaching part of the bottom). Stuck: u = (tau_x z / G, tau_y z / G, -p z / E), G = E / 2."""
    q = tau * DIAGONAL3
    body = cc.Body(cc.box(nx=n, ny=n, nz=1, cell=cell), steel(nu=0.0), contact="bottom",
                   traction={"top": (q[0], q[1], -P), "left": (0.0, 0.0, -q[0]), "right": (0.0, 0.0, q[0]),
                             "front": (0.0, 0.0, -q[1]), "back": (0.0, 0.0, q[1])})
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", o, law=law) for o in obstacles])


def _side_shear(q):
    """The complementary shear (tractions, Pa) on the sides of a unit box under the shear ``q`` (q_x, q_y)."""
    return {"left": (0.0, 0.0, -q[0]), "right": (0.0, 0.0, q[0]), "front": (0.0, 0.0, -q[1]), "back": (0.0, 0.0, q[1])}


def sliding_layer3d(g, s=1e-4, n=2):
    """The layer of :func:`uniform_layer3d` (tetrahedra) with its top moved by s along :data:`DIAGONAL3` (pressed by
    p there: a second tag "lid" on the top faces) and the complementary shear of g on its sides, against the
    rigid plane z = 0 with Tresca's ``g``: for s > g / G it slides, sigma_xz, sigma_yz = g along the diagonal, the
    slip s - g / G (G = E / 2)."""
    mesh = cc.box(nx=n, ny=n, nz=1)
    mesh = cc.TetMesh(mesh.points, mesh.tets, {**{t: mesh.boundary(t) for t in mesh.tags}, "lid": mesh.boundary("top")})
    d = s * DIAGONAL3
    body = cc.Body(mesh, steel(nu=0.0), contact="bottom", traction={"top": (0.0, 0.0, -P), **_side_shear(g * DIAGONAL3)},
                   displacement={"lid": (d[0], d[1], None)})
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=cc.Tresca(g))])


LAYERS3D = {"stuck": lambda: uniform_layer3d(0.2 * P, cc.Tresca(2 * P)), "sliding": lambda: sliding_layer3d(1e5)}
"""The 3D layers on the plane whose P2 "gamma3" answers several modules read (tests/test_friction_p2_gamma3.py,
test_friction_hencky3d_p2.py): the uniform layer stuck under Tresca 2 p (tau = 0.2 p), the layer sliding under
Tresca 1e5 Pa (s = 1e-4 m)."""


def layer_key(name):
    """(key, make) of conftest's ``shared`` for the P2 "gamma3" answer of ``LAYERS3D[name]``:
    ``shared(*layer_key(name))``."""
    return ("P2 layer on a plane, gamma3", name), lambda: cc.solve(LAYERS3D[name](), "gamma3", degree=2)


NEVER_YIELDING = cc.materials.hencky(E=E, nu=0.0, sigma_y=1e15, h=0.1)
"""A Hencky material of the layers' steel (nu = 0) whose yield stress no strain reaches: its answers are the linear
material's."""

STUCK_LAWS = {"tresca": lambda tau: cc.Tresca(10 * tau), "coulomb": lambda tau: cc.Coulomb(1.0)}
"""The laws that hold the uniform layer of :func:`uniform_layer3d` stuck under the shear tau."""


def never_yielding_key(law):
    """(key, make) of conftest's ``shared`` for the P2 "gamma3" answer (a ResidualWarning an error) of the uniform
    layer (:func:`uniform_layer3d`, tau = 0.2 p) of the :data:`NEVER_YIELDING` Hencky material under
    ``STUCK_LAWS[law]`` ("tresca": 10 tau; "coulomb": mu = 1), stuck: tests/test_friction_hencky3d_p2.py and
    test_refusals.py read it (``shared(*never_yielding_key(law))``)."""

    def make():
        tau = 0.2 * P
        layer = uniform_layer3d(tau, STUCK_LAWS[law](tau))
        body = layer.bodies[0].with_changes(material=NEVER_YIELDING)
        with warnings.catch_warnings():
            warnings.simplefilter("error", cc.ResidualWarning)
            return cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=layer.contacts[0].law)]),
                            "gamma3", degree=2)

    return ("P2 layer of a never-yielding Hencky body on a plane, stuck, gamma3", law), make


def uniform_pair3d(tau, law, swap=False, n=2):
    """Two unit layers (n x n x 1 tetrahedra each, matching faces, nu = 0) in the uniform state of
    :func:`uniform_layer3d`, the upper one on the lower one clamped at z = -1, ``law`` between them; ``swap``: the
    pair posed from the lower layer. Stuck: u = (tau_x (z + 1) / G, tau_y (z + 1) / G, -p (z + 1) / E)."""
    q = tau * DIAGONAL3
    a = cc.Body(cc.box(nx=n, ny=n, nz=1), steel(nu=0.0), contact="bottom",
                traction={"top": (q[0], q[1], -P), **_side_shear(q)}, name="upper")
    lower = cc.box(nx=n, ny=n, nz=1)
    b = cc.Body(lower.with_points(lower.points - [0.0, 0.0, 1.0]), steel(nu=0.0), contact="top", clamped="bottom",
                traction=_side_shear(q), name="lower")
    pair = cc.Contact(b, "top", a, "bottom", law=law) if swap else cc.Contact(a, "bottom", b, "top", law=law)
    return cc.Scene(a, b, contacts=[pair])


def tresca_reference(Tu, Kzz, fz, u_fixed, bottom, capacity):
    """(u (n, 3), R (m, 3)): the nodal Tresca law on the nodes ``bottom`` of a body against the plane z = 0 solved
    independently of the package: the body condensed onto those nodes' dofs (``Tu`` the free-dof basis, ``Kzz``
    and ``fz`` the reduced stiffness and load, ``u_fixed`` the prescribed part), its dual QP by
    :func:`projected_gradient_tresca` with the rows' ``capacity`` (N), the displacements back from the forces R."""
    import scipy.sparse as sp

    dofs = np.ravel(np.column_stack([3 * bottom, 3 * bottom + 1, 3 * bottom + 2]))
    Pc = sp.csr_matrix((np.ones(len(dofs)), (np.arange(len(dofs)), dofs)), shape=(len(dofs), Tu.shape[0]))
    PT = (Pc @ Tu).toarray()
    W = PT @ np.linalg.solve(Kzz, PT.T)                                        # m per N
    q = PT @ np.linalg.solve(Kzz, fz) + Pc @ u_fixed
    R = projected_gradient_tresca(W, q, capacity)
    return (Tu @ np.linalg.solve(Kzz, fz + PT.T @ R) + u_fixed).reshape(-1, 3), R.reshape(-1, 3)


def projected_gradient_tresca(W, q, capacity, iterations=20000):
    """The nodal Tresca law's dual QP (module docstring) by FISTA with adaptive restart: R (t1, t2, n per node)."""
    n = len(q) // 3

    def project(V):
        V = V.reshape(n, 3).copy()
        norm = np.linalg.norm(V[:, :2], axis=1)
        V[:, :2] *= np.minimum(1.0, capacity / np.maximum(norm, np.finfo(float).tiny))[:, None]
        V[:, 2] = np.maximum(V[:, 2], 0.0)
        return V.ravel()

    def energy(X):
        return 0.5 * X @ W @ X + q @ X

    step = 1.0 / np.linalg.eigvalsh(W).max()
    R = Y = np.zeros(3 * n)
    t, restarted = 1.0, False
    for _ in range(iterations):
        new = project(Y - step * (W @ Y + q))
        if np.abs(new - R).max() <= 1e-15 * np.abs(new).max():
            return new
        if energy(new) > energy(R):                        # restart the momentum; twice in a row: at rounding
            if restarted:
                return R
            Y, t, restarted = R, 1.0, True
            continue
        restarted = False
        t_new = 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * t * t))
        Y, R, t = new + (t - 1.0) / t_new * (new - R), new, t_new
    return R


def walled(law, wall_law=None, gap=0.0):
    """The block of :func:`sheared` (no shear on its top) pushed by 0.3 p on its left face against a rigid wall at
    x = L + ``gap``, ``law`` on the floor, ``wall_law`` (None: frictionless) on the upper half of its right face
    against the wall (not the corner: its floor row's slip and its wall row would be one direction): a scene with
    two pairs, friction on one of them (``gap`` 1 mm: the wall never touched, the floor's friction holds it)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4, segments={"side": ("right", H / 2, H)})
    b = cc.Body(m, steel(), contact="bottom", traction={"top": (0.0, -P), "left": (0.3 * P, 0.0)})
    wall = cc.Rigid.plane(point=(L + gap, 0.0), normal=(-1.0, 0.0))
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law), cc.Contact(b, "side", wall, law=wall_law)])


def pair2d(law, q=0.02 * P, condition="sigma1"):
    """The block (1 m x 0.5 m, 7 x 3 cells) under (q, -p) on its top on a wider clamped block (1.4 m x 0.5 m, 9 x 3
    cells: non-matching lines), ``law`` between them under ``condition``."""
    a = cc.Body(cc.rectangle(x=(0.0, L), y=(0.0, H), nx=7, ny=3), steel(), contact="bottom", traction={"top": (q, -P)})
    b = cc.Body(cc.rectangle(x=(-0.2, L + 0.2), y=(-H, 0.0), nx=9, ny=3), steel(), contact="top", clamped="bottom")
    return cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=law, condition=condition)])


def pair2d_key():
    """(key, make) of conftest's ``shared`` for the P2 "gamma3" answer of :func:`pair2d` under Tresca 0.03 p sheared
    by 0.02 p, both lines under "gamma3", with the calls of the finish's one-row pivots (``finish.friction._pivots``,
    a list: one entry per call): (solution, calls), read by tests/test_friction_finish.py and
    test_friction_p2_gamma3.py (``shared(*pair2d_key())``)."""

    def make():
        from cvxcontact.backends.finish import friction as finish

        pivots, calls = finish._pivots, []

        def spy(*args, **kwargs):
            calls.append(1)
            return pivots(*args, **kwargs)

        with pytest.MonkeyPatch.context() as monkeypatch:
            monkeypatch.setattr(finish, "_pivots", spy)
            return cc.solve(pair2d(cc.Tresca(0.03 * P), 0.02 * P, condition="gamma3"), condition="gamma3",
                            degree=2), calls

    return ("P2 pair of non-matching lines, gamma3, Tresca 0.03 p",), make


def opened(law, dim=2):
    """The block (2D: 1 m x 0.5 m, 8 x 4 cells; 3D: the unit cube, 3 x 3 x 2 cells) clamped on its left face and
    pulled by p along x on its right face, on a rigid floor at its base (gap 0), ``law`` there: Poisson's
    contraction lifts the base, so the floor never touches (every row open)."""
    if dim == 2:
        b = cc.Body(cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4), steel(), contact="bottom", clamped="left",
                    traction={"right": (P, 0.0)})
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])
    b = cc.Body(cc.box(nx=3, ny=3, nz=2), steel(), contact="bottom", clamped="left",
                traction={"right": (P, 0.0, 0.0)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR3D, law=law, condition="sigma1")])


def unloaded(law, dim=2):
    """The block of :func:`opened` with no load at all: the answer is 0."""
    return opened(law, dim).with_loads(0, traction={})


def opened_pair(law, dim=2):
    """A block clamped on its left face and lifted by p on its top, over a wider block clamped on its bottom
    (2D: 1 m x 0.5 m, 7 x 3 cells on 1.4 m x 0.5 m, 9 x 3 cells; 3D: a unit box, 2 x 2 x 1 cells, on another of 3 x
    3 x 1 cells: non-matching faces) across a gap of 0.1 mm, ``law`` between them under "sigma1" (nodal rows at the
    upper block's nodes): the pair opens further, every row open."""
    if dim == 2:
        a = cc.Body(cc.rectangle(x=(0.0, L), y=(0.0, H), nx=7, ny=3), steel(), contact="bottom", clamped="left",
                    traction={"top": (0.0, P)})
        b = cc.Body(cc.rectangle(x=(-0.2, L + 0.2), y=(-H, 0.0), nx=9, ny=3), steel(), contact="top",
                    clamped="bottom")
    else:
        a = cc.Body(cc.box(nx=2, ny=2, nz=1), steel(), contact="bottom", clamped="left",
                    traction={"top": (0.0, 0.0, P)})
        lower = cc.box(nx=3, ny=3, nz=1)
        b = cc.Body(lower.with_points(lower.points - [0.0, 0.0, 1.0]), steel(), contact="top", clamped="bottom")
    return cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=law, condition="sigma1", gap=1e-4)])


WALL = cc.Rigid.plane(point=(L, 0.0), normal=(-1.0, 0.0))


def cornered(law, s=2e-5, d=2e-5, nx=8, ny=4):
    """The block (nu = 0.3) moved by u_x = s on its left face and u_y = -d on its top, on the rigid floor y = 0
    (``law``) and against the rigid wall x = L (frictionless) along its whole right face: the floor's and the
    wall's rows share the corner node (L, 0), where the floor row's slip and the wall row move the same
    displacement. Returns (the body, the scene)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    b = cc.Body(m, steel(), contact="bottom", displacement={"left": (s, None), "top": (None, -d)})
    return b, cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law), cc.Contact(b, "right", WALL)])


def cornered_reference(body, capacity):
    """(u (n, 2), floor forces (normal, tangential) per bottom node, wall forces per right node) of
    :func:`cornered` solved independently of the package's contact code: the body's stiffness condensed onto its
    bottom and right nodes, the dual of the nodal Tresca law (``capacity`` N/m per bottom node, sorted by x) and
    the wall's Signorini rows a bound-constrained QP, solved exactly by bounded-variable least squares (an active
    set method: finite, its answer a least-squares solve on the free set)."""
    import scipy.sparse as sp
    from scipy.optimize import lsq_linear

    from cvxcontact.fem.space import P1

    system = P1().assemble_loads(body, P1().assemble_matrices(body))   # SI, the prescribed faces lifted
    Tu, u_fixed = system.Tu, system.u_fixed
    K = (Tu.T @ system.Kuu @ Tu).toarray()
    f = Tu.T @ system.f
    pts = body.mesh.points
    bottom = np.flatnonzero(np.isclose(pts[:, 1], 0.0))
    bottom = bottom[np.argsort(pts[bottom, 0])]
    right = np.flatnonzero(np.isclose(pts[:, 0], L))
    # rows r . u <= gap: the floor's -u_y <= 0 and the wall's u_x <= 0; the friction rows u_x (|R| <= capacity)
    dofs = np.concatenate([2 * bottom + 1, 2 * right, 2 * bottom])
    signs = np.concatenate([-np.ones(len(bottom)), np.ones(len(right)), np.ones(len(bottom))])
    rows = sp.csr_matrix((signs, (np.arange(len(dofs)), dofs)), shape=(len(dofs), Tu.shape[0]))
    PT = (rows @ Tu).toarray()
    W = PT @ np.linalg.solve(K, PT.T)
    q = -(PT @ np.linalg.solve(K, f) + rows @ u_fixed)             # min 1/2 R^T W R + q^T R over the bounds
    lower = np.concatenate([np.zeros(len(bottom) + len(right)), -capacity])
    upper = np.concatenate([np.full(len(bottom) + len(right), np.inf), capacity])
    e, V = np.linalg.eigh(W)
    keep = e > 1e-12 * e.max()                                     # W is singular where two rows share a dof
    A = np.sqrt(e[keep])[:, None] * V[:, keep].T                    # W = A^T A, and A^T b = -q
    b = -(V[:, keep].T @ q) / np.sqrt(e[keep])
    R = lsq_linear(A, b, bounds=(lower, upper), method="bvls", tol=1e-15).x
    u = (Tu @ np.linalg.solve(K, f - PT.T @ R) + u_fixed).reshape(-1, 2)
    n = len(bottom)
    return u, (R[:n], R[n + len(right):]), R[n:n + len(right)]


WALL3D = cc.Rigid.plane(point=(1.0, 0.0, 0.0), normal=(-1.0, 0.0, 0.0))


def cornered3d(law, s=2e-5, d=2e-5, n=3):
    """The 3D twin of :func:`cornered`: the unit cube (n x n x 2 cells) moved by u_x = s on its left face and u_z =
    -d on its top, held along y on its front face, on the rigid floor z = 0 (``law``) and against the rigid wall x =
    1 (frictionless) along its whole right face, both under "sigma1": the floor's and the wall's rows share the
    nodes of the edge x = 1, z = 0 (the floor rows' slip along x and the wall rows move the same displacements; the
    left face's bottom edge has a prescribed slip along x, its y component moved). Returns (the body, the
    scene)."""
    b = cc.Body(cc.box(nx=n, ny=n, nz=2), steel(), contact="bottom",
                displacement={"left": (s, None, None), "front": (None, 0.0, None), "top": (None, None, -d)})
    return b, cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR3D, law=law, condition="sigma1"),
                                    cc.Contact(b, "right", WALL3D, condition="sigma1")])


def cornered3d_reference(body, capacity):
    """(u (n, 3), floor forces (m, 3): t_x, t_y, n per bottom node): :func:`cornered3d` with P1 tetrahedra and the
    nodal Tresca law (``capacity`` N per bottom node) solved independently of the package's contact code: the body
    condensed onto its bottom and right nodes, the dual QP of the floor's cones and the wall's Signorini rows (a
    wall node's group: its normal -u_x, tangential components of capacity 0) by :func:`projected_gradient_tresca`."""
    import scipy.sparse as sp

    from cvxcontact.fem.space import P1Tet

    system = P1Tet().assemble_loads(body, P1Tet().assemble_matrices(body))
    Tu, u_fixed = system.Tu, system.u_fixed
    K = (Tu.T @ system.Kuu @ Tu).toarray()
    f = Tu.T @ system.f
    pts = body.mesh.points
    bottom = np.flatnonzero(np.isclose(pts[:, 2], 0.0))
    right = np.flatnonzero(np.isclose(pts[:, 0], 1.0))
    # groups (t1, t2, n) of rows Pc: the reaction R enters as +Pc^T R, the normal component >= 0 (tresca_reference)
    dofs = np.concatenate([np.column_stack([3 * bottom, 3 * bottom + 1, 3 * bottom + 2]),
                           np.column_stack([3 * right + 1, 3 * right + 2, 3 * right])]).ravel()
    signs = np.concatenate([np.ones(3 * len(bottom)), np.tile([1.0, 1.0, -1.0], len(right))])
    Pc = sp.csr_matrix((signs, (np.arange(len(dofs)), dofs)), shape=(len(dofs), Tu.shape[0]))
    PT = (Pc @ Tu).toarray()
    W = PT @ np.linalg.solve(K, PT.T)
    q = PT @ np.linalg.solve(K, f) + Pc @ u_fixed
    R = projected_gradient_tresca(W, q, np.concatenate([capacity, np.zeros(len(right))]), iterations=40000)
    u = (Tu @ np.linalg.solve(K, f + PT.T @ R) + u_fixed).reshape(-1, 3)
    return u, R.reshape(-1, 3)[:len(bottom)]


def pressed_disk(law, depth=1e-4, nx=8, ny=4, mirrored=False):
    """The block 1 m x 0.5 m (nx x ny cells) clamped on its top and pressed ``depth`` into a rigid disk of radius 1 m
    below x = 0 (tests/test_friction_p2_gamma3.py): under the P2 cones its contact ends inside the elements beside
    x = 0. ``mirrored``: the mesh reflected about x = 0 (the same scene, its triangles the mirror images)."""
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=nx, ny=ny)
    if mirrored:
        m = cc.Mesh(m.points * [-1.0, 1.0], m.triangles[:, ::-1], {t: m.boundary(t) for t in m.tags})
    body = cc.Body(m, steel(), contact="bottom", clamped="top")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.circle(center=(0.0, -1.0), radius=1.0 + depth),
                                               law=law)])


def dragged_disk(law, s=1e-5, d=1e-4, nx=8, ny=4):
    """The block of :func:`pressed_disk` moved by (s, -d) on its top onto the disk of radius 1 m (touching at x = 0):
    dragged over it, the contact ends inside the elements beside x = 0."""
    body = cc.Body(cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=nx, ny=ny), steel(), contact="bottom",
                   displacement={"top": (s, -d)})
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.circle(center=(0.0, -1.0), radius=1.0),
                                               law=law)])


def walled_disk(law, s=1e-5, d=1e-4):
    """The block of :func:`dragged_disk` moved by (s, -d) on its top onto the disk (``law``, under "gamma3") and
    pressed by that drag against a frictionless rigid wall touching its right face at x = 0.5 (its middle half,
    0.125 <= y <= 0.375, under "sigma1": not the top corner the top's displacement holds). Solve it with
    ``degree=2`` alone (the conditions are the pairs'). The 2D polish at the tangency points declines there
    (measured: its tangency structure unsettled in 10 rounds; docs/howto/friction.md; Tresca under the default
    kernels, Coulomb under all but Sandybridge) and the cut rounds' answer stands."""
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=8, ny=4, segments={"side": ("right", 0.125, 0.375)})
    body = cc.Body(m, steel(), contact="bottom", displacement={"top": (s, -d)})
    disk = cc.Contact(body, "bottom", cc.Rigid.circle(center=(0.0, -1.0), radius=1.0), law=law, condition="gamma3")
    wall = cc.Rigid.plane(point=(0.5, 0.0), normal=(-1.0, 0.0))
    return cc.Scene(body, contacts=[disk, cc.Contact(body, "side", wall, condition="sigma1")])


def tilted(law, nx=8, q=0.3):
    """A free 1 m x 1 m block (nx x 8 cells) on the floor under (q p, -p) on its top: its left heel lifts (the
    contact ends inside an element for nx = 8, at a node for nx = 7), nothing but friction holds it along x."""
    b = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 1.0), nx=nx, ny=8), steel(), contact="bottom",
                traction={"top": (q * P, -P)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def sheared_hencky(law, p=1e8, nx=8, ny=4):
    """A Hencky block 1 m x 0.5 m (E = 200 GPa, nu = 0.3, sigma_y = p, h = 0.1: it yields at its corners) on the
    floor under (p / 2, -p) on its top: the contact sticks in its middle and slips towards its ends under a threshold
    0.6 p (Coulomb: mu = 0.6) (tests/test_friction_hencky.py, benchmarks/friction_p2_declines.py)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    b = cc.Body(m, cc.materials.hencky(E=E, nu=0.3, sigma_y=p, h=0.1), contact="bottom",
                traction={"top": (0.5 * p, -p)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


P2_CONES = {"condition": "gamma3", "degree": 2}
"""The options of the P2 "everywhere" cones ("gamma3" with degree=2)."""


def tilted_key(law, nx):
    """(key, make) of conftest's ``shared`` for the P2 "gamma3" answer (:data:`P2_CONES`) of :func:`tilted` (q = 0.3)
    under ``law`` with ``nx`` cells along x: tests/test_friction_p2_cuts.py and test_friction_p2_gamma3_checks.py
    read it (``shared(*tilted_key(law, nx))``)."""
    return ("P2 tilted free block on the floor", law, nx), lambda: cc.solve(tilted(law, nx), **P2_CONES)


def finished_p2(scene, made=None):
    """The answer of ``scene`` under the P2 cones (:data:`P2_CONES`), finished by the friction Newton: raises on a
    ResidualWarning, asserts ok, polished and the finish. ``made`` (optional): a callable returning that answer
    solved elsewhere (conftest's ``shared``, its warnings raised again), read under the same filters instead."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(scene, **P2_CONES) if made is None else made()
    assert sol.ok and sol.polished and sol.info.finish == cc.Finish.FRICTION_NEWTON, sol.info.declined
    assert sol.info.declined is None
    return sol


def declined_p2(scene, options=P2_CONES):
    """The answer of ``scene`` under the P2 cones (``options``: :data:`P2_CONES`, or ``degree=2`` alone where the
    pairs name their conditions) where the finish at the exact tangency points (3D: and on the ridges) declines
    after the cut rounds: the cuts' answer, labelled as a declined finish (a ResidualWarning naming the decline and
    the cut rounds' answer as what is kept, not polished, no finish, ``info.declined`` saying why, the interior
    point's route); asserts those."""
    with pytest.warns(cc.ResidualWarning,
                      match=r"was declined \(.*\); the cut rounds' answer is kept \(sol.polished is False\)"):
        sol = cc.solve(scene, **options)
    assert not sol.polished and sol.info.finish is None and sol.info.route == cc.Route.INTERIOR_POINT_FRICTION
    assert "not finished at the exact tangency points" in str(sol.info.declined), sol.info.declined
    return sol


def watched_p2(scene):
    """(:func:`finished_p2` of ``scene``, the outcomes of the 3D friction finish at the tangency points or ridges
    during that solve: ``frictiontangency._polish``, True where it finished, one per call)."""
    from cvxcontact.backends import frictiontangency
    from cvxcontact.backends.finish import Declined

    kept, seen = frictiontangency._polish, []

    def spy(*args):
        out = kept(*args)
        seen.append(not isinstance(out, Declined))
        return out

    frictiontangency._polish = spy
    try:
        return finished_p2(scene), seen
    finally:
        frictiontangency._polish = kept


def capped_pair(law, radius=500.0, d=3e-4, s=0.0, n=(6, 4), condition="sigma2", swap=False, turn=None,
                span=(0.0, 1.0), centre=(0.5, 0.5), length=1.0, piezo=False, volts=0.0, order=None, floor=None,
                dome=None, traction=None):
    """A curved part against a planar one in 3D (node-to-face, ``contact/surface.CurvedSurfaceInterface``): a steel
    block (0, 1)^2 x (-0.5, 0) m (n[0] x n[0] x 2 cells, clamped at its base, planar "top") under a steel block
    (0, 1)^2 x (0, 0.5) (n[1] x n[1] x 2 cells) whose "bottom" is lifted onto the spherical cap of ``radius`` (m)
    touching z = 0 at the centre (each node by z_s (1 - z / 0.5), z_s = r^2 / (R + sqrt(R^2 - r^2)); None: flat),
    its top moved by (s, 0, -d); ``law`` on the pair posed from the lower block under ``condition`` (``swap``: from
    the upper block, under "sigma1"). Both grids are mirror-symmetric about x = 0.5 and y = 0.5, so with s = 0 the
    whole scene is. ``turn``: a rotation matrix applied to the whole scene (points and prescribed displacement).
    ``span``: the upper block's x and y range instead of (0, 1) (wider: nodes of its bottom miss the lower top);
    ``centre``: the cap's lowest point (x, y); ``length``: every length (the blocks, the radius, ``span``,
    ``centre``; not d, s) times it; ``piezo``: both blocks PZT-5A (poled along z), the lower grounded at its base,
    the upper's top at ``volts`` (V); ``order``: a seed renumbering both meshes' nodes (``TetMesh.renumbered`` with
    a random permutation of each: the same bodies, another numbering); ``floor``: the lower block clamped on its
    "left" face only, its "bottom" on the rigid plane z = -0.5 under the law ``floor`` (a second pair, rigid);
    ``dome``: a radius (m): the lower block's top lifted onto a dome of that radius (highest at the centre, z = 0)
    and the upper block's bottom left flat (``radius`` ignored): the curved part on the lower body, the planar
    one facing down; ``traction`` (3,) Pa: the upper block's top loaded by it instead of moved (nothing else holds
    that block: its rigid motions along the plane are held by the friction alone)."""
    L = float(length)
    lower = cc.box(x=(0.0, L), y=(0.0, L), z=(-0.5 * L, 0.0), nx=n[0], ny=n[0], nz=2)
    upper = cc.box(x=tuple(L * np.asarray(span)), y=tuple(L * np.asarray(span)), z=(0.0, 0.5 * L), nx=n[1],
                   ny=n[1], nz=2)
    if dome is not None:
        p = np.array(lower.points)
        r2 = (p[:, 0] - centre[0] * L) ** 2 + (p[:, 1] - centre[1] * L) ** 2
        p[:, 2] -= r2 / (dome * L + np.sqrt((dome * L) ** 2 - r2)) * (1.0 + p[:, 2] / (0.5 * L))
        lower, radius = lower.with_points(p), None
    if radius is not None:
        p = np.array(upper.points)
        R = radius * L
        r2 = (p[:, 0] - centre[0] * L) ** 2 + (p[:, 1] - centre[1] * L) ** 2
        p[:, 2] += r2 / (R + np.sqrt(R ** 2 - r2)) * (1.0 - p[:, 2] / (0.5 * L))
        upper = upper.with_points(p)
    if order is not None:
        rng = np.random.default_rng(order)
        lower, upper = (m.renumbered(rng.permutation(len(m.points))) for m in (lower, upper))
    moved = np.array([s, 0.0, -d])
    if turn is not None:
        lower, upper = (m.with_points(np.asarray(m.points) @ np.asarray(turn).T) for m in (lower, upper))
        moved = np.asarray(turn) @ moved
    material = cc.materials.PZT5A if piezo else steel()
    grounded, driven = ({"grounded": "bottom"}, {"potential": {"top": volts}}) if piezo else ({}, {})
    a = cc.Body(lower, material, clamped="bottom" if floor is None else "left", contact="top", name="lower",
                **grounded)
    held = {"displacement": {"top": tuple(moved)}} if traction is None else {"traction": {"top": tuple(traction)}}
    b = cc.Body(upper, material, contact="bottom", name="upper", **held, **driven)
    flat = "sigma1" if swap else condition
    if dome is not None:
        flat = "sigma2" if swap else "sigma1"
    pair = (cc.Contact(b, "bottom", a, "top", condition=flat, law=law) if swap
            else cc.Contact(a, "top", b, "bottom", condition=flat, law=law))
    if floor is None:
        return cc.Scene(a, b, contacts=[pair])
    plane = cc.Rigid.plane(point=(0.0, 0.0, -0.5 * L), normal=(0.0, 0.0, 1.0))
    return cc.Scene(a, b, contacts=[pair, cc.Contact(a, "bottom", plane, law=floor)])


def two_caps(laws, radius=50.0, d=3e-4, s=1e-4, n=(6, 3)):
    """Two curved parts on one planar part (two node-to-face pairs): the steel block (0, 1)^2 x (-0.5, 0) m of
    :func:`capped_pair` (n[0] x n[0] x 2 cells, clamped at its base) under two steel blocks (0, 0.5) x (0, 1) and
    (0.5, 1) x (0, 1) (x, y; n[1] x 2 n[1] x 2 cells, 0 < z < 0.5) whose bottoms are lifted onto spherical caps of
    ``radius`` (m) centred below each, their tops moved by (s, 0, -d) and (0, -s, -d); pair i (the lower "top"
    against block i's "bottom", "sigma2") under ``laws[i]``."""
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=n[0], ny=n[0], nz=2)
    a = cc.Body(lower, steel(), clamped="bottom", contact="top", name="lower")
    bodies, pairs = [a], []
    for i, (x, moved, law) in enumerate(zip(((0.0, 0.5), (0.5, 1.0)), ((s, 0.0, -d), (0.0, -s, -d)), laws)):
        m = cc.box(x=x, y=(0.0, 1.0), z=(0.0, 0.5), nx=n[1], ny=2 * n[1], nz=2)
        p = np.array(m.points)
        r2 = (p[:, 0] - sum(x) / 2) ** 2 + (p[:, 1] - 0.5) ** 2
        p[:, 2] += r2 / (radius + np.sqrt(radius ** 2 - r2)) * (1.0 - p[:, 2] / 0.5)
        b = cc.Body(m.with_points(p), steel(), displacement={"top": moved}, contact="bottom", name=f"cap {i}")
        bodies.append(b)
        pairs.append(cc.Contact(a, "top", b, "bottom", condition="sigma2", law=law))
    return cc.Scene(*bodies, contacts=pairs)


def uniform_stack(tau, law, conditions=("gamma3", "sigma1"), nx=(4, 3, 5), cell="triangle"):
    """Three blocks (L x H each, ``nx`` cells across: top, middle, bottom; non-matching lines by default; nu = 0)
    stacked on y in [-2H, H], the lowest clamped at its base, in the uniform state of :func:`uniform_layer` (the
    top block under (tau, -p), the complementary shear (0, -+tau) on every block's sides), ``law`` on both pairs,
    the upper pair (top on middle) under ``conditions[0]``, the lower one under ``conditions[1]``. Stuck: u =
    (tau (y + 2H) / G, -p (y + 2H) / E), G = E / 2, exact in P2 (and Q2: ``cell="quad"``)."""
    side = {"left": (0.0, -tau), "right": (0.0, tau)}
    blocks = []
    for k, (n, y0, name) in enumerate(zip(nx, (0.0, -H, -2 * H), ("top", "middle", "bottom"))):
        m = cc.rectangle(x=(0.0, L), y=(y0, y0 + H), nx=n, ny=2, cell=cell)
        load = {**side, "top": (tau, -P)} if k == 0 else side
        blocks.append(cc.Body(m, steel(nu=0.0), contact="top" if k == 2 else "bottom", traction=load, name=name,
                              **({"clamped": "bottom"} if k == 2 else {})))
    top, middle, bottom = blocks
    return cc.Scene(*blocks, contacts=[cc.Contact(top, "bottom", middle, "top", law=law, condition=conditions[0]),
                                       cc.Contact(middle, "bottom", bottom, "top", law=law, condition=conditions[1])])


def rolled_stack(law, conditions=("gamma3", "sigma1"), q=0.05 * P, nx=(4, 4, 4)):
    """Three steel blocks (nu = 0.3; L x H each, ``nx`` cells across, the "right" diagonal) stacked on y in
    [-2H, H], each held along x on its left face (u_x = 0), the lowest clamped at its base, the top one under (q,
    -p): Poisson's expansion slides the upper blocks over the clamped one without friction; ``law`` on both pairs,
    the upper under ``conditions[0]``, the lower under ``conditions[1]``. With matching ``nx`` and a threshold
    that holds them, every row stuck: the answer of :func:`rolled_union`, the one body they make."""
    blocks = []
    for k, (n, y0, name) in enumerate(zip(nx, (0.0, -H, -2 * H), ("top", "middle", "bottom"))):
        m = cc.rectangle(x=(0.0, L), y=(y0, y0 + H), nx=n, ny=2, diagonal="right")
        extra = {"traction": {"top": (q, -P)}} if k == 0 else {}
        held = {"left": (0.0, None), **({"bottom": (0.0, 0.0)} if k == 2 else {})}
        blocks.append(cc.Body(m, steel(), contact="top" if k == 2 else "bottom", displacement=held, name=name,
                              **extra))
    top, middle, bottom = blocks
    return cc.Scene(*blocks, contacts=[cc.Contact(top, "bottom", middle, "top", law=law, condition=conditions[0]),
                                       cc.Contact(middle, "bottom", bottom, "top", law=law, condition=conditions[1])])


def rolled_union(q=0.05 * P, n=4):
    """The one body (L x 3H on y in [-2H, H], n x 6 cells, the "right" diagonal: the triangles of
    :func:`rolled_stack`'s three blocks) with the same supports and load: the stack bonded (its only contact a
    rigid wall 1 m beside it, never touched)."""
    m = cc.rectangle(x=(0.0, L), y=(-2 * H, H), nx=n, ny=6, diagonal="right")
    b = cc.Body(m, steel(), traction={"top": (q, -P)}, displacement={"left": (0.0, None), "bottom": (0.0, 0.0)},
                contact="right")
    far = cc.Rigid.plane(point=(L + 1.0, 0.0), normal=(-1.0, 0.0))        # 1 m away: never touched
    return cc.Scene(b, contacts=[cc.Contact(b, "right", far, condition="sigma1")])


def uniform_stack3d(tau, law, conditions=("gamma3", "sigma1"), n=(2, 3, 3)):
    """The 3D :func:`uniform_stack`: three unit boxes (``n`` x ``n`` x 1 tetrahedra each: top, middle, bottom; nu =
    0) stacked on z in [-2, 1], the lowest clamped at its base, in the uniform state of :func:`uniform_layer3d`
    (the top box under (tau_x, tau_y, -p) along :data:`DIAGONAL3`, the complementary shear on every box's
    sides), ``law`` on both pairs, the upper (top on middle) under ``conditions[0]``, the lower under
    ``conditions[1]``. Stuck: u = (tau_x (z + 2) / G, tau_y (z + 2) / G, -p (z + 2) / E), G = E / 2."""
    q = tau * DIAGONAL3
    boxes = []
    for k, (m, z0, name) in enumerate(zip(n, (0.0, -1.0, -2.0), ("top", "middle", "bottom"))):
        mesh = cc.box(nx=m, ny=m, nz=1)
        mesh = mesh.with_points(mesh.points + [0.0, 0.0, z0])
        load = {**_side_shear(q), "top": (q[0], q[1], -P)} if k == 0 else _side_shear(q)
        boxes.append(cc.Body(mesh, steel(nu=0.0), contact="top" if k == 2 else "bottom", traction=load, name=name,
                             **({"clamped": "bottom"} if k == 2 else {})))
    top, middle, bottom = boxes
    return cc.Scene(*boxes, contacts=[cc.Contact(top, "bottom", middle, "top", law=law, condition=conditions[0]),
                                      cc.Contact(middle, "bottom", bottom, "top", law=law, condition=conditions[1])])


def compliant_series(tau, k, g=None, law=None, nx=4, ny=2, floor_law=None):
    """Two layers (1 m x 0.5 m, nu = 0) in the uniform state of :func:`uniform_layer` (sigma_yy = -p, sigma_xy = tau:
    (tau, -p) on the upper one's top, the complementary shear on both layers' sides): the upper layer on the lower
    one (matching lines) with ``law`` (default Tresca's g, > tau: stuck), the lower one on the rigid floor y = -H
    under cc.NormalCompliance(k) with u_x = 0 on its base (a second tag "base"). Springs in series and the stuck
    shear: u = (tau (y + H) / G, -p / k - p (y + H) / E), G = E / 2 (plane strain, nu = 0), in both layers.
    ``floor_law``: another law on the floor pair (default cc.NormalCompliance(k)). Returns the scene (bodies "upper",
    "lower")."""
    law = cc.Tresca(g) if law is None else law
    top = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    upper = cc.Body(top, steel(nu=0.0), contact="bottom", name="upper",
                    traction={"top": (tau, -P), "left": (0.0, -tau), "right": (0.0, tau)})
    m = cc.rectangle(x=(0.0, L), y=(-H, 0.0), nx=nx, ny=ny)
    m = cc.Mesh(m.points, m.triangles, {**{t: m.boundary(t) for t in m.tags}, "base": m.boundary("bottom")})
    lower = cc.Body(m, steel(nu=0.0), contact="top", name="lower", displacement={"base": (0.0, None)},
                    traction={"left": (0.0, -tau), "right": (0.0, tau)})
    floor = cc.Rigid.plane(point=(0.0, -H), normal=(0.0, 1.0))
    return cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", law=law),
                                            cc.Contact(lower, "bottom", floor,
                                                       law=cc.NormalCompliance(k) if floor_law is None else floor_law)])


def compliant_series_exact(points, tau, k):
    """The closed form of :func:`compliant_series` at ``points`` (n, 2): (n, 2) m."""
    y = np.asarray(points, dtype=float)[:, 1] + H
    return np.column_stack([tau * y / (E / 2), -P / k - P * y / E])


def compliant_series3d(tau, k, g=None, n=2, cell="tetra", law=None):
    """The 3D counterpart of :func:`compliant_series`: two unit boxes (n x n x 1 cells, nu = 0) in the uniform state of
    :func:`uniform_layer3d`, the upper one on the lower one with ``law`` (default Tresca's g; stuck), the lower one on the rigid plane
    z = -1 under cc.NormalCompliance(k), u_x = u_y = 0 on its base. u = (tau_x (z+1) / G, tau_y (z+1) / G,
    -p / k - p (z + 1) / E) along :data:`DIAGONAL3`."""
    q = tau * DIAGONAL3
    upper = cc.Body(cc.box(nx=n, ny=n, nz=1, cell=cell), steel(nu=0.0), contact="bottom", name="upper",
                    traction={"top": (q[0], q[1], -P), **_side_shear(q)})
    mesh = cc.box(nx=n, ny=n, nz=1, cell=cell)
    mesh = mesh.with_points(mesh.points - [0.0, 0.0, 1.0])
    Mesh = type(mesh)
    cells = mesh.tets if cell == "tetra" else mesh.cells
    mesh = Mesh(mesh.points, cells, {**{t: mesh.boundary(t) for t in mesh.tags}, "base": mesh.boundary("bottom")})
    lower = cc.Body(mesh, steel(nu=0.0), contact="top", name="lower", displacement={"base": (0.0, 0.0, None)},
                    traction=_side_shear(q))
    floor = cc.Rigid.plane(point=(0.0, 0.0, -1.0), normal=(0.0, 0.0, 1.0))
    law = cc.Tresca(g) if law is None else law
    return cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", law=law),
                                            cc.Contact(lower, "bottom", floor, law=cc.NormalCompliance(k))])


def compliant_series3d_exact(points, tau, k):
    """The closed form of :func:`compliant_series3d` at ``points`` (n, 3): (n, 3) m."""
    z = np.asarray(points, dtype=float)[:, 2] + 1.0
    q = tau * DIAGONAL3
    return np.column_stack([q[0] * z / (E / 2), q[1] * z / (E / 2), -P / k - P * z / E])


def lidded(law, force=-P, lid_law=None, q=0.05 * P, at=H, nx=8, ny=4):
    """The block (1 m x 0.5 m, nu = 0.3) on the rigid floor y = 0 (``law``) under the shear traction (q, 0) on its
    right face, pressed from above by the plane y = ``at`` (``lid_law`` on that pair; None: frictionless) under the
    prescribed force (0, ``force``) N/m (``force`` None: the plane fixed at y = ``at``): force control beside a
    friction law; the block is held along x by the friction alone."""
    b = cc.Body(cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny), steel(), contact="bottom",
                traction={"right": (q, 0.0)})
    lid = cc.Rigid.plane(point=(0.0, at), normal=(0.0, -1.0), force=None if force is None else (0.0, force))
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law), cc.Contact(b, "top", lid, law=lid_law)])


def positive_forces(r, elements, rounds=8):
    """Coulomb's normal nodal forces under the P2 cones (docs/howto/friction.md, "Coulomb under the cones"), written
    node by node: the nodal forces ``r`` with each negative one taken from the positive ones of its patch (the nodes
    of the ``elements``, lists of nodes, that hold it) in proportion to them, repeated while a node is negative."""
    p = np.array(r, dtype=float)
    patch = [set() for _ in p]
    for e in elements:
        for a in e:
            patch[a].update(int(b) for b in e)
    for _ in range(rounds):
        plus, new = np.maximum(p, 0.0), p.copy()
        for a in np.flatnonzero(p < 0):
            mass = sum(plus[b] for b in patch[a])
            if mass > 0:
                new[a] = 0.0
                for b in patch[a]:
                    new[b] -= plus[b] * -p[a] / mass
        p = new
    return p


def dragged_blocks3d(law, press=1e-4):
    """Two non-matching blocks (3 x 2 x 1 cells on 2 x 3 x 1; E = 1 GPa, nu = 0.3) on z in [0, 1] meeting at
    z = 0.5, the lower clamped at its base, the upper one's top moved by (4e-4, 2e-4, -``press``) m: pressed and
    dragged along x and y, ``law`` on the pair (posed from the upper block)."""
    mats = cc.materials.isotropic(E=1e9, nu=0.3)
    up = cc.box(x=(0, 1), y=(0, 1), z=(0.5, 1), nx=3, ny=2, nz=1)
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=2, ny=3, nz=1)
    b1 = cc.Body(up, mats, contact="bottom", displacement={"top": (4e-4, 2e-4, -press)})
    b2 = cc.Body(low, mats, clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", law=law)])


def dragged_stack(laws, conditions=("gamma3", "sigma1"), nx=(4, 3, 5), s=2e-5, order=(0, 1), middle=None,
                  quarter=0, scale=1.0, cell="triangle"):
    """Three blocks (L x H each, ``nx`` cells across: top, middle, bottom; non-matching lines by default) stacked on
    y in [-2H, H]: the top one pressed by p and dragged by u_x = ``s`` on its left face, the middle one held by
    its two pairs alone (its horizontal equilibrium: the same shear through both), the lowest clamped at its base;
    ``laws[0]`` and ``conditions[0]`` on the upper pair (top on middle), ``laws[1]``, ``conditions[1]`` on the
    lower one, the pairs listed in ``order``; ``middle``: the middle body's material and electrodes (keywords of
    cc.Body; steel by default); the whole scene turned by ``quarter`` quarter turns about the origin (its loads
    and supports with it) and its lengths and ``s`` times ``scale``: its displacements those turned and scaled;
    ``cell="quad"``: quadrilaterals. A threshold far below
    the other pair's slides the top block alone (or the top two together) over every row of that pair: its shear
    force is then g L (Tresca) or mu p L (Coulomb) through both pairs."""
    R = np.linalg.matrix_power(np.array([[0.0, -1.0], [1.0, 0.0]]), quarter)
    drag = [None, None]
    drag[int(np.argmax(np.abs(R[:, 0])))] = float(R[:, 0].sum()) * s * scale      # u . (R e_x) = s, by its component
    blocks = []
    for k, (n, y0, name) in enumerate(zip(nx, (0.0, -H, -2 * H), ("top", "middle", "bottom"))):
        m = cc.rectangle(x=(0.0, L), y=(y0, y0 + H), nx=n, ny=2, cell=cell)
        m = m.with_points(scale * m.points @ R.T)
        kw = [{"traction": {"top": tuple(R @ [0.0, -P])}, "displacement": {"left": tuple(drag)}},
              dict(middle or {}), {"clamped": "bottom"}][k]
        material = kw.pop("material", steel())
        blocks.append(cc.Body(m, material, contact="top" if k == 2 else "bottom", name=name, **kw))
    top, mid, bottom = blocks
    pairs = [cc.Contact(top, "bottom", mid, "top", law=laws[0], condition=conditions[0]),
             cc.Contact(mid, "bottom", bottom, "top", law=laws[1], condition=conditions[1])]
    return cc.Scene(*blocks, contacts=[pairs[i] for i in order])


def dragged_stack3d(g, conditions=("gamma3", "sigma1"), n=(2, 3, 2), s=2e-5, cell="tetra"):
    """The 3D :func:`dragged_stack`: three unit boxes (``n`` x ``n`` x 1 tetrahedra each; non-matching faces) stacked
    on z in [-2, 1], the top one pressed by p and dragged by u_x = ``s`` on its left face, the top and middle ones
    held along y on their front faces (the middle one's x held by its pairs alone), the lowest clamped at its base;
    Tresca's ``g[0]`` on the upper pair under ``conditions[0]``, ``g[1]`` on the lower one under
    ``conditions[1]``; ``cell="hex"``: hexahedra."""
    boxes = []
    for k, (m, z0, name) in enumerate(zip(n, (0.0, -1.0, -2.0), ("top", "middle", "bottom"))):
        mesh = cc.box(nx=m, ny=m, nz=1, cell=cell)
        mesh = mesh.with_points(mesh.points + [0.0, 0.0, z0])
        held = {"front": (None, 0.0, None)}
        kw = [{"traction": {"top": (0.0, 0.0, -P)}, "displacement": {"left": (s, None, None), **held}},
              {"displacement": held}, {"clamped": "bottom"}][k]
        boxes.append(cc.Body(mesh, steel(), contact="top" if k == 2 else "bottom", name=name, **kw))
    top, middle, bottom = boxes
    return cc.Scene(*boxes, contacts=[
        cc.Contact(top, "bottom", middle, "top", law=cc.Tresca(g[0]), condition=conditions[0]),
        cc.Contact(middle, "bottom", bottom, "top", law=cc.Tresca(g[1]), condition=conditions[1])])


def friction_held_layers(interface, length=1.0, stress=1.0, nx=4, ny=2):
    """Two layers (nu = 0, L x H each) under p on the top: the upper one (a roller on its left) on the lower one
    (``interface``: frictionless, Signorini or compliance), the lower one on the floor with Tresca (g = 0.2 p), which
    alone holds its x translation, unloaded along x. In the units ``length`` (m per unit: 1e-3 for mm) and
    ``stress`` (Pa per unit: 1e6 for MPa; a compliance law's stiffness is given in Pa/m and converted here).
    u = (0, -r - p y' / E) with y' = y + H and r the interface's penetration (m)."""
    h, p = H / length, P / stress
    top = cc.rectangle(x=(0.0, L / length), y=(0.0, h), nx=nx, ny=ny)
    upper = cc.Body(top, steel(nu=0.0, scale=1.0 / stress), contact="bottom", name="upper",
                    traction={"top": (0.0, -p)}, displacement={"left": (0.0, None)})
    low = cc.rectangle(x=(0.0, L / length), y=(-h, 0.0), nx=nx, ny=ny)
    lower = cc.Body(low, steel(nu=0.0, scale=1.0 / stress), contact="top", name="lower")
    floor = cc.Rigid.plane(point=(0.0, -h), normal=(0.0, 1.0))
    if interface.compliant:
        m = interface.exponent
        interface = cc.NormalCompliance(interface.stiffness * length ** m / stress, m)
    return cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", law=interface),
                                            cc.Contact(lower, "bottom", floor, law=cc.Tresca(0.2 * p))])
