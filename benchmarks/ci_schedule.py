"""A list-scheduling model of .ci/run's wall time on 2 cores (benchmarks/results/ci_time.md): each queued job to
the core that frees first, not before its install is done, with the job times of .ci/run's logs.

- before (main at 73f4b4dd): both installs, then the jobs A, B, one per kernel set of K, K's MKL_CBWR, longest first;
- after (.ci/run now): run B's job ready at its install's end (run A's and K's at run A's); each kernel set of K in
  parts of CPU shares ``--shares`` (.ci/run's CI_PARTS), queued after A and B, every set's first part, then every
  set's second, ...; each part beyond the first costs ``--overhead`` s more (its pytest process: imports, a clone).

    python benchmarks/ci_schedule.py [--shares "4 2 1 1"] [--overhead 2] [--less NUMERICS OTHER]

``--less``: the CPU s of test work taken off (NUMERICS: of the numerics tests, which run in A, B and every kernel
set of K; OTHER: of run A's other tests), each job's time shortened by them times its wall per CPU s (the job's
time over the numerics tests' CPU s when it ran: the run's ``cpu``, else ``NUMERICS_CPU``; run A's other tests at 1 s
a CPU s).
"""

import argparse

# wall s of each job in .ci/run's logs: the installs (iA, iB), job A (pytest + documentation build), job B,
# the K kernel sets, K's MKL_CBWR; "cpu": the numerics tests' CPU s then (.ci/numerics_cpu.tsv's sum), if not
# NUMERICS_CPU
RUNS = {
    "ci_run9 (05:12, 1652 s)": {"iA": 42, "iB": 23, "A": 936 + 33, "B": 594, "K": [541, 467, 450], "mkl": 18},
    "ci_run 11:37 (2445 s, loaded)": {"iA": 45, "iB": 29, "A": 1142 + 74, "B": 817, "K": [868, 873, 713], "mkl": 43},
    "ci_run10b (08:42, 3457 s, loaded)": {"iA": 52, "iB": 51, "A": 2092 + 109, "B": 1394, "K": [1365, 911, 592],
                                          "mkl": 25},
    "ci_run 14:28 (1686 s, parts)": {"iA": 44, "iB": 27, "A": 880, "B": 544, "K": [599, 591, 608], "mkl": 22},
    "ci_run 17:28 (1582 s, e749fd76)": {"iA": 42, "iB": 23, "A": 834, "B": 491, "K": [573, 574, 564], "mkl": 21,
                                        "cpu": 540.2},
    "ci_run 18:00 (1603 s, 1f844ec7)": {"iA": 46, "iB": 25, "A": 905, "B": 574, "K": [555, 527, 516], "mkl": 22,
                                        "cpu": 540.2},
}
NUMERICS_CPU = 556.0
"""CPU s of the numerics tests (one BLAS thread, default kernels) when ci_run 14:28 ran (.ci/numerics_cpu.tsv's
sum then, with the modules added since: benchmarks/results/ci_time.md)."""


def less(r: dict, numerics: float, other: float) -> dict:
    """``r`` with ``numerics`` CPU s of numerics tests and ``other`` of run A's other tests taken off each job."""
    k = numerics / r.get("cpu", NUMERICS_CPU)
    return {**r, "A": r["A"] - numerics - other, "B": r["B"] * (1 - k), "K": [d * (1 - k) for d in r["K"]]}


def schedule(jobs: list[tuple[str, float, float]], cores: int = 2) -> float:
    """The end (s) of ``jobs`` ((name, seconds, ready at)) in queue order: a core that frees takes the first job
    ready by then (else the one ready first)."""
    free, queue = [0.0] * cores, list(jobs)
    while queue:
        i = min(range(cores), key=lambda k: free[k])
        ready = [j for j in queue if j[2] <= free[i]]
        job = ready[0] if ready else min(queue, key=lambda j: j[2])
        queue.remove(job)
        free[i] = max(free[i], job[2]) + job[1]
    return max(free)


def before(r: dict) -> float:
    t0 = max(r["iA"], r["iB"])
    jobs = [("A", r["A"]), ("B", r["B"])] + [(f"K{i}", d) for i, d in enumerate(r["K"])] + [("mkl", r["mkl"])]
    return schedule([(name, d, t0) for name, d in jobs])


def after(r: dict, shares: list[float], overhead: float) -> float:
    jobs = sorted([("B", r["B"], r["iB"]), ("A", r["A"], r["iA"])], key=lambda j: j[2])
    for p, s in enumerate(shares):
        jobs += [(f"K{i}.{p}", d * s / sum(shares) + (overhead if p else 0.0), r["iA"]) for i, d in enumerate(r["K"])]
    return schedule(jobs + [("mkl", r["mkl"], r["iA"])])


if __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cli.add_argument("--shares", default="4 2 1 1")
    cli.add_argument("--overhead", type=float, default=2.0)
    cli.add_argument("--less", nargs=2, type=float, default=(0.0, 0.0), metavar=("NUMERICS", "OTHER"))
    args = cli.parse_args()
    shares = [float(s) for s in args.shares.split()]
    print(f"{'run':36s} {'before':>7s} {'after':>7s} {'saved':>6s} {'both busy':>9s}")
    for name, r in RUNS.items():
        r = less(r, *args.less)
        work = r["A"] + r["B"] + sum(r["K"]) + r["mkl"] + (len(shares) - 1) * len(r["K"]) * args.overhead
        busy = r["iB"] + (work + r["iA"] - r["iB"]) / 2        # both cores busy from run B's install to the end
        b, a = before(r), after(r, shares, args.overhead)
        print(f"{name:36s} {b:7.0f} {a:7.0f} {b - a:6.0f} {busy:9.0f}")
