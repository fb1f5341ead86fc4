"""The friction finish beside a non-quadratic bulk energy (a Hencky body): sequential quadratic steps, damped on the
program's objective (docs/howto/friction.md; docs/refusals.md row 36).

Each step is the exact friction finish (:func:`~cvxcontact.backends.finish.solve_friction`) of the energy's
second-order model at the last answer x_k (:meth:`~cvxcontact.backends.mixed.MixedEnergy.linearised`: the tangent
T_k = Hess L(x_k), b_k = T_k x_k - grad L(x_k)), from the last answer's (x, y, mu). Its answer x* minimises the model
plus the friction energy sum_a c_a |S_a x + s0_a| under the normal rows G x <= g; with the bodies' energy convex
(a Hencky body), d = x* - x_k is a descent direction of the program's objective F(x) = L(x) + sum_a c_a |S_a x +
s0_a| (a proximal Newton step: the model's Hessian is positive definite), and F is convex on the rows. Electric
unknowns (a piezoelectric body; their enthalpy a saddle, concave in phi) leave it so: their rows are linear, so
that every model's answer satisfies them exactly, and on them L is the energy with the potentials eliminated,
max over phi, convex in the displacements, and d its proximal Newton step (measured: a PZT layer beside a yielding
block, undamped the steps cycled). The first step is taken in full (its start, the interior point's answer or
an earlier round's, may lie outside the rows: its objective bounds nothing); its answer and every later iterate, a
convex combination of answers, are within them. Where a later full step raises F beyond rounding (measured: a Hencky block indented by a
rigid sphere under 3D P2 cones yields under it and the undamped steps cycle at a relative residual of 1), the step is
halved until F(x_k + alpha d) <= F(x_k) + 1e-4 alpha Delta, Delta = grad L(x_k) . d + friction energy(x*) -
friction energy(x_k) < 0 (Armijo on the proximal Newton decrement); near the answer the full steps are taken and
converge quadratically. The steps stop once a full step's relative residual of the nonlinear (26) with the normal
and tangential forces is at most :data:`SEQUENTIAL_TOL` with the closed and stuck rows of the step before and the
rigid motions only the contact holds balanced to :data:`HELD_ROUNDING` (or their balance no longer halving: a rigid
displacement far above the deformation inflates each row's size |K| |u|, so the rows' residual cannot see the
motions' balance; measured: a block held along x by a compliance law alone, 4.5e-10 one step short), or at most
:data:`~cvxcontact.backends.bulkcuts.BULK_STALL_TOL` and no longer halving, or where no descent is left from an answer
whose full step had reached :data:`SEQUENTIAL_TOL` (its forces: that step's, the exact finish of its own model);
declined after :data:`SEQUENTIAL_STEPS` steps, or where no descent is left above it. A linear material: one solve.
Coulomb's capacities c = mu y are those of each step's forces (the objective at them; the acceptance is the
residual's).
"""

from __future__ import annotations

import logging

import numpy as np

from .bulkcuts import BULK_STALL_TOL
from .finish import Declined, Stop
from .finish.friction import solve_friction

__all__ = ["ARMIJO", "ENERGY_ROUNDING", "HELD_ROUNDING", "SEQUENTIAL_STEPS", "SEQUENTIAL_TOL", "SMALLEST_STEP",
           "sequential"]

log = logging.getLogger(__name__)

SEQUENTIAL_TOL = 1e-12
"""A non-quadratic energy's friction finish (:func:`sequential`) stops once the relative residual of the nonlinear
(26) with the normal and tangential forces is at most this (rounding of its terms) with the same closed and stuck
rows at two steps in a row."""

HELD_ROUNDING = 16 * np.finfo(float).eps
"""The held rigid motions' balance :func:`sequential` stops at: |H r| <= this times |H| m, H the motions only the
contact holds, r the residual of the nonlinear (26) with the row forces, m the sizes of its terms (the rounding of
the rows summed along the motions; measured 0.02 .. 0.07 eps after the step that reaches it, 30 eps before)."""

SEQUENTIAL_STEPS = 30
"""The most sequential quadratic steps of :func:`sequential`; then it declines."""

ARMIJO = 1e-4
"""The fraction of the proximal Newton decrement a damped step must gain (:func:`sequential`)."""

ENERGY_ROUNDING = 1e-12
"""A full step whose objective is above the last one's by at most this, relative to the larger of |F| and C U (the
friction finish's force and displacement scales), is taken undamped: rounding of the objective."""

SMALLEST_STEP = 2.0 ** -30
"""Below this step length the damping finds no descent (:func:`sequential`)."""


