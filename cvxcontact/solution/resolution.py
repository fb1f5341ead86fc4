"""Is the contact zone resolved by the mesh? The checks behind :class:`~cvxcontact.errors.ResolutionWarning`.

On each side of each contact pair, the contact zone is the set of the body's trace nodes where the pressure
it feels is positive (2D: :meth:`Solution.traction <cvxcontact.solution.Solution.traction>`, above 1e-9 of its
largest value, as :meth:`~cvxcontact.solution.Solution.in_contact`; 3D: the nodal forces its trace nodes
receive, interpolation(k)^T of the pair's forces, above 1e-9 of their largest: they are local, where the P2
Riesz pressure of a small zone has lobes of either sign over the whole face). Each connected set of such
nodes (joined by the faces they share) is one zone; the contact faces that touch it (a face with a node in the zone) carry its pressure. Two rules:

* **cells across the zone**: in 2D the faces touching the zone (P2: the half-faces between consecutive P2
  nodes, where the pressure has its values: the README's P2 floor zone of 3 faces, 6 half-faces, reads its
  peak within 0.5 % of a mesh refined three times); in 3D the same count across the zone's narrowest
  direction, width / h + 2 (width: the extent of its nodes along their minor principal axis; h = sqrt(2 |F|)
  of the median area |F| of the faces touching it: the leg of a right isosceles face, 0.93 of an equilateral
  face's edge; P2: h / 2, the spacing of the P2 nodes; + 2: the faces on either side that carry the pressure
  of its outermost nodes, as the 2D count has them), rounded to an integer: the least width of a ring of nodes
  around a vertex of a triangulated face is cos 30 deg = 0.87 of its diameter (the README's PZT disc: a centre
  node and a ring of six, 3.7 -> 4, the 2D count of a centre node and its two neighbours). On a structured
  face it is the 2D count along that direction. With fewer than :data:`MIN_CELLS` the pressure's shape across the zone is not resolved: a
  Hertz zone of 1-3 faces gives a peak pressure tens of per cent off while the discrete problem is solved
  exactly. A zone covering every node of the face a side offers (a flat punch) has no edge to resolve and is
  not counted.
* **shape of the contact cells**: the cells owning the faces that touch a zone have aspect ratio at most
  :data:`MAX_ASPECT` (:func:`aspect_ratios`: longest edge over the inscribed circle's (sphere's) diameter,
  normalised to 1 for the equilateral triangle (regular tetrahedron)); a cell far longer than it is thick
  across the zone makes the gradients of the contact stress depend on its direction.

A pair against a rigid obstacle has one side; of a pair of bodies the sides whose nodes carry the pair's forces
are checked (both under "gamma3", body l under "sigma_l": under "sigma2" the forces sit at body 2's nodes and
the pressure body 1 feels is a row of spikes whatever body 1's mesh).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..contact.sides import pair_sides
from ..fem.trace import TRACES
from ..geometry.quadratic import P2Nodes
from .solution import pair_label

__all__ = ["MAX_ASPECT", "MIN_CELLS", "UNHELD_TOL", "aspect_ratios", "rowless", "unheld", "unresolved", "zone_cells"]

UNHELD_TOL = 1e-9
"""A P2 midpoint no row holds (:func:`unheld`) is reported where it penetrates the obstacle it reaches by more than
this times the body's largest displacement (rounding is some 1e-16 of it)."""

MIN_CELLS = 4
"""The fewest cells of a body (2D: contact faces, 3D: face sizes across the zone) that must span a contact
zone."""

MAX_ASPECT = 20.0
"""The largest aspect ratio (:func:`aspect_ratios`) of a cell owning a face that touches a contact zone."""


@dataclass(frozen=True)
class _Zone:
    """One contact zone of one side: ``across`` cells across it (float in 3D), ``where`` its location in words,
    ``width`` (m) its extent across (the loaded nodes'), ``h`` (m) the size of its faces, ``whole`` True if it
    covers every node of the face the side offers, ``facets`` (k, d) the mesh vertices of the faces touching it."""

    across: float
    where: str
    width: float
    h: float
    whole: bool
    facets: np.ndarray


def zone_cells(x, pressure) -> list[tuple[int, float, float]]:
    """The contact zones along one 2D trace: (faces touching the zone, s_first, s_last) per connected run of
    nodes with positive ``pressure`` (above 1e-9 of its largest value), ``x`` the nodes' tangential
    coordinates (m, sorted; P2: vertices and midpoints interleaved, and each half-face between two of its
    nodes counts as one cell)."""
    return [(len(iv), lo, hi) for iv, lo, hi in _runs(x, pressure)]


