"""The route of a friction law (:class:`~cvxcontact.contact.laws.Tresca`, :class:`~cvxcontact.contact.laws.Coulomb`):
the full program with the friction energy (docs/howto/friction.md).

    minimise   (the full program of :mod:`cvxcontact.backends.full`) + sum_a c_a |s_a|
    subject to s = E [u_t] + E [u_D t]           (the slip at the contact rows)
               E [u_nu] + R t <= E g              (Signorini rows)

with c_a = g_a w_a the friction capacity of row a (threshold g_a times its lumped length w_a, scaled). In 2D
|s_a| is an absolute value (a second-order cone of one component); in 3D s_a is the row's slip along the two
tangents of the pair's frame and |s_a| its Euclidean norm (a second-order cone of two components), the rows'
multipliers 2-vectors with |mu_a| <= c_a. The multiplier of the slip rows is the
tangential force of each row: with the momentum rows K u - f + J^T y + T^T mu = 0, ``mu`` lies in
[-c_a, c_a] and mu_a = c_a sign(s_a) where the row slips; the force on the first body along t is -mu_a.

Coulomb (thresholds g_a = mu p_a that depend on the pressure): a fixed point on the capacities. The start is the
stuck contact (the slip of those rows held at 0: the limit mu -> infinity, posed wherever the friction will hold
the body); then c^(k) = mu y^(k-1) (the normal row forces of the previous iterate; c_a = mu p_a w_a = mu y_a)
and the same program, compiled once (a CVXPY parameter), is solved again, until
max_a |c^(k+1) - c^(k)| <= tol max_a c^(k+1) (the law's ``tolerance``), or the change stops decreasing (by 10 %) below
:data:`RESOLUTION` (the interior point's resolution); at most ``max_iterations`` times, then
the iterate of smallest change (the one closest to its own law: its capacities and those of its pressures differ
least) with a :class:`~cvxcontact.errors.FixedPointWarning`; a converged fixed point also answers with its
iterate of smallest change (at the interior point's resolution the change wanders). Before each iterate the capacities are
checked to hold the load (:func:`~cvxcontact.fem.kernel.refuse_sliding`): where they cannot, a SceneError names
the sliding motion.

With P2 elements under "gamma3" (:func:`conic_full`, the term
:class:`~cvxcontact.discrete.terms.ConesWithFriction`) the normal rows are the cones of every element
(:func:`~cvxcontact.backends.cones.cone_program`), the frictional rows every node of X_h (beside a pair under a
nodal condition the rows of E: that pair's own rows, each a degenerate element of the cones), the normal forces y the
cones' force r = B^T beta on those rows (Coulomb: c_a = mu p_a, p = r made non-negative with its sums kept,
:meth:`~cvxcontact.discrete.slip.Slip.pressing`); the finish is :func:`finish_on_nodes`: the nodes' round,
cut points where the contact ends inside an element, then Newton at the exact tangency points with the
stick-slip partition fixed (3D: :func:`~cvxcontact.backends.frictiontangency.tangency_polish`); Coulomb's by a
fixed point on Tresca's capacities mu r there.

The interior point's answer (Clarabel at the conic tolerances, :data:`~cvxcontact.backends.program.CLARABEL_CONIC`;
beside a Hencky body the bulk cones', :data:`~cvxcontact.backends.program.CLARABEL_BULK_CONES`) is then finished
exactly (:func:`exact_finish`, :mod:`cvxcontact.backends.finish.friction`; Coulomb: on its own law, the capacities
those of the finished forces), or kept where the finish is declined; checked (:mod:`cvxcontact.solution.friction`).
"""

from __future__ import annotations

import logging
import time
import warnings
from dataclasses import replace
from types import SimpleNamespace

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from ..contact.bernstein import element, point_rows
from ..errors import FixedPointWarning, user_stacklevel
from ..fem.kernel import refuse_sliding
from .cones import MIXED_CUT_TOL
from .cuts import accumulate_cuts, point_read_back
from .finish import Declined, Stop, force_displacements, ipm_active, reach_forces
from .finish.forces import friction_scale
from .finish.friction import FrictionRows
from .frictionrows import (
    balances,
    moved_components,
    prescribed_row_slip,
    shared_rows,
    slip_matrix,
)
from .frictionsteps import sequential as _sequential
from .frictiontangency import kept as _kept
from .frictiontangency import row_slack, tangency_polish
from .full import ContactModel, mixed_kkt
from .mixed import HeldEnergy, mixed_system, stacked, unstacked
from .program import conic_options, timed_program
from .result import INTERIOR_POINT_KEPT, Finish, RawResult, Route
from .signorini import dependent_rows
from .tangency import tangency_newton

__all__ = ["CONE_ROUNDING", "CUT_FAILURES", "CUT_ROUNDS", "ENERGY_SLACK", "RESOLUTION", "UNFINISHED_CONES",
           "conic_full", "exact_finish", "finish_on_nodes", "friction_program", "full", "interior_active",
           "prescribed_row_slip", "row_forces"]

log = logging.getLogger(__name__)

RESOLUTION = 1e-8
"""Below this relative change of the capacities, a fixed point whose change no longer decreases by 10 % per
iteration has reached the interior point's resolution and stops as converged (on the sheared layers of
tests/test_coulomb.py the change wanders at ~1e-11 there; a true contraction of 0.52 is not mistaken for it)."""


ENERGY_SLACK = 1e-9
"""The finish is declined if its objective exceeds the interior point's by more than this, relative to the
larger of |objective| and C U: the interior point's own answer may sit below the true minimum by its
infeasibility (its rows at the conic tolerances)."""


