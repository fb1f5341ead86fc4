"""Planar contact surfaces with P2 (10-node) tetrahedra: both traces quadratic on every overlay triangle, X_h the
continuous piecewise quadratics on the overlay (docs/formulation.md §15).

Each body's trace on its planar part is a continuous P2 function on its own faces (6-node triangles: vertices
and edge midpoints, :class:`~cvxcontact.geometry.quadratic.P2TetNodes`). The overlay of the two P1 face
triangulations (:mod:`cvxcontact.contact.overlay`; the P2 faces are the same straight triangles) cuts the
overlap into triangles on each of which both traces are quadratic, so the jump [u_nu] lies in

    X_h = continuous piecewise quadratics on the overlay triangles

whose nodes are the overlay vertices (first, in the overlay's order) and the midpoints of the overlay edges.
The jump at those nodes is an evaluation of each trace (exact); a nodal condition at other points of the
overlap (the P2 nodes of one body's faces, "sigma1"/"sigma2") is the P2 interpolation of X_h there (exact, since
[u_nu] is in X_h). lambda_h is the Riesz representer in X_h of the row forces: M lambda_h = E^T y with M the P2
mass matrix of the overlay.

Against a rigid obstacle X_h is the body's own P2 trace on its nodes that reach the obstacle, and every
condition constrains every one of them (as for P1); on faces the obstacle reaches only in part a compliance law sits
on the reaching nodes themselves (:meth:`QuadraticSurface._partial_weights`, every node positive).

A normal-compliance law is integrated by a quadrature of positive weights on the constrained triangles
(:meth:`QuadraticSurface.quadrature`: the 6-point rule of degree 4, :data:`P2_FACE_RULE`, at whose points the
law's rows evaluate [u_nu]); the integrals of the P2 basis functions (:meth:`QuadraticSurface.weights`) are 0 at
the vertices and A/3 at the edge midpoints, so a nodal quadrature would let a vertex penetrate for free
(docs/formulation.md §15, "Normal compliance"). Under "sigma1"/"sigma2" on a face the overlap's edge cuts, the
law sits on the rows themselves, weighted by the red refinement's hats integrated over the overlap
(:meth:`QuadraticSurface._cut_weights`, positive).
"""

from __future__ import annotations

from copy import copy

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from scipy.spatial import cKDTree

from ..errors import SceneError
from .bernstein import bernstein_map
from .interface import CONDITIONS, normal_jump, read_only, row_directions, row_frames, shares_to_nearest
from .overlay import barycentric, locate, overlay  # noqa: F401  (locate: re-exported)
from .riesz import Represented, TraceRiesz
from .surface import reached_faces

__all__ = ["QuadraticSurface", "P2_TRIANGLE_MASS", "P2_FACE_RULE", "RED_SUBTRIANGLES", "p2_shape", "p2_triangle_nodes",
           "p2_weights", "red_mass", "red_weights", "locate"]

P2_TRIANGLE_MASS = np.array([[6, -1, -1, 0, -4, 0],
                             [-1, 6, -1, 0, 0, -4],
                             [-1, -1, 6, -4, 0, 0],
                             [0, 0, -4, 32, 16, 16],
                             [-4, 0, 0, 16, 32, 16],
                             [0, -4, 0, 16, 16, 32]]) / 180.0
"""The P2 mass matrix of a triangle of unit area in the triangle6 order (v0, v1, v2, m01, m12, m20)."""


def _face_rule():
    a, b = 0.445948490915965, 0.091576213509771
    L = np.array([[1 - 2 * a, a, a], [a, 1 - 2 * a, a], [a, a, 1 - 2 * a],
                  [1 - 2 * b, b, b], [b, 1 - 2 * b, b], [b, b, 1 - 2 * b]])
    w = np.array([0.223381589678011] * 3 + [0.109951743655322] * 3)
    L.setflags(write=False), w.setflags(write=False)
    return L, w


P2_FACE_RULE = _face_rule()
"""(L (6, 3), w (6,)): the 6-point rule of degree 4 on a triangle (Strang and Fix; Dunavant's degree-4 rule) in
barycentric coordinates, its weights positive and summing to 1 (to 1e-15; times the area: m^2), its points inside; exact for
the energy k/2 r^2 of a linear law and the forces p(r) N_i of a quadratic penetration r on a triangle in contact.
Tabulated to 15 decimals (their closed forms a, b = (8 - sqrt 10 +- sqrt(38 - 44 sqrt(2/5))) / 18,
w = (620 +- sqrt(213125 - 53320 sqrt 10)) / 3720); the P2 volume loads of fem/p2.py take the same rule."""



def p2_shape(L) -> np.ndarray:
    """(k, 6): the triangle6 shape functions (v0, v1, v2, m01, m12, m20) at barycentric coordinates L (k, 3):
    L_i (2 L_i - 1) at the vertices, 4 L_i L_j at the edge midpoints."""
    L = np.asarray(L, dtype=float)
    return np.column_stack([L * (2 * L - 1), 4 * L[:, 0] * L[:, 1], 4 * L[:, 1] * L[:, 2], 4 * L[:, 2] * L[:, 0]])


