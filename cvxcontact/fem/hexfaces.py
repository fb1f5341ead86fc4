"""The contact rows of Q1 hexahedra between two bodies' faces: bilinear traces on planar pairs, matching, nested
and aligned faces, Q2 faces (:class:`SimpsonSurface`, :class:`BiquadraticRows`), and the refusals where a hexahedral
space's rows would not be exact (docs/formulation.md §13, docs/howto/quadrilaterals.md).

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
the nodal rows with the biquadratic hats' integrals (:class:`SimpsonSurface`; a friction law's capacities too).

lambda_h on hexahedral faces (:class:`LumpedPressure`): the consistent representer in the P1 functions of the
faces' triangles, which the simplices' read-back solves, is not the Q1 trace's: for a uniform pressure p the Q1
rows carry p times the bilinear hats' integrals (A/4 per face corner) while that P1 mass weighs the corners on a
triangle diagonal A/3 and the others A/6, and it read 0.42 p to 2.2 p (a 3 x 3 face grid). Every Q1 pair
reads lambda_h as the pressure the constrained side feels, each node's work-equivalent force over its hat's
integral, interpolated by the bilinear faces at the nodes of X_h: exact for a uniform pressure, non-negative
where the forces are. The pairs take it through their public hook
(:meth:`~cvxcontact.contact.riesz.Represented.with_representer`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..contact.interface import shares_to_nearest
from ..contact.overlay import locate, overlay
from ..contact.quadratic import QuadraticStack
from ..contact.quadratic3d import QuadraticSurface, _p2_mass
from ..contact.surface import SurfaceInterface
from ..errors import UnsupportedError
from ..geometry.quadratic import Q2HexNodes
from .hex import bilinear_rows, face_hats, reference_points
from .quad import QuadElement
from .simplex import simplex_rule
from .trace import LinearTrace

__all__ = ["FACE_TRACE", "NESTED_TOL", "BilinearSurface", "BiquadraticRows", "CrossingSurface", "FaceTrace",
           "LumpedPressure", "NestedSurface", "Nesting", "Pieces", "SimpsonSurface", "constrained_side",
           "dependent_law_rows", "hex_contact", "hex_pair", "independent_rows", "law_weights", "matching", "nesting",
           "pieces", "q2_pair", "quadratic_pressures", "simpson_lumped"]

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

    def __init__(self, itf):
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
    area = 0.5 * np.abs(_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    cells = (np.asarray(ov.cell_a) // 2, np.asarray(ov.cell_b) // 2)
    reasons = []
    for fine in (0, 1):
        trace, other = itf.traces[fine], itf.traces[1 - fine]
        name = f"{trace.body.name} {trace.part!r}"
        corners = _corners(trace)
        X = np.asarray(trace.x)[corners]                                            # (k, 4, 2)
        size = 0.5 * np.abs(_cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]))           # the faces' areas
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
    points, weights = _triangles_rule(ov, 4)
    corners = _corners(trace)
    host = np.repeat(np.asarray(ov.cell_a if side == 0 else ov.cell_b) // 2, weights.shape[1])
    N = bilinear_rows(np.asarray(trace.x)[corners], corners, host, points, len(trace.nodes))
    hats = N.T @ weights.ravel()
    at = np.asarray(ov.node_a if side == 0 else ov.node_b)
    inside = np.flatnonzero(at >= 0)
    out = np.zeros(itf.size)
    out[at[inside]] = shares_to_nearest(hats, inside, np.asarray(trace.x))
    return out


def _triangles_rule(ov, degree: int):
    """(points (t m, 2), weights (t, m) m^2): the degree-``degree`` triangle rule on each triangle of the overlay
    ``ov`` (its points in the plane, triangle by triangle; its weights times the triangle's area)."""
    P = np.asarray(ov.vertices)[np.asarray(ov.triangles)]                     # (t, 3, 2)
    area = 0.5 * np.abs(_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    L, w = simplex_rule(2, degree)
    return np.einsum("mi,tid->tmd", L, P).reshape(-1, 2), np.outer(area, w)


def _faces_on_overlap(itf, side, tol: float = NESTED_TOL) -> np.ndarray:
    """The faces of side ``side`` of the two-body pair ``itf`` (indices into its ``mesh.boundary(part)``) that
    meet its overlap: an overlay triangle of area above ``tol`` of the face's."""
    ov = itf.overlay
    P = np.asarray(ov.vertices)[np.asarray(ov.triangles)]
    area = 0.5 * np.abs(_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    X = np.asarray(itf.traces[side].x)[_corners(itf.traces[side])]
    size = 0.5 * np.abs(_cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]))
    q = np.asarray(ov.cell_a if side == 0 else ov.cell_b) // 2
    return np.unique(q[area > tol * size[q]])


def _cross(a, b) -> np.ndarray:
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
    area = 0.5 * np.abs(_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    X = [np.asarray(t.x)[_corners(t)] for t in itf.traces]                        # (k, 4, 2) per side
    size = [0.5 * np.abs(_cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])) for x in X]
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


