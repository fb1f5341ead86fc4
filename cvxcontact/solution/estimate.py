"""A posteriori error estimate of a solution: a residual estimator with contact terms (docs/accuracy.md).

The error is measured in the energy norm of the coupled problem (docs/formulation.md §2; the skew
coupling drops out of A((u, phi), (u, phi))):

    |||(v, psi)|||^2 = sum over bodies int_Omega  c eps(v) : eps(v) + kappa grad psi . grad psi

(J/m per unit thickness in 2D, J in 3D). The estimator (Hild & Nicaise 2005 for Signorini contact, with the
electric counterparts) sums, per cell T (triangle or tetrahedron) of every body,

    eta_T^2 = 1/c_T [ h_T^2 ||f0 + div sigma_h||_T^2 + sum_F h_F ||R_F||_F^2 ]
            + 1/kappa_T [ h_T^2 ||div D_h - q0||_T^2 + sum_F h_F ||r_F||_F^2 ]
            + contact terms of the contact cells next to T,

F the facets of T (edges in 2D, faces in 3D): an interior facet counts half of R_F = [sigma_h n]
(r_F = [D_h . n]); a traction facet R_F = sigma_h n - f2, a free one sigma_h n (a roller's: its tangential
part; a part with prescribed components: the free ones), a charged facet r_F = D_h . n - q2 (D . nu = q2,
eq. (11)), a free one D_h . n; clamped facets and electrodes none. On the contact part of each side,
R_F = sigma_h n + lambda_h n (eq. (8): sigma_nu = -lambda, sigma_tau = 0; lambda_h the solution's multiplier,
0 beyond its support). On each cell S of the contact mesh of a Signorini pair (2D: the merged segments; 3D:
the elements of X_h, the overlay triangles or the faces against an obstacle) the complementarity
int_S lambda_h^+ (g - [u_h nu])^+ and the penetration c_T / h_S ||([u_h nu] - g)^+||_S^2, shared by the
cells of both sides. c_T (Pa) is the smallest eigenvalue of the body's stiffness on tensor-orthonormal
strains (2 mu for an isotropic material), kappa_T (F/m) the smallest of its permittivity: with them every
term is an energy. h_T is the longest edge of T, h_F the longest edge of F, h_S that of S.

One dimension-blind core (:func:`vertex_fields`, the element and facet residuals on the simplices, with the
quadrature of :func:`cvxcontact.fem.simplex.simplex_rule`); the contact terms read lambda_h where it lives,
on the merged line (2D) or on the elements of X_h (3D, :meth:`elements` of the pair's surface).

The constants of reliability are unknown: the estimate is not a guaranteed bound (``guaranteed`` False);
its effectivity (estimate / true error) is measured against nested fine-mesh references
(:mod:`cvxcontact.apps.studies.estimate`, docs/accuracy.md).

Covered: 2D and 3D, P1 and P2, elastic and piezoelectric bodies, pairs and rigid obstacles, the three
Signorini conditions and normal compliance (then the traction mismatch only: the law allows the
penetration). A friction law (Tresca, Coulomb) subtracts its tangential traction t_h from R_F on the contact
parts and adds the friction cone and the slip complementarity on each S (:mod:`.slipestimate`). A curved part
against a planar one (3D) reads lambda_h on the curved side's faces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..contact.interface import row_frames, row_tangents
from ..contact.overlay import barycentric, locate
from ..fem.assembly import VOIGT, gradients, strain_matrix
from ..fem.p2 import shape_functions
from ..fem.simplex import simplex_rule
from ..fem.space import space
from ..geometry.facets import facet_keys
from ..geometry.facets import facets as facet_table
from ..physics.fingerprint import geometry_fingerprint
from . import slipestimate as slip

__all__ = ["ErrorEstimate", "Geometry", "cell_energies", "energy_density", "estimate", "vertex_fields"]

CELLS = 1 << 15
"""Cells per block of the strain matrices and edge vectors formed on the fly (bounds their temporaries)."""

_GAUSS3 = (0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5 / 18, 8 / 18, 5 / 18]))


@dataclass(frozen=True)
class ErrorEstimate:
    """The estimated discretisation error of a solution in the energy norm (module docstring).

    ``absolute``: eta = (sum_T eta_T^2)^(1/2), sqrt(J/m) in 2D (per unit thickness), sqrt(J) in 3D;
    ``norm``: the solution's own energy norm |||(u_h, phi_h)|||, same unit; ``relative`` = absolute / norm.
    ``indicators[k]`` (m_k,): eta_T of each cell of body k (``scene.bodies[k].mesh.cells``: triangles or
    tetrahedra). ``parts``: eta^2 split by term (J/m, J; a friction law adds "friction cone" and "slip
    complementarity"). ``guaranteed``: whether ``absolute`` is a proven upper
    bound of the true error (False: a residual estimator's constants are unknown; its effectivity is
    measured, docs/accuracy.md). ``kind``: "residual". ``unit``: "sqrt(J/m)" (2D) or "sqrt(J)" (3D).
    """

    absolute: float
    norm: float
    indicators: tuple
    parts: dict = field(default_factory=dict)
    guaranteed: bool = False
    kind: str = "residual"
    unit: str = "sqrt(J/m)"

    @property
    def relative(self) -> float:
        """absolute / norm (dimensionless); inf for a solution of zero energy with a non-zero estimate."""
        if self.norm > 0:
            return self.absolute / self.norm
        return 0.0 if self.absolute == 0 else float("inf")

    def __str__(self) -> str:
        return (f"{100 * self.relative:.3g} % ({self.kind}, {'guaranteed' if self.guaranteed else 'not guaranteed'}; "
                f"{self.absolute:.4g} of {self.norm:.4g} {self.unit} in the energy norm)")


# ---------------------------------------------------------------------------------------------- fields


def vertex_fields(body, u, phi, degree: int):
    """The fields of body ``body`` (a triangle or tetrahedron mesh of dimension d) at the d + 1 vertices of
    each cell, from whose barycentric interpolation they follow everywhere in it (constant for P1, affine for
    P2 on straight cells): strain eps (m, d + 1, s) Voigt (engineering shears; s = 3 in 2D, 6 in 3D), grad phi
    (m, d + 1, d) V/m or None, sigma (m, d + 1, s) Pa Voigt = c eps + e^T grad phi, D (m, d + 1, d) C/m^2 =
    e eps - kappa grad phi or None; and the barycentric gradients (m, d, d + 1), measures (m,) (areas or
    volumes)."""
    eps, gphi, sigma, D, gradL, measure = _fields(Geometry(body, degree), u, phi)
    copies = gradL.shape[2] // eps.shape[1]                          # constant on a cell: the same at each vertex
    eps, gphi, sigma, D = (None if a is None else np.repeat(a, copies, axis=1) for a in (eps, gphi, sigma, D))
    return eps, gphi, sigma, D, gradL, measure


def _fields(g, u, phi):
    """:func:`vertex_fields` from the body's :class:`Geometry` ``g``, each field at its q distinct corner values:
    (m, q, ...) with q = d + 1, or q = 1 where the fields are constant on a cell (then every vertex has it)."""
    c, e, kappa = g.tensors
    u = np.asarray(u, dtype=float)
    m = len(g.el)
    ue = u[g.el].reshape(m, -1)
    eps = _strains(g.G, ue)
    sigma = eps @ c.T
    gphi = D = None
    if e is not None:
        pe = np.asarray(phi, dtype=float)[g.el]
        gphi = np.einsum("mvdj,mj->mvd", g.G, pe)
        sigma = sigma + gphi @ e
        D = eps @ e.T - gphi @ kappa.T
    return eps, gphi, sigma, D, g.gradL, g.measure


def _strains(G, ue) -> np.ndarray:
    """(m, q, s) Voigt strains B(G[:, i]) ue at the q corner values, G (m, q, d, k) the shape gradients, ue (m, d k)
    the element displacements; B (:func:`strain_matrix`, 576 bytes per P1 tetrahedron) by blocks of CELLS cells."""
    m, q, dim, _ = G.shape
    eps = np.empty((m, q, len(VOIGT[dim])))
    for s in range(0, m, CELLS):
        for i in range(q):
            eps[s:s + CELLS, i] = np.einsum("mij,mj->mi", strain_matrix(G[s:s + CELLS, i]), ue[s:s + CELLS])
    return eps


def _onto(L, q):
    """Barycentric weights ``L`` (..., d + 1) summed onto q distinct corner values (q = d + 1: ``L`` itself; q = 1:
    their sum, 1, for a field constant on the cell)."""
    L = np.asarray(L, dtype=float)
    return L.reshape(L.shape[:-1] + (q, -1)).sum(axis=-1)


def energy_density(body, eps, gphi):
    """c eps : eps + kappa grad phi . grad phi (J/m^3) of Voigt strains ``eps`` (..., s) and ``gphi`` (..., d)."""
    c, _, kappa = body.material.tensors(3 if eps.shape[-1] == 6 else 2)
    w = ((eps @ c) * eps).sum(axis=-1)
    if gphi is not None:
        w = w + ((gphi @ kappa) * gphi).sum(axis=-1)
    return w


def _cell_energies(body, fields) -> np.ndarray:
    """int_T of the energy density of affine fields with vertex values eps, gphi: the mass matrix of P1 on a
    d-simplex, |T| (delta_ij + 1) / ((d + 1)(d + 2)), applied to the quadratic form (exact). The density is read
    as eps . sigma - grad phi . D (= c eps : eps + kappa grad phi . grad phi: the coupling e cancels), bilinear in
    the vertex values. The fields may hold q = 1 value per cell (constant: each of the k = d + 1 vertices has it,
    r = k / q copies)."""
    eps, gphi, sigma, D, gradL, measure = fields
    k, q = gradL.shape[2], eps.shape[1]
    r = k // q

    def density(a, b, c=None, d=None):                    # a . b - c . d over the last axis
        w = (a * b).sum(axis=-1)
        return w if c is None else w - (c * d).sum(axis=-1)

    sums = [None if x is None else x.sum(axis=1) for x in (eps, sigma, gphi, D)]
    total = r * density(eps, sigma, gphi, D).sum(axis=1) + r * r * density(*sums)
    return total * measure / (k * (k + 1))


def cell_energies(body, u, phi, degree: int) -> np.ndarray:
    """(m,) int_T c eps(u) : eps(u) + kappa grad phi . grad phi of each cell (J/m in 2D, J in 3D): the squared
    energy norm of (u, phi) cell by cell (exact: the integrand is at most quadratic, the rule of degree 2)."""
    return _cell_energies(body, vertex_fields(body, u, phi, degree))


class Geometry:
    """What the estimate of one body reads from its mesh and material alone, in one element degree: the
    material tensors and their smallest eigenvalues c_T (Pa), kappa_T (F/m); the cells' measures (m^2 or m^3),
    barycentric gradients (1/m), element nodes and shape gradients at the corners; the facet table with each
    facet's cells, outward normal, measure and diameter h_F (m), and where its vertices sit among the
    distinct corner values of its cells (:func:`_fields`); h_T (m); and, built when first asked, the
    facets of each boundary part. A load case of the same geometry reuses it: :func:`estimate` keeps it in a
    ``cache`` under the body's :func:`~cvxcontact.physics.fingerprint.geometry_fingerprint` and the degree (the
    loads are not in the key: they are read from the body on every call)."""

    def __init__(self, body, degree: int):
        mesh = self._mesh = body.mesh
        self.dim = mesh.points.shape[1]
        self.tensors = c, _, kappa = body.material.tensors(self.dim)
        self.cT = _smallest(c, True)
        self.kT = _smallest(kappa, False) if kappa is not None else None
        self.measure, self.gradL = gradients(mesh.points, mesh.cells)
        # G (m, q, d, k): q = d + 1, or 1 (P1: a view of gradL, one copy of the gradients)
        self.el, self.G = space(degree, mesh.cell).corner_gradients(body, self.gradL)
        self._parts: dict = {}

    @cached_property
    def facets(self):
        """The facet table (:func:`~cvxcontact.geometry.facets.facets`: owners, local indices, vertices, keys)."""
        return facet_table(self._mesh.cells, len(self._mesh.points))

    @cached_property
    def hT(self) -> np.ndarray:
        """(m,) m: the longest edge of each cell."""
        return _diameters(self._mesh.points, self._mesh.cells)

    @cached_property
    def faces(self) -> _Faces:
        """Each facet's cells, outward normal, measure and diameter, and where its vertices sit among the
        distinct corner values of its cells (:class:`_Faces`)."""
        mesh, dim = self._mesh, self.dim
        owners, local, vertices, _ = self.facets
        c0 = owners[:, 0]
        grad = self.gradL[c0, :, local[:, 0]]                 # grad of the opposite vertex's coordinate: inward
        size = np.linalg.norm(grad, axis=1)
        inner = owners[:, 1] >= 0
        ii = np.flatnonzero(inner)
        c1 = owners[ii, 1]
        q = self.G.shape[1]                                   # the fields' distinct values per cell (_fields)
        area = dim * self.measure[c0] * size                  # |F| = d |T| |grad L_i|
        hF = _diameters(mesh.points, vertices)
        return _Faces(c0=c0, c1=c1, inner=inner.astype(float), ii=ii, normal=-grad / size[:, None], area=area,
                      hF=hF, pos0=(_facet_positions(mesh.cells[c0], vertices) % q)[:, :min(q, dim)],
                      pos1=(_facet_positions(mesh.cells[c1], vertices[ii]) % q)[:, :min(q, dim)],
                      scale=np.where(inner, 0.5, 1.0) * hF * area)

    def part(self, tag) -> np.ndarray:
        """The indices in the facet table of the facets of boundary part ``tag``."""
        if tag not in self._parts:
            mesh, key = self._mesh, self.facets[3]
            self._parts[tag] = np.searchsorted(key, facet_keys(np.sort(mesh.boundary(tag), axis=1), len(mesh.points)))
        return self._parts[tag]

    def points(self, L) -> np.ndarray:
        """(m, d) m: the points of barycentric coordinates ``L`` (d + 1,) in each cell (formed anew, not kept)."""
        return _at(self._mesh.points, self._mesh.cells, L)


@dataclass(frozen=True)
class _Faces:
    """The facets of a :class:`Geometry`: ``c0`` (f,) the first cell of each (its normal points out of it),
    ``c1`` the second cell of the interior ones ``ii`` (``inner`` (f,) 1.0 for those, else 0.0), ``normal``
    (f, d) unit, ``area`` (f,) m (2D) or m^2, ``hF`` (f,) m its longest edge, ``pos0`` / ``pos1`` (f, v) the
    index among its first / second cell's distinct corner values of each of its vertices (v = d, or 1 for
    fields constant on a cell), ``scale`` (f,) the weight h_F |F| of its residual, halved on an interior
    facet (shared by its two cells)."""

    c0: np.ndarray
    c1: np.ndarray
    inner: np.ndarray
    ii: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    hF: np.ndarray
    pos0: np.ndarray
    pos1: np.ndarray
    scale: np.ndarray


def _geometry(body, degree: int, cache) -> Geometry:
    """The :class:`Geometry` of ``body`` in ``degree``: from ``cache`` (a dict, or None: built afresh) under the
    body's geometry fingerprint and the degree, else built (and kept there)."""
    if cache is None:
        return Geometry(body, degree)
    key = (geometry_fingerprint(body), degree)
    if key not in cache:
        cache[key] = Geometry(body, degree)
    return cache[key]


