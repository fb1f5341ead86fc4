"""The pieces every route shares: the condensation of a problem onto its contact unknowns (a reduction with
apply/invert, built once per geometry and kept in the :class:`~cvxcontact.backends.result.Cache`), the fields
of a solved program, and the rows no unknown moves (docs/formulation.md §7, §8 "Held nodes")."""

from __future__ import annotations

import time

import numpy as np

from .budget import Budget
from .condensed import Compliance, condense, contact_dofs, quasi_definite_rhs
from .conic import least_held_duals
from .factor import Forward
from .finish.lcp import closed_solve
from .released import Released

__all__ = ["Condensation", "Held", "condensation", "split", "program_fields", "held_cone", "release_held"]


class Condensation:
    """The reduction of a problem onto its contact unknowns (docs/formulation.md §7), as a pair of maps.

    Built once per geometry (``__init__``: each body's quasi-definite matrix factorised with its contact dofs
    as a Schur block, :func:`~cvxcontact.backends.condensed.condense`, and the interface compliance W = sum_l
    R_l Sigma_l^-1 R_l^T of the rows E): the factorisations are the inverse data. :meth:`apply` reduces a load
    case to the interface: per body the unconstrained Gamma displacements v0 and the interface loads
    Sigma v0, and the free slack d = E [v0_nu] - g (the forward sweeps are kept; a body whose scaled load
    is bit for bit the last load case's reuses its sweep). :meth:`invert` maps the
    contact forces y on the rows back to every body's (u, phi) (one backward sweep per body);
    :meth:`invert_gamma` does the same from Gamma values v instead (the interior dofs for given v). Where
    memory is short (:mod:`cvxcontact.backends.budget`) a body's factors are freed once its Sigma and its load's
    forward sweep are taken, and each later sweep re-makes its interior factorisation (:attr:`released`); the
    checks' |K| values go with them (:meth:`~cvxcontact.discrete.blocks.Block.keep_no_abs`).
    """

    def __init__(self, problem, settings, timings, whole: bool = True):
        t0 = time.perf_counter()
        held = [bool(getattr(b, "held_by_contact", None)) for b in problem.scene.bodies]
        blocks = list(problem.blocks)
        budget = Budget([_nonzeros(b) for b in blocks], [len(contact_dofs(b)) for b in blocks])
        self.bodies = [condense(b, s, m, settings.factorization, held=h, budget=budget)   # held: forced.py only
                       for b, s, m, h in zip(blocks, problem.matrices, problem.meshes, held)]
        for b, c in zip(blocks, self.bodies):
            if isinstance(c.factor, Released):     # memory short: the checks' |K| store goes with the factors
                b.keep_no_abs()
        # a body held by the contact only has a singular Sigma: no compliance (backends/forced.py does without)
        self.compliance = None if any(held) else Compliance(self.bodies, problem.E)
        if whole and self.compliance is not None:
            _ = self.compliance.W              # formed here (timed with the factorisations) for the routes reading
            # it whole; the finish of dependent rows reads a block of it (Compliance.keep) and passes whole=False
        self.sweeps = None
        self._loaded = [None] * len(self.bodies)   # per body (F, its forward sweep) of the last load case
        self._batched = [[] for _ in self.bodies]  # per body [(F, its forward sweep)] of the prepared load cases
        self._pending = [[] for _ in self.bodies]  # per body [F] of the prepared load cases, not yet swept
        self.swept = 0.0                           # seconds of the batched sweeps made since the last prepare
        self._deferred = None          # [((u, phi) Held, sweeps, v, blocks)] of the held backward sweeps (defer)
        self.psd_factors = {}          # factors of W on sets of nodes (cuts.psd_factor), shared by the solves
        timings["factorization"] = timings.get("factorization", 0.0) + time.perf_counter() - t0  # (a hand-over:
        # the sparse route's before it, signorini._hand_over)

    @property
    def W(self):
        """The interface compliance (rows x rows, scaled)."""
        return self.compliance.W

    @property
    def released(self) -> bool:
        """Whether some body's factors were freed after its Sigma was taken (:mod:`cvxcontact.backends.budget`):
        its later sweeps re-make its interior factorisation."""
        return any(isinstance(c.factor, Released) for c in self.bodies)

    @property
    def factorization(self) -> str:
        """The adapters that factorised the bodies ("superlu", "pardiso")."""
        return ",".join(dict.fromkeys(c.factorization for c in self.bodies))

    def apply(self, problem, timings):
        """(v0, loads, d) of the load case of ``problem`` (see the class docstring)."""
        t0 = time.perf_counter()
        rhs = [quasi_definite_rhs(b) for b in problem.blocks]
        self.sweeps = [self.forward(k, F) for k, F in enumerate(rhs)]
        v0 = [c.unconstrained(f) for c, f in zip(self.bodies, self.sweeps)]
        d = None if self.compliance is None else self.compliance.free_slack(v0, problem.g)
        timings["interface_load"] = time.perf_counter() - t0
        return v0, [c.stiffness @ v for c, v in zip(self.bodies, v0)], d

    def forward(self, k, F):
        """Body k's forward sweep of its scaled load F: the last load case's if F is bit for bit the same (a load
        case that leaves this body's scaled loads as they were: the sweep would give the same numbers), else the
        one :meth:`prepare` batched for a load bit for bit F, else a new sweep (kept with a copy of F: 8 bytes per
        unknown of the body)."""
        sweep = self._last(k, F)
        if sweep is not None:
            return sweep
        if any(np.array_equal(G, F) for G in self._pending[k]):
            self._sweep_batch(k)
        sweep = next((s for G, s in self._batched[k] if np.array_equal(G, F)), None)
        if sweep is None:
            sweep = self.bodies[k].forward(F)
        self._loaded[k] = (np.array(F, dtype=float), sweep)
        return sweep

    def _last(self, k, F):
        """Body k's forward sweep of the last load case if its scaled load was bit for bit F, else None."""
        last = self._loaded[k]
        return last[1] if last is not None and np.array_equal(last[0], F) else None

    def prepare(self, problems) -> None:
        """Batch the forward sweeps of the load cases ``problems`` (problems of this geometry and contact rows):
        per body, one sweep of all their distinct scaled loads as the columns of one right-hand side (each
        factor read once for all of them: the sweeps are bound by reading the factors), made when :meth:`forward`
        first asks for one of them (a route that sweeps nothing, e.g. the sparse route a fallback moved the solver
        to, makes none) and kept until :meth:`flush` ends the batch; :meth:`forward` takes a load's sweep from here
        when its F is bit for bit one of them. A batched sweep gives the single sweep's numbers to rounding (the
        adapters' multi-column kernels sum in another order). Kept: a copy of each load and its sweep (16 bytes
        per unknown of the body and load case). A body whose factors were freed
        (:class:`~cvxcontact.backends.released.Released`) sweeps one load at a time."""
        self.swept = 0.0
        for k, c in enumerate(self.bodies):
            self._batched[k], self._pending[k] = [], []
            if isinstance(c.factor, Released):
                continue
            loads: list = []
            for p in problems:
                F = np.asarray(quasi_definite_rhs(p.blocks[k]), dtype=float)
                if self._last(k, F) is None and not any(np.array_equal(G, F) for G in loads):
                    loads.append(F)
            if len(loads) >= 2:                   # one load: the single sweep, as solve() makes it
                self._pending[k] = loads

    def _sweep_batch(self, k) -> None:
        """Body k's forward sweep of the loads :meth:`prepare` kept, as the columns of one right-hand side."""
        t0 = time.perf_counter()
        loads, self._pending[k] = self._pending[k], []
        sweep = self.bodies[k].forward(np.column_stack(loads))
        self._batched[k] = [(F, Forward(sweep.reduced[:, j].copy(), sweep.state[:, j])) for j, F in enumerate(loads)]
        self.swept += time.perf_counter() - t0

    def invert(self, problem, y, timings):
        """(u, phi) of every body under the contact forces ``y`` on the rows of the last :meth:`apply`."""
        t0 = time.perf_counter()
        x = [c.back_substitute(f, problem.E.T @ y) for c, f in zip(self.bodies, self.sweeps)]
        timings["back_substitution"] = timings.get("back_substitution", 0.0) + time.perf_counter() - t0
        return split(self.bodies, x, problem.blocks)

    def invert_closed(self, problem, y, active, timings):
        """(u, phi, y) of every body under the contact forces ``y`` of an exact finish on the rows of the last
        :meth:`apply`, its closed rows ``active`` (W_AA y_A = d_A) met to rounding of the fields by one step of
        iterative refinement of the mixed system (26) on them.

        The slack d - W y of a closed row is a difference of terms far larger than the displacements there
        where the load alone would move a body much further than the contact lets it (a thin stiff layer pressed
        onto a substrate, thin_layer(40): |d_a| about 9e3 times the row's displacement scale U_a), so
        :meth:`invert` meets those rows only to about 1e-11 U_a (the complementarity check, the square root of
        slack times force, then reads 2e-6). Here the closed rows' slack s_A = E_A [u_nu] - g_A is read from the
        fields' Gamma values, the force that closes it, W_AA dy_A = s_A
        (:func:`~cvxcontact.backends.finish.lcp.closed_solve`: the finish's own factor where kept), is added to
        y, and the Gamma values move by the small correction -Sigma^{-1} J^T E^T dy, never recomputed from the
        large terms: s_A then reads 1e-16 U_a (measured, thin_layer(40)). The momentum and Gauss rows are met to
        rounding by the back-substitution (equilibrium 8e-17): their residual is not refined.

        One backward sweep per body: the Gamma values v = Sigma^{-1} (r - J^T E^T y) of the fields are all the
        slack reads (the sweep sets x_G = v), and the correction's right-hand side J^T E^T dy lies on the Gamma
        dofs, whose forward sweep is its own reduced load (b_I = 0: r = b_G), so S^{-1} of it is the backward
        sweep of zero interior with Gamma values Sigma^{-1} J^T E^T dy; the sweeps being linear, the fields are
        the backward sweep of the load's forward sweep with v less that correction (before: the fields' sweep, then
        a forward and a backward sweep of the correction per body; the same fields to rounding)."""
        E, g = problem.E, problem.g
        t0 = time.perf_counter()
        v = [c.gamma_values(f, E.T @ y) for c, f in zip(self.bodies, self.sweeps)]
        active = np.asarray(active, dtype=bool)
        if self.compliance is not None and active.any():
            slack = sum(R @ vk for R, vk in zip(self.compliance.rows, v)) - g
            dy = closed_solve(self.compliance.W, slack, active, self.compliance.last_factor)
            y = y + dy
            v = [vk - c.factor.schur_solve(c.jump.T @ (E.T @ dy)) for vk, c in zip(v, self.bodies)]
        timings["back_substitution"] = timings.get("back_substitution", 0.0) + time.perf_counter() - t0
        if self._deferred is not None:            # the fields made by flush(): unreadable until then
            held = Held(), Held()
            self._deferred.append((held, list(self.sweeps), v, problem.blocks))
            return (*held, y)
        return (*self.invert_gamma(problem, v, timings), y)

    def defer(self) -> None:
        """Hold the backward sweeps of :meth:`invert_closed` until :meth:`flush`: the fields it hands out are
        :class:`Held` lists, which :meth:`flush` fills and which refuse to be read before, so that the sweeps of
        several load cases run as the columns of one right-hand side (``ContactSolver.solve_many``; its route
        reads no field before the read-back, and one that did would raise, not read a placeholder)."""
        self._deferred = []

    def flush(self) -> float:
        """Make the backward sweeps held since :meth:`defer` into the fields handed out (per body one sweep of all
        of them as the columns of one right-hand side; one alone, or a body whose factors were freed, one at a time:
        the single sweep's numbers), and stop holding; the batch of :meth:`prepare` ends too (its sweeps dropped:
        a later load case is swept as :meth:`forward` alone would); the seconds it took."""
        t0 = time.perf_counter()
        pending, self._deferred = self._deferred or [], None
        x = [[] for _ in pending]                     # per held load case, its bodies' unknowns
        for k, c in enumerate(self.bodies):
            if len(pending) == 1 or isinstance(c.factor, Released):
                for xs, (_, f, v, _) in zip(x, pending):
                    xs.append(c.factor.backward(f[k], v[k]))
            elif pending:
                X = c.factor.backward(Forward(None, np.column_stack([f[k].state for _, f, _, _ in pending])),
                                      np.column_stack([v[k] for _, _, v, _ in pending]))
                for j, xs in enumerate(x):
                    xs.append(X[:, j].copy())
        for xs, ((u, phi), _, _, blocks) in zip(x, pending):
            fields = split(self.bodies, xs, blocks)
            u.fill(fields[0])
            phi.fill(fields[1])
        for k, batched in enumerate(self._batched):    # the batch is over: a later load case sweeps afresh (as
            last = self._loaded[k]                     # solve() alone would), and the last sweep kept holds a
            if last is not None and any(s is last[1] for _, s in batched):     # column of its own, not a view of
                own = Forward(last[1].reduced, np.array(last[1].state))       # the batch's whole right-hand side
                if self.sweeps is not None:
                    self.sweeps = [own if s is last[1] else s for s in self.sweeps]
                self._loaded[k] = (last[0], own)
        self._batched = [[] for _ in self.bodies]
        self._pending = [[] for _ in self.bodies]
        return time.perf_counter() - t0

    def invert_gamma(self, problem, v, timings):
        """(u, phi) of every body with its Gamma values ``v`` (per body) given, for the last :meth:`apply`."""
        t0 = time.perf_counter()
        x = [c.factor.backward(f, vk) for c, f, vk in zip(self.bodies, self.sweeps, v)]
        timings["back_substitution"] = timings.get("back_substitution", 0.0) + time.perf_counter() - t0
        return split(self.bodies, x, problem.blocks)


