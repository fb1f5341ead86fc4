"""Exploration: an outer iteration for P1 "gamma3" rows on the mixed system, monotone in the dual energy (issue 33
item 1, items 2 and 3 of docs/explanation/gamma3-fast-route.md "What a route would need"). Not in the package.

The problem: min 1/2 x^T A x - F^T x over G x <= g, A the two bodies' stiffness (no row in it), G the m "gamma3"
rows (R on the contact dofs, m > d: the rows depend on each other). Its dual energy
theta(y) = min_x L(x, y) = -1/2 x(y)^T A x(y) - g^T y, x(y) = A^-1 (F - G^T y), is concave in y >= 0, with gradient
s(y) = G x(y) - g. Each outer step (a dual active-set step safeguarded by theta):

1. the candidate rows C = {z > 0} or {s > tol} (the primal-dual active set's rule, its constant infinite) of the
   last candidate (x_B, z of 3-4; at the start and after a face met before: the dual iterate's x(y), y);
2. an independent subset B of C: column-pivoted QR of C's rows on the contact dofs (weighted 1 + z / max z +
   s^+ / max s^+, so that the rows that carry force or penetrate most come first), cut 1e-10 of the first pivot;
3. the face: min energy over G_B x = g_B, solved exactly (PARDISO on the mixed system [[A, G_B^T], [G_B, 0]], the
   other rows decoupled; one analysis, a numeric factorisation per step, two refinement steps): x_B, y_B;
4. the forces on dependent rows without W: z >= 0 on the rows touching at x_B (|s_i| <= 1e-9 of the jump's
   scale) with R_T^T z = R_B^T y_B, by non-negative least squares (scipy's Lawson-Hanson, dense d x |T|);
5. certified (stop) where x_B is feasible (every row's s <= 1e-9 of the scale) and z represents the force (NNLS
   residual <= 1e-9 of it): then x_B, z satisfy the Karush-Kuhn-Tucker conditions exactly, whatever the faces
   visited;
6. otherwise the candidate y+ = z (>= 0) is accepted where theta(y+) > theta(y) (one solve with a factor of A,
   factorised once); else the exact maximiser of theta on the segment [y, y+] (theta is a concave quadratic on
   it: one more solve), and where that does not grow theta, the segment to max(y + alpha s, 0) (a projected
   gradient step, alpha = 1e3 (|y| + 1) / |s|, the segment's exact maximiser): theta never falls (it grows unless
   y maximises it already), so no dual point repeats, and a face met before hands the next set to the dual iterate.

That is ``--method dual`` (the default). Also measured:

* ``--method primal``: a primal active set on independent faces, monotone in the energy, every iterate feasible:
  from the bonded face at x = 0 (feasible where g >= 0), the step to the face's minimiser cut by the ratio test over
  every row (the blocking rows join the face, an independent subset by the QR); at a face's minimiser the forces by
  NNLS as in 4, certified as in 5, else the face shrunk to the NNLS forces' support (the residual
  rho = r - R_T^T z is orthogonal to their rows, so the smaller face's minimiser differs and the energy falls);
* ``--method primal-neutral``: the same, the face shrunk only to the touching rows rho does not open
  (R_j rho >= -1e-9 |rho| |R_j|): fewer rows re-join one by one;
* ``--method hybrid``: 6 dual steps, then primal-neutral from x = 0 on the last dual face.

Measured on two_boxes(n, "gamma3", True): the outer steps (face solves), whether they settle (certified) within
``--steps``, the answer against the condensed route's (cc.solve's default: its jump at every row, and the
displacements against the face of its closed rows P solved by the same PARDISO system), CPU seconds
(``time.process_time``: the outer iteration with every factorisation, QR and NNLS; the condensed route's solve; the
bonded AMG-CG yardstick's set-up and solve, benchmarks/harness.py ``amg_bonded`` on the same mesh's "sigma1" rows,
as bench_gamma3_scale.py --amg). Results: benchmarks/results/explore_gamma3_outer.md.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_outer.py \
        --n 8 12 16 24 32 40 [--method primal-neutral] [--steps 40]
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import nnls

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import amg_bonded, bonded_kkt, bonded_system, peak_gb, rel
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.factor import PardisoSymmetric

CUT = 1e-10        # rank cut of the QR, relative to its first pivot
TOUCH = 1e-9       # touching / feasible, relative to the jump's scale
REPRESENT = 1e-9   # NNLS residual, relative to the force


class Mixed:
    """The mixed system [[A, G^T], [G, D]] of fixed pattern: rows in B closed (G_i, D_ii = 0), the others
    decoupled (G_i = 0, D_ii = -1: y_i = 0). One PARDISO analysis, a numeric factorisation per set."""

    def __init__(self, A, G):
        self.N, self.m = A.shape[0], G.shape[0]
        Ac, Gc = A.tocoo(), G.tocoo()
        N, m = self.N, self.m
        self.gk = len(Gc.data)
        self.rows = np.concatenate([Ac.row, Gc.row + N, Gc.col, np.arange(N + m)])
        self.cols = np.concatenate([Ac.col, Gc.col, Gc.row + N, np.arange(N + m)])
        self.base = np.concatenate([Ac.data, Gc.data, Gc.data, np.zeros(N + m)])
        self.grow = Gc.row
        self.ps = None

    def matrix(self, closed: np.ndarray) -> sp.csc_matrix:
        data = self.base.copy()
        nA, k, N = len(data) - 2 * self.gk - self.N - self.m, self.gk, self.N
        off = ~closed[self.grow]
        data[nA:nA + k][off] = 0.0
        data[nA + k:nA + 2 * k][off] = 0.0
        diag = data[nA + 2 * k:]
        diag[N:][~closed] = -1.0
        K = sp.coo_matrix((data, (self.rows, self.cols)), shape=(N + self.m, N + self.m)).tocsc()
        K.sort_indices()
        return K

    def solve(self, closed, F, g):
        """(x, y) of the closed rows' face. The analysis (its scaling and matching) is made on the first set's
        values; a later set's factorisation on it can leave a residual far above rounding after the refinement
        (measured on explore_gamma3_alm_amg's n = 24 answer face: 1.1e-2 of the jump's scale of penetration),
        so a residual above 1e-10 of the right-hand side makes a new analysis on this set's values (counted in
        ``analyses``)."""
        K = self.matrix(closed)
        rhs = np.concatenate([F, np.where(closed, g, 0.0)])
        for fresh in (False, True):
            if self.ps is None or fresh:
                self.ps = PardisoSymmetric(K)
                self.analyses = getattr(self, "analyses", 0) + 1
            self.ps.factor(K)
            z = self.ps.solve(rhs)
            for _ in range(2):
                z += self.ps.solve(rhs - K @ z)
            if np.abs(rhs - K @ z).max() <= 1e-10 * np.abs(rhs).max():
                break
        return z[:self.N], z[self.N:]


def jump_scale(G, *xs_and_g) -> float:
    """The rows' scale: the largest |x| over the vectors given (and |g|) times the largest row sum |G_i|_1."""
    *xs, g = xs_and_g
    return max(max(np.abs(v).max() for v in xs) * np.abs(G).sum(axis=1).max(), np.abs(g).max(), 1e-300)


