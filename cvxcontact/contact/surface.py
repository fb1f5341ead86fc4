"""Planar contact surfaces in 3D: the traces of two tetrahedral bodies, the overlay of their faces, the jump
rows and lambda_h in X_h = T1 + T2 (docs/formulation.md, "Contact surfaces in 3D").

The 3D counterparts of :class:`~cvxcontact.contact.interface.Trace` and
:class:`~cvxcontact.contact.interface.Interface`, with the same protocol (``size``, ``x``, ``points``,
``normal``, ``traces``, ``sigma``, ``jump``, ``interpolation``, ``evaluation``, ``weights``, ``extend``,
``mass``, ``multiplier``, ``obstacle_gap``, ``rigid``, ``dim``). The nodes of X_h (the rows of "gamma3") are the
vertices of the overlay of the two face triangulations (:mod:`cvxcontact.contact.overlay`); the jump is affine
on each overlay cell, so non-penetration at those vertices is non-penetration everywhere on the overlap.
"""

from __future__ import annotations

from copy import copy

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from ..errors import SceneError, UnsupportedError
from .interface import CONDITIONS, normal_jump, read_only, row_directions, row_frames
from .overlay import OVERLAY_TOL, locate, overlay
from .riesz import Represented, TraceRiesz

__all__ = ["SurfaceTrace", "SurfaceInterface", "CurvedTrace", "CurvedSurfaceInterface", "canonical_frame", "is_planar"]

_REL_TOL = 1e-9     # geometric tolerance relative to the scene size (as in 2D)
_ANGLE_TOL = 1e-8   # largest angle between a face's normal and the part's normal (radians)


def canonical_frame(normal) -> np.ndarray:
    """(2, 3): an orthonormal frame (t1, t2) of the plane with unit normal ``normal``, the same for
    ``normal`` and ``-normal`` (so both sides of a pair share it): m = +-normal with its largest component
    positive, t1 the unit projection of the coordinate axis least aligned with it, t2 = m x t1. For a plane
    z = const, (t1, t2) = (x, y)."""
    n = np.asarray(normal, dtype=float)
    big = int(np.argmax(np.abs(n) + 1e-12 * np.arange(3)[::-1]))    # ties: the first axis
    m = n if n[big] > 0 else -n
    axis = int(np.argmin(np.abs(m) - 1e-12 * np.arange(3)[::-1]))   # ties: the first axis
    t1 = np.eye(3)[axis] - m[axis] * m
    t1 /= np.linalg.norm(t1)
    return np.array([t1, np.cross(m, t1)])


class SurfaceTrace:
    """The P1 trace of one body on a planar boundary part: ``faces`` (k, 3) (indices into ``nodes``),
    ``nodes`` (n,) the mesh nodes of the part (sorted), ``points`` (n, 3) m, ``unit_normal`` (3,) the outward
    normal, ``offset`` = x . nu (m) of the plane, ``frame`` (2, 3) the in-plane axes (t1, t2) shared with the
    other side, ``x`` (n, 2) the nodes' in-plane coordinates (m), ``lumped`` (n,) the area of the part
    attributed to each node (m^2, ``mesh.node_areas``: a third of each triangle's, a hexahedral face's Q1 hats)."""

    def __init__(self, body, k, tol, part=None, frame=None):
        mesh = body.mesh
        part = body.contact if part is None else part
        label = f"{body.name}: contact part {part!r}"
        if part not in mesh.tags:
            raise SceneError(f"{label}: unknown boundary tag; the mesh has {sorted(mesh.tags)}")
        faces, _, n, deviation, turn = _flatness(mesh, part)
        if len(faces) == 0:
            raise SceneError(f"{label} has no face")
        if n is None:
            raise SceneError(f"{label} is not planar: its outward face normals cancel (a closed or folded surface)")
        nodes = np.unique(faces)
        points = np.asarray(mesh.points, dtype=float)[nodes]
        offset = float(np.mean(points @ n))
        if deviation > tol or turn > _ANGLE_TOL:
            raise SceneError(f"{label} is not planar: its nodes leave its mean plane (normal ({n[0]:.6g}, "
                             f"{n[1]:.6g}, {n[2]:.6g})) by up to {deviation:.3g} m and its face normals turn by "
                             f"up to {np.degrees(turn):.3g} degrees; a contact surface must be one plane")
        frame = canonical_frame(n) if frame is None else np.asarray(frame, dtype=float)
        self.nodes = read_only(nodes)
        self.faces = read_only(np.searchsorted(nodes, faces))
        self.points = read_only(points)
        self.unit_normal = self.normal = read_only(n)
        self.offset = offset
        self.frame = read_only(frame)
        self.x = read_only(points @ frame.T)
        self.lumped = read_only(np.asarray(mesh.node_areas(part), dtype=float)[nodes])   # hexahedra: the Q1 hats'
        self.k, self.part, self.body = k, part, body

    def mass(self) -> sp.csr_matrix:
        """(n, n) P1 mass matrix of the part (m^2)."""
        P = self.x[self.faces]
        d1, d2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
        area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
        local = (np.ones((3, 3)) + np.eye(3)) / 12.0
        rows = np.repeat(self.faces, 3, axis=1).ravel()
        cols = np.tile(self.faces, (1, 3)).ravel()
        return sp.csr_matrix(((area[:, None, None] * local).ravel(), (rows, cols)), shape=(len(self.nodes),) * 2)


