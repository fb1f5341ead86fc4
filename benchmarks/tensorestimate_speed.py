"""The residual estimate on quadrilaterals and hexahedra (``solution/tensorestimate.py``) before and after its
vectorisation, in one process: the module as it was (read from git at :data:`BEFORE`, loaded beside the package)
against the package's.

``check``: on every scene of tests/scenes.py and every scene builder of tests/scenes3d.py (its defaults) built on
quadrilaterals / hexahedra (``cc.rectangle`` and ``cc.box`` called with ``cell="quad"`` / ``"hex"`` while the scene
is built; a builder whose meshes come from elsewhere keeps its triangles, a scene the package does not solve on
quadrilaterals or hexahedra is listed as such), the hexahedral pairs of tests/hex_scenes.py (warped cells) and
warped piezoelectric patches: the estimate's total, its parts and per-cell indicators old and new, as max |new -
old| / max |old| and against the energy norm |||u_h|||.

``time``: CPU seconds (one thread; best of ``--repeats``, old and new alternating) of the whole estimate
(``solution.estimate.estimate``: the geometry built afresh, the element, facet and contact terms) on
``apps.demo.two_blocks(n)`` on P1 triangles and on Q1 quadrilaterals (the same bodies, nodes and unknowns), and
on a 3D pair of boxes on P1 tetrahedra and on Q1 hexahedra (``tests/hex_scenes.pair``, the same counts).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/tensorestimate_speed.py check
    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/tensorestimate_speed.py time
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))                     # this checkout
sys.path.insert(0, str(ROOT / "tests"))           # the scenes

import numpy as np

import cvxcontact as cc
from cvxcontact.errors import CvxContactError
from cvxcontact.fem.quad import TensorElement
from cvxcontact.solution import estimate as estimate_module
from cvxcontact.solution.estimate import estimate

BEFORE = "6af2c7b"
"""The commit whose ``solution/tensorestimate.py`` is the reference (the module before its vectorisation)."""
PATH = "cvxcontact/solution/tensorestimate.py"


def before(path, name):
    """The module ``path`` of the package at :data:`BEFORE`, loaded as ``name`` beside the package's own."""
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{BEFORE}:{path}"], check=True, capture_output=True,
                            text=True).stdout
    file = Path(tempfile.mkdtemp()) / Path(path).name
    file.write_text(source)
    spec = importlib.util.spec_from_file_location(name, file)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


NEW = estimate_module.GEOMETRIES["quad"], TensorElement.locate
OLD = (before(PATH, "cvxcontact.solution._tensorestimate_before").TensorGeometry,
       before("cvxcontact/fem/quad.py", "cvxcontact.fem._quad_before").TensorElement.locate)
"""(the estimate's geometry, Newton's method locating the contact traces' points in the cells) new and old."""


def use(which):
    geometry, TensorElement.locate = which
    for cell in ("quad", "hex"):
        estimate_module.GEOMETRIES[cell] = geometry


def both(sol):
    use(OLD)
    old = estimate(sol)[0]
    use(NEW)
    return old, estimate(sol)[0]


@contextlib.contextmanager
def tensor_meshes():
    """``cc.rectangle`` and ``cc.box`` building quadrilaterals and hexahedra (whatever cell the caller asks)."""
    rectangle, box = cc.rectangle, cc.box
    cc.rectangle = lambda *a, **k: rectangle(*a, **{**k, "cell": "quad"})
    cc.box = lambda *a, **k: box(*a, **{**k, "cell": "hex"})
    try:
        yield
    finally:
        cc.rectangle, cc.box = rectangle, box


def rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.abs(b).max(initial=0.0)
    d = np.abs(a - b).max(initial=0.0)
    return d / scale if scale > 0 else d


def compare(old, new) -> tuple[float, float, float, float, float, bool]:
    """(total, indicators: max |new - old| / max |old|; the parts and the squared indicators eta_T^2 against
    |||u_h|||^2 + eta^2 (the sums the estimate adds, against the squared energy norm and the estimate's own);
    the norm's difference; the size of the estimate against the norm (rounding: a state the elements represent
    exactly); every number bit for bit)."""
    dt = rel(new.absolute, old.absolute)
    di = max(rel(a, b) for a, b in zip(new.indicators, old.indicators))
    n2 = old.norm ** 2 + old.absolute ** 2
    dp = max(abs(new.parts[k] - old.parts[k]) for k in old.parts) / n2
    de = max(np.abs(np.concatenate(new.indicators) ** 2 - np.concatenate(old.indicators) ** 2).max(),
             abs(new.absolute ** 2 - old.absolute ** 2)) / n2
    same = (new.absolute == old.absolute and new.norm == old.norm and new.parts == old.parts
            and all(np.array_equal(a, b) for a, b in zip(new.indicators, old.indicators)))
    return dt, di, max(dp, de), rel(new.norm, old.norm), old.absolute / old.norm, same


