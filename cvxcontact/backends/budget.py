"""When the condensed route frees each body's factorisation after taking its interface stiffness (a memory budget).

The condensed route (:mod:`cvxcontact.backends.condensed`) factorises each body's quasi-definite S with its
contact (Gamma) dofs as a Schur block and keeps the factors for the forward and backward sweeps of every load
case. Between the Schur complements and the final back-substitution only Sigma (dense, m x m) and the interface
program are needed, so where memory is short each body's factors are freed right after its Sigma and its load's
forward sweep are taken (:class:`~cvxcontact.backends.released.Released`), and the back-substitution re-makes one
body's interior factorisation at a time: the peak is then the larger of one body's factorisation and the interface
program, not their sum. Such a body keeps no |K| values for the checks either (8 bytes per stored entry a re-solve
would keep otherwise, :meth:`~cvxcontact.discrete.blocks.Block.keep_no_abs`). Small scenes keep their factors
(re-solves reuse them at today's speed).

The decision is measured, not guessed: after body k's factorisation, with M_k the bytes its factors hold (PARDISO's
own report, iparm[14]-[16]) and A the machine's available memory now (``MemAvailable`` of /proc/meminfo), the
factors are freed if what follows does not fit in :data:`SAFETY` A:

    sum_{j > k} M_k nnz(S_j) / nnz(S_k)  +  INTERFACE_BYTES sum_l m_l^2  >  SAFETY A

(the later bodies' factorisations scaled by their matrices' nonzeros, the interface program by the entries of the
Sigma_l). Where either number is unknown (SuperLU on a platform without /proc/meminfo, say) everything is kept.
In a container the machine's ``MemAvailable`` is the host's: the room left under the process's control-group
memory limits (:func:`cgroup_room`) bounds A where a limit is set.
:data:`RELEASE` forces the choice (tests, benchmarks).
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["INTERFACE_BYTES", "RELEASE", "SAFETY", "Budget", "cgroup_room", "mem_available"]

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

CGROUP = "/sys/fs/cgroup"
"""Where the control groups are mounted (cgroup v2; v1's memory controller under ``memory/``)."""

PROC_CGROUP = "/proc/self/cgroup"
"""The process's control groups (lines ``hierarchy:controllers:path``)."""


def mem_available() -> int | None:
    """The memory available to this process in bytes: the machine's (``MemAvailable`` of /proc/meminfo), at most
    the room left under its control-group limits (:func:`cgroup_room`); None where neither can be read."""
    machine = None
    try:
        with open(MEMINFO) as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    machine = 1024 * int(line.split()[1])
                    break
    except (OSError, ValueError, IndexError):
        machine = None
    room = cgroup_room()
    known = [a for a in (machine, room) if a is not None]
    return min(known) if known else None


def _read(path) -> str | None:
    try:
        with open(path) as f:
            return f.read().strip()
    except OSError:
        return None


def cgroup_room() -> int | None:
    """Bytes left under the memory limits of the process's control group and of each group above it (cgroup v2:
    ``memory.max`` - ``memory.current``; v1: ``memory.limit_in_bytes`` - ``memory.usage_in_bytes``), the least
    of them; None where no limit is set ("max") or none can be read (no control groups: another platform)."""
    groups = []                                                  # (directory, limit file, usage file)
    for line in (_read(PROC_CGROUP) or "").splitlines():
        hierarchy, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        parts = [p for p in path.split("/") if p]
        if hierarchy == "0" and not controllers:                 # v2: the unified hierarchy
            files, root = ("memory.max", "memory.current"), CGROUP
        elif "memory" in controllers.split(","):                 # v1: the memory controller's hierarchy
            files, root = ("memory.limit_in_bytes", "memory.usage_in_bytes"), os.path.join(CGROUP, "memory")
        else:
            continue
        groups += [(os.path.join(root, *parts[:i]), *files) for i in range(len(parts), -1, -1)]
    room = []
    for directory, limit, usage in groups:
        lim, used = _read(os.path.join(directory, limit)), _read(os.path.join(directory, usage))
        try:
            if lim is not None and used is not None and lim != "max":
                room.append(max(int(lim) - int(used), 0))
        except ValueError:
            continue
    return min(room) if room else None


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

    def release(self, memory: int | None, possible: bool = True) -> bool:
        """Whether to free the factors of the next body, ``memory`` the bytes they hold (None: unknown).
        ``possible``: False for a body whose factors are not freed whatever the memory (no Gamma dofs, or only
        Gamma dofs): its turn is taken (the later bodies are read as later), False returned."""
        k, self.k = self.k, self.k + 1
        if not possible:
            return False
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
