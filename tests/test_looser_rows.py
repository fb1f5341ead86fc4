"""looser_rows (cvxcontact/backends/parallel.py: the rows a tighter parallel row implies, vectorised in ParallelRows)
against its definition written as a loop over the rows (the implementation before it was vectorised) on random
rows, and the AMG route's own dofs shared by a parallel group (cvxcontact/backends/amg.py, own_dofs). Index and
comparison logic, no linear algebra: not a numerics module (the scenes with two obstacles at one node, solved by
every route: tests/test_sparse_parallel_rows.py)."""

import numpy as np
import scipy.sparse as sp

from cvxcontact.backends.amg import own_dofs
from cvxcontact.backends.parallel import (
    PARALLEL_TOL,
    ParallelRows,
    looser_rows,
    repeated_rows,
)


def _looser_rows_by_definition(G, g, tol=PARALLEL_TOL):
    """looser_rows as its docstring reads it, a loop over the rows (the implementation before it was vectorised):
    rows grouped by their columns, each group tightest first (ties by index), a row not yet implied implying every
    later one whose unit row is within ``tol`` in every entry."""
    G = sp.csr_matrix(G, copy=True)
    G.eliminate_zeros()
    G.sort_indices()
    norms = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())
    gap = np.asarray(g, dtype=float) / np.where(norms > 0, norms, 1.0)
    groups: dict[bytes, list[int]] = {}
    for a in np.flatnonzero(norms > 0):
        groups.setdefault(G.indices[G.indptr[a]:G.indptr[a + 1]].tobytes(), []).append(int(a))
    looser = np.zeros(G.shape[0], dtype=bool)
    for rows in (r for r in groups.values() if len(r) > 1):
        rows = np.array(rows)[np.argsort(gap[rows], kind="stable")]
        U = np.array([G.data[G.indptr[a]:G.indptr[a + 1]] / norms[a] for a in rows])
        for i in range(len(rows)):
            if not looser[rows[i]]:
                looser[rows[i + 1:]] |= np.abs(U[i + 1:] - U[i]).max(axis=1) <= tol
    return looser


def _random_rows(rng):
    """(G, g, tol): a few rows on 2-5 unknowns, copies of 1-3 base rows scaled by c > 0 or c < 0 (opposite: not
    parallel), some moved by 0.4-6 tol in an entry (chains of rows each within tol of the next, not of all), by
    1e-6, scaled by 1e-200 (squares underflow: norm 0), an entry set to an explicit 0, empty rows (held rows);
    gaps from a few values (ties, -0.0) or random, now and then a NaN; ``tol`` PARALLEL_TOL or, a third of the
    time, exactly the largest entry difference of two unit rows on the same columns (the edge: <= holds)."""
    n = int(rng.integers(2, 6))
    base = []
    for _ in range(int(rng.integers(1, 4))):
        L = int(rng.integers(1, min(n, 3) + 1))
        vals = rng.choice([1.0, -1.0, 0.5, 3.0]) * rng.standard_normal(L) if rng.random() < 0.7 else np.ones(L)
        base.append((np.sort(rng.choice(n, L, replace=False)), vals))
    rows = []
    for _ in range(int(rng.integers(1, 14))):
        if rng.random() < 0.1:
            rows.append((np.zeros(0, dtype=int), np.zeros(0)))
            continue
        cols, vals = base[int(rng.integers(len(base)))]
        vals = vals * rng.choice([1.0, 2.0, 0.25, -1.0, -2.0, rng.uniform(0.1, 10.0)])
        r, at = rng.random(), int(rng.integers(len(vals)))
        if r < 0.3:
            vals[at] += rng.choice([0.4, 0.6, 0.9, 1.1, 1.5, 2.0]) * int(rng.integers(1, 4)) * PARALLEL_TOL \
                * np.abs(vals).max()
        elif r < 0.35:
            vals[at] += 1e-6
        elif r < 0.4:
            vals = vals * 1e-200
        elif r < 0.45:
            vals[at] = 0.0
        rows.append((cols, vals))
    m = len(rows)
    G = sp.csr_matrix((np.concatenate([v for _, v in rows]), np.concatenate([c for c, _ in rows]).astype(np.int32),
                       np.concatenate([[0], np.cumsum([len(c) for c, _ in rows])])), shape=(m, n))
    g = rng.choice([0.0, -0.0, 1.0, -1.0, 2.0, 0.5], size=m) if rng.random() < 0.5 else rng.standard_normal(m)
    if rng.random() < 0.1:
        g[int(rng.integers(m))] = np.nan
    tol = PARALLEL_TOL
    if rng.random() < 0.3:
        H = sp.csr_matrix(G, copy=True)
        H.eliminate_zeros()
        H.sort_indices()
        cols = [H.indices[H.indptr[a]:H.indptr[a + 1]] for a in range(m)]
        vals = [H.data[H.indptr[a]:H.indptr[a + 1]] for a in range(m)]
        full = [a for a in range(m) if np.any(vals[a] ** 2 > 0)]
        if full:
            a = full[int(rng.integers(len(full)))]
            same = [b for b in full if np.array_equal(cols[b], cols[a])]
            b = same[int(rng.integers(len(same)))]
            unit = [vals[k] / np.sqrt((vals[k] ** 2).sum()) for k in (a, b)]
            tol = float(np.abs(unit[0] - unit[1]).max())
    return G, g, tol


