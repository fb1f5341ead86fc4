"""Discrete spaces: the one place where the element degree is decided (docs/architecture.md).

A :class:`Space` numbers the nodes of a body, assembles it (``Kuu``, ``Kup``, ``Kpp`` and the loads,
SI units) and builds the contact lines of a scene (:class:`ContactLines`): the stacked jump operators,
the evaluation rows of a condition, the laws on those rows, their quadrature weights, the conic rows of the
"everywhere" condition and the gap at the rows' nodes. Everything above this layer (the discrete problem,
the backends, the read-back) asks the space and never branches on the degree.

``P1`` (3-node triangles, the paper's elements), ``P2`` (6-node triangles on the P1 mesh,
docs/formulation.md §8), ``Q1`` (4-node quadrilaterals) and ``Q2`` (9-node quadrilaterals) are the 2D spaces,
``P1Tet`` (4-node tetrahedra) and ``P2Tet`` (10-node tetrahedra) the 3D ones; :data:`SPACES` holds them by
(cell, degree) and :func:`space` gives the one of a degree on a mesh's cell (``mesh.cell``). A space answers
its node sets, its assembly, its contact lines (the traces of Q1/Q2 on a side are the 2- and 3-node segments
of P1/P2, so they share P1's and P2's contact code), the VTK cells of its output, the shape gradients at
the cells' centres (the fields of the output) and whether the error estimates cover it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from ..contact.interface import Stack, row_directions
from ..contact.laws import RowLaws, pair_laws
from ..contact.quadratic import ConditionRows, QuadraticStack, p2_pairs
from ..contact.quadratic3d import QuadraticSurface
from ..contact.truegap import GapDeparture
from ..errors import SceneError, SolverError, UnsupportedError, frozen
from ..geometry.quadratic import P2Nodes, P2TetNodes, Q2HexNodes, Q2Nodes
from . import p2
from .assembly import BodySystem, assemble_loads, assemble_matrices, assemble_points, gradients, \
    strain_at, strain_points
from .hex import HEX1_ELEMENT, HEX2_ELEMENT
from .hexfaces import FACE_TRACE, dependent_law_rows, hex_contact, hex_pair, independent_rows, law_weights
from .q2faces import q2_pair, quadratic_pressures
from .quad import Q1_ELEMENT, Q2_ELEMENT
from .trace import TRACES, LinearTrace

__all__ = ["Space", "P1", "P2", "P1Tet", "P2Tet", "Q1", "Q2", "Q1Hex", "Q2Hex", "ContactLines", "space", "space_of",
           "SPACES", "needs_matching_faces"]


@dataclass(frozen=True)
class ContactLines:
    """The contact rows of a scene in one space (SI; docs/formulation.md §3, §8, §10).

    ``interface``: what the bodies' jump operators come from (``interface.jump(k, n_nodes)``: [u_nu] at the
    stacked nodes of X_h from body k's nodal displacements) and what the read-back reports per pair;
    ``offsets``: pair i's nodes of X_h are ``offsets[i]:offsets[i + 1]``; ``E``: the evaluation rows of the
    condition (one row per constrained node; the identity under the conic condition); ``cone``: (B,
    segments) of the conic "everywhere" rows (P2 "gamma3"), else None; ``rows``: the law of every row
    (:class:`~cvxcontact.contact.laws.RowLaws`, or :class:`~cvxcontact.contact.quadratic.ConeRowLaws` when
    cones sit next to a compliance law); ``weights`` (m): the law's quadrature weights on the rows (None
    without a compliance law); ``cone_pairs``: with a compliance law, per pair whether it is posed as a cone (a
    program mixing cones and compliance where one is: :attr:`mixed`; None without a compliance law); ``gap`` (m):
    the gap at the stacked nodes of X_h (pair gaps plus the distance to rigid obstacles); ``obstacles``: the scene's
    :class:`~cvxcontact.physics.obstacles.ObstacleRows` with their rows at those nodes; ``mixed_bernstein``: the
    cone pairs' Bernstein map of a mixed program (None otherwise); ``dependent``: whether a compliance law's rows can depend
    on each other whatever the condition (its quadrature points on P2 faces: six per triangle, more than the
    nodes; the interface compliance W is singular on them, docs/formulation.md §15); ``departure``: the
    departure of the true gap from its P2 interpolant on the cone's elements that face a curved rigid obstacle
    (:class:`~cvxcontact.contact.truegap.GapDeparture`, m), None where the gap is quadratic on every element;
    ``independent``: the "gamma3" rows between two bodies are known to be linearly independent (Q1 hexahedra on
    nested faces: one row per node of the finer side, :func:`~cvxcontact.fem.hexfaces.independent_rows`), so no
    route need treat them as possibly dependent; ``node_cone``: with a friction law under "gamma3" beside a pair
    under a nodal condition, the cone on the nodes of X_h where ``cone`` sits on E's rows (None otherwise:
    :attr:`cone_on_nodes`); ``element``: what the P2 elements answer under each pair's condition beyond these rows
    (:class:`~cvxcontact.contact.quadratic.ConditionRows`: E's rows, the cones on them, the cone pairs' Bernstein
    map; None for the other spaces). The space poses the rows of the conditions (under "gamma3" the cones on the
    nodes of X_h, the nodal pairs' rows as degenerate cones; beside a compliance law its rows); what a combination
    of laws needs beyond them is its contact term's to ask (:meth:`~cvxcontact.discrete.terms.ContactTerm.own_lines`:
    a friction law's cones on E's rows, the cones' ``mixed_bernstein`` and
    :class:`~cvxcontact.contact.quadratic.ConeRowLaws` beside a compliance law).
    """

    interface: object
    offsets: np.ndarray
    E: sp.csr_matrix
    cone: tuple | None
    rows: RowLaws
    weights: np.ndarray | None
    cone_pairs: tuple | None
    gap: np.ndarray
    obstacles: tuple
    mixed_bernstein: tuple | None = None
    dependent: bool = False
    departure: GapDeparture | None = None
    independent: bool = False
    node_cone: tuple | None = None
    element: ConditionRows | None = None

    def __post_init__(self):
        frozen(self.E)                          # canonical and read-only: a solve cannot reorder the rows' entries

    @property
    def cone_on_nodes(self) -> tuple | None:
        """(B, cells) of the conic condition on the nodes of X_h: ``cone`` where E is the identity; with a friction
        law beside a pair under a nodal condition ``cone`` sits on E's rows (:meth:`~cvxcontact.contact.quadratic.
        QuadraticStack.row_cone`) and this is ``node_cone``, its B times E (what the conic checks read)."""
        return self.cone if self.node_cone is None else self.node_cone

    @property
    def conic(self) -> bool:
        """True if the rows are the conic condition of docs/formulation.md §8 (no compliance law)."""
        return self.cone is not None

    @property
    def mixed(self) -> bool:
        """True if cones sit next to a compliance law in one program (docs/formulation.md §10, "P2"): some pair is
        posed as a cone beside a compliance law (``cone_pairs``)."""
        return self.cone_pairs is not None and any(self.cone_pairs)

    def key(self) -> tuple:
        """What the factorisations and interface matrices of a backend depend on: the nodes of X_h, the
        jump operators' pattern and the evaluation rows (a moved obstacle may change them)."""
        return (tuple(np.asarray(self.offsets).tolist()), self.E.shape, self.E.indices.tobytes(),
                self.E.indptr.tobytes(), self.E.data.tobytes(), _interface_key(self.interface))


def _interface_key(interface) -> bytes:
    """The nodes of X_h of every pair and the directions of its rows (a curved obstacle's, towards its closest
    points, move with it: the jump operators change, not only the gap)."""
    pairs = getattr(interface, "interfaces", None) or [interface]
    return b"".join(np.ascontiguousarray(np.asarray(p.x, dtype=float)).tobytes() +
                    np.ascontiguousarray(np.asarray(p.points, dtype=float)).tobytes() +
                    (np.ascontiguousarray(row_directions(p, p.normal), dtype=float).tobytes()
                     if getattr(p, "obstacle", None) is not None else b"") for p in pairs)


class Space(Protocol):
    """What the discrete problem asks of a space: its ``cell`` (the mesh's cell type, ``mesh.cell``),
    ``degree`` (of its traces on the contact lines: 1 segments of 2 nodes, 2 of 3 nodes), ``dim``
    (displacement components per node), whether the error ``estimates`` cover it and whether the equilibrated
    error bound does (``bounded``: :mod:`cvxcontact.solution.bound`, P1 triangles), its ``trace`` on the contact
    lines (:mod:`cvxcontact.fem.trace`: what the read-back, estimates and output ask of X_h), its ``label``
    ("P1", "Q2", ...: figures and reports), the ``order`` of its energy-norm error on smooth solutions (h^order:
    the rate the studies expect), whether a pair of two bodies needs their contact faces meshed alike
    (``matching_faces``: local refinement then refines the partners' strips together, ``cc.adapt``; optional, a
    space without it does not: :func:`needs_matching_faces`) and the methods below."""

    cell: str
    degree: int
    dim: int
    estimates: bool
    bounded: bool
    trace: LinearTrace
    label: str
    order: int
    matching_faces: bool

    def nodes(self, body):
        """The node set of ``body`` (None: the mesh's vertices)."""

    def node_set(self, mesh):
        """The node set of this space on ``mesh`` (``points``, ``cells``, ``boundary_nodes``,
        ``node_components``): the mesh itself where the nodes are its vertices."""

    def shape_values(self, L) -> np.ndarray:
        """(..., k): the element's shape functions at barycentric coordinates ``L`` (..., d + 1) of a simplex
        (the order of ``node_set(mesh).cells``); simplex spaces."""

    def vtk_cells(self, body, nodes=None) -> list[tuple[str, np.ndarray]]:
        """The cells of ``body`` as meshio (VTK) blocks [(type, (m, k) node indices in VTK's order)]."""

    def centre_gradients(self, body, nodes=None) -> tuple[np.ndarray, np.ndarray]:
        """(cells (m, k), G (m, dim, k) 1/m): the element nodes and the shape gradients at each cell's centre
        (where the output evaluates the fields)."""

    def corner_gradients(self, body, gradL: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(cells (m, k), G (m, q, d, k) 1/m): the element nodes and the shape gradients at each simplex's
        q = d + 1 vertices (the error estimates' fields, affine on a cell for P2), q = 1 where they are constant
        on a cell (P1); spaces the estimates cover. ``gradL``: the mesh's barycentric gradients (m, d, d + 1)
        if the caller has them (:func:`~cvxcontact.fem.assembly.gradients`; P1's G is then a view of them, not
        a second copy)."""

    def assemble_matrices(self, body, nodes=None) -> BodySystem:
        """Kuu, Kup, Kpp and the Dirichlet prolongations of ``body`` on ``nodes`` (SI), no loads."""

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        """``matrices`` with the loads of ``body`` (SI)."""

    def contact(self, scene, condition: str, law, nodes=None) -> ContactLines:
        """The contact rows of ``scene`` under ``condition`` and ``law`` (each pair's own first)."""


class P1:
    """P1 (3-node) triangles: the mesh's vertices, the merged P1 contact mesh of every pair."""

    cell, degree, dim, estimates = "triangle", 1, 2, True
    trace, label, order, bounded = TRACES[1], "P1", 1, True
    matching_faces = False
    vtk = "triangle"
    """The meshio (VTK) cell type."""

    def nodes(self, body):
        return None

    def node_set(self, mesh):
        return mesh

    def shape_values(self, L) -> np.ndarray:
        _simplex(self)
        return np.asarray(L)

    def corner_gradients(self, body, gradL: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        _estimated(self)
        gradL = gradients(body.mesh.points, body.mesh.cells)[1] if gradL is None else gradL
        return body.mesh.cells, gradL[:, None]                                  # constant on a cell: q = 1

    def vtk_cells(self, body, nodes=None) -> list[tuple[str, np.ndarray]]:
        return [(self.vtk, np.asarray((body.mesh if nodes is None else nodes).cells))]

    def centre_gradients(self, body, nodes=None) -> tuple[np.ndarray, np.ndarray]:
        return body.mesh.cells, gradients(body.mesh.points, body.mesh.cells)[1]

    def assemble_matrices(self, body, nodes=None) -> BodySystem:
        _check_cell(self, body)
        return _bulk(assemble_matrices(body), body, lambda: strain_points(body))

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        return assemble_loads(body, matrices)

    def _stack(self, scene, condition):
        """The stacked pairs the contact rows are read from: the scene's."""
        return scene.stack

    def contact(self, scene, condition: str, law, nodes=None) -> ContactLines:
        stack = self._stack(scene, condition)
        laws = pair_laws(scene, law)
        offsets = stack.row_offsets(condition, scene.conditions)
        rows = RowLaws(laws, np.diff(offsets))
        weights = None
        if rows.compliant:
            weights = stack.weights(condition, scene.conditions)
            for i, (a, b) in enumerate(zip(offsets[:-1], offsets[1:])):
                if rows.laws[i].compliant and not (weights[a:b] > 0).all():
                    raise SceneError(f"contacts[{i}] {scene.contacts[i]!r}: a normal-compliance law needs at least "
                                     f"two constrained nodes (it is integrated over their lumped lengths); under "
                                     f"{scene.conditions[i] or condition!r} the pair has {b - a}: use gamma3 or "
                                     "Signorini")
        return ContactLines(interface=stack, offsets=np.asarray(stack.offsets), E=stack.evaluation(
            condition, scene.conditions), cone=None, rows=rows, weights=weights, cone_pairs=None,
            gap=scene.gap_values(), obstacles=tuple(scene.obstacles))


class P2:
    """P2 (6-node) triangles built on the P1 mesh (vertices, then edge midpoints; docs/formulation.md §8)."""

    cell, degree, dim, estimates = "triangle", 2, 2, True
    trace, label, order, bounded = TRACES[2], "P2", 2, False
    matching_faces = False
    vtk = "triangle6"

    def nodes(self, body):
        return self.node_set(body.mesh)

    def node_set(self, mesh):
        return P2Nodes(mesh)

    def shape_values(self, L) -> np.ndarray:
        _simplex(self)
        return p2.shape_functions(L)

    def corner_gradients(self, body, gradL: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        _estimated(self)
        gradL = gradients(body.mesh.points, body.mesh.cells)[1] if gradL is None else gradL
        corners = np.eye(gradL.shape[2])
        return self.nodes(body).cells, np.stack([p2.shape_gradients(gradL, c) for c in corners], axis=1)

    def vtk_cells(self, body, nodes=None) -> list[tuple[str, np.ndarray]]:
        return [(self.vtk, np.asarray((self.nodes(body) if nodes is None else nodes).cells))]

    def centre_gradients(self, body, nodes=None) -> tuple[np.ndarray, np.ndarray]:
        nodes = self.nodes(body) if nodes is None else nodes
        gradL = gradients(body.mesh.points, body.mesh.cells)[1]
        return nodes.cells, p2.shape_gradients(gradL, np.full(gradL.shape[2], 1.0 / gradL.shape[2]))

    def assemble_matrices(self, body, nodes=None) -> BodySystem:
        _check_cell(self, body)
        nodes = self.nodes(body) if nodes is None else nodes
        return _bulk(p2.assemble_matrices(body, nodes), body, lambda: p2.strain_points(body, nodes))

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        return p2.assemble_loads(body, matrices, self.nodes(body) if nodes is None else nodes)

    def contact(self, scene, condition: str, law, nodes=None) -> ContactLines:
        nodes = [self.nodes(b) for b in scene.bodies] if nodes is None else nodes
        pairs = p2_pairs(scene, nodes, condition, law)
        stack = pairs.stack
        cone = None
        if pairs.conic_only:       # the cone on the gamma3 pairs, nodal rows as degenerate cones (§8)
            E = sp.identity(stack.size, format="csr")
            cone = stack.cone_rows(condition, list(pairs.conditions))
            counts = np.diff(stack.offsets)                # E's rows: a law row per node of X_h (as P2Tet's)
        else:
            E = stack.evaluation(condition, list(pairs.conditions))
            counts = np.diff(stack.row_offsets(condition, scene.conditions))
        rows = RowLaws(pair_laws(scene, law), counts)
        weights = stack.weights(condition, scene.conditions) if rows.compliant else None   # Simpson (§10)
        gap = np.concatenate([scene.pair_gap_values(i, np.array(itf.x)) for i, itf in enumerate(stack.interfaces)])
        departure = None if cone is None else gap_departure(scene, stack, list(pairs.conditions), cone[1], gap)
        on_cone = None if pairs.cone_pairs is None else np.repeat(pairs.cone_pairs, rows.counts)
        return ContactLines(interface=pairs.interface, offsets=np.asarray(stack.offsets), E=E, cone=cone,
                            rows=rows, weights=weights,
                            cone_pairs=tuple(pairs.cone_pairs) if pairs.cone_pairs is not None else None,
                            gap=gap, obstacles=tuple(_p2_obstacles(scene, stack)), departure=departure,
                            element=ConditionRows(stack, tuple(pairs.conditions), on_cone))


def gap_departure(scene, stack, conditions, cells, gap) -> GapDeparture | None:
    """The :class:`~cvxcontact.contact.truegap.GapDeparture` of the cone's elements ``cells`` (S, w; stacked
    nodes of X_h, in the order of :meth:`~cvxcontact.contact.quadratic.QuadraticStack.cone_rows`) that lie on a
    "gamma3" pair with a rigid obstacle: the true gap there is :meth:`~cvxcontact.physics.scene.Scene.
    pair_gap_values` (the pair's gap plus the obstacle's own distance) at the element's points, ``gap`` (m) the
    gap at the nodes. None where every such element's gap is quadratic (a plane, no obstacle)."""
    cells = np.asarray(cells)
    S, w = cells.shape
    pair = np.full(S, -1)
    at = 0
    for i, (itf, c) in enumerate(zip(stack.interfaces, conditions)):
        if c == "gamma3":
            real = len(np.asarray(itf.segments))        # 3D: the faces; the orphan nodes' cells come after
            count = len(np.asarray(getattr(itf, "cone_cells", itf.segments)))
            if itf.rigid:
                pair[at:at + real] = i
        else:
            count = itf.evaluation(c).shape[0]
        at += count
    if not (pair >= 0).any():
        return None
    x = np.asarray(stack.x, dtype=float)
    corners = cells[:, [0, 2]] if w == 3 else cells[:, :3]

    def located(elements, points):
        """Per pair i: (on, s, X): the elements of pair i, their points' coordinates s on the pair's line or
        plane (m) and their corners' X (k, c, m) (s = L X, L the full barycentric coordinates)."""
        for i in np.unique(pair[elements]):
            on = np.flatnonzero(pair[elements] == i)
            X = x[corners[elements[on]]]                       # (k, 2) abscissae or (k, 3, 2) in-plane points
            X = X[:, :, None] if w == 3 else X
            L = np.column_stack([1 - points[on], points[on]]) if w == 3 else points[on]
            s = np.einsum("kv,kvd->kd", L, X)
            yield int(i), on, (s[:, 0] if w == 3 else s), X

    def true_gap(elements, points):
        out = np.empty(len(elements))
        for i, on, s, _ in located(elements, points):
            out[on] = scene.pair_gap_values(i, s)
        return out

    def derivatives(elements, points):
        k, c = len(elements), (2 if w == 3 else 3)
        g, grad, hess = np.empty(k), np.empty((k, c)), np.empty((k, c, c))
        for i, on, s, X in located(elements, points):
            g[on], gs, hs = scene.pair_gap_derivatives(i, s)
            grad[on] = np.einsum("kvd,kd->kv", X, gs)          # ds/dL = X
            hess[on] = np.einsum("kvd,kde,kue->kvu", X, hs, X)
        return g, grad, hess

    return GapDeparture.build(true_gap, np.asarray(gap, dtype=float)[cells], pair >= 0, derivatives)


def _p2_obstacles(scene, stack, dim: int = 2):
    """The scene's :class:`~cvxcontact.physics.obstacles.ObstacleRows` with their rows at the stacked P2 nodes of
    ``stack`` (a :class:`~cvxcontact.contact.quadratic.QuadraticStack`): the sensitivities c(x) of each
    obstacle at its pairs' P2 nodes (vertices and midpoints), zero elsewhere; ``basis`` and ``force`` kept."""
    out = []
    for o in scene.obstacles:
        rows = np.zeros((stack.size, dim))
        for i in o.pairs:
            itf = stack.interfaces[i]
            rows[stack.offsets[i]:stack.offsets[i + 1]] = o.obstacle.sensitivity(itf.points, itf.normal)
        out.append(replace(o, rows=sp.csr_matrix(rows)))
    return out


def _bulk(system: BodySystem, body, points) -> BodySystem:
    """``system`` with the quadrature points of its bulk energy (``points()``: the strain map and weights) when
    the material's energy is not the quadratic form of Kuu (:attr:`BodySystem.strain`)."""
    if body.material.quadratic:
        return system
    strain, weights = points()
    return replace(system, strain=strain, weights=weights, material=body.material)


def _estimated(space):
    """UnsupportedError where the error estimates do not cover ``space`` (``space.estimates``)."""
    if not space.estimates:
        raise UnsupportedError(f"the error estimates do not cover {space.label} {space.cell} cells: use "
                               "triangles or tetrahedra")


def _simplex(space):
    """UnsupportedError for a space whose cells are not simplices (barycentric coordinates do not place a point)."""
    if space.cell not in ("triangle", "tetra"):
        raise UnsupportedError(f"{space.label} {space.cell} cells: shape functions at barycentric coordinates "
                               "are those of triangles and tetrahedra")


def _check_cell(space, body):
    cell = body.mesh.cell
    if cell != space.cell:
        raise SolverError(f"{body.name}: a body of {cell} cells in the space {type(space).__name__} of "
                          f"{space.cell} cells: use space({space.degree}, {cell!r})")


class Q1(P1):
    """Q1 (4-node, bilinear) quadrilaterals (:mod:`cvxcontact.fem.quad`, 2 x 2 Gauss): the mesh's vertices;
    the traces on the contact lines are P1's segments, so the contact rows are P1's."""

    cell, degree, dim, estimates = "quad", 1, 2, True
    label, bounded = "Q1", False
    vtk = "quad"
    element = Q1_ELEMENT

    def centre_gradients(self, body, nodes=None) -> tuple[np.ndarray, np.ndarray]:
        held = self._held(body, nodes)
        return held.cells, self.element.at(body.mesh.points[body.mesh.cells], np.zeros(body.dim))[1]

    def _held(self, body, nodes):
        """The node set the unknowns live on (``nodes``, else the space's, else the mesh's vertices)."""
        nodes = self.nodes(body) if nodes is None else nodes
        return body.mesh if nodes is None else nodes

    def assemble_matrices(self, body, nodes=None) -> BodySystem:
        _check_cell(self, body)
        held = self._held(body, nodes)
        nodes = None if held is body.mesh else held
        points = self.element.points(body.mesh)
        return _bulk(assemble_points(body, held.cells, len(held.points), points, nodes), body,
                     lambda: strain_at(points, held.cells, body.dim, len(held.points)))

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        return self.element.loads(body, matrices, nodes)


class Q2(P2):
    """Q2 (9-node, biquadratic Lagrange) quadrilaterals on the bilinear map of each cell (vertices, edge
    midpoints, centres: :class:`~cvxcontact.geometry.quadratic.Q2Nodes`; 3 x 3 Gauss; why 9 nodes and not the
    8-node serendipity: :mod:`cvxcontact.fem.quad`); the traces on the contact lines are P2's 3-node segments,
    so the contact rows (nodal and the "gamma3" cones) are P2's."""

    cell, degree, dim, estimates = "quad", 2, 2, True
    label = "Q2"
    vtk = "quad9"
    element = Q2_ELEMENT

    def node_set(self, mesh):
        return Q2Nodes(mesh)

    centre_gradients, _held, assemble_matrices = Q1.centre_gradients, Q1._held, Q1.assemble_matrices

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        return self.element.loads(body, matrices, self.nodes(body) if nodes is None else nodes)




class P1Tet(P1):
    """P1 (4-node) tetrahedra: the mesh's vertices (the same dimension-generic assembly as P1) and the planar
    contact surfaces of the scene (:class:`~cvxcontact.contact.surface.SurfaceInterface`: the overlay's vertices
    are the nodes of X_h, docs/formulation.md §13), stacked as in 2D."""

    cell, degree, dim, estimates = "tetra", 1, 3, True
    bounded = False
    vtk = "tetra"


class P2Tet(P2):
    """P2 (10-node) tetrahedra built on the P1 mesh (vertices, then edge midpoints); in contact, the planar
    surfaces with P2 traces (:class:`~cvxcontact.contact.quadratic3d.QuadraticSurface`: X_h the continuous
    piecewise quadratics on the overlay, docs/formulation.md §15) under the nodal conditions "sigma1"/"sigma2"
    (rows at that body's P2 face nodes; against a rigid obstacle at its P2 face nodes that reach it) and under
    "gamma3" the copositive "everywhere" condition on every triangle of X_h (§16). A normal-compliance law sits on
    the quadrature points of the triangles the condition's nodes form ("gamma3": the triangles of X_h, no cone):
    its rows evaluate [u_nu] there (the P2 interpolant of the condition's nodal rows, a positive-weight rule of
    degree 4, :meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.quadrature`, §15; on faces the overlap's
    edge cuts, the nodal rows with positive weights); a Signorini "gamma3" pair's copositive cones sit beside it in
    one program (``cone_pairs``; the rows on them, ``element.on_cone``, from which the term of that combination
    takes its ``mixed_bernstein``), as do a limited compliant "gamma3" pair's (at g + l, on its nodes of X_h beside
    the law's quadrature rows)."""

    cell, degree, dim, estimates = "tetra", 2, 3, True
    vtk = "tetra10"

    def pair_surface(self, itf, nodes, members, condition):
        """The P2 pair of the planar pair ``itf`` (the bodies' P2 ``nodes``, their ``members`` indices) under
        ``condition``: :class:`~cvxcontact.contact.quadratic3d.QuadraticSurface` (the seam a space whose traces
        are not the triangles' own overrides)."""
        return QuadraticSurface(itf, nodes, members)

    def node_set(self, mesh):
        return P2TetNodes(mesh)

    def vtk_cells(self, body, nodes=None) -> list[tuple[str, np.ndarray]]:
        cells = np.asarray((self.nodes(body) if nodes is None else nodes).cells)
        return [(self.vtk, cells[:, [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]])]      # VTK's tetra10 swaps the last two

    def contact(self, scene, condition: str, law, nodes=None) -> ContactLines:
        nodes = [self.nodes(b) for b in scene.bodies] if nodes is None else nodes
        laws = pair_laws(scene, law)
        conditions = [c or condition for c in scene.conditions]
        compliant = any(lw.compliant for lw in laws)
        limited = [c == "gamma3" and lw.compliant and lw.penetration_limit is not None
                   for c, lw in zip(conditions, laws)]
        cone_pairs = [c == "gamma3" and (not lw.compliant or lim) for c, lw, lim in zip(conditions, laws, limited)]
        for i, itf in enumerate(scene.interfaces):
            if getattr(itf, "curved", None) is not None:
                raise UnsupportedError(f"contacts[{i}] {itf.label}: a curved contact part with P2 (10-node) "
                                       "tetrahedra is not available: use degree=1")
        members = scene.stack.members
        pairs = [self.pair_surface(itf, tuple(nodes[k] for k in m if k is not None), m, c)
                 for itf, m, c in zip(scene.interfaces, members, conditions)]
        stack = QuadraticStack(pairs, members)
        cone = weights = None
        if "gamma3" in conditions and not compliant:   # the copositive condition on the gamma3 pairs (§16)
            E = sp.identity(stack.size, format="csr")
            cone = stack.cone_rows(condition, conditions)
        else:                            # nodal rows; a compliant gamma3 pair's: every node of X_h (§15)
            E = stack.evaluation(condition, conditions)
        counts = np.diff(stack.offsets) if cone is not None else np.diff(stack.row_offsets(condition, conditions))
        on_cone = None
        if compliant:                    # a compliant pair's rows: the law's quadrature points on its triangles (§15)
            rules = [_law_rows(itf, c, lw, n, lim)
                     for itf, c, lw, n, lim in zip(pairs, conditions, laws, counts, limited)]
            E = (sp.block_diag([Q for Q, _, _ in rules], format="csr") @ E).tocsr()
            weights = np.concatenate([w for _, w, _ in rules])
            counts = np.array([len(w) for _, w, _ in rules])
            on_cone = np.concatenate([c for _, _, c in rules])
        gap = np.concatenate([scene.pair_gap_values(i, np.array(itf.x)) for i, itf in enumerate(pairs)])
        departure = None if cone is None else gap_departure(scene, stack, conditions, cone[1], gap)
        return ContactLines(interface=pairs[0] if len(pairs) == 1 else stack, offsets=np.asarray(stack.offsets),
                            E=E, cone=cone, rows=RowLaws(laws, counts), weights=weights, gap=gap,
                            cone_pairs=tuple(cone_pairs) if compliant else None,
                            obstacles=tuple(_p2_obstacles(scene, stack, self.dim)), dependent=compliant,
                            departure=departure, element=ConditionRows(stack, tuple(conditions), on_cone))


