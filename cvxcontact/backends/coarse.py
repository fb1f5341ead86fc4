"""The coarse start of the sparse route (:class:`~cvxcontact.backends.sparse.SparseContact`): a start set for
its active-set steps on a long interface from the answer of a coarse subset of the contact rows
(:meth:`CoarseStart.coarse_start`; taken by :func:`~cvxcontact.backends.signorini.sparse` above
:data:`~cvxcontact.backends.sparse.COARSE_ROWS` free rows, or where the other starts lead nowhere).

:class:`CoarseStart` is a base of :class:`~cvxcontact.backends.sparse.SparseContact` and reads its mixed system:
``G`` (m x n, the contact rows), ``A`` (the quasi-definite block), ``w`` (the rows' weights), ``m``, ``n``,
``factorization``, ``perm`` (SuperLU's order, set here if unset) and
:meth:`~cvxcontact.backends.sparse.SparseContact.matrix`; it sets ``_bonded_analysis`` (PARDISO's next analysis
on the bonded values, :meth:`~cvxcontact.backends.sparse.SparseContact._refactor`).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .elimination import ordering
from .finish import Declined, solve_lcp

__all__ = ["COARSE_HOPS", "NEAR_DEPENDENT", "CoarseStart"]

COARSE_HOPS = 4
"""The coarse rows are a maximal independent set of the rows' graph to this many hops (rows sharing a dof are
neighbours); the start closes every row within as many hops of a closed coarse row."""

NEAR_DEPENDENT = 1e-2
"""Two rows whose Jacobi-scaled cosine exceeds 1 - this are nearly dependent (merged nodes of two traces close
together): the start closes at most one of them (the more compliant)."""


class CoarseStart:
    """The coarse start of :class:`~cvxcontact.backends.sparse.SparseContact` (module docstring)."""

    def coarse_start(self, F, g, free=None):
        """A start set for :meth:`solve`'s steps on a long interface, from the answer of a coarse subproblem.

        The coarse rows: a maximal independent set of the free rows' graph to :data:`COARSE_HOPS` hops (no two
        within as many shared dofs of each other: about one row in ten on thin_layer). Their problem (26)-(27)
        alone (every other row left out) is solved on its dense Schur complement, the coarse rows' compliance
        W_c = G_c S^{-1} G_c^T (c x c, one partial factorisation of [[S, G_c^T], [G_c, 0]] with the coarse rows as
        its Schur block, :func:`~cvxcontact.backends.factor.factorize`, freed at once), as the LCP y >= 0,
        s = q - W_c y <= 0, y^T s = 0 with q = G_c S^{-1} F - g_c (:func:`~cvxcontact.backends.finish.solve_lcp`).
        The start: every free row within :data:`COARSE_HOPS` hops of a closed coarse row, less the stiffer row of
        each nearly dependent pair (:data:`NEAR_DEPENDENT`). Only a start: the answer is the steps' (checked as
        always). Why: from the bonded start a slender layer's contact zone moves by hundreds of rows a step, each
        step a numeric factorisation (15 on thin_layer(3000)); from this start 4. Returns None where there is no
        coarse problem to solve (every free row coarse, none free) or it cannot be solved (a perturbed pivot, a
        singular W_c, the LCP declined): the caller then starts from the bonded system. From this call on, a new
        PARDISO analysis of this object is made on the bonded values (:meth:`_refactor`).

        Parameters
        ----------
        F : (n,) ndarray, the loads [f_1; -q_1; ...] (scaled)
        g : (m,) ndarray, the rows' gaps (scaled)
        free : (m,) bool ndarray, optional, the rows that may close (default every row)

        Returns
        -------
        (m,) bool ndarray, the rows to close first, or None (above)
        """
        free = np.ones(self.m, dtype=bool) if free is None else np.asarray(free, dtype=bool)
        self._bonded_analysis = True          # the steps from the start: PARDISO analysed on the bonded values
        out = self._coarse(F, g, free)
        if out is None:
            return None
        C, idx, y = out
        start = np.zeros(self.m)
        start[idx[y > 0]] = 1.0
        for _ in range(COARSE_HOPS):                    # the rows within COARSE_HOPS hops of a closed coarse row
            start = (C @ start > 0).astype(float)
        start = free & (start > 0)
        Gs = self.G @ sp.diags(1.0 / np.sqrt(np.abs(self.A.diagonal())))
        P = (Gs @ Gs.T).tocoo()
        norm = np.sqrt(np.maximum(np.asarray(Gs.multiply(Gs).sum(axis=1)).ravel(), np.finfo(float).tiny))
        cos = P.data / (norm[P.row] * norm[P.col])
        near = np.flatnonzero((P.row < P.col) & (cos > 1.0 - NEAR_DEPENDENT))
        near = near[np.argsort(-cos[near], kind="stable")]          # the most nearly dependent pairs first
        for a, b in zip(P.row[near], P.col[near]):
            if start[a] and start[b]:
                start[a if self.w[a] < self.w[b] else b] = False
        return start if start.any() else None

    def _coarse(self, F, g, free):
        """(C, idx, y) of :meth:`coarse_start`: the rows' graph (pattern, m x m: rows sharing a dof, each its own
        neighbour), the coarse rows and their forces (the LCP's answer on W_c, > 0 on the closed ones); None as
        there."""
        from .factor import factorize as factorize_schur

        B = abs(self.G).tocsr()
        B.data[:] = 1.0
        C = (B @ B.T).tocsr()
        C.data[:] = 1.0
        keep, blocked = np.zeros(self.m, dtype=bool), ~free
        for a in range(self.m):        # greedy maximal independent set, in row order; each ball by its own search
            if not blocked[a]:         # (no power of the graph is formed: to 4 hops it holds ~100-300 rows per row)
                keep[a] = True
                ball = np.array([a])
                for _ in range(COARSE_HOPS):
                    ball = np.unique(np.concatenate([C.indices[C.indptr[b]:C.indptr[b + 1]] for b in ball]))
                blocked[ball] = True
        idx = np.flatnonzero(keep)
        if len(idx) == 0 or len(idx) == int(free.sum()):
            return None
        Gc = self.G[idx]
        M = sp.bmat([[self.A, Gc.T], [Gc, None]], format="csr")
        gamma = self.n + np.arange(len(idx))
        order = None
        if self.factorization != "pardiso":             # SuperLU: the route's ordering of S's dofs, the rows last
            if self.perm is None:
                self.perm = ordering(self.matrix(np.ones(self.m, dtype=bool)), self.n + np.arange(self.m))
            order = np.concatenate([self.perm[self.perm < self.n], gamma])
        try:
            fac = factorize_schur(M, gamma, self.factorization, order=order)
        except (SolverError, RuntimeError):
            return None
        try:
            q = -fac.forward(np.concatenate([np.asarray(F, dtype=float), np.zeros(len(idx))])).reduced \
                - np.asarray(g, dtype=float)[idx]                        # G_c S^{-1} F - g_c
            W = -fac.schur                                               # the Schur block of M is -W_c
        finally:
            fac.free()
        out = solve_lcp(W, q, np.ones(len(idx), dtype=bool))
        if isinstance(out, Declined):
            return None
        return C, idx, np.where(out[1], out[0], 0.0)
