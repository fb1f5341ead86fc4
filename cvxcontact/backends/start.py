"""A solve started from the contact forces of a solution on another mesh of the same scene: the warm start of
:func:`cvxcontact.adapt` (``ContactSolver(..., start=previous_solution)``).

The state a solution hands on is its contact force as point loads on the contact lines or surfaces
(:class:`ContactState`): per point its pair, its position on the pair (2D: s along the pair's tangent, m; 3D:
(s1, s2) in the pair's plane axes ``frame``, the overlay's vertex coordinates, m) and its force (N/m in 2D, N in
3D). A nodal condition's forces are point loads at the nodes of X_h (3D: the overlay's vertices); the P2 "gamma3" finish's (:mod:`cvxcontact.backends.cuts`) are the point
forces of its cut points, so the state is mesh-independent: the same loads sit at the same places on any mesh.

What a new solve takes from it, only as a start (the answer is the finish's, verified as without it):

- nodal Signorini conditions (2D and 3D): the first active-set guess (:func:`start_active`: the rows where the
  old force, interpolated linearly along s, or in 3D over the Delaunay triangles of the old points, is positive), which the condensed, sparse and AMG routes verify and correct
  instead of running an interior point first (as a re-solve of the same geometry does from its last active set);
- the P2 "gamma3" cones: the cuts' starting points and forces (:func:`cone_seeds`: the P2 nodes of every element
  plus the old loaded points on the new elements), instead of an interior point's tangency seeds; the cuts stop
  at rounding whatever their start (docs/formulation.md §8).

Not used: normal-compliance and mixed laws, friction (:func:`contact_state` returns None there: the contact
term's ``hands_on(raw)``, :mod:`cvxcontact.discrete.terms`); the cones' seeds are 2D only (3D P2 conditions are
nodal rows). A solve computes its state only when it is read
(``Solution.state``, :func:`deferred_state`): most solutions never start another.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator
from scipy.spatial import QhullError

from ..contact.bernstein import point_rows
from .cuts import seed_points, unique_rows

__all__ = ["ContactState", "contact_state", "point_loads", "deferred_state", "start_active", "cone_seeds", "AROUND"]

AROUND = np.array([-1e-2, -1e-3, 1e-3, 1e-2])
"""Offsets (in t) of further zero-force starting points on either side of each loaded point inside an element
(:func:`cone_seeds`), as the interior point's seeds have theirs (:data:`~cvxcontact.backends.cuts.SEED_SPREAD`):
the cuts close in on a tangency point by halving the interval around it. Measured on the adapt study's P2 run
to 17,356 unknowns: 333 rounds in all with these, 336 without, 179 from the interior point's seeds."""


@dataclass(frozen=True)
class ContactState:
    """Contact forces as point loads: ``pair`` (k,) the contact pair of each point, ``s`` its position on the pair
    (m; 2D: (k,) along the pair's tangent; 3D: (k, 2) in the pair's plane axes), ``force`` (k,) its force (N/m
    in 2D, N in 3D, >= 0; zero-force points mark where contact is not)."""

    pair: np.ndarray
    s: np.ndarray
    force: np.ndarray


def _node_pair(lines, nodes) -> np.ndarray:
    """The pair of each stacked node of X_h of the contact lines ``lines``."""
    return np.searchsorted(np.asarray(lines.offsets), nodes, side="right") - 1


def _positions(lines) -> np.ndarray | None:
    """Positions (m) of the stacked nodes of X_h of ``lines``: s (n,) in 2D, (s1, s2) (n, 2) in the pairs' plane
    axes in 3D; None where they have none."""
    x = getattr(lines.interface, "x", None)
    return None if x is None or np.ndim(x) not in (1, 2) else np.asarray(x, dtype=float)


def contact_state(problem, raw) -> ContactState | None:
    """The :class:`ContactState` of an exact finish ``raw`` (scaled) on ``problem``; None where a start does not
    apply (module docstring) or the answer is not an exact finish."""
    if not problem.term.hands_on(raw):
        return None
    return point_loads(problem.lines, problem.units, raw.y, raw.points)


def point_loads(lines, units, y, points=None) -> ContactState | None:
    """The :class:`ContactState` of the row forces ``y`` (scaled) on the contact lines ``lines`` (units
    ``units``), or of the cuts' point forces ``points`` = (segment, t, force) where given (2D); None where the
    lines have no positions."""
    x = _positions(lines)
    if x is None:
        return None
    if points is not None:                          # the cuts' point forces
        segment, t, f = points
        cells = lines.cone[1]
        a, b = x[cells[segment, 0]], x[cells[segment, 2]]
        s, pair = (1 - t) * a + t * b, _node_pair(lines, cells[segment, 0])
    else:                                           # nodal forces on X_h
        f = lines.E.T @ np.asarray(y, dtype=float)
        s, pair = x, _node_pair(lines, np.arange(len(x)))
    force = np.maximum(np.asarray(f, dtype=float), 0.0) * units.force
    return ContactState(pair=np.asarray(pair), s=np.asarray(s, dtype=float), force=force)


