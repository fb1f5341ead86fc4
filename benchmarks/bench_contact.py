"""Benchmark: a contact solve against one sparse solve of the bonded coupled system.

For two-body piezoelectric scenes of growing size it measures, in one run per size
(each size in a fresh subprocess, so that peak memory is that size's own):

* T_floor: one sparse solve of the bonded system, the faster of
  - "closed": the mixed system (26) with the contact held closed at every merged
    node, a KKT matrix with a zero block (SuperLU, MMD on A^T + A, threshold pivoting);
  - "removed": the two bodies without contact, each a symmetric quasi-definite
    system factorised without pivoting (SuperLU, MMD on A^T + A, symmetric mode),
  assembly excluded;
* T_contact: ``ContactSolver(scene, "gamma3", method="condensed").solve()``,
  assembly excluded (it is the same for both and reported on its own);
* the ratio T_contact / T_floor, the share of model build + CVXPY compile, the
  interior-point iterations, the residual report, peak memory (RSS);
* a re-solve with other loads through the same ContactSolver, as a fraction of the
  first solve;
* for the smaller sizes also the full CVXPY model (``method="full"``), and the
  largest difference between the two answers.

Run:  python benchmarks/bench_contact.py [--sizes 60 120 240 450] [--full-up-to 120] [--csv FILE]
"""

from __future__ import annotations

import argparse
import csv
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def scene(nx, scale=1.0):
    import cvxcontact as cc

    ny, nx2 = max(2, nx // 2), max(2, round(0.9 * nx) + 1)
    upper = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny)
    lower = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=nx2, ny=max(2, nx2 // 2))
    b1 = cc.Body(upper, cc.materials.PZT5A, clamped="top", grounded="top", contact="bottom",
                 body_force=lambda x, y: (0 * x, -2e9 * scale * (1 + np.cos(np.pi * x))),
                 surface_charge={"left": -0.05 * scale}, name="PZT-5A")
    b2 = cc.Body(lower, cc.materials.PZT4, clamped="bottom", grounded="bottom", contact="top", name="PZT-4")
    return cc.Scene(b1, b2)


def removed_solve(blocks):
    """One sparse solve of each body's system without contact (the other floor)."""
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.condensed import quasi_definite

    t0 = time.perf_counter()
    res = []
    for b in blocks:
        S, F = quasi_definite(b)
        x = spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True)).solve(F)
        res.append(np.linalg.norm(S @ x - F) / np.linalg.norm(F))
    return time.perf_counter() - t0, float(max(res))


