"""The contact term of a discrete problem: what its law poses and does in a solve (docs/architecture.md, "A new
contact law"; issue 31, "Seams").

A :class:`ContactTerm` is built once with the :class:`~cvxcontact.discrete.DiscreteProblem` (``problem.term``)
from its contact lines, the first term of :data:`TERMS` that poses them. The backends, the read-back, the solve
and ``cc.Model`` call its methods instead of branching on its kind:

- ``term.program(problem)``: its rows or cones in the full convex program, a
  :class:`~cvxcontact.backends.full.ContactModel` (``.problem``, ``.u``, ``.phi``, ``.t``, and the contact
  constraints whose duals are its forces); ``term.program_forces(problem, model, u, taus) -> (y, z, beta)``: those
  forces read from the solved program (the rows no unknown moves at their least admissible force);
- ``term.read_back(problem, raw, tol, timings) -> Solution``: lambda_h in SI and the checks of its law (each
  read-back computes the checks of (26)-(27) that apply: nodal, compliance, conic; docs/checks.md);
- ``term.finish_declined(problem, raw, polish) -> bool``: an exact finish of its law applies and did not run (a
  :class:`~cvxcontact.errors.ResidualWarning`). Which finish runs is the backend's route for the term's ``kind``
  (each backend declares the kinds it solves in ``routes``, :data:`cvxcontact.backends.KINDS`; one that has no
  route for the kind refuses the problem with a SolverError), since a finish works on that backend's matrices;
- around a route (:func:`cvxcontact.backends.run.run`): ``term.start(problem, cache)`` sets the first active-set
  guess from another mesh's state (``takes_active_start``); ``term.determining_rows(problem, raw)`` the rows the
  well-posedness check after the solve reads (the route's active set; a compliance law's, the rows that carry a
  force where the route gives none); ``term.held_forces(problem, y)`` the forces the answer reports (Signorini
  rows no unknown moves at 0, their least admissible value: docs/formulation.md §8, "Held nodes");
- after it: ``term.hands_on(raw)``, whether the answer hands a state on to a solve on another mesh
  (:func:`~cvxcontact.backends.start.contact_state`; an exact finish of a term with ``hands_on_state``).

Where the methods' work lives: discrete/ sits below backends/ and solution/ in the layers (tests/test_layers.py),
so a term names its functions as "module:function" (or gives the function itself, for a term from outside the
package), resolved on first call (:func:`named`, the pattern of a backend's ``routes``,
:func:`cvxcontact.backends.run.route`): the import order stays one way, and each law's program, forces and
read-back stay beside the code of their layer (backends/full.py, backends/cones.py, solution/nodal.py,
solution/readback.py). A new law adds one class here (its names and answers, the combination of laws it poses,
``parts``, from :data:`PARTS`, or its own ``poses(lines)``), an entry of :data:`TERMS` (:func:`register_term` from
outside), its functions, and a route for its kind in each backend that solves it; nothing else branches on it. A
combination of laws is a term too: which combinations are posed is what the terms declare (a combination none
declares is refused by :func:`contact_term`), and what the combination needs beyond its program is the term's
(its read-back, its finish by its backends' routes, ``beside_user_terms`` for ``cc.Model``'s user terms).

The answers a backend or the solve still asks as data (what :class:`~cvxcontact.backends.ProblemDescription`
tells a backend, and the solve's bookkeeping):

- ``kind``: the key of its route in a backend's ``routes``;
- ``compliant``, ``cones``, ``tangential``: a normal-compliance law on some rows; the P2 "everywhere" cones in
  its program (docs/formulation.md §8, §10); a friction law's tangential part;
- ``takes_active_start``: a state from another mesh gives the first active-set guess
  (:func:`~cvxcontact.backends.start.start_active`, ``term.start``); ``hands_on_state``: its exact finish's forces
  can start a solve on another mesh (:func:`~cvxcontact.backends.start.contact_state`);
- ``zeroes_held_forces``, ``active_from_forces``: what ``term.held_forces`` and ``term.determining_rows`` do
  (read by no one outside this module: the methods decide);
- ``finishes``: an exact finish exists whose decline is reported; ``always_finished``: it runs on every problem
  with a quadratic energy (the cones' cuts only on problems they can condense);
- ``rows_may_depend``: its evaluation rows are rows whose linear dependence a route must handle (the cones'
  E is the identity on X_h);
- ``estimated``: the a posteriori error estimates count its forces (else ``unestimated`` says why, in the
  solution's ``estimate_reason``); ``takes_user_terms``: ``cc.Model`` poses user terms beside it (else
  ``refuses_user_terms`` is the refusal's message); ``unfinished_hint``: what the solve's warning adds where its
  interior-point answer fails the checks (the cones: how far an interior point stops).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp

from ..contact.laws import RowLaws
from ..contact.quadratic import ConeRowLaws
from ..errors import SolverError, UnsupportedError
from .slip import Slip

__all__ = ["PARTS", "UNPOSED", "ContactTerm", "SignoriniRows", "ComplianceRows", "EverywhereCones",
           "ConesBesideCompliance", "TrescaFriction", "FrictionBesideCompliance", "ConesWithFriction", "TERMS",
           "contact_term", "parts_of", "register_term", "unregister_term", "named", "cones_on_rows",
           "cones_beside_law"]


def named(where: str | Callable) -> Callable:
    """The function a term names: ``where`` itself if callable, else the "module:function" (an absolute module
    name) imported on first call; SolverError if it does not import."""
    if callable(where):
        return where
    module, _, name = where.partition(":")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError, ValueError) as exc:
        raise SolverError(f"the contact term's function {where!r} does not import ({exc}); name the function "
                          f"itself or an importable 'module:function'") from exc


PARTS = {
    "cones": lambda lines: lines.conic or lines.mixed,
    "compliance": lambda lines: lines.rows.compliant,
    "friction": lambda lines: lines.rows.friction,
}
"""The laws a problem's contact lines may combine, each with its test on the lines
(:class:`~cvxcontact.fem.space.ContactLines`): the P2 "gamma3" cones (docs/formulation.md §8; beside a compliance
law too, §10), a normal-compliance law on some rows (§10), a friction law on some rows (docs/howto/friction.md).
Signorini's nodal rows are the empty combination. A term declares the combination it poses (``parts``)."""


