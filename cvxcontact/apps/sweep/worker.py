"""Running one case (with its retry ladder) and the worker process that runs cases for the driver.

Retry ladder, for a case whose solve fails (:class:`~cvxcontact.errors.SolverError`) or whose
checks of (26)-(27) fail (``Solution.ok`` false):

1. the sweep's method with the scene file's solver settings (a prepared ContactSolver of the
   same geometry is reused: load-only cases share its factorisations);
2. the same backend with tighter solver tolerances and more iterations (Clarabel only:
   ``tol_gap_abs = tol_gap_rel = tol_feas = 1e-12``, ``tol_ktratio = 1e-10``, ``max_iter`` at
   least 400);
3. the other backend ("full" <-> "condensed").

It stops at the first attempt that passes its checks. Every attempt is recorded in the case file
(``attempts``); the result kept is the passing one, else the last attempt that gave a solution.
Bad input is not retried.
"""

from __future__ import annotations

import copy
import os
import signal
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ...errors import CvxContactError, ResidualWarning, SolverError
from .spec import machine, versions
from .store import FAILURES, SweepOutputError, write_case, write_json

__all__ = ["solve_case", "worker_main", "limit_threads", "THREAD_VARIABLES"]

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
                    "NUMEXPR_NUM_THREADS", "RAYON_NUM_THREADS")
TIGHT = dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12, tol_ktratio=1e-10)

_SOLVERS: dict = {}     # per process: {(scene file, method, geometry key): ContactSolver}, one geometry at a time


def _one_line(exc):
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def _ladder(settings, method):
    """The attempts (method, settings) after the first; see the module docstring."""
    steps = []
    if settings["solver"] == "CLARABEL":
        opts = dict(settings["solver_options"])
        opts.update(TIGHT, max_iter=max(400, 2 * int(opts.get("max_iter", 200))))
        steps.append((method, {**settings, "solver_options": opts}))
    steps.append(("full" if method == "condensed" else "condensed", settings))
    return steps


def _record(n, method, settings, sol=None, error=None, seconds=0.0):
    rec = {"attempt": n, "method": method, "solver": settings["solver"], "solver_options": settings["solver_options"],
           "seconds": seconds}
    if sol is None:
        return {**rec, "error": error}
    return {**rec, "backend": sol.info.method, "status": str(sol.status), "route": str(sol.path),
            "handed_over": sol.info.handed_over, "iterations": sol.info.iterations, "ok": bool(sol.ok), "residuals": sol.residuals()}


def _solve(spec, task, method, scene_path):
    """Attempts of the ladder until one passes; (solution or None, attempts)."""
    from ...solve import ContactSolver

    settings = {**spec.settings, "method": method}
    key = (str(scene_path), method, task["geometry"])
    attempts, best = [], None
    steps = [(method, settings)]
    for n in range(3):
        m, s = steps[n]
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ResidualWarning)          # recorded in the case file
                warnings.filterwarnings("ignore", message="Solution may be inaccurate")     # (CVXPY) likewise
                if n == 0:
                    solver = _SOLVERS.get(key)
                    if solver is not None and solver.accepts(spec.scene):
                        sol = solver.solve(spec.scene)
                    else:
                        _SOLVERS.clear()                                   # one geometry's factors in memory
                        solver = _SOLVERS[key] = ContactSolver(spec.scene, task["condition"], **s)
                        sol = solver.solve()
                else:
                    s = {**s, "method": m}
                    sol = ContactSolver(spec.scene, task["condition"], **s).solve()
            attempts.append(_record(n + 1, m, s, sol=sol, seconds=time.perf_counter() - t0))
            best = sol
            if sol.ok:
                break
            backend = sol.info.method
        except SolverError as exc:
            attempts.append(_record(n + 1, m, s, error=_one_line(exc), seconds=time.perf_counter() - t0))
            backend = m if m != "auto" else "condensed"
        if n == 0:
            steps += _ladder({**settings, "method": backend}, backend)
        if n + 1 >= len(steps):
            break
    return best, attempts


