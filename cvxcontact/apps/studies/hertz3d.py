"""Hertz validation in 3D: a rigid sphere pressed on an elastic block, quarter model.

The sphere (radius R, rigid) touches the block's top face z = 0 at the origin; by symmetry only
x >= 0, y >= 0 is meshed: the block [0, L] x [0, L] x [-L, 0] (L = ``SIZE`` a_ref) has symmetry
rollers on x = 0 and y = 0, its bottom clamped and its far sides free, and a tetrahedral grid graded
towards the contact point (:func:`cvxcontact.box` with ``grade``). The contact part is the patch
[0, 2 a_ref]^2 of the top face; every node of it is a row of the condition (the rigid pair's nodes).

Hertz's solution for a rigid sphere on an elastic half-space under the total force F (N):

    a = (3 F R / (4 E*))^(1/3),   p0 = 3 F / (2 pi a^2),   delta = a^2 / R,   E* = E / (1 - nu^2),
    p(r) = p0 sqrt(1 - r^2 / a^2).

Force control at every mesh level: the sphere's approach delta is the unknown that makes the total
force F (the quarter carries F / 4; :func:`total_force`, the obstacle's vertical resultant) equal to the
prescribed one. Two ways, which agree (tests/test_hertz3d.py): the
sphere guided along z under ``force=(0, 0, -F / 4)`` (``Rigid.sphere(..., guided=(0, 0, 1))``: its x, y
translations are held, as the symmetry holds them, which the scene cannot know), or, cheaper on finer
meshes, :func:`press`: the fixed sphere moved to the approach found by secant steps on F(delta), one
:class:`~cvxcontact.ContactSolver` re-solving the same geometry (F is affine in delta while the active set
stays, so the steps end exactly). The study uses :func:`press`.

Read-back: the contact radius a_h is the mean distance from the axis of the mid-points of the trace
edges joining an active node to an open one (|a_h - a| about h/2; their spread is listed; P2: the edges
of the trace's faces cut into four at their edge midpoints, so about h/4), the peak pressure p0_h the
pressure felt by the block at the node on the axis (P1: its force over its lumped area; against a rigid
obstacle the nodal pressures alternate, low on the axis and high next to it; P2: the Riesz representer of
the nodal forces in the P2 functions of the block's contact faces, :meth:`~cvxcontact.Solution.traction`,
since a P2 vertex's lumped area is zero), the axis cell's force: that of the top nodes of the cell at the
axis (P2: with the midpoints of its face edges) against Hertz's pressure integrated on the same shape
functions (:func:`hat_loads`), delta_h the sphere's approach. P2 (10-node) tetrahedra impose the condition
at every P2 node of the patch (vertices and edge midpoints: the nodal condition "sigma1", :data:`CONDITION`)
or, in rows of their own, on every face of the patch (the copositive condition, "gamma3" with P2,
docs/formulation.md §16). Under the copositive condition the gap closes at points inside the faces (one
tangency point per touching face; at n = 8 no node touches), so its contact radius is read from those points:
the quarter disc with the area of their convex hull (:func:`support_radius`, an estimate from inside; on the
nodal rows, from the active nodes, it lies within a grid spacing of the edge mid-points). Every row also gives
the radius of Hertz's profile with the forces' second moment (:func:`moment_radius`; it assumes Hertz's shape).

Posing (:data:`DISTANCE`): the sphere is posed as the field poses it, by the distance to its closest point and
rows along the radius (``distance="closest"``, docs/formulation.md §12, the default of ``Rigid.sphere``; equal to
GetFEM's radial rows to 1e-14, benchmarks/results/getfem_hertz3d.md). ``scene(..., distance="ray")`` gives the
vertical variant (the distance along the block's normal, rows along z): at a / R = 0.05, n = 8 it gives a 0.59 %
smaller force at Hertz's approach and a 0.38 % longer approach under force control.

Size effect: the block's finite depth (clamped at z = -L) removes the half-space's displacement below
z = -L, nearly uniform over the contact zone: it shortens the approach by about Boussinesq's
u_z(0, 0, -L) = F (1 + nu)(3 - 2 nu) / (2 pi E L) (7 % at L = 10 a) and changes a and p0 only through its
variation across the zone, O((a / L)^2) of that; :func:`run` measures it by doubling L.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...contact.bernstein import TRIANGLE, bernstein_argmax
from ...contact.truegap import GapDeparture
from ...contact.quadratic3d import p2_shape
from ...fem.space import space
from ...geometry.generators3d import box
from ...physics import materials
from ...physics.pairs import Contact, Rigid
from ...physics.scene import Body, Scene
from ...errors import SolverError
from .common import Timer, markdown_table, pyplot, save_figure, slope, write_csv, write_text

E, NU = 70e9, 0.3                 # Pa, -: aluminium
R = 0.02                          # m, the sphere's radius
A_REF = 1e-3                      # m, Hertz's contact radius at the design force
SIZE = 10                         # the block's edge (quarter) in units of A_REF
RATIO = 10.0                      # largest over smallest cell of the graded grid
E_STAR = E / (1 - NU ** 2)
FORCE = 4 * E_STAR * A_REF ** 3 / (3 * R)      # N, the total force giving a = A_REF (5.13 kN)
LEVELS = (8, 16, 24)              # cells per edge of the quarter block (P1)
LEVELS_P2 = (8, 16, 24)           # the same for P2 (10-node) tetrahedra
LEVELS_G3 = (8, 16, 24)           # the same for P2 under the copositive condition
CONDITION = {1: "gamma3", 2: "sigma1"}
"""The condition of each degree: P1 "gamma3" (at the block's nodes, against an obstacle), P2 "sigma1" (the nodal
condition at every P2 node of the block's contact faces); "gamma3" with P2, the copositive condition on the
faces, has rows of its own (:data:`ROWS`)."""


SUPPORT_TOL = 1e-9
"""Where the gap closes under P2 "gamma3" (:func:`support_radius`): q_h >= -1e-9 of the approach (measured: the
touching triangles' maxima within 2e-12 of the approach at n = 8, 16, 24, the nearest separated one 5e-6, 2.7e-8
and 1e-6 below)."""
FORCE_RTOL_CONIC = 1e-7
"""The relative accuracy to which :func:`press` reaches the force under P2 "gamma3": the finished conic answer's
total force moves by about 1e-8 of F between re-solves at approaches 1e-12 apart (the accumulated cuts' least
squares), so 1e-10 is out of reach there."""


DISTANCE = "closest"
"""The sphere's posing in the study (``Rigid.sphere(..., distance=DISTANCE)``): "closest", the distance to the
closest point of the sphere and rows along the radius (the field's posing; "ray": the vertical variant)."""


ROWS = {(1, "gamma3"): LEVELS, (2, "sigma1"): LEVELS_P2, (2, "gamma3"): LEVELS_G3}
"""The study's rows: (degree, condition) -> levels (``quick``: the first of each)."""


def hertz(F, R=R, E_star=E_STAR):
    """(a (m), p0 (Pa), delta (m)) of a rigid sphere of radius R on a half-space under the total force F (N)."""
    a = (3 * F * R / (4 * E_star)) ** (1 / 3)
    return a, 3 * F / (2 * np.pi * a ** 2), a ** 2 / R


def boussinesq_depth(F, depth, E=E, nu=NU):
    """u_z (m) on the axis at ``depth`` (m) below a point force F (N) on a half-space (Boussinesq)."""
    return F * (1 + nu) * (3 - 2 * nu) / (2 * np.pi * E * depth)


def block(n, size=SIZE, ratio=RATIO, twice=False) -> Body:
    """The quarter block: n cells per edge, graded towards the origin, the contact patch "zone"; ``twice``:
    the same grid continued to a block twice as large (the cells beyond L growing on), for the size effect."""
    L = size * A_REF
    mesh = box(x=(0.0, L), y=(0.0, L), z=(-L, 0.0), nx=n, ny=n, nz=n,
               patches={"zone": ("top", (0.0, 2 * A_REF), (0.0, 2 * A_REF))}, grade=((0.0, 0.0, 0.0), ratio))
    if twice:
        mesh = _continued(mesh, L)
    return Body(mesh, materials.isotropic(E=E, nu=NU, name="aluminium"), name="block", clamped=["bottom"],
                roller=["left", "front"], contact="zone")


def _continued(mesh, L):
    """``mesh`` (a graded box [0, L]^2 x [-L, 0] with the patch "zone") with its grid lines kept and continued
    to [0, 2L]^2 x [-2L, 0], the cells beyond L growing in the ratio of the last two: a uniform box of that
    many cells mapped axis by axis onto the lines (the patch maps onto [0, 2 a_ref]^2)."""
    def grown(lines):                                     # lines from 0 to L, continued to 2 L
        h, q, out = lines[-1] - lines[-2], (lines[-1] - lines[-2]) / (lines[-2] - lines[-3]), [lines[-1]]
        while out[-1] + h * q < 2 * L - 0.5 * h * q:
            h *= q
            out.append(out[-1] + h)
        extra = np.array(out[1:] + [2 * L])
        return np.concatenate([lines, L + (extra - L) * L / (extra[-1] - L)]) if len(extra) else lines

    xs = grown(np.unique(mesh.points[:, 0]))
    zs = -grown(-np.unique(mesh.points[:, 2])[::-1])[::-1]
    k = int(np.flatnonzero(np.isclose(xs, 2 * A_REF))[0])
    nx, nz = len(xs) - 1, len(zs) - 1
    unit = box(x=(0, nx), y=(0, nx), z=(0, nz), nx=nx, ny=nx, nz=nz, patches={"zone": ("top", (0, k), (0, k))})
    P = unit.points
    return unit.with_points(np.column_stack([np.interp(P[:, 0], np.arange(nx + 1), xs),
                                             np.interp(P[:, 1], np.arange(nx + 1), xs),
                                             np.interp(P[:, 2], np.arange(nz + 1), zs)]))


def scene(n, delta=None, force=None, size=SIZE, ratio=RATIO, twice=False, distance=DISTANCE) -> Scene:
    """The quarter scene: the sphere fixed at the approach ``delta`` (m; default Hertz's at FORCE), or with
    ``force`` (N, the whole sphere's) a sphere touching at the origin under force control, guided along z
    (the quarter's symmetry planes hold it in x and y); ``distance``: the sphere's posing (:data:`DISTANCE`)."""
    body = block(n, size, ratio, twice)
    if force is not None:
        sphere = Rigid.sphere((0.0, 0.0, R), R, force=(0.0, 0.0, -force / 4), guided=(0.0, 0.0, 1.0),
                              distance=distance)
    else:
        sphere = Rigid.sphere((0.0, 0.0, R - (hertz(FORCE)[2] if delta is None else delta)), R, distance=distance)
    return Scene(body, contacts=[Contact(body, "zone", sphere)])


def press(solver, base: Scene, F=FORCE, rtol=1e-10, steps=30):
    """(solution, approach delta (m), re-solves): the fixed sphere of ``base`` (touching the block at the
    origin) moved down until the total force (four quarters) is F (N), by secant steps on F(delta) with
    ``solver`` (a ContactSolver of ``base``)."""
    sphere = base.obstacles[0].obstacle
    top = sphere.position                                                  # touching at the origin

    def at(delta):
        sol = solver.solve(base.with_obstacles(sphere.moved(to=top - [0.0, 0.0, delta])))
        return sol, total_force(sol)

    return secant_press(at, F, hertz(F)[2], rtol, steps)


def total_force(sol) -> float:
    """N: the total force on the sphere (four quarters), -4 times the vertical component of the obstacle's
    resultant sum_a c_a y_a (:class:`~cvxcontact.ObstacleResult`): the nodal forces y_a act along the rows'
    directions (radial under ``distance="closest"``, where their plain sum overstates it; vertical under
    "ray", where it is 4 sum(y) to rounding). Two elastic bodies (no obstacle, rows along the pair's normal):
    4 sum(y)."""
    if not sol.obstacles:
        return 4 * float(sol.contact.force.sum())
    return -4 * float(sol.obstacles[0].force[2])


def secant_press(at, F, d0, rtol=1e-10, steps=30):
    """(solution, approach delta (m), re-solves): secant steps on F(delta) from the approach ``d0`` (m, e.g.
    Hertz's), ``at(delta)`` giving (solution, total force (N)), until the force is ``F`` (N) to ``rtol``."""
    s0, f0 = at(d0)
    d1 = d0 * (F / f0) ** (2 / 3)                                          # Hertz's scaling as the first step
    for k in range(steps):
        s1, f1 = at(d1)
        if abs(f1 - F) <= rtol * F:
            return s1, d1, k + 2
        d0, f0, d1 = d1, f1, d1 + (F - f1) * (d1 - d0) / (f1 - f0)
    raise SolverError(f"press: the force did not reach {F:g} N in {steps} steps (last {f1:g} N)")


def contact_radius(sol):
    """(a_h, min, max) (m): the distances from the axis of the mid-points of the trace edges joining an active
    node to an open one (mean, smallest, largest)."""
    itf = contact_surface(sol)
    trace, reach = itf.traces[0], block_nodes(sol)
    active = np.zeros(len(trace.nodes), dtype=bool)
    active[reach] = sol.contact.active
    on = np.zeros(len(trace.nodes), dtype=bool)
    on[reach] = True
    return edge_radius(trace, active, on, outward=True)


def contact_points(x, cells, q, tol, departure=None) -> np.ndarray:
    """(k, 2) m: where the gap closes under the copositive condition: the maximiser of the slack on every
    triangle whose maximum is >= -``tol`` (m), and every node where q_h >= -``tol``; q_h = [u_nu] - g_h (m; its
    values at the nodes ``x`` (n, 2) m of the triangle6 ``cells``), the slack q_h itself (its exact maximum), or
    against a curved obstacle's own gap q_h - delta (``departure``, a :class:`~cvxcontact.contact.truegap.
    GapDeparture` in m: :func:`true_departure`). By complementarity the contact force is carried only there (a
    point force at each tangency point; a zero slack on a whole triangle counts its nodes)."""
    x, cells, q = np.asarray(x, dtype=float), np.asarray(cells), np.asarray(q, dtype=float)
    q_max, L = (bernstein_argmax if departure is None else departure.argmax)(q[cells] @ TRIANGLE.to_bernstein.T)
    touch = q_max >= -tol
    return np.concatenate([np.einsum("ti,tid->td", L[touch], x[cells[touch, :3]]), x[q >= -tol]])


def true_departure(sol) -> GapDeparture | None:
    """The :class:`~cvxcontact.contact.truegap.GapDeparture` (m) of the sphere's own gap from its P2 interpolant on
    the triangles of a P2 solution's contact surface (the gap at in-plane points and its derivatives from the
    scene, :meth:`~cvxcontact.physics.scene.Scene.pair_gap_values` and ``pair_gap_derivatives``; the nodal gap the
    contact's): the slack whose maxima are the contact points of P2 "gamma3" (docs/formulation.md §8); None
    between two bodies (a pair's gap function stays interpolated there, as the condition poses it)."""
    if not getattr(sol.scene.interfaces[0], "rigid", False):
        return None
    c = sol.contact
    x, cells = np.asarray(c.x, dtype=float), np.asarray(contact_surface(sol).cells)

    def gap(elements, L):
        return sol.scene.pair_gap_values(0, np.einsum("kv,kvd->kd", L, x[cells[elements, :3]]))

    def derivatives(elements, L):                 # the gap's, in closed form, in L: the point s = L X, ds/dL = X
        X = x[cells[elements, :3]]
        g, gs, hs = sol.scene.pair_gap_derivatives(0, np.einsum("kv,kvd->kd", L, X))
        return g, np.einsum("kvd,kd->kv", X, gs), np.einsum("kvd,kde,kue->kvu", X, hs, X)

    return GapDeparture.build(gap, np.asarray(c.gap, dtype=float)[cells], np.ones(len(cells), dtype=bool),
                              derivatives)


def hull_radius(points) -> float:
    """m: the radius of the quarter disc with the area of the convex hull of ``points`` (k, 2) m (x, y >= 0)
    and the axis point (0, 0): sqrt(4 A / pi) (0 for fewer than two points off the axis)."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.concatenate([np.asarray(points, dtype=float).reshape(-1, 2), [[0.0, 0.0]]])
    try:
        return float(np.sqrt(4 * ConvexHull(pts).volume / np.pi))
    except QhullError:                                   # collinear or too few points: no area
        return 0.0


def support_radius(sol, tol=SUPPORT_TOL) -> tuple[float, int]:
    """(a_hull (m), number of points): :func:`hull_radius` of the points where the contact force is carried:
    the active nodes under a nodal condition (P1, P2 "sigma1"), under P2 "gamma3" the points where the gap
    closes to ``tol`` of the approach (:func:`contact_points` of the slack against the sphere's own gap; the
    largest |[u_nu]| stands for the approach)."""
    c = sol.contact
    x = np.asarray(c.x, dtype=float)
    if sol.contact.trace.gamma3_cones and sol.condition == "gamma3":
        q = np.asarray(c.jump) - np.asarray(c.gap)
        pts = contact_points(x, contact_surface(sol).cells, q, tol * float(np.abs(c.jump).max()),
                             true_departure(sol))
    else:
        pts = x[np.asarray(c.active, dtype=bool)]
    return hull_radius(pts), len(pts)


def moment_radius(x, force) -> float:
    """m: the radius of Hertz's pressure p0 sqrt(1 - r^2 / a^2) with the second moment of the contact forces
    ``force`` (N) at the nodes ``x`` (n, 2) m about the axis: int r^2 p dA / int p dA = 2 a^2 / 5, so
    a = sqrt(5/2 sum(f r^2) / sum(f)). Exact for nodal point forces and for P2 forces (r^2 is quadratic: the sum
    is the integral of r^2 against the force); it assumes Hertz's profile, so it checks the force's spread, not
    the edge of the zone."""
    x, force = np.asarray(x, dtype=float), np.asarray(force, dtype=float)
    return float(np.sqrt(2.5 * (force @ (x * x).sum(axis=1)) / force.sum()))


def block_nodes(sol) -> np.ndarray:
    """(size,) int: the node of the first body's contact trace (the block's; P2: its trace's P2 nodes) at each
    node of X_h: against an obstacle the nodes that reach it, between two bodies the trace node at the same
    in-plane point (the faces match: every node of X_h is one of the block's, else SolverError)."""
    from scipy.spatial import cKDTree

    itf = contact_surface(sol)
    if getattr(itf, "rigid", False):
        return np.asarray(itf.reach)
    trace = itf.traces[0]
    dist, at = cKDTree(np.asarray(trace.x)).query(np.asarray(itf.x))
    if dist.max() > 1e-9 * float(np.ptp(trace.x)):
        raise SolverError("block_nodes: a node of X_h is not a node of the block's contact faces (non-matching "
                          "faces); the study's read-back needs the two bodies' contact faces to match")
    return at


def contact_surface(sol):
    """The contact surface of the solution: the scene's P1 interface, or the P2 surface of a P2 solve."""
    return sol.contact_line(0)


def _linear_faces(faces):
    """(f, 3) faces as given, or each 6-node face (v0, v1, v2, m01, m12, m20) cut into its four triangles."""
    faces = np.asarray(faces)
    if faces.shape[1] == 3:
        return faces
    return faces[:, [0, 3, 5, 3, 1, 4, 5, 4, 2, 3, 4, 5]].reshape(-1, 3)


def edge_radius(trace, active, on, outward=False):
    """(mean, min, max) distance (m) from the z axis of the mid-points of the edges of ``trace`` (its 3-node
    faces, or its 6-node faces cut into four) whose end nodes (both ``on``) differ in ``active``; ``outward``:
    only those whose end nearer the axis is the active one (an open node inside the contact zone, as P2
    vertices may be, then marks no edge of the zone)."""
    points = trace.points
    faces = _linear_faces(trace.faces)
    edges = np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    rho = np.hypot(points[:, 0], points[:, 1])
    near = rho[edges[:, 0]] <= rho[edges[:, 1]]
    i, j = np.where(near, edges[:, 0], edges[:, 1]), np.where(near, edges[:, 1], edges[:, 0])
    cross = on[i] & on[j] & (active[i] != active[j])
    if outward:
        cross &= active[i]
    mid = 0.5 * (points[i[cross]] + points[j[cross]])
    r = np.hypot(mid[:, 0], mid[:, 1])
    return float(r.mean()), float(r.min()), float(r.max())


def hat_loads(trace, pressure, k=8):
    """(n_trace,) N: the integrals of ``pressure(x, y)`` (Pa) against each shape function of a planar trace
    (the hats of its 3-node faces, the P2 functions of its 6-node faces): its faces cut into k^2
    sub-triangles, on each the three-point rule exact for quadratics (the nodal forces of a prescribed
    pressure; exact for an affine one on 3-node faces)."""
    u, v = (g.ravel() for g in np.meshgrid(np.arange(k), np.arange(k), indexing="ij"))
    up, down = u + v <= k - 1, u + v <= k - 2
    corners = np.concatenate([np.stack([np.c_[u, v], np.c_[u + 1, v], np.c_[u, v + 1]], axis=1)[up],
                              np.stack([np.c_[u + 1, v], np.c_[u + 1, v + 1], np.c_[u, v + 1]], axis=1)[down]]) / k
    rule = np.full((3, 3), 1 / 6) + np.eye(3) / 2                       # 2/3 at one corner, 1/6 at the others
    b = np.einsum("pi,sid->spd", rule, corners).reshape(-1, 2)          # (q, 2): (l1, l2) of every point
    lam = np.column_stack([1 - b.sum(axis=1), b])                       # (q, 3) barycentric
    faces = np.asarray(trace.faces)
    P = trace.points[faces[:, :3]]                                      # (f, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    X = np.einsum("qj,fjd->fqd", lam, P)
    w = pressure(X[..., 0], X[..., 1]) * (area / (3 * k ** 2))[:, None]  # (f, q)
    shape = lam if faces.shape[1] == 3 else p2_shape(lam)               # (q, 3) or (q, 6)
    out = np.zeros(len(trace.nodes))
    np.add.at(out, faces, np.einsum("fq,qj->fj", w, shape))
    return out


def measure(sol, delta, closed_form=None):
    """The row of one solution: force, radius, peak pressure, approach against Hertz at the measured force
    (``closed_form(F)`` -> (a, p0, delta), default :func:`hertz`; the peak pressure and the axis cell's force
    are those felt by the first body, the block).
    The contact radius a_h: under a nodal condition the edge mid-points (:func:`contact_radius`), under P2
    "gamma3" the hull of the points where the gap closes (:func:`support_radius`; the zone's edge lies inside
    triangles there, whose nodes need not touch); both estimators, and :func:`moment_radius`, on every row."""
    c = sol.contact
    F = total_force(sol)
    a, p0, d = (closed_form or hertz)(F)
    a_hull, support = support_radius(sol)
    a_moment = moment_radius(c.x, c.force)
    conic = sol.contact.trace.gamma3_cones and sol.condition == "gamma3"
    a_h, a_min, a_max = (a_hull, None, None) if conic else contact_radius(sol)
    itf = contact_surface(sol)
    trace, reach = itf.traces[0], block_nodes(sol)
    r = np.hypot(c.points[:, 0], c.points[:, 1])
    axis = int(np.argmin(r))
    lumped = sol.degree == 1        # P1: force over lumped area; P2: the Riesz pressure and the shape functions
    if lumped:
        p0_h = float(c.pressure[axis])                                  # force over lumped area
    else:                                                               # the Riesz pressure on the P2 faces
        p0_h = float(sol.traction(0)[1][reach[axis]])
    vertices = getattr(trace, "linear", trace).points                   # the grid's vertices (P2: not midpoints)
    lines = np.unique(np.round(vertices[:, 0], 12))
    h = float(np.diff(lines)[:3].max())                                 # cells near the axis
    # the axis cell's top nodes (P2: with the midpoints): their force against Hertz's on the same shape
    # functions, their mean pressure (force over the integral of those shape functions)
    cell = (c.points[:, 0] <= lines[1] * (1 + 1e-9)) & (c.points[:, 1] <= lines[1] * (1 + 1e-9))
    hertz_y = hat_loads(trace, lambda x, y: p0 * np.sqrt(np.maximum(1 - (x * x + y * y) / a ** 2, 0)))
    y_h, y_hertz = float(c.force[cell].sum()), float(hertz_y[reach][cell].sum())
    if lumped:
        area = float(c.measure[cell].sum())
    else:
        area = float(hat_loads(trace, lambda x, y: np.ones_like(x))[reach][cell].sum())
    dofs = sum(3 * len(p) for p in sol.points)
    return dict(F_N=F, h_m=h, dofs=dofs, a_m=a, a_h_m=a_h, a_h_min_m=a_min, a_h_max_m=a_max,
                a_rel_error=a_h / a - 1, a_hull_m=a_hull, a_hull_rel_error=a_hull / a - 1, support_points=support,
                a_moment_m=a_moment, a_moment_rel_error=a_moment / a - 1, p0_Pa=p0, p0_h_Pa=p0_h, p0_rel_error=p0_h / p0 - 1,
                p_cell_Pa=y_h / area, cell_force_rel_error=y_h / y_hertz - 1, delta_m=d,
                delta_h_m=delta, delta_rel_error=delta / d - 1, active_nodes=int(c.active.sum()),
                contact_nodes=len(c.active), ok=sol.ok)


def solve_level(n, size=SIZE, ratio=RATIO, F=FORCE, twice=False, degree=1, condition=None, distance=DISTANCE):
    """(row, solution) of one mesh level under force control (:func:`press`, the condensed backend);
    ``degree`` 2: P2 (10-node) tetrahedra; ``condition`` (default :data:`CONDITION` of the degree), e.g.
    "gamma3" with P2: the copositive condition on the block's faces (docs/formulation.md §16), whose force is
    reached to :data:`FORCE_RTOL_CONIC` (the nodal conditions': 1e-10); ``distance``: the sphere's posing
    (:data:`DISTANCE`)."""
    from ...solve import ContactSolver

    clock = Timer()
    condition = condition or CONDITION[degree]
    base = scene(n, delta=0.0, size=size, ratio=ratio, twice=twice, distance=distance)
    solver = ContactSolver(base, condition, method="condensed", degree=degree)
    conic = space(degree, "tetra").trace.gamma3_cones and condition == "gamma3"
    sol, delta, resolves = press(solver, base, F, rtol=FORCE_RTOL_CONIC if conic else 1e-10)
    row = dict(degree=degree, condition=condition, n=n, size_a=2 * size if twice else size) | measure(sol, delta)
    row |= dict(resolves=resolves, seconds=clock())
    return row, sol



def pressure_axes(ax, title: str, xmax: float, **legend):
    """The axes of a pressure-against-radius plot (m, Pa in engineering notation, at most 5 ticks on r from 0
    to ``xmax`` m), its ``title`` and legend (``legend``: keywords of ``ax.legend``)."""
    from matplotlib.ticker import MaxNLocator

    from ...io.plot import eng

    ax.set(xlabel="distance r from the axis", ylabel="contact pressure", xlim=(0, xmax), title=title)
    ax.title.set_fontsize(10)
    ax.xaxis.set_major_locator(MaxNLocator(5))
    ax.xaxis.set_major_formatter(eng("m"))
    ax.yaxis.set_major_formatter(eng("Pa"))
    ax.legend(**legend)

def figure(sol, rows, sol2=None, rows2=(), sol3=None, rows3=()):
    """Left: the pressure at every contact node against the radius (P1: force over lumped area, felt by the
    block; P2 ``sol2`` (nodal condition) and ``sol3`` (copositive condition, its hull radius marked): the
    pressure felt by the block, the Riesz representer on its P2 faces), with Hertz's profile at the measured
    force; right: the P1 pressure map of the contact patch (quarter), Hertz's circle
    outlined."""
    from matplotlib.ticker import MaxNLocator
    from matplotlib.tri import Triangulation

    from ...io.plot import eng

    plt = pyplot()
    c = sol.contact
    F = total_force(sol)
    a, p0, _ = hertz(F)
    r = np.hypot(c.points[:, 0], c.points[:, 1])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    rs = np.linspace(0, a, 300)
    ax.plot(rs, p0 * np.sqrt(1 - (rs / a) ** 2), "k-", lw=1.5, label="Hertz", zorder=3)
    ax.plot(r[c.active], c.pressure[c.active], "o", ms=3.5, label=f"P1, n = {rows[-1]['n']}: active nodes", zorder=4)
    ax.plot(r[~c.active], c.pressure[~c.active], "x", ms=3, color="0.5", label="P1: open nodes")
    ax.axvline(rows[-1]["a_h_m"], color="C3", lw=0.8, ls="--", label="P1 a_h (edge mid-points)")
    if sol2 is not None:
        trace = contact_surface(sol2).traces[0]
        x2 = trace.points
        ax.plot(np.hypot(x2[:, 0], x2[:, 1]), sol2.traction(0)[1], "s", ms=2.5, color="C2", zorder=5,
                label=f"P2 sigma1, n = {rows2[-1]['n']}: felt pressure")
    if sol3 is not None:
        trace = contact_surface(sol3).traces[0]
        x3 = trace.points
        ax.plot(np.hypot(x3[:, 0], x3[:, 1]), sol3.traction(0)[1], "^", ms=2.5, color="C4", zorder=5,
                label=f"P2 gamma3, n = {rows3[-1]['n']}: felt pressure")
        ax.axvline(rows3[-1]["a_hull_m"], color="C4", lw=0.8, ls=":",
                   label="P2 gamma3 a_h (hull)")
    pressure_axes(ax, f"Rigid sphere (R = {R * 1e3:g} mm) on a block, F = {F / 1e3:.3g} kN: pressure against r",
                  2 * A_REF, fontsize=7, loc="lower left")
    itf = sol.scene.interfaces[0]
    trace = itf.traces[0]
    p = np.zeros(len(trace.nodes))
    p[itf.reach] = c.pressure
    tri = Triangulation(trace.points[:, 0], trace.points[:, 1], trace.faces)
    m = ax2.tripcolor(tri, p, shading="gouraud", cmap="viridis")
    t = np.linspace(0, np.pi / 2, 100)
    ax2.plot(a * np.cos(t), a * np.sin(t), "--", color="C3", lw=1.2, label="Hertz contact radius a")
    ax2.plot(c.points[c.active, 0], c.points[c.active, 1], ".", ms=3, color="C1", label="active nodes")
    ax2.set_aspect("equal")
    ax2.set(xlabel="x", ylabel="y", title=f"P1 pressure on the contact patch (quarter model, n = {rows[-1]['n']})")
    ax2.title.set_fontsize(10)
    for axis in (ax2.xaxis, ax2.yaxis):
        axis.set_major_locator(MaxNLocator(5))
        axis.set_major_formatter(eng("m"))
    fig.colorbar(m, ax=ax2, format=eng("Pa"), label="pressure felt by the block")
    ax2.legend(fontsize=8, loc="upper right")
    return fig


def run(out, quick=False, progress=None):
    say = progress or (lambda s: None)
    out = Path(out)
    conv, sols = {}, {}
    for key, levels in ROWS.items():
        degree, condition = key
        conv[key] = []
        for n in levels[:1] if quick else levels:
            row, sols[key] = solve_level(n, degree=degree, condition=condition)
            conv[key].append(row)
            say(f"hertz3d P{degree} {condition} n={n}: a_h/a - 1 = {row['a_rel_error']:+.2e}, p0_h/p0 - 1 = "
                f"{row['p0_rel_error']:+.2e}, delta_h/delta - 1 = {row['delta_rel_error']:+.2e} "
                f"({row['seconds']:.1f} s)")
    # the size effect: one P1 level again with its grid continued to a block twice as large
    p1 = conv[(1, CONDITION[1])]
    ref = p1[min(1, len(p1) - 1)]
    big, _ = solve_level(ref["n"], twice=True)
    say(f"hertz3d size 2L n={big['n']}: a_h/a - 1 = {big['a_rel_error']:+.2e}, "
        f"delta_h/delta - 1 = {big['delta_rel_error']:+.2e}")
    rows = [r for key in ROWS for r in conv[key]] + [big]
    write_csv(out / "hertz3d.csv", rows)
    save_figure(figure(sols[(1, CONDITION[1])], p1, sols[(2, CONDITION[2])], conv[(2, CONDITION[2])],
                       sols[(2, "gamma3")], conv[(2, "gamma3")]), out / "hertz3d.png")
    return write_report(out, rows)


def read_rows(path) -> list[dict]:
    """The rows of a study's ``hertz3d.csv`` with numbers as numbers (to rewrite its report)."""
    import csv

    def value(v):
        if v in ("True", "False"):
            return v == "True"
        if v == "":
            return None
        try:
            return int(v)
        except ValueError:
            try:
                return float(v)
            except ValueError:
                return v

    with open(path) as fh:
        rows = [{k: value(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    for r in rows:                                   # a table written before the condition column
        if "condition" in r and not isinstance(r["condition"], str):
            r["condition"] = CONDITION[r["degree"]]
        r.setdefault("condition", CONDITION[r["degree"]])
    return rows


def write_report(out, rows):
    """hertz3d.md from the study's rows (P1 levels, P2 levels, the P1 level with the block twice as large);
    returns the rows and the observed rates."""
    kind = {1: (1, CONDITION[1]), 2: (2, CONDITION[2]), 3: (2, "gamma3")}      # 3: P2 gamma3
    conv = {d: [r for r in rows if (r["degree"], r.get("condition", CONDITION[r["degree"]])) == kind[d]
                and r["size_a"] == SIZE] for d in kind}
    big = next(r for r in rows if r["size_a"] == 2 * SIZE)
    ref = next(r for r in conv[1] if r["n"] == big["n"])
    rates = {d: {k: slope([r["h_m"] for r in conv[d]], [abs(r[k]) for r in conv[d]])
                 for k in ("a_rel_error", "a_hull_rel_error", "p0_rel_error", "cell_force_rel_error")
                 if all(r.get(k) is not None for r in conv[d])} for d in kind}
    L = SIZE * A_REF
    cols = ["degree", "condition", "n", "size_a", "dofs", "h_m", "F_N", "a_m", "a_h_m", "a_h_min_m", "a_h_max_m",
            "a_rel_error", "a_hull_m", "a_hull_rel_error", "support_points", "a_moment_m", "a_moment_rel_error",
            "p0_Pa", "p0_h_Pa", "p0_rel_error", "p_cell_Pa", "cell_force_rel_error", "delta_m", "delta_h_m",
            "delta_rel_error", "active_nodes", "ok", "seconds"]
    fmt = {"h_m": ".3e", "F_N": ".6g", "a_m": ".4e", "a_h_m": ".4e", "a_h_min_m": ".3e", "a_h_max_m": ".3e",
           "a_rel_error": "+.3f", "a_hull_m": ".4e", "a_hull_rel_error": "+.3f", "a_moment_m": ".4e",
           "a_moment_rel_error": "+.4f", "p0_Pa": ".4e", "p0_h_Pa": ".4e", "p0_rel_error": "+.3f",
           "p_cell_Pa": ".4e", "cell_force_rel_error": "+.4f", "delta_m": ".4e",
           "delta_h_m": ".4e", "delta_rel_error": "+.3f", "seconds": ".1f"}
    short = ["degree", "condition", "n", "size_a", "dofs", "h_m", "a_rel_error", "a_hull_rel_error",
             "a_moment_rel_error", "p0_rel_error", "cell_force_rel_error", "delta_rel_error", "seconds"]

    def rate(d):
        ns = ", ".join(str(r["n"]) for r in conv[d])
        return (f"P{kind[d][0]} {kind[d][1]} (levels {ns}): contact radius {rates[d]['a_rel_error']:.2f}, peak pressure "
                f"{rates[d]['p0_rel_error']:.2f}, force of the axis cell {rates[d]['cell_force_rel_error']:.2f}")

    def listed(key, d, f="+.3f"):
        return ", ".join(f"{r[key]:{f}}" for r in conv[d])

    gains = ""
    if conv[2]:
        spread = max((r["a_h_max_m"] - r["a_h_min_m"]) / r["a_m"] for r in conv[2][-1:])
        gains = (f"What P2 gains on the same grids (n = {', '.join(str(r['n']) for r in conv[2])}; P2 has the "
                 "unknowns of P1 on a grid twice as fine): the peak pressure, "
                 f"{listed('p0_rel_error', 2)} against P1's {listed('p0_rel_error', 1)}, and the force of the axis "
                 f"cell, {listed('cell_force_rel_error', 2, '+.4f')} against "
                 f"{listed('cell_force_rel_error', 1, '+.4f')}, read from the smooth P2 pressure felt by the block "
                 "instead of alternating nodal values (the axis cell's error changes sign with P2, so its rate "
                 "says little); the contact radius, "
                 f"{listed('a_rel_error', 2)} against {listed('a_rel_error', 1)}, read on the grid of P2 nodes "
                 f"(spacing h/2; the mean of crossings spread over {spread:.2f} a at the finest P2 level, so its "
                 "last digit and rate are rough); the approach, "
                 f"{listed('delta_rel_error', 2)} against {listed('delta_rel_error', 1)}: P2 is at the finite "
                 "block's own value (size effect, below) from the coarsest level on, P1 approaches it from below "
                 "(a P1 mesh is too stiff). A P2 vertex carries almost no force under a smooth pressure "
                 "(the integral of its shape function on a face is zero), so the nodal condition may leave a "
                 "vertex inside the contact zone with a small gap (at n = 8, the vertex on the axis); such a node "
                 "marks no edge of the zone.\n\n")
    conic = ""
    if conv[3]:
        hull = {d: listed("a_hull_rel_error", d) for d in (1, 2, 3)}
        hull_rates = ", ".join(f"{name} {rates[d].get('a_hull_rel_error', float('nan')):.2f}"
                               for d, name in ((1, "P1"), (2, "P2 sigma1"), (3, "P2 gamma3")))
        conic = ("The copositive condition with P2 (\"gamma3\": the jump minus the gap's P2 interpolant <= 0 on "
                 "every face of the patch, docs/formulation.md §16; levels "
                 f"{', '.join(str(r['n']) for r in conv[3])}): every answer finished"
                 f"{' and `ok`' if all(r['ok'] for r in conv[3]) else ''} (the force reached to "
                 f"{FORCE_RTOL_CONIC:g}: the finished force moves by about 1e-8 between re-solves). Peak pressure {listed('p0_rel_error', 3)} (P2 sigma1: "
                 f"{listed('p0_rel_error', 2)}), the axis cell's force {listed('cell_force_rel_error', 3, '+.4f')}, "
                 f"the approach {listed('delta_rel_error', 3)}. The gap closes at points inside the faces (one "
                 "tangency point per touching face; no node touches at n = 8): the zone's edge cannot be read "
                 "from nodes or whole faces (the nodes of the faces that carry force give +0.33, +0.18 at n = 8, "
                 "16). Its a_h is the hull radius (a_hull): the quarter disc with the area of the convex hull of "
                 "the points where the gap closes (the exact maximiser of q_h on each face whose maximum is 0 to "
                 f"{SUPPORT_TOL:g} of the approach, and the nodes where q_h is) with the axis point; by "
                 "complementarity the force is carried there and only there, and the zone reaches at least that "
                 f"far: an estimate from inside, {hull[3]}. On the nodal rows the same hull of the active nodes, "
                 f"P1 {hull[1]}, P2 sigma1 {hull[2]}, lies within a grid spacing of their edge mid-points "
                 f"(a_rel_error there); observed rates in h of a_hull: "
                 f"{hull_rates}. a_moment is the radius of "
                 "Hertz's profile with the contact forces' second moment about the axis (a = sqrt(5/2 sum f r^2 / "
                 "sum f), exact for nodal forces and for P2, r^2 being quadratic): "
                 f"P2 gamma3 {listed('a_moment_rel_error', 3, '+.4f')}, P2 sigma1 "
                 f"{listed('a_moment_rel_error', 2, '+.4f')}, P1 {listed('a_moment_rel_error', 1, '+.4f')}; it "
                 "assumes Hertz's shape, so it checks how the force spreads, not where the zone ends.\n\n")
    text = (f"# Hertz validation in 3D: a rigid sphere on a block\n\n"
            f"Rigid sphere R = {R * 1e3:g} mm on an aluminium block (E = {E / 1e9:g} GPa, nu = {NU}), quarter model "
            f"({L * 1e3:g} mm cube, symmetry rollers on x = 0 and y = 0, bottom clamped, grid graded towards the "
            f"contact point, largest/smallest cell {RATIO:g}), P1 (degree 1) and P2 (degree 2, 10-node) "
            f"tetrahedra, force control: the total force is F = {FORCE:.6g} N to 1e-10 at every "
            f"level (Hertz: a = {A_REF * 1e3:g} mm). "
            "a_h: mean distance from the axis of the mid-points of the edges that leave the active nodes outwards "
            "(an active node to an open one farther from the axis; min and max listed; P2: the edges of the "
            "contact faces cut into four at their edge midpoints, i.e. of the grid of P2 nodes); p0_h: the "
            "pressure felt by the block at the node on the axis (P1: its force over its lumped area; the nodal "
            "pressures against a rigid obstacle alternate, low on the axis, high at its neighbours; P2: the Riesz "
            "representer of the nodal forces in the P2 functions of the block's contact faces, "
            "`sol.traction(0)`, since a P2 vertex has zero lumped area); p_cell: the mean pressure of the top "
            "nodes of the cell at the axis (P2: with the midpoints of its face edges), and cell_force_rel_error "
            "their force against Hertz's pressure integrated on the same shape functions; delta_h: the sphere's "
            "approach. h_m: the grid spacing near the axis (P2: of the vertices). Conditions: P1 gamma3 (at the "
            "block's nodes that reach the sphere); P2 sigma1, the nodal condition at every P2 node of the contact "
            "patch (vertices and edge midpoints); P2 gamma3, the copositive condition on every face of the patch "
            "(its a_h: a_hull, below). a_hull, a_moment: the contact radius from the hull of the points that carry "
            "force and from the forces' second moment, on every row (below). The last row "
            f"(size_a = {2 * SIZE}) is P1 level n = {ref['n']} again, its grid kept and continued to a block twice "
            "as large (the size effect alone). Seconds: one process on a shared two-core machine.\n\n"
            + markdown_table(rows, short, fmt)
            + "\nEvery column (CSV: hertz3d.csv):\n\n" + markdown_table(rows, cols, fmt)
            + f"\nObserved rates in h: {'; '.join(rate(d) for d in kind if conv[d])}.\n\n" + gains + conic
            + f"Size effect: the approach of the {SIZE} a block is short of Hertz's by about Boussinesq's "
              f"displacement at the clamped depth, u_z(L)/delta = {boussinesq_depth(FORCE, L) / hertz(FORCE)[2]:.3f} "
              f"(at {2 * SIZE} a: {boussinesq_depth(FORCE, 2 * L) / hertz(FORCE)[2]:.3f}); the radius and the peak "
              f"pressure move by {big['a_rel_error'] - ref['a_rel_error']:+.1e} and "
              f"{big['p0_rel_error'] - ref['p0_rel_error']:+.1e} (relative to Hertz), the axis cell's force by "
              f"{big['cell_force_rel_error'] - ref['cell_force_rel_error']:+.1e} and the approach by "
              f"{big['delta_rel_error'] - ref['delta_rel_error']:+.3f} when L doubles at n = {ref['n']}.\n")
    write_text(Path(out) / "hertz3d.md", text)
    return dict(rows=rows, rates=rates, rate_a=rates[1]["a_rel_error"], rate_p0=rates[1]["p0_rel_error"],
                rate_cell=rates[1]["cell_force_rel_error"])
