"""Tresca friction under the 3D P2 cones finished at the exact tangency points (docs/howto/friction.md, "Friction
under the P2 cones"): the 3D counterpart of :func:`~cvxcontact.backends.friction._tangency_polish`.

The cuts (:func:`~cvxcontact.backends.friction.finish_on_nodes`) hold q = [u_nu] - g <= 0 at a growing set of fixed
points of each element and stop where every element's maximum is at most ``CONE_ROUNDING`` of the displacements:
their fields are exact to about the square root of that (measured on the 3D boxes lifting at a corner:
benchmarks/results/friction_p2_tangency3d.md). What "exact" means for the 3D cones is the frictionless cones'
(docs/formulation.md §16, §18): on each triangle q is one quadratic, and where the contact ends inside it, q's
maximum over the triangle (or one of its edges) is 0 at an isolated point L* with q's Hessian negative definite on
that sub-simplex; the condition there is m(Q) = 0, m the maximum, smooth with the point row at L* for its gradient
(the tangency Newton, :func:`~cvxcontact.backends.tangency.tangency_newton`); vertex contacts are nodal rows. The
contact zone, a region bounded by a curve in 3D, is then exact where that curve leaves one isolated point of contact
per touching triangle or edge (a curved obstacle whose zone lies inside a few elements: measured on a sphere pressed
into a P2 block, tests/test_friction_p2_tangency3d.py). Where a face pressed and sheared on a plane lifts at a corner
(the 3D boxes of tests/friction_box_scenes.py), the touching triangles' q vanishes along a whole line across each
(q = -(v . L)^2: Q of rank 1, a ridge; its form's second eigenvalue 1.5e-4 of the first at most at the cuts' answer
of the sheared box), neither an isolated point nor an edge: the tangency Newton reads those triangles as flat, holds
their lifted nodes down and does not converge. There :func:`~cvxcontact.backends.ridges.ridge_newton` runs with the
same energy and rows (q = -(w_h)^2, w_h P1 on the ridge triangles, and the tangency rows m(Q) = 0 of the
triangles beside them that touch at isolated points, in one Newton system: the held-side box; accepted where its
forces are a non-negative measure on w_h's zero lines and the points), then the same acceptance below; where both
decline the cuts' answer stands, labelled declined where the contact ends inside a triangle (not polished,
``info.declined`` this module's reason and a :class:`~cvxcontact.errors.ResidualWarning`: it stands about 1e-6 of
the displacements from the exact answer; benchmarks/results/friction_p2_tangency3d.md; :func:`kept`).

With the stick-slip partition of the cuts' answer fixed, Tresca's law in 3D is: a stuck row's slip is 0 (two
linear rows, their multipliers its force), a slipping row's force is c_a s_a / |s_a| (the gradient of c_a |s_a|,
smooth while the slip does not vanish: :class:`~cvxcontact.backends.mixed.SlidingEnergy`). So the tangency Newton
with that energy on (26) finishes it. Accepted where the answer keeps the partition (every stuck row's force within
its capacity, every slipping row's slip turned by less than a right angle and not vanished) and balances (26) with
its own forces; else a :class:`~cvxcontact.backends.finish.declined.Declined` saying why (the cuts' answer
stands, labelled declined by the caller)."""

from __future__ import annotations

import logging
import time
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from .cones import MIXED_CUT_TOL
from .finish.declined import Declined, Stop
from .frictionrows import balances, moved_components, prescribed_row_slip, slip_matrix
from .full import mixed_kkt
from .mixed import HeldEnergy, SlidingEnergy, mixed_system, stacked, unstacked
from .result import Finish, Route
from .ridges import ridge_newton
from .tangency import tangency_newton

__all__ = ["kept", "row_slack", "tangency_polish"]

log = logging.getLogger(__name__)

WHERE = "the Newton at the tangency points after the 3D friction cuts"
"""The finish a decline of this module names."""


