"""The solution of a contact problem: read-back in SI and the checks of (26)-(27).

Read-back (docs/formulation.md §4): with y >= 0 the dual of E [u_nu] <= E g,

    M lambda_h = E^T y        (lambda_h in X_h on the merged mesh, Pa; lambda = -sigma_nu)

The checks are in :mod:`cvxcontact.solution.checks`; what they guarantee is derived in
docs/checks.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from ..backends.result import INTERIOR_POINT_KEPT
from ..fem.trace import TRACES, LinearTrace
from ..errors import SceneError
from ..physics.scene import Scene
from .checks import CERTIFIED, ENERGY_ERROR, obstacle_balance
from .info import SolveInfo, Status

__all__ = ["Solution", "ContactResult", "Electrode", "ObstacleResult", "pair_label", "force_unit", "obstacle_results"]


@dataclass
class ContactResult:
    """Contact quantities on the merged mesh of Gamma_3 (sorted abscissae ``x``, m).

    ``lam`` is lambda_h (Pa), ``jump`` is [u_h nu] (m), ``force`` the equivalent nodal
    force E^T y (N/m), ``constrained`` marks the nodes where non-penetration is imposed
    and ``active`` those among them where the contact is closed (the nodal rows: the rows the finish closes,
    each with a force >= 0, which may be 0: a row closed without pressing, or one of rows that repeat each other
    at a node, coincident obstacles, whose force one of them carries,
    :func:`~cvxcontact.backends.parallel.closed_once`; a normal-compliance law: the rows whose law presses);
    ``line`` is the ordinate of Gamma_3 (m), ``gap`` the initial gap g at the nodes (m).

    Under the P2 "everywhere" cones (2D segments, 3D copositive triangles) ``active`` is a function of the
    displacement: every node of the elements (merged segments, overlay triangles) where [u_h nu] - g reaches 0
    within ``tol`` of the element's displacement scale somewhere on the element
    (:func:`cvxcontact.solution.checks.touching_nodes`), whatever Bernstein duals the route returned (they are
    not unique where runs of segments touch; docs/formulation.md §8, "Which nodes are active"). A curved contact
    touches inside elements, its nodes open: they count as the nodes of a touching element.

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
    """A friction law: the pair's slip threshold g (Pa; Coulomb: mu p at each merged node, Pa; P2 under
    "sigma1"/"sigma2" p is the rows' normal forces over their own weights, as :attr:`row_shear`: the capacities
    mu y_a / w_a, which a sliding row's shear reaches, extended to every node of X_h as :attr:`row_shear` is, the
    nodes between rows included; |row_shear| <= threshold at the nodes where a row sits); None without friction."""
    slip_measure: np.ndarray | None = None
    """A friction law: the area (3D, m^2) or length (2D, m) the law's rows give each node of X_h, E^T w (w the
    rows' lumped areas or lengths, the friction capacities' weights), what :attr:`shear` divides by on a 3D P2
    surface; None without friction."""
    row_pressure: np.ndarray | None = None
    """A P2 pair: the rows' forces read on the condition's own nodes, Pa, extended to every node of X_h as the
    function of the rows' values (the rows of "sigma1"/"sigma2" sit at that body's P2 nodes, not at nodes of X_h);
    what :attr:`pressure` reads. 2D: y_a over their own weights w_a (the lumped lengths of the condition's rows,
    Simpson's on the constrained trace, the cut segments' shares); 3D "sigma1"/"sigma2": their Riesz
    representer in the P2 functions of that body's faces (:meth:`~cvxcontact.fem.trace.QuadraticTrace.row_pressure`).
    None: the pressure is :attr:`force` over :attr:`measure` (3D P2: :attr:`lam`)."""
    row_shear: np.ndarray | None = None
    """A friction law on a P2 pair: the rows' tangential forces over their own weights (Pa; 3D the capacities'
    areas), extended to every node of X_h as :attr:`row_pressure`; what :attr:`shear` reads. None:
    :attr:`shear_force` over the lumped lengths (areas)."""
    shear_multiplier: np.ndarray | None = None
    """A friction law on a 3D P2 pair: t_h (Pa, (n, 2) along the pair's frame; the tangential traction t of eq. (8)
    with friction, :mod:`cvxcontact.solution.slipestimate`), the Riesz representer of the tangential forces in X_h
    read once per side as :attr:`lam` is (:mod:`cvxcontact.solution.sides`: where several pairs hold one part, the
    pair's share of the side's t_h; a pair alone, its own), what the error estimate reads on tetrahedra
    (``trace.friction_fields``; hexahedra read their faces' hats, :mod:`cvxcontact.solution.tensorestimate`).
    Read-only. None: 2D and P1 (the lumped read-back), or without friction."""
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

        Each row's force is divided by the weight that row holds (the quadrature weight of its condition, the
        one a normal-compliance or friction law is weighted by), so a uniform pressure p reads p at every
        constrained node. P2 on a 2D line (a quadratic trace, ``degree`` 2): the rows' forces over their own
        weights (:attr:`row_pressure`; "gamma3" and obstacles: the forces r = M lambda_h over the row sums
        of the P2 mass matrix of X_h, h/6 per adjacent segment at a vertex, 2h/3 at a midpoint; "sigma1" /
        "sigma2": the rows at that body's P2 nodes over their Simpson weights, extended to the nodes of X_h
        as the P2 function of the rows' values), 0 at the nodes no row reads. On a 3D surface the P2 row
        sums vanish at the vertices (a vertex's shape function integrates to 0 on a triangle): under
        "sigma1"/"sigma2" the pressure is the Riesz representer of the rows' forces in the P2 functions of that
        body's faces, extended to every node of X_h as its P2 function (:attr:`row_pressure`); under "gamma3",
        against an obstacle and under a compliance law lambda_h itself (:attr:`lam`).
        """
        return self.trace.pressure(self)

    @property
    def trace(self) -> LinearTrace:
        """The trace of the solution's space on this pair (:mod:`cvxcontact.fem.trace`, by :attr:`degree`)."""
        return TRACES[self.degree]

    @property
    def shear(self) -> np.ndarray | None:
        """The tangential traction sigma_t on the first body along t (Pa): :attr:`shear_force` over the lumped
        lengths of the constrained nodes (as :attr:`pressure`; P2 under "sigma1"/"sigma2" the rows'
        tangential forces over their own weights, :attr:`row_shear`); |sigma_t| <= g at the rows (P2 under
        "sigma1"/"sigma2": between them the P2 function of the rows' values may exceed g). None without friction."""
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


def electrodes(scene, systems, u_si, phi_si, nodes, rows=None) -> list[Electrode]:
    """The :class:`Electrode` results of every piezoelectric body (SI, see :class:`Electrode`).
    ``nodes``: each body's node set (its mesh, or e.g. the :class:`~cvxcontact.geometry.quadratic.P2Nodes` of a
    P2 solution: an electrode's nodes are then its vertices and edge midpoints). ``rows``: the bodies'
    :func:`electrode_rows` if kept (a load case of the same geometry: the same numbers, without the products over
    the whole body)."""
    out = []
    rows = electrode_rows(scene, systems, nodes) if rows is None else rows
    for k, (b, s, u, phi) in enumerate(zip(scene.bodies, systems, u_si, phi_si)):
        if phi is None:
            continue
        at, Kpp, KupT = rows[k]
        r = np.zeros(len(phi))
        r[at] = Kpp @ (phi - s.phi_fixed) - KupT @ (u.ravel() - s.u_fixed) - s.q[at]      # C/m per node
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


def electrode_rows(scene, systems, nodes) -> list:
    """Per body, None for an elastic one, else (the nodes of its electrodes (r,), the rows of Kpp and of Kup^T
    there (CSR, SI)): what :func:`electrodes` reads of the matrices (geometry alone: kept between load cases)."""
    out = []
    for k, (b, s) in enumerate(zip(scene.bodies, systems)):
        if s.Kpp is None:
            out.append(None)
            continue
        tags = [*b.grounded, *b.potential, *getattr(b, "floating", {})]
        at = nodes[k].boundary_nodes(tags) if tags else np.zeros(0, dtype=np.int64)
        out.append((at, s.Kpp.tocsr()[at], s.Kup.T.tocsr()[at]))
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
    _closed: object = field(default=None, repr=False, compare=False)
    """Where each pair's contact is closed (bool per stacked node of X_h; None: not read): the nodes the read-back
    shares a side's lambda_h (and a friction law's t_h) among (:mod:`cvxcontact.solution.sides`)."""

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
        return pair_lines(self.scene, self.interface)[0][pair]

    def report(self) -> str:
        """A short human-readable account of the solve: what `cvxcontact solve` prints.

        Returns
        -------
        str
            Condition, status, exact finish or why declined; method asked, backend run, route, why handed over;
            each check of (26)-(27) against ``tol``; per pair its force (N/m; N in 3D), :meth:`contact_fraction`, active
            nodes; per electrode potential (V), charge (C/m; C in 3D); per obstacle translation (m), force; estimate.
        """
        declined = self.info.declined
        finish = ("exact finish" if self.polished else (self.info.kept or INTERIOR_POINT_KEPT)
                  + (f" (exact finish declined: {declined.phrase})" if declined else ""))
        info = self.info
        ran = info.requested if info.method == info.requested else f"{info.requested} -> {info.method}"
        lines = [f"condition {self.condition}, solver status {self.status}, {finish}",
                 f"  method           {ran}, route: {info.route}"
                 + (f" (handed over: {info.handed_over})" if info.handed_over else "")]
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
                           "(in contact)")
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
    ``prescribed`` (the check "obstacle balance"), and beside a friction law it includes the friction forces on its
    pairs along the translations it is free to make (:func:`~cvxcontact.solution.friction.obstacle_friction`).
    The friction forces of a fixed obstacle's pairs, and those along a plane's own tangents, are not in ``force``
    (the normal contact forces alone there): their resultant is that of the pairs' ``shear_force``.
    ``pairs`` are its contact pairs.
    """

    obstacle: object
    pairs: tuple
    translation: np.ndarray
    force: np.ndarray
    prescribed: np.ndarray | None = None


def obstacle_results(sol, translations, obstacles=None, friction=None) -> None:
    """Fill ``sol.obstacles`` (:class:`ObstacleResult`) from the stacked nodal forces of ``sol.contacts``
    and ``translations`` (m, the unknowns tau of each force-controlled obstacle, in order); add the
    work -F . t of the prescribed forces to ``sol.energy`` and the check "obstacle balance" (the largest
    |F - sum_a c_a y_a| / |F|) to the residuals. ``obstacles``: the scene's
    :class:`~cvxcontact.physics.obstacles.ObstacleRows` with rows at the stacked nodes of ``sol.contacts``
    (default ``sol.scene.obstacles``, the P1 merged nodes; P2: rows at the P2 nodes). ``friction``: per
    force-controlled obstacle (in order) the resultant (d,) of the friction forces on its pairs, added to its force
    (:func:`~cvxcontact.solution.friction.obstacle_friction`; None: none)."""
    y = np.concatenate([c.force for c in sol.contacts])                     # N/m at the stacked merged nodes
    taus, out, worst = iter(translations), [], 0.0
    frictions = iter(friction or ())
    for o in (sol.scene.obstacles if obstacles is None else obstacles):
        rows = o.rows.toarray()
        force = rows.T @ y
        t = np.zeros(rows.shape[1]) if o.force is None else o.basis @ next(taus)
        if o.force is not None:
            extra = next(frictions, 0.0)
            force = force + extra
            worst = max(worst, obstacle_balance(o.force, rows, y, extra))
            sol.energy -= float(o.force @ t)
        for a in (t, force):
            a.setflags(write=False)
        out.append(ObstacleResult(o.obstacle, o.pairs, t, force, o.force))
    sol.obstacles = out
    if any(o.force is not None for o in sol.scene.obstacles):
        sol._checks["obstacle balance"] = worst


def pair_lines(scene, interface):
    """(each pair's contact line, the offsets of its nodes in the stacked arrays): P1 (``interface`` None)
    the scene's interfaces; P2 a :class:`~cvxcontact.contact.quadratic.QuadraticInterface` (one pair) or a
    :class:`~cvxcontact.contact.quadratic.QuadraticStack`."""
    if interface is None:
        return scene.interfaces, scene.stack.offsets
    if hasattr(interface, "interfaces"):
        return interface.interfaces, interface.offsets
    return [interface], [0, interface.size]


def line_offset(pair) -> float:
    """The ordinate (m) of a 2D pair's line (its first part's mean x2); in 3D the offset x . nu of the
    first part's plane."""
    return float(pair.y) if hasattr(pair, "y") else float(pair.traces[0].offset)
