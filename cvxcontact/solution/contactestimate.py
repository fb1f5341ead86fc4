"""The contact terms of the residual estimate (:mod:`cvxcontact.solution.estimate`, docs/accuracy.md), and the
pointwise primitives on simplices they share with it (stress tensors and tractions from Voigt vectors, points
of a facet in its cell, the cells' diameters).

On the contact part of each side, R_F = sigma_h n + lambda_h n (eq. (8): sigma_nu = -lambda, sigma_tau = 0;
lambda_h the solution's multiplier, 0 beyond its support), h_F ||R_F||_F^2 / c_T; on each cell S of the contact
mesh of a Signorini pair (2D: the merged segments; 3D: the elements of X_h, the overlay triangles or the faces
against an obstacle) the complementarity int_S lambda_h^+ (g - [u_h nu])^+ and the penetration
c_T / h_S ||([u_h nu] - g)^+||_S^2, shared by the cells of both sides (a side held by several obstacles: once on
the side, lambda_h the pairs' summed and g - [u_h nu] the least over them; 2D :func:`_side_line_terms`, 3D
:func:`_side_gap_terms`). A friction law subtracts its tangential
traction t_h from R_F and adds the friction cone and the slip complementarity on each S (:mod:`.slipestimate`).
lambda_h is read where it lives: on the merged line (2D) or on the elements of X_h (3D, :meth:`elements` of the
pair's surface).
"""

from __future__ import annotations

import numpy as np

from ..contact.interface import row_frames, row_tangents
from ..contact.overlay import barycentric, locate
from ..contact.sides import held_sides, pair_sides
from ..fem.assembly import VOIGT
from ..fem.p2 import shape_functions
from ..fem.simplex import simplex_rule
from ..geometry.facets import facet_keys
from . import slipestimate as slip

__all__: list[str] = []

CELLS = 1 << 15
"""Cells per block of the strain matrices and edge vectors formed on the fly (bounds their temporaries)."""

_GAUSS3 = (0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5 / 18, 8 / 18, 5 / 18]))


def voigt_traction(sv, n) -> np.ndarray:
    """(k, v, d): sigma n of Voigt vectors ``sv`` (k, v, s) on the unit normals ``n`` (k, d), component by
    component (t_i += sigma_ij n_j over the Voigt pairs), without forming the tensors."""
    dim = n.shape[1]
    terms: dict = {i: [] for i in range(dim)}             # per component i, its (Voigt row, j) in row order
    for row, (i, j) in enumerate(VOIGT[dim]):
        terms[i].append((row, j))
        if i != j:
            terms[j].append((row, i))
    t = np.empty(sv.shape[:2] + (dim,))
    for i, ((row, j), *rest) in terms.items():
        out = t[..., i]
        np.multiply(sv[..., row], n[:, None, j], out=out)
        for row, j in rest:
            out += sv[..., row] * n[:, None, j]
    return t


def voigt_tensor(sv):
    """(..., d, d) symmetric tensors from Voigt vectors (..., s) (xx, yy, xy in 2D; xx, yy, zz, yz, xz, xy in 3D)."""
    dim = 3 if sv.shape[-1] == 6 else 2
    out = np.empty(sv.shape[:-1] + (dim, dim))
    for row, (i, j) in enumerate(VOIGT[dim]):
        out[..., i, j] = out[..., j, i] = sv[..., row]
    return out


def simplex_diameters(points, simplices) -> np.ndarray:
    """(m,) the longest edge of each simplex (m, k) of ``points`` (by blocks of CELLS simplices)."""
    i, j = np.triu_indices(simplices.shape[1], 1)
    out = np.empty(len(simplices))
    for s in range(0, len(simplices), CELLS):
        edge = points[simplices[s:s + CELLS, i]] - points[simplices[s:s + CELLS, j]]   # (block, edges, dim)
        out[s:s + CELLS] = np.sqrt(np.einsum("med,med->me", edge, edge).max(axis=1))
    return out


def facet_positions(cell_vertices, facet_vertices) -> np.ndarray:
    """(k, d): the local index in each cell (vertices ``cell_vertices`` (k, d + 1)) of each vertex of its facet
    ``facet_vertices`` (k, d)."""
    return np.argmax(cell_vertices[:, :, None] == facet_vertices[:, None, :], axis=1)


def _facet_values(values, cell_vertices, facet_vertices, pos=None):
    """(k, d, ...) the vertex values ``values`` (k, d + 1, ...) of cells with vertices ``cell_vertices``
    (k, d + 1) at the vertices ``facet_vertices`` (k, d) of one facet of each (``pos``: their
    :func:`facet_positions`, if known)."""
    pos = facet_positions(cell_vertices, facet_vertices) if pos is None else pos
    return values[np.arange(len(values))[:, None], pos]


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
    return np.einsum("kij,kj->ki", voigt_tensor(np.einsum("kv,kvs->ks", L, sigma_v)), n)


