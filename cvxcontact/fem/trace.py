"""The traces of a space on the contact lines and surfaces: what the read-back, the error estimates and the
output ask of the functions of X_h (docs/formulation.md §3, §8, §15), so that none of them asks for the degree.

:class:`LinearTrace` (P1, Q1, P1 tetrahedra, Q1 hexahedra: X_h continuous piecewise linear on the merged
line or the overlay) and :class:`QuadraticTrace` (P2, Q2, P2 tetrahedra, Q2 hexahedra: continuous piecewise
quadratic; on a 2D line the nodes interleave vertices and segment midpoints, vertex first) answer the
vertices of a line's nodes, its lumped lengths, the values of a nodal function between the nodes, its VTK
line cells, a sampled curve for figures, the pressure a :class:`~cvxcontact.solution.solution.ContactResult`
reports, the pressure a body feels on its own trace and the tangential traction a friction law's error estimate
reads (``friction_fields``). :data:`TRACES` holds them by degree; a space names its own (``Space.trace``).
"""

from __future__ import annotations

import numpy as np

from ..contact.interface import lumped_lengths
from .p2 import shape_functions

__all__ = ["TRACES", "LinearTrace", "QuadraticTrace", "quadratic_curve", "quadratic_lumped"]


def quadratic_lumped(x) -> np.ndarray:
    """Row sums of the P2 mass matrix of the 1D mesh with interleaved nodes ``x`` (vertex, midpoint, ...), m:
    h/6 per adjacent segment at a vertex, 2h/3 at a midpoint."""
    x = np.asarray(x, dtype=float)
    h = x[2::2] - x[:-1:2]
    w = np.zeros_like(x)
    w[:-1:2] += h / 6
    w[2::2] += h / 6
    w[1::2] = 2 * h / 3
    return w


