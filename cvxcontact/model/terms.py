"""The user terms of a :class:`~cvxcontact.model.Model` on its discrete problem: their linearisation, the exact
finish with linear user rows, and the checks of (26)-(27) with the user forces (docs/architecture.md,
"Extending a problem"). Every function reads the scaled :class:`~cvxcontact.discrete.DiscreteProblem`; a user
row is (C, c0, z, equality, affine): C x + c0 <= 0 (or == 0) on the stacked unknowns x = [u_1; phi_1; ...;
tau_1; ...], z its multipliers."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..backends.finish import Declined, MAX_ITER, SIGN_TOL, active_set_steps
from ..backends.full import mixed_kkt
from ..solution.checks import equilibrium_with, node_scales, rigid_balance, row_checks, row_scales, rows_active

__all__ = ["stacked", "linearize", "finish", "checks", "balance", "contact_norms"]

MAX_STEPS = 20
"""Active-set steps of :func:`finish` before it declines."""


def stacked(u, phi, taus=()):
    """x = [u_1; phi_1; u_2; ...; tau_1; ...]: the scaled unknowns in the order of the model's variables."""
    return np.concatenate([a for uk, pk in zip(u, phi) for a in ((uk,) if pk is None else (uk, pk))] + list(taus))


def linearize(expr, x, variables):
    """(C, c0) with expr ~ C x + c0 at x (exact for an affine expr); C None if not differentiable.
    ``variables``: the model's (variable, offset in x) pairs."""
    grad = expr.grad
    m = expr.size
    if grad is None or any(grad.get(v) is None for v in expr.variables()):
        return None, None
    blocks = []
    for v, _ in variables:
        G = grad.get(v)
        blocks.append(sp.csr_matrix((m, v.size)) if G is None else sp.csr_matrix(G).T)
    C = sp.hstack(blocks).tocsr()
    return C, np.asarray(expr.value, dtype=float).flatten(order="F") - C @ x


def contact_norms(problem):
    """The norm of every contact row on the stacked scaled unknowns (1 for a row that moves none)."""
    G = sp.hstack([problem.E @ b.jump for b in problem.blocks]).tocsr()
    n = np.sqrt(np.asarray(G.power(2).sum(axis=1)).ravel())
    return np.where(n > 0, n, 1.0)


def finish(problem, u, phi, y, rows, load, active, x):
    """Exact finish with linear user rows: primal-dual active-set steps on the mixed system (26)
    with the contact rows and the user inequality rows (and, with force-controlled obstacles, their
    translations tau and force balances R^T y = F, docs/formulation.md §12); returns
    (u, phi, y, [z_i], active, taus) or the reason it was declined."""
    E, g, blocks, tr = problem.E, problem.g, list(problem.blocks), list(problem.translations)
    m = [len(r[1]) for r in rows]
    if rows:
        C = sp.vstack([r[0] for r in rows]).tocsr()
        d = -np.concatenate([r[1] for r in rows])
        z = np.concatenate([r[2] for r in rows])
        eq = np.concatenate([np.full(k, r[3]) for k, r in zip(m, rows)])
    else:
        C, d, z, eq = sp.csr_matrix((0, len(x))), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool)
    if not rows and load is None:
        widths = [R.shape[1] for R, _ in tr]
        hold = np.split(np.asarray(x)[len(x) - sum(widths):], np.cumsum(widths)[:-1]) if tr else None
        base = mixed_kkt(blocks, E, g, translations=tr or None, hold=hold)   # translations no row sees: the IPM's

        def kkt(ac, ar):
            out = base(ac)
            if out is None:
                return None
            x = out[0] if tr else (*out[0], [])
            return (*x[:3], np.zeros(0), x[3]), out[2], np.zeros(0)
    else:
        rows_kkt = mixed_kkt(blocks, E, g, rows=C, bound=d, load=load, translations=tr or None)

        def kkt(ac, ar):
            out = rows_kkt(ac, ar)
            if out is None:
                return None
            x = out[0] if tr else (*out[0], [])
            return x, out[1], out[2]
    nc = contact_norms(problem)
    S, norms = row_scales(C, x, d)
    Z = max(float((y * nc).max(initial=0.0)), float((np.abs(z) * norms).max(initial=0.0)))
    ar = eq | rows_active(C @ x - d, S, z, norms, Z)

    def step(state):
        ac, ar = state
        out = kkt(ac, ar)
        if out is None:
            return None
        (uk, pk, yk, zk, tk), sc, sr = out
        xk = stacked(uk, pk, tk)
        moved = problem.moved_g(tk)
        _, U = node_scales([E @ (b.jump @ ui) for b, ui in zip(blocks, uk)], moved)
        S, _ = row_scales(C, xk, d)
        Z = max(float((yk * nc).max(initial=0.0)), float((np.abs(zk) * norms).max(initial=0.0)),
                np.finfo(float).tiny)
        neg_c = ac & (yk * nc < -SIGN_TOL * Z)
        neg_r = ar & ~eq & (zk * norms < -SIGN_TOL * Z)
        bad_c = ~ac & (sc > SIGN_TOL * U)
        bad_r = ~ar & (sr > SIGN_TOL * S)
        if not (neg_c.any() or neg_r.any() or bad_c.any() or bad_r.any()):
            return (uk, pk, yk, zk, tk), None
        return None, ((ac & ~neg_c) | bad_c, (ar & ~neg_r) | bad_r)

    out = active_set_steps(step, (active.copy(), ar), MAX_STEPS, key=lambda s: s[0].tobytes() + s[1].tobytes())
    if isinstance(out, Declined):
        return Declined(out.stop, str(out) + (f" in {MAX_STEPS} steps" if out is MAX_ITER else ""), out.rows)
    (uk, pk, yk, zk, tk), (ac, _), _ = out
    off = np.cumsum([0] + m)
    return uk, pk, yk, [zk[a:b] for a, b in zip(off[:-1], off[1:])], ac, list(tk)