def friction_program(problem, model: ContactModel, extra=(), objective=None):
    """(the CVXPY problem, the slip equality constraint, its rows, the capacities parameter c (scaled), the
    slip variable s, the friction energy) of ``problem``'s friction term added to ``model`` (the full program of the normal rows):
    one slip variable per frictional row and slip component (s: (rows, c), c = 1 in 2D, 2 in 3D), the energy
    sum_a c_a |s_a| (2D: an absolute value; 3D: the Euclidean norm of the row's two components, a
    second-order cone). The constraint is vec(s) = kron(I_c, E[rows]) [u_t] (component-major). ``extra``,
    ``objective``: constraints and a (scaled) objective term posed beside them (``cc.Model``'s user terms,
    :mod:`cvxcontact.backends.frictionuser`)."""
    rows, data = np.flatnonzero(problem.rows.frictional), problem.term.data
    n_c = data.components
    at = np.concatenate([rows + j * problem.E.shape[0] for j in range(n_c)])
    Es = data.rows[at]
    slip = sum((Es @ T) @ u for T, u in zip(data.operators, model.u) if u.size) + prescribed_row_slip(problem)[at]
    slip = slip + sum((Es @ T) @ t for T, t in zip(data.translations, model.t))   # a moving obstacle's
    capacity = cp.Parameter(len(rows), nonneg=True, name="capacity")
    if n_c == 1:
        s = cp.Variable(len(rows), name="slip")
        constraint, energy = s == slip, capacity @ cp.abs(s)
    else:
        s = cp.Variable((len(rows), n_c), name="slip")
        constraint, energy = cp.vec(s, order="F") == slip, capacity @ cp.norm(s, 2, axis=1)
    program = model.with_terms([constraint, *extra], objective=energy if objective is None else energy + objective)
    return program, constraint, rows, capacity, s, energy


def full(problem, cache, settings, timings) -> RawResult:
    """The full program with the friction energy (module docstring), Coulomb's by the fixed point; the normal
    rows' forces ``y``, the tangential row forces ``raw.tangential`` (scaled) from its duals, the capacities
    of the iterate answered ``raw.capacity`` and the fixed point's relative changes ``raw.fixed_point``; then
    (``polish``) the exact finish, :func:`exact_finish`."""
    raw, unsettled = interior_answer(problem, settings, timings, normal_row_forces)
    raw.active = interior_active(problem, raw)
    if settings.polish:
        exact_finish(problem, raw, timings)
    if unsettled and not raw.polished:
        warnings.warn(unsettled, FixedPointWarning, stacklevel=user_stacklevel())
    return raw


def interior_active(problem, raw):
    """The closed rows of the interior point's answer ``raw`` (:func:`~cvxcontact.backends.finish.ipm_active`)."""
    moved = problem.moved_g(raw.taus)
    parts = [problem.E @ (b.jump @ uk) for b, uk in zip(problem.blocks, raw.u)]
    return ipm_active(parts, moved, raw.y, force_displacements(problem.blocks, problem.E, raw.y),
                      reach_forces(problem.blocks, problem.E, raw.u, raw.phi))


UNFINISHED_CONES = "not finished exactly under the P2 cones: the interior point's answer, checked"
"""Why the friction next to the P2 "gamma3" cones keeps the interior point's answer where the finish
(:func:`finish_on_nodes`) is off (``polish=False``) or declined, the finish's own reason after it (in
``raw.declined``)."""

CONE_ROUNDING = 1e-9
"""The finish of the cones with friction (:func:`finish_on_nodes`) stops where the slack's largest value on every
element is at most this times the largest displacement (the closed points' slack is rounding; a contact ending
inside an element dips by a part of the displacements between its nodes)."""

CUT_ROUNDS = 40
"""At most this many rounds of cut points (:func:`finish_on_nodes`; per iterate of Coulomb's fixed point,
:func:`_coulomb_cuts`)."""

CUT_FAILURES = 2
"""The cuts end (declined) once this many rounds' friction finishes were declined: a round that adds many points
whose steps cycle, then its worst point alone, again and again (measured: the 3D box of
benchmarks/friction_p2_gamma3.py lifting at a corner, violation 5e-3 to 4e-4 of the displacements in 11 rounds of
its worst point, 8.3 s CPU before the decline; the interior point 0.24 s)."""


def conic_full(problem, cache, settings, timings) -> RawResult:
    """The full program of the P2 "gamma3" cones (:func:`~cvxcontact.backends.cones.cone_program`) with the
    friction energy on the nodes of X_h (module docstring; the term
    :class:`~cvxcontact.discrete.terms.ConesWithFriction`), Coulomb's by the fixed point on the capacities mu p_a
    of the cones' nodal force r = B^T beta (made non-negative,
    :meth:`~cvxcontact.discrete.slip.Slip.pressing`); ``raw.y`` = r, ``raw.beta`` the Bernstein duals. Then
    (``polish``)
    :func:`finish_on_nodes`; where it does not apply, the interior point's answer with ``raw.declined`` saying
    why (the read-back checks it: the conic checks and the friction law's)."""
    raw, unsettled = interior_answer(problem, settings, timings, normal_cone_forces)
    if settings.polish:
        raw = finish_on_nodes(problem, raw, timings)
    else:
        raw.declined = Declined(Stop.NOT_POSED, UNFINISHED_CONES)
    if unsettled and not raw.polished and raw.kept == INTERIOR_POINT_KEPT:     # not the cuts' answer: its own
        warnings.warn(unsettled, FixedPointWarning, stacklevel=user_stacklevel())   # fixed point converged
    return raw


