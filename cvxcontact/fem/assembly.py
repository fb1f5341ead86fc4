"""Vectorised P1 assembly of the electro-elastic operators of one body (SI units).

With sigma = c eps(u) + e^T grad(phi) and D = e eps(u) - kappa grad(phi), the weak
forms (19)-(20) of the paper read, per unit thickness,

    Kuu u + Kup phi   = f    (+ contact forces)      Kuu = (c eps(u), eps(v))          N/m^2
    -Kup^T u + Kpp phi = q                           v^T Kup phi = (e^T grad phi, eps(v))  C/m^2
                                                     Kpp = (kappa grad phi, grad psi)      F/m
    f = (f0, v) + (f2, v)_Gamma2                     (N/m per node)
    q = (q0, psi) - (q2, psi)_Gamma_b                (C/m per node)

Nodal dofs: u has 2 per node (x then y, index 2 i + c), phi one per node. The supports and
electrodes are imposed by a prolongation (docs/formulation.md §11)

    u = T_u z_u + u_D,      phi = T_p z_p + phi_D

with sparse T_u (2n, m_u) and T_p (n, m_p) and the reduced unknowns z: clamped dofs have no
column, a roller node one column along the part's tangent (u . n = 0), a prescribed component
of ``displacement`` no column (its value in u_D, m), grounded and driven electrode nodes no
column (phi_D = V), and each floating electrode one column equal to 1 on all its nodes (one
shared potential). The prescribed values are lifted: f - Kuu u_D - Kup phi_D and
q + Kup^T u_D - Kpp phi_D; the reduced equations are T^T (...) with the floating charges Q
(C/m) added to their columns' rows.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from ..errors import SceneError

__all__ = ["BodySystem", "assemble", "assemble_matrices", "assemble_loads", "gradients", "strain_matrix",
           "prolongation", "constrained", "lifted"]

_GAUSS2 = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)  # 2-point Gauss abscissae on [0, 1]


@dataclass
class BodySystem:
    """Assembled matrices and loads of one body, all dofs, SI units.

    ``Tu`` / ``Tp`` are the prolongations of the module docstring (u = Tu z_u + u_fixed,
    phi = Tp z_p + phi_fixed); ``u_free`` / ``phi_free`` give for each of their columns the
    dof it acts on (for a plain selection, as with clamped parts and grounded or driven
    electrodes only, exactly the free dofs; a roller column names its node's larger
    component, a floating electrode column its first node); ``floating`` (m_p,) bool marks the
    floating-electrode columns and ``charge`` their prescribed total charges (C/m).
    ``f`` and ``q`` include the lifting of ``u_fixed`` (m) and ``phi_fixed`` (V, zero off the
    electrodes). The electric fields are None for an elastic body.
    """

    Kuu: sp.csr_matrix
    f: np.ndarray
    u_free: np.ndarray
    Kup: sp.csr_matrix | None = None
    Kpp: sp.csr_matrix | None = None
    q: np.ndarray | None = None
    phi_free: np.ndarray | None = None
    phi_fixed: np.ndarray | None = None
    Tu: sp.csr_matrix | None = None
    u_fixed: np.ndarray | None = None
    Tp: sp.csr_matrix | None = None
    floating: np.ndarray | None = None
    charge: np.ndarray | None = None

    @property
    def piezoelectric(self) -> bool:
        return self.Kpp is not None

    def reduced_loads(self) -> tuple[np.ndarray, np.ndarray | None]:
        """(T_u^T f, T_p^T q + Q): the right-hand sides of the reduced equations, SI (N/m, C/m)."""
        fz = self.Tu.T @ self.f
        if not self.piezoelectric:
            return fz, None
        qz = self.Tp.T @ self.q
        qz[self.floating] += self.charge
        return fz, qz


def gradients(points, triangles):
    """Areas (m,) and gradients (m, 2, 3) of the barycentric basis functions, 1/m."""
    p = points[triangles]                                     # (m, 3, 2)
    d = np.roll(p, -1, axis=1) - np.roll(p, 1, axis=1)        # p_{i+1} - p_{i-1}
    area = 0.5 * (d[:, 0, 0] * d[:, 1, 1] - d[:, 0, 1] * d[:, 1, 0])
    grad = np.stack([d[:, :, 1], -d[:, :, 0]], axis=1) / (2.0 * area[:, None, None])
    return area, grad


def strain_matrix(grad):
    """(m, 3, 6) map from element dofs (u0x, u0y, u1x, ...) to (eps11, eps33, 2 eps13)."""
    B = np.zeros((grad.shape[0], 3, 6))
    B[:, 0, 0::2] = grad[:, 0]
    B[:, 1, 1::2] = grad[:, 1]
    B[:, 2, 0::2] = grad[:, 1]
    B[:, 2, 1::2] = grad[:, 0]
    return B


def scatter(blocks, rows, cols, shape):
    """Sum element blocks (m, a, b) into a sparse matrix at global rows (m, a) and cols (m, b)."""
    m, a, b = blocks.shape
    R = np.repeat(rows.astype(np.int32), b, axis=1).ravel()
    C = np.tile(cols.astype(np.int32), (1, a)).ravel()
    return sp.csr_matrix((blocks.ravel(), (R, C)), shape=shape)


def assemble(body) -> BodySystem:
    """Assemble the matrices and the loads of ``body`` (SI units, all dofs)."""
    return assemble_loads(body, assemble_matrices(body))


def assemble_matrices(body) -> BodySystem:
    """Stiffness, coupling and permittivity matrices and the free dofs of ``body``; loads zero."""
    mesh, mat = body.mesh, body.material
    n = len(mesh.points)
    tri = mesh.triangles
    area, grad = gradients(mesh.points, tri)
    B = strain_matrix(grad)
    Bt = np.swapaxes(B, 1, 2) * area[:, None, None]                 # (m, 6, 3), area-weighted
    udofs = (2 * tri[:, :, None] + np.arange(2)).reshape(-1, 6)
    Kuu = scatter((Bt @ mat.c) @ B, udofs, udofs, (2 * n, 2 * n))
    Kup = Kpp = None
    if mat.piezoelectric:
        Gt = np.swapaxes(grad, 1, 2) * area[:, None, None]            # (m, 3, 2)
        Kup = scatter((Bt @ mat.e.T) @ grad, udofs, tri, (2 * n, n))
        Kpp = scatter((Gt @ mat.kappa) @ grad, tri, tri, (n, n))
    return constrained(body, Kuu, Kup, Kpp)


def constrained(body, Kuu, Kup=None, Kpp=None, nodes=None) -> BodySystem:
    """The BodySystem of the assembled matrices (all dofs of ``nodes``; Kup, Kpp None for an elastic body)
    with the prolongations of ``body``'s supports and electrodes (:func:`prolongation`); loads zero."""
    Tu, u_fixed, Tp, floating = prolongation(body, nodes)
    system = BodySystem(Kuu=Kuu, f=np.zeros(Kuu.shape[0]), u_free=_representative(Tu), Tu=Tu, u_fixed=u_fixed)
    if Kpp is not None:
        system.Kup, system.Kpp = Kup, Kpp
        system.Tp, system.floating = Tp, floating
        system.phi_free = _representative(Tp)
        system.charge = np.zeros(int(floating.sum()))
    return system


