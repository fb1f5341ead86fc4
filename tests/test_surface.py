"""Planar contact surfaces in 3D (contact/surface.py): the jump rows at the overlay's vertices, lambda_h in
X_h = T1 + T2, the pressure felt by each body, the patch-test property of the overlay condition, and the refusals.

The bodies here are stand-ins with the attributes of a tetrahedral mesh that SurfaceInterface reads (points,
tags, boundary faces oriented outwards, their normals and areas, size): a contact face embedded in a generic
plane of R^3 plus one apex off the plane. Every expected value comes from a closed form (rigid motions, affine
pressures), a dense pseudo-inverse, or scipy.optimize.nnls, never from the code under test."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import nnls

from cvxcontact.contact.interface import Stack
from cvxcontact.contact.surface import SurfaceInterface, canonical_frame
from cvxcontact.errors import SceneError

from meshes import grid, random_mesh, rotated


class StandInMesh:
    """What SurfaceInterface reads of a tetrahedral mesh: points (n, 3), tags, boundary(tag) (k, 3) faces with
    (p1 - p0) x (p2 - p0) pointing out of the body, outward_normals(tag), face_areas(tag), node_areas(tag) (a third
    of each face's area to each of its nodes), size, and triangulation (the mesh whose faces these are: itself)."""

    dim = 3

    def __init__(self, points, boundaries):
        self.points = np.asarray(points, dtype=float)
        self._faces = {t: np.asarray(f) for t, f in boundaries.items()}
        self.tags = tuple(self._faces)

    def boundary(self, tag):
        return self._faces[tag]

    def _cross(self, tag):
        P = self.points[self._faces[tag]]
        return np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])

    def outward_normals(self, tag):
        c = self._cross(tag)
        return c / np.linalg.norm(c, axis=1)[:, None]

    def face_areas(self, tag):
        return 0.5 * np.linalg.norm(self._cross(tag), axis=1)

    def node_areas(self, tag):
        return np.bincount(self._faces[tag].ravel(), weights=np.repeat(self.face_areas(tag) / 3.0, 3),
                           minlength=len(self.points))

    @property
    def triangulation(self):
        return self

    @property
    def size(self):
        return float(np.linalg.norm(np.ptp(self.points, axis=0)))


class StandInBody:
    def __init__(self, name, mesh, contact="contact"):
        self.name, self.mesh, self.contact = name, mesh, contact


def rotation(seed=3):
    """A generic proper rotation of R^3 (not about a coordinate axis)."""
    Q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return Q * np.sign(np.linalg.det(Q))


def face_body(name, mesh2d, Q, side, origin=np.zeros(3)):
    """A body whose contact face is the 2D triangulation ``mesh2d`` in the plane through ``origin`` spanned by
    Q's first two columns; ``side`` = +1: the body lies on the -Q[:, 2] side (outward normal +Q[:, 2]);
    -1: on the other side. Nodes 0..n-1 are the face's, node n an apex off the plane."""
    uv, tri = mesh2d
    pts = origin + uv[:, :1] * Q[:, 0] + uv[:, 1:] * Q[:, 1]
    apex = pts.mean(axis=0) - side * Q[:, 2]
    faces = tri if side > 0 else tri[:, [0, 2, 1]]
    d1, d2 = uv[tri[:, 1]] - uv[tri[:, 0]], uv[tri[:, 2]] - uv[tri[:, 0]]
    area = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    faces = np.where((area < 0)[:, None], faces[:, [0, 2, 1]], faces)          # counter-clockwise in (t1, t2) first
    return StandInBody(name, StandInMesh(np.vstack([pts, apex]), {"contact": faces, "other": faces[:1]}))


Q = rotation()
PAIRS = {
    "5x5 on 7x3": (grid(5, 5), grid(7, 3, flip=True)),
    "random rotated, partial": (random_mesh(14, np.random.default_rng(5)),
                                rotated(random_mesh(9, np.random.default_rng(6), x=(0.3, 1.4), y=(-0.2, 0.8)), 0.7)),
    "punch on a larger face": (grid(3, 2, x=(0.2, 0.8), y=(0.3, 0.7)), grid(6, 5, x=(-0.5, 1.5), y=(-0.5, 1.5))),
    "nested": (grid(4, 4), grid(8, 8)),
}