def finish_on_nodes(problem, raw, timings) -> RawResult:
    """The exact finish of the cones with friction where their contact closes at points: the friction finish
    (:func:`exact_finish`) of the nodal relaxation (a Signorini row at every node of X_h, the friction rows where
    they are), then, while its slack q = [u_nu] - g leaves an element's cone (its maximum over the element above
    :data:`CONE_ROUNDING` U, exact by :func:`~cvxcontact.contact.bernstein.bernstein_argmax`; against a curved
    obstacle the true slack, q_h less the gap's departure from its interpolant, which vanishes at the nodes), the
    same finish with a normal row added at each such maximum (a cut,
    :func:`~cvxcontact.backends.cuts.accumulate_cuts`; at most :data:`CUT_ROUNDS` rounds and
    :data:`CUT_FAILURES` declined ones); where cut points were added, that answer finished at the exact
    tangency points (:func:`_tangency_polish`; 3D where the contact touches each element at isolated points).
    Coulomb: the nodes' round on its own law (capacities mu y_a of the nodes' forces); where that leaves an
    element's cone, a fixed point on Tresca's capacities c = mu r, r = P^T y the nodal force of the cut points'
    forces, each iterate the finish above at the given capacities (:func:`_coulomb_cuts`, then
    :func:`_coulomb_tangency`). The answer is then the cones': its point forces
    y_p >= 0 are point evaluations, in every element's dual cone (beta_s = sum_p y_p basis(t_p),
    :func:`~cvxcontact.backends.cuts.point_duals`; r = P^T y on X_h; docs/howto/friction.md). Otherwise (a
    finish declined, cuts that do not settle, a fixed point that does not)
    the interior point's answer ``raw`` with its ``declined`` saying why. Returns the answer."""
    B, cells = problem.lines.cone
    n, w = B.shape[1], cells.shape[1]
    where = np.zeros(n, dtype=int)                 # every node of X_h once, as a point of an element holding it
    where[cells.ravel()] = np.arange(cells.size)
    segment, t = where // w, element(w).nodes[where % w]
    P0 = point_rows(B, segment, t)
    if P0.shape != (n, n) or abs(P0 - sp.identity(n)).max() > 1e-15:
        raw.declined = Declined(Stop.NOT_POSED,
                                f"{UNFINISHED_CONES} (the nodes of X_h are not points of its elements)")
        return raw
    if problem.rows.pressure_dependent.any():      # the nodes' round on Coulomb's own law, else its fixed point
        out = _cuts(problem, raw, timings, segment, t, rounds=1)
        if isinstance(out, Declined):
            out = _coulomb_cuts(problem, raw, timings, segment, t)
    else:
        capacity = problem.term.data.capacities(np.zeros(len(problem.g)))
        out = _cuts(problem, raw, timings, segment, t)
        if isinstance(out, Declined):             # the tangency points from the interior point's structure
            done = _tangency_polish(problem, replace(raw, points=None), timings, capacity, INTERIOR_SLIP)
            out = out if isinstance(done, Declined) else done
        elif _cut(problem, out):
            out = _kept(problem, out, _tangency_polish(problem, out, timings, capacity))
    if isinstance(out, Declined):
        raw.declined = Declined(out.stop, f"{UNFINISHED_CONES} (the friction finish on the nodes and cut points: "
                                f"{out})", out.rows)
        return raw
    return out


def _cuts(problem, raw, timings, segment, t, capacity=None, start=None, rounds=CUT_ROUNDS):
    """The cut rounds of :func:`finish_on_nodes` (at most ``rounds``) at the given friction capacities
    (``capacity`` (R,), scaled: Tresca's law at them; default the law's own, Coulomb's on the nodes' forces), from the points (``segment``, ``t``) (the nodes of X_h, then any points kept from an
    earlier call) and the answer ``start`` (its forces on a prefix of the points; default the interior point's
    ``raw``). Returns the finished answer (a new :class:`RawResult`; its ``points`` (segment, t, y) the cut
    points and their forces) or the :class:`~cvxcontact.backends.finish.Declined` that stopped it."""
    B, cells = problem.lines.cone
    n, w = B.shape[1], cells.shape[1]
    tried, solved = [], [] if start is None else [start]

    def solve(P, delta):
        """The friction finish with the normal rows ``P`` (their slack P q - delta), from the last round's answer:
        (point forces, q at the nodes of X_h, each node's displacement scale, the answer, its closed rows), or None
        (its decline kept)."""
        if sum(d is not None for d in tried) >= CUT_FAILURES:
            return None
        begin = next((a for a in reversed(solved) if len(a.y) <= P.shape[0]), None)
        trial = exact_finish(problem, replace(raw), timings, points=(P, delta), start=begin, capacity=capacity)
        tried.append(trial.declined)
        if not trial.polished:
            return None
        solved.append(trial)
        slack, U = row_slack(problem, trial)                               # at the rows of the cones
        return trial.y, slack, np.full(n, U), trial, trial.active

    out = accumulate_cuts(B, solve, segment, t, max_rounds=rounds, tol=CONE_ROUNDING, width=w,
                          departure=problem.departure)
    if isinstance(out, Declined):
        return next((d for d in reversed(tried) if d is not None), out)
    trial = out["state"]
    trial.points = (out["segment"], out["t"], out["y"])
    trial.y, trial.active = point_read_back(B, out["segment"], out["t"], out["y"], out["active"])
    trial.beta = out["beta"]
    trial.pairing = None if problem.departure is None else out["pairing"]
    return trial


def _change(new, old) -> float:
    """max |new - old| / max(max new, max old): the relative change of Coulomb's capacities over an iterate."""
    return float(np.abs(new - old).max(initial=0.0)
                 / max(float(new.max(initial=0.0)), float(old.max(initial=0.0)), np.finfo(float).tiny))