class SimplexSides:
    """What the contact terms read of one body of simplices (:class:`~.estimate.Geometry`): the vertex values of
    sigma_h ``sigma`` (m, q, s) Voigt, Pa, on its cells (q = d + 1, or 1: constant on each cell, read at each of
    the d + 1 vertices) and its facet table ``facets``; :meth:`side` one boundary part of ``parts`` (the body's
    contact parts: only the rows of the cells holding their faces are kept, a copy, not the body's every
    cell). The same questions of a body of quadrilaterals or hexahedra: :class:`~.tensorestimate.TensorSides`."""

    def __init__(self, mesh, sigma, facets, parts):
        self._mesh, self._facets = mesh, facets
        self._cells = {part: _contact_cells(mesh, part, facets) for part in parts}
        kept = np.unique(np.concatenate([np.zeros(0, dtype=int), *(c for c, _ in self._cells.values())]))
        rows = sigma[kept]                                            # (c, q, s), the corners a view of it
        self._sigma, self._kept = np.broadcast_to(rows, (len(rows), mesh.cells.shape[1], rows.shape[2])), kept

    def side(self, part) -> SimplexSide:
        """The :class:`SimplexSide` of contact part ``part``."""
        cell, f = self._cells[part]
        return SimplexSide(self._mesh, self._sigma, (cell, f, np.searchsorted(self._kept, cell)), part)

    def multiplier(self, c, part) -> np.ndarray:
        """lambda_h (Pa) at the nodes of X_h of the 3D contact result ``c`` (on this body's part ``part``): the
        read-back's, ``c.lam`` (the Riesz representer of the forces on the faces' triangles, this body's
        trace)."""
        return np.asarray(c.lam, dtype=float)

    def friction(self, fr, c, part):
        """A friction law's :class:`~cvxcontact.solution.slipestimate.Friction` ``fr`` of the 3D contact result
        ``c`` as this body's trace reads it: ``fr`` itself."""
        return fr


class SimplexSide:
    """One boundary part of a body of simplices, as the contact terms read it: its faces ``f`` (k, d) (the
    mesh's ``boundary(part)``: the trace's segments in 2D, its triangles in 3D), the cell ``cell`` (k,) holding
    each, unit outward ``normals`` (k, d), diameters ``hF`` (k,) m; sigma_h n (:meth:`traction`) at points of
    the trace's elements, the face of each element (:meth:`face_of`: itself) and int_F |sigma_h n|^2
    (:meth:`squares`)."""

    def __init__(self, mesh, sigma, faces, part):
        self._mesh, self._sigma, self._part = mesh, sigma, part
        self.cell, self.f, self._row = faces            # its cells, faces, and the cells' rows of ``sigma``
        self.normals = mesh.outward_normals(part)

    @property
    def hF(self) -> np.ndarray:
        return simplex_diameters(self._mesh.points, self.f)

    def face_of(self, element):
        """The faces of the trace's elements ``element``: the same indices."""
        return element

    def traction(self, element, L) -> np.ndarray:
        """(k, d) sigma_h n (Pa) at the points of barycentric coordinates ``L`` (d,) or (k, d) on the trace's
        elements ``element`` (indices or a slice into ``f``), by blocks of :data:`CELLS` points (the vertex
        values gathered per point, (k, d + 1, s), are the largest temporary of the estimate otherwise)."""
        element = np.arange(len(self.f))[element] if isinstance(element, slice) else np.asarray(element)
        L = np.asarray(L, dtype=float)
        out = np.empty((len(element), self.normals.shape[1]))
        for s in range(0, len(element), CELLS):
            e = element[s:s + CELLS]
            cell = self.cell[e]
            out[s:s + CELLS] = _traction(self._sigma[self._row[e]], _bary(self._mesh.cells[cell], self.f[e],
                                                                  L if L.ndim == 1 else L[s:s + CELLS]),
                                         self.normals[e])
        return out

    def squares(self) -> np.ndarray:
        """(k,) int_F |sigma_h n|^2 (Pa^2 m^2) of each face F (3D: sigma_h n affine on F, a rule of degree 2)."""
        mesh, cell, f = self._mesh, self.cell, self.f
        tv = voigt_traction(_facet_values(self._sigma[self._row], mesh.cells[cell], f), self.normals)
        acc = np.zeros(len(f))
        for Lf, w in zip(*simplex_rule(2, 2)):
            acc += w * (np.einsum("j,kjd->kd", Lf, tv) ** 2).sum(axis=1)
        return acc * mesh.face_areas(self._part)


