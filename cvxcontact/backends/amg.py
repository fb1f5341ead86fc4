"""The AMG route for large 3D scenes: active-set steps on the mixed system (26) whose linear systems are solved by
algebraic-multigrid-preconditioned Krylov iterations, with no factorisation at all.

In 3D a sparse factorisation costs O(N^2) flops and O(N^(4/3)) memory (nested dissection), while
smoothed-aggregation AMG with the rigid-body modes as near-null space solves elasticity in O(N) (docs/explanation/
performance.md). This route keeps the primal-dual active-set steps of the sparse route
(:mod:`cvxcontact.backends.sparse`: the semismooth Newton method for min(y, -s) = 0, the same sign tests, the same
next set y_a w_a + s_a > 0) and changes only how each step's system is solved:

* every contact row a has its own dof s(a): a dof of largest |coefficient| in that row that no other row
  touches (the nodal conditions "sigma1"/"sigma2" and rigid obstacles; not "gamma3", whose overlay rows share
  their dofs: the route then hands the problem to the sparse route). The rows of several obstacles at one node
  with one normal (a floor and a strip raised above it: G_a = c G_b, c > 0) share their group's dof
  (:func:`own_dofs` with the groups of :class:`~cvxcontact.backends.parallel.ParallelRows`): all but the tightest
  of them stay open (:func:`~cvxcontact.backends.parallel.looser_rows`, as on the sparse route: implied, their
  force 0 at an answer; Signorini rows of fixed gaps only, all this route takes), so a closed row still has its
  dof alone. A closed row is eliminated exactly,
  x_s(a) = (g_a - sum_{j != s(a)} G_aj x_j) / G_as(a), i.e. x = T_A r + x_A, and the system of the other dofs
  is K_A = T_A^T S T_A (its eliminated dofs kept as decoupled identity rows, so the size never changes),
  applied unformed (:class:`Reduced`: T_A is the identity but on the eliminated dofs, so a product costs one
  with S, S stacked without the assembled blocks' entries stored as 0.0), formed once per geometry only, for
  the hierarchy's set-up; the closed row's force follows from its own dof's equation,
  y_a = (F - S x)_s(a) / G_as(a);
* K_A r = T_A^T (F - S x_A) is solved by CG to a relative residual ``RTOL`` (1e-10, as the AMG yardstick of
  benchmarks/bench3d.py; the residual of (26) at the answer is that residual, the eliminated rows' equations
  hold to rounding), preconditioned by a smoothed-aggregation hierarchy (pyamg) built on the first system
  solved (the start's rows closed): its displacement block node-blocked (3 x 3) with each body's six
  rigid-body modes. It is built once per geometry: every later step, and every re-solve of a
  :class:`~cvxcontact.ContactSolver`, reuses it. A set differs from the one the hierarchy was built on only at
  the contact dofs (the columns of the rows, both sides: an opened row's dof is a decoupled dof of the
  hierarchy, a closed one's couples across the interface), so its V-cycle is corrected there by an exact
  solve on those dofs, the set's own block K_II factorised once per set (:meth:`KrylovContact._corrected`: a
  symmetric multiplicative Schwarz step, exact solve, V-cycle, exact solve). Measured on two elastic boxes
  (P1, 3.1e4 unknowns; answers agreeing to 8e-11 relative): 34 CG iterations in all and one set-up, against 100
  with the bare V-cycle of one hierarchy and 59 with two set-ups (a rebuild when the stale hierarchy had cost as
  much as a new one, the former rule); a PZT-5A box on aluminium (2.9e4): 57 GMRES iterations and one set-up
  against 71 and two (benchmarks/results/bench3d_scale.md at 1e5-5e5). Every solve starts from the previous
  answer, but a cold one (the first, ``warm_start=False``, or where the previous set led nowhere), which starts from
  zero: the same load solved again is answered with the same bits (warm: its Krylov solves start at the answer and
  stop there at once; cold: as a fresh solver). A set whose reduced right-hand side is zero to rounding
  (:func:`rounding_floor`) is answered by its closed rows alone, warm or cold. A set still changing is solved
  loosely: a step tightens its solve through :data:`STEP_RTOLS` to ``RTOL`` only while the signs hold, so only the
  last set is solved to ``RTOL``, and a loose solve whose set fails its signs stops as soon as two consecutive
  iterates imply the same next set (:data:`SETTLE`).
* With a piezoelectric body K_A = [[A, B], [B^T, -C]] (u, then phi; A the stiffness, C the permittivity
  matrix, both positive definite: (26) with its Gauss rows negated) is symmetric indefinite. It is solved by
  GMRES (:func:`gmres`, right-preconditioned: the stopping test is on the true residual) with the block
  upper-triangular preconditioner P = [[A, B], [0, -C]], A and C each replaced by one V-cycle of its own
  hierarchy (C: Gauss rows, scalar, the constant as near-null space). With exact blocks the eigenvalues of
  K_A P^-1 are 1 and those of the Schur complement C^-1 (C + B^T A^-1 B), in [1, 1 + rho^2] with rho the
  coupling ||C^-1/2 B^T A^-1/2|| (rho^2 = 0.83 and 0.89 measured, dense, on a PZT-5A box on aluminium of
  1.7e3 and 5e3 unknowns), so GMRES needs little more than CG on A alone: on a
  PZT-5A box on aluminium (8.7e4 unknowns, every row closed) 47 iterations against 33 for CG on A alone and
  100 for MINRES with the block-diagonal diag(V_A, V_C) (whose two-sided spectrum doubles the count);
  benchmarks/bench_piezo_amg.py.

The answer is the active set's exact complementarity (y = 0 on open rows, s = 0 on closed ones to rounding,
signs checked as in the sparse route) with (26) solved to ``RTOL``: the solution's checks (docs/checks.md) are
those of every route. A Krylov solve that does not reach ``RTOL`` makes the route hand over to the sparse route.

Needs pyamg (``pip install "cvxcontact[amg]"``); without it ``method="auto"`` never picks this route.
"""