def _flatness(mesh, part):
    """(faces, areas (m^2), n, deviation (m), turn (rad)) of boundary part ``part``: its faces and their areas,
    the unit area-weighted mean of its outward normals n (None if they cancel), the largest distance of its
    nodes from their mean plane normal to n, and the largest angle between a face's normal and n. The faces are
    the triangles of ``mesh.triangulation`` (a hexahedral mesh's faces cut in two, on their corners)."""
    mesh = mesh.triangulation
    faces = np.asarray(mesh.boundary(part))
    if len(faces) == 0:
        return faces, np.zeros(0), None, np.inf, np.inf
    normals = np.asarray(mesh.outward_normals(part), dtype=float)
    areas = np.asarray(mesh.face_areas(part), dtype=float)
    n = (areas[:, None] * normals).sum(axis=0)
    size = np.linalg.norm(n)
    if size <= 1e-12 * areas.sum():
        return faces, areas, None, np.inf, np.inf
    n = n / size
    h = np.asarray(mesh.points, dtype=float)[np.unique(faces)] @ n
    deviation = float(np.abs(h - h.mean()).max())
    turn = float(np.arctan2(np.linalg.norm(np.cross(normals, n), axis=1), normals @ n).max())
    return faces, areas, n, deviation, turn


def is_planar(body, part, tol: float | None = None) -> bool:
    """Whether boundary part ``part`` of the 3D ``body`` is one plane, by the test of :class:`SurfaceTrace`
    (nodes within ``tol`` (m; default 1e-9 of the mesh size) of the mean plane, face normals within 1e-8 rad);
    True for an unknown or empty part (:class:`SurfaceTrace` names those)."""
    mesh = body.mesh
    if part not in mesh.tags:
        return True
    tol = _REL_TOL * mesh.size if tol is None else tol
    faces, _, n, deviation, turn = _flatness(mesh, part)
    return len(faces) == 0 or (n is not None and deviation <= tol and turn <= _ANGLE_TOL)


