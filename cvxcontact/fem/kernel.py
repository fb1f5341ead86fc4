"""Is the assembled contact problem well posed? The rigid motions nothing but the contact holds, judged
across every body and obstacle of a scene together with its loads.

The problem
-----------
With x the unknowns of every body (after the supports' prolongation, docs/formulation.md §11) and the
translations tau of the force-controlled obstacles (§12), the discrete problem reads

    min J(x) = 1/2 x^T K x - f^T x      subject to      G x <= g                          (*)

K symmetric positive semi-definite (the electric unknowns condensed: their block is definite, since every
piece of a piezoelectric body touches an electrode), G the contact rows (the evaluation E of the pairs'
conditions times the normal jumps, plus each obstacle's rows c(x) . t), f the loads (each body's lifted
nodal load, each obstacle's prescribed force). Its kernel Z = ker K is spanned by

- the rigid motions of each body (each mesh component) that no support holds (:meth:`Body.held_modes`:
  P1 vertices or P2 nodes), and
- the translations of the force-controlled obstacles (:class:`~cvxcontact.physics.obstacles.ObstacleRows`
  ``basis``: the directions their rows see).

For d in Z, K d = 0, so J(x + t d) = J(x) - t f^T d, and every row changes by t (G d)_i. (A rigid d has
no strain, so d^T K_up = 0 and d^T K_uu u_D = 0: the condensed and lifted load does the work f^T d.)

The criterion
-------------
Let P = {G x <= g} (non-empty) and R = {d : G d <= 0} its recession cone: the directions no contact
resists (they open rows or leave them unchanged).

(i) Existence. Along d not in Z the energy grows quadratically; along d in Z it changes linearly. A
    convex quadratic bounded below along every ray of a polyhedron is bounded below on it and attains its
    minimum (Frank-Wolfe), so (*) has a solution iff f^T d <= 0 for every d in Z n R. If f^T d > 0 for
    some: no solution, the load pulls the bodies off along d ("pulls ... off").

(ii) Uniqueness. The minimisers of a convex quadratic share K x and f^T x; they are x* + d with d in Z,
    x* + d in P and f^T d = 0. If some non-zero d in Z n R has f^T d = 0, then x* + t d is feasible with
    the same energy for every t >= 0: the motion drifts, whatever the gap g. This includes a d that opens
    some rows and leaves others unchanged (G d <= 0 with zero entries): the load may then be carried by
    the unchanged rows alone, a minimiser exists, and it is not unique. Examples: the tangential
    translation of a force-controlled circle over a half model (it opens every row but the one on the
    symmetry line, where the whole force then sits), a rotation about a corner when the load's line of
    action passes through it, a load-free body on a floor (it may lift off).

Hence the condition decided here, necessary for a unique solution whatever the gaps, and sufficient for a
solution with a bounded set of minimisers:

    (W)   f^T d < 0   for every non-zero d in Z n R.

Not decided by (W): a non-uniqueness that depends on the gaps, a d in Z with f^T d = 0 that closes only
rows that stay open at the solution (a load-free body floating in an open gap); such a d is not in R.
After an exact solve, :func:`check_determined` decides it: (W) on the rows active at the solution.

Normal compliance (docs/formulation.md §10): along a direction that closes a compliant row its energy
grows like t^(m+1), m >= 1, faster than the work; along one that opens it, it vanishes. So the cone R is
the same and (W) is the criterion too (a penetration limit is a row). P2 "gamma3" (the everywhere
condition): the nodal rows at the P2 nodes are used; a rigid motion's jump along a straight line is
affine, so there nodal <= 0 is everywhere <= 0 (only an obstacle's varying sensitivity is not affine).

The decision
------------
In the kernel's coordinates alpha (d = D alpha, D the basis), with A = G D and w = D^T f, (W) says the
cone C' = {alpha : A alpha <= 0, w^T alpha >= 0} is {0}. With L = {A alpha = 0} the motions no row sees
(its lineality):

1. if w has a component in L, the load pushes along it and nothing resists ("pulls ... off"); else every
   direction of L is undetermined (both it and its opposite are in Z n R with zero work);
2. else (L = {0}) C' is pointed: the LP max w^T alpha, A alpha <= eps, |alpha|_inf <= 1 finds a pull-off
   direction if its value is positive (beyond a tolerance);
3. else C' != {0} iff one of the 2 m LPs max +-alpha_j, A alpha <= eps, w^T alpha >= -eps,
   |alpha|_inf <= 1 reaches 1 (scale any non-zero alpha of C' to |alpha|_inf = 1: the LP of its largest
   coordinate reaches 1); a value >= 1/2 names an undetermined direction.

Scales. D's columns are unit motions (translations of 1, rotations moving the piece's size by 1) and E,
the jumps and the sensitivities are dimensionless, so A does not depend on the units; each row of A is
scaled to a unit maximum (which leaves the cone unchanged) and rows that no unit motion moves by
``ROW_TOL`` are dropped (rows held by the supports). w is in N/m; an entry below ``CANCELLATION`` times
the sum of the magnitudes of its terms is rounding (the moment of a symmetric load) and is set to 0;
then w is scaled to a unit norm on each group of kernel coordinates that some row couples, so that
independent parts of a scene with loads of very different size are judged each on its own. Multiplying
every load by a constant, or changing the units of length, leaves the decision unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.linalg import null_space, qr
from scipy.optimize import linprog
from scipy.sparse.csgraph import connected_components

from ..errors import SceneError

__all__ = ["Kernel", "rigid_kernel", "undetermined", "check_well_posed", "refuse_sliding", "check_determined", "ROW_TOL", "CANCELLATION",
           "SLACK"]

ROW_TOL = 1e-9
"""A contact row that every unit kernel motion moves by less than this (dimensionless) is not moved."""
SLIP_POLYGON = 24
"""Sides of the polygon around the circle of a 3D row's slip in :func:`sliding` (the LP's stand-in for the norm)."""

CANCELLATION = 1e-10
"""A kernel direction's work below this fraction of the sum of the magnitudes of its terms is zero."""

