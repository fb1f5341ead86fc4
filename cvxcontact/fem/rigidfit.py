"""The rigid motions of a body on its free unknowns, and a displacement with its rigid part taken out.

A body's free unknowns z_u (u = Tu z_u + u_fixed, Tu with orthonormal columns, docs/formulation.md §11) move
rigidly along Tu^T r, r a rigid motion of one of its mesh components (pieces): r = t + w x (x - c) (3D),
(t_x - w y, t_y + w x) (2D). :class:`RigidFit` keeps, per piece, an orthonormal basis Q of those motions on the
piece's free unknowns, and :meth:`RigidFit.deformation` answers d = z_u - Q Q^T z_u on each piece: the least-squares
rigid fit taken out. The fit is a linear projection that reproduces rigid motions (Q Q^T r = r on the span), so

    deformation(z_u + Tu^T r) = deformation(z_u)     (to rounding, eps |r|)

for every rigid motion r of a piece: a body that slid or turned further has the same deformation, whether the
slide is free or prescribed (a pushed face). The fit is taken on the free unknowns whatever the supports hold: on a
clamped body it takes out the free nodes' best rigid fit too (a motion the supports forbid is dropped only where it
moves no free unknown, :data:`RANK`), so ``deformation`` is a size of the strain, never larger than z_u itself, not a
decomposition into the body's admissible motions. Used for the force scales of the checks
(:func:`~cvxcontact.backends.finish.forces.friction_scale`, ``reach_forces``), which must not grow with how far a
body slid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics.supports import rigid_field

__all__ = ["RANK", "RigidFit", "rigid_fit"]

RANK = 1e-10
"""A rigid motion whose part on the free unknowns is below this fraction of the piece's largest (singular values of
the unit motions restricted there) moves no free unknown (the supports hold it at every node): it is not fitted."""


@dataclass(frozen=True)
class RigidFit:
    """Per piece of a body (``pieces``: (free unknowns of the piece (k,), orthonormal basis Q (k, m) of its rigid
    motions there)), the projection onto the rigid motions (module docstring); ``size`` the body's free unknowns."""

    pieces: tuple
    size: int

    def deformation(self, z: np.ndarray) -> np.ndarray:
        """z - Q Q^T z on every piece: the free unknowns ``z`` (any unit: m or scaled) with their least-squares
        rigid fit taken out (the same unit), invariant under a rigid motion of each piece."""
        d = np.array(z, dtype=float, copy=True)
        for idx, Q in self.pieces:
            d[idx] -= Q @ (Q.T @ d[idx])
        return d


def rigid_fit(points, components, Tu) -> RigidFit:
    """The :class:`RigidFit` of a body whose nodes (its node set: the mesh's vertices, or e.g. P2's nodes) are at
    ``points`` (n, dim) m, in mesh components ``components`` (n,), with the prolongation ``Tu`` (dim n, m_u) of its
    free unknowns (node-major components; orthonormal columns). Each piece's unit motions (translations of 1,
    rotations about its centroid moving its extent by 1) are restricted to its free unknowns and orthonormalised
    by a thin SVD (directions below :data:`RANK`, held by the supports, dropped): one pass over the nodes per
    piece, O(n m^2)."""
    x = np.asarray(points, dtype=float)
    dim = x.shape[1]
    components = np.asarray(components)
    m = dim * (dim + 1) // 2                               # the rigid motions: translations and rotations
    T = Tu.tocsc()
    counts = np.diff(T.indptr)
    owner = np.repeat(components, dim)[T.indices[T.indptr[:-1][counts > 0]]]      # a free unknown's piece
    free = np.flatnonzero(counts > 0)
    pieces = []
    for c in np.unique(components):
        idx = free[owner == c]
        nodes = np.flatnonzero(components == c)
        if len(idx) == 0:
            continue
        xc = x[nodes] - x[nodes].mean(axis=0)
        xc = xc / max(float(np.ptp(xc, axis=0).max()), np.finfo(float).tiny)
        dofs = (dim * nodes[:, None] + np.arange(dim)).ravel()
        B = np.column_stack([rigid_field(v, xc).ravel() for v in np.eye(m)])        # (dim k, m) on the piece
        R = np.asarray(T[dofs][:, idx].T @ B)
        Q, s, _ = np.linalg.svd(R, full_matrices=False)
        keep = s > RANK * s.max(initial=0.0)
        if keep.any():
            pieces.append((idx, Q[:, keep]))
    return RigidFit(tuple(pieces), T.shape[1])