class SurfaceInterface(Represented):
    """Geometry and operators of one contact pair of planar surfaces (docs/formulation.md, "Contact surfaces
    in 3D"): ``SurfaceInterface(bodies)`` (each body's ``contact`` part), ``SurfaceInterface(bodies, parts)``,
    or ``SurfaceInterface((body,), (part,), obstacle=rigid)`` (anything with ``distance(points, normal)``,
    +inf where the obstacle cannot be reached along the normal).

    ``normal`` (3,) is the first body's unit outward normal nu^a (the second's is -nu^a), ``frame`` (2, 3) the
    shared in-plane axes, ``offset`` = x . nu^a (m) on the first part's plane. The nodes of X_h are the vertices of the overlay of the two parts' triangulations:
    ``x`` (v, 2) their in-plane coordinates (m), ``points`` (v, 3) on the first part's plane; ``sigma[l]``
    the vertices that are body l's nodes (inside the overlap). With a rigid obstacle they are the body's
    nodes from which the obstacle is reachable along nu^a, and every condition constrains all of them.
    """

    dim = 3

    def __init__(self, bodies, parts=None, obstacle=None, tol: float = OVERLAY_TOL):
        bodies = tuple(bodies)
        parts = tuple(b.contact for b in bodies) if parts is None else tuple(parts)
        scale = max(b.mesh.size for b in bodies)
        geo_tol = _REL_TOL * scale
        self.obstacle = obstacle
        first = SurfaceTrace(bodies[0], 0, geo_tol, parts[0])
        self.normal, self.frame, self.offset = first.unit_normal, first.frame, first.offset
        self._factor = None
        if obstacle is not None:
            self._rigid(first)
            return
        second = SurfaceTrace(bodies[1], 1, geo_tol, parts[1], frame=first.frame)
        self.traces = [first, second]
        na, nb = first.unit_normal, second.unit_normal
        if na @ nb > -1.0 + _ANGLE_TOL:
            if na @ nb >= 1.0 - _ANGLE_TOL:
                raise SceneError(f"{bodies[0].name} {parts[0]!r} and {bodies[1].name} {parts[1]!r} have the same "
                                 f"outward normal ({_v(na)}): both bodies lie on the same side of the contact "
                                 "plane; they must face each other")
            raise SceneError(f"contact parts do not face each other: {bodies[0].name} {parts[0]!r} has outward normal "
                             f"({_v(na)}), {bodies[1].name} {parts[1]!r} has ({_v(nb)}); a contact pair needs "
                             "parallel planar parts with opposite normals")
        dist = float(np.mean(second.points @ na)) - first.offset
        if abs(dist) > geo_tol:
            raise SceneError(f"contact parts are not coplanar: {bodies[1].name} {parts[1]!r} lies {dist:.9g} m from "
                             f"the plane of {bodies[0].name} {parts[0]!r} along its normal ({_v(na)})")
        ov = overlay(first.x, first.faces, second.x, second.faces, tol)
        if ov.size == 0:
            raise SceneError(f"contact parts do not overlap: in the plane's axes t1 = ({_v(self.frame[0])}), t2 = "
                             f"({_v(self.frame[1])}), {bodies[0].name} {parts[0]!r} spans {_box(first.x)} and "
                             f"{bodies[1].name} {parts[1]!r} spans {_box(second.x)} (m)")
        self.overlay = ov
        self.x = ov.vertices
        self.points = read_only(first.offset * self.normal + ov.vertices @ self.frame)
        self.sigma = tuple(read_only(np.sort(nd[nd >= 0])) for nd in (ov.node_a, ov.node_b))
        self.mass = ov.mass
        self._interp = [ov.Ia, ov.Ib]

    def _rigid(self, first):
        """The pair of one body and a rigid obstacle: the nodes of X_h are the body's trace nodes from which
        the obstacle is reachable; X_h is spanned by their hats on the body's part (the Gram matrix is the
        trace's mass matrix restricted to them)."""
        self.traces = [first]
        d = np.asarray(self.obstacle.distance(first.points, first.unit_normal), dtype=float)
        label = f"{first.body.name}: contact part {first.part!r} against {self.obstacle!r}"
        if d.shape != (len(first.nodes),) or np.isnan(d).any() or (d == -np.inf).any():
            raise SceneError(f"{label}: the obstacle's distance is not a finite number or +inf at every node")
        hit = np.flatnonzero(np.isfinite(d))
        if len(hit) == 0:
            raise SceneError(f"{label}: the obstacle cannot be reached along the part's outward normal "
                             f"({_v(self.normal)}) from any node; it does not face the part")
        self._reach(first, hit)

    def _reach(self, first, hit):
        """X_h on the trace nodes ``hit`` of ``first`` (indices): the pair's nodes, mass, weights and selection."""
        self.reach = read_only(hit)
        self.overlay = None
        self.x = read_only(first.x[hit])
        self.points = read_only(first.points[hit])
        self.sigma = (read_only(np.arange(len(hit))),)
        full = first.mass()
        self.mass = full[hit][:, hit].tocsr()
        self._hats = read_only(np.asarray(full[hit].sum(axis=1)).ravel())     # each hat's integral over the part
        self._partial = len(hit) < len(first.nodes)                 # lambda_h read back as r / w (multiplier)
        reached = np.zeros(len(first.nodes), dtype=bool)
        reached[hit] = True
        P = first.x[first.faces[reached[first.faces].all(axis=1)]]
        d1, d2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
        self._area = float(0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]).sum())
        self._interp = [sp.csr_matrix((np.ones(len(hit)), (np.arange(len(hit)), hit)), shape=(len(hit), len(first.nodes)))]

    @property
    def rigid(self) -> bool:
        """True if the second side is a rigid obstacle (no mesh, no unknowns)."""
        return self.obstacle is not None

    def reaching(self, reached) -> SurfaceInterface:
        """A copy of this obstacle pair whose X_h is the trace nodes ``reached`` (bool per node of its trace):
        the space in which lambda_h of several obstacles on one part is read once, from their forces summed
        (:mod:`cvxcontact.solution.sides`). Its :meth:`multiplier` and :meth:`interpolation` only."""
        out = copy(self)
        out.__dict__.pop("_row_directions", None)
        out._factor = None
        out._reach(self.traces[0], np.flatnonzero(reached))
        return out

    def riesz_parts(self):
        """(the traces' interpolations, the mass of X_h): what a two-body pair reads lambda_h from
        (:class:`~cvxcontact.contact.riesz.TraceRiesz`); None with an obstacle or a representer of its own."""
        return None if self.rigid or self.representer is not None else (self._interp, self.mass)

    @property
    def size(self) -> int:
        """Number of nodes of X_h (overlay vertices; with an obstacle, reachable trace nodes)."""
        return len(self.x)

    @property
    def area(self) -> float:
        """Area of the overlap (m^2); with an obstacle, of the faces whose nodes all reach it."""
        return self.overlay.area if self.overlay is not None else self._area

    def obstacle_gap(self) -> np.ndarray:
        """The distance (m) from each node of X_h to the obstacle along nu^a (0 without an obstacle)."""
        if self.obstacle is None:
            return np.zeros(self.size)
        return np.asarray(self.obstacle.distance(self.points, self.normal), dtype=float)

    def interpolation(self, k) -> sp.csr_matrix:
        """(size, n_trace_k): the P1 functions of body k's trace (columns: ``traces[k].nodes``) at the nodes
        of X_h."""
        return self._interp[k]

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, 3 n_nodes): body k's part u^k . nu^k of [u_nu] at the nodes of X_h from its nodal
        displacements (x, y, z interleaved)."""
        t = self.traces[k]
        return normal_jump(self._interp[k], t.nodes, row_directions(self, t.unit_normal), 3 * n_nodes)

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(2 size, 3 n_nodes): body k's part of the slip [u_t]_j = (u^a - u^b) . t_j at the nodes of X_h,
        component-major (rows j size + a), (t_1, t_2) the pair's ``frame`` (:func:`row_frames`: against a curved
        obstacle, turned into each row's tangent plane) for the first body, their opposites for the second."""
        t = self.traces[k]
        sign = 1.0 if k == 0 else -1.0
        return sp.vstack([normal_jump(self._interp[k], t.nodes, sign * tj, 3 * n_nodes) for tj in row_frames(self)],
                         format="csr")

    def _rows(self, condition) -> np.ndarray:
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if condition == "gamma3" or self.rigid:
            return np.arange(self.size)
        return np.asarray(self.sigma[int(condition[-1]) - 1])

    def evaluation(self, condition) -> sp.csr_matrix:
        """E: rows select the nodes of X_h where non-penetration is imposed ("gamma3": every overlay vertex;
        "sigma1"/"sigma2": the first/second body's nodes in the overlap; with an obstacle, all nodes)."""
        rows = self._rows(condition)
        return sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)), rows)), shape=(len(rows), self.size))

    def weights(self, condition) -> np.ndarray:
        """The areas (m^2) attributed to the rows of :meth:`evaluation`, a quadrature of the overlap for a
        compliance law (and the friction capacities g w_a): "gamma3" the overlay's ``lumped`` areas (shares of
        its cells, independent of the side the pair is posed from); with an obstacle each reaching node's hat
        integrated over the body's part (the row sums of the part's mass matrix: the lumped rule of the law's
        integral, Phi 0 at the nodes the obstacle misses, so that obstacles reaching complementary sets of the
        part's nodes weigh a face they share once; before, the row sums of ``mass``, restricted to the reaching
        nodes, weighed such faces short);
        "sigma_l" the integral over the overlap of body l's hat at each of its nodes there (they sum to the area
        its hats cover)."""
        rows = self._rows(condition)
        if self.rigid:
            return np.array(self._hats)[rows]
        if condition == "gamma3":
            return np.array(self.overlay.lumped)[rows]
        l = int(condition[-1]) - 1
        P = self._interp[l]
        integral = P.T @ self.overlay.lumped          # int over the overlap of each hat (exact: affine on each cell)
        node = self.overlay.node_a if l == 0 else self.overlay.node_b
        own = np.flatnonzero(node >= 0)
        out = np.empty(self.size)
        out[node[own]] = integral[own]
        return out[rows]

    def extend(self, condition, values) -> np.ndarray:
        """The P1 function of the constrained side with nodal ``values`` on the rows of :meth:`evaluation`,
        at every node of X_h ("gamma3" and an obstacle: ``values`` itself; "sigma_l": body l's P1 function,
        its nodes outside the overlap taking the value of the nearest node inside)."""
        values = np.asarray(values, dtype=float)
        rows = self._rows(condition)
        if len(rows) == self.size:
            return values.copy()
        l = int(condition[-1]) - 1
        node = self.overlay.node_a if l == 0 else self.overlay.node_b
        inside = np.flatnonzero(node >= 0)
        at = np.empty(self.size)
        at[rows] = values
        full = np.empty(len(node))
        full[inside] = at[node[inside]]
        outside = np.flatnonzero(node < 0)
        if len(outside):
            x = self.traces[l].x
            full[outside] = full[inside[cKDTree(x[inside]).query(x[outside])[1]]]
        return self._interp[l] @ full

    def multiplier(self, r) -> np.ndarray:
        """lambda_h (N/m^2 for row forces ``r`` in N) at the nodes of X_h: the L^2(Gamma_3) Riesz representer in
        X_h of psi -> sum_a r_a psi(a) (docs/formulation.md, "Contact surfaces in 3D"). Two bodies: X_h = T1 + T2
        = range G, G = [Ia | Ib] (the hats that meet the overlap); G^T M G c = G^T r is singular by dim(T1 n T2)
        and consistent, and lambda_h = G c is the same for every solution. Solved by iterated Tikhonov steps
        c += (A + s D)^-1 (G^T r - A c) (A = G^T M G, D its diagonal, s = 1e-12; one factorisation, kept), at
        most 50, stopping when the residual is below 1e-14 of G^T r or has not decreased for three steps.
        Measured max |G^T (M lambda - r)| / max |G^T r|: 1e-15 on the test faces, 2e-13 at 2.9e4 vertices; on
        faces whose nodes nearly coincide without being merged the hats are nearly dependent (nodes 8e-6 h
        apart: 9e-11; 8e-9 h apart: 3e-9). With an obstacle: M lambda_h = r; with one that reaches the part
        only in part (some of its trace's nodes miss it) each row's force over its weight, lambda_a = r_a / w_a,
        w_a the reaching node's hat integrated over the whole part (:meth:`weights`, the law's; docs/formulation.md
        §13): the mass restricted to the reaching nodes weighs the faces they share with missing nodes short, so
        M lambda_h = r misreads next to where the reach stops (a uniform push read too high there, forces >= 0 a
        pressure < 0); r / w reads a uniform pressure (forces p w_a) as p at every row, is >= 0 where the forces
        are, and keeps the total force. A pair given a ``representer`` (``with_representer``, a space's pressure
        basis: the hook of :class:`~cvxcontact.contact.riesz.Represented`): its ``solve(r)``."""
        r = np.asarray(r, dtype=float)
        if self.representer is not None:
            return self.representer.solve(r)
        if self.rigid and self._partial:
            return r / self._hats
        if self.rigid:
            if self._factor is None:
                self._factor = spla.splu(self.mass.tocsc())
            return self._factor.solve(r)
        if self._factor is None:
            self._factor = TraceRiesz(self._interp, self.mass)
        return self._factor.solve(r)

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by body k on its own trace nodes (``traces[k].nodes``): its nodal forces
        interpolation(k)^T r (N; exact work equivalence) over its lumped areas ``traces[k].lumped``."""
        return (self._interp[k].T @ np.asarray(r, dtype=float)) / self.traces[k].lumped

    def with_interpolation(self, interpolation) -> SurfaceInterface:
        """A copy of this two-body pair whose traces are evaluated at the nodes of X_h by ``interpolation``
        (per side a (size, n_k) matrix, columns ``traces[k].nodes``; e.g. the bilinear functions of hexahedral
        faces, :class:`~cvxcontact.fem.hexfaces.BilinearSurface`) instead of the P1 functions of the faces'
        triangles: its jump rows, the weights and extension of "sigma1"/"sigma2" and lambda_h follow them."""
        out = copy(self)
        out._interp, out._factor = list(interpolation), None
        return out

    def elements(self) -> tuple[np.ndarray, np.ndarray, list]:
        """The triangles on which a function of X_h (lambda_h, the jump) is affine: (nodes (e, 3) of X_h, -1 for
        a vertex outside it where the function is 0; vertices (e, 3, 2) in-plane, m; per side the face of its
        trace (index into ``traces[k].faces``) that holds each). Two bodies: the overlay's triangles; with an
        obstacle: the body's faces with a node that reaches it."""
        if self.overlay is not None:
            tri = np.asarray(self.overlay.triangles)
            return tri, np.asarray(self.overlay.vertices)[tri], [np.asarray(self.overlay.cell_a),
                                                                 np.asarray(self.overlay.cell_b)]
        nodes, corners, faces = reached_faces(self.traces[0], self.reach)
        return nodes, corners, [faces]


