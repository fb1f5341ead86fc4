"""The exact finish of a friction law (Tresca, Coulomb; docs/howto/friction.md, "The exact finish"): semismooth
Newton on the mixed system (26)-(27) with the friction rows, in the Alart-Curnier (projection) form, from the
interior point's answer.

Unknowns w = (x, y, mu): x the stacked unknowns of :func:`~cvxcontact.backends.mixed.mixed_system`, y the normal
row forces, mu_a (c components, c = 1 in 2D, 2 in 3D) the tangential force of frictional row a, s_a = S_a x + s0_a
its slip and c_a = c0_a + D_a y_a its capacity (Tresca: D = 0; Coulomb: c0 = 0, D = mu). With r_n, r_t > 0 (force
per displacement) the conditions are

    T x - b + G^T y + S^T mu = 0                                  (momentum and Gauss rows of (26))
    y_a - max(0, y_a + r_n (G x - g)_a) = 0                        (Signorini, (27))
    mu_a - proj_{B(c_a)}(mu_a + r_t s_a) = 0                       (|mu_a| <= c_a, mu_a = c_a s_a/|s_a| on slip)

whose generalised Jacobian at the point's own active set is: a closed row G_a x = g_a, an open row y_a = 0; a
stuck row (|z_a| <= c_a, z_a = mu_a + r_t s_a) S_a x + s0_a = 0; a slipping row mu_a - c_a t_a = 0 with
t_a = z_a / |z_a|, linearised with P_a = I - t_a t_a^T, k_a = c_a / |z_a| as
(I - k_a P_a) dmu_a - k_a r_t P_a S_a dx - D_a t_a dy_a. In 2D P_a = 0: a slipping row's force is c_a sign(z_a),
a linear condition, and the steps end once the active set is right; in 3D the direction is nonlinear and the
steps converge quadratically near the answer. Each step is damped by halving on the scaled residual's norm,
except that in 3D (and on dependent rows) the full step to an active set not met before is taken even where it
raises the residual (the semismooth active-set move): with P2 tetrahedra's nodal rows a face vertex whose
consistent force would be a tension (a pressure that varies across the face) opens, and the damped steps towards
it only halved the residual at every step (a box pushed across a rigid plane: 3e-7, 1.5e-7, ... and declined).
Not in 2D, where a set already solved that comes back ends the steps as a cycle: there the full steps to new sets
cycled where the damped ones settle (a 2D P2 pair under "sigma1" with Tresca friction, tests/test_tresca.py).

The residual is scaled: the momentum rows over the sizes of their terms, at least those had every unknown been
the largest (|T_i| max|x|: a body at rest beside one that moves, e.g. the clamped lower block of a pair that
opens, has rows whose own terms are the rounding of the coupled solve), the normal and friction rows over the force
scale C (:func:`~cvxcontact.backends.finish.forces.friction_scale` with ``whole``: floored at the elastic forces
at the rows, so an open contact whose Coulomb capacities are 0 has a scale; the whole displacement's, as the
interior point's noise, where the checks read the bodies' deformation). A repeated active set ends the steps where the step
solved it (2D), or where the residual is at rounding (SIGN_TOL) and no longer halves.

A second start: where the steps from the interior point's answer decline, they start once more from its
displacement with every free row closed (y_a = C) and no tangential force (every moved row then slipping along
its slip, z_a = r_t s_a), and the first decline stands if those decline too. The interior point's forces may be
noise where the displacement is mostly rigid: a 1 m cube slid by 1 m deforms by 5.1e-9 m, the units' load is the
slide's, and the contact forces are 1e-10 of the force unit, below the interior point's precision (it answered
0.17 N of a 1000 N load, every row open); the steps from there did not settle, from the second start they settle
in 3 (tests/test_friction_balance.py). The acceptance below is the same for either start. Not in 3D where the rows
may be dependent: there the steps on the slipping rows' directions
(:func:`~cvxcontact.backends.finish.directions.fixed_directions`) come first, then the steps from the interior
point's answer, and no second start.

No data: with no load (b = 0), no prescribed slip (s0 = 0) and no interference (g >= 0 on the rows some unknown
moves), x = 0, y = 0, mu = 0 satisfies every condition, and is the answer (the interior point's is its noise). The
scaled residual is relative, so the steps could not tell that noise from the answer: the finish answers 0 at once,
its rows at zero gap closed with no force.

Degenerate rows: a row may carry no force at no gap and no slip in the answer itself (strict complementarity
fails). With P2 tetrahedra's nodal rows under a uniform pressure and shear the consistent forces vanish at the
face vertices (0 there, A/3 per face at an edge midpoint): y_a = 0, G_a x = g_a, mu_a = 0, s_a = 0, and Coulomb's
capacity mu y_a = 0 too. Either branch of each row's law holds there, the steps reach rounding, and the signs of
y_a + r_n (G x - g)_a and c_a - |z_a| are those of the rounding: the set flips on every step among such rows,
never repeats, and the steps were declined ("did not settle", on some BLAS kernels and not others). Ties go one
way: a row counts as closed while y_a + r_n (G x - g)_a > -TIE C and as stuck while |z_a| <= c_a + TIE C, a
threshold a thousand times rounding (an open row's gap or a slipping row's slip below TIE U is rounding of the
displacements). A degenerate row is then closed and stuck at every step (its gap and slip held at 0, its forces
those (26) gives, rounding), the set repeats and the steps settle; the acceptance checks are unchanged.

A row whose slip some unknown moves in one tangential component but not in the other (a support on a side that
meets the contact fixes one direction at its nodes, docs/howto/friction.md) has a component j with S_a,j = 0: its
force mu_a,j acts on no unknown. Stuck, its slip s_a,j = s0_a,j is then no condition on x, and (26) does not
determine mu_a,j: it takes its least value, mu_a,j = 0 (the value a slipping row's law gives it too, s_a,j = 0
there), the row's stuck condition the slip of its moved component alone. Where the fixed component's prescribed
slip s0_a,j is not 0 the row cannot stick: its law is mu_a = c_a t_a at every point.

Dependent rows (3D "gamma3" between two bodies whose faces do not match: one row per overlay vertex, more rows than
the jump's degrees of freedom, docs/formulation.md §13; or rows of two pairs acting on one unknown, a floor and a
wall sharing a corner node, whose floor row's slip and wall row move the same displacement): the closed normal rows
and the stuck rows' slip rows may be linearly dependent, and the forces on them are then not unique ((26) fixes
only their resultant). Each step keeps a maximal independent subset of them, the rows with the largest forces
(normal rows) and the largest slack to the cone, c_a - |mu_a| (stuck rows), chosen first (column-pivoted QR of the
unit rows so weighted, group by group of rows linked by common unknowns: a floor's nodal rows are groups of one
node's rows, not one dense QR of every row); the step holds the forces of the others where they are (d y_a = 0,
d mu_a = 0), so that they keep the interior point's share and the independent rows carry the correction. The
steps move x onto the same affine set (a dependent row closes with the rows it depends on where the gap is affine
on it: planar faces), and the residual and signs are then checked on every row, the held ones included, as for
independent rows. A slipping row's force is c_a t_a, fixed by x: the subset concerns the closed and stuck rows
alone. Coulomb's capacities mu y_a are those of the forces found, one of the distributions (26) allows. The subset's
forces may have to change sign where the interior point's active set is not the answer's (a row at the edge of the
contact carrying a small force): the full step to a new active set is taken (above) if that set was not met
before.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..factor import superlu
from .declined import Declined, Stop
from .directions import fixed_directions
from .lcp import SIGN_TOL
from .rows import independent_columns

__all__ = ["FrictionRows", "solve_friction"]

MAX_STEPS = 50
"""Newton steps at most."""

STALLS = 3
"""Full steps taken where no damping decreased the residual, at most (then declined: each step is a sparse LU)."""


class FrictionRows:
    """The friction rows of the finish (module docstring): ``S`` (r c, n) the slip rows on x (row-major: row a,
    component j at a c + j), ``s0`` their prescribed part, ``rows`` the normal rows they sit on, ``c0``, ``D`` the
    capacity c_a = c0_a + D_a y_a (scaled), ``moved`` the rows whose slip some unknown moves ((r,), or (r, c) per
    component). A row no unknown moves slips by its prescribed s0_a: its force is c_a s0_a / |s0_a| (the law), or
    0 where s0_a = 0 (then (26) does not determine it: its least value, like the held rows' normal forces). A
    moved row's component no unknown moves (``fixed``) is the module docstring's: force 0 while stuck, and a row
    whose fixed component has a prescribed slip cannot stick (``sticks``: the rows that can)."""

    def __init__(self, S, s0, rows, c0, D, components, moved):
        self.S, self.s0, self.rows = sp.csr_matrix(S), np.asarray(s0, dtype=float), np.asarray(rows)
        self.c0, self.D, self.nc = np.asarray(c0, dtype=float), np.asarray(D, dtype=float), int(components)
        moved = np.asarray(moved, dtype=bool)
        each = np.broadcast_to(moved.reshape(len(moved), -1), (len(moved), self.nc))
        self.moved = each.any(axis=1)
        held = self.s0.reshape(-1, self.nc)
        self.fixed = self.moved[:, None] & ~each
        """(r, c) the components of a moved row that no unknown moves."""
        self.sticks = self.moved & ~(self.fixed & (held != 0)).any(axis=1)
        """(r,) the moved rows that can stick (no fixed component with a prescribed slip)."""
        size = np.linalg.norm(held, axis=1)
        self.held = np.where(self.moved[:, None] | (size[:, None] == 0), 0.0,
                             held / np.maximum(size, np.finfo(float).tiny)[:, None])
        """(r, c) the slip direction of the rows no unknown moves (0 where none is prescribed, or moved)."""

    def slip(self, x) -> np.ndarray:
        """(r, c) the slip of every row at x."""
        return (self.S @ x + self.s0).reshape(-1, self.nc)

    def capacity(self, y) -> np.ndarray:
        """(r,) the capacities at the normal forces y (a tension counts as 0)."""
        return self.c0 + self.D * np.maximum(y[self.rows], 0.0)


def _blocks(B) -> sp.csr_matrix:
    """Block diagonal of the (r, c, c) blocks B."""
    r, c, _ = B.shape
    return sp.bsr_matrix((B, np.arange(r), np.arange(r + 1)), shape=(r * c, r * c)).tocsr()


TIE = 1e-12
"""Degenerate rows (module docstring): a row counts as closed while y_a + r_n (G x - g)_a > -TIE C, as stuck while
|z_a| <= c_a + TIE C (C the force scale), so that rows whose force and gap (slip) are both rounding tie one way."""

OWN = 1e-12
"""An answer's stuck row may carry a force above its capacity by at most this fraction of its own capacity (of
:data:`OWN_FLOOR` C where the capacity is below that): the ties (:data:`TIE`) are of the force scale C, the largest
normal force, and a row whose capacity is far below it, at its stick-slip onset, was accepted stuck 4.0e-10 of its
own capacity over it (the sliding layer of tests/test_friction_directions.py, capacities 1/400 of C). Such rows
slip (:func:`_steps`)."""

OWN_FLOOR = 1e-3
"""The least capacity, as a fraction of the force scale C, that :data:`OWN` is taken of: a capacity at rounding
(Coulomb's on a row that carries no force) is tied at the rounding of C, not of itself."""

OVER_ROUNDS = 3
"""Rounds of :func:`_steps` at most with the rows over their own capacity held slipping."""

WEIGHT_FLOOR = 1e-3
"""Dependent rows: the weights of the basis's pivots (each row's force or slack to the cone over the largest) are
floored here, so that the rows without force are ordered among themselves by their own pivots."""


class _System:
    """The residual and Jacobian of the module docstring at one point, with its active set; ``dependent``: the
    rows may be linearly dependent (module docstring, "Dependent rows")."""

    def __init__(self, T, b, G, g, fr: FrictionRows, free, scales, dependent=False):
        self.T, self.b, self.G, self.g, self.fr, self.free = T, b, G, g, fr, free
        self.C, self.U = scales
        self.r = self.C / self.U
        self.absT, self.absG, self.absS = abs(T), abs(G), abs(fr.S)
        self.reach = np.asarray(self.absT.sum(axis=1)).ravel()
        """|T_i| 1: a momentum row's terms were every unknown at the largest (:meth:`residual`)."""
        self.dependent = bool(dependent)
        self._frozen = {}
        self._factors = {}
        """The Jacobians' LU (or None where singular) by the bytes of their varying blocks (:meth:`factor`)."""
        self.slipping = np.zeros(len(fr.rows), dtype=bool)
        """The rows held slipping (:func:`_steps`: stuck, they were over their own capacity)."""

    def frozen(self, w, state):
        """((R,), (r, c)) the closed normal rows and the stuck rows' moved components whose forces a step keeps
        (module docstring, "Dependent rows"): those outside a maximal independent set of the rows the state
        closes, chosen by a column-pivoted QR of the unit rows weighted by their forces (normal rows) and their
        slack to the cone, c_a - |mu_a| (stuck rows); none if the rows are independent by construction. Chosen
        once per active set (a dense QR of the rows: the steps that only refine the slip directions reuse it)."""
        key = _key(state)
        if key not in self._frozen:
            self._frozen[key] = self._choose(w, state)
        return self._frozen[key]

    def _choose(self, w, state):
        fr = self.fr
        _, y, mu = self.split(w)
        closed, stuck, _, c = state
        normal = np.zeros(len(closed), dtype=bool)
        tangential = np.zeros((len(c), fr.nc), dtype=bool)
        held = stuck[:, None] & ~fr.fixed
        cn, (ta, tj) = np.flatnonzero(closed), np.nonzero(held)
        if not self.dependent or len(cn) + len(ta) == 0:
            return normal, tangential
        M = sp.vstack([self.G[cn], fr.S[ta * fr.nc + tj]]).tocsr()
        slack = np.concatenate([y[cn], (c - np.linalg.norm(mu, axis=1))[ta]])
        weight = np.maximum(slack / max(float(slack.max(initial=0.0)), np.finfo(float).tiny), WEIGHT_FLOOR)
        keep = _kept(M, weight)
        normal[cn[~keep[:len(cn)]]] = True
        tangential[ta[~keep[len(cn):]], tj[~keep[len(cn):]]] = True
        return normal, tangential

    def split(self, w):
        n, R = self.T.shape[0], self.G.shape[0]
        return w[:n], w[n:n + R], w[n + R:].reshape(-1, self.fr.nc)

    def state(self, w):
        """(closed, stuck, z, c): the point's active set (closed normal rows, stuck friction rows; ties within
        :data:`TIE` of the force scale closed and stuck), z = mu + r_t s and the capacities."""
        x, y, mu = self.split(w)
        closed = self.free & (y + self.r * (self.G @ x - self.g) > -TIE * self.C)
        c = self.fr.capacity(y)
        z = mu + self.r * self.fr.slip(x)
        stuck = self.fr.sticks & ~self.slipping & (np.linalg.norm(z, axis=1) <= c + TIE * self.C)
        return closed, stuck, z, c

    def residual(self, w, state=None):
        """The scaled residual (momentum rows over the sizes of their terms, normal and friction rows over C)."""
        x, y, mu = self.split(w)
        closed, stuck, z, c = self.state(w) if state is None else state
        flat = mu.ravel()
        mom = self.T @ x - self.b + self.G.T @ y + self.fr.S.T @ flat
        size = self.absT @ np.abs(x) + np.abs(self.b) + self.absG.T @ np.abs(y) + self.absS.T @ np.abs(flat)
        size = np.maximum(size, self.reach * float(np.abs(x).max(initial=0.0)))   # a row whose unknowns rest
        mom = mom / np.maximum(size, np.finfo(float).tiny + 1e-300 * size.max(initial=0.0))
        normal = np.where(closed, self.r * (self.G @ x - self.g), y) / self.C
        norm_z = np.maximum(np.linalg.norm(z, axis=1), np.finfo(float).tiny)
        proj = np.where(stuck[:, None], np.where(self.fr.fixed, 0.0, z), c[:, None] * z / norm_z[:, None])
        tang = np.where(self.fr.moved[:, None], mu - proj, mu - c[:, None] * self.fr.held) / self.C
        return np.concatenate([mom, normal, tang.ravel()])

    def jacobian(self, state, frozen):
        """The Jacobian at the active set ``state`` (module docstring), ``frozen`` rows held (sparse, CSC)."""
        return self._assemble(*self._varying(state, frozen))

    def factor(self, state, frozen):
        """The sparse LU of :meth:`jacobian` (:func:`~cvxcontact.backends.factor.superlu`), or None where it is
        singular, kept by the bytes of the blocks that vary with ``state`` (:meth:`_varying`; T, G and S are the
        system's own): the same blocks give the same matrix, so a set met again is not factorised again (2D: a
        slipping row's blocks are 0 and 1 whatever its slip, and Murty's pivots and the Newton steps revisit
        sets). At most :data:`KEPT_FACTORS` kept, holding at most :data:`KEPT_ENTRIES` entries of L and U in all,
        the oldest dropped first."""
        blocks = self._varying(state, frozen)
        key = b"".join(np.ascontiguousarray(a).tobytes() for a in blocks)
        if key not in self._factors:
            try:                   # SuperLU raises RuntimeError on a zero pivot (splu issues no warning)
                lu = superlu(self._assemble(*blocks))
            except RuntimeError:
                lu = None
            self._factors[key] = lu
            while len(self._factors) > KEPT_FACTORS or sum(
                    f.nnz for f in self._factors.values() if f is not None) > KEPT_ENTRIES:
                del self._factors[next(iter(self._factors))]
            if key not in self._factors:
                return lu
        return self._factors[key]

    def _varying(self, state, frozen):
        """(on_x, on_mu, dy, closed rows, open rows): the blocks of the Jacobian that depend on ``state``."""
        closed, stuck, z, c = state
        nf, tf = frozen
        fr, nc = self.fr, self.fr.nc
        norm_z = np.maximum(np.linalg.norm(z, axis=1), np.finfo(float).tiny)
        t = np.where(fr.moved[:, None], z / norm_z[:, None], fr.held)
        slip = fr.moved & ~stuck
        k = np.zeros_like(c)       # c / |z| read on the slipping rows only (|z| > c there; a stuck row's z may be 0)
        k[slip] = c[slip] / norm_z[slip]
        eye = np.broadcast_to(np.eye(nc), (len(c), nc, nc))
        P = eye - t[:, :, None] * t[:, None, :]
        loose = np.where((fr.fixed | tf)[:, :, None], eye, 0.0)  # a stuck row's fixed components: mu_a,j = 0
        on_x = np.where(stuck[:, None, None], eye - loose,
                        np.where(slip[:, None, None], -(k * self.r)[:, None, None] * P, 0))
        on_mu = np.where(stuck[:, None, None], loose, np.where(slip[:, None, None], eye - k[:, None, None] * P, eye))
        dy = np.where(stuck[:, None], 0.0, -fr.D[:, None] * t).ravel()
        return on_x, on_mu, dy, (closed & ~nf).astype(float), (~closed | nf).astype(float)

    def _assemble(self, on_x, on_mu, dy, closed, open_):
        """The Jacobian from the blocks of :meth:`_varying`."""
        fr, R, nc = self.fr, self.G.shape[0], self.fr.nc
        r = len(fr.rows)
        r_idx = np.repeat(np.arange(r) * nc, nc) + np.tile(np.arange(nc), r)
        on_y = sp.csr_matrix((dy, (r_idx, np.repeat(fr.rows, nc))), shape=(r * nc, R))
        Gc = sp.diags(closed) @ self.G
        open_ = sp.diags(open_)
        return sp.bmat([[self.T, self.G.T, fr.S.T],
                        [Gc, open_, None],
                        [_blocks(on_x) @ fr.S, on_y, _blocks(on_mu)]], format="csc")

    def step_rhs(self, w, state, frozen):
        """-F unscaled (the Newton right-hand side in the Jacobian's own units; 0 on the ``frozen`` rows)."""
        x, y, mu = self.split(w)
        closed, stuck, z, c = state
        nf, tf = frozen
        mom = self.T @ x - self.b + self.G.T @ y + self.fr.S.T @ mu.ravel()
        normal = np.where(nf, 0.0, np.where(closed, self.G @ x - self.g, y))
        norm_z = np.maximum(np.linalg.norm(z, axis=1), np.finfo(float).tiny)
        s = self.fr.slip(x)
        tang = np.where(stuck[:, None], np.where(self.fr.fixed, mu, np.where(tf, 0.0, s)),
                        mu - c[:, None] * z / norm_z[:, None])
        tang = np.where(self.fr.moved[:, None], tang, mu - c[:, None] * self.fr.held)
        return -np.concatenate([mom, normal, tang.ravel()])


def _kept(M, weight) -> np.ndarray:
    """(k,) the rows of the sparse ``M`` (k rows) in a maximal linearly independent subset, those of the largest
    ``weight`` first (:func:`_basis`), chosen group by group of rows linked by common unknowns (:func:`_linked`)."""
    keep = np.asarray(abs(M).sum(axis=1)).ravel() > 0          # a row alone in its group: kept unless 0
    for part in _linked(M):
        if len(part) > 1:
            keep[part] = _basis(M[part], weight[part])
    return keep


def _linked(M) -> list[np.ndarray]:
    """The rows of the sparse ``M`` in groups linked by common unknowns (the connected components of the graph of
    rows joined where they share a column). Rows of different groups are orthogonal, so a maximal
    independent subset of M is the union of one per group, and the column-pivoted QR of each group picks the rows
    the QR of all of M picks (its pivots within a group depend on that group's columns alone): each group's dense
    QR instead of one of every row (the nodal rows of a floor and a wall sharing an edge: groups of one node's
    rows, not every row of the floor). In the order of the groups' labels."""
    from scipy.sparse.csgraph import connected_components

    pattern = sp.csr_matrix(M, copy=True)
    pattern.data = np.ones(len(pattern.data))
    _, label = connected_components(pattern @ pattern.T, directed=False)
    order = np.argsort(label, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(label[order])) + 1)


