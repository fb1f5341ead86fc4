"""The contact line Gamma_3: traces, merged mesh, jump and multiplier operators.

Notation of docs/formulation.md §3-4. Sigma_h^l are the nodes of mesh l on Gamma_3; the
merged mesh is their union, on which X_h (continuous P1) lives. With nodal
displacements U_l of body l,

    [u_nu] = sum_l J_l U_l        at the merged nodes (J_l = nu_l . trace interpolation)
    M                             P1 mass matrix of X_h on the merged mesh (m)
    E                             evaluation at the constrained nodes (``condition``)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import SceneError

__all__ = ["Interface", "CONDITIONS", "lumped_lengths"]

CONDITIONS = ("gamma3", "sigma1", "sigma2")
"""K_h(Gamma_3): [u_nu] <= 0 at every merged node; K_h(Sigma_h^l): at the nodes of mesh l."""

_REL_TOL = 1e-9  # geometric tolerance relative to the scene size


class Trace:
    """The P1 trace of one body on Gamma_3: its nodes sorted by abscissa and its outward normal."""

    def __init__(self, body, k, tol):
        mesh = body.mesh
        edges = mesh.boundary(body.contact)
        normals = mesh.outward_normals(body.contact)
        label = f"{body.name}: contact part {body.contact!r}"
        if np.abs(normals[:, 0]).max() > _REL_TOL * 10 or np.ptp(normals[:, 1]) > 1.0:
            raise SceneError(f"{label} is not a straight segment parallel to the x1-axis")
        nodes = np.unique(edges)
        order = np.argsort(mesh.points[nodes, 0])
        self.nodes = _frozen(nodes[order])
        self.x = _frozen(mesh.points[self.nodes, 0])
        self.y = float(np.mean(mesh.points[self.nodes, 1]))
        if np.ptp(mesh.points[self.nodes, 1]) > tol:
            raise SceneError(f"{label} is not a straight segment parallel to the x1-axis "
                             f"(y varies by {np.ptp(mesh.points[self.nodes, 1]):.3g} m)")
        rank = np.empty(mesh.points.shape[0], dtype=int)
        rank[self.nodes] = np.arange(len(self.nodes))
        steps = np.sort(np.abs(np.diff(rank[edges], axis=1)).ravel())
        if len(edges) != len(self.nodes) - 1 or (steps != 1).any():
            raise SceneError(f"{label} is not one connected chain of edges (gaps or branches)")
        self.normal = float(np.sign(normals[0, 1]))
        self.k = k


class Interface:
    """Geometry and operators of Gamma_3 for a pair of bodies (docs/formulation.md §3-4)."""

    def __init__(self, bodies):
        scale = max(b.mesh.size for b in bodies)
        tol = _REL_TOL * scale
        self.traces = [Trace(b, k, tol) for k, b in enumerate(bodies)]
        t1, t2 = self.traces
        if abs(t1.y - t2.y) > tol:
            raise SceneError(f"contact parts are not collinear: {bodies[0].name} at y = {t1.y:.9g} m, "
                             f"{bodies[1].name} at y = {t2.y:.9g} m")
        if t1.normal == t2.normal:
            side = "below" if t1.normal > 0 else "above"
            raise SceneError(f"both bodies lie {side} the contact line; they must face each other")
        if abs(t1.x[0] - t2.x[0]) > tol or abs(t1.x[-1] - t2.x[-1]) > tol:
            raise SceneError(
                "contact parts do not cover the same segment (the endpoints must be shared): "
                f"{bodies[0].name} spans [{t1.x[0]:.9g}, {t1.x[-1]:.9g}] m, "
                f"{bodies[1].name} spans [{t2.x[0]:.9g}, {t2.x[-1]:.9g}] m")
        x, sigma = _merge(t1.x, t2.x, tol)
        self.x, self.sigma = _frozen(x), tuple(_frozen(s) for s in sigma)
        self.y = t1.y
        self.mass = _mass(self.x)
        self._interp = [_interpolation(self.x, t.x) for t in self.traces]

    @property
    def size(self) -> int:
        """Number of merged nodes."""
        return len(self.x)

    def jump(self, k, n_nodes) -> sp.csr_matrix:
        """(n_merged, 2 n_nodes) map from body k's nodal displacements to [u_nu] at merged nodes."""
        t = self.traces[k]
        P = (t.normal * self._interp[k]).tocoo()
        return sp.csr_matrix((P.data, (P.row, 2 * t.nodes[P.col] + 1)), shape=(self.size, 2 * n_nodes))

    def interpolation(self, k) -> sp.csr_matrix:
        """(n_merged, n_trace_k): evaluates P1 functions on body k's trace at the merged nodes."""
        return self._interp[k]

    def evaluation(self, condition) -> sp.csr_matrix:
        """E: rows select the merged nodes where non-penetration is imposed."""
        if condition not in CONDITIONS:
            raise SceneError(f"condition must be one of {CONDITIONS}, got {condition!r}")
        rows = np.arange(self.size) if condition == "gamma3" else self.sigma[int(condition[-1]) - 1]
        return sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)), rows)), shape=(len(rows), self.size))



def _frozen(a) -> np.ndarray:
    """A read-only copy: the interface's arrays are shared by every solve and must not change."""
    a = np.array(a)
    a.setflags(write=False)
    return a


def lumped_lengths(x) -> np.ndarray:
    """Length of a 1D mesh with sorted nodes ``x`` attributed to each node (m): the row sums of its
    P1 mass matrix, half of each adjacent segment."""
    h = np.diff(x)
    w = np.zeros_like(x, dtype=float)
    w[:-1] += h / 2
    w[1:] += h / 2
    return w


def _merge(x1, x2, tol):
    """Merged abscissae and, for each trace, the indices of its nodes in the merged list."""
    x2 = x2.copy()
    x2[[0, -1]] = x1[[0, -1]]  # shared endpoints, equal within tol: take body 1's
    allx = np.concatenate([x1, x2])
    order = np.argsort(allx, kind="stable")
    new = np.concatenate([[True], np.diff(allx[order]) > 1e-3 * tol])
    index = np.empty(len(allx), dtype=int)
    index[order] = np.cumsum(new) - 1
    return allx[order][new], (index[: len(x1)], index[len(x1):])


def _interpolation(x, xt):
    """(len(x), len(xt)) matrix evaluating the P1 function with nodes xt at the points x."""
    seg = np.clip(np.searchsorted(xt, x, side="right") - 1, 0, len(xt) - 2)
    t = np.clip((x - xt[seg]) / (xt[seg + 1] - xt[seg]), 0.0, 1.0)
    rows = np.repeat(np.arange(len(x)), 2)
    cols = np.column_stack([seg, seg + 1]).ravel()
    vals = np.column_stack([1 - t, t]).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(x), len(xt)))


def _mass(x):
    """P1 mass matrix on the 1D mesh with nodes x (m)."""
    h = np.diff(x)
    main = np.zeros(len(x))
    main[:-1] += h / 3
    main[1:] += h / 3
    return sp.diags([h / 6, main, h / 6], [-1, 0, 1], format="csr")
