"""Is the contact zone resolved by the mesh? The check behind :class:`~cvxcontact.errors.ResolutionWarning`.

Along each side of each 2D contact pair, the contact zone is the set of the body's trace nodes where the
pressure it feels is positive (:meth:`Solution.traction <cvxcontact.solution.Solution.traction>`, above 1e-9
of its largest value, as :meth:`~cvxcontact.solution.Solution.in_contact`). Each connected run of such
nodes is one zone; the contact faces (trace edges; P2: a face is a vertex-midpoint-vertex edge) that touch
it carry its pressure (P2: the half-faces between consecutive P2 nodes, where the pressure has its values:
the README's P2 floor zone of 3 faces, 6 half-faces, reads its peak within 0.5 % of a mesh refined three
times). With fewer than :data:`MIN_CELLS` of them the pressure's shape across the zone is not
resolved: a Hertz zone of 1-3 faces gives a peak pressure tens of per cent off while the discrete problem is
solved exactly. A pair against a rigid obstacle has one side; 3D is not checked yet.
"""

from __future__ import annotations

import numpy as np

from .solution import pair_label

__all__ = ["unresolved", "zone_cells", "MIN_CELLS"]

MIN_CELLS = 4
"""The fewest contact faces of a body that must carry a contact zone's pressure."""


def zone_cells(x, pressure) -> list[tuple[int, float, float]]:
    """The contact zones along one trace: (faces touching the zone, s_first, s_last) per connected run of
    nodes with positive ``pressure`` (above 1e-9 of its largest value), ``x`` the nodes' tangential
    coordinates (m, sorted; P2: vertices and midpoints interleaved, and each half-face between two of its
    nodes counts as one cell)."""
    x, p = np.asarray(x, dtype=float), np.asarray(pressure, dtype=float)
    top = float(np.abs(p).max(initial=0.0))
    if top == 0 or len(x) < 2:
        return []
    on = p > 1e-9 * top
    touched = on[:-1] | on[1:]                                   # the intervals between consecutive nodes
    out = []
    edges = np.flatnonzero(np.diff(np.r_[0, touched.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        nodes = np.flatnonzero(on[a: b + 1]) + a
        out.append((int(b - a), float(x[nodes[0]]), float(x[nodes[-1]])))
    return out


def unresolved(sol) -> list[str]:
    """The messages of :class:`~cvxcontact.errors.ResolutionWarning` for ``sol`` (module docstring): one per
    contact zone of a side spanned by fewer than :data:`MIN_CELLS` cells; [] in 3D. Checked are the sides
    whose nodes carry the pair's forces (both under "gamma3", body l under "sigma_l", the body against a rigid
    obstacle: under "sigma2" the forces sit at body 2's nodes and the pressure body 1 feels is a row of
    spikes whatever body 1's mesh), and a zone that covers the whole face a side offers (a flat punch) has
    no edge to resolve and is not counted."""
    if sol.scene.dim != 2:
        return []
    out = []
    for i, pair in enumerate(sol.scene.contacts):
        sides = [(pair.body_a, pair.part_a)] + ([] if pair.rigid else [(pair.other, pair.part_b)])
        condition = sol.scene.conditions[i] or sol.condition
        merged = np.asarray(sol.contacts[i].x, dtype=float)
        for k, (body, part) in enumerate(sides):
            if not pair.rigid and condition in ("sigma1", "sigma2") and k != int(condition[-1]) - 1:
                continue
            x, p = sol.traction(k, i)
            x = np.asarray(x, dtype=float)
            tol = 1e-9 * max(float(np.ptp(x)), np.finfo(float).tiny)
            face = (x >= merged.min() - tol) & (x <= merged.max() + tol)       # the nodes that can touch
            for count, lo, hi in zone_cells(x, p):
                if count >= MIN_CELLS or (lo <= x[face].min() + tol and hi >= x[face].max() - tol):
                    continue
                h = float(np.median(np.diff(x[:: 2 if sol.degree == 2 else 1])))
                width = hi - lo
                out.append(f"contact[{i}] {pair_label(sol, i)}: the contact zone on {body.name}/{part} "
                           f"(s = {lo:.6g} to {hi:.6g} m, {width:.3g} m wide) is carried by {count} "
                           f"{'half-' if sol.degree == 2 else ''}face{'s' if count != 1 else ''} of {body.name} "
                           f"(fewer than {MIN_CELLS}; faces about {h:.3g} m long): its pressure is not resolved. "
                           f"Refine the contact face there: faces of at most {max(width, h) / MIN_CELLS:.3g} m "
                           f"along s = {lo:.6g} to {hi:.6g} m (e.g. cc.graded_block towards the zone, or more "
                           f"cells along {part!r}).")
    return out
