"""The factorisation adapters (cvxcontact.backends.factor): Schur complement and solves against dense
linear algebra, whole solves with PARDISO against SuperLU, typed errors. PARDISO tests skip without oneMKL."""

import ctypes
import os
import warnings

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import cvxcontact as cc
from cvxcontact.apps.demo import thin_layer, two_blocks
from cvxcontact.backends import factor
from cvxcontact.backends import sparse as sparse_backend
from cvxcontact.backends.condensed import condense, contact_dofs, quasi_definite
from cvxcontact.discrete import Block, units
from cvxcontact.errors import CvxContactError, SolverError
from cvxcontact.fem import p2
from cvxcontact.fem.assembly import assemble
from cvxcontact.geometry.quadratic import P2Nodes
from cvxcontact.contact.quadratic import quadratic_interface

from conftest import rel
from matrices import surplus_saddle
from scenes3d import bumped_blocks

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

HAS_PARDISO = factor.pardiso_available()
needs_pardiso = pytest.mark.skipif(not HAS_PARDISO, reason="Intel oneMKL (libmkl_rt) not installed")
KINDS = ["superlu", pytest.param("pardiso", marks=needs_pardiso)]


def dense_schur(S, g):
    """S_GG - S_GI S_II^{-1} S_IG by a dense solve (independent of both adapters)."""
    S = S.toarray()
    i = np.setdiff1d(np.arange(len(S)), g)
    return S[np.ix_(g, g)] - S[np.ix_(g, i)] @ np.linalg.solve(S[np.ix_(i, i)], S[np.ix_(i, g)])


def body_matrices(degree):
    """(block, system, mesh or P2 nodes) of both bodies of the demo scene (nx = 8), scaled."""
    scene = two_blocks(nx=8)
    if degree == 1:
        systems = [assemble(b) for b in scene.bodies]
        meshes = [b.mesh for b in scene.bodies]
        jump = scene.interface.jump
    else:
        meshes = [P2Nodes(b.mesh) for b in scene.bodies]
        systems = [p2.assemble(b, nd) for b, nd in zip(scene.bodies, meshes)]
        jump = quadratic_interface(scene, meshes).jump
    un = units(scene, systems)
    return [(Block.scaled(s, jump(k, len(m.points)), un), s, m) for k, (s, m) in enumerate(zip(systems, meshes))]


@pytest.fixture(scope="module", params=[1, 2], ids=["P1", "P2"])
def bodies(request):
    return body_matrices(request.param)


@pytest.mark.parametrize("kind", KINDS)
def test_schur_complement_and_solves_match_dense(bodies, kind):
    """Sigma to 1e-12 of the dense Schur complement; S^{-1} b, the forward sweep's reduced right-hand side and
    the backward sweep with given Gamma values against dense solves."""
    rng = np.random.default_rng(3)
    for block, system, mesh in bodies:
        c = condense(block, system, mesh, kind)
        assert c.factorization == kind
        S = quasi_definite(block)[0]
        g = c.gamma
        assert 0 < len(g) < S.shape[0]
        assert rel(c.stiffness, dense_schur(S, g)) < 1e-12
        assert np.array_equal(c.stiffness, c.stiffness.T) and np.linalg.eigvalsh(c.stiffness).min() > 0
        D = S.toarray()
        b = rng.standard_normal(len(D))
        assert rel(c.solve(b), np.linalg.solve(D, b)) < 1e-12
        i = np.setdiff1d(np.arange(len(D)), g)
        fwd = c.factor.forward(b)
        reduced = b[g] - D[np.ix_(g, i)] @ np.linalg.solve(D[np.ix_(i, i)], b[i])
        assert rel(fwd.reduced, reduced) < 1e-12
        v = rng.standard_normal(len(g))
        x = c.factor.backward(fwd, v)
        assert np.array_equal(x[g], v)
        assert rel(x[i], np.linalg.solve(D[np.ix_(i, i)], b[i] - D[np.ix_(i, g)] @ v)) < 1e-12
        force = rng.standard_normal(c.jump.shape[0])          # the back-substitution of the condensed solve
        lifted = b.copy()
        lifted[g] -= c.jump.T @ force
        assert rel(c.back_substitute(c.forward(b), force), np.linalg.solve(D, lifted)) < 1e-12
        assert rel(c.unconstrained(fwd), np.linalg.solve(D, b)[g]) < 1e-12