class SimpsonSurface(QuadraticSurface):
    """The :class:`~cvxcontact.contact.quadratic3d.QuadraticSurface` of a pair of Q2 (27-node) hexahedral faces
    (posed on the faces' 6-node triangles, ``Q2HexNodes.triangulation``; matching parallelogram faces or a rigid
    obstacle: :func:`hex_contact`) whose normal-compliance law sits on the nodal rows themselves, integrated by
    the biquadratic faces' own rule: the energy sum_a w_a Phi(r_a) over the rows a of :meth:`evaluation`, w_a the
    integral of node a's biquadratic hat over the constrained side's faces all of whose 9 nodes are rows (3 x 3
    Gauss on the faces' bilinear maps: on a parallelogram of area A the tensor Simpson weights A/36 at a corner,
    4A/36 at an edge midpoint, 16A/36 at the centre; positive, they sum to the faces' area and integrate a
    biquadratic function exactly, docs/formulation.md §10); between two bodies the faces the overlap's edge cuts
    add their nodes' piecewise bilinear hats over the overlap (:meth:`law_weights`). The tetrahedra's rule on the
    faces' triangles (:meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.quadrature`) would integrate the P2
    functions of the triangles, not the biquadratic trace, and the P2 functions of a face's corners integrate to 0
    on its triangles (a corner would penetrate for free)."""

    def law_weights(self, condition) -> np.ndarray:
        """(rows,) m^2: w_a at the rows of :meth:`evaluation` under ``condition`` ("sigma1"/"sigma2" on two bodies,
        any condition against an obstacle). Between two bodies the faces the overlap's edge cuts (some of their 9
        nodes outside it) add their nodes' piecewise bilinear hats integrated over the overlap (:func:`_cut_hats`),
        a node outside giving its share to the nearest row (``shares_to_nearest``, as the P2 faces' and Q1's): the
        weights sum to the overlap's area (before, those faces weighed nothing: a block whose face lies inside
        such faces went through the law with no force). Against an obstacle 0 at a row on no face whose 9 nodes
        all reach it."""
        if not self.rigid and condition not in ("sigma1", "sigma2"):
            raise UnsupportedError(f"a normal-compliance law on Q2 hexahedral faces sits on nodal rows "
                                   f"('sigma1', 'sigma2'), not {condition!r}")
        side = 0 if self.rigid else int(condition[-1]) - 1
        if ("law", side) not in self._factors:                  # kept: quadrature, row_mass and the read-back ask
            t = self.traces[side]
            faces = np.searchsorted(t.nodes, Q2HexNodes(t.body.mesh).boundary(t.part))     # (k, 9) into t.nodes
            at = np.asarray(self.reach) if self.rigid else np.asarray(self.sigma_rows(side))
            row = np.zeros(len(t.nodes), dtype=bool)
            row[at] = True
            whole = row[faces].all(axis=1)
            hats = face_hats(t.points, faces[whole], 2)
            self._factors[("law", side)] = hats[at] if self.rigid else \
                shares_to_nearest(hats + _cut_hats(self, side, faces, whole), at, t.x)
        return self._factors[("law", side)].copy()

    def weights(self, condition) -> np.ndarray:
        """(rows,) m^2: the rows' areas that weigh friction capacities g w_a and the shear read over them: the
        biquadratic hats' integrals (A/36, 4A/36, 16A/36; positive, summing to the faces' area), a uniform shear's
        consistent loads (it sticks from g = tau; the triangles' red lumping only from 16/9 tau). Two bodies:
        :meth:`law_weights`; an obstacle: :func:`simpson_lumped` at the nodes that reach it (howto/friction.md)."""
        if self.rigid:
            return simpson_lumped(self.traces[0])[np.asarray(self.reach)]
        return self.law_weights(condition)

    def quadrature(self, condition) -> tuple[sp.csr_matrix, np.ndarray]:
        """(Q (k, rows), w (k,) m^2): the rows of :meth:`evaluation` of positive :meth:`law_weights` (Q selects
        them) and those weights: the law's energy sum_a w_a Phi(r_a), its nodal forces w_a p(r_a)."""
        w = self.law_weights(condition)
        on = np.flatnonzero(w > 0)
        return sp.csr_matrix((np.ones(len(on)), (np.arange(len(on)), on)), shape=(len(on), len(w))), w[on]

    def row_mass(self, condition) -> sp.csr_matrix:
        """(rows, rows) m^2: the diagonal of :meth:`law_weights` (the lumped mass of the biquadratic faces), so that
        the law's pressure (:meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.law_pressure`) is each row's
        force over its weight: p(r_a) (exact for a uniform pressure, whose consistent loads are p w_a)."""
        return sp.diags(self.law_weights(condition)).tocsr()

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by the pair's body k on its own trace nodes (``traces[k].nodes``): its nodal
        forces interpolation(k)^T r (N; exact work equivalence) over its biquadratic hats' integrals over its
        part (:func:`simpson_lumped`), as Q1's over its bilinear hats' (docs/checks.md, "The pressure views").
        Exact for a uniform pressure on faces the rows' weights cover (its consistent loads are p w_a); the
        Riesz representer in the P2 functions of the faces' triangles, which P2 tetrahedra read, is not the
        biquadratic trace's: it made a uniform p read 0.07 p to 4.5 p, negative on faces that do not match."""
        key = ("felt", k)
        if key not in self._factors:
            self._factors[key] = simpson_lumped(self.traces[k])
        return (self._interp[k].T @ np.asarray(r, dtype=float)) / self._factors[key]


