"""Exploration: P1 "gamma3" from the "sigma1" AMG route's answer, corrected on the band near the contact zone's edge
(issue 33 item 1; docs/explanation/gamma3-fast-route.md, "The sigma1 answer corrected near the edge"). Not in the
package.

The hypothesis: the "gamma3" answer differs from the "sigma1" answer (its rows are overlay rows, one per vertex of
the upper face) only near the contact zone's edge, so its face can be found by a small, local problem there and then
solved exactly once on the whole mesh. On two_boxes(n, ..., elastic=True) (tests/scenes3d.py):

``--table status``: the "gamma3" answer (the condensed route, cc.solve's default; its closed rows' face solved
    again by PARDISO on the mixed system for the displacements, explore_gamma3_outer.Mixed) and the "sigma1" answer
    (the AMG route, explore_gamma3_alm_amg.sigma1_start). Each "gamma3" row's status at either answer: in contact
    (s = G x - g >= -1e-9 of the jump's scale: touching or penetrating) or open. Rows whose status differs, binned by
    their signed distance to the zone's edge at the answer, in element layers h = 1/n of the upper face (the zone:
    the points of the face within h of a row in contact, since open rows lie between touching ones everywhere inside
    it; inside, + the distance from the row's overlay vertex to the nearest row outside the zone; outside, - the
    distance to the nearest row in contact); and every row, binned the same way.
``--table decay``: the relative difference of u (max over nodes |u_sigma1 - u_gamma3| / max |u_gamma3|) binned by
    the node's distance (3D, in h) to the zone's edge at the answer (its rows within h of it, either side).
``--table band``: the band correction, iterated up to ``--rounds`` times from x = the "sigma1" answer:
    1. the band: ``--band edge``, the rows within ``--width`` h (1) of the iterate's zone's edge (measured as
       above); ``--band zone``, the iterate's whole zone widened by ``--width`` h; after a face, also its penetrating
       rows and its closed rows with negative force;
    2. the patch: the nodes within k element layers (graph distance k in the stiffness pattern, both bodies) of the
       band rows' nodes, free; every other dof held at the iterate (Dirichlet data on the patch's boundary); the
       "gamma3" problem on the patch (its rows: those reading a patch dof) solved by Clarabel's interior point
       (tolerances 1e-10), the rows whose slack is within ``--ident`` (1e-6) of the jump's scale taken as touching
       (``--select force``: of those in the patch only the ones whose multiplier exceeds ``--ident`` of the largest);
    3. the whole mesh's rows in contact at the iterate with the patch's answer put in (those outside the patch keep
       the iterate's status) -> an independent subset B (column-pivoted QR, weighted by the patch's multipliers and
       the "sigma1" forces, explore_gamma3_outer.independent) -> the face G_B x = g_B solved exactly on the whole
       mesh (PARDISO, Mixed), and by projected CG with one smoothed-aggregation hierarchy of the bodies
       (explore_gamma3_face's) to 1e-10 from the iterate (warm) and from x = 0 (cold): the iterations counted;
    4. certified as explore_gamma3_alm's finish: every row feasible to 1e-9 of the scale and the face's force
       represented by z >= 0 on the touching rows (backends.cuts.nnls_warm) to 1e-9 of its norm; else the face's
       answer is the next iterate.
    Printed per k: rounds, faces, certified, the certified answer against the condensed route's (jump at every row,
    u against its face), the patch sizes and CPU seconds.
``--table cost``: the same runs priced against one bonded AMG-CG solve of the same mesh (benchmarks/harness.py
    ``amg_bonded``, the yardstick): "sigma1" (the whole AMG route) + patches (Clarabel) + faces (the warm projected
    CG, its LU of G_B G_B^T, the hierarchy once) and, apart, the finish's dense QR and NNLS.

CPU seconds by ``time.process_time``, one thread, one run; results: benchmarks/results/explore_gamma3_band.md.

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_band.py \\
        --table status --n 16 24 32 40
    ... --table decay --n 16 24 32 40
    ... --table band --band edge --n 16 --k 1 2 4 8 --rounds 8     (RAYON_NUM_THREADS=1: Clarabel on one thread)
    ... --table band --band zone --n 16 24 --k 1 2 4 8 --rounds 8  [--ident 1e-8] [--select force]
    ... --table cost (the same runs; every table is printed by --table all)
"""

