"""A guaranteed upper bound of the discretisation error: an equilibrated stress and the Prager-Synge
inequality with contact (docs/accuracy.md, "A guaranteed bound").

One elastic body, gap g on Gamma_3, rows d . v <= g along one direction d per pair, K = {v in V : d . v <= g
on Gamma_3}, u = argmin_K J, J(v) = 1/2 a(v, v) - l(v). For a stress tau that is statically admissible
(div tau + f = 0, tau n = t on traction parts, tau n = 0 on free parts, tau n = -p d with p >= 0 on
Gamma_3; on a roller the tangential traction 0, on a part with prescribed components the free ones 0) and
any v in K:

    |||u - v|||^2 <= || C^{-1/2} (C eps(v) - tau) ||^2 + 2 int_{Gamma_3} p (g - d . v)                (PS)

(integrate tau : eps(u - v) by parts; J(v) - J(u) >= 1/2 |||u - v|||^2 as u minimises J on K, and
-J(u) <= 1/2 int C^{-1} tau : tau + int p g as d . u <= g). Both terms are computed exactly (the second by
5-point Gauss on each edge: exact for a plane, to rounding for a smooth obstacle).

tau: piecewise linear symmetric on the Clough-Tocher split of every triangle (three sub-triangles at the
barycentre; the Johnson-Mercier space), H(div)-conforming. Its nodal values solve

    min || C^{-1/2} (C eps(v) - tau) ||^2  subject to  A tau = b,

A the normal-traction continuity across every sub-triangle edge, div tau = -f on every sub-triangle (f
constant) and the boundary conditions above at the two ends of each boundary edge (tau n is linear there, so
the conditions hold everywhere on it). The equality-constrained minimum is one sparse solve with the
Schur complement A M^-1 A^T (M the compliance mass matrix, block diagonal), regularised and refined to
rounding; the residual of A tau = b is checked.

p: (PS) holds for any p >= 0 (P1 on the contact nodes, the merged nodes of a pair) and any admissible tau that
carries it, so p minimises the right-hand side of (PS) jointly with tau. b = b0 + B p is linear in p, so
each body's stress term, y^T S y with S y = b0 + B p - A tau0, is quadratic in p and the complementarity is
c . p (c_j = 2 int phi_j (g - d . v) >= 0): one small non-negative least-squares problem (exact active set)
over the p at the nodes of the solution's lumped pressure's support widened by two nodes each side (0
elsewhere), then tau solved for that p as above. The lumped pressure (the row forces over the lumped
lengths: oscillating between neighbours where the contact ends at a corner) is kept if it reads lower or the
active set does not settle.

v in K: u_h satisfies the rows at the nodes only; a curved obstacle (``distance="ray"``: g convex along the
part) is violated between them. v = u_h - w with w = a_i d at the contact nodes (0 elsewhere), a_i the
largest violation max_E (d . u_h - g)^+ on the edges at node i (maximised per edge by golden section: exact
for a convex g), so d . v <= g on every edge, and

    |||u - u_h||| <= |||u - v||| + |||w|||   (the bound reported).

A piezoelectric body (docs/accuracy.md, "Piezoelectric bodies"): the coupled energy norm |||(e_u, e_phi)|||^2 =
a(e_u, e_u) + b(e_phi, e_phi) (the skew coupling cancels), the coupled law sigma = c eps + e^T grad phi,
D = e eps - kappa grad phi, and an equilibrated electric displacement D~ (div D~ = q0, D~ . n = q2 on charged
edges, 0 on the other non-electrode edges, total flux -Q through each floating electrode) give, for v in K,

    |||(u - v, phi - phi_h)|||^2 <= || c^{-1/2} (tau - sigma(v, phi_h)) ||^2
                                   + || kappa^{-1/2} (D~ - D(v, phi_h)) ||^2 + 2 int_{Gamma_3} p (g - d . v)   (PS-e)

(the dual of the energy norm is block diagonal: the coupling enters through sigma(v, phi_h) and D(v, phi_h)).
tau is built as above from sigma(v, phi_h); D~ is the Raviart-Thomas (RT0) field closest to D(v, phi_h) in
|| kappa^{-1/2} . ||: one global sparse solve over the edge fluxes.

Pairs of deformable bodies (docs/accuracy.md, "Pairs of deformable bodies"): K = {v : [v . nu] <= g on
Gamma_3}, [v . nu] = v^1 . nu^1 + v^2 . nu^2; each body's tau carries -p nu^k on Gamma_3 with one p >= 0 (P1
on the merged mesh, minimising the bound over both bodies' stresses at once), so tau^1 n^1 = -tau^2 n^2, and
(PS) holds with the sum of the bodies' stress terms and 2 int p (g - [v . nu]). tau^k is built on the body's
reconstruction mesh: the cells along Gamma_3 divided at the other body's nodes (a fan from the opposite
vertex), so that p is linear on each of its contact edges. The correction w covers the largest violation of each merged segment on both sides'
traces, shared theta : 1 - theta at least energy. A rigid obstacle is the one-sided case (no division).

Covered (:data:`COVERED`); others raise :class:`~cvxcontact.errors.UnsupportedError` naming what is.

This module assembles the bound: the coverage, p, the correction w and the terms of (PS), (PS-e); the
equilibrated tau and D~ themselves are built in :mod:`cvxcontact.solution.equilibration`.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import nnls

from ..contact.interface import lumped_lengths, row_directions
from ..errors import SceneError, SolverError, UnsupportedError
from ..fem.space import space
from .equilibration import body_stress, body_system, mesh_edges
from .estimate import ErrorEstimate, cell_energies, read_only

__all__ = ["COVERED", "check_covered", "equilibrated_displacement", "equilibrated_stress", "error_bound",
           "reconstruction_mesh"]

COVERED = ("2D P1, elastic or piezoelectric bodies against fixed rigid obstacles whose rows keep one direction "
           "(a plane, or a curved obstacle with distance='ray') and in pairs under condition 'gamma3', the Signorini law, a constant body force and "
           "constant tractions; constant volume and surface charges, grounded, driven and floating electrodes")
"""What :func:`error_bound` covers."""

_GAUSS5 = np.polynomial.legendre.leggauss(5)
_ZONE_MARGIN = 2               # merged nodes beyond the lumped pressure's support where the optimised p may be > 0


def _refuse(what: str):
    raise UnsupportedError(f"the equilibrated error bound does not cover {what}; it covers {COVERED} "
                           "(use the residual estimate, estimate=True, there)")


def check_covered(scene, degree: int = 1, law=None, condition: str = "gamma3") -> None:
    """Raise :class:`UnsupportedError` naming what is not covered (:data:`COVERED`) by the bound of a
    solve of ``scene`` with ``degree``, the default contact ``law`` and ``condition``; None if covered."""
    if scene.dim == 2 and not space(1, scene.cell).bounded:         # the cells themselves (quadrilaterals)
        _refuse(f"{scene.cell} cells")
    if scene.dim != 2:
        _refuse(f"3D ({scene.cell} cells)")
    if not space(degree, scene.cell).bounded:
        _refuse("P2 elements (degree=2)")
    for i, c in enumerate(scene.contacts):
        if not c.rigid and (scene.conditions[i] or condition) != "gamma3":
            _refuse(f"contacts[{i}]: a pair of deformable bodies under condition "
                    f"{scene.conditions[i] or condition!r} (rows at one body's nodes leave the jump between them "
                    "unchecked; solve with condition='gamma3')")
    for body in scene.bodies:
        if body.piezoelectric and (callable(body.volume_charge.value)
                                   or any(callable(q.value) for q in body.surface_charge.values())):
            _refuse("volume or surface charges given as functions (give constants)")
        if callable(body.body_force.value) or any(callable(t.value) for t in body.traction.values()):
            _refuse("body forces or tractions given as functions (give constants)")
    laws = [law, *(c.law for c in scene.contacts)]
    if any(getattr(x, "compliant", False) for x in laws):
        _refuse("normal compliance")
    if any(getattr(x, "friction", None) is not None for x in laws):
        _refuse("friction (the bound's stress has no tangential traction on Gamma_3)")
    if any(c.rigid and c.other.force is not None for c in scene.contacts):
        _refuse("force-controlled obstacles")
    for i in range(len(scene.contacts)):
        d = np.atleast_2d(row_directions(scene.interfaces[i], scene.interfaces[i].normal))
        if np.abs(d - d[0]).max() > 1e-12:
            _refuse(f"contacts[{i}]: rows whose direction turns along the part (a curved obstacle posed at the "
                    "closest point; distance='ray' keeps the part's normal)")


# ---------------------------------------------------------------------------------------------- the bound


def _body(sol, body) -> int:
    """``body`` checked as the index of one of ``sol``'s bodies (SceneError naming the valid range)."""
    n = len(sol.scene.bodies)
    if isinstance(body, bool) or not isinstance(body, (int, np.integer)) or not 0 <= body < n:
        raise SceneError(f"body must be the index of one of the solution's {n} bodies, an integer 0 to {n - 1} "
                         f"(the order of cc.Scene(...)), got {body!r}")
    return int(body)


