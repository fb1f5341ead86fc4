"""The closest-point posing of a curved rigid obstacle against GetFEM (issue 29 item 3): the 3D Hertz quarter
block (cvxcontact.apps.studies.hertz3d, P1, condition "gamma3", DISPLACEMENT control: the sphere fixed at
Hertz's approach at the design force) solved by cvxcontact with ``distance="closest"`` and ``distance="ray"``
and by GetFEM on the same mesh.

NOT part of CI: the GetFEM half (benchmarks/getfem_hertz3d_side.py) needs Debian's GetFEM
(``apt-get install python3-getfem``, 5.4) and runs under the system interpreter (its numpy ABI differs from the
venv's); the two processes exchange plain npz files (no pickle) in a temporary directory.

    PYTHONPATH=. python benchmarks/compare_getfem_hertz3d.py [--levels 4 8 12]
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
sys.path.insert(0, str(Path(__file__).resolve().parent))  # harness

from harness import write_report

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d

SIDE = Path(__file__).with_name("getfem_hertz3d_side.py")
POSINGS = ("closest", "ray")
LIKE = {"closest": "radial", "ray": "vertical"}


def radius(ratio: float) -> float:
    """m: the sphere's radius at a/R = ``ratio`` (the study's R at its own ratio)."""
    return hertz3d.R if np.isclose(ratio, hertz3d.A_REF / hertz3d.R, rtol=1e-12) else hertz3d.A_REF / ratio


def scene(n: int, ratio: float, posing: str):
    """The study's quarter scene at level ``n`` with the sphere's radius R = a_ref / ``ratio`` fixed at Hertz's
    approach a_ref^2 / R for the contact radius a_ref (the study's own scene, ``hertz3d.scene(n)``, at its
    a/R = 0.05)."""
    if radius(ratio) == hertz3d.R:
        return hertz3d.scene(n, distance=posing)
    body, R = hertz3d.block(n), radius(ratio)
    sphere = cc.Rigid.sphere((0.0, 0.0, R - hertz3d.A_REF ** 2 / R), R, distance=posing)
    return cc.Scene(body, contacts=[cc.Contact(body, "zone", sphere)])


def active(forces) -> int:
    """The rows carrying a force above 1e-9 of the largest (either sign convention)."""
    f = np.abs(np.asarray(forces, float))
    return int(np.count_nonzero(f > 1e-9 * f.max()))


def export(n: int, ratio: float, path: Path) -> dict:
    """Solve the scene at level ``n`` and a/R = ``ratio`` with both posings; write GetFEM's input to ``path``;
    return cvxcontact's answers (force on the quarter (N), u (N, 3) m, rows, active rows)."""
    scenes = {p: scene(n, ratio, p) for p in POSINGS}
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
    for p, sc in scenes.items():
        sol = cc.solve(sc)
        assert sol.ok, f"n = {n}, {p}: cvxcontact's answer is not ok ({sol.status})"
        out[p] = {"force": hertz3d.total_force(sol) / 4, "u": np.asarray(sol.u[0]), "rows": len(sol.contact.force),
                  "active": active(sol.contact.force)}
    np.savez(path, points=mesh.points, tets=mesh.tets, zone=mesh.boundary("zone"), bottom=mesh.boundary("bottom"),
             left=mesh.boundary("left"), front=mesh.boundary("front"), E=hertz3d.E, nu=hertz3d.NU,
             center=np.asarray(sphere.position, float), radius=radius(ratio), delta=hertz3d.A_REF ** 2 / radius(ratio),
             **{f"u_in_{p}": out[p]["u"] for p in POSINGS}, **{f"force_{p}": out[p]["force"] for p in POSINGS},
             **{f"umax_{p}": np.abs(out[p]["u"]).max() for p in POSINGS})
    return out


