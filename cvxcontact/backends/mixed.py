"""The sparse mixed system (26) as an operator on the stacked unknowns x = [u_1; phi_1; ...; tau_1; ...]
(scaled; docs/formulation.md §2, §12): what the Newton finishes of :func:`~cvxcontact.backends.finish.
solve_sparse_compliance` linearise, for a linear material (the quadratic energy 1/2 u^T Kuu u) and for a
non-quadratic bulk energy (:mod:`cvxcontact.discrete.energy`, e.g. Hencky) alike.

Per body the momentum and the (negated, symmetric) Gauss rows of (26) without the contact forces are

    r_u = grad Pi(u) + Kup phi - f,      r_phi = Kup^T u - Kpp phi + q,

and r_tau = -F for the translations of force-controlled obstacles (no stiffness, load F). They are the
gradient of the saddle energy

    L(x) = sum_bodies Pi(u) - f^T u + u^T Kup phi - 1/2 phi^T Kpp phi + q^T phi  -  sum_obstacles F^T tau,

which equals the phi-form energy of the convex program wherever the Gauss rows hold (Kpp phi = Kup^T u + q:
then u^T Kup phi + q^T phi = phi^T Kpp phi), so that it is the merit of a Newton step that keeps them. Its
tangent, [[Hess Pi(u), Kup], [Kup^T, -Kpp]] per body and a zero block for tau, has the sparsity of the linear
system's matrix.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from ..discrete.energy import Quadratic
from .condensed import quasi_definite

__all__ = ["HeldEnergy", "LawEnergy", "MixedEnergy", "SlidingEnergy", "law_linearised", "law_tangent", "mixed_system",
           "stacked", "tangent_blocks", "unstacked"]


class MixedEnergy:
    """The operator of the module docstring for scaled ``blocks`` and ``translations`` ((R, F) per
    force-controlled obstacle, as in :class:`~cvxcontact.backends.full.ContactModel`).

    ``value(x)`` L(x), ``gradient(x)`` [r_u; r_phi; ...; -F] (the residual of (26) without the contact forces),
    ``tangent(x)`` its derivative (sparse, symmetric), ``magnitude(x)`` the sizes of the terms each row of the
    gradient balances (for the relative residuals), ``rounding(x)`` the sizes of the terms whose rounding the
    computed gradient of the bodies' energies carries (:meth:`BulkEnergy.rounding`; the rest of each row is the
    tangent's own, :func:`~cvxcontact.backends.finish.normal_compliance.rounding_floor`); ``linear``: every
    body's energy is quadratic (then the tangent is one constant matrix)."""

    def __init__(self, blocks, translations=()):
        self.blocks = list(blocks)
        self.forces = [np.asarray(F, dtype=float) for _, F in translations or ()]
        self.sizes = [(b.Kuu.shape[0], 0 if b.Kpp is None else b.Kpp.shape[0]) for b in self.blocks]
        self.width = sum(len(F) for F in self.forces)
        self.linear = all(b.bulk.quadratic for b in self.blocks)
        self._tangent = self._assemble(None) if self.linear else None

    def _split(self, x):
        pos = 0
        for b, (nu, npf) in zip(self.blocks, self.sizes):
            yield b, x[pos:pos + nu], (x[pos + nu:pos + nu + npf] if npf else None)
            pos += nu + npf

    def _taus(self, x):
        return x[len(x) - self.width:]

    def value(self, x) -> float:
        e = sum(float(b.bulk.value(u) - b.f @ u) + (0.0 if p is None else float(
            u @ (b.Kup @ p) - 0.5 * p @ (b.Kpp @ p) + b.q @ p)) for b, u, p in self._split(x))
        return e - float(np.concatenate(self.forces or [np.zeros(0)]) @ self._taus(x))

    def gradient(self, x) -> np.ndarray:
        parts = []
        for b, u, p in self._split(x):
            ru = b.bulk.gradient(u) - b.f
            if p is None:
                parts.append(ru)
            else:
                parts += [ru + b.Kup @ p, b.Kup.T @ u - b.Kpp @ p + b.q]
        return np.concatenate(parts + [-F for F in self.forces])

    def magnitude(self, x) -> np.ndarray:
        parts = []
        for b, u, p in self._split(x):
            mu = b.bulk.magnitude(u) + np.abs(b.f)
            if p is None:
                parts.append(mu)
            else:
                parts += [mu + abs(b.Kup) @ np.abs(p), abs(b.Kup).T @ np.abs(u) + abs(b.Kpp) @ np.abs(p) + np.abs(b.q)]
        return np.concatenate(parts + [np.abs(F) for F in self.forces])

    def rounding(self, x) -> np.ndarray:
        parts = []
        for b, u, p in self._split(x):
            parts += [b.bulk.rounding(u)] + ([] if p is None else [np.zeros(len(p))])
        return np.concatenate(parts + [np.zeros(self.width)])

    def residual(self, x, *forces) -> float:
        """The relative residual of the nonlinear (26) at ``x`` with the row forces ``forces`` ((M, f) pairs: the
        rows M on x and their forces f): max_i |gradient(x) + sum M^T f|_i over the sizes of its terms,
        magnitude(x) + sum |M|^T |f| (0 at the answer, rounding of its terms at best)."""
        r, size = self.gradient(x), self.magnitude(x)
        for M, f in forces:
            r = r + M.T @ f
            size = size + abs(M).T @ np.abs(f)
        return float((np.abs(r) / np.maximum(size, np.finfo(float).tiny)).max(initial=0.0))

    def tangent(self, x, secant: bool = False) -> sp.csr_matrix:
        """The derivative of :meth:`gradient` at ``x``; ``secant``: with the bodies' secant stiffness instead
        (:meth:`~cvxcontact.discrete.energy.BulkEnergy.hessian`; the same for a linear material)."""
        return self._tangent if self.linear else self._assemble(x, secant)

    def linearised(self, x):
        """(T, b): the tangent T at ``x`` and b = T x - gradient(x), so that gradient(x') ~ T x' - b near ``x``
        (exact for a linear material: at x = 0, b = [f; -q; ...; F] the loads of (26))."""
        T = self.tangent(x)
        if self.linear:                         # the loads themselves, exactly (no rounding of T x - T x)
            return T, -self.gradient(np.zeros_like(x))
        return T, T @ x - self.gradient(x)

    def pattern(self) -> sp.csr_matrix:
        """Ones wherever :meth:`tangent` may be non-zero at any x (the bodies' :meth:`BulkEnergy.pattern` and
        coupling blocks): one sparsity for every Newton step's factor."""
        def stored(M):                          # ones on every stored entry (explicit zeros included)
            M = sp.csr_matrix(M)
            return sp.csr_matrix((np.ones(M.nnz), M.indices, M.indptr), shape=M.shape)

        mats = []
        for b in self.blocks:
            P = b.bulk.pattern()
            mats.append(P if b.Kpp is None else sp.bmat([[P, stored(b.Kup)], [stored(b.Kup.T), stored(b.Kpp)]]))
        return stored(sp.block_diag(mats + [sp.csr_matrix((self.width, self.width))] * bool(self.width),
                                    format="coo"))

    def _assemble(self, x, secant=False):
        if x is None:
            mats = [quasi_definite(b)[0] for b in self.blocks]
        else:
            mats = []
            for b, u, p in self._split(x):
                H = b.bulk.hessian(u, secant=secant)
                mats.append(H if p is None else sp.bmat([[H, b.Kup], [b.Kup.T, -b.Kpp]]))
            if len(mats) == 1 and not self.width:               # one body: its block itself (no copy)
                return sp.csr_matrix(mats[0])
        return sp.block_diag(mats + [sp.csr_matrix((self.width, self.width))] * bool(self.width), format="csr")


