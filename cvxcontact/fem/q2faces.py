"""The contact rows of Q2 (27-node) hexahedra between two bodies' faces and against an obstacle: matching faces and
rigid obstacles (:class:`SimpsonSurface`), faces that do not match (:class:`BiquadraticRows`), the lumped areas of a
Q2 face trace (:func:`simpson_lumped`) and lambda_h of its pairs (:func:`quadratic_pressures`; docs/formulation.md
§15, docs/howto/quadrilaterals.md).

The pairs are posed by P2 tetrahedra's code on the faces' 6-node triangles (``Q2HexNodes.triangulation``: on a
parallelogram face its 9 nodes are those of its two triangles). A normal-compliance law sits on the nodal rows with
the biquadratic hats' integrals (tensor Simpson on a parallelogram; a friction law's capacities too); the
pressure a body feels and lambda_h are its nodal forces over those integrals
(:class:`~cvxcontact.fem.hexfaces.LumpedPressure`). Which pairs are refused:
:func:`~cvxcontact.fem.hexfaces.hex_contact`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from ..contact.interface import shares_to_nearest
from ..contact.overlay import locate, overlay
from ..contact.quadratic import QuadraticStack
from ..contact.quadratic3d import QuadraticSurface, p2_mass
from ..errors import UnsupportedError
from ..geometry.quadratic import Q2HexNodes
from .hex import face_hats, reference_points
from .hexfaces import (
    FeltFromRows,
    LumpedPressure,
    constrained_side,
    located_hats,
    matching,
    plane_cross,
    triangles_rule,
)
from .quad import QuadElement

__all__ = ["BiquadraticRows", "SimpsonSurface", "q2_pair", "quadratic_pressures", "simpson_lumped"]


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
        such faces went through the law with no force). Against an obstacle each row's node's biquadratic hat
        integrated over the body's part (:func:`simpson_lumped`, as Q1's ``mesh.node_areas``), on the faces the
        obstacle reaches only in part too: the lumped (Simpson) rule of the law's integral over the part, Phi read
        at the nodes and 0 at a node from which the obstacle cannot be reached (it misses it: no row there), so
        that every row carries the law with a positive weight and obstacles reaching complementary sets of the
        part's nodes weigh it once (before, a row on no face whose 9 nodes all reach the obstacle weighed 0 and
        penetrated for free)."""
        if not self.rigid and condition not in ("sigma1", "sigma2"):
            raise UnsupportedError(f"a normal-compliance law on Q2 hexahedral faces sits on nodal rows "
                                   f"('sigma1', 'sigma2'), not {condition!r}")
        side = 0 if self.rigid else int(condition[-1]) - 1
        if ("law", side) not in self._factors:                  # kept: quadrature, row_mass and the read-back ask
            t = self.traces[side]
            if self.rigid:
                self._factors[("law", side)] = simpson_lumped(t)[np.asarray(self.reach)]
                return self._factors[("law", side)].copy()
            faces = np.searchsorted(t.nodes, Q2HexNodes(t.body.mesh).boundary(t.part))     # (k, 9) into t.nodes
            at = np.asarray(self.sigma_rows(side))
            row = np.zeros(len(t.nodes), dtype=bool)
            row[at] = True
            whole = row[faces].all(axis=1)
            hats = face_hats(t.points, faces[whole], 2)
            self._factors[("law", side)] = shares_to_nearest(hats + _cut_hats(self, side, faces, whole), at, t.x)
        return self._factors[("law", side)].copy()

    def weights(self, condition) -> np.ndarray:
        """(rows,) m^2: the rows' areas that weigh friction capacities g w_a and the shear read over them: the
        biquadratic hats' integrals (A/36, 4A/36, 16A/36; positive, summing to the faces' area), a uniform shear's
        consistent loads (it sticks from g = tau; the triangles' red lumping only from 16/9 tau). Two bodies:
        :meth:`law_weights`; an obstacle: :func:`simpson_lumped` at the nodes that reach it (howto/friction.md)."""
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
        area = 0.5 * np.abs(plane_cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
        self.mass = p2_mass(cells, area, len(inside)).tocsr()
        n = len(inside)
        own = sp.csr_matrix((np.ones(n), (np.arange(n), inside)), shape=(n, len(t.nodes)))
        self._interp = [None, None]
        self._interp[side], self._interp[1 - side] = own, _face_rows(other, self.x, QuadElement(2).shape)
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

    def pressure(self, k, r) -> np.ndarray:
        """The pressure (Pa) felt by the pair's body k on its own trace nodes (``traces[k].nodes``) under the row
        forces ``r`` (N). The constrained side: :meth:`SimpsonSurface.pressure` (its forces over its Simpson
        weights). The other side (its nodes are no rows): the rows' pressures q_a = r_a / w_a (w the rows' Simpson
        weights, :meth:`law_weights`: positive, the consistent loads of a unit pressure at the constrained nodes)
        interpolated at its node b by the constrained side's faces split 2 x 2 (:func:`_tents`: the Q1 functions
        of their quarters, positive), normalised over the rows: p_b = sum_a tau_a(x_b) q_a / sum_a tau_a(x_b), 0
        at a node on no constrained face or whose quarter holds no row. The rows' pressure field at the same
        point (action and reaction), a weighted mean of the row pressures of the
        constrained quarter holding the node: non-negative where the forces are, between their least and largest,
        a uniform pressure p (forces p w_a) read p at every node in the overlap, a finer other side included. It
        does not keep the total force by that side's own Simpson weights (off by 4.5 % to 30 % on the tilted
        blocks of tests/test_hex_pressure.py). Measured against a 12 x 12 matching reference of those blocks
        (2 x 2 to 4 x 4 under 3 x 3 to 6 x 6, either condition), at its worst node at most as far off as the
        constrained side's own read, 0.27-0.58 of the peak (the rows' forces moved by the other side's split hats
        over their areas by the rows' rule: 0.27-0.76, and a uniform p read 0 at 56 of 81 nodes of a 4 x 4 side
        over 2 x 2 rows; the other side's work-equivalent forces over its Simpson weights, exact for the total:
        0.26-1.6, down to -53 % of the peak under non-negative forces, a uniform p read -1.6 p to 6.3 p;
        docs/formulation.md §15)."""
        if k == self.side:
            return super().pressure(k, r)
        key = ("felt", k)
        if key not in self._factors:
            t = self.traces[self.side]
            hats = located_hats(t, self.traces[k].x, self._sigma[self.side][0],
                                lambda y, face: _face_rows(t, y, _tents, face))
            self._factors[key] = FeltFromRows(hats, self.law_weights(f"sigma{self.side + 1}"))
        return self._factors[key](r)

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
    points, weights = triangles_rule(cover, 2)
    at = np.repeat(cut[np.asarray(cover.cell_a) // len(_QUARTERS)], weights.shape[1])
    xi = np.clip(reference_points(np.asarray(t.x)[faces[:, :4]], at, points), -1.0, 1.0)
    return np.bincount(faces[at].ravel(), weights=(_tents(xi) * weights.reshape(-1, 1)).ravel(),
                       minlength=len(t.nodes))


def _tents(xi) -> np.ndarray:
    """(m, 9): the hats of a 9-node face split 2 x 2 at reference points ``xi`` (m, 2) in [-1, 1]^2 (the Q1
    functions of its four quarters, tensor products of 1D tents: positive, summing to 1, 1 at their own node and 0
    at the face's other nodes), in the quad9 order of :data:`_QUAD9`."""
    return np.clip(1.0 - np.abs(xi[:, None, :] - _QUAD9[None]), 0.0, None).prod(axis=2)


def _face_rows(trace, x, basis, host=None) -> sp.csr_matrix:
    """(v, n) sparse: the functions ``basis`` (reference points (v, 2) to values (v, 9)) of the 9-node faces of the
    Q2 ``trace`` (a P2 pair's trace on hexahedral faces; columns ``trace.nodes``) at the in-plane points ``x``
    (v, 2) m, each in face ``host`` (v,) of its ``boundary`` if given, else in the face its triangles hold it in
    (UnsupportedError for a point on none): the biquadratic functions (``QuadElement(2).shape``) or the split
    faces' hats (:func:`_tents`)."""
    faces9 = np.searchsorted(np.asarray(trace.nodes), Q2HexNodes(trace.body.mesh).boundary(trace.part))
    if host is None:
        tri, _ = locate(x, np.asarray(trace.x), np.asarray(trace.faces)[:, :3])
        if (tri < 0).any():
            raise UnsupportedError(f"{trace.body.name} {trace.part!r}: a node of the other side lies on none of its "
                                   "faces: its biquadratic trace cannot be read there")
        host = tri // 2
    xi = reference_points(np.asarray(trace.x)[faces9[:, :4]], host, np.asarray(x, dtype=float))
    N = basis(np.clip(xi, -1.0, 1.0))
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