def _representative(T):
    """For each column of T, the row (dof) with the largest entry (the first one on ties)."""
    T = T.tocsc()
    T.sort_indices()
    a = np.abs(T.data)
    col = np.repeat(np.arange(T.shape[1]), np.diff(T.indptr))
    top = np.maximum.reduceat(a, T.indptr[:-1]) if T.shape[1] else np.zeros(0)
    hit = np.flatnonzero(a == top[col])
    first = np.unique(col[hit], return_index=True)[1]
    return T.indices[hit[first]].astype(np.int64)


def prolongation(body, nodes=None):
    """(Tu, u_fixed, Tp, floating) of ``body``: the map from reduced to nodal unknowns (module docstring).

    Tu (2n, m_u) sparse with orthonormal columns, u_fixed (2n,) m; Tp (n, m_p) sparse (None for an
    elastic body), floating (m_p,) bool marking the floating-electrode columns (the last ones, in the
    order of ``body.floating``). Columns follow the node order. Raises SceneError if two supports
    prescribe different values at one node. ``nodes``: the node set of the unknowns, anything with
    ``points`` and ``boundary_nodes(tags)`` (P2: :class:`~cvxcontact.geometry.quadratic.P2Nodes`, whose
    boundary nodes include the midpoints of the boundary edges); default the mesh's vertices (P1).
    """
    mesh = body.mesh if nodes is None else nodes
    n = len(mesh.points)
    ncols, tangent, u_fixed = body.node_supports(nodes)
    first = np.concatenate([[0], np.cumsum(ncols)[:-1]])
    plain = np.flatnonzero(ncols == 2)
    one = np.flatnonzero(ncols == 1)
    rows = np.concatenate([2 * plain, 2 * plain + 1, 2 * one, 2 * one + 1])
    cols = np.concatenate([first[plain], first[plain] + 1, first[one], first[one]])
    data = np.concatenate([np.ones(2 * len(plain)), tangent[one, 0], tangent[one, 1]])
    keep = data != 0
    Tu = sp.csr_matrix((data[keep], (rows[keep], cols[keep])), shape=(2 * n, int(ncols.sum())))
    if not body.piezoelectric:
        return Tu, u_fixed, None, None
    fixed = mesh.boundary_nodes([*body.grounded, *body.potential])
    float_nodes = [mesh.boundary_nodes([t]) for t in body.floating]
    taken = np.zeros(n, dtype=bool)
    taken[fixed] = True
    for f in float_nodes:
        taken[f] = True
    free = np.flatnonzero(~taken)
    m = len(free)
    rows = np.concatenate([free] + float_nodes)
    cols = np.concatenate([np.arange(m)] + [np.full(len(f), m + k) for k, f in enumerate(float_nodes)])
    Tp = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, m + len(float_nodes)))
    floating = np.zeros(m + len(float_nodes), dtype=bool)
    floating[m:] = True
    return Tu, u_fixed, Tp, floating


