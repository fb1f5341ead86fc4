"""Exploration: the condensed "gamma3" interface program handed to Clarabel directly instead of through CVXPY.

A replica of the program of :class:`cvxcontact.backends.condensed.InterfaceModel` without a law (two random SPD
Sigma blocks of the sizes given, random sparse rows): minimise sum_l 1/2 v_l^T Sigma_l v_l - g_l^T v_l subject
to sum_l R_l v_l <= gap. Prints the memory of CVXPY's compilation (tracemalloc: its peak and what it keeps; the
resident set) and of Clarabel's solve on the same data, and checks that Clarabel called directly on
P = triu(blockdiag Sigma_l) (CSC), q = -g, A = [R_1, R_2], b = gap and the nonnegative cone is handed the same
data as by CVXPY and returns the same iterates (the answers' differences printed).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_direct_clarabel.py \\
        --sizes 1681 841 --rows 8353
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import clarabel
import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from cvxcontact.backends.program import CLARABEL


def resident_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1681, 841], help="Gamma dofs of each body")
    ap.add_argument("--rows", type=int, default=8353)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    sigma = []
    for n in args.sizes:
        X = rng.standard_normal((n, n)) / np.sqrt(n)
        S = X @ X.T + np.eye(n)
        sigma.append(0.5 * (S + S.T))
    rows = [sp.random(args.rows, n, density=4 / n, random_state=k, format="csr") for k, n in enumerate(args.sizes)]
    loads = [rng.standard_normal(n) for n in args.sizes]
    gap = 0.01 * np.abs(rng.standard_normal(args.rows))
    v = [cp.Variable(n) for n in args.sizes]
    energy = sum(0.5 * cp.quad_form(x, cp.psd_wrap(S)) - g @ x for x, S, g in zip(v, sigma, loads))
    contact = sum(R @ x for R, x in zip(rows, v)) <= gap
    problem = cp.Problem(cp.Minimize(energy), [contact])
    entries = sum(n * n for n in args.sizes)

    P = sp.block_diag([sp.csc_matrix(np.triu(S)) for S in sigma], format="csc")
    A = sp.hstack(rows, format="csc")
    q = -np.concatenate(loads)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    for k, val in CLARABEL.items():
        setattr(settings, k, val)
    r0 = resident_mb()                              # Clarabel first: the resident set not yet grown by CVXPY's
    t0 = time.process_time()
    solution = clarabel.DefaultSolver(P, q, A, gap, [clarabel.NonnegativeConeT(args.rows)], settings).solve()
    grown = resident_mb() - r0
    print(f"Clarabel directly: {time.process_time() - t0:.2f} CPU s, resident +{grown:.0f} MB "
          f"({grown * 1e6 / entries:.0f} B per entry of Sigma), {solution.iterations} iterations")

    r0 = resident_mb()
    tracemalloc.start()
    t0 = time.process_time()
    data, _, _ = problem.get_problem_data(cp.CLARABEL)
    now, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"CVXPY compilation: {time.process_time() - t0:.2f} CPU s, peak {peak / 1e6:.0f} MB "
          f"({peak / entries:.0f} B per entry of Sigma), kept {now / 1e6:.0f} MB ({now / entries:.0f} B), "
          f"resident +{resident_mb() - r0:.0f} MB")
    same = [float(abs(P - sp.triu(data["P"]).tocsc()).max()), float(abs(A - data["A"]).max()),
            float(np.abs(q - data["c"]).max()), float(np.abs(gap - data["b"]).max())]
    print("the data CVXPY hands Clarabel against the direct one (P, A, q, b; max abs difference):", same)
    del data
    problem.solve(solver="CLARABEL", **CLARABEL)
    print(f"through CVXPY: {problem.solver_stats.num_iters} iterations; max |x - x_cvxpy| "
          f"{np.abs(np.asarray(solution.x) - np.concatenate([x.value for x in v])).max():.1e}, max |z - y_cvxpy| "
          f"{np.abs(np.asarray(solution.z) - np.asarray(contact.dual_value)).max():.1e}")

if __name__ == "__main__":
    main()