def _law_rows(itf, condition, law, n, limited) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """(Q (k, n), w (k,) m^2, cone (k,) bool): the rows of one P2 tetrahedral pair on its ``n`` condition nodes.
    A compliant pair: the law's quadrature (:meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.quadrature`);
    with a penetration limit under "gamma3" also its nodes of X_h (weight 0), on which the copositive cone at
    g + l holds (docs/formulation.md §16): rows [Q; I]. A Signorini pair: its nodes (weight 0), on the cone if
    ``condition`` is "gamma3"."""
    eye = sp.identity(n, format="csr")
    if not law.compliant:
        return eye, np.zeros(n), np.full(n, condition == "gamma3")
    Q, w = itf.quadrature(condition)
    if not limited:
        return Q, w, np.zeros(len(w), dtype=bool)
    return (sp.vstack([Q, eye], format="csr"), np.concatenate([w, np.zeros(n)]),
            np.concatenate([np.zeros(len(w), dtype=bool), np.ones(n, dtype=bool)]))


class Q1Hex(P1Tet):
    """Q1 (8-node, trilinear) hexahedra (:mod:`cvxcontact.fem.hex`, 2 x 2 x 2 Gauss): the mesh's vertices. Its trace
    on a face is bilinear; the contact rows are P1Tet's on the faces' triangles (:attr:`HexMesh.triangulation
    <cvxcontact.geometry.hexmesh.HexMesh.triangulation>`), whose vertices are the faces' corners, with each trace
    evaluated at the nodes of X_h by its bilinear faces (:class:`~cvxcontact.fem.hexfaces.BilinearSurface`; the
    triangles' P1 functions where the faces match, the same values): nodal rows ("sigma1"/"sigma2") at a body's
    face nodes on any faces. "gamma3" is posed where it reduces to nodal rows exactly (a bilinear jump is
    non-negative on a face if it is at its corners): matching faces, rigid planes, nested faces (the finer
    side's nodes) and aligned parallelogram grids (the corners of the pieces where faces meet;
    :mod:`cvxcontact.fem.hexfaces`); a normal-compliance law is integrated by the Q1 hats' face integrals on
    matching and nested faces and against obstacles, by the pieces' areas on aligned parallelograms, and under a
    nodal condition on other faces by the constrained side's hats over the overlap
    (:func:`~cvxcontact.fem.hexfaces.law_weights`); the rest is refused by name
    (:func:`~cvxcontact.fem.hexfaces.hex_contact`)."""

    cell, degree, dim, estimates = "hex", 1, 3, True
    label, trace = "Q1", FACE_TRACE
    vtk = "hexahedron"
    element = HEX1_ELEMENT

    centre_gradients, _held, assemble_matrices = Q1.centre_gradients, Q1._held, Q1.assemble_matrices

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        return self.element.loads(body, matrices, nodes)

    def _stack(self, scene, condition):
        """The scene's pairs, those whose faces do not match with the bilinear traces at the nodes of X_h and,
        nested under "gamma3", its rows at the fine side's nodes (:func:`~cvxcontact.fem.hexfaces.hex_pair`)."""
        pairs = [hex_pair(itf, c or condition) for itf, c in zip(scene.interfaces, scene.conditions)]
        return scene.stack if all(a is b for a, b in zip(pairs, scene.interfaces)) else \
            Stack(pairs, scene.stack.members)

    def contact(self, scene, condition: str, law, nodes=None) -> ContactLines:
        hex_contact(self, scene, condition, law)
        lines = super().contact(scene, condition, law, nodes)
        lines = replace(lines, independent=independent_rows(lines.interface.interfaces, scene.conditions, condition))
        if lines.weights is None:
            return lines
        pairs, conditions = lines.interface.interfaces, [c or condition for c in scene.conditions]
        weights = np.concatenate([law_weights(p, c, lw.compliant) for p, c, lw in     # the Q1 hats' face integrals,
                                  zip(pairs, conditions, lines.rows.laws)])           # not the triangles'
        if weights.shape != lines.weights.shape:
            raise SolverError(f"Q1 hexahedra: {len(weights)} quadrature weights for {len(lines.weights)} contact rows")
        return replace(lines, weights=weights, dependent=dependent_law_rows(pairs, conditions, lines.rows.laws))