SLACK = 1e-9
"""The tolerance of the cone's rows and of the work (scaled rows, unit-norm work, |alpha|_inf <= 1)."""

_PULL = 1e-6
"""A scaled work above this, along a unit direction no contact resists, pulls off (step 2)."""


@dataclass(frozen=True)
class Kernel:
    """The kernel Z of the assembled problem (module docstring) in its coordinates alpha.

    ``rows`` (r, m): how each kernel coordinate changes each contact row's value [u_nu] - g, per unit
    motion (dimensionless; rows that no coordinate moves left out), ``index`` (r,) their rows in the
    evaluation E. ``work`` (m,) N/m: the load's work
    f^T d per unit motion; ``magnitude`` (m,) N/m the sum of the magnitudes of its terms. ``owners``:
    one (label, kind, coordinate slice, namer) per body or obstacle with kernel coordinates, kind "body"
    or "obstacle", namer(alpha_slice) -> readable motion.
    """

    rows: np.ndarray
    index: np.ndarray
    work: np.ndarray
    magnitude: np.ndarray
    owners: tuple
    slip: np.ndarray | None = None
    """With a friction law: (c r_t, m) how each kernel coordinate changes each row's slip [u_t] per unit motion
    (dimensionless; ``components`` c per row, component-major: 1 in 2D, 2 in 3D), ``capacity`` (r_t,) N/m
    each row's friction capacity g_a w_a (``inf``: not known yet, a Coulomb row before its pressure: the row
    resists any slip), ``slip_index`` (r_t,) their rows in E."""
    capacity: np.ndarray | None = None
    slip_index: np.ndarray | None = None
    components: int = 1

    def with_capacity(self, capacity: np.ndarray) -> Kernel:
        """The kernel with the friction capacities ``capacity`` (N/m, one per row of E)."""
        if self.slip_index is None:
            return self
        return replace(self, capacity=np.asarray(capacity, dtype=float)[self.slip_index])

    @property
    def size(self) -> int:
        """The dimension m of the kernel."""
        return len(self.work)

    def at(self, active: np.ndarray) -> "Kernel":
        """The kernel with the rows of E marked in ``active`` (a boolean per row) only."""
        keep = np.asarray(active, dtype=bool)[self.index]
        return replace(self, rows=self.rows[keep], index=self.index[keep])

    def moved(self, alpha: np.ndarray) -> list[tuple[str, str, str]]:
        """(label, kind, motion) of each owner that the kernel motion ``alpha`` moves."""
        alpha = np.asarray(alpha, dtype=float)
        top = float(np.abs(alpha).max(initial=0.0))
        return [(label, kind, namer(alpha[s])) for label, kind, s, namer in self.owners
                if np.abs(alpha[s]).max(initial=0.0) > 1e-6 * top]

    def name(self, alpha: np.ndarray) -> str:
        """The motion ``alpha``, named by its owners: "translation y of body 'layer' with ..."."""
        return " with ".join(f"{motion} of {label}" for label, _, motion in self.moved(alpha))


