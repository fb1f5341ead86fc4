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
quadrature of :func:`cvxcontact.fem.simplex.simplex_rule`); the contact terms (:mod:`.contactestimate`) read
lambda_h where it lives, on the merged line (2D) or on the elements of X_h (3D, :meth:`elements` of the pair's
surface).

The constants of reliability are unknown: the estimate is not a guaranteed bound (``guaranteed`` False);
its effectivity (estimate / true error) is measured against nested fine-mesh references
(:mod:`cvxcontact.apps.studies.estimate`, docs/accuracy.md).

Covered: 2D and 3D, P1 and P2 simplices (here) and Q1 and Q2 quadrilaterals and hexahedra
(:mod:`.tensorestimate`, chosen by :data:`GEOMETRIES`), elastic and piezoelectric bodies, pairs and rigid obstacles, the three
Signorini conditions and normal compliance (then the traction mismatch only: the law allows the
penetration). A friction law (Tresca, Coulomb) subtracts its tangential traction t_h from R_F on the contact
parts and adds the friction cone and the slip complementarity on each S (:mod:`.slipestimate`). A curved part
against a planar one (3D) reads lambda_h on the curved side's faces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from ..errors import frozen
from ..fem.assembly import VOIGT, gradients, voigt_strains
from ..fem.simplex import simplex_rule
from ..fem.space import space
from ..geometry.facets import facet_keys
from ..geometry.facets import facets as facet_table
from ..physics.fingerprint import geometry_fingerprint
from . import contactestimate as contact
from .contactestimate import boundary_roles, simplex_diameters, smallest_eigenvalue
from .tensorestimate import TensorGeometry

__all__ = ["ErrorEstimate", "Geometry", "cell_energies", "energy_density", "estimate", "vertex_fields"]


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
    eps = _strains(g.G, np.take(u.ravel(), g.dofs))
    sigma = _times(eps, c.T)
    gphi = D = None
    if e is not None:
        pe = np.take(np.asarray(phi, dtype=float), g.el)
        gphi = np.einsum("mvdj,mj->mvd", g.G, pe)
        sigma += _times(gphi, e)                                     # in place: the same sums, one array fewer
        D = _times(eps, e.T)
        D -= _times(gphi, kappa.T)
    return eps, gphi, sigma, D, g.gradL, g.measure


def _times(a, b) -> np.ndarray:
    """a (..., i) @ b (i, j): one product of the stacked rows of ``a`` (a (m, q, i) stack of q x i products is
    several times slower)."""
    return (a.reshape(-1, a.shape[-1]) @ b).reshape(a.shape[:-1] + (b.shape[1],))