UNPOSED = {
    frozenset({"cones", "compliance", "friction"}): (
        "a friction law with P2 elements under 'gamma3' (the conic condition: cones on every element of X_h, the "
        "friction rows at its nodes and at the rows of the pairs under a nodal condition) is not available beside a "
        "normal-compliance law: pose every pair under a Signorini law (the default), or use condition='sigma1' or "
        "'sigma2' (nodal rows at the P2 nodes of that body's faces), or degree=1 with 'gamma3' (P1: the condition "
        "everywhere is its nodal rows)"),
}
"""What to do where the lines combine laws no term declares (:func:`contact_term`'s refusal; docs/refusals.md
row 32: friction under the P2 cones beside a compliance law); a combination without words here is refused by
name."""


def parts_of(lines) -> frozenset[str]:
    """The combination of laws (:data:`PARTS`) the contact lines ``lines`` pose."""
    return frozenset(name for name, test in PARTS.items() if test(lines))


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
    unestimated: str
    refuses_user_terms: str
    unfinished_hint: str

    @property
    def estimated(self) -> bool: ...

    @property
    def takes_user_terms(self) -> bool: ...

    @property
    def takes_active_start(self) -> bool: ...

    def program(self, problem): ...

    def program_forces(self, problem, model, u, taus) -> tuple: ...

    def with_user_terms(self, problem, model, constraints, objective, settings, timings, admits): ...

    def read_back(self, problem, raw, tol: float, timings: dict): ...

    def finish_declined(self, problem, raw, polish: bool) -> bool: ...

    def start(self, problem, cache) -> None: ...

    def determining_rows(self, problem, raw): ...

    def held_forces(self, problem, y): ...

    def hands_on(self, raw) -> bool: ...

    def with_data(self, scene, condition: str, lines, systems, units): ...

    def own_lines(self, lines): ...

    def kernel_capacity(self): ...

    def normal_rows(self, problem, energy, G, g): ...