def rigid_kernel(bodies: Sequence, loads: Sequence[np.ndarray], evaluation: sp.spmatrix, interface,
                 obstacles: Sequence = (), nodes: Sequence | None = None, capacity=None) -> Kernel:
    """The :class:`Kernel` of a scene's assembled problem.

    ``bodies``: the scene's bodies; ``loads[k]`` (2 n_k,) N/m body k's lifted nodal load
    (:func:`cvxcontact.fem.assembly.assemble_loads` / :func:`cvxcontact.fem.p2.assemble_loads`, ``.f``);
    ``evaluation`` E (rows, merged nodes) and ``interface`` the stacked contact lines with ``jump(k, n)``
    (P1 ``scene.stack``, P2 the :class:`~cvxcontact.contact.quadratic.QuadraticStack`); ``obstacles`` the
    scene's :class:`~cvxcontact.physics.obstacles.ObstacleRows` with rows on the same merged nodes (fixed ones
    are skipped); ``nodes[k]`` body k's node set (P2 :class:`~cvxcontact.geometry.quadratic.P2Nodes`) or
    None (P1 vertices). ``capacity``: with a friction law, (slip, c, moves): ``slip(k, n)`` body k's slip rows at the
    rows of E, c (N/m) their friction capacities (the kernel's ``slip`` and ``capacity``) and ``moves(o)`` the slip
    rows (c R, k) of a force-controlled obstacle's translations (:func:`~cvxcontact.discrete.slip.obstacle_slip`
    at the frictional rows), else None."""
    E = sp.csr_matrix(evaluation)
    nodes = list(nodes) if nodes is not None else [None] * len(bodies)
    cols, work, magnitude, owners, slips = [], [], [], [], []
    m = 0
    for k, (b, f, nd) in enumerate(zip(bodies, loads, nodes)):
        if not b.held_by_contact:
            continue
        modes = b.held_modes(nd)                                       # (k_b, d n)
        if not len(modes):
            continue
        f = np.asarray(f, dtype=float)
        n = len((b.mesh if nd is None else nd).points)
        J = interface.jump(k, n)
        cols.append(np.asarray(E @ (J @ modes.T)))
        if capacity is not None:
            slips.append(np.asarray(capacity[0](k, n) @ modes.T))
        work.append(modes @ f)
        magnitude.append(np.abs(modes) @ np.abs(f))
        owners.append((f"body {b.name!r}", "body", slice(m, m + len(modes)), b.motion_name))
        m += len(modes)
    for i, o in enumerate(obstacles):
        if o.force is None:
            continue
        basis = np.asarray(o.basis, dtype=float)
        cols.append(np.asarray(E @ sp.csr_matrix(o.rows) @ basis))
        F = np.asarray(o.force, dtype=float)
        work.append(basis.T @ F)
        magnitude.append(np.abs(basis.T) @ np.abs(F))
        if capacity is not None:                        # the slip its translations cause at the frictional rows
            slips.append(np.asarray(capacity[2](o)))
        owners.append((f"obstacle {i} ({o.obstacle!r})", "obstacle", slice(m, m + basis.shape[1]),
                       lambda a, basis=basis: _translation_name(basis @ a)))
        m += basis.shape[1]
    if not m:
        return Kernel(np.zeros((0, 0)), np.zeros(0, dtype=int), np.zeros(0), np.zeros(0), ())
    A = np.hstack(cols)
    index = np.flatnonzero(np.abs(A).max(axis=1) > ROW_TOL)             # rows no unit motion moves: out
    slip = c = None
    if capacity is not None:
        c = np.asarray(capacity[1], dtype=float)
        slip = np.hstack(slips)
        n_c = slip.shape[0] // len(c)                                  # slip components per row
        slip = slip.reshape(n_c, len(c), -1)
        moved = np.abs(slip).max(axis=(0, 2)) > ROW_TOL
        return Kernel(A[index], index, np.concatenate(work), np.concatenate(magnitude), tuple(owners),
                      slip[:, moved].reshape(-1, m), c[moved], np.flatnonzero(moved), n_c)
    return Kernel(A[index], index, np.concatenate(work), np.concatenate(magnitude), tuple(owners))


