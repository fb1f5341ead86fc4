"""A body's factorisation freed once its interface stiffness is taken (cvxcontact.backends.released.Released, the
memory budget of cvxcontact.backends.budget): the sweeps against dense algebra, the condensed route's answers
with the factors freed against those with them kept (the same to rounding), re-solves after a release, the
fallback without PARDISO, and the budget's decision from the available memory."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.demo import two_blocks
from cvxcontact.backends import budget, factor, released
from cvxcontact.backends.condensed import condense, quasi_definite
from cvxcontact.discrete import Block, units
from cvxcontact.fem.assembly import assemble

from conftest import rel
from scenes3d import two_boxes

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

needs_pardiso = pytest.mark.skipif(not factor.pardiso_available(), reason="Intel oneMKL (libmkl_rt) not installed")
KINDS = ["superlu", pytest.param("pardiso", marks=needs_pardiso)]


class Always:
    """A budget that frees every body's factors (counting what it was told)."""

    def __init__(self):
        self.memory = []

    def release(self, memory, possible=True):
        self.memory.append(memory)
        return possible


def no_pardiso(monkeypatch):
    """Emulate a machine without Intel oneMKL (as tests/test_factor.py does)."""
    monkeypatch.setattr(factor, "_LIB", None)
    monkeypatch.setattr(factor, "_LIB_ERROR", "libmkl_rt (Intel oneMKL) was not found")


@pytest.fixture(scope="module")
def piezo_bodies():
    """(block, system, mesh) of both bodies of the 2D piezoelectric demo (nx = 8; S quasi-definite), scaled."""
    scene = two_blocks(nx=8)
    systems = [assemble(b) for b in scene.bodies]
    un = units(scene, systems)
    return [(Block.scaled(s, scene.interface.jump(k, len(b.mesh.points)), un), s, b.mesh)
            for k, (s, b) in enumerate(zip(systems, scene.bodies))]


@pytest.mark.parametrize("kind", KINDS)
def test_released_sweeps_match_dense_solves(piezo_bodies, kind):
    """With the factors freed: Sigma and its Cholesky factors kept (the same arrays), the forward sweep of the
    body's own load read from what was kept (no factorisation), that of another load, the backward sweep and the
    back-substitution re-made, each against dense solves of S to 1e-12."""
    rng = np.random.default_rng(5)
    for block, system, mesh in piezo_bodies:
        kept = condense(block, system, mesh, kind)
        c = condense(block, system, mesh, kind, budget=Always())
        assert isinstance(c.factor, released.Released) and c.factorization == kind and c.factor.remade == 0
        assert np.array_equal(c.stiffness, kept.stiffness)          # the same Schur complement
        S, F = quasi_definite(block)
        D, g = S.toarray(), c.gamma
        i = np.setdiff1d(np.arange(len(D)), g)

        def reduced(b, D=D, g=g, i=i):
            return b[g] - D[np.ix_(g, i)] @ np.linalg.solve(D[np.ix_(i, i)], b[i])

        fwd = c.forward(F)
        assert c.factor.remade == 0                                  # the kept sweep of the body's load
        assert rel(fwd.reduced, reduced(F)) < 1e-12
        b = rng.standard_normal(len(D))
        assert rel(c.forward(b).reduced, reduced(b)) < 1e-12
        assert c.factor.remade == 1
        v = rng.standard_normal(len(g))
        x = c.factor.backward(c.forward(b), v)
        assert np.array_equal(x[g], v)
        assert rel(x[i], np.linalg.solve(D[np.ix_(i, i)], b[i] - D[np.ix_(i, g)] @ v)) < 1e-12
        force = rng.standard_normal(c.jump.shape[0])
        lifted = b.copy()
        lifted[g] -= c.jump.T @ force
        assert rel(c.back_substitute(c.forward(b), force), np.linalg.solve(D, lifted)) < 1e-12
        assert rel(c.solve(b), np.linalg.solve(D, b)) < 1e-12
        B = rng.standard_normal((len(D), 3))                         # several right-hand sides at once
        assert rel(c.solve(B), np.linalg.solve(D, B)) < 1e-12


def _solve_both(scene, monkeypatch, **options):
    out = {}
    for release in (False, True):
        monkeypatch.setattr(budget, "RELEASE", release)
        solver = cc.ContactSolver(scene, **options)
        out[release] = (solver, solver.solve())
    return out


