"""Given friction thresholds that overlap (docs/howto/friction.md, "Obstacles that overlap"): where several
obstacle pairs with a friction capacity that does not scale with the pair's own normal force (``cc.Tresca``:
its threshold g is given) reach the same node of one body's contact part, each pair's row there weighs the
node's whole hat over the part (the law's weights, docs/formulation.md §10), so the discrete problem resists the
slip there by (g1 + g2 + ...) w_a, not by one threshold. The normal forces are shared between such pairs (their
sum at the node is fixed by the body's balance, :mod:`cvxcontact.solution.sides`) and so is Coulomb's capacity
mu y_a (each pair's is mu times its own share of the node's force: they sum to mu times that force), so only a
given threshold adds up. :func:`overlapping_thresholds` finds such nodes when the problem is derived and
:func:`warn_overlapping_thresholds` says so with an :class:`~cvxcontact.errors.OverlapWarning` (a warning, not a
refusal: two layers may be meant).

A node is overlapped where the pairs' weights there sum to more than the weight of one obstacle reaching the
whole part (the pair's ``reaching`` copy of the whole trace): the capacity there exceeds the largest threshold
times the node's own weight. A node shared by two obstacles at the end of their runs (strips x <= 0.4 and
x >= 0.4, both reaching the node x = 0.4) then counts where each row there weighs the node's whole hat (P1 lines,
3D faces: the capacity on that hat is doubled), not where each run's end row weighs its own side (a 2D P2 line:
Simpson's h/6 on each run's segment, together the node's h/3, no capacity added). Two-body pairs are not read:
their rows weigh shares of their own overlap (pairs meeting at a node split its hat), and two bodies overlapping on
one part would interpenetrate.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..contact.sides import held_sides
from ..errors import OverlapWarning, user_stacklevel
from .slip import friction_weights

__all__ = ["overlapping_thresholds", "warn_overlapping_thresholds"]

_AT_NODE = 1.0 - 1e-9
"""A row sits at a trace node where the node's interpolation weight is 1 (a P2 midpoint reads 1 - 1e-16)."""

_EXCESS = 1e-9
"""The pairs' weights at a node overlap where they sum to more than one obstacle's by this fraction (rounding)."""


def _whole_part(itf, condition):
    """(trace nodes,) m (m^2 in 3D): the weights of one obstacle pair reaching the whole part of the obstacle pair
    ``itf`` (its ``reaching`` copy of every trace node) under ``condition``, at each node of its trace; None where
    the pair has no such copy."""
    reaching = getattr(itf, "reaching", None)
    n = itf.interpolation(0).shape[1]
    whole = reaching(np.ones(n, dtype=bool)) if reaching is not None else None
    if whole is None:
        return None
    w = np.asarray(whole.weights(condition), dtype=float)
    at = whole.interpolation(0).tocoo()
    keep = at.data > _AT_NODE
    if len(w) != whole.interpolation(0).shape[0]:
        return None
    out = np.full(n, np.nan)
    out[at.col[keep]] = w[at.row[keep]]
    return out


