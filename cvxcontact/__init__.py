"""cvxcontact: frictionless contact of piezoelectric bodies as convex programs.

Layers (imports flow one way, tests/test_layers.py): geometry -> contact -> physics -> fem ->
discrete -> backends -> solution -> solve -> model -> adapt -> io -> apps. See docs/architecture.md.

    >>> import cvxcontact as cc
    >>> m1 = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=4)
    >>> sol = cc.solve(scene, condition="gamma3")          # doctest: +SKIP

See the README for the full quickstart and the paper's notation mapped to these names.

The public names are imported on first use (PEP 562), so that ``cvxcontact --help`` and
``--version`` start without importing NumPy, SciPy or CVXPY.
"""

import logging as _logging
import sys as _sys
from importlib import import_module
from types import ModuleType as _ModuleType
from typing import TYPE_CHECKING

_logging.getLogger(__name__).addHandler(_logging.NullHandler())   # the library prints nothing (logging)

_WHERE = {
    "materials": (".physics", "materials"), "CONDITIONS": (".contact.interface", "CONDITIONS"),
    "CvxContactError": (".errors", None), "MaterialError": (".errors", None), "MeshError": (".errors", None),
    "ResidualWarning": (".errors", None), "ResolutionWarning": (".errors", None), "FixedPointWarning": (".errors", None), "NonUniqueWarning": (".errors", None),
    "OverlapWarning": (".errors", None), "SceneError": (".errors", None),
    "SolverError": (".errors", None),
    "Mesh": (".geometry.mesh", None), "read_mesh": (".geometry.mesh", None), "rectangle": (".geometry.mesh", None),
    "Body": (".physics.scene", None), "Scene": (".physics.scene", None),
    "Finish": (".solution.info", None), "Route": (".solution.info", None), "SolveInfo": (".solution.info", None),
    "Status": (".solution.info", None),
    "ContactResult": (".solve", None), "ContactSolver": (".solve", None), "Solution": (".solve", None),
    "solve": (".solve", None), "Model": (".model", None), "error_bound": (".solution.bound", None),
    "adapt": (".adapt", None), "Adapted": (".adapt", None), "AdaptStep": (".adapt", None),
    "force_estimate": (".goal", None), "ForceEstimate": (".goal", None),
    "Contact": (".physics.pairs", None), "Rigid": (".physics.pairs", None),
    "graded_block": (".geometry.generators", None), "half_disk": (".geometry.generators", None),
    "TetMesh": (".geometry.tetmesh", None), "QuadMesh": (".geometry.quadmesh", None), "HexMesh": (".geometry.hexmesh", None), "box": (".geometry.generators3d", None),
    "cylinder": (".geometry.generators3d", None),
    "UnsupportedError": (".errors", None), "FrozenError": (".errors", None), "Signorini": (".contact.laws", None), "NormalCompliance": (".contact.laws", None),
    "Tresca": (".contact.laws", None),
    "Coulomb": (".contact.laws", None),
    "load_sweep": (".apps.sweep.load", None), "SweepResults": (".apps.sweep.load", None),
    "SweepResultsError": (".errors", None), "CaseArrays": (".apps.sweep.load", None),
}

__all__ = [
    "materials", "CONDITIONS",
    "Mesh", "QuadMesh", "HexMesh", "rectangle", "read_mesh", "graded_block", "half_disk", "TetMesh", "box", "cylinder",
    "Body", "Scene", "Contact", "Rigid", "Signorini", "NormalCompliance", "Tresca", "Coulomb",
    "solve", "error_bound", "force_estimate", "ForceEstimate", "adapt", "Adapted", "AdaptStep", "ContactSolver", "Solution", "ContactResult", "Model", "SolveInfo", "Status", "Route", "Finish",
    "CvxContactError", "MeshError", "MaterialError", "SceneError", "SolverError", "ResidualWarning", "ResolutionWarning", "FixedPointWarning",
    "NonUniqueWarning", "OverlapWarning", "UnsupportedError", "FrozenError", "load_sweep", "SweepResults", "SweepResultsError",
    "CaseArrays",
]


def __getattr__(name):
    if name == "__version__":            # pyproject.toml's (cvxcontact.version); computed on first use
        value = globals()[name] = import_module(".version", __name__).version()
        return value
    if name not in _WHERE:
        raise AttributeError(f"module 'cvxcontact' has no attribute {name!r}")
    module, attr = _WHERE[name]
    value = getattr(import_module(module, __name__), attr or name)
    globals()[name] = value              # cached: the next access is a plain attribute
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__) | {"__version__"})


class _Package(_ModuleType):
    """The package module: importing the submodule ``cvxcontact.solve`` (``cvxcontact.adapt``) must not replace
    the function ``cvxcontact.solve`` (``cvxcontact.adapt``; the eager ``from .solve import solve`` used to rebind
    it; now done here)."""

    def __setattr__(self, name, value):
        if name in ("solve", "adapt") and isinstance(value, _ModuleType):
            value = getattr(value, name)
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, imported eagerly
    from .contact.interface import CONDITIONS
    from .contact.laws import Coulomb, NormalCompliance, Signorini, Tresca
    from .errors import (CvxContactError, FixedPointWarning, FrozenError, MaterialError, MeshError, NonUniqueWarning,
                         OverlapWarning, ResidualWarning, ResolutionWarning, SceneError, SolverError,
                         SweepResultsError, UnsupportedError)
    from .physics.pairs import Contact, Rigid
    from .geometry.generators import graded_block, half_disk
    from .apps.sweep.load import CaseArrays, SweepResults, load_sweep
    from .geometry.generators3d import box, cylinder
    from .geometry.mesh import Mesh, read_mesh, rectangle
    from .geometry.hexmesh import HexMesh
    from .geometry.quadmesh import QuadMesh
    from .geometry.tetmesh import TetMesh
    from .model import Model
    from .physics import materials
    from .physics.scene import Body, Scene
    from .solution.info import Finish, Route, SolveInfo, Status
    from .solve import ContactResult, ContactSolver, Solution, solve
    from .adapt import Adapted, AdaptStep, adapt

    __version__: str
