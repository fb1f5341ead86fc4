"""Factorisation of one body's quasi-definite matrix with its contact (Gamma) dofs as a Schur block.

Per body the condensed backend (:mod:`cvxcontact.backends.condensed`) needs, from ONE factorisation of
the symmetric quasi-definite form of (26) on the free dofs (scaled, dimensionless units)

    S = [[Kuu, Kup], [Kup^T, -Kpp]],

the interface stiffness (Schur complement of the interior dofs I onto the Gamma dofs G)

    Sigma = S_GG - S_GI S_II^{-1} S_IG            (dense m x m, SPD)

and full solves x = S^{-1} b. :func:`factorize` gives both through one adapter:

``superlu``  SciPy's SuperLU without pivoting in symmetric mode, on a minimum-degree node order with the
             Gamma dofs last; Sigma is the trailing m x m block of L U (a symmetric quasi-definite matrix
             has an LDL^T factorisation in every symmetric order, so no pivoting is needed). L and U are kept
             (each as a SuperLU object of its own) for partial sweeps as PARDISO's below: forward z = L^{-1} b,
             r = L22 z_G; backward x_I = U11^{-1} L11^{-1} (b_I - S_IG v) (:class:`SuperLUFactorization`).
``pardiso``  Intel oneMKL PARDISO through ctypes on ``libmkl_rt`` (the optional extra
             ``pip install "cvxcontact[pardiso]"``, x86-64): real symmetric indefinite (mtype -2), its own
             nested-dissection order for I, the Gamma dofs marked as Schur rows (iparm[35]); the
             factorisation phase returns Sigma densely and factorises S_II only. A full solve is the
             partial forward sweep (phase 331, whose Gamma part is the reduced right-hand side
             r = b_G - S_GI S_II^{-1} b_I), a dense Cholesky solve v = Sigma^{-1} r, and the partial
             backward sweep (phase 333) with x_G = v, giving x_I = S_II^{-1} (b_I - S_IG v). Every
             PARDISO handle runs in oneMKL's reproducible mode (iparm[33] = its thread count,
             :func:`_cnr_threads`): one input gives one answer, bit for bit, run after run at a thread count.
``auto``     ``pardiso`` if its library loads, else ``superlu``.

``libmkl_rt`` is looked for in the environment's ``lib`` (where the ``mkl`` wheel puts it; ``Library/bin``
on Windows), then by :func:`ctypes.util.find_library`; the variable CVXCONTACT_MKL_RT may name the file.

Both adapters also give the two sweeps separately (:meth:`Factorization.forward`,
:meth:`Factorization.backward`): a load case needs r (v0 = Sigma^{-1} r, g = Sigma v0 = r), and the fields
follow from one backward sweep once the contact has fixed v.

:mod:`cvxcontact.backends.released` keeps what the interface needs of a factorisation whose adapter's factors
were freed (:meth:`Factorization.free`; where memory is short, :mod:`cvxcontact.backends.budget`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import os
import sys
import threading
import weakref

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import structural_rank

from ..errors import SolverError

__all__ = ["FACTORIZATIONS", "Factorization", "Forward", "PardisoSymmetric", "factorize", "pardiso_available",
           "resolve", "SUPERLU_OPTIONS", "DENSE_FILL", "DenseLU", "lu", "superlu", "structurally_nonsingular",
           "PardisoInterior", "PARDISO_ORDERINGS", "diagonal_stored", "dense_lu"]

FACTORIZATIONS = ("auto", "superlu", "pardiso")
"""Names accepted by :func:`factorize` (and ``cc.solve(..., factorization=)``)."""

SUPERLU_OPTIONS = dict(permc_spec="NATURAL", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
"""SuperLU without pivoting on a quasi-definite matrix in its elimination order (its sparsity kept): 3.0e6 factor
entries on thin_layer(1500)'s bonded system against 5.5e6 with COLAMD and partial pivoting."""

PARDISO_INSTALL = 'pip install "cvxcontact[pardiso]"'

PARDISO_ORDERINGS = (2, 0)
"""The fill-reducing orders :class:`PardisoSymmetric` takes (PARDISO's iparm[1]): 2 nested dissection (METIS), 0
minimum degree (AMD). Not 3, METIS run in parallel: it keeps PARDISO from its reproducible mode (:func:`_cnr_threads`)."""


DENSE_FILL = 0.1
"""A square sparse matrix storing more than this fraction of its n^2 entries (and n <= :data:`DENSE_MAX`) is
factorised by LAPACK's dense LU in :func:`lu` instead of SuperLU, which is slow on dense blocks: the mixed
system (26) condensed onto the interface (:mod:`cvxcontact.backends.forced`), whose Sigma blocks are dense
(measured: a saddle matrix of 1,057 Gamma dofs, 0.45 s a SuperLU factorisation)."""

DENSE_MAX = 8000
"""The largest order :func:`lu` factorises densely (512 MB: the dense copy, factorised in place)."""