def _smallest(matrix, voigt: bool) -> float:
    """The smallest eigenvalue of a stiffness (Voigt, engineering shear: on tensor-orthonormal strains) or
    permittivity matrix."""
    a = np.asarray(matrix, dtype=float)
    if voigt:
        dim = 3 if len(a) == 6 else 2
        s = np.array([1.0] * dim + [np.sqrt(2.0)] * (len(a) - dim))
        a = s[:, None] * a * s[None, :]
    return float(np.linalg.eigvalsh(0.5 * (a + a.T)).min())


def _voigt_traction(sv, n) -> np.ndarray:
    """(k, v, d): sigma n of Voigt vectors ``sv`` (k, v, s) on the unit normals ``n`` (k, d), component by
    component (t_i += sigma_ij n_j over the Voigt pairs), without forming the tensors."""
    dim = n.shape[1]
    t = np.zeros(sv.shape[:2] + (dim,))
    for row, (i, j) in enumerate(VOIGT[dim]):
        t[..., i] += sv[..., row] * n[:, None, j]
        if i != j:
            t[..., j] += sv[..., row] * n[:, None, i]
    return t


def _tensor(sv):
    """(..., d, d) symmetric tensors from Voigt vectors (..., s) (xx, yy, xy in 2D; xx, yy, zz, yz, xz, xy in 3D)."""
    dim = 3 if sv.shape[-1] == 6 else 2
    out = np.empty(sv.shape[:-1] + (dim, dim))
    for row, (i, j) in enumerate(VOIGT[dim]):
        out[..., i, j] = out[..., j, i] = sv[..., row]
    return out