class Held(list):
    """The per-body fields (u or phi) of a backward sweep held by :meth:`Condensation.defer`: a list that refuses
    to be read (RuntimeError) until :meth:`Condensation.flush` fills it, so that a route reading its fields before
    the batch's sweeps are made fails at once instead of reading a placeholder."""

    filled = False

    def fill(self, values) -> None:
        """The fields, once made (:meth:`Condensation.flush`)."""
        self.filled = True
        super().extend(values)

    def _unfilled(self) -> None:
        if not self.filled:
            raise RuntimeError("the fields of a held backward sweep were read before Condensation.flush made them: "
                               "a route that reads its fields must not run under Condensation.defer")

    def __iter__(self):
        self._unfilled()
        return super().__iter__()

    def __getitem__(self, index):
        self._unfilled()
        return super().__getitem__(index)

    def __len__(self):
        self._unfilled()
        return super().__len__()


def _nonzeros(block) -> int:
    """The nonzeros of a block's quasi-definite S (:func:`~cvxcontact.backends.condensed.quasi_definite`)."""
    return sum(2 * M.nnz if M is block.Kup else M.nnz for M in (block.Kuu, block.Kup, block.Kpp) if M is not None)


def condensation(problem, cache, settings, timings, whole: bool = True) -> Condensation:
    """The :class:`Condensation` of ``problem``, built once per geometry into ``cache``; ``whole``: its interface
    compliance W formed at once (else on first use, or a block of it: :class:`~cvxcontact.backends.condensed.
    Compliance`)."""
    if cache.condensation is None:
        cache.condensation = Condensation(problem, settings, timings, whole)
    return cache.condensation


