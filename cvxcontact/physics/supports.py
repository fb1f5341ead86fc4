"""The supports of a body and the rigid motions they leave free (docs/formulation.md §11).

Functions of a :class:`~cvxcontact.physics.body.Body` (its mesh, clamped, roller and displacement parts),
which the Body's methods of the same names call: the kinematic rows of the supports and their node-by-node
reduction (the prolongation's input), the rigid motions no support holds (a basis per mesh component, their
readable names, their nodal fields on a node set). Whether the contact holds those motions is decided on the
assembled problem (:mod:`cvxcontact.fem.kernel`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SceneError

__all__ = ["component_description", "component_label", "free_basis", "free_motions", "held_modes", "motion_label",
           "motion_name", "node_normals", "node_set", "node_supports", "rigid_field", "supports"]


def supports(body, nodes=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The kinematic constraints of the supports, one row per constrained direction at a node.

    Returns ``(nodes, directions, values)``: u(node) . direction = value (m), with unit
    directions (k, dim): dim rows per clamped node (u = 0), one per prescribed component of a
    ``displacement`` part, one per node of a ``roller`` part (u . n = 0, n the part's unit
    normal). Rows may repeat or be dependent at corners; conflicting values raise a
    SceneError when the prolongation is built (:func:`cvxcontact.fem.assembly.prolongation`).
    ``nodes``: another node set of the mesh with ``points`` and ``boundary_nodes`` (the
    :class:`~cvxcontact.geometry.quadratic.P2Nodes` of P2 elements); default the mesh's vertices.
    """
    mesh = body.mesh.node_set(nodes)
    dim = body.dim
    nodes, dirs, vals = [], [], []
    eye = np.eye(dim)
    if body.clamped:
        c = mesh.boundary_nodes(body.clamped)
        for k in range(dim):
            nodes.append(c)
            dirs.append(np.broadcast_to(eye[k], (len(c), dim)))
            vals.append(np.zeros(len(c)))
    for tag, value in body.displacement.items():
        c = mesh.boundary_nodes([tag])
        for k in range(dim):
            if value[k] is not None:
                nodes.append(c)
                dirs.append(np.broadcast_to(eye[k], (len(c), dim)))
                vals.append(np.full(len(c), value[k]))
    for tag in body.roller:
        c = mesh.boundary_nodes([tag])
        nodes.append(c)
        dirs.append(np.broadcast_to(body._roller_normals[tag], (len(c), dim)))
        vals.append(np.zeros(len(c)))
    if not nodes:
        return np.zeros(0, dtype=int), np.zeros((0, dim)), np.zeros(0)
    return np.concatenate(nodes), np.concatenate(dirs), np.concatenate(vals)


