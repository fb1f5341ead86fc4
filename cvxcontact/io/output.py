"""Files of a solution: VTU per body, a VTU mesh of each contact line (2D) or surface (3D), a JSON summary.

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

from ..contact.interface import row_frames, row_tangents
from ..errors import CvxContactError
from ..fem.fields import body_fields
from ..fem.space import space, space_of
from ..fem.trace import TRACES
from ..solution.solution import force_unit, pair_label, pair_lines

if TYPE_CHECKING:
    from ..solution.solution import Solution

__all__ = ["write_vtu", "write_pvd", "write_summary", "write_all", "summary", "atomic_write", "trace_pressure",
           "surface_cells", "tangential_basis", "friction_vectors"]


def atomic_write(path, write, *, durable: bool = False):
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then rename it to ``path``.

    ``durable``: the temporary is named ``.<name>.<random>.tmp`` (never ``*<suffix>``, so a listing
    of the final files, e.g. ``glob("*.json")``, cannot pick up a half-written one; ``write`` must
    then not rely on the path's extension), it is fsynced before the rename and the folder after,
    so a crash or power loss leaves either the old file or the complete new one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if durable:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    else:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)       # mkstemp makes 0600; give the usual permissions
        if durable:
            _fsync(tmp, os.O_RDONLY)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    if durable:
        _fsync(path.parent, getattr(os, "O_DIRECTORY", 0) | os.O_RDONLY, folder=True)
    return path


def _fsync(path, flags, folder=False):
    """fsync a file, or a folder (its entries; not possible on every platform, then skipped)."""
    try:
        fd = os.open(path, flags)
    except OSError:
        if folder:                          # e.g. Windows cannot open a folder
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not folder:                      # some file systems refuse fsync on a folder (EINVAL)
            raise
    finally:
        os.close(fd)


def _pad3(a):
    return np.column_stack([a, np.zeros(len(a))])


def _sym6(xx, yy, zz, xy):
    """VTK symmetric-tensor order (xx, yy, zz, xy, yz, xz)."""
    z = np.zeros_like(xx)
    return np.column_stack([xx, yy, zz, xy, z, z])


def body_mesh(body, u, phi, nodes=None):
    """A meshio.Mesh of one body with point and cell data named with units (``nodes``: the nodes of a
    degree-2 solution; the cells are the space's VTK cells: ``triangle``/``triangle6``, ``quad`` (VTK_QUAD, 9)
    /``quad9`` (VTK_BIQUADRATIC_QUAD, 28); cell data at the cells' centres)."""
    import meshio

    if getattr(body, "dim", 2) == 3:
        return _solid_mesh(body, u, phi, nodes)
    f = body_fields(body, u, phi, nodes)
    point_data = {"displacement [m]": _pad3(u)}
    cell_data = {
        "strain [-]": _sym6(f.strain[:, 0], f.strain[:, 1], np.zeros(len(f.strain)), f.strain[:, 2]),
        "stress [Pa]": _sym6(*f.stress.T),
        "von Mises stress [Pa]": f.von_mises,
    }
    for label, col in (("xx", 0), ("yy", 1), ("xy", 2)):          # named components (ParaView shows 0..5)
        cell_data[f"strain {label} [-]"] = f.strain[:, col]
    for label, col in (("xx", 0), ("yy", 1), ("zz", 2), ("xy", 3)):  # fem.fields order: sxx, syy, szz, sxy
        cell_data[f"stress {label} [Pa]"] = f.stress[:, col]
    if phi is not None:
        point_data["electric potential [V]"] = phi
        cell_data["electric field [V/m]"] = _pad3(f.electric_field)
        cell_data["electric displacement [C/m^2]"] = _pad3(f.electric_displacement)
    cells = space_of(body, nodes).vtk_cells(body, nodes)
    points = body.mesh.node_set(nodes).points
    return meshio.Mesh(_pad3(points), cells, point_data=point_data,
                       cell_data={k: [v] for k, v in cell_data.items()})


_VTK_ORDER = np.array([0, 1, 2, 5, 3, 4])
"""fem.fields' 3D component order (xx, yy, zz, yz, xz, xy) -> VTK's symmetric tensor order (xx, yy, zz, xy, yz,
xz)."""
_COMPONENTS_3D = ("xx", "yy", "zz", "yz", "xz", "xy")
def _solid_mesh(body, u, phi, nodes=None):
    """A meshio.Mesh of one tetrahedral body: ``tetra`` cells (P1), or ``tetra10`` cells for the P2 nodes
    ``nodes`` (:class:`~cvxcontact.geometry.quadratic.P2TetNodes`, written in VTK's node order by the space;
    cell data at the centroids). Point data ``displacement [m]`` (n, 3) and ``electric potential [V]``; cell data ``strain [-]``
    and ``stress [Pa]`` (symmetric tensors in VTK order xx, yy, zz, xy, yz, xz; tensor shears), their six
    components as named scalars, ``von Mises stress [Pa]``, ``electric field [V/m]`` and ``electric
    displacement [C/m^2]`` (3 components)."""
    import meshio

    f = body_fields(body, u, phi, nodes)
    point_data = {"displacement [m]": np.asarray(u, dtype=float).reshape(-1, 3)}
    cell_data = {"strain [-]": f.strain[:, _VTK_ORDER], "stress [Pa]": f.stress[:, _VTK_ORDER],
                 "von Mises stress [Pa]": f.von_mises}
    for col, label in enumerate(_COMPONENTS_3D):                # named components (ParaView shows 0..5)
        cell_data[f"strain {label} [-]"] = f.strain[:, col]
    for col, label in enumerate(_COMPONENTS_3D):
        cell_data[f"stress {label} [Pa]"] = f.stress[:, col]
    if phi is not None:
        point_data["electric potential [V]"] = np.asarray(phi, dtype=float)
        cell_data["electric field [V/m]"] = f.electric_field
        cell_data["electric displacement [C/m^2]"] = f.electric_displacement
    cells = space_of(body, nodes).vtk_cells(body, nodes)
    points = body.mesh.node_set(nodes).points
    return meshio.Mesh(np.asarray(points, dtype=float), cells, point_data=point_data,
                       cell_data={k: [v] for k, v in cell_data.items()})


def pair_interface(solution, pair=0):
    """Contact pair ``pair``'s line: P1 ``scene.interfaces[pair]``, P2 the solution's quadratic interface
    (or pair ``pair``'s one in its stack of several pairs)."""
    return pair_lines(solution.scene, getattr(solution, "interface", None))[0][pair]


def trace_pressure(solution, k, pair=0):
    """(s, p): the contact pressure felt by side ``k`` (0: the pair's first body, 1: its second; a
    rigid pair has side 0 only) of contact pair ``pair`` on that body's own trace nodes, Pa
    (:meth:`Solution.traction`: the nodal forces moved to that body's nodes, divided by its own
    lumped lengths). The pressure to show first; lambda_h is a diagnostic."""
    return solution.traction(k, pair)


def pair_bodies(solution, pair=0) -> list[int]:
    """Scene indices of the bodies on the sides of contact pair ``pair`` (one index for a rigid pair), in
    the order of that pair's traces (P2: the quadratic interface's own ``members``)."""
    if getattr(solution, "degree", 1) == 2:
        return [m for m in pair_interface(solution, pair).members if m is not None]
    a, b = solution.scene.stack.members[pair]
    return [a] if b is None else [a, b]


def _side_displacements(solution, pair=0):
    """Displacement (n_merged, d) of each side's trace interpolated at the merged nodes (m)."""
    itf = pair_interface(solution, pair)
    return [itf.interpolation(k) @ solution.u[b][t.nodes]
            for k, (b, t) in enumerate(zip(pair_bodies(solution, pair), itf.traces))]


def surface_cells(itf) -> np.ndarray:
    """(c, 3) triangles on the nodes of X_h of a 3D contact pair (``itf`` a
    :class:`~cvxcontact.contact.surface.SurfaceInterface`; P2, a
    :class:`~cvxcontact.contact.quadratic3d.QuadraticSurface`: each 6-node cell of X_h split into four at its
    midpoints): the cells of the overlay of the two bodies' faces,
    or, against a rigid obstacle, the body's faces whose three nodes reach it, or, for a curved part against a
    planar one, the curved part's faces whose three nodes lie over the plane, numbered as the nodes of X_h."""
    if getattr(itf, "degree", 1) == 2:                 # P2 (triangle6 cells on X_h): each split at its midpoints
        c = np.asarray(itf.cells)
        return np.concatenate([c[:, [0, 3, 5]], c[:, [3, 1, 4]], c[:, [5, 4, 2]], c[:, [3, 4, 5]]])
    if itf.overlay is not None:
        return np.asarray(itf.overlay.triangles)
    if getattr(itf, "curved", None) is not None:        # a curved part's faces over the planar one
        return np.asarray(itf.cells)
    t = itf.traces[0]
    where = np.full(len(t.nodes), -1)
    where[itf.reach] = np.arange(len(itf.reach))
    faces = where[t.faces]
    return faces[(faces >= 0).all(axis=1)]


def _vectors(a):
    """Vectors (n, 2) or (n, 3) as VTK's 3-component arrays (2D: a zero third component)."""
    a = np.asarray(a, dtype=float)
    return _pad3(a) if a.shape[1] == 2 else a


def tangential_basis(itf, components: int) -> np.ndarray:
    """(c, n, d) the unit tangents along which contact pair ``itf``'s slip components are measured at each of its n
    nodes of X_h (first body's side): c = 1 in 2D, the pair's tangent t
    (:func:`~cvxcontact.contact.interface.row_tangents`); c = 2 in 3D, its frame (t_1, t_2)
    (:func:`~cvxcontact.contact.interface.row_frames`); against a curved rigid obstacle turned per node."""
    n = len(itf.points)
    if components == 1:
        return np.broadcast_to(np.asarray(row_tangents(itf, 0), dtype=float), (n, 2))[None]
    frame = np.asarray(row_frames(itf), dtype=float)
    return np.broadcast_to(frame[:, None] if frame.ndim == 2 else frame, (components, n, 3))


def friction_vectors(solution, pair=0) -> dict[str, np.ndarray]:
    """A friction pair's tangential fields at its nodes of X_h as vectors in global coordinates (n, d):
    ``slip`` [u_t] (m), ``shear`` sigma_t (Pa, on the first body) and ``shear_force`` (N/m; 3D: N), each
    component times its tangent (:func:`tangential_basis`); ``{}`` for a frictionless pair."""
    c = solution.contacts[pair]
    if c.slip is None:
        return {}
    n = len(c.x)
    basis = tangential_basis(pair_interface(solution, pair), np.asarray(c.slip).reshape(n, -1).shape[1])
    return {k: np.einsum("nc,cnd->nd", np.asarray(v, dtype=float).reshape(n, -1), basis)
            for k, v in (("slip", c.slip), ("shear", c.shear), ("shear_force", c.shear_force))}


def _friction_data(solution, pair) -> dict[str, np.ndarray]:
    """The point data of a friction pair (:func:`contact_mesh`); ``{}`` without friction."""
    c = solution.contacts[pair]
    vectors = friction_vectors(solution, pair)
    if not vectors:
        return {}
    n = len(c.x)
    names = {"slip": "slip {}[m]", "shear": "shear {}[Pa]",
             "shear_force": f"shear force {{}}[{force_unit(solution)}]"}
    data = {}
    for key, name in names.items():
        data[name.format("")] = _vectors(vectors[key])
        parts = np.asarray(getattr(c, key), dtype=float).reshape(n, -1)
        data.update({name.format(f"t{j + 1} "): parts[:, j] for j in range(parts.shape[1])})
    data["slip threshold [Pa]"] = np.broadcast_to(np.asarray(c.threshold, dtype=float), (n,)).copy()
    return data


def contact_mesh(solution, pair=0):
    """A meshio.Mesh of contact pair ``pair``: in 2D its merged line (any direction, drawn at its nodes,
    ``line``/``line3`` cells), in 3D its contact surface (the overlay's ``triangle`` cells at the nodes of
    X_h, :func:`surface_cells`).

    Point data: ``pressure on body j [Pa]`` for each side (j the body's 1-based index in the scene;
    the pressure felt by that body, P1-interpolated from its own trace nodes; a rigid pair has one
    side), ``lambda_h (diagnostic) [Pa]`` (the multiplier on the merged mesh; it may oscillate),
    ``nodal pressure [Pa]``, ``normal jump [m]``, ``gap [m]``, ``nodal force [N/m]`` (3D: ``[N]``),
    ``constrained``, ``active``, ``penetration`` (jump above the gap: at unconstrained nodes
    with sigma_l), ``displacement body j [m]`` and ``displacement [m]`` (their mean, or the one
    body's for a rigid pair: warp by it).

    A friction pair (:class:`~cvxcontact.contact.laws.Tresca`, Coulomb) adds ``slip [m]`` (the slip
    [u_t] = (u^a - u^b)_t), ``shear [Pa]`` (the tangential traction sigma_t on the first body, anti-parallel to
    the slip where it slips) and ``shear force [N/m]`` (3D: ``[N]``; the tangential nodal force on the first
    body) as 3-component vectors in global coordinates (x, y, z; 2D: z = 0), their components along the
    pair's tangent t (2D: ``slip t1 [m]``, ...) or frame (t_1, t_2) (3D: ``slip t1 [m]``, ``slip t2 [m]``,
    ...; :func:`tangential_basis`) as named scalars (the arrays of
    :class:`~cvxcontact.solution.solution.ContactResult`), and
    ``slip threshold [Pa]`` (Tresca's g; Coulomb: mu p at each node). A frictionless pair writes none of them,
    nor does a friction pair without rows (no node of its condition in the overlap: its ContactResult has no slip).

    """
    import meshio

    c = solution.contacts[pair]
    itf = pair_interface(solution, pair)
    n = len(c.x)
    if solution.scene.dim == 3:
        points, cells = np.asarray(c.points, dtype=float), [("triangle", surface_cells(itf))]
    else:
        xy = np.column_stack([c.x, np.full(n, c.line)]) if c.points is None else c.points   # any direction
        points, cells = _pad3(xy), TRACES[getattr(solution, "degree", 1)].line_cells(n)
    sides = _side_displacements(solution, pair)
    bodies = pair_bodies(solution, pair)
    data = {f"pressure on body {b + 1} [Pa]": itf.interpolation(k) @ trace_pressure(solution, k, pair)[1]
            for k, b in enumerate(bodies)}
    data.update({
        "lambda_h (diagnostic) [Pa]": c.lam,
        "nodal pressure [Pa]": c.pressure,
        "normal jump [m]": c.jump,
        "gap [m]": np.zeros(n) if c.gap is None else c.gap,
        f"nodal force [{force_unit(solution)}]": c.force,
        "constrained [-]": c.constrained.astype(float),
        "active [-]": c.active.astype(float),
        "penetration [-]": c.penetration.astype(float),
    })
    data.update(_friction_data(solution, pair))
    data.update({f"displacement body {b + 1} [m]": _vectors(d) for b, d in zip(bodies, sides)})
    data["displacement [m]"] = _vectors(sum(sides) / len(sides))
    return meshio.Mesh(points, cells, point_data=data)


def trace_mesh(solution, k, pair=0):
    """A meshio.Mesh of side ``k``'s own trace on contact pair ``pair`` (2D: a line; 3D: the body's own
    ``triangle`` faces of its contact part): ``pressure on body j [Pa]`` (j the body's 1-based scene index)
    and ``displacement [m]`` (that body's, so the trace warps with it)."""
    import meshio

    itf = pair_interface(solution, pair)
    t = itf.traces[k]
    b = pair_bodies(solution, pair)[k]
    _, p = trace_pressure(solution, k, pair)
    n = len(p)
    if solution.scene.dim == 3:
        faces = np.asarray(t.faces)
        points, cells = np.asarray(t.points, dtype=float), [("triangle6" if faces.shape[1] == 6 else "triangle", faces)]
    else:
        xy = t.points if hasattr(t, "points") else itf.points[0] + np.outer(t.x - itf.x[0], itf.tangent)
        points, cells = _pad3(xy), TRACES[getattr(solution, "degree", 1)].line_cells(n)
    return meshio.Mesh(points, cells, point_data={
        f"pressure on body {b + 1} [Pa]": p, "displacement [m]": _vectors(solution.u[b][t.nodes])})


def contact_stem(stem, pair):
    """File stem of contact pair ``pair``: ``{stem}_contact`` for the first, ``{stem}_contact{i+1}`` after."""
    return f"{stem}_contact" if pair == 0 else f"{stem}_contact{pair + 1}"


def write_vtu(solution, out, stem="solution"):
    """Write ``{stem}_body{j}.vtu`` per body (with the cell field ``error_indicator``, the error estimate's
    eta_T of each cell, sqrt(J/m) in 2D and sqrt(J) in 3D, when the solution has an estimate) and, per contact
    pair i (:func:`contact_stem`:
    ``{stem}_contact.vtu`` for the first, ``{stem}_contact{i+1}.vtu`` after), the merged line and
    one ``..._body{j}.vtu`` per deformable side (j the body's 1-based index in the scene)."""
    import meshio

    out = Path(out)
    paths = []
    for k, body in enumerate(solution.scene.bodies, start=1):
        nodes = space(getattr(solution, "degree", 1), body.mesh.cell).nodes(body)
        mesh = body_mesh(body, solution.u[k - 1], solution.phi[k - 1], nodes)
        est = getattr(solution, "estimate", None)
        if est is not None:                    # eta_T per cell (docs/accuracy.md), in the estimate's unit
            mesh.cell_data["error_indicator"] = [np.asarray(est.indicators[k - 1], dtype=float)]
        paths.append(atomic_write(out / f"{stem}_body{k}.vtu", lambda p, m=mesh: meshio.write(p, m, "vtu")))
    for i in range(len(solution.contacts)):
        name = contact_stem(stem, i)
        line = contact_mesh(solution, i)
        paths.append(atomic_write(out / f"{name}.vtu", lambda p, m=line: meshio.write(p, m, "vtu")))
        for k, b in enumerate(pair_bodies(solution, i)):
            tr = trace_mesh(solution, k, i)
            paths.append(atomic_write(out / f"{name}_body{b + 1}.vtu", lambda p, m=tr: meshio.write(p, m, "vtu")))
    return paths


def write_pvd(vtu_paths, path, groups=None):
    """A ParaView collection (``.pvd``) listing ``vtu_paths`` (relative to the collection's folder).

    ``groups`` (optional, one label per file, e.g. the condition) become the collection's
    timesteps 0, 1, ... in order of first appearance, so ParaView's time control steps through them.
    """
    path = Path(path)
    groups = list(groups) if groups is not None else [""] * len(vtu_paths)
    order = list(dict.fromkeys(groups))
    rows, parts = [], dict.fromkeys(order, 0)
    for f, g in zip(vtu_paths, groups):
        rel = os.path.relpath(Path(f), path.parent).replace(os.sep, "/")
        rows.append(f'    <DataSet timestep="{order.index(g)}" group="{_xml(g)}" part="{parts[g]}" file="{_xml(rel)}"/>')
        parts[g] += 1                                   # one block per file within a time step
    text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
            "  <Collection>\n" + "\n".join(rows) + "\n  </Collection>\n</VTKFile>\n")
    return atomic_write(path, lambda p: Path(p).write_text(text))