class CurvedTrace:
    """The P1 trace of one body on a curved boundary part facing a planar part (plane unit normal ``n_p``, the
    planar body's outward normal; in-plane axes ``frame``): ``faces`` (k, 3) (indices into ``nodes``), ``nodes``
    (n,) its mesh nodes (sorted), ``points`` (n, 3) m, ``unit_normal`` = -n_p (the direction along which the
    pair measures this side's displacement, not the surface's own normal), ``offset`` = -(the plane's x . n_p)
    (m; as the planar partner's side would have), ``frame`` (2, 3), ``x`` (n, 2) the in-plane coordinates of the
    nodes' projections on the plane (m), ``lumped`` (n,) the area of the curved part attributed to each node
    (m^2, a third of each face's true area)."""

    def __init__(self, body, k, part, n_p, offset, frame):
        mesh = body.mesh
        faces, areas, n, _, _ = _flatness(mesh, part)
        label = f"{body.name}: contact part {part!r}"
        if len(faces) == 0:
            raise SceneError(f"{label} has no face")
        if n is None or n @ n_p >= 0:
            raise SceneError(f"{label} (curved) does not face the planar part: the area-weighted mean of its outward "
                             f"normals is {'zero' if n is None else '(' + _v(n) + ')'}, the planar part's outward "
                             f"normal ({_v(n_p)}); the curved part must turn towards the plane (mean normal . n < 0)")
        nodes = np.unique(faces)
        points = np.asarray(mesh.points, dtype=float)[nodes]
        self.nodes = read_only(nodes)
        self.faces = read_only(np.searchsorted(nodes, faces))
        self.points = read_only(points)
        self.unit_normal = self.normal = read_only(-np.asarray(n_p, dtype=float))
        self.offset = -float(offset)
        self.frame = read_only(frame)
        self.x = read_only(points @ np.asarray(frame).T)
        lumped = np.zeros(len(nodes))
        np.add.at(lumped, self.faces.ravel(), np.repeat(areas / 3.0, 3))
        self.lumped = read_only(lumped)
        self.k, self.part, self.body = k, part, body


