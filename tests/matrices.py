"""Small sparse matrices with a known structure, for the factorisation tests and the SuperLU reproducer
(benchmarks/superlu_structurally_singular.py)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def surplus_saddle(n: int, m: int, shift: int = 0, surplus: bool = True) -> sp.csc_matrix:
    """The saddle matrix [[A, C^T], [C, 0]] (order n + m) of a tridiagonal positive definite A (n x n) and m
    constraint rows C on the m - 1 unknowns shift, shift + 3, ... (mod n): ``surplus`` (default) keeps all m
    rows, one more than the unknowns they touch, so that the matrix is structurally singular (structural rank
    n + m - 1: the m rows' columns of C^T meet only m - 1 rows of the lower block's pattern); ``surplus=False``
    drops the last row (order n + m - 1, non-singular: C's m - 1 rows, k = 0 .. m - 2, on its m - 1
    columns, cos(k theta_j) for distinct theta_j: a non-singular block)."""
    i = np.arange(n)
    A = sp.diags([-np.ones(n - 1), 4.0 + np.cos(i), -np.ones(n - 1)], [-1, 0, 1])
    cols = (shift + 3 * np.arange(m - 1)) % n
    vals = np.cos(np.multiply.outer(np.arange(m), 0.3 + 0.7 * np.arange(m - 1)))   # cos(k theta_j)
    C = sp.csr_matrix((vals.ravel(), (np.repeat(np.arange(m), m - 1), np.tile(cols, m))), shape=(m, n))
    if not surplus:
        C = C[:m - 1]
    return sp.bmat([[A, C.T], [C, None]], format="csc")
