"""Routes for nodal non-penetration rows (Signorini, the paper's (8); P1 and the P2 nodal conditions): the full
program, the condensed interface program and the sparse active-set route, each finished exactly
(docs/formulation.md §2, §7, §12; docs/architecture.md "The sparse route")."""

from __future__ import annotations

import logging
import time

import numpy as np

from ..errors import SolverError
from .condensed import InterfaceModel, quasi_definite_rhs
from ..contact.laws import RowLaws, Signorini
from .finish import (Declined, Stop, force_displacements, independent_active_set, independent_interface, ipm_active,
                     lcp_start, reach_forces, row_scales, signs_hold, solve_lcp, solve_sparse_compliance)
from .full import mixed_kkt
from .interface import condensation
from .mixed import mixed_system, stacked, unstacked
from .parallel import ParallelRows, looser_rows
from .program import release, timed_program
from .result import Finish, RawResult, Route

__all__ = ["full", "condensed", "sparse", "interface_finish", "newton_finish", "dependent_rows", "looser_rows",
           "ParallelRows"]

log = logging.getLogger(__name__)


def dependent_rows(problem) -> bool:
    """Whether the contact rows can be linearly dependent: "gamma3" (the pair's own condition, else the one
    given) on a 3D pair of two bodies, one row per overlay vertex, more vertices than the jump's degrees of
    freedom where the faces do not match (docs/formulation.md §13), unless the space marks them independent
    (``lines.independent``: Q1 hexahedra on nested faces, one row per node of the finer side); or a penetration
    limit on rows the space marks as dependent (``lines.dependent``: a compliance law's quadrature points on P2
    faces, §15)."""
    rows = problem.rows
    if problem.lines.dependent and (rows.limited & rows.rows).any():
        return True
    if problem.dim != 3 or problem.lines.independent:
        return False
    interfaces = getattr(problem.interface, "interfaces", (problem.interface,))
    conditions = [c or problem.condition for c in problem.scene.conditions]
    return any(c == "gamma3" and not getattr(i, "rigid", True) for i, c in zip(interfaces, conditions))


def mixed_finish(problem, raw, timings, hold=None, blocks=None):
    """The exact finish on the sparse mixed system (26) (:func:`~cvxcontact.backends.finish.independent_active_set`,
    Lawson-Hanson on the dual: finite, its passive rows independent, its signs measured on each row's own
    displacement scale), from the interior point's forces and active set in ``raw``; fills ``raw``. The one
    finish of the mixed system: rows that may be dependent (3D "gamma3" overlays), bodies held by the contact
    only, force-controlled obstacles (``hold``: the interior point's translations, for the components no
    active row sees, see :func:`~cvxcontact.backends.full.mixed_kkt`). ``blocks``: the bodies' blocks (default
    the problem's; :func:`~cvxcontact.backends.forced.gamma_blocks`: condensed onto their Gamma dofs)."""
    t0 = time.perf_counter()
    tr = list(problem.translations)
    kkt = mixed_kkt(problem.blocks if blocks is None else blocks, problem.E, problem.g, translations=tr, hold=hold)
    free = ~problem.held_rows
    out = independent_active_set(kkt, problem.g, np.where(free, raw.y, 0.0), raw.active & free)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = out
        return raw
    x, raw.active, raw.iterations = out[0], out[1], raw.iterations + out[2]
    raw.u, raw.phi, raw.y = x[:3]
    if tr:
        raw.taus = list(x[3])
    raw.polished, raw.finish = True, "independent active set"
    return raw


