"""Stability where methods fail: the discrete inf-sup constant, oscillations of lambda_h, failure cases.

Inf-sup constant. For a multiplier space Lambda (X_h on the merged mesh, as in the paper's
Lemma 3, or the nodal multipliers of Sigma_h^l, represented in X_h by lambda = M^{-1} E^T y)

    beta_h = inf_{mu in Lambda} sup_{v in V_h} b(v, mu) / (||v||_V ||mu||_{-1/2}),   b(v, mu) = (mu, [v_nu])_Gamma3.

With ||v||_V the energy norm of the two bodies (elastic here: the property is one of the
spaces), sup_v b(v, mu) / ||v||_V = sqrt(z^T W_h z), z = M mu, where W_h is the interface
compliance of the discrete bodies at the merged nodes (the condensation of
:mod:`cvxcontact.backends.condensed`). For ||mu||_{-1/2} we take the dual norm of the same trace
energy, computed on a reference discretisation 8 times finer with matching meshes:
||mu||^2 = z_f^T W_f z_f, z_f = (mu, phi_i^f) the exact load vector of mu on the fine
merged mesh. This is an H^{-1/2}(Gamma_3)-equivalent norm of the continuous problem, so
beta_h <= 1 (up to the fine discretisation) and beta_h is the smallest generalized eigenvalue

    (Q^T W_h Q) a = beta^2 (Q^T N Q) a,   N = P^T W_f P,   Q = M R  (R = I or M^{-1} E^T).

Oscillation: the total variation of lambda_h on the merged mesh relative to that of the
reference (matching fine meshes), in the partial-contact scene.

Failure cases: each is solved and its status, iterations, checks and error against the
best available answer are recorded (numbers in the CSV and the summary).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq

from ...physics import materials
from ...backends.condensed import condense
from ...contact.interface import CONDITIONS
from ...geometry.mesh import Mesh, rectangle
from ...backends.condensed import Compliance
from ...contact.laws import Signorini
from ...discrete import build_problem
from ...fem.space import space
from ...physics.scene import Body, Scene
from ...solve import ContactSolver
from .common import graded_block, markdown_table, pyplot, save_figure, write_csv, write_text
from .convergence import scene as partial_scene

STEEL = materials.isotropic(E=200e9, nu=0.3, name="steel")
ALU = materials.isotropic(E=70e9, nu=0.33, name="aluminium")


def _lower_mesh(n2, shift=0.0, n1=None):
    """Lower block; with ``shift`` its interior columns sit ``shift`` (in cells of the upper mesh)
    to the right of the upper mesh's columns (nearly coincident nodes)."""
    m = rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=n2, ny=max(2, n2 // 2))
    if shift:
        p = m.points.copy()
        inner = (p[:, 0] > 1e-12) & (p[:, 0] < 1 - 1e-12)
        p[inner, 0] += shift / n1
        m = Mesh(p, m.triangles, {t: m.boundary(t) for t in m.tags})
    return m


def elastic_pair(n1, n2, shift=0.0):
    upper = rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n1, ny=max(2, n1 // 2))
    b1 = Body(upper, STEEL, clamped="top", contact="bottom", body_force=(0.0, -1e9))
    b2 = Body(_lower_mesh(n2, shift, n1), ALU, clamped="bottom", contact="top")
    return Scene(b1, b2)


def fine_pair(nf, rows=48):
    """Matching fine blocks, graded towards the contact line so that the first cells are about
    as tall as they are wide (the boundary layer of short-wavelength multipliers is resolved)."""
    target = 1.0 / nf / 0.5                                  # first-cell height / block height
    gamma = 0.0 if target >= 1.0 / rows else brentq(
        lambda g: (np.exp(g / rows) - 1) / (np.exp(g) - 1) - target, 1e-9, 80.0)
    upper = graded_block((0.0, 1.0), (0.0, 0.5), nf, rows, "bottom", gamma=gamma)
    lower = graded_block((0.0, 1.0), (-0.5, 0.0), nf, rows, "top", gamma=gamma)
    return Scene(Body(upper, STEEL, clamped="top", contact="bottom", body_force=(0.0, -1e9)),
                 Body(lower, ALU, clamped="bottom", contact="top"))


def compliance(scene, degree: int = 1):
    """W at the rows of "gamma3" (the merged nodes; P2: the nodes of X_h), in the scaled units of the scene's
    discrete problem (the length and stiffness units are those of the geometry and materials, equal for all
    scenes here, and the load unit cancels in W), and the problem."""
    problem = build_problem(scene, space(degree), "gamma3", Signorini())
    condensed = [condense(b, s, m) for b, s, m in zip(problem.blocks, problem.matrices, problem.meshes)]
    return Compliance(condensed, problem.E).W, problem


def _load_matrix(x_fine, x_coarse):
    """(n_fine, n_coarse) sparse: exact integrals (phi_j^coarse, phi_i^fine) of two 1D P1 bases."""
    import scipy.sparse as sp

    x = np.union1d(x_fine, x_coarse)
    a, b = x[:-1], x[1:]
    h, mid = b - a, 0.5 * (a + b)
    kc = np.clip(np.searchsorted(x_coarse, mid) - 1, 0, len(x_coarse) - 2)
    kf = np.clip(np.searchsorted(x_fine, mid) - 1, 0, len(x_fine) - 2)

    def hat(xs, k, t, right):                  # value at t of the left/right hat of segment k
        s = (t - xs[k]) / (xs[k + 1] - xs[k])
        return s if right else 1 - s

    rows, cols, vals = [], [], []
    for ic in (0, 1):
        fa, fb = hat(x_coarse, kc, a, ic), hat(x_coarse, kc, b, ic)
        for jf in (0, 1):
            ga, gb = hat(x_fine, kf, a, jf), hat(x_fine, kf, b, jf)
            rows.append(kf + jf)
            cols.append(kc + ic)
            vals.append(h / 6 * (2 * fa * ga + fa * gb + fb * ga + 2 * fb * gb))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(x_fine), len(x_coarse)))


