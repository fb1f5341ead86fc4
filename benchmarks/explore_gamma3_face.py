"""Exploration: one exact solve of P1 "gamma3"'s final face on the AMG route's terms (issue 33 item 1;
docs/explanation/gamma3-fast-route.md). Two elastic boxes (tests/scenes3d.py
``two_boxes(n, "gamma3", elastic=True)``), solved on the default route; its closed rows P
(``solver.cache.active``: the exact finish's independent rows) are then held as equalities on the bonded mixed
system (benchmarks/harness.py ``bonded_kkt``) and solved

* by PARDISO (the reference; its jump at every row against the answer's, ``sol.contact.jump``, in metres: the face
  with these rows closed is the answer);
* by smoothed-aggregation AMG-CG to 1e-10 (node-blocked, each body's rigid modes, as ``harness.amg_bonded``) on the
  system with the rows eliminated exactly through a square block: S = one column per row (column-pivoted QR of
  the rows on their columns), x_S = G_S^-1 (g - G_M x_M) (SuperLU), so x = T x_M + x_0 with T's rows
  -G_S^-1 G_M on S; the eliminated dofs kept as decoupled identity rows. Printed: the fill of G_S^-1 G_M, the CG
  iterations and CPU seconds (set-up + solve), the answer against PARDISO's;
* by projected AMG-CG to 1e-10 with the rows kept: CG on the null space of the closed rows G, the projection
  v - G^T (G G^T)^-1 G v by a sparse LU of G G^T (face-sized), preconditioned by the projected V-cycle of one
  hierarchy of the bodies' stiffness A (no row in it: one hierarchy for every set), x = x_0 + the CG iterate with
  x_0 = G^T (G G^T)^-1 g; set-up (LU, hierarchy) + solve in the CPU seconds;
* against the yardstick on the same mesh: one bonded AMG-CG solve with the nodal "sigma1" rows (each its own dof).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/explore_gamma3_face.py --n 12 24 32
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pyamg
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import (
    amg_bonded,
    bonded_kkt,
    bonded_system,
    pardiso_symmetric,
    rel,
    rigid_modes,
)
from scenes3d import two_boxes

import cvxcontact as cc


def face(n: int) -> None:
    """The final face of two_boxes(n, "gamma3") solved by PARDISO and by AMG-CG; one line of text each."""
    s = cc.ContactSolver(two_boxes(n, "gamma3", True)); sol = s.solve(); p = s.problem
    P = np.flatnonzero(s.cache.active)
    rows = [sp.csr_matrix(p.E @ b.jump) for b in p.blocks]
    K, rhs, A, G, _ = bonded_kkt(p.blocks, [r[P] for r in rows], p.g[P])
    N = A.shape[0]; g = rhs[N:]; F = rhs[:N]
    _, z, _, _ = pardiso_symmetric(K, rhs)
    xd = z[:N]
    cj = np.asarray(sol.contact.jump)
    jump = sp.hstack(rows).tocsr() @ xd * p.units.displacement
    print("N", N, "rows m", len(cj), "B", G.shape[0], "direct vs answer (jump)", rel(jump, cj))
    # square-block elimination: S = one column per row (column-pivoted QR of G on its columns)
    t0 = time.process_time()
    cols = np.flatnonzero(np.diff(G.tocsc().indptr))
    Gc = G.tocsc()[:, cols]
    _, _, cp_ = sla.qr(Gc.toarray(), mode="economic", pivoting=True)
    Sl = np.sort(cp_[:G.shape[0]]); S = cols[Sl]
    Mg = np.setdiff1d(cols, S)
    GS = sp.csc_matrix(G.tocsc()[:, S]); GM = G.tocsc()[:, Mg].toarray()
    lu = spla.splu(GS)
    X = lu.solve(GM); X[np.abs(X) < 1e-14 * np.abs(X).max()] = 0.0
    x0 = np.zeros(N); x0[S] = lu.solve(g)
    keep = np.ones(N, bool); keep[S] = False
    Xs = sp.coo_matrix(X)
    Tf = sp.coo_matrix((np.concatenate([np.ones(keep.sum()), -Xs.data]),
                        (np.concatenate([np.flatnonzero(keep), S[Xs.row]]),
                         np.concatenate([np.flatnonzero(keep), Mg[Xs.col]]))),
                       shape=(N, N)).tocsr()
    dummy = sp.csr_matrix((np.ones(len(S)), (S, S)), shape=(N, N))
    Kr = (Tf.T @ A @ Tf + dummy).tocsr(); br = Tf.T @ (F - A @ x0)
    t_red = time.process_time() - t0
    c0 = time.process_time()
    Bm = np.vstack([rigid_modes(p, k) for k in range(len(p.blocks))])
    # each body's modes in the same six columns (as harness.amg_bonded)
    Bm[S] = 0.0
    Kb = Kr.tobsr(blocksize=(3, 3))
    ml = pyamg.smoothed_aggregation_solver(Kb, B=Bm, symmetry="symmetric", max_coarse=30)
    its = []
    xr, info = spla.cg(Kr, br, M=ml.aspreconditioner(cycle="V"), rtol=1e-10, atol=0.0, maxiter=3000,
                       callback=lambda _x: its.append(1))
    cpu = time.process_time() - c0
    x = Tf @ xr + x0
    print(f"eliminated: nnz X {Xs.nnz} ({Xs.nnz / len(S):.1f} per row), nnz Kr {Kr.nnz} vs A {A.nnz}, "
          f"reduce CPU {t_red:.2f} s")
    print(f"AMG-CG on the face: {len(its)} it., CPU {cpu:.2f} s, info {info}, vs direct {rel(x, xd):.1e}, "
          f"rows B residual {np.abs(G @ x - g).max():.1e}")
    # the rows kept: projected CG, one hierarchy of A (no row in it)
    c0 = time.process_time()
    lu_g = spla.splu(sp.csc_matrix(G @ G.T))

    def proj(v):
        return v - G.T @ lu_g.solve(G @ v)

    xp0 = G.T @ lu_g.solve(g)
    modes = np.vstack([rigid_modes(p, k) for k in range(len(p.blocks))])
    V = pyamg.smoothed_aggregation_solver(A.tocsr().tobsr(blocksize=(3, 3)), B=modes, symmetry="symmetric",
                                          max_coarse=30).aspreconditioner(cycle="V")
    r = proj(F - A @ xp0)
    xp, zp, nb, it = np.zeros(N), proj(V @ r), np.linalg.norm(r), 0
    dp, rz = zp.copy(), r @ zp
    while np.linalg.norm(r) > 1e-10 * nb and it < 3000:
        Ad = proj(A @ dp)
        a = rz / (dp @ Ad)
        xp += a * dp
        r -= a * Ad
        zp = proj(V @ r)
        rz, rz_old = r @ zp, rz
        dp = zp + (rz / rz_old) * dp
        it += 1
    xp += xp0
    cpu_p = time.process_time() - c0
    print(f"projected AMG-CG, rows kept: {it} it., CPU {cpu_p:.2f} s, vs direct {rel(xp, xd):.1e}, "
          f"rows residual {np.abs(G @ xp - g).max():.1e}, true residual {np.linalg.norm(proj(F - A @ xp)) / nb:.1e}")
    # the yardstick: the same mesh's sigma1 rows bonded
    s1 = cc.ContactSolver(two_boxes(n, "sigma1", True)); p1 = s1.problem
    _, rhs1, A1, G1, sizes1 = bonded_system(p1)
    y = amg_bonded(p1, A1, G1, rhs1, sizes1)
    print(f"yardstick (sigma1 rows bonded) AMG-CG: {y[2]} it., CPU {y[5]:.2f} s; eliminated / yardstick "
          f"{cpu / y[5]:.2f}, projected / yardstick {cpu_p / y[5]:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[12, 24])
    for n in ap.parse_args().n:
        print(f"n = {n}")
        face(n)


if __name__ == "__main__":
    main()