def _strains(G, ue) -> np.ndarray:
    """(m, q, s) Voigt strains B(G[:, i]) ue at the q corner values, G (m, q, d, k) the shape gradients, ue (m, d k)
    the element displacements (:func:`~cvxcontact.fem.assembly.voigt_strains`: without forming B)."""
    m, q, dim, _ = G.shape
    eps = np.empty((m, q, len(VOIGT[dim])))
    for i in range(q):
        eps[:, i] = voigt_strains(G[:, i], ue)
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
        w = np.einsum("...s,...s->...", a, b)
        return w if c is None else w - np.einsum("...s,...s->...", c, d)

    own = density(eps, sigma, gphi, D)                   # (m, q)
    if q == 1:                                            # the sums over the q values are the values: the same
        together = own[:, 0]                              # numbers as density(*sums), not formed twice
    else:
        together = density(*(None if x is None else x.sum(axis=1) for x in (eps, sigma, gphi, D)))
    total = r * own.sum(axis=1) + r * r * together
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
        self.cT = smallest_eigenvalue(c, True)
        self.kT = smallest_eigenvalue(kappa, False) if kappa is not None else None
        self.measure, self.gradL = gradients(mesh.points, mesh.cells)
        # G (m, q, d, k): q = d + 1, or 1 (P1: a view of gradL, one copy of the gradients)
        self.el, self.G = space(degree, mesh.cell).corner_gradients(body, self.gradL)
        self._parts: dict = {}
        self._roles: dict = {}

    @cached_property
    def dofs(self) -> np.ndarray:
        """(m, k d) the element displacements' indices in the flattened nodal displacements (node-major)."""
        k, dim = self.el.shape[1], self.dim
        index = np.int32 if (int(self.el.max()) + 1) * dim <= np.iinfo(np.int32).max else np.int64
        return (dim * self.el[:, :, None] + np.arange(dim)).reshape(len(self.el), k * dim).astype(index)

    def roles(self, mech: dict, elec: dict, partial: dict) -> _Roles:
        """The :class:`_Roles` of the boundary parts' mechanical roles ``mech`` and electric roles ``elec`` (tag ->
        role, :func:`~.contactestimate.boundary_roles`) and the prescribed components of the ``partial`` parts,
        kept per roles (a load case keeps them unless it loads other parts)."""
        key = (tuple(mech.items()), tuple(elec.items()), tuple((t, tuple(c)) for t, c in partial.items()))
        if key not in self._roles:
            self._roles[key] = _Roles.of(self, mech, elec, partial)
        return self._roles[key]

    @cached_property
    def index(self) -> type:
        """The integer type of the cell, facet and node indices kept here: int32 while every index (the rows of
        the fields stacked, ``q`` per cell; the facets, at most d + 1 per cell; the nodes) fits in it (half the
        bytes of int64), else int64."""
        size = max(self.G.shape[1] * len(self.el) + 1, (self.dim + 1) * len(self.el), len(self._mesh.points))
        return np.int32 if size <= np.iinfo(np.int32).max else np.int64

    @cached_property
    def facets(self):
        """The facet table (:func:`~cvxcontact.geometry.facets.facets`: owners, local indices, vertices, keys),
        kept with owners and vertices of :attr:`index` type and local indices as int8 (the keys int64)."""
        owners, local, vertices, keys = facet_table(self._mesh.cells, len(self._mesh.points))
        return owners.astype(self.index), local.astype(np.int8), vertices.astype(self.index), keys

    @cached_property
    def hT(self) -> np.ndarray:
        """(m,) m: the longest edge of each cell."""
        return simplex_diameters(self._mesh.points, self._mesh.cells)

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
        ii = np.flatnonzero(inner).astype(self.index)
        c1 = owners[ii, 1]
        q = self.G.shape[1]                                   # the fields' distinct values per cell (_fields)
        area = dim * self.measure[c0] * size                  # |F| = d |T| |grad L_i|
        hF = simplex_diameters(mesh.points, vertices)
        pos0 = (contact.facet_positions(mesh.cells[c0], vertices) % q)[:, :min(q, dim)]
        pos1 = (contact.facet_positions(mesh.cells[c1], vertices[ii]) % q)[:, :min(q, dim)]
        at1 = np.full(pos0.shape, q * len(self.el), dtype=self.index)   # a boundary facet's other side: a zero row
        at1[ii] = q * c1[:, None] + pos1
        at0 = (q * c0[:, None] + pos0).astype(self.index)
        return _Faces(c0=c0, c1=c1, inner=inner.astype(float), ii=ii, normal=-grad / size[:, None], area=area,
                      hF=hF, at0=at0, at1=at1, scale=np.where(inner, 0.5, 1.0) * hF * area,
                      jumps=_jump_blocks(at0, at1, q * len(self.el)),
                      owners=tuple(_incidence(c, f, len(self.el), len(c0)) for c, f in ((c0, None), (c1, ii))))

    def part(self, tag) -> np.ndarray:
        """The indices in the facet table of the facets of boundary part ``tag``."""
        if tag not in self._parts:
            mesh, key = self._mesh, self.facets[3]
            self._parts[tag] = np.searchsorted(key, facet_keys(np.sort(mesh.boundary(tag), axis=1), len(mesh.points)))
        return self._parts[tag]

    def terms(self, body, u, phi, eta2, parts, sol) -> tuple[float, contact.SimplexSides]:
        """Add the element and facet terms of ``body``'s fields (displacements ``u``, potentials ``phi``) to its
        ``eta2`` (m,) and ``parts``; (its squared energy norm, what the contact terms read of it)."""
        fields = _fields(self, u, phi)
        _element_terms(body, fields, self, eta2, parts)
        _facet_terms(body, fields, self, eta2, parts, sol)
        contacts = [t for t, role in boundary_roles(body, sol)[0].items() if role == "contact"]
        return (float(_cell_energies(body, fields).sum()),
                contact.SimplexSides(body.mesh, fields[2], self.facets, contacts))

    def points(self, L) -> np.ndarray:
        """(m, d) m: the points of barycentric coordinates ``L`` (d + 1,) in each cell (formed anew, not kept)."""
        return _at(self._mesh.points, self._mesh.cells, L)