def overlapping_thresholds(lines, condition, conditions) -> list[dict]:
    """The overlaps of given friction thresholds on the contact lines ``lines`` (module docstring), one per
    contact part where some node is reached by two or more obstacle pairs whose rows there have a given
    threshold g > 0 and whose weights there sum to more than one obstacle's over the whole part: a dict with
    ``side`` (scene body index, part), ``pairs`` (the pairs' indices among the scene's contacts reaching an
    overlapped node), ``nodes`` (the body's node indices overlapped), ``area`` (m; m^2 in 3D: the nodes' weights
    under one obstacle over the whole part, summed), ``threshold`` (Pa: the largest capacity at one of those nodes
    over its weight, sum_p g_p w_p / w: g1 + g2 where each pair's row weighs the whole hat) and ``single`` (Pa:
    the largest threshold of one of the pairs there). ``condition``, ``conditions``: the solve's condition and
    each pair's own (None: the solve's). Vectorised over the rows (sorting, no pairwise comparison of the pairs'
    nodes)."""
    stack, rows, E = lines.interface, lines.rows, lines.E
    pairs = getattr(stack, "interfaces", ())
    if len(pairs) < 2 or E.shape[0] != rows.size:
        return []
    g = np.where(rows.pressure_dependent, 0.0, rows.thresholds(0.0))          # Pa: the given thresholds
    row_at = np.concatenate([[0], np.cumsum(rows.counts)])
    candidates = [i for i, p in enumerate(pairs)
                  if getattr(p, "rigid", False) and (g[row_at[i]:row_at[i + 1]] > 0).any()]
    if len(candidates) < 2:
        return []
    weights = friction_weights(lines, condition, conditions)
    names: list = []                                   # the sides (scene body index, part) the candidates hold
    sides, node, pair, thr, wt, ref = [], [], [], [], [], []
    for key, (name, held) in enumerate(held_sides(stack, candidates).items()):
        names.append(name)
        first = held[0][0]
        reach = np.asarray(pairs[first].traces[0].nodes)
        part = _whole_part(pairs[first], condition if not conditions or conditions[first] is None else
                           conditions[first])
        known = np.full(reach.max() + 1, np.nan)       # one obstacle's weight at each body node (its first pair's)
        if part is not None:
            known[reach] = part
        for i, _ in held:                              # an obstacle pair: one side
            itf, (r0, r1), (o0, o1) = pairs[i], row_at[i:i + 2], stack.offsets[i:i + 2]
            nodes = np.asarray(itf.traces[0].nodes)
            at = (E[r0:r1, o0:o1] @ itf.interpolation(0)).tocoo()
            keep = (at.data > _AT_NODE) & (g[r0 + at.row] > 0)
            a, t = at.row[keep], at.col[keep]
            sides.append(np.full(len(a), key, dtype=int))
            node.append(nodes[t])
            pair.append(np.full(len(a), i))
            thr.append(g[r0 + a])
            wt.append(weights[r0 + a])
            ids = nodes[t]                             # another pair's trace may hold other nodes: nan
            ref.append(np.where(ids < len(known), known[np.minimum(ids, len(known) - 1)], np.nan))
    side, node, pair, thr, wt, ref = (np.concatenate(v) for v in (sides, node, pair, thr, wt, ref))
    if len(node) == 0:
        return []
    # one entry per (side, node, pair): the rows of one pair at a node counted once
    order = np.lexsort((pair, node, side))             # stable: a pair's rows at a node in their order
    side, node, pair, thr, wt, ref = side[order], node[order], pair[order], thr[order], wt[order], ref[order]
    new = np.r_[True, (np.diff(side) != 0) | (np.diff(node) != 0) | (np.diff(pair) != 0)]
    side, node, pair, thr, wt, ref = side[new], node[new], pair[new], thr[new], wt[new], ref[new]
    start = np.flatnonzero(np.r_[True, (np.diff(side) != 0) | (np.diff(node) != 0)])   # one group per node
    count = np.diff(np.r_[start, len(node)])
    summed, single, heaviest, capacity = (np.add.reduceat(wt, start), np.maximum.reduceat(thr, start),
                                          np.maximum.reduceat(wt, start), np.add.reduceat(thr * wt, start))
    one = np.where(np.isnan(ref[start]), heaviest, ref[start])       # one obstacle's weight at the node
    shared = (count > 1) & (summed > one * (1.0 + _EXCESS))
    on = np.repeat(shared, count)                                      # the entries at an overlapped node
    found = []
    for s in np.unique(side[start[shared]]):
        here = shared & (side[start] == s)
        found.append({"side": names[s], "pairs": sorted(set(pair[on & (side == s)].tolist())),
                      "nodes": node[start[here]], "area": float(one[here].sum()),
                      "threshold": float((capacity[here] / one[here]).max()), "single": float(single[here].max())})
    return found


def warn_overlapping_thresholds(scene, lines, condition, meshes) -> list[dict]:
    """Warn (:class:`~cvxcontact.errors.OverlapWarning`) once per contact part where given friction thresholds
    of several obstacle pairs of ``scene`` overlap on ``lines`` under ``condition`` (:func:`overlapping_thresholds`,
    module docstring), naming the nodes and where they lie (``meshes``: each body's node set, ``points`` in m); the
    overlaps found (empty: no warning)."""
    found = overlapping_thresholds(lines, condition, scene.conditions)
    unit = ("m", "m^2")[scene.dim - 2]
    for o in found:
        k, part = o["side"]
        named = "; ".join(f"contacts[{i}] {scene.contacts[i]!r}" for i in o["pairs"])
        n, where = len(o["nodes"]), _where(meshes[k].points, o["nodes"])
        warning = OverlapWarning(
            f"given friction thresholds overlap on {scene.bodies[k].name}'s contact part {part!r}: the pairs {named} "
            f"reach {n} of its nodes together ({where}; two or more of them at each; the nodes' weights summing to "
            f"{o['area']:.6g} {unit}), where their friction capacities add (g1 + g2 + ...): the slip there is "
            f"resisted by up to {o['threshold']:.6g} Pa, not the {o['single']:.6g} Pa of one pair (the normal "
            "forces, and Coulomb's capacity mu lambda, are shared between the pairs; a given threshold is each "
            "pair's own). If the obstacles are meant as one surface, split them so that each node is reached by "
            "one pair with a threshold (or give the overlap to one pair); two layers that are meant to add may be "
            "kept")
        # the same on every mesh of the scene: cc.adapt says it once
        warning.about = (k, part, tuple(o["pairs"]))
        warnings.warn(warning, stacklevel=user_stacklevel())
    return found


def _where(points, nodes, shown=6) -> str:
    """Where the overlapped ``nodes`` (the body's node indices) lie: the first ``shown`` of them and the box of
    their coordinates ``points`` (m)."""
    x = np.asarray(points, dtype=float)[nodes]
    listed = ", ".join(str(int(a)) for a in nodes[:shown]) + (", ..." if len(nodes) > shown else "")
    corner = ["(" + ", ".join(f"{c:.6g}" for c in v) + ")" for v in (x.min(axis=0), x.max(axis=0))]
    return f"nodes {listed}, in the box from {corner[0]} to {corner[1]} m"
