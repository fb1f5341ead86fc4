"""Obstacles that reach a contact part only in part (tests/test_partial_reach.py, test_hex_partial_reach.py,
tests/test_partial_reach_pressure.py): flat obstacles under a strip of the part, +inf distance off it, and the
faces' triangles at a vertex of the 3 x 3 x 1 box's bottom, obstacles that split the part along an oblique line,
and the P2 nodes' consistent loads on that bottom."""

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


def line(lo, hi, tol=0.0):
    """The line y = 0 under lo - tol <= x < hi + tol, its distance along the ray -y; +inf off it (2D)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return np.where((x[:, 0] >= lo - tol) & (x[:, 0] < hi + tol), x[:, 1], np.inf)
    return cc.Rigid("line", distance, f"the line y = 0 under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile([0.0, 1.0], (len(x), 1)), dim=2)


def half(a, b, c, below):
    """The plane z = 0 under a x + b y < c (``below``) or under its complement, its distance along the ray -z; +inf
    elsewhere: two such obstacles split the part along an oblique line, cutting faces across their diagonals."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        side = a * x[:, 0] + b * x[:, 1] < c
        return np.where(side == below, x[:, 2], np.inf)
    return cc.Rigid("half", distance, f"the plane z = 0 where ({a} x + {b} y < {c}) is {below}",
                    sensitivity=lambda x, nu: np.tile([0.0, 0.0, 1.0], (len(x), 1)), dim=3)


OBLIQUE = [(1.0, 0.7, 0.55), (0.3, 1.0, 0.93)]
"""Lines a x + b y = c that split the 3 x 3 x 1 box's bottom across its faces' diagonals (:func:`half`)."""


def p2_loads(points):
    """(n,) m^2: the consistent loads of a unit pressure at P2 nodes ``points`` of the 3 x 3 x 1 box's bottom, by
    hand: 0 at a vertex, A/3 per triangle of an edge midpoint's edge (A = 1/18 m^2): A/3 on the boundary, 2A/3
    inside."""
    i = np.rint(np.asarray(points)[:, :2] * 6).astype(int)
    vertex = (i % 2 == 0).all(axis=1)
    boundary = ((i == 0) | (i == 6)).any(axis=1)
    return np.where(vertex, 0.0, np.where(boundary, 1 / 54, 2 / 54))
