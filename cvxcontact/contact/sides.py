"""Which contact pairs hold which side. A side is (scene body index, contact part): one body's part that a pair's
trace lies on. Several pairs hold one side where obstacles each reach part of a body's part (docs/accuracy.md,
"Several pairs on one part"), or where a body lies on several bodies; a two-body pair holds two sides, its first
body's and its second's, an obstacle pair one.

The one place that groups pairs by side, read by the given friction thresholds that overlap on a part
(:mod:`cvxcontact.discrete.overlap`), lambda_h read once per side (:mod:`cvxcontact.solution.sides`) and the
estimate's terms summed on each side (:mod:`cvxcontact.solution.contactestimate`). From a stack alone
(``interfaces``: each pair's ``traces``, each with its ``part``; ``members``: each pair's body indices among the
scene's, the second None for an obstacle): P1 and P2 lines and surfaces, :class:`~cvxcontact.contact.interface.Stack`
and :class:`~cvxcontact.contact.quadratic.QuadraticStack` alike.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["held_sides", "pair_sides", "side_groups"]


def pair_sides(stack, i: int) -> list[tuple[int, str]]:
    """The sides (scene body index, part) pair ``i`` of ``stack`` holds, in the order of its traces: its first
    body's, then (a two-body pair) its second body's."""
    return [(k, trace.part) for k, trace in zip(stack.members[i], stack.interfaces[i].traces)]


def held_sides(stack, pairs: Iterable[int] | None = None) -> dict[tuple[int, str], list[tuple[int, int]]]:
    """{side: [(pair index, slot)]}: the pairs of ``stack`` that hold each side (slot 0: the pair's first body, 1:
    its second), in the order read, the sides in the order the pairs first reach them. ``pairs``: the indices of
    the pairs read, in their order (None: every pair, in pair order)."""
    held: dict = {}
    for i in range(len(stack.interfaces)) if pairs is None else pairs:
        for slot, side in enumerate(pair_sides(stack, i)):
            held.setdefault(side, []).append((i, slot))
    return held


def side_groups(stack, alone: Iterable[int] = ()) -> list[list[int]]:
    """The pairs of ``stack`` grouped by the sides they share, connected: a pair joins every group one of whose
    pairs holds one of its sides (a body on two bodies that each lie on a third: one group); the pairs ``alone``
    each a group of its own. Each group in pair order, the groups in the order of their first pairs."""
    alone = set(alone)
    owner: dict = {}
    parent = list(range(len(stack.interfaces)))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for i in range(len(parent)):
        for side in [] if i in alone else pair_sides(stack, i):
            j = owner.setdefault(side, i)
            parent[root(i)] = root(j)
    groups: dict = {}
    for i in range(len(parent)):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())