@dataclass(frozen=True)
class _Term:
    """The answers every term shares unless it says otherwise; ``dim`` the space's displacement components, ``data``
    what it holds beside the problem (:meth:`with_data`)."""

    dim: int
    data: object = field(default=None, compare=False, repr=False)
    kind: ClassVar[str] = ""
    compliant: ClassVar[bool] = False
    cones: ClassVar[bool] = False
    tangential: ClassVar[bool] = False
    zeroes_held_forces: ClassVar[bool] = False
    active_from_forces: ClassVar[bool] = False
    finishes: ClassVar[bool] = True
    always_finished: ClassVar[bool] = True
    rows_may_depend: ClassVar[bool] = True
    unestimated: ClassVar[str] = ""
    """Why the a posteriori error estimates do not cover this term ("" where they do)."""
    refuses_user_terms: ClassVar[str] = ""
    """The message refusing ``cc.Model`` user terms beside this term ("" where it takes them)."""
    unfinished_hint: ClassVar[str] = ""
    """Added to the solve's warning where its interior-point answer (no exact finish) fails the checks."""
    _starts: ClassVar[tuple[int, ...]] = ()   # dims where another mesh's state gives its first active-set guess
    _states: ClassVar[tuple[int, ...]] = ()   # dims where its exact finish's forces are point loads on the pairs
    programs: ClassVar[str | Callable] = "cvxcontact.backends.full:signorini_program"
    """``(problem) -> ContactModel``: its rows or cones in the full convex program (scaled)."""
    forces: ClassVar[str | Callable] = "cvxcontact.backends.full:signorini_forces"
    """``(problem, model, u, taus) -> (y, z, beta)``: its forces from the solved program's duals (scaled)."""
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.nodal:read_back_nodal"
    """``(problem, raw, tol, timings) -> Solution``: lambda_h in SI and the checks of its law."""
    starts: ClassVar[str | Callable] = "cvxcontact.backends.start:start_active"
    """``(problem, state) -> bool per row``: the first active-set guess from a state on another mesh."""
    parts: ClassVar[frozenset[str]] = frozenset()
    """The laws it poses together (:data:`PARTS`): the term poses the contact lines whose :func:`parts_of` are
    these (:meth:`poses`); a combination no registered term declares is refused by name (:func:`contact_term`)."""
    beside_user_terms: ClassVar[str | Callable | None] = None
    """``(problem, model, constraints, objective, settings, timings, admits) -> (raw, force)``: how ``cc.Model``
    solves this term's program beside its user terms, where :meth:`program` is not the whole of it (a friction
    law's slip cones; :meth:`with_user_terms`); None: ``cc.Model`` poses them on :meth:`program` and finishes
    them itself (its active-set finish of the nodal rows and the user rows)."""
    builds: ClassVar[str | Callable | None] = None
    """``(scene, condition, lines, systems, units) -> data``: what the term holds beside the problem, built with it
    (:meth:`with_data`; a friction law's :class:`~cvxcontact.discrete.slip.Slip`, what its routes, finish and
    read-back read); None: nothing."""
    asks: ClassVar[str | Callable | None] = None
    """``(lines) -> lines``: the contact lines its combination of laws poses, from those the space poses
    (:meth:`own_lines`), asking the space's elements for what it needs beyond them (``lines.element``,
    :class:`~cvxcontact.contact.quadratic.ConditionRows`: a friction law under the cones, :func:`cones_on_rows`; the
    cones beside a compliance law, :func:`cones_beside_law`); None: the space's lines as they are."""
    finish_rows: ClassVar[str | Callable] = "cvxcontact.backends.frictionrows:NormalRows"
    """``(problem, energy, G, g) -> rows``: how its laws pose the normal rows G x <= g of the friction finish beside
    the energy (:meth:`normal_rows`): Signorini's as they are
    (:class:`~cvxcontact.backends.frictionrows.NormalRows`), a compliance law's energy added and its rows of a finite
    limit kept (:class:`~cvxcontact.backends.frictionrows.LawRows`)."""

    @classmethod
    def poses(cls, lines) -> bool:
        """Whether this term poses the contact lines ``lines``: their parts (:func:`parts_of`) are its
        :attr:`parts`."""
        return parts_of(lines) == cls.parts

    def program(self, problem):
        """The full convex program of ``problem`` with this term's rows or cones (:attr:`programs`)."""
        return named(type(self).programs)(problem)      # (from the class: a plain function stays unbound)

    def program_forces(self, problem, model, u, taus) -> tuple:
        """(y, z, beta) of the solved ``model`` (:meth:`program`; ``u``, ``taus`` its values): the row forces, the
        limit reactions (None without) and the Bernstein duals (None without cones), scaled (:attr:`forces`)."""
        return named(type(self).forces)(problem, model, u, taus)

    def read_back(self, problem, raw, tol: float, timings: dict):
        """The :class:`~cvxcontact.solution.Solution` of a backend's ``raw`` answer on ``problem``, checked at
        ``tol`` (:attr:`reads_back`)."""
        return named(type(self).reads_back)(problem, raw, tol, timings)

    def finish_declined(self, problem, raw, polish: bool) -> bool:
        """An exact finish of this law applies to ``problem`` (``polish`` asked for it) and ``raw`` is not finished:
        declined by the route, or not run where it always runs (a quadratic energy)."""
        return bool(polish and not raw.polished and self.finishes
                    and (raw.declined or (problem.quadratic and self.always_finished)))

    def with_user_terms(self, problem, model, constraints, objective, settings, timings, admits):
        """``cc.Model``'s answer with user terms where this term declares how (:attr:`beside_user_terms`):
        ``(raw, force)``, the scaled :class:`~cvxcontact.backends.result.RawResult` of ``model`` (its
        :meth:`program`, whose variables the user ``constraints`` and ``objective`` (scaled) are built on) and
        the generalised force the term adds to the momentum rows beyond E^T y (on the model's stacked unknowns;
        None: none), solved with ``settings`` (a :class:`~cvxcontact.backends.result.Settings`); ``admits(raw)``
        says whether an answer finished without the user rows satisfies them (then it is the program's with
        them, their multipliers 0). None where the term declares nothing (``cc.Model``'s own path)."""
        where = type(self).beside_user_terms
        if where is None:
            return None
        return named(where)(problem, model, constraints, objective, settings, timings, admits)

    def with_data(self, scene, condition: str, lines, systems, units):
        """This term holding its data for the problem of ``scene`` under ``condition`` (its contact ``lines``, the
        bodies' assembled ``systems``, the ``units``; :attr:`builds`), itself where it holds none."""
        where = type(self).builds
        if where is None:
            return self
        return replace(self, data=named(where)(scene, condition, lines, systems, units))

    def own_lines(self, lines):
        """The contact lines this term's laws pose, from the space's ``lines`` (:attr:`asks`; the problem holds
        these, built once with it before its data, :meth:`with_data`)."""
        where = type(self).asks
        return lines if where is None else named(where)(lines)

    def kernel_capacity(self):
        """What the well-posedness check before the solve reads of the term's law beside the supports and the rows
        (:func:`~cvxcontact.fem.kernel.check_well_posed`'s ``capacity``: a friction law's, its data's
        ``kernel_capacity()``); None: nothing."""
        hold = getattr(self.data, "kernel_capacity", None)
        return None if hold is None else hold()

    def normal_rows(self, problem, energy, G, g):
        """The normal rows of the friction finish of ``problem`` beside the mixed ``energy`` (G x <= g) as the
        term's laws pose them (:attr:`finish_rows`)."""
        return named(type(self).finish_rows)(problem, energy, G, g)

    def start(self, problem, cache) -> None:
        """Before a route runs: a state from another mesh in ``cache`` (``cache.start``) and no active set gives
        ``cache.active``, the first active-set guess of the rows (:attr:`starts`), where this term takes one
        (:attr:`takes_active_start`)."""
        if cache.start is not None and cache.active is None and self.takes_active_start:
            cache.active = named(type(self).starts)(problem, cache.start)

    def determining_rows(self, problem, raw):
        """The rows whose hold on the bodies the check after the solve reads for ``raw`` (bool per row, or None):
        the route's active set (:func:`~cvxcontact.fem.kernel.check_determined`; a finish's decline may name
        others, :func:`~cvxcontact.backends.finish.declined.rows_to_check`); with :attr:`active_from_forces`, where
        the route has none, the rows that carry a force (a law's force holds a body where it presses, whatever the
        route calls active)."""
        if not self.active_from_forces or raw.active is not None or raw.y is None:
            return raw.active
        y = np.asarray(raw.y, dtype=float)
        return y > 1e-12 * max(float(np.abs(y).max(initial=0.0)), np.finfo(float).tiny)

    def held_forces(self, problem, y):
        """The forces ``y`` of every row as the answer reports them (scaled); with :attr:`zeroes_held_forces`, the
        rows no unknown moves at 0, their least admissible value (docs/formulation.md §8, "Held nodes": (26)-(27)
        do not determine them)."""
        return np.where(problem.held_rows, 0.0, y) if self.zeroes_held_forces else y

    def hands_on(self, raw) -> bool:
        """Whether the answer ``raw`` hands on a state to a solve on another mesh
        (:func:`~cvxcontact.backends.start.contact_state`): an exact finish (``raw.polished``, with its forces
        ``raw.y``) of a term whose finish's forces are point loads on the pairs (:attr:`hands_on_state`: Signorini
        rows, the 2D cones)."""
        return bool(self.hands_on_state and raw.polished and raw.y is not None)

    @property
    def estimated(self) -> bool:
        """The a posteriori error estimates count its forces (:attr:`unestimated` is empty)."""
        return not self.unestimated

    @property
    def takes_user_terms(self) -> bool:
        """``cc.Model`` poses user terms beside it (:attr:`refuses_user_terms` is empty)."""
        return not self.refuses_user_terms

    @property
    def takes_active_start(self) -> bool:
        """A state from another mesh gives the first active-set guess (the rows' positions on the pairs)."""
        return self.dim in self._starts

    @property
    def hands_on_state(self) -> bool:
        """Its exact finish's forces, as point loads on the pairs, can start a solve on another mesh."""
        return self.dim in self._states