def sliding(kernel: Kernel) -> tuple[np.ndarray, float, float] | None:
    """With a friction law: a kernel motion alpha (|alpha|_inf = 1) that no contact row resists (A alpha <= 0)
    along which the load's work exceeds the friction dissipation sum_a c_a |(S alpha)_a| (the energy is then
    unbounded below: no equilibrium), with that work and dissipation (N/m per unit motion); None if there is
    none. The linear program max w^T alpha - c^T s, A alpha <= 0, -s <= S alpha <= s, |alpha|_inf <= 1 (a row
    of infinite capacity: S_a alpha = 0). In 3D (two slip components) s_a >= |(S alpha)_a|_2 is replaced by the
    polygon of :data:`SLIP_POLYGON` sides around the circle (s_a >= d_k . (S alpha)_a / cos(pi/K)): the
    dissipation is over-estimated by at most 1/cos(pi/K) - 1 (0.8 % for K = 24), so a motion is refused only
    where the load truly exceeds the capacity; the dissipation returned is the exact one."""
    if kernel.slip is None or not kernel.size:
        return None
    A, w = _scaled(kernel)
    c = kernel.capacity
    m, r, n_c = kernel.size, len(c), kernel.components
    S = kernel.slip.reshape(n_c, r, m)
    tied = ~np.isfinite(c)
    c = np.where(tied, 0.0, c)
    norm = float(np.linalg.norm(w))
    if norm == 0:
        return None
    obj = np.concatenate([-w / norm, c / norm])
    blocks = [np.hstack([A, np.zeros((len(A), r))])] if len(A) else []
    if n_c == 1:
        blocks += [np.hstack([S[0], -np.eye(r)]), np.hstack([-S[0], -np.eye(r)])]
    else:
        angles = 2 * np.pi * np.arange(SLIP_POLYGON) / SLIP_POLYGON
        cos = np.cos(np.pi / SLIP_POLYGON)
        blocks += [np.hstack([np.cos(a) * S[0] + np.sin(a) * S[1], -cos * np.eye(r)]) for a in angles]
    if tied.any():                                     # S_a alpha = 0 where the capacity is unbounded
        zeros = np.zeros((int(tied.sum()), r))
        blocks += [np.hstack([sign * S[j][tied], zeros]) for j in range(n_c) for sign in (1.0, -1.0)]
    A_ub = np.vstack(blocks)
    b_ub = np.concatenate([np.full(len(A), SLACK), np.zeros(len(A_ub) - len(A))])
    res = linprog(obj, A_ub=A_ub, b_ub=b_ub, bounds=[(-1, 1)] * m + [(0, None)] * r, method="highs")
    if res.status != 0 or -res.fun <= _PULL:
        return None
    alpha = res.x[:m]
    alpha = alpha / np.abs(alpha).max()

    def margin(a):                      # the load's work beyond the exact dissipation, per unit |a|_inf
        return float(kernel.work @ a - c @ np.linalg.norm(S @ a, axis=0)) / float(np.abs(a).max())

    if n_c > 1:                         # the polygon may tilt the motion: drop coordinates that only cost
        alpha[np.abs(alpha) < 1e-6] = 0.0
        for i in np.argsort(np.abs(alpha)):
            trial = alpha.copy()
            trial[i] = 0.0
            if alpha[i] == 0.0 or not trial.any():
                continue
            trial /= np.abs(trial).max()
            held = (len(A) and (A @ trial > SLACK).any()) or (tied.any() and np.abs(S[:, tied] @ trial).max() > ROW_TOL)
            if not held and margin(trial) >= margin(alpha):
                alpha = trial
    return alpha, float(kernel.work @ alpha), float(c @ np.linalg.norm(S @ alpha, axis=0))