def _coulomb_tangency(problem, trial, timings, capacity, tol, most, slip_floor=None, before=()):
    """The cuts' Coulomb answer ``trial`` (its capacities' fixed point converged, ``capacity`` those of its
    forces) finished at the tangency points: the same fixed point c^(k+1) = mu r^(k) on
    :func:`_tangency_polish`'s answers, r^(k) their nodal forces, from ``capacity``, with the stop rule of
    :func:`_coulomb_cuts`; where a polish declines or ``most`` iterates do not settle, the cuts' answer (labelled
    declined, :func:`~cvxcontact.backends.frictiontangency.kept`; its capacities its own forces' to the fixed
    point's tolerance, its slack at the cuts' stop). ``slip_floor``: the first iterate's (:func:`_tangency_polish`),
    from the interior point's answer ``trial`` where the cuts declined (then None where the fixed point does not
    settle). The answer's ``fixed_point``: ``before`` (the cuts' fixed point's changes, which end at ``capacity``)
    then this one's (an answer of the cuts keeps its own)."""
    changes, cuts = [], None if slip_floor is not None else trial
    for _ in range(most):
        done = _tangency_polish(problem, trial, timings, capacity,
                                SLIP_ROUNDING if slip_floor is None or changes else slip_floor)
        if isinstance(done, Declined):
            return None if cuts is None else _kept(problem, cuts, done)
        new = problem.term.data.capacities(done.y)
        changes.append(_change(new, capacity))
        log.info("Coulomb at the tangency points: iterate %d, relative change of the capacities %.2e", len(changes),
                 changes[-1])
        trial, capacity = done, new
        if changes[-1] <= tol or (changes[-1] <= COULOMB_ROUNDING and len(changes) > 1
                                  and changes[-1] > 0.9 * changes[-2]):
            done.fixed_point = tuple(before) + tuple(changes)
            return done
    unsettled = f"Coulomb's fixed point at the tangency points did not settle in {most} iterates ({changes[-1]:.3g})"
    return None if cuts is None else _kept(problem, cuts, Declined(Stop.MAX_ITER, unsettled))


def _cut(problem, trial) -> bool:
    """Whether the cuts' answer ``trial`` holds a point besides the nodes of X_h (else it is exact on them)."""
    return len(trial.points[0]) > problem.lines.cone[0].shape[1]


PARTITIONS = 10
"""Stick-slip partitions tried at most by :func:`_tangency_polish` (a stuck row whose force exceeds its capacity
then slips along it, a slipping row whose slip turns against its force sticks)."""

INTERIOR_SLIP = 1e-7
"""From the interior point's answer (:func:`_tangency_polish` where the cuts declined), a friction row whose slip is
at most this times the largest displacement is stuck, the others slip along their slip (a wrong guess is corrected
by :data:`PARTITIONS`, and caught by the acceptance). Measured on the Coulomb pair of non-matching lines: 1e-7 and
1e-8 finish it; 1e-6 took 9 slipping rows for stuck, and the Newton on the corrected partition did not converge."""

BALANCE_ROUNDING = 1e-10
"""The answer of :func:`_tangency_polish` is taken only where (26) holds with its own nodal forces to this fraction
of its largest term (measured at most 1e-15; a pair under a nodal condition beside the cones, whose rows the
tangency points do not carry, missed it by 2.4e-2 of the load and is left to the cuts' answer)."""

POLISH_2D = "the Newton at the tangency points after the friction cuts"
"""The finish a decline of the 2D :func:`_tangency_polish` names (3D:
:data:`~cvxcontact.backends.frictiontangency.WHERE`)."""

SLIP_ROUNDING = 1e-10
"""A friction row of the cuts' answer whose slip is at most this times the largest displacement is stuck in the
Newton at the tangency points (:func:`_tangency_polish`); the others slip along their slip's sign."""


