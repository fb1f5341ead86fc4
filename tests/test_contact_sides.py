"""Which pairs hold which side (cvxcontact/contact/sides.py): the sides (scene body index, part) read off the scenes'
stacks against the pairs as the scenes pose them, and the groups of pairs connected by shared sides."""

from types import SimpleNamespace

from reach_scenes import block2d, box_on_boxes, line

from cvxcontact.contact.sides import held_sides, pair_sides, side_groups


def test_box_on_two_boxes_holds_the_upper_bottom_twice():
    """The upper box (body 0) on lower boxes 1 and 2: its bottom held by both pairs (each one's first side), each
    lower box's top by its own pair (second side); one group."""
    stack = box_on_boxes().stack
    assert pair_sides(stack, 0) == [(0, "bottom"), (1, "top")]
    assert pair_sides(stack, 1) == [(0, "bottom"), (2, "top")]
    assert held_sides(stack) == {(0, "bottom"): [(0, 0), (1, 0)], (1, "top"): [(0, 1)], (2, "top"): [(1, 1)]}
    assert side_groups(stack) == [[0, 1]]
    assert side_groups(stack, alone={0}) == [[0], [1]]


def test_obstacles_on_one_part_and_a_subset():
    """Three lines under the block's bottom: one side (body 0, "bottom"), three pairs; ``pairs`` reads the ones
    given, in their order."""
    stack = block2d((line(-1.0, 0.7), line(0.3, 2.0), line(-1.0, 2.0))).stack
    assert pair_sides(stack, 2) == [(0, "bottom")]
    assert held_sides(stack) == {(0, "bottom"): [(0, 0), (1, 0), (2, 0)]}
    assert held_sides(stack, [2, 0]) == {(0, "bottom"): [(2, 0), (0, 0)]}
    assert side_groups(stack) == [[0, 1, 2]]
    assert side_groups(stack, alone=[1]) == [[0, 2], [1]]


def _stack(members, parts):
    """A stack as the functions read it: each pair's body indices and its traces' parts."""
    interfaces = [SimpleNamespace(traces=[SimpleNamespace(part=p) for p in ps]) for ps in parts]
    return SimpleNamespace(members=members, interfaces=interfaces)


def test_groups_are_connected_through_shared_sides():
    """Pairs 0 (body 0 "a" on body 1 "b") and 2 (body 2 "c" on body 1 "b") share body 1's "b"; pair 3 (body 2 "c"
    on an obstacle) shares body 2's "c" with pair 2; pair 1 (body 3 "d" on body 4 "e") shares nothing: groups
    [0, 2, 3] and [1], in the order of their first pairs."""
    stack = _stack([(0, 1), (3, 4), (2, 1), (2, None)], [("a", "b"), ("d", "e"), ("c", "b"), ("c",)])
    assert side_groups(stack) == [[0, 2, 3], [1]]
    assert side_groups(stack, alone={2}) == [[0], [1], [2], [3]]
    assert held_sides(stack)[(1, "b")] == [(0, 1), (2, 1)]
    assert held_sides(stack)[(2, "c")] == [(2, 0), (3, 0)]