def compare(levels, ratios, python3, out_path):
    rows, fd = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for ratio in ratios:
            for n in levels:
                scene_npz, answer_npz = Path(tmp) / f"scene{n}.npz", Path(tmp) / f"answer{n}.npz"
                cvx = export(n, ratio, scene_npz)
                subprocess.run([python3, str(SIDE), str(scene_npz), str(answer_npz)], check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                with np.load(answer_npz, allow_pickle=False) as f:
                    gf = {k: f[k] for k in f.files}
                for p in POSINGS:
                    u = cvx[p]["u"]
                    for variant in ("obstacle", LIKE[p]):
                        ug, fg = gf[f"u_{variant}"], float(gf[f"fz_{variant}"])
                        rows.append({"ratio": ratio, "n": n, "posing": p, "getfem": variant, "rows": cvx[p]["rows"],
                                     "active": cvx[p]["active"], "active_getfem": active(gf[f"lam_{variant}"]),
                                     "force": cvx[p]["force"], "force_k": float(gf[f"fz_of_{p}"]), "force_getfem": fg,
                                     "df": (cvx[p]["force"] - fg) / fg, "du": np.abs(ug - u).max() / np.abs(u).max()})
                        print("  ".join(f"{k}={v:.3e}" if isinstance(v, float) else f"{k}={v}"
                                        for k, v in rows[-1].items()), flush=True)
                uo, ug = gf["u_obstacle"], gf["u_given"]
                fo = float(gf["fz_obstacle"])
                fd.append({"ratio": ratio, "n": n, "normal": float(gf["normal_error"]),
                           "df": (float(gf["fz_given"]) - fo) / fo, "du": np.abs(ug - uo).max() / np.abs(uo).max()})
    write(rows, fd, levels, ratios, out_path)
    return rows, fd


def worst(rows, key, **match) -> float:
    """The largest |row[key]| over the rows matching ``match``."""
    return max(abs(r[key]) for r in rows if all(r[k] == v for k, v in match.items()))


def summary(rows, fd, ratios) -> list[str]:
    """The Markdown bullets of the measured agreement."""
    def pair(posing, getfem):
        return (f"|dF| <= {worst(rows, 'df', posing=posing, getfem=getfem):.1e}, "
                f"du <= {worst(rows, 'du', posing=posing, getfem=getfem):.1e}")

    lines = [
        f"- closest vs GetFEM's like-for-like radial rows: {pair('closest', 'radial')} (the same discrete problem).",
        f"- closest vs GetFEM's rigid-obstacle brick: {pair('closest', 'obstacle')}. GetFEM's forward-difference",
        f"  normal is off the exact one by up to {max(r['normal'] for r in fd):.1e}; its basic brick with the rows",
        "  read from its obstacle brick reproduces the obstacle brick's answer to",
        f"  |dF| <= {max(abs(r['df']) for r in fd):.1e}, du <= {max(r['du'] for r in fd):.1e}: that normal is all",
        "  of it.",
        f"- ray vs GetFEM's like-for-like vertical rows: {pair('ray', 'vertical')}.",
    ]
    for ratio in ratios:
        df = [r["df"] for r in rows if (r["posing"], r["getfem"], r["ratio"]) == ("ray", "obstacle", ratio)]
        lines.append(f"- ray vs GetFEM's rigid-obstacle brick at a/R = {ratio:g}: dF from {min(df):.2%} to "
                     f"{max(df):.2%} (the vertical posing's own error; du up to "
                     f"{worst(rows, 'du', posing='ray', getfem='obstacle', ratio=ratio):.1e}).")
    return lines


def write(rows, fd, levels, ratios, out_path):
    """Write the results file (Markdown) of :func:`compare`."""
    delta = hertz3d.hertz(hertz3d.FORCE)[2]
    command = (f"PYTHONPATH=. python benchmarks/compare_getfem_hertz3d.py --levels "
               f"{' '.join(map(str, levels))} --ratios {' '.join(f'{r:g}' for r in ratios)}")
    lines = [
        "# cvxcontact's sphere posings against GetFEM (3D Hertz quarter block, P1)",
        "",
        "Generated by `benchmarks/compare_getfem_hertz3d.py` (not part of CI: it needs Debian's `python3-getfem`,",
        "GetFEM 5.4.2, run by the system python3 through `benchmarks/getfem_hertz3d_side.py`):",
        "",
        "    apt-get install -y python3-getfem",
        f"    {command}",
        "",
        "Scene: `cvxcontact.apps.studies.hertz3d`: the quarter block [0, 10 mm]^2 x [-10 mm, 0] (n cells per edge,",
        "graded towards the origin), E = 70 GPa, nu = 0.3, bottom clamped, rollers on x = 0 and y = 0, P1,",
        "condition \"gamma3\" (a row at every node of the contact patch [0, 2 mm]^2), the rigid sphere of radius",
        "R = a_ref / (a/R) FIXED at Hertz's approach a_ref^2 / R for the contact radius a_ref = 1 mm",
        "(displacement control: one problem per mesh, no force loop). At a/R = 0.05 it is the study's own",
        f"`hertz3d.scene(n, distance=...)` (R = 20 mm, delta = {delta:.6g} m); a/R = 0.1 halves R.",
        "",
        "GetFEM's posings (each solved by its Newton on the Alart-Curnier augmented Lagrangian, nodal multipliers,",
        "the supports as dof constraints with multipliers; its own P1 mesh_fem, stiffness and dof numbering):",
        "",
        "- `obstacle`: `add_nodal_contact_with_rigid_obstacle_brick` with the signed distance",
        "  `sqrt(x^2 + y^2 + (z - zc)^2) - R`: a row at each contact node, gap d(x), direction -grad d / |grad d|",
        "  with grad d by a FORWARD difference of step 1e-3 x the node's first cell's radius estimate. These are",
        "  the closest-point rows (`distance=\"closest\"`) up to that difference's error.",
        "- `radial`: the basic contact brick with the same rows and gaps, the direction in closed form",
        "  (c - x) / |x - c|: like for like with `distance=\"closest\"`.",
        "- `vertical`: the basic contact brick with rows along z and the vertical distance to the sphere's lower",
        "  surface: like for like with `distance=\"ray\"`.",
        "",
        "F: the vertical force on the quarter (N). cvxcontact's is the obstacle's resultant",
        "(`hertz3d.total_force(sol) / 4`); F(K u_cvx) reads it from cvxcontact's u with GetFEM's stiffness (the",
        "z-sum of K u over the contact nodes, an independent read); GetFEM's is that sum on its own u.",
        "dF = (F_cvx - F_getfem) / F_getfem; du = max |u_getfem - u_cvx| / max |u_cvx|; active: rows whose force",
        "exceeds 1e-9 of the largest.",
        "",
        "## Summary",
        "",
        *summary(rows, fd, ratios),
    ]
    lines += [
        "",
        "## Forces and displacements",
        "",
        ("| a/R | n | posing | GetFEM | rows | active (cvx / GetFEM) | F cvx (N) | F(K u_cvx) (N) | F GetFEM (N) | dF "
        "| du |"),
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['ratio']:g} | {r['n']} | {r['posing']} | {r['getfem']} | {r['rows']} "
                     f"| {r['active']} / {r['active_getfem']} | {r['force']:.10g} | {r['force_k']:.10g} "
                     f"| {r['force_getfem']:.10g} | {r['df']:.2e} | {r['du']:.2e} |")
    lines += [
        "",
        "## GetFEM's finite-difference normal",
        "",
        "normal: max over the contact nodes of |n_getfem - n_exact| (n_getfem read from the tangent matrix of the",
        "obstacle brick, its (u, lambda) block being -B_N^T); dF, du: GetFEM's basic brick with those rows (gap d(x))",
        "against the obstacle brick.",
        "",
        "| a/R | n | normal | dF | du |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {r['ratio']:g} | {r['n']} | {r['normal']:.2e} | {r['df']:.1e} | {r['du']:.1e} |" for r in fd]
    write_report(out_path, lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[4, 8, 12])
    ap.add_argument("--ratios", type=float, nargs="+", default=[0.05, 0.1], help="a/R of the sphere")
    ap.add_argument("--python3", default="/usr/bin/python3")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "getfem_hertz3d.md"))
    args = ap.parse_args(argv)
    compare(args.levels, args.ratios, args.python3, args.out)


if __name__ == "__main__":
    main()
