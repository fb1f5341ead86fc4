"""The equilibrated fields of the guaranteed error bound (docs/accuracy.md, "A guaranteed bound"): the stress
tau on the Clough-Tocher split of every triangle (Johnson-Mercier, H(div)-conforming) and, for a piezoelectric
body, the electric displacement D~ (Raviart-Thomas RT0).

tau: piecewise linear symmetric on the three sub-triangles at each triangle's barycentre; its nodal values
minimise || C^{-1/2} (C eps(v) - tau) || subject to A tau = b (normal-traction continuity across every
sub-triangle edge, div tau = -f on every sub-triangle, the boundary conditions at the two ends of each boundary
edge, the contact pressure -p d on Gamma_3 with b = b0 + B p linear in p): one sparse solve with the Schur
complement A M^-1 A^T, regularised and refined to rounding, the residual of A tau = b checked. A body in a pair
is equilibrated on its reconstruction mesh (the cells along Gamma_3 divided at the other body's nodes).

D~: the RT0 field closest to D(v, phi_h) in || kappa^{-1/2} . || with div D~ = q0, D~ . n = q2 on charged
edges, 0 on the other non-electrode edges and total flux -Q through each floating electrode: one global sparse
solve over the edge fluxes.

:mod:`cvxcontact.solution.bound` assembles the bound (PS), (PS-e) from these fields, the pressure p and the
correction into K.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError, UnsupportedError
from ..fem.assembly import gradients, voigt_strains
from ..geometry.facets import facets
from ..geometry.mesh import Mesh
from .estimate import boundary_roles

_K3_INV = np.array([[3.0, -1.0, -1.0], [-1.0, 3.0, -1.0], [-1.0, -1.0, 3.0]])   # area/12 [[2,1,1],..]^-1 * area/3
_EQUILIBRIUM_TOL = 1e-9        # largest |A tau - b| accepted, relative to the stresses (Pa / Pa)


def mesh_edges(mesh):
    """Every edge of a triangle mesh once, from the facet table (:func:`~cvxcontact.geometry.facets.facets`):
    (cells (k, 2) with -1 for a boundary edge's missing neighbour, the local edge index i in each (the edge
    from vertex i to vertex i + 1, opposite vertex i + 2), vertex pair (k, 2) sorted; the keys a n + b of the
    pairs ascending)."""
    owners, opposite, pairs, _ = facets(mesh.triangles, len(mesh.points))
    return owners, np.where(owners >= 0, (opposite + 1) % 3, -1), pairs


# ---------------------------------------------------------------------------------------------- the split


def _split(mesh):
    """The Clough-Tocher split: sub-triangle 3 c + s of cell c has vertices (v_s, v_s+1, barycentre) (same
    orientation as c). Returns areas (3m,), barycentric gradients (3m, 2, 3), vertex coordinates (3m, 3, 2)."""
    p, tri = mesh.points, mesh.triangles
    m, n = len(tri), len(p)
    pts = np.vstack([p, p[tri].mean(axis=1)])
    s = np.arange(3)
    sub = np.stack([tri[:, s], tri[:, (s + 1) % 3], np.repeat((n + np.arange(m))[:, None], 3, axis=1)], axis=2)
    sub = sub.reshape(3 * m, 3)
    area, grad = gradients(pts, sub)
    return area, grad, pts[sub]


def _index(sub, vertex, comp):
    """The unknown of Voigt component ``comp`` (xx, yy, xy) of tau at local ``vertex`` of sub-triangle ``sub``."""
    return (np.asarray(sub) * 3 + vertex) * 3 + comp


class _Rows:
    """The rows of A tau = b, collected as COO triplets."""

    def __init__(self):
        self.r, self.c, self.v, self.b = [], [], [], []
        self.loads = []                                    # (rows, sparse (k, n_p)): rhs + load @ p
        self.count = 0

    def add(self, terms, rhs, load=None):
        """One row per entry of ``rhs`` (k,): ``terms`` a list of (columns (k,), coefficients (k,)); ``load``
        (k, n_p) sparse or None: the rows' right-hand sides are rhs + load @ p for the contact pressures p."""
        rows = self.count + np.arange(len(rhs))
        for cols, coef in terms:
            self.r.append(rows)
            self.c.append(np.asarray(cols))
            self.v.append(np.broadcast_to(np.asarray(coef, dtype=float), rows.shape))
        self.b.append(np.asarray(rhs, dtype=float))
        if load is not None:
            self.loads.append((rows, sp.coo_matrix(load)))
        self.count += len(rhs)

    def traction(self, sub, vertex, n, sign=1.0):
        """The two (x, y) terms of sign * tau n at local ``vertex`` of ``sub`` (normals n (k, 2))."""
        xx, yy, xy = (_index(sub, vertex, k) for k in range(3))
        return ([[(xx, sign * n[:, 0]), (xy, sign * n[:, 1])],
                 [(xy, sign * n[:, 0]), (yy, sign * n[:, 1])]])

    def matrix(self, size, n_p):
        """(A, b, B): A tau = b + B p, B (rows, n_p) sparse."""
        A = sp.csr_matrix((np.concatenate(self.v), (np.concatenate(self.r), np.concatenate(self.c))),
                          shape=(self.count, size))
        r = [rows[load.row] for rows, load in self.loads]
        c = [load.col for _, load in self.loads]
        v = [load.data for _, load in self.loads]
        B = sp.csr_matrix((np.concatenate([np.zeros(0), *v]), (np.concatenate([np.zeros(0, int), *r]),
                                                                np.concatenate([np.zeros(0, int), *c]))),
                          shape=(self.count, n_p))
        return A, np.concatenate(self.b), B