def newton_finish(problem, raw, timings):
    """The exact finish of a non-quadratic bulk energy (the paper's nonlinear A, e.g. Hencky) with Signorini rows:
    semismooth Newton on the nonlinear mixed system (26), the tangent from the energy's Hessian, inside
    primal-dual active-set steps on the contact rows, damped on the energy
    (:func:`~cvxcontact.backends.finish.solve_sparse_compliance` with every row a Signorini row, on
    :class:`~cvxcontact.backends.mixed.MixedEnergy`), from the interior point's answer and active set in
    ``raw``; fills ``raw`` or its ``declined`` (then the interior point is kept). Rows that may be linearly
    dependent (:func:`dependent_rows`) are declined: the steps close the active rows as they are, which
    dependent rows make singular."""
    if dependent_rows(problem):
        raw.declined = Declined(Stop.DEPENDENT_ROWS, "the contact rows may be linearly dependent (3D 'gamma3' "
                                "between bodies); the Newton finish of a non-quadratic energy closes the active rows "
                                "as they are")
        return raw
    t0 = time.perf_counter()
    E, g, blocks = problem.E, problem.g, problem.blocks
    moved = problem.moved_g(raw.taus)
    parts = [E @ (b.jump @ uk) for b, uk in zip(blocks, raw.u)]
    start = ipm_active(parts, moved, raw.y, force_displacements(blocks, E, raw.y),
                       reach_forces(blocks, E, raw.u, raw.phi)) & ~problem.held_rows
    op, G, widths = mixed_system(problem)
    out = solve_sparse_compliance(op, G, g, np.zeros(len(g)), RowLaws.uniform(Signorini(), len(g)),
                                  stacked(raw.u, raw.phi, raw.taus), start)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = out.within("the Newton steps on the nonlinear mixed system did not settle")
        # (a singular step's rows go to the well-posedness check, backends/run.py)
        return raw
    x, raw.y, _, raw.active, steps, history = out
    log.info("Newton finish of the bulk energy: %d steps, relative residuals %s", steps,
             ", ".join(f"{h:.1e}" for h in history))
    raw.u, raw.phi, raw.taus = unstacked(problem, x, widths)
    raw.polished, raw.finish, raw.iterations = True, Finish.NEWTON_BULK, raw.iterations + steps
    return raw


def interface_finish(compliance, d, start, timings, dependent=None, max_iter=None, g=None):
    """Exact LCP solution (y, active, finish) on the interface from the active set ``start``, or why it declined
    (a :class:`~cvxcontact.backends.finish.declined.Declined`). ``g``: the rows' gaps (scaled), which order the
    rows of several obstacles at one node: a row a tighter parallel row implies is left open (its force 0,
    :meth:`~cvxcontact.backends.condensed.Compliance.looser`, as on the sparse and AMG routes; closed beside
    that row W_AA is singular, the steps fail and the answer would rest on the Lawson-Hanson fallback: a 2D P2
    block on a floor and a kinked obstacle both closed at x = 0.3, the floor listed first, read ok=False,
    tests/test_p2_two_runs.py).
    ``dependent``: (v0, g, y0) for rows that may be linearly dependent (W singular, :func:`dependent_rows`):
    the finish of :func:`~cvxcontact.backends.finish.independent_interface` from the forces y0 instead, in at
    most ``max_iter`` Lawson-Hanson steps (None: its own bound)."""
    t0 = time.perf_counter()
    if dependent is None:
        out = solve_lcp(compliance.W, d, start, kept=compliance.last_factor,
                        implied=None if g is None else compliance.looser(g))
    else:
        v0, g, y0 = dependent
        res = independent_interface(compliance, v0, g, y0, start, max_iter=max_iter)
        out = res if isinstance(res, Declined) else (res[0], res[1], "independent active set")
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    return out


