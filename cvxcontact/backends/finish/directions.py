"""A friction finish on dependent normal rows in 3D (:func:`fixed_directions`): Newton on the slipping rows'
directions, each step an exact finish of the normal and stuck rows by Lawson-Hanson.

Where the semismooth steps of :func:`~cvxcontact.backends.finish.friction.solve_friction` do not settle on linearly
dependent normal rows (the cut rounds of the P2 cones with friction, :func:`~cvxcontact.backends.friction.finish_on_nodes`:
a 3D box lifting at a corner, the nodal rows and cut points more than the nodes of X_h), the closed set cycles among
the normal rows while the stick-slip partition has settled (measured on the sheared box of
benchmarks/friction_p2_declines.py: the stuck set fixed from the first step, rows that open with a gap of rounding
and close with a tension, 50 steps and declined, then 50 more from the second start).

Here each step fixes the stick-slip partition of the point w_k (its state: stuck where |z_a| <= c_a, z = mu + r_t s)
and linearises a slipping row's law mu_a = c_a z_a / |z_a| at z_k: with t_a = z_k / |z_k|, k_a = c_a / |z_k| < 1
and P_a = I - t_a t_a^T, mu_a = c_a t_a + D_a s_a, D_a = k_a r_t / (1 - k_a) P_a (symmetric, positive
semidefinite), s_a = S_a x + s0_a. A stuck row's slip S_a x + s0_a = 0 is two opposed rows S_a x <= -s0_a,
-S_a x <= s0_a whose forces' difference is its tangential force. So the step is the mixed system with the matrix
T + S^T D S, the loads b - S^T (c t + D s0), the normal rows G x <= g and the stuck rows' pairs: rows that may be
dependent, solved exactly by :func:`~cvxcontact.backends.finish.dependent.independent_active_set` (Lawson-Hanson
on the forces: its passive rows independent, whatever the dependence; its steps on the rows with one factorisation
of the bodies per step of the directions, the set where they stop solved again to a componentwise backward error of
1e-12, refined, or by a sparse LU of the mixed system: measured on the non-matching boxes of benchmarks/friction_p2_declines.py, a sparse LU at
every one of Lawson-Hanson's steps took 114 s of CPU, 35 s so). It is Newton's step on the slipping rows'
directions (measured: changes 3e-1, 2e-3, 2e-5, 3e-9, 2e-14 of the scales), and the normal rows' active set is
Lawson-Hanson's at every step, so it does not cycle. The steps stop where the change is at most
:data:`DIRECTION_TOL` of the scales, or no longer halves with the residual at rounding (declined where the residual
has not halved in :data:`DIRECTION_STALL` steps); their answer then starts the
semismooth steps, whose acceptance (the active set repeated, the signs, the residual at rounding) is unchanged.
A capacity that depends on the normal force (Coulomb, D != 0) is lagged a step (the cut rounds' capacities are
given: Tresca's law at them).
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp

from ..factor import superlu
from .declined import Declined, Stop
from .dependent import independent_active_set, rows_kkt

__all__ = ["DIRECTION_ROUNDS", "DIRECTION_STALL", "DIRECTION_TOL", "fixed_directions"]

log = logging.getLogger(__name__)

DIRECTION_ROUNDS = 40
"""Steps of :func:`fixed_directions` at most (each a Lawson-Hanson finish; measured: 5 where they settle)."""

DIRECTION_STALL = 4
"""The steps of :func:`fixed_directions` end (declined) once this many in a row have not halved the least residual
so far: a stick-slip partition that flips between two sets, each step's point the other's start (measured: the
non-matching boxes of benchmarks/friction_p2_declines.py, one row at the stick-slip boundary, 64 and 65 stuck rows
in turn, the residual 2e-3 and 1e-13 to 4e-13 in turn, 40 steps; converging steps halve it at least every other
step)."""

DIRECTION_TOL = 1e-13
""":func:`fixed_directions` stops where its step changed no displacement by more than this times U and no force by
more than this times C (the finish's scales)."""


KKT_RESIDUAL = 1e-10
"""A step's mixed system counts as singular where its solution's residual exceeds this times the size of its terms
(max |rhs|, max |M| |s|): nearly parallel point rows (cut points closing in on one point) carry large opposite
forces, whose system is solved to rounding of those terms (measured 2.4e-8 of the right-hand side, 1.2e-16 of the
terms, on the box with a side held under OPENBLAS_CORETYPE=Prescott); Lawson-Hanson then opens a row of negative
force."""


def _checked_solve(M, rhs):
    """The solution of ``M s = rhs`` by SuperLU, or None where it fails or its residual exceeds
    :data:`KKT_RESIDUAL` times the size of its terms."""
    try:
        s = superlu(M).solve(rhs)
    except RuntimeError:
        return None
    if not np.isfinite(s).all() or np.abs(M @ s - rhs).max() > KKT_RESIDUAL * max(
            float(np.abs(rhs).max(initial=0.0)), float((abs(M) @ np.abs(s)).max(initial=0.0)), np.finfo(float).tiny):
        return None
    return s


def fixed_directions(system, w):
    """The steps of the module docstring from ``w`` = (x, y, mu) (stacked as in
    :func:`~cvxcontact.backends.finish.friction.solve_friction`, scaled) on ``system`` (that finish's system: its
    T, b, G, g, friction rows, scales C, U and state): the point (x, y, mu) they reach, stacked as ``w``, or a
    :class:`~cvxcontact.backends.finish.declined.Declined` (a Lawson-Hanson finish declined, or
    :data:`DIRECTION_ROUNDS` steps that did not settle)."""
    fr, C, U = system.fr, system.C, system.U
    free = np.flatnonzero(system.free)
    R, nc, last, best, stalled = len(system.g), fr.nc, None, np.inf, 0
    for k in range(1, DIRECTION_ROUNDS + 1):
        x, y, mu = system.split(w)
        _, stuck, z, c = system.state(w)
        size = np.maximum(np.linalg.norm(z, axis=1), np.finfo(float).tiny)
        slipping = fr.moved & ~stuck
        t = np.where(fr.moved[:, None], z / size[:, None], fr.held)
        kk = np.where(slipping, c / size, 0.0)
        P = np.eye(nc)[None] - t[:, :, None] * t[:, None, :]
        D = np.where(slipping[:, None, None], (kk * system.r / (1.0 - kk))[:, None, None] * P, 0.0)
        Dm = sp.block_diag(list(D), format="csr")
        f = np.where((slipping | ~fr.moved)[:, None], c[:, None] * t, 0.0).ravel()   # the force at s = s(x_k)
        T = (system.T + fr.S.T @ Dm @ fr.S).tocsr()
        held = (stuck[:, None] & ~fr.fixed).ravel()                  # the stuck rows' moved components
        Sh, sh = fr.S[held], fr.s0[held]
        GL = sp.vstack([system.G[free], Sh, -Sh]).tocsr()
        cL = np.concatenate([system.g[free], -sh, sh])
        mh = mu.ravel()[held]
        y0 = np.concatenate([np.maximum(y[free], 0.0), np.maximum(mh, 0.0), np.maximum(-mh, 0.0)])
        kkt = rows_kkt(T, system.b - fr.S.T @ (f + Dm @ fr.s0), GL, cL, _checked_solve)
        out = independent_active_set(kkt, cL, y0, y0 > 0, purify=False)
        if isinstance(out, Declined):
            log.info("friction finish, directions: step %d declined: %s", k, out)
            return out
        (x_new, yL), _, _ = out
        y_new = np.zeros(R)
        y_new[free] = yL[:len(free)]
        flat = f + Dm @ (fr.S @ x_new + fr.s0)
        flat[held] = yL[len(free):len(free) + len(sh)] - yL[len(free) + len(sh):]
        flat = np.where(np.repeat(stuck, nc) & fr.fixed.ravel(), 0.0, flat)
        w_new = np.concatenate([x_new, y_new, flat])
        change = max(float(np.abs(x_new - x).max(initial=0.0)) / U, float(np.abs(y_new - y).max(initial=0.0)) / C,
                     float(np.abs(flat - mu.ravel()).max(initial=0.0)) / C)
        merit = float(np.linalg.norm(system.residual(w_new)))
        log.info("friction finish, directions: step %d, %d stick, %d slip, change %.1e, residual %.1e", k,
                 stuck.sum(), slipping.sum(), change, merit)
        w = w_new
        if change <= DIRECTION_TOL or (merit <= 1e-13 and last is not None and change > 0.5 * last):
            return w
        last = change
        best, stalled = (merit, 0) if merit <= 0.5 * best else (best, stalled + 1)
        if stalled >= DIRECTION_STALL:
            log.info("friction finish, directions: the residual not halved in %d steps (least %.1e)", stalled, best)
            return Declined(Stop.MAX_ITER, "the steps on the slipping rows' directions stalled")
    return Declined(Stop.MAX_ITER, "the steps on the slipping rows' directions did not settle")