def pair(name, Q=Q, origin=np.array([0.3, -1.2, 2.0])):
    a, b = PAIRS[name]
    return SurfaceInterface((face_body("upper", a, Q, +1, origin), face_body("lower", b, Q, -1, origin)))


def generators(itf):
    return sp.hstack([itf.interpolation(0), itf.interpolation(1)], format="csr").toarray()


@pytest.mark.parametrize("name", list(PAIRS))
def test_geometry_of_the_pair(name):
    itf = pair(name)
    assert itf.dim == 3 and itf.size == itf.overlay.size == len(itf.x) == len(itf.points)
    assert np.allclose(itf.normal, Q[:, 2], atol=1e-14)
    t1, t2 = itf.frame
    assert abs(t1 @ t2) < 1e-15 and abs(np.cross(t1, t2) @ itf.normal - 1) < 1e-15 or \
        abs(np.cross(t1, t2) @ itf.normal + 1) < 1e-15
    assert np.array_equal(itf.traces[0].frame, itf.traces[1].frame)
    origin = np.array([0.3, -1.2, 2.0])
    assert np.abs((itf.points - origin) @ itf.normal).max() <= 1e-14            # on the plane
    assert np.abs(itf.points @ itf.frame.T - itf.x).max() <= 1e-14
    for k in range(2):                                                          # sigma: the body's own nodes
        tr = itf.traces[k]
        on = itf.interpolation(k)[itf.sigma[k]]
        assert np.allclose(abs(on).sum(axis=1), 1) and on.nnz == len(itf.sigma[k])
        assert np.abs(itf.points[itf.sigma[k]][:, None] - tr.points[None]).sum(axis=2).min(axis=1).max() <= 1e-14


def test_canonical_frame_is_shared_by_opposite_normals_and_keeps_x_y_on_a_horizontal_plane():
    for n in (Q[:, 2], np.array([0.0, 0.0, 1.0]), np.array([1.0, 0, 0]), np.array([0.6, 0.8, 0.0])):
        F, G = canonical_frame(n), canonical_frame(-n)
        assert np.array_equal(F, G)
        assert np.allclose(F @ F.T, np.eye(2), atol=1e-15) and np.allclose(F @ n, 0, atol=1e-15)
    assert np.array_equal(canonical_frame([0, 0, -1.0]), np.array([[1.0, 0, 0], [0, 1.0, 0]]))


@pytest.mark.parametrize("name", list(PAIRS))
def test_jump_of_rigid_motions_is_the_closed_form_at_every_vertex(name):
    """u^a = a + w x X, u^b = b + w' x X (infinitesimal rigid motions, the bodies' own nodes):
    [u_nu] = (u^a(X) - u^b(X)) . nu^a at every overlay vertex X."""
    itf = pair(name)
    rng = np.random.default_rng(11)
    a, w, b, w2 = rng.normal(size=(4, 3))
    motion = lambda X, t, om: t + np.cross(om, X)
    bodies = [tr.body for tr in itf.traces]
    U = [motion(bodies[0].mesh.points, a, w), motion(bodies[1].mesh.points, b, w2)]
    jump = sum(itf.jump(k, len(U[k])) @ U[k].ravel() for k in range(2))
    X = itf.points
    exact = (motion(X, a, w) - motion(X, b, w2)) @ itf.normal
    assert np.abs(jump - exact).max() <= 1e-13 * np.abs(exact).max()          # measured <= 5.6e-15 relative
    assert itf.jump(0, len(U[0])).shape == (itf.size, 3 * len(U[0]))


@pytest.mark.parametrize("name", list(PAIRS))
def test_multiplier_is_the_riesz_representer_in_X_h(name):
    """lambda_h against a dense computation: lambda = G pinv(G^T M G) G^T r; lambda in range G; G^T M lambda =
    G^T r. On non-matching faces it is not M^-1 r (the overlay's own P1 space is larger than X_h)."""
    itf = pair(name)
    G, M = generators(itf), itf.mass.toarray()
    r = np.random.default_rng(2).uniform(0.0, 1.0, itf.size)
    lam = itf.multiplier(r)
    ref = G @ np.linalg.pinv(G.T @ M @ G, rcond=1e-12) @ (G.T @ r)
    assert np.abs(lam - ref).max() <= 1e-9 * np.abs(ref).max()                 # measured <= 8.1e-14 relative
    assert np.abs(G.T @ (M @ lam - r)).max() <= 1e-11 * np.abs(G.T @ r).max()  # measured <= 1.3e-15
    c = np.linalg.lstsq(G, lam, rcond=None)[0]
    assert np.abs(G @ c - lam).max() <= 1e-10 * np.abs(lam).max()              # lambda is in X_h
    if name != "nested":
        assert np.abs(np.linalg.solve(M, r) - lam).max() > 0.1 * np.abs(lam).max()


