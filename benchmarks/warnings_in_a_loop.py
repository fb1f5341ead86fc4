"""How often a user's loop of solves shows the package's warnings, and how often a solve changes the warning filters.

A plain script (Python's own default filters: no -W, no PYTHONWARNINGS) solves a scene that warns (a force-
controlled circle touching one node of the block under it: a NonUniqueWarning and a ResolutionWarning,
tests/obstacle_scenes.py) three times from one line of a loop, then once more from a second line; under Python's
"default" action each warning should be shown once per line. Printed: the NonUniqueWarning and ResolutionWarning
lines the script's stderr shows after the loop and after the second line, and the changes of the filters
(``warnings._filters_mutated`` calls: ``catch_warnings`` enter and exit, ``filterwarnings``, ``simplefilter``)
made by one solve after a first (imports and the PARDISO look-up happen once per process), for three scenes;
and the CPU time of the second ``chain.invert`` that ``run_program`` makes to read the status before
``unpack_results`` (the rest of its steps are ``problem.solve``'s own), beside the program's size and Clarabel's (wall) time.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/warnings_in_a_loop.py

Run from a checkout (its cvxcontact is imported first); results: CHANGELOG.md (Unreleased, "a loop of solves").
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import textwrap
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

SCRIPT = """
import sys
sys.path[:0] = [{root!r}, {tests!r}]
from obstacle_scenes import half_model
import cvxcontact as cc

def scene():
    return half_model(force=(0.0, -1e7), center_x=0.5, roller=())

for _ in range(3):
    cc.solve(scene(), condition="sigma1")
print("-- after the loop", file=sys.stderr)
cc.solve(scene(), condition="sigma1")
"""


def script_counts() -> list[tuple[int, int]]:
    """[(NonUniqueWarnings, ResolutionWarnings) shown after the loop, and after the second line]."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "user_loop.py"
        path.write_text(textwrap.dedent(SCRIPT.format(root=str(ROOT), tests=str(ROOT / "tests"))))
        env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
        run = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, env=env, check=True)
    loop, _, after = run.stderr.partition("-- after the loop")
    return [(part.count("NonUniqueWarning:"), part.count("ResolutionWarning:")) for part in (loop, loop + after)]


def filter_changes() -> dict[str, int]:
    """{scene: the changes of the filters during its second solve}."""
    from conftest import two_blocks
    from obstacle_scenes import half_model

    import cvxcontact as cc
    calls = []
    mutated = warnings._filters_mutated
    scenes = {"circle on one node, sigma1": (lambda: half_model(force=(0.0, -1e7), center_x=0.5, roller=()),
                                             {"condition": "sigma1"}),
              "two_blocks 3x2/2x2, default": (lambda: two_blocks(n1=(3, 2), n2=(2, 2),
                                                                 traction={"right": (0.0, 3e8)}), {}),
              "two_blocks 3x2/2x2, full": (lambda: two_blocks(n1=(3, 2), n2=(2, 2),
                                                              traction={"right": (0.0, 3e8)}), {"method": "full"})}
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warnings._filters_mutated = lambda: calls.append(1) or mutated()
        try:
            for name, (build, kw) in scenes.items():
                cc.solve(build(), **kw)
                calls.clear()
                cc.solve(build(), **kw)
                out[name] = len(calls)
        finally:
            warnings._filters_mutated = mutated
    return out


def invert_cost() -> list[tuple[str, int, float, float]]:
    """[(scene, scalar variables, the median CPU s of 7 ``chain.invert`` of its program's answer, Clarabel's s)]."""
    import time

    import numpy as np
    from conftest import two_blocks
    from scenes3d import two_boxes

    import cvxcontact as cc
    from cvxcontact.backends import program

    run, rows = program._solve, []

    def spy(problem, solver, verbose, options):
        run(problem, solver, verbose, options)
        data, chain, inverse = problem.get_problem_data(solver, solver_opts=dict(options))
        raw = chain.solve_via_data(problem, data, True, False, dict(options))
        times = []
        for _ in range(7):
            t0 = time.process_time()
            chain.invert(raw, inverse)
            times.append(time.process_time() - t0)
        rows.append((problem.size_metrics.num_scalar_variables, float(np.median(times)),
                     problem.solver_stats.solve_time))

    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        program._solve = spy
        try:
            for name, build in (("two_blocks 16x8/11x6, full", lambda: two_blocks()),
                                ("two_blocks 64x32/44x24, full", lambda: two_blocks((64, 32), (44, 24))),
                                ("two_boxes(6) 3D, full", lambda: two_boxes(6))):
                rows.clear()
                cc.solve(build(), method="full")
                out += [(name, *row) for row in rows]
        finally:
            program._solve = run
    return out


if __name__ == "__main__":
    (loop, both) = script_counts()
    print(f"plain script, 3 solves from one line: {loop[0]} NonUniqueWarning, {loop[1]} ResolutionWarning shown")
    print(f"  and one more from a second line:    {both[0]} NonUniqueWarning, {both[1]} ResolutionWarning in all")
    for name, n in filter_changes().items():
        print(f"filter changes in one solve, {name}: {n}")
    for name, n, t, solve in invert_cost():
        print(f"run_program's extra chain.invert, {name} ({n} scalar variables): {t * 1e3:.2f} ms CPU "
              f"(Clarabel's solve {solve:.3f} s wall)")