def _element(lines, who: str):
    """The elements' answers of ``lines`` (``lines.element``); SolverError naming ``who`` asks where the space
    gives none."""
    if getattr(lines, "element", None) is None:
        raise SolverError(f"{who} asks the space's elements for its rows (ContactLines.element, a "
                          "cvxcontact.contact.quadratic.ConditionRows) and the space's contact lines give none: "
                          "build them with a P2 space (fem.space.P2, P2Tet) or give the space's lines an element")
    return lines.element


def cones_on_rows(lines):
    """The contact ``lines`` of a friction law under the P2 "gamma3" cones (:class:`ConesWithFriction`): its rows are
    the rows of E (the nodes of X_h on the "gamma3" pairs, each nodal pair's own rows, each with its own weight), so
    the cones sit on them (``cone``: each nodal row a degenerate element,
    :meth:`~cvxcontact.contact.quadratic.QuadraticStack.row_cone`; the friction rows and the normal rows are then one
    set) and the space's cones on the nodes of X_h become ``node_cone`` (None where E is the identity: every pair's
    rows are its nodes). From the space's lines (the cones on the nodes of X_h, ``cone_on_nodes``: so lines it
    answered already give themselves again) and its elements' answers (``lines.element``); docs/howto/friction.md,
    "P2 under 'gamma3'"."""
    element = _element(lines, "a friction law under the P2 'gamma3' cones")
    E = element.evaluation()
    identity = E.shape[0] == E.shape[1] and (E - sp.identity(E.shape[0])).count_nonzero() == 0
    return replace(lines, E=E, cone=element.row_cone(), node_cone=None if identity else lines.cone_on_nodes,
                   rows=RowLaws(lines.rows.laws, element.row_counts()))