class Q2Hex(P2Tet):
    """Q2 (27-node, triquadratic Lagrange) hexahedra on the trilinear map of each cell (vertices, edge midpoints,
    face and cell centres: :class:`~cvxcontact.geometry.quadratic.Q2HexNodes`; 3 x 3 x 3 Gauss; why 27 nodes:
    :mod:`cvxcontact.fem.hex`). Its trace on a face is biquadratic (9 nodes); in contact, the Signorini nodal rows
    ("sigma1"/"sigma2") at a body's face nodes, posed by P2Tet's code on the faces' 6-node triangles
    (``Q2HexNodes.triangulation``: on a parallelogram face its 9 nodes are those of its two triangles), exact where
    every row's point is a node of both traces (a rigid obstacle, matching faces); on faces that do not match each
    row reads the other side's biquadratic trace on its faces (:class:`~cvxcontact.fem.q2faces.BiquadraticRows`);
    a normal-compliance law on the same rows, weighted by the biquadratic hats' face integrals
    (:class:`~cvxcontact.fem.q2faces.SimpsonSurface`, docs/formulation.md §15). "gamma3" would evaluate the trace
    between the nodes: refused by name (:func:`~cvxcontact.fem.hexfaces.hex_contact`)."""

    cell, degree, dim, estimates = "hex", 2, 3, True
    label = "Q2"
    matching_faces = True          # cc.adapt keeps its faces meshed alike (refine_together)
    vtk = "hexahedron27"
    element = HEX2_ELEMENT

    def pair_surface(self, itf, nodes, members, condition):
        """The Q2 pair (:func:`~cvxcontact.fem.q2faces.q2_pair`): a compliance law on the nodal rows with the
        biquadratic faces' weights; on faces that do not match, the rows reading the other side's biquadratic
        trace."""
        return q2_pair(itf, nodes, members, condition)

    def node_set(self, mesh):
        return Q2HexNodes(mesh)

    def vtk_cells(self, body, nodes=None) -> list[tuple[str, np.ndarray]]:
        return [(self.vtk, np.asarray((self.nodes(body) if nodes is None else nodes).cells))]

    centre_gradients, _held, assemble_matrices = Q1.centre_gradients, Q1._held, Q1.assemble_matrices

    def assemble_loads(self, body, matrices: BodySystem, nodes=None) -> BodySystem:
        return self.element.loads(body, matrices, self.nodes(body) if nodes is None else nodes)

    def contact(self, scene, condition: str, law, nodes=None) -> ContactLines:
        hex_contact(self, scene, condition, law)
        nodes = [self.nodes(b) for b in scene.bodies] if nodes is None else nodes
        lines = super().contact(scene, condition, law, [n.triangulation for n in nodes])
        return quadratic_pressures(lines, [c or condition for c in scene.conditions])