def _tangency_polish(problem, trial, timings, capacity, slip_floor=None):
    """The cuts' answer ``trial`` (its ``points`` the cut points and forces) finished at the exact tangency points
    (2D; in 3D :func:`~cvxcontact.backends.frictiontangency.tangency_polish`, a slipping row's force turning with
    its slip): the cuts close in on the point where a contact ends inside an element only linearly, the fields' error
    the square root of the violation (measured 2.3e-6 of the displacements at the cuts' stop, 1e-9: the block
    dragged over a disk). With the answer's stick-slip partition fixed, Tresca's law at the capacities
    ``capacity`` (R,) is linear in 2D: a slipping row's force is c_a sign(s_a), a load; a stuck row's slip is
    0, a linear row S_a x + s0_a = 0 whose multiplier is its force. So the frictionless cones' Newton at the
    tangency points (:func:`~cvxcontact.backends.tangency.tangency_newton`, docs/formulation.md §18) on (26)
    with those loads and rows finishes it, from the cuts' points; accepted where its answer keeps the partition
    (|mu_a| <= c_a on the stuck rows, the slip of every slipping row along its force: else the rows that break it
    change side and it runs again, at most :data:`PARTITIONS` times) and balances (26) with its own forces.
    Returns the finished answer (a new :class:`RawResult`) or the :class:`~cvxcontact.backends.finish.Declined`
    saying why (2D and 3D: the cuts' answer stands, labelled by
    :func:`~cvxcontact.backends.frictiontangency.kept`).

    From the interior point's answer (where the cuts declined: ``trial.points`` None, its Bernstein duals the
    contact's structure, as the frictionless cones' :func:`~cvxcontact.backends.cones.finish_cuts_mixed` turns
    to the tangency points), a row stuck where its slip is at most ``slip_floor`` (:data:`INTERIOR_SLIP`) of the
    largest displacement: its slip there is the interior point's noise; the acceptance is the same."""
    if problem.term.data.components != 1:          # 3D: a slipping row's force turns with its slip
        return tangency_polish(problem, trial, timings, capacity,   # the capacities' rounding: 2D's below
                               SLIP_ROUNDING if slip_floor is None else slip_floor, BALANCE_ROUNDING, SLIP_ROUNDING)
    t0 = time.perf_counter()
    R, c = problem.E.shape[0], np.asarray(capacity, dtype=float)
    _, _, widths = mixed_system(problem)
    rows = np.flatnonzero(problem.rows.frictional)
    S = slip_matrix(problem, rows, widths)
    s0 = prescribed_row_slip(problem)[rows]
    x0 = stacked(trial.u, trial.phi, trial.taus)
    U = float(np.abs(x0).max(initial=0.0))
    slip = S @ x0 + s0
    moved = np.asarray(abs(S).sum(axis=1)).ravel() > 0
    stuck = moved & (np.abs(slip) <= (SLIP_ROUNDING if slip_floor is None else slip_floor) * U)
    sign = np.where(stuck, 0.0, np.sign(slip))
    kkt = mixed_kkt(list(problem.blocks), problem.E, problem.g, translations=list(problem.translations))
    A, F, G, n = sp.csr_matrix(kkt.matrix), np.asarray(kkt.rhs, dtype=float), sp.csr_matrix(kkt.rows), len(x0)
    op = mixed_system(problem)[0]           # a non-quadratic energy: Newton on the nonlinear (26) (its gradient)
    B, C = problem.lines.cone[0], max(float(c[rows].max(initial=0.0)), np.finfo(float).tiny)
    mu = trial.tangential.reshape(1, R)[0, rows]
    beta, points = trial.beta, trial.points
    for _ in range(PARTITIONS):
        force = c[rows] * sign                                # the slipping rows' forces (0 on the stuck ones)
        held = S[stuck]
        aug = SimpleNamespace(matrix=sp.bmat([[A, held.T], [held, None]], format="csr"),
                              rhs=np.concatenate([F - S.T @ force, -s0[stuck]]),
                              rows=sp.hstack([G, sp.csr_matrix((G.shape[0], held.shape[0]))]).tocsr())
        out = tangency_newton(aug, B, problem.g, beta, np.concatenate([x0, mu[stuck]]), held=problem.held_rows,
                              tol=MIXED_CUT_TOL, departure=problem.departure, points=points,
                              energy=None if op.linear else HeldEnergy(op, S.T @ force, held, s0[stuck]))
        if isinstance(out, Declined):
            log.info("the Newton at the tangency points after the friction cuts declined: %s", out)
            timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
            return Declined(out.stop, f"{POLISH_2D} declined ({out})")
        x0 = out["x"][:n]
        mu = force.copy()
        mu[stuck] = out["x"][n:]
        new = S @ x0 + s0
        over = stuck & (np.abs(mu) > c[rows] + SLIP_ROUNDING * C)      # stuck beyond its capacity: it slips
        back = ~stuck & moved & (new * sign <= 0)                      # slipping against its force: it sticks
        if not (over.any() or back.any()):
            break
        log.info("the Newton at the tangency points after the friction cuts: %d rows start to slip, %d stick",
                 over.sum(), back.sum())
        sign = np.where(over, np.sign(mu), np.where(back, 0.0, sign))
        stuck = (stuck & ~over) | back
        beta, points = out["beta"], (out["segment"], out["t"], out["y"])
    else:
        timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
        log.info("the Newton at the tangency points after the friction cuts: the stick-slip partition did not settle")
        return Declined(Stop.MAX_ITER, f"{POLISH_2D}: the stick-slip partition did not settle in {PARTITIONS} tries")
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    x = x0
    y = np.asarray(out["nodal"], dtype=float)
    inner, terms = (A @ x - F, abs(A) @ np.abs(x) + np.abs(F)) if op.linear else (op.gradient(x), op.magnitude(x))
    if not balances(inner, terms, G, y, S, mu, BALANCE_ROUNDING):      # (26) with the answer's own forces
        log.info("the Newton at the tangency points after the friction cuts: its forces do not balance (26)")
        return Declined(Stop.SIGNS, f"{POLISH_2D}: its forces do not balance (26)")
    done = replace(trial)
    done.u, done.phi, done.taus = unstacked(problem, x, widths)
    done.y, done.beta, done.active, done.pairing = out["nodal"], out["beta"], out["active"], out["pairing"]
    done.points = (out["segment"], out["t"], out["y"])
    done.tangential = np.zeros(R)
    done.tangential[rows] = mu
    done.capacity = np.zeros(R)
    done.capacity[rows] = c[rows]
    done.polished, done.finish, done.route, done.declined = (True, Finish.FRICTION_NEWTON,
                                                             Route.INTERIOR_POINT_FINISHED, None)
    return done


COULOMB_ROUNDING = 1e-10
"""Below this relative change of the capacities, a fixed point of :func:`_coulomb_cuts` whose change no longer
decreases by 10 % per iterate has reached the rounding of its exact iterates and stops as converged."""