def _basis(M, weight) -> np.ndarray:
    """(k,) the rows of ``M`` (sparse, k rows) in a maximal independent subset, those of the largest ``weight``
    first: a column-pivoted QR of the unit rows so weighted, then a row left out whose part outside the kept rows'
    span is above DEPENDENT_PIVOT joins them (the weights order the pivots; dependence is the unit rows' own)."""
    M = sp.csc_matrix(M)
    M = M[:, np.flatnonzero(np.diff(M.indptr))].toarray()
    norms = np.linalg.norm(M, axis=1)
    unit = (M / np.where(norms > 0, norms, 1.0)[:, None]).T
    keep = np.zeros(len(norms), dtype=bool)
    keep[independent_columns(unit * weight)] = True
    rest = np.flatnonzero(~keep)
    if len(rest):
        Q = np.linalg.qr(unit[:, keep])[0]
        perp = unit[:, rest] - Q @ (Q.T @ unit[:, rest])
        keep[rest[independent_columns(perp)]] = True
    return keep


def _broken(merit, closed_forces, open_gaps, over, stick_slip, turned) -> str:
    """The first of the finish's acceptance conditions (:func:`solve_friction`) that the answer breaks at
    :data:`~cvxcontact.backends.finish.lcp.SIGN_TOL`, in words with its size ('' if none): the scaled residual,
    a tension on a closed row, a penetration of an open one (both over the scales), a force outside the cone, a
    stick-slip or slip-direction product (over C U)."""
    tests = [("the scaled residual", np.array([merit])), ("a tension on a closed row", -closed_forces),
             ("a penetration of an open row", open_gaps), ("a force outside the friction cone", over),
             ("a row that slips below its capacity", stick_slip), ("a force not against the slip", turned)]
    for words, v in tests:
        worst = float(np.max(v, initial=-np.inf))
        if worst > SIGN_TOL:
            return f"{words}, {worst:.2g} of the scales"
    return ""


