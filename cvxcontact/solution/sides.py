"""lambda_h read once per side (docs/accuracy.md, "Several pairs on one part"): where several contact pairs hold
one contact part (a side: body, part), the forces they put on it are summed and lambda_h is solved once on the
union of their supports, each pair then reading its part of it; a pair alone on its sides reads its own
``multiplier`` (unchanged, bit for bit).

The forces of one node shared by several rows of one body are the solver's split of that node's force between
the pairs (arbitrary where the rows depend on each other), so a pair's own Riesz representer reads that split; the
sum over the pairs of a side is the body's force there, fixed by its balance. Two cases are read once:

- obstacles on one part (every pair of the group rigid, one side): the forces summed on the trace's nodes and
  lambda_h read by a copy of one of the pairs whose X_h is the nodes any of them reaches (``reaching``): the
  consistent mass of the part where they reach all of it, the law's weights (P1: r / w; 3D P2: the partial mass)
  where they do not (2D P2: the union run's P2 line; not a run: each pair keeps its own ``multiplier``). The
  estimate sums the pairs' functions, so each pair reads its share of the side's lambda_h at its nodes: each
  node's basis function lives on the whole part (P1, 3D P2), so the share is one over the number of the group's
  pairs reaching the node (of those whose contact is closed there, where one is: an obstacle open at a node,
  its force 0, takes no share of the floor's lambda_h, which its complementarity would charge on its open gap);
  a 2D P2 pair's function lives on its run alone, so the shares are the run's (``shares`` of the union: on each
  segment the runs holding it sum to 1, and of the runs holding the same segments at a node those closed there take
  its share, ``shares(S, closed)``: a floor open under a strip raised above it leaves the strip's nodes to the
  strip; the floor keeps a node where the strip's run starts, which the strip's function cannot reach from the
  other side). A pair closed nowhere (never touched) reads its own, 0.
- two-body pairs of planar surfaces (3D) sharing a side (a body on several bodies): lambda_h in X_h of the
  group, the functions of every side on the pairs' nodes stacked (one column block per side, a shared side's
  functions read by each of its pairs), the pairs' masses block diagonal, the Riesz representer of the stacked
  forces by :class:`~cvxcontact.contact.riesz.TraceRiesz`: its right-hand side is the work on every side's
  functions, on a shared side the forces summed over its pairs. The pairs' overlays are disjoint, so each pair
  reads its own nodes' values.

A friction law's t_h on 3D P2 faces (the Riesz representer of the tangential forces, as lambda_h is of the normal
ones) is read by the same rule, per tangential component (``trace.shear_multiplier`` from the friction read-back,
:mod:`cvxcontact.solution.friction`), frictionless pairs each alone; a Tresca pair counts as closed at every node
(its open rows hold up to g w_a too: a pair closed nowhere may carry part of the side's tangential forces).

Other groups (a two-body pair beside obstacles on one part, 2D two-body pairs, pairs reading lambda_h by a
representer of their own) keep each pair's ``multiplier``, and so does a normal-compliance pair (its read-back sets
lambda_h from its law; its forces are not summed into a Signorini pair's side).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contact.riesz import TraceRiesz
from ..contact.sides import pair_sides, side_groups

__all__ = ["side_multiplier"]


def side_multiplier(stack, r, alone=(), active=None) -> np.ndarray:
    """lambda_h at the stacked nodes of X_h of every pair of ``stack`` (the contact lines' stack: ``interfaces``,
    ``members``, ``offsets``) for the stacked row forces ``r`` (units of ``r`` per unit length or area), read once
    per side where several pairs hold one (module docstring). The pairs ``alone`` (indices: a normal-compliance
    law's, whose read-back sets lambda_h from its law) and a single pair (``stack`` the pair itself) read their own
    ``multiplier``. ``active`` (bool per stacked node of X_h, or None): the nodes where each pair's contact is
    closed; a pair closed nowhere reads its own (its forces, 0: lambda_h 0, not a share of its neighbours'), and
    the shares of obstacles on one part go to the pairs closed at each node (module docstring)."""
    r = np.asarray(r, dtype=float)
    if not hasattr(stack, "interfaces"):                             # one pair: its own
        return stack.multiplier(r)
    pairs, at = stack.interfaces, stack.offsets
    parts = [r[at[i]:at[i + 1]] for i in range(len(pairs))]
    closed = None if active is None else [np.asarray(active[at[i]:at[i + 1]], dtype=bool) for i in range(len(pairs))]
    alone = set(alone) | ({i for i, c in enumerate(closed) if not c.any()} if closed else set())
    lam: list = [None] * len(pairs)
    for group in side_groups(stack, alone):
        read = None
        if len(group) > 1:
            read = _obstacles([pairs[i] for i in group], [parts[i] for i in group],
                              None if closed is None else [closed[i] for i in group])
            if read is None:
                read = _bodies(stack, group, [parts[i] for i in group])
        for i, values in zip(group, read or [pairs[i].multiplier(parts[i]) for i in group]):
            lam[i] = values
    return np.concatenate(lam) if lam else np.zeros(0)


def _obstacles(pairs, forces, closed=None):
    """Obstacles on one part: each pair's lambda_h read once from the forces summed (module docstring), or None
    if the group is not that (a two-body pair in it, or a pair that reads no union). ``closed`` (per pair, bool
    per node of its X_h, or None): where each pair's contact is closed; a node's share goes to the pairs closed
    there (one over their number), to all the pairs reaching it where none is."""
    if not all(p.rigid and getattr(p, "reaching", None) and getattr(p, "representer", None) is None
               and np.array_equal(p.traces[0].nodes, pairs[0].traces[0].nodes) for p in pairs):
        return None
    S = [_selection(p) for p in pairs]                               # (size_i, trace nodes)
    f = sum(s.T @ fi for s, fi in zip(S, forces))                    # the part's nodal forces
    count = sum(np.asarray(s.sum(axis=0)).ravel() for s in S)        # the pairs reaching each node
    union = pairs[0].reaching(count > 0)
    if union is None:                                                # no space of their union (2D P2: not a run)
        return None
    shares = getattr(union, "shares", None)
    on = None if closed is None else [s.T @ c.astype(float) for s, c in zip(S, closed)]   # 1: closed there
    U = _selection(union)
    full = U.T @ union.multiplier(U @ f)
    weights = shares(S, on) if shares else [1.0 / np.maximum(count, 1.0)] * len(S)
    if on is not None and shares is None:            # an obstacle open at a node carries no share of it
        n_on = sum(on)
        weights = [np.where(n_on > 0, o / np.maximum(n_on, 1.0), w) for o, w in zip(on, weights)]
    return [s @ (full * w) for s, w in zip(S, weights)]


def _selection(pair) -> sp.csr_matrix:
    """(size, trace nodes) 0/1: the trace node at each node of X_h of the obstacle pair ``pair`` (its
    interpolation, rounded: a P2 line's reads 1 - 1e-16 at a midpoint)."""
    return sp.csr_matrix((abs(pair.interpolation(0)) > 0.5).astype(float))


def _bodies(stack, group, forces):
    """Two-body pairs sharing sides: lambda_h in their X_h stacked (module docstring), or None if a pair of the
    group reads no traces' Riesz representer (an obstacle, 2D, a representer of its own) or a shared side's
    traces differ."""
    pairs = [stack.interfaces[i] for i in group]
    riesz = [getattr(p, "riesz_parts", lambda: None)() for p in pairs]
    if any(x is None for x in riesz):
        return None
    sizes = [p.size for p in pairs]
    blocks: dict = {}                      # per side: [(row block, its functions)], and its trace's nodes
    nodes: dict = {}
    for b, (i, (interp, _)) in enumerate(zip(group, riesz)):
        for side, trace, P in zip(pair_sides(stack, i), pairs[b].traces, interp):
            if not np.array_equal(nodes.setdefault(side, np.asarray(trace.nodes)), trace.nodes):
                return None
            blocks.setdefault(side, []).append((b, P))
    columns = []
    for held in blocks.values():
        rows = [sp.csr_matrix((n, held[0][1].shape[1])) for n in sizes]
        for b, P in held:
            rows[b] = sp.csr_matrix(P)
        columns.append(sp.vstack(rows, format="csr"))
    mass = sp.block_diag([m for _, m in riesz], format="csr")
    lam = TraceRiesz(columns, mass).solve(np.concatenate(forces))
    return np.split(lam, np.cumsum(sizes)[:-1])