# ---------------------------------------------------------------------------------------------- the estimator


def estimate(sol, signorini: bool = True, cache: dict | None = None) -> tuple[ErrorEstimate | None, str]:
    """(the :class:`ErrorEstimate` of ``sol``, "") (module docstring); the tuple's second entry says why the
    estimate is None for a case not covered (none at present). ``signorini=False`` leaves out the
    complementarity and penetration terms (a problem whose contact rows are equalities: the dual problem of
    :mod:`cvxcontact.goal`). ``cache``: a dict that keeps each body's :class:`Geometry` between calls (a
    ContactSolver's, for its load cases; None: built afresh); the answer is the same with or without it."""
    scene = sol.scene
    bodies = scene.bodies
    eta2 = [np.zeros(len(b.mesh.cells)) for b in bodies]
    parts = dict.fromkeys(("element", "jump", "boundary", "contact traction", "electric element", "electric jump",
                           "electric boundary", "complementarity", "penetration"), 0.0)
    norm2 = 0.0
    data, held = [], []
    for k, b in enumerate(bodies):
        g = _geometry(b, sol.degree, cache)
        fields = _fields(g, sol.u[k], sol.phi[k])
        sigma = fields[2]
        corners = np.broadcast_to(sigma, (len(sigma), g.gradL.shape[2], sigma.shape[2]))   # a view: no copies
        held.append(((None, None, corners, None, g.gradL, g.measure), g.facets))
        norm2 += float(_cell_energies(b, fields).sum())
        data.append((g.cT, g.kT))
        _element_terms(b, fields, g, eta2[k], parts)
        _facet_terms(b, fields, g, eta2[k], parts, sol)
    (_contact_terms if scene.dim == 2 else _surface_contact_terms)(sol, data, held, eta2, parts, signorini)
    indicators = tuple(_read_only(np.sqrt(np.maximum(e, 0.0))) for e in eta2)
    total = float(sum(e.sum() for e in eta2))
    return ErrorEstimate(absolute=float(np.sqrt(max(total, 0.0))), norm=float(np.sqrt(max(norm2, 0.0))),
                         indicators=indicators, parts=parts,
                         unit="sqrt(J)" if scene.dim == 3 else "sqrt(J/m)"), ""


