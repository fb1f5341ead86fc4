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

The profile variant (``run(..., profile=True)``, ``cvxcontact study hertz3d_elastic --profile``): Hertz's own
boundary-value problem, two bodies with FLAT contact faces (the aluminium block of the rigid study,
:func:`cvxcontact.apps.studies.hertz3d.block`, under a steel box, :func:`sphere_block`, matching grids) whose
pair's initial gap carries the sphere's profile g = R - sqrt(R^2 - r^2) - delta (:class:`SphereGap`; Hertz's
half-space approximation, a << R). No part is curved, so P2 (10-node) tetrahedra apply: rows P1 and P2 under the
nodal condition "sigma1" (the block's nodes; P2: its vertices and edge midpoints; the gap evaluated there) and
"gamma3" (P1: the merged nodes, here the same; P2: the copositive condition on every face, the gap entering
through its quadratic interpolant through the face's six nodes, :func:`gap_interpolation_error`), read back as
the rigid study reads its block (:func:`cvxcontact.apps.studies.hertz3d.measure`) against Hertz with E* of both.

Size effect: both bodies are finite (depth L, column height L, width L) where Hertz assumes half-spaces.
Their far fields are missing from the approach: about Boussinesq's u_z at depth L in each body,
F (1 + nu)(3 - 2 nu) / (2 pi E L) (``boussinesq``), against which the approach is listed; a and p0 depend on
the far field only through its variation across the contact zone, O((a / L)^2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import SolverError
from ...fem.space import space
from ...geometry.generators3d import box
from ...physics import materials
from ...physics.pairs import Contact
from ...physics.scene import Body, Scene
from .common import Timer, markdown_table, pyplot, save_figure, slope, write_csv, write_text
from .hertz3d import edge_radius, hat_loads, pressure_axes, secant_press

E1, NU1 = 210e9, 0.3             # Pa, -: the steel punch (sphere)
E2, NU2 = 70e9, 0.3              # Pa, -: the aluminium block
R = 0.02                         # m, the sphere's radius
A_REF = 1e-3                     # m, Hertz's contact radius at the design force
SIZE = 10                        # the bodies' edge (quarter) in units of A_REF
RATIO = 10.0                     # largest over smallest cell of the graded grids
E_STAR = 1.0 / ((1 - NU1 ** 2) / E1 + (1 - NU2 ** 2) / E2)
FORCE = 4 * E_STAR * A_REF ** 3 / (3 * R)       # N, the total force giving a = A_REF (3.85 kN)
LEVELS = (8, 16, 24)            # cells per edge of each quarter body
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


def press(solver, base: Scene, F=FORCE, rtol=1e-10, steps=30, gap=None):
    """(solution, delta (m), re-solves): the gap -delta of ``base`` set by secant steps until the total force
    (four quarters) is F (N), with ``solver`` (a ContactSolver of ``base``); ``gap``: delta -> the pair's gap
    instead (a number or a callable g(s1, s2), m; the profile variant: :func:`profile_gap`)."""
    def at(delta):
        sol = solver.solve(base.with_gap(-delta if gap is None else gap(delta)))
        return sol, 4 * float(sol.contact.force.sum())

    return secant_press(at, F, hertz(F)[2], rtol, steps)


def contact_radius(sol):
    """(a_h, min, max) (m): the distances from the axis of the mid-points of the punch's trace edges (in the
    plane) joining an active node to an open one (mean, smallest, largest)."""
    itf = sol.scene.interfaces[0]
    trace = itf.traces[itf.curved]
    active = np.zeros(len(trace.nodes), dtype=bool)
    active[itf.reach] = sol.contact.active
    on = np.zeros(len(trace.nodes), dtype=bool)
    on[itf.reach] = True
    return edge_radius(_Flat(trace), active, on)


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



def solve_level(n, size=SIZE, ratio=RATIO, F=FORCE):
    """(row, solution) of one mesh level at the total force F (:func:`press`, the condensed backend)."""
    from ...solve import ContactSolver

    clock = Timer()
    base = scene(n, size=size, ratio=ratio)
    solver = ContactSolver(base, CONDITION, method="condensed")
    sol, delta, resolves = press(solver, base, F)
    row = dict(degree=1, n=n) | measure(sol, delta) | dict(resolves=resolves, seconds=clock())
    return row, sol


def figure(sol, rows):
    """Left: the pressure at the punch's contact nodes (row force over lumped area) and felt by the block at its
    own nodes against the radius, Hertz's profile at the measured force; right: the punch's pressure on the
    projection of its curved part (quarter), Hertz's circle outlined."""
    from matplotlib.ticker import MaxNLocator
    from matplotlib.tri import Triangulation

    from ...io.plot import eng

    plt = pyplot()
    c = sol.contact
    F = 4 * float(c.force.sum())
    a, p0, _ = hertz(F)
    r = np.hypot(c.x[:, 0], c.x[:, 1])
    xb, pb = sol.traction(0)
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    rs = np.linspace(0, a, 300)
    ax.plot(rs, p0 * np.sqrt(1 - (rs / a) ** 2), "k-", lw=1.5, label="Hertz (closed form)", zorder=3)
    ax.plot(r[c.active], c.lam[c.active], "o", ms=3.5, label=f"punch's active nodes (n = {rows[-1]['n']})", zorder=4)
    ax.plot(r[~c.active], c.lam[~c.active], "x", ms=3, color="0.5", label="punch's open nodes (zero)")
    rb = np.hypot(xb[:, 0], xb[:, 1])
    ax.plot(rb[pb > 0], pb[pb > 0], "s", ms=2.5, mfc="none", color="C2", label="felt by the block (its nodes)")
    ax.axvline(rows[-1]["a_h_m"], color="C3", lw=0.8, ls="--", label="a_h (active/open mid-points, mean)")
    pressure_axes(ax, f"Steel sphere (R = {R * 1e3:g} mm) on an aluminium block, F = {F / 1e3:.3g} kN", 2 * A_REF,
                  fontsize=8)
    itf = sol.scene.interfaces[0]
    trace = itf.traces[itf.curved]
    p = np.zeros(len(trace.nodes))
    p[itf.reach] = c.lam
    near = (np.hypot(trace.x[:, 0], trace.x[:, 1]) <= 2.5 * A_REF)[trace.faces].any(axis=1)
    tri = Triangulation(trace.x[:, 0], trace.x[:, 1], trace.faces[near])
    m = ax2.tripcolor(tri, p, shading="gouraud", cmap="viridis")
    t = np.linspace(0, np.pi / 2, 100)
    ax2.plot(a * np.cos(t), a * np.sin(t), "--", color="C3", lw=1.2, label="Hertz contact radius a")
    ax2.plot(c.x[c.active, 0], c.x[c.active, 1], ".", ms=3, color="C1", label="active nodes")
    ax2.set_aspect("equal")
    ax2.set(xlabel="x", ylabel="y", xlim=(0, 2 * A_REF), ylim=(0, 2 * A_REF),
            title="Pressure on the punch's curved part, seen along z (quarter)")
    ax2.title.set_fontsize(10)
    for axis in (ax2.xaxis, ax2.yaxis):
        axis.set_major_locator(MaxNLocator(5))
        axis.set_major_formatter(eng("m"))
    fig.colorbar(m, ax=ax2, format=eng("Pa"), label="pressure on the punch")
    ax2.legend(fontsize=8, loc="upper right")
    return fig


class SphereGap:
    """The profile variant's initial gap g(s1, s2) = R - sqrt(R^2 - s1^2 - s2^2) - delta (m): the sphere's
    height over its tangent plane at the in-plane point (s1, s2) (m, the pair's frame, origin on the axis),
    shifted by the approach ``delta`` (m). A vectorised callable; immutable."""

    __slots__ = ("delta", "radius")

    def __init__(self, delta=0.0, radius=R):
        object.__setattr__(self, "delta", float(delta))
        object.__setattr__(self, "radius", float(radius))

    def __setattr__(self, name, value):
        raise AttributeError("SphereGap is immutable: build another with SphereGap(delta, radius)")

    def __call__(self, s1, s2):
        r2 = np.asarray(s1, dtype=float) ** 2 + np.asarray(s2, dtype=float) ** 2
        return self.radius - np.sqrt(self.radius ** 2 - r2) - self.delta

    def __repr__(self):
        return f"SphereGap(delta={self.delta!r}, radius={self.radius!r})"


def sphere_block(n, size=SIZE, ratio=RATIO) -> Body:
    """The profile variant's upper body: the steel box [0, L]^2 x [0, L] (quarter, n cells per edge, graded
    towards the origin as the block) with its flat bottom's patch [0, 2 a_ref]^2 as the contact part "zone",
    symmetry rollers on x = 0 and y = 0, its top held at u_z = 0 (x, y free)."""
    L = size * A_REF
    mesh = box(x=(0.0, L), y=(0.0, L), z=(0.0, L), nx=n, ny=n, nz=n,
               patches={"zone": ("bottom", (0.0, 2 * A_REF), (0.0, 2 * A_REF))}, grade=((0.0, 0.0, 0.0), ratio))
    return Body(mesh, materials.isotropic(E=E1, nu=NU1, name="steel"), name="sphere", roller=["left", "front"],
                displacement={"top": (None, None, 0.0)}, contact="zone")


def profile_scene(n, delta=0.0, size=SIZE, ratio=RATIO) -> Scene:
    """Hertz's own boundary-value problem, quarter model: the aluminium block (:func:`hertz3d.block`) under the
    flat steel body (:func:`sphere_block`), their matching patches "zone" in a pair whose initial gap is the
    sphere's profile :class:`SphereGap` (delta) (the half-space approximation: a << R)."""
    from .hertz3d import block

    lower, upper = block(n, size, ratio), sphere_block(n, size, ratio)
    return Scene(lower, upper, contacts=[Contact(lower, "zone", upper, "zone", gap=SphereGap(delta))])


def solve_profile_level(n, degree=1, condition="sigma1", size=SIZE, ratio=RATIO, F=FORCE):
    """(row, solution) of one level of the profile variant under force control (:func:`press` on the profile's
    approach, the condensed backend); ``degree`` 2: P2 (10-node) tetrahedra; ``condition`` "sigma1" (the
    block's nodes; P2: its P2 nodes) or "gamma3" (P1: every merged node; P2: the copositive condition on every
    face of X_h). The read-back is the rigid study's (:func:`hertz3d.measure`) with E* of both bodies."""
    from ...solve import ContactSolver
    from .hertz3d import FORCE_RTOL_CONIC, measure

    clock = Timer()
    base = profile_scene(n, 0.0, size, ratio)
    solver = ContactSolver(base, condition, method="condensed", degree=degree)
    conic = space(degree, "tetra").trace.gamma3_cones and condition == "gamma3"
    sol, delta, resolves = press(solver, base, F, rtol=FORCE_RTOL_CONIC if conic else 1e-10, gap=SphereGap)
    far = boussinesq(F, size * A_REF, E1, NU1) + boussinesq(F, size * A_REF, E2, NU2)
    row = dict(variant="profile", degree=degree, condition=condition, n=n) | measure(sol, delta, hertz)
    row |= dict(far_field_rel=far / hertz(F)[2], resolves=resolves, seconds=clock())
    return row, sol


def run(out, quick=False, progress=None, profile=False):
    """The study (``profile``: its gap-profile variant, :func:`run_profile`)."""
    if profile:
        return run_profile(out, quick, progress)
    say = progress or (lambda s: None)
    out = Path(out)
    levels = LEVELS[:1] if quick else LEVELS
    rows, sol = [], None
    for n in levels:
        row, sol = solve_level(n)
        rows.append(row)
        say(f"hertz3d_elastic P1 n={n}: a_h/a - 1 = {row['a_rel_error']:+.2e}, p0_h/p0 - 1 = "
            f"{row['p0_rel_error']:+.2e}, delta_h/delta - 1 = {row['delta_rel_error']:+.2e} ({row['seconds']:.1f} s)")
    write_csv(out / "hertz3d_elastic.csv", rows)
    save_figure(figure(sol, rows), out / "hertz3d_elastic.png")
    hs = [r["h_m"] for r in rows]
    rates = {k: slope(hs, [abs(r[k]) for r in rows]) if len(rows) > 1 else float("nan")
             for k in ("a_rel_error", "p0_rel_error", "cell_force_rel_error")}
    L = SIZE * A_REF
    fmt = {"h_m": ".3e", "F_N": ".6g", "a_m": ".4e", "a_h_m": ".4e", "a_h_min_m": ".3e", "a_h_max_m": ".3e",
           "a_rel_error": "+.3f", "p0_Pa": ".4e", "p0_h_Pa": ".4e", "p0_rel_error": "+.3f", "p_block_Pa": ".4e",
           "p_block_rel_error": "+.3f", "cell_force_rel_error": "+.3f", "delta_m": ".4e", "delta_h_m": ".4e",
           "delta_rel_error": "+.3f", "far_field_rel": ".3f", "seconds": ".1f"}
    short = ["degree", "n", "dofs", "rows", "h_m", "a_rel_error", "p0_rel_error", "p_block_rel_error",
             "cell_force_rel_error", "delta_rel_error", "active_nodes", "seconds"]
    cols = ["degree", "n", "dofs", "rows", "h_m", "F_N", "a_m", "a_h_m", "a_h_min_m", "a_h_max_m", "a_rel_error",
            "p0_Pa", "p0_h_Pa", "p0_rel_error", "p_block_Pa", "p_block_rel_error", "cell_force_rel_error",
            "delta_m", "delta_h_m", "delta_rel_error", "far_field_rel", "active_nodes", "ok", "resolves", "seconds"]
    far = rows[0]["far_field_rel"]
    text = (f"# Hertz validation in 3D: an elastic sphere on an elastic block\n\n"
            f"Steel punch with a spherical end (R = {R * 1e3:g} mm, E1 = {E1 / 1e9:g} GPa, nu1 = {NU1}) on an "
            f"aluminium block (E2 = {E2 / 1e9:g} GPa, nu2 = {NU2}), E* = {E_STAR / 1e9:.4g} GPa. Quarter model: the "
            f"block [0, L]^2 x [-L, 0] and the punch's column [0, L]^2 from the sphere's surface up to z = L, L = "
            f"{L * 1e3:g} mm, symmetry rollers on x = 0 and y = 0, the block's bottom clamped, the punch's top held "
            f"at u_z = 0 and pressed by the pair's gap -delta (the same as pushing the top down by delta), grids "
            f"graded towards the contact point (largest/smallest cell {RATIO:g}). P1 tetrahedra, the curved part "
            f"against the block's planar top in a node-to-face pair under the punch's nodal condition "
            f"{CONDITION!r}; delta set by secant re-solves so that the total force is F = {FORCE:.6g} N to 1e-10 "
            f"at every level (Hertz: a = {A_REF * 1e3:g} mm). a_h: mean distance from the axis of the mid-points "
            "of the punch's trace edges joining an active node to an open one (min and max listed); p0_h: the "
            "pressure at the punch's node on the axis (row force over its lumped area); p_block: the pressure "
            "felt by the block at its node on the axis; cell_force_rel_error: the rows of the punch's nodes of the "
            "cell at the axis against Hertz's pressure integrated on their hats (projected on the plane); "
            "delta_h: the approach (the top's push). h_m: the grid spacing near the axis. rows: the punch's nodes "
            "over the block (the constrained nodes).\n\n"
            + markdown_table(rows, short, fmt)
            + "\nEvery column (CSV: hertz3d_elastic.csv):\n\n" + markdown_table(rows, cols, fmt)
            + f"\nObserved rates in h (P1, levels {', '.join(str(n) for n in levels)}): contact radius "
              f"{rates['a_rel_error']:.2f}, peak pressure {rates['p0_rel_error']:.2f}, force of the axis cell "
              f"{rates['cell_force_rel_error']:.2f} (the radius is read from the active/open edges, so its error "
              "is within about h/2 and changes sign between levels).\n\n"
              f"Size effect: both bodies are finite (a block of depth L, a column of height and half-width L) where "
              f"Hertz assumes half-spaces. Their far fields are missing from the approach: Boussinesq's u_z at depth "
              f"L in each body adds up to {far:.3f} of Hertz's delta, the order of the approach's shortfall (the rest "
              "is the coarse mesh's stiffness, shrinking with h); a and p0 see the far field only through its "
              "variation across the contact zone, O((a/L)^2) of it (measured for the rigid sphere in "
              "docs/studies/hertz3d: 3e-4 when L doubles).\n")
    write_text(out / "hertz3d_elastic.md", text)
    return dict(rows=rows, rates=rates)


PROFILE_ROWS = {(1, "sigma1"): (8, 16, 24), (1, "gamma3"): (8, 16, 24), (2, "sigma1"): (8, 16),
                (2, "gamma3"): (8, 16)}
"""The profile variant's rows: (degree, condition) -> levels (``quick``: the first of each)."""
PROFILE_FINE = {(2, "sigma1"): (24,), (2, "gamma3"): (24,)}
"""Levels added by ``run_profile(fine=True)``: P2 at n = 24 (two bodies of 350,000 unknowns each; their cost is
in the study's table)."""


def gap_interpolation_error(sol, k=8) -> float:
    """m: the largest |g - g_h| over the cells of X_h (P1: the overlay triangles, P2: their 6-node cells), each
    sampled at the (k + 1)(k + 2)/2 points of its k-th barycentric lattice: g the profile :class:`SphereGap`
    at the solution's approach, g_h the interpolant (P1 linear, P2 quadratic) of the gap the rows carry
    (``sol.contact.gap``, the profile evaluated at the nodes of X_h). What the copositive "gamma3" condition
    imposes between nodes (docs/formulation.md §16); the nodal rows see g at their nodes only."""
    c = sol.contact
    itf = sol.contact_line(0)
    cells = c.trace.elements(itf)
    i, j = (g.ravel() for g in np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij"))
    keep = i + j <= k
    lam = np.column_stack([k - i[keep] - j[keep], i[keep], j[keep]]) / k          # (q, 3) barycentric
    shape = c.trace.shape_values(lam)
    x = np.asarray(c.x, dtype=float)
    X = np.einsum("qj,cjd->cqd", lam, x[cells[:, :3]])                            # (c, q, 2)
    g_h = np.einsum("qj,cj->cq", shape, np.asarray(c.gap, dtype=float)[cells])
    depth = float(np.max(SphereGap(0.0)(x[:, 0], x[:, 1]) - np.asarray(c.gap)))    # the approach delta
    return float(np.abs(SphereGap(depth)(X[..., 0], X[..., 1]) - g_h).max())


def run_profile(out, quick=False, progress=None, fine=False):
    """The gap-profile variant: every row of :data:`PROFILE_ROWS` (``quick``: level 8 only; ``fine``: with
    :data:`PROFILE_FINE`), written to hertz3d_elastic_profile.csv / .png / .md in ``out``; returns the rows and
    the observed rates."""
    say = progress or (lambda s: None)
    out = Path(out)
    rows, sols = [], {}
    for key, levels in PROFILE_ROWS.items():
        degree, condition = key
        levels = levels + (PROFILE_FINE.get(key, ()) if fine else ())
        for n in levels[:1] if quick else levels:
            row, sol = solve_profile_level(n, degree, condition)
            row["gap_interp_rel"] = gap_interpolation_error(sol) / row["delta_h_m"]
            sols[degree, condition] = (n, sol)
            rows.append(row)
            say(f"hertz3d_elastic profile P{degree} {condition} n={n}: a_h/a - 1 = {row['a_rel_error']:+.2e}, "
                f"p0_h/p0 - 1 = {row['p0_rel_error']:+.2e}, delta_h/delta - 1 = {row['delta_rel_error']:+.2e} "
                f"({row['seconds']:.1f} s)")
    write_csv(out / "hertz3d_elastic_profile.csv", rows)
    save_figure(figure_profile(sols), out / "hertz3d_elastic_profile.png")
    return write_profile_report(out, rows)


def figure_profile(sols):
    """The pressure felt by the block (nonzero values) against r at the finest level of each row (``sols``:
    (degree, condition) -> (n, solution)), with Hertz's profile at the design force."""
    from .hertz3d import contact_surface

    plt = pyplot()
    a, p0, _ = hertz(FORCE)
    fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="constrained")
    rs = np.linspace(0, a, 300)
    ax.plot(rs, p0 * np.sqrt(1 - (rs / a) ** 2), "k-", lw=1.5, label="Hertz (closed form, E* of both)", zorder=3)
    marks = {(1, "sigma1"): "o", (1, "gamma3"): "x", (2, "sigma1"): "s", (2, "gamma3"): "^"}
    for key, (n, sol) in sols.items():
        x = contact_surface(sol).traces[0].points
        p = sol.traction(0)[1]
        on = p != 0
        ax.plot(np.hypot(x[on, 0], x[on, 1]), p[on], marks[key], ms=3, mfc="none",
                label=f"P{key[0]} {key[1]}, n = {n}: felt by the block")
    pressure_axes(ax, f"Steel on aluminium, the sphere's profile (R = {R * 1e3:g} mm) as the gap, "
                  f"F = {FORCE / 1e3:.3g} kN", 2 * A_REF, fontsize=7)
    return fig


def write_profile_report(out, rows):
    """hertz3d_elastic_profile.md from the variant's rows; returns the rows and the observed rates in h."""
    kinds = list(dict.fromkeys((r["degree"], r["condition"]) for r in rows))
    conv = {k: [r for r in rows if (r["degree"], r["condition"]) == k] for k in kinds}
    keys = ("a_rel_error", "a_hull_rel_error", "p0_rel_error", "cell_force_rel_error", "delta_rel_error")
    rates = {k: {q: slope([r["h_m"] for r in conv[k]], [abs(r[q]) for r in conv[k]]) for q in keys} for k in kinds}
    fmt = {"h_m": ".3e", "F_N": ".6g", "a_m": ".4e", "a_h_m": ".4e", "a_h_min_m": ".3e", "a_h_max_m": ".3e",
           "a_rel_error": "+.3f", "a_hull_m": ".4e", "a_hull_rel_error": "+.3f", "a_moment_m": ".4e",
           "a_moment_rel_error": "+.4f", "p0_Pa": ".4e", "p0_h_Pa": ".4e", "p0_rel_error": "+.3f",
           "p_cell_Pa": ".4e", "cell_force_rel_error": "+.4f", "delta_m": ".4e", "delta_h_m": ".4e",
           "delta_rel_error": "+.3f", "far_field_rel": ".3f", "gap_interp_rel": ".1e", "seconds": ".1f"}
    short = ["degree", "condition", "n", "dofs", "h_m", "a_rel_error", "a_hull_rel_error", "a_moment_rel_error",
             "p0_rel_error", "cell_force_rel_error", "delta_rel_error", "gap_interp_rel", "seconds"]
    cols = ["degree", "condition", "n", "dofs", "h_m", "F_N", "a_m", "a_h_m", "a_h_min_m", "a_h_max_m",
            "a_rel_error", "a_hull_m", "a_hull_rel_error", "support_points", "a_moment_m", "a_moment_rel_error",
            "p0_Pa", "p0_h_Pa", "p0_rel_error", "p_cell_Pa", "cell_force_rel_error", "delta_m", "delta_h_m",
            "delta_rel_error", "far_field_rel", "gap_interp_rel", "active_nodes", "contact_nodes", "ok",
            "resolves", "seconds"]

    def listed(k, q, f="+.3f", ns=None):
        return ", ".join(f"{r[q]:{f}}" for r in conv[k] if ns is None or r["n"] in ns)

    def rate(k):
        return (f"P{k[0]} {k[1]} (levels {', '.join(str(r['n']) for r in conv[k])}): peak pressure "
                f"{rates[k]['p0_rel_error']:.2f}, axis cell's force {rates[k]['cell_force_rel_error']:.2f}, "
                f"approach {rates[k]['delta_rel_error']:.2f}, contact radius {rates[k]['a_rel_error']:.2f}")

    same = ""
    if (1, "sigma1") in conv and (1, "gamma3") in conv:
        d = max(abs(r1[q] - r3[q]) for r1, r3 in zip(conv[1, "sigma1"], conv[1, "gamma3"]) for q in keys)
        same = (f"On matching faces the merged nodes are the block's nodes, so P1 \"gamma3\" and P1 \"sigma1\" pose "
                f"the same rows: their columns agree to {d:.0e} (relative to Hertz).\n\n")
    p2 = ""
    if (2, "sigma1") in conv and (1, "sigma1") in conv:
        common = [n for n in (r["n"] for r in conv[2, "sigma1"]) if n in {r["n"] for r in conv[1, "sigma1"]}]
        p2 = (f"At equal levels (n = {', '.join(map(str, common))}) P2 reads the peak pressure closer to Hertz: "
              f"P2 sigma1 {listed((2, 'sigma1'), 'p0_rel_error', ns=common)}"
              + (f", P2 gamma3 {listed((2, 'gamma3'), 'p0_rel_error', ns=common)}" if (2, "gamma3") in conv else "")
              + f" against P1's {listed((1, 'sigma1'), 'p0_rel_error', ns=common)}; the approach, P2 sigma1 "
              f"{listed((2, 'sigma1'), 'delta_rel_error', ns=common)} against P1's "
              f"{listed((1, 'sigma1'), 'delta_rel_error', ns=common)}.\n\n")
    text = (f"# Hertz validation in 3D, two elastic bodies: the gap-profile model\n\n"
            f"Hertz's own boundary-value problem: two elastic half-spaces, here a steel body (E1 = {E1 / 1e9:g} GPa, "
            f"nu1 = {NU1}) on an aluminium block (E2 = {E2 / 1e9:g} GPa, nu2 = {NU2}), E* = {E_STAR / 1e9:.4g} GPa, "
            f"both with FLAT contact faces, the curvature of the sphere (R = {R * 1e3:g} mm) carried by the pair's "
            "initial gap g(x, y) = R - sqrt(R^2 - r^2) - delta (Hertz's approximation: a << R). Quarter model "
            f"(x, y >= 0): the block [0, L]^2 x [-L, 0] with its bottom clamped, the steel box [0, L]^2 x [0, L] "
            f"with its top held at u_z = 0, L = {SIZE * A_REF * 1e3:g} mm, symmetry rollers on x = 0 and y = 0, "
            f"matching grids graded towards the axis (largest/smallest cell {RATIO:g}, n cells per edge), the "
            f"contact parts the patches [0, 2a]^2 of the two faces. The approach delta is set by secant re-solves "
            f"so that the total force is F = {FORCE:.6g} N (to 1e-10; P2 gamma3 to 1e-7) at every level "
            f"(Hertz: a = {A_REF * 1e3:g} mm). The punch with a spherical end (hertz3d_elastic.md) is the same "
            "contact with a curved part, P1 only; this variant gives the P2 rows.\n\n"
            "The gap is a function of the in-plane coordinates: the nodal rows (P1 and P2 \"sigma1\": the block's "
            "nodes, P2: its vertices and edge midpoints; P1 \"gamma3\": the merged nodes) evaluate it at their "
            "nodes; the copositive condition (P2 \"gamma3\", docs/formulation.md §16) imposes [u_nu] <= g_h on "
            "every face, g_h the quadratic interpolant of g through the six nodes of the face. gap_interp_rel: "
            "the largest |g - g_h| on the patch over the approach (P1: the linear interpolant), what the cells see "
            "of the profile between nodes (the quadratic part of the profile, r^2 / 2R, is interpolated exactly "
            "by P2).\n\n"
            "Columns as the rigid sphere's study (docs/studies/hertz3d), against Hertz with E* of both bodies: "
            "a_h the mean distance from the axis of the mid-points of the block's trace edges leaving the active "
            "nodes outwards (P2: on the grid of P2 nodes; P2 gamma3: the hull radius a_hull of the points where "
            "the gap closes, an estimate from inside); a_moment the radius of Hertz's profile with the forces' "
            "second moment; p0_h the pressure felt by the block on the axis (P1: force over lumped area, P2: the "
            "Riesz representer on its P2 faces); cell_force_rel_error the force of the axis cell's top nodes "
            "against Hertz's pressure on the same shape functions; delta_h the approach. h_m: the grid spacing "
            "near the axis (P2: of the vertices); dofs: both bodies. Seconds: one process on a shared two-core "
            "machine (under varying load). `cvxcontact study hertz3d_elastic --profile` runs P1 to n = 24 and P2 "
            "to n = 16; the P2 rows at n = 24 come from `run_profile(out, fine=True)` (about 11 GB peak memory "
            "each, measured).\n\n"
            + markdown_table(rows, short, fmt)
            + "\nEvery column (CSV: hertz3d_elastic_profile.csv):\n\n" + markdown_table(rows, cols, fmt)
            + f"\nObserved rates in h: {'; '.join(rate(k) for k in kinds if len(conv[k]) > 1)}.\n\n"
            + same + p2
            + "The table is close to the rigid sphere's (docs/studies/hertz3d) for a reason: the steel body's grid "
              "is the block's mirror image and both have Poisson's ratio 0.3, so its surface compliance is E2/E1 "
              "times the block's, and with its top clamped the pair would be exactly the rigid sphere on the block "
              "with Hertz's E* (tests/test_hertz3d_elastic.py: the errors agree to 2e-13 at n = 8, P2 gamma3 to "
              "1.4e-6); the study holds the top in z only, which changes the approach (P1 n = 8: -0.110 against "
              "-0.113) and leaves a and p0 to three digits. Two routes to the same numbers: the pair's gap "
              "function between two bodies, and a rigid obstacle's distance.\n\n"
            + f"Size effect: both bodies are finite; Boussinesq's u_z at depth L in each body adds up to "
              f"{rows[0]['far_field_rel']:.3f} of Hertz's delta, the order of the approach's shortfall on the "
              "finest levels: P2's approach stays near the finite bodies' own value from the coarsest level on "
              "(its rate in h says nothing), P1's approaches it from below (a P1 mesh is too stiff); a and p0 see "
              "the far field only through its variation across the contact zone. The axis cell's force changes "
              "sign with P2 (its rate says little).\n")
    write_text(Path(out) / "hertz3d_elastic_profile.md", text)
    return dict(rows=rows, rates=rates)
