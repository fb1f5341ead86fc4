"""Hexahedral two-body scenes and an independent sampler of their contact jump (tests/test_hex_nested.py,
tests/test_refusals.py): boxes of Q1 hexahedra on [0, 1]^2, warped by a piecewise bilinear map so that grids
refining each other stay nested face in reference rectangle; a lower block clamped under an upper one pushed
down; the jump g - [u_nu] sampled on the faces of one side with both traces evaluated by the Q1 functions written
here (no package code: the other side's face and reference point found by this module's own Newton iteration);
the nested and aligned crossing grids (:data:`NESTED`, :data:`CROSSING`) and an affine gap leaving part of the
faces open (:data:`TILTED`, :data:`PUSH`) that tests/test_hex_nested.py and tests/test_hex_compliance.py share.
"""

import numpy as np

import cvxcontact as cc

STEEL = cc.materials.isotropic(E=200e9, nu=0.3)
ALU = cc.materials.isotropic(E=70e9, nu=0.33)
SIDES = ["left", "right", "front", "back"]
DELTA = 1e-5
CENTRE = np.array([0.08, -0.06])     # where the centre column of a "skewed" grid moves (m)


# the series column: two blocks of height H (steel below, aluminium above) pushed together by DELTA through a
# compliance law p = k r^m (tests/test_hex_compliance.py, tests/test_hex_q2_compliance.py)
H = 0.5
M_S, M_A = float(STEEL.tensors(3)[0][2, 2]), float(ALU.tensors(3)[0][2, 2])     # c_33 (Pa): uniaxial strain
SOFT = {1: 2e11, 2: 2e16}     # Pa/m^m by exponent m: the law's penetration 0.42 and 0.56 of DELTA


def series(k, m, c=H / M_S + H / M_A, delta=DELTA):
    """(p Pa, r m): pressure and penetration of a column of compliance ``c`` (m/Pa; default the steel-aluminium
    column, H / M_steel + H / M_alu) pushed by ``delta`` through the law p = k r^m: r + p c = delta."""
    r = delta / (1.0 + k * c) if m == 1 else (np.sqrt(1.0 + 4.0 * k * c * delta) - 1.0) / (2.0 * k * c)
    return k * r ** m, r


def check_column(sol, p, r):
    """Assert the series column's closed form on ``sol`` (steel below z = H, aluminium above): u_z piecewise linear
    with the jump r at the faces, no lateral u, the forces summing to p times the faces' area (1 m^2), every row
    reading p. Measured: u <= 1.2e-15 DELTA (Q2, Q1 nested/crossing <= 6.8e-16), forces <= 1.4e-15 p, lam <=
    2.9e-15 p."""
    for k, exact in enumerate((lambda z: -p * z / M_S, lambda z: -p * H / M_S - r - p * (z - H) / M_A)):
        z = sol.points[k][:, 2]
        assert np.abs(sol.u[k][:, 2] - exact(z)).max() <= 1e-12 * DELTA
        assert np.abs(sol.u[k][:, :2]).max() <= 1e-12 * DELTA
    c = sol.contacts[0]
    assert abs(c.force.sum() - p) <= 1e-12 * p
    assert np.abs(c.lam - p).max() <= 1e-12 * p


def warp(xy):
    """(k, 2): the piecewise bilinear map of the unit square onto itself taking the 2 x 2 grid's centre (0.5, 0.5)
    to (0.5, 0.5) + CENTRE, the square's boundary fixed: a coarse grid of 2 x 2 general quadrilaterals, and any
    grid refining the regular one (points at k/2^j) mapped by it nests in it, face in reference rectangle."""
    xy = np.asarray(xy, dtype=float)
    i = np.minimum((xy * 2).astype(int), 1)                        # the cell of the regular 2 x 2 grid
    s = xy * 2 - i                                                  # its local coordinates in [0, 1]^2
    corner = lambda a, b: np.stack([(i[:, 0] + a) / 2, (i[:, 1] + b) / 2], axis=1) + \
        CENTRE * (((i[:, 0] + a) == 1) & ((i[:, 1] + b) == 1))[:, None]
    N = [(1 - s[:, 0]) * (1 - s[:, 1]), s[:, 0] * (1 - s[:, 1]), s[:, 0] * s[:, 1], (1 - s[:, 0]) * s[:, 1]]
    return sum(n[:, None] * corner(a, b) for n, (a, b) in zip(N, ((0, 0), (1, 0), (1, 1), (0, 1))))


def block(n, z, skewed=False, m=None):
    """A box [0, 1]^2 x z of n x m x 1 hexahedra (m = n unless given), warped by :func:`warp` if ``skewed``."""
    mesh = cc.box(z=z, nx=n, ny=n if m is None else m, nz=1, cell="hex")
    if not skewed:
        return mesh
    p = mesh.points.copy()
    p[:, :2] = warp(p[:, :2])
    return mesh.with_points(p)


def pair(lower_mesh, upper_mesh, gap=0.0, push=DELTA, materials=(STEEL, STEEL), swap=False, rollers=True):
    """The lower block clamped on its bottom, the upper one pushed down by ``push`` at its top, rollers on the
    sides (``rollers``; without them the upper's top is held in its plane), one pair between the lower's top and the upper's bottom (``swap``: written upper
    first) with ``gap``."""
    sides = SIDES if rollers else []
    lower = cc.Body(lower_mesh, materials[0], roller=sides, clamped=["bottom"], contact="top", name="lower")
    upper = cc.Body(upper_mesh, materials[1], roller=sides, contact="bottom", name="upper",
                    displacement={"top": (None, None, -push) if rollers else (0.0, 0.0, -push)})
    contact = cc.Contact(upper, "bottom", lower, "top", gap=gap) if swap else \
        cc.Contact(lower, "top", upper, "bottom", gap=gap)
    return cc.Scene(lower, upper, contacts=[contact])


