"""Force-controlled rigid obstacles and bodies held by the contact only on the condensed route (docs/formulation.md
§7, §11, §12): the mixed system (26) condensed exactly onto each body's contact (Gamma) dofs, the obstacles'
translations kept as unknowns of that small system, a held body's rigid motions in its singular Sigma.

With every body held by its supports, each body's quasi-definite S is factorised once per geometry with its
Gamma dofs as a Schur block (:class:`~cvxcontact.backends.interface.Condensation`, PARDISO or SuperLU through
:mod:`cvxcontact.backends.factor`), and the contact rows touch the Gamma dofs only, so (26) on any set of closed
rows is, exactly,

    [[Sigma, 0,  G^T], [0, 0, R^T], [G, R, 0]] [v; tau; y] = [Sigma v0; F; g]

(Sigma = diag(Sigma_l) the interface stiffness, v0 the unconstrained Gamma displacements, G = [E J_1, E J_2, ...]
the rows on the Gamma dofs, R the rows' sensitivity to the translations tau, F the prescribed forces): the full
system bordered by the translations, of the size of the interface. The bodies' fields follow from v by one
backward sweep each. :func:`gamma_blocks` writes the condensed bodies as :class:`~cvxcontact.discrete.Block` s
(Kuu = Sigma, f = Sigma v0, jump = J), so that the full model's program
(:class:`~cvxcontact.backends.full.ContactModel` with its translations) and its exact finishes on the mixed
system (:func:`~cvxcontact.backends.full.mixed_kkt`: the independent active set, the accumulated cuts and
Newton at the tangency points) run unchanged on the interface: a sparse LU of (26) there costs a dense
factorisation of the interface's size instead of one of every body.

A body held by the contact only (its S singular along the rigid motions the contact rows see) is factorised as
S + D, D a positive diagonal on its Gamma dofs (:func:`~cvxcontact.backends.condensed.condense`, ``held``): the
sweeps are S's, its Sigma = Schur(S + D) - D is singular along those motions, and the mixed system (26) on the
interface holds them by its closed rows as the full one does (Signorini rows only: the registry's
``HELD_KINDS``).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..discrete.blocks import Block
from ..discrete.energy import Quadratic
from .full import ContactModel
from .interface import condensation
from .program import conic_options, timed_program
from .result import RawResult

__all__ = ["cones", "gamma_blocks", "signorini"]


def gamma_blocks(reduction, loads) -> list[Block]:
    """The condensed bodies of ``reduction`` (:class:`~cvxcontact.backends.interface.Condensation`) as scaled
    blocks on their Gamma dofs: Kuu = Sigma_l (dense, stored sparse), f = ``loads`` (Sigma_l v0_l, its
    :meth:`~cvxcontact.backends.interface.Condensation.apply`), jump = J_l, no potentials."""
    out = []
    for c, f in zip(reduction.bodies, loads):
        S = sp.csr_matrix(np.asarray(c.stiffness, dtype=float))
        out.append(Block(Kuu=S, f=np.asarray(f, dtype=float), jump=sp.csr_matrix(c.jump), bulk=Quadratic(S)))
    return out


def _program(problem, blocks, settings, timings, **kw):
    """The full model's program on the condensed ``blocks`` with the obstacles' translations, solved."""
    t0 = time.perf_counter()
    model = ContactModel(blocks, problem.E, problem.g, translations=list(problem.translations), **kw)
    timings["model"] = timings.get("model", 0.0) + time.perf_counter() - t0
    return model


def _loads(problem, reduction, timings) -> list:
    """Each body's condensed load r = F_G - S_GI S_II^-1 F_I (the forward sweep's reduced load: Sigma v0 where
    Sigma is regular; a body held by the contact only has no v0)."""
    reduction.apply(problem, timings)
    return [f.reduced for f in reduction.sweeps]


def _fields(problem, reduction, raw, timings) -> RawResult:
    """``raw`` with its Gamma values (``raw.u``) turned into every body's fields (one backward sweep each)."""
    raw.u, raw.phi = reduction.invert_gamma(problem, [np.asarray(v, dtype=float) for v in raw.u], timings)
    raw.factorization = reduction.factorization
    return raw


def signorini(problem, cache, settings, timings) -> RawResult:
    """Signorini rows with force-controlled obstacles or bodies held by the contact only, condensed: the program on
    the interface with the translations, then the exact finish of the full route on the condensed mixed system
    (:func:`~cvxcontact.backends.signorini.mixed_finish`, the interior point's translations holding the
    components no active row sees), the fields by back-substitution."""
    from .finish import force_displacements, ipm_active, reach_forces
    from .signorini import mixed_finish

    reduction = condensation(problem, cache, settings, timings)
    blocks = gamma_blocks(reduction, _loads(problem, reduction, timings))
    model = _program(problem, blocks, settings, timings)
    iterations = timed_program(model.problem, settings, timings)
    E = problem.E
    raw = RawResult(u=[v.value for v in model.u], phi=[None] * len(blocks), method="condensed",
                    y=np.asarray(model.contact.dual_value, dtype=float).ravel(), program=model.problem,
                    taus=[np.asarray(t.value, dtype=float).ravel() for t in model.t], iterations=iterations)
    moved = problem.moved_g(raw.taus)                                   # the obstacles moved
    parts = [E @ (b.jump @ uk) for b, uk in zip(blocks, raw.u)]
    raw.active = ipm_active(parts, moved, raw.y, force_displacements(blocks, E, raw.y),
                            reach_forces(blocks, E, raw.u, raw.phi))
    if settings.polish:
        mixed_finish(problem, raw, timings, hold=raw.taus or None, blocks=blocks)
    return _fields(problem, reduction, raw, timings)


def cones(problem, cache, settings, timings) -> RawResult:
    """The P2 "everywhere" cones with force-controlled obstacles, condensed: the conic program on the interface
    with the translations, then the accumulated cuts and Newton at the tangency points on the condensed mixed
    system (:func:`~cvxcontact.backends.cones.finish_cuts_mixed`), the fields by back-substitution. No
    certificate (the energy bound has no translations)."""
    from .cones import cone_nodal_force, cone_width, finish_cuts_mixed, held_beta
    from .conic import bernstein_duals

    reduction = condensation(problem, cache, settings, timings)
    blocks = gamma_blocks(reduction, _loads(problem, reduction, timings))
    w = cone_width(problem)
    model = _program(problem, blocks, settings, timings, bernstein=problem.lines.cone[0], width=w)
    iterations = timed_program(model.problem, settings, timings, conic_options(settings.solver, settings.options))
    beta = held_beta(problem, bernstein_duals(model.cone, model.row, w))
    raw = RawResult(u=[v.value for v in model.u], phi=[None] * len(blocks), y=cone_nodal_force(problem, beta),
                    beta=beta, program=model.problem, iterations=iterations, method="condensed",
                    taus=[np.asarray(t.value, dtype=float).ravel() for t in model.t])
    if settings.polish:
        finish_cuts_mixed(problem, timings, raw, blocks=blocks)
    return _fields(problem, reduction, raw, timings)