SPACES = {("triangle", 1): P1, ("triangle", 2): P2, ("tetra", 1): P1Tet, ("tetra", 2): P2Tet, ("quad", 1): Q1,
          ("quad", 2): Q2, ("hex", 1): Q1Hex, ("hex", 2): Q2Hex}
"""The spaces by (cell, degree): the cell type of a mesh (``mesh.cell``) and the element degree."""


def space(degree, cell: str = "triangle") -> Space:
    """The :class:`Space` of ``degree`` (1: P1/Q1, 2: P2/Q2) on cells of type ``cell`` ("triangle", "quad",
    "tetra", "hex": ``mesh.cell``, ``scene.cell``); SolverError for any other value."""
    if isinstance(degree, bool) or degree not in (1, 2):
        raise SolverError(f"degree must be 1 (P1, Q1) or 2 (P2, Q2), got {degree!r}")
    cells = sorted({c for c, _ in SPACES})
    if not isinstance(cell, str) or cell not in cells:
        raise SolverError(f"cell must be one of {cells} (the mesh's cell type, mesh.cell), got {cell!r}")
    return SPACES[cell, degree]()


def needs_matching_faces(element) -> bool:
    """Whether the space ``element`` needs a two-body pair's contact faces meshed alike (its ``matching_faces``;
    False for a space that does not define it: the attribute is optional, a space registered in :data:`SPACES`
    before it existed keeps working)."""
    return bool(getattr(element, "matching_faces", False))


def space_of(body, nodes=None) -> Space:
    """The :class:`Space` of ``body``'s cells whose node set is ``nodes`` (None: the mesh's vertices, degree 1;
    a quadratic node set such as :class:`~cvxcontact.geometry.quadratic.P2Nodes`: degree 2)."""
    return space(1 if nodes is None else 2, body.mesh.cell)
