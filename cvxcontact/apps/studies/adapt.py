"""Adaptive against uniform refinement on the Hertz cylinder (2D, P1 and P2): accuracy against unknowns and time.

The scene is the Hertz validation's (:mod:`.hertz`: a steel cylinder of radius R as the upper block with the gap
x^2 / (2 R) - delta on an aluminium block, both 4 m x 2 m, non-matching meshes), started from coarse uniform
grids (``N0`` cells along the upper trace, about 0.8 N0 below: the contact zone, 0.21 m wide, lies inside one
or two cells). Uniform: the start refined 0, 1, ... times into four (:func:`~cvxcontact.geometry.refine.
refine_uniform`). Adaptive: :func:`cvxcontact.adapt` (``LOOP``: Dorfler's bulk marking, newest-vertex bisection, each
body on its own). For every mesh: the unknowns, the estimate ``sol.estimate`` (sqrt(J/m), energy norm), and
the true errors of the peak pressure p0_h and the half-width a_h against Hertz's closed form for the load P the
solution carries (:func:`.hertz.hertz`; the finite blocks put the physics within about 1e-3 of it: the
finest P2 meshes of the Hertz study converge to p0 / p0_Hertz - 1 = +1e-3). Time: the CPU seconds (process
time; run it single-threaded, ``OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``, for the work
alone) to reach the mesh's answer, the sum of every solve, estimate and refinement up to it (adaptive, each
step warm-started from the last; uniform: its own solve only, the mesh being given). :func:`reached`: the
meshes from which the peak pressure stays within 1 % (the issue's target), and the ratios (adaptive: the loop run
again to stop on that mesh, :func:`timed`, its answer exact).

``run(out, quick=False)`` writes adapt.csv, adapt.md and adapt.png into ``out``.
"""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ...adapt import LOOPS, peak_pressure
from ...adapt import adapt as adapt_loop
from ...errors import ResidualWarning, ResolutionWarning
from ...fem.space import space
from ...geometry.generators import graded_block
from ...geometry.mesh import Mesh, rectangle
from ...geometry.refine import refine_uniform
from ...physics import materials
from ...physics.pairs import Contact, Rigid
from ...physics.scene import Body, Scene
from .common import DEGREES, Timer, markdown_table, pyplot, save_figure, slope, solve_quietly, write_csv, write_text
from .hertz import ALU, DELTA, HEIGHT, R, STEEL, WIDTH, e_star, half_width, hertz

N0 = 8
LOOP = {order: asdict(LOOPS[2, order]) for order in (1, 2)}     # P1, P2
"""Per degree, the options of :func:`cvxcontact.adapt`: its 2D defaults (:data:`cvxcontact.adapt.LOOPS`), passed
explicitly. P2: Dorfler's theta = 0.9, each marked cell bisected as often as eta_T ~ h_T^1 predicts
(:func:`cvxcontact.adapt.mark_bisections`), the steps before the last left at the interior point's answer (its exact
finish, the cuts, costs more than the interior point it starts from). Chosen from a scan of theta in
(0.7, 0.8, 0.9, 0.95) and rate in (1, 1.5, 2) for the time to 1 % peak pressure (docs/accuracy.md). P1: theta = 0.5,
one bisection per marked cell (rate = inf), every step exact (a P1 step is a warm-started active set, cheaper than
an interior point); the P2 choice leaves P1's peak pressure at +1.1 % at 42,624 unknowns where this one is within
1 % from 24,074."""
OPTIONS = dict(condition="gamma3", method="condensed")


