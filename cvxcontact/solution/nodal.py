"""The read-backs of the nodal contact terms (docs/formulation.md §4, §8, §10): a backend's
:class:`~cvxcontact.backends.result.RawResult` on a :class:`~cvxcontact.discrete.DiscreteProblem` -> a
:class:`~cvxcontact.solution.Solution` in SI with lambda_h and the checks of its law (docs/checks.md). One
read-back per term, which names it (``term.read_back``, :mod:`cvxcontact.discrete.terms`):

- :func:`read_back_nodal`: Signorini rows (:class:`~cvxcontact.discrete.terms.SignoriniRows`);
- :func:`read_back_cones`: the P2 "everywhere" cones (:class:`~cvxcontact.discrete.terms.EverywhereCones`);
- :func:`read_back_compliance`: a normal-compliance law on some rows
  (:class:`~cvxcontact.discrete.terms.ComplianceRows`);
- :func:`read_back_conic_mix`: the cones beside a compliance law
  (:class:`~cvxcontact.discrete.terms.ConesBesideCompliance`).

The first two share :func:`_assembled` (lambda_h, the jumps, the bodies' balance, the fields, the pairs' results)
and differ in their checks and in which nodes they call constrained and active.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse.linalg as spla

from ..backends.finish.forces import RowReach
from .checks import (
    ENERGY_ERROR,
    checks,
    compliance_checks,
    conic_checks,
    energy_error,
    rigid_balance,
    touching_nodes,
)
from .info import Route, SolveInfo, Status
from .sides import side_multiplier
from .solution import (
    ContactResult,
    Solution,
    electrode_rows,
    electrodes,
    line_offset,
    pair_lines,
)

__all__ = ["read_back_nodal", "read_back_cones", "read_back_compliance", "read_back_conic_mix"]


def _fields(problem, raw):
    """The names the read-backs share, from a problem and a raw result (scaled)."""
    return (problem.scene, problem.condition, problem.blocks, problem.systems, problem.units, problem.E,
            problem.moved_gap(raw.taus), raw.u, raw.phi)


def read_back_nodal(problem, raw, tol: float, timings) -> Solution:
    """Scaled (u, phi, y) of ``raw`` -> a Solution in SI with lambda_h and the checks of (26)-(27) at Signorini's
    nodal rows (the term :class:`~cvxcontact.discrete.terms.SignoriniRows`; P1 and P2 sigma conditions):
    ``raw.y`` the row forces, ``raw.active`` the closed rows, the gap the one force-controlled obstacles moved
    to. The constrained nodes are those the rows read, the active ones those the closed rows read."""
    blocks, E, gap, u, phi = problem.blocks, problem.E, problem.moved_gap(raw.taus), raw.u, raw.phi
    y = raw.y
    reach = problem.shared("row reach", lambda: RowReach(blocks, E), rows=True)     # the matrices' part, kept
    checks_ = checks(blocks, u, phi, E.T @ y, E, E @ gap, y,   # the row forces (3D: M lam = E^T y on the traces)
                     abs(E) @ problem.translation_sizes(raw.taus) if raw.taus else None, problem.rigid_fits, reach)
    on = np.zeros(problem.interface.size, dtype=bool)
    on[np.flatnonzero(np.asarray(abs(E[np.flatnonzero(raw.active)]).sum(axis=0)).ravel() > 0)] = True
    return _assembled(problem, raw, tol, timings, checks_, E, on)


def read_back_cones(problem, raw, tol: float, timings) -> Solution:
    """The Solution of the P2 "everywhere" cones (the term :class:`~cvxcontact.discrete.terms.EverywhereCones`;
    docs/formulation.md §8): ``raw.beta`` (S, 3) are the Bernstein duals of each merged segment, ``raw.y`` the
    nodal force r = B^T beta on X_h and M lambda_h = r; the cone's rows (B, segments) are ``problem.lines.cone``.
    Checks: :func:`~cvxcontact.solution.checks.conic_checks` (and the certified energy error where the route
    computed one); the constrained nodes those B reads, the active ones the nodes of the elements where the
    contact closes somewhere (:func:`~cvxcontact.solution.checks.touching_nodes` at ``tol``: a function of the
    displacement alone, not of the duals beta, which are not unique where runs of segments touch)."""
    blocks, E, gap, u, phi, beta = problem.blocks, problem.E, problem.moved_gap(raw.taus), raw.u, raw.phi, raw.beta
    B, elements = problem.lines.cone_on_nodes        # (beside a nodal pair a friction law's cones sit on E's rows)
    checks_ = conic_checks(blocks, u, phi, E.T @ raw.y, B, gap, beta, departure=problem.departure,
                           pairing=raw.pairing, moved=problem.translation_sizes(raw.taus) if raw.taus else None)
    if raw.certificate is not None:
        checks_[ENERGY_ERROR] = energy_error(blocks, u, phi, raw.certificate)
    on = read_columns(B) & touching_nodes(blocks, u, gap, E.T @ raw.y, B, elements, tol, departure=problem.departure)
    return _assembled(problem, raw, tol, timings, checks_, B, on)


def read_columns(rows) -> np.ndarray:
    """The columns (nodes) the sparse ``rows`` read (bool per column)."""
    return np.asarray(abs(rows).sum(axis=0)).ravel() > 0


def _assembled(problem, raw, tol: float, timings, checks_: dict, support, on) -> Solution:
    """What every nodal read-back shares: lambda_h (M lambda_h = E^T y), the jumps, the bodies' balance under the
    contact force (added to ``checks_``' "equilibrium"), the energy, the fields in SI, a
    :class:`ContactResult` per pair (``constrained``: the merged nodes the rows ``support`` read; ``on``: the
    active ones), a provisional SolveInfo."""
    scene, condition, blocks, systems, un, E, gap, u, phi = _fields(problem, raw)
    y, polished, problem_, nodes = raw.y, raw.polished, raw.program, problem.meshes
    trace = problem.space.trace
    itf = problem.interface
    interface = trace.kept(itf)
    Ety = E.T @ y
    compliant = [i for i, law in enumerate(getattr(problem.rows, "laws", ())) if law.compliant]   # their own law's
    shift = problem.prescribed_jump        # [u_D nu] (the blocks' jumps act on the free unknowns only)
    jump = sum(b.jump @ uk for b, uk in zip(blocks, u)) + shift
    sizes = sum(np.abs(b.jump @ uk) for b, uk in zip(blocks, u)) + np.abs(shift)      # the terms of the jump
    reach = max(float(sizes.max(initial=0.0)), *(float(np.abs(uk).max(initial=0.0)) for uk in u))   # the bodies'
    # displacement scale; per node with its own gap, not another row's: a floor 1000 m below, never touched, read
    # a floor open by 3e-6 m under a strip raised above it (0.3 DELTA) closed at tol 1e-6 (its share of lambda_h)
    scale = np.maximum(reach, np.abs(gap + shift))
    closed = on | (gap + shift - jump <= tol * scale)          # each pair's contact closed, per node (sides.py)
    lam = side_multiplier(itf, Ety, compliant, closed)   # scaled; the Riesz representer in X_h (M lam = E^T y)
    for k, (b, s, blk, uk, pk) in enumerate(zip(scene.bodies, systems, blocks, u, phi)):
        modes = b.held_modes(nodes[k])                                        # bodies held by the contact only
        if len(modes):
            balance = rigid_balance(blk, (s.Tu.T @ modes.T).T, uk, pk, Ety, prolongation=s.Tu, dim=b.dim)
            checks_["equilibrium"] = max(checks_["equilibrium"], balance)
    energy = sum(b.energy(uk, pk) for b, uk, pk in zip(blocks, u, phi)) * un.force * un.displacement
    u_si, phi_si = [], []
    for s, b, uk, pk in zip(systems, scene.bodies, u, phi):
        full = s.u_fixed + s.Tu @ (uk * un.displacement)                  # u = T_u z + u_D
        u_si.append(full.reshape(-1, problem.dim))
        if pk is None:                            # elastic, or every potential prescribed (phi = phi_D)
            phi_si.append(s.phi_fixed.copy() if s.piezoelectric else None)
            continue
        phi_si.append(s.phi_fixed + s.Tp @ (pk * un.potential))          # phi = T_p z + phi_D
    constrained = read_columns(support)                                                        # the rows' nodes
    contacts = []
    pairs, offsets = pair_lines(scene, interface)
    for i, pair in enumerate(pairs):                  # each pair's slice of the stacked rows
        part = slice(offsets[i], offsets[i + 1])
        cond = condition if scene.conditions[i] is None else scene.conditions[i]
        measure = trace.measure(pair, cond)           # the rows' quadrature weights (lengths or areas), or None
        rows = np.flatnonzero(read_columns(E[:, part].T))   # the pair's rows (each reads its own pair's nodes only)
        row_pressure = trace.row_pressure(pair, cond, E[rows][:, part], y[rows] * un.force)  # P2: y_a / w_a; M p = y
        contacts.append(ContactResult(
            x=pair.x.copy(), lam=lam[part] * un.force, jump=jump[part] * un.displacement,
            force=Ety[part] * un.force, constrained=constrained[part].copy(), active=on[part].copy(), line=line_offset(pair),
            gap=(gap + shift)[part] * un.displacement, points=pair.points.copy(), normal=np.array(pair.normal, dtype=float),
            degree=trace.degree, scale=float(sizes[part].max(initial=0.0)) * un.displacement, measure=measure,
            row_pressure=row_pressure))
    for a in [*u_si, *(p for p in phi_si if p is not None), *(getattr(c, f) for c in contacts for f in
              ("x", "lam", "jump", "force", "constrained", "active", "gap", "points", "normal", "measure",
               "row_pressure")
              if getattr(c, f) is not None)]:
        a.setflags(write=False)                 # results are data: read-only, never silently edited
    contact = contacts[0]
    # a verified exact finish is the answer whatever the interior point that started it reported
    status = (raw.status or problem_.status) if problem_ is not None and not polished else Status.OPTIMAL
    info = SolveInfo(status=status, method="",
                     route=Route.INTERIOR_POINT_FINISHED if polished else Route.INTERIOR_POINT,
                     polished=polished, timings=timings)              # provisional: the caller completes it
    pts = [n.points for n in nodes]
    return Solution(scene=scene, condition=condition, u=u_si, phi=phi_si, contact=contact, problem=problem_,
                    tol=tol, info=info, energy=float(energy), _checks=checks_, contacts=contacts, points=list(pts),
                    degree=trace.degree, interface=interface, _closed=closed,
                    electrodes=electrodes(scene, systems, u_si, phi_si, nodes,
                                          problem.shared("electrode rows", lambda: electrode_rows(scene, systems,
                                                                                                  nodes))))


def read_back_compliance(problem, raw, tol: float, timings, polished: bool | None = None) -> Solution:
    """Like :func:`read_back_nodal` for a normal-compliance law (SI; docs/formulation.md §10). ``polished``:
    whether to report the arrays as an exact finish (default ``raw.polished``).

    ``law`` is one :class:`~cvxcontact.contact.laws.NormalCompliance` on every row, or the per-row
    :class:`~cvxcontact.contact.laws.RowLaws` of the pairs (Signorini and compliance pairs mixed).
    ``force`` are the row forces the backend applied (scaled), ``z`` the limit reactions (the
    multipliers of r <= l; on Signorini rows l = 0; None if no row has a limit), ``weights`` the lumped
    lengths of the constrained nodes (scaled). Per pair: on a compliance pair lambda = p(r) + z / w at its
    constrained nodes (r = [u_nu] - g from the returned u), extended to its merged mesh as the P1 function
    of those nodes (:meth:`~cvxcontact.contact.interface.Interface.extend`), and ``force`` = E^T (w
    lambda), the force the checks put into (26); on a Signorini pair lambda_h is the multiplier
    M lambda_h = E^T z of :func:`read_back_nodal`. ``contacts[i].law`` is pair i's law; ``sol.law`` is
    ``given`` (the law given to ``solve``), or ``law`` itself when it is one law. ``energy`` includes
    sum_a w_a Phi_a(r_a). P2 (``interface`` the pair's
    :class:`~cvxcontact.contact.quadratic.QuadraticInterface`, ``nodes`` the bodies' P2 nodes): the rows
    are the P2 contact nodes of the condition, ``weights`` their Simpson weights, and lambda is extended to
    X_h as the P2 function of those nodes (:meth:`~cvxcontact.contact.quadratic.QuadraticInterface.extend`).
    P2 tetrahedra: the rows of a compliance pair are the law's quadrature points on its P2 faces, and lambda at
    the condition's nodes is the Riesz representer of the row forces w p(r) + z in the P2 functions of those
    faces (:meth:`~cvxcontact.contact.quadratic3d.QuadraticSurface.law_pressure`), extended likewise.
    (P2 with a conic penetration limit: :func:`read_back_conic_mix`.)
    """
    scene, condition, blocks, systems, un, E, gap, u, phi = _fields(problem, raw)
    polished = raw.polished if polished is None else polished
    law = rows = problem.rows
    weights, z, nodes, given = problem.weights, raw.z, problem.meshes, problem.law
    interface = problem.space.trace.kept(problem.interface)
    scaled = rows.scaled(un.stress * un.load, un.displacement)
    force = np.asarray(raw.y, dtype=float)
    sol = read_back_nodal(problem, replace(raw, y=force, active=force > 0, beta=None, polished=polished), tol, timings)
    g = E @ gap
    checks_, lam = compliance_checks(blocks, u, phi, E, g, weights, scaled, force, z)
    r = sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u)) - g
    unit = un.stress * un.load
    # the law's pressure as the backend applied it, (y - z) / w (p(r) on a row of weight 0): after an exact
    # finish a stiff law's p(r) reads r to rounding times k, the finish's force does not (the checks' law)
    p = np.divide(force - (0.0 if z is None else z), weights, out=scaled.pressure(r) + 0.0, where=weights > 0)
    nodal = E.T @ force                                     # = E^T (w lambda), stacked merged nodes, scaled
    for k, (b, s, blk, uk, pk) in enumerate(zip(scene.bodies, systems, blocks, u, phi)):
        modes = b.held_modes(nodes[k])                                        # bodies held by the contact only
        if len(modes):           # their balance under the law's force E^T (w lambda) (docs/checks.md)
            balance = rigid_balance(blk, (s.Tu.T @ modes.T).T, uk, pk, nodal, prolongation=s.Tu, dim=b.dim)
            checks_["equilibrium"] = max(checks_["equilibrium"], balance)
    offsets = np.concatenate([[0], np.cumsum(rows.counts)]).astype(int)
    contacts = []
    pairs, merged_at = pair_lines(scene, interface)
    for i, (itf, c, pair_law) in enumerate(zip(pairs, sol.contacts, rows.laws)):
        if pair_law.compliant:
            cond = condition if scene.conditions[i] is None else scene.conditions[i]
            merged = slice(merged_at[i], merged_at[i + 1])
            rows_i = slice(offsets[i], offsets[i + 1])
            lam_i, own = lam[rows_i], {}
            if hasattr(itf, "law_pressure"):     # P2 faces: rows at the law's quadrature points, lambda the Riesz
                law_i = ~np.asarray(getattr(rows, "cone", np.zeros(len(force), dtype=bool)))[rows_i]   # of w p + z
                lam_i = itf.law_pressure(cond, force[rows_i][law_i]) * un.length     # (not the cone's nodal rows)
                own = {"row_pressure": None}     # the law's lambda is the pressure (its rows are not the nodes')
            elif z is not None and cond == "gamma3" and getattr(itf, "rigid", True) is False:
                # 3D gamma3 between two bodies: the limit reactions of dependent rows are not unique, their work
                # on the jumps is; z as a pressure is its Riesz representer in X_h (as a Signorini pair's, §13),
                # read at the rows (every node of X_h but on Q1 hexahedra's nested and crossing faces)
                lam_i = p[rows_i] + itf.evaluation(cond) @ itf.multiplier((E.T @ z)[merged]) * un.force / unit
            c = replace(c, lam=itf.extend(cond, lam_i) * unit, force=nodal[merged] * un.force, **own)
            for a in (c.lam, c.force):
                a.setflags(write=False)
        contacts.append(replace(c, law=pair_law))
    sol.contacts, sol.contact, sol._checks = contacts, contacts[0], checks_
    sol.law = law if given is None else given
    if polished:     # the finish solved the interface equation to rounding (checked); the IPM gave its start
        sol.info = replace(sol.info, status=Status.OPTIMAL)
    sol.energy += float(weights @ scaled.energy(r)) * un.force * un.displacement
    return sol


def read_back_conic_mix(problem, raw, tol: float, timings) -> Solution:
    """:func:`read_back_compliance` for a P2 scene whose "everywhere" cones (docs/formulation.md §8) sit next to
    a normal-compliance law (§10, "P2"). ``law`` is the :class:`~cvxcontact.contact.quadratic.ConeRowLaws` of
    the rows of ``E`` (``law.cone``: the rows of the cone pairs, E the identity on their nodes of X_h),
    ``cone`` = (B, segments) of the cones on the stacked nodes of X_h
    (:meth:`~cvxcontact.contact.quadratic.QuadraticStack.bernstein_of`), ``beta`` (S, 3) their Bernstein
    duals, ``z`` the reactions (the cone's nodal force B^T beta plus the multipliers of the nodal limit rows),
    ``force`` = w p(r) + z the row forces (scaled). Per pair: a nodal pair as in :func:`read_back_compliance`;
    a Signorini "gamma3" pair lambda_h = M^-1 B^T beta (as :func:`read_back`); a compliant "gamma3" pair with
    a limit lambda = p(r) + M^-1 B^T beta. Checks: the residual of (26) and the law as in
    :func:`~cvxcontact.solution.checks.compliance_checks` (with the nodal limit rows' feasibility,
    complementarity and cone), and feasibility, complementarity and cone of the cones
    (:func:`~cvxcontact.solution.checks.conic_checks`, at the gap g + l), the worse of both reported.
    ``active`` of a cone pair: the nodes of its elements where the cone closes at the gap g + l
    (:func:`~cvxcontact.solution.checks.touching_nodes`, as :func:`read_back_cones`), and its rows with p(r) > 0."""
    scene, _, blocks, _, un, E, gap, u, phi = _fields(problem, raw)
    law, interface, cone, beta, force = problem.rows, problem.interface, problem.lines.mixed_bernstein, raw.beta, raw.y
    sol = read_back_compliance(problem, raw, tol, timings, polished=raw.polished)     # polished: §18's finish
    scaled = law.scaled(un.stress * un.load, un.displacement)
    B, elements = cone
    force = np.asarray(force, dtype=float)
    cone_checks = conic_checks(blocks, u, phi, E.T @ force, B, gap + E.T @ scaled.cone_shift, beta,
                               force_scale=float(np.abs(force).max(initial=0.0)),
                               moved=problem.translation_sizes(raw.taus) if raw.taus else None)
    checks_ = dict(sol._checks)
    for key in ("feasibility", "complementarity", "cone"):
        checks_[key] = max(checks_.get(key, 0.0), cone_checks[key])
    r = sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u)) - E @ gap
    p = scaled.pressure(r)
    zc = B.T @ beta.ravel()                                                    # the cones' force on X_h, scaled
    on = read_columns(B) & touching_nodes(blocks, u, gap + E.T @ scaled.cone_shift, E.T @ force, B, elements, tol)
    pairs, offsets = pair_lines(scene, interface)
    rows_at = np.concatenate([[0], np.cumsum(law.counts)]).astype(int)
    contacts = []
    for i, (itf, c) in enumerate(zip(pairs, sol.contacts)):
        a, b = rows_at[i], rows_at[i + 1]
        cone_i = np.asarray(law.cone[a:b])
        if b == a or not cone_i.any():
            contacts.append(c)
            continue
        nodes_i = slice(offsets[i], offsets[i + 1])                  # = the cone rows of a:b (E = I there)
        if cone_i.all():                                             # 2D: the law on the cone's rows
            law_p = p[a:b]
            riesz = spla.spsolve((itf.mass / un.length).tocsc(), zc[nodes_i])         # M scaled like w
        else:       # P2 tetrahedra: the law's quadrature rows, then the cone's nodes of X_h (weight 0)
            cond = scene.conditions[i] or problem.condition
            law_p = itf.law_pressure(cond, force[a:b][~cone_i]) * un.length
            riesz = itf.multiplier(zc[nodes_i]) * un.length
        changes = {"active": on[nodes_i] | (law_p > 0)}
        if c.law is not None and c.law.compliant:
            changes["lam"] = (law_p + riesz) * (un.stress * un.load)
        c = replace(c, **changes)
        for arr in changes.values():
            arr.setflags(write=False)
        contacts.append(c)
    sol.contacts, sol.contact, sol._checks = contacts, contacts[0], checks_
    return sol
