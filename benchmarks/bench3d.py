"""Benchmark: the default 3D ``cc.solve`` (P1 tetrahedra) against two solves of the bonded scene.

Scenes (built here, P1, the contact condition ``--condition``, default "sigma1"):

* ``two_boxes(n)``: a PZT-5A box [0, 1] x [0, 1] x [0, 0.5] m (n x n x n/2 cells, clamped and grounded on
  top, body force 2e9 N/m^3 downwards, traction 3e8 N/m^2 along z on its right face, surface charge
  -0.05 C/m^2 on its left face) on an aluminium box [0, 1] x [0, 1] x [-0.5, 0] m (about 0.7 n cells a
  side, clamped at the bottom): non-matching faces on z = 0, the 3D analogue of ``demo.two_blocks``.
  ``--elastic`` makes the upper box aluminium too (no potentials).
* ``sphere(n)``: an aluminium block [-1, 1]^2 x [-1, 0] m (n x n x n/2 cells, clamped at the bottom)
  pressed 0.02 m deep by a fixed rigid sphere of radius 2 m (``cc.Rigid.sphere``): a Hertz contact whose
  zone (radius about 0.2 m) is a small part of the rows (one per top node).

A size is a count of unknowns N (>= 1e3), turned into n (two_boxes N ~ 2.8 n^3 with potentials, 2.2 n^3
without; sphere N ~ 1.65 n^3), or n itself (< 1e3). Each part of each case runs in a fresh subprocess,
so that its peak memory (``resource.getrusage`` maxrss) is its own.

Parts of one case:

* ``default``: ``cc.ContactSolver(scene).solve()`` as ``cc.solve`` runs it (``method="auto"``), from the
  Scene to the checked Solution; ``default_s`` excludes assembly (``assembly_s``, ``sol.timings``); the
  other ``sol.timings`` stages, the route, the number of systems solved (``steps``), factorisations and
  column solves of the sparse route, and the solution's residuals of (26)-(27) (docs/checks.md).
* ``bonded`` (the yardsticks): the same scaled blocks with every contact row closed, [u_nu] = g at every
  row (the rows' own E), i.e. the mixed system K = [[S, G^T], [G, 0]] of the free dofs and the rows,
  assembled once (excluded), then solved from scratch:
  - ``pardiso_s``: Intel oneMKL PARDISO, real symmetric indefinite with weighted matching
    (:class:`cvxcontact.backends.factor.PardisoSymmetric`: analysis + factorisation + solve);
  - ``amg_s``: smoothed-aggregation AMG (pyamg, ``pip install pyamg``) with the rigid-body modes of each
    body as near-null space, preconditioned CG to a relative residual 1e-10 (MINRES with a block-diagonal
    AMG preconditioner, u and phi, for a piezoelectric body: its matrix is quasi-definite) on the bonded
    system with its constraints eliminated exactly (each row solved for its own dof, the dof of largest
    coefficient, which no other row touches: sigma1 and rigid obstacles; not gamma3), setup + solve.
    Its answer is checked against PARDISO's (``amg_vs_pardiso``, max |a - b| / max |b| of x).
  ``bonded_s`` is the faster of the two.

Run (one thread per process: the machine is shared):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 python benchmarks/bench3d.py --sizes 1e5 5e5 1e6 \
        [--scenes two_boxes sphere] [--runs 1] [--csv benchmarks/results/bench3d.csv] [--md FILE]

Printed and written: one row per case with both parts, ``default_s / bonded_s`` (and to each yardstick),
peak memory of each part, and growth exponents (least-squares slope of log time against log N) per scene.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout

SCENES = ("two_boxes", "sphere")


def two_boxes(n: int, condition: str = "sigma1", elastic: bool = False):
    """The two-box scene (module docstring)."""
    import cvxcontact as cc
    from cvxcontact.physics import materials

    n = max(2, int(n))
    n2 = max(2, round(0.7 * n))
    aluminium = materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=max(1, n // 2))
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=n2, ny=n2, nz=max(1, (n2 + 1) // 2))
    if elastic:
        b1 = cc.Body(upper, aluminium, clamped=["top"], name="upper box", body_force=(0.0, 0.0, -2e9),
                     traction={"right": (0.0, 0.0, 3e8)})
    else:
        b1 = cc.Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], name="PZT-5A box",
                     body_force=(0.0, 0.0, -2e9), traction={"right": (0.0, 0.0, 3e8)},
                     surface_charge={"left": -0.05})
    b2 = cc.Body(lower, aluminium, clamped=["bottom"], name="aluminium box")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", condition=condition)])


def sphere(n: int, condition: str = "sigma1", elastic: bool = True):
    """The rigid sphere pressed into a block (module docstring)."""
    import cvxcontact as cc
    from cvxcontact.physics import materials

    n = max(2, int(n))
    block = cc.box(x=(-1.0, 1.0), y=(-1.0, 1.0), z=(-1.0, 0.0), nx=n, ny=n, nz=max(1, n // 2))
    body = cc.Body(block, materials.isotropic(E=70e9, nu=0.3, name="aluminium"), clamped=["bottom"],
                   name="aluminium block")
    ball = cc.Rigid.sphere((0.0, 0.0, 2.0 - 0.02), 2.0)
    return cc.Scene(body, contacts=[cc.Contact(body, "top", ball)])


def cells(scene: str, size: float, elastic: bool) -> int:
    """n for a size: n itself below 1e3, else a count of unknowns (module docstring), even."""
    if size < 1e3:
        return int(size)
    per = {"two_boxes": 2.2 if elastic else 2.8, "sphere": 1.65}[scene]
    return max(2, 2 * round((size / per) ** (1 / 3) / 2))


def make(scene, n, condition, elastic):
    return {"two_boxes": two_boxes, "sphere": sphere}[scene](n, condition, elastic)


def peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def unknowns(problem) -> int:
    return int(sum(b.Kuu.shape[0] + (b.Kpp.shape[0] if b.Kpp is not None else 0) for b in problem.blocks))


# ------------------------------------------------------------------------------------------------ default

def default_part(scene, n, condition, elastic, runs):
    import cvxcontact as cc

    cc.solve(make(scene, 4, condition, elastic))                        # imports, first-call set-up
    rows = []
    for _ in range(runs):
        sc = make(scene, n, condition, elastic)
        t0, c0 = time.perf_counter(), time.process_time()
        solver = cc.ContactSolver(sc)
        t_asm, c_asm = time.perf_counter() - t0, time.process_time() - c0
        sol = solver.solve()
        total, cpu = time.perf_counter() - t0, time.process_time() - c0
        tm = {k: float(v) for k, v in dict(sol.timings).items()}
        sparse = solver.cache.sparse
        rows.append(dict(default_total_s=total, assembly_s=tm.get("assembly", 0.0),
                         default_s=total - tm.get("assembly", 0.0), default_cpu_s=cpu - c_asm,
                         solver_build_s=t_asm,
                         **{f"t_{k}": v for k, v in tm.items() if k != "assembly"},
                         method=sol.info.method, route=str(sol.info.route), steps=sol.info.iterations,
                         factorization=sol.info.factorization or "-", ok=bool(sol.ok),
                         factorizations=getattr(sparse, "factorizations", -1),
                         column_solves=getattr(sparse, "column_solves", -1),
                         krylov_iterations=getattr(solver.cache.amg, "iterations", -1),
                         active_rows=int(np.sum(solver.cache.active)) if solver.cache.active is not None else -1,
                         **{f"res_{k}": float(v) for k, v in sol.residuals().items()}))
        N, m = unknowns(solver.problem), int(solver.problem.E.shape[0])
        del solver, sol
    out = _median(rows)
    out.update(unknowns=N, contact_rows=m, default_peak_gb=peak_gb())
    return out


# ------------------------------------------------------------------------------------------------ bonded

def bonded_system(problem):
    """K = [[S, G^T], [G, 0]] (CSC, sorted, every diagonal stored), its right-hand side [F; g], the blocks'
    sizes and G (the contact rows on the stacked free dofs x = [u_1; phi_1; u_2; ...])."""
    import scipy.sparse as sp

    from cvxcontact.backends.condensed import quasi_definite

    parts = [quasi_definite(b) for b in problem.blocks]
    E = problem.E
    G = sp.hstack([sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], S.shape[0] - b.Kuu.shape[0]))])
                   for b, (S, _) in zip(problem.blocks, parts)]).tocsr()
    G.data[np.abs(G.data) < 1e-12 * np.abs(G.data).max()] = 0.0
    G.eliminate_zeros()
    A = sp.block_diag([S for S, _ in parts], format="csr")
    m = G.shape[0]
    K = sp.bmat([[A, G.T], [G, sp.csr_matrix((m, m))]], format="coo")
    d = np.arange(K.shape[0])                                   # every diagonal entry stored (zeros too)
    K = sp.coo_matrix((np.concatenate([K.data, np.zeros(len(d))]), (np.concatenate([K.row, d]),
                                                                    np.concatenate([K.col, d]))), shape=K.shape)
    K = K.tocsc()                                               # sums the duplicates, keeps explicit zeros
    K.sort_indices()
    rhs = np.concatenate([F for _, F in parts] + [np.asarray(problem.g, dtype=float)])
    sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(problem.blocks, parts)]
    return K, rhs, A.tocsr(), G, sizes


def pardiso_bonded(K, rhs):
    from cvxcontact.backends.factor import PardisoSymmetric

    t0, c0 = time.perf_counter(), time.process_time()
    ps = PardisoSymmetric(K)
    ps.factor(K)
    z = ps.solve(rhs)
    t, c = time.perf_counter() - t0, time.process_time() - c0
    perturbed = ps.perturbed
    ps.release()
    return t, z, perturbed, c


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


def amg_bonded(problem, A, G, rhs, sizes, tol=1e-10):
    """Smoothed-aggregation AMG-preconditioned CG (MINRES with potentials) on the bonded system with its
    constraints eliminated (module docstring): (seconds, x, iterations, reduction seconds, residual) or None.

    The eliminated dofs keep their place as decoupled identity rows (zero right-hand side), so that every
    node keeps its three displacement dofs and the u block is handed to pyamg node-blocked (BSR 3 x 3: node
    aggregates; dof-wise aggregation was measured 10x slower); their rows of the near-null space are zero."""
    import pyamg
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = A.shape[0]
    t0 = time.perf_counter()
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
    t_red = time.perf_counter() - t0
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
    ml_u = pyamg.smoothed_aggregation_solver(Kuu, B=B, symmetry="symmetric", max_coarse=30)   # blocks of 6 dofs
    its = []
    cb = lambda _x: its.append(1)  # noqa: E731
    if len(p_idx) == 0:
        x_r, info = spla.cg(Kr, br, M=ml_u.aspreconditioner(cycle="V"), rtol=tol, atol=0.0, maxiter=2000,
                            callback=cb)
    else:
        Kpp = -Kr[p_idx][:, p_idx].tocsr()                       # the Gauss rows were negated (quasi-definite)
        ml_p = pyamg.smoothed_aggregation_solver(Kpp, symmetry="symmetric", max_coarse=500)
        Pu, Pp = ml_u.aspreconditioner(cycle="V"), ml_p.aspreconditioner(cycle="V")

        def prec(r):
            z = np.empty_like(r)
            z[u_idx] = Pu @ r[u_idx]
            z[p_idx] = Pp @ r[p_idx]
            return z

        M = spla.LinearOperator(Kr.shape, matvec=prec, dtype=float)
        x_r, rtol = None, tol
        for _ in range(4):           # MINRES stops on the preconditioned residual: tighten until the true one
            x_r, info = spla.minres(Kr, br, x0=x_r, M=M, rtol=rtol, maxiter=4000, callback=cb)
            if np.linalg.norm(br - Kr @ x_r) <= tol * np.linalg.norm(br):
                break
            rtol /= 30.0
    t, cpu = time.perf_counter() - t0, time.process_time() - c0
    residual = float(np.linalg.norm(br - Kr @ x_r) / np.linalg.norm(br))
    if residual > tol:
        return None
    return t, Tf @ x_r + x0, len(its), t_red, residual, cpu


def bonded_part(scene, n, condition, elastic, runs, pardiso=True):
    """Both yardsticks on the bonded system, AMG first (its peak memory is then its own), PARDISO if ``pardiso``."""
    import cvxcontact as cc

    solver = cc.ContactSolver(make(scene, n, condition, elastic))
    problem = solver.problem
    t0 = time.perf_counter()
    K, rhs, A, G, sizes = bonded_system(problem)
    nan = float("nan")
    out = dict(kkt_size=int(K.shape[0]), bonded_build_s=time.perf_counter() - t0, amg_s=nan, amg_cpu_s=nan,
               amg_iterations=-1, amg_reduce_s=nan, amg_vs_pardiso=nan, amg_residual=nan, pardiso_s=nan,
               pardiso_cpu_s=nan)
    x = None
    try:
        import pyamg  # noqa: F401
        res = [amg_bonded(problem, A, G, rhs, sizes) for _ in range(runs)]
        if all(r is not None for r in res):
            x = res[-1][1]
            out.update(amg_s=statistics.median(r[0] for r in res), amg_cpu_s=statistics.median(r[5] for r in res),
                       amg_iterations=res[-1][2], amg_reduce_s=res[-1][3], amg_residual=res[-1][4])
    except ImportError:
        pass
    out["amg_peak_gb"] = peak_gb()
    if pardiso:
        ts = [pardiso_bonded(K, rhs) for _ in range(runs)]
        z = ts[-1][1]
        out.update(pardiso_s=statistics.median(t[0] for t in ts), pardiso_cpu_s=statistics.median(t[3] for t in ts),
                   pardiso_perturbed=int(ts[-1][2]),
                   pardiso_residual=float(np.linalg.norm(K @ z - rhs) / np.linalg.norm(rhs)))
        if x is not None:
            nA = A.shape[0]
            out["amg_vs_pardiso"] = float(np.abs(x - z[:nA]).max() / np.abs(z[:nA]).max())
    out["bonded_peak_gb"] = peak_gb()
    return out


def _median(rows):
    out = {}
    for key, value in rows[0].items():
        vals = [r[key] for r in rows]
        out[key] = statistics.median(vals) if isinstance(value, float) else value
    return out


def _run(args):
    out = subprocess.run([sys.executable, __file__, "--one", json.dumps(args)], capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(f"{args}: exit {out.returncode}\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def case(scene, size, condition, elastic, runs, parts, pardiso_up_to=float("inf")):
    n = cells(scene, size, elastic)
    row = dict(scene=scene, n=n, condition=condition, elastic=elastic or scene == "sphere",
               load=" ".join(f"{x:.1f}" for x in os.getloadavg()))
    a = dict(scene=scene, n=n, condition=condition, elastic=elastic, runs=runs)
    if "default" in parts:
        row.update(_run(dict(a, part="default")))
    if "bonded" in parts:
        row.update(_run(dict(a, part="bonded", pardiso=bool(size <= pardiso_up_to))))
    nan = float("nan")
    yard = [row.get(k, nan) for k in ("pardiso_s", "amg_s")]
    row["bonded_s"] = min((y for y in yard if y == y), default=nan)
    d = row.get("default_s", nan)
    row["ratio_bonded"] = d / row["bonded_s"]
    row["ratio_pardiso"] = d / row.get("pardiso_s", nan)
    row["ratio_amg"] = d / row.get("amg_s", nan)
    return row


def growth(rows):
    lines = []
    for name in sorted({r["scene"] for r in rows}):
        sel = sorted((r for r in rows if r["scene"] == name and "unknowns" in r), key=lambda r: r["unknowns"])
        if len(sel) < 2:
            continue
        N = np.log([r["unknowns"] for r in sel])
        fits = {k: np.polyfit(N, np.log([r[k] for r in sel]), 1)[0]
                for k in ("default_s", "default_cpu_s", "pardiso_s", "amg_s", "amg_cpu_s", "default_peak_gb")
                if all(k in r and r[k] == r[k] and r[k] > 0 for r in sel)}
        lines.append(f"growth {name}: " + ", ".join(f"{k} N^{v:.2f}" for k, v in fits.items()))
    return lines


def summary(r) -> str:
    g = lambda k, f="{:.2f}": f.format(r[k]) if k in r else "-"  # noqa: E731
    return (f"{r['scene']} n={r['n']}: {g('unknowns', '{:,}')} unknowns, {g('contact_rows', '{}')} rows "
            f"[{r.get('method', '-')}/{r.get('factorization', '-')}, {r.get('route', '-')}, {g('steps', '{}')} "
            f"steps, {g('factorizations', '{}')} factorisations, {g('column_solves', '{}')} column solves, "
            f"{g('krylov_iterations', '{}')} Krylov iterations] "
            f"default {g('default_s')} s, CPU {g('default_cpu_s')} s (+ assembly {g('assembly_s')}; factorisation "
            f"{g('t_factorization')}, AMG setup {g('t_amg_setup')}, active set {g('t_active_set')}) ok={r.get('ok', '-')} "
            f"compl {g('res_complementarity', '{:.1e}')} | PARDISO {g('pardiso_s')} s (CPU {g('pardiso_cpu_s')}), AMG-CG "
            f"{g('amg_s')} s (CPU {g('amg_cpu_s')}) "
            f"({g('amg_iterations', '{}')} it., vs PARDISO {g('amg_vs_pardiso', '{:.1e}')}) | default/bonded "
            f"{g('ratio_bonded')} (/PARDISO {g('ratio_pardiso')}, /AMG {g('ratio_amg')}) | peak default "
            f"{g('default_peak_gb')} GB, bonded {g('bonded_peak_gb')} GB | load {r['load']}")


def markdown(rows) -> str:
    head = ("| scene | unknowns | contact rows | route | steps | default [s] (CPU) | assembly [s] | "
            "PARDISO bonded [s] (CPU) | AMG-CG bonded [s] (CPU, it.) | default / faster bonded | / PARDISO | / AMG | "
            "peak default [GB] | peak AMG / PARDISO [GB] | ok | load |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    f = lambda r, k, s="{:.2f}": s.format(r[k]) if k in r and r[k] == r[k] else "-"  # noqa: E731
    for r in rows:
        out.append(f"| {r['scene']} | {f(r, 'unknowns', '{:,}')} | {f(r, 'contact_rows', '{}')} | "
                   f"{r.get('method', '-')}/{r.get('factorization', '-')} | {f(r, 'steps', '{}')} | "
                   f"{f(r, 'default_s')} ({f(r, 'default_cpu_s')}) | {f(r, 'assembly_s')} | "
                   f"{f(r, 'pardiso_s')} ({f(r, 'pardiso_cpu_s')}) | {f(r, 'amg_s')} ({f(r, 'amg_cpu_s')}, "
                   f"{f(r, 'amg_iterations', '{}')}) | **{f(r, 'ratio_bonded')}** | {f(r, 'ratio_pardiso')} | "
                   f"{f(r, 'ratio_amg')} | {f(r, 'default_peak_gb')} | {f(r, 'amg_peak_gb')} / {f(r, 'bonded_peak_gb')} | "
                   f"{r.get('ok', '-')} | {r['load']} |")
    return "\n".join(out)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="*", default=[1e5, 5e5])
    p.add_argument("--scenes", nargs="*", default=list(SCENES), choices=SCENES)
    p.add_argument("--condition", default="sigma1", choices=("sigma1", "sigma2", "gamma3"))
    p.add_argument("--elastic", action="store_true", help="two_boxes: an aluminium upper box (no potentials)")
    p.add_argument("--parts", nargs="*", default=["default", "bonded"], choices=("default", "bonded"))
    p.add_argument("--runs", type=int, default=1)
    p.add_argument("--pardiso-up-to", type=float, default=float("inf"),
                   help="the PARDISO yardstick only for sizes up to this (it grows like N^2)")
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "bench3d.csv"))
    p.add_argument("--md", help="also write the table as Markdown to this file")
    p.add_argument("--append", action="store_true", help="append to the CSV instead of replacing it")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        if a["part"] == "default":
            print(json.dumps(default_part(a["scene"], a["n"], a["condition"], a["elastic"], a["runs"])))
        else:
            print(json.dumps(bonded_part(a["scene"], a["n"], a["condition"], a["elastic"], a["runs"], a["pardiso"])))
        return
    rows = []
    for scene in args.scenes:
        for size in args.sizes:
            r = case(scene, size, args.condition, args.elastic, args.runs, args.parts, args.pardiso_up_to)
            rows.append(r)
            print(summary(r), flush=True)
    for line in growth(rows):
        print(line)
    path = Path(args.csv)
    path.parent.mkdir(parents=True, exist_ok=True)
    old = []
    if args.append and path.exists():
        with open(path, newline="") as fh:
            old = list(csv.DictReader(fh))
    keys = list(dict.fromkeys(k for r in old + rows for k in r))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(old + rows)
    print("wrote", path)
    if args.md:
        Path(args.md).write_text(markdown(rows) + "\n")
        print("wrote", args.md)


if __name__ == "__main__":
    main()