class BiquadraticRows(SimpsonSurface):
    """A Q2 pair whose faces do not match, under the nodal condition of side ``side`` ("sigma1" for 0, "sigma2" for
    1): the rows at that side's 9-node face nodes inside the overlap, each reading the other side's biquadratic
    trace where the node lies on its faces (as :class:`BilinearSurface` reads a bilinear one). X_h is the
    constrained side's P2 trace on its faces' 6-node triangles wholly in the overlap (``x`` its nodes inside the
    overlap, ``cells`` those triangles, ``mass`` their P2 mass); its own interpolation is the identity on those
    nodes, the other side's the 9 biquadratic functions of its face holding each node (reference coordinates by
    Newton on the face's bilinear map: exact on the parallelograms :func:`hex_contact` asks for). The rows are
    then the Q2 jump at the constrained nodes exactly; the condition of the other side is not posed here."""

    def __init__(self, linear, nodes, members, side: int):
        super().__init__(linear, nodes, members)
        t, other = self.traces[side], self.traces[1 - side]
        inside = np.asarray(self._sigma[side][0])
        at = np.full(len(t.nodes), -1)
        at[inside] = np.arange(len(inside))
        faces = np.asarray(t.faces)
        cells = at[faces[(at[faces] >= 0).all(axis=1)]]
        self.side, self.x, self.cells = side, t.x[inside], cells
        self.x.setflags(write=False)
        self.cells.setflags(write=False)
        P = self.x[cells[:, :3]]
        area = 0.5 * np.abs(_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
        self.mass = _p2_mass(cells, area, len(inside)).tocsr()
        n = len(inside)
        own = sp.csr_matrix((np.ones(n), (np.arange(n), inside)), shape=(n, len(t.nodes)))
        self._interp = [None, None]
        self._interp[side], self._interp[1 - side] = own, _biquadratic_rows(other, self.x)
        self._sigma = [None, None]
        self._sigma[side] = (inside, sp.identity(n, format="csr"))
        self._sigma[1 - side] = (np.zeros(0, dtype=np.int64), sp.csr_matrix((0, n)))
        self._factors = {}
        self.points = self.offset * np.asarray(self.normal) + self.x @ np.asarray(self.frame)
        self.points.setflags(write=False)

    def evaluation(self, condition) -> sp.csr_matrix:
        """The identity on X_h (the constrained side's nodes) under its own nodal condition; any other condition
        is not posed on this pair (UnsupportedError)."""
        if condition != f"sigma{self.side + 1}":
            raise UnsupportedError(f"a Q2 pair on faces that do not match is posed under 'sigma{self.side + 1}', "
                                   f"its constrained side's nodal condition, not {condition!r}")
        return super().evaluation(condition)

    def elements(self) -> tuple[np.ndarray, np.ndarray, list]:
        """The triangles of X_h (the constrained side's face triangles in the overlap), their in-plane corners, and
        per side the triangle of its trace holding each (the constrained side's own; None for the other: found by
        location where needed)."""
        t = self.traces[self.side]
        hosts = [None, None]
        at = np.full(len(t.nodes), -1)
        at[np.asarray(self._sigma[self.side][0])] = np.arange(self.size)
        faces = np.asarray(t.faces)
        hosts[self.side] = np.flatnonzero((at[faces] >= 0).all(axis=1))
        return np.asarray(self.cells), self.x[np.asarray(self.cells)[:, :3]], hosts


# a 9-node face's nodes in [-1, 1]^2 (quad9 order: corners, side midpoints, centre); its quarters' triangles
_QUAD9 = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [0, -1], [1, 0], [0, 1], [-1, 0], [0, 0]], dtype=float)
_QUARTERS = np.array([[0, 4, 8], [0, 8, 7], [4, 1, 5], [4, 5, 8], [8, 5, 2], [8, 2, 6], [7, 8, 6], [7, 6, 3]])