def sequential(op, G, g, fr, free, x, y, mu, scales, dependent, held=None):
    """The friction finish of the mixed energy ``op`` from (x, y, mu) (module docstring): for a linear material one
    solve of its system; for a non-quadratic energy the damped sequential quadratic steps. ``G``, ``g``: the normal
    rows G x <= g; ``fr``: the :class:`~cvxcontact.backends.finish.friction.FrictionRows`; ``free``: the normal rows
    some unknown moves; ``scales``: (C, U) the force and displacement scales; ``dependent``: the rows may be
    linearly dependent; ``held`` (k, n) or None: the rigid motions only the contact holds, on the unknowns x (the
    steps go on while their balance still halves above :data:`HELD_ROUNDING`). Returns solve_friction's (x, y, mu,
    closed, steps), the steps summed, or the Declined that stopped it."""
    steps, seen, last, res, settled, unbalanced = 0, None, np.inf, np.inf, None, np.inf
    for i in range(1 if op.linear else SEQUENTIAL_STEPS):
        T, b = op.linearised(x)
        out = solve_friction(T, b, G, g, fr, free, x, y, mu, scales, dependent=dependent)
        if isinstance(out, Declined) or op.linear:
            return out
        target, y_new, mu_new, closed, k = out
        steps += k
        c = fr.capacity(y_new)
        alpha = _damping(op, fr, x, target, c, scales) if i > 0 else 1.0
        if alpha is None:                 # no descent from x: the last full step's answer, if it was at rounding
            if settled is not None:
                return (*settled, steps)
            return Declined(Stop.STALL, f"the sequential quadratic steps of the friction finish found no descent at "
                            f"a relative residual {res:.1e} of the nonlinear (26)")
        x = target if alpha == 1.0 else x + alpha * (target - x)
        y, mu = y_new, mu_new
        key = (closed.tobytes(), (c - np.linalg.norm(mu, axis=1) > 1e-9 * scales[0]).tobytes())
        res = op.residual(x, (G, y), (fr.S, mu.ravel()))
        log.info("friction finish, sequential quadratic step %.3g: relative residual %.1e", alpha, res)
        balance = _held_balance(op, held, x, (G, y), (fr.S, mu.ravel()))
        if alpha == 1.0 and ((res <= SEQUENTIAL_TOL and key == seen and (balance <= HELD_ROUNDING
                                                                          or balance > 0.5 * unbalanced))
                             or (res <= BULK_STALL_TOL and res > 0.5 * last)):
            return x, y, mu, closed, steps
        unbalanced = balance if alpha == 1.0 else np.inf
        settled = (x, y, mu, closed) if alpha == 1.0 and res <= SEQUENTIAL_TOL else None
        seen, last = (key, res) if alpha == 1.0 else (None, np.inf)
    return Declined(Stop.MAX_ITER, f"the sequential quadratic steps of the friction finish stopped at a relative "
                    f"residual {res:.1e} of the nonlinear (26)")


def _held_balance(op, held, x, *forces) -> float:
    """max_j |H r|_j / (|H| m)_j: the balance of the held rigid motions ``held`` (H) at ``x``, r the residual of the
    nonlinear (26) with the row forces ``forces`` and m the sizes of its terms (:meth:`MixedEnergy.residual`'s); 0
    without motions. The rows' relative residual cannot see it: a rigid displacement far above the deformation
    inflates each row's size |K| |u| (a block held along x by a compliance law alone, 117 m of translation beside
    0.3 of deformation: rows at 970 eps of their sizes, the translation's balance 4.5e-10 of the forces along it)."""
    if held is None or held.shape[0] == 0:
        return 0.0
    r, size = op.gradient(x), op.magnitude(x)
    for M, f in forces:
        r = r + M.T @ f
        size = size + abs(M).T @ np.abs(f)
    along = np.abs(held) @ size
    return float((np.abs(held @ r) / np.maximum(along, np.finfo(float).tiny)).max(initial=0.0))


def _damping(op, fr, x, target, c, scales):
    """The step length toward the model's answer ``target`` from ``x`` (module docstring): 1 where the full step
    does not raise the objective F beyond :data:`ENERGY_ROUNDING`, else the first halving that gains
    :data:`ARMIJO` of the proximal Newton decrement; None where there is no descent (a decrement at rounding, or
    no halving above :data:`SMALLEST_STEP` gains it)."""
    def friction(z):
        return float(c @ np.linalg.norm(fr.slip(z), axis=1))

    f0, d = op.value(x) + friction(x), target - x
    floor = ENERGY_ROUNDING * max(abs(f0), scales[0] * scales[1])
    if op.value(target) + friction(target) <= f0 + floor:
        return 1.0
    decrement = float(op.gradient(x) @ d) + friction(target) - friction(x)
    if decrement >= -floor:
        return None
    alpha = 0.5
    while alpha >= SMALLEST_STEP:
        z = x + alpha * d
        if op.value(z) + friction(z) <= f0 + ARMIJO * alpha * decrement:
            return alpha
        alpha /= 2
    return None
