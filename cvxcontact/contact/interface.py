"""The contact line Gamma_3: traces, merged mesh, jump and multiplier operators.

Notation of docs/formulation.md §3-4. Sigma_h^l are the nodes of mesh l on Gamma_3; the
merged mesh is their union, on which X_h (continuous P1) lives. With nodal
displacements U_l of body l,

    [u_nu] = sum_l J_l U_l        at the merged nodes (J_l = nu_l . trace interpolation)
    [u_t]  = sum_l T_l U_l        the tangential part, (u^a - u^b) . t (T_l = +-t . trace interpolation)
    M                             P1 mass matrix of X_h on the merged mesh (m)
    E                             evaluation at the constrained nodes (``condition``)
"""

from __future__ import annotations

from copy import copy

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import SceneError

__all__ = ["Interface", "Stack", "CONDITIONS", "lumped_lengths", "shares_to_nearest", "canonical_tangent",
           "row_directions", "row_tangents", "row_frames"]

CONDITIONS = ("gamma3", "sigma1", "sigma2")
"""K_h(Gamma_3): [u_nu] <= 0 at every merged node; K_h(Sigma_h^l): at the nodes of mesh l."""

_REL_TOL = 1e-9  # geometric tolerance relative to the scene size
_ANGLE_TOL = 1e-8  # largest spread of the unit normals of one straight part (radians)


def canonical_tangent(normal) -> np.ndarray:
    """The unit tangent of a straight contact line with unit normal ``normal``: the one with a
    positive x1 component (positive x2 for a line parallel to the x2-axis), so that both bodies of a
    pair, whose normals are opposite, share it and a line parallel to the x1-axis keeps s = x1."""
    t = np.array([-normal[1], normal[0]], dtype=float)
    if t[0] < -_ANGLE_TOL or (abs(t[0]) <= _ANGLE_TOL and t[1] < 0):
        t = -t
    return t


class Trace:
    """The P1 trace of one body on its contact part: nodes sorted by the tangential coordinate s =
    x . t (m), the unit outward normal ``normal`` (2,) and ``points`` (n, 2) in that order.

    ``x`` is s (the abscissa for a line parallel to the x1-axis); ``unit_normal`` the outward normal;
    ``normal`` its x2 component when that is +-1, else 0 (the 0.1 meaning: +-1 for a horizontal line)."""

    def __init__(self, body, k, tol, part=None, tangent=None):
        mesh = body.mesh
        part = body.contact if part is None else part
        label = f"{body.name}: contact part {part!r}"
        if part not in mesh.tags:
            raise SceneError(f"{label}: unknown boundary tag; the mesh has {sorted(mesh.tags)}")
        edges = mesh.boundary(part)
        normals = mesh.outward_normals(part)
        n = normals.mean(axis=0)
        n /= np.linalg.norm(n)
        cross = np.abs(normals[:, 0] * n[1] - normals[:, 1] * n[0])     # sin of each edge's turn (arccos loses
        spread = float(np.where(normals @ n > 0, np.arcsin(np.minimum(cross, 1.0)), np.pi).max())  # digits near 0)
        if spread > _ANGLE_TOL:
            raise SceneError(f"{label} is not a straight segment: its edge normals turn by up to "
                             f"{np.degrees(spread):.3g} degrees")
        t = canonical_tangent(n) if tangent is None else np.asarray(tangent, dtype=float)
        nodes = np.unique(edges)
        order = np.argsort(mesh.points[nodes] @ t, kind="stable")
        self.nodes = read_only(nodes[order])
        self.points = read_only(mesh.points[self.nodes])
        self.x = read_only(self.points @ t)
        self.offset = float(np.mean(self.points @ n))
        off = np.ptp(self.points @ n)
        if off > tol:
            raise SceneError(f"{label} is not a straight segment (its nodes leave the line by "
                             f"{off:.3g} m)")
        self.y = float(np.mean(self.points[:, 1]))
        rank = np.empty(mesh.points.shape[0], dtype=int)
        rank[self.nodes] = np.arange(len(self.nodes))
        steps = np.sort(np.abs(np.diff(rank[edges], axis=1)).ravel())
        if len(edges) != len(self.nodes) - 1 or (steps != 1).any():
            raise SceneError(f"{label} is not one connected chain of edges (gaps or branches)")
        self.unit_normal = read_only(n)
        self.normal = float(np.round(n[1])) if abs(abs(n[1]) - 1.0) <= _ANGLE_TOL else 0.0
        self.tangent = read_only(t)
        self.k, self.part, self.body = k, part, body