def undetermined(kernel: Kernel) -> tuple[str, list[np.ndarray]] | None:
    """None if (W) holds (module docstring), else ``(kind, directions)``: kind "pulls" (the load does
    positive work along the direction, which no contact resists) or "free" (it does none: nothing determines
    the direction), ``directions`` kernel coordinates alpha (|alpha|_inf = 1)."""
    if not kernel.size:
        return None
    A, w = _scaled(kernel)
    if kernel.slip is not None and len(kernel.slip):   # friction resists slip both ways: S alpha = 0
        S = kernel.slip[np.abs(kernel.slip).max(axis=1) > 0]
        S = S / np.abs(S).max(axis=1, keepdims=True)
        A = np.vstack([A, S, -S]) if len(A) else np.vstack([S, -S])
    m = kernel.size
    coupled = sp.csr_matrix(np.abs(A).T @ np.abs(A) > 0) if len(A) else sp.csr_matrix((m, m))
    count, group = connected_components(coupled, directed=False)
    for g in range(count):
        on = np.flatnonzero(group == g)
        rows = A[:, on]
        rows = rows[np.abs(rows).max(axis=1) > 0] if len(rows) else rows
        verdict = _decide(rows, w[on])
        if verdict is not None:
            kind, dirs = verdict
            out = []
            for d in dirs:
                full = np.zeros(m)
                full[on] = d
                out.append(full)
            return kind, out
    return None


def _decide(A, w):
    """(W) on one coupled group: A (r, m) scaled rows, w (m,) work (N/m, cancellation removed)."""
    m = len(w)
    norm = float(np.linalg.norm(w))
    w = w / norm if norm > 0 else w
    # 1. the lineality L = {A alpha = 0}: no row sees these motions, in either direction
    if len(A):
        # Vt (m, m) whole either way; U only as wide as needed (r x r would be r^2 floats: 8e3 contact rows took
        # 0.5 GB; Vt and sv bitwise the same as with full_matrices=True)
        _, sv, Vt = np.linalg.svd(A, full_matrices=len(A) < m)
        rank = int((sv > 1e-9 * sv[0]).sum()) if len(sv) else 0
        L = Vt[rank:].T
    else:
        L = np.eye(m)
    if L.shape[1]:
        wl = L.T @ w
        if np.linalg.norm(wl) > SLACK:
            d = L @ wl
            return "pulls", [d / np.abs(d).max()]
        return "free", list(_readable(L))
    # 2. a pull-off direction (L = {0}: the cone is pointed)
    ub = np.full(len(A), SLACK)
    if norm > 0:
        res = linprog(-w, A_ub=A, b_ub=ub, bounds=(-1, 1), method="highs")
        if res.status == 0 and -res.fun > _PULL:
            return "pulls", [res.x / np.abs(res.x).max()]
    # 3. a non-zero direction along which the load does no work and no contact resists
    A_ub, b_ub = (np.vstack([A, -w[None, :]]), np.append(ub, SLACK)) if norm > 0 else (A, ub)
    d = _free_direction(A_ub, b_ub, range(m), m)
    return None if d is None else ("free", [d])


