"""Convergence study: errors against a much finer reference, for the three contact conditions,
with P1 and P2 elements.

For each scene, degree and condition, five mesh levels with non-matching meshes on Gamma_3
(the lower body has about 3/4 of the upper body's cells, plus one) are solved (condensed path)
and compared with one reference per scene: P2 with the conic "everywhere" condition on matching
meshes (n = 256 cells; 32 in the quick version), see :class:`Reference` for the choice. P1 levels
n = 8 ... 128, P2 levels n = 4 ... 64 (P2 at n has about the unknowns of P1 at 2n). Errors:

* energy norm of (u, phi): ||e||_E^2 = e_u^T Kuu e_u + e_phi^T Kpp e_phi with the reference's P2
  matrices (the symmetric part of the paper's a(., .)), e = I_ref(u_h, phi_h) - (u_ref, phi_ref),
  relative to the reference's norm; I_ref is the interpolation of the P1 or P2 field at the
  reference's P2 nodes;
* lambda in L2(Gamma_3): exact integration (3-point Gauss on the union of the breakpoints) of the
  difference of two functions of the line, each piecewise linear (P1) or piecewise quadratic on
  the merged segments (P2, X_h of docs/formulation.md §8), relative to ||lambda_ref||;
* lambda in the mesh-dependent H^{-1/2} norm ||mu||_{-1/2,h}^2 = sum_s h_s ||mu||_{L2(s)}^2 over the
  segments s of the coarse merged mesh (the norm of the paper's discrete analysis), relative
  to sqrt(|Gamma_3|) ||lambda_ref||_L2 (a fixed number, so that the rate is that of the norm);
* the pressure felt by the upper body (:meth:`Solution.traction`, nodal forces moved to its
  own trace nodes) in L2(Gamma_3), against the same quantity of the reference, relative:
  the non-oscillating view of the multiplier.

Observed rates are least-squares slopes in h (and the slope of the two finest levels). The
theorems' rates for the energy error are h^{1/2+eta} (Theorems 1 and 3) and h^{1/2+eta/2}
(Theorem 2), with u in H^{3/2+eta}; eta is capped at 1/2 by P1 and tends to 1 with P2 for a solution
in H^{5/2-eps}; the figure draws h^1.5, h^1 and h^0.75 beside the data.

Scenes: "hertzian" (a parabolic gap, g = (x - 1/2)^2 / 2 - 0.05 m, closes on an interior zone,
about [0.27, 0.73]: smooth data, two transitions with the square-root behaviour of
Hertz contact, the setting of Theorem 3; the clamped-free corners of the blocks still limit the
regularity) and "partial" (the quickstart scene: the contact zone reaches a corner of the bodies,
loaded edges, corner singularities: less regular), both written to ``convergence.*``; and
"smooth" (the hertzian blocks and gap with roller, i.e. symmetry, lateral sides: no corner
singularity, the solution in H^{5/2-eps} with its only singularities at the two transition points,
the setting where P2 can show Theorem 1's h^{3/2}; see :func:`scene`), written to
``convergence_smooth.*`` with its own reference (P2 gamma3, n = 512; 32 in the quick version), whose
own error is measured by the reference at half its n (``convergence_smooth_reference.csv``), the
rates level by level, and the largest penetration max([u_h nu] - g)_+ of every solution
(:func:`max_penetration`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...contact.interface import CONDITIONS
from ...errors import SceneError
from ...fem.space import space
from ...fem.trace import TRACES
from ...geometry.mesh import rectangle
from ...physics import materials
from ...physics.materials import Elastic
from ...physics.scene import Body, Scene
from .common import (
    DEGREES,
    Timer,
    markdown_table,
    pyplot,
    save_figure,
    slope,
    solve_quietly,
    write_csv,
    write_text,
)

THEOREM = {"gamma3": ("Th. 1", 1.0), "sigma1": ("Th. 2", 0.75), "sigma2": ("Th. 2", 0.75)}

ALUMINIUM = materials.isotropic(E=70e9, nu=0.3, name="aluminium")
"""The lower block's material (E = 70 GPa, nu = 0.3)."""