_FINE = {}


def _fine(nf):
    """The fine matching pair's interface and compliance (cached: P1 and P2 studies share them)."""
    if nf not in _FINE:
        fine = fine_pair(nf)
        _FINE.clear()
        _FINE[nf] = (fine.interface, compliance(fine)[0])
    return _FINE[nf]


def compliance_p2(scene):
    """W at the P2 nodes of X_h on the merged mesh (docs/formulation.md §8), and the P2 interface."""
    W, problem = compliance(scene, degree=2)
    return W, problem.interface


def _load_matrix_p2(x_fine, x2):
    """(n_fine, n_X) sparse: exact integrals (phi_j, phi_i^fine) of the P2 basis of X_h (nodes ``x2``,
    vertices and midpoints interleaved) against the fine P1 hats (3-point Gauss on the union of the
    breakpoints: exact for the cubic products)."""
    import scipy.sparse as sp

    xv = x2[::2]
    x = np.union1d(x_fine, xv)
    h = np.diff(x)
    g = 0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    w = np.array([5.0, 8.0, 5.0]) / 18.0
    t = (x[:-1, None] + h[:, None] * g[None]).ravel()
    wt = (h[:, None] * w[None]).ravel()
    kc = np.clip(np.searchsorted(xv, t) - 1, 0, len(xv) - 2)
    s = (t - xv[kc]) / (xv[kc + 1] - xv[kc])
    coarse = ((2 * kc, (1 - s) * (1 - 2 * s)), (2 * kc + 1, 4 * s * (1 - s)), (2 * kc + 2, s * (2 * s - 1)))
    kf = np.clip(np.searchsorted(x_fine, t) - 1, 0, len(x_fine) - 2)
    sf = (t - x_fine[kf]) / (x_fine[kf + 1] - x_fine[kf])
    rows, cols, vals = [], [], []
    for jc, vc in coarse:
        for jf, vf in ((kf, 1 - sf), (kf + 1, sf)):
            rows.append(jf)
            cols.append(jc)
            vals.append(wt * vc * vf)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(x_fine), len(x2)))


