"""Obstacles that reach a contact part only in part (tests/test_partial_reach.py, test_hex_partial_reach.py,
tests/test_partial_reach_pressure.py): flat obstacles under a strip of the part, +inf distance off it, and the
faces' triangles at a vertex of the 3 x 3 x 1 box's bottom, obstacles that split the part along an oblique line,
and the P2 nodes' consistent loads on that bottom."""

from itertools import pairwise

import numpy as np
from friction_scenes import P, uniform_layer3d
from hex_scenes import DELTA, SIDES, STEEL, H

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


def tilted_plane(lo, hi):
    """The plane z = -4e-6 x - 3e-6 y under the strip lo <= x < hi, its distance along the ray -z; +inf off it:
    the 3 x 3 x 1 box pushed by 1e-5 touches it everywhere with a pressure varying in x and y (an answer not in
    the discrete space)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return np.where((x[:, 0] >= lo) & (x[:, 0] < hi), x[:, 2] + 4e-6 * x[:, 0] + 3e-6 * x[:, 1], np.inf)
    return cc.Rigid("tilted plane", distance, f"the plane z = -4e-6 x - 3e-6 y under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile([0.0, 0.0, 1.0], (len(x), 1)), dim=3)


def step(at, dim, drop=3e-6):
    """One obstacle: the plane (2D: line) y = 0 (3D: z) under x < ``at``, y = -``drop`` under x >= ``at``, its
    distance along the ray -y (-z): the upper envelope of :func:`strip` (:func:`line`) under x < ``at`` and
    :func:`lowered` under the whole part, as a single pair."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return x[:, dim - 1] + np.where(x[:, 0] < at, 0.0, drop)
    return cc.Rigid("step", distance, f"a floor falling by {drop} at x = {at}",
                    sensitivity=lambda x, nu: np.tile(np.eye(dim)[dim - 1], (len(x), 1)), dim=dim)


def raised(lo, hi, dim, up=3e-6):
    """One obstacle: the plane (2D: line) y = 0 (3D: z) with the strip lo <= x < hi of it raised by ``up`` (m), its
    distance along the ray -y (-z): the upper envelope of a whole floor (:func:`line`, :func:`strip`) and
    :func:`lowered` (``drop=-up``) under that strip, as a single pair (the tightest gap at each node)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return x[:, dim - 1] - np.where((x[:, 0] >= lo) & (x[:, 0] < hi), up, 0.0)
    return cc.Rigid("raised", distance, f"a floor raised by {up} under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile(np.eye(dim)[dim - 1], (len(x), 1)), dim=dim)


def box_on_boxes(cuts=(0.4,), n=3):
    """The n x n x 1 box [0, 1]^2 x [0, H] of steel pushed down by DELTA onto boxes [c_i, c_i+1] x [0, 1] x [-H, 0]
    clamped at their bottom (0 = c_0 < cuts < 1), every side on rollers, one pair per lower box (the upper box
    first): a column in uniaxial strain, the pressure the closed form M DELTA / (2 H) (M = c_33) on the whole
    interface; the lower boxes' meshes (2 cells per 0.4 m along x, 2 along y) meet the upper box's faces in part
    only."""
    top = cc.Body(cc.box(nx=n, ny=n, nz=1, z=(0.0, H)), STEEL, roller=SIDES,
                  displacement={"top": (None, None, -DELTA)}, contact="bottom", name="upper")
    edges = (0.0, *cuts, 1.0)
    lows = [cc.Body(cc.box(x=(a, b), nx=max(1, round(5 * (b - a))), ny=2, nz=1, z=(-H, 0.0)), STEEL,
                    roller=SIDES, clamped="bottom", contact="top", name=f"lower {i}")
            for i, (a, b) in enumerate(pairwise(edges))]
    return cc.Scene(top, *lows, contacts=[cc.Contact(top, "bottom", low, "top") for low in lows])


def block_on_blocks2d(law=None, cuts=(0.4,), flip=False):
    """The 2D steel block [0, 1] x [0, H] (5 x 2 cells, clamped on its top, pressed down by its weight, sheared on
    its right side) interfering by 1e-5 m with lower blocks [c_i, c_i+1] x [-H, 0] (7 cells per m along x) clamped
    at their base (0 = c_0 < ``cuts`` < 1), ``law`` on each pair: its bottom held by every pair, posed from the upper
    block (its bottom each pair's first side) or, ``flip``, from each lower one (its second side)."""
    top = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, H), nx=5, ny=2), STEEL, clamped="top", contact="bottom",
                  body_force=(0.0, -2e9), traction={"right": (0.0, 1e8)}, name="upper")
    edges = (0.0, *cuts, 1.0)
    lows = [cc.Body(cc.rectangle(x=(a, b), y=(-H, 0.0), nx=max(1, round(7 * (b - a))), ny=2), STEEL,
                    clamped="bottom", contact="top", name=f"lower {i}") for i, (a, b) in enumerate(pairwise(edges))]
    return cc.Scene(top, *lows, contacts=[cc.Contact(low, "top", top, "bottom", gap=-1e-5, law=law) if flip else
                                          cc.Contact(top, "bottom", low, "top", gap=-1e-5, law=law) for low in lows])