@pytest.mark.parametrize("name", list(PAIRS))
def test_multiplier_returns_an_affine_pressure_and_a_constant_one(name):
    """r_a = sum_b M_ab p(b): the row forces of the X_h function p (affine, so in T1 and in X_h); lambda_h = p."""
    itf = pair(name)
    for p in (np.full(itf.size, 2.5e6), 1e6 * (3.0 + 2.0 * itf.x[:, 0] - 1.5 * itf.x[:, 1])):
        lam = itf.multiplier(itf.mass @ p)
        assert np.abs(lam - p).max() <= 1e-10 * np.abs(p).max()                 # measured <= 1.3e-14 relative


def _patch_rows(itf, rows, p=1.0):
    """nnls: y >= 0 on ``rows`` with sum_a y_a psi(a) = int p psi for every generator psi of X_h; returns y and
    the residual relative to |G^T M 1 p|."""
    G = generators(itf)
    target = G.T @ (itf.mass @ np.full(itf.size, p))
    y, res = nnls(G[rows].T, target, maxiter=50 * len(rows))
    return y, res / np.linalg.norm(target)


@pytest.mark.parametrize("name", list(PAIRS))
def test_patch_test_property_of_the_overlay_condition(name):
    """Non-negative row forces on the overlay vertices that reproduce int p psi for every psi in X_h exist
    (3d.md §2); with them lambda_h = p."""
    itf = pair(name)
    y, res = _patch_rows(itf, np.arange(itf.size), p=4e5)
    assert res <= 1e-10                                                          # measured <= 1.1e-16
    assert (y >= 0).all()
    assert np.abs(itf.multiplier(y) - 4e5).max() <= 1e-9 * 4e5                   # measured <= 6e-14 relative


def test_nodal_rows_fail_the_patch_test_on_non_matching_faces_and_pass_it_on_nested_ones():
    """Under "sigma1"/"sigma2" on 5x5 on 7x3 no y >= 0 on one side's nodes reproduces int p psi (node-to-face
    methods fail the patch test); on nested faces the finer side's nodes do, the coarser side's do not."""
    itf = pair("5x5 on 7x3")
    for rows in itf.sigma:
        assert _patch_rows(itf, rows)[1] > 1e-3                                  # measured 0.14, 0.26
    nested = pair("nested")
    assert _patch_rows(nested, nested.sigma[1])[1] <= 1e-10                      # the fine side: measured 1e-16
    assert _patch_rows(nested, nested.sigma[0])[1] > 1e-3                        # the coarse side: measured 0.63


@pytest.mark.parametrize("name", ["5x5 on 7x3", "nested"])
def test_pressure_felt_by_each_body_under_a_uniform_pressure(name):
    """Both faces cover the same square: each body's nodal force int p psi_a over its lumped area is p."""
    itf = pair(name)
    r = itf.mass @ np.full(itf.size, 3e5)
    for k in range(2):
        assert np.abs(itf.pressure(k, r) - 3e5).max() <= 1e-10 * 3e5                # measured <= 2.3e-15
        lumped = np.zeros(len(itf.traces[k].nodes))
        pts, faces = itf.traces[k].x, itf.traces[k].faces
        d1, d2 = pts[faces[:, 1]] - pts[faces[:, 0]], pts[faces[:, 2]] - pts[faces[:, 0]]
        np.add.at(lumped, faces.ravel(), np.repeat(np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / 6, 3))
        assert np.allclose(itf.traces[k].lumped, lumped, rtol=1e-13, atol=0)


def test_punch_pressure_is_felt_only_where_the_faces_overlap():
    itf = pair("punch on a larger face")
    r = itf.mass @ np.full(itf.size, 1.0)
    assert np.abs(itf.pressure(0, r) - 1.0).max() <= 1e-12                       # the punch: all inside
    big = itf.pressure(1, r)
    x = PAIRS["punch on a larger face"][1][0]                # the large face's nodes whose cells miss the punch
    far = (x[:, 0] < 1 / 6 - 1e-9) | (x[:, 0] > 5 / 6 + 1e-9) | (x[:, 1] < 0.3 - 1e-9) | (x[:, 1] > 0.7 + 1e-9)
    assert far.sum() == 42 - 6 and (big[far] == 0).all() and (itf.overlay.node_b[far] < 0).all()
    assert (big[~far] > 0).all()
    force = itf.interpolation(1).T @ r
    assert abs(force.sum() - 0.6 * 0.4) <= 1e-13                                # total = p x punch area


