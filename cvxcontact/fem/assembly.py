"""Vectorised P1 assembly of the electro-elastic operators of one body (SI units), on triangles (2D, per
unit thickness) or tetrahedra (3D).

With sigma = c eps(u) + e^T grad(phi) and D = e eps(u) - kappa grad(phi), the weak
forms (19)-(20) of the paper read, per unit thickness in 2D (the units below; in 3D the integrals are over
the volume and its boundary faces and every unit gains a factor m: Kuu N/m, Kup C/m, Kpp F, f in N and q
in C per node),

    Kuu u + Kup phi   = f    (+ contact forces)      Kuu = (c eps(u), eps(v))          N/m^2
    -Kup^T u + Kpp phi = q                           v^T Kup phi = (e^T grad phi, eps(v))  C/m^2
                                                     Kpp = (kappa grad phi, grad psi)      F/m
    f = (f0, v) + (f2, v)_Gamma2                     (N/m per node)
    q = (q0, psi) - (q2, psi)_Gamma_b                (C/m per node)

Nodal dofs: u has dim per node (x, y[, z]; index dim i + c), phi one per node; eps in the Voigt order of
:mod:`cvxcontact.physics.materials` (2D (xx, yy, 2xy), 3D (xx, yy, zz, 2yz, 2xz, 2xy)) and c, e, kappa the
material's ``tensors(dim)``. The supports and electrodes are imposed by a prolongation
(docs/formulation.md §11)

    u = T_u z_u + u_D,      phi = T_p z_p + phi_D

with sparse T_u (dim n, m_u) and T_p (n, m_p) and the reduced unknowns z: clamped dofs have no
column, a roller node one column per free direction (u . n = 0: the tangent in 2D, two tangents of the
face in 3D, one on the edge of two roller faces, none at a corner of three), a prescribed component
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
from .simplex import element_load, simplex_rule

__all__ = ["BodySystem", "NodePattern", "assemble", "assemble_loads", "assemble_matrices", "coefficients",
           "constrained", "gradient_products", "gradients", "lifted", "points_strain", "prolongation",
           "strain_matrix", "strain_points", "voigt_strains"]

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
    strain: sp.csr_matrix | None = None
    """A material with a non-quadratic energy (``material.quadratic`` False): the Voigt strains at the
    quadrature points from all u dofs ((q s, dim n), 1/m), their ``weights`` (q,) (m^2, 2D; m^3, 3D) and the
    ``material``; None otherwise (the energy is the quadratic form of Kuu)."""
    weights: np.ndarray | None = None
    material: object = None

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
    """Measures (m,) (areas, or volumes for tetrahedra (m, 4)) and gradients (m, dim, dim + 1) of the
    barycentric basis functions, 1/m."""
    if triangles.shape[1] == 4:
        return _tet_gradients(points, triangles)
    p = points[triangles]                                     # (m, 3, 2)
    d = np.roll(p, -1, axis=1) - np.roll(p, 1, axis=1)        # p_{i+1} - p_{i-1}
    area = 0.5 * (d[:, 0, 0] * d[:, 1, 1] - d[:, 0, 1] * d[:, 1, 0])
    grad = np.stack([d[:, :, 1], -d[:, :, 0]], axis=1) / (2.0 * area[:, None, None])
    return area, grad


TETS = 1 << 16
"""Tetrahedra per block of :func:`_tet_gradients` (its temporaries, about 450 bytes a cell, stay within a
block: measured, they were the peak of a large 3D solve's estimate)."""


def _tet_gradients(points, tets):
    """Volumes (m,) and gradients (m, 3, 4) of the barycentric functions of positively oriented tetrahedra:
    with e_k = p_k - p_0 and det = e1 . (e2 x e3), grad L1 = e2 x e3 / det (cyclic), grad L0 = -sum. By blocks
    of :data:`TETS` cells (each cell's numbers are those of all cells at once)."""
    m = len(tets)
    volume, grad = np.empty(m), np.empty((m, 3, 4))
    for a in range(0, m, TETS):
        p = points[tets[a:a + TETS]]                              # (b, 4, 3)
        e1, e2, e3 = (p[:, k] - p[:, 0] for k in (1, 2, 3))
        c = np.stack([np.cross(e2, e3), np.cross(e3, e1), np.cross(e1, e2)], axis=2)     # (b, 3, 3) columns
        det = np.einsum("md,md->m", e1, c[:, :, 0])
        g = c / det[:, None, None]
        volume[a:a + TETS] = det / 6.0
        grad[a:a + TETS, :, 1:] = g
        grad[a:a + TETS, :, 0] = -g.sum(axis=2)
    return volume, grad


VOIGT = {2: ((0, 0), (1, 1), (0, 1)), 3: ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))}
"""The strain components (i, j) of the Voigt vector in each dimension (engineering shear for i != j)."""