class Interface:
    """Geometry and operators of one contact pair (docs/formulation.md §3-4).

    ``Interface(bodies)``: the paper's pair, each body's ``contact`` tag. ``Interface(bodies, parts)``
    names the parts; ``Interface((body,), (part,), obstacle=rigid)`` pairs one body with a rigid
    obstacle (:class:`cvxcontact.physics.pairs.Rigid`, anything with ``distance(points, normal)``).

    The pair is a straight segment in any direction: ``normal`` is the first body's unit outward
    normal nu^a (the second's is -nu^a), ``tangent`` t the shared unit tangent
    (:func:`canonical_tangent`) and s = x . t (m) the tangential coordinate. Contact lives on the
    overlap [s_lo, s_hi] of the two parts: the merged mesh ``x`` (values of s, sorted) holds the
    nodes of both traces inside the overlap, its two endpoints included; ``sigma[l]`` indexes body
    l's nodes among them; nodes outside the overlap are free. With a rigid obstacle the merged mesh
    is the body's trace where the obstacle can be reached along nu^a (a contiguous run of nodes) and
    every condition constrains all of its nodes.
    """

    dim = 2
    _partial = False  # an obstacle reaching the part only in part: lambda_h read back as r / w (multiplier)

    def __init__(self, bodies, parts=None, obstacle=None):
        bodies = tuple(bodies)
        parts = tuple(b.contact for b in bodies) if parts is None else tuple(parts)
        scale = max(b.mesh.size for b in bodies)
        tol = _REL_TOL * scale
        self.obstacle = obstacle
        first = Trace(bodies[0], 0, tol, parts[0])
        t = first.tangent
        self.normal, self.tangent = first.unit_normal, t
        if obstacle is not None:
            self._rigid(first, tol)
            return
        second = Trace(bodies[1], 1, tol, parts[1], tangent=t)
        self.traces = [first, second]
        na, nb = first.unit_normal, second.unit_normal
        if na @ nb > -1.0 + _ANGLE_TOL:
            if abs(na @ nb - 1.0) <= _ANGLE_TOL and abs(na[0]) <= _ANGLE_TOL:
                side = "below" if na[1] > 0 else "above"
                raise SceneError(f"both bodies lie {side} the contact line; they must face each other")
            raise SceneError(f"contact parts do not face each other: {bodies[0].name} {parts[0]!r} has outward "
                             f"normal ({na[0]:.6g}, {na[1]:.6g}), {bodies[1].name} {parts[1]!r} has "
                             f"({nb[0]:.6g}, {nb[1]:.6g}); a contact pair needs parallel parts with opposite normals")
        dist = float(np.mean(second.points @ na)) - first.offset
        if abs(dist) > tol:
            raise SceneError(f"contact parts are not collinear: {bodies[1].name} {parts[1]!r} lies {dist:.9g} m from "
                             f"the line of {bodies[0].name} {parts[0]!r} along its normal (mean x2: "
                             f"{bodies[0].name} at y = {first.y:.9g} m, {bodies[1].name} at y = {second.y:.9g} m)")
        # ends shared within tol take the first body's value (as cvxcontact 0.1 did)
        lo = first.x[0] if abs(first.x[0] - second.x[0]) <= tol else max(first.x[0], second.x[0])
        hi = first.x[-1] if abs(first.x[-1] - second.x[-1]) <= tol else min(first.x[-1], second.x[-1])
        if hi - lo <= tol:
            raise SceneError(
                f"contact parts do not overlap: {bodies[0].name} {parts[0]!r} spans s in [{first.x[0]:.9g}, "
                f"{first.x[-1]:.9g}] m, {bodies[1].name} {parts[1]!r} spans [{second.x[0]:.9g}, {second.x[-1]:.9g}] m "
                f"along the tangent ({t[0]:.6g}, {t[1]:.6g})")
        x, sigma = _merge(first.x, second.x, lo, hi, tol)
        self.x, self.sigma = read_only(x), tuple(read_only(s) for s in sigma)
        self.y = first.y
        self.points = read_only(first.points[0] + np.outer(self.x - first.x[0], t))
        self.mass = _mass(self.x)
        self._interp = [_interpolation(self.x, tr.x) for tr in self.traces]

    def _rigid(self, first, tol):
        """The pair of one body and a rigid obstacle: the merged mesh is the body's reachable trace."""
        self.traces = [first]
        d = np.asarray(self.obstacle.distance(first.points, first.unit_normal), dtype=float)
        label = f"{first.body.name}: contact part {first.part!r} against {self.obstacle!r}"
        if d.shape != first.x.shape or np.isnan(d).any() or (d == -np.inf).any():
            raise SceneError(f"{label}: the obstacle's distance is not a finite number or +inf at every node")
        hit = np.flatnonzero(np.isfinite(d))
        if len(hit) < 2:
            raise SceneError(f"{label}: the obstacle cannot be reached along the part's outward normal "
                             f"({self.normal[0]:.6g}, {self.normal[1]:.6g}) from at least two nodes; it does "
                             "not face the part")
        if (np.diff(hit) != 1).any():
            raise SceneError(f"{label}: the nodes that reach the obstacle along the normal are not one "
                             "contiguous run; split the part")
        self._reach(first, hit)

    def _reach(self, first, hit):
        """X_h on the trace nodes ``hit`` of ``first`` (indices, one contiguous run or not): the pair's nodes,
        mass, weights and selection."""
        self.reach = read_only(hit)
        self.x = read_only(first.x[hit])
        self.sigma = (read_only(np.arange(len(hit))),)
        self.y = first.y
        self.points = read_only(first.points[hit])
        self.mass = _mass(self.x)
        # each reaching node's hat integrated over the whole trace (the law's weights); the run's own mass
        # weighs the segments beyond its ends nothing
        self._hats = read_only(lumped_lengths(np.asarray(first.x, dtype=float))[hit])
        self._partial = len(hit) < len(first.x)
        P = sp.csr_matrix((np.ones(len(hit)), (np.arange(len(hit)), hit)), shape=(len(hit), len(first.x)))
        self._interp = [P]

    @property
    def rigid(self) -> bool:
        """True if the second side is a rigid obstacle (no mesh, no unknowns)."""
        return self.obstacle is not None

    def reaching(self, reached) -> Interface:
        """A copy of this obstacle pair whose X_h is the trace nodes ``reached`` (bool per node of its trace):
        the space in which lambda_h of several obstacles on one part is read once, from their forces summed
        (:mod:`cvxcontact.solution.sides`). Its :meth:`multiplier` and :meth:`interpolation` only."""
        out = copy(self)
        out.__dict__.pop("_row_directions", None)
        out._reach(self.traces[0], np.flatnonzero(reached))
        return out

    def obstacle_gap(self) -> np.ndarray:
        """The distance (m) from each merged node to the obstacle along nu^a (0 without an obstacle)."""
        if self.obstacle is None:
            return np.zeros(self.size)
        return np.asarray(self.obstacle.distance(self.points, self.normal), dtype=float)

    @property
    def size(self) -> int:
        """Number of merged nodes."""
        return len(self.x)

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(n_merged, 2 n_nodes) map from body k's nodal displacements to its part u^k . nu^k of
        [u_nu] = u^a . nu^a + u^b . nu^b at the merged nodes."""
        t = self.traces[k]
        return normal_jump(self._interp[k], t.nodes, row_directions(self, t.unit_normal), 2 * n_nodes)

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(n_merged, 2 n_nodes) map from body k's nodal displacements to its part of the slip
        [u_t] = (u^a - u^b) . t at the merged nodes (t the pair's tangent, :func:`row_tangents`; against a
        rigid obstacle, u^a . t)."""
        t = self.traces[k]
        return normal_jump(self._interp[k], t.nodes, row_tangents(self, k), 2 * n_nodes)

    def interpolation(self, k) -> sp.csr_matrix:
        """(n_merged, n_trace_k): evaluates P1 functions on body k's trace at the merged nodes."""
        return self._interp[k]

    def multiplier(self, r) -> np.ndarray:
        """lambda_h at the merged nodes (N/m for row forces ``r`` in N): the Riesz representer in X_h of
        psi -> sum_a r_a psi(a), i.e. M lambda_h = r (X_h is P1 on the merged mesh; docs/formulation.md §4).
        Against an obstacle that reaches the part only in part (some of its trace's nodes miss it): each row's
        force over its weight, lambda_a = r_a / w_a, w_a the reaching node's hat integrated over the whole part
        (:meth:`weights`, the law's; docs/formulation.md §10). The run's own mass weighs the segment beyond
        its end nothing, so M lambda_h = r misread there (a uniform push on obstacles reaching complementary
        runs read 0 and 3 p; forces >= 0 a pressure < 0); r / w reads a uniform pressure (forces p w_a) as p
        at every row, is >= 0 where the forces are, and keeps the total force, sum_a w_a lambda_a = sum_a r_a."""
        if self._partial:
            return np.asarray(r, dtype=float) / self._hats
        M = self.mass
        ab = np.zeros((3, M.shape[0]))
        ab[0, 1:] = M.diagonal(1)
        ab[1] = M.diagonal()
        ab[2, :-1] = M.diagonal(-1)
        return sla.solve_banded((1, 1), ab, np.asarray(r, dtype=float))

    def support(self, values) -> tuple[np.ndarray, np.ndarray]:
        """(abscissae s (m), nodal values): the line on which the P1 function of X_h with nodal ``values`` (at the
        merged nodes: lambda_h, t_h) lives on the body's trace. Against an obstacle that reaches the part only in
        part, the whole trace with 0 at the nodes the obstacle misses: each reaching node's hat over the whole
        part, as :meth:`multiplier` and :meth:`weights` read it (obstacles reaching complementary runs then sum
        to a uniform pressure on the segment between them); else the merged mesh itself."""
        values = np.asarray(values, dtype=float)
        if not self._partial:
            return np.asarray(self.x, dtype=float), values
        full = np.zeros((len(self.traces[0].x),) + values.shape[1:])
        full[self.reach] = values
        return np.asarray(self.traces[0].x, dtype=float), full

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by body k on its own trace nodes (``traces[k].nodes``): its nodal forces
        interpolation(k)^T r (N/m; exact work equivalence) over the lumped lengths of its trace."""
        return (self._interp[k].T @ np.asarray(r, dtype=float)) / lumped_lengths(self.traces[k].x)

    def evaluation(self, condition) -> sp.csr_matrix:
        """E: rows select the merged nodes where non-penetration is imposed ("sigma1"/"sigma2": the
        nodes of the pair's first/second body inside the overlap; with a rigid obstacle, every
        condition selects all merged nodes)."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if condition == "gamma3" or self.rigid:
            rows = np.arange(self.size)
        else:
            rows = self.sigma[int(condition[-1]) - 1]
        return sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)), rows)), shape=(len(rows), self.size))

    def weights(self, condition) -> np.ndarray:
        """The lumped lengths (m) of the nodes constrained under ``condition`` (the rows of
        :meth:`evaluation`): the row sums of the P1 mass matrix of the 1D mesh those nodes form
        (the merged mesh for gamma3, mesh l's nodes in the overlap for sigma_l). The quadrature
        weights of a normal-compliance energy (docs/formulation.md §10). With an obstacle each reaching
        node's hat integrated over the body's whole trace (the lumped rule with Phi 0 at the nodes the
        obstacle misses): obstacles reaching complementary runs of the trace weigh the segment between
        them once (before, the run's own mesh: that segment weighed nothing)."""
        if self.rigid:
            return np.array(self._hats)
        return lumped_lengths(self.x[self.evaluation(condition).indices])

    def extend(self, condition, values) -> np.ndarray:
        """The P1 function of the mesh of the constrained nodes under ``condition`` with nodal
        ``values`` there, evaluated at every merged node (constant beyond its end nodes)."""
        xc = self.x[self.evaluation(condition).indices]
        values = np.asarray(values, dtype=float)
        if len(xc) == self.size:
            return values.copy()
        return _interpolation(self.x, xc) @ values