def _scaled(kernel) -> tuple[np.ndarray, np.ndarray]:
    """(A, w): the kernel's rows scaled to a unit largest entry, and its work with cancellation removed."""
    A = kernel.rows / np.abs(kernel.rows).max(axis=1, keepdims=True) if len(kernel.rows) else kernel.rows
    w = np.where(np.abs(kernel.work) > CANCELLATION * kernel.magnitude, kernel.work, 0.0)
    return A, w


def _free_direction(A_ub, b_ub, coords, m: int) -> np.ndarray | None:
    """A direction alpha (m,) with A_ub alpha <= b_ub, |alpha|_inf <= 1 whose coordinate j reaches 1/2 in
    either sign for some j of ``coords`` (a linear program each), scaled to |alpha|_inf = 1; or None (at the cost
    of one linear program where :func:`_bounded_below_half` proves that none reaches 1/2)."""
    if _bounded_below_half(A_ub, b_ub, coords, m):
        return None
    for j in coords:
        for sign in (1.0, -1.0):
            c = np.zeros(m)
            c[j] = -sign
            res = linprog(c, A_ub=A_ub if len(A_ub) else None, b_ub=b_ub if len(A_ub) else None, bounds=(-1, 1),
                          method="highs")
            if res.status == 0 and -res.fun >= 0.5:
                x = np.where(np.abs(res.x) > 1e-6, res.x, 0.0)
                return x / np.abs(x).max()
    return None


def _bounded_below_half(A_ub, b_ub, coords, m: int) -> bool:
    """True if no alpha with A_ub alpha <= b_ub (b_ub >= 0), |alpha|_inf <= 1 has a coordinate j of ``coords``
    above 1/4 in either sign, proved by weak duality: for y >= 0 and z = A_ub^T y -+ e_j, +-alpha_j <= b_ub^T y +
    |z|_1. One linear program finds y0 >= 1 with A_ub^T y0 = 0 (the rows span R^m positively: the cone
    {A_ub alpha <= 0} is {0}); a least-squares Y with A_ub^T Y = I (A_ub of full column rank) then gives
    y = max(+-Y_j + t y0, 0) for every objective at once. False (not proved: :func:`_free_direction` solves its
    2 m programs, as before) where either fails or a bound, or 1e-6 |y|_1 (ten times HiGHS's feasibility
    tolerance on the rows), is not below 1/4; where True, each of those programs stays below 1/2 by a margin, so
    none would have named a direction: the same decision, at the cost of one program instead of 2 m."""
    A_ub, b_ub = np.asarray(A_ub, dtype=float).reshape(-1, m), np.asarray(b_ub, dtype=float)
    r = len(A_ub)
    coords = np.asarray(list(coords), dtype=int)
    if r <= m or not len(coords) or (b_ub < 0).any():
        return False
    res = linprog(np.ones(r), A_eq=A_ub.T, b_eq=np.zeros(m), bounds=(1, None), method="highs")
    if res.status != 0:
        return False
    y0 = res.x
    Y, _, rank, _ = np.linalg.lstsq(A_ub.T, np.eye(m)[:, coords], rcond=None)
    if rank < m:
        return False
    E = np.eye(m)[:, coords]
    worst = 0.0
    for sign in (1.0, -1.0):
        t = np.maximum(0.0, (-sign * Y / y0[:, None]).max(axis=0))     # sign Y_j + t y0 >= 0, column by column
        y = np.maximum(sign * Y + t * y0[:, None], 0.0)
        z = np.abs(A_ub.T @ y - sign * E).sum(axis=0)                    # sign e_j = A_ub^T y - z exactly
        worst = max(worst, float((b_ub @ y + z).max()), 1e-6 * float(y.sum(axis=0).max()))
    return worst < 0.25


def _readable(L):
    """A basis of the column space of L with an identity at pivot coordinates (pure motions where possible),
    each column scaled to a unit maximum."""
    _, _, piv = qr(L.T, pivoting=True)
    k = L.shape[1]
    B = L @ np.linalg.inv(L[piv[:k]])
    B = np.where(np.abs(B) > 1e-9, B, 0.0)
    return (B / np.abs(B).max(axis=0)).T