def smallest_eigenvalue(matrix, voigt: bool) -> float:
    """The smallest eigenvalue of a stiffness (Voigt, engineering shear: on tensor-orthonormal strains) or
    permittivity matrix."""
    a = np.asarray(matrix, dtype=float)
    if voigt:
        dim = 3 if len(a) == 6 else 2
        s = np.array([1.0] * dim + [np.sqrt(2.0)] * (len(a) - dim))
        a = s[:, None] * a * s[None, :]
    return float(np.linalg.eigvalsh(0.5 * (a + a.T)).min())


def boundary_roles(body, sol):
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


def contact_terms(sol, data, cache, eta2, parts, signorini=True):
    """2D: on each side (body, contact part) h_E ||sigma_h n + sum_i (lambda_i n - t_i t)||^2 / c_T over the pairs
    i that hold the part (one, or several obstacles each reaching part of it; t_i a friction law's, the first body's
    and the opposite on the second), once per side; on each merged segment of a Signorini pair the
    complementarity and the penetration (a side held by several obstacles: once on the side,
    :func:`_side_line_terms`) and the friction terms, shared by the cells of the sides (module docstring)."""
    scene = sol.scene
    held = held_sides(scene.stack)                                      # per side (k, part): [(pair, its side)]
    sided = _gap_sides(sol, held, signorini)     # sides whose complementarity is read once (_side_line_terms)
    done, fields = set(), {}
    for i, c in enumerate(sol.contacts):
        if i not in fields:
            fields[i] = _pair_fields(sol, i)
        located = []
        for k, part in pair_sides(scene.stack, i):
            mesh = scene.bodies[k].mesh
            on = cache[k].side(part)
            cell, e, n = on.cell, on.f, on.normals                      # e oriented: domain on the left
            p = mesh.points
            if (k, part) not in done:
                done.add((k, part))
                for j, _ in held[(k, part)]:
                    if j not in fields:
                        fields[j] = _pair_fields(sol, j)
                h = np.linalg.norm(p[e[:, 1]] - p[e[:, 0]], axis=1)
                acc = np.zeros(len(e))
                for tq, w in zip(*_GAUSS3):
                    x = (1 - tq) * p[e[:, 0]] + tq * p[e[:, 1]]
                    R = on.traction(slice(None), np.array([1 - tq, tq]))
                    for j, side in held[(k, part)]:
                        cj, t, x_line, lam, tv, _ = fields[j]
                        R += _line_at(cj, x_line, lam, x @ t)[:, None] * n
                        if tv is not None:                              # the first body's t_h t, the other's -t_h t
                            R -= (1 - 2 * side) * np.column_stack([_line_at(cj, x_line, v, x @ t) for v in tv.T])
                    acc += w * (R ** 2).sum(axis=1)
                term = h ** 2 * acc / data[k][0]
                np.add.at(eta2[k], cell, term)
                parts["contact traction"] += float(term.sum())
            t = fields[i][1]
            s_lo, s_hi = np.minimum(p[e[:, 0]] @ t, p[e[:, 1]] @ t), np.maximum(p[e[:, 0]] @ t, p[e[:, 1]] @ t)
            located.append((k, cell, s_lo, s_hi))
        if not signorini or (c.law is not None and getattr(c.law, "compliant", False)):
            continue                                                   # compliance: penetration is the law
        key = pair_sides(scene.stack, i)[0]
        if key in sided and sided[key][-1] == i:       # obstacles sharing the part: read on the side, once
            _side_line_terms(sol, {j: fields[j] for j in sided[key]}, located, data, eta2, parts)
        _signorini_terms(c, located, data, eta2, parts, fields[i][5], alone=key not in sided)


def _pair_fields(sol, i):
    """2D pair ``i`` of ``sol`` as the traction term reads it: (its contact result, its tangent (2,), the line its
    functions live on (m, :meth:`~cvxcontact.contact.interface.Interface.support`), lambda_h there, a friction
    law's t_h there as vectors (n, 2) along each row's tangent (turned: a curve) and its
    :class:`~cvxcontact.solution.slipestimate.Friction`, or None, None)."""
    c, line = sol.contacts[i], sol._pair_line(i)
    t = np.asarray(sol.scene.interfaces[i].tangent, dtype=float)
    x, lam = line.support(c.lam)
    fr = slip.friction_of(sol, i)                                       # a friction law's t_h, else None
    if fr is None:
        return c, t, x, lam, None, None
    tv = line.support(fr.t[:, None] * np.broadcast_to(row_tangents(line, 0), (len(fr.t), 2)))[1]
    return c, t, x, lam, tv, fr