class Stack:
    """The contact rows of several pairs stacked (one merged-node list per pair, concatenated).

    ``members[i]`` = (index of pair i's first body, index of its second body or None for a rigid
    obstacle) among the scene's bodies. ``jump(k, n)`` stacks body k's parts of every pair's jump
    (zero rows where it is not a member), ``mass`` is block diagonal (still tridiagonal),
    ``evaluation`` block diagonal with each pair's condition, ``offsets`` the row ranges.
    """

    def __init__(self, interfaces, members):
        self.interfaces, self.members = tuple(interfaces), tuple(members)
        self.offsets = np.concatenate([[0], np.cumsum([i.size for i in self.interfaces])]).astype(int)
        self.mass = sp.block_diag([i.mass for i in self.interfaces], format="csr")
        self.x = read_only(np.concatenate([i.x for i in self.interfaces]))

    @property
    def size(self) -> int:
        """Number of stacked merged nodes."""
        return int(self.offsets[-1])

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, d n_nodes): body k's part of [u_nu] at every pair's merged nodes (d = the pairs' ``dim``)."""
        return self._stacked(k, n_nodes, lambda itf, side: itf.jump(side, n_nodes))

    @property
    def slip_components(self) -> int:
        """Components of the slip per merged node: 1 in 2D (along t), 2 in 3D (along the pairs' frames)."""
        return self.interfaces[0].dim - 1

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(c size, d n_nodes): body k's part of the slip [u_t] at every pair's merged nodes
        (:meth:`Interface.tangential_jump`, :meth:`~cvxcontact.contact.surface.SurfaceInterface.tangential_jump`),
        c = :attr:`slip_components`, component-major (rows j size + a: component j at stacked node a). An
        interface without a tangential part (no ``tangential_jump``): UnsupportedError naming it."""
        from ..errors import UnsupportedError

        c = self.slip_components
        for itf in self.interfaces:
            if not hasattr(itf, "tangential_jump"):
                raise UnsupportedError(f"a friction law on {type(itf).__name__} contact lines is not available: "
                                       "the interface has no slip rows (tangential_jump); pose the pair without a "
                                       "friction law, or give its interface a tangential_jump(k, n_nodes)")
        parts = []
        for itf, (a, b) in zip(self.interfaces, self.members):
            side = 0 if k == a else 1 if k == b else None
            T = (itf.tangential_jump(side, n_nodes) if side is not None
                 else sp.csr_matrix((c * itf.size, itf.dim * n_nodes)))
            parts.append((T, itf.size))
        return sp.vstack([T[j * n:(j + 1) * n] for j in range(c) for T, n in parts], format="csr")

    def _stacked(self, k, n_nodes, part) -> sp.csr_matrix:
        """``part(interface, side)`` of every pair body k belongs to (side 0: first body, 1: second), zero
        rows where it is not a member, stacked."""
        rows = []
        for itf, (a, b) in zip(self.interfaces, self.members):
            if k == a:
                rows.append(part(itf, 0))
            elif k == b:
                rows.append(part(itf, 1))
            else:
                rows.append(sp.csr_matrix((itf.size, itf.dim * n_nodes)))
        return sp.vstack(rows, format="csr")

    def evaluation(self, condition, conditions=None) -> sp.csr_matrix:
        """Block-diagonal E: pair i's rows under ``conditions[i]`` (None: ``condition``)."""
        conditions = conditions or [None] * len(self.interfaces)
        return sp.block_diag([itf.evaluation(condition if c is None else c)
                              for itf, c in zip(self.interfaces, conditions)], format="csr")

    def weights(self, condition, conditions=None) -> np.ndarray:
        """The lumped lengths (m) of every pair's constrained nodes, in the row order of
        :meth:`evaluation`: pair i's :meth:`Interface.weights` under ``conditions[i]`` (None:
        ``condition``), concatenated (each pair's own 1D mesh, never the stacked abscissae)."""
        conditions = conditions or [None] * len(self.interfaces)
        return np.concatenate([itf.weights(condition if c is None else c)
                               for itf, c in zip(self.interfaces, conditions)])

    def row_offsets(self, condition, conditions=None) -> np.ndarray:
        """Row ranges of the pairs in :meth:`evaluation`: pair i owns rows offsets[i]:offsets[i+1]."""
        conditions = conditions or [None] * len(self.interfaces)
        counts = [itf.evaluation(condition if c is None else c).shape[0] for itf, c in zip(self.interfaces, conditions)]
        return np.concatenate([[0], np.cumsum(counts)]).astype(int)

    def multiplier(self, r) -> np.ndarray:
        """lambda_h of every pair (:meth:`Interface.multiplier` of its slice of the stacked row forces
        ``r`` on X_h), concatenated."""
        return np.concatenate([itf.multiplier(ri) for itf, ri in zip(self.interfaces, self.split(r))])

    def split(self, values):
        """Pair i's slice of a stacked array."""
        return [values[a:b] for a, b in zip(self.offsets[:-1], self.offsets[1:])]


def normal_jump(P, nodes, unit_normal, n_dofs) -> sp.csr_matrix:
    """(P.shape[0], n_dofs): u . nu at the nodes of X_h from a body's nodal displacements (components
    interleaved, d = the normal's length per node), with P the interpolation of its trace (columns: trace nodes
    ``nodes``) and nu its unit outward normal (d,), or one unit direction per row of P (P.shape[0], d): a rigid
    obstacle's row directions (:func:`row_directions`). Shared by the P1 and P2 contact lines and the 3D
    surfaces."""
    P = P.tocoo()
    unit_normal = np.asarray(unit_normal, dtype=float)
    d = unit_normal.shape[-1]
    N = np.broadcast_to(unit_normal, (P.shape[0], d))
    rows = np.tile(P.row, d)
    cols = np.concatenate([d * nodes[P.col] + i for i in range(d)])
    vals = np.concatenate([N[P.row, i] * P.data for i in range(d)])
    keep = vals != 0
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(P.shape[0], n_dofs))