@pytest.mark.parametrize("name", list(PAIRS))
def test_conditions_weights_and_extension(name):
    itf = pair(name)
    assert itf.evaluation("gamma3").shape == (itf.size, itf.size)
    for l, cond in enumerate(("sigma1", "sigma2")):
        E = itf.evaluation(cond)
        assert np.array_equal(E.indices, itf.sigma[l]) and E.shape == (len(itf.sigma[l]), itf.size)
    assert abs(itf.weights("gamma3").sum() - itf.area) <= 1e-13 * itf.area
    assert (itf.weights("gamma3") > 0).all()
    f = lambda x: 1.0 + 0.5 * x[:, 0] - 0.25 * x[:, 1]
    for l, cond in enumerate(("sigma1", "sigma2")):
        w = itf.weights(cond)
        assert (w > 0).all()
        tr = itf.traces[l]
        node = itf.overlay.node_a if l == 0 else itf.overlay.node_b
        if (node >= 0).all():          # the side lies in the overlap: its lumped areas, its P1 extension exact
            order = np.argsort(node)
            assert np.allclose(w, tr.lumped[order], rtol=1e-12, atol=0)
            assert np.abs(itf.extend(cond, f(itf.x[itf.sigma[l]])) - f(itf.x)).max() <= 1e-13
        assert np.abs(itf.extend(cond, np.full(len(itf.sigma[l]), 7.0)) - 7.0).max() <= 1e-13
    assert np.array_equal(itf.extend("gamma3", f(itf.x)), f(itf.x))
    with pytest.raises(SceneError, match="condition must be one of"):
        itf.evaluation("everywhere")


class Plane:
    """A rigid plane through ``point`` with normal ``n`` towards the body, reachable within ``radius`` of
    ``point`` (+inf beyond): distance along the body's normal nu, (x - p) . n / (-nu . n)."""

    def __init__(self, point, n, radius=np.inf):
        self.point, self.n, self.radius = np.asarray(point, float), np.asarray(n, float), radius

    def distance(self, x, nu):
        d = (x - self.point) @ self.n / (-(nu @ self.n))
        return np.where(np.linalg.norm(x - self.point, axis=1) <= self.radius, d, np.inf)


def test_a_body_against_a_rigid_obstacle():
    body = face_body("block", grid(4, 3), Q, +1)
    plane = Plane(1e-3 * Q[:, 2] + 0.5 * Q[:, 0], -Q[:, 2])
    itf = SurfaceInterface((body,), ("contact",), obstacle=plane)
    assert itf.rigid and itf.size == 20 and len(itf.traces) == 1
    assert np.allclose(itf.obstacle_gap(), 1e-3, rtol=1e-12)
    for cond in ("gamma3", "sigma1", "sigma2"):
        assert itf.evaluation(cond).shape == (20, 20)
    lam = itf.multiplier(itf.mass @ np.full(20, 2e5))
    assert np.abs(lam - 2e5).max() <= 1e-9 * 2e5
    assert abs(itf.area - 1.0) <= 1e-14 and abs(itf.weights("gamma3").sum() - 1.0) <= 1e-14
    U = np.tile([0.1, -0.2, 0.3], (len(body.mesh.points), 1))
    assert np.allclose(itf.jump(0, len(U)) @ U.ravel(), np.array([0.1, -0.2, 0.3]) @ Q[:, 2], rtol=1e-14)
    near = SurfaceInterface((body,), ("contact",), obstacle=Plane(1e-3 * Q[:, 2] + 0.5 * (Q[:, 0] + Q[:, 1]),
                                                                      -Q[:, 2], radius=0.3))
    reach = np.linalg.norm(body.mesh.points[:-1] - 0.5 * (Q[:, 0] + Q[:, 1]), axis=1) <= 0.3
    assert np.array_equal(near.reach, np.flatnonzero(reach)) and near.size == reach.sum()
    with pytest.raises(SceneError, match="cannot be reached"):
        SurfaceInterface((body,), ("contact",), obstacle=Plane(Q[:, 2] + 9 * Q[:, 0], -Q[:, 2], radius=0.1))