def warped_patch(cell, degree):
    """A warped block of PZT-5A (tests/test_tensor_estimate.py's piezoelectric patch: rollers, grounded bottom,
    200 V on top, pressed by a plane) with a body force and a volume charge: every electric term, the divergence
    on cells that are not parallelograms."""
    n = 3
    mesh = cc.rectangle(nx=n, ny=n, cell="quad") if cell == "quad" else cc.box(nx=n, ny=n, nz=n, cell="hex")
    p = mesh.points.copy()
    inner = np.setdiff1d(np.arange(len(p)), mesh.boundary_nodes(mesh.tags))
    p[inner] += np.random.default_rng(0).uniform(-0.15, 0.15, (len(inner), p.shape[1])) / n
    mesh = mesh.with_points(p)
    dim = mesh.dim
    rollers = {"quad": ["left", "bottom"], "hex": ["left", "front", "bottom"]}[cell]
    top = np.eye(dim)[dim - 1]
    body = cc.Body(mesh, cc.materials.PZT5A, roller=rollers, grounded=["bottom"], potential={"top": 200.0},
                   contact="top", body_force=tuple(-2e9 * top), volume_charge=1e-3)
    plane = cc.Rigid.plane(tuple(top * (1.0 - 1e-6)), tuple(-top))
    return cc.Scene(body, contacts=[cc.Contact(body, "top", plane)]), {"condition": "sigma1", "degree": degree}


def all_scenes():
    import hex_scenes
    import scenes3d
    from scenes import SCENES

    out = {f"{name} (quadrilaterals)": item for name, item in SCENES.items()}
    for name, build in scenes3d.default_builders().items():
        out[f"3D {name} (hexahedra)"] = (build, {})
    for label in hex_scenes.NESTED:
        out[f"hex_scenes {label}, uniform"] = (lambda label=label: hex_scenes.nested(label)[0], {})
        out[f"hex_scenes {label}, tilted gap"] = (
            lambda label=label: hex_scenes.nested(label, gap=hex_scenes.TILTED, push=hex_scenes.PUSH)[0], {})
    out["hex_scenes skewed 4 on 2, Q2 tilted gap"] = (
        lambda: hex_scenes.nested("skewed 4 on 2", gap=hex_scenes.TILTED, push=hex_scenes.PUSH)[0],
        {"degree": 2, "condition": "sigma1"})
    for cell in ("quad", "hex"):
        for degree in (1, 2):
            out[f"warped PZT patch, {cell} Q{degree}"] = (lambda c=cell, d=degree: warped_patch(c, d)[0],
                                                         warped_patch(cell, degree)[1])
    return out


def check() -> None:
    print("| scene | cells (tensor) | total | indicators | parts, eta_T^2 / (norm^2 + eta^2) | norm | estimate / norm "
          "| bit for bit |")
    print("|---|---|---|---|---|---|---|---|")
    worst = [0.0] * 4
    for name, (build, options) in all_scenes().items():
        try:
            with tensor_meshes():
                scene = build()
        except (TypeError, CvxContactError) as exc:
            print(f"| {name} | not built: {type(exc).__name__} | | | | | | |")
            continue
        if not isinstance(scene, cc.Scene):
            continue
        tensor = sum(len(b.mesh.cells) for b in scene.bodies if b.mesh.cell in ("quad", "hex"))
        if not tensor:
            print(f"| {name} | no quadrilaterals or hexahedra (its meshes are not rectangles or boxes) | | | | | | |")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sol = cc.solve(scene, **options, estimate=False)
            except CvxContactError as exc:
                print(f"| {name} | not solved on these cells: {type(exc).__name__} | | | | | | |")
                continue
        d = compare(*both(sol))
        worst = [max(w, x) for w, x in zip(worst, d[:4])]
        print(f"| {name} | {tensor:,} | " + " | ".join(f"{x:.1e}" for x in d[:5]) + f" | {'yes' if d[5] else 'no'} |",
              flush=True)
    print("| worst | | " + " | ".join(f"{x:.1e}" for x in worst) + " | | |")