def _key(state) -> tuple:
    """The active set of a state (closed normal rows, stuck friction rows; in 2D the slipping rows' directions,
    sign(z_a), too: a step that turns a slipping row's direction changes its law mu_a = c_a sign(z_a), and
    repeating the set without it ended the steps as settled where they were not, measured: a block dragged over a
    disk under the P2 cones with Tresca's friction, a cut round's residual 0.04 of the scales) as a hashable key."""
    closed, stuck, z = state[0], state[1], state[2]
    turn = np.where(stuck, 0, np.sign(z[:, 0])).astype(np.int8) if z.shape[1] == 1 else b""
    return closed.tobytes(), stuck.tobytes(), bytes(turn)


def _step(system, w, state):
    """The semismooth Newton step from ``w`` on the active set ``state`` (its Jacobian's sparse LU,
    :func:`~cvxcontact.backends.factor.superlu`: none on a structurally singular one), or None where that
    Jacobian is singular or the step not finite."""
    frozen = system.frozen(w, state)
    lu = system.factor(state, frozen)
    if lu is None:
        return None
    dw = lu.solve(system.step_rhs(w, state, frozen))
    return dw if np.isfinite(dw).all() else None


KEPT_FACTORS = 16
"""The Jacobians' LU a finish keeps at most (:meth:`_System.factor`): the sets that Murty's pivots and the 2D
Newton steps revisit are recent ones (measured on the 2D Coulomb scenes of
tests/test_friction_p2_gamma3_mixed.py: 521 of 924 factorisations were of a set among the last 8)."""

