"""Shared scene builders for the test suite (small sizes: the whole suite runs in seconds)."""

import dataclasses
import hashlib
import importlib
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc


def pytest_report_header(config):
    """Which cvxcontact the suite runs: the installed package (the `pytest` script) or the clone's tree
    (`python -m pytest` from the clone's root). .ci/run checks this line."""
    return f"cvxcontact {cc.__version__} from {Path(cc.__file__).resolve().parent}"


def two_blocks(n1=(16, 8), n2=(11, 6), mat1=None, mat2=None, scale=1.0, diagonal="alternate", **load):
    """Piezo block on top of an elastic block, touching along y = 0 on [0, 1]."""
    m1 = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=n1[0], ny=n1[1], diagonal=diagonal)
    m2 = cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=n2[0], ny=n2[1], diagonal=diagonal)
    mat1 = mat1 or cc.materials.PZT5A
    mat2 = mat2 or cc.materials.isotropic(E=70e9, nu=0.3)
    loads = dict(body_force=(0.0, -2e9 * scale), traction={"right": (0.0, 3e8 * scale)})
    if mat1.piezoelectric:
        loads["surface_charge"] = {"left": -0.05 * scale}
        loads["grounded"] = ["top"]
    loads.update(load)
    b1 = cc.Body(m1, mat1, clamped=["top"], contact="bottom", **loads)
    b2 = cc.Body(m2, mat2, clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2)


@pytest.fixture(scope="session")
def scene():
    return two_blocks()


@pytest.fixture(scope="session")
def solutions(scene):
    return {c: cc.solve(scene, condition=c) for c in cc.CONDITIONS}


def _fingerprint(x, depth=0):
    """What a shared answer holds, to compare before and after the tests that read it: every array's bytes, every
    number, string and container, the fields of a dataclass but those of :data:`_UNCOMPARED` (the problem, scene,
    interface, lazily made state and memos: not answers a test compares); other objects by identity."""
    if isinstance(x, np.ndarray):
        data = repr(x.tolist()) if x.dtype == object else np.ascontiguousarray(x).tobytes()
        return "array", x.dtype.str, x.shape, hash(data)
    if x is None or isinstance(x, (bool, int, str, complex, np.generic)):
        return x
    if isinstance(x, float):
        return repr(x)
    if depth > 8:
        return "deep", id(x)
    if isinstance(x, (list, tuple)):
        return type(x).__name__, tuple(_fingerprint(v, depth + 1) for v in x)
    if isinstance(x, dict):
        return "dict", tuple((repr(k), _fingerprint(v, depth + 1)) for k, v in x.items())
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return type(x).__name__, tuple((f.name, _fingerprint(getattr(x, f.name), depth + 1))
                                       for f in dataclasses.fields(x) if f.name not in _UNCOMPARED)
    return "object", id(x)


_UNCOMPARED = frozenset({"problem", "scene", "interface", "_state", "_pending_state", "products", "absolute"})
"""Fields a shared answer's fingerprint leaves out: the problem, scene and interface (not answers), the lazily made
state, and a Block's memos ``products`` (its last product K z, :meth:`~cvxcontact.discrete.blocks.Block._times`)
and ``absolute`` (|K|'s values, kept from the second |K| |z| on, :meth:`~cvxcontact.discrete.blocks.Block.
abs_values`): a check read with other displacements updates them, the answer unchanged (each keyed by the
read-only matrix itself; the product also by z's numbers)."""


def _memo():
    """(memo, get): the memo of :func:`once` and its ``get(key, make)``."""
    memo = {}

    def get(key, make):
        if key not in memo:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                value = make()
            memo[key] = value, list(caught), _fingerprint(value)
        value, caught, _ = memo[key]
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return value

    return memo, get


def _unchanged(memo):
    """Assert that every answer of ``memo`` holds what it held when made."""
    changed = [key for key, (value, _, made) in memo.items() if _fingerprint(value) != made]
    assert not changed, f"a test changed the shared answers of {changed}: copy an answer before changing it"


@pytest.fixture(scope="module")
def once():
    """A module's memo of the answers several of its tests read (one solve each, not one per test):
    ``once(key, make)`` returns ``make()``, called the first time ``key`` (hashable: the scene's builder and
    arguments) is asked for. The warnings that call raised (every one recorded, whatever the filters) are raised
    again at each call under the caller's filters, so a test sees what a solve of its own would have warned (a
    ResidualWarning an error where it is one). The answers are read, never changed, by the tests: after the
    module, each is checked to hold what it held when made (:func:`_fingerprint`), a test that changed one fails."""
    memo, get = _memo()
    yield get
    _unchanged(memo)


@pytest.fixture(scope="session")
def shared():
    """:func:`once` across the modules of one run: the answers that several test modules read (each key named
    by a fixtures module, with its builder: the same key is the same scene in every module); checked unchanged
    after the run."""
    memo, get = _memo()
    yield get
    _unchanged(memo)


def rel(a, b):
    """Relative max-norm difference of two arrays."""
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def fields_agree(a, b, tol, force_tol=None):
    """Two Solutions of one scene agree: the same active set, and u, phi within ``tol`` and the contact force
    within ``force_tol`` (default ``tol``) (:func:`rel`)."""
    assert np.array_equal(a.contact.active, b.contact.active)
    for ua, ub in zip(a.u, b.u):
        assert rel(ua, ub) < tol
    for pa, pb in zip(a.phi, b.phi):
        if pb is not None:
            assert rel(pa, pb) < tol
    assert rel(a.contact.force, b.contact.force) < (tol if force_tol is None else force_tol)


