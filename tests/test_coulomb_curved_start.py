"""Coulomb's start against a curved obstacle (backends/friction.py, ``_stuck``): the stuck start holds the slip of
the rows that can stick at 0, but not a row whose slip a support prescribes. Against a disk the tangent at a
corner of the contact face is tilted, so the corner's unknown normal displacement moves its slip too; holding it
at 0 would cancel the support's slip by driving the corner into the disk (by 1e-4 m / sin(theta), 20 m on a
disk of radius 1e5 m): the start was infeasible (SolverError) for a block dragged along a disk by its side.
"""

import warnings

import numpy as np
import pytest
from friction_scenes import P, steel

import cvxcontact as cc

FLAT = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def _dragged(obstacle, mu=0.2):
    """The nu = 0 block (1 m x 0.5 m) pressed by p on its top, its left face moved by u_x = 1e-4 m (its bottom
    corner a contact node), on ``obstacle`` with Coulomb(mu)."""
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=8, ny=4)
    b = cc.Body(m, steel(nu=0.0), contact="bottom", traction={"top": (0.0, -P)}, displacement={"left": (1e-4, None)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", obstacle, law=cc.Coulomb(mu))])


@pytest.mark.numerics
@pytest.mark.parametrize("keywords", [{"condition": "gamma3"}, {"condition": "sigma1", "degree": 2}],
                         ids=["p1", "p2-sigma1"])
def test_a_block_dragged_along_a_flat_disk_slides_as_on_the_floor(keywords):
    """On disks of radius 1e5 m and 1e6 m (their gap departs from the floor's by x^2 / 2R <= 1.25e-6, 1.25e-7 m)
    the dragged block slides at every node with the friction force mu N, finished, and its answer tends to the
    floor's as 1/R (measured 1.250e-2 and 1.251e-3 of the displacements, the gap's departure over them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        floor = cc.solve(_dragged(FLAT), **keywords)
        U = np.abs(floor.u[0]).max()
        departures = []
        for radius in (1e5, 1e6):
            sol = cc.solve(_dragged(cc.Rigid.circle(center=(0.0, -radius), radius=radius)), **keywords)
            assert sol.ok and sol.polished, sol.info.declined
            c = sol.contact
            assert (np.abs(c.slip) > 1e-3 * U).all()                                 # every node slides
            assert abs(np.abs(c.shear_force).sum() / (0.2 * c.force.sum()) - 1) <= 1e-10   # measured 2.2e-16
            departures.append(np.abs(sol.u[0] - floor.u[0]).max() / U)
    assert abs(departures[0] / 1.25e-2 - 1) <= 0.05 and abs(departures[0] / departures[1] - 10) <= 0.1