def _read_only(a):
    a = np.asarray(a, dtype=float)
    a.setflags(write=False)
    return a


def _diameters(points, simplices) -> np.ndarray:
    """(m,) the longest edge of each simplex (m, k) of ``points`` (by blocks of CELLS simplices)."""
    i, j = np.triu_indices(simplices.shape[1], 1)
    out = np.empty(len(simplices))
    for s in range(0, len(simplices), CELLS):
        edge = points[simplices[s:s + CELLS, i]] - points[simplices[s:s + CELLS, j]]   # (block, edges, dim)
        out[s:s + CELLS] = np.sqrt(np.einsum("med,med->me", edge, edge).max(axis=1))
    return out


def _at(points, cells, L):
    """(m, d) the points of barycentric coordinates L (d + 1,) or (m, d + 1) in each cell."""
    return np.einsum("...k,mkd->md", L, points[cells])


def _element_terms(body, fields, geometry, eta2, parts):
    """h_T^2 ||f0 + div sigma_h||^2 / c_T and h_T^2 ||div D_h - q0||^2 / kappa_T (a rule of degree 2)."""
    _, _, sigma, D, gradL, measure = fields
    hT, cT, kT = geometry.hT, geometry.cT, geometry.kT
    dim = gradL.shape[1]
    # sigma is affine: d sigma / d x_j = sum_i sigma(vertex i) d L_i / d x_j;  (div sigma)_i = sum_j d sigma_ij / d x_j
    f0, q0 = body.body_force, body.volume_charge
    if sigma.shape[1] == 1:                                # fields constant on each cell: no divergence, exactly
        div, rd = np.zeros((len(sigma), dim)), (None if D is None else np.zeros(len(D)))
    else:
        dsig = _tensor(np.einsum("mvs,mjv->mjs", sigma, gradL))                  # (m, j, i, i')
        div = np.einsum("mjij->mi", dsig)
        rd = np.einsum("mvd,mdv->m", D, gradL) if D is not None else None       # div D (constant)
    mech = (div ** 2).sum(axis=1)                          # constant residuals without loads
    elec = None if D is None else rd ** 2
    if f0.nonzero or (D is not None and q0.nonzero):
        mech, elec = 0.0, (None if D is None else 0.0)
        for L, w in zip(*simplex_rule(dim, 2)):
            x = geometry.points(L)
            r = div + np.asarray(f0(*x.T), dtype=float).reshape(len(div), dim) if f0.nonzero else div
            mech = mech + w * (r ** 2).sum(axis=1)
            if D is not None:
                re = rd - np.asarray(q0(*x.T), dtype=float).reshape(len(rd)) if q0.nonzero else rd
                elec = elec + w * re ** 2
    term = hT ** 2 * mech * measure / cT
    eta2 += term
    parts["element"] += float(term.sum())
    if D is not None:
        term = hT ** 2 * elec * measure / kT
        eta2 += term
        parts["electric element"] += float(term.sum())


