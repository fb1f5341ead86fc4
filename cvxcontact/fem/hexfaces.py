"""The contact rows of Q1 hexahedra between two bodies' faces: bilinear traces on planar pairs, matching, nested
and aligned faces, lambda_h of hexahedral pairs (:class:`LumpedPressure`), and the refusals where a hexahedral
space's rows would not be exact (docs/formulation.md §13, docs/howto/quadrilaterals.md); Q2 faces' pairs:
:mod:`cvxcontact.fem.q2faces`.

The contact code of :class:`~cvxcontact.contact.surface.SurfaceInterface` works on the faces' triangles
(``HexMesh.triangulation``); a Q1 trace is bilinear on each quadrilateral face, not affine on its triangles.
:class:`BilinearSurface` keeps the pair's overlay (its vertices are the nodes of X_h) and evaluates each trace
there by its bilinear faces, so a row at a body's node reads the other body's Q1 trace exactly.

"gamma3" (non-penetration everywhere on Gamma_3) reduces to nodal rows where the jump is bilinear on known
quadrilaterals, whose corners then decide: matching faces (every vertex of X_h a node of both traces) and
nested faces (:func:`nesting`): every face q of the finer side that meets the overlap lies in it and in one face
Q of the coarser side, as the image under Q's bilinear map of a rectangle of Q's reference square with edges
along its axes (on parallelograms: q's edges parallel to Q's; any refinement of Q by its edge midpoints and
centre, aligned grids 2:1 in one or both directions). Then Q's map restricted to q is q's own (both bilinear,
equal at the corners), the coarse trace on q is bilinear in q's reference coordinates, and so is the jump
(fine trace minus coarse trace, along the plane's fixed normal): a bilinear function on a square attains its
minimum at a corner, so the rows at the fine side's nodes (:class:`NestedSurface`: "gamma3" posed as the fine
side's "sigma" rows, no row at the overlay's other vertices, which would be redundant and dependent) are
non-penetration everywhere on the overlap. The gap those rows read is the pair's g at the fine nodes, so the
condition holds everywhere for g's bilinear interpolant on the fine faces: g itself for a constant gap or any g
affine in the plane (two flat parts, parallel or not).

Faces that do not nest but are all parallelograms with edges along two common directions (aligned grids of any
ratio, 3 on 2, a coarse face overhanging a finer part: :func:`pieces`) are rectangles in the affine coordinates
of those directions; where a face of one side meets a face of the other, the piece is a rectangle on which both
traces, and the jump, are bilinear: :class:`CrossingSurface` poses "gamma3" at the pieces' corners (more rows
than the jump has degrees of freedom: they may depend on each other, the exact finish takes that; their forces
are not unique, the pressure each body feels is). General quadrilaterals that cross are refused
(:func:`hex_contact`): the jump is not bilinear on the pieces there.

A normal-compliance law (:func:`law_weights`) sits on the same rows, integrated by the lumped (corner) rule
where the jump is bilinear: the constrained side's hats over its faces on the overlap on matching and nested
faces (the finer side's rows, under "gamma3" or its own nodal condition), a quarter of each piece's area at its
corners on aligned parallelograms ("gamma3"; those rows may depend on each other, :func:`dependent_law_rows`).
The coarser side's rows on nested faces and nodal rows on crossing faces read a jump that is not bilinear on the
constrained faces: there the law is the lumped rule of the constrained side's hats integrated over the overlap
(:func:`_overlap_hats`), a consistent approximation rather than an exact integral. On Q2 faces the law sits on
the nodal rows with the biquadratic hats' integrals (:class:`~cvxcontact.fem.q2faces.SimpsonSurface`; a friction law's
capacities too).

lambda_h on hexahedral faces (:class:`LumpedPressure`): the consistent representer in the P1 functions of the
faces' triangles, which the simplices' read-back solves, is not the Q1 trace's: for a uniform pressure p the Q1
rows carry p times the bilinear hats' integrals (A/4 per face corner) while that P1 mass weighs the corners on a
triangle diagonal A/3 and the others A/6, and it read 0.42 p to 2.2 p (a 3 x 3 face grid). Every Q1 pair
reads lambda_h as the pressure the constrained side feels, each node's work-equivalent force over its hat's
integral, interpolated by the bilinear faces at the nodes of X_h: exact for a uniform pressure, non-negative
where the forces are. The pairs take it through their public hook
(:meth:`~cvxcontact.contact.riesz.Represented.with_representer`). On faces that do not match, under a nodal
condition, the side whose nodes carry no row feels the rows' pressures interpolated by the constrained side's faces
(:class:`FeltFromRows`, shared with Q2's :class:`~cvxcontact.fem.q2faces.BiquadraticRows`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..contact.interface import shares_to_nearest
from ..contact.overlay import locate
from ..contact.surface import SurfaceInterface
from ..errors import UnsupportedError
from .hex import bilinear_rows, face_hats, reference_points
from .simplex import simplex_rule
from .trace import LinearTrace

__all__ = ["FACE_TRACE", "NESTED_TOL", "BilinearSurface", "CrossingSurface", "FaceTrace", "FeltFromRows",
           "LumpedPressure", "NestedSurface", "Nesting", "Pieces", "constrained_side", "dependent_law_rows",
           "hex_contact", "hex_pair", "independent_rows", "law_weights", "located_hats", "matching", "nesting",
           "pieces"]

NESTED_TOL = 1e-8
"""How far (in the reference square [-1, 1]^2 of a coarse face, 2 wide) a fine face's corner may sit off the
rectangle of :func:`nesting`, and the relative area a fine face may miss of the overlap or spill over a second
coarse face, for the faces to count as nested."""


def matching(itf) -> bool:
    """True if every node of X_h of the two-body pair ``itf`` is a node of both traces (faces matching corner to
    corner, on the overlap)."""
    return all(len(nodes) == itf.size for nodes in itf.sigma)


def _corners(trace) -> np.ndarray:
    """(k, 4): the corners of the quadrilateral faces of ``trace`` (indices into ``trace.nodes``, in order around
    each face; face q's triangles are 2 q, 2 q + 1 of ``trace.faces``)."""
    return np.searchsorted(trace.nodes, trace.body.mesh.boundary(trace.part))


class BilinearSurface(SurfaceInterface):
    """The two-body :class:`~cvxcontact.contact.surface.SurfaceInterface` ``itf`` (its overlay, its nodes of X_h)
    with each trace evaluated at the nodes of X_h by its Q1 faces' bilinear functions instead of the P1
    functions of the faces' triangles: the nodal rows "sigma1"/"sigma2" (a body's nodes, located on the other
    body's faces) are then the Q1 jump exactly. Each vertex is located in an overlay triangle and with it in a
    triangle of each trace, whose face is that triangle's quadrilateral."""

    def __init__(self, itf, side: int | None = None):
        ov = itf.overlay
        triangles = np.asarray(ov.triangles)
        host = np.empty(itf.size, dtype=np.int64)
        host[triangles.ravel()] = np.repeat(np.arange(len(triangles)), 3)
        rows = []
        for trace, cell in zip(itf.traces, (ov.cell_a, ov.cell_b)):
            corners = _corners(trace)
            rows.append(bilinear_rows(trace.x[corners], corners, np.asarray(cell)[host] // 2,
                                      np.asarray(ov.vertices), len(trace.nodes)))
        self.__dict__.update(vars(itf.with_interpolation(rows)))
        self.side, self._felt = side, {}

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by the pair's body k on its own trace nodes (``traces[k].nodes``) under the row
        forces ``r`` (N; at the nodes of X_h). Posed under side ``side``'s nodal condition (:func:`hex_pair`), the
        other side (its nodes are no rows) reads the rows' pressures interpolated by the constrained side's
        bilinear faces, normalised over the rows (:class:`FeltFromRows`; q_a = r_a / w_a, w the rows'
        :func:`law_weights`): a uniform p read p at every node in the overlap, a finer other side included. Its
        work-equivalent forces over its hats' integrals (the constrained side's read,
        :meth:`SurfaceInterface.pressure <cvxcontact.contact.surface.SurfaceInterface.pressure>`) read a uniform
        p as 0 at the 16 of the 25 nodes of a 4 x 4 side over 2 x 2 rows that hold no row and 4 p at the others
        (0 at 20 of 36 over 5 x 5; docs/formulation.md §15)."""
        if self.side is None or k == self.side:
            return super().pressure(k, r)
        if k not in self._felt:
            t = self.traces[self.side]
            corners = _corners(t)
            rows = np.asarray(self.sigma[self.side])
            at = np.asarray(self.overlay.node_a if self.side == 0 else self.overlay.node_b)
            node = np.empty(self.size, dtype=np.int64)
            node[at[at >= 0]] = np.flatnonzero(at >= 0)          # each row's node of X_h as a node of that side
            hats = located_hats(t, self.traces[k].x, node[rows], lambda y, face: bilinear_rows(
                np.asarray(t.x)[corners], corners, face, y, len(t.nodes)))
            self._felt[k] = FeltFromRows(hats, law_weights(self, f"sigma{self.side + 1}"))
        return self._felt[k](np.asarray(r, dtype=float)[np.asarray(self.sigma[self.side])])


@dataclass(frozen=True)
class Nesting:
    """Whether the faces of a two-body pair are nested (:func:`nesting`): ``fine`` the finer side (0 or 1), None
    if they are not; ``faces`` the fine side's faces on the overlap (indices into its ``mesh.boundary(part)``);
    ``reason`` why not (per side tried), empty if nested."""

    fine: int | None
    faces: np.ndarray
    reason: str = ""


def nesting(itf, tol: float = NESTED_TOL) -> Nesting:
    """Whether the faces of the two-body pair ``itf`` are nested (module docstring): for a side l, every face of
    l that meets the overlap (its overlay triangles of area above ``tol`` of the face's) lies in it (they cover
    the face to ``tol`` of its area) and in one face Q of the other side, its corners at reference points of Q
    (Newton on Q's bilinear map) such that each of its edges runs along an axis of Q's reference square (the
    smaller of its steps in the two reference coordinates at most ``tol``). Side 0 is tried first."""
    ov = itf.overlay
    P = np.asarray(ov.vertices)[np.asarray(ov.triangles)]
    area = 0.5 * np.abs(plane_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    cells = (np.asarray(ov.cell_a) // 2, np.asarray(ov.cell_b) // 2)
    reasons = []
    for fine in (0, 1):
        trace, other = itf.traces[fine], itf.traces[1 - fine]
        name = f"{trace.body.name} {trace.part!r}"
        corners = _corners(trace)
        X = np.asarray(trace.x)[corners]                                            # (k, 4, 2)
        size = 0.5 * np.abs(plane_cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]))           # the faces' areas
        q, Q = cells[fine], cells[1 - fine]
        keep = area > tol * size[q]
        links = np.unique(np.column_stack([q[keep], Q[keep]]), axis=0)
        hosts = np.bincount(links[:, 0], minlength=len(X))
        if (hosts > 1).any():
            f = int(np.argmax(hosts))
            reasons.append(f"face {f} of {name} lies across {hosts[f]} faces of the other side")
            continue
        faces = np.flatnonzero(hosts == 1)
        covered = np.bincount(q, weights=area, minlength=len(X))[faces]
        short = np.abs(covered - size[faces]) > tol * size[faces]
        if short.any():
            f = int(faces[np.argmax(short)])
            reasons.append(f"face {f} of {name} lies partly outside the overlap")
            continue
        host = np.empty(len(X), dtype=np.int64)
        host[links[:, 0]] = links[:, 1]
        coarse = np.asarray(other.x)[_corners(other)]
        xi = reference_points(coarse, np.repeat(host[faces], 4), X[faces].reshape(-1, 2)).reshape(-1, 4, 2)
        steps = np.abs(np.roll(xi, -1, axis=1) - xi).min(axis=2).max(axis=1)      # each edge off the axes
        if (steps > tol).any():
            f = int(np.argmax(steps))
            reasons.append(f"face {int(faces[f])} of {name} is not a rectangle of its face {int(host[faces[f]])} of "
                           f"the other side in that face's bilinear coordinates (an edge off its axes by "
                           f"{steps[f]:.3g} of the reference square)")
            continue
        return Nesting(fine, faces)
    return Nesting(None, np.zeros(0, dtype=np.int64), "; ".join(reasons))


def _side_hats(itf, side, faces) -> np.ndarray:
    """(size,) m^2: at each node of X_h of the two-body pair ``itf`` that is a node of side ``side``, the integral
    of that node's Q1 hat over the side's faces ``faces`` (indices into its ``mesh.boundary(part)``: its faces on
    the overlap; 2 x 2 Gauss on each face's bilinear map, exact on planar faces); 0 at the other nodes."""
    trace = itf.traces[side]
    hats = face_hats(trace.points, _corners(trace)[faces], 1)
    at = np.asarray(itf.overlay.node_a if side == 0 else itf.overlay.node_b)
    out = np.zeros(itf.size)
    out[at[at >= 0]] = hats[at >= 0]
    return out


def _overlap_hats(itf, side) -> np.ndarray:
    """(size,) m^2: at each node of X_h of the two-body pair ``itf`` that is a node of side ``side``, the integral
    over the overlap of that node's Q1 hat on the side's faces, a node of those faces outside the overlap giving
    its share to the nearest node inside (:func:`~cvxcontact.contact.interface.shares_to_nearest`, the rule of the
    P2 faces the overlap's edge cuts); 0 at the other nodes. Each overlay triangle lies in one face of the side;
    the hats are integrated on it by the degree-4 triangle rule (their reference points by Newton on the face's
    bilinear map): exact on parallelogram faces (a hat is then quadratic in the plane), and the weights sum to the
    overlap's area on any faces. Positive where a hat meets the overlap: the law's weights at the constrained
    side's nodes where the jump is not bilinear on its faces (the other side's trace read at them)."""
    ov, trace = itf.overlay, itf.traces[side]
    points, weights = triangles_rule(ov, 4)
    corners = _corners(trace)
    host = np.repeat(np.asarray(ov.cell_a if side == 0 else ov.cell_b) // 2, weights.shape[1])
    N = bilinear_rows(np.asarray(trace.x)[corners], corners, host, points, len(trace.nodes))
    hats = N.T @ weights.ravel()
    at = np.asarray(ov.node_a if side == 0 else ov.node_b)
    inside = np.flatnonzero(at >= 0)
    out = np.zeros(itf.size)
    out[at[inside]] = shares_to_nearest(hats, inside, np.asarray(trace.x))
    return out


def triangles_rule(ov, degree: int):
    """(points (t m, 2), weights (t, m) m^2): the degree-``degree`` triangle rule on each triangle of the overlay
    ``ov`` (its points in the plane, triangle by triangle; its weights times the triangle's area)."""
    P = np.asarray(ov.vertices)[np.asarray(ov.triangles)]                     # (t, 3, 2)
    area = 0.5 * np.abs(plane_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    L, w = simplex_rule(2, degree)
    return np.einsum("mi,tid->tmd", L, P).reshape(-1, 2), np.outer(area, w)


def _faces_on_overlap(itf, side, tol: float = NESTED_TOL) -> np.ndarray:
    """The faces of side ``side`` of the two-body pair ``itf`` (indices into its ``mesh.boundary(part)``) that
    meet its overlap: an overlay triangle of area above ``tol`` of the face's."""
    ov = itf.overlay
    P = np.asarray(ov.vertices)[np.asarray(ov.triangles)]
    area = 0.5 * np.abs(plane_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    X = np.asarray(itf.traces[side].x)[_corners(itf.traces[side])]
    size = 0.5 * np.abs(plane_cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]))
    q = np.asarray(ov.cell_a if side == 0 else ov.cell_b) // 2
    return np.unique(q[area > tol * size[q]])


def plane_cross(a, b) -> np.ndarray:
    """The z component of the cross product of in-plane vectors ``a``, ``b`` (..., 2)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


class NestedSurface(BilinearSurface):
    """A :class:`BilinearSurface` on nested faces (:func:`nesting`, side ``fine`` the finer): "gamma3" is posed
    as the fine side's nodal rows ("sigma1" for side 0, "sigma2" for side 1; the module docstring says why they
    are the condition everywhere on the overlap), a row's quadrature weight (``weights``: the pressure
    read-back, a friction law's capacity) the integral over the overlap of the fine side's bilinear hat."""

    def __init__(self, itf, nested: Nesting):
        super().__init__(itf)
        self.fine, self._faces = nested.fine, nested.faces

    def _nodal(self, condition) -> str:
        return f"sigma{self.fine + 1}" if condition == "gamma3" else condition

    def _rows(self, condition) -> np.ndarray:
        return super()._rows(self._nodal(condition))

    def weights(self, condition) -> np.ndarray:
        """The fine side's Q1 hats integrated over its faces on the overlap (m^2; 2 x 2 Gauss on each face's
        bilinear map, exact on planar faces) at the rows of "gamma3"; the rows of "sigma1"/"sigma2" as
        :meth:`SurfaceInterface.weights <cvxcontact.contact.surface.SurfaceInterface.weights>`."""
        if condition != "gamma3":
            return super().weights(condition)
        return _side_hats(self, self.fine, self._faces)[self._rows(condition)]

    def extend(self, condition, values) -> np.ndarray:
        return super().extend(self._nodal(condition), values)


@dataclass(frozen=True)
class Pieces:
    """The pieces of a two-body pair whose faces are parallelograms with edges along two common directions
    (:func:`pieces`): ``rows`` the nodes of X_h at the pieces' corners (None if the faces are not such
    parallelograms), ``weights`` (m^2) a quarter of each piece's area summed at each of them, ``reason`` why not."""

    rows: np.ndarray | None
    weights: np.ndarray
    reason: str = ""


