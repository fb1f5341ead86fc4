"""What a backend returns: one :class:`RawResult` per solve, with the routes and statuses as constants.

The constants are :class:`enum.StrEnum` members, so they compare equal to plain strings
(``Status.OPTIMAL == "optimal" == cvxpy.OPTIMAL``, ``Route.WARM_START == "active-set warm start"``) and
serialise to JSON as those strings; :class:`~cvxcontact.solution.info.SolveInfo` reports them.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import astuple, dataclass, field
from enum import StrEnum

import numpy as np

from .finish.declined import Declined

__all__ = ["Status", "Route", "Finish", "RawResult", "Settings", "Cache", "INTERIOR_POINT_KEPT", "declined_words",
           "load_key"]


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
    bonded system (3D: from the rows the obstacles already close), no convex program (``iterations``: the
    systems solved)."""
    INTERIOR_POINT_FRICTION = "interior point (no exact finish: friction)"
    """A friction law (:mod:`cvxcontact.backends.friction`): the full program's interior-point answer at the
    conic tolerances, checked (the friction cone, stick/slip complementarity, slip direction), where its exact
    finish (:attr:`Finish.FRICTION_NEWTON`) did not run (``polish=False``) or was declined."""
    INTERIOR_POINT_NONLINEAR = "interior point (no exact finish: non-linear user terms)"
    """A :class:`~cvxcontact.Model` with non-linear user terms: the interior-point answer, checked."""
    INTERIOR_POINT_NONLINEAR_ENERGY = "interior point (no exact finish: a non-quadratic bulk energy)"
    """A material with a non-quadratic energy (e.g. :func:`cvxcontact.materials.hencky`) whose Newton finish
    (:attr:`Finish.NEWTON_BULK`) did not run (``polish=False``) or was declined (rows that may be linearly
    dependent, or steps that did not settle; ``SolveInfo.declined`` says which): the full program's
    interior-point answer, checked with the nonlinear internal forces."""
    NEWTON_DIRECT = "Newton on the nonlinear mixed system, no interior point"
    """A non-quadratic bulk energy (method "newton", :mod:`cvxcontact.backends.nonlinear`): Newton on (26) with the
    contact active set (:attr:`Finish.NEWTON_BULK`) from the elastic predictor (a re-solve: the previous answer);
    ``iterations`` counts the Newton steps."""
    NEWTON_FELL_BACK = "Newton without an interior point did not settle -> interior point + Newton finish"
    """Method "newton": its Newton steps did not settle (a revisited active set, a singular
    step, a stall); the full route (the interior point, then the Newton finish) answered instead."""
    NO_CONTACT = "no contact at zero force: the unconstrained solution"
    """The conic P2 condition (condensed): the bodies' unconstrained solution already satisfies it on every
    merged segment, so it is the solution, exactly (forces 0), and no program is solved."""
    KRYLOV_ACTIVE_SET = "active-set steps, AMG-preconditioned Krylov solves"
    """The AMG route (method "amg", :mod:`cvxcontact.backends.amg`): the sparse route's active-set steps with
    each system solved by AMG-preconditioned CG/MINRES to a relative residual 1e-10, no factorisation."""
    SPARSE_HANDED_OVER = "sparse active-set steps did not settle -> condensed"
    """The sparse route (method "sparse", or ``auto`` choosing it): its steps did not settle (a cycle, a singular
    system in every attempt, :meth:`~cvxcontact.backends.sparse.SparseContact.solve`) on an interface of at most
    :data:`~cvxcontact.backends.SPARSE_ROWS` rows; the condensed route (interior point + exact finish) answered
    instead, its answer checked as any (``SolveInfo.method`` "condensed")."""
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
    ACCUMULATED_CUTS = "accumulated cuts"
    """The P2 "everywhere" condition: the nodal problem at a growing set of points of every merged segment
    (:mod:`cvxcontact.backends.cuts`)."""
    TANGENCY_NEWTON = "tangency Newton"
    """The P2 "everywhere" condition touching inside elements: Newton on the KKT system of each touching
    element's maximum (:mod:`cvxcontact.backends.tangency`)."""
    INDEPENDENT_ACTIVE_SET = "independent active set"
    """Linearly dependent rows (3D "gamma3"): Lawson-Hanson on the sparse mixed system, the rows carrying the
    forces kept independent (:func:`cvxcontact.backends.finish.independent_active_set`)."""
    NEWTON_BULK = "Newton on the nonlinear mixed system with the contact active set"
    """A non-quadratic bulk energy (the paper's nonlinear A, e.g. Hencky) with Signorini rows: semismooth Newton
    steps on (26) with the energy's tangent, damped on the energy, inside primal-dual active-set steps on the
    contact rows, from the interior point's answer
    (:func:`cvxcontact.backends.finish.solve_sparse_compliance`)."""
    FRICTION_NEWTON = "semismooth Newton on the friction rows' active set"
    """A friction law (Tresca, Coulomb): semismooth Newton on (26)-(27) with the friction rows in the
    Alart-Curnier form, from the interior point's answer (:func:`cvxcontact.backends.finish.friction.
    solve_friction`; docs/howto/friction.md, "The exact finish")."""
    NEWTON_INDEPENDENT = "semismooth Newton on independent active sets"
    """Linearly dependent rows with a condition r <= l next to a compliance law (3D "gamma3"): Newton steps on
    the law, each an independent active set of the linearised mixed system
    (:func:`cvxcontact.backends.compliance.dependent_newton`)."""


