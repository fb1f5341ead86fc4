"""Figures with matplotlib: deformed bodies, and the contact pressure / [u_nu] along Gamma_3.

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
from ..geometry.quadratic import P2Nodes

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..solution.solution import Solution

__all__ = ["plot_deformed", "plot_deformed_all", "plot_contact", "magnification", "si_prefix", "obstacle_outline",
           "draw_obstacles", "eng", "at_rounding", "quadratic_trace"]

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
    p2 = getattr(solution, "degree", 1) == 2
    if field == "potential":
        return [p if p is None or not p2 else p[:len(b.mesh.points)] for b, p in zip(solution.scene.bodies, solution.phi)]
    return [body_fields(b, u, p, P2Nodes(b.mesh) if p2 else None).von_mises
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
    sorted, 2n + 1 of them) with nodal ``values``, sampled at ``samples`` points per segment."""
    x, v = np.asarray(x, dtype=float), np.asarray(values, dtype=float)
    t = np.linspace(0.0, 1.0, samples)
    basis = np.stack([2 * (t - 0.5) * (t - 1), 4 * t * (1 - t), 2 * t * (t - 0.5)])      # at t = 0, 1/2, 1
    xs = x[0:-1:2, None] + (x[2::2] - x[0:-1:2])[:, None] * t
    vs = v[0:-1:2, None] * basis[0] + v[1::2, None] * basis[1] + v[2::2, None] * basis[2]
    return xs.ravel(), vs.ravel()


def _draw(ax, x, v, degree, style, **kw):
    """Nodal values drawn with ``style`` (a marker and/or a line style); for P2 (an odd number of nodes)
    the line is the quadratic through the nodes and the markers sit at the nodes."""
    marker = "".join(ch for ch in style if ch in "os^vdx")
    line = style[len(marker):] if style.startswith(marker) else style.replace(marker, "")
    if degree == 2 and len(x) >= 3 and len(x) % 2 == 1 and line:
        xs, vs = quadratic_trace(x, v)
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
    line, stepping along its tangent, the surface point is reached along the body's outward
    normal nu^a. A plane comes out as a straight segment across the plot, a circle as the arc
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
    out = line[hit] + d[hit, None] * nu
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
    units) fixes the colour limits, e.g. to share them across conditions. Returns the Figure.
    """
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
        tri = body.mesh.triangles
        if v is None:
            ax.tripcolor(p[:, 0], p[:, 1], tri, facecolors=np.zeros(len(tri)), cmap="Greys", vmin=0, vmax=4,
                         edgecolors="0.55", linewidth=0.2)
            continue
        kw = dict(shading="gouraud") if len(v) == len(p) else dict(facecolors=v, edgecolors="face")
        args = (v,) if len(v) == len(p) else ()
        mappable = ax.tripcolor(p[:, 0], p[:, 1], tri, *args, cmap="viridis", vmin=clim[0], vmax=clim[1], **kw)
        ax.triplot(p[:, 0], p[:, 1], tri, color="k", linewidth=0.15, alpha=0.5)
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
    magnification for all (so conditions compare at a glance). Returns the Figure."""
    _check_field(field, "plot_deformed_all")
    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
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
    Returns the Figure.
    """
    plt = _pyplot()
    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
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