def _runs(x, pressure):
    """(the intervals between consecutive nodes touching the zone, s_first, s_last) per zone of a 2D trace."""
    x, p = np.asarray(x, dtype=float), np.asarray(pressure, dtype=float)
    top = float(np.abs(p).max(initial=0.0))
    if top == 0 or len(x) < 2:
        return []
    on = p > 1e-9 * top
    touched = on[:-1] | on[1:]                                   # the intervals between consecutive nodes
    out = []
    edges = np.flatnonzero(np.diff(np.r_[0, touched.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        nodes = np.flatnonzero(on[a: b + 1]) + a
        out.append((np.arange(a, b), float(x[nodes[0]]), float(x[nodes[-1]])))
    return out


def aspect_ratios(points, cells) -> np.ndarray:
    """Aspect ratio of each simplex: its longest edge over the diameter of its inscribed circle (2D) or sphere
    (3D), divided by that of the regular simplex (sqrt(3), sqrt(6)) so that the equilateral triangle and the
    regular tetrahedron have 1; r_in = d |K| / |dK|. ``points`` (n, d) m, ``cells`` (m, d + 1)."""
    P = np.asarray(points, dtype=float)[np.asarray(cells)]
    d = P.shape[2]
    pairs = [(i, j) for i in range(d + 1) for j in range(i + 1, d + 1)]
    edges = np.linalg.norm(np.stack([P[:, j] - P[:, i] for i, j in pairs], axis=1), axis=2)
    E = P[:, 1:] - P[:, :1]
    if d == 2:
        size = 0.5 * np.abs(E[:, 0, 0] * E[:, 1, 1] - E[:, 0, 1] * E[:, 1, 0])
        boundary = edges.sum(axis=1)
        regular = np.sqrt(3.0)
    else:
        size = np.abs(np.einsum("mi,mi->m", E[:, 0], np.cross(E[:, 1], E[:, 2]))) / 6.0
        opposite = [[k for k in range(4) if k != i] for i in range(4)]
        boundary = sum(0.5 * np.linalg.norm(np.cross(P[:, b] - P[:, a], P[:, c] - P[:, a]), axis=1)
                       for a, b, c in opposite)
        regular = np.sqrt(6.0)
    inradius = d * size / np.maximum(boundary, np.finfo(float).tiny)
    return edges.max(axis=1) / np.maximum(2 * inradius, np.finfo(float).tiny) / regular


def _owners(cells, facets, near=None) -> np.ndarray:
    """The cell owning each boundary facet (k, d) (mesh vertex indices) among ``cells`` (m, d + 1). ``near``: the
    sorted indices of some cells among which is every cell with a vertex on a facet (e.g. the cells at the facets'
    boundary part, :meth:`~cvxcontact.geometry.base.CellMesh.cells_at`), searched instead of all."""
    cells, facets = np.asarray(cells), np.asarray(facets)
    n = int(max(cells.max(initial=0), facets.max(initial=0))) + 1
    touched = np.zeros(n, dtype=bool)
    touched[facets.ravel()] = True
    if near is None:
        near = np.flatnonzero(touched[cells].any(axis=1))          # the cells with a vertex on a facet
    else:
        near = near[touched[cells[near]].any(axis=1)]              # the same cells, from a superset
    d1 = cells.shape[1]
    local = np.array([[j for j in range(d1) if j != i] for i in range(d1)])
    mine = np.sort(cells[near][:, local], axis=2).reshape(-1, d1 - 1)
    weights = n ** np.arange(d1 - 1, dtype=np.int64)
    keys = mine.astype(np.int64) @ weights
    order = np.argsort(keys, kind="stable")
    want = np.sort(facets, axis=1).astype(np.int64) @ weights
    hit = order[np.searchsorted(keys[order], want)]
    return near[hit // d1]


def _linear_trace(itf, k):
    """The P1 trace of side k (the linear interface's, for a P2 one)."""
    return itf.linear.traces[k] if hasattr(itf, "linear") else itf.traces[k]


def _zones_2d(sol, itf, k, p, merged, trace) -> list[_Zone]:
    """The zones of side k of a 2D pair (:class:`_Zone`; ``p`` the pressure at ``itf.traces[k].x``; ``trace``
    the solution's :mod:`~cvxcontact.fem.trace`)."""
    side = itf.traces[k]
    x = np.asarray(side.x, dtype=float)
    nodes = np.asarray(side.nodes)
    tol = 1e-9 * max(float(np.ptp(x)), np.finfo(float).tiny)
    face = (x >= merged.min() - tol) & (x <= merged.max() + tol)           # the nodes that can touch
    step = trace.step
    h = float(np.median(np.diff(x[::step])))
    out = []
    for intervals, lo, hi in _runs(x, p):
        first = intervals // step * step                                   # each interval's face: its vertices
        facets = np.column_stack([nodes[first], nodes[first + step]])
        inside = x[face]                                                   # none: the overlap inside a face
        whole = bool(inside.size and lo <= inside.min() + tol and hi >= inside.max() - tol)
        out.append(_Zone(len(intervals), f"s = {lo:.6g} to {hi:.6g} m", hi - lo, h, whole, facets))
    return out


def _zones_3d(sol, itf, k, p, merged, trace) -> list[_Zone]:
    """The zones of side k of a 3D pair (:class:`_Zone`): connected sets of loaded nodes (joined by the faces
    they share), width / h + 2 cells across (module docstring)."""
    side = itf.traces[k]
    x = np.asarray(side.x, dtype=float)                                    # (n, 2) in-plane coordinates
    faces = np.asarray(side.faces)                                         # (f, 3) or (f, 6), local
    nodes = np.asarray(side.nodes)
    top = float(np.abs(p).max(initial=0.0))
    if top == 0:
        return []
    on = p > 1e-9 * top
    size = max(float(np.ptp(x, axis=0).max()), np.finfo(float).tiny)
    lo_m, hi_m = merged.min(axis=0) - 1e-9 * size, merged.max(axis=0) + 1e-9 * size
    can = ((x >= lo_m) & (x <= hi_m)).all(axis=1)                          # the nodes that can touch
    f_on = on[faces]
    rows = np.repeat(np.arange(len(faces)), faces.shape[1])[f_on.ravel()]
    cols = faces.ravel()[f_on.ravel()]
    incidence = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(faces), len(x)))
    _, label = connected_components(incidence.T @ incidence, directed=False)
    V = x[faces[:, :3]]
    areas = 0.5 * np.abs((V[:, 1, 0] - V[:, 0, 0]) * (V[:, 2, 1] - V[:, 0, 1])
                         - (V[:, 1, 1] - V[:, 0, 1]) * (V[:, 2, 0] - V[:, 0, 0]))
    out = []
    for zone in np.unique(label[on]):
        mine = on & (label == zone)
        touching = (mine[faces]).any(axis=1)
        loaded = x[mine]
        centre = loaded.mean(axis=0)
        if len(loaded) > 1:
            _, vecs = np.linalg.eigh(np.cov((loaded - centre).T) + 1e-30 * np.eye(2))
            minor = vecs[:, 0]
        else:
            minor = np.array([1.0, 0.0])
        h = float(np.sqrt(2 * np.median(areas[touching]))) / trace.step       # between nodes
        width = float(np.ptp(loaded @ minor))
        where = (f"around ({centre[0]:.4g}, {centre[1]:.4g}) m in the plane's axes, {len(loaded)} loaded "
                 f"node{'s' if len(loaded) != 1 else ''}")
        out.append(_Zone(float(np.round(width / h + 2)), where, width, h, bool(mine[can].all()), nodes[faces[touching][:, :3]]))
    return out


def unresolved(sol) -> list[str]:
    """The messages of :class:`~cvxcontact.errors.ResolutionWarning` for ``sol`` (module docstring): one per
    contact zone of a checked side spanned by fewer than :data:`MIN_CELLS` cells (unless it covers the whole
    face), and one per zone whose contact cells have an aspect ratio above :data:`MAX_ASPECT`; 2D and 3D."""
    dim = sol.scene.dim
    zones_of = _zones_2d if dim == 2 else _zones_3d
    out = []
    for i, pair in enumerate(sol.scene.contacts):
        sides = [(sol.scene.bodies[k], part) for k, part in pair_sides(sol.scene.stack, i)]
        condition = sol.scene.conditions[i] or sol.condition
        merged = np.asarray(sol.contacts[i].x, dtype=float)
        itf = sol._pair_line(i)
        trace = sol.contacts[i].trace
        for k, (body, part) in enumerate(sides):
            if not pair.rigid and condition in ("sigma1", "sigma2") and k != int(condition[-1]) - 1:
                continue
            if dim == 2:
                _, p = sol.traction(k, i)
            else:                                       # the nodal forces: local (module docstring)
                p = itf.interpolation(k).T @ np.asarray(sol.contacts[i].force, dtype=float)
            head = f"contact[{i}] {pair_label(sol, i)}: the contact zone on {body.name}/{part}"
            for z in zones_of(sol, itf, k, np.asarray(p, dtype=float), merged, trace):
                if z.across < MIN_CELLS and not z.whole:
                    out.append(_too_few(head, z, body.name, part, dim, trace))
                simplices = getattr(body.mesh, "split", body.mesh)     # quadrilaterals, hexahedra: their simplices
                at = np.isin(z.facets, simplices.boundary_nodes(part)).all()     # the zone's facets on its part:
                cells = _owners(simplices.cells, z.facets, simplices.cells_at(part) if at else None)  # its cells
                ratio = aspect_ratios(simplices.points, simplices.cells[cells])
                if ratio.max() > MAX_ASPECT:
                    worst = cells[int(np.argmax(ratio))]
                    out.append(f"{head} ({z.where}) lies on {len(cells)} cell{'s' if len(cells) != 1 else ''} of "
                               f"{body.name} with aspect ratio up to {ratio.max():.3g} (cell {worst}; above "
                               f"{MAX_ASPECT:g}; 1 is the {'equilateral triangle' if dim == 2 else 'regular tetrahedron'}"
                               f"): cells that elongated do not resolve the stress across the zone. Remesh the cells "
                               f"along {part!r} there with aspect ratio at most {MAX_ASPECT:g} (e.g. more cells "
                               f"across the body's thickness near the contact, or fewer along the face).")
    return out


def rowless(sol) -> list[str]:
    """The messages of :class:`~cvxcontact.errors.ResolutionWarning` for the pairs of two bodies that meet over an
    overlap of positive extent while their condition puts no row on it: under "sigma_l" the rows are the nodes of
    body l's part inside the overlap (K_h(Sigma_h^l)), and a part coarser than the overlap has none, so nothing
    keeps the bodies apart there. Independent of the estimate (a solution is exact for a problem without rows)."""
    out = []
    for i, pair in enumerate(sol.scene.contacts):
        c = sol.contacts[i]
        x = np.asarray(c.x, dtype=float).reshape(len(c.x), -1)
        if pair.rigid or len(x) < 2 or np.asarray(c.constrained).any() or not np.ptp(x, axis=0).all():
            continue
        condition = sol.scene.conditions[i] or sol.condition
        body, part = ((pair.body_a, pair.part_a), (pair.other, pair.part_b))[condition == "sigma2"]
        other = "sigma1" if condition == "sigma2" else "sigma2"
        where = ", ".join(f"{lo:.6g} to {hi:.6g}" for lo, hi in zip(x.min(axis=0), x.max(axis=0)))
        over = np.asarray(c.jump, dtype=float) - (0.0 if c.gap is None else np.asarray(c.gap, dtype=float))
        out.append(f"contact[{i}] {pair_label(sol, i)}: under {condition!r} the rows are the nodes of "
                   f"{body.name}/{part} inside the overlap of the pair (s = {where} m), and there is none: nothing "
                   f"keeps the bodies apart there (largest [u_nu] - g at the merged nodes: {over.max():.3g} m, "
                   f"positive: interpenetration). Use condition={other!r} or 'gamma3', or refine {part!r} of "
                   f"{body.name} so that its nodes fall in the overlap.")
    return out


def _too_few(head, z, name, part, dim, trace) -> str:
    """The message of a zone spanned by fewer than MIN_CELLS cells."""
    need = max(z.width, z.h) / MIN_CELLS
    if dim == 2:
        unit = f"{trace.span}{'s' if z.across != 1 else ''}"
        return (f"{head} ({z.where}, {z.width:.3g} m wide) is carried by {z.across} {unit} of {name} "
                f"(fewer than {MIN_CELLS}; faces about {z.h:.3g} m long): its pressure is not resolved. "
                f"Refine the contact face there: faces of at most {need:.3g} m along {z.where} (e.g. "
                f"cc.graded_block towards the zone, or more cells along {part!r}).")
    return (f"{head} ({z.where}, {z.width:.3g} m across its narrowest direction) is spanned by {z.across:.0f} "
            f"faces of {name} (fewer than {MIN_CELLS}; faces of about {z.h:.3g} m{trace.spacing}): "
            f"its pressure is not resolved. Refine the contact face there: faces of at most {need:.3g} m "
            f"across the zone (e.g. refine the mesh towards it, or more cells along {part!r}).")


def unheld(sol) -> list[str]:
    """The messages of :class:`~cvxcontact.errors.ResolutionWarning` for the P2 midpoints of a 2D body's contact
    part that reach a rigid obstacle (its distance finite there) which no row of that pair holds, and which the
    answer pushes into that obstacle (by more than :data:`UNHELD_TOL` of the body's largest displacement). A 2D P2
    pair reads the reach at the vertices: its X_h is the P2 line of its run of reaching vertices, whole segments
    (docs/formulation.md, "Rigid obstacles"), so a segment with one vertex out of reach is not in it, though its
    midpoint may lie over the obstacle: two obstacles meeting inside a segment (neither run holds it), or an
    obstacle whose reach starts inside the segment beside another's run (only the other's rows hold it). Nothing
    of K_h(Sigma_h) keeps the midpoint out of that obstacle, the checks pass (the discrete problem is solved) and
    the answer is not the one obstacle's of the same surface. Independent of the estimate. A force-controlled
    obstacle is read where the answer translated it (:attr:`ObstacleResult.translation
    <cvxcontact.solution.solution.ObstacleResult.translation>`)."""
    out = []
    if sol.scene.dim != 2 or TRACES[sol.degree].step < 2:      # no node between two vertices: X_h holds them all
        return out
    nodes = {}
    moved = {id(o.obstacle): o.translation for o in sol.obstacles if np.any(o.translation)}   # force controlled
    for i, pair in enumerate(sol.scene.contacts):
        itf = sol.scene.interfaces[i]
        if not pair.rigid or not getattr(itf, "rigid", False):
            continue
        trace = itf.traces[0]
        v, x = np.asarray(trace.nodes), np.asarray(trace.x, dtype=float)
        if len(v) < 2:
            continue
        reached = np.zeros(len(v), dtype=bool)
        reached[np.asarray(itf.reach)] = True
        mid = 0.5 * (np.asarray(trace.points)[:-1] + np.asarray(trace.points)[1:])
        obstacle = itf.obstacle if id(itf.obstacle) not in moved else itf.obstacle.moved(by=moved[id(itf.obstacle)])
        d = np.asarray(obstacle.distance(mid, itf.normal), dtype=float)     # where the answer put it (its t)
        off = np.flatnonzero(np.isfinite(d) & ~(reached[:-1] & reached[1:]))      # over the obstacle, not in X_h
        if not len(off):
            continue
        k = sol.scene.stack.members[i][0]
        body = sol.scene.bodies[k]
        if k not in nodes:
            nodes[k] = P2Nodes(body.mesh)
        u = np.asarray(sol.u[k], dtype=float)
        at = nodes[k].midpoint(v[off], v[off + 1])
        s = 0.5 * (x[off] + x[off + 1])
        load = sol.scene.contacts[i].gap
        g = np.asarray(load(s, np.full_like(s, itf.y)), dtype=float) + d[off]
        over = u[at] @ np.asarray(itf.normal, dtype=float) - g
        bad = over > UNHELD_TOL * max(float(np.abs(u).max(initial=0.0)), np.finfo(float).tiny)
        if not bad.any():
            continue
        segs = "; ".join(f"s = {x[j]:.6g} to {x[j + 1]:.6g} m (midpoint in by {o:.3g} m)"
                         for j, o in zip(off[bad], over[bad]))
        out.append(f"contact[{i}] {pair_label(sol, i)}: the P2 midpoint of {int(bad.sum())} segment(s) of "
                   f"{body.name}/{pair.part_a} lies over this obstacle but no row of the pair holds it (a 2D P2 "
                   f"pair's rows are the P2 nodes of its run of reaching vertices, whole segments): {segs}. The "
                   f"answer pushes it into the obstacle; the checks do not see it (it is not a row). Put a vertex "
                   f"of {pair.part_a!r} where the obstacle's reach ends, or let the obstacle's distance be finite "
                   f"up to the segment's far vertex (beside another obstacle there the rows are parallel and the "
                   f"tighter holds), or use degree=1.")
    return out
