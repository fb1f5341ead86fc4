"""Exploration: "gamma3" rows on the mixed system by an augmented Lagrangian whose subproblems a semismooth Newton
method solves (monotone in each subproblem's energy), finished on one exact face (issue 33 item 1; the next step
of benchmarks/explore_gamma3_outer.py, docs/explanation/gamma3-fast-route.md). Not in the package.

The problem: min f(x) = 1/2 x^T A x - F^T x over G x <= g (A the two bodies' stiffness, no row in it; G the m
"gamma3" rows, m > d contact dofs: dependent rows, so the multipliers are not unique and the active-set methods of
explore_gamma3_outer.py cycle or swing). The augmented Lagrangian (a proximal point method on the dual) makes each
subproblem's multiplier unique whatever the rows' dependence:

    phi_y(x) = f(x) + 1/(2 rho) |max(0, y + rho (G x - g))|^2,       y <- max(0, y + rho (G x - g)) at its minimiser.

phi_y is convex, piecewise quadratic and C^1, so a semismooth Newton step on its gradient A x - F + G^T lam(x)
(lam = max(0, y + rho s), s = G x - g), the generalised Hessian A + rho G_I^T G_I (I = {y + rho s >= 0}, the kinks
taken as active, so that the first step from x = 0 is the bonded face's: symmetric positive definite, no saddle
point, one fixed pattern: one analysis), followed by the exact line search on phi_y (piecewise quadratic in t: its
derivative is monotone, root by safeguarded Newton), decreases phi_y monotonically; a subproblem ends on a full step
that keeps I, or once its gradient is below ``eta`` (0.1) of the update's G^T (lam - y). A descent method cannot
cycle: this is the "semismooth step with a monotone energy guard". rho = ``--beta`` times the median diagonal of A
on the contact dofs over the median |G_i|^2, times ``--grow`` (10) after an update that does not shrink the
multipliers' change fourfold (``--always``: after every update).

The finish (exactness does not come from the augmented Lagrangian's limit): after each multiplier update, the rows
T = {y+_i > 0 or s_i >= -tau} (tau = ``--tau`` times the update's size |y+ - y|_inf / rho, the multiplier's change
read as a distance) with an independent subset B by column-pivoted QR (weighted by y+), the face G_B x = g_B solved
exactly (PARDISO on the mixed system, explore_gamma3_outer.Mixed), and the certificate: every row feasible to 1e-9
of the jump's scale, the face's force R_B^T y_B represented by z >= 0 on the rows touching there (the package's warm
Lawson-Hanson, backends.cuts.nnls_warm, started from y+) to 1e-9 of its norm. Certified (x_B, z) satisfy the
Karush-Kuhn-Tucker conditions exactly, so x_B is THE answer (f strictly convex): no accepted answer rests on the
augmented Lagrangian's accuracy. Not certified: up to ``--retries`` more faces (a face that penetrates takes the
penetrating rows; one whose force NNLS does not represent keeps the touching rows its residual does not open), then
the iteration continues (a finish is tried again only when T changes). ``--diagnose``: a certified run, then the same
run comparing each update's T with the answer's touching rows (``ref``).

Counted: Newton steps (one SPD solve each: on an AMG route a CG solve on A + rho G_I^T G_I), multiplier updates,
finishes tried (one exact face solve each). CPU seconds (``time.process_time``) split into the Newton solves
(PARDISO, Cholesky-like on the SPD matrix), the finishes' QR, face solves and NNLS.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_alm.py \
        --n 8 12 16 24 32 [--beta 1e3] [--tau 1] [--retries 3] [--steps 200]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import explore_gamma3_outer as outer_mod
from explore_gamma3_outer import REPRESENT, TOUCH, Mixed, independent, jump_scale
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.cuts import nnls_warm
from cvxcontact.backends.factor import PardisoSymmetric

BETA = 1e3       # rho = BETA * median diag(A) on the contact dofs / median |G_i|^2
VERBOSE = False
TAU = 1.0        # the finish's touching band, in units of the last multiplier update's size / rho


class Hessian:
    """A + rho G^T diag(a) G on the fixed pattern of A + G^T G (every row's outer product kept, zeros too):
    one PARDISO analysis, a numeric factorisation per active set."""

    def __init__(self, A, G, rho: float):
        Ac, Gr = A.tocoo(), G.tocsr()
        N, m = A.shape[0], G.shape[0]
        ri, ci, vi = [], [], []
        for i in range(m):        # each row's outer product (at most 18 x 18 entries: a benchmark's set-up)
            lo, hi = Gr.indptr[i], Gr.indptr[i + 1]
            c, v = Gr.indices[lo:hi], Gr.data[lo:hi]
            ri.append(np.repeat(c, len(c)))
            ci.append(np.tile(c, len(c)))
            vi.append(np.outer(v, v).ravel())
        self.owner = np.repeat(np.arange(m), [len(r) for r in ri])
        self.rows = np.concatenate([Ac.row, np.concatenate(ri), np.arange(N)])
        self.cols = np.concatenate([Ac.col, np.concatenate(ci), np.arange(N)])
        self.vA, self.vG = Ac.data, np.concatenate(vi)
        self.N, self.ps, self.rho = N, None, rho

    def matrix(self, active: np.ndarray) -> sp.csc_matrix:
        data = np.concatenate([self.vA, np.where(active[self.owner], self.rho * self.vG, 0.0), np.zeros(self.N)])
        H = sp.coo_matrix((data, (self.rows, self.cols)), shape=(self.N, self.N)).tocsc()   # keeps the zeros
        H.sort_indices()
        return H

    def solve(self, active, rhs, rtol=None):
        """The step for the rows ``active``; ``rtol`` (a Krylov solve's tolerance) is ignored: a direct solve."""
        H = self.matrix(active)
        if self.ps is None:
            self.ps = PardisoSymmetric(H)
        self.ps.factor(H)
        x = self.ps.solve(rhs)
        for _ in range(2):
            x += self.ps.solve(rhs - H @ x)
        return x


def line_search(a, b, q, c, rho, t=1.0):
    """The exact minimiser over t >= 0 of phi(x + t dx) - phi(x): its derivative b + a t + sum_i q_i max(0, c_i +
    rho q_i t) (a = dx^T A dx > 0, b = dx^T (A x - F), q = G dx, c = y + rho s) is increasing and piecewise linear;
    safeguarded Newton from ``t`` on a bracket."""
    def dphi(t):
        lam = np.maximum(0.0, c + rho * q * t)
        return b + a * t + q @ lam, a + rho * np.sum(q[lam > 0] ** 2)
    lo, hi = 0.0, None
    for _ in range(200):
        d, h = dphi(t)
        if abs(d) <= 1e-14 * (abs(b) + a * t + 1e-300):
            return t
        if d > 0:
            hi = t
        else:
            lo = t
        tn = t - d / h
        if hi is None:
            t = max(tn, 2 * t)
        elif not lo < tn < hi:
            t = 0.5 * (lo + hi)
        else:
            t = tn
    return t


def alm(A, F, G, g, steps: int, log=print, beta: float = BETA, tau: float = TAU, eta: float = 0.1,
        grow: float = 10.0, retries: int = 3, always: bool = False, ref=None, start=None, newton_solver=None,
        loose: float | None = None, cpu=None, armijo: bool = False):
    """The augmented Lagrangian with semismooth Newton subproblems and the exact finish (module docstring).
    ``start``: (x, y) to start from (default x = 0, y = 0); ``newton_solver(A, G, rho)``: the Newton steps'
    solver, with ``.solve(active, rhs, rtol)`` and a writable ``.rho`` (default :class:`Hessian`, PARDISO);
    ``loose``: the steps' tolerance while the active set changes (tightened to ``loose**3`` on a step whose set
    repeats the last one's; None: every step exact, a direct solver's); ``cpu``: a dict the CPU seconds of the
    parts are added to (also logged); ``armijo``: a Newton step is taken whole where it decreases phi by 1e-4 of
    its slope's prediction (Armijo), the exact line search only where it does not. Returns (x, z, Newton steps +
    face solves, certified, records)."""
    m = G.shape[0]
    cols = np.flatnonzero(np.diff(G.tocsc().indptr))
    R = G.tocsc()[:, cols].tocsr()
    gn2 = np.asarray(G.multiply(G).sum(axis=1)).ravel()
    rho = beta * np.median(A.diagonal()[cols]) / np.median(gn2[gn2 > 0])
    c0 = time.process_time()
    hess = (newton_solver or Hessian)(A, G, rho)
    cpu = {} if cpu is None else cpu
    for k in ("setup", "newton", "qr", "face", "nnls"):
        cpu.setdefault(k, 0.0)
    cpu["setup"] += time.process_time() - c0
    mixed = Mixed(A, G)
    colnorm = np.sqrt(gn2)
    x, y = (np.zeros(A.shape[0]), np.zeros(m)) if start is None else (np.array(start[0]), np.array(start[1]))
    records, tried = [], set()
    newton = updates = faces = 0
    last_act = None
    z = np.zeros(m)
    last_change = np.inf
    while newton < steps:
        # the subproblem for y: semismooth Newton, exact line search, until the active set repeats on a full step
        inner = 0
        while newton < steps:
            s = G @ x - g
            lam = np.maximum(0.0, y + rho * s)
            act = y + rho * s >= 0       # the kinks (lam = 0 exactly, e.g. x = 0 where g = 0) taken as active
            grad = A @ x - F + G.T @ lam
            c0 = time.process_time()
            rtol = None if loose is None else (loose ** 3 if np.array_equal(act, last_act) else loose)
            last_act = act
            dx = hess.solve(act, -grad, rtol)
            cpu["newton"] += time.process_time() - c0
            newton += 1
            inner += 1
            Adx = A @ dx
            a_, b_, q_, c_ = dx @ Adx, dx @ (A @ x - F), G @ dx, y + rho * s
            t = None
            if armijo:           # the full step where it decreases phi enough (it may cross many kinks)
                gain = 0.5 * a_ + b_ + (np.sum(np.maximum(0.0, c_ + rho * q_) ** 2)
                                        - np.sum(np.maximum(0.0, c_) ** 2)) / (2 * rho)
                if gain <= 1e-4 * (b_ + q_ @ np.maximum(0.0, c_)):
                    t = 1.0
            if t is None:
                t = line_search(a_, b_, q_, c_, rho)
            x = x + t * dx
            s = G @ x - g
            same = np.array_equal(act, y + rho * s >= 0)
            lam = np.maximum(0.0, y + rho * s)
            gnew = np.linalg.norm(A @ x - F + G.T @ lam)
            if VERBOSE:
                log({"newton": newton, "t": t, "I": int(act.sum()), "flips": int(np.sum(act != (y + rho * s >= 0))),
                     "grad": gnew})
            if (same and abs(t - 1.0) < 1e-8) or gnew <= eta * np.linalg.norm(G.T @ (lam - y)):
                break
        yn = np.maximum(0.0, y + rho * s)
        updates += 1
        scale = jump_scale(G, x, g)
        change = np.abs(yn - y).max() / rho      # a distance (the rows' units): how far from the limit
        y = yn
        if always or change > 0.25 * last_change:          # the multipliers' change fell by less than 4: a larger rho
            rho *= grow
            hess.rho = rho
        last_change = change
        T = np.flatnonzero((y > 0) | (s >= -max(tau * change, TOUCH * scale)))
        rec = {"update": updates, "newton": newton, "inner": inner, "rho": rho, "viol": max(s.max(), 0) / scale,
               "change": change / scale, "T": len(T), "I": int(np.sum(y > 0))}
        if ref is not None:      # diagnosis: T against the answer's touching rows and its forces' support
            xs, zs = ref
            ss = G @ xs - g
            Ts = np.flatnonzero(np.abs(ss) <= TOUCH * jump_scale(G, xs, g))
            rec.update(extra=len(np.setdiff1d(T, Ts)), missing=len(np.setdiff1d(Ts, T)),
                       missing_z=len(np.setdiff1d(np.flatnonzero(zs > 0), T)), err=float(
                           np.abs(x - xs).max() / np.abs(xs).max()))
        key = hash(T.tobytes())
        if key in tried or len(T) == 0:
            rec["move"] = "update"
            records.append(rec)
            log(rec)
            continue
        tried.add(key)
        # the finish: exact faces from T, certified or not; a face that penetrates takes its penetrating rows, one
        # whose force z >= 0 does not represent keeps only the touching rows the NNLS residual does not open
        for attempt in range(retries + 1):
            c0 = time.process_time()
            B = T[independent(R[T].toarray(), 1.0 + y[T] / max(y.max(), 1e-300))]
            c1 = time.process_time()
            closed = np.zeros(m, bool)
            closed[B] = True
            xB, yB = mixed.solve(closed, F, g)
            c2 = time.process_time()
            faces += 1
            sB = G @ xB - g
            scB = jump_scale(G, xB, g)
            Tt = np.flatnonzero(np.abs(sB) <= TOUCH * scB)
            viol = max(sB.max(), 0.0) / scB
            r = R[B].T @ yB[B]
            rn = max(np.linalg.norm(r), 1e-300)
            rep, nxt = np.inf, None
            if viol <= TOUCH:
                M = R[Tt].T.toarray()
                colscale = colnorm[Tt] * rn
                out = nnls_warm(M, r, y[Tt], lambda v, c=colscale: c, tol=1e-13)
                if out is not None:
                    zT = out[0]
                    res = r - M @ zT
                    rep = np.linalg.norm(res) / rn
                    z = np.zeros(m)
                    z[Tt] = zT
                    nxt = Tt[M.T @ res >= -1e-9 * np.linalg.norm(res) * colnorm[Tt]]
            else:
                nxt = np.union1d(T, np.flatnonzero(sB > TOUCH * scB))
            c3 = time.process_time()
            cpu["qr"] += c1 - c0
            cpu["face"] += c2 - c1
            cpu["nnls"] += c3 - c2
            rec.setdefault("finish", []).append({"B": len(B), "Tt": len(Tt), "viol": float(viol), "rep": float(rep),
                                                 "negB": int(np.sum(yB[B] < 0))})
            if viol <= TOUCH and rep <= REPRESENT:
                rec["move"] = "certified"
                records.append(rec)
                log(rec)
                log({"newton": newton, "updates": updates, "faces": faces,
                     **{f"cpu_{k}": v for k, v in cpu.items()}})
                return xB, z, newton + faces, True, records
            if nxt is None or np.array_equal(nxt, T):
                break
            T = nxt
            tried.add(hash(T.tobytes()))
        rec["move"] = "finish declined"
        records.append(rec)
        log(rec)
    log({"newton": newton, "updates": updates, "faces": faces, **{f"cpu_{k}": v for k, v in cpu.items()}})
    return x, z, newton + faces, False, records


def diagnose(n: int, a) -> None:
    """A certified run, then the same run logging each update's band T against its answer (``ref``)."""
    s = cc.ContactSolver(two_boxes(n, "gamma3", True))
    A, F, G, g = outer_mod.mixed_data(s.problem)
    del s
    kw = {"beta": a.beta, "tau": a.tau, "retries": a.retries, "grow": a.grow, "always": a.always}
    x, z, k, ok, _ = alm(A, F, G, g, a.steps, log=lambda r: None, **kw)
    print(f"n = {n}: reference certified {ok} in {k} solves", flush=True)
    keys = ("update", "newton", "viol", "T", "extra", "missing", "missing_z", "err", "move")
    alm(A, F, G, g, a.steps, log=lambda r: print("  ", {k: r[k] for k in keys if k in r}, flush=True), ref=(x, z),
        **kw)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[8, 12, 16])
    ap.add_argument("--steps", type=int, default=200, help="most Newton steps")
    ap.add_argument("--beta", type=float, default=BETA)
    ap.add_argument("--tau", type=float, default=TAU)
    ap.add_argument("--retries", type=int, default=3, help="more faces per finish")
    ap.add_argument("--grow", type=float, default=10.0, help="rho's growth factor")
    ap.add_argument("--always", action="store_true", help="rho grows at every update")
    ap.add_argument("--diagnose", action="store_true", help="each update's band against the answer's rows")
    ap.add_argument("--verbose", action="store_true", help="one line per Newton step")
    a = ap.parse_args()
    global VERBOSE
    VERBOSE = a.verbose
    if a.diagnose:
        for n in a.n:
            diagnose(n, a)
        return
    outer_mod.METHODS["alm"] = lambda *args, **kw: alm(*args, beta=a.beta, tau=a.tau,
                                                                retries=a.retries, grow=a.grow,
                                                                always=a.always, **kw)
    for n in a.n:
        print(f"n = {n}", flush=True)
        outer_mod.run(n, a.steps, "alm")


if __name__ == "__main__":
    main()