def inf_sup(n1, n2, shift=0.0, fine_factor=8, degree=1):
    """beta_h for the three multiplier choices on the pair (n1, n2); ``degree`` 2: P2 bodies and the P2
    multiplier spaces (X_h continuous piecewise quadratic on the merged mesh; nodal ones at the P2
    nodes of Sigma_h^l), against the same fine P1 H^{-1/2} norm."""
    coarse = elastic_pair(n1, n2, shift)
    fitf, Wf = _fine(fine_factor * max(n1, n2))
    if degree == 1:
        W, itf = compliance(coarse)[0], coarse.interface
        P = _load_matrix(fitf.x, itf.x)
    else:
        W, itf = compliance_p2(coarse)
        P = _load_matrix_p2(fitf.x, itf.x)
    N = (P.T @ (P.T @ Wf.T).T)
    N = 0.5 * (N + N.T)
    M = itf.mass.toarray()
    out = {}
    for condition in CONDITIONS:
        E = itf.evaluation(condition).toarray()
        Q = M if condition == "gamma3" else E.T                 # z = M mu, mu = R a
        R = np.eye(itf.size) if condition == "gamma3" else np.linalg.solve(M, E.T)
        A, B = Q.T @ W @ Q, R.T @ N @ R
        out[condition] = float(np.sqrt(max(sla.eigh(A, B, eigvals_only=True)[0], 0.0)))
    return out


def _tv(lam):
    return float(np.abs(np.diff(lam)).sum())


def run(out, quick=False, progress=None):
    say = progress or (lambda s: None)
    out = Path(out)
    rows = []
    levels = [8, 16] if quick else [8, 16, 32]
    ratios = [1, 2, 5, 10] if quick else [1, 2, 3, 5, 10, 20]     # quick: fine pairs up to 8 x 81 cells
    for n1 in levels:
        for r in ratios:
            if n1 * r > (80 if quick else 320):
                continue
            beta = inf_sup(n1, n1 * r + (1 if r > 1 else 0))
            rows.append(dict(study="inf-sup", n1=n1, n2=n1 * r + (1 if r > 1 else 0), shift=0.0, **beta))
            say(f"inf-sup n1={n1} ratio 1:{r}: " + ", ".join(f"{k} {v:.3f}" for k, v in beta.items()))
    for shift in ([1e-1, 1e-3, 1e-6] if quick else [0.5, 1e-1, 1e-2, 1e-3, 1e-4, 1e-6]):
        n1 = 16
        beta = inf_sup(n1, n1, shift)
        rows.append(dict(study="inf-sup, nearly coincident nodes", n1=n1, n2=n1, shift=shift, **beta))
        say(f"inf-sup coincident shift {shift:g} h: " + ", ".join(f"{k} {v:.3f}" for k, v in beta.items()))
    for n1, n2 in ([(8, 8), (8, 17)] if quick else [(8, 8), (8, 17), (8, 41), (16, 16), (16, 33), (32, 65)]):
        beta = inf_sup(n1, n2, degree=2)
        rows.append(dict(study="inf-sup P2", n1=n1, n2=n2, shift=0.0, **beta))
        say(f"inf-sup P2 n1={n1} n2={n2}: " + ", ".join(f"{k} {v:.3f}" for k, v in beta.items()))
    osc = _oscillation(quick, say)
    cases = _failure_cases(quick, say)
    write_csv(out / "stability_infsup.csv", rows)
    write_csv(out / "stability_oscillation.csv", osc)
    write_csv(out / "stability_failures.csv", cases)
    _figure(rows, osc, out)
    text = ("# Stability\n\n## Discrete inf-sup constant beta_h\n\nElastic pair (steel on aluminium), "
            "H^{-1/2} norm from a matching reference 8 times finer (see `cvxcontact/apps/studies/stability.py`). "
            "Rows \"inf-sup P2\": P2 bodies and P2 multipliers (X_h continuous piecewise quadratic on the merged "
            "mesh for gamma3; represented nodal ones at the P2 nodes of Sigma_h^l), same fine P1 norm.\n\n"
            + markdown_table(rows, ["study", "n1", "n2", "shift", "gamma3", "sigma1", "sigma2"],
                             {"shift": "g", "gamma3": ".4f", "sigma1": ".4f", "sigma2": ".4f"})
            + "\n## Oscillation of lambda_h (partial-contact scene)\n\nTV(lambda_h) / TV(lambda_ref).\n\n"
            + markdown_table(osc, ["n1", "n2", "gamma3", "sigma1", "sigma2"],
                             {"gamma3": ".2f", "sigma1": ".2f", "sigma2": ".2f"})
            + "\n## Failure cases\n\n"
            + markdown_table(cases, ["case", "condition", "status", "path", "iterations", "polished", "equilibrium",
                                     "complementarity", "error_u", "note"],
                             {"equilibrium": ".1e", "complementarity": ".1e", "error_u": ".1e"}))
    write_text(out / "stability.md", text)
    return dict(inf_sup=rows, oscillation=osc, failures=cases)


