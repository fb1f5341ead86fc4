"""What the fast Hencky route keeps between its steps answers the point, the load and the sparsity asked, never an
earlier one's: the strains and stresses of the last points (``StrainEnergy._state``), the Hessians on H_0's shared
index arrays, the tangent solver's places of a sparsity, and the per-cell sums of the yielded points' blocks."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import rel
from hencky_scenes import NU, SIGMA_Y, E, H, indented

import cvxcontact as cc
from cvxcontact.backends.mixed import mixed_system
from cvxcontact.backends.nonlinear import TangentSolver
from cvxcontact.discrete import build_problem
from cvxcontact.discrete import energy as energies
from cvxcontact.fem.space import space

HENCKY = cc.materials.hencky(E, NU, SIGMA_Y, H)


def problem_of(nx=8, ny=3, depth=5e-3, degree=1):
    scene = indented(HENCKY, nx=nx, ny=ny, depth=depth)
    return build_problem(scene, space(degree), "sigma1" if degree == 2 else "gamma3", cc.Signorini())


def strained(bulk, seed, size=1e-2):
    """A displacement whose strains reach ``size`` (s_y = 3e-3: some points yield, some do not)."""
    z = np.random.default_rng(seed).normal(size=bulk.A.shape[1])
    return z * size / np.abs(bulk.strains(z)).max()


@pytest.mark.parametrize("degree", [1, 2])
def test_the_kept_states_answer_the_point_asked(degree):
    """Gradients, values and magnitudes asked at five points in turn, then again in another order and at a point
    changed in place after it was asked, equal those of a fresh energy at each point (the same arithmetic: equal
    bits)."""
    problem = problem_of(degree=degree)
    bulk, system = problem.blocks[0].bulk, problem.systems[0]
    points = [strained(bulk, seed) for seed in range(5)]

    def fresh(z):
        other = type(bulk)(system, problem.units)
        return other.gradient(z), other.value(z), other.magnitude(z)

    for z in points + [points[0], points[3], points[1], points[4], points[3]]:
        got, expected = (bulk.gradient(z), bulk.value(z), bulk.magnitude(z)), fresh(z)
        assert all(np.array_equal(a, b) for a, b in zip(got, expected))
    z = points[4]
    bulk.gradient(z)
    z[:3] += 1e-4                                                   # the caller's array, changed in place
    assert np.array_equal(bulk.gradient(z), fresh(z)[0])


def test_a_new_load_and_a_new_mesh_read_their_own_energy():
    """Each load's problem has its own energy: a second depth (another load) and a second mesh answer as a fresh
    build of theirs, after the first was asked at the same displacement."""
    first = problem_of(depth=5e-3)
    z = strained(first.blocks[0].bulk, 7)
    g1 = first.blocks[0].bulk.gradient(z)
    scene = indented(HENCKY, nx=8, ny=3, depth=2e-3)
    second = first.with_loads(scene)
    g2 = second.blocks[0].bulk.gradient(z)
    assert np.array_equal(g2, problem_of(depth=2e-3).blocks[0].bulk.gradient(z))
    assert not np.array_equal(g1, g2)
    other = problem_of(nx=9, ny=3)
    zo = strained(other.blocks[0].bulk, 7)
    assert np.array_equal(other.blocks[0].bulk.gradient(zo), problem_of(nx=9, ny=3).blocks[0].bulk.gradient(zo))


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
def test_hessians_share_the_sparsity_not_the_values(degree):
    """Two Hessians at two points: the same index arrays (H_0's), each its own values, each A^T diag(w C) A formed
    here by sparse products at its point (C the material's tangent), the first unchanged by the second."""
    problem = problem_of(degree=degree)
    bulk = problem.blocks[0].bulk
    z1, z2 = strained(bulk, 1), strained(bulk, 2, 2e-2)
    H1 = bulk.hessian(z1)
    kept = H1.data.copy()
    H2 = bulk.hessian(z2)
    assert H1.indices is H2.indices and H1.indptr is H2.indptr and H1.data is not H2.data
    assert np.array_equal(H1.data, kept)
    for z, Hz in ((z1, H1), (z2, H2)):
        C = bulk.material.tangent(bulk.strains(z), bulk.dim) * bulk.w[:, None, None]
        expected = (bulk.A.T @ sp.block_diag(list(C), format="csr") @ bulk.A).toarray()
        assert rel(Hz.toarray(), expected) < 1e-13                      # measured <= 4.4e-16
    assert bulk.hessian(np.zeros_like(z1)).indices is H1.indices       # at rest: H_0's values, its sparsity


@pytest.mark.numerics
def test_the_tangent_solver_reads_each_sparsity_it_is_given():
    """The system of the tangent solver for a Hessian on H_0's shared index arrays, then for a tangent of fewer
    entries (other arrays), then the first again: each [[K, G_L^T], [G_L, -I_open]] formed here densely."""
    problem = problem_of()
    op, G, _ = mixed_system(problem)
    solver = TangentSolver(op.pattern(), G, "superlu")
    bulk = problem.blocks[0].bulk
    m = G.shape[0]
    at = np.zeros(m, dtype=bool)
    at[: m // 2] = True

    def expected(K):
        closed = sp.diags(at.astype(float))
        return sp.bmat([[K, G.T @ closed], [closed @ G, -sp.diags((~at).astype(float))]]).toarray()

    K1 = op.tangent(np.concatenate([strained(bulk, 3), np.zeros(G.shape[1] - bulk.A.shape[1])]))
    K2 = sp.csr_matrix(K1.multiply(abs(K1) > 0.5 * abs(K1).max() * 1e-2))   # a thinner sparsity
    K2.eliminate_zeros()
    assert K2.nnz < K1.nnz
    for K in (K1, K2, K1, op.tangent(np.zeros(G.shape[1]))):
        assert np.array_equal(solver.matrix(K, at).toarray(), expected(K))


def test_the_run_sums_are_those_of_reduceat():
    """The per-run sums of the yielded points' blocks (one sparse product) against numpy's reduceat, runs of 1 to 6,
    and no point at all."""
    rng = np.random.default_rng(11)
    runs = np.repeat(np.arange(40), rng.integers(1, 7, size=40))
    local = rng.normal(size=(len(runs), 4, 4))
    starts = np.flatnonzero(np.concatenate([[True], runs[1:] != runs[:-1]]))
    assert rel(energies._run_sums(local, runs), np.add.reduceat(local, starts, axis=0)) < 1e-13   # measured 1.3e-16
    assert energies._run_sums(local[:0], runs[:0]).shape == (0, 4, 4)


@pytest.mark.parametrize("degree", [1, 2])
def test_a_hessian_thinned_in_place_leaves_the_next_ones(degree):
    """A caller thins a Hessian in place (small entries zeroed, ``eliminate_zeros``): the Hessians share H_0's index
    arrays, so the change either is refused (read-only arrays) or stays in that Hessian; the next Hessian equals a
    fresh energy's at its point (was: H_0's indptr rewritten in place, the next Hessian a broadcast error)."""
    problem = problem_of(degree=degree)
    bulk, system = problem.blocks[0].bulk, problem.systems[0]
    z1, z2 = strained(bulk, 1), strained(bulk, 2, 2e-2)
    H = bulk.hessian(z1)
    H.data[np.abs(H.data) < 1e-3 * np.abs(H.data).max()] = 0.0
    try:
        H.eliminate_zeros()
    except ValueError:                                              # read-only index arrays: refused
        pass
    expected = type(bulk)(system, problem.units).hessian(z2).toarray()
    assert rel(bulk.hessian(z2).toarray(), expected) < 1e-13        # measured 0 (the same sums)


@pytest.mark.parametrize("degree", [1, 2])
def test_colliding_hashes_of_the_cells_give_the_same_sparsity_and_hessians(degree, monkeypatch):
    """The points' column lists are grouped by an integer hash checked entry by entry: with every weight of the hash
    forced to 1 (the key the sum of the columns: different lists collide), the groups are read from the lists
    themselves; the pattern and the Hessians are those of an energy built with the real hash (equal bits)."""
    problem = problem_of(degree=degree)
    bulk, system = problem.blocks[0].bulk, problem.systems[0]
    z = strained(bulk, 5)
    real = type(bulk)(system, problem.units)
    pattern, hessian = real.pattern(), real.hessian(z)
    rng = np.random.default_rng

    class Ones:
        def __init__(self, seed=None):
            self.inner = rng(seed)

        def integers(self, low, high=None, size=None, **kw):
            return np.ones(size, dtype=np.int64)

    monkeypatch.setattr(energies.np.random, "default_rng", Ones)
    forced = type(bulk)(system, problem.units)
    A, s = sp.csr_matrix(real.A), real.s
    groups = real._local()[2]                                       # a point of each distinct column list
    sums = {int(np.unique(A[p * s:(p + 1) * s].indices[A[p * s:(p + 1) * s].data != 0]).sum()) for p in groups}
    assert len(sums) < len(groups)                                  # the forced keys collide
    assert forced.pattern().nnz == pattern.nnz and (forced.pattern() != pattern).nnz == 0
    got = forced.hessian(z)
    assert np.array_equal(got.indptr, hessian.indptr) and np.array_equal(got.indices, hessian.indices)
    assert np.array_equal(got.data, hessian.data)
