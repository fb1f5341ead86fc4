"""The full model: the phi-form convex program of every body in CVXPY (docs/formulation.md §2).

    minimise   sum_bodies 1/2 u^T Kuu u + 1/2 phi^T Kpp phi - f^T u
    subject to Kpp phi - Kup^T u = q              (Gauss law (20), one per piezoelectric body)
               E [u_nu] <= E g                     (K_h(Gamma_3) or K_h(Sigma_h^l))

(no -q^T phi term: the constraint fixes phi). An elastic body has no phi and no
Gauss constraint. The reference backend: it accepts every problem the package poses,
and :func:`mixed_kkt` solves its mixed system (26) on a given active set (the exact finish).
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .condensed import quasi_definite

__all__ = ["ContactModel", "mixed_kkt"]


class ContactModel:
    """The CVXPY problem for given scaled blocks and constraint rows ``E``.

    Attributes: ``problem``, ``u`` and ``phi`` (variables per body, ``phi[k]`` None
    for an elastic body), ``gauss`` (equality constraints per body, or None) and
    ``contact`` (the inequality constraint E [u_nu] <= E g).
    """

    def __init__(self, blocks, E, gap_rows):
        self.blocks = blocks
        self.u = [cp.Variable(b.Kuu.shape[0], name=f"u{k + 1}") for k, b in enumerate(blocks)]
        self.phi = [cp.Variable(b.Kpp.shape[0], name=f"phi{k + 1}") if b.Kpp is not None else None
                    for k, b in enumerate(blocks)]
        energy, self.gauss = 0, []
        for b, u, phi in zip(blocks, self.u, self.phi):
            energy += 0.5 * cp.quad_form(u, cp.psd_wrap(b.Kuu)) - b.f @ u
            if phi is None:
                self.gauss.append(None)
                continue
            energy += 0.5 * cp.quad_form(phi, cp.psd_wrap(b.Kpp))
            self.gauss.append(b.Kpp @ phi - b.Kup.T @ u == b.q)
        jump = sum((E @ b.jump) @ u for b, u in zip(blocks, self.u))
        self.contact = jump <= gap_rows
        self.problem = cp.Problem(cp.Minimize(energy), [c for c in self.gauss if c is not None] + [self.contact])


def mixed_kkt(blocks, E, g):
    """``kkt(active)`` for the exact finish of the full model: the sparse mixed system (26)

    [[A, G^T], [G, 0]] [x; y_A] = [F; g_A] with, per body, A = [[Kuu, Kup], [Kup^T, -Kpp]],
    F = [f; -q] (Gauss rows negated, which makes it symmetric) and G the active rows of E [u_nu].
    """
    parts = [quasi_definite(b) for b in blocks]
    A = sp.block_diag([S for S, _ in parts])
    rhs = np.concatenate([F for _, F in parts])
    sizes = [(b.Kuu.shape[0], S.shape[0] - b.Kuu.shape[0]) for b, (S, _) in zip(blocks, parts)]
    rows = [sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], n_phi))]) for b, (_, n_phi) in zip(blocks, sizes)]
    G_all = sp.hstack(rows).tocsr()

    def kkt(active):
        G = G_all[active]
        K = sp.bmat([[A, G.T], [G, None]], format="csc")
        b = np.concatenate([rhs, g[active]])
        try:
            lu = spla.splu(K, permc_spec="MMD_AT_PLUS_A")
        except RuntimeError:  # singular: the active set does not determine the multipliers
            return None
        z = lu.solve(b)
        for _ in range(2):    # iterative refinement: bodies of very different stiffness share one LU
            z += lu.solve(b - K @ z)
        n = A.shape[0]
        y = np.zeros(E.shape[0])
        y[active] = z[n:]
        u, phi, pos = [], [], 0
        for nu, npf in sizes:
            u.append(z[pos:pos + nu])
            phi.append(z[pos + nu:pos + nu + npf] if npf else None)
            pos += nu + npf
        slack = G_all @ z[:n] - g
        return (u, phi, y), y, slack, max(np.abs(uk).max(initial=0.0) for uk in u)

    return kkt
