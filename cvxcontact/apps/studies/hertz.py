"""Hertz validation: a cylinder pressed on a block, as two elastic blocks with a parabolic gap.

The cylinder (radius R) is the upper block with the initial gap g(x) = x^2 / (2 R) - delta
(delta: the prescribed approach, an interference); both blocks are clamped on their far
edges and are large compared with the contact width. The classical plane-strain Hertz
solution for the measured load P (N/m) is

    a = sqrt(4 P R / (pi E*)),   p(x) = (2 P / (pi a^2)) sqrt(a^2 - x^2),   p0 = 2 P / (pi a),
    1 / E* = (1 - nu1^2) / E1 + (1 - nu2^2) / E2.

The FE half-width a_h is the mid-point between the outermost closed node and the first
open node on each side (so |a_h - a| <= h/2 is the resolution limit, h/4 for P2 whose X_h
nodes include the segments' midpoints; "closed": see :func:`half_width`); p0_h is the peak
pressure felt by the cylinder (:meth:`Solution.traction` on its trace nodes; the merged-
mesh nodal forces of gamma3 alternate, see the stability study). Meshes are graded towards the contact zone
and do not match on Gamma_3 (the lower block has about 0.8 times the cells).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...physics import materials
from ...physics.scene import Body, Scene
from .common import DEGREES, Timer, graded_block, solve_quietly, markdown_table, pyplot, save_figure, slope, write_csv, write_text

STEEL, ALU = (200e9, 0.3), (70e9, 0.33)
R, DELTA, WIDTH, HEIGHT = 2.0, 1e-2, 2.0, 2.0


def hertz(P, R, E_star):
    """Half-width a (m) and peak pressure p0 (Pa) of 2D Hertz contact under load P (N/m)."""
    a = np.sqrt(4 * P * R / (np.pi * E_star))
    return a, 2 * P / (np.pi * a)


def e_star(E1, nu1, E2, nu2):
    return 1.0 / ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2)


def scene(n, ratio=0.8):
    """The cylinder-on-block scene: n cells on the upper trace, about ``ratio`` n below."""
    upper = graded_block((-WIDTH, WIDTH), (0.0, HEIGHT), n, n // 2, "bottom", beta=3.0, gamma=2.5)
    m = max(4, round(ratio * n) + 1)
    lower = graded_block((-WIDTH, WIDTH), (-HEIGHT, 0.0), m, m // 2, "top", beta=3.0, gamma=2.5)
    b1 = Body(upper, materials.isotropic(*STEEL, name="steel"), clamped="top", contact="bottom", name="cylinder")
    b2 = Body(lower, materials.isotropic(*ALU, name="aluminium"), clamped="bottom", contact="top", name="block")
    return Scene(b1, b2, gap=lambda x: x ** 2 / (2 * R) - DELTA)


def half_width(contact):
    """Mid-point estimate of the contact half-width (m): between the outermost closed node and the
    next open one on each side. P1: closed = active (a nonzero force at the node). P2 (a trace whose "gamma3"
    takes cones, ``contact.trace.gamma3_cones``): the nodal forces
    r = B^T beta of X_h are not sign-definite and a segment carrying force has open ends, so a node of
    X_h is closed where the jump reaches the gap, [u_nu] - g >= -1e-3 DELTA (the approach sets the scale;
    the interior point closes contact to about 1e-7 DELTA here)."""
    x = contact.x
    act = (contact.jump - contact.gap) >= -1e-3 * DELTA if contact.trace.gamma3_cones else contact.active
    if not act.any():
        return 0.0
    i0, i1 = np.flatnonzero(act)[[0, -1]]
    left = 0.5 * (x[i0] + x[max(i0 - 1, 0)])
    right = 0.5 * (x[i1] + x[min(i1 + 1, len(x) - 1)])
    return 0.5 * (right - left)


def figure(rows, last, levels):
    """The study's figure: left, the pressure on the finest P2 and P1 meshes against the Hertz profile (λ_h of
    the merged mesh drawn faintly and clipped to the Hertz scale, its range stated); right, the errors of the
    half-width and the peak pressure against the unknowns. ``last[degree] = (sol, a, p0, P)``."""
    from matplotlib.ticker import EngFormatter, MaxNLocator

    plt = pyplot()
    sol, a, p0, P = last[2]
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    c = sol.contact
    xs = np.linspace(-a, a, 400)
    ax.plot(xs, 2 * P / (np.pi * a ** 2) * np.sqrt(np.maximum(a ** 2 - xs ** 2, 0)), "k-", lw=1.5,
            label="Hertz (closed form, measured P)", zorder=3)
    xt, pt = sol.traction(0)
    nt = np.abs(xt) <= 1.6 * a
    ax.plot(xt[nt], pt[nt], "o", ms=3, label=f"P2 (n = {levels[2][-1]}): pressure on the cylinder's nodes", zorder=4)
    x1, p1 = last[1][0].traction(0)
    n1 = np.abs(x1) <= 1.6 * a
    ax.plot(x1[n1], p1[n1], "x", ms=3, label=f"P1 (n = {levels[1][-1]}): the same", zorder=4)
    near = np.abs(c.x) <= 1.6 * a
    lam = c.lam[near]
    top = 1.35 * p0
    ax.plot(c.x[near], np.clip(lam, -0.25 * p0, top), "-", lw=0.6, alpha=0.35, color="C3",
            label=rf"P2: $\lambda_h$ on the merged mesh, clipped (range {lam.min() / 1e9:.1f} to {lam.max() / 1e9:.1f} GPa)")
    ax.set_ylim(-0.25 * p0, top)
    ax.xaxis.set_major_locator(MaxNLocator(6))
    ax.xaxis.set_major_formatter(EngFormatter(unit="m"))
    ax.yaxis.set_major_formatter(EngFormatter(unit="Pa"))
    ax.set_xlabel("x1 along the contact line")
    ax.set_ylabel("contact pressure")
    ax.set_title(f"Cylinder (R = {R} m) on a block: pressure along the contact", fontsize=10)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)
    for degree, style in ((1, "-"), (2, "--")):
        sub = [r for r in rows if r["degree"] == degree]
        ax2.loglog([r["dofs"] for r in sub], [abs(r["a_rel_error"]) for r in sub], "o" + style, label=f"P{degree}: |a_h / a - 1|")
        ax2.loglog([r["dofs"] for r in sub], [abs(r["p0_rel_error"]) for r in sub], "s" + style, label=f"P{degree}: |p0_h / p0 - 1|")
    ax2.set_xlabel("unknowns (u and phi, both bodies)")
    ax2.set_ylabel("relative error")
    ax2.set_title("Error against Hertz, P1 and P2 at equal unknowns", fontsize=10)
    ax2.legend(fontsize=8)
    ax2.xaxis.set_minor_formatter(plt.NullFormatter())
    return fig


def level(degree, n):
    """One row of the study's table (the scene at ``n`` cells with P``degree`` elements, solved) and the solution."""
    clock = Timer()
    sol = solve_quietly(scene(n), "gamma3", method="condensed", degree=degree)
    seconds = clock()
    c = sol.contact
    P = float(c.force.sum())
    a, p0 = hertz(P, R, e_star(*STEEL, *ALU))
    a_h, p0_h = half_width(c), float(sol.traction(0)[1].max())
    xv = c.trace.vertices(c.x)                                  # merged vertices
    h = float(np.diff(xv)[np.abs(xv[:-1]) <= a].max()) if P > 0 else float("nan")
    dofs = sum(3 * len(p) if ph is not None else 2 * len(p) for p, ph in zip(sol.points, sol.phi))
    return dict(degree=degree, n=n, dofs=dofs, h_contact_m=h, load_N_per_m=P, a_m=a, a_h_m=a_h,
                a_rel_error=a_h / a - 1, p0_Pa=p0, p0_h_Pa=p0_h, p0_rel_error=p0_h / p0 - 1,
                active_nodes=int(c.active.sum()), ok=sol.ok, seconds=seconds), sol