def _continuity(rows, sub_a, va, sub_b, vb, n):
    """tau_a n = tau_b n at the points local ``va`` of ``sub_a`` and ``vb`` of ``sub_b``."""
    for ta, tb in zip(rows.traction(sub_a, va, n), rows.traction(sub_b, vb, n, -1.0)):
        rows.add(ta + tb, np.zeros(len(n)))


# ---------------------------------------------------------------------------------------------- the stress


def body_system(sol, body, v, phi_h, loads, n_p) -> dict:
    """The conditions on the equilibrated stress of one body (module docstring) on its reconstruction mesh (the
    contact edges of its pairs divided at the breakpoints in ``loads``), for the admissible displacement ``v``
    (n, 2) and the potential ``phi_h`` (n,) or None; ``loads``: per contact side, dict(breaks, d, part, x, tol,
    offset): A tau = b + B p for the pressures p (n_p,), its Schur complement S = A M^-1 A^T factorised."""
    mesh0 = body.mesh
    tri0 = mesh0.triangles
    m0 = len(tri0)
    c_mat = body.material.tensors(2)[0]
    _, cell_grad = gradients(mesh0.points, tri0)
    eps_v = voigt_strains(cell_grad, v[tri0])                                           # (m, 3) Voigt
    sigma_v = eps_v @ c_mat.T                                                            # (m, 3) Pa
    D_v = None
    if body.piezoelectric:                     # the coupled law: sigma = c eps + e^T grad phi, D = e eps - kappa grad phi
        _, e_mat, kappa = body.material.tensors(2)
        gphi = np.einsum("mdj,mj->md", cell_grad, phi_h[tri0])                          # (m, 2) V/m
        sigma_v = sigma_v + gphi @ e_mat
        D_v = eps_v @ e_mat.T - gphi @ kappa.T                                           # (m, 2) C/m^2
    mesh, parent, lift = _divided(mesh0, [(s["part"], s["breaks"]) for s in loads])
    p_pts, tri = mesh.points, mesh.triangles
    m = len(tri)
    area, grad, _ = _split(mesh)
    size = 27 * m
    tau0 = np.broadcast_to(np.repeat(sigma_v[parent], 3, axis=0)[:, None, :], (3 * m, 3, 3)).ravel()

    rows = _Rows()
    subs = np.arange(3 * m)
    # normal traction continuity inside each cell: the edge barycentre -> v_s shared by sub s and s - 1
    P = np.vstack([p_pts, p_pts[tri].mean(axis=1)])
    for s in range(3):
        a, b = 3 * np.arange(m) + s, 3 * np.arange(m) + (s - 1) % 3
        e = P[len(p_pts) + np.arange(m)] - p_pts[tri[:, s]]
        n = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
        _continuity(rows, a, 0, b, 1, n)            # at v_s: local 0 of sub s, local 1 of sub s - 1
        _continuity(rows, a, 2, b, 2, n)            # at the barycentre
    # across the mesh's interior edges; the boundary conditions on its boundary edges
    cells, local, pairs = mesh_edges(mesh)
    c0, l0 = cells[:, 0], local[:, 0]
    sa, sb = p_pts[tri[c0, l0]], p_pts[tri[c0, (l0 + 1) % 3]]
    h = np.linalg.norm(sb - sa, axis=1)
    n_out = np.column_stack([(sb - sa)[:, 1], -(sb - sa)[:, 0]]) / h[:, None]     # outward of c0
    inner = np.flatnonzero(cells[:, 1] >= 0)
    c1, l1 = cells[inner, 1], local[inner, 1]
    same = tri[c1, l1] == tri[c0[inner], l0[inner]]
    sub0, sub1 = 3 * c0[inner] + l0[inner], 3 * c1 + l1
    _continuity(rows, sub0, 0, sub1, np.where(same, 0, 1), n_out[inner])
    _continuity(rows, sub0, 1, sub1, np.where(same, 1, 0), n_out[inner])
    _boundary_rows(rows, sol, body, mesh, cells, local, pairs, n_out, loads, n_p)
    # div tau = -f on every sub-triangle
    f = np.asarray(body.body_force.value, dtype=float)
    g = grad                                                                          # (3m, 2, 3)
    rows.add([(_index(subs, k, 0), g[:, 0, k]) for k in range(3)] + [(_index(subs, k, 2), g[:, 1, k]) for k in range(3)],
             np.full(3 * m, -f[0]))
    rows.add([(_index(subs, k, 2), g[:, 0, k]) for k in range(3)] + [(_index(subs, k, 1), g[:, 1, k]) for k in range(3)],
             np.full(3 * m, -f[1]))
    A, rhs, B = rows.matrix(size, n_p)
    scale = 1.0 / np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
    A, B = sp.diags(scale) @ A, sp.diags(scale) @ B
    rhs = rhs * scale

    # M^-1: per sub-triangle (3 / area) K3_INV kron C (the inverse of (area / 12) [[2,1,1],..] kron C^-1)
    blocks = (3.0 / area)[:, None, None] * np.kron(_K3_INV, c_mat)[None]
    Minv = sp.block_diag(list(blocks), format="csr")
    S = (A @ Minv @ A.T).tocsc()                     # regularised: singular where rows are redundant
    lu = spla.splu((S + 1e-10 * S.diagonal().max() * sp.identity(S.shape[0], format="csc")).tocsc())
    return {"mesh": mesh, "parent": parent, "m": m0, "area": area, "tau0": tau0, "v": lift @ v, "phi_h": phi_h,
            "D_v": D_v, "sigma_v": sigma_v, "A": A, "rhs": rhs, "B": B, "Minv": Minv, "S": S, "lu": lu}


