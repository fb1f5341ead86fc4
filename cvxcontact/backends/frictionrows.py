"""The friction rows' slip on the stacked unknowns (:mod:`cvxcontact.backends.friction`): the prescribed slip, the
slip matrix of the friction finish on x = (u, phi, taus) (the translations of force-controlled obstacles included,
the friction term's ``data.translations``, :class:`~cvxcontact.discrete.slip.Slip`), which slip components some
unknown moves, and whether two pairs' rows share an unknown (docs/howto/friction.md, "Rows that share a node"); and
the normal rows of the friction finish as the term's laws pose them (:class:`NormalRows`, :class:`LawRows`: the
term's ``finish_rows``)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .mixed import LawEnergy, stacked

__all__ = ["LawRows", "NormalRows", "balances", "moved_components", "prescribed_row_slip", "scattered", "shared_rows",
           "slip_matrix"]


def prescribed_row_slip(problem) -> np.ndarray:
    """E [u_D t]: the slip prescribed displacements of contact nodes fix at every slip row ((c R,), component-major
    like the friction term's ``data.rows``, scaled): the constant part of the slip s = E [u_t] + E [u_D t] (module
    docstring); a selection of its rows is the same selection of ``data.rows`` applied to ``data.prescribed``."""
    data = problem.term.data
    Es = data.rows
    return Es @ np.broadcast_to(np.asarray(data.prescribed, dtype=float), (Es.shape[1],))


def moved_components(problem, rows) -> np.ndarray:
    """(len(rows), c) mask of the slip components of the frictional ``rows`` that some unknown moves (a support
    that fixes one direction at a row's nodes leaves the other moved)."""
    data = problem.term.data
    n_c, R = data.components, problem.E.shape[0]
    Es = data.rows
    reach = sum((abs(Es @ T) @ np.ones(T.shape[1]) for T in data.operators), np.zeros(n_c * R))
    reach = reach + sum((abs(Es @ T) @ np.ones(T.shape[1]) for T in data.translations), np.zeros(n_c * R))
    return reach.reshape(n_c, R)[:, rows].T > 0


def scattered(values, mask) -> np.ndarray:
    """``values`` of the rows ``mask`` selects, on every row (0 / False elsewhere)."""
    out = np.zeros(len(mask), dtype=np.asarray(values).dtype)
    out[mask] = values
    return out


def slip_matrix(problem, order, widths):
    """The slips of the friction rows' components ``order`` (row a, component j at a n_c + j) as rows on the
    stacked unknowns x = (u, phi, taus) of :func:`~cvxcontact.backends.mixed.stacked` (``widths``: the
    translations'; 0 on phi; on the translations the slip their obstacle's motion causes, the friction term's
    ``data.translations``): (len(order), len(x)), CSR."""
    data = problem.term.data
    Es = data.rows[order]
    moves = data.translations or [np.zeros((Es.shape[1], w)) for w in widths]
    return sp.hstack([sp.hstack([Es @ T, sp.csr_matrix((len(order), 0 if b.Kpp is None else b.Kpp.shape[0]))])
                      for b, T in zip(problem.blocks, data.operators)]
                     + [sp.csr_matrix(Es @ T) for T in moves]).tocsr()


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
    n_c = problem.term.data.components
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


class NormalRows:
    """The normal rows G x <= g of the friction finish (:func:`~cvxcontact.backends.friction.exact_finish`) beside
    the mixed ``energy`` of ``problem`` as Signorini's law poses them: the rows and their forces y as they are (the
    terms' default ``finish_rows``)."""

    def __init__(self, problem, energy, G, g):
        self.energy, self.G, self.g = energy, G, g

    def posed(self, first, free, y0, rows):
        """(energy, G, g, free, y0, on): what the finish's steps take from the start ``first`` (a RawResult), the
        rows some unknown moves ``free``, the start's forces ``y0`` on them and the frictional ``rows`` (``on``: their
        places among the normal rows)."""
        return self.energy, self.G, self.g, free, y0, rows

    def forces(self, x, y, closed, raw):
        """(y, closed): every row's force and whether it is closed from the steps' answer ``x`` and its normal rows'
        forces ``y`` and closed set ``closed`` (``raw``: the answer, whose other fields a law may set)."""
        return y, closed


class LawRows(NormalRows):
    """The normal rows of the friction finish beside a normal-compliance law (docs/howto/friction.md, "Next to a
    compliance law"; the term :class:`~cvxcontact.discrete.terms.FrictionBesideCompliance`): the law's energy added
    to ``energy`` (:class:`~cvxcontact.backends.mixed.LawEnergy`: sequential quadratic steps, semismooth on its rows),
    the rows with a finite limit r <= l (the Signorini rows, the frictional ones among them) the finish's normal
    rows, their forces the reactions z; every row's force the law's w p(r) plus z."""

    def __init__(self, problem, energy, G, g):
        law = problem.scaled_law
        self.limited = law.limited
        self.energy = LawEnergy(energy, G, g, problem.weights, law)
        self.G, self.g = G[self.limited], (g + np.where(self.limited, law.penetration_limit, 0.0))[self.limited]

    def posed(self, first, free, y0, rows):
        y0 = (first.y - self.energy.forces(stacked(first.u, first.phi, first.taus)))[self.limited]   # reactions z
        on = np.searchsorted(np.flatnonzero(self.limited), rows)      # the frictional rows (Signorini) among them
        return self.energy, self.G, self.g, free[self.limited], y0, on

    def forces(self, x, y, closed, raw):
        z, y = y, self.energy.forces(x)
        y[self.limited] += z
        closed, raw.z = scattered(closed, self.limited) | (y > 0), scattered(z, self.limited)
        return y, closed