CASES = tuple((degree, condition) for degree in DEGREES for condition in CONDITIONS)
"""The (degree, condition) pairs the study solves at every level: both degrees, the three conditions."""


def scene(kind: str, n1: int, n2: int, material: Elastic = ALUMINIUM) -> Scene:
    """The study's scene ``kind`` with ``n1`` cells on the upper body's contact side, ``n2`` on the lower's.

    Both blocks are 1 m x 0.5 m (upper PZT-5A, poled along y, clamped and grounded on top; lower
    ``material``, aluminium by default, clamped at the bottom), Gamma_3 = [0, 1] x {0}. ``material`` may be a
    nonlinear material (:func:`~cvxcontact.physics.materials.hencky`: the paper's nonlinear A; the study
    ``convergence_hencky``).

    * ``"hertzian"``: the parabolic gap g(x) = (x - 1/2)^2 / 2 - 0.05 m (an interference of 0.05 m
      at x = 1/2) closes on an interior zone; lateral sides free.
    * ``"partial"``: g = 0, body force, a traction on the right side and a surface charge on the
      left; the contact zone reaches the corner x = 0 (the quickstart's scene).
    * ``"smooth"``: the hertzian blocks and gap with **roller lateral sides** (u_x = 0, no
      tangential traction, no surface charge, on x = 0 and x = 1 of both blocks). Why this is as
      smooth as a contact solution can be: x = 0 and x = 1 are then symmetry planes. Both materials
      are invariant under x -> -x (isotropic; 6mm poled along y has no c16, c26 or e-coupling
      between x and y that changes sign), and under that reflection u_x is odd, u_y and phi are
      even, so u_x = 0, sigma_xy = 0 and D_x = 0 are exactly the conditions the even/odd extension
      satisfies. The solution is therefore the restriction of the solution of the 2 m-periodic
      layer problem (blocks repeated by reflection), which has no corners at all: the clamped
      top/bottom, the grounded top and the free part of Gamma_3 become straight boundaries, and the
      corners of angle pi/2 where a roller meets a clamped, free or grounded side carry no
      singularity (r^{lambda} with integer lambda only). The contact zone (about [0.24, 0.76]) stays
      away from the rollers, so the gap's kink in the reflected problem never enters. What is left
      is the contact condition: at the two transition points the solution behaves like
      r^{3/2} (pressure ~ sqrt(distance), Hertz), i.e. u in H^{5/2-eps} near them and smooth
      elsewhere: eta -> 1 in Theorems 1-3, the case where P2 can show h^{3/2}. Roller supports
      remove the corner singularities exactly, where long blocks or loads far from the corners
      would only make their coefficients small (and a manufactured solution would need a smooth
      prescribed contact zone, which Signorini data cannot impose: its transitions are r^{3/2}
      anyway). The gap is still a parabola, so the conic reference remains conforming.
    """
    upper = rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n1, ny=max(2, n1 // 2))
    lower = rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=n2, ny=max(2, n2 // 2))
    alu = material
    if kind == "hertzian":
        b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom")
        b2 = Body(lower, alu, clamped=["bottom"], contact="top")
        return Scene(b1, b2, gap=lambda x: (x - 0.5) ** 2 / 2.0 - 0.05)
    if kind == "partial":
        b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom",
                  body_force=(0.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05})
        b2 = Body(lower, alu, clamped=["bottom"], contact="top")
    elif kind == "smooth":
        b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], roller=["left", "right"],
                  contact="bottom")
        b2 = Body(lower, alu, clamped=["bottom"], roller=["left", "right"], contact="top")
        return Scene(b1, b2, gap=lambda x: (x - 0.5) ** 2 / 2.0 - 0.05)
    else:
        raise SceneError(f"unknown convergence scene {kind!r}; known: {SCENES}")
    return Scene(b1, b2)


