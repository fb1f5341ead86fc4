"""The solution of a contact problem: read-back in SI and the checks of (26)-(27).

Read-back (docs/formulation.md §4): with y >= 0 the dual of E [u_nu] <= E g,

    M lambda_h = E^T y        (lambda_h in X_h on the merged mesh, Pa; lambda = -sigma_nu)

The checks are in :mod:`cvxcontact.solution.checks`; what they guarantee is derived in
docs/checks.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import cvxpy as cp
import numpy as np
import scipy.sparse.linalg as spla

from ..fem.trace import TRACES, LinearTrace
from ..errors import SceneError
from ..physics.scene import Scene
from .checks import (CERTIFIED, ENERGY_ERROR, checks, compliance_checks, conic_checks, energy_error, obstacle_balance,
                     rigid_balance)
from .info import Route, SolveInfo, Status

__all__ = ["Solution", "ContactResult", "Electrode", "ObstacleResult", "read_back_nodal", "read_back_compliance", "pair_label", "force_unit",
           "read_back_conic_mix",
           "obstacle_results"]


@dataclass
class ContactResult:
    """Contact quantities on the merged mesh of Gamma_3 (sorted abscissae ``x``, m).

    ``lam`` is lambda_h (Pa), ``jump`` is [u_h nu] (m), ``force`` the equivalent nodal
    force E^T y (N/m), ``constrained`` marks the nodes where non-penetration is imposed
    and ``active`` those among them that carry a positive force; ``line`` is the
    ordinate of Gamma_3 (m), ``gap`` the initial gap g at the nodes (m).

    For a pair in any direction, ``x`` is the tangential coordinate s = x . t (m) along the pair's
    tangent t (:func:`cvxcontact.contact.interface.canonical_tangent`; s = x1 for a line parallel to
    the x1-axis), ``points`` (n, d) the coordinates of the contact nodes (m; in 2D and 3D), ``normal`` the
    first body's unit outward normal nu^a and ``line`` the mean x2 of the first body's part.

    In 3D (a planar contact surface) ``x`` (n, 2) are the nodes' in-plane coordinates (s1, s2) along the
    pair's frame (t1, t2) (:func:`cvxcontact.contact.surface.canonical_frame`; (x, y) for a plane
    z = const), ``points`` (n, 3), ``force`` in N (not N/m), ``line`` the offset x . nu^a of the plane.
    """

    x: np.ndarray
    lam: np.ndarray
    jump: np.ndarray
    force: np.ndarray
    constrained: np.ndarray
    active: np.ndarray
    line: float = 0.0
    gap: np.ndarray | None = None
    points: np.ndarray | None = None
    normal: np.ndarray | None = None
    degree: int = 1
    """1: P1 (X_h continuous piecewise linear); 2: P2 (``x`` interleaves merged vertices and segment
    midpoints, X_h continuous piecewise quadratic)."""
    law: object = None
    """The pair's normal law (:mod:`cvxcontact.contact.laws`) when a compliance law was solved in the
    scene; None means Signorini."""
    measure: np.ndarray | None = None
    """P1: the length (2D, m) or area (3D, m^2) attributed to each constrained node by the mesh those nodes
    form (the quadrature weights of the condition's rows), 0 elsewhere; :attr:`pressure` divides by it."""
    slip: np.ndarray | None = None
    """A friction law (:class:`~cvxcontact.contact.laws.Tresca`): the slip [u_t] = (u^a - u^b) . t (m) at the
    merged nodes, t the pair's tangent (3D: (n, 2), along the pair's frame t_1, t_2); None without friction."""
    shear_force: np.ndarray | None = None
    """A friction law: the tangential nodal force on the first body along t (N/m, 3D N, (n, 2) like ``slip``;
    anti-parallel to ``slip`` where it slips); :attr:`shear` divides it by the lumped lengths (areas). None
    without friction."""
    threshold: float | np.ndarray | None = None
    """A friction law: the pair's slip threshold g (Pa; Coulomb: mu p at each merged node, Pa); None without
    friction."""
    scale: float = 0.0
    """The size (m) of the terms of ``jump`` on this pair: the largest sum over its nodes of both bodies'
    |u . nu| (and of a prescribed displacement's |u_D . nu|), the scale of :attr:`penetration`."""

    @property
    def pressure(self) -> np.ndarray:
        """Nodal force divided by the lumped length of each constrained node (Pa).

        The forces E^T y sit on the constrained nodes only (every merged node for gamma3,
        the nodes of mesh l for sigma_l), so each is divided by the lumped length of the
        mesh made of those nodes (for sigma_l: mesh l's own trace), never by the merged
        mesh's shorter lengths. 0 at the nodes without a constraint (they carry no force).
        For the pressure felt by a body use :meth:`Solution.traction`.

        P2 (a quadratic trace, ``degree`` 2): the forces r = M lambda_h live on every node of X_h, each divided
        by the row sum of the P2 mass matrix of X_h (h/6 per adjacent segment at a vertex, 2h/3 at a
        midpoint). On a 3D surface the P2 row sums vanish at the vertices (a vertex's shape function
        integrates to 0 on a triangle): there the pressure is lambda_h itself (:attr:`lam`).
        """
        return self.trace.pressure(self)

    @property
    def trace(self) -> LinearTrace:
        """The trace of the solution's space on this pair (:mod:`cvxcontact.fem.trace`, by :attr:`degree`)."""
        return TRACES[self.degree]

    @property
    def shear(self) -> np.ndarray | None:
        """The tangential traction sigma_t on the first body along t (Pa): :attr:`shear_force` over the lumped
        lengths of the constrained nodes (as :attr:`pressure`); |sigma_t| <= g. None without friction."""
        if self.shear_force is None:
            return None
        return self.trace.per_length(self, self.shear_force)

    @property
    def penetration(self) -> np.ndarray:
        """Boolean mask of the merged nodes where [u_nu] exceeds the gap g by more than 1e-9 of the
        largest |[u_nu]|, |g| or :attr:`scale` (with sigma_l, the unconstrained nodes of the other mesh may
        penetrate). (Where both sides move together and the gap is 0, [u_nu] is rounding of their
        displacements: ``scale``, not |[u_nu]|, measures it.)"""
        gap = np.zeros(len(self.x)) if self.gap is None else self.gap
        scale = max(float(np.abs(self.jump).max()), float(np.abs(gap).max()), float(self.scale),
                    np.finfo(float).tiny)
        return (self.jump - gap) > 1e-9 * scale


@dataclass(frozen=True)
class Electrode:
    """One electrode of a piezoelectric body: grounded (phi = 0), driven (phi = V) or floating.

    ``body`` is the body's index in the scene, ``tag`` the boundary part, ``kind`` one of
    "grounded", "driven", "floating"; ``potential`` its potential (V; the mean over its nodes
    for a driven electrode whose potential varies along it) and ``charge`` its total charge
    (C/m; C in 3D): the reaction of the Gauss equation (20) summed over its nodes, i.e. -int D.nu ds
    (for a floating electrode, the prescribed Q). A node shared by two electrodes counts for
    the first in the order grounded, driven, floating.
    """

    body: int
    tag: str
    kind: str
    potential: float
    charge: float


def electrodes(scene, systems, u_si, phi_si, nodes) -> list[Electrode]:
    """The :class:`Electrode` results of every piezoelectric body (SI, see :class:`Electrode`).
    ``nodes``: each body's node set (its mesh, or e.g. the :class:`~cvxcontact.geometry.quadratic.P2Nodes` of a
    P2 solution: an electrode's nodes are then its vertices and edge midpoints)."""
    out = []
    for k, (b, s, u, phi) in enumerate(zip(scene.bodies, systems, u_si, phi_si)):
        if phi is None:
            continue
        r = s.Kpp @ (phi - s.phi_fixed) - s.Kup.T @ (u.ravel() - s.u_fixed) - s.q      # C/m per node
        taken = np.zeros(len(phi), dtype=bool)
        parts = ([(t, "grounded") for t in b.grounded] + [(t, "driven") for t in b.potential]
                 + [(t, "floating") for t in getattr(b, "floating", {})])
        for tag, kind in parts:
            on = nodes[k].boundary_nodes([tag])
            mine = on[~taken[on]]
            taken[on] = True
            out.append(Electrode(body=k, tag=tag, kind=kind, potential=float(phi[on].mean()),
                                 charge=float(r[mine].sum())))
    return out


@dataclass
class Solution:
    """Result of :func:`solve`: the fields, the contact forces and the checks of one solve.

    How the answer was reached (``path``, ``problem``, ``polished``): docs/reference/solve-options.md, "What
    the solution records"; what the checks guarantee: docs/checks.md.

    Attributes
    ----------
    u : list of (n_k, d) arrays, m
        Nodal displacements of each body k, at ``points[k]``.
    phi : list of (n_k,) arrays or None, V
        Nodal potentials of each body (None for an elastic body).
    contact : ContactResult
        The first pair's contact: jump, gap, lambda_h (Pa), forces; ``contacts`` holds every pair's.
    energy : float, J/m (J in 3D)
        The reduced coupled energy Pi(u_h) of docs/formulation.md §2.
    ok : bool
        True if the solve succeeded and every check of (26)-(27) is within ``tol``.
    tol : float
        The checks' tolerance (dimensionless).
    info : SolveInfo
        How the solve went: status, backend, route, iterations, timings (s), finish.
    electrodes : list of Electrode
        Potential (V) and charge (C/m; C in 3D) of every electrode.
    obstacles : list of ObstacleResult
        Each rigid obstacle's translation (m) and force (N/m; N in 3D).
    estimate : ErrorEstimate or None
        The a posteriori estimate of the discretisation error (docs/accuracy.md).
    """

    scene: Scene
    condition: str
    u: list
    phi: list
    contact: ContactResult
    problem: cp.Problem | None
    tol: float
    info: SolveInfo
    energy: float = float("nan")
    _checks: dict = field(default_factory=dict, repr=False)
    law: object = None
    """The normal contact law given to ``solve`` (:mod:`cvxcontact.contact.laws`; the law of the pairs
    without their own) when some pair follows normal compliance; None means Signorini everywhere. Each
    pair's own law: ``contacts[i].law``."""
    contacts: list = field(default_factory=list)
    """One :class:`ContactResult` per contact pair, in the order of ``scene.contacts``; ``contact`` is
    the first."""
    points: list = field(default_factory=list)
    """``points[k]``: coordinates (m) of body k's nodes in the order of ``u[k]`` and ``phi[k]`` (P1: the
    mesh points; P2: vertices first, then edge midpoints)."""
    degree: int = 1
    """1: P1 elements; 2: P2 (6-node) elements (docs/formulation.md §8)."""
    interface: object = field(default=None, repr=False)
    """P2: the :class:`~cvxcontact.contact.quadratic.QuadraticInterface` of the scene's pair (the merged
    P2 nodes of ``contact``), or with several pairs their
    :class:`~cvxcontact.contact.quadratic.QuadraticStack` (pair i: ``interface.interfaces[i]``, the nodes of
    ``contacts[i]``); None for P1 (``scene.interfaces``)."""
    electrodes: list = field(default_factory=list)
    """:class:`Electrode` results (potential V, charge C/m) of every electrode of every body."""
    obstacles: list = field(default_factory=list)
    """One :class:`ObstacleResult` per distinct rigid obstacle (translation m, reaction ``force`` N/m in 2D,
    N in 3D), in the order of ``scene.obstacles``."""
    estimate: object = None
    """The a posteriori :class:`~cvxcontact.solution.estimate.ErrorEstimate` of the discretisation error in the
    energy norm (docs/accuracy.md), computed with every solve (``solve(..., estimate=False)`` skips it); None
    when it was skipped or the case is not covered: :attr:`estimate_reason` says which."""
    estimate_reason: str = ""
    """Why :attr:`estimate` is None ("" when it is not)."""
    _state: object = field(default=None, repr=False)
    _pending_state: object = field(default=None, repr=False, compare=False)

    @property
    def state(self):
        """The contact forces as point loads on the contact lines or surfaces (a
        :class:`~cvxcontact.backends.start.ContactState`: pair, position in m (2D: s; 3D: (s1, s2) in the
        pair's plane axes), force in N/m in 2D, N in 3D), what a solve of the same scene on another mesh starts
        from (``ContactSolver(..., start=sol)``); None where that does not apply (3D P2 "gamma3", compliance or
        mixed laws, friction, an answer without an exact finish). Computed when first read
        (:meth:`defer_state`)."""
        if self._pending_state is not None:
            self._state, self._pending_state = self._pending_state(), None
        return self._state

    @state.setter
    def state(self, value) -> None:
        self._state, self._pending_state = value, None

    def defer_state(self, compute) -> None:
        """Let :attr:`state` be ``compute()`` (a call without arguments, or None: no state), made when it is
        first read (:func:`~cvxcontact.backends.start.deferred_state`)."""
        self._state, self._pending_state = None, compute

    @property
    def status(self) -> Status:
        """Solver status (:class:`Status`; equal to the CVXPY status string)."""
        return self.info.status

    @property
    def polished(self) -> bool:
        """True if the arrays are the exact finish."""
        return self.info.polished

    @property
    def method(self) -> str:
        """The backend actually used ("amg", "sparse", "condensed" or "full")."""
        return self.info.method

    @property
    def path(self) -> str:
        """The route taken (:class:`Route`; equal to the former strings)."""
        return self.info.route

    @property
    def timings(self):
        """Read-only mapping stage -> wall-clock seconds of this solve."""
        return self.info.timings

    def residuals(self) -> dict[str, float]:
        """The checks of the mixed formulation (26)-(27): relative residuals, each passing below ``tol``.

        Returns
        -------
        dict[str, float]
            Check name ("equilibrium", "feasibility", "complementarity", "cone", ...) -> relative residual
            (dimensionless). What each bounds: docs/checks.md, "The four checks".
        """
        return dict(self._checks)

    @property
    def ok(self) -> bool:
        """True if the solver reported optimal (or the answer is a verified exact finish) and every check is
        below ``tol``; where the conic condition's certified bound "energy error" is present, it and the three
        contact checks it certifies (feasibility, complementarity, cone) pass together if either does
        (docs/checks.md, "The certified bound")."""
        return self.status == cp.OPTIMAL and all(self._passes(k) for k in self._checks)

    def _passes(self, key: str) -> bool:
        """Whether check ``key`` passes at ``tol`` (see :attr:`ok`)."""
        c, tol = self._checks, self.tol
        if c[key] <= tol:
            return True
        if ENERGY_ERROR not in c:
            return False
        if key in CERTIFIED:
            return c[ENERGY_ERROR] <= tol
        return key == ENERGY_ERROR and all(c[k] <= tol for k in CERTIFIED if k in c)

    def traction(self, k: int, pair: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """The contact pressure felt by body ``k`` of pair ``pair`` on its own trace nodes: the pressure to plot.

        Parameters
        ----------
        k : int
            0 or 1: the first or the second body of the pair (0 only against a rigid obstacle).
        pair : int
            Index of the contact pair in ``scene.contacts``.

        Returns
        -------
        x : ndarray
            The trace nodes' tangential coordinate s (m; in 3D (n, 2) in-plane coordinates).
        p : ndarray
            The pressure at those nodes (Pa). How it is made from the nodal forces, and how it differs from
            ``lam``: docs/checks.md, "The pressure views: what to plot, what to check".
        """
        itf = self._pair_line(pair)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < len(itf.traces):
            raise SceneError(f"traction(k): k must be {'0 (the body; the other side is rigid)' if itf.rigid else '0 or 1 (the body)'}, "
                             f"got {k!r}")
        return itf.traces[k].x.copy(), TRACES[self.degree].felt(itf, k, self.contacts[pair].force)

    def in_contact(self, pair: int = 0) -> np.ndarray:
        """The contact zone of pair ``pair``: where the pressure felt by the bodies is positive.

        Parameters
        ----------
        pair : int
            Index of the contact pair in ``scene.contacts``.

        Returns
        -------
        ndarray of bool
            One entry per merged node (``contacts[pair].x``): the mean of :meth:`traction` of each side at the
            node is above 1e-9 of its largest value. Why it differs from ``contacts[pair].active``:
            docs/checks.md, "The pressure views: what to plot, what to check".
        """
        itf = self._pair_line(pair)
        sides = range(len(itf.traces))
        p = sum(itf.interpolation(k) @ self.traction(k, pair)[1] for k in sides) / len(sides)
        top = float(np.abs(p).max()) if len(p) else 0.0
        return p > 1e-9 * top if top > 0 else np.zeros(len(p), dtype=bool)

    def contact_fraction(self, pair: int = 0) -> float | None:
        """The share of pair ``pair``'s surface (length in 2D, area in 3D) in its contact zone (:meth:`in_contact`).

        Parameters
        ----------
        pair : int
            Index of the contact pair in ``scene.contacts``.

        Returns
        -------
        float or None
            Between 0 and 1 (dimensionless; 1: contact over the whole surface), each merged node weighted by its
            lumped length or area (``contacts[pair].measure``; P2 in 2D: the P2 lumped lengths). None for P2 in
            3D (a face vertex has no lumped area).
        """
        c = self.contacts[pair]
        if c.measure is not None:
            w = np.asarray(c.measure, dtype=float)
        elif np.ndim(c.x) == 1:
            w = c.trace.lumped(c.x)
        else:
            return None
        return float(w[self.in_contact(pair)].sum() / w.sum()) if w.sum() > 0 else None

    def contact_line(self, pair: int = 0):
        """The contact line (surface) pair ``pair``'s results live on: ``scene.interfaces[pair]``, or the
        quadratic interface of the space's traces (:attr:`interface`); its ``traces``, ``x``, ``points``."""
        return self._pair_line(pair)

    def _pair_line(self, pair: int):
        if isinstance(pair, bool) or not isinstance(pair, (int, np.integer)) or \
                not 0 <= pair < len(self.scene.interfaces):
            raise SceneError(f"pair must be an index of scene.contacts (0 to {len(self.scene.interfaces) - 1}), "
                             f"got {pair!r}")
        return _pairs(self.scene, self.interface)[0][pair]

    def report(self) -> str:
        """A short human-readable account of the solve: what `cvxcontact solve` prints.

        Returns
        -------
        str
            The condition, the status, the exact finish or not (and why it was declined: ``info.declined``), each
            check of (26)-(27) against ``tol``; per pair its force (N/m; N in 3D), :meth:`contact_fraction` and
            active nodes; per electrode its potential (V) and charge (C/m; C in 3D); per obstacle its translation
            (m) and force; the error :attr:`estimate`.
        """
        finish = "exact finish" if self.polished else "interior-point answer"
        lines = [f"condition {self.condition}, solver status {self.status}, {finish}"]
        if self.info.declined:
            lines.append(f"  (exact finish declined: {self.info.declined})")
        lines += [f"  {k:16s} {v:.2e}  {'ok' if v <= self.tol else 'ok (certified)' if self._passes(k) else 'FAILED'}"
                  for k, v in self._checks.items()]
        unit, charge = force_unit(self), "C" if self.scene.dim == 3 else "C/m"
        for i, c in enumerate(self.contacts):
            zone, share = self.in_contact(i), self.contact_fraction(i)
            lines.append(f"  contact[{i}] {pair_label(self, i)}: force {c.force.sum():.6g} {unit}; pressure > 0 at "
                         f"{int(zone.sum())} of {len(zone)} nodes"
                         + (f" ({100 * share:.4g} % of the {'area' if self.scene.dim == 3 else 'length'})"
                            if share is not None else "")
                         + f"; {int(c.active.sum())} of {int(c.constrained.sum())} constrained nodes active "
                           "(carry a force)")
        for e in self.electrodes:
            lines.append(f"  electrode {self.scene.bodies[e.body].name}/{e.tag} ({e.kind}): potential "
                         f"{e.potential:.6g} V, charge {e.charge:.6g} {charge}")
        for j, o in enumerate(self.obstacles):
            lines.append(f"  obstacle[{j}] {o.obstacle!r}: translation ({_numbers(o.translation)}) m, force "
                         f"({_numbers(o.force)}) {unit}")
        lines.append(f"  estimate         {self.estimate}" if self.estimate is not None
                     else f"  estimate         none ({self.estimate_reason or 'not computed'})")
        return "\n".join(lines)


def _numbers(v) -> str:
    return ", ".join(f"{float(a) + 0.0:.6g}" for a in v)              # + 0.0: no "-0"


def pair_label(solution, pair=0) -> str:
    """A short name of contact pair ``pair``: "upper/bottom - lower/top" or "block/bottom - Rigid.plane(...)"."""
    c = solution.scene.contacts[pair]
    other = repr(c.other) if c.rigid else f"{c.other.name}/{c.part_b}"
    return f"{c.body_a.name}/{c.part_a} - {other}"


def force_unit(solution) -> str:
    """The unit of a nodal or resultant force of ``solution``: "N/m" in 2D (per unit thickness), "N" in 3D."""
    return "N" if solution.scene.dim == 3 else "N/m"


@dataclass(frozen=True)
class ObstacleResult:
    """One rigid obstacle of the solution (docs/formulation.md §12).

    ``translation`` (d,) m: its rigid translation t (0 for a fixed obstacle; for a plane, along its
    normal: a tangential translation changes nothing); ``force`` (d,): the obstacle's reaction, N/m in 2D
    (per unit thickness), N in 3D: the resultant the obstacle
    exerts on the bodies, sum_a c_a y_a over its nodes a (c_a of
    :meth:`~cvxcontact.physics.pairs.Rigid.sensitivity`, y_a >= 0 the nodal contact forces), equal and
    opposite to the contact's push on the obstacle, i.e. the force needed to hold it where it is (a plane
    under a body: upwards; a sphere pressed down onto one: downwards); for a force-controlled obstacle it equals the prescribed
    ``prescribed`` (the check "obstacle balance"). ``pairs`` are its contact pairs.
    """

    obstacle: object
    pairs: tuple
    translation: np.ndarray
    force: np.ndarray
    prescribed: np.ndarray | None = None


def obstacle_results(sol, translations, obstacles=None) -> None:
    """Fill ``sol.obstacles`` (:class:`ObstacleResult`) from the stacked nodal forces of ``sol.contacts``
    and ``translations`` (m, the unknowns tau of each force-controlled obstacle, in order); add the
    work -F . t of the prescribed forces to ``sol.energy`` and the check "obstacle balance" (the largest
    |F - sum_a c_a y_a| / |F|) to the residuals. ``obstacles``: the scene's
    :class:`~cvxcontact.physics.pairs.ObstacleRows` with rows at the stacked nodes of ``sol.contacts``
    (default ``sol.scene.obstacles``, the P1 merged nodes; P2: rows at the P2 nodes)."""
    y = np.concatenate([c.force for c in sol.contacts])                     # N/m at the stacked merged nodes
    taus, out, worst = iter(translations), [], 0.0
    for o in (sol.scene.obstacles if obstacles is None else obstacles):
        rows = o.rows.toarray()
        force = rows.T @ y
        t = np.zeros(rows.shape[1]) if o.force is None else o.basis @ next(taus)
        if o.force is not None:
            worst = max(worst, obstacle_balance(o.force, rows, y))
            sol.energy -= float(o.force @ t)
        for a in (t, force):
            a.setflags(write=False)
        out.append(ObstacleResult(o.obstacle, o.pairs, t, force, o.force))
    sol.obstacles = out
    if any(o.force is not None for o in sol.scene.obstacles):
        sol._checks["obstacle balance"] = worst


def _fields(problem, raw):
    """The names the read-backs share, from a problem and a raw result (scaled)."""
    return (problem.scene, problem.condition, problem.blocks, problem.systems, problem.units, problem.E,
            problem.moved_gap(raw.taus), raw.u, raw.phi)


def read_back_nodal(problem, raw, tol: float, timings) -> "Solution":
    """Scaled (u, phi, y) of ``raw`` -> a Solution in SI with lambda_h and the checks of (26)-(27) (nodal rows,
    ``raw.active`` the closed ones; the gap that force-controlled obstacles moved to).

    P2: with the conic condition, ``raw.beta`` (S, 3) are the Bernstein duals of each merged segment, ``raw.y``
    is the nodal force r = B^T beta on X_h and M lambda_h = r (docs/formulation.md §8); the cone's rows (B,
    segments) are ``problem.lines.cone`` and the constrained nodes the nodes B reads.
    """
    scene, condition, blocks, systems, un, E, gap, u, phi = _fields(problem, raw)
    y, active, polished, problem_, beta, nodes = raw.y, raw.active, raw.polished, raw.program, raw.beta, problem.meshes
    trace = problem.space.trace
    itf = problem.interface
    interface = trace.kept(itf)
    g = E @ gap
    Ety = E.T @ y
    lam = itf.multiplier(Ety)              # scaled; the Riesz representer in X_h (2D: M lam = E^T y)
    shift = problem.prescribed_jump        # [u_D nu] (the blocks' jumps act on the free unknowns only)
    jump = sum(b.jump @ uk for b, uk in zip(blocks, u)) + shift
    sizes = sum(np.abs(b.jump @ uk) for b, uk in zip(blocks, u)) + np.abs(shift)      # the terms of the jump
    if beta is not None:
        B, segments = problem.lines.cone
        checks_ = conic_checks(blocks, u, phi, Ety, B, gap, beta, departure=problem.departure, pairing=raw.pairing)
        if raw.certificate is not None:
            checks_[ENERGY_ERROR] = energy_error(blocks, u, phi, raw.certificate)
        S = segments[beta.sum(axis=1) > 1e-6 * max(float(np.abs(beta).max(initial=0.0)), 1e-300)]
        active = np.zeros(itf.size, dtype=bool)
        active[S.ravel()] = True              # the nodes of segments that carry a force
    else:
        checks_ = checks(blocks, u, phi, Ety, E, g, y,     # the row forces (3D: M lam = E^T y only on the traces)
                         abs(E) @ problem.translation_sizes(raw.taus) if raw.taus else None)
    for k, (b, s, blk, uk, pk) in enumerate(zip(scene.bodies, systems, blocks, u, phi)):
        modes = b.held_modes(nodes[k])                                        # bodies held by the contact only
        if len(modes):
            balance = rigid_balance(blk, (s.Tu.T @ modes.T).T, uk, pk, Ety)
            checks_["equilibrium"] = max(checks_["equilibrium"], balance)
    energy = sum(b.energy(uk, pk) for b, uk, pk in zip(blocks, u, phi)) * un.force * un.displacement
    u_si, phi_si = [], []
    for s, b, uk, pk in zip(systems, scene.bodies, u, phi):
        full = s.u_fixed + s.Tu @ (uk * un.displacement)                  # u = T_u z + u_D
        u_si.append(full.reshape(-1, problem.dim))
        if pk is None:
            phi_si.append(None)
            continue
        phi_si.append(s.phi_fixed + s.Tp @ (pk * un.potential))          # phi = T_p z + phi_D
    constrained = np.zeros(itf.size, dtype=bool)
    on = np.zeros(itf.size, dtype=bool)
    # the merged nodes in the support of the constrained rows (conic: of the cone's rows; P1: the rows' nodes)
    support = np.flatnonzero(np.asarray(abs(E if beta is None else B).sum(axis=0)).ravel() > 0)
    constrained[support] = True
    if beta is not None:
        on = active
    else:
        on[np.flatnonzero(np.asarray(abs(E[np.flatnonzero(active)]).sum(axis=0)).ravel() > 0)] = True
    contacts = []
    pairs, offsets = _pairs(scene, interface)
    for i, pair in enumerate(pairs):                  # each pair's slice of the stacked rows
        part = slice(offsets[i], offsets[i + 1])
        cond = condition if scene.conditions[i] is None else scene.conditions[i]
        measure = trace.measure(pair, cond)           # the rows' quadrature weights (lengths or areas), or None
        contacts.append(ContactResult(
            x=pair.x.copy(), lam=lam[part] * un.force, jump=jump[part] * un.displacement,
            force=Ety[part] * un.force, constrained=constrained[part].copy(), active=on[part].copy(), line=_line(pair),
            gap=(gap + shift)[part] * un.displacement, points=pair.points.copy(), normal=np.array(pair.normal, dtype=float),
            degree=trace.degree, scale=float(sizes[part].max(initial=0.0)) * un.displacement, measure=measure))
    for a in [*u_si, *(p for p in phi_si if p is not None), *(getattr(c, f) for c in contacts for f in
              ("x", "lam", "jump", "force", "constrained", "active", "gap", "points", "normal", "measure")
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
                    degree=trace.degree, interface=interface,
                    electrodes=electrodes(scene, systems, u_si, phi_si, nodes))


def read_back_compliance(problem, raw, tol: float, timings, polished: bool | None = None) -> "Solution":
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
            balance = rigid_balance(blk, (s.Tu.T @ modes.T).T, uk, pk, nodal)
            checks_["equilibrium"] = max(checks_["equilibrium"], balance)
    offsets = np.concatenate([[0], np.cumsum(rows.counts)]).astype(int)
    contacts = []
    pairs, merged_at = _pairs(scene, interface)
    for i, (itf, c, pair_law) in enumerate(zip(pairs, sol.contacts, rows.laws)):
        if pair_law.compliant:
            cond = condition if scene.conditions[i] is None else scene.conditions[i]
            merged = slice(merged_at[i], merged_at[i + 1])
            rows_i = slice(offsets[i], offsets[i + 1])
            lam_i = lam[rows_i]
            if hasattr(itf, "law_pressure"):     # P2 faces: rows at the law's quadrature points, lambda the Riesz
                lam_i = itf.law_pressure(cond, force[rows_i]) * un.length            # representer of w p + z
            elif z is not None and cond == "gamma3" and getattr(itf, "rigid", True) is False:
                # 3D gamma3 between two bodies: the limit reactions of dependent rows are not unique, their work
                # on the jumps is; z as a pressure is its Riesz representer in X_h (as a Signorini pair's, §13)
                lam_i = p[rows_i] + itf.multiplier((E.T @ z)[merged]) * un.force / unit
            c = replace(c, lam=itf.extend(cond, lam_i) * unit, force=nodal[merged] * un.force)
            for a in (c.lam, c.force):
                a.setflags(write=False)
        contacts.append(replace(c, law=pair_law))
    sol.contacts, sol.contact, sol._checks = contacts, contacts[0], checks_
    sol.law = law if given is None else given
    if polished:     # the finish solved the interface equation to rounding (checked); the IPM gave its start
        sol.info = replace(sol.info, status=Status.OPTIMAL)
    sol.energy += float(weights @ scaled.energy(r)) * un.force * un.displacement
    return sol


def read_back_conic_mix(problem, raw, tol: float, timings) -> "Solution":
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
    ``active`` of a cone pair: the nodes of its segments that carry a force, and its rows with p(r) > 0."""
    scene, condition, blocks, systems, un, E, gap, u, phi = _fields(problem, raw)
    law, interface, cone, beta, force = problem.rows, problem.interface, problem.lines.mixed_bernstein, raw.beta, raw.y
    sol = read_back_compliance(problem, raw, tol, timings, polished=raw.polished)     # polished: §18's finish
    scaled = law.scaled(un.stress * un.load, un.displacement)
    B, segments = cone
    force = np.asarray(force, dtype=float)
    cone_checks = conic_checks(blocks, u, phi, E.T @ force, B, gap + E.T @ scaled.cone_shift, beta,
                               force_scale=float(np.abs(force).max(initial=0.0)))
    checks_ = dict(sol._checks)
    for key in ("feasibility", "complementarity", "cone"):
        checks_[key] = max(checks_.get(key, 0.0), cone_checks[key])
    r = sum(E @ (b.jump @ uk) for b, uk in zip(blocks, u)) - E @ gap
    p = scaled.pressure(r)
    zc = B.T @ beta.ravel()                                                    # the cones' force on X_h, scaled
    carries = segments[beta.sum(axis=1) > 1e-6 * max(float(np.abs(beta).max(initial=0.0)), 1e-300)]
    on = np.zeros(len(gap), dtype=bool)
    on[carries.ravel()] = True
    pairs, offsets = _pairs(scene, interface)
    rows_at = np.concatenate([[0], np.cumsum(law.counts)]).astype(int)
    contacts = []
    for i, (itf, c) in enumerate(zip(pairs, sol.contacts)):
        a, b = rows_at[i], rows_at[i + 1]
        if b == a or not law.cone[a]:
            contacts.append(c)
            continue
        nodes_i = slice(offsets[i], offsets[i + 1])                            # = rows a:b (E = I there)
        active = on[nodes_i] | (p[a:b] > 0)
        changes = {"active": active}
        if c.law is not None and c.law.compliant:
            lam = p[a:b] + spla.spsolve((itf.mass / un.length).tocsc(), zc[nodes_i])    # M scaled like w
            changes["lam"] = lam * (un.stress * un.load)
        c = replace(c, **changes)
        for arr in changes.values():
            arr.setflags(write=False)
        contacts.append(c)
    sol.contacts, sol.contact, sol._checks = contacts, contacts[0], checks_
    return sol


def _pairs(scene, interface):
    """(each pair's contact line, the offsets of its nodes in the stacked arrays): P1 (``interface`` None)
    the scene's interfaces; P2 a :class:`~cvxcontact.contact.quadratic.QuadraticInterface` (one pair) or a
    :class:`~cvxcontact.contact.quadratic.QuadraticStack`."""
    if interface is None:
        return scene.interfaces, scene.stack.offsets
    if hasattr(interface, "interfaces"):
        return interface.interfaces, interface.offsets
    return [interface], [0, interface.size]


def _line(pair) -> float:
    """The ordinate (m) of a 2D pair's line (its first part's mean x2); in 3D the offset x . nu of the
    first part's plane."""
    return float(pair.y) if hasattr(pair, "y") else float(pair.traces[0].offset)