def full(problem, cache, settings, timings) -> RawResult:
    """The whole phi-form program in CVXPY (the reference), finished exactly: on the interface (bodies held by
    their supports) or on the sparse mixed system (bodies held by the contact, force-controlled obstacles)."""
    t0 = time.perf_counter()
    E, g, blocks, tr = problem.E, problem.g, problem.blocks, list(problem.translations)
    model = problem.term.program(problem)              # its rows (full.signorini_program)
    timings["model"] = time.perf_counter() - t0
    iterations = timed_program(model.problem, settings, timings)
    raw = RawResult(u=[v.value for v in model.u], phi=[v.value if v is not None else None for v in model.phi],
                    y=np.asarray(model.contact.dual_value, dtype=float).ravel(), program=model.problem,
                    taus=[np.asarray(t.value, dtype=float).ravel() for t in model.t], method="full",
                    iterations=iterations)
    if not problem.quadratic:          # the finishes below solve linear systems of Kuu: Newton on (26) instead
        if settings.polish:
            newton_finish(problem, raw, timings)
        if not raw.polished:
            raw.route = Route.INTERIOR_POINT_NONLINEAR_ENERGY
        return raw
    moved = problem.moved_g(raw.taus)                                   # the obstacles moved
    parts = [E @ (b.jump @ uk) for b, uk in zip(blocks, raw.u)]
    slack = sum(parts) - moved
    raw.active = ipm_active(parts, moved, raw.y, force_displacements(blocks, E, raw.y),
                            reach_forces(blocks, E, raw.u, raw.phi))
    if not settings.polish:
        return raw
    if dependent_rows(problem) or problem.held or tr:
        return mixed_finish(problem, raw, timings, hold=raw.taus or None)
    reduction = condensation(problem, cache, settings, timings)
    _, _, d = reduction.apply(problem, timings)
    W = reduction.W
    out = interface_finish(reduction.compliance, d, lcp_start(W, d, raw.y, slack), timings, g=g)
    if isinstance(out, Declined):
        raw.declined = out
        return raw
    t0 = time.perf_counter()
    exact = mixed_kkt(blocks, E, g)(out[1])      # the full model's own sparse solve
    timings["polish"] += time.perf_counter() - t0
    w, S = row_scales(W, d, out[0])
    if exact is not None and signs_hold(exact[1], exact[2], out[1], w, S):
        (raw.u, raw.phi, raw.y), raw.active, raw.polished, raw.finish = exact[0], out[1], True, out[2]
    else:
        raw.declined = Declined(Stop.SIGNS, "the sparse mixed system on the finished active set is singular or breaks "
                                "the signs")
    return raw


WARM_STEPS = 40
"""The Lawson-Hanson steps a re-solve on dependent rows (3D "gamma3") takes from the previous exact answer before it
solves the interface program instead: each step adds or drops one row, and a changed load can move hundreds of
rows (two elastic boxes, 19,953 unknowns, body force changed by 1 %, 10 %, 30 %: 562, 123, 11 steps from the
previous answer; the program and its finish, about 20 steps' time at 5e4 unknowns: measured in
benchmarks/results/bench_gamma3_scale.md)."""


def condensed(problem, cache, settings, timings) -> RawResult:
    """Each body condensed onto its contact dofs, the interface QP, the exact LCP finish, one back-substitution
    per body; a re-solve starts from the previous exact active set (no program). Force-controlled obstacles,
    bodies held by the contact only: :func:`~cvxcontact.backends.forced.signorini`."""
    if problem.translations or problem.held:
        from .forced import signorini as forced

        return forced(problem, cache, settings, timings)
    E, g = problem.E, problem.g
    dependent = dependent_rows(problem)
    reduction = condensation(problem, cache, settings, timings, whole=not dependent)   # dependent: W's block
    cond, compliance = reduction.bodies, reduction.compliance
    v0, loads, d = reduction.apply(problem, timings)
    warm = settings.warm_start and settings.polish and cache.active is not None

    def finish(start, y0, max_iter=None):
        return interface_finish(compliance, d, start, timings, (v0, g, y0) if dependent else None, max_iter, g)

    # dependent rows: the previous forces start the finish, for at most WARM_STEPS steps, else the program
    out = finish(cache.active, cache.own.get("condensed forces", cache.active), WARM_STEPS) if warm else None
    raw = RawResult(u=[], phi=[], y=np.zeros(len(d)), method="condensed")
    if out is not None and not isinstance(out, Declined):  # re-solve: the previous active set, corrected
        raw.y, raw.active, raw.polished, raw.route, raw.finish = out[0], out[1], True, Route.WARM_START, out[2]
    else:
        t0 = time.perf_counter()
        model = InterfaceModel(cond, loads, E, g)
        timings["model"] = time.perf_counter() - t0
        raw.iterations = timed_program(model.problem, settings, timings)
        raw.y = np.asarray(model.contact.dual_value, dtype=float).ravel()
        parts = [E @ (c.jump @ var.value) for c, var in zip(cond, model.v)]
        slack = sum(parts) - g
        raw.active = ipm_active(parts, g, raw.y, force_displacements(problem.blocks, E, raw.y))
        raw.program = model.problem
        release(model.problem)             # its compiled data and Clarabel's factors: not needed by the finish
        if settings.polish:
            out = finish(raw.active if dependent else lcp_start(compliance.W, d, raw.y, slack), raw.y)
            if isinstance(out, Declined):
                raw.declined = out
            else:
                raw.y, raw.active, raw.polished, raw.finish = out[0], out[1], True, out[2]
    if raw.polished and not dependent:      # the closed rows met to rounding (Condensation.invert_closed)
        raw.u, raw.phi, raw.y = reduction.invert_closed(problem, raw.y, raw.active, timings)
    else:
        raw.u, raw.phi = reduction.invert(problem, raw.y, timings)
    if raw.polished:
        cache.active, cache.own["condensed forces"] = raw.active, raw.y
    return raw