def _translation_name(t) -> str:
    """A readable name of an obstacle's translation t (m per unit; 2 or 3 components)."""
    t = np.asarray(t, dtype=float) / np.linalg.norm(t)
    axis = np.flatnonzero(np.abs(t) > 1e-9)
    if len(axis) == 1:
        return f"translation {'xyz'[axis[0]]}"
    return f"translation along ({', '.join(f'{c:.4g}' for c in t)})"


def check_well_posed(bodies: Sequence, loads: Sequence[np.ndarray], evaluation: sp.spmatrix, interface,
                     obstacles: Sequence = (), nodes: Sequence | None = None, capacity=None) -> Kernel | None:
    """Raise a :class:`~cvxcontact.errors.SceneError` naming the body or obstacle and the motion if the
    assembled problem leaves a rigid motion undetermined or unbounded: condition (W) of the module
    docstring, over every body and obstacle at once. Arguments as in :func:`rigid_kernel`. Returns the
    :class:`Kernel` (for :func:`check_determined` after the solve), or None, at no cost, when no body has
    a motion the supports leave free and no obstacle is force controlled. With a friction law (``capacity``, as in
    :func:`rigid_kernel`) the friction holds slipping motions up to its capacity: a load beyond it slides the
    body (:func:`sliding`), refused naming the motion."""
    if not any(b.held_by_contact for b in bodies) and not any(o.force is not None for o in obstacles):
        return None
    kernel = rigid_kernel(bodies, loads, evaluation, interface, obstacles, nodes, capacity)
    refuse_sliding(kernel)
    verdict = undetermined(kernel)
    if verdict is None:
        return kernel
    kind, dirs = verdict
    if kind == "pulls":
        d = dirs[0]
        moved = kernel.moved(d)
        who, motion = ((moved[0][0], moved[0][2]) if len(moved) == 1 else ("the bodies", kernel.name(d)))
        raise SceneError(f"the load pulls {who} off along {motion} (its net load along it, "
                         f"{float(kernel.work @ d):.6g} N/m, is not balanced by compressive contact forces): add a "
                         "support or load it towards the contact")
    raise SceneError(f"nothing determines the {_names(kernel, dirs)}: the load does no work along it and no contact "
                     f"resists it: {_hint(kernel, dirs)}")


def refuse_sliding(kernel: Kernel | None, what: str | None = None, remedy: str = "raise the threshold") -> None:
    """Raise a :class:`~cvxcontact.errors.SceneError` naming the motion if the load slides a body beyond its
    friction capacity (:func:`sliding`); ``what`` says what the capacity is (default: the threshold times the
    contact length, 2D, or area, 3D) and ``remedy`` what raises it."""
    slide = None if kernel is None else sliding(kernel)
    if slide is None:
        return
    d, work, dissipation = slide
    moved = kernel.moved(d)
    who, motion = ((moved[0][0], moved[0][2]) if len(moved) == 1 else ("the bodies", kernel.name(d)))
    unit = "N" if kernel.components > 1 else "N/m"                     # 3D: two slip components per row
    what = what or f"threshold times contact {'area' if kernel.components > 1 else 'length'}"
    raise SceneError(f"the load slides {who} along {motion}: its net load along it, {work:.6g} {unit}, exceeds "
                     f"the friction capacity {dissipation:.6g} {unit} ({what}), so no "
                     f"equilibrium exists: add a support, reduce the tangential load or {remedy}")