def effectivity_falls_within(build, options, measured):
    """The estimate's effectivity on nested meshes (levels 0, 1 against level 3,
    :func:`cvxcontact.apps.studies.estimate.effectivity`) within the ``measured`` range (lo, hi) widened by 3 either
    way, every solve ``ok``, and estimate and true error both falling from level 0 to 1."""
    from cvxcontact.apps.studies import estimate as study

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)        # a level 0 may be under-resolved
        rows = study.effectivity(build, options, levels=(0, 1), reference=3)
    lo, hi = measured
    for r in rows:
        assert r["ok"]
        assert lo / 3 <= r["effectivity"] <= hi * 3, r
    assert rows[1]["estimate"] < rows[0]["estimate"]
    assert rows[1]["true_error"] < rows[0]["true_error"]


def benchmark(name):
    """The module benchmarks/<name>.py (the benchmark scripts are no package), loaded from its file."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def captured(monkeypatch, scene, **options):
    """``cc.solve(scene, **options)`` with the problem and a copy of the raw result its read-back was given:
    (the solution, the problem, the raw result), for tests that perturb an answer and read it back again."""
    from cvxcontact.solution.readback import read_back

    seen = {}

    def spy(problem, raw, *args, **kwargs):
        seen.update(problem=problem, raw=dataclasses.replace(raw))
        return read_back(problem, raw, *args, **kwargs)

    monkeypatch.setattr(importlib.import_module("cvxcontact.solve"), "read_back", spy)
    sol = cc.solve(scene, **options)
    return sol, seen["problem"], seen["raw"]


def p2_trace_side(sol, k, xs):
    """Body ``k``'s normal displacement u_y at the abscissae ``xs`` of a horizontal contact line from its own P2
    trace (its boundary edges, quadratic Lagrange on (start, end, mid)) (m)."""
    from cvxcontact.geometry.quadratic import P2Nodes

    body = sol.scene.bodies[k]
    nodes = P2Nodes(body.mesh)
    e = nodes.boundary(body.contact)
    xa, xb = nodes.points[e[:, 0], 0], nodes.points[e[:, 1], 0]
    lo, hi = np.minimum(xa, xb), np.maximum(xa, xb)
    j = np.array([np.flatnonzero((lo <= x + 1e-15) & (x <= hi + 1e-15))[0] for x in xs])
    t = (xs - xa[j]) / (xb[j] - xa[j])
    uy = sol.u[k][:, 1]
    return uy[e[j, 0]] * (1 - t) * (1 - 2 * t) + uy[e[j, 1]] * t * (2 * t - 1) + uy[e[j, 2]] * 4 * t * (1 - t)


def p2_trace_jump(sol, xs):
    """[u_nu] at the abscissae ``xs`` of a horizontal contact line from each body's own P2 trace
    (:func:`p2_trace_side`), body 1 above the line and body 2 below: independent of the merged mesh and of what
    the contact rows or cones hold (m)."""
    return sum((-1.0 if k == 0 else 1.0) * p2_trace_side(sol, k, xs) for k in range(len(sol.scene.bodies)))


# what a solve reads and answers, array by array (tests/test_solve_reads_only.py, tests/test_same_bits.py)
CACHES = {"_shared", "products"}        # what a problem builds on first use (its shared store, a block's last K z)


def arrays(obj, path="problem", seen=None, out=None, skip=CACHES) -> dict:
    """Every numpy array reachable from ``obj`` through the package's objects, containers and sparse matrices,
    by path (the attributes named in ``skip`` left out: by default the caches of :data:`CACHES`)."""
    seen = set() if seen is None else seen
    out = {} if out is None else out
    if id(obj) in seen or obj is None or isinstance(obj, (str, bytes, int, float, complex)):
        return out
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        if obj.dtype != object:
            out[path] = obj
        else:
            for i, x in enumerate(obj.ravel()):
                arrays(x, f"{path}[{i}]", seen, out, skip)
    elif sp.issparse(obj):
        out.update({f"{path}.{a}": getattr(obj, a) for a in ("data", "indices", "indptr", "row", "col", "offsets")
                    if isinstance(getattr(obj, a, None), np.ndarray)})
    elif isinstance(obj, (list, tuple)):
        for i, x in enumerate(obj):
            arrays(x, f"{path}[{i}]", seen, out, skip)
    elif isinstance(obj, dict):
        for k, x in obj.items():
            arrays(x, f"{path}[{k!r}]", seen, out, skip)
    elif type(obj).__module__.startswith("cvxcontact"):
        names = list(getattr(obj, "__dict__", {}))
        names += [n for c in type(obj).__mro__ for n in getattr(c, "__slots__", ())]
        for n in dict.fromkeys(names):
            if n not in skip and hasattr(obj, n):
                arrays(getattr(obj, n), f"{path}.{n}", seen, out, skip)
    return out


def digests(obj, path="problem", skip=CACHES) -> dict:
    """path -> a digest of the array's dtype, shape and bytes (:func:`arrays`)."""
    return {k: hashlib.sha256(str((a.dtype, a.shape)).encode() + np.ascontiguousarray(a).tobytes()).hexdigest()
            for k, a in arrays(obj, path, skip=skip).items()}


def changed(before: dict, after: dict) -> list:
    """The arrays of ``before`` that ``after`` holds with other bits (a cache filled on first use is no change)."""
    return sorted(k for k in before if after.get(k) != before[k])
