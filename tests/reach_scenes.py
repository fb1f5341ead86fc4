"""Obstacles that reach a contact part only in part (tests/test_partial_reach.py, test_hex_partial_reach.py,
tests/test_partial_reach_pressure.py): flat obstacles under a strip of the part, +inf distance off it, and the
faces' triangles at a vertex of the 3 x 3 x 1 box's bottom."""

import numpy as np
from hex_scenes import H

import cvxcontact as cc


def strip(lo, hi):
    """The plane z = 0 under the strip lo <= x < hi, its distance along the ray -z; +inf off the strip."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return np.where((x[:, 0] >= lo) & (x[:, 0] < hi), x[:, 2], np.inf)
    return cc.Rigid("strip", distance, f"the plane z = 0 under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile([0.0, 0.0, 1.0], (len(x), 1)), dim=3)


def triangles_at(x, y):
    """The number of the faces' triangles at the vertex (x, y) (m): the diagonals of the 3 x 3 squares read off
    the mesh's bottom faces (the box's Kuhn cells are mirrored from cell to cell)."""
    mesh = cc.box(nx=3, ny=3, nz=1, z=(0.0, H))
    p = np.asarray(mesh.points)[np.asarray(mesh.boundary("bottom"))][..., :2]     # (k, 3, 2)
    return (np.abs(p - [x, y]).max(axis=2) < 1e-9).any(axis=1).sum()


def line(lo, hi):
    """The line y = 0 under lo <= x < hi, its distance along the ray -y; +inf off it (2D)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return np.where((x[:, 0] >= lo) & (x[:, 0] < hi), x[:, 1], np.inf)
    return cc.Rigid("line", distance, f"the line y = 0 under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile([0.0, 1.0], (len(x), 1)), dim=2)
