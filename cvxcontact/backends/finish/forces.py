"""Forces and scales of the finish: nodal forces from the rows, each row's reach and scale, the interior point's
active set read from its forces."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ...discrete.energy import abs_product


def node_scales(parts, g, extra=None):
    """Slack E [u_nu] - g of the constrained rows, from each body's part E J_l u_l, and each row's
    displacement scale U_a: the sizes of both parts there plus the gap plus ``extra`` (the local
    displacement of the row's own force, :func:`force_displacements`), floored at 1e-9 of the largest."""
    U = sum(np.abs(p) for p in parts) + np.abs(g)
    if extra is not None:
        U = U + extra
    return sum(parts) - g, np.maximum(U, 1e-9 * U.max(initial=0.0) + np.finfo(float).tiny)


def force_displacements(blocks, E, y):
    """w_a |y_a|: the displacement the contact force y_a of row a produces through the diagonal of each
    body's stiffness, w_a = sum_l sum_j (E J_l)_aj^2 / (K_uu,l)_jj (scaled units). A node held at exactly
    [u_nu] = g by a rigid obstacle or a stuck partner has no other displacement scale (docs/checks.md)."""
    return row_compliance(blocks, E) * np.abs(y)


def row_compliance(blocks, E) -> np.ndarray:
    """w_a = sum_l sum_j (E J_l)_aj^2 / (K_uu,l)_jj: each row's compliance through the diagonal of each body's
    stiffness (scaled units; the unknowns with no stiffness diagonal do not count)."""
    w = np.zeros(E.shape[0])
    for b in blocks:
        R = (E @ b.jump).tocsr()
        w += np.asarray(R.multiply(R) @ inverse_diagonal(b.Kuu)).ravel()
    return w


def inverse_diagonal(K) -> np.ndarray:
    """1 / K_jj where the diagonal is positive, 0 elsewhere (an unknown no stiffness holds)."""
    d = K.diagonal()
    return np.where(d > 0, 1.0 / np.where(d > 0, d, 1.0), 0.0)


def _elastic_forces(blocks, u, phi):
    """Per body (block, |Kuu| |u| + |Kup| |phi|): the sizes of the elastic forces at its unknowns (scaled)."""
    for k, (b, uk) in enumerate(zip(blocks, u)):
        f = abs_product(b.Kuu, uk)
        pk = None if phi is None else phi[k]
        if pk is not None and getattr(b, "Kup", None) is not None:
            f = f + abs(b.Kup) @ np.abs(pk)
        yield b, f


def reach_displacements(blocks, E, u, phi=None):
    """The displacement each row's unknowns would have from the elastic forces of their neighbours alone:
    sum_l |E J_l| D_l^{-1} (|Kuu_l| |u_l| + |Kup_l| |phi_l|), D_l the positive diagonal of Kuu_l (scaled units;
    the check-side twin of :func:`row_reach`). The rounding of a node's displacement is relative to it: a node
    that does not move (a P2 face vertex on a rigid plane under a uniform pressure) has a slack of rounding and
    no displacement of its own, and its neighbours' displacements are the scale of that rounding."""
    return sum((abs(E @ b.jump) @ (inverse_diagonal(b.Kuu) * f) for b, f in _elastic_forces(blocks, u, phi)),
               np.zeros(E.shape[0]))


def reach_forces(blocks, E, u, phi=None, fits=None):
    """The size of the elastic forces at each row's unknowns, sum_l |E J_l| (|Kuu_l| |u_l| + |Kup_l| |phi_l|)
    (scaled forces): the force scale of a contact row that carries no force (an open contact, or forces of
    interior-point noise), below which a contact force is not read as a force (:data:`FORCE_FLOOR`). ``fits``
    (per body, :class:`~cvxcontact.fem.rigidfit.RigidFit`, e.g. ``problem.rigid_fits``): u_l read as its
    deformation, its rigid fit taken out (:func:`deformations`), so the scale does not grow with a slide."""
    return sum((abs(E @ b.jump) @ f for b, f in _elastic_forces(blocks, deformations(fits, u), phi)),
               np.zeros(E.shape[0]))


class RowReach:
    """:func:`row_compliance`, :func:`reach_displacements` and :func:`reach_forces` of the rows ``E`` on ``blocks``
    with what they read of the matrices alone taken once (a load case of the same geometry and rows reuses it,
    :meth:`~cvxcontact.discrete.DiscreteProblem.shared`): the rows' compliance w_a, and per body |E J_l|, the
    unknowns it reads (the columns holding its entries) and there the rows of Kuu_l and |Kup_l| and the inverse
    diagonal of Kuu_l. The reaches then read |Kuu_l| |u_l| and |Kup_l| |phi_l| at those unknowns only, not over
    the whole body: each row's sum is the same as in the whole product, so the answers are the same numbers."""

    def __init__(self, blocks, E):
        self.compliance = row_compliance(blocks, E)
        self._bodies = []
        for b in blocks:
            A = abs(E @ b.jump).tocsr()
            at = np.flatnonzero(np.diff(A.tocsc().indptr))            # the unknowns the rows read
            Kup = getattr(b, "Kup", None)
            K = b.Kuu.tocsr()[at]
            self._bodies.append((A, at, K, np.abs(K.data), None if Kup is None else abs(Kup.tocsr()[at]),
                                 inverse_diagonal(b.Kuu)[at]))

    def _forces(self, u, phi):
        """Per body (|E J_l|, the unknowns it reads, |Kuu_l| |u_l| + |Kup_l| |phi_l| there, 1 / diag Kuu_l there)."""
        for k, ((A, at, K, Kabs, Kp, inverse), uk) in enumerate(zip(self._bodies, u)):
            f = abs_product(K, uk, Kabs)                            # (|K|'s values kept: the same numbers)
            pk = None if phi is None else phi[k]
            if pk is not None and Kp is not None:
                f = f + Kp @ np.abs(pk)
            yield A, at, f, inverse, len(uk)

    def displacements(self, u, phi=None) -> np.ndarray:
        """:func:`reach_displacements` of ``u``, ``phi`` (scaled)."""
        return sum((A @ _placed(at, inverse * f, n) for A, at, f, inverse, n in self._forces(u, phi)),
                   np.zeros(len(self.compliance)))

    def forces(self, u, phi=None, fits=None) -> np.ndarray:
        """:func:`reach_forces` of ``u``, ``phi`` (scaled; ``fits``: read as the deformation)."""
        return sum((A @ _placed(at, f, n) for A, at, f, _, n in self._forces(deformations(fits, u), phi)),
                   np.zeros(len(self.compliance)))


def _placed(at, values, n) -> np.ndarray:
    """(n,) zeros with ``values`` at ``at``."""
    out = np.zeros(n)
    out[at] = values
    return out


def deformations(fits, u):
    """Each body's free unknowns ``u`` (scaled) with its least-squares rigid fit per piece taken out
    (``fits``: per body, :class:`~cvxcontact.fem.rigidfit.RigidFit`); ``u`` itself when ``fits`` is None."""
    return u if fits is None else [fit.deformation(uk) for fit, uk in zip(fits, u)]


def slip_reach(blocks, slip, u, phi=None):
    """The size of the elastic forces at each slip row's unknowns, sum_l |Es T_l| (|Kuu_l| |u_l| + |Kup_l|
    |phi_l|) (scaled forces; ``slip`` a friction term's :class:`~cvxcontact.discrete.slip.Slip`: Es its slip rows
    ``rows``, T_l body l's tangential jump on its free unknowns, ``operators``): :func:`reach_forces` for the
    tangential rows of a friction law."""
    Es = slip.rows
    return sum((abs(Es @ T) @ f for T, (_, f) in zip(slip.operators, _elastic_forces(blocks, u, phi))),
               np.zeros(Es.shape[0]))


def friction_scale(problem, u, phi, y, capacity, whole: bool = False) -> float:
    """C = max(max c_a, :func:`force_scale`) (scaled forces): the force scale of a friction law's rows (the checks';
    the finish's with ``whole``), the largest capacity ``capacity`` or normal row force ``y``, floored at :data:`FORCE_FLOOR`
    of the largest elastic force of the bodies' deformation at the unknowns of the normal rows ``problem.E``
    (:func:`reach_forces`) and of the friction term's slip rows (:func:`slip_reach`). With the contact open
    and capacities mu y_a (Coulomb) or g = 0 the capacities and forces are 0 or rounding: the tangential forces'
    rounding is then measured against the elastic forces there, not against nothing (docs/howto/friction.md, "What
    is checked").

    The floor reads each body's displacement ``u`` with its least-squares rigid fit taken out, per piece
    (``problem.rigid_fits``, :class:`~cvxcontact.fem.rigidfit.RigidFit`): |Kuu| (u - Q Q^T u) + |Kup| |phi|. The
    free unknowns' Kuu has no rigid kernel where a support prescribes a displacement (Kuu r = -K_fD r_D), so
    |Kuu| |u| grows with a rigid slide: after a slide of 0.1 m the floor outgrew the contact forces and the cone
    check read a violation 450x smaller than after 0.1 mm. With the fit taken out, adding a rigid motion of a body
    to ``u`` leaves C unchanged (to rounding); a deformed body keeps a non-zero floor (the awkward scenes: an open
    contact, whose Coulomb capacities are 0). Neither the loads (the lifted prescribed displacements: they move
    with a slide) nor element matrices (the assembly does not keep them) are needed: one pass over the free
    unknowns with m = 3 (2D) or 6 (3D) rigid motions per piece, after one orthonormalisation per problem.

    ``whole``: the floor reads the whole ``u`` instead, as :func:`ipm_active` does: the finish's scale on an
    interior point's answer, whose noise is relative to the whole displacement, the rigid part included (a
    strain-free block lifted off a Coulomb floor by its supports: the floor of its deformation, rounding, made
    the noise of its open rows the scale and the finish declined, tests/test_check_floor.py)."""
    d = deformations(None if whole else problem.rigid_fits, u)
    blocks = problem.blocks
    reach = np.concatenate([reach_forces(blocks, problem.E, d, phi), slip_reach(blocks, problem.term.data, d, phi)])
    return max(float(np.max(capacity, initial=0.0)), force_scale(y, reach))


FORCE_FLOOR = 1e-6
"""The largest contact force Y is floored at this fraction of the largest elastic force at the contact rows
(:func:`reach_forces`) where it normalises the forces (the active rows of an interior point, the
complementarity and cone checks): with the contact open, an interior point's forces are noise (1e-8 of
that scale, measured) and must not read as a contact (docs/checks.md)."""


def force_scale(y, reach=None) -> float:
    """Y = max(max |y|, FORCE_FLOOR max ``reach``) (:func:`reach_forces`), at least the smallest float."""
    Y = float(np.abs(y).max(initial=0.0))
    if reach is not None:
        Y = max(Y, FORCE_FLOOR * float(np.max(reach, initial=0.0)))
    return max(Y, np.finfo(float).tiny)


def ipm_active(parts, g, y, extra=None, reach=None):
    """Active rows of an interior-point answer: the force, relative to the largest contact force
    (:func:`force_scale`, floored by ``reach``, :func:`reach_forces`), beats the open gap relative to the
    row's displacement scale (free of units and load scale; ``extra`` as in :func:`node_scales`, e.g.
    :func:`force_displacements`)."""
    slack, U = node_scales(parts, g, extra)
    return y / force_scale(y, reach) > np.abs(slack) / U


def slack_terms(rows, x, g, moved=None) -> tuple[np.ndarray, np.ndarray]:
    """(T, n) at the nodes of a slack q = sum_l R_l x_l - g: T_k the size of the terms row k adds up,
    sum_l (|R_l| |x_l|)_k + |g_k| (+ ``moved``_k, the size of the terms a force-controlled obstacle's translation
    adds to g), and n_k the most roundings one of those terms meets before q_k is formed: the stored entries of
    the rows (one product and one addition each), one addition per part and the gap's subtraction (+ 3 where
    ``moved``: a translation's components). ``rows`` and ``x`` are sequences of the parts (each body's jump and
    unknowns; or one stacked matrix and vector)."""
    rows = [sp.csr_matrix(R) for R in rows]
    T = sum((abs(R) @ np.abs(xl) for R, xl in zip(rows, x)), np.zeros(len(g))) + np.abs(g)
    n = sum((np.diff(R.indptr) for R in rows), np.zeros(len(g), dtype=int)) + len(rows) + 2
    if moved is not None:
        T, n = T + np.abs(moved), n + 3
    return T, n


def coefficient_rounding(B, T, n, after: int = 0) -> np.ndarray:
    """A bound on the rounding of each b_j = sum_k B_jk q_k (a Bernstein coefficient of a slack, or its value
    at a point: the rows of ``B``) in an answer an exact finish closed, from the slack's terms (T, n)
    (:func:`slack_terms`): c_j eps (|B| T)_j, c_j = 2 d_j + 2 + ``after``, d_j = max_k n_k + nnz(B_j) + 1 the most
    roundings one of its terms meets (docs/checks.md, "The rounding of b_s"); ``after``: the roundings a sum of the
    b_j meets after them (a pairing beta_s . b_s: w, its products and additions).

    A sum of terms t_i computed in floating point is within gamma_d sum |t_i| ~ d eps sum |t_i| of the exact sum
    when no term meets more than d roundings (Higham, Accuracy and Stability of Numerical Algorithms, §3.1).
    b_j is computed twice: by the finish, which closes it to its own rounding (Newton's last step: its residual
    at the rounding of its evaluation, the step's backward error and the update x + dx, eps |x| per unknown:
    the "+ 2"), and by whoever reads it back from the same unknowns in another order (the checks). The two
    differ by at most 2 gamma_d (|B| T)_j, so b_j of a closed coefficient reads within that of 0."""
    B = sp.csr_matrix(B)
    counts = np.diff(B.indptr)
    deepest = np.zeros(B.shape[0])
    has = counts > 0
    deepest[has] = np.maximum.reduceat(np.asarray(n, dtype=float)[B.indices], B.indptr[:-1][has])
    d = deepest + counts + 1
    return (2 * d + 2 + after) * np.finfo(float).eps * (abs(B) @ np.asarray(T, dtype=float))
