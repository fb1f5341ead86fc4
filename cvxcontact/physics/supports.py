"""The supports of a body and the rigid motions they leave free (docs/formulation.md §11).

Functions of a :class:`~cvxcontact.physics.scene.Body` (its mesh, clamped, roller and displacement parts),
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

__all__ = ["supports", "node_supports", "free_motions", "motion_name", "component_label", "held_modes",
           "node_set", "free_basis", "motion_label", "node_normals"]


def supports(body, nodes=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The kinematic constraints of the supports, one row per constrained direction at a node.

    Returns ``(nodes, directions, values)``: u(node) . direction = value (m), with unit
    directions: two rows per clamped node (u = 0), one per prescribed component of a
    ``displacement`` part, one per node of a ``roller`` part (u . n = 0, n the part's unit
    normal). Rows may repeat or be dependent at corners; conflicting values raise a
    SceneError when the prolongation is built (:func:`cvxcontact.fem.assembly.prolongation`).
    ``nodes``: another node set of the mesh with ``points`` and ``boundary_nodes`` (the
    :class:`~cvxcontact.geometry.quadratic.P2Nodes` of P2 elements); default the mesh's vertices.
    """
    mesh = body.mesh if nodes is None else nodes
    nodes, dirs, vals = [], [], []
    eye = np.eye(2)
    if body.clamped:
        c = mesh.boundary_nodes(body.clamped)
        for k in range(2):
            nodes.append(c)
            dirs.append(np.broadcast_to(eye[k], (len(c), 2)))
            vals.append(np.zeros(len(c)))
    for tag, value in body.displacement.items():
        c = mesh.boundary_nodes([tag])
        for k in range(2):
            if value[k] is not None:
                nodes.append(c)
                dirs.append(np.broadcast_to(eye[k], (len(c), 2)))
                vals.append(np.full(len(c), value[k]))
    for tag in body.roller:
        c = mesh.boundary_nodes([tag])
        nodes.append(c)
        dirs.append(np.broadcast_to(body._roller_normals[tag], (len(c), 2)))
        vals.append(np.zeros(len(c)))
    if not nodes:
        return np.zeros(0, dtype=int), np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(nodes), np.concatenate(dirs), np.concatenate(vals)