from __future__ import annotations

import importlib.util
import logging
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .condensed import quasi_definite, quasi_definite_rhs
from .finish import Declined, Stop, active_set_steps, signs_hold
from .krylov import GMRES_RESTART, gmres, v_cycle
from .krylov import seeded as _seeded
from .parallel import ParallelRows
from .sparse import row_weights

log = logging.getLogger(__name__)

__all__ = ["KrylovContact", "available", "gmres", "own_dofs", "RTOL", "STEP_RTOLS", "AMG_INSTALL", "GMRES_RESTART",
           "LOOSE_KEEP", "Reduced", "RETRIES", "SETTLE", "loose_stages", "rounding_floor", "v_cycle"]

RTOL = 1e-10
"""Relative residual (2-norm) of the Krylov solve that gives the answer. 1e-12 was not always attainable: on two
tied elastic boxes at 1e5 unknowns the true residual of CG stalled above it (rounding), and the route handed over
to the sparse one."""

STEP_RTOLS = (1e-1, 1e-2, 1e-4, 1e-6)
"""Relative residuals of the Krylov solves that only pick the next active set, loosest first: a step solves its
system to the first and tightens to the next only while the signs hold, and to RTOL last, so that a set still
changing costs a few iterations and only the last set is solved to RTOL (the signs are checked there before the
set is accepted; the solves of one set continue from each other). Measured on two elastic boxes (P1, 1.0e5
unknowns, 1369 rows, the same 6 sets and answer): 123 CG iterations in all with one loose stage 1e-4, 68 with
(1e-1, 1e-3), 79 with (1e-2, 1e-4), 61 with (1e-1, 1e-2, 1e-4). The stage 1e-6: on two_boxes "sigma1" at 8.2e5
unknowns a set passed its signs at 1e-4 and failed them (2 rows) only at RTOL, after 43 iterations, the next set
then 27 more; with 1e-6 the failure shows after 15 and the steps take 103 Krylov iterations against 127 (11 sets,
the same final set), at 1.5e5 71 against 70 (benchmarks/results/bench3d_scale.md). Where the last set's signs
already hold at 1e-4 it saves nothing and costs a restart: tests/scenes3d.py two_boxes (2.0e4-8.1e4 unknowns)
48 -> 50, 58 -> 61, 62 -> 63 iterations, two_boxes(elastic=True) (2.0e4-9.4e4) 27 -> 28, 35 -> 37, 40 -> 42, the
same sets and answers to 2e-10 (the review of h-sigfast)."""

SETTLE = True
"""Whether a loose solve (:data:`STEP_RTOLS`) stops before its tolerance as soon as two consecutive Krylov iterates
imply the same next active set, their signs failing (:meth:`KrylovContact._system` ``verdict``; GMRES: iterates
within :data:`LOOSE_KEEP`, formed from the kept vectors with no application of the preconditioner). Such an answer
only picks the next set, as every loose one; the sets whose signs hold still tighten to RTOL, so the answer keeps
its guarantee. Measured on two_boxes "sigma1" (PZT-5A on aluminium, GMRES): 1.5e5 unknowns 6 steps and 71 Krylov
iterations without it, 8 and 67 with it; 4.1e5: 11 and 89, 10 and 84, the same final set; two aluminium boxes
(CG; tests/test_amg_route.py ``_elastic_boxes(1e9, n=16)``): 7 steps and 58 iterations, 5 and 38, where without
it the loose steps cycled (a set's 1e-2 solve pointed to a set whose 1e-4 solve pointed back) and were retried
on tight solves (benchmarks/results/bench3d_scale.md)."""

RETRIES = (1.0, 1e-4, 0.0)
"""The loosest stage of :data:`STEP_RTOLS` the active-set steps, then each of their retries, may use
(:func:`loose_stages`: the stages at or below it, read from STEP_RTOLS when the steps run, so a changed STEP_RTOLS
changes the retries too), each followed by RTOL. By default every stage, then (1e-4, 1e-6), then none: steps
that cycle on loose solves (a set's loose answer points to a set already seen) are retried from the last set on
the tighter loose stages (1e-4, 1e-6), then, if they cycle again, on tight solves alone (a retry that cycles on
those hands the problem to the sparse route). Measured on two_boxes "sigma1" at 366,062 unknowns (n = 52,
``bench3d.py --sizes 4e5``): 2391 rows closed at 1e-2 pointed to 2390, whose 1e-4 solve (2 iterations, settled)
pointed back; retried on tight solves, 2390 and then 2391 took 47 and 44 Krylov iterations, 118 in all; retried on
(1e-4, 1e-6) first, 2 + 8 + 13 + 28, 78 in all, the same final set (benchmarks/results/bench3d_scale.md)."""

AMG_INSTALL = 'pip install "cvxcontact[amg]"'


def loose_stages(ceiling: float) -> tuple:
    """The loose stages of :data:`STEP_RTOLS` (as it is now) at or below ``ceiling`` (an entry of :data:`RETRIES`),
    loosest first: by default STEP_RTOLS (ceiling 1.0), STEP_RTOLS[2:] (1e-4), () (0.0)."""
    return tuple(rtol for rtol in STEP_RTOLS if rtol <= ceiling)

