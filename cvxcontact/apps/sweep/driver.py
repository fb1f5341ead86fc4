"""The driver of a sweep: lock, resume, schedule the cases on worker processes, stop cleanly.

Workers are processes (forked on POSIX, spawned elsewhere; thread counts set per worker to
cores / workers), each fed one case at a time through its
own pipe, preferring a case of the geometry it has prepared. The driver therefore always
knows which case each worker is running: a worker that dies (killed, out of memory) is
recorded as a failure of that case and replaced; the other workers go on. Ctrl-C or SIGTERM
terminates the workers at once (the cases in flight stay pending), writes the manifest from
the files on disk and re-raises KeyboardInterrupt. Workers exit by themselves if the driver
dies (kill -9 included): see :func:`cvxcontact.apps.sweep.worker.worker_main`.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from ...errors import CvxContactError
from .spec import SweepError, machine, read_sweep, versions
from .store import (FAILURES, FolderLock, SweepOutputError, case_state, clean_temporaries, prepare_out,
                    remove_case, supersede, write_json)
from .worker import THREAD_VARIABLES, solve_case, worker_main

__all__ = ["SweepReport", "run_sweep", "main_progress"]


@dataclass
class SweepReport:
    """What a run did. ``done``: cases with a result passing its checks; ``checks_failed``: results whose
    checks fail after the retry ladder ({id: message}); ``failed``: cases without a result ({id: reason},
    invalid cases included); ``invalid``: ids of the cases whose scene is invalid; ``skipped``: results
    from earlier runs; ``superseded``: earlier results of a different input moved to ``superseded_to``;
    ``redone``: corrupt or incomplete files found and redone."""

    total: int
    done: int
    failed: dict
    skipped: int
    seconds: float
    checks_failed: dict = field(default_factory=dict)
    invalid: list = field(default_factory=list)
    superseded: int = 0
    superseded_to: str | None = None
    redone: int = 0


def _record_invalid(out, case):
    write_json(out / FAILURES / f"{case.id}.json",
               {"case": case.id, "name": case.name, "condition": case.condition, "overrides": case.overrides,
                "scene": case.data, "versions": versions(), "machine": machine(),
                "error": f"invalid input: {case.invalid}"})


def _write_manifest(out, sweep, states, threads):
    write_json(out / "manifest.json", {
        "sweep": str(sweep.path), "scene": str(sweep.scene_path), "method": sweep.method,
        "versions": versions(), "machine": machine(), "threads_per_worker": threads,
        "states": {s: sum(v == s for v in states.values())
                   for s in ("done", "checks_failed", "failed", "pending")},
        "cases": [{"id": c.id, "name": c.name, "condition": c.condition, "overrides": c.overrides,
                   "state": states[c.id], "scene": c.data, "provenance": c.provenance,
                   "result": f"cases/{c.id}.json" if states[c.id] in ("done", "checks_failed") else None,
                   "failure": f"failures/{c.id}.json" if states[c.id] == "failed" else None}
                  for c in sweep.cases]})


@contextmanager
def _sigterm_interrupts():
    """SIGTERM raises KeyboardInterrupt in the main thread (so the sweep stops as on Ctrl-C)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def run_sweep(path, out, workers=None, scheduler=None, retry_failed=False, progress=None,
              allow_outside: bool = False, export_problem: bool = False, skip_invalid: bool = False) -> SweepReport:
    """Run (or resume) the sweep of ``path`` into the folder ``out``.

    ``workers``: local processes (default: the number of cores; 1 runs in this process, where Ctrl-C
    takes effect only when the factorisation or solver call under way returns).
    ``scheduler``: address of a Dask distributed scheduler, or a ``distributed.Client``.
    ``retry_failed``: run the recorded failures and the cases whose checks failed again.
    ``progress``: a callable taking one line of text. ``allow_outside``: accept a scene file outside
    the sweep file's folder and mesh files outside the scene file's folder. ``export_problem``: also write each case's conic problem
    data. ``skip_invalid``: record cases whose scene is invalid as failures and run the others
    (default: refuse the sweep, naming them).

    Raises :class:`SweepError` (bad sweep file or invalid cases), :class:`SweepOutputError`
    (output folder not writable, disk full), :class:`SweepLockedError` (another sweep runs on
    ``out``), KeyboardInterrupt (Ctrl-C, SIGTERM; the manifest matches the folder).
    """
    for name, flag in (("allow_outside", allow_outside), ("export_problem", export_problem),
                       ("skip_invalid", skip_invalid), ("retry_failed", retry_failed)):
        if not isinstance(flag, bool):
            raise SweepError(f"{name} must be True or False, got {flag!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise SweepError(f"workers must be a whole number >= 1, got {workers!r}")
    say = progress or (lambda line: None)
    sweep = read_sweep(path, allow_outside=allow_outside)
    invalid = sweep.invalid
    if invalid and not skip_invalid:
        first = invalid[0]
        raise SweepError(f"{len({c.name for c in invalid})} of {len({c.name for c in sweep.cases})} cases of "
                         f"{sweep.path} are invalid, e.g. {first.name!r} (overrides {first.overrides}): "
                         f"{first.invalid}; fix them, or pass --skip-invalid to record them as failures and run "
                         "the others")
    out = prepare_out(out)
    with FolderLock(out), _sigterm_interrupts():
        return _run_locked(sweep, out, workers, scheduler, retry_failed, say, allow_outside, export_problem)


def _run_locked(sweep, out, workers, scheduler, retry_failed, say, allow_outside, export_problem):
    t0 = time.perf_counter()
    clean_temporaries(out)
    ids = {c.id for c in sweep.cases}
    moved, target = supersede(out, ids)
    if moved:
        say(f"{moved} earlier result(s) of a different input (scene, mesh, materials, method, version, or a case "
            f"no longer in the sweep) moved to {target}; they are not reused")
    states, redone = {}, 0
    for c in sweep.cases:
        state, _ = case_state(out, c.id)
        if state == "corrupt":
            remove_case(out, c.id)
            redone, state = redone + 1, "pending"
        if c.invalid:
            if state != "failed":
                _record_invalid(out, c)
            state = "failed"
        elif retry_failed and state in ("failed", "checks_failed"):
            remove_case(out, c.id)
            state = "pending"
        states[c.id] = state
    if redone:
        say(f"{redone} corrupt or incomplete result(s) found (bad JSON, missing or altered npz); they are redone")
    workers = workers or os.cpu_count() or 1
    threads = max(1, (os.cpu_count() or 1) // workers)
    skipped = sum(s in ("done", "checks_failed") for s in states.values())
    todo = [c for c in sweep.cases if states[c.id] == "pending"]
    say(f"{len(sweep.cases)} cases: {skipped} already done, "
        f"{sum(s == 'failed' for s in states.values())} failed before, {len(todo)} to run")
    _write_manifest(out, sweep, states, threads)
    finished = 0
    results = _execute(todo, sweep, out, workers, threads, scheduler, allow_outside, export_problem)
    try:
        for case_id, state, message in results:
            finished += 1
            states[case_id] = state
            _write_manifest(out, sweep, states, threads)
            rate = (time.perf_counter() - t0) / finished
            say(f"{sum(s == 'done' for s in states.values())}/{len(sweep.cases)} done, "
                f"{sum(s == 'checks_failed' for s in states.values())} failing checks, "
                f"{sum(s == 'failed' for s in states.values())} failed, ETA {rate * (len(todo) - finished):.0f} s")
    finally:
        results.close()                                # workers stopped before the folder is read
        clean_temporaries(out)                         # half-written files of workers stopped mid-write
        for c in sweep.cases:                          # the manifest says what the folder holds
            if states[c.id] == "pending":
                state, _ = case_state(out, c.id)
                states[c.id] = state if state != "corrupt" else "pending"
        _write_manifest(out, sweep, states, threads)
    failed, checks_failed = {}, {}
    for c in sweep.cases:
        state, info = case_state(out, c.id)
        if state == "failed":
            failed[c.id] = info["error"]
        elif state == "checks_failed":
            checks_failed[c.id] = f"checks failed at tol={info.get('tolerance')}"
    return SweepReport(total=len(sweep.cases), done=sum(s == "done" for s in states.values()), failed=failed,
                       skipped=skipped, seconds=time.perf_counter() - t0, checks_failed=checks_failed,
                       invalid=[c.id for c in sweep.invalid], superseded=moved,
                       superseded_to=str(target) if target else None, redone=redone)


def _execute(cases, sweep, out, workers, threads, scheduler, allow_outside, export_problem):
    """Yield ``(id, state, message)`` as cases finish."""
    args = (str(sweep.scene_path), sweep.method, str(out), allow_outside, export_problem)
    if scheduler is not None:
        yield from _dask(cases, args, scheduler)
        return
    if workers == 1:                   # in this process: Ctrl-C waits for the numerical call under way
        for c in sorted(cases, key=lambda c: c.geometry):
            yield solve_case(c.as_task(), *args)
        return
    if cases:                          # in worker processes, even a single case: Ctrl-C stops them at once
        yield from _Pool(min(workers, len(cases)), threads, args).run(cases)


def run_chunk(tasks, scene_path, method, out, allow_outside=False, export_problem=False):
    """Solve a list of cases in this process (a Dask task); returns [(id, state, message)]."""
    return [solve_case(t, scene_path, method, out, allow_outside, export_problem) for t in tasks]


def _dask(cases, args, scheduler):
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError:
        raise CvxContactError("a Dask scheduler was given but dask.distributed is not installed "
                              "(pip install 'cvxcontact[dask]')") from None
    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    groups: dict = {}
    for c in cases:
        groups.setdefault(c.geometry, []).append(c.as_task())
    chunks = [g[i:i + 8] for g in groups.values() for i in range(0, len(g), 8)]
    futures = [client.submit(run_chunk, chunk, *args, pure=False) for chunk in chunks]
    try:
        for fut in dask_completed(futures):
            yield from fut.result()
    finally:
        client.cancel(futures)


class _Pool:
    """Spawned worker processes, one case each at a time (see the module docstring)."""

    def __init__(self, n, threads, args):
        import multiprocessing

        # fork where there is one (fast: no re-import; thread counts are then set in the worker through
        # the OpenBLAS API, see worker.limit_threads); spawn elsewhere (the environment set below)
        methods = multiprocessing.get_all_start_methods()
        self.ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        self.n, self.threads, self.args = n, threads, args
        self.slots: list = []

    def _start(self):
        parent, child = self.ctx.Pipe()
        env = {k: os.environ.get(k) for k in THREAD_VARIABLES}
        old_int = signal.signal(signal.SIGINT, signal.SIG_IGN)      # inherited: the worker ignores Ctrl-C
        try:
            for k in THREAD_VARIABLES:
                os.environ.setdefault(k, str(self.threads))
            proc = self.ctx.Process(target=worker_main, args=(child, os.getpid(), self.threads, *self.args), daemon=True,
                                    name="cvxcontact-sweep-worker")
            proc.start()
        finally:
            signal.signal(signal.SIGINT, old_int)
            for k, v in env.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
        child.close()
        return {"proc": proc, "conn": parent, "case": None, "geometry": None}

    def _assign(self, slot, groups):
        if not slot["proc"].is_alive():
            slot["conn"].close()
            fresh = self._start()
            slot.update(fresh)
        if slot["geometry"] in groups:
            key = slot["geometry"]
        else:
            busy = {s["geometry"] for s in self.slots if s["case"] is not None}
            free = [k for k in groups if k not in busy] or list(groups)
            key = max(free, key=lambda k: len(groups[k]))
        case = groups[key].popleft()
        if not groups[key]:
            del groups[key]
        slot["case"], slot["geometry"] = case, key
        slot["conn"].send(case.as_task())

    def run(self, cases):
        from multiprocessing.connection import wait

        groups: dict = {}
        for c in cases:
            groups.setdefault(c.geometry, deque()).append(c)
        try:
            self.slots = [self._start() for _ in range(self.n)]
            for slot in self.slots:
                if groups:
                    self._assign(slot, groups)
            while any(s["case"] is not None for s in self.slots):
                busy = [s for s in self.slots if s["case"] is not None]
                ready = wait([s["conn"] for s in busy] + [s["proc"].sentinel for s in busy], timeout=1.0)
                finished = []                          # yielded after the free workers have new cases
                for slot in busy:
                    message = None
                    if slot["conn"] in ready or slot["proc"].sentinel in ready:
                        try:
                            if slot["conn"].poll():
                                message = slot["conn"].recv()
                        except (EOFError, OSError):
                            message = None
                    if message is not None:
                        if message[0] == "fatal":
                            raise SweepOutputError(message[1])
                        slot["case"] = None
                        finished.append(message[1:])
                    elif not slot["proc"].is_alive():
                        finished.append(self._died(slot, slot["case"]))
                        slot["conn"].close()
                        self.slots[self.slots.index(slot)] = slot = self._start()
                    if slot["case"] is None and groups:
                        self._assign(slot, groups)
                yield from finished
        finally:
            self.stop()

    def _died(self, slot, case):
        out = Path(self.args[2])
        slot["case"] = None
        state, _ = case_state(out, case.id)
        if state in ("done", "checks_failed"):             # it died after writing its result
            return case.id, state, ""
        code = slot["proc"].exitcode
        how = (f"killed by signal {signal.Signals(-code).name}" if code is not None and code < 0
               else f"exit code {code}")
        reason = (f"WorkerDied: the worker process running this case ended ({how}), e.g. killed by the "
                  "out-of-memory killer; the case is recorded as failed (rerun with --retry-failed)")
        write_json(out / FAILURES / f"{case.id}.json",
                   {"case": case.id, "name": case.name, "condition": case.condition, "overrides": case.overrides,
                    "scene": case.data, "versions": versions(), "machine": machine(), "error": reason})
        return case.id, "failed", reason

    def stop(self):
        """Terminate every worker now (SIGTERM, then SIGKILL after 2 s)."""
        for s in self.slots:
            if s["proc"].is_alive():
                s["proc"].terminate()
        deadline = time.monotonic() + 2.0
        for s in self.slots:
            s["proc"].join(max(0.0, deadline - time.monotonic()))
            if s["proc"].is_alive():
                s["proc"].kill()
                s["proc"].join(1.0)
            s["conn"].close()
        self.slots = []


def main_progress(quiet):
    """A progress printer for the command line (stderr)."""
    if quiet:
        return None
    return lambda line: print(f"[sweep] {line}", file=sys.stderr, flush=True)