@pytest.mark.parametrize("kind", KINDS)
def test_the_condensation_keeps_one_copy_of_each_sigma_and_its_cholesky_factors(bodies, kind):
    """Sigma (m x m dense, m the contact dofs: the largest arrays of a 3D condensation besides the factor) is
    held once: the body's ``stiffness`` is its factorisation's Schur complement, and the interface compliance
    solves with the factorisation's own Cholesky factors, which are Sigma's (checked against dense algebra). A
    body condensed with the shift of ``held`` keeps Sigma = Schur(S + D) - D apart from the shifted Schur
    complement it factorised, equal to the dense Schur complement of S, and the compliance factorises that."""
    import scipy.linalg as sla

    from cvxcontact.backends.condensed import Compliance

    conds = [condense(block, system, mesh, kind) for block, system, mesh in bodies]
    for c in conds:
        assert c.stiffness is c.factor.schur
        L, lower = c.factor.cholesky
        assert rel(sla.cho_solve((L, lower), c.stiffness), np.eye(len(c.gamma))) < 1e-10
    E = sp.eye(conds[0].jump.shape[0], format="csr")
    comp = Compliance(conds, E)
    assert all(np.shares_memory(f[0], c.factor.cholesky[0]) for f, c in zip(comp._factors, conds))
    block, system, mesh = bodies[0]
    held = condense(block, system, mesh, kind, held=True)
    S = quasi_definite(block)[0]
    assert held.stiffness is not held.factor.schur
    assert rel(held.stiffness, dense_schur(S, held.gamma)) < 1e-12
    comp = Compliance([held], sp.eye(held.jump.shape[0], format="csr"))
    assert not np.shares_memory(comp._factors[0][0], held.factor.cholesky[0])
    assert rel(sla.cho_solve(comp._factors[0], held.stiffness), np.eye(len(held.gamma))) < 1e-10


@needs_pardiso
def test_pardiso_on_a_random_quasi_definite_matrix_with_threads():
    """A generic quasi-definite S (not from a mesh), Schur rows scattered, with one MKL thread: Sigma and a
    solve against dense; the memory is released on request and once only."""
    rng = np.random.default_rng(0)
    A = sp.random(80, 80, 0.08, random_state=1)
    P = sp.random(30, 30, 0.2, random_state=2)
    C = sp.random(80, 30, 0.1, random_state=3)
    S = sp.bmat([[A @ A.T + 2 * sp.eye(80), C], [C.T, -(P @ P.T + sp.eye(30))]], format="csc")
    g = np.sort(rng.choice(110, 12, replace=False))
    f = factor.factorize(S, g, "pardiso", threads=1)
    assert f.name == "pardiso"
    assert rel(f.schur, dense_schur(S, g)) < 1e-12
    b = rng.standard_normal(110)
    assert rel(f.solve(b), np.linalg.solve(S.toarray(), b)) < 1e-12
    f.release()
    assert not f._finalizer.alive
    f.release()                                            # idempotent