def _bary(cell_vertices, facet_vertices, Lf):
    """(k, d + 1) the barycentric coordinates in cells with vertices ``cell_vertices`` (k, d + 1) of the points of
    barycentric coordinates ``Lf`` (d,) or (k, d) on their facets with vertices ``facet_vertices`` (k, d)."""
    k = len(cell_vertices)
    pos = np.argmax(cell_vertices[:, :, None] == facet_vertices[:, None, :], axis=1)     # (k, d)
    L = np.zeros(cell_vertices.shape)
    np.put_along_axis(L, pos, np.broadcast_to(Lf, (k, pos.shape[1])), axis=1)
    return L


def _traction(sigma_v, L, n):
    """sigma n (k, d) at barycentric L (k, d + 1) of Voigt vertex values (k, d + 1, s), unit normals n (k, d)."""
    return np.einsum("kij,kj->ki", _tensor(np.einsum("kv,kvs->ks", L, sigma_v)), n)


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


def _affine_mean_square(values) -> np.ndarray:
    """(k,): the mean over each simplex of |f|^2 for the affine f of vertex values ``values`` (k, v, c) (v
    vertices): (sum_i |f_i|^2 + |sum_i f_i|^2) / (v (v + 1))."""
    v = values.shape[1]
    return ((values ** 2).sum(axis=(1, 2)) + (values.sum(axis=1) ** 2).sum(axis=1)) / (v * (v + 1))


def _facet_positions(cell_vertices, facet_vertices) -> np.ndarray:
    """(k, d): the local index in each cell (vertices ``cell_vertices`` (k, d + 1)) of each vertex of its facet
    ``facet_vertices`` (k, d)."""
    return np.argmax(cell_vertices[:, :, None] == facet_vertices[:, None, :], axis=1)


def _facet_values(values, cell_vertices, facet_vertices, pos=None):
    """(k, d, ...) the vertex values ``values`` (k, d + 1, ...) of cells with vertices ``cell_vertices``
    (k, d + 1) at the vertices ``facet_vertices`` (k, d) of one facet of each (``pos``: their
    :func:`_facet_positions`, if known)."""
    pos = _facet_positions(cell_vertices, facet_vertices) if pos is None else pos
    return values[np.arange(len(values))[:, None], pos]