@dataclass(frozen=True)
class _Faces:
    """The facets of a :class:`Geometry`: ``c0`` (f,) the first cell of each (its normal points out of it),
    ``c1`` the second cell of the interior ones ``ii`` (``inner`` (f,) 1.0 for those, else 0.0), ``normal``
    (f, d) unit, ``area`` (f,) m (2D) or m^2, ``hF`` (f,) m its longest edge, ``at0`` / ``at1`` (f, v) where each
    of its vertices sits among the distinct corner values of its first / second cell, as a row of the fields
    stacked (m q, ...) (v = d, or 1 for fields constant on a cell; a boundary facet's second: the row m q, a zero
    row appended), ``scale`` (f,) the weight h_F |F| of its residual, halved on an interior facet (shared by its
    two cells); ``jumps`` the jumps at0 - at1 as sparse operators on the stacked fields (:func:`_jump_blocks`) and
    ``owners`` the cells' incidences of the facet terms (:func:`_incidence`: first cells, second cells): what a
    load case reads of the facets, formed once per geometry."""

    c0: np.ndarray
    c1: np.ndarray
    inner: np.ndarray
    ii: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    hF: np.ndarray
    at0: np.ndarray
    at1: np.ndarray
    scale: np.ndarray
    jumps: tuple
    owners: tuple


def _jump_blocks(at0, at1, rows) -> tuple:
    """The jumps of :func:`_normal_jumps` as sparse operators on the fields stacked (``rows`` rows): per block of
    ``contact.CELLS`` facets a CSR matrix (k v, rows), +1 at each facet vertex's row ``at0`` of its first cell and
    -1 at ``at1`` of its second (none on a boundary facet: ``at1`` is ``rows``, the zero row). Applied to the
    stacked values it gives each jump as 1 a + (-1) b summed from 0: a - b (and a on a boundary facet), the same
    numbers as the differences of the rows taken (read-only; 12 bytes per facet vertex and side)."""
    out = []
    for s in range(0, max(len(at0), 1), contact.CELLS):                     # (one block if empty)
        a0, a1 = at0[s:s + contact.CELLS].ravel(), at1[s:s + contact.CELLS].ravel()
        inner = np.flatnonzero(a1 < rows)
        r = np.arange(len(a0))
        J = sp.csr_matrix((np.concatenate([np.ones(len(a0)), -np.ones(len(inner))]),
                           (np.concatenate([r, inner]), np.concatenate([a0, a1[inner]]))), shape=(len(a0), rows))
        out.append((frozen(J), min(contact.CELLS, len(at0) - s)))
    return tuple(out)


def _incidence(cells, at, m, count) -> sp.csr_matrix:
    """(m, count) CSR: 1.0 at (cells[i], at[i]) (``at`` None: i), for each cell the facets whose term it takes,
    in facet order; its product with the facet terms is ``np.bincount(cells, terms[at], m)``'s sums in the same
    order from 0 (the same numbers; read-only)."""
    at = np.arange(len(cells)) if at is None else at
    return frozen(sp.csr_matrix((np.ones(len(cells)), (cells, at)), shape=(m, count)))


