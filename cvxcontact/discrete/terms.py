"""The contact term of a discrete problem: what its law poses and what the solve asks of it (docs/architecture.md,
"A new contact law").

A :class:`ContactTerm` is built once with the :class:`~cvxcontact.discrete.DiscreteProblem` (``problem.term``)
from its contact lines, the first term of :data:`TERMS` that poses them. It answers the questions the backends,
the read-back and the solve ask of a law, instead of each branching on flags:

- ``kind``: the key of its route in a backend's ``routes`` (:data:`cvxcontact.backends.KINDS`) and of its
  read-back (:data:`cvxcontact.solution.readback.READ_BACKS`);
- ``compliant``, ``cones``, ``tangential``: a normal-compliance law on some rows; the P2 "everywhere" cones in
  its program (docs/formulation.md §8, §10); a friction law's tangential part (what
  :class:`~cvxcontact.backends.ProblemDescription` tells a backend);
- ``takes_active_start``: a state from another mesh gives the first active-set guess
  (:func:`~cvxcontact.backends.start.start_active`); ``hands_on_state``: its exact finish's forces can start a
  solve on another mesh (:func:`~cvxcontact.backends.start.contact_state`);
- ``zeroes_held_forces``: the forces of the rows no unknown moves are set to 0, their least admissible value
  (docs/formulation.md §8, "Held nodes"); ``active_from_forces``: without an active set from the finish, the rows
  that carry a force count as active for the determinacy check (:func:`~cvxcontact.fem.kernel.check_determined`);
- ``finishes``: an exact finish exists whose decline is reported; ``always_finished``: it runs on every problem
  with a quadratic energy (the cones' cuts only on problems they can condense);
- ``rows_may_depend``: its evaluation rows are rows whose linear dependence a route must handle (the cones'
  E is the identity on X_h);
- ``estimated``: the a posteriori error estimates count its forces; ``takes_user_terms``: ``cc.Model`` poses
  user terms beside it.

A new law that needs another program adds a class here (its answers and its ``poses(lines)``), an entry of
:data:`TERMS`, a route per backend that solves it and a read-back (docs/architecture.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

__all__ = ["ContactTerm", "SignoriniRows", "ComplianceRows", "EverywhereCones", "ConesBesideCompliance",
           "TrescaFriction", "TERMS", "contact_term"]


@runtime_checkable
class ContactTerm(Protocol):
    """What a problem's contact term answers (module docstring). ``dim``: the space's displacement components."""

    kind: str
    compliant: bool
    cones: bool
    tangential: bool
    hands_on_state: bool
    zeroes_held_forces: bool
    active_from_forces: bool
    finishes: bool
    always_finished: bool
    rows_may_depend: bool
    estimated: bool
    takes_user_terms: bool

    @property
    def takes_active_start(self) -> bool: ...


@dataclass(frozen=True)
class _Term:
    """The answers every term shares unless it says otherwise; ``dim`` the space's displacement components."""

    dim: int
    kind: ClassVar[str] = ""
    compliant: ClassVar[bool] = False
    cones: ClassVar[bool] = False
    tangential: ClassVar[bool] = False
    zeroes_held_forces: ClassVar[bool] = False
    active_from_forces: ClassVar[bool] = False
    finishes: ClassVar[bool] = True
    always_finished: ClassVar[bool] = True
    rows_may_depend: ClassVar[bool] = True
    estimated: ClassVar[bool] = True
    takes_user_terms: ClassVar[bool] = True
    _starts: ClassVar[tuple[int, ...]] = ()   # dims where another mesh's state gives its first active-set guess
    _states: ClassVar[tuple[int, ...]] = ()   # dims where its exact finish's forces are point loads on the pairs

    @property
    def takes_active_start(self) -> bool:
        """A state from another mesh gives the first active-set guess (the rows' positions on the pairs)."""
        return self.dim in self._starts

    @property
    def hands_on_state(self) -> bool:
        """Its exact finish's forces, as point loads on the pairs, can start a solve on another mesh."""
        return self.dim in self._states


@dataclass(frozen=True)
class SignoriniRows(_Term):
    """Signorini's law at nodal rows E [u_nu] <= E g (P1, P2 sigma conditions; docs/formulation.md §2, §8)."""

    kind: ClassVar[str] = "signorini"
    zeroes_held_forces: ClassVar[bool] = True
    _starts: ClassVar[tuple[int, ...]] = (2, 3)
    _states: ClassVar[tuple[int, ...]] = (2, 3)

    @staticmethod
    def poses(lines) -> bool:
        return True


@dataclass(frozen=True)
class ComplianceRows(_Term):
    """A normal-compliance law on some nodal rows, Signorini (or a penetration limit) on the others (§10)."""

    kind: ClassVar[str] = "compliance"
    compliant: ClassVar[bool] = True
    active_from_forces: ClassVar[bool] = True

    @staticmethod
    def poses(lines) -> bool:
        return lines.rows.compliant


@dataclass(frozen=True)
class EverywhereCones(_Term):
    """The P2 "gamma3" condition: a cone per element on the Bernstein coefficients of the slack (§8); its
    cuts finish only problems they can condense."""

    kind: ClassVar[str] = "conic"
    cones: ClassVar[bool] = True
    always_finished: ClassVar[bool] = False
    rows_may_depend: ClassVar[bool] = False
    _states: ClassVar[tuple[int, ...]] = (2,)     # the cuts' point loads along s (backends.start.cone_seeds)

    @staticmethod
    def poses(lines) -> bool:
        return lines.conic


@dataclass(frozen=True)
class ConesBesideCompliance(_Term):
    """The P2 cones of some pairs in one program with a normal-compliance law on others (§10, "P2"); the
    interior point's answer (no exact finish is reported as declined)."""

    kind: ClassVar[str] = "mixed"
    compliant: ClassVar[bool] = True
    cones: ClassVar[bool] = True
    finishes: ClassVar[bool] = False
    always_finished: ClassVar[bool] = False

    @staticmethod
    def poses(lines) -> bool:
        return lines.mixed


@dataclass(frozen=True)
class TrescaFriction(_Term):
    """Signorini rows and a friction law's cone per row on the slip (docs/howto/friction.md; Tresca, and Coulomb
    by a fixed point on the thresholds; 2D and 3D P1, 2D P2 under the nodal conditions): the full program only,
    then its exact finish (:func:`cvxcontact.backends.friction.exact_finish`; a decline keeps the interior
    point's answer without a warning, as before the finish existed); no error estimate, no user terms yet."""

    kind: ClassVar[str] = "friction"
    tangential: ClassVar[bool] = True
    finishes: ClassVar[bool] = False
    always_finished: ClassVar[bool] = False
    estimated: ClassVar[bool] = False
    takes_user_terms: ClassVar[bool] = False

    @staticmethod
    def poses(lines) -> bool:
        return lines.rows.friction


TERMS: tuple = (TrescaFriction, ConesBesideCompliance, EverywhereCones, ComplianceRows, SignoriniRows)
"""The terms in the order they are tried: the first whose ``poses(lines)`` holds is the problem's (a friction
law before the normal ones, cones beside a law before cones alone, Signorini rows last)."""


def contact_term(lines, dim: int) -> ContactTerm:
    """The :class:`ContactTerm` of the contact lines ``lines`` (:class:`~cvxcontact.fem.space.ContactLines`) in
    a space of ``dim`` displacement components: the first of :data:`TERMS` that poses them."""
    return next(term for term in TERMS if term.poses(lines))(dim)