def tangency_polish(problem, trial, timings, capacity, floor: float, balance_tol: float, capacity_tol: float):
    """The cuts' answer ``trial`` (its ``points`` the cut points and forces) of Tresca's law at the capacities
    ``capacity`` (R,) (scaled) finished at the exact tangency points in 3D (module docstring); a friction row whose
    slip is at most ``floor`` times the largest displacement is stuck, the others slip along their slip. Accepted
    where the partition holds (a stuck row's force within its capacity to ``capacity_tol`` of the largest, a
    slipping row's slip above ``floor``) and (26) balances with the answer's own forces to ``balance_tol`` of its
    largest term. Returns the finished answer (a new :class:`~cvxcontact.backends.result.RawResult`) or the
:class:`~cvxcontact.backends.finish.declined.Declined` saying why."""
    t0 = time.perf_counter()
    try:
        return _polish(problem, trial, capacity, floor, balance_tol, capacity_tol)
    finally:
        timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0


def _polish(problem, trial, capacity, floor, balance_tol, capacity_tol):
    R, n_c, c = problem.E.shape[0], problem.term.data.components, np.asarray(capacity, dtype=float)
    op, _, widths = mixed_system(problem)
    rows = np.flatnonzero(problem.rows.frictional)
    order = (rows[:, None] + R * np.arange(n_c)[None, :]).ravel()        # row a, component j at a n_c + j
    S = slip_matrix(problem, order, widths)
    s0 = prescribed_row_slip(problem)[order]
    x0 = stacked(trial.u, trial.phi, trial.taus)
    n, U = len(x0), float(np.abs(x0).max(initial=0.0))
    slip = (S @ x0 + s0).reshape(-1, n_c)
    size = np.linalg.norm(slip, axis=1)
    moved = moved_components(problem, rows)                              # (k, n_c)
    stuck = moved.any(axis=1) & (size <= floor * U)
    sliding = ~stuck & (size > 0)             # a row no unknown moves slips along its prescribed slip, if any
    held_comp = (stuck[:, None] & moved).ravel()                         # the stuck rows' moved components
    slide_comp = np.repeat(sliding, n_c)
    held = S[held_comp]
    energy = HeldEnergy(SlidingEnergy(op, S[slide_comp], s0[slide_comp], c[rows][sliding], n_c), np.zeros(n),
                        held, s0[held_comp])
    kkt = mixed_kkt(list(problem.blocks), problem.E, problem.g, translations=list(problem.translations))
    G = sp.csr_matrix(kkt.rows)
    # the unknowns extended by the stuck rows' multipliers (kkt's matrix and loads are the energy's, not read)
    aug = SimpleNamespace(matrix=kkt.matrix, rhs=kkt.rhs,
                          rows=sp.hstack([G, sp.csr_matrix((G.shape[0], held.shape[0]))]).tocsr())
    mu0 = trial.tangential.reshape(n_c, R)[:, rows].T.ravel()[held_comp]
    out = tangency_newton(aug, problem.lines.cone[0], problem.g, trial.beta, np.concatenate([x0, mu0]),
                          held=problem.held_rows, tol=MIXED_CUT_TOL, departure=problem.departure,
                          points=trial.points, energy=energy)
    if isinstance(out, Declined):                # contact along lines across the triangles: the ridges' Newton
        ridge = ridge_newton(energy, G, problem.g, problem.lines.cone[0], np.concatenate([x0, mu0]), n, MIXED_CUT_TOL)
        if isinstance(ridge, Declined):
            log.info("the Newton at the tangency points after the 3D friction cuts declined: %s; on the ridges: %s",
                     out, ridge)
            return Declined(ridge.stop, f"{WHERE} declined ({out}), and on the ridges ({ridge})")
        log.info("the Newton at the tangency points after the 3D friction cuts declined (%s); finished on the ridges "
                 "(%d point forces on their zero lines)", out, len(ridge["y"]))
        out = {"x": ridge["z"], "nodal": ridge["nodal"], "beta": ridge["beta"], "active": ridge["active"],
               "pairing": None, "segment": ridge["segment"], "t": ridge["t"], "y": ridge["y"]}
    x = out["x"][:n]
    mu = np.zeros(len(order))
    mu[held_comp] = out["x"][n:]
    mu[slide_comp] = energy.energy.forces(x).ravel()
    mu = mu.reshape(-1, n_c)
    new = (S @ x + s0).reshape(-1, n_c)
    C = max(float(c[rows].max(initial=0.0)), np.finfo(float).tiny)
    over = stuck & (np.linalg.norm(mu, axis=1) > c[rows] + capacity_tol * C)
    turned = sliding & ((np.sum(new * slip, axis=1) <= 0) | (np.linalg.norm(new, axis=1) <= floor * U))
    if over.any() or turned.any():
        log.info("the Newton at the tangency points after the 3D friction cuts: %d stuck rows over their capacity, "
                 "%d slipping rows turned: the cuts' answer stands", over.sum(), turned.sum())
        return Declined(Stop.SIGNS, f"{WHERE}: {over.sum()} stuck rows over their capacity, {turned.sum()} "
                        "slipping rows turned")
    y = np.asarray(out["nodal"], dtype=float)
    if not balances(op.gradient(x), op.magnitude(x), G, y, S, mu.ravel(), balance_tol):    # (26), own forces
        log.info("the Newton at the tangency points after the 3D friction cuts: its forces do not balance (26)")
        return Declined(Stop.SIGNS, f"{WHERE}: its forces do not balance (26)")
    done = replace(trial)
    done.u, done.phi, done.taus = unstacked(problem, x, widths)
    done.y, done.beta, done.active, done.pairing = out["nodal"], out["beta"], out["active"], out["pairing"]
    done.points = (out["segment"], out["t"], out["y"])
    done.tangential = np.zeros((n_c, R))
    done.tangential[:, rows] = mu.T
    done.tangential = done.tangential.ravel()
    done.capacity = np.zeros(R)
    done.capacity[rows] = c[rows]
    done.polished, done.finish, done.route, done.declined = (True, Finish.FRICTION_NEWTON,
                                                             Route.INTERIOR_POINT_FINISHED, None)
    return done



