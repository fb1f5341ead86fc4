"""Q1 hexahedra: "gamma3" between two bodies whose contact faces are nested (issue 31, item 3;
cvxcontact/fem/hexfaces.py).

Independent references: the jump of the answer sampled at 7 x 7 points of every fine face, both traces evaluated
by the Q1 shape functions written here (the coarse face's reference point found by this file's own Newton
iteration), against the gap; the uniaxial closed form of a column squeezed through nested faces (displacements,
stresses, forces, pressures); the reference backend (``method="full"``); the same scene with its pair written
the other way round; the fine side's nodal rows ("sigma1"/"sigma2", the same condition) and the coarse side's
(a weaker one, under which the fine face sinks into the coarse body between the coarse corners).
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.errors import UnsupportedError
from cvxcontact.fem.fields import body_fields
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics

STEEL = cc.materials.isotropic(E=200e9, nu=0.3)
ALU = cc.materials.isotropic(E=70e9, nu=0.33)
SIDES = ["left", "right", "front", "back"]
DELTA = 1e-5
CENTRE = np.array([0.08, -0.06])     # where the centre column of a "skewed" grid moves (m)


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
    reference point lies in [-1, 1]^2 to 1e-10)."""
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
    assert inside.any(axis=1).all()
    face = np.argmax(inside, axis=1)
    return face, xi[np.arange(k), face]


def sampled_slack(scene, sol, fine, gap=None, n=7):
    """(slack (F, n * n), scale): g - [u_nu] at n x n points of each of the fine side's contact faces (F), both
    traces by the Q1 functions of their faces (the fine face's own; the coarse face holding the point, located by
    :func:`locate`), u . nu of the lower body (its top, nu = +z) minus the upper's, g the function ``gap``(x, y)
    (None: 0); ``scale`` the largest |u_z| on the two faces."""
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
    jump = uz[0] - uz[1]
    g = np.zeros(len(points)) if gap is None else np.asarray(gap(points[:, 0], points[:, 1]), dtype=float)
    scale = max(np.abs(sol.u[k][bodies[k].mesh.boundary_nodes([parts[k]]), 2]).max() for k in (0, 1))
    return (g - jump).reshape(len(faces), -1), scale


CASES = {"4 on 2": (4, 2, None, False), "2 on 4": (2, 4, None, False), "4x2 on 2x2": (4, 2, 2, False),
         "skewed 4 on 2": (4, 2, None, True), "skewed 2 on 4": (2, 4, None, True)}


def nested(case, **kw):
    """The pair of :data:`CASES` ``case``: (n lower, n upper, m of the finer side in y or None, skewed)."""
    n1, n2, m, skewed = CASES[case]
    fine_m = lambda n: m if (m is not None and n == max(n1, n2)) else None
    return pair(block(n1, (0.0, 0.5), skewed, fine_m(n1)), block(n2, (0.5, 1.0), skewed, fine_m(n2)), **kw), \
        int(n2 > n1)


TILTED = lambda s1, s2: 1e-6 + 8e-6 * s1 + 3e-6 * s2        # an affine gap (m): partial contact
PUSH = 6e-6                                                  # m, against TILTED from 1e-6 to 1.2e-5


