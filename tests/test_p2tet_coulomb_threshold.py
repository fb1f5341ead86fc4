"""The Coulomb threshold a 3D P2 (10-node tetrahedra) pair reports under "sigma1"/"sigma2" (ContactResult.threshold).

The solver holds each row's tangential force within its capacity mu y_a (y_a the row's normal force); the shear is
read as each row's force over its own weight w_a (the red refinement's). The threshold is read the same way,
mu y_a / w_a, so that |shear| <= threshold at every row with equality where it slides. (Read as mu times the
pressure, the Riesz representer of the rows' forces, its P2 function was negative at a row and a sliding
row's shear exceeded it 124 times.)
Reference built here: the rows' normal forces from the pressure and the rows' P2 mass (M p = y).
"""

import warnings

import numpy as np
import pytest
from friction_scenes import dragged_blocks3d

import cvxcontact as cc

MU = 0.3


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_the_shear_is_at_most_the_coulomb_threshold_at_the_rows(condition):
    """Non-matching blocks (nu = 0.3), the upper one's top dragged along x and y and pressed: every row slides. At
    the rows |shear| <= threshold (measured 2.9e-16 of the largest threshold over it at most; bound 1e-12), the
    threshold is non-negative, and it is mu times the rows' normal forces over their weights where those are
    (measured 5.8e-16 of the largest; bound 1e-12)."""
    scene = dragged_blocks3d(cc.Coulomb(MU), press=1e-4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, condition, degree=2)
    c, itf = sol.contact, sol.interface
    E = itf.evaluation(condition)
    shear = np.linalg.norm(np.column_stack([E @ c.shear[:, j] for j in range(2)]), axis=1)
    threshold = E @ np.asarray(c.threshold)
    top = threshold.max()
    assert sol.ok and top > 0 and threshold.min() >= 0
    assert (shear - threshold).max() <= 1e-12 * top
    y = itf.row_mass(condition) @ (E @ c.pressure)             # the rows' normal forces, M p = y
    assert np.abs(threshold - MU * y / itf.weights(condition)).max() <= 1e-12 * top
