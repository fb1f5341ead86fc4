"""The friction terms of the residual error estimate (docs/accuracy.md, "Friction"; Tresca and Coulomb).

A friction law adds the tangential traction t to the contact traction of eq. (8): on the first body of a pair
sigma n = -lambda nu + t tau (tau the pair's tangent in 2D, t (., 2) along its frame (t_1, t_2) in 3D), on the
second body the opposite, with |t| <= g and t anti-parallel to the slip [u_t] where [u_t] != 0
(g |[u_t]| + t . [u_t] = 0). The estimate reads t_h, the discrete tangential traction, from the row forces as the
trace of the space decides (``ContactResult.trace.friction_fields``, :mod:`cvxcontact.fem.trace`):

- 2D (P1, P2) and 3D P1: the lumped read-back, each row's tangential force over the length (area) it holds
  (``ContactResult.shear``, Pa), the function of the rows' nodes in X_h (``Interface.extend``: under
  "sigma1"/"sigma2" the merged nodes without a row take the value of the constrained side's function, not 0);
  the threshold g_h likewise (Tresca: g; Coulomb: mu p at each row). There the lumped weights are the
  consistent loads of a constant (P1's hats, Simpson's h/6, 2h/3 on a P2 line), so a uniform traction reads
  exactly, and t_h meets |t_h| <= g at every row, as the law's rows ask; the Riesz representer of nodal forces
  would oscillate where the slip starts (up to twice the threshold on the meshes of
  tests/test_friction_estimate.py) and charge the cone term with an artefact of the read-back.
- 3D P2 (the trace of Q2's 6-node face triangles too; hexahedra read t_h over their faces' Q1/Q2 hats instead,
  :mod:`.tensorestimate`): the consistent loads
  of a uniform traction tau are 0 at a face's vertices and tau A/3 at its edge midpoints, while the rows hold A/12
  and A/4 (the red refinement's lumping, ``ContactResult.slip_measure``): the lumped read-back would read tau as 0
  and 4/3 tau, whose interpolant reaches 16/9 tau inside a face, and charge an exact uniform state. t_h is the
  Riesz representer of the row forces in X_h, M t_h = f per tangential component, as lambda_h is (exact for a
  uniform traction), read once per side where several pairs hold one part (:mod:`.sides`, by the friction
  read-back: ``ContactResult.shear_multiplier``); g_h the threshold the solution reports at every node (Tresca g;
  Coulomb mu p with p the representer lambda_h). The slip complementarity reads the traction the rows prescribe
  instead (``Friction.r``, the lumped read-back): a sliding row's force is g w_a, whose representer oscillates
  about g by a pattern the size of g at every mesh size and would charge every sliding face by a fixed fraction of
  g |[u_t]| whatever h.

On each cell S of the contact mesh (2D: the merged segments) two terms, in the estimator's units (J/m in 2D):

    friction cone      h_S / c_T ||(|t_h| - g_h)^+||_S^2
    slip complement    int_S (g_h |[u_ht]| + t_r . [u_ht])^+          (t_r = t_h but on 3D P2 faces)

g_h the threshold the solution reports (Tresca: g; Coulomb: mu p at each node, interpolated). Both vanish for
the exact solution; at a finished discrete solution they are not zero where a segment holds both a stuck and a
slipping node (the stick-slip transition, where the law holds at the rows but not between them): there they
localise. The traction mismatch h_E ||sigma_h n + lambda_h nu - t_h tau||^2 replaces the frictionless
h_E ||sigma_h n + lambda_h nu||^2 in the contact traction term (:mod:`cvxcontact.solution.estimate`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Friction", "friction_elements", "friction_of", "friction_points", "friction_segments",
           "nodal_vectors", "tangential_vectors"]


@dataclass(frozen=True)
class Friction:
    """A pair's friction law as the estimate reads it, at every node of X_h: ``t`` t_h (Pa; on the first body, along
    the pair's tangent, 3D (n, 2) along its frame), ``g`` g_h (n,) (Pa), ``s`` the slip [u_t] (m; like ``t``),
    ``r`` the traction the law's rows prescribe (Pa, like ``t``: ``t`` itself but on 3D P2 faces; module
    docstring)."""

    t: np.ndarray
    g: np.ndarray
    s: np.ndarray
    r: np.ndarray


def friction_of(sol, i: int) -> Friction | None:
    """The :class:`Friction` of pair ``i`` of ``sol`` (module docstring); None without a friction law on that pair
    (a frictionless pair beside a friction law's reads back a zero shear and no threshold: no friction terms)."""
    c = sol.contacts[i]
    if c.shear_force is None or c.threshold is None:
        return None
    t, r, g = c.trace.friction_fields(sol._pair_line(i), sol.scene.conditions[i] or sol.condition, c)
    return Friction(t=t, g=g, s=np.asarray(c.slip, dtype=float), r=r)


def friction_segments(f: Friction, contact, a, b, rule) -> tuple[np.ndarray, np.ndarray]:
    """2D: (int_S ((|t_h| - g_h)^+)^2 (Pa^2 m), int_S (g_h |[u_ht]| + t_r [u_ht])^+ (J/m)) on each merged
    segment S = [a, b] (m, tangential coordinates) of a pair's :class:`ContactResult` ``contact`` and
    :class:`Friction` ``f`` (module docstring), by the 1D Gauss ``rule`` (points on [0, 1], weights summing to 1)."""
    x = np.asarray(contact.x, dtype=float)
    h = b - a
    cone, slip = np.zeros(len(a)), np.zeros(len(a))
    for tq, w in zip(*rule):
        at = a + tq * h
        tv, rv, gv, sv = (contact.trace.values(x, v, at) for v in (f.t, f.r, f.g, f.s))
        cone += w * np.maximum(np.abs(tv) - gv, 0.0) ** 2
        slip += w * np.maximum(gv * np.abs(sv) + rv * sv, 0.0)
    return cone * h, slip * h


def tangential_vectors(f: Friction | None, frames, elements, N) -> tuple[np.ndarray, np.ndarray] | None:
    """3D: t_h as vectors t_h1 t_1 + t_h2 t_2 (Pa) with the rows' ``frames``
    (:func:`~cvxcontact.contact.interface.row_frames`: (2, 3), or (2, n, 3) turned per row) on the elements of X_h
    (``elements`` (e, 3 | 6), -1 outside X_h): (where t_h is not 0 on an element (e,) bool, its values (e, q, 3)
    at the rule's points of shape values ``N`` (q, 3 | 6)); None without a friction law (``f`` None)."""
    if f is None:
        return None
    nodal = nodal_vectors(f.t, frames)[elements]                                             # (e, k, 3)
    return (nodal != 0).any(axis=(1, 2)), np.einsum("qk,ek...->eq...", N, nodal)


def nodal_vectors(values, frames) -> np.ndarray:
    """3D: (n + 1, 3) the tangential ``values`` (n, 2) at the n nodes of X_h (t_h, t_r, the slip) as vectors
    along the rows' ``frames`` (as :func:`tangential_vectors`), and a last row of zeros (index -1: outside X_h)."""
    fr = np.asarray(frames, dtype=float)
    v = np.asarray(values, dtype=float)
    return np.concatenate([v[:, :1] * fr[0] + v[:, 1:] * fr[1], np.zeros((1, 3))])


def friction_points(t, g, s, r) -> tuple[np.ndarray, np.ndarray]:
    """3D: the integrands ((|t_h| - g_h)^+)^2 (Pa^2) and (g_h |[u_ht]| + t_r . [u_ht])^+ (Pa m) of
    :func:`friction_elements` at points, from vectors ``t``, ``s``, ``r`` (p, 3) and ``g`` (p,)."""
    cone = np.maximum(np.linalg.norm(t, axis=1) - g, 0.0) ** 2
    return cone, np.maximum(g * np.linalg.norm(s, axis=1) + (r * s).sum(axis=1), 0.0)


def friction_elements(f: Friction, elements, N, weights) -> tuple[np.ndarray, np.ndarray]:
    """3D: (int_S ((|t_h| - g_h)^+)^2 (Pa^2 m^2), int_S (g_h |[u_ht]| + t_r . [u_ht])^+ (J)) on each element S of
    X_h (``elements`` (e, 3 | 6): its nodes, -1 outside X_h) of the :class:`Friction` ``f``, by the rule of shape
    values ``N`` (q, 3 | 6) and weights ``weights`` (e, q) (the element's area times the rule's weights)."""

    def at(values):                                               # (e, q, ...) at the rule's points
        v = np.concatenate([values, np.zeros((1,) + values.shape[1:])])[elements]
        return np.einsum("qk,ek...->eq...", N, v)

    tq, rq, gq, sq = at(f.t), at(f.r), at(f.g), at(f.s)
    cone = np.maximum(np.linalg.norm(tq, axis=2) - gq, 0.0) ** 2
    slip = np.maximum(gq * np.linalg.norm(sq, axis=2) + (rq * sq).sum(axis=2), 0.0)
    return (weights * cone).sum(axis=1), (weights * slip).sum(axis=1)
