"""The contact line Gamma_3 with P2 traces: merged mesh, X_h of continuous quadratics, Bernstein form.

docs/formulation.md §8. Each body's trace on Gamma_3 is piecewise quadratic on its own edges
(vertices and edge midpoints, :class:`cvxcontact.geometry.quadratic.P2Nodes`). The merged mesh is
the union of both traces' vertices; on each merged segment both traces are quadratic, so the jump
[u_h nu] lies in X_h = continuous piecewise quadratics on the merged mesh. The nodes of X_h are
numbered along the line: ``x[2 i]`` is merged vertex i, ``x[2 i + 1]`` the midpoint of segment i.

    [u_nu] = sum_l J_l U_l        at the P2 nodes of the merged mesh (exact: an evaluation)
    M                             P2 mass matrix of X_h (m)
    E                             evaluation at the P2 nodes of mesh l's trace (K_h(Sigma_h^l))
    B                             Bernstein coefficients (b0, b1, b2) of each merged segment:
                                  b0 = q(0), b2 = q(1), b1 = 2 q(1/2) - (q(0) + q(1)) / 2

With the P2 interpolant g_h of the gap, q = [u_nu] - g_h <= 0 on a whole segment iff its Bernstein
coefficients satisfy the second-order-cone condition of docs/formulation.md §8 ("gamma3").

Against a rigid obstacle the line is the body's own P2 trace where it reaches the obstacle
(:class:`QuadraticInterface` with one trace); several pairs are stacked in a :class:`QuadraticStack`
(:func:`quadratic_stack`), whose :meth:`QuadraticStack.cone_rows` poses conic and nodal pairs together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SceneError, UnsupportedError
from ..geometry.quadratic import P2Nodes
from .bernstein import bernstein_argmax, bernstein_basis, bernstein_map, bernstein_max, point_rows  # noqa: F401
from .interface import CONDITIONS, Interface, normal_jump, read_only, row_directions, row_tangents, shares_to_nearest
from .laws import RowLaws, pair_laws

__all__ = ["QuadraticInterface", "QuadraticStack", "quadratic_interface", "quadratic_stack", "p2_interpolation",
           "bernstein_max", "bernstein_argmax", "bernstein_basis", "point_rows", "ConeRowLaws", "P2Pairs", "p2_pairs",
           "ConditionRows"]

def p2_interpolation(xv, pts) -> sp.csr_matrix:
    """(len(pts), 2 len(xv) - 1): evaluates at ``pts`` the continuous P2 function on the 1D mesh with
    sorted vertices ``xv`` and interleaved nodes (vertex, midpoint, vertex, ...)."""
    seg = np.clip(np.searchsorted(xv, pts, side="right") - 1, 0, len(xv) - 2)
    t = np.clip((pts - xv[seg]) / (xv[seg + 1] - xv[seg]), 0.0, 1.0)
    vals = np.column_stack([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)])
    cols = 2 * seg[:, None] + np.arange(3)
    rows = np.repeat(np.arange(len(pts)), 3)
    M = sp.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=(len(pts), 2 * len(xv) - 1))
    M.eliminate_zeros()
    return M


class _Trace2:
    """The P2 trace of one body: vertex abscissae s (sorted along the pair's tangent), interleaved P2 node
    indices (vertex, midpoint, vertex, ...), their abscissae ``x`` and the unit outward normal."""

    def __init__(self, trace, nodes: P2Nodes):
        v = trace.nodes
        mids = nodes.midpoint(v[:-1], v[1:])
        self.k, self.normal, self.unit_normal, self.y = trace.k, trace.normal, trace.unit_normal, trace.y
        self.part = trace.part
        self.xv = trace.x
        order = np.empty(2 * len(v) - 1, dtype=int)
        order[0::2], order[1::2] = v, mids
        self.nodes = read_only(order)
        self.x = read_only(nodes.points[order] @ trace.tangent)


class QuadraticInterface:
    """Geometry and operators of one contact pair for P2 traces (module docstring): two bodies, or a body
    against a rigid obstacle (one trace).

    ``QuadraticInterface(linear, nodes, members=(0, 1))``: ``linear`` is the pair's P1
    :class:`~cvxcontact.contact.interface.Interface` (it has checked the line, the normals and the
    overlap: any straight orientation, partial overlap), ``nodes`` the :class:`P2Nodes` of its first and
    second body, ``members`` their indices among the scene's bodies. The merged vertices are the P1
    merged nodes (both traces' vertices inside the overlap); ``x`` interleaves them with the segment
    midpoints (tangential coordinate s, m). Same interface as the P1 one (``x``, ``size``, ``mass``,
    ``evaluation``, ``interpolation(k)`` and ``traces[k]`` by the pair's body k), except that
    :meth:`jump` takes the *scene's* body index (like :class:`~cvxcontact.contact.interface.Stack`),
    plus :meth:`bernstein` and ``segments``.

    A rigid obstacle (``linear.rigid``; ``nodes`` and ``members`` then name the one body, ``members =
    (k, None)``): X_h is the body's own P2 trace on the run of vertices that reach the obstacle (the P1
    merged nodes) with its edge midpoints, [u_nu] = u . nu there, and every condition constrains every
    node of X_h (as for P1); the gap g_h is the P2 interpolant of the obstacle's distance plus the pair's
    gap at those nodes (docs/formulation.md §8, "Rigid obstacles")."""

    degree = 2

    def __init__(self, linear: Interface, nodes, members=(0, 1)):
        nodes, members = tuple(nodes), tuple(members)
        if len(nodes) != len(linear.traces):
            raise SceneError(f"the P2 contact line needs the P2 nodes of each of its {len(linear.traces)} bodies, "
                             f"got {len(nodes)}")
        self.rigid, self.obstacle = linear.rigid, linear.obstacle
        self.linear, self.nodes, self.members = linear, nodes, members
        self.traces = [_Trace2(t, n) for t, n in zip(linear.traces, nodes)]
        self.y, self.normal, self.tangent = linear.y, linear.normal, linear.tangent
        xv = np.asarray(linear.x, dtype=float)
        self.xv = read_only(xv)
        x = np.empty(2 * len(xv) - 1)
        x[0::2], x[1::2] = xv, 0.5 * (xv[:-1] + xv[1:])
        self.x = read_only(x)
        self.points = read_only(linear.points[0] + np.outer(x - xv[0], linear.tangent))
        self.segments = read_only(2 * np.arange(len(xv) - 1)[:, None] + np.arange(3))   # (S, 3) node indices
        self.mass = _mass(xv)
        self._interp = [p2_interpolation(t.xv, self.x) for t in self.traces]
        # nodes of each trace inside the overlap, as points of X_h: the rows of E for K_h(Sigma_h^l)
        tol = 1e-9 * max(t.body.mesh.size for t in linear.traces)
        lo, hi = xv[0], xv[-1]
        inside = [np.flatnonzero((t.x >= lo - tol) & (t.x <= hi + tol)) for t in self.traces]
        self._sigma_at = tuple(read_only(at) for at in inside)        # their indices in the interleaved trace
        self.sigma_x = tuple(read_only(np.clip(t.x[at], lo, hi)) for t, at in zip(self.traces, inside))


    @property
    def size(self) -> int:
        """Number of P2 nodes of the merged mesh."""
        return len(self.x)

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, 2 n_nodes) map from the P2 nodal displacements of the scene's body ``k`` to its part
        u^k . nu^k of [u_nu] at the merged P2 nodes (zero if k is not a member of the pair)."""
        if k not in self.members:
            return sp.csr_matrix((self.size, 2 * n_nodes))
        t = self.traces[self.members.index(k)]
        return normal_jump(self._interp[t.k], t.nodes, row_directions(self, t.unit_normal), 2 * n_nodes)

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, 2 n_nodes) map from the P2 nodal displacements of the scene's body ``k`` to its part of the
        slip [u_t] = (u^a - u^b) . t at the merged P2 nodes (t the pair's tangent for the first body, -t for
        the second, :func:`~cvxcontact.contact.interface.row_tangents`; zero if k is not a member)."""
        if k not in self.members:
            return sp.csr_matrix((self.size, 2 * n_nodes))
        side = self.members.index(k)
        t = self.traces[side]
        return normal_jump(self._interp[t.k], t.nodes, row_tangents(self, side), 2 * n_nodes)

    def evaluation(self, condition) -> sp.csr_matrix:
        """E: rows evaluate X_h at the points where a nodal (linear) condition is imposed.

        ``"sigma1"``/``"sigma2"``: the P2 nodes of that body's trace inside the overlap (vertices and
        midpoints); ``"gamma3"``: every P2 node of the merged mesh (the nodal relaxation of the conic
        condition, used only to start or to compare; the conic condition itself is :meth:`bernstein`)."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if condition == "gamma3" or self.rigid:
            return sp.identity(self.size, format="csr")
        return p2_interpolation(self.xv, self.sigma_x[int(condition[-1]) - 1])

    def weights(self, condition) -> np.ndarray:
        """The quadrature weights (m) of a law weighted on the rows of :meth:`evaluation` (normal compliance,
        friction's capacities; docs/formulation.md §10), all positive, summing to the length of the overlap.
        ``"gamma3"`` (and an obstacle): the row sums of the P2 mass matrix of the merged P2 line (Simpson: h/6 at
        each end vertex of a segment, 2h/3 at its midpoint). ``"sigma1"``/``"sigma2"``: Simpson's on the
        segments of that body's trace with all three nodes in the overlap; on a segment the overlap's end cuts
        (some of its nodes outside), its red refinement (the segment split at its midpoint into two P1 segments)
        with the P1 hats integrated over the overlap, a node outside giving its share to the nearest node inside
        (:func:`~cvxcontact.contact.interface.shares_to_nearest`, the rule of the 3D faces'
        :meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface._cut_weights`). Where no node of that trace lies
        in the overlap the pair has no row and no weight (an empty array; the solve warns,
        :func:`~cvxcontact.solution.resolution.rowless`)."""
        xc = self._constrained(condition)
        if condition == "gamma3" or self.rigid:
            return np.asarray(_mass(xc[0::2]).sum(axis=1)).ravel()
        k = int(condition[-1]) - 1
        at, xc = self._sigma_at[k], self.sigma_x[k]
        if len(at) == 0:
            return np.zeros(0)
        a, b = at[0] % 2, len(at) - 1 - at[-1] % 2               # the run's first and last vertex
        w = np.zeros(len(at))
        if b > a:                                                # the segments with all three nodes inside
            w[a:b + 1] = np.asarray(_mass(xc[a:b + 1:2]).sum(axis=1)).ravel()
        x = np.array(self.traces[k].x, dtype=float)
        x[at] = xc
        pieces = np.setdiff1d(np.arange(len(x) - 1), np.arange(at[a], at[b])) if b > a else np.arange(len(x) - 1)
        hats = _overlap_hats(x, pieces, self.xv[0], self.xv[-1])
        return w + shares_to_nearest(hats, at, x)

    def extend(self, condition, values) -> np.ndarray:
        """The function of the constrained nodes under ``condition`` (:meth:`weights`) with nodal ``values``
        there, evaluated at every node of X_h: under "sigma1"/"sigma2" the P2 function of the mesh they form
        (constant beyond its end nodes) if they begin and end at vertices of that body's trace, else that trace's
        P2 function with its nodes outside the overlap taking the value of the nearest node inside (as on 3D
        faces, :meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.extend`)."""
        values = np.asarray(values, dtype=float)
        if condition == "gamma3" or self.rigid:
            return values.copy()
        xc = self._constrained(condition)
        if xc is not None:
            return p2_interpolation(xc[0::2], np.asarray(self.x)) @ values
        k = int(condition[-1]) - 1
        at = self._sigma_at[k]
        if len(at) == 0:                                         # no row: nothing to extend
            return np.zeros(self.size)
        nearest = np.clip(np.arange(len(self.traces[k].x)) - at[0], 0, len(at) - 1)    # the run is contiguous
        return self._interp[k] @ values[nearest]

    def _constrained(self, condition) -> np.ndarray | None:
        """Abscissae of the constrained nodes of ``condition`` if they form an interleaved P2 mesh (every node
        of X_h; under "sigma1"/"sigma2" if that body's nodes in the overlap begin and end at vertices of its
        trace), else None (:meth:`weights`; also where no node of that trace lies in the overlap)."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        if condition == "gamma3" or self.rigid:
            return np.asarray(self.x)
        k = int(condition[-1]) - 1
        at = self._sigma_at[k]
        if len(at) >= 3 and at[0] % 2 == 0 and at[-1] % 2 == 0:
            return self.sigma_x[k]
        return None

    def bernstein(self) -> sp.csr_matrix:
        """(3 S, size) map from nodal values of X_h to the Bernstein coefficients, rows (b0, b1, b2) of
        segment 0, then segment 1, ..."""
        return bernstein_map(self.segments, self.size)

    def multiplier(self, r) -> np.ndarray:
        """lambda_h (N/m for forces ``r`` in N) at the nodes of X_h: M lambda_h = r (docs/formulation.md §8)."""
        return spla.spsolve(self.mass.tocsc(), np.asarray(r, dtype=float))

    def reaching(self, reached) -> QuadraticInterface | None:
        """A copy of this obstacle pair whose X_h is the P2 line of the trace's nodes ``reached`` (bool per P2 node
        of its trace, interleaved): the space in which lambda_h of several obstacles on one part is read once, from
        their forces summed (:mod:`cvxcontact.solution.sides`); None unless they are one run from vertex to
        vertex (a P2 line)."""
        reached = np.asarray(reached, dtype=bool)
        v = np.flatnonzero(reached[0::2])
        if len(v) < 2 or (np.diff(v) != 1).any() or not reached[2 * v[0]:2 * v[-1] + 1].all():
            return None
        vertices = np.zeros(len(self.linear.traces[0].x), dtype=bool)
        vertices[v] = True
        return type(self)(self.linear.reaching(vertices), self.nodes, self.members)

    @staticmethod
    def shares(selections, closed=None) -> list[np.ndarray]:
        """Per obstacle pair on one part (``selections``: each one's 0/1 (size_i, trace nodes), one run from vertex
        to vertex), the share of each trace node's lambda_h in its values. Its function lives on its run's
        segments alone, so on each segment the shares of the runs holding it sum to 1: a node inside C runs 1 / C
        for them (a midpoint is inside every run holding its segment) and 0 for the runs that end or start there;
        a vertex inside none 1 / A for the A runs ending there and 1 / B for the B starting there. ``closed`` (per
        pair, 1 per trace node where its contact is closed, or None): of the runs holding the same segments at a
        node (inside; ending; starting) those closed there take its share, one over their number, where one is
        (an obstacle open at a node, its force 0, takes none; the sums per segment kept): a floor open under a
        strip raised above it leaves the strip's nodes to the strip, as on P1 and 3D P2 faces. A run's first or
        last vertex inside another run stays with that run even where it is open there: the segment beyond is that
        run's alone and its function, continuous, reaches the vertex with the side's value (forced by the pairs'
        spaces, whatever the split; tests/test_p2_run_vertex.py)."""
        j = np.arange(selections[0].shape[1])
        held = [np.flatnonzero(np.asarray(abs(s).sum(axis=0)).ravel() > 0.5) for s in selections]
        lo, hi = (np.array([h[k] for h in held])[:, None] for k in (0, -1))
        inside, ends, starts = (lo < j) & (j < hi), (hi == j) & (lo < j), (lo == j) & (hi > j)
        alone = inside.sum(axis=0) == 0
        groups = (inside, ends & alone, starts & alone)
        if closed is None:
            return list(sum(m / np.maximum(m.sum(axis=0), 1) for m in groups))
        on = np.array([np.asarray(c, dtype=float) > 0.5 for c in closed])
        # per group at each node: the closed runs of it, where it has one, else all of it
        share = [np.where((m & on).any(axis=0), m & on, m) for m in groups]
        return list(sum(m / np.maximum(m.sum(axis=0), 1) for m in share))

    def support(self, values) -> tuple[np.ndarray, np.ndarray]:
        """(abscissae s (m), nodal values): the line on which the P2 function of X_h with nodal ``values`` lives,
        X_h itself (against an obstacle reaching the part only in part, the run's own P2 line, as
        :meth:`multiplier` reads it; 0 beyond it)."""
        return np.asarray(self.x, dtype=float), np.asarray(values, dtype=float)

    def interpolation(self, k) -> sp.csr_matrix:
        """(size, n_trace_k): evaluates P2 functions on the pair's body k's trace at the merged P2 nodes."""
        return self._interp[k]


def quadratic_interface(scene, nodes) -> QuadraticInterface:
    """The :class:`QuadraticInterface` of a scene with one contact pair (two of its bodies, or one body and a
    rigid obstacle; ``nodes[k]``: the P2 nodes of the scene's body k). Several pairs: UnsupportedError
    (:func:`quadratic_stack` takes them)."""
    if len(scene.interfaces) != 1:
        raise UnsupportedError(f"P2 elements (degree=2) with {len(scene.interfaces)} contact pairs are not "
                               "supported here (one pair only); use degree=1")
    return _pair(scene, nodes, 0)


def quadratic_stack(scene, nodes):
    """The P2 contact line of every pair of ``scene``: its :class:`QuadraticInterface` when it has one pair,
    else a :class:`QuadraticStack` of one per pair (``nodes[k]``: the P2 nodes of the scene's body k)."""
    if len(scene.interfaces) == 1:
        return _pair(scene, nodes, 0)
    return QuadraticStack([_pair(scene, nodes, i) for i in range(len(scene.interfaces))], scene.stack.members)


class P2Pairs:
    """What the contact pairs of a P2 scene pose (docs/formulation.md §8, §10), one place for
    :class:`~cvxcontact.solve.ContactSolver` and :class:`~cvxcontact.model.Model`.

    ``interface`` is the scene's :class:`QuadraticInterface` (one pair) or :class:`QuadraticStack`, ``stack``
    always a stack; per pair i: ``conditions[i]`` (its own, else the one given), ``laws[i]``, ``conic[i]``
    (a Signorini "gamma3" pair: the cone at g) and ``limited[i]`` (a compliant "gamma3" pair with a
    penetration limit l: the cone at g + l). Without a compliance law the scene is ``conic_only`` if some
    pair is conic (the nodal pairs' rows then posed as degenerate cones, :meth:`QuadraticStack.cone_rows`);
    with one, the cone pairs (``cone_pairs``) join the compliance energy in one program."""

    def __init__(self, interface, stack, conditions, laws, conic, limited):
        self.interface, self.stack = interface, stack
        self.conditions, self.laws = tuple(conditions), tuple(laws)
        self.conic, self.limited = tuple(conic), tuple(limited)
        self.compliant = any(lw.compliant for lw in self.laws)
        self.cone_pairs = [c or lim for c, lim in zip(self.conic, self.limited)] if self.compliant else None
        self.conic_only = any(self.conic) and not self.compliant


def p2_pairs(scene, nodes, condition: str, law) -> P2Pairs:
    """The :class:`P2Pairs` of ``scene`` (``nodes[k]``: the P2 nodes of body k; ``condition`` and ``law``
    those given to ``solve``/``Model``, each pair's own taking precedence). A pair under a sigma condition with
    no row in the overlap has no row for its law either (the solve warns: ResolutionWarning)."""
    interface = quadratic_stack(scene, nodes)
    stack = interface if isinstance(interface, QuadraticStack) else QuadraticStack([interface], scene.stack.members)
    conditions = [c or condition for c in scene.conditions]
    laws = pair_laws(scene, law)
    conic, limited = [], []
    for cond, lw in zip(conditions, laws):
        conic.append(cond == "gamma3" and not lw.compliant)      # compliance: nodal rows (§10)
        limited.append(cond == "gamma3" and lw.compliant and lw.penetration_limit is not None)
    return P2Pairs(interface, stack, conditions, laws, conic, limited)


def _pair(scene, nodes, i) -> QuadraticInterface:
    a, b = scene.stack.members[i]
    if b is None:
        return QuadraticInterface(scene.interfaces[i], (nodes[a],), (a, None))
    return QuadraticInterface(scene.interfaces[i], (nodes[a], nodes[b]), (a, b))


class QuadraticStack:
    """The P2 contact lines of several pairs stacked (the P2 counterpart of
    :class:`~cvxcontact.contact.interface.Stack`): the nodes of X_h of pair 0, then pair 1, ...

    ``interfaces[i]`` is pair i's :class:`QuadraticInterface`, ``members[i]`` its (first body, second body
    or None) among the scene's bodies, ``offsets`` the node ranges. ``jump(k, n)`` stacks the scene's body
    k's part of every pair's jump; ``mass``, ``evaluation`` and :meth:`bernstein` are block diagonal (pair
    i's rows under its own condition), ``segments`` the stacked (S, 3) node indices of every merged
    segment."""

    degree = 2

    def __init__(self, interfaces, members):
        self.interfaces, self.members = tuple(interfaces), tuple(members)
        self.offsets = np.concatenate([[0], np.cumsum([i.size for i in self.interfaces])]).astype(int)
        self.mass = sp.block_diag([i.mass for i in self.interfaces], format="csr")
        self.x = read_only(np.concatenate([i.x for i in self.interfaces]))
        self.segments = read_only(np.concatenate([i.segments + o for i, o in zip(self.interfaces, self.offsets)]))

    @property
    def size(self) -> int:
        """Number of stacked P2 nodes."""
        return int(self.offsets[-1])

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(size, 2 n_nodes): the scene's body k's part of [u_nu] at every pair's P2 nodes (zero rows where
        k is not a member)."""
        return sp.vstack([itf.jump(k, n_nodes) for itf in self.interfaces], format="csr")

    @property
    def slip_components(self) -> int:
        """Components of the slip per node: 1 on 2D lines (along t), 2 on 3D surfaces (along the pairs' frames)."""
        return getattr(self.interfaces[0], "slip_components", 1)

    def tangential_jump(self, k, n_nodes) -> sp.csr_matrix:
        """(c size, d n_nodes): the scene's body k's part of the slip [u_t] at every pair's P2 nodes
        (:meth:`QuadraticInterface.tangential_jump`,
        :meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.tangential_jump`), c = :attr:`slip_components`,
        component-major (rows j size + a: component j at stacked node a)."""
        c = self.slip_components
        parts = [(itf.tangential_jump(k, n_nodes), itf.size) for itf in self.interfaces]
        return sp.vstack([T[j * n:(j + 1) * n] for j in range(c) for T, n in parts], format="csr")

    def _each(self, condition, conditions):
        conditions = conditions or [None] * len(self.interfaces)
        return [condition if c is None else c for c in conditions]

    def evaluation(self, condition, conditions=None) -> sp.csr_matrix:
        """Block-diagonal E: pair i's rows (:meth:`QuadraticInterface.evaluation`) under ``conditions[i]``
        (None: ``condition``)."""
        return sp.block_diag([itf.evaluation(c) for itf, c in zip(self.interfaces, self._each(condition, conditions))],
                             format="csr")

    def weights(self, condition, conditions=None) -> np.ndarray:
        """Pair i's :meth:`QuadraticInterface.weights` under its condition, concatenated (m)."""
        return np.concatenate([itf.weights(c) for itf, c in zip(self.interfaces, self._each(condition, conditions))])

    def row_offsets(self, condition, conditions=None) -> np.ndarray:
        """Row ranges of the pairs in :meth:`evaluation`: pair i owns rows offsets[i]:offsets[i+1]."""
        counts = [itf.evaluation(c).shape[0] for itf, c in zip(self.interfaces, self._each(condition, conditions))]
        return np.concatenate([[0], np.cumsum(counts)]).astype(int)

    def bernstein(self) -> sp.csr_matrix:
        """(3 S, size): every pair's :meth:`QuadraticInterface.bernstein`, block diagonal."""
        return sp.block_diag([itf.bernstein() for itf in self.interfaces], format="csr")

    def bernstein_of(self, pairs):
        """(B, segments) of the "everywhere" condition on the pairs marked in ``pairs`` (a boolean per pair):
        B (3 S, size) maps the stacked nodes of X_h to the Bernstein coefficients of those pairs' merged
        segments (pair by pair, :meth:`QuadraticInterface.bernstein`; zero columns on the other pairs' nodes),
        ``segments`` (S, 3) their stacked node indices. The conic rows of a scene mixing conic pairs with
        normal-compliance pairs (docs/formulation.md §10, "P2")."""
        pairs = [bool(p) for p in pairs]
        if len(pairs) != len(self.interfaces):
            raise SceneError(f"bernstein_of: {len(pairs)} flags for {len(self.interfaces)} pairs")
        blocks = [itf.bernstein() if on else sp.csr_matrix((0, itf.size))
                  for itf, on in zip(self.interfaces, pairs)]
        segs = [np.asarray(getattr(itf, "cone_cells", itf.segments)) + o             # 3D: with its nodal cells
                for itf, o, on in zip(self.interfaces, self.offsets, pairs) if on]
        width = np.asarray(self.interfaces[0].segments).shape[1]
        segments = np.concatenate(segs) if segs else np.zeros((0, width), dtype=int)
        return sp.block_diag(blocks, format="csr"), read_only(segments)

    def split(self, values):
        """Pair i's slice of a stacked array."""
        return [values[a:b] for a, b in zip(self.offsets[:-1], self.offsets[1:])]

    def multiplier(self, r) -> np.ndarray:
        """lambda_h of every pair (its ``multiplier`` of its slice of the stacked forces ``r``), concatenated."""
        return np.concatenate([itf.multiplier(ri) for itf, ri in zip(self.interfaces, self.split(r))])

    def cone_rows(self, condition, conditions=None):
        """(B, segments): the conic rows of every pair when some pairs are under "gamma3" and others under a
        nodal condition (docs/formulation.md §8, "Several pairs"). A "gamma3" pair contributes its
        :meth:`QuadraticInterface.bernstein` rows and ``segments``; a nodal pair each row e of its
        :meth:`QuadraticInterface.evaluation` three times, (b0, b1, b2) = (e q, e q, e q), the Bernstein
        coefficients of the constant e q, which the cone holds non-positive iff e q <= 0: exactly the nodal
        row; its "segment" is the (up to three) nodes of X_h that row reads, the first repeated to fill
        three. B is (3 S, size) on the stacked nodes of X_h, ``segments`` (S, 3) stacked node indices. On 3D
        surfaces (triangles, 6 coefficients each) the same with six: a nodal row repeated six times is the
        constant e q on a degenerate triangle, whose copositive condition is e q <= 0."""
        w = np.asarray(self.interfaces[0].segments).shape[1]
        blocks, segs = [], []
        for itf, c, o in zip(self.interfaces, self._each(condition, conditions), self.offsets):
            if c == "gamma3":
                blocks.append(itf.bernstein())
                segs.append(np.asarray(getattr(itf, "cone_cells", itf.segments)) + o)     # 3D: with its nodal cells
                continue
            E = itf.evaluation(c).tocsr()
            blocks.append(sp.csr_matrix(E[np.repeat(np.arange(E.shape[0]), w)]))
            seg = np.empty((E.shape[0], w), dtype=int)
            for r in range(E.shape[0]):
                cols = E.indices[E.indptr[r]:E.indptr[r + 1]]
                seg[r] = np.resize(cols, w) if len(cols) else 0
            segs.append(seg + o)
        return sp.block_diag(blocks, format="csr"), read_only(np.concatenate(segs))

    def row_cone(self, condition, conditions=None):
        """(B, cells): :meth:`cone_rows` on the rows of :meth:`evaluation` E instead of the nodes of X_h, so that
        B E is :meth:`cone_rows`' B and its cells are the same elements in the same order. A "gamma3" pair's rows
        are its nodes of X_h (E the identity there): its :meth:`QuadraticInterface.bernstein` rows and cells,
        indexed by row; a nodal pair's row a (three times in 2D, six in 3D) is the degenerate element of the
        constant e_a q, its cell the row a repeated. A friction law's rows are the rows of E (its capacities on
        their own weights, :meth:`weights`): beside a nodal pair the cones then sit on those rows
        (docs/howto/friction.md, "P2 under 'gamma3'")."""
        w = np.asarray(self.interfaces[0].segments).shape[1]
        blocks, cells = [], []
        conditions = self._each(condition, conditions)
        for itf, c, o in zip(self.interfaces, conditions, self.row_offsets(condition, conditions)[:-1]):
            E = itf.evaluation(c)
            if c == "gamma3":
                if E.shape != (itf.size, itf.size) or (E - sp.identity(itf.size)).count_nonzero():
                    raise SceneError("row_cone: a 'gamma3' pair's rows must be its nodes of X_h")
                blocks.append(itf.bernstein())
                cells.append(np.asarray(getattr(itf, "cone_cells", itf.segments)) + o)
                continue
            m = E.shape[0]
            blocks.append(sp.identity(m, format="csr")[np.repeat(np.arange(m), w)])
            cells.append(np.repeat(np.arange(m), w).reshape(m, w) + o)
        return sp.block_diag(blocks, format="csr"), read_only(np.concatenate(cells))


@dataclass(frozen=True, eq=False)
class ConditionRows:
    """What the P2 elements of a scene answer under each pair's condition, beside the rows its space poses
    (``lines.element`` of :class:`~cvxcontact.fem.space.ContactLines`): the contact term of a combination of laws
    asks it for the rows its laws need (:meth:`~cvxcontact.discrete.terms.ContactTerm.own_lines`; a friction law
    under the cones: the cones on E's rows; the cones beside a compliance law: the cone pairs' Bernstein map).

    ``stack``: the pairs' :class:`QuadraticStack` (its rows; lambda_h is read by the lines' ``interface``);
    ``conditions``: each pair's condition; ``on_cone`` (rows of E,): with a compliance law, whether each row is a
    row of a pair under the cone (a Signorini "gamma3" pair's, a limited compliant "gamma3" pair's nodes of X_h;
    docs/formulation.md §10, §16), None without one."""

    stack: QuadraticStack
    conditions: tuple
    on_cone: np.ndarray | None = None

    def evaluation(self) -> sp.csr_matrix:
        """E: the rows of the pairs' conditions on the stacked nodes of X_h (:meth:`QuadraticStack.evaluation`)."""
        return self.stack.evaluation(None, list(self.conditions))

    def row_counts(self) -> np.ndarray:
        """The rows of E per pair (:meth:`QuadraticStack.row_offsets`)."""
        return np.diff(self.stack.row_offsets(None, list(self.conditions)))

    def row_cone(self) -> tuple:
        """(B, cells): the cones of the conic condition on E's rows (:meth:`QuadraticStack.row_cone`)."""
        return self.stack.row_cone(None, list(self.conditions))

    def cones_of(self, pairs) -> tuple:
        """(B, segments): the "everywhere" cones of the pairs marked in ``pairs`` on the nodes of X_h
        (:meth:`QuadraticStack.bernstein_of`)."""
        return self.stack.bernstein_of(pairs)


class ConeRowLaws(RowLaws):
    """The :class:`~cvxcontact.contact.laws.RowLaws` of a P2 scene whose conic pairs sit next to
    normal-compliance pairs (docs/formulation.md §10, "P2"). ``cone`` marks the rows of the pairs whose
    condition is the "everywhere" cone of §8 rather than nodal rows: a Signorini "gamma3" pair (the cone at
    g) and a compliant "gamma3" pair with a penetration limit l (the cone at g + l). On those rows
    ``penetration_limit`` is ``inf`` (no nodal row r <= l: the cone holds instead) and ``cone_shift`` is the
    shift of the cone's gap (m: 0 on a Signorini pair, l on a limited compliant one; 0 on the other rows).
    Stiffness, exponent, pressure and energy are those of :class:`RowLaws` (0 on Signorini rows)."""

    def __init__(self, laws, counts, cone):
        super().__init__(laws, counts)
        cone = np.asarray(cone, dtype=bool)
        if cone.shape != (self.size,):
            raise SceneError(f"ConeRowLaws: {cone.shape} cone flags for {self.size} rows")
        limit = np.asarray(self.penetration_limit)
        pair = np.repeat(np.arange(len(self.counts)), self.counts)
        on_pair = (np.bincount(pair, weights=cone, minlength=len(self.counts)) > 0)[pair]
        self.cone = cone
        self.cone_shift = np.where(cone & np.isfinite(limit), limit, 0.0)
        self.penetration_limit = np.where(on_pair, np.inf, limit)    # the cone holds a cone pair's limit
        for a in (self.cone, self.cone_shift, self.penetration_limit):
            a.setflags(write=False)

    def off_cone(self) -> RowLaws:
        """The :class:`RowLaws` of the rows off the cone (``~cone``, in order): per pair its rows off the cone, a
        cone pair's law without its penetration limit (the cone holds it: 3D P2, a limited compliant "gamma3"
        pair's quadrature rows)."""
        from dataclasses import replace

        at = np.concatenate([[0], np.cumsum(self.counts)]).astype(int)
        laws, counts = [], []
        for lw, a, b in zip(self.laws, at[:-1], at[1:]):
            n = int((~self.cone[a:b]).sum())
            if n:
                laws.append(replace(lw, penetration_limit=None) if lw.compliant and self.cone[a:b].any() else lw)
                counts.append(n)
        return RowLaws(laws, counts)

    def scaled(self, pressure: float, displacement: float) -> "ConeRowLaws":
        """The same rows in units of ``pressure`` (Pa) and ``displacement`` (m), cone flags kept."""
        return ConeRowLaws([law.scaled(pressure, displacement) if law.compliant else law for law in self.laws],
                           self.counts, self.cone)


def _overlap_hats(x, pieces, lo, hi) -> np.ndarray:
    """(len(x),) m: the integrals over the overlap [lo, hi] of the P1 hats of the 1D mesh with sorted nodes ``x``
    restricted to its segments ``pieces`` (piece i from x[i] to x[i + 1]; the red refinement of a P2 line is the
    P1 line through all its nodes): exact, the hats being affine on each piece. Non-negative; they sum to the
    length of the overlap the pieces cover."""
    p, q = x[pieces], x[pieces + 1]
    c, d = np.clip(lo, p, q), np.clip(hi, p, q)
    span = q - p
    mid = 0.5 * (c + d - 2 * p) / np.where(span > 0, span, 1.0)          # the hat of x[i + 1] at the middle
    length = d - c
    return (np.bincount(pieces, weights=length * (1 - mid), minlength=len(x))
            + np.bincount(pieces + 1, weights=length * mid, minlength=len(x)))


def _mass(xv):
    """P2 mass matrix (m) of the 1D mesh with vertices ``xv`` (interleaved node numbering)."""
    h = np.diff(xv)
    local = np.array([[4.0, 2.0, -1.0], [2.0, 16.0, 2.0], [-1.0, 2.0, 4.0]]) / 30.0
    seg = 2 * np.arange(len(h))[:, None] + np.arange(3)
    rows = np.repeat(seg, 3, axis=1).ravel()
    cols = np.tile(seg, (1, 3)).ravel()
    vals = (h[:, None, None] * local).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * len(xv) - 1,) * 2)