def _xml(text):
    return str(text).replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


def _per_m(solution) -> str:
    """The suffix of a key whose unit is per unit thickness in 2D: "_per_m" in 2D, "" in 3D."""
    return "" if solution.scene.dim == 3 else "_per_m"


def _pair_summary(solution, i) -> dict:
    c = solution.contacts[i]
    felt = [(b, trace_pressure(solution, k, i)[1], _lengths(solution, k, i))
            for k, b in enumerate(pair_bodies(solution, i))]
    s = c.x
    out = {"pressure_on_body_Pa": [{"body": b + 1, "max": float(p.max()), "min": float(p.min()),
                                    "mean": float(np.average(p, weights=w))} for b, p, w in felt],
           "pair": i, "label": pair_label(solution, i),
           "bodies": [solution.scene.bodies[b].name for b, _, _ in felt],
           "obstacle": repr(solution.scene.contacts[i].other) if solution.scene.contacts[i].rigid else None,
           "normal": [float(v) for v in c.normal] if c.normal is not None else None,
           "merged_nodes": int(len(c.x)), "constrained_nodes": int(c.constrained.sum()),
           "active_nodes": int(c.active.sum()), "contact_zone_nodes": int(solution.in_contact(i).sum()),
           "contact_zone_fraction": solution.contact_fraction(i)}
    if solution.scene.dim == 3:
        frame = pair_interface(solution, i).frame
        out["frame"] = [[float(v) for v in t] for t in frame]
        out["active_s_m"] = ([[float(s[c.active, j].min()), float(s[c.active, j].max())] for j in range(2)]
                             if c.active.any() else None)
    else:
        out["active_x_m"] = [float(s[c.active].min()), float(s[c.active].max())] if c.active.any() else None
    out[f"total_force_N{_per_m(solution)}"] = float(c.force.sum())
    out["penetrating_nodes"] = int((c.penetration & ~c.constrained).sum())
    out["lambda_h_diagnostic_Pa"] = {"min": float(c.lam.min()), "max": float(c.lam.max())}
    vectors = friction_vectors(solution, i)
    if vectors:
        g = np.asarray(c.threshold, dtype=float)
        out["friction"] = {"max_slip_m": float(np.linalg.norm(vectors["slip"], axis=1).max(initial=0.0)),
                           "max_shear_Pa": float(np.linalg.norm(vectors["shear"], axis=1).max(initial=0.0)),
                           "threshold_Pa": {"min": float(g.min()), "max": float(g.max())},
                           f"total_shear_force_N{_per_m(solution)}": [float(v) for v in
                                                                     vectors["shear_force"].sum(axis=0)]}
    return out