def node_supports(body, nodes=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The supports reduced node by node: ``(free, directions, u_fixed)``.

    ``free`` (n,) the number of free displacement components of each node (dim, ..., 0),
    ``directions`` (n, dim, dim) whose first ``free[i]`` rows are node i's free orthonormal directions
    when it is partly held (a roller node: the part's tangent in 2D, two tangents of the face in 3D; a
    node on two roller faces: their common direction), ``u_fixed`` (dim n,) the prescribed displacement
    (m; the least-squares value of the node's rows, which must hold exactly: conflicting supports at a
    node raise a SceneError). ``nodes`` as in :func:`supports`.
    """
    mesh = body.mesh.node_set(nodes)
    dim = body.dim
    n = len(mesh.points)
    nodes, dirs, vals = supports(body, nodes)
    u_fixed, free, directions = np.zeros(dim * n), np.full(n, dim), np.zeros((n, dim, dim))
    order = np.argsort(nodes, kind="stable")
    nodes, dirs, vals = nodes[order], dirs[order], vals[order]
    starts = np.flatnonzero(np.r_[True, np.diff(nodes) != 0]) if len(nodes) else np.zeros(0, dtype=int)
    counts = np.diff(np.r_[starts, len(nodes)])
    for r in np.unique(counts):                 # the nodes with r rows together: (k, r, dim) stacked SVDs
        first = starts[counts == r]
        at = first[:, None] + np.arange(r)
        i, D, v = nodes[first], dirs[at], vals[at]
        U, sv, Vt = np.linalg.svd(D)                                    # (k, r, r), (k, min), (k, dim, dim)
        keep = sv > 1e-9
        rank = keep.sum(axis=1)
        # the least-squares value V diag(1/s) U^T v over the singular values kept (lstsq with rcond 1e-9)
        coef = np.where(keep, np.einsum("kji,kj->ki", U[:, :, :sv.shape[1]], v) / np.where(keep, sv, 1.0), 0.0)
        ud = np.einsum("kji,kj->ki", Vt[:, :sv.shape[1], :], coef)
        miss = np.abs(np.einsum("kjd,kd->kj", D, ud) - v).max(axis=1)
        bad = np.flatnonzero(miss > 1e-9 * np.maximum(np.abs(v).max(axis=1), 1e-300))
        if len(bad):
            b = bad[0]
            rows = ", ".join(f"u.({', '.join(f'{x:.3g}' for x in d)}) = {x:.6g}" for d, x in zip(D[b], v[b]))
            raise SceneError(f"{body.name}: the supports prescribe incompatible displacements at node {int(i[b])} "
                             f"({', '.join(f'{x:.6g}' for x in mesh.points[i[b]])}) m: {rows}")
        u_fixed[(dim * i[:, None] + np.arange(dim)).ravel()] = ud.ravel()
        free[i] = dim - rank
        for q in np.unique(rank[(rank > 0) & (rank < dim)]):           # partly held: the free directions
            sel = rank == q
            directions[i[sel], :dim - q] = Vt[sel, q:]
    return free, directions, u_fixed


def free_motions(body, contact: bool | Sequence[str] = True) -> list[str]:
    """The rigid motions of the body that nothing holds, as readable names (empty if none).

    A rigid motion u(x) = t + w x (x - xc) (2D: (tx - w (y - yc), ty + w (x - xc))) is held by the
    supports if some support row has u . direction != 0, and by a contact part (``contact=True``: the
    ``contact`` part; a list: those parts; False: none) if u . nu != 0 at some of its nodes (nu the outward
    normal; contact holds on one side only). Each connected piece of the mesh is checked on its own.
    """
    out = []
    for c, free, centre, size in free_basis(body, contact):
        out += [motion_label(v, centre, size) + component_label(body, c) for v in free]
    return out


def motion_name(body, coefficients: ArrayLike) -> str:
    """A readable name of the rigid motion sum_j coefficients[j] held_modes()[j] (e.g. "translation y",
    "rotation about (0.5, 0) m", in 3D "translation along z", "rotation about x through (0, 0.5, 0) m"; the
    mesh component too when the mesh has several)."""
    a = np.asarray(coefficients, dtype=float)
    names, k = [], 0
    for c, V, centre, size in free_basis(body):
        v = a[k:k + len(V)] @ V
        k += len(V)
        if np.abs(v).max() > 1e-9 * max(float(np.abs(a).max()), 1e-300):
            names.append(motion_label(v, centre, size) + component_label(body, c))
    return " and ".join(names)


def component_label(body, c) -> str:
    """" of mesh component c (...)" when the mesh has several components, else ""."""
    if int(body.mesh.components.max()) == 0:
        return ""
    return f" of mesh component {c} ({component_description(body.mesh, c)})"


def component_description(mesh, c) -> str:
    """"k triangles, centroid at (x, y) m" (tetrahedra, (x, y, z) in 3D) of mesh component c."""
    inside = mesh.components == c
    measure = mesh.areas[inside] if mesh.dim == 2 else mesh.volumes[inside]
    cg = (mesh.points[mesh.cells[inside]].mean(axis=1) * measure[:, None]).sum(axis=0) / measure.sum()
    return (f"{int(inside.sum())} {'triangles' if mesh.dim == 2 else 'tetrahedra'}, centroid at "
            f"({', '.join(f'{x:.4g}' for x in cg)}) m")


def held_modes(body, nodes=None) -> np.ndarray:
    """(k, dim n_nodes): the rigid motions no support holds (the contact must), as nodal displacement fields
    (components interleaved per node; translations in m per unit, rotations scaled by the piece's size).
    Empty (0, dim n_nodes) when the supports hold every rigid motion. Used by the balance check and by
    the well-posedness check of the assembled problem (:mod:`cvxcontact.fem.kernel`).
    ``nodes``: the node set (P2: :class:`~cvxcontact.geometry.quadratic.P2Nodes`); default the mesh's
    vertices."""
    points, comp = node_set(body, nodes)
    dim = body.dim
    rows = []
    if body.held_by_contact:
        for c, V, centre, size in free_basis(body):
            on = (comp == c).astype(float)[:, None]
            x = (points - centre) / size
            rows += [(on * rigid_field(v, x)).ravel() for v in V]
    return np.array(rows).reshape(-1, dim * len(points))


def rigid_field(v, x) -> np.ndarray:
    """(n, dim) the rigid motion v at points x (n, dim): 2D v = (tx, ty, w), u = (tx - w y, ty + w x);
    3D v = (t, w), u = t + w x x."""
    if x.shape[1] == 2:
        tx, ty, w = v
        return np.column_stack([tx - w * x[:, 1], ty + w * x[:, 0]])
    return v[:3] + np.cross(v[3:], x)


def node_set(body, nodes):
    """(points (n, dim) m, mesh component of each node) of the mesh's vertices or of ``nodes`` (a node
    set of the mesh with ``points`` and ``cells`` (m, k), e.g. the P2 nodes)."""
    held = body.mesh.node_set(nodes)
    return held.points, held.node_components


def free_basis(body, contact=False):
    """Per mesh component with rigid motions the supports (and with ``contact`` the normals of the
    contact parts: True the ``contact`` part, or a list of parts) leave free: (component, V (k, 3) in 2D
    orthonormal rows of (tx, ty, w), (k, 6) in 3D of (tx, ty, tz, wx, wy, wz), in scaled coordinates,
    centre (m), size (m))."""
    mesh = body.mesh
    nodes, dirs, _ = supports(body)
    own = [] if body.contact is None else [body.contact]
    parts = (own if contact is True else list(contact)) if contact else []
    for tag in parts:
        nodes = np.concatenate([nodes, mesh.boundary_nodes([tag])])
        dirs = np.concatenate([dirs, node_normals(mesh, tag)])
    out = []
    for c in range(int(mesh.components.max()) + 1):
        pts = mesh.points[mesh.node_components == c]
        centre = pts.mean(axis=0)
        size = float(np.ptp(pts, axis=0).max()) or 1.0
        keep = mesh.node_components[nodes] == c
        x = (mesh.points[nodes[keep]] - centre) / size
        d = dirs[keep]
        if body.dim == 2:
            A = np.column_stack([d[:, 0], d[:, 1], -x[:, 1] * d[:, 0] + x[:, 0] * d[:, 1]])
        else:
            A = np.column_stack([d, np.cross(x, d)])                   # u . d = t . d + w . (x x d)
        k = A.shape[1]
        _, sv, Vt = np.linalg.svd(np.vstack([A, np.zeros((k, k))]), full_matrices=False)   # Vt (k, k); no U
        free = Vt[sv <= 1e-9 * max(sv.max(initial=0.0), 1.0)]
        if len(free):
            out.append((c, free, centre, size))
    return out


_AXES = "xyz"


def _direction(a):
    """"x" (or "y", "z") for a unit vector along an axis (its largest component positive), else "(a1, a2, a3)"."""
    for k in range(len(a)):
        if abs(a[k] - 1.0) <= 1e-9:
            return _AXES[k]
    return f"({', '.join(f'{x:.4g}' for x in a)})"


def motion_label(v, centre, size):
    """A readable name of the rigid motion v (scaled coordinates, see Body.free_motions): 2D (tx, ty, w),
    3D (tx, ty, tz, wx, wy, wz)."""
    if len(v) == 3:
        tx, ty, w = v
        if abs(w) <= 1e-9:
            t = np.array([tx, ty]) / np.hypot(tx, ty)
            if abs(t[1]) <= 1e-9:
                return "translation x"
            if abs(t[0]) <= 1e-9:
                return "translation y"
            return f"translation along ({t[0]:.4g}, {t[1]:.4g})"
        xc, yc = (round(c / size, 6) * size + 0.0 for c in (centre[0] - ty / w * size, centre[1] + tx / w * size))
        return f"rotation about ({xc:.4g}, {yc:.4g}) m"                 # (to 1e-6 of the piece's size)
    t, w = np.asarray(v[:3], dtype=float), np.asarray(v[3:], dtype=float)
    nw = np.linalg.norm(w)
    if nw <= 1e-9:
        t = t / np.linalg.norm(t)
        return f"translation along {_direction(t if t[np.argmax(np.abs(t))] > 0 else -t)}"
    axis = w / nw
    if axis[np.argmax(np.abs(axis))] < 0:
        axis = -axis
    p = centre + size * np.cross(w, t) / nw ** 2                       # the point of the axis nearest the centre
    p = np.round(p / size, 6) * size + 0.0
    name = f"rotation about {_direction(axis)} through ({', '.join(f'{x:.4g}' for x in p)}) m"
    if abs(t @ w) > 1e-9 * nw * max(np.linalg.norm(t), 1e-300) and abs(t @ axis) > 1e-9:
        name += " with a translation along that axis"
    return name


def node_normals(mesh, tag):
    """(boundary_nodes(tag), dim) unit outward normals of a part at its nodes (mean of the adjacent edges,
    or faces in 3D)."""
    nodes = mesh.boundary_nodes([tag])
    cells, normals = mesh.boundary(tag), mesh.outward_normals(tag)
    acc = np.zeros((len(mesh.points), normals.shape[1]))
    for k in range(cells.shape[1]):
        np.add.at(acc, cells[:, k], normals)
    n = acc[nodes]
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