class LawEnergy:
    """A :class:`MixedEnergy` ``energy`` plus the normal-compliance energy of the contact rows (docs/formulation.md
    §10): L(x) + sum_a w_a Phi_a(G_a x - g_a), ``law`` the rows' scaled :class:`~cvxcontact.contact.laws.RowLaws`
    (Phi_a = 0 on Signorini rows), ``weights`` w the rows' lumped lengths, G x - g the penetration
    (:func:`mixed_system`). Its gradient adds the law's row forces G^T (w p(r)), its tangent G^T diag(w p'(r)) G
    (semismooth for m = 1: p' is k on the rows in penetration, 0 elsewhere). ``linear``: the energy is quadratic
    and no row is compliant. What the friction finish beside a compliance law steps on
    (:func:`~cvxcontact.backends.frictionsteps.sequential`), with the rows of a finite limit as its normal rows."""

    def __init__(self, energy: MixedEnergy, G, g, weights, law):
        self.energy, self.G, self.g, self.law = energy, sp.csr_matrix(G), np.asarray(g, dtype=float), law
        self.w = np.asarray(weights, dtype=float)
        self.absG = abs(self.G)
        self.linear = energy.linear and not law.compliant

    def forces(self, x) -> np.ndarray:
        """The law's row forces w p(G x - g) (scaled)."""
        return self.w * self.law.pressure(self.G @ x - self.g)

    def value(self, x) -> float:
        return self.energy.value(x) + float(self.w @ self.law.energy(self.G @ x - self.g))

    def gradient(self, x) -> np.ndarray:
        return self.energy.gradient(x) + self.G.T @ self.forces(x)

    def magnitude(self, x) -> np.ndarray:
        return self.energy.magnitude(x) + self.absG.T @ np.abs(self.forces(x))

    def rounding(self, x) -> np.ndarray:
        return self.energy.rounding(x)

    residual = MixedEnergy.residual

    def tangent(self, x, secant: bool = False) -> sp.csr_matrix:
        return law_tangent(self.energy.tangent(x, secant), self.G, self.g, self.w, self.law, x)

    def linearised(self, x):
        """(T, b) as :meth:`MixedEnergy.linearised`, the law's term linearised at ``x`` (:func:`law_linearised`)."""
        if self.linear:
            return self.energy.linearised(x)
        return law_linearised(self.energy.tangent(x), self.energy.gradient(x), self.G, self.g, self.w, self.law, x)


