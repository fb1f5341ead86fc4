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

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from ..errors import SceneError
from .interface import CONDITIONS, normal_jump, read_only
from .overlay import OVERLAY_TOL, overlay
from .riesz import TraceRiesz

__all__ = ["SurfaceTrace", "SurfaceInterface", "canonical_frame"]

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
    attributed to each node (m^2, a third of each face's)."""

    def __init__(self, body, k, tol, part=None, frame=None):
        mesh = body.mesh
        part = body.contact if part is None else part
        label = f"{body.name}: contact part {part!r}"
        if part not in mesh.tags:
            raise SceneError(f"{label}: unknown boundary tag; the mesh has {sorted(mesh.tags)}")
        faces = np.asarray(mesh.boundary(part))
        if len(faces) == 0:
            raise SceneError(f"{label} has no face")
        normals = np.asarray(mesh.outward_normals(part), dtype=float)
        areas = np.asarray(mesh.face_areas(part), dtype=float)
        n = (areas[:, None] * normals).sum(axis=0)
        size = np.linalg.norm(n)
        if size <= 1e-12 * areas.sum():
            raise SceneError(f"{label} is not planar: its outward face normals cancel (a closed or folded surface)")
        n /= size
        nodes = np.unique(faces)
        points = np.asarray(mesh.points, dtype=float)[nodes]
        offset = float(np.mean(points @ n))
        deviation = float(np.abs(points @ n - offset).max())
        turn = float(np.arctan2(np.linalg.norm(np.cross(normals, n), axis=1), normals @ n).max())
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
        lumped = np.zeros(len(nodes))
        np.add.at(lumped, self.faces.ravel(), np.repeat(areas / 3.0, 3))
        self.lumped = read_only(lumped)
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


class SurfaceInterface:
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
        self.reach = read_only(hit)
        self.overlay = None
        self.x = read_only(first.x[hit])
        self.points = read_only(first.points[hit])
        self.sigma = (read_only(np.arange(len(hit))),)
        self.mass = first.mass()[hit][:, hit].tocsr()
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
        return normal_jump(self._interp[k], t.nodes, t.unit_normal, 3 * n_nodes)

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
        compliance law: "gamma3" (and an obstacle) the row sums of ``mass``; "sigma_l" the integral over the
        overlap of body l's hat at each of its nodes there (they sum to the area its hats cover)."""
        rows = self._rows(condition)
        if condition == "gamma3" or self.rigid:
            return np.asarray(self.mass.sum(axis=1)).ravel()[rows]
        l = int(condition[-1]) - 1
        P = self._interp[l]
        integral = P.T @ (self.mass @ np.ones(self.size))                   # int over the overlap of each hat
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
        apart: 9e-11; 8e-9 h apart: 3e-9). With an obstacle: M lambda_h = r."""
        r = np.asarray(r, dtype=float)
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


def _v(a) -> str:
    return ", ".join(f"{float(c):.6g}" for c in a)


def _box(x) -> str:
    lo, hi = x.min(axis=0), x.max(axis=0)
    return f"t1 in [{lo[0]:.9g}, {hi[0]:.9g}], t2 in [{lo[1]:.9g}, {hi[1]:.9g}]"
