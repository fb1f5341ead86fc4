"""A friction law's own data: what its term (:class:`~cvxcontact.discrete.terms.TrescaFriction` and the terms
derived from it, :class:`~cvxcontact.discrete.terms.ConesWithFriction`) holds beside the problem (docs/howto/
friction.md, docs/architecture.md "A new contact law").

:class:`Slip`, built with the problem (:meth:`~cvxcontact.discrete.terms.ContactTerm.with_data`) from the contact
lines, the bodies' systems and the units, is the slip s = E [u_t] of the rows on the free unknowns (each body's
tangential jump restricted to them, ``operators``; the rows of every slip component, ``rows``), the slip that
prescribed displacements fix (``prescribed``) and the slip a force-controlled obstacle's translations cause
(``translations``, :func:`obstacle_slip`), the rows' weights (``weights``: :func:`friction_weights`) and the
capacities c_a = g_a(p_a) w_a they give (:meth:`Slip.capacities`), and the capacity the well-posedness check reads
before the solve (:meth:`Slip.kernel_capacity`). The problem holds the term; nothing outside a friction term's
functions reads this.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..contact.bernstein import positive_force
from ..errors import SolverError, UnsupportedError, frozen
from .blocks import Units

__all__ = ["Slip", "friction_weights", "obstacle_slip", "row_weights", "slip_rows"]


@dataclass(frozen=True, eq=False)
class Slip:
    """A friction law's data (module docstring), scaled like the problem's blocks (:mod:`cvxcontact.discrete.blocks`).

    ``lines``: the problem's :class:`~cvxcontact.fem.space.ContactLines`; ``units``: its units; ``dim``: the scene's
    dimension; ``condition``, ``conditions``: the solve's condition and each pair's own (None: the solve's);
    ``tangential``: each body's slip
    [u_t] at the nodes of X_h from its nodal displacements (SI, component-major, :func:`obstacle_slip`'s layout);
    ``operators``: the same on its free unknowns (the blocks' jump's counterpart, T_k T_u); ``prescribed``: [u_D t],
    the slip prescribed displacements of contact nodes fix (scaled); ``translations``: per force-controlled obstacle,
    the slip at the nodes of X_h of its translation unknowns tau ((c size, k), :func:`obstacle_slip`); ``weights``:
    the rows' weights of the capacities (m; m^2 in 3D, :func:`friction_weights`)."""

    lines: object
    units: Units
    dim: int
    condition: str
    conditions: tuple
    tangential: tuple
    operators: tuple
    prescribed: np.ndarray | float
    translations: tuple
    weights: np.ndarray

    def __post_init__(self):
        for T in self.operators:                # canonical and read-only, as the blocks' jumps: the read-back's
            frozen(T)                           # abs(T) (solution/friction.py) sorted them in place

    @classmethod
    def build(cls, scene, condition: str, lines, systems, units: Units) -> Slip:
        """The data of a friction law on ``lines`` (:class:`~cvxcontact.fem.space.ContactLines`) of ``scene`` under
        ``condition``, the bodies' assembled ``systems`` and ``units``; UnsupportedError where a frictional pair's
        rows are not its nodes (:func:`friction_weights`)."""
        dim = scene.dim
        counts = [len(s.f) // dim for s in systems]
        forced = [o for o in lines.obstacles if o.force is not None]
        moves = tuple(obstacle_slip(lines.interface, o, counts) for o in forced)
        tangential = tuple(lines.interface.tangential_jump(k, n) for k, n in enumerate(counts))
        operators = tuple((T @ s.Tu).tocsr() for T, s in zip(tangential, systems))
        prescribed = sum((T @ s.u_fixed for T, s in zip(tangential, systems) if s.u_fixed is not None),
                         np.zeros(tangential[0].shape[0])) / units.displacement
        weights = friction_weights(lines, condition, scene.conditions)
        return cls(lines=lines, units=units, dim=dim, condition=condition, conditions=tuple(scene.conditions),
                   tangential=tangential, operators=operators, prescribed=prescribed, translations=moves,
                   weights=weights)

    @property
    def components(self) -> int:
        """Components of the slip per row: 1 in 2D (along t), 2 in 3D (along the pair's frame)."""
        return getattr(self.lines.interface, "slip_components", 1)

    @property
    def rows(self) -> sp.csr_matrix:
        """kron(I_c, E): the rows of every slip component (component-major, :func:`slip_rows`)."""
        return slip_rows(self.lines.E, self.lines.interface)

    @property
    def row_lengths(self) -> np.ndarray:
        """The lumped lengths of the rows (docs/formulation.md §10), scaled: the friction energy's weights."""
        return self.weights / self.units.length

    @property
    def thresholds(self) -> np.ndarray:
        """The slip thresholds of the rows at zero pressure, scaled (g / (c0 s); 0 on frictionless rows and on
        rows whose threshold is the pressure's, :meth:`capacities`)."""
        return self.lines.rows.thresholds(0.0) / (self.units.stress * self.units.load)

    def pressing(self, y: np.ndarray) -> np.ndarray:
        """The normal row forces whose pressures set a pressure-dependent friction law's thresholds (scaled): the
        row forces ``y`` themselves, and under the P2 cones, where the nodal force y = B^T beta may be negative
        at a node beside a force between nodes, its non-negative parts with the sums kept, node by node's patch
        (:func:`~cvxcontact.contact.bernstein.positive_force`; docs/howto/friction.md, "Coulomb under the
        cones"): the same wherever y >= 0 around a node."""
        cone = self.lines.cone
        return np.asarray(y, dtype=float) if cone is None else positive_force(cone[1], y)

    def capacities(self, y: np.ndarray) -> np.ndarray:
        """The friction capacity c_a = g_a(p_a) w_a of every row (scaled), the thresholds at the pressures
        p_a = y_a / w_a of the normal row forces ``y`` (scaled), those of :meth:`pressing` (Coulomb:
        c_a = mu p_a w_a = mu y_a where y >= 0 around the row; under the P2 cones they sum to mu times the
        normal force)."""
        y = self.pressing(y)
        w = self.row_lengths
        stress = self.units.stress * self.units.load
        pressure = np.divide(np.asarray(y, dtype=float), w, out=np.zeros(len(w)), where=w > 0) * stress
        return self.lines.rows.thresholds(pressure) / stress * w

    def kernel_capacity(self):
        """(T, c, moves) for the well-posedness check (:func:`~cvxcontact.fem.kernel.check_well_posed`'s
        ``capacity``): the slip rows [u_t] of every body (a function k, n_nodes -> rows at the evaluation rows),
        each row's friction capacity g_a w_a (N/m; ``inf`` where the threshold is the pressure's, not known before
        the solve: such a row resists every slip, and the friction route checks its capacity at every iterate),
        and ``moves(o)``, the slip rows of a force-controlled obstacle's translations on the frictional rows.
        SolverError where the cones' rows and the friction rows differ; UnsupportedError for Coulomb under the 3D
        P2 cones between two bodies (docs/refusals.md)."""
        lines, condition, rows, E, weights = self.lines, self.condition, self.lines.rows, self.lines.E, self.weights
        if lines.conic and not rows.size == len(weights) == E.shape[0]:   # the cones on E's rows (no compliance
            #                              law: cones beside one are lines.mixed, refused by the terms: terms.UNPOSED)
            raise SolverError(f"friction under the P2 'gamma3' cones: {rows.size} friction rows, {len(weights)} "
                              f"weights and {E.shape[0]} rows of the cones, which must be the same rows (the space's "
                              "contact lines are inconsistent, not the scene)")
        pairs = getattr(lines.interface, "interfaces", (lines.interface,))
        if lines.conic and rows.pressure_dependent.any() and self.dim == 3 and any(
                not getattr(i, "rigid", True) and (c or condition) == "gamma3"
                for i, c in zip(pairs, self.conditions)):
            raise UnsupportedError(
                "a pressure-dependent friction law (cc.Coulomb) with P2 tetrahedra under 'gamma3' between two bodies "
                "is not available: its capacities mu r_a need the cones' nodal normal forces r on the nodes of X_h, "
                "which are not unique where the faces do not match (more overlay nodes than the jump's degrees of "
                "freedom: the capacities, and the answer, would depend on the solver's representation); use "
                "cc.Tresca(g) under 'gamma3', or cc.Coulomb with condition='sigma1' or 'sigma2' (nodal rows with "
                "positive weights), or degree=1 with 'gamma3'; against a rigid obstacle Coulomb under 'gamma3' with "
                "P2 is available")
        capacity = np.where(rows.pressure_dependent, np.inf, rows.thresholds(0.0) * weights)
        Ec = slip_rows(E, lines.interface)
        frictional = np.tile(rows.frictional, self.components)
        forced = [o for o in lines.obstacles if o.force is not None]
        on_rows = {id(o): np.where(frictional[:, None], Ec @ T, 0.0) for o, T in zip(forced, self.translations)}
        interface = lines.interface
        return (lambda k, n: Ec @ interface.tangential_jump(k, n)), capacity, lambda o: on_rows[id(o)]


def obstacle_slip(interface, obstacle, counts, basis=None) -> np.ndarray:
    """(c size, k): the slip [u_t] at the stacked nodes of X_h (component-major, like ``tangential_jump``) that a
    unit translation of the obstacle along each of its ``basis`` columns causes on its pairs' nodes: the body's
    nodes slip against it by -t . t_a, minus the slip of the body translated by t (the interpolations of the traces
    sum to 1), 0 on the other pairs' nodes. ``counts``: the bodies' node counts; ``basis`` (d, k): other directions
    (default the obstacle's ``basis``; the identity gives the slip of a translation along each axis)."""
    c = getattr(interface, "slip_components", 1)
    offsets = getattr(interface, "offsets", (0, interface.size))
    size = int(offsets[-1])
    on = np.zeros(size, dtype=bool)
    for i in obstacle.pairs:
        on[offsets[i]:offsets[i + 1]] = True
    basis = np.asarray(obstacle.basis if basis is None else basis, dtype=float)
    out = np.zeros((c * size, basis.shape[1]))
    for k, n in enumerate(counts):
        T = interface.tangential_jump(k, n)
        out -= np.column_stack([T @ np.tile(v, n) for v in basis.T])
    out[~np.tile(on, c)] = 0.0
    return out


def friction_weights(lines, condition, conditions) -> np.ndarray:
    """The weights of the friction capacities g_a w_a, one per row (m; m^2 in 3D): :func:`row_weights`, or, where a
    compliance pair's rows are its law's quadrature points (P2 in 3D: not one row per node of the condition), per
    pair its :func:`row_weights` where they are its rows and the law's own weights on such a pair (frictionless: no
    capacity there, the weights of its quadrature). UnsupportedError if a frictional pair's rows are not its nodes."""
    w = row_weights(lines.interface, condition, conditions)
    rows = lines.rows
    if len(w) == rows.size or lines.weights is None or not hasattr(lines.interface, "interfaces"):
        return w
    interfaces = lines.interface.interfaces
    conditions = conditions or [None] * len(interfaces)
    parts, start = [], 0
    for itf, c, n, law in zip(interfaces, conditions, rows.counts, rows.laws):
        own = itf.weights(condition if c is None else c)
        if len(own) != n and law.friction is not None:
            raise UnsupportedError(f"a friction law on a pair whose {n} contact rows are not the {len(own)} nodes of "
                                   "its condition is not available: pose the pair under a nodal condition")
        parts.append(own if len(own) == n else np.asarray(lines.weights[start:start + n], dtype=float))
        start += n
    return np.concatenate(parts)


def row_weights(interface, condition, conditions) -> np.ndarray:
    """The lumped lengths (areas) of the rows (m; docs/formulation.md §10) of a stack of pairs under their own
    ``conditions`` (None: ``condition``), or of one P2 pair
    (:class:`~cvxcontact.contact.quadratic.QuadraticInterface`, which poses its own condition: Simpson's weights, all
    positive)."""
    if hasattr(interface, "interfaces"):
        return interface.weights(condition, conditions)
    return interface.weights(conditions[0] or condition if conditions else condition)


def slip_rows(E, interface) -> sp.csr_matrix:
    """The evaluation rows of every slip component: kron(I_c, E) (c = the interface's ``slip_components``, 1 in
    2D, 2 in 3D; component-major like :meth:`~cvxcontact.contact.interface.Stack.tangential_jump`)."""
    return sp.kron(sp.identity(getattr(interface, "slip_components", 1), format="csr"), E, format="csr")
