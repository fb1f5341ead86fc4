"""Adaptive refinement (2D and 3D): solve, estimate, mark, refine, until the estimate or a budget says stop.

Each step solves the scene (:func:`cvxcontact.solve.ContactSolver`), reads the error estimate's indicators
eta_T of every body (:mod:`cvxcontact.solution.estimate`, docs/accuracy.md), marks by Dorfler's bulk
criterion on all bodies together (:func:`mark_bulk`: the fewest cells, largest first, whose eta_T^2 sum to
``theta`` times the total) and bisects them (:func:`cvxcontact.geometry.refine.refine_marked`: newest-vertex
bisection of triangles, longest-edge bisection of tetrahedra, both with conforming closure; a tensor grid of
quadrilaterals or hexahedra: its strips through them halved, below); with ``rate``, each
marked cell as often as its indicator predicts (:func:`mark_bisections`, "h-prediction";
:func:`~cvxcontact.geometry.refine.refine_times`): fewer steps to grade the mesh. The scene is rebuilt on the
refined meshes (``Body.with_changes(mesh=...)``, ``Scene.with_bodies``: loads, parts, pairs, gaps and obstacles
kept); each body is refined on its own, so the two sides of a pair need not match (the merged mesh of the pair
is rebuilt by the next solve).

Each solve after the first starts from the previous step's contact forces (``ContactSolver(..., start=sol)``,
:mod:`cvxcontact.backends.start`: point loads along the contact lines, in 3D at the overlay's vertices in the
pair's plane, which do not depend on the mesh): a nodal condition's first active set (2D and 3D), the 2D P2
"gamma3" cuts' first points, instead of an interior point (on the sparse and AMG routes: instead of the rows the
obstacles close); the answer is the exact finish's as from a cold start (``warm_start=False`` among the options
solves every step cold). 3D P2 "gamma3" (copositive cones) starts every step cold. With ``exact_steps=False``
the steps before the last keep the interior point's answer (no exact finish, no state handed on: the next
step's interior point starts cold) and the mesh the loop stops on is solved with the exact finish: the answer
returned is exact and checked either way. The fields are not carried over: the routes adapt uses solve the
bodies directly.

Covered: 2D and 3D, P1 and P2 on triangles and tetrahedra, Q1 and Q2 on quadrilaterals and hexahedra whose mesh is
a tensor grid (its nodes the product of sorted x, y (z) coordinate lists, its cells the grid's cells:
:func:`cvxcontact.geometry.grid.tensor_grid`, found from the mesh; ``cc.rectangle``, ``cc.graded_block``,
``cc.box`` with ``cell="quad"`` or ``"hex"``). A grid is refined without hanging nodes by halving every column and
row (slab in 3D) that holds a marked cell (:func:`cvxcontact.geometry.grid.refine_grid`, through
:func:`cvxcontact.geometry.refine.refine_local`), once a step whatever ``rate`` asks (a strip halved k times
multiplies every cell along it by 2^k): the cost is that the whole strip through a marked cell is refined, a
graded grid whose unknowns grow as the strips' lengths, not as the marked cells (on the Q1 block under a rigid
circle of tests/test_adapt_grid.py the estimate still falls faster per unknown than under uniform refinement:
benchmarks/results/adapt_grid.md). In 3D a curved boundary stays the faceted surface of the first mesh: new
boundary nodes are the midpoints of the facets' edges (``curves`` is 2D triangles only); a rigid obstacle is
exact whatever the mesh. Not covered: quadrilaterals and hexahedra that are not a tensor grid (an unstructured
gmsh mesh, a grid turned out of the axes): :class:`~cvxcontact.errors.UnsupportedError` naming the alternatives,
triangles or tetrahedra, or a tensor grid; two hexahedral bodies in contact on Q2 cells (their contact faces must
match corner to corner, which refining each body on its own does not keep: the second step's solve raises).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .errors import (
    ResidualWarning,
    ResolutionWarning,
    SceneError,
    UnsupportedError,
    reissue,
    user_stacklevel,
)
from .fem.space import needs_matching_faces, space
from .geometry.refine import Curve, local_refusal, refine_together, start_local
from .goal import force_estimate
from .physics.scene import Scene
from .solve import ContactSolver, Solution

__all__ = ["LOOPS", "TARGETS", "AdaptStep", "Adapted", "Loop", "adapt", "mark_bisections", "mark_bulk", "peak_pressure",
           "unknowns"]


def _force_target(sol):
    est = force_estimate(sol)
    return est.indicators, est.relative


TARGETS: dict[str, Callable[[Solution], tuple]] = {
    "energy": lambda sol: (sol.estimate.indicators, sol.estimate.relative),
    "force": _force_target,
}
"""What :func:`adapt` refines for (``target=``): name -> sol -> (the cell indicators it marks by, one array per
body; the relative estimate ``tol`` reads): "energy", the residual estimate (docs/accuracy.md); "force", the
first pair's total contact force (:func:`cvxcontact.goal.force_estimate`: one more solve per step)."""