def shape(xi):
    """(k, 4): the Q1 functions of the reference square [-1, 1]^2 at ``xi`` (k, 2), corners in the VTK order
    (-1, -1), (1, -1), (1, 1), (-1, 1)."""
    a, b = xi[:, 0], xi[:, 1]
    return np.stack([(1 - a) * (1 - b), (1 + a) * (1 - b), (1 + a) * (1 + b), (1 - a) * (1 + b)], axis=1) / 4


def locate(X, points):
    """(face (k,), xi (k, 2)): a quadrilateral of corners ``X`` (f, 4, 2) holding each point (k, 2) and its
    reference point there (Newton on every face's bilinear map from its centre, 40 steps; the first face whose
    reference point lies in [-1, 1]^2 to 1e-10; face -1 for a point in none)."""
    k, f = len(points), len(X)
    xi = np.zeros((k, f, 2))
    d = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) / 4
    for _ in range(40):
        N = shape(xi.reshape(-1, 2)).reshape(k, f, 4)
        a, b = xi[..., 0:1], xi[..., 1:2]
        dNa = d[:, 0] * (1 + d[:, 1] * 4 * b)                       # d N_i / d a, d N_i / d b
        dNb = d[:, 1] * (1 + d[:, 0] * 4 * a)
        r = points[:, None] - np.einsum("kfi,fid->kfd", N, X)
        J = np.stack([np.einsum("kfi,fid->kfd", dNa, X), np.einsum("kfi,fid->kfd", dNb, X)], axis=-1)
        xi = xi + np.linalg.solve(J, r[..., None])[..., 0]
    inside = (np.abs(xi) <= 1 + 1e-10).all(axis=2)
    face = np.where(inside.any(axis=1), np.argmax(inside, axis=1), -1)
    return face, xi[np.arange(k), np.maximum(face, 0)]


def sampled_slack(scene, sol, fine, gap=None, n=7):
    """(slack (F, n * n), scale): g - [u_nu] at n x n points of each of the contact faces (F) of side ``fine`` of
    the pair of :func:`pair` (0: the lower body), both traces by the Q1 functions of their faces (the face's own;
    the other side's face holding the point, located by :func:`locate`; NaN at a point off the other side's
    part), u . nu of the lower body (its top, nu = +z) minus the upper's, g the function ``gap``(x, y) (None: 0);
    ``scale`` the largest |u_z| on the two faces."""
    bodies, parts = scene.bodies, ("top", "bottom")
    t = np.linspace(-1.0, 1.0, n)
    ref = np.stack(np.meshgrid(t, t, indexing="ij"), axis=-1).reshape(-1, 2)
    N = shape(ref)
    faces = bodies[fine].mesh.boundary(parts[fine])
    X = bodies[fine].mesh.points[faces][:, :, :2]
    points = np.einsum("pi,fid->fpd", N, X).reshape(-1, 2)
    uz = [None, None]
    uz[fine] = np.einsum("pi,fi->fp", N, sol.u[fine][faces, 2]).ravel()
    coarse = bodies[1 - fine].mesh.boundary(parts[1 - fine])
    face, xi = locate(bodies[1 - fine].mesh.points[coarse][:, :, :2], points)
    uz[1 - fine] = (shape(xi) * sol.u[1 - fine][coarse[face], 2]).sum(axis=1)
    jump = np.where(face >= 0, uz[0] - uz[1], np.nan)
    g = np.zeros(len(points)) if gap is None else np.asarray(gap(points[:, 0], points[:, 1]), dtype=float)
    scale = max(np.abs(sol.u[k][bodies[k].mesh.boundary_nodes([parts[k]]), 2]).max() for k in (0, 1))
    return (g - jump).reshape(len(faces), -1), scale


NESTED = {"4 on 2": ((4, 4), (2, 2), False), "2 on 4": ((2, 2), (4, 4), False), "4x2 on 2x2": ((4, 2), (2, 2), False),
          "2x2 on 2x4": ((2, 2), (2, 4), False), "8 on 2": ((8, 8), (2, 2), False),
          "skewed 4 on 2": ((4, 4), (2, 2), True), "skewed 2 on 4": ((2, 2), (4, 4), True)}
"""Nested pairs: the lower and upper blocks' cells (nx, ny), and whether the grids are warped (:func:`block`)."""


def nested(case, **kw):
    """(the pair of :data:`NESTED` ``case``, its finer side: 0 the lower block, 1 the upper)."""
    (n1, m1), (n2, m2), skewed = NESTED[case]
    return pair(block(n1, (0.0, 0.5), skewed, m1), block(n2, (0.5, 1.0), skewed, m2), **kw), int(n2 * m2 > n1 * m1)


TILTED = lambda s1, s2: 1e-6 + 8e-6 * s1 + 3e-6 * s2        # an affine gap (m): partial contact
PUSH = 6e-6                                                  # m, against TILTED from 1e-6 to 1.2e-5


CROSSING = {"3 on 2": ((3, 3), (2, 2)), "2 on 3": ((2, 2), (3, 3)), "3x2 on 2x5": ((3, 2), (2, 5)),
            "5 on 3": ((5, 5), (3, 3))}
"""Aligned grids that do not nest: the lower and upper blocks' cells (nx, ny)."""