def _coulomb_cuts(problem, raw, timings, segment, t):
    """Coulomb's finish with cut points: the fixed point c^(k+1) = mu r^(k) on Tresca's capacities, r^(k) = P^T y
    the nodal force on X_h of the cut points' forces of iterate k (made non-negative, a negative entry, a P2 node's
    share of a force between nodes, taken from its patch: :meth:`~cvxcontact.discrete.slip.Slip.pressing`),
    each iterate the Tresca finish :func:`_cuts` at c^(k), exact; from the
    interior point's capacities c^(0) = mu r (its cones' nodal force), each iterate starting from the last one's
    points and answer. It stops where max_a |c^(k+1) - c^(k)| <= tol max_a c^(k+1) (the law's ``tolerance``), or
    where that change no longer decreases by 10 % below :data:`COULOMB_ROUNDING`; the answer is the last iterate,
    whose capacities are those of its own forces to that change. The map is a contraction for small mu (the
    friction forces' effect on the pressures is of order mu; measured rates in docs/howto/friction.md); where it is
    not (``max_iterations`` of the law reached, or an iterate declined) the finish declines. The answer's
    ``fixed_point`` is this fixed point's relative changes (then :func:`_coulomb_tangency`'s after them, where
    that one answers), not the interior point's."""
    tol, most = problem.rows.fixed_point
    capacity = problem.term.data.capacities(raw.y)
    start, changes = None, []
    for _ in range(most):
        trial = _cuts(problem, raw, timings, segment, t, capacity=capacity, start=start)
        if isinstance(trial, Declined):
            if start is not None:
                return trial
            # the first iterate's cuts declined: the fixed point at the tangency points from the interior point
            done = _coulomb_tangency(problem, replace(raw, points=None), timings, capacity, tol, most,
                                     INTERIOR_SLIP)
            return trial if done is None else done
        new = problem.term.data.capacities(trial.y)
        changes.append(_change(new, capacity))
        log.info("Coulomb finish at cut points: iterate %d, relative change of the capacities %.2e", len(changes),
                 changes[-1])
        if changes[-1] <= tol or (changes[-1] <= COULOMB_ROUNDING and len(changes) > 1
                                  and changes[-1] > 0.9 * changes[-2]):
            trial.fixed_point = tuple(changes)
            return _coulomb_tangency(problem, trial, timings, new, tol, most,
                                     before=trial.fixed_point) if _cut(problem, trial) else trial
        segment, t, y = trial.points                  # the next iterate starts from these points and forces
        capacity, start = new, replace(trial, y=y)
    return Declined(Stop.MAX_ITER, f"Coulomb's fixed point on the cut points' capacities changed them by "
                    f"{changes[-1]:.3g} (relative) at its iterate {len(changes)}, above the tolerance {tol:.3g}")


def row_forces(problem, model: ContactModel, u, taus) -> tuple:
    """(y, None, None): the Signorini rows' multipliers of the solved friction program (scaled; the term
    :class:`~cvxcontact.discrete.terms.TrescaFriction`'s forces)."""
    return np.asarray(model.contact.dual_value, dtype=float).ravel(), None, None


def normal_row_forces(problem, model):
    """(y, None): the normal row forces of the solved program (scaled), as its term reads them (Signorini rows:
    their multipliers; beside a compliance law w p(r) + z on every row, :func:`~cvxcontact.backends.compliance.
    compliance_forces`)."""
    values = [np.asarray(v.value, dtype=float).ravel() if v.size else np.zeros(0) for v in model.u]
    taus = [np.asarray(t.value, dtype=float).ravel() for t in model.t]
    return problem.term.program_forces(problem, model, values, taus)[0], None


def normal_cone_forces(problem, model):
    """(r, beta): the cones' nodal force r = B^T beta on X_h and their Bernstein duals beta (the held elements' at
    their least admissible value; :func:`~cvxcontact.backends.cones.cone_forces`), scaled."""
    y, _, beta = problem.term.program_forces(problem, model, None, None)
    return y, beta


def interior_answer(problem, settings, timings, normal, model=None, extra=(), objective=None):
    """(raw, unsettled): the interior point's answer of the full program with the friction energy (Tresca's, or
    Coulomb's fixed point), ``normal(problem, model) -> (y, beta)`` reading the normal forces of the solved
    program; ``unsettled`` the words of a :class:`~cvxcontact.errors.FixedPointWarning` (None: converged or
    Tresca), warned by the route if no finish reaches the law. ``model``: the term's program to add the friction
    to (None: built here); ``extra``, ``objective``: terms posed beside (:func:`friction_program`)."""
    t0 = time.perf_counter()
    E = problem.E
    if model is None:
        model = problem.term.program(problem)          # the normal rows or cones (the term's program)
    program, constraint, rows, capacity, s, friction = friction_program(problem, model, extra, objective)
    timings["model"] = time.perf_counter() - t0
    # beside a non-quadratic energy the bulk cones' settings (equilibrated): the conic ones stalled there, Clarabel
    # ended InsufficientProgress (SolverError) on Coulomb's first program of a yielding P2 block (sigma1, sigma2)
    options = conic_options(settings.solver, settings.options, quadratic=problem.quadratic)
    n_c = problem.term.data.components

    def answer():
        """The arrays of the program's current solution: u, phi, (y, beta), mu ((c R,) component-major, like the
        slip rows; CVXPY's L = ... + nu^T (s - slip)), the translations and the capacities it was posed with."""
        mu = np.zeros((n_c, E.shape[0]))
        mu[:, rows] = -np.asarray(constraint.dual_value, dtype=float).reshape(n_c, len(rows))
        return ([np.asarray(v.value, dtype=float).ravel() if v.size else np.zeros(0) for v in model.u],
                [np.asarray(v.value, dtype=float).ravel() if v is not None else None for v in model.phi],
                normal(problem, model), mu.ravel(),
                [np.asarray(t.value, dtype=float).ravel() for t in model.t], np.array(capacity.value, dtype=float))

    fixed_point, unsettled = problem.rows.fixed_point, None
    if fixed_point is None:                                       # Tresca: the thresholds are given
        capacity.value = problem.term.data.capacities(np.zeros(E.shape[0]))[rows]
        iterations, best, changes = timed_program(program, settings, timings, options), answer(), None
        status = program.status
    else:
        # the start without the user terms: holding the slip at 0 may contradict them (a slip they prescribe), and
        # it only seeds the capacities of the fixed point, whose programs take them
        stuck = _stuck(problem, model, constraint, rows, capacity, s, friction)
        iterations, (best, status), changes, unsettled = _fixed_point(
            problem, model, stuck, program, capacity, rows, answer, fixed_point,
            lambda p: timed_program(p, settings, timings, options), lambda: normal(problem, model)[0])
    u, phi, (y, beta), mu, taus, posed = best
    raw = RawResult(u=u, phi=phi, y=y, beta=beta, program=program, taus=taus, method="full", iterations=iterations,
                    route=Route.INTERIOR_POINT_FRICTION, status=status)
    raw.tangential = mu
    raw.capacity = np.zeros(E.shape[0])
    raw.capacity[rows] = posed
    raw.fixed_point = changes
    return raw, unsettled