def test_looser_rows_is_its_definition_on_random_rows():
    """The vectorised looser_rows (ParallelRows: groups once, order per gaps) gives the loop's answer bit for bit on
    800 random cases (:func:`_random_rows`: ties, zero and held rows, opposite rows, chains within tol, tol at a
    measured difference), the groups reused for other gaps. Not vacuous: 612 of them have a looser row, 69 a
    chained cluster (``exact`` False). Mutants caught (cases differing): each cluster's tightest kept where a chain
    is not all within tol, 61; splits at tol / 2, 192; splits at >= tol, 154; ties by the larger index, 120."""
    rng = np.random.default_rng(20261206)
    looser = chained = 0
    for _ in range(800):
        G, g, tol = _random_rows(rng)
        expected = _looser_rows_by_definition(G, g, tol)
        groups = ParallelRows(G, tol)
        assert np.array_equal(looser_rows(G, g, tol), expected), (G.toarray(), g, tol)
        assert np.array_equal(groups.looser(g), expected)
        assert np.array_equal(groups.looser(g[::-1].copy()), _looser_rows_by_definition(G, g[::-1], tol))  # reused
        looser += expected.any()
        chained += (~groups.exact).any()
    assert looser > 300 and chained > 30      # measured 612 and 69


def test_own_dofs_share_a_parallel_group_s_dof():
    """Two obstacles' rows at one node (rows 0, 1, 3: one row times 1, 2, 0.5) have no dof of their own; with their
    parallel groups they share the first row's (the largest entry, column 1), each its own coefficient there; the
    anti-parallel row 2 is no member (dofs of its own needed: none left); rows within tol of each other in a chain
    but not all (not ``exact``) do not share (None)."""
    G = sp.csr_matrix(np.array([[0.5, 1.0, 0, 0], [1.0, 2.0, 0, 0], [0, 0, 1.0, 0], [0.25, 0.5, 0, 0], [0, 0, 0, 3.0]]))
    assert own_dofs(G) is None
    dof, coef = own_dofs(G, ParallelRows(G))
    assert dof.tolist() == [1, 1, 2, 1, 3] and coef.tolist() == [1.0, 2.0, 1.0, 0.5, 3.0]
    opposite = sp.vstack([G, sp.csr_matrix(np.array([[-0.5, -1.0, 0, 0]]))]).tocsr()
    assert own_dofs(opposite, ParallelRows(opposite)) is None
    chain = sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 1.0 + 2e-12], [1.0, 1.0 + 4e-12]]))
    assert not ParallelRows(chain).exact.all() and own_dofs(chain, ParallelRows(chain)) is None


