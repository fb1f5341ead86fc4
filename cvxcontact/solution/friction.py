"""Read-back and checks of a friction law (Tresca, Coulomb; docs/howto/friction.md, docs/checks.md "Friction").

With mu_a the tangential force of row a (scaled, :mod:`cvxcontact.backends.friction`), s_a its slip
E [u_t], c_a = g_a w_a its friction capacity at the answer's own pressures (Coulomb: c_a = mu y_a, so the
checks are Coulomb's cone and complementarity, not the last Tresca iterate's), C =
:func:`~cvxcontact.backends.finish.forces.friction_scale` (the largest capacity or normal row force, floored at
FORCE_FLOOR of the largest elastic force of the bodies' deformation at the rows' unknowns, free of rigid motions:
tangential forces are measured against the contact forces, a threshold far below the pressure, or zero, leaves the
normal forces' scale, and an open contact, whose Coulomb capacities are 0, the elastic forces' there) and U the largest nodal displacement of the bodies
(one scale for all rows: a stuck row's own displacement is rounding; dimensionless):

    equilibrium      (26) with the tangential forces T^T mu added to the momentum rows (and to the
                     balance of the rigid motions only the contact holds, read from each body's
                     deformation, u less its rigid fit, so its rounding does not grow with a slide, and
                     measured against the rows' friction force |mu_a| on each tangential component: the
                     direction of a sliding row's force is known to the slip's rounding, so a motion across
                     the slide sees that rounding of the whole force); each momentum row's scale at
                     least FORCE_FLOOR of the largest of all bodies (``equilibrium_with(at_rest=True)``:
                     a body at rest beside one that moves)
    friction cone    max over a of (|mu_a| - c_a)^+ / C                |sigma_t| <= g
    stick-slip       max over a of sqrt( |c_a - |mu_a|| |s_a| / (C U) )  (g - |sigma_t|) |[u_t]| = 0
    slip direction   max over a of sqrt( (-mu_a s_a)^+ / (C U) )        sigma_t anti-parallel to the slip
"""

from __future__ import annotations

import numpy as np

from ..backends.finish.forces import friction_scale
from .checks import equilibrium_with, rigid_balance
from .nodal import read_columns
from .sides import side_multiplier
from .solution import pair_lines

__all__ = ["friction_checks", "obstacle_friction", "read_back_friction"]


def friction_checks(mu, slip, capacity, U, Y=0.0) -> dict[str, float]:
    """The friction cone, stick-slip and slip-direction checks (module docstring) of row forces ``mu``, slips
    ``slip`` ((r,) in 2D, (r, 2) in 3D: |.| the Euclidean norm of a row, the slip direction
    (|mu_a| |s_a| - mu_a . s_a) / 2, which is (-mu_a s_a)^+ in 2D and vanishes only where mu_a is parallel to s_a)
    and capacities ``capacity`` (scaled), ``U`` the displacement scale and ``Y`` the normal rows' force scale
    (scaled; :func:`~cvxcontact.backends.finish.forces.friction_scale`)."""
    tiny = np.finfo(float).tiny
    C = max(float(np.max(capacity, initial=0.0)), float(Y), tiny)
    CU = max(C * U, tiny)
    mu, slip = np.asarray(mu, dtype=float), np.asarray(slip, dtype=float)
    if mu.ndim == 1:
        a, s, turned = np.abs(mu), np.abs(slip), np.maximum(-mu * slip, 0.0)
    else:
        a, s = np.linalg.norm(mu, axis=1), np.linalg.norm(slip, axis=1)
        turned = np.maximum(a * s - np.einsum("ij,ij->i", mu, slip), 0.0) / 2
    return {"friction cone": float((np.maximum(a - capacity, 0.0) / C).max(initial=0.0)),
            "stick-slip": float(np.sqrt((np.abs(capacity - a) * s / CU).max(initial=0.0))),
            "slip direction": float(np.sqrt((turned / CU).max(initial=0.0)))}


