"""The strains of the fields read-back, the quad/hex estimate and the equilibrated bound formed without the strain
matrices (``fem.assembly.voigt_strains``) against with them (``strain_matrix(grad) @ ue`` cell by cell, as before),
in one process: the same solution read both ways.

``check``: on every scene of tests/scenes.py, every scene builder of tests/scenes3d.py (its defaults) and a Q1/Q2
quadrilateral and a Q1 hexahedral pair (the tensor-product estimate), max |new - old| / max |old| of each body's
strain, stress, von Mises stress, E and D (:func:`~cvxcontact.fem.fields.body_fields`), of the estimate's total and
indicators (:func:`~cvxcontact.solution.estimate.estimate`) and of the equilibrated bound
(:func:`cvxcontact.error_bound`, where covered).

``time``: CPU seconds (one thread; best of ``--repeats``, old and new alternating) of the strains alone at the cells'
centres, the fields of every body and the estimate on ``apps.demo.two_blocks(560)`` (P1 triangles; the same bodies on Q1 quadrilaterals) and on 3D pairs
(``tests/scenes3d.two_boxes(n)``, P1 tetrahedra, and two_boxes(n / 2), P2; a Q1 hexahedral pair).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/strains_readback.py check
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/strains_readback.py time
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the scenes

import numpy as np

import cvxcontact as cc
from cvxcontact.errors import CvxContactError, UnsupportedError
from cvxcontact.fem import assembly, fields
from cvxcontact.fem.space import space, space_of
from cvxcontact.solution import equilibration, tensorestimate
from cvxcontact.solution.estimate import estimate

USERS = (fields, tensorestimate, equilibration)
NEW = assembly.voigt_strains


def through_matrices(grad, ue):
    """The Voigt strains as the read-back formed them before: the strain matrices applied cell by cell."""
    return np.einsum("mij,mj->mi", assembly.strain_matrix(grad), np.asarray(ue).reshape(len(ue), -1))


def use(f):
    for module in USERS:
        module.voigt_strains = f


def read(sol):
    """(fields per body, estimate, bound or None) of ``sol``."""
    out = []
    for b, u, p in zip(sol.scene.bodies, sol.u, sol.phi):
        f = fields.body_fields(b, u, p, space(sol.degree, b.mesh.cell).nodes(b))
        out.append({k: v for k, v in vars(f).items() if v is not None})
    est = estimate(sol)[0]
    try:
        bound = cc.error_bound(sol)
    except UnsupportedError:
        bound = None
    return out, est, bound


def rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.abs(b).max(initial=0.0)
    d = np.abs(a - b).max(initial=0.0)
    return d / scale if scale > 0 else d


def differences(sol) -> tuple[float, float, float, float, float | None]:
    """(fields, D, estimate, estimate / norm, bound or None): max |new - old| / max |old| over the scene's bodies
    per field (strain, stress, von Mises, E; the largest), D's against the size of its terms (max |e| max |eps| +
    max |kappa| max |E|: a D of rounding size, a layer's D that vanishes, stays rounding), the estimate's total and
    indicators (each against its own largest value, and against the energy norm |||u_h|||: an estimate that is
    rounding, a solution the elements represent exactly, differs in its own leading digits), the bound's."""
    use(through_matrices)
    f0, e0, b0 = read(sol)
    use(NEW)
    f1, e1, b1 = read(sol)
    df = dD = 0.0
    for key in ("strain", "stress", "von_mises", "electric_field"):
        pairs = [(a[key], b[key]) for a, b in zip(f1, f0) if key in b]
        if pairs:
            scale = max(np.abs(b).max() for _, b in pairs)
            d = max(np.abs(a - b).max() for a, b in pairs)
            df = max(df, d / scale if scale > 0 else d)
    terms = [0.0]
    for body, a, b in zip(sol.scene.bodies, f1, f0):
        if "electric_displacement" in b:
            _, e, kappa = body.material.tensors(sol.scene.dim)
            terms.append(np.abs(e).max() * np.abs(b["strain"]).max() * 2
                         + np.abs(kappa).max() * np.abs(b["electric_field"]).max())
            dD = max(dD, np.abs(a["electric_displacement"] - b["electric_displacement"]).max())
    dD = dD / max(terms) if max(terms) > 0 else dD
    de = max([rel(e1.absolute, e0.absolute)] + [rel(x, y) for x, y in zip(e1.indicators, e0.indicators)])
    dn = max(np.abs(np.concatenate(e1.indicators) - np.concatenate(e0.indicators)).max(),
             abs(e1.absolute - e0.absolute)) / e0.norm
    db = None
    if b0 is not None:
        db = max([rel(b1.absolute, b0.absolute)] + [rel(x, y) for x, y in zip(b1.indicators, b0.indicators)])
    return df, dD, de, dn, db


def tensor_scenes():
    """A Q1 and a Q2 quadrilateral pair (tests/conftest.two_blocks' bodies on quadrilaterals) and a Q1 hexahedral
    pair (tests/hex_scenes.py; uniformly pressed, which Q1 represents exactly: its estimate is rounding, and under
    a tilted gap, partly open): the tensor-product estimate."""
    from conftest import two_blocks
    from hex_scenes import PUSH, TILTED, nested

    quads = quad_bodies(two_blocks((8, 4), (5, 3)))
    return {"two blocks, Q1 quadrilaterals": (lambda: quads, {}),
            "two blocks, Q2 quadrilaterals": (lambda: quads, {"degree": 2}),
            "hexahedral pair (skewed 4 on 2), uniform": (lambda: nested("skewed 4 on 2")[0], {}),
            "hexahedral pair (skewed 4 on 2), tilted gap": (lambda: nested("skewed 4 on 2", gap=TILTED, push=PUSH)[0],
                                                            {})}


