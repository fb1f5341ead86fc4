"""Krylov pieces of the AMG route (:mod:`cvxcontact.backends.amg`) that know nothing of contact: restarted GMRES
with kept preconditioned vectors and a settled stop (:func:`gmres`), one V-cycle of a pyamg hierarchy as an operator
(:func:`v_cycle`), and the seeded random state of a hierarchy's set-up (:func:`seeded`)."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import scipy.sparse.linalg as spla

__all__ = ["GMRES_RESTART", "gmres", "seeded", "v_cycle"]

GMRES_RESTART = 100
"""Krylov vectors kept by GMRES (piezoelectric bodies) before it restarts: (GMRES_RESTART + 1) N doubles at
most."""


def gmres(K, b, x0, M, rtol: float, restart: int = GMRES_RESTART, maxiter: int = 2000, callback=None,
          keep: int = 0, settled=None) -> np.ndarray:
    """x with ||b - K x|| <= rtol ||b|| (2-norms) by right-preconditioned restarted GMRES (Saad, Iterative
    Methods for Sparse Linear Systems, 2003, Alg. 9.5; classical Gram-Schmidt applied twice), from ``x0``,
    ``M`` the preconditioner (a fixed linear operator). Right preconditioning minimises the true residual, so
    the stopping test is on ||b - K x|| itself (checked on the recomputed residual at each restart). Returns
    the last iterate if the test is not met after ``maxiter`` iterations or three restarts whose estimate met it
    (rounding: the caller checks the residual). ``callback()`` is called once per iteration.

    ``keep``: the first ``keep`` preconditioned basis vectors z_j = M v_j of a cycle are kept (``keep`` N doubles
    more), so that its update x += M V y = Z y + M (V[keep:] y[keep:]) applies M only to the basis beyond them:
    a cycle of at most ``keep`` iterations (a loose solve, :data:`STEP_RTOLS`) costs one application of M per
    iteration instead of one more. The same x in exact arithmetic (M linear).

    ``settled(x)``: asked after each iteration k <= ``keep`` of the first cycle about its iterate x_k = x0 + Z[:k]
    y_k (cheap: no application of M); if it answers True, x_k is returned at once, whatever its residual (a loose
    solve whose verdict has settled, :data:`SETTLE`; the caller knows the test was not met)."""
    n = b.shape[0]
    x = np.array(x0, dtype=float)
    target = rtol * np.linalg.norm(b)
    V = np.empty((restart + 1, n))                  # the Arnoldi basis (pages are touched only when used)
    keep = min(max(int(keep), 0), restart)
    Z = np.empty((keep, n))                         # M V[:keep] of the current cycle
    done, short = 0, 0
    while done < maxiter:
        r = b - K @ x
        beta = np.linalg.norm(r)
        if beta <= target or short == 3:            # met, or the recurrence's estimate met it 3 times but
            break                                   # the recomputed residual did not (rounding: give up)
        V[0] = r / beta
        H = np.zeros((restart + 1, restart))
        cs, sn = np.zeros(restart), np.zeros(restart)
        g = np.zeros(restart + 1)
        g[0] = beta
        k = 0
        while k < restart and done < maxiter:
            z = M @ V[k]
            if k < keep:
                Z[k] = z
            w = K @ z
            h = V[:k + 1] @ w
            w -= V[:k + 1].T @ h
            h2 = V[:k + 1] @ w
            w -= V[:k + 1].T @ h2
            H[:k + 1, k] = h + h2
            H[k + 1, k] = hn = np.linalg.norm(w)
            if hn > 0.0:
                V[k + 1] = w / hn
            for i in range(k):                      # the previous Givens rotations on the new column
                H[i, k], H[i + 1, k] = cs[i] * H[i, k] + sn[i] * H[i + 1, k], -sn[i] * H[i, k] + cs[i] * H[i + 1, k]
            d = np.hypot(H[k, k], H[k + 1, k])
            cs[k], sn[k] = (H[k, k] / d, H[k + 1, k] / d) if d > 0.0 else (1.0, 0.0)
            H[k, k], H[k + 1, k] = d, 0.0
            g[k], g[k + 1] = cs[k] * g[k], -sn[k] * g[k]
            k += 1
            done += 1
            if callback is not None:
                callback()
            if abs(g[k]) <= target or hn == 0.0:      # converged, or the Krylov space is invariant
                break
            if settled is not None and k <= keep and done == k and np.all(np.diag(H[:k, :k]) != 0.0):
                xk = x + Z[:k].T @ np.linalg.solve(np.triu(H[:k, :k]), g[:k])
                if settled(xk):
                    return xk
        if k == 0:
            break
        short += abs(g[k]) <= target
        y = np.linalg.solve(np.triu(H[:k, :k]), g[:k]) if np.all(np.diag(H[:k, :k]) != 0.0) else \
            np.linalg.lstsq(np.triu(H[:k, :k]), g[:k], rcond=None)[0]
        j = min(k, keep)
        x += Z[:j].T @ y[:j]
        if k > j:
            x += M @ (V[j:k].T @ y[j:])
    return x


def v_cycle(ml) -> spla.LinearOperator:
    """One V-cycle of the hierarchy ``ml`` (a pyamg multilevel solver: its ``levels``, each with ``A``, ``R``,
    ``P`` and smoothers, and ``coarse_solver``) from a zero guess, as an operator: the arrays of
    ``ml.aspreconditioner(cycle="V")`` (pyamg's cycle: pre-smoothing, the coarse correction of the restricted
    residual, post-smoothing, level by level), without the two residual norms ||b - A x|| of the finest level
    that pyamg's ``solve`` computes around its one cycle (its stopping test, read by no preconditioner): two
    finest-level products per application: 13.7-14.5 % of a displacement V-cycle's CPU seconds at 1.5e5 unknowns,
    11-14 % of a two_boxes "sigma1" solve's at 1.5e5 and 4.1e5 (benchmarks/results/bench3d_scale.md)."""
    levels, coarse = ml.levels, ml.coarse_solver

    def cycle(lvl, x, b):
        A = levels[lvl].A
        levels[lvl].presmoother(A, x, b)
        coarse_b = levels[lvl].R @ (b - A @ x)
        coarse_x = np.zeros_like(coarse_b)
        if lvl == len(levels) - 2:
            coarse_x[:] = coarse(levels[-1].A, coarse_b)
        else:
            cycle(lvl + 1, coarse_x, coarse_b)
        x += levels[lvl].P @ coarse_x
        levels[lvl].postsmoother(A, x, b)

    def apply(b):
        b = np.ravel(np.asarray(b, dtype=np.result_type(b, levels[0].A.dtype)))   # as pyamg's solve: upcast
        if len(levels) == 1:
            return coarse(levels[0].A, b)
        x = np.zeros_like(b)
        cycle(0, x, b)
        return x

    return spla.LinearOperator(levels[0].A.shape, matvec=apply, dtype=levels[0].A.dtype)


@contextmanager
def seeded(seed: int = 0):
    """NumPy's global random state seeded for the block (and restored after it): pyamg starts its spectral-radius
    estimates from ``np.random.rand`` vectors, so an unseeded set-up gives a hierarchy, and answers, that differ
    from run to run (measured: 5e-13 relative on two_boxes); the caller's random stream is left as it was."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(state)
