"""Shared pieces of the studies: graded meshes, tables, figures, transfer between meshes."""

from __future__ import annotations

import csv
import time
import warnings
from pathlib import Path

import numpy as np

from ...geometry.generators import graded_block  # noqa: F401  (moved to the geometry layer; kept importable here)
from ...geometry.mesh import Mesh, rectangle  # noqa: F401
from ...errors import ResidualWarning
from ...io.output import atomic_write


DEGREES = (1, 2)
"""The element degrees a study compares (data: each is ``space(degree, cell)``, which answers its label, trace and
order)."""


def solve_quietly(scene, condition, **options):
    """``ContactSolver(scene, condition, **options).solve()`` without the ResidualWarning: the studies
    record the checks themselves (``sol.ok``, ``sol.residuals()``). The P2 conic condition ends at the
    interior point's complementarity (about 1e-6, docs/formulation.md §8), which can exceed tol."""
    from ...solve import ContactSolver

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        return ContactSolver(scene, condition, **options).solve()


def write_csv(path, rows):
    """Write a list of dicts as CSV (atomic); the columns are the union of the keys, in order."""
    keys = list(dict.fromkeys(k for r in rows for k in r))

    def write(p):
        with open(p, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)

    return atomic_write(path, write)


def write_text(path, text):
    return atomic_write(path, lambda p: Path(p).write_text(text))


def save_figure(fig, path):
    import matplotlib.pyplot as plt

    atomic_write(path, lambda p: fig.savefig(p, dpi=130, format="png"))
    plt.close(fig)
    return path


def markdown_table(rows, columns, formats=None):
    """A Markdown table of ``rows`` (dicts) with the given columns and format strings."""
    formats = formats or {}
    head = "| " + " | ".join(columns) + " |\n|" + "---|" * len(columns) + "\n"
    body = "".join("| " + " | ".join(format(r[c], formats.get(c, "")) if c in r and r[c] is not None else "—"
                                     for c in columns) + " |\n" for r in rows)
    return head + body


def slope(h, e):
    """Least-squares slope of log e against log h (the observed rate)."""
    h, e = np.asarray(h, float), np.asarray(e, float)
    ok = (e > 0) & np.isfinite(e)
    return float(np.polyfit(np.log(h[ok]), np.log(e[ok]), 1)[0]) if ok.sum() >= 2 else float("nan")


class Timer:
    def __init__(self):
        self.t0 = time.perf_counter()

    def __call__(self):
        return time.perf_counter() - self.t0


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
