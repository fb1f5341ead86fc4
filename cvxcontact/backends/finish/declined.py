"""Why an exact finish stopped without an answer: a typed result, not a bare string."""

from __future__ import annotations

import enum

import numpy as np

__all__ = ["Stop", "Declined", "SINGULAR", "CYCLE", "MAX_ITER", "SINGULAR_FORCES", "STALL", "rows_to_check"]


class Stop(enum.Enum):
    """What stopped a finish's steps."""

    SINGULAR = "the mixed system on the active set is singular"
    CYCLE = "the active-set steps cycle"
    MAX_ITER = "the active-set steps did not settle"
    SINGULAR_FORCES = "the mixed system on the rows carrying the forces is singular"
    SIGNS = ("the answer on the settled active set breaks a sign, the friction cone or the slip direction, or its "
             "residual is above rounding")
    WORSE = "the answer's energy is above the interior point's"
    NOT_POSED = "the finish does not apply to this problem"
    STALL = "the Newton steps stalled above rounding"
    NO_SOLUTION = "the system at the finish's rows has no exact solution"
    DEPENDENT_ROWS = "the contact rows may be linearly dependent"
    GIVEN = "a registered backend's own reason"
    """A reason a registered backend gave as a plain string (:meth:`Declined.of`)."""


class Declined(str):
    """A finish's refusal: its :class:`Stop` (``.stop``) and, as the string itself, the words the solution's
    ``info.declined`` reports (a ``str`` so that the backends compose their messages from it). Test for it with
    ``isinstance(out, Declined)``; an answer is a tuple. ``rows`` (bool per contact row, optional; with
    :attr:`Stop.SINGULAR_FORCES`): the rows carrying the forces in the system found singular, which the
    well-posedness check after the solve reads in place of the interior point's
    (:func:`~cvxcontact.fem.kernel.check_determined`: a body those rows leave free, the load doing no work along
    it, is refused by name)."""

    stop: Stop
    rows: np.ndarray | None

    def __new__(cls, stop: Stop, words: str | None = None, rows: np.ndarray | None = None) -> "Declined":
        self = super().__new__(cls, stop.value if words is None else words)
        self.stop, self.rows = stop, rows
        return self

    def __repr__(self) -> str:
        return f"Declined({self.stop.name})"

    def __eq__(self, other) -> bool:
        """Two declines are equal when their stops, words and rows are (the same words from different stops are
        different declines); a decline and a plain ``str`` compare by the words alone, as strings do (a message
        or a test reading ``info.declined == "..."``). Not transitive across the two: a plain string may equal
        two declines that differ in their stops."""
        if isinstance(other, Declined):
            return (self.stop is other.stop and str.__eq__(self, other)
                    and _same_rows(self.rows, other.rows))
        return str.__eq__(self, other)

    def __ne__(self, other) -> bool:
        out = self.__eq__(other)
        return out if out is NotImplemented else not out

    def __hash__(self) -> int:
        """The hash of the words, as a ``str``'s: equal objects (two declines, or a decline and a plain string,
        :meth:`__eq__`) hash alike, and declines that differ in their stop alone only collide (a set or a dict
        keeps both: they compare unequal). A hash of the stop too would break that rule for a decline and the
        plain string of its words."""
        return str.__hash__(self)

    def __reduce__(self):
        """Pickled and copied with its stop, words and rows (a ``str`` subclass would be rebuilt from its words
        alone)."""
        return Declined, (self.stop, str(self), self.rows)

    @property
    def phrase(self) -> str:
        """A short phrase for a report: the :class:`Stop`'s words (a registered backend's own reason: the words
        it gave)."""
        return str(self) if self.stop is Stop.GIVEN else self.stop.value

    def within(self, context: str) -> Declined:
        """The same decline (its stop and rows) with its words set in ``context`` ("<context>: <words>")."""
        return Declined(self.stop, f"{context}: {self}", self.rows)

    def checked_rows(self, rows: np.ndarray | None, polished: bool) -> np.ndarray | None:
        """The rows the well-posedness check after the solve reads (:func:`rows_to_check`) when this decline
        stands next to ``rows`` (the route's own: its active set, or the rows carrying a force) and the answer is
        ``polished`` or not: :attr:`Stop.SINGULAR_FORCES` the rows of its singular system (``rows`` if it does not
        name them), whatever the answer; every other stop, ``rows`` of a finished answer only."""
        if self.stop is Stop.SINGULAR_FORCES:
            return rows if self.rows is None else self.rows
        return rows if polished else None

    @classmethod
    def of(cls, reason) -> Declined | None:
        """``reason`` as a typed decline: None for no reason (None, ""), a :class:`Declined` itself, a plain
        string (a registered backend's) as :attr:`Stop.GIVEN` with its words."""
        if isinstance(reason, Declined) or reason is None:
            return reason
        if isinstance(reason, str):
            return cls(Stop.GIVEN, reason) if reason else None
        raise TypeError(f"a declined finish's reason must be a Declined or a string, got {type(reason).__name__}")


def _same_rows(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two declines' ``rows`` are the same (both None, or equal arrays)."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.array_equal(a, b))


SINGULAR = Declined(Stop.SINGULAR)
CYCLE = Declined(Stop.CYCLE)
MAX_ITER = Declined(Stop.MAX_ITER)
SINGULAR_FORCES = Declined(Stop.SINGULAR_FORCES)
STALL = Declined(Stop.STALL)


def rows_to_check(declined: Declined | None, rows: np.ndarray | None, polished: bool) -> np.ndarray | None:
    """The contact rows whose hold on the bodies the check after a solve reads
    (:func:`~cvxcontact.fem.kernel.check_determined`), or None for no check: with no decline, ``rows`` (the
    route's: its active set or the rows carrying a force) of a finished answer; with one, what it says
    (:meth:`Declined.checked_rows`)."""
    if declined is None:
        return rows if polished else None
    return declined.checked_rows(rows, polished)
