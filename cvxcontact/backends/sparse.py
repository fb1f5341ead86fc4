"""The sparse route for long contact interfaces: active-set steps on the sparse mixed system (26).

The condensed backend reduces each body to dense matrices on its contact dofs (Sigma_l, B_l, W:
m x m, memory m^2, time m^3). For a long interface (a thin layer: thousands of merged contact nodes)
that is what costs. This backend never forms them. It solves the Signorini problem (26)-(27) on the
sparse mixed system of every body at once (scaled units, x = [u_1; phi_1; u_2; ...] the free dofs,
S = diag_l [[Kuu, Kup], [Kup^T, -Kpp]], F = [f_l; -q_l], G = E [u_nu] the m contact rows):

    K(A) = [[S,     G^T P],       K(A) [x; y] = [F; P g]      P = diag(1 on the active rows A)
            [P G, -(I - P)]]

an active row is closed (G_a x = g_a, its force y_a free), an open row has y_a = 0 and no coupling.
Every contact row is present whatever A (an open row's couplings are stored as explicit zeros), so the
sparsity pattern of K(A) is fixed: the fill-reducing ordering is computed once per geometry and reused
by every factorisation (:func:`factorize` with SciPy's SuperLU; with ``factorization="pardiso"``,
:class:`~cvxcontact.backends.factor.PardisoSymmetric`: one analysis, then a numeric factorisation per
base, measured 4x faster on thin_layer(3000): 2.9 s against 12.2 s for 16 factorisations; on a slender interface
analysed in minimum degree order, :data:`SLENDER_FILL`, :meth:`SparseContact._analysed`).

Primal-dual active-set steps (the semismooth Newton method for min(y, -s) = 0, s = G x - g) from A_0:
A_{k+1} = {a : y_a w_a + s_a > 0}, w_a = sum_l sum_j (E J_l)_aj^2 / (K_uu,l)_jj the row's diagonal
compliance (a force turned into a displacement of that node, as in the checks, docs/checks.md), until
A_{k+1} = A_k with y >= 0 on A and s <= 0 off A, each to ``SIGN_TOL`` of the row's own scale. A_0 is
the bonded system (every row closed: [u_nu] = g at every merged node) for a first solve (in 3D the rows the
obstacles already close, :func:`~cvxcontact.backends.signorini.cheap_start`; above :data:`COARSE_ROWS` free rows
the rows near the closed ones of a coarse subproblem solved on its dense Schur complement,
:meth:`SparseContact.coarse_start`), the previous active set for a re-solve of a :class:`~cvxcontact.ContactSolver`.

Most steps change only a few rows near the edges of the contact zone, so K(A) is not refactorised at
each step: with the factor of a base K(A_b), K(A) z = b is solved exactly by the capacitance (bordered)
form on the c rows where A and A_b differ: a row dropped from A_b gets a free gap correction t_a with
the condition y_a = 0, a row added gets a force s_a on x with the condition G_a x = b_a; the c x c
dense system for (t, s) needs one base solve per changed row (cached across steps, stored as two
m-vectors each: O(m c) memory). When c exceeds ``cap`` (default: what a refactorisation costs in
column solves, measured, at most 500) K(A) is refactorised with the stored ordering and becomes the base. Every
answer is checked against K(A) itself (componentwise backward error <= 1e-12, after up to two
refinement steps) and refactorised if the check fails, with PARDISO's analysis redone on K(A) itself if it fails
again (its scaling and matching are taken from the first matrix analysed, which may not suit a later one: measured,
thin_layer(1000) from the coarse start, 124 perturbed pivots and a failed check on its second set; analysed
afresh, the steps go on to the answer). Steps that stop (a cycle, a system failing its check) on the
state an earlier solve left, the base and PARDISO's analysis, are retried from a fresh factorisation and analysis:
the path of a new object (:meth:`SparseContact._attempts`). The answer is taken from a factor of K(A) for the
final set A itself (under the timed cap: which base the steps end on follows the clock); where the steps on the
columns (below) end on a set whose signs hold, that set is factorised as its own system at once
(:meth:`SparseContact._last`), not solved through the base first.

Near the answer the steps flip a few rows at a time (on a long interface between non-matching meshes, rows whose
force and gap are both tiny beside their scales: thin_layer(3000) took 7 steps of 1-19 rows after its last
refactorisation). While a set differs from the base in at most ``cap`` rows, the forces and gaps of EVERY row are
the base solution's plus the cached capacitance columns (m-vectors) times the c capacitance unknowns, so such steps
are taken on the columns alone, O(m c) each, with no solve of the full size (:meth:`SparseContact._settle`); the
set where they stop is then solved and checked exactly as above, and the steps go on from it if a sign fails.
Measured (one thread): thin_layer(3000) 16 systems against 22, thin_layer(200) 8 against 14, the factorisations
unchanged.

Memory: the sparse factor of K (what one bonded solve needs) + O(m c) for the capacitance columns +
a c x c dense matrix (c <= cap <= 500): no m x m matrix.

Accepts: the quadratic energy of linear (piezo)elasticity with linear contact rows E [u_nu] <= E g
(P1, or P2 with a nodal condition), the Signorini law on every row, every body held by its own
supports, no rigid obstacle under force control, no user terms. Normal compliance, the P2 conic
condition, bodies held by the contact only and force control are left to "condensed"/"full"
(:mod:`cvxcontact.backends`).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .condensed import quasi_definite
from .coarse import COARSE_HOPS, NEAR_DEPENDENT, bordered_upper, coarse_rows, row_graph, spread  # noqa: F401
from .elimination import factorize, ordering
from .pattern import MixedPattern, block_diagonal
from . import SPARSE_ROWS  # noqa: F401  (the auto threshold, defined with the registry)
from ..errors import SolverError
from .finish import Declined, active_set_steps, lawson_hanson, row_compliance, row_reach, signs_hold, solve_lcp

__all__ = ["SparseContact", "factorize", "SPARSE_ROWS", "SOFT", "COARSE_ROWS", "SLENDER_FILL", "SLENDER_FACE"]

COARSE_ROWS = 3000
"""The free contact rows from which the route's first solve starts from the coarse rows' answer
(:meth:`SparseContact.coarse_start`) instead of the bonded system. Measured on thin_layer (one thread, PARDISO,
numeric factorisations and CPU from the bonded start / from this start): n = 3000 (5,101 rows) 15 / 4 and 2.7 /
1.65 s, n = 5000 (8,501 rows) 16-17 / 5 and 4.3-4.8 / 3.2-3.5 s, but n = 1000 (1,701 rows) 9 / 6-7 and 0.57-0.59 /
0.58-0.68 s (the coarse problem's partial factorisation costs about one bonded solve: worth it where the bonded
start takes many steps; benchmarks/results/bench_longif.md)."""

SLENDER_FACE = 2.0 / 3.0
"""A slender interface, for the route's PARDISO order (:data:`SLENDER_FILL`): more contact rows m than n ** this (n
the free unknowns), i.e. more rows than on a face of a cube of n unknowns: bodies thinner than a cube. Measured
m / n^(2/3): thin_layer(1000) 1.58, (3000) 2.27 (and 0.92, 1.05, 1.16 at n = 200, 300, 400); two 3D boxes
(tests/scenes3d.two_boxes, n = 12, 18, 24) 0.54-0.55; two 2D blocks 0.15-0.26 (demo.two_blocks(64), (300)). The
registry's SPARSE_SLENDER (m > 3 sqrt(n)) does not separate them: the 3D boxes at n = 24 have 3.2 sqrt(n)."""

