"""Hertz validation in 3D, two elastic bodies: a steel punch with a spherical end on an aluminium block.

Quarter model (x >= 0, y >= 0) of a sphere of radius R touching the block's top face z = 0 at the origin.
The block is [0, L] x [0, L] x [-L, 0] (L = ``SIZE`` a_ref), bottom clamped; the punch is the column
[0, L] x [0, L] above the sphere's surface z = R - sqrt(R^2 - x^2 - y^2) up to z = L (a square column with
a spherical end, :func:`punch_mesh`). Both have symmetry rollers on x = 0 and y = 0 and grids graded towards
the contact point. The punch's curved "bottom" meets the block's planar "top" in a node-to-face pair
(:class:`~cvxcontact.contact.surface.CurvedSurfaceInterface`) under the punch's nodal condition "sigma2".

Loading: the punch's top is held at u_z = 0 (x, y free) and the pair's gap is -delta: the same problem as
pushing the top down by delta (the punch's rigid translation by -delta e_z changes no strain and moves every
jump by delta; tests/test_hertz3d_elastic.py checks it), and a load, so one ContactSolver re-solves it.
:func:`press` finds the delta giving the total force F (four quarters) by secant steps.

Hertz for two elastic bodies (1/R = 1/R_sphere, the block flat):

    1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2,   a = (3 F R / (4 E*))^(1/3),   p0 = 3 F / (2 pi a^2),
    delta = a^2 / R,   p(r) = p0 sqrt(1 - r^2 / a^2).

Read-back (P1): a_h the mean distance from the axis of the mid-points of the punch's trace edges joining an
active node to an open one (in the plane, the projections); p0_h the pressure at the punch's node on the axis
(its row force over its lumped area of the curved part); p_block the pressure felt by the block at its node
on the axis; the axis cell's force: the rows of the punch's nodes in the cell at the axis against Hertz's
pressure integrated on the punch's hats over their projections on the plane (the rows carry the force along
the plane's normal; :func:`cvxcontact.apps.studies.hertz3d.hat_loads`). The pressures are over the curved part's
true lumped areas, which exceed the projected ones by under 0.2 % within r < 2 a.

Size effect: both bodies are finite (depth L, column height L, width L) where Hertz assumes half-spaces.
Their far fields are missing from the approach: about Boussinesq's u_z at depth L in each body,
F (1 + nu)(3 - 2 nu) / (2 pi E L) (``boussinesq``), against which the approach is listed; a and p0 depend on
the far field only through its variation across the contact zone, O((a / L)^2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import SolverError
from ...geometry.generators3d import box
from ...physics import materials
from ...physics.pairs import Contact
from ...physics.scene import Body, Scene
from .common import Timer, markdown_table, pyplot, save_figure, slope, write_csv, write_text
from .hertz3d import _edge_radius, hat_loads

E1, NU1 = 210e9, 0.3             # Pa, -: the steel punch (sphere)
E2, NU2 = 70e9, 0.3              # Pa, -: the aluminium block
R = 0.02                         # m, the sphere's radius
A_REF = 1e-3                     # m, Hertz's contact radius at the design force
SIZE = 10                        # the bodies' edge (quarter) in units of A_REF
RATIO = 10.0                     # largest over smallest cell of the graded grids
E_STAR = 1.0 / ((1 - NU1 ** 2) / E1 + (1 - NU2 ** 2) / E2)
FORCE = 4 * E_STAR * A_REF ** 3 / (3 * R)       # N, the total force giving a = A_REF (3.85 kN)
LEVELS = (8, 12, 16)             # cells per edge of each quarter body
CONDITION = "sigma2"             # the punch (second body) carries the rows


def hertz(F, R=R, E_star=E_STAR):
    """(a (m), p0 (Pa), delta (m)) of two elastic bodies (relative radius R, contact modulus E*) under F (N)."""
    a = (3 * F * R / (4 * E_star)) ** (1 / 3)
    return a, 3 * F / (2 * np.pi * a ** 2), a ** 2 / R


def boussinesq(F, depth, E, nu):
    """u_z (m) on the axis at ``depth`` (m) below a point force F (N) on a half-space (Boussinesq)."""
    return F * (1 + nu) * (3 - 2 * nu) / (2 * np.pi * E * depth)


def punch_mesh(n, size=SIZE, ratio=RATIO, radius=R):
    """The quarter punch: the graded box [0, L]^2 x [0, L] (L = size a_ref, n cells per edge) with its bottom
    mapped onto the sphere z_s(x, y) = R - sqrt(R^2 - x^2 - y^2) touching z = 0 at the origin, each node lifted
    by z_s (1 - z / L) (the top stays at z = L). Tags as :func:`cvxcontact.box` ("bottom" is curved)."""
    L = size * A_REF
    if 2 * L * L >= radius * radius:
        raise SolverError(f"punch_mesh: the column's corner ({L:g}, {L:g}) m lies outside the sphere of radius "
                          f"{radius:g} m")
    mesh = box(x=(0.0, L), y=(0.0, L), z=(0.0, L), nx=n, ny=n, nz=n, grade=((0.0, 0.0, 0.0), ratio))
    p = np.array(mesh.points)
    zs = radius - np.sqrt(radius ** 2 - p[:, 0] ** 2 - p[:, 1] ** 2)
    p[:, 2] += zs * (1 - p[:, 2] / L)
    return mesh.with_points(p)


def bodies(n, size=SIZE, ratio=RATIO, pushed=None):
    """(block, punch) of level n. ``pushed``: the punch's top pushed down by that much (m) instead of held."""
    L = size * A_REF
    block = Body(box(x=(0.0, L), y=(0.0, L), z=(-L, 0.0), nx=n, ny=n, nz=n, grade=((0.0, 0.0, 0.0), ratio)),
                 materials.isotropic(E=E2, nu=NU2, name="aluminium"), name="block", clamped=["bottom"],
                 roller=["left", "front"])
    top = 0.0 if pushed is None else -float(pushed)
    punch = Body(punch_mesh(n, size, ratio), materials.isotropic(E=E1, nu=NU1, name="steel"), name="punch",
                 roller=["left", "front"], displacement={"top": (None, None, top)})
    return block, punch