def held_motions(problem, raw) -> np.ndarray:
    """H (k, n): the rigid motions of the bodies that only the contact holds (:meth:`~cvxcontact.physics.body.Body.
    held_modes`, in each body's reduced coordinates T_u^T r) on the unknowns x = [u_1; phi_1; ...; tau_1; ...] of
    :func:`~cvxcontact.backends.mixed.stacked` for the answer ``raw`` (its blocks' sizes), 0 elsewhere."""
    n, rows, pos = len(stacked(raw.u, raw.phi, raw.taus)), [], 0
    for k, (b, s, uk, pk) in enumerate(zip(problem.scene.bodies, problem.systems, raw.u, raw.phi)):
        modes = b.held_modes(problem.meshes[k])
        if len(modes):
            block = np.zeros((len(modes), n))
            block[:, pos:pos + len(uk)] = (s.Tu.T @ modes.T).T
            rows.append(block)
        pos += len(uk) + (0 if pk is None else len(pk))
    return np.vstack(rows) if rows else np.zeros((0, n))


def exact_finish(problem, raw, timings, points=None, start=None, capacity=None) -> RawResult:
    """The exact finish of the friction law (:func:`~cvxcontact.backends.finish.solve_friction`: semismooth
    Newton on (26)-(27) with the friction rows, Coulomb's capacities mu y_a those of the answer's own forces)
    from the interior point's answer in ``raw``; fills ``raw`` (polished, :attr:`Finish.FRICTION_NEWTON`) or
    its ``declined`` (a :class:`~cvxcontact.backends.finish.Declined`, the interior point's answer kept): a
    non-quadratic energy (a Hencky body) is finished by damped sequential quadratic steps (:func:`~cvxcontact.backends.frictionsteps.sequential`); a
    singular step, steps that do not settle, broken signs, or an energy above the
    interior point's (beyond :data:`ENERGY_SLACK`; not against a curved obstacle's own gap at points, where the
    interior point's program is the interpolant's). Rows that may be linearly dependent
    (:func:`~cvxcontact.backends.signorini.dependent_rows`: 3D "gamma3" pairs) are finished on an independent
    subset of them per step. ``points`` (P, delta): the normal rows at points of the P2 cones' elements instead of
    E's (P (k, n) on the nodes of X_h, its first n rows the nodes themselves, the frictional rows; the slack
    P q - delta, ``delta`` a curved obstacle's departure at the points; :func:`finish_on_nodes`): ``raw.y`` and
    ``raw.active`` are then per point; ``start``: an answer to start the steps from (its forces on a prefix of the
    points), else ``raw`` (whose energy the finish's may not exceed either way). ``capacity`` (R,): the friction
    capacities to finish at (scaled; Tresca's law at them), instead of the law's (:func:`_coulomb_cuts`)."""
    t0 = time.perf_counter()
    E = problem.E
    op, G, widths = mixed_system(problem)
    first = raw if start is None else start
    g, free, y0, dependent = problem.g, ~problem.held_rows, first.y, False
    if points is not None:                        # the rows at points of the cones' elements (finish_on_nodes)
        P, delta = points
        G, g, y0 = (P @ G).tocsr(), P @ g + delta, np.concatenate([first.y, np.zeros(P.shape[0] - len(first.y))])
        free, dependent = (abs(P) @ free.astype(float)) > 0, P.shape[0] > P.shape[1]
    x0 = stacked(raw.u, raw.phi, raw.taus)
    data = problem.term.data
    R, n_c = E.shape[0], data.components
    rows = np.flatnonzero(problem.rows.frictional)
    order = (rows[:, None] + R * np.arange(n_c)[None, :]).ravel()            # row a, component j at a c + j
    S = slip_matrix(problem, order, widths)
    dependent = dependent or dependent_rows(problem) or shared_rows(problem, G, S, rows)
    normal = problem.term.normal_rows(problem, op, G, g)     # the normal rows as its laws pose them (frictionrows)
    op, G, g, free, y0, on = normal.posed(first, free, y0, rows)
    c0 = data.capacities(np.zeros(R)) if capacity is None else np.asarray(capacity, dtype=float)
    slope = data.capacities(np.ones(R)) - data.capacities(np.zeros(R)) if capacity is None else np.zeros(R)
    fr = FrictionRows(S, prescribed_row_slip(problem)[order], on, c0[rows], slope[rows], n_c,
                      moved_components(problem, rows))
    U = max([float(np.abs(uk).max(initial=0.0)) for uk in raw.u]
            + [float(np.max(np.abs(data.prescribed), initial=0.0))])
    C = friction_scale(problem, raw.u, raw.phi, raw.y, raw.capacity, whole=True)     # the interior point's noise
    if not (U > 0 and C > 0):
        raw.declined = Declined(Stop.NOT_POSED, "nothing moves or nothing is pressed: no scale to finish on")
        return raw
    out = _sequential(op, G, g, fr, free, stacked(first.u, first.phi, first.taus), y0,
                      first.tangential.reshape(n_c, R)[:, rows].T,
                      (C, U), dependent, held=held_motions(problem, first))
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = out
        return raw
    x, y, mu, closed, steps = out

    def objective(x_, capacity):
        """The program's objective at x_ (the energy of (26) and the friction energy at ``capacity``)."""
        return op.value(x_) + float(capacity @ np.linalg.norm(fr.slip(x_), axis=1))

    c = fr.capacity(y)
    # a row of capacity 0 (Coulomb's on an open row, y = 0 exactly) has the point 0 for its cone: its force is 0,
    # not the rounding of the steps' solves (1e-30 on a strain-free lifted block, which the checks' floor of the
    # bodies' deformation, itself rounding there, read as a stick-slip of 2.8e-5)
    mu = np.where((c == 0)[:, None], 0.0, mu)
    before, after = objective(x0, c), objective(x, c)
    log.info("friction finish: %d steps, objective %.17g (the interior point's %.17g, relative change %.1e)", steps,
             after, before, (after - before) / max(abs(before), C * U))
    bounded = points is None or problem.departure is None   # a curved obstacle's own gap: the interior point's
    #                        program is its interpolant's, whose answer leaves the true gap: its energy bounds nothing
    if bounded and after > before + ENERGY_SLACK * max(abs(before), C * U):
        raw.declined = Declined(Stop.WORSE, f"{Stop.WORSE.value} ({after:.17g} > {before:.17g})")
        return raw
    y, closed = normal.forces(x, y, closed, raw)  # every row's force (beside a compliance law: w p(r), and z)
    raw.u, raw.phi, raw.taus = unstacked(problem, x, widths)
    raw.y, raw.active = y, closed
    raw.tangential = np.zeros((n_c, R))
    raw.tangential[:, rows] = mu.T
    raw.tangential = raw.tangential.ravel()
    raw.capacity = np.zeros(R)
    raw.capacity[rows] = c
    raw.polished, raw.finish, raw.route = True, Finish.FRICTION_NEWTON, Route.INTERIOR_POINT_FINISHED
    raw.iterations += steps
    return raw