def sparse(problem, cache, settings, timings) -> RawResult:
    """Active-set steps on the sparse mixed system (26) (:mod:`cvxcontact.backends.sparse`), from the bonded
    system (first solve; above :data:`~cvxcontact.backends.sparse.COARSE_ROWS` free rows from the answer of the
    coarse rows, :meth:`~cvxcontact.backends.sparse.SparseContact.coarse_start`, the bonded system if that
    leads nowhere) or the previous active set (re-solve); where every start tried leads nowhere, from the coarse
    rows' answer whatever the size (measured: thin_layer(200) on a flat gap, and a thin clamped plate on a
    block with a crowned gap at 1,681 rows, where the steps from the bonded start cycle). Exact, no interior
    point (``polish`` does not apply). ``iterations`` counts the systems solved. A row a tighter parallel row implies
    stays open (:func:`looser_rows`: two obstacles at one node; the groups, :class:`ParallelRows`, kept in
    ``cache.own["parallel rows"]`` for the geometry); where the steps still do not settle, the condensed
    route answers (:func:`_hand_over`, route ``SPARSE_HANDED_OVER``)."""
    from .sparse import COARSE_ROWS, SparseContact

    if dependent_rows(problem):
        return _sparse_dependent(problem, cache, settings, timings)
    if cache.sparse is None:
        cache.sparse = SparseContact(list(problem.blocks), problem.E, factorization=settings.factorization)
    sc, f0 = cache.sparse, cache.sparse.factor_time
    t0 = time.perf_counter()
    warm = settings.warm_start and cache.active is not None
    rhs = np.concatenate([quasi_definite_rhs(b) for b in problem.blocks])
    free = ~problem.held_rows        # a row no unknown moves stays open (closed, K(A) would be singular; §8)
    if cache.own.get("parallel rows") is None:        # the parallel groups of the rows: once per geometry
        cache.own["parallel rows"] = ParallelRows(sc.G)
    free &= ~cache.own["parallel rows"].looser(problem.g)   # so does a row a tighter parallel row implies (K(A)
    # singular too: :func:`looser_rows`)
    if not settings.warm_start:
        first = cheap_start(problem, free)
        fresh_analysis(sc, free if first is None else first)
    out = sc.solve(rhs, problem.g, cache.active & free, free=free) if warm else None
    start, coarse = cheap_start(problem, free), False
    if out is None and start is None and int(free.sum()) >= COARSE_ROWS:    # a long interface: from the
        start, coarse = sc.coarse_start(rhs, problem.g, free), True           # answer of its coarse rows
    if out is None and start is not None:                  # 3D: the rows the obstacles already close
        out, warm = sc.solve(rhs, problem.g, start, free=free), False
    if out is None:                                        # first solve, or the previous set led nowhere
        out = sc.solve(rhs, problem.g, free, free=free)    # from the bonded system of the rows that move
        warm = False
    if out is None and not coarse:                         # the bonded start led nowhere either: the coarse
        start = sc.coarse_start(rhs, problem.g, free)      # rows' answer, whatever the size
        out = None if start is None else sc.solve(rhs, problem.g, start, free=free)
    if sc.factor_time > f0:
        timings["factorization"] = timings.get("factorization", 0.0) + sc.factor_time - f0
    timings["active_set"] = time.perf_counter() - t0 - (sc.factor_time - f0)
    if out is None:
        return _hand_over(problem, cache, settings, timings, "the active-set steps on the sparse mixed system did "
                          "not settle (they cycled or met a singular system)")
    u, phi, y, active, steps = out
    cache.active = active
    return RawResult(u=u, phi=phi, y=y, active=active, polished=True, iterations=steps, method="sparse",
                     route=Route.WARM_START if warm else Route.SPARSE_ACTIVE_SET, finish="active set",
                     factorization=sc.factorization)