def quad_bodies(scene):
    """``scene`` with each body's mesh (a rectangle's triangles) on quadrilaterals of the same box and counts."""
    bodies = []
    for b in scene.bodies:
        lo, hi = b.mesh.points.min(axis=0), b.mesh.points.max(axis=0)
        nx = len(np.unique(b.mesh.points[:, 0])) - 1
        ny = len(np.unique(b.mesh.points[:, 1])) - 1
        mesh = cc.rectangle(x=(lo[0], hi[0]), y=(lo[1], hi[1]), nx=nx, ny=ny, cell="quad")
        bodies.append(b.with_changes(mesh=mesh))
    return scene.with_bodies(*bodies)


def all_scenes():
    import scenes3d
    from scenes import SCENES

    out = dict(SCENES)
    for name, build in scenes3d.default_builders().items():
        out[f"3D {name}"] = (build, {})
    out.update(tensor_scenes())
    return out


def check() -> None:
    print("| scene | fields | D | estimate | estimate / norm | bound |")
    print("|---|---|---|---|---|---|")
    worst = [0.0] * 5
    for name, (build, options) in all_scenes().items():
        try:
            scene = build()
        except (TypeError, CvxContactError) as exc:   # a helper of scenes3d, or a builder needing other arguments
            print(f"| {name} | not built with its defaults: {type(exc).__name__} | | | | |")
            continue
        if not isinstance(scene, cc.Scene):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sol = cc.solve(scene, **options)
            except CvxContactError as exc:
                print(f"| {name} | not solved with its defaults: {type(exc).__name__} | | | | |")
                continue
        d = differences(sol)
        worst = [max(w, x or 0.0) for w, x in zip(worst, d)]
        print("| " + name + " | " + " | ".join("-" if x is None else f"{x:.1e}" for x in d) + " |", flush=True)
    print("| worst | " + " | ".join(f"{x:.1e}" for x in worst) + " |")


def cpu(f, repeats):
    best = np.inf
    for _ in range(repeats):
        t = time.process_time()
        f()
        best = min(best, time.process_time() - t)
    return best


def timed(label, sol, repeats):
    def fields_of():
        for b, u, p in zip(sol.scene.bodies, sol.u, sol.phi):
            fields.body_fields(b, u, p, space(sol.degree, b.mesh.cell).nodes(b))

    centres = [(space_of(b, n).centre_gradients(b, n), u) for b, u, n in
               ((b, u, space(sol.degree, b.mesh.cell).nodes(b)) for b, u in zip(sol.scene.bodies, sol.u))]

    def strains_of():                          # the strains alone, at the cells' centres (as the fields read them)
        for (el, grad), u in centres:
            fields.voigt_strains(grad, np.asarray(u)[el])

    jobs = {"strains": strains_of, "fields": fields_of, "estimate": lambda: estimate(sol)}
    cells = sum(len(b.mesh.cells) for b in sol.scene.bodies)
    for job, f in jobs.items():
        old = new = np.inf
        for _ in range(repeats):               # alternating, so that the machine's load hits both alike
            use(through_matrices)
            old = min(old, cpu(f, 1))
            use(NEW)
            new = min(new, cpu(f, 1))
        print(f"| {label} | {cells:,} | {job} | {old:.3f} | {new:.3f} | {old / new:.2f} |", flush=True)


def timing(repeats: int, n3: int, nhex: int, only3d: bool = False) -> None:
    import scenes3d
    from hex_scenes import pair

    from cvxcontact.apps import demo

    print("| scene | cells | read | before (CPU s) | after (CPU s) | before / after |")
    print("|---|---|---|---|---|---|")
    if not only3d:
        tri = demo.two_blocks(560)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = cc.solve(tri, estimate=False)
        timed("two_blocks(560), P1 triangles", sol, repeats)
        del sol
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = cc.solve(quad_bodies(tri), estimate=False)
        timed("two_blocks(560), Q1 quadrilaterals", sol, repeats)
        del sol
    for degree, n in ((1, n3), (2, n3 // 2)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = cc.solve(scenes3d.two_boxes(n), degree=degree, estimate=False)
        timed(f"3D two_boxes({n}), P{degree} tetrahedra", sol, repeats)
        del sol
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = cc.solve(pair(cc.box(z=(0.0, 0.5), nx=2 * nhex, ny=2 * nhex, nz=nhex, cell="hex"),
                            cc.box(z=(0.5, 1.0), nx=nhex, ny=nhex, nz=nhex, cell="hex")), estimate=False)
    timed(f"3D hexahedral pair ({2 * nhex}^2 x {nhex} on {nhex}^3), Q1", sol, repeats)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("what", choices=("check", "time"))
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--n3", type=int, default=24, help="two_boxes(n) of the 3D timing (P1; P2: n / 2)")
    p.add_argument("--only3d", action="store_true", help="the 3D scenes only")
    p.add_argument("--nhex", type=int, default=12, help="the hexahedral pair: 2n x 2n x n under n x n x n")
    args = p.parse_args()
    print(cc.__file__)
    check() if args.what == "check" else timing(args.repeats, args.n3, args.nhex, args.only3d)


if __name__ == "__main__":
    main()