@needs_pardiso
def test_pardiso_gives_one_input_the_same_bits_run_after_run_on_two_threads():
    """Each PARDISO handle runs in oneMKL's reproducible mode (iparm[33] = its thread count): on 2 threads, six new
    handles on thin_layer(200)'s K(A) (the sparse route's way: analysed on the bonded values, a numeric factorisation
    of K(A), a single right-hand side solved) give the same bits, and so do six condensations of its first body
    (Sigma, a forward and a backward sweep; these were the same on main too). Without it the single right-hand-side
    solves gave up to 4 distinct answers in 6, 2 in most runs (benchmarks/pardiso_cnr.py). The answers solve their
    systems: componentwise backward errors measured 1.4e-14 to 1.6e-14 (K(A)) and 6.5e-15 to 9.8e-15 (S) under the
    five kernel sets and MKL_CBWR=COMPATIBLE; bound 5e-12 (>= 310x)."""
    problem = cc.ContactSolver(thin_layer(200), method="sparse").problem
    sc = sparse_backend.SparseContact(list(problem.blocks), problem.E)
    rng = np.random.default_rng(5)
    moves = np.asarray(abs(sc.G).sum(axis=1)).ravel() > 0
    K0, K = sc.matrix(moves), sc.matrix(moves & (rng.random(sc.m) < 0.6))
    b = rng.standard_normal(K.shape[0])
    S, _ = quasi_definite(problem.blocks[0])
    gamma = contact_dofs(problem.blocks[0])
    F = rng.standard_normal(S.shape[0])
    mixed, condensed = set(), set()
    for _ in range(6):
        h = factor.PardisoSymmetric(K, threads=2).analyse(K0)
        x = h.factor(K).solve(b)
        h.release()
        mixed.add(x.tobytes())
        f = factor.factorize(S, gamma, "pardiso", threads=2)
        y = f.solve(F)
        condensed.add(f.schur.tobytes() + y.tobytes())
        f.release()
    assert len(mixed) == 1 and len(condensed) == 1
    backward = [np.max(abs(M @ z - r) / (abs(M) @ abs(z) + abs(r))) for M, z, r in ((K, x, b), (S, y, F))]
    assert max(backward) < 5e-12


@needs_pardiso
def test_each_pardiso_call_asks_for_the_reproducible_mode_at_the_thread_count_it_runs_on(monkeypatch):
    """iparm[33] (CNR) is the count of threads the call runs on: ``threads=`` where given; MKL_NUM_THREADS /
    OMP_NUM_THREADS read when the handle is made (a sweep worker sets them after MKL loaded), for that handle's whole
    life; else MKL's own count, asked at the call. A handle made under one environment and solved under another keeps
    its count. (Main left iparm[33] at pardisoinit's -1: no CNR; this test failed there.) The solve is checked against SciPy's LU."""
    lib = factor._load()
    rng = np.random.default_rng(3)
    A = sp.random(60, 60, density=0.1, random_state=rng)
    K = sp.csc_matrix(A + A.T + 20 * sp.eye(60))
    K.sort_indices()
    b = rng.standard_normal(60)
    seen = []
    call = factor.PardisoFactorization._call

    def spy(self, phase, rhs, x, nrhs=1):
        call(self, phase, rhs, x, nrhs)
        seen.append((phase, int(self._iparm[33])))

    monkeypatch.setattr(factor.PardisoSymmetric, "_call", spy)
    for var in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        monkeypatch.delenv(var, raising=False)
    mkl = lib.MKL_Get_Max_Threads()
    for env, threads, want in ((None, None, mkl), ("3", None, 3), ("3", 2, 2), (None, 1, 1)):
        if env is None:
            monkeypatch.delenv("MKL_NUM_THREADS", raising=False)
        else:
            monkeypatch.setenv("MKL_NUM_THREADS", env)
        seen.clear()
        h = factor.PardisoSymmetric(K, threads=threads).factor(K)
        monkeypatch.setenv("MKL_NUM_THREADS", "1")              # after the handle was made: not its count
        x = h.solve(b)
        h.release()
        assert [p for p, _ in seen] == [12, 33] and {t for _, t in seen} == {want}, (env, threads, seen)
        # measured 5.2e-16 relative to max|x| against SciPy's LU (every count, 5 kernel sets); bound 1e-12 (1900x)
        assert np.max(abs(x - spla.spsolve(K, b))) < 1e-12 * np.max(abs(x))


@needs_pardiso
def test_pardiso_refuses_a_singular_matrix():
    """A singular interior block (a decoupled dof with a zero diagonal) is a typed error, never a Sigma."""
    A = sp.diags(np.r_[np.full(20, 2.0), 0.0]) + sp.diags(np.full(20, -1.0), 1) + sp.diags(np.full(20, -1.0), -1)
    A = sp.csc_matrix(A)
    A[19, 20] = A[20, 19] = 0.0
    A.eliminate_zeros()
    with pytest.raises(SolverError, match="PARDISO"):
        factor.factorize(A, np.array([0, 1]), "pardiso")