@dataclass(frozen=True)
class Loop:
    """How :func:`adapt` marks and solves by default: Dorfler's ``theta``, the bisections' ``rate``
    (:func:`mark_bisections`; ``math.inf``: each marked cell once) and ``exact_steps``."""

    theta: float
    rate: float
    exact_steps: bool


LOOPS: dict[tuple[int, int], Loop] = {
    (2, 1): Loop(theta=0.5, rate=float("inf"), exact_steps=True),
    (2, 2): Loop(theta=0.9, rate=1.0, exact_steps=False),
    (3, 1): Loop(theta=0.5, rate=float("inf"), exact_steps=True),
    (3, 2): Loop(theta=0.5, rate=float("inf"), exact_steps=True),
}
"""(dimension, degree) -> the :class:`Loop` whose values :func:`adapt` takes for ``theta``, ``rate`` and
``exact_steps`` left None. 2D P2: theta 0.9, rate 1, the steps before the last left at the interior point's
answer (its exact finish, the cuts, costs more than the interior point): on the adapt study's Hertz cylinder and on
issue 30's rigid cylinder the old loop (theta 0.5, one bisection, every step exact) stops after its 10 steps
at 1,402 and 730 unknowns, the peak pressure -0.58 % and -96 % off Hertz, this one reaches both within 3 % and the
half-width within 5 % under 5e4 unknowns (docs/accuracy.md, "Defaults per degree"). P1 keeps theta 0.5, one
bisection, every step exact (a P1 step is a warm-started active set; the P2 choice leaves P1's peak pressure at
+1.1 % at 42,624 unknowns where this one is within 1 % from 24,074); 3D is as measured in 2D P1 (not
scanned)."""


def peak_pressure(sol: Solution) -> float:
    """The largest contact pressure of ``sol`` (Pa): the maximum of ``sol.traction(0, pair)`` (the pressure felt by
    the first body of each pair, at its trace nodes) over the pairs; 0 without contact."""
    return max((float(np.max(sol.traction(0, i)[1], initial=0.0)) for i in range(len(sol.contacts))), default=0.0)


def unknowns(bodies: Sequence, degree: int) -> int:
    """The nodal unknowns of ``bodies`` (:class:`~cvxcontact.physics.body.Body`, or anything with ``mesh`` and
    ``piezoelectric``) at ``degree``: u (dim per node) and phi (one per node of a piezoelectric body) on the
    nodes of the degree's space (:meth:`~cvxcontact.fem.space.Space.node_set`), as ``AdaptStep.unknowns``
    counts them after the solve."""
    total = 0
    for b in bodies:
        nodes = len(space(degree, b.mesh.cell).node_set(b.mesh).points)
        total += nodes * (b.mesh.points.shape[1] + int(b.piezoelectric))
    return int(total)


@dataclass(frozen=True)
class AdaptStep:
    """One step of :func:`adapt`: the mesh solved and what its solution's estimate said.

    ``cells``: the cells (triangles, tetrahedra, quadrilaterals, hexahedra) of all bodies; ``unknowns``: nodal
    unknowns (u and phi, all bodies); ``estimate`` (sqrt(J/m)) and ``relative``: ``sol.estimate.absolute`` and
    ``.relative``; ``marked``: cells marked for the next mesh (0 on the last step); ``solve_s``: the solve with its
    estimate (s), ``refine_s``: marking, refinement and the rebuilt scene (s); ``cpu_s``: the CPU seconds of both
    (process time: on a machine shared with other work, wall time measures the neighbours); ``ok``: the solution's
    checks; ``peak`` (Pa): the largest contact pressure of the step (:func:`peak_pressure`), ``peak_change``: its
    relative change from the step before, |peak_k - peak_(k-1)| / peak_k (NaN on step 0): an indicator of the peak
    pressure's error, not a bound (docs/accuracy.md, "The peak pressure between steps").
    """

    step: int
    cells: int
    unknowns: int
    estimate: float
    relative: float
    marked: int
    solve_s: float
    refine_s: float
    ok: bool
    cpu_s: float = float("nan")
    peak: float = float("nan")
    peak_change: float = float("nan")