@pytest.mark.parametrize("elastic", [True, False], ids=["elastic", "piezo"])
def test_gamma3_3d_with_the_factors_freed_equals_kept(monkeypatch, elastic):
    """Two boxes, non-matching faces, "gamma3" on the default (condensed) route: the answer with every body's
    factors freed and re-made equals the one with them kept to rounding (measured max |du| / max |u|: 6.8e-16
    elastic, 1.4e-15 piezoelectric; bound 1e-12), the same active rows; ``info.released`` says which ran. A
    re-solve with other loads after the release (the forward sweep re-made) equals the kept solver's re-solve
    (measured 1.6e-15, 3.3e-15) and a fresh solve of the new scene (2.3e-15, 2.9e-15)."""
    scene = two_boxes(6, "gamma3", elastic)
    out = _solve_both(scene, monkeypatch)
    (ks, kept), (rs, rel_) = out[False], out[True]
    assert kept.ok and rel_.ok
    assert not kept.info.released and rel_.info.released
    assert kept.info.factorization == rel_.info.factorization
    assert "back_substitution" in rel_.timings
    assert rel(np.concatenate([np.ravel(u) for u in rel_.u]), np.concatenate([np.ravel(u) for u in kept.u])) < 1e-12
    if not elastic:
        assert rel(np.concatenate([np.ravel(p) for p in rel_.phi if p is not None]),
                   np.concatenate([np.ravel(p) for p in kept.phi if p is not None])) < 1e-12
    assert np.array_equal(np.asarray(ks.cache.active), np.asarray(rs.cache.active))
    other = scene.with_loads(0, body_force=(0.0, 0.0, -3e9))
    again_kept, again_rel = ks.solve(other), rs.solve(other)
    fresh = cc.solve(other)
    assert again_rel.ok and again_rel.info.released and again_rel.info.factorizations == 0

    def u(s):
        return np.concatenate([np.ravel(x) for x in s.u])

    assert rel(u(again_rel), u(again_kept)) < 1e-12
    assert rel(u(again_rel), u(fresh)) < 1e-12
    assert rel(u(again_rel), u(rel_)) > 1e-3               # the new load was applied, not the kept sweep


def _abs_kept(solver) -> int:
    """Bytes of Kuu's, Kup's and Kpp's |values| the solver's blocks keep for the checks (Block.abs_values; Kup^T
    reads Kup's; |jump|, of the contact rows alone, is left out)."""
    return sum(v[2].nbytes for b in solver.problem.blocks for k, v in b.absolute.items()
               if k in ("Kuu", "Kup", "Kpp") and v[2] is not None)


def test_a_re_solve_after_a_release_keeps_no_abs_values(monkeypatch):
    """The checks keep |K|'s values from a matrix's second |K| |x| on (a re-solve's), 8 bytes per stored entry of
    Kuu, Kup and Kpp; where the condensed route freed the bodies' factors (memory short) they go with them: after
    two re-solves none is kept (before: 64,208 bytes here, as with the factors kept, unaccounted by the budget),
    and the answers are those of the solver that keeps both (u to rounding; measured 1.5e-15 to 3.3e-15 over the
    five kernel sets, bound 1e-12)."""
    scene = two_boxes(4, "gamma3", False)
    loads = [scene.with_loads(0, body_force=(0.0, 0.0, -f)) for f in (3e9, 1e9)]
    out = {}
    for release in (False, True):
        monkeypatch.setattr(budget, "RELEASE", release)
        solver = cc.ContactSolver(scene)
        out[release] = (solver, [solver.solve(), *(solver.solve(s) for s in loads)])
    kept, freed = out[False][0], out[True][0]
    assert _abs_kept(kept) == 8 * sum(M.nnz for b in kept.problem.blocks for M in (b.Kuu, b.Kup, b.Kpp)
                                      if M is not None)
    assert _abs_kept(freed) == 0 and all(s.info.released and s.ok for s in out[True][1])
    for a, b in zip(out[False][1], out[True][1]):
        assert rel(np.concatenate([np.ravel(u) for u in b.u]), np.concatenate([np.ravel(u) for u in a.u])) < 1e-12