def run(out, quick=False, progress=None):
    say = progress or (lambda s: None)
    out = Path(out)
    # P2 at n has about the unknowns of P1 at 2n (nodes at every vertex and edge midpoint)
    levels = {1: [24, 48, 96], 2: [12, 24, 48]} if quick else {1: [32, 64, 128, 256, 512], 2: [16, 32, 64, 128, 256]}
    rows, last = [], {}
    for degree in DEGREES:
        for n in levels[degree]:
            row, sol = level(degree, n)
            rows.append(row)
            say(f"hertz P{degree} n={n}: a_h/a - 1 = {row['a_rel_error']:+.2e}, "
                f"p0_h/p0 - 1 = {row['p0_rel_error']:+.2e} ({row['seconds']:.1f} s)")
            last[degree] = (sol, row["a_m"], row["p0_Pa"], row["load_N_per_m"])
    write_csv(out / "hertz.csv", rows)
    fig = figure(rows, last, levels)
    save_figure(fig, out / "hertz.png")
    rate = {}
    for degree in DEGREES:
        sub = [r for r in rows if r["degree"] == degree]
        hs = [r["h_contact_m"] for r in sub]
        rate[degree] = (slope(hs, [abs(r["a_rel_error"]) for r in sub]), slope(hs, [abs(r["p0_rel_error"]) for r in sub]))
    text = (f"# Hertz validation\n\nCylinder (steel, R = {R} m) on a block (aluminium) as two graded blocks "
            f"{2 * WIDTH} m wide with gap x^2/(2R) - {DELTA} m, condition gamma3 (P2: the conic \"everywhere\" "
            "condition), non-matching meshes. P2 at n has about the unknowns of P1 at 2n. h_contact_m: largest "
            "merged-mesh segment in the contact zone (P2: between merged vertices; its nodes are twice as dense).\n\n"
            + markdown_table(rows, ["degree", "n", "dofs", "h_contact_m", "load_N_per_m", "a_m", "a_h_m", "a_rel_error",
                                    "p0_Pa", "p0_h_Pa", "p0_rel_error", "active_nodes", "ok", "seconds"],
                             {"h_contact_m": ".2e", "load_N_per_m": ".4e", "a_m": ".5f", "a_h_m": ".5f",
                              "a_rel_error": "+.2e", "p0_Pa": ".4e", "p0_h_Pa": ".4e", "p0_rel_error": "+.2e",
                              "seconds": ".2f"})
            + "".join(f"\nObserved rates in h, P{d}: half-width {rate[d][0]:.2f}, peak pressure {rate[d][1]:.2f}.\n"
                      for d in (1, 2)))
    write_text(out / "hertz.md", text)
    return dict(rows=rows, rate_a=rate[1][0], rate_p0=rate[1][1], rate_a_p2=rate[2][0], rate_p0_p2=rate[2][1])
