"""Parallel contact rows: the rows of several obstacles at one node with the same normal (coincident obstacles, a
floor and a strip raised above part of it) are one row of G repeated, each with its own gap (docs/architecture.md,
"The sparse route"). Closed together they make a mixed system (26) singular: two equal rows with equal gaps leave
the split of the node's force between them free, two of different gaps cannot both close. Each route reads them
here: the sparse and AMG routes and the exact LCP finish on the interface of the condensed and full routes
(:meth:`~cvxcontact.backends.condensed.Compliance.looser`) leave the looser rows open (:func:`looser_rows`, the groups
once per geometry: :class:`ParallelRows`), the exact solve of (26) on an active set
closes each repeated row once (:func:`repeated_rows`, :func:`~cvxcontact.backends.full.mixed_kkt`)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import locked

__all__ = ["PARALLEL_TOL", "ParallelRows", "closed_once", "looser_rows", "normalised_gaps", "repeated_rows"]

PARALLEL_TOL = 1e-12
"""Two contact rows are parallel (:func:`looser_rows`) where their unit rows (each row of G over its 2-norm) agree to
this in every entry: the rows of two obstacles at one node with the same normal are equal to the last bit. Two
parallel rows repeat each other (:func:`repeated_rows`) where their normalised gaps also agree to this, relative to
the largest |g_a| / |G_a|."""


def _row_norms(G) -> np.ndarray:
    """The 2-norm of each row of the sparse G."""
    G = sp.csr_matrix(G)
    return np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())


def normalised_gaps(G, g) -> np.ndarray:
    """g_a / |G_a| per contact row (|G_a| the row's 2-norm; g_a itself for a row of no entry): the distance, in the
    unknowns' units, a row's gap stands for, which orders parallel rows (tightest first)."""
    norms = _row_norms(G)
    return np.asarray(g, dtype=float) / np.where(norms > 0, norms, 1.0)


def looser_rows(G, g, tol: float = PARALLEL_TOL) -> np.ndarray:
    """The contact rows another row implies (bool per row): a row a with G_a = c G_b, c > 0 (to ``tol``,
    :data:`PARALLEL_TOL`), of a normalised gap g_a / |G_a| >= g_b / |G_b| (the tightest of each parallel group is
    kept; of equal gaps, the first). G_b x <= g_b gives G_a x <= g_a: the row is never needed, its force is 0 at an
    answer, and closed beside the kept one it makes K(A) of the sparse route singular (two equal rows, gaps
    different). Where: the rows of several obstacles at one node, e.g. a floor and a strip raised 3e-6 m above it
    over part of it (3D P2 block: every step from the bonded or the coarse start met a singular system; only the
    tighter of two such rows can close unless the gaps coincide). Rows of no entry (held rows) are not matched.
    For Signorini rows of fixed gaps only, as the sparse and AMG routes (its callers) take: not beside a compliance
    law (a looser row penetrated carries a force too), friction (a row's force bounds its friction) or a
    force-controlled obstacle (gaps g - R tau: their order may change with tau), which the "sparse" and "amg"
    backends do not accept (:mod:`cvxcontact.backends`). The groups once, the order per gaps:
    :class:`ParallelRows` (``ParallelRows(G, tol).looser(g)``, this function)."""
    return ParallelRows(G, tol).looser(g)


class ParallelRows:
    """The parallel groups of the rows of ``G`` (m x n), found once per geometry (the rows do not change with the
    loads, the gaps do): :meth:`looser` orders each group by the gaps of a load case (:func:`looser_rows`).

    Vectorised: the rows with entries are grouped by their pattern (per row length, a lexicographic sort of their
    columns), then each group is split coordinate by coordinate where the sorted unit rows (G_a / |G_a|) differ
    by more than ``tol``: rows in different clusters are never within ``tol`` of each other, so the greedy order of
    :func:`looser_rows` (tightest first; a row not yet implied implies every later one within ``tol``) acts on
    each cluster alone. A cluster of diameter <= ``tol`` in every coordinate (:attr:`exact`: the rows of several
    obstacles at one node, equal to the last bit) keeps its tightest row and drops the others; any other cluster
    (rows chained within ``tol`` but not all within it of each other) is ordered row by row as the greedy
    definition reads. The diameter and the splits are exact in floating point (fl(a - b) is monotone in a and b),
    so :meth:`looser` is the definition's answer on every input.

    Attributes
    ----------
    rows : (k,) int ndarray, the rows in clusters of two or more, by cluster then row index
    cluster : (k,) int ndarray, each one's cluster (0, 1, ...; sorted)
    exact : (c,) bool ndarray, per cluster, whether its rows are all within ``tol`` of each other
    """

    def __init__(self, G, tol: float = PARALLEL_TOL):
        G = sp.csr_matrix(G, copy=True)
        G.eliminate_zeros()
        G.sort_indices()
        self.m = G.shape[0]
        norms = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())
        self._scale = np.where(norms > 0, norms, 1.0)                   # the gaps' normalisation
        lengths = np.diff(G.indptr)
        rows, cluster, units, count = [], [], {}, 0
        for L in np.unique(lengths[norms > 0]):       # rows on the same unknowns (the only candidates), per length
            R = np.flatnonzero((lengths == L) & (norms > 0))
            at = G.indptr[R][:, None] + np.arange(L)
            P, U = G.indices[at], G.data[at] / norms[R][:, None]
            order = np.lexsort(P.T[::-1])                          # by pattern, then row index (a stable sort)
            R, P, U = R[order], P[order], U[order]
            new = np.concatenate([[True], (P[1:] != P[:-1]).any(axis=1)])
            R, U, cid = _shared(R, U, np.cumsum(new))
            for c in range(L):                        # split where the sorted c-th coordinate jumps by > tol
                if len(R) == 0:
                    break
                order = np.lexsort((R, U[:, c], cid))
                R, U, cid = R[order], U[order], cid[order]
                jump = np.diff(U[:, c]) > tol
                R, U, cid = _shared(R, U, np.cumsum(np.concatenate([[True], (np.diff(cid) != 0) | jump])))
            if len(R) == 0:
                continue
            order = np.lexsort((R, cid))                             # by cluster, then row index
            R, U, cid = R[order], U[order], cid[order]
            first = np.flatnonzero(np.concatenate([[True], np.diff(cid) != 0]))
            diameter = (np.maximum.reduceat(U, first, axis=0) - np.minimum.reduceat(U, first, axis=0)).max(axis=1)
            for k in np.flatnonzero(~(diameter <= tol)):             # (NaN: not within tol, as the definition)
                units[count + k] = U[first[k]:first[k + 1] if k + 1 < len(first) else len(R)]
            rows.append(R)
            cluster.append(count + np.repeat(np.arange(len(first)), np.diff(np.append(first, len(R)))))
            count += len(first)
        exact = np.ones(count, dtype=bool)
        exact[list(units)] = False
        self.rows = locked(np.concatenate(rows) if rows else np.zeros(0, dtype=int))      # (kept for the geometry:
        self.cluster = locked(np.concatenate(cluster) if cluster else np.zeros(0, dtype=int))       # read-only)
        self.exact = locked(exact)
        self._units, self._tol = units, tol

    def looser(self, g) -> np.ndarray:
        """(m,) bool: the rows a tighter parallel row implies under gaps ``g`` (:func:`looser_rows`)."""
        looser = np.zeros(self.m, dtype=bool)
        if len(self.rows) == 0:
            return looser
        gap = (np.asarray(g, dtype=float) / self._scale)[self.rows]
        order = np.lexsort((self.rows, gap, self.cluster))         # tightest first, ties by index
        rows, cluster = self.rows[order], self.cluster[order]
        lead = np.concatenate([[True], np.diff(cluster) != 0])
        looser[rows[~lead & self.exact[cluster]]] = True
        for U, rows in self._chained(gap):                        # chained clusters: the greedy definition
            out = np.zeros(len(rows), dtype=bool)
            for i in range(len(rows)):
                if not out[i]:
                    out[i + 1:] |= np.abs(U[i + 1:] - U[i]).max(axis=1) <= self._tol
            looser[rows] = out
        return looser

    def _chained(self, gap):
        """Per chained cluster (not :attr:`exact`): its unit rows and rows, tightest first by ``gap`` (per position
        of :attr:`rows`; ties by index), for the greedy definitions row by row."""
        for k, U in self._units.items():
            mine = np.arange(*np.searchsorted(self.cluster, [k, k + 1]))     # (rows by index, U in that order;
            # cluster sorted: a search, not a scan of every row per cluster, quadratic where every node chains)
            seq = mine[np.argsort(gap[mine], kind="stable")]
            yield U[seq - mine[0]], self.rows[seq]

    def repeated(self, g) -> np.ndarray:
        """(m,) int: per row, the first row of its class of repeated rows under gaps ``g`` (:func:`repeated_rows`).

        Greedy, tightest first (ties by index): a row in no class yet leads one, with every later row of its
        cluster in none whose unit row is within ``tol`` of the leader's and whose normalised gap is within ``tol``
        x the largest finite |g_a| / |G_a| of the leader's; the class's label its lowest row index. Every row of a
        class is within the tolerance of its leader, the tightest (:func:`closed_once` closes the leader). In a
        cluster of :attr:`exact` every two unit rows are within ``tol``: one step takes each such cluster's next
        class at once (the steps as many as the most classes of one cluster); chained clusters row by row."""
        first = np.arange(self.m)
        gap = np.asarray(g, dtype=float) / self._scale
        finite = np.abs(gap[np.isfinite(gap)])             # (an infinite gap repeats nothing: inf - inf is nan)
        scale = self._tol * max(float(finite.max(initial=0.0)), np.finfo(float).tiny)
        if len(self.rows) == 0:
            return first
        order = np.lexsort((self.rows, gap[self.rows], self.cluster))      # tightest first, ties by index
        rows, gs = self.rows[order], gap[self.rows[order]]
        cluster = self.cluster[order]
        lo = np.flatnonzero(np.concatenate([[True], np.diff(cluster) != 0]))      # each cluster's span
        hi = np.append(lo[1:], len(rows))
        lead, end = lo[self.exact[cluster[lo]]], hi[self.exact[cluster[lo]]]
        done = np.zeros(len(rows), dtype=bool)            # (positions in that order) in a class already
        while len(lead):                                  # each exact cluster's next class, all at once
            n = end - lead
            starts = np.cumsum(n) - n
            which = np.repeat(np.arange(len(lead)), n)
            offset = np.arange(n.sum()) - starts[which]
            pos = lead[which] + offset
            with np.errstate(invalid="ignore"):           # inf - inf (rows no obstacle reaches): NaN, joins none
                near = np.abs(gs[pos] - gs[lead[which]]) <= scale
            joins = ~done[pos] & (near | (offset == 0))
            label = np.full(len(lead), self.m)
            np.minimum.at(label, which[joins], rows[pos[joins]])
            first[rows[pos[joins]]] = label[which[joins]]
            done[pos[joins]] = True
            step = np.minimum.reduceat(np.where(done[pos], n[which], offset), starts)   # the next leader
            lead = lead + step
            lead, end = lead[lead < end], end[lead < end]
        for U, crow in self._chained(gap[self.rows]):     # chained clusters: the greedy definition
            out = np.zeros(len(crow), dtype=bool)
            for i in range(len(crow)):
                if out[i]:
                    continue
                same = ~out[i + 1:] & (np.abs(U[i + 1:] - U[i]).max(axis=1) <= self._tol) & (
                    np.abs(gap[crow[i + 1:]] - gap[crow[i]]) <= scale)
                cls = np.concatenate([[crow[i]], crow[i + 1:][same]])
                first[cls] = cls.min()
                out[i:][np.concatenate([[True], same])] = True
        return first


def _shared(R, U, cid):
    """The rows of ``R`` (their unit rows ``U``, cluster ids ``cid``, sorted) whose cluster has two or more."""
    size = np.bincount(cid)
    keep = size[cid] > 1
    return R[keep], U[keep], cid[keep]


def repeated_rows(G, g, tol: float = PARALLEL_TOL) -> np.ndarray:
    """Per contact row, the first row (lowest index) it repeats: G_a = c G_b, c > 0, and g_a / |G_a| = g_b / |G_b|
    (both to ``tol``, :data:`PARALLEL_TOL`; the gaps relative to the largest finite normalised gap), or the row itself
    (int per row). Rows of one class are one equation: closing them together is closing one, the force on them
    is determined only in its sum (coincident obstacles: two planes of one position and normal, the same gaps).
    Unlike :func:`looser_rows` this reads no order of gaps, so it holds for any law closing the rows as they are
    (the rows of a force-controlled obstacle included, their translation columns part of G). The groups:
    :class:`ParallelRows` (``ParallelRows(G, tol).repeated(g)``, this function)."""
    return ParallelRows(G, tol).repeated(g)


def closed_once(first: np.ndarray, active: np.ndarray, gap: np.ndarray | None = None) -> np.ndarray:
    """The rows of ``active`` (bool per row) closed in a solve: of each class of repeated rows (``first``, from
    :func:`repeated_rows`) one active row, the tightest (``gap``: :func:`normalised_gaps`; ties, or without it,
    the first); the others are the same equation (their force 0, their slack that of the row kept). The
    tightest, because a class's gaps agree only to the tolerance of :func:`repeated_rows` (relative to the
    largest gap): closing a looser row would leave a tighter one penetrated by their difference, while a looser
    row left open beside the tighter one closed is feasible (its slack that difference, <= 0)."""
    keep = np.asarray(active, dtype=bool).copy()
    at = np.flatnonzero(keep & (np.bincount(first, minlength=len(first))[first] > 1))   # active, in a class
    if len(at):
        if gap is not None:                                     # tightest first within a class, ties by index
            at = at[np.lexsort((at, np.asarray(gap, dtype=float)[at]))]
        _, kept = np.unique(first[at], return_index=True)      # each class's first row in that order
        keep[at] = False
        keep[at[kept]] = True
    return keep