def _stuck(problem, model, constraint, rows, capacity, s, friction):
    """The program of Coulomb's start (module docstring): the slip of the pressure-dependent rows that can stick
    held at 0 (some unknown moves their slip, and no support prescribes a slip there: a side that meets the
    contact moved along a tangent, docs/howto/friction.md; against a curved obstacle its tangent at a corner
    is tilted, so the unknown normal displacement moves that slip too, but cancelling the support's slip with it
    would drive the corner into the obstacle: the start was infeasible), the other rows at their given
    thresholds (``capacity`` set here; 0 on the pressure-dependent ones). Without ``cc.Model``'s user terms (its
    slip held at 0 may contradict them: a slip they prescribe); the fixed point's programs take them."""
    E, data = problem.E, problem.term.data
    n_c = data.components
    moved = moved_components(problem, rows)
    at = np.concatenate([rows + j * E.shape[0] for j in range(n_c)])
    prescribed = prescribed_row_slip(problem)[at].reshape(n_c, len(rows)).T != 0
    pressure = problem.rows.pressure_dependent[rows]
    sticks = pressure & moved.any(axis=1) & ~prescribed.any(axis=1)
    capacity.value = np.where(pressure & moved.any(axis=1), 0.0, data.capacities(np.zeros(E.shape[0]))[rows])
    held = [s[np.flatnonzero(sticks)] == 0] if sticks.any() else []
    return model.with_terms([constraint, *held], objective=friction)


def _fixed_point(problem, model, stuck, program, capacity, rows, answer, fixed_point, solve, forces):
    """Coulomb's fixed point on the capacities (module docstring) from the ``stuck`` start, re-solving
    ``program`` with ``capacity`` set to the last normal row forces' (``forces()``, of the program last solved;
    ``solve(program)``: its interior-point iterations); (iterations, (``answer()`` of the iterate of smallest
    change, the solver status of that iterate), the relative changes, the words of a
    :class:`~cvxcontact.errors.FixedPointWarning` if it did not converge, else None: :func:`full` warns if the exact
    finish does not reach Coulomb's law either)."""
    tol, most = fixed_point
    iterations = solve(stuck)
    solved = stuck                                         # the program whose solution the variables hold
    previous, changes, best, converged = None, [], None, False
    for _ in range(most + 1):
        c_all = problem.term.data.capacities(forces())
        c = c_all[rows]
        if previous is not None:
            changes.append(float(np.abs(c - previous).max(initial=0.0)
                                 / max(float(c.max(initial=0.0)), float(previous.max(initial=0.0)),
                                       np.finfo(float).tiny)))
            if best is None or changes[-1] <= min(changes[:-1]):   # the iterate closest to its own law
                best = answer(), solved.status
            if changes[-1] <= tol or (changes[-1] <= RESOLUTION and len(changes) > 1
                                      and changes[-1] > 0.9 * changes[-2]):
                converged = True                 # below the tolerance, or at the interior point's resolution
                break
            if len(changes) == most:
                break
        if problem.kernel is not None:
            refuse_sliding(problem.kernel.with_capacity(c_all * problem.units.force),
                           "the friction coefficient times the normal force of the fixed point's iterate "
                           f"{len(changes) + 1}", "raise the friction coefficient")
        capacity.value = c
        iterations += solve(program)
        solved, previous = program, c
    unsettled = None if converged else (
        f"Coulomb friction: the fixed point on the slip thresholds changed them by {changes[-1]:.3g} (relative) at "
        f"its last iteration ({len(changes)}), above the tolerance {tol:.3g}, and the exact finish from it was "
        f"declined: the answer is its iterate of smallest change ({min(changes):.3g}; its checks say how far from "
        f"Coulomb's law): raise Coulomb(max_iterations=...), or lower the coefficient (the fixed point contracts "
        f"for small mu only)")
    return iterations, best, tuple(changes), unsettled