def strain_matrix(grad):
    """(m, s, dim k) map from element dofs (u0x, u0y[, u0z], u1x, ...) to the Voigt strain (2D (eps11, eps33,
    2 eps13): s = 3; 3D (xx, yy, zz, 2yz, 2xz, 2xy): s = 6), ``grad`` (m, dim, k) the basis gradients."""
    m, dim, k = grad.shape
    pairs = VOIGT[dim]
    B = np.zeros((m, len(pairs), dim * k))
    for row, (i, j) in enumerate(pairs):
        B[:, row, i::dim] = grad[:, j]
        if i != j:
            B[:, row, j::dim] = grad[:, i]
    return B


def voigt_strains(grad, ue) -> np.ndarray:
    """(m, s) Voigt strains (as :func:`strain_matrix`: engineering shears) of the element displacements ``ue``
    (m, dim k), node-major (u0x, u0y[, u0z], u1x, ...), ``grad`` (m, dim, k) the basis gradients (1/m): the same
    numbers as ``strain_matrix(grad) @ ue`` cell by cell up to summation order, without forming the (m, s, dim k)
    matrices (most of whose entries are zeros): eps_ij = sum_k (grad_j,k u_i,k + grad_i,k u_j,k) / (1 + delta_ij)."""
    m, dim, k = grad.shape
    u = np.asarray(ue).reshape(m, k, dim)
    out = np.empty((m, len(VOIGT[dim])))
    for row, (i, j) in enumerate(VOIGT[dim]):
        e = np.einsum("mk,mk->m", grad[:, j], u[:, :, i])
        if i != j:
            e += np.einsum("mk,mk->m", grad[:, i], u[:, :, j])
        out[:, row] = e
    return out


def points_strain(B, weights, udofs, n_dofs) -> tuple[sp.csr_matrix, np.ndarray]:
    """The sparse map (q s, n_dofs) from the u dofs to the stacked Voigt strains at q points, from their element
    strain matrices ``B`` (q, s, dim k) on the element dofs ``udofs`` (q, dim k), with the points' ``weights``."""
    q, s, _ = B.shape
    return scatter(B, np.arange(q * s).reshape(q, s), udofs, (q * s, n_dofs)), np.asarray(weights, dtype=float)


def strain_points(body) -> tuple[sp.csr_matrix, np.ndarray]:
    """P1: the strain map and weights of :func:`points_strain` at one point per element (the strain is constant
    there, so the energy of any density is integrated exactly)."""
    area, grad = gradients(body.mesh.points, body.mesh.cells)
    return points_strain(strain_matrix(grad), area, element_dofs(body.mesh.cells, body.dim),
                         body.dim * len(body.mesh.points))


def scatter(blocks, rows, cols, shape):
    """Sum element blocks (m, a, b) into a sparse matrix at global rows (m, a) and cols (m, b)."""
    _, a, b = blocks.shape
    R = np.repeat(rows.astype(np.int32), b, axis=1).ravel()
    C = np.tile(cols.astype(np.int32), (1, a)).ravel()
    return sp.csr_matrix((blocks.ravel(), (R, C)), shape=shape)


