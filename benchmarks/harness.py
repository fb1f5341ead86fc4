"""The benchmarks' common harness: measurement plumbing and the bonded yardsticks.

Used by benchmarks/bench3d.py, benchmarks/bench_default.py and benchmarks/bench_piezo_amg.py.

Plumbing: each part of a case runs in a fresh subprocess of the calling script (``run_part``: the script's
``--one JSON`` mode, whose last printed line is the part's JSON result), so that its peak memory (``peak_gb``,
``resource.getrusage`` maxrss) is its own; times are medians over runs (``median_row``); growth exponents are
least-squares slopes of log time against log unknowns (``growth``); rows are written as CSV (``write_csv``)
and Markdown tables (``markdown_table``, ``cell``).

Yardsticks: the scene's scaled blocks with every constraint row closed, i.e. the mixed system
K = [[S, G^T], [G, 0]] of the free dofs (S: each block's quasi-definite matrix, its Gauss rows negated) and
the rows G x = g (``bonded_kkt``), solved from scratch by

* Intel oneMKL PARDISO, real symmetric indefinite with weighted matching, through cvxcontact
  (``pardiso_symmetric``) or through ``pypardiso`` (``pypardiso_solve``: mtype -2 or 11);
* SciPy SuperLU (``superlu_solve``: MMD on A^T + A, threshold pivoting 0.1);
* smoothed-aggregation AMG (pyamg) preconditioned CG, GMRES with the AMG route's block upper-triangular
  preconditioner for a piezoelectric body (``amg_bonded``), on the system with its constraints eliminated
  exactly (``eliminate``: each row solved for its own dof; not "gamma3" overlay rows, which share their dofs).

NumPy and SciPy only at import; cvxcontact, pyamg and pypardiso are imported by the yardsticks that need them.
"""

from __future__ import annotations

import collections
import csv
import functools
import json
import os
import resource
import statistics
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path

import numpy as np

# ------------------------------------------------------------------------------------------------ plumbing


class StageTimes:
    """Process CPU seconds by stage: :meth:`wrap` replaces ``owner.name`` by a timer (inclusive) that also sums the
    time of the calls wrapped with ``pardiso=True`` made inside it (PARDISO's share); the stages nest, so a row's
    rest (inclusive less PARDISO) is that stage's own work with its callees'. ``acc[label]``: calls, inclusive,
    PARDISO inside (benchmarks/longif_stages.py, coarse3d_stages.py)."""

    def __init__(self):
        self.acc = collections.defaultdict(lambda: [0, 0.0, 0.0])
        self._stack: list[float] = []

    def wrap(self, owner, name: str, label: str, pardiso: bool = False) -> None:
        inner, acc, stack = getattr(owner, name), self.acc, self._stack

        @functools.wraps(inner)
        def timed(*args, **kw):
            t0 = time.process_time()
            stack.append(0.0)
            try:
                return inner(*args, **kw)
            finally:
                dt, inside = time.process_time() - t0, stack.pop()
                inside = dt if pardiso else inside
                if stack:
                    stack[-1] += inside
                row = acc[label]
                row[0], row[1], row[2] = row[0] + 1, row[1] + dt, row[2] + inside
        setattr(owner, name, timed)

    def lines(self, rounds: int, by_rest: bool) -> list[str]:
        """One line per stage, per round (``rounds`` counted), in ms: largest rest first (``by_rest``) or largest
        inclusive time first."""
        k = max(rounds, 1)
        order = sorted(self.acc.items(), key=lambda kv: -(kv[1][1] - kv[1][2] if by_rest else kv[1][1]))
        return [f"{label:44s} calls {calls / k:5.1f}  inclusive {inc / k * 1e3:7.1f}  PARDISO {inside / k * 1e3:7.1f}"
                f"  rest {(inc - inside) / k * 1e3:7.1f}" for label, (calls, inc, inside) in order]


def peak_gb() -> float:
    """Peak resident memory of this process so far, GB (``ru_maxrss``, KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def resident_mb() -> float:
    """Resident memory of this process now, MB."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 1e6


