"""An independent dense reference for small two-body contact scenes (tests only).

Nothing here goes through the package's solver path (no model, no condensation, no
active-set finish, no Interface operators): only the per-body SI matrices and loads
of :func:`cvxcontact.fem.assembly.assemble` are used. The contact line, the merged mesh,
the jump rows and the constrained rows are rebuilt here from the meshes.

Per body, on the free dofs, the mixed system (26) reads

    Kuu u + Kup phi = f - J^T E^T y,        -Kup^T u + Kpp phi = q.

The Gauss rows give phi = Kpp^{-1} (q + Kup^T u); substituted in the momentum rows,

    K u = f_eff - R^T y,      K = Kuu + Kup Kpp^{-1} Kup^T,   f_eff = f - Kup Kpp^{-1} q,   R = E J.

So u = u0 - K^{-1} R^T y with u0 = K^{-1} f_eff, and the slack of the constraint
E [u_nu] <= E g is s = d - W y with W = sum_k R_k K_k^{-1} R_k^T (SPD: R has full row rank)
and d = sum_k R_k u0_k - E g. Signorini: the LCP  y >= 0, s <= 0, y.s = 0, i.e. the KKT
conditions of  min_{y >= 0} 1/2 y^T W y - d^T y. With W = L L^T,

    1/2 y^T W y - d^T y = 1/2 || L^T y - L^{-1} d ||^2 - 1/2 || L^{-1} d ||^2

(the cross term is y^T L L^{-1} d = y^T d), so y is the non-negative least-squares
solution of  min || L^T y - L^{-1} d ||, y >= 0  (scipy.optimize.nnls). Its passive set
is then re-solved exactly (W_AA y_A = d_A) and the signs re-checked.

Scaling: each body's K is divided by the largest entry of its Kuu (the Kpp block by its
largest entry, Kup by the geometric mean), the forces by the largest load, and W by
its largest entry, so that stiffness ratios of 1e9 lose no digits to the units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import nnls

from cvxcontact.fem.assembly import assemble

from reference_problems import hat


@dataclass
class TraceRef:
    nodes: np.ndarray      # node indices on the contact part, sorted by abscissa
    x: np.ndarray          # their abscissae (m)
    line: float            # ordinate of the contact line (m)
    normal: float          # y-component of the outward normal (+1 or -1)


def trace(body) -> TraceRef:
    mesh = body.mesh
    nodes = np.unique(mesh.boundary(body.contact))
    nodes = nodes[np.argsort(mesh.points[nodes, 0], kind="stable")]
    line = float(mesh.points[nodes, 1].mean())
    normal = -1.0 if mesh.points[:, 1].mean() > line else 1.0   # a body above the line has outward normal -y
    return TraceRef(nodes, mesh.points[nodes, 0].copy(), line, normal)


def merge(x1, x2, tol):
    """Union of two sorted abscissa lists, nodes closer than ``tol`` taken once."""
    allx = np.sort(np.concatenate([x1, x2]))
    keep = np.concatenate([[True], np.diff(allx) > tol])
    return allx[keep]


@dataclass
class RefSolution:
    x: np.ndarray              # merged abscissae (m)
    rows: np.ndarray           # constrained merged nodes
    u: list                    # (n_k, 2) SI displacements
    phi: list                  # (n_k,) potentials or None
    y: np.ndarray              # nodal forces on the constrained rows (N/m)
    force: np.ndarray          # E^T y on the merged nodes (N/m)
    active: np.ndarray         # rows with y > 0 (bool over rows)
    slack: np.ndarray          # E [u_nu] - E g (m)
    d0: np.ndarray             # unconstrained jump at every merged node (m)
    lcp: dict                  # relative LCP residuals of the reference itself


class Reference:
    """Dense reference for ``bodies`` (two cvxcontact Bodies) under ``condition``; assembled once,
    :meth:`solve` takes the gap at the merged nodes (m)."""

    def __init__(self, bodies, condition="gamma3"):
        self.bodies = bodies
        tr = [trace(b) for b in bodies]
        size = max(float(np.ptp(b.mesh.points, axis=0).max()) for b in bodies)
        tol = 1e-10 * size
        assert abs(tr[0].line - tr[1].line) <= tol and tr[0].normal == -tr[1].normal
        self.x = merge(tr[0].x, tr[1].x, tol)
        if condition == "gamma3":
            rows = np.arange(len(self.x))
        else:
            t = tr[int(condition[-1]) - 1]
            rows = np.flatnonzero([np.abs(t.x - xm).min() <= tol for xm in self.x])
        self.rows = rows
        self.parts = []
        for b, t in zip(bodies, tr):
            s = assemble(b)
            n = len(b.mesh.points)
            J = np.zeros((len(self.x), 2 * n))
            J[:, 2 * t.nodes + 1] = t.normal * hat(self.x, t.x)
            uf = s.u_free
            Kuu = s.Kuu[uf][:, uf].toarray()
            c = np.abs(Kuu).max()
            K = Kuu / c
            f_eff = s.f[uf].copy()
            piezo = s.Kpp is not None
            if piezo:
                pf = s.phi_free
                Kup = s.Kup[uf][:, pf].toarray()
                Kpp = s.Kpp[pf][:, pf].toarray()
                e = np.abs(Kpp).max()
                kup, kpp = Kup / np.sqrt(c * e), Kpp / e
                kpp_cho = sla.cho_factor(kpp)
                K = K + kup @ sla.cho_solve(kpp_cho, kup.T)
                f_eff = f_eff - Kup @ sla.cho_solve(kpp_cho, s.q[pf]) / e
            K = 0.5 * (K + K.T)
            cho = sla.cho_factor(K)
            R = J[rows][:, uf]
            self.parts.append(dict(s=s, n=n, J=J, uf=uf, c=c, cho=cho, R=R, f_eff=f_eff, piezo=piezo,
                                   B=sla.cho_solve(cho, R.T)))
        self.Fs = max(max(np.abs(p["f_eff"]).max(initial=0.0) for p in self.parts), np.finfo(float).tiny)
        self.cref = max(p["c"] for p in self.parts)
        for p in self.parts:   # u0 = K^{-1} f_eff, kept in units of Fs / cref (O(1) for the stiffest body)
            p["u0"] = sla.cho_solve(p["cho"], p["f_eff"] / self.Fs) * (self.cref / p["c"])
        self.Wt = sum(p["R"] @ p["B"] * (self.cref / p["c"]) for p in self.parts)   # = cref * W
        self.Wt = 0.5 * (self.Wt + self.Wt.T)
        # unconstrained jump at every merged node (m)
        self.d0 = sum(p["J"][:, p["uf"]] @ p["u0"] for p in self.parts) * self.Fs / self.cref

    def solve(self, gap) -> RefSolution:
        """The reference solution for the gap ``gap`` (m) at the merged nodes."""
        gap = np.asarray(gap, dtype=float)
        # scaled: Wt yh = dh with y = Fs yh, dh = cref d / Fs
        dh = sum(p["R"] @ p["u0"] for p in self.parts) - gap[self.rows] * self.cref / self.Fs
        w0 = np.abs(self.Wt).max()
        A, b = self.Wt / w0, dh / w0
        L = sla.cholesky(A, lower=True)
        yh, _ = nnls(L.T, sla.solve_triangular(L, b, lower=True), maxiter=50 * len(b))
        yh = self._refine(A, b, yh)
        s = b - A @ yh
        y = yh * self.Fs
        scale_b = max(np.abs(b).max(), np.abs(A @ yh).max(), np.finfo(float).tiny)
        ymax = max(np.abs(yh).max(), np.finfo(float).tiny)
        lcp = {"negative_y": float(max(-yh.min(initial=0.0), 0.0) / ymax),
               "penetration": float(max(s.max(initial=0.0), 0.0) / scale_b),
               "complementarity": float(np.abs(yh * s).max(initial=0.0) / (ymax * scale_b))}
        us, phis = [], []
        for p in self.parts:
            uf_vals = (p["u0"] - p["B"] @ yh * (self.cref / p["c"])) * self.Fs / self.cref
            u = np.zeros(2 * p["n"])
            u[p["uf"]] = uf_vals
            us.append(u.reshape(-1, 2))
            if p["piezo"]:
                st = p["s"]
                pf = st.phi_free
                Kup = st.Kup[p["uf"]][:, pf].toarray()
                Kpp = st.Kpp[pf][:, pf].toarray()
                e = np.abs(Kpp).max()
                phi = st.phi_fixed.copy()
                phi[pf] += np.linalg.solve(Kpp / e, (st.q[pf] + Kup.T @ uf_vals) / e)
                phis.append(phi)
            else:
                phis.append(None)
        force = np.zeros(len(self.x))
        force[self.rows] = y
        return RefSolution(x=self.x.copy(), rows=self.rows, u=us, phi=phis, y=y, force=force, active=yh > 0,
                           slack=s * w0 * self.Fs / self.cref, d0=self.d0.copy(), lcp=lcp)

    @staticmethod
    def _refine(A, b, yh):
        """Re-solve the NNLS passive set exactly; primal-dual active-set steps if the signs break."""
        act = yh > 0
        best = yh
        scale = max(np.abs(b).max(), np.finfo(float).tiny)
        for _ in range(20):
            y = np.zeros_like(b)
            if act.any():
                y[act] = np.linalg.solve(A[np.ix_(act, act)], b[act])
            s = b - A @ y
            ymax = max(np.abs(y).max(), np.finfo(float).tiny)
            if y.min(initial=0.0) >= -1e-13 * ymax and s[~act].max(initial=0.0) <= 1e-13 * scale:
                return y
            new = y / ymax + s / scale > 0
            if np.array_equal(new, act):
                break
            act = new
        return best


def mixed_residual(bodies, ref: RefSolution):
    """Relative residual of (26) for the reference (SI, per body, both row blocks), recomputed from
    the assembled matrices with the reference's own jump rows."""
    r = Reference.__new__(Reference)
    Reference.__init__(r, bodies)          # gamma3 rows: J over every merged node
    out = 0.0
    for p, u, phi in zip(r.parts, ref.u, ref.phi):
        st, uf = p["s"], p["uf"]
        uv = u.ravel()[uf]
        contact = p["J"][:, uf].T @ ref.force
        mom = st.Kuu[uf][:, uf] @ uv - st.f[uf] + contact
        scale = max(np.abs(st.f[uf]).max(), np.abs(st.Kuu[uf][:, uf] @ uv).max(), np.abs(contact).max())
        if phi is not None:
            pf = st.phi_free
            pv = phi[pf]
            mom = mom + st.Kup[uf][:, pf] @ pv
            gauss = -st.Kup[uf][:, pf].T @ uv + st.Kpp[pf][:, pf] @ pv - st.q[pf]
            gscale = max(np.abs(st.q[pf]).max(), np.abs(st.Kpp[pf][:, pf] @ pv).max())
            out = max(out, np.abs(gauss).max() / gscale)
        out = max(out, np.abs(mom).max() / scale)
    return out
