"""Where the Newton steps on the mixed system (26) stop (cvxcontact.backends.finish.solve_sparse_compliance): at the
rounding floor of the system solved, which grows with the tangent's conditioning (docs/formulation.md §19, "Where
the Newton steps stop"), checked on a chain of springs whose floor a stiffness contrast raises, against its closed
form."""

import numpy as np
import pytest
import scipy.sparse as sp

from cvxcontact.backends.finish import Declined, Stop, solve_sparse_compliance
from cvxcontact.contact.laws import RowLaws, Signorini

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

EPS = np.finfo(float).eps


class Chain:
    """n springs in series (stiffness k_i) from a clamp to n free nodes, the load P at the last one: the energy
    1/2 sum k_i (x_i - x_{i-1})^2 - P x_n (x_0 = 0), each row's scale from the springs' forces |B^T| |k B x| + |f|
    (as a Hencky body's, from its stresses: not |K| |x|, which a stiff spring carried far by a soft one makes
    much larger)."""

    def __init__(self, k, P):
        n = len(k)
        self.k = np.asarray(k, dtype=float)
        self.B = sp.diags([np.ones(n), -np.ones(n - 1)], [0, -1], format="csr")      # the springs' elongations
        self.f = np.zeros(n)
        self.f[-1] = P
        self.K = (self.B.T @ sp.diags(self.k) @ self.B).tocsr()

    def value(self, x):
        return 0.5 * float(self.k @ (self.B @ x) ** 2) - float(self.f @ x)

    def gradient(self, x):
        return self.B.T @ (self.k * (self.B @ x)) - self.f

    def tangent(self, x):
        return self.K

    def magnitude(self, x):
        return abs(self.B).T @ np.abs(self.k * (self.B @ x)) + np.abs(self.f)


@pytest.mark.parametrize("contrast", [1.0, 1e6, 1e7])
def test_a_stiff_chain_on_a_soft_spring_settles_at_its_rounding_floor(contrast):
    """One soft spring at the clamp, n - 1 springs ``contrast`` times stiffer, the end pushed twice as far as the
    gap g of its Signorini row: the steps settle (before the floor of each step's own rounding, the contrast 1e7
    never settled: residuals 1.7e-9, above the fixed 1e-10) on the closed form, the end at the gap and one
    force g / sum(1/k) in every spring, the reaction to the rounding those residuals allow."""
    n, g = 20, 1.0
    k = np.full(n, contrast)
    k[0] = 1.0
    force = g / (1 / k).sum()
    chain = Chain(k, 2 * force)
    G = sp.csr_matrix(([1.0], ([0], [n - 1])), shape=(1, n))
    out = solve_sparse_compliance(chain, G, np.array([g]), np.zeros(1), RowLaws.uniform(Signorini(), 1),
                                  np.zeros(n), np.array([True]))
    assert not isinstance(out, Declined), out
    x, y, steps, history = out[0], out[1], out[4], out[5]
    print(f"contrast {contrast:.0e}: {steps} steps, relative residuals {history}, reaction error "
          f"{abs(y[0] - force) / force:.1e}, displacement error {np.abs(x - force * np.cumsum(1 / k)).max() / g:.1e}")
    # measured (relative residual, reaction error, displacement error), one step each: 1: 1.1e-15, 6.9e-16,
    # 2.2e-16; 1e6: 5.6e-11, 4.0e-11, 1.1e-15; 1e7: 1.7e-9, 9.8e-11, 8.9e-16 (the bound below: 2.7e-8 at 1e7)
    assert np.abs(x - force * np.cumsum(1 / k)).max() <= 1e-12 * g
    # the reaction balances the sum of the rows' residuals, each below the rounding of its 3 terms of size
    # (|K| |x|)_i (a bound, not the code's floor: 3 eps sum_i (|K| |x|)_i ~ 6 n contrast eps force)
    assert abs(y[0] - force) <= 3 * EPS * (abs(chain.K) @ np.abs(x)).sum() + 1e-13 * force
    assert history[-1] > 1e-10 or contrast < 1e7       # the case is the one the fixed 1e-10 declined