@dataclass(frozen=True)
class Settings:
    """How to run a backend: the CVXPY ``solver`` and its ``options`` (checked), ``verbose``, ``polish`` (the
    exact finish), ``warm_start`` (re-solves from the previous active set), ``factorization`` (the adapter of
    :mod:`cvxcontact.backends.factor`)."""

    solver: str = "CLARABEL"
    options: Mapping[str, object] = field(default_factory=dict)
    verbose: bool = False
    polish: bool = True
    warm_start: bool = True
    factorization: str = "auto"


INTERIOR_POINT_KEPT = "interior-point answer"
"""What a declined finish keeps unless its caller names another answer (:attr:`RawResult.kept`)."""


@dataclass(eq=False)
class RawResult:
    """What one backend solve returns, scaled (docs/formulation.md §6), read back once into a Solution.

    ``u``, ``phi``: each body's free unknowns; ``y``: the force on every contact row (nodal rows: their
    multipliers; compliance: w p(r) + z; cones: the nodal force B^T beta on X_h); ``active``: the closed
    nodal rows (Signorini) or None; ``z``: the limit reactions of a compliance law (None: no row has a
    limit); ``beta``: the Bernstein duals (S, 3) of the cones or None; ``taus``: the translations of the
    force-controlled obstacles; ``polished``: the arrays are an exact finish; ``program``: the CVXPY problem
    solved (None: no program); ``route``, ``finish``, ``iterations``, ``declined`` (why a finish was
    declined: a :class:`~cvxcontact.backends.finish.declined.Declined`, None if none was), ``method`` (the backend that ran), ``factorization``: as reported in SolveInfo; ``certificate``: the conic condition's
    energy-norm error bound (below)."""

    u: list
    phi: list
    y: np.ndarray
    active: np.ndarray | None = None
    z: np.ndarray | None = None
    beta: np.ndarray | None = None
    taus: list = field(default_factory=list)
    polished: bool = False
    program: object = None
    route: str = Route.INTERIOR_POINT
    finish: str | None = None
    iterations: int = 0
    declined: Declined | None = None
    method: str = ""
    factorization: str = ""
    released: bool = False
    """The condensation freed some body's factors and re-made them for the sweeps (SolveInfo.released)."""
    tangential: np.ndarray | None = None
    """A friction law: the tangential force mu_a of every row (scaled; the force on the pair's first body along
    its tangent is -mu_a, :mod:`cvxcontact.backends.friction`), None without friction."""
    capacity: np.ndarray | None = None
    """A friction law: the capacity c_a = g_a w_a of every row the answer was solved with (scaled; Coulomb: the
    last iterate's mu y_a), None without friction."""
    status: str | None = None
    """The solver status of the iterate the arrays are (None: ``program``'s own, its last solve; Coulomb's answer
    is the fixed point's iterate of smallest change, not necessarily its last)."""
    fixed_point: tuple | None = None
    """Coulomb friction: the relative change of the capacities at each iteration of the fixed point
    (:mod:`cvxcontact.backends.friction`), None for a given threshold or without friction."""
    certificate: float | None = None
    """The P2 "everywhere" condition: a rigorous bound on the energy-norm error of the displacements (scaled;
    :func:`cvxcontact.backends.cuts.energy_bound`), None where none was computed."""
    points: tuple | None = None
    """The cuts' answer as point forces (:mod:`cvxcontact.backends.cuts`): (element, t, y) of every cut point (y
    scaled), None from every other finish (what :func:`~cvxcontact.backends.start.contact_state` reads)."""
    pairing: np.ndarray | None = None
    """Against a curved obstacle's true gap (docs/formulation.md §8, "Rigid obstacles"): per element, the
    finish's point forces' sum y_p delta(x_p) (scaled), so that their pairing with the true slack is
    beta . b - pairing; None where the answer's duals are no such point forces (or there is no departure)."""
    handed_over: str = ""
    """Where the route asked for handed the problem to another (:attr:`Route.SPARSE_HANDED_OVER`, the AMG route's
    hand-over to the sparse route), why, in words (the reasons of each hand-over in turn, "; "-joined); "" where
    none did (SolveInfo.handed_over)."""
    kept: str = INTERIOR_POINT_KEPT
    """Where a finish was declined (``declined``), what the arrays are, in the words of the warning
    (:func:`declined_words`): the interior point's answer, or the answer the caller that labels the decline keeps
    and names (the cut rounds' answer where the polish at the tangency points declined,
    :func:`~cvxcontact.backends.frictiontangency.kept`)."""


