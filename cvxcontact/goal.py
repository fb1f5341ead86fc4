"""Goal-oriented estimate of the total contact force of a pair (docs/accuracy.md, "The total contact force:
cc.force_estimate").

The quantity read is F = int_{A} lambda (N/m in 2D): the resultant of the contact pressure of pair ``i``
over its contact zone A. With A held fixed (the solution's active rows as equalities), F is a linear
functional of the solution, F = a(u, z) - l(z) for any z with normal jump [z nu] = 1 on A, and the dual
solution z (a(v, z) = 0 for every v with [v nu] = 0 on A, [z nu] = 1 on A, no loads, the Dirichlet parts
homogeneous) makes the error a product of the two discretisation errors,

    F - F_h = a(u - u_h, z - z_h)   (Galerkin orthogonality of both problems on the same active set),

so |F - F_h| <= |||u - u_h||| |||z - z_h|||. The estimate replaces both errors by the residual estimator of
:mod:`cvxcontact.solution.estimate`: eta_F = eta(u_h) eta(z_h) (N/m), with cell indicators
eta_T(u_h) eta_T(z_h) (their sum is at most eta_F, Cauchy-Schwarz). z_h is solved with the same element, mesh
and contact condition as u_h: the scene with its loads removed (body forces, tractions, charges zero; the
prescribed displacements and potentials zero) and the pair's gap replaced by -delta on the solution's active
nodes and +delta elsewhere (delta a length of the solution's scale; z_h = u_h(dual) / delta), so that the
contact rows of A are pressed apart by delta; its estimate drops the complementarity and penetration terms
(the dual's contact rows are equalities).

Not guaranteed: the estimator's constants are unknown, the active set of the exact solution is not the
discrete one, and the product is a Cauchy-Schwarz bound that ignores how e_u and e_z align (it overestimates
when they do not). The measured effectivity is in docs/accuracy.md. Covered: 2D, P1 and P2, Signorini
conditions, pairs of bodies and fixed rigid obstacles (the dual replaces the obstacle by the plane of the
part: rows along its normal, which a curved obstacle posed at the closest point does not have exactly); not
covered (a typed error): a force-controlled obstacle (its force is prescribed), normal compliance (its force is
not the multiplier of an equality), 3D.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SceneError, UnsupportedError
from .physics.pairs import Rigid
from .physics.scene import Scene
from .solution.estimate import estimate as residual_estimate
from .solution.estimate import read_only
from .solve import ContactSolver, Solution

__all__ = ["ForceEstimate", "force_estimate"]


@dataclass(frozen=True)
class ForceEstimate:
    """The estimated error of the total contact force of one pair (module docstring).

    ``absolute``: eta_F = eta(u_h) eta(z_h) (N/m in 2D); ``force``: F_h, the sum of the pair's nodal contact
    forces (N/m); ``relative`` = absolute / |force|. ``indicators[k]`` (m_k,): eta_T(u_h) eta_T(z_h) of each
    cell of body k (N/m). ``primal``: eta(u_h) (sqrt(J/m)); ``dual``: eta(z_h) (sqrt(J/m) per m of normal
    jump). ``held``: the fraction of the solution's active nodes that the dual solve kept in contact (1: the
    dual is the linearised problem on the active set). ``guaranteed``: False (module docstring).
    """

    absolute: float
    force: float
    indicators: tuple
    primal: float
    dual: float
    pair: int
    held: float
    guaranteed: bool = False
    kind: str = "dual-weighted (product)"
    unit: str = "N/m"

    @property
    def relative(self) -> float:
        """absolute / |force| (dimensionless); inf for a zero force with a non-zero estimate."""
        if self.force != 0:
            return self.absolute / abs(self.force)
        return 0.0 if self.absolute == 0 else float("inf")

    def __str__(self) -> str:
        return (f"{100 * self.relative:.3g} % ({self.kind}, not guaranteed; {self.absolute:.4g} of "
                f"{self.force:.4g} {self.unit}, pair {self.pair})")


def force_estimate(sol: Solution, pair: int = 0, **options) -> ForceEstimate:
    """The goal-oriented estimate of the error of pair ``pair``'s total contact force (N/m).

    The dual problem, the estimate and what it measured:
    docs/accuracy.md, "The total contact force: cc.force_estimate".

    Parameters
    ----------
    sol : Solution
        A 2D solution (P1 or P2, Signorini conditions, fixed obstacles).
    pair : int
        The index of the pair in ``sol.scene.contacts``.
    **options : dict, optional
        Passed to the dual's :class:`~cvxcontact.solve.ContactSolver` (``method``, ``tol``, ...); the
        condition and degree are the solution's.

    Returns
    -------
    ForceEstimate
        Costs one more solve of the same size (the dual).

    Raises
    ------
    UnsupportedError
        For a 3D scene, a force-controlled obstacle, a compliance law or a friction law in the scene.
    SceneError
        For a ``pair`` that is not an index into ``sol.scene.contacts``.
    """
    scene = sol.scene
    if scene.dim != 2:
        raise UnsupportedError(f"force_estimate covers 2D scenes, got a {scene.dim}D one: its dual gap is a "
                               "function of the tangential coordinate s; use sol.estimate (energy norm) in 3D")
    n = len(sol.contacts)
    if isinstance(pair, bool) or not isinstance(pair, (int, np.integer)) or not 0 <= pair < n:
        raise SceneError(f"force_estimate: pair must be an index 0..{n - 1} into scene.contacts, got {pair!r}")
    forced = [c for c in scene.contacts if c.rigid and c.other.force is not None]
    if forced:
        raise UnsupportedError(f"force_estimate: {forced[0]} is pressed by a prescribed force, which is then the "
                               "pair's force (no discretisation error); fix the obstacle (Rigid.with_force(None)) "
                               "to estimate the force of a prescribed position")
    if any(c.shear_force is not None for c in sol.contacts):
        raise UnsupportedError("force_estimate covers frictionless contact; with a friction law the dual problem "
                               "is not posed yet: read sol.estimate (energy norm), which counts the friction law")
    if any(c.law is not None and getattr(c.law, "compliant", False) for c in sol.contacts):
        raise UnsupportedError("force_estimate covers Signorini conditions; under normal compliance the force "
                               "is the law's, not the multiplier of an equality: read sol.estimate")
    delta = float(max(np.abs(u).max() for u in sol.u)) or 1e-6        # m: a length of the solution's scale
    dual = ContactSolver(dual_scene(sol, pair, delta), sol.condition, degree=sol.degree, estimate=False,
                         **options).solve()
    est_u = sol.estimate if sol.estimate is not None else residual_estimate(sol)[0]
    est_z = residual_estimate(dual, signorini=False)[0]
    eta_z = [e / delta for e in est_z.indicators]
    active = np.asarray(sol.contacts[pair].active, dtype=bool)
    held = float((active & np.asarray(dual.contacts[pair].active, dtype=bool)).sum() / max(active.sum(), 1))
    indicators = tuple(read_only(a * b) for a, b in zip(est_u.indicators, eta_z))
    return ForceEstimate(absolute=est_u.absolute * est_z.absolute / delta,
                         force=float(np.sum(sol.contacts[pair].force)), indicators=indicators,
                         primal=est_u.absolute, dual=est_z.absolute / delta, pair=int(pair), held=held)


def dual_scene(sol: Solution, pair: int, delta: float):
    """The scene of the dual problem of pair ``pair``'s force (module docstring): ``sol.scene`` without loads
    (zero prescribed displacements and potentials), pair ``pair``'s gap -``delta`` (m) on the solution's active
    nodes and +``delta`` elsewhere, every other pair's gap 0 on its active nodes and +``delta`` elsewhere."""
    scene = sol.scene
    dim = scene.dim
    bodies = []
    for b in scene.bodies:
        if b.displacement:
            b = b.with_changes(displacement={t: tuple(None if x is None else 0.0 for x in v)
                                             for t, v in b.displacement.items()})
        loads = dict(body_force=(0.0,) * dim, traction={}, surface_charge={}, volume_charge=0.0)
        if b.potential:
            loads["potential"] = dict.fromkeys(b.potential, 0.0)
        if b.floating:
            loads["floating"] = dict.fromkeys(b.floating, 0.0)
        bodies.append(b.with_loads(**loads))
    out = scene.with_bodies(*bodies)
    gaps = [_step(np.asarray(c.x, dtype=float), np.asarray(c.active, dtype=float), -delta if i == pair else 0.0,
                  delta) for i, c in enumerate(sol.contacts)]
    if not any(c.rigid for c in out.contacts):
        for i, g in enumerate(gaps):
            out = out.with_gap(g, pair=i)
        return out
    return Scene(*out.bodies, contacts=[c.with_changes(other=_plane(c), gap=g) if c.rigid else c.with_changes(gap=g)
                                        for c, g in zip(out.contacts, gaps)])


def _plane(pair) -> Rigid:
    """A fixed rigid half-plane whose boundary is the line of ``pair``'s straight part, facing it: the distance
    to it is 0 along the part, so the pair's gap alone poses the dual's rows, along the part's normal (a curved
    obstacle posed at the closest point has rows along its own normals: they differ by the angle the contact
    zone spans on it, a / R for a circle)."""
    mesh = pair.body_a.mesh
    n = mesh.outward_normals(pair.part_a).mean(axis=0)
    return Rigid.plane(mesh.points[np.asarray(mesh.boundary(pair.part_a))[0, 0]], -n / np.linalg.norm(n))


def _step(x, active, inside, outside):
    """g(s): ``inside`` at the merged nodes ``x`` marked ``active`` (and between two such), ``outside`` elsewhere."""
    return lambda s: np.where(np.interp(s, x, active) > 0.5, inside, outside)