def law_linearised(T, gradient, G, g, weights, law, x):
    """(K, b): the second-order model at ``x`` of an energy with the normal-compliance energy of the rows G x - g
    added, sum_a w_a Phi_a(G_a x - g_a) (``law`` the rows' scaled :class:`~cvxcontact.contact.laws.RowLaws`, w the
    ``weights``; docs/formulation.md §10), from the energy's tangent ``T`` and ``gradient`` at ``x``: with
    r = G x - g and D = diag(w p'(r)),

        K = T + G^T D G,      b = K x - (gradient + G^T w p(r)),

    so that the whole gradient near ``x`` is K x' - b (the law's forces w p(r) + D G (x' - x); semismooth for
    m = 1: p' is k on the rows in penetration, 0 elsewhere). The one linearisation of the law: the friction finish
    beside a compliance law (:meth:`LawEnergy.linearised`) and the Newton steps on the law around dependent rows
    (:func:`~cvxcontact.backends.compliance.dependent_newton`) step on it."""
    K = law_tangent(T, G, g, weights, law, x)
    return K, K @ x - (gradient + G.T @ (np.asarray(weights, dtype=float) * law.pressure(G @ x - g)))


def law_tangent(T, G, g, weights, law, x) -> sp.csr_matrix:
    """K = T + G^T diag(w p'(G x - g)) G: the tangent ``T`` of an energy with the compliance energy of the rows added
    (:func:`law_linearised`)."""
    D = np.asarray(weights, dtype=float) * law.derivative(G @ x - g)
    return (T + G.T @ sp.diags(D) @ G).tocsr()


