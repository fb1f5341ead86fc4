"""Backends: the ways a discrete problem is solved.

``full``       the phi-form convex program of every body in CVXPY (the reference; accepts everything)
``condensed``  each body condensed exactly onto its contact unknowns, a small interface QP in CVXPY
``amg``        the same steps with AMG-preconditioned Krylov solves, no factorisation: large 3D scenes (pyamg)
``sparse``     active-set steps on the sparse mixed system (26) of every body: long interfaces
``newton``     a non-quadratic bulk energy (Hencky): Newton on the nonlinear (26), no interior point
``finish``     the exact finish: the interface LCP solved by scaled active-set steps (NNLS fallback)
``options``    validation of solver names and options before anything is assembled

The registry :data:`BACKENDS` lists the backends in speed order (fastest first), each a :class:`Backend` with
an ``accepts(problem) -> bool`` on a :class:`ProblemDescription` and a ``prefers(problem)``.
``method="auto"`` (the default) takes the first backend that accepts the problem and prefers it (no
``prefers``: every problem it accepts) (:func:`choose`): "amg" for a 3D scene of at least
:data:`AMG_UNKNOWNS` unknowns when pyamg is installed, "sparse" for a slender interface (:data:`SPARSE_SLENDER`) or above :data:`SPARSE_ROWS` contact rows
(where the condensed route's dense m x m interface matrices dominate), else "condensed"; "newton" for a
non-quadratic bulk energy with Signorini rows or a compliance law (:mod:`cvxcontact.backends.nonlinear`), "full"
for what none accepts (e.g. the P2 cones beside a non-quadratic energy, :func:`~cvxcontact.backends.cones.
finish_bulk`). A backend outside the package plugs in with one call, :func:`register` (docs/howto/extending.md).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

from ..discrete.terms import TERMS
from ..errors import SolverError, UnsupportedError
from .result import Route

__all__ = ["METHODS", "DEFAULT_METHOD", "ProblemDescription", "Backend", "Fallback", "BACKENDS", "KINDS", "choose",
           "describe", "register", "unregister", "backend", "SPARSE_ROWS", "SPARSE_SLENDER", "AMG_UNKNOWNS",
           "Refusal", "REFUSALS"]

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

    ``quadratic_energy``: the energy is the quadratic form of linear (piezo)elasticity (False: some body's
    material has a non-quadratic bulk energy, :mod:`cvxcontact.discrete.energy`; "newton" and "full" solve it).
    ``linear_contact``: the contact constraints are linear rows E [u_nu] <= E g.
    ``user_terms``: number of user-added objective terms or constraints (CVXPY expressions
    on the body unknowns); the condensed backend eliminates the interior unknowns, so it
    cannot take any.
    ``held_by_contact``: some body has a rigid motion that only the contact holds (its stiffness
    is singular, so it cannot be condensed on its own).
    ``force_control``: some rigid obstacle is force controlled (its translation is an unknown with no
    stiffness, coupled to every body it touches; docs/formulation.md §12); the condensed backend takes it for
    the kinds of :data:`FORCED_KINDS` (the translations bordering the condensed system), sparse and AMG do not.
    ``contact_rows``, ``unknowns``: the contact rows m and the unknowns N (0: not known), for ``prefers``.
    ``compliant``, ``conic``: a normal-compliance law; the P2 conic condition. ``dim``: 2 or 3. ``degree``:
    the element degree (1: P1, 2: P2).
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
    degree: int = 1
    piezoelectric: bool = False
    dependent_rows: bool = False
    friction: bool = False
    """Some pair has a friction law (:class:`~cvxcontact.contact.laws.Tresca`, ``Coulomb``): a cone per contact row on the
    slip, posed by the full program only (no condensed, sparse or AMG route, no exact finish yet)."""
    kind: str = "signorini"
    """The kind of the problem's contact term (:data:`KINDS`): a backend with no route for it refuses the problem."""


