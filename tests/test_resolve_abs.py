"""|K|'s values kept per problem for the checks' row scales |A| |x| (Block.abs_values, abs_product's ``absolute``):
formed once, shared by the load cases of a prepared problem, read-only, never read for another matrix, and the row
scales the same numbers as without them. The oracles: scipy's abs(K) @ |z| (the same sums row by row: CSR), the
products without the kept values (the same operations: CSC by blocks), a problem built afresh for the load case."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import two_blocks

import cvxcontact as cc
from cvxcontact.discrete import build_problem, energy
from cvxcontact.discrete.energy import abs_product
from cvxcontact.fem.space import space


@pytest.fixture(scope="module")
def problem():
    return build_problem(two_blocks(), space(1, "triangle"), "gamma3", cc.Signorini())


def _fields(blk, seed):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(blk.Kuu.shape[0])
    phi = None if blk.Kpp is None else rng.standard_normal(blk.Kpp.shape[0])
    return u, phi, rng.standard_normal(blk.jump.shape[0])


def _scales_without(blk, u, phi, c):
    """The row scales as formed before the values were kept (every |K| formed by the product itself)."""
    cu = abs(blk.jump).T @ np.abs(c) + np.abs(blk.f)
    au = abs_product(blk.Kuu, u) + cu
    if blk.Kpp is None:
        return au, np.zeros(0)
    return au + abs_product(blk.Kup, phi), abs_product(blk.Kpp, phi) + abs_product(blk.Kup.T, u) + np.abs(blk.q)


@pytest.mark.parametrize("rows", [energy.ROWS, 7], ids=["one block", "blocks of 7"])
def test_the_row_scales_are_the_same_numbers_with_the_kept_values(problem, monkeypatch, rows):
    """Blocks of 7 rows/columns: Kup^T (CSC) summed block by block as before, bit for bit; scipy's abs(K) @ |z|
    sums a CSR row in the same order (bit for bit) and a CSC block sum to rounding (measured 9.7e-17 relative;
    bound 1e-13)."""
    monkeypatch.setattr(energy, "ROWS", rows)
    for k, blk in enumerate(problem.blocks):
        u, phi, c = _fields(blk, k)
        kept = blk.magnitude(u, phi, c)
        for a, b in zip(kept, _scales_without(blk, u, phi, c)):
            assert np.array_equal(a, b)
        assert np.array_equal(abs_product(blk.Kuu, u, blk.abs_values("Kuu")[1]), abs(blk.Kuu) @ np.abs(u))
        if blk.Kpp is not None:
            direct = abs(blk.Kpp) @ np.abs(phi) + abs(blk.Kup).T @ np.abs(u) + np.abs(blk.q)
            assert np.abs(kept[1] - direct).max() <= 1e-13 * np.abs(direct).max()


def test_the_kept_values_are_read_only_shared_by_load_cases_and_not_read_for_another_matrix(problem):
    upper = problem.blocks[0]
    values = {name: upper.abs_values(name)[1] for name in ("Kuu", "Kup", "Kpp", "KupT")}
    for v in values.values():
        assert not v.flags.writeable
        with pytest.raises(ValueError):
            v[0] = 1.0
    assert values["KupT"] is values["Kup"]                                  # Kup^T reads Kup's values
    assert values["Kuu"].nbytes == 8 * upper.Kuu.nnz                       # 8 bytes per stored entry
    assert np.array_equal(values["Kuu"], np.abs(upper.Kuu.data))
    again = problem.with_loads(two_blocks(scale=0.37, traction={"right": (0.0, -1e8)}))
    assert all(again.blocks[0].abs_values(n)[1] is v for n, v in values.items())   # formed once per problem
    other = replace(upper, Kuu=2.0 * upper.Kuu)                             # another matrix: its own values
    assert other.abs_values("Kuu")[1] is not values["Kuu"]
    assert np.array_equal(other.abs_values("Kuu")[1], 2.0 * values["Kuu"])
    assert np.array_equal(upper.abs_values("Kuu")[1], values["Kuu"])         # its own again (formed anew)


@pytest.mark.numerics
def test_a_re_solve_checks_as_a_problem_built_afresh_and_answers_as_a_fresh_solver():
    """The solver's blocks (values kept since its first solve) and a problem built for the new scene alone give
    the same row scales and the same checks on the same fields (bit for bit: the same matrices, the same
    operations); the re-solve answers, checks and estimates as a fresh solver of the new scene (another route to
    the same finish: u and the estimate measured identical, bounds 1e-12 and 1e-10 relative; both ok)."""
    from cvxcontact.solution.checks import checks

    solver = cc.ContactSolver(two_blocks(), method="condensed")
    solver.solve()
    other = two_blocks(scale=0.37, traction={"right": (0.0, -1e8)})
    sol = solver.solve(other)
    kept, fresh = solver.problem, build_problem(other, space(1, "triangle"), "gamma3", cc.Signorini())
    assert all(b.absolute for b in kept.blocks) and not any(b.absolute for b in fresh.blocks)
    assert kept.units == fresh.units
    fields = [_fields(b, 5 + k) for k, b in enumerate(kept.blocks)]
    for a, b, x in zip(kept.blocks, fresh.blocks, fields):
        for p, q in zip(a.magnitude(*x), b.magnitude(*x)):
            assert np.array_equal(p, q)
    y = np.random.default_rng(3).random(kept.E.shape[0])
    us, phis, c = [x[0] for x in fields], [x[1] for x in fields], fields[0][2]
    assert checks(kept.blocks, us, phis, c, kept.E, kept.g, y) == checks(fresh.blocks, us, phis, c, fresh.E,
                                                                           fresh.g, y)
    new = cc.ContactSolver(other, method="condensed").solve()
    assert sol.ok and new.ok
    for a, b in zip(sol.u, new.u):
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    assert abs(sol.estimate.absolute - new.estimate.absolute) <= 1e-10 * new.estimate.absolute
    for name, value in new.residuals().items():
        assert sol.residuals()[name] <= max(10 * value, 1e-12), name




def test_a_first_product_keeps_no_values_and_never_forms_them_at_once(monkeypatch):
    """A one-shot solve's checks take one |K| |x| per matrix: it is formed block by block as without the store
    (nothing kept; |Kuu| |u|'s traced peak with blocks of 7 rows, P2: measured 0.17 and 0.17 of the bytes of
    |Kuu|'s values, its out and |u| included; asserted below 1: they were never formed at once); the second
    product keeps them (read-only, np.abs of the values: its peak above them) and both give the numbers formed
    without the store, bit for bit."""
    import tracemalloc

    monkeypatch.setattr(energy, "ROWS", 7)
    problem = build_problem(two_blocks(n1=(16, 8), n2=(11, 6)), space(2, "triangle"), "gamma3", cc.Signorini())
    for k, blk in enumerate(problem.blocks):
        u, phi, c = _fields(blk, 11 + k)
        fresh, values = replace(blk, absolute={}), 8 * blk.Kuu.nnz
        peaks = []
        for _ in range(2):
            tracemalloc.start()
            fresh._abs_times("Kuu", u)
            peaks.append(tracemalloc.get_traced_memory()[1])
            tracemalloc.stop()
            if len(peaks) == 1:
                assert fresh.absolute["Kuu"][2] is None                   # asked once: nothing kept
        assert peaks[0] < values < peaks[1], (peaks, values)
        kept = fresh.absolute["Kuu"][2]
        assert not kept.flags.writeable and np.array_equal(kept, np.abs(blk.Kuu.data))
        fresh = replace(blk, absolute={})
        first, second = fresh.magnitude(u, phi, c), fresh.magnitude(u, phi, c)
        assert all(fresh.absolute[n][2] is not None for n in fresh.absolute)
        for a, b, w in zip(first, second, _scales_without(blk, u, phi, c)):
            assert np.array_equal(a, w) and np.array_equal(b, w)