def body_stress(sol, body, system, p) -> dict:
    """The equilibrated stress of one body (``system``: :func:`body_system`) for the contact pressures p, its
    conditions' residual checked, and the equilibrated electric displacement of a piezoelectric body."""
    A, rhs = system["A"], system["rhs"] + system["B"] @ p
    tau = _equilibrate(system["S"], system["lu"], A, rhs, system["Minv"], system["tau0"])
    residual = np.abs(A @ tau - rhs).max()
    stress_scale = max(np.abs(tau).max(), np.abs(system["sigma_v"]).max(), np.finfo(float).tiny)
    if not residual <= _EQUILIBRIUM_TOL * stress_scale:
        raise SolverError(f"{body.name}: the equilibrated stress satisfies its conditions only to "
                          f"{residual / stress_scale:.3g} (relative; needed {_EQUILIBRIUM_TOL:g}): the error bound is "
                          "not available for this mesh")
    part = {k: system[k] for k in ("mesh", "parent", "m", "area", "tau0", "v", "phi_h")}
    part.update(tau=tau, residual=float(residual / stress_scale), electric=np.zeros(system["m"]))
    if body.piezoelectric:
        D_vertices, electric, residual_e = _equilibrated_flux(sol, body, system["D_v"])
        part.update(D=D_vertices, electric=electric, residual=max(part["residual"], residual_e))
    return part