@pytest.mark.parametrize("case", list(CASES))
def test_nested_gamma3_holds_everywhere_on_the_fine_faces(case):
    """Under an affine gap that leaves part of the faces open, "gamma3" on nested faces (aligned grids 2:1 in
    both directions or one, the finer side below or above; general quadrilaterals refined in their bilinear
    coordinates) is non-penetration at every sampled point of every fine face (7 x 7 per face, the Q1 traces
    written here), the rows are the fine side's nodes only (fewer than the overlay's vertices where the faces'
    diagonals cross), every fine face whose four corners carry force is closed everywhere (a bilinear jump
    vanishing at its corners), the checks hold, and the reference backend gives the same answer."""
    scene, fine = nested(case, gap=TILTED, rollers=False, push=PUSH)
    lines = space(1, "hex").contact(scene, "gamma3", None)
    itf = lines.interface.interfaces[0]
    fine_nodes = scene.bodies[fine].mesh.boundary_nodes(["top" if fine == 0 else "bottom"])
    assert lines.E.shape[0] == len(fine_nodes) <= itf.size
    if case == "4x2 on 2x2":
        assert len(fine_nodes) < itf.size                        # the coarse diagonals cut the fine faces
    assert np.array_equal(lines.gap, TILTED(itf.x[:, 0], itf.x[:, 1]))      # the gap at the nodes of X_h
    sol = cc.solve(scene, "gamma3")
    assert sol.ok and sol.polished
    slack, scale = sampled_slack(scene, sol, fine, TILTED)
    assert scale > 0.1 * PUSH
    assert slack.min() >= -1e-12 * scale                                   # measured >= -5.5e-16 scale
    assert slack.max() >= 0.1 * scale                                      # partly open: measured 0.91 scale
    c = sol.contacts[0]
    force = np.asarray(c.force)
    carry = force > 1e-9 * force.max()
    node_of = np.full(scene.bodies[fine].mesh.points.shape[0], -1)
    at = np.asarray(itf.overlay.node_a if fine == 0 else itf.overlay.node_b)
    node_of[itf.traces[fine].nodes[at >= 0]] = at[at >= 0]
    faces = scene.bodies[fine].mesh.boundary("top" if fine == 0 else "bottom")
    closed = carry[node_of[faces]].all(axis=1)
    assert 0 < closed.sum() < len(faces)
    assert np.abs(slack[closed]).max() <= 1e-12 * scale                    # measured <= 5.5e-16 scale
    assert (np.abs(c.jump - c.gap)[carry] <= 1e-12 * scale).all()          # at the rows: measured <= 5.5e-16
    full = cc.solve(scene, "gamma3", method="full")
    assert full.ok
    for k in (0, 1):
        assert np.abs(full.u[k] - sol.u[k]).max() <= 1e-10 * scale         # measured <= 9.7e-16 scale


@pytest.mark.parametrize("case", ["4 on 2", "2 on 4", "4x2 on 2x2", "skewed 4 on 2", "skewed 2 on 4"])
def test_uniform_pressure_through_nested_faces_is_the_closed_form(case):
    """A steel block under an aluminium one, rollers on the sides, pushed by DELTA through nested faces: uniaxial
    strain, sigma_zz = -p, p = DELTA / (H/M_steel + H/M_alu), u_z piecewise linear, u_x = u_y = 0, the force p A
    (A = 1 m^2), the pressure each body feels (nodal forces over the Q1 hats' areas) and the rows' pressure
    (forces over the fine hats' integrals) p at every node."""
    scene, _ = nested(case, materials=(STEEL, ALU))
    sol = cc.solve(scene, "gamma3")
    assert sol.ok and sol.polished
    M_s, M_a = float(STEEL.tensors(3)[0][2, 2]), float(ALU.tensors(3)[0][2, 2])
    H = 0.5
    p = DELTA / (H / M_s + H / M_a)
    for k, exact in enumerate((lambda z: -p * z / M_s, lambda z: -p * H / M_s - p * (z - H) / M_a)):
        z = sol.points[k][:, 2]
        assert np.abs(sol.u[k][:, 2] - exact(z)).max() <= 1e-12 * DELTA      # measured <= 6.8e-16 DELTA
        assert np.abs(sol.u[k][:, :2]).max() <= 1e-12 * DELTA                # measured <= 3.3e-16 DELTA
        stress = body_fields(scene.bodies[k], sol.u[k], None).stress
        c = (STEEL, ALU)[k].tensors(3)[0]
        assert np.abs(stress[:, 2] + p).max() <= 1e-12 * p                      # measured <= 6.3e-16 p
        assert np.abs(stress[:, 0] + p * c[0, 2] / c[2, 2]).max() <= 1e-12 * p  # measured <= 2.4e-16 p
        assert np.abs(stress[:, 3:]).max() <= 1e-12 * p                         # measured <= 3.3e-16 p
    c = sol.contacts[0]
    assert abs(c.force.sum() - p) <= 1e-12 * p                                 # measured <= 4.7e-16 p
    assert np.abs(c.pressure[c.constrained] - p).max() <= 1e-12 * p           # measured <= 2.1e-15 p
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] - p).max() <= 1e-12 * p              # measured <= 2.1e-15 p


