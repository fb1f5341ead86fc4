"""The residual estimate (:mod:`.estimate`, docs/accuracy.md) on quadrilaterals and hexahedra, Q1 and Q2.

The same terms as on simplices, per cell T of every body,

    eta_T^2 = 1/c_T [ h_T^2 ||f0 + div sigma_h||_T^2 + sum_F h_F ||R_F||_F^2 ]
            + 1/kappa_T [ h_T^2 ||div D_h - q0||_T^2 + sum_F h_F ||r_F||_F^2 ] + contact terms,

with fields that are not affine on a cell: sigma_h, D_h are evaluated at Gauss points of the cell's multilinear
map (:class:`~cvxcontact.fem.quad.TensorElement`), and their divergence from the physical second derivatives
of the fields (the second derivatives of the shape functions as in
:meth:`~cvxcontact.fem.quad.TensorElement.at_points`: a Q1 field's sigma_h varies on a cell, so div sigma_h is
not 0 in general). The fields are formed from their reference derivatives, one matrix product of all cells'
nodal values with the shape functions' values at a rule's point (the same point in every cell; a facet's
points grouped by the facet's place in its cell), then mapped by each cell's Jacobian (closed-form inverses,
:func:`~cvxcontact.fem.quad.inverse`), the Hessian on its symmetric pairs (Q1: the mixed ones alone). Rules: (degree + 2)^d Gauss points on each cell and
(degree + 2)^(d - 1) on each facet (an edge, or a quadrilateral face of a hexahedron), the facet's points
placed in both its cells as the same combination of its corners' reference coordinates, its unit normal and
area element from Nanson's formula n da = det J J^-T N dA on the first cell (N the reference face's normal).
h_T is the cell's diameter (its longest corner-to-corner distance), h_F the facet's. The boundary roles
(clamped, rollers, prescribed components, tractions, charges, electrodes) and the contact terms are the
simplices' (:mod:`.contactestimate`): the contact parts' traces are the same segments (2D) and face triangles
(3D) as the contact rows'; sigma_h n there is read at the points of those triangles, located in the cells by
Newton's method on the multilinear map (:meth:`~cvxcontact.fem.quad.TensorElement.locate`).

The energy norm (the estimate's ``norm``) is integrated by the same cell rule (exact on parallelograms and
parallelepipeds, where it equals u^T K u).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property, lru_cache
from itertools import pairwise

import numpy as np
from scipy.spatial import cKDTree

from ..fem.assembly import VOIGT
from ..fem.hex import face_hats
from ..fem.quad import gauss_cube, inverse
from ..fem.space import space
from ..geometry.facets import facet_keys, paired
from . import contactestimate as contact

__all__ = ["TensorGeometry", "TensorSides"]


class TensorGeometry:
    """What the estimate of one body of quadrilaterals or hexahedra reads from its mesh and material alone, in
    one degree (the counterpart of :class:`~cvxcontact.solution.estimate.Geometry`): the material tensors and
    c_T (Pa), kappa_T (F/m); the element (:class:`~cvxcontact.fem.quad.TensorElement`), the element nodes, the
    cells' corners; h_T; the facet table (each facet's one or two cells and its corners' positions in each) and
    the facets of each boundary part. Kept between load cases as the simplices' geometry is."""

    def __init__(self, body, degree: int):
        mesh = self._mesh = body.mesh
        sp = space(degree, mesh.cell)
        self.space, self.element = sp, sp.element
        self.dim = mesh.points.shape[1]
        self.tensors = c, _, kappa = body.material.tensors(self.dim)
        self.cT = contact.smallest_eigenvalue(c, True)
        self.kT = contact.smallest_eigenvalue(kappa, False) if kappa is not None else None
        self.el = np.asarray(sp.node_set(mesh).cells)
        self.corners = mesh.points[mesh.cells]                                  # (m, 2^d, d)
        self.n = degree + 2                                                     # Gauss points per axis
        self._parts: dict = {}

    @cached_property
    def hT(self) -> np.ndarray:
        """(m,) m: the diameter of each cell (its longest corner-to-corner distance)."""
        return contact.simplex_diameters(self._mesh.points, self._mesh.cells)

    @cached_property
    def facets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(owners (f, 2): the cells sharing each facet, -1 for a boundary facet's missing second; pos0 (f, v):
        the local corners of the facet in its first cell, in order around it; pos1 (f, v): the positions of the
        same vertices in the second cell (interior facets, 0 elsewhere); vertices (f, v); keys (f,) ascending)."""
        mesh, faces = self._mesh, self.element.faces
        cells = np.asarray(mesh.cells)
        nf, v = faces.shape
        every = cells[:, faces].reshape(-1, v)                                  # row nf c + a: face a of cell c
        first, second, keys = paired(_keys(every, len(mesh.points)))
        owners = np.column_stack([first // nf, np.where(second >= 0, second // nf, -1)])
        vertices = every[first]
        pos1 = np.zeros_like(vertices)
        ii = second >= 0
        pos1[ii] = contact.facet_positions(cells[owners[ii, 1]], vertices[ii])
        return owners, faces[first % nf], pos1, vertices, keys

    def part(self, tag) -> np.ndarray:
        """The indices in the facet table of the facets of boundary part ``tag``."""
        if tag not in self._parts:
            mesh = self._mesh
            self._parts[tag] = np.searchsorted(self.facets[4], _keys(np.asarray(mesh.boundary(tag)), len(mesh.points)))
        return self._parts[tag]

    @cached_property
    def _flux(self) -> np.ndarray:
        """(nc d (d + 1) / 2, d [+ 1]): the divergence of the stress (and of D) from the second derivatives of
        the fields w = (u_1, ..., u_d[, phi]), nc components: div_i = sum_(c, g <= p) M[(c, g, p), i]
        d^2 w_c / dx_g dx_p (the Hessian symmetric: the terms of (g, p) and (p, g) in one). Column i < d is row i
        of the stress tensor (sigma_ip), column d (piezoelectric) D_p; the entries are those of c, e, kappa (a
        shear's twice), read off the fields of unit gradients by the formulas of :meth:`_values`."""
        d, nc = self.dim, self._components
        unit = np.eye(nc * d).reshape(nc * d, nc, d)                            # dw_c / dx_g = 1 for one (c, g)
        _, _, sigma, D = self._values(unit)
        F = contact.voigt_tensor(sigma)                                              # ((c, g), i, p)
        if D is not None:
            F = np.concatenate([F, D[:, None, :]], axis=1)
        M = F.reshape(nc, d, -1, d).transpose(0, 1, 3, 2)                      # (c, g, p, i)
        g, p = np.triu_indices(d)                                               # the Hessian's g <= p
        return (M[:, g, p] + np.where((g < p)[:, None], M[:, p, g], 0.0)).reshape(nc * len(g), -1)

    @property
    def _components(self) -> int:
        """The fields' components per node: d displacements and, piezoelectric, the potential."""
        return self.dim + (self.tensors[1] is not None)

    @cached_property
    def _corners_T(self) -> np.ndarray:
        """(m, d, 2^d) the cells' corner coordinates, coordinate-major (the products with shared basis values
        are then one matrix product for all cells)."""
        return np.ascontiguousarray(self.corners.transpose(0, 2, 1))

    def _nodal(self, u, phi, cells=slice(None)) -> np.ndarray:
        """(m, nc, k) the nodal values of u (and phi) on the k element nodes of each of the cells ``cells``,
        component-major."""
        w = np.asarray(u, dtype=float).reshape(-1, self.dim)
        if self.tensors[1] is not None:
            w = np.column_stack([w, np.asarray(phi, dtype=float).reshape(-1)])
        return np.ascontiguousarray(w.T[:, self.el[cells]].transpose(1, 0, 2))

    def _values(self, g):
        """(eps (k, s), grad phi (k, d) or None, sigma (k, s) Pa, D (k, d) C/m^2 or None) of the gradients
        ``g`` (k, nc, d) (g[:, c, p] = dw_c / dx_p): Voigt strains with engineering shears, sigma = c eps -
        e^T E, D = e eps + kappa E, E = -grad phi (eq. (2))."""
        c, e, kappa = self.tensors
        pairs = VOIGT[self.dim]
        eps = np.empty((len(g), len(pairs)))
        for row, (i, j) in enumerate(pairs):
            eps[:, row] = g[:, i, j] if i == j else g[:, i, j] + g[:, j, i]
        sigma = eps @ c.T
        gphi = D = None
        if e is not None:
            gphi = g[:, self.dim]
            sigma = sigma + gphi @ e
            D = eps @ e.T - gphi @ kappa.T
        return eps, gphi, sigma, D

    def _basis(self, xi, second: bool) -> tuple:
        """(N1 (p, 2^d, 1), dN1 (p, 2^d, d), dN (p, k, d), ((d2N1 (p, 2^d, u), d2N (p, k, u)), (a (u,), b (u,)))
        or None) at the reference points ``xi`` (p, d), node-major: the map's and the element's shape functions
        and derivatives, the second d^2 / dxi_a dxi_b for the pairs a <= b where either is not 0 everywhere (Q1:
        a < b, the multilinear functions' own second derivatives 0); those at one point (p = 1: a point of the
        cell or facet rule) kept for the next call (:func:`_shared_basis`)."""
        if len(xi) == 1:
            return _shared_basis(self.element, tuple(np.asarray(xi, dtype=float)[0]), second)
        return _point_basis(self.element, xi, second)

    def _evaluate(self, X, W, basis):
        """(x (k, d) m, det J (k,), J^-T (k, d, d), g (k, nc, d), div (k, d [+ 1]) or None) at one point per
        cell of corners ``X`` (k, d, 2^d) and nodal values ``W`` (k, nc, n), the :meth:`_basis` at those points
        (p = k, or p = 1: the same reference point in every cell, one matrix product for all). The gradients
        g = (grad_xi w) J^-1; the second derivatives J^-T (d^2 w / dxi^2 - sum_c dw/dx_c d^2 x_c / dxi^2) J^-1
        (the map's own curvature taken out, :meth:`~cvxcontact.fem.quad.TensorElement.at_points`), contracted
        with :attr:`_flux`."""
        N1, dN1, dN, d2N = basis
        k, d = len(X), self.dim
        x = _times(X, N1)[:, :, 0]
        det, inv = inverse(_times(X, dN1))                            # J[e, a] = dx_e / dxi_a
        g = _times(W, dN) @ inv                                       # (k, nc, d): dw_c / dx_p
        if d2N is None:
            return x, det, inv.transpose(0, 2, 1), g, None
        (d2N1, d2N), (a, b) = d2N
        R = _times(W, d2N) - g @ _times(X, d2N1)                      # (k, c, u): the pairs u = (a, b) kept
        rows = inv.transpose(1, 2, 0)                                 # (a, g, k): the cells last, contiguous
        gv, pv = np.triu_indices(d)                                   # v = (g, p), g <= p
        kron = rows[a][:, gv] * rows[b][:, pv]                        # (u, v, k): J^-1_ag J^-1_bp (+ a <-> b)
        off = a < b
        kron[off] += rows[b[off]][:, gv] * rows[a[off]][:, pv]
        H = R @ kron.transpose(2, 0, 1)                               # (k, c, v): d^2 w_c / dx_g dx_p
        return x, det, inv.transpose(0, 2, 1), g, H.reshape(k, -1) @ self._flux

    def fields(self, cells, xi, u, phi, second: bool = False):
        """The fields at one reference point ``xi`` (k, d) of each of the cells ``cells`` (k,): (x (k, d) m,
        det J (k,), J^-T (k, d, d), eps (k, s), grad phi (k, d) or None, sigma (k, s) Pa, D (k, d) C/m^2 or None,
        div sigma (k, d) Pa/m and div D (k,) C/m^3 (or None) with ``second``, else None)."""
        return self._fields_of(self._evaluate(self._corners_T[cells], self._nodal(u, phi, cells),
                                              self._basis(np.asarray(xi, dtype=float), second)))

    def _fields_of(self, evaluated):
        """:meth:`fields`' tuple of what :meth:`_evaluate` returned."""
        x, det, inv_T, g, div = evaluated
        eps, gphi, sigma, D = self._values(g)
        divD = None
        if div is not None:
            div, divD = div[:, :self.dim], (div[:, self.dim] if D is not None else None)
        return x, det, inv_T, eps, gphi, sigma, D, div, divD

    def _facet_points(self, cells, pos, W):
        """For each point q of the facet rule: (w_q, x (f, d) m, n da / dA (f, d) m^(d - 1), eps, grad phi, sigma,
        D (:meth:`_values`)) at that point of each facet, in its cell ``cells`` (f,), the facet's corners at the
        local positions ``pos`` (f, v) there, with the nodal values ``W`` (m, nc, n); n da / dA = det J J^-T N
        (Nanson's formula, N the reference face's unit outward normal: the mean of its corners). The facets
        are taken in groups of the same ``pos`` (one reference point per group and q: its shape functions
        evaluated once, one matrix product for the group), each group's values written back in place."""
        Wq, wq = self.element.face_rule(self.n)
        corners, d = self.element.corners, self.dim
        f, (base, v) = len(cells), (len(corners), pos.shape[1])
        code = (pos * base ** np.arange(v)).sum(axis=1)
        seen = np.zeros(base ** v, dtype=bool)
        seen[code] = True
        labels = np.flatnonzero(seen)
        which = np.searchsorted(labels, code)
        order = np.argsort(which, kind="stable")
        bounds = np.searchsorted(which[order], np.arange(len(labels) + 1))
        rep = np.empty(len(labels), dtype=int)
        rep[which] = np.arange(f)
        ref = np.einsum("qv,gvd->gqd", Wq, corners[pos[rep]])                       # (groups, q, d)
        normal = corners[pos[rep]].mean(axis=1)                                     # (groups, d)
        X, Wo = self._corners_T[cells[order]], W[cells[order]]
        for q in range(len(wq)):
            x, nda, g = np.empty((f, d)), np.empty((f, d)), np.empty((f, W.shape[1], d))
            for k, (a, b) in enumerate(pairwise(bounds)):
                at = order[a:b]
                x[at], det, inv_T, g[at], _ = self._evaluate(X[a:b], Wo[a:b], self._basis(ref[k, q][None], False))
                nda[at] = det[:, None] * (inv_T @ normal[k])
            yield (wq[q], x, nda) + self._values(g)

    def terms(self, body, u, phi, eta2, parts, sol) -> tuple[float, TensorSides]:
        """Add the element and facet terms of ``body``'s fields to its ``eta2`` (m,) and ``parts``; (its squared
        energy norm, what the contact terms read of it)."""
        W = self._nodal(u, phi)
        energy = self._element_terms(body, W, eta2, parts)
        self._facet_terms(body, W, eta2, parts, sol)
        return energy, TensorSides(self, u, phi, W)

    def _element_terms(self, body, W, eta2, parts) -> float:
        """h_T^2 ||f0 + div sigma_h||^2 / c_T and h_T^2 ||div D_h - q0||^2 / kappa_T; the squared energy norm."""
        m, dim = len(self.el), self.dim
        f0, q0 = body.body_force, body.volume_charge
        mech, elec, energy = np.zeros(m), np.zeros(m), 0.0
        for xi, w in zip(*gauss_cube(self.n, dim)):
            x, det, _, eps, gphi, sigma, D, div, divD = self._fields_of(
                self._evaluate(self._corners_T, W, self._basis(xi[None], True)))
            wd = w * det
            r = div + np.asarray(f0(*x.T), dtype=float).reshape(m, dim) if f0.nonzero else div
            mech += wd * (r ** 2).sum(axis=1)
            density = (eps * sigma).sum(axis=1)
            if D is not None:
                re = divD - np.asarray(q0(*x.T), dtype=float).reshape(m) if q0.nonzero else divD
                elec += wd * re ** 2
                density = density - (gphi * D).sum(axis=1)
            energy += float(wd @ density)
        term = self.hT ** 2 * mech / self.cT
        eta2 += term
        parts["element"] += float(term.sum())
        if self.kT is not None:
            term = self.hT ** 2 * elec / self.kT
            eta2 += term
            parts["electric element"] += float(term.sum())
        return energy

    def _facet_terms(self, body, W, eta2, parts, sol):
        """h_F ||R_F||^2 / c_T and h_F ||r_F||^2 / kappa_T on every facet (module docstring of :mod:`.estimate`:
        an interior facet's jump shared by its two cells; the boundary facets by their part's role; contact
        parts are left to the contact terms)."""
        owners, pos0, pos1, vertices, _ = self.facets
        dim = self.dim
        c0 = owners[:, 0]
        ii = np.flatnonzero(owners[:, 1] >= 0)
        c1 = owners[ii, 1]
        f = len(c0)
        roles_m, roles_e = contact.boundary_roles(body, sol)
        zero_m, zero_e, roller = np.zeros(f, bool), np.zeros(f, bool), np.zeros(f, bool)
        keep = np.ones((f, dim))
        for tag, role in roles_m.items():
            at = self.part(tag)
            if role in ("dirichlet", "contact"):
                zero_m[at] = True
            elif role == "roller":
                roller[at] = True
            elif role == "partial":
                comps = [i for i, val in enumerate(body.displacement[tag]) if val is not None]
                keep[np.ix_(at, comps)] = 0.0
        for tag, role in roles_e.items():
            if role == "dirichlet":
                zero_e[self.part(tag)] = True
        keep[zero_m] = 0.0
        mech, elec = np.zeros(f), np.zeros(f)
        for (wq, x, nvec, _, _, sigma, D), (_, _, _, _, _, sigma1, D1) in zip(
                self._facet_points(c0, pos0, W), self._facet_points(c1, pos1[ii], W)):
            length = np.sqrt((nvec ** 2).sum(axis=1))
            da = wq * length
            n = nvec / length[:, None]
            R = contact.voigt_traction(sigma[:, None], n)[:, 0]
            R[ii] -= contact.voigt_traction(sigma1[:, None], n[ii])[:, 0]
            for tag, load in body.traction.items():
                at = self.part(tag)
                R[at] -= np.asarray(load(*x[at].T), dtype=float).reshape(len(at), dim)
            R[roller] -= (R[roller] * n[roller]).sum(axis=1)[:, None] * n[roller]
            mech += da * ((R * keep) ** 2).sum(axis=1)
            if D is not None:
                r = (D * n).sum(axis=1)
                r[ii] -= (D1 * n[ii]).sum(axis=1)
                for tag, load in body.surface_charge.items():
                    at = self.part(tag)
                    r[at] -= np.asarray(load(*x[at].T), dtype=float).reshape(len(at))
                elec += da * np.where(zero_e, 0.0, r) ** 2
        inner = np.zeros(f)
        inner[ii] = 1.0
        scale = np.where(inner > 0, 0.5, 1.0) * contact.simplex_diameters(self._mesh.points, vertices)
        term = scale * mech / self.cT
        jump = float(term @ inner)
        parts["jump"] += 2 * jump
        parts["boundary"] += float(term.sum()) - jump
        if self.kT is not None:
            term_e = scale * elec / self.kT
            jump = float(term_e @ inner)
            parts["electric jump"] += 2 * jump
            parts["electric boundary"] += float(term_e.sum()) - jump
            term = term + term_e
        eta2 += np.bincount(c0, term, len(eta2)) + np.bincount(c1, term[ii], len(eta2))


def _point_basis(element, xi, second: bool) -> tuple:
    """:meth:`TensorGeometry._basis` of ``element`` at the points ``xi`` (p, d)."""
    lin, d = element.linear, np.shape(xi)[1]
    N1, dN1 = lin.shape_derivatives(xi)
    dN = element.shape_derivatives(xi)[1]
    out = (N1[:, :, None], dN1.transpose(0, 2, 1), dN.transpose(0, 2, 1))
    if not second:
        return out + (None,)
    a, b = np.triu_indices(d)                                   # the pairs a <= b of d^2 / dxi_a dxi_b
    d2 = [f.second_derivatives(xi)[:, a, b].transpose(0, 2, 1) for f in (lin, element)]    # (n, nodes, pairs)
    live = np.flatnonzero(np.any(d2[0] != 0, axis=(0, 1)) | np.any(d2[1] != 0, axis=(0, 1)))
    return out + ((tuple(np.ascontiguousarray(v[:, :, live]) for v in d2), (a[live], b[live])),)


@lru_cache(maxsize=4096)
def _shared_basis(element, xi: tuple, second: bool) -> tuple:
    """:func:`_point_basis` at the one point ``xi`` (d floats): the points of the cell and facet rules are a
    few (per element, the rule's points on each face in each of its orientations), each computed once; the
    arrays read-only (shared between calls)."""
    out = _point_basis(element, np.array([xi]), second)
    for a in (*out[:3], *(out[3][0] if second else ())):
        a.setflags(write=False)
    return out


def _times(T, B) -> np.ndarray:
    """(k, r, s): the rows of ``T`` (k, r, n) times the basis values ``B`` (p, n, s), p = k (point by point) or
    p = 1 (one point for all: a single matrix product)."""
    if len(B) == 1:
        k, r, n = T.shape
        return (T.reshape(k * r, n) @ B[0]).reshape(k, r, -1)
    return T @ B


def _keys(faces, n) -> np.ndarray:
    """One int64 key per facet (k, v) of a mesh of ``n`` nodes: :func:`facet_keys` of its three lowest vertices
    (two on an edge), which no other facet of a conforming mesh of convex cells shares."""
    f = np.sort(faces, axis=1)
    return facet_keys(f[:, :min(f.shape[1], 3)], n)


class TensorSides:
    """What the contact terms read of one body of quadrilaterals or hexahedra (the counterpart of
    :class:`~cvxcontact.solution.contactestimate.SimplexSides`): :meth:`side` one boundary part."""

    def __init__(self, geometry: TensorGeometry, u, phi, W=None):
        self._g, self._W = geometry, geometry._nodal(u, phi) if W is None else W

    def side(self, part) -> TensorSide:
        """The :class:`TensorSide` of boundary part ``part``."""
        return TensorSide(self._g, self._W, part)

    def multiplier(self, c, part) -> np.ndarray:
        """lambda_h (Pa) at the nodes of X_h of the 3D contact result ``c``: the read-back's ``c.lam``, on
        hexahedral faces the pressure the constrained side feels (:class:`~cvxcontact.fem.hexfaces.LumpedPressure`:
        each node's force over the integral of its hat on the faces, bilinear Q1 or biquadratic Q2, interpolated
        by the faces at the nodes of X_h; exact for a uniform pressure). ``part`` is not read (the protocol of
        :class:`~cvxcontact.solution.contactestimate.SimplexSides`)."""
        return np.asarray(c.lam, dtype=float)

    def friction(self, fr, c, part):
        """The :class:`~cvxcontact.solution.slipestimate.Friction` ``fr`` of the 3D contact result ``c`` with
        t_h read as lambda_h is (:meth:`multiplier`) where the nodes of X_h are nodes of this body's faces: the
        rows' tangential forces over the hats' integrals (exact for a uniform traction; the read-back keeps no
        such representer of the tangential forces); ``fr`` itself where they are not."""
        lumped = self._lumped(c, part, c.shear_force)
        return fr if lumped is None else replace(fr, t=lumped)

    def _lumped(self, c, part, forces):
        """``forces`` (n, ...) at the nodes of X_h over the integrals of the nodes' hats on this body's faces of
        part ``part``; None if a node of X_h is not a node of the faces."""
        g = self._g
        nodes = g.space.node_set(g._mesh)
        faces = np.asarray(nodes.boundary(part))
        points = np.asarray(nodes.points, dtype=float)
        hats = face_hats(points, faces, g.space.degree)
        on = np.unique(faces)
        distance, at = cKDTree(points[on]).query(np.asarray(c.points, dtype=float))
        if len(on) == 0 or distance.max(initial=0.0) > 1e-9 * g._mesh.size:
            return None
        forces = np.asarray(forces, dtype=float)
        return forces / hats[on[at]].reshape((-1,) + (1,) * (forces.ndim - 1))


class TensorSide:
    """One boundary part of a body of quadrilaterals or hexahedra as the contact terms read it: its faces ``f``
    (k, v) (``mesh.boundary(part)``), the cell ``cell`` (k,) holding each, unit outward ``normals`` (k, d),
    diameters ``hF`` (k,) m; sigma_h n at points of the trace's elements (:meth:`traction`: the faces' edges in
    2D, the faces' two triangles in 3D, ``triangulation.boundary(part)``), the face of each element
    (:meth:`face_of`) and int_F |sigma_h n|^2 (:meth:`squares`)."""

    def __init__(self, geometry: TensorGeometry, W, part):
        self._g, self._W = geometry, W
        mesh = geometry._mesh
        self.f = np.asarray(mesh.boundary(part))
        self.cell = geometry.facets[0][geometry.part(part), 0]
        self.normals = mesh.outward_normals(part)
        self.hF = contact.simplex_diameters(mesh.points, self.f)
        self._pos = contact.facet_positions(np.asarray(mesh.cells)[self.cell], self.f)    # (k, v) in each cell
        # the trace's elements: the edges themselves (2D); the faces' triangles 2 j, 2 j + 1 of face j (3D)
        self._elements = np.asarray(getattr(mesh, "triangulation", mesh).boundary(part))
        self._per = len(self._elements) // max(len(self.f), 1)

    def face_of(self, element):
        """The faces (indices into ``f``) of the trace's elements ``element``."""
        return np.arange(len(self._elements))[element] // self._per

    def traction(self, element, L) -> np.ndarray:
        """(k, d) sigma_h n (Pa) at the points of barycentric coordinates ``L`` (v,) or (k, v) on the trace's
        elements ``element`` (indices or a slice): each point located in its face's cell."""
        g = self._g
        face = self.face_of(element)
        tri = self._elements[element]
        L = np.broadcast_to(np.asarray(L, dtype=float), tri.shape)
        cell = self.cell[face]
        x = np.einsum("kv,kvd->kd", L, g._mesh.points[tri])
        start = np.einsum("kv,kvd->kd", L, g.element.corners[contact.facet_positions(np.asarray(g._mesh.cells)[cell], tri)])
        xi = g.element.locate(g.corners[cell], x, start)
        sigma = g._fields_of(g._evaluate(g._corners_T[cell], self._W[cell], g._basis(xi, False)))[5]
        return np.einsum("kij,kj->ki", contact.voigt_tensor(sigma), self.normals[face])

    def squares(self) -> np.ndarray:
        """(k,) int_F |sigma_h n|^2 (Pa^2 m^2) of each face F, by the facet rule of the geometry."""
        g = self._g
        acc = np.zeros(len(self.f))
        for wq, _, nvec, _, _, sigma, _ in g._facet_points(self.cell, self._pos, self._W):
            da = wq * np.sqrt((nvec ** 2).sum(axis=1))
            acc += da * (contact.voigt_traction(sigma[:, None], self.normals)[:, 0] ** 2).sum(axis=1)
        return acc