def _adversarial_rows(rng, kind):
    """(G, g, tol) beyond :func:`_random_rows` (the review of h-looser): up to 600 rows on one or two patterns
    (huge groups), rows moved by 0-15 tol (chains), by ``kind``: 1 NaN or +-inf entries, 2 the data permuted on
    the same columns, 3 unsorted columns and duplicate entries (not summed), 4 rows scaled by 1e+-160, 1e+-300;
    gaps with +-inf and NaN; tol 0, 1e-8, 0.5 or inf too."""
    n = int(rng.integers(1, 6))
    m = int(rng.integers(200, 600)) if kind == 0 else int(rng.integers(1, 60))
    L = int(rng.integers(1, n + 1))
    base = [(np.sort(rng.choice(n, L, replace=False)), rng.standard_normal(L)) for _ in range(int(rng.integers(1, 3)))]
    data, idx, ptr = [], [], [0]
    for _ in range(m):
        c, v = base[int(rng.integers(len(base)))]
        v = v * rng.uniform(0.1, 10) * (1 if rng.random() < 0.9 else -1)
        if rng.random() < 0.4:
            v = v.copy()
            v[int(rng.integers(len(v)))] += rng.choice([-1, 1]) * rng.uniform(0, 5) * int(rng.integers(0, 4)) \
                * PARALLEL_TOL * np.abs(v).max()
        if kind == 1 and rng.random() < 0.1:
            v = v.copy()
            v[int(rng.integers(len(v)))] = rng.choice([np.nan, np.inf, -np.inf])
        if kind == 2 and rng.random() < 0.3:
            v = rng.permutation(v)
        c = c.copy()
        if kind == 3 and rng.random() < 0.3:
            perm = rng.permutation(len(c))
            c, v = c[perm], v[perm]
            if rng.random() < 0.5:
                c, v = np.append(c, c[0]), np.append(v, -v[0] * rng.choice([1.0, 0.5]))
        if kind == 4 and rng.random() < 0.2:
            v = v * rng.choice([1e-160, 1e160, 1e-300, 1e300])
        data.append(v)
        idx.append(c)
        ptr.append(ptr[-1] + len(c))
    G = sp.csr_matrix((np.concatenate(data), np.concatenate(idx), np.array(ptr)), shape=(m, n))
    r = rng.random()
    g = (rng.choice([0.0, -0.0, 1.0, np.inf, -np.inf, np.nan], size=m) if r < 0.3 else
         rng.choice([0.0, 1.0, 2.0], size=m) if r < 0.6 else rng.standard_normal(m))
    return G, g, float(rng.choice([PARALLEL_TOL, 0.0, 1e-8, 0.5, np.inf]))


def test_looser_rows_is_its_definition_on_adversarial_rows():
    """ParallelRows(G, tol).looser(g) is the loop's answer on 500 cases of :func:`_adversarial_rows` (100 of each
    kind; huge groups, NaN/inf data and gaps, permuted data, unsorted and duplicate entries, extreme scales, tol 0
    and inf). Not vacuous: measured 482 with a looser row, 90 with a chained cluster; the mutant splitting at >= tol fails it."""
    rng = np.random.default_rng(20261207)
    looser = chained = 0
    with np.errstate(all="ignore"):
        for i in range(500):
            G, g, tol = _adversarial_rows(rng, i % 5)
            expected = _looser_rows_by_definition(G, g, tol)
            groups = ParallelRows(G, tol)
            assert np.array_equal(groups.looser(g), expected), (i, tol)
            looser += expected.any()
            chained += (~groups.exact).any()
    assert looser > 200 and chained > 20


