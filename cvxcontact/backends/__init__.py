"""Backends: the ways a discrete problem is solved.

``full``       the phi-form convex program of every body in CVXPY (the reference; accepts everything)
``condensed``  each body condensed exactly onto its contact unknowns, a small interface QP in CVXPY
``amg``        the same steps with AMG-preconditioned Krylov solves, no factorisation: large 3D scenes (pyamg)
``sparse``     active-set steps on the sparse mixed system (26) of every body: long interfaces
``finish``     the exact finish: the interface LCP solved by scaled active-set steps (NNLS fallback)
``options``    validation of solver names and options before anything is assembled

The registry :data:`BACKENDS` lists the backends in speed order (fastest first), each with
an ``accepts(problem) -> bool`` on a :class:`ProblemDescription` and a ``prefers(problem)``.
``method="auto"`` (the default) takes the first backend that accepts the problem and prefers it (no
``prefers``: every problem it accepts) (:func:`choose`): "amg" for a 3D scene of at least
:data:`AMG_UNKNOWNS` unknowns when pyamg is installed, "sparse" for a slender interface (:data:`SPARSE_SLENDER`) or above :data:`SPARSE_ROWS` contact rows
(where the condensed route's dense m x m interface matrices dominate), else "condensed", "full" for what
neither accepts.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from ..errors import SolverError

__all__ = ["METHODS", "DEFAULT_METHOD", "ProblemDescription", "Backend", "BACKENDS", "choose", "describe", "SPARSE_ROWS",
           "SPARSE_SLENDER", "AMG_UNKNOWNS"]

AMG_UNKNOWNS = 50_000
"""``method="auto"`` takes the AMG route (:mod:`cvxcontact.backends.amg`) for 3D scenes of at least this many
unknowns when pyamg is installed: there a sparse factorisation of the 3D bodies (O(N^2) flops) costs more than
AMG-preconditioned Krylov solves (O(N) each); measured in benchmarks/results/bench3d.md (elastic) and
benchmarks/results/bench_piezo_amg.md (a PZT-5A box on aluminium, GMRES with the block-triangular
preconditioner: CPU time against the sparse route 1.6 x at 2.2e4 unknowns, 0.6 x at 8.7e4)."""

SPARSE_ROWS = 8000
"""``method="auto"`` prefers the sparse route (:mod:`cvxcontact.backends.sparse`) over the condensed one for
more contact rows than this whatever the bodies (the condensed route's dense interface matrices, W alone
m x m doubles, reach 0.5 GB), or for a slender interface (:data:`SPARSE_SLENDER`)."""

SPARSE_SLENDER = 3.0
"""... or when the contact rows m exceed this many times sqrt(N), N the unknowns: a long interface beside
the bodies (a thin layer). A bulky 2D body has m ~ sqrt(N) (two_blocks: m / sqrt(N) = 1.1-1.2 at every
size), a thin layer many times more (thin_layer: 5.5 at n = 400, 8.8 at 1,000, 15 at 3,000). Why: the
condensed route costs a factorisation plus O(m^3) dense work and holds O(m^2) memory, the sparse route a
few factorisations of the mixed system (measured, 2 cores: two_blocks at 2.5e6 unknowns, 1,793 rows:
condensed about 40 s / 6 GB against sparse 1,100 s / 17 GB (SuperLU steps); thin_layer(400), 681 rows:
sparse 1.1 s against condensed 5.1 s; thin_layer(3000), 5,101 rows: sparse 17 s / 334 MB, condensed 622 s
/ 5 GB). A slender layer's interface compliance is also ill-conditioned: the condensed answer may fail
its checks, and ``auto`` then falls back to the sparse route anyway (Route.SPARSE_FALLBACK)."""


@dataclass(frozen=True)
class ProblemDescription:
    """What a backend needs to know about a problem to say whether it can solve it.

    ``quadratic_energy``: the energy is the quadratic form of linear (piezo)elasticity.
    ``linear_contact``: the contact constraints are linear rows E [u_nu] <= E g.
    ``user_terms``: number of user-added objective terms or constraints (CVXPY expressions
    on the body unknowns); the condensed backend eliminates the interior unknowns, so it
    cannot take any.
    ``held_by_contact``: some body has a rigid motion that only the contact holds (its stiffness
    is singular, so it cannot be condensed on its own).
    ``force_control``: some rigid obstacle is force controlled (its translation is an unknown with no
    stiffness, coupled to every body it touches; docs/formulation.md §12).
    ``contact_rows``, ``unknowns``: the contact rows m and the unknowns N (0: not known), for ``prefers``.
    ``compliant``, ``conic``: a normal-compliance law; the P2 conic condition. ``dim``: 2 or 3.
    ``piezoelectric``: some body has potentials.
    ``dependent_rows``: the contact rows can depend on each other (P1 "gamma3" between two 3D bodies: more
    overlay vertices than the jump's dofs, docs/formulation.md §13); the AMG route does not take them, the
    sparse route does (a regularised stage, then Lawson-Hanson on the sparse mixed system:
    :func:`~cvxcontact.backends.signorini._sparse_dependent`) but ``auto`` does not prefer it there: measured
    slower than the condensed route up to 7.6e3 unknowns (two elastic boxes, 22 systems, 14 factorisations).
    """

    quadratic_energy: bool = True
    linear_contact: bool = True
    user_terms: int = 0
    held_by_contact: bool = False
    force_control: bool = False
    contact_rows: int = 0
    unknowns: int = 0
    compliant: bool = False
    conic: bool = False
    dim: int = 2
    piezoelectric: bool = False
    dependent_rows: bool = False


def describe(problem, user_terms: int = 0) -> ProblemDescription:
    """The :class:`ProblemDescription` of a :class:`~cvxcontact.discrete.DiscreteProblem` (with ``user_terms``
    added by a :class:`~cvxcontact.Model`)."""
    from .signorini import dependent_rows

    return ProblemDescription(held_by_contact=problem.held, force_control=bool(problem.forced),
                              contact_rows=int(problem.E.shape[0]), unknowns=problem.unknowns,
                              compliant=problem.compliant, conic=problem.conic or problem.mixed,
                              user_terms=user_terms, dim=problem.dim,
                              piezoelectric=any(b.Kpp is not None for b in problem.blocks),
                              dependent_rows=bool(dependent_rows(problem)) and not problem.conic)


@dataclass(frozen=True)
class Backend:
    """A registered backend: its ``name`` (the ``method=`` value), what it ``accepts``, what it ``prefers``
    among those (None: all; ``method="auto"`` only) and its ``routes``: for each kind of problem it solves
    ("signorini", "compliance", "conic", "mixed": :func:`cvxcontact.backends.run.kind`) the function that
    solves it, as "module:function" in this package (resolved when first run, so that the registry imports
    nothing), each ``route(problem, cache, settings, timings) -> RawResult``."""

    name: str
    accepts: Callable[[ProblemDescription], bool]
    summary: str = ""
    prefers: Callable[[ProblemDescription], bool] | None = None
    routes: Mapping[str, str] = field(default_factory=dict)


def _condensed_accepts(p: ProblemDescription) -> bool:
    return p.quadratic_energy and p.linear_contact and p.user_terms == 0 and not p.held_by_contact \
        and not p.force_control


def _amg_accepts(p: ProblemDescription) -> bool:
    return _condensed_accepts(p) and not p.compliant and not p.conic and not p.dependent_rows


def _sparse_accepts(p: ProblemDescription) -> bool:
    return _condensed_accepts(p) and not p.compliant and not p.conic


def _amg_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("pyamg") is not None


BACKENDS: tuple[Backend, ...] = (
    Backend("amg", _amg_accepts,
            "active-set steps with AMG-preconditioned Krylov solves (large 3D scenes; pyamg; no factorisation)",
            prefers=lambda p: p.dim == 3 and p.unknowns >= AMG_UNKNOWNS and _amg_available(),
            routes=MappingProxyType({"signorini": "amg:signorini"})),
    Backend("sparse", _sparse_accepts,
            "active-set steps on the sparse mixed system (long interfaces; no dense m x m matrix)",
            prefers=lambda p: not p.dependent_rows and (p.contact_rows > SPARSE_ROWS
                                                         or (p.unknowns > 0 and p.contact_rows > SPARSE_SLENDER
                                                             * p.unknowns ** 0.5)),
            routes=MappingProxyType({"signorini": "signorini:sparse"})),
    Backend("condensed", _condensed_accepts,
            "exact condensation onto the contact dofs + interface QP + exact finish (fast)",
            routes=MappingProxyType({"signorini": "signorini:condensed", "compliance": "compliance:condensed",
                                     "conic": "cones:condensed", "mixed": "cones:mixed_condensed"})),
    Backend("full", lambda p: True, "the whole phi-form model in CVXPY (reference; accepts everything)",
            routes=MappingProxyType({"signorini": "signorini:full", "compliance": "compliance:full",
                                     "conic": "cones:full", "mixed": "cones:mixed_full"})),
)
"""The backends in speed order, fastest first (the sparse route where it prefers the problem: long interfaces)."""

DEFAULT_METHOD = "auto"
"""The default ``method=``: the fastest backend that accepts the problem."""

METHODS = ("auto",) + tuple(b.name for b in BACKENDS)
"""Backend names accepted by :func:`cvxcontact.solve` (``method=``)."""


def choose(method: str, problem: ProblemDescription | None = None) -> str:
    """The backend to run for ``method`` on ``problem`` (default: the package's own problem).

    ``"auto"`` gives the first backend of :data:`BACKENDS` that accepts and prefers ``problem``; a named
    backend is returned if it accepts it. Raises :class:`~cvxcontact.errors.SolverError` for an
    unknown name or a backend that does not accept the problem.
    """
    problem = ProblemDescription() if problem is None else problem
    if method == "auto":
        for b in BACKENDS:
            if b.accepts(problem) and (b.prefers is None or b.prefers(problem)):
                return b.name
        raise SolverError(f"no backend accepts {problem}; backends: {[b.name for b in BACKENDS]}")
    for b in BACKENDS:
        if b.name == method:
            if not b.accepts(problem):
                raise SolverError(f"method {method!r} does not accept {problem}; use method='auto' or 'full'")
            return b.name
    raise SolverError(f"method must be one of {METHODS}, got {method!r}")