def test_nested_gamma3_is_the_fine_sides_nodal_rows_and_stricter_than_the_coarse_sides():
    """A fine upper block (4 x 4 faces) pushed onto a coarse lower one (one face): "gamma3" is the fine side's
    nodal rows ("sigma2" here: the same rows, the same answer); the coarse side's rows ("sigma1", its four
    corners) let the fine face sink into the coarse body between them (the sampled jump), "gamma3" does not, and
    its energy is the larger (a smaller feasible set). (The two routes differ: "gamma3" between two 3D bodies is
    finished as if its rows could depend on each other.)"""
    scene = pair(block(1, (0.0, 0.5)), block(4, (0.5, 1.0)), rollers=False)
    a = space(1, "hex").contact(scene, "gamma3", None)
    b = space(1, "hex").contact(scene, "sigma2", None)
    assert (a.E != b.E).nnz == 0 and a.E.shape[0] == 25
    g3, s2, s1 = (cc.solve(scene, c) for c in ("gamma3", "sigma2", "sigma1"))
    assert g3.ok and s2.ok and s1.ok
    slack, scale = sampled_slack(scene, g3, 1)
    for k in (0, 1):
        assert np.abs(g3.u[k] - s2.u[k]).max() <= 1e-12 * scale               # measured <= 1.1e-15 scale
    assert slack.min() >= -1e-12 * scale                                       # measured >= -1.6e-15 scale
    coarse_rows, _ = sampled_slack(scene, s1, 1)
    assert coarse_rows.min() <= -0.1 * scale                                   # measured -1.8 scale
    assert g3.energy - s1.energy >= 1e-2 * abs(s1.energy)                      # measured 0.38 |s1.energy|


@pytest.mark.parametrize("case", ["4 on 2", "skewed 2 on 4"])
def test_either_side_first_gives_the_same_answer(case):
    """The pair written fine side first or second (Contact(lower, "top", upper, "bottom") or the reverse) poses
    the same condition: the same displacements, force and energy."""
    one, _ = nested(case, gap=TILTED, rollers=False, push=PUSH)
    two, _ = nested(case, gap=TILTED, rollers=False, push=PUSH, swap=True)
    a, b = cc.solve(one, "gamma3"), cc.solve(two, "gamma3")
    assert a.ok and b.ok
    scale = max(np.abs(u).max() for u in a.u)
    for k in (0, 1):
        assert np.abs(a.u[k] - b.u[k]).max() <= 1e-10 * scale                  # measured <= 6.9e-17 scale
    assert abs(a.contacts[0].force.sum() - b.contacts[0].force.sum()) <= 1e-10 * abs(a.contacts[0].force.sum())
    assert abs(a.energy - b.energy) <= 1e-10 * abs(a.energy)                   # measured <= 1.6e-16 (both)


def test_faces_neither_matching_nor_nested_are_refused_naming_why_and_the_alternatives():
    """Typed refusals of "gamma3" between faces that neither match nor nest: crossing grids (3 on 2: a face lies
    across several), a skewed fine grid inside one coarse face (its faces are not rectangles of the coarse face's
    bilinear coordinates: the jump is not bilinear there), a coarse face overhanging the fine part's edge (a fine
    face partly outside the overlap); "sigma1" is taken on each."""
    cases = {"crossing": (block(3, (0.0, 0.5)), block(2, (0.5, 1.0)), "lies across"),
             "skewed inside": (block(1, (0.0, 0.5)), block(2, (0.5, 1.0), skewed=True), "not a rectangle"),
             "overhang": (cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=4, ny=4, nz=1, cell="hex"),
                          cc.box(x=(0.1, 0.9), y=(0.0, 1.0), z=(0.5, 1.0), nx=1, ny=2, nz=1, cell="hex"),
                          "partly outside")}
    for lower, upper, why in cases.values():
        scene = pair(lower, upper, rollers=False)
        with pytest.raises(UnsupportedError, match=f"not nested.*{why}.*condition='sigma1'.*nested.*tetrahedra"):
            cc.solve(scene, "gamma3")
        assert cc.solve(scene, "sigma1").ok