def describe(problem, user_terms: int = 0) -> ProblemDescription:
    """The :class:`ProblemDescription` of a :class:`~cvxcontact.discrete.DiscreteProblem` (with ``user_terms``
    added by a :class:`~cvxcontact.Model`)."""
    from .signorini import dependent_rows

    term = problem.term
    return ProblemDescription(quadratic_energy=problem.quadratic, held_by_contact=problem.held, force_control=bool(problem.forced),
                              contact_rows=int(problem.E.shape[0]), unknowns=problem.unknowns,
                              compliant=term.compliant, conic=term.cones,
                              user_terms=user_terms, dim=problem.dim, degree=problem.space.degree,
                              piezoelectric=any(b.Kpp is not None for b in problem.blocks),
                              dependent_rows=term.rows_may_depend and bool(dependent_rows(problem)),
                              friction=term.tangential, kind=term.kind)


def _kinds() -> tuple:
    return tuple(dict.fromkeys(t.kind for t in reversed(TERMS)))


@dataclass(frozen=True)
class Fallback:
    """What ``method="auto"`` runs when a backend's exact (finished) answer fails the checks of (26)-(27):
    the backend ``method`` (if it accepts the problem and ``when`` holds), whose answer replaces the first one if
    it passes and then reports ``route`` (:class:`~cvxcontact.backends.result.Route` or a backend's own label);
    later load cases of the solver keep ``method``."""

    method: str
    route: str
    when: Callable[[ProblemDescription], bool] = lambda p: True


@dataclass(frozen=True)
class Backend:
    """A registered backend: its ``name`` (the ``method=`` value), what it ``accepts``, what it ``prefers``
    among those (None: all; ``method="auto"`` only), its ``routes``: for each kind of problem it solves
    (:data:`KINDS`: :func:`cvxcontact.backends.run.kind`) the function that solves it, each
    ``route(problem, cache, settings, timings) -> RawResult``, given as the function or as "module:function"
    (a module name relative to this package when it starts with a dot; resolved when first run, so that the
    registry imports nothing), and its ``fallback`` (:class:`Fallback`, None: its answer stands). It solves a
    problem (:meth:`solves`) that it accepts and whose kind it has a route for: ``choose`` refuses the others."""

    name: str
    accepts: Callable[[ProblemDescription], bool]
    summary: str = ""
    prefers: Callable[[ProblemDescription], bool] | None = None
    routes: Mapping[str, str | Callable] = field(default_factory=dict)
    fallback: Fallback | None = None

    def solves(self, problem: ProblemDescription) -> bool:
        """It has a route for the kind of ``problem``'s contact term and accepts ``problem``."""
        return problem.kind in self.routes and self.accepts(problem)


FORCED_KINDS = ("signorini", "conic")
"""The kinds the condensed backend solves with force-controlled obstacles (the translations bordering the
condensed system, :mod:`cvxcontact.backends.forced`): Signorini rows and the P2 cones. The cones' finish there,
Newton at the tangency points on a system of the interface's size, takes a step for convergence only with its
residual at rounding (:data:`~cvxcontact.backends.tangency.ACCEPT_TOL`; before, a step at rounding was taken with
the residual off balance: equilibrium 1.1e-5 under OPENBLAS_CORETYPE=Prescott on tests/scenes.py's
force-controlled punch, which stayed with "full" until then)."""

HELD_KINDS = ("signorini",)
"""The kinds the condensed backend solves with bodies held by the contact only (their rigid motions kept in the
condensed system, :mod:`cvxcontact.backends.forced`). Not yet the P2 cones: on a layer held by the contact under
a uniform pressure (tests/test_p2_supports.py) Newton at the tangency points stops on the condensed system with
its forces off balance by 1e-3 of the load (the cuts before it balance to rounding); "full" takes them."""


FORCED_SLENDER = 2.0
"""``method="auto"`` takes a force-controlled obstacle or a body held by the contact to the condensed route only
while the contact rows m are at most this many times sqrt(N) (N the unknowns); beyond, to "full". Its finishes
solve the mixed system on the interface, whose Sigma blocks are dense (m^3 work a factorisation, by SuperLU):
issue 30's punch on the hand-graded 100 x 50 mesh (m / sqrt(N) = 1.0, 40,602 unknowns) 0.8 s CPU against 10 s
on "full"; on cc.adapt's mesh refined along the contact (529 rows, 13,366 unknowns, m / sqrt(N) = 4.6) 8.2 s against 11.2 s,
at its next step (23,980 unknowns) 48 s against 34 s (benchmarks/results/forced_finish.md). N = 0 (not known):
condensed."""