KEPT_ENTRIES = 10 ** 7
"""The entries of L and U the kept factors of :meth:`_System.factor` hold at most (about 120 MB)."""

PIVOTS = 1
"""The single-row changes of :func:`_pivots` at most, per row (normal and friction rows; plus 10): each is a sparse
LU. Measured: the tilted block settles within it; where it does not (the 2D pair of non-matching lines, the tilted
block with Coulomb at nx = 7) four per row cost 3.6 to 4.1 s CPU before the decline, one per row 1.0 to 1.5 s
(benchmarks/results/friction_p2_declines.md)."""


def _pivots(system, w, solved, most: int):
    """Murty's least-index rule on a 2D active set that cycles (:func:`solve_friction`): from the set ``solved``
    (a state), the full step that solves it exactly (the 2D conditions are linear on a set), then, where the point
    reached asks for other sets, the change of its first row alone (normal rows by index, then friction rows: closed
    or open, stuck or slipping, the slip's direction), again, at most ``most`` times. The Newton steps change every
    row at once and may jump between two sets (a contact edge between two nodes with a cut point between them: each
    set makes the other node's force a tension; measured on a free block tilted on a floor under the P2 cones), a
    single change at a time moves on. Returns (w, state, steps) once the point's own set is the one solved, or
    None."""
    R = len(system.g)
    for k in range(1, most + 1):
        dw = _step(system, w, solved)
        if dw is None:
            return None
        w = w + dw
        state = system.state(w)
        closed, stuck, z, _ = solved
        turned = ~stuck & ~state[1] & (np.sign(z[:, 0]) != np.sign(state[2][:, 0]))
        flips = np.concatenate([np.flatnonzero(closed != state[0]),
                                R + np.flatnonzero((stuck != state[1]) | turned)])
        if not len(flips):
            return w, state, k
        i = int(flips.min())
        closed, stuck, z = closed.copy(), stuck.copy(), z.copy()
        if i < R:
            closed[i] = state[0][i]
        else:
            stuck[i - R], z[i - R] = state[1][i - R], state[2][i - R]
        solved = (closed, stuck, z, state[3])
    return None