@dataclass(frozen=True)
class Adapted:
    """What :func:`adapt` returns: the last ``solution`` and its ``scene``, the ``history`` (one
    :class:`AdaptStep` per solve), why it ``stopped`` ("tol", "max_steps", "max_cells" or "max_unknowns") and, with
    ``keep=True``, every step's solution in ``solutions``."""

    solution: Solution
    scene: Scene
    history: tuple
    stopped: str
    solutions: tuple = ()


def mark_bulk(indicators: Sequence[ArrayLike], theta: float) -> list[np.ndarray]:
    """Dorfler's bulk marking over several bodies: boolean masks, one per entry of ``indicators`` (eta_T of
    each cell, sqrt(J/m)), marking the fewest cells, largest eta_T first, with
    sum_marked eta_T^2 >= theta sum_all eta_T^2 (0 < theta <= 1). Ties at the threshold are all marked."""
    theta = _fraction(theta)
    eta2 = [np.asarray(e, dtype=float) ** 2 for e in indicators]
    flat = np.concatenate(eta2)
    total = flat.sum()
    if not total > 0:
        return [np.zeros(len(e), dtype=bool) for e in eta2]
    ranked = np.sort(flat)[::-1]
    k = int(np.searchsorted(np.cumsum(ranked), theta * total * (1 - 1e-12)))   # first index reaching the bulk
    threshold = ranked[min(k, len(ranked) - 1)]
    return [e >= threshold for e in eta2]


def mark_bisections(indicators: Sequence[ArrayLike], theta: float, rate: float, dim: int = 2,
                    most: int = 8) -> list[np.ndarray]:
    """Dorfler's set (:func:`mark_bulk`) with the bisections each marked cell is predicted to need: one int array
    per entry of ``indicators``, 0 on unmarked cells, on a marked cell T

        k_T = ceil(dim log2(eta_T / eta_free) / rate),   1 <= k_T <= most,

    the fewest bisections after which eta_T ~ h_T^rate, with h_T shrinking by 2^(1/dim) per bisection (a bisection
    halves a triangle's area, a tetrahedron's volume), predicts its children's indicators at or below eta_free,
    the largest indicator left unmarked (the level the unmarked cells already meet: equidistribution; every
    marked cell gets 1 if none is left). ``rate`` (> 0): the exponent s of eta_T ~ h_T^s where the cell's
    error lives (s = p + 1 for a smooth solution, area-weighted, in 2D; about 1.5 at the edge of a contact
    zone, u ~ r^(3/2)); a larger ``rate`` asks fewer bisections (the loop's next steps add what is missing)."""
    rate, most = _rate(rate), _count(most, "most", 1)
    masks = mark_bulk(indicators, theta)
    eta = [np.asarray(e, dtype=float) for e in indicators]
    free = max((float(e[~m].max()) for e, m in zip(eta, masks) if (~m).any()), default=0.0)
    out = []
    for e, m in zip(eta, masks):
        k = np.zeros(len(e), dtype=np.int64)
        if free > 0:
            k[m] = np.ceil(dim * np.log2(e[m] / free) / rate - 1e-9)
        k[m] = np.clip(k[m], 1, most)
        out.append(k)
    return out


