"""Vectorised P2 (6-node triangle, 10-node tetrahedron) assembly of the electro-elastic operators of one
body (SI units).

The same weak forms (19)-(20) as :mod:`cvxcontact.fem.assembly` (see there for the blocks and the
electrode lifting), on the P2 nodes of :class:`cvxcontact.geometry.quadratic.P2Nodes` (vertices
first, then edge midpoints). The basis on a straight triangle with barycentrics L0, L1, L2 is

    N_i = L_i (2 L_i - 1)  (vertices),   N_3 = 4 L0 L1,  N_4 = 4 L1 L2,  N_5 = 4 L2 L0  (midpoints).

Quadrature: the gradients are linear, so the stiffness integrands are quadratic and the 3-point
rule (degree 2) is exact; volume loads use a 6-point rule of degree 4 (exact for a quadratic load
density times a P2 basis function) and surface loads the 3-point Gauss rule on edges (degree 5).

Tetrahedra: the same basis with four barycentrics, N_i = L_i (2 L_i - 1) at the vertices and 4 L_a L_b
at the midpoints of the edges ``EDGES[3]`` (the tetra10 order of
:class:`~cvxcontact.geometry.quadratic.P2TetNodes`: (0,1), (1,2), (0,2), (0,3), (1,3), (2,3)); faces as
(v0, v1, v2, m01, m12, m20). Stiffness by a degree-2 rule, volume and
face loads by degree-4 rules (:func:`cvxcontact.fem.simplex.simplex_rule`).
"""

from __future__ import annotations

import numpy as np

from ..contact.quadratic3d import P2_FACE_RULE
from ..geometry.quadratic import P2Nodes
from ..geometry.tetmesh import EDGES as TET_EDGES
from .assembly import (BodySystem, accumulate, assemble_points, face_load, gradients, lifted, strain_at,
                       strain_matrix)
from .simplex import element_load, simplex_rule

__all__ = ["assemble_matrices", "assemble_loads", "assemble", "shape_functions", "shape_gradients", "EDGES"]

EDGES = {2: ((0, 1), (1, 2), (2, 0)), 3: tuple(tuple(int(v) for v in e) for e in TET_EDGES)}
"""The local edges (a, b) of the midpoint nodes, in element order, per dimension."""

# degree-2 rule on the reference triangle (barycentric coordinates, weights summing to 1)
_TRI3 = (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3))
_TRI6 = P2_FACE_RULE                       # degree-4 rule (Strang-Fix / Dunavant 6 points), weights summing to 1
_GAUSS3 = (0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5 / 18, 8 / 18, 5 / 18]))
_STIFFNESS_RULE = {2: _TRI3, 3: simplex_rule(3, 2)}        # degree 2: exact for products of linear gradients


def shape_functions(L) -> np.ndarray:
    """The P2 basis functions at barycentric coordinates ``L`` (..., k): (..., 6) on a triangle (k = 3),
    (..., 10) on a tetrahedron (k = 4): L_i (2 L_i - 1), then 4 L_a L_b on the ``EDGES``."""
    L = np.asarray(L)
    edges = EDGES[L.shape[-1] - 1]
    return np.stack([L[..., i] * (2 * L[..., i] - 1) for i in range(L.shape[-1])]
                    + [4 * L[..., a] * L[..., b] for a, b in edges], axis=-1)


def shape_gradients(gradL, L) -> np.ndarray:
    """Gradients (m, dim, k) of the P2 basis (1/m) at barycentrics ``L`` (dim + 1,), with ``gradL``
    (m, dim, dim + 1) the gradients of the barycentric coordinates."""
    g = [gradL[:, :, i] for i in range(gradL.shape[2])]
    return np.stack([(4 * L[i] - 1) * g[i] for i in range(len(g))]
                    + [4 * (L[b] * g[a] + L[a] * g[b]) for a, b in EDGES[len(g) - 1]], axis=2)


strain_p2 = strain_matrix
"""The strain map of the P2 gradients (:func:`cvxcontact.fem.assembly.strain_matrix`)."""


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
    return assemble_points(body, nodes.cells, len(nodes), stiffness_points(body), nodes)


def stiffness_points(body) -> list[tuple[np.ndarray, np.ndarray]]:
    """[(G (m, dim, k), w (m,))]: the P2 shape gradients and weights at the points of the stiffness rule
    (degree 2) of every element (:func:`~cvxcontact.fem.assembly.assemble_points`)."""
    area, gradL = gradients(body.mesh.points, body.mesh.cells)
    return [(shape_gradients(gradL, L), w * area) for L, w in zip(*_STIFFNESS_RULE[body.dim])]


def strain_points(body, nodes: P2Nodes):
    """P2: the strain map and weights (:func:`cvxcontact.fem.assembly.points_strain`) at the points of the
    stiffness rule (degree 2) of every element, point by point."""
    return strain_at(stiffness_points(body), nodes.cells, body.dim, len(nodes))


def assemble_loads(body, matrices: BodySystem, nodes: P2Nodes) -> BodySystem:
    """A BodySystem sharing the matrices of ``matrices`` with the P2 consistent loads of ``body``."""
    if body.dim == 3:
        return _tet_loads(body, matrices, nodes)
    f = _body_load(nodes, body.body_force, 2)
    for tag, load in body.traction.items():
        f += edge_load_p2(nodes, nodes.boundary(tag), load, 2)
    q = None
    if matrices.piezoelectric:
        q = _body_load(nodes, body.volume_charge, 1)[:, 0]
        for tag, load in body.surface_charge.items():
            q -= edge_load_p2(nodes, nodes.boundary(tag), load, 1)[:, 0]
    return lifted(body, matrices, f.ravel(), q, nodes)


def _tet_loads(body, matrices, nodes):
    """The P2 consistent loads of a 10-node tetrahedral body (degree-4 rules: exact for quadratic densities)."""
    mesh, n = body.mesh, len(nodes)

    def volume(load, ncomp):
        if not load.nonzero:
            return np.zeros((n, ncomp))
        return element_load(nodes.points, mesh.cells, nodes.cells, mesh.volumes, load, ncomp, simplex_rule(3, 4),
                            shape_functions, n)

    def faces(tag, load, ncomp):
        f = nodes.boundary(tag)
        return face_load(nodes.points, f[:, :3], f, load, ncomp, 4, shape_functions, n)

    f = volume(body.body_force, 3)
    for tag, load in body.traction.items():
        f += faces(tag, load, 3)
    q = None
    if matrices.piezoelectric:
        q = volume(body.volume_charge, 1)[:, 0]
        for tag, load in body.surface_charge.items():
            q -= faces(tag, load, 1)[:, 0]
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


def edge_load_p2(nodes, edges, load, ncomp):
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
