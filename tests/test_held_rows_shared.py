"""A load case of the same contact rows and no force-controlled obstacle shares the held rows of the last one
(cvxcontact/discrete/problem.py _derive): they equal freshly formed ones, and are formed afresh where an obstacle is
under force control."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.discrete.problem import held_rows

pytestmark = pytest.mark.numerics

ALU = cc.materials.isotropic(E=70e9, nu=0.3, name="aluminium")


def _corner_scene(scale=1.0):
    """Two blocks both clamped at their left side, in contact along y = 0: the contact node at x = 0 is held on
    both sides (a held row); the upper block loaded by a body force (x ``scale``)."""
    upper = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=8, ny=4), ALU, clamped=["left"], contact="bottom",
                    body_force=(0.0, -2e9 * scale), name="upper")
    lower = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=6, ny=3), ALU, clamped=["left", "bottom"],
                    contact="top", name="lower")
    return cc.Scene(upper, lower)


def test_a_load_case_shares_the_held_rows_and_they_are_the_fresh_ones():
    """A load case of the same contact rows shares the held rows of the one before (the same read-only array) and
    they are held_rows formed afresh on its rows and blocks; a load case under a force-controlled obstacle forms
    its own (its translations move rows), also the fresh ones."""
    from obstacle_scenes import circle

    problem = cc.ContactSolver(_corner_scene()).problem
    assert problem.held_rows.any() and not problem.held_rows.all()
    again = problem.with_loads(_corner_scene(0.37))
    assert again.held_rows is problem.held_rows and not again.held_rows.flags.writeable
    assert np.array_equal(again.held_rows, held_rows(again.E, again.blocks, again.translations))
    scene = circle()
    forced = cc.ContactSolver(scene, degree=2).problem
    loaded = forced.with_loads(scene.with_loads(0, body_force=(0.0, -1e8)))
    assert loaded.translations and loaded.held_rows is not forced.held_rows
    assert np.array_equal(loaded.held_rows, held_rows(loaded.E, loaded.blocks, loaded.translations))