def row_directions(interface, normal) -> np.ndarray:
    """The unit direction (d,) or directions (size, d) along which a pair's rows measure the displacement of its
    body with outward normal ``normal``: ``normal`` itself, or, against a rigid obstacle that poses its own
    directions (:meth:`cvxcontact.physics.pairs.Rigid.direction`: towards the closest point of a curved
    obstacle), those at the nodes of X_h (``interface.points``), computed once per interface."""
    obstacle = getattr(interface, "obstacle", None)
    if obstacle is None or not hasattr(obstacle, "direction"):
        return normal
    cached = interface.__dict__.get("_row_directions")
    if cached is None:
        cached = read_only(obstacle.direction(interface.points, interface.normal))
        interface.__dict__["_row_directions"] = cached
    return cached


def row_tangents(interface, k) -> np.ndarray:
    """The direction (2,) or directions (size, 2) along which a 2D pair's rows measure body k's part of the slip
    [u_t] = (u^a - u^b) . t: the pair's tangent t for the first body (k = 0), -t for the second; against a
    curved rigid obstacle, each row's direction (:func:`row_directions`) turned by +90 degrees, oriented
    like t (the tangent of the obstacle's surface at the closest point)."""
    t = np.asarray(interface.tangent, dtype=float)
    d = np.asarray(row_directions(interface, interface.normal), dtype=float)
    if d.ndim == 2:
        turned = np.column_stack([-d[:, 1], d[:, 0]])
        t = turned * np.where(turned @ t < 0, -1.0, 1.0)[:, None]
    return t if k == 0 else -t