LOOSE_KEEP = 16
"""Preconditioned Krylov vectors a loose GMRES solve (:data:`STEP_RTOLS`) keeps (:func:`gmres` ``keep``), so that
an answer within that many iterations costs no application of the preconditioner beyond its iterations', and its
iterates can be formed cheaply for :data:`SETTLE` (16 N doubles at most, beside the basis of as many vectors;
not kept by the answer's solve, RTOL, the longest basis: 24-43 vectors at 1.5e5-8.2e5 unknowns). Measured on
two_boxes "sigma1" (PZT-5A on aluminium) with the four loose stages: the stages 1e-1 to 1e-4 take 0-9 iterations,
the stage 1e-6 10-15 (12 and 10 at 1.5e5, 13-14 at 4.1e5, 15 at 8.2e5; benchmarks/results/bench3d_scale.md), which
with 10 kept vectors applied the preconditioner once more for their update; each saved application is one
iteration's V-cycles."""


def available() -> bool:
    """Whether pyamg can be imported (the optional extra ``amg``)."""
    return importlib.util.find_spec("pyamg") is not None


def own_dofs(G, parallel=None):
    """Each row's own dof: (dof, coefficient) arrays over the rows of ``G`` (m x n), the dof of largest
    |coefficient| among those no other row touches, or None if a row with entries has none, or if another
    entry of a row is some row's own dof (then eliminating one row would change another's). Rows without
    entries get dof -1. ``parallel``: the parallel groups of ``G``'s rows
    (:class:`~cvxcontact.backends.parallel.ParallelRows`, the rows of several obstacles at one node): the rows of
    a group whose rows are all parallel (``exact``) share the own dof of its first row, each with its own
    coefficient there (one of them at most is ever closed: the others are implied, :meth:`KrylovContact.solve`)."""
    G = sp.csr_matrix(G)
    if parallel is not None and len(parallel.rows):
        first = np.concatenate([[True], np.diff(parallel.cluster) != 0])
        lead = parallel.rows[np.maximum.accumulate(np.where(first, np.arange(len(first)), 0))]
        follow = ~first & parallel.exact[parallel.cluster]
        kept = np.ones(G.shape[0], dtype=bool)
        kept[parallel.rows[follow]] = False
        out = own_dofs(G[kept])
        if out is None:
            return None
        dof, coef = np.full(G.shape[0], -1), np.zeros(G.shape[0])
        dof[kept], coef[kept] = out
        rows, dof[parallel.rows[follow]] = parallel.rows[follow], dof[lead[follow]]
        coef[rows] = np.asarray(G[rows, dof[rows]]).ravel()
        return dof, coef
    m = G.shape[0]
    rows = np.repeat(np.arange(m), np.diff(G.indptr))
    used = np.bincount(G.indices, minlength=G.shape[1])
    score = np.where(used[G.indices] == 1, np.abs(G.data), -1.0)
    best = np.full(m, -1.0)
    np.maximum.at(best, rows, score)
    hit = np.flatnonzero((score == best[rows]) & (best[rows] > 0))
    first = np.full(m, -1)
    first[rows[hit[::-1]]] = hit[::-1]                 # the first such entry of each row
    empty = np.diff(G.indptr) == 0
    if np.any((first < 0) & ~empty):
        return None
    dof = np.where(empty, -1, G.indices[np.maximum(first, 0)])
    coef = np.where(empty, 0.0, G.data[np.maximum(first, 0)])
    own = np.zeros(G.shape[1], dtype=bool)
    own[dof[dof >= 0]] = True
    if np.any(own[G.indices] & (G.indices != dof[rows])):
        return None
    return dof, coef


ROWS = 1 << 16
"""Rows per block of :func:`congruence`."""


def congruence(Tt, S, T, D) -> sp.csr_matrix:
    """``(Tt @ S @ T + D).tocsr()`` (Tt = T^T; all CSR; D diagonal, on rows where Tt @ S @ T has no entry: the
    eliminated rows of :meth:`KrylovContact._reduced`), the same arrays, formed by blocks of :data:`ROWS` rows,
    each copied into K's arrays (reserved: pages are touched as they are filled) and freed before the next: about
    one copy of K beside S, where the whole expression held three (Tt S, its product with T, the sum with D: the
    peak of the AMG route's steps on large scenes).

    A row of a sparse product comes from the rows of its factors alone, so each block's rows are the whole
    product's; the sum with D is reproduced row by row: scipy adds two canonical CSR matrices by merging their
    sorted rows, else it gives each row's entries in the reverse of their order in the product (D's entries,
    alone in their rows, anywhere). Any other D: the whole expression."""
    n = Tt.shape[0]
    Dr = np.diff(D.indptr)
    if np.any(Dr > 1):
        return (Tt @ S @ T + D).tocsr()
    cap = 2 * S.nnz + D.nnz + n             # room for K (untouched pages hold no memory); grown if ever short
    idx = np.int32 if max(cap, S.shape[1]) < np.iinfo(np.int32).max else np.int64
    data, indices, indptr = np.empty(cap, dtype=S.dtype), np.empty(cap, dtype=idx), np.empty(n + 1, dtype=idx)
    indptr[0], pos, canonical = 0, 0, D.has_canonical_format
    for a in range(0, n, ROWS):
        p = Tt[a:a + ROWS] @ S @ T                                  # the whole product's rows a, a + 1, ...
        rows, counts = p.shape[0], np.diff(p.indptr)
        if np.any((counts > 0) & (Dr[a:a + rows] > 0)):
            return (Tt @ S @ T + D).tocsr()
        canonical = canonical and p.has_canonical_format
        ptr = pos + np.concatenate([[0], np.cumsum(counts + Dr[a:a + rows])])      # the product's entries or D's
        if ptr[-1] > len(data):
            data, indices = (np.concatenate([x, np.empty(max(len(x), int(ptr[-1])), dtype=x.dtype)])
                             for x in (data, indices))
        indptr[a + 1:a + 1 + rows] = ptr[1:]
        dst = np.repeat(ptr[:-1] - p.indptr[:-1], counts) + np.arange(p.nnz)
        data[dst], indices[dst] = p.data, p.indices
        d = np.flatnonzero(Dr[a:a + rows])
        data[ptr[d]], indices[ptr[d]] = D.data[D.indptr[a + d]], D.indices[D.indptr[a + d]]
        pos = int(ptr[-1])
    if not canonical:                       # the sum's order: each row reversed (merged, sorted, if canonical)
        for a in range(0, n, ROWS):
            lo, hi = int(indptr[a]), int(indptr[min(a + ROWS, n)])
            counts = np.diff(indptr[a:a + ROWS + 1])
            start = np.repeat(indptr[a:a + ROWS][:len(counts)], counts)
            src = start + np.repeat(indptr[a + 1:a + 1 + len(counts)], counts) - 1 - np.arange(lo, hi)
            data[lo:hi], indices[lo:hi] = data[src], indices[src]
    data.resize(pos, refcheck=False)        # trimmed in place (realloc): a view of the reserve would make scipy
    indices.resize(pos, refcheck=False)     # copy it (``prune``: a view of a much larger array), two copies of K
    return sp.csr_matrix((data, indices, indptr), shape=(n, S.shape[1]))