def adapt(scene: Scene, condition: str = "gamma3", *, theta: float | None = None, max_steps: int = 10,
          max_cells: int | None = None, tol: float | None = None, max_unknowns: int | None = None,
          curves: Mapping[str | int, Mapping[str, Curve]] | None = None,
          progress: Callable[[str], None] | None = None, keep: bool = False, target: str = "energy",
          rate: float | None = None, most: int = 8, exact_steps: bool | None = None, **options) -> Adapted:
    """Refine ``scene``'s meshes where the error estimate sits, solving on each.

    The loop is the module's docstring; how to use it, and what it measured: docs/accuracy.md,
    "Adaptive refinement: cc.adapt".

    Parameters
    ----------
    scene : Scene
        A 2D or 3D scene of triangles or tetrahedra, or of quadrilaterals or hexahedra on tensor grids; its
        meshes are the first step's (how each kind is refined: the module docstring,
        :func:`~cvxcontact.geometry.refine.refine_local`).
    condition : str
        The contact condition of every solve, as in :func:`cvxcontact.solve`.
    theta : float, optional
        Dorfler's bulk fraction, 0 < theta <= 1 (0.3-0.6 is usual; 1 refines every cell with a
        non-zero indicator). None: the scene's dimension and degree's (:data:`LOOPS`: 0.9 in 2D P2, else 0.5).
    max_steps : int
        Refinements at most (``max_steps + 1`` solves).
    max_cells : int, optional
        Stop before solving a mesh with more cells than this (all bodies).
    tol : float, optional
        Stop when the target's relative estimate <= tol (``sol.estimate.relative`` for "energy"). A loop that
        stops otherwise warns (:class:`~cvxcontact.errors.ResolutionWarning`, the best estimate reached).
    max_unknowns : int, optional
        Stop before solving a mesh with more nodal unknowns than this (u and phi, all bodies: ``AdaptStep.
        unknowns``; the refined mesh's are counted before its solve, :func:`unknowns`).
    curves : dict, optional
        Body (its name or index in ``scene.bodies``) -> {tag: closest-point map} of its curved boundary
        parts (:func:`~cvxcontact.geometry.refine.refine_marked`); without, new boundary nodes are the
        edges' midpoints. 2D triangles only (a 3D scene or a grid of quadrilaterals with ``curves`` is refused).
    progress : callable, optional
        Called with one line of text per step (the package's progress convention, as the sweeps and studies).
    keep : bool
        Keep every step's solution in ``Adapted.solutions`` (memory: one solution per step).
    target : str
        What the marking aims at, a key of :data:`TARGETS`: "energy" (the energy-norm estimate) or "force"
        (the first pair's total contact force, goal-oriented).
    rate : float, optional
        Bisect each marked cell as often as its indicator asks (:func:`mark_bisections`, at most ``most`` times in
        a step; a grid's strips are halved once a step whatever it asks); ``math.inf``: each marked cell once.
        None: the dimension and degree's (:data:`LOOPS`: 1 in 2D P2, else inf).
    most : int
        The most bisections of one cell in one step with ``rate`` (8: h_T / 16 in 2D).
    exact_steps : bool, optional
        True: every step's answer is the exact finish's. False: the steps before the last keep the interior
        point's answer, the last mesh is solved exactly (docs/accuracy.md, "Adaptive refinement: cc.adapt").
        None: the dimension and degree's (:data:`LOOPS`: False in 2D P2, else True).
    **options : dict, optional
        Passed to :class:`~cvxcontact.solve.ContactSolver` (``method``, ``degree``, ``tol``, ``warm_start``,
        ...); ``estimate=False`` is refused (the loop needs the estimate), and so is ``start`` (the loop passes
        each step's solution to the next).

    Returns
    -------
    Adapted

    Raises
    ------
    UnsupportedError
        For a mesh of quadrilaterals or hexahedra that is not a tensor grid, ``curves`` in 3D or on a grid, or a
        solution without an estimate (the reason is named).
    SceneError
        For a scene that is not a Scene, or a parameter out of range.

    Notes
    -----
    With ``tol`` given and not reached (a stop by ``max_steps``, ``max_cells`` or ``max_unknowns``) a
    :class:`~cvxcontact.errors.ResolutionWarning` says so, with the estimate reached and what to do; the answer
    returned is the last (the finest) mesh's.
    A :class:`~cvxcontact.errors.ResolutionWarning` of an intermediate step is dropped (the loop refines
    what it names), and with ``exact_steps=False`` its :class:`~cvxcontact.errors.ResidualWarning` (an interior
    point's answer, not exact by design: ``AdaptStep.ok`` records its checks); the last step's are raised.
    Other warnings pass.
    """
    if not isinstance(scene, Scene):
        raise SceneError(f"adapt takes a cc.Scene, got {type(scene).__name__}")
    if scene.dim == 3 and curves:
        raise UnsupportedError("adapt: curves= puts new boundary nodes back on 2D curves only; in 3D the new "
                               "boundary nodes stay on the flat facets of the first mesh: remove curves= (or mesh "
                               "the curved body finely where it matters)")
    if options.get("estimate", True) is not True:
        raise SceneError("adapt needs the error estimate of every solve: remove estimate=False")
    if "start" in options:
        raise SceneError("adapt starts each solve from the previous step's solution itself: remove start=")
    degree = options.get("degree", 1)
    space(degree, scene.cell)                                   # a bad degree: the solver's typed error, here
    loop = LOOPS[scene.dim, degree]
    theta = loop.theta if theta is None else theta
    rate = loop.rate if rate is None else rate
    exact_steps = loop.exact_steps if exact_steps is None else exact_steps
    if not isinstance(exact_steps, bool):
        raise SceneError(f"adapt: exact_steps must be True, False or None (the default of the degree), got "
                         f"{exact_steps!r}")
    if target not in TARGETS:
        raise SceneError(f"adapt: target must be one of {sorted(TARGETS)}, got {target!r}")
    theta = _fraction(theta)
    rate, most = _rate(rate), _count(most, "most", 1)
    max_steps = _count(max_steps, "max_steps", 0)
    max_cells = None if max_cells is None else _count(max_cells, "max_cells", 1)
    max_unknowns = None if max_unknowns is None else _count(max_unknowns, "max_unknowns", 1)
    if max_unknowns is not None and unknowns(scene.bodies, degree) > max_unknowns:
        raise SceneError(f"adapt: the first mesh already has {unknowns(scene.bodies, degree)} unknowns, more than "
                         f"max_unknowns = {max_unknowns}: raise max_unknowns or start from a coarser mesh")
    if tol is not None and not (isinstance(tol, (int, float)) and not isinstance(tol, bool) and tol > 0):
        raise SceneError(f"adapt: tol must be a positive number (the relative estimate to reach), got {tol!r}")
    say = progress or (lambda line: None)
    body_curves = _curves(scene, curves)
    for k, b in enumerate(scene.bodies):
        why = local_refusal(b.mesh, bool(body_curves.get(k)))
        if why:
            raise UnsupportedError(f"adapt cannot refine body {b.name!r} locally: {why}")
    alike = _alike(scene, degree)
    first = [start_local(b.mesh) for b in scene.bodies]
    if any(m is not b.mesh for m, b in zip(first, scene.bodies)):
        scene = scene.with_bodies(*(b.with_changes(mesh=m) for b, m in zip(scene.bodies, first)))
    exact = options.pop("polish", True)             # the last step's finish; the others' too with exact_steps
    history, kept = [], []
    step, sol, told = 0, None, set()
    while True:
        clock, cpu = time.perf_counter(), time.process_time()
        finished = exact and (exact_steps or step >= max_steps)    # the last step by count: exact at once
        sol, caught = _solve(scene, condition, sol, options, finished)
        if sol.estimate is None:
            raise UnsupportedError(f"adapt: the solution has no error estimate ({sol.estimate_reason})")
        cells = sum(len(b.mesh.cells) for b in scene.bodies)
        indicators, relative = TARGETS[target](sol)
        stopped = ("tol" if tol is not None and relative <= tol else "max_steps" if step >= max_steps else "")
        solve_s = time.perf_counter() - clock
        clock = time.perf_counter()
        marked, refined = [], None
        if not stopped:
            marked = (mark_bulk(indicators, theta) if np.isinf(rate)
                      else mark_bisections(indicators, theta, rate, scene.dim, most))
            meshes = refine_together([b.mesh for b in scene.bodies], [mk.astype(np.int64) for mk in marked],
                                     alike, [body_curves.get(k) for k in range(len(scene.bodies))])
            bodies = [b.with_changes(mesh=m) for b, m in zip(scene.bodies, meshes)]
            if max_cells is not None and sum(len(m.cells) for m in meshes) > max_cells:
                stopped, marked = "max_cells", []
            elif max_unknowns is not None and unknowns(bodies, degree) > max_unknowns:
                stopped, marked = "max_unknowns", []
            else:
                refined = scene.with_bodies(*bodies)
        refine_s = time.perf_counter() - clock
        if stopped and exact and not finished:             # the mesh it stops on, solved exactly
            clock = time.perf_counter()
            sol, caught = _solve(scene, condition, sol, options, True)
            solve_s += time.perf_counter() - clock
            if stopped == "tol":                           # the stop read the interior point's estimate
                relative = TARGETS[target](sol)[1]
        cpu_s = time.process_time() - cpu
        est = sol.estimate
        dropped = (ResolutionWarning, ResidualWarning) if exact and not finished else ResolutionWarning
        # an interior point's answer (exact_steps=False) is not exact: said
        reissue([w for w in caught if (stopped or not issubclass(w.category, dropped)) and not _told(w, told)])
        peak = peak_pressure(sol)
        before = history[-1].peak if history else float("nan")
        row = AdaptStep(step=step, cells=cells, unknowns=int(sum(u.size + (0 if p is None else p.size)
                                                                   for u, p in zip(sol.u, sol.phi))),
                        estimate=est.absolute, relative=est.relative, marked=sum(np.count_nonzero(m) for m in marked),
                        solve_s=solve_s, refine_s=refine_s, ok=bool(sol.ok), cpu_s=cpu_s, peak=peak,
                        peak_change=abs(peak - before) / peak if peak > 0 else float("nan"))
        history.append(row)
        if keep:
            kept.append(sol)
        say(f"adapt step {step}: {cells} cells, {row.unknowns} unknowns, estimate {est.absolute:.4g} "
            f"({100 * est.relative:.3g} %), {row.marked} marked ({solve_s:.2f} s)")
        if stopped:
            if stopped == "tol" and relative > tol:
                warnings.warn(f"adapt: the interior point's relative estimate reached tol = {tol:g} on the last mesh "
                              f"({row.unknowns} unknowns), its exact answer's reads {relative:.3g}: call again with "
                              "exact_steps=True or a slightly smaller tol", ResolutionWarning,
                              stacklevel=user_stacklevel())
            if tol is not None and stopped != "tol":
                best = min(history, key=lambda r: r.relative)
                warnings.warn(f"adapt: the relative estimate {row.relative:.3g} of the last mesh ({row.unknowns} "
                              f"unknowns) is above tol = {tol:g}: stopped by {stopped}; the lowest of the loop "
                              f"{best.relative:.3g} at step {best.step} ({best.unknowns} unknowns). The answer "
                              f"returned is the last mesh's; to reach tol raise {stopped} (the estimate falls "
                              "about as N^(-p/2) in the unknowns N, P1 p = 1, P2 p = 2, in 2D) or ask a larger tol",
                              ResolutionWarning, stacklevel=user_stacklevel())
            return Adapted(solution=sol, scene=scene, history=tuple(history), stopped=stopped, solutions=tuple(kept))
        scene, step = refined, step + 1