def _locate(mesh, points):
    """Triangle index and barycentric coordinates (m, 3) of ``points`` (m, 2) in the P1 ``mesh``."""
    import matplotlib.tri as mtri

    pts, triangles = mesh.points, mesh.triangles
    tri = mtri.Triangulation(pts[:, 0], pts[:, 1], triangles)
    idx = tri.get_trifinder()(points[:, 0], points[:, 1])
    lost = idx < 0
    if lost.any():            # on the boundary, round-off: the nearest triangle by centroid
        cen = pts[triangles].mean(axis=1)
        idx[lost] = np.argmin(((points[lost, None, :] - cen[None]) ** 2).sum(-1), axis=1)
    p = pts[triangles[idx]]                                               # (m, 3, 2)
    T = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)          # (m, 2, 2)
    lam12 = np.linalg.solve(T, (points - p[:, 0])[..., None])[..., 0]
    return idx, np.column_stack([1 - lam12.sum(1), lam12])


def _transfer(mesh, values, points, degree=1):
    """Interpolation at ``points`` (m, 2) of the P1 (``degree`` 1, values at the mesh points) or P2
    (values at the :class:`~cvxcontact.geometry.quadratic.P2Nodes` of ``mesh``) field ``values`` (n, k)."""
    idx, bary = _locate(mesh, points)
    element = space(degree, mesh.cell)
    return np.einsum("mi,mik->mk", element.shape_values(bary), values[element.node_set(mesh).cells[idx]])


def _line_function(x, f, degree):
    """The piecewise polynomial on the line: P1 through (x, f), or P2 with ``x`` interleaving the
    vertices and the midpoints of the segments (X_h of docs/formulation.md §8). Returns (breaks, eval)."""
    x, f = np.asarray(x, float), np.asarray(f, float)
    trace = TRACES[degree]
    return trace.vertices(x), lambda t: trace.values(x, f, t)


def _line_difference_l2(a, b, weight_mesh=None):
    """||f_a - f_b||_L2 of two piecewise polynomial functions ``a``, ``b`` = (x, f, degree) of the
    line (3-point Gauss on the union of their breakpoints: exact for degrees up to 2); with
    ``weight_mesh`` (nodes), the h-weighted sum_s h_s ||f_a - f_b||^2_{L2(s)} (square root taken)."""
    (ba, fa), (bb, fb) = _line_function(*a), _line_function(*b)
    x = np.union1d(ba, bb)
    h = np.diff(x)
    g = 0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    w = np.array([5.0, 8.0, 5.0]) / 18.0
    t = x[:-1, None] + h[:, None] * g[None]
    d = fa(t) - fb(t)
    seg = h * (d ** 2 @ w)
    if weight_mesh is not None:
        mid = 0.5 * (x[:-1] + x[1:])
        k = np.clip(np.searchsorted(weight_mesh, mid) - 1, 0, len(weight_mesh) - 2)
        seg = seg * np.diff(weight_mesh)[k]
    return float(np.sqrt(seg.sum()))


def _p1_difference_l2(x1, f1, x2, f2, weight_mesh=None):
    """||f1 - f2||_L2 of two piecewise linear functions (see :func:`_line_difference_l2`)."""
    return _line_difference_l2((x1, f1, 1), (x2, f2, 1), weight_mesh)