def check_determined(kernel: Kernel | None, active: np.ndarray) -> None:
    """After an exact solve: raise a :class:`~cvxcontact.errors.SceneError` if the solution leaves a body's
    motion free, i.e. some non-zero d in Z moving a body that no active row resists (G_A d <= 0) along which
    the load does no work. The minimisers are x* + d with d in Z, x* + d feasible and f^T d = 0; near x* the
    rows that are open do not matter, and f^T d = y^T G_A d by stationarity; so d is a further minimiser iff
    G_A d <= 0 and f^T d >= 0: (W) of the module docstring on the active rows A. It catches what (W) on all
    rows cannot see, a motion held only by rows that are open at the solution (a load-free body floating
    in an open gap). ``active``: a boolean per row of E (the exact finish's active set).

    A free motion of obstacles alone (an obstacle on one contact node whose sensitivity has no tangential
    part: a sphere touching at the node on its axis) is not refused: (W) on all rows held before the solve,
    so the open rows bound it, and the bodies' fields and the forces are the same at every minimiser (the
    energy is strictly convex in them); a :class:`~cvxcontact.errors.NonUniqueWarning` names it (the
    finish holds it at the interior point's value, ``mixed_kkt(hold=)``)."""
    if kernel is None or active is None:
        return
    here = kernel.at(active)
    verdict = undetermined(here)
    if verdict is None or verdict[0] != "free":
        return
    moving = _free_body_motion(here)
    if moving is not None:
        raise SceneError(f"the solution does not determine the {_names(here, [moving])}: the contacts that would "
                         "hold it are open at the solution and the load does no work along it (e.g. a load-free body "
                         f"in an open gap): {_hint(here, [moving])}")
    import warnings

    from ..errors import NonUniqueWarning, user_stacklevel
    dirs = verdict[1]
    obstacle = _owned(here, "obstacle")
    unseen = null_space(here.rows[:, obstacle].reshape(-1, int(obstacle.sum())), rcond=1e-9) if obstacle.any() \
        else np.zeros((0, 0))
    if unseen.shape[1]:                                 # every unseen translation, not one group's
        dirs = []
        for d in _readable(unseen):
            full = np.zeros(here.size)
            full[obstacle] = d
            dirs.append(full)
    warnings.warn(f"the solution does not determine the {_names(here, dirs)} (no contact carrying force sees "
                  "it; the open contacts bound it): one solution is returned, the translation held at the interior "
                  "point's value; the displacements, potentials and contact forces are the same for all. Refine the "
                  "mesh under the obstacle or guide it (guided=) for a unique translation", NonUniqueWarning,
                  stacklevel=user_stacklevel())


def _free_body_motion(kernel) -> np.ndarray | None:
    """A kernel direction that moves a body (a body coordinate reaching 1/2 at |alpha|_inf <= 1) with no row of
    ``kernel`` resisting it and no work of the load against it, or None (the free motions move obstacles
    only)."""
    body = _owned(kernel, "body")
    if not body.any():
        return None
    A, w = _scaled(kernel)
    norm = float(np.linalg.norm(w))
    A_ub = np.vstack([A.reshape(-1, kernel.size), -(w / norm)[None, :]]) if norm > 0 else A.reshape(-1, kernel.size)
    return _free_direction(A_ub, np.full(len(A_ub), SLACK), np.flatnonzero(body), kernel.size)


def _owned(kernel, kind: str) -> np.ndarray:
    """(m,) bool: the kernel coordinates of the owners of ``kind`` ("body" or "obstacle")."""
    mask = np.zeros(kernel.size, dtype=bool)
    for _, owner, sl, _ in kernel.owners:
        mask[sl] = owner == kind
    return mask


def _names(kernel, dirs) -> str:
    names = [kernel.name(d) for d in dirs]
    return names[0] if len(names) == 1 else "motions " + "; ".join(names)


def _hint(kernel, dirs) -> str:
    kinds = {kind for d in dirs for _, kind, _ in kernel.moved(d)}
    hint = []
    if "obstacle" in kinds:
        hint.append("fix the obstacle (no force=, a prescribed position), or give its force a component along "
                    "that motion that a contact resists (a symmetry support of the body does not hold an obstacle "
                    "across it: model the whole body)")
    if "body" in kinds:
        hint.append("add a clamped, roller or displacement support that stops it, or load the body towards the "
                    "contact")
    return "; or ".join(hint)