def _divided(mesh, cuts):
    """``mesh`` with boundary edges divided (the reconstruction mesh of :func:`reconstruction_mesh`): ``cuts``
    a list of (tag, breaks), breaks (k,) positions along the tag's line, s = x . t for a unit direction t
    given with them as breaks = (t, s values): each edge of the tag gets nodes at the s strictly inside it, its
    cell becomes a fan from the opposite vertex. Returns (mesh, parent cell (m',), lift (n', n): the nodal
    values of a P1 function of ``mesh`` at the new mesh's nodes, sparse)."""
    p, tri = mesh.points, mesh.triangles
    n, m = len(p), len(tri)
    new_pts, new_tri, parent = [p], [tri], [np.arange(m)]
    lift_r, lift_c, lift_v = [np.arange(n)], [np.arange(n)], [np.ones(n)]
    chains = {}                                       # sorted edge (a, b) -> the node chain from a to b
    owners, _, _, keys = facets(tri, n)
    tri = tri.copy()
    count, divided = n, set()
    for tag, (t, s_breaks) in cuts:
        if not len(s_breaks):
            continue
        for a, b in mesh.boundary(tag):
            key = min(a, b) * n + max(a, b)
            if (min(a, b), max(a, b)) in chains:
                continue
            sa, sb = p[a] @ t, p[b] @ t
            lo, hi = min(sa, sb), max(sa, sb)
            tol = 1e-9 * (hi - lo)
            inside = s_breaks[(s_breaks > lo + tol) & (s_breaks < hi - tol)]
            if not len(inside):
                continue
            c = int(owners[np.searchsorted(keys, key), 0])
            if c in divided:
                raise UnsupportedError(f"the equilibrated error bound: cell {c} has two contact edges to divide "
                                       "(a cell touching two contact parts); refine the mesh once")
            divided.add(c)
            local = list(tri[c])
            la = local.index(a)
            first, second = (a, b) if local[(la + 1) % 3] == b else (b, a)
            o = local[(local.index(first) + 2) % 3]
            s0, s1 = p[first] @ t, p[second] @ t
            tt = np.sort((inside - s0) / (s1 - s0))
            ids = count + np.arange(len(tt))
            count += len(tt)
            new_pts.append(p[first][None] + tt[:, None] * (p[second] - p[first])[None])
            lift_r += [ids, ids]
            lift_c += [np.full(len(tt), first), np.full(len(tt), second)]
            lift_v += [1.0 - tt, tt]
            chain = np.concatenate([[first], ids, [second]])
            fan = np.column_stack([chain[:-1], chain[1:], np.full(len(chain) - 1, o)])
            tri[c] = fan[0]
            new_tri.append(fan[1:])
            parent.append(np.full(len(fan) - 1, c))
            chains[(min(a, b), max(a, b))] = chain
    if not chains:
        return mesh, np.arange(m), sp.identity(n, format="csr")
    points = np.vstack(new_pts)
    triangles = np.vstack([tri] + new_tri[1:])
    boundaries = {}
    for tag in mesh.tags:
        edges = []
        for a, b in mesh.boundary(tag):
            chain = chains.get((min(a, b), max(a, b)))
            edges.append(np.array([[a, b]]) if chain is None else np.column_stack([chain[:-1], chain[1:]]))
        boundaries[tag] = np.vstack(edges)
    lift = sp.csr_matrix((np.concatenate(lift_v), (np.concatenate(lift_r), np.concatenate(lift_c))),
                         shape=(count, n))
    return Mesh(points, triangles, boundaries), np.concatenate(parent), lift


