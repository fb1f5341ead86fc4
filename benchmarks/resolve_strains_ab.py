"""The estimate's strains from component-major copies (h-resolve3: ``Geometry.rows``, ``voigt_strain_rows``)
against the base commit's (``voigt_strains``' einsum over strided columns of the element displacements gathered
node-major), and the held rows shared by a load case against formed again, interleaved in ONE process.

Scene: ``apps.demo.two_blocks(nx)``, solved once by a ContactSolver (its estimate's Geometry kept). Then ``rounds``
rounds, each timing (process CPU ms) the whole ``estimate`` of that solution once with each side's ``_fields``
(order alternating; "before": the base commit's ``_fields`` and ``_strains`` read from git and run in a module of
their own on the gradients and dofs in the base's layout, formed before the rounds: ``base_layout``), and
``held_rows`` of the problem's rows. Prints the medians, the ratio, and the estimates' agreement (absolute, parts,
indicators: identical or the largest relative difference).

Run (one thread):
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/resolve_strains_ab.py 560 15
"""

import statistics
import subprocess
import sys
import time
import types
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import two_blocks_solver

from cvxcontact.discrete.problem import held_rows
from cvxcontact.solution import estimate as est

BASE = "aa68273b"
ROOT = Path(__file__).resolve().parents[1]


def base_fields(base):
    """``_fields`` of ``base``'s cvxcontact/solution/estimate.py (with its ``_strains``), in a module of its own."""
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{base}:cvxcontact/solution/estimate.py"],
                            capture_output=True, text=True, check=True).stdout
    for old, new in (("from ..", "from cvxcontact."), ("from . import", "from cvxcontact.solution import"),
                     ("from .", "from cvxcontact.solution.")):
        source = source.replace(old, new)
    module = sys.modules["estimate_base"] = types.ModuleType("estimate_base")
    exec(compile(source, f"{base}:estimate.py", "exec"), module.__dict__)    # noqa: S102 (this repository's own code)
    return module._fields


def base_layout(g):
    """What the base commit's ``_fields`` read of a Geometry, in its layout: the barycentric gradients (m, d, d + 1)
    contiguous, G (m, q, d, k) contiguous (P1: a view of them, as ``corner_gradients`` returns it), the node-major
    ``dofs`` (m, k d)."""
    k, dim = g.el.shape[1], g.dim
    gradL = np.ascontiguousarray(g.gradL)
    G = gradL[:, None] if g.G.shape[1] == 1 else np.ascontiguousarray(g.G)
    dofs = (dim * g.el[:, :, None] + np.arange(dim)).reshape(len(g.el), k * dim).astype(np.int32)
    return types.SimpleNamespace(G=G, gradL=gradL, dofs=dofs, el=g.el, tensors=g.tensors, measure=g.measure)


def main():
    warnings.simplefilter("ignore")
    nx, rounds = int(sys.argv[1]), int(sys.argv[2])
    base = sys.argv[3] if len(sys.argv) > 3 else BASE
    fields, layouts = base_fields(base), {}

    def before(g, u, phi):
        return fields(layouts[id(g)], u, phi)              # (the layouts formed before the rounds)

    sides = {"before": before, "after": est._fields}
    scene, solver, first = two_blocks_solver(nx)
    sol = solver.solve(scene.with_loads(0, body_force=(0.0, -2e9 * 0.37)))
    problem = solver.problem
    layouts.update({id(g): base_layout(g) for g in solver._geometry.values()})
    t = {"before": [], "after": [], "held": []}
    answers = {}
    for r in range(rounds):
        for side in (("before", "after") if r % 2 == 0 else ("after", "before")):
            est._fields = sides[side]
            c0 = time.process_time()
            answers[side], _ = est.estimate(sol, cache=solver._geometry, fingerprints=problem.fingerprints)
            t[side].append(time.process_time() - c0)
        c0 = time.process_time()
        held_rows(problem.E, problem.blocks, problem.translations)
        t["held"].append(time.process_time() - c0)
    est._fields = sides["after"]
    med = {k: 1e3 * statistics.median(v) for k, v in t.items()}
    print(f"two_blocks({nx}): first solve {first:.2f} CPU s; {rounds} rounds, base {base}")
    print(f"  estimate of one solution: before {med['before']:.1f} ms ({1e3 * min(t['before']):.1f}-"
          f"{1e3 * max(t['before']):.1f}), after {med['after']:.1f} ms ({1e3 * min(t['after']):.1f}-"
          f"{1e3 * max(t['after']):.1f}), ratio {med['after'] / med['before']:.3f}; held_rows formed "
          f"{med['held']:.2f} ms (a load case of the same rows now shares it)")
    a, b = answers["after"], answers["before"]
    same = (a.absolute == b.absolute and a.norm == b.norm and a.parts == b.parts
            and all(np.array_equal(x, y) for x, y in zip(a.indicators, b.indicators)))
    print("  after vs before: " + ("identical (absolute, norm, parts, indicators)" if same else
                                   f"absolute {abs(a.absolute - b.absolute) / b.absolute:.1e} relative"))


if __name__ == "__main__":
    main()
