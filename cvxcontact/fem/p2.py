"""Vectorised P2 (6-node triangle) assembly of the electro-elastic operators of one body (SI units).

The same weak forms (19)-(20) as :mod:`cvxcontact.fem.assembly` (see there for the blocks and the
electrode lifting), on the P2 nodes of :class:`cvxcontact.geometry.quadratic.P2Nodes` (vertices
first, then edge midpoints). The basis on a straight triangle with barycentrics L0, L1, L2 is

    N_i = L_i (2 L_i - 1)  (vertices),   N_3 = 4 L0 L1,  N_4 = 4 L1 L2,  N_5 = 4 L2 L0  (midpoints).

Quadrature: the gradients are linear, so the stiffness integrands are quadratic and the 3-point
rule (degree 2) is exact; volume loads use a 6-point rule of degree 4 (exact for a quadratic load
density times a P2 basis function) and surface loads the 3-point Gauss rule on edges (degree 5).
"""

from __future__ import annotations

import numpy as np

from ..geometry.quadratic import P2Nodes
from .assembly import BodySystem, accumulate, scatter, constrained, gradients, lifted

__all__ = ["assemble_matrices", "assemble_loads", "assemble", "shape_functions", "shape_gradients"]

# degree-2 rule on the reference triangle (barycentric coordinates, weights summing to 1)
_TRI3 = (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3))
# degree-4 rule (Strang-Fix / Dunavant 6 points), weights summing to 1
_a, _b = 0.445948490915965, 0.091576213509771
_TRI6 = (np.array([[1 - 2 * _a, _a, _a], [_a, 1 - 2 * _a, _a], [_a, _a, 1 - 2 * _a],
                   [1 - 2 * _b, _b, _b], [_b, 1 - 2 * _b, _b], [_b, _b, 1 - 2 * _b]]),
         np.array([0.223381589678011] * 3 + [0.109951743655322] * 3))
_GAUSS3 = (0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5 / 18, 8 / 18, 5 / 18]))


def shape_functions(L) -> np.ndarray:
    """The six P2 basis functions at barycentric coordinates ``L`` (..., 3) -> (..., 6)."""
    L0, L1, L2 = L[..., 0], L[..., 1], L[..., 2]
    return np.stack([L0 * (2 * L0 - 1), L1 * (2 * L1 - 1), L2 * (2 * L2 - 1), 4 * L0 * L1, 4 * L1 * L2, 4 * L2 * L0],
                    axis=-1)


def shape_gradients(gradL, L) -> np.ndarray:
    """Gradients (m, 2, 6) of the P2 basis (1/m) at barycentrics ``L`` (3,), with ``gradL`` (m, 2, 3) the
    gradients of the barycentric coordinates."""
    g0, g1, g2 = gradL[:, :, 0], gradL[:, :, 1], gradL[:, :, 2]
    L0, L1, L2 = L
    return np.stack([(4 * L0 - 1) * g0, (4 * L1 - 1) * g1, (4 * L2 - 1) * g2,
                     4 * (L1 * g0 + L0 * g1), 4 * (L2 * g1 + L1 * g2), 4 * (L0 * g2 + L2 * g0)], axis=2)


def strain_p2(G):
    """(m, 3, 12) map from element dofs (u0x, u0y, u1x, ...) to (eps11, eps33, 2 eps13)."""
    B = np.zeros((G.shape[0], 3, 12))
    B[:, 0, 0::2] = G[:, 0]
    B[:, 1, 1::2] = G[:, 1]
    B[:, 2, 0::2] = G[:, 1]
    B[:, 2, 1::2] = G[:, 0]
    return B


def assemble(body, nodes: P2Nodes | None = None) -> BodySystem:
    """Assemble the P2 matrices and loads of ``body`` (SI units, all dofs of the P2 nodes)."""
    nodes = P2Nodes(body.mesh) if nodes is None else nodes
    return assemble_loads(body, assemble_matrices(body, nodes), nodes)


