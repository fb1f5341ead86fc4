"""Why an exact finish stopped without an answer: a typed result, not a bare string."""

from __future__ import annotations

import enum

import numpy as np

__all__ = ["Stop", "Declined", "SINGULAR", "CYCLE", "MAX_ITER", "SINGULAR_FORCES", "STALL"]


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


SINGULAR = Declined(Stop.SINGULAR)
CYCLE = Declined(Stop.CYCLE)
MAX_ITER = Declined(Stop.MAX_ITER)
SINGULAR_FORCES = Declined(Stop.SINGULAR_FORCES)
STALL = Declined(Stop.STALL)