def assemble(body) -> BodySystem:
    """Assemble the matrices and the loads of ``body`` (SI units, all dofs)."""
    return assemble_loads(body, assemble_matrices(body))


def element_dofs(cells, dim):
    """(m, dim k) displacement dofs of the elements' nodes (component c of node i: dim i + c)."""
    return (dim * cells[:, :, None] + np.arange(dim)).reshape(len(cells), -1)


def assemble_matrices(body) -> BodySystem:
    """Stiffness, coupling and permittivity matrices and the free dofs of ``body``; loads zero."""
    mesh = body.mesh
    area, grad = gradients(mesh.points, mesh.cells)
    return assemble_points(body, mesh.cells, len(mesh.points), [(grad, area)])


def assemble_points(body, cells, n, points, nodes=None) -> BodySystem:
    """Kuu, Kup, Kpp (weak forms (19)-(20), SI) of any element, blind to it: the sums over quadrature points of
    the element integrands, ``points`` a sequence of (G (m, dim, k) 1/m, w (m,)): the shape gradients of the
    ``cells`` (m, k) at one point of every element and its weights (m^2 in 2D, m^3 in 3D); ``n`` nodes; with
    the prolongations of the supports and electrodes on ``nodes`` (None: the mesh's vertices), loads zero.

    Every element matrix entry is bilinear in the gradients: the (p, q) entry of the node pair (a, b) is
    sum_{j,l} D[(p, q), (j, l)] w G[j, a] G[l, b] (:func:`coefficients`). The products w G[j, a] G[l, b] of
    ``ENTRIES_PER_PASS`` // k^2 elements at a time times the rows of D (one matrix product) give their
    Kuu, Kup and Kpp entries at once, summed straight into the nodal pattern (:class:`NodePattern`): no
    coordinate list of the element entries is ever stored."""
    points = list(points)                   # read once per pass: a generator would be used up by the first
    dim = body.dim
    c, e, kappa = body.material.tensors(dim)
    D = coefficients(dim, c, e, kappa)                                   # (dim^2 [+ dim + 1], dim^2)
    pattern = NodePattern(cells, n)
    m, k = cells.shape
    Kuu = pattern.zeros(dim, dim)
    Kup = pattern.zeros(dim, 1) if e is not None else None
    Kpp = pattern.zeros(1, 1) if e is not None else None
    step = max(1, ENTRIES_PER_PASS // (k * k))
    for lo in range(0, m, step):
        part = slice(lo, lo + step)
        entries = sum(D @ gradient_products(G[part], w[part]) for G, w in points)     # (rows, m_part k k)
        pattern.add(Kuu, part, entries[:dim * dim])
        if e is not None:
            pattern.add(Kup, part, entries[dim * dim:dim * dim + dim])
            pattern.add(Kpp, part, entries[dim * dim + dim:])
        del entries
    Kuu = pattern.matrix(Kuu)
    if e is None:
        return constrained(body, Kuu, nodes=nodes)
    return constrained(body, Kuu, pattern.matrix(Kup), pattern.matrix(Kpp), nodes=nodes)


ENTRIES_PER_PASS = 1 << 20
"""Element node pairs whose entries :func:`assemble_points` holds at once (about 0.25 GB of products)."""


def coefficients(dim: int, c, e=None, kappa=None) -> np.ndarray:
    """The rows D ((dim^2, dim^2) elastic; (dim^2 + dim + 1, dim^2) with e (dim, s) C/m^2 and kappa (dim, dim)
    F/m) with which an element's Kuu, Kup and Kpp entries of the node pair (a, b) are
    sum_{j,l} D[row, dim j + l] w G[j, a] G[l, b] (G the shape gradients, w the weight; :func:`assemble_points`):
    Kuu's (p, q) at row dim p + q, D = sum_{r,s} M[r, p, j] c[r, s] M[s, q, l]; Kup's (p, 0) at dim^2 + p,
    sum_r M[r, p, j] e[l, r]; Kpp's at the last row, kappa[j, l]. M[r, p, j] (:data:`VOIGT`) is the Voigt strain
    r's coefficient of d u_p / d x_j (the strain matrix of :func:`strain_matrix` is B[r, (a, p)] =
    sum_j M[r, p, j] G[j, a])."""
    pairs = VOIGT[dim]
    M = np.zeros((len(pairs), dim, dim))
    for r, (i, j) in enumerate(pairs):
        M[r, i, j] = M[r, j, i] = 1.0
    rows = [np.einsum("rpj,rs,sql->pqjl", M, np.asarray(c, dtype=float), M).reshape(dim * dim, dim * dim)]
    if e is not None:
        rows.append(np.einsum("rpj,lr->pjl", M, np.asarray(e, dtype=float)).reshape(dim, dim * dim))
        rows.append(np.asarray(kappa, dtype=float).reshape(1, dim * dim))
    return np.vstack(rows)


def gradient_products(G: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(dim^2, m k k): the products w G[j, a] G[l, b] at row dim j + l, column k^2 e + k a + b, of the gradients
    ``G`` (m, dim, k) (1/m) and weights ``w`` (m,) of m elements (:func:`coefficients`)."""
    m, dim, k = G.shape
    left = [np.repeat(G[:, j] * w[:, None], k, axis=1) for j in range(dim)]     # (m, k k): a-major
    right = [np.tile(G[:, l], (1, k)) for l in range(dim)]
    out = np.empty((dim, dim, m, k * k))
    for j in range(dim):
        for l in range(dim):
            np.multiply(left[j], right[l], out=out[j, l])
    return out.reshape(dim * dim, m * k * k)


class NodePattern:
    """The nodal sparsity pattern of ``cells`` (m, k) on ``n`` nodes: node i couples to node j when an element has
    both, as a CSR pattern (``indptr``, ``indices``, sorted), and for each element's node pair (a, b) the position
    ``pos`` (m, k, k) of (cells[e, a], cells[e, b]) in it. A matrix with a (r, s) block per node pair is held as
    its blocks ``data`` (nnz, r, s) on this pattern (:meth:`zeros`), element blocks are summed in by
    :meth:`add` and it is returned in CSR by :meth:`matrix` (rows r i + p, columns s j + q)."""

    def __init__(self, cells, n: int):
        cells = np.asarray(cells)
        m, k = cells.shape
        rows = np.repeat(cells, k, axis=1).ravel()             # element-major, node pair (a, b) a-major
        cols = np.tile(cells, (1, k)).ravel()
        graph = sp.csr_matrix((np.ones(len(rows), dtype=bool), (rows, cols)), shape=(n, n))
        graph.sum_duplicates()                                 # canonical: sorted, unique (as the lookup needs)
        self.n, self.indptr, self.indices = n, graph.indptr, graph.indices
        index = np.int32 if graph.nnz < np.iinfo(np.int32).max else np.int64
        where = sp.csr_matrix((np.arange(graph.nnz, dtype=index), graph.indices, graph.indptr), shape=(n, n))
        self.pos = np.asarray(where[rows, cols]).reshape(m, k, k)

    @property
    def nnz(self) -> int:
        return len(self.indices)

    def zeros(self, r: int, s: int) -> np.ndarray:
        """The blocks (nnz, r, s) of a zero matrix on the pattern."""
        return np.zeros((self.nnz, r, s))

    def add(self, data: np.ndarray, part: slice, entries: np.ndarray) -> None:
        """Sum the element entries (r s, m_part k k) (row s p + q: the (p, q) entry of each element's node pairs
        (a, b), a-major) of the elements ``part`` into the blocks ``data`` (nnz, r, s), in element order. The
        positions of a run of neighbouring elements span a short range of the pattern (a mesh numbered by
        location), so only that range is summed into."""
        pos = self.pos[part].ravel()
        if not len(pos):
            return
        low = int(pos.min())
        pos = pos - low
        size = int(pos.max()) + 1
        _, r, s = data.shape
        for i in range(r):
            for j in range(s):
                data[low:low + size, i, j] += np.bincount(pos, weights=entries[s * i + j], minlength=size)

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """The CSR matrix (r n, s n) of the blocks ``data`` (nnz, r, s)."""
        _, r, s = data.shape
        if r == s == 1:
            return sp.csr_matrix((data.ravel(), self.indices, self.indptr), shape=(self.n, self.n))
        bsr = sp.bsr_matrix((data, self.indices, self.indptr), shape=(r * self.n, s * self.n))
        return bsr.tocsr()


def strain_at(points, cells, dim, n) -> tuple[sp.csr_matrix, np.ndarray]:
    """The strain map and weights (:func:`points_strain`) at ``points`` [(G, w)] (as :func:`assemble_points`),
    point by point, of the ``cells`` (m, k) of ``n`` nodes."""
    B = np.concatenate([strain_matrix(G) for G, _ in points])
    w = np.concatenate([w for _, w in points])
    return points_strain(B, w, np.tile(element_dofs(cells, dim), (len(points), 1)), dim * n)


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

    Tu (dim n, m_u) sparse with orthonormal columns, u_fixed (dim n,) m; Tp (n, m_p) sparse (None for an
    elastic body), floating (m_p,) bool marking the floating-electrode columns (the last ones, in the
    order of ``body.floating``). Columns follow the node order. Raises SceneError if two supports
    prescribe different values at one node. ``nodes``: the node set of the unknowns, anything with
    ``points`` and ``boundary_nodes(tags)`` (P2: :class:`~cvxcontact.geometry.quadratic.P2Nodes`, whose
    boundary nodes include the midpoints of the boundary edges); default the mesh's vertices (P1).
    """
    mesh = body.mesh if nodes is None else nodes
    n, dim = len(mesh.points), body.dim
    ncols, directions, u_fixed = body.node_supports(nodes)
    first = np.concatenate([[0], np.cumsum(ncols)[:-1]])
    plain = np.flatnonzero(ncols == dim)
    part = np.flatnonzero((ncols > 0) & (ncols < dim))
    # a partly held node i: column first[i] + j is its free direction j (components k at dofs dim i + k)
    node, j, k = (a.ravel() for a in np.meshgrid(part, np.arange(dim - 1), np.arange(dim), indexing="ij"))
    used = j < ncols[node]
    node, j, k = node[used], j[used], k[used]
    rows = np.concatenate([dim * plain + c for c in range(dim)] + [dim * node + k])
    cols = np.concatenate([first[plain] + c for c in range(dim)] + [first[node] + j])
    data = np.concatenate([np.ones(dim * len(plain)), directions[node, j, k]])
    keep = data != 0
    Tu = sp.csr_matrix((data[keep], (rows[keep], cols[keep])), shape=(dim * n, int(ncols.sum())))
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
    if body.dim == 3:
        return _tet_loads(body, matrices)
    mesh = body.mesh
    f = _body_load(mesh, body.body_force, 2)
    for tag, load in body.traction.items():
        f += edge_load(mesh, mesh.boundary(tag), load, 2)
    q = None
    if matrices.piezoelectric:
        q = _body_load(mesh, body.volume_charge, 1)
        for tag, load in body.surface_charge.items():
            q -= edge_load(mesh, mesh.boundary(tag), load, 1)
    return lifted(body, matrices, f.ravel(), q, mesh)


def _tet_loads(body, matrices):
    """The P1 consistent loads of a tetrahedral body: volume densities by the degree-2 rule on each
    tetrahedron, surface densities by the degree-2 rule on each boundary triangle (exact for affine
    densities times the P1 basis)."""
    mesh = body.mesh
    shape = lambda L: L
    tets, n = mesh.cells, len(mesh.points)
    f = _volume_load(mesh.points, tets, tets, mesh.volumes, body.body_force, 3, 2, shape, n)
    for tag, load in body.traction.items():
        f += face_load(mesh.points, mesh.boundary(tag), mesh.boundary(tag), load, 3, 2, shape, n)
    q = None
    if matrices.piezoelectric:
        q = _volume_load(mesh.points, tets, tets, mesh.volumes, body.volume_charge, 1, 2, shape, n)[:, 0]
        for tag, load in body.surface_charge.items():
            q -= face_load(mesh.points, mesh.boundary(tag), mesh.boundary(tag), load, 1, 2, shape, n)[:, 0]
    return lifted(body, matrices, f.ravel(), q, mesh)


def _volume_load(points, vertices, nodes, volumes, load, ncomp, degree, shape, n):
    """(n, ncomp) consistent load of a volume density on tetrahedra (:func:`~cvxcontact.fem.simplex.element_load`
    with the rule of ``degree``); zero without a load."""
    if not load.nonzero:
        return np.zeros((n, ncomp))
    return element_load(points, vertices, nodes, volumes, load, ncomp, simplex_rule(3, degree), shape, n)


def face_load(points, faces, nodes, load, ncomp, degree, shape, n):
    """(n, ncomp) consistent load of a surface density on boundary triangles ``faces`` (k, 3) (vertex
    indices; ``nodes`` (k, j) the element nodes the shape functions act on), rule of ``degree``."""
    a, b, c = (points[faces[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    return element_load(points, faces, nodes, area, load, ncomp, simplex_rule(2, degree), shape, n)


def lifted(body, matrices: BodySystem, f: np.ndarray, q: np.ndarray | None, nodes) -> BodySystem:
    """A BodySystem sharing the matrices of ``matrices`` with the consistent loads ``f`` (dim n,) N/m and
    ``q`` (n,) C/m (None for an elastic body) lifted by the prescribed values (module docstring):
    f - Kuu u_D - Kup phi_D, q + Kup^T u_D - Kpp phi_D, and the floating charges Q (C/m) of ``body``.
    ``nodes``: the node set of the unknowns (the Mesh for P1, P2Nodes for P2)."""
    system = replace(matrices, f=f)
    moved = np.any(matrices.u_fixed)                   # (a product with zeros adds nothing: not formed)
    if matrices.piezoelectric:
        phi_fixed = _electrode_potential(nodes, body)
        driven = np.any(phi_fixed)
        if driven:
            system.f = system.f - matrices.Kup @ phi_fixed
        system.q = q - matrices.Kpp @ phi_fixed if driven else q
        if moved:
            system.q = system.q + matrices.Kup.T @ matrices.u_fixed
        system.phi_fixed = phi_fixed
        system.charge = np.array([body.floating[t] for t in body.floating], dtype=float)    # Q, C/m
    if moved:
        system.f = system.f - matrices.Kuu @ matrices.u_fixed
    return system


def _electrode_potential(mesh, body):
    """Nodal potentials (V) on the driven electrodes, zero elsewhere (grounded included). ``mesh`` is a
    Mesh (P1) or P2Nodes (P2: the potential interpolated at vertices and midpoints)."""
    phi = np.zeros(len(mesh.points))
    for tag, load in body.potential.items():
        nodes = mesh.boundary_nodes([tag])
        phi[nodes] = load(*mesh.points[nodes].T)
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
        share = mesh.vertex_areas                                 # (once per mesh)
        return share[:, None] * load.value if ncomp > 1 else share * float(load.value)
    mid = 0.5 * (p[tri] + p[np.roll(tri, -1, axis=1)])        # midpoints of edges (0,1), (1,2), (2,0)
    val = load(mid[..., 0], mid[..., 1]).reshape(len(tri), 3, ncomp)
    nodal = (val + np.roll(val, 1, axis=1)) * (mesh.areas / 6.0)[:, None, None]   # node i: edges i and i-1
    out = accumulate(tri.ravel(), nodal.reshape(-1, ncomp), len(p))
    return out if ncomp > 1 else out[:, 0]


def edge_load(mesh, edges, load, ncomp):
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