from __future__ import annotations

import argparse
import gc
import itertools
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import explore_gamma3_outer as outer_mod
from explore_gamma3_alm_amg import body_modes, sigma1_start
from explore_gamma3_outer import REPRESENT, TOUCH, Mixed, independent, jump_scale
from harness import amg_bonded, bonded_system, markdown_table, peak_gb, rel
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.backends.amg import _seeded
from cvxcontact.backends.cuts import nnls_warm

DIST_BINS = (-np.inf, -8, -4, -2, -1, 0, 1, 2, 4, 8, np.inf)     # signed distance to the zone's edge, in h
DECAY_BINS = (0, 1, 2, 4, 8, 16, np.inf)                           # distance to the differing rows, in h


def dof_points(p) -> np.ndarray:
    """The coordinates (m) of each free dof's node, stacked over the bodies as the mixed system's x."""
    out = []
    for k in range(len(p.blocks)):
        Tu = sp.csc_matrix(p.systems[k].Tu)
        node = Tu.indices[Tu.indptr[:-1]] // 3
        out.append(np.asarray(p.scene.bodies[k].mesh.points, float)[node])
    return np.vstack(out)


def row_points(G: sp.csr_matrix, pts: np.ndarray, n_upper: int) -> np.ndarray:
    """Each row's overlay vertex (x, y): its upper-body columns' node positions weighted by |coefficient| (the
    barycentric weights of the upper triangle holding it; the rows act on the z dofs alone)."""
    Gu = G[:, :n_upper].tocsr()
    w = abs(Gu)
    s = np.asarray(w.sum(axis=1)).ravel()
    return np.column_stack([(w @ pts[:n_upper, i]) / np.maximum(s, 1e-300) for i in range(2)])


def status(G, g, x):
    """(contact, penetrating, s, scale) of the rows at x: contact s >= -TOUCH scale, penetrating s > TOUCH scale."""
    s = G @ x - g
    sc = jump_scale(G, x, g)
    return s >= -TOUCH * sc, s > TOUCH * sc, s, sc


def edge_distance(rp: np.ndarray, contact: np.ndarray, h: float) -> np.ndarray:
    """Signed distance (in h) from each row to the contact zone's edge. The zone: the points within h of a row in
    contact (the zone is speckled: open rows lie between touching ones everywhere inside it, at the "gamma3" answer
    too); inside it, + the distance to the nearest row outside it; outside, - the distance to the nearest row in
    contact (<= -1)."""
    out = np.full(len(rp), -np.inf)
    if not contact.any():
        return out
    dc = cKDTree(rp[contact]).query(rp)[0]
    inside = dc <= h * (1 + 1e-9)
    out[~inside] = -dc[~inside] / h
    out[inside] = cKDTree(rp[~inside]).query(rp[inside])[0] / h if (~inside).any() else np.inf
    return out