def row_frames(interface) -> np.ndarray:
    """The two unit tangents along which a 3D pair's rows measure the first body's slip: the interface's
    ``frame`` (2, 3), or, against a curved rigid obstacle that poses its own row directions d_a
    (:func:`row_directions`), per row the frame made orthogonal to d_a (Gram-Schmidt, t1 first) (2, size, 3)."""
    frame = np.asarray(interface.frame, dtype=float)
    d = np.asarray(row_directions(interface, interface.normal), dtype=float)
    if d.ndim == 1:
        return frame
    t1 = frame[0] - (d @ frame[0])[:, None] * d
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = frame[1] - (d @ frame[1])[:, None] * d - np.einsum("ij,j->i", t1, frame[1])[:, None] * t1
    t2 /= np.linalg.norm(t2, axis=1, keepdims=True)
    return np.array([t1, t2])


def read_only(a) -> np.ndarray:
    """A read-only copy: the interface's arrays are shared by every solve and must not change."""
    a = np.array(a)
    a.setflags(write=False)
    return a


def lumped_lengths(x) -> np.ndarray:
    """Length of a 1D mesh with sorted nodes ``x`` attributed to each node (m): the row sums of its
    P1 mass matrix, half of each adjacent segment."""
    h = np.diff(x)
    w = np.zeros_like(x, dtype=float)
    w[:-1] += h / 2
    w[1:] += h / 2
    return w