def _alike(scene, degree) -> list:
    """The faces ((k, part), (l, part)) of the scene's two-body pairs that refinement keeps meshed alike: every
    such pair's where the space needs matching faces (``matching_faces``: Q2 hexahedra), else none."""
    if not needs_matching_faces(space(degree, scene.cell)):
        return []
    return [((a, c.part_a), (b, c.part_b)) for c, (a, b) in zip(scene.contacts, scene.stack.members)
            if b is not None]


def _told(w, told) -> bool:
    """Whether the recorded warning ``w`` says what an earlier step's said about the scene itself (its message's
    ``about``, e.g. :class:`~cvxcontact.errors.OverlapWarning`: the same pairs on the same part on every mesh);
    else False, and its ``about`` remembered in ``told``."""
    about = getattr(w.message, "about", None)
    if about is None:
        return False
    seen = (w.category, about) in told
    told.add((w.category, about))
    return seen


def _solve(scene, condition, previous, options, polish):
    """(solution, the warnings it raised): one step's solve, from ``previous`` (module docstring)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = ContactSolver(scene, condition, start=previous, polish=polish, **options).solve()
    return sol, caught


def _fraction(theta):
    if isinstance(theta, bool) or not isinstance(theta, (int, float, np.integer, np.floating)) \
            or not 0 < theta <= 1:
        raise SceneError(f"theta (Dorfler's bulk fraction) must be a number in (0, 1], got {theta!r}; "
                         "0.3-0.6 is usual")
    return float(theta)


def _rate(rate) -> float:
    if isinstance(rate, bool) or not isinstance(rate, (int, float, np.integer, np.floating)) or not rate > 0:
        raise SceneError(f"adapt: rate (the exponent s of eta_T ~ h_T^s) must be a positive number, got {rate!r}")
    return float(rate)


def _count(v, name, low):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
        raise SceneError(f"adapt: {name} must be an integer >= {low}, got {v!r}")
    return int(v)


def _curves(scene, curves) -> dict:
    """{body index: {tag: curve}} from a mapping keyed by body names or indices."""
    if curves is None:
        return {}
    if not isinstance(curves, Mapping):
        raise SceneError(f"adapt: curves must map bodies (names or indices) to {{tag: closest-point map}}, "
                         f"got {type(curves).__name__}")
    names = [b.name for b in scene.bodies]
    out = {}
    for key, parts in curves.items():
        k = key if isinstance(key, (int, np.integer)) and not isinstance(key, bool) else (
            names.index(key) if key in names else None)
        if k is None or not 0 <= k < len(names):
            raise SceneError(f"adapt: curves names body {key!r}; the scene's bodies are {names} "
                             f"(or indices 0..{len(names) - 1})")
        out[int(k)] = dict(parts)
    return out
