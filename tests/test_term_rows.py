"""What a contact term asks of the elements (docs/architecture.md, "A new contact law": ``asks``,
``term.own_lines``): the rows of a combination of laws, checked against the relations they must satisfy, built here
from the elements' own answers (``lines.element``), not from the terms' functions.

- a friction law under the P2 "gamma3" cones beside a nodal pair (2D, 3D): the cones sit on E's rows and the cones
  on the nodes of X_h are those cones times E (the same elements, in the same order); one law row per row of E;
- the cones beside a compliance law: the rows on the cone are exactly the Signorini "gamma3" pair's rows, its
  limit is the cone's (inf), and the cones' Bernstein map reads no node of the compliant pair;
- a term asking on lines no P2 space built: a SolverError naming what asks.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from friction_scenes import P, uniform_stack, uniform_stack3d
from stack_scenes import three_blocks

import cvxcontact as cc
from cvxcontact.discrete.problem import build_problem
from cvxcontact.discrete.terms import (
    ConesBesideCompliance,
    ConesWithFriction,
    cones_on_rows,
)
from cvxcontact.fem.space import space


def _lines(scene):
    problem = build_problem(scene, space(2, scene.cell), "gamma3", None)
    return problem.term, problem.lines


@pytest.mark.parametrize("make", [lambda: uniform_stack(0.2 * P, cc.Tresca(2 * P), ("gamma3", "sigma1"), (4, 3, 3)),
                                  lambda: uniform_stack3d(0.2 * P, cc.Tresca(2 * P), ("gamma3", "sigma1"))],
                         ids=["2d", "3d"])
def test_friction_under_the_cones_sits_on_the_rows_of_e(make):
    term, lines = _lines(make())
    assert isinstance(term, ConesWithFriction)
    E = lines.element.evaluation()
    assert (lines.E != E).nnz == 0
    assert E.shape[0] != E.shape[1] or (E - sp.identity(E.shape[0])).count_nonzero() > 0    # E is not I here
    B_rows, cells_rows = lines.cone
    B_nodes, cells_nodes = lines.node_cone
    assert B_rows.shape[1] == E.shape[0] and B_nodes.shape[1] == E.shape[1]
    assert abs(B_rows @ E - B_nodes).max() == 0.0                # exact: 0/1 selections of E's entries
    assert cells_rows.shape == cells_nodes.shape and cells_rows.max() < E.shape[0]
    assert lines.rows.size == E.shape[0] and lines.cone_on_nodes is lines.node_cone


def test_the_cones_beside_a_compliance_law_hold_the_signorini_pair_only():
    bodies, pairs, _ = three_blocks(("gamma3", "sigma1"))
    laws = (cc.Signorini(), cc.NormalCompliance(1e11))
    term, lines = _lines(cc.Scene(*bodies, contacts=[p.with_changes(law=lw) for p, lw in zip(pairs, laws)]))
    assert isinstance(term, ConesBesideCompliance)
    counts = np.asarray(lines.rows.counts)
    assert np.array_equal(lines.rows.cone, np.repeat([True, False], counts))
    assert np.isinf(lines.rows.penetration_limit[:counts[0]]).all()
    B = lines.mixed_bernstein[0]
    offsets = lines.offsets
    assert abs(B[:, offsets[1]:offsets[2]]).max() == 0.0          # no node of the compliant pair
    assert abs(B[:, offsets[0]:offsets[1]]).max() > 0.0


def test_a_term_asking_lines_without_elements_is_refused_by_name():
    bodies, pairs, _ = three_blocks(("sigma1", "sigma1"))
    lines = build_problem(cc.Scene(*bodies, contacts=pairs), space(1), "sigma1", None).lines
    assert lines.element is None
    with pytest.raises(cc.SolverError, match="under the P2 'gamma3' cones asks the space's elements"):
        cones_on_rows(lines)


def _stacked(laws, conditions):
    bodies, pairs, _ = three_blocks(conditions)
    return cc.Scene(*bodies, contacts=[p.with_changes(law=lw) for p, lw in zip(pairs, laws)])


@pytest.mark.parametrize("laws, conditions", [
    ((cc.Signorini(), cc.Signorini()), ("gamma3", "sigma1")),          # the cones beside a nodal pair (2D: 20 vs 28)
    ((cc.Signorini(), cc.Signorini()), ("sigma2", "gamma3")),
    ((cc.Signorini(), cc.NormalCompliance(1e11)), ("gamma3", "sigma1")),    # the cones beside a compliance law
    ((cc.NormalCompliance(1e11), cc.Signorini()), ("sigma1", "sigma2")),    # nodal rows
], ids=["cones-nodal", "nodal-cones", "cones-compliance", "nodal"])
def test_every_row_of_e_has_one_law_and_each_pair_its_own_rows(laws, conditions):
    """The law of every row (``rows``) is the law of E's rows, pair by pair: rows.size is E's row count, and where E
    is the identity on the nodes of X_h (the cones) each pair's count is its node count. Independent of the terms:
    the pairs' node ranges (``offsets``) and E's own shape."""
    _, lines = _lines(_stacked(laws, conditions))
    assert lines.rows.size == lines.E.shape[0], (lines.rows.size, lines.E.shape)
    if lines.E.shape[0] == lines.E.shape[1] and (lines.E - sp.identity(lines.E.shape[0])).count_nonzero() == 0:
        assert list(lines.rows.counts) == list(np.diff(lines.offsets))


@pytest.mark.parametrize("conditions", [("gamma3", "sigma1"), ("sigma1", "gamma3")])
def test_the_rows_a_term_asks_for_are_asked_once_for_all(conditions):
    """A term's lines asked again are the same lines (``own_lines`` on the problem's lines: a second application
    kept the row cones as the cones on the nodes of X_h, (B (., rows of E)) where (B (., nodes)) belongs)."""
    term, lines = _lines(uniform_stack(0.2 * P, cc.Tresca(2 * P), conditions, (4, 3, 3)))
    again = term.own_lines(lines)
    assert lines.node_cone is not None and again.node_cone[0].shape[1] == lines.E.shape[1]
    for a, b in ((lines.cone, again.cone), (lines.node_cone, again.node_cone)):
        assert (a[0] != b[0]).nnz == 0 and np.array_equal(a[1], b[1])
    assert (again.E != lines.E).nnz == 0 and list(again.rows.counts) == list(lines.rows.counts)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
def test_a_law_of_none_is_signorini_for_build_problem(degree, condition):
    """``build_problem(..., law=None)`` poses Signorini pairs, as ``cc.solve`` does (P2 "gamma3" failed with an
    untyped AttributeError in ``p2_pairs``): the lines equal those of ``cc.Signorini()`` array for array."""
    from conftest import two_blocks
    from cvxcontact.fem.space import space
    scene = two_blocks()
    a = build_problem(scene, space(degree), condition, None).lines
    b = build_problem(scene, space(degree), condition, cc.Signorini()).lines
    assert (a.E != b.E).nnz == 0 and a.E.shape == b.E.shape
    assert np.array_equal(a.gap, b.gap)
