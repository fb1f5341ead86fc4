"""A body's factorisation after its adapter's factors were freed (where memory is short).

:class:`Released` is a factorisation (:class:`~cvxcontact.backends.factor.Factorization`) whose adapter's factors
were freed (:meth:`~cvxcontact.backends.factor.Factorization.free`; the decision is
:mod:`cvxcontact.backends.budget`'s): Sigma, its Cholesky factors and one forward sweep are kept, and every later
sweep re-makes S_II's plain factorisation (:func:`interior_solve`: PARDISO without the Schur option, else SuperLU),
freed at once.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .factor import (
    SUPERLU_OPTIONS,
    Factorization,
    Forward,
    PardisoInterior,
    diagonal_stored,
    pardiso_available,
)

__all__ = ["Released", "interior_solve"]


def interior_solve(U, b, kind: str, order: np.ndarray | None = None) -> np.ndarray:
    """S_II^{-1} b by a fresh factorisation freed before returning (:class:`Released`), ``U`` S_II's upper
    triangle (CSR, every diagonal entry stored): PARDISO (:class:`PardisoInterior`) for ``kind`` "pardiso" where
    it loads and does not perturb a pivot; else SuperLU, on ``order`` (a fill-reducing permutation of S_II's
    rows, the body's own SuperLU order: the leading block of its first factorisation, no more fill) with
    :data:`SUPERLU_OPTIONS` where given, with partial pivoting on SciPy's default order where not (S_II
    quasi-definite: each is an exact triangular solve, to rounding)."""
    if kind == "pardiso" and pardiso_available():
        try:
            factor = PardisoInterior(U)
        except SolverError:
            factor = None
        if factor is not None:
            try:
                return factor.solve(b)
            finally:
                factor.release()
    S_II = (U + U.T - sp.diags(U.diagonal())).tocsc()
    b = np.asarray(b, dtype=float)
    if order is None:
        return spla.splu(S_II).solve(b)
    x = np.empty_like(b)
    x[order] = spla.splu(S_II[order][:, order].tocsc(), **SUPERLU_OPTIONS).solve(b[order])
    return x


class Released(Factorization):
    """A body's factorisation after its adapter's factors were freed (:meth:`Factorization.free`): Sigma, its
    Cholesky factors and the forward sweep of one right-hand side ``rhs`` are kept (taken before the factors
    were freed), with S's interior blocks S_II and S_IG. A forward sweep of another right-hand side and every
    backward sweep re-make S_II's factorisation (:func:`interior_solve`, freed at once; ``remade`` counts them):

        r = b_G - S_IG^T S_II^{-1} b_I,      x_I = S_II^{-1} (b_I - S_IG v),  x_G = v.

    The answers are those of the kept factorisation to rounding (another factorisation of the same S_II). A
    SuperLU body's re-made factorisation keeps its elimination order (``order``: the interior dofs' part of
    ``factor.perm``, as positions in S_II), so its factors are the leading block of the first one's."""

    def __init__(self, factor: Factorization, S, rhs):
        fwd = factor.forward(rhs)
        self.n, self.gamma, self.name = factor.n, factor.gamma, factor.name
        self.schur, self._chol, self._lu = factor.schur, factor._chol, factor._lu
        self._rhs, self._reduced = np.array(rhs, dtype=float), fwd.reduced
        del fwd
        factor.free()
        interior = np.ones(self.n, dtype=bool)
        interior[self.gamma] = False
        self.interior = np.flatnonzero(interior)
        S = sp.csr_matrix(S)[self.interior]
        self._S_IG = S[:, self.gamma].tocsr()
        self._S_II = diagonal_stored(sp.triu(S[:, self.interior], format="coo"), sp.csr_matrix)   # upper only
        perm = getattr(factor, "perm", None)            # SuperLU's order: the interior dofs first, Gamma last
        self.order = None
        if perm is not None:
            position = np.empty(self.n, dtype=np.int64)
            position[self.interior] = np.arange(len(self.interior))
            self.order = position[np.asarray(perm)[:len(self.interior)]]
        self.remade = 0

    def _interior(self, b):
        self.remade += 1
        return interior_solve(self._S_II, b, self.name, self.order)

    def forward(self, rhs):
        rhs = np.asarray(rhs, dtype=float)
        if rhs.shape == self._rhs.shape and np.array_equal(rhs, self._rhs):
            return Forward(self._reduced.copy(), rhs)
        xi = self._interior(rhs[self.interior])
        return Forward(rhs[self.gamma] - self._S_IG.T @ xi, rhs)

    def backward(self, fwd, v):
        b = fwd.state
        x = np.zeros_like(b)
        x[self.gamma] = v
        x[self.interior] = self._interior(b[self.interior] - self._S_IG @ np.asarray(v, dtype=float))
        return x
