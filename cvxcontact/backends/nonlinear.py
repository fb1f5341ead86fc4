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
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import structural_rank

from ..contact.laws import RowLaws, Signorini
from .finish import solve_sparse_compliance
from .mixed import mixed_system, stacked, unstacked
from .result import Finish, RawResult, Route

__all__ = ["TangentSolver", "newton"]

log = logging.getLogger(__name__)


class TangentSolver:
    """x with M x = b for the Newton steps' systems [[T + G^T D G, G_L^T], [G_L, 0]] of one problem: SuperLU with
    the column order of minimum degree on M^T + M computed for the first pattern and reused while the pattern
    (the tangent's and the closed rows L) is the same, two steps of iterative refinement; None if M is singular,
    x not finite or the residual above ``residual`` max|b| (as :func:`~cvxcontact.backends.full.solve_mixed`).
    ``factorizations`` counts the numeric factorisations, ``orderings`` the orderings computed."""

    def __init__(self, residual: float = 1e-8):
        self.residual = residual
        self._key, self._perm = None, None
        self.factorizations = self.orderings = 0

    def __call__(self, M, b):
        M = sp.csc_matrix(M)
        M.sort_indices()
        key = (M.shape, M.indptr.tobytes(), M.indices.tobytes())
        try:
            if key != self._key:
                if structural_rank(M) < M.shape[0]:      # (SuperLU can corrupt memory on these: solve_mixed)
                    return None
                lu = spla.splu(M, permc_spec="MMD_AT_PLUS_A")
                self._key, self._perm = key, lu.perm_c
                self.orderings += 1
            else:
                p = self._perm
                lu = _Permuted(spla.splu(M[p][:, p].tocsc(), permc_spec="NATURAL"), p)
        except RuntimeError:
            return None
        self.factorizations += 1
        x = lu.solve(b)
        for _ in range(2):
            x += lu.solve(b - M @ x)
        if not np.isfinite(x).all():
            return None
        if self.residual is not None and np.abs(M @ x - b).max() > self.residual * max(np.abs(b).max(),
                                                                                       np.finfo(float).tiny):
            return None
        return x


class _Permuted:
    """The LU of M[p][:, p] with ``solve`` in M's order."""

    def __init__(self, lu, p):
        self.lu, self.p = lu, p

    def solve(self, b):
        z = np.empty_like(b)
        z[self.p] = self.lu.solve(np.ascontiguousarray(b[self.p]))
        return z


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
    solver = cache.own.setdefault("newton", TangentSolver())
    out = solve_sparse_compliance(op, G, problem.g, np.zeros(m), RowLaws.uniform(Signorini(), m),
                                  stacked(lin.u, lin.phi), lin.active & ~problem.held_rows, solve=solver)
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