def stacked(blocks, zeros: bool = True) -> sp.csr_matrix:
    """S = diag(S_1, S_2, ...), each body's quasi-definite S_k = [[Kuu, Kup], [Kup^T, -Kpp]] (:func:`~cvxcontact.
    backends.condensed.quasi_definite`), in CSR: the arrays of ``sp.block_diag([quasi_definite(b)[0] ...],
    format="csr")``, formed from the CSR blocks by stacking their rows (each S_k by scipy's CSR stacking, then
    copied into S's arrays and freed) without the COO copy (int64 rows and columns) through which block_diag
    converts, whose transients were the peak of a large solve's start. Blocks not in canonical CSR (sorted,
    no duplicates; block_diag sorts and sums them): the plain expression.

    ``zeros=False``: the entries stored as 0.0 are left out (those arrays after ``eliminate_zeros``; a product
    with S is the same, bit for bit). The assembled blocks keep the nodal pattern, whose entries a structured
    mesh's elements can cancel exactly: 62 % of two_boxes' S at 8.7e4 unknowns (2.85e6 of 4.63e6 entries)."""
    pieces = [m for b in blocks for m in (b.Kuu, b.Kup, b.Kpp) if m is not None]
    if not all(sp.issparse(m) and m.format == "csr" and m.has_canonical_format for m in pieces):
        S = sp.block_diag([quasi_definite(b)[0] for b in blocks], format="csr")
        if not zeros:
            S.eliminate_zeros()
        return S
    sizes = [b.Kuu.shape[0] + (0 if b.Kpp is None else b.Kpp.shape[0]) for b in blocks]
    count = (lambda m: m.nnz) if zeros else (lambda m: int(np.count_nonzero(m.data)))
    nnz = sum(count(m) for b in blocks for m in (b.Kuu, b.Kup, b.Kup, b.Kpp) if m is not None)
    n = sum(sizes)
    idx = np.int32 if max(n, nnz) < np.iinfo(np.int32).max else np.int64
    data, indices, indptr = np.empty(nnz), np.empty(nnz, dtype=idx), np.empty(n + 1, dtype=idx)
    indptr[0], row, pos = 0, 0, 0
    for b, size in zip(blocks, sizes):
        if b.Kpp is None:
            S = b.Kuu
        else:
            S = sp.vstack([sp.hstack([b.Kuu, b.Kup], format="csr"),
                           sp.hstack([b.Kup.T.tocsr(), -b.Kpp], format="csr")], format="csr")
        Sx, Si, ptr = S.data, S.indices, S.indptr       # (S is b.Kuu itself without potentials: not changed)
        if not zeros:                       # S_k's nonzero entries, in their order; its row pointers counted anew
            keep = Sx != 0.0
            Sx, Si, ptr = Sx[keep], Si[keep], np.concatenate([[0], np.cumsum(keep)])[ptr]
        k = len(Sx)
        data[pos:pos + k] = Sx
        indices[pos:pos + k] = Si
        indices[pos:pos + k] += row
        indptr[row + 1:row + size + 1] = ptr[1:]
        indptr[row + 1:row + size + 1] += pos
        row, pos = row + size, pos + k
        del S
    return sp.csr_matrix((data, indices, indptr), shape=(n, n))


def rounding_floor(S: sp.csr_matrix, Tt: sp.csr_matrix, F: np.ndarray, x_fix: np.ndarray,
                   slaves: np.ndarray) -> float:
    """The 2-norm below which the reduced right-hand side ``b = Tt (F - S x_fix)`` is zero to rounding
    (:meth:`KrylovContact._reduced`): k eps || |F| + |S| |x_fix| ||, the first-order bound of the rounding of
    F - S x_fix (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., §3.5), k the terms summed per
    entry (the most stored entries in a row of S, one for F, those of a row of Tt). The scale is the loads and the
    closed rows' forces before Tt takes the eliminated dofs out, not b's own terms: F itself carries rounding of
    that order where its terms cancel (an imposed displacement's lifting K_fD u_D, the same at every dof of a
    uniformly pressed layer), and Tt removes the dofs where they do not (the closed rows' own dofs), so b can be
    pure rounding of F (measured: 6.9e-18 against ||F|| = 0.10, tests/reach_scenes.py's box pressed onto a strip
    and a floor, every row closed). Such a b is no different from zero by its own rounding, and its Krylov answer
    r = K^-1 b would be the rounding itself: ``_reduced`` takes b = 0, so the answer is r = 0, x = x_fix, from any
    start. The floor is a normwise bound (the answer is exact for loads perturbed by at most the floor in 2-norm),
    not a componentwise one: a genuine load whose b lies below it is dropped. On that box the floor is ~75x F's
    own rounding there, and a horizontal body force of 3e-8 N/m^3 (b 0.38 of the floor) gives u_x = 0 against
    the sparse route's 1.4e-20 m (1.4e-15 of max |u|; tests/test_parallel_obstacles.py). (A stopping test relative to ||b|| asked the Krylov solve for ``rtol`` of rounding: from zero it met it,
    from a warm start, whose own residual is of the scale of the terms, it could not, and the route re-solved cold.)
    ``x_fix`` is non-zero on the eliminated dofs ``slaves`` only and S is symmetric: |S| |x_fix| is formed from S's
    rows there."""
    terms = np.abs(F)
    if len(slaves):
        terms = terms + abs(S[slaves]).T @ np.abs(x_fix[slaves])
    k = int(np.diff(S.indptr).max(initial=0)) + 1 + int(np.diff(Tt.indptr).max(initial=0))
    return k * np.finfo(float).eps * float(np.linalg.norm(terms))