def checks(problem, base, u, phi, y, x, rows, grad):
    """The checks of read_back with the user terms: equilibrium of (26) with the user forces (and the balance of
    the rigid motions only the contact holds with them, :func:`~cvxcontact.solution.checks.rigid_balance`, as
    the read-back's ``base`` had it without them), and feasibility/complementarity of each user constraint,
    normalised per row."""
    blocks, E = problem.blocks, problem.E
    t = grad.copy()
    tm = np.abs(grad)
    for C, c0, z, _, _ in rows:
        if C is None:
            t[:] = np.nan
            continue
        t += C.T @ z
        tm += abs(C).T @ np.abs(z)
    forces, pos = [], 0
    for b, uk, pk in zip(blocks, u, phi):
        nu, npf = len(uk), (0 if pk is None else len(pk))
        tu, mu = t[pos:pos + nu].copy(), tm[pos:pos + nu].copy()
        if npf and np.any(t[pos + nu:pos + nu + npf] != 0):
            w = spla.splu(b.Kpp.tocsc()).solve(t[pos + nu:pos + nu + npf])
            tu += b.Kup @ w
            mu += abs(b.Kup) @ np.abs(w)
        forces.append((tu, mu))
        pos += nu + npf
    out = dict(base)
    Ety = E.T @ y
    held = []                  # the balance of the rigid motions only the contact holds, the user forces beside
    for k, (b, s, blk, fit, uk, pk) in enumerate(zip(problem.scene.bodies, problem.systems, blocks,
                                                     problem.rigid_fits, u, phi)):
        modes = b.held_modes(problem.meshes[k])
        if len(modes):
            held.append(rigid_balance(blk, (s.Tu.T @ modes.T).T, fit.deformation(uk), pk, Ety, forces[k],
                                      prolongation=s.Tu, dim=b.dim))
    out["equilibrium"] = float(np.max([equilibrium_with(blocks, u, phi, Ety, forces), *held]))
    nc = contact_norms(problem)
    Z = float((np.abs(y) * nc).max(initial=0.0))     # (the conic nodal force r may change sign)
    for C, c0, z, _, _ in rows:
        if C is not None:
            Z = max(Z, float((np.abs(z) * row_scales(C, x, c0)[1]).max(initial=0.0)))
    for i, (C, c0, z, eq, _) in enumerate(rows):
        if C is None:
            out[f"user[{i}] feasibility"] = out[f"user[{i}] complementarity"] = float("nan")
            continue
        S, norms = row_scales(C, x, c0)
        feas, comp, cone = row_checks(C @ x + c0, S, z, norms, Z, equality=eq)
        out[f"user[{i}] feasibility"] = feas
        if not eq:
            out[f"user[{i}] complementarity"] = comp
            out[f"user[{i}] cone"] = cone
    return out


def balance(problem, y, rows, n_bodies: int) -> float:
    """The force balance of every force-controlled obstacle with the user rows' forces on its translation
    (scaled; docs/formulation.md §12): max |F - R^T y - C_t^T z| / |F| (with the obstacle's check of
    :func:`~cvxcontact.solution.solution.obstacle_results` when no user row touches t)."""
    worst, pos = 0.0, n_bodies
    for R, F in problem.translations:
        k = R.shape[1]
        r = F - R.T @ y
        for C, _, z, _, _ in rows:
            r = r - (np.full(k, np.nan) if C is None else C[:, pos:pos + k].T @ z)
        worst = float(np.max([worst, np.linalg.norm(r) / np.linalg.norm(F)]))     # (nan propagates)
        pos += k
    return worst