def equilibrated_stress(sol, body: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(tau, v) of body ``body`` of ``sol`` (module docstring): tau (3m, 3, 3) the equilibrated stress (Pa, Voigt
    xx, yy, xy) at the vertices (v_s, v_s+1, barycentre) of sub-triangle 3 c + s of cell c of the body's
    reconstruction mesh (:func:`reconstruction_mesh`: its mesh, the cells along a pair's Gamma_3 divided at the
    other body's nodes), linear in between; v (n, 2) the admissible displacement u_h - w (m) at that mesh's
    nodes. UnsupportedError for a case not covered (:data:`COVERED`)."""
    part = _construct(sol)["bodies"][_body(sol, body)]
    return part["tau"].reshape(-1, 3, 3), part["v"]


def reconstruction_mesh(sol, body: int = 0):
    """The mesh on which :func:`equilibrated_stress` builds the stress of body ``body`` of ``sol``: the body's
    mesh with each edge of a pair's contact part divided at the other body's nodes inside it (the cells along it
    divided into fans from the opposite vertex; the same tags); the body's mesh itself against rigid obstacles.
    Returns (mesh, parent (m',): the body's cell each of its cells lies in)."""
    part = _construct(sol)["bodies"][_body(sol, body)]
    return part["mesh"], part["parent"]


def equilibrated_displacement(sol, body: int = 0) -> np.ndarray:
    """The equilibrated electric displacement D~ of piezoelectric body ``body`` of ``sol`` (docs/accuracy.md,
    "Piezoelectric bodies"): (m, 3, 2) C/m^2 at the vertices of every triangle of its mesh, linear in between (a
    Raviart-Thomas field). UnsupportedError for a case not covered (:data:`COVERED`) or an elastic body."""
    body = _body(sol, body)
    if not sol.scene.bodies[body].piezoelectric:
        raise UnsupportedError(f"equilibrated_displacement: body {body} is elastic (no electric displacement); "
                               "give a solution of a piezoelectric body")
    return _construct(sol)["bodies"][body]["D"]


def error_bound(sol) -> ErrorEstimate:
    """The guaranteed upper bound (PS) of |||u - u_h||| of ``sol`` (module docstring; summed over the bodies):
    an :class:`ErrorEstimate` of kind "equilibrated", ``guaranteed`` True, ``parts`` the squared terms
    ("stress", "electric", "complementarity", J/m), the feasibility correction's norm |||w||| ("correction",
    sqrt(J/m)) and the relative residual of the equilibrium conditions ("equilibrium residual"); ``indicators``
    per body and triangle: (stress + electric + complementarity)^(1/2) of the cell (a pair's complementarity
    in the first body's cells). UnsupportedError for a case not covered (:data:`COVERED`); SolverError if a
    stress could not be equilibrated to rounding."""
    b = _construct(sol)
    eta2, stress, electric, correction2, norm2 = [], 0.0, 0.0, 0.0, 0.0
    for k, part in enumerate(b["bodies"]):
        body = sol.scene.bodies[k]
        compliance = np.linalg.inv(body.material.tensors(2)[0])
        # || C^-1/2 (C eps(v) - tau) ||^2 per sub-triangle, exact: (area / 12) [[2,1,1],..] kron C^-1
        e = (part["tau"] - part["tau0"]).reshape(-1, 3, 3)
        K3 = np.array([[2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0]]) / 12.0
        sub = part["area"] * np.einsum("skc,kl,cd,sld->s", e, K3, compliance, e)
        cell = np.bincount(np.repeat(part["parent"], 3), sub, minlength=part["m"])
        stress += float(cell.sum())
        electric += float(part["electric"].sum())
        eta2.append(cell + part["electric"])
        zero = None if part["phi_h"] is None else np.zeros_like(part["phi_h"])
        correction2 += float(cell_energies(body, b["w"][k], zero, 1).sum())
        norm2 += float(cell_energies(body, b["u_h"][k], part["phi_h"], 1).sum())
    comp = 0.0
    for cd in b["contacts"]:
        term = cd["term"](b["v"], cd["p"])
        comp += float(term.sum())
        np.add.at(eta2[cd["owner_body"]], cd["cells"], term)
    correction = float(np.sqrt(max(correction2, 0.0)))
    total = float(np.sqrt(max(stress + electric + comp, 0.0))) + correction
    parts = {"stress": stress, "electric": electric, "complementarity": comp, "correction": correction,
             "equilibrium residual": b["residual"]}
    return ErrorEstimate(absolute=total, norm=float(np.sqrt(max(norm2, 0.0))),
                         indicators=tuple(read_only(np.sqrt(np.maximum(e2, 0.0))) for e2 in eta2),
                         parts=parts, guaranteed=True, kind="equilibrated")


def _construct(sol) -> dict:
    """The admissible v = u_h - w, the equilibrated tau of every body and what the bound needs of them (module
    docstring)."""
    scene = sol.scene
    check_covered(scene, sol.degree, getattr(sol, "law", None), getattr(sol, "condition", "gamma3"))
    for c in sol.contacts:
        if getattr(c.law, "compliant", False):
            _refuse("normal compliance")
    u_h = [np.asarray(u, dtype=float) for u in sol.u]
    contacts = [_contact_data(sol, i, u_h) for i in range(len(scene.contacts))]
    n_p = 0                                         # the pairs' pressures, one vector: pair i at offset + ...
    for cd in contacts:
        cd["offset"] = n_p
        for side in cd["sides"]:
            side["offset"] = n_p
        n_p += len(cd["x"])
    w = [np.zeros_like(u) for u in u_h]
    for cd in contacts:
        for k, wk in cd["w"]:
            w[k] += wk
    v = [u - wk for u, wk in zip(u_h, w)]
    systems = []
    for k, body in enumerate(scene.bodies):
        phi_h = None if sol.phi[k] is None else np.asarray(sol.phi[k], dtype=float)
        loads = [side for cd in contacts for side in cd["sides"] if side["body"] == k]
        systems.append(body_system(sol, body, v[k], phi_h, loads, n_p))
    c = np.concatenate([np.zeros(0), *(cd["weights"](v) for cd in contacts)])
    lumped = np.concatenate([np.zeros(0), *(cd["lumped"] for cd in contacts)])
    p = _pressure(systems, c, lumped, np.concatenate([np.zeros(0, dtype=bool), *(cd["zone"] for cd in contacts)]))
    try:
        bodies = [body_stress(sol, body, system, p) for body, system in zip(scene.bodies, systems)]
    except SolverError:
        # a body held by its contacts alone (rollers on its sides, pressed by its loads) carries only a p that
        # balances them; the minimiser prices (PS) on the conditions' range and may miss that balance, the
        # lumped pressure (the rows' forces) has it
        if p is lumped or np.array_equal(p, lumped):
            raise
        p = lumped
        bodies = [body_stress(sol, body, system, p) for body, system in zip(scene.bodies, systems)]
    for cd in contacts:
        cd["p"] = p[cd["offset"]:cd["offset"] + len(cd["x"])]
    residual = max((part["residual"] for part in bodies), default=0.0)
    return {"bodies": bodies, "contacts": contacts, "w": w, "v": v, "u_h": u_h, "residual": residual}


def _pressure(systems, c, lumped, zone):
    """The contact pressures p >= 0 (n_p,) that minimise the bound's square (PS) over (tau, p) jointly
    (docs/accuracy.md, "A guaranteed bound"): each body's tau is the M-closest to C eps(v) with
    A tau = b + B p, so its stress term is y^T S y with S y = b + B p - A tau0, quadratic in p; the
    complementarity is c . p (``c``: each hat function's 2 int (g - [v . nu]) >= 0). One small dense
    non-negative least-squares problem (exact active set) over the pressures where ``zone`` (n_p,) is True (0
    elsewhere); ``lumped`` (the solution's lumped pressures, >= 0, inside the zone) if it reads lower or the
    active set does not settle. Any p >= 0 that an admissible tau carries keeps (PS) a bound: the choice only
    sharpens it (a body held by its contacts alone needs p to balance its loads: :func:`_construct` falls back to
    the lumped pressure where the chosen one does not)."""
    n_p = len(c)
    free = np.flatnonzero(zone)
    if not len(free):
        return lumped
    H, q = np.zeros((n_p, n_p)), 0.5 * c
    for system in systems:
        B = system["B"].tocsc()
        cols = np.intersect1d(np.flatnonzero(np.diff(B.indptr)), free)
        if not len(cols):
            continue
        r0 = system["rhs"] - system["A"] @ system["tau0"]
        Z = system["lu"].solve(np.column_stack([r0, B[:, cols].toarray()]))
        G = Z.T @ (system["S"] @ Z)
        H[np.ix_(cols, cols)] += 0.5 * (G[1:, 1:] + G[1:, 1:].T)
        q[cols] += G[1:, 0]

    def f(p):                                        # the bound's square up to a constant
        return p @ H @ p + 2.0 * q @ p

    scale = np.sqrt(np.maximum(np.diag(H), 0.0))
    on = (scale > 1e-300) & zone
    p = np.zeros(n_p)
    if on.any():
        Hs = H[np.ix_(on, on)] / np.outer(scale[on], scale[on])
        lam, V = np.linalg.eigh(Hs)
        keep = lam > 1e-13 * lam.max()
        root = np.sqrt(lam[keep])
        try:
            z, _ = nnls(root[:, None] * V[:, keep].T, -(V[:, keep].T @ (q[on] / scale[on])) / root,
                        maxiter=50 * n_p)
        except RuntimeError:                         # the active set did not settle: the lumped pressure
            return lumped
        p[on] = z / scale[on]
    return p if f(p) <= f(lumped) else lumped


def _contact_data(sol, i, u_h):
    """Pair ``i`` (module docstring, "Pairs"): on its merged mesh x (s = x . t, m) the pressure p >= 0 (lumped:
    the row forces over the lumped lengths; P1 on x), per side (each body of the pair) its row direction d, the
    breakpoints of the other side inside its edges and the load -p d it carries; the correction w (on one
    side's trace, along its d) that makes [v . nu] <= g everywhere; the complementarity term
    2 int p (g - [v . nu]) of each merged segment (5-point Gauss: exact for a polynomial gap of at most eighth degree)
    and the cell of the first body holding it."""
    scene = sol.scene
    itf, res = scene.interfaces[i], sol.contacts[i]
    members = scene.stack.members[i]
    x = np.asarray(itf.x, dtype=float)
    if not np.asarray(res.constrained, dtype=bool).all() or len(res.x) != len(x):
        _refuse(f"contacts[{i}]: rows at some merged nodes only (condition 'sigma1' or 'sigma2'; the jump "
                "between them is unchecked): solve with condition='gamma3'")
    p_merged = np.maximum(np.asarray(res.force, dtype=float), 0.0) / lumped_lengths(x)
    tol = 1e-9 * max(b.mesh.size for b in scene.bodies)
    sides = []
    jump_h = np.zeros(len(x))
    for k, trace in enumerate(itf.traces):
        d = np.atleast_2d(row_directions(itf, trace.unit_normal))[0]
        body = members[k]
        jump_h += itf.interpolation(k) @ (u_h[body][trace.nodes] @ d)
        mine = np.zeros(len(x), dtype=bool)
        mine[itf.sigma[k]] = True
        sides.append(dict(body=body, part=trace.part, d=d, trace=trace, x=x, tol=tol,
                          tangent=np.asarray(itf.tangent, dtype=float),
                          breaks=(np.asarray(itf.tangent, dtype=float), x[~mine])))

    def gap(s):
        return scene.pair_gap_values(i, s.ravel()).reshape(s.shape)

    # the largest violation [u_h . nu] - g on each merged segment: samples, then golden section around the best
    s0, s1 = x[:-1], x[1:]
    ts = np.linspace(0.0, 1.0, 33)
    ja, jb = jump_h[:-1], jump_h[1:]

    def violation(tt):
        return (1 - tt) * ja[:, None] + tt * jb[:, None] - gap(s0[:, None] + tt * (s1 - s0)[:, None])

    val = violation(np.broadcast_to(ts, (len(s0), len(ts))))
    kbest = val.argmax(axis=1)
    lo, hi = ts[np.maximum(kbest - 1, 0)], ts[np.minimum(kbest + 1, len(ts) - 1)]
    golden = (np.sqrt(5.0) - 1) / 2
    for _ in range(60):
        x1, x2 = hi - golden * (hi - lo), lo + golden * (hi - lo)
        f1, f2 = violation(x1[:, None])[:, 0], violation(x2[:, None])[:, 0]
        left = f1 > f2
        hi, lo = np.where(left, x2, hi), np.where(left, lo, x1)
    worst = np.maximum(np.maximum(val.max(axis=1), violation(0.5 * (lo + hi)[:, None])[:, 0]), 0.0)
    # a violation at the rounding of [u_h . nu] and g is not one: the finish closes the active rows to rounding,
    # and correcting it would move a supported node by rounding and flip the split below (measured: the stack's
    # bound 65.8 or 64.8 by the BLAS kernels' rounding of two 1e-20 m violations)
    worst[worst <= 1e-12 * max(float(np.abs(jump_h).max(initial=0.0)), float(np.abs(gap(x)).max(initial=0.0)),
                               np.finfo(float).tiny)] = 0.0
    w = _correction(sol, i, sides, worst, u_h)

    # the first body's cell over each merged segment
    first = sides[0]["trace"]
    mesh_a = scene.bodies[members[0]].mesh
    n_a = len(mesh_a.points)
    seg = np.clip(np.searchsorted(first.x, 0.5 * (s0 + s1)) - 1, 0, len(first.x) - 2)
    ea, eb = first.nodes[seg], first.nodes[seg + 1]
    cells_a, _, pairs_a = mesh_edges(mesh_a)
    key_all = pairs_a[:, 0].astype(np.int64) * n_a + pairs_a[:, 1]
    owner = cells_a[np.searchsorted(key_all, np.minimum(ea, eb).astype(np.int64) * n_a + np.maximum(ea, eb)), 0]
    tq, wq = 0.5 * (_GAUSS5[0] + 1.0), 0.5 * _GAUSS5[1]
    g_q = gap(s0[:, None] + tq[None] * (s1 - s0)[:, None])                     # (k, 5)
    length = s1 - s0

    def slack(v):
        """2 |segment| (g - [v . nu]) at the Gauss points times their weights (k, 5)."""
        jump = sum(itf.interpolation(k) @ (v[sd["body"]][sd["trace"].nodes] @ sd["d"]) for k, sd in enumerate(sides))
        jq = (1 - tq)[None] * jump[:-1, None] + tq[None] * jump[1:, None]
        return 2.0 * length[:, None] * (g_q - jq) * wq[None]

    def term(v, p):
        """2 int p (g - [v . nu]) on each merged segment, for the pressure p (len(x),) P1 on the merged mesh."""
        return (((1 - tq)[None] * p[:-1, None] + tq[None] * p[1:, None]) * slack(v)).sum(axis=1)

    def weights(v):
        """c (len(x),): 2 int p (g - [v . nu]) = c . p (the hat functions' integrals against the slack)."""
        q = slack(v)
        return np.bincount(np.arange(len(x) - 1), q @ (1 - tq), len(x)) + np.concatenate([[0.0], q @ tq])

    # where p may be positive: the lumped pressure's support widened by _ZONE_MARGIN merged nodes each side
    zone = np.zeros(len(x), dtype=bool)
    loaded = np.flatnonzero(p_merged > 0)
    if len(loaded):
        zone[max(loaded[0] - _ZONE_MARGIN, 0):loaded[-1] + _ZONE_MARGIN + 1] = True
    return {"sides": sides, "w": w, "cells": owner, "owner_body": members[0], "term": term, "weights": weights,
            "x": x, "lumped": p_merged, "zone": zone}


def _correction(sol, i, sides, worst, u_h):
    """[(body, w)]: the correction of pair ``i`` (module docstring): on a side's trace, w = a_j d at its nodes,
    a_j the largest violation ``worst`` (per merged segment) over the segments inside the trace's edges at node
    j, so that [u_h . nu] - a <= g everywhere. Shared theta : 1 - theta between the two sides of a pair when no
    support holds either (theta = e_b / (e_a + e_b) for the energies e of the full correction on each side:
    the least energy of the split, e_a e_b / (e_a + e_b)); else all on the side no support holds."""
    full, message = [], None
    for side in sides:
        trace, k = side["trace"], side["body"]
        body = sol.scene.bodies[k]
        x = side["x"]
        a = np.zeros(len(trace.x))
        seg = np.clip(np.searchsorted(trace.x, 0.5 * (x[:-1] + x[1:])) - 1, 0, len(trace.x) - 2)
        np.maximum.at(a, seg, worst)
        np.maximum.at(a, seg + 1, worst)
        w = np.zeros_like(u_h[k])
        w[trace.nodes] = a[:, None] * side["d"][None]
        held = _held(body, w)
        if held is None:
            zero = None if sol.phi[k] is None else np.zeros(len(w))
            full.append((k, w, float(cell_energies(body, w, zero, 1).sum())))
        message = message or held
    if not full:
        _refuse(message)
    if len(full) == 1 or full[0][2] + full[1][2] <= 0.0:
        return [full[0][:2]]
    (ka, wa, ea), (kb, wb, eb) = full
    theta = eb / (ea + eb)
    return [(ka, theta * wa), (kb, (1.0 - theta) * wb)]


def _held(body, w) -> str | None:
    """What is wrong if the correction w moves a node a support holds (it would leave the space V), else None."""
    moved = np.flatnonzero(np.abs(w).max(axis=1) > 0)
    if not len(moved):
        return None
    mesh = body.mesh
    for tag in [*body.clamped, *body.displacement]:
        hit = np.intersect1d(moved, mesh.boundary(tag))
        if len(hit):
            return f"a contact part whose admissible correction moves node {hit[0]} of the supported part {tag!r}"
    for tag in body.roller:
        n = mesh.outward_normals(tag).mean(axis=0)
        hit = np.intersect1d(moved, mesh.boundary(tag))
        if len(hit) and np.abs(w[hit] @ n).max() > 0:
            return f"a contact part whose admissible correction moves node {hit[0]} across the roller {tag!r}"
    return None