def _oscillation(quick, say):
    n_ref = 128 if quick else 256
    ref = ContactSolver(partial_scene("partial", n_ref, n_ref), "gamma3", method="condensed").solve()
    tv_ref = _tv(ref.contact.lam)
    rows = []
    for n1, n2 in ([(16, 13), (16, 40), (16, 80)] if quick else [(32, 25), (32, 33), (32, 65), (32, 161), (32, 321)]):
        sc = partial_scene("partial", n1, n2)
        row = dict(n1=n1, n2=n2)
        for condition in CONDITIONS:
            sol = ContactSolver(sc, condition, method="condensed").solve()
            row[condition] = _tv(sol.contact.lam) / tv_ref
        rows.append(row)
        say(f"oscillation {n1}:{n2}: " + ", ".join(f"{c} {row[c]:.2f}" for c in CONDITIONS))
    return rows


def _failure_cases(quick, say):
    import warnings

    from ...errors import CvxContactError, ResidualWarning

    n = 16 if quick else 48
    base = partial_scene("partial", n, 3 * n // 4 + 1)
    upper, lower = base.bodies
    strong = materials.Piezoelectric.from_matrices(materials.PZT5H.c, 2.5 * materials.PZT5H.e, materials.PZT5H.kappa,
                                                   name="PZT-5H with 2.5 e")

    def with_upper(gap=0.0, **kw):
        args = dict(clamped=upper.clamped, grounded=upper.grounded, contact=upper.contact,
                    body_force=(0.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05})
        args.update(kw)
        return Scene(Body(upper.mesh, args.pop("material", upper.material), **args), lower, gap=gap)

    # grazing: the gap equals the free (unconstrained) jump at one point and exceeds it elsewhere,
    # so the bodies touch there with zero force (strict complementarity fails)
    free = ContactSolver(with_upper(gap=1.0), "gamma3", method="condensed").solve().contact
    x_star = free.x[np.argmax(free.jump)]
    grazing = with_upper(gap=lambda x: np.interp(x, free.x, free.jump) + 1e-4 * (x - x_star) ** 2)

    cases = [
        ("reference (scaled, full model)", base, dict(method="full")),
        ("unscaled SI data, full model", base, dict(method="full", scale=False)),
        ("unscaled SI data, condensed", base, dict(method="condensed", scale=False)),
        ("unscaled SI data, loads x 1e-6", with_upper(body_force=(0.0, -2e3), traction={"right": (0.0, 3e2)},
                                                      surface_charge={"left": -0.05e-6}),
         dict(method="full", scale=False)),
        ("scaled, loads x 1e-6", with_upper(body_force=(0.0, -2e3), traction={"right": (0.0, 3e2)},
                                            surface_charge={"left": -0.05e-6}), dict(method="full")),
        ("strong coupling (e x 2.5, PZT-5H)", with_upper(material=strong, body_force=(0.0, -2e9),
                                                         surface_charge={"left": -0.2}), dict(method="full")),
        ("loss of contact (load reversed)", with_upper(body_force=(0.0, 2e9)), dict(method="full")),
        ("grazing contact (touches at one point, zero force)", grazing, dict(method="full")),
        ("extreme mesh ratio 1:20", partial_scene("partial", 8, 161), dict(method="full")),
        ("nearly coincident nodes (1e-6 h)", Scene(upper, Body(_lower_mesh(n, 1e-6, n), lower.material,
                                                                clamped=lower.clamped, contact="top")),
         dict(method="full")),
    ]
    rows = []
    for name, scene, kw in cases:
        for condition in (("gamma3", "sigma1", "sigma2") if "mesh" in name or "coincident" in name else ("gamma3",)):
            row = dict(case=name, condition=condition)
            try:
                exact = ContactSolver(scene, condition, method="condensed").solve()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ResidualWarning)
                    raw = ContactSolver(scene, condition, polish=False, **kw).solve()
                    sol = ContactSolver(scene, condition, **kw).solve()
                stats = raw.problem.solver_stats
                res = sol.residuals()
                scale = max(np.abs(u).max() for u in exact.u) or 1.0
                row.update(status=sol.status, path=sol.path, iterations=stats.num_iters, polished=sol.polished,
                           equilibrium=res["equilibrium"], complementarity=res["complementarity"],
                           error_u=max(np.abs(a - b).max() for a, b in zip(raw.u, exact.u)) / scale,
                           note=f"raw interior-point u vs exact; {int(sol.contact.active.sum())} active")
            except CvxContactError as exc:
                row.update(status="error", note=" ".join(str(exc).split())[:160])
            rows.append(row)
            say(f"failure case {name} ({condition}): {row.get('status')}, raw error {row.get('error_u', float('nan')):.1e}")
    return rows