def read_back_friction(problem, raw, sol) -> None:
    """Complete ``sol`` (read back as nodal Signorini rows) with the friction law: every pair's ``slip`` (m),
    ``shear_force`` (N/m, on the first body along the pair's tangent; 3D: (n, 2) along the pair's frame
    (t_1, t_2)) and the checks of the module docstring,
    the equilibrium check recomputed with the tangential forces."""
    from dataclasses import replace

    E, blocks, un, u, phi = problem.E, problem.blocks, problem.units, raw.u, raw.phi
    data = problem.term.data                                              # the friction term's Slip
    Es, n_c = data.rows, data.components
    mu = np.asarray(raw.tangential, dtype=float)                          # (c R,) component-major
    Ety, Tmu = E.T @ raw.y, Es.T @ mu
    forces = [(T.T @ Tmu, abs(T).T @ np.abs(Tmu)) for T in data.operators]
    checks = sol._checks
    equilibrium = equilibrium_with(blocks, u, phi, Ety, forces, at_rest=True)
    sizes = abs(Es).T @ np.tile(np.linalg.norm(mu.reshape(n_c, -1), axis=0), n_c)  # |mu_a| on each component
    for k, (body, s, blk, T, fit, uk, pk) in enumerate(zip(problem.scene.bodies, problem.systems, blocks,
                                                            data.operators, problem.rigid_fits, u, phi)):
        modes = body.held_modes(problem.meshes[k])
        if len(modes):
            extra = (T.T @ Tmu, abs(T).T @ sizes)
            equilibrium = max(equilibrium, rigid_balance(blk, (s.Tu.T @ modes.T).T, fit.deformation(uk), pk, Ety,
                                                         extra, prolongation=s.Tu, dim=body.dim))
    checks["equilibrium"] = equilibrium
    shift = np.broadcast_to(np.asarray(data.prescribed, dtype=float), (Es.shape[1],))
    slip = sum(T @ uk for T, uk in zip(data.operators, u)) + shift            # at the nodes of X_h (c size,)
    slip = slip + sum((T @ t for T, t in zip(data.translations, raw.taus)), np.zeros(len(slip)))
    U = max([float(np.abs(uk).max(initial=0.0)) for uk in u] + [float(np.abs(shift).max(initial=0.0))]
            + [float(np.abs(t).max(initial=0.0)) for t in raw.taus])
    rows = problem.rows.frictional
    capacity = data.capacities(raw.y)               # at the answer's pressures (Coulomb: mu y_a, its own cone)
    by_row = (lambda v: v) if n_c == 1 else (lambda v: v.reshape(n_c, -1).T)  # (R,) or (R, c)
    checks.update(friction_checks(by_row(mu)[rows], by_row(Es @ slip)[rows], capacity[rows], U,
                                  friction_scale(problem, u, phi, raw.y, capacity[rows])))
    offsets = problem.lines.offsets

    slip, Tmu = by_row(slip), by_row(Tmu)                                 # per node of X_h: (size,) or (size, c)
    measure = E.T @ (data.row_lengths * un.length)                     # the rows' weights at the nodes of X_h
    trace = problem.space.trace
    pairs, _ = pair_lines(problem.scene, trace.kept(problem.interface))
    pressing = data.pressing(raw.y)                       # the thresholds' normal forces (scaled)

    def row_read(i, a, b, forces):
        """P2: the rows' ``forces`` (scaled, one per row of E or (R, c)) over their own weights at the nodes of
        X_h (``trace.row_shear``); None where the pair has no row weights."""
        cond = problem.scene.conditions[i] or problem.condition
        rows = np.flatnonzero(read_columns(E[:, a:b].T))
        return trace.row_shear(pairs[i], cond, E[rows][:, a:b], forces[rows] * un.force)

    def row_shear(i, a, b):
        """P2: the rows' tangential forces over their own weights at the nodes of X_h (``trace.row_shear``)."""
        return row_read(i, a, b, -by_row(mu))

    def threshold(i, a, b, contact):
        """The pair's threshold: Tresca's g (Pa); a pressure-dependent law's (Coulomb: mu p) at each node of X_h
        (Pa), p the pressure its capacities weigh: on a P2 pair with row weights the normal forces that set the
        capacities (``pressing``: under the P2 cones the nodal forces made non-negative) over the rows' own
        weights, extended to every node of X_h as the function of the rows' values (``trace.row_shear``, where and
        as the rows' shear ``row_shear`` is read: a sliding row's shear is its threshold, the capacity mu p_a over
        w_a; on a 2D line too, where :attr:`ContactResult.shear` is 0 at the nodes no row reads: the threshold is
        not, the nodes between a "sigma1"/"sigma2" pair's rows carry the function of the rows' thresholds, as
        they carry that of the rows' shears); under the 3D cones, whose rows are the nodes of X_h, over the areas
        the shear is read on (``trace.per_length``), else the pair's read-back pressure; None without friction."""
        f = problem.rows.laws[i].friction
        if f is None:
            return None
        if not f.pressure_dependent:
            return f.threshold
        lumped = row_read(i, a, b, pressing)
        if lumped is None and problem.lines.cone is not None:    # the cones' rows at the nodes of X_h (3D)
            at = replace(contact, row_shear=None, slip_measure=measure[a:b])
            return f.thresholds(trace.per_length(at, E[:, a:b].T @ pressing * un.force))
        if lumped is None:
            return f.thresholds(contact.pressure)
        return f.thresholds(lumped)

    shear = -Tmu * un.force                                               # N/m (3D N) at the nodes of X_h
    laws = getattr(problem.rows, "laws", ())
    alone = [i for i, law in enumerate(laws) if law.compliant or law.friction is None]  # as lambda_h; no t_h
    held = _holding(laws, offsets, sol._closed)
    t_h = trace.shear_multiplier(problem.interface, shear, lambda f: side_multiplier(problem.interface, f, alone,
                                                                                       held))
    sol.contacts = [replace(c, slip=slip[a:b] * un.displacement, shear_force=shear[a:b],
                            threshold=threshold(i, a, b, c), slip_measure=measure[a:b],
                            row_shear=row_shear(i, a, b), shear_multiplier=None if t_h is None else t_h[a:b])
                    for i, (c, a, b) in enumerate(zip(sol.contacts, offsets[:-1], offsets[1:]))]
    for c in sol.contacts:
        for f in ("slip", "shear_force", "threshold", "slip_measure", "row_shear", "shear_multiplier"):
            if isinstance(getattr(c, f), np.ndarray):
                getattr(c, f).setflags(write=False)
    sol.contact = sol.contacts[0]