class HeldEnergy:
    """A :class:`MixedEnergy` ``energy`` with a constant load and linear equality rows appended, on the unknowns
    z = [x; m] (m the rows' multipliers): the saddle energy L(x) + load^T x + m^T (H x + h), whose gradient is
    [grad L(x) + load + H^T m; H x + h] and tangent [[Hess L(x), H^T], [H, 0]]. The stick-slip partition of
    Tresca's law in 2D posed on the nonlinear (26) (:func:`~cvxcontact.backends.friction._tangency_polish`): the
    slipping rows' forces c_a sign(s_a) are the load S^T f, the stuck rows' slips S_a x + s0_a = 0 the rows ``H``
    (h = s0), their multipliers the stuck rows' tangential forces. ``gradient``, ``tangent``, ``magnitude`` as
    :class:`MixedEnergy`'s (what :func:`~cvxcontact.backends.tangency.tangency_newton` reads)."""

    def __init__(self, energy: MixedEnergy, load: np.ndarray, H, h: np.ndarray):
        self.energy, self.load, self.H, self.h = energy, np.asarray(load, dtype=float), sp.csr_matrix(H), h
        self.n, self.linear = len(self.load), energy.linear

    def gradient(self, z) -> np.ndarray:
        x, m = z[:self.n], z[self.n:]
        return np.concatenate([self.energy.gradient(x) + self.load + self.H.T @ m, self.H @ x + self.h])

    def tangent(self, z) -> sp.csr_matrix:
        return sp.bmat([[self.energy.tangent(z[:self.n]), self.H.T], [self.H, None]], format="csr")

    def magnitude(self, z) -> np.ndarray:
        x, m = z[:self.n], z[self.n:]
        return np.concatenate([self.energy.magnitude(x) + np.abs(self.load) + abs(self.H).T @ np.abs(m),
                               abs(self.H) @ np.abs(x) + np.abs(self.h)])


class SlidingEnergy:
    """A :class:`MixedEnergy` ``energy`` with the friction energy of slipping rows added, sum_a c_a |S_a x + s0_a|
    (S (c k, n) the rows' slip components, row a's at a c .. a c + c - 1, c = ``components``; ``s0`` their
    prescribed slip; ``c`` (k,) the capacities): Tresca's law on rows that slip, in 3D (two slip components)
    nonlinear in their direction. Its gradient adds S^T (c_a t_a), t_a = s_a / |s_a| (the rows' friction forces, in
    the scaled force units), its tangent S^T diag(c_a / |s_a| (I - t_a t_a^T)) S (positive semidefinite; smooth
    while no slip vanishes). The stick-slip partition of Tresca's
    law in 3D on (26) (:func:`~cvxcontact.backends.frictiontangency.tangency_polish`); in 2D (one component) the
    gradient is the load c_a sign(s_a) and the tangent 0. ``gradient``, ``tangent``, ``magnitude`` as
    :class:`MixedEnergy`'s (what :func:`~cvxcontact.backends.tangency.tangency_newton` reads)."""

    def __init__(self, energy: MixedEnergy, S, s0: np.ndarray, c: np.ndarray, components: int):
        self.energy, self.S, self.s0, self.c = energy, sp.csr_matrix(S), np.asarray(s0, dtype=float), \
            np.asarray(c, dtype=float)
        self.k, self.components = len(self.c), int(components)
        self.linear = False

    def slips(self, x) -> np.ndarray:
        """(k, c): the rows' slips at ``x``."""
        return (self.S @ x + self.s0).reshape(self.k, self.components)

    def forces(self, x) -> np.ndarray:
        """(k, c): the rows' friction forces c_a t_a at ``x`` (not finite where a slip vanished, silently: the
        Newton that reads them then declines, its system not finite, rather than a warning escaping mid-solve)."""
        s = self.slips(x)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.c[:, None] * s / np.linalg.norm(s, axis=1)[:, None]

    def gradient(self, x) -> np.ndarray:
        return self.energy.gradient(x) + self.S.T @ self.forces(x).ravel()

    def tangent(self, x) -> sp.csr_matrix:
        s = self.slips(x)
        size = np.linalg.norm(s, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):           # a vanished slip: not finite (forces)
            t = s / size[:, None]
            blocks = (self.c / size)[:, None, None] * (np.eye(s.shape[1])[None] - t[:, :, None] * t[:, None, :])
        D = sp.block_diag(list(blocks), format="csr") if self.k else sp.csr_matrix((0, 0))   # nothing slips
        return (self.energy.tangent(x) + self.S.T @ D @ self.S).tocsr()

    def magnitude(self, x) -> np.ndarray:
        return self.energy.magnitude(x) + abs(self.S).T @ np.abs(self.forces(x)).ravel()


