"""The friction rows' slip on the stacked unknowns (:mod:`cvxcontact.backends.friction`): the prescribed slip, the
slip matrix of the friction finish on x = (u, phi, taus) (the translations of force-controlled obstacles included,
``problem.translation_slips``), which slip components some unknown moves, and whether two pairs' rows share an
unknown (docs/howto/friction.md, "Rows that share a node")."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["balances", "moved_components", "prescribed_row_slip", "scattered", "shared_rows", "slip_matrix"]


def prescribed_row_slip(problem) -> np.ndarray:
    """E [u_D t]: the slip prescribed displacements of contact nodes fix at every slip row ((c R,), component-major
    like ``problem.slip_rows``, scaled): the constant part of the slip s = E [u_t] + E [u_D t] (module docstring);
    a selection of its rows is the same selection of ``slip_rows`` applied to ``problem.prescribed_slip``."""
    Es = problem.slip_rows
    return Es @ np.broadcast_to(np.asarray(problem.prescribed_slip, dtype=float), (Es.shape[1],))


def moved_components(problem, rows) -> np.ndarray:
    """(len(rows), c) mask of the slip components of the frictional ``rows`` that some unknown moves (a support
    that fixes one direction at a row's nodes leaves the other moved)."""
    n_c, R = problem.slip_components, problem.E.shape[0]
    Es = problem.slip_rows
    reach = sum((abs(Es @ b.slip) @ np.ones(b.slip.shape[1]) for b in problem.blocks), np.zeros(n_c * R))
    reach = reach + sum((abs(Es @ T) @ np.ones(T.shape[1]) for T in problem.translation_slips), np.zeros(n_c * R))
    return reach.reshape(n_c, R)[:, rows].T > 0


def scattered(values, mask) -> np.ndarray:
    """``values`` of the rows ``mask`` selects, on every row (0 / False elsewhere)."""
    out = np.zeros(len(mask), dtype=np.asarray(values).dtype)
    out[mask] = values
    return out


def slip_matrix(problem, order, widths):
    """The slips of the friction rows' components ``order`` (row a, component j at a n_c + j) as rows on the
    stacked unknowns x = (u, phi, taus) of :func:`~cvxcontact.backends.mixed.stacked` (``widths``: the
    translations'; 0 on phi; on the translations the slip their obstacle's motion causes,
    ``problem.translation_slips``): (len(order), len(x)), CSR."""
    Es = problem.slip_rows[order]
    moves = problem.translation_slips or [np.zeros((Es.shape[1], w)) for w in widths]
    return sp.hstack([sp.hstack([Es @ b.slip, sp.csr_matrix((len(order), 0 if b.Kpp is None else b.Kpp.shape[0]))])
                      for b in problem.blocks] + [sp.csr_matrix(Es @ T) for T in moves]).tocsr()


def shared_rows(problem, G, S, rows) -> bool:
    """Whether the rows of two pairs act on a common unknown (normal rows ``G``, slip rows ``S`` of the frictional
    ``rows``, row a component j at a c + j): a floor and a wall sharing a corner node, whose floor slip row and
    wall row move the same displacement. Closed and stuck there, the rows are linearly dependent and only the
    sum of their forces is determined (docs/howto/friction.md, "Rows that share a node"): the finish then keeps
    an independent subset of them per step, as on dependent rows."""
    counts = problem.rows.counts
    if len(counts) < 2:
        return False
    pair = np.repeat(np.arange(len(counts)), counts)
    n_c = problem.slip_components
    on = [sp.csr_matrix((np.ones(len(pair)), (pair, np.arange(len(pair)))), shape=(len(counts), len(pair))) @ abs(G),
          sp.csr_matrix((np.ones(S.shape[0]), (np.repeat(pair[rows], n_c), np.arange(S.shape[0]))),
                        shape=(len(counts), S.shape[0])) @ abs(S)]
    touched = (sum(on) != 0).astype(int)                 # (pairs, unknowns): the pairs whose rows move each unknown
    return bool((np.asarray(touched.sum(axis=0)).ravel() > 1).any())


def balances(inner, size, G, y, S, mu, tol) -> bool:
    """Whether (26) holds with an answer's own forces: the internal forces ``inner`` (the bulk energy's gradient
    minus the loads) + G^T y (normal rows) + S^T mu (friction rows) within ``tol`` of the largest of its terms'
    magnitudes (``size`` those of ``inner``), entry by entry (the tangency polishes' acceptance, 2D and 3D)."""
    balance = inner + G.T @ y + S.T @ mu
    terms = size + abs(G.T) @ np.abs(y) + abs(S.T) @ np.abs(mu)
    return not (np.abs(balance) > tol * max(float(terms.max(initial=0.0)), np.finfo(float).tiny)).any()
