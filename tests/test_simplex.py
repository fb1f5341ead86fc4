"""Simplex quadrature (fem/simplex.py): exact on every monomial of the barycentric coordinates up to its
degree, against the closed form int_T L^a = |T| dim! prod(a_i!) / (|a| + dim)!; positive weights, points
inside."""

import itertools
import math

import numpy as np
import pytest

from cvxcontact.fem.simplex import simplex_rule


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_rule_is_exact_to_its_degree(dim, degree):
    L, w = simplex_rule(dim, degree)
    assert (w > 0).all() and (L > 0).all() and np.allclose(L.sum(axis=1), 1.0) and abs(w.sum() - 1) <= 1e-15
    worst = 0.0
    for a in itertools.product(range(degree + 1), repeat=dim + 1):
        if sum(a) > degree:
            continue
        exact = math.factorial(dim) * math.prod(math.factorial(k) for k in a) / math.factorial(sum(a) + dim)
        worst = max(worst, abs(w @ np.prod(L ** np.array(a), axis=1) - exact) / exact)
    assert worst <= 1e-14                                    # measured <= 1.1e-15


def test_rule_is_not_exact_beyond_its_degree():
    """The degree-2 tetrahedron rule (8 points, exact to 3) misses a degree-4 monomial: the test above can fail."""
    L, w = simplex_rule(3, 2)
    exact = math.factorial(3) * math.factorial(4) / math.factorial(4 + 3)
    assert abs(w @ L[:, 0] ** 4 - exact) / exact > 1e-3                      # measured 0.042