def _equilibrate(S, lu, A, rhs, Minv, tau0, steps: int = 30):
    """argmin (tau - tau0)^T M (tau - tau0) subject to A tau = rhs: tau = tau0 + M^-1 A^T y with
    S y = rhs - A tau0, S = A M^-1 A^T, ``lu`` the factors of S regularised (it is singular where rows are
    redundant), refined until the residual stops falling."""
    r0 = rhs - A @ tau0
    y = np.zeros_like(r0)
    best, best_y = np.inf, y
    for step in range(steps):
        res = r0 - S @ y
        norm = np.abs(res).max()
        if norm < best:
            best, best_y = norm, y.copy()
        if norm <= 1e-15 * max(np.abs(r0).max(), 1e-300) or (step > 3 and norm > 0.9 * best):
            break
        y = y + lu.solve(res)
    return tau0 + Minv @ (A.T @ best_y)


def _boundary_rows(rows, sol, body, mesh, cells, local, pairs, n_out, loads, n_p):
    """tau n on the boundary edges of ``mesh`` (``body``'s reconstruction mesh; module docstring): traction t,
    0 on free parts, -p d on the contact parts (``loads``: the edges inside a pair's overlap, p the pair's
    entries ``offset`` + (0 .. len(x) - 1) of the pressures (n_p,): right-hand sides linear in p; 0 on the
    others), tangential 0 on rollers, the free components 0 on parts with prescribed components, nothing on
    clamped parts."""
    p = mesh.points
    bnd = np.flatnonzero(cells[:, 1] < 0)
    key = pairs[:, 0].astype(np.int64) * len(p) + pairs[:, 1]
    role = np.full(len(key), "free", dtype=object)
    tag_of = np.full(len(key), None, dtype=object)
    mech, _ = boundary_roles(body, sol)
    for tag, r in mech.items():
        e = mesh.boundary(tag)
        idx = np.searchsorted(key, np.minimum(e[:, 0], e[:, 1]).astype(np.int64) * len(p) + np.maximum(e[:, 0], e[:, 1]))
        role[idx], tag_of[idx] = r, tag
    tri = mesh.triangles
    c0, l0 = cells[:, 0], local[:, 0]
    ends = np.column_stack([tri[c0, l0], tri[c0, (l0 + 1) % 3]])      # node of local vertex 0, 1 of the sub
    # -p d at the two ends j of the contact edges, component comp: pressure[j][comp] @ p (len(key), n_p)
    pressure = [[sp.csr_matrix((len(key), n_p)) for _ in range(2)] for _ in range(2)]
    for load in loads:
        e = mesh.boundary(load["part"])
        idx = np.searchsorted(key, np.minimum(e[:, 0], e[:, 1]).astype(np.int64) * len(p) + np.maximum(e[:, 0], e[:, 1]))
        s = p[ends[idx]] @ load["tangent"]                                               # (k, 2)
        x, tol = load["x"], load["tol"]
        inside = ((s >= x[0] - tol) & (s <= x[-1] + tol)).all(axis=1)
        idx, s = idx[inside], s[inside]
        pick = sp.csr_matrix((np.ones(len(idx)), (idx, np.arange(len(idx)))), shape=(len(key), len(idx)))
        place = sp.csr_matrix((np.ones(len(x)), (load["offset"] + np.arange(len(x)), np.arange(len(x)))),
                              shape=(n_p, len(x)))
        for j in range(2):
            hat = pick @ _hat(s[:, j], x) @ place.T
            for comp in range(2):
                pressure[j][comp] = pressure[j][comp] - load["d"][comp] * hat
    for j in range(2):
        for r in ("free", "traction", "contact"):
            idx = bnd[role[bnd] == r]
            if not len(idx):
                continue
            t = np.zeros((len(idx), 2))
            if r == "traction":
                t = np.array([body.traction[tag_of[i]].value for i in idx], dtype=float)
            for comp, terms in enumerate(rows.traction(3 * c0[idx] + l0[idx], j, n_out[idx])):
                rows.add(terms, t[:, comp], pressure[j][comp][idx] if r == "contact" else None)
        idx = bnd[role[bnd] == "roller"]
        if len(idx):
            n = n_out[idx]
            tx, ty = rows.traction(3 * c0[idx] + l0[idx], j, n)
            tvec = np.column_stack([-n[:, 1], n[:, 0]])
            rows.add([(cols, coef * tvec[:, 0]) for cols, coef in tx] + [(cols, coef * tvec[:, 1]) for cols, coef in ty],
                     np.zeros(len(idx)))
        idx = bnd[role[bnd] == "partial"]
        for i in idx:
            free = [k for k, val in enumerate(body.displacement[tag_of[i]]) if val is None]
            terms = rows.traction(np.array([3 * c0[i] + l0[i]]), j, n_out[[i]])
            for k in free:
                rows.add(terms[k], np.zeros(1))