def _facet_terms(body, fields, geometry, eta2, parts, sol):
    """The interior jumps and the boundary residuals of ``body`` (module docstring; ``facets`` its
    :func:`~cvxcontact.geometry.facets.facets`); contact parts are left to the contact terms.
    sigma_h and D_h are affine on each facet:
    their normal components are formed at its vertices and interpolated to the quadrature points."""
    sigma, D = fields[2], fields[3]
    g = geometry
    dim = g.dim
    vertices, key = g.facets[2], g.facets[3]
    p = body.mesh.points
    f = g.faces
    n, ii = f.normal, f.ii
    c0, c1 = f.c0[:, None], f.c1[:, None]
    Rv = _voigt_traction(sigma[c0, f.pos0], n)                                                     # (k, v, d)
    Rv[ii] -= _voigt_traction(sigma[c1, f.pos1], n[ii])
    if D is not None:
        rv = np.einsum("kvd,kd->kv", D[c0, f.pos0], n)                                             # (k, v)
        rv[ii] -= np.einsum("kvd,kd->kv", D[c1, f.pos1], n[ii])
    mech_role, elec_role = _boundary_roles(body, sol)
    code = {role: c for c, role in enumerate(("free", "dirichlet", "contact", "roller", "partial", "traction",
                                               "charge"))}      # each facet's role as a small integer
    role_m = np.zeros(len(key), dtype=np.int8)
    role_e = np.zeros(len(key), dtype=np.int8)
    load_m, load_e, index = {}, {}, {}
    for roles, out, loads, kind in ((mech_role, role_m, load_m, "traction"), (elec_role, role_e, load_e, "charge")):
        for tag, role in roles.items():
            if tag not in index:
                index[tag] = g.part(tag)
            out[index[tag]] = code[role]
            if role == kind:
                loads[tag] = index[tag]
    partial = {tag: [comp for comp, val in enumerate(v) if val is not None] for tag, v in body.displacement.items()
               if mech_role.get(tag) == "partial"}

    def keep(at):                                          # (len(at), d): the components of R that count there
        out = np.ones((len(at), dim))
        out[(role_m[at] == code["dirichlet"]) | (role_m[at] == code["contact"])] = 0.0
        for tag, comps in partial.items():
            out[np.ix_(np.isin(at, index[tag]), comps)] = 0.0
        return out

    roller = np.flatnonzero(role_m == code["roller"])
    # without a load R is affine on the facet: the mean of |R|^2 from its vertex values, exactly (the rule of
    # degree 3 below gives the same to rounding); the loaded facets by that rule (a load is any function).
    # Only the boundary facets have a role: R is zeroed where a component does not count, in place.
    Re = Rv.copy()
    Re[roller] -= (Re[roller] * n[roller, None, :]).sum(axis=2)[..., None] * n[roller, None, :]
    Re[(role_m == code["dirichlet"]) | (role_m == code["contact"])] = 0.0
    for tag, comps in partial.items():
        sub = Re[index[tag]]
        sub[..., comps] = 0.0
        Re[index[tag]] = sub
    mech = _affine_mean_square(Re)
    if D is not None:
        re = rv.copy()
        re[role_e == code["dirichlet"]] = 0.0
        elec = _affine_mean_square(re[..., None])
    loaded = np.unique(np.concatenate([np.zeros(0, dtype=int), *load_m.values(), *load_e.values()]))
    if len(loaded):
        mech[loaded] = 0.0
        if D is not None:
            elec[loaded] = 0.0
        at = np.full(len(key), -1)
        at[loaded] = np.arange(len(loaded))
        roller_l = at[roller][at[roller] >= 0]
        keep_l, keep_e = keep(loaded), (role_e[loaded] != code["dirichlet"]).astype(float)
        for Lf, w in zip(*simplex_rule(dim - 1, 3)):
            R = np.tensordot(_onto(Lf, Rv.shape[1]), Rv[loaded], axes=(0, 1))
            x = np.tensordot(Lf, p[vertices[loaded]], axes=(0, 1))
            for tag, idx in load_m.items():
                R[at[idx]] -= np.asarray(body.traction[tag](*x[at[idx]].T), dtype=float).reshape(len(idx), dim)
            R[roller_l] -= (R[roller_l] * n[loaded][roller_l]).sum(axis=1)[:, None] * n[loaded][roller_l]
            R *= keep_l
            mech[loaded] += w * (R ** 2).sum(axis=1)
            if D is not None:
                r = rv[loaded] @ _onto(Lf, rv.shape[1])
                for tag, idx in load_e.items():
                    r[at[idx]] -= np.asarray(body.surface_charge[tag](*x[at[idx]].T), dtype=float).reshape(len(idx))
                elec[loaded] += w * (r * keep_e) ** 2
    # h_F ||R||_F^2 = h_F |F| sum_q w_q R_q^2, an interior jump shared by its two cells (f.scale: the weight h_F |F|)
    term = f.scale * mech / g.cT
    jump = float(term @ f.inner)
    parts["jump"] += 2 * jump
    parts["boundary"] += float(term.sum()) - jump
    if D is not None:
        term_e = f.scale * elec / g.kT
        jump = float(term_e @ f.inner)
        parts["electric jump"] += 2 * jump
        parts["electric boundary"] += float(term_e.sum()) - jump
        term = term + term_e
    eta2 += np.bincount(f.c0, term, len(eta2)) + np.bincount(f.c1, term[ii], len(eta2))


def _contact_cells(mesh, part, facets):
    """(cells (k,), the facets' vertices (k, d) in the part's order) of the faces of boundary part ``part``:
    the cell that holds each."""
    owners, _, _, key = facets
    f = np.asarray(mesh.boundary(part))
    at = np.searchsorted(key, facet_keys(np.sort(f, axis=1), len(mesh.points)))
    return owners[at, 0], f


def _lambda_at(c, s, values=None):
    """lambda_h (Pa; or the function of nodal ``values``) of 2D contact result ``c`` at tangential coordinates
    ``s`` (m): its P1 (P2: piecewise quadratic) function on the merged mesh, 0 beyond it."""
    x = np.asarray(c.x, dtype=float)
    return np.where((s < x[0]) | (s > x[-1]), 0.0, _merged_values(c, s, c.lam if values is None else values))