SLENDER_FILL = 5.0
"""On a slender interface (:data:`SLENDER_FACE`, :meth:`SparseContact._analysed`) PARDISO's analysis is made in
minimum degree order (AMD, iparm[1] = 0) rather than nested dissection (METIS, 2), and kept where its factor holds at
most this many times the entries of K's upper triangle (benchmarks/longif_orderings.py; one thread; analysis /
numeric factorisation CPU s, factor Mflop, fill, METIS against AMD): thin_layer(3000) 0.41 / 0.154 / 292 / 4.6
against 0.23 / 0.129 / 161 / 3.8, thin_layer(1000) 0.135 / 0.049 / 90 / 4.5 against 0.068 / 0.040 / 52 / 3.8,
two_blocks(64) the same fill (4.7) and flops, two_blocks(300) 4,981 against 6,496 Mflop (fill 7.5 against 8.5);
3D boxes (tests/scenes3d.two_boxes, n = 12, 18, 24): AMD fills 9.0, 19.5, 33.6 against 7.2, 13.2, 17.4 and takes
1.8-4.2 times the flops. A slender layer's graph is nearly one-dimensional, where minimum degree is near the best
order; a bulky (3D) one is not. Where minimum degree is tried and not kept, its analysis is lost (about one nested
dissection analysis in 3D: 0.50 s on the boxes at n = 24)."""

CAP_MIN, CAP_MAX = 16, 500
"""The bounds of the default ``cap`` of :class:`SparseContact` (:meth:`SparseContact._over_cap`): changes of at
most CAP_MIN rows are always solved by the capacitance form, changes of more than CAP_MAX rows always refactorised."""

BLOCK_GAIN = 3.0
"""How many times less a capacitance column costs, solved in a block of :data:`CAP_MIN` or more, than a single
solve: the default cap's first guess, before a block has been timed (:meth:`SparseContact._over_cap`). Measured,
one thread: thin_layer(3000) 0.0045 s against 0.016 s (3.5x) with PARDISO; two elastic boxes of 1.1e4 and 2.0e4
unknowns 2.5-6x."""

SOFT = 1e-6
"""The relative compliance of the regularised stage of the sparse route for dependent rows
(:func:`~cvxcontact.backends.signorini._sparse_dependent`): each closed row a reads G_a x - SOFT w_a y_a = g_a,
w_a its own compliance (:func:`row_weights`). Small enough that the exact finish from its forces takes one step
(measured, two elastic boxes 7,578 unknowns, 1,009 rows: Lawson-Hanson steps 94, 5, 1, 1 from 1e-2, 1e-4, 1e-6,
1e-8), large enough that the quasi-definite pivots of dependent rows stay far above rounding."""

SOFT_PATH = (1e-2, 1e-4, SOFT)
"""The continuation of the regularised stage on a first solve: each compliance's Newton steps start from the
previous one's penetrating rows (from the bonded start at SOFT directly, the damped steps were many: 52 and 66
systems on two elastic boxes of 3,138 and 7,578 unknowns)."""


