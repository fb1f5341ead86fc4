"""The conic ("everywhere") contact condition of P2 elements, for the full and the condensed model.

docs/formulation.md §8. On merged segment s, with b_s = (b0, b1, b2) the Bernstein coefficients of
q = [u_h nu] - g_h (``B`` (3 S, n) maps nodal values of X_h to them) and p = -b:

    q <= 0 on the segment   <=>   exists w_s:  ||(2 w_s, p0 - p2)|| <= p0 + p2,   p1 + w_s >= 0.

Read-back: with z_s = (z0, z1, z2) the dual of the cone and mu_s >= 0 that of the linear row,
stationarity in w_s gives mu_s = -2 z1 and the contact force on the nodes of X_h is

    r = B^T beta,   beta_s = (z0 + z2, mu_s, z0 - z2)   (so M lambda_h = r),

beta_s lying in the dual cone beta0, beta2 >= 0, beta1 >= 0, beta1^2 <= 4 beta0 beta2; the
complementarity of the segment is beta_s . b_s = 0. The full model with this condition is
:class:`cvxcontact.backends.full.ContactModel` with ``bernstein=B``; :class:`ConicInterfaceModel` is the
condensed one (the package's own problem: quadratic energy, no user terms).

On the triangles of a 3D contact surface (6 Bernstein coefficients each, :mod:`cvxcontact.contact.bernstein`,
docs/formulation.md §16) the condition is "-Q copositive": -Q = P + N with P a 3 x 3 positive semidefinite
variable and N >= 0 its three off-diagonal entries, one equality per coefficient; the duals of those equalities
are the Bernstein duals beta directly (Z = (beta_ii; beta_ij / 2) positive semidefinite and, by stationarity in
N, entrywise non-negative).
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

__all__ = ["bernstein_constraints", "copositive_constraints", "bernstein_duals", "least_held_duals", "ConicInterfaceModel"]


def bernstein_constraints(jump, B, g, width: int = 3):
    """(cone, row, w): the constraints of the module docstring for the CVXPY expression ``jump`` (the
    nodal values of [u_nu] in X_h, scaled), ``B`` (width S, n) and the gap ``g`` at the nodes (scaled);
    ``width`` 3 (segments: a second-order cone each) or 6 (triangles: :func:`copositive_constraints`)."""
    b = B @ jump - B @ g
    if width == 6:
        return copositive_constraints(b, B.shape[0] // 6)
    S = B.shape[0] // 3
    p0, p1, p2 = -b[0::3], -b[1::3], -b[2::3]
    w = cp.Variable(S, name="w")
    cone = cp.SOC(p0 + p2, cp.vstack([2 * w, p0 - p2]), axis=0)
    row = p1 + w >= 0
    return cone, row, w


def copositive_constraints(b, T: int):
    """(equality, row, P): -Q_t = P_t + N_t on each of the ``T`` triangles of the Bernstein coefficients ``b``
    (a CVXPY expression of length 6 T, order (b00, b11, b22, b01, b12, b20) per triangle), P_t a 3 x 3
    positive semidefinite variable, N_t its three off-diagonal non-negative entries (``row``: N >= 0). One
    vectorised equality: its duals are the Bernstein duals (:func:`bernstein_duals`)."""
    P = [cp.Variable((3, 3), PSD=True) for _ in range(T)]
    V = cp.hstack([cp.vec(p, order="F") for p in P]) if T else cp.Constant(np.zeros(0))
    entry = np.array([0, 4, 8, 3, 7, 2])           # (00, 11, 22, 01, 12, 20) in a column-major 3 x 3
    rows = np.arange(6 * T)
    select = sp.csr_matrix((np.ones(6 * T), (rows, (9 * np.arange(T)[:, None] + entry).ravel())), shape=(6 * T, 9 * T))
    off = (6 * np.arange(T)[:, None] + np.arange(3, 6)).ravel()
    lift = sp.csr_matrix((np.ones(3 * T), (off, np.arange(3 * T))), shape=(6 * T, 3 * T))
    N = cp.Variable(3 * T, name="N")
    equality = select @ V + lift @ N + b == 0
    return equality, N >= 0, P


def bernstein_duals(cone, row, width: int = 3) -> np.ndarray:
    """beta (S, width) from the duals of :func:`bernstein_constraints` (module docstring)."""
    if width == 6:
        return np.asarray(cone.dual_value, dtype=float).reshape(-1, 6)
    z0 = np.asarray(cone.dual_value[0], dtype=float).ravel()
    Z = np.asarray(cone.dual_value[1], dtype=float).reshape(2, -1)
    mu = np.asarray(row.dual_value, dtype=float).ravel()
    return np.column_stack([z0 + Z[1], mu, z0 - Z[1]])


def least_held_duals(beta, held) -> np.ndarray:
    """beta (S, 3) with the entries of the ``held`` Bernstein rows (S, 3 bool: rows no unknown moves, value 0)
    lowered to the least the dual cone beta0, beta2 >= 0, beta1 >= 0, beta1^2 <= 4 beta0 beta2 allows, the
    other entries fixed: such an entry multiplies a constant 0, so (26)-(27) do not determine it. Row 0 (or 2)
    alone: beta0 = beta1^2 / (4 beta2); rows 0 and 2: beta0 = beta2 = beta1 / 2 if both are at least that,
    else the smaller one kept and the other beta1^2 / (4 smaller); row 1 held means every node
    of the segment is (b1 involves all three): beta_s = 0. An entry is never raised."""
    beta = np.array(beta, dtype=float)
    held = np.asarray(held, dtype=bool)
    b0, b1, b2 = beta[:, 0].copy(), beta[:, 1], beta[:, 2].copy()
    tiny = np.finfo(float).tiny
    with np.errstate(divide="ignore", invalid="ignore"):
        low0 = np.where(b1 > 0, b1 ** 2 / (4 * np.maximum(b2, tiny)), 0.0)
        low2 = np.where(b1 > 0, b1 ** 2 / (4 * np.maximum(b0, tiny)), 0.0)
    only0, only2, both = held[:, 0] & ~held[:, 2], held[:, 2] & ~held[:, 0], held[:, 0] & held[:, 2]
    b0 = np.where(only0, np.minimum(b0, low0), b0)
    b2 = np.where(only2, np.minimum(b2, low2), b2)
    # both ends held: the least pair on beta0 beta2 >= beta1^2 / 4 below the given one: (beta1/2, beta1/2) if
    # both are at least beta1/2; else the smaller one s kept and the other lowered to beta1^2 / (4 s)
    half = np.maximum(b1, 0.0) / 2
    s0, s2 = beta[:, 0], beta[:, 2]
    small = np.minimum(s0, s2)
    with np.errstate(divide="ignore", invalid="ignore"):
        other = np.where(b1 > 0, b1 ** 2 / (4 * np.maximum(small, tiny)), 0.0)
    sym = small >= half
    b0 = np.where(both, np.where(sym, half, np.where(s0 <= s2, s0, np.minimum(s0, other))), b0)
    b2 = np.where(both, np.where(sym, half, np.where(s2 < s0, s2, np.minimum(s2, other))), b2)
    out = np.column_stack([b0, b1, b2])
    out[held[:, 1]] = 0.0
    return out


class ConicInterfaceModel:
    """The condensed interface problem (:class:`cvxcontact.backends.condensed.InterfaceModel`) with the
    conic condition: a small SOCP in the Gamma dofs v_l. Attributes: ``problem``, ``v``, ``cone``, ``row``."""

    def __init__(self, bodies, loads, B, g, width: int = 3):
        self.v = [cp.Variable(len(b.gamma), name=f"v{k + 1}") for k, b in enumerate(bodies)]
        # a body whose contact dofs its supports all hold (a roller on the pair's part) has none: no term
        energy = sum(0.5 * cp.quad_form(v, cp.psd_wrap(b.stiffness)) - f @ v
                     for b, v, f in zip(bodies, self.v, loads) if len(b.gamma))
        jump = sum(b.jump @ v for b, v in zip(bodies, self.v))
        self.cone, self.row, _ = bernstein_constraints(jump, B, g, width)
        self.problem = cp.Problem(cp.Minimize(energy), [self.cone, self.row])
