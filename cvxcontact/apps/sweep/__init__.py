"""Reference-solution generator: many cases from one scene file, resumable, verified, identified by content.

A sweep file (TOML) names a base scene file and the cases, as overrides of its keys::

    scene = "two_blocks.toml"              # relative to the sweep file
    method = "auto"                        # optional (default "auto"): see cvxcontact.solve
    conditions = ["gamma3", "sigma1"]      # optional (default: the scene file's condition)

    [grid]                                 # optional: every point of the cartesian product
    "body[0].body_force[1]" = [-1e9, -2e9]
    "body[0].mesh.rectangle.nx" = [8, 16]

    [[case]]                               # optional: one more case, the base scene + these overrides
    name = "heavy"
    "body[0].body_force" = [0.0, -5e9]

runs the 4 grid points and the case "heavy" (a ``[[case]]`` is not combined with the grid),
each under both conditions: 10 cases. See :mod:`.spec` (meaning, validation, ids; ``read_sweep``
reads a sweep file), :mod:`.store` (files, verification on resume, lock), :mod:`.worker` (one case,
retry ladder), :mod:`.driver` (scheduling, interrupts, worker faults), :mod:`.load` (``load_sweep``:
the results as a table and arrays with units), :mod:`.export` (XDMF + HDF5).

Cases that differ only in loads (:data:`cvxcontact.physics.loads.LOAD_FIELDS` of a body,
``SCENE_LOAD_FIELDS`` of the scene: the gap) share a :class:`~cvxcontact.solve.ContactSolver`
inside a worker, so they reuse its factorisations.
"""

from .driver import SweepReport, main_progress, run_chunk, run_sweep
from .load import CaseArrays, SweepResults, SweepResultsError, load_sweep
from .spec import Case, SweepError, apply_overrides, read_sweep
from .store import SweepLockedError, SweepOutputError

__all__ = ["Case", "SweepError", "SweepOutputError", "SweepLockedError", "read_sweep", "run_sweep", "SweepReport",
           "apply_overrides", "main_progress", "run_chunk", "load_sweep", "SweepResults", "CaseArrays",
           "SweepResultsError"]