def cpu(f) -> float:
    t = time.process_time()
    f()
    return time.process_time() - t


def timed(label, sol, repeats, reference=None):
    """One row: the estimate's CPU seconds old and new (best of ``repeats``, alternating), per unknown against
    ``reference`` (CPU s per unknown of the simplices' estimate), the agreement."""
    unknowns = sum(np.size(u) + (0 if p is None else np.size(p)) for u, p in zip(sol.u, sol.phi))
    cells = sum(len(b.mesh.cells) for b in sol.scene.bodies)
    tensor = sol.scene.bodies[0].mesh.cell in ("quad", "hex")
    old = new = np.inf
    for _ in range(repeats):
        if tensor:
            use(OLD)
            old = min(old, cpu(lambda: estimate(sol)))
        use(NEW)
        new = min(new, cpu(lambda: estimate(sol)))
    per = new / unknowns
    ratio = "" if reference is None else f"{per / reference:.2f}"
    agree = f"{compare(*both(sol))[1]:.1e}" if tensor else ""
    print(f"| {label} | {cells:,} | {unknowns:,} | " + (f"{old:.3f}" if tensor else "-") + f" | {new:.3f} | "
          + (f"{old / new:.1f}" if tensor else "-") + f" | {ratio} | {agree} |", flush=True)
    return per


def solved(scene, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return cc.solve(scene, estimate=False, **options)


def timing(repeats: int, n: int, nhex: int) -> None:
    from hex_scenes import pair

    from cvxcontact.apps import demo

    print("| scene | cells | unknowns | before (CPU s) | after (CPU s) | before / after | after per unknown / "
          "simplices' | indicators max rel. diff. |")
    print("|---|---|---|---|---|---|---|---|")
    tri = demo.two_blocks(n)
    ref = timed(f"two_blocks({n}), P1 triangles", solved(tri), repeats)
    timed(f"two_blocks({n}), Q1 quadrilaterals", solved(quads(tri)), repeats, ref)
    timed(f"two_blocks({n // 2}), Q2 quadrilaterals", solved(quads(demo.two_blocks(n // 2)), degree=2), repeats, ref)

    def boxes(cell):
        return pair(cc.box(z=(0.0, 0.5), nx=2 * nhex, ny=2 * nhex, nz=nhex, cell=cell),
                    cc.box(z=(0.5, 1.0), nx=nhex, ny=nhex, nz=nhex, cell=cell))
    ref3 = timed(f"boxes {2 * nhex}^2 x {nhex} on {nhex}^3, P1 tetrahedra", solved(boxes("tetra")), repeats)
    timed(f"boxes {2 * nhex}^2 x {nhex} on {nhex}^3, Q1 hexahedra", solved(boxes("hex")), repeats, ref3)
    h2 = nhex // 2                                 # Q2: the contact faces meshed alike (sigma1 rows)
    timed(f"boxes {h2}^3 on {h2}^3, Q2 hexahedra", solved(pair(
        cc.box(z=(0.0, 0.5), nx=h2, ny=h2, nz=h2, cell="hex"), cc.box(z=(0.5, 1.0), nx=h2, ny=h2, nz=h2, cell="hex")),
        degree=2, condition="sigma1"), repeats, ref3)


def quads(scene):
    """``scene`` with each body's mesh (a rectangle's triangles) on quadrilaterals of the same box and counts."""
    bodies = []
    for b in scene.bodies:
        lo, hi = b.mesh.points.min(axis=0), b.mesh.points.max(axis=0)
        nx, ny = (len(np.unique(b.mesh.points[:, i])) - 1 for i in (0, 1))
        bodies.append(b.with_changes(mesh=cc.rectangle(x=(lo[0], hi[0]), y=(lo[1], hi[1]), nx=nx, ny=ny,
                                                       cell="quad")))
    return scene.with_bodies(*bodies)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("what", choices=("check", "time"))
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--n", type=int, default=560, help="apps.demo.two_blocks(n) (Q2: n / 2)")
    p.add_argument("--nhex", type=int, default=12, help="the 3D pair: 2n x 2n x n under n x n x n (Q2: n / 2)")
    args = p.parse_args()
    print(cc.__file__)
    check() if args.what == "check" else timing(args.repeats, args.n, args.nhex)


if __name__ == "__main__":
    main()
