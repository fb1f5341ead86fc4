"""The exact finish of P2 "everywhere" cones beside a non-quadratic bulk energy by accumulated cuts on the nonlinear
(26) (a Hencky body; docs/formulation.md §16, §19).

Where Newton at the tangency points on the nonlinear (26) does not settle (3D: the triangles' copositive cones,
whose tangency structure keeps moving between rounds), the cones are replaced by point rows q(x_p) <= 0 at
accumulated cut points (:func:`~cvxcontact.backends.cuts.accumulate_cuts`), as the cones of a linear material are
finished (:func:`~cvxcontact.backends.cones.finish_cuts_mixed`), and each round's nodal problem at the points is the
nonlinear one: minimise the bodies' energy L(x) (:class:`~cvxcontact.backends.mixed.MixedEnergy`) subject to the
point rows. It is solved by sequential quadratic steps at fixed points: the energy's second-order model at the
current x (:func:`~cvxcontact.backends.mixed.tangent_blocks`: the Hencky tangent in place of Kuu, the gradient in the
load) solved with the point rows exactly by the linear finish's active set on rows that may depend on each other
(:func:`~cvxcontact.backends.finish.independent_active_set`), warm started from the last step's forces; the steps
stop once the residual of the nonlinear (26) at the points, grad L(x) + (P G)^T y, is at rounding of its terms
(:data:`BULK_RESIDUAL_TOL`), or once it no longer halves below :data:`BULK_STALL_TOL`. The acceptance is the cuts'
own: the exact maximum of each triangle's slack over its Bernstein form (``bernstein_max``) within the cuts'
tolerance of its displacement scale. Fields, forces and the read-back are the nonlinear problem's.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp

from .cuts import (
    accumulate_cuts,
    nodal_slack,
    point_read_back,
    seed_forces,
    seed_points,
)
from .finish import Declined, Stop, independent_active_set, row_reach
from .full import mixed_kkt
from .mixed import mixed_system, stacked, tangent_blocks, unstacked
from .result import Finish

__all__ = ["finish_cuts_bulk"]

log = logging.getLogger(__name__)

BULK_CUT_TOL = 1e-13
"""The cuts' stopping violation, relative to each element's displacement scale (below it, a violation that no longer
halves is rounding: :data:`~cvxcontact.backends.cuts.STALL_TOL`). The fields of a relaxation at points are within
about the square root of its violation: measured on :func:`scenes3d.bumped_blocks` (4 x 4 x 2 / 5 x 3 x 2 cells)
with a Hencky block that never yields, 2.6e-6 from the linear material's answer with 1e-11 (the linear finish's
:data:`~cvxcontact.backends.cones.MIXED_CUT_TOL`), 4.7e-7 with 1e-13 (stalled at 9.5e-13 after 8 rounds), CPU 10.1 s
and 12.7 s; its energy (the material's density summed at the quadrature points) is the lower by 1.5e-9 J of 597 J,
its sampled penetration 3.0e-12 of the displacements against the linear finish's 2.5e-11."""

BULK_ACCEPT_TOL = 1e-11
"""The violation at which the cuts' last round is accepted once their rounds are spent without reaching
:data:`BULK_CUT_TOL` (the linear finish's own stopping violation, :data:`~cvxcontact.backends.cones.MIXED_CUT_TOL`,
above the 1e-12 to which each round's active-set solve closes its rows: measured, a Hencky block under a
piezoelectric one driven at 50 V, 2 x 2 x 1 / 3 x 2 x 1 cells, oscillates at 1.1e-12 for 40 rounds, neither
reaching 1e-13 nor stalling below :data:`~cvxcontact.backends.cuts.STALL_TOL`)."""

BULK_RESIDUAL_TOL = 1e-13
"""The relative residual of the nonlinear (26) at the points (each row against the sizes of its terms) at which the
sequential quadratic steps of a round stop."""

BULK_STALL_TOL = 1e-10
"""Below this relative residual, steps that no longer halve it stop the round (rounding of the energy's gradient)."""

BULK_STEPS = 30
"""The most sequential quadratic steps of one round; a round that does not reach :data:`BULK_STALL_TOL` declines."""


def finish_cuts_bulk(problem, timings, raw, seeds=None) -> bool:
    """The finish of the module docstring from a solved cone program ``raw`` beside a non-quadratic energy (scaled:
    its fields and translations, the start of the steps, and its Bernstein duals ``raw.beta``, whose tangency points
    are the first cut points), or from ``seeds`` (element, t, y: cut points and their forces, e.g. the cuts' answer
    on the energy's tangent, :func:`~cvxcontact.backends.cones.finish_bulk`; ``raw``'s fields then theirs).
    Updates ``raw`` (u, phi, taus, y, beta, active, pairing, points, finish) and returns True, or sets
    ``raw.declined`` and returns False (the rounds and the sequential quadratic steps are logged)."""
    B, cells = problem.lines.cone
    width = cells.shape[1]
    B = sp.csr_matrix(B)
    E, g = problem.E, np.asarray(problem.g, dtype=float)
    tr = list(problem.translations)
    held = problem.held_rows
    op, G, widths = mixed_system(problem)
    t0 = time.perf_counter()
    reach = row_reach(mixed_kkt(problem.blocks, E, g, translations=tr).matrix, G)
    if seeds is None:
        segment, t = seed_points(B, raw.beta, width=width)
        y0 = seed_forces(segment, t, raw.beta)
    else:
        segment, t, y0 = (np.asarray(a) for a in seeds)
    state = {"x": stacked(raw.u, raw.phi, raw.taus if tr else ()), "y": y0, "steps": 0}

    def solve(P, delta):
        P = sp.csr_matrix(P)
        gp = P @ g + delta
        GP = (P @ G).tocsr()
        k = P.shape[0]
        y = np.zeros(k)
        y[:min(k, len(state["y"]))] = state["y"][:k]
        x = state["x"]
        last = res = np.inf
        for _ in range(BULK_STEPS):
            u, _, _ = unstacked(problem, x, widths)
            blocks = tangent_blocks(problem.blocks, u)
            kkt = mixed_kkt(blocks, P @ E, gp, translations=[(P @ R, F) for R, F in tr])
            out = independent_active_set(kkt, gp, y, y > 0, factored=True, purify=False)
            if isinstance(out, Declined):
                out = independent_active_set(kkt, gp, y, y > 0, factored=False, purify=False)
            if isinstance(out, Declined):
                state["why"] = out
                return None
            fields, active = out[0], out[1]
            state["steps"] += 1
            x = stacked(fields[0], fields[1], list(fields[3]) if tr else ())
            y = fields[2]
            res = op.residual(x, (GP, y))
            if res <= BULK_RESIDUAL_TOL or (res <= BULK_STALL_TOL and res > 0.5 * last):
                break
            last = res
        else:
            if res > BULK_STALL_TOL:
                state["why"] = Declined(Stop.STALL, f"the sequential quadratic steps at the cut points stalled at a "
                                        f"relative residual {res:.1e} of the nonlinear (26)")
                return None
        state.update(x=x, y=y)
        slack, scale = nodal_slack(G @ x - g, reach @ np.abs(x) + np.abs(g), g, held)
        return y, slack, scale, x, active

    out = accumulate_cuts(B, solve, segment, t, width=width, tol=BULK_CUT_TOL, departure=problem.departure,
                          accept=BULK_ACCEPT_TOL)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = Declined(out.stop, f"{out} ({state['why']})" if "why" in state else str(out))
        return False
    x = out["state"]
    raw.u, raw.phi, taus = unstacked(problem, x, widths)
    if tr:
        raw.taus = taus
    raw.y, raw.active = point_read_back(B, out["segment"], out["t"], out["y"], out["active"])
    raw.beta, raw.pairing = out["beta"], out["pairing"]
    raw.points = (out["segment"], out["t"], out["y"])
    raw.polished, raw.finish, raw.declined = True, Finish.ACCUMULATED_CUTS, None
    log.info("the cuts on the nonlinear (26): %d rounds, %d sequential quadratic steps, violation %.1e",
             out["rounds"], state["steps"], out["violation"])
    return True