def coarse_scene(n: int = N0, ratio: float = 0.8) -> Scene:
    """The Hertz scene (:func:`.hertz.scene`) on uniform grids: ``n`` cells along the upper trace, about ``ratio`` n
    below."""
    upper = graded_block((-WIDTH, WIDTH), (0.0, HEIGHT), n, max(2, n // 2), "bottom")
    m = max(4, round(ratio * n) + 1)
    lower = graded_block((-WIDTH, WIDTH), (-HEIGHT, 0.0), m, max(2, m // 2), "top")
    b1 = Body(upper, materials.isotropic(*STEEL, name="steel"), clamped="top", contact="bottom", name="cylinder")
    b2 = Body(lower, materials.isotropic(*ALU, name="aluminium"), clamped="bottom", contact="top", name="block")
    return Scene(b1, b2, gap=lambda x: x ** 2 / (2 * R) - DELTA)


def measures(sol) -> dict:
    """The peak pressure and half-width of ``sol`` against Hertz's for the load it carries."""
    c = sol.contact
    P = float(c.force.sum())
    a, p0 = hertz(P, R, e_star(*STEEL, *ALU))
    p0_h = peak_pressure(sol)
    return dict(load_N_per_m=P, p0_rel_error=p0_h / p0 - 1, a_rel_error=half_width(c) / a - 1,
                estimate=sol.estimate.absolute, relative=sol.estimate.relative,
                unknowns=int(sum(u.size + (0 if p is None else p.size) for u, p in zip(sol.u, sol.phi))),
                cells=sum(len(b.mesh.triangles) for b in sol.scene.bodies), ok=bool(sol.ok))


PUNCH = {"radius": 0.05, "force": 1e3, "E": 70e9, "nu": 0.33, "width": 0.1, "height": 0.1}
"""Issue 30's scene: a rigid cylinder (``radius``, m) pressed with ``force`` (N/m, the whole cylinder's) into an
aluminium block 2 ``width`` x ``height`` (m), plane strain, as a half model (:func:`punch_scene`)."""


def punch_block(nx: int = 8, ny: int = 8, beta: float = 0.0, gamma: float = 0.0) -> Mesh:
    """The half block [0, width] x [-height, 0] of :data:`PUNCH`, ``nx`` x ``ny`` cells, graded as issue 30's
    hand-made meshes: towards x = 0 by x = width sinh(beta xi) / sinh(beta), towards the top by the depth
    height (exp(gamma eta) - 1) / (exp(gamma) - 1) (beta = gamma = 0: uniform)."""
    base = rectangle(x=(0.0, 1.0), y=(0.0, 1.0), nx=nx, ny=ny)
    xi, depth = base.points[:, 0], 1 - base.points[:, 1]
    x = PUNCH["width"] * (np.sinh(beta * xi) / np.sinh(beta) if beta > 0 else xi)
    d = PUNCH["height"] * ((np.exp(gamma * depth) - 1) / (np.exp(gamma) - 1) if gamma > 0 else depth)
    return type(base)(np.column_stack([x, -d]), base.cells, {t: base.boundary(t) for t in base.tags})


def punch_scene(mesh: Mesh | None = None) -> Scene:
    """Issue 30's punch on ``mesh`` (default :func:`punch_block`, uniform 8 x 8): the block clamped at its bottom,
    on a roller at x = 0 (the symmetry line), the cylinder force-controlled with half the force, guided along y."""
    body = Body(punch_block() if mesh is None else mesh, materials.isotropic(E=PUNCH["E"], nu=PUNCH["nu"]),
                name="block", clamped=["bottom"], roller=["left"], contact="top")
    r = PUNCH["radius"]
    cylinder = Rigid.circle((0.0, r), r, force=(0.0, -PUNCH["force"] / 2), guided=(0.0, 1.0))
    return Scene(body, contacts=[Contact(body, "top", cylinder)])


def punch_measures(sol) -> dict:
    """The peak pressure p0_h (Pa, the largest of ``sol.traction(0)``) and the half-width a_h (m) of a
    :func:`punch_scene` solution against Hertz's rigid cylinder on an elastic half-plane (E* = E / (1 - nu^2)),
    a_h read as :func:`.hertz.half_width` reads it (the mid-point between the outermost closed node and the next
    open one; a P2 "gamma3" node closed where the jump reaches the gap within 1e-3 of the approach, P1 where it
    carries force); the zone starts on the symmetry line, so a_h is that mid-point's x."""
    c = sol.contact
    approach = -float(sol.obstacles[0].translation[1])
    closed = (c.jump - c.gap) >= -1e-3 * approach if c.trace.gamma3_cones else c.active
    order = np.argsort(c.x)
    x, closed = c.x[order], closed[order]
    last = np.flatnonzero(closed)[-1]
    a_h = 0.5 * (x[last] + x[min(last + 1, len(x) - 1)])
    p0_h = peak_pressure(sol)
    a, p0 = hertz(PUNCH["force"], PUNCH["radius"], PUNCH["E"] / (1 - PUNCH["nu"] ** 2))
    return {"p0": p0_h, "a": a_h, "p0_rel_error": p0_h / p0 - 1, "a_rel_error": a_h / a - 1,
            "unknowns": int(sum(u.size + (0 if p is None else p.size) for u, p in zip(sol.u, sol.phi))),
            "relative": sol.estimate.relative, "ok": bool(sol.ok)}


def uniform(degree: int, levels: int, progress) -> list[dict]:
    base = coarse_scene()
    rows = []
    for level in range(levels + 1):
        scene = base.with_bodies(*(b.with_changes(mesh=refine_uniform(b.mesh, level)[0]) for b in base.bodies))
        clock = time.process_time()
        sol = solve_quietly(scene, degree=degree, **OPTIONS)
        seconds = time.process_time() - clock
        rows.append(dict(refinement="uniform", degree=degree, step=level, **measures(sol), seconds=seconds))
        progress(f"adapt study: P{degree} uniform level {level}: {rows[-1]['unknowns']} unknowns, "
                 f"p0 error {rows[-1]['p0_rel_error']:+.2e}")
    return rows


def adaptive(degree: int, max_unknowns: int, progress) -> list[dict]:
    # unknowns ~ 2 nodes per cell pair (P1) or twice that (P2): a cell budget that stops near max_unknowns
    cells = max_unknowns // space(degree).order ** 2
    result = adapt_loop(coarse_scene(), OPTIONS["condition"], max_steps=60, max_cells=cells, keep=True,
                        **loop(degree), progress=lambda line: progress(f"adapt study: P{degree} {line}"))
    rows, spent = [], 0.0
    for step, sol in zip(result.history, result.solutions):
        spent += step.cpu_s
        rows.append(dict(refinement="adaptive", degree=degree, step=step.step, **measures(sol),
                         seconds=spent))       # its own marking and refinement included: conservative
    progress(f"adapt study: P{degree} adaptive: {len(rows)} steps, {rows[-1]['unknowns']} unknowns, "
             f"p0 error {rows[-1]['p0_rel_error']:+.2e}")
    return rows


def loop(degree: int) -> dict:
    """The study's options of :func:`cvxcontact.adapt` for ``degree`` (all but the stops)."""
    return {**LOOP[degree], "degree": degree, "method": OPTIONS["method"]}


def _uniform_answer(degree: int, level: int):
    """The solve of the start refined ``level`` times, the mesh made first (not timed)."""
    base = coarse_scene()
    scene = base.with_bodies(*(b.with_changes(mesh=refine_uniform(b.mesh, level)[0]) for b in base.bodies))
    return lambda: solve_quietly(scene, degree=degree, **OPTIONS)


def _adaptive_answer(degree: int, step: int):
    """The adaptive loop from the start, stopping on mesh ``step``."""
    return lambda: adapt_loop(coarse_scene(), OPTIONS["condition"], max_steps=step, **loop(degree)).solution


ANSWER = {"uniform": _uniform_answer, "adaptive": _adaptive_answer}
"""Series -> (degree, step) -> a call computing the answer of that mesh from scratch (:func:`timed` times it)."""

REPEATS = 3
"""The answers :func:`reached` compares are computed again this many times; the least CPU seconds count (the
neighbours of a shared machine slow a run, never speed it up)."""


def timed(kind: str, degree: int, step: int) -> dict:
    """The least CPU seconds over :data:`REPEATS` runs to the answer of mesh ``step`` of series ``kind`` from
    scratch (:data:`ANSWER`), and that answer's peak-pressure error: "uniform", the solve of the start refined
    ``step`` times (the mesh given); "adaptive", :func:`cvxcontact.adapt` with ``max_steps=step`` (every step up
    to it, its marking and refinement, and the exact finish of its last mesh, whether or not the steps before
    were exact)."""
    seconds = []
    for _ in range(REPEATS):
        answer = ANSWER[kind](degree, step)
        clock = time.process_time()
        sol = answer()
        seconds.append(time.process_time() - clock)
    return {"seconds": min(seconds), "p0_rel_error": measures(sol)["p0_rel_error"], "polished": bool(sol.polished),
            "ok": bool(sol.ok)}


def figure(rows):
    """2 x 2 log-log panels: the estimate (top) and the peak-pressure error (bottom) against the unknowns
    (left) and the seconds (right), uniform and adaptive, P1 and P2; N^(-1/2) and N^(-1) for reference."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), layout="constrained")
    style = {("uniform", 1): ("C0", "o--"), ("adaptive", 1): ("C0", "o-"),
             ("uniform", 2): ("C1", "s--"), ("adaptive", 2): ("C1", "s-")}
    for (kind, degree), (color, marker) in style.items():
        sub = [r for r in rows if r["refinement"] == kind and r["degree"] == degree]
        for i, (key, what) in enumerate((("estimate", "estimate"), ("p0_rel_error", "p0"))):
            y = [abs(r[key]) for r in sub]
            for j, x in enumerate(([r["unknowns"] for r in sub], [r["seconds"] for r in sub])):
                axes[i, j].loglog(x, y, marker, color=color, ms=4, label=f"P{degree} {kind}")
    n = np.array([min(r["unknowns"] for r in rows), max(r["unknowns"] for r in rows)], dtype=float)
    ref = [r for r in rows if r["refinement"] == "adaptive" and r["degree"] == 1][-1]
    axes[0, 0].loglog(n, ref["estimate"] * (n / ref["unknowns"]) ** -0.5, "k:", lw=1, label=r"$\propto N^{-1/2}$")
    ref2 = [r for r in rows if r["refinement"] == "adaptive" and r["degree"] == 2][-1]
    axes[0, 0].loglog(n, ref2["estimate"] * (n / ref2["unknowns"]) ** -1.0, "k-.", lw=1, label=r"$\propto N^{-1}$")
    for j, xl in enumerate(("unknowns N (u of both bodies)", "seconds to reach the answer (s, 2 shared cores)")):
        axes[1, j].set_xlabel(xl)
    axes[0, 0].set_ylabel(r"error estimate $\eta$ (sqrt(J/m), energy norm)")
    axes[1, 0].set_ylabel(r"$|p_{0,h} / p_0^{Hertz} - 1|$ (peak pressure)")
    axes[0, 0].set_title("Estimate against unknowns", fontsize=10)
    axes[0, 1].set_title("Estimate against time", fontsize=10)
    axes[1, 0].set_title("Peak-pressure error against unknowns", fontsize=10)
    axes[1, 1].set_title("Peak-pressure error against time", fontsize=10)
    for ax in axes.ravel():
        ax.grid(True, which="major", alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"Hertz cylinder (R = {R} m) on a block: adaptive (Dorfler theta = {LOOP[1]['theta']} P1, "
                 f"{LOOP[2]['theta']} P2) against uniform refinement", fontsize=11)
    return fig


TARGET = 0.01
"""The peak-pressure error the study's time comparison asks for (issue 30: 1 %)."""


def reached(rows, target: float = TARGET, again=None) -> list[dict]:
    """Per series (refinement, degree): the first mesh from which |p0_rel_error| stays <= ``target`` on every later
    mesh of the series (a nodal value jumps as nodes enter the zone: the first mesh under it may not stay), its
    unknowns and seconds; None where the series ends above it. Then per degree the ratios uniform / adaptive.
    ``again(kind, degree, step)``, optional: a dict replacing the entry's seconds and p0_rel_error (:func:`timed`:
    the answer computed again from scratch, the adaptive one by the loop stopping there, its answer exact)."""
    out = []
    for degree in DEGREES:
        got = {}
        for kind in ("uniform", "adaptive"):
            sub = [r for r in rows if r["refinement"] == kind and r["degree"] == degree]
            first = None
            for i in range(len(sub)):
                if all(abs(r["p0_rel_error"]) <= target for r in sub[i:]):
                    first = sub[i]
                    break
            if first is not None and again is not None:
                first = {**first, **again(kind, degree, first["step"])}
            got[kind] = first
            out.append(dict(refinement=kind, degree=degree, step=None if first is None else first["step"],
                            unknowns=None if first is None else first["unknowns"],
                            seconds=None if first is None else first["seconds"],
                            p0_rel_error=None if first is None else first["p0_rel_error"]))
        u, a = got["uniform"], got["adaptive"]
        if u is not None and a is not None:
            out.append(dict(refinement="uniform / adaptive", degree=degree, unknowns=u["unknowns"] / a["unknowns"],
                            seconds=u["seconds"] / a["seconds"]))
    return out


def rates(rows) -> dict:
    """Slopes of log(estimate) against log(unknowns) over the last half of each series (at least 3 points)."""
    out = {}
    for kind in ("uniform", "adaptive"):
        for degree in DEGREES:
            sub = [r for r in rows if r["refinement"] == kind and r["degree"] == degree]
            tail = sub[-max(3, len(sub) // 2):]
            out[(kind, degree)] = slope([r["unknowns"] for r in tail], [r["estimate"] for r in tail])
    return out


def _options(degree: int) -> str:
    """``LOOP[degree]`` as the keyword arguments it passes, in backquotes."""
    return "`" + ", ".join(f"{k}={v}" for k, v in LOOP[degree].items()) + "`"


def _threads() -> str:
    """The BLAS thread settings of the run, as the environment gives them (the study's times depend on them)."""
    given = [f"{k}={os.environ[k]}" for k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
             if k in os.environ]
    return ", ".join(given) if given else "unset (the libraries' defaults)"


def run(out, quick: bool = False, progress=None) -> dict:
    """Write adapt.csv, adapt.md and adapt.png into ``out`` (module docstring); returns rows and rates."""
    say = progress or (lambda s: None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    timer = Timer()
    # P2 "gamma3" is an interior-point solve on the condensed (dense) interface, whose size adaptivity grows
    # fastest: the smaller P2 budget keeps the study to a few minutes; quick, P2's few large steps (LOOP) need
    # the full budget to leave the first meshes, which only resolve the zone (3 steps: estimate slope -1.33)
    levels, budget = ({1: 3, 2: 2}, {1: 8_000, 2: 20_000}) if quick else ({1: 5, 2: 4}, {1: 60_000, 2: 20_000})
    rows = []
    with warnings.catch_warnings():          # the coarse meshes do not resolve the zone: what the study shows
        warnings.simplefilter("ignore", ResolutionWarning)
        warnings.simplefilter("ignore", ResidualWarning)     # recorded: the ok column
        for degree in DEGREES:
            rows += uniform(degree, levels[degree], say)
            rows += adaptive(degree, budget[degree], say)
    write_csv(out / "adapt.csv", rows)
    save_figure(figure(rows), out / "adapt.png")
    slopes = rates(rows)
    columns = ["refinement", "degree", "step", "cells", "unknowns", "estimate", "relative", "p0_rel_error",
               "a_rel_error", "seconds", "ok"]
    formats = dict(estimate=".4g", relative=".3g", p0_rel_error="+.2e", a_rel_error="+.2e", seconds=".2f")
    series = {(r["refinement"], r["degree"]): [s for s in rows if (s["refinement"], s["degree"])
                                                 == (r["refinement"], r["degree"])] for r in rows}
    shown = [r for r in rows if r["refinement"] == "uniform" or r["step"] % 3 == 0 or len(series[r["refinement"],
             r["degree"]]) <= 8 or r is series[r["refinement"], r["degree"]][-1]]
    text = (f"# Adaptive against uniform refinement: the Hertz cylinder\n\nGenerated by `cvxcontact study adapt"
            f"{' --quick' if quick else ''}` ({timer():.0f} s). Start: uniform grids, {N0} cells along the "
            f"cylinder's trace (h = {2 * WIDTH / N0:g} m; Hertz half-width 0.105 m), condition gamma3, method "
            f"condensed. Adaptive: `cc.adapt` with {_options(1)} (P1) and {_options(2)} (P2), each step "
            "warm-started from the last (`exact_steps=False`: the steps before the last are the interior point's "
            "answers, `ok` False, not exact); "
            "every third step and the last shown, all of a series of 8 or fewer (all in adapt.csv). `estimate`: "
            "sqrt(J/m) in the energy norm; "
            "`p0_rel_error`, `a_rel_error`: the peak pressure and half-width against Hertz's closed form for the "
            "load the solution carries; `seconds`: CPU seconds (process time) to reach the answer (adaptive: every "
            "step up to it included, its own marking and refinement too; uniform: its own solve; BLAS threads: "
            f"{_threads()}; on a shared machine wall time measures the neighbours).\n\n"
            + markdown_table(shown, columns, formats)
            + "\n\nSlope of log(estimate) against log(unknowns), last half of each series:\n\n"
            + markdown_table([dict(refinement=k, degree=d, slope=v) for (k, d), v in slopes.items()],
                             ["refinement", "degree", "slope"], dict(slope=".2f")))
    reach = reached(rows, again=timed)
    text += (f"\n\nTo {100 * TARGET:g} % peak-pressure error and staying there (the first mesh of each series from "
             f"which every later one is within it; `seconds`: the least CPU seconds of {REPEATS} runs from scratch to "
             "that answer, adaptive: `cc.adapt` stopping on that mesh (`max_steps`), its answer exact; "
             "the last rows: uniform over adaptive):\n\n"
             + markdown_table(reach, ["refinement", "degree", "step", "unknowns", "seconds", "p0_rel_error"],
                              dict(unknowns=".4g", seconds=".3g", p0_rel_error="+.2e")))
    write_text(out / "adapt.md", text)
    return dict(rows=rows, rates=slopes, reached=reach)
