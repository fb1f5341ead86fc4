"""Command line: ``cvxcontact [-v] demo | solve | info | sweep | study`` (see ``cvxcontact --help``).

Exit codes: 0 success, 1 bad input or failed solve (one-line reason on stderr),
2 usage error, 3 solved but the solution fails its checks (files are still written);
for ``sweep`` see :func:`_sweep`.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

from ..errors import CvxContactError

__all__ = ["main"]

# The conditions of contact.interface.CONDITIONS, spelled out so that ``--help`` and ``--version``
# import neither NumPy, SciPy nor CVXPY (tests/test_outputs.py checks the two agree).
CONDITIONS = ("gamma3", "sigma1", "sigma2")


class Progress:
    """Stage-by-stage progress on stderr; silent with ``quiet``."""

    def __init__(self, quiet):
        self.quiet, self.t0 = quiet, time.perf_counter()

    def __call__(self, message):
        if not self.quiet:
            print(f"[{time.perf_counter() - self.t0:7.2f} s] {message}", file=sys.stderr, flush=True)


def _parser():
    p = argparse.ArgumentParser(prog="cvxcontact", description="Contact of piezoelectric bodies as convex programs.")
    import cvxcontact  # the package root (already imported, and lazy): only for its version

    p.add_argument("--version", action="version", version=f"cvxcontact {cvxcontact.__version__}")
    p.add_argument("-v", "--verbose", action="count", default=0,
                   help="the library's log on stderr (before the command: cvxcontact -v solve ...): -v routes and "
                        "fallbacks, -vv also the stage timings")
    sub = p.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="solve the built-in two-block scene; write VTU, PNG and a JSON summary")
    demo.add_argument("--out", default="cvxcontact-demo",
                      help="output folder, relative to the current folder (default: %(default)s)")
    demo.add_argument("--nx", type=int, default=16, help="cells along the contact line, upper body (default: 16)")
    demo.add_argument("--load-scale", type=float, default=None,
                      help="factor on the quickstart scene's loads (default: 0.01, which keeps PZT-5A in its "
                           "linear range; 1 gives the quickstart's 228 MPa and kV/mm fields)")
    solve = sub.add_parser("solve", help="solve a scene file")
    solve.add_argument("scene", help="scene file (TOML)")
    solve.add_argument("--out", default=None,
                       help="output folder (default: SCENE's name + '-out' in the current folder)")
    solve.add_argument("--condition", choices=CONDITIONS + ("all",), default=None,
                       help="non-penetration condition (default: the file's, or gamma3); 'all' compares the three")
    solve.add_argument("--method", choices=("full", "condensed"), default=None,
                       help="full CVXPY model or condensed interface model (default: the file's, or full)")
    solve.add_argument("--degree", type=int, choices=(1, 2), default=None,
                       help="1: P1 elements, 2: P2 (6-node) elements (default: the file's, or 1)")
    solve.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    info = sub.add_parser("info", help="sizes and unknowns of a scene file")
    info.add_argument("scene", help="scene file (TOML)")
    sweep = sub.add_parser("sweep", help="run or resume a sweep of cases (reference solutions)")
    sweep.add_argument("sweep", help="sweep file (TOML)")
    sweep.add_argument("--out", required=True, help="output folder (results, failures, manifest)")
    sweep.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    sweep.add_argument("--scheduler", default=None, help="address of a Dask distributed scheduler")
    sweep.add_argument("--retry-failed", action="store_true",
                       help="run the recorded failures and the cases whose checks failed again")
    sweep.add_argument("--skip-invalid", action="store_true",
                       help="record cases whose scene is invalid as failures and run the others (default: refuse)")
    sweep.add_argument("--export-problem", action="store_true",
                       help="also write each case's conic problem data (P, q, A, b, cones) to cases/<id>.problem.npz")
    study = sub.add_parser("study", help="verification studies: CSV, PNG and a Markdown summary")
    study.add_argument("name", choices=("convergence", "convergence_hencky", "speed", "stability", "hertz", "hertz3d",
                                         "hertz3d_elastic", "estimate", "adapt", "bound", "all"))
    study.add_argument("--out", required=True, help="output folder")
    study.add_argument("--quick", action="store_true", help="reduced version (about a minute on 2 cores)")
    study.add_argument("--profile", action="store_true",
                       help="hertz3d_elastic only: the gap-profile variant (two flat bodies, the sphere's profile as "
                            "the pair's initial gap; P1 and P2 rows)")
    for s in (solve, info, sweep):
        s.add_argument("--allow-outside-mesh", action="store_true",
                       help="accept mesh files outside the scene file's folder, or given by absolute paths "
                            "(sweep: also the scene file outside the sweep file's folder)")
    for s in (demo, solve, info, sweep, study):
        s.add_argument("-q", "--quiet", action="store_true", help="no progress messages")

    return p


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(argv)
    args.argv = argv
    _logging(args)
    progress = Progress(args.quiet)
    try:
        if args.command == "info":
            return _info(args)
        if args.command == "sweep":
            return _sweep(args)
        if args.command == "study":
            return _study(args, progress)
        if args.command == "demo":
            from ..apps.demo import DEMO_LOAD_SCALE, two_blocks

            scale = DEMO_LOAD_SCALE if args.load_scale is None else args.load_scale
            if not (scale == scale and abs(scale) < float("inf")):
                raise CvxContactError(f"--load-scale must be a finite number, got {args.load_scale}")
            progress(f"building the demo scene (PZT-5A block on an aluminium block, loads x {scale:g})")
            return _run(two_blocks(args.nx, scale=scale), list(CONDITIONS), {}, Path(args.out), True, progress,
                        args.quiet)
        from ..io.scenefile import load_scene

        progress(f"reading {args.scene}")
        spec = load_scene(args.scene, allow_outside=args.allow_outside_mesh)
        conditions = list(CONDITIONS) if args.condition == "all" else [args.condition or spec.condition]
        settings = spec.settings
        if args.method:
            settings["method"] = args.method
        if args.degree:
            settings["degree"] = args.degree
        scene_path = Path(args.scene)
        out = Path(args.out) if args.out else Path(f"{scene_path.stem}-out")      # in the current folder
        return _run(spec.scene, conditions, settings, out, not args.no_plots, progress, args.quiet)
    except CvxContactError as exc:
        print(f"cvxcontact: error: {_one_line(exc)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("cvxcontact: interrupted", file=sys.stderr)
        return 130


def _one_line(exc):
    return " ".join(str(exc).split())


def _run(scene, conditions, settings, out, plots, progress, quiet):
    import warnings

    from ..errors import ResidualWarning
    from ..io.output import atomic_write, write_all, write_pvd
    from ..solve import solve

    if out.exists() and not out.is_dir():
        raise CvxContactError(f"--out {str(out)!r} is a file, not a folder; name a folder (it is created if missing)")
    progress(f"writing into {out.resolve()}")
    solutions, files, groups = {}, [], []
    for c in conditions:
        progress(f"solving condition {c}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResidualWarning)   # reported below, once, on stderr
            sol = solve(scene, c, **settings)
        solutions[c] = sol
        progress(f"  {sol.status}, {'exact finish' if sol.polished else 'interior-point answer'}, "
                 f"{sum(int(c.active.sum()) for c in sol.contacts)} active nodes"
                 f"{f' ({len(sol.contacts)} pairs)' if len(sol.contacts) > 1 else ''}, solve {sol.timings.get('solve', 0):.3f} s")
        paths = [p for p in write_all(sol, out, stem=c) if p.suffix == ".vtu"]
        files += paths
        groups += [c] * len(paths)
    try:
        write_pvd(files, out / "results.pvd", groups)
    except OSError as exc:
        raise CvxContactError(f"cannot write results into {str(out)!r}: {exc}") from exc
    if plots:
        progress("drawing figures")
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ..io.plot import plot_contact, plot_contact_map, plot_deformed_3d_all, plot_deformed_all

        if scene.dim == 3:
            figures = {"deformed_von_mises.png": plot_deformed_3d_all(solutions, "von_mises"),
                       "deformed_displacement.png": plot_deformed_3d_all(solutions, "displacement"),
                       "contact.png": plot_contact_map(solutions)}
            deformed = plot_deformed_3d_all
        else:
            figures = {"deformed_von_mises.png": plot_deformed_all(solutions, "von_mises"),
                       "contact.png": plot_contact(solutions)}
            deformed = plot_deformed_all
        if any(b.piezoelectric for b in scene.bodies):               # no potential plot for an all-elastic scene
            figures["deformed_potential.png"] = deformed(solutions, "potential")
        for name, fig in figures.items():
            try:
                atomic_write(out / name, lambda p, f=fig: f.savefig(p, dpi=130, format="png"))
            except OSError as exc:
                raise CvxContactError(f"cannot write {str(out / name)!r}: {exc}") from exc
            finally:
                plt.close(fig)
    if not quiet:
        for sol in solutions.values():
            print(sol.report())
        print(f"results in {out.resolve()}/ (results.pvd opens every VTU file in ParaView)")
    bad = [c for c, s in solutions.items() if not s.ok]
    if bad:
        print(f"cvxcontact: warning: the solution for {bad} fails its checks at tol={solutions[bad[0]].tol:g}; "
              f"see {out}/<condition>.json", file=sys.stderr)
        return 3
    return 0


def _study(args, progress):
    import importlib

    from .studies import STUDIES

    names = STUDIES if args.name == "all" else (args.name,)
    if args.profile and args.name != "hertz3d_elastic":
        raise CvxContactError(f"--profile is a variant of the study hertz3d_elastic, not of {args.name!r}; "
                              "run `cvxcontact study hertz3d_elastic --profile`")
    for name in names:
        progress(f"study {name}{' (quick)' if args.quick else ''}")
        out = Path(args.out) / name if len(names) > 1 else Path(args.out)
        extra = dict(profile=True) if args.profile else {}
        importlib.import_module(f".studies.{name}", __package__).run(out, quick=args.quick, progress=progress,
                                                                    **extra)
        if not args.quiet:
            print(f"{name}: {out}/{name}{'_profile' if args.profile else ''}.md")
    return 0


def _sweep(args):
    """Exit codes: 0 every case solved and checked, 1 bad input / output folder / some cases failed
    (no result), 3 every case solved but some fail their checks, 130 interrupted (README, sweeps)."""
    from .sweep import main_progress, run_sweep

    if args.workers is not None and args.workers < 1:
        raise CvxContactError(f"--workers must be at least 1, got {args.workers}")
    try:
        report = run_sweep(args.sweep, args.out, workers=args.workers, scheduler=args.scheduler,
                           retry_failed=args.retry_failed, progress=main_progress(args.quiet),
                           allow_outside=args.allow_outside_mesh, export_problem=args.export_problem,
                           skip_invalid=args.skip_invalid)
    except KeyboardInterrupt:
        print(f"cvxcontact: interrupted; {_sweep_states(args.out)}. Resume with the same command: "
              f"{shlex.join(['cvxcontact', *args.argv])}", file=sys.stderr, flush=True)
        return 130
    if not args.quiet:
        print(f"{report.done} of {report.total} cases done ({report.skipped} from earlier runs), "
              f"{len(report.checks_failed)} failing their checks, {len(report.failed)} failed, "
              f"{report.seconds:.1f} s; manifest: {args.out}/manifest.json")
        if report.superseded or report.redone:
            print(f"{report.redone} corrupt or incomplete result(s) redone; {report.superseded} result(s) of an "
                  f"earlier input kept aside in {report.superseded_to or '-'}")
    if report.failed:
        first = next(iter(report.failed.items()))
        print(f"cvxcontact: {len(report.failed)} case(s) failed, e.g. {first[0]}: {first[1]} "
              f"(see {args.out}/failures/)", file=sys.stderr)
        return 1
    if report.checks_failed:
        first = next(iter(report.checks_failed.items()))
        print(f"cvxcontact: {len(report.checks_failed)} case(s) solved but fail their checks after the retry "
              f"ladder, e.g. {first[0]}: {first[1]} (see {args.out}/cases/{first[0]}.json)", file=sys.stderr)
        return 3
    return 0


def _sweep_states(out) -> str:
    """What the manifest of an interrupted sweep says: "3 of 14 cases done, 11 pending"."""
    import json

    try:
        manifest = json.loads((Path(out) / "manifest.json").read_text())
        states, total = manifest["states"], len(manifest["cases"])
        return f"{total - states['pending']} of {total} cases have a result or a recorded failure, " \
               f"{states['pending']} pending (results so far: {out}/manifest.json)"
    except (OSError, ValueError, KeyError, TypeError):
        return "no case finished"


def _logging(args) -> None:
    """``-v``: the library's log (routes, fallbacks) on stderr; ``-vv``: with the stage timings (DEBUG)."""
    if not getattr(args, "verbose", 0):
        return
    import logging

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("[%(name)s] %(levelname)s %(message)s"))
    logger = logging.getLogger("cvxcontact")
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG if args.verbose > 1 else logging.INFO)