def p2_triangle_nodes(triangles, n_vertices) -> tuple[np.ndarray, np.ndarray]:
    """(cells (c, 6), edges (e, 2)): the triangle6 node indices of ``triangles`` (c, 3) on vertices numbered
    0 .. n_vertices - 1, the edge midpoints numbered n_vertices + e by sorted vertex pair."""
    tri = np.asarray(triangles, dtype=np.int64)
    pairs = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1), axis=2)
    keys = pairs[..., 0] * max(n_vertices, 1) + pairs[..., 1]
    unique, inverse = np.unique(keys.ravel(), return_inverse=True)
    edges = np.column_stack([unique // max(n_vertices, 1), unique % max(n_vertices, 1)])
    return np.column_stack([tri, n_vertices + inverse.reshape(-1, 3)]), edges


def p2_weights(cells, area, n) -> np.ndarray:
    """(n,): the integrals (m^2) of the continuous P2 basis functions of the triangles ``cells`` (c, 6) of
    ``area`` (c,) m^2: a triangle6 vertex function integrates to 0, an edge function to A/3 (the row sums of
    :data:`P2_TRIANGLE_MASS`). The quadrature on the nodes exact for quadratics (the only one: the integrals of
    the interpolant), with non-negative weights; the vertices carry none."""
    return np.bincount(np.asarray(cells)[:, 3:].ravel(), weights=np.repeat(np.asarray(area) / 3.0, 3), minlength=n)


RED_SUBTRIANGLES = np.array([[0, 3, 5], [1, 4, 3], [2, 5, 4], [3, 4, 5]])
"""The red refinement of a triangle6 (v0, v1, v2, m01, m12, m20): its four triangles of a quarter of its area."""


def red_mass(cells, area, n) -> sp.csr_matrix:
    """(n, n): the P1 mass matrix (m^2) of the red refinement of the triangles ``cells`` (c, 6) of ``area`` (c,)
    m^2 (:data:`RED_SUBTRIANGLES`, each of area A/4): its row sums are :func:`red_weights`, positive."""
    sub = np.asarray(cells)[:, RED_SUBTRIANGLES].reshape(-1, 3)
    local = (np.ones((3, 3)) + np.eye(3)) / 12.0
    vals = (np.repeat(np.asarray(area, dtype=float) / 4.0, 4)[:, None, None] * local).ravel()
    return sp.csr_matrix((vals, (np.repeat(sub, 3, axis=1).ravel(), np.tile(sub, (1, 3)).ravel())), shape=(n, n))


def red_weights(cells, area, n) -> np.ndarray:
    """(n,): the lumped P1 mass (m^2) of the red refinement of the triangles ``cells`` (c, 6) of ``area`` (c,) m^2:
    A/12 at each vertex of a triangle, A/4 at each edge midpoint (three sub-triangles), summing to A. A positive
    nodal rule exact for linear functions (the trapezoidal rule on the sub-triangles); the only nodal rule exact
    for quadratics, :func:`p2_weights`, gives the vertices 0."""
    share = np.tile([1.0 / 12] * 3 + [1.0 / 4] * 3, len(cells)) * np.repeat(np.asarray(area, dtype=float), 6)
    return np.bincount(np.asarray(cells).ravel(), weights=share, minlength=n)


def _p2_rows(L, cells, n_cols) -> sp.csr_matrix:
    """(k, n_cols): the P2 functions with node columns ``cells`` (k, 6) evaluated at barycentric L (k, 3)."""
    vals = p2_shape(L)
    vals[np.abs(vals) < 1e-15] = 0.0                            # rounding of exact zeros
    rows = np.repeat(np.arange(len(L)), 6)
    M = sp.csr_matrix((vals.ravel(), (rows, cells.ravel())), shape=(len(L), n_cols))
    M.eliminate_zeros()
    return M


def p2_mass(cells, area, n) -> sp.csr_matrix:
    """(n, n) P2 mass matrix (m^2) of triangles with node indices ``cells`` (c, 6) and ``area`` (c,) m^2."""
    rows = np.repeat(cells, 6, axis=1).ravel()
    cols = np.tile(cells, (1, 6)).ravel()
    vals = (area[:, None, None] * P2_TRIANGLE_MASS[None]).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


def _area(P) -> np.ndarray:
    d1, d2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


class _Trace6:
    """The P2 trace of one body on its planar part: ``faces`` (k, 6) local indices into ``nodes`` (the body's
    P2 node indices on the part, sorted), ``x`` (n, 2) in-plane coordinates (m), ``points`` (n, 3),
    ``unit_normal``/``normal``, ``offset``, ``frame``, ``mass`` (n, n) its P2 mass matrix (m^2), ``k``,
    ``part``, ``body``, and ``linear`` the P1 :class:`~cvxcontact.contact.surface.SurfaceTrace`."""

    def __init__(self, linear, nodes):
        faces6 = np.asarray(nodes.boundary(linear.part))
        own = np.unique(faces6)
        self.linear = linear
        self.nodes = read_only(own)
        self.faces = read_only(np.searchsorted(own, faces6))
        self.points = read_only(np.asarray(nodes.points, dtype=float)[own])
        self.unit_normal = self.normal = linear.unit_normal
        self.offset, self.frame = linear.offset, linear.frame
        self.x = read_only(self.points @ np.asarray(linear.frame).T)
        self.k, self.part, self.body = linear.k, linear.part, linear.body
        self.mass = p2_mass(self.faces, _area(self.x[self.faces[:, :3]]), len(own)).tocsr()


class QuadraticSurface(Represented):
    """One contact pair of planar surfaces with P2 traces (module docstring): the 3D counterpart of
    :class:`~cvxcontact.contact.quadratic.QuadraticInterface`, with the same protocol (``size``, ``x``,
    ``points``, ``normal``, ``frame``, ``offset``, ``traces``, ``mass``, ``jump(k, n)`` by the scene's body
    index, ``interpolation(k)``, ``evaluation``, ``pressure``, ``rigid``, ``dim``).

    ``QuadraticSurface(linear, nodes, members)``: ``linear`` the pair's P1
    :class:`~cvxcontact.contact.surface.SurfaceInterface` (it has checked planarity, the normals and the
    overlap, and holds the overlay), ``nodes`` the :class:`~cvxcontact.geometry.quadratic.P2TetNodes` of its
    bodies, ``members`` their indices among the scene's bodies ((k, None) with a rigid obstacle).
    ``cells`` (c, 6) are the triangle6 node indices of X_h on each overlay triangle (two bodies) or on each
    face of the body's trace whose six nodes all reach the obstacle.
    """

    degree, dim = 2, 3
    _partial = False  # an obstacle reaching the part only in part: lambda_h read back by _partial_mass (multiplier)

    def __init__(self, linear, nodes, members=(0, 1)):
        nodes, members = tuple(nodes), tuple(members)
        if len(nodes) != len(linear.traces):
            raise SceneError(f"the P2 contact surface needs the P2 nodes of each of its {len(linear.traces)} "
                             f"bodies, got {len(nodes)}")
        self.linear, self.members = linear, members
        self.rigid, self.obstacle = linear.rigid, linear.obstacle
        self.normal, self.frame, self.offset = linear.normal, linear.frame, linear.offset
        self.traces = [_Trace6(t, n) for t, n in zip(linear.traces, nodes)]
        self._factors = {}
        if self.rigid:
            self._rigid()
        else:
            self._overlay()
        self.points = read_only(self.offset * np.asarray(self.normal) + self.x @ np.asarray(self.frame))

    def _overlay(self):
        ov = self.linear.overlay
        nv = len(ov.vertices)
        cells, edges = p2_triangle_nodes(ov.triangles, nv)
        V = np.asarray(ov.vertices)
        self.x = read_only(np.concatenate([V, 0.5 * (V[edges[:, 0]] + V[edges[:, 1]])]))
        self.cells = read_only(cells)
        self.mass = p2_mass(cells, _area(V[ov.triangles]), self.size).tocsr()
        # each node of X_h in one overlay triangle t that has it; its value on body l from l's face cell_l[t]
        host = np.full(self.size, -1)
        position = np.zeros(self.size, dtype=int)
        host[cells.ravel()] = np.repeat(np.arange(len(cells)), 6)
        position[cells.ravel()] = np.tile(np.arange(6), len(cells))
        self._interp = []
        for t, cell in zip(self.traces, (ov.cell_a, ov.cell_b)):
            face = t.faces[np.asarray(cell)[host]]                      # (size, 6)
            L = barycentric(self.x, t.x[face[:, :3]])
            self._interp.append(_p2_rows(np.clip(L, 0.0, None) / np.clip(L, 0.0, None).sum(axis=1)[:, None],
                                         face, len(t.nodes)))
        # the P2 nodes of each body's faces inside the overlap, located in the overlay triangles
        self._sigma = []
        for t in self.traces:
            tri, L = locate(t.x, V, np.asarray(ov.triangles))
            inside = np.flatnonzero(tri >= 0)
            self._sigma.append((read_only(inside), _p2_rows(L[inside], cells[tri[inside]], self.size)))

    def _rigid(self):
        t = self.traces[0]
        d = np.asarray(self.obstacle.distance(t.points, t.unit_normal), dtype=float)
        label = f"{t.body.name}: contact part {t.part!r} against {self.obstacle!r}"
        if d.shape != (len(t.nodes),) or np.isnan(d).any() or (d == -np.inf).any():
            raise SceneError(f"{label}: the obstacle's distance is not a finite number or +inf at every P2 node")
        hit = np.flatnonzero(np.isfinite(d))
        if len(hit) == 0:
            raise SceneError(f"{label}: the obstacle cannot be reached along the part's outward normal from any node")
        self._reach(hit)

    def _reach(self, hit):
        """X_h on the trace nodes ``hit`` (indices): the pair's nodes, whole faces, mass and selection."""
        t = self.traces[0]
        at = np.full(len(t.nodes), -1)
        at[hit] = np.arange(len(hit))
        whole = (at[t.faces] >= 0).all(axis=1)
        self.reach = read_only(hit)
        self.x = read_only(t.x[hit])
        self.cells = read_only(at[t.faces[whole]])
        self.mass = t.mass[hit][:, hit].tocsr()
        self._partial = len(hit) < len(t.nodes)          # lambda_h read back by _partial_mass (multiplier)
        self._interp = [sp.csr_matrix((np.ones(len(hit)), (np.arange(len(hit)), hit)), shape=(len(hit), len(t.nodes)))]

    def reaching(self, reached) -> QuadraticSurface:
        """A copy of this obstacle pair whose X_h is the trace nodes ``reached`` (bool per P2 node of its trace):
        the space in which lambda_h of several obstacles on one part is read once, from their forces summed
        (:mod:`cvxcontact.solution.sides`). Its :meth:`multiplier` and :meth:`interpolation` only."""
        out = copy(self)
        out.__dict__.pop("_row_directions", None)
        out._factors = {}
        out._reach(np.flatnonzero(reached))
        return out

    def riesz_parts(self):
        """(the traces' interpolations, the mass of X_h): what a two-body pair reads lambda_h from
        (:class:`~cvxcontact.contact.riesz.TraceRiesz`); None with an obstacle or a representer of its own."""
        return None if self.rigid or self.representer is not None else (self._interp, self.mass)

    def _partial_mass(self) -> sp.csr_matrix:
        """(size, size) m^2: against an obstacle that reaches the part only in part, the matrix lambda_h is read back
        by (:meth:`multiplier`; docs/formulation.md §15): the P2 mass of the body's faces on the reaching nodes, each
        one's coupling to the nodes the obstacle misses lumped onto its diagonal, so that its row sums are the
        consistent loads of a uniform pressure over the whole part (0 at a vertex, A/3 per face at an edge midpoint)
        and a uniform pressure reads as itself at every row, the total force kept by those loads. Face by face that
        matrix is positive semi-definite (a whole face's definite), its null vectors constant on the face's reaching
        vertices (their consistent load is 0) and 0 at its midpoints, so only vertices on no wholly reached face (lone
        vertices) can make it singular. Each lone vertex is therefore tied to each reaching edge midpoint next to it
        on a face, (A/24)(e_v - e_m)(e_v - e_m)^T (the share the law's red hat moves to it, :meth:`_partial_weights`;
        a constant is not changed), and a lone vertex with no such midpoint takes its red hat's A/12 per face on its
        diagonal (the law's weight: there a uniform pressure is not read exactly). Positive definite."""
        t, hit = self.traces[0], np.asarray(self.reach)
        at = np.full(len(t.nodes), -1)
        at[hit] = np.arange(len(hit))
        miss = np.flatnonzero(at < 0)
        full = t.mass.tocsr()
        lumped = np.asarray(full[hit][:, miss].sum(axis=1)).ravel()
        faces, _, _, part, lone = self._reached_faces()
        local = at[faces]                                               # (f, 6) row of each node, -1 if it misses
        lone = lone[hit]                                                # a reaching vertex on no whole face
        area = _area(t.x[faces[:, :3]])
        # (vertex, midpoint) next to each other on a partial face: m01, m20 at v0; m01, m12 at v1; m12, m20 at v2
        v = local[part][:, [0, 0, 1, 1, 2, 2]].ravel()
        m = local[part][:, [3, 5, 3, 4, 4, 5]].ravel()
        w = np.repeat(area[part] / 24.0, 6)
        keep = (v >= 0) & (m >= 0)
        keep[keep] = lone[v[keep]]
        v, m, w = v[keep], m[keep], w[keep]
        n = len(hit)
        ij = (np.concatenate([v, m, v, m]), np.concatenate([v, m, m, v]))
        tie = sp.csr_matrix((np.concatenate([w, w, -w, -w]), ij), shape=(n, n))
        corner = local[part, :3].ravel()
        on = corner >= 0
        red = np.bincount(corner[on], weights=np.repeat(area[part] / 12.0, 3)[on], minlength=n)
        untied = lone.copy()
        untied[v] = False
        return (self.mass + sp.diags(lumped + np.where(untied, red, 0.0)) + tie).tocsr()

    @property
    def size(self) -> int:
        """Number of nodes of X_h."""
        return len(self.x)

    @property
    def segments(self) -> np.ndarray:
        """The elements of X_h, ``cells`` (c, 6) (the name the stacked contact lines share with 2D)."""
        return self.cells

    @property
    def area(self) -> float:
        """Area (m^2) of the overlap (with an obstacle, of the faces all of whose P2 nodes reach it)."""
        return float(_area(self.x[self.cells[:, :3]]).sum())

    def elements(self) -> tuple[np.ndarray, np.ndarray, list]:
        """The triangles on which a function of X_h (lambda_h, the jump) is quadratic: (triangle6 nodes (e, 6)
        of X_h, -1 for a node outside it where the function is 0; vertices (e, 3, 2) in-plane, m; per side the
        face of its trace that holds each). Two bodies: ``cells`` (the overlay's triangles); with an obstacle:
        the body's faces with a P2 node that reaches it."""
        if not self.rigid:
            ov = self.linear.overlay
            return (np.asarray(self.cells), np.asarray(self.x)[np.asarray(self.cells)[:, :3]],
                    [np.asarray(ov.cell_a), np.asarray(ov.cell_b)])
        nodes, corners, faces = reached_faces(self.traces[0], self.reach)
        return nodes, corners, [faces]

    def interpolation(self, k) -> sp.csr_matrix:
        """(size, n_trace_k): the P2 functions of the pair's body k's trace (columns ``traces[k].nodes``) at
        the nodes of X_h."""
        return self._interp[k]

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, 3 n_nodes): the scene's body ``k``'s part u^k . nu^k of [u_nu] at the nodes of X_h from its
        P2 nodal displacements (x, y, z interleaved); zero if k is not a member of the pair."""
        if k not in self.members:
            return sp.csr_matrix((self.size, 3 * n_nodes))
        t = self.traces[self.members.index(k)]
        return normal_jump(self._interp[t.k], np.asarray(t.nodes), row_directions(self, t.unit_normal), 3 * n_nodes)

    slip_components = 2
    """Components of the slip per node of X_h: along the pair's ``frame`` (t_1, t_2)."""

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(2 size, 3 n_nodes): the scene's body ``k``'s part of the slip [u_t]_j = (u^a - u^b) . t_j at the nodes of
        X_h from its P2 nodal displacements, component-major (rows j size + a), (t_1, t_2) the pair's ``frame``
        (:func:`~cvxcontact.contact.interface.row_frames`: against a curved obstacle turned into each row's
        tangent plane) for the first body, their opposites for the second (as
        :meth:`~cvxcontact.contact.surface.SurfaceInterface.tangential_jump`); zero if k is not a member."""
        if k not in self.members:
            return sp.csr_matrix((2 * self.size, 3 * n_nodes))
        side = self.members.index(k)
        t = self.traces[side]
        sign = 1.0 if side == 0 else -1.0
        return sp.vstack([normal_jump(self._interp[t.k], np.asarray(t.nodes), sign * tj, 3 * n_nodes)
                          for tj in row_frames(self)], format="csr")

    def sigma_rows(self, l) -> np.ndarray:
        """The P2 nodes of body l's trace (indices into ``traces[l].nodes``) inside the overlap, in the order
        of the rows of ``evaluation("sigma<l+1>")``."""
        return self._sigma[l][0]

    def evaluation(self, condition) -> sp.csr_matrix:
        """E: the rows evaluate X_h where the nodal condition is imposed: "sigma1"/"sigma2" at the P2 nodes of
        that body's faces inside the overlap (vertices and edge midpoints); with an obstacle, and under
        "gamma3" (the nodal relaxation of the copositive condition, :meth:`bernstein`), every node of X_h."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if self.rigid or condition == "gamma3":
            return sp.identity(self.size, format="csr")
        return self._sigma[int(condition[-1]) - 1][1]

    def _law_triangles(self, condition) -> tuple[np.ndarray, np.ndarray]:
        """(cells (c, 6), area (c,) m^2): the P2 triangles a normal-compliance law integrates over by
        :data:`P2_FACE_RULE` under ``condition``, their node indices the rows of :meth:`evaluation`. "gamma3" (and
        an obstacle) the triangles of X_h (``cells``); "sigma1"/"sigma2" that body's faces all of whose P2 nodes lie
        in the overlap (the faces the overlap's edge cuts: :meth:`_cut_weights`)."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if self.rigid or condition == "gamma3":
            cells = np.asarray(self.cells)
            return cells, _area(self.x[cells[:, :3]])
        l = int(condition[-1]) - 1
        t, inside = self.traces[l], self.sigma_rows(l)
        faces, _ = self._sigma_faces(condition)
        at = np.full(len(t.nodes), -1)
        at[inside] = np.arange(len(inside))
        return at[faces], _area(t.x[faces[:, :3]])

    def _cut_weights(self, condition) -> np.ndarray:
        """(rows,) m^2: the nodal part of a normal-compliance law's quadrature under "sigma1"/"sigma2" on the faces
        of body l the overlap's edge cuts (some or none of their P2 nodes in the overlap, :meth:`_sigma_faces`): the
        integrals over the overlap's part of those faces of the red refinement's P1 hats (as :meth:`weights`; exact by
        the overlay of the refined faces with the other body's faces), a node outside the overlap giving its share to
        the nearest node inside (the value :meth:`extend` gives it). Non-negative; with the whole faces' rule they
        integrate a constant exactly over the overlap (the weights sum to its area) and, where the overlap's edge
        follows edges of the refined faces (the hats of the nodes outside are 0 on it), a linear function too.
        Against an obstacle: :meth:`_partial_weights`. Zero under "gamma3" and where no face is cut."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if self.rigid:
            return self._partial_weights()
        if condition == "gamma3":
            return np.zeros(self.size)
        _, cut = self._sigma_faces(condition)
        return self._overlap_hats(int(condition[-1]) - 1, cut)

    def _reached_faces(self):
        """The body's faces against an obstacle reaching its part only in part: (faces (f, 6), the nodes the
        obstacle reaches (bool, nodes of the trace), the faces all six of whose nodes it reaches, those some but not
        all of whose nodes it reaches (bool, f each), the lone vertices: reaching vertices on no wholly reached
        face (bool, nodes))."""
        t = self.traces[0]
        reached = np.zeros(len(t.nodes), dtype=bool)
        reached[np.asarray(self.reach)] = True
        faces = np.asarray(t.faces)
        count = reached[faces].sum(axis=1)
        whole, partial = count == 6, (count > 0) & (count < 6)
        lone = reached.copy()
        lone[faces[whole, :3].ravel()] = False                   # a reaching vertex on no whole face
        return faces, reached, whole, partial, lone

    def _partial_weights(self) -> np.ndarray:
        """(size,) m^2: against an obstacle, the law's nodal weights on the faces of the body's part it reaches only
        in part (some of their six P2 nodes reach it, not all; docs/formulation.md §15): the lumped rule of the
        law's integral there, Phi read at the nodes and 0 at the nodes the obstacle misses (as Q1's node areas and
        Q2's ``simpson_lumped``). On a face of area A a reaching node's P2 function's integral (0 at a vertex, A/3
        at an edge midpoint: the consistent loads of a uniform pressure, so obstacles reaching complementary sets
        of the part's nodes weigh such a face as one plane would, and a uniform state is reproduced), except at
        a reaching vertex on no wholly reached face (on no point of :data:`P2_FACE_RULE`: its P2 weight 0 would
        let it penetrate for free), which takes its red hat's integral A/12 (:func:`red_weights`) from each such
        face, A/24 from each of that face's two edge midpoints next to it (the red refinement's weights at such a
        vertex and those midpoints: A/12 and A/4 when both of a midpoint's vertices are). Positive at every
        node of X_h on no wholly reached face (before, such a node carried no law)."""
        t, reach = self.traces[0], np.asarray(self.reach)
        faces, reached, _, partial, lone = self._reached_faces()
        part = faces[partial]
        lone = lone[part[:, :3]].astype(float)                   # (k, 3) at the partial faces' vertices
        area = _area(t.x[part[:, :3]])[:, None]
        share = np.column_stack([lone / 12.0, 1.0 / 3 - (lone + lone[:, [1, 2, 0]]) / 24.0]) * area
        w = np.bincount(part.ravel(), weights=(share * reached[part]).ravel(), minlength=len(t.nodes))
        return w[reach]

    def _overlap_hats(self, l, faces) -> np.ndarray:
        """(rows of "sigma<l+1>",) m^2: the integrals over the overlap of the P1 hats of the red refinement
        (:data:`RED_SUBTRIANGLES`) of body l's ``faces`` (k, 6) (exact: the overlay of the refined faces with the other
        body's faces, on whose cells the hats are affine), a node of those faces outside the overlap giving its share
        to the nearest node inside (the value :meth:`extend` gives it there). Non-negative; they sum to the area of
        the overlap the faces cover, so a constant is integrated exactly. The one rule of the nodal weights on faces
        the overlap's edge cuts: the law's (:meth:`_cut_weights`) and friction's (:meth:`weights`)."""
        t, other, inside = self.traces[l], self.linear.traces[1 - l], self.sigma_rows(l)
        faces = np.asarray(faces).reshape(-1, 6)
        if len(faces) == 0 or len(inside) == 0:
            return np.zeros(len(inside))
        cover = overlay(t.x, faces[:, RED_SUBTRIANGLES].reshape(-1, 3), other.x, other.faces)
        if len(cover.vertices) == 0:
            return np.zeros(len(inside))
        hats = np.asarray(cover.Ia.T @ np.asarray(cover.lumped)).ravel()   # int over the overlap of each hat
        return shares_to_nearest(hats, inside, t.x)

    def _rows(self, condition) -> int:
        return self.size if self.rigid or condition == "gamma3" else len(self.sigma_rows(int(condition[-1]) - 1))

    def quadrature(self, condition) -> tuple[sp.csr_matrix, np.ndarray]:
        """(Q (k, rows), w (k,) m^2): the quadrature of a normal-compliance energy under ``condition``
        (docs/formulation.md §15, "Normal compliance"): :data:`P2_FACE_RULE` on each triangle of
        :meth:`_law_triangles`, Q the P2 functions of the rows of :meth:`evaluation` at its points (triangle by
        triangle, the rule's order within each), w = rule weight x area > 0; then, where the overlap's edge cuts
        faces of body l under "sigma<l+1>", the rows themselves (Q the identity there) with the red hats' integrals
        over the overlap's part of those faces (:meth:`_cut_weights`), and against an obstacle on the faces it
        reaches only in part their lumped weights (:meth:`_partial_weights`), at the rows where they are positive. The
        law's rows are Q E: the energy sum_q w_q Phi(r(x_q)) of r in X_h (exact for m = 1 where a triangle is all in
        contact), the nodal forces E^T Q^T (w p): the integrals of p N_i by the same rule. Q^T w are the row sums
        of :meth:`row_mass` (on whole faces the integrals of the P2 functions, :func:`p2_weights`)."""
        cells, area = self._law_triangles(condition)
        L, w = P2_FACE_RULE
        n = self._rows(condition)
        Q = _p2_rows(np.tile(L, (len(cells), 1)), np.repeat(cells, len(w), axis=0), n)
        cut = self._cut_weights(condition)
        on = np.flatnonzero(cut > 0)
        if len(on) == 0:
            return Q, np.outer(area, w).ravel()
        nodal = sp.csr_matrix((np.ones(len(on)), (np.arange(len(on)), on)), shape=(len(on), n))
        return sp.vstack([Q, nodal], format="csr"), np.concatenate([np.outer(area, w).ravel(), cut[on]])

    def weights(self, condition) -> np.ndarray:
        """The areas (m^2) attributed to the rows of :meth:`evaluation`, positive: the friction capacities g w_a
        (docs/howto/friction.md). Each P2 triangle's red refinement (its six nodes the vertices of four triangles of
        a quarter of its area, :data:`RED_SUBTRIANGLES`) carries the P1 hats phi_i of those nodes, and w_i is their
        integral: "sigma1"/"sigma2" over the overlap (body l's hats, exact by the overlay of the refined faces with
        the other body's, whose cells the hats are affine on: on faces the overlap covers, A/12 at a vertex and A/4 at
        an edge midpoint, :func:`red_weights`, as P1's "sigma_l" weights integrate its hats; on faces the overlap's
        edge cuts, a node outside the overlap gives its share to the nearest node inside, the rule of the law's
        :meth:`_cut_weights`, :meth:`_overlap_hats`: they sum to the overlap's area, so the capacities sum to g
        times it); "gamma3" over the triangles of X_h; against an obstacle each reaching node's red hat over the
        body's whole part, the faces the obstacle reaches only in part included (the row sums of that mass at those
        nodes, as P1's and Q2's: obstacles reaching complementary sets of nodes share such a face's area; before,
        the mass restricted to the reaching nodes weighed it short). Exact for constants, and for linear functions
        where the overlap's edge follows edges of the refined faces. Not the integrals of the P2 functions
        (:func:`p2_weights`, the row sums of :meth:`row_mass`): 0 at the vertices, where a vertex would then slip
        for free."""
        if self.rigid:
            t = self.traces[0]
            M = red_mass(t.faces, _area(t.x[t.faces[:, :3]]), len(t.nodes))
            return np.asarray(M[self.reach].sum(axis=1)).ravel()
        if condition == "gamma3":
            cells, area = self._law_triangles(condition)
            return red_weights(cells, area, self.size)
        l = int(condition[-1]) - 1
        return self._overlap_hats(l, self.traces[l].faces)

    def row_mass(self, condition) -> sp.csr_matrix:
        """(rows, rows): the P2 mass matrix (m^2) of the triangles of :meth:`quadrature` on the rows of
        :meth:`evaluation` (its row sums are :func:`p2_weights`; zero rows at nodes no such triangle has), plus the
        diagonal of the nodal weights on cut faces (:meth:`_cut_weights`): its row sums are Q^T w."""
        cells, area = self._law_triangles(condition)
        n = self._rows(condition)
        return (p2_mass(cells, area, n) + sp.diags(self._cut_weights(condition))).tocsr()

    def law_pressure(self, condition, force) -> np.ndarray:
        """The pressure at the rows of :meth:`evaluation` (Pa for ``force`` in N at the points of
        :meth:`quadrature`, e.g. w_q p(r_q) + z_q): the Riesz representer lambda in the P2 functions of the
        law's triangles, M lambda = Q^T force (M = :meth:`row_mass`; exact for a pressure that is quadratic
        on those triangles, a uniform one included); 0 at rows on no such triangle."""
        Q, _ = self.quadrature(condition)
        return self.row_riesz(condition, Q.T @ np.asarray(force, dtype=float))

    def row_riesz(self, condition, forces) -> np.ndarray:
        """The pressure (Pa for ``forces`` in N, one per row of :meth:`evaluation`) at the rows: the Riesz
        representer of the row forces in the P2 functions of the condition's own faces, M p = forces with M =
        :meth:`row_mass` (under "sigma1"/"sigma2" the P2 mass of that body's faces wholly in the overlap, plus the
        cut faces' nodal weights on its diagonal). Exact for a pressure quadratic on those faces whose forces are
        its integrals against the P2 functions (a uniform one included: the consistent loads of a uniform traction
        on 6-node triangles, 0 at the vertices and A/3 at the edge midpoints); 1^T M p = 1^T forces, the total
        force. 0 at rows on no such face and of no cut weight (their forces are then not read)."""
        M = self.row_mass(condition)
        on = np.flatnonzero(M.diagonal() > 0)
        out = np.zeros(M.shape[0])
        if len(on):
            out[on] = spla.spsolve(M[on][:, on].tocsc(), np.asarray(forces, dtype=float)[on])
        return out

    def _sigma_faces(self, condition) -> tuple[np.ndarray, np.ndarray]:
        """(whole (k, 6), cut (j, 6)): the faces of body l's trace ("sigma<l+1>") all of whose P2 nodes lie in the
        overlap, and the others that may cover part of it (the overlap's edge may cut them): those whose bounding
        box meets the overlap's, some of their P2 nodes in the overlap or none (a face over a corner of the
        overlap may hold none of its nodes; :meth:`_overlap_hats` integrates over the overlap, 0 off it)."""
        l = int(condition[-1]) - 1
        t, inside = self.traces[l], self.sigma_rows(l)
        mark = np.zeros(len(t.nodes), dtype=bool)
        mark[inside] = True
        faces = np.asarray(t.faces)
        count = mark[faces].sum(axis=1)
        V = np.asarray(self.linear.overlay.vertices, dtype=float).reshape(-1, 2)
        corners = np.asarray(t.x, dtype=float)[faces[:, :3]]
        meets = ((corners.min(axis=1) <= V.max(axis=0, initial=-np.inf)).all(axis=1)
                 & (corners.max(axis=1) >= V.min(axis=0, initial=np.inf)).all(axis=1))
        return faces[count == 6], faces[(count < 6) & meets]

    def extend(self, condition, values) -> np.ndarray:
        """The P2 function of the constrained nodes under ``condition`` with nodal ``values`` there (the rows of
        :meth:`evaluation`), at every node of X_h: "gamma3" and an obstacle ``values`` itself; "sigma_l" body
        l's P2 trace function, its nodes outside the overlap taking the value of the nearest node inside."""
        values = np.asarray(values, dtype=float)
        if self.rigid or condition == "gamma3":
            return values.copy()
        l = int(condition[-1]) - 1
        t, inside = self.traces[l], self.sigma_rows(l)
        full = np.zeros(len(t.nodes))                            # no row inside the overlap: 0
        full[inside] = values
        outside = np.setdiff1d(np.arange(len(t.nodes)), inside)
        if len(outside) and len(inside):
            full[outside] = values[cKDTree(t.x[inside]).query(t.x[outside])[1]]
        return self._interp[l] @ full

    @property
    def cone_cells(self) -> np.ndarray:
        """(T, 6): the elements of the copositive condition: ``cells``, and against an obstacle also every node of
        X_h on no such face (a node that reaches the obstacle whose faces do not all reach it) as a degenerate
        cell (the node six times: the constant q there, which the condition holds <= 0, i.e. the nodal row)."""
        cells = np.asarray(self.cells)
        orphan = np.setdiff1d(np.arange(self.size), cells.ravel())
        return read_only(np.concatenate([cells, np.repeat(orphan[:, None], 6, axis=1)]))

    def bernstein(self) -> sp.csr_matrix:
        """(6 T, size): the map from nodal values of X_h to the Bernstein coefficients (b00, b11, b22, b01, b12,
        b20) of each element of :attr:`cone_cells` (overlay triangles; against an obstacle the faces all of whose
        P2 nodes reach it, and the nodes on none): "q <= 0 on every triangle" is the copositive condition of
        docs/formulation.md §16 (:mod:`cvxcontact.contact.bernstein`)."""
        return bernstein_map(self.cone_cells, self.size)

    def multiplier(self, r) -> np.ndarray:
        """lambda_h (Pa for row forces ``r`` in N) at the nodes of X_h: between two bodies the Riesz representer
        in the jumps of the two P2 traces, T1 + T2 (:class:`~cvxcontact.contact.riesz.TraceRiesz`: unique where
        the forces at the overlay's nodes are not, e.g. under the copositive condition); with an obstacle
        M lambda_h = r, M the P2 mass of the body's faces on the reaching nodes; with one that reaches the part only
        in part, that mass with each row's couplings to the missed nodes lumped onto its diagonal and the lone
        vertices tied (:meth:`_partial_mass`: a uniform pressure reads as itself at every row, the total force kept
        by the consistent loads; the restricted mass read 0.44 ... 1.54 p there, 0 at a lone vertex). A pair given a
        ``representer`` (``with_representer``, a space's pressure basis: the hook of
        :class:`~cvxcontact.contact.riesz.Represented`): its ``solve(r)``."""
        if self.representer is not None:
            return self.representer.solve(np.asarray(r, dtype=float))
        key = "riesz"
        if key not in self._factors:
            readback = self._partial_mass() if self._partial else self.mass
            self._factors[key] = (spla.splu(readback.tocsc()) if self.rigid
                                  else TraceRiesz(self._interp, self.mass))
        return self._factors[key].solve(np.asarray(r, dtype=float))

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by the pair's body k on its own trace nodes (``traces[k].x``): the Riesz
        representer, in the P2 functions of its faces, of its nodal forces interpolation(k)^T r (N), i.e.
        M_k p = interpolation(k)^T r with M_k the P2 mass of its faces (a P2 lumping has zero weight at the
        vertices). Exact for a uniform pressure over faces the overlap covers."""
        t = self.traces[k]
        if k not in self._factors:
            self._factors[k] = spla.splu(t.mass.tocsc())
        return self._factors[k].solve(self._interp[k].T @ np.asarray(r, dtype=float))