def shares_to_nearest(shares, inside, points) -> np.ndarray:
    """(len(inside),) the weights of the rows at the nodes ``inside`` (indices into ``shares``) when every other
    node with a positive share gives it to the nearest node of ``inside`` (``points`` (n, d) the nodes'
    coordinates; ``shares`` (n,) e.g. the integrals over the overlap of the hats of the faces or segments its edge
    cuts, m^2 or m). The sum of ``shares`` is kept, so a constant stays integrated exactly (docs/formulation.md
    §10, §15). The one rule of the nodal weights where an overlap's edge cuts the cells of a sigma condition's
    body: 2D P2 segments (:meth:`~cvxcontact.contact.quadratic.QuadraticInterface.weights`) and 3D P2 faces
    (:meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface._overlap_hats`)."""
    from scipy.spatial import cKDTree

    shares, inside = np.asarray(shares, dtype=float), np.asarray(inside, dtype=int)
    points = np.asarray(points, dtype=float).reshape(len(shares), -1)
    out = np.setdiff1d(np.flatnonzero(shares > 0), inside)
    if len(out) == 0:
        return shares[inside]
    nearest = cKDTree(points[inside]).query(points[out])[1]
    return shares[inside] + np.bincount(nearest, weights=shares[out], minlength=len(inside))