def block2d(obstacles, nx=6, cell="triangle"):
    """The ``nx`` x 2 steel block [0, 1] x [0, H] (``cell`` "triangle" or "quad") on rollers, pushed down by DELTA
    onto ``obstacles`` under its bottom (one pair each)."""
    body = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, H), nx=nx, ny=2, cell=cell), STEEL, roller=["left", "right"],
                   displacement={"top": (None, -DELTA)}, contact="bottom")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", o) for o in obstacles])


def block3d(obstacles, cell="tetra", body_force=None):
    """The 3 x 3 x 1 steel box [0, 1]^2 x [0, H] (``cell`` "tetra" or "hex") on rollers, pushed down by DELTA onto
    ``obstacles`` under its bottom (one pair each), under ``body_force`` (N/m^3, default none)."""
    body = cc.Body(cc.box(nx=3, ny=3, nz=1, z=(0.0, H), cell=cell), STEEL, roller=SIDES,
                   displacement={"top": (None, None, -DELTA)}, contact="bottom", body_force=body_force)
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", o) for o in obstacles])


def lowered(lo, hi, dim, drop=3e-6, kink=None):
    """The plane (2D: line) y = -``drop`` (3D: z) under lo <= x < hi, its distance along the ray -y (-z); +inf off
    it. ``kink``: at the floor up to x = kink, then falling by 1e-5 per m (``drop`` not used): beside a whole
    floor under the block pushed by DELTA it is touched where x <= kink only (:func:`block2d`, :func:`block3d`)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        below = drop if kink is None else 1e-5 * np.maximum(0.0, x[:, 0] - kink)
        return np.where((x[:, 0] >= lo) & (x[:, 0] < hi), x[:, dim - 1] + below, np.inf)
    return cc.Rigid("lowered", distance, f"a floor lowered under {lo} <= x < {hi}",
                    sensitivity=lambda x, nu: np.tile(np.eye(dim)[dim - 1], (len(x), 1)), dim=dim)


BODIES = {"2D P1": (2, 1, "tetra"), "2D P2": (2, 2, "tetra"), "3D P1": (3, 1, "tetra"), "3D P2": (3, 2, "tetra"),
          "3D Q1": (3, 1, "hex")}
"""The bodies of the parallel-obstacle scenes (tests/test_parallel_obstacles.py, benchmarks/parallel_same_bits.py):
name -> (dimension, degree, cell)."""


def floor(dim, lo=-1.0, hi=2.0):
    """The floor y = 0 (3D: z = 0) under lo <= x < hi: :func:`line` or :func:`strip`."""
    return line(lo, hi) if dim == 2 else strip(lo, hi)


def block(obstacles, dim, cell):
    """The block of :func:`block2d` or :func:`block3d` on ``obstacles``."""
    return block2d(obstacles) if dim == 2 else block3d(obstacles, cell=cell)


def kinked(dim, kink=0.3, shift=0.0):
    """The plane (2D: line) y = 0 (3D: z) up to x = ``kink``, then falling by 1e-5 per m, moved down by ``shift``
    (m; < 0: up), its distance along the ray -y (-z): :func:`lowered` (``kink``) under the whole part, at x <=
    kink one floor with the block under DELTA; two of them make rows of two obstacles at one node whose contact
    zone the active-set steps find in several sets (gaps equal, ``shift`` 0, or apart by ``shift``)."""
    def distance(x, nu):
        x = np.asarray(x, dtype=float)
        return x[:, dim - 1] + 1e-5 * np.maximum(0.0, x[:, 0] - kink) + shift
    return cc.Rigid("kinked", distance, f"a floor falling by 1e-5 per m from x = {kink}, moved down by {shift}",
                    sensitivity=lambda x, nu: np.tile(np.eye(dim)[dim - 1], (len(x), 1)), dim=dim)


STRIPS_LAWS = {"tresca": lambda: cc.Tresca(2 * P), "coulomb": lambda: cc.Coulomb(0.5)}
"""The laws that hold the layer of :func:`layer_on_strips_key` stuck."""


def layer_on_strips_key(law):
    """(key, make) of conftest's ``shared`` for the 3 x 3 x 1 P2 layer stuck under the uniform shear tau = 0.2 p
    (:func:`friction_scenes.uniform_layer3d`) on the strips x < 0.7, x >= 0.3 and a whole floor (three pairs on its
    bottom), "sigma1", degree 2, under ``STRIPS_LAWS[law]`` ("tresca": Tresca 2 p; "coulomb": Coulomb 0.5): read by
    tests/test_sides.py and test_estimate_shared_part.py (``shared(*layer_on_strips_key(law))``)."""

    def make():
        scene = uniform_layer3d(0.2 * P, STRIPS_LAWS[law](), n=3,
                                obstacles=(strip(-1.0, 0.7), strip(0.3, 2.0), strip(-1.0, 2.0)))
        return cc.solve(scene, "sigma1", degree=2)

    return ("P2 layer stuck on strips and a floor, sigma1", law), make