def rigid_modes(points, Tu, centre=None, size=None) -> np.ndarray:
    """The six rigid-body modes of a body with nodes ``points`` (n, 3) on its free u dofs (``Tu`` the
    prolongation, node-major dofs), about ``centre`` (default the nodes' mean) in units of ``size`` (default
    the body's extent)."""
    x = np.asarray(points, dtype=float)
    centre = x.mean(axis=0) if centre is None else np.asarray(centre, dtype=float)
    size = float(np.ptp(x, axis=0).max()) if size is None else float(size)
    x = (x - centre) / max(size, np.finfo(float).tiny)
    B = np.zeros((3 * len(x), 6))
    for i in range(3):
        B[i::3, i] = 1.0
    B[0::3, 3], B[1::3, 3] = -x[:, 1], x[:, 0]            # about z
    B[1::3, 4], B[2::3, 4] = -x[:, 2], x[:, 1]            # about x
    B[0::3, 5], B[2::3, 5] = x[:, 2], -x[:, 0]            # about y
    return np.asarray(Tu.T @ B)



class _Settled(Exception):
    """Raised from CG's callback to stop a loose solve whose verdict has settled (:data:`SETTLE`); ``r``: the
    iterate."""

    def __init__(self, r):
        super().__init__()
        self.r = r


class Reduced(spla.LinearOperator):
    """K = T^T S T + D of one active set (:meth:`KrylovContact._reduced`) as an operator, not formed: K r =
    T^T (S (T r)) + d r. T is the identity but at the eliminated dofs (one row each), so a product costs about
    one product with S, and a set costs no copy of S (formed by :func:`congruence` once per set and once more
    after the set-up, 0.58 CPU s of a 7.0 s solve of two_boxes "sigma1" at 8.7e4 unknowns; benchmarks/results/
    bench3d_scale.md). Its rows at some dofs, and its coupling
    block, are formed on their own (:meth:`rows`, :meth:`coupling`: the preconditioner's), the whole matrix by
    :meth:`tocsr` (the hierarchy's set-up, once per geometry)."""

    def __init__(self, S: sp.csr_matrix, T: sp.csr_matrix, Tt: sp.csr_matrix, d: np.ndarray):
        super().__init__(dtype=float, shape=S.shape)
        self.S, self.P, self.Pt, self.d = S, T, Tt, d      # P = T (the operator's .T is its transpose)

    def _matvec(self, r):
        r = np.ravel(r)
        return self.Pt @ (self.S @ (self.P @ r)) + self.d * r

    _rmatvec = _matvec                     # K is symmetric (S is)

    def rows(self, idx: np.ndarray) -> sp.csr_matrix:
        """K[idx, :]: T^T's rows there, times S T (a row of a product comes from its factors' rows alone)."""
        idx = np.asarray(idx)
        D = sp.csr_matrix((self.d[idx], (np.arange(len(idx)), idx)), shape=(len(idx), self.shape[1]))
        return (self.Pt[idx] @ self.S @ self.P + D).tocsr()

    def coupling(self, u_idx: np.ndarray, p_idx: np.ndarray) -> sp.csr_matrix:
        """K[u_idx][:, p_idx] for potential dofs ``p_idx`` (T is the identity on them and D has no entry
        there): T^T's rows ``u_idx`` times S's columns ``p_idx``."""
        return (self.Pt[u_idx] @ self.S[:, p_idx]).tocsr()

    def tocsr(self) -> sp.csr_matrix:
        """K formed (:func:`congruence`)."""
        n = self.shape[0]
        slaves = np.flatnonzero(self.d)
        return congruence(self.Pt, self.S, self.P, sp.csr_matrix((self.d[slaves], (slaves, slaves)), shape=(n, n)))


