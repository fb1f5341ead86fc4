"""One normalised call per backend: :func:`run` picks the route of a backend for the kind of contact term a
problem poses and returns one :class:`~cvxcontact.backends.result.RawResult`.

The kinds (:func:`kind`): ``"signorini"`` (nodal rows, P1 or P2), ``"compliance"`` (a normal-compliance law on
some pair, nodal rows), ``"conic"`` (the P2 "everywhere" cones, §8) and ``"mixed"`` (cones next to a compliance
law, §10 "P2"). :data:`ROUTES` maps (backend, kind) to the function that solves it; a backend that solves a
kind registers its function here and its ``accepts`` rule in :data:`cvxcontact.backends.BACKENDS`.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from ..errors import SolverError
from ..fem.kernel import check_determined
from . import compliance, cones, signorini
from .result import RawResult

__all__ = ["ROUTES", "kind", "run"]

ROUTES = {
    ("full", "signorini"): signorini.full,
    ("condensed", "signorini"): signorini.condensed,
    ("sparse", "signorini"): signorini.sparse,
    ("full", "compliance"): partial(compliance.solve, method="full"),
    ("condensed", "compliance"): partial(compliance.solve, method="condensed"),
    ("full", "conic"): cones.full,
    ("condensed", "conic"): cones.condensed,
    ("full", "mixed"): partial(cones.mixed, method="full"),
    ("condensed", "mixed"): partial(cones.mixed, method="condensed"),
}
"""(backend name, kind) -> route(problem, cache, settings, timings) -> RawResult."""


def kind(problem) -> str:
    """The kind of contact term ``problem`` poses (module docstring)."""
    if problem.mixed:
        return "mixed"
    if problem.conic:
        return "conic"
    return "compliance" if problem.compliant else "signorini"


def run(method: str, problem, cache, settings, timings) -> RawResult:
    """Solve ``problem`` with the backend ``method`` (a name of :data:`cvxcontact.backends.BACKENDS`), reusing and
    filling ``cache``; the forces of rows no unknown moves at their least admissible value (docs/formulation.md
    §8, "Held nodes": (26)-(27) do not determine them)."""
    route = ROUTES.get((method, kind(problem)))
    if route is None:
        raise SolverError(f"method {method!r} does not solve a {kind(problem)} problem")
    raw = route(problem, cache.matching(problem.lines.key()), settings, timings)
    if raw.polished and raw.active is not None:     # a motion only rows open at the solution would hold
        check_determined(problem.kernel, raw.active)
    if kind(problem) == "signorini":
        raw.y = np.where(problem.held_rows, 0.0, raw.y)
    if not raw.factorization and cache.condensed:
        raw.factorization = ",".join(dict.fromkeys(c.factorization for c in cache.condensed))
    return raw