def test_bad_factorization_names_and_threads_are_typed_errors(monkeypatch):
    scene = two_blocks(nx=4)
    for bad in ("mumps", "", None, 1, "SuperLU"):
        with pytest.raises(SolverError, match="factorization must be one of .*auto.*superlu.*pardiso"):
            cc.solve(scene, factorization=bad)
    with pytest.raises(SolverError, match="factorization must be one of"):
        cc.ContactSolver(scene, factorization="cholmod")
    S = sp.eye(4, format="csc")
    for bad in (0, -1, True, 1.5):
        with pytest.raises(SolverError, match="threads"):
            factor.factorize(S, np.array([3]), "superlu", threads=bad)
    with pytest.raises(SolverError, match="sorted"):
        factor.factorize(S, np.array([3, 1]), "superlu")
    # without oneMKL: "pardiso" says how to install it, "auto" runs SuperLU
    monkeypatch.setattr(factor, "_LIB", None)
    monkeypatch.setattr(factor, "_LIB_ERROR", "libmkl_rt (Intel oneMKL) was not found")
    with pytest.raises(SolverError, match=r'pip install "cvxcontact\[pardiso\]"') as info:
        cc.solve(scene, factorization="pardiso")
    assert isinstance(info.value, CvxContactError)
    sol = cc.solve(scene)
    assert sol.ok and sol.info.factorization == "superlu"


CASES = [(1, "gamma3"), (1, "sigma1"), (2, "gamma3"), (2, "sigma1")]


@needs_pardiso
@pytest.mark.parametrize("degree,condition", CASES, ids=[f"P{d}-{c}" for d, c in CASES])
def test_whole_solve_pardiso_equals_superlu(degree, condition):
    """cc.solve on the demo scene with each factorisation: both ok, u, phi and the contact force agree to
    1e-11 of their size (measured 3e-14 or less), except P2 "gamma3", an interior-point answer without exact
    finish: u and phi measured 7.9e-14 .. 7.0e-13 and once 1.08e-11 (after a change of 1e-16 in the volume
    loads' quadrature constants), so 2e-9 there (185x); the contact force 1e-9 (measured 2.6e-11 .. 1.4e-10), its
    complementarity 5.0e-7 .. 5.5e-7 (clarabel 0.10.0, 0.11.1), so tol=1e-5 there."""
    scene = two_blocks(nx=8)
    tol = 1e-5 if (degree, condition) == (2, "gamma3") else 1e-6
    sols = {k: cc.solve(scene, condition, degree=degree, factorization=k, tol=tol) for k in ("superlu", "pardiso")}
    a, b = sols["superlu"], sols["pardiso"]
    assert a.ok and b.ok
    assert a.info.factorization == "superlu" and b.info.factorization == "pardiso"
    interior = (degree, condition) == (2, "gamma3")
    for k in range(2):
        assert rel(b.u[k], a.u[k]) < (2e-9 if interior else 1e-11)
    assert rel(b.phi[0], a.phi[0]) < (2e-9 if interior else 1e-11)
    assert rel(b.contact.force, a.contact.force) < (1e-9 if interior else 1e-11)


@needs_pardiso
def test_contact_solver_resolve_with_pardiso():
    """A ContactSolver re-solve with other loads (warm start, no new factorisation) equals a fresh SuperLU
    solve of the loaded scene."""
    base = two_blocks(nx=8)
    solver = cc.ContactSolver(base, "gamma3", factorization="pardiso")
    first = solver.solve()
    assert first.ok and first.info.factorization == "pardiso" and first.info.factorizations == 1
    again = solver.solve(two_blocks(nx=8, scale=1.7))
    assert again.ok and again.info.factorizations == 0 and again.info.factorization == "pardiso"
    fresh = cc.solve(two_blocks(nx=8, scale=1.7), "gamma3", factorization="superlu")
    for k in range(2):
        assert rel(again.u[k], fresh.u[k]) < 1e-11
    assert rel(again.contact.force, fresh.contact.force) < 1e-11