def test_without_pardiso_superlu_is_released_and_remade(monkeypatch):
    """No Intel oneMKL: SuperLU factorises the bodies, and with the factors freed the answer equals the kept one
    to rounding (measured 1.1e-15; bound 1e-12), the re-made interior factorisations SuperLU's too."""
    no_pardiso(monkeypatch)
    out = _solve_both(two_boxes(5, "gamma3", True), monkeypatch)
    kept, rel_ = out[False][1], out[True][1]
    assert kept.info.factorization == rel_.info.factorization == "superlu"
    assert rel_.info.released and not kept.info.released
    assert rel(np.concatenate([np.ravel(u) for u in rel_.u]), np.concatenate([np.ravel(u) for u in kept.u])) < 1e-12


def test_the_budget_frees_the_factors_only_when_memory_is_short(monkeypatch, tmp_path):
    """RELEASE None: the factors are freed where what follows them (the later bodies' factorisations scaled by
    their nonzeros, INTERFACE_BYTES per entry of the Sigma blocks) exceeds SAFETY times MemAvailable, read from
    /proc/meminfo; kept where it fits, where that file cannot be read, or the factors' memory is unknown."""
    monkeypatch.setattr(budget, "RELEASE", None)
    meminfo = tmp_path / "meminfo"
    monkeypatch.setattr(budget, "MEMINFO", str(meminfo))
    monkeypatch.setattr(budget, "PROC_CGROUP", str(tmp_path / "no cgroup"))     # not the test machine's limits

    def available(kb):
        meminfo.write_text(f"MemTotal:       99999999 kB\nMemFree:  1 kB\nMemAvailable:   {kb} kB\n")

    available(4 * 2**20)
    assert budget.mem_available() == 4 * 2**30
    b = budget.Budget([100, 300], [1000, 500])
    interface = budget.INTERFACE_BYTES * (1000**2 + 500**2)          # 200 MB
    need = 2**30 + 3 * 2**30 + interface                              # body 2 estimated 3x body 1's factors
    # body 1, 1 GiB of factors: body 2's 3 GiB and the interface do not fit in 0.75 x 4 GiB
    assert b.release(2**30)
    # body 2, 3 GiB: the interface (200 MB) fits
    assert not b.release(3 * 2**30)
    assert b.released == 1
    available(int(need / budget.SAFETY / 1024) + 1)
    assert not budget.Budget([100, 300], [1000, 500]).release(2**30)
    assert not budget.Budget([100], [1000]).release(None)             # the factors' memory unknown
    meminfo.unlink()
    assert budget.mem_available() is None
    assert not budget.Budget([100], [10**6]).release(2**30)          # no /proc/meminfo: keep, as before
    monkeypatch.setattr(budget, "RELEASE", True)
    assert budget.Budget([100], [1]).release(None)


@pytest.mark.parametrize("pardiso", [pytest.param(True, marks=needs_pardiso), False], ids=["pardiso", "superlu"])
def test_a_scene_is_released_by_the_budget_when_memory_is_short(monkeypatch, tmp_path, pardiso):
    """The decision reaches the route: MemAvailable of 1 KB frees both bodies' factors (info.released; SuperLU's
    factors' memory is known too), the machine's real memory keeps them for this small scene; the answers equal
    to 1e-12."""
    monkeypatch.setattr(budget, "RELEASE", None)
    if not pardiso:
        no_pardiso(monkeypatch)
    scene = two_boxes(4, "gamma3", True)
    kept = cc.solve(scene)
    meminfo = tmp_path / "meminfo"
    meminfo.write_text("MemAvailable:   1 kB\n")
    monkeypatch.setattr(budget, "MEMINFO", str(meminfo))
    short = cc.solve(scene)
    assert short.info.released and not kept.info.released
    assert short.info.factorization == kept.info.factorization == ("pardiso" if pardiso else "superlu")
    assert rel(np.concatenate([np.ravel(u) for u in short.u]), np.concatenate([np.ravel(u) for u in kept.u])) < 1e-12


def _remade(solver):
    return [c.factor.remade for c in solver.cache.condensation.bodies]