def _condensed_prefers(p: ProblemDescription) -> bool:
    return not (p.force_control or p.held_by_contact) or p.unknowns == 0 \
        or p.contact_rows <= FORCED_SLENDER * p.unknowns ** 0.5


def _condensable(p: ProblemDescription) -> bool:
    return p.quadratic_energy and p.linear_contact and p.user_terms == 0 and not p.friction


def _condensed_accepts(p: ProblemDescription) -> bool:
    return _condensable(p) and (not p.force_control or p.kind in FORCED_KINDS) \
        and (not p.held_by_contact or p.kind in HELD_KINDS)


def _amg_accepts(p: ProblemDescription) -> bool:
    return _sparse_accepts(p) and not p.dependent_rows


def _full_accepts(p: ProblemDescription) -> bool:
    # a non-quadratic bulk energy: Signorini rows, and the P2 cones alone (their finish: Newton at the tangency
    # points on the nonlinear (26), else the cuts on it, cones.finish_bulk), and a friction law on nodal rows or
    # beside the P2 cones (its finish by damped sequential quadratic steps, frictionsteps.sequential; in 2D then
    # Newton at the tangency points on the nonlinear (26)); not a compliance law (its routes finish on Kuu)
    return p.quadratic_energy or not p.compliant


def _sparse_accepts(p: ProblemDescription) -> bool:
    return _condensable(p) and not p.force_control and not p.held_by_contact and not p.compliant and not p.conic


def _newton_accepts(p: ProblemDescription) -> bool:
    # a non-quadratic energy with Signorini rows or a compliance law on bodies held by their supports (the rest
    # state's tangent is then definite); the steps close the active rows as they are (independent rows)
    return not p.quadratic_energy and p.linear_contact and p.user_terms == 0 and not p.held_by_contact \
        and not p.force_control and not p.friction and not p.conic and not p.dependent_rows


def _amg_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("pyamg") is not None


_REGISTRY: dict[str, Backend] = {b.name: b for b in (
    Backend("amg", _amg_accepts,
            "active-set steps with AMG-preconditioned Krylov solves (large 3D scenes; pyamg; no factorisation)",
            prefers=lambda p: p.dim == 3 and p.unknowns >= AMG_UNKNOWNS and _amg_available(),
            routes=MappingProxyType({"signorini": ".amg:signorini"})),
    Backend("sparse", _sparse_accepts,
            "active-set steps on the sparse mixed system (long interfaces; no dense m x m matrix)",
            prefers=lambda p: not p.dependent_rows and (p.contact_rows > SPARSE_ROWS
                                                         or (p.unknowns > 0 and p.contact_rows > SPARSE_SLENDER
                                                             * p.unknowns ** 0.5)),
            routes=MappingProxyType({"signorini": ".signorini:sparse"})),
    Backend("condensed", _condensed_accepts,
            "exact condensation onto the contact dofs + interface QP + exact finish (fast)",
            prefers=_condensed_prefers,
            routes=MappingProxyType({"signorini": ".signorini:condensed", "compliance": ".compliance:condensed",
                                     "conic": ".cones:condensed", "mixed": ".cones:mixed_condensed"}),
            # an ill-conditioned interface (a slender layer) loses digits in W: the sparse route solves (26) itself
            fallback=Fallback("sparse", Route.SPARSE_FALLBACK, when=lambda p: p.degree == 1)),
    Backend("newton", _newton_accepts,
            "a non-quadratic bulk energy (Hencky): Newton on the nonlinear mixed system with the contact active "
            "set from the elastic predictor, Signorini rows or a compliance law (no interior point; Signorini: the "
            "full route if it does not settle)",
            routes=MappingProxyType({"signorini": ".nonlinear:newton", "compliance": ".nonlinear:compliance"})),
    Backend("full", _full_accepts, "the whole phi-form model in CVXPY (reference; accepts everything with a "
            "quadratic energy, a non-quadratic one with the Signorini law or the P2 cones: Newton or cuts finish)",
            routes=MappingProxyType({"signorini": ".signorini:full", "compliance": ".compliance:full",
                                     "conic": ".cones:full", "mixed": ".cones:mixed_full",
                                     "friction": ".friction:full", "conic_friction": ".friction:conic_full",
                                     "compliance_friction": ".friction:full"})),
)}
"""The registered backends by name, in speed order (fastest first): :func:`register` adds to it."""

