"""Benchmark helper: does the sparse route's answer depend on its clock? The timed cap
(``SparseContact._over_cap``) chooses between refactorising K(A) and the capacitance columns by
``time.perf_counter``, so the sets factorised and the systems solved follow the machine's speed. Each clock here is
one fresh ``ContactSolver(method="sparse")``: the real clock, then virtual clocks (each perf_counter call of
cvxcontact/backends/sparse.py advances 1, a numeric factorisation, SuperLU's or PARDISO's, ``cost`` more: the
timed cap about 1.5 cost, within 16..500), a first solve and a re-solve at 1.3 times the loads; sha256 (first 12
hex digits) of u, phi and every pair's contact force of both, with the systems solved, factorisations and column
solves of the first. One scene and factorisation per process:

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONPATH=. \
        python benchmarks/sparse_clock_bits.py thin_layer:400 superlu [costs, default 0,10,30,100,300,1000]

Scenes: ``thin_layer:<n>`` (cvxcontact.apps.demo, "gamma3"; the re-solve at 1.3 times its pressure),
``two_boxes:<n>`` (tests/scenes3d.py, "sigma1"; 1.3 times its body force), ``sphere:<n>``
(tests/scenes3d.py sphere_into_block; the re-solve adds a body force of 1e9 N/m^3 downwards).
Results: benchmarks/results/sparse_clock_bits.md.
"""
import hashlib
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import cvxcontact as cc
import cvxcontact.backends.factor as factor_mod
import cvxcontact.backends.sparse as sparse_mod
from cvxcontact.apps.demo import thin_layer

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))          # scenes3d

NOW, COST = [0.0], [0.0]


def virtual() -> float:
    NOW[0] += 1.0
    return NOW[0]


def slow(call):
    """``call`` advancing the virtual clock by COST after it returns (a numeric factorisation)."""
    def timed(*args, **kwargs):
        out = call(*args, **kwargs)
        NOW[0] += COST[0]
        return out
    return timed


def scenes(name: str, scale: float):
    kind, n = name.split(":")
    if kind == "thin_layer":
        return thin_layer(int(n), pressure=1e6 * scale), "gamma3"
    from scenes3d import sphere_into_block, two_boxes
    if kind == "sphere":                  # the block pressed by the sphere, then under its weight's 1e9 N/m^3 too
        scene = sphere_into_block(int(n))
        return (scene if scale == 1.0 else scene.with_loads(0, body_force=(0.0, 0.0, -1e9))), "sigma1"
    scene = two_boxes(int(n), condition="sigma1")
    return scene.with_loads(0, body_force=(0.0, 0.0, -2e9 * scale)), "sigma1"


def main():
    name, fact = sys.argv[1], sys.argv[2]
    costs = [float(c) for c in (sys.argv[3] if len(sys.argv) > 3 else "0,10,30,100,300,1000").split(",")]
    warnings.simplefilter("ignore")
    sparse_mod.factorize = slow(sparse_mod.factorize)
    factor_mod.PardisoSymmetric.factor = slow(factor_mod.PardisoSymmetric.factor)
    (first, cond), (again, _) = scenes(name, 1.0), scenes(name, 1.3)
    hashes = {}
    for label in ["real"] + [f"cost {c:g}" for c in costs]:
        if label == "real":
            sparse_mod.time = time
        else:
            COST[0] = float(label.split()[1])
            sparse_mod.time = SimpleNamespace(perf_counter=virtual)
        solver = cc.ContactSolver(first, cond, method="sparse", factorization=fact, estimate=False)
        h, row = hashlib.sha256(), []
        for scene in (first, again):
            sol = solver.solve(scene)
            sc = solver._cache.sparse
            assert sol.ok and sol.info.method == "sparse", (sol.info.method, sol.info.route)
            for a in [*sol.u, *(p for p in sol.phi if p is not None), *(c.force for c in sol.contacts)]:
                h.update(np.ascontiguousarray(a).tobytes())
            row.append((sol.info.iterations, sc.factorizations, sc.column_solves))
        hashes[label] = h.hexdigest()[:12]
        print(f"| {name} | {fact} | {label} | {hashes[label]} | {row[0][0]} / {row[1][0]} | "
              f"{row[0][1]} / {row[1][1]} | {row[0][2]} / {row[1][2]} |", flush=True)
    sparse_mod.time = time
    print(f"{name} {fact}: {len(set(hashes.values()))} distinct hash(es) over {len(hashes)} clocks")


if __name__ == "__main__":
    main()
