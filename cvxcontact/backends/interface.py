"""The pieces every route shares: the condensed interface of a problem (built once per geometry and kept in
the :class:`~cvxcontact.backends.result.Cache`), the interface load of a load case, the back-substitution,
the fields of a solved program, and the rows no unknown moves (docs/formulation.md §7, §8 "Held nodes")."""

from __future__ import annotations

import time

import numpy as np

from .condensed import Compliance, condense, quasi_definite_rhs
from .conic import least_held_duals

__all__ = ["condensed_interface", "interface_load", "back_substitute", "split", "program_fields", "held_cone",
           "release_held"]


def condensed_interface(problem, cache, settings, timings):
    """(condensed bodies, interface compliance W) of ``problem``, built once per geometry into ``cache``."""
    if cache.condensed is None:
        t0 = time.perf_counter()
        cache.condensed = [condense(b, s, m, settings.factorization)
                           for b, s, m in zip(problem.blocks, problem.matrices, problem.meshes)]
        cache.compliance = Compliance(cache.condensed, problem.E)
        timings["factorization"] = time.perf_counter() - t0
    return cache.condensed, cache.compliance


def interface_load(problem, cache, settings, timings):
    """(rhs, v0, d) of the load case: per-body right-hand sides, unconstrained Gamma displacements and the free
    slack d = E [v0_nu] - g; the forward sweeps are kept in ``cache`` for :func:`back_substitute`."""
    condensed, compliance = condensed_interface(problem, cache, settings, timings)
    t0 = time.perf_counter()
    rhs = [quasi_definite_rhs(b) for b in problem.blocks]
    cache.sweeps = [c.forward(F) for c, F in zip(condensed, rhs)]
    v0 = [c.unconstrained(f) for c, f in zip(condensed, cache.sweeps)]
    d = compliance.free_slack(v0, problem.g)
    timings["interface_load"] = time.perf_counter() - t0
    return rhs, v0, d


def split(condensed, x, blocks):
    """(u, phi) of each body from its back-substituted unknowns ``x``."""
    return ([xk[:c.n_u] for c, xk in zip(condensed, x)],
            [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)])


def back_substitute(problem, cache, y, timings):
    """(u, phi) of every body under the contact forces ``y`` on the rows (one backward sweep per body)."""
    t0 = time.perf_counter()
    x = [c.back_substitute(f, problem.E.T @ y) for c, f in zip(cache.condensed, cache.sweeps)]
    timings["back_substitution"] = timings.get("back_substitution", 0.0) + time.perf_counter() - t0
    return split(cache.condensed, x, problem.blocks)


def program_fields(model, problem, condensed=None):
    """(u, phi, r) of a solved program, r = E [u_nu] - g its rows' penetration (scaled): from the full model's
    fields, or (``condensed`` given) from the condensed model's Gamma values, u and phi then None (they come
    from a back-substitution)."""
    E, g = problem.E, problem.g
    if condensed is not None:
        return None, None, sum(E @ (c.jump @ v.value) for c, v in zip(condensed, model.v)) - g
    u = [v.value for v in model.u]
    phi = [v.value if v is not None else None for v in model.phi]
    return u, phi, sum(E @ (b.jump @ uk) for b, uk in zip(problem.blocks, u)) - g


def held_cone(beta, B, held, c):
    """beta with the entries of the Bernstein rows of ``B`` whose nodes are all ``held`` and whose value
    (at the cone's gap ``c``) is 0 lowered to the least the dual cone allows (:func:`least_held_duals`)."""
    if not np.any(held):
        return beta
    rows = (abs(B) @ (~held).astype(float) == 0) & (np.abs(B @ c) <= 1e-12 * max(np.abs(c).max(), 1e-300))
    return least_held_duals(beta, rows.reshape(-1, 3))


def release_held(y, z, held):
    """(y, z) with the limit reactions z of the ``held`` rows set to 0 and the row forces y lowered by them: a
    reaction on a row no unknown moves acts on nothing, so (26)-(27) do not determine it, and an interior point
    reports an arbitrary, typically huge one (docs/formulation.md §8, "Held nodes")."""
    z = np.asarray(z, dtype=float)
    return y - np.where(held, z, 0.0), np.where(held, 0.0, z)