def assemble_loads(body, matrices: BodySystem) -> BodySystem:
    """A BodySystem sharing the matrices of ``matrices`` with the loads of ``body``.

    ``body`` must have the mesh, material and boundary parts the matrices were built for.
    """
    mesh = body.mesh
    f = _body_load(mesh, body.body_force, 2)
    for tag, load in body.traction.items():
        f += _edge_load(mesh, mesh.boundary(tag), load, 2)
    q = None
    if matrices.piezoelectric:
        q = _body_load(mesh, body.volume_charge, 1)
        for tag, load in body.surface_charge.items():
            q -= _edge_load(mesh, mesh.boundary(tag), load, 1)
    return lifted(body, matrices, f.ravel(), q, mesh)


def lifted(body, matrices: BodySystem, f: np.ndarray, q: np.ndarray | None, nodes) -> BodySystem:
    """A BodySystem sharing the matrices of ``matrices`` with the consistent loads ``f`` (2n,) N/m and
    ``q`` (n,) C/m (None for an elastic body) lifted by the prescribed values (module docstring):
    f - Kuu u_D - Kup phi_D, q + Kup^T u_D - Kpp phi_D, and the floating charges Q (C/m) of ``body``.
    ``nodes``: the node set of the unknowns (the Mesh for P1, P2Nodes for P2)."""
    system = replace(matrices, f=f)
    if matrices.piezoelectric:
        phi_fixed = _electrode_potential(nodes, body)
        system.f = system.f - matrices.Kup @ phi_fixed
        system.q = q - matrices.Kpp @ phi_fixed + matrices.Kup.T @ matrices.u_fixed
        system.phi_fixed = phi_fixed
        system.charge = np.array([body.floating[t] for t in body.floating], dtype=float)    # Q, C/m
    if np.any(matrices.u_fixed):
        system.f = system.f - matrices.Kuu @ matrices.u_fixed
    return system


def _electrode_potential(mesh, body):
    """Nodal potentials (V) on the driven electrodes, zero elsewhere (grounded included). ``mesh`` is a
    Mesh (P1) or P2Nodes (P2: the potential interpolated at vertices and midpoints)."""
    phi = np.zeros(len(mesh.points))
    for tag, load in body.potential.items():
        nodes = mesh.boundary_nodes([tag])
        phi[nodes] = load(mesh.points[nodes, 0], mesh.points[nodes, 1])
    grounded = mesh.boundary_nodes(body.grounded)
    if np.any(phi[grounded] != 0):
        raise SceneError(f"{body.name}: a driven electrode touches a grounded one at a non-zero potential")
    return phi


def _body_load(mesh, load, ncomp):
    """Consistent nodal load of a volume density, edge-midpoint rule (exact for quadratics)."""
    p, tri = mesh.points, mesh.triangles
    if not load.nonzero:
        return np.zeros((len(p), ncomp)) if ncomp > 1 else np.zeros(len(p))
    if not callable(load.value):                                   # constant: area / 3 to each vertex
        share = np.bincount(tri.ravel(), weights=np.repeat(mesh.areas / 3.0, 3), minlength=len(p))
        return share[:, None] * load.value if ncomp > 1 else share * float(load.value)
    mid = 0.5 * (p[tri] + p[np.roll(tri, -1, axis=1)])        # midpoints of edges (0,1), (1,2), (2,0)
    val = load(mid[..., 0], mid[..., 1]).reshape(len(tri), 3, ncomp)
    nodal = (val + np.roll(val, 1, axis=1)) * (mesh.areas / 6.0)[:, None, None]   # node i: edges i and i-1
    out = accumulate(tri.ravel(), nodal.reshape(-1, ncomp), len(p))
    return out if ncomp > 1 else out[:, 0]


def _edge_load(mesh, edges, load, ncomp):
    """Consistent nodal load of a surface density on ``edges``, 2-point Gauss rule."""
    a, b = mesh.points[edges[:, 0]], mesh.points[edges[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    out = np.zeros((len(mesh.points), ncomp))
    for t in _GAUSS2:
        x = (1 - t) * a + t * b
        val = load(x[:, 0], x[:, 1]).reshape(len(edges), ncomp) * (0.5 * length)[:, None]
        out += accumulate(edges.T.ravel(), np.concatenate([(1 - t) * val, t * val]), len(mesh.points))
    return out if ncomp > 1 else out[:, 0]


def accumulate(index, values, n):
    """Sum rows of ``values`` (k, c) into an (n, c) array at ``index`` (k,)."""
    return np.column_stack([np.bincount(index, weights=values[:, j], minlength=n) for j in range(values.shape[1])])