def _line_at(c, x, values, s):
    """The function of nodal ``values`` on the line of nodes ``x`` (m) of 2D contact result ``c``'s trace (P1,
    P2) at tangential coordinates ``s`` (m), 0 beyond it."""
    return np.where((s < x[0]) | (s > x[-1]), 0.0, c.trace.values(x, values, s))


def _signorini_terms(c, located, data, eta2, parts, fr=None, alone=True):
    """2D: int_S lambda_h^+ (g - [u_h nu])^+ and c_T / h_S ||([u_h nu] - g)^+||^2 on each merged segment S (not
    with ``alone`` False: a side held by several obstacles, :func:`_side_line_terms`) and a friction law's terms,
    split evenly between the sides' cells that hold its midpoint."""
    x = np.asarray(c.x, dtype=float)
    xv = c.trace.vertices(x)
    if len(xv) < 2 or not (alone or fr is not None):
        return
    a, b = xv[:-1], xv[1:]
    hS = b - a
    terms = {}
    if alone:                                  # (else read once on the side: _side_line_terms)
        gap = np.zeros(len(x)) if c.gap is None else np.asarray(c.gap, dtype=float)
        open_ = gap - np.asarray(c.jump, dtype=float)                      # g - [u_nu] at the merged nodes
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
        terms = {"complementarity": (comp, 0), "penetration": (pen / hS, 1)}
    owners = _segment_owners(located, 0.5 * (a + b))
    if fr is not None:                                                 # a friction law (:mod:`.slipestimate`)
        cone, slides = slip.friction_segments(fr, c, a, b, _GAUSS3)
        terms.update({"friction cone": (hS * cone, -1), "slip complementarity": (slides, 0)})
    _share(owners, terms, data, eta2, parts)


def _segment_owners(located, mid) -> list:
    """[(body k, cell of k)] per side of ``located`` [(k, cells (e,), the faces' s_lo (e,), s_hi (e,))]: the cell
    whose face holds each abscissa ``mid`` (m), the owners of :func:`_share`."""
    owners = []
    for k, cell, s_lo, s_hi in located:
        order = np.argsort(s_lo)
        j = np.clip(np.searchsorted(s_lo[order], mid, side="right") - 1, 0, len(order) - 1)
        owners.append((k, cell[order[j]]))
    return owners


