"""Checks of the mixed formulation (26)-(27), normalised where nothing can hide (docs/checks.md).

All in scaled units, dimensionless, reported by :meth:`cvxcontact.Solution.residuals`:

    equilibrium      max over bodies k of || r_k || / || |A_k| |x_k| + |F_k| + |J_k^T| |M lambda_h| ||   (26)
    feasibility      max over constrained nodes a of (E [u_nu] - g)_a^+ / U_a
    complementarity  max over a of sqrt( y_a (|(E [u_nu] - g)_a| - SLACK_ROUNDING U_a)^+ / (Y U_a) )   (27)
    cone             max over a of max(-y_a, 0) / Y          (the multiplier lies in Lambda_h)

with r_k the residual of body k's rows of (26), U_a the displacement scale of node a
(both bodies' normal displacements there plus the gap plus the local displacement w_a |y_a| of
its own contact force, :func:`force_displacements`, plus the displacement its neighbours' elastic forces give
it, :func:`reach_displacements`: a node that does not move has no other scale) and Y the largest contact force,
floored at FORCE_FLOOR = 1e-6 of the largest elastic force at the contact rows (:func:`force_scale`): with the
contact open the forces are zero or noise, and noise over noise is not a violation.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..backends.cuts import segment_scales
from ..backends.finish import (FORCE_FLOOR, coefficient_rounding, force_displacements,  # noqa: F401
                               force_scale, ipm_active, node_scales, reach_displacements, reach_forces, slack_terms)
from ..contact.bernstein import bernstein_max, element

__all__ = ["CERTIFIED", "ENERGY_ERROR", "energy_error", "checks", "rigid_balance", "compliance_checks", "conic_checks", "cone_slack", "touching_nodes", "force_displacements", "ipm_active",
           "node_scales", "equilibrium_with", "row_scales", "row_checks", "rows_active",
           "obstacle_balance", "SLACK_ROUNDING", "complementarity"]


def checks(blocks, u, phi, Mlam, E, g, y, moved=None, fits=None, reach=None):
    """The relative residuals of the mixed formulation, in scaled units (module docstring).

    Each is normalised where nothing can hide: equilibrium per body by that body's own
    row scales |A||x| + |F| + |J^T||M lambda_h|; feasibility, complementarity and cone
    per constrained node by that node's displacement scale U_a (the sizes of both
    bodies' normal displacements there and of the gap) and by the largest contact
    force, never by the total load. ``moved`` (per row, optional): the size of the obstacles' translation
    terms in the gap ``g`` (:meth:`~cvxcontact.discrete.DiscreteProblem.translation_sizes`), added to U_a.
    ``fits`` (per body, ``problem.rigid_fits``): the floor of Y reads each body's deformation (:func:`reach_forces`).
    ``reach``: the rows' :class:`~cvxcontact.backends.finish.forces.RowReach` on ``blocks`` and ``E``, if kept (the
    same numbers, without reading the whole matrices).
    """
    tiny = np.finfo(float).tiny
    equilibrium = 0.0
    for b, uk, pk in zip(blocks, u, phi):
        r = np.concatenate(b.residual(uk, pk, Mlam))
        m = np.concatenate(b.magnitude(uk, pk, Mlam))
        equilibrium = max(equilibrium, float(np.linalg.norm(r) / max(np.linalg.norm(m), tiny)))
    if reach is None:
        local = force_displacements(blocks, E, y) + reach_displacements(blocks, E, u, phi)
        elastic = reach_forces(blocks, E, u, phi, fits)
    else:
        local = reach.compliance * np.abs(y) + reach.displacements(u, phi)
        elastic = reach.forces(u, phi, fits)
    slack, U = node_scales([E @ (b.jump @ uk) for b, uk in zip(blocks, u)], g,
                           local + (0.0 if moved is None else np.abs(moved)))
    Y = force_scale(y, elastic)
    return {
        "equilibrium": equilibrium,
        "feasibility": float((np.maximum(slack, 0.0) / U).max(initial=0.0)),
        "complementarity": complementarity(y, slack, Y, U),
        "cone": float(np.maximum(-y, 0.0).max(initial=0.0) / Y),
    }


SLACK_ROUNDING = 64 * np.finfo(float).eps
"""The rounding of a closed row's slack relative to its displacement scale U_a: an exact answer's slack
E [u_nu] - g at its closed rows is the rounding of the bodies' displacements there (measured <= 4.2 eps U_a on
exact finishes in 3D, tests/test_check_rounding.py), and within it a slack cannot be told from zero."""


def complementarity(y, slack, Y: float, U, rounding=None, pairing=None) -> float:
    """max over the rows a of sqrt( (|y_a . s_a - p_a| - |y_a| . R_a)^+ / (Y U_a) ) (27), ``slack`` s, ``U`` the
    rows' displacement scales, ``Y`` the force scale (docs/checks.md).

    ``y`` and ``slack`` (n,): one force and slack per row, the nodal rows; (n, w): a row's w pairs, an element's
    Bernstein duals beta_s and Bernstein coefficients b_s of the slack (:func:`conic_checks`). ``rounding`` R (as
    ``slack``; None: SLACK_ROUNDING U): a bound on each slack entry's rounding in an exact answer; ``pairing`` p
    (n,; None: 0) subtracted from each row's product. On a nodal row the floor is
    |y_a| (|s_a| - SLACK_ROUNDING U_a)^+.

    A square root: the error a complementarity gap allows grows like the root of the product. Without the
    rounding of the slack taken off, an exact answer read the root of rounding (1e-8: y_a ~ Y, |s_a| ~ eps U_a);
    with it, a closed row reads 0 and a gap reads the same to within the floor: the value squared drops by at
    most max_a |y_a| . R_a / (Y U_a) (nodal rows: SLACK_ROUNDING, as |y_a| <= Y, so a gap reading c before reads
    sqrt(c^2 - 1.4e-14) or more; an element: :func:`conic_checks`).
    """
    U = np.asarray(U, dtype=float)
    y, slack = _paired(y), _paired(slack)
    R = SLACK_ROUNDING * U[:, None] if rounding is None else _paired(rounding)
    product = np.abs((y * slack).sum(axis=1) - (0.0 if pairing is None else np.asarray(pairing, dtype=float)))
    gap = np.maximum(product - (np.abs(y) * R).sum(axis=1), 0.0)
    return float(np.sqrt((gap / np.maximum(Y * U, np.finfo(float).tiny)).max(initial=0.0)))


def _paired(a) -> np.ndarray:
    """``a`` as (rows, entries): a (n,) array one entry per row."""
    return np.atleast_2d(np.asarray(a, dtype=float).T).T


def equilibrium_with(blocks, u, phi, Mlam, forces, at_rest: bool = False):
    """The equilibrium check of :func:`checks` with extra generalised forces on the momentum rows.

    ``forces[k]`` is (t_u, m_u) for body k: the extra term of its momentum rows of (26) (e.g. user
    constraints' multipliers times their rows, scaled) and its size |C_u^T| |z| + ..., added to the
    residual and to the row scales respectively. ``at_rest``: each momentum row's scale is at least
    FORCE_FLOOR of the largest momentum row scale of all bodies (:func:`force_scale`'s floor): a body at rest beside
    one that moves (clamped, unloaded, its contact open or carrying forces of rounding) has an answer of the rounding
    of a coupled solve, and its rows' own sizes are that rounding (a friction finish: the Newton steps solve the
    bodies together; docs/howto/friction.md, "What is checked"). A body that carries a force has its own scale.
    """
    tiny = np.finfo(float).tiny
    rows = [(b.residual(uk, pk, Mlam), b.magnitude(uk, pk, Mlam), t, m_extra)
            for b, uk, pk, (t, m_extra) in zip(blocks, u, phi, forces)]
    floor = FORCE_FLOOR * max((float(np.max(mu + m_extra, initial=0.0)) for _, (mu, _), _, m_extra in rows),
                              default=0.0) if at_rest else 0.0
    out = 0.0
    for (ru, rp), (mu, mp), t, m_extra in rows:
        r = np.concatenate([ru + t, rp])
        m = np.concatenate([np.maximum(mu + m_extra, floor), mp])
        out = max(out, float(np.linalg.norm(r) / max(np.linalg.norm(m), tiny)))
    return out


def row_scales(C, x, c0):
    """Per-row scale |C| |x| + |c0| of the rows C x + c0 (the sizes of the terms each row balances),
    floored at 1e-9 of the largest and at |C_i| max|x| (the row's terms were the unknowns at their
    largest: a row u_k == 0 that the answer satisfies to rounding of the displacements must not read its
    rounding as a violation of order 1 when every row reads nearly 0), and the Euclidean norm of each row of
    C (1 for an empty row)."""
    S = abs(C) @ np.abs(x) + np.abs(c0)
    norms = np.sqrt(np.asarray(abs(C).power(2).sum(axis=1)).ravel())
    S = np.maximum(S, 1e-9 * S.max(initial=0.0) + np.finfo(float).tiny)
    S = np.maximum(S, norms * float(np.abs(x).max(initial=0.0)))
    return S, np.where(norms > 0, norms, 1.0)


def row_checks(slack, S, z, norms, Z, equality=False):
    """(feasibility, complementarity, cone) of constraint rows slack = C x + c0 <= 0 (or == 0).

    Normalised per row like the contact checks: feasibility max (slack_i)^+ / S_i (|slack_i| for an
    equality), complementarity max sqrt(z_i |slack_i| / (Z S_i / |C_i|)) and cone max (-z_i)^+ |C_i| / Z,
    with S_i the row's scale (:func:`row_scales`) and Z the largest multiplier of all constraint rows
    measured as a force, z_i |C_i| (the row normalised to unit norm). Equality rows have no sign:
    complementarity and cone are 0.
    """
    Z = max(float(Z), np.finfo(float).tiny)
    feas = (np.abs(slack) if equality else np.maximum(slack, 0.0)) / S
    if equality:
        return float(feas.max(initial=0.0)), 0.0, 0.0
    comp = np.sqrt(np.abs(z * slack) * norms / (Z * S))
    cone = np.maximum(-z, 0.0) * norms / Z
    return float(feas.max(initial=0.0)), float(comp.max(initial=0.0)), float(cone.max(initial=0.0))


def rows_active(slack, S, z, norms, Z):
    """Active rows of an interior-point answer by the rule of :func:`ipm_active`: the force z_i |C_i|
    relative to Z beats the open slack relative to the row's scale S_i."""
    return z * norms / max(float(Z), np.finfo(float).tiny) > np.abs(slack) / S


def cone_slack(blocks, u, g, r) -> tuple[np.ndarray, np.ndarray]:
    """(q, U) at the nodes of X_h: the slack q = [u_h nu] - g of the P2 "everywhere" condition (docs/formulation.md
    §8; <= 0 where admissible) and each node's displacement scale U_a: both bodies' |normal displacement| plus
    |g_a| plus the displacement w_a |r_a| its own contact force produces (:func:`force_displacements`), floored
    at 1e-9 of the largest (scaled units). ``r`` = B^T beta the nodal contact force on X_h."""
    parts = [blk.jump @ uk for blk, uk in zip(blocks, u)]
    # plus the displacement each node's own contact force |r_a| produces (as for the nodal conditions,
    # docs/checks.md): next to a clamped corner on a rigid floor (g = 0) nothing moves, and q there is
    # rounding of the bodies' displacements (measured: complementarity 3.1e-3 without this term, 1.2e-6 with it)
    U = sum(np.abs(p) for p in parts) + np.abs(g) + force_displacements(blocks, sp.identity(len(g), format="csr"), r)
    return sum(parts) - g, np.maximum(U, 1e-9 * U.max(initial=0.0) + np.finfo(float).tiny)


def touching_nodes(blocks, u, g, r, B, elements, tol: float, departure=None) -> np.ndarray:
    """The nodes of X_h of the elements where the P2 "everywhere" condition closes somewhere (bool per node;
    docs/formulation.md §8, "Which nodes are active").

    Per element s of the cone (``elements`` (S, w) its nodes of X_h: a merged segment's 3, an overlay
    triangle's 6; ``B`` (w S, n) the Bernstein map), with b_s the Bernstein coefficients of the slack
    q = [u_h nu] - g (:func:`cone_slack`) and U_s the largest displacement scale of its nodes (as
    :func:`conic_checks`): the element touches where its exact maximum reaches 0 within ``tol`` of U_s,
    max_s q >= -tol U_s (:func:`bernstein_max`; against a curved rigid obstacle, ``departure``, the true slack
    q_h - delta as the feasibility check reads it). Every node of a touching element is active.

    A function of the displacement alone: the Bernstein duals beta are not unique where a run of elements
    touches, so which elements carry a force depends on the route; where q closes does not. By elements, not
    nodes: on a curved contact the bodies touch inside elements and the nodes beside the tangency are open
    (by c h^2 U_a), so a node rule finds no contact at all (the Hertz cylinder at n = 16, the sphere at
    n = 8). A closed node makes each of its elements touch, so the set contains every closed node."""
    q, U = cone_slack(blocks, u, g, r)
    elements = np.asarray(elements)
    width = elements.shape[1]
    b = (B @ q).reshape(-1, width)
    smax = bernstein_max(b) if departure is None else departure.argmax(b)[0]
    on = np.zeros(len(q), dtype=bool)
    on[elements[smax >= -tol * segment_scales(B, U, width)].ravel()] = True
    return on


def conic_checks(blocks, u, phi, r, B, g, beta, force_scale: float = 0.0, departure=None, pairing=None,
                 moved=None):
    """The checks of (26)-(27) for the P2 "everywhere" condition (docs/formulation.md §8, docs/checks.md).

    ``r`` = B^T beta is the nodal contact force on X_h (= M lambda_h), ``B`` (w S, n) the Bernstein map,
    ``g`` the gap at the nodes of X_h and ``beta`` (S, w) the Bernstein duals (w = 3 per merged segment, 6 per
    overlay triangle in 3D, §16). Per element s, with b_s the Bernstein coefficients of q = [u_h nu] - g_h,
    U_s the largest displacement scale of its nodes (both bodies' normal displacements and the gap), R_s the
    rounding of b_s in an exact answer (:func:`~cvxcontact.backends.finish.coefficient_rounding`: c_j eps times
    the size of the terms b_j adds up, (|B| T)_j, T_k = sum_l (|J_l| |u_l|)_k + |g_k| (+ ``moved``_k, the size of
    the force-controlled obstacles' translation terms in ``g``), c_j from how many roundings a term meets, the
    pairing's own w included) and Y the largest entry of beta (:func:`complementarity`):

        equilibrium      as in :func:`checks`, with M lambda_h = r                           (26)
        feasibility      max_s max_{element} q_s^+ / U_s   (exact: :func:`bernstein_max`)
        complementarity  max_s sqrt((|beta_s . b_s| - |beta_s| . R_s)^+ / (Y U_s))               (27)
        cone             max_s of the distance of beta_s to the dual cone (segments: beta0, beta2 >= 0,
                         beta1 >= 0, beta1 <= 2 sqrt(beta0 beta2); triangles: Z positive semidefinite
                         and non-negative), over Y

    ``force_scale``: a force scale (scaled) Y may not fall below, e.g. the compliance force of a P2
    penetration limit (docs/formulation.md §10), whose cone may carry no force at all.

    Against a curved rigid obstacle (``departure``, :class:`~cvxcontact.contact.truegap.GapDeparture`, scaled)
    the slack is the true one, q_h - delta: feasibility is its maximum over each element, complementarity
    beta_s . b_s - ``pairing``_s (the finish's point forces' sum y_p delta(x_p): their pairing with the true
    slack; None: 0, the duals read as the interpolant's).
    """
    tiny = np.finfo(float).tiny
    equilibrium = 0.0
    for blk, uk, pk in zip(blocks, u, phi):
        res = np.concatenate(blk.residual(uk, pk, r))
        m = np.concatenate(blk.magnitude(uk, pk, r))
        equilibrium = max(equilibrium, float(np.linalg.norm(res) / max(np.linalg.norm(m), tiny)))
    q, U = cone_slack(blocks, u, g, r)
    width = beta.shape[1]
    b = (B @ q).reshape(-1, width)
    Us = segment_scales(B, U, width)
    Y = max(float(np.abs(beta).max(initial=0.0)), float(force_scale), tiny)
    cone = element(width).dual_cone_violation(beta)
    smax = bernstein_max(b) if departure is None else departure.argmax(b)[0]
    # the rounding of b_s: b_j = sum_k B_jk q_k from the terms of q_k (docs/checks.md, "The rounding of b_s")
    T, n = slack_terms([blk.jump for blk in blocks], u, g, moved)
    rounding = coefficient_rounding(B, T, n, after=width).reshape(-1, width)
    return {
        "equilibrium": equilibrium,
        "feasibility": float((np.maximum(smax, 0.0) / Us).max(initial=0.0)),
        "complementarity": complementarity(beta, b, Y, Us, rounding, pairing),
        "cone": float(cone.max(initial=0.0) / Y),
    }


ENERGY_ERROR = "energy error"
"""The key of the conic condition's certified bound in ``Solution.residuals()`` (docs/checks.md)."""

CERTIFIED = ("feasibility", "complementarity", "cone")
"""The contact checks whose statement the certified bound replaces where it is the sharper one."""


def energy_error(blocks, u, phi, bound: float) -> float:
    """The certified bound ``bound`` on ||u - u*||_K (scaled; :func:`cvxcontact.backends.cuts.energy_bound`)
    relative to sqrt(sum_k u_k^T Kuu_k u_k + phi_k^T Kpp_k phi_k), the energy norm of the answer in the
    phi-form (twice its stored energy; docs/checks.md, "The certified bound")."""
    E = sum(float(uk @ (b.Kuu @ uk)) + (float(pk @ (b.Kpp @ pk)) if pk is not None else 0.0)
            for b, uk, pk in zip(blocks, u, phi))
    return float(bound / np.sqrt(max(E, np.finfo(float).tiny))) if np.isfinite(bound) else float("inf")


def compliance_checks(blocks, u, phi, E, g, weights, law, force, z=None):
    """Checks of a normal-compliance solution (docs/formulation.md §10, docs/checks.md), scaled units.

    ``law`` is one :class:`~cvxcontact.contact.laws.NormalCompliance` on every row or a per-row
    :class:`~cvxcontact.contact.laws.RowLaws` (pairs mixing Signorini and compliance; a Signorini row is
    k = 0 with the limit l = 0). With r = E [u_nu] - g at the constrained rows, w their lumped lengths,
    p the scaled law, z >= 0 the limit reaction (the Signorini multiplier on a Signorini row; zero
    without a limit) and ``force`` y the row forces the backend applied (w p(r) + z of the returned fields
    for an interior-point answer, the finish's force after an exact finish), the read-back is
    lambda = y / w (nodal values; p(r) on a row of weight 0) and the checks are

        equilibrium      the residual of (26) with the contact force E^T y (= E^T (w lambda)), as in
                         :func:`checks`
        law              max over the compliant rows a of |y_a - z_a - w_a p(r_a)| / (Y + w_a p'(r_a) U_a)
                         (the law (7) at the returned u; Y the largest row force, U_a = |E J u|_a + |g_a|
                         the row's displacement scale: the sizes of the law's two terms, so a stiff law is
                         checked to the rounding of u, not k times it)
        feasibility, complementarity, cone    of r <= l with multiplier z over the rows with a limit
                         (Signorini rows and compliance limits), as in :func:`checks` (only if some row
                         has one)

    All rows of all pairs are checked together, each normalised by its own scale. Returns (checks dict,
    lambda at the rows (scaled pressure)).
    """
    tiny = np.finfo(float).tiny
    parts = [E @ (b.jump @ uk) for b, uk in zip(blocks, u)]
    r = sum(parts) - g
    n = len(r)
    w = np.asarray(weights, dtype=float)
    z = np.zeros(n) if z is None else np.asarray(z, dtype=float)
    force = np.asarray(force, dtype=float)
    # lambda from the force the backend applied (= w p(r) + z of the returned fields for an interior-point
    # answer; the finish's own force after an exact finish: a stiff law reads r, a difference of displacements,
    # to rounding times k, the finish's force is not); the law between the two is checked below
    lam = np.divide(force, w, out=law.pressure(r) + 0.0, where=w > 0)
    applied = force                                # = w lambda; a reaction on a row of weight 0 kept
    c = E.T @ applied
    equilibrium = 0.0
    for b, uk, pk in zip(blocks, u, phi):
        res = np.concatenate(b.residual(uk, pk, c))
        m = np.concatenate(b.magnitude(uk, pk, c))
        equilibrium = max(equilibrium, float(np.linalg.norm(res) / max(np.linalg.norm(m), tiny)))
    Y = max(float(np.abs(force).max(initial=0.0)), tiny)
    compliant = np.broadcast_to(np.asarray(law.stiffness, dtype=float) > 0, (n,))
    # the law's residual against the sizes of its two terms (as equilibrium's |A| |x|): the force Y and the law's
    # change over the row's displacement scale, w p'(r) U (U = |E J u| + |g|): the backward error in u
    _, U = node_scales(parts, g)
    terms = Y + w * law.derivative(r) * U
    out = {"equilibrium": equilibrium,
           "law": float((np.abs(force - z - w * law.pressure(r)) / terms)[compliant].max(initial=0.0))}
    limit = law.penetration_limit
    limit = np.full(n, np.inf) if limit is None else np.broadcast_to(np.asarray(limit, dtype=float), (n,))
    on = np.isfinite(limit)
    if on.any():
        # the displacement each row's reaction z_a (the Signorini multiplier, or the limit's reaction) produces
        # (docs/checks.md): zero on rows off their limit; a row held at its limit where nothing else moves
        # (e.g. at a clamped corner) has no other scale, and its slack is rounding of the bodies' displacements
        extra = force_displacements(blocks, E, z)[on]
        slack, U = node_scales([p[on] for p in parts], g[on] + limit[on], extra)
        out["feasibility"] = float((np.maximum(slack, 0.0) / U).max(initial=0.0))
        out["complementarity"] = complementarity(z[on], slack, Y, U)
        out["cone"] = float(np.maximum(-z[on], 0.0).max(initial=0.0) / Y)
    return out, lam


def rigid_balance(block, modes, u, phi, Mlam, extra=None, *, prolongation, dim: int) -> float:
    """Balance of the rigid motions only the contact holds (scaled units; docs/checks.md, "Bodies held by the
    contact only").

    ``modes`` (k, n_free) are those motions in the body's reduced coordinates (T_u^T r): the stiffness
    does not see them (modes K_uu = 0, modes K_up = 0 exactly), so modes . r_k = modes . (J^T c - f)
    whatever u is, and it is normalised by |modes| (|f| + |J^T| |c|), the loads and contact forces
    on those motions alone, floored at FORCE_FLOOR of sum_a |r_a| |C_a|, the contact forces on the body whatever
    their direction: |r_a| the motion's displacement at node a and |C_a| the size of the node's contact forces (its
    components of |J^T| |c| and of ``extra``'s sizes), both Euclidean over the node's components (a bound of
    |r . C| that does not depend on the axes). A motion no force has a component along (a layer held along x by
    friction alone, unloaded along x, pressed along y) balances rounding, that of the forces across it and of the
    elastic forces: against the forces along it alone that is 0 / 0 (0.1 .. 0.5 measured), against the floor it is
    rounding; any unbalance along it above ``tol`` FORCE_FLOOR of the contact forces still reads above ``tol``.
    The loads f stay out of the floor: they carry the lifting of prescribed displacements, K u_D, the stiffness
    times a slide, not a force on the body. The equilibrium check's row scales |A| |x| cannot bound this: a large
    spurious rigid displacement x inflates them. ``u`` may equally be the body's deformation (its rigid fit taken
    out, :meth:`~cvxcontact.fem.rigidfit.RigidFit.deformation`): modes K_uu u does not change, and its rounding is
    then that of the deformation's elastic forces, not of how far the body moved. ``extra`` (force, size): further
    forces on the momentum rows and the sizes of their terms (e.g. a friction law's T^T mu and |T^T| |mu|).
    ``prolongation`` (dim n, n_free): the body's T_u (orthonormal columns; u = T_u z + u_D) and ``dim`` its
    dimension (the nodal components interleaved per node): the motions and the contact forces are read per node
    through it. Returns 0.0 without modes.
    """
    if modes is None or len(modes) == 0:
        return 0.0
    modes = np.asarray(modes, dtype=float)
    force, scale = (0.0, 0.0) if extra is None else extra
    r_u = block.residual(u, phi, Mlam)[0] + force
    contact = abs(block.jump).T @ np.abs(Mlam) + scale                       # the contact forces' sizes
    along = np.abs(modes) @ (contact + np.abs(block.f))                      # loads and contact forces along r
    per_node = np.linalg.norm((abs(prolongation) @ contact).reshape(-1, dim), axis=1)           # |C_a|
    motion = np.linalg.norm((prolongation @ modes.T).T.reshape(len(modes), -1, dim), axis=2)    # |r_a|
    floor = FORCE_FLOOR * (motion @ per_node)
    return float(np.max(np.abs(modes @ r_u) / np.maximum(np.maximum(along, floor), np.finfo(float).tiny)))


def obstacle_balance(force, rows, nodal_forces, friction=0.0) -> float:
    """Force balance of a force-controlled obstacle (docs/formulation.md §12, docs/checks.md):
    |F - sum_a c_a y_a - f_t| / |F| with F the prescribed force, c_a the rows' sensitivities ``rows``
    (n, 2) and y_a the nodal contact forces ``nodal_forces`` (n,), f_t the resultant of the friction forces on its
    pairs (``friction``, (d,); 0 without; any consistent units)."""
    F = np.asarray(force, dtype=float)
    return float(np.linalg.norm(F - rows.T @ nodal_forces - friction) / np.linalg.norm(F))