def dense_lu(a, overwrite_a: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.linalg.lu_factor(a, overwrite_a=overwrite_a)``'s (lu, piv) of the dense square ``a`` (LAPACK's
    getrf, the same call and bits), with an exactly singular ``a`` (a zero pivot, getrf's info > 0) raising
    :class:`numpy.linalg.LinAlgError` where ``lu_factor`` issues a ``LinAlgWarning``, and a non-finite ``a``
    ValueError: no warning filter turns it into an error, for any change of the filters (``catch_warnings``)
    empties every module's record of the warnings shown once per place, and a user's loop of solves showed its
    warnings at every solve (tests/test_warning_once.py)."""
    a1 = np.asarray_chkfinite(a)
    if a1.size == 0:
        return np.empty_like(a1), np.arange(0, dtype=np.int32)
    getrf, = sla.get_lapack_funcs(("getrf",), (a1,))
    lu_, piv, info = getrf(a1, overwrite_a=overwrite_a)
    if info < 0:
        raise ValueError(f"illegal value in argument {-info} of LAPACK's getrf")
    if info > 0:
        raise np.linalg.LinAlgError(f"diagonal number {info} of U is exactly zero: singular matrix")
    return lu_, piv


class DenseLU:
    """LAPACK's LU with partial pivoting of a (sparse, nearly dense) matrix, with SuperLU's ``solve``; an exactly
    singular matrix raises RuntimeError, as SuperLU does."""

    def __init__(self, K):
        try:
            self.factors = dense_lu(K.toarray(), overwrite_a=True)       # one n^2 copy
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise RuntimeError(f"singular or not finite: {exc}") from exc

    def solve(self, b):
        return sla.lu_solve(self.factors, b, check_finite=False)


def structurally_nonsingular(K) -> None:
    """Raise RuntimeError if the square sparse ``K`` is structurally singular: no permutation puts a stored entry
    on every diagonal position (:func:`scipy.sparse.csgraph.structural_rank` below its order; stored zeros
    count, as they do for SuperLU). Such a K is singular whatever its values, and SuperLU must not see it:
    its column updates then call BLAS with illegal sizes (OpenBLAS prints "On entry to DGEMV parameter
    number 2 had an illegal value", or DTRSV's parameter 6, and skips the call), after which it either stops
    with an error or returns factors whose pivots are rounding (a solve off by ~1e17). O(nnz sqrt(n)) at worst;
    measured 1e-3 s CPU on the systems of order ~2,100 of the P2 "gamma3" cuts on two blocks (SuperLU: 0.02 to
    0.05 s each) and 0.01 s on a saddle matrix of order 130,000 (890,000 entries)."""
    n = K.shape[0]
    rank = int(structural_rank(sp.csr_matrix(K))) if n else 0
    if rank < n:
        raise RuntimeError(f"singular: structural rank {rank} of {n} (a row or column set with too few entries)")


def superlu(K, **options):
    """SciPy's SuperLU (``scipy.sparse.linalg.splu`` with ``options``) of the square sparse ``K``; RuntimeError if
    K is structurally singular (:func:`structurally_nonsingular`) or SuperLU finds it singular."""
    structurally_nonsingular(K)
    return spla.splu(K, **options)


def lu(K, **options):
    """A factorisation of the square sparse ``K`` with ``solve(b)``: SuperLU (:func:`superlu` with ``options``),
    or :class:`DenseLU` where K is nearly dense (:data:`DENSE_FILL`). RuntimeError if singular (structurally
    singular: before either factorisation)."""
    n = K.shape[0]
    if 0 < n <= DENSE_MAX and K.nnz > DENSE_FILL * n * n:
        structurally_nonsingular(K)
        return DenseLU(K)
    return superlu(K, **options)


def diagonal_stored(coo, fmt):
    """The square ``coo`` matrix in the format ``fmt`` (sp.csr_matrix, sp.csc_matrix) with every diagonal entry
    stored, zeros included (PARDISO requires it), duplicates summed and indices sorted."""
    n = coo.shape[0]
    d = np.arange(n)
    M = fmt((np.concatenate([coo.data, np.zeros(n)]), (np.concatenate([coo.row, d]), np.concatenate([coo.col, d]))),
            shape=(n, n))
    M.sum_duplicates()
    M.sort_indices()
    return M


class Forward:
    """The forward sweep of a right-hand side b: ``reduced`` r = b_G - S_GI S_II^{-1} b_I (length m), so that
    the Gamma part of S^{-1} b is Sigma^{-1} r; ``state`` is the adapter's own data for :meth:`backward`."""

    __slots__ = ("reduced", "state")

    def __init__(self, reduced: np.ndarray, state):
        self.reduced, self.state = reduced, state


class Factorization:
    """One factorisation of a body's S with the Gamma dofs ``gamma`` (sorted indices into the body's dof
    vector) as its Schur block. ``schur`` is Sigma (dense, symmetrised, m x m, in ``gamma`` order), ``name``
    the adapter ("superlu" or "pardiso")."""

    name = ""

    def __init__(self, n: int, gamma: np.ndarray, schur: np.ndarray):
        self.n, self.gamma = n, gamma
        schur += schur.T           # symmetrised in place (NumPy buffers the overlapping transpose): the adapter's
        schur *= 0.5               # array is its own (m^2 doubles, m the contact dofs: no second copy)
        self.schur = schur
        self._chol = self._lu = None
        if not len(gamma):
            return
        try:                       # SPD when the Gamma dofs are displacements (the contact dofs)
            self._chol = sla.cho_factor(self.schur)
        except np.linalg.LinAlgError:
            try:
                self._lu = dense_lu(self.schur)
            except (np.linalg.LinAlgError, ValueError) as exc:
                raise SolverError(f"the Schur complement on the {len(gamma)} contact dofs from {self.name} "
                                  f"is singular: {exc}") from exc

    @property
    def cholesky(self):
        """``scipy.linalg.cho_factor``'s factors of Sigma (None if Sigma is indefinite or there is no contact dof),
        for the callers that solve with Sigma themselves (one copy of the factors per body)."""
        return self._chol

    def schur_solve(self, r: np.ndarray) -> np.ndarray:
        """Sigma^{-1} r (dense Cholesky; LU if Sigma is indefinite)."""
        if self._chol is not None:
            return sla.cho_solve(self._chol, r)
        return sla.lu_solve(self._lu, r) if self._lu is not None else np.zeros_like(r)

    @property
    def memory(self) -> int | None:
        """Bytes the adapter's factors hold (PARDISO's own report after the factorisation; SuperLU: its factors'
        nonzeros at 12 bytes each), None where unknown. Sigma and its Cholesky factors are not counted."""
        return None

    def free(self) -> None:
        """Free the adapter's factors now (:class:`cvxcontact.backends.released.Released` keeps what the interface
        needs)."""

    def forward(self, rhs: np.ndarray) -> Forward:
        raise NotImplementedError

    def backward(self, fwd: Forward, v: np.ndarray) -> np.ndarray:
        """x with x_G = v and x_I = S_II^{-1} (b_I - S_IG v), b the right-hand side of ``fwd``."""
        raise NotImplementedError

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """x = S^{-1} rhs in the body's dof order."""
        fwd = self.forward(rhs)
        return self.backward(fwd, self.schur_solve(fwd.reduced))


# --------------------------------------------------------------------------------------------- SuperLU


class SuperLUFactorization(Factorization):
    """SuperLU on ``order`` (a permutation of the dofs, the Gamma dofs last in ``gamma`` order), kept as
    A' = L D L^T for partial sweeps: A = S[order][:, order] = Pr^T L U Pc^T (SuperLU's permutations, the same for
    rows and columns, keep the Gamma block last; checked), A' = Pr A Pc is symmetric, so U = D L^T to rounding and
    L and D = diag(U) alone are kept (L as a SuperLU object of its own: a triangular matrix's, its diagonal the
    pivots, is itself). Split after k = n - m interior rows: forward z = L^{-1} b', r' = L22 z_G (b' = Pr b);
    backward L11^T y_I = D11^{-1} z_I - L21^T y_G, y_G = Pc^T v, x = Pc y; Sigma = L22 D22 L22^T: exact sweeps of
    one symmetric matrix, as PARDISO's. The sweep before, x0 - S^{-1} [0; Sigma (x0_G - v)] with x0 = S^{-1} b,
    cancelled on slender bodies (thin_layer(400)'s layer: |x0| = 1.4e3 |x|, x_I 1.65e-7 off a solve with S_II;
    now 1e-14). Measured (thin_layer(400)'s bodies, two_boxes(14) in 3D): 0.56 to 0.97 x the memory of SuperLU's
    L and U, 1.25 to 1.4 x the factorisation time."""

    name = "superlu"

    def __init__(self, S, gamma, order):
        n, m = S.shape[0], len(gamma)
        if not np.array_equal(order[n - m:], gamma):
            raise SolverError("the superlu order must end with the Gamma dofs in their sorted order")
        self.perm, k = order, n - m
        A = S[order][:, order].tocsc()
        lu = spla.splu(A, **SUPERLU_OPTIONS)
        self._perm_r, self._perm_c = lu.perm_r, lu.perm_c
        self._rows, self._cols = rows, cols = lu.perm_r[k:] - k, lu.perm_c[k:] - k
        if m and (rows.min() < 0 or cols.min() < 0):
            raise SolverError("the factorisation moved the contact dofs away from the end of the elimination "
                              "order; use method='full'")
        if not np.array_equal(lu.perm_r, lu.perm_c):
            raise SolverError("SuperLU permuted the rows and columns of a body's matrix differently; use "
                              "method='full'")
        L = lu.L.tocsc()                         # A' = L D L^T (A' symmetric: its U is D L^T to rounding)
        self._d = lu.U.diagonal()
        del lu
        self._L21 = L[k:, :k].tocsr()
        L22 = L[k:, k:]
        tail = (L22 @ sp.diags(self._d[k:]) @ L22.T).toarray() if m else np.zeros((0, 0))
        self._L22 = L22.tocsr()
        self._sweep_L = spla.splu(L, **SUPERLU_OPTIONS)
        del L
        super().__init__(n, gamma, tail[np.ix_(rows, cols)])

    @property
    def memory(self):
        parts = (self._sweep_L, self._L21, self._L22)
        return None if self._sweep_L is None else 12 * sum(int(x.nnz) for x in parts) + 8 * len(self._d)

    def free(self):
        self._sweep_L = None

    def _permuted(self, rhs):                    # b' = Pr b[order] (a vector or columns)
        b = np.asarray(rhs, dtype=float)
        bp = np.empty_like(b)
        bp[self._perm_r] = b[self.perm]
        return bp

    def _unpermuted(self, y):                    # x over the dofs from y = Pc^T x[order]
        x = np.empty_like(y)
        x[self.perm] = y[self._perm_c]
        return x

    def solve(self, rhs):
        z = self._sweep_L.solve(self._permuted(rhs))
        return self._unpermuted(self._sweep_L.solve(z / self._d.reshape((-1,) + (1,) * (z.ndim - 1)), trans="T"))

    def forward(self, rhs):
        z = self._sweep_L.solve(self._permuted(rhs))             # z = L^{-1} b'
        return Forward((self._L22 @ z[self.n - len(self.gamma):])[self._rows], z)

    def backward(self, fwd, v):
        z, k = fwd.state, self.n - len(self.gamma)
        y = np.zeros_like(z)
        y[k:][self._cols] = v                                    # y_G = Pc^T v
        d = self._d[:k].reshape((-1,) + (1,) * (z.ndim - 1))
        y[:k] = z[:k] / d - self._L21.T @ y[k:]                  # L11^T y_I = D11^{-1} z_I - L21^T y_G
        y[:k] = self._sweep_L.solve(np.concatenate([y[:k], np.zeros_like(y[k:])]), trans="T")[:k]
        x = self._unpermuted(y)
        x[self.gamma] = v
        return x


# --------------------------------------------------------------------------------------------- PARDISO

_LIB = None
_LIB_ERROR = ""
_LOCK = threading.Lock()


def _candidates():
    names = {"linux": ["libmkl_rt.so.3", "libmkl_rt.so.2", "libmkl_rt.so"],
             "darwin": ["libmkl_rt.3.dylib", "libmkl_rt.2.dylib", "libmkl_rt.dylib"],
             "win32": ["mkl_rt.3.dll", "mkl_rt.2.dll", "mkl_rt.dll"]}.get(sys.platform, ["libmkl_rt.so"])
    dirs = [os.path.join(p, sub) for p in dict.fromkeys([sys.prefix, sys.base_prefix, sys.exec_prefix])
            for sub in ("lib", os.path.join("Library", "bin"), "bin")]
    out = [os.path.join(d, n) for d in dirs for n in names]
    out += sorted(glob.glob(os.path.join(sys.prefix, "lib", "libmkl_rt.so*")), reverse=True)
    found = ctypes.util.find_library("mkl_rt")
    if found:
        out.append(found)
    return [p for p in dict.fromkeys(out) if os.path.sep not in p or os.path.exists(p)]


def _load():
    """libmkl_rt with the LP64 interface, or None (the reason in ``_LIB_ERROR``)."""
    global _LIB, _LIB_ERROR
    with _LOCK:
        if _LIB is not None or _LIB_ERROR:
            return _LIB
        # Intel's OpenMP threads spin 200 ms after each parallel region by default; on a few cores they then
        # starve the BLAS threads of the dense interface work that follows each PARDISO call (measured at
        # 1.6e5 unknowns on 2 cores: the 241 x 241 Cholesky of Sigma after the factorisation took 0.06-0.15 s
        # instead of < 1 ms). Sleep at once unless the user chose otherwise (read when OpenMP starts).
        os.environ.setdefault("KMP_BLOCKTIME", "0")
        env = os.environ.get("CVXCONTACT_MKL_RT")
        for path in ([env] if env else []) + _candidates():
            try:
                lib = ctypes.CDLL(path)
                lib.pardiso, lib.pardisoinit
            except (OSError, AttributeError):
                continue
            fn = getattr(lib, "MKL_Set_Interface_Layer", None)
            if fn is not None:
                fn.restype = ctypes.c_int
                if fn(ctypes.c_int(0)) != 0:            # 0 = LP64: 32-bit MKL_INT, as below
                    continue
            p = ctypes.c_void_p
            lib.pardiso.restype = None
            lib.pardiso.argtypes = [p] * 16
            lib.pardisoinit.restype = None
            lib.pardisoinit.argtypes = [p] * 3
            if hasattr(lib, "MKL_Set_Num_Threads_Local"):      # else MKL's own setting is used
                lib.MKL_Set_Num_Threads_Local.restype = ctypes.c_int
                lib.MKL_Set_Num_Threads_Local.argtypes = [ctypes.c_int]
            if hasattr(lib, "MKL_Get_Max_Threads"):
                lib.MKL_Get_Max_Threads.restype = ctypes.c_int
                lib.MKL_Get_Max_Threads.argtypes = []
            _LIB = lib
            return _LIB
        _LIB_ERROR = "libmkl_rt (Intel oneMKL) was not found"
        return None


def pardiso_available() -> bool:
    """Whether Intel oneMKL PARDISO can be loaded (``pip install "cvxcontact[pardiso]"``)."""
    return _load() is not None


def resolve(kind: str) -> str:
    """The adapter ``kind`` runs: "auto" -> "pardiso" if available, else "superlu"."""
    if kind not in FACTORIZATIONS:
        raise SolverError(f"factorization must be one of {FACTORIZATIONS}, got {kind!r}")
    if kind == "auto":
        return "pardiso" if pardiso_available() else "superlu"
    if kind == "pardiso" and not pardiso_available():
        raise SolverError(f"factorization='pardiso' needs Intel oneMKL (libmkl_rt), which was not found: "
                          f'{PARDISO_INSTALL} (x86-64), or use factorization="superlu"')
    return kind


def _threads(threads):
    """The thread count for MKL: ``threads``, else MKL_NUM_THREADS / OMP_NUM_THREADS read now (the sweep
    workers set them after MKL may already be loaded), else 0 (MKL's default: all cores)."""
    if threads is not None:
        return int(threads)
    for k in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        try:
            n = int(os.environ.get(k, "").split(",")[0])
        except ValueError:
            continue
        if n > 0:
            return n
    return 0


def _cnr_threads(lib, threads: int) -> int:
    """PARDISO's iparm[33] for a call on ``threads`` MKL threads (0: MKL's own count, asked now): that count, which
    puts PARDISO in its conditional numerical reproducibility mode (CNR): one input, one answer bit for bit, run
    after run at that thread count on one machine. Without it, on 2 threads, the single right-hand-side solves
    (phase 33) of one factor gave different bits from run to run (benchmarks/pardiso_cnr.py: up to 4 distinct answers
    in 6 runs of thin_layer(200)'s K(A), 2 in most; 1 with CNR). CNR needs the sequential METIS order (iparm[1] = 2,
    not 3)."""
    if threads <= 0 and hasattr(lib, "MKL_Get_Max_Threads"):
        threads = lib.MKL_Get_Max_Threads()
    return max(int(threads), 1)


_ERRORS = {-1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
           -4: "zero pivot, numerical factorization or iterative refinement problem", -5: "unclassified internal error",
           -6: "reordering failed", -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
           -9: "not enough memory for the out-of-core solver", -10: "error opening out-of-core files",
           -11: "read/write error with out-of-core files", -12: "pardiso_64 called from a 32-bit library",
           -13: "interrupted", -15: "the Schur complement could not be computed"}


def _release(lib, pt, n):
    """Phase -1: release PARDISO's memory of the handle ``pt``."""
    i = lambda v: ctypes.byref(ctypes.c_int32(v))  # noqa: E731
    iparm = np.zeros(64, dtype=np.int32)
    err = ctypes.c_int32(0)
    lib.pardiso(pt.ctypes.data, i(1), i(1), i(-2), i(-1), i(n), None, None, None, None, i(1),
                iparm.ctypes.data, i(0), None, None, ctypes.byref(err))


def _open(obj, lib, n, threads):
    """A PARDISO handle on ``obj`` for a real symmetric indefinite matrix of order ``n`` (mtype -2): the
    internal pointer ``_pt``, ``_iparm`` from pardisoinit, ``_perm`` (zeros), the library and thread count,
    and a finaliser releasing PARDISO's memory (phase -1)."""
    obj.n, obj._lib, obj._nthreads = n, lib, _threads(threads)
    obj._pt = np.zeros(64, dtype=np.int64)
    obj._iparm = np.zeros(64, dtype=np.int32)
    obj._perm = np.zeros(n, dtype=np.int32)
    lib.pardisoinit(obj._pt.ctypes.data, ctypes.byref(ctypes.c_int32(-2)), obj._iparm.ctypes.data)
    obj._finalizer = weakref.finalize(obj, _release, lib, obj._pt, n)


class PardisoFactorization(Factorization):
    """Intel oneMKL PARDISO, real symmetric indefinite, with the Gamma dofs as its Schur block (module
    docstring). Raises :class:`SolverError` on any PARDISO error and on perturbed pivots (iparm[13] > 0: the
    factors would then be of a nearby matrix, and Sigma wrong). ``upper``: S is given as what PARDISO reads, its upper
    triangle in CSR, sorted, every diagonal entry stored (the sparse route's coarse start, coarse.bordered_upper)."""

    name = "pardiso"

    def __init__(self, S, gamma, threads=None, upper: bool = False):
        lib = _load()
        if lib is None:
            raise SolverError(f'factorization="pardiso": {_LIB_ERROR}; {PARDISO_INSTALL}')
        n, m = S.shape[0], len(gamma)
        if m == 0 or m == n:
            raise SolverError("the pardiso adapter needs at least one interior and one contact dof")
        U = S if upper else diagonal_stored(sp.triu(sp.csr_matrix(S), format="coo"), sp.csr_matrix)
        self._a = np.ascontiguousarray(U.data, dtype=np.float64)
        self._ia = np.ascontiguousarray(U.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(U.indices, dtype=np.int32)
        _open(self, lib, n, threads)
        self._perm[gamma] = 1
        ip = self._iparm
        ip[0] = 1                  # iparm set here
        ip[1] = 2                  # nested dissection (METIS) for the interior; sequential, as CNR needs (_cnr_threads)
        ip[7] = 0                  # no iterative refinement: the sweeps are exact triangular solves
        ip[9] = 13                 # pivot perturbation 1e-13 (any perturbation is refused below)
        ip[10] = 0                 # no scaling and no weighted matching: S is quasi-definite
        ip[12] = 0
        ip[17] = 0                 # no reporting of nonzeros (saves a pass)
        ip[26] = 0
        ip[34] = 1                 # 0-based indices
        ip[35] = 1                 # Schur complement of the rows marked in perm, returned densely in x
        self.gamma = gamma
        schur = np.zeros((m, m))                               # row-major from PARDISO (symmetric anyway)
        try:
            self._call(12, None, schur)
            if ip[13] > 0:
                raise SolverError(f"PARDISO perturbed {int(ip[13])} pivot(s) of the body's matrix (n = {n}); the "
                                  'interface stiffness would be wrong: use factorization="superlu"')
        except SolverError:
            self._finalizer()                                  # free PARDISO's memory now
            raise
        super().__init__(n, gamma, schur)

    def _call(self, phase, b, x, nrhs=1):
        lib, i = self._lib, (lambda v: ctypes.byref(ctypes.c_int32(v)))
        err = ctypes.c_int32(0)
        local = self._nthreads and hasattr(lib, "MKL_Set_Num_Threads_Local")
        old = lib.MKL_Set_Num_Threads_Local(self._nthreads) if local else None
        self._iparm[33] = _cnr_threads(lib, self._nthreads if local else 0)
        try:
            lib.pardiso(self._pt.ctypes.data, i(1), i(1), i(-2), i(phase), i(self.n), self._a.ctypes.data,
                        self._ia.ctypes.data, self._ja.ctypes.data, self._perm.ctypes.data, i(nrhs),
                        self._iparm.ctypes.data, i(0), None if b is None else b.ctypes.data,
                        None if x is None else x.ctypes.data, ctypes.byref(err))
        finally:
            if old is not None:
                lib.MKL_Set_Num_Threads_Local(old)
        if err.value != 0:
            raise SolverError(f"PARDISO phase {phase} failed with error {err.value} "
                              f"({_ERRORS.get(err.value, 'unknown')}) on a body matrix of order {self.n}")

    def forward(self, rhs):
        b = np.array(rhs, dtype=np.float64, order="F")
        y = np.zeros_like(b)
        self._iparm[5] = 0                                     # solution in x, b untouched
        self._call(331, b, y, b.shape[1] if b.ndim == 2 else 1)
        return Forward(y[self.gamma].copy(), y)

    def backward(self, fwd, v):
        y = np.array(fwd.state, order="F")                     # the forward sweep, with x_G = v
        y[self.gamma] = v
        x = np.zeros_like(y)
        self._call(333, y, x, y.shape[1] if y.ndim == 2 else 1)
        x[self.gamma] = v
        return x

    def release(self):
        """Free PARDISO's memory now (otherwise when this object is collected)."""
        self._finalizer()

    free = release

    @property
    def memory(self):
        """PARDISO's report (iparm[14]-[16], KB): the larger of the analysis' peak and the factorisation's
        permanent plus numerical memory."""
        ip = self._iparm
        return 1024 * max(int(ip[14]), int(ip[15]) + int(ip[16]))


class PardisoInterior:
    """A plain PARDISO factorisation (real symmetric indefinite, mtype -2, no Schur block; the settings of
    :class:`PardisoFactorization` otherwise) of the interior block S_II of a body's quasi-definite S, for
    :func:`cvxcontact.backends.released.interior_solve`. ``S_upper``: S_II's upper triangle in CSR with every
    diagonal entry stored."""

    def __init__(self, S_upper, threads=None):
        lib = _load()
        if lib is None:
            raise SolverError(f'factorization="pardiso": {_LIB_ERROR}; {PARDISO_INSTALL}')
        self._a = np.ascontiguousarray(S_upper.data, dtype=np.float64)
        self._ia = np.ascontiguousarray(S_upper.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(S_upper.indices, dtype=np.int32)
        _open(self, lib, S_upper.shape[0], threads)
        ip = self._iparm
        ip[0], ip[1], ip[7], ip[9], ip[10], ip[12], ip[17], ip[26], ip[34] = 1, 2, 0, 13, 0, 0, 0, 0, 1
        try:
            self._call(12, None, None)
            if ip[13] > 0:
                raise SolverError(f"PARDISO perturbed {int(ip[13])} pivot(s) of a body's interior block")
        except SolverError:
            self._finalizer()
            raise

    _call = PardisoFactorization._call
    release = PardisoFactorization.release

    def solve(self, b):
        b = np.array(b, dtype=np.float64, order="F")
        x = np.zeros_like(b)
        self._iparm[5] = 0
        self._call(33, b, x, b.shape[1] if b.ndim == 2 else 1)
        return x


class PardisoSymmetric:
    """Intel oneMKL PARDISO on a real symmetric indefinite matrix of FIXED sparsity pattern (the sparse
    route's mixed system, :mod:`cvxcontact.backends.sparse`): the analysis (its own nested-dissection order,
    scaling and weighted matching for the zero diagonal of closed contact rows) is done once, each
    :meth:`factor` is a numeric factorisation of new values, :meth:`solve` a solve (vector or columns).
    ``cost``: (Mflop of a factorisation, nonzeros of the factor) as PARDISO's analysis reports them (None before).

    ``K``: CSC with sorted indices, symmetric, every diagonal entry stored (zeros included). Pivots
    PARDISO perturbs (``perturbed``) make the factor that of a nearby matrix; the caller refines against
    K itself (the sparse route checks every answer's componentwise backward error). ``single``: the factor in
    single precision (PARDISO's iparm[27] = 1; the values and the solves' vectors rounded to float32, the answers
    returned in float64): a factor of K to about 6e-8 relative, which the caller refines against K in double
    (measured, the Hencky route's systems at 103,041 unknowns, one thread: a factorisation 0.095 s against 0.136 s,
    a solve 0.013 s against 0.024 s, residual 1e-7 after one solve and 2e-16 after three refinements).
    ``ordering``: PARDISO's fill-reducing order (iparm[1]), one of :data:`PARDISO_ORDERINGS`: 2 its nested
    dissection (METIS, the default; sequential, as reproducibility needs: :func:`_cnr_threads`), 0 minimum degree (AMD; cheaper to analyse, and on a slender 2D layer less fill:
    :data:`~cvxcontact.backends.sparse.SLENDER_FILL`)."""

    def __init__(self, K, threads=None, single: bool = False, ordering: int = 2):
        lib = _load()
        if lib is None:
            raise SolverError(f'factorization="pardiso": {_LIB_ERROR}; {PARDISO_INSTALL}')
        if isinstance(ordering, bool) or ordering not in PARDISO_ORDERINGS:
            raise SolverError(f"PardisoSymmetric: ordering must be one of {PARDISO_ORDERINGS} (PARDISO's iparm[1]: 2 "
                              f"nested dissection, 0 minimum degree; not 3, which is not reproducible), got {ordering!r}")
        K = K if sp.issparse(K) and K.format == "csc" else sp.csc_matrix(K)     # (a wrapper would view its arrays)
        n = K.shape[0]
        if not K.has_sorted_indices:       # factor() reads the values of every later K in this index order
            raise SolverError("PardisoSymmetric needs K in CSC with sorted indices")
        # every later K's, entry for entry: a read-only pattern that owns its arrays (the sparse route's, shared by
        # its every K(A)) is kept as it is, and a K on the same arrays is read without comparing them (_values)
        self._pattern = tuple(a if not a.flags.writeable and a.flags.owndata else a.copy()
                              for a in (K.indptr, K.indices))
        col = np.repeat(np.arange(n, dtype=K.indices.dtype), np.diff(K.indptr))   # CSC of a symmetric K = CSR of K:
        diagonal = np.flatnonzero(K.indices == col)                  # column j's rows >= j = row j's upper part,
        if len(diagonal) != n or not np.array_equal(col[diagonal], np.arange(n)):     # from its diagonal on
            raise SolverError("PardisoSymmetric needs every diagonal entry of K stored")
        self._upper = np.flatnonzero(K.indices >= col)
        self._ia = np.ascontiguousarray(np.concatenate([[0], np.cumsum(K.indptr[1:] - diagonal)]), dtype=np.int32)
        self._ja = np.ascontiguousarray(K.indices[self._upper], dtype=np.int32)
        self.single, self._real = bool(single), np.float32 if single else np.float64
        self._a = np.ascontiguousarray(K.data[self._upper], dtype=self._real)
        self.perturbed, self._analysed = 0, False
        _open(self, lib, n, threads)
        ip = self._iparm
        ip[0] = 1
        ip[1] = int(ordering)      # 2: nested dissection (METIS); 0: minimum degree (AMD)
        ip[7] = 0                  # the caller refines
        ip[9] = 8                  # pivot perturbation 1e-8 (counted in ``perturbed``)
        ip[10] = 1                 # symmetric scaling and weighted matching: saddle-point rows
        ip[12] = 1
        ip[17] = -1                # report the factor's nonzeros and its factorisation's Mflop (``cost``)
        ip[18] = -1
        ip[26] = 0
        ip[27] = int(self.single)  # 1: single precision (the values, factors and solves' vectors in float32)
        ip[34] = 1                 # 0-based indices
        self.cost = None

    _call = PardisoFactorization._call

    @property
    def fill(self) -> float | None:
        """The factor's nonzeros over the stored entries of K's upper triangle, as the analysis reports them (None
        before it): how much the ordering fills in."""
        return None if self.cost is None else self.cost[1] / max(len(self._ja), 1)

    def _values(self, K, what):
        """Take ``K``'s values in the analysed pattern's order; SolverError if its stored entries (CSC, in their
        order) are not exactly those of the matrix given at construction (the same count in another pattern would
        otherwise be read in the wrong places: a factor of another matrix)."""
        K = K if sp.issparse(K) and K.format == "csc" else sp.csc_matrix(K)     # (a wrapper would view its arrays)
        indptr, indices = self._pattern
        same = K.shape == (self.n, self.n) and all(a is b or np.array_equal(a, b) for a, b in
                                                    ((K.indptr, indptr), (K.indices, indices)))
        if not same:
            raise SolverError(f"PardisoSymmetric.{what}: K's pattern differs from the analysed one (the same stored "
                              "entries in the same CSC order are needed; a new PardisoSymmetric for another pattern)")
        if self.single:
            self._a[:] = K.data[self._upper]
        else:                                                         # (in place; indices all valid: clip is moot)
            np.take(K.data, self._upper, out=self._a, mode="clip")

    def analyse(self, K):
        """The analysis alone (PARDISO's phase 11: ordering, symbolic factorisation, and the scaling and weighted
        matching computed from ``K``'s values), kept for every later :meth:`factor`, which is then numeric only;
        no factor is made of ``K`` itself (saves a numeric factorisation where ``K`` is not solved with). Only
        before the first :meth:`factor`; self."""
        if self._analysed:
            raise SolverError("PardisoSymmetric.analyse: already analysed (a new handle analyses afresh)")
        self._values(K, "analyse")
        self._call(11, None, None)
        self.cost = (float(self._iparm[18]), float(self._iparm[17]))     # (factor Mflop, factor nonzeros)
        self._analysed = True
        return self

    def factor(self, K):
        """Numeric factorisation of ``K`` (same pattern as at construction; analysed on ``K`` itself unless
        :meth:`analyse` came first); self."""
        self._values(K, "factor")
        self._call(22 if self._analysed else 12, None, None)
        if not self._analysed:     # (factor Mflop, factor nonzeros) of the analysis
            self.cost = (float(self._iparm[18]), float(self._iparm[17]))
        self._analysed = True
        self.perturbed = int(self._iparm[13])
        return self

    def solve(self, b):
        b = np.asarray(b, dtype=self._real, order="F")      # (read only: iparm[5] = 0, the solution in x)
        x = np.zeros_like(b)
        self._iparm[5] = 0
        self._call(33, b, x, b.shape[1] if b.ndim == 2 else 1)
        return x.astype(np.float64, copy=False)

    def release(self):
        """Free PARDISO's memory now (otherwise when this object is collected)."""
        self._finalizer()


def factorize(S, gamma, kind: str = "auto", *, order: np.ndarray | None = None,
              threads: int | None = None) -> Factorization:
    """Factorise the symmetric quasi-definite ``S`` (sparse, n x n, dimensionless) with the dofs ``gamma``
    (sorted indices) as its Schur block.

    ``kind``: one of :data:`FACTORIZATIONS`. ``order``: for ``superlu``, a fill-reducing permutation of the
    dofs ending with ``gamma`` (default: ``gamma`` last, the rest in their order). ``threads``: MKL threads
    for ``pardiso`` (default: MKL_NUM_THREADS / OMP_NUM_THREADS if set, else MKL's default, all cores).
    Returns a :class:`Factorization` (``.schur`` = Sigma, ``.solve``, ``.forward`` / ``.backward``).
    """
    kind = resolve(kind)
    gamma = np.asarray(gamma, dtype=np.int64)
    if len(gamma) and (np.any(np.diff(gamma) <= 0) or gamma[0] < 0 or gamma[-1] >= S.shape[0]):
        raise SolverError("gamma must be sorted, distinct dof indices of S")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or threads < 1):
        raise SolverError(f"threads must be a positive integer, got {threads!r}")
    if kind == "pardiso":
        return PardisoFactorization(S, gamma, threads)
    if order is None:
        rest = np.ones(S.shape[0], dtype=bool)
        rest[gamma] = False
        order = np.concatenate([np.flatnonzero(rest), gamma])
    return SuperLUFactorization(S, gamma, np.asarray(order))
