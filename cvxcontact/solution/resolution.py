"""Is the contact zone resolved by the mesh? The check behind :class:`~cvxcontact.errors.ResolutionWarning`.

Along each side of each 2D contact pair, the contact zone is the set of the body's trace nodes where the
pressure it feels is positive (:meth:`Solution.traction <cvxcontact.solution.Solution.traction>`, above 1e-9
of its largest value, as :meth:`~cvxcontact.solution.Solution.in_contact`). Each connected run of such
nodes is one zone; the contact faces (trace edges; P2: a face is a vertex-midpoint-vertex edge) that touch
it carry its pressure. With fewer than :data:`MIN_CELLS` of them the pressure's shape across the zone is not
resolved: a Hertz zone of 1-3 faces gives a peak pressure tens of per cent off while the discrete problem is
solved exactly. A pair against a rigid obstacle has one side; 3D is not checked yet.
"""

from __future__ import annotations

import numpy as np

from .solution import pair_label

__all__ = ["unresolved", "zone_cells", "MIN_CELLS"]

MIN_CELLS = 4
"""The fewest contact faces of a body that must carry a contact zone's pressure."""


def zone_cells(x, pressure, degree: int = 1) -> list[tuple[int, float, float]]:
    """The contact zones along one trace: (faces touching the zone, s_first, s_last) per connected run of
    nodes with positive ``pressure`` (above 1e-9 of its largest value), ``x`` the nodes' tangential
    coordinates (m, sorted; P2: vertices and midpoints interleaved)."""
    x, p = np.asarray(x, dtype=float), np.asarray(pressure, dtype=float)
    top = float(np.abs(p).max(initial=0.0))
    if top == 0 or len(x) < 2:
        return []
    on = p > 1e-9 * top
    step = 2 if degree == 2 else 1
    faces = np.arange(0, len(x) - 1, step)                       # face j spans nodes j .. j + step
    touched = np.zeros(len(faces), dtype=bool)
    for d in range(step + 1):
        touched |= on[faces + d]
    out = []
    edges = np.flatnonzero(np.diff(np.r_[0, touched.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        nodes = np.flatnonzero(on[faces[a]: faces[b - 1] + step + 1]) + faces[a]
        out.append((int(b - a), float(x[nodes[0]]), float(x[nodes[-1]])))
    return out


def unresolved(sol) -> list[str]:
    """The messages of :class:`~cvxcontact.errors.ResolutionWarning` for ``sol`` (module docstring): one per
    contact zone of a side spanned by fewer than :data:`MIN_CELLS` faces; [] in 3D."""
    if sol.scene.dim != 2:
        return []
    out = []
    for i, pair in enumerate(sol.scene.contacts):
        sides = [(pair.body_a, pair.part_a)] + ([] if pair.rigid else [(pair.other, pair.part_b)])
        for k, (body, part) in enumerate(sides):
            x, p = sol.traction(k, i)
            for count, lo, hi in zone_cells(x, p, sol.degree):
                if count >= MIN_CELLS:
                    continue
                h = float(np.median(np.diff(np.asarray(x)[:: 2 if sol.degree == 2 else 1])))
                width = hi - lo
                out.append(f"contact[{i}] {pair_label(sol, i)}: the contact zone on {body.name}/{part} "
                           f"(s = {lo:.6g} to {hi:.6g} m, {width:.3g} m wide) is carried by {count} contact "
                           f"face{'s' if count != 1 else ''} of {body.name} (fewer than {MIN_CELLS}; faces "
                           f"about {h:.3g} m long): its pressure is not resolved. Refine the contact face there: "
                           f"faces of at most {max(width, h) / MIN_CELLS:.3g} m along s = {lo:.6g} to {hi:.6g} m "
                           f"(e.g. cc.graded_block towards the zone, or more cells along {part!r}).")
    return out