class PeakSampler:
    """Samples the resident memory every ``dt`` seconds in a thread; keeps the highest sample since :meth:`reset`
    and the main thread's innermost frames of ``packages`` at it. With ``limit_mb``, a watchdog too: above it the
    process prints where it was and ends (exit code 3) before the machine runs short."""

    def __init__(self, dt: float = 0.02, limit_mb: float | None = None, packages=("cvxcontact",)):
        self.dt, self.limit, self.packages = dt, limit_mb, tuple(packages)
        self.main = threading.main_thread().ident
        self.reset()
        threading.Thread(target=self._run, daemon=True).start()

    def reset(self):
        self.peak, self.where = resident_mb(), []

    def _run(self):
        while True:
            r = resident_mb()
            if self.limit is not None and r > self.limit:
                print(json.dumps({"killed": f"resident {r:.0f} MB above the limit {self.limit:.0f} MB",
                                  "at": self.where}), flush=True)
                os._exit(3)
            if r > self.peak:
                frame = sys._current_frames().get(self.main)
                stack = traceback.extract_stack(frame) if frame is not None else []
                self.peak = r
                self.where = [f"{Path(f.filename).name}:{f.lineno} {f.name}" for f in stack
                              if any(p in f.filename for p in self.packages)][-4:]
            time.sleep(self.dt)