@needs_pardiso
def test_auto_falls_back_to_superlu_when_pardiso_refuses(monkeypatch):
    """'auto' with a PARDISO that fails: a warning and SuperLU; an explicit 'pardiso' raises."""
    def refuse(*args, **kwargs):
        raise SolverError("PARDISO perturbed 1 pivot(s)")

    monkeypatch.setattr(factor, "PardisoFactorization", refuse)
    scene = two_blocks(nx=4)
    with pytest.warns(UserWarning, match="falling back to SuperLU"):
        sol = cc.solve(scene)
    assert sol.ok and sol.info.factorization == "superlu"
    with pytest.raises(SolverError, match="perturbed"):
        cc.solve(scene, factorization="pardiso")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cc.solve(scene, factorization="superlu").info.factorization == "superlu"


def test_mkl_threads_follow_the_argument_then_the_environment(monkeypatch):
    """threads= wins; else MKL_NUM_THREADS / OMP_NUM_THREADS as set when the factorisation runs (what the
    sweep workers set after MKL may be loaded); else 0, MKL's default (all cores)."""
    for k in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        monkeypatch.delenv(k, raising=False)
    assert factor._threads(None) == 0 and factor._threads(3) == 3
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    assert factor._threads(None) == 2
    monkeypatch.setenv("MKL_NUM_THREADS", "1")
    assert factor._threads(None) == 1 and factor._threads(4) == 4
    monkeypatch.setenv("MKL_NUM_THREADS", "lots")
    assert factor._threads(None) == 2


@needs_pardiso
def test_pardiso_honours_the_thread_count_of_a_sweep_worker(monkeypatch):
    """The count reaches MKL for the call only: inside it MKL sees 1 thread, afterwards its own setting."""
    lib = factor._load()
    lib.MKL_Get_Max_Threads.restype = int
    before = lib.MKL_Get_Max_Threads()
    seen = []
    original = lib.pardiso

    class Spy:                                            # ctypes functions cannot be patched per attribute
        def __getattr__(self, name):
            return getattr(lib, name)

        def pardiso(self, *args):
            seen.append(lib.MKL_Get_Max_Threads())
            return original(*args)

    monkeypatch.setattr(factor, "_load", lambda: Spy())
    monkeypatch.setenv("MKL_NUM_THREADS", "1")
    S = sp.diags(np.full(6, 2.0)) + sp.diags(np.full(5, -1.0), 1) + sp.diags(np.full(5, -1.0), -1)
    f = factor.factorize(sp.csc_matrix(S), np.array([5]), "pardiso")
    f.solve(np.ones(6))
    assert seen and set(seen) == {1}
    assert lib.MKL_Get_Max_Threads() == before


# ---------------------------------------------------------------------------------------------------------
# structurally singular matrices: refused before SuperLU (benchmarks/results/superlu_structurally_singular.md)

def printed(capfd) -> str:
    """What the process wrote on its file descriptors 1 and 2 since the last read, C stdio flushed first (BLAS's
    xerbla prints with printf, buffered while fd 1 is a file)."""
    if os.name == "posix":
        ctypes.CDLL(None).fflush(None)
    out, err = capfd.readouterr()
    return out + err


@pytest.mark.parametrize("n, m", [(24, 8), (20, 4), (10, 8)])
def test_a_structurally_singular_matrix_is_refused_before_superlu_sees_it(n, m, capfd):
    """m constraint rows on m - 1 unknowns: singular whatever the values. Given to SuperLU (SciPy 1.17.1) these
    print "On entry to DGEMV parameter number 2 had an illegal value" and stop at dpanel_bmod.c (24, 8), print
    DTRSV's and DGEMV's (20, 4), or print nothing and return factors with rounding pivots, a solve of max|x|
    ~1e17 (10, 8), under every OpenBLAS kernel set tried. Every route refuses them with the same RuntimeError,
    silently; the matrix without its surplus row is factorised, as the dense solve gives it."""
    K = surplus_saddle(n, m)
    routes = (factor.lu,            # (these small matrices are dense enough for its LAPACK route, DENSE_FILL)
              factor.superlu, lambda K: sparse_backend.factorize(K, np.arange(K.shape[0])))
    printed(capfd)
    for factorise in routes:
        with pytest.raises(RuntimeError, match=f"structural rank {n + m - 1} of {n + m}"):
            factorise(K)
    assert "illegal value" not in printed(capfd)
    K1 = surplus_saddle(n, m, surplus=False)
    b = np.cos(np.arange(K1.shape[0]))
    for factorise in routes:
        x = factorise(K1).solve(b)
        assert rel(x, np.linalg.solve(K1.toarray(), b)) < 2e-11           # measured <= 1.5e-13 (cond ~3e3)
    assert printed(capfd) == ""