def pieces(itf, tol: float = NESTED_TOL) -> Pieces:
    """Whether every face on the overlap of the two-body pair ``itf`` (both sides; the faces with an overlay
    triangle of area above ``tol`` of theirs) is a parallelogram with edges along the two edge directions d1, d2
    of the first such face of side 0 (in the coordinates (a, b) of x = a d1 + b d2 each edge runs along an axis to
    ``tol`` of the face's extent): every face is then a rectangle in (a, b), each trace bilinear in (a, b) on it,
    and where a face q of one side meets a face Q of the other the piece q n Q is a rectangle on which the jump
    is bilinear, decided at its four corners. Those corners are vertices of the overlay (where the faces' edges
    cross, or their corners); the rows of "gamma3" are there, not at the vertices where the triangles' diagonals
    cross."""
    ov = itf.overlay
    V = np.asarray(ov.vertices)
    P = V[np.asarray(ov.triangles)]
    area = 0.5 * np.abs(plane_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    X = [np.asarray(t.x)[_corners(t)] for t in itf.traces]                        # (k, 4, 2) per side
    size = [0.5 * np.abs(plane_cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])) for x in X]
    cells = (np.asarray(ov.cell_a) // 2, np.asarray(ov.cell_b) // 2)
    keep = (area > tol * size[0][cells[0]]) & (area > tol * size[1][cells[1]])
    links = np.unique(np.column_stack([cells[0][keep], cells[1][keep]]), axis=0)
    first = X[0][links[0, 0]]
    B = np.column_stack([first[1] - first[0], first[3] - first[0]])               # (d1 d2)
    rects = []
    for side, x in enumerate(X):
        faces = np.unique(links[:, side])
        ab = np.einsum("ij,kvj->kvi", np.linalg.inv(B), x[faces] - first[0])      # (f, 4, 2) in (a, b)
        lo, hi = ab.min(axis=1), ab.max(axis=1)
        off = np.abs(np.roll(ab, -1, axis=1) - ab).min(axis=2).max(axis=1) / (hi - lo).min(axis=1)
        if (off > tol).any():
            f = int(faces[np.argmax(off)])
            t = itf.traces[side]
            return Pieces(None, np.zeros(0), f"face {f} of {t.body.name} {t.part!r} is not a parallelogram with "
                          f"edges along those of the other faces (off by {off.max():.3g} of its size)")
        full_lo, full_hi = np.zeros((len(x), 2)), np.zeros((len(x), 2))
        full_lo[faces], full_hi[faces] = lo, hi
        rects.append((full_lo, full_hi))
    lo = np.maximum(rects[0][0][links[:, 0]], rects[1][0][links[:, 1]])
    hi = np.minimum(rects[0][1][links[:, 0]], rects[1][1][links[:, 1]])
    corners = np.stack([lo, np.column_stack([hi[:, 0], lo[:, 1]]), hi, np.column_stack([lo[:, 0], hi[:, 1]])], axis=1)
    points = first[0] + corners.reshape(-1, 2) @ B.T
    h = np.sqrt(min(size[0].min(), size[1].min()))
    dist, at = cKDTree(V).query(points)
    if dist.max() > 1e-6 * h:                  # not expected: the pieces' corners are where the faces' edges cross
        return Pieces(None, np.zeros(0), f"a corner of the pieces is {dist.max():.3g} m from every overlay vertex")
    quarter = np.repeat(np.prod(hi - lo, axis=1) * abs(np.linalg.det(B)) / 4, 4)
    rows = np.unique(at)
    return Pieces(rows, np.bincount(at, weights=quarter, minlength=len(V))[rows])


class CrossingSurface(BilinearSurface):
    """A :class:`BilinearSurface` whose faces are parallelograms along two common directions (:func:`pieces`):
    "gamma3" is posed at the corners of the pieces where faces of the two sides meet (the jump is bilinear on
    each piece), a row's weight a quarter of the area of each piece it is a corner of."""

    def __init__(self, itf, cut: Pieces):
        super().__init__(itf)
        self._cut = cut

    def _rows(self, condition) -> np.ndarray:
        rows = super()._rows(condition)
        return np.asarray(self._cut.rows) if condition == "gamma3" else rows

    def weights(self, condition) -> np.ndarray:
        """The rows' areas (m^2): under "gamma3" a quarter of each piece's area at each of its corners (they sum
        to the overlap's area); under "sigma1"/"sigma2" as :meth:`SurfaceInterface.weights
        <cvxcontact.contact.surface.SurfaceInterface.weights>`."""
        return np.array(self._cut.weights) if condition == "gamma3" else super().weights(condition)

    def extend(self, condition, values) -> np.ndarray:
        """``values`` at the rows of ``condition`` at every node of X_h: under "gamma3" the nodes without a row
        (where the triangles' diagonals cross) take the value of the nearest row; otherwise as
        :meth:`SurfaceInterface.extend <cvxcontact.contact.surface.SurfaceInterface.extend>`."""
        if condition != "gamma3":
            return super().extend(condition, values)
        rows = np.asarray(self._cut.rows)
        x = np.asarray(self.x)
        return np.asarray(values, dtype=float)[cKDTree(x[rows]).query(x)[1]]


class LumpedPressure:
    """lambda_h of a hexahedral pair (module docstring): ``solve(r)`` for the row forces ``r`` at the nodes of X_h
    (N) is P (P^T r / w) (Pa), P (size, n) the interpolation of the constrained side's trace at the nodes of X_h
    (its bilinear or biquadratic faces) and w (n,) its nodes' hat integrals on its faces (m^2): the pressure that
    side feels at the nodes of X_h."""

    def __init__(self, interp, weights) -> None:
        self.interp, self.weights = interp, np.asarray(weights, dtype=float)

    def solve(self, r) -> np.ndarray:
        return self.interp @ ((self.interp.T @ np.asarray(r, dtype=float)) / self.weights)


class FeltFromRows:
    """The pressure (Pa) the side of a two-body hexahedral pair on faces that do not match whose nodes carry no row
    feels (docs/formulation.md §15): ``felt(r)`` for the row forces ``r`` (rows,) N is, at each node b of that
    side, p_b = sum_a tau_a(x_b) q_a / sum_a tau_a(x_b), q_a = r_a / w_a the rows' pressures (``weights`` (rows,)
    m^2: the consistent loads of a unit pressure at the rows, positive; 0 where a weight is 0) and tau_a
    (``hats`` (v, rows): :func:`located_hats`) the constrained side's faces' hats of the rows' nodes at x_b (Q1:
    its bilinear functions; Q2: the Q1 functions of its faces split 2 x 2, positive); 0 at a node on no
    constrained face or whose hats hold no row. A weighted mean of the row pressures of the constrained face
    holding the node: non-negative where the forces are, between their least and largest, a uniform p (forces
    p w_a) read p at every node inside the overlap, a finer side included. It does not keep the total force by
    that side's own hats' integrals."""

    def __init__(self, hats, weights) -> None:
        self.hats, self.weights = sp.csr_matrix(hats), np.asarray(weights, dtype=float)
        self.held = np.asarray(self.hats.sum(axis=1)).ravel()

    def __call__(self, r) -> np.ndarray:
        q = np.divide(np.asarray(r, dtype=float), self.weights, out=np.zeros(len(self.weights)),
                      where=self.weights > 0)
        on = self.held > 0
        out = np.zeros(len(self.held))
        out[on] = (self.hats @ q)[on] / self.held[on]
        return out


def located_hats(trace, x, columns, hats) -> sp.csr_matrix:
    """(v, len(columns)) sparse: the hats ``hats`` of the faces of the hexahedral ``trace`` (``hats(points (m, 2),
    faces (m,))``: (m, n) sparse over ``trace.nodes``, point i in face ``faces[i]`` of its ``mesh.boundary``) at
    the in-plane points ``x`` (v, 2) m, each in the face its triangles hold it in (face q's triangles 2 q, 2 q +
    1 of ``trace.faces``), their columns ``columns`` (indices into ``trace.nodes``); a row of 0 at a point on no
    face."""
    x = np.asarray(x, dtype=float)
    tri, _ = locate(x, np.asarray(trace.x), np.asarray(trace.faces)[:, :3])
    on = np.flatnonzero(tri >= 0)
    place = sp.csr_matrix((np.ones(len(on)), (on, np.arange(len(on)))), shape=(len(x), len(on)))
    return (place @ hats(x[on], tri[on] // 2)).tocsc()[:, np.asarray(columns)].tocsr()


def constrained_side(pair, condition: str) -> int:
    """The side whose nodes carry the rows of ``pair`` under ``condition`` (the obstacle's pairs: 0)."""
    if isinstance(pair, NestedSurface) and condition == "gamma3":
        return pair.fine
    return 1 if condition == "sigma2" and not pair.rigid else 0


def hex_pair(itf, condition: str):
    """The pair of ``itf`` whose rows a Q1 hexahedral space poses under ``condition`` (the pair's own): ``itf``
    against a rigid obstacle and on matching faces; under "gamma3" a :class:`NestedSurface` on nested faces, else
    a :class:`CrossingSurface` on parallelograms along common directions; a :class:`BilinearSurface` otherwise.
    Each as the copy that reads lambda_h by :class:`LumpedPressure` (``with_representer``; ``itf`` unchanged)."""
    pair = None
    if itf.rigid or matching(itf):
        pair = itf
    elif condition == "gamma3":
        nested = nesting(itf)
        if nested.fine is not None:
            pair = NestedSurface(itf, nested)
        else:
            cut = pieces(itf)
            if cut.rows is not None:
                pair = CrossingSurface(itf, cut)
    pair = pair if pair is not None else BilinearSurface(itf, constrained_side(itf, condition))
    side = constrained_side(pair, condition)
    return pair.with_representer(LumpedPressure(pair.interpolation(side), pair.traces[side].lumped))


def law_weights(pair, condition: str, compliant: bool = True) -> np.ndarray:
    """The quadrature weights (m^2) of a normal-compliance law (docs/formulation.md §10) at the rows of the Q1
    pair ``pair`` (:func:`hex_pair`) under ``condition``: positive, the law integrated where the jump is bilinear
    on known faces. Two bodies, matching faces and nested faces under "gamma3" or the finer side's own nodal
    condition (the same rows): the integrals of the constrained side's Q1 hats over its faces on the overlap
    (on nested faces each inside one face of the other side, :func:`nesting`), so that the sum is the lumped
    (corner) rule of int psi([u_nu] - g) on every such face, and the weights sum to the overlap's area; aligned
    parallelograms under "gamma3": a quarter of each piece's area at each of its corners (:attr:`Pieces.weights`,
    the same rule on each piece); under a nodal condition on other faces (crossing grids, the coarser side of
    nested faces) the constrained side's hats integrated over the overlap (:func:`_overlap_hats`: the jump is not
    bilinear on its faces, a consistent lumped rule); a rigid obstacle: the body's hats over its part
    (``mesh.node_areas``).
    ``compliant`` False (a Signorini pair beside compliant ones: no law reads its weights): the constrained
    side's hats over its part at its rows."""
    if condition == "gamma3" and isinstance(pair, (NestedSurface, CrossingSurface)):
        return pair.weights(condition)
    side = constrained_side(pair, condition)
    rows = pair.evaluation(condition).indices
    if compliant and not pair.rigid:
        if not matching(pair) and nesting(pair).fine != side:          # the jump is not bilinear on its faces
            return _overlap_hats(pair, side)[rows]
        return _side_hats(pair, side, _faces_on_overlap(pair, side))[rows]
    hats = np.asarray(pair.traces[side].lumped)               # mesh.node_areas: the Q1 hats' face integrals
    if pair.rigid:
        node = np.asarray(pair.reach)
    else:                                 # every row's node of X_h is a node of the constrained side
        at = np.asarray(pair.overlay.node_a if side == 0 else pair.overlay.node_b)
        node = np.empty(pair.size, dtype=np.int64)
        node[at[at >= 0]] = np.flatnonzero(at >= 0)
    return hats[node[rows]]


def dependent_law_rows(pairs, conditions, laws) -> bool:
    """Whether a normal-compliance law of ``laws`` sits on rows of the Q1 ``pairs`` (each under its condition in
    ``conditions``) that may depend on each other: the "gamma3" rows of a :class:`CrossingSurface`, at the
    pieces' corners (more than the jump's degrees of freedom: the interface compliance W is singular on them,
    :attr:`~cvxcontact.fem.space.ContactLines.dependent`)."""
    return any(isinstance(p, CrossingSurface) and c == "gamma3" and lw.compliant
               for p, c, lw in zip(pairs, conditions, laws))


def independent_rows(pairs, conditions, condition: str) -> bool:
    """Whether the "gamma3" rows of the two-body ``pairs`` (each pair's own condition in ``conditions``, else
    ``condition``) are known to be linearly independent: there are some, and every such pair is a
    :class:`NestedSurface` (one row per node of the finer side, and each row the only one that reads its node)."""
    nested = [isinstance(p, NestedSurface) for p, c in zip(pairs, conditions)
              if (c or condition) == "gamma3" and not p.rigid]
    return bool(nested) and all(nested)


class FaceTrace(LinearTrace):
    """The trace of Q1 hexahedra on the contact surfaces: :class:`~cvxcontact.fem.trace.LinearTrace`, keeping in a
    :class:`~cvxcontact.solution.solution.Solution` the pairs the rows were posed on where they are not the
    scene's own (:class:`BilinearSurface`: the read-back's pressures, measures and felt pressures are then the
    bilinear traces')."""

    def kept(self, interface):
        pairs = getattr(interface, "interfaces", None) or (interface,)
        return interface if any(isinstance(p, BilinearSurface) for p in pairs) else None


FACE_TRACE = FaceTrace()


def hex_contact(space, scene, condition, law=None):
    """UnsupportedError for the contact a hexahedral space does not pose exactly (the spaces' docstrings): curved
    parts; on Q1, "gamma3" against a curved obstacle (its gap is not bilinear on a face: the corners do not
    decide), "gamma3" between faces that neither match corner to corner, nest (:func:`nesting`) nor are
    parallelograms along common directions (:func:`pieces`); on Q2, "gamma3" and faces that are not
    parallelograms (the centre off the diagonal's midpoint). A normal-compliance law
    is taken wherever its condition is (``law``, kept for the spaces' call: :func:`law_weights` on Q1,
    :class:`~cvxcontact.fem.q2faces.SimpsonSurface` on Q2)."""
    alternative = "tetrahedra (cc.box(..., cell='tetra'))"
    if space.degree == 2:
        conditions = [c or condition for c in scene.conditions]
        if "gamma3" in conditions:
            raise UnsupportedError("'gamma3' on Q2 (27-node) hexahedra is not available (the biquadratic trace's "
                                   "condition everywhere on a face): use condition='sigma1' (nodal rows), degree=1 "
                                   f"(Q1 hexahedra) or {alternative}, P2 with degree=2")
        for i, itf in enumerate(scene.interfaces):
            for t in itf.traces:
                X = t.body.mesh.points[t.body.mesh.boundary(t.part)]
                skew = np.abs(X[:, 0] + X[:, 2] - X[:, 1] - X[:, 3]).max()
                if skew > 1e-9 * t.body.mesh.size:
                    raise UnsupportedError(f"contacts[{i}] {scene.contacts[i]!r}: {t.body.name}'s contact faces "
                                           f"are not parallelograms (off by {skew:.3g} m): contact on Q2 hexahedra "
                                           f"needs them; use degree=1 (Q1 hexahedra) or {alternative}")
    for i, (itf, c) in enumerate(zip(scene.interfaces, scene.conditions)):
        c = c or condition
        label = f"contacts[{i}] {scene.contacts[i]!r}"
        if getattr(itf, "curved", None) is not None:
            raise UnsupportedError(f"{label}: a curved contact part of hexahedra is not available: use {alternative}")
        if itf.rigid:
            if c == "gamma3" and getattr(itf.obstacle, "kind", None) != "plane":   # Q2: refused above
                raise UnsupportedError(f"{label}: 'gamma3' on Q1 hexahedra against a curved obstacle is not exact "
                                       "(its gap is not bilinear on a face): use condition='sigma1' (nodal rows) or "
                                       f"{alternative}")
            continue
        if matching(itf):
            continue
        what = f"the contact faces of the two hexahedral bodies do not match corner to corner ({itf.size} nodes " \
               f"of X_h, {len(itf.sigma[0])} and {len(itf.sigma[1])} of them the bodies' nodes)"
        if c == "gamma3":
            nested = nesting(itf)
            cut = pieces(itf) if nested.fine is None else None
            if cut is not None and cut.rows is None:
                raise UnsupportedError(f"{label}: {what}, are not nested ({nested.reason}) and are not parallelograms "
                                       f"along common directions ({cut.reason}): 'gamma3' on Q1 hexahedra is posed "
                                       "where the bilinear jump is decided at known points: matching faces, nested "
                                       "faces (each face of the finer side inside one face of the other, a rectangle "
                                       "of it in its bilinear coordinates) and parallelogram faces along two common "
                                       "directions (any grids aligned with each other). Use condition='sigma1' "
                                       "(nodal rows), mesh the two faces alike, nested or aligned, or use "
                                       f"{alternative}")