def deferred_state(problem, raw) -> Callable[[], ContactState | None] | None:
    """:func:`contact_state` of ``problem`` and ``raw`` as a call made when the state is first read
    (``Solution.state``): :func:`point_loads` on the contact lines, the units and copies of the forces (not the
    bodies' matrices, which a solution kept for a later start would otherwise hold); None where no state applies
    (the same cases as :func:`contact_state`)."""
    if not problem.term.hands_on(raw):
        return None
    points = None if raw.points is None else tuple(np.array(a) for a in raw.points)
    return partial(point_loads, problem.lines, problem.units, np.array(raw.y, dtype=float), points)


def _profile(state, pair, s) -> np.ndarray:
    """The state's force of ``pair`` interpolated linearly at the positions ``s`` (0 outside its points): along s
    in 2D, over the Delaunay triangles of its points in 3D (the nearest point's force where they span no
    triangle)."""
    on = state.pair == pair
    if not on.any() or np.ndim(s) != np.ndim(state.s):
        return np.zeros(len(s))
    if np.ndim(s) == 1:
        order = np.argsort(state.s[on], kind="stable")
        return np.interp(s, state.s[on][order], state.force[on][order], left=0.0, right=0.0)
    points, force = state.s[on], state.force[on]
    try:
        return LinearNDInterpolator(points, force, fill_value=0.0)(s)
    except (QhullError, ValueError):                    # fewer than 3 points, or all on a line
        return NearestNDInterpolator(points, force)(s)


def start_active(problem, state: ContactState) -> np.ndarray:
    """The nodal rows of ``problem`` guessed closed: where the state's force, interpolated linearly
    (:func:`_profile`), is positive at the row's position (the rows read nodes of one pair; a row's position is
    its evaluation of the nodes' positions); none where the state's positions are not this problem's kind (2D
    against 3D)."""
    x = _positions(problem.lines)
    E = problem.E.tocsr()
    if x is None or len(x) != E.shape[1]:
        return np.zeros(E.shape[0], dtype=bool)
    weight = np.maximum(np.asarray(abs(E).sum(axis=1)).ravel(), np.finfo(float).tiny)
    where = E @ x / weight.reshape((-1,) + (1,) * (x.ndim - 1))
    pair = _node_pair(problem.lines, E.indices[E.indptr[:-1]])
    active = np.zeros(E.shape[0], dtype=bool)
    for i in np.unique(pair):
        rows = pair == i
        active[rows] = _profile(state, i, where[rows]) > 0
    return active


def cone_seeds(problem, state: ContactState):
    """(element, t, y0) of the cuts' first round on ``problem``'s cones: the state's loaded points on the elements
    that hold them (their forces, scaled), then the P2 nodes of every element at zero force (a point on a node
    is that node, once)."""
    B, cells = problem.lines.cone
    x = _positions(problem.lines)
    a, b = x[cells[:, 0]], x[cells[:, 2]]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    element_pair = _node_pair(problem.lines, cells[:, 0])
    seg, t, y = [], [], []
    loaded = state.force > 0
    for i in np.unique(state.pair[loaded]):
        own = np.flatnonzero((element_pair == i) & (hi > lo))
        if not len(own):
            continue
        own = own[np.argsort(lo[own], kind="stable")]
        pts = np.flatnonzero(loaded & (state.pair == i))
        s = state.s[pts]
        j = np.clip(np.searchsorted(lo[own], s, side="right") - 1, 0, len(own) - 1)
        e = own[j]
        inside = (s >= lo[e]) & (s <= hi[e])
        e, s, pts = e[inside], s[inside], pts[inside]
        te = np.clip((s - a[e]) / (b[e] - a[e]), 0.0, 1.0)
        seg.append(e)
        t.append(te)
        y.append(state.force[pts] / problem.units.force)
        inner = (te > 0) & (te < 1)
        near = (te[inner][:, None] + AROUND[None, :]).ravel()       # the cuts close in on t* from both sides
        at = np.repeat(e[inner], len(AROUND))
        ok = (near > 0) & (near < 1)
        seg.append(at[ok])
        t.append(near[ok])
        y.append(np.zeros(int(ok.sum())))
    nodes_seg, nodes_t = seed_points(B)
    seg = np.concatenate(seg + [nodes_seg]).astype(int)
    t = np.concatenate(t + [nodes_t])
    y = np.concatenate(y + [np.zeros(len(nodes_t))])
    keep = unique_rows(point_rows(B, seg, t))
    return seg[keep], t[keep], y[keep]