def test_the_p2_gamma3_cuts_on_bumped_blocks_print_nothing_and_factorise_correctly(monkeypatch, capfd):
    """The scene where "On entry to DGEMV parameter number 2 had an illegal value" was printed: linear P2
    gamma3, the exact finish by accumulated cuts, whose tangency Newton meets a structurally singular system
    (more point rows than the unknowns they touch: structural rank 2,179 of 2,221 under the SkylakeX kernels,
    2,178 of 2,220 under Prescott and Sandybridge). That system is refused before SuperLU (the Newton then
    declines, as it did on SuperLU's error); every factorisation SuperLU makes in the run solves a probe
    system to a backward error of rounding; nothing is printed; the answer passes its checks."""
    refused, worst = [], [0.0]
    check, splu = factor.structurally_nonsingular, spla.splu

    def counting(K):
        try:
            check(K)
        except RuntimeError:
            refused.append(K.shape[0])
            raise

    def probed(K, *args, **kw):
        lu = splu(K, *args, **kw)
        v = np.cos(0.7548776662466927 * np.arange(K.shape[0])) + 1.5
        b = K @ v
        x = lu.solve(b)
        worst[0] = max(worst[0], float(np.abs(K @ x - b).max() / (abs(K).max() * np.abs(x).max() + np.abs(b).max())))
        return lu

    monkeypatch.setattr(factor, "structurally_nonsingular", counting)
    monkeypatch.setattr(spla, "splu", probed)
    printed(capfd)
    sol = cc.solve(bumped_blocks(), "gamma3", degree=2)
    assert "illegal value" not in printed(capfd)
    assert refused                                   # the triggering system was met (measured: 1, order 2,221)
    assert worst[0] < 2e-13                          # measured 7.0e-16 (1.2e-15 under Prescott)
    assert sol.ok and sol.info.finish == "accumulated cuts"
    r = sol.residuals()
    assert r["equilibrium"] < 1e-12 and r["feasibility"] < 5e-9     # measured 4.5e-16 .. 2.1e-15, 2.9e-11 .. 3.5e-11
    assert r["complementarity"] < 5e-6 and r["cone"] < 1e-13        # measured 2.4e-8 .. 2.7e-8, 1.0e-16 .. 1.4e-16


