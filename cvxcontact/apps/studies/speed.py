"""Speed against accuracy: wall time and error for every condition x mesh level x solver setting.

Scene: the partial-contact scene of the convergence study (PZT-5A on aluminium), with
non-matching meshes (n and 3n/4 + 1 cells). Each run is timed in its stages (assembly,
model build + CVXPY compile, solver, read-back + exact finish). Two errors are recorded:

* solver error: max |u - u*| / max |u*| against the exact discrete solution u* of the same
  mesh and condition (computed twice, by the condensed and by the full model, each with
  the exact finish; a setting is compared with the one computed by the other model);
* total error: the relative energy error against a fine reference (as in the convergence
  study), which adds the discretisation error.

Settings: Clarabel at tolerances 1e-4 ... 1e-10 (interior-point answer only), Clarabel plus
the exact finish (the default), the condensed model, and OSQP and SCS at their
high-accuracy settings, all through CVXPY.

P1 against P2 (``speed_degree.csv``, the third panel of the figure): on both scenes of the
convergence study, the condensed solve (assembly, condensation, interface problem and back-
substitution: the wall time of ``ContactSolver(...).solve()``) of each condition at P1 levels and
P2 levels, with the total error against the P2 reference. For each scene and condition the wall
time at equal error is compared by interpolating log(time) against log(error) along each
degree's levels: the crossover is the error below which P2 is the cheaper one.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import cvxpy as cp
import numpy as np

from ...contact.interface import CONDITIONS
from ...errors import CvxContactError
from ...solve import ContactSolver
from .common import (
    DEGREES,
    Timer,
    markdown_table,
    pyplot,
    save_figure,
    write_csv,
    write_text,
)
from .convergence import Reference, scene


def settings():
    """(label, ContactSolver keyword arguments) of the compared solver settings."""
    out = [(f"Clarabel tol {t:.0e}", dict(method="full", polish=False,
                                          solver_options=dict(tol_gap_abs=t, tol_gap_rel=t, tol_feas=t)))
           for t in (1e-4, 1e-6, 1e-8, 1e-10)]
    out += [("Clarabel + exact finish", dict(method="full")),
            ("condensed + exact finish", dict(method="condensed"))]
    installed = cp.installed_solvers()
    if "OSQP" in installed:
        out.append(("OSQP eps 1e-7", dict(method="full", polish=False, solver="OSQP", solver_options=dict(
            eps_abs=1e-7, eps_rel=1e-7, max_iter=400000, polishing=True))))
    if "SCS" in installed:
        out.append(("SCS eps 1e-7", dict(method="full", polish=False, solver="SCS", solver_options=dict(
            eps_abs=1e-7, eps_rel=1e-7, max_iters=400000))))
    return out


def run(out, quick=False, progress=None):
    say = progress or (lambda s: None)
    out = Path(out)
    levels, n_ref = ([8, 16], 32) if quick else ([16, 32, 64], 256)
    ref = Reference("partial", n_ref)
    rows = []
    for n in levels:
        sc = scene("partial", n, 3 * n // 4 + 1)
        for condition in CONDITIONS:
            # two independent exact discrete solutions; each setting is compared with the one it is not
            exact_c = ContactSolver(sc, condition, method="condensed").solve()
            exact_f = ContactSolver(sc, condition, method="full").solve()
            assert exact_c.polished and exact_f.polished
            scale = max(np.abs(u).max() for u in exact_c.u)
            for label, kw in settings():
                clock = Timer()
                row = dict(n1=n, condition=condition, setting=label)
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")            # the checks are recorded below
                        sol = ContactSolver(sc, condition, **kw).solve()
                except CvxContactError as exc:
                    row.update(status="error", note=" ".join(str(exc).split())[:120], wall_s=clock())
                    rows.append(row)
                    continue
                t = sol.timings
                row.update(status=sol.status, wall_s=clock(), assembly_s=t.get("assembly", 0) + t.get("loads", 0),
                           build_s=t.get("model", 0) + t.get("compile", 0) + t.get("factorization", 0)
                           + t.get("interface_load", 0),
                           solve_s=t.get("solve", 0),
                           readback_s=t.get("read_back", 0) + t.get("polish", 0) + t.get("back_substitution", 0),
                           solver_error=max(float(np.abs(a - b).max()) for a, b in
                                            zip(sol.u, (exact_f if kw["method"] == "condensed" else exact_c).u)) / scale,
                           total_error=ref.errors(sol)["energy"],
                           equilibrium=sol.residuals()["equilibrium"], ok=sol.ok)
                rows.append(row)
            say(f"speed n={n} {condition}: " + ", ".join(
                f"{r['setting']} {r.get('solver_error', float('nan')):.0e}" for r in rows[-len(settings()):]))
    write_csv(out / "speed.csv", rows)
    deg_rows, cross = _degrees(quick, n_ref, {"partial": ref}, say)
    write_csv(out / "speed_degree.csv", deg_rows)
    _figure(rows, out, deg_rows)
    best = _best(rows)
    text = ("# Speed against accuracy\n\nPartial-contact scene, non-matching meshes; solver error against the "
            "exact discrete solution, total error (energy norm) against a fine reference.\n\n"
            "## Median over conditions and levels\n\n"
            + markdown_table(best, ["setting", "median_wall_s", "median_solver_error", "worst_solver_error",
                                    "median_total_error", "failures"],
                             {"median_wall_s": ".3f", "median_solver_error": ".1e", "worst_solver_error": ".1e",
                              "median_total_error": ".2e"})
            + "\n## All runs\n\n"
            + markdown_table(rows, ["n1", "condition", "setting", "status", "wall_s", "build_s", "solve_s",
                                    "readback_s", "solver_error", "total_error"],
                             {"wall_s": ".3f", "build_s": ".3f", "solve_s": ".3f", "readback_s": ".3f",
                              "solver_error": ".1e", "total_error": ".2e"})
            + "\n## P1 against P2 at equal error\n\nCondensed solves, total error (energy norm) against the P2 "
            f"reference (n = {n_ref}); `p2_cheaper_below`: the error below which P2 takes less wall time than "
            "P1 (interpolated in log-log along the levels; \"all\" if P2 is cheaper over the whole common range, "
            "\"none\" if nowhere in it); `time_ratio_at_finest_common_error`: P1 time / P2 time at the smallest "
            "error both degrees reached.\n\n"
            + markdown_table(cross, ["scene", "condition", "common_error_range", "p2_cheaper_below",
                                     "time_ratio_at_finest_common_error"],
                             {"time_ratio_at_finest_common_error": ".2f"})
            + "\n" + markdown_table(deg_rows, ["scene", "degree", "condition", "n1", "dofs", "wall_s", "total_error"],
                                     {"wall_s": ".3f", "total_error": ".2e"}))
    write_text(out / "speed.md", text)
    return dict(rows=rows, summary=best, degree_rows=deg_rows, crossover=cross)


def _degrees(quick, n_ref, refs, say):
    """P1 and P2 condensed solves on both scenes: wall time and total error; the crossover table."""
    levels = {1: [8, 16], 2: [4, 8]} if quick else {1: [16, 32, 64, 128], 2: [8, 16, 32, 64]}
    rows, cross = [], []
    for kind in ("hertzian", "partial"):
        ref = refs.get(kind) or Reference(kind, n_ref)
        for condition in CONDITIONS:
            for degree in DEGREES:
                for n in levels[degree]:
                    sc = scene(kind, n, 3 * n // 4 + 1)
                    clock = Timer()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        sol = ContactSolver(sc, condition, method="condensed", degree=degree).solve()
                    wall = clock()
                    dofs = sum(3 * len(p) if ph is not None else 2 * len(p) for p, ph in zip(sol.points, sol.phi))
                    rows.append(dict(scene=kind, degree=degree, condition=condition, n1=n, dofs=dofs, wall_s=wall,
                                     total_error=ref.errors(sol)["energy"], ok=sol.ok))
            sub = {d: [r for r in rows if r["scene"] == kind and r["condition"] == condition and r["degree"] == d]
                   for d in (1, 2)}
            cross.append(dict(scene=kind, condition=condition, **crossover(
                [r["total_error"] for r in sub[1]], [r["wall_s"] for r in sub[1]],
                [r["total_error"] for r in sub[2]], [r["wall_s"] for r in sub[2]])))
            say(f"speed P1/P2 {kind} {condition}: P2 cheaper below {cross[-1]['p2_cheaper_below']}")
    return rows, cross


def crossover(e1, t1, e2, t2):
    """Where P2 (errors ``e2``, times ``t2`` along its levels) becomes cheaper than P1 (``e1``, ``t1``)
    at equal error: log(time) interpolated linearly in log(error) on the common error range."""
    def curve(e, t):
        o = np.argsort(e)
        return np.log(np.asarray(e, float)[o]), np.log(np.asarray(t, float)[o])

    (le1, lt1), (le2, lt2) = curve(e1, t1), curve(e2, t2)
    lo, hi = max(le1[0], le2[0]), min(le1[-1], le2[-1])
    if lo >= hi:
        note = ("no common range: P2's coarsest level is more accurate than P1's finest" if le2[-1] < le1[0]
                else "no common range: P1's coarsest level is more accurate than P2's finest")
        return dict(common_error_range="none", p2_cheaper_below=note,
                    time_ratio_at_finest_common_error=float("nan"))
    grid = np.linspace(lo, hi, 400)
    diff = np.interp(grid, le1, lt1) - np.interp(grid, le2, lt2)         # > 0: P2 faster
    ratio = float(np.exp(diff[0]))
    if (diff > 0).all():
        below = "all"
    elif (diff <= 0).all():
        below = "none"
    else:
        k = np.flatnonzero(np.diff(np.sign(diff)))[-1]                    # the last sign change, largest error
        below = f"{np.exp(grid[k + 1]):.1e}" if diff[0] > 0 else f"above {np.exp(grid[k + 1]):.1e}"
    return dict(common_error_range=f"{np.exp(lo):.1e} to {np.exp(hi):.1e}", p2_cheaper_below=below,
                time_ratio_at_finest_common_error=ratio)


def _best(rows):
    out = []
    for label in dict.fromkeys(r["setting"] for r in rows):
        sub = [r for r in rows if r["setting"] == label and r.get("status") != "error"]
        err = [r["solver_error"] for r in sub]
        out.append(dict(setting=label, median_wall_s=float(np.median([r["wall_s"] for r in sub])) if sub else np.nan,
                        median_solver_error=float(np.median(err)) if sub else np.nan,
                        worst_solver_error=float(np.max(err)) if sub else np.nan,
                        median_total_error=float(np.median([r["total_error"] for r in sub])) if sub else np.nan,
                        failures=sum(1 for r in rows if r["setting"] == label) - len(sub)))
    return out


def _figure(rows, out, deg_rows=()):
    plt = pyplot()
    fig, (ax, ax2, ax3) = plt.subplots(1, 3, figsize=(19, 5.6), layout="constrained")
    labels = list(dict.fromkeys(r["setting"] for r in rows))
    levels = sorted({r["n1"] for r in rows})
    markers = "os^vDP*Xh"
    for i, label in enumerate(labels):
        sub = [r for r in rows if r["setting"] == label and r.get("status") != "error"]
        for key, axis in (("solver_error", ax), ("total_error", ax2)):
            axis.scatter([r["wall_s"] for r in sub], [max(r[key], 1e-17) for r in sub], marker=markers[i % 9],
                         s=[12 + 14 * levels.index(r["n1"]) for r in sub], label=label, alpha=0.8)
    for axis, title in ((ax, "solver error vs the exact discrete solution"),
                        (ax2, "total error (energy norm) vs a fine reference")):
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("wall time of the solve [s]")
        axis.set_ylabel("relative error")
        axis.set_title(title + "\n(marker size grows with the mesh level; all three conditions)", fontsize=10)
    ax.legend(fontsize=7)
    colors = dict(gamma3="C0", sigma1="C1", sigma2="C2")
    for kind, fill in (("hertzian", "full"), ("partial", "none")):
        for condition in CONDITIONS:
            for degree, style in ((1, "o-"), (2, "s--")):
                sub = [r for r in deg_rows if r["scene"] == kind and r["condition"] == condition and r["degree"] == degree]
                ax3.loglog([r["wall_s"] for r in sub], [r["total_error"] for r in sub], style, color=colors[condition],
                           fillstyle=fill, ms=5, lw=0.8, label=f"{kind} P{degree} {condition}")
    ax3.set_xlabel("wall time of the condensed solve [s]")
    ax3.set_ylabel("relative energy error vs the P2 reference")
    ax3.set_title("P1 (circles, solid) against P2 (squares, dashed)\nfilled: hertzian scene; open: partial scene",
                  fontsize=10)
    ax3.legend(fontsize=6, ncol=2)
    save_figure(fig, out / "speed.png")