def load() -> str:
    """The machine's load averages over 1, 5 and 15 minutes, as printed beside each case."""
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def run_part(script, args: dict, env=None) -> dict:
    """``python script --one JSON(args)`` in a fresh process (``env``: its environment, default this one's): the
    JSON dictionary on the last line it prints. A failing part raises RuntimeError with its stderr's end."""
    out = subprocess.run([sys.executable, str(script), "--one", json.dumps(args)], capture_output=True, text=True,
                         env=env)
    if out.returncode:
        raise RuntimeError(f"{args}: exit {out.returncode}\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def solve_cpu(scene, condition, **kw):
    """``cc.solve(scene, condition, **kw)`` with its warnings silenced: (the solution, its CPU seconds)."""
    import warnings

    import cvxcontact as cc

    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = cc.solve(scene, condition, **kw)
    return sol, time.process_time() - t0


def side_cells(size: float, per: float) -> int:
    """Cells along a side for a size: the size itself below 1e3, else a count of unknowns N ~ ``per`` n^3 (3D
    scenes of n x n x n/2 cells), rounded to an even n >= 2."""
    if size < 1e3:
        return int(size)
    return max(2, 2 * round((size / per) ** (1 / 3) / 2))


def median_row(rows: list[dict]) -> dict:
    """One row from the rows of repeated runs: the median of each float field, the first run's other fields."""
    out = {}
    for key, value in rows[0].items():
        vals = [r[key] for r in rows]
        out[key] = statistics.median(vals) if isinstance(value, float) else value
    return out


def unknowns(problem) -> int:
    """The free dofs of a DiscreteProblem: u and phi of every block."""
    return int(sum(b.Kuu.shape[0] + (b.Kpp.shape[0] if b.Kpp is not None else 0) for b in problem.blocks))


def rel(a, b) -> float:
    """max |a - b| / max |b| (max |a - b| if b is zero); inf if the shapes differ."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        return float("inf")
    scale = float(np.abs(b).max()) if b.size else 0.0
    return float(np.abs(a - b).max()) / scale if scale > 0 else float(np.abs(a - b).max(initial=0.0))


def growth(rows: list[dict], keys) -> str | None:
    """The exponents p of key ~ N^p (least squares of log key on log N, N the rows' ``unknowns``) for each of
    ``keys`` that every row has, finite and positive, as "key N^p, ..."; None below two rows with ``unknowns``."""
    sel = [r for r in rows if "unknowns" in r]
    if len(sel) < 2:
        return None
    N = np.log([r["unknowns"] for r in sel])
    fits = {k: np.polyfit(N, np.log([r[k] for r in sel]), 1)[0] for k in keys
            if all(k in r and r[k] == r[k] and r[k] > 0 for r in sel)}
    return ", ".join(f"{k} N^{v:.2f}" for k, v in fits.items())


def write_csv(path, rows: list[dict], append: bool = False) -> Path:
    """Write ``rows`` (the union of their keys as columns, in first-seen order) to ``path``, after the rows
    already there if ``append``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    old = []
    if append and path.exists():
        with open(path, newline="") as fh:
            old = list(csv.DictReader(fh))
    keys = list(dict.fromkeys(k for r in old + rows for k in r))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(old + rows)
    return path


def write_report(path, lines: list[str]) -> Path:
    """The Markdown report ``lines`` written to ``path`` (its folder made), one line each; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    print("wrote", path)
    return path


def cell(row: dict, key: str, fmt: str = "{:.2f}") -> str:
    """``row[key]`` formatted, or "-" where the row lacks it or it is NaN."""
    value = row.get(key)
    return "-" if value is None or value != value else fmt.format(value)


def markdown_table(head: list[str], lines: list[list[str]]) -> str:
    """A Markdown table: the column titles, the separator and one line per list of cells."""
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(cells) + " |" for cells in lines]
    return "\n".join(out)


# ------------------------------------------------------------------------------------------------ yardsticks


def bonded_kkt(blocks, rows, g=None):
    """The bonded mixed system of ``blocks`` (scaled Blocks) under the constraint rows ``rows[k]`` (on block k's
    free u dofs) held as equalities G x = g (default g = 0): K = [[S, G^T], [G, 0]] (CSC, sorted, every diagonal
    entry stored, zeros too), its right-hand side [F; g], S = diag(S_k) (CSR), G on the stacked free dofs
    x = [u_1; phi_1; u_2; ...], and each block's (u, phi) sizes. Coefficients below 1e-12 of the largest (the
    interpolation weights of coincident nodes) are dropped first, and rows left empty with them."""
    import scipy.sparse as sp

    from cvxcontact.backends.condensed import quasi_definite

    parts = [quasi_definite(b) for b in blocks]
    G = sp.hstack([sp.hstack([sp.csr_matrix(R), sp.csr_matrix((R.shape[0], S.shape[0] - R.shape[1]))])
                   for R, (S, _) in zip(rows, parts)]).tocsr()
    G.data[np.abs(G.data) < 1e-12 * np.abs(G.data).max()] = 0.0
    G.eliminate_zeros()
    g = np.zeros(G.shape[0]) if g is None else np.asarray(g, dtype=float)
    keep = np.diff(G.indptr) > 0
    G, g = G[keep], g[keep]
    A = sp.block_diag([S for S, _ in parts], format="csr")
    m = G.shape[0]
    K = sp.bmat([[A, G.T], [G, sp.csr_matrix((m, m))]], format="coo")
    d = np.arange(K.shape[0])                                   # every diagonal entry stored (zeros too)
    K = sp.coo_matrix((np.concatenate([K.data, np.zeros(len(d))]), (np.concatenate([K.row, d]),
                                                                    np.concatenate([K.col, d]))), shape=K.shape)
    K = K.tocsc()                                               # sums the duplicates, keeps explicit zeros
    K.sort_indices()
    rhs = np.concatenate([F for _, F in parts] + [g])
    sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(blocks, parts)]
    return K, rhs, A, G, sizes


def bonded_system(problem):
    """``bonded_kkt`` of a DiscreteProblem with every contact row closed, [u_nu] = g at every row (the rows'
    own E): K, [F; g], S, G, sizes."""
    return bonded_kkt(problem.blocks, [problem.E @ b.jump for b in problem.blocks], problem.g)


def thin_layer_route(n: int):
    """The sparse route's data on ``demo.thin_layer(n)`` and its bonded PARDISO yardstick, as the long-interface A/B
    scripts time them (benchmarks/longif_ab.py, longif_final_ab.py): (blocks, E, g, F, bonded) with ``bonded()``
    one bonded PARDISO solve from scratch (pypardiso, symmetric indefinite), returning its process CPU seconds."""
    import pypardiso
    import scipy.sparse as sp

    import cvxcontact as cc
    from cvxcontact.apps import demo
    from cvxcontact.backends.condensed import quasi_definite_rhs

    cc.solve(demo.thin_layer(8))                                # imports and first-call costs out of the timings
    p = cc.ContactSolver(demo.thin_layer(n)).problem
    blocks, E, g = list(p.blocks), p.E, np.asarray(p.g, dtype=float)
    F = np.concatenate([quasi_definite_rhs(b) for b in blocks])
    K, rhs, _, _, _ = bonded_kkt(blocks, [b.jump for b in blocks])
    M = sp.triu(K, format="csr")
    M.sort_indices()

    def bonded() -> float:
        ps = pypardiso.PyPardisoSolver(mtype=-2)
        t0 = time.process_time()
        ps.solve(M, rhs)
        t = time.process_time() - t0
        ps.free_memory(everything=True)
        return t

    return blocks, E, g, F, bonded


def thin_layer_rounds(sides: dict, route, reps: int, pardiso=None):
    """The interleaved A/B rounds of the long-interface scripts (benchmarks/longif_twod_ab.py, longif_pkg_ab.py):
    in ONE process (so that a shared machine's load touches both alike), ``reps`` rounds, the order alternating
    ("before", "after", "bonded"; then "after", "before", "bonded"), of the sparse route from its start with each
    side's ``backends.sparse`` module (``sides``: {"before": module, "after": module}; ``SparseContact(...)``, then
    ``coarse_start`` above the module's ``COARSE_ROWS`` rows, then ``solve``) and one bonded PARDISO solve.
    ``route``: :func:`thin_layer_route`'s (blocks, E, g, F, bonded). ``pardiso``: None, or a callable returning the
    process CPU s spent in PARDISO so far (a spy's counter), each side's run then split into PARDISO's and the rest.

    Returns (t, rest, counts, answers): process CPU s per mode and round (``t``, modes "before", "after", "bonded";
    ``rest``: a side's time less PARDISO's, empty lists without ``pardiso``), per side and round (numeric
    factorisations, capacitance columns, systems) (``counts``) and the last round's (stacked displacements, row
    forces, active set) (``answers``)."""
    blocks, E, g, F, bonded = route
    t = {"before": [], "after": [], "bonded": []}
    rest = {"before": [], "after": []}
    counts, answers = {}, {}
    for r in range(reps):
        for mode in (("before", "after", "bonded") if r % 2 == 0 else ("after", "before", "bonded")):
            if mode == "bonded":
                t[mode].append(bonded())
                continue
            sm = sides[mode]
            inside = pardiso() if pardiso else 0.0
            t0 = time.process_time()
            sc = sm.SparseContact(blocks, E, factorization="auto")
            st = sc.coarse_start(F, g) if len(g) >= sm.COARSE_ROWS else None
            out = sc.solve(F, g, st)
            t[mode].append(time.process_time() - t0)
            if pardiso:
                rest[mode].append(t[mode][-1] - (pardiso() - inside))
            counts.setdefault(mode, []).append((sc.factorizations, sc.column_solves, out[-1]))
            answers[mode] = (np.concatenate(out[0]), out[2], out[3])
    return t, rest, counts, answers


def coarse_rows_by_c4(C, free=None) -> np.ndarray:
    """``backends.coarse.coarse_rows`` as it was before its density dispatch (25d0d37f): the balls of COARSE_HOPS
    hops from the pattern of C^COARSE_HOPS formed by repeated products whatever the density, the greedy independent
    set in row order (``free``: the rows that may be coarse, default all). The A/B scripts' baseline
    (benchmarks/coarse2d_ab.py, coarse3d_ab.py, longif_coarse_rows.py)."""
    from cvxcontact.backends import coarse

    P = C
    for _ in range(coarse.COARSE_HOPS - 1):
        P = P @ C
    P = P.tocsr()
    free = np.ones(C.shape[0], dtype=bool) if free is None else np.asarray(free, dtype=bool)
    keep, blocked = np.zeros(C.shape[0], dtype=bool), ~free
    for a in range(C.shape[0]):
        if not blocked[a]:
            keep[a] = True
            blocked[P.indices[P.indptr[a]:P.indptr[a + 1]]] = True
    return np.flatnonzero(keep)


def two_blocks_solver(nx: int):
    """``demo.two_blocks(nx)`` prepared and solved once as the re-solve scripts time it (benchmarks/
    resolve_closed_ab.py, resolve_batch_ab.py, resolve_profile.py): an untimed ``cc.solve(two_blocks(4))`` first
    (imports, first-call set-up), then (scene, solver, first) with ``first`` the process CPU seconds of
    ``cc.ContactSolver(scene).solve()``, from the Scene to the checked Solution."""
    import cvxcontact as cc
    from cvxcontact.apps import demo

    cc.solve(demo.two_blocks(4))
    scene = demo.two_blocks(nx)
    c0 = time.process_time()
    solver = cc.ContactSolver(scene)
    solver.solve()
    return scene, solver, time.process_time() - c0


def load_cases(scene):
    """``cases(k)``: k new load cases of ``demo.two_blocks`` (the re-solve scripts' loads: the body force, charge and
    traction at 0.37 of the scene's, each traction a thousandth apart from the last so no two cases are alike)."""
    count = iter(range(10 ** 6))

    def cases(k: int) -> list:
        s = 0.37
        return [scene.with_loads(0, body_force=(0.0, -2e9 * s), surface_charge={"left": -0.05 * s},
                                 traction={"right": (0.0, 3e8 * s * (1 + next(count) / 1000))}) for _ in range(k)]

    return cases


def solution_digest(sol) -> str:
    """16 hex digits of a sha256 over a Solution's u, every pair's lambda_h, force and active set, ok and its checks'
    residuals: the same-bits scripts' fingerprint of an answer (cones_nan_same_bits.py, parallel_same_bits.py)."""
    import hashlib

    h = hashlib.sha256()
    for a in [*sol.u, *(getattr(c, name) for c in sol.contacts for name in ("lam", "force", "active"))]:
        h.update(np.ascontiguousarray(np.asarray(a, dtype=float)).tobytes())
    h.update(repr((sol.ok, sorted(sol.residuals().items()))).encode())
    return h.hexdigest()[:16]


def residual(K, z, rhs) -> float:
    """||K z - rhs|| / ||rhs||."""
    return float(np.linalg.norm(K @ z - rhs) / np.linalg.norm(rhs))


def pardiso_symmetric(K, rhs):
    """PARDISO through cvxcontact (:class:`cvxcontact.backends.factor.PardisoSymmetric`: analysis +
    factorisation + solve of K, CSC with every diagonal stored): (seconds, z, perturbed pivots, CPU seconds)."""
    from cvxcontact.backends.factor import PardisoSymmetric

    t0, c0 = time.perf_counter(), time.process_time()
    ps = PardisoSymmetric(K)
    ps.factor(K)
    z = ps.solve(rhs)
    t, c = time.perf_counter() - t0, time.process_time() - c0
    perturbed = ps.perturbed
    ps.release()
    return t, z, perturbed, c


def pypardiso_solve(K, rhs, mtype):
    """PARDISO through ``pypardiso`` from scratch, real symmetric indefinite (mtype -2, upper triangle) or real
    unsymmetric (mtype 11): (seconds, relative residual)."""
    import pypardiso
    import scipy.sparse as sp

    solver = pypardiso.PyPardisoSolver(mtype=mtype)
    M = sp.triu(K, format="csr") if mtype == -2 else sp.csr_matrix(K)     # K stores its whole diagonal
    M.sort_indices()
    t0 = time.perf_counter()
    z = solver.solve(M, rhs)
    t = time.perf_counter() - t0
    solver.free_memory(everything=True)
    return t, residual(K, z, rhs)


def superlu_solve(K, rhs):
    """SciPy SuperLU from scratch (MMD on A^T + A, threshold pivoting 0.1, symmetric mode): (seconds, z)."""
    import scipy.sparse.linalg as spla

    Kc = K.tocsc()
    t0 = time.perf_counter()
    lu = spla.splu(Kc, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1, options=dict(SymmetricMode=True))
    z = lu.solve(rhs)
    return time.perf_counter() - t0, z


def rigid_modes(problem, k) -> np.ndarray:
    """The six rigid-body modes of body k on its free u dofs (columns), coordinates centred and scaled."""
    system, mesh = problem.systems[k], problem.scene.bodies[k].mesh
    x = np.asarray(mesh.points, dtype=float)
    x = (x - x.mean(axis=0)) / np.ptp(x, axis=0).max()
    n = len(x)
    B = np.zeros((3 * n, 6))
    for i in range(3):
        B[i::3, i] = 1.0
    # rotations e_i x x: about z (-y, x, 0), about x (0, -z, y), about y (z, 0, -x)
    B[0::3, 3], B[1::3, 3] = -x[:, 1], x[:, 0]
    B[1::3, 4], B[2::3, 4] = -x[:, 2], x[:, 1]
    B[0::3, 5], B[2::3, 5] = x[:, 2], -x[:, 0]
    return np.asarray(system.Tu.T @ B)


def eliminate(G, g, n):
    """x = T r + x0 with G x = g for every r: each row solved for its own dof (the one of largest |coefficient|,
    touched by no other row). Returns (T, x0, slaves) or None if the rows do not allow it (gamma3)."""
    import scipy.sparse as sp

    G = sp.csr_matrix(G)
    m = G.shape[0]
    col_rows = np.diff(sp.csc_matrix(G).indptr)
    rows = np.repeat(np.arange(m), np.diff(G.indptr))
    own = np.where(col_rows[G.indices] == 1, np.abs(G.data), -1.0)
    best = np.full(m, -1.0)
    np.maximum.at(best, rows, own)
    first = np.full(m, -1)
    hit = own == best[rows]
    idx = np.flatnonzero(hit & (best[rows] > 0))
    first[rows[idx[::-1]]] = idx[::-1]
    if np.any(first < 0):
        return None
    slaves = G.indices[first]
    if len(np.unique(slaves)) != m:
        return None
    piv = G.data[first]
    master = np.ones(n, dtype=bool)
    master[slaves] = False
    pos = np.cumsum(master) - 1
    # slave row: x_s = (g_a - sum_{j != s} G_aj x_j) / G_as, every other x_j a master dof
    Gc = G.tocoo()
    other = Gc.col != slaves[Gc.row]
    if np.any(~master[Gc.col[other]]):
        return None
    T = sp.coo_matrix((np.concatenate([np.ones(master.sum()), -Gc.data[other] / piv[Gc.row[other]]]),
                       (np.concatenate([np.flatnonzero(master), slaves[Gc.row[other]]]),
                        np.concatenate([np.arange(master.sum()), pos[Gc.col[other]]]))),
                      shape=(n, int(master.sum()))).tocsr()
    x0 = np.zeros(n)
    x0[slaves] = np.asarray(g, dtype=float) / piv
    return T, x0, slaves


def amg_bonded(problem, A, G, rhs, sizes, tol=1e-10, preconditioner="triangular"):
    """Smoothed-aggregation AMG-preconditioned CG (with potentials: GMRES, right-preconditioned by the block
    upper-triangular [[V_uu, K_up], [0, -V_pp]] of the AMG route, cvxcontact.backends.amg; ``preconditioner=
    "diagonal"``: MINRES with the block-diagonal one, the route's former solve) on the bonded system with its
    constraints eliminated (``eliminate``): (seconds, x, iterations, reduction seconds, residual, CPU seconds,
    reduction CPU seconds) or None (rows without dofs of their own, or the true residual above ``tol``). The
    seconds and CPU seconds are the set-up and the solve; the reduction (the elimination and T^T A T) is apart.

    The eliminated dofs keep their place as decoupled identity rows (zero right-hand side), so that every
    node keeps its three displacement dofs and the u block is handed to pyamg node-blocked (BSR 3 x 3: node
    aggregates; dof-wise aggregation was measured 10x slower); their rows of the near-null space are zero. The
    V-cycles are the route's (``amg.v_cycle``: pyamg's ``aspreconditioner(cycle="V")`` without its two
    finest-level residual norms, the same bits), so that the route and its yardstick run the same cycle. The
    set-ups are seeded as the route's (``krylov.seeded``: pyamg's spectral-radius estimates start from
    ``np.random.rand`` vectors; unseeded, two runs on two_boxes(10) differed by 1.1e-12 relative), so the
    yardstick is the same hierarchy and the same bits in every run."""
    import pyamg
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.krylov import seeded, v_cycle

    n = A.shape[0]
    t0, c0 = time.perf_counter(), time.process_time()
    out = eliminate(G, rhs[n:], n)
    if out is None:
        return None
    T, x0, slaves = out
    keep = np.ones(n, dtype=bool)
    keep[slaves] = False
    Tn = sp.csr_matrix((np.ones(keep.sum()), (np.flatnonzero(keep), np.arange(keep.sum()))), shape=(n, keep.sum()))
    Tf = (T @ Tn.T).tocsr()                                  # n x n: the slave columns are zero
    dummy = sp.csr_matrix((np.ones(len(slaves)), (slaves, slaves)), shape=(n, n))
    Kr = (Tf.T @ A @ Tf + dummy).tocsr()
    br = Tf.T @ (rhs[:n] - A @ x0)
    kind, modes = [], []
    for k, (nu, npf) in enumerate(sizes):
        kind += [0] * nu + [1] * npf
        modes.append(rigid_modes(problem, k))
    kind = np.array(kind)
    t_red, c_red = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    u_idx, p_idx = np.flatnonzero(kind == 0), np.flatnonzero(kind == 1)
    B = np.zeros((len(u_idx), 6))            # each body's six modes in the same six columns (own aggregates)
    pos = 0
    for k, (nu, npf) in enumerate(sizes):
        B[pos:pos + nu] = modes[k]
        pos += nu
    B[np.isin(u_idx, slaves)] = 0.0
    Kuu = Kr[u_idx][:, u_idx].tocsr()
    if Kuu.shape[0] % 3 == 0:
        Kuu = Kuu.tobsr(blocksize=(3, 3))
    with seeded():                           # pyamg's spectral-radius estimates start from random vectors
        ml_u = pyamg.smoothed_aggregation_solver(Kuu, B=B, symmetry="symmetric", max_coarse=30)   # blocks of 6 dofs
    its = []
    cb = lambda _x=None: its.append(1)  # noqa: E731
    if len(p_idx) == 0:
        x_r, info = spla.cg(Kr, br, M=v_cycle(ml_u), rtol=tol, atol=0.0, maxiter=2000,
                            callback=cb)
    else:
        Kpp = -Kr[p_idx][:, p_idx].tocsr()                       # the Gauss rows were negated (quasi-definite)
        with seeded():
            ml_p = pyamg.smoothed_aggregation_solver(Kpp, symmetry="symmetric", max_coarse=500)
        Pu, Pp = v_cycle(ml_u), v_cycle(ml_p)

        Kup = Kr[u_idx][:, p_idx].tocsr()

        def prec(r):                 # block upper-triangular [[V_uu, Kup], [0, -V_pp]] (the AMG route's)
            z = np.empty_like(r)
            z_p = -(Pp @ r[p_idx])
            z[p_idx] = z_p
            z[u_idx] = Pu @ (r[u_idx] - Kup @ z_p)
            return z

        def diagonal(r):             # block-diagonal (for MINRES: symmetric)
            z = np.empty_like(r)
            z[u_idx] = Pu @ r[u_idx]
            z[p_idx] = Pp @ r[p_idx]
            return z

        if preconditioner == "triangular":
            from cvxcontact.backends.amg import gmres

            x_r = gmres(Kr, br, np.zeros(n), spla.LinearOperator(Kr.shape, matvec=prec, dtype=float), tol,
                        callback=cb)
        else:
            M = spla.LinearOperator(Kr.shape, matvec=diagonal, dtype=float)
            x_r, rtol = None, tol
            for _ in range(4):       # MINRES stops on the preconditioned residual: tighten until the true one
                x_r, info = spla.minres(Kr, br, x0=x_r, M=M, rtol=rtol, maxiter=4000, callback=cb)
                if np.linalg.norm(br - Kr @ x_r) <= tol * np.linalg.norm(br):
                    break
                rtol /= 30.0
    t, cpu = time.perf_counter() - t0, time.process_time() - c0
    res = float(np.linalg.norm(br - Kr @ x_r) / np.linalg.norm(br))
    if res > tol:
        return None
    return t, Tf @ x_r + x0, len(its), t_red, res, cpu, c_red