def arrays(sol) -> dict:
    """The arrays of a case file (names and units: :data:`.store.ARRAY_UNITS`). Contact pair 1 unprefixed,
    pair p >= 2 prefixed ``contact<p>_``; ``pressure<j>``/``trace_s<j>``: the pressure felt by body j
    (1-based scene index) on its own trace nodes (:meth:`Solution.traction`), the one to read first; a pair under
    a friction law also ``slip``, ``shear_force``, ``shear`` and ``threshold`` (:class:`ContactResult`)."""
    from ...io.output import pair_bodies

    out = {}
    for i, c in enumerate(sol.contacts):
        pre = "" if i == 0 else f"contact{i + 1}_"
        line = c.points if c.points is not None else np.column_stack([c.x, np.full(len(c.x), c.line)])
        out.update({f"{pre}x": c.x, f"{pre}line_points": line, f"{pre}lam": c.lam, f"{pre}jump": c.jump,
                    f"{pre}force": c.force, f"{pre}active": c.active, f"{pre}constrained": c.constrained})
        if c.gap is not None:
            out[f"{pre}gap"] = c.gap
        if c.slip is not None:                  # a friction law: its read-back (ContactResult)
            out.update({f"{pre}slip": c.slip, f"{pre}shear_force": c.shear_force, f"{pre}shear": c.shear,
                        f"{pre}threshold": c.threshold})
        for k, b in enumerate(pair_bodies(sol, i)):
            out[f"{pre}trace_s{b + 1}"], out[f"{pre}pressure{b + 1}"] = sol.traction(k, i)
    for k, (body, u, phi) in enumerate(zip(sol.scene.bodies, sol.u, sol.phi), start=1):
        out[f"u{k}"] = u
        if phi is not None:
            out[f"phi{k}"] = phi
        out[f"points{k}"] = body.mesh.points
        out[f"{CELL_ARRAYS[body.mesh.cell]}{k}"] = body.mesh.cells
    return out


CELL_ARRAYS = {"triangle": "triangles", "quad": "quads", "tetra": "tetrahedra", "hex": "hexahedra"}
"""The name of a body's cell array in a case's arrays, by the mesh's cell type (``mesh.cell``)."""


def problem_data(spec, condition):
    """The conic data of the full phi-form program of a case (scaled units of docs/formulation.md §6),
    as CVXPY hands it to Clarabel: minimise x'Px/2 + q'x subject to A x + s = b, s in the cones."""
    import cvxpy as cp
    import numpy as np
    import scipy.sparse as sp

    from ...model import Model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        problem = Model(spec.scene, condition, spec.solver, tol=spec.tol, polish=False,
                        solver_options=spec.options).solve().problem
    data, _, _ = problem.get_problem_data(cp.CLARABEL)
    out = {}
    for name in ("P", "A"):
        m = sp.csc_matrix(data[name])
        out.update({f"{name}_data": m.data, f"{name}_indices": m.indices, f"{name}_indptr": m.indptr,
                    f"{name}_shape": np.array(m.shape)})
    out["q"], out["b"] = np.asarray(data["c"], float), np.asarray(data["b"], float)
    dims = data["dims"]
    out["cone_zero"], out["cone_nonneg"] = np.array(dims.zero), np.array(dims.nonneg)
    out["cone_soc"] = np.array(dims.soc, dtype=int)
    return out