class Reference:
    """A fine solution and what is needed to measure errors against it.

    ``degree`` 2 (the default): P2 with the conic "everywhere" condition on matching meshes
    (``n`` cells on both traces): on matching meshes the three conditions have the same
    multiplier space but the conic one is the conforming one (K_h(Gamma_3) is inside K when the
    gap is piecewise quadratic: g = 0 or a parabola here), and P2 is a higher order than either
    degree it is compared with. Errors of P1 and P2 solutions are measured on the reference's P2
    nodes with its P2 matrices (for a nonlinear lower ``material``, its tangent at zero strain).
    ``condition``, ``method``: another condition and route (a nonlinear material: "sigma1" by the
    Newton route, where the conic condition is refused); ``material``: the lower block's.
    """

    def __init__(self, kind, n, degree=2, condition="gamma3", method="condensed", material=ALUMINIUM):
        self.degree, self.condition = degree, condition
        self.scene = scene(kind, n, n, material)
        self.sol = solve_quietly(self.scene, condition, method=method, degree=degree)
        element = space(degree, self.scene.cell)
        self.mats = [element.assemble_matrices(b, element.nodes(b)) for b in self.scene.bodies]
        self.points = [element.node_set(b.mesh).points for b in self.scene.bodies]
        self.norm_E = np.sqrt(sum(self._energy(k, self.sol.u[k], self.sol.phi[k]) for k in range(2)))
        c = self.sol.contact
        self.lam = (c.x, c.lam, degree)
        self.norm_l2 = _line_difference_l2(self.lam, (c.x, 0 * c.lam, degree))
        xt, pt = self.sol.traction(0)
        self.traction = (xt, pt, degree)
        self.norm_traction = _line_difference_l2(self.traction, (xt, 0 * pt, degree))

    def _energy(self, k, u, phi):
        m = self.mats[k]
        e = float(u.ravel() @ (m.Kuu @ u.ravel()))
        return e + (float(phi @ (m.Kpp @ phi)) if phi is not None else 0.0)

    def errors(self, sol):
        """Relative errors of ``sol`` (P1 or P2, ``sol.degree``) against the reference (module docstring)."""
        d = getattr(sol, "degree", 1)
        e2 = 0.0
        for k, body in enumerate(sol.scene.bodies):
            fields = sol.u[k] if sol.phi[k] is None else np.column_stack([sol.u[k], sol.phi[k]])
            at_ref = _transfer(body.mesh, fields, self.points[k], d)
            du = at_ref[:, :2] - self.sol.u[k]
            dphi = at_ref[:, 2] - self.sol.phi[k] if sol.phi[k] is not None else None
            e2 += self._energy(k, du, dphi)
        c, r = sol.contact, self.sol.contact
        lam = (c.x, c.lam, d)
        lam_l2 = _line_difference_l2(lam, self.lam)
        lam_h = _line_difference_l2(lam, self.lam, weight_mesh=c.x if d == 1 else c.x[::2])
        x1, p1_ = sol.traction(0)
        body = _line_difference_l2((x1, p1_, d), self.traction) / self.norm_traction
        length = r.x[-1] - r.x[0]
        return dict(energy=np.sqrt(e2) / self.norm_E, lam_l2=lam_l2 / self.norm_l2,
                    lam_h12=lam_h / (np.sqrt(length) * self.norm_l2), traction_l2=body)


def max_penetration(contact, samples: int = 8) -> float:
    """max over Gamma_3 of ([u_h nu] - g)_+ (m): the jump minus the gap, continuous piecewise linear
    (P1) or quadratic (P2, exact for the scenes' gaps, 0 or a parabola) on the merged segments, sampled
    at ``samples`` + 1 points per segment: below the true maximum by at most |f''| (h / (2 samples))^2 / 2
    on a segment of length h (a quadratic f near its maximum). 0 up to the solver's tolerance for
    gamma3; with sigma_l, how far the other body's trace enters between the nodes of mesh l."""
    d = contact.degree
    breaks, ev = _line_function(contact.x, contact.jump - (0.0 if contact.gap is None else contact.gap), d)
    t = (breaks[:-1, None] + np.diff(breaks)[:, None] * np.linspace(0.0, 1.0, samples + 1)[None]).ravel()
    return float(max(ev(t).max(), 0.0))


def theorem_rates(condition, degree):
    """(theorem, rate) of the energy error bound: h^{1/2+eta} (Th. 1 for gamma3, Th. 3 for the nodal
    conditions with finitely many transition points) or h^{1/2+eta/2} (Th. 2), with eta at the cap of
    the degree's approximation (P1: eta = 1/2; P2: eta -> 1)."""
    eta = space(degree).order / 2
    if condition == "gamma3":
        return "Th. 1", 0.5 + eta
    return "Th. 2 / Th. 3", f"{0.5 + eta / 2:g} / {0.5 + eta:g}"


SCENES = ("hertzian", "partial", "smooth")
"""The study's scenes; "hertzian" and "partial" are written to ``convergence.*``, "smooth" to
``convergence_smooth.*`` (its own reference, checked against a second reference level)."""