def independent(Rc: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Positions (into Rc's rows) of an independent subset: column-pivoted QR of (weights * Rc)^T."""
    if Rc.shape[0] == 0:
        return np.zeros(0, dtype=int)
    _, Rq, piv = sla.qr((Rc * weights[:, None]).T, mode="economic", pivoting=True, check_finite=False)
    d = np.abs(np.diag(Rq))
    return np.sort(piv[:int(np.sum(d > CUT * d[0]))])


def outer(A, F, G, g, steps: int, log=print, face: bool = False):
    """The outer iteration; returns (x, z, steps taken, settled, per-step records)."""
    cols = np.flatnonzero(np.diff(G.tocsc().indptr))
    R = G.tocsc()[:, cols].tocsr()
    mixed = Mixed(A, G)
    Aopen = sp.csc_matrix(A)
    Aopen.sort_indices()
    open_ = PardisoSymmetric(Aopen).factor(Aopen)

    def xof(rhs):
        x = open_.solve(rhs)
        return x + open_.solve(rhs - A @ x)

    def theta(x, y):
        return -0.5 * x @ (A @ x) - g @ y

    y = np.zeros(G.shape[0])
    x = xof(F)
    scale = max(np.abs(G @ x).max(), np.abs(g).max(), 1e-300)
    th = theta(x, y)
    records = []
    xB = zfull = None
    gen_x, gen_z = x, y          # the set generator: the last candidate's (x_B, z), or the dual iterate's
    seen = set()
    for k in range(1, steps + 1):
        s = G @ gen_x - g
        C = np.flatnonzero((gen_z > 0) | (s > TOUCH * scale))
        zmax, smax = max(gen_z.max(), 1e-300), max(s.max(), 1e-300)
        w = 1.0 + gen_z[C] / zmax + np.maximum(s[C], 0) / smax
        c0 = time.process_time()
        B = C[independent(R[C].toarray(), w)]
        c1 = time.process_time()
        key = hash(B.tobytes())
        repeated = key in seen
        seen.add(key)
        closed = np.zeros(G.shape[0], bool)
        closed[B] = True
        xB, yB = mixed.solve(closed, F, g)
        c2 = time.process_time()
        sB = G @ xB - g
        scale = max(np.abs(G @ xB).max(), np.abs(g).max(), 1e-300)
        T = np.flatnonzero(np.abs(sB) <= TOUCH * scale)
        r = R[B].T @ yB[B]
        zT, res = nnls(R[T].T.toarray(), r, maxiter=50 * max(len(T), 1))
        zfull = np.zeros(G.shape[0])
        zfull[T] = zT
        rep = res / max(np.linalg.norm(r), 1e-300)
        viol = max(sB.max(), 0.0) / scale
        rec = {"step": k, "C": len(C), "B": len(B), "T": len(T), "viol": viol, "rep": rep,
               "negB": int(np.sum(yB[B] < 0)), "repeated": repeated, "qr_s": c1 - c0, "face_s": c2 - c1,
               "nnls_s": time.process_time() - c2}
        if face:
            rec["face"] = B
        if viol <= TOUCH and rep <= REPRESENT:
            rec.update(move="certified", theta=th)
            records.append(rec)
            log(rec)
            return xB, zfull, k, True, records
        xp = xof(F - G.T @ zfull)
        thp = theta(xp, zfull)
        if thp > th:
            y, x, th, move = zfull, xp, thp, "accepted"
        else:
            d, dx = zfull - y, xp - x
            Adx = A @ dx
            curv = dx @ Adx
            slope = -(x @ Adx) - d @ g
            t = min(1.0, slope / curv) if curv > 0 and slope > 0 else 0.0
            if t > 0 and theta(x + t * dx, y + t * d) > th:
                y, x, move = y + t * d, x + t * dx, f"segment t={t:.2g}"
            else:
                s = G @ x - g
                alpha = 1e3 * (np.linalg.norm(y) + 1.0) / max(np.linalg.norm(s), 1e-300)
                d = np.maximum(y + alpha * s, 0.0) - y
                dx = -xof(G.T @ d)
                Adx = A @ dx
                curv, slope = dx @ Adx, -(x @ Adx) - d @ g
                t = min(1.0, slope / curv) if curv > 0 and slope > 0 else 0.0
                y, x, move = y + t * d, x + t * dx, f"projected t={t:.2g}"
            th = theta(x, y)
        # the next set: from the candidate (the primal-dual step), unless its face was met before (a cycle): then
        # from the dual iterate, which theta orders
        gen_x, gen_z = (x, y) if repeated else (xB, zfull)
        rec.update(move=move, theta=th)
        records.append(rec)
        log(rec)
    return xB, zfull, steps, False, records


def hybrid(A, F, G, g, steps: int, log=print, dual_steps: int = 6):
    """``dual_steps`` of the dual outer iteration; where they do not settle, the primal active set (keeping the
    neutral rows) started at x = 0 on the last dual face (x = 0 lies on every face where g = 0 there)."""
    x, z, k, settled, recs = outer(A, F, G, g, dual_steps, log=log, face=True)
    if settled:
        return x, z, k, True, recs
    B = recs[-1]["face"]
    if np.any(g[B] != 0):
        B = None
    x, z, k2, settled, recs2 = primal(A, F, G, g, steps - k, log=log, keep_neutral=True, start=B)
    return x, z, k + k2, settled, recs + recs2


def primal(A, F, G, g, steps: int, log=print, keep_neutral: bool = False, start=None):
    """A primal active set on independent faces, monotone in the energy: from the bonded face (x = 0 is feasible
    for g >= 0), each face solved exactly, the step to its minimiser cut by the ratio test over every row (the
    rows that block join the face, an independent subset by the QR), and at a face's minimiser the forces
    represented by NNLS on the touching rows: certified if they are, else the face shrunk to the support of the
    NNLS forces (the residual rho = r - R_T^T z is orthogonal to their rows, so the new face's minimiser differs
    and the energy falls). Returns (x, z, face solves, settled, records)."""
    cols = np.flatnonzero(np.diff(G.tocsc().indptr))
    R = G.tocsc()[:, cols].tocsr()
    m = G.shape[0]
    mixed = Mixed(A, G)
    x = np.zeros(A.shape[0])
    if np.any(g < 0):
        raise ValueError("the primal start x = 0 needs g >= 0")
    W = np.arange(m)[independent(R.toarray(), np.ones(m))] if start is None else np.sort(start)
    records = []
    z = np.zeros(m)

    def energy(v):
        return 0.5 * v @ (A @ v) - F @ v

    for k in range(1, steps + 1):
        closed = np.zeros(m, bool)
        closed[W] = True
        xW, yW = mixed.solve(closed, F, g)
        p = xW - x
        Gp = G @ p
        sx = G @ x - g
        scale = jump_scale(G, xW, x, g)
        cand = (~closed) & (Gp > TOUCH * scale)
        t_i = np.full(m, np.inf)
        t_i[cand] = np.maximum(-sx[cand], 0.0) / Gp[cand]
        t = min(1.0, t_i.min(initial=np.inf))
        x = x + t * p
        rec = {"step": k, "W": len(W), "t": t}
        if t < 1.0:
            block = np.flatnonzero(t_i <= t + 1e-12 * max(t, 1e-300) + 1e-14)
            U = np.concatenate([W, block])
            wts = np.concatenate([np.full(len(W), 2.0), np.ones(len(block))])
            W = np.sort(U[independent(R[U].toarray(), wts)])
            rec.update(move=f"blocked +{len(block)}", energy=energy(x))
            records.append(rec)
            log(rec)
            continue
        s = G @ x - g
        T = np.flatnonzero(np.abs(s) <= TOUCH * scale)
        r = R[W].T @ yW[W]
        zT, res = nnls(R[T].T.toarray(), r, maxiter=50 * max(len(T), 1))
        z = np.zeros(m)
        z[T] = zT
        rep = res / max(np.linalg.norm(r), 1e-300)
        rec.update(T=len(T), rep=rep, viol=max(s.max(), 0.0) / scale)
        if rep <= REPRESENT and s.max() <= TOUCH * scale:
            rec.update(move="certified", energy=energy(x))
            records.append(rec)
            log(rec)
            return x, z, k, True, records
        if keep_neutral:      # keep every touching row the residual does not open (R_j rho = 0), not z's alone
            rho = r - R[T].T @ zT
            Rr = R[T] @ rho
            S = T[Rr >= -1e-9 * np.linalg.norm(rho) * np.sqrt(np.asarray(R[T].multiply(R[T]).sum(axis=1)).ravel())]
        else:
            S = np.flatnonzero(z > 0)
        W = np.sort(S[independent(R[S].toarray(), 1.0 + z[S] / max(z.max(), 1e-300))])
        rec.update(move=f"shrunk to {len(W)}", energy=energy(x))
        records.append(rec)
        log(rec)
    return x, z, steps, False, records


def run(n: int, steps: int, method: str = "dual") -> dict:
    scene = two_boxes(n, "gamma3", True)
    s = cc.ContactSolver(scene)
    c0 = time.process_time()
    sol = s.solve()
    cpu_cond = time.process_time() - c0
    p = s.problem
    P = np.flatnonzero(s.cache.active)
    A, F, G, g = mixed_data(p)
    N = A.shape[0]
    cj, unit = np.asarray(sol.contact.jump), p.units.displacement
    del s, sol, p                # the condensed route's factors freed before the outer iteration (memory)
    gc.collect()
    c0 = time.process_time()
    x, _z, k, settled, recs = METHODS[method](A, F, G, g, steps, log=lambda r: print("  ", r, flush=True))
    cpu = time.process_time() - c0
    jump = G @ x * unit
    closed = np.zeros(G.shape[0], bool)
    closed[P] = True
    xref, _ = Mixed(A, G).solve(closed, F, g)
    s1 = cc.ContactSolver(two_boxes(n, "sigma1", True))
    p1 = s1.problem
    _, rhs1, A1, G1, sizes1 = bonded_system(p1)
    yard = amg_bonded(p1, A1, G1, rhs1, sizes1)
    out = {"n": n, "N": N, "m": G.shape[0], "d": int(np.sum(np.diff(G.tocsc().indptr) > 0)), "P": len(P),
           "steps": k, "settled": settled, "jump_rel": rel(jump, cj), "x_rel": rel(x, xref), "method": method,
           "moves": " ".join(r["move"][0] for r in recs), "cpu": cpu, "cpu_cond": cpu_cond,
           "yard_it": yard[2] if yard else None, "yard_cpu": yard[5] if yard else None, "peak_gb": peak_gb()}
    print(out, flush=True)
    return out


def mixed_data(p):
    """(A, F, G, g) of a DiscreteProblem's "gamma3" rows: A, F from the harness; G on every row (none dropped:
    the jump compares row by row)."""
    rows = [sp.csr_matrix(p.E @ b.jump) for b in p.blocks]
    _, rhs, A, _, _ = bonded_kkt(p.blocks, rows, p.g)
    G = sp.hstack([sp.hstack([r, sp.csr_matrix((r.shape[0], blk - r.shape[1]))])
                   for r, blk in zip(rows, [b.shape[0] for b in _diag_blocks(A, p)])]).tocsr()
    G.data[np.abs(G.data) < 1e-12 * np.abs(G.data).max()] = 0.0
    G.eliminate_zeros()
    return A, rhs[:A.shape[0]], G, np.asarray(p.g, float)


def _diag_blocks(A, p):
    """Each body's block of A (its free dofs: u, and phi where there are potentials), in order."""
    from cvxcontact.backends.condensed import quasi_definite

    return [quasi_definite(b)[0] for b in p.blocks]


METHODS = {"dual": outer, "primal": primal,
           "primal-neutral": lambda *a, **k: primal(*a, keep_neutral=True, **k), "hybrid": hybrid}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[8, 12, 16])
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--method", choices=tuple(METHODS), default="dual")
    a = ap.parse_args()
    for n in a.n:
        print(f"n = {n}", flush=True)
        run(n, a.steps, a.method)


if __name__ == "__main__":
    main()
