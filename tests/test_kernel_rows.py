"""The well-posedness check's memory with many contact rows on one coupled group (cvxcontact/fem/kernel.py
``_decide``): its SVD asks for the right singular vectors only as wide as needed; full_matrices=True also formed
the r x r left ones (8e3 contact rows: 0.5 GB, 1e5 rows: 74.5 GiB refused by numpy)."""

import tracemalloc

import numpy as np

from cvxcontact.fem import kernel


def test_many_rows_on_one_kernel_direction_stay_small():
    """4000 rows pushing on one translation (a body on a floor, held only by it), its load pressing it on (work
    +1 along the rows' direction): no direction left free, and the check's peak is far below r^2 floats."""
    r = 4000
    A = np.ones((r, 1))
    tracemalloc.start()
    try:
        verdict = kernel._decide(A, np.array([1.0]))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert verdict is None
    assert peak < 8 * r * r / 10        # 12.8 MB; measured 1.1 MB (the linear programs), 129 MB before (r^2)
