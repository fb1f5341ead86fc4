"""SciPy's SuperLU on structurally singular matrices: a minimal reproducer (no cvxcontact code involved).

``scipy.sparse.linalg.splu`` on a square matrix whose structural rank is below its order (here the saddle
matrices of tests/matrices.py: m constraint rows on m - 1 unknowns) makes BLAS calls with illegal sizes,
which OpenBLAS's xerbla reports on standard output ("On entry to DGEMV parameter number 2 had an illegal
value", "On entry to DTRSV parameter number 6 ...") and then skips; the factorisation then stops with an
error, or RETURNS factors whose pivots are rounding (no error, no message: a solve off by ~1e17). The input is
legal (a singular matrix should give "Factor is exactly singular"). cvxcontact refuses such matrices before
SuperLU (``cvxcontact.backends.factor.structurally_nonsingular``).

    python benchmarks/superlu_structurally_singular.py            # results/superlu_structurally_singular.md
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import structural_rank

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from matrices import surplus_saddle

LIBC = ctypes.CDLL(None)          # (POSIX) to flush C stdio, where xerbla's printf waits when stdout is a file


def superlu_output(K):
    """(lu or None, what SuperLU/BLAS printed on fd 1 and 2, the error or None) of splu(K)."""
    with tempfile.TemporaryFile() as out:
        sys.stdout.flush()
        sys.stderr.flush()
        LIBC.fflush(None)
        saved = [os.dup(1), os.dup(2)]
        os.dup2(out.fileno(), 1)
        os.dup2(out.fileno(), 2)
        try:
            lu, err = spla.splu(K), None
        except RuntimeError as exc:
            lu, err = None, str(exc).strip()
        finally:
            LIBC.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
        out.seek(0)
        return lu, out.read().decode(), err


def main():
    print(f"scipy {scipy.__version__}, numpy {np.__version__}, OPENBLAS_CORETYPE="
          f"{os.environ.get('OPENBLAS_CORETYPE', '(default)')}")
    print("| n, m | order | structural rank | printed | outcome |")
    print("|---|---|---|---|---|")
    for n, m in ((24, 8), (20, 4), (10, 8)):
        K = surplus_saddle(n, m)
        lu, printed, err = superlu_output(K)
        lines = sorted({line.strip() for line in printed.splitlines() if line.strip()})
        said = "; ".join(f"{line} (x{printed.count(line)})" for line in lines) or "nothing"
        if lu is not None:
            b = np.ones(K.shape[0])
            x = lu.solve(b)
            err = (f"no error: max|x| = {np.abs(x).max():.1e}, ||K x - b|| / ||b|| = "
                   f"{np.linalg.norm(K @ x - b) / np.linalg.norm(b):.1e}, min |U_ii| = "
                   f"{np.abs(lu.U.diagonal()).min():.1e}")
        print(f"| {n}, {m} | {K.shape[0]} | {structural_rank(K)} | {said} | {err} |")


if __name__ == "__main__":
    main()
