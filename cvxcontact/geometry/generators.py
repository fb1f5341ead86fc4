"""Mesh generators beyond :func:`~cvxcontact.geometry.mesh.rectangle`: a graded block and a half disk.

Both return a validated :class:`~cvxcontact.geometry.mesh.Mesh` (metres) with tagged boundary parts,
so that punches, indenters and refined contact zones need no external mesher.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import MeshError
from .mesh import Mesh, rectangle, segment_parts

__all__ = ["graded_block", "half_disk"]


def graded_block(x: Sequence[float], y: Sequence[float], nx: int, ny: int, contact: str = "bottom",
                 beta: float = 0.0, gamma: float = 0.0, center: float = 0.0,
                 segments: Mapping[str, tuple] | None = None, cell: str = "triangle") -> Mesh:
    """A structured block on ``x`` by ``y`` (m) whose cells shrink towards x = ``center`` (m; sinh
    grading of strength ``beta``) and towards its ``contact`` edge, "bottom" or "top" (exponential
    grading ``gamma``). Tags as :func:`~cvxcontact.geometry.mesh.rectangle`; beta = gamma = 0 gives a
    uniform grid. ``segments`` and ``cell`` ("quad": a :class:`~cvxcontact.geometry.quadmesh.QuadMesh`) as in
    :func:`rectangle`, on the graded coordinates (ends on grid nodes)."""
    if contact not in ("bottom", "top"):
        raise MeshError(f"graded_block: contact must be 'bottom' or 'top', got {contact!r}")
    for key, v in (("beta", beta), ("gamma", gamma), ("center", center)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not np.isfinite(v):
            raise MeshError(f"graded_block: {key} must be a finite number, got {v!r}")
    if beta < 0 or gamma < 0:
        raise MeshError(f"graded_block: beta and gamma must be >= 0, got beta={beta!r}, gamma={gamma!r}")
    base = rectangle(x=(0.0, 1.0), y=(0.0, 1.0), nx=nx, ny=ny, cell=cell)
    xi, eta = base.points[:, 0], base.points[:, 1]
    (x0, x1), (y0, y1) = rectangle(x=x, y=y, nx=1, ny=1).points[[0, 3]].T    # validated intervals
    if beta > 0 and not x0 < center < x1:
        raise MeshError(f"graded_block: center must lie inside x = [{x0:g}, {x1:g}], got {center!r}")
    X = x0 + (x1 - x0) * xi
    if beta > 0:
        t0 = (center - x0) / (x1 - x0)
        u = np.where(xi < t0, (xi - t0) / t0, (xi - t0) / (1 - t0))          # in [-1, 1], 0 at the centre
        X = center + np.where(u < 0, center - x0, x1 - center) * np.sinh(beta * u) / np.sinh(beta)
    d = eta if contact == "bottom" else 1 - eta                             # 0 on the contact edge
    if gamma > 0:
        d = (np.exp(gamma * d) - 1) / (np.exp(gamma) - 1)
    Y = y0 + (y1 - y0) * d if contact == "bottom" else y1 - (y1 - y0) * d
    points = np.column_stack([X, Y])
    tags = {t: base.boundary(t) for t in base.tags}
    tags.update(segment_parts(segments, {t: base.boundary(t) for t in base.tags}, points, "graded_block"))
    return type(base)(points, base.cells, tags)


def half_disk(radius: float, center: Sequence[float] = (0.0, 0.0), nr: int = 6, nt: int = 12,
              side: str = "bottom") -> Mesh:
    """The half of the disk of ``radius`` (m) around ``center`` on the ``side`` ("bottom", "top", "left",
    "right") of its diameter: a cylinder's cross-section cut in two (a half-space indenter, a Hertz half
    model). ``nr`` rings, ``nt`` cells along each half ring (a fan at the centre). Tags: ``"flat"`` (the
    diameter) and ``"arc"`` (the curved boundary)."""
    if isinstance(radius, bool) or not isinstance(radius, (int, float, np.integer, np.floating)) \
            or not np.isfinite(radius) or radius <= 0:
        raise MeshError(f"half_disk: radius must be a positive number (m), got {radius!r}")
    for key, v in (("nr", nr), ("nt", nt)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise MeshError(f"half_disk: {key} must be a positive integer, got {v!r}")
    start = {"bottom": np.pi, "right": -np.pi / 2, "top": 0.0, "left": np.pi / 2}
    if not isinstance(side, str) or side not in start:
        raise MeshError(f"half_disk: side must be one of {sorted(start)}, got {side!r}")
    try:
        cx, cy = (float(c) for c in center)
    except (TypeError, ValueError):
        raise MeshError(f"half_disk: center must be a pair of numbers (m), got {center!r}") from None
    r = radius * np.arange(1, nr + 1) / nr
    t = start[side] + np.pi * np.arange(nt + 1) / nt
    R, T = np.meshgrid(r, t, indexing="ij")                                   # (nr, nt + 1)
    ring = np.column_stack([cx + (R * np.cos(T)).ravel(), cy + (R * np.sin(T)).ravel()])
    points = np.vstack([[cx, cy], ring])
    node = 1 + np.arange(nr * (nt + 1)).reshape(nr, nt + 1)
    fan = np.column_stack([np.zeros(nt, dtype=int), node[0, :-1], node[0, 1:]])
    a, b, c, d = node[:-1, :-1].ravel(), node[:-1, 1:].ravel(), node[1:, :-1].ravel(), node[1:, 1:].ravel()
    triangles = np.vstack([fan, np.column_stack([a, c, d]), np.column_stack([a, d, b])])
    chain = np.concatenate([node[::-1, 0], [0], node[:, -1]])                 # one end of the diameter to the other
    flat = np.column_stack([chain[:-1], chain[1:]])
    arc = np.column_stack([node[-1, :-1], node[-1, 1:]])
    return Mesh(points, triangles, {"flat": flat, "arc": arc})