def scene(n, delta=0.0, size=SIZE, ratio=RATIO, pushed=None) -> Scene:
    """The quarter scene with the pair's gap -delta (m): the punch pressed by delta."""
    block, punch = bodies(n, size, ratio, pushed)
    return Scene(block, punch, contacts=[Contact(block, "top", punch, "bottom", condition=CONDITION, gap=-delta)])


def press(solver, base: Scene, F=FORCE, rtol=1e-10, steps=30):
    """(solution, delta (m), re-solves): the gap -delta of ``base`` set by secant steps until the total force
    (four quarters) is F (N), with ``solver`` (a ContactSolver of ``base``)."""
    def at(delta):
        sol = solver.solve(base.with_gap(-delta))
        return sol, 4 * float(sol.contact.force.sum())

    d0 = hertz(F)[2]
    s0, f0 = at(d0)
    d1 = d0 * (F / f0) ** (2 / 3)                                          # Hertz's scaling as the first step
    for k in range(steps):
        s1, f1 = at(d1)
        if abs(f1 - F) <= rtol * F:
            return s1, d1, k + 2
        d0, f0, d1 = d1, f1, d1 + (F - f1) * (d1 - d0) / (f1 - f0)
    raise SolverError(f"press: the force did not reach {F:g} N in {steps} steps (last {f1:g} N)")


def contact_radius(sol):
    """(a_h, min, max) (m): the distances from the axis of the mid-points of the punch's trace edges (in the
    plane) joining an active node to an open one (mean, smallest, largest)."""
    itf = sol.scene.interfaces[0]
    trace = itf.traces[itf.curved]
    active = np.zeros(len(trace.nodes), dtype=bool)
    active[itf.reach] = sol.contact.active
    on = np.zeros(len(trace.nodes), dtype=bool)
    on[itf.reach] = True
    return _edge_radius(_Flat(trace), active, on)


class _Flat:
    """A curved trace seen in the plane z = 0 (its nodes' projections), for the radii of :func:`contact_radius`."""

    def __init__(self, trace):
        self.faces, self.nodes = trace.faces, trace.nodes
        self.points = np.column_stack([trace.x, np.zeros(len(trace.x))])


def measure(sol, delta):
    """The row of one solution: force, radius, peak pressure, approach against Hertz at the measured force."""
    c = sol.contact
    itf = sol.scene.interfaces[0]
    F = 4 * float(c.force.sum())
    a, p0, d = hertz(F)
    a_h, a_min, a_max = contact_radius(sol)
    r = np.hypot(c.x[:, 0], c.x[:, 1])
    axis = int(np.argmin(r))
    p0_h = float(c.lam[axis])
    xb, pb = sol.traction(0)                                            # the block's own top nodes
    p_block = float(pb[np.argmin(np.hypot(xb[:, 0], xb[:, 1]))])
    lines = np.unique(np.round(c.x[:, 0], 12))
    h = float(np.diff(lines)[:3].max())                                 # cells near the axis
    cell = (c.x[:, 0] <= lines[1] * (1 + 1e-9)) & (c.x[:, 1] <= lines[1] * (1 + 1e-9))
    trace = itf.traces[itf.curved]
    hertz_y = hat_loads(_Flat(trace), lambda x, y: p0 * np.sqrt(np.maximum(1 - (x * x + y * y) / a ** 2, 0)))
    y_h, y_hertz = float(c.force[cell].sum()), float(hertz_y[itf.reach][cell].sum())
    far = boussinesq(F, SIZE * A_REF, E1, NU1) + boussinesq(F, SIZE * A_REF, E2, NU2)
    dofs = sum(3 * len(p) for p in sol.points)
    return dict(F_N=F, h_m=h, dofs=dofs, rows=len(c.x), a_m=a, a_h_m=a_h, a_h_min_m=a_min, a_h_max_m=a_max,
                a_rel_error=a_h / a - 1, p0_Pa=p0, p0_h_Pa=p0_h, p0_rel_error=p0_h / p0 - 1, p_block_Pa=p_block,
                p_block_rel_error=p_block / p0 - 1, cell_force_rel_error=y_h / y_hertz - 1, delta_m=d,
                delta_h_m=delta, delta_rel_error=delta / d - 1, far_field_rel=far / d,
                active_nodes=int(c.active.sum()), ok=sol.ok)