@dataclass(frozen=True)
class _Roles:
    """Where the boundary conditions of one body act on its facet table (:meth:`Geometry.roles`): ``held`` the
    facets where sigma_h n does not count (clamped, prescribed, contact: the contact terms' own), ``roller`` those
    where only its tangential part does, ``partial`` ((facets, components)) those of the parts with prescribed
    components (those do not count), ``grounded`` those where D_h . n does not count (electrodes); ``loaded`` the
    facets with a traction or a charge (their residual by a rule: a load is any function), and there ``load_m`` /
    ``load_e`` (tag -> positions in ``loaded``), ``roller_l`` (positions), ``keep_m`` (l, d) and ``keep_e`` (l,) the
    components that count (1.0, else 0.0)."""

    held: np.ndarray
    roller: np.ndarray
    partial: tuple
    grounded: np.ndarray
    loaded: np.ndarray
    load_m: dict
    load_e: dict
    roller_l: np.ndarray
    keep_m: np.ndarray
    keep_e: np.ndarray

    @classmethod
    def of(cls, g, mech_role, elec_role, partial) -> _Roles:
        """The roles of :meth:`Geometry.roles` on the facet table of ``g``: a part's facets take its role, a facet
        of two parts the later one's."""
        dim, count = g.dim, len(g.facets[3])
        code = {role: c for c, role in enumerate(("free", "dirichlet", "contact", "roller", "partial", "traction",
                                                   "charge"))}      # each facet's role as a small integer
        role_m = np.zeros(count, dtype=np.int8)
        role_e = np.zeros(count, dtype=np.int8)
        load_m, load_e = {}, {}
        for roles, out, loads, kind in ((mech_role, role_m, load_m, "traction"), (elec_role, role_e, load_e, "charge")):
            for tag, role in roles.items():
                out[g.part(tag)] = code[role]
                if role == kind:
                    loads[tag] = g.part(tag)
        held = (role_m == code["dirichlet"]) | (role_m == code["contact"])
        partial = tuple((g.part(tag), list(comps)) for tag, comps in partial.items())
        roller = np.flatnonzero(role_m == code["roller"])
        loaded = np.unique(np.concatenate([np.zeros(0, dtype=int), *load_m.values(), *load_e.values()]))
        at = np.full(count, -1)
        at[loaded] = np.arange(len(loaded))
        keep = np.ones((len(loaded), dim))
        keep[held[loaded]] = 0.0
        for idx, comps in partial:
            keep[np.ix_(np.isin(loaded, idx), comps)] = 0.0
        return cls(held=np.flatnonzero(held), roller=roller, partial=partial,
                   grounded=np.flatnonzero(role_e == code["dirichlet"]), loaded=loaded,
                   load_m={t: at[i] for t, i in load_m.items()}, load_e={t: at[i] for t, i in load_e.items()},
                   roller_l=at[roller][at[roller] >= 0], keep_m=keep,
                   keep_e=(role_e[loaded] != code["dirichlet"]).astype(float))


def _geometry(body, degree: int, cache, fingerprint: str | None = None) -> Geometry:
    """The :class:`Geometry` of ``body`` in ``degree``: from ``cache`` (a dict, or None: built afresh) under the
    body's geometry fingerprint (``fingerprint``, if the caller has just checked it; else computed) and the
    degree, else built (and kept there)."""
    build = GEOMETRIES[body.mesh.cell]
    if cache is None:
        return build(body, degree)
    key = (geometry_fingerprint(body) if fingerprint is None else fingerprint, degree)
    if key not in cache:
        cache[key] = build(body, degree)
    return cache[key]


GEOMETRIES = {"triangle": Geometry, "tetra": Geometry, "quad": TensorGeometry, "hex": TensorGeometry}
"""The estimate's geometry of a body by its cells (``mesh.cell``): :class:`Geometry` for simplices (fields
affine on a cell), :class:`~cvxcontact.solution.tensorestimate.TensorGeometry` for quadrilaterals and
hexahedra (fields at quadrature points)."""


# ---------------------------------------------------------------------------------------------- the estimator