def _hat(s, x):
    """The P1 hat functions of the ascending nodes x at the points s (clamped to [x_0, x_-1]): (len(s),
    len(x)) sparse, ``_hat(s, x) @ p == np.interp(s, x, p)``."""
    s = np.clip(s, x[0], x[-1])
    k = np.clip(np.searchsorted(x, s, side="right") - 1, 0, len(x) - 2)
    t = (s - x[k]) / (x[k + 1] - x[k])
    r = np.arange(len(s))
    return sp.csr_matrix((np.concatenate([1.0 - t, t]), (np.concatenate([r, r]), np.concatenate([k, k + 1]))),
                         shape=(len(s), len(x)))


# ---------------------------------------------------------------------------------------------- the flux


def _equilibrated_flux(sol, body, D_v):
    """The equilibrated electric displacement of a piezoelectric body (docs/accuracy.md, "Piezoelectric
    bodies"): the Raviart-Thomas (RT0) field D~ closest to the solution's D_v = e eps(v) - kappa grad phi_h in
    || kappa^{-1/2} (.) ||, subject to div D~ = q0 on every triangle, D~ . n = q2 on the charged edges, 0 on
    the other edges that are no electrode, and on each floating electrode the total flux int D~ . n = -Q (its
    charge; D~ . n free along it: phi - phi_h is one constant there); free on grounded and driven electrodes.
    One global sparse saddle-point solve over the edge fluxes (C/m). Returns (D~ (m, 3, 2) at the vertices of
    every triangle, C/m^2, linear in between; per triangle || kappa^{-1/2} (D~ - D_v) ||_T^2 (J/m); the
    relative residual of the conditions)."""
    mesh = body.mesh
    p, tri = mesh.points, mesh.triangles
    m, n = len(tri), len(p)
    kappa_inv = np.linalg.inv(body.material.tensors(2)[2])
    owners, opposite, pairs, key = facets(tri, n)
    k = len(key)
    # the edge opposite local vertex i of each triangle, and its orientation (+1: outward of the triangle)
    edge = np.zeros((m, 3), dtype=np.int64)
    sign = np.zeros((m, 3))
    for j, s_ in ((0, 1.0), (1, -1.0)):
        has = owners[:, j] >= 0
        edge[owners[has, j], opposite[has, j]] = np.flatnonzero(has)
        sign[owners[has, j], opposite[has, j]] = s_
    # the RT0 basis of flux 1 through edge i: b_i(x) = sign_i (x - p_i) / (2 |T|), at the edge midpoints
    P = p[tri]                                                                       # (m, 3, 2)
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    mid = 0.5 * (np.roll(P, -1, axis=1) + np.roll(P, -2, axis=1))                   # midpoint opposite vertex q
    B = sign[:, None, :, None] * (mid[:, :, None, :] - P[:, None, :, :]) / (2.0 * area)[:, None, None, None]
    # exact for the quadratic integrands: int_T f = |T| / 3 sum over the edge midpoints
    Mloc = (area / 3.0)[:, None, None] * np.einsum("mqid,de,mqje->mij", B, kappa_inv, B)
    gloc = (area / 3.0)[:, None] * np.einsum("mqid,de,me->mi", B, kappa_inv, D_v)
    M = sp.csr_matrix((Mloc.ravel(), (np.repeat(edge, 3, axis=1).ravel(), np.tile(edge, (1, 3)).ravel())),
                      shape=(k, k))
    g = np.bincount(edge.ravel(), gloc.ravel(), minlength=k)
    # the conditions C F = c: the divergence on each triangle, the boundary fluxes, the floating charges
    rows, cols, vals = [np.repeat(np.arange(m), 3)], [edge.ravel()], [sign.ravel()]
    rhs = [body.volume_charge.value * area]
    count = m
    boundary = np.flatnonzero(owners[:, 1] < 0)
    role = dict.fromkeys(boundary.tolist(), 0.0)                     # edge -> prescribed flux; free electrodes out
    length = np.linalg.norm(p[pairs[:, 1]] - p[pairs[:, 0]], axis=1)

    def edges_of(tag):
        e = np.sort(mesh.boundary(tag), axis=1)
        return np.searchsorted(key, e[:, 0].astype(np.int64) * n + e[:, 1])

    for tag, q2 in body.surface_charge.items():
        role.update({int(i): float(q2.value) * length[i] for i in edges_of(tag)})
    for tag in [*body.grounded, *body.potential, *body.floating]:
        for i in edges_of(tag):
            role.pop(int(i), None)
    fixed = np.array(sorted(role), dtype=np.int64)
    rows.append(count + np.arange(len(fixed)))
    cols.append(fixed)
    vals.append(np.ones(len(fixed)))
    rhs.append(np.array([role[i] for i in fixed.tolist()]))
    count += len(fixed)
    for tag, charge in body.floating.items():
        e = edges_of(tag)
        rows.append(np.full(len(e), count))
        cols.append(e)
        vals.append(np.ones(len(e)))
        rhs.append(np.array([-float(charge)]))
        count += 1
    C = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(count, k))
    c = np.concatenate(rhs)
    F = _constrained_minimum(M, g, C, c)
    D_at = np.einsum("mqid,mi->mqd", B, F[edge])                                       # D~ at the midpoints
    diff = D_at - D_v[:, None, :]
    electric = (area / 3.0) * np.einsum("mqd,de,mqe->m", diff, kappa_inv, diff)
    scale = max(np.abs(c).max(initial=0.0), (np.abs(D_v).max() + np.abs(D_at).max()) * length.max(),
                np.finfo(float).tiny)
    residual = float(np.abs(C @ F - c).max() / scale)
    if not residual <= _EQUILIBRIUM_TOL:
        raise SolverError(f"the equilibrated electric displacement satisfies its conditions only to {residual:.3g} "
                          f"(relative; needed {_EQUILIBRIUM_TOL:g}): the error bound is not available for this mesh")
    D_vertices = np.einsum("mi,mjid->mjd", sign * F[edge],
                           (P[:, :, None, :] - P[:, None, :, :]) / (2.0 * area)[:, None, None, None])
    return D_vertices, electric, residual