@pytest.fixture(scope="module")
def slender():
    """thin_layer(40) (a layer 0.02 thick held on its contact face: S^{-1} F of the layer is about 1.4e3 times
    its fields) solved by the condensed route with SuperLU and by the full route, one solve each."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)      # its elongated substrate cells: not read here
        scene = thin_layer(40)
        solver = cc.ContactSolver(scene, method="condensed", factorization="superlu")
        return solver, solver.solve(), cc.solve(scene, method="full")


def test_condensed_superlu_on_a_slender_layer_equals_the_full_route(slender):
    """The condensed route with SuperLU gives the full route's fields to rounding on a slender layer. Measured
    (default kernels, Haswell, Nehalem, Prescott, Sandybridge): u at most 7.2e-14, phi 9.1e-14 (both Haswell);
    before the backward sweep was split into triangular sweeps of the leading blocks (it subtracted
    S^{-1} [0; Sigma (x0_G - v)] from x0 = S^{-1} b): u 7.5e-10 (Haswell 2.9e-10), phi 2.5e-11 (1.3e-11)."""
    _, sol, full = slender
    assert sol.info.method == "condensed" and sol.info.factorization == "superlu"
    assert rel(np.concatenate([np.ravel(u) for u in sol.u]), np.concatenate([np.ravel(u) for u in full.u])) < 1e-11
    phi, phi_full = ([np.ravel(p) for p in s.phi if p is not None] for s in (sol, full))
    assert rel(np.concatenate(phi), np.concatenate(phi_full)) < 1e-11


def test_superlu_sweeps_of_a_slender_layer_equal_direct_interior_solves(slender):
    """The layer's forward sweep r = F_G - S_GI S_II^{-1} F_I and backward sweep x_I = S_II^{-1} (F_I - S_IG v)
    (v = 0: the face held; v = the unconstrained Gamma values, r's own, x = S^{-1} F) against SciPy's spsolve
    with S_II itself (COLAMD, partial pivoting: another factorisation). Measured (default kernels, Haswell,
    Nehalem, Prescott, Sandybridge) at most 4.8e-14 (r, Prescott); before the sweeps were split (x = x0 -
    S^{-1} [0; Sigma (x0_G - v)], x0 = S^{-1} F): r 1.0e-11, x_I 3.6e-8 for v = 0, 1.3e-14 for r's own v."""
    solver, _, _ = slender
    body = solver.cache.condensation.bodies[0]
    S, F = quasi_definite(solver.problem.blocks[0])
    S, g, fac = S.tocsr(), body.gamma, body.factor
    i = np.setdiff1d(np.arange(S.shape[0]), g)
    S_II = S[i][:, i].tocsc()
    r = F[g] - S[g][:, i] @ spla.spsolve(S_II, F[i])
    fwd = fac.forward(F)
    errors = [rel(fwd.reduced, r)]
    for v in (np.zeros(len(g)), fac.schur_solve(fwd.reduced)):
        x = fac.backward(fwd, v)
        errors.append(rel(x[i], spla.spsolve(S_II, F[i] - S[i][:, g] @ v)))
    assert max(errors) < 5e-12, errors


def test_superlu_sweeps_follow_superlus_own_permutations(monkeypatch):
    """SuperLU's row and column permutations, which its options here leave as the identity (natural order, diagonal
    pivots, symmetric mode: so on every scene measured), are followed by the sweeps where they are not: a minimum
    degree column order that keeps the three Gamma dofs last (this quasi-definite matrix of order 50; the other
    seeds tried move them and are refused) against dense solves. Measured at most 5.2e-16 (Nehalem; the other
    kernel sets 3.7e-16 to 5.0e-16)."""
    monkeypatch.setattr(factor, "SUPERLU_OPTIONS", dict(factor.SUPERLU_OPTIONS, permc_spec="MMD_AT_PLUS_A"))
    t, n, p = 162, 40, 10
    rng = np.random.default_rng(t)
    A = sp.random(n, n, density=0.08, random_state=t)
    B = sp.random(n, p, density=0.2, random_state=t + 1000)
    C = sp.random(p, p, density=0.3, random_state=t + 7)
    S = sp.bmat([[A @ A.T + sp.eye(n), B], [B.T, -(C @ C.T + sp.eye(p))]]).tocsc()
    g = np.sort(rng.choice(n, 3, replace=False))
    rest = np.setdiff1d(np.arange(n + p), g)
    f = factor.factorize(S, g, "superlu", order=np.concatenate([rng.permutation(rest), g]))
    assert not np.array_equal(f._perm_c, np.arange(n + p))
    D, b, v = S.toarray(), rng.standard_normal(n + p), rng.standard_normal(3)
    fwd = f.forward(b)
    x = f.backward(fwd, v)
    D_II = D[np.ix_(rest, rest)]
    r = b[g] - D[np.ix_(g, rest)] @ np.linalg.solve(D_II, b[rest])
    assert rel(f.solve(b), np.linalg.solve(D, b)) < 1e-13 and rel(f.schur, dense_schur(S, g)) < 1e-13
    assert rel(fwd.reduced, r) < 1e-13 and np.array_equal(x[g], v)
    assert rel(x[rest], np.linalg.solve(D_II, b[rest] - D[np.ix_(rest, g)] @ v)) < 1e-13