def solve_case(task: dict, scene_path, method: str, out, allow_outside: bool = False,
               export_problem: bool = False) -> tuple[str, str, str]:
    """Solve one case and write its files. Returns ``(id, state, message)`` with state "done",
    "checks_failed" or "failed". A failure is recorded in ``failures/<id>.json``; a write that fails
    raises :class:`SweepOutputError` (the sweep cannot go on)."""
    from ...io.output import summary
    from .spec import resolve

    scene_path, out = Path(scene_path), Path(out)
    t0 = time.perf_counter()
    record = {"case": task["id"], "name": task["name"], "condition": task["condition"], "method": method,
              "overrides": task["overrides"], "scene": task["data"], "provenance": task["provenance"],
              "versions": versions(), "machine": machine(),
              "threads": {k: os.environ.get(k) for k in THREAD_VARIABLES}}
    try:
        mine = {k: v for k, v in versions().items() if k in task.get("code", {})}
        if mine != task.get("code", {}):
            raise CvxContactError(f"this worker runs other cvxcontact code ({mine}) than the sweep was started "
                                  f"with ({task['code']}); install the same version on every worker")
        spec, provenance = resolve(copy.deepcopy(task["data"]), scene_path, allow_outside)
        if provenance != task["provenance"]:
            raise CvxContactError("a mesh file changed during the sweep (its sha256 differs from the one this "
                                  "case was identified by); run the sweep again")
        sol, attempts = _solve(spec, task, method, scene_path)
        record["attempts"] = attempts
        if sol is None:
            raise SolverError(f"every attempt failed; last: {attempts[-1]['error']}")
        kept = next(a["attempt"] for a in reversed(attempts) if "error" not in a)
        problem = problem_data(spec, task["condition"]) if export_problem else None
        info = sol.info
        record.update(summary(sol))
        record.update({"kept_attempt": kept, "route": str(info.route), "path": str(sol.path), "backend": info.method,
                       "handed_over": info.handed_over,
                       "solver_status": str(sol.problem.status) if sol.problem is not None else None,
                       "iterations": info.iterations, "finish": str(info.finish) if info.finish else None,
                       "seconds": time.perf_counter() - t0})
        write_case(out, task["id"], arrays(sol), record, problem)
        return task["id"], ("done" if sol.ok else "checks_failed"), "" if sol.ok else "checks failed"
    except SweepOutputError:
        raise
    except Exception as exc:  # recorded per case; the sweep goes on
        reason = _one_line(exc)
        write_json(out / FAILURES / f"{task['id']}.json", {**record, "error": reason})
        return task["id"], "failed", reason


# ---------------------------------------------------------------------------------- worker process

def _die_with_parent(parent_pid):
    """Exit when the parent dies: PR_SET_PDEATHSIG (Linux), and a thread polling the parent pid."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)                 # PR_SET_PDEATHSIG
    except (OSError, AttributeError):                         # not Linux: the watchdog below suffices
        pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, daemon=True, name="cvxcontact-sweep-watchdog").start()


def limit_threads(n: int) -> dict:
    """Limit the threads of this process's numerical libraries to ``n``: the environment (for
    libraries loaded later and OpenMP) and, through their C API, the OpenBLAS copies already
    loaded (NumPy's and SciPy's; a forked worker inherits them initialised). Returns
    {library file: threads set}."""
    import ctypes

    for k in THREAD_VARIABLES:
        os.environ[k] = str(n)
    done = {}
    try:
        with open("/proc/self/maps") as f:
            libs = sorted({p for p in (line.split()[-1] for line in f if "/" in line)
                           if "openblas" in os.path.basename(p).lower() and ".so" in os.path.basename(p)})
    except OSError:                                            # not Linux: the environment only
        return done
    for lib in libs:
        try:
            handle = ctypes.CDLL(lib)
        except OSError:
            continue
        for name in ("openblas_set_num_threads", "openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                     "scipy_openblas_set_num_threads64_"):
            fn = getattr(handle, name, None)
            if fn is not None:
                fn(ctypes.c_int(n))
                done[Path(lib).name] = n
                break
    return done


def worker_main(conn, parent_pid, threads, scene_path, method, out, allow_outside, export_problem):
    """Loop of a worker process: receive a task, send ``("result", id, state, message)``; on a write
    failure send ``("fatal", message)``. ``None`` or a closed pipe ends it. SIGINT is ignored (the
    driver stops the workers); thread counts come from the environment the driver set."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)             # a forked worker inherits the driver's handler
    _die_with_parent(parent_pid)
    limit_threads(threads)
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        try:
            conn.send(("result", *solve_case(task, scene_path, method, out, allow_outside, export_problem)))
        except SweepOutputError as exc:
            conn.send(("fatal", str(exc)))
            return