def solve_friction(T, b, G, g, fr: FrictionRows, free, x0, y0, mu0, scales, max_steps: int | None = None,
                   dependent: bool = False):
    """The exact finish of the module docstring from (x0, y0, mu0) (the interior point's answer, scaled).

    ``T``, ``b``: the mixed system's matrix and loads (:meth:`~cvxcontact.backends.mixed.MixedEnergy.linearised`);
    ``G``, ``g``: the normal rows G x <= g; ``fr``: the :class:`FrictionRows`; ``free``: the normal rows some
    unknown moves (the others keep y = 0); ``scales``: (C, U) the force and displacement scales (the largest
    capacity or normal row force; the largest displacement).

    Returns ``(x, y, mu, closed, steps)`` with ``mu`` (r, c), or a :class:`Declined`: a singular step, steps that
    did not settle, or an answer whose signs break at ``SIGN_TOL`` of the scales (a tension on a closed row, a
    penetration of an open one, a force outside the cone, a slip not along its force). ``max_steps``: default
    :data:`MAX_STEPS`; ``dependent``: the rows may be linearly dependent (3D "gamma3" pairs; module docstring)."""
    max_steps = MAX_STEPS if max_steps is None else max_steps
    free = np.asarray(free, dtype=bool)
    if not np.any(b) and not np.any(fr.s0) and (g[free] >= 0).all():
        # no load, no prescribed slip, no interference: x = 0, y = 0, mu = 0 satisfies every condition (module
        # docstring, "No data"); the scaled residual has no scale there (the interior point's noise)
        return np.zeros(T.shape[0]), np.zeros(G.shape[0]), np.zeros((len(fr.rows), fr.nc)), free & (g == 0), 0
    system = _System(T, b, G, g, fr, free, scales, dependent)
    mu0 = np.asarray(mu0, dtype=float)
    w0 = np.concatenate([x0, np.where(free, y0, 0.0), mu0.ravel()])
    if fr.nc > 1 and system.dependent:            # 3D, dependent rows: Lawson-Hanson on the normal rows first
        w1 = fixed_directions(system, w0)
        out = w1 if isinstance(w1, Declined) else _steps(system, w1, max_steps)
        if not isinstance(out, Declined):
            return out
    out = _steps(system, w0, max_steps)
    if isinstance(out, Declined) and not (fr.nc > 1 and system.dependent):
        # once more from every free row closed (module docstring); not after the steps on the directions (3D,
        # dependent rows: measured on the non-matching boxes of benchmarks/friction_p2_declines.py, 2 x 50 steps
        # declined in each declined cut round: the decline 34 s of CPU with this start, 18 s without)
        again = _steps(system, np.concatenate([x0, np.where(free, scales[0], 0.0), np.zeros(mu0.size)]), max_steps)
        out = out if isinstance(again, Declined) else again
    return out