def _hand_over(problem, cache, settings, timings, reason: str) -> RawResult:
    """The condensed route's answer where the sparse route's steps stopped (``reason``), route
    :attr:`~cvxcontact.backends.result.Route.SPARSE_HANDED_OVER`: a route the package has must not leave the call
    failing. Not above :data:`~cvxcontact.backends.SPARSE_ROWS` rows (the condensed route's dense m x m interface
    matrices, 0.5 GB there): SolverError with ``reason`` then."""
    from . import SPARSE_ROWS

    if len(problem.g) > SPARSE_ROWS:
        raise SolverError(f"{reason}; use method='condensed' or 'full'")
    log.info("%s; the condensed route answers instead", reason)
    cache.active = None         # from no previous set: a fresh solver's hand-over, bit for bit
    raw = condensed(problem, cache, settings, timings)
    raw.route, raw.handed_over = Route.SPARSE_HANDED_OVER, reason
    cache.active = None         # the next solve's sparse steps start cold too: warm from this set they may settle
    return raw                  # (sparse bits), where a fresh solver hands over again (condensed bits)


def _sparse_dependent(problem, cache, settings, timings) -> RawResult:
    """The sparse route for rows that may be linearly dependent (P1 "gamma3" between 3D bodies, docs/formulation.md
    §13): two stages on the sparse mixed system (26), no interior point and no dense interface matrix.

    1. the regularised problem, each closed row a compliant by ``SOFT`` times its own compliance w_a
       (G_a x - SOFT w_a y_a = g_a: the mixed matrix is quasi-definite whatever the dependence of the rows, its
       forces unique), by the active-set steps of :meth:`~cvxcontact.backends.sparse.SparseContact.solve` from the
       previous regularised set (re-solve), the rows the obstacles already close (3D) or the bonded system. As
       SOFT -> 0 its forces tend to the least (compliance-weighted) norm forces of the exact problem, which are
       >= 0 on every closed row: the start an interior point gives the finish, at the cost of a few sparse
       factorisations;
    2. the exact finish, :meth:`~cvxcontact.backends.sparse.SparseContact.independent` (crossover of those forces
       onto an independent subset, then Lawson-Hanson on the dual, finite), each step on the exact mixed system
       with the independent passive rows closed, by the capacitance form on one base factor."""
    from .sparse import SOFT, SOFT_PATH, SparseContact

    E, g = problem.E, problem.g
    if cache.sparse is None or getattr(cache.sparse, "twin", None) is None:
        cache.sparse = SparseContact(list(problem.blocks), E, factorization=settings.factorization)
        cache.sparse.twin = SparseContact(list(problem.blocks), E, factorization=settings.factorization,
                                          soft=SOFT * cache.sparse.w)
        cache.sparse.twin.last = None
    sc, soft = cache.sparse, cache.sparse.twin
    f0 = sc.factor_time + soft.factor_time
    t0 = time.perf_counter()
    rhs = np.concatenate([quasi_definite_rhs(b) for b in problem.blocks])
    free = ~problem.held_rows
    warm = settings.warm_start and soft.last is not None
    start = cheap_start(problem)
    if not settings.warm_start:                        # (the regularised steps' analysis too, as a fresh solver's)
        fresh_analysis(soft, free if start is None else start)
    active, steps, out = soft.last & free if warm else (free if start is None else start), 0, None
    for delta in (SOFT,) if warm else SOFT_PATH:      # continuation: each stage starts near its answer
        soft.set_soft(delta * sc.w)
        out = soft.regularised(rhs, g, active)
        if out is None:
            break
        active, steps = out[1], steps + out[2]
    if out is None:
        return _hand_over(problem, cache, settings, timings, "the Newton steps of the regularised problem on the "
                          "sparse mixed system did not settle (a singular system)")
    soft.last = out[1]
    if sc.perm is None and soft.perm is not None:
        sc.perm = soft.perm                              # one pattern: one fill-reducing ordering
    if not settings.warm_start:   # a cold solve: the finish's PARDISO analysis (scaling, matching) and base on its
        sc.forget(analysis=True)  # own values, a fresh solver's bits (an earlier load's rounds otherwise: 3e-15)
    exact = sc.independent(rhs, g, out[0], out[1] & free)
    if sc.factor_time + soft.factor_time > f0:
        timings["factorization"] = timings.get("factorization", 0.0) + sc.factor_time + soft.factor_time - f0
    timings["active_set"] = time.perf_counter() - t0 - (sc.factor_time + soft.factor_time - f0)
    if isinstance(exact, Declined):
        raise SolverError(f"the exact finish on the sparse mixed system stopped ({exact}); use method='condensed' "
                          "or 'full'")
    u, phi, y, active, lh_steps = exact
    cache.active = active
    return RawResult(u=u, phi=phi, y=y, active=active, polished=True, iterations=steps + lh_steps, method="sparse",
                     route=Route.WARM_START if warm else Route.SPARSE_ACTIVE_SET, finish="independent active set",
                     factorization=sc.factorization)