def bonded_solve(blocks, jumps):
    """One sparse solve of (26) with [u_nu] = 0 at every merged node (the floor)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from cvxcontact.backends.condensed import quasi_definite

    t0 = time.perf_counter()
    parts = [quasi_definite(b) for b in blocks]
    A = sp.block_diag([S for S, _ in parts])
    G = sp.hstack([sp.hstack([J, sp.csr_matrix((J.shape[0], S.shape[0] - J.shape[1]))])
                   for J, (S, _) in zip(jumps, parts)])
    K = sp.bmat([[A, G.T], [G, None]], format="csc")
    rhs = np.concatenate([F for _, F in parts] + [np.zeros(G.shape[0])])
    lu = spla.splu(K, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1, options=dict(SymmetricMode=True))
    z = lu.solve(rhs)
    t = time.perf_counter() - t0
    return t, float(np.linalg.norm(K @ z - rhs) / np.linalg.norm(rhs)), K.shape[0]


def scaled_blocks(sc):
    """The scaled free-dof blocks of every body of ``sc`` and the assembly time (s)."""
    from cvxcontact.discrete import Block, units
    from cvxcontact.fem.assembly import assemble

    t0 = time.perf_counter()
    systems = [assemble(b) for b in sc.bodies]
    t_asm = time.perf_counter() - t0
    un = units(sc, systems)
    return [Block.scaled(s, sc.interface.jump(k, len(b.mesh.points)), un)
            for k, (s, b) in enumerate(zip(systems, sc.bodies))], t_asm


def one_size(nx, full):
    import cvxcontact as cc

    sc = scene(nx)
    blocks, t_asm = scaled_blocks(sc)
    t_closed, closed_res, _ = bonded_solve(blocks, [b.jump for b in blocks])
    t_removed, removed_res = removed_solve(blocks)
    t_floor = min(t_closed, t_removed)
    n = sum(b.Kuu.shape[0] + (b.Kpp.shape[0] if b.Kpp is not None else 0) for b in blocks)

    t0 = time.perf_counter()
    solver = cc.ContactSolver(sc, "gamma3", method="condensed")
    sol = solver.solve()
    t_total = time.perf_counter() - t0
    t_contact = t_total - sol.timings["assembly"]
    build = sol.timings.get("model", 0.0) + sol.timings.get("compile", 0.0)

    other = scene(nx, scale=0.37)
    t0 = time.perf_counter()
    again = solver.solve(cc.Scene(*[cc.Body(a.mesh, a.material, clamped=a.clamped, grounded=a.grounded,
                                            contact=a.contact, body_force=o.body_force.value,
                                            surface_charge={t: v.value for t, v in o.surface_charge.items()},
                                            name=a.name)
                                    for a, o in zip(sc.bodies, other.bodies)]))
    t_again = time.perf_counter() - t0

    row = dict(nx=nx, unknowns=n, merged_nodes=sc.interface.size, assembly_s=t_asm, floor_closed_s=t_closed,
               floor_removed_s=t_removed, floor_s=t_floor, floor_residual=max(closed_res, removed_res),
               contact_s=t_contact, ratio=t_contact / t_floor,
               ratio_with_assembly=(t_contact + t_asm) / (t_floor + t_asm),
               factorization_s=sol.timings.get("factorization", 0.0), build_share=build / t_contact,
               ipm_iterations=sol.problem.solver_stats.num_iters, polished=sol.polished,
               active=int(sol.contact.active.sum()), resolve_s=t_again, resolve_share=t_again / t_total,
               resolve_ok=again.ok, resolve_path=again.path, **{f"res_{k}": v for k, v in sol.residuals().items()})
    if full:
        t0 = time.perf_counter()
        ref = cc.solve(sc, "gamma3", method="full")
        row["full_s"] = time.perf_counter() - t0 - ref.timings["assembly"]
        row["full_vs_condensed"] = max(float(np.abs(a - b).max() / np.abs(a).max()) for a, b in zip(ref.u, sol.u))
    row["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    return row


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=int, nargs="+", default=[60, 120, 240, 450])
    p.add_argument("--full-up-to", type=int, default=120, help="also run method='full' up to this nx")
    p.add_argument("--csv", default=str(Path(__file__).with_name("results") / "contact.csv"))
    p.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        print(json.dumps(one_size(args.one, args.one <= args.full_up_to)))
        return
    rows = []
    for nx in args.sizes:
        out = subprocess.run([sys.executable, __file__, "--one", str(nx), "--full-up-to", str(args.full_up_to)],
                             capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        r = rows[-1]
        print(f"nx={nx:4d} unknowns={r['unknowns']:8d} floor closed {r['floor_closed_s']:7.2f} s, removed "
              f"{r['floor_removed_s']:7.2f} s  contact {r['contact_s']:7.2f} s  "
              f"ratio {r['ratio']:5.2f} (with assembly {r['ratio_with_assembly']:5.2f})  build {100 * r['build_share']:4.1f} %  "
              f"iters {r['ipm_iterations']:2d}  re-solve {100 * r['resolve_share']:4.1f} %  "
              f"eq {r['res_equilibrium']:.1e} compl {r['res_complementarity']:.1e}  peak {r['peak_rss_gb']:.2f} GB"
              + (f"  full {r['full_s']:.2f} s, |full-condensed| {r['full_vs_condensed']:.1e}" if "full_s" in r else ""),
              flush=True)
    if len(rows) >= 2:
        n = np.array([r["unknowns"] for r in rows], float)
        for key in ("floor_s", "contact_s"):
            slope = np.polyfit(np.log(n), np.log([r[key] for r in rows]), 1)[0]
            print(f"growth of {key}: N^{slope:.2f}")
    Path(args.csv).parent.mkdir(parents=True, exist_ok=True)
    keys = sorted({k for r in rows for k in r}, key=lambda k: list(rows[-1]).index(k) if k in rows[-1] else 99)
    with open(args.csv, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    print("wrote", args.csv)


if __name__ == "__main__":
    main()