def _steps(system, w, max_steps: int):
    """The damped semismooth Newton steps of :func:`solve_friction` from ``w`` = (x, y, mu) (:func:`_newton`): its
    answer or a :class:`Declined`. Where the answer holds a stuck row whose force is above its capacity by more than
    :data:`OWN` of its own capacity (:func:`_over`; within the ties of the force scale), those rows slip: the steps
    again from that answer with them held slipping (their force c_a t_a, their slip free), at most
    :data:`OVER_ROUNDS` times; where those are declined (a row that truly sticks then slips against its force),
    the answer before them stands."""
    out = _newton(system, w, max_steps)
    for _ in range(OVER_ROUNDS):
        over = None if isinstance(out, Declined) else _over(system, out)
        if over is None or not over.any():
            return out
        before = system.slipping.copy()
        system.slipping = before | over
        again = _newton(system, np.concatenate([out[0], out[1], out[2].ravel()]), max_steps)
        if isinstance(again, Declined):
            system.slipping = before
            return out
        out = again[:4] + (out[4] + again[4],)
    return out


def _over(system, out) -> np.ndarray:
    """(r,) the stuck rows of the answer ``out`` of :func:`_newton` whose force exceeds their capacity by more than
    :data:`OWN` of it (of :data:`OWN_FLOOR` C, at least)."""
    x, y, mu = out[0], out[1], out[2]
    _, stuck, _, c = system.state(np.concatenate([x, y, mu.ravel()]))
    excess = np.linalg.norm(mu, axis=1) - c
    return stuck & system.fr.moved & (excess > OWN * np.maximum(c, OWN_FLOOR * system.C))


