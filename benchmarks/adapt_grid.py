"""Benchmark: adaptive against uniform refinement on tensor grids of quadrilaterals (Q1, Q2) and hexahedra (Q1):
the energy estimate against unknowns and CPU seconds.

2D: a rigid circle (R = 0.6 m) pressed 3 mm into an aluminium block 1 m x 0.5 m, clamped at the bottom
(tests/test_adapt_grid.py's ``indentation``), started from 8 x 4 cells. Adaptive: ``cc.adapt`` with the loop's
defaults for the degree (cvxcontact.adapt.LOOPS), the strips through the marked cells halved once a step
(cvxcontact.geometry.grid.refine_grid), up to ``--unknowns``. Uniform: n x n/2 grids, n = 8 .. ``--n``.
3D: a rigid sphere (R = 0.5 m) pressed 20 mm into an aluminium block 1 m x 1 m x 0.5 m of 4 x 4 x 2 Q1 hexahedra,
"sigma1" (Q1 hexahedra take "gamma3" against planes only), adaptive against uniform 4 x 4 x 2 .. 16 x 16 x 8.
Times: CPU seconds (``time.process_time``); adaptive: the sum over the steps up to that mesh (solve, estimate,
marking, refinement); uniform: its solve with the estimate. Run single-threaded:

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/adapt_grid.py

The numbers of a run are in benchmarks/results/adapt_grid.md and docs/accuracy.md ("Tensor grids").
"""

from __future__ import annotations

import argparse
import time
import warnings

import cvxcontact as cc

ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def indentation(nx, ny):
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny, cell="quad"), ALU, clamped="bottom",
                    contact="top", name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, 0.5 + 0.6 - 3e-3), 0.6))])


def pressed_box(n):
    block = cc.Body(cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=n // 2, cell="hex"), ALU,
                    clamped="bottom", contact="top", name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.sphere((0.47, 0.5, 0.5 + 0.5 - 0.02), 0.5))])


def rows(label, scene_of, sizes, condition, unknowns, steps, **options):
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        t = time.process_time()
        result = cc.adapt(scene_of(sizes[0]), condition, max_steps=steps, max_unknowns=unknowns, **options)
        total = 0.0
        for s in result.history:
            total += s.cpu_s
            out.append((label, "adapt", s.step, s.cells, s.unknowns, s.estimate, s.relative, total))
        for n in sizes:
            t = time.process_time()
            sol = cc.solve(scene_of(n), condition, **options)
            cells = sum(len(b.mesh.cells) for b in sol.scene.bodies)
            out.append((label, "uniform", n, cells, sum(u.size for u in sol.u), sol.estimate.absolute,
                        sol.estimate.relative, time.process_time() - t))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--unknowns", type=int, default=50_000)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--hex-n", type=int, default=16)
    args = ap.parse_args()
    sizes = [n for n in (8, 16, 32, 64, 128, 256) if n <= args.n]
    table = rows("Q1 quad", lambda n: indentation(n, n // 2), sizes, "gamma3", args.unknowns, 20, degree=1)
    table += rows("Q2 quad", lambda n: indentation(n, n // 2), sizes, "gamma3", args.unknowns, 20, degree=2)
    table += rows("Q1 hex", pressed_box, [n for n in (4, 8, 16, 32) if n <= args.hex_n], "sigma1",
                  args.unknowns, 20, degree=1)
    print("| case | series | step / n | cells | unknowns | estimate sqrt(J) | relative | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for label, series, k, cells, unknowns, est, rel, cpu in table:
        print(f"| {label} | {series} | {k} | {cells} | {unknowns} | {est:.4g} | {rel:.3g} | {cpu:.2f} |")


if __name__ == "__main__":
    main()
