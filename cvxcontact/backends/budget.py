"""When the condensed route frees each body's factorisation after taking its interface stiffness (a memory budget).

The condensed route (:mod:`cvxcontact.backends.condensed`) factorises each body's quasi-definite S with its
contact (Gamma) dofs as a Schur block and keeps the factors for the forward and backward sweeps of every load
case. Between the Schur complements and the final back-substitution only Sigma (dense, m x m) and the interface
program are needed, so where memory is short each body's factors are freed right after its Sigma and its load's
forward sweep are taken (:class:`~cvxcontact.backends.factor.Released`), and the back-substitution re-makes one
body's interior factorisation at a time: the peak is then the larger of one body's factorisation and the interface
program, not their sum. Small scenes keep their factors (re-solves reuse them at today's speed).

The decision is measured, not guessed: after body k's factorisation, with M_k the bytes its factors hold (PARDISO's
own report, iparm[14]-[16]) and A the machine's available memory now (``MemAvailable`` of /proc/meminfo), the
factors are freed if what follows does not fit in :data:`SAFETY` A:

    sum_{j > k} M_k nnz(S_j) / nnz(S_k)  +  INTERFACE_BYTES sum_l m_l^2  >  SAFETY A

(the later bodies' factorisations scaled by their matrices' nonzeros, the interface program by the entries of the
Sigma_l). Where either number is unknown (SuperLU on a platform without /proc/meminfo, say) everything is kept.
:data:`RELEASE` forces the choice (tests, benchmarks).
"""

from __future__ import annotations

import numpy as np

__all__ = ["INTERFACE_BYTES", "RELEASE", "SAFETY", "Budget", "mem_available"]

RELEASE: bool | None = None
"""None: decide by the memory budget (module docstring); True: always free the factors; False: never (the
behaviour before the budget existed). Read at each condensation."""

SAFETY = 0.75
"""The fraction of the available memory the rest of a solve may plan to use with the factors kept."""

INTERFACE_BYTES = 250
"""Bytes per entry of the Sigma_l that the interface program and the exact finish take above the factorisations
(CVXPY's compilation, Clarabel and the finish's kept block; measured on two elastic boxes,
benchmarks/results/bench_gamma3_scale.md: 162 bytes per entry at 1.4e5 unknowns, 116 at 3.1e5; 250 for margin)."""

MEMINFO = "/proc/meminfo"


def mem_available() -> int | None:
    """The machine's available memory in bytes (``MemAvailable`` of /proc/meminfo), None where it cannot be read."""
    try:
        with open(MEMINFO) as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return 1024 * int(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None


class Budget:
    """The decision of :data:`RELEASE` for the bodies of one condensation, in the order they are factorised.

    Parameters
    ----------
    nnz : sequence of int
        The nonzeros of each body's S (any consistent measure of its factorisation's size).
    gamma : sequence of int
        Each body's count m_l of Gamma dofs (Sigma_l is m_l x m_l).
    """

    def __init__(self, nnz, gamma):
        self.nnz = [max(int(n), 1) for n in nnz]
        self.interface = INTERFACE_BYTES * float(sum(int(m) ** 2 for m in gamma))
        self.k = 0
        self.released = 0

    def release(self, memory: int | None) -> bool:
        """Whether to free the factors of the next body, ``memory`` the bytes they hold (None: unknown)."""
        k, self.k = self.k, self.k + 1
        if RELEASE is not None:
            out = bool(RELEASE)
        else:
            avail = mem_available()
            if memory is None or avail is None:
                return False
            later = memory * float(np.sum(self.nnz[k + 1:])) / self.nnz[k]
            out = later + self.interface > SAFETY * avail
        self.released += out
        return out