def _info(args):
    from ..fem.space import space
    from ..io.scenefile import load_scene
    from .sweep.worker import CELL_ARRAYS

    spec = load_scene(args.scene, allow_outside=args.allow_outside_mesh)
    itf = spec.scene.interface
    print(f"scene {args.scene}: condition {spec.condition}, solver {spec.solver}, tol {spec.tol:g}")
    total = 0
    for k, b in enumerate(spec.scene.bodies, start=1):
        element = space(spec.degree, b.mesh.cell)          # the file's degree on the body's cells
        s = element.assemble_matrices(b)
        n_u, n_phi = len(s.u_free), len(s.phi_free) if s.piezoelectric else 0
        total += n_u + n_phi
        cells = f"{len(b.mesh.cells)} {CELL_ARRAYS[b.mesh.cell]} ({element.label})"
        nodes = len(element.node_set(b.mesh).points)
        print(f"  body {k} {b.name!r}: {b.material.name}, {nodes} nodes, {cells}; unknowns: "
              f"{n_u} displacement, "
              + (f"{n_phi} potential (electric unknowns)" if b.piezoelectric else "no electric unknowns (elastic)"))
    if spec.scene.dim == 3:                                # planar contact surfaces
        for i, (c, p) in enumerate(zip(spec.scene.contacts, spec.scene.interfaces)):
            n = ", ".join(f"{v + 0.0:.4g}" for v in p.normal)
            sig = f"sigma1 {len(p.sigma[0])}" + ("" if p.rigid else f", sigma2 {len(p.sigma[1])}")
            print(f"  contact[{i}] {c!r}: normal ({n}), area {p.area:.6g} m^2, {p.size} "
                  f"{'reachable trace' if p.rigid else 'overlay'} nodes, {sig}")
        print(f"  total unknowns {total}; constraints (gamma3): {spec.scene.stack.size}")
        return 0
    if len(spec.scene.interfaces) == 1 and not itf.rigid:
        sig = [len(t.x) for t in itf.traces]
        print(f"  contact line y = {itf.y:g} m, x in [{itf.x[0]:g}, {itf.x[-1]:g}] m: {sig[0]} + {sig[1]} trace nodes, "
              f"{itf.size} merged nodes")
        sig = [len(k) for k in itf.sigma]                  # the nodes inside the overlap
        print(f"  total unknowns {total}; constraints: gamma3 {itf.size}, sigma1 {sig[0]}, sigma2 {sig[1]}")
        return 0
    for i, (c, p) in enumerate(zip(spec.scene.contacts, spec.scene.interfaces)):   # contact pairs
        print(f"  contact[{i}] {c!r}: normal ({p.normal[0]:.4g}, {p.normal[1]:.4g}), s in [{p.x[0]:g}, {p.x[-1]:g}] m, "
              f"{p.size} merged nodes, sigma1 {len(p.sigma[0])}" + ("" if p.rigid else f", sigma2 {len(p.sigma[1])}"))
    print(f"  total unknowns {total}; constraints (gamma3): {spec.scene.stack.size}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