class CurvedSurfaceInterface:
    """A node-to-face contact pair: a curved part of one body against a planar part of the other
    (docs/formulation.md, "A curved part against a planar one"), with the protocol of
    :class:`SurfaceInterface`. ``CurvedSurfaceInterface(bodies, parts, curved)``: ``curved`` (0 or 1) is the
    index of the body whose part is curved.

    Each node x of the curved part is projected along the planar part's outward normal n_p onto its plane; the
    nodes whose projection X falls on the planar part (within a relative tolerance) are the nodes of X_h and the
    rows of the only condition posed, K_h(Sigma_h^l) with l the curved body ("sigma1" or "sigma2"). The initial
    gap at x is (x - X) . n_p (``obstacle_gap``; the pair's gap is added), the jump
    [u_nu](x) = u^l(x) . (-n_p) + (P1 interpolant of u^p at X) . n_p, u^p the planar body's displacement on the
    face triangle holding X. Nodes whose projection misses the planar part are free. X_h: the hats of the curved
    trace at those nodes with the lumped (diagonal) mass, so lambda_h is each row's force over the node's
    lumped area of the curved part, which is also the pressure that body feels.

    ``normal`` is nu^a of the first body's side: n_p if the planar body is first, -n_p otherwise; ``x`` (v, 2)
    the in-plane coordinates of the projections, ``points`` (v, 3) the curved nodes themselves (m), ``reach``
    their indices in ``traces[curved]``, ``cells`` the curved faces whose three nodes are rows (numbered as the
    nodes of X_h).
    """

    dim = 3
    rigid = False
    obstacle = None
    overlay = None

    def __init__(self, bodies, parts, curved: int, tol: float = OVERLAY_TOL):
        bodies, parts = tuple(bodies), tuple(parts)
        if curved not in (0, 1) or len(bodies) != 2 or len(parts) != 2:
            raise SceneError(f"a curved pair takes two bodies, two parts and curved = 0 or 1, got {curved!r}")
        planar = 1 - curved
        geo_tol = _REL_TOL * max(b.mesh.size for b in bodies)
        plane = SurfaceTrace(bodies[planar], planar, geo_tol, parts[planar])
        n_p = np.asarray(plane.unit_normal)
        curve = CurvedTrace(bodies[curved], curved, parts[curved], n_p, plane.offset, plane.frame)
        self.curved = curved
        self.label = (f"{bodies[curved].name} {parts[curved]!r} (curved) against {bodies[planar].name} "
                      f"{parts[planar]!r} (planar)")
        self.traces = [plane, curve] if planar == 0 else [curve, plane]
        self.normal = read_only(n_p if planar == 0 else -n_p)
        self.frame, self.offset = plane.frame, (plane.offset if planar == 0 else -plane.offset)
        face, bary = locate(curve.x, plane.x, plane.faces, tol)
        hit = np.flatnonzero(face >= 0)
        if len(hit) == 0:
            raise SceneError(f"{self.label}: no node of the curved part lies over the planar part along its normal "
                             f"({_v(n_p)}): in the plane's axes the curved part spans {_box(curve.x)} and the planar "
                             f"part {_box(plane.x)} (m)")
        self.reach = read_only(hit)
        self.x = read_only(curve.x[hit])
        self.points = read_only(curve.points[hit])
        self._gap = read_only(curve.points[hit] @ n_p - plane.offset)
        size = len(hit)
        own = sp.csr_matrix((np.ones(size), (np.arange(size), hit)), shape=(size, len(curve.nodes)))
        cols = plane.faces[face[hit]]
        other = sp.csr_matrix((bary[hit].ravel(), (np.repeat(np.arange(size), 3), cols.ravel())),
                              shape=(size, len(plane.nodes)))
        other.eliminate_zeros()
        self._interp = [other, own] if planar == 0 else [own, other]
        self.sigma = tuple(read_only(np.arange(size) if k == curved else np.zeros(0, dtype=int)) for k in (0, 1))
        self._lumped = read_only(curve.lumped[hit])
        self.mass = sp.diags(self._lumped, format="csr")
        where = np.full(len(curve.nodes), -1)
        where[hit] = np.arange(size)
        cells = where[curve.faces]
        self.cells = read_only(cells[(cells >= 0).all(axis=1)])

    @property
    def size(self) -> int:
        """Number of nodes of X_h (curved nodes over the planar part)."""
        return len(self.x)

    @property
    def area(self) -> float:
        """Area (m^2) of the curved part attributed to the nodes of X_h (their lumped areas)."""
        return float(self._lumped.sum())

    def elements(self) -> tuple[np.ndarray, np.ndarray, list]:
        """The triangles on which lambda_h is affine (the hats of the curved trace): (nodes (e, 3) of X_h, -1 for
        a vertex outside it; the projections of their vertices on the plane (e, 3, 2), m; per side the face of
        its trace that holds each, None for the planar side: the curved faces do not match its faces): the
        curved faces with a node over the planar part."""
        nodes, corners, faces = reached_faces(self.traces[self.curved], self.reach)
        return nodes, corners, [faces if k == self.curved else None for k in (0, 1)]

    def obstacle_gap(self) -> np.ndarray:
        """The initial gap (m) at each node of X_h: its distance (x - X) . n_p from the plane along the planar
        part's normal (negative: the node starts inside the planar body)."""
        return np.array(self._gap)

    def interpolation(self, k) -> sp.csr_matrix:
        """(size, n_trace_k): body k's P1 trace functions at the nodes of X_h (the curved body's: its own nodes;
        the planar body's: at their projections)."""
        return self._interp[k]

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, 3 n_nodes): body k's part of [u_nu] at the nodes of X_h (the curved side along -n_p, the
        planar side along n_p), from its nodal displacements (x, y, z interleaved)."""
        t = self.traces[k]
        return normal_jump(self._interp[k], t.nodes, row_directions(self, t.unit_normal), 3 * n_nodes)

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(2 size, 3 n_nodes): body k's part of the slip [u_t]_j = (u^a - u^b) . t_j at the nodes of X_h,
        component-major (rows j size + a), (t_1, t_2) the planar part's ``frame`` (the plane is the tangent plane
        of the pair: its rows measure along n_p), taken along +t_j for the first body and -t_j for the second:
        the curved body's displacement at its node x, the planar body's P1 interpolant at the projection X (as
        :meth:`jump`; :meth:`SurfaceInterface.tangential_jump`)."""
        t = self.traces[k]
        sign = 1.0 if k == 0 else -1.0
        return sp.vstack([normal_jump(self._interp[k], t.nodes, sign * tj, 3 * n_nodes) for tj in self.frame],
                         format="csr")

    def _rows(self, condition) -> np.ndarray:
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        own = f"sigma{self.curved + 1}"
        if condition != own:
            raise UnsupportedError(
                f"{self.label}: condition {condition!r} is not available on a curved part (it needs the overlay of "
                f"a curved surface with a plane); use {own!r}, the nodal condition at the curved body's nodes: "
                f"Contact(..., condition={own!r}) or solve(..., condition={own!r})")
        return np.arange(self.size)

    def evaluation(self, condition) -> sp.csr_matrix:
        """E: the identity on the nodes of X_h under the curved body's nodal condition (UnsupportedError,
        naming the pair, for any other)."""
        rows = self._rows(condition)
        return sp.identity(len(rows), format="csr")

    def weights(self, condition) -> np.ndarray:
        """The lumped areas (m^2) of the curved part at the rows (a compliance law's quadrature)."""
        self._rows(condition)
        return np.array(self._lumped)

    def extend(self, condition, values) -> np.ndarray:
        """``values`` at the rows, which are every node of X_h."""
        self._rows(condition)
        return np.asarray(values, dtype=float).copy()

    def multiplier(self, r) -> np.ndarray:
        """lambda_h (Pa for row forces ``r`` in N) at the nodes of X_h: M lambda_h = r with the lumped mass, i.e.
        each row's force over its node's lumped area of the curved part."""
        return np.asarray(r, dtype=float) / self._lumped

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by body k on its own trace nodes: its nodal forces interpolation(k)^T r (N)
        over its lumped areas ``traces[k].lumped``."""
        return (self._interp[k].T @ np.asarray(r, dtype=float)) / self.traces[k].lumped


def reached_faces(trace, reach):
    """(nodes (e, k) of X_h with -1 for a node outside it, in-plane vertices (e, 3, 2), face indices (e,)) of
    the faces of ``trace`` (k nodes each) with a node among ``reach`` (indices into the trace's nodes,
    numbered as X_h)."""
    at = np.full(len(trace.nodes), -1)
    at[reach] = np.arange(len(reach))
    faces = np.asarray(trace.faces)
    keep = np.flatnonzero((at[faces] >= 0).any(axis=1))
    return at[faces[keep]], np.asarray(trace.x)[faces[keep][:, :3]], keep


def _v(a) -> str:
    return ", ".join(f"{float(c):.6g}" for c in a)


def _box(x) -> str:
    lo, hi = x.min(axis=0), x.max(axis=0)
    return f"t1 in [{lo[0]:.9g}, {hi[0]:.9g}], t2 in [{lo[1]:.9g}, {hi[1]:.9g}]"