def _holding(laws, offsets, closed) -> np.ndarray | None:
    """Where each pair's rows may hold a tangential force (bool per stacked node of X_h; None: ``closed`` not
    read), the nodes a side's t_h is shared among (``active`` of
    :func:`~cvxcontact.solution.sides.side_multiplier`): where its contact is closed (``closed``, as lambda_h's
    shares), and everywhere under a threshold that does not depend on the pressure (Tresca's g: an open row holds
    up to g w_a too, so a pair closed nowhere may carry part of a side's tangential forces; read alone, the
    representer of its part on its own reach, the pairs' t_h would not sum to the side's). ``laws`` the pairs'
    (``problem.rows.laws``), ``offsets`` their nodes' in the stack."""
    if closed is None or len(laws) != len(offsets) - 1:
        return closed
    fixed = [law.friction is not None and not law.friction.pressure_dependent for law in laws]
    return np.asarray(closed, dtype=bool) | np.repeat(np.asarray(fixed, dtype=bool), np.diff(offsets))


def obstacle_friction(problem, raw) -> list | None:
    """Per force-controlled obstacle of ``problem`` the resultant (d,) N/m (3D: N) of the friction forces of the
    answer ``raw`` on its pairs along the translations it is free to make (its ``basis`` B), as it enters the
    obstacle's balance: B^T F = B^T sum_a c_a y_a + T^T E_s^T mu, T the slip of its translation unknowns
    (the friction term's ``data.translations``; the stationarity of the energy in them); the part along
    the translations its rows do not see (a plane's tangential ones) is its guide's. None without a friction law or
    a force-controlled obstacle."""
    data = problem.term.data
    if raw.tangential is None or not getattr(data, "translations", ()):
        return None
    force = data.rows.T @ np.asarray(raw.tangential, dtype=float) * problem.units.force
    return [o.basis @ (T.T @ force) for o, T in zip(problem.forced, data.translations)]