@pytest.mark.parametrize("scale", [1.0, 0.0], ids=["pressed", "unloaded"])
def test_the_cones_route_sweeps_each_freed_body_once_per_back_substitution(monkeypatch, scale):
    """P2 "gamma3" (the cones, condensed): with the factors freed each sweep re-makes a body's interior
    factorisation, so the route takes the body's forward sweep once and reuses it: v0 = Sigma^-1 r without a
    backward sweep, the back-substitution from that sweep (was: a full solve for v0 and another for the fields,
    five factorisations a body per solve; now three: the back-substitution, the finish's and the tangency's;
    none but the fields' one without contact), the forward sweep the condensation's (its own load's, kept; the
    finish's load case reads it). The answers equal the kept factors' to 1e-12 (measured 2.3e-15 pressed, 0
    unloaded), on the first solve and on a re-solve with other loads on the first body (one forward sweep more
    for it alone: was two)."""
    from conftest import two_blocks as blocks

    scene = blocks((8, 4), (5, 3), scale=scale)
    out = _solve_both(scene, monkeypatch, condition="gamma3", degree=2)
    (ks, kept), (rs, rel_) = out[False], out[True]
    assert rel_.info.released and rel_.info.method == "condensed"
    assert rel(np.concatenate([np.ravel(u) for u in rel_.u]), np.concatenate([np.ravel(u) for u in kept.u])) < 1e-12
    first = _remade(rs)
    assert first == ([3, 3] if scale else [1, 1])
    other = scene.with_loads(0, body_force=(0.0, -3e9))
    again_kept, again_rel = ks.solve(other), rs.solve(other)
    assert rel(np.concatenate([np.ravel(u) for u in again_rel.u]),
               np.concatenate([np.ravel(u) for u in again_kept.u])) < 1e-12
    assert [b - a for a, b in zip(first, _remade(rs))] == [4, 3]             # the other loads press them


def test_a_control_group_limit_bounds_the_available_memory(monkeypatch, tmp_path):
    """In a container /proc/meminfo is the host's: the room under the process's control-group limits (v2
    memory.max - memory.current of its group and the groups above; v1 memory.limit_in_bytes - usage) bounds
    MemAvailable, and frees the factors the host's memory would have kept (failed before: the host's 64 GiB
    read, the factors kept under a 1 GiB limit). No limit ("max"), no control groups, or unreadable files:
    MemAvailable alone, as before."""
    monkeypatch.setattr(budget, "RELEASE", None)
    meminfo, proc, root = tmp_path / "meminfo", tmp_path / "cgroup", tmp_path / "fs"
    meminfo.write_text(f"MemAvailable:   {64 * 2**20} kB\n")                   # 64 GiB on the host
    monkeypatch.setattr(budget, "MEMINFO", str(meminfo))
    monkeypatch.setattr(budget, "PROC_CGROUP", str(proc))
    monkeypatch.setattr(budget, "CGROUP", str(root))
    proc.write_text("0::/box/job\n")
    group = root / "box" / "job"
    group.mkdir(parents=True)
    (group / "memory.max").write_text("max\n")
    (group / "memory.current").write_text(f"{2**29}\n")
    assert budget.mem_available() == 64 * 2**30                                # no limit on the group
    (root / "box" / "memory.max").write_text(f"{2**30}\n")                    # 1 GiB on the group above,
    (root / "box" / "memory.current").write_text(f"{2**29}\n")                # half of it used
    assert budget.mem_available() == 2**29
    assert budget.Budget([100, 300], [1000, 500]).release(2**28)              # 256 MiB now, 768 MiB later
    meminfo.unlink()
    assert budget.mem_available() == 2**29                                     # the limit without /proc/meminfo
    (group / "memory.max").write_text(f"{2**29 + 2**27}\n")                   # the tighter limit below it
    assert budget.mem_available() == 2**27
    (group / "memory.max").write_text("garbage\n")
    assert budget.mem_available() == 2**29
    proc.write_text("4:memory:/job\n3:cpu:/\n")                              # cgroup v1
    v1 = root / "memory" / "job"
    v1.mkdir(parents=True)
    (v1 / "memory.limit_in_bytes").write_text(f"{3 * 2**30}\n")
    (v1 / "memory.usage_in_bytes").write_text(f"{2**30}\n")
    assert budget.mem_available() == 2 * 2**30
    proc.unlink()
    assert budget.mem_available() is None and budget.cgroup_room() is None    # neither: keep, as before
    assert not budget.Budget([100], [10**6]).release(2**30)