def test_refusals_name_what_is_wrong():
    a, b = grid(3, 3), grid(2, 2)
    upper, lower = face_body("upper", a, Q, +1), face_body("lower", b, Q, -1)
    with pytest.raises(SceneError, match="same outward normal"):
        SurfaceInterface((upper, face_body("lower", b, Q, +1)))
    tilted = Q @ np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    with pytest.raises(SceneError, match="do not face each other"):
        SurfaceInterface((upper, face_body("lower", b, tilted, -1)))
    with pytest.raises(SceneError, match=r"not coplanar: lower 'contact' lies -?0.001 m"):
        SurfaceInterface((upper, face_body("lower", b, Q, -1, origin=-1e-3 * Q[:, 2])))
    with pytest.raises(SceneError, match="do not overlap"):
        SurfaceInterface((upper, face_body("lower", b, Q, -1, origin=3.0 * Q[:, 0])))
    with pytest.raises(SceneError, match="unknown boundary tag"):
        SurfaceInterface((upper, lower), ("contact", "top"))
    bent = face_body("bent", a, Q, +1)
    bent.mesh.points[5] += 1e-4 * Q[:, 2]
    with pytest.raises(SceneError, match=r"bent: contact part 'contact' is not planar: .* by up to 9.\d+e-05 m"):
        SurfaceInterface((bent, lower))
    assert SurfaceInterface((upper, lower)).size > 0


def test_stack_of_surface_pairs_and_the_2d_multiplier():
    """The Stack takes each pair's dim (3 displacement components per node here); its multiplier is each
    pair's. The 2D Interface's multiplier solves M lambda = r."""
    itf = pair("5x5 on 7x3")
    rigid = SurfaceInterface((face_body("third", grid(2, 2), Q, +1, origin=5.0 * Q[:, 2]),), ("contact",),
                             obstacle=Plane(5.001 * Q[:, 2], -Q[:, 2]))
    stack = Stack([itf, rigid], [(0, 1), (2, None)])
    n2 = len(rigid.traces[0].body.mesh.points)
    J = stack.jump(2, n2)
    assert J.shape == (itf.size + rigid.size, 3 * n2) and J[:itf.size].nnz == 0
    assert (stack.jump(0, 37)[itf.size:].nnz, stack.jump(0, 37).shape) == (0, (stack.size, 111))
    r = np.random.default_rng(0).uniform(size=stack.size)
    lam = stack.multiplier(r)
    assert np.array_equal(lam[:itf.size], itf.multiplier(r[:itf.size]))
    assert np.array_equal(lam[itf.size:], rigid.multiplier(r[itf.size:]))

    import cvxcontact as cc
    from conftest import two_blocks
    scene = two_blocks(n1=(7, 3), n2=(5, 3))
    s2 = scene.stack
    r = np.random.default_rng(1).uniform(size=s2.size)
    lam = s2.multiplier(r)
    assert np.abs(s2.mass @ lam - r).max() <= 1e-12 * np.abs(r).max()
    assert s2.jump(0, 10).shape[1] == 20 and isinstance(scene.interfaces[0], cc.contact.Interface)


def test_multiplier_on_nearly_coincident_faces():
    """Two 8x8 faces whose nodes are 8e-6 h apart (not merged: tol h = 1e-9 h): T1 + T2 has nearly dependent
    hats; lambda_h still satisfies G^T M lambda = G^T r and reproduces a constant pressure."""
    a = grid(8, 8)
    itf = SurfaceInterface((face_body("a", a, Q, +1), face_body("b", (a[0] + [1e-6, 0.0], a[1]), Q, -1)))
    assert itf.size > 2 * 81 - 20                                 # not merged: the crossings are vertices
    G, M = generators(itf), itf.mass.toarray()
    r = np.random.default_rng(0).uniform(size=itf.size)
    lam = itf.multiplier(r)
    assert np.abs(G.T @ (M @ lam - r)).max() <= 1e-8 * np.abs(G.T @ r).max()      # measured 9e-11
    assert np.abs(itf.multiplier(itf.mass @ np.full(itf.size, 5.0)) - 5.0).max() <= 1e-8 * 5   # measured 2.9e-10


