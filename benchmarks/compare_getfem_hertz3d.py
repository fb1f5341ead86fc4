"""The closest-point posing of a curved rigid obstacle against GetFEM (issue 29 item 3): the 3D Hertz quarter
block (cvxcontact.apps.studies.hertz3d, P1, condition "gamma3", DISPLACEMENT control: the sphere fixed at
Hertz's approach at the design force) solved by cvxcontact with ``distance="closest"`` and ``distance="ray"``
and by GetFEM on the same mesh.

NOT part of CI: the GetFEM half (benchmarks/getfem_hertz3d_side.py) needs Debian's GetFEM
(``apt-get install python3-getfem``, 5.4) and runs under the system interpreter (its numpy ABI differs from the
venv's); the two processes exchange plain npz files (no pickle) in a temporary directory.

    PYTHONPATH=. /work/venv/bin/python benchmarks/compare_getfem_hertz3d.py [--levels 4 8 12]
        [--python3 /usr/bin/python3] [--out benchmarks/results/getfem_hertz3d.md]

GetFEM poses the sphere three ways (see the side script): its nodal rigid-obstacle brick (rows at the contact
nodes, gap the signed distance d(x) = |x - c| - R, direction minus the gradient of d by a FORWARD difference of
step 1e-3 x the node's cell radius: GetFEM's own normal), and its basic contact brick with the radial rows in
closed form (like for like with "closest") or the vertical rows and vertical distance (like for like with
"ray"). Compared: the vertical force on the quarter (GetFEM's: the z-sum of K u over the contact nodes with
its own stiffness K; cvxcontact's: the obstacle's resultant, ``hertz3d.total_force`` / 4, and the same GetFEM
sum applied to cvxcontact's u, an independent read), max |u_getfem - u_cvx| / max |u|.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import cvxcontact as cc  # noqa: E402
from cvxcontact.apps.studies import hertz3d  # noqa: E402

SIDE = Path(__file__).with_name("getfem_hertz3d_side.py")
POSINGS = ("closest", "ray")
LIKE = {"closest": "radial", "ray": "vertical"}


def export(n: int, path: Path) -> dict:
    """Solve the scene at level ``n`` with both posings; write GetFEM's input to ``path``; return cvxcontact's
    answers (force on the quarter (N), u (N, 3) m)."""
    scenes = {p: hertz3d.scene(n, distance=p) for p in POSINGS}
    body = scenes["closest"].bodies[0]
    mesh = body.mesh
    # the GetFEM side holds every component on "bottom", u_x on "left" (x = 0), u_y on "front" (y = 0): the
    # study's Body must say the same (node by node: free components 0 on the bottom, 1 on both roller faces
    # (their common edge), 2 on one of them, 3 elsewhere)
    held = np.zeros((len(mesh.points), 3), dtype=bool)
    held[mesh.boundary_nodes("bottom")] = True
    held[mesh.boundary_nodes("left"), 0] = True
    held[mesh.boundary_nodes("front"), 1] = True
    free = body.node_supports()[0]
    assert np.array_equal(free, 3 - held.sum(axis=1)), "the study's supports changed: update the GetFEM side"
    assert np.allclose(mesh.points[mesh.boundary_nodes("left"), 0], 0) and np.allclose(
        mesh.points[mesh.boundary_nodes("front"), 1], 0)
    sphere = scenes["closest"].obstacles[0].obstacle
    out = {}
    for p, scene in scenes.items():
        sol = cc.solve(scene)
        assert sol.ok, f"n = {n}, {p}: cvxcontact's answer is not ok ({sol.status})"
        out[p] = dict(force=hertz3d.total_force(sol) / 4, u=np.asarray(sol.u[0]), rows=len(sol.contact.force),
                      active=int(np.count_nonzero(sol.contact.active)))
    np.savez(path, points=mesh.points, tets=mesh.tets, zone=mesh.boundary("zone"), bottom=mesh.boundary("bottom"),
             left=mesh.boundary("left"), front=mesh.boundary("front"), E=hertz3d.E, nu=hertz3d.NU,
             center=np.asarray(sphere.position, float), radius=hertz3d.R, delta=hertz3d.hertz(hertz3d.FORCE)[2],
             **{f"u_in_{p}": out[p]["u"] for p in POSINGS},
             **{f"force_{p}": out[p]["force"] for p in POSINGS})
    return out


def compare(levels, python3, out_path):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in levels:
            scene_npz, answer_npz = Path(tmp) / f"scene{n}.npz", Path(tmp) / f"answer{n}.npz"
            cvx = export(n, scene_npz)
            subprocess.run([python3, str(SIDE), str(scene_npz), str(answer_npz)], check=True)
            with np.load(answer_npz, allow_pickle=False) as f:
                gf = {k: f[k] for k in f.files}
            for p in POSINGS:
                u = cvx[p]["u"]
                scale = np.abs(u).max()
                for variant in ("obstacle", LIKE[p]):
                    ug, fg = gf[f"u_{variant}"], float(gf[f"fz_{variant}"])
                    rows.append(dict(n=n, posing=p, getfem=variant, rows=cvx[p]["rows"], active=cvx[p]["active"],
                                     active_getfem=int(np.count_nonzero(gf[f"lam_{variant}"])),
                                     force=cvx[p]["force"], force_k=float(gf[f"fz_of_{p}"]), force_getfem=fg,
                                     df=(cvx[p]["force"] - fg) / fg, du=np.abs(ug - u).max() / scale))
                    print("  ".join(f"{k}={v:.3e}" if isinstance(v, float) else f"{k}={v}"
                                    for k, v in rows[-1].items()), flush=True)
    write(rows, levels, out_path)
    return rows


def write(rows, levels, out_path):
    lines = [
        "# cvxcontact's sphere posings against GetFEM (3D Hertz quarter block, P1)",
        "",
        "Generated by `benchmarks/compare_getfem_hertz3d.py` (not part of CI: it needs Debian's `python3-getfem`,",
        "GetFEM 5.4.2, run by the system python3 through `benchmarks/getfem_hertz3d_side.py`):",
        "",
        "    apt-get install -y python3-getfem",
        f"    PYTHONPATH=. /work/venv/bin/python benchmarks/compare_getfem_hertz3d.py --levels {' '.join(map(str, levels))}",
        "",
        "Scene: `cvxcontact.apps.studies.hertz3d.scene(n, distance=...)`: the quarter block [0, 10 mm]^2 x",
        "[-10 mm, 0] graded towards the origin, E = 70 GPa, nu = 0.3, bottom clamped, rollers on x = 0 and y = 0,",
        f"the rigid sphere R = 20 mm fixed at Hertz's approach delta = {hertz3d.hertz(hertz3d.FORCE)[2]:.6g} m at",
        f"F = {hertz3d.FORCE:.6g} N (a/R = 0.05); P1, condition \"gamma3\" (rows at the nodes of the contact patch).",
        "Displacement control, so both codes solve one fixed problem on one mesh.",
        "",
        "GetFEM's variants (all solved by its Newton on the Alart-Curnier augmented Lagrangian, nodal multipliers):",
        "",
        "- `obstacle`: `add_nodal_contact_with_rigid_obstacle_brick` with the signed distance",
        "  `sqrt(x^2 + y^2 + (z - zc)^2) - R`: a row at each contact node, gap d(x), direction -grad d / |grad d|",
        "  with grad d by a forward difference of step 1e-3 x the radius estimate of the node's first cell.",
        "  These are the closest-point rows (cvxcontact's `distance=\"closest\"`) up to that difference's error.",
        "- `radial`: the basic contact brick with the same rows, the direction in closed form (x - c) / |x - c|",
        "  (like for like with `distance=\"closest\"`).",
        "- `vertical`: the basic contact brick with rows along z and the vertical distance to the sphere's lower",
        "  surface (like for like with `distance=\"ray\"`).",
        "",
        "F: the vertical force on the quarter (N). cvxcontact's is the obstacle's resultant",
        "(`hertz3d.total_force(sol) / 4`); F(K u) is the same force read from cvxcontact's u with GetFEM's own",
        "stiffness (the z-sum of K u over the contact nodes); GetFEM's is that sum on its own u.",
        "dF = (F_cvx - F_getfem) / F_getfem; du = max |u_getfem - u_cvx| / max |u_cvx|.",
        "",
        "| n | posing | GetFEM | rows | active (cvx / GetFEM) | F cvx (N) | F(K u_cvx) (N) | F GetFEM (N) | dF | du |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['n']} | {r['posing']} | {r['getfem']} | {r['rows']} | {r['active']} / {r['active_getfem']} "
                     f"| {r['force']:.10g} | {r['force_k']:.10g} | {r['force_getfem']:.10g} | {r['df']:.2e} "
                     f"| {r['du']:.2e} |")
    Path(out_path).write_text("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[4, 8])
    ap.add_argument("--python3", default="/usr/bin/python3")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "getfem_hertz3d.md"))
    args = ap.parse_args(argv)
    compare(args.levels, args.python3, args.out)


if __name__ == "__main__":
    main()