def cones_beside_law(lines):
    """The contact ``lines`` of the P2 cones beside a normal-compliance law (:class:`ConesBesideCompliance`): a cone
    pair's rows take the cone, not nodal limit rows (:class:`~cvxcontact.contact.quadratic.ConeRowLaws`, the rows
    ``lines.element.on_cone``), and the cone pairs' Bernstein map on the nodes of X_h (``mixed_bernstein``);
    docs/formulation.md §10, "P2", §16."""
    element = _element(lines, "the P2 'gamma3' cones beside a normal-compliance law")
    return replace(lines, rows=ConeRowLaws(lines.rows.laws, lines.rows.counts, element.on_cone),
                   mixed_bernstein=element.cones_of(lines.cone_pairs))


@dataclass(frozen=True)
class SignoriniRows(_Term):
    """Signorini's law at nodal rows E [u_nu] <= E g (P1, P2 sigma conditions; docs/formulation.md §2, §8)."""

    parts: ClassVar[frozenset[str]] = frozenset()
    kind: ClassVar[str] = "signorini"
    zeroes_held_forces: ClassVar[bool] = True
    _starts: ClassVar[tuple[int, ...]] = (2, 3)
    _states: ClassVar[tuple[int, ...]] = (2, 3)


@dataclass(frozen=True)
class ComplianceRows(_Term):
    """A normal-compliance law on some nodal rows, Signorini (or a penetration limit) on the others (§10)."""

    parts: ClassVar[frozenset[str]] = frozenset({"compliance"})
    kind: ClassVar[str] = "compliance"
    compliant: ClassVar[bool] = True
    active_from_forces: ClassVar[bool] = True
    programs: ClassVar[str | Callable] = "cvxcontact.backends.compliance:compliance_program"
    forces: ClassVar[str | Callable] = "cvxcontact.backends.compliance:compliance_forces"
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.nodal:read_back_compliance"


