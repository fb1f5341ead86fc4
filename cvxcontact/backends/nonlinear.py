"""The fast route of a non-quadratic bulk energy (the paper's nonlinear A, e.g. Hencky; docs/formulation.md §19):
Newton on the nonlinear mixed system (26) with the contact active set, from the linear problem's answer, no
interior point and no CVXPY program.

1. the linear start: the same scene with every body's initial tangent (its ``Kuu``, the material's moduli at zero
   strain) solved by the sparse route's active-set steps (:func:`~cvxcontact.backends.signorini.sparse`: exact,
   its factor kept in the cache for re-solves);
2. from its displacements and active set, the semismooth Newton steps of the finish of the full route
   (:func:`~cvxcontact.backends.finish.solve_sparse_compliance` on :class:`~cvxcontact.backends.mixed.MixedEnergy`,
   every row a Signorini row): damped on the energy, inside primal-dual active-set steps on the contact rows,
   each step one sparse solve of the tangent system with the fill-reducing order of the first
   (:class:`TangentSolver`);
3. if those steps do not settle (the active-set steps revisit a set, a singular step, or a stall above
   rounding), the full route (:func:`~cvxcontact.backends.signorini.full`: the interior point, then the same
   Newton finish) answers instead, ``sol.info.route`` :attr:`~cvxcontact.backends.result.Route.NEWTON_FELL_BACK`
   and the reason logged: never an unfinished answer in its place.

The answer is then checked by the read-back like every other ((26)-(27) with the nonlinear internal forces).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import structural_rank

from ..contact.laws import RowLaws, Signorini
from ..errors import SolverError
from .finish import solve_sparse_compliance
from .mixed import mixed_system, stacked, unstacked
from .result import Finish, RawResult, Route

__all__ = ["TangentSolver", "newton"]

log = logging.getLogger(__name__)

EARLY = 1.0
"""The relative residual of (26) below which the Newton steps check the contact rows' signs and leave a set they
reject (:func:`~cvxcontact.backends.finish.solve_sparse_compliance`'s ``early``): 1, i.e. after every full step,
the primal-dual active-set (semismooth Newton) update of the rows. The linear answer's active set is rarely the
plastic one; converging on each wrong set first cost more steps (measured, the circle pressed into a block of
26,082 unknowns: 16 Newton steps with 1e-4, 21 checking converged sets only, 9 with 1; a revisited set ends in
the full route, never in a wrong answer)."""


class TangentSolver:
    """x with M x = b for the Newton steps' systems M = [[T + G^T D G, G_L^T], [G_L, 0]] (the unknowns x, then the
    closed rows L) of one problem, each put on one sparsity: ``pattern`` (n x n) ones wherever the tangent may be
    non-zero (:meth:`~cvxcontact.backends.mixed.MixedEnergy.pattern`; a product drops the moduli's zeros, which
    would change the pattern from step to step), every diagonal entry stored. Factorised as the sparse route's
    systems (:mod:`cvxcontact.backends.sparse`):
    with ``factorization="pardiso"`` one PARDISO analysis per pattern (:class:`~cvxcontact.backends.factor.
    PardisoSymmetric`), else SuperLU without pivoting in the sparse route's quasi-definite order
    (:func:`~cvxcontact.backends.sparse.ordering`, computed once per pattern); the pattern changes only with L.
    Then up to three steps of iterative refinement against M itself. None if M is singular, x not finite or the
    residual above ``residual`` max|b| (as :func:`~cvxcontact.backends.full.solve_mixed`). ``factorizations``
    counts the numeric factorisations, ``analyses`` the orderings (one per pattern)."""

    def __init__(self, pattern, factorization: str = "auto", residual: float = 1e-8):
        from .factor import resolve

        P = sp.coo_matrix(pattern)
        self.n, self.kind, self.residual = P.shape[0], resolve(factorization), residual
        diag = np.arange(self.n)
        self._rows, self._cols = np.concatenate([P.row, diag]), np.concatenate([P.col, diag])
        self._key = self._perm = self._pardiso = None
        self.factorizations = self.analyses = 0

    def _factor(self, M):
        from .factor import PardisoSymmetric
        from .sparse import factorize, ordering

        key = (M.shape, M.indptr.tobytes(), M.indices.tobytes())
        if key != self._key:
            if structural_rank(M) < M.shape[0]:       # (SuperLU can corrupt memory on these: solve_mixed)
                return None
            self._key, self._perm, self._pardiso = key, None, None
            self.analyses += 1
            if self.kind == "pardiso":
                try:
                    self._pardiso = PardisoSymmetric(M)
                except SolverError:
                    self.kind = "superlu"              # refused: SuperLU from here on
            if self._pardiso is None:
                self._perm = ordering(M, np.arange(self.n, M.shape[0]))
        self.factorizations += 1
        if self._pardiso is not None:
            return self._pardiso.factor(M)
        try:
            return factorize(M, self._perm)
        except RuntimeError:
            return None

    def __call__(self, M, b):
        M, N = sp.coo_matrix(M), M.shape[0]          # on the fixed pattern, every diagonal entry stored (zeros kept)
        extra = np.arange(self.n, N)
        M = sp.coo_matrix((np.concatenate([M.data, np.zeros(len(self._rows) + len(extra))]),
                           (np.concatenate([M.row, self._rows, extra]), np.concatenate([M.col, self._cols, extra]))),
                          shape=M.shape).tocsc()
        M.sort_indices()
        factor = self._factor(M)
        if factor is None:
            return None
        x = factor.solve(b)
        scale = max(np.abs(b).max(initial=0.0), np.finfo(float).tiny)
        for _ in range(3):
            r = b - M @ x
            if not np.isfinite(r).all() or np.abs(r).max(initial=0.0) <= 1e-15 * scale:
                break
            x = x + factor.solve(r)
        if not np.isfinite(x).all():
            return None
        if self.residual is not None and np.abs(M @ x - b).max() > self.residual * scale:
            return None
        return x


def newton(problem, cache, settings, timings) -> RawResult:
    """The route of module docstring for a Signorini problem with a non-quadratic bulk energy: the linear answer,
    then Newton on (26) with the contact active set; the full route if the steps do not settle. ``iterations``:
    the systems solved (the linear start's and the Newton steps)."""
    from .signorini import full, sparse

    t0 = time.perf_counter()
    lin = sparse(problem, cache, settings, timings)          # the initial tangent's answer (exact, linear)
    timings["linear_start"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    op, G, widths = mixed_system(problem)
    m = len(problem.g)
    x0 = stacked(lin.u, lin.phi)
    solver = cache.own.get("newton")
    if solver is None or solver.n != len(x0):
        solver = cache.own["newton"] = TangentSolver(op.pattern(), settings.factorization)
    out = solve_sparse_compliance(op, G, problem.g, np.zeros(m), RowLaws.uniform(Signorini(), m),
                                  x0, lin.active & ~problem.held_rows, solve=solver, early=EARLY)
    timings["newton"] = time.perf_counter() - t1
    if out is None:
        why = "the Newton steps on the nonlinear mixed system did not settle (a singular step, a cycle or a stall)"
        log.info("%s from the linear answer; the full route answers instead", why)
        raw = full(problem, cache, settings, timings)
        raw.route = Route.NEWTON_FELL_BACK
        return raw
    x, y, _, active, steps, history = out
    log.info("Newton from the linear answer: %d steps, relative residuals %s", steps,
             ", ".join(f"{h:.1e}" for h in history))
    u, phi, _ = unstacked(problem, x, widths)
    cache.active = active
    return RawResult(u=u, phi=phi, y=y, active=active, polished=True, iterations=lin.iterations + steps,
                     method="newton", route=Route.NEWTON_FROM_LINEAR, finish=Finish.NEWTON_BULK,
                     factorization=lin.factorization)
