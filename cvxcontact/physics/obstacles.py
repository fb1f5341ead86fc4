"""How each rigid obstacle's translation t (m) enters a scene's stacked contact rows, and the force balance check.

A rigid obstacle (:class:`~cvxcontact.physics.pairs.Rigid`) moved by t changes the condition at a node x of its
pairs to u . nu <= g(x) - c(x) . t, c(x) its sensitivity (docs/formulation.md §12). :func:`obstacle_rows` gathers
each distinct obstacle's rows c(x) at the scene's stacked merged nodes (:class:`ObstacleRows`) and, for a
force-controlled obstacle, checks before solving that compressive contact can balance its prescribed force.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from ..errors import SceneError
from .surfaces import fmt

if TYPE_CHECKING:
    from .pairs import Rigid

__all__ = ["ObstacleRows", "obstacle_rows"]


def unit_direction(v) -> np.ndarray:
    """The unit vector of v with components below 1e-12 of it set to 0 (rounding, not a direction)."""
    v = np.asarray(v, dtype=float) / np.linalg.norm(v)
    return np.where(np.abs(v) < 1e-12, 0.0, v)



@dataclass(frozen=True)
class ObstacleRows:
    """One rigid obstacle of a scene and how its translation t (m) enters the stacked contact rows.

    ``pairs`` are the indices (in ``scene.contacts``) of its pairs; ``rows`` (stack size, dim) the
    sensitivities c(x) of :meth:`~cvxcontact.physics.pairs.Rigid.sensitivity` at the stacked merged nodes (0 on
    other pairs' rows): with t the condition at a node reads u . nu <= g(x) - c(x) . t (docs/formulation.md §12).
    ``force`` is the prescribed resultant (N/m; N in 3D) or None; for a force-controlled obstacle
    ``basis`` (dim, k) spans the translations the contact can see (k = 1 when every c(x) is parallel,
    e.g. a plane: its tangential translations change nothing and are not unknowns; k = 2 for a 3D
    cylinder, whose translations along its axis change nothing; k = dim otherwise; a guided obstacle's
    rows and basis lie along its axes), and the unknowns are t = basis @ tau.
    """

    obstacle: Rigid
    pairs: tuple
    rows: sp.csr_matrix
    force: np.ndarray | None
    basis: np.ndarray

    @property
    def reduced_rows(self) -> sp.csr_matrix:
        """(stack size, k): the rows on the unknowns tau (``rows @ basis``)."""
        return sp.csr_matrix(self.rows @ self.basis)


def obstacle_rows(scene) -> tuple[ObstacleRows, ...]:
    """The :class:`ObstacleRows` of every distinct rigid obstacle of ``scene`` (an obstacle shared by
    several pairs moves as one). For a force-controlled obstacle the prescribed force F must be
    balanced by compressive contact forces y >= 0 at its nodes, F = sum_a y_a c_a (the stationarity of
    the energy in t): SceneError, naming the free direction, if F lies outside the cone of the c_a
    (a force pulling the obstacle away from every body, or a plane's tangential force component,
    which frictionless contact cannot balance)."""
    from scipy.optimize import nnls

    stack = scene.stack
    out, seen = [], {}
    for i, (c, itf) in enumerate(zip(scene.contacts, scene.interfaces)):
        if c.rigid:
            seen.setdefault(id(c.other), (c.other, []))[1].append(i)
    for obstacle, pairs in seen.values():
        dim = obstacle.dim
        rows = np.zeros((stack.size, dim))
        for i in pairs:
            itf = scene.interfaces[i]
            rows[stack.offsets[i]:stack.offsets[i + 1]] = obstacle.sensitivity(itf.points, itf.normal)
        F = obstacle.force
        basis = np.eye(dim)
        if F is not None:
            label = f"{obstacle!r} (pairs {pairs})"
            scale = float(np.linalg.norm(rows, axis=1).max(initial=0.0))
            _, sv, Vt = np.linalg.svd(rows, full_matrices=False)
            if not scale > 0:
                if obstacle.guided is not None:
                    raise SceneError(f"{label}: a translation along its guided axes changes no distance to its "
                                     "pairs' nodes, so no contact force can balance the prescribed force: guide it "
                                     "along a direction that presses it onto the bodies (e.g. the contact's normal)")
                raise SceneError(f"{label}: no node of its pairs sees the obstacle move (its distance is finite at "
                                 "isolated nodes only), so no contact force can balance the prescribed force: give "
                                 "the obstacle a shape that faces the part around the nodes it reaches, or no force "
                                 "(a fixed obstacle)")
            unit = "N/m" if dim == 2 else "N"
            rank = int((sv > 1e-9 * sv[0]).sum())
            if rank < dim:                                  # translations the contact does not see
                basis = Vt[:rank].T * np.sign(rows @ Vt[:rank].T)[np.argmax(np.abs(rows @ Vt[:rank].T), axis=0),
                                                                    np.arange(rank)]
                off = F - basis @ (basis.T @ F)             # the force's part along the unseen translations
                if np.linalg.norm(off) > 1e-9 * np.linalg.norm(F):
                    side = unit_direction(off)
                    along = "its normal " + fmt(basis[:, 0] + 0.0) if rank == 1 else \
                        "the directions " + ", ".join(fmt(b + 0.0) for b in basis.T)
                    seen = int((np.abs(rows) > 0).any(axis=1).sum())
                    few = "" if obstacle.kind in ("plane", "cylinder") else (
                        f" (only {seen} node{'s' if seen != 1 else ''} of its pairs {'lie' if seen != 1 else 'lies'}"
                        f" within its reach, too few to hold it in {dim} directions: refine the mesh under it, "
                        f"cells well below its size, or guide it with guided=<the force's direction>)")
                    raise SceneError(
                        f"{label}: the force {fmt(F)} {unit} has a component {np.linalg.norm(off):.6g} {unit} along "
                        f"{fmt(side)}, which frictionless contact cannot balance: the obstacle is free to slide "
                        f"along {fmt(side)}; give a force along {along} only{few}")
            y, res = nnls(rows.T / scale, F)
            if res > 1e-9 * np.linalg.norm(F):
                r = F - rows.T @ y / scale
                r = unit_direction(r)
                raise SceneError(
                    f"{label}: the force {fmt(F)} {unit} pulls the obstacle away from the bodies "
                    f"(compressive contact forces cannot balance it): the obstacle is free to move along "
                    f"{fmt(r)}; give a force pressing it onto the bodies")
        basis = np.array(basis)
        basis.setflags(write=False)
        out.append(ObstacleRows(obstacle, tuple(pairs), sp.csr_matrix(rows), F, basis))
    return tuple(out)