@dataclass(frozen=True)
class EverywhereCones(_Term):
    """The P2 "gamma3" condition: a cone per element on the Bernstein coefficients of the slack (§8); its
    cuts finish only problems they can condense."""

    parts: ClassVar[frozenset[str]] = frozenset({"cones"})
    kind: ClassVar[str] = "conic"
    cones: ClassVar[bool] = True
    unfinished_hint: ClassVar[str] = (
        "\nThis conic P2 'gamma3' answer is the interior point's (no exact finish: polish=False, cones next to a "
        "compliance law, or a declined finish), which stops where it stops (complementarity 1e-7 to 1e-6 on simple "
        "scenes, up to 1e-4 with held bodies or stacks; docs/formulation.md §8). Pass a tol above what the report "
        "shows to accept that answer, or use 'sigma1'/'sigma2' (nodal P2 conditions, finished exactly).")
    always_finished: ClassVar[bool] = False
    rows_may_depend: ClassVar[bool] = False
    _states: ClassVar[tuple[int, ...]] = (2,)     # the cuts' point loads along s (backends.start.cone_seeds)
    programs: ClassVar[str | Callable] = "cvxcontact.backends.cones:cone_program"
    forces: ClassVar[str | Callable] = "cvxcontact.backends.cones:cone_forces"
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.nodal:read_back_cones"


@dataclass(frozen=True)
class ConesBesideCompliance(_Term):
    """The P2 cones of some pairs in one program with a normal-compliance law on others (§10, "P2"); the
    interior point's answer (no exact finish is reported as declined)."""

    parts: ClassVar[frozenset[str]] = frozenset({"cones", "compliance"})
    kind: ClassVar[str] = "mixed"
    compliant: ClassVar[bool] = True
    cones: ClassVar[bool] = True
    unfinished_hint: ClassVar[str] = EverywhereCones.unfinished_hint
    finishes: ClassVar[bool] = False
    always_finished: ClassVar[bool] = False
    asks: ClassVar[str | Callable | None] = cones_beside_law
    programs: ClassVar[str | Callable] = "cvxcontact.backends.cones:mixed_program"
    forces: ClassVar[str | Callable] = "cvxcontact.backends.cones:mixed_forces"
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.nodal:read_back_conic_mix"


@dataclass(frozen=True)
class TrescaFriction(_Term):
    """Signorini rows and a friction law's cone per row on the slip (docs/howto/friction.md; Tresca, and Coulomb
    by a fixed point on the thresholds; 2D and 3D P1, 2D P2 under the nodal conditions): the full program only,
    then its exact finish (:func:`cvxcontact.backends.friction.exact_finish`; a decline keeps the interior
    point's answer without a warning, as before the finish existed); no error estimate; ``cc.Model``'s user terms
    beside it by :mod:`cvxcontact.backends.frictionuser`."""

    parts: ClassVar[frozenset[str]] = frozenset({"friction"})
    kind: ClassVar[str] = "friction"
    tangential: ClassVar[bool] = True
    finishes: ClassVar[bool] = False
    always_finished: ClassVar[bool] = False
    unestimated: ClassVar[str] = ""
    beside_user_terms: ClassVar[str | Callable | None] = "cvxcontact.backends.frictionuser:beside_user_terms"
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.readback:read_back_tresca"
    forces: ClassVar[str | Callable] = "cvxcontact.backends.friction:row_forces"
    builds: ClassVar[str | Callable | None] = Slip.build
    # its program: the Signorini rows, to which the friction route adds the slip's cones
    # (:func:`cvxcontact.backends.friction.friction_program`)