def estimate(sol, signorini: bool = True, cache: dict | None = None,
             fingerprints: tuple | None = None) -> tuple[ErrorEstimate | None, str]:
    """(the :class:`ErrorEstimate` of ``sol``, "") (module docstring); the tuple's second entry says why the
    estimate is None for a case not covered (none at present). ``signorini=False`` leaves out the
    complementarity and penetration terms (a problem whose contact rows are equalities: the dual problem of
    :mod:`cvxcontact.goal`). ``cache``: a dict that keeps each body's :class:`Geometry` between calls (a
    ContactSolver's, for its load cases; None: built afresh); the answer is the same with or without it.
    ``fingerprints``: the bodies' geometry fingerprints as the caller checked them for this solve (a
    ContactSolver's problem, :attr:`~cvxcontact.discrete.DiscreteProblem.fingerprints`), the cache's keys
    (None: computed here)."""
    scene = sol.scene
    bodies = scene.bodies
    eta2 = [np.zeros(len(b.mesh.cells)) for b in bodies]
    parts = dict.fromkeys(("element", "jump", "boundary", "contact traction", "electric element", "electric jump",
                           "electric boundary", "complementarity", "penetration"), 0.0)
    norm2 = 0.0
    data, held = [], []
    for k, b in enumerate(bodies):
        g = _geometry(b, sol.degree, cache, None if fingerprints is None else fingerprints[k])
        energy, sides = g.terms(b, sol.u[k], sol.phi[k], eta2[k], parts, sol)
        norm2 += energy
        held.append(sides)
        data.append((g.cT, g.kT))
    terms = contact.contact_terms if scene.dim == 2 else contact.surface_contact_terms
    terms(sol, data, held, eta2, parts, signorini)
    indicators = tuple(read_only(np.sqrt(np.maximum(e, 0.0))) for e in eta2)
    total = float(sum(e.sum() for e in eta2))
    return ErrorEstimate(absolute=float(np.sqrt(max(total, 0.0))), norm=float(np.sqrt(max(norm2, 0.0))),
                         indicators=indicators, parts=parts,
                         unit="sqrt(J)" if scene.dim == 3 else "sqrt(J/m)"), ""


def read_only(a):
    """``a`` as a float array whose writing is turned off (results are data)."""
    a = np.asarray(a, dtype=float)
    a.setflags(write=False)
    return a


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
    at_points = not (f0.constant and q0.constant)          # a load function is evaluated at the rule's points
    if sigma.shape[1] == 1:                                # fields constant on each cell: no divergence, exactly
        n = len(sigma) if at_points else 1                 # (and with constant loads one residual for every cell)
        div, rd = np.zeros((n, dim)), (None if D is None else np.zeros(n))
    else:
        dsig = contact.voigt_tensor(np.einsum("mvs,mjv->mjs", sigma, gradL))          # (m, j, i, i')
        div = np.einsum("mjij->mi", dsig)
        rd = np.einsum("mvd,mdv->m", D, gradL) if D is not None else None       # div D (constant)
    mech = (div ** 2).sum(axis=1)                          # constant residuals without loads
    elec = None if D is None else rd ** 2
    if f0.nonzero or (D is not None and q0.nonzero):
        mech, elec = 0.0, (None if D is None else 0.0)
        for L, w in zip(*simplex_rule(dim, 2)):
            x = geometry.points(L).T if at_points else None
            r = div + _load_values(f0, x, div.shape) if f0.nonzero else div
            mech = mech + w * (r ** 2).sum(axis=1)
            if D is not None:
                re = rd - _load_values(q0, x, rd.shape) if q0.nonzero else rd
                elec = elec + w * re ** 2
    term = hT ** 2 * mech * measure / cT
    eta2 += term
    parts["element"] += float(term.sum())
    if D is not None:
        term = hT ** 2 * elec * measure / kT
        eta2 += term
        parts["electric element"] += float(term.sum())


def _load_values(load, x, shape) -> np.ndarray:
    """The values of ``load`` (a :class:`~cvxcontact.physics.body.Load`) at the points ``x`` (d, k) m, as an
    array of ``shape`` (k, ...); ``x`` None for a constant load (its value everywhere: no points needed)."""
    if x is None:
        return np.broadcast_to(load.value, shape)
    return np.asarray(load(*x), dtype=float).reshape(shape)


def _affine_mean_square(values) -> np.ndarray:
    """(k,): the mean over each simplex of |f|^2 for the affine f of vertex values ``values`` (k, v, c) (v
    vertices): (sum_i |f_i|^2 + |sum_i f_i|^2) / (v (v + 1))."""
    v = values.shape[1]
    own = np.einsum("kvc,kvc->k", values, values)
    if v == 1:                                            # one value (a field constant on the facet): |f|^2,
        return own                                        # (own + own) / 2 exactly
    total = values.sum(axis=1)
    return (own + np.einsum("kc,kc->k", total, total)) / (v * (v + 1))