def run(out, quick=False, progress=None, scenes=SCENES):
    """Run the study on ``scenes`` (a subset of :data:`SCENES`) and write its files into ``out``.

    Full version: P1 n = 8 ... 128, P2 n = 4 ... 64; reference P2 gamma3 n = 256 ("hertzian",
    "partial") or n = 512 ("smooth", whose finest P2 error is small enough for a 4-times-finer
    reference to bias it, see :func:`scene`), the smooth one checked against the reference at half its
    n. Quick version: P1 n = 4, 8, 16, P2 n = 4, 8, reference n = 32 (check: 16).
    Returns ``{"rows", "rates"}`` (and ``"smooth"``: the smooth scene's rows, rates, reference check)."""
    say = progress or (lambda s: None)
    out = Path(out)
    unknown = [k for k in scenes if k not in SCENES]
    if unknown:
        raise SceneError(f"unknown convergence scene(s) {unknown}; known: {SCENES}")
    levels = {1: [4, 8, 16], 2: [4, 8]} if quick else {1: [8, 16, 32, 64, 128], 2: [4, 8, 16, 32, 64]}
    result = {}
    main = [k for k in ("hertzian", "partial") if k in scenes]
    if main:
        n_ref = 32 if quick else 256
        rows, rates, _ = measure_rates(main, levels, n_ref, say)
        _write(out, "convergence", main, rows, rates, levels, n_ref)
        result.update(rows=rows, rates=rates)
    if "smooth" in scenes:
        n_ref = 32 if quick else 512
        rows, rates, check = measure_rates(["smooth"], levels, n_ref, say, check_reference=True)
        _write(out, "convergence_smooth", ["smooth"], rows, rates, levels, n_ref, check)
        result["smooth"] = dict(rows=rows, rates=rates, reference_check=check)
        if not main:
            result.update(rows=rows, rates=rates)
    return result


def level(kind: str, degree: int, condition: str, n: int, method: str = "condensed",
          material: Elastic = ALUMINIUM) -> tuple[dict, object]:
    """One level of the study without the reference: the row's columns that need no reference (``scene`` ...
    ``h``, ``dofs``, ``penetration``, ``active``, ``ok``, ``checks_max``, ``seconds``) and the solution
    (solved by ``method``, the lower block of ``material``)."""
    n2 = 3 * n // 4 + 1
    clock = Timer()
    sol = solve_quietly(scene(kind, n, n2, material), condition, method=method, degree=degree)
    seconds = clock()
    dofs = sum(3 * len(p) if ph is not None else 2 * len(p) for p, ph in zip(sol.points, sol.phi))
    return dict(scene=kind, degree=degree, condition=condition, n1=n, n2=n2, h=1.0 / n, dofs=dofs,
                penetration=max_penetration(sol.contact), active=int(sol.contact.active.sum()), ok=sol.ok,
                checks_max=max(sol.residuals().values()), seconds=seconds), sol


def _no_columns(sol) -> dict:
    return {}


