"""Figures with matplotlib: deformed bodies, and lambda_h / [u_nu] along Gamma_3.

Every axis is labelled with its unit, every colour map has a colour bar, and the
displacement magnification is stated in the title.
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

__all__ = ["plot_deformed", "plot_contact", "magnification"]

_FIELDS = {"potential": "electric potential [V]", "von_mises": "von Mises stress [Pa]"}


def _pyplot():
    import matplotlib.pyplot as plt  # imported late: the solver path never needs matplotlib

    return plt


def magnification(solution, fraction=0.1) -> float:
    """A round factor (1, 2 or 5 times a power of ten) that shows the largest displacement
    as at most ``fraction`` of the scene size."""
    umax = max(float(np.abs(u).max()) for u in solution.u)
    if umax == 0:
        return 1.0
    raw = fraction * solution.scene.length / umax
    decade = 10.0 ** np.floor(np.log10(raw))
    return float(decade * max(m for m in (1, 2, 5) if m * decade <= raw))


def plot_deformed(solution: Solution, field: str = "von_mises", magnify: float | None = None,
                  ax: Axes | None = None) -> Figure:
    """Deformed meshes (displacement x ``magnify``) coloured by ``field``: "von_mises" or "potential".

    An elastic body has no potential and is drawn in grey on a potential plot.
    Returns the matplotlib Figure.
    """
    if not isinstance(field, str) or field not in _FIELDS:
        raise SceneError(f"plot_deformed: field must be one of {sorted(_FIELDS)}, got {field!r}")
    plt = _pyplot()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7, 5.5), layout="constrained")
    if magnify is not None and (isinstance(magnify, bool) or not isinstance(magnify, (int, float))
                                or not np.isfinite(magnify) or magnify < 0):
        raise SceneError(f"plot_deformed: magnify must be a finite number >= 0 or None, got {magnify!r}")
    k = magnification(solution) if magnify is None else float(magnify)
    values = []
    for body, u, phi in zip(solution.scene.bodies, solution.u, solution.phi):
        nv = len(body.mesh.points)             # P2: vertices first; drawn on the vertex triangulation
        if field == "potential":
            values.append(phi if phi is None else phi[:nv])
        else:
            nodes = P2Nodes(body.mesh) if getattr(solution, "degree", 1) == 2 else None
            values.append(body_fields(body, u, phi, nodes).von_mises)
    finite = [v for v in values if v is not None]
    vmin = min(float(np.nanmin(v)) for v in finite) if finite else 0.0
    vmax = max(float(np.nanmax(v)) for v in finite) if finite else 1.0
    mappable = None
    for body, u, v in zip(solution.scene.bodies, solution.u, values):
        p = body.mesh.points + k * u[:len(body.mesh.points)]
        tri = body.mesh.triangles
        if v is None:
            ax.tripcolor(p[:, 0], p[:, 1], tri, facecolors=np.zeros(len(tri)), cmap="Greys", vmin=0, vmax=4,
                         edgecolors="0.55", linewidth=0.2)
            continue
        kw = dict(shading="gouraud") if len(v) == len(p) else dict(facecolors=v, edgecolors="face")
        args = (v,) if len(v) == len(p) else ()
        mappable = ax.tripcolor(p[:, 0], p[:, 1], tri, *args, cmap="viridis", vmin=vmin, vmax=vmax, **kw)
        ax.triplot(p[:, 0], p[:, 1], tri, color="k", linewidth=0.15, alpha=0.5)
    if mappable is not None:
        fig.colorbar(mappable, ax=ax, label=_FIELDS[field], shrink=0.85)
    ax.set_aspect("equal")
    ax.set_xlabel("x1 [m]")
    ax.set_ylabel("x3 [m] (poling axis)")
    ax.set_title(f"Deformed bodies, displacement x {k:g}; colour: {_FIELDS[field]}\n"
                 f"condition {solution.condition}, max |u| = {max(np.abs(u).max() for u in solution.u):.3g} m")
    return fig


def plot_contact(solutions: Solution | dict[str, Solution]) -> Figure:
    """lambda_h and [u_nu] along Gamma_3, one column per solution (e.g. per condition).

    ``solutions`` is a Solution or a dict label -> Solution. Returns the Figure.
    """
    plt = _pyplot()
    if not isinstance(solutions, dict):
        solutions = {solutions.condition: solutions}
    n = len(solutions)
    fig, axes = plt.subplots(2, n, figsize=(4.2 * n, 6), sharex=True, squeeze=False, layout="constrained")
    for col, (label, sol) in enumerate(solutions.items()):
        c = sol.contact
        top, bottom = axes[0, col], axes[1, col]
        top.plot(c.x, c.lam, "o-", ms=3, lw=1, label=r"$\lambda_h$ (merged mesh)")
        top.plot(c.x[c.constrained], c.pressure[c.constrained], "s", ms=3, mfc="none",
                 label="nodal force / lumped length")
        top.axhline(0, color="0.6", lw=0.6)
        top.set_title(f"{label}: {int(c.active.sum())} of {int(c.constrained.sum())} nodes active")
        top.set_ylabel(r"contact pressure $\lambda$ [Pa]")
        top.legend(fontsize=8)
        bottom.plot(c.x, c.jump, "o-", ms=3, lw=1, color="C2")
        bottom.plot(c.x[c.active], c.jump[c.active], "o", ms=4, color="C3", label="active")
        bottom.axhline(0, color="0.6", lw=0.6)
        bottom.set_xlabel("x1 along the contact line [m]")
        bottom.set_ylabel(r"normal jump $[u_\nu]$ [m]")
        bottom.legend(fontsize=8)
    fig.suptitle("Contact pressure and normal jump along the contact line")
    return fig
