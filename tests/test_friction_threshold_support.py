"""The friction threshold of a 2D P2 "sigma1" pair on non-matching lines is read where its shear is
(cvxcontact.solution.friction, ``ContactResult.threshold`` and ``row_shear``; docs/howto/friction.md).

The rows of "sigma1" sit at the first body's P2 nodes, not all of them nodes of X_h; the rows' shears over their
own weights are extended to every node of X_h as the function of the rows' values (``row_shear``). The Coulomb
threshold mu p was read on the nodes the rows read only: 0 at X_h's nodes between rows, where ``row_shear`` is not
(0.12 and 0.57 of the threshold measured on the two scenes below). It is now extended as the shear is.

Independent reference: the rows' positions (E x: the rows evaluate X_h's P2 functions, which reproduce x), their
Simpson weights on the first body's 7 edges (h/6 at a vertex per edge, 2h/3 at a midpoint), the rows' forces from
the raw answer, and the first body's quadratic on each of its edges evaluated at X_h's nodes (Lagrange on start,
midpoint, end), written here.
"""

import numpy as np
import pytest
from conftest import captured
from friction_scenes import P, pair2d

import cvxcontact as cc

pytestmark = pytest.mark.numerics

CELLS = 7                         # the first body's edges on the contact line (friction_scenes.pair2d), x in [0, 1]
CASES = {"Tresca": (cc.Tresca(0.01 * P), 0.005 * P), "Coulomb": (cc.Coulomb(0.3), 0.02 * P),
         "Coulomb sliding": (cc.Coulomb(0.01), 0.005 * P)}


@pytest.fixture(scope="module")
def solved():
    """{case: (solution, problem, raw)} of the P2 "sigma1" pair of :func:`friction_scenes.pair2d`."""
    with pytest.MonkeyPatch.context() as mp:
        return {k: captured(mp, pair2d(law, q=q), degree=2) for k, (law, q) in CASES.items()}


def _on_first_body(xi, values, x):
    """The first body's P2 function with ``values`` at its trace nodes ``xi`` (vertices k h and midpoints
    (k + 1/2) h), evaluated at ``x``: Lagrange's quadratic on each edge."""
    h = 1.0 / CELLS
    at = {round(float(p) / (h / 2)): v for p, v in zip(xi, values)}          # node index in half-edges
    assert sorted(at) == list(range(2 * CELLS + 1))                          # one row at each P2 node
    k = np.minimum((x / h).astype(int), CELLS - 1)
    s = x / h - k                                                            # in [0, 1] on edge k
    a, m, b = (np.array([at[2 * j + i] for j in k]) for i in range(3))
    return a * (1 - s) * (1 - 2 * s) + m * 4 * s * (1 - s) + b * s * (2 * s - 1)


@pytest.mark.parametrize("case", list(CASES))
def test_the_threshold_is_the_rows_function_where_the_shear_is(solved, case):
    """Tresca (stuck and sliding rows), Coulomb mu = 0.3 (mostly stuck) and mu = 0.01 (sliding): ``row_shear`` and
    the Coulomb threshold are the first body's P2 functions of the rows' values at every node of X_h (the
    reference above); the threshold is positive at every node, and |shear| <= threshold at X_h's nodes where a
    row sits (the law's own nodes, to rounding) and, for ``shear`` (0 where no row reads), at every node."""
    sol, problem, raw = solved[case]
    law = CASES[case][0]
    assert sol.ok and sol.contact.degree == 2
    c, un, E = sol.contact, problem.units, problem.E
    x = np.asarray(c.x, dtype=float)
    assert abs(x.min()) < 1e-15 and abs(x.max() - 1.0) < 1e-15                   # X_h on the overlap [0, 1]
    assert np.abs(np.asarray(E.sum(axis=1)).ravel() - 1.0).max() < 1e-12         # rows evaluate X_h's functions
    h = 1.0 / CELLS
    xi = E @ x                                                                    # the rows' positions
    half = np.round(xi / (h / 2)).astype(int)
    assert np.abs(xi / (h / 2) - half).max() < 1e-9                              # at the first body's P2 nodes
    w = np.where(half % 2 == 1, 2 * h / 3, h / 6 * np.where((half == 0) | (half == 2 * CELLS), 1, 2))
    assert abs(w.sum() - 1.0) < 1e-12
    shear = _on_first_body(xi, -np.asarray(raw.tangential) * un.force / w, x)
    assert np.abs(np.asarray(c.row_shear) - shear).max() < 1e-9 * np.abs(shear).max()   # measured <= 1.4e-15
    if law.pressure_dependent:
        y = np.asarray(raw.y) * un.force
        assert y.min() > 0                                                        # every row closed
        g = _on_first_body(xi, law.coefficient * y / w, x)
        assert np.shape(c.threshold) == x.shape
        assert np.abs(np.asarray(c.threshold) - g).max() < 1e-9 * g.max()       # measured <= 2.2e-16
    else:
        assert c.threshold == law.threshold
    thr = np.broadcast_to(np.asarray(c.threshold, dtype=float), x.shape)
    assert (thr > 0).all()                                                        # was 0 between rows (Coulomb)
    on_row = np.isin(np.round(x / (h / 2)), half) & (np.abs(x / (h / 2) - np.round(x / (h / 2))) < 1e-9)
    assert on_row.sum() >= CELLS + 1                                  # the first body's vertices (and x = 0.5)
    assert (np.abs(c.row_shear) - thr)[on_row].max() <= 1e-12 * thr.max()       # measured <= 2.9e-16
    assert (np.abs(c.shear) - thr).max() <= 1e-12 * thr.max()                   # measured <= 2.9e-16
