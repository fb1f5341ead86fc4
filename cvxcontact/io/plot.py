"""Figures with matplotlib: deformed bodies, and the contact pressure / [u_nu] along Gamma_3; in 3D the
pressure map in the plane of each contact surface with the contact zone outlined, and the deformed boundary.

Every axis and colour bar carries engineering prefixes on its ticks (matplotlib's EngFormatter:
"200 MPa", "5 mm", "2 kV"), so a millimetre part gets millimetre axes; every colour map has a colour
bar, the displacement magnification is stated in the title, and figures that compare conditions share
one scale per quantity. A quantity at rounding level (below ``ROUNDING`` times its scale) is drawn as
zero and its magnitude stated, not magnified into noise. P2 contact quantities are drawn as the
quadratic on each segment through their nodes, not only at the nodes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError
from ..fem.fields import body_fields
from ..fem.space import space
from ..fem.trace import TRACES, quadratic_curve

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..solution.solution import Solution

__all__ = ["plot_deformed", "plot_deformed_all", "plot_contact", "magnification", "si_prefix", "obstacle_outline",
           "draw_obstacles", "eng", "at_rounding", "quadratic_trace", "plot_contact_map", "contact_zone",
           "plot_deformed_3d", "plot_deformed_3d_all", "boundary_owners"]

_FIELDS = {"potential": ("electric potential", "V"), "von_mises": ("von Mises stress", "Pa")}
ROUNDING = 1e-12      # relative to a quantity's scale: below it, a value is rounding noise and drawn as 0
_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"))


def _pyplot():
    import matplotlib.pyplot as plt  # imported late: the solver path never needs matplotlib

    return plt


def si_prefix(values, unit: str) -> tuple[float, str]:
    """(factor, unit with prefix) so that the largest |value| / factor lies in [1, 1000):
    e.g. 2.3e6 Pa -> (1e6, "MPa"), 2e-5 m -> (1e-6, "µm"). All zero or empty -> (1, unit)."""
    finite = [np.abs(np.asarray(v, dtype=float)) for v in values if v is not None]
    top = max((float(np.nanmax(v)) for v in finite if v.size and np.isfinite(v).any()), default=0.0)
    if top == 0 or not np.isfinite(top):
        return 1.0, unit
    for factor, prefix in _PREFIXES:
        if top >= factor:
            return factor, prefix + unit
    return _PREFIXES[-1][0], _PREFIXES[-1][1] + unit


def magnification(solution, fraction=0.1) -> float:
    """A round factor (1, 2 or 5 times a power of ten) that shows the largest displacement
    as at most ``fraction`` of the scene size."""
    umax = max(float(np.abs(u).max()) for u in solution.u)
    if umax == 0:
        return 1.0
    raw = fraction * solution.scene.length / umax
    decade = 10.0 ** np.floor(np.log10(raw))
    return float(decade * max(m for m in (1, 2, 5) if m * decade <= raw))


def _field_values(solution, field):
    """Per body: the nodal potential or the element von Mises stress. P2: the potential at the vertices
    (listed first) and the stress at the centroids, drawn on the vertex triangulation."""
    if field == "potential":                  # the vertices' (listed first in every node set)
        return [p if p is None else p[:len(b.mesh.points)] for b, p in zip(solution.scene.bodies, solution.phi)]
    return [body_fields(b, u, p, space(getattr(solution, "degree", 1), b.mesh.cell).nodes(b)).von_mises
            for b, u, p in zip(solution.scene.bodies, solution.u, solution.phi)]


def eng(unit: str):
    """Tick formatter with engineering prefixes and ``unit`` (e.g. 2.3e6 with "Pa" -> "2.3 MPa")."""
    from matplotlib.ticker import EngFormatter

    return EngFormatter(unit=unit, sep="\N{THIN SPACE}")


def at_rounding(values, scale: float) -> tuple[np.ndarray, float | None]:
    """(values to draw, magnitude or None): values whose largest |value| is at most ``ROUNDING`` x ``scale``
    (a scale of the same quantity, e.g. the bodies' largest displacement for a jump) are rounding noise,
    returned as zeros with their magnitude; otherwise the values and None."""
    v = np.asarray(values, dtype=float)
    top = float(np.nanmax(np.abs(v))) if v.size else 0.0
    if 0 < top <= ROUNDING * scale:
        return np.zeros_like(v), top
    return v, None


def quadratic_trace(x, values, samples: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """The continuous piecewise quadratic through P2 nodes ``x`` (vertices and midpoints alternating,
    sorted, 2n + 1 of them) with nodal ``values``, sampled at ``samples`` points per segment
    (:meth:`QuadraticTrace.curve <cvxcontact.fem.trace.QuadraticTrace.curve>`)."""
    return quadratic_curve(x, values, samples)


def _draw(ax, x, v, degree, style, **kw):
    """Nodal values drawn with ``style`` (a marker and/or a line style); for P2 (an odd number of nodes)
    the line is the quadratic through the nodes and the markers sit at the nodes."""
    marker = "".join(ch for ch in style if ch in "os^vdx")
    line = style[len(marker):] if style.startswith(marker) else style.replace(marker, "")
    curve = TRACES[degree].curve(x, v)
    if curve is not None and line:
        xs, vs = curve
        ms = kw.pop("ms", 3)
        drawn = ax.plot(xs, vs, line, **kw)[0]
        if marker:
            ax.plot(x, v, marker, ms=ms, color=drawn.get_color())
        return drawn
    return ax.plot(x, v, style, **kw)[0]


def _check_field(field, who):
    if not isinstance(field, str) or field not in _FIELDS:
        raise SceneError(f"{who}: field must be one of {sorted(_FIELDS)}, got {field!r}")


def obstacle_outline(scene, pair: int, samples: int = 200) -> np.ndarray:
    """Points (n, 2) of the surface of the rigid obstacle of contact pair ``pair``, m, sampled
    across the scene's bounding box (extended by a quarter of its size on each side).

    Sampled through the obstacle's own distance function (no mesh): from points on the pair's
    line, stepping along its tangent, the surface point is reached along the row direction (the body's
    outward normal nu^a for a ray posing, towards the closest point otherwise: the foot point). A plane comes out as a straight segment across the plot, a circle as the arc
    that faces the body, a profile as its sampled curve. Empty (0, 2) where the rays miss."""
    itf = scene.interfaces[pair]
    obstacle = scene.contacts[pair].other
    nu, t = np.asarray(itf.normal, dtype=float), np.asarray(itf.tangent, dtype=float)
    pts = np.vstack([b.mesh.points for b in scene.bodies])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    margin = 0.25 * float(np.max(hi - lo))
    lo, hi = lo - margin, hi + margin
    base = itf.points[0]
    reach = float(np.linalg.norm(hi - lo))
    s = np.linspace(-reach, reach, samples)
    line = base + np.outer(s, t)
    d = obstacle.distance(line, nu)
    hit = np.isfinite(d)
    out = line[hit] + d[hit, None] * obstacle.direction(line, nu)[hit]   # the foot: along nu or to the closest point
    return out[np.all((out >= lo) & (out <= hi), axis=1)]


def draw_obstacles(solution: Solution, ax: Axes, magnify: float = 0.0) -> None:
    """Draw every rigid obstacle of ``solution``'s scene on ``ax``, labelled by pair: a fixed obstacle at
    its true position, a force-controlled one moved by ``magnify`` times its translation (m, from
    ``solution.obstacles``; docs/formulation.md §12), as the bodies are drawn with magnified displacements."""
    moved = {i: np.asarray(o.translation, dtype=float) for o in getattr(solution, "obstacles", []) for i in o.pairs}
    for i, c in enumerate(solution.scene.contacts):
        if not c.rigid:
            continue
        xy = obstacle_outline(solution.scene, i) + magnify * moved.get(i, np.zeros(2))
        if len(xy):
            ax.plot(xy[:, 0], xy[:, 1], "-", color="0.25", lw=2.2, solid_capstyle="butt",
                    label=f"rigid obstacle of pair {i + 1}: {c.other!r}")
            ax.plot(xy[:, 0], xy[:, 1], ":", color="white", lw=1.0)


def plot_deformed(solution: Solution, field: str = "von_mises", magnify: float | None = None,
                  ax: Axes | None = None, clim: tuple[float, float] | None = None,
                  colorbar: bool = True) -> Figure:
    """Deformed meshes (displacement x ``magnify``) coloured by ``field``: "von_mises" (MPa or the
    prefix that fits) or "potential" (V, kV, ...).

    An elastic body has no potential and is drawn in grey on a potential plot. ``clim`` (SI
    units) fixes the colour limits, e.g. to share them across conditions. Returns the Figure. A 3D solution
    is drawn by :func:`plot_deformed_3d`.
    """
    if solution.scene.dim == 3:
        return plot_deformed_3d(solution, field, magnify=magnify, ax=ax, clim=clim, colorbar=colorbar)
    _check_field(field, "plot_deformed")
    if magnify is not None and (isinstance(magnify, bool) or not isinstance(magnify, (int, float))
                                or not np.isfinite(magnify) or magnify < 0):
        raise SceneError(f"plot_deformed: magnify must be a finite number >= 0 or None, got {magnify!r}")
    plt = _pyplot()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7, 5.5), layout="constrained")
    k = magnification(solution) if magnify is None else float(magnify)
    values = _field_values(solution, field)
    finite = [v for v in values if v is not None]
    if clim is None:
        clim = (min(float(np.nanmin(v)) for v in finite) if finite else 0.0,
                max(float(np.nanmax(v)) for v in finite) if finite else 1.0)
    name, unit = _FIELDS[field]
    mappable = None
    for body, u, v in zip(solution.scene.bodies, solution.u, values):
        p = body.mesh.points + k * u[:len(body.mesh.points)]       # P2: vertices first
        tri = getattr(body.mesh, "split", body.mesh).triangles     # quadrilaterals: drawn as their two triangles
        if v is not None and len(v) != len(p) and len(v) != len(tri):
            v = np.repeat(v, len(tri) // len(v))                    # a cell's value on each of its triangles
        if v is None:
            ax.tripcolor(p[:, 0], p[:, 1], tri, facecolors=np.zeros(len(tri)), cmap="Greys", vmin=0, vmax=4,
                         edgecolors="0.55", linewidth=0.2)
            continue
        kw = dict(shading="gouraud") if len(v) == len(p) else dict(facecolors=v, edgecolors="face")
        args = (v,) if len(v) == len(p) else ()
        mappable = ax.tripcolor(p[:, 0], p[:, 1], tri, *args, cmap="viridis", vmin=clim[0], vmax=clim[1], **kw)
        from matplotlib.collections import PolyCollection

        ax.add_collection(PolyCollection(p[body.mesh.cells], facecolors="none", edgecolors="k", linewidths=0.15,
                                         alpha=0.5))                # the cells' sides (a quadrilateral's, not its cut)
    draw_obstacles(solution, ax, k)
    if mappable is not None and colorbar:
        fig.colorbar(mappable, ax=ax, label=name, shrink=0.85, format=eng(unit))
    ax.set_aspect("equal")
    ax.xaxis.set_major_formatter(eng("m"))
    ax.yaxis.set_major_formatter(eng("m"))
    ax.set_xlabel("x1")
    ax.set_ylabel("x3 (poling axis)")
    umax = max(np.abs(u).max() for u in solution.u)
    uf, uu = si_prefix([umax], "m")
    ax.set_title(f"{solution.condition}: displacement x {k:g}, max |u| = {umax / uf:.3g} {uu}\n"
                 f"colour: {name}")
    return fig


def plot_deformed_all(solutions: dict[str, Solution], field: str = "von_mises") -> Figure:
    """:func:`plot_deformed` of every solution side by side, with one colour scale and one
    magnification for all (so conditions compare at a glance). Returns the Figure. 3D solutions:
    :func:`plot_deformed_3d_all`."""
    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
    if any(s.scene.dim == 3 for s in solutions.values()):
        return plot_deformed_3d_all(solutions, field)
    _check_field(field, "plot_deformed_all")
    plt = _pyplot()
    n = len(solutions)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n + 1, 4.8), squeeze=False, layout="constrained")
    values = [v for s in solutions.values() for v in _field_values(s, field) if v is not None]
    clim = (min(float(np.nanmin(v)) for v in values), max(float(np.nanmax(v)) for v in values)) if values \
        else (0.0, 1.0)
    k = min(magnification(s) for s in solutions.values())
    for ax, sol in zip(axes[0], solutions.values()):
        plot_deformed(sol, field, magnify=k, ax=ax, clim=clim, colorbar=False)
    name, unit = _FIELDS[field]
    if values:
        import matplotlib as mpl

        norm = mpl.colors.Normalize(clim[0], clim[1])
        fig.colorbar(mpl.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=list(axes[0]),
                     label=name, shrink=0.85, format=eng(unit))
    return fig


def plot_contact(solutions: Solution | dict[str, Solution]) -> Figure:
    """Along each contact line, one column per solution (e.g. per condition) and contact pair,
    one y-scale per row:

    1. the pressure felt by each body of the pair on its own trace nodes (``Solution.traction``):
       the contact pressure to read (one side against a rigid obstacle);
    2. lambda_h on the merged mesh and the nodal pressure: diagnostics (lambda_h may oscillate);
    3. the normal jump [u_nu], with the active nodes marked and penetration at unconstrained nodes
       (possible with sigma_l) flagged by red crosses.

    Ticks carry engineering prefixes (MPa, µm, ...). P2: the pressures, lambda_h and the jump are drawn as
    the quadratic on each segment through their nodes. A row whose values are at rounding level against
    their scale (the jump against the bodies' largest displacement, the pressures against the largest
    pressure of the figure) is drawn as zero and its magnitude stated in the axes.

    ``solutions`` is a Solution or a dict label -> Solution. The abscissa is the tangential
    coordinate s along each pair (s = x1 for a line parallel to x1). The legend sits below the axes.
    Returns the Figure. 3D solutions: :func:`plot_contact_map` (the pressure in the plane of each surface).
    """
    plt = _pyplot()
    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
    if any(s.scene.dim == 3 for s in solutions.values()):
        return plot_contact_map(solutions)
    cols = [(label, sol, i) for label, sol in solutions.items() for i in range(len(sol.contacts))]
    n = len(cols)
    felt = [[(b, *sol.traction(k, i)) for k, b in enumerate(_pair_bodies(sol, i))] for _, sol, i in cols]
    p_scale = max((float(np.abs(p).max()) for f in felt for _, _, p in f if len(p)), default=0.0)
    fig, axes = plt.subplots(3, n, figsize=(max(4.2 * n, 8.0), 8), sharex="col", sharey="row", squeeze=False,
                             layout="constrained")
    for col, (label, sol, i) in enumerate(cols):
        c = sol.contacts[i]
        deg = getattr(c, "degree", 1)
        top, mid, bottom = axes[:, col]
        notes = {}
        for k, (b, x, p) in enumerate(felt[col]):
            p, small = at_rounding(p, p_scale)
            if small is not None:
                notes[top] = f"|p| <= {small:.1e} Pa: rounding, drawn as 0"
            _draw(top, x, p, deg, ("o-", "s--", "^-.", "v:")[b % 4], ms=3, lw=1, color=f"C{b % 10}",
                  label=f"pressure on body {b + 1} (its own trace nodes)")
        top.axhline(0, color="0.6", lw=0.6)
        names = " on ".join(sol.scene.bodies[b].name for b, _, _ in felt[col])
        if sol.scene.contacts[i].rigid:
            names += f" on {sol.scene.contacts[i].other.kind}"
        pair = f"pair {i + 1} ({names})" if len(sol.contacts) > 1 or sol.scene.contacts[i].rigid else ""
        top.set_title(f"{label}{': ' + pair if pair else ''}\n{int(c.active.sum())} of "
                      f"{int(c.constrained.sum())} nodes active", fontsize=9)
        lam, small = at_rounding(c.lam, p_scale)
        if small is not None:
            notes[mid] = f"|lambda_h| <= {small:.1e} Pa: rounding, drawn as 0"
        _draw(mid, c.x, lam, deg, "-", lw=1, color="C4", label=r"$\lambda_h$ on the merged mesh (diagnostic)")
        mid.plot(c.x[c.constrained], c.pressure[c.constrained] if small is None else 0 * c.x[c.constrained], "d",
                 ms=3, mfc="none", color="C5", label="nodal force / lumped length (constrained nodes)")
        mid.axhline(0, color="0.6", lw=0.6)
        u_scale = max(float(np.abs(sol.u[b]).max()) for b, _, _ in felt[col])
        jump, small = at_rounding(c.jump, u_scale)
        if small is not None:
            notes[bottom] = f"|[u_nu]| <= {small:.1e} m: rounding, drawn as 0"
        _draw(bottom, c.x, jump, deg, "o-", ms=3, lw=1, color="C2", label=r"normal jump $[u_\nu]$")
        bottom.plot(c.x[c.active], jump[c.active], "o", ms=4, color="C3", label="active node")
        pen = c.penetration & ~c.constrained
        bottom.plot(c.x[pen], jump[pen], "x", ms=8, mew=2, color="red",
                    label="penetration at an unconstrained node")
        if pen.any():
            bottom.set_title(f"{int(pen.sum())} unconstrained node(s) penetrate", color="red", fontsize=9)
        bottom.axhline(0, color="0.6", lw=0.6)
        bottom.set_xlabel("x1 along the contact line" if c.normal is None or abs(abs(c.normal[1]) - 1) < 1e-12
                          else "s along the contact line")
        for ax, note in notes.items():
            ax.text(0.5, 0.92, note, transform=ax.transAxes, ha="center", va="top", fontsize=8, color="0.2",
                    bbox=dict(boxstyle="round", fc="white", ec="0.7"))
        for ax in (top, mid, bottom):
            ax.xaxis.set_major_formatter(eng("m"))
    for row, (text, unit) in enumerate((("pressure felt by each body", "Pa"), (r"$\lambda_h$ (diagnostic)", "Pa"),
                                        (r"normal jump $[u_\nu]$", "m"))):
        for ax in axes[row]:
            ax.set_ylabel(text)
            ax.yaxis.set_major_formatter(eng(unit))
    handles = {}
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncol=min(3, len(handles)),
               fontsize=8, frameon=False)
    fig.suptitle("Contact along each contact line (one scale per row)")
    return fig


def _pair_bodies(solution, pair):
    a, b = solution.scene.stack.members[pair]
    return [a] if b is None else [a, b]


# ------------------------------------------------------------------------------------------------ 3D figures

_FIELDS_3D = {"von_mises": ("von Mises stress", "Pa"), "displacement": ("|u|", "m"),
              "potential": ("electric potential", "V")}


def contact_zone(solution: Solution, pair: int = 0) -> np.ndarray:
    """(k, 2, 2) the boundary of the contact zone of 3D contact pair ``pair``, as segments in the in-plane
    coordinates (s1, s2) of the pair's frame (m): the contact zone is the union of the cells of the contact
    surface (the overlay, or the body's faces that reach an obstacle) whose three nodes are in contact, i.e.
    where the pressure is positive (:meth:`Solution.in_contact`; not the ``active`` nodes, which carry the
    nodal forces: under "gamma3" a subset of the overlay's); its boundary is every cell edge that belongs to
    exactly one such cell. Empty (0, 2, 2) without a cell whose nodes are all in contact."""
    from .output import pair_interface, surface_cells

    c = solution.contacts[pair]
    tri = surface_cells(pair_interface(solution, pair))
    on = tri[solution.in_contact(pair)[tri].all(axis=1)]
    if len(on) == 0:
        return np.zeros((0, 2, 2))
    edges = np.sort(on[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    return np.asarray(c.x)[unique[count == 1]]


def _zone_words(solution, pair) -> tuple[int, str]:
    """The number of nodes of contact pair ``pair`` in its contact zone and " (p % of the area)" (or "")."""
    share = solution.contact_fraction(pair)
    return int(solution.in_contact(pair).sum()), "" if share is None else f" ({100 * share:.4g} % of the area)"


def _check_3d(solution, who):
    if solution.scene.dim != 3:
        raise SceneError(f"{who} draws 3D solutions; this scene is {solution.scene.dim}D (use plot_contact / "
                         "plot_deformed)")


def plot_contact_map(solutions: Solution | dict[str, Solution]) -> Figure:
    """The contact pressure of 3D contact pairs drawn in the plane of each contact surface: one row per solution
    (e.g. per condition) and pair; in each row the pressure felt by each body on its own faces
    (:meth:`Solution.traction`, P1 on that body's triangles; against a rigid obstacle the body's side only),
    one colour scale for the whole figure, and the opening g - [u_nu] left between the surfaces on the
    overlay (m; 0 where the surfaces touch). The contact zone (:func:`contact_zone`, the union of the cells
    whose nodes are all in contact: positive pressure) is outlined in red on every panel; the overlay's title
    counts its nodes, the share of the area it covers, and the active nodes (those carrying a nodal force). Axes are the pair's in-plane coordinates
    (s1, s2) along its frame (t1, t2) ((x, y) for a plane z = const), with engineering prefixes. Returns the
    Figure."""
    from .output import pair_interface, surface_cells

    plt = _pyplot()
    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
    for sol in solutions.values():
        _check_3d(sol, "plot_contact_map")
    rows = [(label, sol, i) for label, sol in solutions.items() for i in range(len(sol.contacts))]
    felt = [[(b, *sol.traction(k, i)) for k, b in enumerate(_pair_bodies(sol, i))] for _, sol, i in rows]
    top = max((float(np.abs(p).max()) for f in felt for _, _, p in f if len(p)), default=0.0)
    clim = (min(0.0, min((float(p.min()) for f in felt for _, _, p in f if len(p)), default=0.0)), top or 1.0)
    ncols = 3
    fig, axes = plt.subplots(len(rows), ncols, figsize=(13, 3.9 * len(rows) + 0.6), squeeze=False,
                             layout="constrained")
    pressure = None
    for r, ((label, sol, i), sides) in enumerate(zip(rows, felt)):
        itf = sol.scene.interfaces[i]
        zone = contact_zone(sol, i)
        c = sol.contacts[i]
        frame = np.asarray(itf.frame)
        for k, (b, x, p) in enumerate(sides):
            ax = axes[r, k]
            faces = itf.traces[k].faces
            p, small = at_rounding(p, top)
            pressure = ax.tripcolor(x[:, 0], x[:, 1], faces, p, shading="gouraud", cmap="magma",
                                    vmin=clim[0], vmax=clim[1])
            ax.triplot(x[:, 0], x[:, 1], faces, color="w", lw=0.2, alpha=0.5)
            ax.set_title(f"{label}: pressure on {sol.scene.bodies[b].name} (its own faces)"
                         + (f"\npressure at rounding ({small:.0e} Pa), drawn as 0" if small is not None else ""),
                         fontsize=9)
        for k in range(len(sides), 2):
            axes[r, k].set_axis_off()
        ax = axes[r, 2]
        tri = surface_cells(pair_interface(sol, i))      # on the pair the rows were posed on (c.x is its X_h)
        cells = (tri,) if len(tri) else ()           # none (Q2 rows on faces the overlap cuts): matplotlib's Delaunay
        gap = np.zeros(len(c.x)) if c.gap is None else np.asarray(c.gap)
        u_scale = max(float(np.abs(u).max()) for u in sol.u)
        opening, small = at_rounding(gap - np.asarray(c.jump), u_scale)
        vmax = float(opening.max()) if opening.max() > 0 else (u_scale or 1.0)    # closed everywhere: 0 .. max |u|
        shown = ax.tripcolor(c.x[:, 0], c.x[:, 1], *cells, opening, shading="gouraud", cmap="viridis",
                             vmin=min(0.0, float(opening.min())), vmax=vmax)
        fig.colorbar(shown, ax=ax, label=r"opening $g - [u_\nu]$", format=eng("m"), shrink=0.9)
        zone_nodes, share = _zone_words(sol, i)
        ax.set_title(f"{label}: pressure > 0 at {zone_nodes} of {len(c.x)} nodes{share},\n"
                     f"{int(c.active.sum())} active (in contact)"
                     + (f"\nopening at rounding ({small:.0e} m), drawn as 0" if small is not None else ""), fontsize=9)
        for ax in axes[r, :len(sides)].tolist() + [axes[r, 2]]:
            for seg in zone:
                ax.plot(seg[:, 0], seg[:, 1], "-", color="red", lw=1.6)
            ax.set_aspect("equal")
            ax.xaxis.set_major_formatter(eng("m"))
            ax.yaxis.set_major_formatter(eng("m"))
            ax.set_xlabel(f"s1 along t1 = ({_vec(frame[0])})")
            ax.set_ylabel(f"s2 along t2 = ({_vec(frame[1])})")
    if pressure is not None:
        fig.colorbar(pressure, ax=axes[:, :2].ravel().tolist(), label="contact pressure", format=eng("Pa"),
                     shrink=0.9)
    fig.suptitle("Contact pressure in the plane of each contact surface (red: the contact zone's boundary)")
    return fig


def _vec(v) -> str:
    return ", ".join(f"{float(a) + 0.0:.3g}" for a in v)          # + 0.0: no "-0"


def boundary_owners(mesh) -> np.ndarray:
    """(k,) the cell of ``mesh`` (a tetrahedron, a hexahedron) that owns each of its ``boundary_faces``."""
    return mesh.boundary_cells


def _face_values(solution, field):
    """Per body: (its boundary faces (k, 3) triangles or (k, 4) quadrilaterals, the value on each face, SI)."""
    out = []
    for body, u, phi in zip(solution.scene.bodies, solution.u, solution.phi):
        faces = np.asarray(body.mesh.boundary_faces)
        nv = len(body.mesh.points)
        if field == "displacement":
            v = np.linalg.norm(np.asarray(u)[:nv], axis=1)[faces].mean(axis=1)
        elif field == "potential":
            v = None if phi is None else np.asarray(phi)[:nv][faces].mean(axis=1)
        else:
            vm = body_fields(body, u, phi, space(getattr(solution, "degree", 1), body.mesh.cell).nodes(body)).von_mises
            v = vm[boundary_owners(body.mesh)]
        out.append((faces, v))
    return out


def plot_deformed_3d(solution: Solution, field: str = "von_mises", magnify: float | None = None,
                     ax=None, clim: tuple[float, float] | None = None, colorbar: bool = True,
                     view: tuple[float, float] = (25.0, -60.0)) -> Figure:
    """The boundary surface of every body of a 3D solution, deformed (displacement x ``magnify``; default: the
    largest displacement drawn as a tenth of the scene), each face coloured by ``field``: "von_mises" (the
    von Mises stress of the tetrahedron it bounds, Pa), "displacement" (|u|, mean of its nodes, m) or
    "potential" (V, mean of its nodes; elastic bodies grey). ``clim`` (SI) fixes the colour limits; ``ax`` a
    3D axes (``projection="3d"``); ``view`` (elevation, azimuth) in degrees. Returns the Figure."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    _check_3d(solution, "plot_deformed_3d")
    if not isinstance(field, str) or field not in _FIELDS_3D:
        raise SceneError(f"plot_deformed_3d: field must be one of {sorted(_FIELDS_3D)}, got {field!r}")
    if magnify is not None and (isinstance(magnify, bool) or not isinstance(magnify, (int, float))
                                or not np.isfinite(magnify) or magnify < 0):
        raise SceneError(f"plot_deformed_3d: magnify must be a finite number >= 0 or None, got {magnify!r}")
    import matplotlib as mpl

    plt = _pyplot()
    if ax is None:
        fig = plt.figure(figsize=(7.5, 6), layout="constrained")
        ax = fig.add_subplot(projection="3d")
    elif getattr(ax, "name", "") != "3d":
        raise SceneError("plot_deformed_3d: ax must be a 3D axes (fig.add_subplot(projection='3d'))")
    fig = ax.figure
    k = magnification(solution) if magnify is None else float(magnify)
    values = _face_values(solution, field)
    finite = [v for _, v in values if v is not None]
    if clim is None:
        clim = (min(float(v.min()) for v in finite) if finite else 0.0,
                max(float(v.max()) for v in finite) if finite else 1.0)
    norm = mpl.colors.Normalize(*clim) if clim[1] > clim[0] else mpl.colors.Normalize(clim[0] - 1, clim[0] + 1)
    cmap = mpl.colormaps["viridis"]
    moved, polygons, colours = [], [], []
    for body, u, (faces, v) in zip(solution.scene.bodies, solution.u, values):
        p = np.asarray(body.mesh.points) + k * np.asarray(u)[:len(body.mesh.points)]
        moved.append(p)
        polygons.append(p[faces])
        colours.append(np.tile(mpl.colors.to_rgba("0.75"), (len(faces), 1)) if v is None else cmap(norm(v)))
    # one collection for every body, so that the faces are depth-sorted together
    ax.add_collection3d(Poly3DCollection(np.concatenate(polygons), facecolors=np.concatenate(colours),
                                         edgecolors=(0, 0, 0, 0.25), linewidths=0.2))
    pts = np.vstack(moved)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-3 * float((hi - lo).max())))
    ax.view_init(*view)
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y"), (ax.zaxis, "z")):
        axis.set_major_formatter(eng("m"))
        axis.set_label_text(name)
    name, unit = _FIELDS_3D[field]
    if finite and colorbar:
        fig.colorbar(mpl.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=name, shrink=0.7, format=eng(unit))
    umax = max(float(np.abs(u).max()) for u in solution.u)
    uf, uu = si_prefix([umax], "m")
    ax.set_title(f"{solution.condition}: boundary displaced x {k:g}, max |u| = {umax / uf:.3g} {uu}\n"
                 f"colour: {name}", fontsize=10)
    return fig


def plot_deformed_3d_all(solutions: dict[str, Solution], field: str = "von_mises") -> Figure:
    """:func:`plot_deformed_3d` of every solution side by side, with one colour scale and one magnification for
    all. Returns the Figure."""
    import matplotlib as mpl

    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
    for sol in solutions.values():
        _check_3d(sol, "plot_deformed_3d_all")
    if not isinstance(field, str) or field not in _FIELDS_3D:
        raise SceneError(f"plot_deformed_3d_all: field must be one of {sorted(_FIELDS_3D)}, got {field!r}")
    plt = _pyplot()
    n = len(solutions)
    fig = plt.figure(figsize=(5.6 * n + 1.2, 5.2), layout="constrained")
    values = [v for s in solutions.values() for _, v in _face_values(s, field) if v is not None]
    clim = (min(float(v.min()) for v in values), max(float(v.max()) for v in values)) if values else (0.0, 1.0)
    k = min(magnification(s) for s in solutions.values())
    axes = [fig.add_subplot(1, n, j + 1, projection="3d") for j in range(n)]
    for ax, sol in zip(axes, solutions.values()):
        plot_deformed_3d(sol, field, magnify=k, ax=ax, clim=clim, colorbar=False)
    if values:
        name, unit = _FIELDS_3D[field]
        norm = mpl.colors.Normalize(*clim) if clim[1] > clim[0] else mpl.colors.Normalize(clim[0] - 1, clim[0] + 1)
        fig.colorbar(mpl.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=axes, label=name, shrink=0.7,
                     format=eng(unit))
    return fig