class KrylovContact:
    """The mixed system of a 3D problem's scaled blocks with its contact rows, for every active set (module
    docstring). Built once per geometry (the AMG hierarchy); :meth:`solve` per load case. Raises
    :class:`SolverError` if pyamg is missing or the rows have no own dofs (gamma3)."""

    def __init__(self, problem):
        try:
            import pyamg
        except ImportError as exc:
            raise SolverError(f"method 'amg' needs pyamg: {AMG_INSTALL}") from exc
        blocks = self._blocks = list(problem.blocks)
        self.S = stacked(blocks, zeros=False)                         # None between solves (:meth:`release`)
        self._diag = np.abs(self.S.diagonal())
        self.sizes = [(b.Kuu.shape[0], 0 if b.Kpp is None else b.Kpp.shape[0]) for b in blocks]
        self.n = n = self.S.shape[0]
        E = problem.E
        self.m = m = E.shape[0]
        self.G = sp.hstack([sp.hstack([E @ b.jump, sp.csr_matrix((m, npf))])
                            for b, (_, npf) in zip(blocks, self.sizes)]).tocsr()
        self.G.sum_duplicates()
        self.parallel = ParallelRows(self.G)           # the rows of several obstacles at one node: one dof each
        own = own_dofs(self.G, self.parallel)
        if own is None:
            raise SolverError("method 'amg': a contact row has no dof of its own (the overlay rows of 'gamma3' "
                              "share their dofs); use method='sparse'")
        self.dof, self.coef = own
        self.w = row_weights(blocks, E)
        u_idx, p_idx, modes, pos = [], [], [], 0
        for k, (nu, npf) in enumerate(self.sizes):
            u_idx.append(pos + np.arange(nu))
            p_idx.append(pos + nu + np.arange(npf))
            points = problem.meshes[k].points
            Tu = problem.systems[k].Tu
            if Tu.shape[0] != 3 * len(points):
                raise SolverError("method 'amg' solves 3D bodies (three displacement components per node)")
            modes.append(rigid_modes(points, Tu))         # about the body's own centre (below)
            pos += nu + npf
        self.u_idx, self.p_idx = np.concatenate(u_idx), np.concatenate(p_idx)
        # each body's modes about its own centre, in the same six columns: measured on two tied elastic boxes
        # (3.1e4 unknowns), 27 CG iterations to 1e-10 against 40 with the modes about the scene's centre
        self.modes = np.vstack(modes)
        # the contact dofs (positions in u_idx): the columns of the rows, where the sets' systems differ
        self.interface = np.searchsorted(self.u_idx, np.unique(self.G.indices))
        self.ml_u = self.ml_p = None          # built on the first system, once per geometry
        self.setups = 0                      # hierarchies built (one per geometry)
        self.setup_time = 0.0                # seconds: the set-up and the contact-dof factorisations
        self.iterations = 0                  # Krylov iterations, all solves
        self._preconditioner = None          # (closed rows, :meth:`_precondition`) of the last set
        self.x = None                        # the last answer (the next solve's starting point)
        self.declined = None                 # why the last solve returned None (a Declined), the hand-over's words
        self._reduction = None               # :meth:`_reduced` of the last set
        self._slave_rows = None              # (set, S's rows at its eliminated dofs): what y reads of S

    def _diagonal_blocks(self, K):
        """(Kuu, Kpp) of ``K`` as the set-up takes them: Kuu node-blocked (3 x 3 BSR) when every body's u dofs
        come in threes (the CSR copy freed), Kpp with the Gauss rows' sign undone (None without potentials)."""
        Kuu = K[self.u_idx][:, self.u_idx].tocsr()
        if all(nu % 3 == 0 for nu, _ in self.sizes):
            Kuu = Kuu.tobsr(blocksize=(3, 3))
        return Kuu, (-K[self.p_idx][:, self.p_idx].tocsr() if len(self.p_idx) else None)

    def _hierarchy(self, blocks, slaves):
        """The smoothed-aggregation hierarchies, built once on the first system solved (its
        :meth:`_diagonal_blocks` ``blocks``; the start's closed rows eliminated, so that the bodies it ties are
        tied in the hierarchy too; the other sets' systems differ at the contact dofs only, :meth:`_corrected`):
        its displacement block node-blocked with the bodies' rigid-body modes (zero on the eliminated dofs), its
        potential block."""
        import pyamg

        t0 = time.perf_counter()
        Kuu, Kpp = blocks
        B, self.modes = self.modes, None             # needed by the set-up alone (one per geometry): not kept
        B[np.isin(self.u_idx, slaves)] = 0.0
        blocked = Kuu.format == "bsr"
        with _seeded():
            self.ml_u = pyamg.smoothed_aggregation_solver(Kuu, B=B, symmetry="symmetric",
                                                          max_coarse=30 if blocked else 200)
            if Kpp is not None:
                self.ml_p = pyamg.smoothed_aggregation_solver(Kpp, symmetry="symmetric", max_coarse=200)
        self.setups += 1
        self.setup_time += time.perf_counter() - t0

    def _corrected(self, K):
        """The displacement block's preconditioner on the set of ``K``: the hierarchy's V-cycle V (built on
        another set's system) with an exact solve on the contact dofs I (``interface``) of this set's block
        A = K_uu before and after it, z = A_II^-1 r_I, z += V(r - A z), z_I += A_II^-1 (r - A z)_I: symmetric
        positive definite with V (CG) and exact where V is. Only A's rows at I are formed (A is symmetric:
        its columns there are their transpose) and A_II is factorised (SuperLU) once per set."""
        I = self.interface
        rows = K.rows(self.u_idx[I])[:, self.u_idx].tocsr()             # A[I, :]
        lu = spla.splu(rows[:, I].tocsc())
        cols = rows.T.tocsr()                                          # A[:, I]
        V = v_cycle(self.ml_u)

        def apply(r):
            z = np.zeros_like(r)
            z[I] = lu.solve(r[I])
            z += V @ (r - cols @ z[I])
            z[I] += lu.solve(r[I] - rows @ z)
            return z
        return apply

    def _precondition(self, K=None):
        """The preconditioner: the displacement hierarchy's V-cycle (elastic bodies, for CG), or with potentials
        the block upper-triangular P = [[Kuu, Kup], [0, -Kpp]] of ``K`` (for GMRES), its diagonal blocks
        replaced by one V-cycle each: z_phi = -V_pp(r_phi), z_u = V_uu(r_u - Kup z_phi), V_uu corrected on the
        contact dofs (:meth:`_corrected`)."""
        t0 = time.perf_counter()
        Pu = self._corrected(K)
        self.setup_time += time.perf_counter() - t0
        if self.ml_p is None:
            def apply(r):
                z = np.zeros_like(r)
                z[self.u_idx] = Pu(r[self.u_idx])
                return z
        else:
            Pp = v_cycle(self.ml_p)
            Kup = K.coupling(self.u_idx, self.p_idx)

            def apply(r):
                z = np.empty_like(r)
                z_p = -(Pp @ r[self.p_idx])
                z[self.p_idx] = z_p
                z[self.u_idx] = Pu(r[self.u_idx] - Kup @ z_p)
                return z
        return spla.LinearOperator((self.n, self.n), matvec=apply, dtype=float)

    def _reduced(self, rows, F, g):
        """(T, x_fix, K, b) of the closed rows ``rows``: x = T r + x_fix meets them, K = T^T S T + D (the
        eliminated dofs as decoupled rows with S's own diagonal D, the preconditioner's scale there; a
        :class:`Reduced` operator, not formed), b = T^T (F - S x_fix). The last set's are kept: the staged solves
        of one step (:data:`STEP_RTOLS`) share them."""
        key = (rows.tobytes(), F.tobytes(), g.tobytes())
        if self._reduction is not None and self._reduction[0] == key:
            return self._reduction[1]
        self._reduction = None                   # the last set's T freed before this one's is formed
        if self._preconditioner is not None and self._preconditioner[0] != rows.tobytes():
            self._preconditioner = None          # and its preconditioner (contact rows, their factor, Kup's copy)
        n = self.n
        slaves, piv = self.dof[rows], self.coef[rows]
        Gc = self.G[rows].tocoo()
        other = Gc.col != slaves[Gc.row]
        T = sp.identity(n, format="csr") + sp.csr_matrix(
            (np.concatenate([-np.ones(len(rows)), -Gc.data[other] / piv[Gc.row[other]]]),
             (np.concatenate([slaves, slaves[Gc.row[other]]]), np.concatenate([slaves, Gc.col[other]]))),
            shape=(n, n))
        Tt = T.T.tocsr()
        x_fix = np.zeros(n)
        x_fix[slaves] = g[rows] / piv
        S = self._stacked()
        d = np.zeros(n)
        d[slaves] = self._diag[slaves]
        K = Reduced(S, T, Tt, d)
        b = Tt @ (F - S @ x_fix)
        if np.linalg.norm(b) <= rounding_floor(S, Tt, F, x_fix, slaves):
            b = np.zeros(n)                      # zero to rounding: its answer is r = 0 (warm or cold alike)
        self._reduction = (key, (T, x_fix, K, b))
        return T, x_fix, K, b

    def _system(self, active, F, g, x_start, rtol=RTOL, verdict=None):
        """(x, y) with the rows of ``active`` closed, or None if the Krylov solve misses ``rtol``. ``verdict(x,
        y)``: the next active set an answer implies (None: its signs hold); given, a loose solve (rtol > RTOL)
        stops as soon as two consecutive iterates imply the same next set (:data:`SETTLE`), its residual then
        above rtol (an answer of such a solve only picks the next set)."""
        n = self.n
        rows = np.flatnonzero(active)
        slaves, piv = self.dof[rows], self.coef[rows]
        T, x_fix, K, b = self._reduced(rows, F, g)
        key = rows.tobytes()
        if self._slave_rows is None or self._slave_rows[0] != key:
            self._slave_rows = (key, self._stacked()[slaves])                   # S's rows y reads
        if self.ml_u is None:  # the set-up (once per geometry): K formed for its diagonal blocks, then freed
            blocks = self._diagonal_blocks(K.tocsr())
            self._hierarchy(blocks, slaves)
            del blocks
        if self._preconditioner is None or self._preconditioner[0] != key:
            self._preconditioner = (key, self._precondition(K))
        r0 = np.array(x_start) if x_start is not None else np.zeros(n)
        r0[slaves] = 0.0
        its = []
        count = lambda _x=None: its.append(1)  # noqa: E731

        def answer(r):
            x = T @ r + x_fix
            y = np.zeros(self.m)
            y[rows] = (F[slaves] - self._slave_rows[1] @ x) / piv
            return x, y

        settled, stopped = None, [False]           # stopped: the last iterate asked was settled (returned)
        if verdict is not None and rtol > RTOL and SETTLE:
            last = [None]

            def settled(r):                      # the same next set implied by this iterate and the one before
                new = verdict(*answer(r))
                stopped[0] = new is not None and last[0] is not None and np.array_equal(new, last[0])
                last[0] = new
                return stopped[0]
        nb = np.linalg.norm(b)
        if nb == 0.0:
            r = np.zeros(n)
        elif self.ml_p is None:
            def watch(xk):
                count()
                if settled is not None and settled(xk):
                    raise _Settled(np.array(xk))
            try:
                r, _ = spla.cg(K, b, x0=r0, M=self._preconditioner[1], rtol=rtol, atol=0.0, maxiter=1000,
                               callback=watch)
            except _Settled as stop:
                r = stop.r
        else:
            r = gmres(K, b, r0, self._preconditioner[1], rtol, callback=count, keep=LOOSE_KEEP if rtol > RTOL else 0,
                      settled=settled)
        self.iterations += len(its)
        if nb > 0.0 and not stopped[0] and not np.linalg.norm(b - K @ r) <= rtol * nb:
            return None
        return answer(r)

    def release(self) -> None:
        """Drops what a solve builds from the blocks and a re-solve builds again (peak memory): S, the stacked
        blocks (a copy of the scaled stiffness), and the last set's preconditioner (its contact rows, their
        factor and the coupling block Kup, a copy), so that the read-back, checks and estimate run without them.
        Kept: the hierarchies (one set-up per geometry) and the last answer (the next solve's start)."""
        self.S = None
        self._preconditioner = self._slave_rows = None

    def _stacked(self) -> sp.csr_matrix:
        """S, stacked again from the blocks if it was dropped (the same arrays)."""
        if self.S is None:
            self.S = stacked(self._blocks, zeros=False)
        return self.S

    def solve(self, F, g, active, max_iter: int = 50):
        """The Signorini problem for loads ``F`` and gaps ``g`` (scaled) from the active set ``active``, the rows a
        tighter parallel row implies under ``g`` kept open (:func:`~cvxcontact.backends.parallel.looser_rows`: they
        share their dof with it, :func:`own_dofs`);
        ``(u, phi, y, active, steps)`` as :meth:`~cvxcontact.backends.sparse.SparseContact.solve`, or None
        if the steps cycle (on loose solves, they are retried from the last set on tighter ones, :data:`RETRIES`)
        or a Krylov solve misses its tolerance."""
        F, g = np.asarray(F, dtype=float), np.asarray(g, dtype=float)
        self.declined = None
        self._stacked()                          # dropped after the last solve: the same blocks stacked again
        movable = (self.dof >= 0) & ~self.parallel.looser(g)    # an implied row (looser_rows) stays open
        last = [np.asarray(active, dtype=bool) & movable]
        count = [0]

        def step(active, stages):
            last[0] = active
            count[0] += 1

            def verdict(x, y):                   # the next set the answer (x, y) implies, None if its signs hold
                s = self.G @ x - g
                scale = np.abs(self.G) @ np.abs(x) + np.abs(g) + self.w * np.abs(y)
                scale = np.maximum(scale, 1e-14 * max(float(scale.max(initial=0.0)), np.finfo(float).tiny))
                if signs_hold(y, s, active & movable, self.w, scale):
                    return None
                return (y * self.w + s > 0) & movable

            for rtol in stages:                  # loose solves pick the next set; the answer is a tight one
                out = self._system(active & movable, F, g, self.x, rtol, verdict)
                if out is None:
                    return None
                x, y = out
                self.x = x
                new = verdict(x, y)
                if new is not None:
                    return (x, y), new
            return (x, y), None

        for ceiling in RETRIES:                  # steps that cycle on loose solves: retried on tighter ones
            stages = loose_stages(ceiling) + (RTOL,)
            out = active_set_steps(lambda a, stages=stages: step(a, stages), last[0], max_iter)
            if not isinstance(out, Declined) or out.stop is Stop.SINGULAR:
                break
        self._reduction = None
        if isinstance(out, Declined):            # the words the route's hand-over logs (a step's None: a miss)
            self.declined = out if out.stop is not Stop.SINGULAR else Declined(
                Stop.SINGULAR, "a Krylov solve missed its tolerance")
            return None
        out = (out[0], out[1], count[0])
        (x, y), active, steps = out
        u, phi, pos = [], [], 0
        for nu, npf in self.sizes:
            u.append(x[pos:pos + nu])
            phi.append(x[pos + nu:pos + nu + npf] if npf else None)
            pos += nu + npf
        return u, phi, np.where(active, y, 0.0), active, steps