def quadratic_curve(x, values, samples: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """The continuous piecewise quadratic through P2 nodes ``x`` (vertices and midpoints alternating, sorted,
    2n + 1 of them) with nodal ``values``, sampled at ``samples`` points per segment: (xs, vs)."""
    x, v = np.asarray(x, dtype=float), np.asarray(values, dtype=float)
    t = np.linspace(0.0, 1.0, samples)
    basis = np.stack([2 * (t - 0.5) * (t - 1), 4 * t * (1 - t), 2 * t * (t - 0.5)])      # at t = 0, 1/2, 1
    xs = x[0:-1:2, None] + (x[2::2] - x[0:-1:2])[:, None] * t
    vs = v[0:-1:2, None] * basis[0] + v[1::2, None] * basis[1] + v[2::2, None] * basis[2]
    return xs.ravel(), vs.ravel()


class LinearTrace:
    """X_h continuous piecewise linear: the nodes of a 2D line are its vertices (module docstring)."""

    degree = 1
    step = 1
    """Nodes from one vertex of a 2D line to the next."""
    line = "line"
    """The meshio (VTK) cell type of a 2D contact line."""
    span, spacing = "face", ""
    """What lies between two neighbouring nodes of a 2D trace, and how a 3D message qualifies a face's size."""
    gamma3_cones = False
    """Whether "gamma3" (the condition everywhere on the contact line) is posed as cones on the elements of X_h
    (docs/formulation.md §8, §16); False: it reduces to nodal rows (a linear function is non-negative on an
    element if it is at its vertices)."""

    def vertices(self, x) -> np.ndarray:
        """The vertices among the sorted nodes ``x`` of a 2D line (m)."""
        return np.asarray(x)

    def lumped(self, x) -> np.ndarray:
        """The length attributed to each node of a 2D line of sorted nodes ``x`` (m): its mass matrix's row sums."""
        return lumped_lengths(np.asarray(x, dtype=float))

    def side_lengths(self, side) -> np.ndarray:
        """The length (2D, m) or area (3D, m^2) attributed to each node of one body's ``side`` of a pair (its
        trace: ``x``, in 3D ``lumped``): its lumped lengths or areas."""
        return np.asarray(side.lumped) if np.ndim(side.x) == 2 else self.lumped(side.x)

    def values(self, x, values, s) -> np.ndarray:
        """The function of nodal ``values`` on the 2D line of sorted nodes ``x`` at abscissae ``s`` inside it."""
        return np.interp(s, x, values)

    def line_cells(self, n: int) -> list[tuple[str, np.ndarray]]:
        """The cells of a 2D line of ``n`` nodes in order along it, as meshio blocks."""
        return [(self.line, np.column_stack([np.arange(n - 1), np.arange(1, n)]))]

    def curve(self, x, values):
        """A sampled curve through the nodal ``values`` for a figure, or None where the straight lines between
        the nodes are the function (here always)."""

    def elements(self, itf) -> np.ndarray:
        """(c, 3) the triangles of X_h of the 3D two-body pair ``itf`` (its overlay's), numbered as its nodes."""
        return np.asarray(itf.overlay.triangles)

    def shape_values(self, L) -> np.ndarray:
        """(k, 3): the functions of X_h on a triangle of :meth:`elements` at its barycentric coordinates ``L``
        (k, 3)."""
        return np.asarray(L, dtype=float)

    def kept(self, interface):
        """What a :class:`~cvxcontact.solution.solution.Solution` keeps of the contact lines' ``interface``
        (``Solution.interface``): None, the pairs being the scene's own (``scene.interfaces``)."""

    def measure(self, pair, condition: str) -> np.ndarray:
        """The quadrature weights of ``condition``'s rows of ``pair`` at its nodes of X_h (lengths in 2D, m;
        areas in 3D, m^2), 0 at the nodes without a row: what :attr:`ContactResult.pressure` divides by."""
        out = np.zeros(pair.size)
        out[pair.evaluation(condition).indices] = pair.weights(condition)
        return out

    def row_pressure(self, pair, condition: str, rows, forces) -> None:
        """None: the rows of ``condition`` sit at nodes of X_h, whose force over its :meth:`measure` is the row's
        force over its own weight (:meth:`pressure`)."""

    def row_shear(self, pair, condition: str, rows, forces) -> None:
        """None: as :meth:`row_pressure`, for the rows' tangential forces (:meth:`per_length`)."""

    def pressure(self, contact) -> np.ndarray:
        """The pressure (Pa) of a :class:`~cvxcontact.solution.solution.ContactResult`: each constrained node's
        force over its measure (the lumped length of the constrained nodes without one); 0 elsewhere."""
        out = np.zeros(len(contact.x))
        on = np.asarray(contact.constrained, dtype=bool)
        if contact.measure is not None:
            on = on & (contact.measure > 0)
            out[on] = contact.force[on] / contact.measure[on]
        elif on.sum() >= 2:
            out[on] = contact.force[on] / lumped_lengths(contact.x[on])
        return out

    def per_length(self, contact, force) -> np.ndarray:
        """Nodal forces ``force`` (N/m; (n,) or (n, c)) at the constrained nodes of a
        :class:`~cvxcontact.solution.solution.ContactResult` over their measures (Pa), 0 elsewhere (e.g. the
        tangential traction from the shear forces)."""
        out = np.zeros(np.shape(force))
        on = np.asarray(contact.constrained, dtype=bool) & (contact.measure > 0)
        out[on] = force[on] / contact.measure[on].reshape((-1,) + (1,) * (out.ndim - 1))
        return out

    def felt(self, itf, k: int, force) -> np.ndarray:
        """The pressure (Pa) side ``k`` of the pair ``itf`` feels at its own trace nodes under the nodal
        forces ``force`` on the nodes of X_h."""
        return itf.pressure(k, force)

    def shear_multiplier(self, lines, forces, read) -> None:
        """None: t_h is the lumped read-back of the rows' forces (:meth:`friction_fields`), not a representer of
        the tangential ``forces`` of the contact ``lines``."""

    def friction_fields(self, itf, condition: str, contact) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t_h, t_r, g_h) at every node of X_h of the pair ``itf``: the tangential traction t_h (Pa, on the
        first body; (n,) along the pair's tangent in 2D, (n, 2) along its frame in 3D), the traction the
        law's rows prescribe t_r (like t_h: here t_h itself) and the slip threshold (Pa, (n,)) the error
        estimate reads from the friction law of the :class:`~cvxcontact.solution.solution.ContactResult`
        ``contact`` solved under ``condition`` (docs/accuracy.md, "Friction"). The lumped read-back: each
        row's force over the length (area) it holds
        (:attr:`~cvxcontact.solution.solution.ContactResult.shear`), the function of the rows' values
        (``itf.extend``: under "sigma1"/"sigma2" the nodes without a row take the constrained side's
        function); the threshold likewise. Exact for a uniform traction, whose consistent nodal loads are
        the lumped weights times it (P1; Simpson's h/6, 2h/3 on a 2D P2 line), and the traction the rows
        prescribe (a sliding row's force is g w_a: t_h = g there)."""
        E = itf.evaluation(condition)

        def extend(values):                        # the function of the rows' values, at every node of X_h
            v = np.asarray(values, dtype=float)
            cols = [itf.extend(condition, E @ col) for col in v.reshape(len(v), -1).T]
            return np.column_stack(cols).reshape(v.shape)

        t = extend(contact.shear)
        return t, t, extend(np.broadcast_to(np.asarray(contact.threshold, dtype=float), len(contact.slip)))


class QuadraticTrace(LinearTrace):
    """X_h continuous piecewise quadratic: a 2D line's nodes interleave vertices and midpoints (module
    docstring)."""

    degree = 2
    step = 2
    line = "line3"
    span, spacing = "half-face", " between P2 nodes"
    gamma3_cones = True

    def vertices(self, x) -> np.ndarray:
        return np.asarray(x)[::2]

    def lumped(self, x) -> np.ndarray:
        return quadratic_lumped(x)

    def side_lengths(self, side) -> np.ndarray:
        """2D: the P2 lumped lengths of the side's nodes; 3D: the integral of each P2 function of its faces (its
        mass matrix's row sums, 0 at the vertices)."""
        return np.asarray(side.mass.sum(axis=1)).ravel() if np.ndim(side.x) == 2 else self.lumped(side.x)

    def values(self, x, values, s) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        xv = x[::2]
        j = np.clip(np.searchsorted(xv, s) - 1, 0, len(xv) - 2)
        t = (s - xv[j]) / (xv[j + 1] - xv[j])
        return (values[2 * j] * (1 - t) * (1 - 2 * t) + values[2 * j + 2] * t * (2 * t - 1)
                + values[2 * j + 1] * 4 * t * (1 - t))

    def line_cells(self, n: int) -> list[tuple[str, np.ndarray]]:
        """``line3`` cells (end, end, midpoint) of a line of ``n`` interleaved nodes."""
        i = 2 * np.arange((n - 1) // 2)
        return [(self.line, np.column_stack([i, i + 2, i + 1]))]

    def curve(self, x, values, samples: int = 9):
        """The piecewise quadratic through the nodes ``x`` (2n + 1 of them, interleaved) sampled at ``samples``
        points per segment, (xs, vs); None if ``x`` is not such a line."""
        if len(x) < 3 or len(x) % 2 != 1:
            return None
        return quadratic_curve(x, values, samples)

    def elements(self, itf) -> np.ndarray:
        """(c, 6) the 6-node triangles of X_h of the 3D pair ``itf`` (its ``cells``; triangle6 order)."""
        return np.asarray(itf.cells)

    def shape_values(self, L) -> np.ndarray:
        """(k, 6): the triangle6 functions (v0, v1, v2, m01, m12, m20) at barycentric coordinates ``L`` (k, 3)."""
        return shape_functions(np.asarray(L, dtype=float))

    def kept(self, interface):
        """The quadratic interface (or stack) the pairs' P2 nodes are read from."""
        return interface

    def measure(self, pair, condition: str) -> None:
        """None: the forces M lambda_h live on every node of X_h (:meth:`pressure`)."""

    @staticmethod
    def _own(pair, condition: str, rows) -> bool:
        """Whether the sparse ``rows`` are ``condition``'s own rows of ``pair`` (``pair.evaluation(condition)``),
        whose weights the pair holds; not rows a problem was given."""
        own = pair.evaluation(condition)
        return own.shape == rows.shape and not np.abs((own - rows).tocsr().data).max(initial=0.0) > 0

    def row_pressure(self, pair, condition: str, rows, forces) -> np.ndarray | None:
        """The pressure (Pa) at every node of X_h of the rows' normal ``forces`` (one per row of ``rows``, the
        sparse evaluation rows the problem posed on ``pair``'s nodes of X_h; N/m in 2D, N in 3D) read on the
        condition's own nodes, extended to every node of X_h as the function of the rows' values
        (``pair.extend``): a uniform p reads p exactly, the rows being where the forces were made. On a 2D line
        each row's force over its own weight (``pair.weights(condition)``, Simpson's on the constrained trace, the
        cut segments' shares, m), the integral of its P2 function. On a 3D surface under "sigma1"/"sigma2", where
        the P2 functions of a vertex integrate to 0, the Riesz representer in the P2 functions of that body's own
        faces (``pair.row_riesz``: M p = forces, M their P2 mass, the cut faces' weights on its diagonal; the
        consistent loads of a uniform p are 0 at the vertices and pA/3 at the edge midpoints). (The forces E^T y on
        the nodes of X_h over the row sums of X_h's mass matrix, or their representer lambda_h in X_h, would not
        read p: the rows are that body's P2 nodes, and E^T w is not M 1.) None on a 3D surface under "gamma3" and
        against an obstacle (the rows are the nodes of X_h: lambda_h is the rows' representer), and where ``rows``
        are not ``condition``'s own (rows a problem was given, which hold no weights)."""
        forces = np.asarray(forces, dtype=float)
        if np.ndim(pair.x) == 1:
            return self._over_weights(pair, condition, rows, forces)
        if self._on_nodes(pair, condition):
            return None
        if len(forces) == 0:                            # a pair with no row in its overlap (ResolutionWarning)
            return np.zeros(pair.size)
        if not self._own(pair, condition, rows):
            return None
        return pair.extend(condition, pair.row_riesz(condition, forces))

    @staticmethod
    def _on_nodes(pair, condition: str) -> bool:
        """Whether the 3D ``pair`` reads its rows' forces at its nodes of X_h as it is (None from :meth:`row_pressure`
        and :meth:`row_shear`): under "gamma3" and against an obstacle (the rows are the nodes of X_h: lambda_h is
        their representer, a row's force over its measure its own weight's), and a pair given its own pressure's
        representer (``pair.representer``: Q2 hexahedra's faces, whose consistent loads are not the triangles')."""
        return bool(pair.rigid or condition == "gamma3" or pair.representer is not None)

    def row_shear(self, pair, condition: str, rows, forces) -> np.ndarray | None:
        """The tangential traction (Pa) at every node of X_h of the rows' tangential ``forces`` ((r,), or (r, c)
        per component; N/m in 2D, N in 3D): each row's force over its own weight (``pair.weights(condition)``, the
        areas or lengths that weigh the friction capacities g w_a, so that |t| <= g at every row under Tresca),
        extended to every node of X_h as the function of the rows' values (``pair.extend``, per component). On a
        2D line as :meth:`row_pressure`. On a 3D surface the weights are the red refinement's (A/12 at a vertex,
        A/4 at an edge midpoint; the cut faces' shares): a sliding row reads g, a uniform traction that sticks
        reads 0 and 4/3 of itself (its consistent loads are 0 and A/3). None where ``rows`` are not
        ``condition``'s own, and on a 3D surface where the rows are the nodes of X_h (:meth:`_on_nodes`: there
        :meth:`per_length` reads the same ratio at them)."""
        if np.ndim(pair.x) == 2 and self._on_nodes(pair, condition):
            return None
        return self._over_weights(pair, condition, rows, np.asarray(forces, dtype=float))

    def _over_weights(self, pair, condition: str, rows, forces) -> np.ndarray | None:
        """Each row's ``forces`` ((r,) or (r, c)) over its own weight, extended to every node of X_h (per
        component); None where ``rows`` are not ``condition``'s own."""
        if len(forces) == 0:
            return np.zeros((pair.size,) + forces.shape[1:])
        if not self._own(pair, condition, rows):
            return None
        v = forces / np.asarray(pair.weights(condition), dtype=float).reshape((-1,) + (1,) * (forces.ndim - 1))
        cols = [pair.extend(condition, col) for col in v.reshape(len(v), -1).T]
        return np.column_stack(cols).reshape((pair.size,) + forces.shape[1:])

    def pressure(self, contact) -> np.ndarray:
        """The rows' forces read on the condition's own nodes (``contact.row_pressure``, :meth:`row_pressure`): on
        a 2D line 0 at the nodes no row reads; on a 3D surface at every node of X_h (the function of the
        constrained body's trace on the overlap). Without it: on a 2D line the forces r = M lambda_h over the row
        sums of the P2 mass matrix of X_h; on a 3D surface ("gamma3", an obstacle, a compliance law), where those
        row sums vanish at the vertices, lambda_h itself."""
        if contact.row_pressure is None:
            if np.ndim(contact.x) == 2:
                return np.array(contact.lam, dtype=float)
            return contact.force / quadratic_lumped(contact.x)
        if np.ndim(contact.x) == 2:
            return np.array(contact.row_pressure, dtype=float)
        return np.where(np.asarray(contact.constrained, dtype=bool), contact.row_pressure, 0.0)

    def per_length(self, contact, force) -> np.ndarray:
        """The rows' tangential forces over their own weights (``contact.row_shear``, :meth:`row_shear`, for the
        tangential forces ``force`` = ``contact.shear_force``; on a 2D line 0 at the nodes no row reads, on a 3D
        surface at every node of X_h). Without it: on a 2D line the forces over the row sums of the P2 mass matrix
        of X_h; on a 3D surface, where those vanish at the vertices, over the areas the friction law's rows give
        the nodes (``contact.slip_measure``, the pair's ``weights``: the red-refinement lumping on P2 tetrahedra's
        faces, the biquadratic hats' integrals on Q2 hexahedra's; positive; 0 where it is 0)."""
        if contact.row_shear is not None and np.shape(force) == np.shape(contact.row_shear):
            if np.ndim(contact.x) == 2:
                return np.array(contact.row_shear, dtype=float)
            return np.where(np.asarray(contact.constrained, dtype=bool), contact.row_shear, 0.0)
        if np.ndim(contact.x) == 1:
            return force / quadratic_lumped(contact.x)
        w = np.asarray(contact.slip_measure, dtype=float)
        out = np.zeros(np.shape(force))
        on = w > 0
        out[on] = force[on] / w[on].reshape((-1,) + (1,) * (out.ndim - 1))
        return out

    def felt(self, itf, k: int, force) -> np.ndarray:
        """2D: the forces moved to side ``k``'s P2 nodes over their P2 lumped lengths; 3D: the pair's own
        (``itf.pressure``: the Riesz pressure on its P2 faces; on Q2 hexahedral faces the forces over the
        biquadratic hats' integrals)."""
        if getattr(itf, "dim", 2) == 3:
            return itf.pressure(k, force)
        return (itf.interpolation(k).T @ force) / quadratic_lumped(itf.traces[k].x)

    def shear_multiplier(self, lines, forces, read) -> np.ndarray | None:
        """3D: t_h (per unit area of ``forces``' unit: Pa from N) at the stacked nodes of X_h of the contact
        ``lines`` (one pair or their stack), the Riesz representer of the tangential nodal ``forces`` (size, 2)
        in X_h per component as ``read`` (stacked forces -> lambda_h: the lines' multiplier read once per side,
        :mod:`cvxcontact.solution.sides`) reads lambda_h; what :meth:`friction_fields` reads
        (``contact.shear_multiplier``). 2D: None (the lumped read-back)."""
        first = lines.interfaces[0] if hasattr(lines, "interfaces") else lines
        if np.ndim(first.x) == 1:
            return None
        f = np.asarray(forces, dtype=float)
        return np.column_stack([read(col) for col in f.reshape(len(f), -1).T]).reshape(f.shape)

    def friction_fields(self, itf, condition: str, contact) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """2D: the lumped read-back (:meth:`LinearTrace.friction_fields`; Simpson's weights are the consistent
        loads of a constant). 3D: t_h the Riesz representer of the row forces in X_h, per tangential component,
        M t_h = f as lambda_h (``itf.multiplier``; f = ``contact.shear_force``, N): the nodal loads of a uniform
        traction on 6-node triangles are 0 at the vertices and A/3 at the midpoints, so the force over the rows'
        areas (A/12, A/4: :attr:`~cvxcontact.solution.solution.ContactResult.shear`) would read a uniform tau as
        0 and 4/3 tau, whose interpolant reaches 16/9 tau inside. t_r the lumped read-back (the rows' law: a
        sliding row's force g w_a is t_r = g, whose representer oscillates about g by a pattern the size of g
        at every h). g_h the threshold the solution reports at every node of X_h (Tresca g; Coulomb under
        "sigma1"/"sigma2" the rows' capacities mu y_a over their own weights, as t_r reads the shear). t_h read once
        per side where the read-back did (``contact.shear_multiplier``, :meth:`shear_multiplier`), else the pair's
        own representer."""
        if np.ndim(contact.x) == 1:
            return super().friction_fields(itf, condition, contact)
        f = np.asarray(contact.shear_force, dtype=float)
        t = getattr(contact, "shear_multiplier", None)
        if t is None:
            t = np.column_stack([itf.multiplier(col) for col in f.reshape(len(f), -1).T]).reshape(f.shape)
        rows = super().friction_fields(itf, condition, contact)[1]
        return t, rows, np.broadcast_to(np.asarray(contact.threshold, dtype=float), (len(f),)).copy()


TRACES = {1: LinearTrace(), 2: QuadraticTrace()}
"""The traces by the degree of X_h (``Space.degree``, ``ContactResult.degree``)."""
