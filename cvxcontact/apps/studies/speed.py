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
"""

from __future__ import annotations

import warnings
from pathlib import Path

import cvxpy as cp
import numpy as np

from ...contact.interface import CONDITIONS
from ...errors import CvxContactError
from ...solve import ContactSolver
from .common import Timer, markdown_table, pyplot, save_figure, write_csv, write_text
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
    levels, n_ref = ([8, 16], 64) if quick else ([16, 32, 64], 256)
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
    _figure(rows, out)
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
                              "solver_error": ".1e", "total_error": ".2e"}))
    write_text(out / "speed.md", text)
    return dict(rows=rows, summary=best)


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


def _figure(rows, out):
    plt = pyplot()
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 5.2), layout="constrained")
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
    save_figure(fig, out / "speed.png")
