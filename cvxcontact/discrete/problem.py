"""The discrete problem: one object built once per scene, space, condition and law (docs/architecture.md).

:func:`build_problem` assembles every body in a :class:`~cvxcontact.fem.space.Space`, builds the contact
lines of the scene (:class:`~cvxcontact.fem.space.ContactLines`), chooses the reference units and scales
every block (:mod:`cvxcontact.discrete.blocks`). The result, a frozen :class:`DiscreteProblem`, is what
every backend solves and what the read-back reports on:

    minimise   sum_k 1/2 u_k^T Kuu_k u_k + 1/2 phi_k^T Kpp_k phi_k - f_k^T u_k  (+ compliance energy, -F . t)
    subject to Kpp_k phi_k - Kup_k^T u_k = q_k                                  (Gauss law (20))
               E [u_nu] + R t <= E g     (nodal rows)   or   B ([u_nu] - g) in cones (P2 "gamma3", §8)

(scaled, docs/formulation.md §2, §6, §8, §10, §12; t the translations of force-controlled obstacles).

:meth:`DiscreteProblem.with_loads` gives the problem of a scene that differs in its loads only (body
forces, tractions, charges, electrode potentials, gaps, obstacle positions and prescribed forces),
re-deriving exactly what depends on them: the loads, the units, and the contact lines (a moved rigid
obstacle reaches other nodes of the body's trace), reusing the assembled matrices. It refuses (typed) a scene
whose bodies or pairs differ.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ..errors import SceneError, frozen, locked
from ..fem.kernel import Kernel, check_well_posed, rigid_kernel
from ..fem.rigidfit import RigidFit, rigid_fit
from ..fem.space import ContactLines, Space
from ..physics.fingerprint import geometry_fingerprint
from ..physics.scene import Scene
from .blocks import Block, Units, units
from .overlap import warn_overlapping_thresholds
from .terms import ContactTerm, contact_term

__all__ = ["DiscreteProblem", "build_problem"]


ROWS_KEPT = 4
"""How many sets of contact rows :meth:`DiscreteProblem.shared` keeps what depends on (the latest used): a moving
obstacle's earlier rows are dropped, a load case back at one of the last positions finds its rows' structures."""


@dataclass(frozen=True, eq=False)
class DiscreteProblem:
    """The scaled discrete problem of a scene (see the module docstring). Immutable: a changed scene is a new
    problem (:meth:`with_loads`).

    ``scene``, ``space``, ``condition`` and ``law`` (the law of the pairs without their own) as given;
    ``nodes``: each body's node set (None: the mesh's vertices, P1); ``matrices``: each body's assembled
    matrices (SI, no loads); ``systems``: the same with the loads; ``lines``: the contact rows;
    ``units``: the reference units; ``blocks``: the scaled blocks of every body
    (:class:`~cvxcontact.discrete.blocks.Block`); ``gap``: the gap at the stacked nodes of X_h (scaled);
    ``translations``: per force-controlled obstacle (R, F), R its rows' sensitivities to its translation
    unknowns tau, F the prescribed force on them (scaled); ``held_rows``: the rows no unknown moves (nodes
    the supports hold on both sides, or against a fixed obstacle; docs/formulation.md §8, "Held nodes");
    ``prescribed_jump``: [u_D nu] at the nodes of X_h, the part of the jump that prescribed displacements of
    contact nodes fix (scaled; the blocks' jump operators act on the free unknowns only, so ``gap`` is the
    given gap minus it: a clamped contact part is a fixed foundation, a prescribed one a moved line); ``kernel``:
    the rigid motions only the contact holds and the force-controlled obstacles' translations
    (:class:`~cvxcontact.fem.kernel.Kernel`, None if there are none), checked well posed when built and
    against the active rows of an exact finish (:func:`~cvxcontact.fem.kernel.check_determined`); ``term``: the
    contact term its law poses (:class:`~cvxcontact.discrete.terms.ContactTerm`: its route key, its warm start,
    its held rows' forces, its finish, its read-back), built with the problem from its contact lines, holding
    what its law alone reads (``term.data``: a friction law's slip rows, weights and capacities,
    :class:`~cvxcontact.discrete.slip.Slip`).
    """

    scene: Scene
    space: Space
    condition: str
    law: object
    nodes: tuple | None
    matrices: tuple
    systems: tuple
    lines: ContactLines
    units: Units
    blocks: tuple
    gap: np.ndarray
    translations: tuple
    held_rows: np.ndarray
    term: ContactTerm
    scale: bool = True
    prescribed_jump: np.ndarray | float = 0.0
    kernel: Kernel | None = field(default=None, repr=False)
    _fingerprints: tuple = field(default=(), repr=False)
    _shared: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        for R, _ in self.translations:          # canonical and read-only, as the blocks' and E's matrices (frozen)
            frozen(R)

    # ---- what the backends read ---------------------------------------------------------------
    @property
    def E(self):
        """The evaluation rows of the condition (one per constrained node of X_h)."""
        return self.lines.E

    @property
    def g(self) -> np.ndarray:
        """The gap at the rows, scaled: E g."""
        return self.lines.E @ self.gap

    @property
    def departure(self):
        """The true gap's departure from its P2 interpolant on the cone's elements facing a curved rigid
        obstacle, scaled (:class:`~cvxcontact.contact.truegap.GapDeparture`; None: the gap is quadratic on
        every element)."""
        d = self.lines.departure
        return None if d is None else d.scaled(self.units.displacement)

    @property
    def rows(self):
        """The law of every row (:class:`~cvxcontact.contact.laws.RowLaws`)."""
        return self.lines.rows

    @property
    def quadratic(self) -> bool:
        """True if every body's bulk energy is the quadratic form of its Kuu (:mod:`cvxcontact.discrete.energy`)."""
        return all(b.bulk.quadratic for b in self.blocks)

    @property
    def compliant(self) -> bool:
        """True if some row follows a normal-compliance law (docs/formulation.md §10)."""
        return self.lines.rows.compliant

    @property
    def conic(self) -> bool:
        """True if the rows are the conic "everywhere" condition alone (P2 "gamma3", §8)."""
        return self.lines.conic

    @property
    def mixed(self) -> bool:
        """True if cones sit next to a compliance law in one program (§10, "P2")."""
        return self.lines.mixed

    @property
    def friction(self) -> bool:
        """True if some row has a friction law (its term then holds the slip rows, ``term.data``:
        :class:`~cvxcontact.discrete.slip.Slip`)."""
        return self.lines.rows.friction

    @property
    def weights(self) -> np.ndarray | None:
        """The law's quadrature weights on the rows, scaled (None without a compliance law)."""
        w = self.lines.weights
        return None if w is None else w / self.units.length

    @property
    def scaled_law(self):
        """The rows' laws in the scaled units (None without a compliance law)."""
        if not self.compliant:
            return None
        return self.lines.rows.scaled(self.units.stress * self.units.load, self.units.displacement)

    @property
    def obstacles(self) -> tuple:
        """Every rigid obstacle's :class:`~cvxcontact.physics.obstacles.ObstacleRows` at the rows of this space."""
        return self.lines.obstacles

    @property
    def forced(self) -> list:
        """The force-controlled obstacles (:attr:`obstacles` with a prescribed force)."""
        return [o for o in self.lines.obstacles if o.force is not None]

    @property
    def held(self) -> bool:
        """True if some body has a rigid motion that only the contact holds (a singular stiffness)."""
        return any(getattr(b, "held_by_contact", None) for b in self.scene.bodies)

    @property
    def interface(self):
        """The contact line the jump operators come from (the P1 stack, or the P2 interface/stack)."""
        return self.lines.interface

    @property
    def dim(self) -> int:
        """Displacement components per node (the space's)."""
        return self.space.dim

    @property
    def meshes(self) -> list:
        """Each body's node set (its mesh, or the space's nodes, e.g. P2's 6-node graph): where the unknowns
        live (points, cells, boundary nodes; the factorisations' orderings, the read-back)."""
        return list(self.nodes) if self.nodes is not None else [b.mesh for b in self.scene.bodies]

    @property
    def rigid_fits(self) -> tuple[RigidFit, ...]:
        """Each body's rigid motions on its free unknowns (:class:`~cvxcontact.fem.rigidfit.RigidFit`, per mesh
        component of its node set): its deformation, free of how far it slid or turned (built on first use, once
        per geometry: :meth:`shared`)."""
        return self.shared("rigid fits", lambda: tuple(rigid_fit(m.points, m.node_components, s.Tu)
                                                       for m, s in zip(self.meshes, self.systems)))

    @property
    def fingerprints(self) -> tuple[str, ...]:
        """Each body's :func:`~cvxcontact.physics.fingerprint.geometry_fingerprint`, as checked when this problem
        was derived (:meth:`with_loads` checks the scene's bodies against them)."""
        return self._fingerprints

    def shared(self, name: str, build, rows: bool = False):
        """What depends on the geometry alone (the meshes, the supports, the assembled matrices; with ``rows``:
        and the contact rows, :meth:`~cvxcontact.fem.space.ContactLines.key`), built by ``build()`` on first use
        and kept for every load case of this geometry (:meth:`with_loads` hands the same store on; a moved
        obstacle's new rows are another key: those of the :data:`ROWS_KEPT` sets of rows used last are kept, the
        store does not grow with the positions an obstacle takes). Nothing kept here may read a load."""
        store = self._shared
        if not rows:
            if name not in store:
                store[name] = build()
            return store[name]
        key = (name, self.lines.key())
        value = store.pop(key) if key in store else build()
        store[key] = value                                  # the rows used last at the end (insertion order)
        held = list(dict.fromkeys(k[1] for k in reversed(store) if isinstance(k, tuple)))     # the latest first
        for old in held[ROWS_KEPT:]:
            for k in [k for k in store if isinstance(k, tuple) and k[1] == old]:
                del store[k]
        return value

    @property
    def unknowns(self) -> int:
        """Number of nodal unknowns (u and phi, before the supports)."""
        return sum(len(s.f) + (len(s.q) if s.q is not None else 0) for s in self.systems)

    @property
    def allowance(self) -> np.ndarray | float:
        """How far each row may penetrate, scaled: 0 (Signorini), l (a compliance limit), the cone's shift."""
        if not self.compliant:
            return 0.0
        rows = self.lines.rows
        allowance = np.asarray(rows.penetration_limit, dtype=float)
        if hasattr(rows, "cone"):
            allowance = np.where(rows.cone, rows.cone_shift, allowance)
        return allowance / self.units.displacement

    def moved_gap(self, taus) -> np.ndarray:
        """The gap at the stacked nodes with the force-controlled obstacles translated by ``taus`` (scaled); at the
        rows, :meth:`moved_g`."""
        return self.gap - sum((o.reduced_rows @ t for o, t in zip(self.forced, taus)), np.zeros(len(self.gap)))

    def row_translation(self, taus) -> np.ndarray:
        """R tau summed over the force-controlled obstacles (their ``translations``, R their rows' sensitivities)
        at the rows (scaled): how far the translations ``taus`` move the rows' jump, E [u_nu] + R t
        (docs/formulation.md §12); the part the read-backs add to the jump or take from the gap (:meth:`moved_g`)."""
        return sum((R @ tau for (R, _), tau in zip(self.translations, taus)), np.zeros(self.E.shape[0]))

    def moved_g(self, taus) -> np.ndarray:
        """The gap at the rows with the force-controlled obstacles translated by ``taus`` (scaled):
        :attr:`g` - :meth:`row_translation` (at the stacked nodes, :meth:`moved_gap`)."""
        return self.g - self.row_translation(taus)

    def translation_sizes(self, taus) -> np.ndarray:
        """|R tau| summed over the force-controlled obstacles at the stacked nodes (scaled): the size of the terms
        the translations add to the gap, the displacement scale of a row whose moved gap is their cancellation
        (an obstacle that travels far before touching)."""
        return sum((np.abs(o.reduced_rows @ t) for o, t in zip(self.forced, taus)), np.zeros(len(self.gap)))

    def with_rows(self, E, rows=None, weights=None) -> DiscreteProblem:
        """The same problem with the condition posed by other evaluation rows ``E`` (nodes of X_h -> rows), e.g.
        the nodal condition sampled at chosen points of every merged segment (a linear relaxation of the conic
        condition, docs/formulation.md §8); ``rows``: the laws of those rows (default: each pair's law is
        replaced by Signorini on all of them), ``weights`` (m): their quadrature weights for a compliance law.
        No cone is left."""

        from ..contact.laws import RowLaws, Signorini

        E = sp.csr_matrix(E, copy=True)     # the caller's own: the rows' E is made canonical in place (frozen)
        rows = RowLaws.uniform(Signorini(), E.shape[0]) if rows is None else rows
        if E.shape[1] != self.lines.E.shape[1] or rows.size != E.shape[0]:
            raise SceneError(f"with_rows: E must have {self.lines.E.shape[1]} columns (the nodes of X_h) and one "
                             f"row per law row; got E {E.shape} and {rows.size} law rows")
        lines = replace(self.lines, E=E, cone=None, rows=rows, weights=None if weights is None else
                        np.asarray(weights, dtype=float), cone_pairs=None, mixed_bernstein=None,
                        departure=None, node_cone=None)
        term = contact_term(lines, self.dim)
        lines = term.own_lines(lines)
        E = lines.E
        term = term.with_data(self.scene, self.condition, lines, self.systems, self.units)
        translations = tuple((E @ o.reduced_rows, F) for o, (_, F) in zip(self.forced, self.translations))
        kernel = None if self.kernel is None else rigid_kernel(self.scene.bodies, [s.f for s in self.systems], E,
                                                               self.interface, self.obstacles, self.nodes)
        return replace(self, lines=lines, translations=translations,
                       held_rows=held_rows(E, self.blocks, translations), kernel=kernel, term=term)

    # ---- re-solves -----------------------------------------------------------------------------
    def accepts(self, scene) -> bool:
        """Whether ``scene`` differs from this problem's scene in its loads only (:meth:`with_loads` takes it)."""
        try:
            _same_geometry(self, scene)
        except SceneError:
            return False
        return True

    def with_loads(self, scene: Scene) -> DiscreteProblem:
        """The problem of ``scene``, a scene that differs from this one in its loads only (see the module
        docstring). SceneError, naming what differs, for another geometry, material, supports or pairs."""
        _same_geometry(self, scene)                 # (also for the same scene: an edit in place is refused)
        if scene is self.scene:
            return self
        return _derive(scene, self.space, self.condition, self.law, self.nodes, self.matrices, self.scale,
                       previous=self)


def build_problem(scene: Scene, space: Space, condition: str, law, *, scale: bool = True) -> DiscreteProblem:
    """Assemble every body of ``scene`` in ``space`` and build the scaled :class:`DiscreteProblem` of
    ``condition`` and ``law`` (the law of the pairs without their own). ``scale=False`` keeps SI units (the
    stability study only)."""
    nodes = [space.nodes(b) for b in scene.bodies]
    nodes = None if all(n is None for n in nodes) else tuple(nodes)
    matrices = tuple(space.assemble_matrices(b, None if nodes is None else nodes[k])
                     for k, b in enumerate(scene.bodies))
    return _derive(scene, space, condition, law, nodes, matrices, scale)


def _derive(scene, space, condition, law, nodes, matrices, scale, previous=None) -> DiscreteProblem:
    """Everything that depends on the loads (and on the obstacles' positions), from assembled ``matrices``."""
    at = [None] * len(scene.bodies) if nodes is None else nodes
    lines = space.contact(scene, condition, law, nodes)
    term = contact_term(lines, space.dim)         # the combination of laws: a term declares it, or it is refused
    lines = term.own_lines(lines)                 # and asks the elements for the rows its laws need beyond them
    systems = tuple(space.assemble_loads(b, m, n) for b, m, n in zip(scene.bodies, matrices, at))
    forced = [o for o in lines.obstacles if o.force is not None]
    un = units(scene, systems, lines.gap, forces=[o.force for o in forced]) if scale else Units(1.0, 1.0, 1.0, 1.0)
    term = term.with_data(scene, condition, lines, systems, un)      # what its law alone reads (friction: Slip)
    # the motions only the contact holds, judged over every body, pair and load together (or a SceneError)
    kernel = check_well_posed(scene.bodies, [s.f for s in systems], lines.E, lines.interface, lines.obstacles, nodes,
                              capacity=term.kernel_capacity())
    jumps = {}

    def jump(k):                                  # [u_nu] at the nodes of X_h from body k's nodal displacements
        if k not in jumps:
            jumps[k] = lines.interface.jump(k, len(systems[k].f) // space.dim)
        return jumps[k]

    same_rows = previous is not None and previous.lines.key() == lines.key()
    if same_rows:
        blocks = tuple(blk.with_loads(s, un) for blk, s in zip(previous.blocks, systems))
    elif previous is not None:                              # the same matrices, new contact rows
        blocks = tuple(replace(blk, jump=(jump(k) @ s.Tu).tocsr()).with_loads(s, un)
                       for k, (blk, s) in enumerate(zip(previous.blocks, systems)))
    else:
        blocks = tuple(Block.scaled(s, jump(k), un) for k, s in enumerate(systems))
    E = lines.E
    translations = tuple((E @ o.reduced_rows, (o.basis.T @ o.force) / un.force) for o in forced)
    # the same rows E (their key) and jumps and no obstacle under force control: the same held rows, not re-read
    unforced = not translations and previous is not None and not previous.translations
    held = previous.held_rows if same_rows and unforced else held_rows(E, blocks, translations)
    shift = np.zeros(len(lines.gap))             # [u_D nu]: prescribed displacements of contact nodes (§11)
    for k, s in enumerate(systems):
        if s.u_fixed is not None and np.any(s.u_fixed):
            shift = shift + jump(k) @ s.u_fixed
    gap = (lines.gap - shift) / un.displacement
    problem = DiscreteProblem(scene=scene, space=space, condition=condition, law=law, nodes=nodes,
                              matrices=matrices, systems=systems, lines=lines, units=un, blocks=blocks, gap=gap,
                              translations=translations, held_rows=held, term=term,
                              scale=scale, kernel=kernel,
                              prescribed_jump=shift / un.displacement,
                              _fingerprints=previous._fingerprints if previous is not None else
                              tuple(geometry_fingerprint(b) for b in scene.bodies),
                              _shared=previous._shared if previous is not None else {})
    check_reachable(problem)
    # given friction thresholds of several obstacles on one node add up: warned once per problem (and per set of
    # rows: a moved obstacle's new rows are checked again), before the solve
    problem.shared("overlapping thresholds", lambda: warn_overlapping_thresholds(scene, lines, condition,
                                                                                  problem.meshes), rows=True)
    return problem


def held_rows(E, blocks, translations) -> np.ndarray:
    """Rows of ``E`` that no unknown moves: nodes the supports hold (clamped, or a prescribed displacement)
    on both sides of the contact, or against a fixed obstacle. Their slack is the constant -g."""
    reach = sum((abs(E @ b.jump) @ np.ones(b.jump.shape[1]) for b in blocks), np.zeros(E.shape[0]))
    for R, _ in translations:                                       # a force-controlled obstacle can move
        reach = reach + abs(R) @ np.ones(R.shape[1])
    return locked(reach == 0)              # (read-only: a load case of the same rows shares it, _derive)


def check_reachable(problem: DiscreteProblem) -> None:
    """Refuse a contact row that no unknown can move but whose gap (plus the law's penetration allowance) is
    negative: a node the supports hold that an obstacle or a partner already penetrates. The program would
    only be 'infeasible'; this names the pair and the point instead."""
    E, un = problem.E, problem.units
    g = problem.g + problem.allowance
    bad = np.flatnonzero(problem.held_rows & (g < 0))
    if not len(bad):
        return
    a = int(bad[0])
    node = int(E[a].indices[np.argmax(np.abs(E[a].data))])         # the node of X_h the row evaluates
    offsets = problem.lines.offsets
    pair = int(np.searchsorted(offsets, node, side="right") - 1)
    interface = problem.interface
    points = interface.interfaces[pair].points if hasattr(interface, "interfaces") else interface.points
    at = ", ".join(f"{c:.6g}" for c in np.asarray(points)[node - offsets[pair]])
    raise SceneError(f"contact pair {pair}: {len(bad)} constrained node(s) cannot move along the contact normal "
                     f"(held by clamped or prescribed-displacement supports) but start in penetration, e.g. at "
                     f"({at}) m where the gap (plus the law's penetration limit, if any) is "
                     f"{g[a] * un.displacement:.3g} m: the contact condition cannot hold there; free that node, or "
                     "move the obstacle or the gap so that it is >= 0")


def _structure(scene) -> tuple:
    """What a prepared problem depends on beyond the bodies: each pair's members, parts, condition, own law,
    the kind of its obstacle and whether it is force controlled (the gaps, obstacle positions and prescribed
    forces are loads), and the merged-node count of two-body pairs."""
    return tuple((m, c.part_a, c.part_b, c.condition, None if c.rigid else itf.size,
                  c.other.kind if c.rigid else None, getattr(c, "law", None), c.rigid and c.other.force is not None)
                 for m, c, itf in zip(scene.stack.members, scene.contacts, scene.interfaces))


def _prescribed_values(k: int, prepared, body, fp: str) -> None:
    """SceneError naming the part if ``body`` (k-th of the scene) differs from the ``prepared`` body (fingerprint
    ``fp``) in the values of its prescribed displacements only: they are rows of the prepared problem, not
    loads. Returns quietly otherwise (another difference, told by the caller)."""
    old, new = dict(getattr(prepared, "displacement", {})), dict(getattr(body, "displacement", {}))
    changed = sorted(t for t in new if t in old and new[t] != old[t])
    if body is prepared or set(old) != set(new) or not changed:
        return
    try:
        restored = geometry_fingerprint(body.with_changes(displacement=old))
    except SceneError:                                   # the old values do not fit this body: other changes too
        return
    if restored != fp:
        return

    def show(v):
        return "(" + ", ".join("free" if c is None else f"{c:.6g}" for c in v) + ")"

    parts = "; ".join(f"part {t!r} from {show(old[t])} to {show(new[t])} m" for t in changed)
    raise SceneError(f"body {k} ({body.name}): the prescribed displacement changed ({parts}); a prescribed "
                     "displacement is built into a prepared ContactSolver (only loads may change between its "
                     "solves): build a new ContactSolver for this scene, or solve it once with cc.solve(scene)")


def _same_geometry(problem: DiscreteProblem, scene) -> None:
    """SceneError unless ``scene`` differs from ``problem.scene`` in its loads only."""
    if not isinstance(scene, Scene):
        raise SceneError(f"solve takes a Scene, got {type(scene).__name__}")
    prints = problem._fingerprints
    if len(scene.bodies) != len(prints):
        raise SceneError(f"the scene has {len(scene.bodies)} bodies, the prepared one {len(prints)}; "
                         "only loads may change between solves of one ContactSolver")
    for k, (fp, b) in enumerate(zip(prints, scene.bodies), start=1):
        if geometry_fingerprint(b) != fp:
            _prescribed_values(k, problem.scene.bodies[k - 1], b, fp)
            edited = any(b is a for a in problem.scene.bodies)
            raise SceneError(
                f"body {k} ({b.name}): " + ("its mesh, material or boundary parts were changed in place after "
                                             "this ContactSolver was built" if edited else
                                             "differs from the prepared scene in its mesh, material or boundary "
                                             "parts") +
                "; only loads may change between solves of one ContactSolver: build a new Scene and "
                "ContactSolver for the new geometry")
    if _structure(scene) != _structure(problem.scene):
        raise SceneError("the scene's contact pairs (members, parts, conditions, laws, obstacle kinds, force "
                         "control) differ from the prepared scene; only loads (gaps, obstacle positions and forces) "
                         "may change between solves of one ContactSolver: build a new ContactSolver for the new "
                         "geometry")