def _facet_terms(body, fields, geometry, eta2, parts, sol):
    """The interior jumps and the boundary residuals of ``body`` (module docstring; ``facets`` its
    :func:`~cvxcontact.geometry.facets.facets`); contact parts are left to the contact terms.
    sigma_h and D_h are affine on each facet: their normal components are formed at its vertices (an interior
    facet's from the jump of the two cells' values there) and interpolated to the quadrature points."""
    sigma, D = fields[2], fields[3]
    g = geometry
    dim = g.dim
    vertices = g.facets[2]
    p = body.mesh.points
    f = g.faces
    n = f.normal
    mech_role, elec_role = boundary_roles(body, sol)
    partial = {tag: [comp for comp, val in enumerate(v) if val is not None] for tag, v in body.displacement.items()
               if mech_role.get(tag) == "partial"}
    roles = g.roles(mech_role, elec_role, partial)
    Rv = _normal_jumps(sigma, f, n, contact.voigt_traction)                                      # (k, v, d)
    rv = None if D is None else _normal_jumps(D, f, n, lambda J, nb: np.einsum("kvd,kd->kv", J, nb))  # (k, v)
    loaded = roles.loaded
    Rl = Rv[loaded]                                       # the loaded facets' by a rule below (copies)
    rl = None if D is None else rv[loaded]
    # without a load R is affine on the facet: the mean of |R|^2 from its vertex values, exactly (the rule of
    # degree 3 below gives the same to rounding); the loaded facets by that rule (a load is any function).
    # Only the boundary facets have a role: R is zeroed where a component does not count, in place.
    Re, roller = Rv, roles.roller
    Re[roller] -= (Re[roller] * n[roller, None, :]).sum(axis=2)[..., None] * n[roller, None, :]
    Re[roles.held] = 0.0
    for idx, comps in roles.partial:
        sub = Re[idx]
        sub[..., comps] = 0.0
        Re[idx] = sub
    mech = _affine_mean_square(Re)
    if D is not None:
        rv[roles.grounded] = 0.0
        elec = _affine_mean_square(rv[..., None])
    if len(loaded):
        mech[loaded] = 0.0
        if D is not None:
            elec[loaded] = 0.0
        roller_l, n_l = roles.roller_l, n[loaded]
        for Lf, w in zip(*simplex_rule(dim - 1, 3)):
            R = np.tensordot(_onto(Lf, Rl.shape[1]), Rl, axes=(0, 1))
            x = np.tensordot(Lf, p[vertices[loaded]], axes=(0, 1))
            for tag, idx in roles.load_m.items():
                R[idx] -= np.asarray(body.traction[tag](*x[idx].T), dtype=float).reshape(len(idx), dim)
            R[roller_l] -= (R[roller_l] * n_l[roller_l]).sum(axis=1)[:, None] * n_l[roller_l]
            R *= roles.keep_m
            mech[loaded] += w * (R ** 2).sum(axis=1)
            if D is not None:
                r = rl @ _onto(Lf, rl.shape[1])
                for tag, idx in roles.load_e.items():
                    r[idx] -= np.asarray(body.surface_charge[tag](*x[idx].T), dtype=float).reshape(len(idx))
                elec[loaded] += w * (r * roles.keep_e) ** 2
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
    eta2 += f.owners[0] @ term + f.owners[1] @ term         # np.bincount(f.c0, term) + np.bincount(f.c1, term[ii])


def _normal_jumps(values, f, n, times) -> np.ndarray:
    """``times(J, n)`` of the jumps J (k, v, ...) of the vertex values ``values`` (m, q, ...): each facet's first
    cell's values minus its second's (a boundary facet's: its first's) at the facet's v vertices (:class:`_Faces`
    ``at0``, ``at1``), on the facets' normals ``n`` (k, d); by blocks of ``contact.CELLS`` facets, so that the
    jumps (k, v, s) are never all formed (the same numbers: a boundary facet's second side is 0.0)."""
    stacked = values.reshape((len(values) * values.shape[1], -1))
    out, s = None, 0
    for J, k in f.jumps:                                  # (:func:`_jump_blocks`: kept with the facets)
        block = times((J @ stacked).reshape((k, f.at0.shape[1]) + values.shape[2:]), n[s:s + k])
        if out is None:
            out = np.empty((len(f.at0),) + block.shape[1:])
        out[s:s + k] = block
        s += k
    return out
