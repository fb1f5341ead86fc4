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
from .result import Finish, RawResult, Route

__all__ = ["TangentSolver", "compliance", "newton"]

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
    else SuperLU without pivoting in the quasi-definite order :func:`~cvxcontact.backends.sparse.ordering`; each
    step is one numeric factorisation. Then up to three steps of iterative refinement against the matrix itself,
    while a row's residual exceeds 1e-14 of its terms.
    None if it is singular, x not finite or the residual above ``residual`` max|b| (as
    :func:`~cvxcontact.backends.full.solve_mixed`). ``factorizations`` counts the numeric factorisations,
    ``analyses`` the analyses."""

    def __init__(self, pattern, G, factorization: str = "auto", residual: float = 1e-8):
        from .factor import resolve

        P, Gc = sp.coo_matrix(pattern), sp.coo_matrix(G)
        self.n, self.m = n, m = P.shape[0], G.shape[0]
        self.kind, self.residual = resolve(factorization), residual
        self._G = (Gc.row, Gc.col, Gc.data)
        rows = np.concatenate([P.row, np.arange(n), n + Gc.row, Gc.col, n + np.arange(m)])
        cols = np.concatenate([P.col, np.arange(n), Gc.col, n + Gc.row, n + np.arange(m)])
        self._frame = (rows, cols)                  # the fixed pattern, as zeros (added to every step's values)
        self._perm = self._pardiso = None
        self.factorizations = self.analyses = self.refinements = 0

    def matrix(self, K, at) -> sp.csc_matrix:
        """The system of every row for the tangent block ``K`` (n x n) and the closed rows ``at``, on the pattern."""
        n, m = self.n, self.m
        K = sp.coo_matrix(K)
        gr, gc, gv = self._G
        on = np.asarray(at, dtype=bool)
        coupling = np.where(on[gr], gv, 0.0)
        rows, cols = self._frame
        M = sp.coo_matrix((np.concatenate([K.data, np.zeros(len(rows)), coupling, coupling,
                                           np.where(on, 0.0, -1.0)]),
                           (np.concatenate([K.row, rows, n + gr, gc, n + np.arange(m)]),
                            np.concatenate([K.col, cols, gc, n + gr, n + np.arange(m)]))),
                          shape=(n + m, n + m)).tocsc()
        M.sort_indices()
        return M

    def _factor(self, M):
        from .factor import PardisoSymmetric
        from .sparse import factorize, ordering

        if self._pardiso is None and self._perm is None:
            self.analyses += 1
            if self.kind == "pardiso":
                try:
                    self._pardiso = PardisoSymmetric(M)
                except SolverError:
                    self.kind = "superlu"              # refused: SuperLU from here on
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
        factor = self._factor(A)
        if factor is None:
            return None
        z = factor.solve(bb)
        scale = max(np.abs(bb).max(initial=0.0), np.finfo(float).tiny)
        absA, tiny = abs(A), np.finfo(float).tiny
        for _ in range(3):         # refined while a row's residual exceeds 1e-14 of its own terms
            r = bb - A @ z
            self.refinements += 1
            if not np.isfinite(r).all() or (np.abs(r) <= 1e-14 * np.maximum(absA @ np.abs(z) + np.abs(bb), tiny)).all():
                break
            z = z + factor.solve(r)
        if not np.isfinite(z).all() or (self.residual is not None
                                        and np.abs(A @ z - bb).max() > self.residual * scale):
            return None
        return np.concatenate([z[:n], z[n:][at]])


def newton(problem, cache, settings, timings) -> RawResult:
    """The route of the module docstring for Signorini rows: Newton on (26) with the contact active set from the
    elastic predictor (the rows the rest state penetrates closed; a re-solve: the previous answer); the full route
    if the steps do not settle. ``iterations``: the Newton steps (systems solved)."""
    from .signorini import full

    m = len(problem.g)
    start = cache.active if cache.active is not None else np.asarray(problem.g) < 0
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
    if settings.warm_start and last is not None:
        x0, start = last                                     # the previous answer of this geometry
    else:                                                    # the elastic predictor: the rest state
        x0 = np.zeros(G.shape[1])
    out = solve_sparse_compliance(op, G, problem.g, weights, law, x0, None if start is None else start & free,
                                  solve=solver, early=EARLY, armijo=ARMIJO)
    timings["newton"] = time.perf_counter() - t0
    if isinstance(out, Declined):
        cache.own.pop("newton_answer", None)
        return None
    x, y, z, active, steps, history = out
    log.info("Newton on (26), no interior point: %d steps, relative residuals %s", steps,
             ", ".join(f"{h:.1e}" for h in history))
    cache.active, cache.own["newton_answer"] = active, (x, active)
    u, phi, _ = unstacked(problem, x, widths)
    return RawResult(u=u, phi=phi, y=y, z=z, active=active, polished=True, iterations=steps, method="newton",
                     route=Route.NEWTON_DIRECT, finish=Finish.NEWTON_BULK, factorization=solver.kind)