def node_supports(body, nodes=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The supports reduced node by node: ``(free, tangent, u_fixed)``.

    ``free`` (n,) the number of free displacement components of each node (2, 1 or 0),
    ``tangent`` (n, 2) the free unit direction of the nodes with one, ``u_fixed`` (2n,) the
    prescribed displacement (m; the least-squares value of the node's rows, which must hold
    exactly: conflicting supports at a node raise a SceneError). ``nodes`` as in :func:`supports`.
    """
    mesh = body.mesh if nodes is None else nodes
    n = len(mesh.points)
    nodes, dirs, vals = supports(body, nodes)
    u_fixed, free, tangent = np.zeros(2 * n), np.full(n, 2), np.zeros((n, 2))
    order = np.argsort(nodes, kind="stable")
    nodes, dirs, vals = nodes[order], dirs[order], vals[order]
    starts = np.flatnonzero(np.r_[True, np.diff(nodes) != 0]) if len(nodes) else np.zeros(0, dtype=int)
    for a, b in zip(starts, np.r_[starts[1:], len(nodes)]):          # boundary nodes only
        i, D, v = int(nodes[a]), dirs[a:b], vals[a:b]
        _, sv, Vt = np.linalg.svd(D)
        rank = int((sv > 1e-9).sum())
        ud = np.linalg.lstsq(D, v, rcond=1e-9)[0]
        if np.abs(D @ ud - v).max() > 1e-9 * max(float(np.abs(v).max()), 1e-300):
            rows = ", ".join(f"u.({d[0]:.3g}, {d[1]:.3g}) = {x:.6g}" for d, x in zip(D, v))
            raise SceneError(f"{body.name}: the supports prescribe incompatible displacements at node {i} "
                             f"({mesh.points[i, 0]:.6g}, {mesh.points[i, 1]:.6g}) m: {rows}")
        u_fixed[2 * i:2 * i + 2] = ud
        free[i] = 2 - rank
        if rank == 1:
            tangent[i] = Vt[1]
    return free, tangent, u_fixed


def free_motions(body, contact: bool | Sequence[str] = True) -> list[str]:
    """The rigid motions of the body that nothing holds, as readable names (empty if none).

    A rigid motion u(x) = (tx - w (y - yc), ty + w (x - xc)) is held by the supports if some
    support row has u . direction != 0, and by a contact part (``contact=True``: the ``contact``
    part; a list: those parts; False: none) if u . nu != 0 at some of its nodes (nu the outward
    normal; contact holds on one side only). Each connected piece of the mesh is checked on its own.
    """
    out = []
    for c, free, centre, size in free_basis(body, contact):
        out += [motion_label(v, centre, size) + component_label(body, c) for v in free]
    return out


def motion_name(body, coefficients: ArrayLike) -> str:
    """A readable name of the rigid motion sum_j coefficients[j] held_modes()[j] (e.g. "translation y",
    "rotation about (0.5, 0) m"; the mesh component too when the mesh has several)."""
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
    mesh = body.mesh
    if int(mesh.components.max()) == 0:
        return ""
    inside = mesh.components == c
    area = mesh.areas[inside]
    cg = (mesh.points[mesh.triangles[inside]].mean(axis=1) * area[:, None]).sum(axis=0) / area.sum()
    return f" of mesh component {c} ({int(inside.sum())} triangles, centroid at ({cg[0]:.4g}, {cg[1]:.4g}) m)"


def held_modes(body, nodes=None) -> np.ndarray:
    """(k, 2 n_nodes): the rigid motions no support holds (the contact must), as nodal displacement fields
    (x, y interleaved per node; translations in m per unit, rotations scaled by the piece's size).
    Empty (0, 2 n_nodes) when the supports hold every rigid motion. Used by the balance check and by
    the well-posedness check of the assembled problem (:mod:`cvxcontact.fem.kernel`).
    ``nodes``: the node set (P2: :class:`~cvxcontact.geometry.quadratic.P2Nodes`); default the mesh's
    vertices."""
    points, comp = node_set(body, nodes)
    rows = []
    if body.held_by_contact:
        for c, V, centre, size in free_basis(body):
            on = (comp == c).astype(float)
            x = (points - centre) / size
            for tx, ty, w in V:
                r = np.empty(2 * len(points))
                r[0::2] = on * (tx - w * x[:, 1])
                r[1::2] = on * (ty + w * x[:, 0])
                rows.append(r)
    return np.array(rows).reshape(-1, 2 * len(points))


def node_set(body, nodes):
    """(points (n, 2) m, mesh component of each node) of the mesh's vertices or of ``nodes`` (a node
    set of the mesh with ``points`` and ``triangles`` (m, k), e.g. the P2 nodes)."""
    mesh = body.mesh
    if nodes is None:
        return mesh.points, mesh.node_components
    comp = np.empty(len(nodes.points), dtype=mesh.node_components.dtype)
    comp[np.asarray(nodes.triangles).ravel()] = np.repeat(mesh.components, np.shape(nodes.triangles)[1])
    return nodes.points, comp


def free_basis(body, contact=False):
    """Per mesh component with rigid motions the supports (and with ``contact`` the normals of the
    contact parts: True the ``contact`` part, or a list of parts) leave free: (component, V (k, 3)
    orthonormal rows of (tx, ty, w) in scaled coordinates, centre (m), size (m))."""
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
        A = np.column_stack([d[:, 0], d[:, 1], -x[:, 1] * d[:, 0] + x[:, 0] * d[:, 1]])
        _, sv, Vt = np.linalg.svd(np.vstack([A, np.zeros((3, 3))]))
        free = Vt[sv <= 1e-9 * max(sv.max(initial=0.0), 1.0)]
        if len(free):
            out.append((c, free, centre, size))
    return out


def motion_label(v, centre, size):
    """A readable name of the rigid motion (tx, ty, w) (scaled coordinates, see Body.free_motions)."""
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


def node_normals(mesh, tag):
    """(boundary_nodes(tag), 2) unit outward normals of a part at its nodes (mean of the adjacent edges)."""
    nodes = mesh.boundary_nodes([tag])
    edges, normals = mesh.boundary(tag), mesh.outward_normals(tag)
    acc = np.zeros((len(mesh.points), 2))
    np.add.at(acc, edges[:, 0], normals)
    np.add.at(acc, edges[:, 1], normals)
    n = acc[nodes]
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
