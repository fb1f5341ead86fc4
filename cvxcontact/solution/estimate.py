"""A posteriori error estimate of a solution: a residual estimator with contact terms (docs/accuracy.md).

The error is measured in the energy norm of the coupled problem (docs/formulation.md §2; the skew
coupling drops out of A((u, phi), (u, phi))):

    |||(v, psi)|||^2 = sum over bodies int_Omega  c eps(v) : eps(v) + kappa grad psi . grad psi      (J/m)

The estimator (Hild & Nicaise 2005 for Signorini contact, with the electric counterparts) sums, per cell T
of every body,

    eta_T^2 = 1/c_T [ h_T^2 ||f0 + div sigma_h||_T^2 + sum_E h_E ||R_E||_E^2 ]
            + 1/kappa_T [ h_T^2 ||div D_h - q0||_T^2 + sum_E h_E ||r_E||_E^2 ]
            + contact terms of the merged segments next to T,

E the edges of T: an interior edge counts half of R_E = [sigma_h n] (r_E = [D_h . n]); a traction edge
R_E = sigma_h n - f2, a free edge sigma_h n (a roller's: its tangential part; a part with prescribed
components: the free ones), a charged edge r_E = D_h . n - q2 (D . nu = q2, eq. (11)), a free one D_h . n;
clamped edges and electrodes none. On the contact part of each side, R_E = sigma_h n + lambda_h n (eq. (8):
sigma_nu = -lambda, sigma_tau = 0; lambda_h the solution's multiplier, 0 beyond the merged mesh). On each
merged segment S of a Signorini pair, the complementarity int_S lambda_h^+ (g - [u_h nu])^+ and the
penetration c_T / h_S ||([u_h nu] - g)^+||_S^2 (shared by the cells of both sides). c_T (Pa) is the
smallest eigenvalue of the body's stiffness on tensor-orthonormal strains (2 mu for an isotropic
material), kappa_T (F/m) the smallest of its permittivity: with them every term is an energy (J/m).
h_T is the longest edge of T, h_E the length of E.

The constants of reliability are unknown: the estimate is not a guaranteed bound (``guaranteed`` False);
its effectivity (estimate / true error) is measured against nested fine-mesh references
(:mod:`cvxcontact.apps.studies.estimate`, docs/accuracy.md).

Covered: 2D, P1 and P2 (triangles), elastic and piezoelectric bodies, pairs and rigid obstacles, the three
Signorini conditions and normal compliance (then the traction mismatch only: the law allows the
penetration). Not covered yet: 3D (``Solution.estimate`` is None and ``Solution.estimate_reason`` says
why).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..fem.assembly import gradients, strain_matrix
from ..fem.p2 import shape_gradients
from ..geometry.mesh import _edge_table

__all__ = ["ErrorEstimate", "estimate", "energy_density", "cell_energies", "vertex_fields", "UNCOVERED"]

UNCOVERED = {3: "3D (tetrahedra): the residual estimator of this version covers 2D triangles only"}
"""Why a solution gets no estimate, by what it is (the dimension)."""

_GAUSS2 = (0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0), np.array([0.5, 0.5]))     # exact to degree 3 on [0, 1]
_GAUSS3 = (0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5 / 18, 8 / 18, 5 / 18]))
_TRI3 = (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3))


@dataclass(frozen=True)
class ErrorEstimate:
    """The estimated discretisation error of a solution in the energy norm (module docstring).

    ``absolute``: eta = (sum_T eta_T^2)^(1/2), sqrt(J/m) (per unit thickness); ``norm``: the solution's own
    energy norm |||(u_h, phi_h)|||, same unit; ``relative`` = absolute / norm. ``indicators[k]`` (m_k,):
    eta_T of each triangle of body k (``scene.bodies[k].mesh.triangles``). ``parts``: eta^2 split by term
    (J/m). ``guaranteed``: whether ``absolute`` is a proven upper bound of the true error (False: a residual
    estimator's constants are unknown; its effectivity is measured, docs/accuracy.md). ``kind``: "residual".
    """

    absolute: float
    norm: float
    indicators: tuple
    parts: dict = field(default_factory=dict)
    guaranteed: bool = False
    kind: str = "residual"

    @property
    def relative(self) -> float:
        """absolute / norm (dimensionless); inf for a solution of zero energy with a non-zero estimate."""
        if self.norm > 0:
            return self.absolute / self.norm
        return 0.0 if self.absolute == 0 else float("inf")

    def __str__(self) -> str:
        return (f"{100 * self.relative:.3g} % ({self.kind}, {'guaranteed' if self.guaranteed else 'not guaranteed'}; "
                f"{self.absolute:.4g} of {self.norm:.4g} sqrt(J/m) in the energy norm)")


# ---------------------------------------------------------------------------------------------- fields


def vertex_fields(body, u, phi, degree: int):
    """The fields of body ``body`` (2D) at the three vertices of each triangle, from whose barycentric
    interpolation they follow everywhere in it (constant for P1, affine for P2 on straight triangles):
    strain eps (m, 3, 3) Voigt (xx, yy, 2xy), grad phi (m, 3, 2) V/m or None, sigma (m, 3, 3) Pa Voigt
    (xx, yy, xy) = c eps + e^T grad phi, D (m, 3, 2) C/m^2 = e eps - kappa grad phi or None; and the
    barycentric gradients (m, 2, 3), areas (m,)."""
    mesh = body.mesh
    c, e, kappa = body.material.tensors(2)
    area, gradL = gradients(mesh.points, mesh.triangles)
    u = np.asarray(u, dtype=float)
    if degree == 1:
        el = mesh.triangles
        G = np.repeat(gradL[:, None], 3, axis=1)                                    # (m, 3 vertices, 2, 3)
    else:
        from ..geometry.quadratic import P2Nodes

        el = P2Nodes(mesh).triangles
        G = np.stack([shape_gradients(gradL, np.eye(3)[i]) for i in range(3)], axis=1)   # (m, 3, 2, 6)
    m = len(el)
    ue = u[el].reshape(m, -1)
    eps = np.stack([np.einsum("mij,mj->mi", strain_matrix(G[:, i]), ue) for i in range(3)], axis=1)
    sigma = eps @ c.T
    gphi = D = None
    if e is not None:
        pe = np.asarray(phi, dtype=float)[el]
        gphi = np.einsum("mvdj,mj->mvd", G, pe)
        sigma = sigma + gphi @ e
        D = eps @ e.T - gphi @ kappa.T
    return eps, gphi, sigma, D, gradL, area


def energy_density(body, eps, gphi):
    """c eps : eps + kappa grad phi . grad phi (J/m^3) of Voigt strains ``eps`` (..., 3) and ``gphi`` (..., 2)."""
    c, _, kappa = body.material.tensors(2)
    w = np.einsum("...i,ij,...j->...", eps, c, eps)
    if gphi is not None:
        w = w + np.einsum("...i,ij,...j->...", gphi, kappa, gphi)
    return w


def cell_energies(body, u, phi, degree: int) -> np.ndarray:
    """(m,) int_T c eps(u) : eps(u) + kappa grad phi . grad phi of each triangle (J/m): the squared energy
    norm of (u, phi) cell by cell (exact: the integrand is at most quadratic, the 3-point rule degree 2)."""
    eps, gphi, _, _, _, area = vertex_fields(body, u, phi, degree)
    total = 0.0
    for L, w in zip(*_TRI3):
        total = total + w * energy_density(body, L @ eps, None if gphi is None else L @ gphi)
    return total * area


def _smallest(matrix, voigt: bool) -> float:
    """The smallest eigenvalue of a stiffness (Voigt, engineering shear: on tensor-orthonormal strains) or
    permittivity matrix."""
    a = np.asarray(matrix, dtype=float)
    if voigt:
        s = np.array([1.0, 1.0, np.sqrt(2.0)])
        a = s[:, None] * a * s[None, :]
    return float(np.linalg.eigvalsh(0.5 * (a + a.T)).min())


# ---------------------------------------------------------------------------------------------- the estimator


def estimate(sol) -> tuple[ErrorEstimate | None, str]:
    """(the :class:`ErrorEstimate` of ``sol``, "") or (None, why not) for a case not covered (module
    docstring)."""
    scene = sol.scene
    if scene.dim in UNCOVERED:
        return None, UNCOVERED[scene.dim]
    bodies = scene.bodies
    eta2 = [np.zeros(len(b.mesh.triangles)) for b in bodies]
    parts = dict.fromkeys(("element", "jump", "boundary", "contact traction", "electric element", "electric jump",
                           "electric boundary", "complementarity", "penetration"), 0.0)
    norm2 = 0.0
    data, cache = [], []
    for k, b in enumerate(bodies):
        fields = vertex_fields(b, sol.u[k], sol.phi[k], sol.degree)
        edges = _edges(b.mesh)
        cache.append((fields, edges))
        eps, gphi, sigma, D, gradL, area = fields
        w = 0.0
        for L, wq in zip(*_TRI3):
            w = w + wq * energy_density(b, L @ eps, None if gphi is None else L @ gphi)
        norm2 += float((w * area).sum())
        c, _, kappa = b.material.tensors(2)
        cT = _smallest(c, True)
        kT = _smallest(kappa, False) if kappa is not None else None
        data.append((cT, kT))
        hT = _diameters(b.mesh)
        _element_terms(b, fields, hT, cT, kT, eta2[k], parts)
        _edge_terms(b, fields, edges, cT, kT, eta2[k], parts, sol)
    _contact_terms(sol, data, cache, eta2, parts)
    indicators = tuple(_read_only(np.sqrt(np.maximum(e, 0.0))) for e in eta2)
    total = float(sum(e.sum() for e in eta2))
    return ErrorEstimate(absolute=float(np.sqrt(max(total, 0.0))), norm=float(np.sqrt(max(norm2, 0.0))),
                         indicators=indicators, parts=parts), ""


def _read_only(a):
    a = np.asarray(a, dtype=float)
    a.setflags(write=False)
    return a


def _diameters(mesh) -> np.ndarray:
    p = mesh.points[mesh.triangles]
    return np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2).max(axis=1)


def _points(mesh, L):
    """(m, 2) the points of barycentric coordinates L (3,) or (m, 3) in each triangle."""
    p = mesh.points[mesh.triangles]
    return np.einsum("...k,mkd->md", L, p)


def _element_terms(body, fields, hT, cT, kT, eta2, parts):
    """h_T^2 ||f0 + div sigma_h||^2 / c_T and h_T^2 ||div D_h - q0||^2 / kappa_T (the 3-point rule)."""
    eps, gphi, sigma, D, gradL, area = fields
    mesh = body.mesh
    # sigma is affine: d sigma / d x_j = sum_i sigma(vertex i) d L_i / d x_j
    dsig = np.einsum("mvs,mjv->msj", sigma, gradL)                                # (m, 3 voigt, 2)
    div = np.column_stack([dsig[:, 0, 0] + dsig[:, 2, 1], dsig[:, 2, 0] + dsig[:, 1, 1]])
    mech = elec = 0.0
    f0, q0 = body.body_force, body.volume_charge
    for L, w in zip(*_TRI3):
        r = div.copy()
        if f0.nonzero:
            x = _points(mesh, L)
            r += np.asarray(f0(x[:, 0], x[:, 1]), dtype=float).reshape(len(r), 2)
        mech = mech + w * (r ** 2).sum(axis=1)
        if D is not None:
            rd = np.einsum("mvd,mdv->m", D, gradL)                                  # div D (constant)
            if q0.nonzero:
                x = _points(mesh, L)
                rd = rd - np.asarray(q0(x[:, 0], x[:, 1]), dtype=float).reshape(len(rd))
            elec = elec + w * rd ** 2
    term = hT ** 2 * mech * area / cT
    eta2 += term
    parts["element"] += float(term.sum())
    if D is not None:
        term = hT ** 2 * elec * area / kT
        eta2 += term
        parts["electric element"] += float(term.sum())


def _edges(mesh):
    """Every edge of the mesh once: (cells (k, 2) with -1 for a boundary edge's missing neighbour, local
    edge index in each (k, 2), vertex pair (k, 2) sorted)."""
    n = len(mesh.points)
    _, keys_s, order, start, count = _edge_table(mesh.triangles.astype(np.int64), n)   # row 3 t + i: i -> i+1
    first = order[start]
    second = np.where(count == 2, order[np.minimum(start + 1, len(order) - 1)], -1)
    cells = np.column_stack([first // 3, np.where(second >= 0, second // 3, -1)])
    local = np.column_stack([first % 3, np.where(second >= 0, second % 3, -1)])
    pairs = np.column_stack([keys_s[start] // n, keys_s[start] % n])
    return cells, local, pairs


def _edge_bary(local, t, reverse):
    """(k, 3) barycentric coordinates of the point at parameter t along local edge ``local`` (i -> i+1) of
    each cell; ``reverse``: t measured from the edge's other end."""
    k = len(local)
    L = np.zeros((k, 3))
    s = np.where(reverse, 1.0 - t, t)
    L[np.arange(k), local] = 1.0 - s
    L[np.arange(k), (local + 1) % 3] = s
    return L


def _traction(sigma_v, L, n):
    """sigma n (k, 2) at barycentric L (k, 3) of Voigt vertex values (k, 3, 3), unit normals n (k, 2)."""
    s = np.einsum("kv,kvs->ks", L, sigma_v)
    return np.column_stack([s[:, 0] * n[:, 0] + s[:, 2] * n[:, 1], s[:, 2] * n[:, 0] + s[:, 1] * n[:, 1]])


def _boundary_roles(body, sol):
    """Per boundary part of ``body``: its mechanical role ("dirichlet", "roller", "partial", "traction",
    "contact") and electric role ("dirichlet", "charge")."""
    mech, elec = {}, {}
    for t in body.clamped:
        mech[t] = "dirichlet"
    for t, v in body.displacement.items():
        mech[t] = "dirichlet" if all(x is not None for x in v) else "partial"
    for t in body.roller:
        mech[t] = "roller"
    for t in body.traction:
        mech[t] = "traction"
    for c in sol.scene.contacts:
        if c.body_a is body:
            mech[c.part_a] = "contact"
        if not c.rigid and c.other is body:
            mech[c.part_b] = "contact"
    if body.piezoelectric:
        for t in [*body.grounded, *body.potential, *body.floating]:
            elec[t] = "dirichlet"
        for t in body.surface_charge:
            elec[t] = "charge"
    return mech, elec


def _edge_terms(body, fields, edges, cT, kT, eta2, parts, sol):
    """The interior jumps and the boundary residuals of ``body`` (module docstring; ``edges`` its
    :func:`_edges`); contact parts are left to :func:`_contact_terms`."""
    eps, gphi, sigma, D, gradL, area = fields
    mesh = body.mesh
    cells, local, pairs = edges
    p = mesh.points
    hE = np.linalg.norm(p[pairs[:, 1]] - p[pairs[:, 0]], axis=1)
    # the normal of each edge, outward of its first cell: the tangent from local vertex i to i + 1 turned clockwise
    c0, l0 = cells[:, 0], local[:, 0]
    tri = mesh.triangles
    a, b = tri[c0, l0], tri[c0, (l0 + 1) % 3]
    tvec = (p[b] - p[a]) / hE[:, None]
    n = np.column_stack([tvec[:, 1], -tvec[:, 0]])
    rev0 = a != pairs[:, 0]                     # the first cell runs the edge from its larger vertex
    inner = cells[:, 1] >= 0
    mech_role, elec_role = _boundary_roles(body, sol)
    key = pairs[:, 0].astype(np.int64) * len(p) + pairs[:, 1]
    role_m = np.full(len(key), "free", dtype=object)
    role_e = np.full(len(key), "free", dtype=object)
    load_m, load_e = {}, {}
    for roles, out, loads, kind in ((mech_role, role_m, load_m, "traction"), (elec_role, role_e, load_e, "charge")):
        for tag, role in roles.items():
            e = mesh.boundary(tag)
            kt = np.minimum(e[:, 0], e[:, 1]).astype(np.int64) * len(p) + np.maximum(e[:, 0], e[:, 1])
            idx = np.searchsorted(key, kt)
            out[idx] = role
            if role == kind:
                loads[tag] = idx
    mech = np.zeros(len(key))
    elec = np.zeros(len(key))
    c1, l1 = cells[:, 1], local[:, 1]
    for t, w in zip(*_GAUSS2):
        L0 = _edge_bary(l0, t, rev0)
        s0 = _traction(sigma[c0], L0, n)
        x = (1 - t) * p[pairs[:, 0]] + t * p[pairs[:, 1]]
        R = s0.copy()
        if D is not None:
            r = np.einsum("kv,kvd->kd", L0, D[c0])
            r = (r * n).sum(axis=1)
        if inner.any():
            ii = np.flatnonzero(inner)
            a1 = tri[c1[ii], l1[ii]]
            L1 = _edge_bary(l1[ii], t, a1 != pairs[ii, 0])
            R[ii] -= _traction(sigma[c1[ii]], L1, n[ii])
            if D is not None:
                r[ii] -= (np.einsum("kv,kvd->kd", L1, D[c1[ii]]) * n[ii]).sum(axis=1)
        # boundary edges: the loads, the supports
        for tag, idx in load_m.items():
            R[idx] -= np.asarray(body.traction[tag](x[idx, 0], x[idx, 1]), dtype=float).reshape(len(idx), 2)
        R[role_m == "dirichlet"] = 0.0
        R[role_m == "contact"] = 0.0
        roller = np.flatnonzero(role_m == "roller")
        if len(roller):
            R[roller] -= (R[roller] * n[roller]).sum(axis=1)[:, None] * n[roller]      # tangential part only
        for tag, v in body.displacement.items():
            if mech_role.get(tag) == "partial":
                e = mesh.boundary(tag)
                kt = np.minimum(e[:, 0], e[:, 1]).astype(np.int64) * len(p) + np.maximum(e[:, 0], e[:, 1])
                idx = np.searchsorted(key, kt)
                for comp, val in enumerate(v):
                    if val is not None:
                        R[idx, comp] = 0.0
        weight = np.where(inner, 0.5, 1.0)          # an interior jump is shared by its two cells
        mech += w * weight * (R ** 2).sum(axis=1)
        if D is not None:
            for tag, idx in load_e.items():
                r[idx] -= np.asarray(body.surface_charge[tag](x[idx, 0], x[idx, 1]), dtype=float).reshape(len(idx))
            r[role_e == "dirichlet"] = 0.0
            elec += w * weight * r ** 2
    term_m = hE ** 2 * mech / cT                    # h_E ||R||^2 = h_E * (h_E sum_q w_q R_q^2)
    jump = float(term_m[inner].sum()) * 2
    parts["jump"] += jump
    parts["boundary"] += float(term_m[~inner].sum())
    np.add.at(eta2, c0, term_m)
    np.add.at(eta2, c1[inner], term_m[inner])
    if D is not None:
        term_e = hE ** 2 * elec / kT
        parts["electric jump"] += float(term_e[inner].sum()) * 2
        parts["electric boundary"] += float(term_e[~inner].sum())
        np.add.at(eta2, c0, term_e)
        np.add.at(eta2, c1[inner], term_e[inner])


def _lambda_at(c, s):
    """lambda_h (Pa) of contact result ``c`` at tangential coordinates ``s`` (m): its P1 (P2: piecewise
    quadratic) function on the merged mesh, 0 beyond it."""
    x, lam = np.asarray(c.x, dtype=float), np.asarray(c.lam, dtype=float)
    if c.degree == 1:
        return np.interp(s, x, lam, left=0.0, right=0.0)
    xv = x[::2]
    j = np.clip(np.searchsorted(xv, s) - 1, 0, len(xv) - 2)
    t = (s - xv[j]) / (xv[j + 1] - xv[j])
    val = (lam[2 * j] * (1 - t) * (1 - 2 * t) + lam[2 * j + 2] * t * (2 * t - 1) + lam[2 * j + 1] * 4 * t * (1 - t))
    return np.where((s < xv[0]) | (s > xv[-1]), 0.0, val)


def _merged_values(c, s, values):
    """A P1 (P2) function on the merged mesh of ``c`` with nodal ``values``, at ``s`` inside it."""
    x = np.asarray(c.x, dtype=float)
    if c.degree == 1:
        return np.interp(s, x, values)
    xv = x[::2]
    j = np.clip(np.searchsorted(xv, s) - 1, 0, len(xv) - 2)
    t = (s - xv[j]) / (xv[j + 1] - xv[j])
    return values[2 * j] * (1 - t) * (1 - 2 * t) + values[2 * j + 2] * t * (2 * t - 1) + values[2 * j + 1] * 4 * t * (1 - t)


def _contact_terms(sol, data, cache, eta2, parts):
    """On each side of each pair: h_E ||sigma_h n + lambda_h n||^2 / c_T; on each merged segment of a
    Signorini pair the complementarity and the penetration, shared by the cells of the sides (module
    docstring)."""
    scene = sol.scene
    bodies = list(scene.bodies)
    for i, (pair, c) in enumerate(zip(scene.contacts, sol.contacts)):
        t = np.asarray(scene.interfaces[i].tangent, dtype=float)
        sides = [(pair.body_a, pair.part_a)] + ([] if pair.rigid else [(pair.other, pair.part_b)])
        located = []
        for body, part in sides:
            k = next(j for j, b in enumerate(bodies) if b is body)
            mesh = body.mesh
            fields, (cells, local, pairs) = cache[k]
            e = mesh.boundary(part)                                   # oriented: domain on the left
            p = mesh.points
            n = mesh.outward_normals(part)
            h = np.linalg.norm(p[e[:, 1]] - p[e[:, 0]], axis=1)
            key = np.minimum(e[:, 0], e[:, 1]).astype(np.int64) * len(p) + np.maximum(e[:, 0], e[:, 1])
            at = np.searchsorted(pairs[:, 0].astype(np.int64) * len(p) + pairs[:, 1], key)
            cell, loc = cells[at, 0], local[at, 0]
            tri = mesh.triangles
            rev = tri[cell, loc] != e[:, 0]
            acc = np.zeros(len(e))
            for tq, w in zip(*_GAUSS3):
                x = (1 - tq) * p[e[:, 0]] + tq * p[e[:, 1]]
                L = _edge_bary(loc, tq, rev)
                R = _traction(fields[2][cell], L, n) + _lambda_at(c, x @ t)[:, None] * n
                acc += w * (R ** 2).sum(axis=1)
            term = h ** 2 * acc / data[k][0]
            np.add.at(eta2[k], cell, term)
            parts["contact traction"] += float(term.sum())
            s_lo, s_hi = np.minimum(p[e[:, 0]] @ t, p[e[:, 1]] @ t), np.maximum(p[e[:, 0]] @ t, p[e[:, 1]] @ t)
            located.append((k, cell, s_lo, s_hi))
        if c.law is not None and getattr(c.law, "compliant", False):
            continue                                                   # compliance: penetration is the law
        _signorini_terms(c, located, data, eta2, parts)


def _signorini_terms(c, located, data, eta2, parts):
    """int_S lambda_h^+ (g - [u_h nu])^+ and c_T / h_S ||([u_h nu] - g)^+||^2 on each merged segment S,
    split evenly between the sides' cells that hold its midpoint."""
    x = np.asarray(c.x, dtype=float)
    xv = x if c.degree == 1 else x[::2]
    if len(xv) < 2:
        return
    gap = np.zeros(len(x)) if c.gap is None else np.asarray(c.gap, dtype=float)
    open_ = gap - np.asarray(c.jump, dtype=float)                          # g - [u_nu] at the merged nodes
    a, b = xv[:-1], xv[1:]
    hS = b - a
    comp = np.zeros(len(a))
    pen = np.zeros(len(a))
    for tq, w in zip(*_GAUSS3):
        s = a + tq * hS
        lam = _lambda_at(c, s)
        g = _merged_values(c, s, open_)
        comp += w * np.maximum(lam, 0.0) * np.maximum(g, 0.0)
        pen += w * np.maximum(-g, 0.0) ** 2
    comp *= hS
    pen *= hS
    mid = 0.5 * (a + b)
    for k, cell, s_lo, s_hi in located:
        order = np.argsort(s_lo)
        j = np.clip(np.searchsorted(s_lo[order], mid, side="right") - 1, 0, len(order) - 1)
        owner = cell[order[j]]
        share = 1.0 / len(located)
        term_c = share * comp
        term_p = share * data[k][0] * pen / hS
        np.add.at(eta2[k], owner, term_c + term_p)
        parts["complementarity"] += float(term_c.sum())
        parts["penetration"] += float(term_p.sum())