def _constrained_minimum(M, g, C, c, steps: int = 30):
    """argmin 1/2 F^T M F - g^T F subject to C F = c (M symmetric positive definite): the saddle-point system
    [[M, C^T], [C, 0]], factorised with -delta I in its second block (C may have dependent rows: the
    divergences and boundary fluxes of a body without electrode sum to the same total) and refined on the
    unregularised system until its residual stops falling."""
    k, r = M.shape[0], C.shape[0]
    rs = 1.0 / np.sqrt(np.maximum(np.asarray(C.multiply(C).sum(axis=1)).ravel(), np.finfo(float).tiny))
    C, c = sp.diags(rs) @ C, c * rs
    delta = 1e-10 / M.diagonal().max()                  # against the Schur complement C M^-1 C^T ~ 1 / M
    K = sp.bmat([[M, C.T], [C, None]], format="csc")
    lu = spla.splu((K - sp.block_diag([sp.csc_matrix((k, k)), delta * sp.identity(r)], format="csc")).tocsc())
    rhs = np.concatenate([g, c])
    x = np.zeros(k + r)
    best, best_x = np.inf, x
    absK = abs(K)
    for step in range(steps):
        res = rhs - K @ x
        scale = np.maximum(np.abs(rhs), absK @ np.abs(x))                  # each row's own size
        norm = max(np.abs(res[:k]).max() / max(scale[:k].max(), 1e-300),
                   np.abs(res[k:]).max(initial=0.0) / max(scale[k:].max(initial=0.0), 1e-300))
        if norm < best:
            best, best_x = norm, x.copy()
        if norm <= 1e-15 or (step > 3 and norm > 0.9 * best):
            break
        x = x + lu.solve(res)
    return best_x[:k]
