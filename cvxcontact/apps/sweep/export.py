"""Export of a sweep's fields to XDMF + HDF5 (meshio's writer; h5py is the optional extra ``export``).

One pair of files per body and per contact pair of each case (the cases have their own meshes, so they are
not time steps of one mesh): ``<id>_body<k>.xdmf``/``.h5`` and ``<id>_contact<p>.xdmf``/``.h5``. A contact
pair's file holds its rows: in 2D a polyline along the contact line, in 3D one vertex cell per row (the rows of a
surface overlay or of a body's nodes have no cells of their own).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ...errors import CvxContactError

__all__ = ["ExportError", "export_xdmf"]


class ExportError(CvxContactError, RuntimeError):
    """The export cannot run (h5py missing) or cannot write its files."""


def _body_meshes(arrays):
    import meshio

    for k in sorted(int(m.group(1)) for m in (re.fullmatch(r"points(\d+)", n) for n in arrays) if m):
        points = arrays[f"points{k}"]
        kind, cells = next((kind, arrays[f"{name}{k}"]) for name, kind in
                           (("triangles", "triangle"), ("quads", "quad"), ("tetrahedra", "tetra"),
                            ("hexahedra", "hexahedron")) if f"{name}{k}" in arrays)
        n = len(points)                                      # P2: the vertices come first (P2Nodes)
        data = {"displacement [m]": np.asarray(arrays[f"u{k}"])[:n]}
        if f"phi{k}" in arrays:
            data["electric potential [V]"] = np.asarray(arrays[f"phi{k}"])[:n]
        yield f"body{k}", meshio.Mesh(points, [(kind, cells)], point_data=data)


def _contact_meshes(arrays):
    import meshio

    pairs = sorted({1} | {int(m.group(1)) for m in (re.fullmatch(r"contact(\d+)_x", n) for n in arrays) if m})
    for p in pairs:
        pre = "" if p == 1 else f"contact{p}_"
        if f"{pre}line_points" not in arrays:
            continue
        points = np.asarray(arrays[f"{pre}line_points"], dtype=float)
        x = np.asarray(arrays[f"{pre}x"])
        if x.ndim == 1:                                      # 2D: consecutive merged nodes along s
            order = np.argsort(x, kind="stable")
            cells = ("line", np.column_stack([order[:-1], order[1:]]))
        else:                                                # 3D: the rows on the contact plane, one vertex each
            cells = ("vertex", np.arange(len(x))[:, None])
        data = {"lambda_h [Pa]": arrays[f"{pre}lam"], "normal jump [m]": arrays[f"{pre}jump"],
                "nodal force [N/m]": arrays[f"{pre}force"], "active": arrays[f"{pre}active"].astype(np.int32)}
        if f"{pre}gap" in arrays:
            data["gap [m]"] = arrays[f"{pre}gap"]
        yield f"contact{p}", meshio.Mesh(points, [cells], point_data=data)


def export_xdmf(results, ids, target: Path) -> list[Path]:
    """Write the XDMF + HDF5 files of the cases ``ids`` of ``results`` (a :class:`SweepResults`) into ``target``."""
    try:
        import h5py  # noqa: F401  (meshio's XDMF writer stores the arrays with it)
    except ImportError:
        raise ExportError('the XDMF export needs h5py: pip install "cvxcontact[export]"') from None
    import meshio

    try:
        target.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"cannot create {str(target)!r}: {exc.strerror or exc}") from None
    written = []
    for case_id in ids:
        arrays = results.arrays(case_id)
        for name, mesh in [*_body_meshes(arrays), *_contact_meshes(arrays)]:
            path = target / f"{case_id}_{name}.xdmf"
            try:
                meshio.write(path, mesh, file_format="xdmf")
            except OSError as exc:
                raise ExportError(f"cannot write {str(path)!r}: {exc.strerror or exc}") from None
            written.append(path)
    return written