class Scene:
    """One mesh's data: the mixed system (A, F, G, g), the condensed answer, the sigma1 start, the geometry."""

    def __init__(self, n: int):
        self.n, self.h = n, 1.0 / n
        s = cc.ContactSolver(two_boxes(n, "gamma3", True))
        p = s.problem
        c0 = time.process_time()
        sol = s.solve()
        self.cond_cpu = time.process_time() - c0
        self.P = np.flatnonzero(s.cache.active)
        self.cj = np.asarray(sol.contact.jump)
        self.unit = p.units.displacement
        self.A, self.F, self.G, self.g = outer_mod.mixed_data(p)
        self.G.sort_indices()      # built after a solve, E @ jump comes with its indices unsorted (values equal):
        # sigma1_start matches rows by their column indices' bytes, so unsorted it missed 533 of 535 at n = 24
        self.modes = body_modes(p)
        self.pts = dof_points(p)
        n_upper = p.blocks[0].Kuu.shape[0]
        self.rp = row_points(self.G, self.pts, n_upper)
        del s, sol, p
        gc.collect()
        m = self.G.shape[0]
        closed = np.zeros(m, bool)
        closed[self.P] = True
        self.mixed = Mixed(self.A, self.G)
        self.xref, _ = self.mixed.solve(closed, self.F, self.g)
        self.x1, self.y1, self.s1rec = sigma1_start(n, self.G)
        self.N, self.m = self.A.shape[0], m
        cols = np.flatnonzero(np.diff(self.G.tocsc().indptr))
        self.R = self.G.tocsc()[:, cols].tocsr()
        self.d = len(cols)
        self.colnorm = np.sqrt(np.asarray(self.G.multiply(self.G).sum(axis=1)).ravel())
        blk = self.A.tobsr(blocksize=(3, 3))
        self.nodes = sp.csr_matrix((np.ones(len(blk.indices)), blk.indices, blk.indptr),
                                   shape=(self.N // 3, self.N // 3))
        self._hier = None

    # ---- tables 1, 2 -----------------------------------------------------------------------------------------
    def status_rows(self) -> dict:
        cg, _, _, _ = status(self.G, self.g, self.xref)
        c1, pen1, _, _ = status(self.G, self.g, self.x1)
        dist = edge_distance(self.rp, cg, self.h)
        self.dist = dist
        diff = cg != c1
        hist = np.histogram(dist[diff], bins=DIST_BINS)[0]
        return {"n": self.n, "m": self.m, "contact_g3": int(cg.sum()), "contact_s1": int(c1.sum()),
                "pen_s1": int(pen1.sum()), "differ": int(diff.sum()),
                "g3_only": int(np.sum(cg & ~c1)), "s1_only": int(np.sum(c1 & ~cg)), "hist": hist.tolist(),
                "rows_hist": np.histogram(dist, bins=DIST_BINS)[0].tolist(),
                "max_abs_dist": float(np.abs(dist[diff]).max()) if diff.any() else 0.0}

    def decay(self) -> dict:
        """max |u_sigma1 - u_gamma3| / max |u_gamma3| over the nodes binned by their distance (3D, in h) to the
        zone's edge at the answer (its rows within one h of it, on either side)."""
        edge = np.abs(self.dist) <= 1.0 + 1e-9
        tree = cKDTree(np.column_stack([self.rp[edge], np.zeros(edge.sum())]))
        dist = tree.query(self.pts[0::3])[0] / self.h
        du = np.abs(self.x1 - self.xref).reshape(-1, 3).max(axis=1) / np.abs(self.xref).max()
        out = []
        for lo, hi in itertools.pairwise(DECAY_BINS):
            sel = (dist >= lo) & (dist < hi)
            out.append(float(du[sel].max()) if sel.any() else None)
        return {"n": self.n, "bins": out, "total": rel(self.x1, self.xref)}

    # ---- the band correction ---------------------------------------------------------------------------------
    def band(self, x, mode: str, width: float, later: bool, negative=None) -> np.ndarray:
        """The band's rows at the iterate x (module docstring): ``mode`` "edge" the rows within ``width`` h of
        its zone's edge, "zone" its whole zone widened by ``width`` h; after a face (``later``) its penetrating
        rows and its closed rows with negative force too."""
        contact, pen, _, _ = status(self.G, self.g, x)
        d = edge_distance(self.rp, contact, self.h)
        rows = np.abs(d) <= width if mode == "edge" else d >= -width
        if later:
            rows |= pen
            if negative is not None:
                rows[negative] = True
        return np.flatnonzero(rows)

    def patch(self, band_rows: np.ndarray, k: int) -> np.ndarray:
        """The free dofs of the nodes within k element layers (node graph distance) of the band rows' nodes."""
        seed = np.zeros(self.N // 3, bool)
        seed[np.unique(self.G[band_rows].indices) // 3] = True
        reach = seed.copy()
        for _ in range(k):
            reach |= (self.nodes @ reach.astype(float)) > 0
        return np.flatnonzero(np.repeat(reach, 3))

    def solve_patch(self, x, I: np.ndarray):
        """The "gamma3" problem on the patch I (other dofs held at x) by Clarabel; (x with the patch's answer,
        its rows, their multipliers, Clarabel's status, CPU s)."""
        import clarabel

        c0 = time.process_time()
        inI = np.zeros(self.N, bool)
        inI[I] = True
        O = np.flatnonzero(~inI)
        GI = self.G[:, I].tocsr()
        rows = np.flatnonzero(np.diff(GI.indptr) > 0)
        GIr = GI[rows]
        AI = self.A[I][:, I]
        q = -(self.F[I] - self.A[I][:, O] @ x[O])
        b = self.g[rows] - self.G[rows][:, O] @ x[O]
        st = clarabel.DefaultSettings()
        st.verbose = False
        st.tol_gap_abs = st.tol_gap_rel = st.tol_feas = 1e-10
        solver = clarabel.DefaultSolver(sp.triu(AI).tocsc(), q, GIr.tocsc(), b,
                                        [clarabel.NonnegativeConeT(len(rows))],
                                        st)
        out = solver.solve()
        xn = x.copy()
        xn[I] = np.asarray(out.x)
        return xn, rows, np.asarray(out.z), str(out.status), time.process_time() - c0

    def hierarchy(self):
        """One smoothed-aggregation hierarchy of the bodies' stiffness (no row: every face's), built once."""
        if self._hier is None:
            import pyamg

            c0 = time.process_time()
            with _seeded():
                ml = pyamg.smoothed_aggregation_solver(self.A.tocsr().tobsr(blocksize=(3, 3)), B=self.modes,
                                                       symmetry="symmetric", max_coarse=30)
            self._hier = (ml.aspreconditioner(cycle="V"), time.process_time() - c0)
        return self._hier

    def projected_cg(self, B: np.ndarray, start: np.ndarray | None, tol: float = 1e-10, maxiter: int = 500):
        """explore_gamma3_face's projected CG on the face B from ``start`` (projected onto G_B x = g_B; None:
        x = 0): (x, iterations, CPU s without the hierarchy). Stops where the projected residual is below ``tol``
        of the cold start's (the same absolute target warm and cold); at most ``maxiter`` iterations."""
        V, _ = self.hierarchy()
        c0 = time.process_time()
        GB = self.G[B].tocsr()
        gB = self.g[B]
        lu = spla.splu(sp.csc_matrix(GB @ GB.T))

        def proj(v):            # twice: one projection by the LU of G_B G_B^T leaves cond(G_B)^2 eps of G_B v
            w = v - GB.T @ lu.solve(GB @ v)    # (cond 1.3e5 on a zone face at n = 24: the CG then stalled at 7e-10)
            return w - GB.T @ lu.solve(GB @ w)

        xp0 = GB.T @ lu.solve(gB)
        target = tol * np.linalg.norm(proj(self.F - self.A @ xp0))
        x = xp0 if start is None else start - GB.T @ lu.solve(GB @ start - gB)
        r = proj(self.F - self.A @ x)
        z = proj(V @ r)
        dp, rz, it = z.copy(), r @ z, 0
        while np.linalg.norm(r) > target and it < maxiter:
            Ad = proj(self.A @ dp)
            a = rz / (dp @ Ad)
            x = x + a * dp
            r -= a * Ad
            z = proj(V @ r)
            rz, rz_old = r @ z, rz
            dp = z + (rz / rz_old) * dp
            it += 1
        return x, it, time.process_time() - c0

    def correct(self, k: int, a) -> dict:
        """The band correction with k layers, iterated from the sigma1 answer (module docstring)."""
        x, y = self.x1.copy(), self.y1.copy()
        negative = None
        cpu = {"patch": 0.0, "qr": 0.0, "face_pardiso": 0.0, "face_pcg": 0.0, "nnls": 0.0}
        recs = []
        certified, xB = False, x
        for rnd in range(1, a.rounds + 1):
            band_rows = self.band(x, a.band, a.width, rnd > 1, negative)
            I = self.patch(band_rows, k)
            xn, prow, pz, pstat, pcpu = self.solve_patch(x, I)
            cpu["patch"] += pcpu
            yn = y.copy()
            yn[prow] = np.maximum(pz, 0.0)
            s = self.G @ xn - self.g
            sc = jump_scale(self.G, xn, self.g)
            T = np.flatnonzero(s >= -a.ident * sc)
            if a.select == "force":      # the patch's rows carrying force only (the touching ones at zero force left
                inpatch = np.zeros(self.m, bool)    # free: the face's answer shows whether they penetrate)
                inpatch[prow] = True
                T = T[~inpatch[T] | (yn[T] > a.ident * max(yn[prow].max(initial=0.0), 1e-300))]
            c0 = time.process_time()
            B = T[independent(self.R[T].toarray(), 1.0 + yn[T] / max(yn.max(), 1e-300))]
            c1 = time.process_time()
            closed = np.zeros(self.m, bool)
            closed[B] = True
            xB, yB = self.mixed.solve(closed, self.F, self.g)
            c2 = time.process_time()
            print("      patch, QR, PARDISO face CPU s", round(pcpu, 2), round(c1 - c0, 2), round(c2 - c1, 2),
                  flush=True)
            xw, it_w, cpu_w = self.projected_cg(B, x)
            print("      warm projected CG", it_w, round(cpu_w, 2), flush=True)
            xc, it_c, _ = self.projected_cg(B, None)
            cpu["qr"] += c1 - c0
            cpu["face_pardiso"] += c2 - c1
            cpu["face_pcg"] += cpu_w
            c3 = time.process_time()
            sB = self.G @ xB - self.g
            scB = jump_scale(self.G, xB, self.g)
            Tt = np.flatnonzero(np.abs(sB) <= TOUCH * scB)
            viol = max(sB.max(), 0.0) / scB
            r = self.R[B].T @ yB[B]
            rn = max(np.linalg.norm(r), 1e-300)
            rep = np.inf
            if viol <= TOUCH:
                M = self.R[Tt].T.toarray()
                colscale = self.colnorm[Tt] * rn
                out = nnls_warm(M, r, np.maximum(yB[Tt], 0.0), lambda v, c=colscale: c, tol=1e-13)
                if out is not None:
                    rep = np.linalg.norm(r - M @ out[0]) / rn
            cpu["nnls"] += time.process_time() - c3
            cg_ref, _, _, _ = status(self.G, self.g, self.xref)
            rec = {"round": rnd, "band": len(band_rows), "patch_dofs": len(I), "patch_rows": len(prow),
                   "clarabel": pstat, "T": len(T), "B": len(B), "P": len(self.P),
                   "T_vs_answer": (int(np.sum(~cg_ref[T])), int(np.sum(cg_ref) - np.sum(cg_ref[T]))),
                   "viol": float(viol), "rep": float(rep), "negB": int(np.sum(yB[B] < 0)),
                   "pcg_warm": it_w, "pcg_cold": it_c, "pcg_vs_pardiso": rel(xw, xB), "pcg_cold_vs": rel(xc, xB)}
            recs.append(rec)
            print("    ", rec, flush=True)
            if viol <= TOUCH and rep <= REPRESENT:
                certified = True
                break
            negative = B[yB[B] < 0]
            x, y = xB, np.where(closed, np.maximum(yB, 0.0), 0.0)
        out = {"n": self.n, "k": k, "rounds": len(recs), "certified": certified, "recs": recs, "cpu": cpu,
               "jump_rel": rel(self.G @ xB * self.unit, self.cj), "u_rel": rel(xB, self.xref),
               "hier_cpu": self.hierarchy()[1]}
        return out

    def yardstick(self):
        p1 = cc.ContactSolver(two_boxes(self.n, "sigma1", True)).problem
        _, rhs1, A1, G1, sizes1 = bonded_system(p1)
        y = amg_bonded(p1, A1, G1, rhs1, sizes1)
        return (y[2], y[5]) if y else (None, None)


def fmt(v, f="{:.1e}"):
    return "" if v is None else f.format(v)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", choices=("status", "decay", "band", "cost", "all"), default="all")
    ap.add_argument("--n", type=int, nargs="+", default=[16])
    ap.add_argument("--k", type=int, nargs="+", default=[1, 2, 4, 8], help="the patch's element layers")
    ap.add_argument("--rounds", type=int, default=6, help="most band corrections (faces)")
    ap.add_argument("--band", choices=("edge", "zone"), default="edge", help="the band: the edge or the zone")
    ap.add_argument("--width", type=float, default=1.0, help="the band: rows within this many h of the edge")
    ap.add_argument("--ident", type=float, default=1e-6, help="touching in the patch: slack / jump scale")
    ap.add_argument("--select", choices=("touching", "force"), default="touching",
                    help="the face's candidate rows in the patch: touching, or carrying force "
                         "(> ident of the largest)")
    a = ap.parse_args()
    rows1, rows2, rows3, rows4 = [], [], [], []
    for n in a.n:
        print(f"n = {n}", flush=True)
        sc = Scene(n)
        print("  sigma1", sc.s1rec, "condensed CPU", round(sc.cond_cpu, 2), flush=True)
        st = sc.status_rows()
        print("  status", st, flush=True)
        rows1.append([str(n), f"{sc.N:,}", f"{sc.m:,}", f"{st['contact_g3']:,}", f"{st['contact_s1']:,}",
                      f"{st['pen_s1']:,}", f"{st['g3_only']}", f"{st['s1_only']}"] + [str(v) for v in st["hist"]]
                     + [f"{st['max_abs_dist']:.2f}"])
        rows1.append(["", "", "", "", "", "", "every row:", ""] + [str(v) for v in st["rows_hist"]] + [""])
        if a.table in ("decay", "all"):
            de = sc.decay()
            print("  decay", de, flush=True)
            rows2.append([str(n)] + [fmt(v) for v in de["bins"]] + [fmt(de["total"])])
        if a.table in ("band", "cost", "all"):
            yit, ycpu = sc.yardstick()
            for k in a.k:
                c = sc.correct(k, a)
                print("  band", {q: v for q, v in c.items() if q != "recs"}, flush=True)
                r = c["recs"]
                rows3.append([str(n), a.band, str(k), str(c["rounds"]), "yes" if c["certified"] else "no",
                              " / ".join(f"{q['band']}" for q in r), " / ".join(f"{q['patch_dofs']:,}" for q in r),
                              " / ".join(f"{q['T_vs_answer'][0]}+{q['T_vs_answer'][1]}-" for q in r),
                              " / ".join(f"{q['pcg_warm']}" for q in r), " / ".join(f"{q['pcg_cold']}" for q in r),
                              fmt(c["jump_rel"]), fmt(c["u_rel"])])
                cp = c["cpu"]
                s1 = sc.s1rec["sigma1_cpu"]
                route = s1 + cp["patch"] + cp["face_pcg"] + c["hier_cpu"]
                rows4.append([str(n), a.band, str(k), f"{s1:.2f}", f"{cp['patch']:.2f}", f"{c['hier_cpu']:.2f}",
                              f"{cp['face_pcg']:.2f}", f"{cp['qr'] + cp['nnls']:.2f}", f"{route:.2f}",
                              f"{ycpu:.2f} ({yit})" if ycpu else "", f"{route / ycpu:.2f}" if ycpu else "",
                              f"{sc.cond_cpu:.2f}", f"{cp['face_pardiso']:.2f}"])
        print("  peak GB", round(peak_gb(), 2), flush=True)
        del sc
        gc.collect()
    print()
    head = (["n", "unknowns", "rows m", "in contact, gamma3", "in contact, sigma1", "penetrating at sigma1",
             "contact in gamma3 only", "contact in sigma1 only"]
            + [f"[{lo}, {hi})" for lo, hi in itertools.pairwise(DIST_BINS)] + ["largest |distance| (h)"])
    print("Rows whose status differs, by signed distance to the zone's edge (h = 1/n; + inside)")
    print(markdown_table(head, rows1))
    if rows2:
        print("\nmax |u_sigma1 - u_gamma3| / max |u_gamma3| by a node's distance to the zone's edge (h)")
        print(markdown_table(["n"] + [f"[{lo}, {hi})" for lo, hi in itertools.pairwise(DECAY_BINS)]
                             + ["every dof"], rows2))
    if rows3:
        print("\nBand correction (per round: band rows, patch dofs, T's rows open at the answer + answer's contact "
              "rows missing)")
        print(markdown_table(["n", "band", "k", "rounds", "certified", "band rows", "patch dofs",
                              "T: extra+ missing-",
                              "projected CG it. warm", "cold", "jump vs condensed", "u vs condensed"], rows3))
        print("\nCost (CPU s): sigma1 + patches + hierarchy + warm projected-CG faces, against the yardstick")
        print(markdown_table(["n", "band", "k", "sigma1", "patches", "hierarchy", "faces (PCG)", "QR + NNLS (dense)",
                              "route", "yardstick (CG it.)", "route / yardstick", "condensed", "faces (PARDISO)"],
                             rows4))


if __name__ == "__main__":
    main()