@pytest.mark.filterwarnings("ignore::cvxcontact.errors.ResolutionWarning")    # the coarse shared scene
def test_a_body_whose_factors_stay_takes_its_turn_in_the_budget(monkeypatch, tmp_path):
    """A clamped foundation first (its contact part held: no Gamma dofs, its factors never freed), the block
    second: the block's factors are the last ones, so only the interface program follows them and a
    MemAvailable of (interface + the block's factors) / SAFETY keeps them. Before, the foundation did not take
    its turn: the block was read as body 0, itself counted among the later bodies (its factors x 176 / 52
    nonzeros) and freed. 1 KB frees them; the answers equal the kept ones to 1e-12."""
    from foundation_scenes import clamped_foundation

    upper, scene = clamped_foundation("pair")
    scene = cc.Scene(scene.bodies[1], upper, contacts=list(scene.contacts))
    monkeypatch.setattr(budget, "RELEASE", False)
    solver = cc.ContactSolver(scene, condition="sigma1")
    kept = solver.solve()
    foundation, block = solver.cache.condensation.bodies
    assert len(foundation.gamma) == 0 and 0 < len(block.gamma) < block.factor.n
    interface = budget.INTERFACE_BYTES * len(block.gamma) ** 2
    meminfo = tmp_path / "meminfo"
    monkeypatch.setattr(budget, "MEMINFO", str(meminfo))
    monkeypatch.setattr(budget, "PROC_CGROUP", str(tmp_path / "no cgroup"))
    monkeypatch.setattr(budget, "RELEASE", None)
    meminfo.write_text(f"MemAvailable: {int((interface + block.factor.memory) / budget.SAFETY / 1024) + 1} kB\n")
    fits = cc.solve(scene, condition="sigma1")
    assert not fits.info.released
    meminfo.write_text("MemAvailable: 1 kB\n")
    short = cc.solve(scene, condition="sigma1")
    assert short.info.released
    for sol in (fits, short):
        assert rel(np.concatenate([np.ravel(u) for u in sol.u]), np.concatenate([np.ravel(u) for u in kept.u])) < 1e-12


def test_without_pardiso_the_remade_interior_factor_keeps_the_bodys_order(monkeypatch):
    """No Intel oneMKL, piezoelectric boxes, the factors freed: each re-made interior factorisation is SuperLU's
    on the body's own elimination order, not SciPy's default (COLAMD, partial pivoting): its factors' nonzeros
    at most 1.05 x those of the first factorisation's leading (interior) block, hence of the whole (measured
    L + U: 13,454 and 4,095 against leading blocks of 13,529 and 4,095; COLAMD's were 17,914 for the first body,
    +32 %, failing the bound), and the answer equals the kept factors' to 1e-12."""
    no_pardiso(monkeypatch)
    made = []
    splu = factor.spla.splu

    def recording(A, *args, **kwargs):
        lu = splu(A, *args, **kwargs)
        made.append((A.shape[0], lu))
        return lu

    monkeypatch.setattr(factor.spla, "splu", recording)
    out = _solve_both(two_boxes(5, "gamma3", False), monkeypatch)
    (_, kept), (rs, rel_) = out[False], out[True]
    assert rel_.info.released and rel_.info.factorization == "superlu"
    assert rel(np.concatenate([np.ravel(u) for u in rel_.u]), np.concatenate([np.ravel(u) for u in kept.u])) < 1e-12
    bodies = rs.cache.condensation.bodies
    assert all(c.factor.remade > 0 and c.factor.order is not None for c in bodies)
    for c in bodies:
        k = len(c.factor.interior)
        # the released run's own factorisation (not the SuperLU object of its factor L that SuperLUFactorization
        # keeps for its sweeps: that one's U is the identity, n stored)
        first = [lu for n, lu in made if n == c.factor.n and min(lu.L.nnz, lu.U.nnz) > n][-1]
        leading = first.L[:k, :k].nnz + first.U[:k, :k].nnz
        remade = [lu.L.nnz + lu.U.nnz for n, lu in made if n == k]
        assert len(remade) >= c.factor.remade
        assert max(remade) <= 1.05 * leading <= 1.05 * (first.L.nnz + first.U.nnz)
