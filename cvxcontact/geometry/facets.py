"""The facet table of a simplex mesh: every edge of a triangle mesh, every face of a tetrahedron mesh, once,
with the one or two cells that share it (the error estimate's jumps, the equilibrated bound's fluxes)."""

from __future__ import annotations

import numpy as np

__all__ = ["facet_keys", "facets", "paired"]


def facet_keys(sorted_vertices: np.ndarray, n: int) -> np.ndarray:
    """One int64 key per facet of a mesh of ``n`` nodes: its vertex indices (k, d), sorted ascending along each
    row, read as the digits of a base-n number (n^d < 2^63)."""
    f = np.asarray(sorted_vertices).astype(np.int64)
    key = f[:, 0]
    for j in range(1, f.shape[1]):
        key = key * n + f[:, j]
    return key


def facets(cells: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every facet of the simplices ``cells`` (m, d + 1) over ``n`` nodes once: (owners (k, 2), the cells
    sharing it, -1 for a boundary facet's missing second; local (k, 2), the index in each owner of the vertex
    opposite the facet, -1 likewise; vertices (k, d), sorted ascending; keys (k,), :func:`facet_keys` of
    them, ascending)."""
    m, k = cells.shape
    opposite = np.array([[j for j in range(k) if j != i] for i in range(k)])
    vertices = np.sort(cells[:, opposite], axis=2).reshape(-1, k - 1)            # row k t + i: opposite vertex i
    first, second, keys = paired(facet_keys(vertices, n))
    owners = np.column_stack([first // k, np.where(second >= 0, second // k, -1)])
    local = np.column_stack([first % k, np.where(second >= 0, second % k, -1)])
    return owners, local, vertices[first], keys


def paired(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The facets of a conforming mesh listed once per cell side (``keys`` (r,): one key per listed side, equal
    for the two sides of an interior facet) taken once each: (first (k,), the row of each facet's first listing;
    second (k,), the row of its second, -1 for a boundary facet; the facets' keys (k,), ascending)."""
    order = np.argsort(keys, kind="stable")
    ks = keys[order]
    start = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    count = np.diff(np.r_[start, len(ks)])
    second = np.where(count == 2, order[np.minimum(start + 1, len(order) - 1)], -1)
    return order[start], second, ks[start]
