"""Backends: the ways a discrete problem is solved.

``full``       the phi-form convex program of every body in CVXPY (the reference; accepts everything)
``condensed``  each body condensed exactly onto its contact unknowns, a small interface QP in CVXPY
``finish``     the exact finish: the interface LCP solved by scaled active-set steps (NNLS fallback)
``options``    validation of solver names and options before anything is assembled
"""

METHODS = ("full", "condensed")
"""Backend names accepted by :func:`cvxcontact.solve` (``method=``)."""

__all__ = ["METHODS"]