def split(condensed, x, blocks):
    """(u, phi) of each body from its back-substituted unknowns ``x``."""
    return ([xk[:c.n_u] for c, xk in zip(condensed, x)],
            [xk[c.n_u:] if b.Kpp is not None else None for c, xk, b in zip(condensed, x, blocks)])


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


def held_cone(beta, B, held, c, width: int = 3):
    """beta with the entries of the Bernstein rows of ``B`` whose nodes are all ``held`` and whose value
    (at the cone's gap ``c``) is 0 lowered to the least the dual cone allows (segments:
    :func:`least_held_duals`; triangles: the duals of a triangle all of whose rows are so are 0, others kept)."""
    if not np.any(held):
        return beta
    rows = (abs(B) @ (~held).astype(float) == 0) & (np.abs(B @ c) <= 1e-12 * max(np.abs(c).max(), 1e-300))
    if width == 6:
        out = np.array(beta, dtype=float)
        out[rows.reshape(-1, 6).all(axis=1)] = 0.0
        return out
    return least_held_duals(beta, rows.reshape(-1, 3))


def release_held(y, z, held):
    """(y, z) with the limit reactions z of the ``held`` rows set to 0 and the row forces y lowered by them: a
    reaction on a row no unknown moves acts on nothing, so (26)-(27) do not determine it, and an interior point
    reports an arbitrary, typically huge one (docs/formulation.md §8, "Held nodes")."""
    z = np.asarray(z, dtype=float)
    return y - np.where(held, z, 0.0), np.where(held, 0.0, z)
