"""lambda_h in the jumps of the two traces: the Riesz representer of the row forces in X_h = T1 + T2
(docs/formulation.md §13, "Contact surfaces in 3D"; §16 for P2).

On a 3D contact surface the nodes where the condition is posed (the overlay's vertices, with P2 also the
midpoints of its edges) outnumber the dofs of the jump, so the forces r at those nodes are not unique where
rows depend on each other; what is unique is the work they do on every jump, G^T r with G = [I1 | I2] (the two
traces' functions at those nodes). lambda_h is sought in range G: G^T M G c = G^T r (singular by dim(T1 n T2)
and consistent), lambda_h = G c the same for every solution.
"""

from __future__ import annotations

from copy import copy
from typing import Protocol

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["Represented", "Representer", "TraceRiesz"]


class Representer(Protocol):
    """What reads lambda_h of a contact pair from its row forces: ``solve(r)``, lambda_h (Pa) at the nodes of X_h
    for the forces ``r`` (N) at those nodes (:class:`TraceRiesz`; a space's own pressure basis, e.g. the lumped
    pressure of hexahedral faces, :class:`~cvxcontact.fem.hexfaces.LumpedPressure`)."""

    def solve(self, r) -> np.ndarray:
        ...


class Represented:
    """The hook by which a space sets how a 3D contact pair reads lambda_h (the pairs'
    :meth:`multiplier`): ``representer`` None (the pair's own Riesz representer in X_h) or a
    :class:`Representer`; :meth:`with_representer` a copy of the pair reading lambda_h by another."""

    representer: Representer | None = None

    def with_representer(self, representer: Representer):
        """A shallow copy of this pair whose :meth:`multiplier` is ``representer.solve`` (the pair itself is
        unchanged)."""
        out = copy(self)
        out.representer = representer
        return out

_SHIFT = 1e-12    # relative diagonal shift of the singular Gram matrix (iterated)
_STEPS = 50


class TraceRiesz:
    """The solve of the module docstring for the traces' interpolations ``interp`` (each (n, n_k): trace k's
    functions at the n nodes) and the mass matrix ``mass`` (n, n) of the nodes' space, by iterated Tikhonov
    steps c += (A + s D)^-1 (G^T r - A c) (A = G^T M G, D its diagonal, s = 1e-12; one factorisation, kept), at
    most 50, stopping when the residual is below 1e-14 of G^T r or has not decreased for three steps. Only the
    trace functions that meet the overlap (a positive integral of psi^2) are kept."""

    def __init__(self, interp, mass):
        G = sp.hstack(list(interp), format="csc")
        d = np.asarray(G.multiply(mass @ G).sum(axis=0)).ravel()        # int psi^2 over the overlap
        self.G = G[:, np.flatnonzero(d > 1e-14 * d.max())].tocsr()
        self.A = (self.G.T @ mass @ self.G).tocsc()
        self.lu = spla.splu((self.A + sp.diags(_SHIFT * self.A.diagonal())).tocsc())

    def solve(self, r) -> np.ndarray:
        """lambda_h at the nodes (units of ``r`` per unit area of ``mass``)."""
        G, A, lu = self.G, self.A, self.lu
        b = G.T @ np.asarray(r, dtype=float)
        c = np.zeros(A.shape[0])
        size = max(float(np.abs(b).sum()), np.finfo(float).tiny)
        best, since = (np.inf, c), 0
        for _ in range(_STEPS):
            now = float(np.abs(b - A @ c).sum()) / size
            best, since = ((now, c), 0) if now < best[0] else (best, since + 1)
            if now <= 1e-14 or since == 3:               # converged, or stalled at the rounding of G c
                break
            c = c + lu.solve(b - A @ c)
        return G @ best[1]
