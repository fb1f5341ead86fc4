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

from ..backends.finish.declined import Declined
from ..backends.result import Finish, Route, Status
from ..errors import SolverError

__all__ = ["Status", "Route", "Finish", "SolveInfo"]


def _label(kind: type[StrEnum], value) -> str:
    """``value`` as a member of ``kind`` if it is one, else as a backend's own label (a non-empty string)."""
    if value in kind._value2member_map_:
        return kind(value)
    if not isinstance(value, str) or not value:
        raise SolverError(f"a {kind.__name__.lower()} label must be a {kind.__name__} or a backend's own non-empty "
                          f"string, got {value!r}")
    return str(value)


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
        The backend actually used: one of the backends of :data:`cvxcontact.backends.METHODS` ("amg", "sparse",
        "condensed", "newton" or "full", or one registered by :func:`cvxcontact.backends.register`; never "auto").
    requested : str
        The ``method=`` that was asked for ("auto" or one of the backends).
    route : Route or str
        The route that produced the arrays (a member of :class:`Route`, e.g. INTERIOR_POINT,
        INTERIOR_POINT_FINISHED, WARM_START, SPARSE_ACTIVE_SET, KRYLOV_ACTIVE_SET; or the own label of a
        registered backend, :func:`cvxcontact.backends.register`).
    polished : bool
        True if the arrays are an exact finish (the routes of the finish and of the active-set steps).
    iterations : int
        Interior-point iterations of this solve (0 for a warm start); for the sparse route the number of
        active-set steps (systems solved).
    timings : Mapping[str, float]
        Wall-clock seconds per stage of this solve ("assembly", "factorization", "loads",
        "model", "compile", "solve", "polish", "back_substitution", "read_back", ...). A stage
        that did not run in this solve is absent: "factorization" appears once per ContactSolver.
    finish : Finish, str or None
        How the exact finish found its active set (a :class:`Finish`, or a registered backend's own label);
        None if there was no finish.
    factorization : str
        The adapter that factorised the bodies for the condensed path or the exact finish ("superlu" or
        "pardiso", :mod:`cvxcontact.backends.factor`); "" if no body was factorised.
    fixed_point : tuple of float
        Coulomb friction: the relative change of the friction capacities at each iteration of the fixed point
        that produced the answer (docs/howto/friction.md, "Coulomb"; its length is the number of iterations):
        the exact finish's where it ran one (the P2 cones' cut points, then their tangency points), else the
        interior point's (a finish on Coulomb's own law, or a declined one); () otherwise.
    released : bool
        True if the condensed route freed some body's factorisation once its interface stiffness was taken (memory
        short, :mod:`cvxcontact.backends.budget`) and re-made its interior factorisation for the back-substitution
        (the answer is the same to rounding; the "back_substitution" stage then includes the factorisations).
    declined : Declined or None
        Why the exact finish was declined, where the answer is the interior point's because of it: a
        :class:`~cvxcontact.backends.finish.declined.Declined` (a string, its full words; ``.stop`` what stopped
        it, ``.phrase`` the short phrase :meth:`~cvxcontact.solution.Solution.report` shows); None if the arrays
        are an exact finish or none was declined. A plain string becomes a ``Declined`` of ``Stop.GIVEN``.
    handed_over : str
        Where the route of ``requested`` handed the problem to another (:attr:`Route.SPARSE_HANDED_OVER`; the AMG
        route to the sparse route, :mod:`cvxcontact.backends.amg`; ``auto``'s fallback, :attr:`Route.SPARSE_FALLBACK`),
        why, in words (each hand-over's in turn, "; "-joined; :meth:`~cvxcontact.solution.Solution.report` shows it);
        "" where none did.
    kept : str
        Where a finish was declined (``declined``), what the arrays are, in words: "interior-point answer", or
        the answer the finish's caller kept instead (the P2 cones with friction: "cut rounds' answer", exact to
        the cuts' stop; :meth:`~cvxcontact.solution.Solution.report` and the warning name it); "" where none was
        declined.
    """

    status: Status
    method: str
    route: Route | str
    polished: bool = False
    iterations: int = 0
    timings: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    finish: Finish | str | None = None
    requested: str = ""
    factorization: str = ""
    fixed_point: tuple = ()
    declined: Declined | None = None
    released: bool = False
    kept: str = ""
    handed_over: str = ""

    def __post_init__(self):
        object.__setattr__(self, "status", Status(self.status))
        object.__setattr__(self, "route", _label(Route, self.route))
        if self.finish is not None:
            object.__setattr__(self, "finish", _label(Finish, self.finish))
        object.__setattr__(self, "timings", _frozen_timings(self.timings))
        object.__setattr__(self, "iterations", int(self.iterations))
        object.__setattr__(self, "polished", bool(self.polished))
        object.__setattr__(self, "released", bool(self.released))
        object.__setattr__(self, "handed_over", str(self.handed_over or ""))
        object.__setattr__(self, "fixed_point", tuple(float(d) for d in self.fixed_point))
        try:
            object.__setattr__(self, "declined", Declined.of(self.declined))
        except TypeError as exc:
            raise SolverError(f"{exc}; give the Declined a finish returned, its words, or None") from None
        if not self.requested:
            object.__setattr__(self, "requested", self.method)

    @property
    def factorizations(self) -> int:
        """1 if this solve factorised the bodies (the first solve of a condensed ContactSolver), else 0."""
        return int("factorization" in self.timings)
