"""The residual estimate (:mod:`.estimate`, docs/accuracy.md) on quadrilaterals and hexahedra, Q1 and Q2.

The same terms as on simplices, per cell T of every body,

    eta_T^2 = 1/c_T [ h_T^2 ||f0 + div sigma_h||_T^2 + sum_F h_F ||R_F||_F^2 ]
            + 1/kappa_T [ h_T^2 ||div D_h - q0||_T^2 + sum_F h_F ||r_F||_F^2 ] + contact terms,

with fields that are not affine on a cell: sigma_h, D_h are evaluated at Gauss points of the cell's multilinear
map (:class:`~cvxcontact.fem.quad.TensorElement`), and their divergence from the physical second derivatives
of the shape functions (:meth:`~cvxcontact.fem.quad.TensorElement.at_points`: a Q1 field's sigma_h varies on a
cell, so div sigma_h is not 0 in general). Rules: (degree + 2)^d Gauss points on each cell and
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
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from ..fem.assembly import voigt_strains
from ..fem.hex import face_hats
from ..fem.quad import gauss_cube
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
        self.cT = contact._smallest(c, True)
        self.kT = contact._smallest(kappa, False) if kappa is not None else None
        self.el = np.asarray(sp.node_set(mesh).cells)
        self.corners = mesh.points[mesh.cells]                                  # (m, 2^d, d)
        self.n = degree + 2                                                     # Gauss points per axis
        self._parts: dict = {}

    @cached_property
    def hT(self) -> np.ndarray:
        """(m,) m: the diameter of each cell (its longest corner-to-corner distance)."""
        return contact._diameters(self._mesh.points, self._mesh.cells)

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
        pos1[ii] = contact._facet_positions(cells[owners[ii, 1]], vertices[ii])
        return owners, faces[first % nf], pos1, vertices, keys

    def part(self, tag) -> np.ndarray:
        """The indices in the facet table of the facets of boundary part ``tag``."""
        if tag not in self._parts:
            mesh = self._mesh
            self._parts[tag] = np.searchsorted(self.facets[4], _keys(np.asarray(mesh.boundary(tag)), len(mesh.points)))
        return self._parts[tag]

    def fields(self, cells, xi, u, phi, second: bool = False):
        """The fields at one reference point ``xi`` (k, d) of each of the cells ``cells`` (k,): (x (k, d) m,
        det J (k,), J^-T (k, d, d), eps (k, s), grad phi (k, d) or None, sigma (k, s) Pa, D (k, d) C/m^2 or None,
        div sigma (k, d) Pa/m and div D (k,) C/m^3 (or None) with ``second``, else None)."""
        c, e, kappa = self.tensors
        x, G, det, inv_T, H = self.element.at_points(self.corners[cells], xi, second)
        k = len(x)
        ue = np.asarray(u, dtype=float)[self.el[cells]].reshape(k, self.el.shape[1] * self.dim)
        eps = voigt_strains(G, ue)
        sigma = eps @ c.T
        gphi = D = div = divD = pe = None
        if e is not None:
            pe = np.asarray(phi, dtype=float)[self.el[cells]]
            gphi = np.einsum("mdk,mk->md", G, pe)
            sigma = sigma + gphi @ e
            D = eps @ e.T - gphi @ kappa.T
        if second:
            div = np.zeros((k, self.dim))
            divD = None if e is None else np.zeros(k)
            for j in range(self.dim):                      # d/dx_j of the fields: the gradients of dN/dx_j
                Hj = H[:, :, j, :]
                deps = voigt_strains(Hj, ue)
                dsig = deps @ c.T
                if e is not None:
                    dg = np.einsum("mdk,mk->md", Hj, pe)
                    dsig = dsig + dg @ e
                    divD += (deps @ e.T - dg @ kappa.T)[:, j]
                div += contact._tensor(dsig)[:, :, j]
        return x, det, inv_T, eps, gphi, sigma, D, div, divD

    def terms(self, body, u, phi, eta2, parts, sol) -> tuple[float, TensorSides]:
        """Add the element and facet terms of ``body``'s fields to its ``eta2`` (m,) and ``parts``; (its squared
        energy norm, what the contact terms read of it)."""
        energy = self._element_terms(body, u, phi, eta2, parts)
        self._facet_terms(body, u, phi, eta2, parts, sol)
        return energy, TensorSides(self, u, phi)

    def _element_terms(self, body, u, phi, eta2, parts) -> float:
        """h_T^2 ||f0 + div sigma_h||^2 / c_T and h_T^2 ||div D_h - q0||^2 / kappa_T; the squared energy norm."""
        m, dim = len(self.el), self.dim
        cells = np.arange(m)
        f0, q0 = body.body_force, body.volume_charge
        mech, elec, energy = np.zeros(m), np.zeros(m), 0.0
        for xi, w in zip(*gauss_cube(self.n, dim)):
            x, det, _, eps, gphi, sigma, D, div, divD = self.fields(cells, np.broadcast_to(xi, (m, dim)), u, phi, True)
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

    def _facet_terms(self, body, u, phi, eta2, parts, sol):
        """h_F ||R_F||^2 / c_T and h_F ||r_F||^2 / kappa_T on every facet (module docstring of :mod:`.estimate`:
        an interior facet's jump shared by its two cells; the boundary facets by their part's role; contact
        parts are left to the contact terms)."""
        owners, pos0, pos1, vertices, _ = self.facets
        dim, corners = self.dim, self.element.corners
        c0 = owners[:, 0]
        ii = np.flatnonzero(owners[:, 1] >= 0)
        c1 = owners[ii, 1]
        W, wf = self.element.face_rule(self.n)
        xi0 = np.einsum("qv,fvd->fqd", W, corners[pos0])
        xi1 = np.einsum("qv,fvd->fqd", W, corners[pos1[ii]])
        normal_ref = corners[pos0].mean(axis=1)                    # the reference face's unit outward normal
        f = len(c0)
        roles_m, roles_e = contact._boundary_roles(body, sol)
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
        for q in range(len(wf)):
            x, det, inv_T, _, _, sigma, D, _, _ = self.fields(c0, xi0[:, q], u, phi)
            nvec = det[:, None] * np.einsum("fij,fj->fi", inv_T, normal_ref)
            da = wf[q] * np.linalg.norm(nvec, axis=1)
            n = nvec / np.linalg.norm(nvec, axis=1)[:, None]
            _, _, _, _, _, sigma1, D1, _, _ = self.fields(c1, xi1[:, q], u, phi)
            R = np.einsum("fij,fj->fi", contact._tensor(sigma), n)
            R[ii] -= np.einsum("fij,fj->fi", contact._tensor(sigma1), n[ii])
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
        scale = np.where(inner > 0, 0.5, 1.0) * contact._diameters(self._mesh.points, vertices)
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


def _keys(faces, n) -> np.ndarray:
    """One int64 key per facet (k, v) of a mesh of ``n`` nodes: :func:`facet_keys` of its three lowest vertices
    (two on an edge), which no other facet of a conforming mesh of convex cells shares."""
    f = np.sort(faces, axis=1)
    return facet_keys(f[:, :min(f.shape[1], 3)], n)


class TensorSides:
    """What the contact terms read of one body of quadrilaterals or hexahedra (the counterpart of
    :class:`~cvxcontact.solution.contactestimate.SimplexSides`): :meth:`side` one boundary part."""

    def __init__(self, geometry: TensorGeometry, u, phi):
        self._g, self._u, self._phi = geometry, u, phi

    def side(self, part) -> TensorSide:
        """The :class:`TensorSide` of boundary part ``part``."""
        return TensorSide(self._g, self._u, self._phi, part)

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

    def __init__(self, geometry: TensorGeometry, u, phi, part):
        self._g, self._u, self._phi = geometry, u, phi
        mesh = geometry._mesh
        self.f = np.asarray(mesh.boundary(part))
        self.cell = geometry.facets[0][geometry.part(part), 0]
        self.normals = mesh.outward_normals(part)
        self.hF = contact._diameters(mesh.points, self.f)
        self._pos = contact._facet_positions(np.asarray(mesh.cells)[self.cell], self.f)    # (k, v) in each cell
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
        start = np.einsum("kv,kvd->kd", L, g.element.corners[contact._facet_positions(np.asarray(g._mesh.cells)[cell], tri)])
        xi = g.element.locate(g.corners[cell], x, start)
        sigma = g.fields(cell, xi, self._u, self._phi)[5]
        return np.einsum("kij,kj->ki", contact._tensor(sigma), self.normals[face])

    def squares(self) -> np.ndarray:
        """(k,) int_F |sigma_h n|^2 (Pa^2 m^2) of each face F, by the facet rule of the geometry."""
        g = self._g
        W, wf = g.element.face_rule(g.n)
        ref = g.element.corners[self._pos]                                    # (k, v, d)
        xi = np.einsum("qv,kvd->kqd", W, ref)
        normal_ref = ref.mean(axis=1)
        acc = np.zeros(len(self.f))
        for q in range(len(wf)):
            _, det, inv_T, _, _, sigma, _, _, _ = g.fields(self.cell, xi[:, q], self._u, self._phi)
            da = wf[q] * np.linalg.norm(det[:, None] * np.einsum("fij,fj->fi", inv_T, normal_ref), axis=1)
            acc += da * (np.einsum("kij,kj->ki", contact._tensor(sigma), self.normals) ** 2).sum(axis=1)
        return acc