def _repeated_rows_by_definition(G, g, tol=PARALLEL_TOL):
    """repeated_rows as its docstring reads it, a loop over the rows (the loop before h-split, each row marked
    once it is in a class): rows grouped by their columns, each group tightest first (ties by index), a row in no
    class leading one with every later row in none whose unit row is within ``tol`` of its own and whose
    normalised gap is within ``tol`` x the largest finite |normalised gap| of its own; a class labelled by its
    lowest row."""
    G = sp.csr_matrix(G, copy=True)
    G.eliminate_zeros()
    G.sort_indices()
    norms = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel())
    gap = np.asarray(g, dtype=float) / np.where(norms > 0, norms, 1.0)
    scale = tol * max(float(np.abs(gap[np.isfinite(gap)]).max(initial=0.0)), np.finfo(float).tiny)
    groups: dict[bytes, list[int]] = {}
    for a in np.flatnonzero(norms > 0):
        groups.setdefault(G.indices[G.indptr[a]:G.indptr[a + 1]].tobytes(), []).append(int(a))
    first, done = np.arange(G.shape[0]), np.zeros(G.shape[0], dtype=bool)
    for rows in (r for r in groups.values() if len(r) > 1):
        rows = np.array(rows)[np.argsort(gap[rows], kind="stable")]
        U = np.array([G.data[G.indptr[a]:G.indptr[a + 1]] / norms[a] for a in rows])
        for i in range(len(rows)):
            if done[rows[i]]:
                continue
            same = ~done[rows[i + 1:]] & (np.abs(U[i + 1:] - U[i]).max(axis=1) <= tol) & (
                np.abs(gap[rows[i + 1:]] - gap[rows[i]]) <= scale)
            cls = np.concatenate([[rows[i]], rows[i + 1:][same]])
            first[cls], done[cls] = cls.min(), True
    return first


def _near_gaps(rng, G, g, tol):
    """Gaps of a few values moved by 0 to 6 x ``tol`` (classes at the tolerance's edge), or ``g``."""
    m = G.shape[0]
    base = rng.choice([1.0, 2.0, 0.0, -1.0], m) if rng.random() < 0.5 else np.asarray(g, dtype=float)
    return base + rng.integers(0, 4, m) * rng.choice([0.0, 0.3, 0.7, 1.0, 3.0]) * tol * 2.0


def test_repeated_rows_is_its_definition():
    """ParallelRows(G, tol).repeated(g) (repeated_rows: one grouping with looser_rows since h-split) is the loop's
    answer on 500 cases of :func:`_random_rows` and 500 of :func:`_adversarial_rows`, each with its own gaps and
    gaps of classes at the tolerance's edge (:func:`_near_gaps`), the groups reused for both. Not vacuous:
    measured 919 of the 2000 with a class of two rows or more, 246 with a chained cluster."""
    rng = np.random.default_rng(20261208)
    classes = chained = 0
    with np.errstate(all="ignore"):
        for i in range(1000):
            G, g, tol = _random_rows(rng) if i % 2 else _adversarial_rows(rng, i % 5)
            groups = ParallelRows(G, tol)
            for gaps in (np.asarray(g, dtype=float), _near_gaps(rng, G, g, tol)):
                expected = _repeated_rows_by_definition(G, gaps, tol)
                assert np.array_equal(groups.repeated(gaps), expected), (i, tol)
                classes += (expected != np.arange(len(expected))).any()
                chained += (~groups.exact).any()
    assert classes > 400 and chained > 100


def test_repeated_rows_classes_hold_their_leader():
    """Equal rows 0, 1, 2 of gaps 0.6, 0, 1.5 (x 1e-12 of the largest gap, 1e3): row 1 (tightest) leads a class
    with row 0 (0.6 x the tolerance away), labelled 0; row 2 is 1.5 x the tolerance from the leader, a class of its
    own. The loop before h-split let row 0, the class's lowest row, lead a second pass and took row 2 in (0.9 x
    the tolerance from row 0): a class whose rows were not all within the tolerance of the row closed_once keeps."""
    G = sp.csr_matrix(np.array([[1.0], [1.0], [1.0], [0.0]]))
    s = PARALLEL_TOL * 1e3
    g = np.array([0.6 * s, 0.0, 1.5 * s, 1e3])
    assert repeated_rows(G, g).tolist() == [0, 0, 2, 3]
    assert _repeated_rows_by_definition(G, g).tolist() == [0, 0, 2, 3]