@dataclass(frozen=True)
class FrictionBesideCompliance(TrescaFriction):
    """A friction law on some pairs (Signorini rows, the slip's cones) and a normal-compliance law on others (nodal
    rows; docs/howto/friction.md, "Next to a compliance law"): one program, the compliance energy on its rows
    (:func:`cvxcontact.backends.compliance.compliance_program`) plus the friction energy, finished exactly by the
    friction finish on the energy with the law's term (:class:`~cvxcontact.backends.mixed.LawEnergy`: sequential
    quadratic steps, semismooth on the law's rows), or declined (a :class:`~cvxcontact.errors.ResidualWarning`);
    read back with the compliance checks and the friction law's."""

    parts: ClassVar[frozenset[str]] = frozenset({"friction", "compliance"})
    kind: ClassVar[str] = "compliance_friction"
    compliant: ClassVar[bool] = True
    active_from_forces: ClassVar[bool] = True
    finishes: ClassVar[bool] = True
    programs: ClassVar[str | Callable] = ComplianceRows.programs
    forces: ClassVar[str | Callable] = ComplianceRows.forces
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.readback:read_back_compliance_friction"
    finish_rows: ClassVar[str | Callable] = "cvxcontact.backends.frictionrows:LawRows"


@dataclass(frozen=True)
class ConesWithFriction(_Term):
    """The P2 "gamma3" cones (the normal condition on every element, docs/formulation.md §8, §16) and a friction
    law's cone per node of X_h on the slip, its capacity g_a w_a with w_a the positive weights of the nodal P2
    friction (2D: the Simpson weights of the merged P2 line; 3D: the red refinement's lumped areas), Coulomb's
    mu p_a from the cones' nodal force r = B^T beta made non-negative
    (:meth:`~cvxcontact.discrete.slip.Slip.pressing`;
    docs/howto/friction.md, "Coulomb under the cones"); beside a pair under a nodal condition the rows are E's (that
    pair's own rows, each a degenerate element of the cones, with its own weights; ``lines.cone`` on the rows,
    ``lines.cone_on_nodes`` on X_h). The full program
    only (:func:`cvxcontact.backends.friction.conic_full`), finished exactly where the contact closes at nodes (the
    friction finish of the nodal relaxation, kept if it satisfies every element's cone) and, with Tresca, where it
    ends inside an element (normal rows added at the slack's maxima: cut points); elsewhere the finish is declined
    (a :class:`~cvxcontact.errors.ResidualWarning` naming why) and the interior point's answer kept, with the conic
    and friction checks."""

    parts: ClassVar[frozenset[str]] = frozenset({"cones", "friction"})
    kind: ClassVar[str] = "conic_friction"
    cones: ClassVar[bool] = True
    tangential: ClassVar[bool] = True
    always_finished: ClassVar[bool] = False
    rows_may_depend: ClassVar[bool] = False
    beside_user_terms: ClassVar[str | Callable | None] = "cvxcontact.backends.frictionuser:cones_beside_user_terms"
    unfinished_hint: ClassVar[str] = (
        "\nThis P2 'gamma3' friction answer is the interior point's (polish=False, or a finish that declined: on "
        "the nodes and cut points, in 2D then at the exact tangency points; info.declined says why), so its "
        "complementarity and stick-slip checks stop where the interior point stops "
        "(docs/howto/friction.md). Pass a tol above what the report shows to accept it, or use 'sigma1'/'sigma2' "
        "(nodal P2 friction rows, finished exactly).")
    programs: ClassVar[str | Callable] = EverywhereCones.programs
    forces: ClassVar[str | Callable] = EverywhereCones.forces
    reads_back: ClassVar[str | Callable] = "cvxcontact.solution.readback:read_back_conic_friction"
    builds: ClassVar[str | Callable | None] = Slip.build
    asks: ClassVar[str | Callable | None] = cones_on_rows



_ANSWERS = (*ContactTerm.__annotations__, "estimated", "takes_user_terms", "takes_active_start", "program",
            "program_forces", "with_user_terms", "read_back", "finish_declined", "start", "determining_rows",
            "held_forces", "hands_on", "with_data", "own_lines", "kernel_capacity", "normal_rows")
"""What a term answers (the :class:`ContactTerm` protocol's members)."""

_REGISTRY: list = [ConesWithFriction, FrictionBesideCompliance, TrescaFriction, ConesBesideCompliance,
                   EverywhereCones, ComplianceRows, SignoriniRows]
_BUILT_IN = tuple(_REGISTRY)


class _Terms(Sequence):
    """A read-only, always current view of the term registry (:func:`register_term`)."""

    def __getitem__(self, i):
        return tuple(_REGISTRY)[i]

    def __len__(self) -> int:
        return len(_REGISTRY)

    def __repr__(self) -> str:
        return repr(tuple(_REGISTRY))