def _merged_values(c, s, values):
    """A P1 (P2) function on the merged mesh of ``c`` (2D) with nodal ``values``, at ``s`` inside it."""
    return c.trace.values(np.asarray(c.x, dtype=float), values, s)


def _contact_terms(sol, data, cache, eta2, parts, signorini=True):
    """2D: on each side of each pair h_E ||sigma_h n + lambda_h n (- t_h t, a friction law's)||^2 / c_T; on each
    merged segment of a Signorini pair the complementarity and the penetration (and the friction terms), shared by
    the cells of the sides (module docstring)."""
    scene = sol.scene
    bodies = list(scene.bodies)
    for i, (pair, c) in enumerate(zip(scene.contacts, sol.contacts)):
        t = np.asarray(scene.interfaces[i].tangent, dtype=float)
        sides = [(pair.body_a, pair.part_a)] + ([] if pair.rigid else [(pair.other, pair.part_b)])
        located, fr = [], slip.friction_of(sol, i)                       # a friction law's t_h, else None
        if fr is not None:                                     # t_h along each row's tangent (turned: a curve)
            tv = fr.t[:, None] * np.broadcast_to(row_tangents(sol._pair_line(i), 0), (len(fr.t), 2))
        for side, (body, part) in enumerate(sides):
            k = next(j for j, b in enumerate(bodies) if b is body)
            mesh = body.mesh
            fields, facets = cache[k]
            cell, e = _contact_cells(mesh, part, facets)                # e oriented: domain on the left
            p = mesh.points
            n = mesh.outward_normals(part)
            h = np.linalg.norm(p[e[:, 1]] - p[e[:, 0]], axis=1)
            acc = np.zeros(len(e))
            for tq, w in zip(*_GAUSS3):
                x = (1 - tq) * p[e[:, 0]] + tq * p[e[:, 1]]
                L = _bary(mesh.cells[cell], e, np.array([1 - tq, tq]))
                R = _traction(fields[2][cell], L, n) + _lambda_at(c, x @ t)[:, None] * n
                if fr is not None:                                      # the first body's t_h t, the other's -t_h t
                    R -= (1 - 2 * side) * np.column_stack([_lambda_at(c, x @ t, v) for v in tv.T])
                acc += w * (R ** 2).sum(axis=1)
            term = h ** 2 * acc / data[k][0]
            np.add.at(eta2[k], cell, term)
            parts["contact traction"] += float(term.sum())
            s_lo, s_hi = np.minimum(p[e[:, 0]] @ t, p[e[:, 1]] @ t), np.maximum(p[e[:, 0]] @ t, p[e[:, 1]] @ t)
            located.append((k, cell, s_lo, s_hi))
        if not signorini or (c.law is not None and getattr(c.law, "compliant", False)):
            continue                                                   # compliance: penetration is the law
        _signorini_terms(c, located, data, eta2, parts, fr)


def _signorini_terms(c, located, data, eta2, parts, fr=None):
    """2D: int_S lambda_h^+ (g - [u_h nu])^+ and c_T / h_S ||([u_h nu] - g)^+||^2 on each merged segment S,
    split evenly between the sides' cells that hold its midpoint."""
    x = np.asarray(c.x, dtype=float)
    xv = c.trace.vertices(x)
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
    owners = []
    for k, cell, s_lo, s_hi in located:
        order = np.argsort(s_lo)
        j = np.clip(np.searchsorted(s_lo[order], mid, side="right") - 1, 0, len(order) - 1)
        owners.append((k, cell[order[j]]))
    terms = {"complementarity": (comp, 0), "penetration": (pen / hS, 1)}
    if fr is not None:                                                 # a friction law (:mod:`.slipestimate`)
        cone, slides = slip.friction_segments(fr, c, a, b, _GAUSS3)
        terms.update({"friction cone": (hS * cone, -1), "slip complementarity": (slides, 0)})
    _share(owners, terms, data, eta2, parts)


def _share(owners, terms, data, eta2, parts):
    """Add the terms {name: (values (S,), p)} of each contact cell S, each times c_T^p (the complementarity, the
    penetration times c_T, a friction law's terms), split evenly between the sides' ``owners`` [(body k, cell of
    k holding S or -1)]."""
    share = 1.0 / len(owners)
    for k, owner in owners:
        ok = owner >= 0
        for name, (values, p) in terms.items():
            term = share * data[k][0] ** p * values[ok]
            np.add.at(eta2[k], owner[ok], term)
            parts[name] = parts.get(name, 0.0) + float(term.sum())


