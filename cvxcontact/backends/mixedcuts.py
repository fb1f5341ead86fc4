"""The exact finish of P2 "everywhere" cones beside a normal-compliance law by accumulated cuts (docs/formulation.md
§16, "Beside a compliance law").

Where Newton at the tangency points (:func:`~cvxcontact.backends.tangency.tangency_newton`) declines on a program
mixing the cones with a compliance law (3D: a face in full contact leaves its six Bernstein rows, and the rows of
its neighbours, dependent, so the mixed system on the active set is singular), the cones are replaced by point rows
r(x_p) <= 0 at accumulated cut points (:func:`~cvxcontact.backends.cuts.accumulate_cuts`, as the cones alone are
finished, :func:`~cvxcontact.backends.cones.finish_cuts_mixed`). Each round's nodal problem holds the compliance
law's rows, the nodal pairs' rows with their limits and the point rows (Signorini rows, limit 0) on the sparse mixed
system (26): :func:`~cvxcontact.backends.compliance.dependent_newton` solves it exactly whatever the dependence of
the rows with a limit (Newton on the law, its inner active set on independent rows).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..contact.laws import RowLaws, Signorini
from .compliance import dependent_newton, linear_mixed_system
from .cuts import (
    accumulate_cuts,
    nodal_slack,
    point_read_back,
    seed_forces,
    seed_points,
)
from .finish import Declined, Stop
from .mixed import stacked, unstacked
from .result import Finish

__all__ = ["finish_cuts_compliance"]

MIXED_CUT_TOL = 1e-11
"""The cuts' stopping violation, relative to each element's displacement scale (as the cones alone)."""


def finish_cuts_compliance(problem, timings, raw, B) -> bool:
    """The finish of the module docstring on a solved cone/compliance program ``raw`` (scaled: its fields, the
    Bernstein duals ``raw.beta`` (S, w) of the cones ``B`` (w S, N) on the rows of E, the row forces y = w p(r) + z
    and z). Bodies held by their supports only (no held rows, no force-controlled obstacle) and cones on rows the
    law does not weigh: a Signorini pair's, and a limited compliant pair's nodes of X_h beside its quadrature rows
    (3D: the cone at g + l, the point rows r(x_p) <= l); a cone on the law's own rows (2D P2: its nodes) is
    declined. Updates
    ``raw`` (u, phi, y, z, beta, active, finish) and returns True, or sets ``raw.declined`` and returns False."""
    law, g, w = problem.scaled_law, np.asarray(problem.g, dtype=float), np.asarray(problem.weights, dtype=float)
    if list(problem.translations) or np.any(problem.held_rows):
        raw.declined = Declined(Stop.NOT_POSED, "the cuts beside a compliance law take bodies held by their supports")
        return False
    if np.any((w > 0) & np.asarray(law.cone)):          # 2D P2: the cone at g + l on the law's own rows
        raw.declined = Declined(Stop.NOT_POSED, "the cuts beside a compliance law take cones off the law's rows")
        return False
    t0 = time.perf_counter()
    width = int(np.shape(raw.beta)[1])
    B = sp.csr_matrix(B)
    A, F, G, widths = linear_mixed_system(problem)
    rows = np.flatnonzero(~np.asarray(law.cone))             # the law's rows and the nodal pairs' rows
    off = law.off_cone()                                     # the law's rows (a cone pair's without its limit)
    laws, counts = list(off.laws) + [Signorini()], list(off.counts)
    shift = np.asarray(law.cone_shift, dtype=float)          # the cone at g + l of a limited compliant pair
    z_start = np.maximum(np.asarray(raw.z, dtype=float), 0.0)[rows] if raw.z is not None else np.zeros(len(rows))
    state = {"x": stacked(raw.u, raw.phi, raw.taus or ()), "z": z_start}
    segment, t = seed_points(B, raw.beta, width=width)
    state["y"] = seed_forces(segment, t, raw.beta)
    absG = abs(G)

    def solve(P, delta):
        k = P.shape[0]
        Gr = sp.vstack([G[rows], P @ G], format="csr")
        gr = np.concatenate([g[rows], P @ (g + shift) + delta])
        wr = np.concatenate([w[rows], np.zeros(k)])
        y0 = np.zeros(k)
        y0[:min(k, len(state["y"]))] = state["y"][:k]
        z0 = np.concatenate([state["z"], y0])
        out = dependent_newton(A, F, Gr, gr, wr, RowLaws(laws, counts + [k]), state["x"], z0, z0 > 0)
        if isinstance(out, Declined):
            state["why"] = out
            return None
        x, _, z = out[:3]
        state.update(x=x, z=z[:len(rows)], y=z[len(rows):])
        slack, scale = nodal_slack(G @ x - g - shift, absG @ np.abs(x) + np.abs(g), g)
        return state["y"], slack, scale, (x, z), state["y"] > 0

    out = accumulate_cuts(B, solve, segment, t, width=width, tol=MIXED_CUT_TOL)
    timings["polish"] = timings.get("polish", 0.0) + time.perf_counter() - t0
    if isinstance(out, Declined):
        raw.declined = Declined(out.stop, f"{out} ({state['why']})" if "why" in state else str(out))
        return False
    x, z = out["state"]
    raw.u, raw.phi, raw.taus = unstacked(problem, x, widths)
    cone_force, _ = point_read_back(B, out["segment"], out["t"], out["y"], out["active"])
    raw.z = cone_force
    raw.z[rows] += z[:len(rows)]
    raw.y = w * law.pressure(G @ x - g) + raw.z
    raw.beta, raw.active = out["beta"], raw.y > 0
    raw.polished, raw.finish = True, Finish.ACCUMULATED_CUTS
    return True
