"""Files of a solution: VTU per body, a VTU line mesh of Gamma_3, a JSON summary.

All writes are atomic (a temporary file in the target folder, then a rename), so an
interrupted run never leaves a half-written file under the final name. Array names
carry their units, so ParaView shows them as they are.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import CvxContactError
from ..fem.fields import body_fields
from ..geometry.quadratic import P2Nodes

if TYPE_CHECKING:
    from ..solution.solution import Solution

__all__ = ["write_vtu", "write_summary", "write_all", "summary", "atomic_write"]


def atomic_write(path, write):
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then rename it to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)       # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _pad3(a):
    return np.column_stack([a, np.zeros(len(a))])


def _sym6(xx, yy, zz, xy):
    """VTK symmetric-tensor order (xx, yy, zz, xy, yz, xz)."""
    z = np.zeros_like(xx)
    return np.column_stack([xx, yy, zz, xy, z, z])


def body_mesh(body, u, phi, nodes=None):
    """A meshio.Mesh of one body with point and cell data named with units (``nodes``: the P2 nodes of a
    P2 solution, written as quadratic ``triangle6`` cells, cell data at the centroids)."""
    import meshio

    f = body_fields(body, u, phi, nodes)
    point_data = {"displacement [m]": _pad3(u)}
    cell_data = {
        "strain [-]": _sym6(f.strain[:, 0], f.strain[:, 1], np.zeros(len(f.strain)), f.strain[:, 2]),
        "stress [Pa]": _sym6(*f.stress.T),
        "von Mises stress [Pa]": f.von_mises,
    }
    if phi is not None:
        point_data["electric potential [V]"] = phi
        cell_data["electric field [V/m]"] = _pad3(f.electric_field)
        cell_data["electric displacement [C/m^2]"] = _pad3(f.electric_displacement)
    cells = [("triangle", body.mesh.triangles)] if nodes is None else [("triangle6", nodes.triangles)]
    points = body.mesh.points if nodes is None else nodes.points
    return meshio.Mesh(_pad3(points), cells, point_data=point_data,
                       cell_data={k: [v] for k, v in cell_data.items()})


def contact_mesh(solution):
    """A meshio.Mesh of the merged Gamma_3 line with lambda_h, [u_nu], nodal forces."""
    import meshio

    c = solution.contact
    n = len(c.x)
    points = np.column_stack([c.x, np.full(n, c.line), np.zeros(n)])
    if getattr(solution, "degree", 1) == 2:      # P2: quadratic edges (end, end, midpoint)
        i = 2 * np.arange((n - 1) // 2)
        cells = [("line3", np.column_stack([i, i + 2, i + 1]))]
    else:
        cells = [("line", np.column_stack([np.arange(n - 1), np.arange(1, n)]))]
    return meshio.Mesh(points, cells, point_data={
        "contact pressure lambda_h [Pa]": c.lam,
        "nodal pressure [Pa]": c.pressure,
        "normal jump [m]": c.jump,
        "nodal force [N/m]": c.force,
        "constrained [-]": c.constrained.astype(float),
        "active [-]": c.active.astype(float),
    })


def write_vtu(solution, out, stem="solution"):
    """Write ``{stem}_body1.vtu``, ``{stem}_body2.vtu`` and ``{stem}_contact.vtu`` into ``out``."""
    import meshio

    out = Path(out)
    paths = []
    for k, body in enumerate(solution.scene.bodies, start=1):
        nodes = P2Nodes(body.mesh) if getattr(solution, "degree", 1) == 2 else None
        mesh = body_mesh(body, solution.u[k - 1], solution.phi[k - 1], nodes)
        paths.append(atomic_write(out / f"{stem}_body{k}.vtu", lambda p, m=mesh: meshio.write(p, m, "vtu")))
    line = contact_mesh(solution)
    paths.append(atomic_write(out / f"{stem}_contact.vtu", lambda p: meshio.write(p, line, "vtu")))
    return paths


def summary(solution) -> dict:
    """A JSON-ready summary: status, checks, timings, sizes, energy."""
    c = solution.contact
    return {
        "condition": solution.condition,
        "degree": int(getattr(solution, "degree", 1)),
        "status": solution.status,
        "ok": bool(solution.ok),
        "polished": bool(solution.polished),
        "tolerance": solution.tol,
        "residuals": solution.residuals(),
        "timings_s": {k: float(v) for k, v in solution.timings.items()},
        "contact": {"merged_nodes": int(len(c.x)), "constrained_nodes": int(c.constrained.sum()),
                    "active_nodes": int(c.active.sum()),
                    "active_x_m": [float(c.x[c.active].min()), float(c.x[c.active].max())] if c.active.any() else None,
                    "total_force_N_per_m": float(c.force.sum()), "max_lambda_Pa": float(c.lam.max())},
        "energy_J_per_m": solution.energy,
        "bodies": [{"name": b.name, "material": b.material.name, "nodes": int(len(u)),
                    "triangles": int(len(b.mesh.triangles)), "electric_unknowns": bool(b.piezoelectric),
                    "max_displacement_m": float(np.abs(u).max()),
                    "max_abs_potential_V": float(np.abs(p).max()) if p is not None else None}
                   for b, u, p in zip(solution.scene.bodies, solution.u, solution.phi)],
    }


def write_summary(solution, path):
    """Write :func:`summary` as JSON (atomic)."""
    text = json.dumps(summary(solution), indent=2)
    return atomic_write(path, lambda p: Path(p).write_text(text + "\n"))


def write_all(solution: Solution, out: str | os.PathLike[str], stem: str = "solution") -> list[Path]:
    """VTU files and the JSON summary of one solution into the folder ``out``."""
    try:
        paths = write_vtu(solution, out, stem)
        paths.append(write_summary(solution, Path(out) / f"{stem}.json"))
    except OSError as exc:
        raise CvxContactError(f"cannot write results into {str(out)!r}: {exc}") from exc
    return paths