def _merge(x1, x2, lo, hi, tol):
    """Merged abscissae on the overlap [lo, hi] and, for each trace, the indices of its nodes inside
    the overlap in the merged list. Nodes within ``tol`` of an end of the overlap are snapped to it."""
    parts = []
    for x in (x1, x2):
        x = x.copy()
        x[np.abs(x - lo) <= tol] = lo
        x[np.abs(x - hi) <= tol] = hi
        parts.append(x[(x >= lo) & (x <= hi)])
    allx = np.concatenate(parts)
    order = np.argsort(allx, kind="stable")
    new = np.concatenate([[True], np.diff(allx[order]) > 1e-3 * tol])
    index = np.empty(len(allx), dtype=int)
    index[order] = np.cumsum(new) - 1
    return allx[order][new], (index[: len(parts[0])], index[len(parts[0]):])


def _interpolation(x, xt):
    """(len(x), len(xt)) matrix evaluating the P1 function with nodes xt at the points x."""
    seg = np.clip(np.searchsorted(xt, x, side="right") - 1, 0, len(xt) - 2)
    t = np.clip((x - xt[seg]) / (xt[seg + 1] - xt[seg]), 0.0, 1.0)
    rows = np.repeat(np.arange(len(x)), 2)
    cols = np.column_stack([seg, seg + 1]).ravel()
    vals = np.column_stack([1 - t, t]).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(x), len(xt)))


def _mass(x):
    """P1 mass matrix on the 1D mesh with nodes x (m)."""
    h = np.diff(x)
    main = np.zeros(len(x))
    main[:-1] += h / 3
    main[1:] += h / 3
    return sp.diags([h / 6, main, h / 6], [-1, 0, 1], format="csr")