def test_the_steps_run_to_the_floor_when_it_is_low():
    """Without the contrast the floor is eps-level and the steps do not stop above it: a nonlinear chain (springs
    with a cubic term) ends with a relative residual at rounding (below 1e-13, the bound a well-conditioned
    system allows)."""

    class Cubic(Chain):
        def value(self, x):
            e = self.B @ x
            return float(self.k @ (0.5 * e ** 2 + 0.25 * e ** 4)) - float(self.f @ x)

        def gradient(self, x):
            e = self.B @ x
            return self.B.T @ (self.k * (e + e ** 3)) - self.f

        def tangent(self, x):
            e = self.B @ x
            return (self.B.T @ sp.diags(self.k * (1 + 3 * e ** 2)) @ self.B).tocsr()

        def magnitude(self, x):
            e = self.B @ x
            return abs(self.B).T @ (self.k * (np.abs(e) + np.abs(e) ** 3)) + np.abs(self.f)

    n, g, P = 10, 2.0, 3.0
    chain = Cubic(np.ones(n), P)
    G = sp.csr_matrix(([1.0], ([0], [n - 1])), shape=(1, n))
    out = solve_sparse_compliance(chain, G, np.array([g]), np.zeros(1), RowLaws.uniform(Signorini(), 1),
                                  np.zeros(n), np.array([True]))
    assert not isinstance(out, Declined), out
    x, y, history = out[0], out[1], out[5]
    # closed form: every spring stretched by g / n, its force s (1 + s^2) with s = g / n; the reaction P minus it
    s = g / n
    print("relative residuals", history, np.abs(x - s * np.arange(1, n + 1)).max() / g,
          abs(y[0] - (P - s * (1 + s ** 2))) / P)
    # measured: residuals 1.3e-3, 5.3e-16; displacement error 1.1e-16, reaction error 0
    assert np.abs(x - s * np.arange(1, n + 1)).max() <= 1e-13 * g
    assert abs(y[0] - (P - s * (1 + s ** 2))) <= 1e-13 * P
    assert history[-1] <= 1e-13


@pytest.mark.parametrize("rest", [0.0, 1e-13])
def test_a_free_chain_in_an_open_gap_is_a_singular_step_naming_no_row(rest):
    """The chain without its clamp (k_0 = 0: the translation free), load-free, its end short of the gap: every
    step's system is singular (the translation is held by no row carrying a force), which the finish reports as
    such, typed, with the rows that carried forces in it (none): the caller's well-posedness check names the
    free motion from them (tests/test_wellposed.py, the open-gap layer). ``rest``: the start at equilibrium (a
    zero right side) or off it by rounding (as the interior point's: where a singular LU's answer is garbage)."""
    n, g = 6, 1.0
    k = np.ones(n)
    k[0] = 0.0
    chain = Chain(k, 0.0)
    G = sp.csr_matrix(([1.0], ([0], [n - 1])), shape=(1, n))
    x0 = 0.5 * np.ones(n) + rest * np.arange(n)
    out = solve_sparse_compliance(chain, G, np.array([g]), np.zeros(1), RowLaws.uniform(Signorini(), 1), x0,
                                  np.array([False]))
    assert isinstance(out, Declined) and out.stop is Stop.SINGULAR_FORCES, out
    assert out.rows is not None and not out.rows.any()



@pytest.mark.parametrize("degree,condition", [(1, "gamma3"), (2, "sigma1")])
def test_a_translations_computed_forces_lie_within_the_point_by_point_floor(degree, condition):
    """A Hencky layer between side rollers (its translation y free) carried by a large translation: the computed
    internal forces, zero in exact arithmetic, are rounding of the strains that cancel within each quadrature point.
    ``StrainEnergy.rounding`` (the floor's sizes, point by point: |A|^T (w |C| (|A| |z| + |e0|)) + |d|, formed here
    by sparse products) bounds them (n_i eps times it, the floor of the Newton steps); it is never below the
    assembled |H| |z| + |d| (triangle inequality), which the cancelling points' entries of H leave near zero:
    measured P2, max |grad| 4.3e-16, on a row where eps (|H| |z|)_i is 1e-31 (the old floor: the steps stalled,
    tests/test_wellposed.py, the Hencky layer in an open gap)."""
    import cvxcontact as cc
    from cvxcontact.discrete import build_problem
    from cvxcontact.fem.space import space

    hencky = cc.materials.hencky(200e9, 0.3, 2e8, 0.5)
    layer = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.4), nx=3, ny=2), hencky, roller=["left", "right"], name="layer")
    planes = [cc.Rigid.plane((0.0, 0.0), (0.0, 1.0)), cc.Rigid.plane((0.0, 0.4001), (0.0, -1.0))]
    scene = cc.Scene(layer, contacts=[cc.Contact(layer, "bottom", planes[0]), cc.Contact(layer, "top", planes[1])])
    problem = build_problem(scene, space(degree), condition, cc.Signorini())
    bulk, system = problem.blocks[0].bulk, problem.systems[0]
    up = np.zeros(system.Tu.shape[0])
    up[1::2] = 1.0
    z = system.Tu.T @ up
    z *= 0.8 / np.abs(z).max()                               # the translation y of the free unknowns (scaled)
    assert np.abs(bulk.A @ z).max() <= 1e-12 * (abs(bulk.A) @ np.abs(z)).max()     # a rigid motion: no strain
    sizes = bulk.rounding(z)
    C = abs(sp.block_diag(list(bulk.material.tangent(bulk.strains(z), bulk.dim) * bulk.w[:, None, None]),
                          format="csr"))
    expected = abs(bulk.A).T @ (C @ (abs(bulk.A) @ np.abs(z) + np.abs(bulk.e0))) + np.abs(bulk.d)
    assert np.abs(sizes - expected).max() <= 1e-12 * expected.max()                 # measured 0 (P1), 2e-16 (P2)
    H = sp.csr_matrix(bulk.hessian(z))
    assert (sizes >= (1 - 1e-12) * (abs(H) @ np.abs(z) + np.abs(bulk.d))).all()
    n = np.diff(H.indptr)
    forces = np.abs(bulk.gradient(z) + bulk.d)                # the internal forces of the translation (0 exactly)
    print("max |forces| / (n eps sizes):", (forces / (n * EPS * sizes)).max())
    assert (forces <= 4 * n * EPS * sizes).all()      # measured max 0 (P1), 0.035 (P2): below the floor n_i eps
    #                                                   sizes_i by 29x (100x margin on the bound asserted)