REFERENCE = "full"
"""The backend that accepts every problem (the reference): it cannot be replaced or unregistered."""


@dataclass(frozen=True)
class Refusal:
    """A problem no registered backend solves, known by name: :func:`choose` raises
    :class:`~cvxcontact.errors.UnsupportedError` with ``message`` (what is not available, why, what to use instead)
    for a problem of which ``when`` holds, in place of the generic "no backend accepts"."""

    when: Callable[[ProblemDescription], bool]
    message: str


REFUSALS: tuple[Refusal, ...] = ()
"""The refusals :func:`choose` names (docs/refusals.md), each checked only once no registered backend solves the
problem (a backend registered later that solves it lifts it). None is left: row 36, friction beside a non-quadratic
energy under the 3D degree-2 cones, is solved by the full route (:func:`~cvxcontact.backends.friction.conic_full`,
its rounds by :func:`~cvxcontact.backends.frictionsteps.sequential`), as row 35, the 3D P2 copositive cones beside
a non-quadratic energy (:func:`~cvxcontact.backends.cones.finish_bulk`)."""


def _refuse(problem: ProblemDescription) -> None:
    """Raise the :data:`REFUSALS` entry of ``problem``, if any, when no registered backend solves it."""
    if any(b.solves(problem) for b in BACKENDS):
        return
    for refusal in REFUSALS:
        if refusal.when(problem):
            raise UnsupportedError(refusal.message)


class _Live(Sequence):
    """A read-only, always current view of the registry (``items(registry)`` gives its entries)."""

    def __init__(self, items: Callable[[], tuple]):
        self._items = items

    def __getitem__(self, i):
        return self._items()[i]

    def __len__(self) -> int:
        return len(self._items())

    def __eq__(self, other) -> bool:
        return tuple(self) == (tuple(other) if isinstance(other, (tuple, list, _Live)) else other)

    __hash__ = None

    def __repr__(self) -> str:
        return repr(self._items())


KINDS: Sequence[str] = _Live(_kinds)
"""The kinds of contact term a problem poses (:func:`cvxcontact.backends.run.kind`): "signorini", "compliance",
"conic", "mixed", "friction", "compliance_friction", "conic_friction" and those of terms registered from outside
(:func:`cvxcontact.discrete.terms.register_term`); a backend names one route per kind it solves. A live view."""

BACKENDS: Sequence[Backend] = _Live(lambda: tuple(_REGISTRY.values()))
"""The backends in speed order, fastest first (the sparse route where it prefers the problem: long interfaces);
a live view of the registry (:func:`register`)."""

DEFAULT_METHOD = "auto"
"""The default ``method=``: the fastest backend that accepts the problem."""

METHODS: Sequence[str] = _Live(lambda: (DEFAULT_METHOD,) + tuple(_REGISTRY))
"""Backend names accepted by :func:`cvxcontact.solve` (``method=``); a live view of the registry."""


def backend(name: str) -> Backend:
    """The registered backend ``name``; SolverError naming the registered ones otherwise."""
    if not isinstance(name, str) or name not in _REGISTRY:
        raise SolverError(f"method must be one of {tuple(METHODS)}, got {name!r}")
    return _REGISTRY[name]


