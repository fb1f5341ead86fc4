"""The independent yardstick of issue 33: plain P1 elasticity assembly by scikit-fem and smoothed-aggregation
AMG-preconditioned CG (pyamg) to a relative residual 1e-10, on the meshes of bench3d.py's elastic ``two_boxes(n)``.

Nothing of cvxcontact is used (only bench3d.py's size-to-n rule, ``cells``): the two boxes are made by
``skfem.MeshTet.init_tensor`` on the same grid lines as ``cc.box`` (upper (0, 1)^2 x (0, 0.5) m, n x n x n/2
cells; lower (0, 1)^2 x (-0.5, 0) m, n2 = round(0.7 n) cells a side, (n2 + 1) // 2 high; six tetrahedra per
cell, the same node and tetrahedron counts), aluminium (E = 70 GPa, nu = 0.3), assembled by
``skfem.asm(linear_elasticity)`` (one quadrature point: exact for P1), each body clamped where the scene clamps
it (upper: top, lower: bottom), body force 2e9 N/m^3 downwards on both. The bodies are solved one after the
other, not glued (no mortar in a plain code): the same meshes, operator and unknowns (the interface's few
hundred dofs aside) as the bonded solve, each body held on one face only.
Each body: ``skfem.condense`` to the free dofs, ``pyamg.smoothed_aggregation_solver`` (3 x 3 node blocks, the
six rigid-body modes as near-null space, pyamg's defaults otherwise), ``ml.solve(accel="cg", tol=1e-10)``.
Each size runs in a fresh process (its peak memory ``ru_maxrss`` its own), one thread:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench3d_skfem.py --sizes 5e5 1e6

Printed per size: unknowns (free dofs of both bodies), CPU seconds of the assembly (mesh, basis, asm, condense),
of the AMG set-up and of the CG solve, the CG iterations, the true relative residual ||b - A x|| / ||b|| of
each body, the peak memory. ``--check``: also a direct solve (SciPy spsolve) of each body, max |x - x_direct| /
max |x_direct| (small sizes only).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import load, peak_gb, run_part, side_cells


def rigid_modes(p: np.ndarray) -> np.ndarray:
    """The six rigid-body modes of nodes ``p`` (3 x nodes), rows interleaved by node (x0, y0, z0, x1, ...)."""
    x, y, z = p - p.mean(axis=1, keepdims=True)
    B = np.zeros((3 * p.shape[1], 6))
    for k in range(3):
        B[k::3, k] = 1.0
    B[0::3, 3], B[1::3, 3] = -y, x           # rotation about z
    B[1::3, 4], B[2::3, 4] = -z, y           # about x
    B[0::3, 5], B[2::3, 5] = z, -x           # about y
    return B


def body(nx: int, nz: int, z0: float, z1: float, clamp_top: bool, check: bool) -> dict:
    """Assemble, set up and solve one box ((0, 1)^2 x (z0, z1), nx x nx x nz cells); CPU seconds of each stage."""
    import pyamg
    import scipy.sparse.linalg as spla
    from skfem import (
        Basis,
        ElementTetP1,
        ElementVector,
        LinearForm,
        MeshTet,
        asm,
        condense,
    )
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    c0 = time.process_time()
    g = np.linspace(0.0, 1.0, nx + 1)
    mesh = MeshTet.init_tensor(g, g, np.linspace(z0, z1, nz + 1))
    basis = Basis(mesh, ElementVector(ElementTetP1()), intorder=1)      # one point: exact for P1 (constant strains)
    A = asm(linear_elasticity(*lame_parameters(70e9, 0.3)), basis)

    @LinearForm
    def weight(v, w):
        return -2e9 * v[2]

    b = asm(weight, basis)
    zc = mesh.p[2]
    fixed_nodes = np.flatnonzero(np.isclose(zc, z1 if clamp_top else z0))
    fixed = basis.nodal_dofs[:, fixed_nodes].ravel()
    Ar, br, _, free = condense(A, b, D=fixed)
    c_asm = time.process_time() - c0
    keep = np.ones(mesh.p.shape[1], dtype=bool)
    keep[fixed_nodes] = False
    assert np.array_equal(free, np.sort(basis.nodal_dofs[:, keep].T.ravel()))   # whole nodes, interleaved
    B = rigid_modes(mesh.p[:, keep])
    c0 = time.process_time()
    ml = pyamg.smoothed_aggregation_solver(Ar.tobsr(blocksize=(3, 3)), B=B, symmetry="symmetric")
    c_setup = time.process_time() - c0
    res: list[float] = []
    c0 = time.process_time()
    x = ml.solve(br, tol=1e-10, accel="cg", maxiter=2000, residuals=res)
    c_solve = time.process_time() - c0
    out = {"unknowns": int(Ar.shape[0]), "nodes": int(mesh.p.shape[1]), "tets": int(mesh.t.shape[1]),
           "assembly_cpu_s": c_asm, "setup_cpu_s": c_setup, "solve_cpu_s": c_solve, "iterations": len(res) - 1,
           "residual": float(np.linalg.norm(br - Ar @ x) / np.linalg.norm(br)), "levels": len(ml.levels)}
    if check:
        xd = spla.spsolve(Ar.tocsc(), br)
        out["vs_direct"] = float(np.max(np.abs(x - xd)) / np.max(np.abs(xd)))
    return out


def one(n: int, check: bool) -> dict:
    n2 = max(2, round(0.7 * n))
    parts = [body(n, max(1, n // 2), 0.0, 0.5, True, check), body(n2, max(1, (n2 + 1) // 2), -0.5, 0.0, False, check)]
    out = {k: sum(p[k] for p in parts) for k in ("unknowns", "assembly_cpu_s", "setup_cpu_s", "solve_cpu_s")}
    out.update(n=n, bodies=parts, peak_gb=peak_gb())
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=float, nargs="+", default=[1e5])
    p.add_argument("--check", action="store_true", help="also a direct solve of each body (small sizes)")
    p.add_argument("--one", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.one:
        a = json.loads(args.one)
        print(json.dumps(one(a["n"], a["check"])))
        return
    for size in args.sizes:
        n = side_cells(size, 2.2)                    # bench3d.py's ``cells("two_boxes", size, elastic=True)``
        ld = load()
        r = run_part(__file__, {"n": n, "check": args.check})
        total = r["assembly_cpu_s"] + r["setup_cpu_s"] + r["solve_cpu_s"]
        print(f"n={n}: {r['unknowns']:,} unknowns; CPU s: assembly {r['assembly_cpu_s']:.1f}, AMG set-up "
              f"{r['setup_cpu_s']:.1f}, CG {r['solve_cpu_s']:.1f} (set-up + solve "
              f"{r['setup_cpu_s'] + r['solve_cpu_s']:.1f}, all {total:.1f}); peak {r['peak_gb']:.2f} GiB "
              f"({r['peak_gb'] * 2**20 / r['unknowns']:.2f} KiB/unknown); load {ld}", flush=True)
        for b in r["bodies"]:
            print("   ", json.dumps(b), flush=True)


if __name__ == "__main__":
    main()