def test_a_step_its_solve_left_above_rounding_is_no_floor():
    """A step's solve that calls itself exact but returns 1.001 times the correction dx (its reactions exact: its
    own residual 1e-3 K dx, twelve orders above rounding) is credited no more than the rounding of its own rows
    (``solved_rounding``): the steps go on, each a correction solved as loosely, until (26) holds, and end on the
    closed form of the chain. Before, the solve's residual was the floor and the first step, 1e-3 off, was taken as
    converged (the fast route's wrong answers on P2 rows of non-matching meshes, whose step solved scrambled rows)."""
    n, g = 20, 1.0
    k = np.linspace(1.0, 3.0, n)
    force = g / (1 / k).sum()
    chain = Chain(k, 2 * force)
    G = sp.csr_matrix(([1.0], ([0], [n - 1])), shape=(1, n))
    calls = []

    def loose(K, b, at):
        GL = G[at].toarray()
        A = np.block([[K.toarray(), GL.T], [GL, np.zeros((len(GL), len(GL)))]])
        calls.append(1)
        s = np.linalg.solve(A, b)
        s[:n] *= 1 + 1e-3
        return s

    out = solve_sparse_compliance(chain, G, np.array([g]), np.zeros(1), RowLaws.uniform(Signorini(), 1),
                                  np.zeros(n), np.array([True]), solve=loose)
    assert not isinstance(out, Declined), out
    x, y, history = out[0], out[1], out[5]
    print("relative residuals", history, np.abs(x - force * np.cumsum(1 / k)).max() / g, abs(y[0] - force) / force)
    # measured: 5 steps, the residual 1e-3 times smaller at each (2.5e-4 ... 2.4e-15); u and the reaction to 6.7e-16
    # and 1.5e-16 of g and of the force (before: one step, 1e-3 off)
    assert len(calls) > 1
    assert np.abs(x - force * np.cumsum(1 / k)).max() <= 1e-12 * g
    assert abs(y[0] - force) <= 1e-12 * force


def test_the_finish_leaves_the_callers_rows_as_given():
    """The rows G given with unsorted column indices (as P2 rows between non-matching meshes come): the finish
    works on its own copy, so the caller's arrays keep their order (a solver holding their entries' places, as the
    fast route's TangentSolver does, would otherwise see them permuted under it), and the answer is the closed
    form."""
    n, g = 6, 1.0
    k = np.ones(n)
    chain = Chain(k, 2.0)
    # two rows, each with its columns given in decreasing order: the end (Signorini) and the sum of the last two
    G = sp.csr_matrix((np.array([1.0, 0.5, 0.5]), np.array([n - 1, n - 1, n - 2]), np.array([0, 1, 3])),
                      shape=(2, n))
    G.has_sorted_indices = False
    before = (G.indices.copy(), G.data.copy())
    out = solve_sparse_compliance(chain, G, np.array([g, 10.0]), np.zeros(2), RowLaws.uniform(Signorini(), 2),
                                  np.zeros(n), np.array([True, False]))
    assert not isinstance(out, Declined), out
    assert np.array_equal(G.indices, before[0]) and np.array_equal(G.data, before[1])
    x = out[0]
    assert np.abs(x - g * np.arange(1, n + 1) / n).max() <= 1e-13 * g      # the end held at the gap
