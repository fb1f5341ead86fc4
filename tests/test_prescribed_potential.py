"""A piezoelectric body whose every potential node is prescribed (a one-cell-thick layer electroded on both faces):
no free potential unknown, so the body has no Gauss rows and the prescribed potential's lift is a load of the
momentum rows. Every route raised (sparse: TypeError ``Kup @ None`` in the checks; full: CVXPY "Invalid dimensions for
quad_form" on a 0-size variable). References: the potential is the prescribed one exactly (phi_D: 0 V on the bottom
electrode, 100 V on the top); the sparse active set on the mixed system and the full route's interior point with its
exact finish (two algorithms) agree.
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps import demo

pytestmark = pytest.mark.numerics


@pytest.fixture(scope="module")
def solutions():
    scene = demo.thin_layer(40, layer_ny=1, substrate_ny=2)
    out = {}
    for method in ("sparse", "full"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", cc.ResidualWarning)
            out[method] = cc.solve(scene, method=method)
    return scene, out


@pytest.mark.parametrize("method", ["sparse", "full"])
def test_every_potential_prescribed_is_solved_and_checked(solutions, method):
    scene, sols = solutions
    sol = sols[method]
    assert sol.ok and sol.polished
    layer = scene.bodies[0].mesh
    y = layer.points[:, 1]
    assert np.array_equal(sol.phi[0][y == y.min()], np.zeros(np.count_nonzero(y == y.min())))
    assert np.array_equal(sol.phi[0][y == y.max()], np.full(np.count_nonzero(y == y.max()), 100.0))
    assert sol.phi[1] is None


def test_the_routes_agree(solutions):
    """Measured: u 6.2e-15 (layer), 1.7e-14 (substrate) relative; bound 1e-10."""
    _, sols = solutions
    for k in range(2):
        a, b = sols["sparse"].u[k], sols["full"].u[k]
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()
