"""The fast route of a non-quadratic bulk energy (the paper's nonlinear A, e.g. Hencky; docs/formulation.md §19):
Newton on the nonlinear mixed system (26) with the contact active set, no interior point and no CVXPY program.

1. the start: the elastic predictor, i.e. the rest state (the free unknowns 0, the prescribed displacements
   applied) with the rows it penetrates closed, so that the first step is the linear problem of the initial
   tangent on those rows (a re-solve of a :class:`~cvxcontact.ContactSolver`: the previous answer and its active
   set; a ``start=`` state: its rows). Measured against starting from the linear problem's exact answer (the sparse
   route's active-set steps, then Newton): 11 steps and 2.1 s against 8 systems + 9 steps and 3.2 s on a circle
   pressed into a block of 26,082 unknowns (the linear answer's set is not the plastic one either);
2. the semismooth Newton steps of the full route's finish (:func:`~cvxcontact.backends.finish.
   solve_sparse_compliance` on :class:`~cvxcontact.backends.mixed.MixedEnergy`, every row a Signorini row, or the
   rows' normal-compliance law, :func:`compliance`): damped on the energy with a sufficient decrease
   (:data:`ARMIJO`), the contact rows' signs checked after every full step (the primal-dual active-set update,
   :data:`EARLY`), rounding recognised by the step's own floor
   (:func:`~cvxcontact.backends.finish.normal_compliance.rounding_floor`), each step one numeric factorisation on one
   sparsity (:class:`TangentSolver`);
3. if those steps do not settle (the active-set steps revisit a set, a singular step, or a stall above
   rounding), the full route (:func:`~cvxcontact.backends.signorini.full`: the interior point, then the same
   Newton finish) answers instead, ``sol.info.route`` :attr:`~cvxcontact.backends.result.Route.NEWTON_FELL_BACK`
   and the reason logged (a compliance law, which no other route poses beside a non-quadratic energy: a
   SolverError): never an unfinished answer in its place.

The answer is then checked by the read-back like every other ((26)-(27) with the nonlinear internal forces).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp

from ..contact.laws import RowLaws, Signorini
from ..errors import SolverError
from .finish import Declined, solve_sparse_compliance
from .interface import release_held
from .mixed import mixed_system, unstacked
from .result import Finish, RawResult, Route, load_key

__all__ = ["CHEAP", "FAR", "FORCING", "KRYLOV", "LINE", "LOOSE", "NEAR", "ROUGH", "SECANT", "SINGLE", "SINGLE_REFINE",
           "TangentSolver", "compliance", "newton"]

log = logging.getLogger(__name__)

EARLY = 1.0
"""The relative residual of (26) below which the Newton steps check the contact rows' signs and leave a set they
reject (:func:`~cvxcontact.backends.finish.solve_sparse_compliance`'s ``early``): 1, i.e. after every full step,
the primal-dual active-set (semismooth Newton) update of the rows. The start's active set is rarely the plastic
one; converging on each wrong set first cost more steps (measured from the linear answer, the circle pressed into
a block of 26,082 unknowns: 16 Newton steps with 1e-4, 21 checking converged sets only, 9 with 1; a revisited set
ends in the full route, never in a wrong answer)."""


ARMIJO = 1e-4
"""The sufficient decrease of the steps' backtracking on the energy (:func:`~cvxcontact.backends.finish.
solve_sparse_compliance`'s ``armijo``), the condition under which damped Newton on a convex energy with a Lipschitz
gradient converges from any start (the full route's finish starts near the answer and only asks no increase). On
the measured scenes it changes nothing (58k unknowns: the same 18 steps with 0)."""


LINE = 4
"""The most regula falsi steps of the line search on the energy's slope along a Newton step
(:func:`~cvxcontact.backends.finish.solve_sparse_compliance`'s ``line``), each one gradient: where a full step
overshoots the energy's minimum on its line (points yielding or unloading between steps), the step is cut there
instead of halved until the energy decreases. Measured (CPU, one thread, circle into a block): P2 at 103,362
unknowns 16 -> 11 steps (14 -> 8 factorisations), P1 at 103,362 13 -> 11 and at 26,082 11 -> 10; 0: halving
only."""

SECANT = 1
"""The Newton steps after the start's (the elastic predictor's) that take the bodies' secant stiffness instead of
the tangent (:func:`~cvxcontact.backends.finish.solve_sparse_compliance`'s ``secant``; a re-solve from the
previous answer: none). Measured with :data:`LINE` (CPU, one thread, circle into a block): 103,362 unknowns P1 11
-> 9 steps (9 -> 7 factorisations), P2 11 -> 10; 26,082 P1 10 -> 13 steps but 7 -> 8 factorisations (the contact
set left and taken back once). 0: Newton's tangent at every step. (Once opt-in: on SuperLU's factors with GMRES at
every step a 40 x 12 indented block did not settle from it, the backtracking then being on the energy alone, which
an inexact step's closed rows made no merit function; it is on the closed rows' Lagrangian since.)"""

FORCING = 1e-4
"""The forcing term of the inexact Newton steps (:class:`TangentSolver`'s GMRES): a step's system is solved until
its residual is FORCING times that of the last step's answer, the Newton residual after a full step, or to the
direct solve's rounding, whichever comes first; so a step reduces the residual of (26) by about 1e4 or to
rounding, never less than the exact step would beyond that (the steps' stopping test, which reads the residual of
(26) itself, is unchanged); the final steps, where that residual is near rounding, are solved to rounding."""

ROUGH = 1e-6
"""A factorised step's answer is refined to rounding (up to three steps against the matrix itself) only where the
relative residual of (26) before the step (:class:`TangentSolver`'s ``distance``, set by the steps: the last
one's, 0 at the first step) is at most ROUGH: near the answer, where a step's own solve error is credited in the
stopping test's floor. Above it a direct solve within :data:`FORCING` of its right side is taken unrefined, an
inexact Newton step as GMRES's (and like it no floor: ``exact`` False); a step from there does not reach
rounding (the steps' residuals, circle into a block: ... 7e-1, 5e-2, 8e-6, 6e-9, 1e-10). 1e-6, not 1e-4:
the 1e5 P2 circle's eighth step, at 4.8e-5, then takes one solve of its single factor instead of its refinement
(CPU 2.59 -> 2.44 s, the same steps and factorisations, u the same to 3e-15; P1 at 1e5 has no step between)."""

NEAR = 1e-3
"""After a step whose GMRES did not converge, :class:`TangentSolver` factorises the next steps' systems directly
until the last step's answer z_0 nearly solves one, |b - A z_0| <= NEAR |b|: far from the answer the tangent
changes at many points between steps (the plastic zone grows) and GMRES on the last factor took more iterations
than a factorisation costs (2D P1, 26k unknowns: 14-24 iterations to 1e-4 there, 2-5 near the answer)."""

FAR = 1.0
"""Below :data:`CHEAP`, GMRES is not tried on a step whose start, the last step's answer z_0, is a worse start than
none, |b - A z_0| > FAR |b|: the system moved far from the last factor's (the secant step after the elastic
predictor's: 10 to 41 there, and GMRES failed on it in every case measured, 2D P1 at 3,250 to 103,362 unknowns and
P2 at 103,362, after 2 to 5 iterations; 1e-12 to 0.57 at the other steps tried)."""

CHEAP = 10
"""A GMRES budget of at least CHEAP iterations (:data:`KRYLOV`: a factorisation worth 20 solves or more, as in 3D)
makes GMRES the first try at every step, even after one that did not converge, inexact by :data:`LOOSE` instead
of :data:`FORCING` (measured, 3D P1 sphere at 24k unknowns, CPU: 4.3 s with 1 to 3 factorisations against 5.1 to
6.6 s with 6; in 2D, where a factorisation is worth about 9 solves, the same lost: 7.6 s against 5.5 s at 1e5)."""

LOOSE = 1e-2
"""The forcing term of the steps when GMRES is cheap (:data:`CHEAP`): each step still reduces the residual of its
linear model a hundredfold, far more than the halving the stopping test asks."""

KRYLOV = 15
"""The most GMRES iterations of :class:`TangentSolver` on one step's system before it is factorised itself (and
preconditions the next ones). Below it, the budget is half the iterations a factorisation is worth: PARDISO's
analysis reports a factorisation's flops F and the factor's nonzeros L; one iteration (two triangular sweeps and a
product) was measured at F / (4 L) / 5 times less than a factorisation (one thread: 2D P1 8.5 and 8.7 at 26k and
1e5 unknowns, 3D P1 29 at 24k; SuperLU: 6 iterations). 0: a factorisation every step."""


SINGLE = True
""":class:`TangentSolver` factorises in single precision (PARDISO, :class:`~cvxcontact.backends.factor.
PardisoSymmetric`'s ``single``) and refines the answers against the system in double: far from the answer a step
needs only :data:`FORCING` (one solve of a single factor reaches about 1e-7), near it the refinement reaches
rounding as from a double factor (within :data:`SINGLE_REFINE` steps, else the step and every later one are
factorised in double, ``doubled``). Measured (one thread, the systems of the circle pressed into a Hencky block,
P2 at 103,041 unknowns): a factorisation 0.095 s against 0.136 s, a solve 0.013 s against 0.024 s, the residual
1e-7, 4e-12, 7e-15, 2e-16 after one solve and each refinement. False: double precision (SuperLU always)."""

SINGLE_REFINE = 8
"""The most refinements of an answer of a single-precision factor (:data:`SINGLE`) before the step is factorised
in double instead (three sufficed in every system measured)."""


class TangentSolver:
    """[x; z_L] with [[K, G_L^T], [G_L, 0]] [x; z_L] = b for the Newton steps of one problem (K = T + G^T D G the
    tangent block, L the closed rows ``at``; :func:`~cvxcontact.backends.finish.solve_sparse_compliance`'s
    ``solve(K, b, at)``), solved as the sparse route's system of every row
    (:mod:`cvxcontact.backends.sparse`)

        [[K, G^T P], [P G, -(I - P)]] [x; y] = [b_x; P b_L]        P = diag(1 on L)

    (an open row: y_a = 0, no coupling), on ONE sparsity for every step and every L: ``pattern`` (n x n) ones
    wherever the tangent may be non-zero (:meth:`~cvxcontact.backends.mixed.MixedEnergy.pattern`; a product drops
    the moduli's zeros) and every row's couplings, stored as explicit zeros where off. So the fill-reducing
    analysis is done once: with ``factorization="pardiso"`` :class:`~cvxcontact.backends.factor.PardisoSymmetric`,
    else SuperLU without pivoting in the quasi-definite order :func:`~cvxcontact.backends.elimination.ordering`.

    Each system is first solved by GMRES preconditioned by the last numeric factorisation (of an earlier step's
    matrix), from the last step's answer, inexact by :data:`FORCING` (a budget of iterations: ``krylov`` if given,
    else half what a factorisation is worth, at most :data:`KRYLOV`; after a step whose GMRES did not converge only
    near the answer, :data:`NEAR`, else not where the last answer is a worse start than none, :data:`FAR`), else
    factorised itself (with PARDISO in single precision, :data:`SINGLE`) and solved, then refined against the matrix
    itself in double (up to three steps on a double factor, :data:`SINGLE_REFINE` on a single one). Either way the
    answer is accepted only once every row's residual is within 1e-14 of its terms (|A| |z| + |b|; the direct
    solve: or after three refinements), the direct solves' accuracy, so the answers are the same to rounding (the
    steps far from it are inexact by :data:`FORCING`/:data:`LOOSE`; a direct solve there within FORCING of its
    right side is not refined, :data:`ROUGH`).
    None if it is singular, x not finite or the residual above ``residual`` max|b| (as
    :func:`~cvxcontact.backends.full.solve_mixed`). ``factorizations`` counts the numeric factorisations,
    ``analyses`` the analyses, ``solves`` the systems, ``iterations`` the GMRES iterations, ``unrefined`` the
    factorised systems taken unrefined far from the answer (:data:`ROUGH`; ``distance``: the relative residual of
    (26) before the step, which the steps set); ``single``: the factorisations are in single precision
    (:data:`SINGLE`), ``doubled``: a single factor did not refine and double precision took over; ``exact``: the last
    system was solved to rounding (False: GMRES stopped at its forcing term, so its residual is no rounding
    floor for :func:`~cvxcontact.backends.finish.normal_compliance.rounding_floor`)."""

    def __init__(self, pattern, G, factorization: str = "auto", residual: float = 1e-8, krylov: int | None = None):
        from .factor import resolve

        # G's own copy, canonical: the places below index its entries in order, which a caller's in-place sort
        # of G's arrays (scipy's abs(G) sorts an unsorted G) would otherwise permute under them
        P, Gc = sp.coo_matrix(pattern), sp.csr_matrix(G, copy=True)
        Gc.sum_duplicates()
        Gc = Gc.tocoo()
        self.n, self.m = n, m = P.shape[0], G.shape[0]
        self.kind, self.residual = resolve(factorization), residual
        self.krylov, self._fixed = (KRYLOV, False) if krylov is None else (krylov, True)
        N = n + m
        rows = np.concatenate([P.row, np.arange(n), n + Gc.row, Gc.col, n + np.arange(m)])
        cols = np.concatenate([P.col, np.arange(n), Gc.col, n + Gc.row, n + np.arange(m)])
        frame = sp.csc_matrix((np.ones(len(rows)), (rows, cols)), shape=(N, N))   # the fixed pattern
        frame.sort_indices()
        self._indices, self._indptr = frame.indices, frame.indptr
        self._index = sp.csr_matrix((np.arange(1, frame.nnz + 1, dtype=float), frame.indices, frame.indptr),
                                    shape=(N, N))          # the CSC frame read as CSR: (col, row) -> place + 1
        at = self._at                                            # where each coupling and row diagonal sits
        self._G = (Gc.row, Gc.data, at(n + Gc.row, Gc.col), at(Gc.col, n + Gc.row), at(n + np.arange(m),
                                                                                     n + np.arange(m)))
        inner = sp.csr_matrix(P)                                 # where the tangent's entries sit in the frame
        inner.sum_duplicates()
        self._inner = sp.csr_matrix((np.arange(1, inner.nnz + 1, dtype=float), inner.indices, inner.indptr),
                                    shape=(n, n))
        self._places = at(np.repeat(np.arange(n), np.diff(inner.indptr)), inner.indices)
        self._perm = self._pardiso = self._last = self._z = self._found = None
        self._budget, self._failed, self.distance = None, False, 0.0
        self.single, self.doubled = SINGLE and self.kind == "pardiso", False
        self.factorizations = self.analyses = self.refinements = self.solves = self.iterations = 0
        self.unrefined = 0

    def restart(self) -> None:
        """Forget the last step's factor and answer (GMRES's preconditioner and start) before a solve from the rest
        state: its steps are then a fresh solver's, bit for bit (the analysis and the pattern's places are kept:
        exact)."""
        self._last = self._z = None
        self._failed = False

    def _at(self, rows, cols):
        """The places of the entries (rows, cols) in the data of the fixed pattern (CSC, sorted)."""
        return np.asarray(self._index[np.asarray(cols), np.asarray(rows)], dtype=np.int64).ravel() - 1

    def matrix(self, K, at) -> sp.csc_matrix:
        """The system of every row for the tangent block ``K`` (n x n) and the closed rows ``at``, on the pattern."""
        K = sp.csr_matrix(K)
        K.sum_duplicates()
        K.sort_indices()
        last = self._found
        inner = self._inner
        if last is not None and last[3] is K.indptr and last[4] is K.indices:
            places = last[2]                                     # the same index arrays (a tangent on H_0's)
        elif last is not None and np.array_equal(last[0], K.indptr) and np.array_equal(last[1], K.indices):
            places = last[2]                                     # the last step's sparsity (the tangent's own)
        elif np.array_equal(inner.indptr, K.indptr) and np.array_equal(inner.indices, K.indices):
            places = self._places                                # the pattern's own sparsity (no merge)
        else:
            mask = sp.csr_matrix((np.ones(K.nnz), K.indices, K.indptr), shape=K.shape)
            found = self._inner.multiply(mask).tocsr()          # K's entries' places in the pattern (a merge)
            found.sort_indices()
            if found.nnz == K.nnz:
                places = self._places[found.data.astype(np.int64) - 1]
            else:                                                # an entry off the pattern (not by construction)
                places = self._at(np.repeat(np.arange(self.n), np.diff(K.indptr)), K.indices)
        if last is None or last[2] is not places or last[3] is not K.indptr or last[4] is not K.indices:
            self._found = (K.indptr.copy(), K.indices.copy(), places, K.indptr, K.indices)
        gr, gv, lower, upper, diagonal = self._G
        on = np.asarray(at, dtype=bool)
        data = np.zeros(self._index.nnz)
        data[places] = K.data
        data[lower] = data[upper] = np.where(on[gr], gv, 0.0)
        data[diagonal] = np.where(on, 0.0, -1.0)
        N = self.n + self.m
        return sp.csc_matrix((data, self._indices, self._indptr), shape=(N, N))

    def _factor(self, M):
        from .elimination import factorize, ordering
        from .factor import PardisoSymmetric

        if self._pardiso is None and self._perm is None:
            self.analyses += 1
            if self.kind == "pardiso":
                try:
                    self._pardiso = PardisoSymmetric(M, single=self.single)
                except SolverError:
                    self.kind, self.single = "superlu", False        # refused: SuperLU (double) from here on
            if self._pardiso is None:
                self._perm = ordering(M, self.n + np.arange(self.m))
        self.factorizations += 1
        if self._pardiso is not None:
            return self._pardiso.factor(M)
        try:
            return factorize(M, self._perm)
        except RuntimeError:
            return None

    def __call__(self, K, b, at):
        n, at = self.n, np.asarray(at, dtype=bool)
        A = self.matrix(K, at)
        bb = np.zeros(n + self.m)
        bb[:n] = b[:n]
        bb[n + np.flatnonzero(at)] = b[n:]
        self.solves += 1
        absA, tiny = sp.csc_matrix((np.abs(A.data), A.indices, A.indptr), shape=A.shape), np.finfo(float).tiny
        columns, sized = np.asarray(absA.sum(axis=0)).ravel(), np.abs(bb).sum() + len(bb) * tiny

        def settled(z, r):          # every row's residual within 1e-14 of its own terms
            if not np.isfinite(r).all():
                return False
            # summed over the rows, that asks sum|r| <= 1e-14 (1^T |A| |z| + sum|b|): where twice that fails, no
            # row-by-row product is needed (the refinements of a single-precision factor, GMRES's first cycles)
            if np.abs(r).sum() > 2e-14 * (columns @ np.abs(z) + sized):
                return False
            return bool((np.abs(r) <= 1e-14 * np.maximum(absA @ np.abs(z) + np.abs(bb), tiny)).all())

        z, self.exact = None, True
        if self._last is not None and self._z is not None and self._budget:
            z0 = self._z.copy()                                  # the last step's answer, its open rows' y 0
            z0[n + np.flatnonzero(~at)] = 0.0
            near = 0.0 if self._budget >= CHEAP else np.linalg.norm(bb - A @ z0) / max(np.linalg.norm(bb), tiny)
            if near <= (NEAR if self._failed else FAR):
                z = self._gmres(A, bb, at, settled, z0)
                self._failed = z is None
            elif near > FAR:                                     # as if GMRES had failed (it does there)
                self._failed = True
        if z is None:
            z = self._direct(A, bb, settled)
            if z is None and self.single:              # the single factor fell short: double precision from here
                log.info("the single-precision factor of a Newton step's system did not refine to its accuracy; "
                         "double precision from here on")
                self.single, self.doubled = False, True
                if self._pardiso is not None:
                    self._pardiso.release()
                self._pardiso = self._last = None
                self.exact = True
                z = self._direct(A, bb, settled)
        if z is None or not np.isfinite(z).all():
            self._z = None
            return None
        self._z = z
        return np.concatenate([z[:n], z[n:][at]])

    def _direct(self, A, bb, settled):
        """The answer of A z = bb by a numeric factorisation of A, refined against A (up to three steps, up to
        :data:`SINGLE_REFINE` on a single-precision factor) while a row's residual exceeds 1e-14 of its terms
        (``settled``), or taken unrefined within :data:`FORCING` of bb far from the answer (:data:`ROUGH`); None if
        the factorisation fails, its residual exceeds ``residual`` max|bb| (an unrefined answer's: FORCING max|bb|,
        which a singular system's misses as well; a single factor's first answer is within about 1e-7), or a
        single-precision factor does not settle where the answer is asked to rounding (the caller then factorises
        in double)."""
        try:
            factor = self._last = self._factor(A)
        except SolverError:
            if not self.single:
                raise
            return None
        single = self.single
        if factor is None:
            return None
        if self._budget is None:
            self._budget = self._worth()
        z = factor.solve(bb)
        size, rough = np.linalg.norm(bb), self.distance > ROUGH         # far from the answer (:data:`ROUGH`)
        scale = max(np.abs(bb).max(initial=0.0), np.finfo(float).tiny)
        check = np.inf if self.residual is None else self.residual * scale
        done = False
        for _ in range(SINGLE_REFINE if single else 3):    # refined while a row's residual exceeds 1e-14 of its terms
            r = bb - A @ z
            self.refinements += 1
            if settled(z, r) or not np.isfinite(r).all():
                done = True
                break
            if rough and np.linalg.norm(r) <= FORCING * size:
                self.exact = False                           # an inexact Newton step, as GMRES's
                self.unrefined += 1
                done = True
                break
            z = z + factor.solve(r)
        if not done:                                         # (else r is z's residual already)
            r = bb - A @ z
            if single and not settled(z, r):
                return None
        # a singular system's answer misses bb by far more than rounding (or FORCING, an unrefined one's)
        if np.abs(r).max() > (check if self.exact else max(check, FORCING * scale)):
            return None
        return z

    def _worth(self) -> int:
        """The GMRES budget of a step (:data:`KRYLOV`): half the iterations a factorisation is worth."""
        cost = None if self._pardiso is None else self._pardiso.cost
        if self._fixed:
            return self.krylov
        if cost is None or cost[1] <= 0:
            return min(self.krylov, 6)
        return int(np.clip(cost[0] * 1e6 / (4.0 * cost[1]) / 5.0 / 2.0, 2, self.krylov)) if self.krylov else 0

    def _gmres(self, A, b, at, settled, z):
        """GMRES on A z = b from ``z`` (the last step's answer), right-preconditioned by the last factorisation and
        restarted from the true residual r, until :meth:`__call__`'s ``settled`` or |r| <= :data:`FORCING` |r_0|
        (an inexact Newton step: r_0 is the Newton residual after a full step); None after ``krylov`` iterations.
        The open rows' y is set to its exact 0 after each cycle (their rows are -y_a = 0, coupled to nothing); not
        in the preconditioner, whose closed rows would otherwise keep the rows that opened since closed in every
        Krylov vector."""
        open_rows = self.n + np.flatnonzero(~at)
        precondition = self._last.solve
        r = b - A @ z
        goal, budget = (LOOSE if self._budget >= CHEAP else FORCING) * np.linalg.norm(r), self._budget
        while True:
            beta = np.linalg.norm(r)
            if beta <= goal or settled(z, r):
                self.exact = bool(settled(z, r))
                return z
            if budget <= 0:
                return None
            k = budget
            V, Z = np.zeros((k + 1, len(b))), np.zeros((k, len(b)))
            H, cs, sn, e = np.zeros((k + 1, k)), np.zeros(k), np.zeros(k), np.zeros(k + 1)
            V[0], e[0] = r / beta, beta
            for j in range(k):
                Z[j] = precondition(V[j])
                w = A @ Z[j]
                for i in range(j + 1):                       # modified Gram-Schmidt
                    H[i, j] = w @ V[i]
                    w -= H[i, j] * V[i]
                H[j + 1, j] = np.linalg.norm(w)
                if H[j + 1, j] > 0.0:
                    V[j + 1] = w / H[j + 1, j]
                for i in range(j):                           # the earlier rotations, then this one's
                    H[i, j], H[i + 1, j] = cs[i] * H[i, j] + sn[i] * H[i + 1, j], -sn[i] * H[i, j] + cs[i] * H[i + 1, j]
                rho = np.hypot(H[j, j], H[j + 1, j])
                cs[j], sn[j] = (1.0, 0.0) if rho == 0.0 else (H[j, j] / rho, H[j + 1, j] / rho)
                H[j, j], H[j + 1, j] = rho, 0.0
                e[j], e[j + 1] = cs[j] * e[j], -sn[j] * e[j]
                self.iterations += 1
                budget -= 1
                if abs(e[j + 1]) <= max(0.5 * goal, 1e-15 * beta) or H[j, j] == 0.0:
                    break
            used = j + 1
            R = H[:used, :used]
            if np.any(np.diag(R) == 0.0):
                return None
            z = z + np.linalg.solve(np.triu(R), e[:used]) @ Z[:used]
            z[open_rows] = 0.0
            r = b - A @ z


def newton(problem, cache, settings, timings) -> RawResult:
    """The route of the module docstring for Signorini rows: Newton on (26) with the contact active set from the
    elastic predictor (the rows the rest state penetrates closed; a re-solve: the previous answer); the full route
    if the steps do not settle. ``iterations``: the Newton steps (systems solved)."""
    from .signorini import full

    m = len(problem.g)
    warm = settings.warm_start and cache.active is not None       # (warm_start=False: every load from the rest)
    start = cache.active if warm else np.asarray(problem.g) < 0
    raw = _steps(problem, cache, settings, timings, RowLaws.uniform(Signorini(), m), np.zeros(m), start)
    if raw is None:
        log.info("the Newton steps on the nonlinear mixed system did not settle (a singular step, a revisited active "
                 "set or a stall); the full route answers instead")
        raw = full(problem, cache, settings, timings)
        raw.route = Route.NEWTON_FELL_BACK
    return raw


def compliance(problem, cache, settings, timings) -> RawResult:
    """The route of the module docstring for a normal-compliance law on some rows (docs/formulation.md §10): the
    same Newton steps with the law's forces w p(r) and their derivative in the tangent, the rows with a
    penetration limit (and Signorini rows) in the active set, from the rest state. No other route poses a
    compliance law beside a non-quadratic energy: steps that do not settle raise SolverError. ``raw.z``: the
    limit reactions (None without a limit)."""
    law, w = problem.scaled_law, problem.weights
    raw = _steps(problem, cache, settings, timings, law, w, None)
    if raw is None:
        raise SolverError("the Newton steps on the nonlinear mixed system with the compliance law did not settle (a "
                          "singular step, a revisited active set or a stall), and no other route poses a compliance "
                          "law beside a non-quadratic energy: use a linear material, or the Signorini law")
    if law.limited.any():
        raw.y, raw.z = release_held(raw.y, raw.z, problem.held_rows)
    else:
        raw.z = None
    return raw


def _steps(problem, cache, settings, timings, law, weights, start):
    """The Newton steps of :func:`~cvxcontact.backends.finish.solve_sparse_compliance` for the rows' ``law`` with
    their ``weights`` from the rest state and the active set ``start`` (None: the rows at or past their limit
    there), or from the previous answer of this geometry: a RawResult, or None if they do not settle."""
    t0 = time.perf_counter()
    op, G, widths = mixed_system(problem)
    free = ~problem.held_rows
    solver, last = cache.own.get("newton"), cache.own.get("newton_answer")
    if solver is None:
        pattern = op.pattern()
        if np.any(np.asarray(law.stiffness) > 0):              # the law's G^T D G beside the tangent
            pattern = pattern + abs(G).T @ abs(G)
        solver = cache.own["newton"] = TangentSolver(pattern, G, settings.factorization)
    secant, key = SECANT, load_key(problem)
    if settings.warm_start and last is not None and last[2] == key:
        x, active, _, y, z = (np.array(a) for a in last)     # this load's answer: its bits, no step (a step
        out = (x, y, z, active, 0, [])                       # from it would move it by its rounding)
    else:
        if settings.warm_start and last is not None:
            x0, start = last[:2]                             # the previous answer of this geometry (another
            secant = 0                                       # load; near the answer: Newton's tangent)
        else:                                                # the elastic predictor: the rest state, from what a
            x0 = np.zeros(G.shape[1])                        # fresh solver holds (no step's factor or answer)
            solver.restart()
        out = solve_sparse_compliance(op, G, problem.g, weights, law, x0, None if start is None else start & free,
                                      solve=solver, early=EARLY, armijo=ARMIJO, line=LINE, secant=secant)
    timings["newton"] = time.perf_counter() - t0
    if isinstance(out, Declined):
        cache.own.pop("newton_answer", None)
        return None
    x, y, z, active, steps, history = out
    log.info("Newton on (26), no interior point: %d steps (%d factorisations, %d GMRES iterations in all), relative "
             "residuals %s", steps, solver.factorizations, solver.iterations, ", ".join(f"{h:.1e}" for h in history))
    cache.active = active
    cache.own["newton_answer"] = (np.array(x), np.array(active), key, np.array(y), np.array(z))   # (copies: the
    #                                                                     answer's fields view x)
    u, phi, _ = unstacked(problem, x, widths)
    return RawResult(u=u, phi=phi, y=y, z=z, active=active, polished=True, iterations=steps, method="newton",
                     route=Route.NEWTON_DIRECT, finish=Finish.NEWTON_BULK, factorization=solver.kind)