def signorini(problem, cache, settings, timings):
    """The route of method "amg" for nodal Signorini rows: active-set steps with AMG-preconditioned Krylov
    solves, from the previous active set (re-solve), the rows the obstacles already close (3D) or the bonded
    system, a row a tighter parallel row implies left open (:meth:`KrylovContact.solve`); hands the problem to the
    sparse route where it cannot take it (gamma3) or a solve misses RTOL."""
    from .result import RawResult, Route
    from .signorini import cheap_start, sparse

    t0 = time.perf_counter()
    if cache.amg is None:
        try:
            cache.amg = KrylovContact(problem)
        except SolverError as exc:
            if not available():
                raise
            return _handed_over(sparse(problem, cache, settings, timings), f"the AMG route cannot take it: {exc}")
    kc = cache.amg
    setup = kc.setup_time
    rhs = np.concatenate([quasi_definite_rhs(b) for b in problem.blocks])
    free = ~problem.held_rows
    warm = settings.warm_start and cache.active is not None
    out = kc.solve(rhs, problem.g, cache.active & free) if warm else None
    if out is None:                              # a cold solve: from zero, not from the last answer, whose
        kc.x = None                              # rounding the answer would carry (a fresh solver's bits)
        start = cheap_start(problem)
        out = kc.solve(rhs, problem.g, start if start is not None else free)
        warm = False
    kc.release()
    timings["amg_setup"] = kc.setup_time - setup
    timings["active_set"] = time.perf_counter() - t0 - timings.get("amg_setup", 0.0)
    if out is None:
        log.info("the AMG route hands the problem to the sparse route: %s (after %d attempts of amg.RETRIES)",
                 kc.declined, len(RETRIES))
        return _handed_over(sparse(problem, cache, settings, timings),
                            f"the AMG route's steps stopped: {kc.declined} (after {len(RETRIES)} attempts)")
    u, phi, y, active, steps = out
    cache.active = active
    return RawResult(u=u, phi=phi, y=y, active=active, polished=True, iterations=steps, method="amg",
                     route=Route.WARM_START if warm else Route.KRYLOV_ACTIVE_SET, finish="active set",
                     factorization="pyamg")


def _handed_over(raw, reason: str):
    """``raw``, the sparse route's answer to a problem the AMG route handed over, with ``reason`` first in its
    ``handed_over`` (before the sparse route's own hand-over to the condensed route, if it made one)."""
    raw.handed_over = "; ".join(r for r in (reason, raw.handed_over) if r)
    return raw
