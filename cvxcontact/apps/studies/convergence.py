"""Convergence study: errors against a much finer reference, for the three contact conditions.

For each scene and condition, five mesh levels with non-matching meshes on Gamma_3
(the lower body has about 3/4 of the upper body's cells, plus one) are solved and
compared with a reference solved on matching meshes 4 to 8 times finer (on matching
meshes the three conditions coincide, so one reference serves all). Errors:

* energy norm of (u, phi): ||e||_E^2 = e_u^T Kuu e_u + e_phi^T Kpp e_phi on the reference
  mesh (the symmetric part of the paper's a(., .)), e = I_ref(u_h, phi_h) - (u_ref, phi_ref),
  relative to the reference's norm; I_ref is P1 interpolation at the reference nodes;
* lambda in L2(Gamma_3), exact integration of the difference of the two piecewise linear
  functions on the union of their nodes, relative to ||lambda_ref||;
* lambda in the mesh-dependent H^{-1/2} norm ||mu||_{-1/2,h}^2 = sum_s h_s ||mu||_{L2(s)}^2 over the
  segments s of the coarse merged mesh (the norm of the paper's discrete analysis), relative
  to sqrt(|Gamma_3|) ||lambda_ref||_L2 (a fixed number, so that the rate is that of the norm);
* the pressure felt by the upper body (:meth:`Solution.traction`, nodal forces moved to its
  own trace nodes) in L2(Gamma_3), against the same quantity of the reference, relative:
  the non-oscillating view of the multiplier.

Observed rates are least-squares slopes in h. The theorems' rates for the energy error are
h^{1/2+eta} (Theorems 1 and 3) and h^{1/2+eta/2} (Theorem 2), 0 < eta <= 1/2 by regularity; the
figure draws the slopes for eta = 1/2 beside the data.

Scenes: "hertzian" (a parabolic gap, g = (x - 1/2)^2 / 2 - 0.05 m, closes on an interior zone,
about [0.27, 0.73]: smooth data, two transitions with the square-root behaviour of
Hertz contact, the setting of Theorem 3) and "partial" (the quickstart scene: the contact
zone reaches a corner of the bodies, loaded edges, corner singularities: less regular).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...physics import materials
from ...fem.assembly import assemble_matrices
from ...contact.interface import CONDITIONS
from ...geometry.mesh import rectangle
from ...physics.scene import Body, Scene
from ...solve import ContactSolver
from .common import Timer, markdown_table, pyplot, save_figure, slope, write_csv, write_text

THEOREM = {"gamma3": ("Th. 1", 1.0), "sigma1": ("Th. 2", 0.75), "sigma2": ("Th. 2", 0.75)}


def scene(kind, n1, n2):
    upper = rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n1, ny=max(2, n1 // 2))
    lower = rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=n2, ny=max(2, n2 // 2))
    alu = materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    if kind == "hertzian":
        b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom")
        b2 = Body(lower, alu, clamped=["bottom"], contact="top")
        return Scene(b1, b2, gap=lambda x: (x - 0.5) ** 2 / 2.0 - 0.05)
    if kind == "partial":
        b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom",
                  body_force=(0.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05})
        b2 = Body(lower, alu, clamped=["bottom"], contact="top")
    else:
        raise ValueError(f"unknown scene {kind!r}")
    return Scene(b1, b2)


def _transfer(sol_mesh_points, triangles, values, points):
    """P1 interpolation of nodal ``values`` (n, k) of a mesh at ``points`` (m, 2)."""
    import matplotlib.tri as mtri

    tri = mtri.Triangulation(sol_mesh_points[:, 0], sol_mesh_points[:, 1], triangles)
    finder = tri.get_trifinder()
    idx = finder(points[:, 0], points[:, 1])
    lost = idx < 0
    if lost.any():            # on the boundary, round-off: the nearest triangle by centroid
        cen = sol_mesh_points[triangles].mean(axis=1)
        idx[lost] = np.argmin(((points[lost, None, :] - cen[None]) ** 2).sum(-1), axis=1)
    p = sol_mesh_points[triangles[idx]]                                   # (m, 3, 2)
    T = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)          # (m, 2, 2)
    lam12 = np.linalg.solve(T, (points - p[:, 0])[..., None])[..., 0]
    bary = np.column_stack([1 - lam12.sum(1), lam12])
    return np.einsum("mi,mik->mk", bary, values[triangles[idx]])


def _p1_difference_l2(x1, f1, x2, f2, weight_mesh=None):
    """||f1 - f2||_L2 of two piecewise linear functions; with ``weight_mesh`` (nodes), the
    h-weighted version sum_s h_s ||f1 - f2||^2_{L2(s)} (square root taken)."""
    x = np.union1d(x1, x2)
    d = np.interp(x, x1, f1) - np.interp(x, x2, f2)
    h = np.diff(x)
    seg = h / 3 * (d[:-1] ** 2 + d[:-1] * d[1:] + d[1:] ** 2)            # exact for linear d
    if weight_mesh is not None:
        mid = 0.5 * (x[:-1] + x[1:])
        k = np.clip(np.searchsorted(weight_mesh, mid) - 1, 0, len(weight_mesh) - 2)
        seg = seg * np.diff(weight_mesh)[k]
    return float(np.sqrt(seg.sum()))


class Reference:
    """A fine solution and what is needed to measure errors against it."""

    def __init__(self, kind, n):
        self.scene = scene(kind, n, n)
        self.sol = ContactSolver(self.scene, "gamma3", method="condensed").solve()
        self.mats = [assemble_matrices(b) for b in self.scene.bodies]
        self.norm_E = np.sqrt(sum(self._energy(k, self.sol.u[k], self.sol.phi[k]) for k in range(2)))
        c = self.sol.contact
        self.norm_l2 = _p1_difference_l2(c.x, c.lam, c.x, 0 * c.lam)
        self.traction = self.sol.traction(0)
        self.norm_traction = _p1_difference_l2(*self.traction, c.x, 0 * c.x)

    def _energy(self, k, u, phi):
        m = self.mats[k]
        e = float(u.ravel() @ (m.Kuu @ u.ravel()))
        return e + (float(phi @ (m.Kpp @ phi)) if phi is not None else 0.0)

    def errors(self, sol):
        e2 = 0.0
        for k, (body, ref_body) in enumerate(zip(sol.scene.bodies, self.scene.bodies)):
            fields = sol.u[k] if sol.phi[k] is None else np.column_stack([sol.u[k], sol.phi[k]])
            at_ref = _transfer(body.mesh.points, body.mesh.triangles, fields, ref_body.mesh.points)
            du = at_ref[:, :2] - self.sol.u[k]
            dphi = at_ref[:, 2] - self.sol.phi[k] if sol.phi[k] is not None else None
            e2 += self._energy(k, du, dphi)
        c, r = sol.contact, self.sol.contact
        lam_l2 = _p1_difference_l2(c.x, c.lam, r.x, r.lam)
        lam_h = _p1_difference_l2(c.x, c.lam, r.x, r.lam, weight_mesh=c.x)
        x1, p1 = sol.traction(0)
        body = _p1_difference_l2(x1, p1, *self.traction) / self.norm_traction
        length = r.x[-1] - r.x[0]
        return dict(energy=np.sqrt(e2) / self.norm_E, lam_l2=lam_l2 / self.norm_l2,
                    lam_h12=lam_h / (np.sqrt(length) * self.norm_l2), traction_l2=body)


def run(out, quick=False, progress=None):
    say = progress or (lambda s: None)
    out = Path(out)
    levels, n_ref = ([4, 8, 16, 32], 128) if quick else ([8, 16, 32, 64, 128], 512)
    rows, rates = [], []
    for kind in ("hertzian", "partial"):
        clock = Timer()
        ref = Reference(kind, n_ref)
        say(f"convergence {kind}: reference n = {n_ref} ({clock():.1f} s)")
        for condition in CONDITIONS:
            for n in levels:
                n2 = 3 * n // 4 + 1
                clock = Timer()
                sol = ContactSolver(scene(kind, n, n2), condition, method="condensed").solve()
                err = ref.errors(sol)
                rows.append(dict(scene=kind, condition=condition, n1=n, n2=n2, h=1.0 / n, **err,
                                 active=int(sol.contact.active.sum()), ok=sol.ok, seconds=clock()))
            sub = [r for r in rows if r["scene"] == kind and r["condition"] == condition]
            rate = {k: slope([r["h"] for r in sub], [r[k] for r in sub])
                    for k in ("energy", "lam_l2", "lam_h12", "traction_l2")}
            rates.append(dict(scene=kind, condition=condition, theorem=THEOREM[condition][0],
                              theorem_rate=THEOREM[condition][1], **{f"rate_{k}": v for k, v in rate.items()}))
            say(f"  {condition}: energy rate {rate['energy']:.2f}, lambda L2 rate {rate['lam_l2']:.2f}")
    write_csv(out / "convergence.csv", rows)
    write_csv(out / "convergence_rates.csv", rates)
    _figure(rows, rates, levels, out)
    text = ("# Convergence study\n\nErrors against a reference on matching meshes "
            f"(n = {n_ref}); lower mesh n2 = 3n/4 + 1 cells (non-matching). Theorem rates for "
            "the energy error with eta = 1/2.\n\n## Observed rates\n\n"
            + markdown_table(rates, ["scene", "condition", "theorem", "theorem_rate", "rate_energy", "rate_lam_l2",
                                     "rate_lam_h12", "rate_traction_l2"],
                             {"theorem_rate": ".2f", "rate_energy": ".2f", "rate_lam_l2": ".2f", "rate_lam_h12": ".2f",
                              "rate_traction_l2": ".2f"})
            + "\n## Errors\n\n"
            + markdown_table(rows, ["scene", "condition", "n1", "n2", "energy", "lam_l2", "lam_h12", "traction_l2",
                                    "active"],
                             {"energy": ".3e", "lam_l2": ".3e", "lam_h12": ".3e", "traction_l2": ".3e"}))
    write_text(out / "convergence.md", text)
    return dict(rows=rows, rates=rates)


def _figure(rows, rates, levels, out):
    plt = pyplot()
    fig, axes = plt.subplots(3, 2, figsize=(11, 11), layout="constrained", sharex=True)
    marks = dict(gamma3="o-", sigma1="s-", sigma2="^-")
    for i, kind in enumerate(("hertzian", "partial")):
        for j, (key, label) in enumerate((("energy", "relative energy error of (u, phi)"),
                                          ("lam_l2", r"relative $L^2(\Gamma_3)$ error of $\lambda_h$ (merged mesh)"),
                                          ("traction_l2", r"relative $L^2$ error, pressure on the upper body"))):
            ax = axes[j, i]
            for condition in CONDITIONS:
                sub = [r for r in rows if r["scene"] == kind and r["condition"] == condition]
                rate = next(r for r in rates if r["scene"] == kind and r["condition"] == condition)[f"rate_{key}"]
                ax.loglog([r["h"] for r in sub], [r[key] for r in sub], marks[condition], ms=4,
                          label=f"{condition} (slope {rate:.2f})")
            if key == "energy":
                h = np.array([1.0 / n for n in levels])
                e0 = max(r[key] for r in rows if r["scene"] == kind)
                for p, style, text in ((1.0, "k--", "h^1 (Th. 1, 3; eta = 1/2)"), (0.75, "k:", "h^0.75 (Th. 2)")):
                    ax.loglog(h, e0 * (h / h[0]) ** p, style, lw=0.8, label=text)
            ax.set_title(f"{kind} contact: {label}", fontsize=10)
            ax.set_ylabel("relative error")
            ax.legend(fontsize=7)
            ax.xaxis.set_minor_formatter(plt.NullFormatter())
    for ax in axes[2]:
        ax.set_xlabel("h (upper mesh size on the contact line) [m]")
    save_figure(fig, out / "convergence.png")