def test_on_tetrahedral_boxes():
    """The same properties on cc.box meshes (two stacked blocks with 5x5 and 7x3 faces, turned by a generic
    rotation; a punch on a larger block's named patch)."""
    generators3d = pytest.importorskip("cvxcontact.geometry.generators3d")
    box = generators3d.box
    lower = box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=5, ny=5, nz=2)
    upper = box(x=(0, 1), y=(0, 1), z=(0.5, 1.0), nx=7, ny=3, nz=2)
    R = rotation(9)
    itf = SurfaceInterface((StandInBody("upper", upper.with_points(upper.points @ R.T), "bottom"),
                            StandInBody("lower", lower.with_points(lower.points @ R.T), "top")))
    assert np.allclose(itf.normal, R @ [0, 0, -1.0], atol=1e-14) and abs(itf.area - 1.0) <= 1e-14
    assert [len(s) for s in itf.sigma] == [32, 36]
    rng = np.random.default_rng(4)
    a, w, b, w2 = rng.normal(size=(4, 3))
    U = [a + np.cross(w, t.body.mesh.points) for t in itf.traces[:1]] + \
        [b + np.cross(w2, t.body.mesh.points) for t in itf.traces[1:]]
    jump = sum(itf.jump(k, len(U[k])) @ U[k].ravel() for k in range(2))
    X = itf.points
    assert np.abs(jump - (a + np.cross(w, X) - b - np.cross(w2, X)) @ itf.normal).max() <= 1e-13
    assert np.abs(itf.multiplier(itf.mass @ np.full(itf.size, 1e5)) - 1e5).max() <= 1e-9 * 1e5  # measured 1e-14
    assert _patch_rows(itf, np.arange(itf.size))[1] <= 1e-10
    assert min(_patch_rows(itf, s)[1] for s in itf.sigma) > 1e-3
    base = box(x=(-1, 2), y=(-1, 2), z=(0, 0.5), nx=6, ny=6, nz=1, patches={"pad": ("top", (0.2, 0.8), (0.3, 0.7))})
    punch = box(x=(0.2, 0.8), y=(0.3, 0.7), z=(0.5, 0.9), nx=4, ny=3, nz=1)
    for part in ("top", "pad"):
        itf = SurfaceInterface((StandInBody("punch", punch, "bottom"), StandInBody("base", base, part)))
        assert abs(itf.area - 0.24) <= 1e-14


def _facet_heights(R):
    """For each row a of R (rows normalised): max R_a v over {R_b v <= 0 for every b != a, R_a v <= 1}, by LP
    (HiGHS). 1: row a is a facet of the cone {v : R v <= 0} (a point where it alone fails); <= 0: the other rows
    imply it."""
    from scipy.optimize import linprog

    R = R / np.linalg.norm(R, axis=1)[:, None]
    heights = []
    for a in range(len(R)):
        ub = np.zeros(len(R))
        ub[a] = 1.0
        res = linprog(-R[a], A_ub=R, b_ub=ub, bounds=(None, None), method="highs")
        assert res.status == 0
        heights.append(-res.fun)
    return np.array(heights)


def test_every_overlay_row_is_a_facet_and_they_outnumber_the_contact_nodes():
    """The "gamma3" rows (the jump at every overlay vertex) are pairwise distinct and every one is a facet of
    {u : [u_nu] <= 0 at the vertices} (a displacement at which it alone fails), and there are more of them than
    contact nodes on both faces: rows each with a dof of their own are independent, so they cut at most rank R
    facets, and no such set has this feasible set (docs/explanation/gamma3-fast-route.md)."""
    itf = pair("random rotated, partial")                                       # (5x5 on 7x3 alike: 213 > 68 >= 65)
    bodies = [tr.body for tr in itf.traces]
    R = sp.hstack([itf.jump(k, len(bodies[k].mesh.points)) for k in range(2)], format="csc")
    cols = np.flatnonzero(np.diff(R.indptr))
    R = R[:, cols].toarray()
    nodes = len(np.unique(cols // 3))                                           # contact nodes of both faces
    Rn = R / np.linalg.norm(R, axis=1)[:, None]
    assert len(np.unique(np.round(Rn, 12), axis=0)) == len(R)                  # no row repeated
    assert len(R) > nodes >= np.linalg.matrix_rank(R)             # measured 132 > 44 >= 41
    assert _facet_heights(R).min() >= 0.5                                       # measured 1.0 (a redundant row: <= 0)