CLOSED = 1e-12
"""A node of X_h whose slack q is within this of 0 (times the largest displacement) is closed (:func:`kept`: a row
the finish closed is 0 to rounding, measured at most 5.2e-31; the open nodes of the boxes that lift at a corner at
least 2.4e-8 below it)."""


CUTS_KEPT = "cut rounds' answer"
"""What :func:`kept` keeps where the polish declined (:attr:`~cvxcontact.backends.result.RawResult.kept`)."""


def kept(problem, cuts, done):
    """The answer where the cuts' answer ``cuts`` went to the polish at the tangency points (2D:
    :func:`~cvxcontact.backends.friction._tangency_polish`, 3D: :func:`tangency_polish`): the polish's answer
    ``done``; where it declined (``done`` a :class:`~cvxcontact.backends.finish.declined.Declined`) and the
    contact ends inside an element (a cut point with a positive force on an element, a segment in 2D, a triangle in
    3D, whose P2 nodes are not all closed, :data:`CLOSED`: else the slack vanishes on each pressed element, q
    quadratic and 0 at its three or six nodes, and the cuts' answer is exact), the cuts' answer labelled as a finish
    that declined: not polished, the interior point's route, ``declined`` the polish's reason (the read-back reports
    it, the solve warns; module docstring); else the cuts' answer as it is."""
    if not isinstance(done, Declined):
        return done
    cells = problem.lines.cone[1]
    n = problem.E.shape[0]
    segment, _, y = cuts.points
    pressed = np.asarray(segment)[n:][np.asarray(y, dtype=float)[n:] > 0]
    slack, U = row_slack(problem, cuts)
    if (np.abs(slack)[cells[pressed]] <= CLOSED * U).all():
        return cuts
    return replace(cuts, polished=False, route=Route.INTERIOR_POINT_FRICTION, kept=CUTS_KEPT,
                   declined=done.within(f"the {CUTS_KEPT} is kept, not finished at the exact tangency points"))


def row_slack(problem, answer) -> tuple[np.ndarray, float]:
    """([u_nu] - g at the rows of the cones for ``answer``'s displacements and obstacle translations, the largest
    displacement, at least the smallest positive float): the slack the cut rounds and :func:`kept` read."""
    jump = problem.E @ sum(b.jump @ uk for b, uk in zip(problem.blocks, answer.u))
    jump = jump + problem.row_translation(answer.taus)
    U = max([float(np.abs(uk).max(initial=0.0)) for uk in answer.u] + [np.finfo(float).tiny])
    return jump - problem.g, U
