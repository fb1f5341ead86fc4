"""How a solution was reached: :class:`SolveInfo`, with named constants for its fields.

``Solution.info`` is a frozen :class:`SolveInfo`; the older attributes ``Solution.status``,
``.path``, ``.method``, ``.timings`` and ``.polished`` read it. The constants are
:class:`enum.StrEnum` members, so they compare equal to the plain strings used before
(``Status.OPTIMAL == "optimal" == cvxpy.OPTIMAL``, ``Route.WARM_START == "active-set warm start"``)
and serialise to JSON as those strings.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType

__all__ = ["Status", "Route", "Finish", "SolveInfo"]


class Status(StrEnum):
    """Status of the solve (the solver's, or OPTIMAL for a verified active-set warm start)."""

    OPTIMAL = "optimal"
    OPTIMAL_INACCURATE = "optimal_inaccurate"


class Route(StrEnum):
    """The route that produced the arrays of a :class:`~cvxcontact.solution.Solution`."""

    INTERIOR_POINT = "interior point"
    """The interior-point answer as it came from the solver (no finish, or the finish was declined)."""
    INTERIOR_POINT_FINISHED = "interior point + exact finish"
    """An interior-point solve, then the exact active-set finish."""
    WARM_START = "active-set warm start"
    """A re-solve of a ContactSolver from the previous active set: no convex program, no iterations."""
    NEWTON_ONLY = "semismooth Newton (the interior point failed)"
    """Normal compliance: the solver failed on the convex program (e.g. a very stiff law); the exact
    finish, globally convergent on its own, solved the interface equation from the free slack."""
    SPARSE_ACTIVE_SET = "active-set steps on the sparse mixed system"
    """The sparse route (method "sparse"): exact active-set steps on the sparse mixed system (26) from the
    bonded system, no convex program (``iterations``: the systems solved)."""
    INTERIOR_POINT_NONLINEAR = "interior point (no exact finish: non-linear user terms)"
    """A :class:`~cvxcontact.Model` with non-linear user terms: the interior-point answer, checked."""
    NO_CONTACT = "no contact at zero force: the unconstrained solution"
    """The conic P2 condition (condensed): the bodies' unconstrained solution already satisfies it on every
    merged segment, so it is the solution, exactly (forces 0), and no program is solved."""
    SPARSE_FALLBACK = "condensed, failed its checks -> sparse active-set steps"
    """``method="auto"``: the condensed answer failed the checks of (26)-(27) (an ill-conditioned interface
    compliance, e.g. a slender layer); the sparse route (:mod:`cvxcontact.backends.sparse`) solved the
    mixed system from the condensed active set and its answer passed them."""


class Finish(StrEnum):
    """How the exact finish found its active set (:func:`cvxcontact.backends.finish.solve_lcp`)."""

    ACTIVE_SET = "active set"
    ACTIVE_SET_AFTER_NNLS = "active set after NNLS"
    NNLS = "NNLS"
    SEMISMOOTH_NEWTON = "semismooth Newton"
    """Normal compliance: :func:`cvxcontact.backends.finish.solve_compliance`."""


def _frozen_timings(timings: Mapping[str, float] | None) -> Mapping[str, float]:
    return MappingProxyType({str(k): float(v) for k, v in (timings or {}).items()})


@dataclass(frozen=True)
class SolveInfo:
    """What a solve did. Immutable; ``timings`` is a read-only mapping.

    Attributes
    ----------
    status : Status
        OPTIMAL or OPTIMAL_INACCURATE (any other solver status raises SolverError).
    method : str
        The backend actually used ("full" or "condensed"; never "auto").
    requested : str
        The ``method=`` that was asked for ("auto", "full" or "condensed").
    route : Route
        INTERIOR_POINT, INTERIOR_POINT_FINISHED or WARM_START.
    polished : bool
        True if the arrays are the exact finish (route INTERIOR_POINT_FINISHED or WARM_START).
    iterations : int
        Interior-point iterations of this solve (0 for a warm start); for the sparse route the number of
        active-set steps (systems solved).
    timings : Mapping[str, float]
        Wall-clock seconds per stage of this solve ("assembly", "factorization", "loads",
        "model", "compile", "solve", "polish", "back_substitution", "read_back", ...). A stage
        that did not run in this solve is absent: "factorization" appears once per ContactSolver.
    finish : Finish or None
        How the exact finish found its active set; None if there was no finish.
    factorization : str
        The adapter that factorised the bodies for the condensed path or the exact finish ("superlu" or
        "pardiso", :mod:`cvxcontact.backends.factor`); "" if no body was factorised.
    """

    status: Status
    method: str
    route: Route
    polished: bool = False
    iterations: int = 0
    timings: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    finish: Finish | None = None
    requested: str = ""
    factorization: str = ""

    def __post_init__(self):
        object.__setattr__(self, "status", Status(self.status))
        object.__setattr__(self, "route", Route(self.route))
        if self.finish is not None:
            object.__setattr__(self, "finish", Finish(self.finish))
        object.__setattr__(self, "timings", _frozen_timings(self.timings))
        object.__setattr__(self, "iterations", int(self.iterations))
        object.__setattr__(self, "polished", bool(self.polished))
        if not self.requested:
            object.__setattr__(self, "requested", self.method)

    @property
    def factorizations(self) -> int:
        """1 if this solve factorised the bodies (the first solve of a condensed ContactSolver), else 0."""
        return int("factorization" in self.timings)