def summary(solution) -> dict:
    """A JSON-ready summary: status, checks, timings, sizes, energy, contact pairs, electrodes.

    ``contacts`` has one entry per contact pair (``contact`` repeats the first): its bodies (and
    obstacle), ``pressure_on_body_Pa`` (max, min, length- (3D: area-) weighted mean of the pressure felt by
    each body of the pair on its own trace, Pa; ``body`` is the 1-based scene index) comes first;
    ``lambda_h_diagnostic_Pa`` (range of lambda_h on the merged mesh, which may oscillate) is a
    diagnostic; ``penetrating_nodes`` counts unconstrained merged nodes whose jump exceeds the gap
    (possible with sigma_l); a friction pair's ``friction`` holds the largest slip |[u_t]| (m) and shear
    |sigma_t| (Pa) over its nodes, the range of its threshold (Pa) and the sum of its shear forces on the first
    body in global coordinates (``total_shear_force_N_per_m``, 3D ``total_shear_force_N``; a frictionless pair
    has no ``friction`` key); ``contact_zone_nodes`` counts the merged nodes where the pressure is positive
    and ``contact_zone_fraction`` the share of the surface they cover (:meth:`Solution.in_contact`,
    :meth:`Solution.contact_fraction`; ``active_nodes``: those that carry a nodal force); ``active_x_m`` is the range of the tangential coordinate s (m) of the
    active nodes (3D: ``active_s_m``, the ranges of both in-plane coordinates (s1, s2) along the pair's
    ``frame`` (t1, t2)). ``electrodes`` lists every electrode's potential (V) and total charge (C/m);
    ``obstacles`` every rigid obstacle's translation (m), contact force and prescribed force (N/m;
    docs/formulation.md §12). ``estimate``: the error estimate (:attr:`Solution.estimate`: kind, guaranteed,
    relative, the absolute and the solution's energy norm in sqrt(J/m), sqrt(J) in 3D) or {"reason": why none}.

    Quantities per unit thickness in 2D are totals in 3D, and their keys say so: ``total_force_N_per_m``,
    ``charge_C_per_m``, ``contact_force_N_per_m``, ``prescribed_force_N_per_m``, ``energy_J_per_m`` in 2D are
    ``total_force_N``, ``charge_C``, ``contact_force_N``, ``prescribed_force_N``, ``energy_J`` in 3D."""
    pairs = [_pair_summary(solution, i) for i in range(len(solution.contacts))]
    per = _per_m(solution)
    cells = "tetrahedra" if solution.scene.dim == 3 else "triangles"
    return {
        "condition": solution.condition,
        "dimension": int(solution.scene.dim),
        "degree": int(getattr(solution, "degree", 1)),
        "status": solution.status,
        "ok": bool(solution.ok),
        "polished": bool(solution.polished),
        "tolerance": solution.tol,
        "residuals": solution.residuals(),
        "timings_s": {k: float(v) for k, v in solution.timings.items()},
        "contact": pairs[0],
        "contacts": pairs,
        f"energy_J{per}": solution.energy,
        "estimate": _estimate_summary(solution),
        "bodies": [{"name": b.name, "material": b.material.name, "nodes": int(len(u)),
                    cells: int(len(b.mesh.cells)), "electric_unknowns": bool(b.piezoelectric),
                    "max_displacement_m": float(np.abs(u).max()),
                    "max_abs_potential_V": float(np.abs(p).max()) if p is not None else None}
                   for b, u, p in zip(solution.scene.bodies, solution.u, solution.phi)],
        "electrodes": [{"body": e.body + 1, "body_name": solution.scene.bodies[e.body].name, "tag": e.tag,
                        "kind": e.kind, "potential_V": e.potential, f"charge_C{per}": e.charge}
                       for e in getattr(solution, "electrodes", [])],
        "obstacles": [{"obstacle": repr(o.obstacle), "pairs": list(o.pairs),
                       "translation_m": [float(v) for v in o.translation],
                       f"contact_force_N{per}": [float(v) for v in o.force],
                       f"prescribed_force_N{per}": None if o.prescribed is None else [float(v) for v in o.prescribed]}
                      for o in getattr(solution, "obstacles", [])],
    }


def _estimate_summary(solution) -> dict:
    est = getattr(solution, "estimate", None)
    if est is None:
        return {"reason": getattr(solution, "estimate_reason", "") or "not computed"}
    unit = "sqrt_J" + _per_m(solution)
    return {"kind": est.kind, "guaranteed": bool(est.guaranteed), "relative": float(est.relative),
            f"absolute_{unit}": float(est.absolute), f"energy_norm_{unit}": float(est.norm)}


def _lengths(solution, k, pair=0):
    """The lumped lengths (2D, m) or areas (3D, m^2) of side ``k``'s trace nodes on pair ``pair``."""
    return TRACES[getattr(solution, "degree", 1)].side_lengths(pair_interface(solution, pair).traces[k])


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
