"""Backends: the ways a discrete problem is solved.

``full``       the phi-form convex program of every body in CVXPY (the reference; accepts everything)
``condensed``  each body condensed exactly onto its contact unknowns, a small interface QP in CVXPY
``sparse``     active-set steps on the sparse mixed system (26) of every body: long interfaces
``finish``     the exact finish: the interface LCP solved by scaled active-set steps (NNLS fallback)
``options``    validation of solver names and options before anything is assembled

The registry :data:`BACKENDS` lists the backends in speed order (fastest first), each with
an ``accepts(problem) -> bool`` on a :class:`ProblemDescription` and a ``prefers(problem)``.
``method="auto"`` (the default) takes the first backend that accepts the problem and prefers it (no
``prefers``: every problem it accepts) (:func:`choose`): "sparse" above :data:`SPARSE_ROWS` contact rows
(where the condensed route's dense m x m interface matrices dominate), else "condensed", "full" for what
neither accepts.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..errors import SolverError

__all__ = ["METHODS", "DEFAULT_METHOD", "ProblemDescription", "Backend", "BACKENDS", "choose", "SPARSE_ROWS"]

SPARSE_ROWS = 1500
"""``method="auto"`` prefers the sparse route (:mod:`cvxcontact.backends.sparse`) over the condensed one
when the problem has more contact rows than this. Why 1,500: the condensed route holds dense interface
matrices (W: m x m doubles, 18 MB at m = 1,500, 200 MB at 5,000; each body's Sigma_l and B_l, the dense
trailing block of its factor, the interface QP's psd matrix) and factorises them in O(m^3); the sparse
route holds the sparse factor of the mixed system only. Measured (2 shared cores): on bulky bodies with a
short interface the condensed route wins (two_blocks(128), 217 rows: 1.1 s against 2.9 s); on a thin layer
the sparse route wins from a few hundred rows (thin_layer(400), 681 rows: 1.1 s against 5.1 s) and at
1,500-odd rows the dense matrices cost hundreds of MB whatever the bodies (thin_layer(1000), 1,701 rows:
condensed 14.6 s and 600 MB above the scene, sparse 3.9 s and 140 MB; thin_layer(3000), 5,101 rows:
condensed 622 s and 5.0 GB, sparse 17 s and 334 MB). Above 1,500 rows the sparse route is therefore
chosen for every geometry; below, the condensed one (docs/architecture.md, "The sparse route")."""


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
    """

    quadratic_energy: bool = True
    linear_contact: bool = True
    user_terms: int = 0
    held_by_contact: bool = False
    force_control: bool = False
    contact_rows: int = 0
    compliant: bool = False
    conic: bool = False


@dataclass(frozen=True)
class Backend:
    """A registered backend: its ``name`` (the ``method=`` value), what it ``accepts`` and what it
    ``prefers`` among those (None: all; ``method="auto"`` only)."""

    name: str
    accepts: Callable[[ProblemDescription], bool]
    summary: str = ""
    prefers: Callable[[ProblemDescription], bool] | None = None


def _condensed_accepts(p: ProblemDescription) -> bool:
    return p.quadratic_energy and p.linear_contact and p.user_terms == 0 and not p.held_by_contact \
        and not p.force_control


def _sparse_accepts(p: ProblemDescription) -> bool:
    return _condensed_accepts(p) and not p.compliant and not p.conic


BACKENDS: tuple[Backend, ...] = (
    Backend("sparse", _sparse_accepts,
            "active-set steps on the sparse mixed system (long interfaces; no dense m x m matrix)",
            prefers=lambda p: p.contact_rows > SPARSE_ROWS),
    Backend("condensed", _condensed_accepts,
            "exact condensation onto the contact dofs + interface QP + exact finish (fast)"),
    Backend("full", lambda p: True, "the whole phi-form model in CVXPY (reference; accepts everything)"),
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