def register(entry: Backend, *, before: str | None = None, replace: bool = False) -> Backend:
    """Register the backend ``entry`` so that ``cc.solve(scene, method=entry.name)`` runs it (docs/howto/extending.md).

    ``before``: the registered backend it goes before in the speed order that ``method="auto"`` walks (None:
    last, after the reference "full" that accepts every problem, so that ``auto`` never picks it and only
    ``method=entry.name`` runs it). ``replace``: allow re-registering a name (not "full"). Returns ``entry``.
    Raises :class:`~cvxcontact.errors.SolverError` naming what is missing or wrong (a name, a callable
    ``accepts``/``prefers``, a route per kind of :data:`KINDS` given as a function or "module:function", a
    fallback to a registered backend).
    """
    if not isinstance(entry, Backend):
        raise SolverError(f"register takes a cvxcontact.backends.Backend(name, accepts, routes=...), got "
                          f"{type(entry).__name__}")
    name = entry.name
    if not isinstance(name, str) or not name.isidentifier():
        raise SolverError(f"Backend.name must be an identifier (the method= value), got {name!r}")
    if name == DEFAULT_METHOD or name == REFERENCE or (name in _REGISTRY and not replace):
        raise SolverError(f"a backend named {name!r} is already registered or reserved; choose another name"
                          + ("" if name in (DEFAULT_METHOD, REFERENCE) else " or pass replace=True"))
    for what in ("accepts", "prefers"):
        f = getattr(entry, what)
        if not callable(f) and not (what == "prefers" and f is None):
            raise SolverError(f"Backend {name!r}: {what} must be a function of a ProblemDescription returning "
                              f"bool, got {f!r}")
    routes = dict(entry.routes) if isinstance(entry.routes, Mapping) else None
    if not routes:
        raise SolverError(f"Backend {name!r}: routes must map at least one kind of {tuple(KINDS)} to its function "
                          f"route(problem, cache, settings, timings) -> RawResult, got {entry.routes!r}")
    for kind_, where in routes.items():
        if kind_ not in KINDS:
            raise SolverError(f"Backend {name!r}: unknown kind {kind_!r} in routes; the kinds are {tuple(KINDS)}")
        if not (callable(where) or (isinstance(where, str) and where.count(":") == 1 and all(where.split(":")))):
            raise SolverError(f"Backend {name!r}: the {kind_} route must be a function or 'module:function', "
                              f"got {where!r}")
    if entry.fallback is not None and (not isinstance(entry.fallback, Fallback)
                                       or entry.fallback.method not in _REGISTRY or entry.fallback.method == name):
        raise SolverError(f"Backend {name!r}: fallback must be a Fallback(method, route) naming another registered "
                          f"backend {tuple(_REGISTRY)}, got {entry.fallback!r}")
    if before is not None and (before not in _REGISTRY or before == name):
        raise SolverError(f"register(before=...) must name another registered backend {tuple(_REGISTRY)}, "
                          f"got {before!r}")
    entries = [b for b in _REGISTRY.values() if b.name != name]
    at = len(entries) if before is None else next(i for i, b in enumerate(entries) if b.name == before)
    entries.insert(at, entry)
    _REGISTRY.clear()
    _REGISTRY.update((b.name, b) for b in entries)
    return entry


def unregister(name: str) -> Backend:
    """Remove the registered backend ``name`` (not the reference "full", nor one another backend falls back to);
    returns its entry."""
    entry = backend(name)
    users = [b.name for b in _REGISTRY.values() if b.fallback is not None and b.fallback.method == name]
    if name == REFERENCE or users:
        raise SolverError(f"backend {name!r} cannot be unregistered: "
                          + ("it is the reference that accepts every problem" if name == REFERENCE
                             else f"{users} fall back to it"))
    return _REGISTRY.pop(name)


def choose(method: str, problem: ProblemDescription | None = None) -> str:
    """The backend to run for ``method`` on ``problem`` (default: the package's own problem).

    ``"auto"`` gives the first backend of :data:`BACKENDS` that accepts and prefers ``problem``; a named
    backend is returned if it accepts it. Raises :class:`~cvxcontact.errors.UnsupportedError` for a problem no
    backend solves that :data:`REFUSALS` names, :class:`~cvxcontact.errors.SolverError` for an unknown name or a
    backend that does not accept the problem.
    """
    problem = ProblemDescription() if problem is None else problem
    if method == DEFAULT_METHOD:
        for b in BACKENDS:
            if b.solves(problem) and (b.prefers is None or b.prefers(problem)):
                return b.name
        _refuse(problem)
        raise SolverError(f"no backend accepts {problem}; backends: {[b.name for b in BACKENDS]}")
    if not backend(method).solves(problem):
        _refuse(problem)
        raise SolverError(f"method {method!r} does not accept {problem}; use method='auto' or 'full'")
    return method
