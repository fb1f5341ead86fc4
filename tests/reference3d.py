"""An independent dense reference for small 3D contact scenes (tests only).

Nothing here uses the package's contact code (no overlay, SurfaceInterface, Stack, DiscreteProblem,
backend or read-back): only each body's assembled SI matrices and loads (:func:`cvxcontact.fem.assembly.
assemble`, with the prolongations u = T_u z + u_D, phi = T_p w + phi_D of its supports and electrodes) and
its meshes. The contact rows are rebuilt here by brute force:

* the points of a pair of planar parts are the nodes of each face mesh that lie in the other's faces and the
  crossings of their edges (every pair of edges tried), merged within 1e-9 of the scene size;
* [u_nu] at a point is sum_k nu^k . u^k(point), u^k interpolated in the face triangle of mesh k that
  contains it (every triangle tried); "sigma_l" keeps the points that are nodes of mesh l;
* a rigid plane ("plane") or a sphere posed along the normal ("sphere-ray"): every node of the part whose
  normal ray meets it, the distance d along nu by its closed form, and its derivative D = n_o / (nu . n_o)
  with respect to a translation of the obstacle (n_o the obstacle's outward normal at the hit point), so that
  the rows of a force-controlled obstacle are [u_nu] - D . t <= d;
* a sphere posed at the closest point ("sphere"): every node whose closest point of the sphere faces the part
  (n_o . nu < 0), d = |x - centre| - radius, the row's direction (centre - x)/|centre - x| in place of nu and
  D = -n_o: the rows are (centre - x)/|.| . u + n_o . t <= d.

:meth:`Dense.solve_on` solves the mixed system (26) with the rows of a given active set held as equalities,
densely (under "gamma3" the rows are dependent: an independent subset is kept; u, phi and t are unique,
the forces are not) and :meth:`Dense.certify` checks that the answer solves the whole problem: every row
feasible, and non-negative row forces y with R^T y equal to the contact part of the momentum rows (scipy's
nnls).
(The rows of the independent subset chosen by :meth:`Dense.solve_on` need not carry non-negative forces:
the certificate looks for any y >= 0 on all the active rows.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import nnls

from cvxcontact.fem.assembly import assemble


def plane_frame(normal) -> np.ndarray:
    """(2, 3) orthonormal in-plane axes; (x, y) for a plane z = const."""
    n = np.asarray(normal, dtype=float)
    if abs(abs(n[2]) - 1.0) < 1e-12:
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    t1 = np.cross(n, [0.0, 0.0, 1.0])
    t1 /= np.linalg.norm(t1)
    return np.array([t1, np.cross(n, t1)])


@dataclass
class Face:
    body: int
    nodes: np.ndarray          # mesh nodes of the part
    tri: np.ndarray            # (k, 3) local indices into nodes
    points: np.ndarray         # (n, 3)
    normal: np.ndarray         # outward unit normal (mean of the face normals)


def face(scene, k, part) -> Face:
    mesh = scene.bodies[k].mesh
    f = np.asarray(mesh.boundary(part))
    nodes = np.unique(f)
    n = np.asarray(mesh.outward_normals(part)).mean(axis=0)
    return Face(k, nodes, np.searchsorted(nodes, f), np.asarray(mesh.points)[nodes], n / np.linalg.norm(n))


def barycentric(s, X, tri, tol=1e-9) -> np.ndarray:
    """(len(s), len(X)): the P1 hats of the triangulation (X, tri) at the in-plane points s (each point
    located by trying every triangle); a row of zeros for a point outside."""
    A, B, C = X[tri[:, 0]], X[tri[:, 1]], X[tri[:, 2]]
    det = (B[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0])
    d = s[:, None, :] - A[None]                                                       # (P, T, 2)
    l1 = (d[..., 0] * (C[:, 1] - A[:, 1]) - d[..., 1] * (C[:, 0] - A[:, 0])) / det
    l2 = ((B[:, 0] - A[:, 0]) * d[..., 1] - (B[:, 1] - A[:, 1]) * d[..., 0]) / det
    lam = np.stack([1 - l1 - l2, l1, l2], axis=-1)                                    # (P, T, 3)
    worst = lam.min(axis=-1)
    t = worst.argmax(axis=1)
    out = np.zeros((len(s), len(X)))
    inside = worst[np.arange(len(s)), t] >= -tol
    rows = np.flatnonzero(inside)
    np.add.at(out, (np.repeat(rows, 3), tri[t[rows]].ravel()), lam[rows, t[rows]].ravel())
    return out


def crossings(Xa, Ea, Xb, Eb, tol=1e-12) -> np.ndarray:
    """In-plane points where an edge of one mesh crosses an edge of the other (every pair tried)."""
    p, r = Xa[Ea[:, 0]][:, None], Xb[Eb[:, 0]][None]
    dp, dr = (Xa[Ea[:, 1]] - Xa[Ea[:, 0]])[:, None], (Xb[Eb[:, 1]] - Xb[Eb[:, 0]])[None]
    cross = dp[..., 0] * dr[..., 1] - dp[..., 1] * dr[..., 0]
    ok = np.abs(cross) > tol * np.abs(dp).max() * np.abs(dr).max()
    q = r - p
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (q[..., 0] * dr[..., 1] - q[..., 1] * dr[..., 0]) / cross
        t = (q[..., 0] * dp[..., 1] - q[..., 1] * dp[..., 0]) / cross
    s, t = np.where(ok, s, -1.0), np.where(ok, t, -1.0)                     # parallel edges: no crossing
    hit = ok & (s >= -1e-12) & (s <= 1 + 1e-12) & (t >= -1e-12) & (t <= 1 + 1e-12)
    return (p + s[..., None] * dp)[hit]


def edges(tri) -> np.ndarray:
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)


def merge_points(s, tol) -> np.ndarray:
    """Points closer than tol taken once (the first kept)."""
    keep = []
    for i, x in enumerate(s):
        if not keep or np.linalg.norm(s[keep] - x, axis=1).min() > tol:
            keep.append(i)
    return s[keep]


@dataclass
class Rows:
    """The contact rows of one pair: points (m, 3); R[k] (m, 3 n_k) the jump's part of body k; g (m,) the
    gap; D (m, 3) the gap's derivative in the obstacle's translation (None for a fixed one or two bodies);
    nodal[l] the points that are nodes of body l's part (for sigma_l); obstacle the Rigid (its prescribed
    force is read)."""

    points: np.ndarray
    R: dict
    g: np.ndarray
    D: np.ndarray | None
    nodal: dict
    obstacle: object = None
    keep: np.ndarray | None = None     # the constrained rows under the condition (set by Dense)


def pair_rows(scene, i, gap=None, shape=None) -> Rows:
    """The rows of ``scene.contacts[i]`` (two planar parts, or a part against a rigid obstacle described by
    ``shape``: ("plane", point, normal) or ("sphere", centre, radius), m); ``gap(points)`` the pair's gap
    function (m) of the 3D points (default 0)."""
    c = scene.contacts[i]
    ka = scene.bodies.index(c.body_a)
    fa = face(scene, ka, c.part_a)
    tol = 1e-9 * max(float(np.ptp(b.mesh.points, axis=0).max()) for b in scene.bodies)
    gap = (lambda x: np.zeros(len(x))) if gap is None else gap
    na = [len(b.mesh.points) for b in scene.bodies]
    if c.rigid:
        d, D, direction = obstacle_distance(shape, fa.points, fa.normal)
        hit = np.isfinite(d)
        R = np.zeros((hit.sum(), 3 * na[ka]))
        for a in range(3):
            R[np.arange(hit.sum()), 3 * fa.nodes[hit] + a] = direction[hit, a]
        return Rows(fa.points[hit], {ka: R}, gap(fa.points[hit]) + d[hit],
                    None if c.other.force is None else D[hit], {0: np.ones(hit.sum(), bool)}, c.other)
    kb = scene.bodies.index(c.other)
    fb = face(scene, kb, c.part_b)
    T = plane_frame(fa.normal)
    Xa, Xb = fa.points @ T.T, fb.points @ T.T
    in_b = barycentric(Xa, Xb, fb.tri).sum(axis=1) > 0.5
    in_a = barycentric(Xb, Xa, fa.tri).sum(axis=1) > 0.5
    cand = np.concatenate([Xa[in_b], Xb[in_a], crossings(Xa, edges(fa.tri), Xb, edges(fb.tri))])
    s = merge_points(cand, tol)
    offset = float(np.mean(fa.points @ fa.normal))
    points = offset * fa.normal + s @ T
    R = {}
    for k, f, X in ((ka, fa, Xa), (kb, fb, Xb)):
        P = barycentric(s, X, f.tri)
        assert np.allclose(P.sum(axis=1), 1.0), "a point of the overlap outside a face mesh"
        Rk = np.zeros((len(s), 3 * na[k]))
        for a in range(3):
            Rk[:, 3 * f.nodes + a] = f.normal[a] * P
        R[k] = Rk
    nodal = {l: np.array([np.linalg.norm(X - x, axis=1).min() <= tol for x in s])
             for l, X in ((0, Xa), (1, Xb))}
    return Rows(points, R, gap(points), None, nodal)


def obstacle_distance(shape, x, nu):
    """(d, D, direction): the gap (m) from the points x to a rigid plane or sphere (``shape``, as in
    :func:`pair_rows`; +inf where there is no contact), its derivative (3,) per point with respect to the
    obstacle's translation and the rows' unit directions (n, 3), closed forms."""
    kind, a, b = shape
    if kind == "plane":
        p0, n = np.asarray(a, float), np.asarray(b, float) / np.linalg.norm(b)
        d = ((p0 - x) @ n) / (nu @ n)
        return d, np.tile(n / (nu @ n), (len(x), 1)), np.tile(nu, (len(x), 1))
    centre, radius = np.asarray(a, float), float(b)
    if kind == "sphere":                                 # closest point: radial
        w = x - centre
        r = np.sqrt((w * w).sum(axis=1))
        n_o = w / r[:, None]
        d = np.where(n_o @ nu < -1e-12, r - radius, np.inf)
        return d, -n_o, -n_o
    assert kind == "sphere-ray", kind
    w = x - centre
    b, c2 = w @ nu, (w * w).sum(axis=1) - radius ** 2
    disc = b * b - c2
    with np.errstate(invalid="ignore"):
        d = np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
    q = x + np.where(np.isfinite(d), d, 0)[:, None] * nu
    n_o = (q - centre) / radius
    return d, n_o / (n_o @ nu)[:, None], np.tile(nu, (len(x), 1))


@dataclass
class RefAnswer:
    u: list          # per body (n, 3) m
    phi: list        # per body (n,) V or None
    t: np.ndarray    # stacked translations of force-controlled obstacles (m)
    x: np.ndarray    # the stacked unknowns (z, w per body, then t)


class Dense:
    """The dense mixed system (26) of ``scene`` under ``condition`` with the rows of :func:`pair_rows`
    (``gaps[i]``: pair i's gap function of 3D points; ``obstacles[i]``: the shape of pair i's rigid obstacle,
    as in :func:`pair_rows`). Unknowns per body: the reduced displacements z and
    potentials w; then the translations t of the force-controlled obstacles."""

    def __init__(self, scene, condition="gamma3", gaps=None, obstacles=None):
        self.scene, self.systems = scene, [assemble(b) for b in scene.bodies]
        gaps, obstacles = gaps or {}, obstacles or {}
        self.pairs = [pair_rows(scene, i, gaps.get(i), obstacles.get(i)) for i in range(len(scene.contacts))]
        sizes = []
        for s in self.systems:
            sizes += [s.Tu.shape[1], 0 if s.Tp is None else s.Tp.shape[1]]
        self.t_size = 3 * sum(p.D is not None for p in self.pairs)
        self.off = np.concatenate([[0], np.cumsum(sizes + [self.t_size])])
        n = self.off[-1]
        K, b = np.zeros((n, n)), np.zeros(n)
        for k, s in enumerate(self.systems):
            z, w = slice(self.off[2 * k], self.off[2 * k + 1]), slice(self.off[2 * k + 1], self.off[2 * k + 2])
            Tu = s.Tu.toarray()
            K[z, z] = Tu.T @ s.Kuu.toarray() @ Tu
            fz, qz = s.reduced_loads()
            b[z] = fz
            if s.Tp is not None:
                Tp = s.Tp.toarray()
                C = Tu.T @ s.Kup.toarray() @ Tp
                K[z, w], K[w, z], K[w, w] = C, C.T, -Tp.T @ s.Kpp.toarray() @ Tp
                b[w] = -qz
        G, g, forces = [], [], []
        t_at = self.off[-2]
        for i, p in enumerate(self.pairs):
            cond = scene.contacts[i].condition or condition
            every = cond == "gamma3" or p.obstacle is not None
            keep = np.ones(len(p.g), bool) if every else p.nodal[int(cond[-1]) - 1]
            Gi = np.zeros((keep.sum(), n))
            gi = p.g[keep].copy()
            for k, Rk in p.R.items():
                s = self.systems[k]
                Gi[:, self.off[2 * k]:self.off[2 * k + 1]] = Rk[keep] @ s.Tu.toarray()
                gi -= Rk[keep] @ s.u_fixed
            if p.D is not None:
                Gi[:, t_at:t_at + 3] = -p.D[keep]
                b[t_at:t_at + 3] = np.asarray(p.obstacle.force, float)
                t_at += 3
            p.keep = keep
            G.append(Gi)
            g.append(gi)
        self.K, self.b, self.G, self.g = K, b, np.vstack(G), np.concatenate(g)
        self.counts = [len(x) for x in g]

    def points(self, i) -> np.ndarray:
        """The constrained points of pair i (m)."""
        return self.pairs[i].points[self.pairs[i].keep]

    def solve_on(self, active) -> RefAnswer:
        """The stationary point of (26) with the rows ``active`` (bool over the stacked constrained rows)
        held as equalities, the others dropped: a maximal independent subset of the active rows (pivoted
        QR; under "gamma3" the rows are dependent, and u, phi, t do not depend on the choice), then a dense
        LU solve of the Ruiz-equilibrated saddle-point matrix."""
        A = self.G[active]
        if len(A):
            _, Rq, piv = sla.qr(A.T, mode="economic", pivoting=True)
            rank = int((np.abs(np.diag(Rq)) > 1e-10 * abs(Rq[0, 0])).sum())
            rows = np.sort(piv[:rank])
        else:
            rows = np.zeros(0, int)
        A = A[rows]
        n, m = len(self.b), len(A)
        M = np.block([[self.K, A.T], [A, np.zeros((m, m))]])
        rhs = np.concatenate([self.b, self.g[active][rows]])
        d = np.ones(n + m)
        for _ in range(30):                                       # Ruiz: every row's largest entry -> 1
            e = 1.0 / np.sqrt(np.abs(M * d[:, None] * d[None]).max(axis=1))
            d *= e
            if np.abs(e - 1).max() < 1e-3:
                break
        z = d * np.linalg.solve(M * d[:, None] * d[None], d * rhs)
        return self._answer(z[:n])

    def certify(self, ans: RefAnswer, active):
        """(largest penetration over every row / the rows' scale, relative residual of R^T y = (b - K x)
        over y >= 0 on ``active``): both ~0 iff ``ans`` solves the contact problem."""
        slack = self.G @ ans.x - self.g
        # the rows' terms, or the field's size where the rows' nodes do not move (a layer held on its plane: G x and
        # g are rounding there, and slack / scale was 0 or 1.0 by the BLAS kernels' rounding)
        scale = max(float(np.abs(self.g).max()), float((np.abs(self.G) @ np.abs(ans.x)).max()),
                    float(np.abs(self.G).max()) * float(np.abs(ans.x).max()))
        need = self.b - self.K @ ans.x
        y, res = nnls(self.G[active].T, need, maxiter=50 * int(active.sum()) + 100)
        return float(max(slack.max(), 0.0) / scale), float(res / np.linalg.norm(need)), y

    def _answer(self, x) -> RefAnswer:
        u, phi = [], []
        for k, s in enumerate(self.systems):
            z, w = x[self.off[2 * k]:self.off[2 * k + 1]], x[self.off[2 * k + 1]:self.off[2 * k + 2]]
            u.append((s.u_fixed + s.Tu @ z).reshape(-1, 3))
            phi.append(None if s.Tp is None else s.phi_fixed + s.Tp @ w)
        return RefAnswer(u, phi, x[self.off[-2]:], x)


def match(ref_points, sol_points, tol):
    """Index into sol_points of each reference point (asserting both sets are the same to tol)."""
    dist = np.linalg.norm(ref_points[:, None] - sol_points[None], axis=2)
    j = dist.argmin(axis=1)
    assert len(ref_points) == len(sol_points) and dist[np.arange(len(j)), j].max() <= tol \
        and len(np.unique(j)) == len(j), "the package's contact points differ from the reference's"
    return j