def measure_rates(kinds, levels, n_ref, say, check_reference=False, cases=CASES, reference=None, method="condensed",
             material=ALUMINIUM, extra=_no_columns):
    """Errors and rates of every (scene, degree, condition, level) against the scene's reference; with
    ``check_reference``, also the errors of the reference at n_ref / 2 against the one at n_ref.
    ``cases``: the (degree, condition) pairs solved; ``reference``: the reference's (degree, condition)
    (default P2 "gamma3"); ``method``, ``material``: the levels' and the reference's route and lower material;
    ``extra(sol)``: more columns of a level's row (and of the reference check's, for the reference)."""
    rows, rates, checks = [], [], []
    rdeg, rcond = reference or (2, "gamma3")
    tag = f"P{rdeg} {rcond}"
    for kind in kinds:
        clock = Timer()
        ref = Reference(kind, n_ref, rdeg, rcond, method, material)
        say(f"convergence {kind}: reference {tag} n = {n_ref} ({clock():.1f} s)")
        if check_reference:
            half = Reference(kind, n_ref // 2, rdeg, rcond, method, material)
            checks.append(dict(scene=kind, n_ref=n_ref, n_check=n_ref // 2, **ref.errors(half.sol),
                               checks_max=max(ref.sol.residuals().values()), ok=ref.sol.ok,
                               **{f"{k}_ref": v for k, v in extra(ref.sol).items()}))
            say(f"  reference check: {tag} n = {n_ref // 2} against n = {n_ref}: energy "
                f"{checks[-1]['energy']:.2e}")
            del half
        for degree, condition in cases:
            for n in levels[degree]:
                row, sol = level(kind, degree, condition, n, method, material)
                head = {k: row[k] for k in ("scene", "degree", "condition", "n1", "n2", "h", "dofs")}
                tail = {k: row[k] for k in ("penetration", "active", "ok", "checks_max", "seconds")}
                rows.append(dict(head, **ref.errors(sol), **tail, **extra(sol)))
            sub = [r for r in rows if r["scene"] == kind and r["condition"] == condition and r["degree"] == degree]
            keys = ("energy", "lam_l2", "lam_h12", "traction_l2")
            rate = {k: slope([r["h"] for r in sub], [r[k] for r in sub]) for k in keys}
            last = {k: slope([r["h"] for r in sub[-2:]], [r[k] for r in sub[-2:]]) for k in keys}
            theorem, bound = theorem_rates(condition, degree)
            rates.append(dict(scene=kind, degree=degree, condition=condition, theorem=theorem, theorem_rate=bound,
                              **{f"rate_{k}": v for k, v in rate.items()},
                              **{f"last_{k}": v for k, v in last.items()}))
            say(f"  P{degree} {condition}: energy rate {rate['energy']:.2f} (last pair {last['energy']:.2f}), "
                f"lambda H^-1/2_h rate {rate['lam_h12']:.2f}")
    return rows, rates, checks


def _write(out, stem, kinds, rows, rates, levels, n_ref, checks=()):
    """The CSV files, the figure and the Markdown summary of one group of scenes, named ``stem``.*."""
    write_csv(out / f"{stem}.csv", rows)
    write_csv(out / f"{stem}_rates.csv", rates)
    rates_figure(rows, rates, out / f"{stem}.png", kinds)
    f2 = {k: ".2f" for k in ("rate_energy", "last_energy", "rate_lam_l2", "rate_lam_h12", "last_lam_h12",
                             "rate_traction_l2")}
    title = "Convergence study" + (": smooth scene" if kinds == ["smooth"] else "")
    text = (f"# {title}\n\nErrors against a reference solved with P2 and the conic \"everywhere\" "
            f"condition on matching meshes (n = {n_ref} cells on Gamma_3); P1 levels n = "
            f"{', '.join(map(str, levels[1]))}, P2 levels n = {', '.join(map(str, levels[2]))}, lower mesh "
            "n2 = 3n/4 + 1 cells (non-matching). Rates are least-squares slopes over all levels; `last_*` is "
            "the slope between the two finest levels. Theorem rates for the energy error with eta at the "
            "degree's cap (P1: eta = 1/2; P2: eta -> 1): Th. 1 h^{1/2+eta}, Th. 2 h^{1/2+eta/2}, "
            "Th. 3 h^{1/2+eta}.\n\n")
    if kinds == ["smooth"]:
        text += ("Scene: the \"hertzian\" blocks and gap with roller (symmetry) lateral sides, so that the "
                 "solution is as smooth as a contact solution can be (H^{5/2-eps}, singular only at the two "
                 "transition points of the contact zone): see the docstring of "
                 "`cvxcontact.apps.studies.convergence.scene`.\n\n")
    if checks:
        text += ("## The reference's own error\n\nThe reference at half its n (P2 gamma3, matching) measured "
                 "against the reference, same norms (an upper estimate of the reference's own error: with a "
                 "rate p it is (2^p - 1) times that error, 1.8 times for p = 1.5):\n\n"
                 + markdown_table(list(checks), ["scene", "n_check", "n_ref", "energy", "lam_l2", "lam_h12",
                                                 "traction_l2", "checks_max"],
                                  {k: ".3e" for k in ("energy", "lam_l2", "lam_h12", "traction_l2")}
                                  | {"checks_max": ".1e"}) + "\n")
        pair = [dict(degree=r["degree"], condition=r["condition"], n1=r["n1"],
                     **{k: slope([p["h"], r["h"]], [p[k], r[k]]) for k in ("energy", "lam_h12", "traction_l2")})
                for p, r in zip(rows, rows[1:])
                if (p["scene"], p["degree"], p["condition"]) == (r["scene"], r["degree"], r["condition"])]
        text += ("## Rates level by level\n\nSlope between level n/2 and level n (energy, lambda in "
                 "H^{-1/2}_h, pressure on the upper body):\n\n"
                 + markdown_table(pair, ["degree", "condition", "n1", "energy", "lam_h12", "traction_l2"],
                                  {k: ".2f" for k in ("energy", "lam_h12", "traction_l2")}) + "\n")
    text += ("## Observed rates\n\n"
             + markdown_table(rates, ["scene", "degree", "condition", "theorem", "theorem_rate", "rate_energy",
                                      "last_energy", "rate_lam_l2", "rate_lam_h12", "last_lam_h12",
                                      "rate_traction_l2"], f2)
             + "\n## Errors\n\n"
             + markdown_table(rows, ["scene", "degree", "condition", "n1", "n2", "dofs", "energy", "lam_l2", "lam_h12",
                                     "traction_l2"] + (["penetration"] if checks else [])
                              + ["active", "checks_max", "seconds"],
                              {"energy": ".3e", "lam_l2": ".3e", "lam_h12": ".3e", "traction_l2": ".3e",
                               "penetration": ".2e", "checks_max": ".1e", "seconds": ".2f"}))
    write_text(out / f"{stem}.md", text)
    if checks:
        write_csv(out / f"{stem}_reference.csv", list(checks))


LINES = {1: "-", 2: "--"}
"""The figures' line style of each degree."""


def rates_figure(rows, rates, path, kinds=("hertzian", "partial")):
    plt = pyplot()
    fig, axes = plt.subplots(3, len(kinds), figsize=(6 * len(kinds), 12), layout="constrained", sharex=True,
                             squeeze=False)
    marks = dict(gamma3="o", sigma1="s", sigma2="^")
    for i, kind in enumerate(kinds):
        for j, (key, label) in enumerate((("energy", "relative energy error of (u, phi)"),
                                          ("lam_h12", r"$\lambda_h$ in the mesh-dependent $H^{-1/2}$ norm"),
                                          ("traction_l2", r"relative $L^2$ error, pressure on the upper body"))):
            ax = axes[j, i]
            for case in (r for r in rates if r["scene"] == kind):
                degree, condition = case["degree"], case["condition"]
                sub = [r for r in rows if r["scene"] == kind and r["condition"] == condition
                       and r["degree"] == degree]
                ax.loglog([r["h"] for r in sub], [r[key] for r in sub], marks[condition] + LINES[degree], ms=4,
                          label=f"P{degree} {condition} (slope {case[f'rate_{key}']:.2f})")
            if key == "energy":
                h = np.array(sorted({r["h"] for r in rows}))
                e0 = min(r[key] for r in rows if r["scene"] == kind and r["h"] == h[0])
                for p, style, text in ((1.5, "k-.", "h^1.5 (Th. 1, 3; P2, eta -> 1)"),
                                       (1.0, "k--", "h^1 (Th. 2 P2; Th. 1, 3 P1)"),
                                       (0.75, "k:", "h^0.75 (Th. 2, P1)")):
                    ax.loglog(h, e0 * (h / h[0]) ** p, style, lw=0.8, label=text)
            ax.set_title(f"{kind} contact: {label}", fontsize=10)
            ax.set_ylabel("relative error")
            ax.legend(fontsize=6, ncol=2)
            ax.xaxis.set_minor_formatter(plt.NullFormatter())
    for ax in axes[2]:
        ax.set_xlabel("h = 1/n (upper mesh's cell size on the contact line) [m]")
    save_figure(fig, path)