def fresh_analysis(sc, first) -> None:
    """With warm_start=False each load is solved as by a fresh solver: PARDISO's analysis of ``sc`` (its scaling and
    weighted matching, :meth:`~cvxcontact.backends.sparse.SparseContact._refactor`) is made on the first system it
    factorises, K(``first``); kept while the cold solves start from the same rows (the same analysis), made anew
    where they start from others (an earlier start's: 4.3e-13 relative in u from a fresh solver's on two_boxes(6)
    with a deeper gap, tests/test_same_bits.py)."""
    key = np.asarray(first, dtype=bool).tobytes()
    if getattr(sc, "analysed_on", key) != key:
        sc.forget(analysis=True)
    sc.analysed_on = key


def cheap_start(problem, free=None):
    """The first active set of a 3D sparse solve: the rows that move and whose gap is already closed (g <= 0,
    e.g. the nodes inside a rigid sphere's initial overlap); None in 2D, or where it is every such row or none
    (then the bonded start). Why 3D: a contact zone is a patch there, and from the bonded start the steps
    open it ring by ring, each ring more rows than the capacitance form takes, i.e. one refactorisation per
    step (measured, a sphere 0.02 m into a block, 22,500 unknowns, 625 rows: bonded start 6 steps and 4
    factorisations, this start 2 steps and 1). In 2D it is not used: on thin_layer(1000) (a crowned gap
    closed at one node) the steps from it do not settle. ``free``: the rows that may close (default: those that
    move)."""
    if problem.dim != 3:
        return None
    free = ~problem.held_rows if free is None else free
    start = free & (np.asarray(problem.g) <= 0.0)
    return start if 0 < start.sum() < free.sum() else None