def _newton(system, w, max_steps: int):
    """The damped semismooth Newton steps of :func:`_steps` from ``w``: the answer (x, y, mu, closed, steps) that
    passes the acceptance, or a :class:`Declined`."""
    fr = system.fr
    state = system.state(w)
    merit = np.linalg.norm(system.residual(w, state))
    seen, settled, stalled = set(), False, 0
    for steps in range(1, max_steps + 1):
        dw = _step(system, w, state)
        if dw is None:
            return Declined(Stop.SINGULAR)
        key, solved = _key(state), state
        alpha, trial = 1.0, None
        while alpha >= 2.0 ** -10:                        # damping: halve until the scaled residual decreases
            trial = w + alpha * dw
            new = np.linalg.norm(system.residual(trial))
            if new < (1.0 - 1e-4 * alpha) * merit:
                break
            if alpha == 1.0 and (fr.nc > 1 or system.dependent) and _key(system.state(trial)) not in seen | {key}:
                break              # 3D: the full step to a new active set (module docstring)
            alpha /= 2
        else:
            stalled += 1
            if stalled > STALLS:
                return Declined(Stop.MAX_ITER, "the damped Newton steps stopped decreasing the residual")
            trial, new = w + dw, np.linalg.norm(system.residual(w + dw))   # no decrease: the full step
        w, merit_old, merit = trial, merit, new
        state = system.state(w)
        same = _key(state) == key
        if same and (merit == 0.0 or (fr.nc == 1 and alpha == 1.0)
                     or (merit >= 0.5 * merit_old and merit <= SIGN_TOL)):
            settled = True         # the set repeats, and the step solved it (2D) or no longer halves a residual
            #                        at rounding
            break
        seen.add(key)
        if not same and fr.nc == 1 and _key(state) in seen:
            # 2D: a set already solved exactly comes back: one row's change at a time from the set just solved
            out = _pivots(system, w, solved, PIVOTS * (len(system.g) + len(fr.rows)) + 10)
            if out is None:
                return Declined(Stop.CYCLE)
            w, state, pivots = out
            steps += pivots
            merit, settled = np.linalg.norm(system.residual(w, state)), True
            break
    if not settled:
        return Declined(Stop.MAX_ITER)
    x, y, mu = system.split(w)
    closed, _, _, c = state
    C, U = system.C, system.U
    s = fr.slip(x)
    a, norm_s = np.linalg.norm(mu, axis=1), np.linalg.norm(s, axis=1)
    gap = system.G @ x - system.g
    turned = a * norm_s - np.einsum("ij,ij->i", mu, s)
    broken = _broken(merit, y[closed] / C, gap[system.free & ~closed] / U, ((a - c) / C)[fr.moved],
                     (np.abs(c - a) * norm_s / (C * U))[fr.moved], (turned / (C * U))[fr.moved])
    if broken:
        return Declined(Stop.SIGNS, f"{Stop.SIGNS.value}: {broken}")
    return x, y, mu, closed, steps