TERMS: Sequence[type] = _Terms()
"""The term classes in the order they are tried: the first whose ``poses(lines)`` holds is the problem's (the
package's own declare distinct ``parts``, so their order does not matter); a live view of the registry
(:func:`register_term` puts a term from outside first)."""


def register_term(term: type, *, before: type | None = None) -> type:
    """Register the contact term class ``term`` (from outside the package: a frozen dataclass of ``dim``, like the
    classes here, with a ``kind``, a ``poses(lines)`` and the :class:`ContactTerm` answers and methods), tried
    before the registered term ``before`` (None: first of all). Its ``kind`` keys the backends' routes
    (:func:`cvxcontact.backends.register`): a backend without a route for it refuses its problems. Problems built
    afterwards get it where it poses their lines. Returns ``term``; SolverError naming what is missing."""
    if not isinstance(term, type):
        raise SolverError(f"register_term takes a contact term class, got {type(term).__name__}")
    kind = getattr(term, "kind", None)
    if not isinstance(kind, str) or not kind.isidentifier():
        raise SolverError(f"contact term {term.__name__}: kind must be an identifier (its backends' route key), "
                          f"got {kind!r}")
    if not callable(getattr(term, "poses", None)):
        raise SolverError(f"contact term {term.__name__}: poses(lines) -> bool is missing")
    try:
        instance = term(2)
    except TypeError as exc:
        raise SolverError(f"contact term {term.__name__} must be built from the space's dim alone ({exc})") from exc
    missing = [name for name in _ANSWERS if not hasattr(instance, name)]
    if missing or not isinstance(instance, ContactTerm):
        raise SolverError(f"contact term {term.__name__} does not answer what a term answers: missing {missing} "
                          "(derive it from one of cvxcontact.discrete.terms' classes)")
    for flag, reason in (("estimated", "unestimated"), ("takes_user_terms", "refuses_user_terms")):
        if bool(getattr(instance, flag)) == bool(getattr(instance, reason)):     # the flag follows from the reason
            raise SolverError(f"contact term {term.__name__}: {flag}={getattr(instance, flag)!r} disagrees with "
                              f"{reason}={getattr(instance, reason)!r}; the package reads {reason}: set it (why, in "
                              f"words; empty for none) and leave {flag} to follow from it")
    if term in _REGISTRY:
        raise SolverError(f"contact term {term.__name__} is already registered")
    if before is not None and before not in _REGISTRY:
        raise SolverError(f"register_term(before=...) must be a registered term {tuple(TERMS)}, got {before!r}")
    _REGISTRY.insert(0 if before is None else _REGISTRY.index(before), term)
    return term


def unregister_term(term: type) -> type:
    """Remove the registered term class ``term`` (not one of the package's own); returns it."""
    if term in _BUILT_IN or term not in _REGISTRY:
        raise SolverError(f"contact term {term!r} is not a registered term from outside the package "
                          f"({[t.__name__ for t in TERMS if t not in _BUILT_IN]})")
    _REGISTRY.remove(term)
    return term


def contact_term(lines, dim: int) -> ContactTerm:
    """The :class:`ContactTerm` of the contact lines ``lines`` (:class:`~cvxcontact.fem.space.ContactLines`) in
    a space of ``dim`` displacement components: the first of :data:`TERMS` that poses them."""
    for term in TERMS:
        try:
            poses = term.poses(lines)
        except Exception as exc:                     # a term from outside (register_term) that cannot answer
            raise SolverError(f"contact term {term.__name__}: poses(lines) raised {type(exc).__name__}: {exc}; "
                              "fix it or unregister_term it") from exc
        if poses:
            return term(dim)
    if (words := UNPOSED.get(parts_of(lines))) is not None:
        raise UnsupportedError(words)
    named_parts = (lambda parts: " + ".join(sorted(parts)) or "Signorini rows")
    declared = ", ".join(f"{t.kind} ({named_parts(getattr(t, 'parts', ()))})" for t in TERMS)
    raise UnsupportedError(f"no registered contact term poses {named_parts(parts_of(lines))} together (the terms "
                           f"and the laws they declare: {declared}): pose the pairs under fewer laws, or register a "
                           "term declaring them (cvxcontact.discrete.terms.register_term)")