def _surface_contact_terms(sol, data, cache, eta2, parts, signorini=True):
    """3D: on each side of each pair h_F ||sigma_h n + lambda_h n||_F^2 / c_T on its contact faces F, as
    int_F |sigma_h n|^2 + int over the elements S of X_h of (2 lambda_h sigma_nn + lambda_h^2) (lambda_h is a
    P1 (P2) function on the S, 0 beyond them; each S lies in one face of each side, found by
    :func:`~cvxcontact.contact.overlay.locate` in the plane); a friction law's t_h (the first body's, -t_h on the
    second) adds int_S (|t_h|^2 - 2 t_h . (sigma_h n + lambda_h n)) there. On each S of a Signorini pair the
    complementarity and the penetration (and the friction terms), shared by the cells of the sides that hold its
    centroid."""
    bodies = list(sol.scene.bodies)
    Lq, wq = simplex_rule(2, 4)                       # lambda^2 of P2: degree 4
    for i, c in enumerate(sol.contacts):
        itf = sol._pair_line(i)
        elements, corners, hosts = itf.elements()     # (e, 3 | 6) nodes of X_h (-1: outside it), (e, 3, 2) m
        gap = np.zeros(len(c.lam)) if c.gap is None else np.asarray(c.gap, dtype=float)
        open_ = np.append(gap - np.asarray(c.jump, dtype=float), 0.0)[elements]          # g - [u_nu] at their nodes
        lam = np.append(np.asarray(c.lam, dtype=float), 0.0)[elements]
        N = Lq if elements.shape[1] == 3 else shape_functions(Lq)                          # (q, 3 | 6)
        fr = slip.friction_of(sol, i)                                  # a friction law's t_h, else None
        tan = slip.tangential_vectors(fr, row_frames(itf), elements, N)
        live = (lam != 0).any(axis=1) | (open_ < 0).any(axis=1)    # elsewhere every contact term below is 0
        if tan is not None:
            live |= tan[0]
            tan = tan[1][live].reshape(-1, 3)                          # (e q, 3) at the rule's points
        elements, corners, lam, open_ = elements[live], corners[live], lam[live], open_[live]
        hosts = [None if h is None else h[live] for h in hosts]
        lam, open_ = lam @ N.T, open_ @ N.T                                                 # (e, q)
        d1, d2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        areaS = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
        xq = np.einsum("qv,evd->eqd", Lq, corners).reshape(-1, 2)
        wts = (areaS[:, None] * wq[None, :]).ravel()
        owners = []
        for side, (trace, host) in enumerate(zip(itf.traces, hosts)):
            linear = getattr(trace, "linear", trace)                  # P2: its P1 trace (the same faces)
            k = next(j for j, b in enumerate(bodies) if b is linear.body)
            mesh = linear.body.mesh
            fields, facets = cache[k]
            sigma = fields[2]
            cell, f = _contact_cells(mesh, linear.part, facets)
            normals = mesh.outward_normals(linear.part)
            tv = _voigt_traction(_facet_values(sigma[cell], mesh.cells[cell], f), normals)
            acc = np.zeros(len(f))
            for Lf, w in zip(*simplex_rule(2, 2)):
                acc += w * (np.einsum("j,kjd->kd", Lf, tv) ** 2).sum(axis=1)
            acc *= mesh.face_areas(linear.part)
            if host is None:                                            # S not matched to the faces: find them
                face, Lf = locate(xq, linear.x, linear.faces)
                fc = locate(corners.mean(axis=1), linear.x, linear.faces)[0]
            else:
                face = np.repeat(host, len(wq))
                Lf = barycentric(xq, np.asarray(linear.x)[np.asarray(linear.faces)[face]])
                fc = host
            ok = np.flatnonzero(face >= 0)
            fq = face[ok]
            s = _traction(sigma[cell[fq]], _bary(mesh.cells[cell[fq]], f[fq], Lf[ok]), normals[fq])
            lq = lam.ravel()[ok]
            R2 = 2 * lq * (s * normals[fq]).sum(axis=1) + lq ** 2
            if tan is not None:                                     # the first body's t_h, the other's -t_h
                tq = (1 - 2 * side) * tan[ok]
                R2 += ((tq - 2 * s - 2 * lq[:, None] * normals[fq]) * tq).sum(axis=1)
            np.add.at(acc, fq, wts[ok] * R2)
            term = _diameters(mesh.points, f) * acc / data[k][0]
            np.add.at(eta2[k], cell, term)
            parts["contact traction"] += float(term.sum())
            owners.append((k, np.where(fc >= 0, cell[np.maximum(fc, 0)], -1)))
        if not signorini or (c.law is not None and getattr(c.law, "compliant", False)):
            continue                                                   # compliance: penetration is the law
        comp = areaS * (wq * np.maximum(lam, 0.0) * np.maximum(open_, 0.0)).sum(axis=1)
        pen = areaS * (wq * np.maximum(-open_, 0.0) ** 2).sum(axis=1)
        hS = np.max([np.linalg.norm(corners[:, a] - corners[:, b], axis=1) for a, b in ((0, 1), (1, 2), (2, 0))], axis=0)
        terms = {"complementarity": (comp, 0), "penetration": (pen / hS, 1)}
        if tan is not None:                                            # a friction law (:mod:`.slipestimate`)
            cone, slides = slip.friction_elements(fr, elements, N, areaS[:, None] * wq[None, :])
            terms.update({"friction cone": (hS * cone, -1), "slip complementarity": (slides, 0)})
        _share(owners, terms, data, eta2, parts)