def _figure(rows, osc, out):
    plt = pyplot()
    fig, (ax, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")
    marks = dict(gamma3="o-", sigma1="s-", sigma2="^-")
    ratio_rows = [r for r in rows if r["study"] == "inf-sup"]
    for n1 in sorted({r["n1"] for r in ratio_rows}):
        sub = [r for r in ratio_rows if r["n1"] == n1]
        for c in CONDITIONS:
            ax.semilogy([r["n2"] / r["n1"] for r in sub], [r[c] for r in sub], marks[c], ms=3,
                        label=f"{c}, n1={n1}", alpha=0.5 + 0.5 * (n1 == max(x["n1"] for x in ratio_rows)))
    p2_rows = [r for r in rows if r["study"] == "inf-sup P2"]
    for n1 in sorted({r["n1"] for r in p2_rows}):
        sub = [r for r in p2_rows if r["n1"] == n1]
        for c in CONDITIONS:
            ax.semilogy([r["n2"] / r["n1"] for r in sub], [r[c] for r in sub], marks[c][0] + "--", ms=4,
                        mfc="none", label=f"P2 {c}, n1={n1}")
    ax.set_xlabel("mesh ratio n2 / n1 (cells on the contact line)")
    ax.set_ylabel(r"inf-sup constant $\beta_h$")
    ax.set_title("Inf-sup constant against mesh ratio (dashed, open: P2)")
    ax.legend(fontsize=6, ncol=2)
    shift_rows = [r for r in rows if r["study"] == "inf-sup, nearly coincident nodes"]
    for c in CONDITIONS:
        ax2.loglog([r["shift"] for r in shift_rows], [max(r[c], 1e-12) for r in shift_rows], marks[c], label=c)
    ax2.set_xlabel("offset of the lower nodes [cells]")
    ax2.set_ylabel(r"$\beta_h$")
    ax2.set_title("Nearly coincident nodes (n1 = n2 = 16)")
    ax2.legend(fontsize=8)
    for c in CONDITIONS:
        ax3.semilogy([r["n2"] / r["n1"] for r in osc], [r[c] for r in osc], marks[c], label=c)
    ax3.axhline(1, color="0.6", lw=0.6)
    ax3.set_xlabel("mesh ratio n2 / n1")
    ax3.set_ylabel(r"TV($\lambda_h$) / TV($\lambda_{ref}$)")
    ax3.set_title(r"Oscillation of $\lambda_h$ (partial contact)")
    ax3.legend(fontsize=8)
    save_figure(fig, out / "stability.png")