def _cut_hats(pair, side, faces, whole) -> np.ndarray:
    """(n,) m^2: at each node of side ``side``'s Q2 trace of the two-body pair ``pair`` (a :class:`SimpsonSurface`;
    ``faces`` (k, 9) its 9-node faces into ``traces[side].nodes``, ``whole`` those all of whose nodes are rows),
    the integral over the overlap's part of the other faces of the node's hat of the face split 2 x 2 (the Q1
    functions of its four quarters, tensor products of 1D tents in reference coordinates: positive, summing to
    1, as the red refinement's hats of a P2 face). Exact: the overlay of the quarters' triangles with the other
    side's faces, on whose cells a hat is bilinear in the parallelogram's affine coordinates (degree 2), by the
    degree-2 rule at reference points found by Newton on the face's bilinear map. Their sum is the area the
    overlap covers of those faces; 0 where none."""
    t, other = pair.traces[side], pair.linear.traces[1 - side]
    ov = pair.linear.overlay
    host = np.asarray(ov.cell_a if side == 0 else ov.cell_b) // 2
    cut = np.unique(host[~whole[host]])                                  # the faces the overlap's edge cuts
    cover = overlay(np.asarray(t.x), faces[cut][:, _QUARTERS].reshape(-1, 3), np.asarray(other.x),
                    np.asarray(other.faces)) if len(cut) else None
    if cover is None or len(cover.vertices) == 0:
        return np.zeros(len(t.nodes))
    points, weights = _triangles_rule(cover, 2)
    at = np.repeat(cut[np.asarray(cover.cell_a) // len(_QUARTERS)], weights.shape[1])
    xi = np.clip(reference_points(np.asarray(t.x)[faces[:, :4]], at, points), -1.0, 1.0)
    tents = np.clip(1.0 - np.abs(xi[:, None, :] - _QUAD9[None]), 0.0, None).prod(axis=2)     # (m, 9)
    return np.bincount(faces[at].ravel(), weights=(tents * weights.reshape(-1, 1)).ravel(),
                       minlength=len(t.nodes))


def _biquadratic_rows(trace, x) -> sp.csr_matrix:
    """(v, n) sparse: the biquadratic functions of the 9-node faces of the Q2 ``trace`` (a P2 pair's trace on
    hexahedral faces; columns ``trace.nodes``) at the in-plane points ``x`` (v, 2) m, each in the face its
    triangles hold it in (UnsupportedError for a point on none)."""
    faces9 = np.searchsorted(np.asarray(trace.nodes), Q2HexNodes(trace.body.mesh).boundary(trace.part))
    tri, _ = locate(x, np.asarray(trace.x), np.asarray(trace.faces)[:, :3])
    if (tri < 0).any():
        raise UnsupportedError(f"{trace.body.name} {trace.part!r}: a node of the other side lies on none of its "
                               "faces: its biquadratic trace cannot be read there")
    host = tri // 2
    xi = reference_points(np.asarray(trace.x)[faces9[:, :4]], host, np.asarray(x, dtype=float))
    N = QuadElement(2).shape(np.clip(xi, -1.0, 1.0))
    return sp.csr_matrix((N.ravel(), (np.repeat(np.arange(len(x)), 9), faces9[host].ravel())),
                         shape=(len(x), len(trace.nodes)))


def q2_pair(itf, nodes, members, condition):
    """The P2 pair a Q2 hexahedral space poses for ``itf`` under ``condition``: :class:`BiquadraticRows` on
    faces that do not match under a nodal condition, :class:`SimpsonSurface` otherwise (matching faces, a rigid
    obstacle)."""
    if itf.rigid or matching(itf) or condition not in ("sigma1", "sigma2"):
        return SimpsonSurface(itf, nodes, members)
    return BiquadraticRows(itf, nodes, members, int(condition[-1]) - 1)


def simpson_lumped(trace) -> np.ndarray:
    """(n,) m^2: the integrals of the biquadratic hats of the Q2 ``trace``'s nodes (``trace.nodes``) over its part's
    9-node faces (3 x 3 Gauss on the faces' bilinear maps, :func:`~cvxcontact.fem.hex.face_hats`: A/36 at a
    corner, 4A/36 at an edge midpoint, 16A/36 at the centre of a parallelogram face; positive, summing to the
    part's area): the lumped areas of a Q2 face trace, the consistent loads of a unit pressure."""
    nodes = Q2HexNodes(trace.body.mesh)
    return face_hats(nodes.points, nodes.boundary(trace.part), 2)[np.asarray(trace.nodes)]


def quadratic_pressures(lines, conditions):
    """The Q2 hexahedra's contact ``lines`` (``lines.interface``: a
    :class:`~cvxcontact.contact.quadratic3d.QuadraticSurface` or their stack; ``conditions`` each pair's) with
    every pair reading lambda_h by :class:`LumpedPressure` (``with_representer``: copies, the given pairs
    unchanged), w the integrals of the biquadratic hats over the constrained side's faces
    (3 x 3 Gauss on the faces' bilinear maps: A/36 at a corner, A/9 at an edge midpoint, 4A/9 at the centre of a
    parallelogram face; the P2 mass of the faces' triangles, which the tetrahedra's read-back solves, would
    make a uniform pressure oscillate)."""
    stack = getattr(lines.interface, "interfaces", None)
    pairs = []
    for pair, c in zip(stack or (lines.interface,), conditions):
        side = constrained_side(pair, c)
        lumped = simpson_lumped(pair.traces[side])
        pairs.append(pair.with_representer(LumpedPressure(pair.interpolation(side), lumped)))
    return replace(lines, interface=pairs[0] if stack is None else QuadraticStack(pairs, lines.interface.members))


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
    pair = pair if pair is not None else BilinearSurface(itf)
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
    :class:`SimpsonSurface` on Q2)."""
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