def declined_words(subject: str, condition, raw: RawResult) -> str:
    """The words of the :class:`~cvxcontact.errors.ResidualWarning` of a declined exact finish (``cc.solve`` and
    ``cc.Model``): ``subject`` (the scene, or the user model of a scene) under ``condition``, why
    (``raw.declined``) and what is kept (``raw.kept``)."""
    return (f"the exact finish of {subject} ({condition}) was declined ({raw.declined}); the {raw.kept} is kept "
            "(sol.polished is False)")


class Cache:
    """What a backend keeps between solves of one geometry (per ContactSolver): the condensation onto the
    contact unknowns (:class:`~cvxcontact.backends.interface.Condensation`), the sparse factorisation, the AMG
    hierarchy and the last exact active set (warm starts); ``own``: a dict for what any other backend keeps
    (keyed by its name, say). :meth:`matching` empties all of it when the contact rows change (a moved obstacle
    reaching other nodes)."""

    def __init__(self):
        self.key = None
        self.start = None
        """A :class:`~cvxcontact.backends.start.ContactState` of a solution on another mesh, the first solve's
        warm start (``ContactSolver(start=...)``); kept when the rest is cleared, emptied after that solve."""
        self.clear()

    def clear(self):
        self.condensation = self.sparse = self.amg = self.active = None
        self.own: dict = {}

    def prepare(self, problems) -> bool:
        """Hand the coming load cases ``problems`` to what is kept for their contact rows: the condensation
        batches their forward sweeps (:meth:`~cvxcontact.backends.interface.Condensation.prepare`; those on other
        rows are left out). Whether a condensation was kept (none before the first solve of a condensed route)."""
        if self.condensation is None:
            return False
        self.condensation.prepare([p for p in problems if p.lines.key() == self.key])
        return True

    def matching(self, key) -> "Cache":
        """This cache, emptied first if it was filled for other contact rows than ``key``."""
        if key != self.key:
            self.clear()
            self.key = key
        return self


def load_key(problem) -> bytes:
    """A digest of what a load case sets in a prepared geometry's scaled problem: every block's loads (f, q) and
    the public arrays of its bulk energy (a non-quadratic one reads the prescribed displacements there: e0, d), the
    gaps, the force-controlled obstacles' rows and forces and the units. Two problems of one geometry (one
    contact-row key, :meth:`Cache.matching`) with the same key pose the same question bit for bit: what lets a
    route that starts a new load from the previous answer (not exact: the answer then carries that start's
    rounding) answer a repeated load with the bits it gave it (docs/explanation/known-behaviour.md, "Same question, same bits")."""
    digest = hashlib.sha256(repr(astuple(problem.units)).encode())

    def add(a):
        a = np.ascontiguousarray(a)
        digest.update(repr((a.dtype.str, a.shape)).encode())
        digest.update(a.tobytes())

    for b in problem.blocks:
        bulk = sorted(getattr(b.bulk, "__dict__", {}).items())          # (its own arrays; not what it caches)
        for a in (b.f, b.q, *(v for k, v in bulk if not k.startswith("_") and isinstance(v, np.ndarray))):
            add(np.zeros(0) if a is None else a)
    add(problem.g)
    for R, F in problem.translations:
        add(R.toarray() if hasattr(R, "toarray") else R)
        add(np.asarray(F, dtype=float))
    return digest.digest()