def row_weights(blocks, E) -> np.ndarray:
    """(m,) the Jacobi-scaled squared norm of every contact row, sum over bodies of sum_j R_aj^2 / Kuu_jj with
    R = E J the rows on the body's free dofs (dimensionless), floored at 1e-14 of the largest: the weights with
    which the active-set steps compare rows (shared by the sparse and the AMG routes)."""
    w = row_compliance(blocks, E)
    return np.maximum(w, 1e-14 * max(float(w.max(initial=0.0)), np.finfo(float).tiny))


class SparseContact:
    """The sparse mixed system of scaled blocks (:class:`~cvxcontact.discrete.Block`) with contact rows
    ``E``, for every active set (module docstring). Built once per geometry; :meth:`solve` per load case.

    ``cap``: the largest number of rows changed from the base active set solved by the capacitance form
    before refactorising, and taken by the steps on the columns alone (:meth:`_settle`) (None: the measured cost
    of one numeric factorisation in column solves, the columns solved in blocks as the capacitance form solves
    them; at least 16, at most 500; :meth:`_over_cap`: ``cap`` stays None until the capacitance form has solved a
    block of 16 columns or more, which sets it). The count of systems :meth:`solve` reports follows it (its answer
    does not).
    """

    def __init__(self, blocks, E, cap: int | None = None, factorization: str = "superlu", soft=None):
        from .factor import resolve

        self.factorization = resolve(factorization)      # "superlu" or "pardiso" (analysis once, then numeric)
        self._pardiso = None
        parts = [quasi_definite(b) for b in blocks]
        A = block_diagonal([S for S, _ in parts])
        self.sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(blocks, parts)]
        self.n = A.shape[0]
        self.m = m = E.shape[0]
        G = sp.hstack([sp.hstack([E @ b.jump, sp.csr_matrix((m, n_phi))]) for b, (_, n_phi)
                       in zip(blocks, self.sizes)]).tocsr()
        G.sum_duplicates()
        self.G = G
        self.A = A.tocsr()
        self.reach = row_reach(self.A, G)      # |G| + |G| diag(A)^-1 |A|: a row's scale counts its neighbours
        self.w = row_weights(blocks, E)
        # one pattern for every active set: kind 0 = S, 1 = a coupling of contact row `rid`, 2 = its diagonal
        self.pattern = MixedPattern(A, G)
        self.F = np.concatenate([F for _, F in parts])
        self.soft = np.zeros(m) if soft is None else np.broadcast_to(np.asarray(soft, dtype=float), (m,)).copy()
        self.perm = None
        self.cap = cap
        self._timed = cap is None         # the default cap, timed (:meth:`_over_cap`; the answer: :meth:`solve`)
        self._predicted = None            # the set the steps on the columns end on, signs holding (:meth:`_last`)
        self.base = None                  # (active set, factor) of the current base
        self._columns = {}                # row -> (G zx, zy) of its capacitance column on the base
        self._base_state = None           # (G x, y) of the base set's own solution, for the loads F, g
        self.factorizations = 0
        self.factor_time = 0.0            # seconds spent in ordering() and factorize()
        self.column_solves = 0
        self.attempts = 0                 # the attempts (:meth:`_attempts`) the last :meth:`solve` made
        self._bonded_analysis = False     # PARDISO's analysis on the bonded values (:meth:`_refactor`)
        self._t_fact = None               # seconds of a numeric factorisation (the default cap, :meth:`_over_cap`)
        self._t_solve = None              # seconds of the first single solve on a base (the same)

    def matrix(self, active, absolute: bool = False) -> sp.csc_matrix:
        """K(A) in CSC, the fixed pattern with the values of the active set ``active`` (bool, m); ``absolute``: |K(A)|
        (entrywise), a new one (:meth:`~cvxcontact.backends.pattern.MixedPattern.matrix`)."""
        return self.pattern.matrix(np.asarray(active, dtype=bool), self.soft, absolute)

    def _refactor(self, active, K=None, own_analysis: bool = False):
        """Factorise K(``active``) (``K`` if given) and make it the base; False if singular (SuperLU). PARDISO's
        analysis is made on the first matrix a new handle factorises, and its scaling and weighted matching kept
        for every later factorisation; after :meth:`coarse_start` it is made on the values of the bonded system
        instead (every row some unknown moves closed; the analysis alone,
        :meth:`~cvxcontact.backends.factor.PardisoSymmetric.analyse`, no numeric factorisation of those values:
        0.075 s less on thin_layer(3000)), whatever ``active`` is:
        the matching then pairs every contact row with a dof, so a row closed later finds its pivot (measured,
        thin_layer(3000) from the coarse start: analysed on the start's own values 69-72 perturbed pivots in every
        later factorisation, each solve 2.4 times slower and followed by a refinement; on the bonded values none,
        1.65 s against 2.14 s). ``own_analysis``: analyse on K itself (the last resort of :meth:`_system`)."""
        t0 = time.perf_counter()
        K = self.matrix(active) if K is None else K
        if self.factorization == "pardiso":
            t1 = time.perf_counter()
            try:
                if self._pardiso is None:
                    self._pardiso = self._analysed(K, active, own_analysis)
                    t1 = time.perf_counter()      # (a numeric factorisation's time: without the analysis)
                factor = self._pardiso.factor(K)
            except SolverError:
                self._pardiso, self.factorization = None, "superlu"     # refused: SuperLU from here on
                return self._refactor(active, K)
        else:
            if self.perm is None:
                self.perm = ordering(K, self.n + np.arange(self.m))
            t1 = time.perf_counter()
            try:
                factor = factorize(K, self.perm)
            except RuntimeError:
                return False
        t_fact = time.perf_counter() - t1                  # the least seen (the first may include PARDISO's analysis)
        self._t_fact = t_fact if self._t_fact is None else min(self._t_fact, t_fact)
        self.factorizations += 1
        self.factor_time += time.perf_counter() - t0
        self.base = (active.copy(), factor)
        self._columns, self._base_state = {}, None
        return True

    def _analysed(self, K, active, own_analysis: bool):
        """A new PARDISO handle on the route's pattern (:meth:`_refactor`; ``K`` = K(``active``)), analysed on the
        bonded values after :meth:`coarse_start`, else (nested dissection) by its first factorisation of ``K``. On a
        slender interface (more rows than n ** :data:`SLENDER_FACE`) minimum degree first, kept where its factor
        fills at most :data:`SLENDER_FILL` times K's entries (else nested dissection); ``own_analysis`` (the last
        resort of :meth:`_system`): nested dissection on K itself, as before."""
        from .factor import PardisoSymmetric

        moves = np.asarray(abs(self.G).sum(axis=1)).ravel() > 0
        bonded = self._bonded_analysis and not own_analysis and not np.array_equal(active, moves)
        values = self.matrix(moves) if bonded else K          # the analysis on the bonded values (:meth:`_refactor`)
        if not own_analysis and self.m > self.n ** SLENDER_FACE:
            handle = PardisoSymmetric(K, ordering=0).analyse(values)
            if handle.fill <= SLENDER_FILL:
                return handle
            handle.release()
        handle = PardisoSymmetric(K)
        return handle.analyse(values) if bonded else handle

    def _over_cap(self, drop, add) -> bool:
        """Whether the rows ``drop`` and ``add`` changed from the base are more than the cap (refactorise rather
        than solve by the capacitance form). The default cap (``cap=None``): a refactorisation costs about this
        many column solves, solved in blocks as :meth:`_solve_on` solves them: a numeric factorisation's time
        (the least seen, PARDISO's analysis left out) over half a column's, at least :data:`CAP_MIN`, at most
        :data:`CAP_MAX`. A column's time is measured on the first block of at least CAP_MIN columns the capacitance
        form solves (:meth:`_solve_columns`); until then it is taken as :data:`BLOCK_GAIN` times less than the
        first single solve on a base (no block of columns solved for the measurement alone: 16 columns cost about
        a numeric factorisation, 0.072-0.078 s on thin_layer(3000), where the change that asked for them was then
        refactorised anyway). Which sets are refactorised and the steps' count depend on it (on the clock); the answer
        does not: :meth:`solve` takes it from a factor of K(A) for the final set A itself."""
        cap = self.cap
        if cap is None:
            cap = CAP_MIN if self._t_solve is None else \
                int(min(max(CAP_MIN, self._t_fact * BLOCK_GAIN / max(self._t_solve, 1e-7) / 2), CAP_MAX))
        return len(drop) + len(add) > cap

    def _solve_on(self, active, b):
        """z with K(active) z = b through the base factor and the capacitance form; None if singular."""
        n = self.n
        A_b, factor = self.base
        drop = np.flatnonzero(A_b & ~active)
        add = np.flatnonzero(active & ~A_b)
        c = len(drop) + len(add)
        bb = b.copy()
        bb[n + drop] = 0.0
        bb[n + add] = 0.0
        if c == 0:
            t0 = time.perf_counter()
            z = factor.solve(bb)
            if self._t_solve is None:                   # the first single solve (the default cap, _over_cap)
                self._t_solve = time.perf_counter() - t0
            return z
        GZ, YZ = self._capacitance_columns(drop, add)
        z0 = factor.solve(bb)
        ts = self._capacitance(GZ, YZ, drop, add, self.G[add] @ z0[:n], z0[n:], b[n + add])
        if ts is None:
            return None
        bb[n + drop] += ts[:len(drop)]
        for a, s in zip(add, ts[len(drop):]):
            row = self.G.getrow(a)
            bb[row.indices] -= s * row.data
        z = factor.solve(bb)
        z[n + drop] = -b[n + drop]                                   # the open rows' own equation -y = b
        z[n + add] = ts[len(drop):]
        return z

    def _solve_columns(self, keys):
        """Solve the base factor's capacitance columns ``keys`` ((row, 0): a gap correction e_a on a row dropped
        from the base; (row, 1): a force -G_a^T on x along an added row) in one block and cache their
        (G Zx, Zy); the first block of at least :data:`CAP_MIN` columns sets the default cap (:meth:`_over_cap`)."""
        n, factor = self.n, self.base[1]
        cols = np.zeros((n + self.m, len(keys)), order="F")      # as PARDISO reads them (no copy)
        for j, (a, kind) in enumerate(keys):
            if kind == 0:
                cols[n + a, j] = 1.0                                  # a gap correction on the dropped row
            else:
                row = self.G.getrow(a)
                cols[row.indices, j] = -row.data                     # a force on x along the added row
        t0 = time.perf_counter()
        Z = factor.solve(cols)
        t_col = max((time.perf_counter() - t0) / len(keys), 1e-7)
        if self.cap is None and len(keys) >= CAP_MIN:          # the default cap, measured (:meth:`_over_cap`)
            self.cap = int(min(max(CAP_MIN, self._t_fact / t_col / 2), CAP_MAX))
        self.column_solves += len(keys)
        GZ, YZ = self.G @ Z[:n], Z[n:]
        for j, k in enumerate(keys):
            self._columns[k] = (GZ[:, j], YZ[:, j])

    def _capacitance_columns(self, drop, add):
        """(G Zx, Zy) (m x c each) of the base factor's capacitance columns for the rows ``drop`` (dropped from the
        base: a gap correction e_a on the row) and ``add`` (added: a force -G_a^T on x), cached across steps."""
        keys = [(int(a), 0) for a in drop] + [(int(a), 1) for a in add]
        cap = CAP_MIN if self.cap is None else self.cap
        if len(self._columns) > 2 * max(cap, len(keys)):    # keep the cache O(m cap): the current rows only
            self._columns = {k: v for k, v in self._columns.items() if k in set(keys)}
        new = [k for k in keys if k not in self._columns]
        if new:
            self._solve_columns(new)
        if not keys:
            return np.zeros((self.m, 0)), np.zeros((self.m, 0))
        return (np.column_stack([self._columns[k][0] for k in keys]),
                np.column_stack([self._columns[k][1] for k in keys]))

    def _capacitance(self, GZ, YZ, drop, add, Gx0_add, y0, b_add):
        """The c unknowns (t on ``drop``, s on ``add``) of the capacitance form: y_drop = 0 and
        G_add x - soft y_add = b_add, with x, y = the base solution ``(Gx0, y0)`` plus the columns ``GZ, YZ``
        times them; None if the c x c system is singular."""
        M = np.vstack([YZ[drop], GZ[add]])                           # y_drop = 0, G_add x - soft y_add = b_add
        M[len(drop) + np.arange(len(add)), len(drop) + np.arange(len(add))] -= self.soft[add]
        r = np.concatenate([-y0[drop], b_add - Gx0_add])
        try:
            return sla.solve(M, r)
        except (np.linalg.LinAlgError, ValueError):
            return None

    def _settle(self, active, S, visited, max_iter: int = 50):
        """Active-set steps on the base factor's capacitance columns alone, from ``active``: while the set differs
        from the base in at most ``cap`` rows, its forces and slacks on every row are the base solution's plus the
        cached columns (m-vectors) times the c capacitance unknowns, O(m c) a step and no solve with the factor
        but one per row that joins the difference. The same steps as :meth:`solve`'s with the row scales ``S``
        of the last exact state; returns the set where they stop (the signs hold, or a set seen before, or too
        far from the base), which :meth:`solve` then solves exactly and checks. Near the answer the steps flip
        a few rows at a time whose forces and gaps are small beside their scales (1e-7 to 1e-4 of them on
        thin_layer(3000)): this settles them without a system of the full size per step. The result depends on
        the columns' rounding only through which set is tried next: the answer is the exact check's."""
        if self.base is None:
            return active
        n, (A_b, factor) = self.n, self.base
        seen = set(visited)
        for _ in range(max_iter):
            drop = np.flatnonzero(A_b & ~active)
            add = np.flatnonzero(active & ~A_b)
            if active.tobytes() in seen or self._over_cap(drop, add):
                return active
            if self._base_state is None:              # the base set's own solution, once per base and load
                zb = factor.solve(np.concatenate([self.F, np.where(A_b, self._g, 0.0)]))
                self._base_state = (self.G @ zb[:n], zb[n:])
            Gxb, yb = self._base_state
            seen.add(active.tobytes())
            GZ, YZ = self._capacitance_columns(drop, add)
            g_drop = self._g[drop]                      # the base's right-hand side without the dropped rows' gaps
            Gx0 = Gxb - GZ[:, :len(drop)] @ g_drop
            y0 = yb - YZ[:, :len(drop)] @ g_drop
            ts = self._capacitance(GZ, YZ, drop, add, Gx0[add], y0, self._g[add])
            if ts is None:
                return active
            y = np.where(active, y0 + YZ @ ts, 0.0)
            y[add] = ts[len(drop):]
            s = Gx0 + GZ @ ts - self._g
            if signs_hold(y, s, active, self.w, S):
                self._predicted = active.tobytes()      # the columns say: the answer (:meth:`_system`)
                return active
            active = (y * self.w + s > 0) & self._free
        return active

    def _last(self, active) -> bool:
        """Whether :meth:`_system` factorises K(``active``) for itself rather than solving it through the base: the
        set on which the steps on the capacitance columns (:meth:`_settle`) found every sign to hold, under the
        timed cap (whose answer :meth:`solve` takes from a factor of K(A) for the final set A anyway). Factorised as
        the step's own system, that factor is the final one where the exact check confirms the columns; the
        capacitance solve of the set (with its refinement) is not made (0.06 s on thin_layer(3000); where the
        check does not confirm them, the new base is nearer the answer). Once per prediction."""
        if not self._timed or self._predicted != active.tobytes() or np.array_equal(self.base[0], active):
            return False
        self._predicted = None
        return True

    def _system(self, active):
        """(z, residual) of K(active) z = [F; P g] via the base (refactorised if needed; if the answer fails its
        check, refactorised, then refactorised after a fresh analysis, module docstring); None if singular."""
        # K(A) and |K(A)| on the pattern's two kept buffers, only the rows changed since the last system rewritten
        # (the same values as matrix(); held by no one past this call: PARDISO and SuperLU copy what they factorise)
        K, absK = self.pattern.kept(active, self.soft), None
        for attempt in range(3):
            if attempt == 2:
                self.forget(analysis=True)
            if self.base is None or attempt >= 1 or self._last(active) \
                    or self._over_cap(np.flatnonzero(self.base[0] & ~active), np.flatnonzero(active & ~self.base[0])):
                if not self._refactor(active, K, own_analysis=attempt == 2):
                    return None
            b = np.concatenate([self.F, np.where(active, self._g, 0.0)])
            z = self._solve_on(active, b)
            if z is None or not np.isfinite(z).all():
                continue
            for _ in range(3):          # iterative refinement against K(A) itself, while needed
                r = b - K @ z
                # componentwise backward error (each row's own terms; |K(A)| from the pattern's |values|)
                absK = self.pattern.kept(active, self.soft, absolute=True) if absK is None else absK
                scale = absK @ np.abs(z) + np.abs(b)
                # plus, on a contact row, the displacement w_a |y_a| its own force makes (as in the steps): a row
                # closed at g = 0 against a fixed side (a rigid floor, a clamped foundation) has no other term
                scale[self.n:] += self.w * np.abs(z[self.n:])
                if float((np.abs(r) / np.maximum(scale, np.finfo(float).tiny)).max(initial=0.0)) <= 1e-12:
                    if np.array_equal(active, self.base[0]):     # the base set's own solution (_settle)
                        self._base_state = (self.G @ z[:self.n], z[self.n:])
                    return z
                dz = self._solve_on(active, r)
                if dz is None or not np.isfinite(dz).all():
                    break
                z = z + dz
        return None

    def solve(self, F, g, active=None, max_iter: int = 50, free=None):
        """The Signorini problem for loads ``F`` (= [f_1; -q_1; ...], scaled) and gaps ``g`` (rows of E,
        scaled) from the active set ``active`` (default: every row closed, the bonded system). ``free``: the rows
        that may close (bool per row; default every row): every set the steps try stays within it, as the AMG
        route's (``movable``), so that a row left open by its caller (a row no unknown moves, a row a tighter
        parallel row implies: :func:`~cvxcontact.backends.parallel.looser_rows`) is not closed by a step whose
        rounding gives it a slack > 0 (a looser row of a gap equal to its tight twin's to rounding has that
        twin's slack; closed beside it, K(A) is singular and the steps split the node's force between them).

        Returns ``(u, phi, y, active, steps)`` (per-body lists as in
        :func:`~cvxcontact.backends.full.mixed_kkt`, y the row forces, ``steps`` the number of systems
        solved exactly over every attempt, :meth:`_attempts`: those of the attempts that stopped before the one
        that settled too; the steps taken on the capacitance columns alone, :meth:`_settle`, are not counted) or
        None if the steps cycle, stall or meet a singular system in every attempt. :attr:`attempts` is then the
        number of attempts this solve made."""
        self.F = np.asarray(F, dtype=float)
        self._g = np.asarray(g, dtype=float)
        self._base_state, self._predicted = None, None
        n, m = self.n, self.m
        active = np.ones(m, dtype=bool) if active is None else np.asarray(active, dtype=bool).copy()
        self._free = np.ones(m, dtype=bool) if free is None else np.asarray(free, dtype=bool)
        active &= self._free
        visited = set()                                 # the sets solved exactly (the steps' cycle test)
        systems = 0                                     # the systems solved exactly, over every attempt

        def step(active):
            nonlocal systems
            z = self._system(active)
            if z is None:
                return None
            systems += 1
            visited.add(active.tobytes())
            x, y = z[:n], z[n:]
            s = self.G @ x - self._g
            S = self.reach @ np.abs(x) + np.abs(self._g) + self.w * np.abs(y)     # (a node that does not move:
            # a P2 face vertex under a uniform pressure, has a slack of rounding of its neighbours' displacements)
            S = np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), np.finfo(float).tiny))
            if signs_hold(y, s, active, self.w, S):
                return (x, y), None
            new = (y * self.w + s > 0) & self._free
            settled = self._settle(new, S, visited) if settle else new    # the steps near the base on its columns
            return (x, y), (new if settled.tobytes() in visited else settled)

        out, start, self.attempts = None, active, 0
        for settle, fresh in self._attempts():
            if fresh:
                self.forget(analysis=True)
            visited = set()
            self.attempts += 1
            out = active_set_steps(step, start, max_iter)
            if not isinstance(out, Declined):
                break
        if isinstance(out, Declined):
            return None
        (x, y), active, _ = out
        # the timed cap decides the base the steps end on (the capacitance form's last digits: thin_layer(400)'s
        # forces 6.6e-12 or 1.2e-9 from a pivoted LU in two runs): the answer from K(A)'s own factor, clock-free
        if self._timed and self.base is not None and not np.array_equal(self.base[0], active) \
                and self._refactor(active):
            z = self._system(active)
            x, y = (x, y) if z is None else (z[:n], z[n:])
        return self._split(x) + (np.where(active, y, 0.0), active, systems)

    def _attempts(self):
        """The (settle, fresh) of :meth:`solve`'s attempts, each from the same start set: the steps near the base
        on its columns (:meth:`_settle`) on the base a previous solve left, and if they stop (a cycle, a system
        that fails its check, ``max_iter``) the same from a fresh factorisation and analysis (:meth:`forget`),
        then the plain steps (no settling) from a fresh one again. Why fresh: what a solve leaves decides the next
        one's path, the base through the sets the capacitance form takes, and PARDISO's analysis through its
        scaling and weighted matching, computed from the values of the first matrix it factorised and kept for
        every later factor. Measured on thin_layer(1000), analysed on a coarse subset of rows closed: 124-1,237
        perturbed pivots, every later solve from the bonded start on that object stopped on a system that failed
        its check (the fresh object: 10 systems, none perturbed). From a fresh factorisation and analysis the
        path is a fresh object's (with the same ``cap``), whatever this object solved before."""
        first = [(True, False)] if self.base is not None else []
        return first + [(True, True), (False, True)]

    def forget(self, analysis: bool = False):
        """Drop the base factor and its capacitance columns (SuperLU's ordering, which depends on the pattern
        alone, and ``cap`` are kept): the next system is factorised afresh on its own set. ``analysis``: drop
        PARDISO's analysis too (:meth:`_attempts`); the next system pays a new one (0.31-0.33 s on
        thin_layer(3000), about four numeric factorisations)."""
        self.base, self._columns, self._base_state = None, {}, None
        if analysis and self._pardiso is not None:
            self._pardiso.release()
            self._pardiso = None

    def _state(self, active):
        """(x, y, slack G x - g, S each row's displacement scale) of K(active) z = [F; P g], or None if singular."""
        z = self._system(active)
        if z is None:
            return None
        x, y = z[:self.n], np.where(active, z[self.n:], 0.0)
        S = self.reach @ np.abs(x) + np.abs(self._g) + self.w * np.abs(y)
        return x, y, self.G @ x - self._g, np.maximum(S, 1e-14 * max(float(S.max(initial=0.0)), np.finfo(float).tiny))

    def set_soft(self, soft):
        """New compliances of the closed rows (the base factor no longer holds)."""
        self.soft = np.broadcast_to(np.asarray(soft, dtype=float), (self.m,)).copy()
        self.forget()

    def regularised(self, F, g, active, max_iter: int = 100):
        """The regularised problem of the rows' compliances ``soft`` (> 0): min Phi(x) = 1/2 x^T A x - F^T x +
        sum_a (G_a x - g_a)_+^2 / (2 soft_a) (the phi-form energy where the Gauss rows hold, which every iterate
        keeps), strictly convex and piecewise quadratic, by damped semismooth Newton: at x the penetrating rows
        are closed and the Newton point is K(A) z = [F; P g] with G_a x - soft_a y_a = g_a on them (the sparse
        mixed system, quasi-definite whatever the dependence of the rows), with Armijo backtracking on Phi (the
        undamped steps, i.e. primal-dual active-set steps, cycle on dependent rows: W + soft is ill-conditioned).
        Starts from the Newton point of the rows ``active``. Returns ``(y, active, steps)``, y = the penetration
        over soft on the penetrating rows (after ``max_iter`` steps the last iterate's), or None if a system is
        singular."""
        self.F = np.asarray(F, dtype=float)
        self._g = g = np.asarray(g, dtype=float)
        G, soft, n = self.G, self.soft, self.n

        def newton_point(active):
            z = self._system(active)
            return None if z is None else z[:n]

        def energy(x):
            r = np.maximum(G @ x - g, 0.0)
            return 0.5 * x @ (self.A @ x) - self.F @ x + 0.5 * float(np.sum(r * r / soft))

        active = np.asarray(active, dtype=bool).copy()
        x = newton_point(active)
        full = False                                # the last step was a full Newton step (set below)
        for steps in range(1, max_iter + 1):
            if x is None:
                return None
            r = G @ x - g
            new = r > 0
            if steps > 1 and np.array_equal(new, active) and full:
                return np.where(active, r / soft, 0.0), active, steps
            active = new
            target = newton_point(active)
            if target is None:
                return None
            dx = target - x
            slope = float((self.A @ x - self.F + G.T @ (np.maximum(r, 0.0) / soft)) @ dx)
            t, f0 = 1.0, energy(x)
            while t > 1e-10 and energy(x + t * dx) > f0 + 1e-4 * t * min(slope, 0.0) + 1e-14 * abs(f0):
                t *= 0.5
            full = t == 1.0
            x = x + t * dx
        r = G @ x - g                           # not settled: its forces still start the exact finish
        return np.where(r > 0, r / soft, 0.0), r > 0, max_iter

    def independent(self, F, g, y0, start, max_iter: int | None = None):
        """The exact finish for rows that may be linearly dependent (3D "gamma3" overlays, docs/formulation.md
        §13): :func:`~cvxcontact.backends.finish.lawson_hanson` from the forces ``y0`` >= 0 on the rows
        ``start`` (crossover onto an independent subset, then Lawson-Hanson steps on the dual), each step K(P) z
        = [F; P g] on this mixed system with the passive rows P closed (independent, so K(P) is not singular)
        through the base factor and the capacitance form, checked against K(P) itself (:meth:`_system`).
        Returns ``(u, phi, y, passive, steps)`` or the reason it stopped (a string)."""
        self.F = np.asarray(F, dtype=float)
        self._g = np.asarray(g, dtype=float)

        def step(mask, passive):
            out = self._state(mask)
            return None if out is None else ((out[0], out[1]),) + out[1:]

        out = lawson_hanson(self.G, y0, start, lambda first: step, None, g=self._g, max_iter=max_iter)
        if isinstance(out, Declined):
            return out
        (x, y), passive, steps = out
        return self._split(x) + (y, passive, steps)

    def coarse_start(self, F, g, free=None):
        """A start set for :meth:`solve`'s steps on a long interface, from the answer of a coarse subproblem.

        The coarse rows: a maximal independent set of the free rows' graph to :data:`~.coarse.COARSE_HOPS` hops (no
        two within as many shared dofs of each other: about one row in ten on thin_layer). Their problem (26)-(27)
        alone (every other row left out) is solved on its dense Schur complement, the coarse rows' compliance
        W_c = G_c S^{-1} G_c^T (c x c, one partial factorisation of [[S, G_c^T], [G_c, 0]] with the coarse rows as
        its Schur block, :func:`~cvxcontact.backends.factor.factorize`, freed at once), as the LCP y >= 0,
        s = q - W_c y <= 0, y^T s = 0 with q = G_c S^{-1} F - g_c (:func:`~cvxcontact.backends.finish.solve_lcp`).
        The start: every free row within as many hops of a closed coarse row, less the stiffer row of
        each nearly dependent pair (:func:`~.coarse.spread`). Only a start: the answer is the steps' (checked as
        always). Why: from the bonded start a slender layer's contact zone moves by hundreds of rows a step, each
        step a numeric factorisation (15 on thin_layer(3000)); from this start 4. Returns None where there is no
        coarse problem to solve (every free row coarse, none free) or it cannot be solved (a perturbed pivot, a
        singular W_c, the LCP declined): the caller then starts from the bonded system. From this call on, a new
        PARDISO analysis of this object is made on the bonded values (:meth:`_refactor`).

        Parameters
        ----------
        F : (n,) ndarray, the loads [f_1; -q_1; ...] (scaled)
        g : (m,) ndarray, the rows' gaps (scaled)
        free : (m,) bool ndarray, optional, the rows that may close (default every row)

        Returns
        -------
        (m,) bool ndarray, the rows to close first, or None (above)
        """
        free = np.ones(self.m, dtype=bool) if free is None else np.asarray(free, dtype=bool)
        self._bonded_analysis = True          # the steps from the start: PARDISO analysed on the bonded values
        out = self._coarse(F, g, free)
        if out is None:
            return None
        C, idx, y = out
        return spread(C, idx[y > 0], free, self.G, self.A.diagonal(), self.w)

    def _coarse(self, F, g, free):
        """(C, idx, y) of :meth:`coarse_start`: the rows' graph (pattern, m x m: rows sharing a dof, each its own
        neighbour), the coarse rows and their forces (the LCP's answer on W_c, > 0 on the closed ones); None as
        there."""
        from .factor import PardisoFactorization
        from .factor import factorize as factorize_schur

        C = row_graph(self.G)
        idx = coarse_rows(C, free)
        if len(idx) == 0 or len(idx) == int(free.sum()):
            return None
        Gc = self.G[idx]
        gamma = self.n + np.arange(len(idx))
        U = bordered_upper(self.A, Gc) if self.factorization == "pardiso" else None   # what PARDISO reads of M
        M = sp.bmat([[self.A, Gc.T], [Gc, None]], format="csr") if U is None else None
        order = None
        if self.factorization != "pardiso":             # SuperLU: the route's ordering of S's dofs, the rows last
            if self.perm is None:
                self.perm = ordering(self.matrix(np.ones(self.m, dtype=bool)), self.n + np.arange(self.m))
            order = np.concatenate([self.perm[self.perm < self.n], gamma])
        try:
            fac = factorize_schur(M, gamma, self.factorization, order=order) if U is None else \
                PardisoFactorization(U, gamma, upper=True)
        except (SolverError, RuntimeError):
            return None
        try:
            q = -fac.forward(np.concatenate([np.asarray(F, dtype=float), np.zeros(len(idx))])).reduced \
                - np.asarray(g, dtype=float)[idx]                        # G_c S^{-1} F - g_c
            W = -fac.schur                                               # the Schur block of M is -W_c
        finally:
            fac.free()
        out = solve_lcp(W, q, np.ones(len(idx), dtype=bool))
        if isinstance(out, Declined):
            return None
        return C, idx, np.where(out[1], out[0], 0.0)

    def _split(self, x):
        u, phi, pos = [], [], 0
        for nu, npf in self.sizes:
            u.append(x[pos:pos + nu])
            phi.append(x[pos + nu:pos + nu + npf] if npf else None)
            pos += nu + npf
        return u, phi