def assemble_matrices(body, nodes: P2Nodes) -> BodySystem:
    """P2 stiffness, coupling and permittivity matrices and the prolongations of ``body``; loads zero.

    The supports and electrodes enter as with P1 (u = T_u z + u_D, phi = T_p z + phi_D,
    :func:`cvxcontact.fem.assembly.prolongation`) on the P2 nodes: a roller or a prescribed displacement
    holds at the vertices and at the midpoints of its part's edges, a floating electrode's potential is
    one unknown on all of them."""
    mat = body.material
    n = len(nodes)
    el = nodes.triangles
    area, gradL = gradients(body.mesh.points, body.mesh.triangles)
    udofs = (2 * el[:, :, None] + np.arange(2)).reshape(-1, 12)
    Kuu = Kup = Kpp = 0.0
    for L, w in zip(*_TRI3):
        G = shape_gradients(gradL, L)                                    # (m, 2, 6)
        B = strain_p2(G)
        Bt = np.swapaxes(B, 1, 2) * (w * area)[:, None, None]
        Kuu = Kuu + (Bt @ mat.c) @ B
        if mat.piezoelectric:
            Kup = Kup + (Bt @ mat.e.T) @ G
            Kpp = Kpp + ((np.swapaxes(G, 1, 2) * (w * area)[:, None, None]) @ mat.kappa) @ G
    if not mat.piezoelectric:
        return constrained(body, scatter(Kuu, udofs, udofs, (2 * n, 2 * n)), nodes=nodes)
    return constrained(body, scatter(Kuu, udofs, udofs, (2 * n, 2 * n)), scatter(Kup, udofs, el, (2 * n, n)),
                       scatter(Kpp, el, el, (n, n)), nodes=nodes)


def assemble_loads(body, matrices: BodySystem, nodes: P2Nodes) -> BodySystem:
    """A BodySystem sharing the matrices of ``matrices`` with the P2 consistent loads of ``body``."""
    f = _body_load(nodes, body.body_force, 2)
    for tag, load in body.traction.items():
        f += _edge_load(nodes, nodes.boundary(tag), load, 2)
    q = None
    if matrices.piezoelectric:
        q = _body_load(nodes, body.volume_charge, 1)[:, 0]
        for tag, load in body.surface_charge.items():
            q -= _edge_load(nodes, nodes.boundary(tag), load, 1)[:, 0]
    return lifted(body, matrices, f.ravel(), q, nodes)


def _body_load(nodes, load, ncomp):
    """(n, ncomp) consistent P2 nodal load of a volume density (degree-4 rule)."""
    n = len(nodes)
    if not load.nonzero:
        return np.zeros((n, ncomp))
    mesh = nodes.mesh
    p = mesh.points[mesh.triangles]                                   # (m, 3, 2)
    out = np.zeros((n, ncomp))
    for L, w in zip(*_TRI6):
        x = np.einsum("k,mkd->md", L, p)
        val = np.asarray(load(x[:, 0], x[:, 1]), dtype=float).reshape(len(p), ncomp) * (w * mesh.areas)[:, None]
        N = shape_functions(L)                                        # (6,)
        out += accumulate(nodes.triangles.T.ravel(), np.concatenate([Ni * val for Ni in N]), n)
    return out


def _edge_load(nodes, edges, load, ncomp):
    """(n, ncomp) consistent P2 nodal load of a surface density on ``edges`` (start, end, mid)."""
    pts = nodes.points
    a, b = pts[edges[:, 0]], pts[edges[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    out = np.zeros((len(pts), ncomp))
    for t, w in zip(*_GAUSS3):
        x = (1 - t) * a + t * b
        val = np.asarray(load(x[:, 0], x[:, 1]), dtype=float).reshape(len(edges), ncomp) * (w * length)[:, None]
        N = ((1 - t) * (1 - 2 * t), t * (2 * t - 1), 4 * t * (1 - t))
        out += accumulate(edges.T.ravel(), np.concatenate([Ni * val for Ni in N]), len(pts))
    return out