def mixed_system(problem):
    """(operator, G, widths) of the sparse mixed system (26) of ``problem`` (scaled): the :class:`MixedEnergy`
    of its bodies and force-controlled obstacles (``widths`` their translation sizes) and G the rows
    E [u_nu] + R tau on the unknowns x = [u_1; phi_1; ...; tau_1; ...], so that G x - g is the penetration."""
    blocks, E, tr = list(problem.blocks), problem.E, list(problem.translations)
    widths = [R.shape[1] for R, _ in tr]
    G = sp.hstack([sp.hstack([E @ b.jump, sp.csr_matrix((E.shape[0], 0 if b.Kpp is None else b.Kpp.shape[0]))])
                   for b in blocks] + [sp.csr_matrix(R) for R, _ in tr]).tocsr()
    return MixedEnergy(blocks, tr), G, widths


def stacked(u, phi, taus=()):
    """x = [u_1; phi_1; ...; tau_1; ...] (the unknowns of :func:`mixed_system`)."""
    return np.concatenate([np.concatenate([uk, pk]) if pk is not None else uk for uk, pk in zip(u, phi)]
                          + [np.asarray(t, dtype=float) for t in taus])


def unstacked(problem, x, widths):
    """(u, phi, taus) of the unknowns x of :func:`mixed_system`."""
    u, phi, pos = [], [], 0
    for b in problem.blocks:
        nu, npf = b.Kuu.shape[0], 0 if b.Kpp is None else b.Kpp.shape[0]
        u.append(x[pos:pos + nu])
        phi.append(x[pos + nu:pos + nu + npf] if npf else None)
        pos += nu + npf
    taus = list(np.split(x[pos:], np.cumsum(widths)[:-1])) if widths else []
    return u, phi, taus


def tangent_blocks(blocks, u) -> list:
    """The bodies' scaled ``blocks`` linearised at their displacements ``u``: each body's bulk energy replaced by its
    second-order model there, Kuu = H = Hess Pi(u) and f = f - grad Pi(u) + H u (so that Kuu u' - f = grad Pi(u) - f
    + H (u' - u)); the coupling, the permittivity and the rows unchanged. The linear problem of these blocks is the
    Newton (sequential quadratic) model of the nonlinear one at ``u``: the routes that solve linear systems of Kuu
    (the cones' cuts) solve it, and its contact structure is the nonlinear answer's near ``u``. A quadratic energy's
    block is returned as it is."""
    out = []
    for b, uk in zip(blocks, u):
        if b.bulk.quadratic:
            out.append(b)
            continue
        H = sp.csr_matrix(b.bulk.hessian(uk))
        out.append(replace(b, Kuu=H, f=b.f - b.bulk.gradient(uk) + H @ uk, bulk=Quadratic(H)))
    return out
