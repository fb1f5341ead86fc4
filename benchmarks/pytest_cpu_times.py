"""A pytest plugin that records each test's CPU seconds (``time.process_time``: every thread of the pytest process,
not the machine's other load) and wall seconds, setup and teardown included (a module fixture's solves count for
the first test that asks for them), one tab-separated line per test appended to ``$CPU_TIMES_OUT`` as the test
ends (a run cut short keeps what it measured). Then ``python benchmarks/pytest_cpu_times.py FILE...`` prints the
CPU seconds per module, largest first. Results: benchmarks/results/ci_time.md.

    CPU_TIMES_OUT=/tmp/num.tsv PYTHONPATH=.:benchmarks OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \\
        python -m pytest -p pytest_cpu_times -p no:cacheprovider -q -m numerics
"""

import os
import sys
import time
from collections import defaultdict

import pytest


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    c0, w0 = time.process_time(), time.perf_counter()
    yield
    out = os.environ.get("CPU_TIMES_OUT")
    if out:
        with open(out, "a") as f:
            f.write(f"{item.nodeid}\t{time.process_time() - c0:.3f}\t{time.perf_counter() - w0:.3f}\n")


def per_module(paths) -> list[tuple[str, int, float, float]]:
    """(module, tests, CPU s, wall s) summed over the lines of ``paths``, largest CPU first (a test measured twice:
    its last line)."""
    rows = {}
    for path in paths:
        with open(path) as f:
            for line in f:
                node, cpu, wall = line.rstrip("\n").split("\t")
                rows[node] = float(cpu), float(wall)
    mods = defaultdict(lambda: [0, 0.0, 0.0])
    for node, (cpu, wall) in rows.items():
        m = mods[node.split("::")[0]]
        m[0] += 1
        m[1] += cpu
        m[2] += wall
    return sorted(((k, *v) for k, v in mods.items()), key=lambda r: -r[2])


if __name__ == "__main__":
    table = per_module(sys.argv[1:])
    print(f"{'CPU s':>8} {'wall s':>8} {'tests':>6}  module")
    for name, n, cpu, wall in table:
        print(f"{cpu:8.1f} {wall:8.1f} {n:6d}  {name}")
    print(f"{sum(r[2] for r in table):8.1f} {sum(r[3] for r in table):8.1f} {sum(r[1] for r in table):6d}  total")
