"""Exploration: the augmented Lagrangian of benchmarks/explore_gamma3_alm.py for "gamma3" with its Newton steps
solved by AMG-preconditioned CG (one hierarchy per geometry, loose tolerances while the active set changes) and
warm-started from the "sigma1" AMG route's answer on the same mesh (issue 33 item 1, items (a) and (b) of
benchmarks/results/explore_gamma3_alm.md; docs/explanation/gamma3-fast-route.md). Not in the package.

(a) The Newton systems H = A + rho G_I^T G_I (A the two bodies' stiffness, G_I the rows active in the
subproblem) are solved by CG, preconditioned as the AMG route's sets (cvxcontact.backends.amg
``KrylovContact._corrected``): one smoothed-aggregation hierarchy of A (node-blocked 3 x 3, each body's six
rigid-body modes; it holds no row, so it serves every active set and every rho: built once per geometry), its
V-cycle V corrected on the contact dofs J (the columns of G, where H differs from A) by an exact solve with
H_JJ (SuperLU, once per active set and rho): z_J = H_JJ^-1 r_J, z += V (r - H z), z_J += H_JJ^-1 (r - H z)_J
(symmetric positive definite: CG). Each step is solved to ``--loose`` (1e-2) relative residual while the set
changes and to loose^3 on a step whose set repeats the last one's (a Newton step only moves the iterate: the
exactness is the finish's, below). ``--hierarchy penalised``: the hierarchy of A + rho_0 G^T G (every row,
the first rho) instead.

(b) The start: the "sigma1" AMG route (cvxcontact.backends.amg.KrylovContact, as method "amg" runs it) on the
same mesh. Its rows (one per vertex of the upper face, the slave side) are rows of the overlay's: each is
matched to the "gamma3" row with the same columns and proportional coefficients, y_0 its force rescaled
(G_j = c G1_i: y_j = y1_i / c), x_0 its displacements; then A x_0 - F + G^T y_0 = 0 to the route's 1e-10, so
the first subproblem starts at its stationary point but for the overlay rows the slave vertices miss.

The finish is explore_gamma3_alm's: the exact face (PARDISO on the mixed system), the forces by NNLS on the
touching rows, certified by the Karush-Kuhn-Tucker conditions (every row feasible, the face's force represented
by z >= 0): a certified answer is THE answer, whatever the Newton steps' accuracy.

One run per size: the condensed route (cc.solve's default; ``--no-condensed`` above memory), the warm start,
the augmented Lagrangian, and one bonded AMG-CG solve of the same mesh (harness.amg_bonded, the yardstick), CPU
seconds (``time.process_time``) of each part; the certified answer against the condensed route's: the jump at
every row, and the displacements against its closed rows' face (the same PARDISO system).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_alm_amg.py \\
        --n 16 24 32 40 [--loose 1e-2] [--hierarchy bodies|penalised] [--cold] [--steps 300]
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import explore_gamma3_alm as alm_mod
import explore_gamma3_outer as outer_mod
from explore_gamma3_outer import Mixed
from harness import amg_bonded, bonded_system, peak_gb, rel
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.amg import KrylovContact, rigid_modes
from cvxcontact.backends.condensed import quasi_definite_rhs
from cvxcontact.backends.krylov import seeded
from cvxcontact.backends.signorini import cheap_start


def body_modes(problem) -> np.ndarray:
    """Each body's six rigid-body modes on its free u dofs, about its own centre, stacked (the AMG route's)."""
    return np.vstack([rigid_modes(problem.meshes[k].points, problem.systems[k].Tu)
                      for k in range(len(problem.blocks))])


class AMGNewton:
    """The Newton systems A + rho G_I^T G_I by CG with one hierarchy and the contact dofs' exact correction
    (module docstring (a)). Counts CG iterations per solve (``its``)."""

    def __init__(self, A, G, rho: float, modes: np.ndarray, penalised: bool = False):
        import pyamg

        self.A, self.G, self.rho = A.tocsr(), G.tocsr(), rho
        self.J = np.unique(self.G.indices)
        self.AJ = self.A[self.J].tocsr()                   # A[J, :]
        self.GJ = self.G[:, self.J].tocsr()
        H0 = self.A + (rho * (self.G.T @ self.G) if penalised else 0.0)
        H0 = sp.csr_matrix(H0).tobsr(blocksize=(3, 3))
        with seeded():
            self.ml = pyamg.smoothed_aggregation_solver(H0, B=modes, symmetry="symmetric", max_coarse=30)
        self.V = self.ml.aspreconditioner(cycle="V")
        self.its: list[int] = []
        self.levels = len(self.ml.levels)
        self._key = None

    def solve(self, active, rhs, rtol):
        Ga = self.G[np.flatnonzero(active)]
        rho, A, J = self.rho, self.A, self.J
        key = (active.tobytes(), rho)
        if self._key != key:
            GaJ = self.GJ[np.flatnonzero(active)]
            HJ = (self.AJ[:, J] + rho * (GaJ.T @ GaJ)).tocsc()
            self._lu = spla.splu(HJ)
            self._key = key
        lu = self._lu

        def H(v):
            return A @ v + rho * (Ga.T @ (Ga @ v))

        def prec(r):
            z = np.zeros_like(r)
            z[J] = lu.solve(r[J])
            z += self.V @ (r - H(z))
            z[J] += lu.solve((r - H(z))[J])
            return z

        n = A.shape[0]
        its = []
        Hop = spla.LinearOperator((n, n), matvec=H, dtype=float)
        M = spla.LinearOperator((n, n), matvec=prec, dtype=float)
        dx, _ = spla.cg(Hop, rhs, M=M, rtol=rtol, atol=0.0, maxiter=2000, callback=lambda _x: its.append(1))
        self.its.append(len(its))
        return dx


def sigma1_start(n: int, G: sp.csr_matrix):
    """(x_0, y_0, record) from the "sigma1" AMG route on the same mesh (module docstring (b))."""
    c0 = time.process_time()
    p1 = cc.ContactSolver(two_boxes(n, "sigma1", True)).problem
    c1 = time.process_time()
    kc = KrylovContact(p1)
    rhs = np.concatenate([quasi_definite_rhs(b) for b in p1.blocks])
    start = cheap_start(p1)
    out = kc.solve(rhs, p1.g, start if start is not None else ~p1.held_rows)
    c2 = time.process_time()
    if out is None:
        raise RuntimeError("the sigma1 AMG route declined")
    u, _phi, y1, _active, steps = out
    x0 = np.concatenate(u)
    G1 = kc.G.tocsr().copy()
    G1.data[np.abs(G1.data) < 1e-12 * np.abs(G1.data).max()] = 0.0
    G1.eliminate_zeros()
    rows = {}
    for j in range(G.shape[0]):
        lo, hi = G.indptr[j], G.indptr[j + 1]
        if hi > lo:
            rows.setdefault(G.indices[lo:hi].tobytes(), []).append(j)
    y0 = np.zeros(G.shape[0])
    missed = 0
    for i in np.flatnonzero(y1):
        lo, hi = G1.indptr[i], G1.indptr[i + 1]
        v = G1.data[lo:hi]
        hit = None
        for j in rows.get(G1.indices[lo:hi].tobytes(), []):
            w = G.data[G.indptr[j]:G.indptr[j + 1]]
            c = (w @ v) / (v @ v)
            if np.abs(w - c * v).max() <= 1e-10 * np.abs(w).max() and c > 0:
                hit = (j, c)
                break
        if hit is None:
            missed += 1
        else:
            y0[hit[0]] += y1[i] / hit[1]
    rec = {"sigma1_cpu": c2 - c1, "sigma1_assembly_cpu": c1 - c0, "sigma1_steps": steps,
           "sigma1_its": kc.iterations, "sigma1_rows_with_force": int(np.sum(y1 > 0)), "unmatched": missed}
    return x0, y0, rec


def run(n: int, a) -> dict:
    out = {"n": n}
    scene = two_boxes(n, "gamma3", True)
    s = cc.ContactSolver(scene)
    p = s.problem
    A, F, G, g = outer_mod.mixed_data(p)
    unit = p.units.displacement
    out.update(N=A.shape[0], m=G.shape[0], d=int(np.sum(np.diff(G.tocsc().indptr) > 0)))
    if a.condensed:
        c0 = time.process_time()
        sol = s.solve()
        out["condensed_cpu"] = time.process_time() - c0
        P = np.flatnonzero(s.cache.active)
        cj = np.asarray(sol.contact.jump)
        del sol
    modes = body_modes(p)
    del s, p
    gc.collect()
    print("  sizes", out, flush=True)
    start = None
    if not a.cold:
        x0, y0, rec = sigma1_start(n, G)
        out.update(rec)
        r0 = A @ x0 - F + G.T @ y0
        out["start_stationarity"] = float(np.linalg.norm(r0) / np.linalg.norm(F))
        sc = outer_mod.jump_scale(G, x0, g)
        out["start_violation"] = float(max((G @ x0 - g).max(), 0.0) / sc)
        start = (x0, y0)
        print("  start", rec, {k: out[k] for k in ("start_stationarity", "start_violation")}, flush=True)
    solver = {}

    def factory(A_, G_, rho):
        solver["s"] = AMGNewton(A_, G_, rho, modes, penalised=a.hierarchy == "penalised")
        return solver["s"]

    ref = None
    if a.diagnose:         # each update's band against the condensed route's face (its answer), as explore_gamma3_alm
        closed = np.zeros(G.shape[0], bool)
        closed[P] = True
        ref = (Mixed(A, G).solve(closed, F, g)[0], np.zeros(G.shape[0]))
    cpu = {}
    c0 = time.process_time()
    x, _z, _k, settled, recs = alm_mod.alm(
        A, F, G, g, a.steps, log=lambda r: print("   ", r, flush=True), beta=a.beta, tau=a.tau, retries=a.retries,
        start=start, newton_solver=None if a.direct else factory, loose=None if a.direct else a.loose, cpu=cpu,
        armijo=a.armijo, ref=ref)
    out["alm_cpu"] = time.process_time() - c0
    out.update({f"cpu_{q}": v for q, v in cpu.items()})
    its = solver["s"].its if "s" in solver else []
    upd = list(recs)
    out.update(settled=settled, newton=upd[-1]["newton"] if upd else 0, updates=len(upd),
               faces=sum(len(r.get("finish", [])) for r in upd), cg_its=int(sum(its)),
               inner=[r["inner"] for r in upd], levels=solver["s"].levels if "s" in solver else None)
    out["its_per_step"] = its
    if a.condensed:
        out["jump_rel"] = rel(G @ x * unit, cj)
        closed = np.zeros(G.shape[0], bool)
        closed[P] = True
        xref, _ = Mixed(A, G).solve(closed, F, g)
        out["u_rel"] = rel(x, xref)
        del xref
    del A, G
    gc.collect()
    p1 = cc.ContactSolver(two_boxes(n, "sigma1", True)).problem
    _, rhs1, A1, G1, sizes1 = bonded_system(p1)
    yard = amg_bonded(p1, A1, G1, rhs1, sizes1)
    out.update(yard_its=yard[2] if yard else None, yard_cpu=yard[5] if yard else None, peak_gb=peak_gb())
    total = out["alm_cpu"] + out.get("sigma1_cpu", 0.0)
    out["route_cpu"] = total
    if yard:
        out["route/yard"] = total / yard[5]
    if a.condensed:
        out["route/condensed"] = total / out["condensed_cpu"]
    print(out, flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[8, 12, 16])
    ap.add_argument("--steps", type=int, default=300, help="most Newton steps")
    ap.add_argument("--beta", type=float, default=alm_mod.BETA)
    ap.add_argument("--tau", type=float, default=alm_mod.TAU)
    ap.add_argument("--retries", type=int, default=3)
    ap.add_argument("--loose", type=float, default=1e-2, help="CG tolerance while the active set changes")
    ap.add_argument("--hierarchy", choices=("bodies", "penalised"), default="bodies")
    ap.add_argument("--cold", action="store_true", help="start from x = 0, y = 0 (not the sigma1 answer)")
    ap.add_argument("--direct", action="store_true", help="Newton steps by PARDISO (explore_gamma3_alm's)")
    ap.add_argument("--armijo", action="store_true", help="full Newton steps where Armijo holds (else exact)")
    ap.add_argument("--diagnose", action="store_true", help="each update's band against the condensed answer")
    ap.add_argument("--no-condensed", dest="condensed", action="store_false")
    a = ap.parse_args()
    for n in a.n:
        print(f"n = {n}", flush=True)
        run(n, a)


if __name__ == "__main__":
    main()