def _side_line_terms(sol, group, located, data, eta2, parts):
    """2D: the complementarity int_S lambda_h^+ (g - [u_h nu])^+ and the penetration
    c_T / h_S ||([u_h nu] - g)^+||_S^2 of a side held by several obstacles (``group``: {pair index: its
    :func:`_pair_fields`}), on each segment S of the side's trace that one of their runs holds, once (as
    :func:`_side_gap_terms` on a surface): lambda_h the pairs' functions summed (the side's, as the contact traction
    reads it), g - [u_h nu] at each node of the trace the least over the pairs reaching it (the nearest obstacle's;
    a run is contiguous, vertex to vertex, so every node of a segment read is reached by the run holding it, and
    the 0 at a node none reaches is never read); by the estimate's 3-point rule; ``located``: the side's faces, as :func:`_segment_owners` reads
    them. Pair by pair, the discrete space's forced split of lambda_h between the pairs was charged on an open
    pair's gap (docs/accuracy.md, "Several pairs on one part")."""
    first = next(iter(group))
    trace = group[first][0].trace                                       # the space's trace (P1, P2)
    xs = np.asarray(sol._pair_line(first).traces[0].x, dtype=float)    # the side's trace: its nodes' s (m)
    gap = np.full(len(xs), np.inf)
    segments = []
    for c, *_ in group.values():
        x = np.asarray(c.x, dtype=float)
        at = np.clip(np.searchsorted(xs, x), 1, len(xs) - 1)
        at -= (x - xs[at - 1]) < (xs[at] - x)                           # the trace's node at each of its nodes
        own = (np.zeros(len(x)) if c.gap is None else np.asarray(c.gap, dtype=float)) - np.asarray(c.jump, float)
        np.minimum.at(gap, at, own)
        segments.append(np.arange(at[0] // trace.step, at[-1] // trace.step))   # its run's segments
    gap = np.where(np.isfinite(gap), gap, 0.0)
    seg = np.unique(np.concatenate(segments))
    xv = trace.vertices(xs)
    a, hS = xv[seg], xv[seg + 1] - xv[seg]
    comp = np.zeros(len(a))
    pen = np.zeros(len(a))
    for tq, w in zip(*_GAUSS3):
        s = a + tq * hS
        lam = sum(_line_at(c, x_line, lam_i, s) for c, _, x_line, lam_i, _, _ in group.values())
        g = trace.values(xs, gap, s)
        comp += w * np.maximum(lam, 0.0) * np.maximum(g, 0.0)
        pen += w * np.maximum(-g, 0.0) ** 2
    _share(_segment_owners(located, a + 0.5 * hS),
           {"complementarity": (comp * hS, 0), "penetration": (pen, 1)}, data, eta2, parts)


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


def surface_contact_terms(sol, data, cache, eta2, parts, signorini=True):
    """3D: on each side (body, contact part) h_F ||sigma_h n + sum_i (lambda_i n - t_i)||_F^2 / c_T on its faces F,
    the sum over the pairs i that hold the part (one, or several obstacles each reaching part of it), as
    int_F |sigma_h n|^2 (once) + over the elements S of each pair's X_h int_S (2 lambda_i sigma_nn + lambda_i^2)
    (lambda_i a P1 (P2) function on the S, 0 beyond them; each S lies in one face of each side, found by
    :func:`~cvxcontact.contact.overlay.locate` in the plane) + the cross terms between the pairs
    (:func:`_cross_terms`); a friction law's t_i (the first body's, -t_i on the second) adds
    int_S (|t_i|^2 - 2 t_i . (sigma_h n + lambda_i n)). On each S of a Signorini pair the complementarity and the
    penetration (and the friction terms: of the fields summed over the pairs that share its first side,
    :func:`_shared_friction`), shared by the cells of the sides that hold its centroid."""
    Lq, wq = simplex_rule(2, 4)                       # lambda^2 of P2: degree 4
    pairs = [_pair_fields3d(sol, i, cache) for i in range(len(sol.contacts))]
    holders = held_sides(sol.scene.stack)             # per side (k, part): [(pair, its side)]
    held = {key: [pairs[i]["sides"][slot] for i, slot in on] for key, on in holders.items()}   # its [_PairSide]
    last = {key: on[-1][0] for key, on in holders.items()}                                    # its last pair
    acc = {}                                          # per side: int_F |R_F|^2 of its faces
    sided = _gap_sides(sol, holders, signorini)   # sides whose complementarity is read once (_side_gap_terms)
    for i, (c, pr) in enumerate(zip(sol.contacts, pairs)):
        itf, fr = pr["itf"], pr["fr"]
        elements, corners, hosts = pr["elements"], pr["corners"], pr["hosts"]
        open_ = pr["open"]
        lam = pr["lam"][elements]
        N = Lq if elements.shape[1] == 3 else shape_functions(Lq)                          # (q, 3 | 6)
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
        for side, (ps, host) in enumerate(zip(pr["sides"], hosts)):
            linear, k, key = ps.trace, ps.key[0], ps.key
            on = cache[k].side(linear.part)
            cell, normals = on.cell, on.normals
            if key not in acc:
                acc[key] = on.squares()                                 # int_F |sigma_h n|^2 of each face, once
            if host is None:                                            # S not matched to the faces: find them
                face, Lf = locate(xq, linear.x, linear.faces)
                fc = locate(corners.mean(axis=1), linear.x, linear.faces)[0]
            else:
                face = np.repeat(host, len(wq))
                Lf = barycentric(xq, np.asarray(linear.x)[np.asarray(linear.faces)[face]])
                fc = host
            ok = np.flatnonzero(face >= 0)
            s = on.traction(face[ok], Lf[ok])                           # at the points of the trace's triangles
            fq = on.face_of(face[ok])
            lq = lam.ravel()[ok]
            R2 = 2 * lq * (s * normals[fq]).sum(axis=1) + lq ** 2
            if tan is not None:                                     # the first body's t_h, the other's -t_h
                tq = ps.sign * tan[ok]
                R2 += ((tq - 2 * s - 2 * lq[:, None] * normals[fq]) * tq).sum(axis=1)
            np.add.at(acc[key], fq, wts[ok] * R2)
            if len(held[key]) > 1:                                     # kept for the cross terms, shared friction
                ps.points(face, Lf, fq, wts, ok, N, elements)
            for other in held[key][:held[key].index(ps)]:            # the cross terms with the part's pairs
                _cross_terms(acc[key], normals, ps, other)
            if last[key] == i:                                         # the side's last pair: its term
                term = on.hF * acc[key] / data[k][0]
                np.add.at(eta2[k], cell, term)
                parts["contact traction"] += float(term.sum())
            owners.append((k, np.where(fc >= 0, cell[on.face_of(np.maximum(fc, 0))], -1)))
            del face, Lf, ok, s, fq, lq, R2                            # this side's points: not held into the next
        if not signorini or (c.law is not None and getattr(c.law, "compliant", False)):
            continue                                                   # compliance: penetration is the law
        comp = areaS * (wq * np.maximum(lam, 0.0) * np.maximum(open_, 0.0)).sum(axis=1)
        pen = areaS * (wq * np.maximum(-open_, 0.0) ** 2).sum(axis=1)
        hS = np.max([np.linalg.norm(corners[:, a] - corners[:, b], axis=1) for a, b in ((0, 1), (1, 2), (2, 0))], axis=0)
        terms = {"complementarity": (comp, 0), "penetration": (pen / hS, 1)}
        if pr["sides"][0].key in sided:              # obstacles sharing the part: read on the side, once
            terms = {}
            if last[pr["sides"][0].key] == i:
                _share(*_side_gap_terms([pairs[j] for j in sided[pr["sides"][0].key]], cache, N, wq), data, eta2,
                       parts)
        if tan is not None:                                            # a friction law (:mod:`.slipestimate`)
            first = pr["sides"][0]
            if len(held[first.key]) == 1:
                cone, slides = slip.friction_elements(fr, elements, N, areaS[:, None] * wq[None, :])
            else:
                cone, slides = _shared_friction(first, held[first.key], len(elements), len(wq))
            terms.update({"friction cone": (hS * cone, -1), "slip complementarity": (slides, 0)})
        _share(owners, terms, data, eta2, parts)


def _gap_sides(sol, holders, signorini) -> dict:
    """{side key: [pair indices]}: the sides (body, part) held by several pairs (``holders``: each side's
    [(pair, its side)], :func:`~cvxcontact.contact.sides.held_sides`), every one a Signorini pair against an
    obstacle, whose complementarity and penetration are read once on the side (2D :func:`_side_line_terms`, 3D
    :func:`_side_gap_terms`)."""
    if not signorini:
        return {}
    return {key: [i for i, _ in on] for key, on in holders.items() if len(on) > 1
            and all(sol.scene.interfaces[i].rigid and not getattr(sol.contacts[i].law, "compliant", False)
                    for i, _ in on)}


def _side_gap_terms(group, cache, N, wq):
    """(owners, terms) of :func:`_share`: the complementarity int_S lambda_h^+ (g - [u_h nu])^+ and the penetration
    c_T / h_S ||([u_h nu] - g)^+||_S^2 of a side held by several obstacles (``group``: their
    :func:`_pair_fields3d`), on each face S of the side that one of them holds, once: lambda_h the pairs' functions
    summed (the side's, :mod:`~cvxcontact.solution.sides`), g - [u_h nu] at each node of the trace the least over
    the pairs reaching it (the nearest obstacle's; 0 at a node none reaches, as each pair's function is 0 beyond its
    reach); by the rule of shape values ``N`` (q, 3 | 6) and weights ``wq`` (q,) on each face. Each pair's of its
    own functions on the faces a cut crosses read neither (docs/accuracy.md)."""
    side, trace = group[0]["sides"][0], group[0]["itf"].traces[0]
    faces = np.asarray(trace.faces)                                      # (f, 3 | 6) the trace's nodes
    lam, gap = np.zeros(len(trace.nodes)), np.full(len(trace.nodes), np.inf)
    held = []
    for pr in group:
        elements, face = pr["elements"], pr["hosts"][0]
        on = elements >= 0
        nodes = faces[face][on]
        mine = np.zeros(len(lam))
        mine[nodes] = pr["lam"][elements[on]]
        lam += mine
        np.minimum.at(gap, nodes, pr["open"][on])
        held.append(face)
    held = np.unique(np.concatenate(held))
    gap = np.where(np.isfinite(gap), gap, 0.0)
    lq, oq = lam[faces[held]] @ N.T, gap[faces[held]] @ N.T                                  # (e, q)
    corners = np.asarray(side.trace.x)[faces[held][:, :3]]
    d1, d2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    hS = np.max([np.linalg.norm(corners[:, a] - corners[:, b], axis=1) for a, b in ((0, 1), (1, 2), (2, 0))], axis=0)
    comp = area * (wq * np.maximum(lq, 0.0) * np.maximum(oq, 0.0)).sum(axis=1)
    pen = area * (wq * np.maximum(-oq, 0.0) ** 2).sum(axis=1)
    on = cache[side.key[0]].side(side.trace.part)
    return [(side.key[0], on.cell[on.face_of(held)])], {"complementarity": (comp, 0), "penetration": (pen / hS, 1)}


def _pair_fields3d(sol, i, cache) -> dict:
    """Pair ``i`` of a 3D ``sol`` as the contact terms read it: its line ``itf``, the elements of X_h
    (``elements``, ``corners``, ``hosts``: :meth:`elements`), g - [u_nu] (``open``) and lambda_h (``lam``) at their
    nodes (last: 0), a friction law's ``fr`` (or None) and a :class:`_PairSide` per side (``sides``)."""
    c, itf = sol.contacts[i], sol._pair_line(i)
    elements, corners, hosts = itf.elements()     # (e, 3 | 6) nodes of X_h (-1: outside it), (e, 3, 2) m
    gap = np.zeros(len(c.lam)) if c.gap is None else np.asarray(c.gap, dtype=float)
    open_ = np.append(gap - np.asarray(c.jump, dtype=float), 0.0)[elements]              # g - [u_nu] at their nodes
    keys = pair_sides(sol.scene.stack, i)                               # its sides (k, part), first body's first
    k0, part0 = keys[0]
    lam = np.append(cache[k0].multiplier(c, part0), 0.0)
    fr = slip.friction_of(sol, i)                                      # a friction law's t_h, else None
    nodal = {"lam": lam}
    if fr is not None:
        fr = cache[k0].friction(fr, c, part0)
        frames = row_frames(itf)
        nodal.update(t=slip.nodal_vectors(fr.t, frames), s=slip.nodal_vectors(fr.s, frames),
                     r=slip.nodal_vectors(fr.r, frames), g=np.append(np.asarray(fr.g, dtype=float), 0.0))
    sides = []
    for side, (trace, key) in enumerate(zip(itf.traces, keys)):
        linear = getattr(trace, "linear", trace)                      # P2: its P1 trace (the same faces)
        sign = 1 - 2 * side                                            # the first body's t_h, the other's -t_h
        signed = {name: sign * v if name in _SIGNED else v for name, v in nodal.items()}
        sides.append(_PairSide(key, linear, sign, elements, corners, signed))
    return {"itf": itf, "elements": elements, "corners": corners, "hosts": hosts, "open": open_, "lam": lam,
            "fr": fr, "sides": sides}


_SIGNED = ("t", "s", "r")
"""The tangential fields a pair's second body reads with the opposite sign (t_h, the slip, t_r)."""


class _PairSide:
    """What one pair puts on one side ``key`` (body k, contact part): its P1 ``trace`` there, the ``sign`` of its
    tangential fields there (the first body +1, the second -1), the elements of X_h (nodes ``elements``
    (e, 3 | 6), -1 outside; in-plane ``corners`` (e, 3, 2) m) and the ``nodal`` values at the nodes of X_h (last
    row 0): lambda_h "lam" (Pa), a friction law's t_h, the slip and t_r as vectors "t", "s", "r" (times
    ``sign``) and g_h "g"; after :meth:`points`, its rule's points on the side."""

    def __init__(self, key, trace, sign, elements, corners, nodal):
        self.key, self.trace, self.sign = key, trace, sign
        self.elements, self.corners, self.nodal = elements, corners, nodal

    def points(self, face, Lf, fq, w, ok, N, live):
        """Keep the rule's points on the live elements of X_h ``live`` (e, 3 | 6) (shape values ``N``
        (q, 3 | 6)): the trace's faces ``face`` (-1: none) and barycentric coordinates ``Lf`` (e q, 3) there, the
        weights ``w`` (e q,) m^2, the side's faces ``fq`` of those in ``ok``."""
        self.all_face, self.all_Lf, self.all_w, self.rule = face, Lf, w, (N, live)
        self.face, self.Lf, self.fq, self.w = face[ok], Lf[ok], fq, w[ok]

    def read(self, face, Lf) -> tuple[np.ndarray, np.ndarray]:
        """(shape values (p, 3 | 6), nodes of X_h (p, 3 | 6), -1 beyond its elements) at the points of
        barycentric coordinates ``Lf`` (p, 3) on the faces ``face`` (p,) of its trace (-1: none)."""
        faces = np.asarray(self.trace.faces)[np.maximum(face, 0)][:, :3]
        x = np.einsum("pv,pvd->pd", Lf, np.asarray(self.trace.x)[faces])
        S, L = locate(x, self.corners.reshape(-1, 2), np.arange(3 * len(self.corners)).reshape(-1, 3))
        inside = (S >= 0) & (face >= 0)
        N = L if self.elements.shape[1] == 3 else shape_functions(L)
        return N, np.where(inside[:, None], self.elements[np.maximum(S, 0)], -1)

    def value(self, name, N, nodes) -> np.ndarray:
        """(p, ...) the nodal field ``name`` at points read by :meth:`read`."""
        return np.einsum("pk,pk...->p...", N, self.nodal[name][nodes])

    def traction(self, face, Lf, normals) -> np.ndarray:
        """(p, 3) lambda_h n - t_h (Pa) at points of barycentric coordinates ``Lf`` on the faces ``face`` of its
        trace (``normals`` (p, 3) the side's there); 0 beyond its elements."""
        N, nodes = self.read(face, Lf)
        out = self.value("lam", N, nodes)[:, None] * normals
        return out - self.value("t", N, nodes) if "t" in self.nodal else out


def _cross_terms(acc, normals, a, b):
    """Add to ``acc`` (k,) of the side's faces the cross terms 2 int_F (lambda_a n - t_a) . (lambda_b n - t_b) of
    two pairs :class:`_PairSide` ``a``, ``b`` on one side, by the rule on the elements of the pair with more
    points there, the other's function read at those points: exact where each element of the one lies in one
    element of the other or outside them all (obstacles: the faces themselves; disjoint supports: 0). Read only
    on the faces that hold points of both (the other's live elements each lie in one of its faces ``fq``, its
    function 0 elsewhere): the pairs of a part's many pairs that do not meet cost nothing."""
    if len(b.w) > len(a.w):
        a, b = b, a
    keep = np.flatnonzero(np.isin(a.fq, b.fq))
    if not len(keep):
        return
    fq, face, Lf, n = a.fq[keep], a.face[keep], a.Lf[keep], normals[a.fq[keep]]
    np.add.at(acc, fq, 2 * a.w[keep] * (a.traction(face, Lf, n) * b.traction(face, Lf, n)).sum(axis=1))


def _shared_friction(mine, held, e, q) -> tuple[np.ndarray, np.ndarray]:
    """3D: the friction cone and slip complementarity integrals (as
    :func:`~cvxcontact.solution.slipestimate.friction_elements`) on the e live elements of X_h (q rule points
    each) of the pair whose first side is the :class:`_PairSide` ``mine``, of t_h, g_h, the slip and t_r summed
    over the pairs ``held`` that share that side (its own included), each point weighed 1 / (the number of those
    pairs whose elements hold it): the union of their supports counted once (obstacles each reaching part of
    the part: the law of the whole part). Another pair is read only at the points within its elements' radius
    of their bounding box (the only points :func:`~cvxcontact.contact.overlay.locate` can find in one: its
    candidates lie within that radius of a centroid; each point is located alone): it adds 0 at the others, so
    the pairs of a part's many pairs that do not meet cost a comparison of coordinates, not a search."""
    def placed(values, at):                                         # at the rows ``at`` (a slice: all), 0 elsewhere
        if isinstance(at, slice):
            return values
        out = np.zeros((len(count),) + values.shape[1:])
        out[at] = values
        return out

    fields = {name: 0.0 for name in "tgsr"}
    count = np.zeros(len(mine.all_face))
    faces = np.asarray(mine.trace.faces)[np.maximum(mine.all_face, 0)][:, :3]
    x = np.einsum("pv,pvd->pd", mine.all_Lf, np.asarray(mine.trace.x)[faces])       # its points in the plane
    for ps in held:
        if "t" not in ps.nodal:                                      # a frictionless pair: no t_h, no slip law
            continue
        if ps is mine:                                              # its own points: the rule on its elements
            N, live = mine.rule
            N, nodes = np.tile(N, (len(live), 1)), np.repeat(live, len(N), axis=0)
            at = slice(None)
        else:
            corners = ps.corners.reshape(-1, 2)
            centred = ps.corners - ps.corners.mean(axis=1, keepdims=True)
            reach = 1.001 * np.linalg.norm(centred, axis=2).max(initial=0.0)
            at = np.flatnonzero((mine.all_face >= 0) & (x >= corners.min(axis=0, initial=np.inf) - reach).all(axis=1)
                                & (x <= corners.max(axis=0, initial=-np.inf) + reach).all(axis=1))
            if not len(at):
                continue
            N, nodes = ps.read(mine.all_face[at], mine.all_Lf[at])
        count[at] += (nodes >= 0).any(axis=1)
        fields = {name: v + placed(ps.value(name, N, nodes), at) for name, v in fields.items()}
    cone, slides = slip.friction_points(fields["t"], fields["g"], fields["s"], fields["r"])
    w = (mine.all_w / np.maximum(count, 1)).reshape(e, q)
    return (w * cone.reshape(e, q)).sum(axis=1), (w * slides.reshape(e, q)).sum(axis=1)
